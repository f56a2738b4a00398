// The vectorize program as a user runs it: exit codes, messages naming the file, no stray output.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

#include "../test_util.hpp"

namespace {

using trixel_test::read_all;
using trixel_test::run;
using trixel_test::ScratchDir;
using trixel_test::shell_quote;

const std::string kBin = TRIXEL_VECTORIZE_BIN;
const std::filesystem::path kSamples = std::filesystem::path(TRIXEL_SOURCE_DIR) / "samples";

TEST(VectorizeCli, HelpTeachesUsageAndExits0) {
  const auto r = run(shell_quote(kBin) + " --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.output.find("Examples:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("OUT"), std::string::npos);
}

TEST(VectorizeCli, VersionExits0) {
  const auto r = run(shell_quote(kBin) + " --version");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.output.find("vectorize "), std::string::npos);
}

// A build with mimalloc must really allocate through it (every library's malloc bound to it), and
// one without names the C library's.
TEST(VectorizeCli, VersionNamesTheAllocatorInUse) {
  const auto r = run(shell_quote(kBin) + " --version");
  ASSERT_EQ(r.exit_code, 0);
#if TRIXEL_TEST_MIMALLOC
  EXPECT_NE(r.output.find("(allocator: mimalloc 2."), std::string::npos) << r.output;
#else
  EXPECT_NE(r.output.find("(allocator: the C library's)"), std::string::npos) << r.output;
#endif
}

TEST(VectorizeCli, MissingArgumentsAreUsageErrors) {
  EXPECT_EQ(run(shell_quote(kBin)).exit_code, 2);
  EXPECT_EQ(run(shell_quote(kBin) + " only-one.png").exit_code, 2);
  EXPECT_EQ(run(shell_quote(kBin) + " a.png b.svg --no-such-option").exit_code, 2);
}

TEST(VectorizeCli, MissingInputNamesTheFile) {
  ScratchDir dir;
  const auto r =
      run(shell_quote(kBin) + " " + shell_quote(dir / "absent.png") + " " + shell_quote(dir / "out.svg"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("absent.png"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no such file"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "out.svg"));
}

// Overwriting the input would destroy the user's data.
TEST(VectorizeCli, RefusesOutputEqualToInput) {
  ScratchDir dir;
  std::filesystem::copy_file(kSamples / "logo.png", dir / "logo.png");
  const auto size = std::filesystem::file_size(dir / "logo.png");
  const auto r = run(shell_quote(kBin) + " " + shell_quote(dir / "logo.png") + " " +
                     shell_quote(dir / "." / "logo.png"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("refusing"), std::string::npos) << r.output;
  EXPECT_EQ(std::filesystem::file_size(dir / "logo.png"), size);
}

TEST(VectorizeCli, MissingOutputDirectoryIsReported) {
  ScratchDir dir;
  const auto r = run(shell_quote(kBin) + " " + shell_quote(kSamples / "logo.png") + " " +
                     shell_quote(dir / "no" / "out.svg"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("does not exist"), std::string::npos) << r.output;
}

TEST(VectorizeCli, CorruptInputNamesTheFile) {
  ScratchDir dir;
  std::ofstream(dir / "bad.png") << "not a png";
  const auto r =
      run(shell_quote(kBin) + " " + shell_quote(dir / "bad.png") + " " + shell_quote(dir / "out.svg"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("bad.png"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "out.svg"));
}

// Every bundled sample converts, with each preset, into a complete SVG document and nothing else in
// the output folder (no temporary file left behind).
TEST(VectorizeCli, SamplesConvertToCompleteSvg) {
  ScratchDir dir;
  int seen = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kSamples)) {
    if (entry.path().extension() != ".png") continue;
    ++seen;
    for (const char* preset : {"logo", "illustration", "photo"}) {
      const auto out = dir / (entry.path().stem().string() + "-" + preset + ".svg");
      const auto r = run(shell_quote(kBin) + " " + shell_quote(entry.path()) + " " + shell_quote(out) +
                         " --preset " + preset);
      EXPECT_EQ(r.exit_code, 0) << entry.path() << " " << preset << ": " << r.output;
      const std::string svg = read_all(out);
      EXPECT_EQ(svg.rfind("<svg", 0) == 0 || svg.rfind("<?xml", 0) == 0, true) << out;
      EXPECT_NE(svg.find("viewBox=\"0 0 "), std::string::npos) << out;
      EXPECT_NE(svg.find("<path"), std::string::npos) << out;
      EXPECT_NE(svg.find("</svg>"), std::string::npos) << out;
    }
  }
  EXPECT_GE(seen, 4);
  int files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 3 * seen);
}

TEST(VectorizeCli, StatsAsJsonNameEveryStage) {
  ScratchDir dir;
  const auto r = run(shell_quote(kBin) + " " + shell_quote(kSamples / "logo.png") + " " +
                     shell_quote(dir / "logo.svg") + " --stats json -q");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  for (const char* key :
       {"\"edges\"", "\"cdt\"", "\"grouping\"", "\"svg\"", "\"triangles\"", "\"paths\"", "\"bytes\""}) {
    EXPECT_NE(r.output.find(key), std::string::npos) << key << " in " << r.output;
  }
}

TEST(VectorizeCli, BadOptionValuesAreUsageErrors) {
  ScratchDir dir;
  const std::string base =
      shell_quote(kBin) + " " + shell_quote(kSamples / "logo.png") + " " + shell_quote(dir / "x.svg");
  EXPECT_EQ(run(base + " --preset poster").exit_code, 2);
  EXPECT_EQ(run(base + " --colour-tolerance -1").exit_code, 2);
  EXPECT_EQ(run(base + " --backend tpu").exit_code, 2);
  EXPECT_EQ(run(base + " --stats xml").exit_code, 2);
  EXPECT_FALSE(std::filesystem::exists(dir / "x.svg"));
}

// An existing output is replaced whole, never appended to or left half-written.
TEST(VectorizeCli, ExistingOutputIsReplaced) {
  ScratchDir dir;
  std::ofstream(dir / "out.svg") << "old content that is not an svg";
  const auto r = run(shell_quote(kBin) + " " + shell_quote(kSamples / "logo.png") + " " +
                     shell_quote(dir / "out.svg") + " --preset logo");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read_all(dir / "out.svg").find("old content"), std::string::npos);
}

// A device or a pipe as the output is written into, never replaced by a file (as root, a rename over
// /dev/null replaced the device). Here a pipe, read by cat.
TEST(VectorizeCli, APipeAsTheOutputIsWrittenIntoAndKept) {
  ScratchDir dir;
  const std::filesystem::path fifo = dir / "pipe.svg";
  ASSERT_EQ(run("mkfifo " + shell_quote(fifo)).exit_code, 0);
  // The reader gives up after a while: with a rename over the pipe it would wait for a writer forever.
  const auto r = run("timeout 20 cat " + shell_quote(fifo) + " > " + shell_quote(dir / "copy.svg") + " & " +
                     shell_quote(kBin) + " " + shell_quote(kSamples / "logo.png") + " " + shell_quote(fifo) +
                     " --preset logo; status=$?; wait; exit $status");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));
  EXPECT_NE(read_all(dir / "copy.svg").find("</svg>"), std::string::npos);
}

// A report that would replace an input or an output of the batch is refused before any image.
TEST(VectorizeCli, AReportOverAnInputOrAnOutputIsRefused) {
  ScratchDir dir;
  std::filesystem::copy_file(kSamples / "logo.png", dir / "logo.png");
  const std::string batch = shell_quote(kBin) + " " + shell_quote(dir / "logo.png") + " -o " +
                            shell_quote(dir / "out") + " --report ";
  const auto over_input = run(batch + shell_quote(dir / "logo.png"));
  EXPECT_EQ(over_input.exit_code, 2) << over_input.output;
  EXPECT_NE(over_input.output.find("is an input"), std::string::npos) << over_input.output;
  const auto over_output = run(batch + shell_quote(dir / "out" / "logo.svg"));
  EXPECT_EQ(over_output.exit_code, 2) << over_output.output;
  EXPECT_NE(over_output.output.find("is an output"), std::string::npos) << over_output.output;
  EXPECT_EQ(read_all(dir / "logo.png"), read_all(kSamples / "logo.png"));
  EXPECT_FALSE(std::filesystem::exists(dir / "out" / "logo.svg"));
}

// NaN compares false with both ends of a range: it is refused as not a number.
TEST(VectorizeCli, NotANumberIsAUsageError) {
  ScratchDir dir;
  const std::string base =
      shell_quote(kBin) + " " + shell_quote(kSamples / "logo.png") + " " + shell_quote(dir / "x.svg");
  for (const char* option : {"--min-area", "--colour-tolerance", "--simplify", "--blur", "--seam-width"}) {
    const auto r = run(base + " " + option + " nan");
    EXPECT_EQ(r.exit_code, 2) << option << ": " << r.output;
    EXPECT_NE(r.output.find("not a number"), std::string::npos) << option << ": " << r.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "x.svg"));
}

} // namespace
