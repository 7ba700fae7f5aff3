#pragma once
/// @file
/// Serial-chain machines (3-axis, 5-axis table-table / head-head / head-table, the 4-axis lathe
/// X Z B C of document 004) with ISO 230-1 / 230-7 error parameters.
///
/// A machine is two chains from the bed: the workpiece side (bed → … → workpiece, e.g. bed → X →
/// C → workpiece on a lathe, bed → A → C → workpiece on a table-table machine) and the tool side
/// (bed → … → tool, e.g. bed → Z → B → tool). The workpiece frame is the frame of the last
/// workpiece-side body; it coincides with the machine (bed) frame when every joint is at zero.
///
/// Parameter vector (SerialModel::parameters()), in this order:
/// 1. per joint, in joint order (workpiece side bed outward, then tool side bed outward):
///    - rotary axis K about machine axis I (A ∥ X, B ∥ Y, C ∥ Z; the direction may be ±): the two
///      location errors E<J>0<K> then the two orientation errors E<rot J>0<K> for the two axes
///      J ≠ I in X, Y, Z order, then the zero-position error E<rot I>0<K>. C: EX0C EY0C EA0C EB0C
///      EC0C; A: EY0A EZ0A EB0A EC0A EA0A; B: EX0B EZ0B EA0B EC0B EB0B;
///    - linear axis K: its zero offset E<K>0<K> (EX0X, …; EU0U for a U axis);
/// 2. the squareness errors present, X the reference: EC0Y (axes X and Y present), EB0Z (X and Z),
///    EA0Z (Y and Z) — only for linear axes named exactly X, Y, Z;
/// 3. "tool.length" (error = false, nominal = SerialConfig::tool_length, mm).
/// Every error parameter has nominal 0; units mm (locations, offsets) or rad (angles).
///
/// How each error acts (machine frame = the bed frame, which is the frame of every body when all
/// joints are at zero; all rotations are exact, exp of a rotation vector, never first order):
/// - location E<J>0<K>: shifts the axis line of K by that amount along machine axis J (so
///   perpendicular to its direction): the line passes through pivot + Σ E<J>0<K>·e_J;
/// - orientation E<rot J>0<K>: tilts the direction of K by a right-handed rotation of that angle
///   about machine axis J: d = exp([E<A…>·e_J1 + E<…>·e_J2]×)·d_nominal, the line still passing
///   through the (shifted) pivot; e.g. EA0C > 0 turns C's +Z toward −Y, EB0C > 0 toward +X;
/// - zero position E<rot I>0<K>: added to the commanded angle (rad): θ = q·π/180 + EC0C, in the
///   axis's own right-handed sense about its (signed) direction;
/// - linear zero offset E<K>0<K>: added to the commanded value: the carriage moves by d·(q + EX0X);
/// - squareness: turns a linear axis's direction by an exact rotation: d_Y = exp(EC0Y·[e_Z]×)·d_Y,
///   d_Z = exp([EA0Z·e_X + EB0Z·e_Y]×)·d_Z; EC0Y > 0 turns +Y toward −X, EB0Z > 0 turns +Z toward
///   +X, EA0Z > 0 turns +Z toward −Y;
/// - error-motion table of an axis (ErrorMotionTable), looked up at the commanded joint value,
///   interpolated linearly between rows, constant beyond the first and last rows: after its
///   nominal (parameter-erroneous) motion the moving body is turned by exp([ε]×), ε = (rotation
///   errors about X, Y, Z), about a reference point c, then translated by δ = (translation
///   errors), both in the frame of the body that carries the axis (= machine frame at zero). c is
///   the carriage's image of the machine origin (d·s) for a linear axis and the (shifted) axis
///   point for a rotary one: x ↦ exp([ε]×)(M(q)·x − c) + c + δ.
///
/// Rotary axes must be nominally parallel to X, Y or Z (either sense) so that their ISO 230-7
/// names are defined; an axis named A, B or C must be parallel to X, Y or Z respectively. Other
/// directions (a 45° nutating head) are rejected with postproc::Error(usage); linear axes may have
/// any direction.
/// Position-dependent errors — the six error motions of each axis (for X: EXX positioning, EYX and
/// EZX straightness, EAX roll, EBX pitch, ECX yaw) — are tables over the axis's travel; they are
/// data, not parameters, so nominal() keeps them: use without_tables() for the ideal machine.

#include <array>
#include <string>
#include <vector>

#include "postproc/kinematics/model.hpp"

namespace postproc::kin {

/// The six error motions of one axis, sampled over its travel.
struct ErrorMotionTable {
  std::vector<double> position;  ///< joint values, strictly increasing, mm / degrees
  /// Per row: translation errors along X, Y, Z (mm) then rotation errors about X, Y, Z (rad),
  /// of the moving body, in the machine frame.
  std::vector<std::array<double, 6>> error;
  [[nodiscard]] bool empty() const { return position.empty(); }
};

/// One axis of a chain.
struct SerialAxis {
  std::string name;  ///< program letter: "X" … "W", "A" … "C"
  JointType type = JointType::linear;
  /// Motion direction (linear) or rotation axis (rotary, right-handed) at the zero position of
  /// every joint, machine frame, unit length. Rotary axes in the nominal model are parallel to
  /// X, Y or Z (A, B, C); the error parameters tilt them.
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();
  /// Rotary: a point on the rotation axis at the zero position of every joint, machine frame, mm.
  Eigen::Vector3d pivot = Eigen::Vector3d::Zero();
  double min = -std::numeric_limits<double>::infinity();  ///< travel, mm / degrees
  double max = std::numeric_limits<double>::infinity();
  ErrorMotionTable table;  ///< position-dependent errors, may be empty
};

struct SerialConfig {
  std::vector<SerialAxis> workpiece_side;  ///< bed outward to the workpiece
  std::vector<SerialAxis> tool_side;       ///< bed outward to the tool
  /// The spindle gauge point (where tool lengths are measured from) at the zero position of
  /// every joint, machine frame, mm.
  Eigen::Vector3d spindle_point = Eigen::Vector3d::Zero();
  /// The tool axis at the zero position of every joint (from tip toward spindle), unit.
  Eigen::Vector3d tool_axis = Eigen::Vector3d::UnitZ();
  /// A direction normal to tool_axis completing the tool frame (its x axis), unit.
  Eigen::Vector3d tool_x = Eigen::Vector3d::UnitX();
  double tool_length = 0;  ///< gauge point to tool tip along -tool_axis, mm
};

/// A serial-chain model. Joints are ordered workpiece side first, then tool side, each bed
/// outward; `joint_order` of the machine file maps program letters to them.
///
/// inverse(): Newton from `start` on the analytic Jacobian, then (if it fails, or ends outside
/// the travel) Newton from each orientation_candidates() seed; the converged solution nearest
/// `start` (Euclidean in mm / degrees) within the travel is kept. Conditions matched:
/// - no rotary joint (3-axis): the point only; the tool axis cannot change, residual_rad reports
///   its deviation and does not affect the status;
/// - PoseMatch::full with ≥ 6 joints: P and R; otherwise P and the tool axis O (full with fewer
///   than 6 joints falls back to point_and_axis: the spin about O is not controllable);
/// - fewer joints than conditions (the 4-axis lathe, a 4-axis mill with one rotary): the point is
///   matched exactly and the tool axis in least squares (status ok when the point is within
///   tolerance and the step has converged; residual_rad then reports the unavoidable deviation);
/// - more joints than conditions: the minimum-norm step, so the extra joints stay near `start`.
/// At a singular configuration (tool axis along the other rotary axis: A = 0 on an A/C trunnion)
/// Newton cannot start and the seeds are tried; when every solve fails, the status says why
/// (singular, no_convergence, diverged) and q holds the last iterate of the solve from `start`.
class SerialModel final : public Model {
 public:
  /// Builds the nominal model (every error parameter 0). Throws postproc::Error (usage) naming
  /// the problem when the configuration is not a valid chain.
  explicit SerialModel(SerialConfig cfg);
  [[nodiscard]] std::string kind() const override { return "serial"; }
  [[nodiscard]] Solve forward(const JointVector& q, Pose& out) const override;
  [[nodiscard]] Jacobian jacobian(const JointVector& q) const override;
  [[nodiscard]] Solve inverse(const Pose& target, const JointVector& start, JointVector& q,
                              const IkOptions& opt = {}) const override;
  [[nodiscard]] std::shared_ptr<const Model> with_values(std::vector<double> values) const override;
  [[nodiscard]] Eigen::Matrix3d machine_to_workpiece(const JointVector& q) const override;
  [[nodiscard]] const SerialConfig& config() const { return cfg_; }
  /// Joint values of the nominal chain's rotary joints that turn tool_axis into the workpiece
  /// direction `o` (closed form, two rotary joints), every branch, each rotary value taken in the
  /// turn nearest `start`; empty when the machine has not exactly two rotary joints or `o` is
  /// unreachable. Linear joints keep their `start` values. Used to seed inverse() when a program
  /// gives only a tool vector.
  [[nodiscard]] std::vector<JointVector> orientation_candidates(const Eigen::Vector3d& o, const JointVector& start) const;
  /// The same model (same parameter values) without its error-motion tables; with nominal(), the
  /// ideal machine.
  [[nodiscard]] std::shared_ptr<const SerialModel> without_tables() const;
  /// d(pose)/d(parameters) at q, 6 × parameters(): rows 0–2 the tool tip (mm per unit), rows 3–5
  /// the tool frame's rotation (rad per unit, workpiece frame, as rotation_difference), analytic:
  /// each error parameter is a small motion of one joint's link (a zero offset moves it along or
  /// about its axis, a location error conjugates its motion by a translation, an orientation error
  /// or a squareness by a rotation, a scale stretches its travel), carried to the tool through the
  /// chain like a joint's own twist; "tool.length" moves the tip along the tool axis.
  [[nodiscard]] Eigen::Matrix<double, 6, Eigen::Dynamic> identification_jacobian(const JointVector& q) const;
  /// The same, with the pose at q (bit for bit forward()'s) from the same pass along the chain.
  [[nodiscard]] Eigen::Matrix<double, 6, Eigen::Dynamic> identification_jacobian(const JointVector& q, Pose& pose) const;

 private:
  SerialModel(SerialConfig cfg, std::vector<double> values);
  SerialConfig cfg_;
  // Per-axis geometry resolved from the parameter values (src/kinematics/serial_impl.hpp).
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

}  // namespace postproc::kin
