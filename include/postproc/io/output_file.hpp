#pragma once
/// @file
/// Output that appears only on success: written to a temporary file beside the target and renamed
/// into place by commit(). "-" writes to stdout. An input is never overwritten unless asked, and then
/// a backup is kept.

#include <cstdio>
#include <string>
#include <string_view>

namespace postproc::io {

class OutputFile {
 public:
  /// `overwrite_input` names the input path; if it equals `path`, the input is only replaced when
  /// `allow_overwrite` is set, and then `path + ".bak"` keeps the original.
  explicit OutputFile(std::string path, std::string_view input_path = {}, bool allow_overwrite = false);
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  /// An output held in memory (an intermediate stage, e.g. the geometric pass of --mode all):
  /// commit() does nothing, take() hands the bytes over.
  [[nodiscard]] static OutputFile memory();
  [[nodiscard]] std::string take() { return std::move(held_); }
  void write(std::string_view bytes);
  /// Flushes, closes and renames the temporary file into place. Throws postproc::Error on failure.
  void commit();
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  void write_all(std::string_view bytes);
  /// Bytes of standard output held in memory before spilling to a temporary file.
  static constexpr std::size_t kStdoutMemory = std::size_t{16} << 20;
  std::string path_, temp_, held_;
  std::FILE* f_ = nullptr;
  struct MemoryTag {};
  explicit OutputFile(MemoryTag) : memory_(true) {}
  bool memory_ = false;
  bool stdout_ = false, direct_ = false, committed_ = false, backup_ = false;
};

}  // namespace postproc::io
