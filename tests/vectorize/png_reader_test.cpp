// The libpng reader (load_image() reads every PNG with it): every PNG layout, the same pixels as the
// OpenImageIO reader module, and clear errors.

#include <OpenImageIO/imageio.h>
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "../../vectorize/src/oiio_module.hpp"
#include "../../vectorize/src/png_direct.hpp"
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

// A zlib stream of `raw` in stored (uncompressed) deflate blocks.
std::vector<std::uint8_t> zlib_stored(const std::vector<std::uint8_t>& raw,
                                      std::array<std::uint8_t, 2> header = {0x78, 0x01}) {
  std::vector<std::uint8_t> z(header.begin(), header.end()); // zlib header: a 32 KiB window
  std::size_t at = 0;
  do {
    const std::size_t n = std::min<std::size_t>(raw.size() - at, 65535);
    const auto len = static_cast<std::uint16_t>(n);
    z.push_back(at + n == raw.size() ? 1 : 0); // final block or not, stored
    z.insert(z.end(), {static_cast<std::uint8_t>(len), static_cast<std::uint8_t>(len >> 8),
                       static_cast<std::uint8_t>(~len), static_cast<std::uint8_t>(~len >> 8)});
    z.insert(z.end(), raw.begin() + static_cast<std::ptrdiff_t>(at),
             raw.begin() + static_cast<std::ptrdiff_t>(at + n));
    at += n;
  } while (at < raw.size());
  std::uint32_t a = 1, b = 0; // Adler-32
  for (auto byte : raw) {
    a = (a + byte) % 65521;
    b = (b + a) % 65521;
  }
  put32(z, (b << 16) | a);
  return z;
}

struct PngLayout {
  int width = 1;
  int height = 1;
  int bit_depth = 8;
  int colour_type = 0;
  int interlace = 0;
  std::vector<std::uint8_t> palette;
  std::vector<std::uint8_t> trns;
  std::size_t idat_piece = 0; // the zlib stream split into IDAT chunks of this size; 0: one chunk
  std::array<std::uint8_t, 2> zlib_header = {0x78, 0x01};
};

// A PNG written by hand, so the tests can make layouts and damage that the OpenImageIO writer does
// not produce. `raw` holds the scanlines with their filter bytes.
std::vector<std::uint8_t> assemble_png(const PngLayout& layout, const std::vector<std::uint8_t>& raw) {
  std::vector<std::uint8_t> out = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::vector<std::uint8_t> ihdr;
  put32(ihdr, static_cast<std::uint32_t>(layout.width));
  put32(ihdr, static_cast<std::uint32_t>(layout.height));
  ihdr.insert(ihdr.end(),
              {static_cast<std::uint8_t>(layout.bit_depth), static_cast<std::uint8_t>(layout.colour_type), 0,
               0, static_cast<std::uint8_t>(layout.interlace)});
  chunk(out, "IHDR", ihdr);
  if (!layout.palette.empty()) chunk(out, "PLTE", layout.palette);
  if (!layout.trns.empty()) chunk(out, "tRNS", layout.trns);
  const auto z = zlib_stored(raw, layout.zlib_header);
  const std::size_t piece = layout.idat_piece ? layout.idat_piece : z.size();
  for (std::size_t at = 0; at < z.size(); at += piece) {
    chunk(out, "IDAT",
          std::vector<std::uint8_t>(z.begin() + static_cast<std::ptrdiff_t>(at),
                                    z.begin() + static_cast<std::ptrdiff_t>(std::min(z.size(), at + piece))));
  }
  chunk(out, "IEND", {});
  return out;
}

// The rows (packed scanlines without filter bytes) each with filter type 0.
std::vector<std::uint8_t> unfiltered(const std::vector<std::uint8_t>& rows, int height) {
  const std::size_t row_bytes = rows.size() / static_cast<std::size_t>(height);
  std::vector<std::uint8_t> raw;
  for (int y = 0; y < height; ++y) {
    raw.push_back(0);
    raw.insert(raw.end(), rows.begin() + static_cast<std::ptrdiff_t>(y * row_bytes),
               rows.begin() + static_cast<std::ptrdiff_t>((y + 1) * row_bytes));
  }
  return raw;
}

std::vector<std::uint8_t> make_png(int width, int height, int bit_depth, int colour_type,
                                   const std::vector<std::uint8_t>& rows,
                                   const std::vector<std::uint8_t>& palette = {},
                                   const std::vector<std::uint8_t>& trns = {}) {
  PngLayout layout{width, height, bit_depth, colour_type, 0, palette, trns, 0};
  return assemble_png(layout, unfiltered(rows, height));
}

// PNG's filters as an encoder applies them (the specification's section 9, in its own words): each
// byte minus the prediction from the bytes to the left (a), above (b) and above-left (c).
std::vector<std::uint8_t> filtered(const std::vector<std::uint8_t>& rows, int height, int bpp,
                                   const std::vector<int>& types) {
  const std::size_t row_bytes = rows.size() / static_cast<std::size_t>(height);
  std::vector<std::uint8_t> raw;
  for (int y = 0; y < height; ++y) {
    const int type = types[static_cast<std::size_t>(y) % types.size()];
    raw.push_back(static_cast<std::uint8_t>(type));
    const auto at = [&](int row, std::ptrdiff_t i) -> int {
      return row < 0 || i < 0 ? 0
                              : rows[static_cast<std::size_t>(row) * row_bytes + static_cast<std::size_t>(i)];
    };
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(row_bytes); ++i) {
      const int a = at(y, i - bpp), b = at(y - 1, i), c = at(y - 1, i - bpp);
      int prediction = 0;
      if (type == 1) prediction = a;
      if (type == 2) prediction = b;
      if (type == 3) prediction = (a + b) / 2;
      if (type == 4) {
        const int p = a + b - c;
        const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
        prediction = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      }
      raw.push_back(static_cast<std::uint8_t>(at(y, i) - prediction));
    }
  }
  return raw;
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
  EXPECT_FALSE(image.known_opaque);
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
  EXPECT_TRUE(image.known_opaque);
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
  EXPECT_FALSE(image.known_opaque);
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
  EXPECT_EQ(a.known_opaque, b.known_opaque) << path;
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

// A chunk whose length runs past the end of the file is an error at once: libpng allocated (and
// touched) the claimed 2 GiB of a text chunk before finding the file short.
TEST(PngReader, AChunkClaimingMoreThanTheFileHoldsIsAnError) {
  ScratchDir dir;
  const auto good = make_png(8, 2, 1, 0, {0xA0, 0x50});
  std::vector<std::uint8_t> huge(good.begin(), good.begin() + 33); // the signature and IHDR
  put32(huge, 0x7fffffffu);
  huge.insert(huge.end(), {'t', 'E', 'X', 't', 'k', 'e', 'y', 0});
  write_bytes(dir / "huge_text.png", huge);
  const std::string error = error_of(dir / "huge_text.png");
  EXPECT_NE(error.find("huge_text.png: truncated or corrupt: chunk 'tEXt' at byte 33 runs past the end"),
            std::string::npos)
      << error;
}

// libpng refuses sides beyond 10^6 pixels by default; the limit is max_pixels' alone.
TEST(PngReader, ALongImageWithinThePixelLimitIsRead) {
  ScratchDir dir;
  const int length = 1100000;
  std::vector<std::uint8_t> rows;
  for (int y = 0; y < length; ++y) rows.insert(rows.end(), {0, static_cast<std::uint8_t>(y % 2 ? 0x80 : 0)});
  PngLayout tall; // one-bit grey: libpng's to decode
  tall.width = 1;
  tall.height = length;
  tall.bit_depth = 1;
  write_bytes(dir / "tall.png", assemble_png(tall, rows));
  const vectorize::Image image = vectorize::load_png(dir / "tall.png");
  EXPECT_EQ(image.width, 1);
  EXPECT_EQ(image.height, length);
  EXPECT_NE(error_of(dir / "tall.png", length - 1).find("more than the limit"), std::string::npos);
}

// The pixels a decoder must give for packed samples: value / 255 or / 65535, grey replicated, alpha 1
// when the layout has none. Written out here rather than through the readers' shared conversion.
std::vector<float> expected_rgba(const std::vector<std::uint8_t>& rows, int channels, int bit_depth) {
  const std::size_t bytes = static_cast<std::size_t>(bit_depth) / 8;
  const std::size_t pixels = rows.size() / (static_cast<std::size_t>(channels) * bytes);
  std::vector<float> rgba;
  for (std::size_t p = 0; p < pixels; ++p) {
    float sample[4] = {};
    for (int c = 0; c < channels; ++c) {
      const std::uint8_t* v =
          rows.data() + (p * static_cast<std::size_t>(channels) + static_cast<std::size_t>(c)) * bytes;
      sample[c] = bit_depth == 8 ? static_cast<float>(v[0]) * (1.0f / 255.0f)
                                 : static_cast<float>((v[0] << 8) | v[1]) * (1.0f / 65535.0f);
    }
    const bool colour = channels >= 3;
    const bool alpha = channels == 2 || channels == 4;
    rgba.insert(rgba.end(), {sample[0], colour ? sample[1] : sample[0], colour ? sample[2] : sample[0],
                             alpha ? sample[channels - 1] : 1.0f});
  }
  return rgba;
}

vectorize::Image direct_decode(const std::vector<std::uint8_t>& file, std::size_t max_pixels, bool& taken) {
  vectorize::Image image;
  image.width = -7; // a mark: a refused file must leave the image as it was
  taken = vectorize::detail::decode_png_direct(file, max_pixels, image);
  return image;
}

// Every filter type, in every layout the direct decoder takes, split into many IDAT chunks or one:
// the pixels are the samples', and libpng gives the same.
TEST(PngReader, DirectDecoderUndoesEveryFilterAsLibpngDoes) {
  if (!vectorize::detail::png_direct_available())
    GTEST_SKIP() << "built without libdeflate (no direct decoder)";
  ScratchDir dir;
  std::mt19937 random(20261127);
  const std::vector<std::vector<int>> filter_orders = {{0}, {1}, {2}, {3}, {4}, {4, 3, 1, 0, 2, 4, 4, 3}};
  int files = 0;
  for (int bit_depth : {8, 16}) {
    for (int colour_type : {0, 4, 2, 6}) {
      const int channels = colour_type == 0 ? 1 : colour_type == 4 ? 2 : colour_type == 2 ? 3 : 4;
      const int bpp = channels * bit_depth / 8;
      for (const auto& filters : filter_orders) {
        for (std::size_t piece : {std::size_t{0}, std::size_t{7}}) {
          const int width = 29, height = 11;
          std::vector<std::uint8_t> rows(static_cast<std::size_t>(width) * height *
                                         static_cast<std::size_t>(bpp));
          // Smooth ramps with noise, so that the predictions take every branch.
          for (std::size_t i = 0; i < rows.size(); ++i)
            rows[i] = static_cast<std::uint8_t>((i * 3) / 7 + random() % 64 + (random() % 5 == 0 ? 128 : 0));
          PngLayout layout{width, height, bit_depth, colour_type, 0, {}, {}, piece};
          const auto path = (dir / std::to_string(files++)).replace_extension(".png");
          write_bytes(path, assemble_png(layout, filtered(rows, height, bpp, filters)));
          std::ifstream in(path, std::ios::binary);
          const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                                std::istreambuf_iterator<char>());
          bool taken = false;
          const auto direct = direct_decode(bytes, std::size_t{1} << 20, taken);
          ASSERT_TRUE(taken) << path << " depth " << bit_depth << " type " << colour_type;
          const auto libpng = vectorize::detail::load_png_with_libpng(path, std::size_t{1} << 20);
          EXPECT_EQ(direct.width, width);
          EXPECT_EQ(direct.height, height);
          EXPECT_EQ(direct.source_channels, channels);
          EXPECT_EQ(direct.known_opaque, channels == 1 || channels == 3);
          EXPECT_EQ(direct.known_opaque, libpng.known_opaque);
          EXPECT_EQ(direct.rgba, expected_rgba(rows, channels, bit_depth))
              << "depth " << bit_depth << " type " << colour_type << " filter " << filters.front();
          EXPECT_EQ(direct.rgba, libpng.rgba);
          EXPECT_EQ(vectorize::load_png(path).rgba, libpng.rgba);
        }
      }
    }
  }
}

// Every file the direct decoder does not take, or finds wrong, is left untouched to libpng, so the
// layouts read and the errors named stay libpng's.
TEST(PngReader, DirectDecoderLeavesEverythingElseToLibpng) {
  if (!vectorize::detail::png_direct_available())
    GTEST_SKIP() << "built without libdeflate (no direct decoder)";
  ScratchDir dir;
  const std::vector<std::uint8_t> rows = {10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 110, 120}; // 2 x 2 RGB
  const PngLayout rgb{2, 2, 8, 2, 0, {}, {}, 0};
  const auto good = assemble_png(rgb, filtered(rows, 2, 3, {4}));
  bool taken = false;
  direct_decode(good, 100, taken);
  ASSERT_TRUE(taken);

  const auto refused = [&](const std::vector<std::uint8_t>& file, std::size_t max_pixels = 100) {
    bool was_taken = true;
    const auto image = direct_decode(file, max_pixels, was_taken);
    return !was_taken && image.width == -7 && image.rgba.empty();
  };
  EXPECT_TRUE(refused(good, 3)) << "more pixels than the limit";
  EXPECT_TRUE(refused(make_png(4, 1, 2, 3, {0b00011011}, {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12})))
      << "palette";
  EXPECT_TRUE(refused(make_png(2, 1, 8, 2, {1, 2, 3, 4, 5, 6}, {}, {0, 1, 0, 2, 0, 3}))) << "tRNS";
  EXPECT_TRUE(refused(make_png(8, 2, 1, 0, {0xA0, 0x50}))) << "1-bit grey";
  PngLayout interlaced = rgb;
  interlaced.interlace = 1;
  EXPECT_TRUE(refused(assemble_png(interlaced, filtered(rows, 2, 3, {0})))) << "interlaced";
  EXPECT_TRUE(refused(assemble_png(rgb, filtered(rows, 2, 3, {5})))) << "filter type 5";
  auto extra = filtered(rows, 2, 3, {1});
  extra.push_back(0);
  EXPECT_TRUE(refused(assemble_png(rgb, extra))) << "more image data than the rows";
  extra.resize(extra.size() - 2);
  EXPECT_TRUE(refused(assemble_png(rgb, extra))) << "less image data than the rows";
  for (std::size_t cut : {std::size_t{20}, good.size() - 20, good.size() - 1})
    EXPECT_TRUE(
        refused(std::vector<std::uint8_t>(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(cut))))
        << "cut at " << cut;
  for (std::size_t at = 8; at < good.size(); ++at) {
    auto damaged = good;
    damaged[at] ^= 0x04;
    EXPECT_TRUE(refused(damaged)) << "byte " << at << " changed";
  }

  // A zlib header declaring a 256-byte window (CINFO 0): libdeflate would not hold a stream to it, zlib
  // does, so the direct decoder takes it only for images whose data fit in the window. libpng reads
  // the other (valid here: stored blocks reach back nowhere).
  PngLayout small_window = rgb;
  small_window.zlib_header = {0x08, 0x1D};
  bool small_taken = false;
  const auto small = direct_decode(assemble_png(small_window, filtered(rows, 2, 3, {4})), 100, small_taken);
  EXPECT_TRUE(small_taken) << "14 bytes of image data in a 256-byte window";
  EXPECT_EQ(small.rgba, expected_rgba(rows, 3, 8));
  PngLayout wide = small_window;
  wide.width = 100;
  std::vector<std::uint8_t> wide_rows(300 * 2);
  for (std::size_t i = 0; i < wide_rows.size(); ++i) wide_rows[i] = static_cast<std::uint8_t>(i * 7);
  const auto wide_file = assemble_png(wide, filtered(wide_rows, 2, 3, {0}));
  EXPECT_TRUE(refused(wide_file, 1000)) << "602 bytes of image data in a 256-byte window";
  write_bytes(dir / "window.png", wide_file);
  EXPECT_EQ(vectorize::load_png(dir / "window.png").rgba, expected_rgba(wide_rows, 3, 8));

  // libpng names the error of each damaged file, as before.
  auto bad_filter = assemble_png(rgb, filtered(rows, 2, 3, {5}));
  write_bytes(dir / "filter.png", bad_filter);
  EXPECT_NE(error_of(dir / "filter.png").find("corrupt or truncated"), std::string::npos)
      << error_of(dir / "filter.png");
}

} // namespace
