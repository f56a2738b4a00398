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

#include "../../vectorize/src/edges_row.hpp"
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

// The strongest-channel step (vectorised where the build allows) against the plain rule written out
// here: the first channel of the largest gx^2 + gy^2, its derivatives rounded to the nearest integer,
// ties to even, and clamped to 16 bits (cv::saturate_cast<short> within the range of int), and
// the squared lengths of shape pixels in order. Rows of every length up to 11 (whole vectors and
// leftovers), with ties between channels, halves (rounding ties), values beyond 16 bits and zeros.
TEST(Edges, StrongestChannelStepFollowsThePlainRule) {
  std::mt19937 random(7);
  const float specials[] = {0.0f,     0.5f,      1.5f,     2.5f,  -0.5f, -1.5f,
                            32767.5f, -32768.5f, 40000.0f, -1e6f, 3.0f,  -3.0f};
  int checked = 0;
  for (int width = 1; width <= 11; ++width) {
    for (int trial = 0; trial < 200; ++trial) {
      std::vector<float> gx(3 * static_cast<std::size_t>(width));
      std::vector<float> gy(gx.size());
      std::vector<std::uint8_t> shape(static_cast<std::size_t>(width));
      for (std::size_t i = 0; i < gx.size(); ++i) {
        const auto pick = [&] {
          return random() % 3 == 0 ? specials[random() % std::size(specials)]
                                   : static_cast<float>(static_cast<int>(random() % 20001) - 10000) / 8.0f;
        };
        gx[i] = pick();
        gy[i] = pick();
        if (random() % 4 == 0 && i % 3 != 0) { // the same length as the pixel's first channel
          gx[i] = -gx[i - i % 3];
          gy[i] = gy[i - i % 3];
        }
      }
      for (auto& s : shape) s = random() % 3 != 0;
      std::vector<short> out_x(static_cast<std::size_t>(width)), out_y(out_x.size());
      std::vector<float> squared;
      vectorize::detail::strongest_channel_row(gx.data(), gy.data(), shape.data(), width, out_x.data(),
                                               out_y.data(), squared);
      std::vector<float> expected_squared;
      for (int x = 0; x < width; ++x) {
        int best = 0;
        float best_sq = -1.0f;
        for (int c = 0; c < 3; ++c) {
          const float a = gx[3 * x + c];
          const float b = gy[3 * x + c];
          const float sq = a * a + b * b;
          if (sq > best_sq) {
            best_sq = sq;
            best = c;
          }
        }
        const auto to_short = [](float v) {
          return static_cast<short>(std::clamp(std::lrint(v), -32768L, 32767L));
        };
        EXPECT_EQ(out_x[x], to_short(gx[3 * x + best])) << "width " << width << " x " << x;
        EXPECT_EQ(out_y[x], to_short(gy[3 * x + best])) << "width " << width << " x " << x;
        if (shape[x]) expected_squared.push_back(best_sq);
        ++checked;
      }
      EXPECT_EQ(squared, expected_squared);
    }
  }
  EXPECT_EQ(checked, 200 * 66);
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
