// Typed, unit-checked reading of machine-file tables with located diagnostics.
#include "src/machine/toml_fields.hpp"

#include <charconv>
#include <cmath>

#include <fmt/format.h>


namespace postproc::machine {
namespace {

struct UnitDef {
  std::string_view name;
  Dim dim;
  double factor;  // value in this unit × factor = value in the dimension's returned unit
};

constexpr double kPi = 3.14159265358979323846;
constexpr UnitDef kUnits[] = {
    {"nm", Dim::length, 1e-6},       {"um", Dim::length, 1e-3},         {"µm", Dim::length, 1e-3},
    {"mm", Dim::length, 1.0},        {"cm", Dim::length, 10.0},         {"m", Dim::length, 1000.0},
    {"in", Dim::length, 25.4},       {"rad", Dim::angle, 1.0},          {"mrad", Dim::angle, 1e-3},
    {"urad", Dim::angle, 1e-6},      {"µrad", Dim::angle, 1e-6},        {"deg", Dim::angle, kPi / 180},
    {"°", Dim::angle, kPi / 180},    {"arcmin", Dim::angle, kPi / 10800}, {"arcsec", Dim::angle, kPi / 648000},
    {"\"", Dim::angle, kPi / 648000}, {"um/m", Dim::angle, 1e-6},       {"µm/m", Dim::angle, 1e-6},
    {"mm/m", Dim::angle, 1e-3},      {"1/s", Dim::inverse_time, 1.0},   {"1/min", Dim::inverse_time, 1.0 / 60},
    {"(m/min)/mm", Dim::inverse_time, 1000.0 / 60}, {"m/min/mm", Dim::inverse_time, 1000.0 / 60},
    {"s", Dim::time, 1.0},           {"ms", Dim::time, 1e-3},           {"us", Dim::time, 1e-6},
    {"µs", Dim::time, 1e-6},         {"min", Dim::time, 60.0},          {"mm/min", Dim::velocity, 1.0},
    {"m/min", Dim::velocity, 1000.0}, {"mm/s", Dim::velocity, 60.0},    {"m/s", Dim::velocity, 60000.0},
    {"in/min", Dim::velocity, 25.4}, {"deg/min", Dim::velocity, 1.0}, {"deg/s", Dim::velocity, 60.0},
    {"deg/s^2", Dim::acceleration, 1.0}, {"deg/s^3", Dim::jerk, 1.0}, {"mm/s^2", Dim::acceleration, 1.0}, {"m/s^2", Dim::acceleration, 1000.0},
    {"g", Dim::acceleration, 9806.65}, {"mm/s^3", Dim::jerk, 1.0},      {"m/s^3", Dim::jerk, 1000.0},
    {"%", Dim::ratio, 0.01},         {"1", Dim::ratio, 1.0},            {"ppm", Dim::ratio, 1e-6},
    {"um/m", Dim::ratio, 1e-6},      {"µm/m", Dim::ratio, 1e-6},       {"mm/m", Dim::ratio, 1e-3},
};

std::string units_of(Dim d) {
  std::string s;
  for (const auto& u : kUnits)
    if (u.dim == d && u.name != "µm" && u.name != "µrad" && u.name != "µm/m" && u.name != "µs" && u.name != "°" &&
        u.name != "\"")
      s += (s.empty() ? "" : ", ") + std::string(u.name);
  return s;
}

std::string_view type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a number";
    case toml::node_type::boolean: return "a boolean";
    default: return "a date/time";
  }
}

/// The largest magnitude a machine could ever have for a quantity of dimension d, in d's returned
/// unit: beyond it a value is a typo or a corrupted file, refused where it is read (issue 21)
/// rather than failing later at a program line or making a solver diverge.
struct Envelope {
  double limit;
  std::string_view shown;  ///< the limit as the message states it
};
Envelope envelope_of(Dim d) {
  switch (d) {
    case Dim::length: return {1e6, "1e6 mm (1 km)"};
    case Dim::angle: return {1e6 * kPi / 180, "1e6 deg"};
    case Dim::inverse_time: return {1e6, "1e6 1/s"};
    case Dim::time: return {1e6, "1e6 s"};
    case Dim::velocity: return {1e9, "1e9 mm/min"};
    case Dim::acceleration: return {1e9, "1e9 mm/s^2"};
    case Dim::jerk: return {1e13, "1e13 mm/s^3"};
    case Dim::ratio: return {1e6, "1e6"};
  }
  return {1e6, "1e6"};
}

std::optional<double> number_of(const toml::node& n) {
  if (auto v = n.value<double>()) return *v;  // integers convert too
  return std::nullopt;
}

}  // namespace

std::string_view to_string(Dim d) {
  switch (d) {
    case Dim::length: return "length";
    case Dim::angle: return "angle";
    case Dim::inverse_time: return "gain (1/time)";
    case Dim::time: return "time";
    case Dim::velocity: return "velocity";
    case Dim::acceleration: return "acceleration";
    case Dim::jerk: return "jerk";
    case Dim::ratio: return "ratio";
  }
  return "?";
}

std::optional<double> convert_unit(double value, std::string_view unit, Dim d) {
  for (const auto& u : kUnits)
    if (u.name == unit && u.dim == d) return value * u.factor;  // "um/m": an angle (slope) or a ratio (scale)
  return std::nullopt;
}

TomlDoc::TomlDoc(std::string file, std::string text, gcode::DiagnosticSink& sink)
    : file_(std::move(file)), text_(std::move(text)), sink_(sink) {
  std::string_view rest = text_;
  while (!rest.empty()) {
    const auto nl = rest.find('\n');
    std::string_view line = rest.substr(0, nl);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines_.push_back(line);
    if (nl == std::string_view::npos) break;
    rest.remove_prefix(nl + 1);
  }
  try {
    root_ = toml::parse(text_, file_);
    ok_ = true;
  } catch (const toml::parse_error& e) {
    error(e.source(), codes::kSyntax,
          fmt::format("not valid TOML: {}; fix the syntax (https://toml.io: key = value, [table], [[array of tables]])",
                      e.description()));
  }
}

void TomlDoc::error(const toml::source_region& where, std::string_view code, std::string message) {
  gcode::Diagnostic d;
  d.severity = gcode::Severity::error;
  d.code = std::string(code);
  d.file = file_;
  d.where.line = where.begin.line;
  d.where.column = where.begin.column;
  d.message = std::move(message);
  if (where.begin.line >= 1 && where.begin.line <= lines_.size()) d.source_line = std::string(lines_[where.begin.line - 1]);
  if (where.end.line == where.begin.line && where.end.column > where.begin.column)
    d.length = where.end.column - where.begin.column;
  sink_.report(std::move(d));
}

Fields::Fields(TomlDoc& doc, const toml::table& t, std::string path) : doc_(doc), t_(t), path_(std::move(path)) {}

void Fields::error_at(std::string_view key, std::string_view code, std::string message) {
  const toml::node* n = t_.get(key);
  doc_.error(n != nullptr ? n->source() : t_.source(), code, std::move(message));
}

const toml::node* Fields::get(std::string_view key, bool required, std::string_view expected) {
  known(key);
  const toml::node* n = t_.get(key);
  if (n == nullptr && required)
    doc_.error(t_.source(), codes::kMissing,
               fmt::format("[{}] has no '{}'; add {} = <{}>", path_, key, key, expected));
  return n;
}

std::optional<double> Fields::quantity_node(const toml::node& n, std::string_view what, Dim d,
                                            std::string_view default_unit) {
  const auto v = parse_quantity(n, what, d, default_unit);
  if (!v) return v;
  const Envelope e = envelope_of(d);
  if (!std::isfinite(*v) || std::abs(*v) > e.limit) {
    doc_.error(n.source(), codes::kRange,
               fmt::format("{} is beyond anything a machine could have (a {} of magnitude at most {}); check the "
                           "value and its unit",
                           what, to_string(d), e.shown));
    return std::nullopt;
  }
  return v;
}

std::optional<double> Fields::parse_quantity(const toml::node& n, std::string_view what, Dim d,
                                             std::string_view default_unit) {
  if (auto v = number_of(n)) {
    if (!std::isfinite(*v)) {
      doc_.error(n.source(), codes::kRange, fmt::format("{} must be a finite number", what));
      return std::nullopt;
    }
    return convert_unit(*v, default_unit, d);
  }
  if (auto s = n.value<std::string>()) {
    std::string_view t = *s;
    while (!t.empty() && t.front() == ' ') t.remove_prefix(1);
    double v = 0;
    const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
    std::string_view unit = t.substr(static_cast<std::size_t>(ptr - t.data()));
    while (!unit.empty() && unit.front() == ' ') unit.remove_prefix(1);
    while (!unit.empty() && unit.back() == ' ') unit.remove_suffix(1);
    if (ec != std::errc() || !std::isfinite(v)) {
      doc_.error(n.source(), codes::kUnit,
                 fmt::format("{} = \"{}\" is not a quantity; write a number and a unit, e.g. \"12.5 {}\"", what, *s,
                             default_unit));
      return std::nullopt;
    }
    if (unit.empty()) return convert_unit(v, default_unit, d);
    if (auto c = convert_unit(v, unit, d)) return c;
    doc_.error(n.source(), codes::kUnit,
               fmt::format("{} = \"{}\": '{}' is not a unit of {}; use one of: {}", what, *s, unit, to_string(d),
                           units_of(d)));
    return std::nullopt;
  }
  doc_.error(n.source(), codes::kType,
             fmt::format("{} is {}; write a number ({}) or a string such as \"12.5 {}\"", what, type_name(n),
                         default_unit, default_unit));
  return std::nullopt;
}

std::optional<double> Fields::quantity(std::string_view key, Dim d, std::string_view default_unit, bool required,
                                       Range range) {
  const toml::node* n = get(key, required, fmt::format("{} in {}", to_string(d), default_unit));
  if (n == nullptr) return std::nullopt;
  auto v = quantity_node(*n, fmt::format("[{}] {}", path_, key), d, default_unit);
  if (!v) return v;
  const bool low = range.lo_open ? *v <= range.lo : *v < range.lo;
  if (low || *v > range.hi) {
    const double f = *convert_unit(1.0, default_unit, d);
    doc_.error(n->source(), codes::kRange,
               fmt::format("[{}] {} = {} {} is not physical here; it must be {} {} {}{}", path_, key, *v / f,
                           default_unit, range.lo_open ? ">" : "≥", range.lo / f, default_unit,
                           std::isfinite(range.hi) ? fmt::format(" and ≤ {} {}", range.hi / f, default_unit) : ""));
    return std::nullopt;
  }
  return v;
}

std::optional<std::vector<double>> Fields::quantities(std::string_view key, Dim d, std::string_view default_unit,
                                                      bool required, std::size_t min_size) {
  const toml::node* n = get(key, required, fmt::format("[list of {} in {}]", to_string(d), default_unit));
  if (n == nullptr) return std::nullopt;
  const toml::array* a = n->as_array();
  if (a == nullptr) {
    doc_.error(n->source(), codes::kType, fmt::format("[{}] {} is {}; write a list [a, b, …]", path_, key, type_name(*n)));
    return std::nullopt;
  }
  if (a->size() < min_size) {
    doc_.error(n->source(), codes::kRange,
               fmt::format("[{}] {} has {} entries; it needs at least {}", path_, key, a->size(), min_size));
    return std::nullopt;
  }
  std::vector<double> out;
  out.reserve(a->size());
  bool ok = true;
  for (std::size_t i = 0; i < a->size(); ++i) {
    auto v = quantity_node(*a->get(i), fmt::format("[{}] {}[{}]", path_, key, i), d, default_unit);
    if (v) out.push_back(*v);
    else ok = false;
  }
  if (!ok) return std::nullopt;
  return out;
}

std::optional<Eigen::Vector3d> Fields::vector3(std::string_view key, Dim d, std::string_view default_unit,
                                               bool required) {
  const toml::node* n = t_.get(key);
  auto v = quantities(key, d, default_unit, required, 3);
  if (!v) return std::nullopt;
  if (v->size() != 3) {
    doc_.error(n->source(), codes::kRange,
               fmt::format("[{}] {} has {} entries; write three: [x, y, z]", path_, key, v->size()));
    return std::nullopt;
  }
  return Eigen::Vector3d((*v)[0], (*v)[1], (*v)[2]);
}

std::optional<Eigen::Vector3d> Fields::direction(std::string_view key, bool required) {
  auto v = vector3(key, Dim::ratio, "1", required);
  if (!v) return v;
  if (v->norm() < 1e-9) {
    error_at(key, codes::kRange, fmt::format("[{}] {} is a zero vector; give a direction such as [0, 0, 1]", path_, key));
    return std::nullopt;
  }
  return v->normalized();
}

std::optional<std::string> Fields::text(std::string_view key, bool required, std::span<const std::string_view> allowed) {
  std::string choices;
  for (auto a : allowed) choices += (choices.empty() ? "" : ", ") + fmt::format("\"{}\"", a);
  const toml::node* n = get(key, required, allowed.empty() ? std::string("\"text\"") : choices);
  if (n == nullptr) return std::nullopt;
  auto s = n->value<std::string>();
  if (!s) {
    doc_.error(n->source(), codes::kType, fmt::format("[{}] {} is {}; write a string", path_, key, type_name(*n)));
    return std::nullopt;
  }
  if (!allowed.empty()) {
    for (auto a : allowed)
      if (a == *s) return s;
    doc_.error(n->source(), codes::kRange, fmt::format("[{}] {} = \"{}\" is not one of {}", path_, key, *s, choices));
    return std::nullopt;
  }
  return s;
}

std::optional<bool> Fields::boolean(std::string_view key, bool required) {
  const toml::node* n = get(key, required, "true|false");
  if (n == nullptr) return std::nullopt;
  auto b = n->value_exact<bool>();
  if (!b) doc_.error(n->source(), codes::kType, fmt::format("[{}] {} is {}; write true or false", path_, key, type_name(*n)));
  return b;
}

std::optional<std::int64_t> Fields::integer(std::string_view key, bool required, std::int64_t lo, std::int64_t hi) {
  const toml::node* n = get(key, required, fmt::format("integer {}…{}", lo, hi));
  if (n == nullptr) return std::nullopt;
  auto v = n->value_exact<std::int64_t>();
  if (!v) {
    doc_.error(n->source(), codes::kType, fmt::format("[{}] {} is {}; write an integer", path_, key, type_name(*n)));
    return std::nullopt;
  }
  if (*v < lo || *v > hi) {
    doc_.error(n->source(), codes::kRange, fmt::format("[{}] {} = {} must be in {}…{}", path_, key, *v, lo, hi));
    return std::nullopt;
  }
  return v;
}

const toml::table* Fields::table(std::string_view key, bool required) {
  const toml::node* n = get(key, required, "table");
  if (n == nullptr) return nullptr;
  if (const auto* t = n->as_table()) return t;
  doc_.error(n->source(), codes::kType, fmt::format("[{}] {} is {}; it must be a table", path_, key, type_name(*n)));
  return nullptr;
}

const toml::array* Fields::array(std::string_view key, bool required) {
  const toml::node* n = get(key, required, "array");
  if (n == nullptr) return nullptr;
  if (const auto* a = n->as_array()) return a;
  doc_.error(n->source(), codes::kType, fmt::format("[{}] {} is {}; it must be an array", path_, key, type_name(*n)));
  return nullptr;
}

void Fields::finish() {
  for (const auto& [k, v] : t_) {
    if (known_.contains(k.str())) continue;
    std::string names;
    for (const auto& n : known_) names += (names.empty() ? "" : ", ") + n;
    doc_.error(k.source(), codes::kUnknownKey,
               fmt::format("unknown key '{}' in [{}]; known keys here: {} (see docs/machine-file.md)", k.str(),
                           path_.empty() ? std::string("top level") : path_, names));
  }
}

}  // namespace postproc::machine
