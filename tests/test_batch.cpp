// postproc batch (issue 7): walking, globs, shards, manifests and merge; a run on a small job
// folder with -j 1 and -j 4 giving identical bytes.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <set>

#include "postproc/batch/batch.hpp"
#include "postproc/error.hpp"
#include "postproc/io/input_file.hpp"

namespace fs = std::filesystem;
using namespace postproc;

namespace {

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("postproc_batch_" + std::to_string(::getpid()) + "_" +
                                        std::to_string(std::random_device{}()));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

void write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

const fs::path kSamples = fs::path(POSTPROC_SOURCE_DIR) / "samples";

}  // namespace

TEST(Batch, ParseShard) {
  EXPECT_EQ(batch::parse_shard("1/1").index, 1u);
  const auto s = batch::parse_shard("3/8");
  EXPECT_EQ(s.index, 3u);
  EXPECT_EQ(s.count, 8u);
  for (const char* bad : {"0/3", "4/3", "3", "/3", "3/", "a/b", "1/0", "1/3x", "-1/3", ""})
    EXPECT_THROW((void)batch::parse_shard(bad), Error) << bad;
}

TEST(Batch, ShardsCoverEveryFileExactlyOnce) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    const std::size_t n = rng() % 50;
    const auto count = static_cast<unsigned>(1 + rng() % 9);
    std::vector<std::string> files;
    for (std::size_t i = 0; i < n; ++i) files.push_back("f" + std::to_string(1000 + i) + ".nc");
    std::multiset<std::string> seen;
    std::size_t largest = 0, smallest = n + 1;
    for (unsigned k = 1; k <= count; ++k) {
      const auto part = batch::shard_files(files, {k, count});
      seen.insert(part.begin(), part.end());
      largest = std::max(largest, part.size());
      smallest = std::min(smallest, part.size());
    }
    EXPECT_EQ(seen, std::multiset<std::string>(files.begin(), files.end()));
    EXPECT_LE(largest - smallest, 1u) << "shards are balanced by count";
  }
}

TEST(Batch, ListProgramsWalksSortedWithGlobs) {
  TempDir t;
  write(t.path / "b.nc", "M30\n");
  write(t.path / "A.NC", "M30\n");
  write(t.path / "sub/c.ngc", "M30\n");
  write(t.path / "sub/deep/d.MPF", "M30\n");
  write(t.path / "sub/notes.txt", "x\n");
  write(t.path / ".hidden/e.nc", "M30\n");
  write(t.path / "out/f.nc", "M30\n");
  fs::create_symlink(t.path / "missing.nc", t.path / "sub/dangling.nc");
  fs::create_directory_symlink(t.path / "sub", t.path / "loop");
  const auto all = batch::list_programs(t.path, {}, t.path / "out");
  EXPECT_EQ(all, (std::vector<std::string>{"A.NC", "b.nc", "sub/c.ngc", "sub/dangling.nc", "sub/deep/d.MPF"}));
  EXPECT_EQ(batch::list_programs(t.path, {"*.ngc"}, {}), std::vector<std::string>{"sub/c.ngc"});
  // A glob with '/' matches the relative path; '*' does not cross folders.
  EXPECT_EQ(batch::list_programs(t.path, {"sub/*.nc"}, {}), std::vector<std::string>{"sub/dangling.nc"});
  EXPECT_EQ(batch::list_programs(t.path, {"sub/*/*"}, {}), std::vector<std::string>{"sub/deep/d.MPF"});
}

TEST(Batch, RunIsIdenticalForAnyJobCountAndSkipsOnRerun) {
  TempDir t;
  const std::string prog = io::read_file((kSamples / "programs/impeller_axes_bc.nc").string(), "program");
  for (int i = 0; i < 6; ++i) write(t.path / "jobs" / ("d" + std::to_string(i % 3)) / ("p" + std::to_string(i) + ".nc"), prog);
  write(t.path / "jobs/bad.nc", "G1 X1..2\n");
  batch::BatchOptions o;
  o.job_dir = t.path / "jobs";
  o.machine = (kSamples / "machines/trunnion_bc_fanuc.toml").string();
  o.compensate.tool_version = "test";
  std::vector<std::vector<std::string>> outputs;
  for (unsigned jobs : {1u, 4u}) {
    o.out_dir = t.path / ("out" + std::to_string(jobs));
    o.jobs = jobs;
    std::size_t calls = 0;
    const auto r = batch::run_batch(o, [&](const batch::FileResult&, std::size_t done, std::size_t total) {
      ++calls;
      EXPECT_EQ(done, calls);
      EXPECT_EQ(total, 7u);
    });
    EXPECT_EQ(calls, 7u);
    EXPECT_EQ(r.count("written"), 6u);
    EXPECT_EQ(r.count("refused"), 1u);
    EXPECT_FALSE(r.ok());
    ASSERT_EQ(r.files.size(), 7u);
    EXPECT_EQ(r.files[0].path, "bad.nc");  // sorted order whatever finished first
    std::vector<std::string> bytes;
    for (const auto& f : r.files)
      if (f.status == "written") bytes.push_back(io::read_file((o.out_dir / f.path).string(), "output"));
    outputs.push_back(bytes);
    EXPECT_TRUE(fs::exists(o.out_dir / batch::kManifestName));
  }
  EXPECT_EQ(outputs[0], outputs[1]);
  // Re-run: the six are carried over; a changed setting redoes them.
  o.out_dir = t.path / "out4";
  auto again = batch::run_batch(o);
  EXPECT_EQ(again.count("unchanged"), 6u);
  o.compensate.max_deviation_mm = 0.002;
  again = batch::run_batch(o);
  EXPECT_EQ(again.count("written"), 6u);
}

TEST(Batch, MergeRefusesManifestsThatDoNotBelongTogether) {
  auto shard = [](unsigned k, unsigned n, std::vector<std::string> files, std::string settings = "mode=geometric") {
    nlohmann::json j = {{"manifest", "postproc batch"}, {"tool", {{"version", "1"}}}, {"settings", settings},
                        {"job_dir", "jobs"}, {"total_files", 3}, {"shard", {{"index", k}, {"count", n}}}};
    j["files"] = nlohmann::json::array();
    for (const auto& f : files) j["files"].push_back({{"path", f}, {"status", "written"}, {"bytes", 10}});
    j["summary"] = {{"seconds", 1.5 * k}};
    return j;
  };
  const auto ok = batch::merge_manifests({shard(2, 2, {"b.nc"}), shard(1, 2, {"c.nc", "a.nc"})}, {"s2", "s1"});
  EXPECT_TRUE(ok["complete"].get<bool>());
  EXPECT_EQ(ok["files"].size(), 3u);
  EXPECT_EQ(ok["files"][0]["path"], "a.nc");
  EXPECT_EQ(ok["summary"]["written"], 3);
  EXPECT_EQ(ok["summary"]["bytes"], 30);
  const auto partial = batch::merge_manifests({shard(1, 3, {"a.nc"})}, {"s1"});
  EXPECT_FALSE(partial["complete"].get<bool>());
  EXPECT_EQ(partial["missing_shards"], nlohmann::json({2, 3}));
  auto refused = [&](std::vector<nlohmann::json> v, const std::string& why) {
    std::vector<std::string> names;
    for (std::size_t i = 0; i < v.size(); ++i) names.push_back("m" + std::to_string(i));
    try {
      (void)batch::merge_manifests(v, names);
      ADD_FAILURE() << "accepted: " << why;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ExitCode::refused);
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  refused({shard(1, 2, {"a.nc"}), shard(1, 2, {"b.nc"})}, "given twice");
  refused({shard(1, 2, {"a.nc"}), shard(2, 2, {"a.nc"})}, "is in both");
  refused({shard(1, 2, {"a.nc"}), shard(2, 3, {"b.nc"})}, "shards");
  refused({shard(1, 2, {"a.nc"}), shard(2, 2, {"b.nc"}, "mode=contour")}, "settings");
  refused({nlohmann::json{{"x", 1}}}, "not a postproc batch manifest");
}

TEST(Batch, BadFoldersAreUsageErrors) {
  TempDir t;
  batch::BatchOptions o;
  o.job_dir = t.path / "none";
  o.out_dir = t.path / "out";
  EXPECT_THROW((void)batch::run_batch(o), Error);
  fs::create_directories(t.path / "jobs/sub");
  o.job_dir = t.path / "jobs";
  o.out_dir = t.path / "jobs";
  EXPECT_THROW((void)batch::run_batch(o), Error);
  o.job_dir = t.path / "jobs/sub";
  EXPECT_THROW((void)batch::run_batch(o), Error);
}

TEST(Batch, MissingMachineFailsTheFileNotTheBatch) {
  TempDir t;
  write(t.path / "jobs/a.nc", "G0 X0\nM30\n");
  write(t.path / "jobs/m/machine.toml", "this is not toml [\n");
  write(t.path / "jobs/m/b.nc", "G0 X0\nM30\n");
  batch::BatchOptions o;
  o.job_dir = t.path / "jobs";
  o.out_dir = t.path / "out";
  const auto r = batch::run_batch(o);
  ASSERT_EQ(r.files.size(), 2u);
  EXPECT_EQ(r.files[0].status, "failed");
  EXPECT_NE(r.files[0].reason.find("no machine file"), std::string::npos) << r.files[0].reason;
  EXPECT_EQ(r.files[1].status, "failed");
  EXPECT_NE(r.files[1].reason.find("m/machine.toml refused"), std::string::npos) << r.files[1].reason;
  EXPECT_FALSE(r.files[1].diagnostics.empty());
}

// Programs with parameters and control flow (issue 3): written back into their own lines when
// that is exact, refused with the line otherwise, flattened with --flatten; the manifest says how.
TEST(Batch, ResolvedProgramsAreWrittenBackOrRefused) {
  TempDir t;
  write(t.path / "jobs/literal.ngc",
        "G21 G90 G94 G18 G8\nG54\n#<_cut_feed> = 300\nG0 X60. Z10. B0. C0.\nG1 X45. Z2. F#<_cut_feed>\n"
        "o100 if [#<_cut_feed> GT 100]\n  G1 X47.5 Z-5. B-4. C40.\no100 endif\nM30\n");
  write(t.path / "jobs/computed.ngc",
        "G21 G90 G94 G18 G8\nG54\n#<r> = 45\nG0 X60. Z10. B0. C0.\nG1 X[#<r> + 1] Z2. F300.\nM30\n");
  batch::BatchOptions o;
  o.job_dir = t.path / "jobs";
  o.out_dir = t.path / "out";
  o.machine = (kSamples / "machines/lathe_xzbc_doc004.toml").string();
  o.compensate.tool_version = "test";
  auto r = batch::run_batch(o);
  ASSERT_EQ(r.files.size(), 2u);
  const batch::FileResult& computed = r.files[0];
  const batch::FileResult& literal = r.files[1];
  EXPECT_EQ(computed.status, "refused");
  EXPECT_NE(computed.reason.find("PP-E711"), std::string::npos) << computed.reason;
  EXPECT_NE(computed.reason.find(":5:"), std::string::npos) << computed.reason;
  EXPECT_FALSE(fs::exists(o.out_dir / "computed.ngc"));
  ASSERT_EQ(literal.status, "written") << literal.reason;
  EXPECT_EQ(literal.figures["resolution"]["written"], "in place");
  EXPECT_EQ(literal.figures["resolution"]["source_lines_rewritten"], 3);
  const std::string out = io::read_file((o.out_dir / "literal.ngc").string(), "output");
  EXPECT_NE(out.find("\n#<_cut_feed> = 300\n"), std::string::npos);
  EXPECT_NE(out.find(" F#<_cut_feed>\n"), std::string::npos);
  // --flatten: both written as literal moves.
  o.compensate.flatten = true;
  o.out_dir = t.path / "flat";
  r = batch::run_batch(o);
  EXPECT_EQ(r.count("written"), 2u);
  EXPECT_EQ(r.files[0].figures["resolution"]["written"], "flattened");
  EXPECT_EQ(io::read_file((o.out_dir / "computed.ngc").string(), "output").find('#'), std::string::npos);
}

// A program that calls a subprogram file: the manifest records the file and its hash, and a re-run
// redoes the program when the subprogram changed (its output depends on it). The subprogram is
// found in a folder given like --subprogram-dir.
TEST(Batch, SubprogramFilesDecideReruns) {
  TempDir t;
  write(t.path / "jobs/part.nc",
        "%\nO1000\nG21 G90 G17 G54\nG43 H1\nG0 X0. Y0. Z50. A0. C0.\nM98 P9010\nG0 Z50.\nM30\n%\n");
  const fs::path lib = t.path / "lib";
  write(lib / "O9010", "O9010\nG1 X10. Y20. Z5. A10. C30. F500.\nM99\n");
  batch::BatchOptions o;
  o.job_dir = t.path / "jobs";
  o.out_dir = t.path / "out";
  o.machine = (kSamples / "machines/trunnion_ac_fanuc.toml").string();
  o.compensate.tool_version = "test";
  o.compensate.flatten = true;  // the subprogram's move needs a correction: written as literal moves
  o.compensate.resolve.search_dirs = {lib.string()};
  auto r = batch::run_batch(o);
  ASSERT_EQ(r.files.size(), 1u);
  ASSERT_EQ(r.files[0].status, "written") << r.files[0].reason;
  ASSERT_EQ(r.files[0].subprograms.size(), 1u);
  EXPECT_EQ(fs::path(r.files[0].subprograms[0].first).filename(), "O9010");
  const std::string first = io::read_file((o.out_dir / "part.nc").string(), "output");
  EXPECT_NE(first.find("X10."), std::string::npos);
  r = batch::run_batch(o);
  EXPECT_EQ(r.files[0].status, "unchanged");
  EXPECT_EQ(r.files[0].subprograms.size(), 1u);
  write(lib / "O9010", "O9010\nG1 X12. Y20. Z5. A10. C30. F500.\nM99\n");
  r = batch::run_batch(o);
  EXPECT_EQ(r.files[0].status, "written");
  EXPECT_NE(io::read_file((o.out_dir / "part.nc").string(), "output"), first);
  // Without --flatten the move in the subprogram file cannot be written back: refused, naming it.
  o.compensate.flatten = false;
  o.out_dir = t.path / "in_place";
  r = batch::run_batch(o);
  EXPECT_EQ(r.files[0].status, "refused");
  EXPECT_NE(r.files[0].reason.find("O9010"), std::string::npos) << r.files[0].reason;
}
