// The vectorize program as a user runs it: exit codes, messages naming the file, no stray output.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "../test_util.hpp"

namespace {

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

// Every bundled sample decodes; until the conversion stages exist the program must say so and write
// no placeholder file.
TEST(VectorizeCli, SamplesDecodeAndNothingFakeIsWritten) {
  ScratchDir dir;
  int seen = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kSamples)) {
    if (entry.path().extension() != ".png") continue;
    ++seen;
    const auto out = dir / (entry.path().stem().string() + ".svg");
    const auto r = run(shell_quote(kBin) + " " + shell_quote(entry.path()) + " " + shell_quote(out));
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find("not implemented"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
  EXPECT_GE(seen, 4);
}

} // namespace
