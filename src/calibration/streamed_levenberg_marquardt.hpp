#pragma once
// Levenberg–Marquardt over compressed linearisations (jacobian_compression.hpp), for
// identify() on many measurements: each iteration streams the measurements once, on several
// threads, and keeps only a (k+1)×(k+1) triangle, where a Ceres problem holds a residual block
// per measurement and the whole Jacobian. The step rule is Ceres' (LEVENBERG_MARQUARDT trust
// region with Marquardt's diagonal, the same radius updates and tolerances), so both solvers
// stop at the same minimum; tests/test_streamed_solver.cpp compares them.
#include <span>
#include <string>
#include <vector>

#include "postproc/calibration/identify.hpp"
#include "src/calibration/frame_registration.hpp"
#include "src/calibration/jacobian_compression.hpp"
#include "src/calibration/measurement_residual.hpp"

namespace ceres {
class LossFunction;
}

namespace postproc::cal::lsq {

struct StreamedOptions {
  int max_iterations = 150;
  int threads = 1;
  bool numeric = false;
  const ceres::LossFunction* loss = nullptr;
  /// Ridge: λ·‖x_c − x0_c‖² over the identified parameters (0: none).
  double ridge_lambda = 0;
  double function_tolerance = 1e-12;
  double parameter_tolerance = 1e-12;
  double gradient_tolerance = 1e-14;
  Progress progress;
};

struct StreamedSummary {
  int iterations = 0;  ///< steps tried (accepted or not), as Ceres counts them
  bool usable = false;
  bool converged = false;
  std::string message;
  /// Without a loss or ridge term: the linearisation at the result (per-measurement figures
  /// included), which is what identify() analyses there; otherwise empty (aug of size 0).
  Linearised final;
};

/// Minimises over x[identified] and the frames' estimated registration components (frame_of,
/// columns: as linearise()), from x and the frames' current registration; writes both back.
/// `start`: the linearisation at the start point over the same columns, when the caller has it
/// (saves one pass; used only without a loss or ridge term).
[[nodiscard]] StreamedSummary solve_streamed(const kin::Model& model, std::span<const Measurement> fit,
                                             std::span<const Weights> weights, std::span<const int> identified,
                                             std::vector<FrameState>& frames, std::span<const int> frame_of,
                                             std::span<const FrameColumns> columns, const StreamedOptions& options,
                                             std::vector<double>& x, const Linearised* start = nullptr);

}  // namespace postproc::cal::lsq
