// Resolver for the fanuc dialect (see include/postproc/gcode/resolve.hpp): runs a Fanuc Macro B
// program as the control would and writes the literal program it executes.
//
// Model (Fanuc 0i/30i, default parameters):
// - #0 vacant; #1–#33 locals (one set per G65 level, the main program has its own); #100–#499
//   common, vacant at start (cleared at power-off; --set '#100=…' gives a start value);
//   #500–#999 retained common: a value the program did not assign is what the control kept from
//   earlier runs, so reading it needs --set (PP-E701); #1000 and up are system variables, read
//   only with --set (PP-E701). Writes: #3000 raises an alarm (PP-E710); #3001/#3002 (clocks),
//   #3003/#3004 (single-block / feed-hold suppression) and #3901/#3902 (part counts) are stored
//   and dropped (they do not change motion); any other system variable write is refused (PP-E709).
// - Vacant: 0 in arithmetic and GT/GE/LT/LE; EQ/NE against a vacant value test vacancy; `#2=#1`
//   copies vacancy; a word whose value is a bare vacant variable (`X#1`, `X-#1`, `X[#1]`) is
//   omitted from the block, as the control does.
// - Angles in degrees; ATAN (both forms) in 0…360, ASIN in 270…360 ∪ 0…90, ACOS in 0…180 (NAT=0);
//   ROUND rounds half away from zero, FIX truncates, FUP rounds away from zero; MOD rounds both
//   operands to integers; AND/OR/XOR are bitwise on integers (logical on conditions); ADP returns
//   its argument (G65 argument values are taken as written, not in input increments).
// - G65 arguments: specification I, and specification II for repeated I/J/K (I1 J1 K1 I2 …).
//   G65 … L n repeats the call n times, each with fresh locals from the arguments.
// - G66 P… L… <arguments> (modal call): from the next block on, every block with an axis word
//   calls the macro after its move, with G66's arguments, until G67; moves inside the macro called
//   that way do not call it again. G66.1 (a call after every block) is refused (PP-E709).
// - Subprogram targets: O#### / :#### in the same file, else a file O####, O####.nc or ####.nc (also
//   .tap .txt .cnc .eia .min .ptp .prg, any letter case) in opt.search_dirs. M98 P<repeats 4 digits><program 4 digits> (packed form) is used when P has more
//   than 4 digits, there is no L, and no program with the full number exists.
// - A block delete '/' is taken as switched off: the block runs (PP-W702 when it holds a
//   statement, since the switch could change the flow).
#include "fanuc_runner.hpp"
#include "src/gcode/codes.hpp"
#include "src/gcode/program_end.hpp"

namespace postproc::gcode::resolver {
namespace fanuc_run {
namespace {

/// B-64484EN "Custom macro — Variables: rounding": a variable value used in an address is rounded
/// (half away from zero) to the address's least input increment — 0.001 mm / 0.0001 in for lengths,
/// 0.001 deg for angles (increment system IS-B). Arithmetic keeps the full value; only the address
/// gets the rounded one.
/// Addresses of whole numbers: M S T H D P L (a literal with a decimal point there is an alarm,
/// PS0007); a variable's value used in one is rounded to the nearest whole number, half away from
/// zero (M#1 with #1 = 3.5 is M4; Fanuc custom macro, "real versus integer values").
constexpr bool whole_address(char letter) {
  switch (letter) {
    case 'M': case 'S': case 'T': case 'H': case 'D': case 'P': case 'L': return true;
    default: return false;
  }
}

double round_to_increment(double v, char letter, bool inch) {
  double step = 0;
  switch (letter) {
    case 'X': case 'Y': case 'Z': case 'U': case 'V': case 'W': case 'I': case 'J': case 'K': case 'R':
      step = inch ? 1e4 : 1e3;
      break;
    case 'A': case 'B': case 'C': step = 1e3; break;
    default:
      if (!whole_address(letter)) return v;
      step = 1;
      break;
  }
  if (!std::isfinite(v) || std::fabs(v) > 1e12) return v;
  // 1.2345 is stored as 1.23449999…: nudge by a relative 1e-12 so the decimal half rounds away from zero.
  return std::round(v * step * (1 + 1e-12)) / step;
}

}  // namespace

void Runner::report(Span span, Severity sev, std::string_view code, std::string message) {
  if (out_.depth() > 0) message += fmt::format(" ({})", out_.where());
  file_->report(pc_, span, sev, code, std::move(message));
}

void Runner::fail(const Failure& e) {
  Span s = e.span;
  if (s.end <= s.begin) s.end = s.begin + 1;
  report(s, Severity::error, e.code, e.message);
}

void Runner::emit(SourceFile& f, std::size_t line, std::span<const Edit> edits) {
  if (!out_.emit(f, line, edits)) {
    report({0, static_cast<std::uint32_t>(std::max<std::size_t>(1, f.raw(line).size()))}, Severity::error, "PP-E705",
           fmt::format("the program executes {}: a loop that does not end? Check the loop's condition",
                       runaway_limits(opt_)));
    throw Stop{};
  }
}

std::optional<std::size_t> Runner::program_line(SourceFile& f, double number) {
  auto& idx = programs_[f.index()];
  if (!idx) {
    idx = std::make_unique<std::unordered_map<std::uint64_t, std::size_t>>();
    for (std::size_t i = 0; i < f.lines(); ++i) {
      const std::string_view l = f.raw(i);
      std::size_t q = l.find_first_not_of(" \t");
      if (q == std::string_view::npos) continue;
      if (l[q] == '%') q = l.find_first_not_of(" \t", q + 1);
      if (q == std::string_view::npos || q + 1 >= l.size()) continue;
      if (!((l[q] == 'O' || l[q] == 'o' || l[q] == ':') && is_digit(l[q + 1]))) continue;
      std::uint64_t n = 0;
      for (std::size_t j = q + 1; j < l.size() && is_digit(l[j]); ++j) n = n * 10 + static_cast<std::uint64_t>(l[j] - '0');
      idx->emplace(n, i);
    }
  }
  if (number < 0) return std::nullopt;
  auto it = idx->find(saturate<std::uint64_t>(number));
  if (it == idx->end()) return std::nullopt;
  return it->second;
}

std::optional<Runner::Target> Runner::find_program(double number) {
  if (auto l = program_line(*file_, number)) return Target{file_, *l};
  if (file_ != &files_.main())
    if (auto l = program_line(files_.main(), number)) return Target{&files_.main(), *l};
  const auto n = saturate<std::uint64_t>(number);
  std::vector<std::string> names;
  // O5001, O5001.nc, 5001.nc, … in any letter case (FileSet::find compares case-insensitively): the
  // names a program is stored under when it is punched out of or loaded into the control's memory.
  for (const std::string& base : {fmt::format("O{:04d}", n), fmt::format("O{}", n), fmt::format("{:04d}", n),
                                  fmt::format("{}", n)})
    for (const char* ext : {"", ".nc", ".tap", ".txt", ".cnc", ".eia", ".min", ".ptp", ".prg"}) {
      std::string c = base + ext;
      if (std::find(names.begin(), names.end(), c) == names.end()) names.push_back(std::move(c));
    }
  SourceFile* f = files_.find(names);
  if (!f) return std::nullopt;
  if (plans_.size() <= f->index()) {
    plans_.resize(f->index() + 1);
    programs_.resize(f->index() + 1);
  }
  if (auto l = program_line(*f, number)) return Target{f, *l};
  // No O line: the body starts after the leading '%' line, if any.
  for (std::size_t i = 0; i < f->lines(); ++i) {
    const std::string_view l = f->raw(i);
    const std::size_t q = l.find_first_not_of(" \t");
    if (q == std::string_view::npos) continue;
    return Target{f, l[q] == '%' ? i + 1 : i};
  }
  return Target{f, 0};
}

std::size_t Runner::goto_n(SourceFile& f, double n, std::size_t from, Span span) {
  if (auto l = f.find_n(n, from, true)) return *l;
  if (auto l = f.find_n(n, 0, true)) return *l;
  throw Failure{"PP-E704",
                fmt::format("sequence number N{} is not in {}: the jump has no target; add the N number or correct "
                            "the jump",
                            format_value(n, 'N'), f.name()),
                span};
}

std::optional<std::size_t> Runner::find_end(SourceFile& f, std::size_t from, int id, Span span) {
  for (std::size_t i = from + 1; i < f.lines(); ++i) {
    const std::string_view l = f.raw(i);
    // Cheap filter: END / DO need the letters.
    if (l.find_first_of("EeDd") == std::string_view::npos) continue;
    LinePlan* p = plan(f, i);
    for (const Item& it : p->items) {
      if ((it.kind == ItemKind::while_do || it.kind == ItemKind::do_loop) && saturate<int>(it.number) == id)
        throw Failure{"PP-E708",
                      fmt::format("DO {} is opened again at line {} before its END {}: loops with the same number "
                                  "cannot nest; number nested loops 1, 2, 3",
                                  id, i + 1, id),
                      span};
      if (it.kind == ItemKind::end_loop && saturate<int>(it.number) == id) return i;
    }
  }
  throw Failure{"PP-E708", fmt::format("DO {} has no END {} after it in {}; add END {}", id, id, f.name(), id), span};
}

void Runner::call(bool macro, double program, int repeats, const Locals& args, const LinePlan& p, const Item& at,
                  std::string callee) {
  (void)p;
  if (static_cast<int>(frames_.size()) - 1 >= opt_.max_call_depth)
    throw Failure{"PP-E706",
                  fmt::format("{} nests calls {} deep, more than the limit {}: a call that never returns? (Fanuc "
                              "controls allow 4 macro and 10 subprogram levels)",
                              callee, frames_.size(), opt_.max_call_depth),
                  at.span};
  std::optional<Target> t = find_program(program);
  if (!t) {
    std::string dirs;
    for (const std::string& d : opt_.search_dirs) dirs += (dirs.empty() ? "" : ", ") + d;
    throw Failure{"PP-E704",
                  fmt::format("program O{:04d} is not in {} nor a file O{:04d}[.nc|.tap|…] or {:04d}.nc in the search folders ({}); "
                              "add the subprogram or its file",
                              saturate<std::uint64_t>(program), file_->name(), saturate<std::uint64_t>(program),
                              saturate<std::uint64_t>(program), dirs.empty() ? "none" : dirs),
                  at.span};
  }
  out_.push_call(CallFrame{file_->name(), pc_ + 1, std::move(callee)});
  Frame fr;
  fr.file = t->file;
  fr.start = t->line;
  fr.ret_file = file_;
  fr.ret_line = pc_;
  fr.repeats_left = repeats;
  fr.macro = macro;
  if (macro) {
    fr.args = args;
    locals_.push_back(args);
  }
  frames_.push_back(std::move(fr));
  guard_.changed();
  file_ = t->file;
  pc_ = t->line;
}

void Runner::do_return(std::optional<double> to_n, Span span) {
  guard_.changed();  // a return, or the next pass of a repeated call
  Frame& fr = frames_.back();
  if (!to_n && fr.repeats_left > 1) {
    --fr.repeats_left;
    fr.loops.clear();
    if (fr.macro) locals_.back() = fr.args;
    file_ = fr.file;
    pc_ = fr.start;
    return;
  }
  SourceFile* rf = fr.ret_file;
  const std::size_t rl = fr.ret_line;
  if (fr.macro) locals_.pop_back();
  frames_.pop_back();
  out_.pop_call();
  file_ = rf;
  pc_ = rl + 1;
  if (to_n) pc_ = goto_n(*rf, *to_n, rl + 1, span);
}

void Runner::finish_tape() {
  // The run ended in the main program: the closing '%' passes through. Lines between the end and
  // the next program (an O line) are never run: the first that holds NC words is said (PP-W210,
  // as the reader says it for a program without O numbers).
  SourceFile& m = files_.main();
  bool said = false;
  for (std::size_t i = (file_ == &m ? pc_ + 1 : m.lines()); i < m.lines(); ++i) {
    const std::string_view l = m.raw(i);
    const std::size_t q = l.find_first_not_of(" \t");
    if (q != std::string_view::npos && l[q] == '%') {
      static const std::vector<Edit> none;
      emit(m, i, none);
      return;
    }
    if (said) continue;
    Block b;  // lexed quietly: the control never reads these lines, so they raise nothing else
    b.raw = l;
    b.line = i + 1;
    (void)lex_block(m.dialect(), b, LexContext{m.name(), nullptr});
    if (program_end::starts_program(b, m.dialect().id)) {
      said = true;
    } else if (program_end::holds_nc_words(b)) {
      said = true;
      m.report(i, {0, static_cast<std::uint32_t>(std::max<std::size_t>(1, l.size()))}, Severity::warning,
               codes::kAfterProgramEnd, program_end::after_end_message("M30 or M02", pc_ + 1));
    }
  }
}

// Executes the line at (file_, pc_) and moves pc_.
void Runner::step() {
  SourceFile& f = *file_;
  const std::size_t line = pc_;
  LinePlan& p = *plan(f, line);
  if (p.error) throw *p.error;
  if (p.plain && !modal_) {  // (under G66 a plain move still calls the macro)
    static const std::vector<Edit> none;
    emit(f, line, none);
    ++pc_;
    return;
  }
  Frame& fr = frames_.back();
  const bool in_sub = frames_.size() > 1;
  if (p.block_delete && p.statement && !warned_block_delete_) {
    warned_block_delete_ = true;
    report(p.delete_span, Severity::warning, "PP-W702",
           "block delete '/' on a macro statement: resolved with the block-delete switch off (the block runs)");
  }
  action_.assign(p.items.size(), 0);
  text_.resize(p.items.size());
  enum class Next { advance, jump, end_run, stop, ret, call, stop_main_m99 } next = Next::advance;
  std::size_t jump_to = 0;
  std::optional<double> ret_n;
  Span ret_span;
  // Word values as evaluated (for M/G/P/L).
  std::optional<std::size_t> g65, g66, g67, m98, m99, p_word, l_word;
  bool moves = false;  // an axis word with a value (G66 calls after such a block)
  std::vector<double>& vals = vals_;
  vals.assign(p.items.size(), 0.0);
  // G65/G66 arguments are values, not addresses: they are not rounded to an input increment.
  bool macro_args = false;
  for (const Item& it : p.items)
    if (it.kind == ItemKind::word && it.letter == 'G' && it.literal && (it.number == 65 || it.number == 66))
      macro_args = true;
  for (std::size_t k = 0; k < p.items.size(); ++k) {
    const Item& it = p.items[k];
    switch (it.kind) {
      case ItemKind::word: {
        double v = it.number;
        if (!it.literal) {
          const Value x = eval(p, it.e1);
          if (x.vacant) {
            action_[k] = 1;  // a vacant variable: the address is omitted
            vals[k] = NAN;
            continue;
          }
          v = macro_args ? x.v : round_to_increment(x.v, it.letter, inch_);
          action_[k] = 2;
          // A whole-number address is written without a decimal point (S1001, not S1001.).
          text_[k] = whole_address(it.letter) && v == std::round(v) && std::fabs(v) < 1e15
                         ? fmt::format("{:.0f}", v == 0 ? 0.0 : v)
                         : format_value(v, it.letter);
        }
        vals[k] = v;
        if (it.letter == 'G' && (v == 20 || v == 21)) inch_ = v == 20;
        if (it.letter == 'G' && std::fabs(v - 66.1) < 1e-9)
          throw Failure{"PP-E709",
                        "G66.1 (a macro call after every block) is not supported by the resolver; call the macro with "
                        "G65 where it is needed instead",
                        it.span};
        if (it.letter == 'G' && v == 65) g65 = k;
        if (it.letter == 'G' && v == 66) g66 = k;
        if (it.letter == 'G' && v == 67) g67 = k;
        if (std::string_view("XYZABCUVW").find(it.letter) != std::string_view::npos) moves = true;
        if (it.letter == 'M' && v == 98) m98 = k;
        if (it.letter == 'M' && v == 99) m99 = k;
        if (it.letter == 'M' && (v == 30 || v == 2) && next == Next::advance) next = Next::end_run;
        if (it.letter == 'P' && !p_word) p_word = k;
        if (it.letter == 'L' && !l_word) l_word = k;
        break;
      }
      case ItemKind::assign: {
        const Node& target = p.pool.nodes[static_cast<std::size_t>(it.e2)];
        const double index = target.op == Op::var ? target.num : eval(p, target.a).v;
        write_var(p, index, eval(p, it.e1), target.span);
        action_[k] = 1;
        break;
      }
      case ItemKind::if_then:
        if (cond(p, it.e1)) {
          const Node& target = p.pool.nodes[static_cast<std::size_t>(it.e2)];
          const double index = target.op == Op::var ? target.num : eval(p, target.a).v;
          write_var(p, index, eval(p, it.e3), target.span);
        }
        action_[k] = 1;
        break;
      case ItemKind::if_goto:
        if (cond(p, it.e1)) {
          next = Next::jump;
          jump_to = goto_n(f, eval(p, it.e2).v, line + 1, it.span);
        }
        action_[k] = 1;
        break;
      case ItemKind::go_to:
        next = Next::jump;
        jump_to = goto_n(f, eval(p, it.e1).v, line + 1, it.span);
        action_[k] = 1;
        break;
      case ItemKind::while_do:
      case ItemKind::do_loop: {
        const int id = saturate<int>(it.number);
        if (!p.loop_end) p.loop_end = find_end(f, line, id, it.span);
        const bool again = !fr.loops.empty() && fr.loops.back().begin == line;
        const bool go = it.kind == ItemKind::do_loop || cond(p, it.e1);
        if (go) {
          if (!again) fr.loops.push_back({id, line, *p.loop_end});
        } else {
          if (again) fr.loops.pop_back();
          next = Next::jump;
          jump_to = *p.loop_end + 1;
        }
        action_[k] = 1;
        break;
      }
      case ItemKind::end_loop: {
        const int id = saturate<int>(it.number);
        if (fr.loops.empty() || fr.loops.back().id != id || fr.loops.back().end != line)
          throw Failure{"PP-E708",
                        fr.loops.empty() || fr.loops.back().end == line
                            ? fmt::format("END {} without a WHILE […] DO {} before it; add the DO or remove the END", id, id)
                            : fmt::format("END {} closes DO {} opened at line {}: loops must close innermost first "
                                          "(END {} before END {})",
                                          id, fr.loops.back().id, fr.loops.back().begin + 1, fr.loops.back().id, id),
                        it.span};
        next = Next::jump;
        jump_to = fr.loops.back().begin;
        action_[k] = 1;
        break;
      }
      case ItemKind::program_number:
        if (in_sub && line == fr.start) action_[k] = 1;
        break;
      case ItemKind::percent:
        if (in_sub)
          throw Failure{"PP-E708",
                        fmt::format("the subprogram reaches the end of its tape ('%') without M99; add M99 at its end"),
                        it.span};
        next = Next::stop;
        break;
      default: break;
    }
  }
  // Calls and returns.
  Locals args{};
  std::string callee;
  double program = 0;
  int repeats = 1;
  bool macro = false;
  if (g67) {
    action_[*g67] = 1;
    modal_.reset();
    guard_.changed();
  }
  const char* const call_code = g65 ? "G65" : g66 ? "G66" : "M98";
  if ((g65 && g66) || ((g65 || g66) && m98))
    throw Failure{"PP-E709", "a block with two calls (G65, G66, M98): write one per block", p.items[g66 ? *g66 : *m98].span};
  if (g65 || g66 || m98) {
    const Item& at = p.items[g65 ? *g65 : g66 ? *g66 : *m98];
    if (!p_word || std::isnan(vals[*p_word]))
      throw Failure{"PP-E702", fmt::format("{} needs the program number: P####", call_code), at.span};
    program = vals[*p_word];
    if (l_word) {
      if (std::isnan(vals[*l_word])) repeats = 1;
      else repeats = saturate<int>(std::round(vals[*l_word]));
    }
    if (m98 && !l_word && !g65) {
      const Item& pw = p.items[*p_word];
      const std::string_view pt = pw.value.of(f.raw(line));
      if (pw.literal && pt.size() > 4 && program > 9999 && !find_program(program)) {
        repeats = saturate<int>(program / 10000);
        program = std::fmod(program, 10000);
        if (repeats == 0) repeats = 1;
      }
    }
    macro = g65 || g66;
    callee = fmt::format("{} P{}", call_code, format_value(program, 'P'));
    if (macro) {
      const std::size_t head = g65 ? *g65 : *g66;
      // Argument specification I (II for repeated I/J/K); G L N O P are not arguments.
      static constexpr int kSpec1[26] = {1, 2, 3, 7, 8, 9, 0, 11, 4, 5, 6, 0, 13, 0, 0, 0, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26};
      int ijk_group = -1;
      int last_ijk = 3;
      for (std::size_t k = 0; k < p.items.size(); ++k) {
        const Item& it = p.items[k];
        if (it.kind != ItemKind::word) continue;
        action_[k] = 1;
        if (k == head || k == *p_word || (l_word && k == *l_word)) continue;
        const char L = it.letter;
        if (L < 'A' || L > 'Z' || kSpec1[L - 'A'] == 0) {
          if (L == 'G' || L == 'M')
            throw Failure{"PP-E709",
                          fmt::format("{} must be alone in its block with its arguments; put other codes in their own "
                                      "block",
                                      call_code),
                          it.span};
          throw Failure{"PP-E702", fmt::format("{} is not a {} argument address", L, call_code), it.span};
        }
        int var = kSpec1[L - 'A'];
        if (L == 'I' || L == 'J' || L == 'K') {
          const int pos = L - 'I';
          if (pos <= last_ijk) ++ijk_group;
          last_ijk = pos;
          var = 4 + 3 * ijk_group + pos;
          if (var > 33) throw Failure{"PP-E702", "more than 10 I/J/K argument groups", it.span};
        }
        if (!std::isnan(vals[k])) args[static_cast<std::size_t>(var)] = {vals[k], true};
      }
    } else {
      action_[*m98] = 1;
      action_[*p_word] = 1;
      if (l_word) action_[*l_word] = 1;
    }
    if (repeats < 1) repeats = 0;
    if (g66) {
      // The mode is set; the calls come after the moves of the blocks that follow.
      modal_ = ModalCall{program, repeats, args};
      guard_.changed();
      modal_callee_ = callee;
    } else {
      next = Next::call;
    }
  } else if (m99) {
    action_[*m99] = 1;
    if (p_word) {
      action_[*p_word] = 1;
      ret_n = vals[*p_word];
    }
    ret_span = p.items[*m99].span;
    if (in_sub) {
      next = Next::ret;
    } else if (ret_n) {
      next = Next::jump;
      jump_to = goto_n(f, *ret_n, line + 1, ret_span);
    } else {
      next = Next::stop_main_m99;
    }
  }
  // Edits, in source order; a deleted item takes the blanks before it (or after it at the start).
  // edits_ keeps its elements (and their strings' capacity) from line to line.
  std::size_t ne = 0;
  auto add_edit = [&](Span s, std::string_view text) {
    if (ne == edits_.size()) edits_.emplace_back();
    Edit& e = edits_[ne++];
    e.span = s;
    e.text.assign(text);
  };
  std::uint32_t first_kept = p.raw_size;
  for (std::size_t k = 0; k < p.items.size(); ++k)
    if (action_[k] != 1) {
      first_kept = p.items[k].span.begin;
      break;
    }
  if (first_kept == p.raw_size) {
    add_edit({0, p.raw_size}, {});  // nothing left to execute: the line goes
  } else {
    const std::string_view raw = f.raw(line);
    std::uint32_t last_end = 0;
    const std::uint32_t lead = p.has_n ? p.n_span.end : (p.block_delete ? p.delete_span.end : 0);
    for (std::size_t k = 0; k < p.items.size(); ++k) {
      const Item& it = p.items[k];
      if (action_[k] == 2) {
        add_edit(it.value, text_[k]);
        last_end = it.value.end;
      } else if (action_[k] == 1) {
        Span s = it.span;
        if (s.begin < first_kept && s.begin >= lead) {
          while (s.end < raw.size() && is_blank(raw[s.end])) ++s.end;
        } else {
          while (s.begin > last_end && is_blank(raw[s.begin - 1])) --s.begin;
        }
        add_edit(s, {});
        last_end = s.end;
      }
    }
  }
  emit(f, line, std::span<const Edit>(edits_.data(), ne));
  if (next == Next::advance && modal_ && moves && !g66 && modal_->repeats > 0 &&
      std::none_of(frames_.begin(), frames_.end(), [](const Frame& x) { return x.modal; })) {
    // G66 in effect: the macro runs after this block's move (not from inside a macro it called).
    const ModalCall mc = *modal_;
    call(true, mc.program, mc.repeats, mc.args, p, p.items.front(), modal_callee_);
    frames_.back().modal = true;
    return;
  }
  switch (next) {
    case Next::advance: ++pc_; break;
    case Next::jump: {
      // Leaving loops whose range does not hold the target (GOTO out of a loop).
      while (!fr.loops.empty() && (jump_to < fr.loops.back().begin || jump_to > fr.loops.back().end)) fr.loops.pop_back();
      pc_ = jump_to;
      break;
    }
    case Next::end_run: finish_tape(); throw Stop{};
    case Next::stop: throw Stop{};
    case Next::ret: do_return(ret_n, ret_span); break;
    case Next::call:
      if (repeats == 0) {
        ++pc_;
        break;
      }
      call(macro, program, repeats, args, p, p.items[g65 ? *g65 : *m98], callee);
      break;
    case Next::stop_main_m99:
      report(ret_span, Severity::warning, "PP-W701", "M99 in the main program repeats it forever; resolved once");
      throw Stop{};
  }
}

void Runner::run() {
  SourceFile& m = files_.main();
  plans_.resize(1);
  programs_.resize(1);
  locals_.emplace_back();
  frames_.push_back(Frame{&m, 0, nullptr, 0, 1, false, false, {}, {}});
  file_ = &m;
  pc_ = 0;
  // Tape leader: text before the first '%' is not executed (when a program follows the '%').
  std::optional<std::size_t> first_percent;
  for (std::size_t i = 0; i < m.lines(); ++i) {
    const std::string_view l = m.raw(i);
    const std::size_t q = l.find_first_not_of(" \t");
    if (q == std::string_view::npos) continue;
    if (l[q] == '%') first_percent = i;
    break;
  }
  if (!first_percent) {
    for (std::size_t i = 0; i < m.lines(); ++i) {
      const std::string_view l = m.raw(i);
      const std::size_t q = l.find_first_not_of(" \t");
      if (q != std::string_view::npos && l[q] == '%') {
        for (std::size_t j = i + 1; j < m.lines(); ++j)
          if (m.raw(j).find_first_not_of(" \t") != std::string_view::npos) {
            first_percent = i;
            break;
          }
        break;
      }
    }
  }
  // Without '%': listing text (lines that are not NC blocks, comments allowed) before the first
  // program number is skipped the same way (program.cpp's read_leader applies the same rule).
  std::optional<std::size_t> first_o;
  if (!first_percent) {
    bool text = false, blocks = false;
    DiagnosticSink quiet(0);
    Block scratch;
    const Dialect fanuc = make_dialect(DialectId::fanuc);  // the lexing rules do not depend on options
    for (std::size_t i = 0; i < m.lines() && i < 500 && !blocks; ++i) {
      const std::string_view l = m.raw(i);
      const std::size_t q = l.find_first_not_of(" \t");
      if (q == std::string_view::npos) continue;
      if ((l[q] == 'O' || l[q] == 'o' || l[q] == ':') && q + 1 < l.size() && l[q + 1] >= '0' && l[q + 1] <= '9') {
        if (text) first_o = i;
        break;
      }
      if (l[q] == '%') break;
      scratch.clear();
      scratch.raw = l;
      scratch.line = i + 1;
      if (!lex_block(fanuc, scratch, LexContext{"", &quiet})) text = true;
      else if (!scratch.words.empty() || scratch.has_n) blocks = true;
    }
  }
  static const std::vector<Edit> none;
  try {
    if (first_percent) {
      for (std::size_t i = 0; i <= *first_percent; ++i) emit(m, i, none);
      pc_ = *first_percent + 1;
    } else if (first_o) {
      for (std::size_t i = 0; i < *first_o; ++i) emit(m, i, none);
      pc_ = *first_o;
    }
    for (;;) {
      if (pc_ >= file_->lines()) {
        if (frames_.size() > 1) {
          pc_ = file_->lines() ? file_->lines() - 1 : 0;
          report({0, 1}, Severity::error, "PP-E708",
                 fmt::format("the subprogram runs past the end of {} without M99; add M99 at its end", file_->name()));
        }
        return;
      }
      const SourceFile* const at_file = file_;
      const std::size_t at = pc_, depth = frames_.size();
      if (!guard_.step(out_.emitted())) {
        report({0, static_cast<std::uint32_t>(std::max<std::size_t>(1, file_->raw(pc_).size()))}, Severity::error,
               "PP-E705", guard_.silent_message());
        return;
      }
      try {
        step();
      } catch (const Failure& e) {
        fail(e);
        return;
      }
      // Back to an earlier line of the same program level (END m, GOTO back): with nothing
      // changed since the last time here, the loop never ends.
      if (file_ == at_file && frames_.size() == depth && pc_ <= at &&
          !guard_.back_jump(file_->index(), depth, pc_)) {
        pc_ = at;
        report({0, static_cast<std::uint32_t>(std::max<std::size_t>(1, file_->raw(pc_).size()))}, Severity::error,
               "PP-E705", LoopGuard::no_progress_message());
        return;
      }
    }
  } catch (const Stop&) {
  }
}

}  // namespace fanuc_run

void resolve_fanuc(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r) {
  fanuc_run::Runner run(files, out, opt, sink, r);
  run.run();
}

}  // namespace postproc::gcode::resolver
