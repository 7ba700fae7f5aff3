#include "postproc/gcode/motion.hpp"

#include <cmath>

#include <Eigen/Geometry>

namespace postproc::gcode {

namespace {
constexpr std::array<std::int8_t, 128> make_axis_table() {
  std::array<std::int8_t, 128> t{};
  for (auto& v : t) v = -1;
  for (int i = 0; i < kAxisCount; ++i) t[static_cast<std::size_t>(kAxisLetters[static_cast<std::size_t>(i)])] = static_cast<std::int8_t>(i);
  return t;
}
constexpr auto kAxisTable = make_axis_table();
}  // namespace

int axis_index(char L) {
  const auto u = static_cast<unsigned char>(L);
  return u < 128 ? kAxisTable[u] : -1;
}

std::string_view to_string(MotionType t) {
  switch (t) {
    case MotionType::rapid: return "rapid";
    case MotionType::linear: return "linear";
    case MotionType::arc_cw: return "cw";
    case MotionType::arc_ccw: return "ccw";
    case MotionType::drill_cycle: return "drill";
  }
  return "?";
}
std::string_view to_string(Plane p) {
  switch (p) {
    case Plane::xy: return "xy";
    case Plane::zx: return "zx";
    case Plane::yz: return "yz";
  }
  return "?";
}
std::string_view to_string(FeedMode f) {
  switch (f) {
    case FeedMode::per_minute: return "per_minute";
    case FeedMode::per_rev: return "per_rev";
    case FeedMode::inverse_time: return "inverse_time";
  }
  return "?";
}
std::string_view to_string(TcpMode t) {
  switch (t) {
    case TcpMode::off: return "off";
    case TcpMode::fanuc_g43_4: return "G43.4";
    case TcpMode::fanuc_g43_5: return "G43.5";
    case TcpMode::siemens_traori: return "TRAORI";
    case TcpMode::heidenhain_m128: return "M128";
  }
  return "?";
}

Eigen::Vector3d end_direction(const Motion& m) {
  const Eigen::Vector3d start = m.start.head<3>(), end = m.end.head<3>();
  if (m.type != MotionType::arc_cw && m.type != MotionType::arc_ccw) return end - start;
  const PlaneAxes p = plane_axes(m.plane);
  Eigen::Vector3d radial = end - m.arc.centre;
  radial[p.n] = 0;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  normal[p.n] = m.arc.sweep >= 0 ? 1.0 : -1.0;
  Eigen::Vector3d t = normal.cross(radial);
  if (std::abs(m.arc.sweep) > 0) t[p.n] = (end[p.n] - start[p.n]) / std::abs(m.arc.sweep);
  return t;
}

}  // namespace postproc::gcode
