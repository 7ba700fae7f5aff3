#include "postproc/io/output_file.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <set>
#include <system_error>

#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/io/input_guard.hpp"

namespace postproc::io {
namespace fs = std::filesystem;
namespace {

constexpr std::string_view kTempMarker = ".postproc-tmp.";

const std::string& host_name() {
  static const std::string name = [] {
    char buf[256] = {};
    if (::gethostname(buf, sizeof buf - 1) != 0 || buf[0] == '\0') return std::string("localhost");
    std::string s(buf);
    std::replace(s.begin(), s.end(), '/', '_');
    return s;
  }();
  return name;
}

/// `.NAME.postproc-tmp.HOST.PID` beside `target`: hidden, so folder scans (batch) skip it, and
/// naming its host and process, so a later run can tell a dead writer's leftover from a live one.
std::string temp_name(const fs::path& target) {
  std::string name = target.filename().string();
  if (name.size() > 120) name.resize(120);  // room for the suffix within NAME_MAX
  return (target.parent_path() / fmt::format(".{}{}{}.{}", name, kTempMarker, host_name(), ::getpid())).string();
}

/// Removes the temporaries in `dir` that runs on this host left when they were killed (kill -9,
/// out of memory): those whose process no longer exists. Once per folder and process.
void remove_stale_temporaries(const fs::path& dir) {
  static std::mutex lock;
  static std::set<std::string> done;
  std::error_code ec;
  const std::string key = fs::absolute(dir.empty() ? fs::path(".") : dir, ec).lexically_normal().string();
  {
    const std::lock_guard<std::mutex> g(lock);
    if (!done.insert(key).second) return;
  }
  const std::string suffix_host = fmt::format("{}{}.", kTempMarker, host_name());
  for (fs::directory_iterator it(dir.empty() ? fs::path(".") : dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.empty() || name[0] != '.') continue;
    const auto at = name.rfind(suffix_host);
    if (at == std::string::npos) continue;
    const std::string_view pid_text = std::string_view(name).substr(at + suffix_host.size());
    long pid = 0;
    const auto [end_ptr, err] = std::from_chars(pid_text.data(), pid_text.data() + pid_text.size(), pid);
    if (err != std::errc() || end_ptr != pid_text.data() + pid_text.size() || pid <= 0 || pid == ::getpid()) continue;
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // alive (or not ours to judge)
    std::error_code rm;
    fs::remove(it->path(), rm);
  }
}

/// The outputs open in this process, by target, so two outputs of one run never name one file.
std::mutex g_open_lock;
std::set<std::string> g_open;

std::string target_key(const std::string& path) {
  if (path == "-") return path;
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) p = fs::absolute(path, ec).lexically_normal();
  return p.string();
}

}  // namespace

OutputFile::OutputFile(std::string path, std::string_view input_path, bool allow_overwrite) : path_(std::move(path)) {
  std::error_code dev_ec;
  // A character device (/dev/null) may take several outputs: nothing there is replaced.
  if (!fs::is_character_file(path_, dev_ec)) {
    const std::string key = target_key(path_);
    const std::lock_guard<std::mutex> g(g_open_lock);
    if (!g_open.insert(key).second)
      throw Error(ExitCode::usage, fmt::format("{}: PP-E902 two outputs of this run name the same file; give each "
                                               "output (-o, --report, --json, --html, --csv …) its own file",
                                               path_ == "-" ? "<stdout>" : path_));
    key_ = key;
  }
  try {
    if (path_ == "-") {
      // Standard output gets the same guarantee as a file: the bytes are held back and written on
      // commit, so a refused program writes nothing. Up to kStdoutMemory in memory, beyond that in
      // an anonymous temporary file, so memory stays bounded whatever the size.
      stdout_ = true;
      return;
    }
    std::error_code ec;
    if (!input_path.empty() && input_path != "-" && fs::exists(path_, ec) &&
        fs::equivalent(fs::path(path_), fs::path(std::string(input_path)), ec)) {
      if (!allow_overwrite)
        throw Error(ExitCode::usage, fmt::format("{}: PP-E901 output would overwrite the input; choose another -o or "
                                                 "pass --in-place (a .bak backup is kept)",
                                                 path_));
      backup_ = true;
    }
    refuse_if_input();
    // Devices and pipes (/dev/null, a FIFO) are written directly: renaming over them would replace
    // the device with a regular file.
    if (fs::exists(path_, ec) && !fs::is_regular_file(path_, ec)) {
      if (fs::is_directory(path_, ec))
        throw Error(ExitCode::cannot_write,
                    fmt::format("{}: cannot write: it is a folder; name a file inside it", path_));
      f_ = std::fopen(path_.c_str(), "wb");
      if (f_ == nullptr)
        throw Error(ExitCode::cannot_write, fmt::format("{}: cannot open for writing: {}", path_, std::strerror(errno)));
      direct_ = true;
      return;
    }
    remove_stale_temporaries(fs::path(path_).parent_path());
    temp_ = temp_name(fs::path(path_));
    registration_ = TemporaryRegistration(temp_);  // before the file exists: a signal never misses it
    f_ = std::fopen(temp_.c_str(), "wb");
    const int err = errno;
    registration_.created();
    if (f_ == nullptr) {
      registration_.release();
      throw Error(ExitCode::cannot_write, fmt::format("{}: cannot create: {}", temp_, std::strerror(err)));
    }
  } catch (...) {
    const std::lock_guard<std::mutex> g(g_open_lock);
    g_open.erase(key_);
    throw;
  }
}

OutputFile OutputFile::memory() { return OutputFile(MemoryTag{}); }

OutputFile::~OutputFile() {
  if (memory_) return;
  if (!key_.empty()) {
    const std::lock_guard<std::mutex> g(g_open_lock);
    g_open.erase(key_);
  }
  if (f_ != nullptr) std::fclose(f_);
  if (committed_ || stdout_ || direct_) return;
  std::remove(temp_.c_str());  // never leave a partial output behind
  registration_.release();
}

void OutputFile::refuse_if_input() const {
  if (backup_) return;  // the one input this output was allowed to replace
  const std::string input = input_at(path_);
  if (!input.empty())
    throw Error(ExitCode::usage, fmt::format("{}: PP-E901 output would overwrite an input of this run (the {}); "
                                             "choose another file name",
                                             path_, input));
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

void OutputFile::finish() {
  if (memory_ || finished_ || committed_) return;
  finished_ = true;
  if (stdout_) {
    if (f_ != nullptr && std::fflush(f_) != 0)
      throw Error(ExitCode::cannot_write, fmt::format("<stdout>: write failed: {}", std::strerror(errno)));
    return;
  }
  const char* shown = direct_ ? path_.c_str() : temp_.c_str();
  bool failed = std::fflush(f_) != 0 || std::ferror(f_) != 0;
  int err = errno;
  // The bytes reach the disk before the rename, so a crash leaves the old file or the new one.
  if (!failed && !direct_ && ::fsync(::fileno(f_)) != 0 && errno != EINVAL) {
    failed = true;
    err = errno;
  }
  if (std::fclose(f_) != 0 && !failed) {
    failed = true;
    err = errno;
  }
  f_ = nullptr;
  if (direct_) committed_ = true;
  if (failed) throw Error(ExitCode::cannot_write, fmt::format("{}: write failed: {}", shown, std::strerror(err)));
}

void OutputFile::make_backup() {
  const std::string bak = path_ + ".bak";
  std::error_code ec;
  if (fs::exists(fs::symlink_status(bak, ec))) {
    backup_kept_ = true;  // an earlier run's backup holds the first original: never replaced
    return;
  }
  if (::link(path_.c_str(), bak.c_str()) == 0) return;  // the original's own bytes, atomically
  if (errno == EEXIST) {
    backup_kept_ = true;
    return;
  }
  // File systems without hard links: a copy, written beside and renamed, so a .bak is never partial.
  const std::string temp = temp_name(fs::path(bak));
  TemporaryRegistration reg(temp);
  fs::copy_file(path_, temp, fs::copy_options::overwrite_existing, ec);
  reg.created();
  if (!ec) fs::rename(temp, bak, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temp, ignored);
    throw Error(ExitCode::cannot_write, fmt::format("{}: cannot write backup: {}", bak, ec.message()));
  }
}

void OutputFile::publish() {
  if (memory_ || committed_) return;
  if (!finished_) finish();
  if (committed_) return;
  if (stdout_) {
    committed_ = true;
    bool failed = std::fwrite(held_.data(), 1, held_.size(), stdout) != held_.size();
    if (f_ != nullptr) {
      failed = failed || std::fseek(f_, 0, SEEK_SET) != 0;
      char buf[1 << 16];
      std::size_t got = 0;
      while (!failed && (got = std::fread(buf, 1, sizeof buf, f_)) > 0)
        failed = std::fwrite(buf, 1, got, stdout) != got;
      failed = failed || std::ferror(f_) != 0;
      std::fclose(f_);
      f_ = nullptr;
    }
    failed = failed || std::fflush(stdout) != 0;
    if (failed) throw Error(ExitCode::cannot_write, fmt::format("<stdout>: write failed: {}", std::strerror(errno)));
    return;
  }
  refuse_if_input();  // an input read after this output was opened (a subprogram, a table)
  if (backup_) make_backup();
  std::error_code ec;
  fs::rename(temp_, path_, ec);
  if (ec) throw Error(ExitCode::cannot_write, fmt::format("{}: cannot rename into place: {}", path_, ec.message()));
  committed_ = true;
  registration_.release();
}

void OutputFile::commit() {
  finish();
  publish();
}

void OutputFile::commit_all(const std::vector<OutputFile*>& outputs) {
  for (OutputFile* o : outputs)
    if (o != nullptr) o->finish();
  // Standard output first: if the reader has gone (SIGPIPE), the files are not published either.
  for (OutputFile* o : outputs)
    if (o != nullptr && o->stdout_) o->publish();
  for (OutputFile* o : outputs)
    if (o != nullptr) o->publish();
}

}  // namespace postproc::io
