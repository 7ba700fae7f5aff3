// Rotary axes that roll over at a full turn ([axes.C] rollover, issue 23): where the controller
// moves for an absolute word (Fanuc B-63534EN §20.2.1's example; LinuxCNC's own interpreter rs274
// with WRAPPED_ROTARY), which word reaches a corrected position (property over random moves), and
// a compensated program that crosses 0° read back to the corrected positions.
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <random>
#include <sstream>

#include <fmt/format.h>

#include "postproc/compensation/compensate.hpp"
#include "postproc/compensation/verify.hpp"
#include "postproc/gcode/rotary_rollover.hpp"
#include "src/gcode/rotary_direction.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/machine/machine.hpp"
#include "support.hpp"

namespace {
namespace gc = postproc::gcode;
namespace mc = postproc::machine;
namespace cp = postproc::comp;
using gc::RotaryRollover;

constexpr int kA = 3, kC = 5;

gc::Dialect with_rollover(std::string_view name, int axis, RotaryRollover r) {
  gc::DialectOptions o;
  o.rollover[static_cast<std::size_t>(axis)] = r;
  o.integer_input = gc::Dialect::IntegerInput::calculator;
  return *gc::make_dialect(name, o);
}

/// A sample machine file with `rollover = "<rule>"` in its [axes.C] table.
std::optional<mc::Machine> sample_with_c_rollover(const std::string& file, const std::string& rule) {
  std::ifstream in(std::string(POSTPROC_SOURCE_DIR) + "/samples/machines/" + file);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  const std::string anchor = "[axes.C]\n";
  if (text.find(anchor) == std::string::npos) return std::nullopt;
  text.replace(text.find(anchor), anchor.size(), anchor + "rollover = \"" + rule + "\"\n");
  gc::DiagnosticSink msink;
  auto m = mc::parse_machine(file, text, msink);
  for (const auto& diag : msink.stored()) ADD_FAILURE() << gc::format(diag);
  return m;
}

/// B-63534EN/02 §20.2.1 "Rotary axis roll-over", RAB = 0 (shorter way): from A0, A-150 moves −150
/// (coordinate 210), A540 −30 (180), A-620 −80 (100), G91 A380 +380 (120), G91 A-840 −840 (0).
TEST(RotaryRollover, FanucManualExampleShortestWay) {
  const gc::Dialect d = with_rollover("fanuc", kA, RotaryRollover::shortest);
  pptest::Program p(d, "G90 G0 A0\nN1 G90 A-150.0\nN2 G90 A540.0\nN3 G90 A-620.0\nN4 G91 A380.0\nN5 G91 A-840.0\nM30\n");
  ASSERT_EQ(p.motions.size(), 6u) << p.all_codes();
  const double moved[] = {-150, -30, -80, 380, -840};
  const double shown[] = {210, 180, 100, 120, 0};
  for (int i = 0; i < 5; ++i) {
    const gc::Motion& m = p.motions[static_cast<std::size_t>(i + 1)];
    EXPECT_NEAR(m.end[kA] - m.start[kA], moved[i], 1e-9) << "N" << i + 1;
    EXPECT_NEAR(std::fmod(std::fmod(m.end[kA], 360.0) + 360.0, 360.0), shown[i], 1e-9) << "N" << i + 1;
  }
}

TEST(RotaryRollover, OffReadsTheWordAsThePosition) {
  const gc::Dialect d = with_rollover("fanuc", kC, RotaryRollover::off);
  pptest::Program p(d, "G90 G0 C350.\nC10.\nC-370.\nM30\n");
  ASSERT_EQ(p.motions.size(), 3u);
  EXPECT_DOUBLE_EQ(p.motions[1].end[kC], 10.0);
  EXPECT_DOUBLE_EQ(p.motions[2].end[kC], -370.0);
}

TEST(RotaryRollover, SinumerikModuloAxisNeverCrossesZeroInAbsolute) {
  // MD30455 bit 2 = 0: G90 on a 360° modulo axis positions as AC — up when the target is above
  // the position within the turn, down when below.
  const gc::Dialect d = with_rollover("siemens", kC, RotaryRollover::modulo);
  pptest::Program p(d, "G90 G0 C=350\nC=10\nC=370\nC=0\nM30\n");
  ASSERT_EQ(p.motions.size(), 4u) << p.all_codes();
  EXPECT_NEAR(p.motions[1].end[kC] - p.motions[1].start[kC], -340, 1e-9);
  EXPECT_NEAR(p.motions[2].end[kC] - p.motions[2].start[kC], 0, 1e-9);
  EXPECT_NEAR(p.motions[3].end[kC] - p.motions[3].start[kC], -10, 1e-9);
}

TEST(RotaryRollover, LinuxcncRefusesAFullTurnOnAWrappedAxis) {
  const gc::Dialect d = with_rollover("linuxcnc", kC, RotaryRollover::signed_direction);
  pptest::Program p(d, "G90 G0 C0\nG1 C370 F100\nM2\n");
  pptest::expect_diag_at(p, "PP-E207", 2, 4);
}

/// The word chosen for a corrected position is read back to exactly that position, for every
/// rule, over random moves (fixed seed); moves no word can make are refused (nullopt), never
/// written wrongly.
TEST(RotaryRollover, ChosenWordsReadBackToTheTarget) {
  std::mt19937_64 rng(20261126);
  std::uniform_real_distribution<double> pos(-1000, 1000), step(-179.9, 179.9), wide(-359.9, 359.9);
  for (RotaryRollover r : {RotaryRollover::shortest, RotaryRollover::signed_direction, RotaryRollover::modulo}) {
    int written = 0, refused = 0;
    for (int i = 0; i < 20000; ++i) {
      const double from = pos(rng);
      const double target = from + (r == RotaryRollover::shortest ? step(rng) : wide(rng));
      const double like = target + 360.0 * std::round(pos(rng) / 360.0);
      const auto w = gc::rollover_word(r, target, from, like);
      if (!w) {
        ++refused;
        // Only the modulo rule has moves it cannot make: those that cross 0° within the turn.
        EXPECT_EQ(r, RotaryRollover::modulo) << from << " → " << target;
        continue;
      }
      ++written;
      EXPECT_NEAR(gc::rollover_target(r, *w, from), target, 1e-9) << gc::to_string(r) << " " << from << " → " << target;
      EXPECT_LT(std::abs(*w), std::abs(like) + 360.0 + 1e-9);
    }
    EXPECT_GT(written, 5000) << gc::to_string(r);
    if (r == RotaryRollover::modulo) {
      EXPECT_GT(refused, 1000);
    }
  }
}

/// LinuxCNC's own interpreter with [AXIS_C] WRAPPED_ROTARY = 1 against postproc's "signed" rule,
/// over a random program of absolute and incremental C moves (skipped when rs274 is missing).
TEST(RotaryRollover, LinuxcncWrappedRotaryMatchesRs274) {
  if (std::system("command -v rs274 >/dev/null 2>&1") != 0) GTEST_SKIP() << "rs274 (LinuxCNC) not installed";
  pptest::TempDir dir;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> abs_word(-359.999, 359.999), inc_word(-500, 500);
  std::string program = "G90 G0 C0\n";
  for (int i = 0; i < 60; ++i) {
    if (i % 7 == 3) program += fmt::format("G91 G1 C{:.3f} F500\nG90\n", inc_word(rng));
    else program += fmt::format("G0 C{:.3f}\n", abs_word(rng));
  }
  program += "G0 C-0.5\nG0 C0.5\nG0 C-0.5\nM2\n";
  const std::string ngc = dir.file("w.ngc"), ini = dir.file("w.ini"), var = dir.file("w.var"), out = dir.file("out.txt");
  std::ofstream(ngc) << program;
  std::ofstream(ini) << "[RS274NGC]\nPARAMETER_FILE = " << var << "\n[AXIS_C]\nWRAPPED_ROTARY = 1\n[TRAJ]\nCOORDINATES = X Y Z C\n";
  std::ofstream(var) << "";
  ASSERT_EQ(std::system(fmt::format("rs274 -i {} -g {} > {} 2>&1", ini, ngc, out).c_str()), 0);
  std::ifstream in(out);
  std::vector<double> theirs;
  for (std::string line; std::getline(in, line);) {
    const auto at = line.find("STRAIGHT_");
    if (at == std::string::npos) continue;
    double v[6];
    const auto open = line.find('(', at);
    if (std::sscanf(line.c_str() + open, "(%lf, %lf, %lf, %lf, %lf, %lf", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5]) == 6)
      theirs.push_back(v[5]);
  }
  const gc::Dialect d = with_rollover("linuxcnc", kC, RotaryRollover::signed_direction);
  pptest::Program p(d, program);
  ASSERT_EQ(p.sink.count(gc::Severity::error), 0u) << p.all_codes();
  ASSERT_EQ(p.motions.size(), theirs.size());
  for (std::size_t i = 0; i < theirs.size(); ++i) EXPECT_NEAR(p.motions[i].end[kC], theirs[i], 5e-4) << "move " << i;
}

/// A 5-axis program whose C crosses 0° on a table that rolls over (shortest way): the compensated
/// program, read back under the same rule, reaches the intended poses within rounding, and its C
/// words stay within the turn as the program wrote them.
TEST(RotaryRollover, CompensatedProgramAcrossZeroReadsBackToTheCorrectedPoses) {
  const auto m = sample_with_c_rollover("trunnion_bc_fanuc.toml", "shortest");
  ASSERT_TRUE(m);
  std::string program = "%\nO1000\nG21 G90 G94 G54\nG43 H7\nG0 X50. Y0. Z80. B30. C340.\n";
  for (int i = 0; i <= 40; ++i)  // C 340 → 350 … 0 … 20, written within the turn
    program += fmt::format("G1 X{:.3f} Y{:.3f} B30. C{:.3f} F800.\n", 50 - i * 0.5, i * 0.75,
                           std::fmod(340 + i * 1.0, 360.0));
  program += "M30\n%\n";
  const gc::Dialect d = *gc::make_dialect(m->dialect_name, m->dialect_options);
  pptest::TempDir dir;
  std::vector<std::uint64_t> line_map;
  cp::CompensateOptions opt;
  opt.line_map = &line_map;
  opt.tool_version = "test";
  gc::DiagnosticSink sink;
  {
    gc::LineReader reader{std::string_view(program)};
    postproc::io::OutputFile out(dir.file("out.nc"));
    const cp::CompensateResult r = cp::compensate(reader, "in.nc", d, *m, opt, out, sink);
    // C 359° → 0° is a 1° move here: nothing to subdivide (read without roll-over it is −359°).
    EXPECT_EQ(r.subdivided_blocks, 0u);
    for (const auto& diag : sink.stored())
      if (diag.severity == gc::Severity::error) ADD_FAILURE() << gc::format(diag);
    ASSERT_FALSE(sink.has_errors());
    out.commit();
  }
  std::ifstream oin(dir.file("out.nc"));
  std::stringstream os;
  os << oin.rdbuf();
  const std::string written = os.str();
  EXPECT_NE(written.find("rollover-C=shortest"), std::string::npos) << "the header names the rule";
  const cp::VerifyResult v = cp::verify(program, written, line_map, d, *m);
  EXPECT_GE(v.compared, 41u);
  EXPECT_LE(v.max_excess_mm, 1e-7) << "line " << v.worst_line;
  EXPECT_GT(v.max_error_before_mm, 0.005);
  {
    mc::Machine plain = *m;
    plain.dialect_options.rollover[kC] = RotaryRollover::off;
    const gc::Dialect dp = *gc::make_dialect(plain.dialect_name, plain.dialect_options);
    gc::LineReader reader{std::string_view(program)};
    postproc::io::OutputFile out(dir.file("plain.nc"));
    gc::DiagnosticSink psink;
    const cp::CompensateResult r = cp::compensate(reader, "in.nc", dp, plain, opt, out, psink);
    EXPECT_GT(r.subdivided_blocks, 0u) << "without roll-over the 359° → 0° block is a long move";
  }
  // Within the turn as written: no C word at or above 360 and none below 0.
  for (std::size_t at = written.find(" C"); at != std::string::npos; at = written.find(" C", at + 1)) {
    const double c = std::strtod(written.c_str() + at + 2, nullptr);
    EXPECT_GE(c, -0.1) << written.substr(at, 12);
    EXPECT_LT(c, 360.0) << written.substr(at, 12);
  }
}

}  // namespace

namespace {

/// Sinumerik 840D sl Programming Manual Fundamentals, "Absolute dimensions for rotary axes (DC,
/// ACP, ACN)": on a modulo axis C=DC(w) takes the shorter way to w (at most half a turn), C=ACP(w)
/// the positive way, C=ACN(w) the negative way; w within the turn.
TEST(RotaryDirection, SinumerikDcAcpAcnOnAModuloAxis) {
  for (const RotaryRollover r : {RotaryRollover::modulo, RotaryRollover::shortest}) {
    SCOPED_TRACE(gc::to_string(r));
    const gc::Dialect d = with_rollover("siemens", kC, r);
    pptest::Program p(d,
                      "G90 G0 C=10\nC=DC(350)\nC=ACP(10)\nC=ACN(20)\nC=IC(5)\nC=DC(200)\nC=ACP(0)\nC=ACN(0)\n"
                      "C=dc(190)\nC=DC(10)\nM30\n");
    ASSERT_EQ(p.motions.size(), 10u) << p.all_codes();
    // From C10: DC(350) −20, ACP(10) +20, ACN(20) −350, IC(5) +5, DC(200) +175, ACP(0) +160,
    // ACN(0) where it stands: no motion, dc(190) the shorter way −170, DC(10) exactly half a turn:
    // the positive way, +180.
    const double moved[] = {-20, 20, -350, 5, 175, 160, 0, -170, 180};
    for (int i = 0; i < 9; ++i) {
      const gc::Motion& m = p.motions[static_cast<std::size_t>(i + 1)];
      EXPECT_NEAR(m.end[kC] - m.start[kC], moved[i], 1e-9) << "block " << i + 2;
    }
  }
}

TEST(RotaryDirection, RefusedWhereTheControlRefuses) {
  {
    // Not a modulo axis in the machine file: refused at the word (the control raises an alarm).
    const gc::Dialect d = with_rollover("siemens", kC, RotaryRollover::off);
    pptest::Program p(d, "G90 G0 C=10\nC=ACP(20)\nM30\n");
    EXPECT_TRUE(p.has("PP-E207")) << p.all_codes();
  }
  {
    const gc::Dialect d = with_rollover("siemens", kC, RotaryRollover::modulo);
    pptest::Program out_of_turn(d, "G90 G0 C=10\nC=DC(360)\nM30\n");
    EXPECT_TRUE(out_of_turn.has("PP-E207")) << out_of_turn.all_codes();
    pptest::Program negative(d, "G90 G0 C=10\nC=ACN(-10)\nM30\n");
    EXPECT_TRUE(negative.has("PP-E207")) << negative.all_codes();
    pptest::Program linear(d, "G90 G0 X=DC(10)\nM30\n");
    EXPECT_TRUE(linear.has("PP-E207")) << linear.all_codes();
  }
}

/// The words the writer chooses read back to the target under the same function, and a target
/// the function cannot reach has no word.
TEST(RotaryDirection, ChosenWordsReadBackToTheTarget) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> from_d(-720, 720), move_d(-359, 359);
  for (const gc::RotaryDirection dir :
       {gc::RotaryDirection::shortest, gc::RotaryDirection::positive, gc::RotaryDirection::negative}) {
    int reached = 0, refused = 0;
    for (int k = 0; k < 2000; ++k) {
      const double from = from_d(rng), target = from + move_d(rng);
      const auto w = gc::directed_word(dir, target, from);
      const double delta = target - from;
      const bool reachable = dir == gc::RotaryDirection::shortest   ? std::abs(delta) <= 180.0
                             : dir == gc::RotaryDirection::positive ? delta >= 0
                                                                    : delta <= 0;
      if (std::abs(std::abs(delta) - 180.0) < 1e-6) continue;  // the tie: the positive way
      ASSERT_EQ(w.has_value(), reachable) << gc::function_name(dir) << " from " << from << " to " << target;
      if (!w) {
        ++refused;
        continue;
      }
      ++reached;
      EXPECT_GE(*w, 0.0);
      EXPECT_LT(*w, 360.0);
      EXPECT_NEAR(gc::directed_target(dir, *w, from), target, 1e-9);
    }
    EXPECT_GT(reached, 500);
    EXPECT_GT(refused, dir == gc::RotaryDirection::shortest ? 100 : 500);
  }
}

}  // namespace

namespace {

/// A Siemens program positioning its modulo C axis with DC / ACP / ACN, compensated on the A/C
/// trunnion: the functions stay, every value stays within the turn, and the written program reads
/// back (under the same functions) to the corrected poses.
TEST(RotaryDirection, CompensatedWordsKeepTheirFunctionAndReadBackToTheCorrectedPoses) {
  const auto m = sample_with_c_rollover("trunnion_ac_siemens.toml", "modulo");
  ASSERT_TRUE(m);
  const std::string program =
      "G90 G54 G64\nT=\"BALL_8\" M6\nD1\nG0 X40 Y-20 Z30 A-10 C=DC(350)\nG1 X35 Y-15 Z28 C=ACP(5) F800\n"
      "X30 Y-10 C=ACN(355)\nX25 Y-5 C=DC(0.5)\nR1=12.5\nX20 Y0 C=ACP(R1)\nM30\n";
  const gc::Dialect d = *gc::make_dialect(m->dialect_name, m->dialect_options);
  std::vector<std::uint64_t> line_map;
  cp::CompensateOptions opt;
  opt.line_map = &line_map;
  opt.tool_version = "test";
  opt.flatten = true;
  gc::DiagnosticSink sink;
  auto out = postproc::io::OutputFile::memory();
  const cp::CompensateResult r = cp::compensate_program({program, "in.mpf", d, *m}, opt, out, sink);
  for (const auto& diag : sink.stored())
    if (diag.severity == gc::Severity::error) ADD_FAILURE() << gc::format(diag);
  ASSERT_FALSE(sink.has_errors());
  const std::string written = out.take();
  EXPECT_GT(r.words_changed, 0u);
  for (const char* fn : {"C=DC(", "C=ACP(", "C=ACN("}) {
    std::size_t n = 0;
    for (std::size_t at = written.find(fn); at != std::string::npos; at = written.find(fn, at + 1)) {
      ++n;
      const double c = std::strtod(written.c_str() + at + std::strlen(fn), nullptr);
      EXPECT_GE(c, 0.0) << written.substr(at, 20);
      EXPECT_LT(c, 360.0) << written.substr(at, 20);
    }
    EXPECT_GE(n, 1u) << fn << " kept\n" << written;
  }
  // The resolved program (R1 substituted) against the written one.
  const std::string resolved = "G90 G54 G64\nT=\"BALL_8\" M6\nD1\nG0 X40 Y-20 Z30 A-10 C=DC(350)\n"
                               "G1 X35 Y-15 Z28 C=ACP(5) F800\nX30 Y-10 C=ACN(355)\nX25 Y-5 C=DC(0.5)\n\n"
                               "X20 Y0 C=ACP(12.5)\nM30\n";
  const cp::VerifyResult v = cp::verify(resolved, written, line_map, d, *m);
  EXPECT_GE(v.compared, 4u) << written;  // the four feed moves (the first rapid stays as written)
  EXPECT_LE(v.max_excess_mm, 1e-7) << "line " << v.worst_line << "\n" << written;
  EXPECT_GT(v.max_error_before_mm, 0.005);
}

}  // namespace
