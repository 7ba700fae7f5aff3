#pragma once
/// @file
/// Edits of one lexed block, applied to its raw text: everything not edited is copied byte for
/// byte, so a changed block keeps its spacing, case and comments.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/gcode/block.hpp"
#include "postproc/gcode/number_style.hpp"

namespace postproc::gcode {

/// Why a word's value cannot be replaced.
enum class EditRefusal : std::uint8_t {
  no_such_word,   ///< the index is not a word of the block
  not_a_literal,  ///< the value is an expression, parameter or string (ValueKind != number)
};

[[nodiscard]] std::string_view to_string(EditRefusal r);

/// A replacement of the bytes in `span` (of Block::raw) by `text`; an empty span inserts.
struct Edit {
  Span span;
  std::string text;
};

/// Collects edits of one block and renders the edited line. The block must outlive the editor.
/// Edits must not overlap (an insertion at the boundary of a replacement is fine); overlapping
/// edits are a bug of the caller and make render() throw postproc::Error (internal).
class BlockEditor {
 public:
  /// `decimal_point_required`: the dialect reads whole numbers without a point as increments
  /// (Fanuc), so rewritten whole values get a point.
  explicit BlockEditor(const Block& b, bool decimal_point_required = false)
      : b_(&b), point_required_(decimal_point_required) {}

  /// Replaces the value of word `word_index` by `v` (program units) in the word's own number style
  /// with at least `min_decimals` decimals; letter, '=', neighbours stay. Refused for words whose
  /// value is not a plain literal.
  std::optional<EditRefusal> replace_word_value(std::size_t word_index, double v, int min_decimals);
  /// As above with an explicit style (e.g. the source style with trailing_zeros forced).
  std::optional<EditRefusal> replace_word_value(std::size_t word_index, double v, const NumberStyle& style,
                                                int min_decimals);
  /// Replaces the bytes of `s` by `text`.
  void replace(Span s, std::string text) { edits_.push_back({s, std::move(text)}); }
  /// Removes the bytes of `s`.
  void remove(Span s) { edits_.push_back({s, {}}); }
  /// Removes word `word_index` together with the blanks that separated it from the word before
  /// (the first item of a line goes alone, leaving the blank after it).
  void remove_word(std::size_t word_index);
  /// Inserts `text` right after `s` (at s.end). Insertions at one place keep their call order.
  void insert_after(Span s, std::string text) { edits_.push_back({{s.end, s.end}, std::move(text)}); }
  /// Inserts `text` right before `s` (at s.begin).
  void insert_before(Span s, std::string text) { edits_.push_back({{s.begin, s.begin}, std::move(text)}); }

  [[nodiscard]] bool empty() const { return edits_.empty(); }
  [[nodiscard]] const Block& block() const { return *b_; }
  void clear() { edits_.clear(); }

  /// Appends the raw text with all edits applied to `out` (no end-of-line).
  void render(std::string& out);

 private:
  const Block* b_;
  bool point_required_;
  std::vector<Edit> edits_;
};

/// Applies `edits` to `raw`, appending to `out`. Sorts them by position (stable, so insertions at
/// one place keep their order); throws postproc::Error (internal) when two edits overlap.
void render_edits(std::string_view raw, std::vector<Edit>& edits, std::string& out);

}  // namespace postproc::gcode
