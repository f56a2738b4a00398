#include "vectorize/grouping.hpp"

#include <gtest/gtest.h>

#include "../../vectorize/src/cpu_level.hpp"
#include "stage_test_util.hpp"
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <random>
#include <vector>

namespace {

using trixel_test::triangulate_rectangle;

using vectorize::GroupingOptions;
using vectorize::Regions;
using vectorize::TrixelColours;

std::vector<cdt::Point> random_points(double width, double height, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(0.0, width);
  std::uniform_real_distribution<double> y(0.0, height);
  std::vector<cdt::Point> points;
  for (int i = 0; i < count; ++i) points.push_back({x(rng), y(rng)});
  return points;
}

// Points on the vertical line x = at, so that no triangle straddles it (the edges on it are not
// constraints).
std::vector<cdt::Point> column_of_points(double at, double height) {
  std::vector<cdt::Point> points;
  for (double y = 0; y <= height; y += 1.0) points.push_back({at, y});
  return points;
}

cdt::Point centroid(const cdt::Triangulation& t, std::size_t tri) {
  const auto& a = t.vertices[t.triangles[tri][0]];
  const auto& b = t.vertices[t.triangles[tri][1]];
  const auto& c = t.vertices[t.triangles[tri][2]];
  return {(a.x + b.x + c.x) / 3, (a.y + b.y + c.y) / 3};
}

// Trixels coloured by a function of the triangle's centroid, with their true areas.
TrixelColours paint(const cdt::Triangulation& t,
                    const std::function<std::array<float, 4>(cdt::Point)>& colour) {
  TrixelColours trixels(t.triangles.size());
  for (std::size_t tri = 0; tri < t.triangles.size(); ++tri) {
    const auto& a = t.vertices[t.triangles[tri][0]];
    const auto& b = t.vertices[t.triangles[tri][1]];
    const auto& c = t.vertices[t.triangles[tri][2]];
    trixels[tri].area = 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
    trixels[tri].rgba = colour(centroid(t, tri));
  }
  return trixels;
}

// The invariants every grouping must keep: dense ids, areas and counts that add up, the documented
// region colour, regions connected through edges, one transparency per region.
void expect_consistent(const cdt::Triangulation& t, const TrixelColours& trixels, const Regions& regions) {
  ASSERT_EQ(regions.region_of_triangle.size(), t.triangles.size());
  const std::size_t n = regions.regions.size();
  std::vector<double> area(n);
  std::vector<std::array<double, 3>> weighted(n);
  std::vector<std::uint32_t> count(n);
  std::vector<std::uint32_t> first(n, cdt::kNone);
  for (std::uint32_t tri = 0; tri < t.triangles.size(); ++tri) {
    const std::uint32_t r = regions.region_of_triangle[tri];
    ASSERT_LT(r, n);
    area[r] += trixels[tri].area;
    for (int c = 0; c < 3; ++c) weighted[r][c] += trixels[tri].area * trixels[tri].rgba[c];
    ++count[r];
    if (first[r] == cdt::kNone) first[r] = tri;
    EXPECT_EQ(trixels[tri].transparent(), regions.regions[r].transparent);
  }
  for (std::uint32_t r = 0; r < n; ++r) {
    EXPECT_EQ(count[r], regions.regions[r].triangle_count);
    EXPECT_NEAR(area[r], regions.regions[r].area, 1e-9 * (1 + area[r]));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(weighted[r][c] / area[r], regions.regions[r].rgb[c], 1e-5);
    if (r > 0) {
      EXPECT_LT(first[r - 1], first[r]) << "ids not in order of lowest triangle";
    }
    // Connected: a search from the first triangle across edges inside the region reaches all of it.
    std::vector<bool> seen(t.triangles.size());
    std::queue<std::uint32_t> todo;
    todo.push(first[r]);
    seen[first[r]] = true;
    std::uint32_t reached = 0;
    while (!todo.empty()) {
      const std::uint32_t tri = todo.front();
      todo.pop();
      ++reached;
      for (std::uint32_t other : t.neighbors[tri])
        if (other != cdt::kNone && !seen[other] && regions.region_of_triangle[other] == r) {
          seen[other] = true;
          todo.push(other);
        }
    }
    EXPECT_EQ(reached, count[r]) << "region " << r << " is not connected";
  }
}

TEST(GroupingLab, KnownColours) {
  const auto white = vectorize::srgb_to_lab({1, 1, 1});
  EXPECT_NEAR(white[0], 100.0, 1e-3);
  EXPECT_NEAR(white[1], 0.0, 1e-3);
  EXPECT_NEAR(white[2], 0.0, 1e-3);
  const auto red = vectorize::srgb_to_lab({1, 0, 0});
  EXPECT_NEAR(red[0], 53.24, 0.01);
  EXPECT_NEAR(red[1], 80.09, 0.01);
  EXPECT_NEAR(red[2], 67.20, 0.01);
  EXPECT_NEAR(vectorize::delta_e({0, 0, 0}, {3, 4, 12}), 13.0, 1e-12);
}

// srgb_to_lab's cube root is its own (faster than std::cbrt); on channels that are nodes of its
// tabulated sRGB curve (multiples of 1/4096, where the table holds the curve's exact values) it gives
// the formula's CIELAB as std::pow and std::cbrt give it, to a few units in the last place.
TEST(GroupingLab, MatchesTheFormulaToTheLastPlaces) {
  const auto linear = [](double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); };
  const auto f = [](double t) {
    constexpr double delta = 6.0 / 29.0;
    return t > delta * delta * delta ? std::cbrt(t) : t / (3 * delta * delta) + 4.0 / 29.0;
  };
  double worst = 0.0;
  for (int ri = 0; ri <= 4096; ri += 91)
    for (int gi = 0; gi <= 4096; gi += 97)
      for (int bi = 0; bi <= 4096; bi += 89) {
        const std::array<float, 3> rgb = {ri / 4096.0f, gi / 4096.0f, bi / 4096.0f};
        const double r = linear(rgb[0]);
        const double g = linear(rgb[1]);
        const double b = linear(rgb[2]);
        const double fx = f((0.4124564 * r + 0.3575761 * g + 0.1804375 * b) / 0.95047);
        const double fy = f(0.2126729 * r + 0.7151522 * g + 0.0721750 * b);
        const double fz = f((0.0193339 * r + 0.1191920 * g + 0.9503041 * b) / 1.08883);
        const std::array<double, 3> expected = {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
        const auto lab = vectorize::srgb_to_lab(rgb);
        for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(lab[c] - expected[c]));
      }
  EXPECT_LT(worst, 1e-12);
}

TEST(Grouping, FlatColourIsOneRegion) {
  const auto t = triangulate_rectangle(30, 20, random_points(30, 20, 100, 1));
  const auto trixels = paint(t, [](cdt::Point) { return std::array<float, 4>{0.3f, 0.6f, 0.9f, 1}; });
  const auto regions = vectorize::group_trixels(t, trixels);
  ASSERT_EQ(regions.regions.size(), 1u);
  EXPECT_NEAR(regions.regions[0].area, 600.0, 1e-9);
  EXPECT_EQ(regions.regions[0].triangle_count, t.triangles.size());
  expect_consistent(t, trixels, regions);
}

// A constraint is a detected edge: the same colour on both sides still makes two regions, unless the
// small-region merge (which crosses any edge) takes over.
TEST(Grouping, ConstraintsSeparateUntilTheMinimumAreaMerges) {
  const auto t = triangulate_rectangle(4, 4, {}, {{0, 2}}); // the border, then the diagonal (0,0)-(4,4)
  const auto trixels = paint(t, [](cdt::Point) { return std::array<float, 4>{1, 1, 1, 1}; });
  GroupingOptions options;
  options.min_region_area = 0;
  EXPECT_EQ(vectorize::group_trixels(t, trixels, options).regions.size(), 2u);
  options.min_region_area = 8.5;
  const auto merged = vectorize::group_trixels(t, trixels, options);
  EXPECT_EQ(merged.regions.size(), 1u);
  expect_consistent(t, trixels, merged);
}

TEST(Grouping, ToleranceDecidesWhetherCloseColoursJoin) {
  const auto t = triangulate_rectangle(10, 10, column_of_points(5, 10));
  const auto trixels = paint(t, [](cdt::Point p) {
    const float grey = p.x < 5 ? 0.50f : 0.52f; // Delta E about 1.8
    return std::array<float, 4>{grey, grey, grey, 1};
  });
  GroupingOptions options;
  options.min_region_area = 0;
  options.colour_tolerance = 5;
  EXPECT_EQ(vectorize::group_trixels(t, trixels, options).regions.size(), 1u);
  options.colour_tolerance = 1;
  const auto regions = vectorize::group_trixels(t, trixels, options);
  EXPECT_EQ(regions.regions.size(), 2u);
  expect_consistent(t, trixels, regions);
}

// A trixel's CIELAB given with its colour (as colour_trixels gives it with the device's sums) is the
// one the grouping compares: two triangles of greys 0.02 apart join at tolerance 5 (as above), but not
// when their given CIELABs are far apart; given as srgb_to_lab makes them, or NaN (not known), the
// regions are those made without.
TEST(Grouping, GivenLabIsTheOneCompared) {
  const auto t = triangulate_rectangle(4, 4, {}); // two triangles, one each side of a diagonal
  ASSERT_EQ(t.triangles.size(), 2u);
  auto trixels = paint(t, [](cdt::Point) { return std::array<float, 4>{0.50f, 0.50f, 0.50f, 1}; });
  trixels[1].rgba = {0.52f, 0.52f, 0.52f, 1};
  GroupingOptions options;
  options.min_region_area = 0;
  options.colour_tolerance = 5;
  const auto computed = vectorize::group_trixels(t, trixels, options);
  ASSERT_EQ(computed.regions.size(), 1u);
  vectorize::TrixelLab lab;
  for (const auto& trixel : trixels)
    lab.push_back(
        vectorize::srgb_to_lab(std::array<float, 3>{trixel.rgba[0], trixel.rgba[1], trixel.rgba[2]}));
  EXPECT_EQ(vectorize::group_trixels(t, trixels, options, 1, &lab).region_of_triangle,
            computed.region_of_triangle);
  lab[1][0] += 50.0;
  EXPECT_EQ(vectorize::group_trixels(t, trixels, options, 1, &lab).regions.size(), 2u);
  lab[1].fill(std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(vectorize::group_trixels(t, trixels, options, 1, &lab).regions.size(), 1u);
}

// Region means are compared, not neighbouring trixels: a slow ramp must not chain into one region.
TEST(Grouping, GradientDoesNotChainIntoOneRegion) {
  std::vector<cdt::Point> points;
  for (int x = 1; x < 64; ++x) {
    const auto column = column_of_points(x, 4);
    points.insert(points.end(), column.begin(), column.end());
  }
  const auto t = triangulate_rectangle(64, 4, points);
  const auto trixels = paint(t, [](cdt::Point p) {
    const float v = static_cast<float>(p.x / 64.0);
    return std::array<float, 4>{v, v, v, 1};
  });
  GroupingOptions options;
  options.min_region_area = 0;
  const auto regions = vectorize::group_trixels(t, trixels, options);
  EXPECT_GT(regions.regions.size(), 3u);
  expect_consistent(t, trixels, regions);
}

// Transparent trixels are "no shape": they never join opaque ones, not even through the merge.
TEST(Grouping, TransparentNeverJoinsOpaque) {
  const auto t = triangulate_rectangle(10, 10, column_of_points(5, 10));
  const auto trixels = paint(t, [](cdt::Point p) {
    return p.x < 5 ? std::array<float, 4>{1, 0, 0, 0.2f} : std::array<float, 4>{1, 0, 0, 1};
  });
  GroupingOptions options;
  options.colour_tolerance = 1000;
  options.min_region_area = 1000;
  const auto regions = vectorize::group_trixels(t, trixels, options);
  ASSERT_EQ(regions.regions.size(), 2u);
  EXPECT_NE(regions.regions[0].transparent, regions.regions[1].transparent);
  expect_consistent(t, trixels, regions);
}

// A thin strip between two constraints merges into the neighbour closest in colour, not the larger one.
TEST(Grouping, SmallRegionMergesIntoClosestColour) {
  // Border points 0..3 come after these: strip edges at x = 4.5 and x = 5.5.
  const std::vector<cdt::Point> points = {{4.5, 0}, {4.5, 2}, {5.5, 0}, {5.5, 2}};
  const auto t = triangulate_rectangle(12, 2, points, {{0, 1}, {2, 3}});
  const auto trixels = paint(t, [](cdt::Point p) {
    if (p.x < 4.5) return std::array<float, 4>{1, 1, 1, 1};          // white, area 9
    if (p.x < 5.5) return std::array<float, 4>{0.9f, 0.9f, 0.9f, 1}; // light grey, area 2
    return std::array<float, 4>{0, 0, 0, 1};                         // black, area 13
  });
  GroupingOptions options;
  options.min_region_area = 3;
  const auto regions = vectorize::group_trixels(t, trixels, options);
  ASSERT_EQ(regions.regions.size(), 2u);
  std::vector<double> areas = {regions.regions[0].area, regions.regions[1].area};
  std::sort(areas.begin(), areas.end());
  EXPECT_NEAR(areas[0], 11.0, 1e-9);
  EXPECT_NEAR(areas[1], 13.0, 1e-9);
  expect_consistent(t, trixels, regions);
}

// Random colours from a small palette on a random mesh: every invariant, every region at least the
// minimum area where a same-transparency neighbour exists, and the same answer twice.
TEST(Grouping, RandomPaletteKeepsInvariantsAndIsDeterministic) {
  for (unsigned seed = 1; seed <= 4; ++seed) {
    SCOPED_TRACE(seed);
    const auto t = triangulate_rectangle(40, 30, random_points(40, 30, 300, seed));
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> pick(0, 3);
    const std::array<std::array<float, 4>, 4> palette = {
        {{1, 0, 0, 1}, {0, 0, 1, 1}, {0.98f, 0.02f, 0, 1}, {0, 0, 0, 0}}};
    TrixelColours trixels = paint(t, [](cdt::Point) { return std::array<float, 4>{}; });
    for (auto& trixel : trixels) trixel.rgba = palette[pick(rng)];
    GroupingOptions options;
    options.min_region_area = 6;
    const auto regions = vectorize::group_trixels(t, trixels, options);
    expect_consistent(t, trixels, regions);
    const auto again = vectorize::group_trixels(t, trixels, options);
    EXPECT_EQ(again.region_of_triangle, regions.region_of_triangle);
    // A small region left over has no neighbour of its transparency.
    for (std::uint32_t tri = 0; tri < t.triangles.size(); ++tri) {
      const auto r = regions.region_of_triangle[tri];
      if (regions.regions[r].area >= options.min_region_area) continue;
      for (std::uint32_t other : t.neighbors[tri]) {
        if (other == cdt::kNone) continue;
        const auto o = regions.region_of_triangle[other];
        if (o != r) {
          EXPECT_NE(regions.regions[o].transparent, regions.regions[r].transparent);
        }
      }
    }
  }
}

// The grouping's x86-64-v3 copy (cpu_level.hpp) and the baseline one give the same regions to the bit,
// on random colours and opacities (CIELAB from the grouping itself and given), with the small regions'
// merge.
TEST(Grouping, X86V3CopyGivesTheBaselineRegions) {
  vectorize::detail::set_v3_loops(true);
  if (!vectorize::detail::v3_loops()) GTEST_SKIP() << "this build or CPU has no x86-64-v3 copy";
  for (unsigned seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE(seed);
    const auto t = triangulate_rectangle(60, 40, random_points(60, 40, 2000, seed));
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    // A gradient with noise: many neighbours' distances near the tolerance.
    TrixelColours trixels = paint(t, [](cdt::Point p) {
      return std::array<float, 4>{float(p.x / 60), float(p.y / 40), 0.5f, 1};
    });
    for (auto& trixel : trixels) {
      for (int c = 0; c < 3; ++c) trixel.rgba[c] = std::clamp(trixel.rgba[c] + 0.04f * unit(rng), 0.0f, 1.0f);
      if (unit(rng) < 0.03f) trixel.rgba[3] = unit(rng) < 0.5f ? 0.0f : 0.6f;
    }
    GroupingOptions options;
    options.min_region_area = 4;
    options.colour_tolerance = 8;
    const auto group = [&](bool v3) {
      vectorize::detail::set_v3_loops(v3);
      Regions r = vectorize::group_trixels(t, trixels, options);
      vectorize::detail::set_v3_loops(true);
      return r;
    };
    const Regions fast = group(true);
    const Regions baseline = group(false);
    ASSERT_GT(baseline.regions.size(), 10u);
    ASSERT_LT(baseline.regions.size(), t.triangles.size());
    EXPECT_EQ(fast.region_of_triangle, baseline.region_of_triangle);
    ASSERT_EQ(fast.regions.size(), baseline.regions.size());
    for (std::size_t r = 0; r < fast.regions.size(); ++r) {
      EXPECT_EQ(fast.regions[r].rgb, baseline.regions[r].rgb);
      EXPECT_EQ(fast.regions[r].area, baseline.regions[r].area);
      EXPECT_EQ(fast.regions[r].alpha, baseline.regions[r].alpha);
    }
  }
}

} // namespace
