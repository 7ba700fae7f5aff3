// Issue 17 item 1: contour precompensation judged on an independent time-domain truth simulator
// (contour_truth.hpp): the samples of every machine kind, and random programs (fixed seed). The
// corrected program is never worse at its largest contour error than the original, its RMS is at
// least as good as the first-order lag precompensation's, and on smooth programs the RMS falls
// by 80 % or more.
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <random>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "contour_support.hpp"
#include "contour_truth.hpp"
#include "postproc/compensation/compensate.hpp"
#include "postproc/contour/precompensate.hpp"
#include "postproc/contour/simulate.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/machine/machine.hpp"

namespace {

namespace ct = postproc::contour;
namespace mc = postproc::machine;
namespace gc = postproc::gcode;
namespace comp = postproc::comp;
namespace kin = postproc::kin;

mc::Machine machine(const std::string& name) { return pptest::sample_machine(name); }
using pptest::kSamples;

ct::Path path_of(const std::string& text, const mc::Machine& m) {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  gc::DiagnosticSink sink;
  gc::LineReader in{std::string_view(text)};
  ct::Path p = ct::build_path(in, "t.nc", d, m, ct::PathOptions{}, sink);
  EXPECT_FALSE(sink.has_errors());
  return p;
}

struct Compensated {
  std::string text;
  comp::CompensateResult r;
};

Compensated compensate(const std::string& program, const mc::Machine& m, const std::string& mode) {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  comp::CompensateOptions opt;
  opt.mode = *postproc::comp::parse_mode(mode);
  opt.tool_version = "test";
  gc::DiagnosticSink sink;
  auto out = postproc::io::OutputFile::memory();
  Compensated c;
  c.r = comp::compensate_program({program, "t.nc", d, m}, opt, out, sink);
  EXPECT_FALSE(sink.has_errors());
  c.text = out.take();
  return c;
}

/// The truth figures of one program: the original, the corrected program as written, and the
/// first-order lag precompensation of the original's commands (contour::lag_precompensation).
struct Figures {
  pptruth::Truth original, corrected, lag;
  comp::CompensateResult r;
};

Figures judge(const std::string& program, const mc::Machine& m, const std::string& mode = "contour") {
  Figures f;
  const Compensated c = compensate(program, m, mode);
  f.r = c.r;
  const ct::Path original = path_of(program, m);
  const ct::Path written = path_of(c.text, m);
  pptruth::TruthOptions opt;
  opt.nominal = mode == "all";
  opt.tip_interpolation = true;  // tool-tip programs (the blade, G43.4) as the controller interpolates them
  f.original = pptruth::simulate_truth(original, original, *m.actual, opt);
  f.corrected = pptruth::simulate_truth(written, original, *m.actual, opt);
  if (mode == "contour") {
    ct::Path lag = original;
    const std::vector<kin::JointVector> q = ct::lag_precompensation(original);
    for (std::size_t i = 0; i < q.size(); ++i) {
      lag.points[i].q = q[i];
      // Tool-tip programs are interpolated from the program coordinates: the advanced joints as the
      // controller map writes them.
      if (!lag.maps.empty() && lag.maps[lag.points[i].map].form() != mc::Form::axes) {
        mc::Command cmd;
        if (lag.maps[lag.points[i].map].command(q[i], original.points[i].command, cmd).ok()) lag.points[i].command = cmd;
      }
    }
    f.lag = pptruth::simulate_truth(lag, original, *m.actual, opt);
  }
  return f;
}

// The harness itself, against the closed form: a circle of radius R at speed v on a lag-mode
// drive (Kv) is followed on a circle of radius R/√(1 + (v/(R·Kv))²) once the start transient has
// died away; a straight line has no contour error at all.
TEST(ContourTruth, HarnessMatchesTheFirstOrderLagOnACircle) {
  const mc::Machine& m = pptest::mill();
  const double R = 10, v = 3000.0 / 60.0, kv = 30;
  std::string prog = "G90 G54\nG0 X10. Y0. Z0.\n";
  // Three turns; the error is read on the last one.
  const int n = 720;
  for (int i = 1; i <= 3 * n / 2; ++i) {
    const double a = 2 * kin::kPi * i / (n / 2.0);
    prog += fmt::format("G1 X{:.4f} Y{:.4f}{}\n", R * std::cos(a), R * std::sin(a), i == 1 ? " F3000." : "");
  }
  prog += "M30\n";
  const ct::Path p = path_of(prog, m);
  ASSERT_EQ(p.runs.size(), 1u);
  // Measured over the whole run the largest error is the steady one (the transient at the start
  // cuts inside less) or the stop's; the RMS is dominated by the steady circle.
  const pptruth::Truth t = pptruth::simulate_truth(p, p, *m.actual);
  const double w = v / R;
  const double steady = R - R / std::sqrt(1 + (w / kv) * (w / kv));
  EXPECT_NEAR(t.rms_mm, steady, 0.05 * steady) << "steady " << steady;
  const ct::Path line = path_of("G90 G54\nG0 X0 Y0 Z0\nG1 X50. Y20. F3000.\nX100. Y40.\nM30\n", m);
  EXPECT_LT(pptruth::simulate_truth(line, line, *m.actual).max_mm, 1e-6);
}

struct SampleCase {
  const char* program;
  const char* machine;
  const char* mode;
  double resolution_mm;  ///< the program's last written digit
};

class ContourTruthSample : public ::testing::TestWithParam<SampleCase> {};

TEST_P(ContourTruthSample, NeverWorseAtMaxAndAtLeastAsGoodAsLagPrecompensation) {
  const SampleCase c = GetParam();
  const mc::Machine m = machine(c.machine);
  const std::string prog = postproc::io::read_file(kSamples + "programs/" + c.program, "NC program");
  const Figures f = judge(prog, m, c.mode);
  std::printf("%s on %s --mode %s (truth): max %.3f -> %.3f um (lag %.3f), RMS %.3f -> %.3f um (lag %.3f)\n", c.program,
              c.machine, c.mode, f.original.max_mm * 1000, f.corrected.max_mm * 1000, f.lag.max_mm * 1000,
              f.original.rms_mm * 1000, f.corrected.rms_mm * 1000, f.lag.rms_mm * 1000);
  for (const comp::ContourRunReport& rr : f.r.contour_run_reports)
    if (rr.moves > 1)
      std::printf("    run at line %llu: %d iterations (%s), written %s; simulated max %.3f, iterated %.3f, lag %.3f um; "
                  "RMS %.3f, iterated %.3f, lag %.3f um\n",
                  static_cast<unsigned long long>(rr.line), rr.iterations, rr.stop.c_str(), rr.written.c_str(),
                  rr.before_mm * 1000, rr.iterated_mm * 1000, rr.lag_mm * 1000, rr.before_rms_mm * 1000,
                  rr.iterated_rms_mm * 1000, rr.lag_rms_mm * 1000);
  ASSERT_EQ(f.corrected.run_max_mm.size(), f.original.run_max_mm.size());
  EXPECT_LE(f.corrected.max_mm, f.original.max_mm);
  for (std::size_t r = 0; r < f.original.run_max_mm.size(); ++r)
    EXPECT_LE(f.corrected.run_max_mm[r], f.original.run_max_mm[r] * 1.0001 + 1e-6) << "run " << r;
  EXPECT_LT(f.corrected.rms_mm, f.original.rms_mm);
  // The lag baseline is the commands themselves (not rounded to the program's digits, not
  // re-timed by the controller); the written program is compared with it within half a digit.
  if (std::string(c.mode) == "contour") {
    EXPECT_LE(f.corrected.rms_mm, f.lag.rms_mm + 0.5 * c.resolution_mm);
  }
}

INSTANTIATE_TEST_SUITE_P(Samples, ContourTruthSample,
                         ::testing::Values(SampleCase{"cone_frustum_nas979.nc", "trunnion_ac_fanuc.toml", "contour", 1e-4},
                                           SampleCase{"cone_frustum_nas979.nc", "trunnion_ac_fanuc.toml", "all", 1e-4},
                                           SampleCase{"tilted_pocket_3prs_contour.nc", "hybrid_3prs_doc001.toml", "contour",
                                                      1e-3},
                                           SampleCase{"freeform_lathe_contour.ngc", "lathe_xzbc_doc004.toml", "contour", 1e-4},
                                           SampleCase{"blade_5axis_g43_4.nc", "trunnion_bc_fanuc.toml", "contour", 1e-3}));

/// A random program that does not cross itself: a star-shaped curve (radius 30 mm plus three
/// random harmonics, 0.9 of a turn; on the trunnion A and C move too), or with `corners` a random
/// polyline heading forward in X (a new direction within ±60° every 25 blocks of 0.3 mm). The feed
/// ramps up over the first and down over the last 20 blocks (the stop at full speed on a curve
/// cannot be corrected: docs/contour.md, limits). Paths that cross themselves are left out: the
/// verification's own simulator loses its foot point on them (issue 17 item 5, another change).
std::string random_program(std::mt19937& rng, bool five_axis, bool corners) {
  std::uniform_real_distribution<double> u(0, 1);
  const double feed = 2000 + 3000 * u(rng);
  double amp[3], phase[3];
  for (int k = 0; k < 3; ++k) {
    amp[k] = 6 * u(rng) / (k + 1);
    phase[k] = 2 * kin::kPi * u(rng);
  }
  const double pz = 2 * kin::kPi * u(rng), pa = 2 * kin::kPi * u(rng);
  const int n = 500;
  std::vector<std::array<double, 5>> pts;
  if (corners) {
    double x = 0, y = 0, dx = 1, dy = 0;
    for (int i = 0; i <= n; ++i) {
      if (i % 25 == 0 && i > 0) {
        const double a = kin::kPi / 3 * (2 * u(rng) - 1);
        dx = std::cos(a);
        dy = std::sin(a);
      }
      pts.push_back({x, y, 0, 0, 0});
      x += 0.3 * dx;
      y += 0.3 * dy;
    }
  } else {
    for (int i = 0; i <= n; ++i) {
      const double s = 1.8 * kin::kPi * i / n;
      double rho = 30;
      for (int k = 0; k < 3; ++k) rho += amp[k] * std::cos((k + 2) * s + phase[k]);
      pts.push_back({rho * std::cos(s), rho * std::sin(s), 2 * std::sin(s + pz), five_axis ? 10 * std::sin(s + pa) : 0.0,
                     five_axis ? 20 * s / kin::kPi : 0.0});
    }
  }
  const auto words = [&](const std::array<double, 5>& p) {
    return five_axis ? fmt::format("X{:.4f} Y{:.4f} Z{:.4f} A{:.4f} C{:.4f}", p[0], p[1], p[2] - 20, p[3], p[4])
                     : fmt::format("X{:.4f} Y{:.4f} Z{:.4f}", p[0], p[1], p[2]);
  };
  std::string s = "G90 G54\n";
  if (five_axis) s += "G43 H1\n";
  s += "G0 " + words(pts[0]) + "\n";
  int last_f = -1;
  for (int i = 1; i <= n; ++i) {
    const double ramp = std::min({1.0, i / 20.0, (n - i + 1) / 20.0});
    const int f = static_cast<int>(std::max(200.0, feed * ramp));
    s += "G1 " + words(pts[static_cast<std::size_t>(i)]) + (f != last_f ? fmt::format(" F{}.", f) : std::string()) + "\n";
    last_f = f;
  }
  s += "G0 Z50.\nM30\n";
  return s;
}

/// `rms_cut`: the RMS must fall by at least this fraction; `beat_lag`: and be at most the lag
/// precompensation's (within half a written digit, 0.1 µm: the baseline is not rounded).
void property(const mc::Machine& m, bool five_axis, bool corners, unsigned seed, double rms_cut, bool beat_lag) {
  std::mt19937 rng(seed);
  double worst_cut = 0;
  for (int k = 0; k < 6; ++k) {
    const std::string prog = random_program(rng, five_axis, corners);
    const Figures f = judge(prog, m);
    const double cut = f.corrected.rms_mm / f.original.rms_mm;
    worst_cut = std::max(worst_cut, cut);
    std::printf("  program %d: max %.3f -> %.3f um (lag %.3f), RMS %.3f -> %.3f um (lag %.3f), RMS -%.1f %%\n", k,
                f.original.max_mm * 1000, f.corrected.max_mm * 1000, f.lag.max_mm * 1000, f.original.rms_mm * 1000,
                f.corrected.rms_mm * 1000, f.lag.rms_mm * 1000, 100 * (1 - cut));
    for (const comp::ContourRunReport& rr : f.r.contour_run_reports)
      if (rr.moves > 1)
        std::printf("    run at line %llu: %d iterations (%s), written %s; simulated max %.3f, iterated %.3f, lag %.3f um; "
                    "RMS %.3f, iterated %.3f, lag %.3f um\n",
                    static_cast<unsigned long long>(rr.line), rr.iterations, rr.stop.c_str(), rr.written.c_str(),
                    rr.before_mm * 1000, rr.iterated_mm * 1000, rr.lag_mm * 1000, rr.before_rms_mm * 1000,
                    rr.iterated_rms_mm * 1000, rr.lag_rms_mm * 1000);
    EXPECT_LE(f.corrected.max_mm, f.original.max_mm) << "program " << k;
    if (beat_lag) {
      EXPECT_LE(f.corrected.rms_mm, f.lag.rms_mm + 5e-5) << "program " << k;
    }
    if (rms_cut > 0) {
      EXPECT_LE(cut, 1 - rms_cut) << "program " << k;
    }
  }
  std::printf("  smallest RMS cut: -%.1f %%\n", 100 * (1 - worst_cut));
}

TEST(ContourTruthProperty, SmoothRandomProgramsOnAThreeAxisMill) { property(pptest::mill(), false, false, 17, 0.8, true); }

// Sharp corners: never worse at the maximum, the RMS at least halved (measured: −82 % or more).
// Not asserted here: the lag precompensation's commands are better on this truth at corners (RMS
// about 5 µm against 16 … 41 µm). The verification's simulator now measures the input as the
// truth does (its "before" 446.8 … 980.8 µm where the truth has 446.8 … 980.7 µm; it lost its
// foot point here before issue 17 item 5 and reported 1.7 … 7.5 mm), but it simulates the lag
// candidate as written and read back (rounded, re-timed by the controller) at 273 … 838 µm
// against the truth's 63 … 70 µm for the unrounded commands on the original's timing, so the
// gate writes the iterated correction; that gap is not tracking (measured, seed 18).
TEST(ContourTruthProperty, RandomPolylinesWithCornersOnAThreeAxisMill) {
  property(pptest::mill(), false, true, 18, 0.5, false);
}

TEST(ContourTruthProperty, SmoothRandomProgramsOnTheAcTrunnion) {
  property(machine("trunnion_ac_fanuc.toml"), true, false, 19, 0.8, true);
}

}  // namespace
namespace {

/// Zigzags of the correction δ = command − program along the runs: points where joint j's
/// correction (larger than `floor`) changes sign both from the previous and to the next correctable point.
std::size_t zigzags(const ct::Path& p, const std::vector<kin::JointVector>& c, double floor) {
  std::size_t n = 0;
  for (const ct::Run& run : p.runs) {
    std::vector<std::size_t> idx;
    for (std::size_t i = run.begin; i < run.end; ++i)
      if (ct::correctable(p, run, i)) idx.push_back(i);
    for (int j = 0; j < p.joints; ++j)
      for (std::size_t k = 1; k + 1 < idx.size(); ++k) {
        const double a = c[idx[k - 1]][j] - p.points[idx[k - 1]].q[j], b = c[idx[k]][j] - p.points[idx[k]].q[j],
                     d = c[idx[k + 1]][j] - p.points[idx[k + 1]].q[j];
        if (std::abs(b) > floor && a * b < 0 && b * d < 0) ++n;
      }
  }
  return n;
}

// Issue 17: "the corrections alternate in sign from block to block at corners". With the
// correction smoothed along the run (PrecompensateOptions::smoothing) the iterated commands of the
// random polylines with corners and of the 3-PRS pocket hardly zigzag (measured 0 … 92 of 2,000 …
// 10,000 point-joints); without it they do 10 … 20 times as often.
TEST(ContourSmoothness, TheCorrectionDoesNotAlternateInSign) {
  std::mt19937 rng(18);
  struct Case {
    std::string program;
    mc::Machine machine;
  };
  std::vector<Case> cases;
  for (int k = 0; k < 3; ++k) cases.push_back({random_program(rng, false, true), pptest::mill()});
  cases.push_back({postproc::io::read_file(kSamples + "programs/tilted_pocket_3prs_contour.nc", "NC program"),
                   machine("hybrid_3prs_doc001.toml")});
  std::size_t smooth_total = 0, raw_total = 0;
  for (const Case& c : cases) {
    const ct::Path p = path_of(c.program, c.machine);
    const ct::Reference ref(p, *c.machine.actual);
    ct::PrecompensateOptions raw;
    raw.smoothing = 0;
    const ct::Precompensation with = ct::precompensate(p, *c.machine.actual, ref);
    const ct::Precompensation without = ct::precompensate(p, *c.machine.actual, ref, raw);
    const std::size_t zs = zigzags(p, with.commands, 1e-4), zr = zigzags(p, without.commands, 1e-4);
    std::size_t checks = 0;
    for (const ct::Run& run : p.runs)
      for (std::size_t i = run.begin; i < run.end; ++i) checks += ct::correctable(p, run, i) ? static_cast<std::size_t>(p.joints) : 0;
    std::printf("  zigzags of the correction (> 0.1 um): %zu smoothed, %zu without smoothing, of %zu point-joints\n", zs, zr,
                checks);
    smooth_total += zs;
    raw_total += zr;
    EXPECT_LE(zs * 100, checks) << "more than 1 % of the point-joints zigzag";
    EXPECT_LE(zs * 10, zr);
  }
  EXPECT_LE(smooth_total * 20, raw_total);
}

}  // namespace
namespace {

// Issue 17 item 5: `simulate --reference` (and the compensate gate, which uses the same code) must
// not lose track on closely spaced passes: the foot is searched along the path, around the
// commanded point's place, not at the nearest point in space.

/// A zig-zag finishing pattern: `passes` straight passes of 40 moves of 0.5 mm in X, rising
/// 0.05 mm in Y per mm of X (slope 0.05), 0.05 mm apart in Y, joined by half circles of radius
/// 0.025 mm (12 chords); F3600 throughout. With `split`, every straight move is written as two.
std::string zigzag_program(int passes, bool split) {
  std::string s = "G90 G54\nG0 X0. Y0. Z0.\n";
  bool first = true;
  const auto move = [&](double x, double y) {
    s += fmt::format("G1 X{:.4f} Y{:.4f}{}\n", x, y, first ? " F3600." : "");
    first = false;
  };
  for (int p = 0; p < passes; ++p) {
    const bool forward = p % 2 == 0;
    for (int i = 1; i <= 40; ++i) {
      const double x = forward ? 0.5 * i : 20 - 0.5 * i;
      if (split) {
        const double xm = x + (forward ? -0.25 : 0.25);
        move(xm, 0.05 * p + 0.05 * xm);
      }
      move(x, 0.05 * p + 0.05 * x);
    }
    if (p + 1 == passes) break;
    const double xe = forward ? 20 : 0, yc = 0.05 * p + 0.05 * xe + 0.025;
    for (int k = 1; k <= 12; ++k) {
      const double a = -kin::kPi / 2 + kin::kPi * k / 12;
      move(xe + (forward ? 1 : -1) * 0.025 * std::cos(a), yc + 0.025 * std::sin(a));
    }
  }
  return s + "M30\n";
}

/// The 3-axis test mill with a lagging Y drive only (Kv 30/s, no feed-forward); X and Z follow
/// their commands exactly (full velocity feed-forward): on a straight move of slope θ at speed v
/// the contour error is the Y following error v·sin θ / Kv times cos θ.
const mc::Machine& y_lag_mill() {
  static const mc::Machine m = [] {
    std::string toml = pptest::mill3_toml();
    for (const char* a : {"[axes.X]\n", "[axes.Z]\n"}) toml.replace(toml.find(a), std::strlen(a), std::string(a) + "feed_forward = 1\n");
    gc::DiagnosticSink sink;
    auto parsed = mc::parse_machine("y_lag.toml", toml, sink);
    for (const auto& d : sink.stored()) ADD_FAILURE() << gc::format(d);
    if (!parsed) throw std::runtime_error("test machine does not parse");
    return std::move(*parsed);
  }();
  return m;
}

/// Distance from p to the polyline `pts` (cumulative arc length `arc`) over the chords that reach
/// into the arc-length window [lo, hi]; `place` gets the arc length of the nearest point.
double windowed_distance(const std::vector<Eigen::Vector3d>& pts, const std::vector<double>& arc, const Eigen::Vector3d& p,
                         double lo, double hi, double* place = nullptr) {
  double best = 1e300;
  for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
    if (arc[i + 1] < lo || arc[i] > hi) continue;
    const Eigen::Vector3d d = pts[i + 1] - pts[i];
    const double f = d.squaredNorm() > 0 ? std::clamp((p - pts[i]).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
    const double e = (pts[i] + f * d - p).norm();
    if (e < best) {
      best = e;
      if (place != nullptr) *place = arc[i] + f * (arc[i + 1] - arc[i]);
    }
  }
  return best;
}

TEST(SimulateTracking, ZigZagPassesCloserThanTheLag) {
  const mc::Machine& m = y_lag_mill();
  const ct::Path p = path_of(zigzag_program(8, false), m);
  ASSERT_EQ(p.runs.size(), 1u);
  const ct::Reference ref(p, *m.actual);
  ct::SimulateOptions so;
  so.keep_every = 1;
  const ct::Simulation sim = ct::simulate(p, ref, *m.actual, so);

  // 1. Analytic steady state on the straight passes: v = 60 mm/s, Kv = 30/s, tan θ = 0.05. Taken
  // where the Y drive has followed its new direction for 14 mm (7 time constants) and 1 mm
  // before the next turnaround.
  const double theta = std::atan(0.05);
  const double steady = 60.0 / 30.0 * std::sin(theta) * std::cos(theta);
  double mid_max = 0, mid_min = 1e9;
  std::size_t mid = 0;
  for (const ct::SimSample& s : sim.kept) {
    const double x = s.command[0], y = s.command[1];
    const long pass = std::lround((y - 0.05 * x) / 0.05);
    const double along = pass % 2 == 0 ? x : 20 - x;  // mm into the pass
    if (along < 14 || along > 19) continue;
    mid_max = std::max(mid_max, s.tip_mm);
    mid_min = std::min(mid_min, s.tip_mm);
    ++mid;
  }
  ASSERT_GT(mid, 500u);
  std::printf("zig-zag 0.05 mm apart, lag 0.1 mm: steady %.3f um, straight passes %.3f ... %.3f um; simulate max %.3f, "
              "RMS %.3f um\n",
              steady * 1000, mid_min * 1000, mid_max * 1000, sim.tip.max * 1000, sim.tip.rms * 1000);
  EXPECT_NEAR(mid_max, steady, 0.01 * steady);
  EXPECT_NEAR(mid_min, steady, 0.01 * steady);

  // 2. An independent measurement of the same samples: the tool points of the program as a
  // polyline (the half circles' chords depart from the fitted curve by 0.2 µm), the command's
  // place found by brute force among the chords near its last place (it only moves forward), and
  // the actual tip's distance to the chords within twice its distance to the command around it.
  std::vector<Eigen::Vector3d> pts;
  std::vector<double> arc{0};
  for (std::size_t i = p.runs[0].begin; i < p.runs[0].end; ++i) {
    kin::Pose pose;
    ASSERT_TRUE(m.actual->forward(p.points[i].q, pose).ok());
    if (!pts.empty()) arc.push_back(arc.back() + (pose.p - pts.back()).norm());
    pts.push_back(pose.p);
  }
  double s_cmd = 0, max_mm = 0, sum2 = 0;
  for (const ct::SimSample& s : sim.kept) {
    kin::Pose c, a;
    ASSERT_TRUE(m.actual->forward(s.command, c).ok());
    ASSERT_TRUE(m.actual->forward(s.actual, a).ok());
    windowed_distance(pts, arc, c.p, s_cmd, s_cmd + 1.0, &s_cmd);
    const double w = 2 * (a.p - c.p).norm() + 0.005;
    const double e = windowed_distance(pts, arc, a.p, s_cmd - w, s_cmd + w);
    max_mm = std::max(max_mm, e);
    sum2 += e * e;
  }
  const double rms_mm = std::sqrt(sum2 / static_cast<double>(sim.kept.size()));
  std::printf("  independent windowed measurement: max %.3f, RMS %.3f um\n", max_mm * 1000, rms_mm * 1000);
  EXPECT_NEAR(sim.tip.max, max_mm, 0.02 * max_mm);
  EXPECT_NEAR(sim.tip.rms, rms_mm, 0.02 * rms_mm);

  // 3. The truth harness (its own drive integration and search window): the same RMS. Its window
  // reaches ten points behind the last foot, so just after a turnaround it measures against the
  // end of the previous pass, 0.05 mm nearer: its maximum is lower there (measured 101 against
  // 124 µm), never higher.
  const pptruth::Truth truth = pptruth::simulate_truth(p, p, *m.actual);
  std::printf("  truth harness: max %.3f, RMS %.3f um\n", truth.max_mm * 1000, truth.rms_mm * 1000);
  EXPECT_NEAR(sim.tip.rms, truth.rms_mm, 0.03 * truth.rms_mm);
  EXPECT_GE(sim.tip.max, truth.max_mm);
  EXPECT_LE(sim.tip.max, 1.25 * truth.max_mm);

  // 4. The same program written with every straight move split in two, measured against the
  // original's reference (other points: the command's place is tracked forward): the same figures.
  const ct::Path split = path_of(zigzag_program(8, true), m);
  const ct::Simulation s2 = ct::simulate(split, ref, *m.actual);
  std::printf("  split moves against the original: max %.3f, RMS %.3f um\n", s2.tip.max * 1000, s2.tip.rms * 1000);
  EXPECT_NEAR(s2.tip.max, sim.tip.max, 0.02 * sim.tip.max);
  EXPECT_NEAR(s2.tip.rms, sim.tip.rms, 0.02 * sim.tip.rms);
}

// The blade sample on the B/C trunnion, simulated against its own reference (what the compensate
// gate measures as "before"): the largest tool-tip error is the truth harness's within 10 %
// (before: 12.9 mm against about 0.19 mm).
TEST(SimulateTracking, BladeAgainstItselfAgreesWithTheTruth) {
  const mc::Machine m = machine("trunnion_bc_fanuc.toml");
  const std::string prog = postproc::io::read_file(kSamples + "programs/blade_5axis_g43_4.nc", "NC program");
  const ct::Path p = path_of(prog, m);
  const ct::Reference ref(p, *m.actual);
  const ct::Simulation sim = ct::simulate(p, ref, *m.actual);
  pptruth::TruthOptions topt;
  topt.tip_interpolation = true;  // a G43.4 program: the controller interpolates the tool tip
  const pptruth::Truth truth = pptruth::simulate_truth(p, p, *m.actual, topt);
  std::printf("blade on the B/C trunnion: simulate max %.3f, RMS %.3f um; truth max %.3f, RMS %.3f um\n", sim.tip.max * 1000,
              sim.tip.rms * 1000, truth.max_mm * 1000, truth.rms_mm * 1000);
  EXPECT_NEAR(sim.tip.max, truth.max_mm, 0.1 * truth.max_mm);
  ASSERT_EQ(sim.run_tip_max.size(), truth.run_max_mm.size());
  for (std::size_t r = 0; r < truth.run_max_mm.size(); ++r)
    EXPECT_LE(sim.run_tip_max[r], 1.1 * truth.run_max_mm[r] + 1e-3) << "run " << r;
}

}  // namespace
