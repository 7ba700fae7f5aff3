// One measurement against a model's prediction (measurement_residual.hpp).
#include "src/calibration/measurement_residual.hpp"

#include <cmath>

#include <Eigen/Geometry>

#include "src/calibration/frame_registration.hpp"

namespace postproc::cal::lsq {

/// Two unit vectors u, v with (u, v, axis) orthonormal.
void orthonormal_pair(const Vec3& axis, Vec3& u, Vec3& v) {
  const Vec3 a = axis.normalized();
  const Vec3 seed = std::abs(a.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  u = (seed - seed.dot(a) * a).normalized();
  v = a.cross(u);
}

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

bool measurement_rows(Evaluator& ev, const Measurement& m, const Weights& w, const FrameState* frame,
                      const FrameColumns* columns, std::span<const int> where, Eigen::MatrixXd& d, double* res,
                      double* jac, int stride) {
  Prediction p;
  if (!ev.predict_and_derive(m, p, d)) return false;
  const kin::Pose measured = frame != nullptr ? registered_pose(m.measured, frame->r0, frame->reg.data()) : m.measured;
  residual_from(m, measured, p, w, false, res);
  residual_jacobian(m, measured, p, d, w, false, jac, stride, where);
  if (frame != nullptr && columns != nullptr)
    registration_jacobian(m, frame->r0, frame->reg, p, w, false, residual_rows(m, ev.model().joint_count()),
                          columns->components, jac, stride, columns->first);
  return true;
}

}  // namespace postproc::cal::lsq
