// Inverse kinematics with the tool tip exact and a bounded rotary correction for the tool axis
// (Gauss–Newton on a damped least-squares problem with the tip as a hard constraint).
#include "postproc/kinematics/bounded_inverse.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/LU>

namespace postproc::kin {


Solve bounded_inverse(const Model& model, const Pose& target, const JointVector& anchor, JointVector& q,
                      const BoundedIkOptions& opt) {
  const int n = model.joint_count();
  // Joint values in solve units: mm, and rad for rotary joints (interface units are degrees).
  JointVector unit = JointVector::Ones(n);
  JointVector rotary = JointVector::Zero(n);
  for (int j = 0; j < n; ++j)
    if (model.joints()[static_cast<std::size_t>(j)].type == JointType::rotary) {
      unit[j] = kDeg;
      rotary[j] = 1;
    }
  const Eigen::Vector3d ot = target.axis();
  const Eigen::Vector3d u1 = ot.unitOrthogonal();
  const Eigen::Vector3d u2 = ot.cross(u1);

  // The state at joint values q: residuals and the merit of the constrained problem.
  struct State {
    Pose pose;
    Eigen::Vector3d rp;  // tip residual, mm
    Eigen::Vector2d ro;  // axis residual on u1, u2
    double objective = 0;
  };
  const auto evaluate = [&](const JointVector& x, double lambda2, State& st) -> Solve {
    if (Solve f = model.forward(x, st.pose); !f.ok()) return f;
    st.rp = target.p - st.pose.p;
    const Eigen::Vector3d o = st.pose.axis();
    st.ro = Eigen::Vector2d(u1.dot(ot - o), u2.dot(ot - o));
    double reg = 0;
    for (int j = 0; j < n; ++j) reg += rotary[j] * std::pow((x[j] - anchor[j]) * unit[j], 2);
    st.objective = 0.5 * (st.ro.squaredNorm() + lambda2 * reg);
    return {};
  };

  q = anchor;
  State now;
  if (Solve f = evaluate(q, 0, now); !f.ok()) return f;
  const double c = std::max(opt.max_rotary_correction_rad, 1e-12);
  // A floor keeps the system regular where a rotary joint moves neither tip nor axis (C at A = 0
  // with the tip on the C axis); it leaves (1e-5 / σ)² of the error in a direction of strength σ.
  const double e0 = angle_between(now.pose.axis(), ot);
  const double smooth = std::sqrt(e0 / std::max(opt.max_correction_slope, 1e-12));
  const double lambda = std::max(std::clamp(opt.damping_share, 0.0, 1.0) * std::max(e0 / (2 * c), smooth), 1e-5);
  const double lambda2 = lambda * lambda;

  using Kkt = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxJoints + 3, kMaxJoints + 3>;
  using KktVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxJoints + 3, 1>;
  Solve s;
  double last_step = std::numeric_limits<double>::infinity();
  double mu = 0;  // weight of the tip residual in the merit function (mm⁻¹), grows with the multipliers
  const auto finish = [&](Status st, int it) {
    s.status = st;
    s.iterations = it;
    s.residual_mm = now.rp.norm();
    s.residual_rad = angle_between(now.pose.axis(), ot);
    if (s.status == Status::ok && !(s.residual_mm <= opt.tolerance_mm)) s.status = Status::no_convergence;
    return s;
  };
  for (int it = 0;; ++it) {
    if (it == opt.max_iterations) return finish(Status::ok, it);
    const Jacobian jd = model.jacobian(q);
    if (!jd.allFinite()) return finish(Status::diverged, it);
    // Columns per mm / per rad; the axis rows are (O × u)ᵀ·Jθ since d(u·O) = u·(dθ × O).
    const Eigen::Vector3d o = now.pose.axis();
    Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::ColMajor, 3, kMaxJoints> jp(3, n);
    Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::ColMajor, 2, kMaxJoints> jo(2, n);
    const Eigen::Vector3d g1 = o.cross(u1);
    const Eigen::Vector3d g2 = o.cross(u2);
    for (int j = 0; j < n; ++j) {
      const double k = 1 / unit[j];
      jp.col(j) = jd.block<3, 1>(0, j) * k;
      jo(0, j) = g1.dot(jd.block<3, 1>(3, j)) * k;
      jo(1, j) = g2.dot(jd.block<3, 1>(3, j)) * k;
    }
    // KKT system of  min |Jo·dx − ro|² + λ²|D(x + dx − a)|²  s.t.  Jp·dx = rp  (D: the rotary joints),
    // with a vanishing step damping on every joint so that redundant joints stay put.
    Kkt k = Kkt::Zero(n + 3, n + 3);
    k.topLeftCorner(n, n) = jo.transpose() * jo;
    KktVector rhs(n + 3);
    rhs.head(n) = jo.transpose() * now.ro;
    const double tiny = 1e-12 * std::max(1.0, k.topLeftCorner(n, n).diagonal().maxCoeff());
    for (int j = 0; j < n; ++j) {
      k(j, j) += lambda2 * rotary[j] + tiny;
      rhs[j] -= lambda2 * rotary[j] * (q[j] - anchor[j]) * unit[j];
    }
    k.topRightCorner(n, 3) = jp.transpose();
    k.bottomLeftCorner(3, n) = jp;
    rhs.tail(3) = now.rp;
    const Eigen::FullPivLU<Kkt> lu(k);
    if (!lu.isInvertible()) return finish(Status::singular, it);  // the tip cannot move some way here
    const KktVector x = lu.solve(rhs);
    if (!x.allFinite()) return finish(Status::diverged, it);
    // Globalisation: the full step, halved until the merit  objective + μ·|rp|  decreases (an exact
    // penalty for μ above the multipliers). Where the axis error is large (a lathe near the spindle
    // axis, whose C turns the tool axis) plain Gauss–Newton cycles.
    mu = std::max(mu, 2 * x.tail(3).cwiseAbs().maxCoeff() + 1e-3);
    const double merit = now.objective + mu * now.rp.norm();
    double alpha = 1;
    State trial;
    JointVector qt(n);
    bool taken = false;
    for (int h = 0; h < 30; ++h, alpha *= 0.5) {
      for (int j = 0; j < n; ++j) qt[j] = q[j] + alpha * x[j] / unit[j];
      if (!evaluate(qt, lambda2, trial).ok()) continue;
      if (trial.objective + mu * trial.rp.norm() <= merit) {
        taken = true;
        break;
      }
    }
    if (!taken) return finish(Status::ok, it);  // no decrease left: the minimum, to rounding
    double step = 0;
    for (int j = 0; j < n; ++j) step = std::max(step, std::abs(qt[j] - q[j]) * unit[j]);
    q = qt;
    now = trial;
    // Converged: the step is below the tolerance, or down in the rounding noise and no longer
    // shrinking (positions in the metres and angles in the thousands of degrees).
    const bool stalled = step < 1e-8 && step > 0.5 * last_step;
    last_step = step;
    if (step <= opt.step_tolerance || stalled) return finish(Status::ok, it + 1);
  }
}

}  // namespace postproc::kin
