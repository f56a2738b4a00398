#pragma once
// Phase 1 of gCD, first half (paper section 3.1 and Appendix B): the mapping of the input points onto
// an m x m grid, and the grid sites (one kept point per occupied grid cell, the others "missing").
//
// The mapping is chosen so that its inverse is exact: gx * scale + tx is a double computed without
// rounding for every grid coordinate gx in [0, m). Phase 3 moves every kept point from that grid
// position to its true position; if the grid position itself were rounded, the triangulation dualized
// from the grid could already be invalid before any shifting starts (Appendix B).

#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "cdt/cdt.hpp"
#include "cdt/detail/host_device.hpp"

namespace cdt::detail {

class CpuExecutor;

/// Largest grid side accepted: cell indices gy * m + gx and the packed (row, column) pairs of the
/// Voronoi phase need 16 bits per coordinate, and one m x m uint32 array is then already 4 GiB.
inline constexpr std::uint32_t kMaxGridSize = 32768;

/// Scale and translation that map input coordinates onto an m x m grid such that
/// gx * scale + tx is computed without rounding error for every grid coordinate gx in [0, m).
struct GridMapping {
  std::uint32_t m = 0;
  double scale = 0, tx = 0, ty = 0; ///< one scale for both axes (the larger extent), per-axis translation

  /// Exact grid-point position: gx * scale + tx (no rounding, by construction). gx < m.
  CDT_HD double to_x(std::uint32_t gx) const { return static_cast<double>(gx) * scale + tx; }
  CDT_HD double to_y(std::uint32_t gy) const { return static_cast<double>(gy) * scale + ty; }

  /// Grid cell of a coordinate: floor((x - tx) / scale) clamped to [0, m-1] (the paper's "nearest lower
  /// left grid point"). Evaluated exactly: the result g is the largest g in [0, m) with to_x(g) <= x,
  /// or 0 when x < tx, so a kept point never sits left of or below its grid point.
  CDT_HD std::uint32_t grid_x(double x) const { return grid_coordinate(x, tx); }
  CDT_HD std::uint32_t grid_y(double y) const { return grid_coordinate(y, ty); }

private:
  CDT_HD std::uint32_t grid_coordinate(double v, double t) const {
    // The quotient is only an estimate (two roundings); the exact grid positions correct it by at
    // most a step or two. NaN compares false everywhere and lands on 0.
    const double q = (v - t) / scale;
    std::uint32_t g = 0;
    if (q >= static_cast<double>(m - 1)) {
      g = m - 1;
    } else if (q > 0.0) {
      g = static_cast<std::uint32_t>(q);
    }
    while (g > 0 && static_cast<double>(g) * scale + t > v) --g;
    while (g + 1 < m && static_cast<double>(g + 1) * scale + t <= v) ++g;
    return g;
  }
};

/// The low 16 bits of v spread to the even bit positions.
CDT_HD inline std::uint32_t spread_low_bits(std::uint32_t v) {
  v &= 0xFFFFu;
  v = (v | (v << 8)) & 0x00FF00FFu;
  v = (v | (v << 4)) & 0x0F0F0F0Fu;
  v = (v | (v << 2)) & 0x33333333u;
  v = (v | (v << 1)) & 0x55555555u;
  return v;
}

/// The index of grid cell (gx, gy) along a Z curve: the bits of gx and gy interleaved (gx in the even
/// positions). Grid coordinates have at most 15 bits (kMaxGridSize), so keys have at most 30.
CDT_HD inline std::uint32_t z_order_key(std::uint32_t gx, std::uint32_t gy) {
  return spread_low_bits(gx) | (spread_low_bits(gy) << 1);
}

/// Which executor a grid is chosen for (choose_grid_size).
enum class GridFor {
  device,      ///< the CUDA executor: the paper's rounds for every phase
  host,        ///< the CPU executor: missing points inserted by parts with Lawson's algorithm
  host_points, ///< the CPU executor on points without segments
};

/// Grid side for num_points input points: a power of two clamped to [256, 8192] for the device and
/// [32, 8192] for the host. For the device, the smallest one >= sqrt(num_points), between one and four
/// cells per point, up to 2048; past that, half of it, between 1/4 and 1 cell per point. The paper finds
/// larger grids better for larger inputs on its GPU (fewer missing points, section 5.1.1), as
/// Algorithm 3's rounds are the device's slowest way to place a point; but on the H200 machine a grid
/// of 4096^2 cells costs more in the digital Voronoi diagram and the dual than the missing points it
/// spares (medians of 3: uniform 10M + 1M 138-142 ms at 2048 against 154-157 at 4096, 10M points 92.8
/// against 94.1; 8192 was slower still), while below it the finer grid stays the better one on
/// clustered input (the GSHHG coastlines 58.2-58.4 ms at 2048 against 60.1-65.0 at 1024, Gaussian 1M +
/// 100K 33.0-34.7 at 1024 against 35.3-36.2 at 512). For the host, the smallest one >=
/// sqrt(num_points / 8), between 1/8 and 1/2 cell per point: there the parts insert a missing point
/// with its flips at about the cost of placing it in the diagram, dualizing and shifting it, so a
/// coarser grid that leaves more points missing is cheaper in all (measured on 2 cores: 1M uniform
/// points 1111 -> 941 ms at grid 512 instead of 1024, the GSHHG coastlines 3194 -> 2727 ms at 512
/// instead of 2048; 256 and 128 no better on the second). Points without segments go coarser still,
/// sqrt(num_points / 16): their mesh is not compacted after the fake boundary's removal (nothing walks
/// it afterwards), which makes the insertion cheaper again (measured on 2 cores: 1M uniform points
/// 762-851 -> 683-754 ms at 256 instead of 512, 10M 10326-13818 -> 9195-9620 ms at 1024 instead of
/// 2048; with 100K segments 512 stayed better). Small inputs, such as vectorize's PSLGs of 10-25K
/// points, go down to 32 on the host: the CDT of the 12 Kodak photographs' PSLGs took 338 ms in all at
/// 256, 251 at 64 and 233 at 32 on one core (the smallest grid that sqrt(n / 8) allows; 256 before),
/// with the same rendering quality. The grid arrays stay within 256 MiB at m = 8192.
std::uint32_t choose_grid_size(std::size_t num_points, GridFor target = GridFor::device);

/// Appendix B mapping of the points (x[i], y[i]) onto an m x m grid, 1 <= m <= kMaxGridSize.
/// scale is rounded up so that its mantissa has at most 52 - bit_width(m - 1) bits (gx * scale is then
/// exact) and scale and both translations are multiples of one power of two small enough that every
/// gx * scale + t fits in 53 bits (Case 1: the translation loses its low bits; Case 2: a translation
/// much larger than the extent rounds the scale up instead). Every point maps into [0, m); the points'
/// bounding box fits in the grid up to a rounding of the scale (points beyond it are clamped).
/// Throws InvalidInputError for a non-finite coordinate and Error for m outside [1, kMaxGridSize].
GridMapping make_grid_mapping(std::span<const double> x, std::span<const double> y, std::uint32_t m);

/// The same, the points' bounding box found on the executor's threads.
GridMapping make_grid_mapping(std::span<const double> x, std::span<const double> y, std::uint32_t m,
                              CpuExecutor& executor);

/// The same mapping from the points' bounding box [x_min, x_max] x [y_min, y_max] (finite), found
/// elsewhere (on the device, say).
GridMapping grid_mapping_of_box(double x_min, double x_max, double y_min, double y_max, std::uint32_t m);

/// How far (x, y) lies from the grid point of its cell (gx, gy), as a key that orders points by their
/// squared distance from it: the high half of the bits of that distance (a non-negative double, whose
/// bits order as its values do). Kept points are moved from their grid points to their true positions
/// (Phase 3), and the shorter the move, the fewer triangles it turns over (Algorithm 2's bad cases).
/// The same value on the host and the device: the library is built without contraction
/// (-ffp-contract=off, --fmad=false), so each operation is rounded once on both.
CDT_HD inline std::uint32_t grid_point_distance_key(const GridMapping& mapping, double x, double y,
                                                    std::uint32_t gx, std::uint32_t gy) {
  const double dx = x - mapping.to_x(gx);
  const double dy = y - mapping.to_y(gy);
  const double d = dx * dx + dy * dy;
#if defined(__CUDA_ARCH__)
  const auto bits = static_cast<std::uint64_t>(__double_as_longlong(d));
#else
  const auto bits = std::bit_cast<std::uint64_t>(d);
#endif
  return static_cast<std::uint32_t>(bits >> 32);
}

/// The grid sites of Phase 1: each input point's grid cell and the one point kept per occupied cell.
struct GridSites {
  std::vector<std::uint32_t> gx, gy;     ///< per input point
  std::vector<std::uint32_t> cell_owner; ///< m*m, row-major (gy*m+gx): the point kept there, kNone if empty
  std::vector<std::uint32_t> missing; ///< points not kept because another point had the same cell, increasing
  std::vector<std::uint32_t> missing_owner; ///< for each missing point, the kept point of its cell
};

/// Maps every point to its grid cell; of a cell's points the one nearest its grid point is kept
/// (grid_point_distance_key; the lowest index among equal keys), by atomic minima, so the result does
/// not depend on thread timing, and the others become missing points. Fewer than 2^32 - 1
/// points (kNone is the empty-cell sentinel).
GridSites assign_sites(const GridMapping& mapping, std::span<const double> x, std::span<const double> y,
                       CpuExecutor& executor);

} // namespace cdt::detail
