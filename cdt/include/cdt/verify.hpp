#pragma once
// The verifier: checks a Triangulation against the input it was computed from, with exact predicates.
// Tests, the CLI's --verify and the benchmarks use it.

#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "cdt/cdt.hpp"

namespace cdt {

/// Result of verify(): no problems means the triangulation is a valid CDT of the input.
struct VerifyReport {
  /// Human-readable descriptions naming the triangles, edges, vertices or segments involved; only the
  /// first kMaxKept problems are kept.
  std::vector<std::string> problems;
  /// The total number of problems found (may exceed problems.size()).
  std::size_t num_problems = 0;
  static constexpr std::size_t kMaxKept = 20;
  bool ok() const noexcept { return num_problems == 0; }
};

/// Checks that t is a constrained Delaunay triangulation of points and segments, as triangulate()
/// documents it: consistent sizes and indices, input points kept bit for bit, counter-clockwise
/// non-degenerate triangles, symmetric neighbour links and constraint flags, a domain equal to the
/// convex hull (one convex boundary cycle, Euler characteristic 1, no vertex outside), a valid duplicate
/// map with every representative used, every segment present as a chain of collinear constraint edges,
/// and every non-constraint edge locally Delaunay, with ties among co-circular points broken as
/// triangulate() breaks them (the perturbed incircle test), so that only the unique CDT passes. Exact
/// predicates throughout; O(n log n) time for n triangles, vertices and segments. Never throws on malformed t
/// (beyond std::bad_alloc).
///
/// One tolerance: a segment split at a crossing point that is not a double is bent through the rounded
/// point, so a chain that is not straight is accepted when every vertex on it lies within
/// 1024 * 2^-53 * (the largest coordinate magnitude of t.vertices) of the segment and of its bounding box.
///
/// threads: the checks' threads (the report is the same for any number); 0 uses every hardware thread
/// from 16384 triangles on and the calling thread alone below.
VerifyReport verify(const Triangulation& t, std::span<const Point> points, std::span<const Segment> segments,
                    unsigned threads = 0);

} // namespace cdt
