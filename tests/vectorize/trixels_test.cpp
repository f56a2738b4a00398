#include "vectorize/trixels.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "cdt/errors.hpp"
#include "stage_test_util.hpp"
#include "vectorize/grouping.hpp"

namespace {

using trixel_test::triangulate_rectangle;

std::vector<cdt::Point> random_points(int width, int height, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(0.0, width);
  std::uniform_real_distribution<double> y(0.0, height);
  std::vector<cdt::Point> points;
  for (int i = 0; i < count; ++i) points.push_back({x(rng), y(rng)});
  return points;
}

// Points on a grid of 1/steps of a pixel, inside the image.
std::vector<cdt::Point> grid_points(int width, int height, int count, unsigned seed, int steps) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> x(1, steps * width - 1);
  std::uniform_int_distribution<int> y(1, steps * height - 1);
  std::vector<cdt::Point> points;
  for (int i = 0; i < count; ++i) points.push_back({x(rng) / double(steps), y(rng) / double(steps)});
  return points;
}

// Pixel centres, pixel corners and half-way points: edges and vertices right on pixel centres, with
// horizontal and vertical edges through rows and columns of centres.
std::vector<cdt::Point> lattice_points(int width, int height, int count, unsigned seed) {
  return grid_points(width, height, count, seed, 2);
}

vectorize::Image make_image(int width, int height, float (*channel)(int x, int y, int c)) {
  vectorize::Image image;
  image.width = width;
  image.height = height;
  image.rgba.resize(static_cast<std::size_t>(width) * height * 4);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 4; ++c) image.pixel(x, y)[c] = channel(x, y, c);
  return image;
}

float flat(int, int, int c) { return c == 0 ? 0.2f : c == 1 ? 0.4f : c == 2 ? 0.6f : 1.0f; }
float gradient(int x, int y, int c) {
  return c == 3 ? 1.0f : static_cast<float>((x * 7 + y * 3 + c) % 11) / 10;
}

// Checks the fill rule's promise on one triangulation: every centre has one owner whose closed
// triangle contains it, and the per-triangle counts add up to the pixel count.
void expect_each_pixel_once(int width, int height, const cdt::Triangulation& t) {
  const auto owner = vectorize::owner_of_pixels(width, height, t);
  ASSERT_EQ(owner.size(), static_cast<std::size_t>(width) * height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const std::uint32_t tri = owner[static_cast<std::size_t>(y) * width + x];
      ASSERT_NE(tri, cdt::kNone) << "pixel " << x << "," << y << " has no owner";
      for (int i = 0; i < 3; ++i) {
        const cdt::Point& a = t.vertices[t.triangles[tri][i]];
        const cdt::Point& b = t.vertices[t.triangles[tri][(i + 1) % 3]];
        EXPECT_GE(cdt::detail::orient2d(a.x, a.y, b.x, b.y, x + 0.5, y + 0.5), 0)
            << "pixel " << x << "," << y << " outside its owner " << tri;
      }
    }
  const auto image = make_image(width, height, flat);
  const auto trixels = vectorize::colour_trixels(image, t);
  ASSERT_EQ(trixels.size(), t.triangles.size());
  std::uint64_t total = 0;
  for (const auto& trixel : trixels) total += trixel.pixel_count;
  EXPECT_EQ(total, static_cast<std::uint64_t>(width) * height);
}

TEST(TrixelColours, EveryPixelCountedOnceOnRandomTriangulations) {
  for (unsigned seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE(seed);
    const int width = 17 + static_cast<int>(seed) * 5;
    const int height = 9 + static_cast<int>(seed) * 3;
    expect_each_pixel_once(width, height,
                           triangulate_rectangle(width, height, random_points(width, height, 150, seed)));
  }
}

// Vertices and edges exactly on pixel centres are where a naive inside test counts twice or never.
TEST(TrixelColours, EveryPixelCountedOnceWithLatticePointsOnCentres) {
  for (unsigned seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE(seed);
    const int width = 12 + static_cast<int>(seed);
    const int height = 10;
    expect_each_pixel_once(width, height,
                           triangulate_rectangle(width, height, lattice_points(width, height, 80, seed)));
  }
}

// Every pixel centre as a vertex: each centre is a vertex of six or so triangles.
TEST(TrixelColours, EveryPixelCountedOnceWhenEveryCentreIsAVertex) {
  std::vector<cdt::Point> centres;
  for (int y = 0; y < 7; ++y)
    for (int x = 0; x < 9; ++x) centres.push_back({x + 0.5, y + 0.5});
  expect_each_pixel_once(9, 7, triangulate_rectangle(9, 7, centres));
}

// The owner the header's fill rule names, found by trying every triangle: the interior contains the
// centre moved by an infinitesimal eps right and eps^2 down (a zero orientation on edge s->e is decided
// by -(e.y - s.y), then by e.x - s.x).
std::uint32_t brute_force_owner(const cdt::Triangulation& t, double px, double py) {
  std::uint32_t found = cdt::kNone;
  for (std::uint32_t tri = 0; tri < t.triangles.size(); ++tri) {
    bool inside = true;
    for (int i = 0; i < 3 && inside; ++i) {
      const cdt::Point& s = t.vertices[t.triangles[tri][i]];
      const cdt::Point& e = t.vertices[t.triangles[tri][(i + 1) % 3]];
      const int o = cdt::detail::orient2d(s.x, s.y, e.x, e.y, px, py);
      inside = o > 0 || (o == 0 && (e.y < s.y || (e.y == s.y && e.x > s.x)));
    }
    if (!inside) continue;
    EXPECT_EQ(found, cdt::kNone) << "two owners of " << px << "," << py;
    found = tri;
  }
  return found;
}

// Points a hair away from pixel centres and from the rows and columns of centres: the row's crossings
// then fall within rounding distance of a centre, where only the exact test may decide.
std::vector<cdt::Point> near_centre_points(int width, int height, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> x(0, width - 1);
  std::uniform_int_distribution<int> y(0, height - 1);
  std::uniform_int_distribution<int> pick(0, 6);
  // A few units in the last place either way, or a small distance.
  const auto nudge = [&](double v) {
    switch (pick(rng)) {
    case 0:
      return v;
    case 1:
      return std::nextafter(v, 0.0);
    case 2:
      return std::nextafter(std::nextafter(v, 1e9), 1e9);
    case 3:
      return v + 1e-12;
    case 4:
      return v - 3e-10;
    case 5:
      return v + 2e-9;
    default:
      return std::nextafter(v, 1e9);
    }
  };
  std::vector<cdt::Point> points;
  for (int i = 0; i < count; ++i) points.push_back({nudge(x(rng) + 0.5), nudge(y(rng) + 0.5)});
  return points;
}

// Points on a grid of sixteenths of a pixel (the exact half-plane path), many of them on the rows and
// columns of centres.
std::vector<cdt::Point> sixteenth_points(int width, int height, int count, unsigned seed) {
  return grid_points(width, height, count, seed, 16);
}

// owner_of_pixels() (and so colour_trixels(), which walks the same runs) against the fill rule applied
// to every pixel and every triangle.
TEST(TrixelColours, OwnersFollowTheFillRuleExactly) {
  for (unsigned seed = 1; seed <= 12; ++seed) {
    SCOPED_TRACE(seed);
    const int width = 21 + static_cast<int>(seed);
    const int height = 13;
    for (const auto& points :
         {random_points(width, height, 120, seed), lattice_points(width, height, 90, seed),
          near_centre_points(width, height, 90, seed), sixteenth_points(width, height, 120, seed)}) {
      const cdt::Triangulation t = triangulate_rectangle(width, height, points);
      const auto owner = vectorize::owner_of_pixels(width, height, t);
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
          ASSERT_EQ(owner[static_cast<std::size_t>(y) * width + x], brute_force_owner(t, x + 0.5, y + 0.5))
              << "pixel " << x << "," << y;
    }
  }
}

TEST(TrixelColours, MeanOfOwnedPixelsAndAreas) {
  const int width = 24;
  const int height = 16;
  const auto t = triangulate_rectangle(width, height, random_points(width, height, 40, 7));
  const auto image = make_image(width, height, gradient);
  const auto trixels = vectorize::colour_trixels(image, t);
  const auto owner = vectorize::owner_of_pixels(width, height, t);

  std::vector<std::array<double, 4>> sums(t.triangles.size());
  std::vector<int> counts(t.triangles.size());
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const auto tri = owner[static_cast<std::size_t>(y) * width + x];
      for (int c = 0; c < 4; ++c) sums[tri][c] += image.pixel(x, y)[c];
      ++counts[tri];
    }
  double area = 0;
  for (std::size_t tri = 0; tri < t.triangles.size(); ++tri) {
    area += trixels[tri].area;
    EXPECT_GT(trixels[tri].area, 0.0);
    ASSERT_EQ(trixels[tri].pixel_count, static_cast<std::uint32_t>(counts[tri]));
    if (counts[tri] == 0) continue;
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(trixels[tri].rgba[c], sums[tri][c] / counts[tri], 1e-5);
  }
  EXPECT_NEAR(area, width * height, 1e-9 * width * height);
}

// Many points in few pixels make triangles that own no centre; on a flat image their sampled colour
// must still be the flat colour.
TEST(TrixelColours, SliversTakeTheSampledColour) {
  const auto t = triangulate_rectangle(6, 5, random_points(6, 5, 300, 3));
  const auto trixels = vectorize::colour_trixels(make_image(6, 5, flat), t);
  int slivers = 0;
  for (const auto& trixel : trixels) {
    slivers += trixel.pixel_count == 0;
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(trixel.rgba[c], flat(0, 0, c), 1e-6);
  }
  EXPECT_GT(slivers, 0);
}

// A sliver with no constraint between it and its neighbour takes that neighbour's colour, not a
// sample at its centroid: here the centroid lies in the left (black) half of the image, while the
// sliver belongs with the triangles on the right of the constraint at x = 2.
TEST(TrixelColours, SliversTakeTheirNeighboursColour) {
  const auto image = make_image(4, 4, [](int x, int, int c) -> float {
    if (c == 3) return 1.0f;
    return x < 2 ? 0.0f : 1.0f;
  });
  // Points: the constraint (2, 0)-(2, 4) and a point a hair right of it, so that the triangles beside
  // the constraint near (2, 2) own no pixel centre.
  const std::vector<cdt::Point> points = {{2, 0}, {2, 4}, {2.05, 2.0}};
  const auto t = triangulate_rectangle(4, 4, points, {{0, 1}});
  const auto trixels = vectorize::colour_trixels(image, t);
  int slivers = 0;
  for (std::size_t k = 0; k < trixels.size(); ++k) {
    double cx = 0.0;
    for (int i = 0; i < 3; ++i) cx += t.vertices[t.triangles[k][i]].x / 3.0;
    if (trixels[k].pixel_count != 0 || cx < 2.0) continue;
    ++slivers;
    EXPECT_EQ(trixels[k].rgba[0], 1.0f) << "sliver " << k;
  }
  EXPECT_GT(slivers, 0);
}

// A triangle that covers part of a solid pixel is flagged, and then counts as shape even when its
// own pixels are mostly clear; a clear triangle that only grazes a solid pixel stays clear.
TEST(TrixelColours, TrianglesCoveringSolidPixelsAreShape) {
  // Column 0 solid, the rest clear but for a faint column 1 (alpha 0.3).
  const auto image = make_image(4, 4, [](int x, int, int c) -> float {
    if (c != 3) return 0.5f;
    return x == 0 ? 1.0f : x == 1 ? 0.3f : 0.0f;
  });
  // The square split by either diagonal: each half reaches into column 0 (the one at a corner by a
  // sliver of one pixel) though most of its pixels are clear.
  const auto t = triangulate_rectangle(4, 4, {});
  ASSERT_EQ(t.triangles.size(), 2u);
  for (const auto& trixel : vectorize::colour_trixels(image, t)) EXPECT_TRUE(trixel.covers_solid);
  // A constraint along x = 1: the triangles right of it touch column 0 nowhere but on its edge, which
  // does not count; they stay clear.
  const auto t2 = triangulate_rectangle(4, 4, {{1, 0}, {1, 4}}, {{0, 1}});
  const auto trixels = vectorize::colour_trixels(image, t2);
  for (std::size_t k = 0; k < t2.triangles.size(); ++k) {
    double min_x = 4.0;
    for (int i = 0; i < 3; ++i) min_x = std::min(min_x, t2.vertices[t2.triangles[k][i]].x);
    EXPECT_EQ(trixels[k].covers_solid, min_x < 1.0) << "triangle " << k;
    if (min_x >= 1.0) {
      EXPECT_TRUE(trixels[k].transparent()) << "triangle " << k;
    }
  }
}

// Alpha below one half is "no shape"; RGB is alpha-weighted so hidden colour does not leak in.
TEST(TrixelColours, TransparencyAndAlphaWeightedColour) {
  auto image = make_image(4, 4, [](int x, int, int c) -> float {
    if (x < 2) return c == 3 ? 0.0f : 0.0f;      // transparent black
    return c == 0 ? 1.0f : c == 3 ? 1.0f : 0.0f; // opaque red
  });
  // The square split by a diagonal: each triangle owns pixels of both halves.
  const auto t = triangulate_rectangle(4, 4, {});
  const auto trixels = vectorize::colour_trixels(image, t);
  ASSERT_EQ(trixels.size(), 2u);
  for (const auto& trixel : trixels) {
    EXPECT_NEAR(trixel.rgba[0], 1.0f, 1e-6); // only the opaque pixels give colour
    EXPECT_GT(trixel.pixel_count, 0u);
  }
  image = make_image(4, 4, [](int, int, int c) -> float { return c == 3 ? 0.25f : 0.5f; });
  for (const auto& trixel : vectorize::colour_trixels(image, t)) EXPECT_TRUE(trixel.transparent());
}

} // namespace

namespace {

// Colours of an opaque image are summed without the premultiplied sums (they equal the straight ones):
// every triangle away from one translucent pixel must get, to the bit, what the general path gives
// it in the same image with that pixel added.
float noise(int x, int y, int c) {
  if (c == 3) return 1.0f;
  const double v = std::sin(x * 12.9898 + y * 78.233 + c * 37.719) * 43758.5453;
  return static_cast<float>(v - std::floor(v)); // every bit of the mantissa in play
}

TEST(TrixelColours, OpaqueImagesGiveTheGeneralPathsColoursToTheBit) {
  const int width = 61;
  const int height = 47;
  const auto t = triangulate_rectangle(width, height, lattice_points(width, height, 150, 11));
  const vectorize::Image opaque = make_image(width, height, noise);
  vectorize::Image translucent = opaque;
  translucent.pixel(0, 0)[3] = 0.75f;
  const auto a = vectorize::colour_trixels(opaque, t, 1);
  const auto b = vectorize::colour_trixels(translucent, t, 1);
  const auto owner = vectorize::owner_of_pixels(width, height, t);
  ASSERT_EQ(a.size(), b.size());
  std::size_t compared = 0;
  for (std::uint32_t tri = 0; tri < a.size(); ++tri) {
    EXPECT_EQ(a[tri].pixel_count, b[tri].pixel_count);
    EXPECT_TRUE(a[tri].covers_solid) << tri;
    if (tri == owner[0] || a[tri].pixel_count == 0) continue; // the changed pixel's, and slivers
    EXPECT_EQ(a[tri].rgba, b[tri].rgba) << tri;
    EXPECT_EQ(b[tri].covers_solid, true) << tri;
    ++compared;
  }
  EXPECT_GT(compared, 200u);
  EXPECT_NE(a[owner[0]].rgba[3], b[owner[0]].rgba[3]);
}

} // namespace

namespace {

// TrixelDevice::gpu adds up the pixels on the device with the host's code: the same trixels, field for
// field and bit for bit, and the colours' CIELAB as the grouping makes it, where there is a device; without
// one (or without CUDA in the build) a clear cdt::DeviceError rather than another answer.
TEST(TrixelColours, OnTheDeviceTheSameTrixelsOrAClearError) {
  const int width = 53;
  const int height = 41;
  const auto t = triangulate_rectangle(width, height, random_points(width, height, 200, 7));
  vectorize::Image translucent = make_image(width, height, noise);
  for (int x = 0; x < width; ++x) translucent.pixel(x, x % height)[3] = 0.25f;
  for (const vectorize::Image& image : {make_image(width, height, noise), translucent}) {
    if (cdt::gpu_device_count() == 0) {
      EXPECT_THROW(vectorize::colour_trixels(image, t, 1, vectorize::TrixelDevice::gpu), cdt::DeviceError);
      continue;
    }
    vectorize::TrixelLab lab_cpu, lab_gpu;
    const auto on_cpu = vectorize::colour_trixels(image, t, 1, vectorize::TrixelDevice::cpu, {}, &lab_cpu);
    const auto on_gpu = vectorize::colour_trixels(image, t, 1, vectorize::TrixelDevice::gpu, {}, &lab_gpu);
    EXPECT_TRUE(lab_cpu.empty());
    ASSERT_EQ(on_cpu.size(), on_gpu.size());
    ASSERT_EQ(lab_gpu.size(), on_gpu.size());
    for (std::size_t tri = 0; tri < on_cpu.size(); ++tri) {
      EXPECT_EQ(on_cpu[tri].rgba, on_gpu[tri].rgba) << tri;
      EXPECT_EQ(on_cpu[tri].pixel_count, on_gpu[tri].pixel_count) << tri;
      EXPECT_EQ(on_cpu[tri].covers_solid, on_gpu[tri].covers_solid) << tri;
      EXPECT_EQ(on_cpu[tri].area, on_gpu[tri].area) << tri;
      // The CIELAB made with the colours is the grouping's, to the bit (NaN only for sampled slivers).
      if (std::isnan(lab_gpu[tri][0])) {
        EXPECT_EQ(on_gpu[tri].pixel_count, 0u) << tri;
        continue;
      }
      const auto want =
          vectorize::srgb_to_lab({on_gpu[tri].rgba[0], on_gpu[tri].rgba[1], on_gpu[tri].rgba[2]});
      EXPECT_EQ(std::memcmp(lab_gpu[tri].data(), want.data(), sizeof want), 0) << tri;
    }
    // And the grouping with them is the grouping without.
    EXPECT_EQ(vectorize::group_trixels(t, on_gpu, {}, 1, &lab_gpu).region_of_triangle,
              vectorize::group_trixels(t, on_cpu).region_of_triangle);
  }
}

} // namespace
