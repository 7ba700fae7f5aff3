#pragma once
// Runs convert() from memory for the option tests; commits only without errors, as the CLI does.
#include <string>
#include <vector>

#include "postproc/gcode/convert.hpp"
#include "support.hpp"

namespace pptest {

struct Converted {
  std::string out;
  gc::ConvertResult result;
  gc::DiagnosticSink sink;
  bool committed = false;
  std::vector<gc::Diagnostic> errors;
  std::vector<std::string> leftover;  ///< files in the output folder afterwards (no temporaries expected)
  [[nodiscard]] bool refused_with(std::string_view code) const {
    if (committed || errors.empty()) return false;
    for (const auto& e : errors)
      if (e.code != code) return false;
    return true;
  }
  [[nodiscard]] bool error_on_line(std::uint64_t line) const {
    for (const auto& e : errors)
      if (e.where.line == line) return true;
    return false;
  }
};

inline void run_convert(const gc::Dialect& d, const std::string& input, const gc::ConvertOptions& opt, Converted& c) {
  TempDir dir;
  const std::string path = dir.file("out.nc");
  {
    gc::LineReader reader{std::string_view(input)};
    postproc::io::OutputFile out(path);
    c.result = gc::convert(reader, "in.nc", d, opt, out, c.sink);
    if (!c.sink.has_errors()) {
      out.commit();
      c.committed = true;
    }
  }
  c.out = fs::exists(path) ? read_file(path) : std::string();
  c.leftover = dir.entries();
  for (const auto& e : c.sink.stored())
    if (e.severity == gc::Severity::error) c.errors.push_back(e);
}

inline void run_convert(const std::string& name, const std::string& input, const gc::ConvertOptions& opt,
                        Converted& c, bool lathe = false) {
  run_convert(dialect(name, lathe), input, opt, c);
}

/// Fanuc with a stated integer input (how "X100" without a point is read).
inline gc::Dialect fanuc_input(gc::Dialect::IntegerInput in) {
  gc::DialectOptions o;
  o.integer_input = in;
  return gc::make_dialect(gc::DialectId::fanuc, o);
}

inline gc::ConvertOptions units_option(gc::Units u) {
  gc::ConvertOptions o;
  o.units = u;
  return o;
}

inline gc::ConvertOptions linearize_option(double tol) {
  gc::ConvertOptions o;
  o.linearize_tolerance_mm = tol;
  return o;
}

}  // namespace pptest
