#pragma once
// Heidenhain conversational (Klartext) programs (issue 22): the block form and the interpreter
// behind the `heidenhain` dialect. The lexer turns one line into a Block whose first token is the
// block's verb (L, CC, C, CR, CT, LP, CP, LN, TOOL, CYCL, PLANE, …); its address words (X+10,
// IX-5, PR+30, F500, M3) are Words, so writers edit them like any other dialect's words. The
// interpreter turns blocks into the same Motion records as the ISO dialects.
//
// Rules followed and where they come from are listed in docs/dialect-heidenhain.md.

#include <optional>
#include <string>
#include <string_view>

#include "postproc/gcode/interpreter.hpp"
#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/gcode/program.hpp"

namespace postproc::gcode::klartext {

/// What a Klartext block is, read off its first word(s).
enum class Verb : std::uint8_t {
  none,         ///< empty line (block number only)
  comment,      ///< `; …` or `* - …`
  begin_pgm, end_pgm, blk_form, tool_call, tool_def,
  l, ln, lp, c, cc, cr, ct, cp, rnd, chf, appr, dep,
  cycl_def, cycl_call, call_lbl, call_pgm, lbl, fn, q_assign, plane, function,
  m_only,       ///< a block of M functions only (`M3`, `M30`)
  stop, tch_probe, pattern_def, sel, declare,
  other,        ///< a verb this version does not know
};

/// The verb of a lexed Klartext block (the lexer stores it as the first keyword token).
[[nodiscard]] Verb verb_of(const Block& b);
[[nodiscard]] std::string_view to_string(Verb v);

/// True for an indented line the lexer could not read as a Klartext block and did not report: the
/// rest of a block continued with '~', or else an error the interpreter reports (PP-E101).
[[nodiscard]] bool unread_text(const Block& b);

/// True when the line continues on the next one: its text ends with '~' (after a comment too:
/// "Q200=+2 ;SET-UP CLEARANCE ~").
[[nodiscard]] bool continued(std::string_view raw);

/// Lexes `block.raw` as Klartext; see lex_block.
bool lex(const Dialect& d, Block& block, const LexContext& ctx);

/// A Klartext number: optional sign, digits with '.' or ',' as the decimal separator.
[[nodiscard]] bool parse_number(std::string_view text, double& out);

/// Index of the keyword token named `name` (case-insensitive) after the verb, -1 when none.
[[nodiscard]] int find_keyword(const Block& b, std::string_view name);
/// The text of token `i`'s name (for numbers: the number).
[[nodiscard]] std::string_view token_text(const Block& b, int i);

/// The rounding (RND, `rounding`, radius `size`) or chamfer (CHF, length `size`) between the
/// straight moves `a` and `c`: shortens both (their words then no longer name their ends:
/// words_transformed) and returns the element; nullopt with the reason when the control's rule
/// cannot be followed here (arcs next to it, moves out of the plane, an element too large).
[[nodiscard]] std::optional<Motion> corner_element(Motion& a, Motion& c, bool rounding, double size, std::string& why);

/// Runs a whole Klartext program (streaming), the counterpart of run_program for the `heidenhain`
/// dialect.
ProgramStats run(LineReader& reader, const Dialect& d, std::string_view file, DiagnosticSink& sink,
                 BlockVisitor& visitor);

}  // namespace postproc::gcode::klartext
