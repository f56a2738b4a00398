#pragma once
// Stage 1 of the pipeline: decoding a raster file into plain RGBA floats.

#include <cstddef>
#include <filesystem>
#include <memory>
#include <vector>

namespace vectorize {

/// A decoded image: width x height pixels, row-major from the top-left, 4 channels (R, G, B, A) per
/// pixel as non-premultiplied values in [0, 1] in the file's colour space (normally sRGB).
struct Image {
  int width = 0;
  int height = 0;
  std::vector<float> rgba;
  /// Channels of the source file (1 grey, 2 grey+alpha, 3 RGB, 4 RGBA), for reporting.
  int source_channels = 0;
  /// True when every alpha is 1 and the reader knows it without looking: the file had neither an alpha
  /// channel nor a transparent colour, and the reader set them to 1. False says nothing either way
  /// (the stages then read the alphas). Spares three passes over a photograph's pixels.
  bool known_opaque = false;

  float* pixel(int x, int y) { return rgba.data() + 4 * (static_cast<std::size_t>(y) * width + x); }
  const float* pixel(int x, int y) const {
    return rgba.data() + 4 * (static_cast<std::size_t>(y) * width + x);
  }
};

/// An image's pixels kept on the CUDA device from one stage to another (by detect_edges, for
/// colour_trixels), so that they are copied there once; device memory, held while a copy of the handle
/// lives (drop it before the device is given back). Empty when there is none.
using DevicePixels = std::shared_ptr<const void>;

/// Reads any format OpenImageIO reads (PNG, JPEG, TIFF, BMP, WebP, ...), 8/16-bit or float, grey,
/// grey+alpha, RGB or RGBA; grey is replicated to RGB and a missing alpha is 1. Only the first
/// subimage is read. Throws FileError naming the file and the reason: missing, not a regular file,
/// unreadable, unsupported format, corrupt or truncated data, zero size, or more than max_pixels.
/// A build configured with TRIXEL_IMAGE_IO=png has no OpenImageIO and reads PNG only (load_png).
Image load_image(const std::filesystem::path& path, std::size_t max_pixels = std::size_t{1} << 28);

/// Reads a PNG file: 1 to 16 bits per sample, grey, grey+alpha, palette, RGB or RGBA, interlaced or
/// not; palette and transparency chunks become RGB and alpha. The common layouts are decoded directly
/// (libdeflate), all others with libpng. Same result and errors as load_image() gives for a PNG.
Image load_png(const std::filesystem::path& path, std::size_t max_pixels = std::size_t{1} << 28);

/// True when the file starts with the PNG signature.
bool is_png_file(const std::filesystem::path& path);

/// "OpenImageIO x.y.z" or "libpng x.y.z (PNG only)": what load_image() reads with in this build.
const char* image_reader_name();

} // namespace vectorize
