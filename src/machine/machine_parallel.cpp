// Machine-file sections of the parallel machines: [prs_hybrid] (document 001) and [hexapod]
// (document 003). Both build the nominal model; [errors] is applied by parse_machine.
#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/kinematics/hexapod.hpp"
#include "postproc/kinematics/prs_hybrid.hpp"
#include "src/machine/machine_models.hpp"

namespace postproc::machine {
namespace {

/// A list of six [x, y, z] points in mm.
std::optional<std::array<Eigen::Vector3d, 6>> six_points(TomlDoc& doc, Fields& f, std::string_view key) {
  const toml::array* a = f.array(key, true);
  if (a == nullptr) return std::nullopt;
  if (a->size() != 6) {
    f.error_at(key, codes::kRange, fmt::format("[{}] {} has {} points; a 6×6 hexapod needs 6: [[x, y, z], …]",
                                               f.path(), key, a->size()));
    return std::nullopt;
  }
  std::array<Eigen::Vector3d, 6> out;
  for (std::size_t i = 0; i < 6; ++i) {
    const toml::array* p = a->get(i)->as_array();
    bool ok = p != nullptr && p->size() == 3;
    for (std::size_t k = 0; ok && k < 3; ++k) {
      auto v = f.quantity_node(*p->get(k), fmt::format("[{}] {}[{}][{}]", f.path(), key, i, k), Dim::length, "mm");
      ok = v.has_value();
      if (ok) out[i][static_cast<Eigen::Index>(k)] = *v;
    }
    if (!ok) {
      doc.error(a->get(i)->source(), codes::kType, fmt::format("[{}] {}[{}] must be [x, y, z] in mm", f.path(), key, i));
      return std::nullopt;
    }
  }
  return out;
}

std::optional<std::array<double, 6>> six_values(Fields& f, std::string_view key, bool required) {
  auto v = f.quantities(key, Dim::length, "mm", required, 6);
  if (!v) return std::nullopt;
  if (v->size() != 6) {
    f.error_at(key, codes::kRange, fmt::format("[{}] {} needs 6 values (one per strut)", f.path(), key));
    return std::nullopt;
  }
  std::array<double, 6> out{};
  std::copy(v->begin(), v->end(), out.begin());
  return out;
}

}  // namespace

kin::ModelPtr read_prs_hybrid(TomlDoc& doc, Fields& f, const Machine& m) {
  (void)doc;
  kin::PrsHybridGeometry g;
  using R = Fields::Range;
  const R positive{0, 1e5, true};
  bool ok = true;
  auto need = [&ok](std::optional<double> v, double& into) {
    if (v) into = *v;
    else ok = false;
  };
  need(f.quantity("base_radius", Dim::length, "mm", true, positive), g.base_radius);
  need(f.quantity("platform_radius", Dim::length, "mm", true, positive), g.platform_radius);
  need(f.quantity("link_length", Dim::length, "mm", true, positive), g.link_length);
  if (auto t = f.quantity("guide_tilt", Dim::angle, "deg", false, R{-1.5, 1.5})) g.guide_tilt = *t;
  if (auto o = f.vector3("workpiece_origin", Dim::length, "mm", false)) g.workpiece_origin = *o;
  need(f.quantity("x_min", Dim::length, "mm", true), g.x_min);
  need(f.quantity("x_max", Dim::length, "mm", true), g.x_max);
  need(f.quantity("y_min", Dim::length, "mm", true), g.y_min);
  need(f.quantity("y_max", Dim::length, "mm", true), g.y_max);
  need(f.quantity("slider_min", Dim::length, "mm", true), g.q_min);
  need(f.quantity("slider_max", Dim::length, "mm", true), g.q_max);
  f.finish();
  g.tool_length = m.tool_length;
  if (!ok) return nullptr;
  if (g.x_min >= g.x_max || g.y_min >= g.y_max || g.q_min >= g.q_max) {
    doc.error(f.table_ref().source(), codes::kRange, "[prs_hybrid] each *_max must be above its *_min");
    return nullptr;
  }
  if (g.link_length <= std::abs(g.base_radius - g.platform_radius)) {
    f.error_at("link_length", codes::kRange,
               "[prs_hybrid] link_length must exceed |base_radius − platform_radius| or the limbs cannot close");
    return nullptr;
  }
  try {
    return std::make_shared<const kin::PrsHybrid>(g);
  } catch (const Error& e) {
    doc.error(f.table_ref().source(), codes::kInconsistent, fmt::format("[prs_hybrid] {}", e.what()));
    return nullptr;
  }
}

kin::ModelPtr read_hexapod(TomlDoc& doc, Fields& f, const Machine& m) {
  kin::HexapodConfig cfg;
  auto base = six_points(doc, f, "base_joints");
  auto platform = six_points(doc, f, "platform_joints");
  auto offsets = six_values(f, "strut_offsets", true);
  auto smin = six_values(f, "strut_min", true);
  auto smax = six_values(f, "strut_max", true);
  auto axis = f.direction("tool_axis", false);
  auto wp = f.vector3("workpiece_origin", Dim::length, "mm", false);
  auto home = f.vector3("home", Dim::length, "mm", true);
  static constexpr std::string_view kSpin[] = {"previous", "minimal-from-home"};
  const auto spin = f.text("spin", false, kSpin);
  f.finish();
  if (!base || !platform || !offsets || !smin || !smax || !home) return nullptr;
  cfg.base_joints = *base;
  cfg.platform_joints = *platform;
  cfg.strut_offsets = *offsets;
  cfg.strut_min = *smin;
  cfg.strut_max = *smax;
  if (axis) cfg.tool_axis = *axis;
  // The tool tip lies the tool length below the platform origin along the tool axis.
  cfg.tool_tip = -m.tool_length * cfg.tool_axis;
  if (wp) cfg.workpiece.translation() = *wp;
  cfg.home.translation() = *home;
  if (spin) cfg.spin = *spin == "minimal-from-home" ? kin::HexapodSpin::minimal_from_home : kin::HexapodSpin::previous;
  for (int i = 0; i < 6; ++i)
    if ((*smin)[static_cast<std::size_t>(i)] >= (*smax)[static_cast<std::size_t>(i)]) {
      f.error_at("strut_max", codes::kRange, fmt::format("[hexapod] strut {}: strut_max must be above strut_min", i + 1));
      return nullptr;
    }
  try {
    return std::make_shared<const kin::Hexapod>(cfg);
  } catch (const Error& e) {
    doc.error(f.table_ref().source(), codes::kInconsistent, fmt::format("[hexapod] {}", e.what()));
    return nullptr;
  }
}

}  // namespace postproc::machine
