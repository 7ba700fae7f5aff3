#include "postproc/gcode/line_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/io/input_file.hpp"

namespace postproc::gcode {

LineReader::LineReader(const std::string& path, std::size_t chunk) : path_(path), buf_(std::max<std::size_t>(chunk, 1)) {  // a 0-byte buffer would never grow
  if (path == "-") {
    file_ = stdin;
  } else {
    io::accept_input(path, "NC program");
    file_ = std::fopen(path.c_str(), "rb");
    if (file_ == nullptr)
      throw Error(ExitCode::no_input, fmt::format("{}: cannot open for reading: {}", path, std::strerror(errno)));
    owns_file_ = true;
  }
}

LineReader::LineReader(std::string_view memory) : memory_(memory), from_memory_(true) {}

LineReader::~LineReader() {
  if (owns_file_ && file_ != nullptr) std::fclose(file_);
}

bool LineReader::rewind() {
  if (!from_memory_) {
    if (!owns_file_ || file_ == nullptr || std::fseek(file_, 0, SEEK_SET) != 0) return false;
    std::clearerr(file_);
    eof_ = false;
    end_ = 0;
  }
  begin_ = 0;
  line_no_ = 0;
  consumed_ = 0;
  return true;
}

bool LineReader::refill() {
  if (eof_ || from_memory_) return false;
  // Move the unread tail to the front; grow when one line fills the whole buffer.
  const std::size_t tail = end_ - begin_;
  if (begin_ > 0) {
    std::memmove(buf_.data(), buf_.data() + begin_, tail);
    begin_ = 0;
    end_ = tail;
  }
  if (end_ == buf_.size()) buf_.resize(buf_.size() * 2);
  const std::size_t got = std::fread(buf_.data() + end_, 1, buf_.size() - end_, file_);
  if (got == 0) {
    if (std::ferror(file_))
      throw Error(ExitCode::no_input, fmt::format("{}: read error: {}", path_, std::strerror(errno)));
    eof_ = true;
    return false;
  }
  end_ += got;
  return true;
}

namespace {
/// Index of the first '\n' or '\r' in [from, to), or `to`. memchr is vectorised; a lone '\r' is rare.
std::size_t find_eol(const char* base, std::size_t from, std::size_t to) {
  const void* nl = std::memchr(base + from, '\n', to - from);
  const std::size_t n = nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - base) : to;
  const void* cr = std::memchr(base + from, '\r', n - from);
  return cr ? static_cast<std::size_t>(static_cast<const char*>(cr) - base) : n;
}
}  // namespace

bool LineReader::next(std::string_view& line, std::string_view& eol) {
  if (from_memory_) {
    if (begin_ >= memory_.size()) return false;
    const char* base = memory_.data();
    const std::size_t i = find_eol(base, begin_, memory_.size());
    line = memory_.substr(begin_, i - begin_);
    std::size_t e = i;
    if (e < memory_.size()) e += (base[e] == '\r' && e + 1 < memory_.size() && base[e + 1] == '\n') ? 2 : 1;
    eol = memory_.substr(i, e - i);
    consumed_ += e - begin_;
    begin_ = e;
    ++line_no_;
    return true;
  }
  std::size_t scan_from = begin_;
  for (;;) {
    const char* base = buf_.data();
    std::size_t i = find_eol(base, scan_from, end_);
    // A '\r' at the end of the buffer may be the first half of "\r\n": need one more byte.
    const bool need_more = i >= end_ || (base[i] == '\r' && i + 1 >= end_ && !eof_);
    if (need_more) {
      const std::size_t offset = i - begin_;  // bytes already known to hold no EOL
      if (refill()) {
        scan_from = begin_ + offset;
        continue;
      }
      if (begin_ >= end_) return false;
      i = std::min(begin_ + offset, end_);  // refill() may have moved the unread bytes to the front
    }
    base = buf_.data();
    std::size_t e = i;
    if (e < end_) e += (base[e] == '\r' && e + 1 < end_ && base[e + 1] == '\n') ? 2 : 1;
    line = std::string_view(base + begin_, i - begin_);
    eol = std::string_view(base + i, e - i);
    consumed_ += e - begin_;
    begin_ = e;
    ++line_no_;
    return true;
  }
}

}  // namespace postproc::gcode
