#pragma once
/// @file
/// Uncertainty to the cut: a 95 % bound of the tool-tip and tool-axis error that remains at every
/// motion of a compensated program, from the covariance the calibration left in the machine file
/// ([uncertainty], written by `postproc calibrate`) and the output rounding.
///
/// Per motion of the written program, at the joints q the controller commands for it (the
/// controller's map, as `verify` reads programs back):
/// - J(q): the derivatives of the actual model's tool pose (tip mm, orientation rad) by the
///   identified parameters (serial chains: SerialModel::identification_jacobian; other models:
///   central differences; the tool length of the block);
/// - the pose error e = J·δθ with δθ ~ N(0, Σ): Σ_tip = J_p Σ J_pᵀ, Σ_axis = the part of J_r Σ J_rᵀ
///   across the tool axis (a turn about the tool axis does not move it);
/// - bound = k·√λ_max(Σ) + the rounding bound (half a unit of each written word, carried to the
///   tool through the kinematics), with k = √χ²_p(confidence), p the identified parameters.
///   k is the simultaneous (Scheffé) factor: all blocks share the one calibration error δθ, so a
///   per-block factor (√χ²₃ = 2.8 at 95 %) would leave whole stretches of a part uncovered
///   whenever the calibration happens to be off in their direction; with √χ²_p every block is
///   covered together with the stated confidence.
/// The bound covers the calibration's statistical error and the rounding, not the following
/// error (contour modes) or errors outside the model (a parameter that was not identified).

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/gcode/dialect.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::comp {

struct BoundOptions {
  double confidence = 0.95;
};

struct BlockBound {
  std::uint64_t line = 0;       ///< line of the written program
  double tip_mm = 0;            ///< bound of the tool-tip error, mm
  double axis_rad = 0;          ///< bound of the tool-axis angle, rad (0 for 3-axis forms)
  double rounding_mm = 0;       ///< the rounding's part of tip_mm
  bool outside_region = false;  ///< a joint outside the range the calibration was measured in
  int outside_joint = -1;       ///< the first such joint
  kin::JointVector joints;      ///< the joints the controller commands for the motion (mm / deg)
  double tool_length = 0;       ///< mm, of the block
};

struct BoundsResult {
  std::vector<BlockBound> blocks;  ///< in program order
  int parameters = 0;              ///< p
  double k = 0;                    ///< √χ²_p(confidence)
  double max_tip_mm = 0, max_axis_rad = 0;
  std::uint64_t outside_region = 0;  ///< blocks outside the calibrated region
  std::uint64_t skipped = 0;         ///< motions with unknown positions or no controller map
};

/// √ of the χ² quantile with `dof` degrees of freedom at probability `confidence` (Wilson–Hilferty,
/// within 0.3 % for dof ≥ 1 at 0.95).
[[nodiscard]] double chi_quantile_root(int dof, double confidence);

/// The bounds of every motion of `written` (a compensated program) on machine `m`, whose
/// [uncertainty] it needs. Throws postproc::Error (usage) when the machine file has none.
[[nodiscard]] BoundsResult residual_bounds(std::string_view written, const gcode::Dialect& d, const machine::Machine& m,
                                           const BoundOptions& options = {});

/// "line,bound_tip_mm,bound_axis_rad" and one row per bounded motion, full precision.
[[nodiscard]] std::string bounds_csv(const BoundsResult& r);

}  // namespace postproc::comp
