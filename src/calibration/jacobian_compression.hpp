#pragma once
// The weighted residuals of many measurements and their Jacobian, compressed as they are formed
// (a tall-skinny QR in chunks): what a Gauss–Newton step, the identifiability analysis and the
// covariance need is R and Qᵀr of the thin QR of [J r], never J itself. Memory is independent
// of the number of measurements, and chunks are formed on several threads and combined in a
// fixed order, so the result does not depend on the thread count.
#include <cstddef>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "postproc/calibration/measurement.hpp"
#include "src/calibration/frame_registration.hpp"
#include "src/calibration/measurement_residual.hpp"

namespace ceres {
class LossFunction;
}

namespace postproc::cal::lsq {

struct LineariseOptions {
  /// Threads forming chunks; used only where every derivative is analytic (serial chains).
  int threads = 1;
  /// Robust loss ρ on each measurement's ‖rᵢ‖²: its rows are scaled by √ρ′ (iteratively
  /// reweighted least squares, whose fixed point is the robust problem's stationary point) and
  /// the cost is ½·Σρ. Null: plain least squares.
  const ceres::LossFunction* loss = nullptr;
  /// Keep ‖rᵢ‖² of every measurement (per-file figures).
  bool per_measurement = false;
};

/// R and Qᵀr of the thin QR of [J r] over every measurement: `aug` is (k+1)×(k+1) upper
/// triangular with J's k columns first (the model's `columns`, then each frame's components).
struct Linearised {
  Eigen::MatrixXd aug;
  double squared = 0;  ///< ‖r‖² (before any loss)
  double cost = 0;     ///< ½‖r‖², or ½Σρ(‖rᵢ‖²) with a loss
  long rows = 0;       ///< residual components
  std::vector<double> per_measurement;
  /// Index of the first measurement the model cannot evaluate (joints outside its reach, a pose
  /// it cannot assume); everything else is then undefined.
  std::ptrdiff_t failed = -1;

  [[nodiscard]] bool ok() const { return failed < 0; }
  [[nodiscard]] Eigen::Index columns() const { return aug.cols() - 1; }
  /// R (k×k, upper triangular): RᵀR = JᵀJ, so R's columns have J's norms and inner products.
  [[nodiscard]] Eigen::MatrixXd r() const { return aug.topLeftCorner(columns(), columns()); }
  /// Qᵀr (k): the part of the residual that the columns can reach.
  [[nodiscard]] Eigen::VectorXd qtr() const { return aug.col(columns()).head(columns()); }
};

/// Adds rows [a b] (a: k columns, b: the residual) to a compression.
void append_rows(Linearised& lin, const Eigen::MatrixXd& rows);

/// Residuals and Jacobian of `data` at `model` by the parameters `columns`, then each frame's
/// registration components (frame_of[i]: the frame of data[i], −1 for the workpiece), compressed.
[[nodiscard]] Linearised linearise(const kin::Model& model, std::span<const Measurement> data,
                                   std::span<const int> columns, std::span<const Weights> weights,
                                   std::span<const FrameState> frames, std::span<const int> frame_of,
                                   std::span<const FrameColumns> frame_columns, bool numeric,
                                   const LineariseOptions& options = {});

}  // namespace postproc::cal::lsq
