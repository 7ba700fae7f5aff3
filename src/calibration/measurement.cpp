// Calibration measurement files (see measurement.hpp and docs/measurements.md).
#include "postproc/calibration/measurement.hpp"

#include <array>
#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "postproc/error.hpp"

namespace postproc::cal {
namespace {

using Vec3 = Eigen::Vector3d;

constexpr std::array<std::string_view, 5> kKinds = {"poses", "positions", "directions", "attitudes", "struts"};

/// Reads three plain-number columns as a unit vector; PP-C005 for a vector far from unit length.
std::optional<Vec3> unit_vector(CsvTable& t, std::size_t row, const std::array<int, 3>& cols, std::string_view what) {
  Vec3 v;
  for (int k = 0; k < 3; ++k) {
    const auto x = t.number(row, cols[static_cast<std::size_t>(k)]);
    if (!x) return std::nullopt;
    v[k] = *x;
  }
  const double n = v.norm();
  if (!(n > 0.9 && n < 1.1)) {
    t.error(row, cols[0], codes::kCsvRange,
            fmt::format("the {} ({:g}, {:g}, {:g}) has length {:g}; give a unit vector (direction cosines)", what, v.x(),
                        v.y(), v.z(), n));
    return std::nullopt;
  }
  return v / n;
}

/// The tool frame with axis o (unit): x = `hint` made orthogonal to o (a fixed seed when the
/// rotation about o is not measured), y = o × x.
Eigen::Matrix3d frame_with_axis(const Vec3& o, const std::optional<Vec3>& hint = std::nullopt) {
  const Vec3 seed = hint ? *hint : (std::abs(o.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY());
  Eigen::Matrix3d r;
  r.col(0) = (seed - seed.dot(o) * o).normalized();
  r.col(1) = o.cross(r.col(0));
  r.col(2) = o;
  return r;
}

bool ratio_columns(CsvTable& t, std::array<std::string_view, 3> names, bool required, std::array<int, 3>& cols) {
  bool all = true, any = false;
  for (std::size_t k = 0; k < 3; ++k) {
    double s = 1;
    cols[k] = t.find(names[k]) >= 0 || required ? t.quantity_column(names[k], Quantity::ratio, true, s) : -1;
    all = all && cols[k] >= 0;
    any = any || t.find(names[k]) >= 0;
  }
  if (!required && any && !all) {
    for (std::size_t k = 0; k < 3; ++k) {
      double s = 1;
      if (cols[k] < 0) (void)t.quantity_column(names[k], Quantity::ratio, true, s);
    }
    return false;
  }
  return all || (!required && !any);
}

/// "1 um", "0.5um", "2 arcsec": a positive value with a unit of q; nullopt if not.
std::optional<double> quantity_text(std::string_view text, Quantity q) {
  while (!text.empty() && text.front() == ' ') text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t')) text.remove_suffix(1);
  double v = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || ptr == text.data()) return std::nullopt;
  std::string_view unit(ptr, static_cast<std::size_t>(text.data() + text.size() - ptr));
  while (!unit.empty() && unit.front() == ' ') unit.remove_prefix(1);
  const auto f = unit_factor(unit, q);
  if (!f || unit.empty() || !(v > 0) || !std::isfinite(v)) return std::nullopt;
  return v * *f;
}

constexpr std::array<std::string_view, 5> kSettings = {"kind", "frame", "registration", "sigma", "sigma_angle"};

}  // namespace

std::string_view registration_name(int k) {
  static constexpr std::array<std::string_view, 6> names = {"tx", "ty", "tz", "rx", "ry", "rz"};
  return k >= 0 && k < 6 ? names[static_cast<std::size_t>(k)] : "?";
}

std::optional<Source> measurement_source(CsvTable& t, std::string_view kind) {
  Source src;
  bool ok = true;
  const bool point = kind == "poses" || kind == "positions" || kind == "struts";
  if (const auto frame = t.meta("frame")) {
    std::string_view f = *frame;
    const auto space = f.find_first_of(" \t");
    const std::string_view word = f.substr(0, space);
    std::string_view name = space == std::string_view::npos ? std::string_view{} : f.substr(space + 1);
    while (!name.empty() && (name.front() == ' ' || name.front() == '\t')) name.remove_prefix(1);
    if (word == "workpiece" && name.empty()) {
      // the default
    } else if (word == "instrument") {
      if (kind == "struts") {
        t.meta_error("frame", codes::kCsvHeaderKey,
                     "strut readings are taken at a known tool pose in the workpiece frame; '# frame: instrument' "
                     "does not apply to them: remove it");
        ok = false;
      }
      src.frame = name.empty() ? t.file() : std::string(name);
      src.free = point ? static_cast<std::uint8_t>(kTranslation | kRotation) : kRotation;
    } else {
      t.meta_error("frame", codes::kCsvHeaderKey,
                   fmt::format("'# frame: {}': write '# frame: workpiece' (the default) or '# frame: instrument' "
                               "(optionally with a name shared by the files measured in the same set-up)",
                               *frame));
      ok = false;
    }
  }
  if (const auto reg = t.meta("registration")) {
    if (src.frame.empty()) {
      t.meta_error("registration", codes::kCsvHeaderKey,
                   "'# registration:' names the instrument-frame components to estimate, but the file has no "
                   "'# frame: instrument' line; add it or remove this one");
      ok = false;
    } else {
      std::uint8_t free = 0;
      std::string_view rest = *reg;
      bool bad = false;
      while (!rest.empty()) {
        const auto sep = rest.find_first_of(", \t");
        const std::string_view w = rest.substr(0, sep);
        rest = sep == std::string_view::npos ? std::string_view{} : rest.substr(sep + 1);
        if (w.empty()) continue;
        int k = -1;
        for (int i = 0; i < 6; ++i)
          if (w == registration_name(i)) k = i;
        if (w == "none") continue;
        if (k < 0) {
          bad = true;
          break;
        }
        free = static_cast<std::uint8_t>(free | (1u << k));
      }
      if (bad) {
        t.meta_error("registration", codes::kCsvHeaderKey,
                     fmt::format("'# registration: {}': list the components to estimate from tx, ty, tz (mm) and rx, "
                                 "ry, rz (rotations), e.g. '# registration: tx, ty, tz, rz', or 'none'",
                                 *reg));
        ok = false;
      } else if (!point && (free & kTranslation) != 0) {
        t.meta_error("registration", codes::kCsvHeaderKey,
                     "a translation of the instrument frame does not change a direction, so a directions file cannot "
                     "estimate tx, ty or tz; list only rx, ry, rz");
        ok = false;
      } else {
        src.free = free;
      }
    }
  }
  // `# sigma: 1 um`, `# sigma_angle: 2 arcsec`: a positive quantity with a unit of its kind.
  auto uncertainty = [&](std::string_view key, Quantity q, std::string_view example, double& into) {
    const auto text = t.meta(key);
    if (!text) return;
    if (const auto v = quantity_text(*text, q)) {
      into = *v;
      return;
    }
    t.meta_error(key, codes::kCsvHeaderKey,
                 fmt::format("'# {}: {}' is not a positive {} with a unit; write the standard uncertainty of every {} "
                             "value, e.g. '# {}: {}'",
                             key, *text, q == Quantity::length ? "length" : "angle",
                             q == Quantity::length ? "length" : "angle", key, example));
    ok = false;
  };
  uncertainty("sigma", Quantity::length, "1 um", src.sigma_mm);
  uncertainty("sigma_angle", Quantity::angle, "2 arcsec", src.sigma_rad);
  if (!ok) return std::nullopt;
  return src;
}

JointColumns joint_columns(CsvTable& t, const kin::Model& model) {
  JointColumns out;
  out.joints = model.joints();
  for (const kin::Joint& joint : model.joints()) {
    double s = 1;
    out.column.push_back(
        t.quantity_column(joint.name, joint.type == kin::JointType::rotary ? Quantity::angle : Quantity::length, true, s));
    // Joint values stay in interface units: mm and degrees.
    out.scale.push_back(joint.type == kin::JointType::rotary ? s / kin::kDeg : s);
  }
  return out;
}

std::optional<kin::JointVector> joints_of_row(CsvTable& t, const JointColumns& c, std::size_t row) {
  kin::JointVector q(static_cast<Eigen::Index>(c.column.size()));
  for (std::size_t j = 0; j < c.column.size(); ++j) {
    const auto v = t.number(row, c.column[j], c.scale[j]);
    if (!v) return std::nullopt;
    // A measurement is taken at a pose the machine reached: axis values outside its travel are a
    // wrong file, column or unit (the solver would otherwise fit them and report a residual).
    const kin::Joint& joint = c.joints[j];
    constexpr double kSlack = 1e-3;  // mm / degrees: rounding of a pose recorded at a limit
    if (*v < joint.min - kSlack || *v > joint.max + kSlack) {
      const char* unit = joint.type == kin::JointType::rotary ? "deg" : "mm";
      t.error(row, c.column[j], codes::kCsvRange,
              fmt::format("{} = {:g} {} is outside the machine's travel of {} ({:g} … {:g} {}); check the row, the "
                          "column's unit and the machine file's min/max",
                          joint.name, *v, unit, joint.name, joint.min, joint.max, unit));
      return std::nullopt;
    }
    q[static_cast<Eigen::Index>(j)] = *v;
  }
  return q;
}

std::string_view to_string(MeasurementKind k) {
  switch (k) {
    case MeasurementKind::pose: return "pose";
    case MeasurementKind::position: return "position";
    case MeasurementKind::direction: return "direction";
    case MeasurementKind::axis_cosine: return "axis-cosine";
    case MeasurementKind::struts: return "struts";
  }
  return "?";
}

int residual_rows(const Measurement& m, int joints) {
  switch (m.kind) {
    case MeasurementKind::pose: return m.has_torsion ? 6 : 5;
    case MeasurementKind::position: return 3;
    case MeasurementKind::direction: return 2;
    case MeasurementKind::axis_cosine: return 1;
    case MeasurementKind::struts: return joints;
  }
  return 0;
}

std::optional<std::string> measurement_file_kind(CsvTable& table) {
  const auto kind = table.meta("kind");
  std::string list;
  for (auto k : kKinds) list += (list.empty() ? "" : ", ") + std::string(k);
  if (!kind) {
    table.error(CsvTable::kHeader, -1, codes::kCsvColumns,
                fmt::format("the file does not say what it measures; add a first line '# kind: <{}>' (docs/measurements.md)",
                            list));
    return std::nullopt;
  }
  for (auto k : kKinds)
    if (*kind == k) return *kind;
  if (*kind == "step-gauge" || *kind == "step-gauge-edge") return *kind;
  table.error(CsvTable::kHeader, -1, codes::kCsvColumns,
              fmt::format("'# kind: {}' is not a measurement kind; use one of {}, step-gauge, step-gauge-edge", *kind, list));
  return std::nullopt;
}

bool read_measurements(CsvTable& t, const kin::Model& model, std::vector<Measurement>& out) {
  const auto kind = measurement_file_kind(t);
  if (!kind) return false;
  const std::size_t errors0 = t.sink().count(gcode::Severity::error);
  if (!t.check_header_keys(kSettings, kInformationalKeys)) return false;
  const auto source = measurement_source(t, *kind);
  if (!source) return false;
  const bool hexapod = model.kind().find("hexapod") != std::string::npos;
  if (*kind == "struts" && !hexapod) {
    t.error(CsvTable::kHeader, -1, codes::kCsvColumns,
            fmt::format("strut readings calibrate a hexapod, but this machine is {}; use '# kind: poses' or positions",
                        model.kind()));
    return false;
  }

  const JointColumns joints = joint_columns(t, model);
  const bool wants_point = *kind == "poses" || *kind == "positions" || *kind == "struts";
  const bool wants_axis = *kind == "poses" || *kind == "directions" || *kind == "struts";
  std::array<int, 3> pcol{-1, -1, -1}, acol{-1, -1, -1}, ucol{-1, -1, -1};
  double pscale[3] = {1, 1, 1};
  if (wants_point)
    for (std::size_t k = 0; k < 3; ++k)
      pcol[k] = t.quantity_column(std::array<std::string_view, 3>{"x", "y", "z"}[k], Quantity::length, true, pscale[k]);
  bool cols_ok = true;
  if (wants_axis) cols_ok = ratio_columns(t, {"i", "j", "k"}, true, acol) && cols_ok;
  if (*kind == "poses" || *kind == "struts") cols_ok = ratio_columns(t, {"ui", "uj", "uk"}, *kind == "struts", ucol) && cols_ok;
  // Attitudes: travel and stem extension per linear axis (Z optional).
  std::array<int, 3> travel{-1, -1, -1}, stem{-1, -1, -1};
  std::array<double, 3> tscale{1, 1, 1}, sscale{1, 1, 1};
  if (*kind == "attitudes") {
    // Any of the three indicator directions; at least one (a tool tilted in XZ has no usable Y record).
    for (std::size_t k = 0; k < 3; ++k) {
      const std::string axis(1, "xyz"[k]);
      if (t.find("travel_" + axis) >= 0 || t.find("stem_" + axis) >= 0) {
        travel[k] = t.quantity_column("travel_" + axis, Quantity::length, true, tscale[k]);
        stem[k] = t.quantity_column("stem_" + axis, Quantity::length, true, sscale[k]);
      }
    }
    if (t.find("travel_x") < 0 && t.find("travel_y") < 0 && t.find("travel_z") < 0 && t.find("stem_x") < 0 &&
        t.find("stem_y") < 0 && t.find("stem_z") < 0) {
      double unused_scale = 1;
      (void)t.quantity_column("travel_x", Quantity::length, true, unused_scale);
      (void)t.quantity_column("stem_x", Quantity::length, true, unused_scale);
    }
  }
  double unused = 1;
  const int idcol = t.find("id") >= 0 ? t.quantity_column("id", Quantity::ratio, false, unused) : -1;
  const int setcol = t.find("set");
  t.use(idcol);
  t.use(setcol);
  t.report_unused();
  if (t.sink().count(gcode::Severity::error) > errors0 || !cols_ok) return false;
  if (!joints.ok()) return false;

  out.reserve(out.size() + t.rows().size());  // one allocation, not a doubling growth
  for (std::size_t r = 0; r < t.rows().size(); ++r) {
    Measurement m;
    m.file = t.file();
    m.line = t.rows()[r].line;
    m.source = *source;
    m.label = idcol >= 0 ? t.rows()[r].cells[static_cast<std::size_t>(idcol)] : fmt::format("{}:{}", t.file(), m.line);
    if (setcol >= 0) {
      const std::string& s = t.rows()[r].cells[static_cast<std::size_t>(setcol)];
      if (s == "validate") m.validate = true;
      else if (s != "fit" && !s.empty()) {
        t.error(r, setcol, codes::kCsvRange, fmt::format("set '{}' is neither fit nor validate", s));
        continue;
      }
    }
    const auto q = joints_of_row(t, joints, r);
    if (!q) continue;
    m.q = *q;
    bool ok = true;
    if (wants_point) {
      for (int k = 0; k < 3 && ok; ++k) {
        const auto v = t.number(r, pcol[static_cast<std::size_t>(k)], pscale[k]);
        if (!v) ok = false;
        else m.measured.p[k] = *v;
      }
    }
    if (!ok) continue;
    m.has_torsion = false;
    if (wants_axis) {
      const auto o = unit_vector(t, r, acol, "tool axis (i, j, k)");
      if (!o) continue;
      std::optional<Vec3> x;
      if (ucol[0] >= 0) {
        const auto u = unit_vector(t, r, ucol, "tool reference direction (ui, uj, uk)");
        if (!u) continue;
        if (std::abs(u->dot(*o)) > 0.05) {
          t.error(r, ucol[0], codes::kCsvRange,
                  fmt::format("the reference direction is not perpendicular to the tool axis (cosine {:.3g}); give the "
                              "tool frame's x axis",
                              u->dot(*o)));
          continue;
        }
        x = *u;
        m.has_torsion = true;
      }
      m.measured.r = frame_with_axis(*o, x);
    }
    if (*kind == "attitudes") {
      // Per indicator direction: both cells empty = not recorded in this row.
      Vec3 c = Vec3::Zero();
      std::array<bool, 3> given{};
      for (std::size_t k = 0; k < 3 && ok; ++k) {
        if (travel[k] < 0) continue;
        const bool empty_t = t.rows()[r].cells[static_cast<std::size_t>(travel[k])].empty();
        const bool empty_s = t.rows()[r].cells[static_cast<std::size_t>(stem[k])].empty();
        if (empty_t && empty_s) continue;
        const auto d = t.number(r, travel[k], tscale[k]);
        const auto l = t.number(r, stem[k], sscale[k]);
        if (!d || !l) {
          ok = false;
          break;
        }
        if (std::abs(*l) < std::abs(*d) * (1 - 1e-12) || *l == 0) {
          t.error(r, stem[k], codes::kCsvRange,
                  fmt::format("the stem moved {:g} mm for a travel of {:g} mm; the stem extension cannot be shorter "
                              "than the travel (cos = travel / extension ≤ 1): check the record",
                              *l, *d));
          ok = false;
          break;
        }
        c[static_cast<Eigen::Index>(k)] = *d / *l;
        given[k] = true;
      }
      if (!ok) continue;
      const int count = static_cast<int>(given[0]) + static_cast<int>(given[1]) + static_cast<int>(given[2]);
      if (count == 0) {
        t.error(r, -1, codes::kCsvRange, "no indicator record in this row; give travel and stem of at least one axis");
        continue;
      }
      if (count == 1 || (count == 2 && given[2])) {
        // One direction cosine per record: the stem (= −tool axis) against the travel direction.
        // A tool tilted in XZ has no usable Y record; X and Z alone leave the sign of the Y cosine open.
        for (std::size_t k = 0; k < 3; ++k) {
          if (!given[k]) continue;
          Measurement one = m;
          one.kind = MeasurementKind::axis_cosine;
          const Vec3 d = Vec3::Unit(static_cast<Eigen::Index>(k));
          one.measured.r = frame_with_axis(d.unitOrthogonal());
          one.measured.r.col(0) = d;
          one.measured.r.col(1) = one.measured.r.col(2).cross(d);
          one.cosine = -c[static_cast<Eigen::Index>(k)];  // tool axis O = −stem direction
          out.push_back(std::move(one));
        }
        continue;
      }
      if (!given[2]) {
        const double rest = 1 - c.x() * c.x() - c.y() * c.y();
        if (rest < 0) {
          t.error(r, travel[0], codes::kCsvRange, "cos²α + cos²β > 1: the X and Y records contradict each other");
          continue;
        }
        c.z() = -std::sqrt(rest);  // the stem points down, toward the table
      }
      if (std::abs(c.norm() - 1) > 0.02) {
        t.error(r, travel[0], codes::kCsvRange,
                fmt::format("the direction cosines ({:.5f}, {:.5f}, {:.5f}) have length {:.4f}, not 1: the three records "
                            "do not belong to one direction",
                            c.x(), c.y(), c.z(), c.norm()));
        continue;
      }
      m.measured.r = frame_with_axis(-c.normalized());  // the tool axis points from the tip toward the spindle
    }
    if (*kind == "poses") m.kind = MeasurementKind::pose;
    else if (*kind == "positions") m.kind = MeasurementKind::position;
    else if (*kind == "struts") m.kind = MeasurementKind::struts;
    else m.kind = MeasurementKind::direction;
    out.push_back(std::move(m));
  }
  if (t.rows().empty()) {
    t.error(CsvTable::kHeader, -1, codes::kCsvSyntax, "the file has a header but no measurements");
    return false;
  }
  return t.sink().count(gcode::Severity::error) == errors0;
}

std::string write_measurements(std::span<const Measurement> data, const kin::Model& model,
                               const std::vector<std::string>& comment) {
  if (data.empty()) return {};
  const Measurement& first = data.front();
  std::string kind;
  switch (first.kind) {
    case MeasurementKind::pose: kind = "poses"; break;
    case MeasurementKind::position: kind = "positions"; break;
    case MeasurementKind::direction: kind = "directions"; break;
    case MeasurementKind::axis_cosine:
      throw Error(ExitCode::usage, "single indicator records are written as attitudes files, not by write_measurements");
    case MeasurementKind::struts: kind = "struts"; break;
  }
  std::string s = fmt::format("# kind: {}\n", kind);
  for (const std::string& c : comment) s += "# " + c + "\n";
  s += "id";
  for (const kin::Joint& j : model.joints()) s += fmt::format(",{}_{}", j.name, j.type == kin::JointType::rotary ? "deg" : "mm");
  const bool point = first.kind != MeasurementKind::direction;
  const bool axis = first.kind != MeasurementKind::position;
  const bool torsion = axis && first.kind != MeasurementKind::direction && first.has_torsion;
  if (point) s += ",x_mm,y_mm,z_mm";
  if (axis) s += ",i,j,k";
  if (torsion) s += ",ui,uj,uk";
  bool any_validate = false;
  for (const Measurement& m : data) any_validate = any_validate || m.validate;
  if (any_validate) s += ",set";
  s += '\n';
  for (const Measurement& m : data) {
    s += m.label.empty() ? std::string("-") : m.label;
    for (int j = 0; j < m.q.size(); ++j) s += fmt::format(",{:.10g}", m.q[j]);
    if (point) s += fmt::format(",{:.9f},{:.9f},{:.9f}", m.measured.p.x(), m.measured.p.y(), m.measured.p.z());
    const Vec3 o = m.measured.axis();
    if (axis) s += fmt::format(",{:.12f},{:.12f},{:.12f}", o.x(), o.y(), o.z());
    if (torsion) {
      const Vec3 u = m.measured.r.col(0);
      s += fmt::format(",{:.12f},{:.12f},{:.12f}", u.x(), u.y(), u.z());
    }
    if (any_validate) s += m.validate ? ",validate" : ",fit";
    s += '\n';
  }
  return s;
}

}  // namespace postproc::cal
