// postproc convert: the passes that rewrite a program block by block (identity, --strip-comments,
// --renumber, --decimals/--units, --linearize) and the second pass that re-reads converted text.
#include "postproc/gcode/convert.hpp"
#include "postproc/gcode/detect.hpp"

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "postproc/gcode/block_writer.hpp"
#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/program.hpp"
#include "src/gcode/convert_support.hpp"
#include "src/gcode/convert_units.hpp"
#include "src/gcode/linearize.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode {
namespace {
using text::is_space;


/// LinuxCNC comments that act (operator message, debug/print output, probe and log files): kept by
/// --strip-comments like Siemens MSG().
bool active_comment(std::string_view body) {
  while (!body.empty() && is_space(body.front())) body.remove_prefix(1);
  constexpr std::string_view kActive[] = {"MSG,", "DEBUG,", "PRINT,", "PROBEOPEN", "PROBECLOSE",
                                          "LOGOPEN", "LOGAPPEND", "LOGCLOSE", "LOG,"};
  for (std::string_view k : kActive)
    if (text::starts_with_i(body, k)) return true;
  return false;
}

/// Where a pass writes: the output file, or a buffer the next pass reads.
using Writer = std::function<void(std::string_view)>;

/// Forwards diagnostics to the caller's sink; a later pass remaps lines to the input's.
struct Forward {
  DiagnosticSink& to;
  const std::vector<std::uint64_t>* line_map = nullptr;  ///< pass output line → input line (1-based)
  bool later_pass = false;
  bool units = false;  ///< --units ran in the earlier pass
  void operator()(const Diagnostic& d) const {
    // A later pass re-reads the earlier pass's output: the interpreter's warnings and notes were
    // reported already; only refusals (its own, or errors the conversion caused) are new.
    if (later_pass && d.severity != Severity::error) return;
    Diagnostic c = d;
    if (line_map != nullptr && c.where.line >= 1 && c.where.line <= line_map->size())
      c.where.line = (*line_map)[c.where.line - 1];
    if (later_pass && c.code != codes::kLinearizeRefused) {
      // The converted text no longer reads: the conversion is refused, naming why.
      c.message = fmt::format("{}the converted block would be refused ({}: {})", units ? "--units refused: " : "",
                              c.code, c.message);
      if (units) c.code = std::string(codes::kUnitsRefused);
    }
    to.report(std::move(c));
  }
};

class Pass final : public BlockVisitor {
 public:
  Pass(std::string_view file, const Dialect& d, const ConvertOptions& opt, Writer write, Forward fwd,
       ConvertResult& result)
      : file_(file), d_(d), opt_(opt), identity_(opt.identity()), write_(std::move(write)), collect_(0), own_(0),
        r_(result) {
    collect_.on_report = [this, fwd](const Diagnostic& diag) {
      diags_.push_back({diag.code, diag.severity, diag.where.column, diag.length});
      fwd(diag);
    };
    own_.on_report = fwd;
    if (opt_.units || opt_.any_min_decimals())
      units_ = std::make_unique<UnitsPass>(d_, opt_, file_, own_, r_);
    if (opt_.linearize_tolerance_mm)
      lin_ = std::make_unique<Linearizer>(d_, *opt_.linearize_tolerance_mm, file_, own_, r_);
    next_n_ = opt_.renumber_start.value_or(0);
  }

  DiagnosticSink& collector() { return collect_; }
  std::vector<std::uint64_t>* line_map = nullptr;   ///< records each output line's input line
  std::vector<bool>* line_changed = nullptr;        ///< … and whether it differs from it
  const std::vector<std::uint64_t>* in_map = nullptr;     ///< this pass's input line → program line
  const std::vector<bool>* in_changed = nullptr;

  void block(const Block& b, std::span<const Motion> motions, bool) override {
    ++r_.blocks;
    const std::uint64_t src = in_map && b.line <= in_map->size() ? (*in_map)[b.line - 1] : b.line;
    const bool was_changed = in_changed && b.line <= in_changed->size() && (*in_changed)[b.line - 1];
    if (!b.eol.empty() && eol_ != b.eol) eol_ = b.eol;
    if (identity_) {
      emit(b.raw, b.eol, src, was_changed);
      diags_.clear();
      return;
    }
    BlockEditor ed(b, d_.decimal_point_required);
    before_.clear();
    after_.clear();
    const bool had_content = !b.empty() || b.block_delete;
    if (units_) units_->block(b, diags_, ed, before_);
    if (lin_) lin_->block(b, motions, diags_, ed, after_);
    if (opt_.strip_comments) strip_comments(b, ed);
    if (opt_.renumber_start) renumber(b, ed);
    diags_.clear();
    const std::string fallback_eol(b.eol.empty() ? eol_ : b.eol);
    for (const std::string& l : before_) {
      emit(l, fallback_eol, src, true);
      ++r_.inserted_lines;
    }
    const std::string_view eol = after_.empty() ? b.eol : std::string_view(fallback_eol);
    if (ed.empty()) {
      emit(b.raw, eol, src, was_changed);
    } else {
      line_.clear();
      ed.render(line_);
      // Trailing whitespace left by a removed comment goes too; a line that held only comments goes.
      if (opt_.strip_comments || opt_.renumber_start)
        while (!line_.empty() && is_space(line_.back())) line_.pop_back();
      if (had_content && line_.empty()) {
        ++r_.removed_blocks;
      } else {
        const bool changed = line_ != b.raw;
        if (changed && !was_changed) ++r_.changed_blocks;
        if (const auto too_long = changed ? line_too_long(d_, line_, eol) : std::nullopt)
          report_at(LexContext{file_, &own_}, b, {0, static_cast<std::uint32_t>(std::max<std::size_t>(b.raw.size(), 1))},
                    Severity::error, codes::kConvertedLineTooLong,
                    fmt::format("the converted line would be longer than the controller reads ({}): shorten the "
                                "line's comment or put it on a line of its own",
                                *too_long));
        emit(line_, eol, src, changed || was_changed);
      }
    }
    for (std::size_t i = 0; i < after_.size(); ++i) {
      emit(after_[i], i + 1 == after_.size() ? b.eol : std::string_view(fallback_eol), src, true);
      ++r_.inserted_lines;
    }
  }

  void flush() {
    write_(buffer_);
    buffer_.clear();
  }

 private:
  void emit(std::string_view raw, std::string_view eol, std::uint64_t src, bool changed) {
    buffer_.append(raw);
    buffer_.append(eol);
    if (line_map) line_map->push_back(src);
    if (line_changed) line_changed->push_back(changed);
    if (buffer_.size() > (1u << 20)) flush();
  }

  void strip_comments(const Block& b, BlockEditor& ed) {
    for (const Token& t : b.tokens) {
      if (t.kind != TokenKind::paren_comment && t.kind != TokenKind::line_comment) continue;
      if (t.kind == TokenKind::paren_comment && d_.id == DialectId::linuxcnc && active_comment(b.text(t.name)))
        continue;
      Span s = t.span;
      while (s.begin > 0 && is_space(b.raw[s.begin - 1])) --s.begin;  // the separating blank goes too
      ed.remove(s);
    }
  }

  void renumber(const Block& b, BlockEditor& ed) {
    if (d_.id == DialectId::heidenhain) {
      renumber_klartext(b, ed);
      return;
    }
    for (const Token& t : b.tokens) {
      // Jumps name sequence numbers; renumbering would retarget them.
      if (t.kind == TokenKind::control_flow || t.kind == TokenKind::label) {
        refuse(b, t.span, "the program jumps to sequence numbers or labels (GOTO/IF/WHILE/M99 P); renumbering "
                          "would change where it jumps");
        return;
      }
    }
    for (const Word& w : b.words) {
      // M99 P n returns to sequence n; lathe G70–G73 P Q name the contour's first and last block
      // (on mills G73 is peck drilling, whose P and Q are dwell and depth).
      const int g = g_code10(w);
      const GCodeDef* def = g >= 0 ? d_.find_g(static_cast<std::uint16_t>(g)) : nullptr;
      const bool m99p = w.letter == 'M' && w.kind == ValueKind::number && w.number == 99 && has_letter(b, 'P');
      const bool contour = def != nullptr && def->meaning == GMeaning::turning_cycle && g >= 700 && g <= 730 &&
                           has_letter(b, 'P') && has_letter(b, 'Q');
      if (m99p || contour) {
        refuse(b, w.span, "the block refers to sequence numbers (M99 P / G70–G73 P Q); renumbering would change "
                          "their targets");
        return;
      }
    }
    if (!b.has_n) return;
    const Span digits{b.n_span.begin + 1, b.n_span.end};
    const std::string_view old = b.text(digits);
    std::string num = fmt::format("{}", next_n_);
    // Keep the source's zero padding (N0010 stays four digits wide).
    if (!old.empty() && old[0] == '0' && num.size() < old.size()) num.insert(0, old.size() - num.size(), '0');
    ed.replace(digits, std::move(num));
    next_n_ += opt_.renumber_step;
  }

  /// Klartext: every block carries its number (the number is the whole leading integer, no N);
  /// a block without one (a line postproc inserted, a comment) gets the next number. Jumps go to
  /// labels (LBL), never to block numbers, so nothing refers to the numbers.
  void renumber_klartext(const Block& b, BlockEditor& ed) {
    // A line after one that ends in '~' continues that block (cycle parameters): no number.
    std::size_t last = b.raw.find_last_not_of(" \t\r");
    if (last == std::string_view::npos) return;  // a blank line is no block
    const bool continuation = continued_;
    continued_ = b.raw[last] == '~';
    if (continuation) return;
    std::string num = fmt::format("{}", next_n_);
    if (b.has_n) {
      ed.replace(b.n_span, std::move(num));
    } else {
      std::size_t first = 0;
      while (first < b.raw.size() && (b.raw[first] == ' ' || b.raw[first] == '\t')) ++first;
      ed.insert_before(Span{static_cast<std::uint32_t>(first), static_cast<std::uint32_t>(first)}, num + " ");
    }
    next_n_ += opt_.renumber_step;
  }

  bool continued_ = false;  ///< Klartext: the line before ended in '~'

  static bool has_letter(const Block& b, char L) {
    for (const Word& w : b.words)
      if (w.letter == L) return true;
    return false;
  }

  void refuse(const Block& b, Span s, std::string why) {
    report_at(LexContext{file_, &own_}, b, s, Severity::error, codes::kRenumberRefused, fmt::format("--renumber refused: {}", why));
  }

  std::string_view file_;
  const Dialect& d_;
  const ConvertOptions& opt_;
  const bool identity_;  ///< decided once: the per-block path must stay a plain copy
  Writer write_;
  DiagnosticSink collect_;  ///< given to the reader and interpreter: records the block's diagnostics
  DiagnosticSink own_;      ///< convert's own refusals
  ConvertResult& r_;
  BlockDiags diags_;
  std::unique_ptr<UnitsPass> units_;
  std::unique_ptr<Linearizer> lin_;
  std::vector<std::string> before_, after_;
  std::string line_, buffer_;
  std::string eol_ = "\n";  ///< the file's EOL, for new lines
  std::uint64_t next_n_ = 0;
};

}  // namespace

ConvertResult convert(LineReader& in, std::string_view file, const Dialect& given, const ConvertOptions& opt,
                      io::OutputFile& out, DiagnosticSink& sink) {
  // The writer and the interpreter must read the program in the same G-code system.
  const Dialect dialect = given.gcode_system == '?' ? settle_gcode_system(given, in, file, sink) : given;
  ConvertResult result;
  const Writer to_file = [&out](std::string_view s) { out.write(s); };
  ConvertOptions first = opt;
  first.linearize_tolerance_mm.reset();
  // Converted values are re-read before anything is written (an arc rounded into new units may no
  // longer close); linearising runs on the other options' result, so that the chords are computed
  // in the output's units and decimals.
  const bool second_pass = opt.units || (opt.linearize_tolerance_mm && !first.identity());
  if (!second_pass) {
    Pass pass(file, dialect, opt, to_file, Forward{sink}, result);
    pass.line_map = opt.line_map;
    const ProgramStats st = run_program(in, dialect, file, pass.collector(), pass);
    pass.flush();
    result.bytes_in = st.bytes;
    return result;
  }
  std::string buffer;
  std::vector<std::uint64_t> line_map;
  std::vector<bool> line_changed;
  {
    Pass pass(file, dialect, first, [&buffer](std::string_view s) { buffer.append(s); }, Forward{sink}, result);
    pass.line_map = &line_map;
    pass.line_changed = &line_changed;
    const ProgramStats st = run_program(in, dialect, file, pass.collector(), pass);
    pass.flush();
    result.bytes_in = st.bytes;
  }
  if (sink.has_errors()) return result;
  ConvertOptions second;
  second.linearize_tolerance_mm = opt.linearize_tolerance_mm;
  ConvertResult lin;
  Pass pass(file, dialect, second, to_file, Forward{sink, &line_map, true, opt.units.has_value()}, lin);
  pass.in_map = &line_map;
  pass.in_changed = &line_changed;
  pass.line_map = opt.line_map;
  LineReader again{std::string_view(buffer)};
  InterpreterOptions again_opt;
  again_opt.source_text = false;  // the first pass's output: its source was checked
  run_program(again, dialect, file, pass.collector(), pass, again_opt);
  pass.flush();
  result.changed_blocks += lin.changed_blocks;
  result.inserted_lines += lin.inserted_lines;
  result.arcs_linearized = lin.arcs_linearized;
  result.segments = lin.segments;
  return result;
}

}  // namespace postproc::gcode
