// Sinumerik DC / ACP / ACN positioning of modulo rotary axes (rotary_direction.hpp).
#include "src/gcode/rotary_direction.hpp"

#include <cctype>
#include <cmath>

namespace postproc::gcode {
namespace {

/// x modulo 360 in [0, 360).
double turn(double x) {
  const double r = std::fmod(x, 360.0);
  return r < 0 ? r + 360.0 : (r >= 360.0 ? 0.0 : r);
}

bool starts_with_i(std::string_view s, std::string_view p) {
  if (s.size() < p.size()) return false;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (std::toupper(static_cast<unsigned char>(s[i])) != p[i]) return false;
  return true;
}

/// Angles closer than this are equal, degrees (far below any written digit).
constexpr double kSame = 1e-9;

}  // namespace

RotaryDirection direction_of(std::string_view value) {
  if (starts_with_i(value, "DC(")) return RotaryDirection::shortest;
  if (starts_with_i(value, "ACP(")) return RotaryDirection::positive;
  if (starts_with_i(value, "ACN(")) return RotaryDirection::negative;
  return RotaryDirection::none;
}

std::string_view function_name(RotaryDirection d) {
  switch (d) {
    case RotaryDirection::shortest: return "DC";
    case RotaryDirection::positive: return "ACP";
    case RotaryDirection::negative: return "ACN";
    case RotaryDirection::none: break;
  }
  return "";
}

double directed_target(RotaryDirection d, double word, double from) {
  double delta = turn(word) - turn(from);
  switch (d) {
    case RotaryDirection::shortest:
      if (delta > 180.0) delta -= 360.0;
      else if (delta <= -180.0) delta += 360.0;
      break;
    case RotaryDirection::positive:
      if (delta < 0) delta += 360.0;
      break;
    case RotaryDirection::negative:
      if (delta > 0) delta -= 360.0;
      break;
    case RotaryDirection::none: return word;
  }
  if (std::abs(delta) < kSame) delta = 0;
  return from + delta;
}

std::optional<double> directed_word(RotaryDirection d, double target, double from) {
  if (d == RotaryDirection::none) return target;
  const double w = turn(target);
  if (std::abs(directed_target(d, w, from) - target) > kSame) return std::nullopt;
  return w;
}

}  // namespace postproc::gcode
