// The generic parts of every machine model: parameter lookup, the finite-difference Jacobian and
// the Gauss–Newton inverse kinematics that parallel and decorated models inherit.
#include "postproc/kinematics/model.hpp"

#include <cmath>

#include <Eigen/QR>
#include <fmt/format.h>

#include "postproc/error.hpp"

namespace postproc::kin {

std::string_view to_string(Status s) {
  switch (s) {
    case Status::ok: return "ok";
    case Status::no_convergence: return "no convergence";
    case Status::diverged: return "diverged";
    case Status::singular: return "singular configuration";
    case Status::unreachable: return "unreachable";
    case Status::out_of_limits: return "outside the axis travel";
    case Status::outside_map: return "outside the volumetric error map";
  }
  return "?";
}

Model::Model(std::vector<Joint> joints, std::vector<Parameter> params, std::vector<double> values)
    : joints_(std::move(joints)), params_(std::move(params)), values_(std::move(values)) {
  if (values_.size() != params_.size())
    throw Error(ExitCode::internal, fmt::format("model: {} parameter values for {} parameters", values_.size(),
                                                params_.size()));
  if (joints_.empty() || static_cast<int>(joints_.size()) > kMaxJoints)
    throw Error(ExitCode::internal, fmt::format("model: {} joints (1 to {} supported)", joints_.size(), kMaxJoints));
}

int Model::parameter_index(std::string_view name) const {
  for (std::size_t i = 0; i < params_.size(); ++i)
    if (params_[i].name == name) return static_cast<int>(i);
  return -1;
}

std::shared_ptr<const Model> Model::nominal() const {
  std::vector<double> v(params_.size());
  for (std::size_t i = 0; i < params_.size(); ++i) v[i] = params_[i].nominal;
  return with_values(std::move(v));
}

Eigen::Matrix3d Model::machine_to_workpiece(const JointVector&) const { return Eigen::Matrix3d::Identity(); }

Eigen::Vector3d Model::linear_position(const JointVector& q) const {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int j = 0; j < joint_count(); ++j) {
    const auto& n = joints_[static_cast<std::size_t>(j)].name;
    if (n.size() == 1 && n[0] >= 'X' && n[0] <= 'Z') p[n[0] - 'X'] = q[j];
  }
  return p;
}

Eigen::Vector3d rotation_difference(const Eigen::Matrix3d& r_b, const Eigen::Matrix3d& r_a) {
  const Eigen::AngleAxisd aa(r_b * r_a.transpose());
  return aa.axis() * aa.angle();
}

int joint_outside_limits(const Model& m, const JointVector& q) {
  constexpr double kSlack = 1e-9;
  for (int j = 0; j < m.joint_count(); ++j) {
    const Joint& jt = m.joints()[static_cast<std::size_t>(j)];
    if (q[j] < jt.min - kSlack || q[j] > jt.max + kSlack) return j;
  }
  return -1;
}

namespace {
void check_size(const Model& m, const JointVector& q, const char* what) {
  if (q.size() != m.joint_count())
    throw Error(ExitCode::internal, fmt::format("{}: {} joint values given, model '{}' has {} joints", what, q.size(),
                                                m.kind(), m.joint_count()));
}
}  // namespace

Jacobian numeric_jacobian(const Model& m, const JointVector& q, double step) {
  const int n = m.joint_count();
  Jacobian j(6, n);
  Pose plus;
  Pose minus;
  for (int k = 0; k < n; ++k) {
    JointVector qp = q;
    JointVector qm = q;
    qp[k] += step;
    qm[k] -= step;
    if (!m.forward(qp, plus).ok() || !m.forward(qm, minus).ok()) {
      j.col(k).setConstant(std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    j.block<3, 1>(0, k) = (plus.p - minus.p) / (2 * step);
    j.block<3, 1>(3, k) = rotation_difference(plus.r, minus.r) / (2 * step);
  }
  return j;
}

Jacobian Model::jacobian(const JointVector& q) const { return numeric_jacobian(*this, q); }

Solve Model::inverse(const Pose& target, const JointVector& start, JointVector& q, const IkOptions& opt) const {
  // Gauss–Newton on the pose residual. For point_and_axis the orientation residual is the tool
  // axis's deviation projected on two directions normal to the target axis (u1, u2):
  // d(u·O) = u·(dθ × O) = (O × u)·dθ, so those rows of the Jacobian are (O × u)ᵀ Jθ.
  const int n = joint_count();
  q = start;
  const Eigen::Vector3d ot = target.axis();
  Eigen::Vector3d u1 = ot.unitOrthogonal();
  Eigen::Vector3d u2 = ot.cross(u1);
  const int rows = opt.match == PoseMatch::full ? 6 : 5;
  Solve s;
  double prev = std::numeric_limits<double>::infinity();
  for (int it = 0; it <= opt.max_iterations; ++it) {
    Pose now;
    Solve f = forward(q, now);
    if (!f.ok()) {
      s.status = f.status == Status::ok ? Status::diverged : f.status;
      s.iterations = it;
      return s;
    }
    Eigen::Matrix<double, 6, 1> r;
    r.head<3>() = target.p - now.p;
    const Eigen::Vector3d o = now.axis();
    if (opt.match == PoseMatch::full) {
      r.tail<3>() = rotation_difference(target.r, now.r);
    } else {
      r[3] = u1.dot(ot - o);
      r[4] = u2.dot(ot - o);
    }
    s.residual_mm = r.head<3>().norm();
    s.residual_rad = opt.match == PoseMatch::full ? r.tail<3>().norm() : std::asin(std::min(1.0, o.cross(ot).norm()));
    s.iterations = it;
    if (s.residual_mm <= opt.tolerance_mm && s.residual_rad <= opt.tolerance_rad) break;
    const double size = s.residual_mm + s.residual_rad * 1000.0;
    if (it == opt.max_iterations) {
      s.status = Status::no_convergence;
      return s;
    }
    if (it > 3 && size > 4 * prev) {
      s.status = Status::diverged;
      return s;
    }
    prev = size;
    const Jacobian jf = jacobian(q);
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 6, kMaxJoints> a(rows, n);
    a.topRows<3>() = jf.topRows<3>();
    if (opt.match == PoseMatch::full) {
      a.bottomRows<3>() = jf.bottomRows<3>();
    } else {
      a.row(3) = o.cross(u1).transpose() * jf.bottomRows<3>();
      a.row(4) = o.cross(u2).transpose() * jf.bottomRows<3>();
    }
    Eigen::CompleteOrthogonalDecomposition<decltype(a)> cod(a);
    if (cod.rank() < std::min(rows, n)) {
      s.status = Status::singular;
      return s;
    }
    const JointVector dq = cod.solve(r.head(rows));
    q += dq;
  }
  if (opt.check_limits) {
    s.joint = joint_outside_limits(*this, q);
    if (s.joint >= 0) s.status = Status::out_of_limits;
  }
  return s;
}

Solve forward(const Model& m, const JointVector& q, Pose& out) {
  check_size(m, q, "forward kinematics");
  return m.forward(q, out);
}

Jacobian jacobian(const Model& m, const JointVector& q) {
  check_size(m, q, "jacobian");
  return m.jacobian(q);
}

Solve inverse(const Model& m, const Pose& target, const JointVector& start, JointVector& q, const IkOptions& opt) {
  check_size(m, start, "inverse kinematics");
  return m.inverse(target, start, q, opt);
}

}  // namespace postproc::kin
