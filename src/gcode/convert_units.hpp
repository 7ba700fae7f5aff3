#pragma once
// convert --units and --decimals: unit words, length and feed words of each block.
#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/gcode/block_writer.hpp"
#include "postproc/gcode/convert.hpp"
#include "src/gcode/convert_support.hpp"

namespace postproc::gcode {

/// Decimals written for a converted length or feed: mm→inch one more than the source had (at
/// least 4), inch→mm one fewer (at least 3). The printed value is then within half its last digit.
[[nodiscard]] int converted_decimals(int source_decimals, bool to_inch);

/// The unit word convert writes for `inch` in dialect `d` (Sinumerik G700/G710, which also set
/// the feed units; Heidenhain G70/G71; others G20/G21).
[[nodiscard]] std::string_view unit_word(const Dialect& d, bool inch);

/// Per-block rewriting for --units and --decimals. Keeps its own modal state: feed one block at
/// a time, in order.
class UnitsPass {
 public:
  UnitsPass(const Dialect& d, const ConvertOptions& opt, std::string_view file, DiagnosticSink& sink,
            ConvertResult& result);
  /// Adds the block's edits to `ed`; lines to insert before the block go to `before` (no EOL).
  /// Refusals are reported to the sink (PP-E502).
  void block(const Block& b, const BlockDiags& diags, BlockEditor& ed, std::vector<std::string>& before);

 private:
  enum class Scale : std::uint8_t { none, to_inch, to_mm };
  enum class Class : std::uint8_t { none, length, feed, unknown };
  [[nodiscard]] Class classify(const Block& b, const Word& w) const;
  [[nodiscard]] static Scale scale(bool from_inch, bool to_inch);
  void unit_words(const Block& b, BlockEditor& ed);
  void check_constructs(const Block& b, const BlockDiags& diags);
  void scale_word(const Block& b, const Word& w, Class c, Scale s, BlockEditor& ed);
  void pad_word(const Block& b, const Word& w, BlockEditor& ed);
  void refuse(const Block& b, Span at, const std::string& why);

  const Dialect& d_;
  const ConvertOptions& opt_;
  std::string_view file_;
  DiagnosticSink& sink_;
  ConvertResult& r_;
  ModalTrack track_;
  bool out_inch_ = false;       ///< units of the output at this block (controls start in mm)
  bool out_feed_inch_ = false;
  bool seen_address_ = false;   ///< a block with an address word was seen
  /// Printed minus exact position per axis (output units), so that incremental words do not add
  /// up their rounding errors: each is written to bring the printed sum nearest the exact one.
  std::array<double, kAxisCount> carry_{};
  std::array<double, kAxisCount> start_carry_{};  ///< carry_ at the start of the block (arc start point)
};

}  // namespace postproc::gcode
