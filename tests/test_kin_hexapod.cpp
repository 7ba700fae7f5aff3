// Hexapod (document 003): closed-form IK against Newton FK over a random work space, the
// analytic Jacobians against finite differences, and every failure status.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/kinematics/hexapod.hpp"

namespace {

namespace kin = postproc::kin;
using kin::Hexapod;
using kin::JointVector;
using kin::Pose;
using kin::Status;

constexpr std::uint32_t kSeed = 20240611;
constexpr int kPoses = 600;  // ≥ 500 random poses per round-trip test

/// The home tool pose of the design (tip 550 mm above the base, tool axis +Z).
Pose home_tool(const Hexapod& h) { return h.tool_pose(kin::PlatformPose{h.config().home.linear(), h.config().home.translation()}); }

/// A pose within ±100 mm and ±15° (about each workpiece axis) of `centre`.
Pose random_pose(std::mt19937& rng, const Pose& centre, double mm = 100, double deg = 15) {
  std::uniform_real_distribution<double> d(-1, 1);
  Pose p;
  p.p = centre.p + mm * Eigen::Vector3d(d(rng), d(rng), d(rng));
  p.r = (Eigen::AngleAxisd(deg * kin::kDeg * d(rng), Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(deg * kin::kDeg * d(rng), Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(deg * kin::kDeg * d(rng), Eigen::Vector3d::UnitZ()))
            .toRotationMatrix() *
        centre.r;
  return p;
}

/// The same machine with every parameter off by up to ±50 µm.
kin::ModelPtr with_errors(const Hexapod& h, std::mt19937& rng) {
  std::uniform_real_distribution<double> d(-0.05, 0.05);
  std::vector<double> v = h.values();
  for (double& x : v) x += d(rng);
  return h.with_values(std::move(v));
}

JointVector zeros() { return JointVector::Zero(6); }

kin::IkOptions full_match() {
  kin::IkOptions o;
  o.match = kin::PoseMatch::full;
  return o;
}

/// IK then FK (from home, and seeded with the target) over random poses: both must return the pose.
void expect_round_trips(const Hexapod& h, std::mt19937& rng) {
  const Pose centre = home_tool(h);
  double worst_mm = 0;
  double worst_rad = 0;
  for (int n = 0; n < kPoses; ++n) {
    const Pose target = random_pose(rng, centre);
    JointVector q;
    const kin::Solve ik = h.inverse(target, zeros(), q, full_match());
    ASSERT_TRUE(ik.ok()) << kin::to_string(ik.status) << " at pose " << n;
    for (int seeded = 0; seeded < 2; ++seeded) {
      Pose back;
      const kin::Solve fk = seeded ? h.forward(q, back, target) : h.forward(q, back);
      ASSERT_TRUE(fk.ok()) << kin::to_string(fk.status) << " at pose " << n;
      worst_mm = std::max(worst_mm, (back.p - target.p).norm());
      worst_rad = std::max(worst_rad, kin::rotation_difference(back.r, target.r).norm());
    }
  }
  EXPECT_LE(worst_mm, 1e-9);
  EXPECT_LE(worst_rad, 1e-9);
  ::testing::Test::RecordProperty("worst_mm", fmt::format("{:.3g}", worst_mm));
  ::testing::Test::RecordProperty("worst_rad", fmt::format("{:.3g}", worst_rad));
}

TEST(Hexapod, DesignHasNamedParametersAndZeroAtHome) {
  const Hexapod h(kin::hexapod_design());
  EXPECT_EQ(h.kind(), "hexapod");
  ASSERT_EQ(h.joint_count(), 6);
  EXPECT_EQ(h.joints()[2].name, "q3");
  ASSERT_EQ(h.parameters().size(), 42u);
  EXPECT_EQ(h.parameters()[0].name, "base1.x");
  EXPECT_EQ(h.parameters()[8].name, "base3.z");
  EXPECT_EQ(h.parameters()[18 + 7].name, "platform3.y");
  EXPECT_EQ(h.parameters()[41].name, "strut6.offset");
  EXPECT_EQ(h.parameter_index("platform3.z"), 18 + 8);
  for (std::size_t i = 0; i < 42; ++i) {
    EXPECT_EQ(h.parameters()[i].unit, "mm");
    EXPECT_EQ(h.parameters()[i].nominal, h.values()[i]);
  }
  EXPECT_NEAR(h.values()[h.parameter_index("base1.x")], 400 * std::cos(15 * kin::kDeg), 1e-12);
  JointVector q;
  ASSERT_TRUE(h.inverse(home_tool(h), zeros(), q, full_match()).ok());
  EXPECT_LE(q.cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(home_tool(h).p.z(), 550, 1e-12);
}

TEST(Hexapod, RoundTripNominal) {
  std::mt19937 rng(kSeed);
  expect_round_trips(Hexapod(kin::hexapod_design()), rng);
}

TEST(Hexapod, RoundTripWithParameterErrors) {
  std::mt19937 rng(kSeed + 1);
  const Hexapod nominal(kin::hexapod_design());
  for (int m = 0; m < 3; ++m) {
    const auto actual = with_errors(nominal, rng);
    expect_round_trips(dynamic_cast<const Hexapod&>(*actual), rng);
  }
}

TEST(Hexapod, RoundTripWithWorkpieceFrameAndTiltedTool) {
  kin::HexapodConfig cfg = kin::hexapod_design();
  cfg.workpiece = Eigen::Translation3d(30, -20, 400) * Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized());
  cfg.tool_axis = Eigen::Vector3d(0.1, -0.2, 1).normalized();
  cfg.tool_tip = Eigen::Vector3d(5, -3, -160);
  const Hexapod h(cfg);
  std::mt19937 rng(kSeed + 2);
  expect_round_trips(h, rng);
  const Pose home = home_tool(h);
  EXPECT_LE((home.axis() - h.machine_to_workpiece(zeros()) * cfg.home.linear() * cfg.tool_axis).norm(), 1e-12);
  EXPECT_LE((h.linear_position(zeros()) - cfg.workpiece * home.p).norm(), 1e-9);
}

TEST(Hexapod, SeededForwardConvergesInFewSteps) {
  // The remap's FK: nominal model, seeded with the target, struts from a model with errors.
  std::mt19937 rng(kSeed + 3);
  const Hexapod nominal(kin::hexapod_design());
  const auto actual = with_errors(nominal, rng);
  for (int n = 0; n < 100; ++n) {
    const Pose target = random_pose(rng, home_tool(nominal));
    JointVector q;
    ASSERT_TRUE(actual->inverse(target, zeros(), q, full_match()).ok());
    Pose cmd;
    const kin::Solve fk = nominal.forward(q, cmd, target);
    ASSERT_TRUE(fk.ok());
    EXPECT_LE(fk.iterations, 3);
    EXPECT_LE((cmd.p - target.p).norm(), 1.0);  // the errors move the tip by well under a mm
  }
}

TEST(Hexapod, PointAndAxisKeepsTheRotationAboutTheAxisOfStart) {
  std::mt19937 rng(kSeed + 4);
  const Hexapod h(kin::hexapod_design());
  for (int n = 0; n < 50; ++n) {
    const Pose start_pose = random_pose(rng, home_tool(h));
    JointVector start;
    ASSERT_TRUE(h.inverse(start_pose, zeros(), start, full_match()).ok());
    // Target: swing the axis by a few degrees, then add an arbitrary twist about the new axis
    // that point_and_axis must ignore.
    const Eigen::Matrix3d swing =
        Eigen::AngleAxisd(4 * kin::kDeg, start_pose.axis().unitOrthogonal()).toRotationMatrix();
    Pose target = random_pose(rng, start_pose, 10, 0);
    const Eigen::Matrix3d wanted = swing * start_pose.r;
    target.r = Eigen::AngleAxisd(0.7, wanted.col(2)).toRotationMatrix() * wanted;
    JointVector q;
    ASSERT_TRUE(h.inverse(target, start, q).ok());
    Pose got;
    ASSERT_TRUE(h.forward(q, got).ok());
    EXPECT_LE((got.p - target.p).norm(), 1e-9);
    EXPECT_LE(kin::rotation_difference(got.r, wanted).norm(), 1e-9);
  }
}

TEST(Hexapod, ReachedPoseIsWhereTheStrutsOfInversePutTheTool) {
  // The remap takes the intended pose of a tool-vector block from reached_pose() instead of
  // solving forward kinematics for the nominal struts: both spin rules, point + axis targets.
  std::mt19937 rng(kSeed + 5);
  for (const kin::HexapodSpin spin : {kin::HexapodSpin::minimal_from_home, kin::HexapodSpin::previous}) {
    kin::HexapodConfig cfg = kin::hexapod_design();
    cfg.spin = spin;
    const Hexapod h(cfg);
    JointVector start = zeros();
    for (int n = 0; n < 50; ++n) {
      const Pose target = random_pose(rng, home_tool(h));
      const Pose reached = h.reached_pose(target, start, kin::PoseMatch::point_and_axis);
      EXPECT_LE((reached.p - target.p).norm(), 1e-12);
      EXPECT_LE((reached.axis() - target.axis()).norm(), 1e-12);
      JointVector q, q_full;
      ASSERT_TRUE(h.inverse(target, start, q).ok());
      ASSERT_TRUE(h.inverse(reached, start, q_full, full_match()).ok());
      EXPECT_EQ(q, q_full);  // the same struts, bit for bit
      Pose back;
      ASSERT_TRUE(h.forward(q, back).ok());
      EXPECT_LE((back.p - reached.p).norm(), 1e-9);
      EXPECT_LE(kin::rotation_difference(back.r, reached.r).norm(), 1e-9);
      start = q;
    }
  }
}

TEST(Hexapod, JacobianMatchesFiniteDifferences) {
  std::mt19937 rng(kSeed + 5);
  kin::HexapodConfig cfg = kin::hexapod_design();
  cfg.workpiece = Eigen::Translation3d(10, 20, 300) * Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ());
  cfg.tool_tip = Eigen::Vector3d(2, 1, -150);
  const Hexapod nominal(cfg);
  const auto h = with_errors(nominal, rng);
  for (int n = 0; n < 20; ++n) {
    JointVector q;
    ASSERT_TRUE(h->inverse(random_pose(rng, home_tool(nominal)), zeros(), q, full_match()).ok());
    const kin::Jacobian analytic = kin::jacobian(*h, q);
    const kin::Jacobian numeric = kin::numeric_jacobian(*h, q);
    ASSERT_EQ(analytic.cols(), 6);
    EXPECT_LE((analytic - numeric).cwiseAbs().maxCoeff(), 1e-6) << "analytic\n" << analytic << "\nnumeric\n" << numeric;
  }
}

TEST(Hexapod, IdentificationJacobianMatchesFiniteDifferences) {
  std::mt19937 rng(kSeed + 6);
  const Hexapod nominal(kin::hexapod_design());
  const auto h = with_errors(nominal, rng);
  const auto& hex = dynamic_cast<const Hexapod&>(*h);
  constexpr double kStep = 1e-5;
  for (int n = 0; n < 5; ++n) {
    const Pose pose = random_pose(rng, home_tool(nominal));
    const kin::IdentificationJacobian analytic = hex.identification_jacobian(pose);
    for (int k = 0; k < kin::kHexapodParameters; ++k) {
      std::vector<double> plus = hex.values();
      std::vector<double> minus = hex.values();
      plus[static_cast<std::size_t>(k)] += kStep;
      minus[static_cast<std::size_t>(k)] -= kStep;
      JointVector qp;
      JointVector qm;
      ASSERT_TRUE(hex.with_values(plus)->inverse(pose, zeros(), qp, full_match()).ok());
      ASSERT_TRUE(hex.with_values(minus)->inverse(pose, zeros(), qm, full_match()).ok());
      const Eigen::Matrix<double, 6, 1> numeric = (qp - qm) / (2 * kStep);
      EXPECT_LE((analytic.col(k) - numeric).cwiseAbs().maxCoeff(), 1e-7) << hex.parameters()[static_cast<std::size_t>(k)].name;
    }
  }
}

TEST(Hexapod, ForwardReportsImpossibleStruts) {
  const Hexapod h(kin::hexapod_design());
  Pose out;
  out.p = Eigen::Vector3d(1, 2, 3);
  const Pose untouched = out;

  JointVector q = zeros();
  q[0] = 2000;  // strut 1 two metres longer than its neighbours: no platform pose fits
  const kin::Solve s = h.forward(q, out);
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(s.status == Status::diverged || s.status == Status::no_convergence || s.status == Status::singular)
      << kin::to_string(s.status);
  EXPECT_EQ(out.p, untouched.p);  // never a garbage pose

  q = zeros();
  q[3] = -h.values()[static_cast<std::size_t>(h.parameter_index("strut4.offset"))] - 1;  // negative length
  const kin::Solve neg = h.forward(q, out);
  EXPECT_EQ(neg.status, Status::unreachable);
  EXPECT_EQ(neg.joint, 3);

  q = zeros();
  q[0] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(h.forward(q, out).ok());
  EXPECT_EQ(out.p, untouched.p);
}

TEST(Hexapod, ForwardReportsTheIterationLimit) {
  const Hexapod h(kin::hexapod_design());
  std::mt19937 rng(kSeed + 7);
  JointVector q;
  const Pose target = random_pose(rng, home_tool(h));
  ASSERT_TRUE(h.inverse(target, zeros(), q, full_match()).ok());
  Pose out;
  kin::HexapodFkOptions one;
  one.max_iterations = 1;
  const kin::Solve s = h.forward(q, out, home_tool(h), one);
  EXPECT_EQ(s.status, Status::no_convergence);
  EXPECT_EQ(s.iterations, 1);
  EXPECT_GT(s.residual_mm, one.tolerance_mm);
  // The default limit is enough from the same start.
  EXPECT_TRUE(h.forward(q, out, home_tool(h)).ok());
}

TEST(Hexapod, InverseReportsLimitsAndUnreachablePoses) {
  const Hexapod h(kin::hexapod_design());
  Pose high = home_tool(h);
  high.p.z() += 400;  // every strut ~350 mm longer: beyond the ±250 mm travel
  JointVector q;
  kin::Solve s = h.inverse(high, zeros(), q, full_match());
  EXPECT_EQ(s.status, Status::out_of_limits);
  EXPECT_GE(s.joint, 0);
  EXPECT_GT(q[s.joint], 250);  // the values are still returned
  kin::IkOptions no_limits = full_match();
  no_limits.check_limits = false;
  EXPECT_TRUE(h.inverse(high, zeros(), q, no_limits).ok());

  // Platform joint 2 placed on base joint 2: the strut would have zero length.
  kin::PlatformPose x;
  x.t = h.config().base_joints[1] - h.config().platform_joints[1];
  s = h.inverse(h.tool_pose(x), zeros(), q, full_match());
  EXPECT_EQ(s.status, Status::unreachable);
  EXPECT_EQ(s.joint, 1);
}

TEST(Hexapod, WithValuesLeavesTheOriginalUnchanged) {
  const Hexapod h(kin::hexapod_design());
  const std::vector<double> before = h.values();
  JointVector q0;
  ASSERT_TRUE(h.inverse(home_tool(h), zeros(), q0, full_match()).ok());
  std::vector<double> v = before;
  v[static_cast<std::size_t>(h.parameter_index("strut2.offset"))] += 0.5;
  const auto changed = h.with_values(v);
  EXPECT_EQ(h.values(), before);
  EXPECT_EQ(changed->values(), v);
  JointVector q1;
  ASSERT_TRUE(changed->inverse(home_tool(h), zeros(), q1, full_match()).ok());
  EXPECT_NEAR(q1[1], q0[1] - 0.5, 1e-12);
  JointVector q2;
  ASSERT_TRUE(h.inverse(home_tool(h), zeros(), q2, full_match()).ok());
  EXPECT_EQ(q2, q0);
  EXPECT_EQ(changed->nominal()->values(), before);
  EXPECT_THROW((void)h.with_values(std::vector<double>(41, 0.0)), postproc::Error);
}

TEST(Hexapod, BadDesignThrows) {
  kin::HexapodConfig cfg = kin::hexapod_design();
  cfg.tool_axis = Eigen::Vector3d::Zero();
  EXPECT_THROW(Hexapod{cfg}, postproc::Error);
  cfg = kin::hexapod_design();
  cfg.strut_min[4] = 10;
  cfg.strut_max[4] = -10;
  try {
    Hexapod bad(cfg);
    FAIL() << "no throw";
  } catch (const postproc::Error& e) {
    EXPECT_EQ(e.code(), postproc::ExitCode::usage);
    EXPECT_NE(std::string(e.what()).find("strut 5"), std::string::npos) << e.what();
  }
  cfg = kin::hexapod_design();
  for (auto& p : cfg.platform_joints) p.setZero();  // all struts meet in one point: singular
  EXPECT_THROW(Hexapod{cfg}, postproc::Error);
}

}  // namespace
