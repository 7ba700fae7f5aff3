// Identification of a model's error parameters with Ceres, with identifiability analysis (see
// identify.hpp).
#include "postproc/calibration/identify.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <random>

#include <ceres/ceres.h>
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/kinematics/hexapod.hpp"
#include "postproc/kinematics/serial.hpp"
#include "src/calibration/frame_registration.hpp"
#include "src/calibration/identifiability.hpp"
#include "src/calibration/jacobian_compression.hpp"
#include "src/calibration/streamed_levenberg_marquardt.hpp"
#include "src/calibration/measurement_residual.hpp"

namespace postproc::cal {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using lsq::Evaluator;
using lsq::FrameColumns;
using lsq::Prediction;
using lsq::Weights;

/// One measurement as a Ceres residual block over the whole parameter vector (the parameters
/// not identified are held by a SubsetManifold; their Jacobian columns are 0).
///
/// With `substitute` (ψ substitution, 5-DoF poses): 6 rows against the measurement whose torsion
/// is the model's own at the parameters being evaluated (substitute_torsion), so the torsion
/// residual is 0 while the Jacobian keeps the full 6 rows — document 001's iteration. (Updating
/// the substituted torsion only once per iteration instead, so target and Jacobian agree within
/// an iteration, was tried: it needs twice the iterations on document 001's experiment.)
class MeasurementCost final : public ceres::CostFunction {
 public:
  MeasurementCost(Evaluator& ev, const Measurement& m, int n, Weights w, bool substitute, FrameState* frame)
      : ev_(ev),
        m_(m),
        n_(n),
        w_(w),
        substitute_(substitute && !m.has_torsion && m.kind == MeasurementKind::pose),
        frame_(frame) {
    set_num_residuals(lsq::rows_of(m, ev.model().joint_count(), substitute));
    mutable_parameter_block_sizes()->push_back(n);
    if (frame_ != nullptr) mutable_parameter_block_sizes()->push_back(6);
    where_.resize(ev.cols().size());
    for (std::size_t c = 0; c < where_.size(); ++c) where_[c] = ev.cols()[c];
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    ev_.set(parameters[0]);
    Prediction p;
    Eigen::MatrixXd d;
    const bool jacobian = jacobians != nullptr && jacobians[0] != nullptr;
    if (jacobian ? !ev_.predict_and_derive(m_, p, d) : !lsq::predict(ev_.model(), m_, p)) return false;
    const kin::Pose measured = frame_ != nullptr ? registered_pose(m_.measured, frame_->r0, parameters[1]) : m_.measured;
    lsq::residual_from(m_, measured, p, w_, substitute_, residuals);
    if (jacobian) {
      std::fill(jacobians[0], jacobians[0] + num_residuals() * n_, 0.0);
      lsq::residual_jacobian(m_, measured, p, d, w_, substitute_, jacobians[0], n_, where_);
    }
    if (frame_ != nullptr && jacobians != nullptr && jacobians[1] != nullptr) {
      std::array<double, 6> reg{};
      std::copy(parameters[1], parameters[1] + 6, reg.begin());
      static constexpr std::array<int, 6> all = {0, 1, 2, 3, 4, 5};
      lsq::registration_jacobian(m_, frame_->r0, reg, p, w_, substitute_, num_residuals(), all, jacobians[1], 6, 0);
    }
    return true;
  }

 private:
  Evaluator& ev_;
  const Measurement& m_;
  int n_;
  Weights w_;
  bool substitute_;
  FrameState* frame_;
  std::vector<int> where_;
};

/// Tells IdentifyOptions::progress about each solver iteration.
class ProgressCallback final : public ceres::IterationCallback {
 public:
  ProgressCallback(Progress p, int max_iterations) : p_(std::move(p)), max_(max_iterations) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (p_) p_("calibrate", s.iteration, max_);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  Progress p_;
  int max_;
};

/// The ridge penalty √λ·(x_c − x0_c) over the identified parameters.
class RidgeCost final : public ceres::CostFunction {
 public:
  RidgeCost(std::vector<int> cols, std::vector<double> x0, double lambda)
      : cols_(std::move(cols)), x0_(std::move(x0)), s_(std::sqrt(lambda)) {
    set_num_residuals(static_cast<int>(cols_.size()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(x0_.size()));
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const int n = static_cast<int>(x0_.size());
    for (std::size_t r = 0; r < cols_.size(); ++r) {
      const auto c = static_cast<std::size_t>(cols_[r]);
      residuals[r] = s_ * (parameters[0][c] - x0_[c]);
    }
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      std::fill(jacobians[0], jacobians[0] + num_residuals() * n, 0.0);
      for (std::size_t r = 0; r < cols_.size(); ++r) jacobians[0][static_cast<int>(r) * n + cols_[r]] = s_;
    }
    return true;
  }

 private:
  std::vector<int> cols_;
  std::vector<double> x0_;
  double s_;
};

/// λ by generalised cross-validation of the linearised ridge problem b ≈ A·dx, A = −J (the
/// residual falls by J·dx), λ over 1e-12…1e2 in quarter decades. J is given compressed: `r`
/// (some columns of R, J = Q·R) with qtb = Qᵀb, the row count and ‖b‖².
double gcv_lambda(const Eigen::VectorXd& qtb, const Eigen::MatrixXd& r, long rows, double b_squared) {
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(-r, Eigen::ComputeThinU);
  const Eigen::VectorXd s = svd.singularValues();
  const Eigen::VectorXd beta = svd.matrixU().transpose() * qtb;
  const double outside = std::max(0.0, b_squared - beta.squaredNorm());
  const double n = static_cast<double>(rows);
  double best = 1e-3, best_g = std::numeric_limits<double>::infinity();
  for (int e = -48; e <= 8; ++e) {
    const double lambda = std::pow(10.0, e / 4.0);
    double rss = outside, tr = n;
    for (Eigen::Index i = 0; i < s.size(); ++i) {
      const double s2 = s[i] * s[i];
      const double f = lambda / (s2 + lambda);
      rss += f * f * beta[i] * beta[i];
      tr -= s2 / (s2 + lambda);
    }
    const double g = n * rss / (tr * tr);
    if (g < best_g) {
      best_g = g;
      best = lambda;
    }
  }
  return best;
}

/// The refusal of a measurement the model cannot evaluate, naming it.
Error unevaluable(const Measurement& m) {
  return Error(ExitCode::usage, fmt::format("{}: the model cannot evaluate this {} measurement (joints outside its "
                                            "reach, or a pose it cannot assume); check the row",
                                            m.label, to_string(m.kind)));
}

/// lsq::linearise, or unevaluable() of the first measurement the model cannot evaluate.
lsq::Linearised linearised(const kin::Model& model, std::span<const Measurement> data, std::span<const int> columns,
                           std::span<const Weights> weights, std::span<const FrameState> frames,
                           std::span<const int> frame_of, std::span<const FrameColumns> frame_columns, bool numeric,
                           const lsq::LineariseOptions& options) {
  lsq::Linearised lin =
      lsq::linearise(model, data, columns, weights, frames, frame_of, frame_columns, numeric, options);
  if (!lin.ok()) throw unevaluable(data[static_cast<std::size_t>(lin.failed)]);
  return lin;
}

/// Residual rows above which the solver's steps use the normal equations (see identify()).
constexpr int kNormalEquationRows = 60000;

std::vector<Measurement> fit_set(std::span<const Measurement> data) {
  std::vector<Measurement> out;
  for (const Measurement& m : data)
    if (!m.validate) out.push_back(m);
  return out;
}

double sigma_length(const Measurement& m) { return m.source.sigma_mm > 0 ? m.source.sigma_mm : kDefaultSigma; }
double sigma_angle(const Measurement& m, double w) {
  return m.source.sigma_rad > 0 ? m.source.sigma_rad : sigma_length(m) / w;
}



}  // namespace

std::string_view to_string(Method m) {
  switch (m) {
    case Method::least_squares: return "least-squares";
    case Method::ridge: return "ridge";
    case Method::psi_substitution: return "psi-substitution";
  }
  return "?";
}

std::string_view to_string(Solver s) {
  switch (s) {
    case Solver::automatic: return "auto";
    case Solver::ceres: return "ceres";
    case Solver::streamed: return "streamed";
  }
  return "?";
}

std::optional<Solver> parse_solver(std::string_view s) {
  for (Solver v : {Solver::automatic, Solver::ceres, Solver::streamed})
    if (to_string(v) == s) return v;
  return std::nullopt;
}

std::optional<Method> parse_method(std::string_view s) {
  if (s == "least-squares" || s == "ls") return Method::least_squares;
  if (s == "ridge") return Method::ridge;
  if (s == "psi-substitution" || s == "psi") return Method::psi_substitution;
  return std::nullopt;
}

bool measurement_residual(const kin::Model& model, const Measurement& m, double* out, double orientation_weight) {
  Prediction p;
  if (!lsq::predict(model, m, p)) return false;
  lsq::residual_from(m, m.measured, p, Weights{1, orientation_weight}, false, out);
  return true;
}

Eigen::VectorXd residuals(const kin::Model& model, std::span<const Measurement> data, double orientation_weight) {
  int rows = 0;
  for (const Measurement& m : data) rows += residual_rows(m, model.joint_count());
  Eigen::VectorXd out(rows);
  int at = 0;
  for (const Measurement& m : data) {
    const int n = residual_rows(m, model.joint_count());
    if (!measurement_residual(model, m, out.data() + at, orientation_weight))
      out.segment(at, n).setConstant(std::numeric_limits<double>::quiet_NaN());
    at += n;
  }
  return out;
}

void linearise(const kin::Model& model, std::span<const Measurement> data, std::span<const int> columns,
               Eigen::VectorXd& res, Eigen::MatrixXd& jac, double orientation_weight, bool numeric) {
  Evaluator ev(model, std::vector<int>(columns.begin(), columns.end()), numeric);
  ev.set(model.values());
  const int nj = model.joint_count();
  const auto k = static_cast<int>(columns.size());
  int rows = 0;
  for (const Measurement& m : data) rows += residual_rows(m, nj);
  res.resize(rows);
  RowMatrix j = RowMatrix::Zero(rows, k);
  std::vector<int> where(columns.size());
  for (std::size_t c = 0; c < columns.size(); ++c) where[c] = static_cast<int>(c);
  const Weights w{1, orientation_weight};
  Eigen::MatrixXd d;
  int at = 0;
  for (const Measurement& m : data) {
    if (!lsq::measurement_rows(ev, m, w, nullptr, nullptr, where, d, res.data() + at,
                               j.data() + static_cast<Eigen::Index>(at) * k, k))
      throw unevaluable(m);
    at += residual_rows(m, nj);
  }
  jac = j;
}

IdentifyResult identify(const kin::Model& start_model, std::span<const Measurement> data, const IdentifyOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  // The fitted measurements: `data` itself unless some are held out (no copy of a large set).
  std::vector<Measurement> fit_copy;
  if (std::any_of(data.begin(), data.end(), [](const Measurement& m) { return m.validate; })) fit_copy = fit_set(data);
  const std::span<const Measurement> fit = fit_copy.empty() ? data : std::span<const Measurement>(fit_copy);
  if (std::all_of(data.begin(), data.end(), [](const Measurement& m) { return m.validate; })) throw Error(ExitCode::usage, "identify: no measurements to fit (all are marked validate)");
  const int n = static_cast<int>(start_model.parameters().size());
  auto check = [&](int k, std::string_view what) {
    if (k < 0 || k >= n)
      throw Error(ExitCode::usage, fmt::format("identify: {} parameter index {} is not in 0…{}", what, k, n - 1));
  };
  std::vector<int> free = options.free;
  if (free.empty())
    for (int k = 0; k < n; ++k)
      if (start_model.parameters()[static_cast<std::size_t>(k)].error) free.push_back(k);
  for (int k : free) check(k, "free");
  for (int k : options.fixed) check(k, "fixed");
  for (const auto& b : options.bounds) check(b.first, "bounded");
  std::sort(free.begin(), free.end());
  free.erase(std::unique(free.begin(), free.end()), free.end());
  std::erase_if(free, [&](int k) { return std::find(options.fixed.begin(), options.fixed.end(), k) != options.fixed.end(); });

  IdentifyResult result;
  const double w = options.orientation_weight;

  // Weights from the files' uncertainties, relative to the most accurate file (identify.hpp).
  double sigma0 = std::numeric_limits<double>::infinity();
  for (const Measurement& m : fit) sigma0 = std::min(sigma0, sigma_length(m));
  result.sigma_reference_mm = sigma0;
  std::vector<Weights> weights;
  weights.reserve(fit.size());
  for (const Measurement& m : fit) weights.push_back({sigma0 / sigma_length(m), sigma0 / sigma_angle(m, w)});

  // Instrument frames: one per name, its components the union of its files'.
  std::vector<FrameState> frames;
  std::vector<int> frame_of(fit.size(), -1);
  for (std::size_t i = 0; i < fit.size(); ++i) {
    const Source& src = fit[i].source;
    if (src.frame.empty()) continue;
    auto it = std::find_if(frames.begin(), frames.end(), [&](const FrameState& f) { return f.name == src.frame; });
    if (it == frames.end()) {
      frames.push_back(FrameState{src.frame});
      it = frames.end() - 1;
    }
    it->free = static_cast<std::uint8_t>(it->free | src.free);
    ++it->measurements;
    frame_of[i] = static_cast<int>(it - frames.begin());
  }
  for (const Measurement& m : data)
    if (m.validate && !m.source.frame.empty() &&
        std::none_of(frames.begin(), frames.end(), [&](const FrameState& f) { return f.name == m.source.frame; }))
      throw Error(ExitCode::usage,
                  fmt::format("{}: held-out measurement in instrument frame '{}', which no fitted measurement "
                              "determines; fit some measurements of the same set-up, or name the fitted file's frame "
                              "('# frame: instrument NAME' in both files)",
                              m.label, m.source.frame));
  start_registration(start_model, fit, frame_of, frames);
  std::vector<FrameColumns> all_columns(frames.size());
  std::vector<std::pair<int, int>> reg_of;  // (frame, component) per registration column
  int first = static_cast<int>(free.size());
  for (std::size_t f = 0; f < frames.size(); ++f) {
    all_columns[f].first = first;
    for (int k = 0; k < 6; ++k)
      if ((frames[f].free & (1u << k)) != 0) {
        all_columns[f].components.push_back(k);
        reg_of.emplace_back(static_cast<int>(f), k);
        ++first;
      }
  }

  // Every analysis below needs J only through its columns' norms and inner products, and the
  // residual only through Qᵀr and ‖r‖: the compressed R stands for J (jacobian_compression.hpp).
  lsq::LineariseOptions lin_options;
  lin_options.threads = options.threads;
  lin_options.per_measurement = true;  // lets the solver start from it (solve_streamed)
  const lsq::Linearised lin0 = linearised(start_model, fit, free, weights, frames, frame_of, all_columns,
                                          options.numeric_derivatives, lin_options);
  const long rows0 = lin0.rows;
  const Eigen::MatrixXd jall = lin0.r();
  const Eigen::Index nfree = static_cast<Eigen::Index>(free.size());
  const Eigen::MatrixXd j0 = jall.leftCols(nfree);
  result.initial_cost = lin0.cost;
  result.start = analyse_rows(j0, free, start_model, options.rank_tolerance, rows0);
  for (int k : free)
    if (std::find(result.start.dependent.begin(), result.start.dependent.end(), k) == result.start.dependent.end())
      result.identified.push_back(k);
    else
      result.held.push_back(k);
  std::vector<std::vector<std::string>> held_why(frames.size());
  if (!frames.empty()) {
    Eigen::MatrixXd ji(jall.rows(), static_cast<Eigen::Index>(result.identified.size()));
    for (std::size_t c = 0; c < result.identified.size(); ++c)
      ji.col(static_cast<Eigen::Index>(c)) = jall.col(std::find(free.begin(), free.end(), result.identified[c]) - free.begin());
    // A column 99.9995 % inside the span of those before it (residual norm 1e-3 of the column)
    // would be estimated with a noise amplification of 1000: held instead.
    separate_registration(ji, jall.rightCols(jall.cols() - nfree), reg_of, start_model, result.identified, result.held,
                          result.start.dependent, result.held_why, frames, held_why, 1e-3);
    // The report's figures cover what is fitted together: the machine's identified parameters
    // and the estimated registration components (the machine-only null directions stay named).
    std::vector<Label> labels = labels_of(start_model, result.identified);
    Eigen::MatrixXd jf(jall.rows(), static_cast<Eigen::Index>(result.identified.size()));
    for (std::size_t c = 0; c < result.identified.size(); ++c)
      jf.col(static_cast<Eigen::Index>(c)) = jall.col(std::find(free.begin(), free.end(), result.identified[c]) - free.begin());
    for (std::size_t c = 0; c < reg_of.size(); ++c) {
      const auto [f, k] = reg_of[c];
      if ((frames[static_cast<std::size_t>(f)].held & (1u << k)) != 0) continue;
      jf.conservativeResize(Eigen::NoChange, jf.cols() + 1);
      jf.col(jf.cols() - 1) = jall.col(nfree + static_cast<Eigen::Index>(c));
      labels.push_back({fmt::format("{}[{}]", registration_name(k), frames[static_cast<std::size_t>(f)].name), k < 3 ? "mm" : "rad"});
    }
    const Identifiability joint = analyse_labelled(jf, labels, options.rank_tolerance, rows0);
    result.start.rows = joint.rows;
    result.start.parameters = static_cast<int>(free.size() + reg_of.size());
    result.start.rank = joint.rank;
    result.start.condition = joint.condition;
    result.start.o1 = joint.o1;
    result.start.o3 = joint.o3;
    result.start.o4 = joint.o4;
    result.start.singular_values = joint.singular_values;
    result.start.combinations.insert(result.start.combinations.end(), joint.combinations.begin(), joint.combinations.end());
    result.start.weakest = joint.weakest;
  }
  std::vector<FrameColumns> est_columns(frames.size());
  int estimated_registration = 0;
  first = static_cast<int>(result.identified.size());
  for (std::size_t f = 0; f < frames.size(); ++f) {
    est_columns[f].first = first;
    est_columns[f].components = frames[f].estimated();
    first += static_cast<int>(est_columns[f].components.size());
    estimated_registration += static_cast<int>(est_columns[f].components.size());
  }
  const int unknowns = static_cast<int>(result.identified.size()) + estimated_registration;
  if (rows0 < unknowns)
    throw Error(ExitCode::usage, fmt::format("identify: {} parameters but only {} measured components; add measurements "
                                             "or fix parameters",
                                             unknowns, rows0));

  std::vector<double> x = start_model.values();
  const std::vector<double> x0 = x;
  std::optional<lsq::Linearised> streamed_final;  // the streamed solver's linearisation at x
  if (unknowns > 0) {
    if (options.method == Method::ridge && !result.identified.empty()) {
      if (options.ridge_lambda > 0) {
        result.lambda = options.ridge_lambda;
      } else {
        Eigen::MatrixXd ji(j0.rows(), static_cast<Eigen::Index>(result.identified.size()));
        for (std::size_t c = 0; c < result.identified.size(); ++c) {
          const auto at = std::find(free.begin(), free.end(), result.identified[c]) - free.begin();
          ji.col(static_cast<Eigen::Index>(c)) = j0.col(at);
        }
        result.lambda = gcv_lambda(lin0.qtr(), ji, rows0, lin0.squared);
      }
    }
    const bool psi = options.method == Method::psi_substitution;
    const bool can_stream = !psi && options.bounds.empty();
    if (options.solver == Solver::streamed && !can_stream)
      throw Error(ExitCode::usage, fmt::format("identify: the streamed solver does not take {}; use the Ceres solver",
                                               psi ? "ψ substitution" : "parameter bounds"));
    const bool streamed =
        options.solver == Solver::streamed || (options.solver == Solver::automatic && can_stream && rows0 >= kStreamedRows);
    if (streamed) {
      std::unique_ptr<ceres::LossFunction> loss;
      if (options.loss == Loss::huber) loss = std::make_unique<ceres::HuberLoss>(options.loss_scale);
      if (options.loss == Loss::cauchy) loss = std::make_unique<ceres::CauchyLoss>(options.loss_scale);
      lsq::StreamedOptions so;
      so.max_iterations = std::max(1, options.max_iterations);
      so.threads = options.threads;
      so.numeric = options.numeric_derivatives;
      so.loss = loss.get();
      so.ridge_lambda = result.lambda;
      so.progress = options.progress;
      // The start analysis linearised the same columns when nothing was held or separated.
      bool same_columns = result.identified == free;
      for (std::size_t f = 0; f < frames.size(); ++f)
        same_columns = same_columns && est_columns[f].components == all_columns[f].components;
      lsq::StreamedSummary summary = lsq::solve_streamed(start_model, fit, weights, result.identified, frames, frame_of,
                                                         est_columns, so, x, same_columns ? &lin0 : nullptr);
      if (summary.final.aug.size() > 0 && !summary.final.per_measurement.empty()) streamed_final = std::move(summary.final);
      result.solver = Solver::streamed;
      result.iterations = summary.iterations;
      result.usable = summary.usable;
      result.converged = summary.converged;
      result.message = summary.message;
    } else {
      Evaluator ev(start_model, result.identified, options.numeric_derivatives);
      ev.set(x);
      ceres::Problem::Options popt;
      popt.cost_function_ownership = ceres::TAKE_OWNERSHIP;
      popt.loss_function_ownership = ceres::TAKE_OWNERSHIP;
      popt.manifold_ownership = ceres::TAKE_OWNERSHIP;
      ceres::Problem problem(popt);
      double* xp = x.data();
      const bool substitute = options.method == Method::psi_substitution;
      for (std::size_t i = 0; i < fit.size(); ++i) {
        ceres::LossFunction* loss = nullptr;
        if (options.loss == Loss::huber) loss = new ceres::HuberLoss(options.loss_scale);
        if (options.loss == Loss::cauchy) loss = new ceres::CauchyLoss(options.loss_scale);
        FrameState* frame = frame_of[i] >= 0 ? &frames[static_cast<std::size_t>(frame_of[i])] : nullptr;
        if (frame != nullptr)
          problem.AddResidualBlock(new MeasurementCost(ev, fit[i], n, weights[i], substitute, frame), loss, xp,
                                   frame->reg.data());
        else
          problem.AddResidualBlock(new MeasurementCost(ev, fit[i], n, weights[i], substitute, nullptr), loss, xp);
      }
      if (result.lambda > 0) problem.AddResidualBlock(new RidgeCost(result.identified, x0, result.lambda), nullptr, xp);
      std::vector<int> constant;
      for (int k = 0; k < n; ++k)
        if (!std::binary_search(result.identified.begin(), result.identified.end(), k)) constant.push_back(k);
      if (static_cast<int>(constant.size()) == n) problem.SetParameterBlockConstant(xp);
      else if (!constant.empty()) problem.SetManifold(xp, new ceres::SubsetManifold(n, constant));
      for (FrameState& f : frames) {
        const std::vector<int> est = f.estimated();
        std::vector<int> held;
        for (int k = 0; k < 6; ++k)
          if (std::find(est.begin(), est.end(), k) == est.end()) held.push_back(k);
        if (held.size() == 6) problem.SetParameterBlockConstant(f.reg.data());
        else if (!held.empty()) problem.SetManifold(f.reg.data(), new ceres::SubsetManifold(6, held));
      }
      for (const auto& [k, range] : options.bounds) {
        problem.SetParameterLowerBound(xp, k, range.first);
        problem.SetParameterUpperBound(xp, k, range.second);
      }
      ceres::Solver::Options opt;
      opt.minimizer_type = ceres::TRUST_REGION;
      opt.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
      // Dense QR of the whole Jacobian costs rows·p² per step; with many rows the normal equations
      // (p×p, formed once per step) are as accurate at the well-conditioned problems identify()
      // leaves after holding the unidentifiable combinations, and several times cheaper.
      int rows = 0;
      for (const Measurement& m : fit) rows += residual_rows(m, start_model.joint_count());
      opt.linear_solver_type = rows > kNormalEquationRows ? ceres::DENSE_NORMAL_CHOLESKY : ceres::DENSE_QR;
      opt.max_num_iterations = std::max(1, options.max_iterations);
      // ψ substitution converges linearly (its torsion rows' Jacobian ignores that the substituted
      // target moves with the model): it stops at a relative cost change of 1e-8 (1.6e-11 mm² on
      // document 001's experiment; the identified errors agree with a 1e-12 stop to < 0.1 µm).
      opt.function_tolerance = substitute ? 1e-8 : 1e-12;
      opt.parameter_tolerance = 1e-12;
      opt.gradient_tolerance = 1e-14;
      // Serial chains have analytic derivatives throughout: their residual blocks are evaluated on
      // options.threads (the result depends on the thread count only through the order of sums).
      bool struts = false;
      for (const Measurement& m : fit) struts = struts || m.kind == MeasurementKind::struts;
      opt.num_threads = ev.all_analytic() && !struts && options.threads > 1 ? options.threads : 1;
      opt.logging_type = ceres::SILENT;
      ProgressCallback progress_callback(options.progress, opt.max_num_iterations);
      if (options.progress) opt.callbacks.push_back(&progress_callback);
      ceres::Solver::Summary summary;
      ceres::Solve(opt, &problem, &summary);
      // Ceres counts the evaluation at the start as iteration 0.
      result.iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);
      result.usable = summary.IsSolutionUsable();
      result.converged = summary.termination_type == ceres::CONVERGENCE;
      result.message = summary.message;
      result.solver = Solver::ceres;
    }
  } else {
    result.usable = true;
    result.converged = true;
    result.message = "nothing to identify";
  }

  const auto solved = start_model.with_values(x);
  const lsq::Linearised lin1 = streamed_final ? std::move(*streamed_final)
                                              : linearised(*solved, fit, result.identified, weights, frames, frame_of,
                                                           est_columns, options.numeric_derivatives, lin_options);
  const Eigen::MatrixXd j1 = lin1.r();
  result.final_cost = lin1.cost;
  const long dof = lin1.rows - unknowns;
  result.sigma = dof > 0 ? std::sqrt(lin1.squared / static_cast<double>(dof)) : std::numeric_limits<double>::quiet_NaN();
  std::vector<Label> labels = labels_of(*solved, result.identified);
  for (std::size_t f = 0; f < frames.size(); ++f)
    for (int k : est_columns[f].components)
      labels.push_back({fmt::format("{}[{}]", registration_name(k), frames[f].name), k < 3 ? "mm" : "rad"});
  result.solution = analyse_labelled(j1, labels, options.rank_tolerance, lin1.rows);
  for (int& c : result.solution.dependent) c = c < static_cast<int>(result.identified.size()) ? result.identified[static_cast<std::size_t>(c)] : -1;
  for (int& c : result.solution.unobserved) c = c < static_cast<int>(result.identified.size()) ? result.identified[static_cast<std::size_t>(c)] : -1;
  std::erase(result.solution.dependent, -1);
  std::erase(result.solution.unobserved, -1);
  result.stddev.assign(static_cast<std::size_t>(n), std::numeric_limits<double>::quiet_NaN());
  std::vector<double> column_stddev(static_cast<std::size_t>(j1.cols()), std::numeric_limits<double>::quiet_NaN());
  if (j1.cols() > 0) {
    // Cov = σ̂²(JᵀJ)⁻¹ through the SVD of the column-scaled Jacobian (pseudo-inverse on its rank).
    Eigen::VectorXd scale(j1.cols());
    for (Eigen::Index c = 0; c < j1.cols(); ++c) scale[c] = std::max(j1.col(c).norm(), 1e-300);
    const Eigen::MatrixXd js = j1 * scale.cwiseInverse().asDiagonal();
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(js, Eigen::ComputeThinV);
    const Eigen::VectorXd s = svd.singularValues();
    for (Eigen::Index c = 0; c < j1.cols(); ++c) {
      double var = 0;
      for (Eigen::Index i = 0; i < s.size(); ++i)
        if (s[i] > options.rank_tolerance * s[0]) var += svd.matrixV()(c, i) * svd.matrixV()(c, i) / (s[i] * s[i]);
      column_stddev[static_cast<std::size_t>(c)] = result.sigma * std::sqrt(var) / scale[c];
    }
    for (std::size_t c = 0; c < result.identified.size(); ++c)
      result.stddev[static_cast<std::size_t>(result.identified[c])] = column_stddev[c];
    // The machine parameters' block of σ̂²(JᵀJ)⁻¹ (the registration marginalised out).
    const auto ni = static_cast<Eigen::Index>(result.identified.size());
    Eigen::MatrixXd vs = Eigen::MatrixXd::Zero(ni, s.size());
    for (Eigen::Index i = 0; i < s.size(); ++i)
      if (s[i] > options.rank_tolerance * s[0]) vs.col(i) = svd.matrixV().topRows(ni).col(i) / s[i];
    const Eigen::VectorXd inv_scale = scale.head(ni).cwiseInverse();
    result.covariance = result.sigma * result.sigma * inv_scale.asDiagonal() * (vs * vs.transpose()) * inv_scale.asDiagonal();
  }
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const FrameState& fr = frames[f];
    FrameEstimate e;
    e.name = fr.name;
    e.free = fr.free;
    e.held = fr.held;
    e.held_why = held_why[f];
    e.t = Vec3(fr.reg[0], fr.reg[1], fr.reg[2]);
    e.r = rotation_of(Vec3(fr.reg[3], fr.reg[4], fr.reg[5])) * fr.r0;
    e.measurements = fr.measurements;
    e.stddev.fill(std::numeric_limits<double>::quiet_NaN());
    for (std::size_t c = 0; c < est_columns[f].components.size(); ++c)
      e.stddev[static_cast<std::size_t>(est_columns[f].components[c])] =
          column_stddev[static_cast<std::size_t>(est_columns[f].first) + c];
    result.frames.push_back(std::move(e));
  }
  // The start registration, for the report (the rigid fit before the joint solve).
  {
    std::vector<FrameState> s0 = frames;
    for (FrameState& f : s0) f.reg = {};
    start_registration(start_model, fit, frame_of, s0);
    for (std::size_t f = 0; f < frames.size(); ++f) {
      result.frames[f].start_t = Vec3(s0[f].reg[0], s0[f].reg[1], s0[f].reg[2]);
      result.frames[f].start_r = s0[f].r0;
    }
  }
  // χ² per file, in each file's own uncertainty: the residuals are in σ₀ units.
  {
    const int nj = start_model.joint_count();
    const double share =
        lin1.rows > 0 ? 1.0 - static_cast<double>(unknowns) / static_cast<double>(lin1.rows) : 1.0;
    for (std::size_t i = 0; i < fit.size(); ++i) {
      const Measurement& m = fit[i];
      auto it = std::find_if(result.files.begin(), result.files.end(), [&](const FileFit& f) { return f.file == m.file; });
      if (it == result.files.end()) {
        FileFit ff;
        ff.file = m.file;
        ff.sigma_mm = sigma_length(m);
        ff.sigma_rad = sigma_angle(m, w);
        ff.declared = m.source.sigma_mm > 0 || m.source.sigma_rad > 0;
        result.files.push_back(ff);
        it = result.files.end() - 1;
      }
      const int rows = residual_rows(m, nj);
      it->rows += rows;
      it->lengths = it->lengths || (m.kind != MeasurementKind::direction && m.kind != MeasurementKind::axis_cosine);
      it->angles = it->angles || (m.kind != MeasurementKind::position && m.kind != MeasurementKind::struts);
      it->chi2 += lin1.per_measurement[i] / (sigma0 * sigma0);
    }
    for (FileFit& f : result.files)
      f.normalised_rms = f.rows > 0 ? std::sqrt(f.chi2 / (f.rows * std::max(share, 1e-12))) : 0.0;
  }
  result.values = std::move(x);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

std::vector<SignHint> opposite_sign_hints(const kin::Model& start_model, std::span<const Measurement> data,
                                          const IdentifyOptions& options, const IdentifyResult& result) {
  std::vector<SignHint> out;
  // A converged fit within 3σ₀ with angular errors of machine size is not questioned: a wrong sign
  // leaves residuals of the order of the rotation times the radius (millimetres), or the solver
  // explains it with a half-turn error parameter, or does not converge.
  bool suspicious = !(result.sigma <= 3 * result.sigma_reference_mm) || !result.converged;
  for (int k : result.identified) {
    const kin::Parameter& p = start_model.parameters()[static_cast<std::size_t>(k)];
    if (p.error && p.unit == "rad" && std::abs(result.values[static_cast<std::size_t>(k)] - p.nominal) > 0.05)
      suspicious = true;
  }
  if (!suspicious) return out;
  IdentifyOptions o = options;
  o.progress = nullptr;
  for (int j = 0; j < start_model.joint_count(); ++j) {
    const kin::Joint& joint = start_model.joints()[static_cast<std::size_t>(j)];
    if (joint.type != kin::JointType::rotary) continue;
    std::vector<Measurement> flipped(data.begin(), data.end());
    for (Measurement& m : flipped) m.q[j] = -m.q[j];
    try {
      const IdentifyResult r = identify(start_model, flipped, o);
      if (r.usable && r.final_cost * 10 < result.final_cost)
        out.push_back({joint.name, result.final_cost / std::max(r.final_cost, 1e-300), r.sigma});
    } catch (const Error&) {
      // the flipped data cannot even be evaluated: not a better explanation
    }
  }
  // The reversal that explains the data best (another axis's reversal may also beat a diverged
  // fit, but by far less).
  if (out.size() > 1) {
    const auto best = std::max_element(out.begin(), out.end(),
                                       [](const SignHint& a, const SignHint& b) { return a.cost_ratio < b.cost_ratio; });
    const SignHint keep = *best;
    std::erase_if(out, [&](const SignHint& h) { return h.cost_ratio * 10 < keep.cost_ratio; });
  }
  return out;
}

MeasurementError measurement_error(const kin::Model& model, const Measurement& m) {
  double r[kin::kMaxJoints > 6 ? kin::kMaxJoints : 6];
  MeasurementError e{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  if (!measurement_residual(model, m, r, 1.0)) {
    e.position_mm = e.angle_deg = std::numeric_limits<double>::infinity();
    return e;
  }
  switch (m.kind) {
    case MeasurementKind::struts: {
      double worst = 0;
      for (int i = 0; i < m.q.size(); ++i) worst = std::max(worst, std::abs(r[i]));
      e.position_mm = worst;
      break;
    }
    case MeasurementKind::position: e.position_mm = Vec3(r[0], r[1], r[2]).norm(); break;
    case MeasurementKind::direction: e.angle_deg = std::hypot(r[0], r[1]) / kin::kDeg; break;
    case MeasurementKind::axis_cosine: e.angle_deg = std::abs(r[0]) / kin::kDeg; break;  // the cosine's error, as an angle
    case MeasurementKind::pose:
      e.position_mm = Vec3(r[0], r[1], r[2]).norm();
      e.angle_deg = (m.has_torsion ? Vec3(r[3], r[4], r[5]).norm() : std::hypot(r[3], r[4])) / kin::kDeg;
      break;
  }
  return e;
}


}  // namespace postproc::cal
