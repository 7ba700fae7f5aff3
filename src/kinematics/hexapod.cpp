// The 6×6 Stewart platform of document 003: closed-form inverse kinematics, Newton forward
// kinematics, the tool-pose Jacobian and the identification Jacobian of the 42 joint/offset
// parameters.
#include "postproc/kinematics/hexapod.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>
#include <Eigen/SVD>
#include <fmt/format.h>

#include "postproc/error.hpp"

namespace postproc::kin {

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;
using StrutMatrix = Eigen::Matrix<double, 3, kHexapodStruts>;

constexpr int kBaseFirst = 0;
constexpr int kPlatformFirst = 18;
constexpr int kOffsetFirst = 36;
// Below this joint-to-joint distance the strut direction (and so the Jacobian) is undefined.
constexpr double kMinStrutLength = 1e-6;
constexpr double kMaxRotationStep = 0.3;  // rad

Eigen::Matrix3d so3_exp(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (!(a > 0)) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Strut vectors d_i = T·p_i − b_i (base frame) of a platform pose.
StrutMatrix strut_vectors(const PlatformPose& x, const StrutMatrix& base, const StrutMatrix& platform) {
  return (x.r * platform).colwise() + x.t - base;
}

// Strut Jacobian A: dl = A [dt; dφ] with dt the platform translation and dφ its small rotation,
// both base frame: dl_i = n_i·(dt + dφ × R p_i) = n_iᵀ dt + (R p_i × n_i)ᵀ dφ.
Matrix6d strut_jacobian(const StrutMatrix& d, const Vector6d& len, const PlatformPose& x,
                        const StrutMatrix& platform) {
  Matrix6d a;
  for (int i = 0; i < kHexapodStruts; ++i) {
    const Eigen::Vector3d n = d.col(i) / len[i];
    const Eigen::Vector3d rp = x.r * platform.col(i);
    a.block<1, 3>(i, 0) = n.transpose();
    a.block<1, 3>(i, 3) = rp.cross(n).transpose();
  }
  return a;
}

void check_finite(const Eigen::Vector3d& v, const std::string& what) {
  if (!v.allFinite()) throw Error(ExitCode::usage, fmt::format("hexapod: {} is not finite", what));
}

HexapodConfig validated(const HexapodConfig& cfg) {
  for (int i = 0; i < kHexapodStruts; ++i) {
    const auto k = static_cast<std::size_t>(i);
    check_finite(cfg.base_joints[k], fmt::format("base joint {}", i + 1));
    check_finite(cfg.platform_joints[k], fmt::format("platform joint {}", i + 1));
    if (!std::isfinite(cfg.strut_offsets[k]))
      throw Error(ExitCode::usage, fmt::format("hexapod: offset of strut {} is not finite", i + 1));
    if (std::isnan(cfg.strut_min[k]) || std::isnan(cfg.strut_max[k]) || !(cfg.strut_min[k] < cfg.strut_max[k]))
      throw Error(ExitCode::usage, fmt::format("hexapod: travel of strut {} is [{}, {}] mm (min must be below max)",
                                               i + 1, cfg.strut_min[k], cfg.strut_max[k]));
  }
  check_finite(cfg.tool_tip, "the tool tip");
  check_finite(cfg.tool_axis, "the tool axis");
  if (!(cfg.tool_axis.norm() > 1e-12)) throw Error(ExitCode::usage, "hexapod: the tool axis is a zero vector");
  if (!cfg.workpiece.matrix().allFinite() || !cfg.home.matrix().allFinite())
    throw Error(ExitCode::usage, "hexapod: the workpiece or home pose is not finite");
  return cfg;
}

std::vector<Joint> make_joints(const HexapodConfig& cfg) {
  std::vector<Joint> j;
  for (int i = 0; i < kHexapodStruts; ++i) {
    const auto k = static_cast<std::size_t>(i);
    j.push_back(Joint{fmt::format("q{}", i + 1), JointType::linear, cfg.strut_min[k], cfg.strut_max[k]});
  }
  return j;
}

std::vector<Parameter> make_parameters() {
  std::vector<Parameter> p;
  p.reserve(kHexapodParameters);
  constexpr const char* kAxis[3] = {"x", "y", "z"};
  for (int i = 1; i <= kHexapodStruts; ++i)
    for (const char* a : kAxis)
      p.push_back(Parameter{fmt::format("base{}.{}", i, a), "mm", 0, true,
                            fmt::format("base joint {} centre, {} coordinate, base frame", i, a)});
  for (int i = 1; i <= kHexapodStruts; ++i)
    for (const char* a : kAxis)
      p.push_back(Parameter{fmt::format("platform{}.{}", i, a), "mm", 0, true,
                            fmt::format("platform joint {} centre, {} coordinate, platform frame", i, a)});
  for (int i = 1; i <= kHexapodStruts; ++i)
    p.push_back(Parameter{fmt::format("strut{}.offset", i), "mm", 0, true,
                          fmt::format("strut {} origin offset: joint distance minus q{}", i, i)});
  return p;
}

std::vector<double> design_values(const HexapodConfig& cfg) {
  std::vector<double> v(kHexapodParameters);
  for (std::size_t i = 0; i < kHexapodStruts; ++i)
    for (std::size_t a = 0; a < 3; ++a) {
      v[kBaseFirst + 3 * i + a] = cfg.base_joints[i][static_cast<Eigen::Index>(a)];
      v[kPlatformFirst + 3 * i + a] = cfg.platform_joints[i][static_cast<Eigen::Index>(a)];
    }
  for (std::size_t i = 0; i < kHexapodStruts; ++i) v[kOffsetFirst + i] = cfg.strut_offsets[i];
  return v;
}

std::vector<Parameter> parameters_with_nominal(const HexapodConfig& cfg) {
  std::vector<Parameter> p = make_parameters();
  const std::vector<double> v = design_values(cfg);
  for (std::size_t i = 0; i < p.size(); ++i) p[i].nominal = v[i];
  return p;
}

}  // namespace

HexapodConfig hexapod_design() {
  HexapodConfig c;
  // Pairs 30° apart; strut i joins base joint i to the nearest platform joint of the next pair,
  // the usual 6-6 layout that keeps the strut Jacobian well conditioned in the work space.
  constexpr double kBaseDeg[6] = {15, 105, 135, 225, 255, 345};
  constexpr double kPlatformDeg[6] = {45, 75, 165, 195, 285, 315};
  constexpr double kBaseRadius = 400;
  constexpr double kPlatformRadius = 200;
  constexpr double kHomeHeight = 700;
  c.home = Eigen::Isometry3d::Identity();
  c.home.translation() = Eigen::Vector3d(0, 0, kHomeHeight);
  for (std::size_t i = 0; i < 6; ++i) {
    const double b = kBaseDeg[i] * kDeg;
    const double p = kPlatformDeg[i] * kDeg;
    c.base_joints[i] = Eigen::Vector3d(kBaseRadius * std::cos(b), kBaseRadius * std::sin(b), 0);
    c.platform_joints[i] = Eigen::Vector3d(kPlatformRadius * std::cos(p), kPlatformRadius * std::sin(p), 0);
    c.strut_offsets[i] = (c.home * c.platform_joints[i] - c.base_joints[i]).norm();
    c.strut_min[i] = -250;
    c.strut_max[i] = 250;
  }
  c.tool_tip = Eigen::Vector3d(0, 0, -150);
  c.tool_axis = Eigen::Vector3d::UnitZ();
  return c;
}

Hexapod::Hexapod(HexapodConfig cfg) : Hexapod(Private{}, validated(cfg), design_values(cfg)) {
  // A design whose home pose is singular cannot be driven; say so at construction.
  const StrutMatrix d = strut_vectors(home_, base_, platform_);
  const Vector6d len = d.colwise().norm().transpose();
  for (int i = 0; i < kHexapodStruts; ++i)
    if (!(len[i] > kMinStrutLength))
      throw Error(ExitCode::usage, fmt::format("hexapod: strut {} has zero length at the home pose", i + 1));
  const Eigen::JacobiSVD<Matrix6d> svd(strut_jacobian(d, len, home_, platform_));
  const auto& sv = svd.singularValues();
  if (!(sv[5] > 1e-9 * sv[0])) throw Error(ExitCode::usage, "hexapod: the home pose is singular (struts lose rank)");
}

Hexapod::Hexapod(Private, HexapodConfig cfg, std::vector<double> values)
    : Model(make_joints(cfg), parameters_with_nominal(cfg), std::move(values)), cfg_(std::move(cfg)) {
  for (int i = 0; i < kHexapodStruts; ++i) {
    for (int a = 0; a < 3; ++a) {
      base_(a, i) = values_[static_cast<std::size_t>(kBaseFirst + 3 * i + a)];
      platform_(a, i) = values_[static_cast<std::size_t>(kPlatformFirst + 3 * i + a)];
    }
    offset_[i] = values_[static_cast<std::size_t>(kOffsetFirst + i)];
  }
  tool_rot_ = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), cfg_.tool_axis.normalized()).toRotationMatrix();
  home_.r = cfg_.home.linear();
  home_.t = cfg_.home.translation();
  workpiece_.r = cfg_.workpiece.linear();
  workpiece_.t = cfg_.workpiece.translation();
  home_dir_ = strut_vectors(home_, base_, platform_).colwise().normalized();
}

std::shared_ptr<const Model> Hexapod::with_values(std::vector<double> values) const {
  if (values.size() != params_.size())
    throw Error(ExitCode::internal,
                fmt::format("hexapod: {} parameter values given, {} expected", values.size(), params_.size()));
  return std::make_shared<const Hexapod>(Private{}, cfg_, std::move(values));
}

PlatformPose Hexapod::platform_pose(const Pose& tool) const {
  PlatformPose x;
  x.r = workpiece_.r * tool.r * tool_rot_.transpose();
  x.t = workpiece_.r * tool.p + workpiece_.t - x.r * cfg_.tool_tip;
  return x;
}

Pose Hexapod::tool_pose(const PlatformPose& x) const {
  Pose p;
  p.r = workpiece_.r.transpose() * x.r * tool_rot_;
  p.p = workpiece_.r.transpose() * (x.t + x.r * cfg_.tool_tip - workpiece_.t);
  return p;
}

Eigen::Matrix<double, 6, 1> Hexapod::strut_lengths(const PlatformPose& x) const {
  return strut_vectors(x, base_, platform_).colwise().norm().transpose();
}

Solve Hexapod::forward(const JointVector& q, Pose& out) const {
  return solve_forward(q, home_, out, HexapodFkOptions{});
}

Solve Hexapod::forward(const JointVector& q, Pose& out, const Pose& guess, const HexapodFkOptions& opt) const {
  return solve_forward(q, platform_pose(guess), out, opt);
}

Solve Hexapod::solve_forward(const JointVector& q, PlatformPose x, Pose& out, const HexapodFkOptions& opt) const {
  Solve s;
  Vector6d target;
  for (int i = 0; i < kHexapodStruts; ++i) {
    target[i] = q[i] + offset_[i];
    if (!(target[i] > 0)) {  // also catches NaN input
      s.status = Status::unreachable;
      s.joint = i;
      return s;
    }
  }
  // Longest Newton step taken at once: a quarter of the home strut length, and 0.3 rad.
  const double max_step = 0.25 * offset_.cwiseAbs().mean() + 1.0;
  double prev = std::numeric_limits<double>::infinity();
  for (int it = 0;; ++it) {
    const StrutMatrix d = strut_vectors(x, base_, platform_);
    const Vector6d len = d.colwise().norm().transpose();
    const Vector6d res = len - target;
    s.iterations = it;
    s.residual_mm = res.cwiseAbs().maxCoeff();
    if (!std::isfinite(s.residual_mm)) {
      s.status = Status::diverged;
      return s;
    }
    // Another assembly mode (e.g. the platform mirrored through the base) also satisfies the
    // lengths; refuse iterates whose struts point away from their home directions.
    for (int i = 0; i < kHexapodStruts; ++i)
      if (!(d.col(i).dot(home_dir_.col(i)) > 0)) {
        s.status = Status::diverged;
        return s;
      }
    if (s.residual_mm <= opt.tolerance_mm) {
      out = tool_pose(x);
      return s;
    }
    if (it >= opt.max_iterations) {
      s.status = Status::no_convergence;
      return s;
    }
    if (it > 3 && s.residual_mm > 4 * prev) {
      s.status = Status::diverged;
      return s;
    }
    prev = s.residual_mm;
    const Eigen::PartialPivLU<Matrix6d> lu(strut_jacobian(d, len, x, platform_));
    const Vector6d step = lu.solve(-res);
    if (!step.allFinite()) {
      s.status = Status::singular;
      return s;
    }
    // Far from the solution the linearisation overshoots; shorten long steps (damped Newton) so
    // a distant start still converges, and let the residual test catch real divergence.
    const double scale = std::min({1.0, kMaxRotationStep / step.tail<3>().norm(), max_step / step.head<3>().norm()});
    const Eigen::Vector3d dphi = scale * step.tail<3>();
    s.residual_rad = dphi.norm();
    x.t += scale * step.head<3>();
    x.r = so3_exp(dphi) * x.r;
  }
}

Jacobian Hexapod::jacobian_at(const Pose& pose) const {
  const PlatformPose x = platform_pose(pose);
  const StrutMatrix d = strut_vectors(x, base_, platform_);
  const Vector6d len = d.colwise().norm().transpose();
  const Matrix6d a_inv = strut_jacobian(d, len, x, platform_).inverse();
  // Tool tip moves with the platform: dP = dt + dφ × (R tip) = dt − [R tip]× dφ (base frame).
  Matrix6d tip = Matrix6d::Identity();
  tip.block<3, 3>(0, 3) = -skew(x.r * cfg_.tool_tip);
  Matrix6d to_workpiece = Matrix6d::Zero();
  to_workpiece.block<3, 3>(0, 0) = workpiece_.r.transpose();
  to_workpiece.block<3, 3>(3, 3) = workpiece_.r.transpose();
  return to_workpiece * tip * a_inv;
}

Jacobian Hexapod::jacobian(const JointVector& q) const {
  Pose p;
  if (!forward(q, p).ok()) {
    Jacobian j(6, kHexapodStruts);
    j.setConstant(std::numeric_limits<double>::quiet_NaN());
    return j;
  }
  return jacobian_at(p);
}

std::string_view to_string(HexapodSpin s) {
  return s == HexapodSpin::minimal_from_home ? "minimal-from-home" : "previous";
}

Eigen::Matrix3d Hexapod::swing(const Eigen::Matrix3d& origin, const Eigen::Vector3d& axis) {
  return Eigen::Quaterniond::FromTwoVectors(origin.col(2), axis.normalized()).toRotationMatrix() * origin;
}

Eigen::Matrix3d Hexapod::spin_origin(const JointVector& start, const Pose& near) const {
  const Eigen::Matrix3d r_home = tool_pose(home_).r;
  if (cfg_.spin == HexapodSpin::minimal_from_home) return r_home;
  // The previous block's orientation: FK of start, seeded with `near` (start is normally the
  // previous block, nearby); the home orientation when it fails.
  Pose at_start;
  Solve fs = forward(start, at_start, near);
  if (!fs.ok()) fs = forward(start, at_start);
  return fs.ok() ? at_start.r : r_home;
}

double Hexapod::spin_of(const Pose& pose, const Eigen::Matrix3d& origin) {
  const Eigen::Matrix3d rel = swing(origin, pose.axis()).transpose() * pose.r;  // a rotation about z
  return std::atan2(rel(1, 0) - rel(0, 1), rel(0, 0) + rel(1, 1));
}

Eigen::Matrix3d Hexapod::spin_origin_for(const Pose& target, const JointVector& start) const {
  Pose near;  // seeds FK of start: the target point, the home orientation swung onto its axis
  near.p = target.p;
  near.r = swing(tool_pose(home_).r, target.axis());
  return spin_origin(start, near);
}

Pose Hexapod::reached_pose(const Pose& target, const JointVector& start, PoseMatch match,
                           Eigen::Matrix3d* origin) const {
  Pose full = target;
  if (match == PoseMatch::point_and_axis) {
    const Eigen::Matrix3d o = spin_origin_for(target, start);
    if (origin != nullptr) *origin = o;
    full.r = swing(o, target.axis());
  }
  return full;
}

Solve Hexapod::inverse(const Pose& target, const JointVector& start, JointVector& q, const IkOptions& opt) const {
  const Pose full = reached_pose(target, start, opt.match);
  const PlatformPose x = platform_pose(full);
  const StrutMatrix d = strut_vectors(x, base_, platform_);
  q.resize(kHexapodStruts);
  Solve s;
  for (int i = 0; i < kHexapodStruts; ++i) {
    const double len = d.col(i).norm();
    q[i] = len - offset_[i];
    if (!(len > kMinStrutLength) && s.status == Status::ok) {
      s.status = Status::unreachable;
      s.joint = i;
    }
  }
  if (s.ok() && opt.check_limits) {
    s.joint = joint_outside_limits(*this, q);
    if (s.joint >= 0) s.status = Status::out_of_limits;
  }
  return s;
}

IdentificationJacobian Hexapod::identification_jacobian(const Pose& pose) const {
  const PlatformPose x = platform_pose(pose);
  const StrutMatrix d = strut_vectors(x, base_, platform_);
  IdentificationJacobian j = IdentificationJacobian::Zero();
  for (int i = 0; i < kHexapodStruts; ++i) {
    const Eigen::Vector3d n = d.col(i).normalized();
    j.block<1, 3>(i, kBaseFirst + 3 * i) = -n.transpose();
    j.block<1, 3>(i, kPlatformFirst + 3 * i) = n.transpose() * x.r;
    j(i, kOffsetFirst + i) = -1;
  }
  return j;
}

Eigen::Matrix3d Hexapod::machine_to_workpiece(const JointVector&) const { return workpiece_.r.transpose(); }

Eigen::Vector3d Hexapod::linear_position(const JointVector& q) const {
  Pose p;
  if (!forward(q, p).ok()) return Eigen::Vector3d::Zero();
  return workpiece_.r * p.p + workpiece_.t;
}

}  // namespace postproc::kin
