// libFuzzer target: line reader + lexer of every dialect over arbitrary bytes.
//
// Besides "no crash, no sanitizer report, no exception", it checks the invariants the lossless
// writer relies on, and traps when one is broken so that the fuzzer keeps the input:
//   1. the lines' raw + eol bytes concatenate back to the input exactly;
//   2. raw never contains an end-of-line byte, eol is "\n", "\r\n", "\r", or "" on the last line;
//   3. every span of a block (words, their name and value, tokens, their name, N word, block
//      delete) lies within raw;
//   4. words are non-overlapping and in increasing order, and so are tokens.

#include <cstddef>
#include <cstdint>
#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/gcode/block.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/interpreter.hpp"
#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/line_reader.hpp"

namespace {

namespace gc = postproc::gcode;

/// Stops the run at the failed invariant; the trap is what libFuzzer and the replayer catch.
[[gnu::always_inline]] inline void check(bool ok) {
  if (!ok) __builtin_trap();
}

bool within(gc::Span s, std::size_t size) { return s.begin <= s.end && s.end <= size; }
bool inside(gc::Span inner, gc::Span outer) { return outer.begin <= inner.begin && inner.end <= outer.end; }

/// Invariants 3 and 4 for one lexed block.
void check_spans(const gc::Block& b) {
  const std::size_t n = b.raw.size();
  if (b.has_n) check(within(b.n_span, n));
  if (b.block_delete) check(within(b.block_delete_span, n));
  for (std::size_t i = 0; i < b.words.size(); ++i) {
    const gc::Word& w = b.words[i];
    check(within(w.span, n));
    check(inside(w.name, w.span));
    check(inside(w.value, w.span));
    if (i > 0) check(b.words[i - 1].span.end <= w.span.begin);
  }
  for (std::size_t i = 0; i < b.tokens.size(); ++i) {
    const gc::Token& t = b.tokens[i];
    check(within(t.span, n));
    // An unused name is the empty span {0, 0}; a used one must name part of the token.
    if (t.name.size() > 0) check(inside(t.name, t.span));
    if (i > 0) check(b.tokens[i - 1].span.end <= t.span.begin);
  }
}

/// Checks every resolved motion for finite values where they are known.
class NullSink final : public gc::MotionSink {
 public:
  void motion(const gc::Motion& m, const gc::Block&) override {
    for (int a = 0; a < gc::kAxisCount; ++a)
      if ((m.known >> a) & 1u) check(std::isfinite(m.end[a]));  // out-of-range values are refused (PP-E205)
    check(m.line >= 1);
  }
};

/// The four dialects, built once: building them per input would dominate the run time.
const std::vector<gc::Dialect>& dialects() {
  static const std::vector<gc::Dialect> all = [] {
    std::vector<gc::Dialect> v;
    for (std::string_view name : {"fanuc", "siemens", "linuxcnc", "heidenhain-iso"}) v.push_back(*gc::make_dialect(name));
    return v;
  }();
  return all;
}

/// Reads `input` line by line, lexing each block with `dialect`; checks invariants 1 to 4.
void run_dialect(std::string_view input, const gc::Dialect& dialect) {
  gc::DiagnosticSink sink;
  const gc::LexContext ctx{"fuzz", &sink};
  gc::Interpreter interp(dialect, "fuzz", sink);
  NullSink motions;
  gc::LineReader reader(input);
  gc::Block b;  // reused, as the streaming commands do, so stale state would show up
  std::string joined;
  joined.reserve(input.size());
  std::string_view line, eol;
  bool saw_empty_eol = false;
  while (reader.next(line, eol)) {
    check(!saw_empty_eol);  // only the last line may lack an end of line
    check(line.find_first_of("\r\n") == std::string_view::npos);
    check(eol.empty() || eol == "\n" || eol == "\r\n" || eol == "\r");
    saw_empty_eol = eol.empty();
    b.clear();
    b.raw = line;
    b.eol = eol;
    b.line = reader.line_number();
    gc::lex_block(dialect, b, ctx);
    check(b.raw.data() == line.data() && b.raw.size() == line.size());  // the lexer must not re-point raw
    check_spans(b);
    interp.execute(b, motions);  // the interpreter must survive whatever the lexer accepted
    joined.append(b.raw);
    joined.append(b.eol);
  }
  check(joined == input);
  check(reader.bytes_read() == input.size());
  // Formatting exercises the caret display (column and length arithmetic) under the sanitizers.
  for (const gc::Diagnostic& d : sink.stored()) {
    const std::string text = gc::format(d);
    check(!text.empty());
  }
}

}  // namespace

/// libFuzzer entry point; also called by replay_main.cpp for the corpus and the saved crashes.
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  for (const gc::Dialect& d : dialects()) run_dialect(input, d);
  return 0;
}
