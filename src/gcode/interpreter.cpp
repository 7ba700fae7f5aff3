// Modal interpreter, part 1: gathering words, modal state, statements. Motion geometry lives in
// interpreter_motion.cpp.
#include "postproc/gcode/interpreter.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "postproc/gcode/lexer.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/rotary_direction.hpp"
#include "src/gcode/codes.hpp"
#include "src/gcode/number_text.hpp"
#include "src/gcode/siemens_keywords.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode {
namespace {
using text::iequals;
using text::starts_with_i;

/// LinuxCNC stops on a D, E or H word that nothing in its block uses (rs274 2.9, each rule
/// confirmed with rs274 -g; its messages list fewer codes than it accepts): D needs G41, G41.1,
/// G42, G42.1, G96 or a G70–G72 lathe cycle; E needs G70, G76, M66, M67 or M68; H needs G43, G43.2
/// or G76. A motion counts when the block names it or repeats it with axis words (rs274's
/// motion_to_be). The block passes when it holds an M code a configuration may remap (rs274 then
/// skips every check) or a G code this reader does not know (refused for that already). Returns the
/// letter refused and rs274's message, or 0. (A template: Interpreter::BlockWords is private to the
/// interpreter; the call deduces it.)
template <class BlockWords>
std::pair<char, const char*> unused_lcnc_word(const Block& b, const BlockWords& w, std::uint16_t modal_motion10) {
  constexpr std::uint32_t kDEH = (1u << ('D' - 'A')) | (1u << ('E' - 'A')) | (1u << ('H' - 'A'));
  if ((w.letter_present & kDEH) == 0) return {0, nullptr};
  if (std::count_if(b.words.begin(), b.words.end(), [](const Word& x) { return x.letter == 'G'; }) != w.ng)
    return {0, nullptr};
  bool m66_68 = false;
  for (int i = 0; i < w.m_count; ++i) {
    const double m = w.m[static_cast<std::size_t>(i)];
    const bool standard = m == 0 || m == 1 || m == 2 || m == 3 || m == 4 || m == 5 || m == 7 || m == 8 || m == 9 ||
                          m == 30 || m == 60 || (m >= 48 && m <= 53) || (m >= 62 && m <= 68) || (m >= 70 && m <= 73);
    if (!standard) return {0, nullptr};
    m66_68 = m66_68 || (m >= 66 && m <= 68);
  }
  const std::uint16_t motion = w.motion.def != nullptr ? w.motion.def->code10 : w.axis_present != 0 ? modal_motion10 : 0;
  const auto in_block = [&](std::initializer_list<std::uint16_t> codes) {
    for (int k = 0; k < w.ng; ++k)
      if (std::find(codes.begin(), codes.end(), w.g[static_cast<std::size_t>(k)].def->code10) != codes.end()) return true;
    return false;
  };
  const bool lathe_cycle = motion == 700 || motion == 710 || motion == 711 || motion == 712 || motion == 720 ||
                           motion == 721 || motion == 722;
  if (w.has('D') && !in_block({410, 411, 420, 421, 960}) && !lathe_cycle)
    return {'D', "D word with no G41, G41.1, G42, G42.1, G71, G71.1, G71.2 or G96 to use it"};
  if (w.has('E') && motion != 700 && motion != 760 && !m66_68)
    return {'E', "E word with no G70, G76, M66, M67 or M68 to use it"};
  if (w.has('H') && !in_block({430, 432}) && motion != 760) return {'H', "H word with no G43 or G76 to use it"};
  return {0, nullptr};
}

/// rs274's read_integer_value (T, H and M words; L is checked with its cycle): a value within 0.0001
/// of a whole number is that number (floor, or the next one up when the fraction exceeds 0.9999);
/// any other stops the program ("Non integer value for integer"). Snaps the block's values and
/// returns the index of the first word refused, or -1.
template <class BlockWords>
int lcnc_whole_words(BlockWords& w) {
  const auto snap = [](double& v) {
    const double f = std::floor(v), frac = v - f;
    if (frac > 0.9999) v = f + 1;
    else if (frac > 0.0001) return false;
    else v = f;
    return true;
  };
  int bad = -1;
  for (const char L : {'T', 'H'}) {
    const auto li = static_cast<std::size_t>(L - 'A');
    if (w.has(L) && !w.unresolved(L) && !snap(w.letter[li]) && (bad < 0 || w.letter_word[li] < bad)) bad = w.letter_word[li];
  }
  for (int i = 0; i < w.m_count; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (!snap(w.m[k]) && (bad < 0 || w.m_word[k] < bad)) bad = w.m_word[k];
  }
  return bad;
}

/// Largest magnitude accepted for any word value (1e9 mm = 1000 km): beyond it, arithmetic in mm or
/// inches could overflow, and no machine moves that far.
constexpr double kMaxMagnitude = 1e9;

/// Words whose whole-number values Fanuc reads in least input increments (Q too, but only as the
/// peck depth of a drilling cycle: G5.1 Q1 or M98 Q are plain numbers).
constexpr bool is_length_or_angle(char L) {
  switch (L) {
    case 'X': case 'Y': case 'Z': case 'U': case 'V': case 'W': case 'A': case 'B': case 'C':
    case 'I': case 'J': case 'K': case 'R': return true;
    default: return false;
  }
}

/// Value inside Siemens AC(…)/IC(…) when it is a literal number.
bool fn_literal(std::string_view text, double& out) {
  const auto open = text.find('(');
  const auto close = text.rfind(')');
  if (open == std::string_view::npos || close == std::string_view::npos || close <= open) return false;
  std::string_view inner = text.substr(open + 1, close - open - 1);
  while (!inner.empty() && inner.front() == ' ') inner.remove_prefix(1);
  while (!inner.empty() && inner.back() == ' ') inner.remove_suffix(1);
  return scan_number(inner, 0, false) == inner.size() && parse_number(inner, out);
}

/// Siemens keywords that only set state irrelevant to geometry.
constexpr std::string_view kSiemensStateKeywords[] = {
    "CFC", "CFTCP", "CFIN", "FFWON", "FFWOF", "SOFT", "BRISK", "DRIVE", "COMPCAD", "COMPCURV", "COMPOF",
    "COMPON", "FNORM", "FLIN", "FCUB", "CPRECON", "CPRECOF", "UPATH", "SPATH", "ORISON", "ORISOF", "ORIWKS",
    "ORIMKS", "ORIAXES", "ORIVECT", "ORIEULER", "ORIRPY", "ORIRPY2", "ORIVIRT1", "ORIVIRT2", "ORIPLANE",
    "ORICONCW", "ORICONCCW", "ORICONIO", "ORICONTO", "ORICURVE", "ORIPATH", "ORIROTA", "ORIROTR", "ORIROTT",
    "ORIROTC", "ORIC", "ORID", "OSOF", "OSC", "OST", "OSS", "OSSE", "STOPRE", "WAITM", "WAITE", "WAITS",
    "SPOS", "LIMS", "DIAMCYCOF", "G_GROUP", "ACN", "ACP", "DC", "CDON", "CDOF", "CDOF2", "SOFTA", "BRISKA",
    "DYNNORM", "DYNPOS", "DYNROUGH", "DYNSEMIFIN", "DYNFINISH", "TCOABS", "TCOFR", "PAROT", "PAROTOF",
    "TOROT", "TOROTOF", "TOFRAME", "RTLION", "RTLIOF", "GWPSON", "GWPSOF", "SETMS", "M17", "RET",
};

}  // namespace

bool siemens_state_keyword(std::string_view name) {
  for (std::string_view k : kSiemensStateKeywords)
    if (text::iequals(name, k)) return true;
  return false;
}

Interpreter::Interpreter(const Dialect& dialect, std::string file, DiagnosticSink& sink, InterpreterOptions opt)
    : d_(dialect), file_(std::move(file)), sink_(&sink), opt_(opt) {
  s_.diameter_mode = d_.diameter_axis != 0;
  s_.motion = s_.interp_motion = d_.power_on_motion;
  s_.motion_code10 = s_.interp_code10 = d_.power_on_motion == GMeaning::linear ? 10 : 0;
  if (d_.lathe) s_.plane = Plane::zx;  // lathes power up in G18
  // LinuxCNC's interpreter starts in G99 (retract to the R plane; rs274 agrees); Fanuc powers on in G98.
  if (d_.id == DialectId::linuxcnc) s_.return_to_r = true;
  // LinuxCNC's interpreter starts with a feed rate of 0: a feed move before any F is refused ("Cannot
  // do G1 with zero feed rate"; rs274 -g). (Fanuc and Sinumerik keep the last program's F after a
  // reset, depending on parameters: a run-time value the positions do not depend on.)
  if (d_.id == DialectId::linuxcnc) s_.feed_undefined = true;
  if (d_.id == DialectId::siemens) {
    // Reset state (MD20150 $MC_GCODE_RESET_VALUES, factory setting): G1 in group 1, units of the
    // basic system (MD10240). 840D sl Fundamentals, "List of G functions".
    s_.inch = s_.feed_inch = d_.basic_inch;
    s_.motion = d_.reset_motion;
    s_.motion_code10 = d_.reset_motion == GMeaning::rapid ? 0 : d_.reset_motion == GMeaning::linear ? 10 : 0;
  }
}

void Interpreter::report(const Block& b, Span at, Severity sev, std::string_view code, std::string msg) {
  const LexContext ctx{file_, sink_};
  report_at(ctx, b, at, sev, code, std::move(msg));
}

double Interpreter::to_mm(int axis, double v) const {
  if (is_rotary(axis)) return v;
  return s_.inch ? v * 25.4 : v;
}

void Interpreter::unresolved_motion(const Block& b, const BlockWords& w, std::string_view code, std::string what) {
  Span at = w.motion.word >= 0 ? b.words[static_cast<std::size_t>(w.motion.word)].span : Span{};
  if (w.motion.word < 0) {
    for (int a = 0; a < kAxisCount; ++a)
      if (w.axis_word[static_cast<std::size_t>(a)] >= 0) {
        at = b.words[static_cast<std::size_t>(w.axis_word[static_cast<std::size_t>(a)])].span;
        break;
      }
  }
  report(b, at, Severity::warning, code,
         fmt::format("{} is not resolved by this version; positions after it are unknown until absolute "
                     "moves re-establish them (compensation refuses the program unless --pass-through)",
                     what));
}

bool Interpreter::collect(const Block& b, BlockWords& w) {
  w.axis_word.fill(-1);
  w.letter_word.fill(-1);
  bool ok = true;
  // Fanuc lathe G-code system A: U W H are incremental X Z C. In systems B/C they are not (G91 is
  // used; B-64484EN "G code system" / "Absolute and incremental programming").
  const bool lathe_incremental = d_.lathe && d_.id == DialectId::fanuc && d_.gcode_system == 'A';
  // Units for reading whole numbers as increments: a G20/G21 anywhere in this block applies.
  bool inch = s_.inch;
  bool any_whole = false;
  bool drilling = s_.motion == GMeaning::drill_cycle;
  bool r_count = false;  // Fanuc lathe G73 U W R(d): R is a number of divisions, not a length
  if (d_.integer_input != Dialect::IntegerInput::calculator)
    for (const Word& word : b.words) {
      any_whole = any_whole || (word.whole && (is_length_or_angle(word.letter) || word.letter == 'Q'));
      if (word.letter == 'G' && word.kind == ValueKind::number && word.number >= 0 && word.number < 2000)
        if (const GCodeDef* def = d_.find_g(static_cast<std::uint16_t>(std::lround(word.number * 10))))
          if (def->group == GGroup::motion) {
            drilling = def->meaning == GMeaning::drill_cycle;
            r_count = d_.lathe && def->meaning == GMeaning::turning_cycle && def->code10 == 730;
          }
    }
  if (any_whole)
    for (const Word& word : b.words)
      if (word.letter == 'G' && word.kind == ValueKind::number && word.number >= 0 && word.number < 2000)
        if (const GCodeDef* def = d_.find_g(static_cast<std::uint16_t>(std::lround(word.number * 10))))
          inch = def->meaning == GMeaning::inch ? true : def->meaning == GMeaning::mm ? false : inch;
  for (std::size_t i = 0; i < b.words.size(); ++i) {
    const Word& word = b.words[i];
    const auto wi = static_cast<std::int16_t>(i);
    double v = word.number;
    bool resolved = word.kind == ValueKind::number;
    bool fn_abs = false, fn_inc = false;
    if (word.kind == ValueKind::absolute_fn || word.kind == ValueKind::incremental_fn) {
      resolved = fn_literal(b.text(word.value), v);
      fn_abs = word.kind == ValueKind::absolute_fn;
      fn_inc = !fn_abs;
    }
    if (resolved && word.kind == ValueKind::number && d_.integer_input != Dialect::IntegerInput::calculator &&
        v != 0 && word.whole &&
        ((is_length_or_angle(word.letter) && !(word.letter == 'K' && drilling && d_.id == DialectId::fanuc) &&
          !(word.letter == 'R' && r_count)) ||
         (word.letter == 'Q' && drilling))) {
      // (In a Fanuc drilling cycle K is the repeat count, a plain number.)
      // Fanuc with standard input (DPI=0): X100 means 100 least input increments.
      const bool angle = word.letter >= 'A' && word.letter <= 'C';
      v *= angle ? 0.001 : (inch ? 0.0001 : 0.001);
      if (d_.integer_input == Dialect::IntegerInput::unknown && !warned_integer_input_) {
        warned_integer_input_ = true;
        report(b, word.span, Severity::warning, codes::kIntegerInput,
               fmt::format("'{}' has no decimal point: a Fanuc control with standard input reads it as {:g} {}, one "
                           "with calculator-type input (parameter DPI=1, Haas) as {:g}; read as {:g} — pass "
                           "--integer-input increment|calculator to say which (reported once per program)",
                           b.text(word.span), v, angle ? "deg" : (inch ? "in" : "mm"), word.number, v));
      }
    }
    if (resolved && !(std::abs(v) <= kMaxMagnitude)) {
      report(b, word.span, Severity::error, codes::kOutOfRange,
             fmt::format("'{}' is out of range (magnitude above {:g}); check the number", b.text(word.span),
                         kMaxMagnitude));
      ok = false;
      continue;
    }
    if (!resolved && word.kind != ValueKind::string) {
      report(b, word.span, Severity::warning, codes::kExpressionValue,
             fmt::format("value of '{}' is an expression or parameter, which this version recognises but does not "
                         "evaluate; the word's effect is unknown",
                         b.text(word.span)));
    }
    if (word.name_len > 1 || word.index != 0) {
      // Siemens extended addresses: CR= radius, A3/B3/C3 tool vector, others state only.
      const std::string_view nm = b.text(word.name);
      if (!nm.empty() && nm.front() == ',') {
        w.corner_word = wi;
        continue;
      }
      const auto unresolved_bit = [&](unsigned bitv) {
        if (!resolved) w.ext_unresolved = static_cast<std::uint8_t>(w.ext_unresolved | bitv);
      };
      if (iequals(nm, "CR")) {
        w.has_cr = true;
        w.cr = v;
        w.cr_word = wi;
        unresolved_bit(1);
      } else if (iequals(nm, "AR")) {
        w.has_ar = true;
        w.ar = v;
        w.ar_word = wi;
        unresolved_bit(2);
      } else if (iequals(nm, "TURN")) {
        w.has_turn = true;
        w.turn = v;
        w.turn_word = wi;
        unresolved_bit(4);
      } else if (iequals(nm, "CHF") || iequals(nm, "CHR") || iequals(nm, "RND") || iequals(nm, "RNDM")) {
        // RNDM=0 switches modal rounding off: nothing is inserted.
        const bool off = iequals(nm, "RNDM") && resolved && v == 0;
        if (w.siemens_corner_word < 0 && !off) w.siemens_corner_word = wi;
      } else if (d_.id == DialectId::siemens && word.index == 1 && word.name_len == 2 && word.letter >= 'I' &&
                 word.letter <= 'K') {
        // I1= J1= K1=: the intermediate point of CIP.
        const int k = word.letter - 'I';
        w.ip[k] = v;
        w.ip_present = static_cast<std::uint8_t>(w.ip_present | (1u << k));
        if (fn_abs) w.ip_absolute = static_cast<std::uint8_t>(w.ip_absolute | (1u << k));
        if (fn_inc) w.ip_incremental = static_cast<std::uint8_t>(w.ip_incremental | (1u << k));
        if (w.ip_word < 0) w.ip_word = wi;
        unresolved_bit(8);
      }
      if (iequals(nm, "AP") || iequals(nm, "RP")) w.polar = true;
      if (iequals(nm, "AP")) {
        w.has_ap = true;
        w.ap = v;
        w.ap_incremental = fn_inc;
        unresolved_bit(16);
      } else if (iequals(nm, "RP")) {
        w.has_rp = true;
        w.rp = v;
        w.rp_incremental = fn_inc;
        unresolved_bit(32);
      }
      // A3 B3 C3: tool direction vector components under TRAORI.
      if (word.index == 3 && word.name_len == 2 && resolved && word.letter >= 'A' && word.letter <= 'C') {
        w.vector[word.letter - 'A'] = v;
        w.vector_present = static_cast<std::uint8_t>(w.vector_present | (1u << (word.letter - 'A')));
      }
      continue;
    }
    const char L = word.letter;
    if (L == 'G') {
      if (!resolved) {
        ok = false;
        continue;
      }
      const auto code10 = static_cast<long>(std::lround(v * 10));
      const GCodeDef* def = (code10 >= 0 && code10 < 20000 && std::abs(v * 10 - static_cast<double>(code10)) < 1e-6)
                                ? d_.find_g(static_cast<std::uint16_t>(code10))
                                : nullptr;
      if (def == nullptr) {
        const bool system_b_hint = d_.id == DialectId::fanuc && d_.lathe && d_.gcode_system == 'A' && code10 == 910;
        report(b, word.span, Severity::error, codes::kUnknownG,
               fmt::format("'{}' is not a G code of the {} dialect{}; {}", b.text(word.span), d_.name,
                           d_.lathe ? " (lathe)" : "",
                           system_b_hint ? "G91 (incremental) exists in Fanuc lathe G-code system B/C, not in system A "
                                           "(U/W there): pass --gcode-system B if the program is system B"
                                         : "check --dialect (and --lathe)"));
        ok = false;
        continue;
      }
      bool replaced = false;
      if (def->group != GGroup::none && def->group != GGroup::non_modal) {
        for (int k = 0; k < w.ng; ++k) {
          auto& other = w.g[static_cast<std::size_t>(k)];
          if (other.def->group == def->group) {
            const bool g90_a = d_.id == DialectId::fanuc && d_.lathe && d_.gcode_system == 'A' &&
                               (def->code10 == 900 || other.def->code10 == 900);
            // Fanuc's G00–G03 (group 01) and G73–G89 (group 09) share the motion group here: a pair
            // across them stays refused.
            const bool same_fanuc_group =
                (def->meaning == GMeaning::drill_cycle) == (other.def->meaning == GMeaning::drill_cycle);
            if (d_.id == DialectId::fanuc && !g90_a && same_fanuc_group) {
              // Fanuc (G code list, notes): G codes of one group in one block: the last one given
              // is valid. (Lathe system A's G90 is refused instead: there it is the turning cycle,
              // and a system B program's G90 beside G00 is the likelier reading.)
              other = {def, wi};
              if (def->group == GGroup::motion) w.motion = {def, wi};
              replaced = true;
              break;
            }
            report(b, word.span, Severity::error, codes::kModalConflict,
                   fmt::format("'{}' and '{}' belong to the same modal group; keep one of them{}",
                               b.text(b.words[static_cast<std::size_t>(other.word)].span), b.text(word.span),
                               g90_a ? " (in Fanuc lathe G-code system A, G90 is the turning cycle; G90 absolute "
                                       "is system B/C: pass --gcode-system B)"
                                     : ""));
            ok = false;
          }
        }
      }
      if (replaced) continue;
      if (d_.id == DialectId::fanuc && def->meaning == GMeaning::cancel_motion) {
        // G80 after a canned cycle G in the same block (both group 09): G80, the last, is valid.
        for (int k = 0; k < w.ng; ++k)
          if (w.g[static_cast<std::size_t>(k)].def->meaning == GMeaning::drill_cycle) {
            for (int j = k; j + 1 < w.ng; ++j) w.g[static_cast<std::size_t>(j)] = w.g[static_cast<std::size_t>(j + 1)];
            --w.ng;
            if (w.motion.def != nullptr && w.motion.def->meaning == GMeaning::drill_cycle) w.motion = {};
            break;
          }
      }
      if (w.ng >= static_cast<int>(w.g.size())) {
        report(b, word.span, Severity::error, codes::kRepeatedWord,
               fmt::format("more than {} G codes in one block; split the block", w.g.size()));
        ok = false;
        continue;
      }
      w.g[static_cast<std::size_t>(w.ng++)] = {def, wi};
      if (def->group == GGroup::motion) w.motion = {def, wi};
      continue;
    }
    if (L == 'M') {
      if (resolved && w.m_count < static_cast<int>(w.m.size())) {
        w.m[static_cast<std::size_t>(w.m_count)] = v;
        w.m_word[static_cast<std::size_t>(w.m_count++)] = wi;
      }
      continue;
    }
    if (L == '@' || L == '^') {
      const std::uint8_t bitv = L == '@' ? 1 : 2;
      if (w.polar_words & bitv) {
        report(b, word.span, Severity::error, codes::kRepeatedWord, fmt::format("'{}' is given twice in one block; keep one", L));
        ok = false;
        continue;
      }
      (L == '@' ? w.polar_distance : w.polar_angle) = v;
      w.polar_words = static_cast<std::uint8_t>(w.polar_words | bitv | (resolved ? 0 : 4));
      if (w.polar_word < 0) w.polar_word = wi;
      continue;
    }
    int axis = axis_index(L);
    bool incremental = fn_inc;
    if (lathe_incremental && (L == 'U' || L == 'W' || L == 'H')) {
      axis = L == 'U' ? 0 : (L == 'W' ? 2 : 5);
      incremental = true;
    }
    if (axis >= 0) {
      const auto ax = static_cast<std::size_t>(axis);
      const AxisMask bitmask = static_cast<AxisMask>(1u << axis);
      if (w.axis_present & bitmask) {
        report(b, word.span, Severity::error, codes::kRepeatedWord,
               fmt::format("axis {} is given twice in one block; keep one", kAxisLetters[ax]));
        ok = false;
        continue;
      }
      w.axis_present |= bitmask;
      w.axis[static_cast<Eigen::Index>(axis)] = v;
      w.axis_word[ax] = static_cast<std::int8_t>(i < 127 ? i : 127);
      if (incremental) w.axis_incremental |= bitmask;
      if (fn_abs) {
        w.axis_absolute |= bitmask;
        w.axis_direction[ax] = static_cast<std::uint8_t>(direction_of(b.text(word.value)));
      }
      if (!resolved) w.axis_unresolved |= bitmask;
      continue;
    }
    if (L >= 'A' && L <= 'Z') {
      const auto li = static_cast<std::size_t>(L - 'A');
      if (w.letter_present & (1u << li)) {
        // Repeated letters other than G/M are an error on every controller we support.
        report(b, word.span, Severity::error, codes::kRepeatedWord,
               fmt::format("'{}' is given twice in one block; keep one", L));
        ok = false;
        continue;
      }
      w.letter_present |= 1u << li;
      w.letter[li] = v;
      w.letter_word[li] = wi;
      if (!resolved) w.letter_unresolved |= 1u << li;
      if (fn_abs) w.letter_absolute |= 1u << li;
    }
  }
  return ok;
}

void Interpreter::siemens_token(const Block& b, const Token& t, BlockWords& w) {
  const std::string_view name = b.text(t.name);
  if (t.kind == TokenKind::call) {
    if (iequals(name, "TRAORI")) {
      s_.tcp = TcpMode::siemens_traori;
    } else if (iequals(name, "MSG") || iequals(name, "SETAL") || iequals(name, "TRAFOOF")) {
      if (iequals(name, "TRAFOOF")) s_.tcp = TcpMode::off;
    } else if (iequals(name, "CYCLE800")) {
      const bool reset = b.text(t.span).find_first_not_of(" ()", name.size()) == std::string_view::npos;
      s_.tilted_plane = !reset;
      if (!reset) {
        report(b, t.span, Severity::warning, codes::kTiltedPlane,
               "CYCLE800 swivels the work plane, which this version does not resolve; positions after it are in "
               "the swivelled frame and are reported as unknown");
        s_.known = 0;
      }
    } else if (starts_with_i(name, "CYCLE") || starts_with_i(name, "POCKET") || starts_with_i(name, "SLOT") ||
               starts_with_i(name, "HOLES") || starts_with_i(name, "LONGHOLE")) {
      if (mcall_pending_) {
        mcall_active_ = true;
        report(b, t.span, Severity::warning, codes::kVendorCycle,
               fmt::format("MCALL {}: the modal cycle runs at every following position and is not expanded; "
                           "the tool axis position after each call is unknown",
                           name));
      } else {
        report(b, t.span, Severity::warning, codes::kVendorCycle,
               fmt::format("vendor cycle {} is not expanded; its motions are unknown", name));
        s_.known &= static_cast<AxisMask>(~(bit(Axis::x) | bit(Axis::y) | bit(Axis::z)));
      }
    } else {
      report(b, t.span, Severity::warning, codes::kSubprogramCall,
             fmt::format("call {}(…) is not interpreted by this version", name));
    }
    return;
  }
  if (t.kind != TokenKind::keyword) return;
  if (iequals(name, "TRAORI")) {
    s_.tcp = TcpMode::siemens_traori;
  } else if (iequals(name, "TRAFOOF") || iequals(name, "TRAOOF")) {
    if (iequals(name, "TRAOOF"))
      report(b, t.span, Severity::warning, codes::kUnknownKeyword,
             "TRAOOF is not a Sinumerik keyword (TRAFOOF is); treated as TRAFOOF — check the program");
    s_.tcp = TcpMode::off;
  } else if (iequals(name, "CIP") || iequals(name, "CT")) {
    // Group 1 motion keywords (840D sl Fundamentals, list of G functions, group 1): arcs.
    s_.motion = iequals(name, "CIP") ? GMeaning::arc_cip : GMeaning::arc_tangent;
    w.siemens_motion_keyword = true;
    w.motion_keyword_span = t.span;
  } else if (iequals(name, "ASPLINE") || iequals(name, "BSPLINE") || iequals(name, "CSPLINE") || iequals(name, "POLY")) {
    // Motion-group keywords whose paths this version does not compute.
    s_.motion = GMeaning::spline;
    w.siemens_motion_keyword = true;
  } else if (iequals(name, "SUPA")) {
    w.machine_frame = true;
  } else if (iequals(name, "MCALL")) {
    mcall_pending_ = true;
    mcall_active_ = false;
  } else if (iequals(name, "DIAMON") || iequals(name, "DIAM90")) {
    s_.diameter_mode = true;
  } else if (iequals(name, "DIAMOF")) {
    s_.diameter_mode = false;
  } else if (iequals(name, "TRANS") || iequals(name, "ATRANS")) {
    w.axes_consumed = true;
    frame_span_ = t.span;
    frame_keyword_ = iequals(name, "TRANS") ? 1 : 2;
  } else if (iequals(name, "ROT") || iequals(name, "AROT") || iequals(name, "SCALE") || iequals(name, "ASCALE") ||
             iequals(name, "MIRROR") || iequals(name, "AMIRROR") || iequals(name, "RPL")) {
    w.axes_consumed = true;
    frame_span_ = t.span;
    frame_keyword_ = 3;
  } else {
    if (iequals(name, "ORIMKS")) s_.ori_mks = true;
    if (iequals(name, "ORIWKS")) s_.ori_mks = false;
    if (siemens_state_keyword(name)) return;
    report(b, t.span, Severity::warning, codes::kSubprogramCall,
           fmt::format("'{}' is not a keyword this version knows; on a Sinumerik it would call the subprogram "
                       "{} — not followed",
                       name, name));
  }
}

void Interpreter::apply_tokens(const Block& b, BlockWords& w) {
  mcall_pending_ = false;
  frame_keyword_ = 0;
  for (const Token& t : b.tokens) {
    switch (t.kind) {
      case TokenKind::assignment:
        report(b, t.span, Severity::warning, codes::kAssignment,
               fmt::format("assignment '{}' is recognised but not evaluated by this version", b.text(t.name)));
        break;
      case TokenKind::control_flow:
        report(b, t.span, Severity::warning, codes::kControlFlow,
               fmt::format("control flow '{}' is recognised but not followed by this version; motions in and after "
                           "it are read as if it were absent",
                           b.text(t.name)));
        break;
      case TokenKind::declaration:
        report(b, t.span, Severity::warning, codes::kAssignment,
               fmt::format("declaration '{}' is recognised but not evaluated by this version", b.text(t.name)));
        break;
      case TokenKind::keyword:
      case TokenKind::call:
        if (d_.id == DialectId::siemens) siemens_token(b, t, w);
        break;
      default:
        break;
    }
  }
}

void Interpreter::apply_modes(const Block& b, BlockWords& w) {
  // Order follows RS274/NGC: feed mode, feed, units, plane, distance modes, offsets, tool length.
  const FeedMode feed_mode_before = s_.feed_mode;
  for (int k = 0; k < w.ng; ++k) {
    const auto& g = w.g[static_cast<std::size_t>(k)];
    switch (g.def->meaning) {
      case GMeaning::feed_inverse_time: s_.feed_mode = FeedMode::inverse_time; break;
      case GMeaning::feed_per_minute: s_.feed_mode = FeedMode::per_minute; break;
      case GMeaning::feed_per_rev: s_.feed_mode = FeedMode::per_rev; break;
      case GMeaning::inch:
      case GMeaning::mm:
        s_.inch = g.def->meaning == GMeaning::inch;
        // Sinumerik: G70/G71 change lengths only, F stays in the basic system; G700/G710 change F too
        // (840D sl Fundamentals, "Inch or metric dimensions: G70/G700, G71/G710").
        s_.feed_inch = d_.id != DialectId::siemens      ? s_.inch
                       : g.def->code10 == 7000          ? true
                       : g.def->code10 == 7100          ? false
                                                        : d_.basic_inch;
        break;
      default: break;
    }
  }
  if (s_.feed_mode != feed_mode_before && (feed_mode_before == FeedMode::inverse_time ||
                                           s_.feed_mode == FeedMode::inverse_time)) {
    // Leaving or entering inverse time leaves no feed rate (LinuxCNC and Fanuc: the rate is 0 until
    // an F is programmed; a feed move before it is refused by the controller).
    s_.feed = 0;
    s_.feed_known = false;
    s_.feed_undefined = true;
  }
  // Sinumerik G4 F… is a dwell time in seconds, not a feed: the programmed feed stays (Fundamentals,
  // "Dwell time (G4)").
  const bool f_is_dwell = d_.id == DialectId::siemens && w.has_meaning(GMeaning::dwell);
  if (w.has('F') && !f_is_dwell) s_.feed_undefined = false;
  if (f_is_dwell) {
  } else if (w.has('F') && !w.unresolved('F')) {
    const double f = w.get('F');
    s_.feed = s_.feed_mode == FeedMode::inverse_time ? f : (s_.feed_inch ? f * 25.4 : f);
    s_.feed_known = true;
  } else if (w.has('F')) {
    s_.feed_known = false;
  }
  for (int k = 0; k < w.ng; ++k) {
    const auto& g = w.g[static_cast<std::size_t>(k)];
    const Word& word = b.words[static_cast<std::size_t>(g.word)];
    switch (g.def->meaning) {
      case GMeaning::plane_xy: s_.plane = Plane::xy; break;
      case GMeaning::plane_zx: s_.plane = Plane::zx; break;
      case GMeaning::plane_yz: s_.plane = Plane::yz; break;
      case GMeaning::absolute: s_.absolute = true; break;
      case GMeaning::incremental: s_.absolute = false; break;
      case GMeaning::arc_absolute: s_.arc_absolute = true; break;
      case GMeaning::arc_incremental: s_.arc_absolute = false; break;
      case GMeaning::diameter_mode: s_.diameter_mode = true; break;
      case GMeaning::radius_mode: s_.diameter_mode = false; break;
      case GMeaning::return_initial: s_.return_to_r = false; break;
      case GMeaning::return_r: s_.return_to_r = true; break;
      case GMeaning::work_offset: {
        WorkOffset wo{g.def->code10, 0};
        if (g.def->code10 == 541) {
          const long pn = w.whole_or('P', 1, 9999, -1);
          if (pn < 0) {
            report(b, word.span, Severity::error, codes::kMissingWord,
                   "G54.1 needs a literal whole P word from 1 to 9999 naming the additional work offset (e.g. G54.1 P1)");
          } else {
            wo.p = static_cast<std::uint16_t>(pn);
          }
        }
        if (wo.code10 != s_.work_offset.code10 || wo.p != s_.work_offset.p) s_.known = 0;  // offsets are tables
        s_.work_offset = wo;
        break;
      }
      case GMeaning::tilted_plane_on:
        s_.tilted_plane = true;
        w.axes_consumed = true;  // X Y Z I J K of G68.2 define the plane, they do not move
        s_.known = 0;
        report(b, word.span, Severity::warning, codes::kTiltedPlane,
               "tilted work plane: coordinates that follow are in the tilted frame, which this version does not "
               "resolve into the work frame; they are reported as unknown");
        break;
      case GMeaning::tilted_plane_off:
        if (s_.tilted_plane) s_.known = 0;
        s_.tilted_plane = false;
        break;
      case GMeaning::rotation_on:
        w.axes_consumed = true;
        s_.known = 0;
        report(b, word.span, Severity::warning, codes::kTiltedPlane,
               "coordinate rotation (G68) is not resolved by this version; positions after it are unknown");
        break;
      case GMeaning::tilted_plane_heidenhain:
        w.axes_consumed = true;
        s_.tilted_plane = true;
        break;
      case GMeaning::polar_interp_on: s_.polar_interp = true; break;
      case GMeaning::polar_interp_off:
        s_.polar_interp = false;
        s_.known = 0;
        break;
      default: break;
    }
  }
  constexpr std::uint32_t kTH = (1u << ('T' - 'A')) | (1u << ('H' - 'A'));
  if (d_.id == DialectId::fanuc && (w.m_count != 0 || (w.letter_present & kTH) != 0)) {
    // Fanuc: T, H and M take whole numbers; a literal with a decimal point is alarm PS0007 "illegal
    // use of decimal point" (M3.0, T1.5). A G65/G66 macro call's H is an argument (decimals allowed).
    // (A variable's value there is rounded by the resolver: fanuc.cpp, whole_address.)
    bool call = false;
    for (int k = 0; k < w.ng; ++k) {
      const std::uint16_t c = w.g[static_cast<std::size_t>(k)].def->code10;
      call = call || c == 650 || c == 660 || c == 661;
    }
    for (const Word& word : b.words) {
      const char L = static_cast<char>(std::toupper(static_cast<unsigned char>(word.letter)));
      if (word.name_len != 1 || word.kind != ValueKind::number || word.whole || (L != 'T' && L != 'H' && L != 'M') ||
          (call && L == 'H'))
        continue;
      report(b, word.span, Severity::error, codes::kControllerRefuses,
             fmt::format("'{}': a decimal point in {} is alarm PS0007 on a Fanuc control (illegal use of decimal "
                         "point); write the whole number without one",
                         b.text(word.span), L));
      break;
    }
  }
  if (d_.id == DialectId::linuxcnc) {
    if (const int bad = lcnc_whole_words(w); bad >= 0) {
      const Span at = b.words[static_cast<std::size_t>(bad)].span;
      report(b, at, Severity::error, codes::kControllerRefuses,
             fmt::format("'{}' is not a whole number: LinuxCNC stops the program here (rs274: \"Non integer value for "
                         "integer\"); T, H and M take whole numbers",
                         b.text(at)));
    }
    if (const auto [L, why] = unused_lcnc_word(b, w, s_.motion_code10); L != 0) {
      report(b, b.words[static_cast<std::size_t>(w.letter_word[static_cast<std::size_t>(L - 'A')])].span, Severity::error,
             codes::kControllerRefuses,
             fmt::format("LinuxCNC stops the program here (rs274: \"{}\"); remove the word or add the code that uses it",
                         why));
      w.letter_present &= ~(1u << (L - 'A'));
    }
  }
  tool_offsets(b, w);
  if (w.m_count != 0) modal_save_restore(b, w);
  if (d_.id == DialectId::heidenhain_iso) {
    // Heidenhain ISO: I J K set the modal circle centre / pole (absolute, or from the current point
    // in G91); the tool does not move to it.
    for (int a = 0; a < 3; ++a) {
      const char L = static_cast<char>('I' + a);
      if (!w.has(L)) continue;
      if (w.unresolved(L)) {
        s_.circle_centre_known = static_cast<std::uint8_t>(s_.circle_centre_known & ~(1u << a));
        continue;
      }
      const double v = to_mm(a, w.get(L));
      const bool from_current = !s_.absolute;
      if (from_current && !((s_.known >> a) & 1u)) {
        s_.circle_centre_known = static_cast<std::uint8_t>(s_.circle_centre_known & ~(1u << a));
        continue;
      }
      s_.circle_centre[a] = from_current ? s_.position[a] + v : v;
      s_.circle_centre_known = static_cast<std::uint8_t>(s_.circle_centre_known | (1u << a));
    }
  }
  if (d_.id == DialectId::siemens && w.has('L')) {
    report(b, b.words[static_cast<std::size_t>(w.letter_word['L' - 'A'])].span, Severity::warning,
           codes::kSubprogramCall, "subprogram call (L word) is not followed by this version");
  }
  for (int i = 0; i < w.m_count; ++i) {
    const double m = w.m[static_cast<std::size_t>(i)];
    const Span at = b.words[static_cast<std::size_t>(w.m_word[static_cast<std::size_t>(i)])].span;
    // The spindle (M3 / M4 start it, M5 and the program ends stop it) acts before the block's
    // motion (LinuxCNC order of execution; Fanuc and Sinumerik start it with the motion).
    if (m == 3 || m == 4) s_.spindle_turning = true;
    if (m == 5 || m == 2 || m == 30) s_.spindle_turning = false;
    if (d_.id == DialectId::heidenhain_iso && m == 128) s_.tcp = TcpMode::heidenhain_m128;
    if (d_.id == DialectId::heidenhain_iso && m == 129) s_.tcp = TcpMode::off;
    if ((m == 98 || m == 99) && d_.id != DialectId::siemens) {
      report(b, at, Severity::warning, codes::kSubprogramCall,
             m == 98 ? "M98 subprogram call is not followed by this version; positions after it are unknown until "
                       "programmed"
                     : "M99 (return or loop to start) is not followed by this version; positions after it are "
                       "unknown until programmed");
      s_.known = 0;  // the call's moves (or the jump) are not followed: where the axes are is not known
    }
  }
}

}  // namespace postproc::gcode
