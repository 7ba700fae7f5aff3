// postproc diff ORIGINAL CORRECTED: per-block axis deltas and (with a machine file) tool-tip
// distances between the two programs, a summary and the largest changes with their lines.
#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "postproc/compensation/diff.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::cli {
namespace {

constexpr double kArcsec = 180.0 / 3.14159265358979323846 * 3600.0;

struct DiffArgs {
  std::string original, corrected, machine, csv, json;
  DialectArgs dialect;
  double fail_above_um = -1;
  std::size_t worst = 10;
  std::size_t max_per_code = 20;
};

std::string csv_of(const comp::DiffResult& r, bool machine) {
  std::string s = "original_line,corrected_line";
  for (char L : gcode::kAxisLetters) s += fmt::format(",d{}_{}", L, gcode::is_rotary(gcode::axis_index(L)) ? "deg" : "mm");
  s += machine ? ",tip_um,axis_arcsec\n" : ",linear_um\n";
  for (const comp::BlockDiff& b : r.blocks) {
    s += fmt::format("{},{}", b.line_original, b.line_corrected);
    for (int k = 0; k < gcode::kAxisCount; ++k)
      s += ((b.axes >> k) & 1u) ? fmt::format(",{:.9g}", b.delta[k]) : std::string(",");
    if (machine)
      s += std::isnan(b.tip_mm) ? std::string(",,\n") : fmt::format(",{:.6g},{:.6g}\n", b.tip_mm * 1000, b.axis_rad * kArcsec);
    else
      s += fmt::format(",{:.6g}\n", b.linear_mm * 1000);
  }
  return s;
}

/// Indices of the `n` largest deviations, largest first (ties: earlier block first).
std::vector<std::size_t> worst_of(const comp::DiffResult& r, std::size_t n) {
  std::vector<std::size_t> idx(r.blocks.size());
  std::iota(idx.begin(), idx.end(), 0);
  n = std::min(n, idx.size());
  std::partial_sort(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(n), idx.end(), [&](std::size_t x, std::size_t y) {
    return r.blocks[x].deviation_mm > r.blocks[y].deviation_mm ||
           (r.blocks[x].deviation_mm == r.blocks[y].deviation_mm && x < y);
  });
  idx.resize(n);
  return idx;
}

}  // namespace

void setup_diff(CLI::App& app, int& rc) {
  auto o = std::make_shared<DiffArgs>();
  auto* cmd = app.add_subcommand("diff", "compare a program with its corrected version block by block (axis deltas; "
                                         "with a machine file, tool-tip distances)");
  cmd->add_option("original", o->original, "the original program")->required();
  cmd->add_option("corrected", o->corrected, "the corrected program")->required();
  cmd->add_option("-m,--machine", o->machine, "machine file: tool-tip distance and tool-axis angle in the workpiece frame");
  cmd->add_option("--csv", o->csv, "write the per-block deltas here (CSV)");
  cmd->add_option("--json", o->json, "write the summary and the largest changes here (JSON)");
  cmd->add_option("--fail-above", o->fail_above_um,
                  "exit with code 1 when any deviation (tool tip with -m, else linear axes) exceeds this, µm");
  cmd->add_option("--worst", o->worst, "how many of the largest changes to list")->capture_default_str();
  cmd->add_option("--max-per-code", o->max_per_code, "show at most this many diagnostics per code")->capture_default_str();
  add_dialect_options(*cmd, o->dialect, false);
  cmd->callback([o, &rc] {
    gcode::DiagnosticSink sink;
    DiagnosticPrinter printer(sink, o->max_per_code);
    std::optional<machine::Machine> m;
    if (!o->machine.empty()) m = load_or_refuse(o->machine, o->max_per_code);
    if (!m && o->dialect.dialect.empty())
      throw Error(ExitCode::usage, "diff needs the dialect: give -m MACHINE.toml or --dialect");
    const gcode::Dialect d = m && o->dialect.dialect.empty() ? *gcode::make_dialect(m->dialect_name, m->dialect_options)
                                                              : make_dialect(o->dialect);
    const std::string a = io::read_file(o->original, "NC program");
    const std::string b = io::read_file(o->corrected, "NC program");
    const comp::DiffResult r = comp::diff(a, b, o->original, o->corrected, d, m ? &*m : nullptr, sink);
    printer.finish();
    if (sink.has_errors()) {
      std::fputs("postproc: diff: the programs have errors (see above); nothing compared\n", stderr);
      rc = static_cast<int>(ExitCode::refused);
      return;
    }
    const bool with_machine = m.has_value();
    const auto worst = worst_of(r, o->worst);
    if (!o->csv.empty()) {
      write_text(o->csv, o->original, csv_of(r, with_machine));
    }
    const char* what = with_machine ? "tool-tip distance" : "linear-axis change";
    if (!o->json.empty()) {
      nlohmann::json j;
      j["tool"] = {{"name", "postproc"}, {"version", POSTPROC_VERSION}};
      j["original"] = o->original;
      j["corrected"] = o->corrected;
      if (with_machine) j["machine"] = {{"file", m->file}, {"sha256", m->sha256}};
      j["aligned"] = r.by_block ? "by block" : "by path";
      j["motions"] = {{"original", r.motions_original}, {"corrected", r.motions_corrected}};
      j["pairs"] = r.blocks.size();
      j["changed"] = r.changed;
      j["unmatched"] = r.unmatched;
      j["deviation"] = {{"measure", what},
                        {"max_um", r.deviation.max * 1000},
                        {"rms_um", r.deviation.rms * 1000},
                        {"p95_um", r.deviation.p95 * 1000}};
      if (with_machine)
        j["axis_angle"] = {{"max_arcsec", r.angle.max * kArcsec},
                           {"rms_arcsec", r.angle.rms * kArcsec},
                           {"p95_arcsec", r.angle.p95 * kArcsec}};
      nlohmann::json w = nlohmann::json::array();
      for (std::size_t k : worst) {
        const comp::BlockDiff& bd = r.blocks[k];
        w.push_back({{"original_line", bd.line_original},
                     {"corrected_line", bd.line_corrected},
                     {"deviation_um", bd.deviation_mm * 1000},
                     {"rotary_deg", bd.rotary_deg}});
      }
      j["largest"] = w;
      if (o->fail_above_um >= 0) j["fail_above_um"] = o->fail_above_um;
      write_text(o->json, o->original, j.dump(2) + "\n");
    }
    std::string s = fmt::format(
        "postproc: diff {} → {}: {} / {} motions, aligned {}, {} pairs ({} changed, {} unmatched)\n"
        "  {}: max {:.3f} µm, RMS {:.3f} µm, p95 {:.3f} µm\n",
        o->original, o->corrected, r.motions_original, r.motions_corrected, r.by_block ? "by block" : "by path",
        r.blocks.size(), r.changed, r.unmatched, what, r.deviation.max * 1000, r.deviation.rms * 1000,
        r.deviation.p95 * 1000);
    if (with_machine)
      s += fmt::format("  tool-axis angle: max {:.2f} arcsec, RMS {:.2f} arcsec\n", r.angle.max * kArcsec,
                       r.angle.rms * kArcsec);
    for (std::size_t k : worst) {
      const comp::BlockDiff& bd = r.blocks[k];
      if (bd.deviation_mm <= 0 && bd.rotary_deg <= 0) break;
      s += fmt::format("  line {} → {}: {:.3f} µm, rotary {:.5f} deg\n", bd.line_original, bd.line_corrected,
                       bd.deviation_mm * 1000, bd.rotary_deg);
    }
    std::fputs(s.c_str(), stderr);
    rc = 0;
    if (o->fail_above_um >= 0 && r.deviation.max * 1000 > o->fail_above_um) {
      std::fputs(fmt::format("postproc: diff: {} {:.3f} µm exceeds --fail-above {} µm\n", what, r.deviation.max * 1000,
                             o->fail_above_um)
                     .c_str(),
                 stderr);
      rc = 1;
    }
  });
}

}  // namespace postproc::cli
