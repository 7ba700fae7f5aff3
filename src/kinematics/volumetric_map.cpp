// The volumetric error map of document 002 (grid interpolation with an outside policy) and the
// decorator that adds it to any model's tool tip.
#include "postproc/kinematics/volumetric_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include "postproc/error.hpp"

namespace postproc::kin {

namespace {

constexpr char kAxisName[3] = {'x', 'y', 'z'};
// Points this close outside the box are inside: poses computed in floating point land on the
// boundary plus or minus rounding, and refusing them would be noise.
constexpr double kSlackMm = 1e-9;

/// The nodes along one axis that contribute at a point, with their weights and the weights'
/// derivatives per mm. Ghost nodes of the Catmull–Rom stencil beyond the row's ends are folded
/// into the real ones (f[-1] = 2 f[0] − f[1], f[n] = 2 f[n−1] − f[n−2]).
struct Taps {
  int n = 0;
  std::array<int, 4> idx{};
  std::array<double, 4> w{};
  std::array<double, 4> dw{};
};

Taps axis_taps(double u, int count, double h, bool smooth) {
  Taps t;
  int i = static_cast<int>(std::floor(u));
  i = std::clamp(i, 0, count - 2);
  const double s = u - i;
  if (!smooth) {
    t.n = 2;
    t.idx = {i, i + 1, 0, 0};
    t.w = {1 - s, s, 0, 0};
    t.dw = {-1 / h, 1 / h, 0, 0};
    return t;
  }
  const double s2 = s * s;
  const double s3 = s2 * s;
  t.n = 4;
  t.idx = {i - 1, i, i + 1, i + 2};
  t.w = {0.5 * (-s3 + 2 * s2 - s), 0.5 * (3 * s3 - 5 * s2 + 2), 0.5 * (-3 * s3 + 4 * s2 + s), 0.5 * (s3 - s2)};
  t.dw = {0.5 * (-3 * s2 + 4 * s - 1) / h, 0.5 * (9 * s2 - 10 * s) / h, 0.5 * (-9 * s2 + 8 * s + 1) / h,
          0.5 * (3 * s2 - 2 * s) / h};
  if (t.idx[0] < 0) {
    t.w[1] += 2 * t.w[0];
    t.w[2] -= t.w[0];
    t.dw[1] += 2 * t.dw[0];
    t.dw[2] -= t.dw[0];
    t.w[0] = t.dw[0] = 0;
    t.idx[0] = 0;
  }
  if (t.idx[3] > count - 1) {
    t.w[2] += 2 * t.w[3];
    t.w[1] -= t.w[3];
    t.dw[2] += 2 * t.dw[3];
    t.dw[1] -= t.dw[3];
    t.w[3] = t.dw[3] = 0;
    t.idx[3] = count - 1;
  }
  return t;
}

}  // namespace

VolumetricMap::VolumetricMap(const Eigen::Vector3d& origin, const Eigen::Vector3d& spacing,
                             const Eigen::Vector3i& counts, std::vector<Eigen::Vector3d> values,
                             Interpolation interpolation, Outside outside)
    : origin_(origin), spacing_(spacing), counts_(counts), values_(std::move(values)),
      interpolation_(interpolation), outside_(outside) {
  for (int a = 0; a < 3; ++a) {
    if (counts_[a] < 2)
      throw Error(ExitCode::usage, fmt::format("volumetric map: {} node(s) along {} (at least 2 needed)", counts_[a],
                                               kAxisName[a]));
    if (!(spacing_[a] > 0) || !std::isfinite(spacing_[a]))
      throw Error(ExitCode::usage, fmt::format("volumetric map: spacing along {} is {} mm (must be finite and > 0)",
                                               kAxisName[a], spacing_[a]));
    if (!std::isfinite(origin_[a]))
      throw Error(ExitCode::usage, fmt::format("volumetric map: origin {} is not finite", kAxisName[a]));
  }
  const long long expected = static_cast<long long>(counts_[0]) * counts_[1] * counts_[2];
  if (static_cast<long long>(values_.size()) != expected)
    throw Error(ExitCode::usage, fmt::format("volumetric map: {} node values for a {} × {} × {} grid ({} expected)",
                                             values_.size(), counts_[0], counts_[1], counts_[2], expected));
  for (std::size_t n = 0; n < values_.size(); ++n)
    if (!values_[n].allFinite())
      throw Error(ExitCode::usage, fmt::format("volumetric map: node value {} is not finite", n));
}

Eigen::Vector3d VolumetricMap::upper() const {
  return origin_ + spacing_.cwiseProduct((counts_.array() - 1).cast<double>().matrix());
}

const Eigen::Vector3d& VolumetricMap::node(int i, int j, int k) const {
  return values_[static_cast<std::size_t>(i + counts_[0] * (j + counts_[1] * k))];
}

bool VolumetricMap::contains(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d hi = upper();
  for (int a = 0; a < 3; ++a)
    if (!(p[a] >= origin_[a] - kSlackMm && p[a] <= hi[a] + kSlackMm)) return false;
  return true;
}

std::optional<VolumetricMap::Sample> VolumetricMap::sample(const Eigen::Vector3d& p) const {
  const bool inside = contains(p);
  if (!inside) {
    if (outside_ == Outside::refuse) return std::nullopt;
    if (outside_ == Outside::zero) return Sample{};
  }
  const bool smooth = interpolation_ == Interpolation::smooth;
  std::array<Taps, 3> taps;
  for (int a = 0; a < 3; ++a) {
    const double top = counts_[a] - 1;
    const double u = (p[a] - origin_[a]) / spacing_[a];
    const double uc = std::clamp(u, 0.0, top);
    Taps& t = taps[static_cast<std::size_t>(a)];
    t = axis_taps(uc, counts_[a], spacing_[a], smooth);
    // Clamped beyond the slack: E no longer changes along this axis.
    const bool clamped = p[a] < origin_[a] - kSlackMm || p[a] > origin_[a] + top * spacing_[a] + kSlackMm;
    if (clamped) t.dw.fill(0);
  }
  Sample s;
  const auto& [tx, ty, tz] = taps;
  for (int c = 0; c < tz.n; ++c) {
    const auto zc = static_cast<std::size_t>(c);
    for (int b = 0; b < ty.n; ++b) {
      const auto yb = static_cast<std::size_t>(b);
      const double wyz = ty.w[yb] * tz.w[zc];
      const double dyz = ty.dw[yb] * tz.w[zc];
      const double wdz = ty.w[yb] * tz.dw[zc];
      const int row = counts_[0] * (ty.idx[yb] + counts_[1] * tz.idx[zc]);
      for (int a = 0; a < tx.n; ++a) {
        const auto xa = static_cast<std::size_t>(a);
        const Eigen::Vector3d& v = values_[static_cast<std::size_t>(row + tx.idx[xa])];
        s.error += (tx.w[xa] * wyz) * v;
        s.gradient.col(0) += (tx.dw[xa] * wyz) * v;
        s.gradient.col(1) += (tx.w[xa] * dyz) * v;
        s.gradient.col(2) += (tx.w[xa] * wdz) * v;
      }
    }
  }
  return s;
}

std::optional<Eigen::Vector3d> VolumetricMap::error(const Eigen::Vector3d& p) const {
  const auto s = sample(p);
  if (!s) return std::nullopt;
  return s->error;
}

std::optional<Eigen::Matrix3d> VolumetricMap::gradient(const Eigen::Vector3d& p) const {
  const auto s = sample(p);
  if (!s) return std::nullopt;
  return s->gradient;
}

// ---------------------------------------------------------------------------------------------

namespace {
// Called once per Model constructor argument: their evaluation order is unspecified.
const Model& checked_base(const ModelPtr& base, const std::shared_ptr<const VolumetricMap>& map) {
  if (!base) throw Error(ExitCode::usage, "volumetric model: no base model");
  if (!map) throw Error(ExitCode::usage, "volumetric model: no error map");
  return *base;
}
}  // namespace

VolumetricModel::VolumetricModel(ModelPtr base, std::shared_ptr<const VolumetricMap> map)
    : Model(checked_base(base, map).joints(), checked_base(base, map).parameters(), checked_base(base, map).values()),
      base_(std::move(base)),
      map_(std::move(map)) {}

std::optional<Eigen::Vector3d> VolumetricModel::correction(const JointVector& q) const {
  const auto e = map_->error(base_->linear_position(q));
  if (!e) return std::nullopt;
  return base_->machine_to_workpiece(q) * *e;
}

Solve VolumetricModel::forward(const JointVector& q, Pose& out) const {
  Solve s = base_->forward(q, out);
  if (!s.ok()) return s;
  const auto c = correction(q);
  if (!c) {
    s.status = Status::outside_map;
    return s;
  }
  out.p += *c;
  return s;
}

Jacobian VolumetricModel::jacobian(const JointVector& q) const {
  Jacobian j = base_->jacobian(q);
  const auto smp = map_->sample(base_->linear_position(q));
  if (!smp) {
    j.setConstant(std::numeric_limits<double>::quiet_NaN());
    return j;
  }
  const Eigen::Matrix3d r = base_->machine_to_workpiece(q);
  constexpr double kStep = 1e-4;  // mm / degree; both virtuals are smooth, and exact for linear ones
  for (int k = 0; k < joint_count(); ++k) {
    JointVector qp = q;
    JointVector qm = q;
    qp[k] += kStep;
    qm[k] -= kStep;
    const Eigen::Vector3d dlin = (base_->linear_position(qp) - base_->linear_position(qm)) / (2 * kStep);
    const Eigen::Matrix3d dr = (base_->machine_to_workpiece(qp) - base_->machine_to_workpiece(qm)) / (2 * kStep);
    j.block<3, 1>(0, k) += r * smp->gradient * dlin + dr * smp->error;
  }
  return j;
}

Solve VolumetricModel::inverse(const Pose& target, const JointVector& start, JointVector& q,
                               const IkOptions& opt) const {
  IkOptions inner = opt;
  inner.check_limits = false;  // checked once on the final values
  Pose shifted = target;
  Solve s;
  double prev = std::numeric_limits<double>::infinity();
  for (int pass = 0;; ++pass) {
    s = base_->inverse(shifted, start, q, inner);
    if (!s.ok()) return s;
    const auto c = correction(q);
    if (!c) {
      s.status = Status::outside_map;
      return s;
    }
    // The decorated pose of q is (base pose ≈ shifted.p) + c; aim the base at target − c.
    const Eigen::Vector3d next = target.p - *c;
    const double moved = (next - shifted.p).norm();
    s.iterations = pass + 1;
    s.residual_mm += moved;
    if (moved <= opt.tolerance_mm) break;
    if (pass >= opt.max_iterations) {
      s.status = Status::no_convergence;
      return s;
    }
    if (pass > 3 && moved > 4 * prev) {
      s.status = Status::diverged;
      return s;
    }
    prev = moved;
    shifted.p = next;
  }
  if (opt.check_limits) {
    s.joint = joint_outside_limits(*this, q);
    if (s.joint >= 0) s.status = Status::out_of_limits;
  }
  return s;
}

std::shared_ptr<const Model> VolumetricModel::with_values(std::vector<double> values) const {
  return std::make_shared<const VolumetricModel>(base_->with_values(std::move(values)), map_);
}

Eigen::Matrix3d VolumetricModel::machine_to_workpiece(const JointVector& q) const {
  return base_->machine_to_workpiece(q);
}

Eigen::Vector3d VolumetricModel::linear_position(const JointVector& q) const { return base_->linear_position(q); }

}  // namespace postproc::kin
