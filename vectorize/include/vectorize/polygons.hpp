#pragma once
// Stage 9 of the pipeline: the boundary loops of each region, built from the triangulation's own
// vertices so that neighbouring regions share their boundaries exactly (no overlap, no gap).

#include <cstdint>
#include <vector>

#include "cdt/cdt.hpp"
#include "vectorize/grouping.hpp"

namespace vectorize {

/// One closed boundary loop of a region; the closing edge from the last vertex back to the first is
/// implied. Orientation: the region lies to the left of each edge in the triangulation's frame, as for
/// its counter-clockwise triangles. So an outer ring has positive shoelace area computed on the
/// coordinates as given (counter-clockwise in a y-up frame, which is clockwise on screen with y down)
/// and a hole has negative area.
struct Ring {
  /// Vertex ids into Triangulation::vertices, at least three, no two consecutive ones equal.
  std::vector<std::uint32_t> vertices;
  /// The same vertices' coordinates, pixel units.
  std::vector<cdt::Point> points;
  /// Shoelace area, square pixels: positive for an outer ring, negative for a hole.
  double signed_area = 0.0;
  bool hole() const noexcept { return signed_area < 0; }
};

/// The boundary of one region: its rings, with no collinear vertex removed (simplifying one side of a
/// shared boundary and not the other would open cracks). The signed areas of the rings sum to the
/// region's area.
struct RegionPolygon {
  std::uint32_t region = 0; ///< index into Regions::regions
  std::vector<Ring> rings;
};

/// Which regions trace_polygons() traces.
enum class TransparentRegions {
  skip,    ///< only opaque regions (those that are drawn)
  include, ///< every region (for checks and debug overlays)
};

/// The boundary rings of the regions, in increasing region id.
///
/// A boundary edge is an edge whose other side is another region or the hull. At a vertex where the
/// region touches itself (a pinch), each incoming boundary edge continues with the next outgoing one
/// counter-clockwise around the vertex through the outside of the region; so every ring is simple as
/// a vertex sequence, a region that is connected through edges has exactly one outer ring, and each
/// hole ring bounds one connected piece of the rest of the plane. Within a region, rings are listed in
/// the order of the lowest (triangle, edge) they contain, each starting at that edge. Any of these
/// rings renders correctly under both the nonzero and the even-odd fill rule.
/// Preconditions: regions was computed from t by group_trixels(). Time O(triangles).
std::vector<RegionPolygon> trace_polygons(const cdt::Triangulation& t, const Regions& regions,
                                          TransparentRegions transparent = TransparentRegions::skip);

} // namespace vectorize
