// PNG decoding: the direct decoder (png_direct.cpp) for the common layouts, libpng for every other
// file and every error. The image reader of all builds for PNG, and the only one of builds without
// OpenImageIO (a GPU machine that carries only a few small libraries).

#include <png.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "png_direct.hpp"
#include "vectorize/errors.hpp"
#include "vectorize/image.hpp"

namespace vectorize {
namespace {

// libpng reports errors by longjmp. Everything a jump can cross is trivially destructible: the state
// below, and the two small functions that call setjmp. C++ objects live in load_png(), outside them.
struct PngState {
  png_structp png = nullptr;
  png_infop info = nullptr;
  std::FILE* file = nullptr;
  char message[256] = {};
};

extern "C" void on_png_error(png_structp png, png_const_charp message) {
  auto* state = static_cast<PngState*>(png_get_error_ptr(png));
  std::snprintf(state->message, sizeof state->message, "%s", message ? message : "unknown error");
  png_longjmp(png, 1);
}

// Warnings (an unknown chunk, a bad checksum in an ancillary chunk) do not stop decoding and are not
// printed: the reader reports errors through exceptions only.
extern "C" void on_png_warning(png_structp, png_const_charp) {}

struct PngHeader {
  png_uint_32 width = 0;
  png_uint_32 height = 0;
  int channels = 0;        // after the transformations below: 1 to 4
  int bit_depth = 0;       // after the transformations below: 8 or 16
  int source_channels = 0; // in the file
};

// Reads the header and sets up the transformations: palette to RGB, grey below 8 bits to 8 bits,
// transparency chunks to an alpha channel, interlaced rows merged; only the size when the image has
// more than max_pixels pixels.
bool read_header(PngState& state, std::size_t max_pixels, PngHeader& header) {
  if (setjmp(png_jmpbuf(state.png))) return false;
  png_init_io(state.png, state.file);
  png_read_info(state.png, state.info);
  header.width = png_get_image_width(state.png, state.info);
  header.height = png_get_image_height(state.png, state.info);
  // Too large: refused by the caller before png_read_update_info allocates rows of that width.
  if (static_cast<std::size_t>(header.width) * header.height > max_pixels) return true;
  const int colour_type = png_get_color_type(state.png, state.info);
  const bool has_trns = png_get_valid(state.png, state.info, PNG_INFO_tRNS) != 0;
  switch (colour_type) {
  case PNG_COLOR_TYPE_GRAY:
    header.source_channels = has_trns ? 2 : 1;
    break;
  case PNG_COLOR_TYPE_GRAY_ALPHA:
    header.source_channels = 2;
    break;
  case PNG_COLOR_TYPE_PALETTE:
    header.source_channels = has_trns ? 4 : 3;
    break;
  case PNG_COLOR_TYPE_RGB:
    header.source_channels = has_trns ? 4 : 3;
    break;
  default:
    header.source_channels = 4;
    break;
  }
  png_set_expand(state.png);
  png_set_interlace_handling(state.png);
  png_read_update_info(state.png, state.info);
  header.width = png_get_image_width(state.png, state.info);
  header.height = png_get_image_height(state.png, state.info);
  header.channels = png_get_channels(state.png, state.info);
  header.bit_depth = png_get_bit_depth(state.png, state.info);
  return true;
}

bool read_rows(PngState& state, png_bytepp rows) {
  if (setjmp(png_jmpbuf(state.png))) return false;
  png_read_image(state.png, rows);
  png_read_end(state.png, nullptr);
  return true;
}

struct PngReader {
  PngState state;
  ~PngReader() {
    if (state.png) png_destroy_read_struct(&state.png, state.info ? &state.info : nullptr, nullptr);
    if (state.file) std::fclose(state.file);
  }
};

std::string reason_of(const PngState& state, const char* fallback) {
  return state.message[0] ? std::string(state.message) : std::string(fallback);
}

} // namespace

namespace {

/// Throws FileError when a chunk claims more bytes than the file holds after it: libpng allocates an
/// ancillary chunk's claimed length (up to 2 GiB, and touches it) before it finds the file too short.
/// Reads the chunks' headers alone, from the signature to IEND; leaves the file at its start.
void check_chunk_lengths(std::FILE* file, const std::filesystem::path& path) {
  if (std::fseek(file, 0, SEEK_END) != 0) return;
  const long size = std::ftell(file);
  long at = 8; // past the signature
  while (size >= 0 && at + 8 <= size) {
    std::array<unsigned char, 8> header{};
    if (std::fseek(file, at, SEEK_SET) != 0 || std::fread(header.data(), 1, 8, file) != 8) break;
    const unsigned long length =
        (static_cast<unsigned long>(header[0]) << 24) | (header[1] << 16) | (header[2] << 8) | header[3];
    std::string type(reinterpret_cast<const char*>(header.data()) + 4, 4);
    for (char& c : type) c = std::isalpha(static_cast<unsigned char>(c)) ? c : '?'; // printable in a message
    const long room = size - at - 12; // after its header and before its checksum
    if (length > 0x7fffffffUL || room < 0 || static_cast<unsigned long>(room) < length) {
      throw FileError(path, "truncated or corrupt: chunk '" + type + "' at byte " + std::to_string(at) +
                                " runs past the end of the file (it claims " + std::to_string(length) +
                                " bytes of data; " + std::to_string(size - at) + " bytes remain)");
    }
    if (type == "IEND") break;
    at += 12 + static_cast<long>(length);
  }
  std::rewind(file);
}

} // namespace

bool is_png_file(const std::filesystem::path& path) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (!file) return false;
  std::array<unsigned char, 8> signature{};
  const bool whole = std::fread(signature.data(), 1, signature.size(), file) == signature.size();
  std::fclose(file);
  return whole && png_sig_cmp(signature.data(), 0, signature.size()) == 0;
}

Image detail::load_png_with_libpng(const std::filesystem::path& path, std::size_t max_pixels) {
  PngReader reader;
  PngState& state = reader.state;
  state.file = std::fopen(path.c_str(), "rb");
  if (!state.file) throw FileError(path, std::string("cannot open for reading: ") + std::strerror(errno));
  if (!is_png_file(path)) throw FileError(path, "not a PNG file");
  check_chunk_lengths(state.file, path);
  state.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &state, on_png_error, on_png_warning);
  if (!state.png) throw FileError(path, "cannot start the PNG decoder (out of memory)");
  state.info = png_create_info_struct(state.png);
  if (!state.info) throw FileError(path, "cannot start the PNG decoder (out of memory)");
  // The size limit is max_pixels' (checked below), not libpng's default of 10^6 pixels a side.
  png_set_user_limits(state.png, 0x7fffffff, 0x7fffffff);

  PngHeader header;
  if (!read_header(state, max_pixels, header))
    throw FileError(path, "cannot decode: " + reason_of(state, "bad PNG header"));
  if (header.width == 0 || header.height == 0) throw FileError(path, "image has zero size");
  const std::size_t pixels = static_cast<std::size_t>(header.width) * header.height;
  if (pixels > max_pixels) {
    throw FileError(path, "image is " + std::to_string(header.width) + " x " + std::to_string(header.height) +
                              " pixels, more than the limit of " + std::to_string(max_pixels));
  }
  if (header.channels < 1 || header.channels > 4 || (header.bit_depth != 8 && header.bit_depth != 16))
    throw FileError(path, "unsupported PNG layout");

  const std::size_t bytes_per_sample = header.bit_depth / 8;
  const std::size_t row_bytes = static_cast<std::size_t>(header.width) * header.channels * bytes_per_sample;
  std::vector<png_byte> data(row_bytes * header.height);
  std::vector<png_bytep> rows(header.height);
  for (png_uint_32 y = 0; y < header.height; ++y) rows[y] = data.data() + y * row_bytes;
  if (!read_rows(state, rows.data()))
    throw FileError(path, "corrupt or truncated image data: " + reason_of(state, "read failed"));

  Image image;
  image.width = static_cast<int>(header.width);
  image.height = static_cast<int>(header.height);
  image.source_channels = header.source_channels;
  image.known_opaque = header.channels == 1 || header.channels == 3; // samples_to_rgba sets alpha 1
  image.rgba.resize(pixels * 4);
  detail::samples_to_rgba(data.data(), pixels, header.channels, header.bit_depth, image.rgba.data());
  return image;
}

namespace {

// The whole file, or false when it cannot be read or is larger than any PNG of at most max_pixels
// pixels would normally be (libpng then reads it as a stream).
bool read_whole_file(const std::filesystem::path& path, std::size_t max_pixels,
                     std::vector<unsigned char>& bytes) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (!file) return false;
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> closer(file, &std::fclose);
  if (std::fseek(file, 0, SEEK_END) != 0) return false;
  const long size = std::ftell(file);
  const std::size_t room = max_pixels > SIZE_MAX / 2 ? SIZE_MAX / 2 : max_pixels + (std::size_t{1} << 16);
  if (size <= 0 || static_cast<unsigned long>(size) / 16 > room) return false;
  if (std::fseek(file, 0, SEEK_SET) != 0) return false;
  bytes.resize(static_cast<std::size_t>(size));
  return std::fread(bytes.data(), 1, bytes.size(), file) == bytes.size();
}

} // namespace

Image load_png(const std::filesystem::path& path, std::size_t max_pixels) {
  if (detail::png_direct_available()) {
    std::vector<unsigned char> bytes;
    Image image;
    if (read_whole_file(path, max_pixels, bytes) && detail::decode_png_direct(bytes, max_pixels, image))
      return image;
  }
  return detail::load_png_with_libpng(path, max_pixels);
}

namespace detail {

void samples_to_rgba(const unsigned char* samples, std::size_t pixels, int channels, int bit_depth,
                     float* rgba) {
  const bool has_alpha = channels == 2 || channels == 4;
  const float scale = bit_depth == 16 ? 1.0f / 65535.0f : 1.0f / 255.0f;
  if (bit_depth == 8) {
    // The channel count known to the compiler, so that the loop runs on vector registers.
    const auto convert = [&]<int kChannels>() {
      constexpr float k = 1.0f / 255.0f;
      for (std::size_t i = 0; i < pixels; ++i) {
        const unsigned char* src = samples + i * kChannels;
        float* dst = rgba + i * 4;
        const float first = static_cast<float>(src[0]) * k;
        dst[0] = first;
        dst[1] = kChannels >= 3 ? static_cast<float>(src[1]) * k : first;
        dst[2] = kChannels >= 3 ? static_cast<float>(src[2]) * k : first;
        dst[3] = kChannels == 2 || kChannels == 4 ? static_cast<float>(src[kChannels - 1]) * k : 1.0f;
      }
    };
    switch (channels) {
    case 1:
      convert.template operator()<1>();
      break;
    case 2:
      convert.template operator()<2>();
      break;
    case 3:
      convert.template operator()<3>();
      break;
    default:
      convert.template operator()<4>();
      break;
    }
    return;
  }
  for (std::size_t i = 0; i < pixels; ++i) {
    float sample[4] = {};
    for (int c = 0; c < channels; ++c) {
      const unsigned char* p = samples + (i * channels + c) * 2;
      sample[c] = static_cast<float>((unsigned{p[0]} << 8) | p[1]) * scale;
    }
    float* dst = rgba + i * 4;
    if (channels >= 3) {
      dst[0] = sample[0];
      dst[1] = sample[1];
      dst[2] = sample[2];
    } else {
      dst[0] = dst[1] = dst[2] = sample[0];
    }
    dst[3] = has_alpha ? sample[channels - 1] : 1.0f;
  }
}

} // namespace detail

} // namespace vectorize
