#pragma once
// The Siemens resolver's run-time state and its interpreter class (siemens.cpp: evaluation,
// calls and control flow; siemens_statements.cpp: parsing lines into statements). Internal to
// src/gcode/resolve.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "src/gcode/text.hpp"
#include "siemens_parse.hpp"
#include "support.hpp"

namespace postproc::gcode::resolver::siemens_run {


using namespace siemens_parse;

// ------------------------------------------------------------------------------------------------
// Run-time state
// ------------------------------------------------------------------------------------------------

struct Var {
  VType type = VType::real;
  std::uint8_t ndims = 0;
  std::array<int, 3> dims{1, 1, 1};
  double* p = nullptr;
  std::shared_ptr<std::vector<double>> own;
};

struct ArgVal {
  bool given = false;
  double value = 0;
  double* ref = nullptr;       ///< a scalar variable, R parameter or array element
  const Var* whole = nullptr;  ///< a whole array
};

struct Frame {
  SourceFile* f = nullptr;
  std::size_t pc = 0;
  std::size_t begin = 0;
  std::size_t header = npos;  ///< PROC line of this frame
  bool main = false;
  bool in_file_proc = false;
  bool bound = false;
  int repeats_left = 0;
  std::vector<ArgVal> args;
  Span call_span;
  std::size_t call_line = 0;
  std::unordered_map<std::string, Var> vars;
  std::unordered_map<std::size_t, double> for_end;
  std::size_t array_elements = 0;  ///< of the DEF arrays of this frame (ResolveOptions::max_array_elements)
};

struct FileData {
  std::vector<std::unique_ptr<Line>> lines;
  bool all_parsed = false;
  std::vector<std::int64_t> match;           ///< partner line of a structure keyword
  std::vector<std::string> match_error;      ///< per line: structure error message
  std::unordered_map<std::string, std::vector<std::size_t>> labels;
  std::unordered_map<std::string, std::size_t> procs;
  std::size_t header = npos;  ///< PROC line heading the file (nothing executable before it)
};

class Siemens {
 public:
  Siemens(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r)
      : files_(files), out_(out), opt_(opt), sink_(sink), r_(r), d_(make_dialect(DialectId::siemens)) {
    rv_.assign(kRCount, 0.0);
    rstate_.assign(kRCount, 0);
    for (const auto& [k, v] : opt.set)
      if (k.size() >= 2 && k[0] == 'R' && std::all_of(k.begin() + 1, k.end(), is_digit) && k.size() <= 4) {
        const int n = std::atoi(k.c_str() + 1);
        if (n < kRCount) {
          rv_[n] = v;
          rstate_[n] = 2;
        }
      }
  }

  void run();

 private:
  // ---- parsing ----
  FileData& data(SourceFile& f) {
    if (fdata_.size() <= f.index()) fdata_.resize(f.index() + 1);
    FileData& d = fdata_[f.index()];
    if (d.lines.size() != f.lines()) d.lines.resize(f.lines());
    return d;
  }
  Line& line(SourceFile& f, std::size_t i) {
    FileData& d = data(f);
    if (!d.lines[i]) d.lines[i] = parse(f, i);
    return *d.lines[i];
  }
  void parse_all(SourceFile& f);
  std::unique_ptr<Line> parse(SourceFile& f, std::size_t i);
  void parse_items(SourceFile& f, Line& L, const Block& b, std::string_view raw, const std::vector<Masked>& masked);
  void parse_control(Line& L, std::string_view raw, const Token& t);
  void parse_decl(Line& L, std::string_view raw, Span rest);
  void parse_proc(Line& L, std::string_view raw, Span rest);
  Target parse_target(Line& L, std::string_view raw, Span s);
  void parse_case(Line& L, std::string_view raw, const Token& t);
  Jump parse_jump(std::string_view raw, std::uint32_t b, std::uint32_t e, std::string_view kw);
  void parse_args(Line& L, Call& c, std::string_view raw, std::uint32_t open, std::uint32_t close);

  // ---- evaluation ----
  double eval(const Pool& p, std::uint32_t n);
  double read_var(const Pool& p, const Node& n);
  double* var_slot(const Pool& p, const Node& n, Var** whole_out, VType* type_out);
  Var& global(const std::string& name, Span span, bool write, std::size_t indices);
  double* element(Var& v, const Pool& p, const Node& n, const std::uint32_t* idx, std::size_t count, Span span);
  double* r_slot(int r, Span span);
  void assign(const Pool& p, const Target& t, double v);
  static double convert(VType t, double v) {
    if (t == VType::integer) return std::round(v);
    if (t == VType::boolean) return v != 0 ? 1 : 0;
    return v;
  }
  int to_index(double v, Span span) {
    const double r = std::round(v);
    if (std::fabs(v - r) > 1e-9 || r < 0)
      throw Fail{"PP-E707", span, fmt::format("index {} is not a whole number ≥ 0; correct the index", format_value(v, 'X'))};
    if (r > 1e6)
      throw Fail{"PP-E707", span, fmt::format("index {} is beyond 1000000, the largest index or dimension the resolver "
                                              "takes; correct the index", format_value(v, 'X'))};
    return static_cast<int>(r);
  }

  // ---- execution ----
  bool step(Frame& fr, Line& L);
  bool do_return(bool program_end_ok);
  bool push_call(Frame& caller, Line& L, const Call& c, SourceFile& target, std::size_t start, bool in_file, int repeats);
  void bind(Frame& fr, Line& L);
  void declare(Frame& fr, const Pool& p, const Decl& d);
  void structure(SourceFile& f);
  std::optional<std::size_t> find_jump(SourceFile& f, std::size_t pc, const Jump& j);
  SourceFile* find_file(const std::string& name);
  void report(SourceFile& f, std::size_t i, const Line& L, Span span, Severity sev, std::string_view code, std::string msg);
  void fail(SourceFile& f, std::size_t i, const Line& L, const Fail& e) {
    if (std::string_view(e.code) == "PP-U242") {
      // An unknown GUD value decides an assignment, a condition or a call: the run cannot go on.
      report(f, i, L, e.span, Severity::error, "PP-E241",
             e.message + "; here it decides an assignment, condition or call, so the program cannot be followed past it");
      return;
    }
    report(f, i, L, e.span, Severity::error, e.code, e.message);
  }

  FileSet& files_;
  Emitter& out_;
  const ResolveOptions& opt_;
  DiagnosticSink& sink_;
  ResolvedProgram& r_;
  Dialect d_;
  std::vector<FileData> fdata_;
  std::vector<double> rv_;
  std::vector<std::uint8_t> rstate_;  ///< 0 never assigned, 1 assigned, 2 from --set (not yet read)
  std::vector<std::unique_ptr<Frame>> frames_;
  std::unordered_map<std::string, SourceFile*> file_cache_;
  std::unordered_map<std::string, Var> globals_;  ///< GUD names the program writes or --set gives
  std::vector<Edit> edits_;
  SourceFile* cur_file_ = nullptr;
  std::size_t cur_line_ = 0;
  const Line* cur_L_ = nullptr;
  std::size_t array_elements_ = 0;  ///< of all DEF arrays alive (frames on the stack)
  LoopGuard guard_{opt_};
};

// ---- parsing ------------------------------------------------------------------------------------

}  // namespace postproc::gcode::resolver::siemens_run
