#pragma once
// The LinuxCNC (rs274ngc) resolver's compiled lines and its interpreter class (linuxcnc.cpp: compiling
// lines and the block structure, the run; linuxcnc_statements.cpp: parameters, expressions, control
// flow and calls). Internal to src/gcode/resolve.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>

#include "linuxcnc_expr.hpp"
#include "support.hpp"

namespace postproc::gcode::resolver::lcnc_run {

using namespace lcnc;

constexpr int kNumbered = 5603;  // #0 … #5602

inline std::string lower(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return r;
}

/// Numbered parameters the controller fills at run time (or keeps in its var file).
inline const char* runtime_numbered(int n) {
  if (n >= 5061 && n <= 5070) return "the probe result (G38)";
  if (n >= 5161 && n <= 5169) return "the G28 home position (var file)";
  if (n >= 5181 && n <= 5189) return "the G30 position (var file)";
  if (n >= 5210 && n <= 5219) return "the G92 offset (var file)";
  if (n >= 5220 && n <= 5390) return "a coordinate-system offset (var file)";
  if (n == 5399) return "the M66 input result";
  if (n >= 5400 && n <= 5413) return "tool data";
  if (n >= 5420 && n <= 5428) return "the current position";
  if (n >= 5599) return "a controller setting";
  return nullptr;
}

// ---------------------------------------------------------------------------------------------
// Compiled lines

enum class Kw : std::uint8_t {
  none, sub, endsub, call, ret, if_, elseif, else_, endif, while_, endwhile, do_, repeat, endrepeat, break_, continue_,
  program_number,  ///< "O100" alone: a Fanuc-style program number, which rs274 runs through (no effect)
};

struct Assign {
  Span span;  // the assignment token
  bool named = false;
  int name_id = 0;
  Code index;  // numbered: the parameter number
  Code value;
};

struct WordValue {
  Span span;  // the value text
  char letter;
  Code code;
};

struct Line {
  bool compiled = false;
  bool ok = true;          // compiled without error (the error was reported)
  bool plain = true;       // nothing to evaluate: emitted as written
  // control
  Kw kw = Kw::none;
  std::string oname;       // lower case, "o100" or "o<name>" ("o[…]" for a computed number)
  std::optional<Code> onumber;  // o[expression] call: the number, computed when the call runs
  Span control_span;
  std::vector<Code> args;  // call arguments / condition / return value / repeat count
  // ordinary block
  std::vector<WordValue> words;
  std::vector<Assign> assigns;
  std::vector<Span> deletions;  // assignment tokens
  bool ends_program = false;    // M2 / M30
  // Probing (G38.2–G38.5, modal group 1): a line that probes leaves #5061–#5070 to the run.
  enum class Probe : std::uint8_t { none, starts, ends } probe = Probe::none;  ///< G38.x / another group-1 G
  bool axis_words = false;
  bool abort = false;           // (abort, …)
  std::uint8_t context = 0;     // literal M70 (1), M71 (2), M72 (4), M73 (8): saved modal state
  std::uint8_t modes = 0;       // literal G90 (1), G91 (2), G7 (4), G8 (8): the modes a G7x profile reads by
  Span context_span;            // the first of them
  // Fanuc-style numbered programs (LinuxCNC O codes, "Fanuc-Style Numbered Programs"): a literal
  // M98 calls the numbered program P (L times), a literal M99 returns from it.
  bool numbered_call = false;   // M98
  bool numbered_return = false; // M99
  std::optional<Code> call_p, call_l;
  std::vector<Span> call_words; // M98 / M99, P, L: removed from the resolved line (comments stay)
  bool call_other_words = false; // a word beside them (N excepted)
  Span call_span;               // the M98 / M99 word
  bool cycle_profile = false;   // G70–G72: profile in a subroutine
  Span cycle_span;
  bool cycle_q_literal = false; // the Q word is a plain number (cycle_q)
  double cycle_q = 0;
  std::string abort_text;
  std::size_t match = 0;        // structure: see Structure
};

struct Sub {
  SourceFile* file = nullptr;
  std::size_t begin = 0;  // the sub line
  std::size_t end = 0;    // the endsub line
};

/// A modal state saved by M70 or M73 (LinuxCNC M-code reference "M70–M73"), as the resolver
/// follows it: the state itself is the interpreter's; here is which save it is and where, whether
/// it is valid and, at a call level, whether the return restores it (M73).
struct SavedState {
  bool valid = false;
  bool restore = false;          ///< M73 at this level: the return restores it
  std::uint64_t id = 0;          ///< the n-th save of the run
  bool absolute = true, diameter = false;  ///< G90/G91 and G7/G8 as saved (Machine::absolute_)
  const SourceFile* file = nullptr;
  std::size_t line = 0;          ///< of the M70/M73 (or, in the resolved program's slot, of an M71)
};

struct Frame {
  std::array<double, 31> saved{};  // #1–#30 of the caller
  SavedState state;                // this call level's saved modal state
  std::unordered_map<int, double> locals;  // named locals
  std::map<std::size_t, long> repeats;     // remaining passes by repeat line
  std::map<std::string, std::size_t> labels;  // O-word number → the block (line) it named first at this level
  bool numbered = false;                   // an M98 call of a numbered program (#1–#30 are not its own)
};

class Machine {
 public:
  Machine(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r)
      : files_(files), out_(out), opt_(opt), sink_(sink), r_(r), numbered_(kNumbered, 0.0) {
    const std::vector<std::pair<std::string, double>> fixed = {{"_vmajor", 2}, {"_vminor", 9}, {"_value", 0},
                                                               {"_value_returned", 0}, {"_call_level", 0}, {"_task", 1}};
    for (const auto& [n, v] : fixed) globals_[names_.id(n)] = v;
  }

  void run();

 private:
  struct Stop {};  // program end (M2/M30) or a refusal: unwinds everything
  /// rs274's doing_break left set: a break left a while loop and no do … while has ended since
  /// (rs274 then runs the next do … while once only: refused where that matters).
  bool while_broken_ = false;
  /// rs274's doing_continue left set: a continue went to the end of a do loop, and no loop has since
  /// ended by skipping to its endwhile or endrepeat (where rs274 then goes back to the loop's head
  /// instead of leaving: refused where that changes the program).
  bool do_continued_ = false;

  struct FileInfo {
    std::vector<Line> lines;
    // structure: for each control line, the line it pairs with (see prepare)
    std::map<std::size_t, std::size_t> end_of;    // sub → endsub, if → endif, while → endwhile, do → while, repeat → endrepeat
    std::map<std::size_t, std::size_t> start_of;  // the reverse, for closers
    std::map<std::size_t, std::vector<std::size_t>> branches;  // if → [elseif…, else…, endif]
    std::map<std::size_t, std::vector<std::size_t>> breaks;    // while / do → its break lines, in order
  };

  // -- compile -------------------------------------------------------------------------------
  Line& line(SourceFile& f, std::size_t i);
  FileInfo& info(SourceFile& f);
  void parse_error(SourceFile& f, std::size_t i, Span within, const ParseError& e);
  void compile(SourceFile& f, std::size_t i, Line& l);
  void compile_control(SourceFile& f, std::size_t i, const Block& b, const Token& t, Line& l);

  /// Finds the block structure of a file: subs, if/elseif/else/endif, while, do/while, repeat.
  void prepare(SourceFile& f);
  template <class OpenVec>
  void close(SourceFile& f, FileInfo& fi, OpenVec& open, Line& l, std::size_t i, Kw opener) {
    if (open.empty() || open.back().oname != l.oname || open.back().kw != opener)
      mismatch(f, i, l, opener == Kw::sub ? "sub" : opener == Kw::if_ ? "if" : opener == Kw::while_ ? "while"
                                                  : opener == Kw::do_ ? "do" : "repeat");
    fi.end_of[open.back().line] = i;
    fi.start_of[i] = open.back().line;
    if (opener == Kw::if_) fi.branches[open.back().line].push_back(i);
    open.pop_back();
  }
  [[noreturn]] void mismatch(SourceFile& f, std::size_t i, const Line& l, const char* opener);

  // -- evaluate ------------------------------------------------------------------------------
  std::string context() const;
  double numbered(double index);
  std::optional<double> named(int id);
  double eval(const Code& c);

  /// Evaluates, reporting an error located at `span` of line i and stopping the run.
  double value(SourceFile& f, std::size_t i, Span span, const Code& c);

  /// Sets a named parameter; a new value (or a new name) is progress for the loop guard.
  void store(std::unordered_map<int, double>& m, int id, double v);
  void assign(const Assign& a, double v, SourceFile& f, std::size_t i, Span span);

  /// A line that probes (G38.x, or axis words while G38.x is the modal motion) fills #5061–#5070
  /// when it runs (LinuxCNC G-code "G38.x Straight Probe"): values the program set before are gone,
  /// so a later read is refused (PP-E701) unless --set gives it.
  void probe_results(const Line& l);

  // -- execute -------------------------------------------------------------------------------
  enum class Flow { next, jump, ret };

  /// Runs lines [from, to) of f; `in_sub`: an endsub/return ends it. Returns on return/endsub.
  void execute(SourceFile& f, std::size_t from, std::size_t to, bool in_sub);
  static constexpr std::size_t kReturn = static_cast<std::size_t>(-1);

  /// The program ended (M2/M30) before its closing '%': a file that opens with '%' must close with
  /// one, so the closing line is written too (LinuxCNC ignores what lies between).
  void close_tape(SourceFile& main);
  [[noreturn]] void endless(SourceFile& f, std::size_t i, const std::string& why);
  [[noreturn]] void runaway(SourceFile& f, std::size_t i);
  /// A break of loop `loop` (its while / do line) on a line strictly between `from` and its end
  /// (rs274 carries it out when it passes it while skipping to that loop's end).
  static bool break_after(const FileInfo& fi, std::size_t loop, std::size_t from);
  /// The count of a repeat line, rounded as rs274 rounds it.
  double repeat_count(SourceFile& f, std::size_t i, const Line& l);
  /// PP-E709 at loop statement `l` (line i): a defect of rs274 2.9's loop handling (`what` it does)
  /// would decide the result; `instead` says how to write the loop.
  [[noreturn]] void loop_defect(SourceFile& f, std::size_t i, const Line& l, std::string_view what,
                                std::string_view instead);

  bool truth(SourceFile& f, std::size_t i, const Line& l) { return value(f, i, l.control_span, l.args[0]) != 0; }

  /// Carries out an O-word line; returns the next line, or kReturn.
  std::size_t control(SourceFile& f, FileInfo& fi, std::size_t i, Line& l, bool in_sub);

  /// G70–G72 read their profile from the subroutine numbered Q (LinuxCNC docs, G70 and G71-G72):
  /// its lines are passed on, values substituted, as "oN sub" … "oN endsub" right before the
  /// cycle's line, where the interpreter reads them as the profile. rs274 (convert_g7x) runs the
  /// subroutine as a call: O-word control flow, calls and assignments are executed, the lines it
  /// reaches are passed on in that order (a cycle inside a profile is refused, PP-E251).
  void cycle_profile(SourceFile& f, std::size_t pc, const Line& l);
  /// One ordinary line of a G7x profile (`profile_` set): rs274's convert_g7x applies its
  /// assignments and reads its X Z U W (values substituted) for the profile; nothing else of it is
  /// executed (M2, comments, other G codes). The point it reaches is #<_x> / #<_z> afterwards.
  void profile_line(SourceFile& f, std::size_t i, const Line& l);
  /// G90/G91, G7/G8 (bits of Line::modes) executed outside a profile.
  void apply_modes(unsigned bits) {
    if (bits & 1u) absolute_ = true;
    if (bits & 2u) absolute_ = false;
    if (bits & 4u) diameter_ = true;
    if (bits & 8u) diameter_ = false;
  }
  std::size_t enclosing_loop(SourceFile& f, FileInfo& fi, std::size_t i, const Line& l);
  void call(SourceFile& f, std::size_t i, Line& l);
  /// M98 P<n> [L<k>] at line i: runs the numbered program O<n> (its "O<n>" line to the first M99
  /// after it, later in the same file) k times (default 1, L0 none); #1–#30 stay global (LinuxCNC
  /// O codes, "Fanuc-Style Numbered Programs"; checked against rs274 by tests/rs274_control_compare.py).
  void numbered_call(SourceFile& f, std::size_t i, const Line& l);
  /// M99 at line i: the return from the numbered program being run; refused elsewhere (in the main
  /// program LinuxCNC starts the program again, an endless program; an o-word sub ends only with endsub).
  void numbered_return(SourceFile& f, std::size_t i, const Line& l, bool in_sub);
  /// The resolved line of an M98 / M99 line: its comments (the call words removed), if any.
  void emit_call_comments(SourceFile& f, std::size_t i, const Line& l);

  /// M70/M71/M72/M73 (bits 1 2 4 8) executed at line i of the current call level (LinuxCNC M-code
  /// reference "M70–M73": one saved state per call level; M73 asks for the restore at the return).
  /// Below the main program the line is marked "(postproc: call level N)" after the M word (`mark`
  /// receives that insertion) and the interpreter keeps a state per level; the restore at a
  /// return is written as "M72 (postproc: call level N)" on the return line. An M72 with no valid
  /// save at its level stops LinuxCNC (PP-E207). A restore that a single saved state (a LinuxCNC
  /// main program) would not reproduce is noted in ResolvedProgram::not_flat for --flatten.
  void modal_context(SourceFile& f, std::size_t i, unsigned bits, Span at, std::vector<Edit>& mark);
  void check_restore(SourceFile& f, std::size_t i, Span at, const SavedState& s, bool on_return);
  [[nodiscard]] std::string level_mark() const { return fmt::format(" (postproc: call level {})", frames_.size() - 1); }
  [[nodiscard]] static std::string where(const SourceFile& in, const SourceFile* f, std::size_t line);

  FileSet& files_;
  Emitter& out_;
  const ResolveOptions& opt_;
  DiagnosticSink& sink_;
  ResolvedProgram& r_;
  LoopGuard guard_{opt_};
  Names names_;
  std::vector<double> numbered_;
  std::set<int> set_numbered_;
  bool probing_ = false;  ///< G38.x is the modal motion
  std::unordered_map<int, double> globals_;
  std::vector<Frame> frames_;
  std::map<std::string, Sub> subs_;
  std::map<std::string, Sub> numbered_programs_;  ///< numbered programs found by M98 calls ("file:o<n>"): "O<n>" line → its M99
  SavedState flat_;            ///< the resolved program's one saved state (M70/M73, M71 of any level)
  // The modes a G7x profile's #<_x> / #<_z> depend on, followed through the run (rs274 starts in G90, G8).
  bool absolute_ = true, diameter_ = false;
  /// While a G7x profile is read: the point it has reached (rs274 sets the current position to each
  /// profile point), per axis when known; X as a radius.
  struct Profile {
    bool absolute = true, diameter = false;
    bool x_known = false, z_known = false;
    double x = 0, z = 0;
    std::size_t cycle_line = 0;
    long q = 0;
  };
  Profile* profile_ = nullptr;
  int x_id_ = names_.id("_x"), z_id_ = names_.id("_z");
  /// The current point inside a profile for #<_x> (axis 0) / #<_z> (2), #5420 / #5422; throws
  /// PP-E701 where it is not known.
  double profile_position(int axis) const;
  std::uint64_t saves_ = 0;
  std::map<const SourceFile*, std::unique_ptr<FileInfo>> info_;

 public:
  using StopT = Stop;
};

}  // namespace postproc::gcode::resolver::lcnc_run
