// convert --linearize: chords within the tolerance (printed rounding included), exact end points,
// exact incremental sums, inverse-time feeds, refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <sstream>

#include <fmt/format.h>

#include "convert_run.hpp"
#include "postproc/gcode/number_style.hpp"
#include "src/gcode/linearize.hpp"

namespace {

using namespace pptest;

/// counts·10^-d as text ("-12.340").
std::string text_of(std::int64_t counts, int d) {
  return gc::format_counts(counts, d, gc::NumberStyle{false, true, d, false, true}, false);
}

std::vector<std::string> lines_of(const std::string& s) {
  std::vector<std::string> out;
  std::istringstream in(s);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

/// Text of the last word of letter L in `lines` ("" if none).
std::string last_word(const std::vector<std::string>& lines, char L) {
  std::string found;
  for (const auto& l : lines) {
    Lexed x(dialect("linuxcnc"), l);
    for (const auto& w : x.block.words)
      if (w.letter == L) found = std::string(x.of(w.value));
  }
  return found;
}

/// Distance of point q from the (spiral) arc of m at q's angle, in the plane; and the angle swept
/// from the start to q in the arc's direction.
struct ArcFrame {
  int u, v;
  double cu, cv, r0, r1, a0, sweep;
  explicit ArcFrame(const gc::Motion& m) {
    u = m.plane == gc::Plane::xy ? 0 : m.plane == gc::Plane::zx ? 2 : 1;
    v = m.plane == gc::Plane::xy ? 1 : m.plane == gc::Plane::zx ? 0 : 2;
    cu = m.arc.centre[u];
    cv = m.arc.centre[v];
    r0 = std::hypot(m.start[u] - cu, m.start[v] - cv);
    r1 = std::hypot(m.end[u] - cu, m.end[v] - cv);
    a0 = std::atan2(m.start[v] - cv, m.start[u] - cu);
    sweep = m.arc.sweep;
  }
  [[nodiscard]] double deviation(double pu, double pv, double progress) const {
    const double t = std::clamp(progress / std::abs(sweep), 0.0, 1.0);
    return std::abs(std::hypot(pu - cu, pv - cv) - (r0 + t * (r1 - r0)));
  }
};

TEST(ConvertLinearize, SegmentCountFollowsTheChordFormula) {
  EXPECT_FALSE(gc::arc_segments(10, 1, 0.001, 0.001));  // nothing left for the chord
  EXPECT_EQ(*gc::arc_segments(10, std::numbers::pi / 2, 1e9, 0), 1u);
  EXPECT_EQ(*gc::arc_segments(10, 2 * std::numbers::pi, 1e9, 0), 2u);  // steps of at most half a turn
  const double r = 50, tol = 0.01, rho = gc::rounding_mm(3, false);
  const auto n = *gc::arc_segments(r, -3.0, tol, rho);
  const double step = 3.0 / static_cast<double>(n);
  EXPECT_LE(r * (1 - std::cos(step / 2)), tol - rho);
  EXPECT_GT(r * (1 - std::cos(3.0 / static_cast<double>(n - 1) / 2)), tol - rho);  // n is the smallest
  EXPECT_NEAR(gc::rounding_mm(4, true), std::sqrt(2.0) * 0.5e-4 * 25.4, 1e-15);
}

TEST(ConvertLinearize, RandomArcs) {
  std::mt19937 rng(4242);
  auto uni = [&](double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); };
  auto pick = [&](int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); };
  int checked = 0;
  for (int i = 0; i < 250; ++i) {
    const int plane = pick(3);
    const int u = plane == 0 ? 0 : plane == 1 ? 2 : 1, v = plane == 0 ? 1 : plane == 1 ? 0 : 2, nrm = 3 - u - v;
    const char U = "XYZ"[u], V = "XYZ"[v], N = "XYZ"[nrm], CU = "IJK"[u], CV = "IJK"[v];
    const int d = 3 + pick(2);
    const double scale = std::pow(10.0, d);
    const double r = uni(0.5, 150), a0 = uni(0, 2 * std::numbers::pi);
    const int kind = pick(4);
    const double sweep = kind == 0 ? uni(0.05, 1) : kind == 1 ? uni(1, 3) : kind == 2 ? uni(3, 6.2) : 0;
    const bool cw = pick(2) == 0, helical = pick(10) < 3, incremental = pick(10) < 3, inverse = pick(10) < 2;
    const double tol = uni(0.002, 0.05);
    auto counts = [&](double x) { return std::llround(x * scale); };
    const std::int64_t su = counts(uni(-100, 100)), sv = counts(uni(-100, 100)), sn = counts(uni(-20, 20));
    const std::int64_t iu = counts(-r * std::cos(a0)), iv = counts(-r * std::sin(a0));
    const double cu = static_cast<double>(su + iu) / scale, cv = static_cast<double>(sv + iv) / scale;
    const double a1 = a0 + (cw ? -sweep : sweep);
    const std::int64_t eu = kind == 3 ? su : counts(cu + r * std::cos(a1)), ev = kind == 3 ? sv : counts(cv + r * std::sin(a1));
    const std::int64_t en = helical ? sn + counts(uni(-10, 10)) : sn;
    std::string arc = fmt::format("{}G{} {}{} {}{}", incremental ? "G91 " : "", cw ? 2 : 3, U,
                                  text_of(incremental ? eu - su : eu, d), V, text_of(incremental ? ev - sv : ev, d));
    if (helical) arc += fmt::format(" {}{}", N, text_of(incremental ? en - sn : en, d));
    arc += fmt::format(" {}{} {}{} F{}", CU, text_of(iu, d), CV, text_of(iv, d), inverse ? "2.5" : "500");
    const std::string program = fmt::format("G21 G90 G{} {}\nG0 {}{} {}{} {}{}\n{}\nG90 G94\nM2\n",
                                            17 + plane, inverse ? "G93" : "G94", U, text_of(su, d), V, text_of(sv, d),
                                            N, text_of(sn, d), arc);
    const gc::Dialect dl = dialect("linuxcnc");
    const Program original(dl, program);
    ASSERT_EQ(original.sink.count(gc::Severity::error), 0u) << program << original.all_codes();
    ASSERT_EQ(original.motions.size(), 2u) << program;
    const gc::Motion& m = original.motions[1];
    const ArcFrame f(m);
    // Exact points (before rounding) lie on the arc.
    const std::uint64_t n = *gc::arc_segments(std::max(f.r0, f.r1), m.arc.sweep, tol, gc::rounding_mm(d, false));
    for (std::uint64_t k = 0; k <= n; ++k) {
      const double t = static_cast<double>(k) / static_cast<double>(n);
      const gc::AxisVector q = gc::arc_point(m, t);
      EXPECT_NEAR(f.deviation(q[u], q[v], t * std::abs(m.arc.sweep)), 0.0, 1e-9);
      EXPECT_NEAR(q[nrm], m.start[nrm] + t * (m.end[nrm] - m.start[nrm]), 1e-9);
    }
    EXPECT_LE((gc::arc_point(m, 1) - m.end).norm(), 1e-9);
    Converted c;
    run_convert("linuxcnc", program, linearize_option(tol), c);
    ASSERT_TRUE(c.committed) << program << (c.errors.empty() ? "" : c.errors[0].message);
    const Program out(dl, c.out);
    ASSERT_EQ(out.motions.size(), 1 + c.result.segments) << c.out;
    // Every printed point and every chord's midpoint within the tolerance of the arc, in order.
    double progress = 0;
    gc::AxisVector prev = m.start;
    for (std::size_t j = 1; j < out.motions.size(); ++j) {
      const gc::Motion& s = out.motions[j];
      ASSERT_EQ(s.type, gc::MotionType::linear);
      double step = std::atan2(s.end[v] - f.cv, s.end[u] - f.cu) - std::atan2(prev[v] - f.cv, prev[u] - f.cu);
      step = std::remainder(step, 2 * std::numbers::pi) * (m.arc.sweep < 0 ? -1 : 1);
      EXPECT_GE(step, -1e-9) << "segment " << j << " goes backwards\n" << c.out;
      const double before = progress;
      progress += step;
      EXPECT_LE(f.deviation(s.end[u], s.end[v], progress), tol + 1e-9) << "point " << j;
      const gc::AxisVector mid = (s.end + prev) / 2;
      EXPECT_LE(f.deviation(mid[u], mid[v], (before + progress) / 2), tol + 1e-9) << "chord " << j;
      prev = s.end;
    }
    EXPECT_NEAR(progress, std::abs(m.arc.sweep), 1e-6);
    EXPECT_LE((out.motions.back().end - m.end).norm(), 1e-9);
    // The end is the source's own text (absolute), or the increments add up to it exactly.
    const auto all = lines_of(c.out);
    const std::vector<std::string> section(all.begin() + 2, all.end() - 2);
    for (auto [L, a] : {std::pair{U, u}, std::pair{V, v}, std::pair{N, nrm}}) {
      if (L == N && !helical) continue;
      const std::int64_t start = a == u ? su : a == v ? sv : sn, end = a == u ? eu : a == v ? ev : en;
      if (!incremental) {
        EXPECT_EQ(last_word(section, L), text_of(end, d)) << c.out;
        continue;
      }
      std::int64_t sum = 0;
      for (const auto& l : section) {
        Lexed x(dl, l);
        for (const auto& w : x.block.words)
          if (w.letter == L) {
            std::int64_t k = 0;
            ASSERT_TRUE(gc::literal_counts(x.of(w.value), d, k));
            sum += k;
          }
      }
      EXPECT_EQ(sum, end - start) << L << "\n" << c.out;
    }
    // Inverse time: each of the segments gets n times the arc's F, so the time is unchanged.
    if (inverse) {
      const std::string want =
          gc::format_counts(25 * static_cast<std::int64_t>(c.result.segments), 1, gc::detect_style("2.5"), false);
      for (const auto& l : section) EXPECT_EQ(last_word({l}, 'F'), want) << l;
    }
    ++checked;
  }
  EXPECT_EQ(checked, 250);
}

TEST(ConvertLinearize, KeepsTheBlocksOtherWordsAndLinearisesModalArcs) {
  const std::string in =
      "G21 G90 G17\nG0 X0 Y0\nN10 G02 X10. Y0 I5. J0 F100. M8 (c)\nX20. I5.\n/G1 X21.\n/G3 X31. Y0 R5.\nM30\n";
  Converted c;
  run_convert("fanuc", in, linearize_option(0.5), c);
  ASSERT_TRUE(c.committed) << (c.errors.empty() ? "" : c.errors[0].message);
  const auto lines = lines_of(c.out);
  EXPECT_EQ(lines[2].rfind("N10 G01 X", 0), 0u) << lines[2];  // G02 → G01, zero padding kept
  EXPECT_NE(lines[2].find(" F100. M8 (c)"), std::string::npos) << lines[2];
  EXPECT_EQ(c.out.find('I'), std::string::npos) << c.out;
  EXPECT_EQ(c.out.find('R'), std::string::npos) << c.out;
  EXPECT_EQ(c.result.arcs_linearized, 3u);
  EXPECT_NE(c.out.find("\n/G1 X22.464 Y-3.536\n"), std::string::npos) << c.out;  // block delete carried
  EXPECT_NE(c.out.find("\nX"), std::string::npos) << c.out;       // the modal arc's own block stays first
  // Every motion of the result is a straight line; the last point of each arc is its source text.
  const Program out(dialect("fanuc"), c.out);
  for (const auto& m : out.motions) EXPECT_NE(m.type, gc::MotionType::arc_cw);
  EXPECT_NE(c.out.find("X10. Y0\n"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("X31. Y0\n"), std::string::npos) << c.out;
}

TEST(ConvertLinearize, IncrementalArcsAddUpExactly) {
  const std::string in =
      "G21 G90 G17\nG0 X0 Y0\nG91 G1 X0.333 Y0.333 F100.\nG3 X-10.001 Y10.001 I-10.001 J0.\nG90\n";
  Converted c;
  run_convert("fanuc", in, linearize_option(0.003), c);
  ASSERT_TRUE(c.committed) << (c.errors.empty() ? "" : c.errors[0].message);
  std::int64_t x = 0, y = 0;
  const auto lines = lines_of(c.out);
  for (std::size_t i = 3; i + 1 < lines.size(); ++i) {
    Lexed l(dialect("fanuc"), lines[i]);
    for (const auto& w : l.block.words) {
      if (w.letter != 'X' && w.letter != 'Y') continue;
      std::int64_t k = 0;
      ASSERT_TRUE(gc::literal_counts(l.of(w.value), 3, k)) << lines[i];
      (w.letter == 'X' ? x : y) += k;
    }
  }
  EXPECT_EQ(x, -10001);
  EXPECT_EQ(y, 10001);
  EXPECT_GT(c.result.segments, 10u);
}

TEST(ConvertLinearize, InverseTimeFeedsKeepTheArcsTime) {
  Converted c;
  run_convert("fanuc", "G21 G90 G17\nG0 X0 Y0\nG93 G2 X10. Y0 I5. J0 F4.\nG94\n", linearize_option(0.05), c);
  ASSERT_TRUE(c.committed) << (c.errors.empty() ? "" : c.errors[0].message);
  const Program out(dialect("fanuc"), c.out);
  double minutes = 0;
  for (const auto& m : out.motions)
    if (m.feed_mode == gc::FeedMode::inverse_time) minutes += 1 / m.feed;
  EXPECT_NEAR(minutes, 1 / 4.0, 1e-12);
  EXPECT_EQ(out.motions.size(), 1 + c.result.segments);
}

TEST(ConvertLinearize, LatheDiameterAndInchPrograms) {
  Converted lathe;
  run_convert("fanuc", "G18 G21 G99\nG0 X20. Z0\nG2 X40. Z-10. I0 K-10. F0.2\nM30\n", linearize_option(0.01), lathe, true);
  ASSERT_TRUE(lathe.committed) << (lathe.errors.empty() ? "" : lathe.errors[0].message);
  const Program lo(dialect("fanuc", true), lathe.out);
  for (std::size_t j = 1; j < lo.motions.size(); ++j)  // radius positions on the r = 10 arc about (10, -10)
    EXPECT_NEAR(std::hypot(lo.motions[j].end[0] - 10, lo.motions[j].end[2] + 10), 10, 0.01);
  EXPECT_NE(lathe.out.find("X40. Z-10.\n"), std::string::npos) << lathe.out;  // diameter, as written
  Converted inch;
  run_convert("fanuc", "G20 G90 G17\nG0 X0 Y0\nG2 X1. Y0 I.5 J0 F10.\n", linearize_option(0.01), inch);
  ASSERT_TRUE(inch.committed) << (inch.errors.empty() ? "" : inch.errors[0].message);
  const Program io(dialect("fanuc"), inch.out);
  for (std::size_t j = 1; j < io.motions.size(); ++j)
    EXPECT_NEAR(std::hypot(io.motions[j].end[0] - 12.7, io.motions[j].end[1]), 12.7, 0.01);
  EXPECT_NE(inch.out.find("X1. Y0\n"), std::string::npos) << inch.out;
}

TEST(ConvertLinearize, WithUnitsWorksInTheOutputsUnits) {
  gc::ConvertOptions o = linearize_option(0.01);
  o.units = gc::Units::inch;
  Converted c;
  run_convert("fanuc", "G21 G90 G17\nG0 X0 Y0\nG2 X25.4 Y0 I12.7 J0 F254.\nM30\n", o, c);
  ASSERT_TRUE(c.committed) << (c.errors.empty() ? "" : c.errors[0].message);
  EXPECT_EQ(c.out.rfind("G20 G90 G17\n", 0), 0u) << c.out;
  const Program out(dialect("fanuc"), c.out);
  for (std::size_t j = 1; j < out.motions.size(); ++j) {
    EXPECT_EQ(out.motions[j].type, gc::MotionType::linear);
    EXPECT_NEAR(std::hypot(out.motions[j].end[0] - 12.7, out.motions[j].end[1]), 12.7, 0.01);
  }
  EXPECT_NE(c.out.find("X1. Y0\n"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("F10."), std::string::npos) << c.out;
}

TEST(ConvertLinearize, Refusals) {
  struct Case {
    const char* program;
    double tol;
    std::uint64_t line;
  };
  const Case cases[] = {
      {"G21 G90\nG0 X0 Y0\nG2 X10.000 Y0 I5. J0\n", 0.0007, 3},  // tolerance below the rounding
      {"G21 G90\nG2 X10. Y0 I5. J0 F100.\n", 0.01, 2},             // no position before the arc
      {"G21 G90\nG0 X0 Y0\nG28 X0 Y0\nG2 X10. Y0 I5. J0\n", 0.01, 4},  // after G28
      {"G21 G90\nG0 X0 Y0\nG2 X[#1] Y0 I5. J0 F100.\n", 0.01, 3}, // expression: unresolved arc
      {"G21 G90\nG0 X0 Y0\nG2 X10. Y0 I5. J0 F#2\n", 0.01, 3},    // F given by a parameter
  };
  for (const auto& k : cases) {
    Converted c;
    run_convert("fanuc", k.program, linearize_option(k.tol), c);
    EXPECT_TRUE(c.refused_with("PP-E503")) << k.program;
    EXPECT_TRUE(c.error_on_line(k.line)) << k.program;
    EXPECT_TRUE(c.out.empty());
  }
}


TEST(ConvertLinearize, FanucWholeNumbersFollowTheIntegerInputSetting) {
  using In = gc::Dialect::IntegerInput;
  const std::string in = "G21 G90 G17\nG0 X0 Y0\nG2 X10000 Y0 I5000 J0 F100.\nM30\n";
  Converted unknown;
  run_convert(fanuc_input(In::unknown), in, linearize_option(0.01), unknown);
  EXPECT_TRUE(unknown.refused_with("PP-E503"));
  Converted increment;  // X10000 = 10 mm
  run_convert(fanuc_input(In::increment), in, linearize_option(0.01), increment);
  ASSERT_TRUE(increment.committed) << (increment.errors.empty() ? "" : increment.errors[0].message);
  const Program out(fanuc_input(In::increment), increment.out);
  for (std::size_t j = 1; j < out.motions.size(); ++j)
    EXPECT_NEAR(std::hypot(out.motions[j].end[0] - 5, out.motions[j].end[1]), 5, 0.01) << increment.out;
  EXPECT_NE(increment.out.find("X10000 Y0\n"), std::string::npos) << increment.out;  // the source's end text
  EXPECT_NEAR(out.motions.back().end[0], 10, 1e-12);
}

}  // namespace
