// compensate: the corrected program on the actual machine reproduces the original on the nominal
// machine within the output rounding (samples and random programs); a machine without errors
// leaves programs byte for byte; refusals are located.
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include <fmt/format.h>

#include "postproc/compensation/compensate.hpp"
#include "postproc/compensation/geometric_report.hpp"
#include "postproc/error.hpp"
#include "postproc/machine/program_map.hpp"
#include "postproc/compensation/verify.hpp"
#include "postproc/machine/machine.hpp"
#include "sample_machine.hpp"
#include "support.hpp"

namespace {
namespace mc = postproc::machine;
namespace gc = postproc::gcode;
namespace cp = postproc::comp;
using pptest::TempDir;

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

const std::string kSamples = std::string(POSTPROC_SOURCE_DIR) + "/samples/";

mc::Machine load(const std::string& name) { return pptest::sample_machine(name); }

struct Comp {
  std::string out;
  std::vector<std::uint64_t> line_map;
  cp::CompensateResult result;
  gc::DiagnosticSink sink;
  bool committed = false;
};

void compensate(const mc::Machine& m, const std::string& program, Comp& r, cp::CompensateOptions opt = {}) {
  gc::DialectOptions dopt = m.dialect_options;
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, dopt);
  TempDir dir;
  const std::string path = dir.file("out.nc");
  opt.line_map = &r.line_map;
  opt.tool_version = "test";
  {
    gc::LineReader reader{std::string_view(program)};
    postproc::io::OutputFile out(path);
    r.result = cp::compensate(reader, "in.nc", d, m, opt, out, r.sink);
    if (!r.sink.has_errors()) {
      out.commit();
      r.committed = true;
    }
  }
  if (r.committed) r.out = read_file(path);
}

cp::VerifyResult check(const mc::Machine& m, const std::string& program, const Comp& r) {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  return cp::verify(program, r.out, r.line_map, d, m);
}

/// The same machine without any error: actual = nominal.
mc::Machine without_errors(mc::Machine m) {
  m.actual = m.nominal;
  return m;
}

struct SampleCase {
  const char* machine;
  const char* program;
};

class Samples : public ::testing::TestWithParam<SampleCase> {};

/// The sample's program compensated for its machine with the tests' limits.
void compensate_sample(const mc::Machine& m, const std::string& program, Comp& r) {
  cp::CompensateOptions opt;
  // The blade's drilled holes lean 1.3 µm over their depth on this machine (B/C and squareness
  // errors): a cycle cannot follow a leaning axis, so it is accepted only within the limit.
  if (std::string(Samples::GetParam().program) == "blade_5axis_g43_4.nc") opt.max_deviation_mm = 0.002;
  compensate(m, program, r, opt);
}

TEST_P(Samples, CorrectedProgramOnActualMachineReproducesNominalPathWithinRounding) {
  const mc::Machine m = load(GetParam().machine);
  const std::string program = read_file(kSamples + "programs/" + GetParam().program);
  Comp r;
  compensate_sample(m, program, r);
  for (const auto& d : r.sink.stored())
    if (d.severity == gc::Severity::error) ADD_FAILURE() << gc::format(d);
  ASSERT_TRUE(r.committed);
  const cp::VerifyResult v = check(m, program, r);
  EXPECT_GT(v.compared, 5u);
  // The machine's errors matter (tens of µm), the corrected program removes them down to rounding.
  EXPECT_GT(v.max_error_before_mm, 0.005);
  EXPECT_LE(v.max_excess_mm, 1e-7) << "line " << v.worst_line << ", error " << v.max_error_mm << " mm, bound "
                                   << v.max_bound_mm << " mm";
  EXPECT_LT(v.max_error_mm, v.max_error_before_mm / 5);
  // The header names the tool, the mode, the machine file and its hash.
  EXPECT_NE(r.out.find(fmt::format("postproc test compensate mode=geometric machine={}machines/{} sha256={}", kSamples,
                                   GetParam().machine, m.sha256)),
            std::string::npos);
}

// The HTML report of a geometric compensation shows what verify() finds on the written program
// read back: every compared point, the largest errors of the original (which the compensator
// found on its own, from the original's words) and of the corrected program.
TEST_P(Samples, GeometricReportShowsTheVerifiedFigures) {
  const mc::Machine m = load(GetParam().machine);
  const std::string program = read_file(kSamples + "programs/" + GetParam().program);
  Comp r;
  compensate_sample(m, program, r);
  ASSERT_TRUE(r.committed);
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  std::vector<cp::VerifyPoint> points;
  const cp::VerifyResult v = cp::verify(program, r.out, r.line_map, d, m, &points);
  ASSERT_EQ(points.size(), v.compared);
  double before = 0, after = 0, before_rad = 0;
  for (const cp::VerifyPoint& p : points) {
    before = std::max(before, p.before_mm);
    before_rad = std::max(before_rad, p.before_rad);
    after = std::max(after, p.after_mm);
    EXPECT_LE(p.after_mm, p.bound_mm + 1e-7) << "line " << p.line;
  }
  EXPECT_EQ(after, v.max_error_mm);
  EXPECT_EQ(before, v.max_error_before_mm);
  // (The hexapod's forward kinematics iterates: the two evaluations agree to its tolerance.)
  EXPECT_NEAR(before, r.result.max_error_before_mm, 1e-8);
  EXPECT_NEAR(before_rad, r.result.max_error_before_rad, 1e-10);
  cp::GeometricReport gr;
  gr.program = GetParam().program;
  gr.verify = &v;
  gr.points = &points;
  const std::string html = cp::geometric_report_html(gr);
  EXPECT_NE(html.find(fmt::format("id=\"before-tip-max-um\">{:.3f}<", before * 1000)), std::string::npos);
  EXPECT_NE(html.find(fmt::format("id=\"after-tip-max-um\">{:.3f}<", after * 1000)), std::string::npos);
  cp::GeometricReport missing;
  EXPECT_THROW((void)cp::geometric_report_html(missing), postproc::Error);
}

TEST_P(Samples, MachineWithoutErrorsLeavesTheProgramByteForByte) {
  const mc::Machine m = without_errors(load(GetParam().machine));
  const std::string program = read_file(kSamples + "programs/" + GetParam().program);
  Comp r;
  cp::CompensateOptions opt;
  opt.header = false;
  compensate(m, program, r, opt);
  ASSERT_TRUE(r.committed);
  EXPECT_EQ(r.out, program);
  EXPECT_EQ(r.result.changed_blocks, 0u);
}

INSTANTIATE_TEST_SUITE_P(Compensate, Samples,
                         ::testing::Values(SampleCase{"trunnion_bc_fanuc.toml", "blade_5axis_g43_4.nc"},
                                           SampleCase{"trunnion_bc_fanuc.toml", "impeller_axes_bc.nc"},
                                           SampleCase{"trunnion_bc_heidenhain.toml", "impeller_axes_bc.h"},
                                           SampleCase{"trunnion_ac_siemens.toml", "housing_traori.mpf"},
                                           SampleCase{"hybrid_3prs_doc001.toml", "tilted_pocket_3prs.nc"},
                                           SampleCase{"hexapod_doc003.toml", "freeform_hexapod_g43_5.nc"},
                                           SampleCase{"lathe_xzbc_doc004.toml", "freeform_lathe_xzbc.ngc"},
                                           SampleCase{"mill3_stepgauge_map.toml", "pocket_3axis_map.nc"}),
                         [](const auto& tp) {
                           std::string n = std::string(tp.param.machine) + "_" + tp.param.program;
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

/// Random axis programs over the travel: every corrected end point within rounding.
TEST(Compensate, RandomFiveAxisProgramsWithinRounding) {
  const mc::Machine m = load("trunnion_bc_fanuc.toml");
  std::mt19937_64 rng(20261122);
  const int count = std::getenv("POSTPROC_PROPERTY_COUNT") ? std::atoi(std::getenv("POSTPROC_PROPERTY_COUNT")) : 4;
  std::uniform_real_distribution<double> x(-200, 200), y(-150, 150), z(-50, 200), b(-90, 90), c(-720, 720);
  for (int k = 0; k < count; ++k) {
    std::string program = "%\nO1000\nG21 G90 G94 G54\nG43 H7\n";
    program += fmt::format("G0 X{:.3f} Y{:.3f} Z{:.3f} B{:.3f} C{:.3f}\n", x(rng), y(rng), z(rng), b(rng), c(rng));
    for (int i = 0; i < 25; ++i)
      program += fmt::format("G1 X{:.3f} Y{:.3f} Z{:.3f} B{:.3f} C{:.3f} F1000.\n", x(rng), y(rng), z(rng), b(rng), c(rng));
    program += "M30\n%\n";
    Comp r;
    compensate(m, program, r);
    for (const auto& d : r.sink.stored())
      if (d.severity == gc::Severity::error) ADD_FAILURE() << gc::format(d);
    ASSERT_TRUE(r.committed) << program;
    const cp::VerifyResult v = check(m, program, r);
    EXPECT_EQ(v.compared, 26u);
    EXPECT_LE(v.max_excess_mm, 1e-7) << "program " << k << " line " << v.worst_line;
    // Long random moves leave the path between end points: they are subdivided.
    EXPECT_GT(r.result.subdivided_blocks, 0u);
  }
}

TEST(Compensate, TravelExceededIsRefusedWithTheLine) {
  const mc::Machine m = load("trunnion_bc_fanuc.toml");
  // X499.999 plus the corrections at B60 C45 leaves the 500 mm travel (by 0.022 mm).
  const std::string program = "G21 G90 G54\nG0 X0 Y0 Z100 B60 C45\nG1 X499.999 F1000\nM30\n";
  Comp r;
  compensate(m, program, r);
  EXPECT_FALSE(r.committed);
  bool found = false;
  for (const auto& d : r.sink.stored())
    found = found || (d.code == "PP-E603" && d.where.line == 3 && d.message.find("joint X") != std::string::npos);
  EXPECT_TRUE(found);
}

TEST(Compensate, UnknownWorkOffsetAndToolLengthAreRefusedNamingTheFix) {
  const mc::Machine m = load("trunnion_bc_fanuc.toml");
  Comp r;
  compensate(m, "G90 G57\nG0 X0 Y0 Z100 B0 C0\n", r);
  ASSERT_FALSE(r.sink.stored().empty());
  EXPECT_EQ(r.sink.stored().front().code, "PP-E602");
  EXPECT_NE(r.sink.stored().front().message.find("[work_offsets] G57"), std::string::npos);
  Comp r2;
  compensate(m, "G90 G54\nG0 X0 Y0 Z100 B0 C0\nG0 G43 H12 Z100\n", r2);
  ASSERT_FALSE(r2.sink.stored().empty());
  EXPECT_NE(r2.sink.stored().front().message.find("H12"), std::string::npos);
}

/// A program that writes its own work offset with plain numbers (LinuxCNC G-code reference "G10 L2
/// Set Coordinate System"; Fanuc B-64484EN "Changing workpiece coordinate system by programmed
/// command (G10)", G90) is placed where it puts the origin: the output equals that of the same
/// program without the G10 on a machine file whose G54 holds those values (axes not written keep
/// the machine file's). G10 L2 under Fanuc G91 (added to a value not known here) and G10 L20
/// (from the current point) are still refused.
TEST(Compensate, WorkOffsetWrittenByTheProgramIsWhereItPutsIt) {
  mc::Machine m = load("trunnion_bc_fanuc.toml");
  const std::string body = "G0 X0 Y0 Z100 B0 C0\nG1 X20 Y10 Z50 B-20 C30 F500\nM30\n";
  Comp with_g10;
  compensate(m, "G90 G10 L2 P1 X12.5 Y-7 Z3\nG54\n" + body, with_g10);
  ASSERT_TRUE(with_g10.committed) << (with_g10.sink.stored().empty() ? "" : with_g10.sink.stored().front().message);
  mc::Machine moved = m;
  gc::AxisVector g54 = moved.work_offsets.at("G54");
  g54[0] = 12.5;
  g54[1] = -7;
  g54[2] = 3;
  moved.work_offsets["G54"] = g54;
  Comp plain;
  compensate(moved, "G90 G54\n" + body, plain);
  ASSERT_TRUE(plain.committed);
  // The bodies from the first move on (the headers differ: the machine file's hash, the G10 line).
  const auto body_of = [](const std::string& t) { return t.substr(std::min(t.size(), t.find("G0 X"))); };
  EXPECT_EQ(body_of(with_g10.out), body_of(plain.out));
  EXPECT_NE(body_of(with_g10.out), body);  // it was corrected
}

/// G92 at a point the program does not know (after G28 the axes are at the controller's reference
/// point) shifts the program's coordinates by an unknown amount: the later moves are refused,
/// located and naming the shift, not placed on the machine with a made-up shift.
/// Whether the run refused at `line` with a message holding `text` (and, if given, code `code`).
::testing::AssertionResult refused_at(const Comp& r, std::uint64_t line, std::string_view text, std::string_view code = {}) {
  if (r.committed) return ::testing::AssertionFailure() << "the program was written";
  for (const auto& d : r.sink.stored())
    if (d.where.line == line && d.message.find(text) != std::string::npos && (code.empty() || d.code == code))
      return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "no refusal at line " << line << " naming '" << text << "'; first: "
                                       << (r.sink.stored().empty() ? std::string() : r.sink.stored().front().message);
}

TEST(Compensate, G92WhereThePositionIsUnknownIsRefusedNamingTheShift) {
  const mc::Machine m = load("trunnion_bc_fanuc.toml");
  Comp r;
  compensate(m, "G90 G54\nG0 X0 Y0 Z100 B0 C0\nG91 G28 Z0\nG90 G92 Z50\nG1 X10 F100\n", r);
  EXPECT_TRUE(refused_at(r, 5, "G92 shift of Z", "PP-E602"));
  // The same G92 where Z is known is an ordinary shift.
  Comp known;
  compensate(m, "G90 G54\nG0 X0 Y0 Z100 B0 C0\nG92 Z50\nG1 X10 F100\n", known);
  EXPECT_TRUE(known.committed) << (known.sink.stored().empty() ? std::string() : known.sink.stored().front().message);
}

/// G10 L10 rewrites H1's geometry offset: the machine file's length for H1 is no longer the
/// controller's, so the moves under G43 H1 are refused, naming the G10, not compensated with it.
TEST(Compensate, ToolLengthRewrittenByG10IsRefused) {
  const mc::Machine m = load("trunnion_bc_fanuc.toml");
  Comp r;
  compensate(m, "G90 G54\nG0 X0 Y0 Z100 B0 C0\nG10 L10 P1 R5.\nG43 H1 Z100.\nG1 X10. F100.\n", r);
  EXPECT_TRUE(refused_at(r, 4, "rewrote the length of tool H1"));
  // The same G10 while G43 H1 is already in force: the length in force changes at the next G43 H
  // (as the reader holds it), so the move after it keeps the machine file's length; the next G43 H1
  // is refused.
  mc::Machine with_h1 = m;
  with_h1.tool_lengths[1] = 100.0;
  with_h1.dialect_options.tool_lengths = with_h1.tool_lengths;
  Comp after;
  compensate(with_h1, "G90 G54\nG0 X0 Y0 Z100 B0 C0\nG43 H1 Z100.\nG1 X5. F100.\nG10 L10 P1 R5.\nG1 X10.\nG43 H1 Z90.\n",
             after);
  EXPECT_TRUE(refused_at(after, 7, "rewrote the length of tool H1"));
}

/// G10 writes of a work offset whose value is not known here (Fanuc G10 L2 under G91: added to the
/// table's value; LinuxCNC G10 L2 with R, G10 L20 from the current point) leave the machine file's
/// value for that system no longer where the controller puts the program: the moves under it are
/// refused, naming the G10 (Fanuc B-64484EN "Changing workpiece coordinate system by programmed
/// command (G10)"; LinuxCNC G-code reference "G10 L2", "G10 L20"). A write of another system does
/// not touch the active one until the program selects it. Plain G90 values are taken
/// (WorkOffsetWrittenByTheProgramIsWhereItPutsIt).
TEST(Compensate, WorkOffsetWrittenByG10IsRefused) {
  const mc::Machine m = load("trunnion_bc_fanuc.toml");
  Comp fanuc;
  compensate(m, "G90 G54\nG0 X0 Y0 Z100 B0 C0\nG91 G10 L2 P1 X5.\nG90 G0 X10. Y10. Z50.\nG1 X20. F100.\n", fanuc);
  EXPECT_TRUE(refused_at(fanuc, 4, "wrote work offset G54"));
  Comp other;
  compensate(m, "G90 G54\nG0 X0 Y0 Z100 B0 C0\nG10 L2 P2 X5.\nG0 X10. Y10. Z50.\nG1 X20. F100.\n", other);
  EXPECT_TRUE(other.committed) << (other.sink.stored().empty() ? std::string() : other.sink.stored().front().message);
  mc::Machine l = m;
  l.dialect_name = "linuxcnc";
  Comp rot;
  compensate(l, "G21 G90 G54\nG0 X0 Y0 Z100 B0 C0\nG10 L2 P0 R30\nG0 X10 Y10 Z50\nG1 X20 F100\nM2\n", rot);
  EXPECT_TRUE(refused_at(rot, 4, "wrote work offset G54"));
  Comp l20;
  compensate(l, "G21 G90 G54\nG0 X0 Y0 Z100 B0 C0\nG10 L20 P1 Z90\nG0 X10 Y10 Z50\nM2\n", l20);
  EXPECT_TRUE(refused_at(l20, 4, "wrote work offset G54"));
}

TEST(Compensate, FeedMoveWithUnknownAxisIsRefusedRapidIsKept) {
  const mc::Machine m = load("trunnion_bc_fanuc.toml");
  Comp r;
  compensate(m, "G90 G54\nG0 X10 Y10\nG1 X20 F100\n", r);
  ASSERT_EQ(r.sink.count(gc::Severity::error), 1u);
  EXPECT_EQ(r.sink.count(gc::Severity::warning), 1u);  // the rapid: PP-W601
  for (const auto& d : r.sink.stored())
    if (d.severity == gc::Severity::error) {
      EXPECT_EQ(d.where.line, 3u);
    }
}

/// Issue 17: a program whose first rapid gives only Z. The other axes stay where the controller
/// holds them (it moves only the named axes): on a machine without errors nothing is refused
/// (the G55 program was refused with "X would be at -620 mm"), nothing is warned, the program is
/// kept byte for byte and every figure is ~0 (the residual was 113 mm / 110 deg, 141 mm on the
/// hexapod: figures from an assumed 0 against a sample at the end of the travel).
TEST(Compensate, FirstRapidWithOnlyZOnMachineWithoutErrorsKeepsProgramAndReportsZeroFigures) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"trunnion_bc_fanuc.toml", "G90 G17 G21 G55\nG0 Z50.\nG0 X10. Y20.\nG1 X30. Y20. F500\nG1 X30. Y40.\nM30\n"},
      {"trunnion_bc_fanuc.toml", "G90 G17 G21\nG0 Z50.\nG0 X10. Y20.\nG1 X30. Y20. F500\nM30\n"},
      {"trunnion_ac_siemens.toml", "G90 G17 G71 G55\nG0 Z50.\nG1 X10. Y20. F500\nM30\n"},
      {"hexapod_doc003.toml", "G21 G90 G54\nG0 G43.5 H5 Z40. I0. J0. K1.\nG0 X10. Y5.\nG1 X-20. Y-10. Z5. F1500.\nM30\n"},
      {"hybrid_3prs_doc001.toml", "G21 G90 G54\nG0 Z50.\nG0 X-40. Y-25. Z20. A12. B-15.\nG1 Z2. F800.\nM30\n"},
  };
  for (const auto& [machine, program] : cases) {
    SCOPED_TRACE(machine + ": " + program);
    const mc::Machine m = without_errors(load(machine));
    Comp r;
    cp::CompensateOptions opt;
    opt.header = false;
    compensate(m, program, r, opt);
    for (const auto& d : r.sink.stored()) ADD_FAILURE() << gc::format(d);
    ASSERT_TRUE(r.committed);
    EXPECT_EQ(r.out, program);
    EXPECT_LT(r.result.max_error_before_mm, 1e-9);
    EXPECT_LT(r.result.max_error_before_rad, 1e-7);  // acos of a unit dot product: 1.5e-8 noise
    // The written values are the program's own: only the output rounding of the remap remains.
    EXPECT_LT(r.result.max_residual_mm, 1e-6);
    EXPECT_LT(r.result.max_residual_rad, 1e-7);
  }
}

/// Issue 17: an inch program is corrected as accurately as the same program in mm, up to the
/// output resolution (0.0001 in = 2.54 µm against 0.001 mm). [axes] decimals count in mm; inch
/// words were written and judged at 3 decimals (25.4 µm): residual 18.6 µm against 1.4 µm.
TEST(Compensate, InchProgramCorrectedToTheInchResolution) {
  const mc::Machine m = load("trunnion_bc_fanuc.toml");
  std::string mm = "G21 G90 G94 G17 G54\nG0 X0. Y0. Z100. B0. C0.\n";
  std::string in = "G20 G90 G94 G17 G54\nG0 X0. Y0. Z3.937 B0. C0.\n";
  for (int i = 0; i < 30; ++i) {
    const double x = 2 + 0.1 * i, y = 1 + 0.5 * std::sin(i / 5.0), z = 1 - 0.01 * i, b = 20 + 0.5 * i, c = 30 + 2 * i;
    mm += fmt::format("G1 X{:.3f} Y{:.3f} Z{:.3f} B{:.3f} C{:.3f} F500.\n", 25.4 * x, 25.4 * y, 25.4 * z, b, c);
    in += fmt::format("G1 X{:.4f} Y{:.4f} Z{:.4f} B{:.3f} C{:.3f} F20.\n", x, y, z, b, c);
  }
  Comp rm, ri;
  compensate(m, mm, rm);
  compensate(m, in, ri);
  ASSERT_TRUE(rm.committed);
  ASSERT_TRUE(ri.committed);
  // Half an output increment on each of three axes, plus the rotary words' rounding.
  EXPECT_LT(rm.result.max_residual_mm, 2e-3);
  EXPECT_LT(ri.result.max_residual_mm, 3e-3);
  EXPECT_GT(ri.result.max_error_before_mm, 0.02);  // there is something to correct
  const cp::VerifyResult v = check(m, in, ri);
  EXPECT_EQ(v.compared, 31u);
  EXPECT_LE(v.max_excess_mm, 1e-7);
  EXPECT_LT(v.max_error_mm, 3e-3);
}

TEST(Compensate, InverseTimeFeedScaledWhenSubdivided) {
  const mc::Machine m = load("trunnion_bc_fanuc.toml");
  const std::string program = "G90 G54 G21\nG0 X0 Y0 Z100 B0 C0\nG93 G1 X150 Y80 Z20 B60 C200 F2.\nM30\n";
  Comp r;
  compensate(m, program, r);
  ASSERT_TRUE(r.committed);
  ASSERT_EQ(r.result.subdivided_blocks, 1u);
  const std::uint64_t n = r.result.segments_added + 1;
  // Every segment carries F = 2 × n so that the whole move keeps its 0.5 min.
  const std::string f = fmt::format("F{}", 2 * n);
  std::size_t count = 0;
  for (std::size_t at = r.out.find(f); at != std::string::npos; at = r.out.find(f, at + 1)) ++count;
  EXPECT_EQ(count, n) << r.out;
  EXPECT_LE(check(m, program, r).max_excess_mm, 1e-7);
}

}  // namespace

namespace {

TEST(ProgramMap, VirtualAnglesRoundTrip) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> ang(-80, 80);
  for (int i = 0; i < 1000; ++i) {
    const double a = ang(rng), b = ang(rng);
    const Eigen::Vector3d o = postproc::machine::virtual_ab_axis(a, b);
    EXPECT_NEAR(o.norm(), 1.0, 1e-15);
    const Eigen::Vector2d back = postproc::machine::virtual_ab_angles(o);
    EXPECT_NEAR(back[0], a, 1e-9);
    EXPECT_NEAR(back[1], b, 1e-9);
  }
  // A = B = 0 is the spindle axis; A turns it toward −Y, B toward +X.
  EXPECT_TRUE(postproc::machine::virtual_ab_axis(0, 0).isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_LT(postproc::machine::virtual_ab_axis(10, 0).y(), 0);
  EXPECT_GT(postproc::machine::virtual_ab_axis(0, 10).x(), 0);
}

/// The controller's map and its inverse agree: command(joints(c)) = c for every form.
TEST(ProgramMap, CommandOfJointsIsTheCommand) {
  const mc::Machine m = load("trunnion_bc_fanuc.toml");
  gc::AxisVector offset = gc::AxisVector::Zero();
  offset[0] = -120;
  offset[2] = 35;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> lin(-80, 80), b(-60, 60), c(-400, 400);
  for (postproc::machine::Form f : {postproc::machine::Form::axes, postproc::machine::Form::tcp_rotary, postproc::machine::Form::tcp_vector}) {
    const postproc::machine::ProgramMap map(m, m.nominal, m.actual, f, offset, f == postproc::machine::Form::axes, 85.25);
    postproc::kin::JointVector start = postproc::kin::JointVector::Zero(m.nominal->joint_count());
    for (int i = 0; i < 200; ++i) {
      postproc::machine::Command cmd;
      cmd.c << lin(rng), lin(rng), lin(rng), 0, b(rng), c(rng), 0, 0, 0;
      if (f == postproc::machine::Form::tcp_vector) {
        // A reachable vector: the nominal axis of some B/C.
        postproc::kin::JointVector q = start;
        q[0] = b(rng);
        q[1] = c(rng);
        postproc::kin::Pose p;
        ASSERT_TRUE(m.nominal->forward(q, p).ok());
        cmd.vector = p.axis();
        start = q;
      }
      postproc::kin::JointVector q;
      ASSERT_TRUE(map.joints(cmd, start, q).ok()) << postproc::machine::to_string(f);
      postproc::machine::Command back;
      ASSERT_TRUE(map.command(q, cmd, back).ok());
      for (int a = 0; a < 6; ++a) EXPECT_NEAR(back.c[a], cmd.c[a], 1e-8) << postproc::machine::to_string(f) << " axis " << a;
      EXPECT_LT((back.vector - cmd.vector).norm(), 1e-9);
    }
  }
}

}  // namespace

namespace {

/// After a change of work offset the held corrected position is re-established from the
/// program, and single-axis moves that follow are still within rounding everywhere.
TEST(Compensate, WorkOffsetChangeKeepsEveryEndPointWithinRounding) {
  const mc::Machine m = load("trunnion_bc_fanuc.toml");
  const std::string program =
      "G21 G90 G54\nG0 X0 Y0 Z100 B0 C0\nG1 X30 F500\nY20\nG55\nG0 X10 Y10 Z50 B-20 C30\nG1 X40\nY-15\nZ20\n"
      "G54 G0 X5 Y5 Z80 B0 C0\nG1 Y25\nM30\n";
  Comp r;
  compensate(m, program, r);
  for (const auto& d : r.sink.stored())
    if (d.severity == gc::Severity::error) ADD_FAILURE() << gc::format(d);
  ASSERT_TRUE(r.committed);
  const cp::VerifyResult v = check(m, program, r);
  EXPECT_EQ(v.compared, 9u);
  EXPECT_LE(v.max_excess_mm, 1e-7) << "line " << v.worst_line << "\n" << r.out;
}

}  // namespace
