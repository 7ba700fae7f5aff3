// Roll-over positioning of rotary axes (see rotary_rollover.hpp).
#include "postproc/gcode/rotary_rollover.hpp"

#include <cmath>

namespace postproc::gcode {
namespace {

/// x modulo 360 in [0, 360).
double turn(double x) {
  const double r = std::fmod(x, 360.0);
  return r < 0 ? r + 360.0 : (r >= 360.0 ? 0.0 : r);
}

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

}  // namespace postproc::gcode
