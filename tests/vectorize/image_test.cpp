#include "vectorize/image.hpp"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <vector>

#include "../test_util.hpp"
#include "vectorize/errors.hpp"

namespace {

using trixel_test::ScratchDir;

// Writes a width x height image whose channel c of pixel (x, y) is pattern(x, y, c), in any format.
template <class T>
void write_image(const std::filesystem::path& path, int width, int height, int channels, OIIO::TypeDesc type,
                 T (*pattern)(int, int, int)) {
  std::vector<T> data(static_cast<std::size_t>(width) * height * channels);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < channels; ++c)
        data[(static_cast<std::size_t>(y) * width + x) * channels + c] = pattern(x, y, c);
  auto out = OIIO::ImageOutput::create(path.string());
  ASSERT_TRUE(out) << OIIO::geterror();
  OIIO::ImageSpec spec(width, height, channels, type);
  spec.attribute("oiio:UnassociatedAlpha", 1); // store the values as given, without un-premultiplying
  ASSERT_TRUE(out->open(path.string(), spec));
  ASSERT_TRUE(out->write_image(type, data.data()));
  out->close();
}

std::uint8_t rgb8(int x, int y, int c) {
  return static_cast<std::uint8_t>(c == 0 ? x * 10 : c == 1 ? y * 20 : 200);
}
std::uint16_t grey16(int x, int, int) { return static_cast<std::uint16_t>(x * 4096); }
std::uint8_t rgba8(int x, int, int c) { return static_cast<std::uint8_t>(c == 3 ? (x < 2 ? 0 : 255) : 128); }
std::uint8_t half_alpha8(int, int, int c) { return static_cast<std::uint8_t>(c == 3 ? 128 : 200); }
std::uint8_t grey_alpha8(int x, int, int c) {
  return static_cast<std::uint8_t>(c == 0 ? 51 : (x == 0 ? 0 : 255));
}

TEST(LoadImage, ReadsEightBitRgb) {
  ScratchDir dir;
  write_image(dir / "a.png", 5, 3, 3, OIIO::TypeDesc::UINT8, rgb8);
  const auto image = vectorize::load_image(dir / "a.png");
  ASSERT_EQ(image.width, 5);
  ASSERT_EQ(image.height, 3);
  EXPECT_EQ(image.source_channels, 3);
  EXPECT_NEAR(image.pixel(2, 1)[0], 20 / 255.0f, 1e-6);
  EXPECT_NEAR(image.pixel(2, 1)[1], 20 / 255.0f, 1e-6);
  EXPECT_NEAR(image.pixel(2, 1)[2], 200 / 255.0f, 1e-6);
  EXPECT_EQ(image.pixel(4, 2)[3], 1.0f); // no alpha in the file: opaque
  EXPECT_TRUE(image.known_opaque);
}

TEST(LoadImage, ReadsSixteenBitGreyAsRgb) {
  ScratchDir dir;
  write_image(dir / "g.png", 4, 2, 1, OIIO::TypeDesc::UINT16, grey16);
  const auto image = vectorize::load_image(dir / "g.png");
  const float* p = image.pixel(3, 1);
  EXPECT_NEAR(p[0], 3 * 4096 / 65535.0f, 1e-6);
  EXPECT_EQ(p[0], p[1]);
  EXPECT_EQ(p[1], p[2]);
  EXPECT_EQ(p[3], 1.0f);
}

TEST(LoadImage, KeepsAlphaOfRgbaAndGreyAlpha) {
  ScratchDir dir;
  write_image(dir / "rgba.png", 4, 1, 4, OIIO::TypeDesc::UINT8, rgba8);
  write_image(dir / "ga.png", 3, 1, 2, OIIO::TypeDesc::UINT8, grey_alpha8);
  const auto rgba = vectorize::load_image(dir / "rgba.png");
  EXPECT_EQ(rgba.pixel(0, 0)[3], 0.0f);
  EXPECT_EQ(rgba.pixel(3, 0)[3], 1.0f);
  const auto ga = vectorize::load_image(dir / "ga.png");
  EXPECT_EQ(ga.pixel(0, 0)[3], 0.0f);
  EXPECT_NEAR(ga.pixel(1, 0)[0], 0.2f, 1e-6);
  EXPECT_EQ(ga.pixel(1, 0)[3], 1.0f);
}

// Edge pixels of logos are partly transparent; their colour must not be darkened by premultiplication.
TEST(LoadImage, ColourUnderPartialAlphaIsUnassociated) {
  ScratchDir dir;
  write_image(dir / "half.png", 2, 2, 4, OIIO::TypeDesc::UINT8, half_alpha8);
  const auto image = vectorize::load_image(dir / "half.png");
  EXPECT_NEAR(image.pixel(1, 1)[0], 200 / 255.0f, 1e-6);
  EXPECT_NEAR(image.pixel(1, 1)[3], 128 / 255.0f, 1e-6);
  EXPECT_FALSE(image.known_opaque);
}

TEST(LoadImage, ReadsJpegAndTiff) {
  ScratchDir dir;
  write_image(dir / "a.jpg", 8, 8, 3, OIIO::TypeDesc::UINT8, rgb8);
  write_image(dir / "a.tif", 8, 8, 3, OIIO::TypeDesc::UINT8, rgb8);
  EXPECT_EQ(vectorize::load_image(dir / "a.jpg").width, 8);
  EXPECT_EQ(vectorize::load_image(dir / "a.tif").height, 8);
}

// Each bad input must produce an error that names the file and gives a reason, never a crash.
void expect_file_error(const std::filesystem::path& path, const std::string& reason_part) {
  try {
    vectorize::load_image(path);
    FAIL() << "no error for " << path;
  } catch (const vectorize::FileError& e) {
    EXPECT_EQ(e.path(), path);
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(reason_part), std::string::npos) << e.what();
  }
}

TEST(LoadImage, ReportsMissingFile) {
  ScratchDir dir;
  expect_file_error(dir / "nope.png", "no such file");
}

TEST(LoadImage, ReportsDirectory) {
  ScratchDir dir;
  expect_file_error(dir.path(), "directory");
}

TEST(LoadImage, ReportsEmptyFile) {
  ScratchDir dir;
  std::ofstream(dir / "empty.png").close();
  expect_file_error(dir / "empty.png", "empty");
}

TEST(LoadImage, ReportsNonImage) {
  ScratchDir dir;
  std::ofstream(dir / "notes.png") << "this is plain text, not a PNG\n";
  expect_file_error(dir / "notes.png", "cannot decode");
}

TEST(LoadImage, ReportsTruncatedPng) {
  ScratchDir dir;
  write_image(dir / "full.png", 64, 64, 3, OIIO::TypeDesc::UINT8, rgb8);
  const auto size = std::filesystem::file_size(dir / "full.png");
  std::filesystem::copy_file(dir / "full.png", dir / "cut.png");
  std::filesystem::resize_file(dir / "cut.png", size / 2);
  expect_file_error(dir / "cut.png", "");
  // The reason must say something about the data, whichever step OpenImageIO fails at.
  try {
    vectorize::load_image(dir / "cut.png");
  } catch (const vectorize::FileError& e) {
    const std::string reason = e.reason();
    EXPECT_TRUE(reason.find("corrupt") != std::string::npos ||
                reason.find("cannot decode") != std::string::npos)
        << reason;
  }
}

// A JPEG or TIFF cut short is an error too: their readers filled the missing rows (black, grey) and
// said so only on the side.
TEST(LoadImage, ReportsTruncatedJpegAndTiff) {
  ScratchDir dir;
  for (const char* name : {"full.jpg", "full.tif"}) {
    const std::filesystem::path full = dir / name;
    write_image(full, 64, 64, 3, OIIO::TypeDesc::UINT8, rgb8);
    const std::filesystem::path cut = dir / ("cut" + full.extension().string());
    std::filesystem::copy_file(full, cut);
    std::filesystem::resize_file(cut, std::filesystem::file_size(full) / 2);
    expect_file_error(cut, "corrupt or truncated");
  }
}

TEST(LoadImage, RefusesImagesOverThePixelLimit) {
  ScratchDir dir;
  write_image(dir / "big.png", 20, 10, 3, OIIO::TypeDesc::UINT8, rgb8);
  try {
    vectorize::load_image(dir / "big.png", 199);
    FAIL();
  } catch (const vectorize::FileError& e) {
    EXPECT_NE(e.reason().find("20 x 10"), std::string::npos) << e.what();
  }
}

} // namespace
