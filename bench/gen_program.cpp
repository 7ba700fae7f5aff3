// postproc_gen_program: writes the deterministic 5-axis benchmark program to a file.
//
//   postproc_gen_program --blocks N --out FILE [--seed S] [--dialect fanuc|linuxcnc]
//
// The program is streamed in 1 MiB chunks so that an 18M-block (1 GB) file needs no more memory
// than a small one.

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>

#include <CLI/CLI.hpp>

#include "program_generator.hpp"

namespace {

/// Writes `data` completely or reports why not.
bool write_all(std::FILE* f, const std::string& data) {
  return std::fwrite(data.data(), 1, data.size(), f) == data.size();
}

}  // namespace

int main(int argc, char** argv) {
  using postproc::bench::GenDialect;
  postproc::bench::GeneratorOptions opt;
  std::string out_path;

  CLI::App app{"Writes a deterministic, realistic simultaneous 5-axis NC program for benchmarks"};
  app.add_option("--blocks", opt.blocks, "number of body blocks (about 56 bytes each)")->required();
  app.add_option("--out", out_path, "output file ('-' for stdout)")->required();
  app.add_option("--seed", opt.seed, "path and arc variation (default 1)");
  const std::map<std::string, GenDialect> dialects{{"fanuc", GenDialect::fanuc},
                                                   {"linuxcnc", GenDialect::linuxcnc}};
  app.add_option("--dialect", opt.dialect, "fanuc (with O number) or linuxcnc (for rs274)")
      ->transform(CLI::CheckedTransformer(dialects, CLI::ignore_case));
  CLI11_PARSE(app, argc, argv);

  std::FILE* f = out_path == "-" ? stdout : std::fopen(out_path.c_str(), "wb");
  if (f == nullptr) {
    std::fprintf(stderr, "postproc_gen_program: cannot open %s: %s\n", out_path.c_str(), std::strerror(errno));
    return 73;
  }

  postproc::bench::ProgramGenerator gen(opt);
  std::string chunk;
  constexpr std::size_t kChunk = std::size_t{1} << 20;
  chunk.reserve(kChunk + 4096);
  std::uint64_t bytes = 0;
  bool ok = true;
  auto flush = [&] {
    ok = ok && write_all(f, chunk);
    bytes += chunk.size();
    chunk.clear();
  };

  gen.header(chunk);
  for (std::uint64_t i = 0; i < opt.blocks && ok; ++i) {
    gen.append_block(chunk);
    if (chunk.size() >= kChunk) flush();
  }
  gen.footer(chunk);
  flush();
  if (f != stdout) ok = std::fclose(f) == 0 && ok;
  else ok = std::fflush(f) == 0 && ok;
  if (!ok) {
    std::fprintf(stderr, "postproc_gen_program: cannot write %s: %s\n", out_path.c_str(), std::strerror(errno));
    return 73;
  }
  std::fprintf(stderr, "postproc_gen_program: %llu blocks, %llu bytes (%.1f bytes/block) -> %s\n",
               static_cast<unsigned long long>(opt.blocks), static_cast<unsigned long long>(bytes),
               opt.blocks ? static_cast<double>(bytes) / static_cast<double>(opt.blocks) : 0.0,
               out_path.c_str());
  return 0;
}
