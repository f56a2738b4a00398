// PointPlacement: outline points on the shape's edge, inside their own pixel, never shared.
#include "vectorize/placement.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <utility>

namespace {

using vectorize::Image;
using vectorize::PixelPoint;
using vectorize::PointPlacement;
using vectorize::Position;

Image blank(int width, int height) {
  Image image;
  image.width = width;
  image.height = height;
  image.rgba.assign(static_cast<std::size_t>(width) * height * 4, 0.0f);
  return image;
}

void set_alpha(Image& image, int x, int y, float alpha) { image.pixel(x, y)[3] = alpha; }

// A solid rectangle [x0, x1) x [y0, y1) on a transparent 12 x 10 image.
Image rectangle(int x0, int y0, int x1, int y1) {
  Image image = blank(12, 10);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) set_alpha(image, x, y, 1.0f);
  return image;
}

TEST(PointPlacement, WithoutImageEveryPointIsThePixelCentre) {
  const PointPlacement placement;
  EXPECT_EQ(placement.position({3, 4}), (Position{3.5, 4.5}));
  EXPECT_FALSE(placement.solid({3, 4}));
}

TEST(PointPlacement, OpaqueImageKeepsCentres) {
  Image image = blank(5, 5);
  for (std::size_t i = 3; i < image.rgba.size(); i += 4) image.rgba[i] = 1.0f;
  const PointPlacement placement(image);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) EXPECT_EQ(placement.position({x, y}), (Position{x + 0.5, y + 0.5}));
}

// An alpha that is not a number counts as no shape (it is not >= 1/2), as an alpha below 1/2 does:
// the pixels beside it are on an outline even when every other pixel is opaque.
TEST(PointPlacement, NotANumberAlphaIsNoShape) {
  Image image = blank(5, 5);
  for (std::size_t i = 3; i < image.rgba.size(); i += 4) image.rgba[i] = 1.0f;
  set_alpha(image, 2, 2, std::nanf(""));
  const PointPlacement placement(image);
  EXPECT_TRUE(placement.place({1, 2}).outline);
  EXPECT_NE(placement.position({1, 2}), (Position{1.5, 2.5}));
  EXPECT_FALSE(placement.place({0, 0}).outline);
}

// A hard edge: the outline pixel's point lies on the boundary it shares with the transparent
// neighbour, so the polygon covers the whole pixel; a corner pixel's point is its outer corner.
TEST(PointPlacement, HardEdgeLandsOnThePixelBoundary) {
  const Image image = rectangle(3, 2, 8, 7);
  const PointPlacement placement(image);
  EXPECT_EQ(placement.position({3, 4}), (Position{3.0, 4.5})); // left side
  EXPECT_EQ(placement.position({7, 4}), (Position{8.0, 4.5})); // right side
  EXPECT_EQ(placement.position({5, 2}), (Position{5.5, 2.0})); // top
  EXPECT_EQ(placement.position({5, 6}), (Position{5.5, 7.0})); // bottom
  EXPECT_EQ(placement.position({3, 2}), (Position{3.0, 2.0})); // top-left corner
  EXPECT_EQ(placement.position({5, 4}), (Position{5.5, 4.5})); // inside: not an outline
  EXPECT_EQ(placement.position({1, 1}), (Position{1.5, 1.5})); // no shape
  EXPECT_TRUE(placement.solid({5, 4}));
  EXPECT_FALSE(placement.solid({1, 1}));
  EXPECT_FALSE(placement.solid({-1, 4}));
}

// The image border is no outline: a shape touching it keeps its points there at the centres.
TEST(PointPlacement, ImageBorderIsNotAnOutline) {
  const Image image = rectangle(0, 0, 4, 10);
  const PointPlacement placement(image);
  EXPECT_EQ(placement.position({0, 5}), (Position{0.5, 5.5}));
  EXPECT_EQ(placement.position({3, 5}), (Position{4.0, 5.5}));
}

// An anti-aliased edge: the point goes to where alpha, interpolated between the two centres,
// crosses one half.
TEST(PointPlacement, SoftEdgeLandsOnTheHalfAlphaCrossing) {
  Image image = blank(6, 3);
  for (int y = 0; y < 3; ++y) {
    set_alpha(image, 0, y, 1.0f);
    set_alpha(image, 1, y, 1.0f);
    set_alpha(image, 2, y, 0.8f);
    set_alpha(image, 3, y, 0.2f);
  }
  const PointPlacement placement(image);
  const Position p = placement.position({2, 1});
  EXPECT_NEAR(p.x, 2.5 + 0.3 / 0.6, 1e-12);
  EXPECT_EQ(p.y, 1.5);
}

// A shape pixel that touches the transparent area only at a corner moves towards that corner, so
// that a chain through it does not leave half of it uncovered.
TEST(PointPlacement, DiagonalContactMovesAlongTheDiagonal) {
  Image image = rectangle(2, 2, 6, 6);
  set_alpha(image, 2, 2, 0.0f); // notch the top-left corner
  const PointPlacement placement(image);
  EXPECT_EQ(placement.position({3, 3}), (Position{3.0, 3.0}));
}

// Two solid blocks touching at a corner: the pixels on either side would both move into it; they
// keep distinct points, each just short of the corner.
TEST(PointPlacement, PixelsTouchingAtACornerKeepDistinctPoints) {
  Image image = blank(8, 8);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 3; ++x) {
      set_alpha(image, x + 1, y + 1, 1.0f);
      set_alpha(image, x + 4, y + 4, 1.0f);
    }
  const PointPlacement placement(image);
  const Position a = placement.position({3, 3});
  const Position b = placement.position({4, 4});
  EXPECT_NE(a, b);
  EXPECT_NEAR(a.x, 3.95, 1e-12);
  EXPECT_NEAR(a.y, 3.95, 1e-12);
  EXPECT_NEAR(b.x, 4.05, 1e-12);
  EXPECT_NEAR(b.y, 4.05, 1e-12);
}

std::string alpha_around(const Image& image, int cx, int cy) {
  std::ostringstream out;
  for (int y = cy - 2; y <= cy + 2; ++y) {
    for (int x = cx - 2; x <= cx + 2; ++x)
      out << (x < 0 || y < 0 || x >= image.width || y >= image.height ? -1.0f : image.pixel(x, y)[3]) << ' ';
    out << '\n';
  }
  return out.str();
}

// On random alpha fields: every point lies in its own pixel's closed square and no two pixels share
// a point, so placement never merges PSLG vertices.
TEST(PointPlacement, PointsStayInTheirPixelAndAreDistinct) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> level(0, 4);
  for (int round = 0; round < 300; ++round) {
    Image image = blank(16, 16);
    for (std::size_t i = 3; i < image.rgba.size(); i += 4)
      image.rgba[i] = static_cast<float>(level(rng)) / 4.0f;
    const PointPlacement placement(image);
    std::map<std::pair<double, double>, std::pair<int, int>> seen;
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 16; ++x) {
        const Position p = placement.position({x, y});
        ASSERT_GE(p.x, x);
        ASSERT_LE(p.x, x + 1.0);
        ASSERT_GE(p.y, y);
        ASSERT_LE(p.y, y + 1.0);
        const auto [at, fresh] = seen.insert({{p.x, p.y}, {x, y}});
        ASSERT_TRUE(fresh) << "pixels " << x << "," << y << " and " << at->second.first << ","
                           << at->second.second << " share a point; round " << round << ", alpha around:\n"
                           << alpha_around(image, x, y);
      }
  }
}

} // namespace
