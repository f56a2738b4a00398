// The libpng reader (load_image() reads every PNG with it): every PNG layout, the same pixels as the
// OpenImageIO reader module, and clear errors.

#include <OpenImageIO/imageio.h>
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "../../vectorize/src/oiio_module.hpp"
#include "../test_util.hpp"
#include "vectorize/errors.hpp"
#include "vectorize/image.hpp"

namespace {

using trixel_test::ScratchDir;
namespace fs = std::filesystem;

const fs::path kSamples = fs::path(TRIXEL_SOURCE_DIR) / "samples";

std::uint32_t crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc = 0) {
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

void put32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<std::uint8_t>(v >> shift));
}

void chunk(std::vector<std::uint8_t>& out, const char* type, const std::vector<std::uint8_t>& body) {
  put32(out, static_cast<std::uint32_t>(body.size()));
  const std::size_t start = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), body.begin(), body.end());
  put32(out, crc32(out.data() + start, out.size() - start));
}

// A PNG written by hand (uncompressed deflate blocks), so the tests can make layouts that the
// OpenImageIO writer does not produce: palettes, 1-bit grey, transparency chunks. `rows` holds the
// packed scanlines without their filter bytes.
std::vector<std::uint8_t> make_png(int width, int height, int bit_depth, int colour_type,
                                   const std::vector<std::uint8_t>& rows,
                                   const std::vector<std::uint8_t>& palette = {},
                                   const std::vector<std::uint8_t>& trns = {}) {
  std::vector<std::uint8_t> out = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::vector<std::uint8_t> ihdr;
  put32(ihdr, static_cast<std::uint32_t>(width));
  put32(ihdr, static_cast<std::uint32_t>(height));
  ihdr.insert(ihdr.end(),
              {static_cast<std::uint8_t>(bit_depth), static_cast<std::uint8_t>(colour_type), 0, 0, 0});
  chunk(out, "IHDR", ihdr);
  if (!palette.empty()) chunk(out, "PLTE", palette);
  if (!trns.empty()) chunk(out, "tRNS", trns);
  const std::size_t row_bytes = rows.size() / static_cast<std::size_t>(height);
  std::vector<std::uint8_t> raw;
  for (int y = 0; y < height; ++y) {
    raw.push_back(0); // filter: none
    raw.insert(raw.end(), rows.begin() + static_cast<std::ptrdiff_t>(y * row_bytes),
               rows.begin() + static_cast<std::ptrdiff_t>((y + 1) * row_bytes));
  }
  std::vector<std::uint8_t> z = {0x78, 0x01, 1}; // zlib header; one final stored block
  const auto len = static_cast<std::uint16_t>(raw.size());
  z.insert(z.end(), {static_cast<std::uint8_t>(len), static_cast<std::uint8_t>(len >> 8),
                     static_cast<std::uint8_t>(~len), static_cast<std::uint8_t>(~len >> 8)});
  z.insert(z.end(), raw.begin(), raw.end());
  std::uint32_t a = 1, b = 0; // Adler-32
  for (auto byte : raw) {
    a = (a + byte) % 65521;
    b = (b + a) % 65521;
  }
  put32(z, (b << 16) | a);
  chunk(out, "IDAT", z);
  chunk(out, "IEND", {});
  return out;
}

void write_bytes(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

std::string error_of(const fs::path& path, std::size_t max_pixels = std::size_t{1} << 28) {
  try {
    vectorize::load_png(path, max_pixels);
  } catch (const vectorize::FileError& e) {
    return e.what();
  }
  return "";
}

TEST(PngReader, PaletteWithTransparencyBecomesRgba) {
  ScratchDir dir;
  // 2-bit palette, 4 x 1: indices 0 1 2 3; entry 1 half transparent, entry 2 fully transparent.
  const std::vector<std::uint8_t> palette = {255, 0, 0, 0, 255, 0, 0, 0, 255, 10, 20, 30};
  write_bytes(dir / "p.png", make_png(4, 1, 2, 3, {0b00011011}, palette, {255, 128, 0}));
  const auto image = vectorize::load_png(dir / "p.png");
  ASSERT_EQ(image.width, 4);
  ASSERT_EQ(image.height, 1);
  EXPECT_EQ(image.source_channels, 4);
  EXPECT_EQ(image.pixel(0, 0)[0], 1.0f);
  EXPECT_EQ(image.pixel(0, 0)[3], 1.0f);
  EXPECT_EQ(image.pixel(1, 0)[1], 1.0f);
  EXPECT_FLOAT_EQ(image.pixel(1, 0)[3], 128 / 255.0f);
  EXPECT_EQ(image.pixel(2, 0)[3], 0.0f);
  EXPECT_FLOAT_EQ(image.pixel(3, 0)[0], 10 / 255.0f);
  EXPECT_FLOAT_EQ(image.pixel(3, 0)[2], 30 / 255.0f);
  EXPECT_EQ(image.pixel(3, 0)[3], 1.0f); // beyond the tRNS entries: opaque
}

TEST(PngReader, OneBitGreyExpandsToBlackAndWhite) {
  ScratchDir dir;
  write_bytes(dir / "g.png", make_png(8, 2, 1, 0, {0b10100000, 0b01010000}));
  const auto image = vectorize::load_png(dir / "g.png");
  EXPECT_EQ(image.source_channels, 1);
  EXPECT_EQ(image.pixel(0, 0)[0], 1.0f);
  EXPECT_EQ(image.pixel(1, 0)[1], 0.0f);
  EXPECT_EQ(image.pixel(2, 0)[2], 1.0f);
  EXPECT_EQ(image.pixel(1, 1)[0], 1.0f);
  EXPECT_EQ(image.pixel(7, 1)[0], 0.0f);
  EXPECT_EQ(image.pixel(7, 1)[3], 1.0f);
}

TEST(PngReader, SixteenBitGreyAlphaKeepsItsPrecision) {
  ScratchDir dir;
  // 2 x 1, grey+alpha, 16 bits: (0x1234, 0xFFFF), (0xFFFF, 0x0101)
  write_bytes(dir / "ga.png", make_png(2, 1, 16, 4, {0x12, 0x34, 0xFF, 0xFF, 0xFF, 0xFF, 0x01, 0x01}));
  const auto image = vectorize::load_png(dir / "ga.png");
  EXPECT_EQ(image.source_channels, 2);
  EXPECT_FLOAT_EQ(image.pixel(0, 0)[0], 0x1234 / 65535.0f);
  EXPECT_EQ(image.pixel(0, 0)[3], 1.0f);
  EXPECT_FLOAT_EQ(image.pixel(1, 0)[3], 0x0101 / 65535.0f);
}

// The OpenImageIO reader module, as load_image() uses it for formats other than PNG.
vectorize::Image load_with_openimageio(const fs::path& path) {
  static const auto load = [] {
    const auto module = fs::path(TRIXEL_BINARY_DIR) / "bin" / vectorize::detail::kOiioModuleFile;
    void* handle = dlopen(module.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) throw std::runtime_error(dlerror());
    return reinterpret_cast<vectorize::detail::OiioLoadFunction>(
        dlsym(handle, vectorize::detail::kOiioLoadSymbol));
  }();
  vectorize::Image image;
  char reason[256] = {};
  if (!load || !load(path.c_str(), std::size_t{1} << 28, &image, reason, sizeof reason))
    throw std::runtime_error(path.string() + ": " + reason);
  return image;
}

// The two readers must agree to the bit, so that a PNG converts exactly as it would through
// OpenImageIO.
void expect_same_as_openimageio(const fs::path& path) {
  const auto a = vectorize::load_png(path);
  const auto b = load_with_openimageio(path);
  ASSERT_EQ(a.width, b.width) << path;
  ASSERT_EQ(a.height, b.height) << path;
  EXPECT_EQ(a.source_channels, b.source_channels) << path;
  std::size_t differing = 0;
  for (std::size_t i = 0; i < a.rgba.size(); ++i) differing += a.rgba[i] != b.rgba[i];
  EXPECT_EQ(differing, 0u) << path;
}

TEST(PngReader, SamplesReadExactlyAsWithOpenImageIO) {
  for (const char* name : {"logo.png", "strokes.png", "gradient.png", "photo.png"})
    expect_same_as_openimageio(kSamples / name);
}

TEST(PngReader, SixteenBitRgbaReadsAsWithOpenImageIO) {
  ScratchDir dir;
  const int w = 7, h = 5, channels = 4;
  std::vector<std::uint16_t> data(static_cast<std::size_t>(w) * h * channels);
  for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<std::uint16_t>(i * 1031 % 65536);
  auto out = OIIO::ImageOutput::create((dir / "c.png").string());
  ASSERT_TRUE(out);
  OIIO::ImageSpec spec(w, h, channels, OIIO::TypeDesc::UINT16);
  spec.attribute("oiio:UnassociatedAlpha", 1);
  ASSERT_TRUE(out->open((dir / "c.png").string(), spec));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT16, data.data()));
  out->close();
  expect_same_as_openimageio(dir / "c.png");
}

TEST(PngReader, ErrorsNameTheFileAndTheReason) {
  ScratchDir dir;
  const auto good = make_png(8, 2, 1, 0, {0xA0, 0x50});

  write_bytes(dir / "text.png", {'h', 'e', 'l', 'l', 'o', '\n', 0, 0, 0});
  EXPECT_NE(error_of(dir / "text.png").find("not a PNG file"), std::string::npos);
  EXPECT_NE(error_of(dir / "text.png").find("text.png"), std::string::npos);

  write_bytes(dir / "cut.png", std::vector<std::uint8_t>(good.begin(), good.begin() + 45));
  EXPECT_NE(error_of(dir / "cut.png").find("cut.png: "), std::string::npos);
  EXPECT_FALSE(error_of(dir / "cut.png").empty());

  auto bad_crc = good;
  bad_crc[50] ^= 0xFF; // inside the IDAT data: its checksum no longer matches
  write_bytes(dir / "crc.png", bad_crc);
  EXPECT_NE(error_of(dir / "crc.png").find("corrupt or truncated"), std::string::npos)
      << error_of(dir / "crc.png");

  write_bytes(dir / "big.png", good);
  EXPECT_NE(error_of(dir / "big.png", 15).find("more than the limit of 15"), std::string::npos);

  EXPECT_NE(error_of(dir / "missing.png").find("missing.png: cannot open"), std::string::npos);
}

} // namespace
