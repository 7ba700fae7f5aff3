// Levenberg–Marquardt on compressed linearisations (streamed_levenberg_marquardt.hpp).
#include "src/calibration/streamed_levenberg_marquardt.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/QR>
#include <fmt/format.h>

#include "src/calibration/jacobian_compression.hpp"

namespace postproc::cal::lsq {
namespace {

// Ceres' defaults for the LEVENBERG_MARQUARDT trust region (ceres::Solver::Options).
constexpr double kInitialRadius = 1e4;
constexpr double kMaxRadius = 1e16;
constexpr double kMinRadius = 1e-32;
constexpr double kMinDiagonal = 1e-6;
constexpr double kMaxDiagonal = 1e32;
constexpr double kMinRelativeDecrease = 1e-3;

/// A point of the search: parameters, registrations and their linearisation.
struct Point {
  std::vector<double> x;
  std::vector<FrameState> frames;
  Linearised lin;
  double cost = 0;  ///< with the ridge term
};

}  // namespace

StreamedSummary solve_streamed(const kin::Model& model, std::span<const Measurement> fit,
                               std::span<const Weights> weights, std::span<const int> identified,
                               std::vector<FrameState>& frames, std::span<const int> frame_of,
                               std::span<const FrameColumns> columns, const StreamedOptions& options,
                               std::vector<double>& x, const Linearised* start) {
  const std::vector<double> x0 = x;
  const double ridge = std::max(0.0, options.ridge_lambda);
  const auto ni = static_cast<Eigen::Index>(identified.size());
  Eigen::Index k = ni;
  for (const FrameColumns& f : columns) k += static_cast<Eigen::Index>(f.components.size());
  LineariseOptions lo;
  lo.threads = options.threads;
  lo.loss = options.loss;
  const bool plain = options.loss == nullptr && ridge <= 0;
  lo.per_measurement = plain;

  // Evaluates a point; false when the model cannot evaluate a measurement there.
  const auto evaluate = [&](Point& p) {
    const kin::ModelPtr at_x = model.with_values(p.x);
    p.lin = linearise(*at_x, fit, identified, weights, p.frames, frame_of, columns, options.numeric, lo);
    if (!p.lin.ok() || !std::isfinite(p.lin.cost)) return false;
    p.cost = p.lin.cost;
    if (ridge > 0) {
      Eigen::MatrixXd rows = Eigen::MatrixXd::Zero(ni, k + 1);
      const double s = std::sqrt(ridge);
      for (Eigen::Index c = 0; c < ni; ++c) {
        const auto at = static_cast<std::size_t>(identified[static_cast<std::size_t>(c)]);
        rows(c, c) = s;
        rows(c, k) = s * (p.x[at] - x0[at]);
        p.cost += 0.5 * rows(c, k) * rows(c, k);
      }
      append_rows(p.lin, rows);
    }
    return std::isfinite(p.cost);
  };
  const auto norm_of = [&](const Point& p) {
    double s = 0;
    for (int c : identified) s += p.x[static_cast<std::size_t>(c)] * p.x[static_cast<std::size_t>(c)];
    for (std::size_t f = 0; f < columns.size(); ++f)
      for (int c : columns[f].components) s += p.frames[f].reg[static_cast<std::size_t>(c)] * p.frames[f].reg[static_cast<std::size_t>(c)];
    return std::sqrt(s);
  };

  StreamedSummary summary;
  Point at{x, frames, {}, 0};
  if (plain && start != nullptr && start->ok() && start->columns() == k && !start->per_measurement.empty()) {
    at.lin = *start;
    at.cost = at.lin.cost;
  } else if (!evaluate(at)) {
    summary.message = "the model cannot evaluate every measurement at the start values";
    return summary;
  }
  summary.usable = true;
  double radius = kInitialRadius, decrease = 2.0;
  for (;;) {
    const Eigen::MatrixXd r = at.lin.r();
    const Eigen::VectorXd c = at.lin.qtr();
    // ∇cost = Jᵀr = Rᵀ(Qᵀr).
    const Eigen::VectorXd gradient = r.transpose() * c;
    if (k == 0 || gradient.lpNorm<Eigen::Infinity>() <= options.gradient_tolerance) {
      summary.converged = true;
      summary.message = fmt::format("Gradient tolerance reached. Gradient max norm: {:e} <= {:e}",
                                    k == 0 ? 0.0 : gradient.lpNorm<Eigen::Infinity>(), options.gradient_tolerance);
      break;
    }
    if (summary.iterations >= options.max_iterations) {
      summary.message = fmt::format("Maximum number of iterations reached. Number of iterations: {}.",
                                    summary.iterations);
      break;
    }
    if (radius < kMinRadius) {
      summary.message = fmt::format("Minimum trust region radius reached. Trust region radius: {:e} <= {:e}", radius,
                                    kMinRadius);
      break;
    }
    // min ‖Rδ + c‖² + ‖Dδ‖²/radius, D² = the columns' squared norms (Marquardt), by QR.
    Eigen::MatrixXd a(2 * k, k);
    a.topRows(k) = r;
    a.bottomRows(k).setZero();
    for (Eigen::Index j = 0; j < k; ++j)
      a(k + j, j) = std::sqrt(std::clamp(r.col(j).squaredNorm(), kMinDiagonal, kMaxDiagonal) / radius);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(2 * k);
    b.head(k) = -c;
    const Eigen::VectorXd step = a.householderQr().solve(b);
    ++summary.iterations;
    if (options.progress) options.progress("calibrate", summary.iterations, options.max_iterations);
    const double x_norm = norm_of(at);
    if (step.norm() <= options.parameter_tolerance * (x_norm + options.parameter_tolerance)) {
      summary.converged = true;
      summary.message = fmt::format("Parameter tolerance reached. Relative step_norm: {:e} <= {:e}.",
                                    step.norm() / (x_norm + options.parameter_tolerance), options.parameter_tolerance);
      break;
    }
    const double model_change = 0.5 * (c.squaredNorm() - (r * step + c).squaredNorm());
    Point trial{at.x, at.frames, {}, 0};
    for (Eigen::Index j = 0; j < ni; ++j) trial.x[static_cast<std::size_t>(identified[static_cast<std::size_t>(j)])] += step[j];
    Eigen::Index col = ni;
    for (std::size_t f = 0; f < columns.size(); ++f)
      for (int comp : columns[f].components) trial.frames[f].reg[static_cast<std::size_t>(comp)] += step[col++];
    const bool valid = model_change > 0 && evaluate(trial);
    const double change = valid ? at.cost - trial.cost : -std::numeric_limits<double>::infinity();
    if (valid && change / model_change > kMinRelativeDecrease) {
      const double quality = change / model_change;
      radius = std::min(kMaxRadius, radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * quality - 1.0, 3)));
      decrease = 2.0;
      const double before = at.cost;
      at = std::move(trial);
      if (std::abs(change) <= options.function_tolerance * before) {
        summary.converged = true;
        summary.message = fmt::format("Function tolerance reached. |cost_change|/cost: {:e} <= {:e}",
                                      std::abs(change) / before, options.function_tolerance);
        break;
      }
    } else {
      if (valid && std::abs(change) <= options.function_tolerance * at.cost) {
        summary.converged = true;
        summary.message = fmt::format("Function tolerance reached. |cost_change|/cost: {:e} <= {:e}",
                                      std::abs(change) / at.cost, options.function_tolerance);
        break;
      }
      radius /= decrease;
      decrease *= 2.0;
    }
  }
  x = std::move(at.x);
  frames = std::move(at.frames);
  if (plain) summary.final = std::move(at.lin);
  return summary;
}

}  // namespace postproc::cal::lsq
