// Serial-chain machines: nominal forward kinematics against hand-computed values, the documented
// action of each error parameter, FK→IK round trips with random errors and error-motion tables,
// the analytic Jacobian against central differences, orientation branches, travel limits and
// configuration errors. Random tests use a fixed seed; POSTPROC_TEST_COUNT raises the count.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "postproc/error.hpp"
#include "postproc/kinematics/serial.hpp"

namespace {

using namespace postproc::kin;
using Eigen::Vector3d;
constexpr unsigned kSeed = 20240604;
constexpr double kInf = std::numeric_limits<double>::infinity();

int count(int dflt) {
  const char* e = std::getenv("POSTPROC_TEST_COUNT");
  return e ? std::max(dflt, std::atoi(e)) : dflt;
}

SerialAxis linear(const std::string& name, Vector3d dir, double lo, double hi) {
  SerialAxis a;
  a.name = name;
  a.direction = dir;
  a.min = lo;
  a.max = hi;
  return a;
}

SerialAxis rotary(const std::string& name, Vector3d dir, Vector3d pivot, double lo = -kInf, double hi = kInf) {
  SerialAxis a = linear(name, dir, lo, hi);
  a.type = JointType::rotary;
  a.pivot = pivot;
  return a;
}

// A machine to test, with the rotary joint whose angle `singular` makes the tool axis parallel to
// the other rotary axis (random samples keep 5° away from it).
struct Machine {
  std::string name;
  SerialConfig cfg;
  int tilt = -1;
  double singular = 0;
};

// Tool side X Y Z from the bed; spindle gauge point `spindle`, tool along +Z.
void xyz_head(SerialConfig& c, Vector3d spindle, double length) {
  c.tool_side = {linear("X", Vector3d::UnitX(), -500, 500), linear("Y", Vector3d::UnitY(), -400, 400),
                 linear("Z", Vector3d::UnitZ(), -400, 100)};
  c.spindle_point = spindle;
  c.tool_length = length;
}

// 3-axis: the table carries Y (program +Y moves the tool +Y on the part, so the table moves −Y).
Machine three_axis() {
  Machine m{"xyz", {}, -1, 0};
  m.cfg.workpiece_side = {linear("Y", -Vector3d::UnitY(), -300, 300)};
  m.cfg.tool_side = {linear("X", Vector3d::UnitX(), -500, 500), linear("Z", Vector3d::UnitZ(), -400, 100)};
  m.cfg.spindle_point = Vector3d(0, 0, 300);
  m.cfg.tool_length = 100;
  return m;
}

// A/C trunnion: A about X through the origin, C about Z through (10, 0, 0); tip at (0, 0, 100).
Machine table_ac() {
  Machine m{"table_ac", {}, 0, 0};
  m.cfg.workpiece_side = {rotary("A", Vector3d::UnitX(), Vector3d::Zero(), -110, 30),
                          rotary("C", Vector3d::UnitZ(), Vector3d(10, 0, 0), -720, 720)};
  xyz_head(m.cfg, Vector3d(0, 0, 200), 100);
  return m;
}

Machine table_bc() {
  Machine m{"table_bc", {}, 0, 0};
  m.cfg.workpiece_side = {rotary("B", Vector3d::UnitY(), Vector3d::Zero(), -100, 100),
                          rotary("C", Vector3d::UnitZ(), Vector3d::Zero())};
  xyz_head(m.cfg, Vector3d(0, 0, 200), 100);
  return m;
}

// Fork head: C then B on the tool side, B's line 100 mm above the gauge point; tip at (0, 0, 50).
Machine head_head() {
  Machine m{"head_head", {}, 4, 0};
  xyz_head(m.cfg, Vector3d(0, 0, 100), 50);
  m.cfg.tool_side.push_back(rotary("C", Vector3d::UnitZ(), Vector3d::Zero(), -360, 360));
  m.cfg.tool_side.push_back(rotary("B", Vector3d::UnitY(), Vector3d(0, 0, 150), -100, 100));
  return m;
}

Machine head_table() {
  Machine m{"head_table", {}, 4, 0};
  m.cfg.workpiece_side = {rotary("C", Vector3d::UnitZ(), Vector3d::Zero())};
  xyz_head(m.cfg, Vector3d(0, 0, 100), 50);
  m.cfg.tool_side.push_back(rotary("B", Vector3d::UnitY(), Vector3d(0, 0, 150), -100, 100));
  return m;
}

// The 4-axis lathe of document 004: bed → X → C → workpiece, bed → Z → B → tool. X moves the
// headstock, so it points along −X (program +X puts the tool at +X on the part). At B = 0 the
// tool lies radially: its axis (tip → holder) is +X; B turns it about a line parallel to Y
// through (200, 0, 0); gauge point (150, 0, 0), tool 50 long, so the tip is at (100, 0, 0).
Machine lathe() {
  Machine m{"lathe_xzbc", {}, 3, 90};
  m.cfg.workpiece_side = {linear("X", -Vector3d::UnitX(), -50, 300),
                          rotary("C", Vector3d::UnitZ(), Vector3d::Zero(), -720, 720)};
  m.cfg.tool_side = {linear("Z", Vector3d::UnitZ(), -500, 50),
                     rotary("B", Vector3d::UnitY(), Vector3d(200, 0, 0), -80, 80)};
  m.cfg.spindle_point = Vector3d(150, 0, 0);
  m.cfg.tool_axis = Vector3d::UnitX();
  m.cfg.tool_x = Vector3d::UnitZ();
  m.cfg.tool_length = 50;
  return m;
}

std::vector<Machine> machines() { return {three_axis(), table_ac(), table_bc(), head_head(), head_table(), lathe()}; }

JointVector qv(std::initializer_list<double> v) {
  JointVector q(static_cast<Eigen::Index>(v.size()));
  Eigen::Index i = 0;
  for (double x : v) q[i++] = x;
  return q;
}

Pose fk(const Model& m, const JointVector& q) {
  Pose p;
  EXPECT_TRUE(forward(m, q, p).ok());
  return p;
}

::testing::AssertionResult near(const Vector3d& a, const Vector3d& b, double tol = 1e-9) {
  if ((a - b).norm() <= tol) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "(" << a.transpose() << ") vs (" << b.transpose() << ")";
}

std::pair<double, double> travel(const SerialAxis& a) {
  const double span = a.type == JointType::rotary ? 360 : 400;
  return {std::isfinite(a.min) ? a.min : -span, std::isfinite(a.max) ? a.max : span};
}

// 21-row tables on every axis: tens of µm, tens of arcsec.
void add_tables(SerialConfig& c, std::mt19937& rng) {
  std::uniform_real_distribution<double> mm(-0.02, 0.02);
  std::uniform_real_distribution<double> rad(-1e-4, 1e-4);
  for (auto* side : {&c.workpiece_side, &c.tool_side})
    for (auto& a : *side) {
      const auto [lo, hi] = travel(a);
      a.table = {};
      for (int r = 0; r <= 20; ++r) {
        a.table.position.push_back(lo + (hi - lo) * r / 20.0);
        a.table.error.push_back({mm(rng), mm(rng), mm(rng), rad(rng), rad(rng), rad(rng)});
      }
    }
}

std::vector<double> random_errors(const Model& m, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> v;
  for (const auto& p : m.parameters())
    v.push_back(!p.error ? p.nominal : u(rng) * (p.unit == "mm" ? 0.05 : 2.5e-4));
  return v;
}

// The nominal machine's config with tables, and that machine with random errors.
std::shared_ptr<const Model> actual_machine(const Machine& mc, std::mt19937& rng) {
  SerialConfig c = mc.cfg;
  add_tables(c, rng);
  const SerialModel base(c);
  return base.with_values(random_errors(base, rng));
}

JointVector random_q(const Machine& mc, std::mt19937& rng) {
  std::vector<const SerialAxis*> axes;
  for (const auto& a : mc.cfg.workpiece_side) axes.push_back(&a);
  for (const auto& a : mc.cfg.tool_side) axes.push_back(&a);
  JointVector q(static_cast<Eigen::Index>(axes.size()));
  for (std::size_t j = 0; j < axes.size(); ++j) {
    const auto [lo, hi] = travel(*axes[j]);
    std::uniform_real_distribution<double> u(lo, hi);
    const auto i = static_cast<Eigen::Index>(j);
    do q[i] = u(rng);
    while (static_cast<int>(j) == mc.tilt && std::abs(q[i] - mc.singular) < 5);
  }
  return q;
}

double angle(const Pose& a, const Pose& b) { return rotation_difference(a.r, b.r).norm(); }

TEST(KinSerial, NominalForwardByHand) {
  {
    const SerialModel m(three_axis().cfg);  // joints Y X Z
    const Pose p = fk(m, qv({10, 5, -3}));
    EXPECT_TRUE(near(p.p, Vector3d(5, 10, 197)));
    EXPECT_TRUE(near(p.axis(), Vector3d::UnitZ()));
  }
  {
    const SerialModel m(table_ac().cfg);  // joints A C X Y Z
    EXPECT_TRUE(near(fk(m, qv({0, 0, 0, 0, 0})).p, Vector3d(0, 0, 100)));
    // C = 90° turns the table about the line x = 10: the bed point (50, 0, 100) is (10, −40, 100).
    const Pose c90 = fk(m, qv({0, 90, 50, 0, 0}));
    EXPECT_TRUE(near(c90.p, Vector3d(10, -40, 100)));
    EXPECT_TRUE(near(c90.axis(), Vector3d::UnitZ()));
    const Pose a90 = fk(m, qv({90, 0, 0, 0, 0}));
    EXPECT_TRUE(near(a90.p, Vector3d(0, 100, 0)));
    EXPECT_TRUE(near(a90.axis(), Vector3d::UnitY()));
    const Pose both = fk(m, qv({90, 90, 0, 0, 0}));
    EXPECT_TRUE(near(both.p, Vector3d(110, 10, 0)));
    EXPECT_TRUE(near(both.axis(), Vector3d::UnitX()));
    EXPECT_TRUE(near(m.machine_to_workpiece(qv({0, 90, 0, 0, 0})) * Vector3d::UnitX(), -Vector3d::UnitY()));
  }
  {
    const SerialModel m(table_bc().cfg);
    const Pose p = fk(m, qv({90, 0, 0, 0, 0}));
    EXPECT_TRUE(near(p.p, Vector3d(-100, 0, 0)));
    EXPECT_TRUE(near(p.axis(), -Vector3d::UnitX()));
  }
  {
    const SerialModel m(head_head().cfg);  // joints X Y Z C B
    const Pose b90 = fk(m, qv({0, 0, 0, 0, 90}));
    EXPECT_TRUE(near(b90.p, Vector3d(-100, 0, 150)));
    EXPECT_TRUE(near(b90.axis(), Vector3d::UnitX()));
    const Pose cb = fk(m, qv({10, 20, 30, 90, 90}));
    EXPECT_TRUE(near(cb.p, Vector3d(10, -80, 180)));
    EXPECT_TRUE(near(cb.axis(), Vector3d::UnitY()));
    EXPECT_TRUE(m.machine_to_workpiece(qv({0, 0, 0, 90, 90})).isIdentity(1e-15));
  }
  {
    const SerialModel m(head_table().cfg);  // joints C X Y Z B
    const Pose p = fk(m, qv({90, 0, 0, 0, 90}));
    EXPECT_TRUE(near(p.p, Vector3d(0, 100, 150)));
    EXPECT_TRUE(near(p.axis(), -Vector3d::UnitY()));
  }
  {
    const SerialModel m(lathe().cfg);  // joints X C Z B
    const Pose zero = fk(m, qv({0, 0, 0, 0}));
    EXPECT_TRUE(near(zero.p, Vector3d(100, 0, 0)));
    EXPECT_TRUE(near(zero.axis(), Vector3d::UnitX()));
    EXPECT_TRUE(near(zero.r.col(0), Vector3d::UnitZ()));
    EXPECT_TRUE(near(fk(m, qv({10, 0, 20, 0})).p, Vector3d(110, 0, 20)));
    EXPECT_TRUE(near(fk(m, qv({0, 90, 0, 0})).p, Vector3d(0, -100, 0)));
    const Pose b90 = fk(m, qv({0, 0, 0, 90}));
    EXPECT_TRUE(near(b90.p, Vector3d(200, 0, 100)));
    EXPECT_TRUE(near(b90.axis(), -Vector3d::UnitZ()));
  }
}

TEST(KinSerial, ParameterNamesAreIso) {
  const auto names = [](const Machine& mc) {
    const SerialModel m(mc.cfg);
    std::vector<std::string> v;
    for (const auto& p : m.parameters()) v.push_back(p.name);
    return v;
  };
  EXPECT_EQ(names(table_ac()), (std::vector<std::string>{"EY0A", "EZ0A", "EB0A", "EC0A", "EA0A", "EX0C", "EY0C",
                                                         "EA0C", "EB0C", "EC0C", "EX0X", "EXX.scale", "EY0Y",
                                                         "EYY.scale", "EZ0Z", "EZZ.scale", "EC0Y", "EB0Z", "EA0Z",
                                                         "tool.length"}));
  EXPECT_EQ(names(head_head()), (std::vector<std::string>{"EX0X", "EXX.scale", "EY0Y", "EYY.scale", "EZ0Z",
                                                          "EZZ.scale", "EX0C", "EY0C", "EA0C", "EB0C", "EC0C", "EX0B",
                                                          "EZ0B", "EA0B", "EC0B", "EB0B", "EC0Y", "EB0Z", "EA0Z",
                                                          "tool.length"}));
  // The X Z B C lathe: the centre height is EY0C (the spindle's line along Y), the lean of X
  // against the spindle EB0Z (Z's direction turned about Y, i.e. X–Z squareness), the tool length
  // "tool.length" (freed with --free), positioning scale errors EXX.scale / EZZ.scale.
  EXPECT_EQ(names(lathe()), (std::vector<std::string>{"EX0X", "EXX.scale", "EX0C", "EY0C", "EA0C", "EB0C", "EC0C",
                                                      "EZ0Z", "EZZ.scale", "EX0B", "EZ0B", "EA0B", "EC0B", "EB0B",
                                                      "EB0Z", "tool.length"}));
  EXPECT_EQ(names(three_axis()).size(), 10u);  // EX0X EXX.scale … EC0Y EB0Z EA0Z tool.length
  const SerialModel m(table_ac().cfg);
  for (const auto& p : m.parameters()) {
    EXPECT_FALSE(p.description.empty()) << p.name;
    EXPECT_TRUE(p.unit == "mm" || p.unit == "rad" || (p.unit == "ratio" && p.name.ends_with(".scale"))) << p.name;
    EXPECT_EQ(p.error, p.name != "tool.length");
  }
  EXPECT_EQ(m.parameters()[static_cast<std::size_t>(m.parameter_index("EA0C"))].unit, "rad");
  EXPECT_EQ(m.parameters().back().nominal, 100);
  EXPECT_EQ(m.joints()[1].name, "C");
  EXPECT_EQ(m.joints()[1].type, JointType::rotary);
  EXPECT_EQ(m.joints()[1].max, 720);
}

// One error at a time on the A/C trunnion, against the conventions of serial.hpp.
std::shared_ptr<const Model> with(const SerialModel& m, const std::string& name, double v) {
  std::vector<double> vals = m.values();
  vals.at(static_cast<std::size_t>(m.parameter_index(name))) = v;
  return m.with_values(vals);
}

TEST(KinSerial, ErrorParametersActAsDocumented) {
  const SerialModel m(table_ac().cfg);
  const double e = 1e-3;
  // The C line moves to x = 10.01; at C = 180° the bed point (50, 0, 100) lands at −29.98.
  EXPECT_TRUE(near(fk(*with(m, "EX0C", 0.01), qv({0, 180, 50, 0, 0})).p, Vector3d(-29.98, 0, 100)));
  // The zero-position error adds to the commanded angle.
  EXPECT_TRUE(near(fk(*with(m, "EC0C", e), qv({0, 0, 50, 0, 0})).p,
                   Vector3d(10 + 40 * std::cos(e), -40 * std::sin(e), 100)));
  // EA0C tilts C's +Z toward −Y: the table turns about (0, −sin e, cos e).
  const Vector3d c_dir(0, -std::sin(e), std::cos(e));
  const Eigen::Matrix3d turned = Eigen::AngleAxisd(kPi / 2, c_dir).toRotationMatrix().transpose();
  EXPECT_TRUE(with(m, "EA0C", e)->machine_to_workpiece(qv({0, 90, 0, 0, 0})).isApprox(turned, 1e-14));
  EXPECT_TRUE(near(fk(*with(m, "EX0X", 0.01), qv({0, 0, 50, 0, 0})).p, Vector3d(50.01, 0, 100)));
  EXPECT_TRUE(near(fk(*with(m, "EC0Y", e), qv({0, 0, 0, 100, 0})).p,
                   Vector3d(-100 * std::sin(e), 100 * std::cos(e), 100)));
  EXPECT_TRUE(near(fk(*with(m, "EB0Z", e), qv({0, 0, 0, 0, -100})).p,
                   Vector3d(-100 * std::sin(e), 0, 100 - 100 * std::cos(e))));
  EXPECT_TRUE(near(fk(*with(m, "EA0Z", e), qv({0, 0, 0, 0, -100})).p,
                   Vector3d(0, 100 * std::sin(e), 100 - 100 * std::cos(e))));
  EXPECT_TRUE(near(fk(*with(m, "tool.length", 101), qv({0, 0, 0, 0, 0})).p, Vector3d(0, 0, 99)));

  // Error-motion table of X: δ then a pitch about Y, about the carried origin (s, 0, 0).
  SerialConfig c = table_ac().cfg;
  c.tool_side[0].table.position = {0, 100};
  c.tool_side[0].table.error = {{0, 0, 0, 0, e, 0}, {0, 0.02, 0, 0, e, 0}};
  const SerialModel t(c);
  EXPECT_TRUE(near(fk(t, qv({0, 0, 25, 0, 0})).p, Vector3d(25 + 100 * std::sin(e), 0.005, 100 * std::cos(e))));
  EXPECT_NEAR(fk(t, qv({0, 0, -50, 0, 0})).p.y(), 0, 1e-12);     // constant before the first row
  EXPECT_NEAR(fk(t, qv({0, 0, 150, 0, 0})).p.y(), 0.02, 1e-12);  // and after the last
  EXPECT_TRUE(near(fk(*t.without_tables(), qv({0, 0, 25, 0, 0})).p, Vector3d(25, 0, 100)));
}

TEST(KinSerial, RoundTripsWithErrorsAndTables) {
  std::mt19937 rng(kSeed);
  const int n = count(500);
  for (const Machine& mc : machines()) {
    const auto m = actual_machine(mc, rng);
    std::uniform_real_distribution<double> nudge(-0.3, 0.3);
    double worst_q = 0;
    for (int i = 0; i < n; ++i) {
      const JointVector q0 = random_q(mc, rng);
      const Pose target = fk(*m, q0);
      JointVector start = q0;
      for (Eigen::Index j = 0; j < start.size(); ++j) start[j] += nudge(rng);
      JointVector q;
      const Solve s = inverse(*m, target, start, q);
      ASSERT_TRUE(s.ok()) << mc.name << " #" << i << ": " << to_string(s.status) << " q0 " << q0.transpose();
      const Pose got = fk(*m, q);
      ASSERT_LE((got.p - target.p).norm(), 1e-9) << mc.name << " #" << i;
      ASSERT_LE(angle(got, target), 1e-9) << mc.name << " #" << i;
      worst_q = std::max(worst_q, (q - q0).cwiseAbs().maxCoeff());
    }
    EXPECT_LE(worst_q, 1e-8) << mc.name;
  }
}

// Unevenly spaced table rows (looked up by search, not by the row spacing): round trips and the
// analytic Jacobian still hold.
TEST(KinSerial, UnevenTablesRoundTrip) {
  std::mt19937 rng(kSeed + 5);
  std::uniform_real_distribution<double> mm(-0.02, 0.02);
  std::uniform_real_distribution<double> rad(-1e-4, 1e-4);
  const Machine mc = table_ac();
  SerialConfig c = mc.cfg;
  for (auto* side : {&c.workpiece_side, &c.tool_side})
    for (auto& a : *side) {
      const auto [lo, hi] = travel(a);
      for (int r = 0; r <= 15; ++r) {
        const double f = r / 15.0;
        a.table.position.push_back(lo + (hi - lo) * f * f);
        a.table.error.push_back({mm(rng), mm(rng), mm(rng), rad(rng), rad(rng), rad(rng)});
      }
    }
  const SerialModel base(c);
  const auto m = base.with_values(random_errors(base, rng));
  std::uniform_real_distribution<double> nudge(-0.3, 0.3);
  for (int i = 0; i < count(300); ++i) {
    const JointVector q0 = random_q(mc, rng);
    const Pose target = fk(*m, q0);
    JointVector start = q0;
    for (Eigen::Index j = 0; j < start.size(); ++j) start[j] += nudge(rng);
    JointVector q;
    const Solve s = inverse(*m, target, start, q);
    ASSERT_TRUE(s.ok()) << i << ": " << to_string(s.status);
    const Pose got = fk(*m, q);
    ASSERT_LE((got.p - target.p).norm(), 1e-9) << i;
    ASSERT_LE(angle(got, target), 1e-9) << i;
    EXPECT_LE((q - q0).cwiseAbs().maxCoeff(), 1e-8) << i;
    if (i < 50) {
      const Jacobian a = jacobian(*m, q0);
      const Jacobian d = numeric_jacobian(*m, q0);
      ASSERT_LE(((a - d).array().abs() / (1 + d.array().abs())).maxCoeff(), 2e-7) << i;
    }
  }
}

TEST(KinSerial, InverseKeepsTheTurnOfStart) {
  std::mt19937 rng(kSeed + 1);
  const auto m = actual_machine(table_ac(), rng);
  const JointVector q0 = qv({-40, 370, 30, -20, -50});
  JointVector q;
  ASSERT_TRUE(inverse(*m, fk(*m, q0), qv({-39.8, 369.7, 30.2, -20, -50}), q).ok());
  EXPECT_NEAR(q[1], 370, 1e-8);
  EXPECT_LE((q - q0).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(KinSerial, AnalyticJacobianMatchesDifferences) {
  std::mt19937 rng(kSeed + 2);
  for (const Machine& mc : machines()) {
    const auto m = actual_machine(mc, rng);
    const auto ideal = SerialModel(mc.cfg);
    for (int i = 0; i < 50; ++i) {
      const JointVector q = random_q(mc, rng);
      const Jacobian a = jacobian(*m, q);
      const Jacobian d = numeric_jacobian(*m, q);
      ASSERT_EQ(a.cols(), m->joint_count());
      const double err = ((a - d).array().abs() / (1 + d.array().abs())).maxCoeff();
      ASSERT_LE(err, 2e-7) << mc.name << " #" << i << "\n" << a << "\n" << d;
      // The tables' slopes are part of it: the actual Jacobian differs from the ideal one.
      if (i == 0) {
        EXPECT_GT((a - jacobian(ideal, q)).cwiseAbs().maxCoeff(), 1e-5) << mc.name;
      }
    }
  }
}

TEST(KinSerial, OrientationBranchesAndTheNearestOne) {
  const SerialModel m(table_ac().cfg);
  const Vector3d o = fk(m, qv({-30, 40, 0, 0, 0})).axis();
  const auto c = m.orientation_candidates(o, qv({0, 100, 1, 2, 3}));
  ASSERT_EQ(c.size(), 2u);
  bool seen[2] = {false, false};
  for (const JointVector& q : c) {
    EXPECT_TRUE(near(fk(m, q).axis(), o, 1e-12));
    EXPECT_EQ(q[2], 1);  // linear joints keep start
    EXPECT_EQ(q[4], 3);
    if (std::abs(q[0] + 30) < 1e-9 && std::abs(q[1] - 40) < 1e-9) seen[0] = true;
    if (std::abs(q[0] - 30) < 1e-9 && std::abs(q[1] - 220) < 1e-9) seen[1] = true;  // C in the turn nearest 100
  }
  EXPECT_TRUE(seen[0] && seen[1]);
  EXPECT_TRUE(m.orientation_candidates(o, qv({0, 100, 0, 0, 0})).size() == 2);
  EXPECT_TRUE(SerialModel(three_axis().cfg).orientation_candidates(o, qv({0, 0, 0})).empty());
  EXPECT_TRUE(SerialModel(head_table().cfg).orientation_candidates(o, qv({0, 0, 0, 0, 0})).size() == 2);

  // From A = 0 (singular: C does not turn the tool) Newton cannot start; the seeds find both
  // branches and the nearest to start (A −30, C 40) is kept …
  const JointVector q1 = qv({-30, 40, 50, -20, -30});
  const Pose target = fk(m, q1);
  JointVector q;
  ASSERT_TRUE(inverse(m, target, qv({0, 100, 0, 0, 0}), q).ok());
  EXPECT_LE((q - q1).cwiseAbs().maxCoeff(), 1e-8);
  // … unless it is outside the travel: with A limited to [0, 30] the other branch is taken.
  SerialConfig cfg = table_ac().cfg;
  cfg.workpiece_side[0].min = 0;
  const SerialModel limited(cfg);
  const Solve s = inverse(limited, target, qv({0, 100, 0, 0, 0}), q);
  ASSERT_TRUE(s.ok()) << to_string(s.status);
  EXPECT_NEAR(q[0], 30, 1e-8);
  EXPECT_NEAR(q[1], 220, 1e-8);
  const Pose got = fk(limited, q);
  EXPECT_TRUE(near(got.p, target.p));
  EXPECT_TRUE(near(got.axis(), target.axis()));
}

TEST(KinSerial, OutOfLimitsIsReportedWithTheValues) {
  const SerialModel m(table_ac().cfg);
  const JointVector q0 = qv({-20, 10, 600, 0, 0});  // X beyond 500
  JointVector q;
  const Solve s = inverse(m, fk(m, q0), q0, q);
  EXPECT_EQ(s.status, Status::out_of_limits);
  EXPECT_EQ(s.joint, 2);
  EXPECT_LE((q - q0).cwiseAbs().maxCoeff(), 1e-9);
  IkOptions off;
  off.check_limits = false;
  EXPECT_TRUE(inverse(m, fk(m, q0), q0, q, off).ok());
}

TEST(KinSerial, RemapMatchesWhatTheMachineCan) {
  std::mt19937 rng(kSeed + 3);
  for (const Machine& mc : {three_axis(), lathe(), table_ac()}) {
    const auto actual = actual_machine(mc, rng);
    const SerialModel nominal(mc.cfg);
    for (int i = 0; i < 100; ++i) {
      const JointVector q0 = random_q(mc, rng);
      const Pose target = fk(nominal, q0);
      JointVector q;
      IkOptions opt;
      opt.check_limits = false;
      const Solve s = inverse(*actual, target, q0, q, opt);
      ASSERT_TRUE(s.ok()) << mc.name << " #" << i << " " << to_string(s.status);
      const Pose got = fk(*actual, q);
      EXPECT_LE((got.p - target.p).norm(), 1e-9) << mc.name;
      // 3-axis and lathe: the point is matched; the axis deviation the machine cannot remove is
      // reported (tens of arcsec), not hidden.
      EXPECT_NEAR(s.residual_rad, std::acos(std::min(1.0, got.axis().dot(target.axis()))), 1e-7) << mc.name;
      EXPECT_LE(s.residual_rad, mc.name == "table_ac" ? 1e-12 : 2e-3) << mc.name;
    }
  }
}

TEST(KinSerial, FullMatchFallsBackToTheAxisOnFiveJoints) {
  const SerialModel m(head_head().cfg);
  const JointVector q0 = qv({10, 20, -30, 40, 50});
  IkOptions opt;
  opt.match = PoseMatch::full;
  JointVector q;
  ASSERT_TRUE(inverse(m, fk(m, q0), q0 + qv({0.1, 0.1, 0.1, 0.1, 0.1}), q, opt).ok());
  EXPECT_LE((q - q0).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(KinSerial, WithValuesLeavesTheOriginal) {
  std::mt19937 rng(kSeed + 4);
  const SerialModel m(table_ac().cfg);
  const std::vector<double> before = m.values();
  const JointVector q = qv({-20, 30, 40, 50, -60});
  const Pose p0 = fk(m, q);
  const auto changed = m.with_values(random_errors(m, rng));
  EXPECT_EQ(m.values(), before);
  EXPECT_TRUE(near(fk(m, q).p, p0.p, 0));
  EXPECT_GT((fk(*changed, q).p - p0.p).norm(), 1e-4);
  EXPECT_EQ(changed->kind(), "serial");
  EXPECT_TRUE(near(fk(*changed->nominal(), q).p, p0.p, 1e-12));
  EXPECT_THROW((void)m.with_values({1, 2}), postproc::Error);
}

void expect_usage(const SerialConfig& c, const std::string& fragment) {
  try {
    const SerialModel m(c);
    ADD_FAILURE() << "no error for: " << fragment;
  } catch (const postproc::Error& e) {
    EXPECT_EQ(e.code(), postproc::ExitCode::usage);
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(KinSerial, BadConfigurationsAreRefused) {
  SerialConfig c = table_ac().cfg;
  c.tool_side[1].direction = Vector3d::Zero();
  expect_usage(c, "axis 'Y': direction (0, 0, 0) is zero");
  c = table_ac().cfg;
  c.workpiece_side[1].direction = Vector3d(1, 1, 0);
  expect_usage(c, "rotary axis 'C': direction (1, 1, 0) is not parallel to X, Y or Z");
  c = table_ac().cfg;
  c.workpiece_side[0].direction = Vector3d::UnitZ();
  expect_usage(c, "an axis named A must be parallel to X");
  c = table_ac().cfg;
  for (const char* extra : {"U", "V", "W", "Q"}) c.tool_side.push_back(linear(extra, Vector3d::UnitX(), -1, 1));
  expect_usage(c, "9 axes (2 on the workpiece side, 7 on the tool side); 1 to 8 supported");
  expect_usage(SerialConfig{}, "0 axes");
  c = table_ac().cfg;
  c.tool_side[0].name = "A";
  expect_usage(c, "axis 'A' appears twice");
  c = table_ac().cfg;
  c.tool_x = Vector3d::UnitZ();
  expect_usage(c, "not normal to the tool axis");
  c = table_ac().cfg;
  c.tool_side[0].table.position = {0, 0};
  c.tool_side[0].table.error = {{}, {}};
  expect_usage(c, "axis 'X': error-motion table positions must increase strictly");
  c = table_ac().cfg;
  c.tool_side[0].min = 10;
  c.tool_side[0].max = 0;
  expect_usage(c, "axis 'X': travel [10, 0] is empty");
  // A negative direction is allowed: it is the axis's sense, the ISO names stay.
  c = table_ac().cfg;
  c.workpiece_side[1].direction = -Vector3d::UnitZ();
  EXPECT_EQ(SerialModel(c).parameter_index("EC0C"), 9);
}

}  // namespace

TEST(KinSerial, PositioningScaleStretchesTheTravel) {
  // EXX.scale = s: the X slide travels (1 + s)·x; the Jacobian column of X grows by the same factor.
  const Machine mc = three_axis();
  const SerialModel nominal(mc.cfg);
  std::vector<double> v = nominal.values();
  v[static_cast<std::size_t>(nominal.parameter_index("EXX.scale"))] = 20e-6;  // 20 µm/m
  const auto scaled = nominal.with_values(v);
  JointVector q(3);  // Y, X, Z
  q << -120, 400, 35;
  Pose a, b;
  ASSERT_TRUE(nominal.forward(q, a).ok());
  ASSERT_TRUE(scaled->forward(q, b).ok());
  EXPECT_NEAR((b.p - a.p).norm(), 400 * 20e-6, 1e-12);
  const Jacobian ja = nominal.jacobian(q), jb = scaled->jacobian(q);
  EXPECT_NEAR(jb.col(1).norm(), ja.col(1).norm() * (1 + 20e-6), 1e-12);
  EXPECT_NEAR(jb.col(0).norm(), ja.col(0).norm(), 1e-15);
}
