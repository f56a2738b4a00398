#pragma once
// Stage 10 of the pipeline: the regions as SVG. Formats into a stream and does no file I/O itself.

#include <array>
#include <cstdint>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "vectorize/grouping.hpp"
#include "vectorize/polygons.hpp"

namespace vectorize {

/// How write_svg() keeps anti-aliasing renderers from showing the background through the hairline
/// cracks between adjacent regions (each region's edge pixels are only partly covered by its path, and
/// the partial coverages of two neighbours do not add up to an opaque pixel).
enum class Seams {
  /// Paths only: the smallest file, faint cracks where renderers anti-alias.
  none,
  /// Each path also stroked in its own colour, seam_width wide (default 0.5 px), largest region
  /// first: cracks mostly hidden, though edge pixels still let a little background through.
  stroke,
  /// Every path drawn twice (the second time through <use>): first, as an underlay, filled and stroked
  /// in its own colour seam_width wide (default 3 px), then filled exactly on top. A pixel that a
  /// boundary between two regions crosses lies within 1.5 px of the region drawn later, so the
  /// underlay covers it fully and no background shows through inside the shape; the exact fills on
  /// top keep every boundary where it is. Where the image has transparent areas, a mask keeps the
  /// underlay off them. Translucent regions (alpha below 0.75, covering no solid pixel) are drawn
  /// with their opacity and stay out of the underlay.
  underlay,
};

/// Options of write_svg().
struct SvgOptions {
  Seams seams = Seams::underlay;
  /// Width of the seam stroke, pixels; 0 takes the style's default (stroke 0.5, underlay 3).
  double seam_width = 0.0;
  /// Decimal places of coordinates, 0 to 6. Every coordinate is rounded to this grid once, so a vertex
  /// shared by two regions is written identically in both paths.
  int precision = 2;
};

/// Parses "none", "stroke" or "underlay"; throws std::invalid_argument naming the valid ones.
Seams parse_seams(std::string_view name);

/// Writes an SVG document of width x height pixels (viewBox "0 0 width height", y down, the pipeline's
/// coordinates) with one <path> per opaque region in polygons, filled with the region's colour as
/// #rrggbb (or #rgb); a region's rings are subpaths of its path (holes are oriented opposite to outer
/// rings, so the default nonzero fill rule leaves them empty). Path data use an absolute moveto per
/// ring, then relative lineto/h/v with compact numbers (no trailing zeros, no leading zero before the
/// point, separators only where needed). Polygons of transparent regions are skipped. Paths are
/// ordered by decreasing region area, then increasing region id.
/// Preconditions: polygons come from trace_polygons() with these regions; width, height > 0.
/// Throws std::invalid_argument for a precision outside 0..6 or a negative seam_width.
void write_svg(std::ostream& out, const std::vector<RegionPolygon>& polygons, const Regions& regions,
               int width, int height, const SvgOptions& options = {});

/// The document write_svg() writes, as a string.
std::string svg_document(const std::vector<RegionPolygon>& polygons, const Regions& regions, int width,
                         int height, const SvgOptions& options = {});

/// The compact decimal form of units * 10^-decimals as write_svg() writes numbers: "-1.5", ".25", "3",
/// "0". decimals in 0..18 (others are clamped to that range).
std::string compact_decimal(std::int64_t units, int decimals);

/// A colour as "#rrggbb", or "#rgb" when that says the same; channels in [0, 1], clamped, rounded.
std::string svg_colour(const std::array<float, 3>& rgb);

} // namespace vectorize
