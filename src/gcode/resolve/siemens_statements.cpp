// The Siemens resolver: each source line parsed once into its statements (see siemens_runner.hpp),
// and the IF/WHILE/FOR/REPEAT/LOOP structure of a file matched.
#include "siemens_runner.hpp"

#include "src/gcode/rotary_direction.hpp"

namespace postproc::gcode::resolver::siemens_run {

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
        // AC(…) / IC(…) / DC(…) / ACP(…) / ACN(…): the argument is the expression, the wrapper kept.
        const bool wrapped = text::starts_with_i(v, "AC(") || text::starts_with_i(v, "IC(") ||
                             direction_of(v) != RotaryDirection::none;
        if (wrapped && v.back() == ')')
          s.edit = {static_cast<std::uint32_t>(m.value.begin + v.find('(') + 1), m.value.end - 1};
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
          throw Fail{"PP-E709", w.value, fmt::format("'{}' combines AC/IC/DC/ACP/ACN with more terms; write the function alone", w.value.of(raw))};
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

}  // namespace postproc::gcode::resolver::siemens_run
