#pragma once
/// @file
/// What `postproc check` reports about a program: counts, axes, extents, feeds.

#include <array>
#include <cstdint>
#include <limits>
#include <span>

#include "postproc/gcode/motion.hpp"

namespace postproc::gcode {

struct FeedRange {
  double min = std::numeric_limits<double>::infinity();
  double max = -std::numeric_limits<double>::infinity();
  std::uint64_t count = 0;
};

struct ProgramSummary {
  std::uint64_t blocks = 0;
  std::array<std::uint64_t, 5> motions_by_type{};  ///< indexed by MotionType
  AxisMask axes_used = 0;
  AxisVector min = AxisVector::Constant(std::numeric_limits<double>::infinity());
  AxisVector max = AxisVector::Constant(-std::numeric_limits<double>::infinity());
  std::array<FeedRange, 3> feeds{};  ///< indexed by FeedMode; mm/min, mm/rev, 1/min
  std::uint64_t machine_frame_moves = 0;

  /// Adds one motion: work-frame end points, and the quadrant points arcs pass through, enter the
  /// extents (machine-coordinate rows do not).
  void add(const Motion& m);
  [[nodiscard]] std::uint64_t motions() const;
};

}  // namespace postproc::gcode
