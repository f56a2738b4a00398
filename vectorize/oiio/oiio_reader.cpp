// The OpenImageIO reader of load_image(), built as a shared module that the program opens only when
// an input is not a PNG (see vectorize/src/oiio_module.hpp): every format OpenImageIO reads.

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "../src/oiio_module.hpp"
#include "vectorize/image.hpp"

namespace {

using vectorize::Image;

// A failure to report; the loader adds the file's path.
struct ReadError {
  std::string reason;
  explicit ReadError(std::string r) : reason(std::move(r)) {}
};

// OpenImageIO's messages are multi-line and sometimes repeat the path; keep the first useful line.
std::string first_line(std::string message) {
  const auto nl = message.find('\n');
  if (nl != std::string::npos) message.resize(nl);
  while (!message.empty() && (message.back() == ' ' || message.back() == '\r')) message.pop_back();
  return message;
}

Image load(const std::filesystem::path& path, std::size_t max_pixels) {
  // Ask for unassociated (straight) alpha: PNG stores it that way and OpenImageIO would otherwise
  // premultiply, darkening the colour of every partly transparent edge pixel.
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto input = OIIO::ImageInput::open(path.string(), &config);
  if (!input) {
    std::string reason = first_line(OIIO::geterror());
    if (reason.empty()) reason = "not an image in a format this build can read";
    throw ReadError("cannot decode: " + reason);
  }
  const OIIO::ImageSpec& spec = input->spec();
  if (spec.width <= 0 || spec.height <= 0) throw ReadError("image has zero size");
  if (spec.depth > 1) throw ReadError("volume images are not supported");
  const int channels = spec.nchannels;
  if (channels < 1) throw ReadError("image has no channels");
  const std::size_t pixels = static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height);
  if (pixels > max_pixels) {
    throw ReadError("image is " + std::to_string(spec.width) + " x " + std::to_string(spec.height) +
                    " pixels, more than the limit of " + std::to_string(max_pixels));
  }

  std::vector<float> raw(pixels * static_cast<std::size_t>(channels));
  // A reader may fill what it could not read and report it only as an error on the side (a TIFF cut
  // short became black rows, a JPEG cut short grey ones).
  if (!input->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, raw.data()) || input->has_error()) {
    std::string reason = first_line(input->geterror());
    if (reason.empty()) reason = "read failed";
    throw ReadError("corrupt or truncated image data: " + reason);
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
  image.known_opaque = alpha < 0; // every alpha set to 1 below
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

} // namespace

extern "C" __attribute__((visibility("default"))) bool trixel_oiio_load_image(const char* path,
                                                                              std::size_t max_pixels,
                                                                              Image* out, char* reason,
                                                                              std::size_t reason_size) {
  static_assert(std::is_same_v<decltype(&trixel_oiio_load_image), vectorize::detail::OiioLoadFunction>);
  try {
    *out = load(path, max_pixels);
    return true;
  } catch (const ReadError& e) {
    std::snprintf(reason, reason_size, "%s", e.reason.c_str());
  } catch (const std::exception& e) {
    std::snprintf(reason, reason_size, "cannot decode: %s", e.what());
  }
  return false;
}
