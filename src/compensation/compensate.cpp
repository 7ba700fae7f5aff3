// postproc compensate --mode geometric: every motion's end point is remapped through the machine
// (program_map.hpp), written back in the word's own style, moves whose interpolation would leave
// the intended path are subdivided, and anything that cannot be resolved exactly is refused.
#include "postproc/compensation/compensate.hpp"

#include <filesystem>


#include "postproc/kinematics/hexapod.hpp"
#include "src/compensation/compensator.hpp"

namespace postproc::comp {
namespace detail {
void Compensator::write_end(const Block& b, const Motion& m, gcode::BlockEditor& ed, const Command& out) {
  const WordWriter::Outcome o = writer_.rewrite(b, m, mask_, written_, written_known_, out, ed);
  if (!o.ok) {
    refuse(b, o.column, kRefused, o.why);
    written_known_ = 0;
    return;
  }
  r_.words_changed += o.changed;
  r_.words_inserted += o.inserted;
  written_ = out.c;
  written_known_ = m.known | mask_;
  prev_vector_ = m.tool_vector;
  prev_written_vector_ = out.vector;
}

void Compensator::write_segments(const Block& b, const Motion& m, gcode::BlockEditor& ed,
                                 const std::vector<Command>& pts, const std::vector<double>& fractions,
                                 const Command& out) {
  // The block keeps its words and moves to the first point; the other points follow as new
  // lines of the same motion (inverse-time feeds scaled so the block keeps its duration).
  if (m.words_transformed) {
    // New lines would hold work coordinates where the control reads radius/angle (G16) or mirrored
    // values (G51.1).
    refuse(b, m.column, kRefused,
           "the move needs subdividing but its axis words are not its end point in work coordinates (Fanuc G16 "
           "polar, G51.1 mirror image or G29; or a chamfer or rounding built at its end: Heidenhain RND/CHF, Fanuc "
           ",C/,R, Sinumerik CHF=/RND=); write the block in plain coordinates (a corner as its own move)");
    written_known_ = 0;
    return;
  }
  const std::uint64_t n = pts.size() + 1;
  // Inverse time (G93): piece i takes its share of the move's time, so its F is the block's
  // divided by that share (the piece count for equal pieces).
  const bool g93 = m.feed_mode == gcode::FeedMode::inverse_time;
  const auto scale = [&](std::size_t i) {
    if (!g93) return 0.0;
    if (fractions.size() != pts.size()) return static_cast<double>(n);
    const double from = i == 0 ? 0.0 : fractions[i - 1], to = i < fractions.size() ? fractions[i] : 1.0;
    return 1 / (to - from);
  };
  const WordWriter::Outcome o = writer_.rewrite(b, m, mask_, written_, written_known_, pts.front(), ed, scale(0));
  if (!o.ok) {
    refuse(b, o.column, kRefused, o.why);
    written_known_ = 0;
    return;
  }
  r_.words_changed += o.changed;
  r_.words_inserted += o.inserted;
  const std::size_t first_new = after_.size();
  AxisVector prev = pts.front().c;
  for (std::size_t i = 1; i <= pts.size(); ++i) {
    const Command& p = i < pts.size() ? pts[i] : out;
    std::optional<std::string> line =
        writer_.segment_line(b, m, mask_, prev, p, scale(i));
    if (!line) {
      refuse(b, m.column, kRefused,
             "a segment of this subdivided move cannot be written under the rotary axis's roll-over rule "
             "([axes.…] rollover); program the move incrementally or in shorter steps");
      after_.clear();
      written_known_ = 0;
      return;
    }
    if (!line->empty()) after_.push_back(std::move(*line));
    prev = p.c;
  }
  // A one-shot exact stop (G9) acts at the end of its block's move: it goes with the last piece.
  if (const auto* g = track_.find(gcode::GMeaning::exact_stop);
      g != nullptr && g->def->group == gcode::GGroup::non_modal && after_.size() > first_new) {
    const std::string word(b.text(b.words[g->word].span));
    std::string& last = after_.back();
    const std::string sep = word_separator(b);
    if (!last.empty() && last.back() == '*') last.insert(last.size() - 1, word + sep);
    else last += sep + word;
    // The word and the blanks after it (before it, when it ends the block).
    const gcode::Span w = b.words[g->word].span;
    std::uint32_t from = w.begin, to = w.end;
    while (to < b.raw.size() && (b.raw[to] == ' ' || b.raw[to] == '\t')) ++to;
    if (to == b.raw.size())
      while (from > 0 && (b.raw[from - 1] == ' ' || b.raw[from - 1] == '\t')) --from;
    ed.remove({from, to});
  }
  if (d_.id == gcode::DialectId::heidenhain && !after_.empty() && !unnumbered_warned_ && !opt_.renumbered_after) {
    // Klartext numbers every block; the new lines have none (numbers are renumbered only when asked).
    unnumbered_warned_ = true;
    note(b, m.column, kUnnumberedBlocks,
         "new blocks follow this one without block numbers (a subdivided move or a linearised arc; the TNC numbers "
         "every block): renumber the program before running it — postproc convert --renumber 0,1, or the TNC "
         "editor");
  }
  written_ = out.c;
  written_known_ = m.known | mask_;
  prev_vector_ = m.tool_vector;
  prev_written_vector_ = out.vector;
}

}  // namespace detail

std::string_view to_string(Mode m) {
  switch (m) {
    case Mode::geometric: return "geometric";
    case Mode::contour: return "contour";
    case Mode::all: return "all";
  }
  return "?";
}

std::optional<Mode> parse_mode(std::string_view s) {
  for (Mode m : {Mode::geometric, Mode::contour, Mode::all})
    if (s == to_string(m)) return m;
  return std::nullopt;
}

namespace {

/// The header's text at one of three lengths (0: everything; 1: the machine file by its name, the
/// sha256 still naming it exactly; 2: also the free text and the --set values by count only).
std::string header_text(const machine::Machine& m, const CompensateOptions& opt, int shorter) {
  const std::string file = shorter >= 1 ? std::filesystem::path(m.file).filename().string() : m.file;
  std::string text =
      fmt::format("postproc {} compensate mode={} machine={} sha256={}", opt.tool_version, to_string(opt.mode), file, m.sha256);
  // The controller conventions the corrections were computed under (docs/machine-file.md).
  if (const auto* hex = dynamic_cast<const kin::Hexapod*>(m.nominal.get()))
    text += fmt::format(" hexapod-spin={}", kin::to_string(hex->config().spin));
  if (m.ik_branch != machine::IkBranch::nearest) text += fmt::format(" ik-branch={}", machine::to_string(m.ik_branch));
  for (int a = 0; a < gcode::kAxisCount; ++a)
    if (m.dialect_options.rollover[static_cast<std::size_t>(a)] != gcode::RotaryRollover::off)
      text += fmt::format(" rollover-{}={}", gcode::kAxisLetters[static_cast<std::size_t>(a)],
                          gcode::to_string(m.dialect_options.rollover[static_cast<std::size_t>(a)]));
  if (opt.flatten)
    text += shorter >= 2 ? " flattened" : " flattened=parameters, calls and loops resolved into literal moves";
  if (opt.resolved_in_place && !opt.flatten)
    text += shorter >= 2 ? " resolved-in-place" : " resolved=parameters, calls and loops kept, literal words corrected in place";
  if (shorter >= 2 && !opt.resolve.set.empty())
    text += fmt::format(" set={} values (see the report)", opt.resolve.set.size());
  else
    for (const auto& [name, value] : opt.resolve.set) text += fmt::format(" set {}={}", name, value);
  for (char& c : text)
    if (c == '(' || c == ')' || c == ';') c = '_';
  return text;
}

}  // namespace

std::string header_comment(const gcode::Dialect& d, const machine::Machine& m, const CompensateOptions& opt) {
  // A controller that reads lines up to a length (LinuxCNC: 252 characters) must be able to read
  // the header: it is shortened until it fits (a CR of the end of line counted).
  const std::size_t limit = gcode::max_line_length(d);
  std::string line;
  for (int shorter = 0; shorter <= 2; ++shorter) {
    const std::string text = header_text(m, opt, shorter);
    line = d.paren_comments ? "(" + text + ")" : "; " + text;
    if (limit == 0 || line.size() + 1 <= limit) break;
  }
  return line;
}

std::size_t compensation_header_offset(std::string_view line) {
  // "postproc VERSION compensate mode=" inside a comment ('(' or ';' before it), then sha256=.
  for (std::size_t at = line.find("postproc "); at != std::string_view::npos; at = line.find("postproc ", at + 1)) {
    const std::size_t version_end = line.find(' ', at + 9);
    if (version_end == std::string_view::npos || version_end == at + 9) continue;
    if (line.substr(version_end, 17) != " compensate mode=") continue;
    if (line.find(" sha256=", version_end) == std::string_view::npos) continue;
    const std::string_view before = line.substr(0, at);
    if (before.find('(') == std::string_view::npos && before.find(';') == std::string_view::npos) continue;
    return at;
  }
  return std::string_view::npos;
}

namespace {

/// The header in one line (compensation_header_offset), with its words.
std::optional<CompensationHeader> header_in(std::string_view line, std::uint64_t line_no) {
  const std::size_t h = compensation_header_offset(line);
  if (h == std::string_view::npos) return std::nullopt;
  const auto word = [&](std::string_view key) -> std::string_view {
    const std::size_t k = line.find(key, h);
    if (k == std::string_view::npos) return "?";
    const std::size_t v = k + key.size();
    return line.substr(v, std::min(line.size(), line.find_first_of(" )", v)) - v);
  };
  return CompensationHeader{line_no, static_cast<std::uint32_t>(h + 1), line, word(" compensate mode="),
                            word(" machine=")};
}

}  // namespace

std::optional<CompensationHeader> find_compensation_header(std::string_view program) {
  if (program.find(" compensate mode=") == std::string_view::npos) return std::nullopt;
  std::uint64_t line_no = 1;
  for (std::size_t at = 0; at < program.size(); ++line_no) {
    std::size_t end = program.find('\n', at);
    if (end == std::string_view::npos) end = program.size();
    std::string_view line = program.substr(at, end - at);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (std::optional<CompensationHeader> h = header_in(line, line_no)) return h;
    at = end + 1;
  }
  return std::nullopt;
}

bool warn_servo_precompensated(std::string_view program, std::string_view file, std::string_view command,
                               gcode::DiagnosticSink& sink) {
  const std::optional<CompensationHeader> h = find_compensation_header(program);
  if (!h || (h->mode != "contour" && h->mode != "all")) return false;
  gcode::Diagnostic d;
  d.severity = gcode::Severity::warning;
  d.code = "PP-W622";
  d.file = std::string(file);
  d.where = {h->line, h->column};
  d.message = fmt::format(
      "this program was written by postproc compensate --mode {}: its points lead the servo lag on purpose, so the "
      "contour errors that {} measures against its own points are not those of the part; simulate it against the "
      "original program: postproc simulate {} -m {} --reference ORIGINAL",
      h->mode, command, file, h->machine);
  d.length = 8;  // "postproc"
  gcode::set_source_line(d, h->text);
  sink.report(std::move(d));
  return true;
}

bool refuse_recompensation(std::string_view line, std::uint64_t line_no, std::string_view file,
                           const CompensateOptions& opt, gcode::DiagnosticSink& sink) {
  if (opt.allow_recompensation) return false;
  const std::optional<CompensationHeader> h = header_in(line, line_no);
  if (!h) return false;
  gcode::Diagnostic d;
  d.severity = gcode::Severity::error;
  d.code = "PP-E620";
  d.file = std::string(file);
  d.where = {line_no, h->column};
  d.message = fmt::format(
      "this program was already compensated by postproc (its header names machine file {}): compensating it again "
      "applies the corrections a second time; compensate the original program, or give --allow-recompensation if "
      "a second compensation is intended",
      h->machine);
  gcode::set_source_line(d, line);
  d.length = static_cast<std::uint32_t>(line.size() - (h->column - 1));
  sink.report(std::move(d));
  return true;
}

CompensateResult compensate(gcode::LineReader& in, std::string_view file, const gcode::Dialect& dialect,
                            const machine::Machine& m, const CompensateOptions& opt, io::OutputFile& out,
                            gcode::DiagnosticSink& sink) {
  if (opt.jobs > 1) return detail::compensate_parallel(in, file, dialect, m, opt, out, sink);
  CompensateResult r;
  detail::Compensator c(file, dialect, m, opt, &out, sink, r);
  c.set_reader(&in);
  const gcode::ProgramStats st = gcode::run_program(in, dialect, file, c.collector(), c);
  c.finish();
  r.bytes_in = st.bytes;
  return r;
}

}  // namespace postproc::comp
