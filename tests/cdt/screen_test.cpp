// Screening segments against the Delaunay mesh (gcd/screen.hpp) and splitting only the suspects: the
// corridor walk against brute force, the suspects of a hand-made case, and triangulate() with
// screening against triangulate() splitting every segment first.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "artem_ogre.hpp"
#include "cdt/cdt.hpp"
#include "cdt/io.hpp"
#include "cdt/verify.hpp"
#include "executor/cpu_executor.hpp"
#include "gcd/insert.hpp"
#include "gcd/screen.hpp"
#include "mesh_test_util.hpp"
#include "pslg_generators.hpp"

namespace {

using cdt::detail::kNoId;
using cdt::detail::Mesh;
using trixel_gen::Distribution;
using trixel_test::orient_of;
using trixel_test::sweep_triangulate;

using Edge = std::pair<std::uint32_t, std::uint32_t>;

Edge undirected(std::uint32_t a, std::uint32_t b) { return {std::min(a, b), std::max(a, b)}; }

/// Every edge of the mesh, once.
std::set<Edge> mesh_edges(const Mesh& mesh) {
  std::set<Edge> edges;
  for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
    if (!mesh.alive(t)) continue;
    for (std::uint32_t i = 0; i < 3; ++i)
      edges.insert(undirected(mesh.tri[3 * t + (i + 1) % 3], mesh.tri[3 * t + (i + 2) % 3]));
  }
  return edges;
}

/// What the walk from a to b reports, as sets.
struct Walked {
  bool ok = false;
  std::set<std::uint32_t> vertices;
  std::set<Edge> crossed;
  std::set<Edge> along;
};

/// The ends of encoded edge e, lower first.
Edge edge_ends(const cdt::detail::MeshView& m, std::uint32_t e) {
  const std::uint32_t t = cdt::detail::edge_tri(e), i = cdt::detail::edge_index(e);
  return undirected(m.v(t, cdt::detail::next3(i)), m.v(t, cdt::detail::prev3(i)));
}

Walked walk(Mesh& mesh, std::uint32_t a, std::uint32_t b) {
  Walked w;
  const cdt::detail::MeshView m = mesh.view();
  w.ok = cdt::detail::walk_corridor(
      m, a, b, [&](std::uint32_t v) { w.vertices.insert(v); },
      [&](std::uint32_t e) { w.crossed.insert(edge_ends(m, e)); },
      [&](std::uint32_t e) { w.along.insert(edge_ends(m, e)); });
  return w;
}

/// The same by brute force: the vertices on the closed segment, the edges between two of them, and the edges
/// whose interiors it crosses at one point interior to both.
Walked brute_force(const Mesh& mesh, std::uint32_t a, std::uint32_t b) {
  Walked w;
  w.ok = true;
  const auto on_segment = [&](std::uint32_t v) {
    if (orient_of(mesh, a, b, v) != 0) return false;
    const double lo_x = std::min(mesh.xy[a].x, mesh.xy[b].x), hi_x = std::max(mesh.xy[a].x, mesh.xy[b].x);
    const double lo_y = std::min(mesh.xy[a].y, mesh.xy[b].y), hi_y = std::max(mesh.xy[a].y, mesh.xy[b].y);
    return mesh.xy[v].x >= lo_x && mesh.xy[v].x <= hi_x && mesh.xy[v].y >= lo_y && mesh.xy[v].y <= hi_y;
  };
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v)
    if (on_segment(v)) w.vertices.insert(v);
  for (const auto& [p, q] : mesh_edges(mesh)) {
    const int op = orient_of(mesh, a, b, p), oq = orient_of(mesh, a, b, q);
    const int oa = orient_of(mesh, p, q, a), ob = orient_of(mesh, p, q, b);
    if (op * oq < 0 && oa * ob < 0) w.crossed.insert({p, q});
    if (w.vertices.count(p) != 0 && w.vertices.count(q) != 0) w.along.insert({p, q});
  }
  return w;
}

TEST(WalkCorridor, MatchesBruteForceOnRandomPointsAndLattices) {
  int with_vertices_between = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const trixel_gen::Pslg in =
        seed % 2 == 0 ? trixel_gen::lattice(7) : trixel_gen::random_points(60, Distribution::uniform, seed);
    std::vector<double> x, y;
    for (const cdt::Point& p : in.points) {
      x.push_back(p.x);
      y.push_back(p.y);
    }
    Mesh mesh = sweep_triangulate(x, y);
    trixel_gen::Random rng(seed);
    const auto n = static_cast<std::uint32_t>(x.size());
    for (int k = 0; k < 40; ++k) {
      const auto a = static_cast<std::uint32_t>(rng.next() % n);
      const auto b = static_cast<std::uint32_t>(rng.next() % n);
      if (a == b) continue;
      const Walked got = walk(mesh, a, b);
      const Walked want = brute_force(mesh, a, b);
      ASSERT_TRUE(got.ok) << "seed " << seed << " " << a << "-" << b;
      EXPECT_EQ(got.vertices, want.vertices) << "seed " << seed << " " << a << "-" << b;
      EXPECT_EQ(got.crossed, want.crossed) << "seed " << seed << " " << a << "-" << b;
      EXPECT_EQ(got.along, want.along) << "seed " << seed << " " << a << "-" << b;
      if (want.vertices.size() > 2) ++with_vertices_between;
    }
  }
  EXPECT_GT(with_vertices_between, 5); // the lattices put vertices on many segments
}

TEST(WalkCorridor, FailsForAnEndOutsideTheMesh) {
  Mesh mesh = sweep_triangulate({0, 1, 0, 5}, {0, 0, 1, 5});
  mesh.vert_tri[3] = kNoId; // vertex 3 taken out of the mesh
  EXPECT_FALSE(walk(mesh, 0, 3).ok);
}

/// Vertex (i, j) of a lattice of lattice_mesh() `width` vertices wide.
std::uint32_t at(std::uint32_t i, std::uint32_t j, std::uint32_t width = 6) { return j * width + i; }

/// A width x height lattice, each square cut by its rising diagonal.
Mesh lattice_mesh(std::uint32_t width = 6, std::uint32_t height = 6) {
  std::vector<double> x, y;
  for (std::uint32_t j = 0; j < height; ++j) {
    for (std::uint32_t i = 0; i < width; ++i) {
      x.push_back(i);
      y.push_back(j);
    }
  }
  std::vector<trixel_test::Triangle> triangles;
  for (std::uint32_t j = 0; j + 1 < height; ++j) {
    for (std::uint32_t i = 0; i + 1 < width; ++i) {
      triangles.push_back({at(i, j, width), at(i + 1, j, width), at(i + 1, j + 1, width)});
      triangles.push_back({at(i, j, width), at(i + 1, j + 1, width), at(i, j + 1, width)});
    }
  }
  return trixel_test::mesh_from_triangles(x, y, triangles);
}

TEST(ScreenPieces, EdgesAreCleanTheOthersAndWhatTheyCrossSuspect) {
  // The pieces: the edges along the row y = 4 (far from the rest), the edge (2, 0)-(2, 1), and a piece
  // from (1, 0) to (3, 1) that crosses it.
  Mesh mesh = lattice_mesh();
  std::vector<cdt::detail::ConstraintPiece2> pieces;
  for (std::uint32_t i = 0; i + 1 < 6; ++i) pieces.push_back({at(i, 4), at(i + 1, 4), 0});
  pieces.push_back({at(2, 0), at(2, 1), 0});
  pieces.push_back({at(1, 0), at(3, 1), 0});
  const std::set<Edge> edges = mesh_edges(mesh);
  for (std::size_t k = 0; k + 1 < pieces.size(); ++k)
    ASSERT_TRUE(edges.count(undirected(pieces[k].a, pieces[k].b))) << k;
  ASSERT_FALSE(edges.count(undirected(pieces.back().a, pieces.back().b)));
  for (unsigned threads : {1u, 2u}) {
    cdt::detail::CpuExecutor executor(threads);
    const cdt::detail::ScreenedPieces s = cdt::detail::screen_pieces(mesh.view(), pieces, executor);
    ASSERT_TRUE(s.complete);
    EXPECT_EQ(s.pieces, (std::vector<std::uint32_t>{5, 6})) << threads << " threads";
    EXPECT_TRUE(s.changes) << threads << " threads"; // a crossing: the split will change the pieces
    // The ends of both: the corners of the two triangles at the crossed edge.
    std::vector<std::uint32_t> want{at(1, 0), at(3, 1), at(2, 0), at(2, 1)};
    std::sort(want.begin(), want.end());
    EXPECT_EQ(s.sites, want) << threads << " threads";
  }
}

// Pieces that are no edges: suspect when they meet, clean when their corridors share no triangle.
TEST(ScreenPieces, PiecesThatAreNoEdgesAreSuspectOnlyWhereTheyMeet) {
  Mesh mesh = lattice_mesh();
  cdt::detail::CpuExecutor executor(2);
  const auto screen = [&](const std::vector<cdt::detail::ConstraintPiece2>& pieces) {
    const cdt::detail::ScreenedPieces s = cdt::detail::screen_pieces(mesh.view(), pieces, executor);
    EXPECT_TRUE(s.complete);
    return s;
  };
  // Far apart, through no vertex: nothing to split.
  const cdt::detail::ScreenedPieces apart = screen({{at(0, 0), at(2, 1), 0}, {at(3, 3), at(5, 4), 0}});
  EXPECT_TRUE(apart.pieces.empty());
  EXPECT_TRUE(apart.sites.empty());
  EXPECT_FALSE(apart.changes);
  // Crossing at (1, 0.5), inside the edge (1, 0)-(1, 1): both suspect, with the corners around.
  const cdt::detail::ScreenedPieces crossing = screen({{at(0, 0), at(2, 1), 0}, {at(0, 1), at(2, 0), 0}});
  EXPECT_EQ(crossing.pieces, (std::vector<std::uint32_t>{0, 1}));
  EXPECT_TRUE(crossing.changes);
  for (const std::uint32_t v : {at(0, 0), at(2, 1), at(0, 1), at(2, 0), at(1, 0), at(1, 1)})
    EXPECT_TRUE(std::binary_search(crossing.sites.begin(), crossing.sites.end(), v)) << v;
  // One runs along the edges of the row y = 2 through (1, 2); the other crosses it at (0.5, 2), inside
  // the edge (0, 2)-(1, 2) that the first runs along. Both orders: the lower piece owns the triangles.
  const cdt::detail::ConstraintPiece2 along{at(0, 2), at(2, 2), 0}, across{at(0, 1), at(1, 3), 0};
  EXPECT_EQ(screen({along, across}).pieces, (std::vector<std::uint32_t>{0, 1}));
  EXPECT_TRUE(screen({along, across}).changes);
  EXPECT_TRUE(screen({across, along}).changes);
  EXPECT_EQ(screen({across, along}).pieces, (std::vector<std::uint32_t>{0, 1}));
  // A fan from (0, 0): both pass the triangle (0, 0), (1, 0), (1, 1) and meet only at their common end,
  // which the exact test of the two settles. In every order of the pieces.
  const cdt::detail::ConstraintPiece2 low{at(0, 0), at(3, 1), 0}, high{at(0, 0), at(2, 1), 0};
  for (const auto& fan : {std::vector{low, high}, std::vector{high, low}}) {
    const cdt::detail::ScreenedPieces s = screen(fan);
    EXPECT_TRUE(s.pieces.empty());
    EXPECT_TRUE(s.sites.empty());
    EXPECT_FALSE(s.changes);
  }
  // A third through that triangle makes a crowd, whose members are listed and tested in pairs: they meet
  // only at their common end.
  const cdt::detail::ConstraintPiece2 third{at(0, 0), at(5, 2), 0};
  for (const auto& fan : {std::vector{low, high, third}, std::vector{third, high, low}}) {
    const cdt::detail::ScreenedPieces s = screen(fan);
    EXPECT_TRUE(s.pieces.empty());
    EXPECT_TRUE(s.sites.empty());
    EXPECT_FALSE(s.changes);
  }
  // A fourth from (1, 0) to (0, 1) crosses all three inside that triangle: the crowd is suspect, with the
  // triangle's corners, in every place of the list.
  const cdt::detail::ConstraintPiece2 crosser{at(1, 0), at(0, 1), 0};
  for (const auto& crowd : {std::vector{low, high, third, crosser}, std::vector{crosser, third, high, low},
                            std::vector{high, crosser, low, third}}) {
    const cdt::detail::ScreenedPieces s = screen(crowd);
    EXPECT_EQ(s.pieces, (std::vector<std::uint32_t>{0, 1, 2, 3}));
    EXPECT_TRUE(s.changes);
    for (const std::uint32_t v : {at(0, 0), at(1, 0), at(1, 1), at(0, 1), at(3, 1), at(2, 1), at(5, 2)})
      EXPECT_TRUE(std::binary_search(s.sites.begin(), s.sites.end(), v)) << v;
  }
  // Beside a crowd that meets nothing, a pair crossing elsewhere: only the pair is suspect.
  const std::vector<cdt::detail::ConstraintPiece2> calm_crowd{
      low, high, third, {at(3, 3), at(5, 4), 0}, {at(3, 4), at(5, 3), 0}};
  EXPECT_EQ(screen(calm_crowd).pieces, (std::vector<std::uint32_t>{3, 4}));
  // A crossing pair beside a fan from (2, 2) that shares a triangle: the fan stays clean.
  const std::vector<cdt::detail::ConstraintPiece2> mixed{
      {at(0, 0), at(2, 1), 0}, {at(0, 1), at(2, 0), 0}, {at(2, 2), at(5, 3), 0}, {at(2, 2), at(4, 3), 0}};
  EXPECT_EQ(screen(mixed).pieces, (std::vector<std::uint32_t>{0, 1}));
  EXPECT_TRUE(screen(mixed).changes);
}

// A crowd that a far piece passes, or listed more than kCrowdLimit times, keeps all its members
// suspect (the screen cannot tell whether they cross), with the triangle's corners.
TEST(ScreenPieces, CrowdsOfAFarPieceOrOfTooManyStaySuspect) {
  cdt::detail::CpuExecutor executor(2);
  {
    // A 60 x 2 strip: 120 vertices over a 59 x 1 box, far beyond 24 * sqrt(59 / 120), about 16.8.
    Mesh strip = lattice_mesh(60, 2);
    const auto on = [](std::uint32_t i, std::uint32_t j) { return at(i, j, 60); };
    const cdt::detail::ConstraintPiece2 low{on(0, 0), on(3, 1), 0}, high{on(0, 0), on(2, 1), 0},
        near{on(0, 0), on(16, 1), 0}, far{on(0, 0), on(17, 1), 0};
    const auto screen = [&](const std::vector<cdt::detail::ConstraintPiece2>& pieces) {
      const cdt::detail::ScreenedPieces s = cdt::detail::screen_pieces(strip.view(), pieces, executor);
      EXPECT_TRUE(s.complete);
      return s;
    };
    const cdt::detail::ScreenedPieces short_crowd = screen({low, high, near});
    EXPECT_TRUE(short_crowd.pieces.empty());
    EXPECT_TRUE(short_crowd.sites.empty());
    for (const auto& crowd :
         {std::vector{low, high, far}, std::vector{far, high, low}, std::vector{high, far, low}}) {
      const cdt::detail::ScreenedPieces s = screen(crowd);
      EXPECT_EQ(s.pieces, (std::vector<std::uint32_t>{0, 1, 2}));
      EXPECT_FALSE(s.changes); // suspects that meet nothing: the screen cannot tell
      for (const std::uint32_t v : {on(0, 0), on(1, 0), on(1, 1), on(3, 1), on(2, 1), on(17, 1)})
        EXPECT_TRUE(std::binary_search(s.sites.begin(), s.sites.end(), v)) << v;
    }
  }
  // A fan from (0, 0) on a 16 x 16 lattice: every piece to a vertex (i, j) below the diagonal, through
  // no vertex, passes the triangle (0, 0), (1, 0), (1, 1). kCrowdLimit of them are listed and clean; one
  // more keeps them all suspect.
  Mesh mesh = lattice_mesh(16, 16);
  std::vector<cdt::detail::ConstraintPiece2> fan;
  for (std::uint32_t i = 2; i < 16 && fan.size() <= cdt::detail::kCrowdLimit; ++i) {
    for (std::uint32_t j = 1; j < i && fan.size() <= cdt::detail::kCrowdLimit; ++j)
      if (std::gcd(i, j) == 1) fan.push_back({at(0, 0, 16), at(i, j, 16), 0});
  }
  ASSERT_EQ(fan.size(), cdt::detail::kCrowdLimit + 1);
  const cdt::detail::ScreenedPieces all = cdt::detail::screen_pieces(mesh.view(), fan, executor);
  EXPECT_EQ(all.pieces.size(), fan.size());
  EXPECT_FALSE(all.changes);
  fan.pop_back();
  const cdt::detail::ScreenedPieces listed = cdt::detail::screen_pieces(mesh.view(), fan, executor);
  EXPECT_TRUE(listed.pieces.empty());
  EXPECT_TRUE(listed.sites.empty());
}

TEST(ScreenPieces, AnEndOutsideTheMeshMakesEverythingSuspect) {
  Mesh mesh = sweep_triangulate({0, 1, 0, 5}, {0, 0, 1, 5});
  mesh.vert_tri[3] = kNoId;
  cdt::detail::CpuExecutor executor(1);
  const std::vector<cdt::detail::ConstraintPiece2> pieces{{0, 3, 0}};
  EXPECT_FALSE(cdt::detail::screen_pieces(mesh.view(), pieces, executor).complete);
}

// --- triangulate() with screening against splitting first --------------------------------------------

using Coordinates = std::pair<double, double>;

/// The constraint edges by their ends' coordinates, with their segment ids.
std::set<std::tuple<Coordinates, Coordinates, std::uint32_t>> constraint_edges(const cdt::Triangulation& t) {
  std::set<std::tuple<Coordinates, Coordinates, std::uint32_t>> edges;
  for (std::size_t k = 0; k < t.triangles.size(); ++k) {
    for (std::uint32_t i = 0; i < 3; ++i) {
      if (t.segment_of_edge[k][i] == cdt::kNone) continue;
      const cdt::Point& p = t.vertices[t.triangles[k][(i + 1) % 3]];
      const cdt::Point& q = t.vertices[t.triangles[k][(i + 2) % 3]];
      const Coordinates u{p.x, p.y}, w{q.x, q.y};
      edges.insert({std::min(u, w), std::max(u, w), t.segment_of_edge[k][i]});
    }
  }
  return edges;
}

/// The triangles by their corners' coordinates, rotated to start at the smallest.
std::set<std::array<Coordinates, 3>> triangles_by_coordinates(const cdt::Triangulation& t) {
  std::set<std::array<Coordinates, 3>> out;
  for (const auto& tri : t.triangles) {
    std::array<Coordinates, 3> c;
    for (int i = 0; i < 3; ++i) c[i] = {t.vertices[tri[i]].x, t.vertices[tri[i]].y};
    std::rotate(c.begin(), std::min_element(c.begin(), c.end()), c.end());
    out.insert(c);
  }
  return out;
}

std::multiset<Coordinates> vertex_coordinates(const cdt::Triangulation& t) {
  std::multiset<Coordinates> out;
  for (const cdt::Point& p : t.vertices) out.insert({p.x, p.y});
  return out;
}

/// Screening gives the same vertices and constraint edges as splitting first, and both verify; with
/// points in general position also the same triangles.
void expect_same_as_splitting_first(const std::vector<cdt::Point>& points,
                                    const std::vector<cdt::Segment>& segments, bool general_position,
                                    const std::string& what) {
  cdt::Options cpu;
  cpu.backend = cdt::Backend::cpu; // splitting first runs on the CPU executor
  const cdt::Triangulation screened = cdt::triangulate(points, segments, cpu);
  const cdt::Triangulation first = cdt::detail::triangulate_splitting_first(points, segments, cpu);
  EXPECT_TRUE(cdt::verify(screened, points, segments).ok()) << what;
  EXPECT_TRUE(cdt::verify(first, points, segments).ok()) << what;
  EXPECT_EQ(screened.stats.added_vertices, first.stats.added_vertices) << what;
  EXPECT_EQ(vertex_coordinates(screened), vertex_coordinates(first)) << what;
  EXPECT_EQ(constraint_edges(screened), constraint_edges(first)) << what;
  if (general_position) {
    EXPECT_EQ(triangles_by_coordinates(screened), triangles_by_coordinates(first)) << what;
  }
  const auto split = std::find_if(screened.stats.phases.begin(), screened.stats.phases.end(),
                                  [](const cdt::PhaseStats& p) { return p.name == "split"; });
  // A run started again splitting first (a screened split that failed) has no split phase of its own.
  if (screened.stats.attempts == 1) {
    EXPECT_EQ(split != screened.stats.phases.end(), !segments.empty()) << what;
  }
}

TEST(TriangulateScreened, CrossingRandomSegmentsAsSplittingFirst) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    trixel_gen::Pslg in = trixel_gen::random_points(3000, Distribution::uniform, seed);
    trixel_gen::Random rng(seed + 100);
    // Long random segments: thousands of crossings, several on most segments.
    trixel_gen::add_random_segments(in, 120, rng);
    expect_same_as_splitting_first(in.points, in.segments, true, "seed " + std::to_string(seed));
    cdt::Options cpu;
    cpu.backend = cdt::Backend::cpu;
    const cdt::Triangulation t = cdt::triangulate(in.points, in.segments, cpu);
    EXPECT_LT(t.stats.added_vertices, in.points.size()) << seed;
    EXPECT_EQ(t.stats.attempts, 1u) << seed << ": the crossing vertices are inserted into the sites' mesh";
  }
}

// Long segments among few points: more crossing vertices than sites, so the mesh is made again from
// all of them instead of inserting them. The same result as splitting first; the statistics name each
// phase once, summing both attempts.
TEST(TriangulateScreened, CrossingsOutnumberingTheSitesMakeTheMeshAgain) {
  for (std::uint64_t seed = 1; seed <= 2; ++seed) {
    trixel_gen::Pslg in = trixel_gen::random_points(300, Distribution::uniform, seed);
    trixel_gen::Random rng(seed + 200);
    trixel_gen::add_random_segments(in, 150, rng);
    const std::string what = "seed " + std::to_string(seed);
    expect_same_as_splitting_first(in.points, in.segments, true, what);
    std::vector<std::set<std::array<Coordinates, 3>>> triangles;
    for (const unsigned threads : {1u, 3u}) {
      cdt::Options cpu;
      cpu.backend = cdt::Backend::cpu;
      cpu.threads = threads;
      const cdt::Triangulation t = cdt::triangulate(in.points, in.segments, cpu);
      EXPECT_GT(t.stats.added_vertices, in.points.size()) << what;
      EXPECT_EQ(t.stats.attempts, 2u) << what;
      std::set<std::string> names;
      for (const cdt::PhaseStats& p : t.stats.phases)
        EXPECT_TRUE(names.insert(p.name).second) << what << p.name;
      const auto split = std::find_if(t.stats.phases.begin(), t.stats.phases.end(),
                                      [](const cdt::PhaseStats& p) { return p.name == "split"; });
      ASSERT_NE(split, t.stats.phases.end()) << what;
      EXPECT_EQ(split->missing, t.stats.added_vertices) << what;
      triangles.push_back(triangles_by_coordinates(t));
    }
    EXPECT_EQ(triangles[0], triangles[1]) << what << ": the same for any thread count";
  }
}

TEST(TriangulateScreened, SyntheticPslgWithAFewCrossersAsSplittingFirst) {
  // Mostly edges of the Delaunay mesh (short segments), plus a few long ones crossing them.
  trixel_gen::Pslg in = trixel_gen::synthetic_pslg(20000, 2000, Distribution::uniform, 7);
  trixel_gen::Random rng(8);
  trixel_gen::add_random_segments(in, 10, rng);
  expect_same_as_splitting_first(in.points, in.segments, true, "synthetic");
}

TEST(TriangulateScreened, LatticeSegmentsThroughPointsAndOverlapsAsSplittingFirst) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const trixel_gen::Pslg in = trixel_gen::lattice_with_segments(24, 150, seed);
    expect_same_as_splitting_first(in.points, in.segments, false, "lattice seed " + std::to_string(seed));
  }
}

TEST(TriangulateScreened, ArtemOgreFilesAsSplittingFirst) {
  const int files =
      trixel_test::for_each_artem_ogre_file([](const std::string& name, const cdt::io::Pslg& in) {
        try {
          expect_same_as_splitting_first(in.points, in.segments, false, name);
        } catch (const cdt::Error& e) {
          ADD_FAILURE() << name << ": " << e.what();
        }
      });
  EXPECT_EQ(files, trixel_test::kArtemOgreFiles);
}

TEST(TriangulateScreened, RejectedCrossingsNameTheSameSegments) {
  const trixel_gen::Pslg in = trixel_gen::lattice_with_segments(16, 80, 3);
  cdt::Options o;
  o.crossings = cdt::CrossingSegments::reject;
  o.backend = cdt::Backend::cpu;
  std::pair<std::uint32_t, std::uint32_t> screened{0, 0}, first{1, 1};
  try {
    cdt::triangulate(in.points, in.segments, o);
    ADD_FAILURE() << "no error (screened)";
  } catch (const cdt::CrossingSegmentsError& e) {
    screened = {e.first(), e.second()};
  }
  try {
    cdt::detail::triangulate_splitting_first(in.points, in.segments, o);
    ADD_FAILURE() << "no error (splitting first)";
  } catch (const cdt::CrossingSegmentsError& e) {
    first = {e.first(), e.second()};
  }
  EXPECT_EQ(screened, first);
}

// Crossings among segments that nearly overlap at the limit of double precision, found by random
// testing: a crossing point rounded onto a piece the screen left clean, a piece bent through one
// across another, and suspects whose split alone did not converge (the whole input's does). Each failed
// inside the screened run; now it starts again splitting first, and gives what splitting first gives.
TEST(TriangulateScreened, RoundedCrossingsBesideCleanPiecesAsSplittingFirst) {
  struct Case {
    std::string what;
    std::vector<cdt::Point> points;
    std::vector<cdt::Segment> segments;
  };
  const std::vector<Case> cases = {
      {"a crossing rounded onto a piece near (1, 1)",
       {{1.000000146279435, 1.0000000000002391},
        {0.99999999999999944, 0.99999999999999978},
        {1.0000000000000009, -1},
        {0.99999999999999989, -0.99999999999999922},
        {1.0000000000000004, -1.0000000000000002},
        {-1.3252357242056929, -1.8516892597678218},
        {0.99999999999929279, 1.0000000000005604},
        {1.0000000422592494, 1.0000000000005709},
        {1.0000000000000018, -1.0000000000000016},
        {1.0000000000000018, -0.99999999999999944},
        {0.99999999999923328, 1.0000000000004989},
        {0.99999999999999911, 0.99999999999999922},
        {0.99999995415679832, 1.0000000000005007},
        {1.0000000000000018, -1.0000000000000004}},
       {{5, 7}, {3, 6}, {8, 10}, {11, 3}, {12, 4}, {1, 5}, {0, 3}, {2, 1}}},
      {"a piece bent across another near (1e15, 1e15)",
       {{999999739530013.75, 999999999999300.12},
        {1000000000000891.5, 999999999999565.75},
        {1000000405257049.2, 1000000000000816.5},
        {999999999999206.38, 999999999999486.5},
        {999999999999999.5, -1000000000000000.9},
        {862416096287312.88, -1539532636117132.2},
        {1000000000000000.4, -1000000000000000.8},
        {1000000000000001, 1000000000000000.1},
        {1000000000000000.2, -999999999999999.62},
        {999999999999999, -1000000000000000.8}},
       {{1, 5}, {2, 8}, {7, 6}, {9, 2}, {3, 9}, {2, 5}, {5, 8}, {0, 4}, {8, 9}}},
      {"crossings near (1e-15, 1e-15) that a split of the suspects alone keeps making",
       {{9.9999999999999968e-16, 9.9999999999999968e-16},  {9.999999999999987e-16, 1.0000000000000007e-15},
        {1.0000000000000013e-15, 9.9999999999999988e-16},  {9.9999999999999909e-16, 1.0000000000000009e-15},
        {1.0000000000000003e-15, 9.9999999999999929e-16},  {1.0000000000000011e-15, 9.999999999999987e-16},
        {9.9999999999999909e-16, 9.9999999999999949e-16},  {2.770773269690543e-16, -1.805061180916183e-15},
        {1.0000000000007968e-15, 1.0000000000006278e-15},  {9.9999999999999929e-16, 9.9999999999999968e-16},
        {1.0000000000000013e-15, 9.999999999999987e-16},   {9.9999999999999909e-16, 9.999999999999987e-16},
        {9.9999999999999988e-16, -1.0000000000000005e-15}, {1.0000000000000011e-15, 9.9999999999999949e-16},
        {9.9999999999999968e-16, -9.9999999999999889e-16}, {9.9999994655527881e-16, 9.999999999994534e-16},
        {9.9999999999999909e-16, 9.9999999999999968e-16},  {1.0000000000000011e-15, 9.9999999999999909e-16},
        {9.9999999999999929e-16, 9.9999999999999949e-16},  {9.9999923611365862e-16, 1.0000000000001158e-15},
        {9.9999999999999949e-16, 9.9999999999999988e-16},  {1.0000000000000007e-15, 9.9999999999999949e-16},
        {1.0000000000000013e-15, -9.9999999999999949e-16}, {9.999999999999985e-16, 9.9999999999999909e-16},
        {1.0000000000000009e-15, 9.9999999999999889e-16}},
       {{3, 22}, {8, 23}, {13, 12}, {7, 2}, {15, 10}, {14, 1}, {19, 0}, {24, 20}}},
  };
  for (const Case& c : cases) {
    expect_same_as_splitting_first(c.points, c.segments, false, c.what);
    cdt::Options cpu;
    cpu.backend = cdt::Backend::cpu;
    EXPECT_GE(cdt::triangulate(c.points, c.segments, cpu).stats.attempts, 2u) << c.what;
  }
}

// Many inputs of that kind (one in ten failed inside the screened run before it started again
// splitting first) come out verified. Splitting first may bend them otherwise: a vertex added
// in a repair round is snapped into the suspects alone when screened, into every piece when not.
TEST(TriangulateScreened, NearlyOverlappingSegmentsComeOutVerified) {
  cdt::Options cpu;
  cpu.backend = cdt::Backend::cpu;
  int restarted = 0;
  for (std::uint64_t seed = 1; seed <= 300; ++seed) {
    const trixel_gen::Pslg in = trixel_gen::nearly_overlapping(seed);
    const std::string what = "seed " + std::to_string(seed);
    try {
      const cdt::Triangulation t = cdt::triangulate(in.points, in.segments, cpu);
      const cdt::VerifyReport report = cdt::verify(t, in.points, in.segments);
      EXPECT_TRUE(report.ok()) << what << ": " << (report.problems.empty() ? "" : report.problems.front());
      restarted += t.stats.attempts > 1;
    } catch (const cdt::InvalidInputError& e) {
      EXPECT_EQ(e.kind(), cdt::InvalidInputError::Kind::all_collinear) << what << ": " << e.what();
    } catch (const cdt::Error& e) {
      ADD_FAILURE() << what << ": " << e.what();
    }
  }
  EXPECT_GT(restarted, 10) << "few inputs needed the split started again: the test lost its point";
}

// A long segment's corridor walked in parts (the GPU backend's, each part from the triangle holding a
// point of the segment to the next part's) makes the calls of the whole walk, each once: every crossed
// edge, every edge run along and every vertex passed, on a Delaunay mesh of random points and a
// lattice (segments through its points and along its lines), for segments between random vertices.
TEST(ScreenWalk, PartsOfACorridorMakeTheWholeWalk) {
  using cdt::detail::CorridorPart;
  using cdt::detail::MeshView;
  trixel_gen::Random rng(92);
  const Mesh mesh = trixel_test::points_and_lattice_mesh([&] { return rng.unit(); }, 2500, 30);
  Mesh copy = mesh;
  const MeshView m = copy.view();
  const std::uint32_t n = mesh.num_vertices();
  struct Calls {
    std::multiset<std::uint32_t> crossed, along, vertices;
  };
  std::size_t compared = 0, split = 0, through_vertices = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    // Half the segments within the lattice, between lattice points.
    const std::uint32_t lattice = 2500;
    const auto a = trial % 2 == 0 ? static_cast<std::uint32_t>(rng.next() % n)
                                  : lattice + static_cast<std::uint32_t>(rng.next() % 900);
    const auto b = trial % 2 == 0 ? static_cast<std::uint32_t>(rng.next() % n)
                                  : lattice + static_cast<std::uint32_t>(rng.next() % 900);
    if (a == b) continue;
    Calls whole;
    const auto record = [&](Calls& c) {
      return std::tuple{[&c](std::uint32_t v) { c.vertices.insert(v); },
                        [&c](std::uint32_t e) { c.crossed.insert(e); },
                        [&c, m](std::uint32_t e) { c.along.insert(std::min(e, m.adj[e])); }};
    };
    {
      auto [on_vertex, crossed, along] = record(whole);
      if (!cdt::detail::walk_corridor(m, a, b, on_vertex, crossed, along)) continue;
    }
    // Parts from q - 1 inner points of the segment, located from a random vertex.
    const int q = 2 + static_cast<int>(rng.next() % 12);
    std::vector<CorridorPart> parts(1); // the first from a
    for (int j = 1; j < q; ++j) {
      const double s = static_cast<double>(j) / q;
      const double px = m.xy[a].x + s * (m.xy[b].x - m.xy[a].x), py = m.xy[a].y + s * (m.xy[b].y - m.xy[a].y);
      const cdt::detail::PointLocation loc =
          cdt::detail::locate_point(m, static_cast<std::uint32_t>(rng.next() % n), px, py);
      CorridorPart part;
      if (loc.status != cdt::detail::WorkStatus::ok || !cdt::detail::walk_entry(m, a, b, loc.tri, part.at))
        continue;
      part.tri = loc.tri;
      const bool again =
          std::any_of(parts.begin(), parts.end(), [&](const CorridorPart& p) { return p.tri == part.tri; });
      if (!again) parts.push_back(part);
    }
    for (std::size_t j = 0; j + 1 < parts.size(); ++j) parts[j].stop = parts[j + 1].tri;
    Calls joined;
    bool ok = true, in_order = true;
    for (CorridorPart& part : parts) {
      auto [on_vertex, crossed, along] = record(joined);
      ok = cdt::detail::walk_corridor(m, a, b, on_vertex, crossed, along, &part) && ok;
      if (part.stop != kNoId && !part.met_stop) in_order = false;
    }
    if (!in_order) continue; // the backend walks such a segment whole
    ++compared;
    if (parts.size() > 1) ++split;
    if (whole.vertices.size() > 2) ++through_vertices;
    EXPECT_TRUE(ok) << a << " -> " << b;
    EXPECT_EQ(joined.crossed, whole.crossed) << a << " -> " << b;
    EXPECT_EQ(joined.along, whole.along) << a << " -> " << b;
    EXPECT_EQ(joined.vertices, whole.vertices) << a << " -> " << b;
    if (HasFailure()) return;
  }
  EXPECT_GT(compared, 2500u);
  EXPECT_GT(split, 1500u);
  EXPECT_GT(through_vertices, 100u);
}

} // namespace
