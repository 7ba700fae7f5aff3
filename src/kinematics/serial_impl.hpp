#pragma once
// Private to the serial model: the per-axis geometry resolved once from the parameter values, so
// forward kinematics, the Jacobian (serial.cpp) and the inverse (serial_inverse.cpp) only do the
// per-q work: a sine/cosine per rotary axis, a table lookup, products of 3×3 rotations.
#include <array>
#include <vector>

#include "postproc/kinematics/serial.hpp"

namespace postproc::kin {

namespace serial_detail {
/// x ↦ r·x + t.
struct Rigid {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  [[nodiscard]] Rigid operator*(const Rigid& b) const { return {r * b.r, r * b.t + t}; }
};

/// exp([e]×): the exact rotation of rotation vector e (rad); `jl` (if not null) receives the left
/// Jacobian, so that d exp([e]×)·exp([e]×)ᵀ = [jl·de]×.
Eigen::Matrix3d rotation_exp(const Eigen::Vector3d& e, Eigen::Matrix3d* jl = nullptr);
/// Rotation by angle a (rad) about unit axis d, right-handed.
Eigen::Matrix3d rotation_about(const Eigen::Vector3d& d, double a);
}  // namespace serial_detail

struct SerialModel::Impl {
  using Rigid = serial_detail::Rigid;
  struct Axis {
    bool rotary = false;
    Eigen::Vector3d dir;    // actual direction (squareness / orientation errors applied), unit
    Eigen::Vector3d point;  // rotary: actual point of the axis line (pivot + location errors), mm
    double offset = 0;      // zero offset added to the commanded value: mm, or rad for rotary
    // Error-motion table (empty: none): rows and the slope of each segment, per mm / degree.
    std::vector<double> pos;
    std::vector<std::array<double, 6>> val;
    std::vector<std::array<double, 6>> slope;
    double inv_step = 0;  // 1 / row spacing when the rows are evenly spaced (the usual case), else 0
  };
  /// One joint's motion in its parent's frame at q, with its spatial twist (w, v) per mm / degree
  /// in that frame (a point x of the body moves by w × x + v).
  struct Local {
    Rigid x;
    Eigen::Vector3d w;
    Eigen::Vector3d v;
    bool turns = false;  // x.r is not the identity
  };

  std::vector<Axis> axes;  // joint order
  int workpiece_count = 0;  // joints [0, workpiece_count) are on the workpiece side
  int rotary_count = 0;
  Rigid tool0;  // tool frame in the last tool-side body's frame (= machine frame at zero)

  /// The twist (w, v) only when `twist`.
  [[nodiscard]] Local local(int j, double q, bool twist) const;
  /// Pose of the tool in the workpiece frame at q; the Jacobian too when `jac` is not null.
  /// `workpiece` receives the workpiece-side transform (workpiece frame → machine frame).
  void evaluate(const JointVector& q, Pose& out, Jacobian* jac, Rigid* workpiece = nullptr) const;
  /// Newton iteration from `start` (no limit check), see SerialModel::inverse.
  Solve newton(const Pose& target, const JointVector& start, JointVector& q, const IkOptions& opt) const;
};

}  // namespace postproc::kin
