// LineReader: exact end-of-line bytes from memory and from files, for every chunk size.
#include <gtest/gtest.h>

#include "postproc/error.hpp"
#include "support.hpp"

namespace {

using namespace pptest;

struct Line {
  std::string raw, eol;
  bool operator==(const Line&) const = default;
};
std::ostream& operator<<(std::ostream& os, const Line& l) {
  return os << ::testing::PrintToString(l.raw) << "+" << ::testing::PrintToString(l.eol);
}

std::vector<Line> read_all(gc::LineReader& r, std::uint64_t* bytes = nullptr) {
  std::vector<Line> out;
  std::string_view line, eol;
  while (r.next(line, eol)) {
    out.push_back({std::string(line), std::string(eol)});
    EXPECT_EQ(r.line_number(), out.size());
  }
  if (bytes) *bytes = r.bytes_read();
  return out;
}

std::vector<Line> from_memory(std::string_view text, std::uint64_t* bytes = nullptr) {
  gc::LineReader r(text);
  return read_all(r, bytes);
}

std::vector<Line> from_file(const std::string& text, std::size_t chunk, std::uint64_t* bytes = nullptr) {
  TempDir dir;
  const std::string path = dir.file("in.nc");
  write_file(path, text);
  gc::LineReader r(path, chunk);
  return read_all(r, bytes);
}

using Lines = std::vector<Line>;

TEST(LineReader, EndOfLineKinds) {
  EXPECT_EQ(from_memory("A\nB\n"), (Lines{{"A", "\n"}, {"B", "\n"}}));
  EXPECT_EQ(from_memory("A\r\nB\r\n"), (Lines{{"A", "\r\n"}, {"B", "\r\n"}}));
  EXPECT_EQ(from_memory("A\rB\r"), (Lines{{"A", "\r"}, {"B", "\r"}}));
  EXPECT_EQ(from_memory("A\nB"), (Lines{{"A", "\n"}, {"B", ""}}));
  EXPECT_EQ(from_memory("\n\n"), (Lines{{"", "\n"}, {"", "\n"}}));
  EXPECT_EQ(from_memory("A\n\r\nB"), (Lines{{"A", "\n"}, {"", "\r\n"}, {"B", ""}}));
  // "\n\r" is two line ends, not one.
  EXPECT_EQ(from_memory("A\n\rB"), (Lines{{"A", "\n"}, {"", "\r"}, {"B", ""}}));
  EXPECT_EQ(from_memory("A\r\r\n"), (Lines{{"A", "\r"}, {"", "\r\n"}}));
  EXPECT_TRUE(from_memory("").empty());
}

TEST(LineReader, MixedEndingsCountBytes) {
  const std::string text = "G0 X1\r\nG1 X2\n\rG2 X3\rlast";
  std::uint64_t bytes = 0;
  const Lines lines = from_memory(text, &bytes);
  EXPECT_EQ(bytes, text.size());
  EXPECT_EQ(lines, (Lines{{"G0 X1", "\r\n"}, {"G1 X2", "\n"}, {"", "\r"}, {"G2 X3", "\r"}, {"last", ""}}));
}

TEST(LineReader, FileMatchesMemoryForEveryChunkSize) {
  const std::vector<std::string> texts = {
      "A\nB\n", "A\r\nB\r\n", "A\rB", "A\nB", "\n\n", "", "x", "\r\n", "\r\r\n\n",
      "G0 X1\r\nG1 X2\n\rG2 X3\rlast", "N1\r\nN2\r\nN3\r\nN4\r\n", std::string(40, 'A') + "\r\n" + std::string(3, 'B'),
  };
  for (const auto& t : texts) {
    const Lines expected = from_memory(t);
    for (std::size_t chunk : {1u, 2u, 3u, 4u, 5u, 7u, 16u, 1u << 20}) {
      std::uint64_t bytes = 0;
      EXPECT_EQ(from_file(t, chunk, &bytes), expected) << "chunk " << chunk << " text " << ::testing::PrintToString(t);
      EXPECT_EQ(bytes, t.size());
    }
  }
}

TEST(LineReader, LineLongerThanTheChunk) {
  const std::string longline(10000, 'X');
  const std::string text = "G0\n" + longline + "\r\nG1 X1\n";
  const Lines lines = from_file(text, 8);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0], (Line{"G0", "\n"}));
  EXPECT_EQ(lines[1].raw.size(), longline.size());
  EXPECT_EQ(lines[1], (Line{longline, "\r\n"}));
  EXPECT_EQ(lines[2], (Line{"G1 X1", "\n"}));
}

TEST(LineReader, FileEndingInLoneCr) {
  // Old Mac line ends: the last line's '\r' must be its EOL, as the memory reader does.
  for (const std::string& text : std::vector<std::string>{"A\rB\r", "\r", "G0 X1\rG1 X2\r", "G0\n" + std::string(100, 'Y') + "\r"}) {
    const Lines expected = from_memory(text);
    ASSERT_EQ(expected.back().eol, "\r");
    for (std::size_t chunk : {1u, 3u, 8u, 1u << 20}) {
      const Lines got = from_file(text, chunk);
      EXPECT_EQ(got, expected) << "chunk " << chunk;
    }
  }
}

TEST(LineReader, CrLfSplitAcrossChunks) {
  // With a chunk of 4 bytes the "\r\n" of "ABC\r\n" straddles the first refill.
  for (std::size_t chunk = 1; chunk <= 6; ++chunk)
    EXPECT_EQ(from_file("ABC\r\nDEF\r\n", chunk), (Lines{{"ABC", "\r\n"}, {"DEF", "\r\n"}})) << chunk;
}

TEST(LineReader, MissingFileThrowsNoInput) {
  try {
    gc::LineReader r(std::string("/nonexistent/dir/none.nc"));
    FAIL() << "no exception";
  } catch (const postproc::Error& e) {
    EXPECT_EQ(e.code(), postproc::ExitCode::no_input);
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/none.nc"), std::string::npos);
  }
}

TEST(LineReader, ZeroChunkStillReadsTheFile) {
  // Nothing documents a minimum chunk; a chunk of 0 must not silently read an empty file.
  TempDir dir;
  write_file(dir.file("a.nc"), "G0 X1\n");
  gc::LineReader r(dir.file("a.nc"), 0);
  const Lines lines = read_all(r);
  EXPECT_EQ(lines, (Lines{{"G0 X1", "\n"}}));
}

TEST(LineReader, ViewsStayValidUntilNextCall) {
  const std::string text = "AAAA\nBBBB\nCCCC";
  TempDir dir;
  write_file(dir.file("a.nc"), text);
  gc::LineReader r(dir.file("a.nc"), 2);
  std::string_view line, eol;
  std::string joined;
  while (r.next(line, eol)) {
    joined.append(line);
    joined.append(eol);
  }
  EXPECT_EQ(joined, text);
  EXPECT_FALSE(r.next(line, eol));  // stays at end
}

}  // namespace

namespace {
// rewind() starts again at line 1 with the same lines and byte counts (memory and files, any
// chunk size, also after a partial read); a stream that cannot be read twice says so.
TEST(LineReader, RewindReadsTheSameLinesAgain) {
  const std::string text = "G0 X1\r\nG1 X2\n\rG2 X3\rlast";
  const Lines expected = from_memory(text);
  gc::LineReader m{std::string_view(text)};
  std::string_view line, eol;
  ASSERT_TRUE(m.next(line, eol));
  ASSERT_TRUE(m.rewind());
  EXPECT_EQ(m.line_number(), 0u);
  EXPECT_EQ(read_all(m), expected);
  TempDir dir;
  const std::string path = dir.file("in.nc");
  write_file(path, text);
  for (std::size_t chunk : {1u, 3u, 1u << 20}) {
    gc::LineReader f(path, chunk);
    std::uint64_t bytes = 0;
    EXPECT_EQ(read_all(f, &bytes), expected);
    ASSERT_TRUE(f.rewind());
    EXPECT_EQ(read_all(f, &bytes), expected) << "chunk " << chunk;
    EXPECT_EQ(bytes, text.size());
  }
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  ASSERT_EQ(::write(fds[1], "G0\n", 3), 3);
  ::close(fds[1]);
  gc::LineReader p("/dev/fd/" + std::to_string(fds[0]));
  ASSERT_TRUE(p.next(line, eol));
  EXPECT_FALSE(p.rewind());
  ::close(fds[0]);
}
}  // namespace
