#pragma once
// Debug overlays: a stage's output drawn over the dimmed input image, written as PNG, SVG or PDF.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string_view>

#include "vectorize/image.hpp"

namespace vectorize {

/// File format of an overlay.
enum class OverlayFormat { png, svg, pdf };

/// Parses "png", "svg" or "pdf"; throws std::invalid_argument naming the valid ones.
OverlayFormat parse_overlay_format(std::string_view name);

/// "png", "svg" or "pdf": the file name extension of the format, without the dot.
const char* overlay_extension(OverlayFormat format) noexcept;

/// What a saved overlay shows under the drawing.
enum class OverlayBackground {
  dimmed_input, ///< the input blended towards black (an overlay to look at on its own)
  none,         ///< nothing: transparent wherever nothing was drawn (a layer to stack on others)
};

/// A drawing surface the size of the input image, starting with the input blended towards black.
/// Coordinates are image pixels with y down: pixel (x, y) covers [x, x + 1] x [y, y + 1], so its
/// centre is at (x + 0.5, y + 0.5). Colours are non-premultiplied RGBA in [0, 1].
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
  /// dash > 0 draws it dashed, dash pixels on and off.
  void polyline(const float* xy, int num_points, bool closed, const float rgba[4], double width = 1.0,
                double dash = 0.0);

  /// Draws num_segments separate segments (x0, y0, x1, y1 each) in one stroke, width in pixels.
  void segments(const float* xy, std::size_t num_segments, const float rgba[4], double width = 1.0);

  /// Fills a polygon (num_points >= 3 vertices, closed implicitly). seam > 0 also strokes its outline
  /// that wide in the same colour, so that adjacent polygons of one colour show no anti-aliasing crack.
  void fill_polygon(const float* xy, int num_points, const float rgba[4], double seam = 0.0);

  /// Draws num_points discs of the given radius (pixels) centred at (x, y) pairs, each with a dark
  /// outline so that they stand out on any background.
  void dots(const float* xy, std::size_t num_points, double radius, const float rgba[4]);

  /// Paints the pixels whose mask entry is non-zero in one colour, as whole unanti-aliased pixels.
  /// mask holds width() * height() entries, row-major from the top-left.
  void pixels(const std::uint8_t* mask, const float rgba[4]);

  /// Writes the canvas; the file is written to a temporary name and renamed. Throws FileError.
  void save(const std::filesystem::path& path, OverlayFormat format = OverlayFormat::png,
            OverlayBackground background = OverlayBackground::dimmed_input) const;

private:
  struct State;
  std::unique_ptr<State> state_;
};

/// Writes the image as an 8-bit RGBA PNG (alpha kept), through a temporary file renamed once
/// complete. For a base layer that a browser can show whatever format the input came in. Throws
/// FileError naming the path.
void save_image_png(const Image& image, const std::filesystem::path& path);

} // namespace vectorize
