// Stage 2's edges on the device (vectorize::gpu::edge_classes) against the host running the same steps
// (vectorize/src/edge_steps.hpp: gradient_rows in bands, edge_thresholds, suppress_rows, hysteresis):
// the same classes, pixel for pixel, with and without blur (up to the widest, sigma 50), with automatic and
// given thresholds, on images down to one pixel wide or high and at a photograph's size.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "cdt/cdt.hpp"
#include "edge_kernels.hpp"

namespace {

namespace d = vectorize::detail;

struct Raster {
  int width = 0;
  int height = 0;
  std::vector<float> rgba;
};

// Discs and a ramp of different colours under 16-bit noise: edges of every direction, flat areas and
// faint texture, so that the quantile, the suppression's four sectors and the hysteresis all matter.
Raster test_image(int width, int height, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> noise(-0.02f, 0.02f);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  struct Disc {
    float x, y, r, colour[3];
  };
  std::vector<Disc> discs;
  for (int k = 0; k < 6; ++k)
    discs.push_back({unit(rng) * width,
                     unit(rng) * height,
                     (0.1f + 0.3f * unit(rng)) * std::max(width, height),
                     {unit(rng), unit(rng), unit(rng)}});
  Raster r{width, height, std::vector<float>(static_cast<std::size_t>(width) * height * 4)};
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      float c[3] = {0.3f * x / std::max(1, width), 0.5f, 0.2f + 0.5f * y / std::max(1, height)};
      for (const Disc& disc : discs)
        if ((x - disc.x) * (x - disc.x) + (y - disc.y) * (y - disc.y) < disc.r * disc.r)
          for (int i = 0; i < 3; ++i) c[i] = disc.colour[i];
      float* p = &r.rgba[(static_cast<std::size_t>(y) * width + x) * 4];
      for (int i = 0; i < 3; ++i)
        p[i] = std::round(std::clamp(c[i] + noise(rng), 0.0f, 1.0f) * 65535.0f) / 65535.0f;
      p[3] = 1.0f;
    }
  return r;
}

std::vector<std::uint8_t> host_classes(const Raster& r, const d::BlurTaps& taps,
                                       const d::ThresholdRule& rule) {
  const std::size_t n = static_cast<std::size_t>(r.width) * r.height;
  std::vector<std::int16_t> dx(n), dy(n);
  std::vector<std::uint32_t> magnitude(n);
  d::GradientScratch scratch;
  const auto source = [&](int y, float* const* planes) {
    for (int x = 0; x < r.width; ++x)
      for (int c = 0; c < 3; ++c)
        planes[c][x] = r.rgba[(static_cast<std::size_t>(y) * r.width + x) * 4 + c] * d::kEdgeScale;
  };
  for (int r0 = 0; r0 < r.height; r0 += 16)
    d::gradient_rows(source, r.width, r.height, taps, r0, std::min(r.height, r0 + 16), dx.data(), dy.data(),
                     magnitude.data(), scratch);
  const d::SquaredThresholds t = d::edge_thresholds(rule, magnitude.data(), n);
  std::vector<std::uint8_t> classes(n);
  d::suppress_rows(dx.data(), dy.data(), magnitude.data(), r.width, r.height, t, 0, r.height, classes.data());
  d::hysteresis(classes.data(), r.width, r.height);
  return classes;
}

// Expects the device's classes to equal the host's; returns how many pixels are strong.
std::size_t expect_same_classes(const Raster& r, double sigma, const d::ThresholdRule& rule,
                                const std::string& what) {
  const d::BlurTaps taps = d::blur_taps(sigma);
  const std::vector<std::uint8_t> expected = host_classes(r, taps, rule);
  std::vector<std::uint8_t> got(expected.size(), 0x55);
  vectorize::gpu::edge_classes(r.rgba.data(), r.width, r.height, taps, rule, got.data());
  std::size_t strong = 0;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(got[i], expected[i]) << what << ", pixel " << i % r.width << "," << i / r.width;
    if (got[i] != expected[i]) break;
    strong += got[i] == d::kStrong;
  }
  return strong;
}

class EdgesGpu : public ::testing::Test {
protected:
  void SetUp() override {
    if (cdt::gpu_device_count() == 0) GTEST_SKIP() << "no CUDA device";
  }
};

TEST_F(EdgesGpu, SameClassesAsTheHost) {
  d::ThresholdRule automatic;
  d::ThresholdRule given;
  given.low = 20.0;
  given.high = 60.0;
  d::ThresholdRule high_only;
  high_only.high = 45.0;
  const std::vector<std::pair<int, int>> sizes = {{1, 1}, {1, 7}, {7, 1}, {2, 2}, {33, 17}, {160, 120}};
  std::size_t strong = 0;
  unsigned seed = 1;
  for (const auto& [width, height] : sizes)
    for (const double sigma : {0.0, 0.7, 1.2, 3.0, 50.0})
      for (const auto& [rule, name] : {std::pair{automatic, "automatic"}, std::pair{given, "given"},
                                       std::pair{high_only, "high only"}}) {
        const Raster r = test_image(width, height, seed++);
        strong += expect_same_classes(r, sigma, rule,
                                      std::to_string(width) + "x" + std::to_string(height) + ", sigma " +
                                          std::to_string(sigma) + ", thresholds " + name);
      }
  EXPECT_GT(strong, 1000u); // edges were found, not only compared
}

// The device's hysteresis (connected components) against the host's (a flood from the strong pixels)
// on class fields made to stress it: random candidates near the density where 8-connected clusters
// span the field, a few strong seeds; a spiral of candidates one pixel wide with its one strong pixel at
// the centre (a component thousands of pixels long); fields one pixel wide or high; no strong pixel.
TEST_F(EdgesGpu, HysteresisMatchesTheHost) {
  std::mt19937 rng(11);
  std::size_t promoted = 0;
  const auto check = [&](std::vector<std::uint8_t> classes, int width, int height, const std::string& what) {
    std::vector<std::uint8_t> expected = classes;
    d::hysteresis(expected.data(), width, height);
    const auto before = static_cast<std::size_t>(std::count(classes.begin(), classes.end(), d::kStrong));
    vectorize::gpu::hysteresis(classes.data(), width, height);
    EXPECT_EQ(classes, expected) << what;
    promoted += static_cast<std::size_t>(std::count(expected.begin(), expected.end(), d::kStrong)) - before;
  };
  for (const auto& [width, height] :
       std::vector<std::pair<int, int>>{{1, 1}, {1, 300}, {300, 1}, {257, 129}, {1000, 700}})
    for (const double density : {0.3, 0.45, 0.6}) {
      std::vector<std::uint8_t> classes(static_cast<std::size_t>(width) * height);
      std::bernoulli_distribution candidate(density), strong(0.002);
      for (std::uint8_t& c : classes)
        c = strong(rng) ? d::kStrong : candidate(rng) ? d::kCandidate : d::kNotEdge;
      check(classes, width, height,
            std::to_string(width) + "x" + std::to_string(height) + ", density " + std::to_string(density));
      std::replace(classes.begin(), classes.end(), d::kStrong, d::kCandidate);
      check(classes, width, height,
            "no strong pixel, " + std::to_string(width) + "x" + std::to_string(height));
    }
  // A square spiral: rings of candidates two pixels apart, joined at one corner each.
  const int side = 301;
  std::vector<std::uint8_t> spiral(static_cast<std::size_t>(side) * side, d::kNotEdge);
  int x = 0, y = 0, step_x = 1, step_y = 0, lo = 0, hi = side - 1;
  for (int k = 0; k < side * side / 2; ++k) {
    spiral[static_cast<std::size_t>(y) * side + x] = d::kCandidate;
    if (step_x == 1 && x == hi)
      step_x = 0, step_y = 1;
    else if (step_y == 1 && y == hi)
      step_x = -1, step_y = 0;
    else if (step_x == -1 && x == lo)
      step_x = 0, step_y = -1, lo += 2;
    else if (step_y == -1 && y == lo)
      step_x = 1, step_y = 0, hi -= 2;
    if (lo > hi) break;
    x += step_x;
    y += step_y;
  }
  spiral[static_cast<std::size_t>(y) * side + x] = d::kStrong;
  check(spiral, side, side, "spiral");
  EXPECT_GT(promoted, 10000u); // candidates were promoted, not only left alone
}

// The device's selection of the automatic thresholds' quantile against std::nth_element, on values
// that stress its three passes: all equal, ties at a bin's edges, the extremes of 32 bits, one value.
TEST_F(EdgesGpu, KthSmallestIsExact) {
  std::mt19937 rng(7);
  std::vector<std::vector<std::uint32_t>> sets = {
      {5}, {0, 0, 0}, {0xffffffffu, 0, 0x80000000u, 0x7fffffffu}, std::vector<std::uint32_t>(1000, 12345)};
  for (const int n : {2, 17, 1000, 100000}) {
    std::vector<std::uint32_t> wide(n), small(n), bins(n), squares(n);
    for (int i = 0; i < n; ++i) {
      wide[i] = rng();
      small[i] = rng() % 7;
      // values one apart across the passes' bin boundaries (bits 10 and 21)
      bins[i] = (i % 2 ? 1u << 21 : 1u << 10) + rng() % 3 - 1;
      const std::uint32_t m = rng() % 46341;
      squares[i] = m * m;
    }
    for (auto* v : {&wide, &small, &bins, &squares}) sets.push_back(*v);
  }
  for (const auto& values : sets) {
    std::vector<std::size_t> ranks = {
        0, values.size() - 1, values.size() / 2,
        static_cast<std::size_t>(0.85 * static_cast<double>(values.size() - 1))};
    for (const std::size_t k : ranks) {
      std::vector<std::uint32_t> sorted = values;
      std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(k), sorted.end());
      EXPECT_EQ(vectorize::gpu::kth_smallest(values.data(), values.size(), k), sorted[k])
          << values.size() << " values, k " << k;
    }
  }
  EXPECT_THROW(vectorize::gpu::kth_smallest(sets[0].data(), 1, 1), std::invalid_argument);
}

// The images edge_classes keeps on the device for the trixel colours take at most kKeptImageBytes
// at once: beyond it the image is not kept (its edges are made all the same), and a kept image freed
// makes room again.
TEST_F(EdgesGpu, KeptImagesStayWithinTheirBound) {
  const int side = 2048;
  const Raster r = test_image(side, side, 5);
  const std::size_t bytes = 4 * sizeof(float) * side * side;
  const std::size_t room = vectorize::gpu::kKeptImageBytes / bytes;
  const d::BlurTaps taps = d::blur_taps(1.0);
  const std::vector<std::uint8_t> expected = host_classes(r, taps, {});
  std::vector<std::unique_ptr<vectorize::gpu::DeviceImage>> kept;
  std::vector<std::uint8_t> classes(expected.size());
  for (std::size_t k = 0; k <= room; ++k) {
    kept.emplace_back();
    vectorize::gpu::edge_classes(r.rgba.data(), side, side, taps, {}, classes.data(), &kept.back());
    EXPECT_EQ(classes, expected) << "image " << k;
    EXPECT_EQ(kept.back() != nullptr, k < room) << "image " << k;
  }
  kept.front().reset();
  std::unique_ptr<vectorize::gpu::DeviceImage> again;
  vectorize::gpu::edge_classes(r.rgba.data(), side, side, taps, {}, classes.data(), &again);
  EXPECT_NE(again, nullptr);
}

TEST_F(EdgesGpu, SameClassesAtAPhotographsSize) {
  const Raster r = test_image(768, 512, 99);
  for (const double sigma : {1.0, 1.2}) EXPECT_GT(expect_same_classes(r, sigma, {}, "768x512"), 1000u);
}

} // namespace
