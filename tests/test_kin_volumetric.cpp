// Volumetric error map (document 002): interpolation exactness and smoothness, the outside
// policies, construction checks, and the decorator over small test machines and the hexapod.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "postproc/error.hpp"
#include "postproc/kinematics/hexapod.hpp"
#include "postproc/kinematics/volumetric_map.hpp"

namespace {

namespace kin = postproc::kin;
using kin::JointVector;
using kin::Pose;
using kin::Status;
using kin::VolumetricMap;
using Interp = VolumetricMap::Interpolation;
using Outside = VolumetricMap::Outside;

constexpr std::uint32_t kSeed = 424242;
const Eigen::Vector3d kOrigin(-200, -150, 50);
const Eigen::Vector3d kSpacing(100, 75, 60);
const Eigen::Vector3i kCounts(5, 4, 6);

/// A 3-axis machine: P = (X, Y, Z), R = I. No parameters.
class Cartesian final : public kin::Model {
 public:
  Cartesian() : Model(axes(), {}, {}) {}
  [[nodiscard]] std::string kind() const override { return "cartesian"; }
  [[nodiscard]] kin::Solve forward(const JointVector& q, Pose& out) const override {
    out.p = q.head<3>();
    out.r.setIdentity();
    return {};
  }
  /// Closed form (the tool axis is always Z; only the point can be matched).
  [[nodiscard]] kin::Solve inverse(const Pose& target, const JointVector&, JointVector& q,
                                   const kin::IkOptions& = {}) const override {
    q = target.p;
    return {};
  }
  [[nodiscard]] std::shared_ptr<const Model> with_values(std::vector<double>) const override {
    return std::make_shared<const Cartesian>();
  }

 private:
  static std::vector<kin::Joint> axes() {
    return {{"X", kin::JointType::linear, -500, 500}, {"Y", kin::JointType::linear, -500, 500}, {"Z"}};
  }
};

/// X Y Z plus a rotary table C (degrees) carrying the workpiece: P_w = Rz(−C)·(X, Y, Z).
class CartesianWithTable final : public kin::Model {
 public:
  CartesianWithTable() : Model({{"X"}, {"Y"}, {"Z"}, {"C", kin::JointType::rotary}}, {}, {}) {}
  [[nodiscard]] std::string kind() const override { return "table"; }
  [[nodiscard]] kin::Solve forward(const JointVector& q, Pose& out) const override {
    const Eigen::Matrix3d r = machine_to_workpiece(q);
    out.p = r * q.head<3>();
    out.r = r;
    return {};
  }
  [[nodiscard]] std::shared_ptr<const Model> with_values(std::vector<double>) const override {
    return std::make_shared<const CartesianWithTable>();
  }
  [[nodiscard]] Eigen::Matrix3d machine_to_workpiece(const JointVector& q) const override {
    return Eigen::AngleAxisd(-q[3] * kin::kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  }
};

std::vector<Eigen::Vector3d> random_nodes(std::mt19937& rng, double size_mm = 0.02) {
  std::uniform_real_distribution<double> d(-size_mm, size_mm);
  std::vector<Eigen::Vector3d> v(static_cast<std::size_t>(kCounts.prod()));
  for (auto& e : v) e = Eigen::Vector3d(d(rng), d(rng), d(rng));
  return v;
}

Eigen::Vector3d node_point(int i, int j, int k) { return kOrigin + kSpacing.cwiseProduct(Eigen::Vector3d(i, j, k)); }

/// A random point of the grid box shrunk by `margin` (a fraction of its size) on every side.
Eigen::Vector3d random_inside(std::mt19937& rng, const VolumetricMap& m, double margin = 0) {
  std::uniform_real_distribution<double> d(margin, 1 - margin);
  return m.origin() + (m.upper() - m.origin()).cwiseProduct(Eigen::Vector3d(d(rng), d(rng), d(rng)));
}

std::shared_ptr<const VolumetricMap> make_map(std::vector<Eigen::Vector3d> nodes, Interp interp = Interp::smooth,
                                              Outside outside = Outside::refuse) {
  return std::make_shared<const VolumetricMap>(kOrigin, kSpacing, kCounts, std::move(nodes), interp, outside);
}

TEST(VolumetricMap, ReproducesAffineFieldsExactly) {
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> d(-1e-4, 1e-4);
  const Eigen::Matrix3d a = Eigen::Matrix3d::NullaryExpr([&] { return d(rng); });
  const Eigen::Vector3d c(0.01, -0.02, 0.005);
  std::vector<Eigen::Vector3d> nodes;
  for (int k = 0; k < kCounts.z(); ++k)
    for (int j = 0; j < kCounts.y(); ++j)
      for (int i = 0; i < kCounts.x(); ++i) nodes.push_back(a * node_point(i, j, k) + c);
  for (Interp interp : {Interp::trilinear, Interp::smooth}) {
    const auto m = make_map(nodes, interp);
    for (int n = 0; n < 500; ++n) {
      const Eigen::Vector3d p = random_inside(rng, *m);
      const auto s = m->sample(p);
      ASSERT_TRUE(s);
      EXPECT_LE((s->error - (a * p + c)).norm(), 1e-15);
      EXPECT_LE((s->gradient - a).cwiseAbs().maxCoeff(), 1e-17);
    }
  }
}

TEST(VolumetricMap, ReproducesNodeValues) {
  std::mt19937 rng(kSeed + 1);
  const auto nodes = random_nodes(rng);
  for (Interp interp : {Interp::trilinear, Interp::smooth}) {
    const auto m = make_map(nodes, interp);
    for (int k = 0; k < kCounts.z(); ++k)
      for (int j = 0; j < kCounts.y(); ++j)
        for (int i = 0; i < kCounts.x(); ++i) {
          const auto e = m->error(node_point(i, j, k));
          ASSERT_TRUE(e);
          EXPECT_LE((*e - m->node(i, j, k)).norm(), 1e-16) << i << ' ' << j << ' ' << k;
        }
  }
}

TEST(VolumetricMap, SmoothIsC1AcrossCellFaces) {
  std::mt19937 rng(kSeed + 2);
  const auto nodes = random_nodes(rng);
  const auto smooth = make_map(nodes, Interp::smooth);
  const auto linear = make_map(nodes, Interp::trilinear);
  constexpr double kD = 1e-7;
  double worst_jump = 0;
  double worst_grad_jump = 0;
  double linear_grad_jump = 0;
  for (int n = 0; n < 300; ++n) {
    Eigen::Vector3d p = random_inside(rng, *smooth);
    const int axis = n % 3;
    const int face = 1 + n % (kCounts[axis] - 2);  // an interior face
    p[axis] = kOrigin[axis] + face * kSpacing[axis];
    Eigen::Vector3d lo = p;
    Eigen::Vector3d hi = p;
    lo[axis] -= kD;
    hi[axis] += kD;
    const auto a = *smooth->sample(lo);
    const auto b = *smooth->sample(hi);
    // Value continuous: the step across the face is what the gradient predicts.
    worst_jump = std::max(worst_jump, (b.error - a.error - a.gradient.col(axis) * 2 * kD).norm());
    worst_grad_jump = std::max(worst_grad_jump, (a.gradient - b.gradient).cwiseAbs().maxCoeff());
    linear_grad_jump = std::max(linear_grad_jump, (linear->sample(lo)->gradient - linear->sample(hi)->gradient).cwiseAbs().maxCoeff());
  }
  EXPECT_LE(worst_jump, 1e-15);
  EXPECT_LE(worst_grad_jump, 1e-11);   // gradient continuous (second derivative ~ 1e-6 / mm)
  EXPECT_GE(linear_grad_jump, 1e-5);   // the check can see a kink: trilinear has one
}

TEST(VolumetricMap, GradientMatchesFiniteDifferences) {
  std::mt19937 rng(kSeed + 3);
  const auto nodes = random_nodes(rng);
  for (Interp interp : {Interp::trilinear, Interp::smooth}) {
    const auto m = make_map(nodes, interp);
    constexpr double kH = 1e-4;
    for (int n = 0; n < 200; ++n) {
      const Eigen::Vector3d p = random_inside(rng, *m, 1e-3);
      Eigen::Matrix3d numeric;
      for (int a = 0; a < 3; ++a) {
        Eigen::Vector3d hi = p;
        Eigen::Vector3d lo = p;
        hi[a] += kH;
        lo[a] -= kH;
        numeric.col(a) = (*m->error(hi) - *m->error(lo)) / (2 * kH);
      }
      const Eigen::Matrix3d analytic = *m->gradient(p);
      // Trilinear: exact except when p ± h straddles a face (then within the kink).
      EXPECT_LE((analytic - numeric).cwiseAbs().maxCoeff(), interp == Interp::smooth ? 1e-10 : 1e-3);
    }
  }
}

TEST(VolumetricMap, OutsidePolicies) {
  std::mt19937 rng(kSeed + 4);
  const auto nodes = random_nodes(rng);
  const Eigen::Vector3d out = kOrigin + Eigen::Vector3d(-30, 100, 70);  // below the box in x only
  const Eigen::Vector3d nearest = kOrigin + Eigen::Vector3d(0, 100, 70);
  for (Interp interp : {Interp::trilinear, Interp::smooth}) {
    const auto refuse = make_map(nodes, interp, Outside::refuse);
    EXPECT_FALSE(refuse->contains(out));
    EXPECT_FALSE(refuse->sample(out));
    EXPECT_FALSE(refuse->error(out));
    EXPECT_FALSE(refuse->gradient(out));
    // On the boundary plus rounding: still inside.
    EXPECT_TRUE(refuse->error(refuse->upper() + Eigen::Vector3d::Constant(1e-12)));

    const auto clamp = make_map(nodes, interp, Outside::clamp);
    const auto c = clamp->sample(out);
    ASSERT_TRUE(c);
    EXPECT_LE((c->error - *clamp->error(nearest)).norm(), 1e-16);
    EXPECT_EQ(c->gradient.col(0), Eigen::Vector3d::Zero());
    EXPECT_LE((c->gradient.rightCols<2>() - clamp->gradient(nearest)->rightCols<2>()).cwiseAbs().maxCoeff(), 1e-16);
    const Eigen::Vector3d far_corner = clamp->upper() + Eigen::Vector3d(5, 5, 5);
    EXPECT_LE((*clamp->error(far_corner) - nodes.back()).norm(), 1e-16);

    const auto zero = make_map(nodes, interp, Outside::zero);
    ASSERT_TRUE(zero->sample(out));
    EXPECT_EQ(*zero->error(out), Eigen::Vector3d::Zero());
    EXPECT_EQ(*zero->gradient(out), Eigen::Matrix3d::Zero());
    EXPECT_EQ(*zero->error(nearest), *refuse->error(nearest));  // inside: the map as usual
  }
  // refuse is the default
  EXPECT_EQ(VolumetricMap(kOrigin, kSpacing, kCounts, nodes).outside(), Outside::refuse);
}

TEST(VolumetricMap, TwoNodesPerAxisIsTrilinear) {
  std::mt19937 rng(kSeed + 5);
  std::uniform_real_distribution<double> d(-0.01, 0.01);
  std::vector<Eigen::Vector3d> nodes(8);
  for (auto& e : nodes) e = Eigen::Vector3d(d(rng), d(rng), d(rng));
  const VolumetricMap s(kOrigin, kSpacing, Eigen::Vector3i(2, 2, 2), nodes, Interp::smooth);
  const VolumetricMap t(kOrigin, kSpacing, Eigen::Vector3i(2, 2, 2), nodes, Interp::trilinear);
  for (int n = 0; n < 100; ++n) {
    const Eigen::Vector3d p = random_inside(rng, s);
    EXPECT_LE((*s.error(p) - *t.error(p)).norm(), 1e-16);
  }
}

void expect_usage_error(const std::function<void()>& build, const std::string& needle) {
  try {
    build();
    FAIL() << "no throw, expected: " << needle;
  } catch (const postproc::Error& e) {
    EXPECT_EQ(e.code(), postproc::ExitCode::usage);
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(VolumetricMap, BadConstructionThrows) {
  std::mt19937 rng(kSeed + 6);
  const auto nodes = random_nodes(rng);
  expect_usage_error([&] { VolumetricMap(kOrigin, kSpacing, Eigen::Vector3i(5, 1, 24), nodes); }, "along y");
  expect_usage_error([&] { VolumetricMap(kOrigin, Eigen::Vector3d(100, 0, 60), kCounts, nodes); }, "spacing along y");
  expect_usage_error([&] { VolumetricMap(kOrigin, Eigen::Vector3d(100, 75, -60), kCounts, nodes); }, "spacing along z");
  expect_usage_error([&] { VolumetricMap(kOrigin, kSpacing, Eigen::Vector3i(5, 4, 5), nodes); }, "(100 expected)");
  auto bad = nodes;
  bad[7].x() = std::numeric_limits<double>::quiet_NaN();
  expect_usage_error([&] { VolumetricMap(kOrigin, kSpacing, kCounts, bad); }, "node value 7");
  expect_usage_error([&] { kin::VolumetricModel(nullptr, make_map(nodes)); }, "base model");
  expect_usage_error([&] { kin::VolumetricModel(std::make_shared<Cartesian>(), nullptr); }, "error map");
}

TEST(VolumetricModel, ForwardAddsTheMapAndInverseRoundTrips) {
  std::mt19937 rng(kSeed + 7);
  const auto base = std::make_shared<const Cartesian>();
  const auto map = make_map(random_nodes(rng, 0.05));
  const kin::VolumetricModel m(base, map);
  EXPECT_EQ(m.kind(), "volumetric(cartesian)");
  EXPECT_EQ(m.joint_count(), 3);
  EXPECT_EQ(m.joints()[0].max, 500);
  double worst = 0;
  for (int n = 0; n < 500; ++n) {
    const Eigen::Vector3d p = random_inside(rng, *map);
    JointVector q = p;
    Pose out;
    ASSERT_TRUE(m.forward(q, out).ok());
    EXPECT_LE((out.p - (p + *map->error(p))).norm(), 1e-15);
    // Inverse: joints that put the tool on p despite the error.
    Pose target;
    target.p = p;
    JointVector back;
    const kin::Solve s = m.inverse(target, JointVector::Zero(3), back);
    ASSERT_TRUE(s.ok()) << kin::to_string(s.status) << " after " << s.iterations << " passes, residual " << s.residual_mm;
    ASSERT_TRUE(m.forward(back, out).ok());
    worst = std::max(worst, (out.p - p).norm());
  }
  EXPECT_LE(worst, 1e-9);
  EXPECT_EQ(m.linear_position(JointVector(Eigen::Vector3d(1, 2, 3))), Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(m.machine_to_workpiece(JointVector::Zero(3)), Eigen::Matrix3d::Identity());
}

TEST(VolumetricModel, OutsideTheMap) {
  std::mt19937 rng(kSeed + 8);
  const auto nodes = random_nodes(rng);
  const kin::VolumetricModel refuse(std::make_shared<Cartesian>(), make_map(nodes));
  const JointVector q = Eigen::Vector3d(400, 0, 100);  // x beyond the box (−200 … 200)
  Pose out;
  EXPECT_EQ(refuse.forward(q, out).status, Status::outside_map);
  Pose target;
  target.p = q;
  JointVector back;
  EXPECT_EQ(refuse.inverse(target, JointVector::Zero(3), back).status, Status::outside_map);
  EXPECT_TRUE(refuse.jacobian(q).hasNaN());

  const kin::VolumetricModel zero(std::make_shared<Cartesian>(), make_map(nodes, Interp::smooth, Outside::zero));
  ASSERT_TRUE(zero.forward(q, out).ok());
  EXPECT_EQ(out.p, q.head<3>());
  const kin::VolumetricModel clamp(std::make_shared<Cartesian>(), make_map(nodes, Interp::smooth, Outside::clamp));
  ASSERT_TRUE(clamp.inverse(target, JointVector::Zero(3), back).ok());
  ASSERT_TRUE(clamp.forward(back, out).ok());
  EXPECT_LE((out.p - target.p).norm(), 1e-9);
}

TEST(VolumetricModel, JacobianMatchesFiniteDifferences) {
  std::mt19937 rng(kSeed + 9);
  const auto map = make_map(random_nodes(rng, 0.05));
  const kin::VolumetricModel cart(std::make_shared<Cartesian>(), map);
  const kin::VolumetricModel table(std::make_shared<CartesianWithTable>(), map);
  std::uniform_real_distribution<double> deg(-180, 180);
  for (int n = 0; n < 50; ++n) {
    const Eigen::Vector3d p = random_inside(rng, *map, 1e-2);
    const JointVector q3 = p;
    EXPECT_LE((kin::jacobian(cart, q3) - kin::numeric_jacobian(cart, q3)).cwiseAbs().maxCoeff(), 1e-7);
    JointVector q4(4);
    q4 << p, deg(rng);
    const kin::Jacobian a = kin::jacobian(table, q4);
    EXPECT_LE((a - kin::numeric_jacobian(table, q4)).cwiseAbs().maxCoeff(), 1e-7) << a;
  }
}

TEST(VolumetricModel, WithValuesWrapsTheBase) {
  const kin::ModelPtr hex = std::make_shared<const kin::Hexapod>(kin::hexapod_design());
  std::mt19937 rng(kSeed + 10);
  // A map over the hexapod's work space (base frame): tip at z = 550 ± 100 mm at home.
  std::vector<Eigen::Vector3d> nodes(5 * 5 * 5);
  std::uniform_real_distribution<double> d(-0.03, 0.03);
  for (auto& e : nodes) e = Eigen::Vector3d(d(rng), d(rng), d(rng));
  const auto map = std::make_shared<const VolumetricMap>(Eigen::Vector3d(-150, -150, 400), Eigen::Vector3d(75, 75, 75),
                                                         Eigen::Vector3i(5, 5, 5), nodes, Interp::smooth);
  const kin::VolumetricModel m(hex, map);
  EXPECT_EQ(m.kind(), "volumetric(hexapod)");
  EXPECT_EQ(m.parameters().size(), 42u);
  std::vector<double> v = m.values();
  v[5] += 0.1;
  const auto changed = m.with_values(v);
  EXPECT_EQ(changed->kind(), "volumetric(hexapod)");
  EXPECT_EQ(changed->values(), v);
  EXPECT_EQ(m.values(), hex->values());
  // Round trip through the decorated hexapod (full pose).
  kin::IkOptions full;
  full.match = kin::PoseMatch::full;
  for (int n = 0; n < 20; ++n) {
    Pose target;
    target.p = Eigen::Vector3d(d(rng), d(rng), 550 + d(rng)) * 2000;
    target.p.z() = 550 + 2000 * d(rng);
    target.r = Eigen::AngleAxisd(0.1 * n / 20, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
    JointVector q;
    ASSERT_TRUE(changed->inverse(target, JointVector::Zero(6), q, full).ok());
    Pose out;
    ASSERT_TRUE(changed->forward(q, out).ok());
    EXPECT_LE((out.p - target.p).norm(), 1e-9);
    EXPECT_LE(kin::rotation_difference(out.r, target.r).norm(), 1e-9);
  }
  const JointVector q0 = JointVector::Zero(6);
  EXPECT_LE((kin::jacobian(m, q0) - kin::numeric_jacobian(m, q0)).cwiseAbs().maxCoeff(), 1e-6);
}

}  // namespace
