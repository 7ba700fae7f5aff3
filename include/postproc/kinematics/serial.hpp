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
/// Error parameters (all nominal 0; mm or rad), named as ISO 230-1 / 230-7 name them:
/// - per rotary axis K with nominal direction along the machine axis I ∈ {X, Y, Z} (A ∥ X, B ∥ Y,
///   C ∥ Z): the location errors of its axis line, E<J>0<K> for the two directions J ≠ I
///   (e.g. EX0C, EY0C), its orientation errors E<R>0<K> for the two rotations about J ≠ I (EA0C,
///   EB0C), and its zero-position error E<I-rotation>0<K> (EC0C);
/// - per linear axis K: its zero-point (positioning) offset E<K>0<K> (EX0X, …);
/// - squareness of the linear axes, X the reference: EC0Y (Y to X, about Z), EB0Z (Z to X, about
///   Y), EA0Z (Z to Y, about X) — present when the machine has both axes;
/// - the tool: "tool.length" (not an error parameter; nominal = the configured length, mm).
/// Position-dependent errors — the six error motions of each axis (for X: EXX positioning, EYX and
/// EZX straightness, EAX roll, EBX pitch, ECX yaw) — are tables over the axis's travel,
/// interpolated linearly between rows, constant beyond the ends; they are data, not parameters.

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

 private:
  SerialModel(SerialConfig cfg, std::vector<double> values);
  SerialConfig cfg_;
  // implementation data (precomputed parameter indices, per-axis transforms) is the implementer's
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

}  // namespace postproc::kin
