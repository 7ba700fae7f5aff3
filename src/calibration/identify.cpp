// Identification of a model's error parameters with Ceres, with identifiability analysis (see
// identify.hpp).
#include "postproc/calibration/identify.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <random>

#include <ceres/ceres.h>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/kinematics/hexapod.hpp"

namespace postproc::cal {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Two unit vectors u, v with (u, v, axis) orthonormal.
void orthonormal_pair(const Vec3& axis, Vec3& u, Vec3& v) {
  const Vec3 a = axis.normalized();
  const Vec3 seed = std::abs(a.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  u = (seed - seed.dot(a) * a).normalized();
  v = a.cross(u);
}

/// What the model predicts for a measurement: the tool pose at the commanded joints, or (struts)
/// the joint values at the measured pose.
struct Prediction {
  kin::Pose pose;
  kin::JointVector q;
};

bool predict(const kin::Model& model, const Measurement& m, Prediction& out) {
  if (m.kind == MeasurementKind::struts) {
    kin::IkOptions o;
    o.match = kin::PoseMatch::full;
    o.check_limits = false;
    return model.inverse(m.measured, m.q, out.q, o).ok() && out.q.allFinite();
  }
  return model.forward(m.q, out.pose).ok();
}

/// The measurement with its torsion replaced by the model's: the model's orientation turned by
/// the smallest rotation that carries the model's tool axis onto the measured one. The rotation
/// between the two then has no component about the tool axis (dψ = 0 of document 001); the
/// measured tilt is kept exactly.
kin::Pose substitute_torsion(const kin::Pose& measured, const kin::Pose& model) {
  kin::Pose out = measured;
  const Eigen::Quaterniond align = Eigen::Quaterniond::FromTwoVectors(model.axis(), measured.axis());
  out.r = align.toRotationMatrix() * model.r;
  return out;
}

bool substituted(const Measurement& m, bool substitute) {
  return substitute && m.kind == MeasurementKind::pose && !m.has_torsion;
}

int rows_of(const Measurement& m, int joints, bool substitute) {
  return substituted(m, substitute) ? 6 : residual_rows(m, joints);
}

/// Residual rows of `m` against prediction `p` (see identify.hpp).
void residual_from(const Measurement& m, const Prediction& p, double w, bool substitute, double* res) {
  if (m.kind == MeasurementKind::struts) {
    for (int i = 0; i < m.q.size(); ++i) res[i] = m.q[i] - p.q[i];
    return;
  }
  int at = 0;
  if (m.kind != MeasurementKind::direction) {
    const Vec3 dp = m.measured.p - p.pose.p;
    for (int k = 0; k < 3; ++k) res[at++] = dp[k];
  }
  if (m.kind == MeasurementKind::position) return;
  if (m.kind == MeasurementKind::pose && (m.has_torsion || substitute)) {
    const kin::Pose target = m.has_torsion ? m.measured : substitute_torsion(m.measured, p.pose);
    const Vec3 dth = w * kin::rotation_difference(target.r, p.pose.r);
    for (int k = 0; k < 3; ++k) res[at++] = dth[k];
    return;
  }
  Vec3 u, v;
  orthonormal_pair(m.measured.axis(), u, v);
  const Vec3 d = m.measured.axis() - p.pose.axis();
  res[at++] = w * u.dot(d);
  res[at++] = w * v.dot(d);
}

/// A model at parameter values x, with what derivatives by the parameters `cols` need. Ceres
/// evaluates every residual block at the same x in turn, so the model (and the perturbed models
/// of central differences) are built once per x and shared.
class Evaluator {
 public:
  Evaluator(const kin::Model& base, std::vector<int> cols, bool numeric)
      : base_(base), cols_(std::move(cols)), numeric_(numeric) {}

  void set(const double* x) {
    const std::size_t n = base_.values().size();
    if (model_ && std::memcmp(x_.data(), x, n * sizeof(double)) == 0) return;
    x_.assign(x, x + n);
    model_ = base_.with_values(x_);
    plus_.assign(cols_.size(), nullptr);
    minus_.assign(cols_.size(), nullptr);
  }
  void set(const std::vector<double>& x) { set(x.data()); }
  [[nodiscard]] const kin::Model& model() const { return *model_; }
  [[nodiscard]] const std::vector<int>& cols() const { return cols_; }

  /// d(prediction)/d(cols): pose kinds 6 × k (dP mm, dθ rad per unit), struts joints × k.
  bool derivative(const Measurement& m, Eigen::MatrixXd& d) {
    const bool struts = m.kind == MeasurementKind::struts;
    const int k = static_cast<int>(cols_.size());
    d.resize(struts ? model_->joint_count() : 6, k);
    std::vector<bool> done(cols_.size(), false);
    if (!numeric_) analytic(m, d, done);
    for (int c = 0; c < k; ++c) {
      if (done[static_cast<std::size_t>(c)]) continue;
      const double h = step(cols_[static_cast<std::size_t>(c)]);
      Prediction a, b;
      if (!predict(perturbed(c, +1), m, a) || !predict(perturbed(c, -1), m, b)) return false;
      if (struts) {
        d.col(c) = (a.q - b.q) / (2 * h);
      } else {
        d.col(c).head<3>() = (a.pose.p - b.pose.p) / (2 * h);
        d.col(c).tail<3>() = kin::rotation_difference(a.pose.r, b.pose.r) / (2 * h);
      }
    }
    return d.allFinite();
  }

 private:
  [[nodiscard]] double step(int param) const {
    return base_.parameters()[static_cast<std::size_t>(param)].unit == "rad" ? 1e-7 : 1e-5;
  }
  const kin::Model& perturbed(int c, int sign) {
    auto& slot = sign > 0 ? plus_[static_cast<std::size_t>(c)] : minus_[static_cast<std::size_t>(c)];
    if (!slot) {
      std::vector<double> x = x_;
      const int p = cols_[static_cast<std::size_t>(c)];
      x[static_cast<std::size_t>(p)] += sign * step(p);
      slot = base_.with_values(std::move(x));
    }
    return *slot;
  }
  /// The models' own identification Jacobians: the 3-PRS hybrid's 33 errors (pose at q), the
  /// hexapod's 42 parameters (strut coordinates at a pose).
  void analytic(const Measurement& m, Eigen::MatrixXd& d, std::vector<bool>& done) const {
    if (const auto* prs = dynamic_cast<const kin::PrsHybrid*>(model_.get()); prs && m.kind != MeasurementKind::struts) {
      kin::Solve s;
      const kin::PrsHybrid::IdentificationJacobian j = prs->identification_jacobian(m.q, &s);
      if (!s.ok()) return;
      for (std::size_t c = 0; c < cols_.size(); ++c)
        if (cols_[c] < kin::PrsHybrid::kErrorCount) {
          d.col(static_cast<Eigen::Index>(c)) = j.col(cols_[c]);
          done[c] = true;
        }
    } else if (const auto* hex = dynamic_cast<const kin::Hexapod*>(model_.get());
               hex && m.kind == MeasurementKind::struts) {
      const kin::IdentificationJacobian j = hex->identification_jacobian(m.measured);
      for (std::size_t c = 0; c < cols_.size(); ++c) {
        d.col(static_cast<Eigen::Index>(c)) = j.col(cols_[c]);
        done[c] = true;
      }
    }
  }

  const kin::Model& base_;
  std::vector<int> cols_;
  bool numeric_;
  std::vector<double> x_;
  kin::ModelPtr model_;
  std::vector<kin::ModelPtr> plus_, minus_;
};

/// d(residual)/d(cols) from d(prediction)/d(cols), rows as residual_from.
void residual_jacobian(const Measurement& m, const Prediction& p, const Eigen::MatrixXd& d, double w, bool substitute,
                       double* out, int stride, std::span<const int> where) {
  const int k = static_cast<int>(d.cols());
  int row = 0;
  auto put = [&](const Eigen::RowVectorXd& r) {
    for (int c = 0; c < k; ++c) out[row * stride + where[static_cast<std::size_t>(c)]] = r[c];
    ++row;
  };
  if (m.kind == MeasurementKind::struts) {
    for (Eigen::Index i = 0; i < d.rows(); ++i) put(-d.row(i));
    return;
  }
  if (m.kind != MeasurementKind::direction)
    for (int i = 0; i < 3; ++i) put(-d.row(i));
  if (m.kind == MeasurementKind::position) return;
  const auto rot = d.bottomRows(3);
  if (m.kind == MeasurementKind::pose && (m.has_torsion || substitute)) {
    for (int i = 0; i < 3; ++i) put(-w * rot.row(i));
    return;
  }
  Vec3 u, v;
  orthonormal_pair(m.measured.axis(), u, v);
  const Vec3 o = p.pose.axis();
  put(-w * (o.cross(u)).transpose() * rot);
  put(-w * (o.cross(v)).transpose() * rot);
}

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
  MeasurementCost(Evaluator& ev, const Measurement& m, int n, double w, bool substitute)
      : ev_(ev), m_(m), n_(n), w_(w), substitute_(substitute && !m.has_torsion && m.kind == MeasurementKind::pose) {
    set_num_residuals(rows_of(m, ev.model().joint_count(), substitute));
    mutable_parameter_block_sizes()->push_back(n);
    where_.resize(ev.cols().size());
    for (std::size_t c = 0; c < where_.size(); ++c) where_[c] = ev.cols()[c];
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    ev_.set(parameters[0]);
    Prediction p;
    if (!predict(ev_.model(), m_, p)) return false;
    residual_from(m_, p, w_, substitute_, residuals);
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::MatrixXd d;
      if (!ev_.derivative(m_, d)) return false;
      std::fill(jacobians[0], jacobians[0] + num_residuals() * n_, 0.0);
      residual_jacobian(m_, p, d, w_, substitute_, jacobians[0], n_, where_);
    }
    return true;
  }

 private:
  Evaluator& ev_;
  const Measurement& m_;
  int n_;
  double w_;
  bool substitute_;
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
/// residual falls by J·dx), λ over 1e-12…1e2 in quarter decades.
double gcv_lambda(const Eigen::VectorXd& b, const Eigen::MatrixXd& j) {
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(-j, Eigen::ComputeThinU);
  const Eigen::VectorXd s = svd.singularValues();
  const Eigen::VectorXd beta = svd.matrixU().transpose() * b;
  const double outside = std::max(0.0, b.squaredNorm() - beta.squaredNorm());
  const double n = static_cast<double>(b.size());
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

std::vector<Measurement> fit_set(std::span<const Measurement> data) {
  std::vector<Measurement> out;
  for (const Measurement& m : data)
    if (!m.validate) out.push_back(m);
  return out;
}

std::string unit_text(const kin::Parameter& p) { return p.unit == "rad" ? "rad" : "mm"; }

}  // namespace

std::string_view to_string(Method m) {
  switch (m) {
    case Method::least_squares: return "least-squares";
    case Method::ridge: return "ridge";
    case Method::psi_substitution: return "psi-substitution";
  }
  return "?";
}

std::optional<Method> parse_method(std::string_view s) {
  if (s == "least-squares" || s == "ls") return Method::least_squares;
  if (s == "ridge") return Method::ridge;
  if (s == "psi-substitution" || s == "psi") return Method::psi_substitution;
  return std::nullopt;
}

bool measurement_residual(const kin::Model& model, const Measurement& m, double* out, double orientation_weight) {
  Prediction p;
  if (!predict(model, m, p)) return false;
  residual_from(m, p, orientation_weight, false, out);
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
  int rows = 0;
  for (const Measurement& m : data) rows += residual_rows(m, nj);
  const int k = static_cast<int>(columns.size());
  res.resize(rows);
  RowMatrix j = RowMatrix::Zero(rows, k);
  std::vector<int> where(columns.size());
  for (int c = 0; c < k; ++c) where[static_cast<std::size_t>(c)] = c;
  int at = 0;
  for (const Measurement& m : data) {
    Prediction p;
    Eigen::MatrixXd d;
    if (!predict(ev.model(), m, p) || !ev.derivative(m, d))
      throw Error(ExitCode::usage, fmt::format("{}: the model cannot evaluate this {} measurement (joints outside its "
                                               "reach, or a pose it cannot assume); check the row",
                                               m.label, to_string(m.kind)));
    residual_from(m, p, orientation_weight, false, res.data() + at);
    residual_jacobian(m, p, d, orientation_weight, false, j.data() + static_cast<Eigen::Index>(at) * k, k, where);
    at += residual_rows(m, nj);
  }
  jac = j;
}

Identifiability analyse(const Eigen::MatrixXd& j, std::span<const int> columns, const kin::Model& model,
                        double rank_tolerance) {
  Identifiability a;
  a.rows = static_cast<int>(j.rows());
  a.parameters = static_cast<int>(columns.size());
  std::vector<int> observed;
  std::vector<double> scale;
  double max_norm = 0;
  for (Eigen::Index c = 0; c < j.cols(); ++c) max_norm = std::max(max_norm, j.col(c).norm());
  for (Eigen::Index c = 0; c < j.cols(); ++c) {
    const double n = j.col(c).norm();
    if (n <= 1e-12 * std::max(max_norm, 1e-300)) {
      a.unobserved.push_back(columns[static_cast<std::size_t>(c)]);
      a.dependent.push_back(columns[static_cast<std::size_t>(c)]);
    } else {
      observed.push_back(static_cast<int>(c));
      scale.push_back(n);
    }
  }
  if (observed.empty()) return a;
  Eigen::MatrixXd js(j.rows(), static_cast<Eigen::Index>(observed.size()));
  for (std::size_t c = 0; c < observed.size(); ++c) js.col(static_cast<Eigen::Index>(c)) = j.col(observed[c]) / scale[c];
  // Full V: with fewer rows than columns the null directions beyond the rows are needed too.
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(js, Eigen::ComputeFullV);
  a.singular_values = svd.singularValues();
  const Eigen::Index m = a.singular_values.size();
  const double smax = a.singular_values[0];
  a.rank = 0;
  for (Eigen::Index i = 0; i < m; ++i)
    if (a.singular_values[i] > rank_tolerance * smax) ++a.rank;
  if (a.rank > 0) {
    const double smin = a.singular_values[a.rank - 1];
    a.condition = smax / smin;
    a.o3 = smin;
    a.o4 = smin * smin / smax;
    double log_sum = 0;
    for (int i = 0; i < a.rank; ++i) log_sum += std::log(a.singular_values[i]);
    a.o1 = std::exp(log_sum / a.rank) / std::sqrt(static_cast<double>(std::max(a.rows, 1)));
  }
  // Null directions: the columns of V beyond the rank (and all of them when rows < columns).
  const Eigen::MatrixXd v = svd.matrixV();
  for (Eigen::Index i = a.rank; i < v.cols(); ++i) {
    Eigen::Index big = 0;
    v.col(i).cwiseAbs().maxCoeff(&big);
    const double ref = v(big, i) / scale[static_cast<std::size_t>(big)];
    std::string text;
    for (Eigen::Index c = 0; c < v.rows(); ++c) {
      if (std::abs(v(c, i)) < 0.05 * std::abs(v(big, i))) continue;
      const kin::Parameter& p = model.parameters()[static_cast<std::size_t>(columns[static_cast<std::size_t>(observed[static_cast<std::size_t>(c)])])];
      text += fmt::format("{}{:+.3g} {} {}", text.empty() ? "" : ", ", v(c, i) / scale[static_cast<std::size_t>(c)] / ref,
                          unit_text(p), p.name);
    }
    a.combinations.push_back(text);
  }
  // Which parameters to hold: the columns a rank-revealing QR puts last.
  const int nullity = static_cast<int>(observed.size()) - a.rank;
  if (nullity > 0) {
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(js);
    const auto& perm = qr.colsPermutation().indices();
    for (int i = a.rank; i < static_cast<int>(observed.size()); ++i)
      a.dependent.push_back(columns[static_cast<std::size_t>(observed[static_cast<std::size_t>(perm[i])])]);
  }
  std::sort(a.dependent.begin(), a.dependent.end());
  return a;
}

IdentifyResult identify(const kin::Model& start_model, std::span<const Measurement> data, const IdentifyOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<Measurement> fit = fit_set(data);
  if (fit.empty()) throw Error(ExitCode::usage, "identify: no measurements to fit (all are marked validate)");
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
  Eigen::VectorXd res0;
  Eigen::MatrixXd j0;
  linearise(start_model, fit, free, res0, j0, w, options.numeric_derivatives);
  result.initial_cost = 0.5 * res0.squaredNorm();
  result.start = analyse(j0, free, start_model, options.rank_tolerance);
  for (int k : free)
    if (std::find(result.start.dependent.begin(), result.start.dependent.end(), k) == result.start.dependent.end())
      result.identified.push_back(k);
    else
      result.held.push_back(k);
  if (static_cast<int>(res0.size()) < static_cast<int>(result.identified.size()))
    throw Error(ExitCode::usage, fmt::format("identify: {} parameters but only {} measured components; add measurements "
                                             "or fix parameters",
                                             result.identified.size(), res0.size()));

  std::vector<double> x = start_model.values();
  const std::vector<double> x0 = x;
  if (!result.identified.empty()) {
    if (options.method == Method::ridge) {
      if (options.ridge_lambda > 0) {
        result.lambda = options.ridge_lambda;
      } else {
        Eigen::MatrixXd ji(j0.rows(), static_cast<Eigen::Index>(result.identified.size()));
        for (std::size_t c = 0; c < result.identified.size(); ++c) {
          const auto at = std::find(free.begin(), free.end(), result.identified[c]) - free.begin();
          ji.col(static_cast<Eigen::Index>(c)) = j0.col(at);
        }
        result.lambda = gcv_lambda(res0, ji);
      }
    }
    Evaluator ev(start_model, result.identified, options.numeric_derivatives);
    ev.set(x);
    ceres::Problem::Options popt;
    popt.cost_function_ownership = ceres::TAKE_OWNERSHIP;
    popt.loss_function_ownership = ceres::TAKE_OWNERSHIP;
    ceres::Problem problem(popt);
    double* xp = x.data();
    const bool substitute = options.method == Method::psi_substitution;
    for (const Measurement& m : fit) {
      ceres::LossFunction* loss = nullptr;
      if (options.loss == Loss::huber) loss = new ceres::HuberLoss(options.loss_scale);
      if (options.loss == Loss::cauchy) loss = new ceres::CauchyLoss(options.loss_scale);
      problem.AddResidualBlock(new MeasurementCost(ev, m, n, w, substitute), loss, xp);
    }
    if (result.lambda > 0) problem.AddResidualBlock(new RidgeCost(result.identified, x0, result.lambda), nullptr, xp);
    std::vector<int> constant;
    for (int k = 0; k < n; ++k)
      if (!std::binary_search(result.identified.begin(), result.identified.end(), k)) constant.push_back(k);
    if (!constant.empty()) problem.SetManifold(xp, new ceres::SubsetManifold(n, constant));
    for (const auto& [k, range] : options.bounds) {
      problem.SetParameterLowerBound(xp, k, range.first);
      problem.SetParameterUpperBound(xp, k, range.second);
    }
    ceres::Solver::Options opt;
    opt.minimizer_type = ceres::TRUST_REGION;
    opt.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    opt.linear_solver_type = ceres::DENSE_QR;
    opt.max_num_iterations = std::max(1, options.max_iterations);
    // ψ substitution converges linearly (its torsion rows' Jacobian ignores that the substituted
    // target moves with the model): it stops at a relative cost change of 1e-8 (1.6e-11 mm² on
    // document 001's experiment; the identified errors agree with a 1e-12 stop to < 0.1 µm).
    opt.function_tolerance = substitute ? 1e-8 : 1e-12;
    opt.parameter_tolerance = 1e-12;
    opt.gradient_tolerance = 1e-14;
    opt.num_threads = 1;
    opt.logging_type = ceres::SILENT;
    ProgressCallback progress_callback(options.progress, opt.max_num_iterations);
    if (options.progress) opt.callbacks.push_back(&progress_callback);
    ceres::Solver::Summary summary;
    ceres::Solve(opt, &problem, &summary);
    // Ceres counts the evaluation at the start as iteration 0.
    result.iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);
    result.usable = summary.IsSolutionUsable();
    result.message = summary.message;
  } else {
    result.usable = true;
    result.message = "nothing to identify";
  }

  const auto solved = start_model.with_values(x);
  Eigen::VectorXd res1;
  Eigen::MatrixXd j1;
  linearise(*solved, fit, result.identified, res1, j1, w, options.numeric_derivatives);
  result.final_cost = 0.5 * res1.squaredNorm();
  const int dof = static_cast<int>(res1.size()) - static_cast<int>(result.identified.size());
  result.sigma = dof > 0 ? std::sqrt(res1.squaredNorm() / dof) : std::numeric_limits<double>::quiet_NaN();
  result.solution = analyse(j1, result.identified, *solved, options.rank_tolerance);
  result.stddev.assign(static_cast<std::size_t>(n), std::numeric_limits<double>::quiet_NaN());
  if (!result.identified.empty()) {
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
      result.stddev[static_cast<std::size_t>(result.identified[static_cast<std::size_t>(c)])] =
          result.sigma * std::sqrt(var) / scale[c];
    }
  }
  result.values = std::move(x);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
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
    case MeasurementKind::pose:
      e.position_mm = Vec3(r[0], r[1], r[2]).norm();
      e.angle_deg = (m.has_torsion ? Vec3(r[3], r[4], r[5]).norm() : std::hypot(r[3], r[4])) / kin::kDeg;
      break;
  }
  return e;
}

namespace doc001 {

kin::Pose target(double z, double theta, double phi, double x, double y) {
  kin::Pose p;
  p.p = Vec3(x, y, -z);
  const Vec3 n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
  const Mat3 f = Vec3(1, -1, -1).asDiagonal();
  p.r = f * kin::PrsHybrid::tilt_rotation(n) * f;
  return p;
}

std::vector<kin::Pose> pose_set() {
  std::vector<kin::Pose> out;
  for (double z : {700.0, 800.0, 900.0}) {
    out.push_back(target(z, 0, 0));
    for (int k = 0; k < 8; ++k) out.push_back(target(z, 40 * kin::kDeg, k * 45 * kin::kDeg));
  }
  return out;
}

std::vector<Measurement> simulate(const kin::PrsHybrid& controller, const kin::PrsHybrid& truth,
                                  std::span<const kin::Pose> targets, unsigned seed, bool has_torsion, double noise_mm,
                                  double noise_deg) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Measurement> out;
  for (const kin::Pose& t : targets) {
    Measurement m;
    m.kind = MeasurementKind::pose;
    if (!controller.nominal_inverse(t, m.q).ok()) throw Error(ExitCode::usage, "simulate: a target cannot be commanded");
    if (!truth.forward(m.q, m.measured).ok()) throw Error(ExitCode::usage, "simulate: a commanded pose cannot be reached");
    const Vec3 dp(u(rng), u(rng), u(rng));
    const Vec3 dth(u(rng), u(rng), u(rng));
    m.measured.p += noise_mm * dp;
    const Vec3 w = noise_deg * kin::kDeg * dth;
    if (w.norm() > 0) m.measured.r = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() * m.measured.r;
    m.has_torsion = has_torsion;
    m.label = fmt::format("pose{}", out.size() + 1);
    out.push_back(m);
  }
  return out;
}

double max_tip_error_z700(const kin::PrsHybrid& commanding, const kin::PrsHybrid& truth) {
  double worst = 0;
  const kin::JointVector start = kin::JointVector::Zero(5);
  for (int ti = 0; ti <= 40; ++ti)
    for (int pi = 0; pi < 72; ++pi) {
      const kin::Pose t = target(700, ti * kin::kDeg, pi * 5 * kin::kDeg);
      kin::JointVector q;
      if (!commanding.inverse(t, start, q).ok()) return std::numeric_limits<double>::infinity();
      kin::Pose real;
      if (!truth.forward(q, real).ok()) return std::numeric_limits<double>::infinity();
      worst = std::max(worst, (real.p - t.p).norm());
    }
  return worst;
}

}  // namespace doc001

}  // namespace postproc::cal
