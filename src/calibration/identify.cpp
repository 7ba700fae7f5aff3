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

/// Row weights of one measurement: length rows (mm, struts) and angle rows (mm-eq per rad).
struct Weights {
  double length = 1;
  double angle = kOrientationWeight;
};

/// Residual rows of `m`, whose measured pose (in the workpiece frame) is `measured`, against
/// prediction `p` (see identify.hpp).
void residual_from(const Measurement& m, const kin::Pose& measured, const Prediction& p, const Weights& w,
                   bool substitute, double* res) {
  if (m.kind == MeasurementKind::struts) {
    for (int i = 0; i < m.q.size(); ++i) res[i] = w.length * (m.q[i] - p.q[i]);
    return;
  }
  if (m.kind == MeasurementKind::axis_cosine) {
    res[0] = w.angle * (m.cosine - measured.r.col(0).dot(p.pose.axis()));
    return;
  }
  int at = 0;
  if (m.kind != MeasurementKind::direction) {
    const Vec3 dp = measured.p - p.pose.p;
    for (int k = 0; k < 3; ++k) res[at++] = w.length * dp[k];
  }
  if (m.kind == MeasurementKind::position) return;
  if (m.kind == MeasurementKind::pose && (m.has_torsion || substitute)) {
    const kin::Pose target = m.has_torsion ? measured : substitute_torsion(measured, p.pose);
    const Vec3 dth = w.angle * kin::rotation_difference(target.r, p.pose.r);
    for (int k = 0; k < 3; ++k) res[at++] = dth[k];
    return;
  }
  Vec3 u, v;
  orthonormal_pair(measured.axis(), u, v);
  const Vec3 d = measured.axis() - p.pose.axis();
  res[at++] = w.angle * u.dot(d);
  res[at++] = w.angle * v.dot(d);
}

/// d(residual)/d(registration components) by central differences (no model evaluation: the
/// prediction does not depend on the registration). Rows ≤ 6 (frames never hold strut readings).
void registration_jacobian(const Measurement& m, const Mat3& r0, std::array<double, 6> reg, const Prediction& p,
                           const Weights& w, bool substitute, int rows, std::span<const int> components, double* out,
                           int stride, int first_column) {
  std::array<double, 6> a{}, b{};
  for (std::size_t c = 0; c < components.size(); ++c) {
    const auto k = static_cast<std::size_t>(components[c]);
    const double h = k < 3 ? 1e-3 : 1e-6;  // exact for t (linear); O(h²) for ω
    const double keep = reg[k];
    reg[k] = keep + h;
    residual_from(m, registered_pose(m.measured, r0, reg.data()), p, w, substitute, a.data());
    reg[k] = keep - h;
    residual_from(m, registered_pose(m.measured, r0, reg.data()), p, w, substitute, b.data());
    reg[k] = keep;
    for (int r = 0; r < rows; ++r)
      out[r * stride + first_column + static_cast<int>(c)] =
          (a[static_cast<std::size_t>(r)] - b[static_cast<std::size_t>(r)]) / (2 * h);
  }
}

/// A model at parameter values x, with what derivatives by the parameters `cols` need. Ceres
/// evaluates every residual block at the same x in turn, so the model (and the perturbed models
/// of central differences) are built once per x and shared.
class Evaluator {
 public:
  Evaluator(const kin::Model& base, std::vector<int> cols, bool numeric)
      : base_(base), cols_(std::move(cols)), numeric_(numeric) {}

  /// Ceres may evaluate residual blocks on several threads, all at the same x: the first to see a
  /// new x rebuilds the model under the lock; the others then read it.
  void set(const double* x) {
    const std::size_t n = base_.values().size();
    const std::lock_guard<std::mutex> lock(mutex_);
    if (model_ && std::memcmp(x_.data(), x, n * sizeof(double)) == 0) return;
    x_.assign(x, x + n);
    model_ = base_.with_values(x_);
    plus_.assign(cols_.size(), nullptr);
    minus_.assign(cols_.size(), nullptr);
  }
  /// True when every column has an analytic derivative for every measurement kind but struts
  /// (serial chains): no perturbed model is ever built, so evaluations may run in parallel.
  [[nodiscard]] bool all_analytic() const {
    return !numeric_ && dynamic_cast<const kin::SerialModel*>(&base_) != nullptr;
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
    return base_.parameters()[static_cast<std::size_t>(param)].unit == "mm" ? 1e-5 : 1e-7;  // mm; rad, ratio
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
    } else if (const auto* serial = dynamic_cast<const kin::SerialModel*>(model_.get());
               serial && m.kind != MeasurementKind::struts) {
      const Eigen::Matrix<double, 6, Eigen::Dynamic> j = serial->identification_jacobian(m.q);
      for (std::size_t c = 0; c < cols_.size(); ++c) {
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
  std::mutex mutex_;
};

/// d(residual)/d(cols) from d(prediction)/d(cols), rows as residual_from.
void residual_jacobian(const Measurement& m, const kin::Pose& measured, const Prediction& p, const Eigen::MatrixXd& d,
                       const Weights& w, bool substitute, double* out, int stride, std::span<const int> where) {
  const int k = static_cast<int>(d.cols());
  int row = 0;
  auto put = [&](const Eigen::RowVectorXd& r) {
    for (int c = 0; c < k; ++c) out[row * stride + where[static_cast<std::size_t>(c)]] = r[c];
    ++row;
  };
  if (m.kind == MeasurementKind::struts) {
    for (Eigen::Index i = 0; i < d.rows(); ++i) put(-w.length * d.row(i));
    return;
  }
  if (m.kind == MeasurementKind::axis_cosine) {
    // d·O moves by d·(dθ × O) = (O × d)·dθ.
    put(-w.angle * (p.pose.axis().cross(Vec3(measured.r.col(0)))).transpose() * d.bottomRows(3));
    return;
  }
  if (m.kind != MeasurementKind::direction)
    for (int i = 0; i < 3; ++i) put(-w.length * d.row(i));
  if (m.kind == MeasurementKind::position) return;
  const auto rot = d.bottomRows(3);
  if (m.kind == MeasurementKind::pose && (m.has_torsion || substitute)) {
    for (int i = 0; i < 3; ++i) put(-w.angle * rot.row(i));
    return;
  }
  Vec3 u, v;
  orthonormal_pair(measured.axis(), u, v);
  const Vec3 o = p.pose.axis();
  put(-w.angle * (o.cross(u)).transpose() * rot);
  put(-w.angle * (o.cross(v)).transpose() * rot);
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
  MeasurementCost(Evaluator& ev, const Measurement& m, int n, Weights w, bool substitute, FrameState* frame)
      : ev_(ev),
        m_(m),
        n_(n),
        w_(w),
        substitute_(substitute && !m.has_torsion && m.kind == MeasurementKind::pose),
        frame_(frame) {
    set_num_residuals(rows_of(m, ev.model().joint_count(), substitute));
    mutable_parameter_block_sizes()->push_back(n);
    if (frame_ != nullptr) mutable_parameter_block_sizes()->push_back(6);
    where_.resize(ev.cols().size());
    for (std::size_t c = 0; c < where_.size(); ++c) where_[c] = ev.cols()[c];
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    ev_.set(parameters[0]);
    Prediction p;
    if (!predict(ev_.model(), m_, p)) return false;
    const kin::Pose measured = frame_ != nullptr ? registered_pose(m_.measured, frame_->r0, parameters[1]) : m_.measured;
    residual_from(m_, measured, p, w_, substitute_, residuals);
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::MatrixXd d;
      if (!ev_.derivative(m_, d)) return false;
      std::fill(jacobians[0], jacobians[0] + num_residuals() * n_, 0.0);
      residual_jacobian(m_, measured, p, d, w_, substitute_, jacobians[0], n_, where_);
    }
    if (frame_ != nullptr && jacobians != nullptr && jacobians[1] != nullptr) {
      std::array<double, 6> reg{};
      std::copy(parameters[1], parameters[1] + 6, reg.begin());
      static constexpr std::array<int, 6> all = {0, 1, 2, 3, 4, 5};
      registration_jacobian(m_, frame_->r0, reg, p, w_, substitute_, num_residuals(), all, jacobians[1], 6, 0);
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

/// The registration columns of one frame in a Jacobian: its components, from column `first`.
struct FrameColumns {
  std::vector<int> components;
  int first = 0;
};

/// Residuals and Jacobian of `data` at `model`: the model's parameters `columns`, then each
/// frame's registration components (frame_of[i]: the frame of data[i], −1 for the workpiece).
void linearise_all(const kin::Model& model, std::span<const Measurement> data, std::span<const int> columns,
                   std::span<const Weights> weights, std::span<const FrameState> frames, std::span<const int> frame_of,
                   std::span<const FrameColumns> frame_columns, Eigen::VectorXd& res, Eigen::MatrixXd& jac,
                   bool numeric) {
  Evaluator ev(model, std::vector<int>(columns.begin(), columns.end()), numeric);
  ev.set(model.values());
  const int nj = model.joint_count();
  int rows = 0;
  for (const Measurement& m : data) rows += residual_rows(m, nj);
  int k = static_cast<int>(columns.size());
  for (const FrameColumns& f : frame_columns) k += static_cast<int>(f.components.size());
  res.resize(rows);
  RowMatrix j = RowMatrix::Zero(rows, k);
  std::vector<int> where(columns.size());
  for (std::size_t c = 0; c < columns.size(); ++c) where[c] = static_cast<int>(c);
  int at = 0;
  for (std::size_t i = 0; i < data.size(); ++i) {
    const Measurement& m = data[i];
    Prediction p;
    Eigen::MatrixXd d;
    if (!predict(ev.model(), m, p) || !ev.derivative(m, d))
      throw Error(ExitCode::usage, fmt::format("{}: the model cannot evaluate this {} measurement (joints outside its "
                                               "reach, or a pose it cannot assume); check the row",
                                               m.label, to_string(m.kind)));
    const int f = frame_of.empty() ? -1 : frame_of[i];
    const FrameState* frame = f >= 0 ? &frames[static_cast<std::size_t>(f)] : nullptr;
    const kin::Pose measured = frame != nullptr ? registered_pose(m.measured, frame->r0, frame->reg.data()) : m.measured;
    const int n = residual_rows(m, nj);
    residual_from(m, measured, p, weights[i], false, res.data() + at);
    double* out = j.data() + static_cast<Eigen::Index>(at) * k;
    residual_jacobian(m, measured, p, d, weights[i], false, out, k, where);
    if (frame != nullptr && static_cast<std::size_t>(f) < frame_columns.size()) {
      const FrameColumns& fc = frame_columns[static_cast<std::size_t>(f)];
      registration_jacobian(m, frame->r0, frame->reg, p, weights[i], false, n, fc.components, out, k, fc.first);
    }
    at += n;
  }
  jac = j;
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

std::optional<Method> parse_method(std::string_view s) {
  if (s == "least-squares" || s == "ls") return Method::least_squares;
  if (s == "ridge") return Method::ridge;
  if (s == "psi-substitution" || s == "psi") return Method::psi_substitution;
  return std::nullopt;
}

bool measurement_residual(const kin::Model& model, const Measurement& m, double* out, double orientation_weight) {
  Prediction p;
  if (!predict(model, m, p)) return false;
  residual_from(m, m.measured, p, Weights{1, orientation_weight}, false, out);
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
  const std::vector<Weights> w(data.size(), Weights{1, orientation_weight});
  linearise_all(model, data, columns, w, {}, {}, {}, res, jac, numeric);
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

  Eigen::VectorXd res0;
  Eigen::MatrixXd jall;
  linearise_all(start_model, fit, free, weights, frames, frame_of, all_columns, res0, jall, options.numeric_derivatives);
  const Eigen::Index nfree = static_cast<Eigen::Index>(free.size());
  const Eigen::MatrixXd j0 = jall.leftCols(nfree);
  result.initial_cost = 0.5 * res0.squaredNorm();
  result.start = analyse(j0, free, start_model, options.rank_tolerance);
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
    const Identifiability joint = analyse_labelled(jf, labels, options.rank_tolerance);
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
  if (static_cast<int>(res0.size()) < unknowns)
    throw Error(ExitCode::usage, fmt::format("identify: {} parameters but only {} measured components; add measurements "
                                             "or fix parameters",
                                             unknowns, res0.size()));

  std::vector<double> x = start_model.values();
  const std::vector<double> x0 = x;
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
        result.lambda = gcv_lambda(res0, ji);
      }
    }
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
  } else {
    result.usable = true;
    result.converged = true;
    result.message = "nothing to identify";
  }

  const auto solved = start_model.with_values(x);
  Eigen::VectorXd res1;
  Eigen::MatrixXd j1;
  linearise_all(*solved, fit, result.identified, weights, frames, frame_of, est_columns, res1, j1,
                options.numeric_derivatives);
  result.final_cost = 0.5 * res1.squaredNorm();
  const int dof = static_cast<int>(res1.size()) - unknowns;
  result.sigma = dof > 0 ? std::sqrt(res1.squaredNorm() / dof) : std::numeric_limits<double>::quiet_NaN();
  std::vector<Label> labels = labels_of(*solved, result.identified);
  for (std::size_t f = 0; f < frames.size(); ++f)
    for (int k : est_columns[f].components)
      labels.push_back({fmt::format("{}[{}]", registration_name(k), frames[f].name), k < 3 ? "mm" : "rad"});
  result.solution = analyse_labelled(j1, labels, options.rank_tolerance);
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
    const double share = res1.size() > 0 ? 1.0 - static_cast<double>(unknowns) / static_cast<double>(res1.size()) : 1.0;
    int at = 0;
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
      it->chi2 += res1.segment(at, rows).squaredNorm() / (sigma0 * sigma0);
      at += rows;
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
