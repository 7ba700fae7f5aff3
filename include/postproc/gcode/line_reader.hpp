#pragma once
/// @file
/// Streaming line reader: memory bounded by the buffer and the longest line, not the file size.

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace postproc::gcode {

/// Reads lines from a file or stdin ("-"), keeping each line's exact end-of-line bytes.
class LineReader {
 public:
  /// Opens `path` ("-" = stdin). Throws postproc::Error (exit code io_error) if it cannot be opened.
  explicit LineReader(const std::string& path, std::size_t chunk = 1 << 20);
  /// Reads from an in-memory buffer (tests, fuzzing). The buffer must outlive the reader.
  /// Pass a std::string_view explicitly: a std::string selects the file constructor.
  explicit LineReader(std::string_view memory);
  ~LineReader();
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;

  /// Next line without its EOL in `line`, the EOL itself in `eol`. False at end of input.
  /// Views stay valid until the next call.
  bool next(std::string_view& line, std::string_view& eol);
  /// Starts again at the first line (memory buffers and regular files). False, leaving the reader
  /// where it was, when the input cannot be read twice (stdin, a pipe).
  bool rewind();
  [[nodiscard]] std::uint64_t line_number() const { return line_no_; }
  [[nodiscard]] std::uint64_t bytes_read() const { return consumed_; }

 private:
  bool refill();
  std::FILE* file_ = nullptr;
  bool owns_file_ = false;
  bool eof_ = false;
  std::string path_;
  std::vector<char> buf_;
  std::size_t begin_ = 0, end_ = 0;  // unread bytes are buf_[begin_, end_)
  std::string_view memory_;
  bool from_memory_ = false;
  std::uint64_t line_no_ = 0;
  std::uint64_t consumed_ = 0;
};

}  // namespace postproc::gcode
