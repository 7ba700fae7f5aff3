#pragma once
/// @file
/// Absolute positioning of rotary axes whose position rolls over at a full turn: where the
/// controller moves for an absolute word, and which word reaches a given position. A machine
/// setting per rotary axis (`[axes.C] rollover`, docs/machine-file.md); positions are continuous
/// (unwrapped) degrees, so the path between two blocks is the controller's.

#include <cstdint>
#include <optional>
#include <string_view>

namespace postproc::gcode {

enum class RotaryRollover : std::uint8_t {
  /// No roll-over: the word is the position (Fanuc 1008#0 ROA = 0, a Sinumerik axis that is not a
  /// modulo axis, LinuxCNC without WRAPPED_ROTARY). The factory setting.
  off,
  /// The word modulo 360° is the target, reached by the shorter way; half a turn goes positive
  /// (Fanuc ROA = 1 with 1008#1 RAB = 0, B-63534EN §20.2.1; Sinumerik modulo axis with MD30455 bit 2 = 1).
  shortest,
  /// |word| modulo 360° is the target, the sign the direction (less than one turn; no move when
  /// already there): Fanuc ROA = 1 with RAB = 1, LinuxCNC [AXIS_n] WRAPPED_ROTARY = 1 (LinuxCNC
  /// refuses |word| ≥ 360).
  signed_direction,
  /// The word modulo 360° is the target, the direction that of target − position modulo 360°
  /// (never across 0°): a Sinumerik 360° modulo axis with MD30455 bit 2 = 0 (G90 as AC).
  modulo,
};

[[nodiscard]] std::string_view to_string(RotaryRollover r);
/// "off", "shortest", "signed", "modulo"; nullopt otherwise.
[[nodiscard]] std::optional<RotaryRollover> rollover_from_name(std::string_view name);

/// The continuous position (degrees) an absolute word `word` moves the axis to from `from`.
[[nodiscard]] double rollover_target(RotaryRollover r, double word, double from);
/// The word that moves the axis from `from` to the continuous position `target` under rule r —
/// among the values that do, the one nearest `like` (the word as the program wrote it) — or
/// nullopt when none does (e.g. a signed move of a full turn or more, a modulo move across 0°).
[[nodiscard]] std::optional<double> rollover_word(RotaryRollover r, double target, double from, double like);

}  // namespace postproc::gcode
