// Phase 1's first half on the device: the steps cdt::triangulate runs on the host before the digital
// Voronoi diagram (the sites' coordinates, the grid mapping's box, the Z order, the renumbering, the
// grid cells with their owners, the kept sites and the box of every position), each the same
// computation, so the numbering, the cells and the missing points are the host's. The positions and
// cells stay on the device; only the numbering, the kept flags and the missing points come back.

#include <bit>
#include <cstddef>
#include <cstdint>
#include <memory>
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

namespace cdt::gpu {

using ::cdt::detail::GridMapping;
using ::cdt::detail::kNoId;
using ::cdt::detail::MissingPoint;

namespace detail {
namespace {

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

constexpr unsigned kBoxThreads = 256;
constexpr unsigned kBoxBlocks = 256;

/// Per block, the box of the points (x[i], y[i]) and, when x2 is given, (x2[i], y2[i]), over the
/// block's grid-stride share of [0, n), n >= 1.
__global__ void box_kernel(std::size_t n, const double* x, const double* y, const double* x2,
                           const double* y2, Extent* out) {
  __shared__ Extent part[kBoxThreads];
  Extent e{x[0], y[0], x[0], y[0]};
  const std::size_t stride = static_cast<std::size_t>(gridDim.x) * blockDim.x;
  for (std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x; i < n; i += stride) {
    e.add(x[i], y[i]);
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

/// The box of the points (x[i], y[i]) and, when x2 is given, (x2[i], y2[i]), i in [0, n), n >= 1: a
/// block's part each on the device, the parts merged here.
Extent box_of(CudaExecutor& executor, std::size_t n, const double* x, const double* y,
              const double* x2 = nullptr, const double* y2 = nullptr) {
  DeviceBuffer<Extent> d_parts(kBoxBlocks);
  box_kernel<<<kBoxBlocks, kBoxThreads, 0, executor.stream()>>>(n, x, y, x2, y2, d_parts.data());
  CDT_CUDA_CHECK_LAUNCH("site_box");
  std::vector<Extent> parts(kBoxBlocks);
  executor.download(parts.data(), d_parts.data(), kBoxBlocks);
  Extent all = parts[0];
  for (const Extent& p : parts) all.add(p);
  return all;
}

/// DeviceSites' construction (a constructor cannot hold the extended lambdas of its steps).
void prepare_sites(DeviceSites::State& s, std::span<const Point> vertices,
                   std::span<const std::uint32_t> sites, std::uint32_t m, GridMapping& mapping,
                   ::cdt::detail::Box& bounds, std::vector<std::uint32_t>& site_vertex,
                   std::vector<std::uint32_t>& site_of_vertex, std::vector<std::uint8_t>& kept,
                   std::vector<MissingPoint>& missing, const HostParallelFor& parallel) {
  const std::size_t nv = vertices.size();
  const std::size_t n = sites.size();
  if (n == 0 || n > nv || nv >= kNoId) throw Error("internal error: DeviceSites: no sites, or too many");
  if (m == 0 || m > ::cdt::detail::kMaxGridSize)
    throw Error("internal error: DeviceSites: grid size " + std::to_string(m) + " out of range");
  require_device_memory(sites_device_bytes(nv, n, m), 0,
                        "the grid sites of " + std::to_string(n) + " points on a " + std::to_string(m) +
                            " x " + std::to_string(m) + " grid");
  CudaExecutor& executor = s.executor;
  ::cdt::detail::StepTrace trace("device sites");
  s.n = static_cast<std::uint32_t>(n);
  s.m = m;

  // The vertices go up as they are (x, y pairs); the list of sites only when some vertex is a
  // duplicate (the sites are then not every vertex in order).
  static_assert(sizeof(Point) == 2 * sizeof(double));
  DeviceBuffer<double> d_xy(2 * nv);
  executor.upload(d_xy.data(), reinterpret_cast<const double*>(vertices.data()), 2 * nv);
  const bool every_vertex = n == nv;
  DeviceBuffer<std::uint32_t> d_sites(every_vertex ? 1 : n);
  if (!every_vertex) executor.upload(d_sites.data(), sites.data(), n);
  const double* xy = d_xy.data();
  const std::uint32_t* site_list = every_vertex ? nullptr : d_sites.data();

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
  DeviceBuffer<std::uint32_t> d_site_vertex(n), d_site_of_vertex(nv);
  std::uint32_t* vertex_of = d_site_vertex.data();
  std::uint32_t* site_of = d_site_of_vertex.data();
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

  // Grid cells; the lowest site of a cell owns it (atomic minimum, whatever the order of the threads).
  const std::size_t cells = static_cast<std::size_t>(m) * m;
  s.gx.resize(n);
  s.gy.resize(n);
  s.cell_owner.resize(cells);
  std::uint32_t* gx = s.gx.data();
  std::uint32_t* gy = s.gy.data();
  std::uint32_t* owner = s.cell_owner.data();
  executor.fill_bytes(owner, 0xFF, cells);
  executor.for_each(
      n,
      [=] __device__(std::size_t k) {
        gx[k] = map.grid_x(tx[k]);
        gy[k] = map.grid_y(ty[k]);
        atomic_min(owner + static_cast<std::size_t>(gy[k]) * map.m + gx[k], static_cast<std::uint32_t>(k));
      },
      "site_cells");

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
  static_assert(sizeof(MissingPoint) == 2 * sizeof(std::uint32_t));
  DeviceBuffer<std::uint32_t> d_pairs(2 * static_cast<std::size_t>(num_missing) + 1);
  const std::uint32_t* missing_site = d_missing.data();
  std::uint32_t* pairs = d_pairs.data();
  executor.for_each(
      num_missing,
      [=] __device__(std::size_t i) {
        const std::uint32_t k = missing_site[i];
        pairs[2 * i] = k;
        pairs[2 * i + 1] = owner[static_cast<std::size_t>(gy[k]) * map.m + gx[k]];
      },
      "missing_points");
  trace.mark("ordered, cells, kept, bounds");

  site_vertex.resize(n);
  site_of_vertex.resize(nv);
  kept.resize(n);
  missing.resize(num_missing);
  executor.download(site_vertex.data(), vertex_of, n, &parallel);
  executor.download(site_of_vertex.data(), site_of, nv, &parallel);
  executor.download(kept.data(), keep, n, &parallel);
  executor.download(reinterpret_cast<std::uint32_t*>(missing.data()), pairs,
                    2 * static_cast<std::size_t>(num_missing));
  trace.mark("downloaded");
}

} // namespace
} // namespace detail

std::size_t sites_device_bytes(std::size_t num_vertices, std::size_t num_sites, std::uint32_t m) {
  // Vertices (16 bytes) and their sites (4); per site: the list of sites, 4 positions, 2 cells, the
  // sort's keys and values twice, the numbering, the kept flag, a missing point (4 + 32 + 8 + 16 + 4 +
  // 1 + 12); the m * m owners; CUB's scratch and the executor's within a margin of a megabyte plus a
  // byte per site.
  const std::size_t cells = static_cast<std::size_t>(m) * m;
  return 20 * num_vertices + 78 * num_sites + 4 * cells + (std::size_t{1} << 20);
}

DeviceSites::DeviceSites(std::span<const Point> vertices, std::span<const std::uint32_t> sites,
                         std::uint32_t m, GridMapping& mapping, ::cdt::detail::Box& bounds,
                         std::vector<std::uint32_t>& site_vertex, std::vector<std::uint32_t>& site_of_vertex,
                         std::vector<std::uint8_t>& kept, std::vector<MissingPoint>& missing,
                         const HostParallelFor& parallel)
    : state_(std::make_unique<State>()) {
  detail::prepare_sites(*state_, vertices, sites, m, mapping, bounds, site_vertex, site_of_vertex, kept,
                        missing, parallel);
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
