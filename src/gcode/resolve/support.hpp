#pragma once
// Shared machinery of the dialect resolvers (include/postproc/gcode/resolve.hpp): source files
// lexed on demand, the emitter that writes the resolved program with its line and call-stack
// maps, and number formatting.
#include <bit>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "postproc/gcode/block.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/resolve.hpp"

namespace postproc::gcode::resolver {

/// One program or subprogram file: its lines, lexed on demand. A line lexed a second time (a loop
/// body, a subprogram) is kept lexed; others are lexed into a scratch block.
class SourceFile {
 public:
  SourceFile(std::string name, std::string text, std::uint32_t index, const Dialect& d, DiagnosticSink& sink);
  SourceFile(const SourceFile&) = delete;
  SourceFile& operator=(const SourceFile&) = delete;

  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] std::uint32_t index() const { return index_; }  ///< into ResolvedProgram::files
  [[nodiscard]] const Dialect& dialect() const { return d_; }
  [[nodiscard]] std::size_t lines() const { return lines_.size(); }
  [[nodiscard]] std::string_view raw(std::size_t i) const { return lines_[i]; }
  /// Line i ends in a CR (a CRLF or CR-only end of line).
  [[nodiscard]] bool ends_in_cr(std::size_t i) const {
    const std::size_t end = static_cast<std::size_t>(lines_[i].data() - text_.data()) + lines_[i].size();
    return end < text_.size() && text_[end] == '\r';
  }
  /// The lexed block of line i (0-based). Valid until the next call of block() on this file
  /// unless the line is cached (a line asked for twice is cached from then on).
  const Block& block(std::size_t i);
  /// False when line i had a lexical error (reported once, on its first lexing).
  [[nodiscard]] bool lexed_ok(std::size_t i) { (void)block(i); return ok_[i] != 0; }
  /// First line index at or after `from` (forward) or at or before `from` (backward) whose N
  /// number equals `n`; nullopt when none.
  [[nodiscard]] std::optional<std::size_t> find_n(double n, std::size_t from, bool forward);
  [[nodiscard]] const LexContext& context() const { return ctx_; }

  /// Reports at a span of line i's block.
  void report(std::size_t i, Span span, Severity sev, std::string_view code, std::string message);

 private:
  std::string name_, text_;
  std::uint32_t index_;
  const Dialect& d_;
  LexContext ctx_;
  std::vector<std::string_view> lines_;
  std::vector<std::uint8_t> seen_, ok_;  // ok_: 1 lexed without error
  std::vector<std::unique_ptr<Block>> cache_;
  Block scratch_;
  std::size_t scratch_line_ = static_cast<std::size_t>(-1);
  std::vector<std::pair<double, std::size_t>> n_index_;  // built on first find_n
  bool n_built_ = false;
};

/// A replacement inside one block's raw text: `span` becomes `text` (empty text deletes).
struct Edit {
  Span span;
  std::string text;
};

/// Writes the resolved program and its maps.
class Emitter {
 public:
  explicit Emitter(ResolvedProgram& out, const ResolveOptions& opt) : out_(out), opt_(opt) {
    out_.stacks.emplace_back();  // 0: the main program
  }
  /// Emits line `line` (0-based) of `f` with `edits` applied (sorted by span, not overlapping).
  /// The line is dropped when only blanks (and no comment) are left. Returns false once
  /// max_blocks is exceeded (the caller reports PP-E705 and stops).
  bool emit(SourceFile& f, std::size_t line, std::span<const Edit> edits);
  void push_call(CallFrame frame);
  void pop_call();
  [[nodiscard]] std::size_t depth() const { return frames_.size(); }
  /// "reached through o100 call at line 12 → …" for messages; empty at the top level.
  [[nodiscard]] std::string where() const;
  [[nodiscard]] std::uint64_t emitted() const { return out_.source_line.size(); }

 private:
  std::uint32_t stack_id();
  ResolvedProgram& out_;
  const ResolveOptions& opt_;
  std::vector<CallFrame> frames_;
  std::map<std::vector<std::pair<std::string, std::uint64_t>>, std::uint32_t> interned_;
  std::uint32_t current_ = 0;
  bool current_valid_ = true;
  std::string line_;
};

/// `v` converted to the integer type T, saturating at T's limits (NaN gives 0): a program value
/// used as a count, an id or a program number never converts with undefined behaviour.
template <class T>
[[nodiscard]] T saturate(double v) {
  if (!(v == v)) return T{0};
  if (v <= static_cast<double>(std::numeric_limits<T>::min())) return std::numeric_limits<T>::min();
  if (v >= static_cast<double>(std::numeric_limits<T>::max())) return std::numeric_limits<T>::max();
  return static_cast<T>(v);
}

/// Endless-loop detection shared by the resolvers (PP-E705). The runner calls step() for every line
/// it executes, changed() whenever its state changes (a variable takes a new value, a call or
/// return, a loop counter moves) and back_jump() whenever control goes back to an earlier line of
/// the same file and call level (a loop's next pass, a GOTO back).
class LoopGuard {
 public:
  explicit LoopGuard(const ResolveOptions& opt) : max_silent_(opt.max_silent_lines) {}
  /// One executed line; `emitted` = blocks written so far. False once more than
  /// ResolveOptions::max_silent_lines lines ran in a row without writing a block.
  [[nodiscard]] bool step(std::uint64_t emitted) {
    if (emitted != last_emitted_) {
      last_emitted_ = emitted;
      silent_ = 0;
    }
    return ++silent_ <= max_silent_;
  }
  void changed() { ++generation_; }
  /// Variable `key` went from `from` to `to` (value_added: it did not exist). Values are tracked as
  /// a hash of every variable's value rather than as progress, so that a pass which leaves each
  /// variable as it found it (0 → 1 → 0) is still caught at the loop's head. Keys: numbered_key,
  /// named_key.
  void value_changed(std::uint64_t key, double from, double to) { values_ ^= mix(key, from) ^ mix(key, to); }
  void value_added(std::uint64_t key, double to) { values_ ^= mix(key, to); }
  [[nodiscard]] static std::uint64_t numbered_key(int n) { return static_cast<std::uint64_t>(static_cast<std::uint32_t>(n)); }
  /// A named variable: global (depth 0) or local to the call `depth` levels deep. A call's locals
  /// stay in the hash when it returns; as a call or return advances the generation, that can only
  /// hide an endless loop across calls, never flag a loop that ends.
  [[nodiscard]] static std::uint64_t named_key(int id, std::size_t depth) {
    return (std::uint64_t{1} << 63) | (static_cast<std::uint64_t>(depth & 0x7fffffffu) << 32) |
           static_cast<std::uint32_t>(id);
  }
  /// False when the program comes back to line `target` of file `file` at call depth `depth` with
  /// no state changed since it last came back there: the resolution is deterministic, so it would
  /// run the same lines and write the same blocks forever.
  [[nodiscard]] bool back_jump(std::uint32_t file, std::size_t depth, std::size_t target);
  /// "N lines executed without writing a block" / the no-progress text, for PP-E705 messages.
  [[nodiscard]] std::string silent_message() const;
  [[nodiscard]] static std::string no_progress_message();

 private:
  /// A 64-bit hash of (key, value); -0 and +0 hash alike, as they compare equal.
  [[nodiscard]] static std::uint64_t mix(std::uint64_t key, double v) {
    std::uint64_t x = std::bit_cast<std::uint64_t>(v == 0 ? 0.0 : v) ^ (key * 0x9E3779B97F4A7C15ull);
    x ^= x >> 30;
    x *= 0xBF58476D1CE4E5B9ull;
    x ^= x >> 27;
    x *= 0x94D049BB133111EBull;
    return x ^ (x >> 31);
  }
  std::uint64_t max_silent_;
  std::uint64_t silent_ = 0, last_emitted_ = 0, generation_ = 0, values_ = 0;
  /// Loop head → (generation, value hash) when last there.
  std::unordered_map<std::uint64_t, std::pair<std::uint64_t, std::uint64_t>> heads_;
};

/// A value as the resolved text writes it: no exponent, up to 10 decimals, trailing zeros
/// removed. Whole values keep a point for length/angle/feed letters (`X100.`: Fanuc would read
/// `X100` as increments) and none for code letters (G M T H D N O P L E).
[[nodiscard]] std::string format_value(double v, char letter);
/// Expressions nest at most this deep (brackets, function calls, unary operators, indirect
/// variables, operands of a chain of binary operators): deeper ones are refused (PP-E712) long
/// before the parser's or the evaluator's recursion could exhaust the stack.
inline constexpr int kMaxExpressionDepth = 256;
/// The message of PP-E712.
[[nodiscard]] std::string too_deep_message();
/// Counts one level of expression nesting while alive (the parsers' recursion guard).
class Nesting {
 public:
  explicit Nesting(int& depth) : depth_(++depth) {}
  ~Nesting() { --depth_; }
  Nesting(const Nesting&) = delete;
  Nesting& operator=(const Nesting&) = delete;
  [[nodiscard]] bool too_deep() const { return depth_ > kMaxExpressionDepth; }

 private:
  int& depth_;
};

/// True when `v` converts to a 64-bit integer exactly enough for the integer operators (MOD, DIV,
/// bitwise AND/OR/XOR, BCD): finite and within ±2^53 (false for NaN).
[[nodiscard]] inline bool integer_range(double v) { return v >= -9007199254740992.0 && v <= 9007199254740992.0; }

/// "more than N blocks or M MiB of resolved program" (the limits of PP-E705).
[[nodiscard]] std::string runaway_limits(const ResolveOptions& opt);

/// True when `b` holds anything a resolver evaluates: an assignment, control flow, declaration
/// or label token, or a word whose value is an expression or parameter.
[[nodiscard]] bool block_has_statements(const Block& b);

// Per-dialect resolvers (src/gcode/resolve/<dialect>.cpp). `main` is files[0]; `load` finds a
// subprogram file by name in opt.search_dirs and adds it to the program's files.
class FileSet {
 public:
  FileSet(ResolvedProgram& out, const Dialect& d, const ResolveOptions& opt, DiagnosticSink& sink)
      : out_(out), d_(d), opt_(opt), sink_(sink) {}
  SourceFile& add(std::string name, std::string text);
  /// The first of `candidates` (file names, e.g. "probe.ngc", "O2000", "O2000.nc") that exists in
  /// one of the search folders, loaded; nullptr when none. Cached by name.
  SourceFile* find(const std::vector<std::string>& candidates);
  [[nodiscard]] SourceFile& main() { return *files_.front(); }

 private:
  ResolvedProgram& out_;
  const Dialect& d_;
  const ResolveOptions& opt_;
  DiagnosticSink& sink_;
  std::vector<std::unique_ptr<SourceFile>> files_;
  std::map<std::string, SourceFile*> by_name_;
};

void resolve_linuxcnc(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r);
void resolve_fanuc(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r);
void resolve_siemens(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r);
void resolve_heidenhain(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink,
                        ResolvedProgram& r);
/// True when a lexed Klartext block holds anything the resolver evaluates (Q parameters, FN, labels, calls).
[[nodiscard]] bool klartext_needs(const Block& b);

}  // namespace postproc::gcode::resolver
