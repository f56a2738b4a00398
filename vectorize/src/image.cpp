#include "vectorize/image.hpp"

#if TRIXEL_WITH_OIIO
#include <OpenImageIO/imageio.h>
#else
#include <png.h>
#endif

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <system_error>

#include "vectorize/errors.hpp"

namespace vectorize {
namespace {

#if TRIXEL_WITH_OIIO
// OpenImageIO's messages are multi-line and sometimes repeat the path; keep the first useful line.
std::string first_line(std::string message) {
  const auto nl = message.find('\n');
  if (nl != std::string::npos) message.resize(nl);
  while (!message.empty() && (message.back() == ' ' || message.back() == '\r')) message.pop_back();
  return message;
}
#endif

void check_readable_file(const std::filesystem::path& path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) throw FileError(path, "no such file");
  if (std::filesystem::is_directory(status)) throw FileError(path, "is a directory, not an image file");
  if (!std::filesystem::is_regular_file(status)) throw FileError(path, "not a regular file");
  std::ifstream probe(path, std::ios::binary);
  if (!probe) throw FileError(path, std::string("cannot open for reading: ") + std::strerror(errno));
  if (std::filesystem::file_size(path, ec) == 0 && !ec) throw FileError(path, "empty file (0 bytes)");
}

} // namespace

#if !TRIXEL_WITH_OIIO

const char* image_reader_name() { return "libpng " PNG_LIBPNG_VER_STRING " (PNG only)"; }

Image load_image(const std::filesystem::path& path, std::size_t max_pixels) {
  check_readable_file(path);
  if (!is_png_file(path))
    throw FileError(path,
                    "unsupported format: this build reads PNG only (configured with TRIXEL_IMAGE_IO=png)");
  return load_png(path, max_pixels);
}

#else

const char* image_reader_name() { return "OpenImageIO " OIIO_VERSION_STRING; }

Image load_image(const std::filesystem::path& path, std::size_t max_pixels) {
  check_readable_file(path);
  // Ask for unassociated (straight) alpha: PNG stores it that way and OpenImageIO would otherwise
  // premultiply, darkening the colour of every partly transparent edge pixel.
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto input = OIIO::ImageInput::open(path.string(), &config);
  if (!input) {
    std::string reason = first_line(OIIO::geterror());
    if (reason.empty()) reason = "not an image in a format this build can read";
    throw FileError(path, "cannot decode: " + reason);
  }
  const OIIO::ImageSpec& spec = input->spec();
  if (spec.width <= 0 || spec.height <= 0) throw FileError(path, "image has zero size");
  if (spec.depth > 1) throw FileError(path, "volume images are not supported");
  const int channels = spec.nchannels;
  if (channels < 1) throw FileError(path, "image has no channels");
  const std::size_t pixels = static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height);
  if (pixels > max_pixels) {
    throw FileError(path, "image is " + std::to_string(spec.width) + " x " + std::to_string(spec.height) +
                              " pixels, more than the limit of " + std::to_string(max_pixels));
  }

  std::vector<float> raw(pixels * static_cast<std::size_t>(channels));
  if (!input->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, raw.data())) {
    std::string reason = first_line(input->geterror());
    if (reason.empty()) reason = "read failed";
    throw FileError(path, "corrupt or truncated image data: " + reason);
  }
  input->close();

  // Which channel is alpha: OIIO reports it, with the usual 2- and 4-channel layouts as fallback.
  int alpha = spec.alpha_channel;
  if (alpha < 0 && (channels == 2 || channels == 4)) alpha = channels - 1;
  const int colour_channels = alpha >= 0 ? std::min(channels - 1, 3) : std::min(channels, 3);

  Image image;
  image.width = spec.width;
  image.height = spec.height;
  image.source_channels = channels;
  image.rgba.resize(pixels * 4);
  for (std::size_t i = 0; i < pixels; ++i) {
    const float* src = raw.data() + i * static_cast<std::size_t>(channels);
    float* dst = image.rgba.data() + i * 4;
    if (colour_channels >= 3) {
      dst[0] = src[0];
      dst[1] = src[1];
      dst[2] = src[2];
    } else {
      dst[0] = dst[1] = dst[2] = src[0];
    }
    dst[3] = alpha >= 0 ? src[alpha] : 1.0f;
    for (int c = 0; c < 4; ++c) dst[c] = std::clamp(dst[c], 0.0f, 1.0f);
  }
  return image;
}

#endif

} // namespace vectorize
