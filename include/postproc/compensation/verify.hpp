#pragma once
/// @file
/// Checks a compensated program against its original: every end point of the corrected program,
/// run through the *actual* model, must reproduce the intended pose of the original end point on
/// the *nominal* model within the output rounding (half a unit of the last decimal of every
/// written axis, carried to the tool tip through the kinematics).

#include <cstdint>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "postproc/gcode/dialect.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::comp {

struct VerifyResult {
  std::uint64_t compared = 0;      ///< end points compared
  std::uint64_t skipped = 0;       ///< motions with unknown axes or left as written
  double max_error_mm = 0;         ///< largest tool-tip distance, mm
  double max_error_rad = 0;        ///< largest tool-axis angle, rad
  double max_excess_mm = 0;        ///< largest distance beyond the point's rounding bound (≤ 0: within rounding)
  double max_bound_mm = 0;         ///< largest rounding bound met, mm
  std::uint64_t worst_line = 0;    ///< original line of max_excess_mm
  double max_error_before_mm = 0;  ///< the original program on the actual machine, for comparison
  double max_error_before_rad = 0; ///< its largest tool-axis angle, rad
};

/// One compared end point (VerifyOptions::points): where the tool tip should be, and the errors
/// the original and the corrected program leave there on the actual machine.
struct VerifyPoint {
  std::uint64_t line = 0;        ///< original line
  Eigen::Vector3d intended;      ///< intended tool tip (nominal machine, workpiece frame), mm
  double before_mm = 0;          ///< the original program on the actual machine: tool-tip distance, mm
  double before_rad = 0;         ///< and tool-axis angle, rad
  double after_mm = 0;           ///< the corrected program on the actual machine, mm
  double after_rad = 0;          ///< rad
  double bound_mm = 0;           ///< the rounding bound of the corrected point, mm
};

/// `line_map`: for each line of the corrected program, the original line it came from (as
/// compensate reports it; 0 for the header). Motions are matched by that map: the last motion
/// of the lines of an original block is compared with the original block's end point.
/// `points` (optional) receives every compared end point in program order.
VerifyResult verify(std::string_view original, std::string_view corrected, const std::vector<std::uint64_t>& line_map,
                    const gcode::Dialect& d, const machine::Machine& m, std::vector<VerifyPoint>* points = nullptr);

}  // namespace postproc::comp
