#pragma once
// Stage 3 of the pipeline: edge pixels linked into chains between endpoints and junctions.

#include <vector>

#include "vectorize/edges.hpp"

namespace vectorize {

/// A pixel position: column x and row y from the top-left (integers, not the pixel's centre).
struct PixelPoint {
  int x = 0;
  int y = 0;
  friend bool operator==(const PixelPoint&, const PixelPoint&) = default;
};

/// A chain of edge pixels, consecutive points 8-adjacent.
///
/// Open chain (closed == false): points.front() and points.back() are endpoints or junctions; a
/// junction pixel ends every chain that meets there, with the same coordinates, so chains join by
/// their end points. Both ends may be the same junction (a loop hanging off it). Closed chain: a loop
/// with no endpoint or junction; the last point links back to the first, which is not repeated.
struct Chain {
  std::vector<PixelPoint> points;
  bool closed = false;
};

/// Links the edge pixels into chains.
///
/// Cleanup first: in every fully set 2x2 block, pixels whose removal keeps the topology (simple
/// points) are removed until none is left, so thick spots do not make clusters of junctions; then
/// one-pixel spurs (an end pixel linked only to a junction, removable without changing the topology)
/// are removed in one pass, so that a bump on a line does not split it. Pixels
/// are then linked by m-adjacency (Gonzalez and Woods, "Digital Image Processing", 2.5.2): 4-neighbours
/// always, diagonal neighbours only when they share no set 4-neighbour. That keeps the staircase
/// corners of a 4-connected line at two links (no false junction) and makes the links a plane graph:
/// segments between linked pixel centres meet only at shared ends. Pixels with a number of links other
/// than two are endpoints or junctions and split chains. Every link belongs to exactly one chain;
/// isolated pixels (no link) give no chain. Deterministic: chains start in raster order.
std::vector<Chain> trace_chains(const EdgeMap& edges);

} // namespace vectorize
