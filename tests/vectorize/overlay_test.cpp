#include "vectorize/overlay.hpp"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <fstream>
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

} // namespace
