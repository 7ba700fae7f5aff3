#pragma once
/// @file
/// Output that appears only on success: written to a hidden temporary file beside the target
/// (`.NAME.postproc-tmp.HOST.PID`) and renamed into place by commit(). "-" writes to stdout.
///
/// Guarantees (docs/outputs.md): no output is written over an input of the run (io::input_guard;
/// PP-E901, exit 64) unless it is the one input `allow_overwrite` names, and then the first original
/// is kept as NAME.bak; two outputs of one run never name the same file (PP-E902, exit 64); the
/// temporary is removed on every error path and on SIGINT/SIGTERM/SIGHUP/SIGPIPE
/// (io::install_signal_cleanup); temporaries left by killed runs (kill -9, out of memory) are
/// removed by the next output into the same folder; several outputs of a run are published together
/// (commit_all): all are written completely first, then renamed.

#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/io/signal_cleanup.hpp"

namespace postproc::io {

class OutputFile {
 public:
  /// `input_path` names the input this output may replace: if `path` is that file, it is only
  /// replaced when `allow_overwrite` is set, and then `path + ".bak"` keeps the original (an
  /// existing .bak, holding an earlier original, is kept instead: backup_kept()).
  explicit OutputFile(std::string path, std::string_view input_path = {}, bool allow_overwrite = false);
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  /// An output held in memory (an intermediate stage, e.g. the geometric pass of --mode all):
  /// commit() does nothing, take() hands the bytes over.
  [[nodiscard]] static OutputFile memory();
  [[nodiscard]] std::string take() { return std::move(held_); }
  void write(std::string_view bytes);
  /// finish() then publish(). Throws postproc::Error on failure (nothing replaced then).
  void commit();
  /// Flushes and closes the temporary file: afterwards only the rename is left. Throws
  /// postproc::Error (cannot_write) when a write failed (full disk, file-size limit).
  void finish();
  /// Renames the finished temporary into place (standard output: writes the held bytes). Checks
  /// again that the target is no input of the run (inputs read after the output was opened).
  void publish();
  /// Commits several outputs of one run together: every one is finished before any is published,
  /// so a write failure of one leaves all targets as they were.
  static void commit_all(const std::vector<OutputFile*>& outputs);
  [[nodiscard]] const std::string& path() const { return path_; }
  /// True when the input was replaced but an existing NAME.bak (an earlier original) was kept.
  [[nodiscard]] bool backup_kept() const { return backup_kept_; }

 private:
  void write_all(std::string_view bytes);
  void refuse_if_input() const;
  void make_backup();
  /// Bytes of standard output held in memory before spilling to a temporary file.
  static constexpr std::size_t kStdoutMemory = std::size_t{16} << 20;
  std::string path_, temp_, held_, key_;
  std::FILE* f_ = nullptr;
  TemporaryRegistration registration_;
  struct MemoryTag {};
  explicit OutputFile(MemoryTag) : memory_(true) {}
  bool memory_ = false;
  bool stdout_ = false, direct_ = false, committed_ = false, finished_ = false, backup_ = false, backup_kept_ = false;
};

}  // namespace postproc::io
