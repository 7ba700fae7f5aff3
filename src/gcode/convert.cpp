#include "postproc/gcode/convert.hpp"

#include <string>
#include <vector>

#include <fmt/format.h>

#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/program.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {
namespace {

/// A replacement of the bytes in `span` by `text`.
struct Edit {
  Span span;
  std::string text;
};

/// Applies sorted, non-overlapping edits to `raw`.
void render(std::string_view raw, std::vector<Edit>& edits, std::string& out) {
  std::sort(edits.begin(), edits.end(), [](const Edit& a, const Edit& b) { return a.span.begin < b.span.begin; });
  std::uint32_t at = 0;
  for (const Edit& e : edits) {
    out.append(raw.substr(at, e.span.begin - at));
    out.append(e.text);
    at = e.span.end;
  }
  out.append(raw.substr(at));
}

bool is_space(char c) { return c == ' ' || c == '\t'; }

class Converter final : public BlockVisitor {
 public:
  Converter(std::string_view file, const ConvertOptions& opt, io::OutputFile& out, DiagnosticSink& sink)
      : file_(file), opt_(opt), out_(out), sink_(sink) {}

  void block(const Block& b, std::span<const Motion>, bool) override {
    ++result.blocks;
    if (opt_.identity()) {
      write(b.raw, b.eol);
      return;
    }
    edits_.clear();
    bool had_content = !b.empty() || b.block_delete;
    if (opt_.strip_comments) strip_comments(b);
    if (opt_.renumber_start) renumber(b);
    if (edits_.empty()) {
      write(b.raw, b.eol);
      return;
    }
    line_.clear();
    render(b.raw, edits_, line_);
    // Trailing whitespace left by a removed comment goes too; a line that held only comments goes.
    while (!line_.empty() && is_space(line_.back())) line_.pop_back();
    if (had_content && line_.empty()) {
      ++result.removed_blocks;
      return;
    }
    ++result.changed_blocks;
    write(line_, b.eol);
  }

  ConvertResult result;

 private:
  void write(std::string_view raw, std::string_view eol) {
    buffer_.append(raw);
    buffer_.append(eol);
    if (buffer_.size() > (1u << 20)) flush();
  }

 public:
  void flush() {
    out_.write(buffer_);
    buffer_.clear();
  }

 private:
  void strip_comments(const Block& b) {
    for (const Token& t : b.tokens) {
      if (t.kind != TokenKind::paren_comment && t.kind != TokenKind::line_comment) continue;
      Span s = t.span;
      while (s.begin > 0 && is_space(b.raw[s.begin - 1])) --s.begin;  // the separating blank goes too
      edits_.push_back({s, ""});
    }
  }

  void renumber(const Block& b) {
    for (const Token& t : b.tokens) {
      // Jumps name sequence numbers; renumbering would retarget them.
      if (t.kind == TokenKind::control_flow || t.kind == TokenKind::label) {
        refuse(b, t.span, "the program jumps to sequence numbers or labels (GOTO/IF/WHILE/M99 P); renumbering "
                          "would change where it jumps");
        return;
      }
    }
    for (const Word& w : b.words)
      if ((w.letter == 'M' && w.number == 99) || (w.letter == 'G' && w.number >= 70 && w.number <= 73 &&
                                                   b.words.size() > 1 && has_letter(b, 'P') && has_letter(b, 'Q'))) {
        refuse(b, w.span, "the block refers to sequence numbers (M99 P / G70–G73 P Q); renumbering would change "
                          "their targets");
        return;
      }
    if (!b.has_n) return;
    const Span digits{b.n_span.begin + 1, b.n_span.end};
    const std::string_view old = b.text(digits);
    std::string num = fmt::format("{}", next_n_);
    // Keep the source's zero padding (N0010 stays four digits wide).
    if (!old.empty() && old[0] == '0' && num.size() < old.size()) num.insert(0, old.size() - num.size(), '0');
    edits_.push_back({digits, std::move(num)});
    next_n_ += opt_.renumber_step;
  }

  static bool has_letter(const Block& b, char L) {
    for (const Word& w : b.words)
      if (w.letter == L) return true;
    return false;
  }

  void refuse(const Block& b, Span s, std::string why) {
    const LexContext ctx{file_, &sink_};
    report_at(ctx, b, s, Severity::error, "PP-E501", fmt::format("--renumber refused: {}", why));
  }

  std::string_view file_;
  const ConvertOptions& opt_;
  io::OutputFile& out_;
  DiagnosticSink& sink_;
  std::vector<Edit> edits_;
  std::string line_, buffer_;
  std::uint64_t next_n_ = 0;

 public:
  void start() { next_n_ = opt_.renumber_start.value_or(0); }
};

}  // namespace

ConvertResult convert(LineReader& in, std::string_view file, const Dialect& dialect, const ConvertOptions& opt,
                      io::OutputFile& out, DiagnosticSink& sink) {
  Converter c(file, opt, out, sink);
  c.start();
  const ProgramStats st = run_program(in, dialect, file, sink, c);
  c.flush();
  c.result.bytes_in = st.bytes;
  return c.result;
}

}  // namespace postproc::gcode
