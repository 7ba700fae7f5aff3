// postproc batch JOBDIR -m MACHINE -o OUTDIR: compensate a job folder tree in parallel into a
// mirrored tree with a manifest; postproc batch merge: join shard manifests.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "postproc/batch/batch.hpp"
#include "postproc/io/input_file.hpp"
#include "progress_bar.hpp"

namespace postproc::cli {
namespace {

namespace fs = std::filesystem;

struct BatchArgs {
  std::string job_dir, out_dir, machine, machine_name = "machine.toml", mode = "geometric", shard;
  std::string dialect;  ///< "" = each machine file's
  std::vector<std::string> globs;
  unsigned jobs = 0;
  double max_deviation_um = 1.0;
  double max_angle_arcsec = 4.0;
  int iterations = 12;
  std::string contour_split = "auto";
  bool no_header = false, force = false, quiet = false, flatten = false, allow_recompensation = false;
  ResolveArgs resolve;
  // merge
  std::vector<std::string> manifests;
  std::string merged;
};

double num(const nlohmann::json& j, const char* group, const char* key) {
  const auto g = j.find(group);
  if (g == j.end() || !g->is_object()) return std::nan("");
  const auto v = g->find(key);
  return v != g->end() && v->is_number() ? v->get<double>() : std::nan("");
}

std::string cell(double v, double scale, const char* spec) {
  return std::isnan(v) ? std::string("-") : fmt::format(fmt::runtime(spec), v * scale);
}

/// One line per file for logs (stderr is not a terminal), and for failures on a terminal.
std::string file_line(const batch::FileResult& f, std::size_t done, std::size_t total, bool contour) {
  std::string s = fmt::format("postproc: batch [{}/{}] {}: {}", done, total, f.path, f.status);
  if (f.status == "written" || f.status == "unchanged") {
    const auto& fig = f.figures;
    s += fmt::format(" ({} blocks changed, largest correction {} mm, tool axis {} mrad",
                     cell(num(fig, "counts", "changed_blocks"), 1, "{:.0f}"),
                     cell(num(fig, "figures", "max_correction_mm"), 1, "{:.4f}"),
                     cell(num(fig, "figures", "max_axis_correction_rad"), 1e3, "{:.4f}"));
    if (contour)
      s += fmt::format(", contour {} → {} µm", cell(num(fig, "contour", "before_tip_um"), 1, "{:.3f}"),
                       cell(num(fig, "contour", "after_tip_um"), 1, "{:.3f}"));
    s += fmt::format(", {:.2f} s)", f.seconds);
  } else {
    s += ": " + f.reason;
    if (f.removed_stale_output) s += " (the earlier output was removed)";
  }
  return s;
}

std::string summary_table(const batch::BatchResult& r, bool contour) {
  std::size_t w = 4;
  for (const auto& f : r.files) w = std::max(w, f.path.size());
  w = std::min<std::size_t>(w, 60);
  std::string s = fmt::format("{:<{}}  {:<9}  {:>9}  {:>9}  {:>15}  {:>16}  {:>14}  {:>18}  {:>16}", "file", w, "status",
                              "blocks", "changed", "correction (mm)", "err before (mm)", "residual (mm)",
                              "axis before (mrad)", "axis after (mrad)");
  if (contour) s += fmt::format("  {:>17}  {:>16}", "contour before (µm)", "contour after (µm)");
  s += fmt::format("  {:>8}\n", "time (s)");
  for (const auto& f : r.files) {
    const auto& g = f.figures;
    s += fmt::format("{:<{}}  {:<9}  {:>9}  {:>9}  {:>15}  {:>16}  {:>14}", f.path, w, f.status,
                     cell(num(g, "counts", "blocks"), 1, "{:.0f}"), cell(num(g, "counts", "changed_blocks"), 1, "{:.0f}"),
                     cell(num(g, "figures", "max_correction_mm"), 1, "{:.4f}"),
                     cell(num(g, "figures", "max_error_before_mm"), 1, "{:.4f}"),
                     cell(num(g, "figures", "max_residual_after_mm"), 1, "{:.5f}"));
    // Tool-axis error before and residual after on every machine kind (the reports hold degrees).
    constexpr double kMradPerDeg = 1e3 * 3.14159265358979323846 / 180;
    s += fmt::format("  {:>18}  {:>16}", cell(num(g, "figures", "max_error_before_deg"), kMradPerDeg, "{:.4f}"),
                     cell(num(g, "figures", "max_residual_after_deg"), kMradPerDeg, "{:.5f}"));
    if (contour)
      s += fmt::format("  {:>18}  {:>17}", cell(num(g, "contour", "before_tip_um"), 1, "{:.3f}"),
                       cell(num(g, "contour", "after_tip_um"), 1, "{:.3f}"));
    s += fmt::format("  {:>8.2f}\n", f.seconds);
  }
  return s;
}

std::string totals(const nlohmann::json& summary) {
  return fmt::format("{} files: {} written, {} unchanged (skipped), {} refused, {} failed; {:.1f} MB in {:.1f} s",
                     summary.value("files", 0), summary.value("written", 0), summary.value("unchanged", 0),
                     summary.value("refused", 0), summary.value("failed", 0),
                     summary.value("bytes", 0.0) / 1e6, summary.value("seconds", 0.0));
}

void run_merge(const BatchArgs& a, int& rc) {
  std::vector<std::string> names;
  std::string out = a.merged;
  for (const std::string& m : a.manifests) {
    std::error_code ec;
    if (fs::is_directory(m, ec)) {
      std::vector<std::string> found;
      for (const auto& e : fs::directory_iterator(m, ec)) {
        const std::string n = e.path().filename().string();
        if (n.rfind("postproc-manifest.shard-", 0) == 0 && n.size() > 5 && n.substr(n.size() - 5) == ".json")
          found.push_back(e.path().string());
      }
      if (found.empty())
        throw Error(ExitCode::no_input, fmt::format("{}: no postproc-manifest.shard-*.json in this folder", m));
      std::sort(found.begin(), found.end());
      names.insert(names.end(), found.begin(), found.end());
      if (out.empty()) out = (fs::path(m) / batch::kManifestName).string();
    } else {
      names.push_back(m);
    }
  }
  if (out.empty()) throw Error(ExitCode::usage, "batch merge: give -o MERGED.json (or a folder of shard manifests)");
  std::vector<nlohmann::json> shards;
  for (const std::string& n : names) {
    try {
      shards.push_back(nlohmann::json::parse(io::read_file(n, "manifest")));
    } catch (const nlohmann::json::exception& e) {
      throw Error(ExitCode::refused, fmt::format("{}: not JSON ({})", n, e.what()));
    }
  }
  const nlohmann::json merged = batch::merge_manifests(shards, names);
  OutputSet outputs;
  outputs.add(out, merged.dump(2) + "\n");
  outputs.commit();
  const auto& s = merged["summary"];
  std::string text = fmt::format("postproc: batch merge: {} manifests → {}: {}\n", names.size(), out, totals(s));
  if (!merged["complete"].get<bool>())
    text += fmt::format("postproc: batch merge: shards missing: {} (of {}); run them, then merge again\n",
                        merged["missing_shards"].dump(), merged["shard"]["count"].get<unsigned>());
  for (const auto& p : s["failures"]) text += fmt::format("postproc: batch merge: not compensated: {}\n", p.get<std::string>());
  std::fputs(text.c_str(), stderr);
  rc = merged["complete"].get<bool>() && s["failures"].empty() ? 0 : static_cast<int>(ExitCode::refused);
}

}  // namespace

void setup_batch(CLI::App& app, int& rc) {
  auto o = std::make_shared<BatchArgs>();
  auto* cmd = app.add_subcommand("batch", "compensate every program of a job folder tree into a mirrored tree, in "
                                          "parallel, with a manifest (re-runs skip unchanged files)");
  cmd->add_option("job_dir", o->job_dir, "the job folder to walk");
  cmd->add_option("-m,--machine", o->machine,
                  "default machine file; a machine.toml in a job folder (or a folder above it) overrides it there");
  cmd->add_option("-o,--output", o->out_dir, "output folder: the job folder's tree is mirrored here");
  cmd->add_option("-j,--jobs", o->jobs, "programs compensated at once (default: the cores this process may use, from its CPU affinity)");
  cmd->add_option("--glob", o->globs,
                  "file names to take (repeatable; case-insensitive; a glob with '/' matches the path below the job "
                  "folder); default *.nc *.ngc *.tap *.mpf *.spf *.cnc *.gcode *.eia *.iso *.ptp *.min *.h (Heidenhain Klartext)");
  cmd->add_option("--mode", o->mode, "geometric, contour or all, as for compensate")
      ->check(CLI::IsMember({"geometric", "contour", "all"}))
      ->capture_default_str();
  cmd->add_option("--shard", o->shard,
                  "k/N: take only the k-th of N shares of the files (cluster array jobs); its manifest is "
                  "postproc-manifest.shard-k-of-N.json; join them with `postproc batch merge`");
  cmd->add_option("--machine-name", o->machine_name, "name of per-folder machine files")->capture_default_str();
  cmd->add_option("--dialect", o->dialect,
                  fmt::format("read every program as this dialect ({}) instead of its machine file's; a program "
                              "whose first lines hold another dialect's construct gets warning PP-W005 either way",
                              gcode::dialect_names()))
      ->check([](const std::string& v) {
        return gcode::make_dialect(v).has_value() ? std::string()
                                                  : fmt::format("unknown dialect '{}'; use {}", v, gcode::dialect_names());
      });
  cmd->add_option("--max-deviation", o->max_deviation_um, "as for compensate, µm")->capture_default_str();
  cmd->add_option("--max-angle-deviation", o->max_angle_arcsec, "as for compensate, arcsec")->capture_default_str();
  cmd->add_option("--iterations,--max-iterations", o->iterations, "contour modes: most prediction / correction rounds")
      ->capture_default_str();
  cmd->add_option("--contour-split", o->contour_split, "contour modes: auto or off, as for compensate")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "off"}));
  cmd->add_flag("--no-header", o->no_header, "do not write the header comment into the programs");
  cmd->add_flag("--allow-recompensation", o->allow_recompensation,
                "compensate programs that already carry postproc's compensation header (refused otherwise, PP-E620)");
  cmd->add_flag("--flatten", o->flatten, "as for compensate: write programs with parameters or loops as literal moves");
  add_resolve_options(*cmd, o->resolve);
  cmd->add_flag("--force", o->force, "compensate every file again, even when the manifest says it is unchanged");
  cmd->add_flag("-q,--quiet", o->quiet, "no summary table (the manifest still has everything)");
  cmd->require_subcommand(0, 1);

  auto* merge = cmd->add_subcommand("merge", "join the shard manifests of a batch (a folder, or the manifest files)");
  merge->add_option("manifests", o->manifests, "shard manifests, or the output folder holding them")->required();
  merge->add_option("-o,--output", o->merged, "merged manifest (default: postproc-manifest.json in the folder given)");
  merge->callback([o, &rc] { run_merge(*o, rc); });

  cmd->callback([o, cmd, merge, &rc] {
    if (merge->parsed()) return;
    if (o->job_dir.empty() || o->out_dir.empty())
      throw Error(ExitCode::usage, "batch needs a job folder and -o OUTDIR: postproc batch JOBDIR -m MACHINE -o OUTDIR");
    if (!(o->max_deviation_um > 0) || !std::isfinite(o->max_deviation_um))
      throw Error(ExitCode::usage, "--max-deviation must be a positive number of µm, e.g. 1");
    if (!(o->max_angle_arcsec > 0) || !std::isfinite(o->max_angle_arcsec))
      throw Error(ExitCode::usage, "--max-angle-deviation must be a positive number of arcsec, e.g. 4");
    (void)cmd;
    batch::BatchOptions opt;
    opt.job_dir = o->job_dir;
    opt.out_dir = o->out_dir;
    opt.machine = o->machine;
    opt.machine_name = o->machine_name;
    opt.dialect = o->dialect;
    opt.globs = o->globs;
    opt.compensate.mode = *comp::parse_mode(o->mode);  // checked by --mode
    opt.compensate.max_deviation_mm = o->max_deviation_um / 1000.0;
    opt.compensate.max_angle_rad = o->max_angle_arcsec / 3600.0 * 3.14159265358979323846 / 180.0;
    opt.compensate.header = !o->no_header;
    opt.compensate.tool_version = POSTPROC_VERSION;
    opt.compensate.flatten = o->flatten;
    opt.compensate.allow_recompensation = o->allow_recompensation;
    opt.compensate.resolve = make_resolve_options(o->resolve);
    opt.compensate.contour.max_iterations = o->iterations;
    opt.compensate.contour_split = o->contour_split == "auto";
    opt.jobs = o->jobs > 0 ? o->jobs : usable_cores();
    if (!o->shard.empty()) opt.shard = batch::parse_shard(o->shard);
    opt.force = o->force;
    const bool contour = o->mode != "geometric";

    ProgressBar bar("postproc: batch");
    std::uint64_t failures = 0;
    const batch::BatchResult r = batch::run_batch(opt, [&](const batch::FileResult& f, std::size_t done, std::size_t total) {
      const bool bad = f.status == "refused" || f.status == "failed";
      failures += bad ? 1 : 0;
      if (!bar.enabled())
        std::fputs((file_line(f, done, total, contour) + "\n").c_str(), stderr);
      else if (bad)
        bar.line(file_line(f, done, total, contour));
      if (bar.enabled())
        bar.update("", static_cast<double>(done), static_cast<double>(total),
                   fmt::format("{}/{} files{}", done, total, failures ? fmt::format(", {} not compensated", failures) : ""));
    });
    bar.finish();
    for (const std::string& n : r.notes) std::fputs(fmt::format("postproc: batch: {}\n", n).c_str(), stderr);
    if (!o->quiet) std::fputs(summary_table(r, contour).c_str(), stdout);
    const nlohmann::json manifest = batch::manifest_json(opt, r);
    const std::string manifest_path =
        (fs::path(o->out_dir) / (opt.shard.count > 1 ? batch::shard_manifest_name(opt.shard.index, opt.shard.count)
                                                     : std::string(batch::kManifestName)))
            .string();
    std::string text = fmt::format("postproc: batch: {}{}; manifest {}\n", totals(manifest["summary"]),
                                   opt.shard.count > 1 ? fmt::format(" (shard {}/{} of {} files)", opt.shard.index,
                                                                     opt.shard.count, r.total_files)
                                                       : std::string(),
                                   manifest_path);
    if (!r.ok()) {
      text += "postproc: batch: not compensated (no output written for them):\n";
      for (const auto& f : r.files)
        if (f.status == "refused" || f.status == "failed")
          text += fmt::format("  {}: {}: {}\n", f.path, f.status, f.reason);
    }
    std::fputs(text.c_str(), stderr);
    rc = r.ok() ? 0 : static_cast<int>(ExitCode::refused);
  });
}

}  // namespace postproc::cli
