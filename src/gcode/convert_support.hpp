#pragma once
// Shared by the convert passes: a light modal tracker over the G words of each block (the visitor
// does not see the interpreter's state), the diagnostics the reader and interpreter reported for
// the block being visited, and small word helpers.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/gcode/block.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/motion.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {

/// The G code × 10 of a literal G word (G43.4 → 434), or -1 when it is not one.
[[nodiscard]] int g_code10(const Word& w);

/// The span of the literal number of a word: its value for plain literals, the argument of a
/// Siemens AC(…)/IC(…) when that is a literal; nullopt for expressions, parameters and strings.
[[nodiscard]] std::optional<Span> literal_span(const Block& b, const Word& w);

/// Decimals a literal without a point stands for where the dialect reads whole numbers as least
/// input increments (Fanuc standard input, `Dialect::integer_input` not calculator): "X100" is
/// 100 × 0.001 mm = 0.1 mm, so 3 (mm, degrees) or 4 (inch lengths). 0 where it means whole units
/// (a point was written, calculator input, another dialect, or a letter that is not a length or
/// angle).
[[nodiscard]] int implied_decimals(const Dialect& d, const Word& w, std::string_view literal, bool inch);

/// True when the meaning of such a literal depends on a setting nobody stated (integer input
/// unknown): rewriting it would fix a guess into the program.
[[nodiscard]] inline bool ambiguous_integer(const Dialect& d, int implied) {
  return implied > 0 && d.integer_input == Dialect::IntegerInput::unknown;
}

/// True for words written with a plain single-letter address (X, not CR or A3).
[[nodiscard]] inline bool plain_letter(const Word& w) { return w.name_len == 1 && w.index == 0; }

/// Modal state as far as convert needs it, updated from each block's G words (the state in force
/// for the block's own words, as the interpreter applies units, feed mode and distance first).
struct ModalTrack {
  explicit ModalTrack(const Dialect& d)
      : dialect(&d), diameter(d.diameter_axis != 0), motion(d.power_on_motion), interp_motion(d.power_on_motion),
        motion_code10(d.power_on_motion == GMeaning::linear ? 10 : 0), interp_code10(motion_code10) {
    inch = feed_inch = d.basic_inch;
  }
  void update(const Block& b);

  /// The block's G codes (valid after update()).
  struct G {
    const GCodeDef* def = nullptr;
    std::size_t word = 0;
    [[nodiscard]] bool operator==(const G&) const = default;
  };
  std::vector<G> block_g;
  [[nodiscard]] const G* find(GMeaning m) const;
  [[nodiscard]] bool has(GMeaning m) const { return find(m) != nullptr; }
  [[nodiscard]] const G* block_motion() const;
  /// A non-modal G code of the block that takes the axis words as data (G4, G10, G52, G92, G28, …).
  [[nodiscard]] const G* axis_consumer() const;
  /// True when the word is an axis position written incrementally (G91, lathe U/W/H, IC()).
  [[nodiscard]] bool incremental(const Word& w) const;
  /// Axis index of a word (lathe U/W/H map to X/Z/C), -1 if not an axis word.
  [[nodiscard]] int axis_of(const Word& w) const;

  const Dialect* dialect;
  bool inch = false;       ///< geometry in inches (G20, G70, G700)
  bool feed_inch = false;  ///< feeds in inches (Siemens: only G700; G70 keeps the basic system)
  FeedMode feed_mode = FeedMode::per_minute;
  bool absolute = true;
  bool arc_absolute = false;  ///< LinuxCNC G90.1: I J K are absolute centre coordinates
  bool diameter = false;      ///< X is written as a diameter (lathes, G7, DIAMON)
  Plane plane = Plane::xy;
  GMeaning motion = GMeaning::cancel_motion;
  GMeaning interp_motion = GMeaning::cancel_motion;  ///< last G00–G03 (Fanuc: what G80 returns to)
  std::uint16_t motion_code10 = 0;
  std::uint16_t interp_code10 = 0;
  bool css = false;         ///< G96: S is a surface speed (m/min or ft/min)
  bool tcp_vector = false;  ///< Fanuc G43.5: I J K are a tool direction
  bool polar_command = false;  ///< Fanuc G16: X/Y are radius/angle
  bool units_in_block = false;  ///< the block has a units word
  bool axis_words_data = false;  ///< Klartext: the block's axis words are data (CC, cycle 7, BLK FORM), not a move
  [[nodiscard]] bool operator==(const ModalTrack&) const = default;
};

/// One diagnostic of the block being visited (reported by the lexer or interpreter).
struct BlockDiag {
  std::string code;
  Severity severity = Severity::note;
  std::uint32_t column = 1;
  std::uint32_t length = 1;
};
using BlockDiags = std::vector<BlockDiag>;

/// Span of a diagnostic in its block.
[[nodiscard]] inline Span span_of(const BlockDiag& d) { return {d.column - 1, d.column - 1 + d.length}; }

}  // namespace postproc::gcode
