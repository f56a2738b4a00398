#include "gcd/dualize.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "executor/cpu_executor.hpp"
#include "gcd/voronoi.hpp"
#include "predicate_cases.hpp"

namespace {

using namespace cdt::detail;

// Nearest site by exact integer distance, ties to the lower index (the paper's Definition 1).
std::vector<std::uint32_t> brute_force_colour(const std::vector<std::uint32_t>& gx,
                                              const std::vector<std::uint32_t>& gy, std::uint32_t m) {
  std::vector<std::uint32_t> colour(static_cast<std::size_t>(m) * m);
  for (std::uint32_t y = 0; y < m; ++y)
    for (std::uint32_t x = 0; x < m; ++x) {
      std::int64_t best = -1;
      std::uint32_t best_site = 0;
      for (std::uint32_t s = 0; s < gx.size(); ++s) {
        const std::int64_t dx = std::int64_t{gx[s]} - x, dy = std::int64_t{gy[s]} - y;
        const std::int64_t d = dx * dx + dy * dy;
        if (best < 0 || d < best) {
          best = d;
          best_site = s;
        }
      }
      colour[static_cast<std::size_t>(y) * m + x] = best_site;
    }
  return colour;
}

// Links symmetric through encoded edges, every triangle CCW, vert_tri incident, boundary convex.
void expect_valid(const Mesh& mesh) {
  std::size_t boundary_edges = 0;
  for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
    if (!mesh.alive(t)) continue;
    const std::uint32_t a = mesh.tri[3 * t], b = mesh.tri[3 * t + 1], c = mesh.tri[3 * t + 2];
    ASSERT_GT(orient2d(mesh.xy[a].x, mesh.xy[a].y, mesh.xy[b].x, mesh.xy[b].y, mesh.xy[c].x, mesh.xy[c].y), 0)
        << "triangle " << t;
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t e = mesh.adj[3 * t + i];
      if (e == kNoId) {
        ++boundary_edges;
        continue;
      }
      ASSERT_EQ(mesh.adj[e], 3 * t + i);
      const std::uint32_t u = e / 3, j = e % 3;
      EXPECT_EQ(mesh.tri[3 * u + next3(j)], mesh.tri[3 * t + prev3(i)]);
      EXPECT_EQ(mesh.tri[3 * u + prev3(j)], mesh.tri[3 * t + next3(i)]);
    }
  }
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    const std::uint32_t t = mesh.vert_tri[v];
    if (t != kNoId) {
      EXPECT_TRUE(mesh.tri[3 * t] == v || mesh.tri[3 * t + 1] == v || mesh.tri[3 * t + 2] == v);
    }
  }
  EXPECT_GE(boundary_edges, 3u);
}

struct Sites {
  std::vector<std::uint32_t> gx, gy;
  std::vector<double> x, y;
  std::vector<std::uint8_t> kept;

  /// A kept site at grid point (px, py), at that position.
  void add(std::uint32_t px, std::uint32_t py) {
    gx.push_back(px);
    gy.push_back(py);
    x.push_back(px);
    y.push_back(py);
    kept.push_back(1);
  }
};

Sites random_sites(std::uint32_t m, std::uint32_t count, std::uint64_t seed) {
  trixel_test::Rng rng(seed);
  Sites s;
  std::vector<std::uint8_t> used(static_cast<std::size_t>(m) * m, 0);
  while (s.gx.size() < count) {
    const auto x = static_cast<std::uint32_t>(rng.range(0, m - 1));
    const auto y = static_cast<std::uint32_t>(rng.range(0, m - 1));
    if (used[static_cast<std::size_t>(y) * m + x]) continue;
    used[static_cast<std::size_t>(y) * m + x] = 1;
    s.add(x, y);
  }
  return s;
}

TEST(Dualize, RandomSitesGiveAValidMeshInsideTheFakeBoundary) {
  CpuExecutor executor(2);
  int dual_used = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const std::uint32_t m = 64;
    const Sites s = random_sites(m, 40, seed);
    const auto colour = brute_force_colour(s.gx, s.gy, m);
    DualizeStats stats;
    const Mesh mesh =
        dualize(colour, m, s.x, s.y, s.kept, Box{0, 0, double(m - 1), double(m - 1)}, executor, &stats);
    expect_valid(mesh);
    const auto n = static_cast<std::uint32_t>(s.x.size());
    EXPECT_EQ(mesh.num_vertices(), n + stats.fake_vertices);
    dual_used += stats.dual_triangles > 0;
    // Every site is in the mesh, and the outer boundary is exactly the fake polygon.
    if (stats.dual_triangles > 0) {
      for (std::uint32_t v = 0; v < n; ++v)
        EXPECT_NE(mesh.vert_tri[v], kNoId) << "seed " << seed << " site " << v;
    }
    std::size_t live = 0;
    for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) live += mesh.alive(t);
    // Euler for a triangulated disk whose boundary is the fake polygon: T = 2V - h - 2.
    const std::size_t used = stats.dual_triangles > 0 ? n + stats.fake_vertices : stats.fake_vertices;
    EXPECT_EQ(live, 2 * used - stats.fake_vertices - 2) << "seed " << seed;
  }
  // Brute-force colouring is not amended, so a diagram with debris may fall back; most must not.
  EXPECT_GE(dual_used, 15);
}

// Too few sites for a Voronoi vertex: the mesh is the fake polygon and everything is left for
// missing-point insertion rather than failing.
TEST(Dualize, TwoSitesFallBackToTheFakePolygon) {
  CpuExecutor executor(1);
  const std::uint32_t m = 16;
  Sites s;
  s.gx = {2, 12};
  s.gy = {3, 9};
  s.x = {2, 12};
  s.y = {3, 9};
  s.kept = {1, 1};
  const auto colour = brute_force_colour(s.gx, s.gy, m);
  DualizeStats stats;
  const Mesh mesh = dualize(colour, m, s.x, s.y, s.kept, Box{0, 0, 15, 15}, executor, &stats);
  expect_valid(mesh);
  EXPECT_EQ(stats.dual_triangles, 0u);
  EXPECT_EQ(mesh.vert_tri[0], kNoId);
  EXPECT_EQ(mesh.vert_tri[1], kNoId);
}

// Collinear sites on a lattice row produce ties everywhere; the dual must still be valid.
TEST(Dualize, LatticeSitesWithTiesStayValid) {
  CpuExecutor executor(2);
  const std::uint32_t m = 32;
  Sites s;
  for (std::uint32_t y = 2; y < m; y += 6)
    for (std::uint32_t x = 1; x < m; x += 5) {
      s.add(x, y);
    }
  const auto colour = brute_force_colour(s.gx, s.gy, m);
  DualizeStats stats;
  const Mesh mesh = dualize(colour, m, s.x, s.y, s.kept, Box{0, 0, 31, 31}, executor, &stats);
  expect_valid(mesh);
  EXPECT_GT(stats.dual_triangles, 0u);
}

// A full lattice's hull is four straight sides of collinear sites. The fake boundary's triangles share
// the hull out among the fake vertices, each the part in its own direction, so that no fake vertex's fan
// holds a whole side (steps that walk fans, above all the fake boundary's removal, walk them on one
// thread).
TEST(Dualize, FakeVerticesShareAStraightHull) {
  CpuExecutor executor(2);
  const std::uint32_t m = 64;
  Sites s;
  std::vector<std::uint32_t> colour(static_cast<std::size_t>(m) * m);
  for (std::uint32_t y = 0; y < m; ++y)
    for (std::uint32_t x = 0; x < m; ++x) {
      colour[static_cast<std::size_t>(y) * m + x] = static_cast<std::uint32_t>(s.x.size());
      s.add(x, y);
    }
  DualizeStats stats;
  const Mesh mesh =
      dualize(colour, m, s.x, s.y, s.kept, Box{0, 0, double(m - 1), double(m - 1)}, executor, &stats);
  expect_valid(mesh);
  ASSERT_GT(stats.dual_triangles, 0u);
  const auto n = static_cast<std::uint32_t>(s.x.size());
  const std::uint32_t hull = 4 * (m - 1);
  ASSERT_EQ(stats.fake_vertices, 16u); // ceil(sqrt(hull size))
  std::vector<std::uint32_t> fan(stats.fake_vertices, 0);
  for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
    if (!mesh.alive(t)) continue;
    for (std::uint32_t i = 0; i < 3; ++i)
      if (mesh.tri[3 * t + i] >= n) ++fan[mesh.tri[3 * t + i] - n];
  }
  std::uint32_t total = 0;
  for (std::uint32_t f = 0; f < stats.fake_vertices; ++f) {
    EXPECT_LE(fan[f], 2 * hull / stats.fake_vertices + 4) << "fake vertex " << f;
    total += fan[f];
  }
  // The ring between hull and fake polygon: a triangle per hull edge (one fake corner) and one per fake
  // edge (two).
  EXPECT_EQ(total, hull + 2 * stats.fake_vertices);
}

// A pass after taking the sites of degenerate corners out recomputes only the rows of corners around
// the recoloured cells and keeps the others from the first pass: it must give what a pass over every
// row gives. Dense sites on the amended digital diagram meet collinear at corners often.
TEST(Dualize, SecondPassReusesTheRowsThatDidNotChange) {
  CpuExecutor executor(2);
  int second_passes = 0;
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    const std::uint32_t m = 128;
    Sites s = random_sites(m, 10000, seed);
    GridSites grid;
    grid.gx = s.gx;
    grid.gy = s.gy;
    grid.cell_owner.assign(static_cast<std::size_t>(m) * m, cdt::kNone);
    for (std::uint32_t k = 0; k < s.gx.size(); ++k)
      grid.cell_owner[static_cast<std::size_t>(s.gy[k]) * m + s.gx[k]] = k;
    std::vector<std::uint32_t> colour = compute_digital_voronoi(grid, m, executor);
    const Box box{0, 0, double(m - 1), double(m - 1)};
    DualCorners corners;
    std::vector<std::uint32_t> degenerate;
    const Mesh first = dualize(colour, m, s.x, s.y, s.kept, box, executor, nullptr, &degenerate, &corners);
    if (first.num_slots() > 0) continue;
    ++second_passes;
    corners.mark_changed(remove_sites_from_colouring(colour, grid, m, degenerate), m);
    for (const std::uint32_t v : degenerate) s.kept[v] = 0;
    std::vector<std::uint32_t> cached_culprits;
    std::vector<std::uint32_t> full_culprits;
    const Mesh cached =
        dualize(colour, m, s.x, s.y, s.kept, box, executor, nullptr, &cached_culprits, &corners);
    const Mesh full = dualize(colour, m, s.x, s.y, s.kept, box, executor, nullptr, &full_culprits);
    EXPECT_EQ(cached.tri, full.tri) << "seed " << seed;
    EXPECT_EQ(cached.adj, full.adj) << "seed " << seed;
    EXPECT_EQ(cached_culprits, full_culprits) << "seed " << seed;
  }
  EXPECT_GE(second_passes, 20);
}

} // namespace
