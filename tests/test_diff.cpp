// postproc diff (issue 7): pairing by block and by path, axis deltas, tool-tip distances.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "contour_support.hpp"
#include "postproc/compensation/diff.hpp"

namespace {

namespace comp = postproc::comp;
namespace gc = postproc::gcode;

const gc::Dialect& fanuc() {
  static const gc::Dialect d = *gc::make_dialect(pptest::mill().dialect_name, pptest::mill().dialect_options);
  return d;
}

TEST(Diff, SameStructurePairsByBlock) {
  const std::string a = "G90 G54\nG0 X0 Y0 Z10.\nG1 Z0 F500\nX10. Y5.\nX20.\n";
  const std::string b = "(corrected)\nG90 G54\nG0 X0 Y0 Z10.\nG1 Z0 F500\nX10.003 Y4.996\nX20.\n";
  gc::DiagnosticSink sink;
  const comp::DiffResult r = comp::diff(a, b, "a.nc", "b.nc", fanuc(), &pptest::mill(), sink);
  ASSERT_FALSE(sink.has_errors());
  EXPECT_TRUE(r.by_block);
  ASSERT_EQ(r.blocks.size(), 4u);
  // The last block's Y is modal: it stays at the corrected 4.996, so that block changed too.
  EXPECT_EQ(r.changed, 2u);
  EXPECT_NEAR(r.blocks[3].delta[1], -0.004, 1e-12);
  const comp::BlockDiff& d = r.blocks[2];
  EXPECT_EQ(d.line_original, 4u);
  EXPECT_EQ(d.line_corrected, 5u);
  EXPECT_NEAR(d.delta[0], 0.003, 1e-12);
  EXPECT_NEAR(d.delta[1], -0.004, 1e-12);
  EXPECT_NEAR(d.linear_mm, 0.005, 1e-12);
  // The mill's tool tip moves with X and Y one to one: the tip distance is the axis change.
  EXPECT_NEAR(d.tip_mm, 0.005, 1e-9);
  EXPECT_NEAR(d.axis_rad, 0.0, 1e-12);
  EXPECT_NEAR(r.deviation.max, 0.005, 1e-9);
  EXPECT_EQ(r.blocks[r.deviation.worst].line_original, 4u);
}

TEST(Diff, AddedPointsPairByPath) {
  // The corrected program splits the second move into four segments and shifts its end.
  const std::string a = "G90 G54\nG0 X0 Y0 Z0\nG1 X10. F500\nX20. Y10.\nX30.\n";
  const std::string b = "G90 G54\nG0 X0 Y0 Z0\nG1 X10. F500\nX12.5 Y2.5\nX15. Y5.\nX17.5 Y7.5\nX20.002 Y10.\nX30.\n";
  gc::DiagnosticSink sink;
  const comp::DiffResult r = comp::diff(a, b, "a.nc", "b.nc", fanuc(), nullptr, sink);
  ASSERT_FALSE(sink.has_errors());
  EXPECT_FALSE(r.by_block);
  EXPECT_EQ(r.motions_original, 4u);
  EXPECT_EQ(r.motions_corrected, 7u);
  ASSERT_EQ(r.blocks.size(), 4u);
  EXPECT_EQ(r.blocks[2].line_original, 4u);
  EXPECT_EQ(r.blocks[2].line_corrected, 7u);  // the last segment, not an added point
  EXPECT_NEAR(r.blocks[2].delta[0], 0.002, 1e-12);
  EXPECT_EQ(r.blocks[3].line_corrected, 8u);
  EXPECT_EQ(r.changed, 1u);
  EXPECT_EQ(r.unmatched, 0u);
  EXPECT_TRUE(std::isnan(r.blocks[2].tip_mm));  // no machine: no tool-tip figures
  EXPECT_NEAR(r.deviation.max, 0.002, 1e-12);
  // Without a machine the plotted point is the original's X, Y, Z.
  ASSERT_TRUE(r.blocks[2].point_known);
  EXPECT_EQ(r.blocks[2].point_mm, Eigen::Vector3d(20, 10, 0));
  EXPECT_EQ(comp::worst_blocks(r, 2), (std::vector<std::size_t>{2, 0}));
}

TEST(Diff, PointsUnknownUntilEveryWrittenAxisIsKnown) {
  const std::string a = "G90 G54\nG0 Z10.\nX1. Y2.\nG1 Z0 F500\n";
  gc::DiagnosticSink sink;
  const comp::DiffResult r = comp::diff(a, a, "a.nc", "a.nc", fanuc(), nullptr, sink);
  ASSERT_EQ(r.blocks.size(), 3u);
  EXPECT_FALSE(r.blocks[0].point_known);  // X and Y not yet known
  ASSERT_TRUE(r.blocks[1].point_known);
  EXPECT_EQ(r.blocks[1].point_mm, Eigen::Vector3d(1, 2, 10));
  // With the mill: the intended tool tip, the axis values less the 100 mm tool (no G43 active).
  const comp::DiffResult m = comp::diff(a, a, "a.nc", "a.nc", fanuc(), &pptest::mill(), sink);
  ASSERT_TRUE(m.with_machine);
  EXPECT_FALSE(m.blocks[0].point_known);  // X, Y unknown: no tool tip
  ASSERT_TRUE(m.blocks[2].point_known);
  EXPECT_NEAR((m.blocks[2].point_mm - Eigen::Vector3d(1, 2, -100)).norm(), 0, 1e-9);
}

TEST(Diff, IdenticalProgramsShowNoChange) {
  const std::string a = "G90 G54\nG0 X0 Y0 Z0\nG1 X10. Y3. F500\nG2 X20. Y3. R5.\n";
  gc::DiagnosticSink sink;
  const comp::DiffResult r = comp::diff(a, a, "a.nc", "a.nc", fanuc(), &pptest::mill(), sink);
  ASSERT_FALSE(sink.has_errors());
  EXPECT_EQ(r.changed, 0u);
  EXPECT_EQ(r.deviation.max, 0.0);
}

}  // namespace
