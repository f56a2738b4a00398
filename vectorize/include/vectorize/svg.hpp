#pragma once
// Stage 10 of the pipeline: the regions as SVG. Formats into a stream and does no file I/O itself.

#include <array>
#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "vectorize/grouping.hpp"
#include "vectorize/polygons.hpp"

namespace vectorize {

/// Options of write_svg().
struct SvgOptions {
  /// Hide the hairline cracks that anti-aliasing renderers leave between adjacent regions: each path
  /// is also stroked in its own colour (round joins), and paths are drawn largest region first, so a
  /// smaller region's stroke covers the crack over its larger neighbour.
  bool seams = true;
  /// Width of that stroke, pixels; half of it spills over each boundary.
  double seam_width = 0.5;
  /// Decimal places of coordinates, 0 to 6. Every coordinate is rounded to this grid once, so a vertex
  /// shared by two regions is written identically in both paths.
  int precision = 2;
};

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

/// The compact decimal form of units * 10^-decimals as write_svg() writes numbers: "-1.5", ".25", "3",
/// "0". decimals in 0..18.
std::string compact_decimal(std::int64_t units, int decimals);

/// A colour as "#rrggbb", or "#rgb" when that says the same; channels in [0, 1], clamped, rounded.
std::string svg_colour(const std::array<float, 3>& rgb);

} // namespace vectorize
