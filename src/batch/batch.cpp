// postproc batch: walk a job folder, compensate every program in parallel into a mirrored tree,
// keep a manifest for incremental re-runs and shards.
#include "postproc/batch/batch.hpp"

#include <fnmatch.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <system_error>
#include <thread>

#include <fmt/format.h>

#include "postproc/compensation/result_json.hpp"
#include "postproc/gcode/detect.hpp"
#include "postproc/error.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/io/input_guard.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::batch {
namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

bool hidden(const fs::path& p) {
  const std::string n = p.filename().string();
  return !n.empty() && n[0] == '.';
}

bool matches(const std::vector<std::string>& globs, const std::string& rel, const std::string& name) {
  for (const std::string& g : globs) {
    const bool pathwise = g.find('/') != std::string::npos;
    if (::fnmatch(g.c_str(), pathwise ? rel.c_str() : name.c_str(), FNM_CASEFOLD | (pathwise ? FNM_PATHNAME : 0)) == 0)
      return true;
  }
  return false;
}

void walk(const fs::path& dir, const std::string& rel_dir, const std::vector<std::string>& globs, const fs::path& skip,
          std::vector<std::string>& out, std::vector<std::string>* unreadable) {
  std::error_code ec;
  fs::directory_iterator it(dir, ec);
  if (ec) {
    if (unreadable) unreadable->push_back(rel_dir.empty() ? "." : rel_dir);
    return;
  }
  std::vector<fs::directory_entry> entries;
  for (; it != fs::directory_iterator(); it.increment(ec)) {
    if (ec) break;
    entries.push_back(*it);
  }
  if (ec && unreadable) unreadable->push_back(rel_dir.empty() ? "." : rel_dir);
  for (const fs::directory_entry& e : entries) {
    if (hidden(e.path())) continue;
    const std::string name = e.path().filename().string();
    const std::string rel = rel_dir.empty() ? name : rel_dir + "/" + name;
    std::error_code ec2;
    const bool link = e.is_symlink(ec2);
    const bool dir_entry = e.is_directory(ec2);
    if (dir_entry) {
      // Linked folders are not followed (no cycles, no walking out of the job folder).
      if (link) continue;
      if (!skip.empty()) {
        std::error_code ec3;
        if (fs::equivalent(e.path(), skip, ec3)) continue;
      }
      walk(e.path(), rel, globs, skip, out, unreadable);
      continue;
    }
    // Regular files, and links to files (a dangling link is listed so that it fails visibly).
    if (!(e.is_regular_file(ec2) || link)) continue;
    if (matches(globs, rel, name)) out.push_back(rel);
  }
}

std::string settings_of(const BatchOptions& o) {
  const comp::CompensateOptions& c = o.compensate;
  std::string s = fmt::format("mode={};max_deviation_mm={:.17g};max_angle_rad={:.17g};header={}", comp::to_string(c.mode),
                              c.max_deviation_mm, c.max_angle_rad, c.header ? 1 : 0);
  if (c.mode != comp::Mode::geometric)
    s += fmt::format(";iterations={};contour_split={}", o.compensate.contour.max_iterations, c.contour_split ? "auto" : "off");
  if (c.flatten) s += ";flatten=1";
  if (!o.dialect.empty()) s += fmt::format(";dialect={}", o.dialect);
  for (const auto& [name, value] : c.resolve.set) s += fmt::format(";set {}={:.17g}", name, value);
  for (const std::string& dir : c.resolve.search_dirs) s += fmt::format(";subprogram-dir {}", dir);
  return s;
}

/// A machine file as loaded for the batch: the machine, or why it cannot be used.
struct LoadedMachine {
  std::string label;  ///< as recorded in the manifest
  std::optional<machine::Machine> machine;
  std::optional<gcode::Dialect> dialect;
  std::string reason;  ///< when not loaded
  nlohmann::json diagnostics = nlohmann::json::array();
};

LoadedMachine load(const std::string& path, const std::string& label, const std::string& dialect_override,
                   std::size_t max_diagnostics) {
  LoadedMachine lm;
  lm.label = label;
  gcode::DiagnosticSink sink;
  try {
    lm.machine = machine::load_machine(path, sink);
  } catch (const Error& e) {
    lm.reason = fmt::format("machine file {}: {}", label, e.what());
    return lm;
  }
  lm.diagnostics = comp::diagnostics_json(sink, max_diagnostics);
  if (!lm.machine) {
    lm.reason = fmt::format("machine file {} refused", label);
    for (const auto& d : sink.stored())
      if (d.severity == gcode::Severity::error) {
        lm.reason = fmt::format("machine file {} refused: {}:{}:{}: {}", label, d.file, d.where.line, d.where.column,
                                d.message);
        break;
      }
    return lm;
  }
  // Headers and reports name the machine file as the manifest does (relative to the job folder
  // for per-folder files), so the output does not depend on where the job folder is mounted.
  lm.machine->file = label;
  const std::string& name = dialect_override.empty() ? lm.machine->dialect_name : dialect_override;
  auto dialect = gcode::make_dialect(name, lm.machine->dialect_options);
  if (!dialect) {
    lm.reason = fmt::format("machine file {}: unknown dialect '{}'", label, name);
    lm.machine.reset();
    return lm;
  }
  lm.dialect = *dialect;
  return lm;
}

/// Entries of earlier manifests by path (this shard's first, then the merged one).
std::map<std::string, nlohmann::json> previous_entries(const fs::path& out_dir, const std::string& own,
                                                       std::vector<std::string>& notes) {
  std::map<std::string, nlohmann::json> by_path;
  for (const std::string& name : {own, std::string(kManifestName)}) {
    const fs::path p = out_dir / name;
    std::error_code ec;
    if (!fs::exists(p, ec)) continue;
    try {
      const nlohmann::json j = nlohmann::json::parse(io::read_state_file(p.string(), "manifest"));
      for (const nlohmann::json& e : j.at("files")) by_path.emplace(e.at("path").get<std::string>(), e);
    } catch (const std::exception& e) {
      notes.push_back(fmt::format("{}: earlier manifest not usable ({}); its files are compensated again", p.string(),
                                  e.what()));
    }
  }
  return by_path;
}

std::string str_or_empty(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : std::string();
}

class Runner {
 public:
  Runner(const BatchOptions& o, const std::map<std::string, nlohmann::json>& prev,
         const std::map<std::string, const LoadedMachine*>& machine_of)
      : o_(o), prev_(prev), machine_of_(machine_of), settings_(settings_of(o)) {}

  FileResult run(const std::string& rel) const {
    const auto t0 = Clock::now();
    FileResult fr;
    fr.path = rel;
    fr.tool_version = o_.compensate.tool_version;
    fr.settings = settings_;
    const fs::path in = o_.job_dir / fs::path(rel);
    const fs::path out = o_.out_dir / fs::path(rel);
    try {
      process(fr, in, out);
    } catch (const std::exception& e) {  // a bug, or a write that failed: this file fails, the rest go on
      fr.status = "failed";
      fr.reason = e.what();
    }
    if (fr.status == "refused" || fr.status == "failed") {
      std::error_code ec;
      if (fs::is_regular_file(out, ec) && fs::remove(out, ec)) fr.removed_stale_output = true;
    }
    fr.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    return fr;
  }

 private:
  void process(FileResult& fr, const fs::path& in, const fs::path& out) const {
    const LoadedMachine* lm = machine_of_.at(fr.path);
    if (lm == nullptr) {
      fr.status = "failed";
      fr.reason = fmt::format("no machine file: give -m, or put {} in its folder or a folder above", o_.machine_name);
      return;
    }
    fr.machine_file = lm->label;
    if (!lm->machine) {
      fr.status = "failed";
      fr.reason = lm->reason;
      fr.diagnostics = lm->diagnostics;
      return;
    }
    fr.machine_sha256 = lm->machine->sha256;
    std::string text;
    try {
      text = io::read_file(in.string(), "NC program");
    } catch (const Error& e) {
      fr.status = "failed";
      fr.reason = e.what();
      return;
    }
    fr.bytes = text.size();
    fr.input_sha256 = machine::sha256_hex(text);
    if (!o_.force && unchanged(fr, out)) return;

    gcode::DiagnosticSink sink(o_.max_diagnostics);
    gcode::warn_other_dialect(text, in.string(), *lm->dialect,
                              o_.dialect.empty() ? fmt::format("the dialect of the machine file {}", lm->label)
                                                 : std::string("--dialect"),
                              sink);
    auto mem = io::OutputFile::memory();
    comp::ContourDetails details;
    const comp::CompensateResult r = comp::compensate_program({text, in.string(), *lm->dialect, *lm->machine}, o_.compensate, mem,
                                                              sink, &details);
    fr.diagnostics = comp::diagnostics_json(sink, o_.max_diagnostics);
    if (sink.has_errors()) {
      fr.status = "refused";
      fr.reason = "the program has errors";
      for (const auto& d : sink.stored())
        if (d.severity == gcode::Severity::error) {
          fr.reason = fmt::format("{}:{}:{}: {} {}", d.file, d.where.line, d.where.column, d.code, d.message);
          break;
        }
      return;
    }
    fr.figures = comp::result_json(r, o_.compensate.mode, &details);
    for (const std::string& sub : r.subprogram_files)
      fr.subprograms.emplace_back(sub, machine::sha256_hex(io::read_file(sub, "subprogram")));
    const std::string bytes = mem.take();
    fr.output_sha256 = machine::sha256_hex(bytes);
    std::error_code ec;
    fs::create_directories(out.parent_path(), ec);
    if (ec)
      throw Error(ExitCode::cannot_write,
                  fmt::format("cannot create folder {}: {}", out.parent_path().string(), ec.message()));
    io::OutputFile f(out.string(), in.string(), false);
    f.write(bytes);
    f.commit();
    fr.status = "written";
  }

  /// Carries the earlier entry over when nothing that decides the output has changed.
  bool unchanged(FileResult& fr, const fs::path& out) const {
    const auto it = prev_.find(fr.path);
    if (it == prev_.end()) return false;
    const nlohmann::json& e = it->second;
    const std::string status = str_or_empty(e, "status");
    if (status != "written" && status != "unchanged") return false;
    const auto machine = e.find("machine");
    if (machine == e.end() || !machine->is_object()) return false;
    if (str_or_empty(e, "input_sha256") != fr.input_sha256 || str_or_empty(*machine, "sha256") != fr.machine_sha256 ||
        str_or_empty(e, "tool_version") != fr.tool_version || str_or_empty(e, "settings") != fr.settings)
      return false;
    // The subprogram files the resolution read must be as they were.
    std::vector<std::pair<std::string, std::string>> subs;
    if (const auto sp = e.find("subprograms"); sp != e.end()) {
      if (!sp->is_array()) return false;
      for (const nlohmann::json& x : *sp) {
        const std::string file = str_or_empty(x, "file"), sha = str_or_empty(x, "sha256");
        try {
          if (file.empty() || machine::sha256_hex(io::read_file(file, "subprogram")) != sha) return false;
        } catch (const Error&) {
          return false;
        }
        subs.emplace_back(file, sha);
      }
    }
    const std::string out_sha = str_or_empty(e, "output_sha256");
    std::error_code ec;
    if (out_sha.empty() || !fs::is_regular_file(out, ec)) return false;
    try {
      if (machine::sha256_hex(io::read_state_file(out.string(), "output")) != out_sha) return false;
    } catch (const Error&) {
      return false;
    }
    fr.status = "unchanged";
    fr.output_sha256 = out_sha;
    fr.subprograms = std::move(subs);
    if (const auto f = e.find("figures"); f != e.end()) fr.figures = *f;
    if (const auto d = e.find("diagnostics"); d != e.end()) fr.diagnostics = *d;
    return true;
  }

  const BatchOptions& o_;
  const std::map<std::string, nlohmann::json>& prev_;
  const std::map<std::string, const LoadedMachine*>& machine_of_;
  std::string settings_;
};

fs::path absolute_of(const fs::path& p) {
  std::error_code ec;
  fs::path a = fs::weakly_canonical(fs::absolute(p), ec);
  return ec ? fs::absolute(p).lexically_normal() : a;
}

bool inside(const fs::path& child, const fs::path& parent) {
  const auto c = child.lexically_normal(), q = parent.lexically_normal();
  auto ci = c.begin();
  for (auto qi = q.begin(); qi != q.end(); ++qi, ++ci) {
    if (qi->empty()) continue;  // trailing separator
    if (ci == c.end() || *ci != *qi) return false;
  }
  return true;
}

nlohmann::json entry_json(const FileResult& f) {
  nlohmann::json e;
  e["path"] = f.path;
  e["status"] = f.status;
  e["input_sha256"] = f.input_sha256;
  e["output"] = (f.status == "written" || f.status == "unchanged") ? nlohmann::json(f.path) : nlohmann::json(nullptr);
  e["output_sha256"] = f.output_sha256.empty() ? nlohmann::json(nullptr) : nlohmann::json(f.output_sha256);
  e["machine"] = {{"file", f.machine_file}, {"sha256", f.machine_sha256}};
  e["tool_version"] = f.tool_version;
  e["settings"] = f.settings;
  e["bytes"] = f.bytes;
  e["seconds"] = f.seconds;
  if (!f.reason.empty()) e["reason"] = f.reason;
  if (f.removed_stale_output) e["removed_stale_output"] = true;
  if (!f.subprograms.empty()) {
    nlohmann::json subs = nlohmann::json::array();
    for (const auto& [file, sha] : f.subprograms) subs.push_back({{"file", file}, {"sha256", sha}});
    e["subprograms"] = subs;
  }
  e["figures"] = f.figures.is_null() ? nlohmann::json::object() : f.figures;
  e["diagnostics"] = f.diagnostics;
  return e;
}

nlohmann::json summary_of(const nlohmann::json& files, double seconds) {
  nlohmann::json s = {{"files", files.size()}, {"written", 0}, {"unchanged", 0}, {"refused", 0}, {"failed", 0}};
  std::uint64_t bytes = 0;
  nlohmann::json failures = nlohmann::json::array();
  for (const nlohmann::json& e : files) {
    const std::string st = str_or_empty(e, "status");
    if (s.contains(st)) s[st] = s[st].get<std::uint64_t>() + 1;
    if (st == "refused" || st == "failed") failures.push_back(e.at("path"));
    bytes += e.value("bytes", std::uint64_t{0});
  }
  s["bytes"] = bytes;
  s["seconds"] = seconds;
  s["failures"] = failures;
  return s;
}

}  // namespace

const std::vector<std::string>& default_globs() {
  static const std::vector<std::string> g = {"*.nc",  "*.ngc", "*.tap", "*.mpf", "*.spf", "*.cnc",
                                             "*.gcode", "*.eia", "*.iso", "*.ptp", "*.min", "*.h"};
  return g;
}

std::string shard_manifest_name(unsigned index, unsigned count) {
  return fmt::format("postproc-manifest.shard-{}-of-{}.json", index, count);
}

Shard parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  unsigned k = 0, n = 0;
  std::size_t used_k = 0, used_n = 0;
  try {
    if (slash != std::string::npos && slash > 0 && slash + 1 < text.size()) {
      k = static_cast<unsigned>(std::stoul(text.substr(0, slash), &used_k));
      n = static_cast<unsigned>(std::stoul(text.substr(slash + 1), &used_n));
    }
  } catch (const std::exception&) {
    k = n = 0;
  }
  if (slash == std::string::npos || used_k != slash || used_n != text.size() - slash - 1 || n == 0 || k == 0 || k > n)
    throw Error(ExitCode::usage,
                fmt::format("--shard '{}': give k/N with 1 ≤ k ≤ N, e.g. --shard 2/8 (k is the array task index)", text));
  return {k, n};
}

std::size_t BatchResult::count(std::string_view status) const {
  return static_cast<std::size_t>(
      std::count_if(files.begin(), files.end(), [&](const FileResult& f) { return f.status == status; }));
}

std::vector<std::string> list_programs(const fs::path& job_dir, const std::vector<std::string>& globs,
                                       const fs::path& skip_dir, std::vector<std::string>* unreadable) {
  std::vector<std::string> out;
  walk(job_dir, "", globs.empty() ? default_globs() : globs, skip_dir, out, unreadable);
  std::sort(out.begin(), out.end());
  if (unreadable) std::sort(unreadable->begin(), unreadable->end());
  return out;
}

std::vector<std::string> shard_files(const std::vector<std::string>& files, Shard s) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < files.size(); ++i)
    if (i % s.count == s.index - 1) out.push_back(files[i]);
  return out;
}

BatchResult run_batch(const BatchOptions& opt, const FileDone& on_file) {
  const auto t0 = Clock::now();
  const io::RunInputs run;  // no output of the batch over any program, subprogram or machine file it read
  std::error_code ec;
  if (!fs::is_directory(opt.job_dir, ec))
    throw Error(ExitCode::no_input, fmt::format("{}: not a folder (give the job folder to walk)", opt.job_dir.string()));
  const fs::path job = absolute_of(opt.job_dir), outd = absolute_of(opt.out_dir);
  if (inside(job, outd))
    throw Error(ExitCode::usage, fmt::format("the job folder {} is the output folder {} or inside it: outputs could "
                                             "overwrite programs; give -o a folder outside the job folder",
                                             opt.job_dir.string(), opt.out_dir.string()));
  fs::create_directories(opt.out_dir, ec);
  if (ec)
    throw Error(ExitCode::cannot_write,
                fmt::format("cannot create the output folder {}: {}", opt.out_dir.string(), ec.message()));
  if (opt.shard.count == 0 || opt.shard.index == 0 || opt.shard.index > opt.shard.count)
    throw Error(ExitCode::usage, "shard must be k/N with 1 ≤ k ≤ N");

  BatchResult result;
  std::vector<std::string> unreadable;
  const std::vector<std::string> all = list_programs(opt.job_dir, opt.globs, inside(outd, job) ? opt.out_dir : fs::path(),
                                                     &unreadable);
  result.total_files = all.size();
  const std::vector<std::string> mine = shard_files(all, opt.shard);

  // Machines: the nearest per-folder file, else the default; each file loaded once.
  std::map<std::string, std::unique_ptr<LoadedMachine>> loaded;  // by label
  std::map<std::string, const LoadedMachine*> machine_of;         // by program
  std::map<std::string, const LoadedMachine*> by_folder;          // cache, by relative folder
  auto machine_for_folder = [&](const std::string& folder) -> const LoadedMachine* {
    std::string f = folder;
    std::vector<std::string> visited;
    const LoadedMachine* found = nullptr;
    for (;;) {
      if (auto it = by_folder.find(f); it != by_folder.end()) {
        found = it->second;
        break;
      }
      visited.push_back(f);
      const std::string label = f.empty() ? opt.machine_name : f + "/" + opt.machine_name;
      const fs::path candidate = opt.job_dir / fs::path(label);
      std::error_code e2;
      if (fs::exists(candidate, e2)) {
        auto& slot = loaded[label];
        if (!slot) slot = std::make_unique<LoadedMachine>(load(candidate.string(), label, opt.dialect, opt.max_diagnostics));
        found = slot.get();
        break;
      }
      if (f.empty()) {
        if (!opt.machine.empty()) {
          auto& slot = loaded["-m " + opt.machine];
          if (!slot) slot = std::make_unique<LoadedMachine>(load(opt.machine, opt.machine, opt.dialect, opt.max_diagnostics));
          found = slot.get();
        }
        break;
      }
      const auto slash = f.rfind('/');
      f = slash == std::string::npos ? std::string() : f.substr(0, slash);
    }
    for (const std::string& v : visited) by_folder[v] = found;
    return found;
  };
  for (const std::string& rel : mine) {
    const auto slash = rel.rfind('/');
    machine_of[rel] = machine_for_folder(slash == std::string::npos ? std::string() : rel.substr(0, slash));
  }

  const std::string own = opt.shard.count > 1 ? shard_manifest_name(opt.shard.index, opt.shard.count) : kManifestName;
  std::map<std::string, nlohmann::json> prev;
  if (!opt.force) prev = previous_entries(opt.out_dir, own, result.notes);
  // Fewer programs than jobs: the cores left over go to each program's own threads (the output
  // of compensate is the same for any number, CompensateOptions::jobs).
  const unsigned workers =
      std::max(1u, std::min<unsigned>(opt.jobs, static_cast<unsigned>(std::max<std::size_t>(mine.size(), 1))));
  BatchOptions run_opt = opt;
  if (run_opt.compensate.jobs <= 1) run_opt.compensate.jobs = std::max(1u, opt.jobs / workers);
  const Runner runner(run_opt, prev, machine_of);

  result.files.resize(mine.size());
  std::atomic<std::size_t> next{0};
  std::mutex lock;
  std::size_t done = 0;
  auto worker = [&] {
    for (;;) {
      const std::size_t i = next.fetch_add(1);
      if (i >= mine.size()) return;
      FileResult fr = runner.run(mine[i]);
      std::lock_guard<std::mutex> g(lock);
      result.files[i] = std::move(fr);
      ++done;
      if (on_file) on_file(result.files[i], done, mine.size());
    }
  };
  const unsigned n = workers;
  if (n == 1) {
    worker();
  } else {
    std::vector<std::thread> threads;
    threads.reserve(n);
    for (unsigned t = 0; t < n; ++t) threads.emplace_back(worker);
    for (std::thread& t : threads) t.join();
  }
  // Folders that could not be read are failures too: their programs were not seen.
  for (const std::string& u : opt.shard.index == 1 ? unreadable : std::vector<std::string>{}) {
    FileResult fr;
    fr.path = u + "/";
    fr.status = "failed";
    fr.reason = "folder cannot be read: its programs were not compensated";
    fr.tool_version = opt.compensate.tool_version;
    fr.settings = settings_of(opt);
    result.files.push_back(std::move(fr));
  }
  result.seconds = std::chrono::duration<double>(Clock::now() - t0).count();

  io::OutputFile manifest((opt.out_dir / own).string());
  manifest.write(manifest_json(opt, result).dump(2) + "\n");
  manifest.commit();
  return result;
}

nlohmann::json manifest_json(const BatchOptions& opt, const BatchResult& r) {
  nlohmann::json j;
  j["manifest"] = "postproc batch";
  j["format"] = 1;
  j["tool"] = {{"name", "postproc"}, {"version", opt.compensate.tool_version}};
  j["job_dir"] = opt.job_dir.string();
  j["out_dir"] = opt.out_dir.string();
  j["mode"] = comp::to_string(opt.compensate.mode);
  j["settings"] = settings_of(opt);
  j["limits"] = {{"max_deviation_mm", opt.compensate.max_deviation_mm},
                 {"max_angle_deviation_deg", opt.compensate.max_angle_rad * 180.0 / 3.14159265358979323846}};
  j["machine"] = {{"default", opt.machine}, {"per_folder_file", opt.machine_name}};
  j["globs"] = opt.globs.empty() ? default_globs() : opt.globs;
  j["shard"] = {{"index", opt.shard.index}, {"count", opt.shard.count}};
  j["total_files"] = r.total_files;
  nlohmann::json files = nlohmann::json::array();
  for (const FileResult& f : r.files) files.push_back(entry_json(f));
  j["summary"] = summary_of(files, r.seconds);
  j["files"] = std::move(files);
  j["notes"] = r.notes;
  return j;
}

nlohmann::json merge_manifests(const std::vector<nlohmann::json>& shards, const std::vector<std::string>& names) {
  if (shards.empty()) throw Error(ExitCode::usage, "batch merge: no shard manifests given");
  auto refuse = [](const std::string& why) { throw Error(ExitCode::refused, "batch merge: " + why); };
  const nlohmann::json& first = shards.front();
  unsigned count = 0;
  std::map<unsigned, std::string> seen;
  std::map<std::string, std::string> owner;  // path → manifest
  nlohmann::json files = nlohmann::json::array();
  double seconds = 0;
  std::uint64_t total = 0;
  for (std::size_t s = 0; s < shards.size(); ++s) {
    const nlohmann::json& m = shards[s];
    const std::string& name = names.at(s);
    if (!m.is_object() || m.value("manifest", std::string()) != "postproc batch" || !m.contains("files") ||
        !m.contains("shard"))
      refuse(fmt::format("{} is not a postproc batch manifest", name));
    const unsigned k = m["shard"].value("index", 0u), n = m["shard"].value("count", 0u);
    if (s == 0) {
      count = n;
      total = m.value("total_files", std::uint64_t{0});
    }
    if (n != count)
      refuse(fmt::format("{} is shard {}/{} but {} is of {} shards", name, k, n, names.front(), count));
    for (const char* key : {"settings", "job_dir"})
      if (m.value(key, std::string()) != first.value(key, std::string()))
        refuse(fmt::format("{} and {} differ in {} ('{}' against '{}')", name, names.front(), key,
                           m.value(key, std::string()), first.value(key, std::string())));
    if (m["tool"].value("version", std::string()) != first["tool"].value("version", std::string()))
      refuse(fmt::format("{} and {} were written by different postproc versions", name, names.front()));
    if (m.value("total_files", std::uint64_t{0}) != total)
      refuse(fmt::format("{} saw {} programs in the job folder but {} saw {}: the tree changed between the shard runs; "
                         "run the shards again",
                         name, m.value("total_files", std::uint64_t{0}), names.front(), total));
    if (auto [it, fresh] = seen.emplace(k, name); !fresh)
      refuse(fmt::format("shard {}/{} given twice ({} and {})", k, n, it->second, name));
    for (const nlohmann::json& e : m["files"]) {
      const std::string p = e.value("path", std::string());
      if (auto [it, fresh] = owner.emplace(p, name); !fresh)
        refuse(fmt::format("{} is in both {} and {}", p, it->second, name));
      files.push_back(e);
    }
    seconds = std::max(seconds, m.contains("summary") ? m["summary"].value("seconds", 0.0) : 0.0);
  }
  std::sort(files.begin(), files.end(), [](const nlohmann::json& a, const nlohmann::json& b) {
    return a.value("path", std::string()) < b.value("path", std::string());
  });
  nlohmann::json missing = nlohmann::json::array();
  for (unsigned k = 1; k <= count; ++k)
    if (!seen.count(k)) missing.push_back(k);
  nlohmann::json j = first;
  j["shard"] = {{"count", count}, {"merged_from", names}};
  j["missing_shards"] = missing;
  j["complete"] = missing.empty();
  j["summary"] = summary_of(files, seconds);
  j["files"] = std::move(files);
  j["notes"] = nlohmann::json::array();
  return j;
}

}  // namespace postproc::batch
