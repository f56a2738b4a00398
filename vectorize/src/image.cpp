#include "vectorize/image.hpp"

#include <dlfcn.h>
#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "oiio_module.hpp"
#include "vectorize/errors.hpp"

namespace vectorize {
namespace {

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

#if TRIXEL_WITH_OIIO

// The OpenImageIO module: opened once, on the first input that is not a PNG. The program's own
// folder is searched first (the build tree keeps programs and module together), then ../lib/trixel,
// then the system's library path.
struct OiioModule {
  detail::OiioLoadFunction load = nullptr;
  std::string error;
};

const OiioModule& oiio_module() {
  static const OiioModule module = [] {
    OiioModule m;
    std::vector<std::string> candidates;
    if (const char* env = std::getenv("TRIXEL_OIIO_READER"); env && *env) candidates.emplace_back(env);
    std::error_code ec;
    const auto exe_dir = std::filesystem::read_symlink("/proc/self/exe", ec).parent_path();
    if (!ec) {
      candidates.push_back((exe_dir / detail::kOiioModuleFile).string());
      candidates.push_back((exe_dir / ".." / "lib" / "trixel" / detail::kOiioModuleFile).string());
    }
    candidates.emplace_back(detail::kOiioModuleFile);
    for (const auto& candidate : candidates) {
      void* handle = dlopen(candidate.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!handle) {
        if (m.error.empty()) m.error = dlerror();
        continue;
      }
      m.load = reinterpret_cast<detail::OiioLoadFunction>(dlsym(handle, detail::kOiioLoadSymbol));
      if (m.load) return m;
      m.error = candidate + " has no " + detail::kOiioLoadSymbol;
    }
    return m;
  }();
  return module;
}

#endif

} // namespace

#if TRIXEL_WITH_LIBDEFLATE
#define TRIXEL_PNG_READER "libpng " PNG_LIBPNG_VER_STRING " with libdeflate"
#else
#define TRIXEL_PNG_READER "libpng " PNG_LIBPNG_VER_STRING
#endif

const char* image_reader_name() {
#if TRIXEL_WITH_OIIO
  return TRIXEL_PNG_READER " for PNG, OpenImageIO (loaded on first use) for other formats";
#else
  return TRIXEL_PNG_READER " (PNG only)";
#endif
}

Image load_image(const std::filesystem::path& path, std::size_t max_pixels) {
  check_readable_file(path);
  if (is_png_file(path)) return load_png(path, max_pixels);
#if TRIXEL_WITH_OIIO
  const OiioModule& module = oiio_module();
  if (!module.load) {
    throw FileError(path, "not a PNG, and the OpenImageIO reader for other formats cannot be loaded (" +
                              module.error + ")");
  }
  Image image;
  char reason[512] = {};
  if (!module.load(path.c_str(), max_pixels, &image, reason, sizeof reason)) throw FileError(path, reason);
  return image;
#else
  throw FileError(path,
                  "unsupported format: this build reads PNG only (configured with TRIXEL_IMAGE_IO=png)");
#endif
}

} // namespace vectorize
