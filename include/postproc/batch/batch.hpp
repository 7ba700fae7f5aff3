#pragma once
/// @file
/// `postproc batch JOBDIR -m MACHINE -o OUTDIR`: compensates every program of a job folder tree
/// into a mirrored tree, in parallel, with a manifest that makes re-runs incremental and lets a
/// cluster scheduler split the work into shards.
///
/// - **Walk.** Every regular file (or link to one) under the job folder whose name matches one of
///   the globs (case-insensitive; a glob with '/' matches the path relative to the job folder).
///   Hidden files and folders (".name") and the output folder are skipped. The list is sorted by
///   relative path (bytewise, '/' separators): the order is the same on every machine.
/// - **Machine.** A file named `machine_name` (default `machine.toml`) in a program's folder or
///   any folder above it, up to the job folder, overrides the default machine for that subtree
///   (the nearest wins).
/// - **Output.** OUTDIR/<relative path>, written to a temporary file and renamed on success. A
///   program that is refused or fails leaves no output: an output of an earlier run at that path
///   is removed (it no longer corresponds to the input) and the manifest says so.
/// - **Skipping.** A file is not compensated again when the previous manifest (this shard's, or the
///   merged one in OUTDIR) lists it as written with the same input SHA-256, machine SHA-256, tool
///   version and settings (mode and limits), and its output is still there with the recorded
///   SHA-256. Its entry is carried over with status "unchanged".
/// - **Shards.** `--shard k/N` takes the files whose position i (0-based) in the sorted list has
///   i mod N = k − 1; its manifest is `postproc-manifest.shard-k-of-N.json`. The shards of one
///   tree cover every file exactly once; `merge_manifests` joins them.
/// - **Determinism.** Each program is compensated on its own, so the output bytes do not depend on
///   the number of jobs or on which shard ran it.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "postproc/compensation/compensate.hpp"
#include "postproc/contour/precompensate.hpp"

namespace postproc::batch {

/// Globs used when none is given: the usual NC program extensions.
[[nodiscard]] const std::vector<std::string>& default_globs();

/// Manifest file names in OUTDIR.
inline constexpr const char* kManifestName = "postproc-manifest.json";
[[nodiscard]] std::string shard_manifest_name(unsigned index, unsigned count);

struct Shard {
  unsigned index = 1;  ///< k, 1-based
  unsigned count = 1;  ///< N
};
/// Parses "k/N" (1 ≤ k ≤ N); throws postproc::Error (usage) otherwise.
[[nodiscard]] Shard parse_shard(const std::string& text);

struct BatchOptions {
  std::filesystem::path job_dir;
  std::filesystem::path out_dir;
  std::string machine;                      ///< default machine file (may be empty if every folder has one)
  std::string machine_name = "machine.toml";  ///< per-folder override file name
  std::string dialect;                      ///< every program read as this dialect; "" = each machine file's
  std::vector<std::string> globs;           ///< empty: default_globs()
  comp::CompensateOptions compensate;       ///< mode, limits, header, tool version, contour iteration
  unsigned jobs = 1;                        ///< worker threads
  Shard shard;
  bool force = false;                       ///< ignore earlier manifests: compensate every file
  std::size_t max_diagnostics = 50;         ///< stored per file in the manifest
};

/// One program of the batch.
struct FileResult {
  std::string path;            ///< relative to the job folder, '/' separators
  std::string status;          ///< "written", "unchanged", "refused" (the program has errors), "failed"
  std::string input_sha256;    ///< empty when the input could not be read
  std::string output_sha256;   ///< written / unchanged only
  std::string machine_file;    ///< as given (-m) or relative to the job folder (per-folder file)
  std::string machine_sha256;
  std::string tool_version;
  std::string settings;        ///< mode and limits, the part of the skip key besides the hashes
  std::uint64_t bytes = 0;     ///< input size
  double seconds = 0;          ///< time spent on this file (0 for a carried-over entry's own time)
  std::string reason;          ///< refused / failed: one line saying why
  bool removed_stale_output = false;  ///< an earlier run's output was removed
  /// Subprogram files the program's resolution read (path as found, SHA-256): a re-run redoes the
  /// file when one of them changed.
  std::vector<std::pair<std::string, std::string>> subprograms;
  nlohmann::json figures;      ///< result_json() of the run: counts, figures, contour
  nlohmann::json diagnostics = nlohmann::json::array();
};

struct BatchResult {
  std::vector<FileResult> files;  ///< in the sorted order of the walk (this shard's files)
  std::uint64_t total_files = 0;  ///< files found in the whole tree (all shards)
  double seconds = 0;
  std::vector<std::string> notes;  ///< e.g. an earlier manifest that could not be read
  [[nodiscard]] std::size_t count(std::string_view status) const;
  [[nodiscard]] bool ok() const { return count("refused") + count("failed") == 0; }
};

/// The programs under `job_dir` matching `globs` (empty: default_globs()), sorted, relative, with
/// '/' separators. Folders that cannot be read are returned in `unreadable` (relative).
[[nodiscard]] std::vector<std::string> list_programs(const std::filesystem::path& job_dir,
                                                     const std::vector<std::string>& globs,
                                                     const std::filesystem::path& skip_dir,
                                                     std::vector<std::string>* unreadable = nullptr);

/// The part of `files` (sorted) that shard `s` takes.
[[nodiscard]] std::vector<std::string> shard_files(const std::vector<std::string>& files, Shard s);

/// Called once per finished file (from the worker that finished it, serialised by a lock):
/// the file, how many are done, how many in all.
using FileDone = std::function<void(const FileResult&, std::size_t done, std::size_t total)>;

/// Runs the batch. Throws postproc::Error (usage) for a bad job / output folder (missing, the
/// same, or the job folder inside the output folder); every per-file problem is a FileResult.
/// Writes the manifest (shard manifest with --shard) into OUTDIR.
[[nodiscard]] BatchResult run_batch(const BatchOptions& opt, const FileDone& on_file = {});

/// The manifest of a run: tool, settings, default machine, shard, per-file entries, summary.
[[nodiscard]] nlohmann::json manifest_json(const BatchOptions& opt, const BatchResult& r);

/// Joins shard manifests (parsed JSON) into one. Throws postproc::Error (refused) with the reason
/// when they do not belong together (different shard counts, settings, tool version or job
/// folder; a shard given twice; a file in two shards). Missing shards are listed in
/// "missing_shards" and make `complete` false.
[[nodiscard]] nlohmann::json merge_manifests(const std::vector<nlohmann::json>& shards,
                                             const std::vector<std::string>& names);

}  // namespace postproc::batch
