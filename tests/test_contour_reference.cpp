// The intended contour (reference.hpp, document 004): B-spline fits through the intended tool
// points and tool-axis marker points of a path, and the contour error of actual poses against them
// (normal distance to the tool-point curve, angle to the fitted tool axis), across fit windows.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "contour_support.hpp"
#include "postproc/machine/program_map.hpp"
#include "postproc/contour/path.hpp"
#include "postproc/contour/reference.hpp"
#include "postproc/error.hpp"
#include "postproc/machine/machine.hpp"

namespace {

namespace ct = postproc::contour;
namespace kin = postproc::kin;
namespace mc = postproc::machine;
namespace gc = postproc::gcode;

constexpr double kPi = kin::kPi;

using pptest::add_run;
using pptest::circle;
using pptest::empty_path;
using pptest::mill;
using pptest::xyz;

constexpr double kRadius = 50;
constexpr int kChords = 3600;
const Eigen::Vector3d kCentreQ(100, 50, -20);

struct CirclePath {
  ct::Path path;
  Eigen::Vector3d centre;  ///< of the tool-tip circle (workpiece frame), mm
};

CirclePath circle_path() {
  CirclePath c;
  c.path = empty_path(mill());
  add_run(c.path, circle(kCentreQ, kRadius, kChords), 2000.0 / 60);
  kin::Pose pose;
  EXPECT_TRUE(mill().actual->forward(xyz(kCentreQ.x(), kCentreQ.y(), kCentreQ.z()), pose).ok());
  c.centre = pose.p;  // linear axes: the tip circle is the joint circle moved by FK(0)
  return c;
}

/// Tight fits (the spline interpolates: its deviation from the true circle is ~1e-9 mm) and short
/// windows, so that queries cross piece boundaries.
ct::ReferenceOptions tight() {
  ct::ReferenceOptions o;
  o.fit.tolerance_mm = 1e-9;
  o.window = 500;
  o.overlap = 32;
  return o;
}

kin::Pose pose_at(const Eigen::Vector3d& p, const Eigen::Matrix3d& r = Eigen::Matrix3d::Identity()) {
  kin::Pose pose;
  pose.p = p;
  pose.r = r;
  return pose;
}

TEST(ContourReference, FitsTheCircleWithinTolerance) {
  const CirclePath c = circle_path();
  const ct::Reference ref(c.path, *mill().actual);
  EXPECT_LE(ref.max_fit_residual_mm(), 1e-4);
  EXPECT_GT(ref.max_fit_residual_mm(), 0.0);  // a least-squares fit, not an interpolation
  EXPECT_TRUE(ref.within_tolerance());
  ASSERT_EQ(ref.runs(), 1U);
  EXPECT_EQ(ref.run(0).begin, 0U);
  EXPECT_EQ(ref.run(0).end, c.path.points.size());
  EXPECT_THROW((void)ref.run(1), postproc::Error);
  for (std::size_t i : {std::size_t{0}, std::size_t{900}, std::size_t{kChords}}) {
    kin::Pose pose;
    ASSERT_TRUE(mill().actual->forward(c.path.points[i].q, pose).ok());
    EXPECT_LT((ref.intended(i).p - pose.p).norm(), 1e-12);
    EXPECT_NEAR((pose.p - c.centre).norm(), kRadius, 1e-9);
  }
  // The fit reaches the tolerance between the points too: the curve stays on the circle.
  for (int k = 0; k < 360; ++k) {
    const double a = 2 * kPi * (k + 0.37) / 360;
    const Eigen::Vector3d p = c.centre + kRadius * Eigen::Vector3d(std::cos(a), std::sin(a), 0);
    const std::size_t hint = static_cast<std::size_t>(std::lround(a / (2 * kPi) * kChords));
    const ct::ContourError e = ref.error(pose_at(p), hint);
    EXPECT_LT(e.distance, 1e-4) << k;
  }
}

TEST(ContourReference, RadialOffsetIsTheContourError) {
  const CirclePath c = circle_path();
  const ct::Reference ref(c.path, *mill().actual, tight());
  EXPECT_LT(ref.max_fit_residual_mm(), 1e-9);
  const double d = 0.010;  // 10 µm
  int checked = 0;
  for (int k = 0; k < 2000; ++k) {
    const double a = 2 * kPi * (k + 0.5) / 2000;  // between and at points, every piece boundary
    const double sign = k % 2 == 0 ? 1 : -1;       // outside and inside
    const Eigen::Vector3d radial(std::cos(a), std::sin(a), 0);
    const Eigen::Vector3d p = c.centre + (kRadius + sign * d) * radial;
    const double exact = a / (2 * kPi) * kChords;  // the point index at this angle
    // A hint a few points off (the commanded point lags or leads the actual one).
    const auto hint = static_cast<std::size_t>(std::clamp<long>(std::lround(exact) + (k % 7) - 3, 0, kChords));
    const ct::ContourError e = ref.error(pose_at(p), hint);
    ASSERT_TRUE(e.converged) << k;
    ASSERT_NEAR(e.distance, d, 1e-7) << k;
    ASSERT_LT((e.vector + sign * d * radial).norm(), 1e-7) << k;  // radial, toward the circle
    ASSERT_NEAR((e.foot - c.centre).norm(), kRadius, 1e-7) << k;
    ASSERT_LE(std::abs(static_cast<double>(e.point) - exact), 0.5 + 1e-9) << k;
    ASSERT_LT(e.angle, 1e-9) << k;
    ++checked;
  }
  EXPECT_EQ(checked, 2000);
}

TEST(ContourReference, TangentialOffsetIsNotAContourError) {
  const CirclePath c = circle_path();
  const ct::Reference ref(c.path, *mill().actual, tight());
  for (std::size_t i : {std::size_t{1}, std::size_t{499}, std::size_t{1234}, std::size_t{2700}}) {
    const double a = 2 * kPi * static_cast<double>(i) / kChords;
    const Eigen::Vector3d tangent(-std::sin(a), std::cos(a), 0);
    const Eigen::Vector3d p = ref.intended(i).p + 0.010 * tangent;  // 10 µm ahead along the path
    const ct::ContourError e = ref.error(pose_at(p), i);
    // Off the circle only by the circle's own curvature: √(R² + d²) − R = 1 nm.
    EXPECT_NEAR(e.distance, std::hypot(kRadius, 0.010) - kRadius, 1e-8) << i;
    EXPECT_LT(e.distance, 2e-6) << i;
  }
}

TEST(ContourReference, TiltedToolAxisIsTheAxisError) {
  const CirclePath c = circle_path();
  const ct::Reference ref(c.path, *mill().actual, tight());
  for (std::size_t i : {std::size_t{10}, std::size_t{1800}, std::size_t{3599}}) {
    const Eigen::Vector3d x = Eigen::Vector3d::UnitX();
    const Eigen::Matrix3d tilt = Eigen::AngleAxisd(1e-4, x).toRotationMatrix();  // 100 µrad about X
    const ct::ContourError e = ref.error(pose_at(ref.intended(i).p, tilt), i);
    EXPECT_NEAR(e.angle, 1e-4, 1e-10) << i;
    EXPECT_LT((e.rotation + 1e-4 * x).norm(), 1e-10) << i;  // back about −X
    EXPECT_LT((e.axis - Eigen::Vector3d::UnitZ()).norm(), 1e-10) << i;
    EXPECT_LT(e.distance, 1e-8) << i;
  }
}

TEST(ContourReference, TracksAcrossPiecesFromAFarHint) {
  // The foot is found on the piece its point belongs to, even from a hint in the neighbouring
  // piece (hint 40 points away, past the overlap of 32).
  const CirclePath c = circle_path();
  const ct::Reference ref(c.path, *mill().actual, tight());
  for (std::size_t i : {std::size_t{460}, std::size_t{468}, std::size_t{500}, std::size_t{936}, std::size_t{1404}}) {
    const double a = 2 * kPi * static_cast<double>(i) / kChords;
    const Eigen::Vector3d radial(std::cos(a), std::sin(a), 0);
    const Eigen::Vector3d p = c.centre + (kRadius + 0.02) * radial;
    for (long off : {-40L, 40L}) {
      const ct::ContourError e = ref.error(pose_at(p), static_cast<std::size_t>(static_cast<long>(i) + off));
      EXPECT_EQ(e.point, i) << i << " " << off;
      EXPECT_NEAR(e.distance, 0.02, 1e-7) << i << " " << off;
    }
  }
}

/// A toy 5-axis model: tool tip = (X, Y, Z) mm, tool axis = Rx(A)·ẑ (A in degrees).
class ToyHead final : public kin::Model {
 public:
  ToyHead() : Model(joints(), {}, {}) {}
  [[nodiscard]] std::string kind() const override { return "toy"; }
  [[nodiscard]] kin::Solve forward(const kin::JointVector& q, kin::Pose& out) const override {
    out.p = q.head<3>();
    out.r = Eigen::AngleAxisd(q[3] * kin::kDeg, Eigen::Vector3d::UnitX()).toRotationMatrix();
    return {};
  }
  [[nodiscard]] std::shared_ptr<const Model> with_values(std::vector<double>) const override {
    return std::make_shared<ToyHead>();
  }

 private:
  static std::vector<kin::Joint> joints() {
    std::vector<kin::Joint> j(4);
    const char* names[] = {"X", "Y", "Z", "A"};
    for (std::size_t k = 0; k < 4; ++k) j[k].name = std::string(names[k]);
    j[3].type = kin::JointType::rotary;
    return j;
  }
};

kin::JointVector xyza(double x, double y, double z, double a) {
  kin::JointVector q(4);
  q << x, y, z, a;
  return q;
}

/// A bare path of 4-joint points (no maps or drives: only the Reference reads it).
ct::Path toy_path(const std::vector<std::vector<kin::JointVector>>& runs) {
  ct::Path p;
  p.joints = 4;
  for (const auto& r : runs) {
    const std::size_t begin = p.points.size();
    for (const auto& q : r) {
      ct::PathPoint pt;
      pt.q = q;
      p.points.push_back(pt);
    }
    p.runs.push_back(ct::Run{begin, p.points.size()});
  }
  return p;
}

kin::Pose toy_pose(double x, double y, double z, double a_deg) {
  kin::Pose p;
  ToyHead h;
  EXPECT_TRUE(h.forward(xyza(x, y, z, a_deg), p).ok());
  return p;
}

TEST(ContourReference, OrientationOnlyMoveUsesTheMarkerCurve) {
  // Run 0: the tip stays at (10, 0, 0) while A turns 0 → 30° in 1° steps: every tip point is the
  // same, so only the marker curve says where along the run a pose is.
  std::vector<kin::JointVector> turn;
  for (int k = 0; k <= 30; ++k) turn.push_back(xyza(10, 0, 0, k));
  const ct::Path p = toy_path({turn});
  const ToyHead head;
  const ct::Reference ref(p, head);
  EXPECT_TRUE(ref.within_tolerance());
  for (double a : {0.0, 3.3, 10.25, 17.6, 29.9}) {
    const ct::ContourError e = ref.error(toy_pose(10, 0, 0, a), 15);
    EXPECT_LT(e.angle, 1e-5) << a;  // the intended axis at the actual one's place on the turn
    EXPECT_LT(e.distance, 1e-12) << a;
    EXPECT_EQ(e.point, static_cast<std::size_t>(std::lround(a))) << a;
    EXPECT_TRUE(e.converged) << a;
  }
  // Tilted out of the plane of the turn (the YZ plane): the axis error is the angle to that plane.
  kin::Pose off = toy_pose(10, 0, 0, 12.5);
  off.r = Eigen::AngleAxisd(1e-3, Eigen::Vector3d::UnitY()).toRotationMatrix() * off.r;
  const ct::ContourError e = ref.error(off, 12);
  EXPECT_NEAR(e.angle, std::asin(std::abs(off.axis().x())), 1e-6);
  EXPECT_GT(e.angle, 0.9e-3);
}

TEST(ContourReference, AxisIsInterpolatedAlongAFiveAxisMove) {
  // X 0 → 30 mm while A 0 → 30°, 31 points: the intended axis at X = x is Rx(x°)·ẑ.
  std::vector<kin::JointVector> move;
  for (int k = 0; k <= 30; ++k) move.push_back(xyza(k, 0, 0, k));
  const ToyHead head;
  ct::ReferenceOptions o;
  o.fit.tolerance_mm = 1e-8;  // so that the fits' own deviation stays well below the 1 µrad checked
  const ct::Reference ref(toy_path({move}), head, o);
  for (double x : {0.5, 7.75, 15.0, 22.2}) {
    const kin::Pose actual = toy_pose(x, 0.004, 0, x + 0.01);  // 4 µm off in Y, 0.01° more A
    const ct::ContourError e = ref.error(actual, static_cast<std::size_t>(x));
    EXPECT_NEAR(e.distance, 0.004, 1e-6) << x;
    EXPECT_NEAR(e.angle, 0.01 * kin::kDeg, 1e-6) << x;
    const Eigen::Vector3d axis = Eigen::AngleAxisd(x * kin::kDeg, Eigen::Vector3d::UnitX()) * Eigen::Vector3d::UnitZ();
    EXPECT_LT((e.axis - axis).norm(), 1e-6) << x;
  }
}

TEST(ContourReference, SinglePointRunsArePlainDistances) {
  const ToyHead head;
  const ct::Path p = toy_path({{xyza(0, 0, 0, 0), xyza(5, 0, 0, 0)}, {xyza(1, 2, 3, 20)}, {xyza(4, 4, 4, 0), xyza(4, 4, 4, 0)}});
  const ct::Reference ref(p, head);
  ASSERT_EQ(ref.runs(), 3U);
  const ct::ContourError e = ref.error(toy_pose(1, 2, 3.5, 20.5), 2);
  EXPECT_NEAR(e.distance, 0.5, 1e-12);
  EXPECT_LT((e.vector - Eigen::Vector3d(0, 0, -0.5)).norm(), 1e-12);
  EXPECT_NEAR(e.angle, 0.5 * kin::kDeg, 1e-12);
  EXPECT_EQ(e.point, 2U);
  // A run of two coincident poses has no curve either.
  const ct::ContourError f = ref.error(toy_pose(4, 4, 5, 0), 4);
  EXPECT_NEAR(f.distance, 1.0, 1e-12);
  EXPECT_EQ(f.point, 3U);
  // The straight run: exact segment.
  const ct::ContourError g = ref.error(toy_pose(2.5, 0.3, 0, 0), 0);
  EXPECT_NEAR(g.distance, 0.3, 1e-12);
  EXPECT_EQ(g.point, 0U);
  EXPECT_THROW((void)ref.error(toy_pose(0, 0, 0, 0), 5), postproc::Error);  // no such point
}

TEST(ContourReference, RepeatedPointDoesNotHideACorner) {
  // X 0 → 10, the point 10 again (a zero-length block), then Y 0 → 10 in 1 mm steps: the path
  // turns 90° at (10, 0, 0). The repeated point must not hide the corner from the span cut (a
  // cubic through it would overshoot): the actual tip on the straight first move is on the
  // contour, and so is one on the second.
  std::vector<kin::JointVector> pts;
  for (int k = 0; k <= 10; ++k) pts.push_back(xyza(k, 0, 0, 0));
  pts.push_back(xyza(10, 0, 0, 0));
  for (int k = 1; k <= 10; ++k) pts.push_back(xyza(10, k, 0, 0));
  const ToyHead head;
  const ct::Reference ref(toy_path({pts}), head);
  for (double x : {8.5, 9.2, 9.7, 9.95}) {
    const ct::ContourError e = ref.error(toy_pose(x, 0, 0, 0), static_cast<std::size_t>(x));
    EXPECT_LT(e.distance, 1e-6) << x;
  }
  for (double y : {0.05, 0.3, 0.8, 1.5}) {
    const ct::ContourError e = ref.error(toy_pose(10, y, 0, 0), 12);
    EXPECT_LT(e.distance, 1e-6) << y;
  }
}

TEST(ContourReference, FootPastASharpCornerIsOnTheNextSpan) {
  // X 0 → 10 in 0.5 mm steps, then back at 160° (1 mm steps): a tool 0.45 mm past the corner,
  // 1 µm above the path, searched from the corner point (which belongs to the first span). The
  // first span's curve has a false local minimum 0.15 mm away, near its point before the corner;
  // the foot is on the second span, 1 µm away (simulate once reported 204 µm there for one
  // sample of a Siemens sample, which made the verification withhold a good correction).
  std::vector<kin::JointVector> pts;
  for (int k = 0; k <= 20; ++k) pts.push_back(xyza(0.5 * k, 0, 0, 0));
  const Eigen::Vector2d d(std::cos(160 * kin::kDeg), std::sin(160 * kin::kDeg));
  for (int j = 1; j <= 10; ++j) pts.push_back(xyza(10 + j * d.x(), j * d.y(), 0, 0));
  const ToyHead head;
  const ct::Reference ref(toy_path({pts}), head);
  const ct::ContourError e = ref.error(toy_pose(10 + 0.45 * d.x(), 0.45 * d.y(), 0.001, 0), 20, 21, 0.45);
  EXPECT_NEAR(e.distance, 0.001, 1e-6);
}

TEST(ContourReference, RejectsBadOptions) {
  const ToyHead head;
  const ct::Path p = toy_path({{xyza(0, 0, 0, 0), xyza(5, 0, 0, 0)}});
  ct::ReferenceOptions o;
  o.marker_length_mm = 0;
  EXPECT_THROW(ct::Reference(p, head, o), postproc::Error);
  o = {};
  o.window = 8;
  o.overlap = 8;
  EXPECT_THROW(ct::Reference(p, head, o), postproc::Error);
}

TEST(ContourReference, Summary) {
  const std::vector<double> v{3, 1, 4, 1, 5, 9, 2, 6, 5, 3, 5, 8, 9, 7, 9, 3, 2, 3, 8, 4};
  const ct::Summary s = ct::summarise(v);
  EXPECT_EQ(s.count, 20U);
  EXPECT_EQ(s.max, 9);
  EXPECT_EQ(s.worst, 5U);  // the first 9
  double sum2 = 0;
  for (double x : v) sum2 += x * x;
  EXPECT_DOUBLE_EQ(s.rms, std::sqrt(sum2 / 20));
  EXPECT_EQ(s.p95, 9);  // nearest rank ⌈19⌉ = 19th of 1 1 2 2 3 3 3 3 4 4 5 5 5 6 7 8 8 9 9 9
  std::vector<double> ramp;
  for (int i = 1; i <= 100; ++i) ramp.push_back(i);
  EXPECT_EQ(ct::summarise(ramp).p95, 95);
  EXPECT_EQ(ct::summarise({0.25}).p95, 0.25);
  const ct::Summary e = ct::summarise({});
  EXPECT_EQ(e.count, 0U);
  EXPECT_EQ(e.max, 0);
  EXPECT_EQ(e.rms, 0);
  EXPECT_EQ(e.p95, 0);
}

TEST(ContourReference, QueryRate) {
  // Not a benchmark: a guard against a pathological slowdown (an allocation or a global search per
  // query). The rate is printed for the record.
  const CirclePath c = circle_path();
  const ct::Reference ref(c.path, *mill().actual);
  const int n = 200000;
  std::size_t hint = 0;
  double sum = 0;
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < n; ++k) {
    const double a = 0.01 + (2 * kPi - 0.02) * k / n;  // the run is open at angle 0
    const Eigen::Vector3d p = c.centre + (kRadius - 0.012) * Eigen::Vector3d(std::cos(a), std::sin(a), 0);
    const ct::ContourError e = ref.error(pose_at(p), hint);
    hint = e.point;
    sum += e.distance;
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("[ rate     ] %.3g error() queries/s (%d queries, %.3f s)\n", n / s, n, s);
  EXPECT_NEAR(sum / n, 0.012, 1e-4);
  EXPECT_GT(n / s, 2e3);
}

}  // namespace
