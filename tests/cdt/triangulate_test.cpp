// End-to-end tests of triangulate(): every result must pass the exact verifier.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "artem_ogre.hpp"
#include "canonical_triangles.hpp"
#include "cdt/cdt.hpp"
#include "cdt/io.hpp"
#include "cdt/verify.hpp"
#include "pslg_generators.hpp"

namespace {

using trixel_gen::Distribution;

void expect_verified(const trixel_gen::Pslg& in, const cdt::Options& options = {},
                     const std::string& what = "") {
  const cdt::Triangulation t = cdt::triangulate(in.points, in.segments, options);
  const cdt::VerifyReport report = cdt::verify(t, in.points, in.segments);
  EXPECT_TRUE(report.ok()) << what << ": " << report.num_problems << " problems, first: "
                           << (report.problems.empty() ? "" : report.problems.front());
}

TEST(Triangulate, UniformPointsVerify) {
  for (std::size_t n : {3u, 10u, 100u, 1000u, 20000u})
    expect_verified(trixel_gen::random_points(n, Distribution::uniform, n), {}, std::to_string(n));
}

TEST(Triangulate, GaussianAndClusteredPointsVerify) {
  expect_verified(trixel_gen::random_points(20000, Distribution::gaussian, 5), {}, "gaussian");
  expect_verified(trixel_gen::clustered(20000, 7, 6), {}, "clustered");
}

// A pixel lattice is co-circular everywhere: flipping must terminate and the result verify.
TEST(Triangulate, LatticeVerifies) {
  for (std::uint32_t k : {3u, 10u, 64u})
    expect_verified(trixel_gen::lattice(k), {}, "lattice " + std::to_string(k));
}

TEST(Triangulate, LatticeWithRandomSegmentsVerifies) {
  expect_verified(trixel_gen::lattice_with_segments(32, 200, 3), {}, "lattice+segments");
}

TEST(Triangulate, SyntheticPslgVerifies) {
  for (Distribution d : {Distribution::uniform, Distribution::gaussian}) {
    expect_verified(trixel_gen::synthetic_pslg(20000, 2000, d, 9), {}, "synthetic");
  }
}

// Thin circle and two lines: the inputs the digital Voronoi approximation handles worst.
TEST(Triangulate, ThinCircleAndTwoLinesVerify) {
  trixel_gen::Pslg circle;
  for (int i = 0; i < 2000; ++i) {
    const double a = 6.283185307179586 * i / 2000;
    circle.points.push_back({std::cos(a), std::sin(a)});
  }
  expect_verified(circle, {}, "circle");
  trixel_gen::Pslg lines;
  for (int i = 0; i < 1000; ++i) {
    lines.points.push_back({i * 0.001, 0.0});
    lines.points.push_back({i * 0.001, 1.0});
  }
  expect_verified(lines, {}, "two lines");
}

// The digital Voronoi dual must carry the bulk of the work: only points sharing a grid cell (about one
// in nine on a grid of four or more cells per point, as here), those next to degenerate corners, and
// bad shifting cases are left to missing-point insertion. Integer coordinates make collinear sites at
// grid corners common.
TEST(Triangulate, DualKeepsMostPointsOutOfMissingInsertion) {
  for (const bool integer : {false, true}) {
    auto in = trixel_gen::random_points(30000, Distribution::uniform, 12);
    if (integer) {
      for (auto& p : in.points) p = {std::floor(p.x * 2000.0), std::floor(p.y * 2000.0)};
    }
    cdt::Options options;
    options.grid_size = 512; // 8.7 cells per point
    const cdt::Triangulation t = cdt::triangulate(in.points, in.segments, options);
    std::uint64_t missing = 0;
    for (const auto& phase : t.stats.phases) {
      if (phase.name == "insert") missing = phase.missing;
    }
    EXPECT_LT(missing, in.points.size() / 5) << (integer ? "integer" : "double") << " coordinates";
    EXPECT_TRUE(cdt::verify(t, in.points, in.segments).ok());
  }
}

TEST(Triangulate, SingleAndManyThreadsBothVerify) {
  const auto in = trixel_gen::synthetic_pslg(5000, 500, Distribution::uniform, 4);
  for (unsigned threads : {1u, 3u}) {
    cdt::Options o;
    o.threads = threads;
    expect_verified(in, o, "threads " + std::to_string(threads));
  }
}

/// The CPU backend with 1 and with 3 threads: the same vertices, triangles, links and constraint
/// edges, verified.
void expect_same_for_any_thread_count(const trixel_gen::Pslg& in) {
  cdt::Options one;
  one.backend = cdt::Backend::cpu;
  one.threads = 1;
  cdt::Options three = one;
  three.threads = 3;
  const cdt::Triangulation a = cdt::triangulate(in.points, in.segments, one);
  const cdt::Triangulation b = cdt::triangulate(in.points, in.segments, three);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.neighbors, b.neighbors);
  EXPECT_EQ(a.segment_of_edge, b.segment_of_edge);
  EXPECT_TRUE(cdt::verify(a, in.points, in.segments).ok());
}

// Points alone keep the slots of the insertion (no compaction after the fake boundary): their order
// must not depend on the thread count either.
TEST(Triangulate, PointsAloneGiveTheSameTrianglesForAnyThreadCount) {
  expect_same_for_any_thread_count(trixel_gen::random_points(60000, Distribution::gaussian, 11));
}

// Segments through points, overlapping and crossing: the screened split and the added vertices too.
TEST(Triangulate, SegmentsGiveTheSameTrianglesForAnyThreadCount) {
  expect_same_for_any_thread_count(trixel_gen::lattice_with_segments(30, 300, 5));
}

/// The same triangles from schedules as different as the CPU executor's can be: grids from far coarser
/// to far finer than the points (so that the sites, the missing points and every round differ), one and
/// three threads. Ties among co-circular points are broken by one perturbation (incircle_perturbed), so
/// the CDT is unique and every schedule must reach it.
void expect_one_cdt_for_every_schedule(const std::vector<cdt::Point>& points,
                                       const std::vector<cdt::Segment>& segments, const std::string& what) {
  cdt::Options first;
  first.backend = cdt::Backend::cpu;
  first.threads = 1;
  const cdt::Triangulation reference = cdt::triangulate(points, segments, first);
  const cdt::VerifyReport report = cdt::verify(reference, points, segments);
  EXPECT_TRUE(report.ok()) << what << ": " << (report.problems.empty() ? "" : report.problems.front());
  const auto expected = trixel_test::canonical_triangles(reference);
  cdt::Triangulation canonical_reference = reference;
  cdt::canonicalize(canonical_reference);
  const cdt::VerifyReport canonical_report = cdt::verify(canonical_reference, points, segments);
  EXPECT_TRUE(canonical_report.ok()) << what << " canonicalized: "
                                     << (canonical_report.problems.empty()
                                             ? ""
                                             : canonical_report.problems.front());
  for (const std::uint32_t grid : {16u, 64u, 256u, 2048u}) {
    for (const unsigned threads : {1u, 3u}) {
      cdt::Options o = first;
      o.grid_size = grid;
      o.threads = threads;
      cdt::Triangulation t = cdt::triangulate(points, segments, o);
      const std::string where =
          what + ", grid " + std::to_string(grid) + ", " + std::to_string(threads) + " threads";
      EXPECT_EQ(trixel_test::canonical_triangles(t), expected) << where;
      // In canonical order the arrays themselves are equal.
      cdt::canonicalize(t);
      EXPECT_EQ(t.vertices, canonical_reference.vertices) << where;
      EXPECT_EQ(t.triangles, canonical_reference.triangles) << where;
      EXPECT_EQ(t.neighbors, canonical_reference.neighbors) << where;
      EXPECT_EQ(t.segment_of_edge, canonical_reference.segment_of_edge) << where;
    }
  }
}

// Pixel lattices are co-circular everywhere: without one rule for ties each schedule would pick its
// own diagonals.
TEST(Triangulate, CoCircularInputsGiveOneCdtForEverySchedule) {
  for (std::uint32_t k : {3u, 10u, 64u}) {
    const auto in = trixel_gen::lattice(k);
    expect_one_cdt_for_every_schedule(in.points, in.segments, "lattice " + std::to_string(k));
  }
  const auto with_segments = trixel_gen::lattice_with_segments(40, 300, 7);
  expect_one_cdt_for_every_schedule(with_segments.points, with_segments.segments, "lattice with segments");
  // Pixel centres along rings, as an image's outlines give.
  trixel_gen::Pslg rings;
  for (int r = 2; r <= 40; r += 3) {
    const auto first = static_cast<std::uint32_t>(rings.points.size());
    for (int a = 0; a < 8 * r; ++a) {
      const double angle = 6.283185307179586 * a / (8 * r);
      rings.points.push_back(
          {std::floor(50 + r * std::cos(angle)) + 0.5, std::floor(50 + r * std::sin(angle)) + 0.5});
    }
    const auto last = static_cast<std::uint32_t>(rings.points.size());
    for (std::uint32_t i = first; i + 1 < last; i += 2) rings.segments.push_back({i, i + 1});
  }
  expect_one_cdt_for_every_schedule(rings.points, rings.segments, "pixel rings");
}

TEST(Triangulate, ArtemOgreFilesGiveOneCdtForEverySchedule) {
  const int files =
      trixel_test::for_each_artem_ogre_file([](const std::string& name, const cdt::io::Pslg& in) {
        expect_one_cdt_for_every_schedule(in.points, in.segments, name);
      });
  EXPECT_EQ(files, trixel_test::kArtemOgreFiles);
}

// Every input file of the peer library's test suite (crossings, overlaps, hanging edges).
TEST(Triangulate, ArtemOgreFilesVerify) {
  const int files =
      trixel_test::for_each_artem_ogre_file([](const std::string& name, const cdt::io::Pslg& in) {
        try {
          const cdt::Triangulation t = cdt::triangulate(in.points, in.segments);
          const cdt::VerifyReport report = cdt::verify(t, in.points, in.segments);
          EXPECT_TRUE(report.ok()) << name << ": "
                                   << (report.problems.empty() ? "" : report.problems.front());
        } catch (const cdt::Error& e) {
          ADD_FAILURE() << name << ": " << e.what();
        }
      });
  EXPECT_EQ(files, trixel_test::kArtemOgreFiles);
}

TEST(Triangulate, BadInputGivesTypedErrors) {
  using Kind = cdt::InvalidInputError::Kind;
  const auto kind_of = [](std::vector<cdt::Point> p, std::vector<cdt::Segment> s) {
    try {
      cdt::triangulate(p, s);
    } catch (const cdt::InvalidInputError& e) {
      return e.kind();
    }
    ADD_FAILURE() << "no InvalidInputError";
    return Kind::too_few_points;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(kind_of({{0, 0}, {1, 0}, {nan, 1}}, {}), Kind::non_finite_coordinate);
  EXPECT_EQ(kind_of({{0, 0}, {1, 0}, {0, 1}}, {{0, 3}}), Kind::index_out_of_range);
  EXPECT_EQ(kind_of({{0, 0}, {1, 0}, {0, 0}}, {}), Kind::too_few_points);
  EXPECT_EQ(kind_of({{0, 0}, {1, 1}, {2, 2}, {3, 3}}, {}), Kind::all_collinear);
}

TEST(Triangulate, ZeroLengthSegmentsIgnoredUnderResolveRejectedUnderReject) {
  const std::vector<cdt::Point> p{{0, 0}, {1, 0}, {0, 1}, {1, 0}};
  const std::vector<cdt::Segment> s{{0, 1}, {1, 1}, {3, 1}};
  const cdt::Triangulation t = cdt::triangulate(p, s);
  EXPECT_EQ(t.stats.zero_length_segments, 2u);
  EXPECT_TRUE(cdt::verify(t, p, s).ok());
  cdt::Options strict;
  strict.crossings = cdt::CrossingSegments::reject;
  try {
    cdt::triangulate(p, s, strict);
    ADD_FAILURE() << "no error under reject";
  } catch (const cdt::InvalidInputError& e) {
    EXPECT_EQ(e.kind(), cdt::InvalidInputError::Kind::degenerate_segment);
    EXPECT_EQ(e.item(), 1u);
  }
}

TEST(Triangulate, CrossingsRejectedNameBothSegments) {
  const std::vector<cdt::Point> p{{0, 0}, {2, 2}, {0, 2}, {2, 0}, {5, 5}};
  const std::vector<cdt::Segment> s{{0, 1}, {2, 3}};
  cdt::Options o;
  o.crossings = cdt::CrossingSegments::reject;
  try {
    cdt::triangulate(p, s, o);
    FAIL();
  } catch (const cdt::CrossingSegmentsError& e) {
    EXPECT_EQ(e.first(), 0u);
    EXPECT_EQ(e.second(), 1u);
  }
  // Resolved, the crossing becomes a vertex after the inputs.
  const cdt::Triangulation t = cdt::triangulate(p, s);
  EXPECT_EQ(t.vertices.size(), 6u);
  EXPECT_TRUE(cdt::verify(t, p, s).ok());
}

TEST(Triangulate, DuplicatesAreMergedWithTheMapInTheResult) {
  const std::vector<cdt::Point> p{{0, 0}, {1, 0}, {0, 1}, {1, 0}, {1, 1}};
  const cdt::Triangulation t = cdt::triangulate(p, {});
  ASSERT_EQ(t.duplicate_of.size(), 5u);
  EXPECT_EQ(t.duplicate_of[3], 1u);
  EXPECT_EQ(t.triangles.size(), 2u);
  EXPECT_TRUE(cdt::verify(t, p, {}).ok());
}

// Starting CUDA ahead: true exactly when there is a device to start; without one, nothing happens.
// Giving the device back lets it start again.
TEST(Triangulate, StartGpuReportsWhetherADeviceStarted) {
  EXPECT_EQ(cdt::start_gpu(), cdt::gpu_device_count() > 0);
  EXPECT_EQ(cdt::start_gpu(), cdt::gpu_device_count() > 0); // and again, once started
  cdt::stop_gpu();
  EXPECT_EQ(cdt::start_gpu(), cdt::gpu_device_count() > 0);
}

TEST(Triangulate, ExplicitGpuBackendWithoutDeviceIsAnError) {
  if (cdt::gpu_device_count() > 0) GTEST_SKIP() << "a CUDA device is present (the GPU tests cover it)";
  cdt::Options o;
  o.backend = cdt::Backend::gpu;
  const std::vector<cdt::Point> p{{0, 0}, {1, 0}, {0, 1}};
  EXPECT_THROW(cdt::triangulate(p, {}, o), cdt::DeviceError);
}

} // namespace
