// libFuzzer target: measurement files (CSV) and step-gauge files over arbitrary bytes, read for a
// serial 5-axis trunnion, the 3-PRS hybrid head and the hexapod (the sample machine files, read
// once from POSTPROC_SAMPLES_DIR).
//
// Besides "no crash, no sanitizer report, no exception escaping", it checks that every accepted
// measurement holds only finite numbers and that a refused file reported an error.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "postproc/calibration/csv.hpp"
#include "postproc/calibration/measurement.hpp"
#include "postproc/calibration/step_gauge.hpp"
#include "postproc/error.hpp"
#include "postproc/machine/machine.hpp"

namespace {

namespace gc = postproc::gcode;

[[gnu::always_inline]] inline void check(bool ok) {
  if (!ok) __builtin_trap();
}

std::vector<postproc::machine::Machine> load_machines() {
  std::vector<postproc::machine::Machine> out;
  for (const char* name : {"trunnion_bc_fanuc_nominal.toml", "hybrid_3prs_doc001_nominal.toml", "hexapod_doc003_nominal.toml"}) {
    gc::DiagnosticSink sink;
    auto m = postproc::machine::load_machine(std::string(POSTPROC_SAMPLES_DIR) + "/machines/" + name, sink);
    check(m.has_value());  // the harness itself is broken without its machines
    out.push_back(std::move(*m));
  }
  return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > (1u << 20)) return 0;
  static const std::vector<postproc::machine::Machine> machines = load_machines();
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    for (const auto& m : machines) {
      gc::DiagnosticSink sink;
      auto table = postproc::cal::CsvTable::parse("fuzz.csv", text, sink);
      if (!table) {
        check(sink.has_errors());
        continue;
      }
      std::vector<postproc::cal::Measurement> out;
      const bool ok = postproc::cal::read_measurements(*table, *m.nominal, out);
      if (!ok) check(sink.has_errors());
      for (const auto& mm : out) {
        check(mm.q.allFinite());
        check(mm.measured.p.allFinite() && mm.measured.r.allFinite());
      }
      for (const auto& d : sink.stored()) (void)gc::format(d);
    }
    gc::DiagnosticSink sink;
    postproc::cal::StepGaugeData gauge;
    if (!postproc::cal::add_step_gauge_text("fuzz.csv", text, gauge, sink)) check(sink.has_errors());
  } catch (const postproc::Error&) {
    return 0;
  }
  return 0;
}
