#include "postproc/io/output_file.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include <fmt/format.h>
#include <unistd.h>

#include "postproc/error.hpp"

namespace postproc::io {
namespace fs = std::filesystem;

OutputFile::OutputFile(std::string path, std::string_view input_path, bool allow_overwrite) : path_(std::move(path)) {
  if (path_ == "-") {
    // Standard output gets the same guarantee as a file: the bytes are held back and written on
    // commit, so a refused program writes nothing. Up to kStdoutMemory in memory, beyond that in an
    // anonymous temporary file, so memory stays bounded whatever the size.
    stdout_ = true;
    return;
  }
  std::error_code ec;
  // Devices and pipes (/dev/null, a FIFO) are written directly: renaming over them would replace
  // the device with a regular file.
  if (fs::exists(path_, ec) && !fs::is_regular_file(path_, ec)) {
    f_ = std::fopen(path_.c_str(), "wb");
    if (f_ == nullptr)
      throw Error(ExitCode::cannot_write, fmt::format("{}: cannot open for writing: {}", path_, std::strerror(errno)));
    direct_ = true;
    return;
  }
  if (!input_path.empty() && input_path != "-" && fs::exists(path_, ec) &&
      fs::equivalent(fs::path(path_), fs::path(std::string(input_path)), ec)) {
    if (!allow_overwrite)
      throw Error(ExitCode::usage, fmt::format("{}: output would overwrite the input; choose another -o or pass "
                                               "--in-place (a .bak backup is kept)",
                                               path_));
    backup_ = true;
  }
  temp_ = fmt::format("{}.tmp.{}", path_, ::getpid());
  f_ = std::fopen(temp_.c_str(), "wb");
  if (f_ == nullptr)
    throw Error(ExitCode::cannot_write, fmt::format("{}: cannot create: {}", temp_, std::strerror(errno)));
}

OutputFile OutputFile::memory() { return OutputFile(MemoryTag{}); }

OutputFile::~OutputFile() {
  if (committed_ || memory_) return;
  if (stdout_ || direct_) {
    if (f_ != nullptr) std::fclose(f_);
    return;
  }
  if (f_ != nullptr) std::fclose(f_);
  std::remove(temp_.c_str());  // never leave a partial output behind
}

void OutputFile::write(std::string_view bytes) {
  if (bytes.empty()) return;
  if (memory_) {
    held_.append(bytes);
    return;
  }
  if (stdout_ && f_ == nullptr) {
    if (held_.size() + bytes.size() <= kStdoutMemory) {
      held_.append(bytes);
      return;
    }
    f_ = std::tmpfile();
    if (f_ == nullptr)
      throw Error(ExitCode::cannot_write, fmt::format("cannot create a temporary file for stdout: {}", std::strerror(errno)));
    write_all(held_);
    held_.clear();
    held_.shrink_to_fit();
  }
  write_all(bytes);
}

void OutputFile::write_all(std::string_view bytes) {
  if (std::fwrite(bytes.data(), 1, bytes.size(), f_) != bytes.size())
    throw Error(ExitCode::cannot_write, fmt::format("{}: write failed: {}", stdout_ ? "<stdout>" : direct_ ? path_ : temp_,
                                                    std::strerror(errno)));
}

void OutputFile::commit() {
  if (memory_) return;
  if (stdout_) {
    bool failed = std::fwrite(held_.data(), 1, held_.size(), stdout) != held_.size();
    if (f_ != nullptr) {
      failed = failed || std::fflush(f_) != 0 || std::fseek(f_, 0, SEEK_SET) != 0;
      char buf[1 << 16];
      std::size_t got = 0;
      while (!failed && (got = std::fread(buf, 1, sizeof buf, f_)) > 0)
        failed = std::fwrite(buf, 1, got, stdout) != got;
      failed = failed || std::ferror(f_) != 0;
      std::fclose(f_);
      f_ = nullptr;
    }
    failed = failed || std::fflush(stdout) != 0;
    committed_ = true;
    if (failed) throw Error(ExitCode::cannot_write, fmt::format("<stdout>: write failed: {}", std::strerror(errno)));
    return;
  }
  if (direct_) {
    const bool failed = std::fflush(f_) != 0;
    std::fclose(f_);
    f_ = nullptr;
    committed_ = true;
    if (failed) throw Error(ExitCode::cannot_write, fmt::format("{}: write failed: {}", path_, std::strerror(errno)));
    return;
  }
  const bool failed = std::fflush(f_) != 0 || std::ferror(f_) != 0;
  std::fclose(f_);
  f_ = nullptr;
  if (failed) throw Error(ExitCode::cannot_write, fmt::format("{}: write failed: {}", temp_, std::strerror(errno)));
  std::error_code ec;
  if (backup_) {
    fs::copy_file(path_, path_ + ".bak", fs::copy_options::overwrite_existing, ec);
    if (ec) throw Error(ExitCode::cannot_write, fmt::format("{}.bak: cannot write backup: {}", path_, ec.message()));
  }
  fs::rename(temp_, path_, ec);
  if (ec) throw Error(ExitCode::cannot_write, fmt::format("{}: cannot rename into place: {}", path_, ec.message()));
  committed_ = true;
}

}  // namespace postproc::io
