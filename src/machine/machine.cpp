// Machine files: the [machine], [tool], [work_offsets], [axes.*], [errors] and [volumetric_map]
// tables; the model sections ([serial], [prs_hybrid], [hexapod]) are read in machine_models.cpp.
#include "postproc/machine/machine.hpp"


#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>
#include <openssl/evp.h>

#include "postproc/error.hpp"
#include "postproc/kinematics/serial.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/kinematics/volumetric_map.hpp"
#include "src/machine/machine_models.hpp"
#include "src/machine/toml_fields.hpp"

namespace postproc::machine {

std::string_view to_string(IkBranch b) {
  switch (b) {
    case IkBranch::nearest: return "nearest";
    case IkBranch::tilt_positive: return "tilt-positive";
    case IkBranch::tilt_negative: return "tilt-negative";
    case IkBranch::nearest_in_travel: return "nearest-in-travel";
  }
  return "?";
}
namespace {

constexpr std::string_view kDialects[] = {"fanuc", "siemens", "linuxcnc", "heidenhain-iso", "heidenhain"};
constexpr std::string_view kModels[] = {"serial", "prs-hybrid", "hexapod"};
constexpr std::string_view kCoordinates[] = {"axes", "tool-tip"};
constexpr std::string_view kOrientations[] = {"rotary-axes", "vector", "virtual-ab"};
constexpr std::string_view kFeeds[] = {"combined-axes", "tool-tip"};
constexpr std::string_view kGSystems[] = {"A", "B", "auto"};

void read_axis(Fields& f, AxisSettings& a, bool rotary) {
  using R = Fields::Range;
  if (auto d = f.integer("decimals", false, 0, 9)) a.decimals = static_cast<int>(*d);
  a.kv = f.quantity("kv", Dim::inverse_time, "1/s", false, R{0, 1e4, true});
  if (auto v = f.quantity("feed_forward", Dim::ratio, "1", false, R{0, 1})) a.feed_forward = *v;
  if (auto v = f.quantity("acceleration_feed_forward", Dim::ratio, "1", false, R{0, 1})) a.acceleration_feed_forward = *v;
  a.velocity_loop_time = f.quantity("velocity_loop_time", Dim::time, "s", false, R{0, 1, false});
  // Rotary axes: deg/min, deg/s², deg/s³ (numbers default to those).
  a.max_velocity = f.quantity("max_velocity", Dim::velocity, rotary ? "deg/min" : "mm/min", false, R{0, 1e7, true});
  a.max_acceleration =
      f.quantity("max_acceleration", Dim::acceleration, rotary ? "deg/s^2" : "mm/s^2", false, R{0, 1e7, true});
  a.max_jerk = f.quantity("max_jerk", Dim::jerk, rotary ? "deg/s^3" : "mm/s^3", false, R{0, 1e9, true});
  f.finish();
}

/// [interpolator]: corner = "time" | "tolerance", corner_time, corner_tolerance.
void read_interpolator(TomlDoc& doc, const toml::table& t, Machine& m) {
  Fields f(doc, t, "interpolator");
  static constexpr std::string_view kCorners[] = {"time", "tolerance"};
  InterpolatorSettings& s = m.interpolator;
  if (auto c = f.text("corner", false, kCorners)) s.corner = *c == "tolerance" ? CornerRule::tolerance : CornerRule::time;
  if (auto v = f.quantity("corner_time", Dim::time, "s", false, Fields::Range{0, 1, true})) s.corner_time = *v;
  if (auto v = f.quantity("corner_tolerance", Dim::length, "mm", false, Fields::Range{0, 10, true}))
    s.corner_tolerance = *v;
  f.finish();
}

/// [work_offsets] G54 = { X = …, Y = …, C = … }.
void read_work_offsets(TomlDoc& doc, const toml::table& t, Machine& m) {
  for (const auto& [k, v] : t) {
    const std::string name(k.str());
    const toml::table* axes = v.as_table();
    if (axes == nullptr) {
      doc.error(v.source(), codes::kType,
                fmt::format("[work_offsets] {} must be a table of axis values, e.g. {} = {{ X = -250, Y = -180, Z = -400 }}",
                            name, name));
      continue;
    }
    Fields f(doc, *axes, "work_offsets." + name);
    gcode::AxisVector off = gcode::AxisVector::Zero();
    for (int i = 0; i < gcode::kAxisCount; ++i) {
      const char letter[2] = {gcode::kAxisLetters[static_cast<std::size_t>(i)], 0};
      if (auto q = f.quantity(letter, gcode::is_rotary(i) ? Dim::angle : Dim::length, gcode::is_rotary(i) ? "deg" : "mm",
                              false))
        off[i] = gcode::is_rotary(i) ? *q / kin::kDeg : *q;
    }
    f.finish();
    m.work_offsets[name] = off;
  }
}

/// [tool.lengths] / [tool.radii]: N = "<value> mm" by H/D offset number (LinuxCNC: tool number).
void read_tool_numbers(TomlDoc& doc, Fields& f, const char* name, std::map<std::uint32_t, double>& out) {
  const toml::table* t = f.table(name, false);
  if (t == nullptr) return;
  const std::string section = fmt::format("tool.{}", name);
  Fields lf(doc, *t, section);
  for (const auto& [k, v] : *t) {
    const std::string key(k.str());
    if (key.empty() || key.size() > 5 || key.find_first_not_of("0123456789") != std::string::npos) {
      doc.error(k.source(), codes::kUnknownKey,
                fmt::format("[{}] key '{}' is not a tool offset number; write e.g. 3 = \"12.5 mm\" for number 3",
                            section, key));
      lf.known(key);
      continue;
    }
    const auto n = static_cast<std::uint32_t>(std::stoul(key));
    if (auto l = lf.quantity(key, Dim::length, "mm", true, {0, 2000})) out[n] = *l;
  }
  lf.finish();
}

void read_tool(TomlDoc& doc, Fields& f, Machine& m) {
  if (auto l = f.quantity("length", Dim::length, "mm", true, {0, 2000})) m.tool_length = *l;
  read_tool_numbers(doc, f, "lengths", m.tool_lengths);
  read_tool_numbers(doc, f, "radii", m.tool_radii);
  f.finish();
}

/// [uncertainty] parameters = [names], covariance = [[…]] (mm, rad), [uncertainty.region]
/// JOINT = [min, max] (mm / deg). The covariance must be square, symmetric and positive
/// semi-definite (a file edited by hand is checked, not trusted).
void read_uncertainty(TomlDoc& doc, const toml::table& t, const kin::Model& model, Machine& m) {
  Fields f(doc, t, "uncertainty");
  Uncertainty u;
  bool ok = true;
  if (const toml::array* names = f.array("parameters", true)) {
    for (const toml::node& n : *names) {
      const auto* s = n.as_string();
      const int k = s != nullptr ? model.parameter_index(s->get()) : -1;
      if (k < 0) {
        doc.error(n.source(), codes::kUnknownKey,
                  "[uncertainty] parameters must name parameters of this machine (as [errors] does); this one is not");
        ok = false;
        continue;
      }
      u.parameters.push_back(k);
    }
  }
  const auto p = static_cast<Eigen::Index>(u.parameters.size());
  u.covariance = Eigen::MatrixXd::Zero(p, p);
  if (const toml::array* rows = f.array("covariance", true)) {
    if (static_cast<Eigen::Index>(rows->size()) != p) {
      f.error_at("covariance", codes::kInconsistent,
                 fmt::format("[uncertainty] covariance has {} rows for {} parameters; it must be {}×{}", rows->size(), p, p, p));
      ok = false;
    } else {
      for (Eigen::Index i = 0; i < p && ok; ++i) {
        const toml::array* row = (*rows)[static_cast<std::size_t>(i)].as_array();
        if (row == nullptr || static_cast<Eigen::Index>(row->size()) != p) {
          f.error_at("covariance", codes::kInconsistent,
                     fmt::format("[uncertainty] covariance row {} must be an array of {} numbers", i + 1, p));
          ok = false;
          break;
        }
        for (Eigen::Index j = 0; j < p; ++j) {
          const auto v = (*row)[static_cast<std::size_t>(j)].value<double>();
          if (!v || !std::isfinite(*v)) {
            f.error_at("covariance", codes::kRange,
                       fmt::format("[uncertainty] covariance[{}][{}] is not a finite number", i + 1, j + 1));
            ok = false;
            break;
          }
          u.covariance(i, j) = *v;
        }
      }
      if (ok && p > 0) {
        const double scale = std::max(u.covariance.cwiseAbs().maxCoeff(), 1e-300);
        const bool symmetric = (u.covariance - u.covariance.transpose()).cwiseAbs().maxCoeff() <= 1e-9 * scale;
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(u.covariance);
        if (!symmetric || eig.eigenvalues().minCoeff() < -1e-9 * scale) {
          f.error_at("covariance", codes::kInconsistent,
                     "[uncertainty] covariance is not a covariance (symmetric, positive semi-definite); write it again "
                     "with postproc calibrate");
          ok = false;
        }
      }
    }
  }
  if (const toml::table* region = f.table("region", false)) {
    Fields rf(doc, *region, "uncertainty.region");
    u.region_min.assign(static_cast<std::size_t>(model.joint_count()), -std::numeric_limits<double>::infinity());
    u.region_max.assign(static_cast<std::size_t>(model.joint_count()), std::numeric_limits<double>::infinity());
    for (int j = 0; j < model.joint_count(); ++j) {
      const kin::Joint& joint = model.joints()[static_cast<std::size_t>(j)];
      const bool rotary = joint.type == kin::JointType::rotary;
      if (auto r = rf.quantities(joint.name, rotary ? Dim::angle : Dim::length, rotary ? "deg" : "mm", false)) {
        if (r->size() != 2 || !((*r)[0] <= (*r)[1])) {
          rf.error_at(joint.name, codes::kInconsistent,
                      fmt::format("[uncertainty.region] {} must be [min, max] with min ≤ max", joint.name));
          ok = false;
          continue;
        }
        const double to = rotary ? 180.0 / kin::kPi : 1.0;  // degrees in the model's joint units
        u.region_min[static_cast<std::size_t>(j)] = (*r)[0] * to;
        u.region_max[static_cast<std::size_t>(j)] = (*r)[1] * to;
      }
    }
    rf.finish();
  }
  f.finish();
  if (ok) m.uncertainty = std::move(u);
}

/// [errors] NAME = quantity, one per error parameter of the model.
kin::ModelPtr apply_errors(TomlDoc& doc, const toml::table& t, const kin::ModelPtr& model) {
  std::vector<double> values = model->values();
  Fields f(doc, t, "errors");
  for (const auto& [k, v] : t) {
    const std::string name(k.str());
    const int idx = model->parameter_index(name);
    f.known(name);
    if (idx < 0) {
      std::string names;
      for (const auto& p : model->parameters())
        if (p.error) names += (names.empty() ? "" : " ") + p.name;
      doc.error(k.source(), codes::kUnknownKey,
                fmt::format("[errors] '{}' is not an error parameter of this {} machine; its parameters are: {}", name,
                            model->kind(), names));
      continue;
    }
    const kin::Parameter& p = model->parameters()[static_cast<std::size_t>(idx)];
    const bool angle = p.unit == "rad";
    const bool ratio = p.unit == "ratio";
    if (auto q = f.quantity_node(v, fmt::format("[errors] {}", name),
                                 angle ? Dim::angle : ratio ? Dim::ratio : Dim::length, angle ? "rad" : ratio ? "1" : "mm")) {
      if ((angle && std::abs(*q) > 0.1) || (ratio && std::abs(*q) > 0.01) || (!angle && !ratio && p.error && std::abs(*q) > 50.0)) {
        doc.error(v.source(), codes::kRange,
                  fmt::format("[errors] {} = {} {} is not a small error (|value| ≤ {}); check the unit (e.g. \"12 um\", "
                              "\"15 arcsec\", \"20 um/m\")",
                              name, *q, p.unit, angle ? "0.1 rad" : ratio ? "0.01 (1 %)" : "50 mm"));
        continue;
      }
      values[static_cast<std::size_t>(idx)] = p.error ? p.nominal + *q : *q;
    }
  }
  return model->with_values(std::move(values));
}

kin::ModelPtr apply_map(TomlDoc& doc, Fields& f, kin::ModelPtr base) {
  using kin::VolumetricMap;
  auto origin = f.vector3("origin", Dim::length, "mm", true);
  auto spacing = f.vector3("spacing", Dim::length, "mm", true);
  std::array<int, 3> counts{};
  bool ok = true;
  if (const toml::array* c = f.array("counts", true)) {
    if (c->size() != 3) ok = false;
    for (std::size_t i = 0; i < 3 && i < c->size(); ++i) {
      auto n = c->get(i)->value_exact<std::int64_t>();
      if (!n || *n < 2 || *n > 1000) ok = false;
      else counts[i] = static_cast<int>(*n);
    }
    if (!ok) f.error_at("counts", codes::kRange, "[volumetric_map] counts must be three integers 2…1000: [nx, ny, nz]");
  } else {
    ok = false;
  }
  const auto unit = f.text("unit", false).value_or("um");
  const auto factor = convert_unit(1.0, unit, Dim::length);
  if (!factor) {
    f.error_at("unit", codes::kUnit, fmt::format("[volumetric_map] unit \"{}\" is not a length unit (um, mm, …)", unit));
    ok = false;
  }
  static constexpr std::string_view kInterp[] = {"trilinear", "smooth"};
  static constexpr std::string_view kOutside[] = {"refuse", "clamp", "zero"};
  const auto interp = f.text("interpolation", false, kInterp).value_or("trilinear");
  const auto outside = f.text("outside", false, kOutside).value_or("refuse");
  std::vector<Eigen::Vector3d> data;
  if (const toml::array* e = f.array("errors", true)) {
    for (std::size_t i = 0; i < e->size(); ++i) {
      const toml::array* row = e->get(i)->as_array();
      std::optional<double> x, y, z;
      if (row != nullptr && row->size() == 3) {
        x = row->get(0)->value<double>();
        y = row->get(1)->value<double>();
        z = row->get(2)->value<double>();
      }
      if (!x || !y || !z) {
        doc.error(e->get(i)->source(), codes::kType,
                  fmt::format("[volumetric_map] errors[{}] must be [ex, ey, ez] numbers in {}", i, unit));
        ok = false;
        break;
      }
      const Eigen::Vector3d err(*x * factor.value_or(1), *y * factor.value_or(1), *z * factor.value_or(1));
      if (!err.allFinite() || err.cwiseAbs().maxCoeff() > 1e6) {
        doc.error(e->get(i)->source(), codes::kRange,
                  fmt::format("[volumetric_map] errors[{}] is not finite or beyond 1e6 mm; check the value and the unit "
                              "(\"{}\")",
                              i, unit));
        ok = false;
        break;
      }
      data.push_back(err);
    }
  } else {
    ok = false;
  }
  f.finish();
  if (!ok || !origin || !spacing) return base;
  const std::size_t expected = static_cast<std::size_t>(counts[0]) * static_cast<std::size_t>(counts[1]) *
                               static_cast<std::size_t>(counts[2]);
  if (data.size() != expected) {
    f.error_at("errors", codes::kInconsistent,
               fmt::format("[volumetric_map] has {} error vectors; counts {}×{}×{} need {} (x fastest, then y, then z)",
                           data.size(), counts[0], counts[1], counts[2], expected));
    return base;
  }
  try {
    auto map = std::make_shared<const VolumetricMap>(
        *origin, *spacing, Eigen::Vector3i(counts[0], counts[1], counts[2]), std::move(data),
        interp == "smooth" ? VolumetricMap::Interpolation::smooth : VolumetricMap::Interpolation::trilinear,
        outside == "clamp" ? VolumetricMap::Outside::clamp
                           : (outside == "zero" ? VolumetricMap::Outside::zero : VolumetricMap::Outside::refuse));
    return std::make_shared<const kin::VolumetricModel>(std::move(base), std::move(map));
  } catch (const Error& e) {
    f.error_at("errors", codes::kInconsistent, fmt::format("[volumetric_map] {}", e.what()));
    return base;
  }
}

}  // namespace

std::optional<double> tool_length_of(const Machine& m, const gcode::Motion& mo) {
  if (!mo.tool_length_active) return m.tool_length;
  if (mo.tool_length_known && mo.tool_length != 0) return mo.tool_length;
  if (mo.tool_length_h == 0) return m.tool_length;
  if (mo.tool_length_rewritten) return std::nullopt;  // G10 rewrote it: the file's value is stale
  const auto it = m.tool_lengths.find(mo.tool_length_h);
  if (it == m.tool_lengths.end()) return std::nullopt;
  return it->second;
}

std::string rewritten_length_refusal(const gcode::Motion& mo) {
  return fmt::format("the program rewrote the length of tool H{} (G10 L1/L10/L11) to a value that is not known here "
                     "(set from the machine position, or an unresolved expression), so the machine file's length for "
                     "it is not the controller's; write the length with G10 L1 P{} Z… as a number, or give the "
                     "program without the G10",
                     mo.tool_length_h, mo.tool_length_h);
}

std::string work_offset_name(const gcode::WorkOffset& w) {
  if (w.code10 == 541) return fmt::format("G54.1P{}", w.p);
  if (w.code10 == 2470) return fmt::format("PRESET{}", w.p);  // Heidenhain cycle 247 Q339=p
  if (w.code10 % 10 == 0) return fmt::format("G{}", w.code10 / 10);
  return fmt::format("G{}.{}", w.code10 / 10, w.code10 % 10);
}

namespace {
// Whether turning joint j keeps the tool tip's Z and its distance from the workpiece Z axis (the
// nominal machine, at a pose with the tip off that axis): j spins the part about that line.
bool turns_about_workpiece_z(const kin::Model& nominal, int j) {
  kin::JointVector q = kin::JointVector::Zero(nominal.joint_count());
  for (int k = 0; k < nominal.joint_count(); ++k)
    if (nominal.joints()[static_cast<std::size_t>(k)].type == kin::JointType::linear) q[k] = 37.0 + 11.0 * k;
  kin::Pose p0, p1;
  if (!nominal.forward(q, p0).ok()) return false;
  q[j] += 90;
  if (!nominal.forward(q, p1).ok()) return false;
  const double r0 = std::hypot(p0.p.x(), p0.p.y());
  return r0 > 1e-3 && std::abs(std::hypot(p1.p.x(), p1.p.y()) - r0) < 1e-6 && std::abs(p1.p.z() - p0.p.z()) < 1e-6;
}
}  // namespace

std::optional<Machine> parse_machine(std::string file, std::string text, gcode::DiagnosticSink& sink) {
  const std::size_t errors_before = sink.count(gcode::Severity::error);
  Machine m;
  char turning_spindle = 0;  // [machine] turning_spindle, checked against the chain below
  m.file = file;
  m.sha256 = sha256_hex(text);
  m.joint_of_axis.fill(-1);
  TomlDoc doc(std::move(file), std::move(text), sink);
  if (!doc.ok()) return std::nullopt;
  Fields top(doc, doc.root(), "");

  // [machine]
  if (const toml::table* mt = top.table("machine", true)) {
    Fields f(doc, *mt, "machine");
    m.name = f.text("name", false).value_or("");
    f.known("schema");
    if (auto v = f.integer("schema", false, 1, 1)) (void)v;
    m.dialect_name = f.text("dialect", true, kDialects).value_or("fanuc");
    m.dialect_options.lathe = f.boolean("lathe", false).value_or(false);
    const std::string gsys = std::string(f.text("gcode_system", false, kGSystems).value_or("auto"));
    m.dialect_options.gcode_system = gsys == "auto" ? '?' : gsys[0];
    static constexpr std::string_view kIntegerInput[] = {"increment", "calculator"};
    if (auto ii = f.text("integer_input", false, kIntegerInput))
      m.dialect_options.integer_input =
          *ii == "increment" ? gcode::Dialect::IntegerInput::increment : gcode::Dialect::IntegerInput::calculator;
    // Fanuc parameter 3402#0 (G01): the motion mode at power-on / reset, G0 unless the machine says G1.
    static constexpr std::string_view kPowerOn[] = {"G0", "G1"};
    if (auto pm = f.text("power_on_motion", false, kPowerOn)) m.dialect_options.power_on_motion = *pm == "G1" ? 1 : 0;
    // Fanuc parameter 3403#5 (CIR): a G02/G03 without I J K or R moves straight (0) or alarms (1).
    static constexpr std::string_view kNoCentre[] = {"linear", "alarm"};
    if (auto nc = f.text("arc_without_centre", false, kNoCentre)) m.dialect_options.arc_without_centre_alarm = *nc == "alarm";
    // Sinumerik MD20150[0] (reset value of G group 1) and MD10240 (basic system metric / inch).
    if (auto rm = f.text("reset_motion", false, kPowerOn)) m.dialect_options.reset_motion = *rm == "G0" ? '0' : '1';
    static constexpr std::string_view kBasic[] = {"metric", "inch"};
    if (auto bs = f.text("basic_system", false, kBasic)) m.dialect_options.basic_inch = *bs == "inch";
    m.model_kind = f.text("model", true, kModels).value_or("serial");
    const auto coords = f.text("program", false, kCoordinates).value_or(m.model_kind == "serial" ? "axes" : "tool-tip");
    m.coordinates = coords == "axes" ? ProgramCoordinates::axes : ProgramCoordinates::tool_tip;
    const auto orient = f.text("orientation", false, kOrientations).value_or("rotary-axes");
    m.orientation = orient == "vector" ? Orientation::vector
                                       : (orient == "virtual-ab" ? Orientation::virtual_ab : Orientation::rotary_axes);
    const auto feed = f.text("feed", false, kFeeds).value_or(m.coordinates == ProgramCoordinates::axes ? "combined-axes" : "tool-tip");
    m.feed = feed == "tool-tip" ? FeedReference::tool_tip : FeedReference::combined_axes;
    if (auto p = f.quantity("interpolation_period", Dim::time, "s", false, {1e-6, 0.1})) m.interpolation_period = *p;
    if (auto c = f.quantity("max_rotary_correction", Dim::angle, "deg", false, {1e-7, 0.5}))
      m.max_rotary_correction_rad = *c;
    static constexpr std::string_view kBranches[] = {"nearest", "tilt-positive", "tilt-negative",
                                                     "nearest-in-travel"};
    if (auto br = f.text("ik_branch", false, kBranches)) {
      m.ik_branch = *br == "tilt-positive"       ? IkBranch::tilt_positive
                    : *br == "tilt-negative"     ? IkBranch::tilt_negative
                    : *br == "nearest-in-travel" ? IkBranch::nearest_in_travel
                                                 : IkBranch::nearest;
      if (m.model_kind != "serial" && m.ik_branch != IkBranch::nearest)
        f.error_at("ik_branch", codes::kInconsistent,
                   fmt::format("[machine] ik_branch = \"{}\" chooses between the two solutions of a serial machine "
                               "with two rotary axes; a {} machine has no such choice — remove the key",
                               *br, m.model_kind));
    }
    static constexpr std::string_view kSpindleAxes[] = {"A", "B", "C"};
    if (auto ts = f.text("turning_spindle", false, kSpindleAxes)) turning_spindle = (*ts)[0];
    if (m.model_kind != "serial" && m.coordinates == ProgramCoordinates::axes)
      f.error_at("program", codes::kInconsistent,
                 fmt::format("a {} machine is programmed in tool-tip coordinates; write program = \"tool-tip\"",
                             m.model_kind));
    if (m.model_kind != "serial" && m.orientation == Orientation::rotary_axes)
      f.error_at("orientation", codes::kInconsistent,
                 fmt::format("a {} machine has no rotary axes; write orientation = \"vector\" or \"virtual-ab\"",
                             m.model_kind));
    f.finish();
  }
  if (const toml::table* t = top.table("interpolator", false)) read_interpolator(doc, *t, m);
  if (const toml::table* t = top.table("tool", true)) {
    Fields f(doc, *t, "tool");
    read_tool(doc, f, m);
  }
  // The interpreter resolves the offsets the program selects from the same table.
  m.dialect_options.tool_lengths = m.tool_lengths;
  m.dialect_options.tool_radii = m.tool_radii;
  if (const toml::table* t = top.table("work_offsets", false)) read_work_offsets(doc, *t, m);

  // The model section named by [machine] model.
  kin::ModelPtr model;
  const std::string section = m.model_kind == "prs-hybrid" ? "prs_hybrid" : m.model_kind;
  for (std::string_view s : {"serial", "prs_hybrid", "hexapod"})
    if (s != section && top.has(s)) {
      top.error_at(s, codes::kInconsistent,
                   fmt::format("[{}] does not belong to a '{}' machine; remove it or change [machine] model", s,
                               m.model_kind));
      top.known(s);
    }
  if (const toml::table* t = top.table(section, true)) {
    Fields f(doc, *t, section);
    const toml::table* motions = top.table("error_motions", false);
    if (section == "serial") model = read_serial(doc, f, motions, m);
    else if (section == "prs_hybrid") model = read_prs_hybrid(doc, f, m);
    else model = read_hexapod(doc, f, m);
  }
  if (model) {
    // read_* build models with every parameter nominal; a serial chain's error-motion tables
    // are configuration data, so the controller's model is the chain without them.
    m.nominal = model;
    if (const auto* serial = dynamic_cast<const kin::SerialModel*>(model.get())) m.nominal = serial->without_tables();
    if (const toml::table* t = top.table("errors", false)) model = apply_errors(doc, *t, model);
    if (const toml::table* t = top.table("volumetric_map", false)) {
      Fields f(doc, *t, "volumetric_map");
      model = apply_map(doc, f, model);
    }
    m.actual = model;
    if (const toml::table* t = top.table("uncertainty", false)) read_uncertainty(doc, *t, *model, m);
  } else {
    top.known("errors");
    top.known("volumetric_map");
    top.known("uncertainty");
  }

  // [axes.X] …
  if (const toml::table* t = top.table("axes", true)) {
    for (const auto& [k, v] : *t) {
      const std::string key(k.str());
      const int ax = key.size() == 1 ? gcode::axis_index(key[0]) : -1;
      const toml::table* at = v.as_table();
      if (ax < 0 || at == nullptr) {
        doc.error(k.source(), codes::kUnknownKey,
                  fmt::format("[axes.{}] is not a program axis table; use [axes.X] … [axes.C] (X Y Z A B C U V W)", key));
        continue;
      }
      Fields f(doc, *at, "axes." + key);
      AxisSettings s;
      if (gcode::is_rotary(ax)) {
        // Roll-over positioning of absolute words (docs/machine-file.md "Controller conventions").
        static constexpr std::string_view kRollover[] = {"off", "shortest", "signed", "modulo"};
        if (auto r = f.text("rollover", false, kRollover))
          m.dialect_options.rollover[static_cast<std::size_t>(ax)] = *gcode::rollover_from_name(*r);
      }
      read_axis(f, s, gcode::is_rotary(ax));
      m.axes[static_cast<std::size_t>(ax)] = s;
    }
  }
  // [drives.q1] … servo data of joints that are not program axes (parallel machines).
  if (const toml::table* t = top.table("drives", false)) {
    for (const auto& [k, v] : *t) {
      const std::string key(k.str());
      const toml::table* dt = v.as_table();
      bool joint = false;
      bool rotary = false;
      if (m.actual)
        for (const kin::Joint& jt : m.actual->joints())
          if (jt.name == key) {
            joint = true;
            rotary = jt.type == kin::JointType::rotary;
          }
      if (!joint || dt == nullptr) {
        std::string names;
        if (m.actual)
          for (const kin::Joint& jt : m.actual->joints()) names += (names.empty() ? "" : ", ") + jt.name;
        doc.error(k.source(), codes::kUnknownKey,
                  fmt::format("[drives.{}] does not name a joint of this machine; its joints are {}", key, names));
        continue;
      }
      Fields f(doc, *dt, "drives." + key);
      AxisSettings s;
      read_axis(f, s, rotary);
      m.drives[key] = s;
    }
  }
  if (m.actual && m.model_kind == "serial") {
    for (int j = 0; j < m.actual->joint_count(); ++j) {
      const std::string& n = m.actual->joints()[static_cast<std::size_t>(j)].name;
      const int ax = n.size() == 1 ? gcode::axis_index(n[0]) : -1;
      if (ax >= 0) {
        m.joint_of_axis[static_cast<std::size_t>(ax)] = j;
        if (!m.axes[static_cast<std::size_t>(ax)])
          top.error_at("axes", codes::kMissing,
                       fmt::format("the serial chain has axis {} but there is no [axes.{}] table; add one with its "
                                   "decimals and servo data",
                                   n, n));
      }
    }
  }
  if (turning_spindle != 0) {
    const int ax = gcode::axis_index(turning_spindle);
    const int j = m.model_kind == "serial" ? m.joint_of_axis[static_cast<std::size_t>(ax)] : -1;
    if (j < 0 || !m.actual || m.actual->joints()[static_cast<std::size_t>(j)].type != kin::JointType::rotary)
      top.error_at("machine", codes::kInconsistent,
                   fmt::format("[machine] turning_spindle = \"{}\" names no rotary axis of this serial machine; name "
                               "the workpiece spindle's rotary axis or remove the key",
                               turning_spindle));
    else if (!turns_about_workpiece_z(*m.nominal, j))
      top.error_at("machine", codes::kInconsistent,
                   fmt::format("[machine] turning_spindle = \"{}\": that axis does not turn the workpiece about the "
                               "workpiece Z axis through its origin; a turning move's radius and Z are measured about "
                               "that line — put the workpiece frame on the spindle axis",
                               turning_spindle));
    else
      m.turning_spindle_axis = ax;
  }
  top.finish();
  if (sink.count(gcode::Severity::error) > errors_before) return std::nullopt;
  return m;
}

std::optional<Machine> load_machine(const std::string& path, gcode::DiagnosticSink& sink) {
  return parse_machine(path, io::read_file(path, "machine file"), sink);
}

std::string sha256_hex(std::string_view bytes) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), md, &len, EVP_sha256(), nullptr) != 1)
    throw Error(ExitCode::internal, "SHA-256 failed (OpenSSL EVP_Digest)");
  std::string hex;
  hex.reserve(2 * len);
  for (unsigned int i = 0; i < len; ++i) hex += fmt::format("{:02x}", md[i]);
  return hex;
}

}  // namespace postproc::machine
