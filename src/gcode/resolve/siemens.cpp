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
// Warnings: PP-W704 main program runs into a PROC definition (the run ends there). An R parameter
// read before it is assigned is PP-E701 (its value is the machine's).
#include "siemens_runner.hpp"

namespace postproc::gcode::resolver {
namespace siemens_run {

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
  Var& v = it != fr.vars.end() ? it->second : global(name, n.span, false, n.count);
  if (!numeric(v.type))
    throw Fail{"PP-E709", n.span, fmt::format("{} is a {} variable; the resolver evaluates only REAL, INT and BOOL values", name, type_name(v.type))};
  if (type_out) *type_out = v.type;
  if (whole_out && n.count == 0 && v.ndims > 0) {
    *whole_out = &v;
    return nullptr;
  }
  return element(v, p, n, p.kids.data() + n.first, n.count, n.span);
}

Var& Siemens::global(const std::string& name, Span span, bool write, std::size_t indices) {
  // A name the program uses without DEF: a global user variable (GUD) or another variable defined on
  // the controller, not in the program (Job planning, "Global user data (GUD)"). Its value is the
  // controller's: known only when the program writes it first or the user gives it (--set).
  if (auto g = globals_.find(name); g != globals_.end()) return g->second;
  const auto make = [&](double value) -> Var& {
    Var v;
    v.own = std::make_shared<std::vector<double>>(1, value);
    v.p = v.own->data();
    return globals_.emplace(name, std::move(v)).first->second;
  };
  if (indices == 0) {
    for (const auto& [key, value] : opt_.set)
      if (text::iequals(key, name)) {
        r_.used_settings[key] = value;
        return make(value);
      }
    if (write) return make(0.0);
  }
  throw Fail{"PP-U242", span,
             fmt::format("'{}' is not defined in this program: a global user variable (GUD) or machine data whose value "
                         "is known only on the controller; give it with --set {}=… (or DEF it in the program){}",
                         name, name, indices ? " — an undeclared array cannot be given this way" : "")};
}

double Siemens::read_var(const Pool& p, const Node& n) { return *var_slot(p, n, nullptr, nullptr); }

double Siemens::eval(const Pool& p, std::uint32_t idx) {
  const Node& n = p.nodes[idx];
  auto kid = [&](int k) { return eval(p, p.kids[n.first + static_cast<std::uint32_t>(k)]); };
  auto domain = [&](bool bad, std::string_view what) {
    if (bad)
      throw Fail{"PP-E707", n.span, fmt::format("{} in '{}'; correct the values", what, n.span.of(cur_file_->raw(cur_line_)))};
  };
  // Overflow is an error at the expression that produced it, never an 'inf' word.
  auto finite = [&](double v, std::string_view what) {
    domain(!std::isfinite(v), fmt::format("the {} overflows (beyond ±1.8e308)", what));
    return v;
  };
  // Operands of DIV, B_AND, B_OR, B_XOR, B_NOT: exact integers of a 64-bit word.
  auto integer = [&](double v) {
    domain(!integer_range(std::trunc(v)), fmt::format("the operand {} is too large for an integer operation (beyond ±2^53)", v));
    return static_cast<std::int64_t>(std::trunc(v));
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
        // R parameters are kept by the control between programs (and set by the operator): a read
        // before the program assigns one is a value only the machine knows (as Fanuc's retained
        // variables), so the block that reads it is refused rather than run with a guess.
        throw Fail{"PP-E701", n.span,
                   fmt::format("R{} is read before the program assigns it: the control keeps R parameters between "
                               "programs, so its value is what an earlier program or the operator left; give it with "
                               "--set R{}=…",
                               r, r)};
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
    case Op::bnot: return static_cast<double>(~integer(kid(0)));
    case Op::add: return finite(kid(0) + kid(1), "sum");
    case Op::sub: return finite(kid(0) - kid(1), "difference");
    case Op::mul: return finite(kid(0) * kid(1), "product");
    case Op::div: {
      const double a = kid(0), b = kid(1);
      domain(b == 0, "division by zero");
      return finite(a / b, "quotient");
    }
    case Op::idiv: {
      const double a = kid(0), b = kid(1);
      domain(b == 0, "division by zero");
      return std::trunc(finite(a / b, "quotient"));
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
    case Op::band: return static_cast<double>(integer(kid(0)) & integer(kid(1)));
    case Op::bor: return static_cast<double>(integer(kid(0)) | integer(kid(1)));
    case Op::bxor: return static_cast<double>(integer(kid(0)) ^ integer(kid(1)));
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
      if (!std::isfinite(v)) {
        std::string_view name = "the function";
        for (const FnInfo& f : kFunctions)
          if (f.fn == n.fn) name = f.name;
        domain(true, fmt::format("{} overflows (beyond ±1.8e308)", name));
      }
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
      double* slot = r_slot(r, t.span);
      if (*slot != v) guard_.changed();  // a new value is progress for the loop guard
      *slot = v;
      rstate_[static_cast<std::size_t>(r)] = 1;
      return;
    }
    case Target::var: {
      Frame& fr = *frames_.back();
      auto it = fr.vars.find(t.name);
      Var& var = it != fr.vars.end() ? it->second : global(t.name, t.span, true, t.index.size());
      if (!numeric(var.type))
        throw Fail{"PP-E709", t.span, fmt::format("{} is a {} variable; the resolver evaluates only REAL, INT and BOOL values", t.name, type_name(var.type))};
      Node dummy;
      double* slot = element(var, p, dummy, t.index.data(), t.index.size(), t.span);
      if (*slot != convert(var.type, v)) guard_.changed();
      *slot = convert(var.type, v);
      return;
    }
    case Target::sysvar:
      throw Fail{"PP-E709", t.span, fmt::format("writing the system variable {} is not followed by the resolver; set it on the machine", t.name)};
  }
}

void Siemens::declare(Frame& fr, const Pool& p, const Decl& d) {
  guard_.changed();
  for (const DeclVar& dv : d.vars) {
    if (fr.vars.count(dv.name))
      throw Fail{"PP-E702", dv.span, fmt::format("syntax error: '{}' is declared twice; remove one DEF", dv.name)};
    Var v;
    v.type = d.type;
    v.ndims = static_cast<std::uint8_t>(dv.dims.size());
    std::size_t size = 1;
    for (std::size_t k = 0; k < dv.dims.size(); ++k) {
      const double dim = eval(p, dv.dims[k]);
      if (dim > static_cast<double>(opt_.max_array_elements))
        throw Fail{"PP-E714", p.nodes[dv.dims[k]].span,
                   fmt::format("the array {} would have {} elements or more, more than {}, the limit of the resolver "
                               "(--max-array-elements); declare a smaller array",
                               dv.name, format_value(dim, 'P'), opt_.max_array_elements)};
      const int n = to_index(dim, p.nodes[dv.dims[k]].span);
      if (n < 1) throw Fail{"PP-E702", dv.span, "syntax error: an array needs at least one element"};
      v.dims[k] = n;
      size *= static_cast<std::size_t>(n);  // ≤ 1e6 per dimension, ≤ 3 dimensions: no overflow
    }
    // Checked before allocating: an absurd DEF is a located refusal, not an out-of-memory failure.
    if (size > opt_.max_array_elements || array_elements_ + size > opt_.max_array_elements)
      throw Fail{"PP-E714", dv.span,
                 fmt::format("the array {} has {} elements; with the arrays already declared that is more than {}, the "
                             "limit of the resolver (--max-array-elements); declare a smaller array",
                             dv.name, size, opt_.max_array_elements)};
    array_elements_ += size;
    fr.array_elements += size;
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
  guard_.changed();
  return true;
}

/// Leaves the current frame (RET, M17, end of file). False: the run ends.
bool Siemens::do_return(bool) {
  guard_.changed();  // a return, or the next pass of a repeated call
  Frame& fr = *frames_.back();
  if (fr.main) return false;
  if (fr.repeats_left > 0) {
    --fr.repeats_left;
    fr.pc = fr.begin;
    fr.bound = false;
    // Each pass starts with fresh local variables; VAR references stay bound to the caller's.
    fr.vars.clear();
    fr.for_end.clear();
    array_elements_ -= fr.array_elements;
    fr.array_elements = 0;
    return true;
  }
  array_elements_ -= fr.array_elements;
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
          try {
            edits_.push_back({s.edit, format_value(eval(L.pool, s.expr), s.letter)});
          } catch (const Fail& e) {
            if (std::string_view(e.code) != "PP-U242") throw;
            // Only this word depends on the unknown value: it stays as written, and the
            // interpreter reads its effect as unknown (this block is refused, not the program).
            report(f, i, L, e.span, Severity::warning, e.code, e.message);
          }
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
      repeats = saturate<int>(pv);
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
        guard_.changed();
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
            Var& var = it != fr.vars.end() ? it->second : global(t.name, L.ctl_span, false, t.index.size());
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
             fmt::format("{} executed: the program does not end (an endless loop?); check the loop condition",
                         runaway_limits(opt_)));
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
    const std::size_t at = fr.pc, depth = frames_.size();
    const auto endless = [&](const std::string& why) {
      cur_file_ = &f;
      cur_line_ = at;
      report(f, at, L, {0, static_cast<std::uint32_t>(std::max<std::size_t>(1, f.raw(at).size()))}, Severity::error,
             "PP-E705", why);
    };
    if (!guard_.step(out_.emitted())) {
      endless(guard_.silent_message());
      return;
    }
    if (L.trivial) {
      if (!out_.emit(f, fr.pc, {})) {
        cur_file_ = &f;
        cur_line_ = fr.pc;
        report(f, fr.pc, L, {0, static_cast<std::uint32_t>(std::max<std::size_t>(1, f.raw(fr.pc).size()))}, Severity::error, "PP-E705",
               fmt::format("{} executed: the program does not end (an endless loop?); check the loop condition",
                           runaway_limits(opt_)));
        return;
      }
      ++fr.pc;
      continue;
    }
    if (!step(fr, L)) return;
    // Back to an earlier line of the same call (ENDWHILE, ENDLOOP, UNTIL, GOTOB …): with nothing
    // changed since the last time there, the loop never ends.
    if (frames_.size() == depth && frames_.back().get() == &fr && fr.pc <= at &&
        !guard_.back_jump(f.index(), depth, fr.pc)) {
      endless(LoopGuard::no_progress_message());
      return;
    }
  }
}

}  // namespace siemens_run

void resolve_siemens(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r) {
  siemens_run::Siemens s(files, out, opt, sink, r);
  s.run();
}

}  // namespace postproc::gcode::resolver
