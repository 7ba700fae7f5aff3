// ProgramSummary: counts, extents (arc bulges included, machine rows excluded) and feed ranges.
#include <gtest/gtest.h>

#include "postproc/gcode/summary.hpp"
#include "support.hpp"

namespace {
using namespace pptest;

gc::ProgramSummary summarise(const Program& p) {
  gc::ProgramSummary s;
  for (const auto& m : p.motions) s.add(m);
  return s;
}

TEST(Summary, CountsExtentsAndFeeds) {
  const Program p(dialect("fanuc"),
                  "G21 G90 G17 G0 X10 Y0 Z5\nG1 Z-1 F200\nG3 X-10 Y0 I-10 J0 F400\nG3 X10 Y0 R10\n"
                  "G53 G0 Z-300\nG0 X0 Y0 Z50\n");
  const auto s = summarise(p);
  EXPECT_EQ(s.motions(), 6u);
  EXPECT_EQ(s.motions_by_type[static_cast<int>(gc::MotionType::rapid)], 3u);
  EXPECT_EQ(s.motions_by_type[static_cast<int>(gc::MotionType::arc_ccw)], 2u);
  EXPECT_EQ(s.motions_by_type[static_cast<int>(gc::MotionType::arc_cw)], 0u);
  EXPECT_EQ(s.machine_frame_moves, 1u);
  // Two ccw half circles: the first passes (0, 10), the way back (0, -10); both bulges count.
  EXPECT_DOUBLE_EQ(s.min[0], -10);
  EXPECT_DOUBLE_EQ(s.max[0], 10);
  EXPECT_DOUBLE_EQ(s.min[1], -10);
  EXPECT_DOUBLE_EQ(s.max[1], 10);
  // Z: the G53 machine move (-300) is not in work coordinates.
  EXPECT_DOUBLE_EQ(s.min[2], -1);
  EXPECT_DOUBLE_EQ(s.max[2], 50);
  const auto& f = s.feeds[static_cast<int>(gc::FeedMode::per_minute)];
  EXPECT_EQ(f.count, 3u);  // rapids have no feed
  EXPECT_DOUBLE_EQ(f.min, 200);
  EXPECT_DOUBLE_EQ(f.max, 400);
  EXPECT_EQ(s.axes_used, gc::bit(gc::Axis::x) | gc::bit(gc::Axis::y) | gc::bit(gc::Axis::z));
}

TEST(Summary, QuarterArcWithinOneQuadrantAddsNoBulge) {
  const Program p(dialect("linuxcnc"), "G17 G0 X10 Y0\nG3 X7.0710678118654755 Y7.0710678118654755 I-10 J0 F100\n");
  const auto s = summarise(p);
  EXPECT_DOUBLE_EQ(s.max[0], 10);
  EXPECT_NEAR(s.max[1], 7.0710678118654755, 1e-12);
}

}  // namespace
