#pragma once
// Shared helpers of the unit tests: lex one block, run a whole program from memory, temp folders.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <unistd.h>

#include "postproc/gcode/block.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/gcode/program.hpp"
#include "postproc/gcode/resolve.hpp"

namespace pptest {

namespace gc = postproc::gcode;
namespace fs = std::filesystem;

/// Tests write whole numbers like X10 meaning 10 mm, so Fanuc reads them calculator-style unless a
/// test asks for another integer input (see Interpreter.FanucIntegerInput).
inline gc::Dialect dialect(std::string_view name, bool lathe = false,
                           gc::Dialect::IntegerInput integer_input = gc::Dialect::IntegerInput::calculator) {
  gc::DialectOptions o;
  o.lathe = lathe;
  o.integer_input = integer_input;
  auto d = gc::make_dialect(name, o);
  if (!d) throw std::runtime_error("unknown dialect");
  return *d;
}

/// One lexed block. Not movable: `block.raw` views `text`.
struct Lexed {
  Lexed(const gc::Dialect& d, std::string t, std::uint64_t line = 1) : text(std::move(t)) {
    block.raw = text;
    block.line = line;
    ok = gc::lex_block(d, block, gc::LexContext{"t.nc", &sink});
  }
  Lexed(const Lexed&) = delete;
  Lexed& operator=(const Lexed&) = delete;

  [[nodiscard]] std::string_view of(gc::Span s) const { return block.text(s); }
  [[nodiscard]] std::vector<std::string> words() const {
    std::vector<std::string> out;
    for (const auto& w : block.words) out.emplace_back(of(w.span));
    return out;
  }
  [[nodiscard]] std::vector<std::string> tokens() const {
    std::vector<std::string> out;
    for (const auto& t : block.tokens) out.emplace_back(of(t.span));
    return out;
  }
  [[nodiscard]] std::vector<std::string> codes() const {
    std::vector<std::string> out;
    for (const auto& d : sink.stored()) out.push_back(d.code);
    return out;
  }

  std::string text;
  gc::Block block;
  gc::DiagnosticSink sink;
  bool ok = false;
};

/// True when the block's spans are ordered, disjoint and every byte outside them is a blank, i.e.
/// the raw text is exactly the spans plus blanks between them.
inline ::testing::AssertionResult covers_raw(const gc::Block& b) {
  std::vector<gc::Span> spans;
  if (b.block_delete) spans.push_back(b.block_delete_span);
  if (b.has_n) spans.push_back(b.n_span);
  for (const auto& w : b.words) spans.push_back(w.span);
  for (const auto& t : b.tokens) spans.push_back(t.span);
  std::sort(spans.begin(), spans.end(), [](gc::Span a, gc::Span c) { return a.begin < c.begin; });
  std::uint32_t at = 0;
  std::string rebuilt;
  for (const auto& s : spans) {
    if (s.begin < at || s.end < s.begin || s.end > b.raw.size())
      return ::testing::AssertionFailure() << "span [" << s.begin << "," << s.end << ") overlaps or is outside";
    for (std::uint32_t k = at; k < s.begin; ++k)
      if (b.raw[k] != ' ' && b.raw[k] != '\t')
        return ::testing::AssertionFailure() << "byte " << k << " ('" << b.raw[k] << "') is in no span";
    rebuilt.append(b.raw.substr(at, s.begin - at));
    rebuilt.append(b.raw.substr(s.begin, s.size()));
    at = s.end;
  }
  for (std::uint32_t k = at; k < b.raw.size(); ++k)
    if (b.raw[k] != ' ' && b.raw[k] != '\t')
      return ::testing::AssertionFailure() << "trailing byte " << k << " is in no span";
  rebuilt.append(b.raw.substr(at));
  if (rebuilt != b.raw) return ::testing::AssertionFailure() << "rebuilt text differs";
  return ::testing::AssertionSuccess();
}

/// The weaker invariants of a block with lexical errors (as the fuzz target checks): every span lies
/// in raw, and words and tokens are each ordered and disjoint.
inline ::testing::AssertionResult spans_within(const gc::Block& b) {
  const auto n = b.raw.size();
  const auto in = [n](gc::Span s) { return s.begin <= s.end && s.end <= n; };
  if (b.has_n && !in(b.n_span)) return ::testing::AssertionFailure() << "N span outside raw";
  if (b.block_delete && !in(b.block_delete_span)) return ::testing::AssertionFailure() << "'/' span outside raw";
  for (std::size_t i = 0; i < b.words.size(); ++i) {
    const auto& w = b.words[i];
    if (!in(w.span) || w.name.begin < w.span.begin || w.value.end > w.span.end)
      return ::testing::AssertionFailure() << "word " << i << " outside raw or its span";
    if (i > 0 && b.words[i - 1].span.end > w.span.begin) return ::testing::AssertionFailure() << "words overlap";
  }
  for (std::size_t i = 0; i < b.tokens.size(); ++i) {
    if (!in(b.tokens[i].span)) return ::testing::AssertionFailure() << "token " << i << " outside raw";
    if (i > 0 && b.tokens[i - 1].span.end > b.tokens[i].span.begin)
      return ::testing::AssertionFailure() << "tokens overlap";
  }
  return ::testing::AssertionSuccess();
}

/// What a run leaves behind: its motions and diagnostics, with lookups.
struct RunOutput : gc::BlockVisitor {
  void block(const gc::Block&, std::span<const gc::Motion> ms, bool lexed_ok) override {
    for (const auto& m : ms) motions.push_back(m);
    if (!lexed_ok) ++lex_errors;
  }
  [[nodiscard]] bool has(std::string_view code) const { return sink.per_code().count(std::string(code)) > 0; }
  [[nodiscard]] const gc::Diagnostic* find(std::string_view code) const {
    for (const auto& d : sink.stored())
      if (d.code == code) return &d;
    return nullptr;
  }
  [[nodiscard]] std::string all_codes() const {
    std::string s;
    for (const auto& d : sink.stored()) s += d.code + "@" + std::to_string(d.where.line) + ":" +
                                             std::to_string(d.where.column) + " ";
    return s;
  }
  /// The motion from source line `line` (the last one if several).
  [[nodiscard]] const gc::Motion* at_line(std::uint64_t line) const {
    const gc::Motion* found = nullptr;
    for (const auto& m : motions)
      if (m.line == line) found = &m;
    return found;
  }

  gc::DiagnosticSink sink;
  std::vector<gc::Motion> motions;
  int lex_errors = 0;
};

/// A whole program run through reader, lexer and interpreter from memory.
struct Program : RunOutput {
  Program(const gc::Dialect& d, std::string program, gc::InterpreterOptions opt = {}) : text(std::move(program)) {
    gc::LineReader reader{std::string_view(text)};
    stats = gc::run_program(reader, d, "t.nc", sink, *this, opt);
  }
  std::string text;
  gc::ProgramStats stats;
};

/// A program run as `postproc check` runs it: the resolver (parameters, variables, control flow,
/// subprograms), then the interpreter.
struct ResolvedProgram : RunOutput {
  ResolvedProgram(const gc::Dialect& d, std::string program, gc::ResolveOptions opt = {}) : text(std::move(program)) {
    gc::run_program_text(text, d, "t.nc", sink, *this, opt);
  }
  std::string text;
};

/// Expects a diagnostic `code` (the first one stored) at line:column.
template <class Run>
void expect_diag_at(const Run& r, std::string_view code, std::uint64_t line, std::uint32_t column) {
  const gc::Diagnostic* d = r.find(code);
  ASSERT_NE(d, nullptr) << "no " << code << "; got " << r.all_codes();
  EXPECT_EQ(d->where.line, line) << code;
  EXPECT_EQ(d->where.column, column) << code;
}

/// A fresh folder under the system temp dir, removed with its contents at the end of the test.
class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    path_ = fs::temp_directory_path() /
            ("postproc-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  [[nodiscard]] const fs::path& path() const { return path_; }
  [[nodiscard]] std::string file(const std::string& name) const { return (path_ / name).string(); }
  [[nodiscard]] std::vector<std::string> entries() const {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(path_)) out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  fs::path path_;
};

inline void write_file(const std::string& path, std::string_view bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline std::string read_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

}  // namespace pptest
