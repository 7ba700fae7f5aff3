// Resolver for the siemens dialect (see include/postproc/gcode/resolve.hpp): runs a Sinumerik
// 840D program — R parameters, DEF variables and arrays, NAME=expr, IF/ELSE/ENDIF, WHILE, FOR,
// REPEAT/UNTIL, LOOP, CASE … OF, GOTOF/GOTOB/GOTO/GOTOC, L/named/PROC subprograms — and emits the literal
// program through the Emitter.
//
// Each source line is parsed once into a `Line` (statements, expressions compiled into a node
// pool, static deletions) and cached per (file, line); loops re-run the cached form.
//
// Lines the block lexer cannot read (array or R[…] assignment targets `B[1]=…`, `R[R1]=…`,
// system-variable writes `$X=…`, `CALL "NAME"`) are re-lexed with those statements masked by
// blanks, so the remaining words keep their byte spans.
//
// Warnings: PP-W703 R parameter read before it is assigned (taken as 0);
//           PP-W704 main program runs into a PROC definition (the run ends there).
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

namespace postproc::gcode::resolver {
namespace {

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
    if (std::fabs(v - r) > 1e-9 || r < 0 || r > 1e6)
      throw Fail{"PP-E707", span, fmt::format("index {} is not a whole number ≥ 0; correct the index", format_value(v, 'X'))};
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
  std::vector<Edit> edits_;
  SourceFile* cur_file_ = nullptr;
  std::size_t cur_line_ = 0;
  const Line* cur_L_ = nullptr;
};

// ---- parsing ------------------------------------------------------------------------------------

std::unique_ptr<Line> Siemens::parse(SourceFile& f, std::size_t i) {
  auto L = std::make_unique<Line>();
  const std::string_view raw = f.raw(i);
  DiagnosticSink quiet(0);
  LexContext ctx{f.name(), &quiet};
  Block b;
  b.raw = raw;
  b.line = i + 1;
  std::vector<Masked> masked;
  std::string masked_text;
  scan_statements(raw, masked);
  bool ok;
  if (masked.empty()) {
    ok = lex_block(d_, b, ctx);
  } else {
    // Mask the statements the lexer cannot read (or splits at blanks) and lex the rest: spans
    // stay the same.
    masked_text.assign(raw);
    for (const Masked& m : masked)
      for (std::uint32_t q = m.span.begin; q < m.span.end; ++q) masked_text[q] = ' ';
    b.raw = masked_text;
    ok = lex_block(d_, b, ctx);
    L->lexed_ok = false;
  }
  if (!ok) {
    // The lexer's complaint is reported by the interpreter when it reads the resolved line; the
    // statements it could read are still carried out here.
    L->lexed_ok = false;
  }
  try {
    parse_items(f, *L, b, raw, masked);
  } catch (const Fail& e) {
    L->error = e;
    L->trivial = false;
  }
  return L;
}

Target Siemens::parse_target(Line& L, std::string_view raw, Span s) {
  Target t;
  t.span = s;
  Parser p(raw, s.begin, s.end, L.pool);
  const std::uint32_t b = p.pos();
  if (b < s.end && raw[b] == '$') {
    t.kind = Target::sysvar;
    for (std::uint32_t k = b; k < s.end; ++k)
      if (!is_blank(raw[k])) t.name += upper(raw[k]);
    return t;
  }
  const std::string name = p.ident();
  if (name.empty()) p.fail_here("a variable name is expected");
  if (name == "R" && p.peek() == '[') {
    p.expect('[', "");
    t.kind = Target::rindirect;
    t.index.push_back(p.expr());
    p.expect(']', "closing R[…]");
  } else if (name.size() >= 2 && name[0] == 'R' && std::all_of(name.begin() + 1, name.end(), is_digit)) {
    t.kind = Target::rconst;
    t.r = std::atoi(name.c_str() + 1);
    if (t.r >= kRCount) throw Fail{"PP-E703", s, fmt::format("{} does not exist (R0 to R{}); use a lower number", name, kRCount - 1)};
  } else {
    t.kind = Target::var;
    t.name = name;
    if (p.accept('[')) {
      do t.index.push_back(p.expr());
      while (p.accept(','));
      p.expect(']', "closing the index");
    }
  }
  p.expect_end("the variable");
  return t;
}

// CASE (expression) OF value GOTOF target value GOTOB target … DEFAULT GOTOF target
void Siemens::parse_case(Line& L, std::string_view raw, const Token& t) {
  const std::uint32_t b = t.name.end, e = t.span.end;
  const std::uint32_t of = find_keyword(raw, b, e, {"OF"});
  if (of == static_cast<std::uint32_t>(-1))
    throw Fail{"PP-E702", t.span, "syntax error: write CASE (expression) OF value GOTOF label … DEFAULT GOTOF label"};
  {
    Parser p(raw, b, of, L.pool);
    if (p.at_end()) p.fail_here("CASE needs an expression");
    L.cond = p.expr();
    p.expect_end("the CASE expression");
  }
  std::uint32_t pos = of + 2;
  while (true) {
    while (pos < e && (raw[pos] == ' ' || raw[pos] == '\t')) ++pos;
    if (pos >= e) break;
    std::string_view which;
    const std::uint32_t g = find_keyword(raw, pos, e, {"GOTOF", "GOTOB", "GOTOC", "GOTO"}, &which);
    if (g == static_cast<std::uint32_t>(-1))
      throw Fail{"PP-E702", {pos, e}, "syntax error: each CASE value needs a jump: value GOTOF label"};
    // The jump's target: one label or block number.
    std::uint32_t q = g + static_cast<std::uint32_t>(which.size());
    while (q < e && (raw[q] == ' ' || raw[q] == '\t')) ++q;
    while (q < e && (is_ident(raw[q]))) ++q;
    const Jump jump = parse_jump(raw, g + static_cast<std::uint32_t>(which.size()), q, which);
    std::string_view value = raw.substr(pos, g - pos);
    while (!value.empty() && (value.back() == ' ' || value.back() == '\t')) value.remove_suffix(1);
    if (text::iequals(value, "DEFAULT")) {
      L.case_default = jump;
    } else {
      Parser p(raw, pos, g, L.pool);
      if (p.at_end()) p.fail_here("a CASE branch needs a value before its jump");
      L.cases.emplace_back(p.expr(), jump);
      p.expect_end("the CASE value");
    }
    pos = q;
  }
  if (L.cases.empty() && !L.case_default)
    throw Fail{"PP-E702", t.span, "syntax error: CASE … OF has no branch (value GOTOF label)"};
}

Jump Siemens::parse_jump(std::string_view raw, std::uint32_t b, std::uint32_t e, std::string_view kw) {
  Jump j;
  const std::string k = upper(kw);
  j.kind = k == "GOTOF" ? GoKind::forward : k == "GOTOB" ? GoKind::backward : k == "GOTOC" ? GoKind::quiet : GoKind::both;
  Pool scratch;
  Parser p(raw, b, e, scratch);
  const std::uint32_t at = p.pos();
  if (p.at_end()) p.fail_here(fmt::format("{} needs a label or block number", k));
  if (raw[at] == '"' || raw[at] == '(')
    throw Fail{"PP-E709", {at, e}, fmt::format("{} to a computed target is not followed by the resolver; write the label", k)};
  std::string id;
  if (is_digit(raw[at])) {
    std::uint32_t q = at;
    while (q < e && is_digit(raw[q])) ++q;
    id = "N" + std::string(raw.substr(at, q - at));
    p.set_pos(q);
  } else {
    id = p.ident();
  }
  if (id.empty()) p.fail_here(fmt::format("{} needs a label or block number", k));
  j.span = {at, p.pos()};
  if (id.size() >= 2 && id[0] == 'N' && std::all_of(id.begin() + 1, id.end(), is_digit)) {
    j.is_n = true;
    j.n = std::atof(id.c_str() + 1);
  } else {
    j.label = id;
  }
  p.expect_end("the jump target");
  return j;
}

void Siemens::parse_control(Line& L, std::string_view raw, const Token& t) {
  const std::string kw = upper(raw.substr(t.name.begin, t.name.size()));
  const std::uint32_t b = t.name.end, e = t.span.end;
  L.ctl_span = t.span;
  auto blank_rest = [&](Ctl c) {
    Parser p(raw, b, e, L.pool);
    p.expect_end(kw);
    L.ctl = c;
  };
  auto condition = [&](std::uint32_t cb, std::uint32_t ce) {
    Parser p(raw, cb, ce, L.pool);
    if (p.at_end()) p.fail_here(fmt::format("{} needs a condition", kw));
    L.cond = p.expr();
    p.expect_end("the condition");
  };
  if (kw == "IF") {
    std::string_view which;
    const std::uint32_t g = find_keyword(raw, b, e, {"GOTOF", "GOTOB", "GOTOC", "GOTO"}, &which);
    if (g != static_cast<std::uint32_t>(-1)) {
      condition(b, g);
      L.jump = parse_jump(raw, g + static_cast<std::uint32_t>(which.size()), e, which);
      L.ctl = Ctl::if_goto;
    } else {
      condition(b, e);
      L.ctl = Ctl::if_block;
    }
  } else if (kw == "ELSE") blank_rest(Ctl::else_);
  else if (kw == "ENDIF") blank_rest(Ctl::endif);
  else if (kw == "ENDWHILE") blank_rest(Ctl::endwhile);
  else if (kw == "ENDFOR") blank_rest(Ctl::endfor);
  else if (kw == "REPEAT") blank_rest(Ctl::repeat);
  else if (kw == "LOOP") blank_rest(Ctl::loop);
  else if (kw == "ENDLOOP") blank_rest(Ctl::endloop);
  else if (kw == "WHILE") {
    condition(b, e);
    L.ctl = Ctl::while_;
  } else if (kw == "UNTIL") {
    condition(b, e);
    L.ctl = Ctl::until;
  } else if (kw == "FOR") {
    // FOR var = from TO to
    std::uint32_t eq = static_cast<std::uint32_t>(-1);
    for (std::uint32_t k = b; k < e; ++k)
      if (raw[k] == '=' && !(k + 1 < e && raw[k + 1] == '=') && !(k > b && (raw[k - 1] == '<' || raw[k - 1] == '>' || raw[k - 1] == '='))) {
        eq = k;
        break;
      }
    const std::uint32_t to = eq == static_cast<std::uint32_t>(-1) ? eq : find_keyword(raw, eq + 1, e, {"TO"});
    if (eq == static_cast<std::uint32_t>(-1) || to == static_cast<std::uint32_t>(-1))
      throw Fail{"PP-E702", t.span, "syntax error: write FOR variable = start TO end"};
    L.for_var = parse_target(L, raw, {b, eq});
    if (L.for_var.kind == Target::sysvar)
      throw Fail{"PP-E709", L.for_var.span, "a system variable as FOR counter is not supported; use an R parameter or INT variable"};
    Parser pf(raw, eq + 1, to, L.pool);
    L.for_from = pf.expr();
    pf.expect_end("the start value");
    Parser pt(raw, to + 2, e, L.pool);
    L.for_to = pt.expr();
    pt.expect_end("the end value");
    L.ctl = Ctl::for_;
  } else if (kw == "GOTO" || kw == "GOTOF" || kw == "GOTOB" || kw == "GOTOC") {
    L.jump = parse_jump(raw, b, e, kw);
    L.ctl = Ctl::go;
  } else if (kw == "RET") {
    Parser p(raw, b, e, L.pool);
    if (!p.at_end()) throw Fail{"PP-E709", t.span, "RET with arguments (return to a label) is not supported; use RET alone"};
    L.ctl = Ctl::ret;
  } else if (kw == "CASE") {
    parse_case(L, raw, t);
    L.ctl = Ctl::case_;
  } else if (kw == "TO") {
    throw Fail{"PP-E702", t.span, "syntax error: TO outside FOR"};
  } else {
    return;  // STOPRE: left in the line
  }
  L.deletes.push_back(t.span);
}

void Siemens::parse_decl(Line& L, std::string_view raw, Span rest) {
  Parser p(raw, rest.begin, rest.end, L.pool);
  std::string tname = p.ident();
  if (tname == "NCK" || tname == "CHAN" || tname == "LUD" || tname == "GUD" || tname == "PUD")
    throw Fail{"PP-E709", rest, fmt::format("global user data (DEF {} …) is not evaluated by the resolver; define the variables in the program", tname)};
  const auto type = type_of(tname);
  if (!type) p.fail_here("DEF needs a type: REAL, INT, BOOL, CHAR, STRING[n], AXIS or FRAME");
  Decl d;
  d.type = *type;
  d.span = rest;
  if (*type == VType::string && p.accept('[')) {
    (void)p.expr();
    p.expect(']', "closing STRING[n]");
  }
  for (std::string_view attr : {"PHU", "LLI", "ULI", "PRD"})
    if (iequals(p.peek_ident(), attr))
      throw Fail{"PP-E709", rest, fmt::format("DEF attribute {} is not evaluated by the resolver; remove it", attr)};
  do {
    DeclVar v;
    const std::uint32_t nb = p.pos();
    v.name = p.ident();
    if (v.name.empty()) p.fail_here("a variable name is expected");
    if (p.accept('[')) {
      do v.dims.push_back(p.expr());
      while (p.accept(','));
      p.expect(']', "closing the array size");
      if (v.dims.size() > 3) throw Fail{"PP-E702", {nb, p.pos()}, "syntax error: arrays have at most 3 dimensions"};
    }
    v.span = {nb, p.pos()};
    if (p.accept('=')) {
      if (!numeric(d.type)) {
        // Initial values of STRING/CHAR/AXIS/FRAME variables are not kept; reading them is refused.
        std::uint32_t q = p.pos();
        int depth = 0;
        bool str = false;
        for (; q < rest.end; ++q) {
          const char c = raw[q];
          if (c == '"') str = !str;
          if (str) continue;
          if (c == '(' || c == '[') ++depth;
          if (c == ')' || c == ']') --depth;
          if (depth == 0 && c == ',') break;
        }
        p.set_pos(q);
      } else if (!v.dims.empty()) {
        if (p.accept_kw("REP")) {
          v.rep = true;
          p.expect('(', "after REP");
          v.init.push_back(p.expr());
          p.expect(')', "closing REP(…)");
        } else {
          (void)p.accept_kw("SET");
          p.expect('(', "opening the list of initial values");
          do v.init.push_back(p.expr());
          while (p.accept(','));
          p.expect(')', "closing the list of initial values");
        }
      } else {
        v.init.push_back(p.expr());
      }
    }
    d.vars.push_back(std::move(v));
  } while (p.accept(','));
  p.expect_end("the declaration");
  L.decls.push_back(std::move(d));
  L.items.push_back({Item::decl, static_cast<std::uint32_t>(L.decls.size() - 1)});
}

void Siemens::parse_proc(Line& L, std::string_view raw, Span rest) {
  Parser p(raw, rest.begin, rest.end, L.pool);
  L.proc.name = p.ident();
  if (L.proc.name.empty()) p.fail_here("PROC needs a name");
  if (p.accept('(')) {
    if (!p.accept(')')) {
      do {
        Param prm;
        prm.by_ref = p.accept_kw("VAR");
        const std::string t = p.ident();
        const auto type = type_of(t);
        if (!type) p.fail_here("a parameter type (REAL, INT, BOOL, …) is expected");
        prm.type = *type;
        if (prm.type == VType::string && p.accept('[')) {
          (void)p.expr();
          p.expect(']', "closing STRING[n]");
        }
        prm.name = p.ident();
        if (prm.name.empty()) p.fail_here("a parameter name is expected");
        if (p.accept('[')) {
          do {
            if (p.peek() == ',' || p.peek() == ']') prm.dims.push_back(static_cast<std::uint32_t>(-1));
            else prm.dims.push_back(p.expr());
          } while (p.accept(','));
          p.expect(']', "closing the array size");
        }
        L.proc.params.push_back(std::move(prm));
      } while (p.accept(','));
      p.expect(')', "closing the parameter list");
    }
  }
  // SAVE, DISPLOF, SBLOF, ACTBLOCNO and the like are attributes without effect here.
  L.has_proc = true;
}

void Siemens::parse_args(Line& L, Call& c, std::string_view raw, std::uint32_t open, std::uint32_t close) {
  c.has_args = true;
  Parser p(raw, open + 1, close, L.pool);
  if (p.at_end()) return;
  for (;;) {
    if (p.peek() == ',' || p.at_end()) c.args.emplace_back(std::nullopt);
    else c.args.emplace_back(p.expr());
    if (!p.accept(',')) break;
  }
  p.expect_end("the arguments");
}

void Siemens::parse_items(SourceFile& f, Line& L, const Block& b, std::string_view raw,
                          const std::vector<Masked>& masked) {
  // Everything in source order: words, tokens and masked statements.
  struct Ref {
    std::uint32_t at;
    int kind;  // 0 word, 1 token, 2 masked
    std::size_t i;
  };
  std::vector<Ref> order;
  for (std::size_t k = 0; k < b.words.size(); ++k) order.push_back({b.words[k].span.begin, 0, k});
  for (std::size_t k = 0; k < b.tokens.size(); ++k) order.push_back({b.tokens[k].span.begin, 1, k});
  for (std::size_t k = 0; k < masked.size(); ++k) order.push_back({masked[k].span.begin, 2, k});
  std::sort(order.begin(), order.end(), [](const Ref& a, const Ref& c) { return a.at < c.at; });

  int candidates = 0;
  std::vector<Call> pending;  // call candidates, order kept
  for (const Token& t : b.tokens)
    if (t.kind == TokenKind::keyword && iequals(raw.substr(t.name.begin, t.name.size()), "MCALL")) L.mcall = true;

  for (const Ref& ref : order) {
    if (ref.kind == 2) {
      const Masked& m = masked[ref.i];
      const Span span = m.span;
      if (m.kind == Masked::call) {
        const auto q1 = raw.find('"', span.begin);
        Call c;
        c.kind = Call::explicit_call;
        c.name = upper(raw.substr(q1 + 1, span.end - q1 - 2));
        c.span = span;
        L.calls.push_back(std::move(c));
        L.items.push_back({Item::call, static_cast<std::uint32_t>(L.calls.size() - 1)});
        ++candidates;
        continue;
      }
      if (m.kind == Masked::word) {
        // An address whose value has blanks inside: X=R1 + 2, X=AC(R1 + 2).
        ++L.others;
        WordSub s;
        s.edit = m.value;
        s.letter = upper(raw[m.name.begin]);
        const std::string_view v = m.value.of(raw);
        if (v.size() > 3 && (text::starts_with_i(v, "AC(") || text::starts_with_i(v, "IC(")) && v.back() == ')')
          s.edit = {m.value.begin + 3, m.value.end - 1};
        Parser p(raw, s.edit.begin, s.edit.end, L.pool);
        s.expr = p.expr();
        p.expect_end("the value");
        L.subs.push_back(s);
        L.items.push_back({Item::word, static_cast<std::uint32_t>(L.subs.size() - 1)});
        continue;
      }
      if (address_name(upper(m.name.of(raw)))) {
        ++L.others;
        WordSub s;
        s.edit = m.value;
        s.letter = upper(raw[m.name.begin]);
        Parser p(raw, m.value.begin, m.value.end, L.pool);
        s.expr = p.expr();
        p.expect_end("the value");
        L.subs.push_back(s);
        L.items.push_back({Item::word, static_cast<std::uint32_t>(L.subs.size() - 1)});
        continue;
      }
      Assign a;
      a.span = span;
      a.target = parse_target(L, raw, m.name);
      Parser p(raw, m.value.begin, m.value.end, L.pool);
      a.expr = p.expr();
      p.expect_end("the value");
      if (a.target.kind == Target::sysvar)
        throw Fail{"PP-E709", span, fmt::format("writing the system variable {} is not followed by the resolver; set it on the machine", a.target.name)};
      L.assigns.push_back(std::move(a));
      L.items.push_back({Item::assign, static_cast<std::uint32_t>(L.assigns.size() - 1)});
      L.deletes.push_back(span);
      continue;
    }
    if (ref.kind == 0) {
      const Word& w = b.words[ref.i];
      if (w.kind == ValueKind::expression || w.kind == ValueKind::parameter) {
        WordSub s;
        s.edit = w.value;
        s.letter = w.letter;
        Parser p(raw, w.value.begin, w.value.end, L.pool);
        s.expr = p.expr();
        p.expect_end("the value");
        if (w.letter == 'P' && w.name_len == 1) {
          L.has_p = true;
          L.p_span = w.span;
          L.p_expr = s.expr;
          continue;
        }
        L.subs.push_back(s);
        L.items.push_back({Item::word, static_cast<std::uint32_t>(L.subs.size() - 1)});
        ++L.others;
      } else if (w.kind == ValueKind::absolute_fn || w.kind == ValueKind::incremental_fn) {
        // AC(expr) / IC(expr): the argument is evaluated, the wrapper kept.
        const auto open = raw.find('(', w.value.begin);
        std::uint32_t close = static_cast<std::uint32_t>(open);
        int depth = 0;
        for (; close < w.value.end; ++close) {
          if (raw[close] == '(') ++depth;
          if (raw[close] == ')' && --depth == 0) break;
        }
        if (close + 1 != w.value.end)
          throw Fail{"PP-E709", w.value, fmt::format("'{}' combines AC/IC with more terms; write AC(…) or IC(…) alone", w.value.of(raw))};
        ++L.others;
        const Span inner{static_cast<std::uint32_t>(open + 1), close};
        std::string_view in = inner.of(raw);
        while (!in.empty() && is_blank(in.front())) in.remove_prefix(1);
        while (!in.empty() && is_blank(in.back())) in.remove_suffix(1);
        char* endp = nullptr;
        const std::string tmp(in);
        (void)std::strtod(tmp.c_str(), &endp);
        if (!tmp.empty() && endp == tmp.c_str() + tmp.size()) continue;  // a literal: nothing to do
        WordSub s;
        s.edit = inner;
        s.letter = w.letter;
        Parser p(raw, inner.begin, inner.end, L.pool);
        s.expr = p.expr();
        p.expect_end("the value");
        L.subs.push_back(s);
        L.items.push_back({Item::word, static_cast<std::uint32_t>(L.subs.size() - 1)});
      } else if (w.letter == 'L' && w.name_len == 1 && w.kind == ValueKind::number) {
        Call c;
        c.kind = Call::lword;
        c.name = "L" + std::string(w.value.of(raw));
        c.span = w.span;
        L.calls.push_back(std::move(c));
        L.items.push_back({Item::call, static_cast<std::uint32_t>(L.calls.size() - 1)});
        ++candidates;
      } else if (w.letter == 'P' && w.name_len == 1 && w.kind == ValueKind::number) {
        L.has_p = true;
        L.p_span = w.span;
        L.p_value = w.number;
      } else if (w.letter == 'M' && w.name_len == 1 && w.kind == ValueKind::number && (w.number == 30 || w.number == 2)) {
        L.end_program = true;
        ++L.others;
      } else if (w.letter == 'M' && w.name_len == 1 && w.kind == ValueKind::number && w.number == 17) {
        L.m17 = true;
        L.m17_span = w.span;
        ++L.others;
      } else {
        ++L.others;
      }
      continue;
    }
    const Token& t = b.tokens[ref.i];
    switch (t.kind) {
      case TokenKind::paren_comment:
      case TokenKind::line_comment: ++L.others; break;
      case TokenKind::percent:
        if (f.index() != 0) L.deletes.push_back(t.span);
        else ++L.others;
        break;
      case TokenKind::program_number:
      case TokenKind::block_end: ++L.others; break;
      case TokenKind::assignment: {
        std::uint32_t eq = t.name.end;
        while (eq < t.span.end && raw[eq] != '=') ++eq;
        if (address_name(upper(t.name.of(raw)))) {
          // A multi-letter address with '=' (TURN=2, RND=R1): its value is substituted, the word kept.
          ++L.others;
          std::uint32_t v = eq + 1;
          while (v < t.span.end && is_blank(raw[v])) ++v;
          const std::string tmp(raw.substr(v, t.span.end - v));
          char* endp = nullptr;
          (void)std::strtod(tmp.c_str(), &endp);
          if (!tmp.empty() && endp == tmp.c_str() + tmp.size()) break;
          WordSub s;
          s.edit = {v, t.span.end};
          s.letter = upper(raw[t.name.begin]);
          Parser p(raw, v, t.span.end, L.pool);
          s.expr = p.expr();
          p.expect_end("the value");
          L.subs.push_back(s);
          L.items.push_back({Item::word, static_cast<std::uint32_t>(L.subs.size() - 1)});
          break;
        }
        Assign a;
        a.span = t.span;
        a.target = parse_target(L, raw, t.name);
        Parser p(raw, eq + 1, t.span.end, L.pool);
        a.expr = p.expr();
        p.expect_end("the value");
        L.assigns.push_back(std::move(a));
        L.items.push_back({Item::assign, static_cast<std::uint32_t>(L.assigns.size() - 1)});
        L.deletes.push_back(t.span);
        break;
      }
      case TokenKind::control_flow: {
        const std::size_t before = L.deletes.size();
        parse_control(L, raw, t);
        if (L.deletes.size() == before) ++L.others;  // STOPRE
        break;
      }
      case TokenKind::declaration: {
        const std::string kw = upper(raw.substr(t.name.begin, t.name.size()));
        if (kw == "DEF") parse_decl(L, raw, {t.name.end, t.span.end});
        else if (kw == "PROC") parse_proc(L, raw, {t.name.end, t.span.end});
        else if (kw == "DEFINE")
          throw Fail{"PP-E709", t.span, "DEFINE … AS macros are not evaluated by the resolver; write the text out"};
        // EXTERN: declaration of a subprogram's parameters, nothing to do.
        L.deletes.push_back(t.span);
        break;
      }
      case TokenKind::label:
        L.has_label = true;
        L.label = upper(raw.substr(t.name.begin, t.name.size()));
        L.deletes.push_back(t.span);
        break;
      case TokenKind::keyword:
      case TokenKind::call: {
        const std::string name = upper(raw.substr(t.name.begin, t.name.size()));
        if (name == "SETAL" && t.kind == TokenKind::call) {
          const auto open = raw.find('(', t.name.end);
          Call tmp;
          parse_args(L, tmp, raw, static_cast<std::uint32_t>(open), t.span.end - 1);
          if (tmp.args.empty() || !tmp.args[0]) throw Fail{"PP-E702", t.span, "syntax error: SETAL needs an alarm number"};
          L.setal.push_back(*tmp.args[0]);
          L.items.push_back({Item::setal, static_cast<std::uint32_t>(L.setal.size() - 1)});
          L.deletes.push_back(t.span);
          break;
        }
        if (L.mcall || builtin_name(name)) {
          ++L.others;
          break;
        }
        Call c;
        c.kind = Call::named;
        c.name = name;
        c.span = t.span;
        if (t.kind == TokenKind::call) {
          // Arguments are parsed when the call is followed (a vendor cycle's are left as written).
          c.has_args = true;
        }
        L.calls.push_back(std::move(c));
        L.items.push_back({Item::call, static_cast<std::uint32_t>(L.calls.size() - 1)});
        ++candidates;
        break;
      }
    }
  }
  if (L.has_p && L.calls.empty()) {
    // A P word without a call is an ordinary word.
    ++L.others;
    if (L.p_expr) {
      WordSub s;
      s.edit = {L.p_span.begin + 1, L.p_span.end};
      // keep "P=" : edit the value only
      const Word* pw = nullptr;
      for (const Word& w : b.words)
        if (w.span.begin == L.p_span.begin) pw = &w;
      if (pw) s.edit = pw->value;
      s.letter = 'P';
      s.expr = *L.p_expr;
      L.subs.push_back(s);
      L.items.push_back({Item::word, static_cast<std::uint32_t>(L.subs.size() - 1)});
    }
    L.has_p = false;
  }
  (void)candidates;
  L.executable = !L.items.empty() || L.ctl != Ctl::none || L.has_proc || L.end_program || L.m17 ||
                 !b.words.empty() || b.has_n ||
                 std::any_of(b.tokens.begin(), b.tokens.end(), [](const Token& t) {
                   return t.kind != TokenKind::line_comment && t.kind != TokenKind::paren_comment && t.kind != TokenKind::percent;
                 });
  // Deletions swallow the blanks after them (and before them at the end of the line).
  std::sort(L.deletes.begin(), L.deletes.end(), [](Span a, Span c) { return a.begin < c.begin; });
  const auto n = static_cast<std::uint32_t>(raw.size());
  std::vector<Span> merged;
  for (Span s : L.deletes) {
    while (s.end < n && is_blank(raw[s.end])) ++s.end;
    if (!merged.empty() && s.begin <= merged.back().end) merged.back().end = std::max(merged.back().end, s.end);
    else merged.push_back(s);
  }
  if (!merged.empty() && merged.back().end == n) {
    Span& s = merged.back();
    const std::uint32_t floor = merged.size() > 1 ? merged[merged.size() - 2].end : 0;
    while (s.begin > floor && is_blank(raw[s.begin - 1])) --s.begin;
    if (merged.size() > 1 && s.begin == floor) {
      merged[merged.size() - 2].end = s.end;
      merged.pop_back();
    }
  }
  L.deletes = std::move(merged);
  L.trivial = L.items.empty() && L.deletes.empty() && L.ctl == Ctl::none && !L.has_label && !L.has_proc &&
              !L.end_program && !L.m17 && L.calls.empty();
}

void Siemens::parse_all(SourceFile& f) {
  FileData& d = data(f);
  if (d.all_parsed) return;
  for (std::size_t i = 0; i < f.lines(); ++i) (void)line(f, i);
  d.all_parsed = true;
  bool seen_exec = false;
  for (std::size_t i = 0; i < f.lines(); ++i) {
    const Line& L = *d.lines[i];
    if (L.has_label) d.labels[L.label].push_back(i);
    if (L.has_proc) {
      d.procs.emplace(L.proc.name, i);
      if (!seen_exec && d.header == npos) d.header = i;
    }
    if (L.executable || L.lex_failed || L.error) seen_exec = true;
  }
}

void Siemens::structure(SourceFile& f) {
  FileData& d = data(f);
  if (!d.match.empty() || f.lines() == 0) return;
  parse_all(f);
  d.match.assign(f.lines(), -1);
  d.match_error.assign(f.lines(), {});
  struct Open {
    Ctl ctl;
    std::size_t line;
    std::int64_t else_line;
  };
  std::vector<Open> stack;
  auto opener_name = [](Ctl c) -> std::string_view {
    switch (c) {
      case Ctl::if_block: return "IF";
      case Ctl::while_: return "WHILE";
      case Ctl::for_: return "FOR";
      case Ctl::repeat: return "REPEAT";
      case Ctl::loop: return "LOOP";
      default: return "?";
    }
  };
  auto closer_for = [](Ctl c) -> std::string_view {
    switch (c) {
      case Ctl::if_block: return "ENDIF";
      case Ctl::while_: return "ENDWHILE";
      case Ctl::for_: return "ENDFOR";
      case Ctl::repeat: return "UNTIL";
      case Ctl::loop: return "ENDLOOP";
      default: return "?";
    }
  };
  for (std::size_t i = 0; i < f.lines(); ++i) {
    const Line& L = *d.lines[i];
    Ctl want = Ctl::none;
    std::string_view closer;
    switch (L.ctl) {
      case Ctl::if_block: case Ctl::while_: case Ctl::for_: case Ctl::repeat: case Ctl::loop:
        stack.push_back({L.ctl, i, -1});
        continue;
      case Ctl::else_:
        if (stack.empty() || stack.back().ctl != Ctl::if_block || stack.back().else_line >= 0) {
          d.match_error[i] = "ELSE without an open IF; check the IF/ELSE/ENDIF structure";
        } else {
          stack.back().else_line = static_cast<std::int64_t>(i);
        }
        continue;
      case Ctl::endif: want = Ctl::if_block; closer = "ENDIF"; break;
      case Ctl::endwhile: want = Ctl::while_; closer = "ENDWHILE"; break;
      case Ctl::endfor: want = Ctl::for_; closer = "ENDFOR"; break;
      case Ctl::until: want = Ctl::repeat; closer = "UNTIL"; break;
      case Ctl::endloop: want = Ctl::loop; closer = "ENDLOOP"; break;
      default: continue;
    }
    if (stack.empty() || stack.back().ctl != want) {
      d.match_error[i] = stack.empty()
                             ? fmt::format("{} without an open {}; check the structure", closer, opener_name(want))
                             : fmt::format("{} closes the {} at line {}, which needs {}; check the structure", closer,
                                           opener_name(stack.back().ctl), stack.back().line + 1, closer_for(stack.back().ctl));
      continue;
    }
    const Open o = stack.back();
    stack.pop_back();
    d.match[i] = static_cast<std::int64_t>(o.line);
    if (o.else_line >= 0) {
      d.match[o.line] = o.else_line;
      d.match[static_cast<std::size_t>(o.else_line)] = static_cast<std::int64_t>(i);
    } else {
      d.match[o.line] = static_cast<std::int64_t>(i);
    }
  }
  for (const Open& o : stack)
    d.match_error[o.line] = fmt::format("{} is not closed by {} in this file; add it", opener_name(o.ctl), closer_for(o.ctl));
}

// ---- evaluation ---------------------------------------------------------------------------------

double* Siemens::r_slot(int r, Span span) {
  if (r < 0 || r >= kRCount) throw Fail{"PP-E703", span, fmt::format("R{} does not exist (R0 to R{}); correct the index", r, kRCount - 1)};
  return &rv_[static_cast<std::size_t>(r)];
}

double* Siemens::element(Var& v, const Pool& p, const Node& n, const std::uint32_t* idx, std::size_t count, Span span) {
  if (count != v.ndims)
    throw Fail{"PP-E702", span, fmt::format("syntax error: '{}' has {} index(es), the variable {}; write one index per dimension",
                                            span.of(cur_file_->raw(cur_line_)), count, v.ndims == 0 ? "is not an array" : fmt::format("has {} dimension(s)", v.ndims))};
  std::size_t off = 0;
  for (std::size_t k = 0; k < count; ++k) {
    const Node& in = p.nodes[idx[k]];
    const int i = to_index(eval(p, idx[k]), in.span);
    if (i >= v.dims[k])
      throw Fail{"PP-E707", in.span, fmt::format("index {} is outside the array (size {}); indices run from 0", i, v.dims[k])};
    off = off * static_cast<std::size_t>(v.dims[k]) + static_cast<std::size_t>(i);
  }
  (void)n;
  return v.p + off;
}

double* Siemens::var_slot(const Pool& p, const Node& n, Var** whole_out, VType* type_out) {
  Frame& fr = *frames_.back();
  const std::string& name = p.names[n.name];
  auto it = fr.vars.find(name);
  if (it == fr.vars.end())
    throw Fail{"PP-E703", n.span, fmt::format("'{}' is not a known variable; declare it with DEF at the top of the program, or check the spelling", name)};
  Var& v = it->second;
  if (!numeric(v.type))
    throw Fail{"PP-E709", n.span, fmt::format("{} is a {} variable; the resolver evaluates only REAL, INT and BOOL values", name, type_name(v.type))};
  if (type_out) *type_out = v.type;
  if (whole_out && n.count == 0 && v.ndims > 0) {
    *whole_out = &v;
    return nullptr;
  }
  return element(v, p, n, p.kids.data() + n.first, n.count, n.span);
}

double Siemens::read_var(const Pool& p, const Node& n) { return *var_slot(p, n, nullptr, nullptr); }

double Siemens::eval(const Pool& p, std::uint32_t idx) {
  const Node& n = p.nodes[idx];
  auto kid = [&](int k) { return eval(p, p.kids[n.first + static_cast<std::uint32_t>(k)]); };
  auto domain = [&](bool bad, std::string_view what) {
    if (bad)
      throw Fail{"PP-E707", n.span, fmt::format("{} in '{}'; correct the values", what, n.span.of(cur_file_->raw(cur_line_)))};
  };
  switch (n.op) {
    case Op::num: return n.num;
    case Op::rparam:
    case Op::rindirect: {
      const int r = n.op == Op::rparam ? n.r : to_index(kid(0), n.span);
      double* s = r_slot(r, n.span);
      std::uint8_t& st = rstate_[static_cast<std::size_t>(r)];
      if (st == 2) {
        r_.used_settings[fmt::format("R{}", r)] = *s;
        st = 1;
      } else if (st == 0) {
        st = 1;
        report(*cur_file_, cur_line_, *cur_L_, n.span, Severity::warning, "PP-W703",
               fmt::format("R{} is read before the program assigns it; taken as 0 (the controller keeps R parameters "
                           "between programs: give its value with --set R{}=…)", r, r));
      }
      return *s;
    }
    case Op::var: return read_var(p, n);
    case Op::sysvar: {
      const std::string& key = p.names[n.name];
      auto it = opt_.set.find(key);
      if (it == opt_.set.end())
        throw Fail{"PP-E701", n.span, fmt::format("{} is run-time state of the controller, unknown before the program runs; "
                                                  "give its value with --set '{}=…' or remove the read", key, key)};
      r_.used_settings[key] = it->second;
      return it->second;
    }
    case Op::neg: return -kid(0);
    case Op::lnot: return kid(0) == 0 ? 1 : 0;
    case Op::bnot: return static_cast<double>(~static_cast<std::int64_t>(std::trunc(kid(0))));
    case Op::add: return kid(0) + kid(1);
    case Op::sub: return kid(0) - kid(1);
    case Op::mul: return kid(0) * kid(1);
    case Op::div: {
      const double a = kid(0), b = kid(1);
      domain(b == 0, "division by zero");
      return a / b;
    }
    case Op::idiv: {
      const double a = kid(0), b = kid(1);
      domain(b == 0, "division by zero");
      return std::trunc(a / b);
    }
    case Op::mod: {
      const double a = kid(0), b = kid(1);
      domain(b == 0, "MOD by zero");
      return std::fmod(a, b);
    }
    case Op::eq: return kid(0) == kid(1) ? 1 : 0;
    case Op::ne: return kid(0) != kid(1) ? 1 : 0;
    case Op::gt: return kid(0) > kid(1) ? 1 : 0;
    case Op::lt: return kid(0) < kid(1) ? 1 : 0;
    case Op::ge: return kid(0) >= kid(1) ? 1 : 0;
    case Op::le: return kid(0) <= kid(1) ? 1 : 0;
    case Op::land: { const bool a = kid(0) != 0, b = kid(1) != 0; return a && b ? 1 : 0; }
    case Op::lor: { const bool a = kid(0) != 0, b = kid(1) != 0; return a || b ? 1 : 0; }
    case Op::lxor: { const bool a = kid(0) != 0, b = kid(1) != 0; return a != b ? 1 : 0; }
    case Op::band: return static_cast<double>(static_cast<std::int64_t>(std::trunc(kid(0))) & static_cast<std::int64_t>(std::trunc(kid(1))));
    case Op::bor: return static_cast<double>(static_cast<std::int64_t>(std::trunc(kid(0))) | static_cast<std::int64_t>(std::trunc(kid(1))));
    case Op::bxor: return static_cast<double>(static_cast<std::int64_t>(std::trunc(kid(0))) ^ static_cast<std::int64_t>(std::trunc(kid(1))));
    case Op::func: {
      const double a = kid(0);
      const double rad = a * kPi / 180.0;
      double v = 0;
      switch (n.fn) {
        case Fn::sin: v = std::sin(rad); break;
        case Fn::cos: v = std::cos(rad); break;
        case Fn::tan:
          domain(std::fabs(std::cos(rad)) < 1e-15, "TAN of 90° (odd multiple) is infinite");
          v = std::tan(rad);
          break;
        case Fn::asin: domain(std::fabs(a) > 1 + 1e-12, "ASIN of a value beyond ±1"); v = std::asin(std::clamp(a, -1.0, 1.0)) * 180.0 / kPi; break;
        case Fn::acos: domain(std::fabs(a) > 1 + 1e-12, "ACOS of a value beyond ±1"); v = std::acos(std::clamp(a, -1.0, 1.0)) * 180.0 / kPi; break;
        case Fn::atan2: v = std::atan2(a, kid(1)) * 180.0 / kPi; break;
        case Fn::sqrt: domain(a < 0, "square root of a negative value"); v = std::sqrt(a); break;
        case Fn::abs: v = std::fabs(a); break;
        case Fn::pot: v = a * a; break;
        case Fn::trunc: v = std::trunc(a); break;
        case Fn::round: v = std::round(a); break;
        case Fn::roundup: v = std::ceil(a); break;
        case Fn::ln: domain(a <= 0, "logarithm of a value ≤ 0"); v = std::log(a); break;
        case Fn::exp: v = std::exp(a); break;
        case Fn::minval: v = std::min(a, kid(1)); break;
        case Fn::maxval: v = std::max(a, kid(1)); break;
        case Fn::bound: {
          const double lo = a, hi = kid(1), x = kid(2);
          v = std::clamp(x, std::min(lo, hi), std::max(lo, hi));
          break;
        }
      }
      domain(!std::isfinite(v), "the result is not a finite number");
      if (std::fabs(v) < 1e-15) v = 0;
      return v;
    }
  }
  return 0;
}

void Siemens::assign(const Pool& p, const Target& t, double v) {
  switch (t.kind) {
    case Target::rconst:
    case Target::rindirect: {
      const int r = t.kind == Target::rconst ? t.r : to_index(eval(p, t.index[0]), p.nodes[t.index[0]].span);
      *r_slot(r, t.span) = v;
      rstate_[static_cast<std::size_t>(r)] = 1;
      return;
    }
    case Target::var: {
      Frame& fr = *frames_.back();
      auto it = fr.vars.find(t.name);
      if (it == fr.vars.end())
        throw Fail{"PP-E703", t.span, fmt::format("'{}' is not a known variable; declare it with DEF at the top of the program, or check the spelling", t.name)};
      Var& var = it->second;
      if (!numeric(var.type))
        throw Fail{"PP-E709", t.span, fmt::format("{} is a {} variable; the resolver evaluates only REAL, INT and BOOL values", t.name, type_name(var.type))};
      Node dummy;
      *element(var, p, dummy, t.index.data(), t.index.size(), t.span) = convert(var.type, v);
      return;
    }
    case Target::sysvar:
      throw Fail{"PP-E709", t.span, fmt::format("writing the system variable {} is not followed by the resolver; set it on the machine", t.name)};
  }
}

void Siemens::declare(Frame& fr, const Pool& p, const Decl& d) {
  for (const DeclVar& dv : d.vars) {
    if (fr.vars.count(dv.name))
      throw Fail{"PP-E702", dv.span, fmt::format("syntax error: '{}' is declared twice; remove one DEF", dv.name)};
    Var v;
    v.type = d.type;
    v.ndims = static_cast<std::uint8_t>(dv.dims.size());
    std::size_t size = 1;
    for (std::size_t k = 0; k < dv.dims.size(); ++k) {
      const int n = to_index(eval(p, dv.dims[k]), p.nodes[dv.dims[k]].span);
      if (n < 1) throw Fail{"PP-E702", dv.span, "syntax error: an array needs at least one element"};
      v.dims[k] = n;
      size *= static_cast<std::size_t>(n);
    }
    v.own = std::make_shared<std::vector<double>>(size, 0.0);
    v.p = v.own->data();
    if (dv.rep) {
      const double x = convert(v.type, eval(p, dv.init[0]));
      std::fill(v.own->begin(), v.own->end(), x);
    } else {
      if (dv.init.size() > size)
        throw Fail{"PP-E702", dv.span, fmt::format("syntax error: {} initial values for {} element(s)", dv.init.size(), size)};
      for (std::size_t k = 0; k < dv.init.size(); ++k) (*v.own)[k] = convert(v.type, eval(p, dv.init[k]));
    }
    fr.vars.emplace(dv.name, std::move(v));
  }
}

// ---- execution ----------------------------------------------------------------------------------

void Siemens::report(SourceFile& f, std::size_t i, const Line& L, Span span, Severity sev, std::string_view code, std::string msg) {
  const std::string where = out_.where();
  if (!where.empty()) msg += "; " + where;
  if (L.lexed_ok) {
    f.report(i, span, sev, code, std::move(msg));
    return;
  }
  // The block lexer rejects this line as written (a statement it cannot read was masked): report
  // directly so the lexer's own complaint is not repeated.
  Block b;
  b.raw = f.raw(i);
  b.line = i + 1;
  report_at(f.context(), b, span, sev, code, std::move(msg));
}

SourceFile* Siemens::find_file(const std::string& name) {
  auto it = file_cache_.find(name);
  if (it != file_cache_.end()) return it->second;
  SourceFile* f = nullptr;
  try {
    f = files_.find({name + ".SPF", "_N_" + name + "_SPF", name + ".MPF"});
  } catch (const std::exception&) {
    f = nullptr;
  }
  file_cache_.emplace(name, f);
  return f;
}

std::optional<std::size_t> Siemens::find_jump(SourceFile& f, std::size_t pc, const Jump& j) {
  const bool fwd = j.kind != GoKind::backward;
  const bool back = j.kind == GoKind::backward || j.kind == GoKind::both || j.kind == GoKind::quiet;
  if (j.is_n) {
    if (fwd) {
      if (auto r = f.find_n(j.n, pc + 1, true)) return r;
    }
    if (back) return f.find_n(j.n, pc, false);
    return std::nullopt;
  }
  parse_all(f);
  const FileData& d = data(f);
  auto it = d.labels.find(j.label);
  if (it == d.labels.end()) return std::nullopt;
  if (fwd)
    for (std::size_t l : it->second)
      if (l > pc) return l;
  if (back)
    for (auto r = it->second.rbegin(); r != it->second.rend(); ++r)
      if (*r <= pc) return *r;
  return std::nullopt;
}

void Siemens::bind(Frame& fr, Line& L) {
  const auto& params = L.proc.params;
  if (fr.args.size() > params.size())
    throw Fail{"PP-E702", L.ctl_span.size() ? L.ctl_span : Span{0, 1},
               fmt::format("syntax error: {} takes {} parameter(s) but the call gives {}; correct the call", L.proc.name, params.size(), fr.args.size())};
  for (std::size_t k = 0; k < params.size(); ++k) {
    const Param& prm = params[k];
    const ArgVal a = k < fr.args.size() ? fr.args[k] : ArgVal{};
    if (!numeric(prm.type))
      throw Fail{"PP-E709", {0, static_cast<std::uint32_t>(cur_file_->raw(cur_line_).size())},
                 fmt::format("parameter {} is {}; the resolver passes only REAL, INT and BOOL values", prm.name, type_name(prm.type))};
    Var v;
    v.type = prm.type;
    if (prm.by_ref) {
      if (a.whole) {
        v = *a.whole;
        v.type = prm.type;
      } else if (a.ref) {
        v.p = a.ref;
      } else if (a.given) {
        throw Fail{"PP-E709", {0, static_cast<std::uint32_t>(cur_file_->raw(cur_line_).size())},
                   fmt::format("VAR parameter {} needs a variable as argument, not a value; pass a variable", prm.name)};
      } else {
        v.own = std::make_shared<std::vector<double>>(1, 0.0);
        v.p = v.own->data();
      }
    } else {
      if (!prm.dims.empty())
        throw Fail{"PP-E702", {0, static_cast<std::uint32_t>(cur_file_->raw(cur_line_).size())},
                   fmt::format("syntax error: array parameter {} must be VAR", prm.name)};
      v.own = std::make_shared<std::vector<double>>(1, convert(prm.type, a.given ? a.value : 0.0));
      v.p = v.own->data();
    }
    fr.vars[prm.name] = std::move(v);
  }
}

bool Siemens::push_call(Frame& caller, Line& L, const Call& c, SourceFile& target, std::size_t start, bool in_file, int repeats) {
  SourceFile& f = *caller.f;
  const std::size_t i = caller.pc;
  if (out_.depth() >= static_cast<std::size_t>(opt_.max_call_depth)) {
    report(f, i, L, c.span, Severity::error, "PP-E706",
           fmt::format("calling {} exceeds the call depth of {}; check for recursion without an end", c.name, opt_.max_call_depth));
    return false;
  }
  auto fr = std::make_unique<Frame>();
  fr->f = &target;
  fr->begin = start;
  fr->pc = start;
  fr->in_file_proc = in_file;
  fr->repeats_left = repeats - 1;
  fr->call_line = i;
  fr->call_span = c.span;
  if (in_file) {
    fr->header = start;
  } else {
    parse_all(target);
    fr->header = data(target).header;
  }
  // Arguments, evaluated in the caller.
  if (c.has_args) {
    for (const auto& a : c.args) {
      ArgVal v;
      if (a) {
        v.given = true;
        const Node& n = L.pool.nodes[*a];
        if (n.op == Op::var) {
          Var* whole = nullptr;
          double* s = var_slot(L.pool, n, &whole, nullptr);
          if (whole) v.whole = whole;
          else {
            v.ref = s;
            v.value = *s;
          }
        } else if (n.op == Op::rparam || n.op == Op::rindirect) {
          v.value = eval(L.pool, *a);
          v.ref = r_slot(n.op == Op::rparam ? n.r : to_index(eval(L.pool, L.pool.kids[n.first]), n.span), n.span);
        } else {
          v.value = eval(L.pool, *a);
        }
      }
      fr->args.push_back(v);
    }
  }
  if (!fr->args.empty() && fr->header == npos) {
    report(f, i, L, c.span, Severity::error, "PP-E702",
           fmt::format("syntax error: {} has no PROC line declaring parameters, but the call passes {}; add PROC {}(…) or remove the arguments",
                       c.name, fr->args.size(), c.name));
    return false;
  }
  out_.push_call(CallFrame{f.name(), i + 1, c.name});
  frames_.push_back(std::move(fr));
  return true;
}

/// Leaves the current frame (RET, M17, end of file). False: the run ends.
bool Siemens::do_return(bool) {
  Frame& fr = *frames_.back();
  if (fr.main) return false;
  if (fr.repeats_left > 0) {
    --fr.repeats_left;
    fr.pc = fr.begin;
    fr.bound = false;
    // Each pass starts with fresh local variables; VAR references stay bound to the caller's.
    fr.vars.clear();
    fr.for_end.clear();
    return true;
  }
  frames_.pop_back();
  out_.pop_call();
  ++frames_.back()->pc;
  return true;
}

bool Siemens::step(Frame& fr, Line& L) {
  SourceFile& f = *fr.f;
  const std::size_t i = fr.pc;
  cur_file_ = &f;
  cur_line_ = i;
  cur_L_ = &L;
  if (L.lex_failed) {
    (void)f.block(i);  // the lexer reports what it cannot read
    if (!sink_.has_errors()) {
      Block b;
      b.raw = f.raw(i);
      b.line = i + 1;
      report_at(f.context(), b, {0, 1}, Severity::error, "PP-E702", "syntax error: the block cannot be read; correct it");
    }
    return false;
  }
  if (L.error) {
    fail(f, i, L, *L.error);
    return false;
  }
  try {
    if (L.has_proc) {
      if (fr.header == i && !fr.bound) {
        bind(fr, L);
        fr.bound = true;
      } else if (fr.main) {
        report(f, i, L, {0, static_cast<std::uint32_t>(f.raw(i).size())}, Severity::warning, "PP-W704",
               fmt::format("the main program runs into the definition of PROC {}; the run ends here (end the main program with M30)", L.proc.name));
        return false;
      } else {
        return do_return(true);  // the next PROC ends this body
      }
    }
    edits_.clear();
    const Call* call = nullptr;
    SourceFile* call_target = nullptr;
    std::size_t call_start = 0;
    bool call_in_file = false;
    int dyn_deleted = 0;
    for (const Item& it : L.items) {
      switch (it.kind) {
        case Item::assign: {
          const Assign& a = L.assigns[it.index];
          assign(L.pool, a.target, eval(L.pool, a.expr));
          break;
        }
        case Item::word: {
          const WordSub& s = L.subs[it.index];
          edits_.push_back({s.edit, format_value(eval(L.pool, s.expr), s.letter)});
          break;
        }
        case Item::decl: declare(fr, L.pool, L.decls[it.index]); break;
        case Item::setal: {
          const double v = eval(L.pool, L.setal[it.index]);
          throw Fail{"PP-E710", L.deletes.empty() ? Span{0, 1} : L.deletes.front(),
                     fmt::format("the program raises alarm {} (SETAL); on the machine it stops here — check the condition that led to it",
                                 format_value(v, 'M'))};
        }
        case Item::call: {
          const Call& c = L.calls[it.index];
          SourceFile* found = nullptr;
          std::size_t found_start = 0;
          bool found_in_file = false;
          // Same-file PROC first, then a file in the search folders.
          parse_all(f);
          const FileData& d = data(f);
          if (auto p = d.procs.find(c.name); p != d.procs.end() && c.kind != Call::lword) {
            found = &f;
            found_start = p->second;
            found_in_file = true;
          } else if (SourceFile* t = find_file(c.name)) {
            found = t;
          }
          if (!found) {
            if (c.kind == Call::named) break;  // a controller function or cycle: left for the interpreter
            throw Fail{"PP-E704", c.span, fmt::format("subprogram {} not found: no PROC {} in this file and no {}.SPF in the search folders ({}); "
                                                      "put the file next to the program", c.name, c.name, c.name, opt_.search_dirs.empty() ? "none given" : fmt::format("{}", fmt::join(opt_.search_dirs, ", ")))};
          }
          if (call)
            throw Fail{"PP-E709", c.span, fmt::format("two subprogram calls in one block ({} and {}) are not supported; write one per block", call->name, c.name)};
          if (L.ctl != Ctl::none)
            throw Fail{"PP-E709", c.span, "a subprogram call and control flow in one block are not supported; split the block"};
          call = &c;
          call_target = found;
          call_start = found_start;
          call_in_file = found_in_file;
          ++dyn_deleted;
          if (c.has_args && c.kind == Call::named && c.args.empty()) {
            // Arguments are parsed only now that the call is known to be a subprogram.
            const std::string_view raw = f.raw(i);
            const auto open = raw.find('(', c.span.begin);
            Call& mc = const_cast<Call&>(c);
            parse_args(L, mc, raw, static_cast<std::uint32_t>(open), c.span.end - 1);
          }
          edits_.push_back({c.span, {}});
          break;
        }
      }
    }
    int repeats = 1;
    if (call && L.has_p) {
      const double pv = L.p_expr ? eval(L.pool, *L.p_expr) : L.p_value;
      if (pv < 1 || pv != std::round(pv))
        throw Fail{"PP-E702", L.p_span, fmt::format("syntax error: the repeat count P{} must be a whole number ≥ 1", format_value(pv, 'P'))};
      repeats = static_cast<int>(pv);
      edits_.push_back({L.p_span, {}});
      ++dyn_deleted;
    }
    // Control flow: where to go after this line.
    std::size_t next = i + 1;
    bool stop = false, ret = false;
    auto structure_of = [&]() -> FileData& {
      structure(f);
      FileData& d = data(f);
      if (!d.match_error[i].empty()) throw Fail{"PP-E708", L.ctl_span, d.match_error[i]};
      return d;
    };
    auto partner = [&](FileData& d) { return static_cast<std::size_t>(d.match[i]); };
    auto go = [&](const Jump& jump) {
      auto t = find_jump(f, i, jump);
      if (t) {
        next = *t;
      } else if (jump.kind != GoKind::quiet) {
        throw Fail{"PP-E704", jump.span,
                   fmt::format("jump target {} not found {}; add the label or block number, or check the spelling",
                               jump.is_n ? fmt::format("N{}", format_value(jump.n, 'N')) : jump.label + ":",
                               jump.kind == GoKind::forward ? "after this block (GOTOF searches forward)"
                               : jump.kind == GoKind::backward ? "before this block (GOTOB searches backward)"
                                                               : "in this program")};
      }
    };
    switch (L.ctl) {
      case Ctl::none: break;
      case Ctl::if_goto:
        if (eval(L.pool, L.cond) != 0) go(L.jump);
        break;
      case Ctl::go: go(L.jump); break;
      case Ctl::case_: {
        // The first branch whose value equals the expression, else DEFAULT, else the next line.
        const double v = eval(L.pool, L.cond);
        const Jump* to = L.case_default ? &*L.case_default : nullptr;
        for (const auto& [value, jump] : L.cases)
          if (eval(L.pool, value) == v) {
            to = &jump;
            break;
          }
        if (to != nullptr) go(*to);
        break;
      }
      case Ctl::if_block: {
        FileData& d = structure_of();
        if (eval(L.pool, L.cond) == 0) {
          const std::size_t t = partner(d);
          next = data(f).lines[t]->ctl == Ctl::else_ ? t + 1 : t;
        }
        break;
      }
      case Ctl::else_: {
        FileData& d = structure_of();
        if (d.match[i] < 0) throw Fail{"PP-E708", L.ctl_span, "ELSE without an open IF; check the IF/ELSE/ENDIF structure"};
        next = partner(d);
        break;
      }
      case Ctl::endif: (void)structure_of(); break;
      case Ctl::while_: {
        FileData& d = structure_of();
        if (eval(L.pool, L.cond) == 0) next = partner(d) + 1;
        break;
      }
      case Ctl::endwhile: next = partner(structure_of()); break;
      case Ctl::for_: {
        FileData& d = structure_of();
        const double from = eval(L.pool, L.for_from);
        const double to = eval(L.pool, L.for_to);
        assign(L.pool, L.for_var, from);
        fr.for_end[i] = to;
        if (from > to) next = partner(d) + 1;
        break;
      }
      case Ctl::endfor: {
        FileData& d = structure_of();
        const std::size_t head = partner(d);
        auto e = fr.for_end.find(head);
        if (e == fr.for_end.end())
          throw Fail{"PP-E708", L.ctl_span, fmt::format("ENDFOR reached without running the FOR at line {} (a jump into the loop); check the structure", head + 1)};
        Line& H = *d.lines[head];
        cur_L_ = &H;
        // Read and increment the counter through the FOR line's own target.
        double v = 0;
        {
          const Target& t = H.for_var;
          if (t.kind == Target::var) {
            auto it = fr.vars.find(t.name);
            if (it == fr.vars.end()) throw Fail{"PP-E703", L.ctl_span, fmt::format("FOR variable '{}' is not declared; declare it with DEF INT", t.name)};
            Var& var = it->second;
            Node dummy;
            cur_line_ = head;
            v = *element(var, H.pool, dummy, t.index.data(), t.index.size(), t.span);
          } else {
            cur_line_ = head;
            const int r = t.kind == Target::rconst ? t.r : to_index(eval(H.pool, t.index[0]), t.span);
            v = *r_slot(r, t.span);
          }
          v += 1;
          assign(H.pool, t, v);
          cur_line_ = i;
          cur_L_ = &L;
        }
        if (v <= e->second) next = head + 1;
        break;
      }
      case Ctl::repeat: (void)structure_of(); break;
      case Ctl::until: {
        FileData& d = structure_of();
        if (eval(L.pool, L.cond) == 0) next = partner(d) + 1;
        break;
      }
      case Ctl::loop: (void)structure_of(); break;
      case Ctl::endloop: next = partner(structure_of()) + 1; break;
      case Ctl::ret:
        ret = true;
        break;
    }
    if (L.m17 && !fr.main) {
      edits_.push_back({L.m17_span, {}});
      ret = true;
    } else if (L.m17) {
      stop = true;
    }
    if (L.end_program) stop = true;
    if (ret && fr.main) stop = true;
    // Emit.
    bool emitted;
    if (L.others == 0 && dyn_deleted == static_cast<int>(L.calls.size() + (L.has_p ? 1 : 0)) && !(L.m17 && fr.main)) {
      const Edit all{{0, static_cast<std::uint32_t>(f.raw(i).size())}, {}};
      emitted = out_.emit(f, i, std::span<const Edit>(&all, 1));
    } else {
      for (const Span& s : L.deletes) edits_.push_back({s, {}});
      std::sort(edits_.begin(), edits_.end(), [](const Edit& a, const Edit& b) { return a.span.begin < b.span.begin; });
      // Deletions swallowed the blanks after them; drop overlaps with a following call/P deletion.
      for (std::size_t k = 1; k < edits_.size(); ++k)
        if (edits_[k].span.begin < edits_[k - 1].span.end) edits_[k].span.begin = edits_[k - 1].span.end;
      emitted = out_.emit(f, i, edits_);
    }
    if (!emitted) {
      report(f, i, L, {0, static_cast<std::uint32_t>(std::max<std::size_t>(1, f.raw(i).size()))}, Severity::error, "PP-E705",
             fmt::format("more than {} blocks executed: the program does not end (an endless loop?); check the loop condition, "
                         "or raise the block limit", opt_.max_blocks));
      return false;
    }
    if (stop) return false;
    if (call) {
      return push_call(fr, L, *call, *call_target, call_start, call_in_file, repeats);
    }
    if (ret) return do_return(true);
    fr.pc = next;
    return true;
  } catch (const Fail& e) {
    fail(f, i, *cur_L_, e);
    return false;
  }
}

void Siemens::run() {
  auto main = std::make_unique<Frame>();
  main->f = &files_.main();
  main->main = true;
  frames_.push_back(std::move(main));
  {
    // A PROC heading the main program is bound with no arguments.
    SourceFile& f = files_.main();
    parse_all(f);
    frames_.back()->header = data(f).header;
  }
  while (!frames_.empty()) {
    Frame& fr = *frames_.back();
    SourceFile& f = *fr.f;
    if (fr.pc >= f.lines()) {
      if (!do_return(true)) return;
      continue;
    }
    Line& L = line(f, fr.pc);
    if (L.trivial) {
      if (!out_.emit(f, fr.pc, {})) {
        cur_file_ = &f;
        cur_line_ = fr.pc;
        report(f, fr.pc, L, {0, static_cast<std::uint32_t>(std::max<std::size_t>(1, f.raw(fr.pc).size()))}, Severity::error, "PP-E705",
               fmt::format("more than {} blocks executed: the program does not end (an endless loop?); check the loop condition, "
                           "or raise the block limit", opt_.max_blocks));
        return;
      }
      ++fr.pc;
      continue;
    }
    if (!step(fr, L)) return;
  }
}

}  // namespace

void resolve_siemens(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r) {
  Siemens s(files, out, opt, sink, r);
  s.run();
}

}  // namespace postproc::gcode::resolver
