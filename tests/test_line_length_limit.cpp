// The longest line a controller reads (issue 16): LinuxCNC's rs274ngc stops with "Command too long"
// at a line of 253 characters or more, its CR counted (LINELEN 255 with fgets; checked against
// rs274 in tests/rs274_line_length.py). What postproc writes for LinuxCNC must stay readable: the
// compensation header is shortened until it fits, and a corrected block that would no longer fit
// is refused at its line (PP-E601 / PP-E711) instead of being written as a program the controller
// refuses.
#include <string>

#include <gtest/gtest.h>

#include "postproc/compensation/compensate.hpp"
#include "postproc/gcode/convert.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/machine/machine.hpp"
#include "sample_machine.hpp"

namespace {

namespace gc = postproc::gcode;
namespace mc = postproc::machine;
namespace comp = postproc::comp;

/// The B/C trunnion read as a LinuxCNC machine (axis-position programs).
mc::Machine linuxcnc_trunnion() {
  mc::Machine m = pptest::sample_machine("trunnion_bc_fanuc.toml");
  m.dialect_name = "linuxcnc";
  return m;
}

std::string comment_to(std::string line, std::size_t length) {
  line += " (";
  line += std::string(length - line.size() - 1, 'c');
  return line + ")";
}

struct Written {
  std::string written;
  gc::DiagnosticSink sink;
};

void run(const std::string& program, const mc::Machine& m, bool flatten, Written& r,
         comp::Mode mode = comp::Mode::geometric) {
  const gc::Dialect d = *gc::make_dialect("linuxcnc");
  comp::CompensateOptions opt;
  opt.tool_version = "test";
  opt.flatten = flatten;
  opt.mode = mode;
  auto out = postproc::io::OutputFile::memory();
  (void)comp::compensate_program({program, "in.ngc", d, m}, opt, out, r.sink);
  r.written = out.take();
}

std::size_t longest_line(const std::string& text) {
  std::size_t longest = 0, at = 0;
  while (at < text.size()) {
    std::size_t e = text.find('\n', at);
    if (e == std::string::npos) e = text.size();
    longest = std::max(longest, e - at);
    at = e + 1;
  }
  return longest;
}

TEST(LineLengthLimit, TheDialectsLimits) {
  EXPECT_EQ(gc::max_line_length(*gc::make_dialect("linuxcnc")), 252u);
  EXPECT_FALSE(gc::line_too_long(*gc::make_dialect("linuxcnc"), 252, false));
  EXPECT_TRUE(gc::line_too_long(*gc::make_dialect("linuxcnc"), 252, true));
  EXPECT_TRUE(gc::line_too_long(*gc::make_dialect("linuxcnc"), 253, false));
  EXPECT_FALSE(gc::line_too_long(*gc::make_dialect("fanuc"), 100000, true)) << "no limit postproc knows of";
}

TEST(LineLengthLimit, TheHeaderFitsWithALongMachinePathAndIsStillRecognised) {
  mc::Machine m = linuxcnc_trunnion();
  m.file = "/shop/" + std::string(200, 'd') + "/trunnion_bc.toml";
  comp::CompensateOptions opt;
  opt.tool_version = "0.1.0";
  opt.flatten = true;
  const gc::Dialect lcnc = *gc::make_dialect("linuxcnc"), fanuc = *gc::make_dialect("fanuc");
  const std::string h = comp::header_comment(lcnc, m, opt);
  EXPECT_LE(h.size(), 251u) << h;  // a CRLF file's CR counts too
  EXPECT_NE(h.find("machine=trunnion_bc.toml sha256=" + m.sha256), std::string::npos) << h;
  EXPECT_NE(comp::compensation_header_offset(h), std::string::npos) << "a second run still recognises it";
  // Without a limit the header names the whole path.
  EXPECT_NE(comp::header_comment(fanuc, m, opt).find(m.file), std::string::npos);
  // Short enough as it is: unchanged.
  m.file = "m.toml";
  EXPECT_NE(comp::header_comment(lcnc, m, opt).find("flattened=parameters"), std::string::npos);
}

TEST(LineLengthLimit, ACorrectedBlockThatWouldNotFitIsRefusedAtItsLine) {
  const mc::Machine m = linuxcnc_trunnion();
  // Line 3 is 230 / 245 characters, which LinuxCNC reads; its correction writes three decimals on
  // X, Y and Z and the C word (14 characters more): 244 fits, 259 does not.
  const std::string fits = comment_to("G1 X10 Y10 Z-5 F500", 230), too_long = comment_to("G1 X10 Y10 Z-5 F500", 245);
  for (const bool flatten : {false, true}) {
    SCOPED_TRACE(flatten);
    Written ok;
    run("G21 G90 G54 G94\nG0 X0 Y0 Z50 B0 C0\n" + fits + "\nG1 X20\nM2\n", m, flatten, ok);
    EXPECT_FALSE(ok.sink.has_errors()) << (ok.sink.stored().empty() ? "" : ok.sink.stored()[0].message);
    EXPECT_LE(longest_line(ok.written), 252u);
    EXPECT_EQ(ok.written.find("G1 X10 Y10"), std::string::npos) << "corrected: " << ok.written;
    Written bad;
    run("G21 G90 G54 G94\nG0 X0 Y0 Z50 B0 C0\n" + too_long + "\nG1 X20\nM2\n", m, flatten, bad);
    ASSERT_TRUE(bad.sink.has_errors());
    const gc::Diagnostic& e = bad.sink.stored()[0];
    EXPECT_EQ(e.code, "PP-E601") << e.message;
    EXPECT_EQ(e.where.line, 3u);
    EXPECT_NE(e.message.find("LinuxCNC reads at most 252"), std::string::npos) << e.message;
  }
}

TEST(LineLengthLimit, AResolvedLineWrittenBackThatWouldNotFitIsRefusedAtItsLine) {
  const mc::Machine m = linuxcnc_trunnion();
  // With a parameter the program is resolved and its corrections carried back into its own lines.
  const std::string program = "G21 G90 G54 G94\n#1 = 10\nG0 X0 Y0 Z50 B0 C0\n" +
                              comment_to("G1 X#1 Y10 Z-5 F500", 245) + "\nG1 X20\nM2\n";
  Written bad;
  run(program, m, false, bad);
  ASSERT_TRUE(bad.sink.has_errors());
  const gc::Diagnostic& e = bad.sink.stored()[0];
  EXPECT_EQ(e.where.line, 4u) << e.message;
  EXPECT_NE(e.message.find("LinuxCNC reads at most 252"), std::string::npos) << e.message;
}

TEST(LineLengthLimit, TheContourStageWritesARunUncorrectedWhereACorrectedBlockWouldNotFit) {
  const mc::Machine m = linuxcnc_trunnion();
  // A run of fast feed moves (a contour correction of about 400 µm); line 4 is 250 characters and
  // its correction adds 5 or more. The run's corrected text cannot be read back (the refusal is in
  // the writer), so the run is written as the stage received it (PP-W621) -- readable.
  const std::string program = "G21 G90 G54 G94\nG0 X0 Y0 Z5 B0 C0\nG1 X50 Y0 F6000\n" +
                              comment_to("G1 X50 Y50", 250) + "\nG1 X0 Y50\nG1 X0 Y0\nM2\n";
  Written r;
  run(program, m, true, r, comp::Mode::contour);
  EXPECT_FALSE(r.sink.has_errors()) << (r.sink.stored().empty() ? "" : r.sink.stored()[0].message);
  EXPECT_LE(longest_line(r.written), 252u);
  bool withheld = false;
  for (const auto& d : r.sink.stored()) withheld = withheld || d.code == "PP-W621";
  EXPECT_TRUE(withheld);
  // 200 characters: corrected and written.
  Written ok;
  run("G21 G90 G54 G94\nG0 X0 Y0 Z5 B0 C0\nG1 X50 Y0 F6000\n" + comment_to("G1 X50 Y50", 200) +
          "\nG1 X0 Y50\nG1 X0 Y0\nM2\n",
      m, true, ok, comp::Mode::contour);
  bool written = true;
  for (const auto& d : ok.sink.stored()) written = written && d.code != "PP-W621";
  EXPECT_TRUE(written);
  EXPECT_EQ(ok.written.find("G1 X50 Y50 ("), std::string::npos) << "corrected: " << ok.written;
}

TEST(LineLengthLimit, ConvertRefusesALineItWouldMakeTooLong) {
  const gc::Dialect d = *gc::make_dialect("linuxcnc");
  gc::ConvertOptions opt;
  opt.renumber_start = 10;  // N1 becomes N10: one character more
  for (const std::size_t length : {251u, 252u}) {
    SCOPED_TRACE(length);
    const std::string program = "G21 G90\n" + comment_to("N1 G1 X1 F100", length) + "\nN2 M2\n";
    gc::LineReader in{std::string_view(program)};
    gc::DiagnosticSink sink;
    auto out = postproc::io::OutputFile::memory();
    (void)gc::convert(in, "in.ngc", d, opt, out, sink);
    if (length == 251) {
      EXPECT_FALSE(sink.has_errors()) << (sink.stored().empty() ? "" : sink.stored()[0].message);
      EXPECT_EQ(longest_line(out.take()), 252u);
    } else {
      ASSERT_TRUE(sink.has_errors());
      EXPECT_EQ(sink.stored()[0].code, "PP-E504");
      EXPECT_EQ(sink.stored()[0].where.line, 2u);
    }
  }
}

}  // namespace
