#pragma once
/// @file
/// How a controller turns a block's command into joint values, and the geometric remap that
/// makes the real machine do what the nominal one would have done. Below every compensation
/// stage (geometric remap, contour) and the checks that compare programs.
///
/// Let C(c) be the controller's map from a command c (program coordinates) to joint values:
/// - axis programs: q = c + work offset (+ the tool length on Z while G43 is active);
/// - tool-tip programs (TCP: G43.4, G43.5, TRAORI, M128; parallel machines): q = IK_nominal(c).
/// The intended pose is I(c) = FK_nominal(C(c)); the real machine reaches R(c) = FK_actual(C(c)).
/// The corrected command c' solves R(c') = I(c):
/// - axis programs: c' = IK_actual(FK_nominal(q)) − offsets;
/// - tool-tip programs: c' = FK_nominal(IK_actual(I(c))) written back in the program's form (tool
///   tip + rotary axis values, + tool vector, or + virtual angles), because the controller applies
///   its nominal model to c' and so commands exactly the joints IK_actual found.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>

#include "postproc/gcode/motion.hpp"
#include "postproc/kinematics/model.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::kin {
class Hexapod;
}  // namespace postproc::kin

namespace postproc::machine {

/// What a block's axis words mean.
enum class Form : std::uint8_t {
  axes,        ///< machine axis positions (TCP off)
  tcp_rotary,  ///< tool tip + the machine's rotary axis values (G43.4, TRAORI with A/B/C, M128)
  tcp_vector,  ///< tool tip + tool vector (G43.5 I J K, TRAORI A3 B3 C3, parallel machines "vector")
  tcp_virtual, ///< tool tip + virtual angles A B (parallel machines "virtual-ab")
  turning,     ///< axis positions while the workpiece spindle turns ([machine] turning_spindle, M3 / M4):
               ///< the tool tip's radius and Z are what the program means, the spindle axis is no position
};
[[nodiscard]] std::string_view to_string(Form f);

/// A command in program coordinates: axis values (mm / degrees, work coordinates as the
/// interpreter resolved them) and, for vector forms, the tool vector (workpiece frame, unit).
struct Command {
  gcode::AxisVector c = gcode::AxisVector::Zero();
  Eigen::Vector3d vector = Eigen::Vector3d::UnitZ();
};

/// The controller's map for one modal context (form, work offset, tool length).
class ProgramMap {
 public:
  /// `offset`: the work offset (+ G52/G92 shifts) of the block, mm / degrees per program axis;
  /// `tool_length`: mm; `length_on_z`: G43 adds the tool length to the Z joint (axis programs).
  ProgramMap(const machine::Machine& m, kin::ModelPtr nominal, kin::ModelPtr actual, Form form,
             const gcode::AxisVector& offset, bool length_on_z, double tool_length);

  [[nodiscard]] Form form() const { return form_; }
  /// A new block: what the map keeps for the remaps of one block is forgotten (hexapods: the spin
  /// rule's orientation of the block's start struts), so that each block's results depend on that
  /// block alone (the parallel run, compensate_parallel.cpp, relies on it).
  void new_block() const { origin_known_ = false; }
  /// C(c): the joints the controller commands; `start` picks the branch / turn for tool-tip forms.
  [[nodiscard]] kin::Solve joints(const Command& cmd, const kin::JointVector& start, kin::JointVector& q) const;
  /// Why joints() failed, in the user's terms: for a tool axis no solution of which lies within
  /// the rotary axes' travel (ik_branch "nearest-in-travel") the joint and its travel; otherwise
  /// the solver's status.
  [[nodiscard]] std::string explain(const kin::Solve& s) const;
  /// The inverse of C on the nominal model: the command whose controller joints are q.
  [[nodiscard]] kin::Solve command(const kin::JointVector& q, const Command& like, Command& out) const;
  /// The geometric remap of one command: corrected command, the actual joints it commands.
  [[nodiscard]] kin::Solve correct(const Command& cmd, const kin::JointVector& start, Command& out,
                                   kin::JointVector& q_actual) const;
  /// Poses I(c) (nominal) and R(c) (actual) of a command.
  [[nodiscard]] kin::Solve intended(const Command& cmd, const kin::JointVector& start, kin::Pose& p,
                                    kin::JointVector& q) const;
  [[nodiscard]] kin::Solve real(const Command& cmd, const kin::JointVector& start, kin::Pose& p,
                                kin::JointVector& q) const;
  /// Forward kinematics of the actual model at q, a pose known to be near `near` (the hexapod's
  /// iterative solve starts there, from home when that fails; other models ignore it).
  [[nodiscard]] kin::Solve actual_forward(const kin::JointVector& q, const kin::Pose& near, kin::Pose& p) const;
  [[nodiscard]] const kin::Model& nominal() const { return *nominal_; }
  [[nodiscard]] const kin::Model& actual() const { return *actual_; }
  /// Program axis of joint j (-1 for joints that are not program axes, e.g. hexapod struts).
  [[nodiscard]] int axis_of_joint(int j) const { return axis_of_joint_[static_cast<std::size_t>(j)]; }
  /// The intended pose and nominal joints of the last correct() call.
  [[nodiscard]] const kin::Pose& last_intended() const { return last_goal_; }
  /// last_intended() as the part sees it (as_cut on the nominal machine): computed once per block.
  [[nodiscard]] const kin::Pose& last_intended_cut() const {
    return form_ == Form::turning ? last_goal_cut_ : last_goal_;
  }
  [[nodiscard]] const kin::JointVector& last_nominal_joints() const { return last_q_nom_; }
  /// The tool-axis angle (rad) the last correct() left on the real machine because it took the
  /// bounded solve (kinematics/bounded_inverse.hpp: near a singular pose, or a machine with fewer
  /// joints than tool tip + tool axis); 0 when the exact inverse matched the tool axis.
  [[nodiscard]] double last_bounded_residual_rad() const { return last_bounded_residual_rad_; }
  /// A pose as the part sees it: for turning moves the tip as (radius, 0, axial place) about the
  /// real spindle axis of `model` at joints q (the circle the tip traces as the spindle turns) and
  /// the orientation in that cylindrical frame (radial, tangential, axial) — the spinning part
  /// cannot tell apart poses that differ by a turn about its axis; other forms: p itself.
  /// `p` is model's forward kinematics at q. Compare poses through it.
  [[nodiscard]] kin::Pose as_cut(const kin::Model& model, const kin::JointVector& q, const kin::Pose& p) const;

 private:
  [[nodiscard]] kin::Pose target_of(const Command& cmd) const;
  /// command() with the nominal model's iterative forward kinematics (hexapod) started at `near`.
  [[nodiscard]] kin::Solve command_near(const kin::JointVector& q, const Command& like, Command& out,
                                        const kin::Pose* near) const;
  /// Turning: the linear joints of q (the rest held) so that the real tool tip has the radius and
  /// axial place of `want` (the intended pose as_cut; Gauss–Newton, least squares where the radius
  /// is below what the machine reaches).
  [[nodiscard]] kin::Solve solve_turning(const kin::Pose& want, kin::JointVector& q) const;
  /// The hexapod's correction of a tool-vector block: struts q that put the real tool tip and
  /// axis at `goal` and that the controller's own spin rule (from `start`, its previous struts)
  /// reproduces from the written block.
  [[nodiscard]] kin::Solve hexapod_spin_consistent(const kin::Hexapod& nominal, const kin::Pose& goal,
                                                   const kin::JointVector& start, const kin::JointVector& q_nom,
                                                   kin::JointVector& q) const;
  const machine::Machine* m_;
  kin::ModelPtr nominal_, actual_;
  Form form_;
  gcode::AxisVector offset_;
  double length_z_ = 0;  ///< added to the Z joint
  int spindle_joint_ = -1;  ///< turning: the joint of the workpiece spindle (held at 0)
  mutable double last_bounded_residual_rad_ = 0;
  /// Hexapods: the models as such, and the whole pose the last joints() solved the nominal struts
  /// for (the spin rule applied): the intended pose without forward kinematics, and where the
  /// actual model's forward kinematics starts.
  const kin::Hexapod* hex_nominal_ = nullptr;
  const kin::Hexapod* hex_actual_ = nullptr;
  mutable kin::Pose last_reached_;
  mutable Eigen::Matrix3d last_origin_ = Eigen::Matrix3d::Identity();  ///< the spin rule's orientation it swung
  mutable bool last_reached_valid_ = false;
  /// The spin rule's orientation for struts origin_start_ (valid while origin_known_): every
  /// remap of one block starts from the same struts (new_block() forgets it).
  mutable kin::JointVector origin_start_;
  mutable Eigen::Matrix3d origin_ = Eigen::Matrix3d::Identity();
  mutable bool origin_known_ = false;
  mutable kin::Pose last_goal_;
  mutable kin::Pose last_goal_cut_;
  mutable kin::JointVector last_q_nom_;
  std::array<int, kin::kMaxJoints> axis_of_joint_{};
  std::array<int, gcode::kAxisCount> joint_of_axis_{};
};

/// The form of a motion's axis words on machine `m` (TCP mode, frame, machine file settings).
[[nodiscard]] Form form_of(const machine::Machine& m, const gcode::Motion& mo);
/// The offset from the program's coordinates to the workpiece frame for a motion: the work
/// offset (nullopt when the machine file does not give it) + G52/TRANS + G92 shifts; zero in
/// machine coordinates (G53); nullopt too when a G92 shift is not known (Motion::position_offset_unknown).
[[nodiscard]] std::optional<gcode::AxisVector> program_offset(const machine::Machine& m, const gcode::Motion& mo);
/// Why program_offset() has no answer for `mo`: the refusal's text, naming what to do.
[[nodiscard]] std::string program_offset_refusal(const machine::Machine& m, const gcode::Motion& mo);

/// Newton on the linear joints of q only, so that the tool tip reaches `target` (mm, workpiece
/// frame); the rotary joints keep their values.
[[nodiscard]] kin::Solve solve_linear(const kin::Model& model, const Eigen::Vector3d& target, kin::JointVector& q);

/// Virtual angles (degrees) ↔ tool axis: O = Rx(A)·Ry(B)·ẑ = (sin B, −sin A cos B, cos A cos B).
[[nodiscard]] Eigen::Vector3d virtual_ab_axis(double a_deg, double b_deg);
[[nodiscard]] Eigen::Vector2d virtual_ab_angles(const Eigen::Vector3d& o);

/// The program axes whose words a block of form `f` carries on machine `m`.
[[nodiscard]] gcode::AxisMask written_axes(const machine::Machine& m, Form f);

/// Nominal and actual models with the tool length of the block (serial models carry it as the
/// parameter "tool.length"; others ignore it). Cached per length.
///
/// [errors] "tool.length" (docs/machine-file.md: the calibrated length of the tool of [tool]
/// length, as `calibrate` writes it) is the actual model's tool length for that tool, exactly as
/// `calibrate simulate` uses m.actual; its deviation from [tool] length is known for that tool
/// only, so a block with another tool length is refused (length_error_known, PP-E621).
class ToolLengthModels {
 public:
  explicit ToolLengthModels(const machine::Machine& m);
  /// Nominal model with `mm`; actual model with `mm` plus the calibrated deviation (0 without
  /// [errors] "tool.length").
  const std::pair<kin::ModelPtr, kin::ModelPtr>& with_tool_length(double mm);
  /// False when the machine file calibrates the tool length ([errors] "tool.length") and `mm`
  /// is not the length of that tool ([tool] length).
  [[nodiscard]] bool length_error_known(double mm) const {
    return deviation_ == 0 || std::abs(mm - m_.tool_length) <= 1e-9;
  }
  /// The message for a block whose tool length is not that tool's (PP-E621).
  [[nodiscard]] std::string unknown_length_error(double mm, std::uint32_t h) const;

 private:
  const machine::Machine& m_;
  double deviation_ = 0;  ///< actual − nominal "tool.length" of the machine file, mm
  std::map<double, std::pair<kin::ModelPtr, kin::ModelPtr>> cache_;
};

/// The diagnostic code of unknown_length_error (compensate, contour paths).
inline constexpr std::string_view kToolLengthError = "PP-E621";

/// The controller map of a motion's context (form, work offset + shifts, tool length); nullopt
/// when the machine file lacks the work offset or the tool length. For checks and comparisons;
/// compensate itself reports what is missing.
[[nodiscard]] std::optional<ProgramMap> map_of(const machine::Machine& m, ToolLengthModels& models,
                                               const gcode::Motion& mo);

/// The tool vector is modal under TCP (G43.5 / TRAORI blocks without I J K / A3 B3 C3 keep it;
/// tool-tip machines always): fills it into motions that do not program it, forgets it when TCP
/// ends.
class ModalToolVector {
 public:
  explicit ModalToolVector(const machine::Machine& m) : m_(&m) {}
  [[nodiscard]] gcode::Motion apply(const gcode::Motion& m) {
    gcode::Motion c = m;
    const bool tip = m.tcp != gcode::TcpMode::off || m_->coordinates == machine::ProgramCoordinates::tool_tip;
    if (m.tool_vector_known) {
      vector_ = m.tool_vector;
      known_ = true;
    } else if (known_ && tip) {
      c.tool_vector = vector_;
      c.tool_vector_known = true;
    }
    if (!tip) known_ = false;
    return c;
  }
  [[nodiscard]] bool operator==(const ModalToolVector& o) const {
    return m_ == o.m_ && vector_ == o.vector_ && known_ == o.known_;
  }

 private:
  const machine::Machine* m_;
  Eigen::Vector3d vector_ = Eigen::Vector3d::UnitZ();
  bool known_ = false;
};

}  // namespace postproc::machine
