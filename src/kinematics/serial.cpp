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
  add_skew(r, s, d);
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
      p.push_back(Parameter{fmt::format("E{0}{0}.scale", k), "ratio", 0, true,
                            fmt::format("positioning scale error of {}: its travel is (1 + scale) times the commanded "
                                        "one (the linear part of ISO 230-2's positioning deviation E{}{})",
                                        k, k, k)});
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
      g.gain = 1 + value(fmt::format("E{0}{0}.scale", k));
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
    if (g.rotary) {
      g.dd = g.dir * g.dir.transpose();
      g.pq = g.point - g.dir.dot(g.point) * g.dir;
      g.pk = g.dir.cross(g.point);
    }
    const auto& pos = a->table.position;
    const auto& val = a->table.error;
    g.rows.resize(pos.size());
    for (std::size_t r = 0; r < pos.size(); ++r) {
      g.rows[r].pos = pos[r];
      g.rows[r].val = val[r];
      if (r + 1 < pos.size())
        for (std::size_t c = 0; c < 6; ++c) g.rows[r].slope[c] = (val[r + 1][c] - val[r][c]) / (pos[r + 1] - pos[r]);
    }
    if (pos.size() >= 2) {
      const double h = (pos.back() - pos.front()) / static_cast<double>(pos.size() - 1);
      bool even = true;
      for (std::size_t r = 0; r < pos.size(); ++r)
        even = even && std::abs(pos[r] - (pos.front() + h * static_cast<double>(r))) <= 1e-9 * h;
      if (even) g.inv_step = 1 / h;
    }
    impl->axes.push_back(std::move(g));
  }
  // What each parameter moves (identification_jacobian), in parameter order.
  {
    impl->roles.resize(params_.size());
    int j = 0;
    for (const auto* a : all_axes(cfg_)) {
      const std::string& k = a->name;
      auto set = [&](const std::string& name, Impl::Role role, const Eigen::Vector3d& e) {
        const int i = parameter_index(name);
        if (i >= 0) impl->roles[static_cast<std::size_t>(i)] = Impl::ParamRole{role, j, e};
      };
      if (a->type == JointType::linear) {
        set(fmt::format("E{0}0{0}", k), Impl::Role::linear_offset, Eigen::Vector3d::Zero());
        set(fmt::format("E{0}{0}.scale", k), Impl::Role::linear_scale, Eigen::Vector3d::Zero());
        if (k == "Y") {
          set("EC0Y", Impl::Role::squareness, Eigen::Vector3d::UnitZ());
          impl->tilt[static_cast<std::size_t>(j)] = square_y;
        }
        if (k == "Z") {
          set("EA0Z", Impl::Role::squareness, Eigen::Vector3d::UnitX());
          set("EB0Z", Impl::Role::squareness, Eigen::Vector3d::UnitY());
          impl->tilt[static_cast<std::size_t>(j)] = square_z;
        }
      } else {
        const int i = machine_axis(a->direction.normalized());
        Eigen::Vector3d tilt = Eigen::Vector3d::Zero();
        for (int c = 0; c < 3; ++c) {
          if (c == i) continue;
          set(fmt::format("E{}0{}", kXyz[c], k), Impl::Role::rotary_location, Eigen::Vector3d::Unit(c));
          set(fmt::format("E{}0{}", kAbc[c], k), Impl::Role::rotary_tilt, Eigen::Vector3d::Unit(c));
          tilt[c] = value(fmt::format("E{}0{}", kAbc[c], k));
        }
        set(fmt::format("E{}0{}", kAbc[i], k), Impl::Role::rotary_offset, Eigen::Vector3d::Zero());
        impl->tilt[static_cast<std::size_t>(j)] = tilt;
      }
      ++j;
    }
    const int tl = parameter_index("tool.length");
    if (tl >= 0) impl->roles[static_cast<std::size_t>(tl)] = Impl::ParamRole{Impl::Role::tool_length, -1, Eigen::Vector3d::Zero()};
    impl->tool_axis = cfg_.tool_axis;
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

namespace {

// Coefficients of exp([e]×) = I + a[e]× + b[e]×² and of its left Jacobian I + b[e]× + c[e]×²
// (t = |e|²), as rotation_exp computes them.
inline void exp_coefficients(double t, double& a, double& b, double& c) {
  if (t < 1e-4) {  // (products with the reciprocals: no division on the path of every table)
    a = 1 - t * (1.0 / 6) * (1 - t * (1.0 / 20) * (1 - t * (1.0 / 42)));
    b = 0.5 * (1 - t * (1.0 / 12) * (1 - t * (1.0 / 30) * (1 - t * (1.0 / 56))));
    c = (1 - t * (1.0 / 20) * (1 - t * (1.0 / 42) * (1 - t * (1.0 / 72)))) * (1.0 / 6);
  } else {
    const double th = std::sqrt(t);
    const double s = std::sin(th);
    a = s / th;
    b = (1 - std::cos(th)) / t;
    c = (th - s) / (t * th);
  }
}

// m = (1 − f·t)·I + g·[e]× + f·e·eᵀ.
inline void so3_into(double x, double y, double z, double t, double g, double f, Eigen::Matrix3d& m) {
  const double d = 1 - f * t;
  const double fxy = f * x * y;
  const double fxz = f * x * z;
  const double fyz = f * y * z;
  m(0, 0) = d + f * x * x;
  m(1, 0) = fxy + g * z;
  m(2, 0) = fxz - g * y;
  m(0, 1) = fxy - g * z;
  m(1, 1) = d + f * y * y;
  m(2, 1) = fyz + g * x;
  m(0, 2) = fxz + g * y;
  m(1, 2) = fyz - g * x;
  m(2, 2) = d + f * z * z;
}

}  // namespace

void SerialModel::Impl::trig(const JointVector& q, Trig& t) const {
  const int n = static_cast<int>(axes.size());
  for (int j = 0; j < n; ++j) {
    const Axis& g = axes[static_cast<std::size_t>(j)];
    if (!g.rotary) continue;
    serial_detail::sincos_deg(q[j], g.offset, t.s[static_cast<std::size_t>(j)], t.c[static_cast<std::size_t>(j)]);
  }
}

template <bool Twist>
void SerialModel::Impl::chain(const JointVector& q, const Trig& tr, Chain& out, int* hint, Record* rec) const {
  // Per joint: its motion in its parent's frame (rotation lr, translation lt, turning or not) and,
  // for the Jacobian, its local twist (lw, lv); then the product into its side's transform, which
  // moves the twist to the machine frame (Ad). A side whose rotation is still the identity (the
  // first joints from the bed) takes the local values as they are.
  const int n = static_cast<int>(axes.size());
  bool identity[2] = {true, true};
  for (Rigid& a : out.side) {
    a.r.setIdentity();
    a.t.setZero();
  }
  for (int j = 0; j < n; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const Axis& g = axes[k];
    const int sd = j < workpiece_count ? 0 : 1;
    Rigid& a = out.side[sd];
    Eigen::Matrix3d lr;
    Eigen::Vector3d lt;
    Eigen::Vector3d lw;
    Eigen::Vector3d lv;
    bool turns = g.rotary;
    if (rec) {
      rec->before[k] = a;
      rec->re[k].setIdentity();
      rec->et[k].setZero();
      rec->cp[k] = g.point;
    }
    // Nominal (parameter-erroneous) motion: a translation along dir, or a turn about the axis line.
    if (g.rotary) {
      const double s = tr.s[k];
      const double c = tr.c[k];
      const double c1 = 1 - c;
      const Eigen::Vector3d& d = g.dir;
      lr = c1 * g.dd;
      lr.diagonal().array() += c;
      serial_detail::add_skew(lr, s, d);
      lt = c1 * g.pq - s * g.pk;
      if constexpr (Twist) {
        lw = d * kDeg;
        lv = -kDeg * g.pk;  // −w × point
      }
    } else {
      lt = g.dir * (q[j] * g.gain + g.offset);
      if constexpr (Twist) {
        lw.setZero();
        lv = g.dir * g.gain;
      }
    }
    if (!g.rows.empty()) {
      // Error motion E after the motion: x ↦ Re(x − c) + c + δ about the reference point c (the
      // carried origin d·s, or the axis point). Twist of E∘M: w = Jl·ε' + Re·w_M; v = δ' + v_M − w × t
      // for linear axes (t = c + δ), δ' − w × (c + δ) for rotary ones.
      const double x = q[j];
      const Row* row = &g.rows.back();
      double dx = 0;
      bool inside = false;
      if (x < g.rows.front().pos) {
        row = &g.rows.front();
      } else if (x < g.rows.back().pos) {
        std::size_t i = 0;
        const std::size_t segments = g.rows.size() - 1;
        if (g.inv_step > 0) {
          i = std::min(static_cast<std::size_t>((x - g.rows.front().pos) * g.inv_step), segments - 1);
        } else {
          const std::size_t h = hint ? static_cast<std::size_t>(hint[j]) : segments;
          if (h < segments && g.rows[h].pos <= x && x < g.rows[h + 1].pos) {
            i = h;
          } else {
            const auto it = std::upper_bound(g.rows.begin(), g.rows.end(), x,
                                             [](double v, const Row& r) { return v < r.pos; });
            i = static_cast<std::size_t>(it - g.rows.begin() - 1);
            if (hint) hint[j] = static_cast<int>(i);
          }
        }
        row = &g.rows[i];
        dx = x - row->pos;
        inside = true;
      }
      const std::array<double, 6>& v0 = row->val;
      const std::array<double, 6>& sl = row->slope;
      double e[6];
      for (int c = 0; c < 6; ++c) e[c] = inside ? v0[static_cast<std::size_t>(c)] + sl[static_cast<std::size_t>(c)] * dx
                                                : v0[static_cast<std::size_t>(c)];
      const double t = e[3] * e[3] + e[4] * e[4] + e[5] * e[5];
      double ca = 0;
      double cb = 0;
      double cc = 0;
      exp_coefficients(t, ca, cb, cc);
      Eigen::Matrix3d re;
      so3_into(e[3], e[4], e[5], t, ca, cb, re);
      const Eigen::Vector3d delta(e[0], e[1], e[2]);
      if (rec) {
        rec->re[k] = re;
        rec->cp[k] = g.point + delta;
        rec->et[k] = g.rotary ? Eigen::Vector3d(g.point + delta - re * g.point) : Eigen::Vector3d(delta - re * lt + lt);
      }
      Eigen::Vector3d cp;
      if (g.rotary) {
        cp = g.point + delta;
        const Eigen::Matrix3d m = lr;
        lr.noalias() = re * m;
        lt = cp;
        lt.noalias() -= lr * g.point;
      } else {
        cp = lt + delta;
        lr = re;
        turns = true;
        lt = cp;
      }
      if constexpr (Twist) {
        if (inside) {
          Eigen::Matrix3d jl;
          so3_into(e[3], e[4], e[5], t, cb, cc, jl);
          const Eigen::Vector3d we = jl * Eigen::Vector3d(sl[3], sl[4], sl[5]);
          if (g.rotary) {
            lw = we + re * lw;
          } else {
            lw = we;
          }
          lv = Eigen::Vector3d(sl[0], sl[1], sl[2]) - lw.cross(cp);
        } else {
          if (g.rotary) lw = re * Eigen::Vector3d(lw);
          lv = -lw.cross(cp);
        }
        if (!g.rotary) lv += g.dir * g.gain;
      }
    }
    if (rec) {
      rec->lr[k] = turns ? lr : Eigen::Matrix3d::Identity();
      rec->lt[k] = lt;
    }
    if (identity[sd]) {
      if constexpr (Twist) {
        out.w[k] = lw;
        out.v[k] = lv + a.t.cross(lw);
      }
      a.t += lt;
      if (turns) {
        a.r = lr;
        identity[sd] = false;
      }
    } else {
      if constexpr (Twist) {
        out.w[k].noalias() = a.r * lw;
        out.v[k].noalias() = a.r * lv;
        out.v[k] += a.t.cross(out.w[k]);
      }
      a.t.noalias() += a.r * lt;
      if (turns) {
        const Eigen::Matrix3d m = a.r;
        a.r.noalias() = m * lr;
      }
    }
  }
}

template void SerialModel::Impl::chain<true>(const JointVector&, const Trig&, Chain&, int*, Record*) const;
template void SerialModel::Impl::chain<false>(const JointVector&, const Trig&, Chain&, int*, Record*) const;

void SerialModel::Impl::evaluate(const JointVector& q, Pose& out, Jacobian* jac, Rigid* workpiece) const {
  Trig t;
  trig(q, t);
  Chain ch;
  if (jac) {
    chain<true>(q, t, ch);
  } else {
    chain<false>(q, t, ch);
  }
  const Rigid& tw = ch.side[0];
  const Rigid& ts = ch.side[1];
  Eigen::Matrix3d tool_r;  // tool frame → machine frame
  tool_r.noalias() = ts.r * tool0.r;
  Eigen::Vector3d tip = ts.t;
  tip.noalias() += ts.r * tool0.t;
  // Pose in the workpiece frame: tw⁻¹ · tool.
  out.r.noalias() = tw.r.transpose() * tool_r;
  out.p.noalias() = tw.r.transpose() * (tip - tw.t);
  if (workpiece) *workpiece = tw;
  if (!jac) return;
  const int n = static_cast<int>(axes.size());
  jac->resize(6, n);
  for (int j = 0; j < n; ++j) {
    const auto k = static_cast<std::size_t>(j);
    // Tool-side joints move the tip point (fixed in the machine frame at this instant) directly;
    // workpiece-side ones move the workpiece frame, so the tip moves the opposite way in it.
    const double sign = j < workpiece_count ? -1.0 : 1.0;
    jac->block<3, 1>(0, j).noalias() = sign * (tw.r.transpose() * (ch.w[k].cross(tip) + ch.v[k]));
    jac->block<3, 1>(3, j).noalias() = sign * (tw.r.transpose() * ch.w[k]);
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

Eigen::Matrix<double, 6, Eigen::Dynamic> SerialModel::identification_jacobian(const JointVector& q) const {
  Pose unused;
  return identification_jacobian(q, unused);
}

Eigen::Matrix<double, 6, Eigen::Dynamic> SerialModel::identification_jacobian(const JointVector& q, Pose& pose) const {
  const Impl& m = *impl_;
  Impl::Trig t;
  m.trig(q, t);
  Impl::Chain ch;
  Impl::Record rec;
  m.chain<false>(q, t, ch, nullptr, &rec);
  const Rigid& tw = ch.side[0];
  const Rigid& ts = ch.side[1];
  Eigen::Vector3d tip = ts.t;
  tip.noalias() += ts.r * m.tool0.t;
  {  // as Impl::evaluate: the pose in the workpiece frame, tw⁻¹ · tool
    Eigen::Matrix3d tool_r;
    tool_r.noalias() = ts.r * m.tool0.r;
    pose.r.noalias() = tw.r.transpose() * tool_r;
    pose.p.noalias() = tw.r.transpose() * (tip - tw.t);
  }
  const Eigen::Matrix3d back = tw.r.transpose();  // machine frame → workpiece frame
  Eigen::Matrix<double, 6, Eigen::Dynamic> out = Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, static_cast<Eigen::Index>(params_.size()));
  // Ad_T(w, v) = (R·w, R·v + t × R·w).
  const auto ad = [](const Eigen::Matrix3d& r, const Eigen::Vector3d& tr, const Eigen::Vector3d& w, const Eigen::Vector3d& v,
                     Eigen::Vector3d& w_out, Eigen::Vector3d& v_out) {
    w_out = r * w;
    v_out = r * v + tr.cross(w_out);
  };
  for (std::size_t p = 0; p < params_.size(); ++p) {
    const Impl::ParamRole& role = m.roles[p];
    if (role.role == Impl::Role::tool_length) {
      out.block<3, 1>(0, static_cast<Eigen::Index>(p)) = back * (-(ts.r * m.tool_axis));
      continue;
    }
    const auto k = static_cast<std::size_t>(role.joint);
    const Impl::Axis& g = m.axes[k];
    // The parameter's twist in the joint's parent (local) frame.
    Eigen::Vector3d wl = Eigen::Vector3d::Zero(), vl = Eigen::Vector3d::Zero();
    // A small rotation vector e at tilt t: exp([t + εe]×) = exp([ε·J(t)e]×)·exp([t]×), J ≈ I + ½[t]×.
    const Eigen::Vector3d e = role.e + 0.5 * m.tilt[k].cross(role.e);
    switch (role.role) {
      case Impl::Role::linear_offset: vl = g.dir; break;
      case Impl::Role::linear_scale: vl = g.dir * q[static_cast<Eigen::Index>(k)]; break;
      case Impl::Role::squareness: vl = e.cross(g.dir) * (q[static_cast<Eigen::Index>(k)] * g.gain + g.offset); break;
      case Impl::Role::rotary_offset:
        wl = rec.re[k] * g.dir;
        vl = -wl.cross(rec.cp[k]);
        break;
      case Impl::Role::rotary_location:
        // T(εe)·L·T(−εe): (0, e) − Ad_L(0, e).
        vl = role.e - rec.lr[k] * role.e;
        break;
      case Impl::Role::rotary_tilt: {
        // E·C·M·C⁻¹ with C the turn about e through the axis point: Ad_E(ζ) − Ad_L(ζ).
        const Eigen::Vector3d zw = e, zv = -e.cross(g.point);
        Eigen::Vector3d w1, v1, w2, v2;
        ad(rec.re[k], rec.et[k], zw, zv, w1, v1);
        ad(rec.lr[k], rec.lt[k], zw, zv, w2, v2);
        wl = w1 - w2;
        vl = v1 - v2;
        break;
      }
      case Impl::Role::tool_length: break;
    }
    // To the machine frame through the side's transform before the joint, then to the tool.
    Eigen::Vector3d w, v;
    ad(rec.before[k].r, rec.before[k].t, wl, vl, w, v);
    const double sign = role.joint < m.workpiece_count ? -1.0 : 1.0;
    out.block<3, 1>(0, static_cast<Eigen::Index>(p)) = sign * (back * (w.cross(tip) + v));
    out.block<3, 1>(3, static_cast<Eigen::Index>(p)) = sign * (back * w);
  }
  return out;
}

Eigen::Matrix3d SerialModel::machine_to_workpiece(const JointVector& q) const {
  Impl::Trig t;
  impl_->trig(q, t);
  Impl::Chain ch;
  impl_->chain<false>(q, t, ch);
  return ch.side[0].r.transpose();
}

}  // namespace postproc::kin
