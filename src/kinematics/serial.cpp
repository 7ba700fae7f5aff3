// Serial-chain machines: configuration checks, the ISO 230-7 parameter vector, the geometry those
// parameters give, forward kinematics and the analytic Jacobian (screw axes of the erroneous
// chain). The inverse is in serial_inverse.cpp.
#include "postproc/kinematics/serial.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "postproc/error.hpp"
#include "src/kinematics/serial_impl.hpp"

namespace postproc::kin {

using serial_detail::Rigid;
using serial_detail::rotation_about;
using serial_detail::rotation_exp;

namespace serial_detail {

namespace {
// (1 − f·t)·I + g·[e]× + f·e·eᵀ, i.e. I + g·[e]× + f·[e]×² since [e]×² = e·eᵀ − t·I (t = |e|²).
// Written out: this runs for every tabled axis of every evaluation.
Eigen::Matrix3d so3_series(const Eigen::Vector3d& e, double t, double g, double f) {
  const double x = e.x();
  const double y = e.y();
  const double z = e.z();
  const double d = 1 - f * t;
  const double fxy = f * x * y;
  const double fxz = f * x * z;
  const double fyz = f * y * z;
  Eigen::Matrix3d m;
  m << d + f * x * x, fxy - g * z, fxz + g * y,  //
      fxy + g * z, d + f * y * y, fyz - g * x,   //
      fxz - g * y, fyz + g * x, d + f * z * z;
  return m;
}
}  // namespace

Eigen::Matrix3d rotation_exp(const Eigen::Vector3d& e, Eigen::Matrix3d* jl) {
  // R = I + a[e] + b[e]², Jl = I + b[e] + c[e]²; series below 1e-2 rad, where the closed forms
  // lose digits to cancellation (error tables and ISO errors are always in that range, so this
  // path costs no trigonometry).
  const double t = e.squaredNorm();
  double a = 0;
  double b = 0;
  double c = 0;
  if (t < 1e-4) {
    a = 1 - t / 6 * (1 - t / 20 * (1 - t / 42));
    b = 0.5 * (1 - t / 12 * (1 - t / 30 * (1 - t / 56)));
    c = (1 - t / 20 * (1 - t / 42 * (1 - t / 72))) / 6;
  } else {
    const double th = std::sqrt(t);
    const double s = std::sin(th);
    a = s / th;
    b = (1 - std::cos(th)) / t;
    c = (th - s) / (t * th);
  }
  if (jl) *jl = so3_series(e, t, b, c);
  return so3_series(e, t, a, b);
}

Eigen::Matrix3d rotation_about(const Eigen::Vector3d& d, double a) {
  const double c = std::cos(a);
  const double s = std::sin(a);
  Eigen::Matrix3d r = (1 - c) * d * d.transpose();
  r.diagonal().array() += c;
  r(0, 1) -= s * d.z();
  r(1, 0) += s * d.z();
  r(0, 2) += s * d.y();
  r(2, 0) -= s * d.y();
  r(1, 2) -= s * d.x();
  r(2, 1) += s * d.x();
  return r;
}

}  // namespace serial_detail

namespace {

constexpr const char* kXyz = "XYZ";
constexpr const char* kAbc = "ABC";
constexpr double kParallel = 1e-9;  // |1 − |d·e_I|| below which a rotary axis counts as ∥ e_I

[[noreturn]] void bad(const std::string& what) { throw Error(ExitCode::usage, "serial machine: " + what); }

std::string show(const Eigen::Vector3d& v) { return fmt::format("({:g}, {:g}, {:g})", v.x(), v.y(), v.z()); }

// The machine axis (0 X, 1 Y, 2 Z) a rotary axis turns about; its direction is already unit.
int machine_axis(const Eigen::Vector3d& d) {
  int i = 0;
  d.cwiseAbs().maxCoeff(&i);
  return std::abs(std::abs(d[i]) - 1) <= kParallel ? i : -1;
}

// Every axis in joint order, with its side.
std::vector<const SerialAxis*> all_axes(const SerialConfig& cfg) {
  std::vector<const SerialAxis*> v;
  for (const auto& a : cfg.workpiece_side) v.push_back(&a);
  for (const auto& a : cfg.tool_side) v.push_back(&a);
  return v;
}

void check_unit(const Eigen::Vector3d& v, const std::string& what) {
  if (!v.allFinite() || v.norm() < 1e-9) bad(fmt::format("{} {} is zero or not finite", what, show(v)));
}

void check_table(const SerialAxis& a) {
  const auto& t = a.table;
  if (t.position.size() != t.error.size())
    bad(fmt::format("axis '{}': error-motion table has {} positions and {} error rows", a.name, t.position.size(),
                    t.error.size()));
  for (std::size_t r = 0; r < t.position.size(); ++r) {
    const bool finite = std::isfinite(t.position[r]) &&
                        std::all_of(t.error[r].begin(), t.error[r].end(), [](double x) { return std::isfinite(x); });
    if (!finite) bad(fmt::format("axis '{}': error-motion table row {} is not finite", a.name, r + 1));
    if (r > 0 && !(t.position[r] > t.position[r - 1]))
      bad(fmt::format("axis '{}': error-motion table positions must increase strictly (row {}: {:g} after {:g})",
                      a.name, r + 1, t.position[r], t.position[r - 1]));
  }
}

// Checks what the chain needs; throws usage errors naming the axis and the value.
void validate(const SerialConfig& cfg) {
  const auto axes = all_axes(cfg);
  if (axes.empty() || static_cast<int>(axes.size()) > kMaxJoints)
    bad(fmt::format("{} axes ({} on the workpiece side, {} on the tool side); 1 to {} supported", axes.size(),
                    cfg.workpiece_side.size(), cfg.tool_side.size(), kMaxJoints));
  for (std::size_t i = 0; i < axes.size(); ++i) {
    const SerialAxis& a = *axes[i];
    if (a.name.empty()) bad(fmt::format("axis {} has no name", i + 1));
    for (std::size_t k = 0; k < i; ++k)
      if (axes[k]->name == a.name) bad(fmt::format("axis '{}' appears twice", a.name));
    check_unit(a.direction, fmt::format("axis '{}': direction", a.name));
    if (std::isnan(a.min) || std::isnan(a.max) || a.min > a.max)
      bad(fmt::format("axis '{}': travel [{:g}, {:g}] is empty", a.name, a.min, a.max));
    check_table(a);
    if (a.type != JointType::rotary) continue;
    if (!a.pivot.allFinite()) bad(fmt::format("axis '{}': pivot {} is not finite", a.name, show(a.pivot)));
    const int i_axis = machine_axis(a.direction.normalized());
    if (i_axis < 0)
      bad(fmt::format("rotary axis '{}': direction {} is not parallel to X, Y or Z; ISO 230-7 error names need "
                      "A ∥ X, B ∥ Y, C ∥ Z",
                      a.name, show(a.direction)));
    if (a.name.size() == 1 && a.name[0] >= 'A' && a.name[0] <= 'C' && a.name[0] - 'A' != i_axis)
      bad(fmt::format("rotary axis '{}' turns about {} {}; an axis named {} must be parallel to {}", a.name,
                      kXyz[i_axis], show(a.direction), a.name, kXyz[a.name[0] - 'A']));
  }
  check_unit(cfg.tool_axis, "tool axis");
  check_unit(cfg.tool_x, "tool x direction");
  if (std::abs(cfg.tool_axis.normalized().dot(cfg.tool_x.normalized())) > 1e-6)
    bad(fmt::format("tool x direction {} is not normal to the tool axis {}", show(cfg.tool_x), show(cfg.tool_axis)));
  if (!cfg.spindle_point.allFinite() || !std::isfinite(cfg.tool_length))
    bad("spindle point or tool length is not finite");
}

SerialConfig normalized(SerialConfig cfg) {
  validate(cfg);
  for (auto* side : {&cfg.workpiece_side, &cfg.tool_side})
    for (auto& a : *side) a.direction.normalize();
  cfg.tool_axis.normalize();
  cfg.tool_x = (cfg.tool_x - cfg.tool_x.dot(cfg.tool_axis) * cfg.tool_axis).normalized();
  return cfg;
}

std::vector<Joint> make_joints(const SerialConfig& cfg) {
  std::vector<Joint> j;
  for (const auto* a : all_axes(cfg)) j.push_back(Joint{a->name, a->type, a->min, a->max});
  return j;
}

bool has_linear(const SerialConfig& cfg, char name) {
  for (const auto* a : all_axes(cfg))
    if (a->type == JointType::linear && a->name.size() == 1 && a->name[0] == name) return true;
  return false;
}

std::vector<Parameter> make_params(const SerialConfig& cfg) {
  validate(cfg);
  std::vector<Parameter> p;
  const auto add = [&p](std::string name, const char* unit, std::string what) {
    p.push_back(Parameter{std::move(name), unit, 0, true, std::move(what)});
  };
  for (const auto* a : all_axes(cfg)) {
    const std::string& k = a->name;
    if (a->type == JointType::linear) {
      add(fmt::format("E{0}0{0}", k), "mm", fmt::format("zero offset of {} added to its commanded value, mm", k));
      continue;
    }
    const int i = machine_axis(a->direction.normalized());
    const int j1 = i == 0 ? 1 : 0;
    const int j2 = i == 2 ? 1 : 2;
    for (int j : {j1, j2})
      add(fmt::format("E{}0{}", kXyz[j], k), "mm",
          fmt::format("location of the {} axis line along machine {}, mm", k, kXyz[j]));
    for (int j : {j1, j2})
      add(fmt::format("E{}0{}", kAbc[j], k), "rad",
          fmt::format("orientation of the {} axis: tilt about machine {} (right-handed), rad", k, kXyz[j]));
    add(fmt::format("E{}0{}", kAbc[i], k), "rad", fmt::format("zero-position error of {} added to its angle, rad", k));
  }
  if (has_linear(cfg, 'X') && has_linear(cfg, 'Y'))
    add("EC0Y", "rad", "squareness of Y to X: Y's direction turned about machine Z, rad");
  if (has_linear(cfg, 'X') && has_linear(cfg, 'Z'))
    add("EB0Z", "rad", "squareness of Z to X: Z's direction turned about machine Y, rad");
  if (has_linear(cfg, 'Y') && has_linear(cfg, 'Z'))
    add("EA0Z", "rad", "squareness of Z to Y: Z's direction turned about machine X, rad");
  p.push_back(Parameter{"tool.length", "mm", cfg.tool_length, false,
                        "tool length from the spindle gauge point to the tip along -tool axis, mm"});
  return p;
}

std::vector<double> nominal_values(const SerialConfig& cfg) {
  std::vector<double> v;
  for (const auto& p : make_params(cfg)) v.push_back(p.nominal);
  return v;
}

}  // namespace

SerialModel::SerialModel(SerialConfig cfg) : SerialModel(cfg, nominal_values(cfg)) {}

SerialModel::SerialModel(SerialConfig cfg, std::vector<double> values)
    : Model(make_joints(cfg), make_params(cfg), std::move(values)), cfg_(normalized(std::move(cfg))) {
  for (std::size_t i = 0; i < values_.size(); ++i)
    if (!std::isfinite(values_[i]))
      throw Error(ExitCode::usage, fmt::format("serial machine: parameter {} = {} is not finite", params_[i].name,
                                               values_[i]));
  const auto value = [this](const std::string& name) {
    const int i = parameter_index(name);
    return i < 0 ? 0.0 : values_[static_cast<std::size_t>(i)];
  };
  auto impl = std::make_shared<Impl>();
  impl->workpiece_count = static_cast<int>(cfg_.workpiece_side.size());
  const Eigen::Vector3d square_y(0, 0, value("EC0Y"));
  const Eigen::Vector3d square_z(value("EA0Z"), value("EB0Z"), 0);
  for (const auto* a : all_axes(cfg_)) {
    Impl::Axis g;
    g.rotary = a->type == JointType::rotary;
    g.dir = a->direction;
    g.point = a->pivot;
    const std::string& k = a->name;
    if (!g.rotary) {
      g.offset = value(fmt::format("E{0}0{0}", k));
      if (k == "Y") g.dir = rotation_exp(square_y) * g.dir;
      if (k == "Z") g.dir = rotation_exp(square_z) * g.dir;
    } else {
      ++impl->rotary_count;
      const int i = machine_axis(g.dir);
      Eigen::Vector3d tilt = Eigen::Vector3d::Zero();
      for (int j = 0; j < 3; ++j) {
        if (j == i) continue;
        g.point[j] += value(fmt::format("E{}0{}", kXyz[j], k));
        tilt[j] = value(fmt::format("E{}0{}", kAbc[j], k));
      }
      g.dir = rotation_exp(tilt) * g.dir;
      g.offset = value(fmt::format("E{}0{}", kAbc[i], k));
    }
    g.pos = a->table.position;
    g.val = a->table.error;
    for (std::size_t r = 1; r < g.pos.size(); ++r) {
      std::array<double, 6> s{};
      for (std::size_t c = 0; c < 6; ++c) s[c] = (g.val[r][c] - g.val[r - 1][c]) / (g.pos[r] - g.pos[r - 1]);
      g.slope.push_back(s);
    }
    if (g.pos.size() >= 2) {
      const double h = (g.pos.back() - g.pos.front()) / static_cast<double>(g.pos.size() - 1);
      bool even = true;
      for (std::size_t r = 0; r < g.pos.size(); ++r)
        even = even && std::abs(g.pos[r] - (g.pos.front() + h * static_cast<double>(r))) <= 1e-9 * h;
      if (even) g.inv_step = 1 / h;
    }
    impl->axes.push_back(std::move(g));
  }
  impl->tool0.r.col(0) = cfg_.tool_x;
  impl->tool0.r.col(1) = cfg_.tool_axis.cross(cfg_.tool_x);
  impl->tool0.r.col(2) = cfg_.tool_axis;
  impl->tool0.t = cfg_.spindle_point - value("tool.length") * cfg_.tool_axis;
  impl_ = std::move(impl);
}

std::shared_ptr<const Model> SerialModel::with_values(std::vector<double> values) const {
  if (values.size() != params_.size())
    throw Error(ExitCode::internal, fmt::format("serial machine: {} parameter values given, the model has {}",
                                                values.size(), params_.size()));
  return std::shared_ptr<const SerialModel>(new SerialModel(cfg_, std::move(values)));
}

std::shared_ptr<const SerialModel> SerialModel::without_tables() const {
  SerialConfig c = cfg_;
  for (auto* side : {&c.workpiece_side, &c.tool_side})
    for (auto& a : *side) a.table = {};
  return std::shared_ptr<const SerialModel>(new SerialModel(std::move(c), values_));
}

SerialModel::Impl::Local SerialModel::Impl::local(int j, double q, bool twist) const {
  const Axis& g = axes[static_cast<std::size_t>(j)];
  Local l;
  // Nominal (parameter-erroneous) motion: a translation along dir, or a turn about the axis line.
  if (!g.rotary) {
    l.x.t = g.dir * (q + g.offset);
    l.w.setZero();
    l.v = g.dir;
  } else {
    l.turns = true;
    l.x.r = rotation_about(g.dir, q * kDeg + g.offset);
    l.x.t = g.point - l.x.r * g.point;
    l.w = g.dir * kDeg;
    if (twist) l.v = -l.w.cross(g.point);
  }
  if (g.pos.empty()) return l;
  // Error motion E after the motion: x ↦ Re(x − c) + c + δ about the reference point c (the
  // carried origin d·s, or the axis point). Twist of E∘M: w = Jl·ε' + Re·w_M; v = δ' + v_M − w × t
  // for linear axes (t = c + δ), δ' − w × (c + δ) for rotary ones.
  std::array<double, 6> e = g.val.back();
  std::array<double, 6> de{};
  if (q < g.pos.front()) {
    e = g.val.front();
  } else if (q < g.pos.back()) {
    std::size_t k = 0;
    if (g.inv_step > 0) {
      k = std::min(static_cast<std::size_t>((q - g.pos.front()) * g.inv_step), g.slope.size() - 1);
    } else {
      k = static_cast<std::size_t>(std::upper_bound(g.pos.begin(), g.pos.end(), q) - g.pos.begin() - 1);
    }
    de = g.slope[k];
    for (std::size_t c = 0; c < 6; ++c) e[c] = g.val[k][c] + de[c] * (q - g.pos[k]);
  }
  const Eigen::Vector3d delta(e[0], e[1], e[2]);
  Eigen::Matrix3d jl;
  const Eigen::Matrix3d re = rotation_exp(Eigen::Vector3d(e[3], e[4], e[5]), twist ? &jl : nullptr);
  l.turns = true;
  l.x.r = g.rotary ? Eigen::Matrix3d(re * l.x.r) : re;
  const Eigen::Vector3d c = g.rotary ? Eigen::Vector3d(g.point + delta) : Eigen::Vector3d(l.x.t + delta);
  l.x.t = g.rotary ? Eigen::Vector3d(c - l.x.r * g.point) : c;
  if (!twist) return l;
  const Eigen::Vector3d ddelta(de[0], de[1], de[2]);
  const Eigen::Vector3d we = jl * Eigen::Vector3d(de[3], de[4], de[5]);
  l.w = we + re * l.w;
  l.v = ddelta - l.w.cross(c) + (g.rotary ? Eigen::Vector3d::Zero() : g.dir);
  return l;
}

void SerialModel::Impl::evaluate(const JointVector& q, Pose& out, Jacobian* jac, Rigid* workpiece) const {
  // Both chains from the bed; the twist of joint j in the machine frame is the local twist moved
  // by the product of the bodies before it (Ad).
  const int n = static_cast<int>(axes.size());
  std::array<Eigen::Vector3d, kMaxJoints> wb;
  std::array<Eigen::Vector3d, kMaxJoints> vb;
  Rigid side[2];
  for (int j = 0; j < n; ++j) {
    Rigid& a = side[j < workpiece_count ? 0 : 1];
    const Local l = local(j, q[j], jac != nullptr);
    if (jac) {
      const auto k = static_cast<std::size_t>(j);
      wb[k].noalias() = a.r * l.w;
      vb[k].noalias() = a.r * l.v;
      vb[k] += a.t.cross(wb[k]);
    }
    a.t.noalias() += a.r * l.x.t;
    if (l.turns) a.r = a.r * l.x.r;  // (a product into its own operand: Eigen uses a temporary)
  }
  const Rigid& tw = side[0];
  const Rigid tool = side[1] * tool0;  // tool frame → machine frame
  // Pose in the workpiece frame: tw⁻¹ · tool.
  out.r.noalias() = tw.r.transpose() * tool.r;
  out.p.noalias() = tw.r.transpose() * (tool.t - tw.t);
  if (workpiece) *workpiece = tw;
  if (!jac) return;
  jac->resize(6, n);
  for (int j = 0; j < n; ++j) {
    const auto k = static_cast<std::size_t>(j);
    // Tool-side joints move the tip point (fixed in the machine frame at this instant) directly;
    // workpiece-side ones move the workpiece frame, so the tip moves the opposite way in it.
    const double sign = j < workpiece_count ? -1.0 : 1.0;
    jac->block<3, 1>(0, j).noalias() = sign * (tw.r.transpose() * (wb[k].cross(tool.t) + vb[k]));
    jac->block<3, 1>(3, j).noalias() = sign * (tw.r.transpose() * wb[k]);
  }
}

Solve SerialModel::forward(const JointVector& q, Pose& out) const {
  impl_->evaluate(q, out, nullptr);
  return {};
}

Jacobian SerialModel::jacobian(const JointVector& q) const {
  Pose p;
  Jacobian j;
  impl_->evaluate(q, p, &j);
  return j;
}

Eigen::Matrix3d SerialModel::machine_to_workpiece(const JointVector& q) const {
  Pose p;
  Rigid tw;
  impl_->evaluate(q, p, nullptr, &tw);
  return tw.r.transpose();
}

}  // namespace postproc::kin
