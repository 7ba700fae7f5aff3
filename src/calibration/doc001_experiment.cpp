// Document 001's simulation experiment (the 3-PRS hybrid-head calibration paper, section 3), for
// the tests and the bench (identify.hpp, namespace doc001).
#include <random>

#include <fmt/format.h>

#include "postproc/calibration/identify.hpp"
#include "postproc/error.hpp"

namespace postproc::cal {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

namespace doc001 {

kin::Pose target(double z, double theta, double phi, double x, double y) {
  kin::Pose p;
  p.p = Vec3(x, y, -z);
  const Vec3 n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
  const Mat3 f = Vec3(1, -1, -1).asDiagonal();
  p.r = f * kin::PrsHybrid::tilt_rotation(n) * f;
  return p;
}

std::vector<kin::Pose> pose_set() {
  std::vector<kin::Pose> out;
  for (double z : {700.0, 800.0, 900.0}) {
    out.push_back(target(z, 0, 0));
    for (int k = 0; k < 8; ++k) out.push_back(target(z, 40 * kin::kDeg, k * 45 * kin::kDeg));
  }
  return out;
}

std::vector<Measurement> simulate(const kin::PrsHybrid& controller, const kin::PrsHybrid& truth,
                                  std::span<const kin::Pose> targets, unsigned seed, bool has_torsion, double noise_mm,
                                  double noise_deg) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Measurement> out;
  for (const kin::Pose& t : targets) {
    Measurement m;
    m.kind = MeasurementKind::pose;
    if (!controller.nominal_inverse(t, m.q).ok()) throw Error(ExitCode::usage, "simulate: a target cannot be commanded");
    if (!truth.forward(m.q, m.measured).ok()) throw Error(ExitCode::usage, "simulate: a commanded pose cannot be reached");
    const Vec3 dp(u(rng), u(rng), u(rng));
    const Vec3 dth(u(rng), u(rng), u(rng));
    m.measured.p += noise_mm * dp;
    const Vec3 w = noise_deg * kin::kDeg * dth;
    if (w.norm() > 0) m.measured.r = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() * m.measured.r;
    m.has_torsion = has_torsion;
    m.label = fmt::format("pose{}", out.size() + 1);
    out.push_back(m);
  }
  return out;
}

double max_tip_error_z700(const kin::PrsHybrid& commanding, const kin::PrsHybrid& truth) {
  double worst = 0;
  const kin::JointVector start = kin::JointVector::Zero(5);
  for (int ti = 0; ti <= 40; ++ti)
    for (int pi = 0; pi < 72; ++pi) {
      const kin::Pose t = target(700, ti * kin::kDeg, pi * 5 * kin::kDeg);
      kin::JointVector q;
      if (!commanding.inverse(t, start, q).ok()) return std::numeric_limits<double>::infinity();
      kin::Pose real;
      if (!truth.forward(q, real).ok()) return std::numeric_limits<double>::infinity();
      worst = std::max(worst, (real.p - t.p).norm());
    }
  return worst;
}

}  // namespace doc001

}  // namespace postproc::cal
