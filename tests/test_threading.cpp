// Threading cycles (issue 16, area "threading"; docs/threading.md): each cycle is expanded into the
// passes the controller cuts, or refused at its line. Expected end points come from the manuals'
// rules (named per test), recomputed here from the programmed words; the LinuxCNC programs in
// tests/threading/linuxcnc are also compared move for move with rs274 (tests/threading_compare.sh).
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "postproc/compensation/compensate.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/machine/machine.hpp"
#include "sample_machine.hpp"
#include "src/gcode/codes.hpp"
#include "support.hpp"

namespace {

namespace gc = postproc::gcode;
namespace codes = postproc::gcode::codes;
using pptest::dialect;

constexpr double kEps = 1e-9;

template <class Run>
std::vector<const gc::Motion*> of_line(const Run& r, std::uint64_t line) {
  std::vector<const gc::Motion*> out;
  for (const auto& m : r.motions)
    if (m.line == line) out.push_back(&m);
  return out;
}

double rad(double deg) { return deg * std::numbers::pi / 180.0; }

// ---------------------------------------------------------------------------------------------
// LinuxCNC G76 (LinuxCNC G-code reference, linuxcnc.org/docs/html/gcode/g-code.html#gcode:g76).
// The drive line is the start X; the thread peak lies |I| from it, the first pass |I|+|J|, pass n
// |I|+|J|·n^(1/R) (R1 constant depth, R2 constant area), the last pass |I|+|K| followed by H
// spring passes at full depth. Each pass: rapid to the retract X at the pass's start Z, rapid in
// (or the entry taper), the synchronised cut to Z (or the exit taper), rapid out. Then a rapid to
// the block's end point.

TEST(ThreadingLinuxcnc, G76ConstantDepthPassesThenFullDepth) {
  // No R: constant depth J per pass (R1). I-1 J0.1 K0.92 from X10: passes at depth 1.1 … 1.9
  // (1 + 0.1·n < 1.92, n = 1…9), then the full depth 1.92 once (H0). Radius mode (G8).
  gc::Dialect d = dialect("linuxcnc");
  pptest::Program r(d,
                    "G21 G18 G8 G90\n"
                    "M3 S500\n"
                    "G0 X10 Z5\n"
                    "G76 P1.5 Z-30 I-1 J0.1 K0.92\n"
                    "G0 X20\n"
                    "M2\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error) + r.sink.count(gc::Severity::warning), 0u) << r.all_codes();
  const auto ms = of_line(r, 4);
  ASSERT_EQ(ms.size(), 10u * 4 + 1);
  for (int n = 1; n <= 10; ++n) {
    const double depth = n <= 9 ? 1 + 0.1 * n : 1.92;
    const double clear = 10 - (depth - 1.92);  // the retract line: depth − full depth from the drive line
    const auto* p = &ms[static_cast<std::size_t>(4 * (n - 1))];
    EXPECT_EQ(p[0]->type, gc::MotionType::rapid);
    EXPECT_NEAR(p[0]->end[0], clear, kEps) << n;
    EXPECT_NEAR(p[0]->end[2], 5, kEps) << n;
    EXPECT_EQ(p[1]->type, gc::MotionType::rapid);
    EXPECT_NEAR(p[1]->end[0], 10 - depth, kEps) << n;
    EXPECT_EQ(p[2]->type, gc::MotionType::linear);
    EXPECT_NEAR(p[2]->end[0], 10 - depth, kEps) << n;
    EXPECT_NEAR(p[2]->end[2], -30, kEps) << n;
    EXPECT_EQ(p[2]->feed_mode, gc::FeedMode::per_rev);  // synchronised: P per revolution
    EXPECT_NEAR(p[2]->feed, 1.5, kEps);
    EXPECT_EQ(p[3]->type, gc::MotionType::rapid);
    EXPECT_NEAR(p[3]->end[0], clear, kEps) << n;
    EXPECT_NEAR(p[3]->end[2], -30, kEps) << n;
  }
  // The final rapid to the block's end point (X unchanged: the drive line).
  EXPECT_EQ(ms.back()->type, gc::MotionType::rapid);
  EXPECT_NEAR(ms.back()->end[0], 10, kEps);
  EXPECT_NEAR(ms.back()->end[2], -30, kEps);
  for (const auto* m : ms) {
    EXPECT_EQ(m->column, 1u);
    EXPECT_EQ(m->known & 5u, 5u);
  }
  // G76 stays the motion mode; the next G0 block is an ordinary rapid.
  const auto next = of_line(r, 5);
  ASSERT_EQ(next.size(), 1u);
  EXPECT_NEAR(next[0]->end[0], 20, kEps);
}

TEST(ThreadingLinuxcnc, G76DegressionCompoundAngleSpringPassesAndTapersInDiameterMode) {
  // G7: I J K are diameters (reference, note under G76). Inside thread (I > 0: towards +X).
  // R2 constant area: depth n = |I| + |J|·√n; Q29.5: each pass starts (depth − |I|)·tan 29.5°
  // further back along Z, and the cut ends at Z + |K|·tan 29.5° minus that offset. E2 L3: the
  // entry feeds in to depth − K at the start, then along the taper to full depth E further; the
  // exit leaves at E before the end along a taper to depth − K. Taper lead = P·√(E²+K²)/E.
  gc::Dialect d = dialect("linuxcnc");
  pptest::Program r(d,
                    "G21 G18 G7 G90\n"
                    "M3 S500\n"
                    "G0 X16 Z5\n"
                    "G76 P1.5 Z-30 I2 J0.2 K1.84 R2 Q29.5 H2 E2 L3\n"
                    "M2\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error) + r.sink.count(gc::Severity::warning), 0u) << r.all_codes();
  const auto ms = of_line(r, 4);
  const double drive = 8, peak = 1, first = 0.1, height = 0.92, full = peak + height;
  const double t = std::tan(rad(29.5));
  const double target = -30 + height * t;
  const double taper_lead = 1.5 * std::hypot(2.0, height) / 2.0;
  std::vector<double> depths;
  for (int n = 1; peak + first * std::sqrt(n) < full; ++n) depths.push_back(peak + first * std::sqrt(n));
  for (int k = 0; k < 3; ++k) depths.push_back(full);
  ASSERT_EQ(ms.size(), depths.size() * 6 + 1);
  for (std::size_t n = 0; n < depths.size(); ++n) {
    const double depth = depths[n], zoff = (depth - peak) * t;
    const auto* p = &ms[6 * n];
    EXPECT_EQ(p[0]->type, gc::MotionType::rapid);
    EXPECT_NEAR(p[0]->end[0], drive + depth - full, kEps) << n;
    EXPECT_NEAR(p[0]->end[2], 5 - zoff, kEps) << n;
    EXPECT_EQ(p[1]->type, gc::MotionType::linear);  // entry taper: in to depth − K, synchronised
    EXPECT_NEAR(p[1]->end[0], drive + depth - height, kEps) << n;
    EXPECT_NEAR(p[1]->end[2], 5 - zoff, kEps) << n;
    EXPECT_NEAR(p[1]->feed, taper_lead, kEps);
    EXPECT_NEAR(p[2]->end[0], drive + depth, kEps) << n;
    EXPECT_NEAR(p[2]->end[2], 5 - zoff - 2, kEps) << n;
    EXPECT_NEAR(p[2]->feed, taper_lead, kEps);
    EXPECT_NEAR(p[3]->end[0], drive + depth, kEps) << n;  // the thread at the pitch
    EXPECT_NEAR(p[3]->end[2], target - zoff + 2, kEps) << n;
    EXPECT_NEAR(p[3]->feed, 1.5, kEps);
    EXPECT_EQ(p[3]->feed_mode, gc::FeedMode::per_rev);
    EXPECT_NEAR(p[4]->end[0], drive + depth - height, kEps) << n;  // exit taper
    EXPECT_NEAR(p[4]->end[2], target - zoff, kEps) << n;
    EXPECT_NEAR(p[4]->feed, taper_lead, kEps);
    EXPECT_EQ(p[5]->type, gc::MotionType::rapid);
    EXPECT_NEAR(p[5]->end[0], drive + depth - full, kEps) << n;
    EXPECT_NEAR(p[5]->end[2], target - zoff, kEps) << n;
  }
  EXPECT_NEAR(ms.back()->end[0], drive, kEps);
  EXPECT_NEAR(ms.back()->end[2], -30, kEps);
  EXPECT_TRUE(ms.back()->diameter_mode);
}

TEST(ThreadingLinuxcnc, G76TowardsPlusZMirrorsTheAngleAndInchIsConverted) {
  // A thread cut towards +Z (Z end above the start) offsets the passes the other way (rs274
  // negates the compound angle). Inch program: the moves are converted to mm, the lead too.
  gc::Dialect d = dialect("linuxcnc");
  pptest::Program r(d,
                    "G20 G18 G8 G90\n"
                    "M3 S500\n"
                    "G0 X1 Z-2\n"
                    "G76 P0.05 Z0.5 I-0.0625 J0.015625 K0.046875 Q30 H0\n"
                    "M2\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error) + r.sink.count(gc::Severity::warning), 0u) << r.all_codes();
  const auto ms = of_line(r, 4);
  const double t = std::tan(rad(-30));
  // Depths 0.078125, 0.09375 (< 0.109375), then 0.109375 (binary fractions: no rounding doubt).
  ASSERT_EQ(ms.size(), 3u * 4 + 1);
  const double depths[3] = {0.078125, 0.09375, 0.109375};
  for (int n = 0; n < 3; ++n) {
    const double zoff = (depths[n] - 0.0625) * t;
    EXPECT_NEAR(ms[static_cast<std::size_t>(4 * n)]->end[2], (-2 - zoff) * 25.4, 1e-9) << n;
    EXPECT_NEAR(ms[static_cast<std::size_t>(4 * n + 2)]->end[2], (0.5 + 0.046875 * t - zoff) * 25.4, 1e-9) << n;
    EXPECT_NEAR(ms[static_cast<std::size_t>(4 * n + 2)]->end[0], (1 - depths[n]) * 25.4, 1e-9) << n;
    EXPECT_NEAR(ms[static_cast<std::size_t>(4 * n + 2)]->feed, 0.05 * 25.4, 1e-12);
  }
}

TEST(ThreadingLinuxcnc, G76EndsAtTheBlocksEndPointIncrementalAndWithX) {
  // rs274 ends the cycle with a rapid to the block's axis words read as for G0 (G91: increments;
  // an X word moves off the drive line only in that last rapid).
  gc::Dialect d = dialect("linuxcnc");
  pptest::Program r(d,
                    "G21 G18 G8 G90\n"
                    "M3 S500\n"
                    "G0 X10 Z5\n"
                    "G91 G76 P1 Z-20 I-0.5 J0.2 K0.6 X3\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error), 0u) << r.all_codes();
  const auto ms = of_line(r, 4);
  ASSERT_GE(ms.size(), 5u);
  EXPECT_NEAR(ms[2]->end[2], -15, kEps);  // the cut ends at 5 − 20
  EXPECT_NEAR(ms[2]->end[0], 10 - 0.7, kEps);
  EXPECT_NEAR(ms.back()->end[0], 13, kEps);
  EXPECT_NEAR(ms.back()->end[2], -15, kEps);
}

TEST(ThreadingLinuxcnc, G76RefusedWhereRs274RefusesIt) {
  // rs274 (LinuxCNC 2.9) stops on these; the reference lists them under "It is an error if".
  gc::Dialect d = dialect("linuxcnc");
  const std::string head = "G21 G18 G8\nM3 S500\nG0 X10 Z5\n";
  const struct {
    const char* block;
    std::uint32_t column;
  } cases[] = {
      {"G76 P1 Z-20 I-0.5 J0.05", 1},             // I J or K words missing
      {"G76 Z-20 I-0.5 J0.05 K0.6", 1},           // P word missing
      {"G76 P1 I-0.5 J0.05 K0.6", 1},             // all axes missing
      {"G76 P1 Z-20 I0 J0.05 K0.6", 1},           // I must not be 0
      {"G76 P1 Z-20 I-0.5 J0 K0.6", 1},           // J must be greater than 0
      {"G76 P1 Z-20 I-0.5 J0.6 K0.6", 1},         // K must be greater than J
      {"G76 P1 Z-20 I-0.5 J0.05 K0.6 L-1", 1},    // negative L
      {"G76 P1 Z-20 I-0.5 J0.05 K0.6 H1.5", 1},   // H not an integer
      {"G76 P1 Z-20 I-0.5 J0.05 K0.6 C10", 1},    // rotary axis
      {"G41 G76 P1 Z-20 I-0.5 J0.05 K0.6", 5},    // cutter compensation on
  };
  for (const auto& c : cases) {
    pptest::Program r(d, head + c.block + "\n");
    pptest::expect_diag_at(r, codes::kThreadingRejected, 4, c.column);
    EXPECT_TRUE(of_line(r, 4).empty()) << c.block;
  }
  // Spindle stopped (M5, or never started).
  pptest::Program stopped(d, "G21 G18 G8\nG0 X10 Z5\nG76 P1 Z-20 I-0.5 J0.05 K0.6\n");
  pptest::expect_diag_at(stopped, codes::kThreadingRejected, 3, 1);
  // G76 stays the motion mode: a following block with Z alone is a G76 without P.
  pptest::Program modal(d, head + "G76 P1 Z-20 I-0.5 J0.05 K0.6\nZ-25\n");
  pptest::expect_diag_at(modal, codes::kThreadingRejected, 5, 1);
  EXPECT_FALSE(of_line(modal, 4).empty());
}

TEST(ThreadingLinuxcnc, G76FromAnUnknownPointOrWithUnknownWordsIsNotFollowed) {
  gc::Dialect d = dialect("linuxcnc");
  pptest::Program unknown(d, "G21 G18 G8\nM3 S500\nG0 X10\nG76 P1 Z-20 I-0.5 J0.05 K0.6\n");
  pptest::expect_diag_at(unknown, codes::kUnknownPosition, 4, 1);
  EXPECT_TRUE(of_line(unknown, 4).empty());
  // A value the reader does not evaluate (unresolved program): the cycle is not followed.
  pptest::Program expr(d, "G21 G18 G8\nM3 S500\nG0 X10 Z5\nG76 P1 Z-20 I-0.5 J0.05 K[#1+0.6]\n");
  EXPECT_TRUE(expr.has(codes::kThreadingUnresolved)) << expr.all_codes();
  EXPECT_TRUE(of_line(expr, 4).empty());
}

// ---------------------------------------------------------------------------------------------
// Fanuc lathe (Series 0i-TD B-64304EN / 30i-B B-64484EN, "Threading (G32)" and "Threading cycle
// (G92)"; 30i-A B-63944EN 4.1.2 "Threading Cycle (G92)": operations 1-4). X is a diameter.

TEST(ThreadingFanuc, G32IsAStraightMoveAtTheLeadPerRevolution) {
  // G32 X(U) Z(W) F: F is the lead; the move is synchronised with the spindle: a linear move whose
  // feed per revolution is the lead (as LinuxCNC G33). U/W are increments (system A).
  pptest::Program r(dialect("fanuc", true),
                    "G21 G99\n"
                    "G0 X30. Z5.\n"
                    "G32 Z-20. F1.5\n"
                    "G0 X40.\n"
                    "Z5.\n"
                    "X29.\n"
                    "G32 U-1. W-25. F2.\n"
                    "W-2.\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error) + r.sink.count(gc::Severity::warning), 0u) << r.all_codes();
  const auto a = of_line(r, 3);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a[0]->type, gc::MotionType::linear);
  EXPECT_NEAR(a[0]->end[0], 15, kEps);
  EXPECT_NEAR(a[0]->end[2], -20, kEps);
  EXPECT_EQ(a[0]->feed_mode, gc::FeedMode::per_rev);
  EXPECT_NEAR(a[0]->feed, 1.5, kEps);
  EXPECT_EQ(a[0]->column, 1u);
  const auto b = of_line(r, 7);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_NEAR(b[0]->end[0], 14, kEps);  // X29 − U1 (diameter) = 28 → radius 14
  EXPECT_NEAR(b[0]->end[2], -20, kEps);
  EXPECT_NEAR(b[0]->feed, 2, kEps);
  const auto c = of_line(r, 8);  // G32 stays in force (group 01)
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0]->type, gc::MotionType::linear);
  EXPECT_NEAR(c[0]->end[2], -22, kEps);
  EXPECT_EQ(c[0]->feed_mode, gc::FeedMode::per_rev);
}

TEST(ThreadingFanuc, G32WithoutALeadOrOnAMillIsNotFollowed) {
  pptest::Program nolead(dialect("fanuc", true), "G21\nG0 X30. Z5.\nG32 Z-20.\n");
  pptest::expect_diag_at(nolead, codes::kThreadingUnresolved, 3, 1);
  EXPECT_TRUE(of_line(nolead, 3).empty());
  // A lead written as K (NX posts for the Fanuc 0T write "G32Z3.46K.05" after F.03 for G1):
  // not the Fanuc G32 format; refused rather than cut at F.
  pptest::Program k(dialect("fanuc", true), "G20 G99\nG0 X.8 Z4.7\nG1 X.8 F.03\nG32 Z3.46 K.05\n");
  pptest::expect_diag_at(k, codes::kThreadingUnresolved, 4, 1);
  EXPECT_TRUE(of_line(k, 4).empty());
  // Fanuc milling: G32 is not the lathe's thread cutting; the mill table's refusal stays.
  pptest::Program mill(dialect("fanuc"), "G21\nG0 X30. Z5.\nG32 Z-20. F1.5\n");
  pptest::expect_diag_at(mill, codes::kThreading, 3, 1);
}

TEST(ThreadingFanuc, G92FourOperationsAndModalRepeats) {
  // (1) rapid from A to X, (2) threading to Z at F per revolution, (3) rapid to A's X, (4) rapid
  // to A's Z. X(U) Z(W) R are modal in the cycle: a block with X (U) alone cuts again at that X.
  pptest::Program r(dialect("fanuc", true),
                    "G21 G99\n"
                    "G0 X30. Z5.\n"
                    "G92 X29.2 Z-20. F1.5\n"
                    "X28.6\n"
                    "U-1.8\n"
                    "G0 X40.\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error) + r.sink.count(gc::Severity::warning), 0u) << r.all_codes();
  const double xs[3] = {14.6, 14.3, 14.1};  // radius; U-1.8 is from A (X30)
  for (int k = 0; k < 3; ++k) {
    const auto ms = of_line(r, static_cast<std::uint64_t>(3 + k));
    ASSERT_EQ(ms.size(), 4u) << k;
    const gc::MotionType type[4] = {gc::MotionType::rapid, gc::MotionType::linear, gc::MotionType::rapid,
                                    gc::MotionType::rapid};
    const double want[4][2] = {{xs[k], 5}, {xs[k], -20}, {15, -20}, {15, 5}};
    for (int i = 0; i < 4; ++i) {
      EXPECT_EQ(ms[static_cast<std::size_t>(i)]->type, type[i]) << k << " " << i;
      EXPECT_NEAR(ms[static_cast<std::size_t>(i)]->end[0], want[i][0], kEps) << k << " " << i;
      EXPECT_NEAR(ms[static_cast<std::size_t>(i)]->end[2], want[i][1], kEps) << k << " " << i;
    }
    EXPECT_EQ(ms[1]->feed_mode, gc::FeedMode::per_rev);
    EXPECT_NEAR(ms[1]->feed, 1.5, kEps);
    EXPECT_EQ(ms[0]->column, 1u);
  }
  // G0 ends the cycle: an ordinary rapid.
  const auto g0 = of_line(r, 6);
  ASSERT_EQ(g0.size(), 1u);
  EXPECT_NEAR(g0[0]->end[0], 20, kEps);
}

TEST(ThreadingFanuc, G92TaperRIsTheRadiusAtTheStartMinusTheEndAndG78InSystemB) {
  // Taper thread: R = (radius where the thread starts) − (radius at the end point); operation 1
  // goes to the end X plus R. System B: the same cycle is G78 (G92 sets the coordinate system).
  gc::DialectOptions o;
  o.lathe = true;
  o.gcode_system = 'B';
  o.integer_input = gc::Dialect::IntegerInput::calculator;
  const gc::Dialect b = *gc::make_dialect("fanuc", o);
  for (const auto& [d, code] : {std::pair{dialect("fanuc", true), "G92"}, std::pair{b, "G78"}}) {
    pptest::Program r(d, std::string("G21\nG0 X50. Z10.\n") + code + " X40. Z-30. R-2. F2.\nX39.\n");
    ASSERT_EQ(r.sink.count(gc::Severity::error) + r.sink.count(gc::Severity::warning), 0u) << code << r.all_codes();
    const auto first = of_line(r, 3), again = of_line(r, 4);
    ASSERT_EQ(first.size(), 4u) << code;
    ASSERT_EQ(again.size(), 4u) << code;
    EXPECT_NEAR(first[0]->end[0], 20 - 2, kEps);
    EXPECT_NEAR(first[0]->end[2], 10, kEps);
    EXPECT_NEAR(first[1]->end[0], 20, kEps);
    EXPECT_NEAR(first[1]->end[2], -30, kEps);
    EXPECT_NEAR(first[1]->feed, 2, kEps);
    EXPECT_NEAR(again[0]->end[0], 19.5 - 2, kEps);  // R stays in force
    EXPECT_NEAR(again[1]->end[2], -30, kEps);       // Z too
    EXPECT_NEAR(again[3]->end[0], 25, kEps);
    EXPECT_NEAR(again[3]->end[2], 10, kEps);
  }
}

TEST(ThreadingFanuc, G92RefusedWhereItsPathIsNotKnown) {
  gc::Dialect d = dialect("fanuc", true);
  // A new cycle needs both X(U) and Z(W).
  pptest::Program noz(d, "G21\nG0 X30. Z5.\nG92 X29. F1.5\n");
  pptest::expect_diag_at(noz, codes::kThreadingUnresolved, 3, 1);
  // A G76 first block set parameter 5130 (r = 10: a chamfer of one lead) whose angle (5131) the
  // program does not give.
  pptest::Program chamfer(d, "G21\nG0 X30. Z5.\nG76 P011060 Q100 R0.05\nG92 X29. Z-20. F1.5\n");
  pptest::expect_diag_at(chamfer, codes::kThreadingParameter, 4, 1);
  EXPECT_TRUE(of_line(chamfer, 4).empty());
  // r = 00: no chamfer; the cycle is read.
  pptest::Program nochamfer(d, "G21\nG0 X30. Z5.\nG76 P010060 Q100 R0.05\nG92 X29. Z-20. F1.5\n");
  EXPECT_EQ(of_line(nochamfer, 4).size(), 4u) << nochamfer.all_codes();
  // Unknown start point.
  pptest::Program unknown(d, "G21\nG0 X30.\nG92 X29. Z-20. F1.5\n");
  pptest::expect_diag_at(unknown, codes::kUnknownPosition, 3, 1);
}

// ---------------------------------------------------------------------------------------------
// compensate: a cycle's moves are motions of its block; through a machine without errors the
// program comes out byte for byte, and the block after the cycle keeps its words (the written
// position is where the cycle ended, not where the block before it left the tool).

TEST(ThreadingCompensate, CycleBlocksThroughAMachineWithoutErrorsStayByteForByte) {
  postproc::machine::Machine m = pptest::sample_machine("lathe_xzbc_doc004.toml");  // LinuxCNC, radius mode
  m.actual = m.nominal;
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  const std::string program =
      "G18 G21 G8 G90 G54\n"
      "T1 M6\n"
      "G0 X60 Z10 B0 C0\n"
      "M3 S500\n"
      "G0 X40 Z5\n"
      "G76 P1 Z-20 I-0.5 J0.1 K0.6 Q29.5 H1 E1 L3\n"
      "G0 X50\n"  // no Z: stays at the cycle's end Z-20
      "G1 X55 F100\n"
      "M2\n";
  pptest::TempDir dir;
  const std::string path = dir.file("out.ngc");
  postproc::comp::CompensateOptions opt;
  opt.header = false;
  opt.tool_version = "test";
  gc::DiagnosticSink sink;
  {
    gc::LineReader reader{std::string_view(program)};
    postproc::io::OutputFile out(path);
    const auto r = postproc::comp::compensate(reader, "in.ngc", d, m, opt, out, sink);
    for (const auto& diag : sink.stored())
      if (diag.severity == gc::Severity::error) ADD_FAILURE() << gc::format(diag);
    ASSERT_FALSE(sink.has_errors());
    out.commit();
    EXPECT_EQ(r.changed_blocks, 0u);
  }
  EXPECT_EQ(pptest::read_file(path), program);
}

}  // namespace
