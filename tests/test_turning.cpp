// Turning moves on a mill-turn ([machine] turning_spindle = "C", issue 17 item 4): while the spindle
// turns (M3/M4) a block means the tool tip's radius and Z; the correction moves X and Z only, never
// writes C, and is checked here independently: the written X Z on the calibrated model give the
// nominal radius and Z about the real spindle axis (the circle the tip traces as C spins). C programmed while spinning is refused
// located; facing to the centre past a centre-height error is written at the closest approach and
// said; the machine file's key is checked; the contour modes refuse turning moves located.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "postproc/compensation/compensate.hpp"
#include "postproc/contour/precompensate.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/machine/machine.hpp"
#include "support.hpp"

namespace {
namespace mc = postproc::machine;
namespace gc = postproc::gcode;
namespace cp = postproc::comp;
namespace kin = postproc::kin;

const std::string kLathe = std::string(POSTPROC_SOURCE_DIR) + "/samples/machines/lathe_xzbc_doc004.toml";

std::string lathe_text(const std::string& spindle) {
  std::string t = postproc::io::read_file(kLathe, "machine file");
  const std::string key = "interpolation_period = \"1 ms\"\n";
  const auto at = t.find(key);
  EXPECT_NE(at, std::string::npos);
  if (!spindle.empty()) t.insert(at + key.size(), "turning_spindle = \"" + spindle + "\"\n");
  return t;
}

std::optional<mc::Machine> parse(const std::string& text, gc::DiagnosticSink& sink) {
  return mc::parse_machine("lathe.toml", text, sink);
}

struct Outcome {
  std::string out;
  gc::DiagnosticSink sink;
  cp::CompensateResult result;
};

void compensate(const mc::Machine& m, const std::string& program, Outcome& r, const std::string& mode = "geometric") {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  pptest::TempDir dir;
  const std::string path = dir.file("out.ngc");
  cp::CompensateOptions opt;
  opt.header = false;
  opt.mode = *postproc::comp::parse_mode(mode);
  postproc::io::OutputFile out(path);
  if (mode == "contour") {
    r.result = cp::compensate_contour({program, "turn.ngc", d, m}, opt, out, r.sink);
  } else {
    gc::LineReader reader{std::string_view(program)};
    r.result = cp::compensate(reader, "turn.ngc", d, m, opt, out, r.sink);
  }
  if (r.sink.has_errors()) return;
  out.commit();
  r.out = postproc::io::read_file(path, "output");
}

// The X / Z values each line leaves in force (modal), in order; -1e9 until given.
std::vector<std::pair<double, double>> xz_per_line(const std::string& text) {
  std::vector<std::pair<double, double>> out;
  std::istringstream in(text);
  std::string line;
  double x = -1e9, z = -1e9;
  static const std::regex word("([XZ])(-?[0-9]*\\.?[0-9]*)");
  while (std::getline(in, line)) {
    for (std::sregex_iterator it(line.begin(), line.end(), word), end; it != end; ++it)
      ((*it)[1] == "X" ? x : z) = std::stod((*it)[2]);
    out.emplace_back(x, z);
  }
  return out;
}

// The tool tip's radius and axial place about `model`'s spindle axis for program X Z (G54 of the
// sample: X −100), B 0: the tip at eight spindle angles traces a circle; its centre is their mean,
// its axis the normal of their plane, its radius their distance from the centre (all equal).
std::pair<double, double> radius_z(const mc::Machine& m, const kin::Model& model, double x, double z) {
  std::vector<Eigen::Vector3d> pts;
  for (int k = 0; k < 8; ++k) {
    kin::JointVector q = kin::JointVector::Zero(model.joint_count());
    q[m.joint_of_axis[0]] = x + m.work_offsets.at("G54")[0];
    q[m.joint_of_axis[2]] = z + m.work_offsets.at("G54")[2];
    q[m.joint_of_axis[5]] = 45.0 * k;
    kin::Pose p;
    EXPECT_TRUE(model.forward(q, p).ok());
    pts.push_back(p.p);
  }
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : pts) c += p / 8.0;
  Eigen::Vector3d n = (pts[0] - c).cross(pts[2] - c);
  if (n.norm() < 1e-15) return {0.0, c.z()};
  n.normalize();
  if (n.z() < 0) n = -n;
  double r = 0;
  for (const auto& p : pts) r += ((p - c) - (p - c).dot(n) * n).norm() / 8.0;
  return {r, c.dot(n)};
}

const std::string kProgram =
    "G21 G90 G54\nG0 B0\nM3 S1000\nG0 X20 Z2\nG1 X10 Z0 F100\nG1 Z-20\nG1 X6 Z-25\nG1 X2 Z-28\nG0 X30\nM5\nM2\n";

TEST(Turning, RadiusAndZAboutTheRealSpindleAxisCorrectedByXAndZOnly) {
  gc::DiagnosticSink ms;
  const auto m = parse(lathe_text("C"), ms);
  ASSERT_TRUE(m.has_value());
  ASSERT_EQ(m->turning_spindle_axis, 5);
  Outcome r;
  compensate(*m, kProgram, r);
  for (const auto& d : r.sink.stored())
    EXPECT_NE(d.severity, gc::Severity::error) << gc::format(d);
  ASSERT_FALSE(r.out.empty());
  EXPECT_EQ(r.out.find('C'), std::string::npos) << "no C word written:\n" << r.out;
  const auto before = xz_per_line(kProgram);
  const auto after = xz_per_line(r.out);
  ASSERT_EQ(before.size(), after.size());
  const double half_digit = 0.5e-4 * std::sqrt(2.0) + 1e-9;  // [axes] decimals = 4 for X and Z
  int checked = 0;
  double worst_before = 0;
  for (std::size_t i = 3; i + 2 < before.size(); ++i) {  // the turning moves (spindle on)
    const auto [x0, z0] = before[i];
    const auto [x1, z1] = after[i];
    const auto want = radius_z(*m, *m->nominal, x0, z0);
    const auto was = radius_z(*m, *m->actual, x0, z0);
    worst_before = std::max(worst_before, std::hypot(was.first - want.first, was.second - want.second));
    const auto got = radius_z(*m, *m->actual, x1, z1);
    EXPECT_LT(std::hypot(got.first - want.first, got.second - want.second), half_digit) << "line " << i + 1;
    ++checked;
  }
  EXPECT_EQ(checked, 6);
  EXPECT_GT(worst_before, 5 * half_digit) << "the machine's errors change the turned radius / Z";
}

TEST(Turning, SpindleAxisProgrammedWhileTurningIsRefusedLocated) {
  gc::DiagnosticSink ms;
  const auto m = parse(lathe_text("C"), ms);
  ASSERT_TRUE(m.has_value());
  Outcome r;
  compensate(*m, "G21 G90 G54\nG0 X20 Z2 B0 C0\nM3 S500\nG1 X10 C90 F100\nM5\nM2\n", r);
  bool found = false;
  for (const auto& d : r.sink.stored())
    found = found || (d.code == "PP-E605" && d.where.line == 4 && d.message.find("M5") != std::string::npos);
  EXPECT_TRUE(found);
  // After M5, C is an axis again: positioning it is compensated as an axis move.
  Outcome ok;
  compensate(*m, "G21 G90 G54\nG0 X20 Z2 B0 C0\nM3 S500\nG1 X10 F100\nM5\nG1 X12 C90\nM2\n", ok);
  EXPECT_FALSE(ok.sink.has_errors());
  EXPECT_NE(ok.out.find("C9"), std::string::npos) << ok.out;
}

TEST(Turning, FacingPastTheCentreHeightErrorIsWrittenAtTheClosestApproachAndSaid) {
  gc::DiagnosticSink ms;
  const auto m = parse(lathe_text("C"), ms);
  ASSERT_TRUE(m.has_value());
  Outcome r;
  compensate(*m, "G21 G90 G54\nG0 B0\nM3 S800\nG0 X10 Z0\nG1 X0 F50\nG1 X-0.0\nG0 Z5\nM5\nM2\n", r);
  int warned = 0;
  for (const auto& d : r.sink.stored()) {
    EXPECT_NE(d.severity, gc::Severity::error) << gc::format(d);
    if (d.code == "PP-W602") {
      ++warned;
      EXPECT_EQ(d.where.line, 5u) << gc::format(d);
    }
  }
  EXPECT_EQ(warned, 1) << "said once, at the first such block";
  // The written X is where the real tool passes the spindle axis closest: no X nearer the axis does better.
  const auto after = xz_per_line(r.out);
  const auto [x, z] = after[4];
  const double here = radius_z(*m, *m->actual, x, z).first;
  for (double dx : {-0.002, -0.0005, 0.0005, 0.002})
    EXPECT_LE(here, radius_z(*m, *m->actual, x + dx, z).first + 1e-7) << dx;
}

TEST(Turning, MachineFileKeyIsChecked) {
  for (const std::string bad : {"B", "A"}) {
    gc::DiagnosticSink sink;
    const auto m = parse(lathe_text(bad), sink);
    EXPECT_FALSE(m.has_value()) << bad;
    bool named = false;
    for (const auto& d : sink.stored()) named = named || d.message.find("turning_spindle") != std::string::npos;
    EXPECT_TRUE(named) << bad;
  }
  // Without the key the same program is axis positions: C is not known, the moves are refused.
  gc::DiagnosticSink ms;
  const auto m = parse(lathe_text(""), ms);
  ASSERT_TRUE(m.has_value());
  Outcome r;
  compensate(*m, kProgram, r);
  EXPECT_TRUE(r.sink.has_errors());
}

TEST(Turning, ContourModesRefuseTurningMovesLocated) {
  gc::DiagnosticSink ms;
  const auto m = parse(lathe_text("C"), ms);
  ASSERT_TRUE(m.has_value());
  Outcome r;
  compensate(*m, kProgram, r, "contour");
  bool found = false;
  for (const auto& d : r.sink.stored()) found = found || (d.code == "PP-E614" && d.where.line == 5);  // the first feed move
  EXPECT_TRUE(found);
}

}  // namespace
