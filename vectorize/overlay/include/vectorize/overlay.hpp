#pragma once
// Debug overlays: a stage's output drawn over the dimmed input image, written as PNG, SVG or PDF.

#include <filesystem>
#include <memory>

#include "vectorize/image.hpp"

namespace vectorize {

/// File format of an overlay.
enum class OverlayFormat { png, svg, pdf };

/// A drawing surface the size of the input image, starting with the input blended towards black.
class OverlayCanvas {
public:
  /// dim in [0, 1]: 0 keeps the input as is, 1 paints it black. Transparent pixels show a
  /// checkerboard so that "no shape" areas are visible.
  OverlayCanvas(const Image& input, double dim = 0.6);
  ~OverlayCanvas();
  OverlayCanvas(const OverlayCanvas&) = delete;
  OverlayCanvas& operator=(const OverlayCanvas&) = delete;

  int width() const noexcept;
  int height() const noexcept;

  /// Draws a polyline in image pixel coordinates (pixel centres at half-integers), width in pixels.
  void polyline(const float* xy, int num_points, bool closed, const float rgba[4], double width = 1.0);

  /// Writes the canvas; the file is written to a temporary name and renamed. Throws FileError.
  void save(const std::filesystem::path& path, OverlayFormat format = OverlayFormat::png) const;

private:
  struct State;
  std::unique_ptr<State> state_;
};

} // namespace vectorize
