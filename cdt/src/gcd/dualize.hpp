#pragma once
// Phase 2 of gCD (paper section 3.2): the triangulation dual to the amended digital Voronoi diagram,
// completed to a convex hull and enclosed by a fake boundary.

#include <cstdint>
#include <span>
#include <vector>

#include "gcd/mesh.hpp"

namespace cdt::detail {

class CpuExecutor;

/// Axis-aligned box.
struct Box {
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;
};

struct DualizeStats {
  std::uint64_t dual_triangles = 0; ///< triangles from 3- and 4-colour grid corners
  std::uint64_t hull_triangles = 0; ///< triangles added to make the hull convex
  std::uint32_t fake_vertices = 0;  ///< size of the fake boundary
};

/// Builds the phase-2 mesh.
///
/// colour: m * m site indices (row-major, gy * m + gx), every grid point coloured, each colour region
/// connected (the Standard-flooding result of phase 1). x, y: per site its current position: the
/// exact grid position for sites that own a grid point (kept[i] != 0), anything for the others.
/// bounds: a box containing every position the sites will take (grid and true positions).
///
/// Returns a mesh whose vertices 0..n-1 are the sites (sites that are not kept have vert_tri == kNoId)
/// and n..n+k-1 the fake boundary: a convex polygon of about sqrt(hull size) vertices, far enough out
/// that every site position is strictly inside. All triangles are counter-clockwise. When the dual has
/// no triangle (fewer than three kept sites, or all of them collinear) the mesh is the fake polygon
/// alone and every site is left for missing-point insertion.
///
/// A grid corner can give a triangle that is not counter-clockwise: three collinear sites meeting at a
/// corner (ties on a lattice do this), which the diagram's validity argument does not cover. With
/// `degenerate` given, dualize then returns an empty mesh and lists there the sites to take out of the
/// diagram (remove_sites_from_colouring) before trying again; without it, it falls back to the fake
/// polygon alone.
Mesh dualize(std::span<const std::uint32_t> colour, std::uint32_t m, std::span<const double> x,
             std::span<const double> y, std::span<const std::uint8_t> kept, const Box& bounds,
             CpuExecutor& executor, DualizeStats* stats = nullptr,
             std::vector<std::uint32_t>* degenerate = nullptr);

} // namespace cdt::detail
