// libFuzzer target: machine files (TOML) through the whole reader, over arbitrary bytes.
//
// Besides "no crash, no sanitizer report, no exception escaping", it checks that a file is either
// refused with at least one located error, or accepted as a machine whose models exist and whose
// every parameter value is finite (issue 21: values no machine could have are refused where read).

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "postproc/error.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/machine/machine.hpp"

namespace {

[[gnu::always_inline]] inline void check(bool ok) {
  if (!ok) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > (1u << 20)) return 0;  // machine files are small; keep each run fast
  namespace gc = postproc::gcode;
  gc::DiagnosticSink sink;
  std::optional<postproc::machine::Machine> m;
  try {
    m = postproc::machine::parse_machine("fuzz.toml", std::string(reinterpret_cast<const char*>(data), size), sink);
  } catch (const postproc::Error&) {
    return 0;  // a located refusal by exception (exit 2/64/66) is an answer
  }
  for (const auto& d : sink.stored()) {
    check(d.where.line >= 1 || d.file.empty() || !d.message.empty());
    (void)gc::format(d);
  }
  if (!m) {
    check(sink.has_errors());
    return 0;
  }
  check(!sink.has_errors());
  check(m->nominal != nullptr && m->actual != nullptr);
  for (double v : m->actual->values()) check(std::isfinite(v));
  check(std::isfinite(m->tool_length) && std::isfinite(m->interpolation_period) && m->interpolation_period > 0);
  return 0;
}
