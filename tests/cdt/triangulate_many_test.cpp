// triangulate_many(): every input gets what triangulate() gives it alone, whether it was triangulated
// with others or on its own, and an error stays with its own input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "cdt/cdt.hpp"
#include "cdt/verify.hpp"
#include "pslg_generators.hpp"

namespace {

using trixel_gen::add_frame;
using trixel_gen::framed_pixels;
using trixel_gen::Pslg;

std::vector<cdt::Input> as_inputs(const std::vector<Pslg>& pslgs) {
  std::vector<cdt::Input> inputs;
  for (const Pslg& p : pslgs) inputs.push_back({p.points, p.segments});
  return inputs;
}

// The result equals triangulate()'s for the input alone, array for array once both are canonical.
void expect_as_alone(const cdt::ManyResult& got, const Pslg& in, const cdt::Options& options,
                     const std::string& what) {
  ASSERT_FALSE(got.error) << what;
  cdt::Triangulation mine = got.triangulation;
  cdt::Triangulation alone = cdt::triangulate(in.points, in.segments, options);
  const cdt::VerifyReport report = cdt::verify(mine, in.points, in.segments);
  EXPECT_TRUE(report.ok()) << what << ": " << (report.problems.empty() ? "" : report.problems.front());
  cdt::canonicalize(mine);
  cdt::canonicalize(alone);
  EXPECT_EQ(mine.vertices, alone.vertices) << what;
  EXPECT_EQ(mine.triangles, alone.triangles) << what;
  EXPECT_EQ(mine.neighbors, alone.neighbors) << what;
  EXPECT_EQ(mine.segment_of_edge, alone.segment_of_edge) << what;
  EXPECT_EQ(mine.duplicate_of, alone.duplicate_of) << what;
  EXPECT_EQ(mine.stats.zero_length_segments, alone.stats.zero_length_segments) << what;
}

TEST(TriangulateMany, FramedInputsTriangulatedTogetherGiveTheirOwnCdts) {
  std::vector<Pslg> pslgs;
  for (int k = 0; k < 7; ++k) pslgs.push_back(framed_pixels(20 + 13 * k, 15 + 9 * (k % 3), 100 + k, k % 4));
  Pslg empty_frame; // corners and sides only
  add_frame(empty_frame, 3, 2, 0);
  pslgs.push_back(empty_frame);
  Pslg duplicates = framed_pixels(30, 30, 7); // points given twice, a zero-length segment
  duplicates.points.push_back(duplicates.points[5]);
  duplicates.points.push_back(duplicates.points[0]);
  duplicates.segments.push_back({5, static_cast<std::uint32_t>(duplicates.points.size() - 2)});
  pslgs.push_back(duplicates);
  Pslg shifted = framed_pixels(25, 25, 8); // a frame away from the origin, at negative coordinates
  for (auto& p : shifted.points) p = {p.x - 1000.25, p.y + 77.5};
  pslgs.push_back(shifted);
  const std::vector<cdt::Input> inputs = as_inputs(pslgs);
  for (const unsigned threads : {1u, 3u}) {
    cdt::Options options;
    options.backend = cdt::Backend::cpu;
    options.threads = threads;
    const std::vector<cdt::ManyResult> got = cdt::triangulate_many(inputs, options);
    ASSERT_EQ(got.size(), pslgs.size());
    for (std::size_t i = 0; i < got.size(); ++i) {
      const std::string what = "input " + std::to_string(i) + ", threads " + std::to_string(threads);
      expect_as_alone(got[i], pslgs[i], options, what);
      EXPECT_EQ(got[i].triangulation.stats.inputs, pslgs.size()) << what;
    }
  }
}

// Inputs that cannot share a call are triangulated alone, and come out the same.
TEST(TriangulateMany, OtherInputsAreTriangulatedAlone) {
  std::vector<Pslg> pslgs;
  pslgs.push_back(framed_pixels(40, 30, 1));
  pslgs.push_back(framed_pixels(40, 30, 2));
  Pslg unframed = framed_pixels(30, 30, 3); // a side not covered: its last segment removed
  unframed.segments.pop_back();
  pslgs.push_back(unframed);
  Pslg inexact = framed_pixels(30, 30, 4); // coordinates whose low bits a translation would round
  for (auto& p : inexact.points) p = {p.x / 3.0 + 0.1, p.y / 7.0};
  pslgs.push_back(inexact);
  Pslg crossing = framed_pixels(30, 30, 5); // two segments crossing between pixel centres: a vertex added
  const auto first = static_cast<std::uint32_t>(crossing.points.size());
  crossing.points.insert(crossing.points.end(), {{3.5, 3.5}, {6.5, 6.5}, {3.5, 6.5}, {6.5, 3.5}});
  crossing.segments.insert(crossing.segments.end(), {{first, first + 1}, {first + 2, first + 3}});
  pslgs.push_back(crossing);
  pslgs.push_back(trixel_gen::random_points(500, trixel_gen::Distribution::uniform, 6)); // no segments
  const std::vector<cdt::Input> inputs = as_inputs(pslgs);
  cdt::Options options;
  options.backend = cdt::Backend::cpu;
  options.threads = 2;
  const std::vector<cdt::ManyResult> got = cdt::triangulate_many(inputs, options);
  ASSERT_EQ(got.size(), pslgs.size());
  // The crossing input shares the call of the first two, then is triangulated again alone.
  const std::vector<std::uint32_t> together = {3, 3, 1, 1, 1, 1};
  for (std::size_t i = 0; i < got.size(); ++i) {
    expect_as_alone(got[i], pslgs[i], options, "input " + std::to_string(i));
    EXPECT_EQ(got[i].triangulation.stats.inputs, together[i]) << "input " << i;
  }
  EXPECT_GT(got[4].triangulation.vertices.size(), pslgs[4].points.size()); // the crossing's vertex
}

// Frames past 2^53 wide: the cells' margin of 1 rounds away, so two copies of a frame 1e50 wide would
// be placed touching (the second's bottom side on the first's top, their corners merged as
// duplicates, and the second left without triangles). They are triangulated alone.
TEST(TriangulateMany, FramesTooWideForTheirCellsAreTriangulatedAlone) {
  const double w = 1e50;
  Pslg huge; // the corners twice, the sides, one diagonal
  huge.points = {{w, 0}, {0, w}, {w, w}, {0, w}, {w, 0}, {w, w}, {0, 0}, {0, 0}};
  huge.segments = {{5, 3}, {6, 1}, {4, 2}, {0, 7}};
  const std::vector<Pslg> pslgs = {huge, framed_pixels(20, 20, 9), huge};
  cdt::Options options;
  options.backend = cdt::Backend::cpu;
  const std::vector<cdt::ManyResult> got = cdt::triangulate_many(as_inputs(pslgs), options);
  ASSERT_EQ(got.size(), pslgs.size());
  for (std::size_t i = 0; i < got.size(); ++i)
    expect_as_alone(got[i], pslgs[i], options, "input " + std::to_string(i));
  EXPECT_EQ(got[2].triangulation.triangles.size(), 2u);
}

// A bad input gets triangulate()'s error; the others are not affected.
TEST(TriangulateMany, ErrorsStayWithTheirInputs) {
  std::vector<Pslg> pslgs;
  pslgs.push_back(framed_pixels(30, 20, 11));
  Pslg out_of_range = framed_pixels(30, 20, 12);
  out_of_range.segments.push_back({0, static_cast<std::uint32_t>(out_of_range.points.size())});
  pslgs.push_back(out_of_range);
  Pslg not_finite = framed_pixels(30, 20, 13);
  not_finite.points[3].x = std::numeric_limits<double>::quiet_NaN();
  pslgs.push_back(not_finite);
  pslgs.push_back(framed_pixels(30, 20, 14));
  Pslg crossing = framed_pixels(30, 20, 15); // an error under the reject policy only
  const auto first = static_cast<std::uint32_t>(crossing.points.size());
  crossing.points.insert(crossing.points.end(), {{3.5, 3.5}, {6.5, 6.5}, {3.5, 6.5}, {6.5, 3.5}});
  crossing.segments.insert(crossing.segments.end(), {{first, first + 1}, {first + 2, first + 3}});
  pslgs.push_back(crossing);
  const std::vector<cdt::Input> inputs = as_inputs(pslgs);
  cdt::Options options;
  options.backend = cdt::Backend::cpu;
  options.crossings = cdt::CrossingSegments::reject;
  const std::vector<cdt::ManyResult> got = cdt::triangulate_many(inputs, options);
  ASSERT_EQ(got.size(), pslgs.size());
  const auto kind = [&](std::size_t i) {
    try {
      std::rethrow_exception(got[i].error);
    } catch (const cdt::InvalidInputError& e) {
      return e.kind();
    } catch (...) {
    }
    ADD_FAILURE() << "input " << i << ": no InvalidInputError";
    return cdt::InvalidInputError::Kind::too_few_points;
  };
  ASSERT_TRUE(got[1].error);
  EXPECT_EQ(kind(1), cdt::InvalidInputError::Kind::index_out_of_range);
  ASSERT_TRUE(got[2].error);
  EXPECT_EQ(kind(2), cdt::InvalidInputError::Kind::non_finite_coordinate);
  ASSERT_TRUE(got[4].error);
  EXPECT_THROW(std::rethrow_exception(got[4].error), cdt::CrossingSegmentsError);
  for (const std::size_t i : {0u, 3u})
    expect_as_alone(got[i], pslgs[i], options, "input " + std::to_string(i));
  EXPECT_TRUE(cdt::triangulate_many({}, options).empty());
}

} // namespace
