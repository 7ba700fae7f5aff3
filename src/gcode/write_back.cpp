// write_back: the rewritten literal program of a resolved program, carried back onto the source
// lines it was executed from (include/postproc/gcode/write_back.hpp).
#include "postproc/gcode/write_back.hpp"

#include <algorithm>
#include <optional>
#include <set>

#include <fmt/format.h>

#include "postproc/gcode/lexer.hpp"
#include "src/gcode/klartext.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode {
namespace {


struct SourceLine {
  std::string_view text, eol;
};

/// Lines as the resolver numbers them: "\r\n", "\n" and "\r" each end one.
std::vector<SourceLine> split_source(std::string_view t) {
  std::vector<SourceLine> lines;
  std::size_t pos = 0;
  while (pos < t.size()) {
    std::size_t end = t.find_first_of("\r\n", pos);
    if (end == std::string_view::npos) {
      lines.push_back({t.substr(pos), {}});
      break;
    }
    std::size_t next = end + 1;
    if (t[end] == '\r' && next < t.size() && t[next] == '\n') ++next;
    lines.push_back({t.substr(pos, end - pos), t.substr(end, next - end)});
    pos = next;
  }
  return lines;
}

std::vector<std::string_view> split_lf(std::string_view t) {
  std::vector<std::string_view> lines;
  std::size_t pos = 0;
  while (pos < t.size()) {
    std::size_t end = t.find('\n', pos);
    if (end == std::string_view::npos) end = t.size();
    lines.push_back(t.substr(pos, end - pos));
    pos = end + 1;
  }
  return lines;
}

bool lex(const Dialect& d, std::string_view text, std::uint64_t line, Block& b) {
  b.clear();
  b.raw = text;
  b.line = line;
  DiagnosticSink quiet(0);
  return lex_block(d, b, LexContext{"", &quiet});
}

/// The index of the `ordinal`-th word named `name` in `b` (case-insensitive), -1 when none.
int nth_word(const Block& b, std::string_view name, int ordinal) {
  for (std::size_t i = 0; i < b.words.size(); ++i)
    if (text::iequals(b.text(b.words[i].name), name) && ordinal-- == 0) return static_cast<int>(i);
  return -1;
}

struct TextEdit {
  std::uint32_t begin = 0, end = 0;  // replaced span (begin == end: an insertion)
  std::string text;
  int word = -1;  // the word replaced, or the word the insertion follows
};

std::string apply_edits(std::string_view raw, const std::vector<TextEdit>& edits) {
  std::string s;
  std::uint32_t pos = 0;
  for (const TextEdit& e : edits) {
    s.append(raw.substr(pos, e.begin - pos));
    s += e.text;
    pos = e.end;
  }
  s.append(raw.substr(pos));
  return s;
}

struct Refusal {
  std::uint32_t column = 1;  // 1-based, in the source line
  std::uint32_t length = 1;
  std::string why;
};

/// One execution of source line `s`: the resolved block `r` was compensated into `out` (one line,
/// or several when the move was subdivided). Returns the text that replaces `s` (lines joined by
/// `eol`), or the reason it cannot.
class LineMapper {
 public:
  explicit LineMapper(const Dialect& d) : d_(d) {}

  std::optional<std::string> map(std::string_view s, std::string_view r, const std::vector<std::string_view>& out,
                                 std::string_view eol, Refusal& why) {
    std::string joined;
    if (out.empty()) {
      why.why = "the rewritten program drops this block, which cannot be carried back onto its source line";
      return std::nullopt;
    }
    if (s == r) {  // the line was not substituted: the compensated lines replace it as they are
      for (std::size_t k = 0; k < out.size(); ++k) {
        if (k > 0) joined += eol;
        joined += out[k];
      }
      return joined;
    }
    const bool lexed = lex(d_, s, 1, bs_) && lex(d_, r, 1, br_) && lex(d_, out[0], 1, bo_);
    if (!lexed) {
      why.why = "the line cannot be lexed again to carry the correction back";
      return std::nullopt;
    }
    if (out.size() > 1)
      for (const Token& t : bs_.tokens)
        if (t.kind == TokenKind::control_flow || t.kind == TokenKind::call) {
          why.column = t.span.begin + 1;
          why.why = fmt::format("the move needs subdivision into {} moves, written as new lines after this one, but "
                                "the line also holds control flow ('{}') that would skip or repeat them",
                                out.size(), bs_.text(t.span));
          return std::nullopt;
        }
    // The compensator replaces the numbers of words and inserts words: align the corrected block
    // with the resolved one word by word and check that this reproduces it exactly.
    std::vector<TextEdit> on_r;
    std::size_t i = 0;
    std::uint32_t prev_out_end = bo_.has_n ? bo_.n_span.end : 0;
    for (std::size_t j = 0; j < bo_.words.size(); ++j) {
      const Word& wo = bo_.words[j];
      const std::string_view ot = bo_.text(wo.span);
      if (i < br_.words.size() && text::iequals(br_.text(br_.words[i].name), bo_.text(wo.name))) {
        const Word& wr = br_.words[i];
        if (br_.text(wr.span) != ot) on_r.push_back({wr.span.begin, wr.span.end, std::string(ot), static_cast<int>(i)});
        ++i;
      } else {
        if (i == 0) {
          why.why = "a word the correction adds has no word before it to follow in the source line";
          return std::nullopt;
        }
        const std::uint32_t at = br_.words[i - 1].span.end;
        on_r.push_back({at, at, std::string(bo_.raw.substr(prev_out_end, wo.span.end - prev_out_end)),
                        static_cast<int>(i - 1)});
      }
      prev_out_end = wo.span.end;
    }
    if (i != br_.words.size() || apply_edits(br_.raw, on_r) != bo_.raw) {
      why.why = "the corrected block cannot be matched word by word with the block as resolved";
      return std::nullopt;
    }
    // The same edits on the source line, word for word (the n-th X of the resolved block is the
    // n-th X of the source line).
    std::vector<TextEdit> on_s;
    for (const TextEdit& e : on_r) {
      const Word& wr = br_.words[static_cast<std::size_t>(e.word)];
      const std::string_view name = br_.text(wr.name);
      int ordinal = 0;
      for (int k = 0; k < e.word; ++k)
        if (text::iequals(br_.text(br_.words[static_cast<std::size_t>(k)].name), name)) ++ordinal;
      const int si = nth_word(bs_, name, ordinal);
      if (si < 0) {
        why.why = fmt::format("the word {} of the block as resolved is not in the source line", br_.text(wr.span));
        return std::nullopt;
      }
      const Word& ws = bs_.words[static_cast<std::size_t>(si)];
      if (e.begin == e.end) {
        on_s.push_back({ws.span.end, ws.span.end, e.text, si});
        continue;
      }
      if (bs_.text(ws.span) != br_.text(wr.span)) {
        why.column = ws.span.begin + 1;
        why.length = std::max<std::uint32_t>(1, ws.span.end - ws.span.begin);
        why.why = fmt::format("{} needs the corrected value {} but is written as '{}' here (as resolved: {}); a "
                              "corrected value cannot be written into an expression or parameter",
                              name, e.text, bs_.text(ws.span), br_.text(wr.span));
        return std::nullopt;
      }
      on_s.push_back({ws.span.begin, ws.span.end, e.text, si});
    }
    std::stable_sort(on_s.begin(), on_s.end(), [](const TextEdit& a, const TextEdit& b) { return a.begin < b.begin; });
    joined = apply_edits(bs_.raw, on_s);
    for (std::size_t k = 1; k < out.size(); ++k) {
      joined += eol;
      joined += out[k];
    }
    return joined;
  }

 private:
  const Dialect& d_;
  Block bs_, br_, bo_;
};

/// What the executions of one source line of the program came to.
struct LineState {
  std::uint64_t runs = 0;       // executions seen so far
  std::uint64_t total = 0;      // executions in all
  bool unchanged = true;        // every execution so far left the line as it is
  bool refused = false;
  std::int64_t rep = -1;        // changed lines: index into replacements (and keys, added)
};

/// A replacement for a message: its lines joined by " | ", at most about 100 characters.
std::string shorten(std::string_view s) {
  std::string t;
  for (std::size_t i = 0; i < s.size() && t.size() < 100; ++i) {
    if (s[i] == '\r') continue;
    if (s[i] == '\n') t += " | ";
    else t += s[i];
  }
  if (t.size() >= 100) t += "...";
  return t;
}

}  // namespace

bool header_waits(const Block& b) {
  // Klartext: BEGIN PGM must stay the program's first block.
  if (b.line <= 3 && !b.tokens.empty() && b.tokens.front().kind == TokenKind::keyword &&
      klartext::verb_of(b) == klartext::Verb::begin_pgm)
    return true;
  bool leading = b.leader || b.raw.empty();
  for (const Token& t : b.tokens)
    leading = leading || t.kind == TokenKind::percent || t.kind == TokenKind::program_number;
  return leading && b.words.empty() && b.line <= 3;
}

WriteBackResult write_back(std::string_view source, std::string_view file, const Dialect& d,
                           const ResolvedProgram& r, std::string_view compensated,
                           const std::vector<std::uint64_t>& line_map, std::string_view header, std::string& out,
                           DiagnosticSink& sink) {
  WriteBackResult res;
  const std::vector<SourceLine> src = split_source(source);
  const std::vector<std::string_view> resolved = split_lf(r.text);
  const std::vector<std::string_view> comp = split_lf(compensated);
  const std::size_t n = r.source_line.size();
  const auto refuse = [&](std::uint64_t line, std::string_view text, const Refusal& why, std::string_view in_file) {
    Diagnostic diag;
    diag.severity = Severity::error;
    diag.code = "PP-E711";
    diag.file = std::string(in_file);
    diag.where = {line, why.column};
    set_source_line(diag, text);
    diag.length = why.length;
    diag.message = why.why + "; give --flatten to write the resolved program as literal moves instead";
    sink.report(std::move(diag));
  };
  if (resolved.size() != n || comp.size() != line_map.size()) {
    refuse(1, src.empty() ? std::string_view() : src.front().text,
           {1, 1, "internal: the resolved or compensated program does not match its line map"}, file);
    return res;
  }
  // The compensated lines of each resolved line (contiguous: the compensator writes in order).
  std::vector<std::uint32_t> first_out(n, 0), count_out(n, 0);
  for (std::size_t k = 0; k < line_map.size(); ++k) {
    const std::uint64_t rl = line_map[k];
    if (rl == 0 || rl > n) continue;  // a header line
    if (count_out[rl - 1]++ == 0) first_out[rl - 1] = static_cast<std::uint32_t>(k);
  }
  std::vector<LineState> state(src.size());
  for (std::size_t i = 0; i < n; ++i)
    if (r.source_file[i] == 0 && r.source_line[i] >= 1 && r.source_line[i] <= src.size())
      ++state[r.source_line[i] - 1].total;
  // Per changed source line: its replacement, the resolved and rewritten text that gave it, and
  // the lines it adds after the source line.
  std::vector<std::string> replacements, keys;
  std::vector<std::uint64_t> added;
  std::set<std::pair<std::uint32_t, std::uint64_t>> refused_elsewhere;
  LineMapper mapper(d);
  std::vector<std::string_view> outs;
  std::string key;
  bool ok = true;
  for (std::size_t i = 0; i < n; ++i) {
    outs.assign(comp.begin() + first_out[i], comp.begin() + first_out[i] + count_out[i]);
    const bool unchanged = outs.size() == 1 && outs.front() == resolved[i];
    const std::uint64_t line = r.source_line[i];
    if (r.source_file[i] != 0 || line < 1 || line > src.size()) {
      if (unchanged || !refused_elsewhere.insert({r.source_file[i], line}).second) continue;
      ok = false;
      const std::string& name = r.source_file[i] < r.files.size() ? r.files[r.source_file[i]] : std::string(file);
      refuse(line, resolved[i],
             {1, 1, fmt::format("this block of the subprogram file {} needs a change, but only the program itself is "
                                "written (the block becomes '{}')",
                                name, shorten(outs.empty() ? std::string_view() : outs.front()))},
             name);
      continue;
    }
    LineState& st = state[line - 1];
    const SourceLine& s = src[line - 1];
    if (st.refused) continue;
    const std::uint64_t run = ++st.runs;
    const auto conflict = [&](std::string_view what) {
      st.refused = true;
      ok = false;
      refuse(line, s.text,
             {1, static_cast<std::uint32_t>(std::max<std::size_t>(1, s.text.size())),
              fmt::format("this line runs {} times (a loop body or a subprogram called more than once) and its "
                          "corrections differ between runs: {}",
                          st.total, what)},
             file);
    };
    if (unchanged) {
      if (!st.unchanged) {
        conflict(fmt::format("the runs before run {} need '{}', run {} none", run,
                             shorten(replacements[static_cast<std::size_t>(st.rep)]), run));
      }
      continue;
    }
    key.assign(resolved[i]);
    key += '\n';
    for (std::string_view o : outs) {
      key += o;
      key += '\n';
    }
    if (!st.unchanged && keys[static_cast<std::size_t>(st.rep)] == key) continue;  // the same as before
    Refusal why;
    const std::optional<std::string> rep = mapper.map(s.text, resolved[i], outs, s.eol.empty() ? "\n" : s.eol, why);
    if (!rep) {
      st.refused = true;
      ok = false;
      refuse(line, s.text, why, file);
      continue;
    }
    // Every line of the replacement must be one the controller reads (LinuxCNC: 252 characters).
    std::optional<std::string> too_long;
    for (std::size_t a = 0; a <= rep->size() && !too_long;) {
      std::size_t e = rep->find('\n', a);
      if (e == std::string::npos) e = rep->size();
      const bool cr = e > a && (*rep)[e - 1] == '\r';
      too_long = line_too_long(d, e - a - (cr ? 1 : 0), cr || (e == rep->size() && !s.eol.empty() && s.eol.front() == '\r'));
      a = e + 1;
    }
    if (too_long) {
      st.refused = true;
      ok = false;
      refuse(line, s.text,
             {1, static_cast<std::uint32_t>(std::max<std::size_t>(1, s.text.size())),
              fmt::format("the corrected line would be longer than the controller reads ({}): shorten the line's "
                          "comment or put it on a line of its own",
                          *too_long)},
             file);
      continue;
    }
    if (run > 1 && st.unchanged) {
      conflict(fmt::format("run {} needs '{}' but the runs before it none", run, shorten(*rep)));
      continue;
    }
    if (!st.unchanged) {
      if (replacements[static_cast<std::size_t>(st.rep)] != *rep)
        conflict(fmt::format("run 1 needs '{}', run {} '{}'", shorten(replacements[static_cast<std::size_t>(st.rep)]),
                             run, shorten(*rep)));
      continue;
    }
    st.unchanged = false;
    st.rep = static_cast<std::int64_t>(replacements.size());
    replacements.push_back(*rep);
    added.push_back(outs.size() - 1);
    keys.push_back(key);
  }
  if (!ok) return res;
  // The header where a flat program gets it: after a leading '%' / program-number line.
  std::size_t header_at = src.size();
  if (!header.empty()) {
    Block b;
    for (std::size_t k = 0; k < src.size(); ++k) {
      lex(d, src[k].text, k + 1, b);
      if (!header_waits(b)) {
        header_at = k;
        break;
      }
    }
  }
  out.clear();
  out.reserve(source.size() + source.size() / 8 + header.size() + 2);
  for (std::size_t k = 0; k < src.size(); ++k) {
    const std::string_view eol = src[k].eol;
    if (k == header_at) {
      out += header;
      out += eol.empty() ? std::string_view("\n") : eol;
    }
    const LineState& st = state[k];
    if (st.unchanged) {
      out += src[k].text;
    } else {
      out += replacements[static_cast<std::size_t>(st.rep)];
      ++res.lines_changed;
      res.lines_added += added[static_cast<std::size_t>(st.rep)];
    }
    out += eol;
  }
  res.ok = true;
  return res;
}

}  // namespace postproc::gcode
