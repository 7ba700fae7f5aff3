// LinuxCNC tool table files: T, Z and D words per line (LinuxCNC "Tool Table Format").
#include "postproc/gcode/tool_table.hpp"

#include <cmath>
#include <fstream>

#include <fmt/format.h>

#include "postproc/io/input_file.hpp"

#include "src/gcode/number_text.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode {

bool read_linuxcnc_tool_table(const std::string& path, DialectOptions& opt, DiagnosticSink& sink) {
  io::accept_input(path, "tool table");
  std::ifstream in(path, std::ios::binary);
  auto fail = [&](std::uint64_t line, std::uint32_t col, std::uint32_t len, const std::string& text, std::string msg) {
    Diagnostic d;
    d.code = "PP-E208";
    d.file = path;
    d.where = {line, col};
    d.message = std::move(msg);
    d.source_line = text;
    d.length = std::max<std::uint32_t>(len, 1);
    sink.report(std::move(d));
    return false;
  };
  if (!in) return fail(0, 0, 1, "", "cannot open the tool table file; check the path");
  std::string text;
  std::uint64_t line_no = 0;
  bool ok = true;
  while (std::getline(in, text)) {
    ++line_no;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    const std::string_view s(text.data(), std::min(text.find(';'), text.size()));
    long tool = -1;
    double length = 0, diameter = 0, orientation = 0;
    bool has_length = false, has_diameter = false, has_orientation = false;
    std::size_t i = 0;
    while (i < s.size()) {
      if (text::is_space(s[i])) {
        ++i;
        continue;
      }
      const char L = text::upper(s[i]);
      std::size_t e = i + 1;
      while (e < s.size() && !text::is_space(s[e])) ++e;
      double v = 0;
      if (L < 'A' || L > 'Z' || !parse_number(s.substr(i + 1, e - i - 1), v) || !std::isfinite(v) || std::abs(v) > 1e6) {
        ok = fail(line_no, static_cast<std::uint32_t>(i + 1), static_cast<std::uint32_t>(e - i), text,
                  fmt::format("'{}' is not a tool table word (T, P, X…W, D, I, J, Q with a number); correct the line",
                              s.substr(i, e - i)));
        break;
      }
      if (L == 'T') tool = (v >= 0 && v == std::floor(v) && v < 1e6) ? static_cast<long>(v) : -2;
      if (L == 'Z') length = v, has_length = true;
      if (L == 'D') diameter = v, has_diameter = true;
      if (L == 'Q') orientation = v, has_orientation = true;
      i = e;
    }
    if (!ok) break;
    if (tool == -1 && s.find_first_not_of(" \t") == std::string_view::npos) continue;  // blank or comment line
    if (tool < 0) {
      ok = fail(line_no, 1, static_cast<std::uint32_t>(s.size()), text,
                "a tool table line without a whole T number; write e.g. T3 P3 Z25.4 D6");
      break;
    }
    if (has_length) opt.tool_lengths[static_cast<std::uint32_t>(tool)] = length;
    if (has_diameter) opt.tool_radii[static_cast<std::uint32_t>(tool)] = diameter / 2;
    if (has_orientation) {
      // LinuxCNC "Tool Table Format": Q is the lathe tool orientation, a whole number 0–9.
      if (!(orientation >= 0 && orientation <= 9 && orientation == std::floor(orientation))) {
        ok = fail(line_no, 1, static_cast<std::uint32_t>(s.size()), text,
                  "Q (tool orientation) is a whole number from 0 to 9; correct the line");
        break;
      }
      opt.tool_orientations[static_cast<std::uint32_t>(tool)] = static_cast<int>(orientation);
    }
  }
  return ok;
}

}  // namespace postproc::gcode
