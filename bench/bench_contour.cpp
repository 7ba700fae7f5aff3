// Contour precompensation rate (issue 6): a 5-axis program of N blocks (default 200,000) on the
// A/C trunnion sample machine (Kv 30/s, lag mode, F2000), in memory, one core. Prints the time of
// each stage (path, reference contour, prediction, precompensation, the whole
// compensate --mode contour with parsing and writing) as blocks/s, and, in the same process, the
// geometric compensation of the same program as the baseline ratio. Median of 3 runs.
// Usage: postproc_bench_contour [BLOCKS]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "postproc/compensation/compensate.hpp"
#include "postproc/contour/path.hpp"
#include "postproc/contour/precompensate.hpp"
#include "postproc/contour/reference.hpp"
#include "postproc/machine/machine.hpp"

namespace {

using namespace postproc;

/// A smooth 5-axis axis program: X Y on a wavy circle, Z and A oscillating, C turning.
std::string program(std::size_t blocks) {
  std::string s = "%\nO7000 (CONTOUR BENCH)\nG21 G90 G94 G17 G54\nG0 G43 H1 Z150.\nG0 X60. Y0. Z-20. A15. C0.\n";
  s += "G9 G1 X60. Y0. Z-20. A15. C0. F500.\n";
  for (std::size_t i = 1; i <= blocks; ++i) {
    const double p = 2 * 3.14159265358979323846 * static_cast<double>(i) / 1600.0;
    s += fmt::format("X{:.4f} Y{:.4f} Z{:.4f} A{:.4f} C{:.4f}{}\n", 60 * std::cos(p) + 5 * std::sin(7 * p),
                     60 * std::sin(p), -20 + 2 * std::sin(3 * p), 15 + 5 * std::sin(2 * p),
                     static_cast<double>(i) * 360.0 / 1600.0, i == 1 ? " F2000." : "");
  }
  s += "G0 Z150.\nM30\n%\n";
  return s;
}

double median_seconds(const std::function<void()>& f) {
  std::vector<double> t;
  for (int k = 0; k < 3; ++k) {
    const auto a = std::chrono::steady_clock::now();
    f();
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count());
  }
  std::sort(t.begin(), t.end());
  return t[1];
}

}  // namespace

int main(int argc, char** argv) {
  const std::size_t blocks = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 200000;
  gcode::DiagnosticSink sink;
  const auto m = machine::load_machine(std::string(POSTPROC_SOURCE_DIR) + "/samples/machines/trunnion_ac_fanuc.toml", sink);
  if (!m) return 1;
  const gcode::Dialect d = *gcode::make_dialect(m->dialect_name, m->dialect_options);
  const std::string text = program(blocks);

  contour::Path path;
  const double t_path = median_seconds([&] {
    gcode::LineReader in{std::string_view(text)};
    path = contour::build_path(in, "bench.nc", d, *m, contour::PathOptions{}, sink);
  });
  if (sink.has_errors()) return 1;
  std::optional<contour::Reference> ref;
  const double t_ref = median_seconds([&] { ref.emplace(path, *m->actual); });
  contour::Prediction p;
  const double t_pred = median_seconds([&] { p = contour::predict(path, *m->actual, *ref); });
  contour::Precompensation pc;
  const double t_pre = median_seconds([&] { pc = contour::precompensate(path, *m->actual, *ref); });
  comp::CompensateResult r;
  const double t_all = median_seconds([&] {
    comp::CompensateOptions opt;
    opt.mode = postproc::comp::Mode::contour;
    auto out = io::OutputFile::memory();
    r = comp::compensate_contour({text, "bench.nc", d, *m}, opt, out, sink);
  });
  const double t_geo = median_seconds([&] {
    comp::CompensateOptions opt;
    auto out = io::OutputFile::memory();
    gcode::LineReader in{std::string_view(text)};
    (void)comp::compensate(in, "bench.nc", d, *m, opt, out, sink);
  });
  const auto rate = [&](double s) { return static_cast<double>(blocks) / s; };
  std::printf("contour precompensation, %zu blocks, trunnion A/C (5 joints), median of 3 runs, one core\n", blocks);
  std::printf("  path (parse, controller map, feed profile)  %8.3f s  %10.0f blocks/s\n", t_path, rate(t_path));
  std::printf("  reference contour (NURBS fits)              %8.3f s  %10.0f blocks/s\n", t_ref, rate(t_ref));
  std::printf("  one prediction                              %8.3f s  %10.0f blocks/s\n", t_pred, rate(t_pred));
  std::printf("  precompensation (%d iterations)              %8.3f s  %10.0f blocks/s\n", pc.iterations, t_pre, rate(t_pre));
  std::printf("  compensate --mode contour (all of it)       %8.3f s  %10.0f blocks/s   (target 200000)\n", t_all, rate(t_all));
  std::printf("  compensate --mode geometric (baseline)      %8.3f s  %10.0f blocks/s   contour/geometric time ratio %.2f\n",
              t_geo, rate(t_geo), t_all / t_geo);
  std::printf("  predicted contour error %.3f -> %.3f um (tool tip), %.2f -> %.2f arcsec (tool axis)\n",
              r.contour_before_mm * 1000, r.contour_after_mm * 1000, r.contour_before_rad * 206264.806,
              r.contour_after_rad * 206264.806);
  return 0;
}
