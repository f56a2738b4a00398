#pragma once
// Long walks in parts. A segment's walk through the mesh (the screen's corridors, Algorithm 4's piece
// walks) is one thread's chain of dependent loads, a few a triangle, so a step that walks every piece
// lasts as long as its longest walk: on the H200 machine 7.46 ms for the six piece walks at 10M points
// + 100K segments, the same as with 1M segments (7.1), and 4.97 ms for the corridors' walk with either
// (pieces up to half the square long cross over a thousand triangles). A piece longer than kPartSteps
// times the vertices' spacing is walked in parts instead, each from a point of the piece on
// (walk_entry), located by a straight walk from a vertex in its cell of a grid (WalkHints), and ending
// where the next part starts. Parts found out of order (a located triangle met before an earlier
// one's) have their piece walked whole again.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "cuda_check.cuh"
#include "cuda_executor.cuh"
#include "device_sites.cuh"
#include "gcd/constraints.hpp"
#include "gcd/insert.hpp"
#include "gcd/mesh.hpp"

namespace cdt::gpu::detail {

/// Triangles a part walks, about. 24 against 48 at 10M points + 1M segments (H200 machine): the
/// screen's walks 1.5 ms shorter, the constraints' the same (more pieces walked whole again).
inline constexpr double kPartSteps = 24.0;
/// At most this many parts a piece.
inline constexpr std::uint32_t kMaxParts = 256;

/// The grid of hints: per cell of a side x side grid over the vertices' box, a vertex in it (any one)
/// or kNoId; and the length of a part.
struct WalkHints {
  double x0 = 0, y0 = 0, inverse_cell = 0;
  std::uint32_t side = 0;
  const std::uint32_t* cell = nullptr;
  double part_length = 0;       ///< 0: no parts
  double width = 0, height = 0; ///< the vertices' box (0 x 0 for fewer than 3 vertices)

  __device__ std::uint32_t cell_of(double x, double y) const {
    const double cx = (x - x0) * inverse_cell, cy = (y - y0) * inverse_cell;
    const auto clamp = [&](double v) {
      return v <= 0.0 ? 0u : v >= side - 1 ? side - 1 : static_cast<std::uint32_t>(v);
    };
    return clamp(cy) * side + clamp(cx);
  }
  /// How many parts the walk of piece a -> b is cut into.
  __device__ std::uint32_t parts_of(const ::cdt::detail::MeshView& m, std::uint32_t a,
                                    std::uint32_t b) const {
    if (part_length <= 0.0) return 1;
    const ::cdt::detail::Vec2 pa = m.xy[a], pb = m.xy[b];
    const double dx = pb.x - pa.x, dy = pb.y - pa.y;
    const double parts = sqrt(dx * dx + dy * dy) / part_length;
    return parts < 1.0 ? 1u : parts >= kMaxParts - 1 ? kMaxParts : 1u + static_cast<std::uint32_t>(parts);
  }
};

/// Builds the hints for the vertices of m into `cells` (waits for the vertices' box): side about half
/// the square root of the vertices; no parts when the box is a point.
WalkHints make_walk_hints(CudaExecutor& executor, const ::cdt::detail::MeshView& m,
                          DeviceBuffer<std::uint32_t>& cells);

/// Where a part starts: a triangle (kNoId: the point was not usable, the part before walks on) and
/// how the piece enters it.
struct PartStart {
  std::uint32_t tri;
  ::cdt::detail::WalkEntry at;
};

/// The first usable start among parts [from, end), kNoId when none.
__device__ inline std::uint32_t first_usable(const PartStart* part_start, std::uint32_t from,
                                             std::uint32_t end) {
  for (std::uint32_t u = from; u < end; ++u)
    if (part_start[u].tri != ::cdt::detail::kNoId) return part_start[u].tri;
  return ::cdt::detail::kNoId;
}

/// The parts of the long pieces among n, for the kernels: the long pieces (their indices k among the
/// n), for each its parts after the first, [long_first[l], end_of(l)), each with its piece (l) and its
/// start; per piece k, the start of its second part (first_stop, kNoId when none or not long).
struct WalkPartsView {
  std::uint32_t num_long = 0, num_parts = 0;
  const std::uint32_t* longs = nullptr;
  const std::uint32_t* long_first = nullptr;
  const std::uint32_t* part_of = nullptr;
  const PartStart* part_start = nullptr;
  const std::uint32_t* first_stop = nullptr;

  __device__ std::uint32_t end_of(std::uint32_t l) const {
    return l + 1 < num_long ? long_first[l + 1] : num_parts;
  }
  /// Where part u ends: the next usable start of its piece, kNoId at b.
  __device__ std::uint32_t stop_after(std::uint32_t u) const {
    return first_usable(part_start, u + 1, end_of(part_of[u]));
  }
  /// Where piece k's first part, from a, ends.
  __device__ std::uint32_t first_stop_of(std::size_t k) const {
    return first_stop != nullptr ? first_stop[k] : ::cdt::detail::kNoId;
  }
};

/// The buffers of WalkPartsView, kept from call to call.
struct WalkParts {
  DeviceBuffer<std::uint32_t> longs, long_first, part_of, first_stop;
  DeviceBuffer<PartStart> part_start;
};

/// Finds the long pieces among k in [0, n) with wanted(k) (ends(k) their ConstraintPiece2), their parts
/// and where the parts start; waits for the counts. An empty view when there are none.
template <class Ends, class Wanted>
WalkPartsView plan_walk_parts(CudaExecutor& executor, const ::cdt::detail::MeshView& m,
                              const WalkHints& hints, std::uint32_t n, Ends ends, Wanted wanted,
                              WalkParts& buffers) {
  using ::cdt::detail::ConstraintPiece2;
  using ::cdt::detail::kNoId;
  WalkPartsView v;
  if (hints.part_length <= 0.0 || n == 0) return v;
  buffers.longs.resize(n);
  v.num_long = executor.compact(
      n,
      [=] __device__(std::size_t k) {
        if (!wanted(k)) return false;
        const ConstraintPiece2 p = ends(k);
        return hints.parts_of(m, p.a, p.b) > 1;
      },
      buffers.longs.data());
  if (v.num_long == 0) return WalkPartsView{};
  const std::uint32_t num_long = v.num_long;
  const std::uint32_t* longs = buffers.longs.data();
  buffers.long_first.resize(num_long);
  std::uint32_t* long_first = buffers.long_first.data();
  executor.for_each(
      num_long,
      [=] __device__(std::size_t l) {
        const ConstraintPiece2 p = ends(longs[l]);
        long_first[l] = hints.parts_of(m, p.a, p.b) - 1; // the parts after the first
      },
      "long_pieces");
  const std::uint32_t num_parts = executor.exclusive_scan(long_first, num_long);
  buffers.part_of.resize(num_parts);
  buffers.part_start.resize(num_parts);
  std::uint32_t* part_of = buffers.part_of.data();
  PartStart* part_start = buffers.part_start.data();
  executor.for_each(
      num_long,
      [=] __device__(std::size_t l) {
        const std::uint32_t end = l + 1 < num_long ? long_first[l + 1] : num_parts;
        for (std::uint32_t u = long_first[l]; u < end; ++u) part_of[u] = static_cast<std::uint32_t>(l);
      },
      "part_pieces");
  executor.for_each(
      num_parts,
      [=] __device__(std::size_t u) {
        const std::uint32_t l = part_of[u];
        const ConstraintPiece2 p = ends(longs[l]);
        const std::uint32_t end = l + 1 < num_long ? long_first[l + 1] : num_parts;
        const std::uint32_t parts = end - long_first[l] + 1;
        const double along = static_cast<double>(u - long_first[l] + 1) / parts;
        const double px = m.xy[p.a].x + along * (m.xy[p.b].x - m.xy[p.a].x);
        const double py = m.xy[p.a].y + along * (m.xy[p.b].y - m.xy[p.a].y);
        PartStart start{kNoId, {}};
        const std::uint32_t from = hints.cell[hints.cell_of(px, py)];
        if (from != kNoId) {
          const ::cdt::detail::PointLocation loc = ::cdt::detail::locate_point(m, from, px, py);
          if (loc.status == ::cdt::detail::WorkStatus::ok &&
              ::cdt::detail::walk_entry(m, p.a, p.b, loc.tri, start.at))
            start.tri = loc.tri;
        }
        part_start[u] = start;
      },
      "locate_parts");
  buffers.first_stop.resize(n);
  std::uint32_t* first_stop = buffers.first_stop.data();
  executor.fill_bytes(first_stop, 0xFF, n);
  executor.for_each(
      num_long,
      [=] __device__(std::size_t l) {
        const std::uint32_t end = l + 1 < num_long ? long_first[l + 1] : num_parts;
        first_stop[longs[l]] = first_usable(part_start, long_first[l], end);
      },
      "first_stops");
  v.num_parts = num_parts;
  v.longs = longs;
  v.long_first = long_first;
  v.part_of = part_of;
  v.part_start = part_start;
  v.first_stop = first_stop;
  return v;
}

} // namespace cdt::gpu::detail
