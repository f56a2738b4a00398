#pragma once
// The PNG reader's two decoders, for load_png() and for the tests that compare them.

#include <cstddef>
#include <filesystem>
#include <span>

#include "vectorize/image.hpp"

namespace vectorize::detail {

/// True when this build has the direct decoder (it needs libdeflate).
bool png_direct_available();

/// Decodes the common layouts directly: 8 or 16 bits per sample, grey, grey+alpha, RGB or RGBA, not
/// interlaced, no palette or transparency chunk, every critical chunk's CRC and the zlib checksum
/// right, exactly the expected amount of image data. Returns false, and leaves `image` as it was,
/// for anything else, including every damaged file and an image of more than max_pixels pixels:
/// load_png() then reads the file with libpng, which decodes every other layout and names the error.
/// The pixels are those libpng gives, bit for bit. (Deflate data that breaks the format in ways zlib
/// refuses and libdeflate does not, which no encoder writes, is decoded here; see png_direct.cpp.)
bool decode_png_direct(std::span<const unsigned char> file, std::size_t max_pixels, Image& image);

/// Converts `pixels` packed samples of `channels` channels (1 grey, 2 grey+alpha, 3 RGB, 4 RGBA) at
/// 8 or 16 bits (big-endian) into RGBA floats: value / 255 or / 65535, grey replicated, alpha 1 if
/// absent. Both decoders write their pixels through it.
void samples_to_rgba(const unsigned char* samples, std::size_t pixels, int channels, int bit_depth,
                     float* rgba);

/// load_png() without the direct decoder: libpng for every file.
Image load_png_with_libpng(const std::filesystem::path& path, std::size_t max_pixels);

} // namespace vectorize::detail
