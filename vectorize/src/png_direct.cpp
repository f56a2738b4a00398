// The direct PNG decoder: the whole file in memory, its image data inflated by libdeflate in one
// call, each row unfiltered (Average and Paeth a pixel at a time in SIMD lanes) and converted to
// floats while it is in cache. libpng, inflating through zlib's streaming decoder, took 13-17 ms of a
// Kodak photograph's conversion on one core; this decoder takes 6-7. Every file it does not take, or
// finds anything wrong with, goes to libpng (load_png), so the layouts read and the errors reported
// are libpng's. One difference is left: libdeflate accepts a few deflate encodings that zlib refuses
// (a literal/length table of 288 codes or a distance table of 32, a distance table of one code read
// through its unused bit pattern); no encoder writes them, and a file made so is decoded here (its
// checksum must still hold) where libpng would report it corrupt.

#include "png_direct.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <vector>

#if TRIXEL_WITH_LIBDEFLATE
#include <libdeflate.h>
#endif
#if defined(__SSE4_1__)
#include <smmintrin.h>
#endif

namespace vectorize::detail {

#if TRIXEL_WITH_LIBDEFLATE

namespace {

std::uint32_t read_be32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

bool is_type(const unsigned char* p, const char* name) { return std::memcmp(p, name, 4) == 0; }

// libpng's own limit on either side (PNG_USER_WIDTH_MAX, PNG_USER_HEIGHT_MAX).
constexpr std::uint32_t kMaxSide = 1000000;

struct Header {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  int bit_depth = 0;
  int channels = 0;
};

#if defined(__SSE4_1__)
// Average and Paeth for 3 and 4 bytes per pixel, one pixel per step in 16-bit lanes: the bytes of a
// row depend on the pixel to their left, so the lanes are the pixel's channels. The same arithmetic
// as the byte loops below, and for the first pixel (a = c = 0) the same prediction as theirs. Reads
// one byte beyond the row when Bpp is 3 (the buffers have room).
template <std::size_t Bpp, bool Paeth>
void unfilter_pixels(unsigned char* row, const unsigned char* above, std::size_t size) {
  static_assert(Bpp == 3 || Bpp == 4);
  const __m128i zero = _mm_setzero_si128();
  const __m128i low_byte = _mm_set1_epi16(0xFF);
  __m128i a = zero;
  __m128i c = zero;
  for (std::size_t i = 0; i + Bpp <= size; i += Bpp) {
    std::uint32_t up = 0;
    std::uint32_t here = 0;
    std::memcpy(&up, above + i, 4); // a byte beyond a 3-byte pixel is read and not used
    std::memcpy(&here, row + i, 4);
    const __m128i b = _mm_unpacklo_epi8(_mm_cvtsi32_si128(static_cast<int>(up)), zero);
    const __m128i x = _mm_unpacklo_epi8(_mm_cvtsi32_si128(static_cast<int>(here)), zero);
    __m128i predicted;
    if constexpr (Paeth) {
      const __m128i pa = _mm_abs_epi16(_mm_sub_epi16(b, c));
      const __m128i pb = _mm_abs_epi16(_mm_sub_epi16(a, c));
      const __m128i pc = _mm_abs_epi16(_mm_sub_epi16(_mm_add_epi16(a, b), _mm_add_epi16(c, c)));
      const __m128i b_or_c = _mm_blendv_epi8(b, c, _mm_cmpgt_epi16(pb, pc));
      predicted = _mm_blendv_epi8(a, b_or_c, _mm_or_si128(_mm_cmpgt_epi16(pa, pb), _mm_cmpgt_epi16(pa, pc)));
    } else {
      predicted = _mm_srli_epi16(_mm_add_epi16(a, b), 1);
    }
    a = _mm_and_si128(_mm_add_epi16(x, predicted), low_byte);
    c = b;
    const auto out = static_cast<std::uint32_t>(_mm_cvtsi128_si32(_mm_packus_epi16(a, zero)));
    std::memcpy(row + i, &out, Bpp);
  }
}
#endif

// The filters of PNG (the specification's section 9): each row's bytes are the differences from a
// prediction made of the already decoded bytes to the left (a), above (b) and above-left (c), `bpp`
// bytes apart. Returns false for an unknown filter type.
bool unfilter_row(int type, unsigned char* row, const unsigned char* above, std::size_t size,
                  std::size_t bpp) {
#if defined(__SSE4_1__)
  // Average and Paeth of 3- and 4-byte pixels in SIMD lanes.
  using PixelLoop = void (*)(unsigned char*, const unsigned char*, std::size_t);
  static constexpr PixelLoop kPixelLoops[2][2] = {{unfilter_pixels<3, false>, unfilter_pixels<3, true>},
                                                  {unfilter_pixels<4, false>, unfilter_pixels<4, true>}};
  if ((type == 3 || type == 4) && (bpp == 3 || bpp == 4)) {
    kPixelLoops[bpp - 3][type - 3](row, above, size);
    return true;
  }
#endif
  switch (type) {
  case 0:
    return true;
  case 1:
    for (std::size_t i = bpp; i < size; ++i) row[i] = static_cast<unsigned char>(row[i] + row[i - bpp]);
    return true;
  case 2:
    for (std::size_t i = 0; i < size; ++i) row[i] = static_cast<unsigned char>(row[i] + above[i]);
    return true;
  case 3:
    for (std::size_t i = 0; i < bpp; ++i) row[i] = static_cast<unsigned char>(row[i] + (above[i] >> 1));
    for (std::size_t i = bpp; i < size; ++i)
      row[i] = static_cast<unsigned char>(row[i] + ((unsigned{row[i - bpp]} + above[i]) >> 1));
    return true;
  case 4:
    for (std::size_t i = 0; i < bpp; ++i) row[i] = static_cast<unsigned char>(row[i] + above[i]);
    for (std::size_t i = bpp; i < size; ++i) {
      const int a = row[i - bpp];
      const int b = above[i];
      const int c = above[i - bpp];
      const int pa = std::abs(b - c);
      const int pb = std::abs(a - c);
      const int pc = std::abs(a + b - 2 * c);
      const int predicted = (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
      row[i] = static_cast<unsigned char>(row[i] + predicted);
    }
    return true;
  default:
    return false;
  }
}

// The header, if the layout is one this decoder takes.
bool read_header(const unsigned char* ihdr, Header& header) {
  header.width = read_be32(ihdr);
  header.height = read_be32(ihdr + 4);
  header.bit_depth = ihdr[8];
  const int colour_type = ihdr[9];
  if (header.width == 0 || header.height == 0 || header.width > kMaxSide || header.height > kMaxSide)
    return false;
  if (header.bit_depth != 8 && header.bit_depth != 16) return false;
  switch (colour_type) {
  case 0:
    header.channels = 1;
    break;
  case 2:
    header.channels = 3;
    break;
  case 4:
    header.channels = 2;
    break;
  case 6:
    header.channels = 4;
    break;
  default:
    return false; // palette or invalid
  }
  return ihdr[10] == 0 && ihdr[11] == 0 && ihdr[12] == 0; // deflate, adaptive filters, not interlaced
}

struct DecompressorDeleter {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

} // namespace

bool png_direct_available() { return true; }

bool decode_png_direct(std::span<const unsigned char> file, std::size_t max_pixels, Image& image) {
  static constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  const unsigned char* const data = file.data();
  const std::size_t size = file.size();
  if (size < 8 + 25 || std::memcmp(data, kSignature, 8) != 0) return false;

  // The chunks: IHDR first, IDAT chunks in one run, IEND last. Any other critical chunk (PLTE
  // included) and tRNS, whose alpha libpng makes, leave the file to libpng; other ancillary chunks
  // are skipped, as libpng skips them without transformations asking for them.
  Header header;
  std::vector<std::span<const unsigned char>> idat;
  std::size_t idat_bytes = 0;
  bool idat_ended = false;
  bool ended = false;
  std::size_t pos = 8;
  for (bool first = true; !ended; first = false) {
    if (size - pos < 12) return false;
    const std::uint32_t length = read_be32(data + pos);
    if (length > 0x7FFFFFFFu || size - pos - 12 < length) return false;
    const unsigned char* type = data + pos + 4;
    for (int i = 0; i < 4; ++i) {
      const unsigned char ch = type[i];
      if (!((ch >= 'A' && ch <= 'Z') || (ch >= 'a' && ch <= 'z'))) return false;
    }
    const bool critical = (type[0] & 0x20) == 0;
    const unsigned char* body = type + 4;
    if (critical) {
      const auto crc = static_cast<std::uint32_t>(libdeflate_crc32(0, type, std::size_t{length} + 4));
      if (crc != read_be32(body + length)) return false;
    }
    if (first != is_type(type, "IHDR")) return false;
    if (first) {
      if (length != 13 || !read_header(body, header)) return false;
    } else if (is_type(type, "IDAT")) {
      if (idat_ended) return false;
      idat.emplace_back(body, length);
      idat_bytes += length;
    } else if (is_type(type, "IEND")) {
      if (length != 0 || idat.empty()) return false;
      ended = true;
    } else if (critical || is_type(type, "tRNS")) {
      return false;
    } else if (!idat.empty()) {
      idat_ended = true;
    }
    pos += std::size_t{length} + 12;
  }

  const std::size_t pixels = std::size_t{header.width} * header.height;
  if (pixels > max_pixels) return false;
  const std::size_t bytes_per_sample = static_cast<std::size_t>(header.bit_depth) / 8;
  const std::size_t bpp = static_cast<std::size_t>(header.channels) * bytes_per_sample;
  const std::size_t row_bytes = std::size_t{header.width} * bpp;
  const std::size_t raw_bytes = (row_bytes + 1) * header.height;

  // One zlib stream over the IDAT chunks' bodies, which must hold it exactly.
  std::vector<unsigned char> joined;
  std::span<const unsigned char> stream = idat.front();
  if (idat.size() > 1) {
    joined.resize(idat_bytes);
    std::size_t at = 0;
    for (const auto& part : idat) {
      std::memcpy(joined.data() + at, part.data(), part.size());
      at += part.size();
    }
    stream = joined;
  }
  // libdeflate ignores the window size the zlib header declares (2^(CINFO + 8) bytes); zlib, inside
  // libpng, refuses a distance beyond it. A smaller window than the largest is taken only when the
  // whole image fits in it, where no distance can reach beyond it.
  if (stream.size() < 2) return false;
  const unsigned window_log = (stream[0] >> 4) + 8u;
  if (window_log > 15 || (window_log < 15 && raw_bytes > (std::size_t{1} << window_log))) return false;
  constexpr std::size_t kSlack = 4; // the pixel loops' reads beyond the last row
  std::unique_ptr<unsigned char[]> raw(new (std::nothrow) unsigned char[raw_bytes + kSlack]);
  const std::unique_ptr<libdeflate_decompressor, DecompressorDeleter> inflater(
      libdeflate_alloc_decompressor());
  if (!raw || !inflater) return false;
  std::size_t used_in = 0;
  std::size_t made = 0;
  if (libdeflate_zlib_decompress_ex(inflater.get(), stream.data(), stream.size(), raw.get(), raw_bytes,
                                    &used_in, &made) != LIBDEFLATE_SUCCESS ||
      used_in != stream.size() || made != raw_bytes) {
    return false;
  }

  // Unfilter in place, each row converted while it is in cache. A bad filter type leaves the whole
  // file to libpng, so `image` is filled only into a local first.
  Image decoded;
  decoded.width = static_cast<int>(header.width);
  decoded.height = static_cast<int>(header.height);
  decoded.source_channels = header.channels;
  decoded.known_opaque = header.channels == 1 || header.channels == 3; // no tRNS here: alpha 1
  decoded.rgba.resize(pixels * 4);
  const std::vector<unsigned char> zero_row(row_bytes + kSlack, 0);
  const unsigned char* above = zero_row.data();
  for (std::uint32_t y = 0; y < header.height; ++y) {
    unsigned char* line = raw.get() + y * (row_bytes + 1);
    if (!unfilter_row(line[0], line + 1, above, row_bytes, bpp)) return false;
    samples_to_rgba(line + 1, header.width, header.channels, header.bit_depth,
                    decoded.rgba.data() + std::size_t{y} * header.width * 4);
    above = line + 1;
  }
  image = std::move(decoded);
  return true;
}

#else

bool png_direct_available() { return false; }

bool decode_png_direct(std::span<const unsigned char>, std::size_t, Image&) { return false; }

#endif

} // namespace vectorize::detail
