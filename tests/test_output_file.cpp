// io::OutputFile: output appears only on commit, never half-written, and never over the input.
#include <gtest/gtest.h>

#include "postproc/error.hpp"
#include "postproc/io/output_file.hpp"
#include "support.hpp"

namespace {

using namespace pptest;
using postproc::Error;
using postproc::ExitCode;
using postproc::io::OutputFile;

TEST(OutputFile, CommitRenamesIntoPlace) {
  TempDir dir;
  const std::string path = dir.file("out.nc");
  {
    OutputFile out(path);
    out.write("G0 X1\r\n");
    out.write("");
    out.write("G1 X2");
    EXPECT_FALSE(fs::exists(path));  // nothing visible before commit
    EXPECT_EQ(dir.entries().size(), 1u);  // only the temporary file
    out.commit();
    EXPECT_EQ(out.path(), path);
  }
  EXPECT_EQ(read_file(path), "G0 X1\r\nG1 X2");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.nc"});
}

TEST(OutputFile, NoCommitLeavesNothingAndKeepsTheOldFile) {
  TempDir dir;
  const std::string path = dir.file("out.nc");
  { OutputFile out(path); out.write("partial"); }
  EXPECT_TRUE(dir.entries().empty());
  write_file(path, "old");
  { OutputFile out(path); out.write("new"); }
  EXPECT_EQ(read_file(path), "old");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.nc"});
  {
    OutputFile out(path);
    out.write("new");
    out.commit();
  }
  EXPECT_EQ(read_file(path), "new");
}

TEST(OutputFile, RefusesToOverwriteTheInput) {
  TempDir dir;
  const std::string in = dir.file("prog.nc");
  write_file(in, "G0 X1\n");
  for (const std::string& spelled : {in, (dir.path() / "." / "prog.nc").string(),
                                     (dir.path() / "sub" / ".." / "prog.nc").string()}) {
    fs::create_directories(dir.path() / "sub");
    try {
      OutputFile out(spelled, in);
      FAIL() << "no exception for " << spelled;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ExitCode::usage);
      EXPECT_NE(std::string(e.what()).find("would overwrite the input"), std::string::npos);
    }
    fs::remove(dir.path() / "sub");
  }
  EXPECT_EQ(read_file(in), "G0 X1\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"prog.nc"});
}

TEST(OutputFile, OverwriteWhenAllowedKeepsBackup) {
  TempDir dir;
  const std::string in = dir.file("prog.nc");
  write_file(in, "G0 X1\n");
  {
    OutputFile out(in, in, true);
    out.write("G0 X2\n");
    EXPECT_EQ(read_file(in), "G0 X1\n");
    out.commit();
  }
  EXPECT_EQ(read_file(in), "G0 X2\n");
  EXPECT_EQ(read_file(in + ".bak"), "G0 X1\n");
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"prog.nc", "prog.nc.bak"}));
}

TEST(OutputFile, DifferentFileNextToInputIsFine) {
  TempDir dir;
  const std::string in = dir.file("prog.nc");
  write_file(in, "G0 X1\n");
  OutputFile out(dir.file("prog.out.nc"), in);
  out.write("x");
  out.commit();
  EXPECT_EQ(read_file(dir.file("prog.out.nc")), "x");
  EXPECT_FALSE(fs::exists(in + ".bak"));
}

TEST(OutputFile, CannotCreateIsExit73) {
  try {
    OutputFile out("/nonexistent-dir-postproc/out.nc");
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::cannot_write);
  }
}

TEST(OutputFile, DashWritesToStdout) {
  ::testing::internal::CaptureStdout();
  {
    OutputFile out("-", "-");
    out.write("G0 X1\n");
    out.commit();
  }
  EXPECT_EQ(::testing::internal::GetCapturedStdout(), "G0 X1\n");
}

}  // namespace
