#pragma once
// Stage 4 of the pipeline: chains simplified to polylines within a pixel tolerance, never crossing.

#include <vector>

#include "vectorize/chains.hpp"
#include "vectorize/placement.hpp"

namespace vectorize {

/// A simplified chain: a subsequence of its chain's points that keeps both ends of an open chain.
/// closed as in Chain (the last point links back to the first, which is not repeated).
struct Polyline {
  std::vector<PixelPoint> points;
  bool closed = false;
};

/// Simplifies each chain by removing points, one result per chain in the same order.
///
/// Guarantees, with points where `placement` puts them (by default the pixel centres):
/// - every point of a chain lies within tolerance_px of the segment of its polyline that replaced it,
///   and no segment passes inside a shape's outline point by more than its Placement::slack, so that
///   the polygons keep covering the shape's solid rim pixels;
/// - the ends of open chains (endpoints and junctions) are kept, so chains still join;
/// - no crossing is created, neither between polylines nor within one: a new segment touches no other
///   segment except at a shared end, and never overlaps one; and no segment sweeps over another point
///   (so a small loop or a dangling chain stays on its side). Chains that already cross stay as given.
/// - a closed chain keeps at least 3 points and an open chain whose ends coincide at least 4, so no
///   loop collapses.
///
/// Points are removed greedily, cheapest (smallest deviation) first, with candidate segments checked
/// exactly (orient2d) against the segments found in a uniform grid, so the time is near-linear in the
/// number of points for chains from an image. Consecutive duplicate points are dropped first, then
/// (when every point is at its pixel centre and consecutive points are 8-adjacent, as traced chains
/// are) the middle points of exactly straight runs that no other chain point shares, that lie on no
/// outline and whose steps no other diagonal may cross: the greedy pass would remove them first
/// anyway, and the segments keep covering the same points.
/// The chains left of the median x of all points and those right of it are simplified apart, on two
/// threads when `threads` allows (0: every hardware thread), then the chains across it; the result is
/// the same for any number of threads.
/// tolerance_px >= 0 (0 removes only points that lie exactly on a straight run); throws
/// std::invalid_argument otherwise.
std::vector<Polyline> simplify_chains(const std::vector<Chain>& chains, double tolerance_px,
                                      const PointPlacement& placement = {}, unsigned threads = 1);

} // namespace vectorize
