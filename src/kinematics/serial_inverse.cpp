// Inverse kinematics of serial chains: Newton on the analytic Jacobian from the caller's start (the
// fast path of every compensated block: fixed-capacity matrices, no heap), and the closed-form
// orientation solve of two rotary axes that seeds it when the start is poor or singular.
#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <limits>

#include <Eigen/LU>
#include <Eigen/QR>

#include "postproc/kinematics/serial.hpp"
#include "src/kinematics/serial_impl.hpp"

namespace postproc::kin {

namespace {

// Below this pivot ratio the square system is treated as singular (a rank loss, not just a poorly
// scaled mm / degree mix, whose ratios stay above ~1e-6).
constexpr double kSingularPivot = 1e-12;
// Step (mm / degree) below which an over-determined iteration (the lathe) has converged.
constexpr double kStepConverged = 1e-9;
// Residual size (mm + 1000·rad) below which Newton's next residual is expected to be within the
// tolerance, so the next evaluation skips the Jacobian (and redoes it with one if that was wrong).
constexpr double kQuadraticZone = 1e-5;

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 6, kMaxJoints>;

template <class Lu>
bool well_conditioned(const Lu& lu) {
  const auto d = lu.matrixLU().diagonal().cwiseAbs();
  return d.minCoeff() > kSingularPivot * d.maxCoeff();
}

// Gaussian elimination with partial pivoting, written out for the 5 × 5 system of every 5-axis
// block (Eigen's general LU costs several times more at this size), in place on row-major
// arrays; false on a rank loss.
bool solve5(double (&a)[5][5], double (&b)[5], JointVector& x) {
  double scale = 0;
  for (const auto& row : a)
    for (double v : row) scale = std::max(scale, std::abs(v));
#pragma GCC unroll 5
  for (int k = 0; k < 5; ++k) {
    int p = k;
#pragma GCC unroll 4
    for (int i = k + 1; i < 5; ++i)
      if (std::abs(a[i][k]) > std::abs(a[p][k])) p = i;
    if (!(std::abs(a[p][k]) > kSingularPivot * scale)) return false;
    if (p != k) {
#pragma GCC unroll 5
      for (int c = k; c < 5; ++c) std::swap(a[k][c], a[p][c]);
      std::swap(b[k], b[p]);
    }
    const double inv = 1 / a[k][k];
#pragma GCC unroll 4
    for (int i = k + 1; i < 5; ++i) {
      const double f = a[i][k] * inv;
#pragma GCC unroll 4
      for (int c = k + 1; c < 5; ++c) a[i][c] -= f * a[k][c];
      b[i] -= f * b[k];
    }
  }
  x.resize(5);
#pragma GCC unroll 5
  for (int k = 4; k >= 0; --k) {
    double v = b[k];
#pragma GCC unroll 4
    for (int c = k + 1; c < 5; ++c) v -= a[k][c] * x[c];
    x[k] = v / a[k][k];
  }
  return true;
}

// The Newton step for A·dq = r (m conditions, n joints); false when A has lost rank.
bool solve_step(const RowMatrix& a, const Eigen::Matrix<double, 6, 1>& r, JointVector& dq) {
  const auto m = a.rows();
  const auto n = a.cols();
  if (m == n) {
    using Square = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 6, 6>;
    const Eigen::PartialPivLU<Square> lu{Square(a)};
    if (!well_conditioned(lu)) return false;
    dq = lu.solve(r.head(m));
  } else if (m < n) {
    // Minimum-norm step: the joints the conditions leave free stay where they are.
    using Square = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 6, 6>;
    const Eigen::PartialPivLU<Square> lu(Square(a * a.transpose()));
    if (!well_conditioned(lu)) return false;
    dq = a.transpose() * lu.solve(r.head(m));
  } else if (n >= 3) {
    // Point first: minimise |Jo·dq − ro| subject to Jp·dq = rp (KKT system), so a machine with
    // fewer joints than conditions matches the point exactly and the tool axis as well as it can.
    using Kkt = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxJoints + 3,
                              kMaxJoints + 3>;
    using KktVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxJoints + 3, 1>;
    const auto jo = a.bottomRows(m - 3);
    Kkt k = Kkt::Zero(n + 3, n + 3);
    k.topLeftCorner(n, n) = jo.transpose() * jo;
    k.topRightCorner(n, 3) = a.topRows(3).transpose();
    k.bottomLeftCorner(3, n) = a.topRows(3);
    KktVector rhs(n + 3);
    Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, 3, 1> ro(m - 3);
    for (Eigen::Index i = 0; i < m - 3; ++i) ro[i] = r[3 + i];  // (a segment() here trips -Warray-bounds)
    rhs.head(n) = jo.transpose() * ro;
    rhs.tail(3) = r.head<3>();
    const Eigen::FullPivLU<Kkt> lu(k);
    if (!lu.isInvertible()) return false;
    dq = lu.solve(rhs).head(n);
  } else {
    const Eigen::CompleteOrthogonalDecomposition<RowMatrix> cod(a);
    dq = cod.solve(r.head(m));
  }
  return dq.allFinite();
}

// The value of an angle (degrees) in the turn nearest `near`.
double nearest_turn(double deg, double near) { return deg + 360.0 * std::round((near - deg) / 360.0); }

// The angle (rad) that turns u into c about unit axis a; `fallback` when u is on the axis.
double turn_angle(const Eigen::Vector3d& a, const Eigen::Vector3d& u, const Eigen::Vector3d& c, double fallback) {
  const Eigen::Vector3d up = u - a.dot(u) * a;
  const Eigen::Vector3d cp = c - a.dot(c) * a;
  if (up.norm() < 1e-12 || cp.norm() < 1e-12) return fallback;
  return std::atan2(a.dot(up.cross(cp)), up.dot(cp));
}

}  // namespace

Solve SerialModel::Impl::newton(const Pose& target, const JointVector& start, JointVector& q,
                                const IkOptions& opt) const {
  // Residual rows: dP, then for point_and_axis the axis deviation on two directions u normal to
  // the target axis, whose rows are (O × u)ᵀ·Jθ because d(u·O) = u·(dθ × O); for full, the
  // rotation vector from the current to the target orientation. The point rows are solved in the
  // machine frame (the workpiece-frame rows turned by the workpiece rotation, an orthogonal map
  // that leaves the step as it is), which spares moving every Jacobian column to the workpiece.
  const int n = static_cast<int>(axes.size());
  const bool point_only = rotary_count == 0;
  const bool full = !point_only && opt.match == PoseMatch::full && n >= 6;
  const int m = point_only ? 3 : (full ? 6 : 5);
  q = start;
  const Eigen::Vector3d ot = target.axis();
  const Eigen::Vector3d u1 = ot.unitOrthogonal();
  const Eigen::Vector3d u2 = ot.cross(u1);
  // The residual size (mm + 1000·rad, see below) at which both tolerances hold.
  const double goal = std::min(opt.tolerance_mm, point_only ? opt.tolerance_mm : 1000.0 * opt.tolerance_rad);
  Solve s;
  double prev = std::numeric_limits<double>::infinity();
  double prev2 = std::numeric_limits<double>::infinity();
  double last_step = std::numeric_limits<double>::infinity();
  Trig tr;
  trig(q, tr);
  Chain ch;
  std::array<int, kMaxJoints> hint{};
  hint.fill(std::numeric_limits<int>::max());
  RowMatrix a(m, n);
  Eigen::Matrix<double, 6, 1> r;
  JointVector dq(n);
  bool have_jac = false;
  for (int it = 0;; ++it) {
    // The Jacobian is skipped where the residual is expected to be within the tolerance after this
    // evaluation: below kQuadraticZone, or when quadratic convergence (r_k ≈ C·r_{k−1}², C from the
    // last two residuals) predicts it with a factor 10 to spare. A wrong guess costs one more pass.
    have_jac = !(prev < kQuadraticZone || (prev2 < std::numeric_limits<double>::infinity() && prev2 > 0 &&
                                           prev * prev * prev < 0.1 * goal * prev2 * prev2));
    if (have_jac) {
      chain<true>(q, tr, ch, hint.data());
    } else {
      chain<false>(q, tr, ch, hint.data());
    }
    const Rigid& tw = ch.side[0];
    const Rigid& ts = ch.side[1];
    Eigen::Vector3d tip = ts.t;  // machine frame
    tip.noalias() += ts.r * tool0.t;
    Eigen::Vector3d now_p;  // workpiece frame, as forward() computes it
    now_p.noalias() = tw.r.transpose() * (tip - tw.t);
    r.head<3>() = target.p - now_p;
    Eigen::Vector3d o;
    Eigen::Matrix3d now_r;
    if (full) {
      Eigen::Matrix3d tool_r;
      tool_r.noalias() = ts.r * tool0.r;
      now_r.noalias() = tw.r.transpose() * tool_r;
      o = now_r.col(2);
      r.tail<3>() = rotation_difference(target.r, now_r);
      s.residual_rad = r.tail<3>().norm();
    } else {
      const Eigen::Vector3d z = ts.r * tool0.r.col(2);
      o.noalias() = tw.r.transpose() * z;
      const Eigen::Vector3d d = ot - o;
      r[3] = u1.dot(d);
      r[4] = u2.dot(d);
      // The angle between o and ot from the chord |ot − o| = 2·sin(angle / 2) while it is small
      // (series of 2·asin(x / 2), exact to rounding below 1e-2), else atan2.
      const double x = d.norm();
      s.residual_rad = x < 1e-2 ? x * (1 + x * x * (1.0 / 24) * (1 + x * x * (9.0 / 80))) : std::atan2(o.cross(ot).norm(), o.dot(ot));
    }
    s.residual_mm = r.head<3>().norm();
    s.iterations = it;
    const bool axis_done = point_only || s.residual_rad <= opt.tolerance_rad || (m > n && last_step <= kStepConverged);
    if (s.residual_mm <= opt.tolerance_mm && axis_done) {
      s.status = Status::ok;
      return s;
    }
    if (it >= opt.max_iterations) {
      s.status = Status::no_convergence;
      return s;
    }
    // What the iteration drives to zero (the axis deviation is not, without enough joints).
    const double size = s.residual_mm + (point_only || m > n ? 0.0 : s.residual_rad * 1000.0);
    if (it > 3 && size > 4 * prev) {
      s.status = Status::diverged;
      return s;
    }
    prev2 = prev;
    prev = size;
    if (!have_jac) chain<true>(q, tr, ch, hint.data());
    // Point rows in the machine frame: the column of joint j is ±(w × tip + v), the residual
    // tw.r·dP; axis rows ±((tw.r·(O × u))·w); full: ±tw.rᵀ·w in the workpiece frame.
    Eigen::Matrix<double, 6, 1> rm = r;
    rm.head<3>().noalias() = tw.r * r.head<3>();
    Eigen::Vector3d g1 = Eigen::Vector3d::Zero();
    Eigen::Vector3d g2 = Eigen::Vector3d::Zero();
    if (!full && !point_only) {
      g1.noalias() = tw.r * o.cross(u1);
      g2.noalias() = tw.r * o.cross(u2);
    }
    if (m == 5 && n == 5) {  // the 5-axis fast path
      double a5[5][5];
      double b5[5] = {rm[0], rm[1], rm[2], rm[3], rm[4]};
      for (int j = 0; j < 5; ++j) {
        const auto k = static_cast<std::size_t>(j);
        const double sign = j < workpiece_count ? -1.0 : 1.0;
        const Eigen::Vector3d& w = ch.w[k];
        const Eigen::Vector3d c = w.cross(tip) + ch.v[k];
        a5[0][j] = sign * c.x();
        a5[1][j] = sign * c.y();
        a5[2][j] = sign * c.z();
        a5[3][j] = sign * g1.dot(w);
        a5[4][j] = sign * g2.dot(w);
      }
      if (!solve5(a5, b5, dq)) {
        s.status = Status::singular;
        return s;
      }
    } else {
      for (int j = 0; j < n; ++j) {
        const auto k = static_cast<std::size_t>(j);
        const double sign = j < workpiece_count ? -1.0 : 1.0;
        const Eigen::Vector3d& w = ch.w[k];
        a.block<3, 1>(0, j) = sign * (w.cross(tip) + ch.v[k]);
        if (full) {
          a.block<3, 1>(3, j).noalias() = sign * (tw.r.transpose() * w);
        } else if (!point_only) {
          a(3, j) = sign * g1.dot(w);
          a(4, j) = sign * g2.dot(w);
        }
      }
      if (!solve_step(a, rm, dq)) {
        s.status = Status::singular;
        return s;
      }
    }
    // New sines and cosines by the angle addition formulas while the step is small (Newton's
    // steps near the answer; series exact to rounding below 1e-2 rad), else afresh.
    for (int j = 0; j < n; ++j) {
      const auto k = static_cast<std::size_t>(j);
      const double before = q[j];
      q[j] += dq[j];
      if (!axes[k].rotary) continue;
      const double h = (q[j] - before) * kDeg;
      if (std::abs(h) < 1e-2) {
        const double h2 = h * h;
        const double sh = h * (1 - h2 * (1.0 / 6) * (1 - h2 * (1.0 / 20) * (1 - h2 * (1.0 / 42))));
        const double ch1 = h2 * 0.5 * (1 - h2 * (1.0 / 12) * (1 - h2 * (1.0 / 30) * (1 - h2 * (1.0 / 56))));  // 1 − cos h
        const double sn = tr.s[k];
        const double cs = tr.c[k];
        tr.s[k] = sn - sn * ch1 + cs * sh;
        tr.c[k] = cs - cs * ch1 - sn * sh;
      } else {
        serial_detail::sincos_deg(q[j], axes[k].offset, tr.s[k], tr.c[k]);
      }
    }
    last_step = dq.cwiseAbs().maxCoeff();
  }
}

Solve SerialModel::inverse(const Pose& target, const JointVector& start, JointVector& q, const IkOptions& opt) const {
  Solve s = impl_->newton(target, start, q, opt);
  const auto outside = [&](const JointVector& v) { return opt.check_limits ? joint_outside_limits(*this, v) : -1; };
  if ((!s.ok() || outside(q) >= 0) && impl_->rotary_count == 2) {
    // Seeds on every orientation branch; keep the converged one nearest start, within travel first.
    bool best_in = false;  // s, if ok, is outside the travel
    double best = s.ok() ? (q - start).squaredNorm() : std::numeric_limits<double>::infinity();
    for (const JointVector& seed : orientation_candidates(target.axis(), start)) {
      JointVector qc;
      const Solve sc = impl_->newton(target, seed, qc, opt);
      if (!sc.ok()) continue;
      const bool in = outside(qc) < 0;
      const double d = (qc - start).squaredNorm();
      if ((in && !best_in) || (in == best_in && d < best)) {
        best_in = in;
        best = d;
        q = qc;
        s = sc;
      }
    }
  }
  if (s.ok() && opt.check_limits) {
    s.joint = joint_outside_limits(*this, q);
    if (s.joint >= 0) s.status = Status::out_of_limits;
  }
  return s;
}

std::vector<JointVector> SerialModel::orientation_candidates(const Eigen::Vector3d& o, const JointVector& start) const {
  // On the nominal chain only the rotary joints turn the tool: O = R_w(θ)ᵀ·R_t(θ)·o0. With the two
  // rotary joints r0 (nearer the bed on its side, or on the workpiece side) and r1, each case is
  // Rot(a, α)·u = Rot(b, β)·w = c (Paden–Kahan subproblem 2): c lies on two cones, so
  // c = x·a + y·b ± z·(a × b); then α and β follow as the angle of one vector turned into another.
  std::vector<JointVector> out;
  if (impl_->rotary_count != 2 || start.size() != joint_count() || !(o.norm() > 0) || !o.allFinite()) return out;
  int r[2] = {-1, -1};
  for (int j = 0, k = 0; j < joint_count(); ++j)
    if (joints_[static_cast<std::size_t>(j)].type == JointType::rotary) r[k++] = j;
  const auto dir = [this](int j) {
    const int w = static_cast<int>(cfg_.workpiece_side.size());
    return j < w ? cfg_.workpiece_side[static_cast<std::size_t>(j)].direction
                 : cfg_.tool_side[static_cast<std::size_t>(j - w)].direction;
  };
  const bool ws0 = r[0] < impl_->workpiece_count;
  const bool ws1 = r[1] < impl_->workpiece_count;
  const Eigen::Vector3d on = o.normalized();
  // Side a turns the tool axis o0, side b the target; joint = sign·angle.
  int ja = r[1];
  int jb = r[0];
  double sa = 1;
  double sb = ws0 && !ws1 ? 1 : -1;  // head-table: +; head-head: −
  if (ws0 && ws1) {  // table-table: Rot(d0, −θ0)·o0 = Rot(d1, θ1)·o
    ja = r[0];
    jb = r[1];
    sa = -1;
    sb = 1;
  }
  const Eigen::Vector3d a = dir(ja);
  const Eigen::Vector3d b = dir(jb);
  const Eigen::Vector3d& u = cfg_.tool_axis;
  const double ab = a.dot(b);
  const double det = 1 - ab * ab;
  if (det < 1e-12) return out;  // parallel rotary axes cannot set an orientation
  const double ca = a.dot(u);
  const double cb = b.dot(on);
  const double x = (ca - ab * cb) / det;
  const double y = (cb - ab * ca) / det;
  const double z2 = (1 - (x * x + y * y + 2 * x * y * ab)) / det;
  if (z2 < -1e-9) return out;  // the target axis is outside the cone the two axes can reach
  const double z = std::sqrt(std::max(0.0, z2));
  const Eigen::Vector3d axb = a.cross(b);
  for (double sign : {1.0, -1.0}) {
    const Eigen::Vector3d c = x * a + y * b + sign * z * axb;
    JointVector q = start;
    const double alpha = turn_angle(a, u, c, sa * start[ja] * kDeg);
    const double beta = turn_angle(b, on, c, sb * start[jb] * kDeg);
    q[ja] = nearest_turn(sa * alpha / kDeg, start[ja]);
    q[jb] = nearest_turn(sb * beta / kDeg, start[jb]);
    out.push_back(q);
    if (z < 1e-9) break;  // one branch only
  }
  return out;
}

}  // namespace postproc::kin
