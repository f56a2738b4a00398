#pragma once
// Stage 8 of the pipeline: trixel grouping (after Prasad and Skourikhine, "Vectorized image
// segmentation via trixel agglomeration", Pattern Recognition 39(4), 2006, sec. 3): adjacent triangles
// of similar colour that are not separated by a detected edge (a constraint) form one region.

#include <array>
#include <cstdint>
#include <vector>

#include "cdt/cdt.hpp"
#include "vectorize/trixels.hpp"

namespace vectorize {

/// Options of group_trixels(), in human units.
struct GroupingOptions {
  /// Largest colour difference, as CIE76 Delta E (Euclidean distance in CIELAB, D65, from sRGB), at
  /// which two regions are joined across a non-constraint edge. About 2.3 is a just-noticeable
  /// difference; 0 joins only identical colours.
  double colour_tolerance = 10.0;
  /// Regions smaller than this (square pixels) are merged into their closest-colour neighbour of the
  /// same transparency, across any edge; 0 keeps every region.
  double min_region_area = 4.0;
};

/// One region: a set of triangles connected through edges.
struct Region {
  /// Area-weighted mean of the trixels' RGB, non-premultiplied sRGB in [0, 1].
  std::array<float, 3> rgb{};
  /// Sum of the triangles' areas, square pixels.
  double area = 0.0;
  std::uint32_t triangle_count = 0;
  /// A "no shape" region made of transparent trixels; it is not drawn.
  bool transparent = false;
  /// Area-weighted mean of the trixels' alpha: from 0.5 to 1 for a region that is drawn.
  float alpha = 1.0f;
  /// Whether a triangle of the region covers part of a solid pixel (Trixel::covers_solid): the region
  /// is then drawn without opacity.
  bool covers_solid = false;
};

/// The result of group_trixels().
struct Regions {
  /// Region id of each triangle, indexed like Triangulation::triangles.
  std::vector<std::uint32_t> region_of_triangle;
  /// Region ids are dense, numbered in the order of each region's lowest triangle index.
  std::vector<Region> regions;
};

/// Groups the triangles of t into regions.
///
/// Colour differences below are Delta E plus 100 times the difference in alpha, so that a translucent
/// area (alpha between 0.5 and 1) does not join a solid one of the same colour.
/// 1. Join: edges between opaque trixels that are not constraints are visited in increasing order of
///    the Delta E between their two trixels (ties by triangle, then edge index); the regions on both
///    sides are joined when the Delta E between the regions' current mean colours is within
///    options.colour_tolerance. Comparing region means rather than trixel pairs keeps a slow gradient
///    from chaining into one region. Transparent trixels join each other across every edge (their
///    colour means nothing, and constraints between them come from hidden colour) and never join
///    opaque ones.
/// 2. Merge: while some region is smaller than options.min_region_area, the smallest (ties by lowest
///    id) is merged into the neighbour, across any edge, of the same transparency whose colour is
///    closest (ties by lowest triangle index); a region with no such neighbour stays.
/// Deterministic: the colours and the sorted candidates are computed on up to `threads` threads (0:
/// every hardware thread) with the same result for any number. Preconditions: trixels.size() ==
/// t.triangles.size(); t as triangulate() returns it. Time O(n log n) for n triangles.
/// `lab`, when given and not empty, holds the trixels' CIELAB where it is known already (colour_trixels
/// with TrixelDevice::gpu makes it); the others' are made here.
Regions group_trixels(const cdt::Triangulation& t, const TrixelColours& trixels,
                      const GroupingOptions& options = {}, unsigned threads = 1,
                      const TrixelLab* lab = nullptr);

/// CIELAB (D65 white) of a non-premultiplied sRGB colour with channels in [0, 1].
std::array<double, 3> srgb_to_lab(const std::array<float, 3>& rgb);

/// CIE76 Delta E: the Euclidean distance between two CIELAB colours.
double delta_e(const std::array<double, 3>& lab1, const std::array<double, 3>& lab2);

} // namespace vectorize
