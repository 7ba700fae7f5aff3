// LinuxCNC cutter radius compensation (G41/G42, G41.1/G42.1, G40): the tool-centre path, computed as
// LinuxCNC's interpreter does (user manual "Cutter Radius Compensation"; G-code reference "G41, G42
// Cutter Compensation", "G41.1, G42.1 Dynamic Cutter Compensation"; rs274ngc interp_convert.cc
// convert_straight_comp1/2, convert_arc_comp1/2 and interp_queue.cc move_endpoint_and_flush). The
// expectations are computed by hand below (and agree with rs274 -g to its 4 printed decimals).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <optional>
#include <sstream>

#include "postproc/compensation/compensate.hpp"
#include "postproc/io/output_file.hpp"
#include "sample_machine.hpp"
#include "src/gcode/cutter_offset.hpp"
#include "support.hpp"

namespace {

using namespace pptest;
using gc::Axis;
constexpr double kTol = 1e-9;
constexpr double kPi = std::numbers::pi;

gc::Dialect lcnc(std::map<std::uint32_t, double> radii, std::map<std::uint32_t, int> orientations = {}) {
  gc::DialectOptions o;
  o.tool_radii = std::move(radii);
  o.tool_orientations = std::move(orientations);
  return *gc::make_dialect("linuxcnc", o);
}

void expect_at(const gc::Motion& m, double x, double y, double z = 0) {
  EXPECT_NEAR(m.end[0], x, kTol) << "line " << m.line;
  EXPECT_NEAR(m.end[1], y, kTol) << "line " << m.line;
  EXPECT_NEAR(m.end[2], z, kTol) << "line " << m.line;
}

void expect_arc(const gc::Motion& m, double cx, double cy, double sweep) {
  ASSERT_TRUE(m.type == gc::MotionType::arc_cw || m.type == gc::MotionType::arc_ccw) << "line " << m.line;
  EXPECT_NEAR(m.arc.centre[0], cx, kTol) << "line " << m.line;
  EXPECT_NEAR(m.arc.centre[1], cy, kTol) << "line " << m.line;
  EXPECT_NEAR(m.arc.sweep, sweep, 1e-9) << "line " << m.line;
}

// "Cutter Radius Compensation": G42, radius 5, along +X then +Y. The entry move ends one radius to
// the right of X0 Y0, at right angles to the line from the tool (X-10 Y0) to it: X0 Y-5. The
// junction X20 is an outside corner: the straight move ends at X20 Y-5, an arc about the
// programmed corner (counter-clockwise, 90°) takes the tool to X25 Y0, and the move along Y ends at
// X25 Y20. G40 releases it; the next move runs from there to the programmed X30 Y30.
TEST(CutterOffset, EntryMoveAndOutsideCornerArc) {
  const Program r(lcnc({{1, 5.0}}),
                  "G21 G17 G90\nT1 M6\nG0 X-10 Y0\nG42 G1 X0 Y0 F100\nX20\nY20\nG40 G1 X30 Y30\nM2\n");
  EXPECT_EQ(r.sink.stored().size(), 0u) << r.all_codes();
  ASSERT_EQ(r.motions.size(), 6u);
  expect_at(r.motions[1], 0, -5);
  EXPECT_EQ(r.motions[1].line, 4u);
  expect_at(r.motions[2], 20, -5);
  EXPECT_EQ(r.motions[2].line, 5u);
  expect_at(r.motions[3], 25, 0);
  expect_arc(r.motions[3], 20, 0, kPi / 2);
  EXPECT_EQ(r.motions[3].line, 6u);  // the corner arc belongs to the block that makes the corner
  EXPECT_EQ(r.motions[3].programmed, 0u);
  expect_at(r.motions[4], 25, 20);
  EXPECT_EQ(r.motions[4].line, 6u);
  expect_at(r.motions[5], 30, 30);
  EXPECT_NEAR(r.motions[5].start[0], 25, kTol);  // from where compensation left the tool
  EXPECT_NEAR(r.motions[5].start[1], 20, kTol);
  for (std::size_t i = 1; i <= 4; ++i) {
    EXPECT_TRUE(r.motions[i].words_transformed);
    EXPECT_EQ(r.motions[i].cutter_radius, 5.0);
  }
  EXPECT_EQ(r.motions[5].cutter_radius, 0.0);
}

// An inside corner (G41 along the same path): the two offset lines meet one radius inside both, at
// X15 Y5 — the move along X is shortened there (retreat r / tan(90°/2) = 5), the move along Y starts
// there. A move along Z only, held between them, ends where the shortened move ends.
TEST(CutterOffset, InsideCornerShortensTheMoveBefore) {
  const Program r(lcnc({{1, 5.0}}),
                  "G21 G17 G90\nT1 M6\nG0 X-10 Y0\nG41 G1 X0 Y0 F100\nX20\nZ-1\nY20\nG40 G1 X30 Y30\nM2\n");
  EXPECT_EQ(r.sink.stored().size(), 0u) << r.all_codes();
  ASSERT_EQ(r.motions.size(), 6u);
  expect_at(r.motions[1], 0, 5);
  expect_at(r.motions[2], 15, 5);
  expect_at(r.motions[3], 15, 5, -1);
  EXPECT_EQ(r.motions[3].line, 6u);
  expect_at(r.motions[4], 15, 20, -1);
}

// A straight move into an arc at an inside corner (G41, the tool inside the counter-clockwise arc
// about X10 Y10, radius √200): the offset line Y5 meets the offset circle of radius √200 − 5 at
// X = 10 + √((√200 − 5)² − 5²); the arc then ends one radius towards the centre from X20 Y20.
TEST(CutterOffset, LineIntoArcInsideCorner) {
  const Program r(lcnc({{1, 5.0}}),
                  "G21 G17 G90\nT1 M6\nG0 X-10 Y0\nG41 G1 X0 Y0 F100\nX20\nG3 X20 Y20 I-10 J10\nG40 G1 X0\nM2\n");
  EXPECT_EQ(r.sink.stored().size(), 0u) << r.all_codes();
  ASSERT_EQ(r.motions.size(), 5u);
  const double inner = std::sqrt(200.0) - 5;
  const double x = 10 + std::sqrt(inner * inner - 25);
  expect_at(r.motions[2], x, 5);
  const double k = 5 / std::sqrt(2.0);
  expect_at(r.motions[3], 20 - k, 20 - k);
  const double a0 = std::atan2(5 - 10, x - 10), a1 = std::atan2(20 - k - 10, 20 - k - 10);
  expect_arc(r.motions[3], 10, 10, a1 - a0);
}

// Tangent junctions need no corner element (directions within 0.05 rad): G42 along a line, a
// counter-clockwise quarter arc tangent to it and a line tangent to the arc. The tool outside the
// arc: the arc's radius grows by 5 (15), its centre stays.
TEST(CutterOffset, TangentJunctionsInsertNothing) {
  const Program r(lcnc({{1, 5.0}}),
                  "G21 G17 G90\nT1 M6\nG0 X-10 Y0\nG42 G1 X0 Y0 F100\nX20\nG3 X30 Y10 I0 J10\nG1 Y30\nG40 X40\nM2\n");
  EXPECT_EQ(r.sink.stored().size(), 0u) << r.all_codes();
  ASSERT_EQ(r.motions.size(), 6u);
  expect_at(r.motions[2], 20, -5);
  expect_at(r.motions[3], 35, 10);
  expect_arc(r.motions[3], 20, 10, kPi / 2);
  expect_at(r.motions[4], 35, 30);
}

// The entry move as an arc (convert_arc_comp1): from X0 Y0, G41 G3 to X30 Y0 about X15 Y0, the tool
// inside: it ends at X25 Y0 and runs along the arc through its start point about the point on the
// line to the programmed centre equally far from both: X12.5 Y0.
TEST(CutterOffset, EntryArc) {
  const Program r(lcnc({{1, 5.0}}), "G21 G17 G90\nT1 M6\nG0 X0 Y0\nG41 G3 X30 Y0 I15 J0 F100\nM2\n");
  EXPECT_EQ(r.sink.stored().size(), 0u) << r.all_codes();
  ASSERT_EQ(r.motions.size(), 2u);
  expect_at(r.motions[1], 25, 0);
  expect_arc(r.motions[1], 12.5, 0, kPi);
}

// G91 under compensation counts from the programmed point, not from the tool centre; G18 works in
// Z X (G41 = left of the move seen in Z→X axes, as LinuxCNC's comp_get_current swaps them).
TEST(CutterOffset, IncrementalWordsAndG18) {
  const Program r(lcnc({{1, 5.0}}), "G21 G17 G90\nT1 M6\nG0 X-10 Y0\nG42 G1 X0 Y0 F100\nG91 X20\nG90 G40 X30\nM2\n");
  EXPECT_EQ(r.sink.stored().size(), 0u) << r.all_codes();
  ASSERT_EQ(r.motions.size(), 4u);
  expect_at(r.motions[2], 20, -5);
  const Program z(lcnc({{1, 5.0}}), "G21 G18 G90\nT1 M6\nG0 X0 Z10\nG41 G1 X0 Z0 F100\nZ-20\nG40 X10\nM2\n");
  EXPECT_EQ(z.sink.stored().size(), 0u) << z.all_codes();
  ASSERT_EQ(z.motions.size(), 4u);
  // Along −Z the left side is −X in the (Z, X) frame: the entry ends at X−5 Z0, the next at X−5 Z−20.
  EXPECT_NEAR(z.motions[1].end[0], -5, kTol);
  EXPECT_NEAR(z.motions[1].end[2], 0, kTol);
  EXPECT_NEAR(z.motions[2].end[0], -5, kTol);
  EXPECT_NEAR(z.motions[2].end[2], -20, kTol);
}

// Where the radius comes from (convert_cutter_compensation_on): D names a tool, D0 and no D the tool
// in the spindle (rs274 with a tool table: G41 D0 after T1 M6 offsets by tool 1's radius); a
// negative diameter runs on the other side; G41.1 D gives the diameter. Without a tool change the
// spindle's tool is not known: PP-U220 as before.
TEST(CutterOffset, RadiusFromTheToolTable) {
  const auto d = lcnc({{1, 5.0}, {2, -2.0}});
  const Program d0(d, "G21 G17 G90\nT1 M6\nG0 X-10 Y0\nG41 D0 G1 X0 Y0 F100\nM2\n");
  ASSERT_EQ(d0.motions.size(), 2u) << d0.all_codes();
  expect_at(d0.motions[1], 0, 5);
  const Program neg(d, "G21 G17 G90\nT1 M6\nG0 X-10 Y0\nG41 D2 G1 X0 Y0 F100\nM2\n");
  ASSERT_EQ(neg.motions.size(), 2u) << neg.all_codes();
  expect_at(neg.motions[1], 0, -2);
  const Program dyn(d, "G21 G17 G90\nG0 X-10 Y0\nG42.1 D6 G1 X0 Y0 F100\nM2\n");
  ASSERT_EQ(dyn.motions.size(), 2u) << dyn.all_codes();
  expect_at(dyn.motions[1], 0, -3);
  const Program unknown(d, "G21 G17 G90\nG0 X-10 Y0\nG41 G1 X0 Y0 F100\nM2\n");
  expect_diag_at(unknown, "PP-U220", 3, 5);
}

// With a radius the tool table does not give, LinuxCNC still offsets the path, by a radius this run
// does not know: the moves under G41/G42 are not known in the plane (Z still is); after G40 the
// programmed point is known again, but a tool change right after it reads back where the offset
// path ended (rs274 toolchange_flag), which is not known either.
TEST(CutterOffset, UnknownRadiusLeavesThePlaneUnknown) {
  const auto d = lcnc({{1, 5.0}});
  const Program r(d, "G21 G17 G90\nT3 M6\nG0 X-10 Y0 Z5\nG41 G1 X0 Y0 F100\nY20 Z2\nG40 G1 X-10\nY-10\n"
                     "G41 G1 X0 Y0\nG40\nT1 M6\nG91 G1 Z1\nG90 G1 X0 Y0 Z0\nM2\n");
  ASSERT_EQ(r.motions.size(), 8u) << r.all_codes();
  const gc::AxisMask xy = gc::bit(Axis::x) | gc::bit(Axis::y);
  for (const std::size_t i : {std::size_t{1}, std::size_t{2}, std::size_t{5}})
    EXPECT_EQ(r.motions[i].known & xy, 0) << "line " << r.motions[i].line;
  EXPECT_TRUE(r.motions[2].known & gc::bit(Axis::z));
  EXPECT_NEAR(r.motions[2].end[2], 2, kTol);
  for (const std::size_t i : {std::size_t{3}, std::size_t{4}}) EXPECT_EQ(r.motions[i].known & xy, xy);
  expect_at(r.motions[4], -10, -10, 2);
  // Line 11: after G40 without a move, T1 M6 reads X Y back from where the offset path ended.
  EXPECT_EQ(r.motions[6].line, 11u);
  EXPECT_EQ(r.motions[6].known & xy, 0);
  expect_at(r.motions[7], 0, 0, 0);
  EXPECT_EQ(r.motions[7].known & xy, xy);
}

// What LinuxCNC refuses under compensation is refused at the block it names (PP-E220, exit 2).
TEST(CutterOffset, LinuxcncRefusalsAreLocated) {
  const auto d = lcnc({{1, 5.0}, {2, 25.0}});
  const std::string head = "G21 G17 G90\nT1 M6\nG0 X-10 Y0\nG41 G1 X0 Y0 F100\n";
  expect_diag_at(Program(d, head + "X20\nG54\nM2\n"), "PP-E220", 6, 1);
  expect_diag_at(Program(d, head + "X20\nG41 X30\nM2\n"), "PP-E220", 6, 1);
  expect_diag_at(Program(d, head + "X20\nG19\nM2\n"), "PP-E220", 6, 1);
  expect_diag_at(Program(d, head + "X20\nT2 M6\nM2\n"), "PP-E220", 6, 4);
  expect_diag_at(Program(d, head + "X20\nG40\nG2 X30 Y10 R10\nM2\n"), "PP-E220", 7, 1);
  expect_diag_at(Program(d, "G21 G17 G90\nT1 M6\nG0 X0 Y0\nG41 G1 X4 F100\nM2\n"), "PP-E220", 4, 5);
  // Radius 25: the second move is shorter than the retreat into the inside corner (rs274: "Straight
  // feed in concave corner cannot be reached by the tool without gouging", at the block after it).
  const Program gouge(d, "G21 G17 G90\nT2 M6\nG0 X-40 Y0\nG41 G1 X0 Y0 F100\nX10\nY30\nM2\n");
  expect_diag_at(gouge, "PP-E220", 6, 1);
  EXPECT_NE(gouge.find("PP-E220")->message.find("Straight feed in concave corner"), std::string::npos);
}

// A program that ends (no M2) with a move held: LinuxCNC never issues it; postproc says so there.
TEST(CutterOffset, HeldMoveAtTheEndIsNotIssued) {
  const Program r(lcnc({{1, 5.0}}), "G21 G17 G90\nT1 M6\nG0 X-10 Y0\nG41 G1 X0 Y0 F100\nX20\n");
  expect_diag_at(r, "PP-U220", 5, 1);
  ASSERT_EQ(r.motions.size(), 2u);
  expect_at(r.motions[1], 0, 5);
}

gc::Motion programmed(gc::MotionType type, Eigen::Vector2d from, Eigen::Vector2d to, Eigen::Vector2d centre = {}) {
  gc::Motion m;
  m.type = type;
  m.start = gc::AxisVector::Zero();
  m.end = gc::AxisVector::Zero();
  m.start[0] = from.x();
  m.start[1] = from.y();
  m.end[0] = to.x();
  m.end[1] = to.y();
  m.known = 0x1ff;
  if (type == gc::MotionType::arc_cw || type == gc::MotionType::arc_ccw) {
    m.arc.centre = Eigen::Vector3d(centre.x(), centre.y(), 0);
    m.arc.radius = (from - centre).norm();
    m.arc.turns = 1;
  }
  return m;
}

// The geometry alone (cutter_offset.hpp): LinuxCNC's find_turn, and outside corners before and
// between arcs (convert_arc_comp2, "convex, two arcs needed"). G42, radius 1, an "m": a line along
// +X to X0, a clockwise half circle X0→X20 about X10 and another X20→X40 about X30, the tool inside
// the arcs. At X0 the path turns left (an outside corner for G42): an arc about X0 Y0 from Y−1 to
// X1 (90°); the first half circle runs at radius 9 to X19; at the cusp X20 the path reverses: an arc
// about X20 Y0 from X19 to X21 under it (180°); the second half circle ends at X39.
TEST(CutterOffset, TurnAngleAndCornersBetweenArcs) {
  const Eigen::Vector2d c(0, 0);
  EXPECT_NEAR(gc::cutter_turn_angle({1, 0}, c, 1, {0, 1}), kPi / 2, kTol);
  EXPECT_NEAR(gc::cutter_turn_angle({1, 0}, c, -1, {0, 1}), -3 * kPi / 2, kTol);
  EXPECT_NEAR(gc::cutter_turn_angle({1, 0}, c, 1, {1, 0}), 2 * kPi, kTol);
  EXPECT_NEAR(gc::cutter_turn_angle({1, 0}, c, 2, {0, 1}), 2 * kPi + kPi / 2, kTol);
  gc::CutterOffset off;
  gc::AxisVector at = gc::AxisVector::Zero();
  at[0] = -10;
  off.start(gc::CutterOffset::Side::right, 1.0, gc::Plane::xy, 0, at);
  std::vector<gc::Motion> out;
  ASSERT_FALSE(off.move(programmed(gc::MotionType::linear, {-10, 0}, {0, 0}), out));
  EXPECT_TRUE(out.empty());  // held until the next move says where it ends
  ASSERT_FALSE(off.move(programmed(gc::MotionType::arc_cw, {0, 0}, {20, 0}, {10, 0}), out));
  ASSERT_EQ(out.size(), 2u);
  expect_at(out[0], 0, -1);
  expect_at(out[1], 1, 0);
  expect_arc(out[1], 0, 0, kPi / 2);
  ASSERT_FALSE(off.move(programmed(gc::MotionType::arc_cw, {20, 0}, {40, 0}, {30, 0}), out));
  ASSERT_EQ(out.size(), 4u);
  expect_at(out[2], 19, 0);
  expect_arc(out[2], 10, 0, -kPi);
  expect_at(out[3], 21, 0);
  expect_arc(out[3], 20, 0, kPi);
  ASSERT_FALSE(off.flush(out));
  ASSERT_EQ(out.size(), 5u);
  expect_at(out[4], 39, 0);
  expect_arc(out[4], 30, 0, -kPi);
}

// compensate on `program` through machine `m`; the first error, if any.
std::optional<gc::Diagnostic> first_compensate_error(const postproc::machine::Machine& m, const std::string& program) {
  TempDir dir;
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  gc::DiagnosticSink sink;
  gc::LineReader reader{std::string_view(program)};
  postproc::io::OutputFile out(dir.file("out.nc"));
  postproc::comp::CompensateOptions opt;
  opt.tool_version = "test";
  (void)postproc::comp::compensate(reader, "in.nc", d, m, opt, out, sink);
  for (const auto& x : sink.stored())
    if (x.severity == gc::Severity::error) return x;
  return std::nullopt;
}

// compensate refuses a program under a non-zero cutter radius, located at the first such move: the
// controller would offset corrected points again.
TEST(CutterOffset, CompensateRefusesAProgramUnderCompensation) {
  postproc::machine::Machine m = sample_machine("trunnion_bc_fanuc.toml");
  m.dialect_name = "linuxcnc";
  const std::string program =
      "G21 G90 G54\nG0 X0 Y0 Z100 B0 C0\nT1 M6\nG41 G1 X20 F100\nY20\nG40 G1 X0\nM2\n";
  m.dialect_options.tool_radii = {{1, 3.0}};
  const auto e = first_compensate_error(m, program);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->code, "PP-E601");
  EXPECT_EQ(e->where.line, 4u);
  EXPECT_NE(e->message.find("cutter radius compensation with radius 3 mm"), std::string::npos) << e->message;
  // The same program with a zero radius is compensated as before.
  m.dialect_options.tool_radii = {{1, 0.0}};
  const auto e0 = first_compensate_error(m, program);
  EXPECT_FALSE(e0.has_value()) << gc::format(*e0);
  // A radius the tool table does not give: refused at the first move under G41 (its point in the
  // plane is not known), never written as if the radius were 0.
  m.dialect_options.tool_radii = {};
  const auto eu = first_compensate_error(m, program);
  ASSERT_TRUE(eu.has_value());
  EXPECT_EQ(eu->where.line, 4u) << gc::format(*eu);
}

// Fanuc and Sinumerik G41/G42 are not computed: compensate refuses the first move under a radius
// that is not 0 or not known (PP-E601; rapids too, which the controllers offset as well), and
// passes D0 / a radius of 0 in the machine file's table (the CAM path is the tool centre).
TEST(CutterOffset, CompensateRefusesFanucAndSinumerikRadius) {
  postproc::machine::Machine m = sample_machine("trunnion_bc_fanuc.toml");
  const std::string fanuc = "G21 G90 G54\nG0 X0 Y0 Z100 B0 C0\nG41 D1 G0 X20\nG1 Y20 F100\nG40 G1 X0\nM30\n";
  m.dialect_options.tool_radii = {};
  const auto e = first_compensate_error(m, fanuc);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->code, "PP-E601");
  EXPECT_EQ(e->where.line, 3u);
  EXPECT_NE(e->message.find("a radius the tool table does not give"), std::string::npos) << e->message;
  m.dialect_options.tool_radii = {{1, 4.0}};
  const auto e4 = first_compensate_error(m, fanuc);
  ASSERT_TRUE(e4.has_value());
  EXPECT_NE(e4->message.find("radius 4 mm"), std::string::npos) << e4->message;
  m.dialect_options.tool_radii = {{1, 0.0}};
  const auto e0 = first_compensate_error(m, fanuc);
  EXPECT_FALSE(e0.has_value()) << gc::format(*e0);
  m.dialect_options.tool_radii = {};
  const auto d0 = first_compensate_error(m, "G21 G90 G54\nG0 X0 Y0 Z100 B0 C0\nG41 D0 G1 X20 F100\nG40 G1 X0\nM30\n");
  EXPECT_FALSE(d0.has_value()) << gc::format(*d0);
  m.dialect_name = "siemens";
  m.tool_lengths[1] = m.tool_lengths.count(0) ? m.tool_lengths[0] : 0.0;  // D1's length: known
  m.dialect_options.tool_lengths = m.tool_lengths;
  const auto s = first_compensate_error(m, "G71 G90 G54\nT1 D1\nG0 X0 Y0 Z100 B0 C0\nG41 G1 X20 F100\nG40 G1 X0\nM30\n");
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->code, "PP-E601");
  EXPECT_EQ(s->where.line, 4u);
}

}  // namespace
