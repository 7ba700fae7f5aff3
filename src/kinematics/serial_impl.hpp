#pragma once
// Private to the serial model: the per-axis geometry resolved once from the parameter values, so
// forward kinematics, the Jacobian (serial.cpp) and the inverse (serial_inverse.cpp) only do the
// per-q work: one pass over the joints, a sine/cosine per rotary axis (precomputed by the caller),
// an O(1) table lookup, products of 3×3 rotations, no temporaries and no heap.
#include <array>
#include <cmath>
#include <vector>

#include "postproc/kinematics/serial.hpp"

namespace postproc::kin {

namespace serial_detail {

/// Adds s·[d]× to r: the skew part of Rodrigues' rotation about unit axis d (s = sin angle).
inline void add_skew(Eigen::Matrix3d& r, double s, const Eigen::Vector3d& d) {
  r(0, 1) -= s * d.z();
  r(1, 0) += s * d.z();
  r(0, 2) += s * d.y();
  r(2, 0) -= s * d.y();
  r(1, 2) -= s * d.x();
  r(2, 1) += s * d.x();
}
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

/// Sine and cosine of deg·π/180 + rad: the quarter turns are taken off in degrees (exactly), the
/// rest (within ±π/4 + rad) by Taylor series to degree 17 / 18 (truncation below 1e-17), so a
/// rotary joint costs a few dozen flops instead of a libm call; libm beyond ±1 rad or 1e9 degrees.
inline void sincos_deg(double deg, double rad, double& s, double& c) {
  constexpr double kDegRad = 3.14159265358979323846 / 180.0;
  if (!(std::abs(deg) < 1e9 && std::abs(rad) < 0.2)) {
    s = std::sin(deg * kDegRad + rad);
    c = std::cos(deg * kDegRad + rad);
    return;
  }
  const auto k = static_cast<long long>(deg * (1.0 / 90) + (deg < 0 ? -0.5 : 0.5));
  const double x = (deg - 90.0 * static_cast<double>(k)) * kDegRad + rad;  // deg − 90k is exact
  const double x2 = x * x;
  const double sx =
      x * (1 + x2 * (-1.0 / 6 + x2 * (1.0 / 120 + x2 * (-1.0 / 5040 + x2 * (1.0 / 362880 +
      x2 * (-1.0 / 39916800 + x2 * (1.0 / 6227020800 + x2 * (-1.0 / 1307674368000 + x2 * (1.0 / 355687428096000)))))))));
  const double cx =
      1 + x2 * (-0.5 + x2 * (1.0 / 24 + x2 * (-1.0 / 720 + x2 * (1.0 / 40320 + x2 * (-1.0 / 3628800 +
      x2 * (1.0 / 479001600 + x2 * (-1.0 / 87178291200 + x2 * (1.0 / 20922789888000 + x2 * (-1.0 / 6402373705728000)))))))));
  switch (k & 3) {
    case 0: s = sx; c = cx; break;
    case 1: s = cx; c = -sx; break;
    case 2: s = -sx; c = -cx; break;
    default: s = -cx; c = sx; break;
  }
}
}  // namespace serial_detail

struct SerialModel::Impl {
  using Rigid = serial_detail::Rigid;
  /// One row of an error-motion table with the slope of the segment it starts (per mm / degree;
  /// zero on the last row), contiguous so that a lookup touches one cache line or two.
  struct Row {
    double pos = 0;
    std::array<double, 6> val{};
    std::array<double, 6> slope{};
  };
  struct Axis {
    bool rotary = false;
    Eigen::Vector3d dir;    // actual direction (squareness / orientation errors applied), unit
    Eigen::Vector3d point;  // rotary: actual point of the axis line (pivot + location errors), mm
    double offset = 0;      // zero offset added to the commanded value: mm, or rad for rotary
    double gain = 1;        // linear: 1 + the positioning scale error (E<k><k>.scale)
    // Rotary: R(θ) = dd + cos θ·(I − dd) + sin θ·[dir]×, and the translation of the turn about
    // the line, point − R(θ)·point = (1 − cos θ)·pq − sin θ·pk.
    Eigen::Matrix3d dd = Eigen::Matrix3d::Zero();  // dir·dirᵀ
    Eigen::Vector3d pq = Eigen::Vector3d::Zero();  // point − (dir·point)·dir
    Eigen::Vector3d pk = Eigen::Vector3d::Zero();  // dir × point
    // Error-motion table (empty: none).
    std::vector<Row> rows;
    double inv_step = 0;  // 1 / row spacing when the rows are evenly spaced (the usual case), else 0
  };
  /// Sine and cosine of each rotary joint's angle (q·π/180 + offset); unused for linear joints.
  struct Trig {
    std::array<double, kMaxJoints> s{};
    std::array<double, kMaxJoints> c{};
  };
  /// One evaluation of both chains: each side's body → machine transform and, when asked, the
  /// spatial twist (w, v) of each joint in the machine frame per mm / degree (a point x of the
  /// moved body moves by w × x + v).
  struct Chain {
    Rigid side[2];  // [0] workpiece frame → machine frame; [1] last tool-side body → machine frame
    std::array<Eigen::Vector3d, kMaxJoints> w;
    std::array<Eigen::Vector3d, kMaxJoints> v;
  };

  /// Per joint, what the identification Jacobian needs from one chain evaluation.
  struct Record {
    std::array<Rigid, kMaxJoints> before;            // the side's transform before the joint (→ machine)
    std::array<Eigen::Matrix3d, kMaxJoints> lr;      // the joint's local rotation (error motion included)
    std::array<Eigen::Matrix3d, kMaxJoints> re;      // the error motion's rotation (identity without a table)
    std::array<Eigen::Vector3d, kMaxJoints> cp;      // rotary: the turn's point (axis point + table δ)
    std::array<Eigen::Vector3d, kMaxJoints> et;      // the error motion's translation: E(y) = re·y + et
    std::array<Eigen::Vector3d, kMaxJoints> lt;      // the joint's local translation (error motion included)
  };
  /// What each parameter is, for the identification Jacobian (parameter order).
  enum class Role : std::uint8_t { linear_offset, linear_scale, rotary_offset, rotary_location, rotary_tilt, squareness, tool_length };
  struct ParamRole {
    Role role = Role::tool_length;
    int joint = -1;
    Eigen::Vector3d e = Eigen::Vector3d::Zero();  // machine axis of a location, tilt or squareness
  };
  std::vector<ParamRole> roles;
  Eigen::Vector3d tool_axis = Eigen::Vector3d::UnitZ();  // normalised, for tool.length
  std::array<Eigen::Vector3d, kMaxJoints> tilt{};       // per joint: the tilt (rotary) or squareness (linear) vector

  std::vector<Axis> axes;  // joint order
  int workpiece_count = 0;  // joints [0, workpiece_count) are on the workpiece side
  int rotary_count = 0;
  Rigid tool0;  // tool frame in the last tool-side body's frame (= machine frame at zero)

  /// The sines and cosines of q's rotary joints.
  void trig(const JointVector& q, Trig& t) const;
  /// Both chains at q (sines and cosines in `t`); the twists only when Twist. `hint` (one per
  /// joint, may be null) is the table segment of the last lookup, tried first on unevenly spaced
  /// tables.
  template <bool Twist>
  void chain(const JointVector& q, const Trig& t, Chain& out, int* hint = nullptr, Record* rec = nullptr) const;
  /// Pose of the tool in the workpiece frame at q; the Jacobian too when `jac` is not null.
  /// `workpiece` receives the workpiece-side transform (workpiece frame → machine frame).
  void evaluate(const JointVector& q, Pose& out, Jacobian* jac, Rigid* workpiece = nullptr) const;
  /// Newton iteration from `start` (no limit check), see SerialModel::inverse.
  Solve newton(const Pose& target, const JointVector& start, JointVector& q, const IkOptions& opt) const;
};

}  // namespace postproc::kin
