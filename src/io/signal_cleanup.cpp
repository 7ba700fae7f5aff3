// Temporaries removed on SIGINT/SIGTERM/SIGHUP/SIGPIPE (see signal_cleanup.hpp).
#include "postproc/io/signal_cleanup.hpp"

#include <climits>
#include <csignal>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <atomic>
#include <mutex>

#include <fmt/format.h>
#include <unistd.h>

#include "postproc/error.hpp"

namespace postproc::io {
namespace {

// Slot states. The handler reads a path only in state `ready`; a path is written only in a
// "creating" section, which the handler waits out after setting `g_dying`, so it never reads a
// path that is being written.
enum : int { kFree = 0, kClaimed = 1, kReady = 2 };

struct Slot {
  std::atomic<int> state{kFree};
  char path[PATH_MAX];
};

Slot g_slots[kMaxTemporaries];
std::atomic<int> g_creating{0};
std::atomic<int> g_dying{0};
std::once_flag g_installed;
constexpr int kSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGPIPE};

static_assert(std::atomic<int>::is_always_lock_free, "the signal handler needs lock-free atomics");

extern "C" void remove_temporaries_and_die(int sig) {
  g_dying.store(1);
  // Another thread may be between registering and creating its temporary: give it up to a
  // second (it stops before creating anything once it sees g_dying).
  for (int i = 0; i < 1000 && g_creating.load() != 0; ++i) {
    const timespec ms{0, 1000000};
    ::nanosleep(&ms, nullptr);
  }
  for (Slot& s : g_slots)
    if (s.state.load() == kReady) ::unlink(s.path);
  // SA_RESETHAND restored the default action: the re-raised signal ends the process when this
  // handler returns, with the status a shell shows as 128 + sig.
  ::raise(sig);
}

/// Entered before a path is written into a slot; never returns once the process is being stopped.
void enter_creating() {
  g_creating.fetch_add(1);
  if (g_dying.load() != 0) {
    g_creating.fetch_sub(1);
    for (;;) ::pause();  // the handler is removing the temporaries and ending the process
  }
}

}  // namespace

void install_signal_cleanup() {
  std::call_once(g_installed, [] {
    for (const int sig : kSignals) {
      struct sigaction old {};
      if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;  // e.g. nohup
      struct sigaction sa {};
      sa.sa_handler = remove_temporaries_and_die;
      sigemptyset(&sa.sa_mask);
      for (const int other : kSignals) sigaddset(&sa.sa_mask, other);  // one cleanup at a time
      sa.sa_flags = SA_RESETHAND;
      ::sigaction(sig, &sa, nullptr);
    }
    std::signal(SIGXFSZ, SIG_IGN);
  });
}

TemporaryRegistration::TemporaryRegistration(const std::string& path) {
  std::error_code ec;
  std::string abs = std::filesystem::absolute(path, ec).string();
  if (ec) abs = path;
  if (abs.size() >= PATH_MAX)
    throw Error(ExitCode::cannot_write, fmt::format("{}: path too long for a temporary file", path));
  enter_creating();
  creating_ = true;
  for (int i = 0; i < static_cast<int>(kMaxTemporaries); ++i) {
    int expected = kFree;
    if (!g_slots[i].state.compare_exchange_strong(expected, kClaimed)) continue;
    std::memcpy(g_slots[i].path, abs.c_str(), abs.size() + 1);
    g_slots[i].state.store(kReady);
    slot_ = i;
    return;
  }
  created();
  throw Error(ExitCode::cannot_write,
              fmt::format("{}: more than {} outputs open at once; use fewer jobs", path, kMaxTemporaries));
}

TemporaryRegistration& TemporaryRegistration::operator=(TemporaryRegistration&& o) noexcept {
  if (this != &o) {
    release();
    slot_ = o.slot_;
    creating_ = o.creating_;
    o.slot_ = -1;
    o.creating_ = false;
  }
  return *this;
}

void TemporaryRegistration::created() {
  if (creating_) g_creating.fetch_sub(1);
  creating_ = false;
}

void TemporaryRegistration::release() {
  created();
  if (slot_ >= 0) g_slots[slot_].state.store(kFree);
  slot_ = -1;
}

std::size_t registered_temporaries() {
  std::size_t n = 0;
  for (const Slot& s : g_slots) n += s.state.load() == kReady ? 1 : 0;
  return n;
}

}  // namespace postproc::io
