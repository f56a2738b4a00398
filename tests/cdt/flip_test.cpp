// Tests of Phase 5 / Step 3 (paper section 3.5): parallel Lawson flipping and the two-step batch flip.

#include "gcd/flip.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"
#include "mesh_test_util.hpp"
#include "pslg_generators.hpp"

namespace {

using namespace cdt::detail;
using trixel_test::expect_valid_mesh;
using trixel_test::is_locally_delaunay;
using trixel_test::sweep_triangulate;
using trixel_test::triangle_set;

struct Points {
  std::vector<double> x, y;
};

Points from_pslg(const trixel_gen::Pslg& p) {
  Points out;
  for (const auto& q : p.points) {
    out.x.push_back(q.x);
    out.y.push_back(q.y);
  }
  return out;
}

Points uniform_points(std::size_t n, std::uint64_t seed) {
  return from_pslg(trixel_gen::random_points(n, trixel_gen::Distribution::uniform, seed));
}

using FlipFunction = FlipStats (*)(Mesh&, CpuExecutor&, const std::uint8_t*);

// The two schedules of the same flips: parallel rounds (the device's), and parts with the rounds
// for what lies between them (the CPU backend's).
struct Schedule {
  const char* name;
  FlipFunction flip;
};
constexpr Schedule kSchedules[] = {{"rounds", &flip_to_delaunay}, {"parts", &flip_to_delaunay_in_parts}};

// Runs the parallel flipping on a copy.
Mesh flipped(const Mesh& input, unsigned threads, FlipStats* stats = nullptr,
             FlipFunction flip = &flip_to_delaunay) {
  Mesh mesh = input;
  CpuExecutor executor(threads);
  const FlipStats s = flip(mesh, executor, nullptr);
  if (stats) *stats = s;
  return mesh;
}

// Edges whose pairs are disjoint and strictly convex, one per pair, in slot order: a batch that can
// flip at once.
std::vector<std::uint32_t> disjoint_convex_edges(const Mesh& input) {
  const MeshView view = const_cast<Mesh&>(input).view();
  std::vector<char> taken(input.num_slots(), 0);
  std::vector<std::uint32_t> edges;
  for (std::uint32_t t = 0; t < input.num_slots(); ++t) {
    if (taken[t]) continue;
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t e = input.adj[3 * t + i];
      if (e == kNoId || taken[e / 3] || !flip_is_convex(view, t, i)) continue;
      taken[t] = taken[e / 3] = 1;
      edges.push_back(3 * t + i);
      break;
    }
  }
  return edges;
}

TEST(FlipTestUtil, SweepTriangulatorIsValid) {
  // The reference triangulator itself, on inputs with collinear starts and collinear hull chains.
  for (const auto& p :
       {trixel_gen::lattice(7), trixel_gen::random_points(300, trixel_gen::Distribution::uniform, 3)}) {
    const Points pts = from_pslg(p);
    const Mesh mesh = sweep_triangulate(pts.x, pts.y);
    expect_valid_mesh(mesh);
    // Every point used: 2n - 2 - h triangles with h points on the hull boundary (the boundary edges).
    std::size_t boundary = 0;
    for (const std::uint32_t e : mesh.adj) boundary += e == kNoId;
    EXPECT_EQ(triangle_set(mesh).size(), 2 * pts.x.size() - 2 - boundary);
  }
  // All collinear: no triangle.
  EXPECT_TRUE(triangle_set(sweep_triangulate({0, 1, 2, 3}, {0, 1, 2, 3})).empty());
}

TEST(FlipToDelaunay, RandomUniformMatchesSerialReference) {
  for (const Schedule& schedule : kSchedules) {
    for (const std::size_t n : {10u, 100u, 1000u, 10000u, 60000u}) {
      const Points pts = uniform_points(n, 100 + n);
      const Mesh input = sweep_triangulate(pts.x, pts.y);
      FlipStats stats;
      const Mesh mesh = flipped(input, 4, &stats, schedule.flip);
      expect_valid_mesh(mesh);
      EXPECT_TRUE(is_locally_delaunay(mesh)) << schedule.name << " " << n;
      Mesh reference = input;
      trixel_test::serial_lawson(reference);
      // In general position the Delaunay triangulation is unique.
      EXPECT_EQ(triangle_set(mesh), triangle_set(reference)) << schedule.name << " " << n;
      EXPECT_TRUE(n < 100 || stats.flips > 0) << schedule.name << " " << n;
    }
  }
}

TEST(FlipToDelaunayInParts, ManyPartsGiveTheSameMeshForAnyThreadCount) {
  // 60000 points give about 120000 slots, several parts; the sweep numbers its triangles from left to
  // right, so each part is a strip and most flips stay inside one. The parts are fixed, so every thread
  // count gives the same mesh, vertex array included.
  const Points pts = uniform_points(60000, 31);
  const Mesh input = sweep_triangulate(pts.x, pts.y);
  ASSERT_GT(input.num_slots(), 100000u);
  FlipStats one_stats, two_stats, four_stats, rounds_stats;
  const Mesh one = flipped(input, 1, &one_stats, &flip_to_delaunay_in_parts);
  const Mesh two = flipped(input, 2, &two_stats, &flip_to_delaunay_in_parts);
  const Mesh four = flipped(input, 4, &four_stats, &flip_to_delaunay_in_parts);
  expect_valid_mesh(four);
  EXPECT_TRUE(is_locally_delaunay(four));
  EXPECT_EQ(one.tri, two.tri);
  EXPECT_EQ(one.tri, four.tri);
  EXPECT_EQ(one.adj, four.adj);
  EXPECT_EQ(one.vert_tri, two.vert_tri);
  EXPECT_EQ(one.vert_tri, four.vert_tri);
  EXPECT_EQ(one_stats.flips, four_stats.flips);
  EXPECT_EQ(one_stats.rounds, four_stats.rounds);
  // The same Delaunay triangulation as the parallel rounds, in fewer rounds: the parts made part of
  // the flips on their own.
  const Mesh rounds = flipped(input, 2, &rounds_stats, &flip_to_delaunay);
  EXPECT_EQ(triangle_set(four), triangle_set(rounds));
  EXPECT_LT(four_stats.rounds, rounds_stats.rounds);
}

TEST(FlipToDelaunay, SingleAndFourThreadsAgree) {
  // Claims depend only on slot indices, so the rounds are the same however threads interleave.
  const Points pts = uniform_points(20000, 7);
  const Mesh input = sweep_triangulate(pts.x, pts.y);
  FlipStats one_stats, four_stats;
  const Mesh one = flipped(input, 1, &one_stats);
  const Mesh four = flipped(input, 4, &four_stats);
  EXPECT_EQ(triangle_set(one), triangle_set(four));
  EXPECT_EQ(one.tri, four.tri);
  EXPECT_EQ(one.adj, four.adj);
  EXPECT_EQ(one_stats.flips, four_stats.flips);
  EXPECT_EQ(one_stats.rounds, four_stats.rounds);
  expect_valid_mesh(four);
}

TEST(FlipToDelaunay, LatticeTerminates) {
  // A pixel lattice is co-circular everywhere: flipping on incircle == 0 would never stop.
  for (const Schedule& schedule : kSchedules) {
    for (const std::uint32_t k : {2u, 3u, 10u, 40u, 200u}) {
      const Points pts = from_pslg(trixel_gen::lattice(k));
      const Mesh input = sweep_triangulate(pts.x, pts.y);
      const Mesh mesh = flipped(input, 4, nullptr, schedule.flip);
      expect_valid_mesh(mesh);
      EXPECT_TRUE(is_locally_delaunay(mesh)) << schedule.name << " " << k;
      EXPECT_EQ(triangle_set(mesh).size(), 2u * (k - 1) * (k - 1)) << schedule.name << " " << k;
      EXPECT_EQ(mesh.tri, flipped(input, 1, nullptr, schedule.flip).tri) << schedule.name << " " << k;
    }
  }
}

TEST(FlipToDelaunay, LatticeWithJitteredPointsStaysValid) {
  // Half the lattice shifted by a few ulps: near-degenerate incircle signs decided by the exact path.
  const std::uint32_t k = 30;
  Points pts = from_pslg(trixel_gen::lattice(k));
  trixel_gen::Random rng(5);
  for (std::size_t i = 0; i < pts.x.size(); i += 2) {
    pts.x[i] = std::nextafter(pts.x[i], rng.unit() < 0.5 ? -1e9 : 1e9);
  }
  const Mesh mesh = flipped(sweep_triangulate(pts.x, pts.y), 4);
  expect_valid_mesh(mesh);
  EXPECT_TRUE(is_locally_delaunay(mesh));
}

TEST(FlipCandidate, FiltersAloneProposeTheSameOrSayUndecided) {
  // The device proposes with the predicates' filters first and asks the exact tests only where they
  // could not decide: on a jittered lattice (many near-degenerate quadruples) and on random points, a
  // decided filtered test must be the exact one, and a proposal without an undecided test the same.
  const std::uint32_t k = 30;
  const Points lattice = from_pslg(trixel_gen::lattice(k));
  Points jittered = lattice;
  trixel_gen::Random rng(9);
  for (std::size_t i = 0; i < jittered.x.size(); i += 3) {
    jittered.y[i] = std::nextafter(jittered.y[i], rng.unit() < 0.5 ? -1e9 : 1e9);
  }
  std::size_t undecided_tests = 0, decided_tests = 0, undecided_proposals = 0, proposals = 0;
  // The lattice's Delaunay mesh: every cell's diagonal is an edge of four co-circular points.
  const Points uniform = uniform_points(3000, 4);
  std::vector<Mesh> meshes{flipped(sweep_triangulate(lattice.x, lattice.y), 1),
                           sweep_triangulate(jittered.x, jittered.y),
                           sweep_triangulate(uniform.x, uniform.y)};
  for (Mesh& mesh : meshes) {
    const MeshView m = mesh.view();
    const std::vector<std::uint8_t> active(mesh.num_slots(), 0);
    const std::vector<std::uint32_t> partner(mesh.num_slots(), kNoId);
    for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
      for (std::uint32_t i = 0; i < 3; ++i) {
        const int filtered = edge_flip_test<false>(m, t, i);
        if (filtered == kUndecided) {
          ++undecided_tests;
          continue;
        }
        ++decided_tests;
        ASSERT_EQ(filtered, edge_flip_test<true>(m, t, i)) << t << " " << i;
      }
      bool undecided = false;
      const std::uint32_t e = delaunay_flip_candidate<false>(m, active.data(), partner.data(), t, &undecided);
      const std::uint32_t exact = delaunay_flip_candidate(m, active.data(), partner.data(), t);
      if (undecided) {
        ++undecided_proposals;
        continue;
      }
      if (exact != kNoId) ++proposals;
      ASSERT_EQ(e, exact) << t;
    }
  }
  EXPECT_GT(undecided_tests, 100u);
  EXPECT_GT(decided_tests, 1000u);
  EXPECT_GT(undecided_proposals, 10u);
  EXPECT_GT(proposals, 100u);
}

TEST(FlipToDelaunay, PointsOnACircle) {
  // Rounded cosines are only nearly co-circular: the exact signs are arbitrary but must be consistent.
  {
    Points pts;
    for (int i = 0; i < 500; ++i) {
      pts.x.push_back(std::cos(2 * 3.141592653589793 * i / 500));
      pts.y.push_back(std::sin(2 * 3.141592653589793 * i / 500));
    }
    pts.x.push_back(0.0);
    pts.y.push_back(0.0);
    const Mesh mesh = flipped(sweep_triangulate(pts.x, pts.y), 4);
    expect_valid_mesh(mesh);
    EXPECT_TRUE(is_locally_delaunay(mesh));
  }
  // Exactly co-circular: the 48 integer points with x^2 + y^2 = 5525, a sweep gives a fan of slivers.
  {
    Points pts;
    for (int xi = -75; xi <= 75; ++xi)
      for (int yi = -75; yi <= 75; ++yi)
        if (xi * xi + yi * yi == 5525) {
          pts.x.push_back(xi);
          pts.y.push_back(yi);
        }
    ASSERT_EQ(pts.x.size(), 48u);
    const Mesh input = sweep_triangulate(pts.x, pts.y);
    FlipStats stats;
    const Mesh mesh = flipped(input, 4, &stats);
    expect_valid_mesh(mesh);
    EXPECT_TRUE(is_locally_delaunay(mesh));
    EXPECT_EQ(stats.flips, 0u) << "every quadrilateral is co-circular";
  }
}

TEST(FlipToDelaunay, ClusteredPoints) {
  const Points pts = from_pslg(trixel_gen::clustered(5000, 7, 11));
  const Mesh input = sweep_triangulate(pts.x, pts.y);
  Mesh reference = input;
  trixel_test::serial_lawson(reference);
  for (const Schedule& schedule : kSchedules) {
    const Mesh mesh = flipped(input, 4, nullptr, schedule.flip);
    expect_valid_mesh(mesh);
    EXPECT_TRUE(is_locally_delaunay(mesh)) << schedule.name;
    EXPECT_EQ(triangle_set(mesh), triangle_set(reference)) << schedule.name;
  }
}

TEST(FlipToDelaunay, ConstraintEdgesAreNeverFlipped) {
  // Random edges fixed as constraints: the result is their constrained Delaunay triangulation.
  const Points pts = uniform_points(3000, 21);
  Mesh input = sweep_triangulate(pts.x, pts.y);
  trixel_gen::Random rng(4);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> fixed;
  for (std::uint32_t t = 0; t < input.num_slots(); ++t) {
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t e = input.adj[3 * t + i];
      if (e == kNoId || e < 3 * t + i || rng.unit() > 0.05) continue;
      const std::uint32_t id = static_cast<std::uint32_t>(fixed.size());
      input.seg[3 * t + i] = id;
      input.seg[e] = id;
      fixed.emplace_back(input.tri[3 * t + next3(i)], input.tri[3 * t + prev3(i)]);
    }
  }
  ASSERT_GT(fixed.size(), 100u);
  Mesh reference = input;
  trixel_test::serial_lawson(reference);
  for (const Schedule& schedule : kSchedules) {
    FlipStats stats;
    const Mesh mesh = flipped(input, 4, &stats, schedule.flip);
    EXPECT_GT(stats.flips, 0u) << schedule.name;
    expect_valid_mesh(mesh);
    EXPECT_TRUE(is_locally_delaunay(mesh)) << schedule.name;
    for (std::uint32_t id = 0; id < fixed.size(); ++id) {
      const std::uint32_t e = trixel_test::find_edge(mesh, fixed[id].first, fixed[id].second);
      ASSERT_NE(e, kNoId) << schedule.name << ": constraint " << id << " was flipped away";
      EXPECT_EQ(mesh.seg[e], id) << schedule.name;
    }
    EXPECT_EQ(triangle_set(mesh), triangle_set(reference)) << schedule.name;
  }
}

TEST(FlipToDelaunay, DelaunayInputNeedsNoFlip) {
  const Points pts = uniform_points(2000, 8);
  const Mesh once = flipped(sweep_triangulate(pts.x, pts.y), 2);
  FlipStats stats;
  const Mesh twice = flipped(once, 2, &stats);
  EXPECT_EQ(stats.flips, 0u);
  EXPECT_EQ(stats.rounds, 1u);
  EXPECT_EQ(twice.tri, once.tri);
}

TEST(FlipToDelaunay, OnlyTheGivenSlotsAreCheckedAtFirst) {
  // A Delaunay mesh with a few edges flipped back: starting from those pairs' slots is enough, and with
  // no slot given nothing is checked, so nothing flips.
  const Points pts = uniform_points(3000, 77);
  Mesh mesh = flipped(sweep_triangulate(pts.x, pts.y), 2);
  const Mesh reference = mesh;
  std::vector<std::uint8_t> only(mesh.num_slots(), 0);
  std::size_t undone = 0;
  for (std::uint32_t t = 0; t < mesh.num_slots() && undone < 40; t += 61) {
    const MeshView m = mesh.view();
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t e = m.adj[3 * t + i];
      if (e == kNoId || only[t] || only[edge_tri(e)] || !flip_is_convex(m, t, i)) continue;
      only[t] = only[edge_tri(e)] = 1;
      flip_edge(m, t, i);
      ++undone;
      break;
    }
  }
  ASSERT_GT(undone, 20u);
  ASSERT_FALSE(is_locally_delaunay(mesh));
  CpuExecutor executor(2);
  for (const Schedule& schedule : kSchedules) {
    Mesh untouched = mesh;
    const std::vector<std::uint8_t> none(mesh.num_slots(), 0);
    const FlipStats idle = schedule.flip(untouched, executor, none.data());
    EXPECT_EQ(idle.flips, 0u) << schedule.name;
    EXPECT_EQ(idle.rounds, 0u) << schedule.name;
    Mesh fixed = mesh;
    const FlipStats stats = schedule.flip(fixed, executor, only.data());
    expect_valid_mesh(fixed);
    EXPECT_TRUE(is_locally_delaunay(fixed)) << schedule.name;
    EXPECT_EQ(triangle_set(fixed), triangle_set(reference)) << schedule.name;
    EXPECT_GE(stats.flips, undone) << schedule.name;
  }
}

TEST(FlipToDelaunay, TinyAndEmptyMeshes) {
  for (const Schedule& schedule : kSchedules) {
    Mesh empty;
    CpuExecutor executor(2);
    EXPECT_EQ(schedule.flip(empty, executor, nullptr).flips, 0u) << schedule.name;
    const Mesh one = trixel_test::mesh_from_triangles({0, 1, 0}, {0, 0, 1}, {{0, 1, 2}});
    FlipStats stats;
    const Mesh out = flipped(one, 2, &stats, schedule.flip);
    EXPECT_EQ(stats.flips, 0u) << schedule.name;
    expect_valid_mesh(out);
    // Two triangles whose shared edge fails: exactly one flip, to the other diagonal.
    const Mesh quad = trixel_test::mesh_from_triangles({0, 10, 9, 0}, {0, 0, 9, 10}, {{0, 1, 3}, {1, 2, 3}});
    const Mesh fixed = flipped(quad, 2, &stats, schedule.flip);
    EXPECT_EQ(stats.flips, 1u) << schedule.name;
    expect_valid_mesh(fixed);
    EXPECT_NE(trixel_test::find_edge(fixed, 0, 2), kNoId) << schedule.name;
  }
}

TEST(FlipBatch, MatchesSequentialFlipEdge) {
  // Disjoint pairs that border each other flip in one batch: the two-step update must give exactly the
  // arrays of flipping them one after the other with flip_edge (which updates outer links directly).
  const Points pts = uniform_points(4000, 31);
  const Mesh input = sweep_triangulate(pts.x, pts.y);
  const std::vector<std::uint32_t> edges = disjoint_convex_edges(input);
  ASSERT_GT(edges.size(), 1000u);
  Mesh sequential = input;
  for (const std::uint32_t e : edges) flip_edge(sequential.view(), e / 3, e % 3);
  Mesh batched = input;
  CpuExecutor executor(4);
  FlipBatch batch(batched.num_slots());
  batch.apply(batched, edges, executor);
  EXPECT_EQ(batched.tri, sequential.tri);
  EXPECT_EQ(batched.adj, sequential.adj);
  EXPECT_EQ(batched.seg, sequential.seg);
  expect_valid_mesh(batched);
  for (const std::uint32_t e : edges) {
    EXPECT_EQ(batch.partner()[e / 3], sequential.adj[3 * (e / 3) + 1] / 3);
  }
  // A second batch through the same scratch flips the diagonals back.
  std::vector<std::uint32_t> back;
  for (const std::uint32_t e : edges) back.push_back(3 * (e / 3) + 1);
  batch.apply(batched, back, executor);
  EXPECT_EQ(triangle_set(batched), triangle_set(input));
  expect_valid_mesh(batched);
}

TEST(FlipWithoutIds, AViewWithoutConstraintIdsFlipsAsOneWithThemAllNone) {
  // The device's flips before the constraints take a view whose seg is null (every id kNoId): the
  // tests read kNoId and the rewrites skip the ids. On a mesh whose ids are all kNoId that must give
  // the same proposals, the same vertices, links and vertex triangles, and leave the ids as they were.
  const Points pts = uniform_points(3000, 77);
  const Mesh input = sweep_triangulate(pts.x, pts.y);
  ASSERT_TRUE(std::all_of(input.seg.begin(), input.seg.end(), [](std::uint32_t s) { return s == kNoId; }));
  Mesh with_ids = input, without = input;
  MeshView full = with_ids.view();
  MeshView bare = without.view();
  bare.seg = nullptr;
  const std::vector<std::uint8_t> active(input.num_slots(), 0);
  const std::vector<std::uint32_t> partner(input.num_slots(), kNoId);
  std::size_t proposals = 0;
  for (std::uint32_t t = 0; t < input.num_slots(); ++t) {
    for (std::uint32_t i = 0; i < 3; ++i) {
      ASSERT_EQ(edge_flip_test<true>(bare, t, i), edge_flip_test<true>(full, t, i)) << t << " " << i;
      ASSERT_EQ(edge_flip_test<false>(bare, t, i), edge_flip_test<false>(full, t, i)) << t << " " << i;
    }
    const std::uint32_t e = delaunay_flip_candidate(full, active.data(), partner.data(), t);
    ASSERT_EQ(delaunay_flip_candidate(bare, active.data(), partner.data(), t), e) << t;
    if (e != kNoId) ++proposals;
    // Real and "fake" vertices split at the middle index: the fans' rule reads the ids too.
    const auto first_fake = static_cast<std::uint32_t>(pts.x.size() / 2);
    ASSERT_EQ(fake_fan_candidate(bare, active.data(), t, first_fake),
              fake_fan_candidate(full, active.data(), t, first_fake))
        << t;
  }
  EXPECT_GT(proposals, 100u);
  // Flip every convex edge of a disjoint set of pairs, one by one, through both views.
  const std::vector<std::uint32_t> edges = disjoint_convex_edges(input);
  ASSERT_GT(edges.size(), 1000u);
  for (const std::uint32_t e : edges) {
    flip_edge(full, e / 3, e % 3);
    flip_edge(bare, e / 3, e % 3);
  }
  EXPECT_EQ(without.tri, with_ids.tri);
  EXPECT_EQ(without.adj, with_ids.adj);
  EXPECT_EQ(without.vert_tri, with_ids.vert_tri);
  EXPECT_EQ(without.seg, input.seg);
  EXPECT_EQ(with_ids.seg, input.seg);
  EXPECT_NE(with_ids.tri, input.tri);
  expect_valid_mesh(without);
}

// link_triangles, which every phase that rebuilds a mesh relies on: the links and each vertex's triangle
// (the highest live slot that has it) do not depend on the thread count, and free slots are skipped.
TEST(LinkTriangles, SameLinksAndVertexTrianglesWhateverTheThreads) {
  const Points p = from_pslg(trixel_gen::random_points(20000, trixel_gen::Distribution::gaussian, 17));
  Mesh serial = sweep_triangulate(p.x, p.y);
  // Free a few slots (a free slot's first vertex is kNoId): their triangles disappear from the links.
  for (std::uint32_t t = 0; t < serial.num_slots(); t += 997) serial.tri[3 * t] = kNoId;
  Mesh parallel = serial;
  CpuExecutor one(1);
  CpuExecutor four(4);
  link_triangles(serial, one);
  link_triangles(parallel, four);
  EXPECT_EQ(parallel.adj, serial.adj);
  EXPECT_EQ(parallel.vert_tri, serial.vert_tri);
  std::vector<std::uint32_t> highest(serial.num_vertices(), kNoId);
  for (std::uint32_t t = 0; t < serial.num_slots(); ++t) {
    if (!serial.alive(t)) continue;
    for (std::uint32_t i = 0; i < 3; ++i) highest[serial.tri[3 * t + i]] = t;
  }
  EXPECT_EQ(serial.vert_tri, highest);
  for (std::uint32_t e = 0; e < serial.adj.size(); ++e) {
    const std::uint32_t f = serial.adj[e];
    if (f == kNoId) continue;
    ASSERT_TRUE(serial.alive(edge_tri(e)));
    ASSERT_TRUE(serial.alive(edge_tri(f)));
    ASSERT_EQ(serial.adj[f], e);
  }
}

TEST(LinkTriangles, AnEdgeOfThreeTrianglesIsAnErrorWhateverTheThreads) {
  // Triangles (0, 1, 2), (1, 0, 3) and (0, 1, 4) all have edge 0-1; the first two use it in opposite
  // directions, the third again from 0 to 1.
  Mesh mesh;
  mesh.xy = {{0, 0}, {1, 0}, {0.5, 1}, {0.5, -1}, {0.2, 2}};
  mesh.add_triangle(0, 1, 2);
  mesh.add_triangle(1, 0, 3);
  mesh.add_triangle(0, 1, 4);
  for (unsigned threads : {1u, 4u}) {
    CpuExecutor executor(threads);
    Mesh copy = mesh;
    EXPECT_THROW(link_triangles(copy, executor), cdt::Error) << threads << " threads";
  }
}

} // namespace
