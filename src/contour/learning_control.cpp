// Normal equations of an end-point correction from simulated samples, and their block-tridiagonal
// solve along a run (learning_control.hpp).
#include "postproc/contour/learning_control.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>

#include "postproc/contour/precompensate.hpp"
#include "src/contour/correction_smoothing.hpp"

namespace postproc::contour {
namespace {

using Block = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kin::kMaxJoints, kin::kMaxJoints>;
using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kin::kMaxJoints, 1>;
using Rows = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, kin::kMaxJoints>;

/// The drive's actual position for the unit ramp command r(τ) = max(τ, 0) from rest (mm per
/// mm/s): τ − e(τ), e the following error of a command that starts moving at unit speed.
double ramp_response(const Drive& d, double tau, double horizon) {
  if (!(tau > 0)) return 0;
  if (tau >= horizon) return tau - d.lag(1.0);
  ErrorState e;
  velocity_jump(d, e, 1.0);
  propagate(d, e, 1.0, tau);
  return tau - e.e;
}

/// The dynamic model is used on runs with at most this many points, on average, within the
/// response horizon (learning_control.hpp).
constexpr double kDynamicPointsPerHorizon = 24;

/// Time constant of the slowest decaying mode of a drive's loop, s.
double slowest_mode(const Drive& d) {
  const double T = d.velocity_loop_time;
  if (!(d.kv > 0)) return 0;
  if (!(T > 0)) return 1 / d.kv;
  const double disc = 1 - 4 * T * d.kv;  // roots of T·s² + s + Kv
  if (disc > 0) return 2 * T / (1 - std::sqrt(disc));
  return 2 * T;
}

}  // namespace

SampleEquations::SampleEquations(const Path& path, double orientation_length_mm, bool dynamic)
    : path_(&path), length_(orientation_length_mm), n_(path.joints) {
  const std::size_t np = path.points.size(), nn = static_cast<std::size_t>(n_ * n_);
  correctable_.assign(np, 0);
  for (const Run& run : path.runs)
    for (std::size_t i = run.begin; i < run.end; ++i) correctable_[i] = correctable(path, run, i) ? 1 : 0;
  weight_tip_.assign(path.runs.size(), 1.0);
  weight_axis_.assign(path.runs.size(), 1.0);
  diag_.assign(np * nn, 0.0);
  off_.assign(np * nn, 0.0);
  grad_.assign(np * static_cast<std::size_t>(n_), 0.0);
  dynamic_at_.assign(np, 0);
  if (dynamic) {
    band_.assign(np, {});
    for (const Drive& d : path.drives) horizon_ = std::max(horizon_, 8 * slowest_mode(d));
    for (const Run& run : path.runs) {
      if (run.end - run.begin < 3 || run.end > np) continue;
      const double duration = path.points[run.end - 1].t - path.points[run.begin].t;
      const bool sparse = duration > 0 && static_cast<double>(run.end - run.begin - 1) * horizon_ / duration <=
                                              kDynamicPointsPerHorizon;
      std::fill(dynamic_at_.begin() + static_cast<std::ptrdiff_t>(run.begin),
                dynamic_at_.begin() + static_cast<std::ptrdiff_t>(run.end), sparse ? 1 : 0);
    }
  }
}

void SampleEquations::clear() {
  std::fill(diag_.begin(), diag_.end(), 0.0);
  std::fill(off_.begin(), off_.end(), 0.0);
  std::fill(grad_.begin(), grad_.end(), 0.0);
  for (std::vector<double>& b : band_) b.clear();
}

void SampleEquations::weigh(std::size_t run, double tip, double axis) {
  if (run >= weight_tip_.size()) return;
  weight_tip_[run] = tip;
  weight_axis_[run] = axis;
}

void SampleEquations::add(const SampleVisit& s) {
  if (s.segment == 0 || s.segment >= correctable_.size()) return;
  const std::size_t a = s.segment - 1, b = s.segment;
  const double wa = correctable_[a] != 0 ? 1 - s.fraction : 0.0, wb = correctable_[b] != 0 ? s.fraction : 0.0;
  if (wa == 0 && wb == 0) return;
  if (s.error.distance == 0 && s.error.angle == 0) return;
  const int n = n_;
  const kin::Jacobian jac = s.model.jacobian(s.actual);
  const Eigen::Vector3d& o = s.error.axis;
  const Eigen::Matrix3d tilt = Eigen::Matrix3d::Identity() - o * o.transpose();
  Rows rows(6, n);
  const double wt = s.run < weight_tip_.size() ? weight_tip_[s.run] : 1.0;
  const double wr = (s.run < weight_axis_.size() ? weight_axis_[s.run] : 1.0) * length_;
  rows.topRows<3>() = wt * jac.topRows<3>();
  rows.bottomRows<3>() = wr * (tilt * jac.bottomRows<3>());
  Eigen::Matrix<double, 6, 1> eps;
  eps.head<3>() = wt * s.error.vector;
  eps.tail<3>() = wr * (tilt * s.error.rotation);
  if (s.path != nullptr && s.path->points.size() == correctable_.size() && dynamic_at_[s.segment] != 0) {
    add_dynamic(s, rows.data(), eps.data());
    return;
  }
  const Block ata = rows.transpose() * rows;
  const Vec ate = rows.transpose() * eps;
  const auto nn = static_cast<std::size_t>(n * n);
  Eigen::Map<Eigen::MatrixXd> da(diag_.data() + a * nn, n, n), db(diag_.data() + b * nn, n, n),
      oa(off_.data() + a * nn, n, n);
  Eigen::Map<Eigen::VectorXd> ga(grad_.data() + a * static_cast<std::size_t>(n), n),
      gb(grad_.data() + b * static_cast<std::size_t>(n), n);
  if (wa != 0) {
    da += wa * wa * ata;
    ga += wa * ate;
  }
  if (wb != 0) {
    db += wb * wb * ata;
    gb += wb * ate;
  }
  if (wa != 0 && wb != 0) oa += wa * wb * ata;
}

void SampleEquations::add_dynamic(const SampleVisit& s, const double* row_data, const double* eps_data) {
  const Path& p = *s.path;
  const int n = n_;
  const auto nn = static_cast<std::size_t>(n * n);
  if (s.run >= p.runs.size()) return;
  const Run& run = p.runs[s.run];
  const Eigen::Map<const Rows> rows(row_data, 6, n);
  const Eigen::Map<const Eigen::Matrix<double, 6, 1>> eps(eps_data);
  const Block ata = rows.transpose() * rows;
  const Vec ate = rows.transpose() * eps;
  // The correctable points whose hat has begun (t_{k−1} < t) and whose response has not died out
  // (t < t_{k+1} + horizon), latest first; each with ψ_k(t) per joint. A side of the hat shorter
  // than one interpolation period is taken as one period (the interpolator samples no finer).
  struct Reach {
    std::size_t k;
    Vec psi;
  };
  thread_local std::vector<Reach> reach;
  reach.clear();
  const double dt = p.period > 0 ? p.period : 1e-3;
  for (std::size_t k = std::min(s.segment, run.end - 1); k > run.begin; --k) {
    if (k + 1 < run.end && p.points[k + 1].t + horizon_ <= s.t) break;
    if (correctable_[k] == 0 || k + 1 >= run.end) continue;
    const double t1 = p.points[k].t;
    const double d1 = std::max(t1 - p.points[k - 1].t, dt), d2 = std::max(p.points[k + 1].t - t1, dt);
    if (!(s.t > t1 - d1)) continue;
    Vec psi(n);
    bool any = false;
    for (int j = 0; j < n; ++j) {
      const Drive& d = p.drives[static_cast<std::size_t>(j)];
      const double r0 = ramp_response(d, s.t - (t1 - d1), horizon_), r1 = ramp_response(d, s.t - t1, horizon_),
                   r2 = ramp_response(d, s.t - (t1 + d2), horizon_);
      psi[j] = (r0 - r1) / d1 - (r1 - r2) / d2;
      any = any || std::abs(psi[j]) > 1e-9;
    }
    if (any) reach.push_back(Reach{k, psi});
  }
  for (std::size_t a = 0; a < reach.size(); ++a) {
    const Reach& ra = reach[a];
    Eigen::Map<Eigen::VectorXd>(grad_.data() + ra.k * static_cast<std::size_t>(n), n) +=
        ra.psi.cwiseProduct(ate);
    Eigen::Map<Eigen::MatrixXd>(diag_.data() + ra.k * nn, n, n) +=
        ra.psi.asDiagonal() * ata * ra.psi.asDiagonal();
    for (std::size_t b = 0; b < a; ++b) {  // reach[b].k > ra.k
      const Reach& rb = reach[b];
      std::vector<double>& band = band_[ra.k];
      const std::size_t off = (rb.k - ra.k - 1) * nn;
      if (band.size() < off + nn) band.resize(off + nn, 0.0);
      Eigen::Map<Eigen::MatrixXd>(band.data() + off, n, n) += ra.psi.asDiagonal() * ata * rb.psi.asDiagonal();
    }
  }
}

void SampleEquations::take_run(const SampleEquations& other, const Run& run) {
  const auto nn = static_cast<std::ptrdiff_t>(n_ * n_), n = static_cast<std::ptrdiff_t>(n_);
  const auto b = static_cast<std::ptrdiff_t>(run.begin), e = static_cast<std::ptrdiff_t>(run.end);
  std::copy(other.diag_.begin() + b * nn, other.diag_.begin() + e * nn, diag_.begin() + b * nn);
  std::copy(other.off_.begin() + b * nn, other.off_.begin() + e * nn, off_.begin() + b * nn);
  std::copy(other.grad_.begin() + b * n, other.grad_.begin() + e * n, grad_.begin() + b * n);
  if (other.band_.size() == band_.size())
    for (std::size_t i = run.begin; i < run.end && i < band_.size(); ++i) band_[i] = other.band_[i];
}

void SampleEquations::solve(const Run& run, const LearningOptions& opt, std::vector<kin::JointVector>& step) const {
  const Path& path = *path_;
  const int n = n_;
  const auto nn = static_cast<std::size_t>(n * n);
  std::vector<std::size_t> idx;
  std::vector<double> times;
  for (std::size_t i = run.begin; i < run.end; ++i)
    if (correctable_[i] != 0) {
      idx.push_back(i);
      times.push_back(path.points[i].t);
    }
  if (idx.empty()) return;
  if (dynamic_at_[run.begin] != 0) return solve_dynamic(run, opt, idx, step);
  const auto diag = [&](std::size_t i) { return Eigen::Map<const Eigen::MatrixXd>(diag_.data() + i * nn, n, n); };
  const auto grad = [&](std::size_t i) {
    return Eigen::Map<const Eigen::VectorXd>(grad_.data() + i * static_cast<std::size_t>(n), n);
  };
  // Damping: relative to each block's diagonal, plus a floor relative to the run's largest
  // diagonal entry (points no sample reaches, joints that move nothing: their shift stays 0).
  double largest = 0;
  for (std::size_t i : idx) largest = std::max(largest, diag(i).diagonal().maxCoeff());
  if (!(largest > 0)) return;
  const double floor = 1e-9 * largest;
  // Block elimination along the run (the symmetric block-tridiagonal Thomas algorithm): the
  // points idx[k] and idx[k + 1] are coupled when they are neighbours on the path.
  const std::size_t m = idx.size();
  std::vector<Eigen::LDLT<Block>> pivot(m);
  std::vector<Block> couple(m);  // B_k: coupling of idx[k] with idx[k + 1] (zero if not neighbours)
  std::vector<Vec> y(m);
  for (std::size_t k = 0; k < m; ++k) {
    Block a = diag(idx[k]);
    a.diagonal() += opt.damping * a.diagonal() + Vec::Constant(n, floor);
    Vec g = grad(idx[k]);
    if (k > 0) {
      // A'_k = A_k − B_{k−1}ᵀ A'_{k−1}⁻¹ B_{k−1};  y_k = g_k − B_{k−1}ᵀ A'_{k−1}⁻¹ y_{k−1}.
      const Block& bprev = couple[k - 1];
      a -= bprev.transpose() * pivot[k - 1].solve(bprev);
      g -= bprev.transpose() * pivot[k - 1].solve(y[k - 1]);
    }
    pivot[k].compute(a);
    y[k] = g;
    if (k + 1 < m && idx[k + 1] == idx[k] + 1)
      couple[k] = Eigen::Map<const Eigen::MatrixXd>(off_.data() + idx[k] * nn, n, n);
    else
      couple[k] = Block::Zero(n, n);
  }
  std::vector<Vec> x(m);
  for (std::size_t k = m; k-- > 0;) {
    Vec r = y[k];
    if (k + 1 < m) r -= couple[k] * x[k + 1];
    x[k] = pivot[k].solve(r);
  }
  for (std::size_t k = 0; k < m; ++k) step[idx[k]] = x[k];
  double lag_time = 0;
  for (const Drive& d : path.drives) lag_time = std::max(lag_time, d.lag(1.0));
  const double tau = opt.smoothing * lag_time;
  std::optional<Smoother> smoother;
  if (tau > 0 && m >= 3) smoother.emplace(times, tau);
  std::vector<double> column;
  run_step(path, idx, smoother ? &*smoother : nullptr, step, true, column);
}

void SampleEquations::solve_dynamic(const Run& run, const LearningOptions& opt, const std::vector<std::size_t>& idx,
                                    std::vector<kin::JointVector>& step) const {
  const int n = n_;
  const auto nn = static_cast<std::size_t>(n * n);
  const std::size_t m = idx.size();
  std::vector<std::ptrdiff_t> col(run.end - run.begin, -1);  // point → first unknown, −1: fixed
  for (std::size_t k = 0; k < m; ++k) col[idx[k] - run.begin] = static_cast<std::ptrdiff_t>(k) * n;
  double largest = 0;
  for (std::size_t i : idx)
    largest = std::max(largest, Eigen::Map<const Eigen::MatrixXd>(diag_.data() + i * nn, n, n).diagonal().maxCoeff());
  if (!(largest > 0)) return;
  const double floor = 1e-9 * largest;
  std::vector<Eigen::Triplet<double>> entries;
  Eigen::VectorXd g(static_cast<Eigen::Index>(m) * n);
  for (std::size_t k = 0; k < m; ++k) {
    const std::size_t i = idx[k];
    const auto c = static_cast<int>(k) * n;
    const Eigen::Map<const Eigen::MatrixXd> d(diag_.data() + i * nn, n, n);
    g.segment(c, n) = Eigen::Map<const Eigen::VectorXd>(grad_.data() + i * static_cast<std::size_t>(n), n);
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b)
        entries.emplace_back(c + a, c + b, d(a, b) + (a == b ? opt.damping * d(a, a) + floor : 0.0));
    const std::vector<double>& band = band_[i];
    for (std::size_t off = 0; off + nn <= band.size(); off += nn) {
      const std::size_t l = i + 1 + off / nn;
      if (l >= run.end || col[l - run.begin] < 0) continue;
      const auto cl = static_cast<int>(col[l - run.begin]);
      const Eigen::Map<const Eigen::MatrixXd> o(band.data() + off, n, n);
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) {
          if (o(a, b) == 0) continue;
          entries.emplace_back(c + a, cl + b, o(a, b));
          entries.emplace_back(cl + b, c + a, o(a, b));
        }
    }
  }
  Eigen::SparseMatrix<double> a(g.size(), g.size());
  a.setFromTriplets(entries.begin(), entries.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(a);
  if (ldlt.info() != Eigen::Success) return;
  const Eigen::VectorXd x = ldlt.solve(g);
  if (ldlt.info() != Eigen::Success || !x.allFinite()) return;
  for (std::size_t k = 0; k < m; ++k) step[idx[k]] = x.segment(static_cast<Eigen::Index>(k) * n, n);
}

}  // namespace postproc::contour
