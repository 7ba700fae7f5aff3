// Normal equations of an end-point correction from simulated samples, and their block-tridiagonal
// solve along a run (learning_control.hpp).
#include "postproc/contour/learning_control.hpp"

#include <algorithm>
#include <optional>

#include <Eigen/Cholesky>

#include "postproc/contour/precompensate.hpp"
#include "src/contour/correction_smoothing.hpp"

namespace postproc::contour {
namespace {

using Block = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kin::kMaxJoints, kin::kMaxJoints>;
using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kin::kMaxJoints, 1>;
using Rows = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, kin::kMaxJoints>;

}  // namespace

SampleEquations::SampleEquations(const Path& path, double orientation_length_mm)
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
}

void SampleEquations::clear() {
  std::fill(diag_.begin(), diag_.end(), 0.0);
  std::fill(off_.begin(), off_.end(), 0.0);
  std::fill(grad_.begin(), grad_.end(), 0.0);
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

void SampleEquations::take_run(const SampleEquations& other, const Run& run) {
  const auto nn = static_cast<std::ptrdiff_t>(n_ * n_), n = static_cast<std::ptrdiff_t>(n_);
  const auto b = static_cast<std::ptrdiff_t>(run.begin), e = static_cast<std::ptrdiff_t>(run.end);
  std::copy(other.diag_.begin() + b * nn, other.diag_.begin() + e * nn, diag_.begin() + b * nn);
  std::copy(other.off_.begin() + b * nn, other.off_.begin() + e * nn, off_.begin() + b * nn);
  std::copy(other.grad_.begin() + b * n, other.grad_.begin() + e * n, grad_.begin() + b * n);
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

}  // namespace postproc::contour
