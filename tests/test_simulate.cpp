// Time-domain simulation (simulate.hpp): the interpolator's commands through the exact per-period
// drive model, the actual poses measured against the intended contour. A circle in lag mode has
// the first-order lag's analytic radial error; a straight line has none though the axes lag.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "contour_support.hpp"
#include "postproc/machine/program_map.hpp"
#include "postproc/contour/path.hpp"
#include "postproc/contour/reference.hpp"
#include "postproc/contour/simulate.hpp"
#include "postproc/error.hpp"
#include "postproc/machine/machine.hpp"

namespace {

namespace ct = postproc::contour;
namespace kin = postproc::kin;
namespace mc = postproc::machine;
namespace gc = postproc::gcode;

constexpr double kPi = kin::kPi;
constexpr double kKv = 30;                 // 1/s, every axis of the machine below
constexpr double kSpeed = 2000.0 / 60.0;   // mm/s (F2000)

using pptest::add_run;
using pptest::circle;
using pptest::empty_path;
using pptest::mill;
using pptest::xyz;

std::vector<kin::JointVector> line(const Eigen::Vector3d& from, const Eigen::Vector3d& to, int n) {
  std::vector<kin::JointVector> qs;
  for (int i = 0; i <= n; ++i) {
    const Eigen::Vector3d q = from + (to - from) * (static_cast<double>(i) / n);
    qs.push_back(xyz(q.x(), q.y(), q.z()));
  }
  return qs;
}

constexpr double kRadius = 50;
const Eigen::Vector3d kCentreQ(100, 50, -20);

/// The tool-tip point of joint position q on the mill.
Eigen::Vector3d tip_of(const Eigen::Vector3d& q) {
  kin::Pose pose;
  EXPECT_TRUE(mill().actual->forward(xyz(q.x(), q.y(), q.z()), pose).ok());
  return pose.p;
}

/// Number of samples the controller's interpolator gives for run r of `p`.
std::uint64_t interpolator_samples(const ct::Path& p, std::size_t r, double settle) {
  std::uint64_t n = 0;
  ct::interpolate(p, p.runs[r], settle, [&](const ct::Sample&) { ++n; });
  return n;
}

/// Radial error of a first-order lag (time constant 1/Kv) following a circle of radius r at
/// speed v: the actual circle has radius r/√(1 + (ωτ)²), ω = v/r.
double lag_circle_error(double r, double v, double kv) {
  const double wt = v / r / kv;
  return r * (1 - 1 / std::sqrt(1 + wt * wt));
}

/// Samples of `sim` (keep_every = 1) in the middle half of [t0, t0 + duration].
std::vector<const ct::SimSample*> middle_half(const ct::Simulation& sim, double t0, double duration) {
  std::vector<const ct::SimSample*> out;
  for (const ct::SimSample& s : sim.kept)
    if (s.t >= t0 + duration / 4 && s.t <= t0 + 3 * duration / 4) out.push_back(&s);
  return out;
}

TEST(Simulate, LagModeCircleHasTheAnalyticRadialError) {
  ct::Path path = empty_path(mill());
  add_run(path, circle(kCentreQ, kRadius, 3600), kSpeed, 10);
  const ct::Reference ref(path, *mill().actual);
  ct::SimulateOptions opt;
  opt.keep_every = 1;
  const ct::Simulation sim = ct::simulate(path, ref, *mill().actual, opt);

  const double expected = lag_circle_error(kRadius, kSpeed, kKv);  // ≈ 12.3 µm
  ASSERT_GT(expected, 0.012);
  ASSERT_LT(expected, 0.0125);
  const double duration = path.duration;
  EXPECT_NEAR(duration, 2 * kPi * kRadius / kSpeed, 1e-3);
  EXPECT_EQ(sim.samples, interpolator_samples(path, 0, opt.settle_s));
  EXPECT_GE(static_cast<double>(sim.samples) * path.period, duration + opt.settle_s);
  ASSERT_EQ(sim.kept.size(), sim.samples);

  const Eigen::Vector3d centre = tip_of(kCentreQ);
  const auto mid = middle_half(sim, 0, duration);
  ASSERT_GT(mid.size(), 4000U);
  double sum = 0;
  for (const ct::SimSample* s : mid) {
    ASSERT_NEAR(s->tip_mm, expected, 0.03 * expected) << s->t;
    // The error is radial: the actual tip is that much inside the circle.
    ASSERT_NEAR(kRadius - (s->tip - centre).norm(), s->tip_mm, 2e-5) << s->t;
    ASSERT_LT(s->axis_rad, 1e-12);
    sum += s->tip_mm;
  }
  EXPECT_NEAR(sum / static_cast<double>(mid.size()), expected, 0.01 * expected);
  std::printf("[ circle   ] radial error %.6f mm (analytic %.6f mm) over %zu samples; max %.6f mm, following %.5f %.5f mm\n",
              sum / static_cast<double>(mid.size()), expected, mid.size(), sim.tip.max, sim.max_following[0],
              sim.max_following[1]);

  // Summaries over every sample: the transient at the start and the stop at the end do not exceed
  // the steady state by much; the worst line is a line of the run.
  EXPECT_EQ(sim.tip.count, sim.samples);
  EXPECT_GE(sim.tip.max, 0.97 * expected);
  EXPECT_LE(sim.tip.max, 1.3 * expected);
  EXPECT_LE(sim.tip.p95, sim.tip.max);
  EXPECT_GE(sim.worst_tip_line, 10U);
  EXPECT_LE(sim.worst_tip_line, 10U + 3600U);
  EXPECT_LT(sim.axis.max, 1e-12);

  // Following error per axis: the lag of a sinusoid of amplitude R, R·ωτ/√(1 + (ωτ)²) ≈ v/Kv.
  const double wt = kSpeed / kRadius / kKv;
  const double following = kRadius * wt / std::sqrt(1 + wt * wt);
  ASSERT_EQ(sim.max_following.size(), 3U);
  EXPECT_NEAR(sim.max_following[0], following, 0.01 * following);
  EXPECT_NEAR(sim.max_following[1], following, 0.01 * following);
  EXPECT_LT(sim.max_following[2], 1e-12);
}

TEST(Simulate, StraightLineLagsWithoutContourError) {
  ct::Path path = empty_path(mill());
  const Eigen::Vector3d from(10, 20, -30), to = from + 200 * Eigen::Vector3d(0.6, 0.8, 0);
  add_run(path, line(from, to, 10), kSpeed, 1);
  const ct::Reference ref(path, *mill().actual);
  const ct::Simulation sim = ct::simulate(path, ref, *mill().actual);
  EXPECT_TRUE(sim.kept.empty());  // keep_every = 0
  EXPECT_GT(sim.samples, 6000U);
  EXPECT_LT(sim.tip.max, 1e-6);
  EXPECT_LT(sim.axis.max, 1e-12);
  const double lag = kSpeed / kKv;  // 1.111 mm
  ASSERT_EQ(sim.max_following.size(), 3U);
  EXPECT_NEAR(std::hypot(sim.max_following[0], sim.max_following[1]), lag, 0.01 * lag);
  EXPECT_NEAR(sim.max_following[0], 0.6 * lag, 0.01 * lag);
  EXPECT_NEAR(sim.max_following[1], 0.8 * lag, 0.01 * lag);
}

TEST(Simulate, RunsFollowEachOtherInTime) {
  ct::Path path = empty_path(mill());
  add_run(path, line(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(30, 0, 0), 3), kSpeed, 1);
  const double first = path.duration;
  add_run(path, circle(kCentreQ, kRadius, 3600), kSpeed, 100);
  const double second = path.duration - first;
  const ct::Reference ref(path, *mill().actual);
  ct::SimulateOptions opt;
  opt.keep_every = 10;
  opt.settle_s = 0.2;
  const ct::Simulation sim = ct::simulate(path, ref, *mill().actual, opt);
  const std::uint64_t n0 = interpolator_samples(path, 0, opt.settle_s), n1 = interpolator_samples(path, 1, opt.settle_s);
  EXPECT_EQ(sim.samples, n0 + n1);
  EXPECT_EQ(sim.kept.size(), (sim.samples + 9) / 10);
  // Every 10th sample, on one time grid across both runs: t = sample index × period.
  for (std::size_t k = 0; k < sim.kept.size(); ++k) {
    ASSERT_NEAR(sim.kept[k].t, static_cast<double>(10 * k) * path.period, 1e-9) << k;
    ASSERT_EQ(sim.kept[k].run, 10 * k < n0 ? 0U : 1U) << k;
  }
  // The second run starts after the first one's moves and settling, at rest on its start point.
  EXPECT_GE(static_cast<double>(n0) * path.period, first + opt.settle_s);
  EXPECT_GE(static_cast<double>(n0 + n1) * path.period, first + second + 2 * opt.settle_s);
  const auto second_run = std::find_if(sim.kept.begin(), sim.kept.end(), [](const ct::SimSample& s) { return s.run == 1; });
  ASSERT_NE(second_run, sim.kept.end());
  EXPECT_GE(second_run->line, 100U);
  EXPECT_GE(sim.worst_tip_line, 100U);  // the circle, not the line
  const double expected = lag_circle_error(kRadius, kSpeed, kKv);
  EXPECT_NEAR(sim.tip.max, expected, 0.3 * expected);
}

TEST(Simulate, ReferenceMayHaveOtherPoints) {
  // The commanded path is the circle in 3600 chords, the intended contour the same circle from
  // 1200 points: the foot is tracked along the reference run from sample to sample.
  ct::Path commanded = empty_path(mill());
  add_run(commanded, circle(kCentreQ, kRadius, 3600), kSpeed, 1);
  ct::Path intended = empty_path(mill());
  add_run(intended, circle(kCentreQ, kRadius, 1200), kSpeed, 1);
  ct::ReferenceOptions ro;
  ro.window = 300;  // several pieces
  ro.overlap = 24;
  const ct::Reference ref(intended, *mill().actual, ro);
  ct::SimulateOptions opt;
  opt.keep_every = 1;
  const ct::Simulation sim = ct::simulate(commanded, ref, *mill().actual, opt);
  const double expected = lag_circle_error(kRadius, kSpeed, kKv);
  const auto mid = middle_half(sim, 0, commanded.duration);
  ASSERT_GT(mid.size(), 4000U);
  for (const ct::SimSample* s : mid) ASSERT_NEAR(s->tip_mm, expected, 0.03 * expected) << s->t;
}

TEST(Simulate, RunCountsMustMatch) {
  ct::Path one = empty_path(mill());
  add_run(one, line(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(10, 0, 0), 2), kSpeed, 1);
  ct::Path two = one;
  add_run(two, line(Eigen::Vector3d(10, 0, 0), Eigen::Vector3d(10, 10, 0), 2), kSpeed, 5);
  const ct::Reference ref(two, *mill().actual);
  try {
    (void)ct::simulate(one, ref, *mill().actual);
    FAIL() << "no error for 1 run against 2";
  } catch (const postproc::Error& e) {
    EXPECT_EQ(e.code(), postproc::ExitCode::usage);
    EXPECT_NE(std::string(e.what()).find("runs"), std::string::npos) << e.what();
  }
}

}  // namespace
