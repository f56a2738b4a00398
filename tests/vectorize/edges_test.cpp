#include "vectorize/edges.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <random>
#include <stdexcept>
#include <vector>

#include "../../vectorize/src/edge_steps.hpp"
#include "cdt/cdt.hpp"
#include "cdt/errors.hpp"
#include "stage_test_util.hpp"

namespace {

using trixel_test::make_image;

using vectorize::EdgeMap;
using vectorize::EdgeOptions;
using vectorize::Image;

int count_edges(const EdgeMap& map) {
  int n = 0;
  for (const auto v : map.on) n += v;
  return n;
}

// A white rectangle [10, 30) x [8, 22) on black.
bool in_rect(int x, int y) { return x >= 10 && x < 30 && y >= 8 && y < 22; }

TEST(Edges, FilledRectangleGivesItsOutline) {
  const Image image = make_image(40, 30, [](int x, int y) {
    const float v = in_rect(x, y) ? 1.0f : 0.0f;
    return std::array{v, v, v, 1.0f};
  });
  const EdgeMap map = vectorize::detect_edges(image);
  ASSERT_EQ(map.width, 40);
  ASSERT_EQ(map.height, 30);
  ASSERT_EQ(map.on.size(), 40u * 30u);
  // Every edge pixel is next to the step (the outline runs between pixels 9|10, 29|30, 7|8, 21|22).
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) {
      if (!map.at(x, y)) continue;
      const bool near_vertical = (std::abs(x - 9) <= 1 || std::abs(x - 30) <= 1) && y >= 6 && y <= 23;
      const bool near_horizontal = (std::abs(y - 7) <= 1 || std::abs(y - 22) <= 1) && x >= 8 && x <= 31;
      EXPECT_TRUE(near_vertical || near_horizontal) << "stray edge pixel at " << x << "," << y;
    }
  // Every side is found along its whole length (corners excepted).
  for (int x = 12; x < 28; ++x) {
    EXPECT_TRUE(map.at(x, 7) || map.at(x, 8)) << "top side missing at x=" << x;
    EXPECT_TRUE(map.at(x, 21) || map.at(x, 22)) << "bottom side missing at x=" << x;
  }
  for (int y = 10; y < 20; ++y) {
    EXPECT_TRUE(map.at(9, y) || map.at(10, y)) << "left side missing at y=" << y;
    EXPECT_TRUE(map.at(29, y) || map.at(30, y)) << "right side missing at y=" << y;
  }
}

TEST(Edges, FlatImageGivesNone) {
  const Image image = make_image(32, 24, [](int, int) { return std::array{0.3f, 0.6f, 0.2f, 1.0f}; });
  EXPECT_EQ(count_edges(vectorize::detect_edges(image)), 0);
}

// Automatic thresholds have a floor, so sensor or JPEG noise of a level or two is not edges.
TEST(Edges, FaintNoiseGivesNone) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> noise(-2, 2);
  const Image image = make_image(64, 48, [&](int, int) {
    return std::array{0.5f + noise(rng) / 255.0f, 0.5f + noise(rng) / 255.0f, 0.5f + noise(rng) / 255.0f,
                      1.0f};
  });
  EXPECT_EQ(count_edges(vectorize::detect_edges(image)), 0);
}

// Red against green of the same grey level: a grey-level gradient sees nothing here.
TEST(Edges, ColourStepOfEqualLuminanceIsFound) {
  const Image image = make_image(30, 20, [](int x, int) {
    return x < 15 ? std::array{0.6f, 0.3f, 0.3f, 1.0f} : std::array{0.3f, 0.6f, 0.3f, 1.0f};
  });
  const EdgeMap map = vectorize::detect_edges(image);
  for (int y = 2; y < 18; ++y) EXPECT_TRUE(map.at(14, y) || map.at(15, y)) << "y=" << y;
}

// An opaque disc on a transparent background whose stored colour is noise: the disc's outline is
// exactly the edge set, and nothing inside the transparent area is an edge.
TEST(Edges, TransparentShapeBoundaryIsEdge) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> any(0.0f, 1.0f);
  auto in_disc = [](int x, int y) { return (x - 20) * (x - 20) + (y - 16) * (y - 16) <= 100; };
  const Image image = make_image(40, 32, [&](int x, int y) {
    if (in_disc(x, y)) return std::array{0.8f, 0.4f, 0.1f, 1.0f};
    return std::array{any(rng), any(rng), any(rng), 0.2f};
  });
  const EdgeMap map = vectorize::detect_edges(image);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 40; ++x) {
      const bool outline = in_disc(x, y) && (!in_disc(x - 1, y) || !in_disc(x + 1, y) || !in_disc(x, y - 1) ||
                                             !in_disc(x, y + 1));
      EXPECT_EQ(map.at(x, y), outline) << x << "," << y;
    }
}

// Two opaque halves of different colour inside a transparent frame: the colour edge stops at the
// shape, and the fill of the transparent area (nearest shape colour) does not carry it outside.
TEST(Edges, NoEdgesInsideTransparentArea) {
  const Image image = make_image(40, 40, [](int x, int y) {
    const bool shape = x >= 10 && x < 30 && y >= 10 && y < 30;
    if (!shape) return std::array{1.0f, 1.0f, 1.0f, 0.0f};
    return x < 20 ? std::array{1.0f, 0.0f, 0.0f, 1.0f} : std::array{0.0f, 0.0f, 1.0f, 1.0f};
  });
  const EdgeMap map = vectorize::detect_edges(image);
  int inside = 0;
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 40; ++x) {
      const bool shape = x >= 10 && x < 30 && y >= 10 && y < 30;
      if (!shape) {
        EXPECT_FALSE(map.at(x, y)) << x << "," << y;
      }
      if (shape && x >= 12 && x < 28 && y >= 12 && y < 28) inside += map.at(x, y) ? 1 : 0;
    }
  EXPECT_GE(inside, 14); // the red|blue step itself is still there
}

// 16-bit input keeps its precision through the Image floats: a step of half an 8-bit level is found
// with thresholds below it and not with thresholds above it. Grey input is R = G = B.
TEST(Edges, SubEightBitGreyStepWithExplicitThresholds) {
  const Image image = make_image(30, 20, [](int x, int) {
    const float v = x < 15 ? 0.5f : 0.5f + 0.5f / 255.0f;
    return std::array{v, v, v, 1.0f};
  });
  EdgeOptions fine;
  fine.blur_sigma_px = 0.0;
  fine.high = 1.0; // the step gives 4 * 0.5 = 2 in 8-bit Sobel units
  fine.low = 0.5;
  const EdgeMap found = vectorize::detect_edges(image, fine);
  for (int y = 2; y < 18; ++y) EXPECT_TRUE(found.at(14, y) || found.at(15, y)) << "y=" << y;
  EdgeOptions coarse = fine;
  coarse.high = 3.0;
  coarse.low = 2.5;
  EXPECT_EQ(count_edges(vectorize::detect_edges(image, coarse)), 0);
}

TEST(Edges, EmptyAndFullyTransparentImagesGiveNone) {
  const EdgeMap empty = vectorize::detect_edges(Image{});
  EXPECT_EQ(empty.width, 0);
  EXPECT_TRUE(empty.on.empty());
  const Image clear = make_image(10, 10, [](int x, int) { return std::array{x * 0.1f, 0.0f, 0.0f, 0.0f}; });
  EXPECT_EQ(count_edges(vectorize::detect_edges(clear)), 0);
}

TEST(Edges, RejectsMalformedInput) {
  Image bad;
  bad.width = 4;
  bad.height = 4;
  bad.rgba.resize(10);
  EXPECT_THROW(vectorize::detect_edges(bad), std::invalid_argument);
  const Image ok = make_image(4, 4, [](int, int) { return std::array{0.0f, 0.0f, 0.0f, 1.0f}; });
  EdgeOptions options;
  options.non_edge_fraction = 1.0;
  EXPECT_THROW(vectorize::detect_edges(ok, options), std::invalid_argument);
}

} // namespace

namespace {

// Horizontal bands of changing colour (steps and ramps along y), with a diagonal line, shifted down by
// `shift` rows; a transparent notch on the left when `notch`.
Image banded_image(int shift, bool notch) {
  return make_image(48, 120, [=](int x, int y) {
    const int v = y - shift;
    const float r = (v / 7) % 2 == 0 ? 0.2f : 0.8f;
    const float g = static_cast<float>((v * 5) % 64) / 64.0f;
    const float b = std::abs(x - v / 2) <= 1 ? 1.0f : 0.1f;
    const float a = notch && x < 6 && v % 40 < 12 ? 0.0f : 1.0f;
    return std::array{r, g, b, a};
  });
}

// The strongest-channel step against the plain rule written out here: the first channel of the
// largest gx^2 + gy^2, its derivatives rounded to the nearest integer, ties to even, and clamped to 16
// bits; with ties between channels, halves (rounding ties), values beyond 16 bits and zeros.
TEST(Edges, StrongestChannelStepFollowsThePlainRule) {
  std::mt19937 random(7);
  const float specials[] = {0.0f,     0.5f,      1.5f,     2.5f,  -0.5f, -1.5f,
                            32767.5f, -32768.5f, 40000.0f, -1e6f, 3.0f,  -3.0f};
  const auto pick = [&] {
    return random() % 3 == 0 ? specials[random() % std::size(specials)]
                             : static_cast<float>(static_cast<int>(random() % 20001) - 10000) / 8.0f;
  };
  for (int trial = 0; trial < 20000; ++trial) {
    float gx[3];
    float gy[3];
    for (int c = 0; c < 3; ++c) {
      gx[c] = pick();
      gy[c] = pick();
      if (c > 0 && random() % 4 == 0) { // the same length as the first channel
        gx[c] = -gx[0];
        gy[c] = gy[0];
      }
    }
    int best = 0;
    float best_sq = -1.0f;
    for (int c = 0; c < 3; ++c) {
      const float sq = gx[c] * gx[c] + gy[c] * gy[c];
      if (sq > best_sq) {
        best_sq = sq;
        best = c;
      }
    }
    const auto to_short = [](float v) {
      return static_cast<int>(std::clamp(std::lrint(v), -32768L, 32767L));
    };
    const vectorize::detail::PixelGradient g =
        vectorize::detail::strongest_channel(gx[0], gy[0], gx[1], gy[1], gx[2], gy[2]);
    ASSERT_EQ(g.dx, to_short(gx[best])) << "trial " << trial;
    ASSERT_EQ(g.dy, to_short(gy[best])) << "trial " << trial;
    ASSERT_EQ(g.magnitude, static_cast<std::uint32_t>(g.dx * g.dx) + static_cast<std::uint32_t>(g.dy * g.dy));
  }
}

// The host's gradient, made tap by tap across rows in bands, against the same steps evaluated pixel by
// pixel with clamped coordinates, as the device evaluates them: equal to the bit, for blurs of several
// widths (none included), images down to one pixel wide or high, and bands anywhere.
TEST(Edges, GradientRowsFollowThePerPixelSteps) {
  namespace d = vectorize::detail;
  std::mt19937 random(11);
  int compared = 0;
  for (const double sigma : {0.0, 0.3, 0.7, 1.2, 2.5, 30.0}) {
    const d::BlurTaps taps = d::blur_taps(sigma);
    for (const auto& [width, height] :
         std::vector<std::pair<int, int>>{{1, 1}, {1, 9}, {9, 1}, {2, 3}, {17, 12}, {40, 33}}) {
      if (taps.radius > 20 && width * height > 30) continue; // the reference's cost grows as radius^2
      std::vector<float> rgba(static_cast<std::size_t>(width) * height * 4);
      for (float& v : rgba) v = static_cast<float>(random() % 65536) / 65535.0f;
      const auto value = [&](int x, int y, int c) {
        x = std::clamp(x, 0, width - 1);
        y = std::clamp(y, 0, height - 1);
        return rgba[(static_cast<std::size_t>(y) * width + x) * 4 + c] * d::kEdgeScale;
      };
      const auto across = [&](int x, int y, int c) {
        float acc = taps.radius == 0 ? value(x, y, c) : taps.weight[0] * value(x, y, c);
        for (int k = 1; k <= taps.radius; ++k)
          acc = d::add_taps(acc, taps.weight[k], value(x - k, y, c), value(x + k, y, c));
        return acc;
      };
      const auto blurred = [&](int x, int y, int c) {
        x = std::clamp(x, 0, width - 1);
        y = std::clamp(y, 0, height - 1);
        float acc = taps.radius == 0 ? across(x, y, c) : taps.weight[0] * across(x, y, c);
        for (int k = 1; k <= taps.radius; ++k)
          acc = d::add_taps(acc, taps.weight[k], across(x, std::max(0, y - k), c),
                            across(x, std::min(height - 1, y + k), c));
        return acc;
      };
      const std::size_t n = static_cast<std::size_t>(width) * height;
      std::vector<std::int16_t> dx(n, 0x5555), dy(n, 0x5555);
      std::vector<std::uint32_t> magnitude(n, 0x55555555);
      d::GradientScratch scratch;
      const auto source = [&](int y, float* const* planes) {
        for (int x = 0; x < width; ++x)
          for (int c = 0; c < 3; ++c)
            planes[c][x] = rgba[(static_cast<std::size_t>(y) * width + x) * 4 + c] * d::kEdgeScale;
      };
      // Bands of random heights covering the rows.
      for (int r0 = 0; r0 < height;) {
        const int r1 = std::min(height, r0 + 1 + static_cast<int>(random() % 7));
        d::gradient_rows(source, width, height, taps, r0, r1, dx.data(), dy.data(), magnitude.data(),
                         scratch);
        r0 = r1;
      }
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
          float gx[3];
          float gy[3];
          for (int c = 0; c < 3; ++c) {
            gx[c] = d::sobel_x(blurred(x - 1, y - 1, c), blurred(x + 1, y - 1, c), blurred(x - 1, y, c),
                               blurred(x + 1, y, c), blurred(x - 1, y + 1, c), blurred(x + 1, y + 1, c));
            gy[c] = d::sobel_y(blurred(x - 1, y - 1, c), blurred(x, y - 1, c), blurred(x + 1, y - 1, c),
                               blurred(x - 1, y + 1, c), blurred(x, y + 1, c), blurred(x + 1, y + 1, c));
          }
          const d::PixelGradient g = d::strongest_channel(gx[0], gy[0], gx[1], gy[1], gx[2], gy[2]);
          const std::size_t i = static_cast<std::size_t>(y) * width + x;
          ASSERT_EQ(dx[i], g.dx) << "sigma " << sigma << " size " << width << "x" << height << " at " << x
                                 << "," << y;
          ASSERT_EQ(dy[i], g.dy) << "sigma " << sigma << " size " << width << "x" << height << " at " << x
                                 << "," << y;
          ASSERT_EQ(magnitude[i], g.magnitude);
          ++compared;
        }
    }
  }
  // A wide blur (sigma 30: taps 120 pixels out, beyond every side) on the small images only.
  EXPECT_EQ(compared, 6 * (1 + 9 + 9 + 6) + 5 * (17 * 12 + 40 * 33));
}

// The suppression over rows (its inner pixels without bounds checks and without branches, also built
// for AVX2) against suppress() pixel by pixel: the same classes, with ties between neighbours,
// magnitudes at the thresholds, gradients on the sectors' borders and images down to one pixel.
TEST(Edges, SuppressionRowsFollowTheStep) {
  namespace d = vectorize::detail;
  std::mt19937 random(13);
  // Derivatives near the sectors' borders (tan 22.5 and tan 67.5 degrees), zeros, both signs.
  const int derivatives[] = {0, 1, -1, 5, -5, 12, -12, 29, -29, 70, -70, 169, -169, 408, -408, 32767, -32768};
  int compared = 0;
  for (const auto& [width, height] :
       std::vector<std::pair<int, int>>{{1, 1}, {1, 5}, {5, 1}, {2, 2}, {3, 3}, {23, 9}, {64, 17}}) {
    const std::size_t n = static_cast<std::size_t>(width) * height;
    for (int trial = 0; trial < 40; ++trial) {
      std::vector<std::int16_t> dx(n), dy(n);
      std::vector<std::uint32_t> magnitude(n);
      for (std::size_t i = 0; i < n; ++i) {
        dx[i] = static_cast<std::int16_t>(random() % 2 ? derivatives[random() % std::size(derivatives)]
                                                       : static_cast<int>(random() % 801) - 400);
        dy[i] = static_cast<std::int16_t>(random() % 2 ? derivatives[random() % std::size(derivatives)]
                                                       : static_cast<int>(random() % 801) - 400);
        magnitude[i] = random() % 24; // small: many ties, and values at both thresholds
      }
      const d::SquaredThresholds t{static_cast<std::uint64_t>(random() % 8),
                                   static_cast<std::uint64_t>(8 + random() % 10)};
      std::vector<std::uint8_t> classes(n, 0x55);
      const int r0 = static_cast<int>(random() % height);
      const int r1 = r0 + 1 + static_cast<int>(random() % (height - r0));
      d::suppress_rows(dx.data(), dy.data(), magnitude.data(), width, height, t, r0, r1, classes.data());
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
          const std::size_t i = static_cast<std::size_t>(y) * width + x;
          if (y < r0 || y >= r1) {
            ASSERT_EQ(classes[i], 0x55) << "row " << y << " outside [" << r0 << ", " << r1 << ")";
            continue;
          }
          const std::uint32_t* mid = magnitude.data() + static_cast<std::size_t>(y) * width;
          const std::uint8_t expected = d::suppress(dx[i], dy[i], magnitude[i], y > 0 ? mid - width : nullptr,
                                                    mid, y + 1 < height ? mid + width : nullptr, x, width, t);
          ASSERT_EQ(classes[i], expected) << width << "x" << height << " trial " << trial << " at " << x
                                          << "," << y << " dx " << dx[i] << " dy " << dy[i];
          ++compared;
        }
    }
  }
  EXPECT_GT(compared, 10000);
}

// The hysteresis keeps the candidates 8-connected to a strong pixel through candidates, diagonals
// included, and drops the others.
TEST(Edges, HysteresisKeepsCandidatesConnectedToStrongPixels) {
  namespace d = vectorize::detail;
  // 0: not an edge, 1: candidate, 2: strong.
  const std::vector<std::uint8_t> before = {
      1, 1, 0, 0, 0, 0, //
      0, 0, 1, 0, 0, 1, //
      0, 0, 0, 2, 0, 1, //
      0, 1, 0, 0, 0, 0, //
      1, 0, 0, 0, 1, 1, //
  };
  const std::vector<std::uint8_t> after = {
      2, 2, 0, 0, 0, 0, //
      0, 0, 2, 0, 0, 1, //
      0, 0, 0, 2, 0, 1, //
      0, 1, 0, 0, 0, 0, //
      1, 0, 0, 0, 1, 1, //
  };
  std::vector<std::uint8_t> classes = before;
  d::hysteresis(classes.data(), 6, 5);
  EXPECT_EQ(classes, after);
}

// The suppression keeps a pixel that exceeds its neighbour against the gradient and equals or exceeds
// the one along it, in each of the four sectors, and classes it by the thresholds.
TEST(Edges, SuppressionComparesAlongTheGradient) {
  namespace d = vectorize::detail;
  const d::SquaredThresholds t{100, 400};
  // Rows above, at and below the pixel (x = 1 of 3).
  const std::uint32_t up[3] = {10, 20, 30};
  const std::uint32_t mid[3] = {40, 200, 60};
  const std::uint32_t down[3] = {70, 80, 90};
  EXPECT_EQ(d::suppress(10, 0, 200, up, mid, down, 1, 3, t), d::kCandidate);   // along x: 40 and 60
  EXPECT_EQ(d::suppress(0, 10, 200, up, mid, down, 1, 3, t), d::kCandidate);   // along y: 20 and 80
  EXPECT_EQ(d::suppress(10, 10, 200, up, mid, down, 1, 3, t), d::kCandidate);  // down-right: 10 and 90
  EXPECT_EQ(d::suppress(10, -10, 200, up, mid, down, 1, 3, t), d::kCandidate); // down-left: 30 and 70
  EXPECT_EQ(d::suppress(10, 0, 60, up, mid, down, 1, 3, t), d::kNotEdge);      // at most the low threshold
  EXPECT_EQ(d::suppress(10, 0, 500, up, mid, down, 1, 3, t), d::kStrong);
  const std::uint32_t high_after[3] = {40, 200, 200};
  EXPECT_EQ(d::suppress(10, 0, 200, up, high_after, down, 1, 3, t), d::kCandidate); // equal along: kept
  const std::uint32_t high_before[3] = {200, 200, 60};
  EXPECT_EQ(d::suppress(10, 0, 200, up, high_before, down, 1, 3, t), d::kNotEdge); // equal against: not
  // Outside the image a magnitude is 0.
  EXPECT_EQ(d::suppress(0, 10, 200, nullptr, mid, nullptr, 1, 3, t), d::kCandidate);
  EXPECT_EQ(d::suppress(10, 0, 200, up, mid, down, 0, 1, t), d::kCandidate);
}

// EdgeDevice::gpu: the same edges as the CPU's with a device (an image with transparency stays on the
// CPU), cdt::DeviceError without one or without CUDA.
TEST(Edges, OnTheDeviceTheSameEdgesOrAClearError) {
  std::mt19937 random(5);
  const Image opaque = make_image(61, 47, [&](int x, int y) {
    const float v = (x - 30) * (x - 30) + (y - 20) * (y - 20) < 200 ? 0.8f : 0.2f;
    return std::array<float, 4>{v, 0.5f + static_cast<float>(random() % 100) / 1000.0f, 1.0f - v, 1.0f};
  });
  Image translucent = opaque;
  for (int x = 0; x < 20; ++x) translucent.pixel(x, 3)[3] = 0.0f;
  EdgeOptions options;
  if (cdt::gpu_device_count() == 0) {
    EXPECT_THROW(vectorize::detect_edges(opaque, options, 1, vectorize::EdgeDevice::gpu), cdt::DeviceError);
    return;
  }
  for (const Image& image : {opaque, translucent}) {
    const EdgeMap on_cpu = vectorize::detect_edges(image, options, 1);
    EXPECT_GT(count_edges(on_cpu), 20);
    EXPECT_EQ(vectorize::detect_edges(image, options, 1, vectorize::EdgeDevice::gpu).on, on_cpu.on);
  }
}

} // namespace

// The gradient is computed in bands of rows with the blur's and the Sobel filter's reach of rows
// around each: an edge comes out the same wherever it falls relative to the bands (the picture moved
// down by a few rows gives the same edges moved down), and for any number of threads.
TEST(Edges, BandsAndThreadsDoNotChangeTheEdges) {
  EdgeOptions options;
  options.blur_sigma_px = 1.5;
  options.low = 20.0;
  options.high = 60.0;
  for (const bool notch : {false, true}) {
    const Image image = banded_image(0, notch);
    const EdgeMap one = vectorize::detect_edges(image, options, 1);
    ASSERT_GT(count_edges(one), 100);
    for (const unsigned threads : {2u, 3u, 0u})
      EXPECT_EQ(vectorize::detect_edges(image, options, threads).on, one.on) << "threads " << threads;
    for (const int shift : {5, 13, 27}) {
      const EdgeMap moved = vectorize::detect_edges(banded_image(shift, notch), options, 2);
      int compared = 0;
      for (int y = 10; y + shift < image.height - 10; ++y)
        for (int x = 0; x < image.width; ++x) {
          ASSERT_EQ(one.at(x, y), moved.at(x, y + shift))
              << "pixel " << x << "," << y << " moved by " << shift << (notch ? " (notch)" : "");
          ++compared;
        }
      EXPECT_GT(compared, 1000);
    }
  }
}
