// End to end on shapes with transparency, rendered back with rsvg-convert: the SVG covers every solid
// pixel completely (no background shows through, not even at anti-aliased rims) and paints nothing
// well away from the shapes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "../test_util.hpp"
#include "vectorize/image.hpp"
#include "vectorize/pipeline.hpp"

namespace {

using trixel_test::run;
using trixel_test::ScratchDir;
using trixel_test::shell_quote;
using vectorize::Image;

constexpr int kWidth = 128;
constexpr int kHeight = 96;

// Fraction of pixel (x, y) inside a shape, from 4 x 4 samples: anti-aliased edges as a renderer draws
// them. With samples = 1, the pixel centre alone decides (a hard, aliased edge).
template <class Inside>
float coverage(int x, int y, int samples, Inside&& inside) {
  int hits = 0;
  for (int j = 0; j < samples; ++j)
    for (int i = 0; i < samples; ++i)
      hits += inside(x + (i + 0.5) / samples, y + (j + 0.5) / samples) ? 1 : 0;
  return static_cast<float>(hits) / (samples * samples);
}

void paint(Image& image, int x, int y, float alpha, float r, float g, float b) {
  if (alpha <= 0.0f) return;
  float* p = image.pixel(x, y);
  if (alpha < p[3]) return; // the most opaque shape wins; shapes here barely overlap
  p[0] = r;
  p[1] = g;
  p[2] = b;
  p[3] = alpha;
}

// Hard-edged frame with a hole, a hard-edged disc (a staircase outline), an anti-aliased disc, an
// anti-aliased hexagon shaded left to right, and a translucent ellipse (a shadow). No solid feature is
// a single pixel thin between transparent pixels: an edge chain runs along the middle of such a
// feature, which has no area to fill.
Image shapes() {
  Image image;
  image.width = kWidth;
  image.height = kHeight;
  image.rgba.assign(static_cast<std::size_t>(kWidth) * kHeight * 4, 0.0f);
  const auto frame = [](double x, double y) {
    const bool outer = x >= 8 && x < 40 && y >= 8 && y < 40;
    const bool hole = x >= 18 && x < 30 && y >= 18 && y < 30;
    return outer && !hole;
  };
  const auto disc = [](double cx, double cy, double r) {
    return [=](double x, double y) { return (x - cx) * (x - cx) + (y - cy) * (y - cy) < r * r; };
  };
  const auto hexagon = [](double x, double y) {
    // Convex, slanted edges: the regular hexagon of radius 20 about (44, 72), turned by 0.3 rad.
    for (int k = 0; k < 6; ++k) {
      const double a0 = 0.3 + k * std::acos(-1.0) / 3.0;
      const double a1 = a0 + std::acos(-1.0) / 3.0;
      const double ax = 44 + 20 * std::cos(a0), ay = 72 + 20 * std::sin(a0);
      const double bx = 44 + 20 * std::cos(a1), by = 72 + 20 * std::sin(a1);
      if ((bx - ax) * (y - ay) - (by - ay) * (x - ax) < 0) return false;
    }
    return true;
  };
  const auto ellipse = [](double x, double y) {
    return (x - 100) * (x - 100) / (20.0 * 20.0) + (y - 62) * (y - 62) / (8.0 * 8.0) < 1.0;
  };
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      paint(image, x, y, coverage(x, y, 1, frame), 0.2f, 0.4f, 0.8f);
      paint(image, x, y, coverage(x, y, 1, disc(62, 22, 13.3)), 0.85f, 0.1f, 0.1f);
      paint(image, x, y, coverage(x, y, 4, disc(100, 26, 16.2)), 0.1f, 0.6f, 0.2f);
      paint(image, x, y, coverage(x, y, 4, hexagon), 0.9f - 0.01f * (x - 24), 0.7f, 0.2f + 0.01f * (x - 24));
      paint(image, x, y, 0.6f * coverage(x, y, 1, ellipse), 0.1f, 0.1f, 0.1f);
    }
  return image;
}

TEST(OutlineCoverage, SolidPixelsAreCoveredAndFarPixelsStayClear) {
  if (run("command -v rsvg-convert").exit_code != 0)
    GTEST_SKIP() << "rsvg-convert is not installed (Debian package librsvg2-bin): the SVG cannot be rendered";
  const Image image = shapes();
  const vectorize::Conversion conversion = vectorize::convert(image);
  ScratchDir dir;
  { std::ofstream(dir / "shapes.svg") << conversion.svg; }
  for (const char* background : {"white", "magenta"}) {
    const std::string command = "rsvg-convert -w " + std::to_string(kWidth) + " -h " +
                                std::to_string(kHeight) + " --background-color " + background + " -o " +
                                shell_quote(dir / (std::string(background) + ".png")) + " " +
                                shell_quote(dir / "shapes.svg");
    const auto result = run(command);
    ASSERT_EQ(result.exit_code, 0) << result.output;
  }
  const Image white = vectorize::load_image(dir / "white.png");
  const Image magenta = vectorize::load_image(dir / "magenta.png");
  ASSERT_EQ(white.width, kWidth);
  ASSERT_EQ(magenta.height, kHeight);

  int solid = 0;
  int uncovered = 0;
  int far = 0;
  int painted_far = 0;
  double squared_error = 0.0;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const float* in = image.pixel(x, y);
      const float* w = white.pixel(x, y);
      const float* m = magenta.pixel(x, y);
      if (in[3] >= 1.0f) {
        ++solid;
        bool differs = false;
        for (int c = 0; c < 3; ++c) differs = differs || w[c] != m[c];
        if (differs) {
          ++uncovered;
          ADD_FAILURE() << "solid pixel " << x << "," << y << " lets the background through";
        }
      }
      // Transparent pixels two or more pixels from any shape pixel: nothing may be painted there.
      bool near_shape = false;
      for (int dy = -2; dy <= 2 && !near_shape; ++dy)
        for (int dx = -2; dx <= 2 && !near_shape; ++dx) {
          const int nx = std::clamp(x + dx, 0, kWidth - 1);
          const int ny = std::clamp(y + dy, 0, kHeight - 1);
          near_shape = image.pixel(nx, ny)[3] > 0.0f;
        }
      if (!near_shape) {
        ++far;
        if (w[0] != 1.0f || w[1] != 1.0f || w[2] != 1.0f) ++painted_far;
      }
      for (int c = 0; c < 3; ++c) {
        const double expected = in[c] * in[3] + (1.0 - in[3]);
        squared_error += (w[c] - expected) * (w[c] - expected);
      }
    }
  ASSERT_GT(solid, 2000);
  ASSERT_GT(far, 2000);
  EXPECT_EQ(uncovered, 0);
  EXPECT_EQ(painted_far, 0);
  // Over white, the render stays close to the input composited over white (measured 26.2 dB: the
  // threshold guards against a coverage fix that paints whole rims or clear areas).
  const double psnr = 10.0 * std::log10(1.0 / (squared_error / (3.0 * kWidth * kHeight)));
  std::printf("PSNR over white: %.2f dB\n", psnr);
  EXPECT_GT(psnr, 24.0);
}

} // namespace
