// Uncertainty to the cut: a bound per motion of a compensated program from the calibration's
// covariance and the output rounding (see residual_bounds.hpp).
#include "postproc/compensation/residual_bounds.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/gcode/program.hpp"
#include "postproc/kinematics/serial.hpp"
#include "postproc/machine/program_map.hpp"
#include "src/compensation/compensate_support.hpp"

namespace postproc::comp {
namespace {

/// The actual model of one tool length and, unless it is a serial chain (analytic Jacobian), its
/// parameter-perturbed copies (central differences).
struct Perturbed {
  kin::ModelPtr base;
  std::vector<kin::ModelPtr> plus, minus;
  std::vector<double> step;
};

Perturbed perturb(const kin::ModelPtr& base, std::span<const int> params) {
  Perturbed p;
  p.base = base;
  if (dynamic_cast<const kin::SerialModel*>(base.get()) != nullptr) return p;  // analytic
  for (int k : params) {
    const double h = base->parameters()[static_cast<std::size_t>(k)].unit == "mm" ? 1e-5 : 1e-7;  // mm; rad, ratio
    std::vector<double> a = base->values(), b = base->values();
    a[static_cast<std::size_t>(k)] += h;
    b[static_cast<std::size_t>(k)] -= h;
    p.plus.push_back(base->with_values(std::move(a)));
    p.minus.push_back(base->with_values(std::move(b)));
    p.step.push_back(h);
  }
  return p;
}

/// Largest eigenvalue of a symmetric 3×3 matrix (≥ 0).
double largest(const Eigen::Matrix3d& s) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> e(0.5 * (s + s.transpose()), Eigen::EigenvaluesOnly);
  return std::max(0.0, e.eigenvalues().maxCoeff());
}

}  // namespace

double chi_quantile_root(int dof, double confidence) {
  // Wilson–Hilferty: χ²_p(α) ≈ p·(1 − 2/(9p) + z_α·√(2/(9p)))³, z the normal quantile.
  const double z = [&] {
    // Acklam's rational approximation of the normal quantile (|error| < 1.2e-9).
    const double p = std::clamp(confidence, 1e-12, 1 - 1e-12);
    static constexpr double a[] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                                   1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
    static constexpr double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                                   6.680131188771972e+01,  -1.328068155288572e+01};
    static constexpr double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                   -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
    static constexpr double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                                   3.754408661907416e+00};
    if (p < 0.02425) {
      const double q = std::sqrt(-2 * std::log(p));
      return (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
             ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
    }
    if (p > 1 - 0.02425) {
      const double q = std::sqrt(-2 * std::log(1 - p));
      return -(((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
             ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
    }
    const double q = p - 0.5, r = q * q;
    return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
           (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
  }();
  const double n = std::max(1, dof);
  const double t = 1 - 2 / (9 * n) + z * std::sqrt(2 / (9 * n));
  return std::sqrt(n * t * t * t);
}

BoundsResult residual_bounds(std::string_view written, const gcode::Dialect& d, const machine::Machine& m,
                             const BoundOptions& options) {
  if (!m.uncertainty)
    throw Error(ExitCode::usage,
                fmt::format("{}: the machine file has no [uncertainty] table, so nothing says how well its errors are "
                            "known; calibrate it with postproc calibrate (which writes the table) to get bounds",
                            m.file));
  const machine::Uncertainty& u = *m.uncertainty;
  BoundsResult r;
  r.parameters = static_cast<int>(u.parameters.size());
  r.k = chi_quantile_root(r.parameters, options.confidence);

  MotionCollector collected(d);
  {
    gcode::DiagnosticSink quiet(0);
    gcode::LineReader reader{written};
    gcode::run_program(reader, d, "written", quiet, collected);
  }
  ToolLengthModels models(m);
  std::map<double, Perturbed> perturbed;  // per tool length
  kin::JointVector start = kin::JointVector::Zero(m.nominal->joint_count());
  const auto p = static_cast<Eigen::Index>(u.parameters.size());
  Eigen::MatrixXd jac(6, p);
  for (const auto& [line, c] : collected.by_line) {
    const gcode::Motion& mo = c.motion;
    const Form f = form_of(m, mo);
    const gcode::AxisMask need = written_axes(m, f);
    const auto length = machine::tool_length_of(m, mo);
    if (c.reference || mo.type == gcode::MotionType::drill_cycle || (mo.known & need) != need || !length) {
      ++r.skipped;
      continue;
    }
    auto map = map_of(m, models, mo);
    kin::Pose got;
    kin::JointVector q;
    if (!map || !map->real(Command{mo.end, mo.tool_vector}, start, got, q).ok()) {
      ++r.skipped;
      continue;
    }
    auto it = perturbed.find(*length);
    if (it == perturbed.end()) it = perturbed.emplace(*length, perturb(models.with_tool_length(*length).second, u.parameters)).first;
    const Perturbed& pm = it->second;
    bool ok = true;
    if (const auto* serial = dynamic_cast<const kin::SerialModel*>(pm.base.get())) {
      // Serial chains: the analytic identification Jacobian (no perturbed models needed).
      const Eigen::Matrix<double, 6, Eigen::Dynamic> all = serial->identification_jacobian(q);
      for (Eigen::Index k = 0; k < p; ++k) jac.col(k) = all.col(u.parameters[static_cast<std::size_t>(k)]);
    }
    for (Eigen::Index k = 0; k < p && ok && pm.plus.size() == static_cast<std::size_t>(p); ++k) {
      kin::Pose a, b;
      ok = pm.plus[static_cast<std::size_t>(k)]->forward(q, a).ok() && pm.minus[static_cast<std::size_t>(k)]->forward(q, b).ok();
      if (!ok) break;
      const double h2 = 2 * pm.step[static_cast<std::size_t>(k)];
      jac.col(k).head<3>() = (a.p - b.p) / h2;
      jac.col(k).tail<3>() = kin::rotation_difference(a.r, b.r) / h2;
    }
    if (!ok) {
      ++r.skipped;
      continue;
    }
    const Eigen::MatrixXd s6 = jac * u.covariance * jac.transpose();
    const Eigen::Matrix3d tip = s6.topLeftCorner<3, 3>();
    const Eigen::Vector3d o = got.axis();
    const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - o * o.transpose();
    const Eigen::Matrix3d rot = across * s6.bottomRightCorner<3, 3>() * across.transpose();
    const RoundingBound rb = rounding_bound(m, *map, mo, need, f, start, got);
    BlockBound bb;
    bb.line = line;
    bb.joints = q;
    bb.tool_length = *length;
    bb.rounding_mm = rb.tip_mm;
    bb.tip_mm = r.k * std::sqrt(largest(tip)) + rb.tip_mm;
    const bool oriented = f != Form::axes || m.nominal->joint_count() > 3;
    bb.axis_rad = oriented ? r.k * std::sqrt(largest(rot)) + rb.axis_rad : 0.0;
    if (!u.region_min.empty())
      for (int j = 0; j < q.size(); ++j)
        if (q[j] < u.region_min[static_cast<std::size_t>(j)] - 1e-9 || q[j] > u.region_max[static_cast<std::size_t>(j)] + 1e-9) {
          bb.outside_region = true;
          bb.outside_joint = j;
          break;
        }
    r.outside_region += bb.outside_region ? 1 : 0;
    r.max_tip_mm = std::max(r.max_tip_mm, bb.tip_mm);
    r.max_axis_rad = std::max(r.max_axis_rad, bb.axis_rad);
    r.blocks.push_back(bb);
    start = q;
  }
  return r;
}

std::string bounds_csv(const BoundsResult& r) {
  std::string s = "line,bound_tip_mm,bound_axis_rad\n";
  for (const BlockBound& b : r.blocks) s += fmt::format("{},{:.9g},{:.9g}\n", b.line, b.tip_mm, b.axis_rad);
  return s;
}

}  // namespace postproc::comp
