#include "postproc/gcode/detect.hpp"

#include <array>

#include "src/gcode/text.hpp"

namespace postproc::gcode {
namespace {
using text::upper;

struct Marker {
  std::string_view text;  // matched case-insensitively
  DialectId id;
  bool at_line_start;
};

// Constructs that only one dialect writes. Order matters: the first match wins.
constexpr std::array<Marker, 22> kMarkers = {{
    {"TRAORI", DialectId::siemens, false},     {"TRAFOOF", DialectId::siemens, false},
    {"CYCLE8", DialectId::siemens, false},     {"%_N_", DialectId::siemens, true},
    {"DEF REAL", DialectId::siemens, true},    {"MSG(", DialectId::siemens, false},
    {";$PATH", DialectId::siemens, true},      {"G642", DialectId::siemens, false},
    {"#<", DialectId::linuxcnc, false},        {" SUB", DialectId::linuxcnc, false},
    {"ENDSUB", DialectId::linuxcnc, false},    {"M428", DialectId::linuxcnc, false},
    {"G64 P", DialectId::linuxcnc, false},     {"ENDWHILE", DialectId::linuxcnc, false},
    {"G43.4", DialectId::fanuc, false},        {"G05.1", DialectId::fanuc, false},
    {"G54.1", DialectId::fanuc, false},        {"WHILE [", DialectId::fanuc, false},
    {"GOTO", DialectId::fanuc, false},         {"M128", DialectId::heidenhain_iso, false},
    {"BEGIN PGM", DialectId::heidenhain_iso, true}, {"G65 P", DialectId::fanuc, false},
}};


bool match_at(std::string_view line, std::size_t pos, std::string_view pat) {
  if (pos + pat.size() > line.size() || upper(line[pos]) != pat[0]) return false;
  for (std::size_t i = 1; i < pat.size(); ++i)
    if (upper(line[pos + i]) != pat[i]) return false;
  return true;
}

}  // namespace

std::optional<DialectGuess> guess_dialect(std::string_view text, std::size_t max_lines) {
  std::size_t start = 0;
  for (std::size_t ln = 1; ln <= max_lines && start < text.size(); ++ln) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(start, end - start);
    for (const Marker& m : kMarkers) {
      // Markers inside ( ) comments say nothing about the dialect: "(ROUGH SUB-PROGRAM)".
      const std::size_t last = m.at_line_start ? 0 : line.size();
      int depth = 0;
      for (std::size_t p = 0; p <= last && p < line.size(); ++p) {
        if (line[p] == '(' && !m.at_line_start) ++depth;
        if (depth == 0 && match_at(line, p, m.text))
          return DialectGuess{m.id, std::string(m.text), ln, static_cast<std::uint32_t>(p + 1)};
        if (line[p] == ')' && depth > 0) --depth;
      }
    }
    start = end + 1;
  }
  return std::nullopt;
}

}  // namespace postproc::gcode
