#pragma once
// Phase 2 of gCD (paper section 3.2): the triangulation dual to the amended digital Voronoi diagram,
// completed to a convex hull and enclosed by a fake boundary.

#include <cstdint>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "box.hpp"
#include "cdt/cdt.hpp"
#include "cdt/detail/host_device.hpp"
#include "cdt/detail/predicates.hpp"
#include "gcd/mesh.hpp"

namespace cdt::detail {

class CpuExecutor;

/// A dual triangle: three site indices, counter-clockwise.
struct DualTriangle {
  std::uint32_t a, b, c;
};

/// Per site a flag (1: kept in the diagram), with the allocator of the triangulation's large arrays
/// (cdt.hpp): sized without a zero fill where every flag is then written.
using FlagArray = std::vector<std::uint8_t, DefaultInitAllocator<std::uint8_t>>;

struct DualizeStats {
  std::uint64_t dual_triangles = 0; ///< triangles from 3- and 4-colour grid corners
  std::uint64_t hull_triangles = 0; ///< triangles added to make the hull convex
  std::uint32_t fake_vertices = 0;  ///< size of the fake boundary
};

/// The dual triangles of a colouring by row of grid corners (row r: the corners between cell rows r
/// and r + 1), as dualize found them, for a later call to reuse.
struct DualCorners {
  std::vector<std::vector<DualTriangle>> per_row;
  std::vector<std::uint8_t> invalid;                ///< per row: a corner gave no valid triangles
  std::vector<std::vector<std::uint32_t>> culprits; ///< per row: the sites its invalid corners name
  std::vector<std::uint8_t> stale;                  ///< per row: to recompute; empty = every row

  /// Marks the rows of the corners around each recoloured cell (cell = y * m + x) stale.
  void mark_changed(std::span<const std::uint32_t> cells, std::uint32_t m);
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
///
/// `corners` (optional) keeps the dual triangles of every row of grid corners from one call to the
/// next: a call after remove_sites_from_colouring then recomputes only the rows marked stale (the rows
/// of corners that touch a recoloured cell), where a full pass costs a scan of the whole grid.
Mesh dualize(std::span<const std::uint32_t> colour, std::uint32_t m, std::span<const double> x,
             std::span<const double> y, std::span<const std::uint8_t> kept, const Box& bounds,
             CpuExecutor& executor, DualizeStats* stats = nullptr,
             std::vector<std::uint32_t>* degenerate = nullptr, DualCorners* corners = nullptr);

/// Appends to out the sites to take out of the diagram for an invalid corner (corner_triangles returned
/// -1): the middle one of three collinear sites (the diagram degenerates there), else every site of the
/// corner.
void corner_culprits(const std::uint32_t q[4], const double* x, const double* y,
                     std::vector<std::uint32_t>& out);

/// Room for the triangulation of n sites with the fake boundary (2 n + k - 2 triangles for k fake
/// vertices, at most about sqrt(n) of them) and an eighth more, so that hull completion and Phase 4
/// append slots without reallocating: the slots Algorithm 2 frees stay in the array, and the CPU
/// executor's Phase 4 appends two slots per missing point after them (1-2% over 2 n on uniform
/// points and the coastlines). Pages past the used part are never touched, so this costs address space
/// only.
void reserve_mesh_slots(Mesh& mesh, std::uint32_t n);

/// A boundary edge of a linked mesh: its encoded id and its ends, counter-clockwise around the mesh.
struct OpenEdge {
  std::uint32_t edge;
  std::uint32_t from;
  std::uint32_t to;
};

/// What completes a dual: hull completion and the fake boundary (the second half of dualize), worked
/// out from the dual's open edges alone, so that it applies alike to a mesh on the host and one on the
/// device. The dual has n sites and num_dual slots; what is added comes after them.
struct DualCompletion {
  std::vector<Vec2> fake;              ///< the fake boundary's vertices, numbered n, n + 1, ...
  std::vector<DualTriangle> triangles; ///< in slots num_dual, num_dual + 1, ...
  std::vector<std::uint32_t> adj;      ///< 3 per added triangle
  /// (open edge of the dual, the added edge now across it)
  std::vector<std::pair<std::uint32_t, std::uint32_t>> links;
  std::vector<std::uint32_t> fake_vert_tri; ///< per fake vertex, its first added triangle
  std::uint64_t hull_triangles = 0;
};

/// Plans the completion of a dual from its open edges (in increasing edge order) and the sites'
/// positions xy (the n sites as the dual has them). std::nullopt when the open edges are not one simple
/// cycle: then only the fake polygon alone can start the mesh. Throws Error when the added triangles
/// do not pair up with the open edges (not a valid dual).
std::optional<DualCompletion> plan_dual_completion(std::span<const OpenEdge> open, std::span<const Vec2> xy,
                                                   std::uint32_t num_dual, const Box& bounds);

/// The same, given only the positions of the open edges' first vertices: open[k].from is at (open_x[k],
/// open_y[k]) (each boundary vertex is the first of one open edge); n: the number of sites.
std::optional<DualCompletion> plan_dual_completion(std::span<const OpenEdge> open,
                                                   std::span<const double> open_x,
                                                   std::span<const double> open_y, std::uint32_t n,
                                                   std::uint32_t num_dual, const Box& bounds);

/// Throws Error when a site that is not kept (a missing point) has a triangle in the dual: vert_tri
/// holds at least the sites' entries.
void check_missing_sites_left_out(std::span<const std::uint8_t> kept, std::span<const std::uint32_t> vert_tri,
                                  CpuExecutor& executor);

/// The second half of dualize, for a mesh whose dual triangles are in place and linked (slots ordered
/// by their lowest vertex, vert_tri the highest incident slot, as dualize leaves them; the CUDA
/// executor builds that part on the device): completes the hull, adds the fake boundary and links it.
/// mesh.x, mesh.y hold the n sites. Falls back to the fake polygon alone, like dualize, when the
/// dual's boundary is not one simple cycle.
Mesh complete_dual(Mesh mesh, std::span<const std::uint8_t> kept, const Box& bounds, CpuExecutor& executor,
                   DualizeStats* stats = nullptr);

// --- per-element work (host and device) --------------------------------------------------------------

/// Triangles dual to the grid corner whose four cells, counter-clockwise from the lower left, have
/// colours q[0..3]. Writes 0, 1 or 2 triangles into out; returns their number, or -1 when the corner
/// would give a triangle that is not counter-clockwise (not the dual of a valid diagram).
CDT_HD inline int corner_triangles(const std::uint32_t q[4], const double* x, const double* y,
                                   DualTriangle out[2]) {
  const auto orient = [x, y](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    return orient2d(x[a], y[a], x[b], y[b], x[c], y[c]);
  };
  // Remove cyclically repeated neighbours: the regions around the corner in counter-clockwise order.
  std::uint32_t ring[4];
  int n = 0;
  for (int k = 0; k < 4; ++k) {
    if (q[k] != q[(k + 3) % 4]) ring[n++] = q[k];
  }
  if (n < 3) return 0;
  if (n == 3) {
    if (orient(ring[0], ring[1], ring[2]) <= 0) return -1;
    out[0] = {ring[0], ring[1], ring[2]};
    return 1;
  }
  // A colour touching the corner from two diagonal cells separates the other two there: they are not
  // Voronoi neighbours at this corner, so it is no Voronoi vertex.
  if (ring[0] == ring[2] || ring[1] == ring[3]) return 0;
  if (orient(ring[0], ring[1], ring[2]) > 0 && orient(ring[0], ring[2], ring[3]) > 0) {
    out[0] = {ring[0], ring[1], ring[2]};
    out[1] = {ring[0], ring[2], ring[3]};
    return 2;
  }
  if (orient(ring[1], ring[2], ring[3]) > 0 && orient(ring[1], ring[3], ring[0]) > 0) {
    out[0] = {ring[1], ring[2], ring[3]};
    out[1] = {ring[1], ring[3], ring[0]};
    return 2;
  }
  return -1;
}

/// The grid corner's four colours, counter-clockwise from the lower left cell (gx, gy); the corner is
/// the point shared by cells (gx, gy) and (gx + 1, gy + 1) of the m x m colouring.
CDT_HD_INLINE void corner_colours(const std::uint32_t* colour, std::uint32_t m, std::uint32_t gx,
                                  std::uint32_t gy, std::uint32_t q[4]) {
  const std::size_t lo = static_cast<std::size_t>(gy) * m + gx;
  const std::size_t hi = lo + m;
  q[0] = colour[lo];
  q[1] = colour[lo + 1];
  q[2] = colour[hi + 1];
  q[3] = colour[hi];
}

} // namespace cdt::detail
