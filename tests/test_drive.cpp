// Servo drive model (issue 6): the closed loop integrated step by step reaches the quasi-static
// following error e₁·ṙ + e₂·r̈ of drive.hpp; lag mode gives document 004's q̇/Kv.
#include <gtest/gtest.h>

#include <cmath>

#include "postproc/contour/drive.hpp"

namespace {

using postproc::contour::Drive;
using postproc::contour::DriveState;

/// Runs a command r(t) = v·t + a·t²/2 for `seconds` at period dt; returns r − y at the end.
double run(const Drive& d, double v, double a, double seconds, double dt = 0.001) {
  DriveState s;
  const int n = static_cast<int>(std::lround(seconds / dt));
  for (int k = 0; k < n; ++k) {
    const double t0 = k * dt, t1 = (k + 1) * dt;
    const double r0 = v * t0 + 0.5 * a * t0 * t0, r1 = v * t1 + 0.5 * a * t1 * t1;
    postproc::contour::step(d, s, r0, r1, a, dt);
  }
  const double t = n * dt;
  return v * t + 0.5 * a * t * t - s.y;
}

TEST(Drive, LagModeFollowingErrorIsVelocityOverKv) {
  Drive d;
  d.kv = 30;
  const double v = 2000.0 / 60.0;  // 2000 mm/min
  EXPECT_NEAR(d.lag(v), v / 30, 1e-15);
  EXPECT_NEAR(run(d, v, 0, 2.0), v / 30, 1e-9);  // e^(−60) of the transient is gone
}

TEST(Drive, FeedForwardAndVelocityLoop) {
  Drive d;
  d.kv = 40;
  d.feed_forward = 0.6;
  d.velocity_loop_time = 0.004;
  const double v = 25;
  EXPECT_NEAR(d.lag(v), 0.4 * v / 40, 1e-15);
  EXPECT_NEAR(run(d, v, 0, 3.0), d.lag(v), 1e-9);
}

TEST(Drive, AccelerationTermMatchesTheLoop) {
  // Constant acceleration: the linear loop's error tends to e₁·ṙ(t) + e₂·a. The interpolator
  // hands the loop chords of the parabola (linear within each period), which lie a·dt²/12 above
  // it on average: that much, no more, separates the two.
  for (double g : {0.0, 0.5}) {
    Drive d;
    d.kv = 25;
    d.feed_forward = 0.3;
    d.acceleration_feed_forward = g;
    d.velocity_loop_time = 0.006;
    const double a = 500, seconds = 3.0;
    EXPECT_NEAR(run(d, 0, a, seconds), d.lag(a * seconds, a), a * 1e-6 / 8) << g;
  }
}

TEST(Drive, StepIsExactForAnyPeriod) {
  // Linear commands (a ramp from rest, with its start transient) are integrated exactly: the same
  // state whatever the period.
  Drive d;
  d.kv = 30;
  d.velocity_loop_time = 0.005;
  EXPECT_NEAR(run(d, 10, 0, 0.2, 0.001), run(d, 10, 0, 0.2, 0.0001), 1e-10);
  EXPECT_GT(std::abs(run(d, 10, 0, 0.05, 0.001) - d.lag(10)), 1e-3);  // still in the transient at 50 ms
  d.velocity_loop_time = 0;
  EXPECT_NEAR(run(d, 10, 0, 0.2, 0.001), run(d, 10, 0, 0.2, 0.0001), 1e-10);
}

TEST(Drive, PropagateMatchesTheLoopForEveryDamping) {
  // The prediction's closed-form error (velocity_jump + propagate) against the integrated loop for
  // a ramp from rest: over-damped, critically damped and oscillating velocity loops, lag mode and
  // feed-forward, after 20 ms and after 200 ms.
  for (double t_loop : {0.0, 0.002, 1.0 / 120.0, 0.02})
    for (double f : {0.0, 0.6})
      for (double g : {0.0, 0.5})
        for (double seconds : {0.02, 0.2}) {
          Drive d;
          d.kv = 30;
          d.velocity_loop_time = t_loop;
          d.feed_forward = f;
          d.acceleration_feed_forward = g;
          postproc::contour::ErrorState e;
          postproc::contour::velocity_jump(d, e, 10.0);
          postproc::contour::propagate(d, e, 10.0, seconds);
          // The loop integrated at a fine period; its acceleration feed-forward sees the start as
          // the interpolator does: the velocity step within the first period (a = Δv/dt there).
          const double dt = 1e-5;
          postproc::contour::DriveState s;
          const int n = static_cast<int>(std::lround(seconds / dt));
          for (int k = 0; k < n; ++k)
            postproc::contour::step(d, s, 10.0 * k * dt, 10.0 * (k + 1) * dt, k == 0 ? 10.0 / dt : 0.0, dt);
          EXPECT_NEAR(e.e, 10.0 * n * dt - s.y, 2e-4) << t_loop << " " << f << " " << g << " " << seconds;
        }
}

}  // namespace
