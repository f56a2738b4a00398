// Tests of Phase 3 (shifting, Algorithms 1-2) and Phase 4 (Algorithm 3, fake boundary removal) of gCD, paper
// sections 3.3-3.4, on fixtures built by shift_test_util.hpp (independent of Phases 1-2).

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <set>
#include <span>
#include <utility>
#include <vector>

#include "cdt/errors.hpp"
#include "gcd/insert.hpp"
#include "gcd/shift.hpp"
#include "mesh_test_util.hpp"
#include "shift_test_util.hpp"

namespace {

using cdt::detail::CpuExecutor;
using cdt::detail::Mesh;
using cdt::detail::MissingArray;
using cdt::detail::MissingPoint;
using shift_test::check_mesh;
using shift_test::Fixture;
using shift_test::FixtureOptions;
using shift_test::make_fixture;
using shift_test::run_phases;

struct Points {
  std::vector<double> x, y;
  void add(double px, double py) {
    x.push_back(px);
    y.push_back(py);
  }
};

/// Drops exact duplicates (the phases require distinct points; upstream merges them).
Points distinct(const Points& p) {
  std::set<std::pair<double, double>> seen;
  Points out;
  for (std::size_t i = 0; i < p.x.size(); ++i)
    if (seen.emplace(p.x[i], p.y[i]).second) out.add(p.x[i], p.y[i]);
  return out;
}

Points uniform(std::size_t n, double size, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> d(0.0, size);
  Points p;
  for (std::size_t i = 0; i < n; ++i) {
    const double px = d(rng);
    p.add(px, d(rng));
  }
  return distinct(p);
}

Fixture fixture(const Points& p, FixtureOptions opt = {}) { return make_fixture(p.x, p.y, opt); }

// A coarse grid moves sites up to four units from their grid positions, past many of their neighbours: many
// bad cases, many points sharing a cell, and on the sweep fixture (long thin triangles) even more of both.
TEST(ShiftInsert, RandomPointsOnCoarseGridHaveBadCasesAndMissingPoints) {
  for (bool delaunay : {true, false}) {
    Fixture f = fixture(uniform(3000, 64.0, 1), {.cell = 4.0, .fakes = 8, .delaunay = delaunay});
    CpuExecutor ex(2);
    const auto r = run_phases(f, ex);
    ASSERT_EQ(r.error, "") << "delaunay " << delaunay;
    EXPECT_GT(r.shift.bad, 0u);
    EXPECT_GT(f.missing.size(), 0u);
    EXPECT_EQ(r.insert.inserted, r.missing);
    // Cells whose kept site was a bad case: their other points wait for it (the paper's delay).
    EXPECT_GT(r.delayed_hints, 0u);
  }
}

// A site already at its grid position has nothing to move across, so Algorithm 1 must call it good.
TEST(ShiftInsert, SitesOnTheirGridPositionsAreAllGoodCases) {
  Points p;
  std::mt19937 rng(2);
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j)
      if (rng() % 3 != 0) p.add(i, j);
  Fixture f = fixture(p);
  CpuExecutor ex(1);
  const auto r = run_phases(f, ex);
  ASSERT_EQ(r.error, "");
  EXPECT_EQ(r.shift.bad, 0u);
  EXPECT_EQ(r.shift.shifted, p.x.size());
}

// Four lattice points per cell: every missing point lies exactly on an edge (2->4 splits) or on a line
// through vertices (the walk restarts at vertices on its segment).
TEST(ShiftInsert, HalfLatticePutsMissingPointsOnEdges) {
  Points p;
  for (int i = 0; i < 48; ++i)
    for (int j = 0; j < 48; ++j) p.add(i * 0.5, j * 0.5);
  for (bool delaunay : {true, false}) {
    Fixture f = fixture(p, {.cell = 1.0, .fakes = 8, .delaunay = delaunay});
    CpuExecutor ex(2);
    const auto r = run_phases(f, ex);
    ASSERT_EQ(r.error, "") << "delaunay " << delaunay;
    EXPECT_EQ(r.insert.inserted, 3u * 24 * 24);
  }
}

// Sixteen points per cell on a quarter lattice, shuffled so kept sites are not the lower-left corners:
// lattice shifts land on lines of neighbours (bad cases with collinear stars) and insertions chain along
// rows.
TEST(ShiftInsert, ShuffledQuarterLattice) {
  Points p;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) p.add(i * 0.25, j * 0.25);
  std::vector<std::size_t> order(p.x.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), std::mt19937(3));
  Points q;
  for (std::size_t i : order) q.add(p.x[i], p.y[i]);
  Fixture f = fixture(q);
  CpuExecutor ex(2);
  const auto r = run_phases(f, ex);
  ASSERT_EQ(r.error, "");
  EXPECT_GT(r.shift.bad, 0u);
}

/// A 20 x 20 square with points every 0.25 along its sides (straight runs on the hull, between grid
/// points too) and `inner` random points inside.
Points square_with_straight_sides(int inner, unsigned seed) {
  Points p;
  for (int k = 0; k <= 80; ++k) {
    const double t = k * 0.25;
    p.add(t, 0);
    p.add(t, 20);
    if (k != 0 && k != 80) {
      p.add(0, t);
      p.add(20, t);
    }
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> d(0.0, 20.0);
  for (int i = 0; i < inner; ++i) {
    const double px = d(rng);
    p.add(px, d(rng));
  }
  return p;
}

// Sites on the hull edges, some between grid points: the fake boundary keeps them interior until it goes, and
// the removal must leave every one of them on the hull with no zero-area triangle (check_mesh verifies both).
TEST(FakeBoundary, RemovalKeepsSitesCollinearWithTheHull) {
  const Points p = square_with_straight_sides(300, 4);
  for (std::uint32_t fakes : {3u, 4u, 8u, 40u}) {
    Fixture f = fixture(distinct(p), {.cell = 1.0, .fakes = fakes, .delaunay = true});
    CpuExecutor ex(2);
    const auto r = run_phases(f, ex);
    ASSERT_EQ(r.error, "") << fakes << " fake vertices";
  }
}

// The hull is a thin diagonal band: its boundary is far from axis-aligned and most fakes see long chains.
TEST(FakeBoundary, ThinDiagonalBand) {
  Points p;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> d(0.0, 1.0);
  for (int i = 0; i < 2000; ++i) {
    const double t = 500 * d(rng);
    p.add(t, t + 3 * d(rng));
  }
  for (int k = 0; k <= 100; ++k) p.add(5.0 * k, 5.0 * k); // collinear with a hull edge
  Fixture f = fixture(distinct(p), {.cell = 1.0, .fakes = 6, .delaunay = false});
  CpuExecutor ex(2);
  const auto r = run_phases(f, ex);
  ASSERT_EQ(r.error, "");
}

// The GPU backend removes the fake boundary on the host from a copy of the fake vertices' fans, numbered
// locally (DeviceMesh::remove_fake_boundary): deleting the fake vertices there, ranked by their ids in the
// whole mesh, and writing the result back must leave the mesh exactly as the deletion on the whole mesh
// does, slot for slot. Here the copy is made from a host mesh the way the device makes it.
struct FansCopy {
  Mesh fans;
  std::vector<std::uint32_t> slot;     ///< the mesh's slot of each local slot but the last (free) one
  std::vector<std::uint32_t> vertex;   ///< the mesh's id of each local vertex
  std::uint32_t num_fans = 0;          ///< local slots [0, num_fans) are the fans' triangles
  std::uint32_t first_fake = 0;        ///< the first local fake vertex
  std::vector<std::uint32_t> vert_tri; ///< local vert_tri as copied
};

FansCopy copy_fans(const Mesh& mesh, std::uint32_t first_fake) {
  using cdt::detail::kNoId;
  FansCopy c;
  std::map<std::uint32_t, std::uint32_t> local; // mesh slot -> local slot
  for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
    const std::uint32_t* v = &mesh.tri[3 * t];
    if (v[0] == kNoId || std::max({v[0], v[1], v[2]}) < first_fake) continue;
    local[t] = static_cast<std::uint32_t>(c.slot.size());
    c.slot.push_back(t);
  }
  c.num_fans = static_cast<std::uint32_t>(c.slot.size());
  for (std::uint32_t r = 0; r < c.num_fans; ++r) {
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t e = mesh.adj[3 * c.slot[r] + i];
      if (e != kNoId && local.emplace(e / 3, static_cast<std::uint32_t>(c.slot.size())).second)
        c.slot.push_back(e / 3);
    }
  }
  std::map<std::uint32_t, std::uint32_t> vlocal;
  for (const std::uint32_t t : c.slot)
    for (std::uint32_t j = 0; j < 3; ++j) vlocal[mesh.tri[3 * t + j]] = 0;
  for (auto& [v, l] : vlocal) {
    l = static_cast<std::uint32_t>(c.vertex.size());
    c.vertex.push_back(v);
  }
  c.first_fake =
      static_cast<std::uint32_t>(std::ranges::lower_bound(c.vertex, first_fake) - c.vertex.begin());
  const auto slots = c.slot.size() + 1;
  c.fans.tri.assign(3 * slots, kNoId);
  c.fans.adj.assign(3 * slots, kNoId);
  c.fans.seg.assign(3 * slots, kNoId);
  for (std::size_t q = 0; q < c.slot.size(); ++q)
    for (std::uint32_t j = 0; j < 3; ++j) c.fans.tri[3 * q + j] = vlocal[mesh.tri[3 * c.slot[q] + j]];
  for (std::uint32_t k = 0; k < 3 * c.num_fans; ++k) {
    const std::uint32_t e = mesh.adj[3 * c.slot[k / 3] + k % 3];
    c.fans.seg[k] = mesh.seg[3 * c.slot[k / 3] + k % 3];
    if (e == kNoId) continue;
    const std::uint32_t u = local.at(e / 3);
    c.fans.adj[k] = 3 * u + e % 3;
    if (u >= c.num_fans) c.fans.adj[3 * u + e % 3] = k;
  }
  for (const std::uint32_t v : c.vertex) {
    c.fans.xy.push_back(mesh.xy[v]);
    const std::uint32_t t = mesh.vert_tri[v];
    c.fans.vert_tri.push_back(t == kNoId          ? kNoId
                              : local.contains(t) ? local[t]
                                                  : static_cast<std::uint32_t>(c.slot.size()));
  }
  c.vert_tri = c.fans.vert_tri;
  return c;
}

void write_back(Mesh& mesh, const FansCopy& c) {
  using cdt::detail::kNoId;
  const auto edge = [&](std::uint32_t le) { return le == kNoId ? kNoId : 3 * c.slot.at(le / 3) + le % 3; };
  for (std::uint32_t k = 0; k < 3 * c.num_fans; ++k) {
    const std::uint32_t e = mesh.adj[3 * c.slot[k / 3] + k % 3];
    if (e == kNoId) continue;
    const auto it = std::ranges::find(c.slot, e / 3);
    const auto u = static_cast<std::uint32_t>(it - c.slot.begin());
    if (u >= c.num_fans) mesh.adj[e] = edge(c.fans.adj[3 * u + e % 3]);
  }
  for (std::uint32_t k = 0; k < 3 * c.num_fans; ++k) {
    const std::uint32_t t = c.slot[k / 3], i = k % 3;
    mesh.tri[3 * t + i] = c.fans.tri[k] == kNoId ? kNoId : c.vertex.at(c.fans.tri[k]);
    mesh.adj[3 * t + i] = edge(c.fans.adj[k]);
    mesh.seg[3 * t + i] = c.fans.seg[k];
  }
  for (std::uint32_t v = 0; v < c.first_fake; ++v) {
    const std::uint32_t t = c.fans.vert_tri[v];
    if (t != c.vert_tri[v]) mesh.vert_tri[c.vertex[v]] = t == kNoId ? kNoId : c.slot.at(t);
  }
}

TEST(FakeBoundary, RemovalFromACopyOfTheFansMatchesTheWholeMesh) {
  using namespace cdt::detail;
  const Points hull_runs = square_with_straight_sides(400, 6);
  struct Case {
    Points points;
    FixtureOptions options;
    const char* name;
  };
  const std::vector<Case> cases = {
      {distinct(hull_runs), {.cell = 1.0, .fakes = 4, .delaunay = true}, "straight hull, 4 fakes"},
      {distinct(hull_runs), {.cell = 1.0, .fakes = 40, .delaunay = false}, "straight hull, 40 fakes"},
      {uniform(3000, 100.0, 7), {.cell = 2.0, .fakes = 12, .delaunay = false}, "uniform, 12 fakes"},
  };
  for (const Case& c : cases) {
    Fixture f = fixture(c.points, c.options);
    CpuExecutor ex(2);
    MissingArray missing = f.missing;
    shift_to_true_positions(f.mesh, f.num_sites, f.true_x, f.true_y, missing, ex);
    insert_missing_points(f.mesh, missing, ex);
    Mesh whole = f.mesh;
    Mesh patched = f.mesh;
    remove_fake_boundary(whole, f.num_sites, ex, nullptr, false);
    ASSERT_EQ(check_mesh(whole), "") << c.name;

    FansCopy copy = copy_fans(patched, f.num_sites);
    ASSERT_GT(copy.num_fans, 0u) << c.name;
    ASSERT_LT(copy.slot.size(), patched.num_slots()) << c.name << ": the copy must be a part of the mesh";
    delete_fake_vertices(copy.fans, copy.first_fake, ex, copy.vertex.data());
    write_back(patched, copy);
    patched.xy.resize(f.num_sites);
    patched.vert_tri.resize(f.num_sites);
    EXPECT_EQ(patched.tri, whole.tri) << c.name;
    EXPECT_EQ(patched.adj, whole.adj) << c.name;
    EXPECT_EQ(patched.seg, whole.seg) << c.name;
    EXPECT_EQ(patched.vert_tri, whole.vert_tri) << c.name;
  }
}

// Dense clusters put many points into single cells (long insertion chains in one container) next to
// sparse regions whose triangles are long and thin.
TEST(ShiftInsert, ClusteredPoints) {
  Points p;
  std::mt19937_64 rng(6);
  std::normal_distribution<double> tight(0.0, 0.3);
  std::uniform_real_distribution<double> d(0.0, 200.0);
  for (int c = 0; c < 12; ++c) {
    const double cx = d(rng), cy = d(rng);
    for (int i = 0; i < 300; ++i) {
      const double px = cx + tight(rng);
      p.add(px, cy + tight(rng));
    }
  }
  for (int i = 0; i < 200; ++i) {
    const double px = d(rng);
    p.add(px, d(rng));
  }
  for (bool delaunay : {true, false}) {
    Fixture f = fixture(distinct(p), {.cell = 1.0, .fakes = 8, .delaunay = delaunay});
    CpuExecutor ex(2);
    const auto r = run_phases(f, ex);
    ASSERT_EQ(r.error, "") << "delaunay " << delaunay;
  }
}

TEST(ShiftInsert, TinyInputs) {
  Points three;
  three.add(0.5, 0.5);
  three.add(3.25, 0.75);
  three.add(1.5, 2.5);
  Points one_cell; // all points in one cell: a single kept site, the rest inserted around it
  one_cell.add(0.1, 0.1);
  one_cell.add(0.9, 0.2);
  one_cell.add(0.5, 0.8);
  one_cell.add(0.4, 0.3);
  for (const Points* p : {&three, &one_cell}) {
    Fixture f = fixture(*p, {.cell = 1.0, .fakes = 3, .delaunay = false});
    CpuExecutor ex(1);
    const auto r = run_phases(f, ex);
    ASSERT_EQ(r.error, "");
  }
}

// The CPU executor runs steps in parallel only above 4096 elements; both thread counts must give valid and,
// since every step is deterministic, identical meshes. The sweep fixture makes nearly every kept site a bad
// case, so Algorithms 2 and 3 also run rounds of thousands of elements.
TEST(ShiftInsert, OneAndFourThreadsGiveTheSameValidMesh) {
  const Points p = uniform(40000, 256.0, 7);
  for (bool delaunay : {true, false}) {
    Fixture f1 = fixture(p, {.cell = delaunay ? 2.0 : 1.0, .fakes = 16, .delaunay = delaunay});
    Fixture f4 = f1;
    CpuExecutor ex1(1), ex4(4);
    const auto r1 = run_phases(f1, ex1);
    const auto r4 = run_phases(f4, ex4);
    ASSERT_EQ(r1.error, "") << "delaunay " << delaunay;
    ASSERT_EQ(r4.error, "") << "delaunay " << delaunay;
    EXPECT_GT(r1.shift.bad, delaunay ? 1000u : 10000u);
    EXPECT_EQ(r1.shift.bad, r4.shift.bad);
    EXPECT_EQ(f1.mesh.tri, f4.mesh.tri);
    EXPECT_EQ(f1.mesh.adj, f4.mesh.adj);
    EXPECT_EQ(f1.mesh.vert_tri, f4.mesh.vert_tri);
  }
}

// The CPU schedule of Phases 4 and 5 (parts inserting their points with Lawson's flips, the rounds for the
// rest) ends in the Delaunay triangulation, the same as Algorithm 3's rounds followed by the flips, and in
// the same mesh for any thread count.
TEST(InsertInParts, SameDelaunayTriangulationAsTheRoundsForAnyThreadCount) {
  const Points uniform_points = uniform(60000, 256.0, 5);
  Points clustered;
  {
    std::mt19937_64 rng(9);
    std::normal_distribution<double> d(0.0, 1.0);
    for (int c = 0; c < 40; ++c) {
      const double cx = 10.0 * c, cy = 3.0 * (c % 7);
      for (int i = 0; i < 1500; ++i) clustered.add(cx + 0.05 * d(rng), cy + 0.05 * d(rng));
    }
    clustered = distinct(clustered);
  }
  for (const Points* p : {&uniform_points, static_cast<const Points*>(&clustered)}) {
    const Fixture base = fixture(*p, {.cell = 2.0, .fakes = 16, .delaunay = true});
    Fixture rounds = base;
    CpuExecutor ex2(2);
    ASSERT_EQ(run_phases(rounds, ex2).error, "");
    cdt::detail::flip_to_delaunay(rounds.mesh, ex2);
    Fixture one = base, two = base, four = base;
    CpuExecutor ex1(1), ex4(4);
    const auto r1 = run_phases(one, ex1, true);
    const auto r2 = run_phases(two, ex2, true);
    const auto r4 = run_phases(four, ex4, true);
    ASSERT_EQ(r1.error, "");
    ASSERT_EQ(r2.error, "");
    ASSERT_EQ(r4.error, "");
    EXPECT_GT(r1.missing, 10000u);
    EXPECT_EQ(r1.insert.inserted, r1.missing);
    EXPECT_GT(r1.insert.flips, 0u);
    EXPECT_TRUE(trixel_test::is_locally_delaunay(one.mesh));
    // In general position the Delaunay triangulation is unique.
    EXPECT_EQ(trixel_test::triangle_set(one.mesh), trixel_test::triangle_set(rounds.mesh));
    EXPECT_EQ(one.mesh.tri, two.mesh.tri);
    EXPECT_EQ(one.mesh.tri, four.mesh.tri);
    EXPECT_EQ(one.mesh.adj, four.mesh.adj);
    EXPECT_EQ(one.mesh.vert_tri, four.mesh.vert_tri);
    EXPECT_EQ(r1.insert.flips, r4.insert.flips);
    EXPECT_EQ(r1.last_flips, r4.last_flips);
  }
}

// Points whose hints are not in the mesh, and a lattice whose points fall on edges (2 -> 4 splits inside
// the parts), still end Delaunay: the first go to Algorithm 3's rounds, whose triangles the last flips check.
TEST(InsertInParts, UselessHintsAndPointsOnEdges) {
  Points p;
  for (int i = 0; i < 120; ++i)
    for (int j = 0; j < 120; ++j) p.add(i, j);
  for (int i = 0; i < 119; i += 3)
    for (int j = 0; j < 119; j += 5) p.add(i + 0.5, j + 0.5); // on the diagonals of the lattice squares
  Fixture f = fixture(p, {.cell = 2.0, .fakes = 8, .delaunay = true});
  ASSERT_GT(f.missing.size(), 1000u);
  for (std::size_t k = 0; k < f.missing.size(); k += 7) f.missing[k].hint = cdt::detail::kNoId;
  CpuExecutor ex(2);
  const auto r = run_phases(f, ex, true);
  ASSERT_EQ(r.error, "");
  EXPECT_GT(r.insert.rounds, 1u) << "the points without a hint go through the rounds";
  EXPECT_TRUE(trixel_test::is_locally_delaunay(f.mesh));
}

/// A square 0-1-2-3 (CCW) split into the two triangles of the diagonal 0-2; further vertices unplaced.
Mesh square_mesh(std::vector<std::pair<double, double>> extra) {
  Mesh m;
  m.xy = {{0, 0}, {4, 0}, {4, 4}, {0, 4}};
  for (auto [px, py] : extra) {
    m.xy.push_back({px, py});
  }
  m.add_triangle(0, 1, 2);
  m.add_triangle(0, 2, 3);
  CpuExecutor ex(1);
  cdt::detail::link_triangles(m, ex);
  return m;
}

// A point on the diagonal takes the 2->4 split; one inside a triangle the 1->3 split; both in one round.
TEST(InsertMissing, SplitsOnEdgeAndInsideTriangle) {
  Mesh m = square_mesh({{2, 2}, {3, 1}, {1, 3.5}});
  CpuExecutor ex(1);
  const MissingArray missing{{4, 0}, {5, 1}, {6, 3}};
  const auto stats = cdt::detail::insert_missing_points(m, missing, ex);
  EXPECT_EQ(stats.inserted, 3u);
  EXPECT_EQ(check_mesh(m), "");
  std::size_t live = 0;
  for (std::uint32_t t = 0; t < m.num_slots(); ++t) live += m.alive(t) ? 1 : 0;
  EXPECT_EQ(live, 2u + 2u * 3u);
}

// Point location must report a duplicate instead of walking forever or splitting into zero-area triangles.
TEST(InsertMissing, PointOnAVertexThrows) {
  Mesh m = square_mesh({{4, 4}});
  CpuExecutor ex(1);
  const MissingArray missing{{4, 0}};
  EXPECT_THROW(cdt::detail::insert_missing_points(m, missing, ex), cdt::Error);
}

// Hints that point at each other can never be satisfied: the round must fail rather than spin.
TEST(InsertMissing, CyclicHintsThrow) {
  Mesh m = square_mesh({{1, 1}, {3, 1}});
  CpuExecutor ex(1);
  const MissingArray missing{{4, 5}, {5, 4}};
  EXPECT_THROW(cdt::detail::insert_missing_points(m, missing, ex), cdt::Error);
}

// A far hint along the lattice direction (2, 1) meets lattice vertices in the middle of crossed edges (the
// walk restarts there), and a hint that never enters the mesh falls back to a mesh vertex instead of waiting
// forever.
TEST(InsertMissing, FarAndUselessHints) {
  Points p;
  for (int i = 0; i < 12; ++i)
    for (int j = 0; j < 12; ++j) p.add(i, j);
  p.add(8.5, 4.25);  // shares the cell of (8, 4)
  p.add(9.25, 9.75); // shares the cell of (9, 9)
  for (bool delaunay : {true, false}) {
    Fixture f = fixture(p, {.cell = 1.0, .fakes = 8, .delaunay = delaunay});
    ASSERT_EQ(f.missing.size(), 2u);
    f.missing[0].hint = 0;                  // the site at (0, 0)
    f.missing[1].hint = cdt::detail::kNoId; // no hint at all
    CpuExecutor ex(1);
    const auto r = run_phases(f, ex);
    ASSERT_EQ(r.error, "") << "delaunay " << delaunay;
    EXPECT_EQ(r.shift.bad, 0u);
  }
}

// Missing points listed along a curve (as the points' space-filling order lists a coastline's) crowd a few
// containers. Were the lowest list position to win each container, the winner would be the crowd's end
// and its split would leave the rest of the crowd in one child: a round per point. The scattered claim
// keys pick an arbitrary member, so the rounds grow with the logarithm of the crowd.
TEST(InsertMissing, CrowdsAlongACurveTakeFewRounds) {
  Points p;
  for (int i = 0; i < 4000; ++i) {
    const double t = i / 40.0; // 0 .. 100
    p.add(t, t * t / 200.0 + 0.001 * i);
  }
  for (bool delaunay : {true, false}) {
    Fixture f = fixture(p, {.cell = 32.0, .fakes = 8, .delaunay = delaunay});
    ASSERT_GT(f.missing.size(), 3900u);
    CpuExecutor ex(2);
    const auto r = run_phases(f, ex);
    ASSERT_EQ(r.error, "") << "delaunay " << delaunay;
    EXPECT_EQ(r.insert.inserted, r.missing);
    EXPECT_LT(r.insert.rounds, 100u) << "delaunay " << delaunay;
  }
}

// The claim keys are a bijection of [0, 2^31) that never gives kNoId.
TEST(InsertMissing, ClaimKeysAreInvertible) {
  using cdt::detail::claim_holder;
  using cdt::detail::claim_key;
  std::mt19937 rng(3);
  std::uniform_int_distribution<std::uint32_t> any(0, 0x7FFFFFFEu);
  for (int i = 0; i < 100000; ++i) {
    const std::uint32_t q = i < 50000 ? static_cast<std::uint32_t>(i) : any(rng);
    const std::uint32_t key = claim_key(q);
    ASSERT_LT(key, 0x80000000u);
    ASSERT_EQ(claim_holder(key), q);
  }
  EXPECT_EQ(claim_holder(cdt::detail::kNoId), cdt::detail::kNoId);
  // Neighbouring positions get scattered keys: the lowest key of a run is rarely at its start.
  int at_start = 0;
  for (std::uint32_t base = 0; base < 64000; base += 64) {
    std::uint32_t best = base;
    for (std::uint32_t q = base; q < base + 64; ++q)
      if (claim_key(q) < claim_key(best)) best = q;
    at_start += best == base ? 1 : 0;
  }
  EXPECT_LT(at_start, 100);
}

/// Vertex 0 at (cx, cy) surrounded by ring vertices 1..n; triangles (0, i, i + 1).
Mesh star_mesh(double cx, double cy, const std::vector<std::pair<double, double>>& ring) {
  Mesh m;
  m.xy = {{cx, cy}};
  for (auto [px, py] : ring) {
    m.xy.push_back({px, py});
  }
  const auto n = static_cast<std::uint32_t>(ring.size());
  for (std::uint32_t i = 1; i <= n; ++i) m.add_triangle(0, i, i == n ? 1 : i + 1);
  CpuExecutor ex(1);
  cdt::detail::link_triangles(m, ex);
  return m;
}

void delete_centre(Mesh& m) {
  CpuExecutor ex(1);
  cdt::detail::HoleWorkspace ws;
  const std::vector<std::uint32_t> active{0};
  std::vector<std::uint32_t> hint(1);
  cdt::detail::delete_vertex_round(m, active, cdt::detail::HoleShape::star, nullptr, hint.data(), ws, ex);
}

// The centre lies on both diagonals of the square, so no ear keeps it strictly in the kernel: the exact
// emptiness test must take over.
TEST(ShiftDelete, KernelOnEveryDiagonalFallsBackToExactEars) {
  Mesh m = star_mesh(2, 2, {{0, 0}, {4, 0}, {4, 4}, {0, 4}});
  delete_centre(m);
  EXPECT_EQ(check_mesh(m), "");
  std::size_t live = 0;
  for (std::uint32_t t = 0; t < m.num_slots(); ++t) live += m.alive(t) ? 1 : 0;
  EXPECT_EQ(live, 2u);
  EXPECT_EQ(m.vert_tri[0], cdt::detail::kNoId);
}

// A deeply non-convex star with collinear ring vertices: every ear must be strictly CCW and empty.
TEST(ShiftDelete, NonConvexStarWithCollinearRingIsRetriangulated) {
  std::vector<std::pair<double, double>> ring;
  const int n = 60;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * 3.14159265358979323846 * k / n;
    const double r = k % 2 == 0 ? 40 : 12 + (k % 7);
    ring.emplace_back(std::round(r * std::cos(a) * 64) / 64, std::round(r * std::sin(a) * 64) / 64);
  }
  // Three ring vertices on one straight line (x = 40 near angle 0).
  ring.insert(ring.begin() + 1, {40, 1});
  ring.insert(ring.begin(), {40, -1});
  Mesh m = star_mesh(0.125, 0.0625, ring);
  ASSERT_EQ(shift_test::check_mesh(m, false), "");
  delete_centre(m);
  EXPECT_EQ(shift_test::check_mesh(m, false), "");
}

/// The mesh's edges as vertex pairs (smaller first).
std::set<std::pair<std::uint32_t, std::uint32_t>> edges_of(const Mesh& m) {
  std::set<std::pair<std::uint32_t, std::uint32_t>> e;
  for (std::uint32_t t = 0; t < m.num_slots(); ++t) {
    if (!m.alive(t)) continue;
    for (std::uint32_t k = 0; k < 3; ++k) {
      const std::uint32_t a = m.tri[3 * t + k], b = m.tri[3 * t + (k + 1) % 3];
      e.emplace(std::min(a, b), std::max(a, b));
    }
  }
  return e;
}

// Algorithm 2's rounds, checked against their rule written on the edge set of the mesh before each round:
// the first pick is every leaving vertex with no lower-priority leaving neighbour; the second adds every
// leaving vertex next to none of the first pick whose lower-priority leaving neighbours all are. Each
// round's set is then independent, every leaving vertex goes, and the mesh stays valid.
TEST(ShiftDelete, RoundsTakeBothPicksOfIndependentVertices) {
  for (unsigned seed : {1u, 2u, 3u}) {
    Fixture f = fixture(uniform(4000, 64.0, seed), {.cell = 0.5, .fakes = 8, .delaunay = true});
    const Mesh& m = f.mesh;
    std::mt19937 rng(seed);
    std::vector<std::uint8_t> leaving(m.num_vertices(), cdt::detail::kStays);
    std::vector<std::uint32_t> pending;
    for (std::uint32_t v = 0; v < f.num_sites; ++v)
      if (m.vert_tri[v] != cdt::detail::kNoId && rng() % 3 != 0) {
        leaving[v] = cdt::detail::kLeaving;
        pending.push_back(v);
      }
    ASSERT_GT(pending.size(), 1000u);
    std::set<std::uint32_t> left(pending.begin(), pending.end());
    auto edges = edges_of(m);
    std::size_t second_picks = 0;
    std::uint64_t rounds_seen = 0;
    const auto after_round = [&](std::span<const std::uint32_t> active, std::span<const std::uint32_t>) {
      ++rounds_seen;
      std::map<std::uint32_t, std::vector<std::uint32_t>> next; // leaving neighbours, before the round
      for (auto [a, b] : edges)
        if (left.count(a) != 0 && left.count(b) != 0) {
          next[a].push_back(b);
          next[b].push_back(a);
        }
      const auto lower = [](std::uint32_t w, std::uint32_t v) {
        return cdt::detail::vertex_priority(w) < cdt::detail::vertex_priority(v);
      };
      std::set<std::uint32_t> first, later, expected;
      for (std::uint32_t v : left)
        if (std::none_of(next[v].begin(), next[v].end(), [&](std::uint32_t w) { return lower(w, v); }))
          first.insert(v);
      for (std::uint32_t v : left)
        if (first.count(v) == 0 &&
            std::any_of(next[v].begin(), next[v].end(), [&](std::uint32_t w) { return first.count(w) != 0; }))
          later.insert(v);
      expected = first;
      for (std::uint32_t v : left)
        if (first.count(v) == 0 && later.count(v) == 0 &&
            std::all_of(next[v].begin(), next[v].end(),
                        [&](std::uint32_t w) { return !lower(w, v) || later.count(w) != 0; })) {
          expected.insert(v);
          ++second_picks;
        }
      EXPECT_EQ(std::set<std::uint32_t>(active.begin(), active.end()), expected) << "round " << rounds_seen;
      for (std::uint32_t v : active) {
        for (std::uint32_t w : next[v]) EXPECT_EQ(expected.count(w), 0u) << v << " and " << w << " adjacent";
        EXPECT_EQ(leaving[v], cdt::detail::kStays);
        left.erase(v);
      }
      for (std::uint32_t v : left) EXPECT_EQ(leaving[v], cdt::detail::kLeaving);
      EXPECT_EQ(check_mesh(m), "") << "round " << rounds_seen;
      edges = edges_of(m);
    };
    CpuExecutor ex(4);
    const std::uint64_t rounds =
        cdt::detail::delete_vertices(f.mesh, pending, cdt::detail::HoleShape::star, leaving, after_round, ex);
    EXPECT_EQ(rounds, rounds_seen);
    EXPECT_TRUE(left.empty());
    EXPECT_GT(second_picks, 0u) << "seed " << seed;
    for (std::uint32_t v : pending) EXPECT_EQ(m.vert_tri[v], cdt::detail::kNoId);
  }
}

// A growth past the slots' capacity leaves room for an eighth more, so that the next small one (the
// vertices the split adds after Phase 4) moves nothing; new slots are free.
TEST(MeshSlots, GrowthPastTheCapacityLeavesRoom) {
  Mesh m = star_mesh(0, 0, {{1, 0}, {0, 1}, {-1, 0}, {0, -1}});
  const std::uint32_t before = m.num_slots();
  const std::size_t big = 8 * (m.tri.capacity() / 3 + 1000);
  const std::uint32_t first = m.grow_slots(static_cast<std::uint32_t>(big));
  EXPECT_EQ(first, before);
  ASSERT_EQ(m.num_slots(), before + big);
  EXPECT_GE(m.tri.capacity(), 3 * (m.num_slots() + m.num_slots() / 8));
  EXPECT_GE(m.adj.capacity(), m.tri.capacity());
  EXPECT_GE(m.seg.capacity(), m.tri.capacity());
  const std::uint32_t* tri = m.tri.data();
  const std::uint32_t* adj = m.adj.data();
  const std::uint32_t* seg = m.seg.data();
  m.grow_slots(m.num_slots() / 8);
  EXPECT_EQ(m.tri.data(), tri);
  EXPECT_EQ(m.adj.data(), adj);
  EXPECT_EQ(m.seg.data(), seg);
  for (std::uint32_t t = before; t < m.num_slots(); ++t) EXPECT_FALSE(m.alive(t));
  EXPECT_EQ(check_mesh(m, false), "");
}

// Every other test trusts check_mesh, so it must reject each kind of damage it claims to detect.
TEST(ShiftCheckMesh, RejectsBrokenMeshes) {
  const Fixture good = fixture(uniform(200, 16.0, 9), {.cell = 1.0, .fakes = 5, .delaunay = true});
  ASSERT_EQ(check_mesh(good.mesh), "");
  std::uint32_t interior = cdt::detail::kNoId; // a triangle with no boundary edge
  for (std::uint32_t t = 0; t < good.mesh.num_slots() && interior == cdt::detail::kNoId; ++t)
    if (good.mesh.adj[3 * t] != cdt::detail::kNoId && good.mesh.adj[3 * t + 1] != cdt::detail::kNoId &&
        good.mesh.adj[3 * t + 2] != cdt::detail::kNoId)
      interior = t;
  ASSERT_NE(interior, cdt::detail::kNoId);
  const std::uint32_t t = interior;
  {
    Mesh m = good.mesh; // clockwise triangle
    std::swap(m.tri[3 * t + 1], m.tri[3 * t + 2]);
    EXPECT_NE(check_mesh(m), "");
  }
  {
    Mesh m = good.mesh; // one-sided link
    m.adj[m.adj[3 * t]] = cdt::detail::kNoId;
    EXPECT_NE(check_mesh(m), "");
  }
  {
    Mesh m = good.mesh; // a hole in the middle
    for (std::uint32_t i = 0; i < 3; ++i) {
      m.adj[m.adj[3 * t + i]] = cdt::detail::kNoId;
      m.tri[3 * t + i] = m.adj[3 * t + i] = cdt::detail::kNoId;
    }
    for (std::uint32_t v = 0; v < m.num_vertices(); ++v)
      if (m.vert_tri[v] == t) m.vert_tri[v] = cdt::detail::kNoId;
    EXPECT_NE(check_mesh(m), "");
  }
  {
    Mesh m = good.mesh; // vert_tri not incident
    const std::uint32_t v = m.tri[3 * t];
    m.vert_tri[v] = m.adj[3 * t] / 3;
    EXPECT_NE(check_mesh(m), "");
  }
  {
    Mesh m; // a valid triangulation of an L-shape: right everywhere except that it is not the convex hull
    m.xy = {{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};
    for (std::uint32_t k = 1; k + 1 < 6; ++k) m.add_triangle(0, k, k + 1);
    CpuExecutor ex(1);
    cdt::detail::link_triangles(m, ex);
    EXPECT_EQ(check_mesh(m, false), "");
    EXPECT_NE(check_mesh(m), "");
  }
}

} // namespace
