// [machine] ik_branch (issue 23): which of the two inverse-kinematics solutions of a serial
// machine with two rotary axes the controller takes for a tool axis. Checked with the model's own
// forward kinematics (not under test): both solutions put the tool on the commanded axis; under
// "tilt-positive" / "tilt-negative" the tilting axis (the one that flips sign between them) has
// that sign whatever the block before; under "nearest" the branch of the block before is kept.
// End to end: a Fanuc G43.5 program read into the commanded path takes the branch the setting
// names.
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "postproc/compensation/compensate.hpp"
#include "postproc/compensation/verify.hpp"
#include "postproc/contour/path.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/machine/machine.hpp"
#include "postproc/machine/program_map.hpp"

namespace {

namespace mc = postproc::machine;
namespace gc = postproc::gcode;
namespace kin = postproc::kin;

std::string sample(const std::string& name) {
  std::ifstream in(std::string(POSTPROC_SOURCE_DIR) + "/samples/machines/" + name);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The B/C trunnion with `line` added to its [machine] table.
std::optional<mc::Machine> trunnion(const std::string& line, gc::DiagnosticSink& sink) {
  std::string text = sample("trunnion_bc_fanuc.toml");
  const std::string anchor = "[machine]\n";
  text.replace(text.find(anchor), anchor.size(), anchor + line + "\n");
  return mc::parse_machine("bc.toml", text, sink);
}

int joint(const kin::Model& m, char name) {
  for (int j = 0; j < m.joint_count(); ++j)
    if (m.joints()[static_cast<std::size_t>(j)].name == std::string(1, name)) return j;
  return -1;
}

double wrap(double deg) { return std::remainder(deg, 360.0); }

TEST(IkBranch, TheSettingChoosesTheSignOfTheTiltingAxis) {
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.2, 1.0).normalized();
  for (const char* setting : {"nearest", "tilt-positive", "tilt-negative"}) {
    SCOPED_TRACE(setting);
    gc::DiagnosticSink sink;
    const auto m = trunnion(std::string("ik_branch = \"") + setting + "\"", sink);
    ASSERT_TRUE(m) << (sink.stored().empty() ? "" : sink.stored()[0].message);
    EXPECT_EQ(mc::to_string(m->ik_branch), setting);
    const mc::ProgramMap map(*m, m->nominal, m->nominal, mc::Form::tcp_vector, gc::AxisVector::Zero(), false, 100.0);
    const int b = joint(*m->nominal, 'B'), c = joint(*m->nominal, 'C');
    ASSERT_GE(b, 0);
    ASSERT_GE(c, 0);
    mc::Command cmd;
    cmd.c << 10, -5, 20, 0, 0, 0, 0, 0, 0;
    cmd.vector = axis;
    for (const double start_b : {-25.0, 25.0}) {
      SCOPED_TRACE(start_b);
      kin::JointVector start = kin::JointVector::Zero(m->nominal->joint_count());
      start[b] = start_b;
      start[c] = 40;
      kin::JointVector q;
      ASSERT_TRUE(map.joints(cmd, start, q).ok());
      kin::Pose p;
      ASSERT_TRUE(m->nominal->forward(q, p).ok());
      EXPECT_LT((p.axis() - axis).norm(), 1e-9) << "on the commanded axis";
      const double tilt = wrap(q[b]);
      EXPECT_GT(std::abs(tilt), 5.0);
      if (std::string(setting) == "tilt-positive") {
        EXPECT_GT(tilt, 0);
      } else if (std::string(setting) == "tilt-negative") {
        EXPECT_LT(tilt, 0);
      } else {
        // "nearest": of the two solutions, the one nearer the joints of the block before.
        const auto other_rule = [&](const char* r) {
          gc::DiagnosticSink s;
          const auto mo = trunnion(std::string("ik_branch = \"") + r + "\"", s);
          const mc::ProgramMap mm(*mo, mo->nominal, mo->nominal, mc::Form::tcp_vector, gc::AxisVector::Zero(), false,
                                  100.0);
          kin::JointVector qo;
          EXPECT_TRUE(mm.joints(cmd, start, qo).ok());
          return qo;
        };
        const kin::JointVector qp = other_rule("tilt-positive"), qn = other_rule("tilt-negative");
        const kin::JointVector& near = (qp - start).squaredNorm() < (qn - start).squaredNorm() ? qp : qn;
        EXPECT_LT((q - near).norm(), 1e-6);
      }
    }
  }
}

TEST(IkBranch, TheTwoBranchesAreTheSamePoseWithTheTiltFlippedAndTheTableHalfATurnOn) {
  gc::DiagnosticSink s1, s2;
  const auto pos = trunnion("ik_branch = \"tilt-positive\"", s1);
  const auto neg = trunnion("ik_branch = \"tilt-negative\"", s2);
  ASSERT_TRUE(pos && neg);
  const mc::ProgramMap mp(*pos, pos->nominal, pos->nominal, mc::Form::tcp_vector, gc::AxisVector::Zero(), false, 100.0);
  const mc::ProgramMap mn(*neg, neg->nominal, neg->nominal, mc::Form::tcp_vector, gc::AxisVector::Zero(), false, 100.0);
  const int b = joint(*pos->nominal, 'B'), c = joint(*pos->nominal, 'C');
  mc::Command cmd;
  cmd.c << -12, 7, 15, 0, 0, 0, 0, 0, 0;
  cmd.vector = Eigen::Vector3d(-0.4, 0.1, 1.0).normalized();
  const kin::JointVector start = kin::JointVector::Zero(pos->nominal->joint_count());
  kin::JointVector qp, qn;
  ASSERT_TRUE(mp.joints(cmd, start, qp).ok());
  ASSERT_TRUE(mn.joints(cmd, start, qn).ok());
  EXPECT_NEAR(wrap(qp[b] + qn[b]), 0.0, 1e-6);
  EXPECT_NEAR(std::abs(wrap(qp[c] - qn[c])), 180.0, 1e-6);
  kin::Pose pp, pn;
  ASSERT_TRUE(pos->nominal->forward(qp, pp).ok());
  ASSERT_TRUE(pos->nominal->forward(qn, pn).ok());
  EXPECT_LT((pp.p - pn.p).norm(), 1e-6) << "the same tool tip";
  EXPECT_LT((pp.axis() - pn.axis()).norm(), 1e-9) << "the same tool axis";
}

TEST(IkBranch, AProgramReadIntoThePathTakesTheNamedBranch) {
  // G43.5: tool tip X Y Z and tool axis I J K (Fanuc). The first block's joints come from the
  // rule alone (start B0 C0); the tool axis tilts 20° toward −X.
  const std::string program =
      "%\nO1\nG21 G90 G94 G54\nG0 X0. Y0. Z100. B0. C0.\nG43.5 H7 X0. Y0. Z50. I0. J0. K1.\nG1 X5. Y0. Z10. I-0.34202 J0. K0.93969 F1000.\n"
      "X10. Y2. Z10.\nG49\nM30\n%\n";
  double tilt[3] = {0, 0, 0};
  int k = 0;
  for (const char* setting : {"nearest", "tilt-positive", "tilt-negative"}) {
    gc::DiagnosticSink msink;
    const auto m = trunnion(std::string("ik_branch = \"") + setting + "\"", msink);
    ASSERT_TRUE(m);
    const gc::Dialect d = *gc::make_dialect(m->dialect_name, m->dialect_options);
    gc::DiagnosticSink sink;
    gc::LineReader in{std::string_view(program)};
    const postproc::contour::Path path = postproc::contour::build_path(in, "t.nc", d, *m, {}, sink);
    for (const auto& diag : sink.stored())
      if (diag.severity == gc::Severity::error) ADD_FAILURE() << setting << ": " << diag.message;
    ASSERT_FALSE(path.points.empty());
    const int b = joint(*m->nominal, 'B');
    tilt[k++] = wrap(path.points.back().q[b]);
  }
  EXPECT_NEAR(std::abs(tilt[0]), 20.0, 0.01);
  EXPECT_NEAR(tilt[1], 20.0, 0.01);
  EXPECT_NEAR(tilt[2], -20.0, 0.01);
  EXPECT_TRUE(tilt[0] == tilt[1] || tilt[0] == tilt[2]);
}

TEST(IkBranch, RefusedWhereThereIsNoChoiceAndForUnknownValues) {
  gc::DiagnosticSink s1;
  EXPECT_FALSE(trunnion("ik_branch = \"shortest\"", s1));
  std::string hex = sample("hexapod_doc003.toml");
  const std::string anchor = "[machine]\n";
  ASSERT_NE(hex.find(anchor), std::string::npos);
  hex.replace(hex.find(anchor), anchor.size(), anchor + "ik_branch = \"tilt-positive\"\n");
  gc::DiagnosticSink s2;
  EXPECT_FALSE(mc::parse_machine("hex.toml", hex, s2));
  bool named = false;
  for (const auto& d : s2.stored()) named = named || d.message.find("ik_branch") != std::string::npos;
  EXPECT_TRUE(named);
}

}  // namespace
namespace {

/// At the pole (the tool axis on the C axis, B0) C is free: the controller holds it where it
/// stands and moves only the linear axes. A G43.5 run that starts there used to be refused by the
/// contour path ("inverse kinematics failed at the start of this move", a singular Jacobian).
TEST(IkBranch, AtThePoleTheOtherRotaryAxisStaysWhereItStands) {
  gc::DiagnosticSink s;
  const auto m = trunnion("", s);
  ASSERT_TRUE(m);
  const mc::ProgramMap map(*m, m->nominal, m->nominal, mc::Form::tcp_vector, gc::AxisVector::Zero(), false, 85.25);
  const int b = joint(*m->nominal, 'B'), c = joint(*m->nominal, 'C');
  mc::Command cmd;
  cmd.c << 3, -4, 50, 0, 0, 0, 0, 0, 0;
  for (const double held : {0.0, 37.5}) {
    kin::JointVector start = kin::JointVector::Zero(m->nominal->joint_count()), q;
    start[c] = held;
    ASSERT_TRUE(map.joints(cmd, start, q).ok()) << held;
    EXPECT_NEAR(q[b], 0.0, 1e-9);
    EXPECT_NEAR(q[c], held, 1e-9);
    kin::Pose p;
    ASSERT_TRUE(m->nominal->forward(q, p).ok());
    EXPECT_LT((p.axis() - Eigen::Vector3d::UnitZ()).norm(), 1e-9);
  }
  const std::string program = "%\nO1\nG21 G90 G94 G54\nG0 X0. Y0. Z100. B0. C0.\nG43.5 H7 X0. Y0. Z50. I0. J0. K1.\n"
                              "G1 X5. Y0. Z10. F1000.\nX10. Y2. Z10.\nG49\nM30\n%\n";
  const gc::Dialect d = *gc::make_dialect(m->dialect_name, m->dialect_options);
  gc::DiagnosticSink sink;
  gc::LineReader in{std::string_view(program)};
  const postproc::contour::Path path = postproc::contour::build_path(in, "t.nc", d, *m, {}, sink);
  EXPECT_FALSE(sink.has_errors()) << (sink.stored().empty() ? "" : sink.stored()[0].message);
  EXPECT_EQ(path.points.size(), 3u);
}

}  // namespace

namespace {

/// A G43.5 program with the tool axis vertical (the pole of the B/C trunnion), compensated under
/// each rule. Read back under the same rule the written blocks put the real tool tip where the
/// nominal one would be. Where the rule lets the controller take the corrected axis on the same
/// branch ("nearest", and "tilt-negative" here: the correction tilts B negative at C0), the tool
/// axis is corrected too; under "tilt-positive" that tilt would turn the table half a turn, so the
/// rotary joints keep the intended pose and only the tip is corrected (the axis keeps its error).
TEST(IkBranch, CompensatedAtThePoleUnderEachRule) {
  const std::string program = "%\nO1\nG21 G90 G94 G54\nG0 X0. Y0. Z100. B0. C0.\nG43.5 H7 X0. Y0. Z50. I0. J0. K1.\n"
                              "G1 X5. Y0. Z10. F1000.\nX10. Y2. Z10.\nG49\nM30\n%\n";
  for (const char* setting : {"nearest", "tilt-positive", "tilt-negative"}) {
    SCOPED_TRACE(setting);
    gc::DiagnosticSink msink;
    const auto m = trunnion(std::string("ik_branch = \"") + setting + "\"", msink);
    ASSERT_TRUE(m);
    const gc::Dialect d = *gc::make_dialect(m->dialect_name, m->dialect_options);
    std::vector<std::uint64_t> line_map;
    postproc::comp::CompensateOptions opt;
    opt.line_map = &line_map;
    opt.tool_version = "test";
    gc::DiagnosticSink sink;
    auto out = postproc::io::OutputFile::memory();
    const postproc::comp::CompensateResult r =
        postproc::comp::compensate_program(program, "in.nc", d, *m, opt, {}, out, sink);
    for (const auto& diag : sink.stored())
      if (diag.severity == gc::Severity::error) ADD_FAILURE() << diag.message;
    ASSERT_FALSE(sink.has_errors());
    const std::string written = out.take();
    EXPECT_EQ(written.find("ik-branch=") != std::string::npos, std::string(setting) != "nearest") << written;
    EXPECT_LT(r.max_residual_mm, 0.001) << "the tool tip is corrected";
    if (std::string(setting) == "tilt-positive") {
      EXPECT_GT(r.max_residual_rad, 0.9 * r.max_error_before_rad) << "the tool axis keeps its error";
      EXPECT_EQ(written.find("I0.0001"), std::string::npos) << written;
    } else {
      EXPECT_LT(r.max_residual_rad, 0.1 * r.max_error_before_rad) << "the tool axis is corrected";
    }
    const postproc::comp::VerifyResult v = postproc::comp::verify(program, written, line_map, d, *m);
    EXPECT_GE(v.compared, 3u);
    EXPECT_LT(v.max_excess_mm, 1e-6) << "line " << v.worst_line;
  }
}

}  // namespace
