// triangulate() with Backend::gpu: the digital Voronoi diagram, the dual, shifting, missing points,
// the segments' screen, constraints and flips run on the device. Up to shifting each phase is the CPU
// executor's step for step, so those phases must count the same, and both insert the same missing points;
// from there the schedules differ (parallel rounds on the device, parts of the mesh with Lawson's flips on
// CPU threads). Ties among co-circular points are broken by one perturbation on both (incircle_perturbed),
// so the CDT is unique and the result must be the CPU backend's triangle for triangle on every input,
// lattices included, and verify.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "artem_ogre.hpp"
#include "canonical_triangles.hpp"
#include "cdt/cdt.hpp"
#include "cdt/io.hpp"
#include "cdt/verify.hpp"
#include "cdt_kernels.hpp"
#include "pslg_generators.hpp"

namespace {

using trixel_gen::Distribution;

void expect_same_as_cpu(const std::vector<cdt::Point>& points, const std::vector<cdt::Segment>& segments,
                        const std::string& what) {
  cdt::Options gpu;
  gpu.backend = cdt::Backend::gpu;
  cdt::Options cpu;
  cpu.backend = cdt::Backend::cpu;
  const cdt::Triangulation on_gpu = cdt::triangulate(points, segments, gpu);
  // The CPU executor picks a coarser grid of its own; on the device's grid the phases up to the missing
  // points must do the same work.
  cpu.grid_size = on_gpu.stats.grid_size;
  const cdt::Triangulation on_cpu = cdt::triangulate(points, segments, cpu);
  EXPECT_EQ(on_gpu.stats.backend.rfind("gpu", 0), 0u) << what << ": backend " << on_gpu.stats.backend;
  EXPECT_EQ(trixel_test::canonical_triangles(on_gpu), trixel_test::canonical_triangles(on_cpu)) << what;
  cdt::Triangulation gpu_canonical = on_gpu;
  cdt::Triangulation cpu_canonical = on_cpu;
  cdt::canonicalize(gpu_canonical);
  cdt::canonicalize(cpu_canonical);
  EXPECT_TRUE(gpu_canonical.vertices == cpu_canonical.vertices &&
              gpu_canonical.triangles == cpu_canonical.triangles &&
              gpu_canonical.neighbors == cpu_canonical.neighbors &&
              gpu_canonical.segment_of_edge == cpu_canonical.segment_of_edge)
      << what << ": canonical arrays differ";
  EXPECT_EQ(on_gpu.triangles.size(), on_cpu.triangles.size()) << what;
  // The device's merge leaves the identity maps of inputs without duplicates to a thread of their own.
  EXPECT_EQ(on_gpu.duplicate_of, on_cpu.duplicate_of) << what;
  ASSERT_EQ(on_gpu.stats.phases.size(), on_cpu.stats.phases.size()) << what;
  for (std::size_t k = 0; k < on_cpu.stats.phases.size(); ++k) {
    const cdt::PhaseStats& g = on_gpu.stats.phases[k];
    const cdt::PhaseStats& c = on_cpu.stats.phases[k];
    EXPECT_EQ(g.name, c.name) << what;
    EXPECT_EQ(g.missing, c.missing) << what << ", phase " << c.name;
    if (c.name == "insert") break; // the missing points and everything after them are scheduled differently
    EXPECT_EQ(g.flips, c.flips) << what << ", phase " << c.name;
    EXPECT_EQ(g.iterations, c.iterations) << what << ", phase " << c.name;
  }
  for (const auto* result : {&on_gpu, &on_cpu}) {
    const cdt::VerifyReport report = cdt::verify(*result, points, segments);
    EXPECT_TRUE(report.ok()) << what << (result == &on_gpu ? " (gpu): " : " (cpu): ")
                             << (report.problems.empty() ? "" : report.problems.front());
  }
}

class TriangulateGpu : public ::testing::Test {
protected:
  void SetUp() override {
    if (cdt::gpu_device_count() == 0) GTEST_SKIP() << "no CUDA device";
  }
};

TEST_F(TriangulateGpu, PointsMatchTheCpuBackend) {
  for (std::size_t n : {10u, 1000u, 100000u, 1000000u}) {
    const auto in = trixel_gen::random_points(n, Distribution::uniform, n);
    expect_same_as_cpu(in.points, in.segments, "uniform " + std::to_string(n));
  }
  const auto g = trixel_gen::random_points(100000, Distribution::gaussian, 3);
  expect_same_as_cpu(g.points, g.segments, "gaussian 100000");
}

TEST_F(TriangulateGpu, SegmentsMatchTheCpuBackend) {
  for (std::size_t n : {1000u, 100000u}) {
    const auto in = trixel_gen::synthetic_pslg(n, n / 10, Distribution::uniform, n + 1);
    expect_same_as_cpu(in.points, in.segments, "synthetic " + std::to_string(n));
  }
}

// From 2^16 pieces the device inserts the constraints beside the host's split, kept when the split
// changed nothing (the synthetic segments cross nothing) and undone when it did (long crossers added).
TEST_F(TriangulateGpu, ManySegmentsMatchTheCpuBackend) {
  trixel_gen::Pslg synthetic = trixel_gen::synthetic_pslg(700000, 70000, Distribution::uniform, 54);
  expect_same_as_cpu(synthetic.points, synthetic.segments, "synthetic 700000");
  trixel_gen::Random rng(55);
  trixel_gen::add_random_segments(synthetic, 10, rng);
  expect_same_as_cpu(synthetic.points, synthetic.segments, "synthetic 700000 with crossers");
}

// Starting CUDA ahead, giving the device back, and triangulating again: the device starts afresh (its
// context, staging memory and buffer pool made again) and gives the same triangles. Large enough that
// the copies go through the pinned staging blocks.
TEST_F(TriangulateGpu, StoppedDeviceStartsAgain) {
  const auto in = trixel_gen::synthetic_pslg(300000, 30000, Distribution::uniform, 77);
  cdt::Options gpu;
  gpu.backend = cdt::Backend::gpu;
  ASSERT_TRUE(cdt::start_gpu());
  cdt::Triangulation first = cdt::triangulate(in.points, in.segments, gpu);
  cdt::stop_gpu();
  cdt::stop_gpu(); // nothing left to give back
  cdt::Triangulation again = cdt::triangulate(in.points, in.segments, gpu);
  cdt::stop_gpu();
  ASSERT_TRUE(cdt::start_gpu());
  cdt::Triangulation third = cdt::triangulate(in.points, in.segments, gpu);
  for (auto* t : {&first, &again, &third}) {
    EXPECT_EQ(t->stats.backend.rfind("gpu", 0), 0u) << t->stats.backend;
    cdt::canonicalize(*t);
  }
  EXPECT_TRUE(first.triangles == again.triangles && first.neighbors == again.neighbors &&
              first.segment_of_edge == again.segment_of_edge && first.triangles == third.triangles);
  const cdt::VerifyReport report = cdt::verify(again, in.points, in.segments);
  EXPECT_TRUE(report.ok()) << (report.problems.empty() ? "" : report.problems.front());
}

// The pinned result memory: a large result's per-triangle arrays come from blocks pinned for it, the
// next result of the same input takes the same blocks once the first is freed, and a result still held
// when the device is given back stays whole (its blocks are unpinned, then freed with it). Every result
// is the one made without it.
TEST_F(TriangulateGpu, PinnedResultsAreReusedAndOutliveTheDevice) {
  const auto in = trixel_gen::synthetic_pslg(800000, 20000, Distribution::uniform, 78);
  cdt::Options gpu;
  gpu.backend = cdt::Backend::gpu;
  const auto canonical = [](const cdt::Triangulation& t) {
    cdt::Triangulation copy = t;
    cdt::canonicalize(copy);
    return copy;
  };
  const auto same = [](const cdt::Triangulation& a, const cdt::Triangulation& b) {
    return a.triangles == b.triangles && a.neighbors == b.neighbors &&
           a.segment_of_edge == b.segment_of_edge && a.vertices == b.vertices &&
           a.duplicate_of == b.duplicate_of;
  };
  const auto blocks = [](const cdt::Triangulation& t) {
    std::vector<const void*> p = {t.triangles.data(), t.neighbors.data(), t.segment_of_edge.data()};
    std::sort(p.begin(), p.end());
    return p;
  };
  ASSERT_TRUE(cdt::keep_pinned_results(0));
  const cdt::Triangulation expected = canonical(cdt::triangulate(in.points, in.segments, gpu));
  ASSERT_GE(expected.triangles.size() * sizeof(expected.triangles[0]), cdt::detail::kPinnedArrayBytes);

  // Whether all three arrays lie in pinned blocks in use.
  const auto pinned = [](const cdt::Triangulation& t) {
    const std::size_t bytes = t.triangles.size() * sizeof(t.triangles[0]);
    return cdt::gpu::in_result_block(t.triangles.data(), bytes) &&
           cdt::gpu::in_result_block(t.neighbors.data(), bytes) &&
           cdt::gpu::in_result_block(t.segment_of_edge.data(), bytes);
  };

  ASSERT_TRUE(cdt::keep_pinned_results(std::size_t{256} << 20));
  cdt::Triangulation first = cdt::triangulate(in.points, in.segments, gpu);
  EXPECT_TRUE(pinned(first));
  EXPECT_TRUE(same(canonical(first), expected));
  const std::vector<const void*> first_blocks = blocks(first);
  first = cdt::Triangulation{};
  EXPECT_FALSE(cdt::gpu::in_result_block(first_blocks[0], 1)); // free again
  cdt::Triangulation second = cdt::triangulate(in.points, in.segments, gpu);
  EXPECT_TRUE(pinned(second));
  EXPECT_EQ(blocks(second), first_blocks);
  EXPECT_TRUE(same(canonical(second), expected));

  cdt::stop_gpu();
  EXPECT_FALSE(pinned(second)); // unpinned, still whole
  EXPECT_TRUE(same(canonical(second), expected));
  second = cdt::Triangulation{};
  cdt::Triangulation third = cdt::triangulate(in.points, in.segments, gpu);
  EXPECT_TRUE(pinned(third));
  EXPECT_TRUE(same(canonical(third), expected));
  // Kept no more: the blocks in use are freed with their arrays, and no array comes from them.
  ASSERT_TRUE(cdt::keep_pinned_results(0));
  third = cdt::Triangulation{};
  const cdt::Triangulation fourth = cdt::triangulate(in.points, in.segments, gpu);
  EXPECT_FALSE(pinned(fourth));
  EXPECT_TRUE(same(canonical(fourth), expected));
}

// With few segments against the triangles, segment_of_edge comes over the bus as its constraint words
// alone and the host writes kNoId into the rest: a result in blocks that held another input's result
// keeps nothing of it. 80000 segments: from 2^16 pieces the constraints run beside the split, and the
// host fills the array while it waits for them (DeviceMesh::prefill_segments); with fewer (the test
// above) output() fills it.
TEST_F(TriangulateGpu, PinnedSegmentsKeepNothingOfTheLastResult) {
  const auto a = trixel_gen::synthetic_pslg(800000, 80000, Distribution::uniform, 91);
  const auto b = trixel_gen::synthetic_pslg(800000, 80000, Distribution::uniform, 92);
  cdt::Options gpu;
  gpu.backend = cdt::Backend::gpu;
  const auto canonical = [](cdt::Triangulation t) {
    cdt::canonicalize(t);
    return t;
  };
  ASSERT_TRUE(cdt::keep_pinned_results(0));
  const cdt::Triangulation expected = canonical(cdt::triangulate(b.points, b.segments, gpu));
  ASSERT_TRUE(cdt::keep_pinned_results(std::size_t{256} << 20));
  std::vector<const void*> blocks_of_a;
  {
    const cdt::Triangulation first = cdt::triangulate(a.points, a.segments, gpu);
    blocks_of_a = {first.triangles.data(), first.neighbors.data(), first.segment_of_edge.data()};
  }
  const cdt::Triangulation second = cdt::triangulate(b.points, b.segments, gpu);
  const std::size_t bytes = second.segment_of_edge.size() * sizeof(second.segment_of_edge[0]);
  EXPECT_TRUE(cdt::gpu::in_result_block(second.segment_of_edge.data(), bytes));
  EXPECT_NE(std::find(blocks_of_a.begin(), blocks_of_a.end(), second.segment_of_edge.data()),
            blocks_of_a.end());
  const cdt::Triangulation got = canonical(second);
  EXPECT_TRUE(got.triangles == expected.triangles);
  EXPECT_TRUE(got.segment_of_edge == expected.segment_of_edge);
  EXPECT_GT(std::count_if(got.segment_of_edge.begin(), got.segment_of_edge.end(),
                          [](const std::array<std::uint32_t, 3>& s) { return s[0] != cdt::kNone; }),
            0);
  ASSERT_TRUE(cdt::keep_pinned_results(0));
}

// While the constraints run beside the split, the rows of the output that no corridor reaches are made
// and sent into the pinned result memory (DeviceMesh::start_early_output), numbered first; the others
// follow at the end, and early rows that changed after all (crossers: vertices added at the end, and
// flips past the corridors) are sent again (MeshGpu.OutputStartedEarlyIsTheOutputMadeAtTheEnd makes
// sure of both ways). Either way the result is the one made without it.
TEST_F(TriangulateGpu, OutputStartedEarlyMatchesTheOutputWithout) {
  const trixel_gen::Pslg plain = trixel_gen::synthetic_pslg(800000, 80000, Distribution::uniform, 93);
  trixel_gen::Pslg crossed = plain;
  trixel_gen::Random rng(94);
  trixel_gen::add_random_segments(crossed, 10, rng);
  cdt::Options gpu;
  gpu.backend = cdt::Backend::gpu;
  const auto canonical = [](cdt::Triangulation t) {
    cdt::canonicalize(t);
    return t;
  };
  for (const trixel_gen::Pslg* in : {&plain, static_cast<const trixel_gen::Pslg*>(&crossed)}) {
    const std::string what = in == &plain ? "synthetic" : "synthetic with crossers";
    ASSERT_TRUE(cdt::keep_pinned_results(0));
    const cdt::gpu::EarlyOutputRows before = cdt::gpu::early_output_rows();
    const cdt::Triangulation expected = canonical(cdt::triangulate(in->points, in->segments, gpu));
    EXPECT_EQ(cdt::gpu::early_output_rows().sent, before.sent) << what << ": not pinned, not early";
    ASSERT_TRUE(cdt::keep_pinned_results(std::size_t{256} << 20));
    const cdt::Triangulation t = cdt::triangulate(in->points, in->segments, gpu);
    const cdt::gpu::EarlyOutputRows after = cdt::gpu::early_output_rows();
    // Most rows lie away from the corridors of 80000 short and long segments among 1.6M triangles.
    EXPECT_GT(after.sent - before.sent, t.triangles.size() / 4) << what;
    const cdt::Triangulation got = canonical(t);
    EXPECT_TRUE(got.vertices == expected.vertices && got.triangles == expected.triangles &&
                got.neighbors == expected.neighbors && got.segment_of_edge == expected.segment_of_edge)
        << what;
    const cdt::VerifyReport report = cdt::verify(t, in->points, in->segments);
    EXPECT_TRUE(report.ok()) << what << ": " << (report.problems.empty() ? "" : report.problems.front());
  }
  ASSERT_TRUE(cdt::keep_pinned_results(0));
}

// Vertices added at crossings give a result more than 2n triangles (a lattice with random segments: one
// added vertex in 250 points); the room the output sets aside for them keeps it in the pinned result
// memory, which the device writes directly, instead of arrays grown outside it.
TEST_F(TriangulateGpu, PinnedResultsHoldTheSplitsVertices) {
  const auto in = trixel_gen::lattice_with_segments(1024, 1024 * 1024 / 16, 5);
  cdt::Options gpu;
  gpu.backend = cdt::Backend::gpu;
  ASSERT_TRUE(cdt::keep_pinned_results(std::size_t{512} << 20));
  const cdt::Triangulation t = cdt::triangulate(in.points, in.segments, gpu);
  EXPECT_GT(t.stats.added_vertices, 0u);
  EXPECT_GT(t.triangles.size(), 2 * in.points.size());
  const std::size_t bytes = t.triangles.size() * sizeof(t.triangles[0]);
  EXPECT_TRUE(cdt::gpu::in_result_block(t.triangles.data(), bytes) &&
              cdt::gpu::in_result_block(t.neighbors.data(), bytes) &&
              cdt::gpu::in_result_block(t.segment_of_edge.data(), bytes));
  const cdt::VerifyReport report = cdt::verify(t, in.points, in.segments);
  EXPECT_TRUE(report.ok()) << (report.problems.empty() ? "" : report.problems.front());
  ASSERT_TRUE(cdt::keep_pinned_results(0));
}

// The pinned result memory's blocks keep to their limit: one that does not fit beside the blocks in use
// is refused and the free ones stay for the next that fits; a free block is taken again by a request of
// its size; 0 frees them and refuses every request.
TEST_F(TriangulateGpu, PinnedBlocksKeepToTheirLimit) {
  constexpr std::size_t kMiB = std::size_t{1} << 20;
  cdt::gpu::set_result_blocks_limit(0);
  cdt::gpu::set_result_blocks_limit(64 * kMiB);
  void* const a = cdt::gpu::take_result_block(40 * kMiB);
  ASSERT_NE(a, nullptr);
  EXPECT_TRUE(cdt::gpu::in_result_block(a, 40 * kMiB));
  EXPECT_FALSE(cdt::gpu::in_result_block(a, 40 * kMiB + 2 * kMiB)); // beyond the block
  EXPECT_EQ(cdt::gpu::take_result_block(32 * kMiB), nullptr);       // 40 + 32 > 64
  void* const b = cdt::gpu::take_result_block(16 * kMiB);
  ASSERT_NE(b, nullptr);
  EXPECT_TRUE(cdt::gpu::give_back_result_block(b));
  EXPECT_FALSE(cdt::gpu::in_result_block(b, 1));
  EXPECT_EQ(cdt::gpu::take_result_block(32 * kMiB), nullptr); // the block in use leaves 24
  EXPECT_EQ(cdt::gpu::take_result_block(16 * kMiB), b);       // the free block stayed
  int local = 0;
  EXPECT_FALSE(cdt::gpu::give_back_result_block(&local));
  EXPECT_TRUE(cdt::gpu::give_back_result_block(b));
  EXPECT_TRUE(cdt::gpu::give_back_result_block(a));
  cdt::gpu::set_result_blocks_limit(0);
  EXPECT_EQ(cdt::gpu::take_result_block(16 * kMiB), nullptr);
}

// Crossing segments: the device screens them, the host splits the suspects, and the mesh comes back
// to the host for the crossing vertices and goes up again.
TEST_F(TriangulateGpu, CrossingSegmentsMatchTheCpuBackend) {
  trixel_gen::Pslg crossing = trixel_gen::random_points(3000, Distribution::uniform, 51);
  trixel_gen::Pslg synthetic = trixel_gen::synthetic_pslg(20000, 2000, Distribution::uniform, 52);
  trixel_gen::Random rng(53);
  trixel_gen::add_random_segments(crossing, 120, rng); // thousands of crossings
  trixel_gen::add_random_segments(synthetic, 10, rng); // mostly Delaunay edges, a few long ones across
  for (const auto* in : {&crossing, &synthetic}) {
    const std::string what = in == &crossing ? "random crossing segments" : "synthetic with crossers";
    expect_same_as_cpu(in->points, in->segments, what);
    cdt::Options gpu;
    gpu.backend = cdt::Backend::gpu;
    const cdt::Triangulation t = cdt::triangulate(in->points, in->segments, gpu);
    EXPECT_GT(t.stats.added_vertices, 0u) << what;
    const auto split = std::find_if(t.stats.phases.begin(), t.stats.phases.end(),
                                    [](const cdt::PhaseStats& p) { return p.name == "split"; });
    ASSERT_NE(split, t.stats.phases.end()) << what << ": screened, not split first";
    EXPECT_EQ(split->missing, t.stats.added_vertices) << what;
  }
}

// Nearly overlapping segments near 1, 1e15 and 1e-15, whose screened split can miss a crossing and
// start again splitting first: the same on the device.
TEST_F(TriangulateGpu, NearlyOverlappingSegmentsMatchTheCpuBackend) {
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    const trixel_gen::Pslg in = trixel_gen::nearly_overlapping(seed);
    try {
      expect_same_as_cpu(in.points, in.segments, "nearly overlapping, seed " + std::to_string(seed));
    } catch (const cdt::InvalidInputError&) {
      // all points collinear, say: the input checks' tests compare those
    }
  }
}

// Enough pieces for the constraints beside the split (2^16), some through points and some crossing: the
// run beside the split ends at its first walk and starts again without the suspects, whose pieces go in
// after the crossing vertices.
TEST_F(TriangulateGpu, PiecesThroughPointsAndCrossingsBesideTheSplitMatchTheCpuBackend) {
  trixel_gen::Pslg in = trixel_gen::synthetic_pslg(150000, 70000, Distribution::uniform, 54);
  ASSERT_GE(in.segments.size(), std::size_t{1} << 16);
  // Short horizontal runs of three points, exactly collinear, each with a segment over all three.
  for (std::uint32_t k = 0; k < 20; ++k) {
    const auto first = static_cast<std::uint32_t>(in.points.size());
    const double x = 0.03125 + 0.046875 * k, y = 0.0078125 + 0.046875 * k;
    for (std::uint32_t i = 0; i < 3; ++i) in.points.push_back({x + i * 0x1p-21, y});
    in.segments.push_back({first, first + 2});
  }
  trixel_gen::Random rng(55);
  trixel_gen::add_random_segments(in, 6, rng); // long ones, across many
  expect_same_as_cpu(in.points, in.segments, "pieces through points, crossings");
  cdt::Options gpu;
  gpu.backend = cdt::Backend::gpu;
  const cdt::Triangulation t = cdt::triangulate(in.points, in.segments, gpu);
  EXPECT_GT(t.stats.added_vertices, 0u);
  EXPECT_EQ(t.stats.attempts, 1u); // the added vertices went into the constrained mesh
}

// Co-circular everywhere: many ties in the diagram and in every flip.
TEST_F(TriangulateGpu, LatticesMatchTheCpuBackend) {
  for (std::uint32_t k : {10u, 64u, 200u}) {
    const auto in = trixel_gen::lattice_with_segments(k, k, k);
    expect_same_as_cpu(in.points, in.segments, "lattice " + std::to_string(k));
  }
  const auto bare = trixel_gen::lattice(128);
  expect_same_as_cpu(bare.points, bare.segments, "lattice 128 without segments");
}

// Co-circular everywhere and every edge constrained: a lattice whose every triangle edge is a segment
// (each cell split by a diagonal, alternating), and the same lattice with five segments.
TEST_F(TriangulateGpu, EveryEdgeASegmentMatchesTheCpuBackend) {
  constexpr std::uint32_t k = 120;
  trixel_gen::Pslg all = trixel_gen::lattice(k);
  const auto id = [&](std::uint32_t x, std::uint32_t y) { return y * k + x; };
  for (std::uint32_t y = 0; y < k; ++y) {
    for (std::uint32_t x = 0; x < k; ++x) {
      if (x + 1 < k) all.segments.push_back({id(x, y), id(x + 1, y)});
      if (y + 1 < k) all.segments.push_back({id(x, y), id(x, y + 1)});
      if (x + 1 < k && y + 1 < k) {
        if ((x + y) % 2 == 0)
          all.segments.push_back({id(x, y), id(x + 1, y + 1)});
        else
          all.segments.push_back({id(x + 1, y), id(x, y + 1)});
      }
    }
  }
  expect_same_as_cpu(all.points, all.segments, "lattice with every edge a segment");
  cdt::Options gpu;
  gpu.backend = cdt::Backend::gpu;
  const cdt::Triangulation t = cdt::triangulate(all.points, all.segments, gpu);
  std::size_t constrained = 0;
  for (const auto& words : t.segment_of_edge)
    for (const std::uint32_t w : words) constrained += w != cdt::kNone ? 1 : 0;
  EXPECT_EQ(constrained, 3 * t.triangles.size()); // every edge of every triangle
  const auto few = trixel_gen::lattice_with_segments(k, 5, 9);
  expect_same_as_cpu(few.points, few.segments, "lattice with five segments");
}

TEST_F(TriangulateGpu, ArtemOgreFilesMatchTheCpuBackend) {
  const int files =
      trixel_test::for_each_artem_ogre_file([](const std::string& name, const cdt::io::Pslg& in) {
        expect_same_as_cpu(in.points, in.segments, name);
      });
  EXPECT_EQ(files, trixel_test::kArtemOgreFiles);
}

/// The InvalidInputError a triangulation throws, as (kind, item, message); kind -1 when it throws none.
struct Outcome {
  int kind = -1;
  std::uint64_t item = 0;
  std::string message;
  std::size_t zero_length_segments = 0;
  bool operator==(const Outcome&) const = default;
};

Outcome outcome_of(const std::vector<cdt::Point>& points, const std::vector<cdt::Segment>& segments,
                   cdt::Backend backend, cdt::CrossingSegments crossings) {
  cdt::Options options;
  options.backend = backend;
  options.crossings = crossings;
  Outcome out;
  try {
    out.zero_length_segments = cdt::triangulate(points, segments, options).stats.zero_length_segments;
  } catch (const cdt::InvalidInputError& e) {
    out.kind = static_cast<int>(e.kind());
    out.item = e.item();
    out.message = e.what();
  }
  return out;
}

// The input checks run on the device with the GPU backend: every bad input gets the CPU backend's error
// (the same kind, point or segment and message: the lowest bad point first, then the lowest bad
// segment), and the zero-length segments that resolve ignores are counted alike.
TEST_F(TriangulateGpu, BadInputsGetTheCpuBackendsErrors) {
  const std::vector<cdt::Point> square = {{0, 0}, {4, 0}, {4, 4}, {0, 4}, {1, 1}, {3, 1}, {2, 3}, {1, 3}};
  const std::vector<cdt::Segment> sides = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 6}};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    std::string name;
    std::vector<cdt::Point> points;
    std::vector<cdt::Segment> segments;
    int kind;             // the error expected under reject
    std::uint64_t item;   // its point or segment
    int resolve_kind = 0; // under resolve, when not `kind`: -1 for none
    std::uint64_t resolve_item = 0;
  };
  using Kind = cdt::InvalidInputError::Kind;
  std::vector<Case> cases;
  const auto with_point = [&](std::size_t i, cdt::Point p) {
    std::vector<cdt::Point> points = square;
    points[i] = p;
    return points;
  };
  const auto with_segments = [&](std::vector<cdt::Segment> more) {
    std::vector<cdt::Segment> segments = sides;
    segments.insert(segments.end(), more.begin(), more.end());
    return segments;
  };
  const int none = -1;
  cases.push_back({"NaN", with_point(5, {1.0, nan}), sides, int(Kind::non_finite_coordinate), 5});
  std::vector<cdt::Point> two_bad = with_point(6, {nan, 0});
  two_bad[3] = {inf, 1};
  cases.push_back({"infinity before NaN", two_bad, sides, int(Kind::non_finite_coordinate), 3});
  cases.push_back(
      {"beyond the range", with_point(2, {4, -2e60}), sides, int(Kind::coordinate_out_of_range), 2});
  cases.push_back(
      {"below the range", with_point(4, {1e-300, 3}), sides, int(Kind::coordinate_out_of_range), 4});
  cases.push_back({"bad point and bad segment", with_point(7, {inf, inf}), with_segments({{0, 99}}),
                   int(Kind::non_finite_coordinate), 7});
  cases.push_back({"ends beyond the points", square, with_segments({{5, 7}, {2, 8}, {9, 1}}),
                   int(Kind::index_out_of_range), 6});
  cases.push_back(
      {"a point to itself", square, with_segments({{5, 5}, {1, 7}}), int(Kind::degenerate_segment), 5, none});
  std::vector<cdt::Point> copied = square;
  copied.push_back(copied[5]);
  cases.push_back({"two copies of a point", copied, with_segments({{1, 7}, {8, 5}}),
                   int(Kind::degenerate_segment), 6, none});
  cases.push_back({"zero length before an end beyond", square, with_segments({{5, 5}, {2, 8}}),
                   int(Kind::degenerate_segment), 5, int(Kind::index_out_of_range), 6});
  cases.push_back({"no points", {}, {}, int(Kind::too_few_points), 0});
  cases.push_back({"two points", {{0, 0}, {1, 1}}, {{0, 1}}, int(Kind::too_few_points), 2});
  cases.push_back({"collinear", {{0, 0}, {1, 1}, {2, 2}, {3, 3}}, {}, int(Kind::all_collinear), 4});
  // The first two points one: the line is the first and the next distinct point's.
  cases.push_back({"collinear, copies first",
                   {{0, 0}, {0, 0}, {2, 2}, {0, 0}, {1, 1}, {-3, -3}},
                   {},
                   int(Kind::all_collinear),
                   4});
  cases.push_back({"copies first, then off the line", {{0, 0}, {0, 0}, {2, 2}, {1, 1}, {1, 0}}, {}, none, 0});
  cases.push_back({"four copies of two points",
                   {{1, 1}, {1, 1}, {2, 3}, {1, 1}},
                   {{0, 2}},
                   int(Kind::too_few_points),
                   2});
  std::size_t zero_length_seen = 0;
  for (const Case& c : cases) {
    for (const auto crossings : {cdt::CrossingSegments::resolve, cdt::CrossingSegments::reject}) {
      const std::string what =
          c.name + (crossings == cdt::CrossingSegments::reject ? " (reject)" : " (resolve)");
      const Outcome cpu = outcome_of(c.points, c.segments, cdt::Backend::cpu, crossings);
      const Outcome gpu = outcome_of(c.points, c.segments, cdt::Backend::gpu, crossings);
      EXPECT_EQ(gpu, cpu) << what << ": gpu " << gpu.kind << " " << gpu.item << " '" << gpu.message
                          << "', cpu " << cpu.kind << " " << cpu.item << " '" << cpu.message << "'";
      // Zero-length segments are an error only under reject.
      const bool resolving = crossings == cdt::CrossingSegments::resolve && c.resolve_kind != 0;
      EXPECT_EQ(cpu.kind, resolving ? c.resolve_kind : c.kind) << what;
      if (cpu.kind >= 0) {
        EXPECT_EQ(cpu.item, resolving ? c.resolve_item : c.item) << what;
      } else {
        zero_length_seen += cpu.zero_length_segments;
      }
    }
  }
  EXPECT_EQ(zero_length_seen, 2u); // {5, 5}, and {8, 5} between two copies of a point
}

} // namespace

// triangulate_many on the device: framed inputs in one call, each cut back to exactly the CDT the CPU
// backend makes of it alone; an input with a crossing (a vertex added) and an unframed one alone.
TEST(TriangulateManyGpu, FramedInputsMatchTheCpuBackendAlone) {
  if (cdt::gpu_device_count() == 0) GTEST_SKIP() << "no CUDA device";
  std::vector<trixel_gen::Pslg> pslgs;
  for (int k = 0; k < 12; ++k)
    pslgs.push_back(trixel_gen::framed_pixels(40 + 37 * k, 30 + 23 * (k % 5), 300 + k, k % 3));
  trixel_gen::Pslg crossing = trixel_gen::framed_pixels(60, 50, 400);
  const auto first = static_cast<std::uint32_t>(crossing.points.size());
  crossing.points.insert(crossing.points.end(), {{3.5, 3.5}, {6.5, 6.5}, {3.5, 6.5}, {6.5, 3.5}});
  crossing.segments.insert(crossing.segments.end(), {{first, first + 1}, {first + 2, first + 3}});
  pslgs.push_back(crossing);
  pslgs.push_back(trixel_gen::random_points(5000, Distribution::uniform, 401));
  std::vector<cdt::Input> inputs;
  for (const auto& p : pslgs) inputs.push_back({p.points, p.segments});
  cdt::Options gpu;
  gpu.backend = cdt::Backend::gpu;
  cdt::Options cpu;
  cpu.backend = cdt::Backend::cpu;
  const std::vector<cdt::ManyResult> got = cdt::triangulate_many(inputs, gpu);
  ASSERT_EQ(got.size(), pslgs.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    const std::string what = "input " + std::to_string(i);
    ASSERT_FALSE(got[i].error) << what;
    cdt::Triangulation mine = got[i].triangulation;
    EXPECT_EQ(mine.stats.backend.rfind("gpu", 0), 0u) << what << ": backend " << mine.stats.backend;
    EXPECT_EQ(mine.stats.inputs, i < 12 ? 13u : 1u)
        << what; // the crossing input shared a call, then went alone
    const cdt::VerifyReport report = cdt::verify(mine, pslgs[i].points, pslgs[i].segments);
    EXPECT_TRUE(report.ok()) << what << ": " << (report.problems.empty() ? "" : report.problems.front());
    cdt::Triangulation alone = cdt::triangulate(pslgs[i].points, pslgs[i].segments, cpu);
    cdt::canonicalize(mine);
    cdt::canonicalize(alone);
    EXPECT_TRUE(mine.vertices == alone.vertices && mine.triangles == alone.triangles &&
                mine.neighbors == alone.neighbors && mine.segment_of_edge == alone.segment_of_edge)
        << what << ": canonical arrays differ from the CPU backend's";
  }
}
