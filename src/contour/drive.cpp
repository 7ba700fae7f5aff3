// Servo drive model (see drive.hpp).
#include "postproc/contour/drive.hpp"

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

void step(const Drive& d, DriveState& s, double r0, double r1, double a, double dt) {
  const double rdot = (r1 - r0) / dt;
  const double t = d.velocity_loop_time;
  // The loop's forcing w(τ) = Kv·r(τ) + f·ṙ + g·T·a is linear in the time τ within the step, so it
  // joins the state as (w, ẇ) and the whole step is one matrix exponential.
  const double w0 = d.kv * r0 + d.feed_forward * rdot + d.acceleration_feed_forward * t * a;
  const double w1 = d.kv * rdot;
  if (t > 0) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
    m(0, 1) = 1;
    m(1, 0) = -d.kv / t;
    m(1, 1) = -1 / t;
    m(1, 2) = 1 / t;
    m(2, 3) = 1;
    const Eigen::Matrix4d e = (m * dt).exp();
    const Eigen::Vector4d z = e * Eigen::Vector4d(s.y, s.v, w0, w1);
    s.y = z[0];
    s.v = z[1];
  } else {
    // Ideal velocity loop: ẏ = w − Kv·y.
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    m(0, 0) = -d.kv;
    m(0, 1) = 1;
    m(1, 2) = 1;
    const Eigen::Vector3d z = (m * dt).exp() * Eigen::Vector3d(s.y, w0, w1);
    s.y = z[0];
    s.v = z[1] - d.kv * s.y;
  }
}

}  // namespace postproc::contour
