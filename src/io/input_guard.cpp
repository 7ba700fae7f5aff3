// The inputs of this run by file identity (see input_guard.hpp).
#include "postproc/io/input_guard.hpp"

#include <sys/stat.h>

#include <map>
#include <mutex>
#include <utility>

#include <fmt/format.h>

namespace postproc::io {
namespace {

using Identity = std::pair<dev_t, ino_t>;

struct Noted {
  std::string path, what;
};

std::mutex g_lock;
std::map<Identity, Noted> g_inputs;
int g_runs = 0;

bool identity(const std::string& path, Identity& id) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return false;
  id = {st.st_dev, st.st_ino};
  return true;
}

}  // namespace

RunInputs::RunInputs() {
  const std::lock_guard<std::mutex> g(g_lock);
  ++g_runs;
}

RunInputs::~RunInputs() {
  const std::lock_guard<std::mutex> g(g_lock);
  if (--g_runs == 0) g_inputs.clear();
}

void note_input(const std::string& path, std::string_view what) {
  Identity id;
  if (path.empty() || path == "-" || !identity(path, id)) return;
  const std::lock_guard<std::mutex> g(g_lock);
  if (g_runs > 0) g_inputs.insert_or_assign(id, Noted{path, std::string(what)});
}

std::string input_at(const std::string& path) {
  Identity id;
  if (path.empty() || path == "-" || !identity(path, id)) return {};
  const std::lock_guard<std::mutex> g(g_lock);
  const auto it = g_inputs.find(id);
  if (it == g_inputs.end()) return {};
  Identity still;
  // The inode may have been reused by a new file since the input was read and removed.
  if (!identity(it->second.path, still) || still != id) return {};
  return fmt::format("{} {}", it->second.what, it->second.path);
}

}  // namespace postproc::io
