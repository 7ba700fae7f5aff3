#pragma once
// Sinumerik's absolute positions of a modulo rotary axis with a direction (840D sl Programming
// Manual Fundamentals, "Absolute dimensions for rotary axes (DC, ACP, ACN)"): C=DC(w) the shortest
// way to w, C=ACP(w) the positive way, C=ACN(w) the negative way; w is a position within the turn,
// 0 ≤ w < 360°. The axis must be a modulo axis ([axes.C] rollover "modulo" or "shortest").
#include <optional>
#include <string_view>

namespace postproc::gcode {

enum class RotaryDirection : unsigned char { none, shortest, positive, negative };

/// The direction function that wraps an axis value's text ("DC(…)", "ACP(…)", "ACN(…)", any case),
/// or none.
[[nodiscard]] RotaryDirection direction_of(std::string_view value);

/// "DC", "ACP", "ACN" ("" for none).
[[nodiscard]] std::string_view function_name(RotaryDirection d);

/// Where the axis ends (continuous degrees) when it stands at `from` and the word says `word`
/// (0 ≤ word < 360) with direction d: DC the shorter way (exactly half a turn: the positive way),
/// ACP forward by (word − from) mod 360, ACN backward by (from − word) mod 360; no motion when the
/// word is where the axis stands.
[[nodiscard]] double directed_target(RotaryDirection d, double word, double from);

/// The word (0 ≤ w < 360) that takes the axis from `from` to `target` under d, or nullopt when
/// none does (DC: more than half a turn; ACP: a negative move; ACN: a positive one; any: a full
/// turn or more).
[[nodiscard]] std::optional<double> directed_word(RotaryDirection d, double target, double from);

}  // namespace postproc::gcode
