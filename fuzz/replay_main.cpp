// postproc_fuzz_replay: runs LLVMFuzzerTestOneInput on saved inputs without libFuzzer, so the
// test suite can replay fuzz/corpus and fuzz/crashes with any compiler.
//
//   postproc_fuzz_replay DIR_OR_FILE...
//
// Directories are read recursively in sorted order (for reproducible logs); hidden files and
// README* files are skipped. A broken invariant traps (the process dies), so exit status 0 means
// every input passed.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

namespace fs = std::filesystem;

bool skipped(const fs::path& p) {
  const std::string name = p.filename().string();
  return name.empty() || name.front() == '.' || name.rfind("README", 0) == 0;
}

/// Every input file named by `arg`, sorted.
std::vector<fs::path> inputs(const fs::path& arg) {
  std::vector<fs::path> files;
  if (fs::is_directory(arg)) {
    for (const auto& e : fs::recursive_directory_iterator(arg))
      if (e.is_regular_file() && !skipped(e.path())) files.push_back(e.path());
    std::sort(files.begin(), files.end());
  } else {
    files.push_back(arg);
  }
  return files;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s DIR_OR_FILE...\n", argv[0]);
    return 64;
  }
  std::size_t count = 0;
  for (int i = 1; i < argc; ++i) {
    const fs::path arg(argv[i]);
    if (!fs::exists(arg)) {
      std::fprintf(stderr, "postproc_fuzz_replay: %s: no such file or directory\n", argv[i]);
      return 66;
    }
    for (const fs::path& p : inputs(arg)) {
      std::ifstream in(p, std::ios::binary);
      if (!in) {
        std::fprintf(stderr, "postproc_fuzz_replay: %s: cannot read\n", p.string().c_str());
        return 66;
      }
      const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      // Named before running: if the input traps, the log says which one it was.
      std::fprintf(stderr, "replay %s (%zu bytes)\n", p.string().c_str(), bytes.size());
      LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
      ++count;
    }
  }
  std::fprintf(stderr, "postproc_fuzz_replay: %zu inputs passed\n", count);
  return 0;
}
