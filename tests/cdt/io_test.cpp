#include "cdt/io.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "../test_util.hpp"

#ifndef TRIXEL_TEST_DATA_DIR
#error "TRIXEL_TEST_DATA_DIR must name the tests/data folder"
#endif

namespace {

namespace fs = std::filesystem;
using cdt::kNone;
using cdt::Point;
using cdt::Segment;
using cdt::Triangulation;
using cdt::io::Pslg;

// Passes when f throws a FileError for `path` at `line` whose what() is "<path>:<line>: ..." and
// contains `needle`; an assertion result so failures are reported at the calling line.
::testing::AssertionResult throws_file_error(const std::function<void()>& f, const fs::path& path,
                                             std::uint64_t line, const std::string& needle) {
  try {
    f();
  } catch (const cdt::FileError& e) {
    const std::string what = e.what();
    const std::string prefix = path.string() + ":" + std::to_string(line) + ": ";
    if (e.path() != path.string())
      return ::testing::AssertionFailure()
             << "path " << e.path() << ", expected " << path << " (" << what << ")";
    if (e.line() != line)
      return ::testing::AssertionFailure()
             << "line " << e.line() << ", expected " << line << " (" << what << ")";
    if (what.rfind(prefix, 0) != 0)
      return ::testing::AssertionFailure()
             << "what() \"" << what << "\" does not start with \"" << prefix << "\"";
    if (what.find(needle) == std::string::npos)
      return ::testing::AssertionFailure()
             << "what() \"" << what << "\" does not contain \"" << needle << "\"";
    return ::testing::AssertionSuccess();
  } catch (const std::exception& e) {
    return ::testing::AssertionFailure() << "threw something other than FileError: " << e.what();
  }
  return ::testing::AssertionFailure() << "did not throw";
}

bool same_bits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

// Coordinates whose shortest decimal form is long or unusual, so a lossy writer would show.
std::vector<Point> awkward_points() {
  return {
      {0.1, 1.0 / 3.0},
      {-0.0, 0.0},
      {std::numeric_limits<double>::denorm_min(), -std::numeric_limits<double>::min()},
      {std::numeric_limits<double>::max(), -std::numeric_limits<double>::max()},
      {123456789.123456789, -2.2250738585072014e-308},
      {1e300, 5e-300},
      {std::nextafter(1.0, 2.0), std::nextafter(1.0, 0.0)},
  };
}

void expect_same_points(const std::vector<Point>& got, const std::vector<Point>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_TRUE(same_bits(got[i].x, want[i].x)) << i << ": " << got[i].x << " vs " << want[i].x;
    EXPECT_TRUE(same_bits(got[i].y, want[i].y)) << i << ": " << got[i].y << " vs " << want[i].y;
  }
}

// The unit square split along its diagonal 0-2: triangle 0 = (0, 1, 2), triangle 1 = (0, 2, 3).
Triangulation square(bool diagonal_is_constraint) {
  Triangulation t;
  t.vertices = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  t.triangles = {{0, 1, 2}, {0, 2, 3}};
  t.neighbors = {{kNone, 1, kNone}, {kNone, kNone, 0}};
  const std::uint32_t diagonal = diagonal_is_constraint ? 0 : kNone;
  t.segment_of_edge = {{kNone, diagonal, kNone}, {kNone, kNone, diagonal}};
  t.duplicate_of = {0, 1, 2, 3};
  return t;
}

class Io : public ::testing::Test {
protected:
  // Writes `text` verbatim to `name` in the scratch directory.
  fs::path write(const std::string& name, const std::string& text) const {
    const fs::path path = dir_ / name;
    std::ofstream out(path, std::ios::binary);
    out << text;
    return path;
  }

  static std::string contents(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }

  // Writes `text` to `name` and checks that read_pslg (format by extension) rejects it as described.
  ::testing::AssertionResult rejects(const std::string& name, const std::string& text, std::uint64_t line,
                                     const std::string& needle) const {
    const fs::path path = write(name, text);
    return throws_file_error([&] { cdt::io::read_pslg(path); }, path, line, needle);
  }

  trixel_test::ScratchDir dir_;
};

// ---- round trips --------------------------------------------------------------------------------

TEST_F(Io, RoundTripsNodeBitForBitZeroBased) {
  const auto points = awkward_points();
  const fs::path path = dir_ / "a.node";
  cdt::io::write_node(path, points, 0);
  const Pslg read = cdt::io::read_node(path);
  EXPECT_EQ(read.first_index, 0u);
  expect_same_points(read.points, points);
  EXPECT_TRUE(read.segments.empty());
}

TEST_F(Io, RoundTripsNodeBitForBitOneBased) {
  const auto points = awkward_points();
  const fs::path path = dir_ / "a.node";
  cdt::io::write_node(path, points, 1);
  EXPECT_EQ(contents(path).rfind("7 2 0 0\n1 0.1 ", 0), 0u) << contents(path);
  const Pslg read = cdt::io::read_node(path);
  EXPECT_EQ(read.first_index, 1u);
  expect_same_points(read.points, points);
}

TEST_F(Io, RoundTripsPolyInBothBases) {
  for (const unsigned base : {0u, 1u}) {
    SCOPED_TRACE(base);
    Pslg pslg;
    pslg.points = awkward_points();
    pslg.segments = {{0, 1}, {1, 2}, {6, 0}, {3, 5}};
    pslg.holes = {{0.25, -0.75}, {1e-310, 7.0}};
    pslg.first_index = base;
    const fs::path path = dir_ / "a.poly";
    cdt::io::write_poly(path, pslg);
    const Pslg read = cdt::io::read_poly(path);
    EXPECT_EQ(read.first_index, base);
    expect_same_points(read.points, pslg.points);
    EXPECT_EQ(read.segments, pslg.segments);
    expect_same_points(read.holes, pslg.holes);
  }
}

TEST_F(Io, RoundTripsEleInBothBases) {
  const Triangulation t = square(false);
  for (const unsigned base : {0u, 1u}) {
    SCOPED_TRACE(base);
    const fs::path path = dir_ / "a.ele";
    cdt::io::write_ele(path, t, base);
    EXPECT_EQ(cdt::io::read_ele(path, base), t.triangles);
  }
  EXPECT_EQ(contents(dir_ / "a.ele"), "2 3 0\n1 1 2 3\n2 1 3 4\n");
}

TEST_F(Io, WritesNeighWithMinusOneForNoNeighbour) {
  const fs::path path = dir_ / "a.neigh";
  cdt::io::write_neigh(path, square(false), 1);
  EXPECT_EQ(contents(path), "2 3\n1 -1 2 -1\n2 -1 -1 1\n");
  cdt::io::write_neigh(path, square(false), 0);
  EXPECT_EQ(contents(path), "2 3\n0 -1 1 -1\n1 -1 -1 0\n");
}

TEST_F(Io, WritesEachEdgeOnceWithHullAndConstraintMarkers) {
  const fs::path path = dir_ / "a.edge";
  cdt::io::write_edge(path, square(false), 0);
  // The diagonal 2-0 is interior and unconstrained: marker 0; the four hull edges: marker 1.
  EXPECT_EQ(contents(path), "5 1\n0 1 2 1\n1 2 0 0\n2 0 1 1\n3 2 3 1\n4 3 0 1\n");
  cdt::io::write_edge(path, square(true), 1);
  EXPECT_EQ(contents(path), "5 1\n1 2 3 1\n2 3 1 1\n3 1 2 1\n4 3 4 1\n5 4 1 1\n");
}

// segment_of_edge may be left empty by callers that have no constraints.
TEST_F(Io, WritesEdgesWithoutSegmentInformation) {
  Triangulation t = square(true);
  t.segment_of_edge.clear();
  const fs::path path = dir_ / "a.edge";
  cdt::io::write_edge(path, t, 0);
  EXPECT_EQ(contents(path), "5 1\n0 1 2 1\n1 2 0 0\n2 0 1 1\n3 2 3 1\n4 3 0 1\n");
}

TEST_F(Io, WriteReplacesAnExistingFileAndLeavesNoTemporary) {
  const fs::path path = write("a.node", "stale contents that are longer than the new file\n");
  cdt::io::write_node(path, std::vector<Point>{{1, 2}}, 0);
  EXPECT_EQ(contents(path), "1 2 0 0\n0 1 2\n");
  EXPECT_FALSE(fs::exists(dir_ / "a.node.tmp"));
}

TEST_F(Io, WriteIntoMissingDirectoryFails) {
  const fs::path path = dir_ / "no-such-dir" / "a.node";
  EXPECT_TRUE(throws_file_error(
      [&] {
        cdt::io::write_node(path, std::vector<Point>{{1, 2}}, 0);
      },
      path, 0, "No such file or directory"));
}

// Here the temporary is created, so this checks the cleanup after a late failure (the rename).
TEST_F(Io, FailedRenameRemovesTheTemporary) {
  const fs::path path = dir_ / "occupied.node";
  fs::create_directory(path);
  fs::create_directory(path / "keep-me-non-empty");
  EXPECT_TRUE(throws_file_error(
      [&] {
        cdt::io::write_node(path, std::vector<Point>{{1, 2}}, 0);
      },
      path, 0, "cannot rename"));
  EXPECT_FALSE(fs::exists(dir_ / "occupied.node.tmp"));
  EXPECT_TRUE(fs::is_directory(path));
}

// Writers refuse data they would otherwise turn into a file no reader accepts.
TEST_F(Io, WritersRejectInvalidData) {
  const fs::path node = dir_ / "a.node";
  EXPECT_TRUE(throws_file_error(
      [&] {
        cdt::io::write_node(node, std::vector<Point>{{1, 2}}, 2);
      },
      node, 0, "first_index must be 0 or 1"));
  const std::vector<Point> nan_point = {{0, std::numeric_limits<double>::quiet_NaN()}};
  EXPECT_TRUE(throws_file_error([&] { cdt::io::write_node(node, nan_point, 0); }, node, 0, "non-finite"));
  EXPECT_FALSE(fs::exists(node));

  Pslg pslg;
  pslg.points = {{0, 0}, {1, 0}};
  pslg.segments = {{0, 2}};
  const fs::path poly = dir_ / "a.poly";
  EXPECT_TRUE(throws_file_error([&] { cdt::io::write_poly(poly, pslg); }, poly, 0, "segment 0"));

  Triangulation t = square(false);
  t.neighbors.pop_back();
  const fs::path neigh = dir_ / "a.neigh";
  EXPECT_TRUE(throws_file_error([&] { cdt::io::write_neigh(neigh, t, 0); }, neigh, 0, "neighbour entries"));
  t = square(false);
  t.triangles[1][2] = 4;
  const fs::path ele = dir_ / "a.ele";
  EXPECT_TRUE(throws_file_error([&] { cdt::io::write_ele(ele, t, 0); }, ele, 0, "vertex 4"));
}

// ---- reading valid files --------------------------------------------------------------------------

TEST_F(Io, ReadsOneBasedNode) {
  const Pslg pslg = cdt::io::read_node(write("a.node", "3 2 2 1\n"
                                                       "1 0.5 1.5 7 8 1\n"
                                                       "2 -2 3e2 0 0 0\n"
                                                       "3 4 5 1.5 -inf -3\n"));
  EXPECT_EQ(pslg.first_index, 1u);
  EXPECT_EQ(pslg.points, (std::vector<Point>{{0.5, 1.5}, {-2, 300}, {4, 5}}));
  EXPECT_TRUE(pslg.segments.empty());
  EXPECT_TRUE(pslg.holes.empty());
}

// Triangle lets the trailing fields of a header line default (dimension 2, no attributes/markers).
TEST_F(Io, ReadsNodeWithShortHeader) {
  const Pslg pslg = cdt::io::read_node(write("a.node", "2\n0 1 2\n1 3 4\n"));
  EXPECT_EQ(pslg.points, (std::vector<Point>{{1, 2}, {3, 4}}));
  EXPECT_EQ(cdt::io::read_node(write("b.node", "0 2 0 0\n")).points.size(), 0u);
}

// Triangle documents that a .poly file can be read as a .node: everything after the vertices is ignored.
TEST_F(Io, ReadsPolyContentsAsNode) {
  const Pslg pslg = cdt::io::read_node(write("a.node", "2 2 0 0\n0 1 2\n1 3 4\n1 0\n0 0 1\n0\n"));
  EXPECT_EQ(pslg.points.size(), 2u);
  EXPECT_TRUE(pslg.segments.empty());
}

TEST_F(Io, ReadsPolyWithMarkersHolesAndRegions) {
  const Pslg pslg = cdt::io::read_poly(write("a.poly", "4 2 0 1\n"
                                                       "1 0 0 1\n"
                                                       "2 4 0 1\n"
                                                       "3 4 4 1\n"
                                                       "4 0 4 1\n"
                                                       "4 1\n"
                                                       "1 1 2 5\n"
                                                       "2 2 3 5\n"
                                                       "3 3 4 5\n"
                                                       "4 4 1 5\n"
                                                       "1\n"
                                                       "1 2 2\n"
                                                       "2\n"
                                                       "1 1 1 10 0.5\n"
                                                       "2 3 3 20\n"));
  EXPECT_EQ(pslg.first_index, 1u);
  EXPECT_EQ(pslg.points, (std::vector<Point>{{0, 0}, {4, 0}, {4, 4}, {0, 4}}));
  EXPECT_EQ(pslg.segments, (std::vector<Segment>{{0, 1}, {1, 2}, {2, 3}, {3, 0}}));
  EXPECT_EQ(pslg.holes, (std::vector<Point>{{2, 2}}));
}

TEST_F(Io, PolyWithZeroVerticesReadsTheNodeBesideIt) {
  write("shape.node", "3 2 0 0\n1 0 0\n2 1 0\n3 0 1\n");
  const Pslg pslg = cdt::io::read_poly(write("shape.poly", "0 2 0 0\n3 0\n1 1 2\n2 2 3\n3 3 1\n0\n"));
  EXPECT_EQ(pslg.first_index, 1u);
  EXPECT_EQ(pslg.points, (std::vector<Point>{{0, 0}, {1, 0}, {0, 1}}));
  EXPECT_EQ(pslg.segments, (std::vector<Segment>{{0, 1}, {1, 2}, {2, 0}}));
}

// The error must name the .node the reader looked for, and say why it looked there.
TEST_F(Io, PolyWithZeroVerticesAndNoNodeNamesTheNode) {
  const fs::path poly = write("lonely.poly", "0 2 0 0\n0 0\n0\n");
  EXPECT_TRUE(
      throws_file_error([&] { cdt::io::read_poly(poly); }, dir_ / "lonely.node", 0, "lists 0 vertices"));
}

// Segment endpoints of a vertex-less .poly are checked against the .node's vertices.
TEST_F(Io, PolyWithZeroVerticesChecksEndpointsAgainstTheNode) {
  write("shape.node", "2 2 0 0\n0 0 0\n1 1 0\n");
  EXPECT_TRUE(rejects("shape.poly", "0 2 0 0\n1 0\n0 0 2\n0\n", 3, "index out of range"));
}

TEST_F(Io, SkipsCommentsAndBlankLines) {
  const Pslg pslg = cdt::io::read_poly(write("a.poly", "# a square\n"
                                                       "\n"
                                                       "   \t \n"
                                                       "4 2 0 0 # vertices\n"
                                                       "0 0 0\n"
                                                       "#1 9 9\n"
                                                       "1 1 0#glued comment\n"
                                                       "\n"
                                                       "2 1 1\n"
                                                       "3 0 1\n"
                                                       "1 0\n"
                                                       "  0   0\t2  \n"
                                                       "0\n"
                                                       "# trailing comment\n"
                                                       "\n"));
  EXPECT_EQ(pslg.points, (std::vector<Point>{{0, 0}, {1, 0}, {1, 1}, {0, 1}}));
  EXPECT_EQ(pslg.segments, (std::vector<Segment>{{0, 2}}));
}

// Two of the test data files use CRLF; the last line of a file may lack its newline.
TEST_F(Io, ReadsCrlfAndMissingFinalNewline) {
  const Pslg pslg = cdt::io::read_edge_list(write("a.txt", "2 1\r\n0 1\r\n2 3\r\n0 1"));
  EXPECT_EQ(pslg.points, (std::vector<Point>{{0, 1}, {2, 3}}));
  EXPECT_EQ(pslg.segments, (std::vector<Segment>{{0, 1}}));
}

// strtod, and so Triangle, accepts these spellings; std::from_chars alone would refuse the '+'.
TEST_F(Io, AcceptsNumberSpellingsTriangleAccepts) {
  const Pslg pslg = cdt::io::read_edge_list(write("a.txt", "3 1\n+1.5 -2\n.5 5.\n1E3 -2.5e-3\n+0 +2\n"));
  EXPECT_EQ(pslg.points, (std::vector<Point>{{1.5, -2}, {0.5, 5}, {1000, -0.0025}}));
  EXPECT_EQ(pslg.segments, (std::vector<Segment>{{0, 2}}));
}

TEST_F(Io, ReadsEleWithSixNodesAndAttributes) {
  const fs::path path = write("a.ele", "2 6 1\n1 1 2 3 4 5 6 0.5\n2 3 2 1 6 5 4 -1\n");
  const cdt::TriangleArray want = {{0, 1, 2}, {2, 1, 0}};
  EXPECT_EQ(cdt::io::read_ele(path, 1), want);
}

TEST_F(Io, ReadPslgPicksFormatByExtension) {
  EXPECT_EQ(cdt::io::read_pslg(write("a.node", "1 2 0 0\n1 5 6\n")).points, (std::vector<Point>{{5, 6}}));
  EXPECT_EQ(cdt::io::read_pslg(write("a.poly", "1 2 0 0\n1 5 6\n0 0\n0\n")).points,
            (std::vector<Point>{{5, 6}}));
  EXPECT_EQ(cdt::io::read_pslg(write("a.txt", "1 0\n5 6\n")).points, (std::vector<Point>{{5, 6}}));
  EXPECT_EQ(cdt::io::read_pslg(write("noext", "1 0\n5 6\n")).points, (std::vector<Point>{{5, 6}}));
}

// Every input of the CDT test corpus must load, with exactly the counts its first line announces.
TEST_F(Io, ReadsEveryArtemOgreFile) {
  const fs::path folder = fs::path(TRIXEL_TEST_DATA_DIR) / "cdt" / "artem-ogre-CDT";
  ASSERT_TRUE(fs::is_directory(folder)) << folder;
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (entry.path().extension() != ".txt") continue;
    SCOPED_TRACE(entry.path().string());
    ++files;
    std::ifstream in(entry.path());
    std::size_t vertices = 0;
    std::size_t edges = 0;
    ASSERT_TRUE(in >> vertices >> edges);
    Pslg pslg;
    ASSERT_NO_THROW(pslg = cdt::io::read_pslg(entry.path()));
    EXPECT_EQ(pslg.points.size(), vertices);
    EXPECT_EQ(pslg.segments.size(), edges);
    EXPECT_EQ(pslg.first_index, 0u);
    EXPECT_TRUE(pslg.holes.empty());
  }
  // The README lists 36 files; fewer would mean the folder or the filter is wrong.
  EXPECT_GE(files, 36u);

  const Pslg square = cdt::io::read_edge_list(folder / "unit_square.txt");
  EXPECT_EQ(square.points, (std::vector<Point>{{0, 0}, {1, 0}, {1, 1}, {0, 1}}));
  EXPECT_EQ(square.segments, (std::vector<Segment>{{0, 1}, {1, 2}, {2, 3}, {3, 0}}));
  const Pslg sweden = cdt::io::read_edge_list(folder / "Constrained_Sweden.txt");
  ASSERT_FALSE(sweden.points.empty());
  EXPECT_EQ(sweden.points[0], (Point{16.836666, 56.826942}));
}

// ---- errors -------------------------------------------------------------------------------------

TEST_F(Io, MissingFileIsReportedAtLineZero) {
  const fs::path path = dir_ / "absent.node";
  EXPECT_TRUE(throws_file_error([&] { cdt::io::read_node(path); }, path, 0, "No such file or directory"));
}

TEST_F(Io, DirectoryIsReportedAtLineZero) {
  const fs::path path = dir_ / "folder.txt";
  fs::create_directory(path);
  EXPECT_TRUE(throws_file_error([&] { cdt::io::read_pslg(path); }, path, 0, "directory"));
}

TEST_F(Io, EmptyFileIsReportedAtLineZero) {
  EXPECT_TRUE(rejects("a.node", "", 0, "empty"));
  EXPECT_TRUE(rejects("a.txt", "", 0, "empty"));
}

TEST_F(Io, FileOfOnlyCommentsNamesItsLastLine) {
  EXPECT_TRUE(rejects("a.poly", "# nothing\n\n# here\n", 3, "no data"));
}

TEST_F(Io, TruncatedNodeNamesTheLastLine) {
  EXPECT_TRUE(rejects("a.node", "3 2 0 0\n0 0 0\n1 1 1\n# more to come\n", 4, "expected vertex 3 of 3"));
}

TEST_F(Io, TruncatedPolyNamesTheMissingSection) {
  EXPECT_TRUE(rejects("a.poly", "1 2 0 0\n0 0 0\n", 2, "segment header"));
  EXPECT_TRUE(rejects("b.poly", "2 2 0 0\n0 0 0\n1 1 1\n1 0\n0 0 1", 5, "hole header"));
  EXPECT_TRUE(rejects("c.poly", "2 2 0 0\n0 0 0\n1 1 1\n2 0\n0 0 1\n", 5, "segment 2 of 2"));
  EXPECT_TRUE(rejects("d.poly", "1 2 0 0\n0 0 0\n0 0\n0\n2\n0 1 1 3\n", 6, "region 2 of 2"));
}

TEST_F(Io, TruncatedEdgeListNamesTheLastLine) {
  EXPECT_TRUE(rejects("a.txt", "2 2\n0 0\n1 1\n0 1\n", 4, "edge 2 of 2"));
}

TEST_F(Io, TruncatedEleNamesTheLastLine) {
  const fs::path path = write("a.ele", "2 3 0\n0 0 1 2\n");
  EXPECT_TRUE(throws_file_error([&] { cdt::io::read_ele(path, 0); }, path, 2, "triangle 2 of 2"));
}

TEST_F(Io, NonNumericFieldsAreRejected) {
  EXPECT_TRUE(rejects("a.node", "2 2 0 0\n0 0 0\n1 one 0\n", 3, "x coordinate 'one' is not a number"));
  // from_chars stops at the 'x'; the rest of the field must not be silently dropped.
  EXPECT_TRUE(rejects("b.node", "1 2 0 0\n0 0 2.5x\n", 2, "'2.5x' is not a number"));
  EXPECT_TRUE(rejects("c.node", "1 2 0 0\n0 0 0x1p3\n", 2, "is not a number"));
  EXPECT_TRUE(rejects("d.node", "1 2 0 0\n0.0 0 0\n", 2, "vertex number '0.0' is not an integer"));
  EXPECT_TRUE(rejects("e.node", "1 2 1 0\n0 0 0 attr\n", 2, "attribute 'attr' is not a number"));
  EXPECT_TRUE(rejects("f.node", "1 2 0 1\n0 0 0 1.5\n", 2, "boundary marker '1.5' is not an integer"));
  EXPECT_TRUE(rejects("g.txt", "2 1\n0 0\n1 1\n0 b\n", 4, "edge endpoint 'b' is not an integer"));
  EXPECT_TRUE(rejects("h.txt", "2.0 0\n0 0\n1 1\n", 1, "vertex count '2.0' is not an integer"));
  EXPECT_TRUE(rejects("i.txt", "++2 0\n0 0\n1 1\n", 1, "is not an integer"));
}

TEST_F(Io, WrongFieldCountsAreRejected) {
  EXPECT_TRUE(rejects("a.node", "2 2 0 0\n0 0 0\n1 1\n", 3, "expected 3 fields (<index> <x> <y>), found 2"));
  // With attributes and a marker announced, each vertex line must carry them.
  EXPECT_TRUE(rejects("b.node", "1 2 1 1\n0 0 0 1\n", 2, "expected 5 fields"));
  EXPECT_TRUE(rejects("c.txt", "1 0\n5\n", 2, "expected 2 fields (<x> <y>), found 1"));
  EXPECT_TRUE(rejects("d.txt", "1\n5 6\n", 1, "expected 2 fields"));
  EXPECT_TRUE(rejects("e.poly", "1 2 0 0\n0 0 0\n1 0\n0 0\n0\n", 4, "expected 3 fields"));
  EXPECT_TRUE(rejects("f.poly", "1 2 0 0\n0 0 0\n0 0\n1\n0 1\n", 5, "expected 3 fields"));
  EXPECT_TRUE(rejects("g.poly", "1 2 0 0\n0 0 0\n0 0\n0\n1\n0 1 1\n", 6, "expected 4 or more fields"));
}

TEST_F(Io, TrailingGarbageIsRejected) {
  EXPECT_TRUE(
      rejects("a.node", "2 2 0 0\n0 0 0\n1 1 1 junk\n", 3, "trailing garbage 'junk' after <index> <x> <y>"));
  EXPECT_TRUE(rejects("b.node", "2 2 0 0 9\n0 0 0\n1 1 1\n", 1, "trailing garbage '9'"));
  EXPECT_TRUE(rejects("c.txt", "2 1\n0 0\n1 1\n0 1 2\n", 4, "trailing garbage '2'"));
  EXPECT_TRUE(rejects("d.poly", "1 2 0 0\n0 0 0\n0 0\n0 extra\n", 4, "trailing garbage 'extra'"));
  const fs::path ele = write("e.ele", "1 3 0\n0 0 1 2 3\n");
  EXPECT_TRUE(throws_file_error([&] { cdt::io::read_ele(ele, 0); }, ele, 2, "trailing garbage '3'"));
}

// More records than announced would otherwise be dropped without a word.
TEST_F(Io, DataAfterTheLastRecordIsRejected) {
  EXPECT_TRUE(rejects("a.txt", "2 0\n0 0\n1 1\n2 2\n", 4, "unexpected data '2' after the last edge"));
  EXPECT_TRUE(rejects("b.poly", "1 2 0 0\n0 0 0\n0 0\n0\n0\n7\n", 6, "unexpected data '7'"));
  const fs::path ele = write("c.ele", "1 3 0\n0 0 1 2\n1 0 1 2\n");
  EXPECT_TRUE(throws_file_error([&] { cdt::io::read_ele(ele, 0); }, ele, 3, "unexpected data"));
}

TEST_F(Io, NonFiniteCoordinatesAreRejected) {
  EXPECT_TRUE(rejects("a.node", "2 2 0 0\n0 0 0\n1 nan 1\n", 3, "x coordinate 'nan' is not finite"));
  EXPECT_TRUE(rejects("b.txt", "1 0\n0 -inf\n", 2, "y coordinate '-inf' is not finite"));
  EXPECT_TRUE(rejects("c.txt", "1 0\n0 Infinity\n", 2, "is not finite"));
  EXPECT_TRUE(rejects("d.poly", "1 2 0 0\n0 0 0\n0 0\n1\n0 inf 0\n", 5, "is not finite"));
  // Overflow must not quietly become infinity either.
  EXPECT_TRUE(rejects("e.txt", "1 0\n1e999 0\n", 2, "out of the range of a double"));
}

TEST_F(Io, NegativeCountsAreRejected) {
  EXPECT_TRUE(rejects("a.node", "-1 2 0 0\n", 1, "vertex count '-1' is negative"));
  EXPECT_TRUE(rejects("b.txt", "1 -2\n0 0\n", 1, "edge count '-2' is negative"));
  EXPECT_TRUE(rejects("c.poly", "1 2 0 0\n0 0 0\n0 0\n-1\n", 4, "hole count '-1' is negative"));
  EXPECT_TRUE(rejects("d.node", "1 2 -1 0\n0 0 0\n", 1, "attribute count '-1' is negative"));
}

// Absurd counts must fail on the header line, before any memory is reserved for them.
TEST_F(Io, TooLargeCountsAreRejectedBeforeReserving) {
  EXPECT_TRUE(rejects("a.node", "4294967296 2 0 0\n", 1, "is too large"));
  EXPECT_TRUE(rejects("b.node", "99999999999999999999999 2 0 0\n", 1, "is out of range"));
  EXPECT_TRUE(rejects("c.node", "4294967295 2 0 0\n0 0 0\n", 1, "more than the remaining 6 bytes"));
  EXPECT_TRUE(rejects("d.txt", "1 1000000000\n0 0\n", 1, "more than the remaining"));
  // Many attributes make each record long, so even one vertex cannot fit.
  EXPECT_TRUE(rejects("e.node", "1 2 4000000000 0\n0 0 0\n", 1, "more than the remaining"));
  EXPECT_TRUE(rejects("f.poly", "1 2 0 0\n0 0 0\n3000000000 0\n", 3, "more than the remaining"));
  const fs::path ele = write("g.ele", "2000000000 3 0\n0 0 1 2\n");
  EXPECT_TRUE(throws_file_error([&] { cdt::io::read_ele(ele, 0); }, ele, 1, "more than the remaining"));
}

TEST_F(Io, DimensionOtherThanTwoIsRejected) {
  EXPECT_TRUE(rejects("a.node", "1 3 0 0\n0 0 0 0\n", 1, "dimension must be 2, found 3"));
  EXPECT_TRUE(rejects("b.poly", "1 two 0 0\n0 0 0\n", 1, "dimension 'two' is not an integer"));
}

TEST_F(Io, BoundaryMarkerCountAboveOneIsRejected) {
  EXPECT_TRUE(rejects("a.node", "1 2 0 2\n0 0 0 1 1\n", 1, "boundary markers must be 0 or 1, found 2"));
  EXPECT_TRUE(rejects("b.poly", "1 2 0 0\n0 0 0\n0 3\n0\n", 3, "boundary markers must be 0 or 1, found 3"));
}

TEST_F(Io, IndicesOutOfRangeAreRejected) {
  // 1-based file: 0 is as wrong as one past the end.
  EXPECT_TRUE(
      rejects("a.poly", "2 2 0 0\n1 0 0\n2 1 1\n1 0\n1 0 2\n0\n", 5, "segment endpoint 0 is not in 1..2"));
  EXPECT_TRUE(
      rejects("b.poly", "2 2 0 0\n0 0 0\n1 1 1\n1 0\n0 1 2\n0\n", 5, "segment endpoint 2 is not in 0..1"));
  EXPECT_TRUE(rejects("c.txt", "2 1\n0 0\n1 1\n0 2\n", 4, "edge endpoint 2 is not in 0..1"));
  EXPECT_TRUE(rejects("d.txt", "2 1\n0 0\n1 1\n-1 0\n", 4, "edge endpoint -1 is not in 0..1"));
  EXPECT_TRUE(rejects("e.txt", "0 1\n0 0\n", 2, "there are no vertices"));
  const fs::path ele = write("f.ele", "1 3 0\n1 1 2 0\n");
  EXPECT_TRUE(throws_file_error([&] { cdt::io::read_ele(ele, 1); }, ele, 2, "vertex 0 is not in 1.."));
}

TEST_F(Io, NonConsecutiveIndicesAreRejected) {
  EXPECT_TRUE(rejects("a.node", "3 2 0 0\n1 0 0\n2 1 1\n4 2 2\n", 4,
                      "non-consecutive vertex numbers: expected 3, found 4"));
  EXPECT_TRUE(
      rejects("b.node", "2 2 0 0\n2 0 0\n3 1 1\n", 2, "first vertex must be numbered 0 or 1, found 2"));
  EXPECT_TRUE(rejects("c.poly", "2 2 0 0\n0 0 0\n1 1 1\n2 0\n0 0 1\n0 1 0\n0\n", 6,
                      "non-consecutive segment numbers"));
  EXPECT_TRUE(rejects("d.poly", "1 2 0 0\n0 0 0\n0 0\n2\n1 0 0\n1 0 0\n", 6, "non-consecutive hole numbers"));
  const fs::path ele = write("e.ele", "2 3 0\n1 1 2 3\n1 1 2 3\n");
  EXPECT_TRUE(
      throws_file_error([&] { cdt::io::read_ele(ele, 1); }, ele, 3, "non-consecutive triangle numbers"));
}

TEST_F(Io, EleWithUnsupportedNodesPerTriangleIsRejected) {
  const fs::path ele = write("a.ele", "1 4 0\n0 0 1 2 3\n");
  EXPECT_TRUE(throws_file_error([&] { cdt::io::read_ele(ele, 0); }, ele, 1, "must be 3 or 6, found 4"));
}

TEST_F(Io, ReadEleRejectsFirstIndexAboveOne) {
  const fs::path ele = write("a.ele", "1 3 0\n0 0 1 2\n");
  EXPECT_TRUE(throws_file_error([&] { cdt::io::read_ele(ele, 2); }, ele, 0, "first_index must be 0 or 1"));
}

} // namespace
