// [machine] ik_branch (issue 23): which of the two inverse-kinematics solutions of a serial
// machine with two rotary axes the controller takes for a tool axis. Checked with the model's own
// forward kinematics (not under test): both solutions put the tool on the commanded axis; under
// "tilt-positive" / "tilt-negative" the tilting axis (the one that flips sign between them) has
// that sign whatever the block before; under "nearest" the branch of the block before is kept.
// End to end: a Fanuc G43.5 program read into the commanded path takes the branch the setting
// names.
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>
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

/// `program` compensated on machine `m` (geometric mode) into memory.
struct Compensated {
  postproc::comp::CompensateResult r;
  std::string written;
  std::vector<std::uint64_t> line_map;
  gc::DiagnosticSink sink;
};
void compensate(const std::string& program, const mc::Machine& m, Compensated& c) {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  postproc::comp::CompensateOptions opt;
  opt.line_map = &c.line_map;
  opt.tool_version = "test";
  auto out = postproc::io::OutputFile::memory();
  c.r = postproc::comp::compensate_program({program, "in.nc", d, m}, opt, out, c.sink);
  c.written = out.take();
}

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
    Compensated c;
    compensate(program, *m, c);
    for (const auto& diag : c.sink.stored())
      if (diag.severity == gc::Severity::error) ADD_FAILURE() << diag.message;
    ASSERT_FALSE(c.sink.has_errors());
    const postproc::comp::CompensateResult& r = c.r;
    const std::vector<std::uint64_t>& line_map = c.line_map;
    const std::string& written = c.written;
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

namespace {

/// The B/C trunnion with B's travel [bmin, bmax] and C's [cmin, cmax] (infinite: no limits).
std::optional<mc::Machine> trunnion_travel(const std::string& setting, double bmin, double bmax, double cmin,
                                           double cmax, gc::DiagnosticSink& sink) {
  std::string text = sample("trunnion_bc_fanuc.toml");
  const std::string anchor = "[machine]\n", b_travel = "min = -110\nmax = 110\n",
                    c_pivot = "pivot = [0, 0, 0]           # C unlimited: no min/max\n";
  if (text.find(b_travel) == std::string::npos || text.find(c_pivot) == std::string::npos) return std::nullopt;
  text.replace(text.find(b_travel), b_travel.size(), fmt::format("min = {}\nmax = {}\n", bmin, bmax));
  if (std::isfinite(cmin))
    text.replace(text.find(c_pivot), c_pivot.size(), c_pivot + fmt::format("min = {}\nmax = {}\n", cmin, cmax));
  text.replace(text.find(anchor), anchor.size(), anchor + "ik_branch = \"" + setting + "\"\n");
  return mc::parse_machine("bc.toml", text, sink);
}

/// The tool axis of the B/C trunnion in the workpiece frame, written out independently of the
/// model: the table turns the part, so the spindle's +Z seen from the part is Rz(−C)·Ry(−B)·Z.
Eigen::Vector3d bc_tool_axis(double b_deg, double c_deg) {
  const double b = b_deg * kin::kDeg, c = c_deg * kin::kDeg;
  return {-std::sin(b) * std::cos(c), std::sin(b) * std::sin(c), std::cos(b)};
}

/// Heidenhain's rule for PLANE without SEQ (TNC 640 user's manual, "Tilting the working plane",
/// "Selecting possible solutions: SEQ"; Beckhoff TF5200 P-CHAN-00189 tool_ori_cs.mode 2): of the
/// solutions within the rotary axes' travel the one nearest the present position; none: an error.
/// Written here from the closed form of bc_tool_axis, every turn of C enumerated.
std::optional<std::pair<double, double>> expected_in_travel(const Eigen::Vector3d& o, double b0, double c0,
                                                            double bmin, double bmax, double cmin, double cmax) {
  std::optional<std::pair<double, double>> best;
  double best_d = 1e300;
  const double tilt = std::acos(std::clamp(o.z(), -1.0, 1.0)) / kin::kDeg;
  for (const double sign : {1.0, -1.0}) {
    const double b = sign * tilt, sb = std::sin(b * kin::kDeg);
    const double c = std::atan2(o.y() / sb, -o.x() / sb) / kin::kDeg;
    if (b < bmin || b > bmax) continue;
    const double lo = std::isfinite(cmin) ? cmin : c0 - 720, hi = std::isfinite(cmax) ? cmax : c0 + 720;
    for (double k = std::ceil((lo - c) / 360.0); c + 360 * k <= hi; ++k) {
      const double d = (b - b0) * (b - b0) + (c + 360 * k - c0) * (c + 360 * k - c0);
      if (d < best_d) {
        best_d = d;
        best = std::make_pair(b, c + 360 * k);
      }
    }
  }
  return best;
}

TEST(IkBranch, NearestInTravelTakesTheNearestSolutionWithinTheRotaryTravel) {
  std::mt19937 rng(2311);
  std::uniform_real_distribution<double> u(0, 1);
  const double inf = std::numeric_limits<double>::infinity();
  struct Travel {
    double bmin, bmax, cmin, cmax;
  };
  const Travel travels[] = {{-110, 110, -inf, inf}, {-110, 5, -inf, inf}, {-5, 110, -inf, inf},
                            {-110, 110, -30, 200},  {-5, 110, 0, 359.999}, {-110, 110, -400, -100},
                            {-110, 110, 0, 90},     {-30, 110, 0, 90}};
  int refused = 0, switched = 0;
  for (const Travel& t : travels) {
    gc::DiagnosticSink sink;
    const auto m = trunnion_travel("nearest-in-travel", t.bmin, t.bmax, t.cmin, t.cmax, sink);
    ASSERT_TRUE(m) << (sink.stored().empty() ? "" : sink.stored()[0].message);
    EXPECT_EQ(mc::to_string(m->ik_branch), "nearest-in-travel");
    const mc::ProgramMap map(*m, m->nominal, m->nominal, mc::Form::tcp_vector, gc::AxisVector::Zero(), false, 100.0);
    const int b = joint(*m->nominal, 'B'), c = joint(*m->nominal, 'C');
    // The independent tool axis agrees with the model's convention (one pose).
    kin::JointVector probe = kin::JointVector::Zero(m->nominal->joint_count());
    probe[b] = 30;
    probe[c] = 70;
    kin::Pose pp;
    ASSERT_TRUE(m->nominal->forward(probe, pp).ok());
    ASSERT_LT((pp.axis() - bc_tool_axis(30, 70)).norm(), 1e-12);
    for (int i = 0; i < 200; ++i) {
      const double tb = 5 + 75 * u(rng), tc = 360 * u(rng);
      const Eigen::Vector3d o = bc_tool_axis(tb, tc);
      kin::JointVector start = kin::JointVector::Zero(m->nominal->joint_count());
      start[b] = std::max(t.bmin, -60.0) + (std::min(t.bmax, 60.0) - std::max(t.bmin, -60.0)) * u(rng);
      start[c] = std::isfinite(t.cmin) ? t.cmin + (t.cmax - t.cmin) * u(rng) : -500 + 1000 * u(rng);
      mc::Command cmd;
      cmd.c << 10, -5, 20, 0, 0, 0, 0, 0, 0;
      cmd.vector = o;
      kin::JointVector q;
      const kin::Solve s = map.joints(cmd, start, q);
      const auto want = expected_in_travel(o, start[b], start[c], t.bmin, t.bmax, t.cmin, t.cmax);
      if (!want) {
        EXPECT_EQ(s.status, kin::Status::out_of_limits) << "no solution in travel: the controller stops";
        EXPECT_NE(map.explain(s).find("nearest-in-travel"), std::string::npos) << map.explain(s);
        ++refused;
        continue;
      }
      ASSERT_TRUE(s.ok()) << i << ": " << map.explain(s);
      EXPECT_NEAR(q[b], want->first, 1e-6) << i;
      EXPECT_NEAR(q[c], want->second, 1e-6) << i;
      EXPECT_LT((bc_tool_axis(q[b], q[c]) - o).norm(), 1e-9);
      kin::Pose p;
      ASSERT_TRUE(m->nominal->forward(q, p).ok());
      EXPECT_LT((p.p - Eigen::Vector3d(10, -5, 20)).norm(), 1e-6) << "the tool tip where programmed";
      // Where the unconstrained nearest solution leaves the travel, the rule switched.
      const auto free = expected_in_travel(o, start[b], start[c], -inf, inf, -inf, inf);
      if (free && (free->first < t.bmin || free->first > t.bmax || (std::isfinite(t.cmin) && (free->second < t.cmin || free->second > t.cmax))))
        ++switched;
    }
  }
  EXPECT_GT(refused, 10) << "the sample reaches the case with no solution in travel";
  EXPECT_GT(switched, 50) << "the sample reaches the switch";
}

/// End to end: B's travel stops at +5°, and the program tilts the tool 20° toward −X, which the
/// nearest solution takes with B +20° (C stays). Under "nearest" the block is refused at its line
/// (the controller would stop there); under "nearest-in-travel" the controller takes B −20° with
/// C half a turn on, and the compensated program, read back under the same rule, is verified.
TEST(IkBranch, NearestInTravelEndToEnd) {
  const double inf = std::numeric_limits<double>::infinity();
  const std::string program =
      "%\nO1\nG21 G90 G94 G54\nG0 X0. Y0. Z100. B0. C0.\nG43.5 H7 X0. Y0. Z50. I-0.34202 J0. K0.93969\n"
      "G1 X5. Y0. Z10. F1000.\nX10. Y2. Z10.\nG49\nM30\n%\n";
  for (const char* setting : {"nearest", "nearest-in-travel"}) {
    SCOPED_TRACE(setting);
    gc::DiagnosticSink msink;
    const auto m = trunnion_travel(setting, -110, 5, -inf, inf, msink);
    ASSERT_TRUE(m);
    const gc::Dialect d = *gc::make_dialect(m->dialect_name, m->dialect_options);
    Compensated run;
    compensate(program, *m, run);
    const gc::DiagnosticSink& sink = run.sink;
    const postproc::comp::CompensateResult& r = run.r;
    const std::vector<std::uint64_t>& line_map = run.line_map;
    if (std::string(setting) == "nearest") {
      ASSERT_TRUE(sink.has_errors());
      const auto& e = sink.stored()[0];
      EXPECT_EQ(e.code, "PP-E603") << e.message;
      EXPECT_EQ(e.where.line, 5u) << e.message;
      continue;
    }
    for (const auto& diag : sink.stored())
      if (diag.severity == gc::Severity::error) ADD_FAILURE() << diag.message;
    ASSERT_FALSE(sink.has_errors());
    const std::string& written = run.written;
    EXPECT_NE(written.find("ik-branch=nearest-in-travel"), std::string::npos) << written;
    EXPECT_LT(r.max_residual_mm, 0.001);
    EXPECT_LT(r.max_residual_rad, 0.1 * r.max_error_before_rad);
    const postproc::comp::VerifyResult v = postproc::comp::verify(program, written, line_map, d, *m);
    EXPECT_GE(v.compared, 3u);
    EXPECT_LT(v.max_excess_mm, 1e-6) << "line " << v.worst_line;
    // Read into the path, the tilted blocks stand at B −20° and C 180° (the independent closed form).
    gc::DiagnosticSink psink;
    gc::LineReader in{std::string_view(program)};
    const postproc::contour::Path path = postproc::contour::build_path(in, "t.nc", d, *m, {}, psink);
    ASSERT_FALSE(path.points.empty());
    const int b = joint(*m->nominal, 'B'), c = joint(*m->nominal, 'C');
    EXPECT_NEAR(path.points.back().q[b], -20.0, 0.01);
    EXPECT_NEAR(std::abs(wrap(path.points.back().q[c])), 180.0, 1e-6);
  }
  // No solution within travel (B limited to ±5°): refused at the line, naming B and the rule.
  gc::DiagnosticSink msink;
  const auto m = trunnion_travel("nearest-in-travel", -5, 5, -inf, inf, msink);
  ASSERT_TRUE(m);
  Compensated c;
  compensate(program, *m, c);
  const gc::DiagnosticSink& sink = c.sink;
  ASSERT_TRUE(sink.has_errors());
  EXPECT_EQ(sink.stored()[0].code, "PP-E603");
  EXPECT_EQ(sink.stored()[0].where.line, 5u);
  EXPECT_NE(sink.stored()[0].message.find("joint B within its travel -5 … 5 deg"), std::string::npos)
      << sink.stored()[0].message;
}

}  // namespace

namespace {

/// Under a rule that does not depend on the block before (a sign rule; "nearest-in-travel" where
/// only one solution lies in travel), a program restarted in the middle gets the same corrected
/// blocks from the restart on: the correction carries no history of its own.
TEST(IkBranch, RestartInMidProgramGivesTheSameBlocksUnderHistoryFreeRules) {
  // A G43.5 sweep at B −(12…35)° and C −60…60° (the tilt-negative solution; written as I J K with
  // the closed form above), every block giving the tool tip and the axis.
  std::string program = "%\nO1\nN10 G21 G90 G94 G54\nN20 G0 X0. Y0. Z100. B0. C0.\n";
  for (int k = 0; k < 40; ++k) {
    const double b = -12 - 23 * std::sin(0.08 * k), c = -60 + 3 * k;
    const Eigen::Vector3d o = bc_tool_axis(b, c);
    program += fmt::format("N{} {}X{:.3f} Y{:.3f} Z{:.3f} I{:.6f} J{:.6f} K{:.6f}{}\n", 30 + 10 * k,
                           k == 0 ? "G43.5 H7 G1 " : "", 20 * std::cos(0.1 * k), 15 * std::sin(0.1 * k), 5 + 0.2 * k,
                           o.x(), o.y(), o.z(), k == 0 ? " F1000." : "");
  }
  program += "N500 G49\nN510 M30\n%\n";
  // Restart at N230: drop N30 … N220; N230 gives every word of the pose, and G43.5 / F again.
  const std::size_t from = program.find("\nN30 ") + 1, to = program.find("\nN230 ") + 1;
  std::string restarted = program.substr(0, from) + program.substr(to);
  restarted.replace(restarted.find("N230 "), 5, "N230 G43.5 H7 G1 F1000. ");
  const double inf = std::numeric_limits<double>::infinity();
  for (const char* setting : {"tilt-negative", "nearest-in-travel"}) {
    SCOPED_TRACE(setting);
    gc::DiagnosticSink msink;
    const auto m = trunnion_travel(setting, -110, std::string(setting) == "nearest-in-travel" ? 5 : 110, -inf, inf,
                                   msink);
    ASSERT_TRUE(m);
    const auto run = [&](const std::string& text) {
      Compensated c;
      compensate(text, *m, c);
      for (const auto& diag : c.sink.stored())
        if (diag.severity == gc::Severity::error) ADD_FAILURE() << diag.message;
      std::map<int, std::string> by_n;
      std::istringstream in(c.written);
      std::string line;
      while (std::getline(in, line))
        if (line.size() > 1 && line[0] == 'N') by_n[std::stoi(line.substr(1))] = line;
      return by_n;
    };
    const auto a = run(program), b = run(restarted);
    int same = 0, changed = 0;
    for (const auto& [n, line] : b) {
      if (n <= 230) continue;  // N230 carries the restart's extra words
      ASSERT_TRUE(a.contains(n)) << n;
      EXPECT_EQ(a.at(n), line) << "N" << n;
      ++same;
      changed += program.find(line) == std::string::npos;
    }
    EXPECT_GE(same, 20);
    EXPECT_GE(changed, 15) << "the blocks compared are corrected ones";
  }
}

}  // namespace
