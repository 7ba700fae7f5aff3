// Issue 6: the commanded path (feed interpretation, limits, runs), the prediction of following
// and contour errors, precompensation, and compensate --mode contour checked on the
// time-domain simulator.
#include <cmath>
#include <stdexcept>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "contour_support.hpp"
#include "postproc/compensation/compensate.hpp"
#include "postproc/contour/path.hpp"
#include "postproc/contour/precompensate.hpp"
#include "postproc/contour/reference.hpp"
#include "postproc/contour/simulate.hpp"
#include "postproc/machine/machine.hpp"

namespace {

namespace ct = postproc::contour;
namespace kin = postproc::kin;
namespace mc = postproc::machine;
namespace gc = postproc::gcode;
namespace comp = postproc::comp;

constexpr double kKv = 30;                // 1/s
constexpr double kSpeed = 2000.0 / 60.0;  // mm/s at F2000

std::string mill(const std::string& axes_extra = "") { return pptest::mill3_toml(axes_extra); }

mc::Machine load(const std::string& text) {
  gc::DiagnosticSink sink;
  auto m = mc::parse_machine("mill.toml", text, sink);
  for (const auto& d : sink.stored()) ADD_FAILURE() << d.message;
  if (!m) throw std::runtime_error("machine file refused");
  return *m;
}

ct::Path path_of(const std::string& program, const mc::Machine& m, gc::DiagnosticSink& sink) {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  gc::LineReader in{std::string_view(program)};
  return ct::build_path(in, "t.nc", d, m, ct::PathOptions{}, sink);
}

/// A circle of radius r (mm) as n G1 points at F2000, starting at (r, 0), after a rapid there.
std::string circle(double r, int n, double feed = 2000, int turns = 1) {
  std::string s = "%\nO1000 (circle)\nG90 G17 G21 G54\nG0 X" + fmt::format("{:.4f}", r) + " Y0. Z0.\n";
  for (int i = 1; i <= n * turns; ++i) {
    const double a = 2 * kin::kPi * i / n;
    s += fmt::format("G1 X{:.4f} Y{:.4f}{}\n", r * std::cos(a), r * std::sin(a), i == 1 ? fmt::format(" F{:.0f}", feed) : "");
  }
  s += "G0 Z50.\nM30\n%\n";
  return s;
}

TEST(ContourPath, FeedTimesAndRuns) {
  const mc::Machine m = load(mill());
  gc::DiagnosticSink sink;
  const ct::Path p = path_of("G90 G54\nG0 X0 Y0 Z0\nG1 X10. F600\nY10.\nG0 Z5.\nG1 Z0 F1200\nX0\nM30\n", m, sink);
  ASSERT_FALSE(sink.has_errors());
  ASSERT_EQ(p.runs.size(), 2u);  // the rapid ends the first run
  EXPECT_EQ(p.runs[0].size(), 3u);
  EXPECT_EQ(p.runs[1].size(), 3u);
  // No acceleration limits: each move at its feed, 10 mm at 600 mm/min = 1 s.
  EXPECT_NEAR(p.points[1].t - p.points[0].t, 1.0, 1e-9);
  EXPECT_NEAR(p.points[2].t - p.points[1].t, 1.0, 1e-9);
  EXPECT_NEAR(p.points[5].t - p.points[4].t, 10.0 / 20.0, 1e-9);
  EXPECT_EQ(p.points[2].line, 4u);
  EXPECT_TRUE(p.points[0].run_start);
  EXPECT_NEAR(p.points[2].q[1], 10.0, 1e-12);
}

TEST(ContourPath, InverseTimeAndVelocityLimit) {
  const mc::Machine m = load(mill("max_velocity = \"300 mm/min\"\n"));
  gc::DiagnosticSink sink;
  // G93: F2 = the block lasts 1/2 min (30 s) unless an axis would exceed its limit; the second
  // move at F2000 is slowed to 300 mm/min by the X limit (10 mm → 2 s).
  const ct::Path p = path_of("G90 G54\nG0 X0 Y0 Z0\nG93 G1 X5. F2.\nG94 X15. F2000\nM30\n", m, sink);
  ASSERT_FALSE(sink.has_errors());
  ASSERT_EQ(p.runs.size(), 1u);
  EXPECT_NEAR(p.points[1].t - p.points[0].t, 30.0, 1e-9);
  EXPECT_NEAR(p.points[2].t - p.points[1].t, 2.0, 1e-9);
}

TEST(ContourPath, AccelerationProfileAndCornerSlowDown) {
  const mc::Machine m = load(mill("max_acceleration = \"1000 mm/s^2\"\n"));
  gc::DiagnosticSink sink;
  // 20 mm at F2000 from rest to rest with 1000 mm/s²: accelerating 33.3 mm/s takes 1/30 s over
  // 0.556 mm, so the move lasts 20/33.33 + 1/30 s. A 90° corner then a stop.
  const ct::Path p = path_of("G90 G54\nG0 X0 Y0 Z0\nG1 X20. F2000\nY20.\nM30\n", m, sink);
  ASSERT_FALSE(sink.has_errors());
  ASSERT_EQ(p.points.size(), 3u);
  // Corner: the jump of X (and Y) velocity ≤ 1000 mm/s² · 5 ms = 5 mm/s.
  EXPECT_NEAR(p.points[1].speed, 5.0, 1e-9);
  const double v = kSpeed, a = 1000, vc = 5;
  const double expected = (v / a) + (v - vc) / a + (20 - v * v / (2 * a) - (v * v - vc * vc) / (2 * a)) / v;
  EXPECT_NEAR(p.points[1].t - p.points[0].t, expected, 1e-9);
  // The interpolator reproduces the profile: samples move monotonically and end on the point.
  double last = -1;
  std::size_t n = 0;
  ct::interpolate(p, p.runs[0], 0.0, [&](const ct::Sample& s) {
    const double x = s.q[0] + s.q[1];
    EXPECT_GE(x, last - 1e-12);
    last = x;
    ++n;
  });
  EXPECT_NEAR(last, 40.0, 1e-9);
  EXPECT_NEAR(static_cast<double>(n), std::ceil(p.duration / p.period) + 1, 1.0);
}

TEST(ContourPath, RefusesWhatItCannotTime) {
  const mc::Machine m = load(mill());
  {
    gc::DiagnosticSink sink;
    (void)path_of("G90 G54\nG0 X0 Y0 Z0\nG1 X10.\n", m, sink);
    ASSERT_TRUE(sink.has_errors());
    EXPECT_EQ(sink.stored().front().code, "PP-E612");
    EXPECT_EQ(sink.stored().front().where.line, 3u);
  }
  {
    gc::DiagnosticSink sink;
    (void)path_of("G90 G54\nG0 X0 Y0 Z0\nG95 G1 X10. F0.1\n", m, sink);
    ASSERT_TRUE(sink.has_errors());
    EXPECT_NE(sink.stored().front().message.find("revolution"), std::string::npos);
  }
  {
    std::string no_kv = mill();
    no_kv.replace(no_kv.find("kv = \"30 1/s\""), 13, "");
    gc::DiagnosticSink sink;
    (void)path_of("G90 G54\nG0 X0 Y0 Z0\nG1 X10. F100\n", load(no_kv), sink);
    ASSERT_TRUE(sink.has_errors());
    EXPECT_EQ(sink.stored().front().code, "PP-E611");
    EXPECT_NE(sink.stored().front().message.find("[axes.X]"), std::string::npos);
  }
}

TEST(ContourPredict, LagModeFollowingErrorIsVelocityOverKv) {
  const mc::Machine m = load(mill());
  gc::DiagnosticSink sink;
  std::string prog = "G90 G54\nG0 X0 Y0 Z0\nG1 X0.5 Y0.5 F2000\n";
  for (int i = 2; i <= 40; ++i) prog += fmt::format("X{:.1f} Y{:.1f}\n", 0.5 * i, 0.5 * i);
  const ct::Path p = path_of(prog, m, sink);
  ASSERT_FALSE(sink.has_errors());
  const ct::Reference ref(p, *m.actual);
  const ct::Prediction pr = ct::predict(p, *m.actual, ref);
  // Along a 45° line each axis moves at v/√2: after the start transient e = v/(√2·Kv); at the
  // point reached after t it is e·(1 − exp(−Kv·t)) (first-order lag from rest); no contour error.
  const double e = kSpeed / std::sqrt(2.0) / kKv;
  EXPECT_NEAR(pr.max_following[0], e, 1e-6);
  EXPECT_NEAR(pr.points[40].following[1], e, 1e-6);
  const double t = p.points[3].t - p.points[0].t;
  EXPECT_NEAR(pr.points[3].following[0], e * (1 - std::exp(-kKv * t)), 1e-9);
  EXPECT_LT(pr.tip.max, 1e-6);
}

TEST(ContourPredict, CircleMatchesFirstOrderLagAndSimulation) {
  const mc::Machine m = load(mill());
  gc::DiagnosticSink sink;
  const double r = 20;
  const ct::Path p = path_of(circle(r, 720, 2000, 2), m, sink);
  ASSERT_FALSE(sink.has_errors());
  const ct::Reference ref(p, *m.actual);
  EXPECT_LT(ref.max_fit_residual_mm(), 1e-4);
  const ct::Prediction pr = ct::predict(p, *m.actual, ref);
  // Steady state of a first-order lag on a circle: radius R/√(1 + (ωτ)²).
  const double wt = kSpeed / r / kKv;
  const double exact = r * (1 - 1 / std::sqrt(1 + wt * wt));
  const std::size_t mid = p.runs[0].begin + p.runs[0].size() / 2;
  EXPECT_NEAR(pr.points[mid].tip_mm, exact, 0.03 * exact);
  // The time-domain simulation agrees in the steady state (its max includes the start).
  ct::SimulateOptions so;
  so.keep_every = 1;
  const ct::Simulation s = ct::simulate(p, ref, *m.actual, so);
  ASSERT_FALSE(s.kept.empty());
  const ct::SimSample& at_mid = s.kept[s.kept.size() / 2];
  EXPECT_NEAR(at_mid.tip_mm, exact, 0.05 * exact);
}

/// Compensates `program` in memory with --mode contour and returns the corrected text.
std::string contour_compensate(const std::string& program, const mc::Machine& m, comp::CompensateResult& r,
                               gc::DiagnosticSink& sink) {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  comp::CompensateOptions opt;
  opt.mode = postproc::comp::Mode::contour;
  opt.tool_version = "test";
  auto out = postproc::io::OutputFile::memory();
  r = comp::compensate_contour({program, "t.nc", d, m}, opt, out, sink);
  return out.take();
}

TEST(ContourCompensate, CircleErrorsCancelOnTheSimulator) {
  const mc::Machine m = load(mill());
  const std::string prog = circle(20, 720, 2000, 2);
  gc::DiagnosticSink sink;
  comp::CompensateResult r;
  const std::string out = contour_compensate(prog, m, r, sink);
  ASSERT_FALSE(sink.has_errors());
  EXPECT_GT(r.contour_before_mm, 0.005);
  // Issue 17: before / after are the time-domain simulation's maxima (the start transient from
  // rest stays, see below); the iteration's prediction is reported next to them.
  EXPECT_LT(r.contour_after_mm, r.contour_before_mm);
  EXPECT_LT(r.contour_predicted_after_mm, 0.1 * r.contour_before_mm);
  EXPECT_GE(r.contour_iterations, 1);
  // The header names the mode; the rapid, the comment and the program end are byte for byte.
  EXPECT_NE(out.find("compensate mode=contour"), std::string::npos);
  EXPECT_NE(out.find("\nO1000 (circle)\n"), std::string::npos);
  EXPECT_NE(out.find("\nG0 Z50.\nM30\n%\n"), std::string::npos);
  EXPECT_GT(r.changed_blocks, 1000u);
  // The corrected program on the simulator, measured against the original's intended contour.
  gc::DiagnosticSink s1, s2;
  const ct::Path original = path_of(prog, m, s1);
  const ct::Path corrected = path_of(out, m, s2);
  ASSERT_FALSE(s1.has_errors());
  ASSERT_FALSE(s2.has_errors());
  const ct::Reference ref(original, *m.actual);
  const ct::Simulation before = ct::simulate(original, ref, *m.actual);
  const ct::Simulation after = ct::simulate(corrected, ref, *m.actual);
  // The start of the circle (from rest) has a transient neither the prediction nor the
  // correction removes; the steady state is where the comparison holds.
  EXPECT_GT(before.tip.p95, 0.005);
  EXPECT_LT(after.tip.p95, 0.1 * before.tip.p95);
  EXPECT_NEAR(r.contour_before_mm, before.tip.max, 1e-9);
  EXPECT_NEAR(r.contour_after_mm, after.tip.max, 1e-9);
}

TEST(ContourCompensate, StraightLinesAreLeftAlone) {
  const mc::Machine m = load(mill());
  const std::string prog = "G90 G54\nG0 X0 Y0 Z0\nG1 X10. F2000\nX20.\nX30.\nM30\n";
  gc::DiagnosticSink sink;
  comp::CompensateResult r;
  comp::CompensateOptions opt;
  const std::string out = contour_compensate(prog, m, r, sink);
  ASSERT_FALSE(sink.has_errors());
  EXPECT_EQ(r.changed_blocks, 0u);
  EXPECT_EQ(out.substr(out.find('\n') + 1), prog);
}

TEST(ContourCompensate, ArcsAreWrittenAsTheyAreWithAWarning) {
  const mc::Machine m = load(mill());
  std::string prog = "G90 G17 G54\nG0 X20. Y0 Z0\n";
  for (int i = 1; i <= 90; ++i)
    prog += fmt::format("G1 X{:.4f} Y{:.4f}{}\n", 20 * std::cos(i * kin::kPi / 180), 20 * std::sin(i * kin::kPi / 180),
                        i == 1 ? " F2000" : "");
  prog += "G3 X-20. Y0 I0 J-20.\nM30\n";
  gc::DiagnosticSink sink;
  comp::CompensateResult r;
  const std::string out = contour_compensate(prog, m, r, sink);
  ASSERT_FALSE(sink.has_errors());
  bool warned = false;
  for (const auto& d : sink.stored())
    if (d.code == "PP-W611") warned = d.where.line == 93;
  EXPECT_TRUE(warned);
  EXPECT_NE(out.find("\nG3 X-20. Y0 I0 J-20.\n"), std::string::npos);
  EXPECT_GT(r.changed_blocks, 50u);  // the G1 points are corrected
}

}  // namespace
