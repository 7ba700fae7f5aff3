// The LinuxCNC resolver at run time: numbered and named parameters, expression evaluation,
// assignments, the line loop, O-word control flow and subroutine calls (linuxcnc_runner.hpp).
#include "linuxcnc_runner.hpp"

#include <algorithm>
#include <iterator>
#include <string_view>

namespace postproc::gcode::resolver::lcnc_run {

std::string Machine::context() const {
  const std::string w = out_.where();
  return w.empty() ? std::string() : "; " + w;
}

double Machine::numbered(double index) {
  const double r = std::round(index);
  if (std::fabs(index - r) > 1e-4 || r < 0 || r >= kNumbered)
    throw EvalError{"PP-E703", fmt::format("parameter #{} does not exist (LinuxCNC has #1 … #{})", index, kNumbered - 1)};
  const int n = static_cast<int>(r);
  if (profile_ && (n == 5420 || n == 5422)) return profile_position(n == 5420 ? 0 : 2);
  if (const char* what = runtime_numbered(n)) {
    const std::string key = fmt::format("#{}", n);
    if (const auto it = opt_.set.find(key); it != opt_.set.end()) {
      r_.used_settings[key] = it->second;
      return set_numbered_.count(n) ? numbered_[static_cast<std::size_t>(n)] : it->second;
    }
    if (!set_numbered_.count(n))
      throw EvalError{"PP-E701", fmt::format("#{} is {}, known only when the program runs; give its value with "
                                             "--set '#{}=…'", n, what, n)};
  }
  return numbered_[static_cast<std::size_t>(n)];
}

namespace {

/// LinuxCNC's predefined named parameters (G-code overview, "Predefined Named Parameters"; names
/// folded to lower case): rs274 refuses an assignment to any of them ("Cannot assign to read-only
/// parameter", checked name by name against rs274 2.9).
bool read_only_named(std::string_view n) {
  static constexpr std::string_view kPredefined[] = {
      "_vmajor", "_vminor", "_line", "_motion_mode", "_plane", "_ccomp", "_metric", "_imperial", "_absolute",
      "_incremental", "_inverse_time", "_units_per_minute", "_units_per_rev", "_coord_system", "_tool_offset",
      "_retract_r_plane", "_retract_old_z", "_spindle_rpm_mode", "_spindle_css_mode", "_ijk_absolute_mode",
      "_lathe_diameter_mode", "_lathe_radius_mode", "_spindle_on", "_spindle_cw", "_mist", "_flood",
      "_speed_override", "_feed_override", "_adaptive_feed", "_feed_hold", "_feed", "_rpm", "_x", "_y", "_z", "_a",
      "_b", "_c", "_u", "_v", "_w", "_abs_x", "_abs_y", "_abs_z", "_abs_a", "_abs_b", "_abs_c", "_current_tool",
      "_current_pocket", "_selected_tool", "_selected_pocket", "_value", "_value_returned", "_task", "_call_level",
      "_remap_level"};
  return std::find(std::begin(kPredefined), std::end(kPredefined), n) != std::end(kPredefined);
}

}  // namespace

std::optional<double> Machine::named(int id) {
  const std::string& n = names_.name(id);
  if (profile_ && (id == x_id_ || id == z_id_)) return profile_position(id == x_id_ ? 0 : 2);
  if (!n.empty() && n[0] == '_') {
    if (const auto it = globals_.find(id); it != globals_.end()) return it->second;
    const std::string key = "#<" + std::string(n) + ">";
    std::string upper = key;
    for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (const auto it = opt_.set.find(upper); it != opt_.set.end()) {
      r_.used_settings[upper] = it->second;
      return it->second;
    }
    return std::nullopt;
  }
  auto& loc = frames_.back().locals;
  if (const auto it = loc.find(id); it != loc.end()) return it->second;
  return std::nullopt;
}

double Machine::eval(const Code& c) {
  double st[64];
  int sp = 0;
  for (const Instr& in : c.ops) {
    if (sp >= 62) throw EvalError{"PP-E702", "the expression nests too deeply"};
    switch (in.op) {
      case Op::num: st[sp++] = in.value; break;
      case Op::param: st[sp++] = numbered(in.value); break;
      case Op::param_ind: st[sp - 1] = numbered(st[sp - 1]); break;
      case Op::named: {
        const auto v = named(static_cast<int>(in.value));
        if (!v) {
          const std::string& n = names_.name(static_cast<int>(in.value));
          throw EvalError{n[0] == '_' ? "PP-E701" : "PP-E703",
                          n[0] == '_' ? fmt::format("#<{}> is not set by the program (a controller value, known only "
                                                    "when it runs?); set it first or give --set '#<{}>=…'", n, n)
                                      : fmt::format("#<{}> is read before it is set (LinuxCNC refuses this)", n)};
        }
        st[sp++] = *v;
        break;
      }
      case Op::exists: st[sp++] = named(static_cast<int>(in.value)) ? 1.0 : 0.0; break;
      case Op::neg: st[sp - 1] = -st[sp - 1]; break;
      default: apply_operator(in.op, st, sp); break;
    }
  }
  return st[0];
}

double Machine::value(SourceFile& f, std::size_t i, Span span, const Code& c) {
  try {
    return eval(c);
  } catch (const EvalError& e) {
    f.report(i, span, Severity::error, e.code, e.what + context());
    throw Stop{};
  }
}

void Machine::store(std::unordered_map<int, double>& m, int id, double v) {
  const auto [it, fresh] = m.try_emplace(id, v);
  if (!fresh && it->second == v) return;
  const std::uint64_t key = LoopGuard::named_key(id, &m == &globals_ ? 0 : frames_.size());
  if (fresh) guard_.value_added(key, v);
  else guard_.value_changed(key, it->second, v);
  it->second = v;
}

void Machine::assign(const Assign& a, double v, SourceFile& f, std::size_t i, Span span) {
  if (a.named) {
    const std::string& n = names_.name(a.name_id);
    if (read_only_named(n)) {
      f.report(i, span, Severity::error, "PP-E710",
               fmt::format("#<{}> is a predefined parameter, read-only in LinuxCNC: its interpreter stops here "
                           "('Cannot assign to read-only parameter'); use a name of your own{}",
                           n, context()));
      throw Stop{};
    }
    store(n[0] == '_' ? globals_ : frames_.back().locals, a.name_id, v);
    return;
  }
  const double idx = value(f, i, span, a.index);
  const double r = std::round(idx);
  if (r < 1 || r >= kNumbered || std::fabs(idx - r) > 1e-4) {
    f.report(i, span, Severity::error, "PP-E703", fmt::format("parameter #{} does not exist{}", idx, context()));
    throw Stop{};
  }
  const int n = static_cast<int>(r);
  if ((n >= 5400 && n <= 5413) || (n >= 5420 && n <= 5428)) {
    f.report(i, span, Severity::error, "PP-E710",
             fmt::format("#{} ({}) is read-only in LinuxCNC: its interpreter stops here ('Parameter is readonly'); "
                         "use a parameter of your own (#31–#5000){}",
                         n, n <= 5413 ? "the current tool's number and offsets" : "the current position", context()));
    throw Stop{};
  }
  double& slot = numbered_[static_cast<std::size_t>(n)];
  if (slot != v) guard_.value_changed(LoopGuard::numbered_key(n), slot, v);
  slot = v;
  if (runtime_numbered(n) && set_numbered_.insert(n).second) guard_.changed();  // now readable: progress
}

void Machine::probe_results(const Line& l) {
  const bool was = probing_;
  if (l.probe == Line::Probe::starts) probing_ = true;
  if (l.probe == Line::Probe::ends) probing_ = false;
  if (probing_ != was) guard_.changed();
  if (!probing_ || (l.probe != Line::Probe::starts && !l.axis_words)) return;
  for (int n = 5061; n <= 5070; ++n) set_numbered_.erase(n);
  guard_.changed();
}

void Machine::execute(SourceFile& f, std::size_t from, std::size_t to, bool in_sub) {
  FileInfo& fi = info(f);
  std::size_t pc = from;
  std::vector<Edit> edits;
  std::vector<double> pending;
  while (pc < to) {
    Line& l = line(f, pc);
    if (!l.ok) throw Stop{};
    if (!guard_.step(out_.emitted())) endless(f, pc, guard_.silent_message());
    if (profile_ && l.kw == Kw::none) {
      profile_line(f, pc, l);
      ++pc;
      continue;
    }
    if (l.plain) {
      if (l.context) {
        edits.clear();
        modal_context(f, pc, l.context, l.context_span, edits);
        if (!out_.emit(f, pc, edits)) runaway(f, pc);
      } else if (!out_.emit(f, pc, {})) {
        runaway(f, pc);
      }
      if (l.modes) apply_modes(l.modes);
      probe_results(l);
      if (l.ends_program) throw Stop{};
      ++pc;
      continue;
    }
    if (l.numbered_return) {
      numbered_return(f, pc, l, in_sub);
      emit_call_comments(f, pc, l);
      return;
    }
    if (l.numbered_call) {
      emit_call_comments(f, pc, l);
      numbered_call(f, pc, l);
      ++pc;
      continue;
    }
    if (l.kw != Kw::none) {
      const std::size_t next = control(f, fi, pc, l, in_sub);
      if (next == kReturn) return;
      // The control line's comments stay (the O-word statement is removed).
      Edit del{l.control_span, ""};
      if (f.raw(pc).find('(') != std::string_view::npos && !out_.emit(f, pc, std::span<const Edit>(&del, 1)))
        runaway(f, pc);
      if (next <= pc && !guard_.back_jump(f.index(), frames_.size(), next))
        endless(f, pc, LoopGuard::no_progress_message());
      pc = next;
      continue;
    }
    if (l.abort) {
      f.report(pc, Span{0, static_cast<std::uint32_t>(f.raw(pc).size())}, Severity::error, "PP-E710",
               fmt::format("the program aborts here: {}{}", l.abort_text, context()));
      throw Stop{};
    }
    // Values on the line use the parameters as they were before it; its assignments take
    // effect after the line (rs274ngc).
    edits.clear();
    pending.clear();
    for (const Assign& as : l.assigns) pending.push_back(value(f, pc, as.span, as.value));
    unsigned context = l.context, modes = l.modes;
    Span context_at = l.context_span;
    for (const WordValue& v : l.words) {
      const double x = value(f, pc, v.span, v.code);
      if (v.letter == 'M' && x >= 70 && x <= 73 && x == std::floor(x)) {  // M[…] computed to M70–M73
        if (context == 0) context_at = v.span;
        context |= 1u << (static_cast<int>(x) - 70);
      }
      if (v.letter == 'G') {  // G[…] computed to G90 G91 G7 G8
        const long g10 = std::lround(x * 10);
        modes |= g10 == 900 ? 1u : g10 == 910 ? 2u : g10 == 70 ? 4u : g10 == 80 ? 8u : 0u;
      }
      edits.push_back({v.span, format_value(x, v.letter)});
    }
    // rs274's order within a block: M70–M73, then G7/G8 and G90/G91, then the motion (a G7x cycle,
    // whose profile is written before this line).
    if (context) modal_context(f, pc, context, context_at, edits);
    apply_modes(modes);
    if (l.cycle_profile) cycle_profile(f, pc, l);
    for (const Span& d : l.deletions) edits.push_back({d, ""});
    std::sort(edits.begin(), edits.end(), [](const Edit& x, const Edit& y) { return x.span.begin < y.span.begin; });
    if (!out_.emit(f, pc, edits)) runaway(f, pc);
    probe_results(l);
    for (std::size_t k = 0; k < l.assigns.size(); ++k) assign(l.assigns[k], pending[k], f, pc, l.assigns[k].span);
    if (l.ends_program) throw Stop{};
    ++pc;
  }
}

void Machine::close_tape(SourceFile& main) {
  const auto percent = [&](std::size_t i) {
    const std::string_view l = main.raw(i);
    const std::size_t q = l.find_first_not_of(" \t");
    return q != std::string_view::npos && l[q] == '%';
  };
  const auto blank = [&](std::size_t i) { return main.raw(i).find_first_not_of(" \t") == std::string_view::npos; };
  std::size_t first = 0, last = main.lines();
  while (first < main.lines() && blank(first)) ++first;
  while (last > first + 1 && blank(last - 1)) --last;
  if (first >= main.lines() || last <= first + 1 || !percent(first) || !percent(last - 1)) return;
  const bool written = !r_.source_line.empty() && r_.source_file.back() == main.index() && r_.source_line.back() == last;
  if (!written) (void)out_.emit(main, last - 1, {});
}

void Machine::endless(SourceFile& f, std::size_t i, const std::string& why) {
  f.report(i, Span{0, static_cast<std::uint32_t>(std::max<std::size_t>(1, f.raw(i).size()))}, Severity::error, "PP-E705",
           why + context());
  throw Stop{};
}

void Machine::runaway(SourceFile& f, std::size_t i) {
  f.report(i, Span{0, static_cast<std::uint32_t>(f.raw(i).size())}, Severity::error, "PP-E705",
           fmt::format("the program executes {}: a loop that does not end?{}", runaway_limits(opt_), context()));
  throw Stop{};
}

std::size_t Machine::control(SourceFile& f, FileInfo& fi, std::size_t i, Line& l, bool in_sub) {
  const bool opens = l.kw == Kw::if_ || l.kw == Kw::do_ || l.kw == Kw::repeat ||
                     (l.kw == Kw::while_ && !fi.start_of.contains(i));
  if (opens) {
    // rs274: at one call level a number names one block ("duplicate O-word label" when a second
    // block with it runs, also after the first has ended; each call of a subroutine starts afresh).
    const auto [it, fresh] = frames_.back().labels.emplace(l.oname, i);
    if (!fresh && it->second != i) {
      f.report(i, l.control_span, Severity::error, "PP-E708",
               fmt::format("'{}' uses the number of the block at line {} again: LinuxCNC refuses it (\"duplicate "
                           "O-word label\"); give each block its own number{}",
                           f.raw(i).substr(l.control_span.begin, l.control_span.size()), it->second + 1, context()));
      throw Stop{};
    }
  }
  switch (l.kw) {
    case Kw::sub: return fi.end_of.at(i) + 1;  // a definition: skipped
    case Kw::endsub:
    case Kw::ret:
      if (!in_sub) {
        f.report(i, l.control_span, Severity::error, "PP-E708",
                 fmt::format("'{}' outside a subroutine", f.raw(i).substr(l.control_span.begin, l.control_span.size())));
        throw Stop{};
      }
      if (frames_.back().numbered) {
        f.report(i, l.control_span, Severity::error, "PP-E708",
                 fmt::format("'{}' inside a numbered program called by M98: LinuxCNC returns from it only with M99 "
                             "(the two styles of subprogram do not mix){}",
                             f.raw(i).substr(l.control_span.begin, l.control_span.size()), context()));
        throw Stop{};
      }
      // rs274 2.9: a return or endsub without a value sets #<_value> and #<_value_returned> to 0;
      // a call leaves them as they are until then (tests/rs274_control_compare.py).
      globals_[names_.id("_value")] = l.args.empty() ? 0.0 : value(f, i, l.control_span, l.args[0]);
      globals_[names_.id("_value_returned")] = l.args.empty() ? 0.0 : 1.0;
      guard_.changed();
      if (const SavedState& st = frames_.back().state; st.valid && st.restore) {
        // M73: LinuxCNC restores the state saved at this level as the subroutine returns; the
        // resolved program does it with an M72 written on the return line.
        check_restore(f, i, l.control_span, st, true);
        const Edit m72{l.control_span, "M72" + level_mark()};
        if (!out_.emit(f, i, std::span<const Edit>(&m72, 1))) runaway(f, i);
      }
      return kReturn;
    case Kw::call: call(f, i, l); return i + 1;
    case Kw::if_: {
      if (truth(f, i, l)) return i + 1;
      for (std::size_t b : fi.branches.at(i)) {
        Line& bl = line(f, b);
        if (bl.kw == Kw::elseif && truth(f, b, bl)) return b + 1;
        if (bl.kw == Kw::else_) return b + 1;
        if (bl.kw == Kw::endif) return b + 1;
      }
      return fi.end_of.at(i) + 1;
    }
    case Kw::elseif:
    case Kw::else_:  // reached from the end of a taken branch: leave the if
      return fi.end_of.at(fi.start_of.at(i)) + 1;
    case Kw::endif: return i + 1;
    case Kw::while_:
      if (auto s = fi.start_of.find(i); s != fi.start_of.end()) {  // the end of a do … while
        const bool again = truth(f, i, l);
        if (again && while_broken_) {
          // rs274 2.9 (LinuxCNC's interpreter) runs the first do … while after a break out of a while
          // loop once only: its 'while' line does not go back (tests/rs274_control_compare.py found
          // it; with the same number twice rs274 hangs). Not a rule to follow: refused.
          loop_defect(f, i, l,
                      "would repeat its do loop, but LinuxCNC 2.9's interpreter runs the first do … while after a "
                      "'break' out of a while loop only once (a while loop ended with break before it)",
                      "end that while loop without break, or write this loop with while … endwhile");
        }
        while_broken_ = false;  // rs274 clears doing_break at every end of a do loop
        return again ? s->second + 1 : i + 1;
      }
      if (truth(f, i, l)) return i + 1;
      // rs274 skips to the endwhile; a continue left pending by a do loop goes back to this line
      // there, whose condition is still false: the loop ends and the pending continue is spent.
      do_continued_ = false;
      // Skipping to its endwhile, rs274 carries out a 'break' of this loop it passes (the skip's
      // name is the loop's own): doing_break is left set although no break was taken.
      if (break_after(fi, i, i)) while_broken_ = true;
      return fi.end_of.at(i) + 1;
    case Kw::endwhile: return fi.start_of.at(i);
    case Kw::do_:
    case Kw::program_number: return i + 1;
    case Kw::repeat: {
      const double n = repeat_count(f, i, l);
      if (n < 1) {
        do_continued_ = false;  // spent at the endrepeat; the count read again is the same
        return fi.end_of.at(i) + 1;
      }
      frames_.back().repeats[i] = saturate<long>(n) - 1;
      guard_.changed();
      return i + 1;
    }
    case Kw::endrepeat: {
      const std::size_t s = fi.start_of.at(i);
      long& left = frames_.back().repeats[s];
      if (left > 0) {
        --left;
        guard_.changed();  // the pass count is state: a repeat with an empty body still ends
        return s + 1;
      }
      if (do_continued_) {
        // rs274 (interp_o_word.cc, O_endrepeat): the loop ends by skipping to its endrepeat, where a
        // continue still pending from a do loop goes back to the repeat line, which reads its count
        // again and, if that is at least 1, runs the loop again (and again each time the do loop's
        // continue recurs): an interpreter defect the program would depend on, refused.
        if (repeat_count(f, s, line(f, s)) >= 1)
          loop_defect(f, s, line(f, s),
                      "would end here, but after a 'continue' in a do loop LinuxCNC 2.9's interpreter reads the "
                      "repeat count again and runs the loop again",
                      "write the do loop without continue (an if around the rest of its body)");
        do_continued_ = false;
      }
      return i + 1;
    }
    case Kw::break_:
    case Kw::continue_: {
      const std::size_t loop = enclosing_loop(f, fi, i, l);
      const Line& ll = line(f, loop);
      const std::size_t end = fi.end_of.at(loop);
      if (l.kw == Kw::break_) {
        if (ll.kw == Kw::while_ && do_continued_) {
          // rs274 2.9: after a continue in a do loop, a break skips to the endwhile, which goes back to
          // the while line (the pending continue is spent there): the loop ends only if its condition
          // is false now; if true it runs on, an interpreter defect the result would depend on: refused.
          if (truth(f, loop, line(f, loop)))
            loop_defect(f, i, l,
                        "after a 'continue' in a do loop: LinuxCNC 2.9's interpreter then does not leave the while "
                        "loop at a break while its condition holds (it runs on until the condition fails)",
                        "write the do loop without continue, or end this loop by its condition");
          do_continued_ = false;
        }
        if (ll.kw == Kw::while_) while_broken_ = true;
        return end + 1;
      }
      // rs274: a continue of a while loop is spent at its endwhile; one of a do loop stays pending
      // (doing_continue is cleared only at an endwhile or endrepeat the interpreter skips to).
      do_continued_ = ll.kw == Kw::do_;
      // Skipping to the loop's end, rs274 carries out a 'break' of the same loop it passes: doing_break
      // is set. A do loop then ends at its while line (doing_break cleared there); a while loop goes
      // back all the same, with doing_break left set.
      const bool passes_break = break_after(fi, loop, i);
      if (ll.kw == Kw::while_) {
        if (passes_break) while_broken_ = true;
        return loop;  // evaluate the condition again
      }
      if (passes_break) {
        while_broken_ = false;
        return end + 1;
      }
      return end;  // do: its while line
    }
    default: return i + 1;
  }
}

void Machine::cycle_profile(SourceFile& f, std::size_t pc, const Line& l) {
  double q = l.cycle_q;
  bool have_q = l.cycle_q_literal;
  for (const WordValue& v : l.words)
    if (v.letter == 'Q') {
      q = value(f, pc, v.span, v.code);
      have_q = true;
    }
  if (!have_q) return;  // the interpreter refuses the cycle without Q
  const auto it = subs_.find(fmt::format("o{}", std::lround(q)));
  if (it == subs_.end()) return;  // … and without its subroutine
  if (profile_) {
    f.report(pc, l.cycle_span, Severity::error, "PP-E251",
             fmt::format("a lathe cycle inside the profile of another (o{} sub, used by the G7x at line {}): rs274 "
                         "takes its G code as the profile's motion mode, which this version does not follow; keep only "
                         "G0/G1/G2/G3 moves and statements in the profile{}",
                         profile_->q, profile_->cycle_line + 1, context()));
    throw Stop{};
  }
  // rs274 (convert_g7x) first moves (G0) to the cycle's X Z, so the profile starts there: with G90
  // and the word given, that point is known (X as a radius under G7).
  Profile prof;
  prof.absolute = absolute_;
  prof.diameter = diameter_;
  prof.cycle_line = pc;
  prof.q = std::lround(q);
  if (absolute_) {
    const Block& cb = f.block(pc);
    for (const Word& w : cb.words)
      if ((w.letter == 'X' || w.letter == 'Z') && w.name_len == 1 && w.kind == ValueKind::number)
        (w.letter == 'X' ? prof.x : prof.z) = w.number, (w.letter == 'X' ? prof.x_known : prof.z_known) = true;
    for (const WordValue& v : l.words)
      if (v.letter == 'X' || v.letter == 'Z')
        (v.letter == 'X' ? prof.x : prof.z) = value(f, pc, v.span, v.code),
                                          (v.letter == 'X' ? prof.x_known : prof.z_known) = true;
    if (diameter_) prof.x /= 2;
  }
  const Sub s = it->second;
  SourceFile& sf = *s.file;
  out_.push_call(CallFrame{f.name(), pc + 1, fmt::format("o{} profile", std::lround(q))});
  if (!out_.emit(sf, s.begin, {})) runaway(sf, s.begin);
  // rs274 runs the subroutine as a call ("oN CALL", no arguments): its O-word control flow, calls
  // and assignments are executed; each other line is read for the profile only.
  Frame fr;
  std::copy(numbered_.begin() + 1, numbered_.begin() + 31, fr.saved.begin() + 1);
  std::fill(numbered_.begin() + 1, numbered_.begin() + 31, 0.0);
  frames_.push_back(std::move(fr));
  guard_.changed();
  globals_[names_.id("_call_level")] = static_cast<double>(frames_.size() - 1);
  profile_ = &prof;
  try {
    execute(sf, s.begin + 1, s.end + 1, true);
  } catch (...) {
    profile_ = nullptr;
    throw;
  }
  profile_ = nullptr;
  std::copy(frames_.back().saved.begin() + 1, frames_.back().saved.end(), numbered_.begin() + 1);
  frames_.pop_back();
  globals_[names_.id("_call_level")] = static_cast<double>(frames_.size() - 1);
  if (!out_.emit(sf, s.end, {})) runaway(sf, s.end);
  out_.pop_call();
}

void Machine::profile_line(SourceFile& f, std::size_t i, const Line& l) {
  if (l.cycle_profile) cycle_profile(f, i, l);  // refused inside a profile
  std::vector<Edit> edits;
  std::vector<double> pending;
  for (const Assign& as : l.assigns) pending.push_back(value(f, i, as.span, as.value));
  // X Z U W of the line: literal or evaluated (parameters as before the line).
  std::array<double, 4> v{};
  std::array<bool, 4> has{};
  const auto slot = [](char c) { return c == 'X' ? 0 : c == 'Z' ? 1 : c == 'U' ? 2 : c == 'W' ? 3 : -1; };
  for (const Word& w : f.block(i).words)
    if (w.name_len == 1 && w.kind == ValueKind::number && slot(w.letter) >= 0) {
      v[static_cast<std::size_t>(slot(w.letter))] = w.number;
      has[static_cast<std::size_t>(slot(w.letter))] = true;
    }
  for (const WordValue& wv : l.words) {
    const double x = value(f, i, wv.span, wv.code);
    if (slot(wv.letter) >= 0) {
      v[static_cast<std::size_t>(slot(wv.letter))] = x;
      has[static_cast<std::size_t>(slot(wv.letter))] = true;
    }
    edits.push_back({wv.span, format_value(x, wv.letter)});
  }
  for (const Span& d : l.deletions) edits.push_back({d, ""});
  std::sort(edits.begin(), edits.end(), [](const Edit& x, const Edit& y) { return x.span.begin < y.span.begin; });
  if (!out_.emit(f, i, edits)) runaway(f, i);
  for (std::size_t k = 0; k < l.assigns.size(); ++k) assign(l.assigns[k], pending[k], f, i, l.assigns[k].span);
  // The point the profile reaches (rs274 convert_g7x under G90: U/W add to the last point, U halved
  // under G7; X (already a radius under G7) and Z replace it). Under G91 every point is relative to
  // the unknown start: not known.
  Profile& p = *profile_;
  if (!p.absolute) {
    p.x_known = p.z_known = false;
    return;
  }
  const double div = p.diameter ? 2.0 : 1.0;
  if (has[2]) p.x += v[2] / div;
  else if (has[0]) p.x = v[0] / div, p.x_known = true;
  if (has[3]) p.z += v[3];
  else if (has[1]) p.z = v[1], p.z_known = true;
}

double Machine::profile_position(int axis) const {
  const Profile& p = *profile_;
  if (axis == 0 ? p.x_known : p.z_known) return axis == 0 ? p.x : p.z;
  const char a = axis == 0 ? 'X' : 'Z';
  throw EvalError{"PP-E701",
                  fmt::format("inside the profile of a lathe cycle (o{} sub, used by the G7x at line {}) the current {} "
                              "(#<_{}>, #{}) is the profile's last point, which is not known here: {}; give {} on the "
                              "cycle block, or an absolute {} in the profile before this line",
                              p.q, p.cycle_line + 1, a, static_cast<char>(std::tolower(a)), axis == 0 ? 5420 : 5422,
                              p.absolute ? fmt::format("the profile has not given {} yet and the cycle block has no {}", a, a)
                                         : std::string("the cycle runs under G91, where the profile is relative to "
                                                       "the position before it"),
                              a, a)};
}

std::string Machine::where(const SourceFile& in, const SourceFile* f, std::size_t line) {
  if (f == nullptr || f == &in) return fmt::format("line {}", line + 1);
  return fmt::format("{}:{}", f->name(), line + 1);
}

void Machine::modal_context(SourceFile& f, std::size_t i, unsigned bits, Span at, std::vector<Edit>& mark) {
  SavedState& level = frames_.back().state;
  if (frames_.size() > 1) mark.push_back({Span{at.end, at.end}, level_mark()});
  if (bits & (1u | 8u)) {  // M70, M73: save at this call level (M73 also asks for the restore at the return)
    level.valid = true;
    level.restore = level.restore || (bits & 8u) != 0;
    level.id = ++saves_;
    level.file = &f;
    level.line = i;
    level.absolute = absolute_;
    level.diameter = diameter_;
    flat_ = level;
    guard_.changed();
  }
  if (bits & 2u) {  // M71: this level's state is invalid (and, in a single-state program, the one state)
    level.valid = false;
    flat_.valid = false;
    flat_.file = &f;
    flat_.line = i;
  }
  if (bits & 4u) check_restore(f, i, at, level, false);
}

void Machine::check_restore(SourceFile& f, std::size_t i, Span at, const SavedState& s, bool on_return) {
  if (!s.valid) {
    f.report(i, at, Severity::error, "PP-E207",
             fmt::format("M72 restores the modal state saved at this call level, but none is valid here (never saved "
                         "with M70/M73 in this {}, or invalidated by M71): LinuxCNC stops here (\"Cannot restore "
                         "context from invalid stack frame\"); save with M70 at this level first{}",
                         frames_.size() > 1 ? "subroutine call — a save of the caller does not count" : "program",
                         context()));
    throw Stop{};
  }
  absolute_ = s.absolute;
  diameter_ = s.diameter;
  if ((flat_.valid && flat_.id == s.id) || !r_.not_flat.empty()) return;
  // Right for postproc's interpreter (a state per call level), but not as one program: noted for
  // --flatten, which refuses then.
  const std::string what =
      on_return ? fmt::format("the subroutine returns here and LinuxCNC restores the modal state that the M73 at {} saved",
                              where(f, s.file, s.line))
                : fmt::format("this M72 restores the modal state saved at {} at this call level", where(f, s.file, s.line));
  const std::string between =
      flat_.valid ? fmt::format("the save at {} (another call level) came after it", where(f, flat_.file, flat_.line))
                  : fmt::format("the M71 at {} (another call level) invalidated it", where(f, flat_.file, flat_.line));
  DiagnosticSink capture;
  LexContext ctx = f.context();
  ctx.sink = &capture;
  report_at(ctx, f.block(i), at, Severity::error, "PP-E709",
            fmt::format("--flatten: {}, but {}; a LinuxCNC main program keeps one saved state, so the resolved program "
                        "cannot restore it as one program; convert or compensate without --flatten (the program is "
                        "written back into itself, subroutines kept), or save and restore at one call level{}",
                        what, between, context()));
  if (!capture.stored().empty()) r_.not_flat.push_back(capture.stored().front());
}

bool Machine::break_after(const FileInfo& fi, std::size_t loop, std::size_t from) {
  const auto it = fi.breaks.find(loop);
  return it != fi.breaks.end() && it->second.back() > from;  // the lines lie inside the loop, in order
}

double Machine::repeat_count(SourceFile& f, std::size_t i, const Line& l) {
  // rs274 rounds the count to the nearest integer, ties to even ([2.5] runs twice, [2.6] three times).
  return std::nearbyint(value(f, i, l.control_span, l.args[0]));
}

void Machine::loop_defect(SourceFile& f, std::size_t i, const Line& l, std::string_view what,
                          std::string_view instead) {
  f.report(i, l.control_span, Severity::error, "PP-E709",
           fmt::format("'{}' {}; the result depends on the interpreter version: {}{}",
                       f.raw(i).substr(l.control_span.begin, l.control_span.size()), what, instead, context()));
  throw Stop{};
}

std::size_t Machine::enclosing_loop(SourceFile& f, FileInfo& fi, std::size_t i, const Line& l) {
  for (const auto& [start, end] : fi.end_of) {
    if (start > i || end < i) continue;
    const Line& s = line(f, start);
    if (s.oname == l.oname && (s.kw == Kw::while_ || s.kw == Kw::do_ || s.kw == Kw::repeat)) return start;
  }
  f.report(i, l.control_span, Severity::error, "PP-E708",
           fmt::format("'{}' is not inside a loop named {}", f.raw(i).substr(l.control_span.begin, l.control_span.size()),
                       l.oname));
  throw Stop{};
}

void Machine::call(SourceFile& f, std::size_t i, Line& l) {
  std::vector<double> args;
  for (const Code& c : l.args) args.push_back(value(f, i, l.control_span, c));
  if (args.size() > 30) {
    f.report(i, l.control_span, Severity::error, "PP-E702", "a call takes at most 30 arguments" + context());
    throw Stop{};
  }
  std::string computed;
  if (l.onumber) {  // o[expression] call: rs274 read_integer_value
    const double v = value(f, i, l.control_span, *l.onumber);
    double n = std::floor(v);
    if (v - n > 0.9999) n += 1;
    else if (v - n > 0.0001 || !(std::abs(v) < 1e9)) {
      f.report(i, l.control_span, Severity::error, "PP-E207",
               fmt::format("the O-word number {} is not a whole number: LinuxCNC stops here (rs274: \"Non integer "
                           "value for integer\"){}",
                           v, context()));
      throw Stop{};
    }
    computed = fmt::format("o{}", static_cast<long long>(n));
  }
  const std::string& oname = l.onumber ? computed : l.oname;
  auto it = subs_.find(oname);
  if (it == subs_.end() && l.oname.size() > 2 && l.oname[1] == '<') {
    const std::string name = l.oname.substr(2, l.oname.size() - 3);
    if (SourceFile* sf = files_.find({name + ".ngc", name + ".NGC", name})) {
      prepare(*sf);
      it = subs_.find(l.oname);
    }
  }
  if (it == subs_.end()) {
    f.report(i, l.control_span, Severity::error, "PP-E704",
             fmt::format("no subroutine '{} sub' in this file{}{}", oname,
                         l.oname[1] == '<' ? fmt::format(" and no file {}.ngc in the search folders",
                                                         l.oname.substr(2, l.oname.size() - 3))
                                           : std::string(),
                         context()));
    throw Stop{};
  }
  if (static_cast<int>(frames_.size()) > opt_.max_call_depth) {
    f.report(i, l.control_span, Severity::error, "PP-E706",
             fmt::format("calls nest deeper than {} levels (endless recursion?){}", opt_.max_call_depth, context()));
    throw Stop{};
  }
  const Sub s = it->second;
  Frame fr;
  std::copy(numbered_.begin() + 1, numbered_.begin() + 31, fr.saved.begin() + 1);
  for (int k = 1; k <= 30; ++k) numbered_[static_cast<std::size_t>(k)] = k <= static_cast<int>(args.size()) ? args[static_cast<std::size_t>(k - 1)] : 0;
  frames_.push_back(std::move(fr));
  guard_.changed();
  globals_[names_.id("_call_level")] = static_cast<double>(frames_.size() - 1);
  out_.push_call(CallFrame{f.name(), i + 1, oname + " call"});
  execute(*s.file, s.begin + 1, s.end + 1, true);
  out_.pop_call();
  std::copy(frames_.back().saved.begin() + 1, frames_.back().saved.end(), numbered_.begin() + 1);
  frames_.pop_back();
  globals_[names_.id("_call_level")] = static_cast<double>(frames_.size() - 1);
}

void Machine::emit_call_comments(SourceFile& f, std::size_t i, const Line& l) {
  if (f.raw(i).find('(') == std::string_view::npos && f.raw(i).find(';') == std::string_view::npos) return;
  std::vector<Edit> del;
  for (const Span& w : l.call_words) del.push_back({w, ""});
  if (!out_.emit(f, i, del)) runaway(f, i);
}

void Machine::numbered_return(SourceFile& f, std::size_t i, const Line& l, bool in_sub) {
  const auto refuse = [&](std::string_view why) {
    f.report(i, l.call_span, Severity::error, "PP-E708", fmt::format("M99 {}{}", why, context()));
    throw Stop{};
  };
  if (!in_sub)
    refuse("in the main program: LinuxCNC starts the program again from its first line (an endless program, "
           "O codes, \"Fanuc-Style Numbered Programs\"); end the program with M2 or M30");
  if (!frames_.back().numbered)
    refuse("inside an o-word subroutine: LinuxCNC ends one only with endsub or return (the two styles of subprogram "
           "do not mix)");
  if (l.call_other_words) refuse("with other words on its line: put the return on a line of its own");
  if (const SavedState& st = frames_.back().state; st.valid && st.restore) {
    f.report(i, l.call_span, Severity::error, "PP-E709",
             fmt::format("M99 returns from a numbered program that asked for the modal state's restore (M73): not "
                         "followed by this version; restore it with M72 before M99{}",
                         context()));
    throw Stop{};
  }
}

void Machine::numbered_call(SourceFile& f, std::size_t i, const Line& l) {
  const auto refuse = [&](const char* code, const std::string& why) {
    f.report(i, l.call_span, Severity::error, code, why + context());
    throw Stop{};
  };
  if (l.call_other_words)
    refuse("PP-E709", "M98 with other words on its line: the order of the call and the rest of the block is not "
                      "followed by this version; put the call on a line of its own");
  if (!l.call_p) refuse("PP-E702", "M98 without P: give the number of the program to call (M98 P100)");
  // rs274 read_integer_value: a whole number within 0.0001.
  const auto whole = [&](const Code& c, char letter) {
    const double v = value(f, i, l.call_span, c);
    double n = std::floor(v);
    if (v - n > 0.9999) n += 1;
    else if (v - n > 0.0001 || !(std::abs(v) < 1e9))
      refuse("PP-E207", fmt::format("M98 {}{} is not a whole number: LinuxCNC stops here (rs274: \"Non integer value "
                                    "for integer\")", letter, v));
    return static_cast<long long>(n);
  };
  const long long n = whole(*l.call_p, 'P');
  const long long times = l.call_l ? whole(*l.call_l, 'L') : 1;
  if (times < 0) refuse("PP-E702", fmt::format("M98 L{}: the repeat count must be 0 or more", times));
  // The LinuxCNC documentation says L0 does not run the program; rs274 2.9 enters the call level
  // without running it: the caller's next lines run at that level, the next M99 returns to them
  // once more, and an endif, endrepeat or endsub of the caller is refused ("undefined O-word
  // label"). Checked with rs274; neither reading can be followed exactly.
  if (times == 0)
    refuse("PP-E709", "M98 with a repeat count of 0: LinuxCNC 2.9's interpreter does not skip the call cleanly (the "
                      "lines after it run at a new call level, and the next M99 returns to them again); remove the "
                      "call or give it a count of 1 or more");
  const std::string name = fmt::format("o{}", n);
  // rs274 keeps a numbered program once a call found it (a later call from after it finds it too).
  const std::string key = fmt::format("{}:{}", f.index(), name);
  auto it = numbered_programs_.find(key);
  if (it == numbered_programs_.end()) {
    // rs274 looks for the program from the call on, to the end of the file.
    const auto numbered_start = [&](std::size_t k) {
      const Line& d = line(f, k);
      return d.ok && d.kw == Kw::program_number && d.oname == name;
    };
    std::size_t at = i + 1;
    while (at < f.lines() && !numbered_start(at)) ++at;
    if (at == f.lines()) {
      std::size_t before = 0;
      while (before < i && !numbered_start(before)) ++before;
      if (before < i)
        refuse("PP-E708", fmt::format("M98 P{} calls the numbered program O{} of line {}, before the call: LinuxCNC "
                                      "looks for it only after the call (O codes, \"Fanuc-Style Numbered Programs\"); "
                                      "move the program after the main program's end",
                                      n, n, before + 1));
      if (subs_.count(name) != 0)
        refuse("PP-E708", fmt::format("M98 P{} calls '{} sub': LinuxCNC calls an o-word subroutine only with "
                                      "'{} call' (the two styles of subprogram do not mix)",
                                      n, name, name));
      refuse("PP-E704", fmt::format("M98 P{}: no numbered program O{} after this line (an 'O{}' line, its "
                                    "blocks, M99)",
                                    n, n, n));
    }
    std::size_t end = at + 1;
    while (end < f.lines() && !(line(f, end).ok && line(f, end).numbered_return)) ++end;
    if (end == f.lines())
      refuse("PP-E708", fmt::format("the numbered program O{} of line {} has no M99 to return with", n, at + 1));
    it = numbered_programs_.emplace(key, Sub{&f, at, end}).first;
  }
  if (static_cast<int>(frames_.size()) > opt_.max_call_depth)
    refuse("PP-E706", fmt::format("calls nest deeper than {} levels (endless recursion?)", opt_.max_call_depth));
  const Sub s = it->second;
  for (long long k = 0; k < times; ++k) {
    Frame fr;
    fr.numbered = true;
    frames_.push_back(std::move(fr));
    guard_.changed();
    globals_[names_.id("_call_level")] = static_cast<double>(frames_.size() - 1);
    out_.push_call(CallFrame{f.name(), i + 1, fmt::format("M98 P{}", n)});
    execute(*s.file, s.begin + 1, s.end + 1, true);
    out_.pop_call();
    frames_.pop_back();
    globals_[names_.id("_call_level")] = static_cast<double>(frames_.size() - 1);
  }
}

}  // namespace postproc::gcode::resolver::lcnc_run
