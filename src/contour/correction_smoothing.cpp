// Smoothing of a run's correction and the drives' lag of it (correction_smoothing.hpp).
#include "src/contour/correction_smoothing.hpp"

#include <array>

namespace postproc::contour {

/// Smoother of a sequence sampled at times t_k: x = argmin Σ(x_k − d_k)² + Σ(τ²·D²x_k)², D² the
/// second divided difference. The matrix I + Σ r_k r_kᵀ is symmetric positive definite and
/// pentadiagonal: factored once (LDLᵀ, band 2) and applied to every joint.
Smoother::Smoother(const std::vector<double>& t, double tau) : m_(t.size()) {
  std::vector<double> a0(m_, 1.0), a1(m_, 0.0), a2(m_, 0.0);  // A(i,i), A(i,i+1), A(i,i+2)
  const double w = tau * tau;
  for (std::size_t k = 1; k + 1 < m_; ++k) {
    const double ha = t[k] - t[k - 1], hb = t[k + 1] - t[k];
    if (!(ha > 0) || !(hb > 0)) continue;
    const double s = 2 * w / (ha + hb);
    const std::array<double, 3> r{s / ha, -s / ha - s / hb, s / hb};  // at k−1, k, k+1
    for (int u = 0; u < 3; ++u) {
      a0[k - 1 + static_cast<std::size_t>(u)] += r[static_cast<std::size_t>(u)] * r[static_cast<std::size_t>(u)];
    }
    a1[k - 1] += r[0] * r[1];
    a1[k] += r[1] * r[2];
    a2[k - 1] += r[0] * r[2];
  }
  d_.assign(m_, 0.0);
  l1_.assign(m_, 0.0);  // L(i+1, i)
  l2_.assign(m_, 0.0);  // L(i+2, i)
  for (std::size_t i = 0; i < m_; ++i) {
    double di = a0[i];
    if (i >= 1) di -= l1_[i - 1] * l1_[i - 1] * d_[i - 1];
    if (i >= 2) di -= l2_[i - 2] * l2_[i - 2] * d_[i - 2];
    d_[i] = di;
    if (i + 1 < m_) {
      double v = a1[i];
      if (i >= 1) v -= l2_[i - 1] * l1_[i - 1] * d_[i - 1];
      l1_[i] = v / di;
    }
    if (i + 2 < m_) l2_[i] = a2[i] / di;
  }
}

void Smoother::apply(std::vector<double>& x) const {
  for (std::size_t i = 1; i < m_; ++i) {
    x[i] -= l1_[i - 1] * x[i - 1];
    if (i >= 2) x[i] -= l2_[i - 2] * x[i - 2];
  }
  for (std::size_t i = 0; i < m_; ++i) x[i] /= d_[i];
  for (std::size_t i = m_; i-- > 0;) {
    if (i + 1 < m_) x[i] -= l1_[i] * x[i + 1];
    if (i + 2 < m_) x[i] -= l2_[i] * x[i + 2];
  }
}


void run_step(const Path& path, const std::vector<std::size_t>& idx, const Smoother* smoother,
              std::vector<kin::JointVector>& step, bool invert_lag, std::vector<double>& column) {
  const int n = path.joints;
  if (smoother != nullptr) {
    column.resize(idx.size());
    for (int j = 0; j < n; ++j) {
      for (std::size_t k = 0; k < idx.size(); ++k) column[k] = step[idx[k]][j];
      smoother->apply(column);
      for (std::size_t k = 0; k < idx.size(); ++k) step[idx[k]][j] = column[k];
    }
  }
  if (!invert_lag || idx.size() < 2) return;
  // The lag of the shift: from the shifts before this point's own lag is added (a copy of the
  // neighbours' values as they were).
  kin::JointVector prev = step[idx[0]];
  for (std::size_t k = 0; k < idx.size(); ++k) {
    const std::size_t lo = k > 0 ? idx[k - 1] : idx[k];
    const std::size_t hi = k + 1 < idx.size() ? idx[k + 1] : idx[k];
    const double dt = path.points[hi].t - path.points[lo].t;
    const kin::JointVector here = step[idx[k]];
    const kin::JointVector& before = k > 0 ? prev : here;
    if (dt > 0)
      for (int j = 0; j < n; ++j)
        step[idx[k]][j] += path.drives[static_cast<std::size_t>(j)].lag((step[hi][j] - before[j]) / dt);
    prev = here;
  }
}

}  // namespace postproc::contour
