#pragma once
// The Fanuc macro B resolver's run-time state and its interpreter class (fanuc.cpp: calls, control
// flow and the run; fanuc_statements.cpp: line plans, variables and expression evaluation).
// Internal to src/gcode/resolve.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "src/gcode/text.hpp"
#include "fanuc_expr.hpp"
#include "support.hpp"

namespace postproc::gcode::resolver::fanuc_run {


using namespace fanuc_expr;

// ---------------------------------------------------------------------------------------------
// Line plans: what a line does, parsed once per (file, line).

enum class ItemKind : std::uint8_t { word, assign, if_goto, if_then, while_do, do_loop, end_loop, go_to, program_number, percent, other };

struct Item {
  ItemKind kind = ItemKind::other;
  Span span;             // the whole item
  Span value;            // word: its value span
  char letter = 0;       // word letter
  bool literal = true;   // word: a literal number
  double number = 0;     // word: literal value; DO/END: loop number; program number
  std::int32_t e1 = -1;  // word value / rhs / condition / goto target
  std::int32_t e2 = -1;  // assignment target (a var node) / THEN target
  std::int32_t e3 = -1;  // THEN value
};

struct LinePlan {
  bool plain = true;  // nothing to evaluate: emitted as is
  bool statement = false;
  std::vector<Item> items;
  ExprPool pool;
  Span n_span, delete_span;
  bool has_n = false, block_delete = false;
  std::uint32_t raw_size = 0;
  std::optional<std::size_t> loop_end;  // WHILE/DO: the line of the matching END
  std::optional<Failure> error;          // a syntax error, reported when the line runs
};

struct Loop {
  int id = 0;
  std::size_t begin = 0, end = 0;  // the WHILE/DO line and its END line
};

struct Var {
  double v = 0;
  bool set = false;
};
using Locals = std::array<Var, 34>;

struct Frame {
  SourceFile* file = nullptr;
  std::size_t start = 0;        // the sub's first line (its O line when it has one)
  SourceFile* ret_file = nullptr;
  std::size_t ret_line = 0;     // the caller's call line
  int repeats_left = 0;
  bool macro = false;           // G65: own locals
  bool modal = false;           // called by a G66 modal call
  Locals args{};                // G65: the arguments (re-set on each repetition)
  std::vector<Loop> loops;
};

struct Stop {};  // the run ended (normally or after an error)

class Runner {
 public:
  Runner(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r)
      : files_(files), out_(out), opt_(opt), sink_(sink), r_(r) {}

  void run();

 private:
  // --- plans
  LinePlan* plan(SourceFile& f, std::size_t line);
  void compile(SourceFile& f, std::size_t line, LinePlan& p);
  void parse_statement(const Block& b, const Token& t, LinePlan& p, Item& it);

  // --- evaluation
  Value eval(const LinePlan& p, std::int32_t n);
  Value read_var(double index, Span span);
  void write_var(const LinePlan& p, double index, Value v, Span span);
  int var_number(double index, Span span) const;
  [[noreturn]] void arith_error(std::string msg, Span span) const { throw Failure{"PP-E707", std::move(msg), span}; }
  bool cond(const LinePlan& p, std::int32_t n) { return eval(p, n).v != 0; }

  // --- execution
  void step();
  void call(bool macro, double program, int repeats, const Locals& args, const LinePlan& p, const Item& at,
            std::string callee);
  void do_return(std::optional<double> to_n, Span span);
  std::optional<std::size_t> find_end(SourceFile& f, std::size_t from, int id, Span span);
  std::size_t goto_n(SourceFile& f, double n, std::size_t from, Span span);
  struct Target {
    SourceFile* file;
    std::size_t line;
  };
  std::optional<Target> find_program(double number);
  std::optional<std::size_t> program_line(SourceFile& f, double number);
  void emit(SourceFile& f, std::size_t line, std::span<const Edit> edits);
  void finish_tape();
  void fail(const Failure& e);
  void report(Span span, Severity sev, std::string_view code, std::string message);

  FileSet& files_;
  Emitter& out_;
  const ResolveOptions& opt_;
  DiagnosticSink& sink_;
  ResolvedProgram& r_;
  LoopGuard guard_{opt_};

  std::vector<std::vector<std::unique_ptr<LinePlan>>> plans_;               // [file][line]
  std::vector<std::unique_ptr<std::unordered_map<std::uint64_t, std::size_t>>> programs_;  // [file] O number → line
  std::vector<Frame> frames_;
  /// A G66 modal call in effect: the macro every block with a move calls after it.
  struct ModalCall {
    double program = 0;
    int repeats = 1;
    Locals args{};
  };
  std::optional<ModalCall> modal_;
  std::string modal_callee_;
  std::vector<Locals> locals_;
  std::array<Var, 1000> common_{};  // #100–#999
  std::unordered_map<int, double> system_;  // system variables written by the program
  SourceFile* file_ = nullptr;
  std::size_t pc_ = 0;
  std::vector<Edit> edits_;
  std::vector<std::uint8_t> action_;  // per item: 0 keep, 1 delete, 2 replace
  std::vector<std::string> text_;
  std::vector<double> vals_;
  bool warned_block_delete_ = false;
  bool inch_ = false;  // G20 seen (least input increment 0.0001 in instead of 0.001 mm)
};

// ---------------------------------------------------------------------------------------------

}  // namespace postproc::gcode::resolver::fanuc_run
