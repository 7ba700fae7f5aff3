// Block edits: splice new text into a block's raw bytes, copying everything else.
#include "postproc/gcode/block_writer.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "postproc/error.hpp"

namespace postproc::gcode {
namespace {
constexpr bool is_blank(char c) { return c == ' ' || c == '\t'; }
}  // namespace

std::string_view to_string(EditRefusal r) {
  switch (r) {
    case EditRefusal::no_such_word: return "no such word";
    case EditRefusal::not_a_literal: return "the value is an expression, parameter or string, not a literal";
  }
  return "?";
}

std::optional<EditRefusal> BlockEditor::replace_word_value(std::size_t word_index, double v, int min_decimals) {
  if (word_index >= b_->words.size()) return EditRefusal::no_such_word;
  const Word& w = b_->words[word_index];
  return replace_word_value(word_index, v, detect_style(b_->text(w.value)), min_decimals);
}

std::optional<EditRefusal> BlockEditor::replace_word_value(std::size_t word_index, double v,
                                                           const NumberStyle& style, int min_decimals) {
  if (word_index >= b_->words.size()) return EditRefusal::no_such_word;
  const Word& w = b_->words[word_index];
  if (w.kind != ValueKind::number) return EditRefusal::not_a_literal;
  replace(w.value, format_number(v, style, min_decimals, point_required_));
  return std::nullopt;
}

void BlockEditor::remove_word(std::size_t word_index) {
  if (word_index >= b_->words.size()) return;
  Span s = b_->words[word_index].span;
  const std::string_view raw = b_->raw;
  std::uint32_t before = s.begin;
  while (before > 0 && is_blank(raw[before - 1])) --before;
  // The blank that separated it from the previous item goes with it. The first item of a line
  // goes alone, so removing two neighbouring words never makes overlapping edits.
  if (before > 0) s.begin = before;
  remove(s);
}

void BlockEditor::render(std::string& out) { render_edits(b_->raw, edits_, out); }

void render_edits(std::string_view raw, std::vector<Edit>& edits, std::string& out) {
  // Insertions (empty spans) sort before a replacement starting at the same byte.
  std::stable_sort(edits.begin(), edits.end(), [](const Edit& a, const Edit& b) {
    return a.span.begin != b.span.begin ? a.span.begin < b.span.begin : a.span.end < b.span.end;
  });
  std::uint32_t at = 0;
  for (const Edit& e : edits) {
    if (e.span.begin < at || e.span.end < e.span.begin || e.span.end > raw.size())
      throw Error(ExitCode::internal,
                  fmt::format("internal error: overlapping or out-of-range block edits at bytes [{}, {}) of '{}'",
                              e.span.begin, e.span.end, raw));
    out.append(raw.substr(at, e.span.begin - at));
    out.append(e.text);
    at = e.span.end;
  }
  out.append(raw.substr(at));
}

}  // namespace postproc::gcode
