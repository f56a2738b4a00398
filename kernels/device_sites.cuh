#pragma once
// The state of gpu::DeviceSites, shared by the files that read it: the sites are prepared in
// sites_kernels.cu, their grid cells go to the digital Voronoi diagram (voronoi_kernels.cu), their
// positions to the dual (dual_kernels.cu) and to shifting (mesh_kernels.cu).

#include <cstdint>

#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"
#include "gcd/constraints.hpp"
#include "gcd/mesh.hpp"

namespace cdt::gpu {

namespace detail {

/// A bounding box; extended point by point.
struct Extent {
  double min_x, min_y, max_x, max_y;

  __host__ __device__ void add(double x, double y) {
    min_x = x < min_x ? x : min_x;
    min_y = y < min_y ? y : min_y;
    max_x = x > max_x ? x : max_x;
    max_y = y > max_y ? y : max_y;
  }
  __host__ __device__ void add(const Extent& e) {
    add(e.min_x, e.min_y);
    add(e.max_x, e.max_y);
  }
};

/// The box of the points (x[i], y[i]) and, when x2 is given, (x2[i], y2[i]), i in [0, n), n >= 1: a
/// block's part each on the device, the parts merged on the host (waits for them).
Extent box_of(CudaExecutor& executor, std::size_t n, const double* x, const double* y,
              const double* x2 = nullptr, const double* y2 = nullptr);

/// The box of the interleaved points xy[i], i in [0, n), n >= 1 (a mesh's vertices).
Extent box_of(CudaExecutor& executor, std::size_t n, const ::cdt::detail::Vec2* xy);

} // namespace detail

struct DeviceSites::State {
  /// Declared first: destroyed after the buffers queued on its stream. Mutable: copies to the host
  /// from a const DeviceSites queue on it.
  mutable detail::CudaExecutor executor;
  std::uint32_t n = 0;  ///< sites
  std::uint32_t m = 0;  ///< grid side
  double magnitude = 0; ///< the largest absolute coordinate of the sites (after prepare)
  /// Until prepare: the vertices (x, y pairs) and the sites' vertex ids (empty when every vertex is a
  /// site, in order).
  std::size_t num_vertices = 0;
  detail::DeviceBuffer<double> vertex_xy;
  detail::DeviceBuffer<std::uint32_t> site_list;
  detail::DeviceBuffer<double> true_x, true_y;     ///< per site (in the Z order), its true position
  detail::DeviceBuffer<double> x, y;               ///< per site, its position in the diagram
  detail::DeviceBuffer<std::uint8_t> kept;         ///< per site, 1 while it is a site of the diagram
  detail::DeviceBuffer<std::uint32_t> site_vertex; ///< per site, its vertex (the host's site_vertex)
  /// Per site its grid cell, and per cell (row-major) its kept site or kNone; DeviceVoronoi takes them.
  detail::DeviceBuffer<std::uint32_t> gx, gy, cell_owner;
  /// The missing points prepare() left on the device (MissingTo::device), until a mesh takes them.
  detail::DeviceBuffer<::cdt::detail::MissingPoint> missing;
  /// Per vertex its site, kept on the device until its late copy to the host is done.
  detail::DeviceBuffer<std::uint32_t> site_of_vertex;
  /// The merge's representatives per point and pieces (a, b, segment triples), and site_list above,
  /// kept on the device while merge_late: until their late copies to the host are done (the pieces,
  /// from kMeshPiecesFrom of them, until prepare() has made mesh_pieces).
  detail::DeviceBuffer<std::uint32_t> duplicate_of, pieces;
  bool merge_late = false;
  /// The merge's pieces in mesh ids (site of a, site of b, piece index), as the host makes them for
  /// the constraints from the pieces and site_of_vertex that come down: made by prepare() while both
  /// are on the device, until DeviceMesh::take_pieces takes them (empty when the merge was the host's
  /// or made fewer than 2^16 pieces, which the constraints insert after the split).
  detail::DeviceBuffer<::cdt::detail::ConstraintPiece2> mesh_pieces;
  /// The copies of site_vertex and site_of_vertex to the host (see DeviceSites::prepare). Declared
  /// last: they are waited for before the buffers above go.
  detail::LateDownloads late;
};

} // namespace cdt::gpu
