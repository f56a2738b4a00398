// Phase 1's first half on the device: the steps cdt::triangulate runs on the host before the digital
// Voronoi diagram (the merge of duplicate points, the sites' coordinates, the grid mapping's box, the Z
// order, the renumbering, the grid cells with their owners, the kept sites and the box of every position),
// each the same computation, so the numbering, the cells and the missing points are the host's. The positions
// and cells stay on the device; only the numbering, the kept flags and the missing points come back.

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <numeric>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "cdt/detail/trace.hpp"
#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"
#include "device_sites.cuh"
#include "gcd/dualize.hpp"
#include "gcd/grid_map.hpp"
#include "gcd/mesh.hpp"
#include "gcd/shift.hpp"
#include "pslg.hpp"

namespace cdt::gpu {

using ::cdt::detail::GridMapping;
using ::cdt::detail::kNoId;
using ::cdt::detail::MissingArray;
using ::cdt::detail::MissingPoint;

namespace detail {
namespace {

/// The merge's maps and pieces, and the vertex maps, of at least this many bytes come down on a thread
/// of their own (merge_input_on_device, prepare_sites).
constexpr std::size_t kLateDownloadBytes = std::size_t{4} << 20;
/// From this many pieces prepare() makes their mesh ids on the device (DeviceSites::State::mesh_pieces):
/// as many as cdt::triangulate needs to insert the constraints beside its split.
constexpr std::size_t kMeshPiecesFrom = std::size_t{1} << 16;

constexpr unsigned kBoxThreads = 256;
constexpr unsigned kBoxBlocks = 256;

/// Per block, the box of the points (x[k i], y[k i]) and, when x2 is given, (x2[i], y2[i]), over the
/// block's grid-stride share of [0, n), n >= 1 (k = step: 2 for interleaved coordinates).
__global__ void box_kernel(std::size_t n, const double* x, const double* y, std::size_t step,
                           const double* x2, const double* y2, Extent* out) {
  __shared__ Extent part[kBoxThreads];
  Extent e{x[0], y[0], x[0], y[0]};
  const std::size_t stride = static_cast<std::size_t>(gridDim.x) * blockDim.x;
  for (std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x; i < n; i += stride) {
    e.add(x[step * i], y[step * i]);
    if (x2 != nullptr) e.add(x2[i], y2[i]);
  }
  part[threadIdx.x] = e;
  __syncthreads();
  for (unsigned half = kBoxThreads / 2; half > 0; half /= 2) {
    if (threadIdx.x < half) part[threadIdx.x].add(part[threadIdx.x + half]);
    __syncthreads();
  }
  if (threadIdx.x == 0) out[blockIdx.x] = part[0];
}

/// The box of the kBoxBlocks parts of box_kernel, into parts[0] (one block of kBoxThreads threads).
__global__ void box_parts_kernel(Extent* parts) {
  static_assert(kBoxBlocks == kBoxThreads);
  __shared__ Extent part[kBoxThreads];
  part[threadIdx.x] = parts[threadIdx.x];
  __syncthreads();
  for (unsigned half = kBoxThreads / 2; half > 0; half /= 2) {
    if (threadIdx.x < half) part[threadIdx.x].add(part[threadIdx.x + half]);
    __syncthreads();
  }
  if (threadIdx.x == 0) parts[0] = part[0];
}

} // namespace

namespace {

Extent box_of_strided(CudaExecutor& executor, std::size_t n, const double* x, const double* y,
                      std::size_t step, const double* x2, const double* y2) {
  DeviceBuffer<Extent> d_parts(kBoxBlocks);
  box_kernel<<<kBoxBlocks, kBoxThreads, 0, executor.stream()>>>(n, x, y, step, x2, y2, d_parts.data());
  CDT_CUDA_CHECK_LAUNCH("site_box");
  // Merged on the device: one box comes back as a reply (kReplyBytes), which does not queue on the copy
  // engine behind other streams' copies (the constraints' walk hints beside the output started early
  // waited 1.2 ms for the parts' copy on the coastlines).
  box_parts_kernel<<<1, kBoxThreads, 0, executor.stream()>>>(d_parts.data());
  CDT_CUDA_CHECK_LAUNCH("site_box_parts");
  static_assert(sizeof(Extent) <= kReplyBytes);
  Extent all{};
  executor.download(&all, d_parts.data(), 1);
  return all;
}

} // namespace

Extent box_of(CudaExecutor& executor, std::size_t n, const double* x, const double* y, const double* x2,
              const double* y2) {
  return box_of_strided(executor, n, x, y, 1, x2, y2);
}

Extent box_of(CudaExecutor& executor, std::size_t n, const ::cdt::detail::Vec2* xy) {
  static_assert(sizeof(::cdt::detail::Vec2) == 2 * sizeof(double));
  return box_of_strided(executor, n, &xy->x, &xy->y, 2, nullptr, nullptr);
}

namespace {

/// The vertices go up as they are (x, y pairs); the list of sites only when some vertex is not a site
/// (a duplicate).
void upload_vertices(DeviceSites::State& s, std::span<const Point> vertices,
                     std::span<const std::uint32_t> sites, const HostParallelFor& parallel) {
  const std::size_t nv = vertices.size();
  const std::size_t n = sites.size();
  if (n == 0 || n > nv || nv >= kNoId) throw Error("internal error: DeviceSites: no sites, or too many");
  static_assert(sizeof(Point) == 2 * sizeof(double));
  s.num_vertices = nv;
  s.n = static_cast<std::uint32_t>(n);
  s.vertex_xy.resize(2 * nv);
  s.executor.upload(s.vertex_xy.data(), reinterpret_cast<const double*>(vertices.data()), 2 * nv, &parallel);
  if (n != nv) {
    s.site_list.resize(n);
    s.executor.upload(s.site_list.data(), sites.data(), n, &parallel);
  }
}

/// Bytes of device memory merge_input_on_device needs for n points: the points (16 bytes), the hash
/// table (at most four slots a point, 16), the representatives and the sites (8); CUB's scratch within
/// a megabyte and a byte a point.
std::size_t duplicates_device_bytes(std::size_t n) { return 41 * n + (std::size_t{1} << 20); }

/// Bytes of device memory pieces_between_representatives needs for m segments beside their ends: the
/// kept ones' keys and labels with the sort's second copies (24 bytes), the starts of equal keys and
/// the pieces (16); CUB's scratch within a megabyte and a byte a segment.
std::size_t pieces_device_bytes(std::size_t m) { return 41 * m + (std::size_t{1} << 20); }

/// The host's initial_segments (cdt/src/pslg.cpp) on the device, from the m segments' ends (a, b pairs,
/// every index below nv) and the representatives `dup` of the nv points: the segments between distinct
/// representatives, as (lower, higher) pairs ordered by (a, b) and then by segment id (a stable radix
/// sort of the segments in id order), each pair once with its lowest id. The pieces stay on the device
/// (as a, b, segment triples), `pieces` sized for them: the caller copies them down.
DeviceBuffer<std::uint32_t> pieces_between_representatives(CudaExecutor& executor, const std::uint32_t* ends,
                                                           std::size_t m, const std::uint32_t* dup,
                                                           std::size_t nv,
                                                           ::cdt::detail::PieceArray& pieces) {
  pieces.clear();
  if (m == 0) return {};
  require_device_memory(pieces_device_bytes(m), 0, "the pieces of " + std::to_string(m) + " segments");
  DeviceBuffer<std::uint32_t> d_kept(m);
  const std::uint32_t num_kept = executor.compact(
      m, [=] __device__(std::size_t k) { return dup[ends[2 * k]] != dup[ends[2 * k + 1]]; }, d_kept.data());
  if (num_kept == 0) return {};
  // Keys a * 2^bits + b, bits enough for any vertex id: 2 * bits <= 64.
  const int bits = nv <= 1 ? 1 : std::bit_width(nv - 1);
  DeviceBuffer<std::uint64_t> d_key(num_kept);
  DeviceBuffer<std::uint32_t> d_label(num_kept);
  std::uint64_t* key = d_key.data();
  std::uint32_t* label = d_label.data();
  const std::uint32_t* kept = d_kept.data();
  executor.for_each(
      num_kept,
      [=] __device__(std::size_t k) {
        const std::uint32_t s = kept[k];
        const std::uint32_t a = dup[ends[2 * static_cast<std::size_t>(s)]];
        const std::uint32_t b = dup[ends[2 * static_cast<std::size_t>(s) + 1]];
        key[k] = (static_cast<std::uint64_t>(a < b ? a : b) << bits) | (a < b ? b : a);
        label[k] = s;
      },
      "piece_keys");
  executor.sort_pairs(key, label, num_kept, 2 * bits);
  DeviceBuffer<std::uint32_t> d_heads(num_kept);
  const std::uint32_t num_pieces = executor.compact(
      num_kept, [=] __device__(std::size_t k) { return k == 0 || key[k] != key[k - 1]; }, d_heads.data());
  static_assert(sizeof(::cdt::detail::ConstraintPiece) == 3 * sizeof(std::uint32_t));
  DeviceBuffer<std::uint32_t> d_pieces(3 * static_cast<std::size_t>(num_pieces));
  std::uint32_t* out = d_pieces.data();
  const std::uint32_t* heads = d_heads.data();
  const std::uint64_t low = (std::uint64_t{1} << bits) - 1;
  executor.for_each(
      num_pieces,
      [=] __device__(std::size_t r) {
        const std::uint64_t k = key[heads[r]];
        out[3 * r] = static_cast<std::uint32_t>(k >> bits);
        out[3 * r + 1] = static_cast<std::uint32_t>(k & low);
        out[3 * r + 2] = label[heads[r]];
      },
      "pieces");
  // Room for what the split adds, as the host's merge leaves (cdt::detail::piece_room).
  pieces.reserve(num_pieces + num_pieces / 256 + 1024);
  pieces.resize(num_pieces);
  return d_pieces;
}

/// Writes 0, 1, ..., n - 1 to out, in parts on the host threads of `parallel` when it is given.
void write_identity(std::uint32_t* out, std::size_t n, const HostParallelFor& parallel) {
  constexpr std::size_t kPart = std::size_t{1} << 20;
  const std::size_t parts = (n + kPart - 1) / kPart;
  const auto part = [&](std::size_t p) {
    const std::size_t begin = p * kPart, end = std::min(n, begin + kPart);
    std::iota(out + begin, out + end, static_cast<std::uint32_t>(begin));
  };
  if (parallel && parts > 1) {
    parallel(parts, part);
  } else {
    for (std::size_t p = 0; p < parts; ++p) part(p);
  }
}

/// merge_input's work on the device: duplicates, sites and pieces. The duplicates as the host's
/// merge_duplicates finds them (each point's representative is the lowest index with its
/// coordinates), through a hash table of point indices with open addressing: each point claims the
/// first slot along its probe sequence (point_hash, then the next slots) that is empty or holds a point
/// with its coordinates. A slot's point never changes its coordinates, so all the points at one place
/// stop at the same slot, which keeps the lowest of them (atomic minimum). Then the sites (the points
/// that are their own representative) and the pieces (pieces_between_representatives).
std::size_t merge_input_on_device(DeviceSites::State& s, std::span<const Point> points,
                                  std::span<const Segment> segments, ::cdt::CrossingSegments policy,
                                  IndexArray& duplicate_of, IndexArray& sites,
                                  ::cdt::detail::PieceArray& pieces, const HostParallelFor& parallel,
                                  bool* identity_unwritten) {
  const std::size_t nv = points.size();
  const std::size_t m = segments.size();
  if (nv == 0 || nv >= kNoId || m >= kNoId)
    throw Error("internal error: DeviceSites: no points, or too many points or segments");
  // The points and the segments' ends first: an input that fails its checks gets their error, not
  // one about the memory the merge would need.
  require_device_memory(16 * nv + 8 * m + (std::size_t{1} << 20), 0,
                        "checking " + std::to_string(nv) + " points and " + std::to_string(m) + " segments");
  CudaExecutor& executor = s.executor;
  ::cdt::detail::StepTrace trace("device duplicates");
  s.num_vertices = nv;
  s.vertex_xy.resize(2 * nv);
  executor.upload(s.vertex_xy.data(), reinterpret_cast<const double*>(points.data()), 2 * nv, &parallel);
  const double* xy = s.vertex_xy.data();
  static_assert(sizeof(Segment) == 2 * sizeof(std::uint32_t));
  DeviceBuffer<std::uint32_t> d_ends(2 * m + 1);
  executor.upload(d_ends.data(), reinterpret_cast<const std::uint32_t*>(segments.data()), 2 * m, &parallel);
  const std::uint32_t* ends = d_ends.data();
  trace.mark("points up");

  // The input checks of cdt::detail::merge_input: the lowest invalid point, else the lowest segment
  // with an end beyond the points or (under reject) of zero length; and the zero-length segments.
  DeviceBuffer<std::uint32_t> d_check(3);
  std::uint32_t* check = d_check.data();
  executor.fill_bytes(check, 0xFF, 2);
  executor.fill_bytes(check + 2, 0, 1);
  executor.for_each(
      nv,
      [=] __device__(std::size_t i) {
        if (!::cdt::detail::point_is_valid(xy[2 * i], xy[2 * i + 1]))
          atomic_min(check, static_cast<std::uint32_t>(i));
      },
      "check_points");
  const bool zero_length_is_error = policy != ::cdt::CrossingSegments::resolve;
  const auto num_points = static_cast<std::uint32_t>(nv);
  executor.for_each(
      m,
      [=] __device__(std::size_t k) {
        const std::uint32_t a = ends[2 * k], b = ends[2 * k + 1];
        if (a >= num_points || b >= num_points) {
          atomic_min(check + 1, static_cast<std::uint32_t>(k));
        } else if (a == b ||
                   (xy[2 * static_cast<std::size_t>(a)] == xy[2 * static_cast<std::size_t>(b)] &&
                    xy[2 * static_cast<std::size_t>(a) + 1] == xy[2 * static_cast<std::size_t>(b) + 1])) {
          atomicAdd(check + 2, 1u);
          if (zero_length_is_error) atomic_min(check + 1, static_cast<std::uint32_t>(k));
        }
      },
      "check_segments");
  std::uint32_t checked[3];
  executor.download(checked, check, 3);
  if (checked[0] != kNoId) ::cdt::detail::throw_invalid_point(points, checked[0]);
  if (checked[1] != kNoId) ::cdt::detail::throw_invalid_segment(points, segments, checked[1]);
  d_check = {};
  require_device_memory(duplicates_device_bytes(nv) - 16 * nv, 0,
                        "merging the duplicates of " + std::to_string(nv) + " points");
  trace.mark("checked");

  s.duplicate_of.resize(nv);
  std::uint32_t* dup = s.duplicate_of.data();
  {
    // A table of at least twice as many slots as points: probe sequences stay short.
    const int table_bits = std::min(32, static_cast<int>(std::bit_width(2 * nv - 1)));
    const std::size_t table_size = std::size_t{1} << table_bits;
    DeviceBuffer<std::uint32_t> d_table(table_size);
    std::uint32_t* table = d_table.data();
    executor.fill_bytes(table, 0xFF, table_size);
    const std::size_t mask = table_size - 1;
    executor.for_each(
        nv,
        [=] __device__(std::size_t k) {
          const double x = xy[2 * k], y = xy[2 * k + 1];
          const auto i = static_cast<std::uint32_t>(k);
          std::size_t slot = static_cast<std::size_t>(::cdt::detail::point_hash(x, y) >> (64 - table_bits));
          for (;;) {
            const std::uint32_t held = atomicCAS(table + slot, kNoId, i);
            if (held == kNoId) break;
            if (xy[2 * static_cast<std::size_t>(held)] == x &&
                xy[2 * static_cast<std::size_t>(held) + 1] == y) {
              atomicMin(table + slot, i);
              break;
            }
            slot = (slot + 1) & mask;
          }
          dup[k] = static_cast<std::uint32_t>(slot);
        },
        "duplicate_slots");
    executor.for_each(
        nv, [=] __device__(std::size_t k) { dup[k] = table[dup[k]]; }, "duplicate_of");
  }
  trace.mark("merged");

  s.pieces = pieces_between_representatives(executor, ends, m, dup, nv, pieces);
  d_ends = {};
  trace.mark("pieces");

  s.site_list.resize(nv);
  const std::uint32_t n = executor.compact(
      nv, [=] __device__(std::size_t i) { return dup[i] == i; }, s.site_list.data());
  s.n = n;
  duplicate_of.resize(nv);
  sites.reserve(::cdt::detail::vertex_room(nv)); // the split appends the vertices it adds
  sites.resize(n);
  if (identity_unwritten != nullptr) *identity_unwritten = false;
  if (n == nv) {
    // No duplicates: both maps are the identity, written on the host's threads instead of coming
    // over the bus (80 MB at 10^7 points), or left to the caller, who writes them later.
    if (identity_unwritten != nullptr) {
      *identity_unwritten = true;
    } else {
      write_identity(duplicate_of.data(), nv, parallel);
      write_identity(sites.data(), n, parallel);
    }
    s.site_list = {};
  }
  // The maps and the pieces are first read on the host after shifting (the pieces in mesh ids, the
  // split, the output): large ones come down on a thread of their own, started with the vertex maps'
  // at the end of prepare() (the coastlines: 36 MB, 1.9 ms of the bus before the sites' steps), small
  // ones at once.
  const std::size_t map_bytes = n == nv ? 0 : 4 * (nv + static_cast<std::size_t>(n));
  if (map_bytes + 4 * s.pieces.size() >= kLateDownloadBytes) {
    s.late.add(reinterpret_cast<std::uint32_t*>(pieces.data()), s.pieces.data(), s.pieces.size());
    if (n != nv) {
      s.late.add(duplicate_of.data(), dup, nv);
      s.late.add(sites.data(), s.site_list.data(), n);
    }
    s.merge_late = true;
  } else {
    executor.download(reinterpret_cast<std::uint32_t*>(pieces.data()), s.pieces.data(), s.pieces.size(),
                      &parallel);
    if (n != nv) {
      executor.download(duplicate_of.data(), dup, nv, &parallel);
      executor.download(sites.data(), s.site_list.data(), n, &parallel);
    }
    // Kept for their mesh ids (prepare) when the constraints will run beside the host's split.
    if (s.pieces.size() / 3 < kMeshPiecesFrom) s.pieces = {};
  }
  if (!s.merge_late || n == nv) s.duplicate_of = {};
  trace.mark("downloaded");
  return checked[2];
}

/// DeviceSites' preparation (a constructor cannot hold the extended lambdas of its steps), from the
/// vertices and sites on the device (upload_vertices or merge_input_on_device), which it frees.
void prepare_sites(DeviceSites::State& s, std::uint32_t m, GridMapping& mapping, ::cdt::detail::Box& bounds,
                   IndexArray& site_vertex, IndexArray& site_of_vertex, ::cdt::detail::FlagArray& kept,
                   MissingArray& missing, const HostParallelFor& parallel,
                   DeviceSites::MissingTo missing_to) {
  const std::size_t nv = s.num_vertices;
  const std::size_t n = s.n;
  if (n == 0 || n > nv || s.vertex_xy.size() != 2 * nv)
    throw Error("internal error: DeviceSites: prepared twice, or without sites");
  if (m == 0 || m > ::cdt::detail::kMaxGridSize)
    throw Error("internal error: DeviceSites: grid size " + std::to_string(m) + " out of range");
  require_device_memory(sites_device_bytes(nv, n, m) - 20 * nv, 0,
                        "the grid sites of " + std::to_string(n) + " points on a " + std::to_string(m) +
                            " x " + std::to_string(m) + " grid");
  CudaExecutor& executor = s.executor;
  ::cdt::detail::StepTrace trace("device sites");
  s.m = m;
  const double* xy = s.vertex_xy.data();
  const std::uint32_t* site_list = n == nv ? nullptr : s.site_list.data();

  // The sites' coordinates in their given order (in x, y for now), their box and the grid mapping.
  s.x.resize(n);
  s.y.resize(n);
  double* x = s.x.data();
  double* y = s.y.data();
  executor.for_each(
      n,
      [=] __device__(std::size_t k) {
        const std::size_t v = site_list != nullptr ? site_list[k] : k;
        x[k] = xy[2 * v];
        y[k] = xy[2 * v + 1];
      },
      "site_coordinates");
  const Extent given = box_of(executor, n, x, y);
  s.magnitude =
      std::max({std::abs(given.min_x), std::abs(given.max_x), std::abs(given.min_y), std::abs(given.max_y)});
  mapping = ::cdt::detail::grid_mapping_of_box(given.min_x, given.max_x, given.min_y, given.max_y, m);
  trace.mark("coordinates up, grid mapping");

  // The Z order of the grid cells, ties in their given order (a stable radix sort), as the host's
  // spatial_site_order.
  const GridMapping map = mapping;
  DeviceBuffer<std::uint32_t> d_key(n), d_order(n);
  std::uint32_t* key = d_key.data();
  std::uint32_t* order = d_order.data();
  executor.for_each(
      n,
      [=] __device__(std::size_t k) {
        key[k] = ::cdt::detail::z_order_key(map.grid_x(x[k]), map.grid_y(y[k]));
        order[k] = static_cast<std::uint32_t>(k);
      },
      "z_order_keys");
  const int key_bits = 2 * std::bit_width(m - 1);
  if (key_bits > 0) executor.sort_pairs(key, order, n, key_bits);

  // Renumbering: site k is the vertex at place order[k]; its true position read from the vertices.
  // The numbering stays on the device for the output (DeviceMesh::take_vertex_ids).
  s.site_vertex.resize(n);
  s.site_of_vertex.resize(nv);
  std::uint32_t* vertex_of = s.site_vertex.data();
  std::uint32_t* site_of = s.site_of_vertex.data();
  s.true_x.resize(n);
  s.true_y.resize(n);
  double* tx = s.true_x.data();
  double* ty = s.true_y.data();
  executor.fill_bytes(site_of, 0xFF, nv);
  executor.for_each(
      n,
      [=] __device__(std::size_t k) {
        const std::uint32_t v = site_list != nullptr ? site_list[order[k]] : order[k];
        vertex_of[k] = v;
        site_of[v] = static_cast<std::uint32_t>(k);
        tx[k] = xy[2 * static_cast<std::size_t>(v)];
        ty[k] = xy[2 * static_cast<std::size_t>(v) + 1];
      },
      "renumber_sites");

  // Grid cells; the site nearest a cell's grid point owns it, the lowest among equals (assign_sites):
  // atomic minima of the distances, then of the sites at the least one, whatever the order of the
  // threads.
  const std::size_t cells = static_cast<std::size_t>(m) * m;
  s.gx.resize(n);
  s.gy.resize(n);
  s.cell_owner.resize(cells);
  std::uint32_t* gx = s.gx.data();
  std::uint32_t* gy = s.gy.data();
  std::uint32_t* owner = s.cell_owner.data();
  {
    DeviceBuffer<std::uint32_t> d_least(cells);
    std::uint32_t* least = d_least.data();
    executor.fill_bytes(least, 0xFF, cells);
    executor.fill_bytes(owner, 0xFF, cells);
    executor.for_each(
        n,
        [=] __device__(std::size_t k) {
          gx[k] = map.grid_x(tx[k]);
          gy[k] = map.grid_y(ty[k]);
          atomic_min(least + static_cast<std::size_t>(gy[k]) * map.m + gx[k],
                     ::cdt::detail::grid_point_distance_key(map, tx[k], ty[k], gx[k], gy[k]));
        },
        "site_cells");
    executor.for_each(
        n,
        [=] __device__(std::size_t k) {
          const std::size_t cell = static_cast<std::size_t>(gy[k]) * map.m + gx[k];
          if (::cdt::detail::grid_point_distance_key(map, tx[k], ty[k], gx[k], gy[k]) == least[cell])
            atomic_min(owner + cell, static_cast<std::uint32_t>(k));
        },
        "site_owners");
  }

  // Kept sites sit at their grid points, the others at their true positions.
  s.kept.resize(n);
  std::uint8_t* keep = s.kept.data();
  executor.for_each(
      n,
      [=] __device__(std::size_t k) {
        const bool own = owner[static_cast<std::size_t>(gy[k]) * map.m + gx[k]] == k;
        keep[k] = own ? 1 : 0;
        x[k] = own ? map.to_x(gx[k]) : tx[k];
        y[k] = own ? map.to_y(gy[k]) : ty[k];
      },
      "kept_sites");
  const Extent all = box_of(executor, n, x, y, tx, ty);
  bounds = ::cdt::detail::Box{all.min_x, all.min_y, all.max_x, all.max_y};

  // The missing points, each with its cell's kept site as the start of its search.
  DeviceBuffer<std::uint32_t> d_missing(n);
  const std::uint32_t num_missing = executor.compact(
      n, [=] __device__(std::size_t k) { return keep[k] == 0; }, d_missing.data());
  s.missing.resize(num_missing);
  const std::uint32_t* missing_site = d_missing.data();
  MissingPoint* pairs = s.missing.data();
  executor.for_each(
      num_missing,
      [=] __device__(std::size_t i) {
        const std::uint32_t k = missing_site[i];
        pairs[i] = MissingPoint{k, owner[static_cast<std::size_t>(gy[k]) * map.m + gx[k]]};
      },
      "missing_points");
  trace.mark("ordered, cells, kept, bounds");

  // Both grow by the vertices the split adds (cdt::triangulate's added_vertices).
  site_vertex.reserve(::cdt::detail::vertex_room(nv));
  site_vertex.resize(n);
  site_of_vertex.reserve(::cdt::detail::vertex_room(nv));
  site_of_vertex.resize(nv);
  kept.resize(n);
  // Room for every site: the dual's degenerate and unreached sites and shifting's bad cases are
  // appended later, and growing the array would copy it all (5.5 million points, 44 MB, into fresh
  // pages) for the first of them. The room beyond the missing points is never written unless used.
  missing.reserve(n);
  executor.download(kept.data(), keep, n, &parallel);
  if (missing_to == DeviceSites::MissingTo::host) {
    missing.resize(num_missing);
    executor.download(missing.data(), pairs, num_missing, &parallel);
    s.missing = {};
  } else {
    missing.clear();
  }
  // The vertex maps are first read on the host after shifting (by the split, the added vertices and
  // the output): large ones come down on a thread of their own meanwhile (the coastlines' 16 MB: the
  // sites' step 2.9 -> 1.2 ms; 10M + 1M, 80 MB: 4.2 -> 1.7), small ones at once, where a thread's
  // start would cost more than the copy.
  if (4 * (static_cast<std::size_t>(n) + nv) >= kLateDownloadBytes) {
    s.late.add(site_vertex.data(), vertex_of, n);
    s.late.add(site_of_vertex.data(), site_of, nv);
  } else {
    executor.download(site_vertex.data(), vertex_of, n, &parallel);
    executor.download(site_of_vertex.data(), site_of, nv, &parallel);
  }
  // The pieces in mesh ids for the constraints, while the merge's pieces and the sites of the vertices
  // are both here: the host's copy of them (21 MB for the coastlines) need not go up again. Without the
  // memory for them the constraints upload the host's.
  if (s.pieces.size() > 0) {
    const std::size_t np = s.pieces.size() / 3;
    try {
      s.mesh_pieces.resize(np);
      ::cdt::detail::ConstraintPiece2* out = s.mesh_pieces.data();
      const std::uint32_t* triples = s.pieces.data();
      executor.for_each(
          np,
          [=] __device__(std::size_t k) {
            out[k] = {site_of[triples[3 * k]], site_of[triples[3 * k + 1]], static_cast<std::uint32_t>(k)};
          },
          "mesh_pieces");
    } catch (const DeviceError&) {
      s.mesh_pieces = {};
    }
    if (!s.merge_late) s.pieces = {}; // on the host already
  }
  s.late.start(); // with the merge's copies, if it left any
  s.vertex_xy = {};
  if (!s.merge_late) s.site_list = {}; // else the source of a late copy, freed once it is done
  trace.mark("downloaded");
}

} // namespace
} // namespace detail

std::size_t sites_device_bytes(std::size_t num_vertices, std::size_t num_sites, std::uint32_t m) {
  // Vertices (16 bytes) and their sites (4); per site: the list of sites, 4 positions, 2 cells, the
  // sort's keys and values twice, the numbering, the kept flag, a missing point (4 + 32 + 8 + 16 + 4 +
  // 1 + 12); the m * m owners and their least distances; CUB's scratch and the executor's within a
  // margin of a megabyte plus a byte per site.
  const std::size_t cells = static_cast<std::size_t>(m) * m;
  return 20 * num_vertices + 78 * num_sites + 8 * cells + (std::size_t{1} << 20);
}

DeviceSites::DeviceSites(std::span<const Point> vertices, std::span<const std::uint32_t> sites,
                         std::uint32_t m, GridMapping& mapping, ::cdt::detail::Box& bounds,
                         IndexArray& site_vertex, IndexArray& site_of_vertex, ::cdt::detail::FlagArray& kept,
                         MissingArray& missing, const HostParallelFor& parallel)
    : state_(std::make_unique<State>()) {
  detail::upload_vertices(*state_, vertices, sites, parallel);
  prepare(m, mapping, bounds, site_vertex, site_of_vertex, kept, missing, parallel);
}

DeviceSites::DeviceSites(std::span<const Point> points, std::span<const Segment> segments,
                         CrossingSegments policy, IndexArray& duplicate_of, IndexArray& sites,
                         ::cdt::detail::PieceArray& pieces, std::size_t& zero_length_segments,
                         const HostParallelFor& parallel, bool* identity_unwritten)
    : state_(std::make_unique<State>()) {
  zero_length_segments = detail::merge_input_on_device(*state_, points, segments, policy, duplicate_of, sites,
                                                       pieces, parallel, identity_unwritten);
}

void DeviceSites::prepare(std::uint32_t m, GridMapping& mapping, ::cdt::detail::Box& bounds,
                          IndexArray& site_vertex, IndexArray& site_of_vertex, ::cdt::detail::FlagArray& kept,
                          MissingArray& missing, const HostParallelFor& parallel, MissingTo missing_to) {
  detail::prepare_sites(*state_, m, mapping, bounds, site_vertex, site_of_vertex, kept, missing, parallel,
                        missing_to);
}

std::size_t DeviceSites::missing_on_device() const { return state_->missing.size(); }

double DeviceSites::magnitude() const { return state_->magnitude; }

void DeviceSites::finish_downloads() {
  State& s = *state_;
  s.late.start(); // the merge's copies, when prepare() has not started them
  s.late.wait();
  s.site_of_vertex = {};
  if (s.merge_late) {
    s.merge_late = false;
    s.duplicate_of = {};
    s.pieces = {};
    if (s.vertex_xy.size() == 0) s.site_list = {}; // prepared: the list is read no more
  }
}

DeviceSites::~DeviceSites() = default;
DeviceSites::DeviceSites(DeviceSites&&) noexcept = default;
DeviceSites& DeviceSites::operator=(DeviceSites&&) noexcept = default;

void DeviceSites::leave_out(std::span<const std::uint32_t> sites) {
  if (sites.empty()) return;
  State& s = *state_;
  for (const std::uint32_t site : sites)
    if (site >= s.n) throw Error("DeviceSites::leave_out: site " + std::to_string(site) + " out of range");
  detail::DeviceBuffer<std::uint32_t> d_sites(sites.size());
  s.executor.upload(d_sites.data(), sites.data(), sites.size());
  const std::uint32_t* list = d_sites.data();
  double* x = s.x.data();
  double* y = s.y.data();
  std::uint8_t* kept = s.kept.data();
  const double* true_x = s.true_x.data();
  const double* true_y = s.true_y.data();
  s.executor.for_each(
      sites.size(),
      [=] __device__(std::size_t k) {
        x[list[k]] = true_x[list[k]];
        y[list[k]] = true_y[list[k]];
        kept[list[k]] = 0;
      },
      "leave_out_sites");
  // Other streams (the dual's) read the positions next; d_sites is freed at the end of this scope.
  s.executor.synchronize();
}

void DeviceSites::positions(std::vector<double>& x, std::vector<double>& y, std::vector<double>* true_x,
                            std::vector<double>* true_y, const HostParallelFor& parallel) const {
  const State& s = *state_;
  const auto copy = [&](std::vector<double>& out, const detail::DeviceBuffer<double>& from) {
    out.resize(s.n);
    s.executor.download(out.data(), from.data(), s.n, &parallel);
  };
  copy(x, s.x);
  copy(y, s.y);
  if (true_x != nullptr) copy(*true_x, s.true_x);
  if (true_y != nullptr) copy(*true_y, s.true_y);
}

} // namespace cdt::gpu
