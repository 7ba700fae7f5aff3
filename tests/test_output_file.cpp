// io::OutputFile: output appears only on commit, never half-written, and never over the input.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <condition_variable>
#include <csignal>
#include <functional>
#include <mutex>
#include <thread>

#include "postproc/error.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/io/input_guard.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/io/signal_cleanup.hpp"
#include "support.hpp"

namespace {

using namespace pptest;
using postproc::Error;
using postproc::ExitCode;
using postproc::io::OutputFile;

ExitCode code_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.code();
  }
  return ExitCode::ok;
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

/// Runs `child` in a forked process; returns its wait status.
int in_child(const std::function<int()>& child) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    int rc = 99;
    try {
      rc = child();
    } catch (...) {
      rc = 98;
    }
    ::_exit(rc);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return status;
}

/// A process id that is certainly not running: a child that has exited and been reaped.
pid_t dead_pid() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  ::waitpid(pid, nullptr, 0);
  return pid;
}

std::string host() {
  char buf[256] = {};
  ::gethostname(buf, sizeof buf - 1);
  return buf;
}

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

TEST(OutputFile, TemporaryIsHiddenNamedAfterHostAndProcessAndRegistered) {
  TempDir dir;
  const std::size_t before = postproc::io::registered_temporaries();
  {
    OutputFile out(dir.file("out.nc"));
    out.write("x");
    const auto names = dir.entries();
    ASSERT_EQ(names.size(), 1u);
    EXPECT_EQ(names[0], ".out.nc.postproc-tmp." + host() + "." + std::to_string(::getpid()));
    EXPECT_EQ(postproc::io::registered_temporaries(), before + 1);
    out.commit();
    EXPECT_EQ(postproc::io::registered_temporaries(), before);
  }
  {
    OutputFile out(dir.file("other.nc"));
    EXPECT_EQ(postproc::io::registered_temporaries(), before + 1);
  }
  EXPECT_EQ(postproc::io::registered_temporaries(), before);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.nc"});
}

TEST(OutputFile, StaleTemporariesOfDeadProcessesAreRemoved) {
  TempDir dir;
  const std::string dead = ".out.nc.postproc-tmp." + host() + "." + std::to_string(dead_pid());
  const std::string alive = ".out.nc.postproc-tmp." + host() + "." + std::to_string(::getppid());
  const std::string elsewhere = ".out.nc.postproc-tmp.another-host." + std::to_string(dead_pid());
  const std::string unrelated = ".out.nc.postproc-tmp." + host() + ".notapid";
  for (const std::string& n : {dead, alive, elsewhere, unrelated}) write_file(dir.file(n), "partial");
  write_file(dir.file("out.nc"), "old");
  {
    OutputFile out(dir.file("out.nc"));
    out.write("new");
    out.commit();
  }
  EXPECT_EQ(read_file(dir.file("out.nc")), "new");
  // A live writer's, another host's (a network share) and names that are not ours stay.
  std::vector<std::string> kept{alive, elsewhere, unrelated, "out.nc"};
  std::sort(kept.begin(), kept.end());
  EXPECT_EQ(dir.entries(), kept);
}

TEST(OutputFile, NoOutputOverAnyInputOfTheRunThroughLinks) {
  TempDir dir;
  const std::string machine = dir.file("m.toml");
  write_file(machine, "[machine]\n");
  postproc::io::note_input(machine, "machine file");
  EXPECT_EQ(code_of([&] { OutputFile out(machine); }), ExitCode::ok);  // no run under way: not noted
  const postproc::io::RunInputs run;
  postproc::io::note_input(machine, "machine file");
  fs::create_symlink(machine, dir.file("link.toml"));
  fs::create_hard_link(machine, dir.file("hard.toml"));
  for (const std::string& target : {machine, dir.file("link.toml"), dir.file("hard.toml")}) {
    EXPECT_EQ(code_of([&] { OutputFile out(target); }), ExitCode::usage) << target;
    EXPECT_NE(message_of([&] { OutputFile out(target); }).find("PP-E901"), std::string::npos);
  }
  EXPECT_EQ(read_file(machine), "[machine]\n");
  // An input noted after the output was opened is caught when publishing.
  const std::string late = dir.file("late.csv");
  write_file(late, "a,b\n");
  {
    OutputFile out(late);
    out.write("overwritten");
    postproc::io::note_input(late, "measurement file");
    EXPECT_EQ(code_of([&] { out.commit(); }), ExitCode::usage);
  }
  EXPECT_EQ(read_file(late), "a,b\n");
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"hard.toml", "late.csv", "link.toml", "m.toml"}));
}

TEST(OutputFile, TwoOutputsOfOneRunNeverNameTheSameFile) {
  TempDir dir;
  {
    OutputFile a(dir.file("r.json"));
    EXPECT_EQ(code_of([&] { OutputFile b(dir.file("r.json")); }), ExitCode::usage);
    EXPECT_EQ(code_of([&] { OutputFile b((dir.path() / "." / "r.json").string()); }), ExitCode::usage);
    OutputFile out("-");
    EXPECT_NE(message_of([&] { OutputFile b("-"); }).find("PP-E902"), std::string::npos);
  }
  OutputFile again(dir.file("r.json"));  // the first one is gone
  OutputFile discard1("/dev/null"), discard2("/dev/null");  // a device takes any number
}

TEST(OutputFile, InPlaceTwiceKeepsTheFirstOriginal) {
  TempDir dir;
  const std::string in = dir.file("prog.nc");
  write_file(in, "original\n");
  for (const char* text : {"first\n", "second\n"}) {
    OutputFile out(in, in, true);
    out.write(text);
    out.commit();
    EXPECT_EQ(out.backup_kept(), std::string(text) == "second\n");
  }
  EXPECT_EQ(read_file(in), "second\n");
  EXPECT_EQ(read_file(in + ".bak"), "original\n");
}

TEST(OutputFile, FullDiskPublishesNoneOfTheOutputs) {
  TempDir dir;
  write_file(dir.file("prog.nc"), "old program");
  const int status = in_child([&] {
    std::signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{2048, 2048};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    try {
      OutputFile program(dir.file("prog.nc")), report(dir.file("report.json"));
      report.write("{}\n");                  // small: fits
      // Beyond the limit, but held in the stdio buffer: EFBIG when commit_all finishes it, after the
      // report was finished (and must still not be published).
      program.write(std::string(3000, 'G'));
      OutputFile::commit_all({&report, &program});
    } catch (const Error& e) {
      return e.code() == ExitCode::cannot_write ? 0 : 1;
    }
    return 2;
  });
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_EQ(read_file(dir.file("prog.nc")), "old program");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"prog.nc"});  // no report, no temporaries
}

TEST(OutputFile, SignalsRemoveEveryTemporaryOfEveryThread) {
  for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) {
    TempDir dir;
    int ready[2];
    ASSERT_EQ(::pipe(ready), 0);
    const pid_t pid = ::fork();
    if (pid == 0) {
      postproc::io::install_signal_cleanup();
      std::mutex m;
      std::condition_variable cv;
      int open = 0;
      std::vector<std::thread> threads;
      for (int t = 0; t < 4; ++t)
        threads.emplace_back([&, t] {
          OutputFile out(dir.file("out" + std::to_string(t) + ".nc"));
          out.write("partial");
          std::unique_lock<std::mutex> g(m);
          ++open;
          cv.notify_all();
          cv.wait(g, [] { return false; });  // held open until the signal ends the process
        });
      {
        std::unique_lock<std::mutex> g(m);
        cv.wait(g, [&] { return open == 4; });
      }
      const char c = 'r';
      (void)!::write(ready[1], &c, 1);
      for (;;) ::pause();
    }
    ::close(ready[1]);
    char c = 0;
    ASSERT_EQ(::read(ready[0], &c, 1), 1);
    ::close(ready[0]);
    EXPECT_EQ(dir.entries().size(), 4u);  // the four temporaries exist
    ::kill(pid, sig);
    int status = 0;
    ::waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << sig;
    EXPECT_EQ(WTERMSIG(status), sig);  // the conventional status: killed by that signal
    EXPECT_TRUE(dir.entries().empty()) << sig;
  }
}

TEST(InputFile, FoldersAndDevicesAreNoInputButPipesAre) {
  TempDir dir;
  fs::create_directory(dir.file("d.nc"));
  EXPECT_EQ(code_of([&] { (void)postproc::io::read_file(dir.file("d.nc"), "NC program"); }), ExitCode::no_input);
  EXPECT_NE(message_of([&] { postproc::io::check_input_kind(dir.file("d.nc"), "machine file"); })
                .find("PP-E903 the machine file is a folder"),
            std::string::npos);
  EXPECT_EQ(code_of([&] { postproc::io::check_input_kind("/dev/null", "NC program"); }), ExitCode::no_input);
  EXPECT_EQ(code_of([&] { gc::LineReader r(dir.file("d.nc")); }), ExitCode::no_input);
  ASSERT_EQ(::mkfifo(dir.file("fifo").c_str(), 0600), 0);
  EXPECT_EQ(code_of([&] { postproc::io::check_input_kind(dir.file("fifo"), "NC program"); }), ExitCode::ok);
  EXPECT_EQ(code_of([&] { postproc::io::check_input_kind("-", "NC program"); }), ExitCode::ok);
}

}  // namespace
