#pragma once
/// @file
/// One block (line) of an NC program, kept losslessly: the raw bytes plus the byte span of every
/// word, comment, expression and statement. Nothing is normalised; the writer splices new text into
/// spans and copies everything else.

#include <cstdint>
#include <string_view>
#include <vector>

#include "postproc/gcode/diagnostic.hpp"

namespace postproc::gcode {

/// How a word's value is written.
enum class ValueKind : std::uint8_t {
  number,      ///< a literal number: X-12.5
  expression,  ///< [ ... ] expression, or Siemens NAME=expr / X=expr
  parameter,   ///< #123, #<name>, R12 as a value
  absolute_fn, ///< Siemens X=AC(...)
  incremental_fn, ///< Siemens X=IC(...)
  string,      ///< T="name"
};

/// An address word: a letter (or a Siemens extended address such as A3, CR, R12) and a value.
struct Word {
  Span span;            ///< the whole word, letter to end of value
  Span name;            ///< the address, e.g. "X", "G", "A3", "CR"
  Span value;           ///< the value text (a number, an expression, …)
  ValueKind kind = ValueKind::number;
  char letter = 0;      ///< upper-cased first letter of the address
  std::uint8_t name_len = 1;  ///< 1 for plain letter addresses
  std::uint8_t index = 0;     ///< extended address digits (A3 → 3), 0 when none
  bool has_equals = false;    ///< written with '=' (Siemens X=10, A3=0.5)
  bool whole = false;         ///< a literal number written without a decimal point (X100)
  double number = 0.0;  ///< parsed value when kind == number
};

enum class TokenKind : std::uint8_t {
  paren_comment,   ///< ( ... )
  line_comment,    ///< ; ... to end of line
  percent,         ///< % program start/end marker (and what follows it on the line, e.g. %_N_X_MPF)
  program_number,  ///< O1234 / :0100 / LinuxCNC o-word is control_flow instead
  assignment,      ///< #1=..., #<x>=..., R1=..., NAME=... (Siemens)
  control_flow,    ///< IF/GOTO/WHILE/DO/END, LinuxCNC o-words, Siemens GOTOF/FOR/LOOP/…
  keyword,         ///< Siemens TRAORI, SUPA, MCALL, DIAMON, … (no arguments)
  call,            ///< Siemens NAME(args): CYCLE800(...), MSG(...), TRAORI(1)
  declaration,     ///< Siemens DEF ..., PROC ...
  label,           ///< Siemens LABEL:
  block_end,       ///< Heidenhain `*`
};

/// Anything in a block that is not an address word.
struct Token {
  Span span;
  TokenKind kind = TokenKind::paren_comment;
  Span name;  ///< keyword/call name, program-number digits, or assigned-to name
};

/// A lexed block. `raw` points into the reader's buffer: valid until the next block is read.
struct Block {
  std::string_view raw;  ///< bytes of the line without its end-of-line
  std::string_view eol;  ///< "\n", "\r\n", "\r" or "" (last line without newline)
  std::uint64_t line = 0;  ///< 1-based
  bool leader = false;          ///< Fanuc tape leader: text before the first '%', ignored by the control
  bool block_delete = false;    ///< starts with '/'
  std::uint8_t block_delete_level = 0;  ///< /2 → 2 (0 for plain '/')
  Span block_delete_span;
  bool has_n = false;
  Span n_span;                  ///< N word (sequence number)
  double n_number = 0;
  std::vector<Word> words;      ///< address words in source order (N excluded)
  std::vector<Token> tokens;    ///< comments and statements in source order

  void clear() {
    raw = {}; eol = {}; line = 0; leader = false; block_delete = false; block_delete_level = 0; block_delete_span = {};
    has_n = false; n_span = {}; n_number = 0; words.clear(); tokens.clear();
  }
  [[nodiscard]] std::string_view text(Span s) const { return s.of(raw); }
  [[nodiscard]] bool empty() const { return words.empty() && tokens.empty() && !has_n; }
};

}  // namespace postproc::gcode
