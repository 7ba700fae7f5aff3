// The 3-PRS hybrid machine of document 001: loop closure per limb, Newton forward kinematics,
// a 3-unknown inverse kinematics and the implicit-differentiation Jacobians.
#include "postproc/kinematics/prs_hybrid.hpp"

#include <cmath>

#include <fmt/format.h>

#include "postproc/error.hpp"

namespace postproc::kin {

namespace {

// Indices of the nominal-geometry parameters after the 33 errors.
constexpr int kGeomA = PrsHybrid::kErrorCount;
constexpr int kGeomB = kGeomA + 1;
constexpr int kGeomL = kGeomA + 2;
constexpr int kTool = kGeomA + 3;
constexpr int kTilt = kGeomA + 4;
constexpr int kParamCount = kGeomA + 5;

constexpr double kLimbAngle = 2 * kPi / 3;

// Offsets inside one limb's 11 errors.
enum LimbError : int { da_x, da_y, da_z, db_x, db_y, tb_x, tb_y, tb_z, tc_x, dq, dl };

Eigen::Matrix3d rot_x(double t) {
  const double c = std::cos(t), s = std::sin(t);
  Eigen::Matrix3d m;
  m << 1, 0, 0, 0, c, -s, 0, s, c;
  return m;
}
Eigen::Matrix3d rot_y(double t) {
  const double c = std::cos(t), s = std::sin(t);
  Eigen::Matrix3d m;
  m << c, 0, s, 0, 1, 0, -s, 0, c;
  return m;
}
Eigen::Matrix3d rot_z(double t) {
  const double c = std::cos(t), s = std::sin(t);
  Eigen::Matrix3d m;
  m << c, -s, 0, s, c, 0, 0, 0, 1;
  return m;
}
// diag(1, −1, −1): base ↔ workpiece axes, and platform ↔ tool axes.
Eigen::Vector3d flip(const Eigen::Vector3d& v) { return {v.x(), -v.y(), -v.z()}; }

// R_i = Rz(2(i − 1)π/3), computed once.
const std::array<Eigen::Matrix3d, 3>& limb_rotations() {
  static const std::array<Eigen::Matrix3d, 3> r{rot_z(0), rot_z(kLimbAngle), rot_z(2 * kLimbAngle)};
  return r;
}

/// Solves a·x = b in place (b becomes x) by Gaussian elimination with partial pivoting. Eigen's
/// PartialPivLU runs a generic loop that costs more than the loop closure itself at N = 6; this
/// one unrolls. False when a pivot vanishes relative to the largest entry (singular).
template <int N, int M>
bool solve_small(Eigen::Matrix<double, N, N> a, Eigen::Matrix<double, N, M>& b) {
  const double scale = a.cwiseAbs().maxCoeff();
  for (int k = 0; k < N; ++k) {
    int piv = k;
    for (int r = k + 1; r < N; ++r)
      if (std::abs(a(r, k)) > std::abs(a(piv, k))) piv = r;
    if (!(std::abs(a(piv, k)) > 1e-13 * scale)) return false;
    if (piv != k) {
      a.row(k).swap(a.row(piv));
      b.row(k).swap(b.row(piv));
    }
    const double inv = 1.0 / a(k, k);
    for (int r = k + 1; r < N; ++r) {
      const double m = a(r, k) * inv;
      if (m == 0.0) continue;
      for (int c = k + 1; c < N; ++c) a(r, c) -= m * a(k, c);
      b.row(r) -= m * b.row(k);
    }
  }
  for (int k = N - 1; k >= 0; --k) {
    for (int c = k + 1; c < N; ++c) b.row(k) -= a(k, c) * b.row(c);
    b.row(k) /= a(k, k);
  }
  return true;
}

Eigen::Matrix3d exp_so3(const Eigen::Vector3d& w) {
  const double t = w.norm();
  if (t < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(t, w / t).toRotationMatrix();
}

std::vector<Parameter> make_parameters(const PrsHybridGeometry& g) {
  struct Spec {
    const char* name;
    const char* unit;
    const char* what;
  };
  static constexpr std::array<Spec, PrsHybrid::kLimbErrors> kSpecs{{
      {"da_x", "mm", "sphere-centre offset along O'A_i (platform frame turned by R_i)"},
      {"da_y", "mm", "sphere-centre offset normal to O'A_i in the platform plane"},
      {"da_z", "mm", "sphere-centre offset along Z'"},
      {"db_x", "mm", "slider zero-point offset along OB_i (base frame turned by R_i)"},
      {"db_y", "mm", "slider zero-point offset normal to the limb plane"},
      {"tb_x", "rad", "guide-frame rotation about OB_i (tilts the guide sideways)"},
      {"tb_y", "rad", "guide-frame rotation about the joint axis (tilts the guide radially)"},
      {"tb_z", "rad", "guide-frame rotation about the guide (turns the revolute axis)"},
      {"tc_x", "rad", "link tilt out of the revolute joint's plane"},
      {"dq", "mm", "slider zero offset along the guide"},
      {"dl", "mm", "link length error"},
  }};
  std::vector<Parameter> p;
  p.reserve(kParamCount);
  for (int i = 1; i <= 3; ++i)
    for (const Spec& s : kSpecs)
      p.push_back({fmt::format("limb{}.{}", i, s.name), s.unit, 0.0, true, fmt::format("limb {}: {}", i, s.what)});
  p.push_back({"geom.a", "mm", g.platform_radius, false, "platform radius |O'A_i|"});
  p.push_back({"geom.b", "mm", g.base_radius, false, "base radius |OB_i| of the slider zero points"});
  p.push_back({"geom.l", "mm", g.link_length, false, "link length, revolute axis to sphere centre"});
  p.push_back({"tool.length", "mm", g.tool_length, false, "platform centre O' to tool tip along Z'"});
  p.push_back({"geom.guide_tilt", "rad", g.guide_tilt, false, "guide tilt from +Z toward OB_i"});
  return p;
}

std::vector<Joint> make_joints(const PrsHybridGeometry& g) {
  return {{"X", JointType::linear, g.x_min, g.x_max},
          {"Y", JointType::linear, g.y_min, g.y_max},
          {"q1", JointType::linear, g.q_min, g.q_max},
          {"q2", JointType::linear, g.q_min, g.q_max},
          {"q3", JointType::linear, g.q_min, g.q_max}};
}

std::vector<double> nominal_values(const PrsHybridGeometry& g) {
  std::vector<double> v(kParamCount, 0.0);
  v[kGeomA] = g.platform_radius;
  v[kGeomB] = g.base_radius;
  v[kGeomL] = g.link_length;
  v[kTool] = g.tool_length;
  v[kTilt] = g.guide_tilt;
  return v;
}

}  // namespace

PrsHybrid::PrsHybrid(PrsHybridGeometry g) : PrsHybrid(g, nominal_values(g)) {}

PrsHybrid::PrsHybrid(PrsHybridGeometry g, std::vector<double> values)
    : Model(make_joints(g), make_parameters(g), std::move(values)), geom_(g) {
  // The parameter vector is the truth for the geometry; geom_ keeps only frames and travel.
  geom_.platform_radius = values_[kGeomA];
  geom_.base_radius = values_[kGeomB];
  geom_.link_length = values_[kGeomL];
  geom_.tool_length = values_[kTool];
  geom_.guide_tilt = values_[kTilt];
  if (!(geom_.platform_radius > 0 && geom_.base_radius > 0 && geom_.tool_length >= 0 &&
        geom_.link_length > std::abs(geom_.base_radius - geom_.platform_radius) &&
        std::abs(geom_.guide_tilt) < kPi / 2))
    throw Error(ExitCode::usage,
                fmt::format("prs_hybrid: geometry a = {} mm, b = {} mm, l = {} mm, tool = {} mm, guide tilt = {} rad "
                            "cannot be assembled (need a, b > 0, l > |b − a|, tool ≥ 0, |tilt| < π/2)",
                            geom_.platform_radius, geom_.base_radius, geom_.link_length, geom_.tool_length,
                            geom_.guide_tilt));
  build_limbs();
}

void PrsHybrid::build_limbs() {
  const Eigen::Matrix3d rb = rot_y(geom_.guide_tilt);
  for (int i = 0; i < 3; ++i) {
    const double* e = values_.data() + i * kLimbErrors;
    const Eigen::Matrix3d& ri = limb_rotations()[static_cast<std::size_t>(i)];
    const Eigen::Matrix3d g = ri * rb * rot_x(e[tb_x]) * rot_y(e[tb_y]) * rot_z(e[tb_z]);
    Limb& l = limbs_[static_cast<std::size_t>(i)];
    l.r = ri * Eigen::Vector3d(geom_.platform_radius + e[da_x], e[da_y], e[da_z]) -
          Eigen::Vector3d(0, 0, geom_.tool_length);
    l.b = ri * Eigen::Vector3d(geom_.base_radius + e[db_x], e[db_y], 0);
    l.u = g.col(2);
    l.y = g.col(1);
    l.lp = geom_.link_length + e[dl];
    l.cy = -l.lp * std::sin(e[tc_x]);
    l.dq = e[dq];
  }
}

std::shared_ptr<const Model> PrsHybrid::with_values(std::vector<double> values) const {
  if (values.size() != params_.size())
    throw Error(ExitCode::internal,
                fmt::format("prs_hybrid: {} parameter values for {} parameters", values.size(), params_.size()));
  return std::shared_ptr<const PrsHybrid>(new PrsHybrid(geom_, std::move(values)));
}

std::shared_ptr<const PrsHybrid> PrsHybrid::with_errors(std::span<const double> errors) const {
  if (errors.size() != static_cast<std::size_t>(kErrorCount))
    throw Error(ExitCode::internal, fmt::format("prs_hybrid: {} error values for {}", errors.size(), kErrorCount));
  std::vector<double> v = values_;
  std::copy(errors.begin(), errors.end(), v.begin());
  return std::shared_ptr<const PrsHybrid>(new PrsHybrid(geom_, std::move(v)));
}

Eigen::Matrix3d PrsHybrid::tilt_rotation(const Eigen::Vector3d& n) {
  // Rz(φ)Ry(θ)Rz(−φ) is the rotation by θ about (−sin φ, cos φ, 0) = e_z × n: the shortest
  // rotation taking e_z to n. Rodrigues with k = e_z × n (|k| = sin θ) and 1 − cos θ = |k|²/(1 + n_z)
  // needs no trigonometry and is smooth at θ = 0, where φ is undefined.
  const Eigen::Vector3d k(-n.y(), n.x(), 0.0);
  Eigen::Matrix3d kx;
  kx << 0, -k.z(), k.y(), k.z(), 0, -k.x(), -k.y(), k.x(), 0;
  return Eigen::Matrix3d::Identity() + kx + kx * kx / (1.0 + n.z());
}

Eigen::Vector3d PrsHybrid::tilt_torsion(const Eigen::Matrix3d& r_t) {
  const Eigen::Vector3d n = r_t.col(2);
  const double theta = std::atan2(std::hypot(n.x(), n.y()), n.z());
  const double phi = std::hypot(n.x(), n.y()) > 0 ? std::atan2(n.y(), n.x()) : 0.0;
  const Eigen::Matrix3d tors = tilt_rotation(n).transpose() * r_t;
  return {phi, theta, std::atan2(tors(1, 0), tors(0, 0))};
}

Pose PrsHybrid::to_workpiece(const Eigen::Vector3d& tip, const Eigen::Matrix3d& r_t, double x, double y) const {
  Pose p;
  p.p = flip(Eigen::Vector3d(tip - geom_.workpiece_origin)) + Eigen::Vector3d(x, y, 0);
  // Tool frame = platform frame · diag(1, −1, −1); the workpiece frame is the base frame turned
  // the same way, so R = F·R_T·F.
  const Eigen::Matrix3d f = Eigen::Vector3d(1, -1, -1).asDiagonal();
  p.r = f * r_t * f;
  return p;
}

void PrsHybrid::residual(const Eigen::Vector3d& sliders, const Eigen::Vector3d& tip, const Eigen::Matrix3d& r_t,
                         Eigen::Matrix<double, 6, 1>& f, Eigen::Matrix<double, 6, 6>* jx) const {
  // Per limb: F1 = (|d|² − l'²)/(2l') ≈ |d| − l' (the length condition, eq. 6, in mm near the
  // solution) and F2 = y·d − c_y (the link stays in the plane normal to the revolute axis,
  // eq. 7), d = A_i − S_i. dA = dH + ω × w with w = R_T r, so ∂F/∂ω = w × ∂F/∂d.
  for (int i = 0; i < 3; ++i) {
    const Limb& l = limbs_[static_cast<std::size_t>(i)];
    const Eigen::Vector3d w = r_t * l.r;
    const Eigen::Vector3d d = tip + w - l.b - (sliders[i] + l.dq) * l.u;
    f[2 * i] = (d.squaredNorm() - l.lp * l.lp) / (2 * l.lp);
    f[2 * i + 1] = l.y.dot(d) - l.cy;
    if (jx != nullptr) {
      jx->block<1, 3>(2 * i, 0) = d.transpose() / l.lp;
      jx->block<1, 3>(2 * i, 3) = w.cross(d).transpose() / l.lp;
      jx->block<1, 3>(2 * i + 1, 0) = l.y.transpose();
      jx->block<1, 3>(2 * i + 1, 3) = w.cross(l.y).transpose();
    }
  }
}

Solve PrsHybrid::platform_forward(const Eigen::Vector3d& sliders, Eigen::Vector3d& tip, Eigen::Matrix3d& r_t) const {
  Solve s;
  // A necessary condition first: sphere centres i and j are |A_i − A_j| apart, so sliders farther
  // apart than l_i + l_j + |A_i − A_j| cannot close the loops (Newton would wander instead).
  std::array<Eigen::Vector3d, 3> slider_pt;
  for (int i = 0; i < 3; ++i) {
    const Limb& l = limbs_[static_cast<std::size_t>(i)];
    slider_pt[static_cast<std::size_t>(i)] = l.b + (sliders[i] + l.dq) * l.u;
  }
  for (std::size_t i = 0; i < 3; ++i) {
    const std::size_t j = (i + 1) % 3;
    const double reach = limbs_[i].lp + limbs_[j].lp + (limbs_[i].r - limbs_[j].r).norm();
    if ((slider_pt[i] - slider_pt[j]).norm() > reach) {
      s.status = Status::unreachable;
      return s;
    }
  }
  // Seed: each sphere centre straight along the guide from its slider, pulled in radially by
  // b − a; the plane through the three gives the tilt (ψ = 0), their centroid O'.
  const double h0 = std::sqrt(std::max(0.0, geom_.link_length * geom_.link_length -
                                                std::pow(geom_.base_radius - geom_.platform_radius, 2)));
  std::array<Eigen::Vector3d, 3> est;
  for (std::size_t i = 0; i < 3; ++i) {
    const Eigen::Vector3d radial = limb_rotations()[i].col(0);
    est[i] = slider_pt[i] + (geom_.platform_radius - geom_.base_radius) * radial + h0 * limbs_[i].u;
  }
  Eigen::Vector3d n = (est[1] - est[0]).cross(est[2] - est[0]).normalized();
  if (n.z() < 0) n = -n;
  Eigen::Matrix3d r = tilt_rotation(n);
  Eigen::Vector3d h = (est[0] + est[1] + est[2]) / 3.0 + geom_.tool_length * n;

  constexpr int kMaxIter = 40;
  constexpr double kTol = 1e-11;  // mm: far below the 1e-9 mm a round trip must hold
  Eigen::Matrix<double, 6, 1> f;
  Eigen::Matrix<double, 6, 6> jx;
  double first = -1;
  for (int it = 0;; ++it) {
    residual(sliders, h, r, f, &jx);
    const double size = f.cwiseAbs().maxCoeff();
    s.iterations = it;
    s.residual_mm = size;
    if (!std::isfinite(size)) {
      s.status = Status::diverged;
      return s;
    }
    if (first < 0) first = size;
    if (size <= kTol) break;
    if (it >= kMaxIter) {
      s.status = Status::no_convergence;
      return s;
    }
    if (it > 3 && size > 1e3 * std::max(first, 1.0)) {
      s.status = Status::diverged;
      return s;
    }
    Eigen::Matrix<double, 6, 1> dx = -f;
    if (!solve_small<6, 1>(jx, dx)) {
      s.status = Status::singular;
      return s;
    }
    h += dx.head<3>();
    // Large rotation steps early on are damped: the loop equations are only locally linear.
    Eigen::Vector3d w = dx.tail<3>();
    if (w.norm() > 0.3) w *= 0.3 / w.norm();
    r = exp_so3(w) * r;
    // Converging quadratically, a step this small leaves a residual of order step²/l: check it
    // without paying for another Jacobian and solve.
    if (dx.head<3>().norm() + 1e3 * w.norm() < 1e-8) {
      residual(sliders, h, r, f, nullptr);
      s.iterations = it + 1;
      s.residual_mm = f.cwiseAbs().maxCoeff();
      if (!(s.residual_mm <= kTol)) {
        s.status = Status::no_convergence;
        return s;
      }
      break;
    }
  }
  // Another assembly mode (a link folded back past its slider, the platform turned over) also
  // closes the loops; it is not this machine's.
  for (int i = 0; i < 3; ++i) {
    const Limb& l = limbs_[static_cast<std::size_t>(i)];
    const Eigen::Vector3d d = h + r * l.r - l.b - (sliders[i] + l.dq) * l.u;
    if (d.dot(l.u) <= 0 || r(2, 2) <= 0) {
      s.status = Status::diverged;
      return s;
    }
  }
  tip = h;
  r_t = r;
  return s;
}

Solve PrsHybrid::forward(const JointVector& q, Pose& out) const {
  Eigen::Vector3d tip;
  Eigen::Matrix3d r_t;
  const Solve s = platform_forward(q.segment<3>(2), tip, r_t);
  if (s.ok()) out = to_workpiece(tip, r_t, q[0], q[1]);
  return s;
}

Jacobian PrsHybrid::jacobian(const JointVector& q) const {
  Jacobian j = Jacobian::Zero(6, 5);
  Eigen::Vector3d tip;
  Eigen::Matrix3d r_t;
  if (!platform_forward(q.segment<3>(2), tip, r_t).ok()) {
    j.setConstant(std::numeric_limits<double>::quiet_NaN());
    return j;
  }
  Eigen::Matrix<double, 6, 1> f;
  Eigen::Matrix<double, 6, 6> jx;
  residual(q.segment<3>(2), tip, r_t, f, &jx);
  // ∂F/∂q_i: only limb i's rows, d moves by −u_i; F2 is blind to it (y ⟂ u).
  Eigen::Matrix<double, 6, 3> jq = Eigen::Matrix<double, 6, 3>::Zero();
  for (int i = 0; i < 3; ++i) {
    const Limb& l = limbs_[static_cast<std::size_t>(i)];
    const Eigen::Vector3d d = tip + r_t * l.r - l.b - (q[2 + i] + l.dq) * l.u;
    jq(2 * i, i) = -d.dot(l.u) / l.lp;
  }
  Eigen::Matrix<double, 6, 3> dx = -jq;
  if (!solve_small<6, 3>(jx, dx)) dx.setConstant(std::numeric_limits<double>::quiet_NaN());
  j(0, 0) = 1;  // X, Y shift the tool relative to the workpiece without turning it
  j(1, 1) = 1;
  for (int c = 0; c < 3; ++c) {
    j.block<3, 1>(0, 2 + c) = flip(Eigen::Vector3d(dx.block<3, 1>(0, c)));
    j.block<3, 1>(3, 2 + c) = flip(Eigen::Vector3d(dx.block<3, 1>(3, c)));
  }
  return j;
}

Solve PrsHybrid::nominal_inverse(const Pose& target, JointVector& q) const {
  Solve s;
  // The nominal 3-PRS platform has ψ = 0 and its centre O' drifts in the base XY plane by
  // x = −a/2·(1 − cos θ)·cos 2φ, y = a/2·(1 − cos θ)·sin 2φ (the joint-plane conditions
  // −x sin α_i + y cos α_i = −a/2·(1 − cos θ)·sin(2α_i − 2φ) hold for all three limbs because
  // (−sin α_i, cos α_i) = (sin 2α_i, cos 2α_i) at α_i = 0, 120°, 240°). Written in n = Z':
  // (1 − cos θ)·(cos 2φ, sin 2φ) = (n_x² − n_y², 2 n_x n_y)/(1 + n_z).
  const Eigen::Vector3d n = -flip(Eigen::Vector3d(target.axis().normalized()));
  if (n.z() <= 1e-9) {
    s.status = Status::unreachable;
    return s;
  }
  const double a = geom_.platform_radius, b = geom_.base_radius, l = geom_.link_length;
  const Eigen::Matrix3d r_t = tilt_rotation(n);
  const double hz = geom_.workpiece_origin.z() - target.p.z();
  Eigen::Vector3d centre(-0.5 * a * (n.x() * n.x() - n.y() * n.y()) / (1 + n.z()), a * n.x() * n.y() / (1 + n.z()),
                         hz - geom_.tool_length * n.z());
  const Eigen::Vector3d tip = centre + geom_.tool_length * n;
  q.resize(5);
  q[0] = target.p.x() - tip.x() + geom_.workpiece_origin.x();
  q[1] = target.p.y() + tip.y() - geom_.workpiece_origin.y();
  const Eigen::Vector3d u0(std::sin(geom_.guide_tilt), 0, std::cos(geom_.guide_tilt));
  for (int i = 0; i < 3; ++i) {
    const Eigen::Matrix3d& ri = limb_rotations()[static_cast<std::size_t>(i)];
    const Eigen::Vector3d d0 = centre + r_t * (ri * Eigen::Vector3d(a, 0, 0)) - ri * Eigen::Vector3d(b, 0, 0);
    const Eigen::Vector3d u = ri * u0;
    const double along = d0.dot(u);
    const double disc = along * along - d0.squaredNorm() + l * l;
    if (disc < 0) {
      s.status = Status::unreachable;
      return s;
    }
    q[2 + i] = along - std::sqrt(disc);  // the slider on the base side of the sphere centre
  }
  return s;
}

Solve PrsHybrid::inverse(const Pose& target, const JointVector& start, JointVector& q, const IkOptions& opt) const {
  if (opt.match == PoseMatch::full) {
    JointVector seed;
    if (!inverse(target, start, seed, IkOptions{PoseMatch::point_and_axis, opt.tolerance_mm, opt.tolerance_rad,
                                                  opt.max_iterations, false})
             .ok())
      seed = start;
    return Model::inverse(target, seed, q, opt);
  }
  Solve s;
  q.resize(5);
  // The tilt fixes R_T = T(n)·Rz(ψ) and the target fixes H_z; the three joint-plane conditions
  // y_i·(H + T Rz(ψ) r_i − b_i) = c_i (the slider's own motion is along u_i ⟂ y_i) leave
  // (H_x, H_y, ψ). Start from the nominal solution; errors of document 001's size take 2–3 steps.
  const Eigen::Vector3d n = -flip(Eigen::Vector3d(target.axis().normalized()));
  if (n.z() <= 1e-9) {  // the tool would point into the head
    s.status = Status::unreachable;
    return s;
  }
  const Eigen::Matrix3d tilt = tilt_rotation(n);
  const double hz = geom_.workpiece_origin.z() - target.p.z();
  const double a = geom_.platform_radius;
  Eigen::Vector3d x(-0.5 * a * (n.x() * n.x() - n.y() * n.y()) / (1 + n.z()) + geom_.tool_length * n.x(),
                    a * n.x() * n.y() / (1 + n.z()) + geom_.tool_length * n.y(), 0.0);  // H_x, H_y, ψ
  Eigen::Matrix3d r_t = tilt;
  for (int it = 0;; ++it) {
    r_t = tilt * rot_z(x[2]);
    const Eigen::Vector3d tip(x[0], x[1], hz);
    Eigen::Vector3d g;
    Eigen::Matrix3d jg;
    for (int i = 0; i < 3; ++i) {
      const Limb& l = limbs_[static_cast<std::size_t>(i)];
      const Eigen::Vector3d w = r_t * l.r;
      g[i] = l.y.dot(tip + w - l.b) - l.cy;
      jg(i, 0) = l.y.x();
      jg(i, 1) = l.y.y();
      jg(i, 2) = l.y.dot(r_t * Eigen::Vector3d(-l.r.y(), l.r.x(), 0.0));  // d/dψ: T·Rz(ψ)·(e_z × r)
    }
    s.iterations = it;
    s.residual_mm = g.cwiseAbs().maxCoeff();
    if (!std::isfinite(s.residual_mm)) {
      s.status = Status::diverged;
      return s;
    }
    if (s.residual_mm <= opt.tolerance_mm) break;
    if (it >= opt.max_iterations) {
      s.status = Status::no_convergence;
      return s;
    }
    Eigen::Vector3d dx = -g;
    if (!solve_small<3, 1>(jg, dx)) {
      s.status = Status::singular;
      return s;
    }
    x += dx;
  }
  const Eigen::Vector3d tip(x[0], x[1], hz);
  q[0] = target.p.x() - tip.x() + geom_.workpiece_origin.x();
  q[1] = target.p.y() + tip.y() - geom_.workpiece_origin.y();
  for (int i = 0; i < 3; ++i) {
    // |d0 − q' u|² = l'² with d0 the link vector at the zero of the slider; y·d0 is already c_y.
    const Limb& l = limbs_[static_cast<std::size_t>(i)];
    const Eigen::Vector3d d0 = tip + r_t * l.r - l.b;
    const double along = d0.dot(l.u);
    const double disc = along * along - d0.squaredNorm() + l.lp * l.lp;
    if (disc < 0) {
      s.status = Status::unreachable;
      return s;
    }
    q[2 + i] = along - std::sqrt(disc) - l.dq;
  }
  s.residual_rad = 0;  // the axis is met by construction
  if (opt.check_limits) {
    s.joint = joint_outside_limits(*this, q);
    if (s.joint >= 0) s.status = Status::out_of_limits;
  }
  return s;
}

PrsHybrid::IdentificationJacobian PrsHybrid::identification_jacobian(const JointVector& q, Solve* s) const {
  IdentificationJacobian out;
  Eigen::Vector3d tip;
  Eigen::Matrix3d r_t;
  const Eigen::Vector3d sl = q.segment<3>(2);
  const Solve fs = platform_forward(sl, tip, r_t);
  if (s != nullptr) *s = fs;
  if (!fs.ok()) {
    out.setConstant(std::numeric_limits<double>::quiet_NaN());
    return out;
  }
  Eigen::Matrix<double, 6, 1> f;
  Eigen::Matrix<double, 6, 6> jx;
  residual(sl, tip, r_t, f, &jx);
  // ∂F/∂r column by column (eq. 9): each error parameter enters only its own limb's two rows.
  Eigen::Matrix<double, 6, kErrorCount> fr = Eigen::Matrix<double, 6, kErrorCount>::Zero();
  const Eigen::Matrix3d rb = rot_y(geom_.guide_tilt);
  for (int i = 0; i < 3; ++i) {
    const Limb& l = limbs_[static_cast<std::size_t>(i)];
    const double* e = values_.data() + i * kLimbErrors;
    const int c0 = i * kLimbErrors;
    const double qp = sl[i] + l.dq;
    const Eigen::Vector3d d = tip + r_t * l.r - l.b - qp * l.u;
    // dd → (dF1, dF2) for a change dd of the link vector with the frame G fixed.
    auto put = [&](int col, const Eigen::Vector3d& dd) {
      fr(2 * i, c0 + col) = d.dot(dd) / l.lp;
      fr(2 * i + 1, c0 + col) = l.y.dot(dd);
    };
    const Eigen::Matrix3d& ri = limb_rotations()[static_cast<std::size_t>(i)];
    const Eigen::Matrix3d rtri = r_t * ri;
    put(da_x, rtri.col(0));
    put(da_y, rtri.col(1));
    put(da_z, rtri.col(2));
    put(db_x, -ri.col(0));
    put(db_y, -ri.col(1));
    put(dq, -l.u);
    // Guide-frame rotations G = R_i R_B Rx Ry Rz: dG/dt = (prefix)·[e]×·(suffix), each factor's
    // derivative written on its right ([e]× commutes with a rotation about e); both u and y turn.
    const Eigen::Matrix3d pre = ri * rb;
    const Eigen::Matrix3d mx = rot_x(e[tb_x]), my = rot_y(e[tb_y]), mz = rot_z(e[tb_z]);
    const std::array<Eigen::Matrix3d, 3> prefix{pre * mx, pre * mx * my, pre * mx * my * mz};
    const std::array<Eigen::Matrix3d, 3> suffix{my * mz, mz, Eigen::Matrix3d::Identity()};
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d ax = Eigen::Vector3d::Unit(k);
      const Eigen::Matrix3d& p = prefix[static_cast<std::size_t>(k)];
      const Eigen::Matrix3d& sfx = suffix[static_cast<std::size_t>(k)];
      const Eigen::Vector3d du = p * ax.cross(sfx.col(2));
      const Eigen::Vector3d dy = p * ax.cross(sfx.col(1));
      fr(2 * i, c0 + tb_x + k) = -qp * d.dot(du) / l.lp;
      fr(2 * i + 1, c0 + tb_x + k) = dy.dot(d) - qp * l.y.dot(du);
    }
    fr(2 * i + 1, c0 + tc_x) = l.lp * std::cos(e[tc_x]);
    fr(2 * i, c0 + dl) = -(d.squaredNorm() + l.lp * l.lp) / (2 * l.lp * l.lp);
    fr(2 * i + 1, c0 + dl) = std::sin(e[tc_x]);
  }
  Eigen::Matrix<double, 6, kErrorCount> dx = -fr;
  if (!solve_small<6, kErrorCount>(jx, dx)) dx.setConstant(std::numeric_limits<double>::quiet_NaN());
  for (int c = 0; c < kErrorCount; ++c) {
    out.block<3, 1>(0, c) = flip(Eigen::Vector3d(dx.block<3, 1>(0, c)));
    out.block<3, 1>(3, c) = flip(Eigen::Vector3d(dx.block<3, 1>(3, c)));
  }
  return out;
}

std::shared_ptr<const PrsHybrid> make_document001_machine() {
  PrsHybridGeometry g;
  g.base_radius = 220;
  g.platform_radius = 201;
  g.link_length = 487;
  g.tool_length = 150;
  g.guide_tilt = 0;
  return std::make_shared<const PrsHybrid>(g);
}

std::array<double, PrsHybrid::kErrorCount> document001_table1_errors() {
  // Rows = limbs, columns as printed (see the header for the reading of units and order).
  static constexpr double kTable[3][PrsHybrid::kLimbErrors] = {
      {3.000, 2.000, 4.000, -1.000, 2.000, 0.010, 0.019, 0.013, 0.009, 3.000, 2.000},
      {2.000, 1.000, 2.000, -3.000, 1.000, 0.052, -0.020, 0.020, 0.010, -3.000, 5.000},
      {1.000, 2.000, 3.000, -5.000, -1.000, 0.014, -0.013, -0.052, -0.015, 1.000, -3.000},
  };
  std::array<double, PrsHybrid::kErrorCount> e{};
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < PrsHybrid::kLimbErrors; ++k) {
      const bool angle = k >= tb_x && k <= tc_x;
      e[static_cast<std::size_t>(i * PrsHybrid::kLimbErrors + k)] = kTable[i][k] * (angle ? kDeg : 1.0);
    }
  return e;
}

}  // namespace postproc::kin
