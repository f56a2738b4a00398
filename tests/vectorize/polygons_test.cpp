#include "vectorize/polygons.hpp"

#include <gtest/gtest.h>

#include "stage_test_util.hpp"
#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <utility>
#include <vector>

namespace {

using trixel_test::triangulate_rectangle;

using vectorize::Regions;
using vectorize::TransparentRegions;

cdt::Point centroid(const cdt::Triangulation& t, std::size_t tri) {
  const auto& a = t.vertices[t.triangles[tri][0]];
  const auto& b = t.vertices[t.triangles[tri][1]];
  const auto& c = t.vertices[t.triangles[tri][2]];
  return {(a.x + b.x + c.x) / 3, (a.y + b.y + c.y) / 3};
}

double triangle_area(const cdt::Triangulation& t, std::size_t tri) {
  const auto& a = t.vertices[t.triangles[tri][0]];
  const auto& b = t.vertices[t.triangles[tri][1]];
  const auto& c = t.vertices[t.triangles[tri][2]];
  return 0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
}

// Regions from a label per triangle (labels must be 0..n-1 and connected through edges).
Regions regions_from_labels(const cdt::Triangulation& t, const std::vector<std::uint32_t>& label,
                            const std::set<std::uint32_t>& transparent = {}) {
  Regions regions;
  regions.region_of_triangle = label;
  regions.regions.resize(*std::max_element(label.begin(), label.end()) + 1);
  for (std::size_t tri = 0; tri < label.size(); ++tri) {
    regions.regions[label[tri]].area += triangle_area(t, tri);
    ++regions.regions[label[tri]].triangle_count;
  }
  for (auto r : transparent) regions.regions[r].transparent = true;
  return regions;
}

// Regions of a random mesh coloured from a palette, grouped by the real stage 8.
Regions random_regions(const cdt::Triangulation& t, unsigned seed, bool with_transparent) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, with_transparent ? 3 : 2);
  const std::array<std::array<float, 4>, 4> palette = {
      {{1, 0, 0, 1}, {0, 0, 1, 1}, {0, 1, 0, 1}, {0, 0, 0, 0}}};
  vectorize::TrixelColours trixels(t.triangles.size());
  for (std::size_t tri = 0; tri < t.triangles.size(); ++tri) {
    trixels[tri].rgba = palette[pick(rng)];
    trixels[tri].area = triangle_area(t, tri);
  }
  vectorize::GroupingOptions options;
  options.min_region_area = 0;
  options.colour_tolerance = 1;
  return vectorize::group_trixels(t, trixels, options);
}

bool on_same_border_side(const cdt::Point& a, const cdt::Point& b, double width, double height) {
  return (a.x == 0 && b.x == 0) || (a.y == 0 && b.y == 0) || (a.x == width && b.x == width) ||
         (a.y == height && b.y == height);
}

// The tiling promise: rings are simple, one outer ring per region, areas add up, and every directed
// boundary edge is used once, by the region on its left, with its reverse used by the region on the
// other side or lying on the border.
void expect_tiling(const cdt::Triangulation& t, const Regions& regions,
                   const std::vector<vectorize::RegionPolygon>& polygons, double width, double height,
                   bool all_regions) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> region_of_edge;
  double total = 0;
  std::uint32_t previous = 0;
  for (std::size_t k = 0; k < polygons.size(); ++k) {
    const auto& polygon = polygons[k];
    if (k > 0) {
      EXPECT_LT(previous, polygon.region);
    }
    previous = polygon.region;
    double area = 0;
    int outer = 0;
    for (const auto& ring : polygon.rings) {
      ASSERT_GE(ring.vertices.size(), 3u);
      ASSERT_EQ(ring.points.size(), ring.vertices.size());
      std::set<std::uint32_t> distinct(ring.vertices.begin(), ring.vertices.end());
      EXPECT_EQ(distinct.size(), ring.vertices.size()) << "ring repeats a vertex";
      area += ring.signed_area;
      outer += !ring.hole();
      for (std::size_t i = 0; i < ring.vertices.size(); ++i) {
        const auto edge = std::make_pair(ring.vertices[i], ring.vertices[(i + 1) % ring.vertices.size()]);
        EXPECT_TRUE(region_of_edge.emplace(edge, polygon.region).second) << "directed edge used twice";
      }
    }
    EXPECT_EQ(outer, 1) << "region " << polygon.region;
    EXPECT_NEAR(area, regions.regions[polygon.region].area, 1e-9 * width * height);
    total += area;
  }
  std::size_t expected_polygons = 0;
  for (const auto& region : regions.regions) expected_polygons += all_regions || !region.transparent;
  EXPECT_EQ(polygons.size(), expected_polygons);
  if (all_regions) {
    EXPECT_NEAR(total, width * height, 1e-9 * width * height);
  }

  for (const auto& [edge, region] : region_of_edge) {
    const auto reverse = region_of_edge.find({edge.second, edge.first});
    if (reverse != region_of_edge.end()) {
      EXPECT_NE(reverse->second, region);
    } else if (all_regions) {
      EXPECT_TRUE(on_same_border_side(t.vertices[edge.first], t.vertices[edge.second], width, height))
          << "edge " << edge.first << "-" << edge.second << " has one side only, off the border";
    }
  }
  // And the converse: each boundary edge of the triangulation of a traced region is in some ring.
  std::size_t boundary_edges = 0;
  for (std::uint32_t tri = 0; tri < t.triangles.size(); ++tri) {
    const auto r = regions.region_of_triangle[tri];
    if (!all_regions && regions.regions[r].transparent) continue;
    for (int i = 0; i < 3; ++i) {
      const auto other = t.neighbors[tri][i];
      if (other != cdt::kNone && regions.region_of_triangle[other] == r) continue;
      ++boundary_edges;
      const auto found = region_of_edge.find({t.triangles[tri][(i + 1) % 3], t.triangles[tri][(i + 2) % 3]});
      ASSERT_NE(found, region_of_edge.end());
      EXPECT_EQ(found->second, r);
    }
  }
  EXPECT_EQ(boundary_edges, region_of_edge.size());
}

TEST(Polygons, OneRegionIsTheRectangle) {
  const auto t = triangulate_rectangle(8, 5, {{2, 2}, {5, 1}, {6, 4}});
  const auto regions = regions_from_labels(t, std::vector<std::uint32_t>(t.triangles.size(), 0));
  const auto polygons = vectorize::trace_polygons(t, regions);
  ASSERT_EQ(polygons.size(), 1u);
  ASSERT_EQ(polygons[0].rings.size(), 1u);
  EXPECT_EQ(polygons[0].rings[0].vertices.size(), 4u); // the corners; no interior vertex is on the hull
  EXPECT_DOUBLE_EQ(polygons[0].rings[0].signed_area, 40.0);
  expect_tiling(t, regions, polygons, 8, 5, true);
}

// A 3x3 grid of unit cells: region 0 is the ring of cells minus the corner (2,2); the centre cell and
// that corner are other regions. Region 0 touches itself at vertex (2,2), where the centre and the
// corner also meet: the pinch must give one outer ring (area 8) and one hole (area -1), not one
// self-touching ring.
TEST(Polygons, PinchVertexSplitsIntoOuterRingAndHole) {
  std::vector<cdt::Point> points;
  for (int y = 0; y <= 3; ++y)
    for (int x = 0; x <= 3; ++x)
      if (!((x == 0 || x == 3) && (y == 0 || y == 3))) points.push_back({double(x), double(y)});
  const auto t = triangulate_rectangle(3, 3, points);
  std::vector<std::uint32_t> label(t.triangles.size());
  for (std::size_t tri = 0; tri < label.size(); ++tri) {
    const auto c = centroid(t, tri);
    const int cx = static_cast<int>(c.x);
    const int cy = static_cast<int>(c.y);
    label[tri] = cx == 1 && cy == 1 ? 1 : cx == 2 && cy == 2 ? 2 : 0;
  }
  // Region ids must be in order of lowest triangle; relabel to keep regions_from_labels honest.
  std::vector<std::uint32_t> relabel(3, cdt::kNone);
  std::uint32_t next = 0;
  for (auto& l : label) {
    if (relabel[l] == cdt::kNone) relabel[l] = next++;
    l = relabel[l];
  }
  const auto regions = regions_from_labels(t, label);
  const auto polygons = vectorize::trace_polygons(t, regions);
  ASSERT_EQ(polygons.size(), 3u);
  const auto& ring_region = polygons[relabel[0]];
  ASSERT_EQ(ring_region.rings.size(), 2u);
  std::vector<double> areas = {ring_region.rings[0].signed_area, ring_region.rings[1].signed_area};
  std::sort(areas.begin(), areas.end());
  EXPECT_DOUBLE_EQ(areas[0], -1.0);
  EXPECT_DOUBLE_EQ(areas[1], 8.0);
  expect_tiling(t, regions, polygons, 3, 3, true);
}

TEST(Polygons, RandomRegionsTileTheRectangle) {
  for (unsigned seed = 1; seed <= 8; ++seed) {
    SCOPED_TRACE(seed);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> x(0, 50);
    std::uniform_real_distribution<double> y(0, 40);
    std::vector<cdt::Point> points;
    for (int i = 0; i < 250; ++i) points.push_back({x(rng), y(rng)});
    // Some lattice points too: collinear hull vertices and axis-parallel edges.
    for (int i = 0; i < 60; ++i) points.push_back({std::floor(x(rng)), std::floor(y(rng))});
    const auto t = triangulate_rectangle(50, 40, points);
    const auto regions = random_regions(t, seed, true);
    expect_tiling(t, regions, vectorize::trace_polygons(t, regions, TransparentRegions::include), 50, 40,
                  true);
    expect_tiling(t, regions, vectorize::trace_polygons(t, regions), 50, 40, false);
  }
}

// Tracing is a pure function of its input: the same rings in the same order twice.
TEST(Polygons, Deterministic) {
  const auto t = triangulate_rectangle(20, 20, {{3, 3}, {7, 12}, {15, 4}, {11, 17}, {9, 9}});
  const auto regions = random_regions(t, 5, false);
  const auto a = vectorize::trace_polygons(t, regions);
  const auto b = vectorize::trace_polygons(t, regions);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a[k].rings.size(), b[k].rings.size());
    for (std::size_t r = 0; r < a[k].rings.size(); ++r)
      EXPECT_EQ(a[k].rings[r].vertices, b[k].rings[r].vertices);
  }
}

} // namespace
