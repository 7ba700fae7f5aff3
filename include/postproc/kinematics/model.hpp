#pragma once
/// @file
/// The kinematics interface every machine model implements: an immutable model (geometry plus a
/// named parameter vector) and free functions over it — forward kinematics, inverse kinematics
/// from a starting point, Jacobian.
///
/// Frames and units:
/// - joint values q are in interface units: mm for linear joints, degrees for rotary joints;
/// - poses are in the workpiece frame, mm; the orientation R maps tool-frame vectors to the
///   workpiece frame; its third column is the tool axis O, pointing from the tool tip toward the
///   spindle (the I J K of G43.5, the A3 B3 C3 of TRAORI);
/// - parameters are in mm (lengths) or rad (angles), as each Parameter's unit says;
/// - the Jacobian's rows are dP (mm) and the small rotation dθ of the tool frame (rad, workpiece
///   frame, dR = [dθ]× R); its columns are per mm of a linear joint and per degree of a rotary one.

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace postproc::kin {

/// Most joints any model has (the hexapod's 6, a hybrid's X Y + 3 sliders, serial chains ≤ 8).
inline constexpr int kMaxJoints = 8;
/// Joint values, mm / degrees; fixed capacity, no heap.
using JointVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxJoints, 1>;
/// 6 × n Jacobian: rows dP (mm) then dθ (rad); columns per mm / per degree of each joint.
using Jacobian = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, kMaxJoints>;

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDeg = kPi / 180.0;  ///< radians per degree

enum class JointType : std::uint8_t { linear, rotary };

/// One actuated joint of the machine.
struct Joint {
  std::string name;  ///< program letter for serial axes ("X", "C"), e.g. "q1" for a slider
  JointType type = JointType::linear;
  double min = -std::numeric_limits<double>::infinity();  ///< travel limit, mm / degrees
  double max = std::numeric_limits<double>::infinity();
  [[nodiscard]] bool limited() const { return min > -std::numeric_limits<double>::infinity() || max < std::numeric_limits<double>::infinity(); }
};

/// One entry of a model's parameter vector.
struct Parameter {
  std::string name;         ///< unique within the model, e.g. "EX0C", "limb2.dl", "base3.x"
  std::string unit;         ///< "mm" or "rad"
  double nominal = 0;       ///< the value of the nominal machine (0 for deviation-type error parameters)
  bool error = true;        ///< an error parameter (false: nominal geometry, e.g. a link length)
  std::string description;  ///< one line: what it is, in which frame
};

/// Tool pose in the workpiece frame.
struct Pose {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();      ///< tool-tip point, mm
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();  ///< tool frame → workpiece frame
  [[nodiscard]] Eigen::Vector3d axis() const { return r.col(2); }  ///< tool-axis unit vector O
};

enum class Status : std::uint8_t {
  ok,
  no_convergence,  ///< iteration limit reached before the tolerance
  diverged,        ///< the iteration moved away (residual grew or left the model's domain)
  singular,        ///< the Jacobian lost rank at this configuration
  unreachable,     ///< no joint values realise the pose (e.g. a strut would need a negative length)
  out_of_limits,   ///< a solution exists but a joint is outside its travel
  outside_map,     ///< the point is outside a volumetric error map that refuses extrapolation
};
[[nodiscard]] std::string_view to_string(Status s);

/// Which part of the pose inverse kinematics must match.
enum class PoseMatch : std::uint8_t {
  point_and_axis,  ///< P and the tool axis O (5 conditions): rotation about O is free
  full,            ///< P and the whole orientation R (6 conditions)
};

struct IkOptions {
  PoseMatch match = PoseMatch::point_and_axis;
  double tolerance_mm = 1e-10;    ///< on |ΔP|
  double tolerance_rad = 1e-12;   ///< on the orientation residual
  int max_iterations = 30;
  bool check_limits = true;       ///< report out_of_limits (the values are still returned)
};

/// Outcome of an iterative solve (inverse kinematics, or a parallel model's forward kinematics).
struct Solve {
  Status status = Status::ok;
  int iterations = 0;
  double residual_mm = 0;    ///< |ΔP| at the end
  double residual_rad = 0;   ///< orientation residual at the end
  int joint = -1;            ///< out_of_limits: the first joint outside its travel
  [[nodiscard]] bool ok() const { return status == Status::ok; }
};

/// An immutable machine model. Subclasses are the serial chain, the 3-PRS hybrid head, the
/// hexapod, and decorators such as the volumetric error map. Thread-safe: every method is const
/// and keeps no mutable state.
class Model {
 public:
  virtual ~Model() = default;
  Model(const Model&) = delete;
  Model& operator=(const Model&) = delete;

  /// "serial", "prs_hybrid", "hexapod", "volumetric(serial)" …
  [[nodiscard]] virtual std::string kind() const = 0;
  [[nodiscard]] const std::vector<Joint>& joints() const { return joints_; }
  [[nodiscard]] int joint_count() const { return static_cast<int>(joints_.size()); }
  [[nodiscard]] const std::vector<Parameter>& parameters() const { return params_; }
  /// Current parameter values, in the order of parameters().
  [[nodiscard]] const std::vector<double>& values() const { return values_; }
  /// Index of a parameter by name, -1 if there is none.
  [[nodiscard]] int parameter_index(std::string_view name) const;

  /// Forward kinematics. Serial chains always succeed; parallel models solve iteratively and say
  /// how it went. `q` must have joint_count() entries.
  [[nodiscard]] virtual Solve forward(const JointVector& q, Pose& out) const = 0;
  /// Jacobian at q. The default is central differences of forward(); models override it with an
  /// analytic one.
  [[nodiscard]] virtual Jacobian jacobian(const JointVector& q) const;
  /// Inverse kinematics: the joint values nearest `start` (the previous block, or the source
  /// program's values) that realise `target`, so rotary joints keep the turn and branch of
  /// `start`. The default is a Gauss–Newton iteration on forward() and jacobian(); models with a
  /// closed form override it.
  [[nodiscard]] virtual Solve inverse(const Pose& target, const JointVector& start, JointVector& q,
                                      const IkOptions& opt = {}) const;
  /// The same model with other parameter values (same order and size as parameters()).
  [[nodiscard]] virtual std::shared_ptr<const Model> with_values(std::vector<double> values) const = 0;
  /// The nominal machine: every parameter at its nominal value.
  [[nodiscard]] std::shared_ptr<const Model> nominal() const;
  /// Rotation from the frame of the linear axes (machine frame) to the workpiece frame at q: the
  /// product of the workpiece-side rotary axes. Identity for machines whose workpiece does not
  /// turn. Used to add machine-frame errors (volumetric map) to a workpiece-frame pose.
  [[nodiscard]] virtual Eigen::Matrix3d machine_to_workpiece(const JointVector& q) const;
  /// The point at which machine-frame positioning errors are looked up (volumetric map): by
  /// default the values of the joints named X, Y, Z (0 where absent), mm.
  [[nodiscard]] virtual Eigen::Vector3d linear_position(const JointVector& q) const;

 protected:
  Model(std::vector<Joint> joints, std::vector<Parameter> params, std::vector<double> values);
  std::vector<Joint> joints_;
  std::vector<Parameter> params_;
  std::vector<double> values_;
};

using ModelPtr = std::shared_ptr<const Model>;

/// Free-function forms (Pinocchio style); they check argument sizes and throw postproc::Error
/// (internal) naming expected and actual sizes.
[[nodiscard]] Solve forward(const Model& m, const JointVector& q, Pose& out);
[[nodiscard]] Jacobian jacobian(const Model& m, const JointVector& q);
[[nodiscard]] Solve inverse(const Model& m, const Pose& target, const JointVector& start, JointVector& q,
                            const IkOptions& opt = {});
/// Central-difference Jacobian (steps 1e-6 mm / 1e-6 degree), for tests and as the default.
[[nodiscard]] Jacobian numeric_jacobian(const Model& m, const JointVector& q, double step = 1e-6);

/// Small-rotation vector θ with R_b ≈ exp([θ]×) R_a (rad, the frame of both), exact for any angle < π.
[[nodiscard]] Eigen::Vector3d rotation_difference(const Eigen::Matrix3d& r_b, const Eigen::Matrix3d& r_a);
/// The angle between two unit vectors (tool axes), rad; exact for small and large angles (atan2).
[[nodiscard]] inline double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}
/// The joint outside its travel, -1 if none (limits compared with a 1e-9 slack).
[[nodiscard]] int joint_outside_limits(const Model& m, const JointVector& q);

}  // namespace postproc::kin
