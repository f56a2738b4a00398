#pragma once
// Stage 5 of the pipeline: the planar straight-line graph (PSLG) handed to the CDT engine.

#include <vector>

#include "cdt/cdt.hpp"
#include "vectorize/image.hpp"
#include "vectorize/placement.hpp"
#include "vectorize/simplify.hpp"

namespace vectorize {

/// Interior points: free points where the colour inside a region varies, so that smooth shading gets
/// triangles of its own.
struct InteriorOptions {
  /// Side of the square grid cells examined, in pixels; 0 for no interior points.
  int cell_size_px = 12;
  /// A cell gets a point when the RMS deviation of its colour from the cell's mean (over R, G, B in
  /// [0, 1], counting only shape pixels away from every segment) exceeds this; 0 gives every cell
  /// with enough such pixels a point.
  double min_std_dev = 0.012;
};

/// Points and segments for cdt::triangulate.
struct Pslg {
  std::vector<cdt::Point> points;
  std::vector<cdt::Segment> segments;
};

/// Builds the PSLG of an image of width x height pixels.
///
/// Coordinates: the image covers [0, width] x [0, height], y down; pixel (x, y) is the unit square
/// from (x, y) to (x + 1, y + 1), and a polyline point (an edge pixel) sits where
/// PointPlacement(image) puts it: its centre (x + 0.5, y + 0.5), or on a transparent image's shape
/// outline, at the shape's edge. Points:
/// - every polyline point, once (junctions shared by several polylines are one point);
/// - the four image corners, and where an open polyline ends in the outermost ring of pixels, the
///   point of the border straight out from it (left/right side first for a corner pixel) with a
///   segment to it, so that the polyline closes off its region against the border;
/// - interior points (see InteriorOptions): per grid cell whose colour varies, the centre of the
///   usable pixel nearest the cell centre, a pixel no segment passes through or next to, so interior
///   points lie at least half a pixel from every segment and never coincide with another point.
/// Segments: consecutive polyline points (and the closing one of a closed polyline), without
/// duplicates or zero-length ones, and the border rectangle split at the border points above.
///
/// Preconditions: width, height >= 1; polyline points inside the image; image either empty (no
/// interior points) or width x height. The result has no crossing segments when the polylines have
/// none (simplify_chains output from trace_chains chains). Throws std::invalid_argument otherwise.
Pslg build_pslg(const std::vector<Polyline>& simplified, int width, int height, const Image& image,
                const InteriorOptions& options = {});

/// The same with the image's PointPlacement already made (the pipeline makes it once for simplification
/// and this stage). Throws std::invalid_argument if `placement` was made for another image.
Pslg build_pslg(const std::vector<Polyline>& simplified, int width, int height, const Image& image,
                const InteriorOptions& options, const PointPlacement& placement);

} // namespace vectorize
