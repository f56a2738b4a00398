#include "vectorize/pslg_build.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <set>
#include <stdexcept>
#include <utility>
#include <vector>

#include "cdt/cdt.hpp"
#include "cdt/detail/predicates.hpp"
#include "cdt/verify.hpp"
#include "stage_test_util.hpp"
#include "vectorize/chains.hpp"
#include "vectorize/edges.hpp"
#include "vectorize/simplify.hpp"

namespace {

using trixel_test::improper;
using trixel_test::make_image;
using trixel_test::on_box;
using trixel_test::orient;

using cdt::Point;
using vectorize::Image;
using vectorize::InteriorOptions;
using vectorize::PixelPoint;
using vectorize::Polyline;
using vectorize::Pslg;

double distance_to_segment(const Point& a, const Point& b, const Point& p) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double len_sq = dx * dx + dy * dy;
  const double t = len_sq > 0 ? std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / len_sq, 0.0, 1.0) : 0.0;
  return std::hypot(p.x - (a.x + t * dx), p.y - (a.y + t * dy));
}

// The properties every PSLG from build_pslg must have: points distinct and inside the image, the four
// corners present, segments valid, distinct and crossing-free, no point in a segment's interior, and
// the border covered by segments.
void expect_clean(const Pslg& pslg, int width, int height) {
  std::set<std::pair<double, double>> distinct;
  for (const Point& p : pslg.points) {
    EXPECT_TRUE(distinct.insert({p.x, p.y}).second) << "duplicate point " << p.x << "," << p.y;
    EXPECT_TRUE(p.x >= 0 && p.y >= 0 && p.x <= width && p.y <= height) << p.x << "," << p.y;
  }
  for (const auto& corner : std::array<std::pair<double, double>, 4>{
           {{0.0, 0.0}, {double(width), 0.0}, {double(width), double(height)}, {0.0, double(height)}}})
    EXPECT_EQ(distinct.count(corner), 1u) << "missing corner " << corner.first << "," << corner.second;
  double border_length = 0.0;
  for (std::size_t i = 0; i < pslg.segments.size(); ++i) {
    const auto [a, b] = pslg.segments[i];
    ASSERT_LT(a, pslg.points.size());
    ASSERT_LT(b, pslg.points.size());
    ASSERT_NE(a, b);
    const Point& pa = pslg.points[a];
    const Point& pb = pslg.points[b];
    const bool on_border =
        (pa.x == pb.x && (pa.x == 0 || pa.x == width)) || (pa.y == pb.y && (pa.y == 0 || pa.y == height));
    if (on_border) border_length += std::hypot(pb.x - pa.x, pb.y - pa.y);
    for (std::size_t j = i + 1; j < pslg.segments.size(); ++j)
      ASSERT_FALSE(improper(pa, pb, pslg.points[pslg.segments[j].a], pslg.points[pslg.segments[j].b]))
          << "segments " << i << " and " << j << " meet";
    for (std::size_t p = 0; p < pslg.points.size(); ++p)
      if (p != a && p != b) {
        ASSERT_FALSE(orient(pa, pb, pslg.points[p]) == 0 && on_box(pa, pb, pslg.points[p]))
            << "point " << p << " on segment " << i;
      }
  }
  EXPECT_DOUBLE_EQ(border_length, 2.0 * (width + height));
}

void expect_triangulates(const Pslg& pslg) {
  cdt::Options options;
  options.backend = cdt::Backend::cpu;
  options.crossings = cdt::CrossingSegments::reject; // the PSLG must need no repair
  const cdt::Triangulation t = cdt::triangulate(pslg.points, pslg.segments, options);
  const cdt::VerifyReport report = cdt::verify(t, pslg.points, pslg.segments);
  EXPECT_TRUE(report.ok()) << (report.problems.empty() ? "" : report.problems.front());
  EXPECT_EQ(t.stats.added_vertices, 0u);
}

TEST(PslgBuild, EmptyInputIsTheBorderRectangle) {
  const Pslg pslg = vectorize::build_pslg({}, 8, 5, Image{}, {});
  EXPECT_EQ(pslg.points.size(), 4u);
  EXPECT_EQ(pslg.segments.size(), 4u);
  expect_clean(pslg, 8, 5);
  expect_triangulates(pslg);
}

TEST(PslgBuild, PixelCentresAndSharedJunctions) {
  // A T junction: three polylines ending at pixel (5, 5).
  const std::vector<Polyline> lines = {
      {{{2, 5}, {5, 5}}, false}, {{{5, 5}, {8, 5}}, false}, {{{5, 5}, {5, 8}}, false}};
  const Pslg pslg = vectorize::build_pslg(lines, 12, 12, Image{}, {});
  EXPECT_EQ(pslg.points.size(), 4u + 4u); // corners + four distinct pixel points
  EXPECT_EQ(std::count(pslg.points.begin(), pslg.points.end(), Point{5.5, 5.5}), 1);
  EXPECT_EQ(std::count(pslg.points.begin(), pslg.points.end(), Point{2.5, 5.5}), 1);
  EXPECT_EQ(pslg.segments.size(), 3u + 4u);
  expect_clean(pslg, 12, 12);
  expect_triangulates(pslg);
}

TEST(PslgBuild, DuplicateAndClosingSegmentsAreKeptOnce) {
  const std::vector<Polyline> lines = {{{{2, 2}, {6, 2}, {4, 6}}, true}, {{{6, 2}, {2, 2}}, false}};
  const Pslg pslg = vectorize::build_pslg(lines, 10, 10, Image{}, {});
  EXPECT_EQ(pslg.segments.size(), 3u + 4u);
  expect_clean(pslg, 10, 10);
  expect_triangulates(pslg);
}

// A line from the left edge to the bottom edge ends in the outer pixel ring; without a segment to the
// border the two regions it separates would stay connected through the half-pixel gap.
TEST(PslgBuild, EndsInTheOuterRingReachTheBorder) {
  const std::vector<Polyline> lines = {{{{0, 3}, {4, 9}}, false}};
  const Pslg pslg = vectorize::build_pslg(lines, 10, 10, Image{}, {});
  EXPECT_EQ(std::count(pslg.points.begin(), pslg.points.end(), Point{0.0, 3.5}), 1);
  EXPECT_EQ(std::count(pslg.points.begin(), pslg.points.end(), Point{4.5, 10.0}), 1);
  EXPECT_EQ(pslg.segments.size(), 1u + 2u + 6u); // the line, two extensions, the border in six pieces
  expect_clean(pslg, 10, 10);
  expect_triangulates(pslg);
  // An end away from the ring is left alone.
  const Pslg inner = vectorize::build_pslg({{{{2, 3}, {4, 7}}, false}}, 10, 10, Image{}, {});
  EXPECT_EQ(inner.segments.size(), 1u + 4u);
}

TEST(PslgBuild, SmoothGradientGetsInteriorPointsAndFlatImageNone) {
  const Image gradient = make_image(48, 36, [](int x, int y) {
    return std::array{x / 48.0f, y / 36.0f, 0.5f, 1.0f};
  });
  const Pslg shaded = vectorize::build_pslg({}, 48, 36, gradient, {});
  EXPECT_EQ(shaded.points.size(), 4u + 4u * 3u); // one point per 12-pixel cell
  expect_clean(shaded, 48, 36);
  expect_triangulates(shaded);
  const Image flat = make_image(48, 36, [](int, int) { return std::array{0.2f, 0.4f, 0.6f, 1.0f}; });
  EXPECT_EQ(vectorize::build_pslg({}, 48, 36, flat, {}).points.size(), 4u);
  InteriorOptions none;
  none.cell_size_px = 0;
  EXPECT_EQ(vectorize::build_pslg({}, 48, 36, gradient, none).points.size(), 4u);
  // Transparent pixels are no shape: no points there.
  const Image clear = make_image(48, 36, [](int x, int y) {
    return std::array{x / 48.0f, y / 36.0f, 0.5f, 0.0f};
  });
  EXPECT_EQ(vectorize::build_pslg({}, 48, 36, clear, {}).points.size(), 4u);
}

// Interior points keep clear of segments: at least half a pixel from every one, so never on one.
TEST(PslgBuild, InteriorPointsKeepClearOfSegments) {
  const Image gradient = make_image(40, 40, [](int x, int y) {
    return std::array{(x + y) / 80.0f, 0.3f, y / 40.0f, 1.0f};
  });
  // Lines right through the cell centres (pixel corners at multiples of 6).
  std::vector<Polyline> lines;
  for (int y = 5; y < 40; y += 6) {
    lines.push_back({{{1, y}, {38, y}}, false});
    if (y + 5 < 40) lines.push_back({{{6 + y, y + 1}, {y, y + 5}}, false}); // slanted, between the rows
  }
  InteriorOptions options;
  options.cell_size_px = 6;
  options.min_std_dev = 0.0;
  const Pslg pslg = vectorize::build_pslg(lines, 40, 40, gradient, options);
  std::size_t free_points = 0;
  std::vector<char> used(pslg.points.size(), 0);
  for (const auto& s : pslg.segments) used[s.a] = used[s.b] = 1;
  for (std::size_t p = 0; p < pslg.points.size(); ++p) {
    if (used[p]) continue;
    ++free_points;
    for (const auto& s : pslg.segments)
      EXPECT_GE(distance_to_segment(pslg.points[s.a], pslg.points[s.b], pslg.points[p]), 0.5);
  }
  EXPECT_GT(free_points, 10u);
  expect_clean(pslg, 40, 40);
  expect_triangulates(pslg);
}

// The front end end to end on a synthetic picture: a sky gradient, a disc, a rectangle, a transparent
// corner and a thin line. The PSLG is clean, triangulates without repair and passes the verifier.
TEST(PslgBuild, SyntheticImageEndToEnd) {
  const int w = 120;
  const int h = 90;
  const Image image = make_image(w, h, [](int x, int y) {
    if (x + y < 14) return std::array{0.0f, 0.0f, 0.0f, 0.0f};
    std::array<float, 4> c{0.3f + 0.5f * y / 90.0f, 0.5f + 0.3f * y / 90.0f, 0.9f, 1.0f};
    if ((x - 40) * (x - 40) + (y - 45) * (y - 45) < 400) c = {0.9f, 0.8f, 0.1f, 1.0f};
    if (x >= 70 && x < 110 && y >= 30 && y < 80) c = {0.2f, 0.6f, 0.2f, 1.0f};
    if (std::abs(y - (x / 3 + 60)) < 1) c = {0.0f, 0.0f, 0.0f, 1.0f};
    return c;
  });
  const auto edges = vectorize::detect_edges(image);
  const auto chains = vectorize::trace_chains(edges);
  ASSERT_FALSE(chains.empty());
  for (const double tolerance : {0.5, 1.0, 2.0}) {
    const auto lines = vectorize::simplify_chains(chains, tolerance);
    const Pslg pslg = vectorize::build_pslg(lines, w, h, image, {});
    EXPECT_GT(pslg.segments.size(), 20u);
    expect_clean(pslg, w, h);
    expect_triangulates(pslg);
  }
}

// Each shaded cell's point is the centre of its usable pixel nearest the cell's centre, the first in
// scan order among equally near ones; found here by brute force over every pixel of every cell, whole
// cells and cells cut by the image's sides, odd and even sizes, with scattered transparent pixels.
TEST(PslgBuild, InteriorPointIsTheUsablePixelNearestTheCellCentre) {
  for (const int cell : {4, 5, 6}) {
    for (const unsigned seed : {1u, 2u, 3u}) {
      const int w = 23;
      const int h = 17;
      const auto clear = [&](int x, int y) { return ((x * 7 + y * 13 + seed * 5) % 11) < 4; };
      const Image image = make_image(w, h, [&](int x, int y) {
        return std::array{(x * x + y) / 600.0f, y / 17.0f, 0.5f, clear(x, y) ? 0.0f : 1.0f};
      });
      InteriorOptions options;
      options.cell_size_px = cell;
      options.min_std_dev = 0.0;
      std::set<std::pair<double, double>> expected;
      for (int y0 = 0; y0 < h; y0 += cell)
        for (int x0 = 0; x0 < w; x0 += cell) {
          const int x1 = std::min(w, x0 + cell);
          const int y1 = std::min(h, y0 + cell);
          int count = 0;
          double best = 1e300;
          std::pair<double, double> point;
          for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) {
              if (clear(x, y)) continue;
              ++count;
              const double d =
                  std::pow(x + 0.5 - (x0 + x1) / 2.0, 2) + std::pow(y + 0.5 - (y0 + y1) / 2.0, 2);
              if (d < best) {
                best = d;
                point = {x + 0.5, y + 0.5};
              }
            }
          if (count >= std::max(4, cell * cell / 4)) expected.insert(point);
        }
      const Pslg pslg = vectorize::build_pslg({}, w, h, image, options);
      std::set<std::pair<double, double>> got;
      for (std::size_t p = 4; p < pslg.points.size(); ++p) got.insert({pslg.points[p].x, pslg.points[p].y});
      EXPECT_EQ(got, expected) << "cell " << cell << ", seed " << seed;
      EXPECT_EQ(pslg.points.size(), 4 + expected.size());
    }
  }
}

TEST(PslgBuild, RejectsBadInput) {
  EXPECT_THROW(vectorize::build_pslg({}, 0, 5, Image{}, {}), std::invalid_argument);
  EXPECT_THROW(vectorize::build_pslg({{{{10, 0}}, false}}, 10, 5, Image{}, {}), std::invalid_argument);
  const Image small = make_image(4, 4, [](int, int) { return std::array{0.0f, 0.0f, 0.0f, 1.0f}; });
  EXPECT_THROW(vectorize::build_pslg({}, 5, 5, small, {}), std::invalid_argument);
  const Image other = small;
  EXPECT_THROW(vectorize::build_pslg({}, 4, 4, small, {}, vectorize::PointPlacement{other}),
               std::invalid_argument);
  EXPECT_NO_THROW(vectorize::build_pslg({}, 4, 4, small, {}, vectorize::PointPlacement{small}));
}

} // namespace
