#pragma once
/// @file
/// Removal of temporary outputs when the process is stopped by a signal (SIGINT, SIGTERM, SIGHUP,
/// SIGPIPE). The paths live in a fixed table of pre-formatted C strings, so the handler only calls
/// unlink(), which is async-signal-safe; it then re-raises the signal with its default action, so
/// the process ends with the conventional status (128 + signal number in a shell).

#include <cstddef>
#include <string>

namespace postproc::io {

/// Installs the handlers (once; a signal the parent set to "ignore" stays ignored) and ignores
/// SIGXFSZ, so that a file-size limit (`ulimit -f`) makes writes fail with EFBIG, which the outputs
/// report (exit 73), instead of killing the process with the temporaries in place.
void install_signal_cleanup();

/// Most temporaries that can be registered at once (a batch holds one per worker).
inline constexpr std::size_t kMaxTemporaries = 256;

/// A registered temporary: `path` is removed by the handler while the registration lasts.
class TemporaryRegistration {
 public:
  TemporaryRegistration() = default;
  /// Registers the absolute form of `path` before the file is created; call created() once it
  /// exists. Until then a signal handler waits (up to a second) for the creation, so no file being
  /// created by another thread escapes it. Throws postproc::Error (cannot_write) when the table is
  /// full or the path is longer than PATH_MAX.
  explicit TemporaryRegistration(const std::string& path);
  ~TemporaryRegistration() { release(); }
  TemporaryRegistration(TemporaryRegistration&& o) noexcept : slot_(o.slot_), creating_(o.creating_) {
    o.slot_ = -1;
    o.creating_ = false;
  }
  TemporaryRegistration& operator=(TemporaryRegistration&& o) noexcept;
  TemporaryRegistration(const TemporaryRegistration&) = delete;
  TemporaryRegistration& operator=(const TemporaryRegistration&) = delete;
  /// The file exists (or its creation failed): the handler no longer waits for it.
  void created();
  /// Ends the registration (after the temporary was renamed into place or removed).
  void release();

 private:
  int slot_ = -1;
  bool creating_ = false;
};

/// Number of temporaries registered now (for tests).
[[nodiscard]] std::size_t registered_temporaries();

}  // namespace postproc::io
