// Roll-over positioning of rotary axes (see rotary_rollover.hpp), and Sinumerik DC / ACP / ACN
// (rotary_direction.hpp).
#include "postproc/gcode/rotary_rollover.hpp"

#include <cmath>

#include "src/gcode/rotary_direction.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode {
namespace {

/// x modulo 360 in [0, 360).
double turn(double x) {
  const double r = std::fmod(x, 360.0);
  return r < 0 ? r + 360.0 : (r >= 360.0 ? 0.0 : r);
}

/// Angles closer than this are equal, degrees (far below any written digit).
constexpr double kSame = 1e-9;

}  // namespace

std::string_view to_string(RotaryRollover r) {
  switch (r) {
    case RotaryRollover::off: return "off";
    case RotaryRollover::shortest: return "shortest";
    case RotaryRollover::signed_direction: return "signed";
    case RotaryRollover::modulo: return "modulo";
  }
  return "?";
}

std::optional<RotaryRollover> rollover_from_name(std::string_view name) {
  for (auto r : {RotaryRollover::off, RotaryRollover::shortest, RotaryRollover::signed_direction, RotaryRollover::modulo})
    if (to_string(r) == name) return r;
  return std::nullopt;
}

double rollover_target(RotaryRollover r, double word, double from) {
  switch (r) {
    case RotaryRollover::off: return word;
    case RotaryRollover::shortest: {
      double d = turn(word) - turn(from);
      if (d > 180.0) d -= 360.0;
      else if (d <= -180.0) d += 360.0;  // exactly half a turn: the positive way
      return from + d;
    }
    case RotaryRollover::signed_direction: {
      double d = turn(std::abs(word)) - turn(from);
      if (std::signbit(word)) {
        if (d > 0) d -= 360.0;
      } else if (d < 0) {
        d += 360.0;
      }
      return from + d;
    }
    case RotaryRollover::modulo: return from + (turn(word) - turn(from));
  }
  return word;
}

std::optional<double> rollover_word(RotaryRollover r, double target, double from, double like) {
  if (r == RotaryRollover::off) return target;
  // Candidates: the target's residue in the turn of `like`, and for the signed rule its mirror
  // with a minus sign (a word −w means "w, the negative way").
  const double base = turn(target);
  const double turns = std::floor(std::abs(like) / 360.0) * 360.0;
  std::optional<double> best;
  const auto consider = [&](double w) {
    if (std::abs(rollover_target(r, w, from) - target) > 1e-9) return;
    if (!best || std::abs(w - like) < std::abs(*best - like)) best = w;
  };
  for (double w : {base + turns, base + turns - 360.0, base + turns + 360.0, base, base - 360.0}) {
    consider(w);
    if (r == RotaryRollover::signed_direction && w != 0) consider(-w);
  }
  return best;
}

// Sinumerik DC / ACP / ACN (rotary_direction.hpp): the same turn arithmetic, one direction per word.

RotaryDirection direction_of(std::string_view value) {
  if (text::starts_with_i(value, "DC(")) return RotaryDirection::shortest;
  if (text::starts_with_i(value, "ACP(")) return RotaryDirection::positive;
  if (text::starts_with_i(value, "ACN(")) return RotaryDirection::negative;
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
