// The bounded inverse (kinematics/bounded_inverse.hpp): tool tip exact, tool axis corrected with a
// bounded, continuous rotary correction near singular poses. On the sample machines' real errors:
// regular poses match the exact inverse; a sweep of B through 0 on the B/C table stays within the
// bound, never worsens the tool axis and is continuous (halving the B step halves the jumps); the
// lathe's tool tip is reached near the spindle axis, where only C can move it sideways.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "postproc/kinematics/bounded_inverse.hpp"
#include "sample_machine.hpp"

namespace {

using namespace postproc;
using kin::kDeg;

double angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }

int joint(const kin::Model& m, const char* name) {
  for (int j = 0; j < m.joint_count(); ++j)
    if (m.joints()[static_cast<std::size_t>(j)].name == name) return j;
  ADD_FAILURE() << "no joint " << name;
  return 0;
}

// The largest rotary change between q and the anchor, degrees.
double rotary_change(const kin::Model& m, const kin::JointVector& q, const kin::JointVector& a) {
  double d = 0;
  for (int j = 0; j < m.joint_count(); ++j)
    if (m.joints()[static_cast<std::size_t>(j)].type == kin::JointType::rotary) d = std::max(d, std::abs(q[j] - a[j]));
  return d;
}

struct Outcome {
  kin::Solve s;
  kin::JointVector q;
  double before_rad = 0;  // tool-axis error of the anchor on the real machine
};

Outcome remap(const machine::Machine& m, const kin::JointVector& q_nom, const kin::BoundedIkOptions& opt) {
  kin::Pose want, before;
  EXPECT_TRUE(m.nominal->forward(q_nom, want).ok());
  EXPECT_TRUE(m.actual->forward(q_nom, before).ok());
  Outcome o;
  o.before_rad = angle(before.axis(), want.axis());
  o.s = kin::bounded_inverse(*m.actual, want, q_nom, o.q, opt);
  kin::Pose got;
  EXPECT_TRUE(m.actual->forward(o.q, got).ok());
  // The Solve's figures are the real machine's at the returned joints.
  EXPECT_NEAR(o.s.residual_mm, (got.p - want.p).norm(), 1e-12);
  EXPECT_NEAR(o.s.residual_rad, angle(got.axis(), want.axis()), 1e-12);
  return o;
}

TEST(BoundedInverse, RegularPosesMatchTheExactInverse) {
  const machine::Machine m = pptest::sample_machine("trunnion_bc_fanuc.toml");
  std::mt19937 rng(20261126);
  std::uniform_real_distribution<double> lin(-150, 150), b(10, 100), c(-360, 360), sign(-1, 1);
  const int jb = joint(*m.actual, "B"), jc = joint(*m.actual, "C");
  for (int i = 0; i < 200; ++i) {
    kin::JointVector q(m.actual->joint_count());
    for (int j = 0; j < q.size(); ++j) q[j] = lin(rng);
    q[jb] = std::copysign(b(rng), sign(rng));
    q[jc] = c(rng);
    const Outcome o = remap(m, q, {});
    ASSERT_TRUE(o.s.ok()) << i;
    EXPECT_LT(o.s.residual_mm, 1e-9) << i;
    // Away from the singularity the full damping takes (λ/σ)² of the error: here under 1 %
    // (compensate blends the damping in only near singular poses and is exact here).
    EXPECT_LT(o.s.residual_rad, 1e-2 * o.before_rad + 1e-12) << i;
    kin::Pose want;
    ASSERT_TRUE(m.nominal->forward(q, want).ok());
    kin::JointVector exact;
    ASSERT_TRUE(m.actual->inverse(want, q, exact).ok());
    EXPECT_LT(rotary_change(*m.actual, o.q, exact), 1e-3) << i;
  }
}

// B from −span to +span through the singular B = 0 (the tool axis along C) at a fixed C.
std::vector<Outcome> sweep(const machine::Machine& m, double span_deg, double step_deg, const kin::BoundedIkOptions& opt) {
  const int jb = joint(*m.actual, "B"), jc = joint(*m.actual, "C");
  std::vector<Outcome> out;
  for (double b = -span_deg; b <= span_deg + 1e-9; b += step_deg) {
    kin::JointVector q = kin::JointVector::Zero(m.actual->joint_count());
    q[joint(*m.actual, "X")] = 40;
    q[joint(*m.actual, "Y")] = -25;
    q[joint(*m.actual, "Z")] = 30;
    q[jb] = b;
    q[jc] = 30;
    out.push_back(remap(m, q, opt));
    out.back().q -= q;  // keep the correction only
  }
  return out;
}

TEST(BoundedInverse, SweepThroughTheSingularPoseIsBoundedAndNeverWorse) {
  const machine::Machine m = pptest::sample_machine("trunnion_bc_fanuc.toml");
  kin::BoundedIkOptions opt;  // 1°
  const auto runs = sweep(m, 6.0, 0.01, opt);
  const int jb = joint(*m.actual, "B"), jc = joint(*m.actual, "C");
  double largest = 0;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const Outcome& o = runs[i];
    const double b = -6.0 + 0.01 * static_cast<double>(i);
    ASSERT_TRUE(o.s.ok()) << "B " << b;
    EXPECT_LT(o.s.residual_mm, 1e-9) << "B " << b;
    EXPECT_LE(o.s.residual_rad, o.before_rad * (1 + 1e-9)) << "B " << b;
    largest = std::max({largest, std::abs(o.q[jb]), std::abs(o.q[jc])});
    // Where the C axis turns the tool axis enough (|B| ≥ 3°), the tool axis is corrected by 95 %.
    if (std::abs(b) >= 3) {
      EXPECT_LT(o.s.residual_rad, 0.05 * o.before_rad) << "B " << b;
    }
  }
  EXPECT_LE(largest, 1.05) << "degrees of rotary correction (bound 1°)";
  // λ ≥ e/(2c) bounds the correction by the whole tool-axis error; the part C must correct near
  // B = 0 is a share of it, and λ ≥ √(e/K) keeps the joint path smooth, so the largest correction
  // stays well under c.
  EXPECT_GT(largest, 0.05) << "the rotary axes do correct near B = 0";

  // The exact inverse at B = 0.02° needs a C correction far beyond the bound: why the bound exists.
  kin::JointVector q = kin::JointVector::Zero(m.actual->joint_count());
  q[joint(*m.actual, "X")] = 40;
  q[jb] = 0.02;
  q[jc] = 30;
  kin::Pose want;
  ASSERT_TRUE(m.nominal->forward(q, want).ok());
  kin::JointVector exact;
  kin::IkOptions full;
  full.check_limits = false;
  if (m.actual->inverse(want, q, exact, full).ok()) {
    EXPECT_GT(std::abs(exact[jc] - q[jc]), 2.0);
  }
}

TEST(BoundedInverse, CorrectionIsContinuousAcrossTheSingularPose) {
  // Halving (here: a tenth of) the B step must shrink the largest jump of the correction between
  // neighbours in proportion: a continuous function of the pose, no switch between branches.
  const machine::Machine m = pptest::sample_machine("trunnion_bc_fanuc.toml");
  const auto jump = [&](double step) {
    const auto runs = sweep(m, 0.5, step, {});
    double j = 0;
    for (std::size_t i = 1; i < runs.size(); ++i) j = std::max(j, (runs[i].q - runs[i - 1].q).cwiseAbs().maxCoeff());
    return j;
  };
  const double coarse = jump(0.01);
  const double fine = jump(0.001);
  EXPECT_GT(coarse, 0);
  EXPECT_LT(fine, coarse / 5) << "coarse " << coarse << "°, fine " << fine << "°";
}

TEST(BoundedInverse, LatheTipReachedNearTheSpindleAxis) {
  // X Z B C lathe with a centre-height error: near the axis only C moves the tip sideways
  // (C ≈ atan(dy / r)); the tip is matched exactly down to a few tens of µm from the axis.
  const machine::Machine m = pptest::sample_machine("lathe_xzbc_doc004.toml");
  const int jx = joint(*m.actual, "X"), jc = joint(*m.actual, "C"), jz = joint(*m.actual, "Z");
  const double x_axis = -m.work_offsets.at("G54")[0];  // joint X with the tip on the spindle axis
  double c_last = 0;
  for (double r : {10.0, 3.0, 1.0, 0.3, 0.1, 0.05, 0.02}) {
    kin::JointVector q = kin::JointVector::Zero(m.actual->joint_count());
    q[jx] = -x_axis + r;  // the sample: X0 of G54 on the axis, X measured as a radius
    q[jz] = -20;
    q[jc] = 15;
    kin::Pose want;
    ASSERT_TRUE(m.nominal->forward(q, want).ok());
    EXPECT_NEAR(std::hypot(want.p.x(), want.p.y()), r, 1e-9) << "the test's reading of the sample";
    const Outcome o = remap(m, q, {});
    ASSERT_TRUE(o.s.ok()) << "r " << r << ": " << kin::to_string(o.s.status);
    EXPECT_LT(o.s.residual_mm, 1e-9) << "r " << r;
    const double dc = std::abs(o.q[jc] - q[jc]);
    EXPECT_GE(dc, c_last * 0.999) << "r " << r << ": C takes more of the correction nearer the axis";
    c_last = dc;
  }
  EXPECT_GT(c_last, 0.5) << "degrees of C at 50 µm from the axis";
}

}  // namespace
