#pragma once
// The shared last steps of a contour correction (precompensate.cpp, learning_control.cpp): the
// per-point joint shifts smoothed along the run, and the drives' lag of the shift added.
#include <cstddef>
#include <vector>

#include "postproc/contour/path.hpp"

namespace postproc::contour {

/// Smoother of a sequence sampled at times t_k: x = argmin Σ(x_k − d_k)² + Σ(τ²·D²x_k)², D² the
/// second divided difference. The matrix I + Σ r_k r_kᵀ is symmetric positive definite and
/// pentadiagonal: factored once (LDLᵀ, band 2) and applied to every joint.
class Smoother {
 public:
  Smoother(const std::vector<double>& t, double tau);
  /// Smooths `x` in place.
  void apply(std::vector<double>& x) const;

 private:
  std::size_t m_;
  std::vector<double> d_, l1_, l2_;
};

/// The step of one iteration for the correctable points `idx` of a run: the shifts smoothed along
/// the run, plus the drives' lag of the smoothed shift (δ = x + e₁·ẋ, central differences over the
/// correctable neighbours, one-sided at the ends). Written into `step` (indexed like path points).
void run_step(const Path& path, const std::vector<std::size_t>& idx, const Smoother* smoother,
              std::vector<kin::JointVector>& step, bool invert_lag, std::vector<double>& column);

}  // namespace postproc::contour
