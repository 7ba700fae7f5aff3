#pragma once
/// @file
/// The 6×6 Stewart platform of document 003: a base and a moving platform joined by six
/// telescoping struts, each with a spherical/universal joint at both ends.
///
/// Frames and units (see model.hpp for the Model conventions):
/// - base frame: fixed to the machine; the frame of the base joint centres b_i (mm). It is the
///   hexapod's machine frame (machine_to_workpiece() rotates it into the workpiece frame);
/// - platform frame: fixed to the moving platform; the frame of the platform joint centres p_i,
///   the tool tip and the tool axis (mm);
/// - workpiece frame: where poses are given; its pose in the base frame is a fixed isometry
///   (identity by default), x_base = workpiece · x_workpiece.
/// - joints "q1" … "q6": the strut (drive-axis) coordinates the NC records, mm. Document 003's
///   relation is |T·p_i − b_i| = q_i + o_i, T the platform pose in the base frame and o_i the
///   strut's origin offset (the joint-to-joint distance at q_i = 0).
///
/// Parameters (42, all mm, nominal = the design value, error = true): "base1.x" … "base6.z" (the
/// 18 base joint coordinates, base frame), "platform1.x" … "platform6.z" (the 18 platform joint
/// coordinates, platform frame), "strut1.offset" … "strut6.offset" (o_i). These are exactly the
/// quantities document 003 identifies from strut coordinates recorded at known poses, so the
/// calibration estimates them directly rather than deviations from them.

#include <array>
#include <cstdint>
#include <string_view>
#include <limits>
#include <memory>
#include <vector>

#include "postproc/kinematics/model.hpp"

namespace postproc::kin {

inline constexpr int kHexapodStruts = 6;
inline constexpr int kHexapodParameters = 42;  ///< 18 base + 18 platform coordinates + 6 offsets

/// The controller's rule for the rotation about the tool axis, which a tool-tip program with a
/// tool vector (G43.5 I J K, TRAORI with vectors, M128 LN) leaves free on a six-axis machine.
enum class HexapodSpin : std::uint8_t {
  /// The tool orientation of the previous block (the joints the controller last commanded) swung
  /// by the smallest rotation onto the new axis: history-dependent.
  previous,
  /// The home orientation swung by the smallest rotation onto the new axis: a function of the
  /// axis alone, so a restart in mid-program gives the same struts.
  minimal_from_home,
};
[[nodiscard]] std::string_view to_string(HexapodSpin s);

/// Design geometry of a hexapod. Index i of every array is strut i + 1 ("q<i+1>").
struct HexapodConfig {
  std::array<Eigen::Vector3d, kHexapodStruts> base_joints{};      ///< b_i, base frame, mm
  std::array<Eigen::Vector3d, kHexapodStruts> platform_joints{};  ///< p_i, platform frame, mm
  std::array<double, kHexapodStruts> strut_offsets{};             ///< o_i, mm
  /// Strut travel, mm of q_i (not of the joint distance); unlimited by default.
  std::array<double, kHexapodStruts> strut_min{-std::numeric_limits<double>::infinity(),
                                               -std::numeric_limits<double>::infinity(),
                                               -std::numeric_limits<double>::infinity(),
                                               -std::numeric_limits<double>::infinity(),
                                               -std::numeric_limits<double>::infinity(),
                                               -std::numeric_limits<double>::infinity()};
  std::array<double, kHexapodStruts> strut_max{
      std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
      std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
      std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  Eigen::Vector3d tool_tip = Eigen::Vector3d::Zero();     ///< tool tip, platform frame, mm
  /// Tool axis (from tip toward spindle), platform frame, unit length. The tool frame is the
  /// platform frame turned by the smallest rotation taking platform Z onto this axis.
  Eigen::Vector3d tool_axis = Eigen::Vector3d::UnitZ();
  /// Pose of the workpiece frame in the base frame (x_base = workpiece · x_workpiece).
  Eigen::Isometry3d workpiece = Eigen::Isometry3d::Identity();
  /// Platform pose in the base frame where forward kinematics starts without a better guess; it
  /// also fixes the assembly mode (FK refuses iterates whose struts turn past 90° from here).
  Eigen::Isometry3d home = Eigen::Isometry3d::Identity();
  /// How inverse() with PoseMatch::point_and_axis chooses the rotation about the tool axis.
  HexapodSpin spin = HexapodSpin::previous;
};

/// A realistic design: base joints on a 400 mm circle in pairs 30° apart (centred on 0°, 120°,
/// 240°), platform joints on a 200 mm circle in pairs 30° apart (centred on 60°, 180°, 300°),
/// each strut joining neighbours of adjacent pairs; home = platform 700 mm above the base, level;
/// tool tip 150 mm below the platform (toward the base), tool axis platform +Z; offsets = the
/// home joint distances (so q = 0 at home); travel ±250 mm.
[[nodiscard]] HexapodConfig hexapod_design();

/// Options of forward kinematics (Newton on the six length equations).
struct HexapodFkOptions {
  double tolerance_mm = 1e-11;  ///< on the largest strut-length residual
  int max_iterations = 30;      ///< Newton steps
};

/// Platform pose in the base frame: x_base = r · x_platform + t (mm).
struct PlatformPose {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

/// d(strut coordinates q, mm) / d(parameters, mm) at a fixed pose: 6 × 42.
using IdentificationJacobian = Eigen::Matrix<double, kHexapodStruts, kHexapodParameters>;

class Hexapod final : public Model {
  struct Private {};  // keeps the value-taking constructor for with_values only

 public:
  /// Builds the model at the design values. Throws postproc::Error (usage) naming the problem
  /// (non-finite coordinates, bad travel, zero tool axis, singular home pose).
  explicit Hexapod(HexapodConfig cfg);
  Hexapod(Private, HexapodConfig cfg, std::vector<double> values);

  [[nodiscard]] std::string kind() const override { return "hexapod"; }
  /// Forward kinematics from the home pose; see the overload with a guess.
  [[nodiscard]] Solve forward(const JointVector& q, Pose& out) const override;
  /// Forward kinematics by Newton on |T·p_i − b_i| = q_i + o_i, the platform pose updated as a
  /// translation plus a rotation vector (base frame), starting from `guess` (a tool pose in the
  /// workpiece frame, e.g. the previous block or the commanded pose). Steps longer than 0.3 rad or
  /// a quarter of the mean strut offset are shortened (damped Newton). Status: unreachable when a
  /// q_i + o_i ≤ 0 (joint = that strut); singular when the strut Jacobian loses rank; diverged
  /// when the residual grows fourfold after the third step or a strut turns past 90° from its
  /// home direction (another assembly mode); no_convergence at the iteration limit.
  /// residual_mm is the largest strut-length residual, residual_rad the last rotation step.
  /// `out` is written only when the status is ok.
  [[nodiscard]] Solve forward(const JointVector& q, Pose& out, const Pose& guess,
                              const HexapodFkOptions& opt = {}) const;
  /// Tool-pose Jacobian (rows dP mm, dθ rad, workpiece frame; columns per mm of strut) at q:
  /// the inverse of the strut-length Jacobian, mapped to the tool tip. NaN when FK fails at q.
  [[nodiscard]] Jacobian jacobian(const JointVector& q) const override;
  /// The same Jacobian at a known tool pose (no forward kinematics).
  [[nodiscard]] Jacobian jacobian_at(const Pose& pose) const;
  /// Closed-form inverse kinematics. PoseMatch::full uses target.r. PoseMatch::point_and_axis
  /// leaves the rotation about the tool axis free and takes swing(spin_origin(start), target axis). Status: unreachable when a joint-to-joint
  /// distance is ≤ 1e-6 mm (strut direction undefined; joint = that strut); out_of_limits (values
  /// still returned) when a strut is outside its travel and opt.check_limits.
  [[nodiscard]] Solve inverse(const Pose& target, const JointVector& start, JointVector& q,
                              const IkOptions& opt = {}) const override;
  /// The whole tool pose inverse() puts the tool at for `target`: `target` itself under
  /// PoseMatch::full, else the target point and axis with the spin rule's rotation about the axis.
  /// forward() of inverse()'s struts gives it back (within its tolerance): where it is needed, no
  /// forward kinematics has to be solved for it.
  /// `origin`, when given, receives the spin rule's orientation (spin_origin_for) it swung.
  [[nodiscard]] Pose reached_pose(const Pose& target, const JointVector& start, PoseMatch match,
                                  Eigen::Matrix3d* origin = nullptr) const;
  /// The orientation the controller's spin rule (config().spin) swings onto each new tool axis:
  /// the home tool orientation, or under HexapodSpin::previous the tool orientation at `start`
  /// (forward kinematics seeded with `near`; home when it fails). Workpiece frame.
  [[nodiscard]] Eigen::Matrix3d spin_origin(const JointVector& start, const Pose& near) const;
  /// spin_origin() for a move from struts `start` to `target`: the forward kinematics of start
  /// seeded with the target point and the home orientation swung onto the target axis.
  [[nodiscard]] Eigen::Matrix3d spin_origin_for(const Pose& target, const JointVector& start) const;
  /// `origin` turned by the smallest rotation taking its axis (column z) onto `axis`.
  [[nodiscard]] static Eigen::Matrix3d swing(const Eigen::Matrix3d& origin, const Eigen::Vector3d& axis);
  /// The signed rotation about the tool axis (rad) from swing(origin, pose's axis) to pose.
  [[nodiscard]] static double spin_of(const Pose& pose, const Eigen::Matrix3d& origin);
  [[nodiscard]] std::shared_ptr<const Model> with_values(std::vector<double> values) const override;
  /// Rotation base frame → workpiece frame (constant).
  [[nodiscard]] Eigen::Matrix3d machine_to_workpiece(const JointVector& q) const override;
  /// The tool tip in the base frame at q (forward kinematics from home; zero when it fails), mm:
  /// where a volumetric map of the hexapod's work space is looked up.
  [[nodiscard]] Eigen::Vector3d linear_position(const JointVector& q) const override;

  /// d q / d(parameters) at a tool pose (workpiece frame) held fixed: row i is strut i, columns in
  /// the order of parameters(). ∂q_i/∂b_i = −n_iᵀ, ∂q_i/∂p_i = n_iᵀ R, ∂q_i/∂o_i = −1 (n_i the
  /// unit strut direction, R the platform rotation). For calibration from recorded strut values.
  [[nodiscard]] IdentificationJacobian identification_jacobian(const Pose& pose) const;

  /// Platform pose (base frame) that puts the tool at `tool` (workpiece frame), and back.
  [[nodiscard]] PlatformPose platform_pose(const Pose& tool) const;
  [[nodiscard]] Pose tool_pose(const PlatformPose& platform) const;
  /// Joint-to-joint distances |T·p_i − b_i| at a platform pose, mm.
  [[nodiscard]] Eigen::Matrix<double, 6, 1> strut_lengths(const PlatformPose& platform) const;
  [[nodiscard]] const HexapodConfig& config() const { return cfg_; }

 private:
  [[nodiscard]] Solve solve_forward(const JointVector& q, PlatformPose x, Pose& out,
                                    const HexapodFkOptions& opt) const;
  HexapodConfig cfg_;
  // Current parameter values unpacked for the hot paths (no heap, no lookups).
  Eigen::Matrix<double, 3, 6> base_;
  Eigen::Matrix<double, 3, 6> platform_;
  Eigen::Matrix<double, 6, 1> offset_;
  Eigen::Matrix<double, 3, 6> home_dir_;  // unit strut directions at home (assembly-mode check)
  Eigen::Matrix3d tool_rot_;              // tool frame → platform frame
  PlatformPose home_;
  PlatformPose workpiece_;                // workpiece frame → base frame
};

}  // namespace postproc::kin
