// Tests of verify(): small triangulations built by hand, each valid one passing and each hand-broken
// one failing with a message that names the check.
#include "cdt/verify.hpp"

#include <gtest/gtest.h>

#include "cdt/cdt.hpp"
#include "cdt/detail/predicates.hpp"
#include "pslg_generators.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace {

using cdt::kNone;
using cdt::Point;
using cdt::Segment;
using cdt::Triangulation;
using Triangle = std::array<std::uint32_t, 3>;

/// A triangulation from vertices and CCW triangles: neighbours by matching reversed edges, constraint
/// flags from (vertex pair -> segment id), duplicate_of the identity unless given.
Triangulation
make_mesh(std::vector<Point> vertices, std::vector<Triangle> triangles,
          const std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t>& constraints = {},
          std::size_t num_points = 0) {
  Triangulation t;
  t.vertices.assign(vertices.begin(), vertices.end());
  t.triangles.assign(triangles.begin(), triangles.end());
  const std::size_t n = t.triangles.size();
  t.neighbors.assign(n, {kNone, kNone, kNone});
  t.segment_of_edge.assign(n, {kNone, kNone, kNone});
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::pair<std::uint32_t, std::uint32_t>> directed;
  for (std::uint32_t k = 0; k < n; ++k) {
    for (std::uint32_t i = 0; i < 3; ++i) {
      directed[{t.triangles[k][(i + 1) % 3], t.triangles[k][(i + 2) % 3]}] = {k, i};
    }
  }
  for (std::uint32_t k = 0; k < n; ++k) {
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t p = t.triangles[k][(i + 1) % 3];
      const std::uint32_t q = t.triangles[k][(i + 2) % 3];
      const auto other = directed.find({q, p});
      if (other != directed.end()) t.neighbors[k][i] = other->second.first;
      const auto c = constraints.find({std::min(p, q), std::max(p, q)});
      if (c != constraints.end()) t.segment_of_edge[k][i] = c->second;
    }
  }
  t.duplicate_of.resize(num_points == 0 ? t.vertices.size() : num_points);
  for (std::uint32_t i = 0; i < t.duplicate_of.size(); ++i) t.duplicate_of[i] = i;
  return t;
}

bool mentions(const cdt::VerifyReport& r, const std::string& words) {
  return std::any_of(r.problems.begin(), r.problems.end(),
                     [&](const std::string& p) { return p.find(words) != std::string::npos; });
}

std::string all_problems(const cdt::VerifyReport& r) {
  std::string s = std::to_string(r.num_problems) + " problems";
  for (const std::string& p : r.problems) s += "\n  " + p;
  return s;
}

// A convex trapezoid: diagonal 0-2 is Delaunay (3 lies outside the circle of 0, 1, 2), 1-3 is not.
//   3 (0,2)
//   |      `--.
//   |          2 (3,1)
//   0 (0,0) -- 1 (3,0)
const std::vector<Point> kQuad{{0, 0}, {3, 0}, {3, 1}, {0, 2}};
Triangulation quad_02(const std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t>& c = {}) {
  return make_mesh(kQuad, {{0, 1, 2}, {0, 2, 3}}, c);
}
Triangulation quad_13(const std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t>& c = {}) {
  return make_mesh(kQuad, {{0, 1, 3}, {1, 2, 3}}, c);
}

// --- Delaunay and constraints ------------------------------------------------------------------------

TEST(Verify, DelaunayDiagonalPasses) {
  const auto r = cdt::verify(quad_02(), kQuad, {});
  EXPECT_TRUE(r.ok()) << all_problems(r);
}

TEST(Verify, NonDelaunayDiagonalFails) {
  const auto r = cdt::verify(quad_13(), kQuad, {});
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r, "not locally Delaunay")) << all_problems(r);
  EXPECT_EQ(r.num_problems, 1u);
}

TEST(Verify, ConstraintMakesNonDelaunayDiagonalValid) {
  const std::vector<Segment> s{{3, 1}};
  const auto r = cdt::verify(quad_13({{{1, 3}, 0}}), kQuad, s);
  EXPECT_TRUE(r.ok()) << all_problems(r);
}

// Co-circular points (a rectangle): the tie is broken by the perturbation of the lexicographically
// first point (0, 0), which pushes it out of the others' circle, so only the diagonal 1-3 passes.
TEST(Verify, CocircularOnlyThePerturbedDiagonalPasses) {
  const std::vector<Point> rect{{0, 0}, {2, 0}, {2, 1}, {0, 1}};
  const auto good = cdt::verify(make_mesh(rect, {{0, 1, 3}, {1, 2, 3}}), rect, {});
  EXPECT_TRUE(good.ok()) << all_problems(good);
  const auto bad = cdt::verify(make_mesh(rect, {{0, 1, 2}, {0, 2, 3}}), rect, {});
  EXPECT_TRUE(mentions(bad, "lies on the circumcircle of")) << all_problems(bad);
  // A constraint on the other diagonal makes it valid.
  const std::vector<Segment> s{{0, 2}};
  Triangulation constrained = make_mesh(rect, {{0, 1, 2}, {0, 2, 3}});
  constrained.segment_of_edge[0][1] = 0;
  constrained.segment_of_edge[1][2] = 0;
  const auto r = cdt::verify(constrained, rect, s);
  EXPECT_TRUE(r.ok()) << all_problems(r);
}

TEST(Verify, MissingConstraintFails) {
  const std::vector<Segment> s{{1, 3}};
  const auto r = cdt::verify(quad_02(), kQuad, s);
  EXPECT_TRUE(mentions(r, "segment 0 (1 -> 3) is missing")) << all_problems(r);
}

TEST(Verify, ConstraintEdgeNotFlaggedFails) {
  const std::vector<Segment> s{{0, 2}};
  const auto r = cdt::verify(quad_02(), kQuad, s);
  EXPECT_TRUE(mentions(r, "edge (0, 2) on it is not a constraint")) << all_problems(r);
  EXPECT_TRUE(cdt::verify(quad_02({{{0, 2}, 0}}), kQuad, s).ok());
}

TEST(Verify, HullEdgeAsSegmentPasses) {
  const std::vector<Segment> s{{1, 0}, {2, 3}};
  const auto r = cdt::verify(quad_02({{{0, 1}, 0}, {{2, 3}, 1}}), kQuad, s);
  EXPECT_TRUE(r.ok()) << all_problems(r);
}

// 4 lies on segment 0-1, so the segment is the chain 0-4-1; overlapping input segments share it.
//   3 ------- 2
//   |  .   .  |
//   0 --- 4 --- 1
const std::vector<Point> kSplit{{0, 0}, {2, 0}, {2, 2}, {0, 2}, {1, 0}};
Triangulation split_mesh(std::uint32_t flag_04, std::uint32_t flag_41) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> c;
  if (flag_04 != kNone) c[{0, 4}] = flag_04;
  if (flag_41 != kNone) c[{1, 4}] = flag_41;
  return make_mesh(kSplit, {{0, 4, 3}, {4, 1, 2}, {4, 2, 3}}, c);
}

TEST(Verify, SegmentAsChainThroughAPointOnItPasses) {
  const std::vector<Segment> s{{0, 1}, {4, 1}, {1, 0}};
  const auto r = cdt::verify(split_mesh(0, 0), kSplit, s);
  EXPECT_TRUE(r.ok()) << all_problems(r);
}

TEST(Verify, ChainWithAnUnflaggedLinkFails) {
  const std::vector<Segment> s{{0, 1}};
  const auto r = cdt::verify(split_mesh(0, kNone), kSplit, s);
  EXPECT_TRUE(mentions(r, "edge (4, 1) on it is not a constraint")) << all_problems(r);
}

// A chain of constraint edges that bends visibly is not the segment, even though it joins its ends.
TEST(Verify, BentChainIsNotTheSegment) {
  std::vector<Point> p = kSplit;
  p[4].y = 1e-3; // above the line 0-1
  const std::vector<Segment> s{{0, 1}};
  const Triangulation t =
      make_mesh(p, {{0, 4, 3}, {4, 1, 2}, {4, 2, 3}, {0, 1, 4}}, {{{0, 4}, 0}, {{1, 4}, 0}});
  const auto r = cdt::verify(t, p, s);
  EXPECT_TRUE(mentions(r, "segment 0 (0 -> 1)")) << all_problems(r);
}

// Segments 0-1 and 2-3 cross at (1/3, 1/3), which is not a double: the added vertex 4 lies on 0-1 but
// an ulp off 2-3, whose chain 2-4-3 must still count.
TEST(Verify, ChainBentThroughARoundedCrossingPasses) {
  const std::vector<Point> p{{0, 0}, {1, 1}, {0, 0.5}, {1, 0}};
  const Point x{1.0 / 3.0, 1.0 / 3.0};
  ASSERT_NE(cdt::detail::orient2d(p[2].x, p[2].y, p[3].x, p[3].y, x.x, x.y), 0);
  std::vector<Point> v = p;
  v.push_back(x);
  Triangulation t = make_mesh(v, {{0, 3, 4}, {3, 1, 4}, {1, 2, 4}, {2, 0, 4}},
                              {{{0, 4}, 0}, {{1, 4}, 0}, {{2, 4}, 1}, {{3, 4}, 1}}, p.size());
  const std::vector<Segment> s{{0, 1}, {2, 3}};
  const auto r = cdt::verify(t, p, s);
  EXPECT_TRUE(r.ok()) << all_problems(r);
  // Unflag one half of the bent chain: now it is missing.
  t.segment_of_edge[0][1] = kNone; // edge (4, 0) of triangle (0, 3, 4)
  t.segment_of_edge[3][0] = kNone; // the same edge in triangle (2, 0, 4)
  EXPECT_TRUE(mentions(cdt::verify(t, p, s), "segment 0 (0 -> 1)"));
}

TEST(Verify, SegmentWithDuplicateEndpointUsesItsRepresentative) {
  std::vector<Point> p = kQuad;
  p.push_back(kQuad[0]);
  Triangulation t = quad_02({{{0, 2}, 0}});
  t.vertices.push_back(kQuad[0]);
  t.duplicate_of.push_back(0);
  const std::vector<Segment> s{{2, 4}};
  const auto r = cdt::verify(t, p, s);
  EXPECT_TRUE(r.ok()) << all_problems(r);
}

// --- triangles and links -----------------------------------------------------------------------------

TEST(Verify, ClockwiseTriangleFails) {
  Triangulation t = quad_02();
  std::swap(t.triangles[0][1], t.triangles[0][2]);
  const auto r = cdt::verify(t, kQuad, {});
  EXPECT_TRUE(mentions(r, "triangle 0 (0, 2, 1) is clockwise")) << all_problems(r);
}

TEST(Verify, DegenerateTriangleFails) {
  const std::vector<Point> p{{0, 0}, {1, 0}, {2, 0}, {1, 1}};
  const Triangulation t = make_mesh(p, {{0, 1, 3}, {1, 2, 3}, {0, 2, 1}});
  const auto r = cdt::verify(t, p, {});
  EXPECT_TRUE(mentions(r, "triangle 2 (0, 2, 1) is degenerate")) << all_problems(r);
}

TEST(Verify, AsymmetricLinkFails) {
  Triangulation t = quad_02();
  t.neighbors[1][2] = kNone;
  const auto r = cdt::verify(t, kQuad, {});
  EXPECT_TRUE(mentions(r, "link not symmetric: triangle 0 -> 1")) << all_problems(r);
  EXPECT_TRUE(mentions(r, "marked as a hull edge")) << all_problems(r);
}

TEST(Verify, LinkToATriangleWithoutTheEdgeFails) {
  const std::vector<Point> p{{0, 0}, {2, 0}, {2, 2}, {0, 2}, {1, 1}};
  Triangulation t = make_mesh(p, {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}});
  ASSERT_TRUE(cdt::verify(t, p, {}).ok()) << all_problems(cdt::verify(t, p, {}));
  t.neighbors[0][0] = 2; // across (1, 4), but triangle 2 has no edge (4, 1)
  const auto r = cdt::verify(t, p, {});
  EXPECT_TRUE(mentions(r, "triangle 0 names 2 as its neighbour across edge (1, 4)")) << all_problems(r);
}

TEST(Verify, ConstraintFlagOnOneSideOnlyFails) {
  Triangulation t = quad_02({{{0, 2}, 0}});
  t.segment_of_edge[1][2] = kNone;
  const std::vector<Segment> s{{0, 2}};
  const auto r = cdt::verify(t, kQuad, s);
  EXPECT_TRUE(mentions(r, "edge (2, 0) is constraint 0 in triangle 0 but none in triangle 1"))
      << all_problems(r);
}

TEST(Verify, ConstraintNamingNoSegmentFails) {
  const auto r = cdt::verify(quad_02({{{0, 2}, 5}}), kQuad, {});
  EXPECT_TRUE(mentions(r, "names segment 5")) << all_problems(r);
}

TEST(Verify, EdgeInThreeTrianglesFails) {
  const std::vector<Point> p{{0, 0}, {2, 0}, {1, 1}, {1, -1}, {1, 2}};
  const Triangulation t = make_mesh(p, {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}});
  const auto r = cdt::verify(t, p, {});
  EXPECT_TRUE(mentions(r, "edge (0, 1) is in 3 triangles")) << all_problems(r);
}

TEST(Verify, OverlappingTrianglesFail) {
  const std::vector<Point> p{{0, 0}, {2, 0}, {1, 1}, {1, 2}};
  const Triangulation t = make_mesh(p, {{0, 1, 2}, {0, 1, 3}});
  const auto r = cdt::verify(t, p, {});
  EXPECT_TRUE(mentions(r, "overlap: both have edge (0, 1) in the same direction")) << all_problems(r);
}

// --- sizes and indices -------------------------------------------------------------------------------

TEST(Verify, InconsistentSizesStopEarly) {
  Triangulation t = quad_02();
  t.neighbors.pop_back();
  const auto r = cdt::verify(t, kQuad, {});
  EXPECT_TRUE(mentions(r, "sizes differ")) << all_problems(r);
  Triangulation u = quad_02();
  u.duplicate_of.pop_back();
  EXPECT_TRUE(mentions(cdt::verify(u, kQuad, {}), "duplicate_of has 3 entries for 4 input points"));
  Triangulation w = quad_02();
  w.vertices.pop_back();
  EXPECT_TRUE(mentions(cdt::verify(w, kQuad, {}), "only 3 vertices for 4 input points"));
}

TEST(Verify, VertexIndexOutOfRangeFails) {
  Triangulation t = quad_02();
  t.triangles[1][2] = 9;
  const auto r = cdt::verify(t, kQuad, {});
  EXPECT_TRUE(mentions(r, "triangle 1 has vertex index 9")) << all_problems(r);
}

TEST(Verify, NeighbourIndexOutOfRangeFails) {
  Triangulation t = quad_02();
  t.neighbors[0][0] = 7;
  const auto r = cdt::verify(t, kQuad, {});
  EXPECT_TRUE(mentions(r, "triangle 0 has neighbour index 7")) << all_problems(r);
}

// Bit for bit: -0 equals 0 as a double but is not the input point.
TEST(Verify, VerticesMustKeepTheInputPointsBitForBit) {
  Triangulation t = quad_02();
  t.vertices[0].x = -0.0;
  const auto r = cdt::verify(t, kQuad, {});
  EXPECT_TRUE(mentions(r, "vertex 0 (-0, 0) differs from input point 0")) << all_problems(r);
}

TEST(Verify, NonFiniteVertexFailsWithoutCrashing) {
  Triangulation t = quad_02();
  t.vertices.push_back({std::nan(""), 1});
  t.triangles.push_back({0, 1, 4});
  t.neighbors.push_back({kNone, kNone, kNone});
  t.segment_of_edge.push_back({kNone, kNone, kNone});
  const auto r = cdt::verify(t, kQuad, {});
  EXPECT_TRUE(mentions(r, "vertex 4 has a non-finite coordinate (nan, 1)")) << all_problems(r);
}

TEST(Verify, SegmentIndexOutOfRangeFails) {
  const std::vector<Segment> s{{0, 4}};
  EXPECT_TRUE(mentions(cdt::verify(quad_02(), kQuad, s), "segment 0 (0, 4) refers to a point beyond"));
}

// --- the domain --------------------------------------------------------------------------------------

TEST(Verify, UnusedPointFails) {
  std::vector<Point> p = kQuad;
  p.push_back({1, 0.5});
  Triangulation t = quad_02();
  t.vertices.assign(p.begin(), p.end());
  t.duplicate_of.push_back(4);
  const auto r = cdt::verify(t, p, {});
  EXPECT_TRUE(mentions(r, "input point 4 is used by no triangle")) << all_problems(r);
  EXPECT_FALSE(mentions(r, "outside")) << all_problems(r);
}

TEST(Verify, PointOutsideTheHullFails) {
  std::vector<Point> p = kQuad;
  p.push_back({5, 5});
  Triangulation t = quad_02();
  t.vertices.assign(p.begin(), p.end());
  t.duplicate_of.push_back(4);
  const auto r = cdt::verify(t, p, {});
  EXPECT_TRUE(mentions(r, "vertex 4 lies outside the hull")) << all_problems(r);
}

TEST(Verify, UnusedAddedVertexFails) {
  Triangulation t = quad_02();
  t.vertices.push_back({1, 0.5});
  const auto r = cdt::verify(t, kQuad, {});
  EXPECT_TRUE(mentions(r, "added vertex 4 is used by no triangle")) << all_problems(r);
}

// An arrow: the hull cycle 0-1-2-3 has a reflex turn at 3.
TEST(Verify, NonConvexHullFails) {
  const std::vector<Point> p{{0, 0}, {4, 0}, {2, 4}, {2, 1}};
  const Triangulation t = make_mesh(p, {{0, 1, 3}, {1, 2, 3}});
  // The input points' hull is the triangle 0-1-2, so 3 is inside it; the mesh misses the part 0-3-2.
  const auto r = cdt::verify(t, p, {});
  EXPECT_TRUE(mentions(r, "hull is not convex: reflex turn at vertex 3")) << all_problems(r);
}

// A hole: the centre of a square ring is not triangulated.
TEST(Verify, HoleInTheMiddleFails) {
  const std::vector<Point> p{{0, 0}, {3, 0}, {3, 3}, {0, 3}, {1, 1}, {2, 1}, {2, 2}, {1, 2}};
  // Each trapezoid and the inner square are co-circular: cut by the diagonals the tie-break keeps.
  std::vector<Triangle> ring{{0, 1, 4}, {1, 5, 4}, {1, 2, 6}, {1, 6, 5},
                             {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
  std::vector<Triangle> full = ring;
  full.push_back({4, 5, 7});
  full.push_back({5, 6, 7});
  const auto ok = cdt::verify(make_mesh(p, full), p, {});
  EXPECT_TRUE(ok.ok()) << all_problems(ok);
  const auto r = cdt::verify(make_mesh(p, ring), p, {});
  EXPECT_TRUE(mentions(r, "Euler characteristic")) << all_problems(r);
  EXPECT_TRUE(mentions(r, "hull edges do not form one closed cycle")) << all_problems(r);
}

// Two triangles sharing only a vertex: the boundary passes twice through it.
TEST(Verify, PinchedDomainFails) {
  const std::vector<Point> p{{0, 0}, {1, 0}, {1, 1}, {2, 1}, {2, 2}};
  const Triangulation t = make_mesh(p, {{0, 1, 2}, {2, 3, 4}});
  const auto r = cdt::verify(t, p, {});
  EXPECT_TRUE(mentions(r, "vertex 2 starts two hull edges")) << all_problems(r);
}

// A fan around a centre whose rim winds around twice: every local check passes (CCW triangles,
// symmetric links, left turns only, V - E + F = 1), only the winding of the hull betrays it.
TEST(Verify, DoublyWoundDiscFails) {
  std::vector<Point> p{{0, 0}};
  std::vector<Triangle> fan;
  for (std::uint32_t k = 0; k < 10; ++k) {
    const double angle = 2 * 3.141592653589793 * 2 * k / 10.0;
    const double radius = k % 2 == 0 ? 1.0 : 1.05;
    p.push_back({radius * std::cos(angle), radius * std::sin(angle)});
    fan.push_back({0, 1 + k, 1 + (k + 1) % 10});
  }
  const auto r = cdt::verify(make_mesh(p, fan), p, {});
  EXPECT_TRUE(mentions(r, "hull turns around 2 times")) << all_problems(r);
  EXPECT_FALSE(mentions(r, "Euler")) << all_problems(r);
  EXPECT_FALSE(mentions(r, "clockwise")) << all_problems(r);
}

TEST(Verify, CollinearHullVerticesPass) {
  const auto r = cdt::verify(split_mesh(kNone, kNone), kSplit, {});
  EXPECT_TRUE(r.ok()) << all_problems(r);
}

TEST(Verify, NoTrianglesFails) {
  Triangulation t = make_mesh(kQuad, {});
  const auto r = cdt::verify(t, kQuad, {});
  EXPECT_TRUE(mentions(r, "no triangles")) << all_problems(r);
}

// --- duplicates --------------------------------------------------------------------------------------

/// kQuad plus point 4, a copy of point 1.
std::vector<Point> quad_with_duplicate() {
  std::vector<Point> p = kQuad;
  p.push_back(kQuad[1]);
  return p;
}
Triangulation quad_02_with_duplicate() {
  Triangulation t = quad_02();
  t.vertices.push_back(kQuad[1]);
  t.duplicate_of.push_back(1);
  return t;
}

TEST(Verify, DuplicateMappedToItsRepresentativePasses) {
  const auto r = cdt::verify(quad_02_with_duplicate(), quad_with_duplicate(), {});
  EXPECT_TRUE(r.ok()) << all_problems(r);
}

TEST(Verify, DuplicateMapToDifferentCoordinatesFails) {
  Triangulation t = quad_02_with_duplicate();
  t.duplicate_of[4] = 2;
  const auto r = cdt::verify(t, quad_with_duplicate(), {});
  EXPECT_TRUE(mentions(r, "point 4 is mapped to 2 but their coordinates differ")) << all_problems(r);
  EXPECT_TRUE(mentions(r, "points 1 and 4 are identical but not merged")) << all_problems(r);
}

TEST(Verify, DuplicateMapToANonRepresentativeFails) {
  std::vector<Point> p = quad_with_duplicate();
  p.push_back(kQuad[1]);
  Triangulation t = quad_02_with_duplicate();
  t.vertices.push_back(kQuad[1]);
  t.duplicate_of.push_back(4); // 5 -> 4, but 4 -> 1
  const auto r = cdt::verify(t, p, {});
  EXPECT_TRUE(mentions(r, "duplicate_of[5] = 4, which is not a representative")) << all_problems(r);
}

TEST(Verify, DuplicateUsedInsteadOfRepresentativeFails) {
  Triangulation t = quad_02_with_duplicate();
  t.triangles[0][1] = 4;
  const auto r = cdt::verify(t, quad_with_duplicate(), {});
  EXPECT_TRUE(mentions(r, "duplicate point 4 is used by a triangle instead of its representative 1"))
      << all_problems(r);
  EXPECT_TRUE(mentions(r, "input point 1 is used by no triangle")) << all_problems(r);
}

TEST(Verify, UnmergedIdenticalPointsFail) {
  Triangulation t = quad_02_with_duplicate();
  t.duplicate_of[4] = 4; // a representative of its own, and unused
  const auto r = cdt::verify(t, quad_with_duplicate(), {});
  EXPECT_TRUE(mentions(r, "points 1 and 4 are identical but not merged")) << all_problems(r);
  EXPECT_TRUE(mentions(r, "input point 4 is used by no triangle")) << all_problems(r);
}

TEST(Verify, DuplicateMapOutOfRangeFails) {
  Triangulation t = quad_02();
  t.duplicate_of[3] = 4;
  EXPECT_TRUE(mentions(cdt::verify(t, kQuad, {}), "duplicate_of[3] = 4 is not an input point"));
}

// --- reporting and scale -----------------------------------------------------------------------------

/// A k x k lattice, each square cut by the diagonal from (x + 1, y) to (x, y + 1): co-circular
/// everywhere, and that diagonal is the one the tie-break keeps ((x, y) comes first, and is pushed out).
Triangulation lattice_mesh(std::uint32_t k, std::vector<Point>& points) {
  points.clear();
  for (std::uint32_t y = 0; y < k; ++y) {
    for (std::uint32_t x = 0; x < k; ++x) points.push_back({static_cast<double>(x), static_cast<double>(y)});
  }
  Triangulation t;
  t.vertices.assign(points.begin(), points.end());
  t.duplicate_of.resize(points.size());
  for (std::uint32_t i = 0; i < points.size(); ++i) t.duplicate_of[i] = i;
  const auto id = [k](std::uint32_t x, std::uint32_t y) { return y * k + x; };
  const auto tri = [k](std::uint32_t x, std::uint32_t y, std::uint32_t half) {
    return 2 * (y * (k - 1) + x) + half;
  };
  for (std::uint32_t y = 0; y + 1 < k; ++y) {
    for (std::uint32_t x = 0; x + 1 < k; ++x) {
      // Lower triangle (x,y) (x+1,y) (x,y+1); upper (x+1,y) (x+1,y+1) (x,y+1). Edge i is opposite
      // corner i.
      t.triangles.push_back({id(x, y), id(x + 1, y), id(x, y + 1)});
      t.neighbors.push_back(
          {tri(x, y, 1), x > 0 ? tri(x - 1, y, 1) : kNone, y > 0 ? tri(x, y - 1, 1) : kNone});
      t.triangles.push_back({id(x + 1, y), id(x + 1, y + 1), id(x, y + 1)});
      t.neighbors.push_back(
          {y + 2 < k ? tri(x, y + 1, 0) : kNone, tri(x, y, 0), x + 2 < k ? tri(x + 1, y, 0) : kNone});
    }
  }
  t.segment_of_edge.assign(t.triangles.size(), {kNone, kNone, kNone});
  return t;
}

TEST(Verify, ManyProblemsAreCountedButFewKept) {
  std::vector<Point> p;
  Triangulation t = lattice_mesh(20, p);
  for (auto& tri : t.triangles) std::swap(tri[1], tri[2]);
  const auto r = cdt::verify(t, p, {});
  EXPECT_GT(r.num_problems, 2 * 19 * 19u);
  EXPECT_EQ(r.problems.size(), cdt::VerifyReport::kMaxKept);
}

// Scale: half a million triangles, rows of constraints, and many overlapping segments along one row
// (which a naive edge-by-edge walk would check in quadratic time). No timing assertion.
TEST(Verify, LargeLatticeWithLongOverlappingSegmentsPasses) {
  const std::uint32_t k = 500;
  std::vector<Point> p;
  Triangulation t = lattice_mesh(k, p);
  std::vector<Segment> s;
  // Row 7 fully constrained, from every one of its points to the far end.
  for (std::uint32_t x = 0; x + 1 < k; ++x) s.push_back({7 * k + x, 7 * k + k - 1});
  const auto seg_id = static_cast<std::uint32_t>(s.size());
  s.push_back({100 * k, 100 * k + k - 1});
  for (std::uint32_t n = 0; n < t.triangles.size(); ++n) {
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t a = t.triangles[n][(i + 1) % 3];
      const std::uint32_t b = t.triangles[n][(i + 2) % 3];
      if (a / k == b / k && a / k == 7) t.segment_of_edge[n][i] = 0;
      if (a / k == b / k && a / k == 100) t.segment_of_edge[n][i] = seg_id;
    }
  }
  const auto r = cdt::verify(t, p, s);
  EXPECT_TRUE(r.ok()) << all_problems(r);
  // Unflag one edge in the middle of row 7: every segment over it fails.
  for (std::uint32_t n = 0; n < t.triangles.size(); ++n) {
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t a = t.triangles[n][(i + 1) % 3];
      const std::uint32_t b = t.triangles[n][(i + 2) % 3];
      if (std::min(a, b) == 7 * k + 250 && std::max(a, b) == 7 * k + 251) t.segment_of_edge[n][i] = kNone;
    }
  }
  const auto broken = cdt::verify(t, p, s);
  EXPECT_EQ(broken.num_problems, 251u) << all_problems(broken);
}

// A large triangulation is checked on several threads, each check over parts of the mesh: its report,
// kept messages and count alike, is the one thread's, valid or broken in many places at once.
TEST(Verify, ManyThreadsReportAsOne) {
  const trixel_gen::Pslg in = trixel_gen::synthetic_pslg(60000, 3000, trixel_gen::Distribution::uniform, 41);
  cdt::Options options;
  options.backend = cdt::Backend::cpu;
  Triangulation t = cdt::triangulate(in.points, in.segments, options);
  ASSERT_GE(t.triangles.size(), 4u * 16384u); // several parts in every check over the triangles
  for (const unsigned threads : {1u, 2u, 5u}) {
    const auto r = cdt::verify(t, in.points, in.segments, threads);
    EXPECT_TRUE(r.ok()) << threads << " threads: " << all_problems(r);
  }
  // Broken all over: every 997th triangle turned clockwise (orientation, links, shared edges, the
  // Delaunay test), every 1999th constraint flag dropped on one side (links, segments), and a few
  // points mapped to a neighbour (duplicates, use).
  std::size_t dropped = 0;
  for (std::size_t k = 0; k < t.triangles.size(); k += 997) std::swap(t.triangles[k][1], t.triangles[k][2]);
  for (std::size_t k = 0; k < t.triangles.size(); ++k) {
    for (std::uint32_t i = 0; i < 3; ++i) {
      if (t.segment_of_edge[k][i] != kNone && ++dropped % 1999 == 0) t.segment_of_edge[k][i] = kNone;
    }
  }
  for (std::uint32_t v = 1000; v < in.points.size(); v += 15000) t.duplicate_of[v] = v - 1;
  const auto one = cdt::verify(t, in.points, in.segments, 1);
  EXPECT_GT(one.num_problems, 3 * cdt::VerifyReport::kMaxKept) << all_problems(one);
  EXPECT_EQ(one.problems.size(), cdt::VerifyReport::kMaxKept);
  for (const unsigned threads : {2u, 3u, 8u}) {
    const auto many = cdt::verify(t, in.points, in.segments, threads);
    EXPECT_EQ(many.num_problems, one.num_problems) << threads << " threads";
    EXPECT_EQ(many.problems, one.problems) << threads << " threads";
  }
  // Only the last checks' problems: the kept messages come from the later parts too.
  for (std::size_t k = 0; k < t.triangles.size(); k += 997) std::swap(t.triangles[k][1], t.triangles[k][2]);
  const auto late = cdt::verify(t, in.points, in.segments, 1);
  EXPECT_FALSE(late.ok());
  const auto late_many = cdt::verify(t, in.points, in.segments, 4);
  EXPECT_EQ(late_many.num_problems, late.num_problems);
  EXPECT_EQ(late_many.problems, late.problems);
}

} // namespace
