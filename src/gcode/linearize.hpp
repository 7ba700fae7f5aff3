#pragma once
// convert --linearize: every resolved arc becomes G1 chords whose deviation from the arc, the
// rounding of the printed coordinates included, stays within a tolerance.
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/gcode/block_writer.hpp"
#include "postproc/gcode/convert.hpp"
#include "postproc/gcode/motion.hpp"
#include "src/gcode/convert_support.hpp"

namespace postproc::gcode {

/// Largest displacement of a printed point by rounding its two plane coordinates to `decimals`
/// (√2 · half a digit), in mm; `inch` when the coordinates are printed in inches.
[[nodiscard]] double rounding_mm(int decimals, bool inch);

/// Number of equal angular steps for an arc of `radius_mm` and `sweep_rad` (signed, turns
/// included) so that each chord between exact arc points deviates at most tol_mm - rounding_mm
/// from the arc: n = ceil(|sweep| / (2·acos(1 - (tol - rounding)/r))), at least 1, and steps of at
/// most half a turn. nullopt when tol_mm ≤ rounding_mm.
[[nodiscard]] std::optional<std::uint64_t> arc_segments(double radius_mm, double sweep_rad, double tol_mm,
                                                        double rounding_mm);

/// The point at fraction t ∈ [0, 1] of arc motion `m` (mm / degrees, work coordinates): in the
/// plane the angle and the radius vary linearly from start to end (an I J K arc's end radius may
/// differ slightly), every other axis linearly (helix). t = 0 gives the start, t = 1 the end.
[[nodiscard]] AxisVector arc_point(const Motion& m, double t);

/// Per-block linearisation. Keeps its own modal state: feed one block at a time, in order.
class Linearizer {
 public:
  Linearizer(const Dialect& d, double tol_mm, std::string_view file, DiagnosticSink& sink, ConvertResult& result);
  /// Adds the block's edits to `ed`; new lines to write after the block go to `after` (no EOL).
  /// Refusals are reported to the sink (PP-E503).
  void block(const Block& b, std::span<const Motion> motions, const BlockDiags& diags, BlockEditor& ed,
             std::vector<std::string>& after);

 private:
  /// How one axis is written in the arc's block and its segments.
  struct AxisOut {
    bool on = false;
    int word = -1;          ///< the axis word in the block, -1 if absent
    Span literal;           ///< the number in the source word
    std::string letter;     ///< what precedes the number ("X", "x", "X=", "U", "X=AC(")
    std::string suffix;     ///< what follows it (")" of AC(…), else empty)
    NumberStyle style;
    int decimals = 3;
    int implied = 0;        ///< decimals a point-less Fanuc literal stands for (X100 = 0.100 mm)
    bool incremental = false;
    std::vector<std::int64_t> counts;  ///< printed point k in units of 10^-decimals (increments: from the start)
  };
  bool check(const Block& b, const Motion& m);
  void linearize(const Block& b, const Motion& m, BlockEditor& ed, std::vector<std::string>& after);
  void plan_axes(const Block& b, const Motion& m, std::array<AxisOut, kAxisCount>& ax);
  void refuse(const Block& b, Span at, const std::string& why);
  void note_styles(const Block& b);
  void remember(const Block& b, std::span<const Motion> motions, const BlockDiags& diags);

  const Dialect& d_;
  double tol_;
  std::string_view file_;
  DiagnosticSink& sink_;
  ConvertResult& r_;
  ModalTrack track_;
  std::array<std::optional<NumberStyle>, 26> last_style_;  ///< per letter, last literal seen
  std::string g1_ = "G1";        ///< G1 as the program writes its motion words (G01 when padded)
  AxisMask known_ = 0;           ///< axes whose position was known after the previous block
  int length_decimals_ = 0;      ///< most decimals of a length literal so far (the program's precision)
  int rotary_decimals_ = 0;      ///< … of a rotary axis literal
};

}  // namespace postproc::gcode
