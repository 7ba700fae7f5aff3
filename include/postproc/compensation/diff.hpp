#pragma once
/// @file
/// `postproc diff ORIGINAL CORRECTED` (issue 7): what a correction did, block by block.
///
/// Alignment: the single motion of every block of each program (rapids included) in program
/// order. When both programs have as many motions, they pair up in order (by block: the structure
/// was kept). Otherwise (blocks were added, e.g. subdivided moves or linearised arcs) every
/// original motion pairs with the corrected motion whose end point is nearest to its own among the
/// ones that follow the previous pair (by path), so added intermediate points are skipped.
///
/// Per pair: the axis deltas (corrected − original, mm / degrees, work coordinates); with a machine
/// file also the distance between the two intended tool tips and the angle between the two
/// intended tool axes in the workpiece frame (each command through the controller's nominal map,
/// machine/program_map.hpp). The deviation summarised is that tool-tip distance with a
/// machine, else the length of the linear-axis delta.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "postproc/contour/reference.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::comp {

struct BlockDiff {
  std::uint64_t line_original = 0;
  std::uint64_t line_corrected = 0;
  gcode::AxisVector delta = gcode::AxisVector::Zero();  ///< corrected − original, mm / degrees
  gcode::AxisMask axes = 0;          ///< axes known in both (compared)
  double linear_mm = 0;              ///< |delta| over the linear axes, mm
  double rotary_deg = 0;             ///< largest |delta| of a rotary axis, degrees
  double tip_mm = std::numeric_limits<double>::quiet_NaN();     ///< with a machine: tool-tip distance, mm
  double axis_rad = std::numeric_limits<double>::quiet_NaN();   ///< with a machine: tool-axis angle, rad
  double deviation_mm = 0;           ///< what the summary counts: tip_mm with a machine, else linear_mm
  /// Where the pair is, for plotting, mm: with a machine the original's intended tool tip in the
  /// workpiece frame; without, the original's X, Y, Z axis values (work coordinates; an axis the
  /// program never writes counts as 0).
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();
  bool point_known = false;          ///< false: point_mm is not known (no tool tip, or an axis not yet known)
};

struct DiffResult {
  std::vector<BlockDiff> blocks;
  std::uint64_t motions_original = 0;
  std::uint64_t motions_corrected = 0;
  bool by_block = true;              ///< false: aligned by path
  bool with_machine = false;         ///< tool-tip figures (a machine was given)
  std::uint64_t changed = 0;         ///< pairs with any axis delta above 1e-9 (mm / deg)
  std::uint64_t unmatched = 0;       ///< original motions without a corrected partner
  contour::Summary deviation;        ///< over `blocks`, mm
  contour::Summary angle;            ///< with a machine, rad
};

/// Compares two programs of the same dialect. `m` (optional) gives the machine for tool-tip
/// figures. Diagnostics of either program go to `sink` under its file name; the caller decides
/// whether errors stop it. A program with parameters, subprograms or control flow is resolved
/// first (with `resolve`; gcode/resolve.hpp): its executed motions are compared in execution
/// order and reported at their source lines.
[[nodiscard]] DiffResult diff(std::string_view original, std::string_view corrected, std::string_view file_original,
                              std::string_view file_corrected, const gcode::Dialect& d, const machine::Machine* m,
                              gcode::DiagnosticSink& sink, const gcode::ResolveOptions& resolve = {});

/// Indices into r.blocks of the `n` largest deviations, largest first (ties: earlier pair first).
[[nodiscard]] std::vector<std::size_t> worst_blocks(const DiffResult& r, std::size_t n);

}  // namespace postproc::comp
