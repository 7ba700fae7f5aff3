#pragma once
// One measurement against a model's prediction, for identify() and its solvers (identify.hpp):
// the residual rows, their derivatives by the model's parameters and by an instrument frame's
// registration, and the model at a parameter vector that provides them.
#include <array>
#include <cstring>
#include <memory>
#include <mutex>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "postproc/calibration/identify.hpp"
#include "postproc/calibration/measurement.hpp"
#include "postproc/kinematics/hexapod.hpp"
#include "postproc/kinematics/prs_hybrid.hpp"
#include "postproc/kinematics/serial.hpp"

namespace postproc::cal::lsq {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

/// What the model predicts for a measurement: the tool pose at the commanded joints, or (struts)
/// the joint values at the measured pose.
struct Prediction {
  kin::Pose pose;
  kin::JointVector q;
};

/// Row weights of one measurement: length rows (mm, struts) and angle rows (mm-eq per rad).
struct Weights {
  double length = 1;
  double angle = kOrientationWeight;
};

/// Two unit vectors u, v with (u, v, axis) orthonormal.
void orthonormal_pair(const Vec3& axis, Vec3& u, Vec3& v);

bool predict(const kin::Model& model, const Measurement& m, Prediction& out);

/// The measurement with its torsion replaced by the model's: the model's orientation turned by
/// the smallest rotation that carries the model's tool axis onto the measured one (document 001's
/// dψ = 0).
[[nodiscard]] kin::Pose substitute_torsion(const kin::Pose& measured, const kin::Pose& model);

[[nodiscard]] bool substituted(const Measurement& m, bool substitute);

/// Residual rows of `m` in the solve (ψ substitution: 6 for a 5-DoF pose).
[[nodiscard]] int rows_of(const Measurement& m, int joints, bool substitute);

/// Residual rows of `m`, whose measured pose (in the workpiece frame) is `measured`, against
/// prediction `p` (see identify.hpp).
void residual_from(const Measurement& m, const kin::Pose& measured, const Prediction& p, const Weights& w,
                   bool substitute, double* res);

/// d(residual)/d(registration components) by central differences (no model evaluation: the
/// prediction does not depend on the registration). Rows ≤ 6 (frames never hold strut readings).
void registration_jacobian(const Measurement& m, const Mat3& r0, std::array<double, 6> reg, const Prediction& p,
                           const Weights& w, bool substitute, int rows, std::span<const int> components, double* out,
                           int stride, int first_column);

/// d(residual)/d(cols) from d(prediction)/d(cols), rows as residual_from.
void residual_jacobian(const Measurement& m, const kin::Pose& measured, const Prediction& p, const Eigen::MatrixXd& d,
                       const Weights& w, bool substitute, double* out, int stride, std::span<const int> where);

/// The registration columns of one frame in a Jacobian: its components, from column `first`.
struct FrameColumns {
  std::vector<int> components;
  int first = 0;
};

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

  /// predict() and derivative() at once: on a serial chain with analytic derivatives one pass
  /// along the chain gives both (the pose bit for bit forward()'s).
  bool predict_and_derive(const Measurement& m, Prediction& p, Eigen::MatrixXd& d) {
    if (!numeric_ && m.kind != MeasurementKind::struts)
      if (const auto* serial = dynamic_cast<const kin::SerialModel*>(model_.get())) {
        const Eigen::Matrix<double, 6, Eigen::Dynamic> j = serial->identification_jacobian(m.q, p.pose);
        d.resize(6, static_cast<Eigen::Index>(cols_.size()));
        for (std::size_t c = 0; c < cols_.size(); ++c) d.col(static_cast<Eigen::Index>(c)) = j.col(cols_[c]);
        return d.allFinite();
      }
    return predict(*model_, m, p) && derivative(m, d);
  }

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

/// The residual rows of one measurement at ev's model and their Jacobian rows: `res` gets the
/// residual_rows() values, `jac` (row stride `stride`) the model's parameters at columns `where`
/// and, with a frame, its components from `columns->first`. `frame`: the instrument frame the
/// measured values are in (null: the workpiece frame); `columns`: its estimated components (null:
/// none). `d` is scratch. False when the model cannot evaluate the measurement.
bool measurement_rows(Evaluator& ev, const Measurement& m, const Weights& w, const FrameState* frame,
                      const FrameColumns* columns, std::span<const int> where, Eigen::MatrixXd& d, double* res,
                      double* jac, int stride);

}  // namespace postproc::cal::lsq
