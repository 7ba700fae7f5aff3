// The model sections of machine files: [serial] (+ [error_motions.*]), [prs_hybrid], [hexapod].
#include "src/machine/machine_models.hpp"

#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/kinematics/serial.hpp"

namespace postproc::machine {
namespace {

constexpr std::string_view kTypes[] = {"linear", "rotary"};

/// [error_motions.<axis>]: position = [...], and the six error-motion columns named as ISO 230-1
/// names them (EXX EYX EZX EAX EBX ECX for X), in length_unit / angle_unit (default um, arcsec).
void read_motion_table(TomlDoc& doc, const toml::table& t, kin::SerialAxis& ax) {
  Fields f(doc, t, "error_motions." + ax.name);
  const bool rotary = ax.type == kin::JointType::rotary;
  auto pos = f.quantities("position", rotary ? Dim::angle : Dim::length, rotary ? "deg" : "mm", true, 2);
  const std::string lu = f.text("length_unit", false).value_or("um");
  const std::string au = f.text("angle_unit", false).value_or("arcsec");
  if (!convert_unit(1, lu, Dim::length)) f.error_at("length_unit", codes::kUnit, fmt::format("'{}' is not a length unit", lu));
  if (!convert_unit(1, au, Dim::angle)) f.error_at("angle_unit", codes::kUnit, fmt::format("'{}' is not an angle unit", au));
  if (!pos) {
    for (const char* c : {"X", "Y", "Z", "A", "B", "C"}) f.known(fmt::format("E{}{}", c, ax.name));
    f.finish();
    return;
  }
  for (std::size_t i = 1; i < pos->size(); ++i)
    if (!((*pos)[i] > (*pos)[i - 1])) {
      f.error_at("position", codes::kRange,
                 fmt::format("[error_motions.{}] position must be strictly increasing (entry {} is not above entry {})",
                             ax.name, i, i - 1));
      f.finish();
      return;
    }
  ax.table.position.resize(pos->size());
  ax.table.error.assign(pos->size(), {0, 0, 0, 0, 0, 0});
  for (std::size_t i = 0; i < pos->size(); ++i) ax.table.position[i] = rotary ? (*pos)[i] / kin::kDeg : (*pos)[i];
  static constexpr const char* kCols[6] = {"X", "Y", "Z", "A", "B", "C"};
  for (int c = 0; c < 6; ++c) {
    const std::string key = fmt::format("E{}{}", kCols[c], ax.name);
    auto col = f.quantities(key, c < 3 ? Dim::length : Dim::angle, c < 3 ? lu : au, false);
    if (!col) continue;
    if (col->size() != pos->size()) {
      f.error_at(key, codes::kInconsistent,
                 fmt::format("[error_motions.{}] {} has {} values for {} positions", ax.name, key, col->size(), pos->size()));
      continue;
    }
    for (std::size_t i = 0; i < col->size(); ++i) ax.table.error[i][static_cast<std::size_t>(c)] = (*col)[i];
  }
  f.finish();
}

bool read_chain(TomlDoc& doc, Fields& f, std::string_view key, const toml::table* motions,
                std::vector<kin::SerialAxis>& out) {
  const toml::array* a = f.array(key, false);
  if (a == nullptr) return true;
  bool ok = true;
  for (std::size_t i = 0; i < a->size(); ++i) {
    const toml::table* t = a->get(i)->as_table();
    if (t == nullptr) {
      doc.error(a->get(i)->source(), codes::kType,
                fmt::format("[serial] {} must be an array of tables: [[serial.{}]] axis = \"X\" …", key, key));
      ok = false;
      continue;
    }
    Fields af(doc, *t, fmt::format("serial.{}[{}]", key, i));
    kin::SerialAxis ax;
    ax.name = af.text("axis", true).value_or("");
    if (ax.name.size() != 1 || gcode::axis_index(ax.name[0]) < 0) {
      if (!ax.name.empty())
        af.error_at("axis", codes::kRange, fmt::format("axis \"{}\" is not a program axis letter (X Y Z A B C U V W)", ax.name));
      ok = false;
    }
    const auto type = af.text("type", true, kTypes).value_or("linear");
    ax.type = type == "rotary" ? kin::JointType::rotary : kin::JointType::linear;
    if (auto d = af.direction("direction", true)) ax.direction = *d;
    else ok = false;
    if (ax.type == kin::JointType::rotary) {
      if (auto p = af.vector3("pivot", Dim::length, "mm", true)) ax.pivot = *p;
      else ok = false;
    }
    const bool rotary = ax.type == kin::JointType::rotary;
    const double unit = rotary ? kin::kDeg : 1.0;
    if (auto v = af.quantity("min", rotary ? Dim::angle : Dim::length, rotary ? "deg" : "mm", !rotary)) ax.min = *v / unit;
    if (auto v = af.quantity("max", rotary ? Dim::angle : Dim::length, rotary ? "deg" : "mm", !rotary)) ax.max = *v / unit;
    if (ax.min >= ax.max) {
      af.error_at("max", codes::kRange, fmt::format("axis {}: max must be above min", ax.name));
      ok = false;
    }
    af.finish();
    if (motions != nullptr && !ax.name.empty())
      if (const toml::node* n = motions->get(ax.name))
        if (const toml::table* mt = n->as_table()) read_motion_table(doc, *mt, ax);
    out.push_back(std::move(ax));
  }
  return ok;
}

}  // namespace

kin::ModelPtr read_serial(TomlDoc& doc, Fields& f, const toml::table* error_motions, const Machine& m) {
  kin::SerialConfig cfg;
  bool ok = read_chain(doc, f, "workpiece_side", error_motions, cfg.workpiece_side);
  ok = read_chain(doc, f, "tool_side", error_motions, cfg.tool_side) && ok;
  if (auto p = f.vector3("spindle_point", Dim::length, "mm", true)) cfg.spindle_point = *p;
  else ok = false;
  if (auto d = f.direction("tool_axis", false)) cfg.tool_axis = *d;
  if (auto d = f.direction("tool_x", false)) cfg.tool_x = *d;
  f.finish();
  cfg.tool_length = m.tool_length;
  if (error_motions != nullptr) {
    for (const auto& [k, v] : *error_motions) {
      bool found = false;
      for (const auto* chain : {&cfg.workpiece_side, &cfg.tool_side})
        for (const auto& ax : *chain) found = found || ax.name == k.str();
      if (!found)
        doc.error(k.source(), codes::kUnknownKey,
                  fmt::format("[error_motions.{}]: the serial chain has no axis {}", k.str(), k.str()));
    }
  }
  if (!ok) return nullptr;
  if (std::abs(cfg.tool_axis.dot(cfg.tool_x)) > 1e-9) {
    f.error_at("tool_x", codes::kInconsistent, "[serial] tool_x must be perpendicular to tool_axis");
    return nullptr;
  }
  try {
    return std::make_shared<const kin::SerialModel>(std::move(cfg));
  } catch (const Error& e) {
    doc.error(f.table_ref().source(), codes::kInconsistent, fmt::format("[serial] {}", e.what()));
    return nullptr;
  }
}

}  // namespace postproc::machine
