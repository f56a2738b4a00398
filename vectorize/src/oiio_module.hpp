#pragma once
// The interface between load_image() and the OpenImageIO reader module (vectorize/oiio/), which is
// a shared module opened on first use: linking OpenImageIO into the program would make every start
// pay for loading and initialising its large dependency closure (about a quarter of a second), while
// PNG, the common case, needs only libpng.

#include <cstddef>

#include "vectorize/image.hpp"

namespace vectorize::detail {

/// File name of the module; it is looked for beside the program first.
inline constexpr const char* kOiioModuleFile = "libtrixel_oiio_reader.so";

/// Name of the module's entry point, of type OiioLoadFunction.
inline constexpr const char* kOiioLoadSymbol = "trixel_oiio_load_image";

/// Decodes `path` into `out`. Returns true on success; otherwise writes the reason (without the path)
/// into `reason` (NUL-terminated, at most reason_size bytes) and returns false. Never throws.
using OiioLoadFunction = bool (*)(const char* path, std::size_t max_pixels, Image* out, char* reason,
                                  std::size_t reason_size);

} // namespace vectorize::detail
