// Servo drive model (see drive.hpp).
#include "postproc/contour/drive.hpp"

#include <array>
#include <cmath>

#include <unsupported/Eigen/MatrixFunctions>

namespace postproc::contour {

std::optional<Drive> drive_of(const machine::AxisSettings& s) {
  if (!s.kv) return std::nullopt;
  Drive d;
  d.kv = *s.kv;
  d.feed_forward = s.feed_forward;
  d.acceleration_feed_forward = s.acceleration_feed_forward;
  d.velocity_loop_time = s.velocity_loop_time.value_or(0.0);
  return d;
}

namespace {

/// The loop's transition over one period depends only on Kv, T and dt: a few drives, one period,
/// so a small per-thread cache saves the matrix exponential on almost every step.
struct Transition {
  double kv = -1, t = -1, dt = -1;
  Eigen::Matrix4d m4 = Eigen::Matrix4d::Zero();
  Eigen::Matrix3d m3 = Eigen::Matrix3d::Zero();
};

const Transition& transition(const Drive& d, double dt) {
  thread_local std::array<Transition, 8> cache;
  thread_local std::size_t next = 0;
  for (const Transition& c : cache)
    if (c.kv == d.kv && c.t == d.velocity_loop_time && c.dt == dt) return c;
  Transition& c = cache[next];
  next = (next + 1) % cache.size();
  c.kv = d.kv;
  c.t = d.velocity_loop_time;
  c.dt = dt;
  const double t = d.velocity_loop_time;
  if (t > 0) {
    // State (y, ẏ, w, ẇ): T·ÿ + ẏ = w − Kv·y with the forcing w linear in time.
    Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
    m(0, 1) = 1;
    m(1, 0) = -d.kv / t;
    m(1, 1) = -1 / t;
    m(1, 2) = 1 / t;
    m(2, 3) = 1;
    c.m4 = (m * dt).exp();
  } else {
    // Ideal velocity loop: ẏ = w − Kv·y.
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    m(0, 0) = -d.kv;
    m(0, 1) = 1;
    m(1, 2) = 1;
    c.m3 = (m * dt).exp();
  }
  return c;
}

}  // namespace

void step(const Drive& d, DriveState& s, double r0, double r1, double a, double dt) {
  const double rdot = (r1 - r0) / dt;
  const double t = d.velocity_loop_time;
  // The loop's forcing w(τ) = Kv·r(τ) + f·ṙ + g·T·a is linear in the time τ within the step, so it
  // joins the state as (w, ẇ) and the whole step is one matrix exponential.
  const double w0 = d.kv * r0 + d.feed_forward * rdot + d.acceleration_feed_forward * t * a;
  const double w1 = d.kv * rdot;
  const Transition& tr = transition(d, dt);
  if (t > 0) {
    const Eigen::Vector4d z = tr.m4 * Eigen::Vector4d(s.y, s.v, w0, w1);
    s.y = z[0];
    s.v = z[1];
  } else {
    const Eigen::Vector3d z = tr.m3 * Eigen::Vector3d(s.y, w0, w1);
    s.y = z[0];
    s.v = z[1] - d.kv * s.y;
  }
}

void velocity_jump(const Drive& d, ErrorState& s, double dw) {
  if (d.velocity_loop_time > 0) s.rate += (1 - d.acceleration_feed_forward) * dw;
}

void propagate(const Drive& d, ErrorState& s, double w, double dt) {
  if (dt <= 0) return;
  const double steady = (1 - d.feed_forward) * w / d.kv;
  const double d0 = s.e - steady;
  const double T = d.velocity_loop_time;
  if (T <= 0) {
    s.e = steady + d0 * std::exp(-d.kv * dt);
    s.rate = -d.kv * (s.e - steady);
    return;
  }
  // The deviation from the steady state solves T·d̈ + ḋ + Kv·d = 0, roots of T·s² + s + Kv.
  const double v0 = s.rate;
  const double disc = 1 - 4 * T * d.kv;
  double dd = 0, dv = 0;
  if (disc > 1e-12) {
    const double r = std::sqrt(disc);
    const double s1 = (-1 + r) / (2 * T), s2 = (-1 - r) / (2 * T);
    const double a = (v0 - s2 * d0) / (s1 - s2), b = d0 - a;
    const double e1 = std::exp(s1 * dt), e2 = std::exp(s2 * dt);
    dd = a * e1 + b * e2;
    dv = a * s1 * e1 + b * s2 * e2;
  } else if (disc < -1e-12) {
    const double al = -1 / (2 * T), be = std::sqrt(-disc) / (2 * T);
    const double c = (v0 - al * d0) / be;
    const double ex = std::exp(al * dt), cs = std::cos(be * dt), sn = std::sin(be * dt);
    dd = ex * (d0 * cs + c * sn);
    dv = al * dd + ex * be * (-d0 * sn + c * cs);
  } else {
    const double al = -1 / (2 * T);
    const double c = v0 - al * d0;
    const double ex = std::exp(al * dt);
    dd = (d0 + c * dt) * ex;
    dv = c * ex + al * dd;
  }
  s.e = steady + dd;
  s.rate = dv;
}

}  // namespace postproc::contour
