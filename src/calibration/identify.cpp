// Identification of the 3-PRS hybrid machine's 33 error parameters with Ceres (see identify.hpp).
#include "postproc/calibration/identify.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <random>

#include <ceres/ceres.h>
#include <Eigen/SVD>

#include "postproc/error.hpp"

namespace postproc::cal {
namespace {

using kin::PrsHybrid;
constexpr int kN = PrsHybrid::kErrorCount;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using RowJac = Eigen::Matrix<double, Eigen::Dynamic, kN, Eigen::RowMajor>;

/// Two unit vectors u, v with (u, v, axis) orthonormal.
void orthonormal_pair(const Vec3& axis, Vec3& u, Vec3& v) {
  const Vec3 a = axis.normalized();
  const Vec3 seed = std::abs(a.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  u = (seed - seed.dot(a) * a).normalized();
  v = a.cross(u);
}

int residual_rows(const PoseMeasurement& m) { return m.has_torsion ? 6 : 5; }

/// Residual (measured − model, mm-equivalent) of one measurement against a model pose, and
/// optionally its derivative by the 33 errors given the model's identification Jacobian.
void pose_residual(const PoseMeasurement& meas, const kin::Pose& model, double* res) {
  const Vec3 dp = meas.measured.p - model.p;
  res[0] = dp.x();
  res[1] = dp.y();
  res[2] = dp.z();
  if (meas.has_torsion) {
    const Vec3 dth = kOrientationWeight * kin::rotation_difference(meas.measured.r, model.r);
    res[3] = dth.x();
    res[4] = dth.y();
    res[5] = dth.z();
  } else {
    Vec3 u, v;
    orthonormal_pair(meas.measured.axis(), u, v);
    const Vec3 d = meas.measured.axis() - model.axis();
    res[3] = kOrientationWeight * u.dot(d);
    res[4] = kOrientationWeight * v.dot(d);
  }
}

/// d(residual)/d(errors), rows as pose_residual. dO = dθ × O, so d(u·O)/dθ = (O × u)ᵀ.
void residual_jacobian(const PoseMeasurement& meas, const kin::Pose& model,
                       const PrsHybrid::IdentificationJacobian& jid, double* out /* rows × 33, row-major */) {
  const int rows = residual_rows(meas);
  Eigen::Map<RowJac> j(out, rows, kN);
  j.topRows<3>() = -jid.topRows<3>();
  if (meas.has_torsion) {
    j.bottomRows<3>() = -kOrientationWeight * jid.bottomRows<3>();
  } else {
    Vec3 u, v;
    orthonormal_pair(meas.measured.axis(), u, v);
    const Vec3 o = model.axis();
    j.row(3) = -kOrientationWeight * (o.cross(u)).transpose() * jid.bottomRows<3>();
    j.row(4) = -kOrientationWeight * (o.cross(v)).transpose() * jid.bottomRows<3>();
  }
}

/// One measured pose as a Ceres residual block over the 33 errors.
/// The measurement with its torsion replaced by the model's: the model's orientation turned by
/// the smallest rotation that carries the model's tool axis onto the measured one. The rotation
/// between the two then has no component about the tool axis (dψ = 0 of document 001); the
/// measured tilt (φ, θ) is kept exactly. (Re-composing Rz(φ)Ry(θ)Rz(−φ)Rz(ψ) from the measured
/// φ, θ and the model's ψ instead leaves a first-order rotation about the axis whenever the axes
/// differ, which makes the torsion-only parameter combinations drift from step to step.)
kin::Pose substitute_torsion(const kin::Pose& measured, const kin::Pose& model) {
  kin::Pose out = measured;
  const Eigen::Quaterniond align = Eigen::Quaterniond::FromTwoVectors(model.axis(), measured.axis());
  out.r = align.toRotationMatrix() * model.r;
  return out;
}

/// With `substitute` (ψ substitution, 5-DoF measurements only): 6 rows against the measurement
/// whose torsion is the model's own at the parameters being evaluated (substitute_torsion), so
/// the torsion residual is 0, while the Jacobian keeps the full 6 rows — document 001's
/// iteration: at each step dψ = 0 and plain (6-row) least squares.
class PoseCost final : public ceres::CostFunction {
 public:
  PoseCost(const PrsHybrid& base, const PoseMeasurement& meas, bool substitute)
      : base_(base), meas_(meas), substitute_(substitute && !meas.has_torsion) {
    set_num_residuals(substitute_ ? 6 : residual_rows(meas));
    mutable_parameter_block_sizes()->push_back(kN);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const auto model = base_.with_errors(std::span<const double>(parameters[0], kN));
    kin::Pose pose;
    if (!model->forward(meas_.q, pose).ok()) return false;
    PoseMeasurement sub;
    const PoseMeasurement* m = &meas_;
    if (substitute_) {
      sub.q = meas_.q;
      sub.measured = substitute_torsion(meas_.measured, pose);
      sub.has_torsion = true;
      m = &sub;
    }
    pose_residual(*m, pose, residuals);
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      kin::Solve s;
      const PrsHybrid::IdentificationJacobian jid = model->identification_jacobian(meas_.q, &s);
      if (!s.ok()) return false;
      residual_jacobian(*m, pose, jid, jacobians[0]);
    }
    return true;
  }

 private:
  const PrsHybrid& base_;
  const PoseMeasurement& meas_;
  bool substitute_;
};

struct SolveOutcome {
  int iterations = 0;
  bool usable = false;
  std::string message;
};

/// LM over the errors `r` (in place) with the pose residuals of `data`. lambda > 0: ridge — the
/// LM damping is λ·I (not Ceres's default λ·diag(JᵀJ)) and never smaller than λ, so each step
/// solves (JᵀJ + μI) dr = −Jᵀf with μ ≥ λ: document 001's ridge iteration, i.e. λ‖dr‖² added to
/// the linearised cost of every step (a Tikhonov prior on the increment); μ only grows above λ
/// when a step fails to lower the cost.
SolveOutcome solve(const PrsHybrid& base, std::span<const PoseMeasurement> data, const std::vector<int>& fixed,
                   std::vector<double>& r, double lambda, int max_iterations, bool substitute) {
  ceres::Problem::Options popt;
  ceres::Problem problem(popt);
  double* x = r.data();
  for (const PoseMeasurement& m : data) problem.AddResidualBlock(new PoseCost(base, m, substitute), nullptr, x);
  if (static_cast<int>(fixed.size()) == kN) {
    problem.SetParameterBlockConstant(x);
  } else if (!fixed.empty()) {
    problem.SetManifold(x, new ceres::SubsetManifold(kN, fixed));
  }
  ceres::Solver::Options opt;
  opt.minimizer_type = ceres::TRUST_REGION;
  opt.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  opt.linear_solver_type = ceres::DENSE_QR;
  opt.max_num_iterations = std::max(1, max_iterations);
  opt.function_tolerance = 1e-12;
  opt.parameter_tolerance = 1e-12;
  opt.gradient_tolerance = 1e-14;
  opt.num_threads = 1;
  if (lambda > 0) {
    opt.min_lm_diagonal = 1.0;
    opt.max_lm_diagonal = 1.0;
    opt.initial_trust_region_radius = 1.0 / lambda;
    opt.max_trust_region_radius = 1.0 / lambda;
  }
  opt.logging_type = ceres::SILENT;
  opt.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(opt, &problem, &summary);
  SolveOutcome out;
  // Ceres counts the evaluation at the start as iteration 0.
  out.iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);
  out.usable = summary.IsSolutionUsable();
  out.message = summary.message;
  return out;
}

/// Stacked residuals and their Jacobian (free columns only) at errors r.
void linearise(const PrsHybrid& base, std::span<const PoseMeasurement> data, const std::vector<double>& r,
               Eigen::VectorXd& b, Eigen::MatrixXd& j) {
  const auto model = base.with_errors(r);
  int rows = 0;
  for (const PoseMeasurement& m : data) rows += residual_rows(m);
  b.resize(rows);
  j.resize(rows, kN);
  int at = 0;
  for (const PoseMeasurement& m : data) {
    kin::Pose pose;
    kin::Solve s;
    if (!model->forward(m.q, pose).ok()) throw Error(ExitCode::usage, "identify: the start model cannot reach a measured pose");
    const PrsHybrid::IdentificationJacobian jid = model->identification_jacobian(m.q, &s);
    const int n = residual_rows(m);
    double res[6];
    RowJac jr(n, kN);
    pose_residual(m, pose, res);
    residual_jacobian(m, pose, jid, jr.data());
    for (int i = 0; i < n; ++i) b[at + i] = res[i];
    j.middleRows(at, n) = jr;
    at += n;
  }
}

/// λ by generalised cross-validation of the linearised ridge problem (see IdentifyOptions).
double gcv_lambda(const PrsHybrid& base, std::span<const PoseMeasurement> data, const std::vector<int>& fixed,
                  const std::vector<double>& r) {
  Eigen::VectorXd b;
  Eigen::MatrixXd jall;
  linearise(base, data, r, b, jall);
  std::vector<int> free;
  for (int k = 0; k < kN; ++k)
    if (std::find(fixed.begin(), fixed.end(), k) == fixed.end()) free.push_back(k);
  Eigen::MatrixXd j(jall.rows(), static_cast<Eigen::Index>(free.size()));
  for (std::size_t c = 0; c < free.size(); ++c) j.col(static_cast<Eigen::Index>(c)) = -jall.col(free[c]);
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(j, Eigen::ComputeThinU);
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

}  // namespace

Eigen::VectorXd pose_residuals(const PrsHybrid& model, std::span<const PoseMeasurement> data) {
  int rows = 0;
  for (const PoseMeasurement& m : data) rows += residual_rows(m);
  Eigen::VectorXd out(rows);
  int at = 0;
  for (const PoseMeasurement& m : data) {
    kin::Pose pose;
    if (!model.forward(m.q, pose).ok()) {
      out.segment(at, residual_rows(m)).setConstant(std::numeric_limits<double>::quiet_NaN());
    } else {
      pose_residual(m, pose, out.data() + at);
    }
    at += residual_rows(m);
  }
  return out;
}

IdentifyResult identify(const PrsHybrid& start_model, std::span<const PoseMeasurement> data, const IdentifyOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  if (data.empty()) throw Error(ExitCode::usage, "identify: no measurements");
  std::vector<int> fixed = options.fixed;
  std::sort(fixed.begin(), fixed.end());
  fixed.erase(std::unique(fixed.begin(), fixed.end()), fixed.end());
  for (int k : fixed)
    if (k < 0 || k >= kN) throw Error(ExitCode::usage, "identify: fixed parameter index " + std::to_string(k) + " is not in 0…32");

  // The nominal geometry carries the errors; start from the start model's errors.
  const std::vector<double>& all = start_model.values();
  std::vector<double> r(all.begin(), all.begin() + kN);
  const auto base = start_model.with_errors(std::vector<double>(kN, 0.0));

  IdentifyResult result;
  {
    const Eigen::VectorXd res0 = pose_residuals(*start_model.with_errors(r), data);
    if (!res0.allFinite()) throw Error(ExitCode::usage, "identify: the start model cannot reach a measured pose");
    result.initial_cost = 0.5 * res0.squaredNorm();
  }

  const bool ridge = options.method == Method::ridge;
  if (ridge) result.lambda = options.ridge_lambda > 0 ? options.ridge_lambda : gcv_lambda(*base, data, fixed, r);
  const SolveOutcome o = solve(*base, data, fixed, r, ridge ? result.lambda : 0, std::max(1, options.max_iterations),
                               options.method == Method::psi_substitution);
  result.iterations = o.iterations;
  result.usable = o.usable;
  result.message = o.message;

  result.final_cost = 0.5 * pose_residuals(*base->with_errors(r), data).squaredNorm();
  result.values = std::move(r);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

namespace doc001 {

kin::Pose target(double z, double theta, double phi, double x, double y) {
  kin::Pose p;
  p.p = Vec3(x, y, -z);
  const Vec3 n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
  const Mat3 f = Vec3(1, -1, -1).asDiagonal();
  p.r = f * PrsHybrid::tilt_rotation(n) * f;
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

std::vector<PoseMeasurement> simulate(const PrsHybrid& controller, const PrsHybrid& truth, std::span<const kin::Pose> targets,
                                      unsigned seed, bool has_torsion, double noise_mm, double noise_deg) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<PoseMeasurement> out;
  for (const kin::Pose& t : targets) {
    PoseMeasurement m;
    if (!controller.nominal_inverse(t, m.q).ok()) throw Error(ExitCode::usage, "simulate: a target cannot be commanded");
    if (!truth.forward(m.q, m.measured).ok()) throw Error(ExitCode::usage, "simulate: a commanded pose cannot be reached");
    const Vec3 dp(u(rng), u(rng), u(rng));
    const Vec3 dth(u(rng), u(rng), u(rng));
    m.measured.p += noise_mm * dp;
    const Vec3 w = noise_deg * kin::kDeg * dth;
    if (w.norm() > 0) m.measured.r = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() * m.measured.r;
    m.has_torsion = has_torsion;
    out.push_back(m);
  }
  return out;
}

double max_tip_error_z700(const PrsHybrid& commanding, const PrsHybrid& truth) {
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
