// The trixel stage's sums on the device (vectorize::gpu::trixel_sums) against the host running the
// same per-triangle code (vectorize/src/trixel_runs.hpp) in triangle order, as colour_trixels does:
// equal to the bit, on meshes whose vertices are off the fine grid (the exact orient2d path), on it
// (the half-plane path, many vertices and edges right on pixel centres), with and without
// transparency; and from the image edge_classes left on the device, with the colours' CIELAB.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "cdt/cdt.hpp"
#include "colour_lab.hpp"
#include "edge_kernels.hpp"
#include "trixel_kernels.hpp"

namespace {

using vectorize::detail::TrixelSums;

struct Raster {
  int width = 0;
  int height = 0;
  std::vector<float> rgba;
};

Raster random_raster(int width, int height, bool transparent, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> level(0, 255);
  Raster r{width, height, std::vector<float>(static_cast<std::size_t>(width) * height * 4)};
  for (std::size_t i = 0; i < r.rgba.size(); ++i) {
    const bool alpha = i % 4 == 3;
    r.rgba[i] = alpha && !transparent ? 1.0f : static_cast<float>(level(rng)) / 255.0f;
  }
  return r;
}

// A CDT of `count` points in [0, width] x [0, height] on a grid of 1/steps pixel (steps 0: anywhere),
// framed by the rectangle's corners and sides.
cdt::Triangulation random_mesh(int width, int height, int count, int steps, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(0.0, width);
  std::uniform_real_distribution<double> uy(0.0, height);
  std::vector<cdt::Point> points;
  for (int i = 0; i < count; ++i) {
    double x = ux(rng);
    double y = uy(rng);
    if (steps > 0) {
      x = std::round(x * steps) / steps;
      y = std::round(y * steps) / steps;
    }
    points.push_back({x, y});
  }
  const auto base = static_cast<std::uint32_t>(points.size());
  points.push_back({0, 0});
  points.push_back({static_cast<double>(width), 0});
  points.push_back({static_cast<double>(width), static_cast<double>(height)});
  points.push_back({0, static_cast<double>(height)});
  std::vector<cdt::Segment> segments;
  for (std::uint32_t i = 0; i < 4; ++i) segments.push_back({base + i, base + (i + 1) % 4});
  cdt::Options options;
  options.backend = cdt::Backend::cpu;
  return cdt::triangulate(points, segments, options);
}

std::vector<TrixelSums> host_sums(const Raster& r, const cdt::Triangulation& t, bool opaque) {
  std::vector<TrixelSums> sums(t.triangles.size());
  const std::size_t row_floats = static_cast<std::size_t>(r.width) * 4;
  for (std::size_t tri = 0; tri < t.triangles.size(); ++tri) {
    vectorize::detail::triangle_runs(t.vertices[t.triangles[tri][0]], t.vertices[t.triangles[tri][1]],
                                     t.vertices[t.triangles[tri][2]], r.width, r.height,
                                     [&](int row, int begin, int end) {
                                       const float* line = r.rgba.data() + row * row_floats;
                                       if (opaque)
                                         vectorize::detail::add_run_opaque(sums[tri], line, begin, end);
                                       else
                                         vectorize::detail::add_run(sums[tri], line, begin, end);
                                     });
  }
  return sums;
}

void expect_equal(const std::vector<TrixelSums>& expected, const std::vector<TrixelSums>& got,
                  const Raster& r, const std::string& what) {
  std::uint64_t pixels = 0;
  for (std::size_t tri = 0; tri < expected.size(); ++tri) {
    const TrixelSums& e = expected[tri];
    const TrixelSums& g = got[tri];
    pixels += g.pixel_count;
    ASSERT_EQ(g.pixel_count, e.pixel_count) << what << ", triangle " << tri;
    ASSERT_EQ(g.covers_solid, e.covers_solid) << what << ", triangle " << tri;
    // Bit for bit: the same operations in the same order.
    ASSERT_EQ(std::memcmp(g.straight, e.straight, sizeof e.straight), 0) << what << ", triangle " << tri;
    ASSERT_EQ(std::memcmp(g.premultiplied, e.premultiplied, sizeof e.premultiplied), 0)
        << what << ", triangle " << tri;
    ASSERT_EQ(std::memcmp(&g.alpha, &e.alpha, sizeof e.alpha), 0) << what << ", triangle " << tri;
  }
  // The mesh covers the image: every pixel centre counted once.
  EXPECT_EQ(pixels, static_cast<std::uint64_t>(r.width) * r.height) << what;
}

// The device's sums equal the host's, with the image copied by trixel_sums and with the image that
// edge_classes left on the device.
void expect_same_sums(const Raster& r, const cdt::Triangulation& t, bool opaque, const std::string& what) {
  const std::vector<TrixelSums> expected = host_sums(r, t, opaque);
  std::vector<TrixelSums> got(t.triangles.size());
  vectorize::gpu::trixel_sums(r.rgba.data(), r.width, r.height, t.vertices.data(), t.vertices.size(),
                              t.triangles.data(), t.triangles.size(), opaque, got.data());
  expect_equal(expected, got, r, what);

  std::unique_ptr<vectorize::gpu::DeviceImage> kept;
  std::vector<std::uint8_t> classes(static_cast<std::size_t>(r.width) * r.height);
  vectorize::gpu::edge_classes(r.rgba.data(), r.width, r.height, vectorize::detail::blur_taps(1.0), {},
                               classes.data(), &kept);
  ASSERT_NE(kept, nullptr) << what;
  EXPECT_EQ(kept->width(), r.width);
  EXPECT_EQ(kept->height(), r.height);
  std::vector<TrixelSums> from_kept(t.triangles.size());
  std::vector<std::array<double, 3>> lab(t.triangles.size(), {-1.0, -1.0, -1.0});
  vectorize::gpu::trixel_sums(nullptr, r.width, r.height, t.vertices.data(), t.vertices.size(),
                              t.triangles.data(), t.triangles.size(), opaque, from_kept.data(), kept->data(),
                              lab.data());
  expect_equal(expected, from_kept, r, what + ", the image kept on the device");
  // The colours' CIELAB: the host's, to the bit, where a triangle owns pixels; zeros elsewhere.
  for (std::size_t tri = 0; tri < expected.size(); ++tri) {
    std::array<double, 3> want{};
    if (expected[tri].pixel_count > 0) {
      float colour[4];
      vectorize::detail::trixel_rgba(expected[tri], opaque, colour);
      vectorize::detail::lab_of_rgb(colour, vectorize::detail::srgb_linear_table(), want.data());
    }
    ASSERT_EQ(std::memcmp(lab[tri].data(), want.data(), sizeof want), 0)
        << what << ", triangle " << tri << ": L " << lab[tri][0] << " against " << want[0];
  }
}

class TrixelSumsGpu : public ::testing::Test {
protected:
  void SetUp() override {
    if (cdt::gpu_device_count() == 0) GTEST_SKIP() << "no CUDA device";
  }
};

TEST_F(TrixelSumsGpu, SameAsTheHostOnEveryKindOfMesh) {
  for (unsigned seed = 1; seed <= 4; ++seed) {
    const int width = 40 + 13 * static_cast<int>(seed);
    const int height = 30 + 7 * static_cast<int>(seed);
    // Anywhere (exact orientation tests), on half pixels (edges through rows of centres), on
    // sixteenths (the half-plane path).
    for (const int steps : {0, 2, 16}) {
      const cdt::Triangulation t = random_mesh(width, height, 400, steps, seed);
      for (const bool transparent : {false, true}) {
        const Raster r = random_raster(width, height, transparent, seed * 7 + steps);
        expect_same_sums(r, t, !transparent,
                         "seed " + std::to_string(seed) + ", grid 1/" + std::to_string(steps) +
                             (transparent ? ", transparent" : ", opaque"));
      }
    }
  }
}

// A photograph's size and mesh density (about 16,000 points on 768 x 512 pixels), and a mesh with a few
// large triangles (a thread adds up thousands of pixels).
TEST_F(TrixelSumsGpu, SameAsTheHostAtAPhotographsSize) {
  const Raster r = random_raster(768, 512, false, 11);
  expect_same_sums(r, random_mesh(768, 512, 16000, 2, 5), true, "photograph-sized, opaque");
  const Raster clear = random_raster(768, 512, true, 12);
  expect_same_sums(clear, random_mesh(768, 512, 30, 0, 6), false, "few large triangles, transparent");
}

// No triangles: nothing to do. No pixels: every triangle owns none (and reads no row).
TEST_F(TrixelSumsGpu, EmptyInputsGiveEmptySums) {
  const Raster r = random_raster(8, 8, false, 1);
  EXPECT_NO_THROW(
      vectorize::gpu::trixel_sums(r.rgba.data(), r.width, r.height, nullptr, 0, nullptr, 0, true, nullptr));
  const cdt::Triangulation t = random_mesh(8, 8, 20, 0, 2);
  for (const int width : {0, 8}) {
    std::vector<TrixelSums> got(t.triangles.size());
    got[0].pixel_count = 7; // overwritten
    vectorize::gpu::trixel_sums(nullptr, width, 8 - width, t.vertices.data(), t.vertices.size(),
                                t.triangles.data(), t.triangles.size(), false, got.data());
    for (const TrixelSums& s : got) {
      EXPECT_EQ(s.pixel_count, 0u) << "width " << width;
      EXPECT_EQ(s.alpha, 0.0) << "width " << width;
    }
  }
}

} // namespace
