#include "vectorize/overlay.hpp"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "../test_util.hpp"
#include "vectorize/errors.hpp"

namespace {

vectorize::Image flat_image(int width, int height, float grey) {
  vectorize::Image image;
  image.width = width;
  image.height = height;
  image.rgba.assign(static_cast<std::size_t>(width) * height * 4, grey);
  for (std::size_t i = 3; i < image.rgba.size(); i += 4) image.rgba[i] = 1.0f;
  return image;
}

TEST(Overlay, PngHasImageSizeAndShowsTheStroke) {
  trixel_test::ScratchDir dir;
  const auto input = flat_image(40, 30, 1.0f);
  vectorize::OverlayCanvas canvas(input, 0.5);
  const float line[] = {5.5f, 15.5f, 35.5f, 15.5f};
  const float red[] = {1, 0, 0, 1};
  canvas.polyline(line, 2, false, red, 3.0);
  canvas.save(dir / "o.png");

  const auto back = vectorize::load_image(dir / "o.png");
  ASSERT_EQ(back.width, 40);
  ASSERT_EQ(back.height, 30);
  // Away from the stroke: the white input dimmed by half. On the stroke: red.
  EXPECT_NEAR(back.pixel(20, 3)[0], 0.5f, 0.01f);
  EXPECT_NEAR(back.pixel(20, 3)[1], 0.5f, 0.01f);
  EXPECT_NEAR(back.pixel(20, 15)[0], 1.0f, 0.01f);
  EXPECT_NEAR(back.pixel(20, 15)[1], 0.0f, 0.01f);
  EXPECT_FALSE(std::filesystem::exists(dir / "o.png.tmp"));
}

TEST(Overlay, WritesSvgAndPdf) {
  trixel_test::ScratchDir dir;
  vectorize::OverlayCanvas canvas(flat_image(10, 10, 0.2f));
  canvas.save(dir / "o.svg", vectorize::OverlayFormat::svg);
  canvas.save(dir / "o.pdf", vectorize::OverlayFormat::pdf);
  std::ifstream svg(dir / "o.svg");
  const std::string text((std::istreambuf_iterator<char>(svg)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("<svg"), std::string::npos);
  std::ifstream pdf(dir / "o.pdf");
  std::string magic(4, '\0');
  pdf.read(magic.data(), 4);
  EXPECT_EQ(magic, "%PDF");
}

// A failed save must name the file and leave nothing behind.
TEST(Overlay, SaveIntoMissingDirectoryFailsCleanly) {
  trixel_test::ScratchDir dir;
  vectorize::OverlayCanvas canvas(flat_image(4, 4, 0.5f));
  EXPECT_THROW(canvas.save(dir / "missing" / "o.png"), vectorize::FileError);
  EXPECT_FALSE(std::filesystem::exists(dir / "missing"));
}

// Stacked in the inspector page: away from the drawing a layer must be fully transparent.
TEST(Overlay, LayerWithoutBackgroundIsTransparentAwayFromTheDrawing) {
  trixel_test::ScratchDir dir;
  vectorize::OverlayCanvas canvas(flat_image(20, 20, 1.0f));
  const float square[] = {2, 2, 8, 2, 8, 8, 2, 8};
  const float blue[] = {0, 0, 1, 1};
  canvas.fill_polygon(square, 4, blue);
  canvas.save(dir / "layer.png", vectorize::OverlayFormat::png, vectorize::OverlayBackground::none);
  const auto back = vectorize::load_image(dir / "layer.png");
  EXPECT_NEAR(back.pixel(5, 5)[2], 1.0f, 0.01f);
  EXPECT_NEAR(back.pixel(5, 5)[3], 1.0f, 0.01f);
  EXPECT_NEAR(back.pixel(15, 15)[3], 0.0f, 0.01f);
}

TEST(Overlay, PixelsSegmentsAndDotsLandWhereGiven) {
  trixel_test::ScratchDir dir;
  const int w = 30, h = 20;
  vectorize::OverlayCanvas canvas(flat_image(w, h, 0.0f), 0.0);
  std::vector<std::uint8_t> mask(static_cast<std::size_t>(w) * h, 0);
  mask[3 * w + 4] = 1; // pixel (4, 3)
  const float green[] = {0, 1, 0, 1};
  canvas.pixels(mask.data(), green);
  const float segments[] = {0, 10.5f, 30, 10.5f, 20.5f, 0, 20.5f, 20};
  const float red[] = {1, 0, 0, 1};
  canvas.segments(segments, 2, red, 1.0);
  const float dot[] = {5.0f, 16.0f};
  const float white[] = {1, 1, 1, 1};
  canvas.dots(dot, 1, 2.5, white);
  canvas.save(dir / "o.png");
  const auto back = vectorize::load_image(dir / "o.png");
  // The mask paints whole pixels and nothing around them.
  EXPECT_NEAR(back.pixel(4, 3)[1], 1.0f, 0.01f);
  EXPECT_NEAR(back.pixel(5, 3)[1], 0.0f, 0.01f);
  EXPECT_NEAR(back.pixel(4, 4)[1], 0.0f, 0.01f);
  EXPECT_NEAR(back.pixel(2, 10)[0], 1.0f, 0.01f);  // on the horizontal segment
  EXPECT_NEAR(back.pixel(20, 17)[0], 1.0f, 0.01f); // on the vertical one
  EXPECT_NEAR(back.pixel(10, 5)[0], 0.0f, 0.01f);  // on neither
  EXPECT_GT(back.pixel(4, 15)[1], 0.9f);           // inside the dot
}

TEST(Overlay, ParsesFormatNames) {
  EXPECT_EQ(vectorize::parse_overlay_format("svg"), vectorize::OverlayFormat::svg);
  EXPECT_STREQ(vectorize::overlay_extension(vectorize::OverlayFormat::pdf), "pdf");
  EXPECT_THROW(vectorize::parse_overlay_format("jpeg"), std::invalid_argument);
}

// The inspector's base layer when the input's format is not one a browser shows.
TEST(Overlay, SaveImagePngKeepsColourAndAlpha) {
  trixel_test::ScratchDir dir;
  auto image = flat_image(6, 4, 0.25f);
  image.pixel(1, 2)[3] = 0.0f;
  image.pixel(3, 1)[0] = 1.0f;
  vectorize::save_image_png(image, dir / "i.png");
  const auto back = vectorize::load_image(dir / "i.png");
  ASSERT_EQ(back.width, 6);
  ASSERT_EQ(back.height, 4);
  EXPECT_NEAR(back.pixel(0, 0)[0], 0.25f, 0.01f);
  EXPECT_NEAR(back.pixel(3, 1)[0], 1.0f, 0.01f);
  EXPECT_NEAR(back.pixel(1, 2)[3], 0.0f, 0.01f);
  EXPECT_NEAR(back.pixel(2, 2)[3], 1.0f, 0.01f);
}

} // namespace
