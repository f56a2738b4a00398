// The cdt command as a user runs it: its four files written all or none, its inputs never overwritten,
// bad input named with the reason.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "../test_util.hpp"

namespace {

namespace fs = std::filesystem;
using trixel_test::read_all;
using trixel_test::run;
using trixel_test::ScratchDir;
using trixel_test::shell_quote;

const std::string kBin = TRIXEL_CDT_BIN;

void write_text(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

std::string cdt_command(const fs::path& input, const fs::path& prefix, const std::string& more = "") {
  return shell_quote(kBin) + " " + shell_quote(input) + " -o " + shell_quote(prefix) + more;
}

/// The files in dir, by name.
std::string listing(const fs::path& dir) {
  std::string names;
  for (const auto& entry : fs::directory_iterator(dir)) names += entry.path().filename().string() + " ";
  return names;
}

// A unit square with one diagonal as a segment, in the edge-list format.
const std::string kSquare = "4 1\n0 0\n1 0\n1 1\n0 1\n0 2\n";

TEST(CdtCli, WritesTheFourFilesAndVerifies) {
  ScratchDir dir;
  write_text(dir / "square.txt", kSquare);
  const auto r = run(cdt_command(dir / "square.txt", dir / "out", " --verify"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("verified"), std::string::npos) << r.output;
  for (const char* ext : {".node", ".ele", ".neigh", ".edge"})
    EXPECT_TRUE(fs::is_regular_file(dir / ("out" + std::string(ext)))) << ext << ": " << listing(dir.path());
  EXPECT_EQ(read_all(dir / "out.ele").substr(0, 6), "2 3 0\n");
  EXPECT_EQ(listing(dir.path()).find(".part"), std::string::npos) << listing(dir.path());
}

// The last file cannot be written (a directory holds its name): none of the four is left, and the
// error names it.
TEST(CdtCli, AnOutputThatCannotBeWrittenLeavesNoneOfTheFiles) {
  ScratchDir dir;
  write_text(dir / "square.txt", kSquare);
  fs::create_directory(dir / "out.edge");
  const auto r = run(cdt_command(dir / "square.txt", dir / "out"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("out.edge"), std::string::npos) << r.output;
  for (const char* ext : {".node", ".ele", ".neigh"})
    EXPECT_FALSE(fs::exists(dir / ("out" + std::string(ext)))) << ext << ": " << listing(dir.path());
  EXPECT_EQ(listing(dir.path()).find(".part"), std::string::npos) << listing(dir.path());
}

// An output prefix naming the input, or the .node a .poly of no vertices reads, is refused before
// anything is written.
TEST(CdtCli, NeverOverwritesItsInput) {
  ScratchDir dir;
  const std::string node = "4 2 0 0\n1 0 0\n2 1 0\n3 1 1\n4 0 1\n";
  write_text(dir / "box.node", node);
  write_text(dir / "box.poly", "0 2 0 0\n2 0\n1 1 3\n2 2 4\n0\n");
  const auto from_poly = run(cdt_command(dir / "box.poly", dir / "box"));
  EXPECT_EQ(from_poly.exit_code, 2) << from_poly.output;
  EXPECT_NE(from_poly.output.find("box.node"), std::string::npos) << from_poly.output;
  const auto from_node = run(cdt_command(dir / "box.node", dir / "box"));
  EXPECT_EQ(from_node.exit_code, 2) << from_node.output;
  EXPECT_NE(from_node.output.find("is the input file"), std::string::npos) << from_node.output;
  EXPECT_EQ(read_all(dir / "box.node"), node);
  EXPECT_FALSE(fs::exists(dir / "box.ele")) << listing(dir.path());
  // Elsewhere the same .poly triangulates, its vertices read from box.node.
  const auto elsewhere = run(cdt_command(dir / "box.poly", dir / "out", " --verify"));
  EXPECT_EQ(elsewhere.exit_code, 0) << elsewhere.output;
}

// Coordinates whose products would underflow are an error naming the file, the point and the reason.
TEST(CdtCli, ATinyCoordinateIsAnErrorNamingThePoint) {
  ScratchDir dir;
  write_text(dir / "tiny.txt", "3 0\n0 0\n1e-300 0\n0 1e-300\n");
  const auto r = run(cdt_command(dir / "tiny.txt", dir / "out"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("tiny.txt"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("point 1"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("underflow"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "out.node")) << listing(dir.path());
}

} // namespace
