// Issue 17 item 2: the controller's corner behaviour as machine-file settings ([interpolator]
// corner = "time" | "tolerance") and the program's blending words (LinuxCNC G64 P, Siemens G641
// ADIS= / G642 CTOL=, G61 / G64). Square-corner programs at known feed: the corner speed follows
// the documented formula (docs/contour.md "Corners"), and the time-domain deviation at the corner
// follows the corner speed.
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "contour_support.hpp"
#include "postproc/contour/path.hpp"
#include "postproc/contour/reference.hpp"
#include "postproc/contour/simulate.hpp"
#include "postproc/machine/machine.hpp"

namespace {

namespace ct = postproc::contour;
namespace mc = postproc::machine;
namespace gc = postproc::gcode;
namespace kin = postproc::kin;

constexpr double kA = 1000;              // mm/s², every axis
constexpr double kFeed = 2000.0 / 60.0;  // mm/s at F2000

/// The 3-axis test mill with max_acceleration kA on every axis, `axis_extra` more per axis,
/// `tables` appended (e.g. an [interpolator] table), in dialect `dialect`.
mc::Machine machine(const std::string& tables = "", const std::string& axis_extra = "",
                    const std::string& dialect = "fanuc", const std::string& kv = "30 1/s") {
  std::string text = pptest::mill3_toml("max_acceleration = \"1000 mm/s^2\"\n" + axis_extra) + tables;
  text.replace(text.find("dialect = \"fanuc\""), 17, "dialect = \"" + dialect + "\"");
  for (auto at = text.find("kv = \"30 1/s\""); at != std::string::npos; at = text.find("kv = \"30 1/s\"", at + 1))
    text.replace(at, 13, "kv = \"" + kv + "\"");
  if (dialect != "fanuc") text.replace(text.find("integer_input = \"calculator\"\n"), 29, "");
  gc::DiagnosticSink sink;
  auto m = mc::parse_machine("mill.toml", text, sink);
  for (const auto& d : sink.stored()) ADD_FAILURE() << gc::format(d);
  if (!m) throw std::runtime_error("machine file refused");
  return *m;
}

ct::Path path_of(const std::string& program, const mc::Machine& m) {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  gc::LineReader in{std::string_view(program)};
  gc::DiagnosticSink sink;
  ct::Path p = ct::build_path(in, "t.nc", d, m, ct::PathOptions{}, sink);
  // Siemens ADIS= / CTOL= are reported as not evaluated by the interpreter (PP-U214); the path reads them.
  for (const auto& diag : sink.stored())
    if (diag.code != "PP-U214") ADD_FAILURE() << gc::format(diag);
  return p;
}

/// X20 then Y20 (a 90° corner) at F2000 from the origin; `setup` is written before the moves.
std::string square(const std::string& setup = "") {
  return "G90 G54\nG0 X0 Y0 Z0\n" + setup + "G1 X20. F2000\nY20.\nM30\n";
}

/// The documented tolerance rule for a turn of θ between two long moves of unit axis
/// directions: blend radius R = tol·cos(θ/2)/(1 − cos(θ/2)) (circular blend tangent to both
/// moves, its middle tol from the corner), speed √(a·R / p) with p the largest share of the
/// centripetal acceleration any axis takes along the blend (1 for the corners below).
double tolerance_speed(double tol, double theta, double a = kA) {
  const double R = tol * std::cos(theta / 2) / (1 - std::cos(theta / 2));
  return std::sqrt(a * R);
}

TEST(ContourCorners, DefaultIsTheFiveMillisecondCornerTime) {
  const mc::Machine m = machine();
  EXPECT_EQ(m.interpolator.corner, mc::CornerRule::time);
  EXPECT_DOUBLE_EQ(m.interpolator.corner_time, 0.005);
  const ct::Path p = path_of(square(), m);
  ASSERT_EQ(p.points.size(), 3u);
  EXPECT_NEAR(p.points[1].speed, kA * 0.005, 1e-9);  // Δv per axis = v ≤ a·t
}

TEST(ContourCorners, RepeatedPointIsPassedThrough) {
  // "X20." twice (a block that repeats the point, common in CAM output): the planner joins the
  // moves on either side of it (LinuxCNC's drops a zero-length segment), so the corner speed is
  // that of the square's corner at both ends of the empty move, not a stop or a jump from rest.
  for (const std::string corner : {"time", "tolerance"}) {
    const mc::Machine m = machine("\n[interpolator]\ncorner = \"" + corner + "\"\n");
    const ct::Path plain = path_of(square(), m);
    const ct::Path p = path_of("G90 G54\nG0 X0 Y0 Z0\nG1 X20. F2000\nX20.\nY20.\nM30\n", m);
    ASSERT_EQ(p.points.size(), 4u) << corner;
    EXPECT_GT(plain.points[1].speed, 1.0) << corner;
    EXPECT_NEAR(p.points[1].speed, plain.points[1].speed, 1e-9) << corner;
    EXPECT_NEAR(p.points[2].speed, plain.points[1].speed, 1e-9) << corner;
    EXPECT_NEAR(p.points[2].t, p.points[1].t, 1e-12) << corner;  // the empty move takes no time
    EXPECT_NEAR(p.duration, plain.duration, 1e-9) << corner;
  }
  // A run that ends with a repeated point stops at the last real move's end.
  const ct::Path q = path_of("G90 G54\nG0 X0 Y0 Z0\nG1 X20. F2000\nX20.\nM30\n", machine());
  ASSERT_EQ(q.points.size(), 3u);
  EXPECT_NEAR(q.points[1].speed, 0.0, 1e-12);
}

TEST(ContourCorners, CornerTimeFromTheMachineFile) {
  const ct::Path p = path_of(square(), machine("\n[interpolator]\ncorner = \"time\"\ncorner_time = \"12 ms\"\n"));
  EXPECT_NEAR(p.points[1].speed, kA * 0.012, 1e-9);
  // A 45° turn: X jumps by v(1 − cos45°), Y by v·sin45° — the larger one limits: v ≤ a·t / sin 45°.
  const ct::Path q = path_of("G90 G54\nG0 X0 Y0 Z0\nG1 X20. F2000\nX40. Y20.\nM30\n",
                             machine("\n[interpolator]\ncorner_time = \"12 ms\"\n"));
  EXPECT_NEAR(q.points[1].speed, kA * 0.012 / std::sin(M_PI / 4), 1e-9);
}

TEST(ContourCorners, CornerToleranceFromTheMachineFile) {
  for (const double tol : {0.01, 0.1}) {
    const ct::Path p = path_of(
        square(), machine("\n[interpolator]\ncorner = \"tolerance\"\ncorner_tolerance = \"" + std::to_string(tol) + " mm\"\n"));
    EXPECT_NEAR(p.points[1].speed, tolerance_speed(tol, M_PI / 2), 1e-9) << tol;
  }
  // 0.1 mm at 90°: R = 0.2414 mm, v = 15.54 mm/s.
  EXPECT_NEAR(tolerance_speed(0.1, M_PI / 2), 15.54, 0.01);
  // A 45° turn: the Y axis takes the whole centripetal acceleration at the blend's start.
  const ct::Path q = path_of("G90 G54\nG0 X0 Y0 Z0\nG1 X20. F2000\nX40. Y20.\nM30\n",
                             machine("\n[interpolator]\ncorner = \"tolerance\"\ncorner_tolerance = \"0.01 mm\"\n"));
  EXPECT_NEAR(q.points[1].speed, tolerance_speed(0.01, M_PI / 4), 1e-9);
  // A gentle turn is not slowed below the feed; a reversal stops.
  const ct::Path g = path_of("G90 G54\nG0 X0 Y0 Z0\nG1 X20. F2000\nX40. Y0.5\nX0. Y-0.5\nM30\n",
                             machine("\n[interpolator]\ncorner = \"tolerance\"\ncorner_tolerance = \"0.1 mm\"\n"));
  EXPECT_NEAR(g.points[1].speed, kFeed, 1e-9);
  EXPECT_NEAR(g.points[2].speed, 0.0, 1e-9);
}

TEST(ContourCorners, BlendIsAtMostHalfOfTheShorterMove) {
  // 0.2 mm moves: the blend may start at most 0.1 mm before the corner, R = 0.1·tan(45°) = 0.1 mm
  // (smaller than the 0.2414 mm the 0.1 mm tolerance would give).
  const ct::Path p = path_of("G90 G54\nG0 X0 Y0 Z0\nG1 X0.2 F2000\nY0.2\nX0.4\nM30\n",
                             machine("\n[interpolator]\ncorner = \"tolerance\"\ncorner_tolerance = \"0.1 mm\"\n"));
  ASSERT_EQ(p.points.size(), 4u);
  // The junction speed is also bounded by the look-ahead (stopping within the moves); the corner
  // rule alone gives √(a·0.1), which the acceleration passes may lower further.
  EXPECT_LE(p.points[1].speed, std::sqrt(kA * 0.1) + 1e-9);
  EXPECT_LT(p.points[1].speed, tolerance_speed(0.1, M_PI / 2));
}

TEST(ContourCorners, JerkLimitsTheBlendSpeed) {
  // Along the blend the centripetal acceleration turns at v/R: jerk v³/R² ≤ max_jerk.
  const std::string tol = "\n[interpolator]\ncorner = \"tolerance\"\ncorner_tolerance = \"0.1 mm\"\n";
  const double R = 0.1 * std::cos(M_PI / 4) / (1 - std::cos(M_PI / 4));
  const ct::Path slow = path_of(square(), machine(tol, "max_jerk = \"10000 mm/s^3\"\n"));
  EXPECT_NEAR(slow.points[1].speed, std::cbrt(1e4 * R * R), 1e-9);
  EXPECT_LT(slow.points[1].speed, tolerance_speed(0.1, M_PI / 2));
  // A generous jerk limit leaves the acceleration rule in charge.
  const ct::Path fast = path_of(square(), machine(tol, "max_jerk = \"1e6 mm/s^3\"\n"));
  EXPECT_NEAR(fast.points[1].speed, tolerance_speed(0.1, M_PI / 2), 1e-9);
}

TEST(ContourCorners, JerkShapesTheRamps) {
  // max_jerk J: the interpolator's output is averaged over a/J (here 1000/20000 = 50 ms), which
  // turns the trapezoidal ramp into an S-curve whose jerk is at most J (without it: a/period).
  const auto max_jerk = [](const ct::Path& p, kin::JointVector& last) {
    std::vector<double> x;
    ct::interpolate(p, p.runs[0], 0.0, [&](const ct::Sample& s) {
      x.push_back(s.q[0]);
      last = s.q;
    });
    double j = 0;
    for (std::size_t k = 3; k < x.size(); ++k)
      j = std::max(j, std::abs(x[k] - 3 * x[k - 1] + 3 * x[k - 2] - x[k - 3]) / std::pow(p.period, 3));
    return j;
  };
  const std::string line = "G90 G54\nG0 X0 Y0 Z0\nG1 X20. F2000\nM30\n";
  kin::JointVector end;
  const ct::Path plain = path_of(line, machine());
  EXPECT_GT(max_jerk(plain, end), 1e5);
  const ct::Path p = path_of(line, machine("", "max_jerk = \"20000 mm/s^3\"\n"));
  ASSERT_EQ(p.jerk_window.size(), 3u);
  EXPECT_NEAR(p.jerk_window[0], 0.05, 1e-12);
  EXPECT_LE(max_jerk(p, end), 20000 * 1.001);
  EXPECT_GT(max_jerk(p, end), 20000 * 0.9);  // the ramps reach it
  EXPECT_NEAR(end[0], 20.0, 1e-9);            // the averaged command still ends on the point
}

TEST(ContourCorners, ExactStopAgainstContinuousPath) {
  const mc::Machine m = machine("\n[interpolator]\ncorner = \"tolerance\"\ncorner_tolerance = \"0.1 mm\"\n");
  // G61: every block ends at rest — the corner ends a run.
  const ct::Path exact = path_of(square("G61\n"), m);
  EXPECT_EQ(exact.runs.size(), 2u);
  // G64 (Fanuc: continuous path, the machine file's rule).
  const ct::Path cont = path_of(square("G61\nG64\n"), m);
  ASSERT_EQ(cont.runs.size(), 1u);
  EXPECT_NEAR(cont.points[1].speed, tolerance_speed(0.1, M_PI / 2), 1e-9);
  // G9 stops at the end of its own block only.
  const ct::Path g9 = path_of("G90 G54\nG0 X0 Y0 Z0\nG1 G9 X20. F2000\nY20.\nX0\nM30\n", m);
  EXPECT_EQ(g9.runs.size(), 2u);
  EXPECT_GT(exact.duration, cont.duration);
}

TEST(ContourCorners, LinuxCncG64P) {
  const mc::Machine time_machine = machine("", "", "linuxcnc");
  // G64 P0.1 overrides the machine's corner time with a 0.1 mm tolerance.
  EXPECT_NEAR(path_of(square("G64 P0.1\n"), time_machine).points[1].speed, tolerance_speed(0.1, M_PI / 2), 1e-9);
  // Inch: P0.004 in = 0.1016 mm.
  EXPECT_NEAR(path_of("G20 G90 G54\nG0 X0 Y0 Z0\nG64 P0.004\nG1 X0.8 F80.\nY0.8\nM30\n", time_machine).points[1].speed,
              tolerance_speed(0.1016, M_PI / 2), 1e-9);
  // G64 without P (or P0): best possible speed — the corner-time rule, even on a tolerance machine.
  const mc::Machine tol_machine =
      machine("\n[interpolator]\ncorner = \"tolerance\"\ncorner_tolerance = \"0.1 mm\"\n", "", "linuxcnc");
  EXPECT_NEAR(path_of(square(), tol_machine).points[1].speed, tolerance_speed(0.1, M_PI / 2), 1e-9);
  EXPECT_NEAR(path_of(square("G64\n"), tol_machine).points[1].speed, kA * 0.005, 1e-9);
  EXPECT_NEAR(path_of(square("G64 P0\n"), tol_machine).points[1].speed, kA * 0.005, 1e-9);
  // G61.1 / G61: exact stop.
  EXPECT_EQ(path_of(square("G64 P0.1\nG61\n"), tol_machine).runs.size(), 2u);
}

TEST(ContourCorners, SiemensG641AdisAndG642Ctol) {
  const mc::Machine m =
      machine("\n[interpolator]\ncorner = \"tolerance\"\ncorner_tolerance = \"0.01 mm\"\n", "", "siemens");
  const std::string sq = "G90 G54\nG0 X0 Y0 Z0\nG1 X20. F2000\nY20.\nM30\n";
  const auto with = [&](const std::string& setup) {
    return path_of("G90 G54\nG0 X0 Y0 Z0\n" + setup + "G1 X20. F2000\nY20.\nM30\n", m).points[1].speed;
  };
  EXPECT_NEAR(path_of(sq, m).points[1].speed, tolerance_speed(0.01, M_PI / 2), 1e-9);  // the machine file's rule
  // G642 uses the machine file's tolerance, or CTOL= when programmed.
  EXPECT_NEAR(with("G642\n"), tolerance_speed(0.01, M_PI / 2), 1e-9);
  EXPECT_NEAR(with("CTOL=0.1\nG642\n"), tolerance_speed(0.1, M_PI / 2), 1e-9);
  // G641 ADIS=0.5: the blend starts 0.5 mm before the corner, R = 0.5·tan(45°) = 0.5 mm.
  EXPECT_NEAR(with("G641 ADIS=0.5\n"), std::sqrt(kA * 0.5), 1e-9);
  // G641 without ADIS and G64: no rounding, the corner-time rule.
  EXPECT_NEAR(with("G641\n"), kA * 0.005, 1e-9);
  EXPECT_NEAR(with("G64\n"), kA * 0.005, 1e-9);
  // G60: exact stop.
  EXPECT_EQ(path_of("G90 G54\nG0 X0 Y0 Z0\nG60\nG1 X20. F2000\nY20.\nM30\n", m).runs.size(), 2u);
}

TEST(ContourCorners, MachineFileRefusesBadSettings) {
  gc::DiagnosticSink sink;
  std::string text = pptest::mill3_toml() + "\n[interpolator]\ncorner = \"round\"\ncorner_tolerance = \"-1 mm\"\n";
  EXPECT_FALSE(mc::parse_machine("mill.toml", text, sink).has_value());
  EXPECT_GE(sink.count(gc::Severity::error), 2u);
}

/// The largest simulated tool-tip contour error of a square-corner program.
double corner_error(const mc::Machine& m, const std::string& program, double& corner_speed) {
  const ct::Path p = path_of(program, m);
  corner_speed = p.points[1].speed;
  const ct::Reference ref(p, *m.actual);
  return ct::simulate(p, ref, *m.actual).tip.max;
}

TEST(ContourCorners, SimulatedDeviationFollowsTheCornerSpeed) {
  // A first-order servo (Kv) taking a 90° corner at constant speed v cuts it by v/(e·Kv): the
  // actual point is the exponentially weighted mean of the past commands, distance
  // (v/Kv)·min(e^−u, u − 1 + e^−u) from the path (u = Kv·t after the corner), largest at u = 1.
  // With the ramps around the corner the speed is not constant, so the simulated value is
  // checked to lie between that and 1.5 times it; and it grows with the corner speed.
  const double kv = 300;
  const std::string tol = "\n[interpolator]\ncorner = \"tolerance\"\ncorner_tolerance = ";
  double last = 0, last_v = 0;
  for (const std::string& table : {std::string(""), tol + "\"0.05 mm\"\n", tol + "\"0.2 mm\"\n"}) {
    double v = 0;
    const double e = corner_error(machine(table, "", "fanuc", "300 1/s"), square(), v);
    const double ideal = v / (std::exp(1.0) * kv);
    EXPECT_GE(e, 0.95 * ideal) << table;
    EXPECT_LE(e, 1.5 * ideal) << table;
    EXPECT_GT(v, last_v);
    EXPECT_GT(e, last);
    last = e;
    last_v = v;
  }
  // Exact stop: no corner deviation from the corner speed (the drives settle on each leg).
  double v = 0;
  const double stop = corner_error(machine("", "", "fanuc", "300 1/s"), square("G61\n"), v);
  EXPECT_LT(stop, 1e-4);
}

}  // namespace
