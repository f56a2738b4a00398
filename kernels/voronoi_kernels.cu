// Phase 1 of gCD on the CUDA executor (paper section 3.1 and Appendix A): the digital Voronoi diagram.
//
// The per-element work is cdt/src/gcd/voronoi.hpp's, the same functions the CPU executor runs
// (pba::run_pba for the Parallel Banding Algorithm; amend::is_orphan_at, debris_successors and
// flood_colour for Algorithm A.1); this file picks band counts that suit a GPU, owns the device
// buffers and runs the steps:
//   1. PBA with one thread per column in phase 1 and per (row, band of 64 columns) in phases 2 and 3;
//   2. the orphans by stream compaction over every cell, the packed sites turned into point indices;
//   3. the debris as rounds of a worklist: each round's new debris test their neighbours, and those
//      that turn into orphans are uncoloured (atomicExch, so each is taken once) and appended;
//   4. the flood as rounds of flood_colour over the debris until no colour changes. The CPU executor
//      floods with a priority queue instead; voronoi.hpp explains why both reach the same colouring.
// Where the paper copies the debris to the CPU for the flood, this keeps them on the device: they are
// few, so steps 3 and 4 cost a few small launches and one 4-byte readback per round.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "cdt/detail/trace.hpp"
#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"
#include "device_sites.cuh"
#include "device_voronoi.cuh"
#include "gcd/probe_map.hpp"
#include "gcd/voronoi.hpp"

namespace cdt::gpu {

namespace detail {

namespace pba = ::cdt::detail::pba;
namespace amend = ::cdt::detail::amend;

/// Rows per band of PBA's phase 1 and columns per band of its phases 2 and 3 on the device: about
/// m^2 / 32 threads in each phase (enough to fill a large GPU from m = 1024 up), and few merge rounds.
inline constexpr std::uint32_t kRowBandHeight = 32;
inline constexpr std::uint32_t kColBandWidth = 64;

/// The device's layout: groups of one column, so a warp of phase 1 reads 32 neighbouring cells.
pba::PbaLayout device_layout(std::uint32_t m, const VoronoiOptions& options) {
  const std::uint32_t row_bands =
      options.row_bands != 0 ? options.row_bands : (m + kRowBandHeight - 1) / kRowBandHeight;
  const std::uint32_t col_bands =
      options.col_bands != 0 ? options.col_bands : (m + kColBandWidth - 1) / kColBandWidth;
  return pba::PbaLayout::make(m, row_bands, m, col_bands);
}

/// Neighbour k (0..3, the order of amend::for_each_neighbour) of a cell, as a cell index.
__device__ __forceinline__ std::uint32_t neighbour_cell(std::uint32_t cell, std::uint32_t m, unsigned k) {
  return k == 0 ? cell - 1 : k == 1 ? cell + 1 : k == 2 ? cell - m : cell + m;
}

/// Direction bit of neighbour cell c of cell (as neighbour_cell numbers them).
__device__ __forceinline__ unsigned neighbour_bit(std::uint32_t cell, std::uint32_t c, std::uint32_t m) {
  return c + 1 == cell ? 1u : c == cell + 1 ? 2u : c + m == cell ? 4u : 8u;
}

/// Every occupied cell's owner must be a point sitting in that cell; the flood reads the sites'
/// positions through the owners, so an inconsistent input must stop here.
void check_owners(CudaExecutor& executor, VoronoiBuffers& b, std::uint32_t m, std::size_t n) {
  auto* d_bad = executor.scalar<std::uint32_t>();
  executor.fill_bytes(d_bad, 0, 1);
  const std::uint32_t* owner = b.owner.data();
  const std::uint32_t* sx = b.site_x.data();
  const std::uint32_t* sy = b.site_y.data();
  executor.for_each(
      static_cast<std::size_t>(m) * m,
      [=] __device__(std::size_t c) {
        const std::uint32_t p = owner[c];
        if (p == kNone) return;
        if (p >= n || sx[p] != c % m || sy[p] != c / m) atomicOr(d_bad, 1u);
      },
      "check_owners");
  std::uint32_t bad = 0;
  executor.download(&bad, d_bad, 1);
  if (bad != 0)
    throw Error("compute_digital_voronoi: cell_owner names a point that is out of range or not in that cell");
}

/// Step 2: the orphans, listed in b.stack; the packed sites in b.colour become point indices.
std::uint32_t find_orphans(CudaExecutor& executor, VoronoiBuffers& b, std::uint32_t m) {
  const std::uint32_t* site = b.colour.data();
  const std::uint32_t count = executor.compact(
      static_cast<std::size_t>(m) * m,
      [=] __device__(std::size_t c) {
        return amend::is_orphan_at(site, m, static_cast<std::uint32_t>(c % m),
                                   static_cast<std::uint32_t>(c / m));
      },
      b.stack.data());
  const std::uint32_t* owner = b.owner.data();
  std::uint32_t* colour = b.colour.data();
  executor.for_each(
      static_cast<std::size_t>(m) * m,
      [=] __device__(std::size_t c) { colour[c] = pba::owner_at(owner, m, colour[c]); },
      "positions_to_owners");
  return count;
}

/// Step 3: grows the orphans b.stack[0, num_orphans) into every debris cell, uncoloured; returns the
/// number of debris.
std::uint32_t find_debris(CudaExecutor& executor, VoronoiBuffers& b, std::uint32_t m,
                          std::uint32_t num_orphans, const amend::FloodView& view, VoronoiStats& stats) {
  std::uint32_t* debris = b.stack.data();
  std::uint32_t* old_colour = b.owner.data(); // free once the colouring holds point indices
  std::uint32_t* colour = b.colour.data();
  // Orphans are distinct cells: each thread uncolours its own.
  executor.for_each(
      num_orphans,
      [=] __device__(std::size_t k) {
        old_colour[k] = colour[debris[k]];
        colour[debris[k]] = kNone;
      },
      "uncolour_orphans");
  std::uint32_t begin = 0, end = num_orphans;
  auto* d_added = executor.scalar<std::uint32_t>();
  while (begin < end) {
    ++stats.debris_rounds;
    const std::uint32_t frontier = end - begin;
    b.successors.resize(frontier);
    std::uint8_t* mask = b.successors.data();
    const std::uint32_t first = begin;
    // Reading only: every successor is tested against the colouring as the last round left it.
    executor.for_each(
        frontier,
        [=] __device__(std::size_t k) {
          const std::uint32_t cell = debris[first + k];
          std::uint32_t next[4];
          const std::uint32_t count = amend::debris_successors(view, cell, old_colour[first + k], next);
          unsigned bits = 0;
          for (std::uint32_t j = 0; j < count; ++j) bits |= neighbour_bit(cell, next[j], m);
          mask[k] = static_cast<std::uint8_t>(bits);
        },
        "debris_successors");
    executor.fill_bytes(d_added, 0, 1);
    const std::uint32_t last = end;
    // Writing only: a cell named by several debris is uncoloured and appended once.
    executor.for_each(
        frontier,
        [=] __device__(std::size_t k) {
          const unsigned bits = mask[k];
          if (bits == 0) return;
          const std::uint32_t cell = debris[first + k];
          for (unsigned j = 0; j < 4; ++j) {
            if ((bits & (1u << j)) == 0) continue;
            const std::uint32_t c = neighbour_cell(cell, m, j);
            const std::uint32_t was = atomicExch(colour + c, kNone);
            if (was == kNone) continue;
            const std::uint32_t slot = last + atomicAdd(d_added, 1u);
            debris[slot] = c;
            old_colour[slot] = was;
          }
        },
        "append_debris");
    std::uint32_t added = 0;
    executor.download(&added, d_added, 1);
    begin = end;
    end += added;
  }
  return end;
}

/// Step 4: Algorithm A.1's flood over the debris b.stack[0, num_debris): rounds of flood_colour, each
/// reading the last round's colouring, until a round changes nothing, which is the one solution of
/// the flood's equation (voronoi.hpp). It settles: a key is held only while a chain of strictly
/// smaller keys supports it, so wrong keys die out from the smallest up (a host replay of these
/// rounds on 3000 dense inputs never needed more than 4); the cap only guards against a defect.
void flood_debris(CudaExecutor& executor, VoronoiBuffers& b, std::uint32_t m, std::uint32_t num_debris,
                  const amend::FloodView& view, VoronoiStats& stats) {
  const std::uint32_t* debris = b.stack.data();
  std::uint32_t* next = b.owner.data(); // the old colours are no longer needed
  std::uint32_t* colour = b.colour.data();
  auto* d_changed = executor.scalar<std::uint32_t>();
  const std::uint64_t cap = 4ull * num_debris * num_debris + num_debris + 16;
  for (;;) {
    if (++stats.flood_rounds > cap) throw Error("internal error: the flood of the debris did not settle");
    executor.fill_bytes(d_changed, 0, 1);
    executor.for_each(
        num_debris,
        [=] __device__(std::size_t k) {
          const std::uint32_t cell = debris[k];
          const std::uint32_t c = amend::flood_colour(view, cell % m, cell / m);
          next[k] = c;
          if (c != colour[cell]) atomicOr(d_changed, 1u);
        },
        "flood_colour");
    executor.for_each(
        num_debris, [=] __device__(std::size_t k) { colour[debris[k]] = next[k]; }, "flood_apply");
    std::uint32_t changed = 0;
    executor.download(&changed, d_changed, 1);
    if (changed == 0) return;
  }
}

} // namespace detail

std::size_t voronoi_device_bytes(std::uint32_t m, std::size_t num_points, const VoronoiOptions& options) {
  if (m == 0 || m > ::cdt::detail::kMaxGridSize) return 0;
  const auto layout = detail::device_layout(m, options);
  const std::size_t cells = static_cast<std::size_t>(m) * m;
  const std::size_t words =
      3 * cells + layout.stack_size_entries() + 2 * layout.band_link_entries() + 2 * num_points;
  // The successor masks (one byte per debris at most), CUB's compaction scratch (well under a byte per
  // cell) and a megabyte for the executor's own scratch.
  return words * sizeof(std::uint32_t) + cells + cells / 8 + (std::size_t{1} << 20);
}

namespace detail {

/// DeviceVoronoi's construction (a constructor cannot hold the extended lambdas of its steps): from
/// the host's arrays, or when `sites` is given from its grid cells (taken over; the arrays are empty).
void colour_on_device(DeviceVoronoi::State& state, std::span<const std::uint32_t> cell_owner,
                      std::span<const std::uint32_t> site_x, std::span<const std::uint32_t> site_y,
                      std::uint32_t m, const VoronoiOptions& options, VoronoiStats* stats,
                      DeviceSites::State* sites = nullptr) {
  if (sites != nullptr) m = sites->m;
  if (m == 0 || m > ::cdt::detail::kMaxGridSize)
    throw Error("compute_digital_voronoi: grid size " + std::to_string(m) + " is outside [1, " +
                std::to_string(::cdt::detail::kMaxGridSize) + "]");
  const std::size_t cells = static_cast<std::size_t>(m) * m;
  if (sites == nullptr && cell_owner.size() != cells)
    throw Error("compute_digital_voronoi: cell_owner has " + std::to_string(cell_owner.size()) +
                " entries, not m * m = " + std::to_string(cells));
  if (sites != nullptr && (sites->cell_owner.size() != cells || sites->gx.size() != sites->n))
    throw Error("internal error: the device's grid sites were taken over already");
  if (site_x.size() != site_y.size())
    throw Error("compute_digital_voronoi: site_x and site_y have different lengths");
  const std::size_t n = sites != nullptr ? sites->n : site_x.size();
  if (n >= kNone) throw Error("compute_digital_voronoi: too many points for 32-bit indices");

  VoronoiStats local;
  VoronoiStats& st = stats != nullptr ? *stats : local;
  st = VoronoiStats{};
  st.device_bytes = voronoi_device_bytes(m, n, options);
  state.m = m;
  state.num_points = n;
  CudaExecutor& executor = state.executor;
  require_device_memory(st.device_bytes, options.memory_limit,
                        "the digital Voronoi diagram of a " + std::to_string(m) + " x " + std::to_string(m) +
                            " grid with " + std::to_string(n) + " points");

  DeviceEvent started, uploaded, coloured, amended;
  started.record(executor.stream());
  VoronoiBuffers& b = state.buffers;
  ::cdt::detail::pba::PbaView v;
  static_cast<::cdt::detail::pba::PbaLayout&>(v) = detail::device_layout(m, options);
  if (sites != nullptr) {
    b.owner = std::move(sites->cell_owner);
    b.site_x = std::move(sites->gx);
    b.site_y = std::move(sites->gy);
  }
  b.owner.resize(cells);
  b.colour.resize(cells);
  b.stack.resize(cells);
  b.stack_size.resize(v.stack_size_entries());
  b.above.resize(v.band_link_entries());
  b.below.resize(v.band_link_entries());
  if (sites == nullptr) {
    b.site_x.resize(n);
    b.site_y.resize(n);
    executor.upload(b.owner.data(), cell_owner.data(), cells);
    executor.upload(b.site_x.data(), site_x.data(), n);
    executor.upload(b.site_y.data(), site_y.data(), n);
  }
  detail::check_owners(executor, b, m, n);
  uploaded.record(executor.stream());

  v.owner = b.owner.data();
  v.column = b.colour.data();
  v.stack = b.stack.data();
  v.stack_size = b.stack_size.data();
  v.above = b.above.data();
  v.below = b.below.data();
  ::cdt::detail::pba::run_pba(executor, v);
  coloured.record(executor.stream());

  const std::uint32_t orphans = options.amend ? detail::find_orphans(executor, b, m) : 0;
  st.orphans = orphans;
  if (!options.amend) {
    const std::uint32_t* owner = b.owner.data();
    std::uint32_t* out = b.colour.data();
    executor.for_each(
        cells, [=] __device__(std::size_t c) { out[c] = ::cdt::detail::pba::owner_at(owner, m, out[c]); },
        "positions_to_owners");
  } else if (orphans != 0) {
    ::cdt::detail::amend::FloodView view;
    view.colour = b.colour.data();
    view.site_x = b.site_x.data();
    view.site_y = b.site_y.data();
    view.m = m;
    const std::uint32_t debris = detail::find_debris(executor, b, m, orphans, view, st);
    st.debris = debris;
    detail::flood_debris(executor, b, m, debris, view, st);
  }
  amended.record(executor.stream());
  st.upload_ms = uploaded.since(started);
  st.pba_ms = coloured.since(uploaded);
  st.amend_ms = amended.since(coloured);
}

} // namespace detail

DeviceVoronoi::DeviceVoronoi(std::span<const std::uint32_t> cell_owner, std::span<const std::uint32_t> site_x,
                             std::span<const std::uint32_t> site_y, std::uint32_t m,
                             const VoronoiOptions& options, VoronoiStats* stats)
    : state_(std::make_unique<State>()) {
  detail::colour_on_device(*state_, cell_owner, site_x, site_y, m, options, stats);
}

DeviceVoronoi::DeviceVoronoi(DeviceSites& sites, const VoronoiOptions& options, VoronoiStats* stats)
    : state_(std::make_unique<State>()) {
  detail::colour_on_device(*state_, {}, {}, {}, 0, options, stats, &sites.state());
}

DeviceVoronoi::~DeviceVoronoi() = default;
DeviceVoronoi::DeviceVoronoi(DeviceVoronoi&&) noexcept = default;
DeviceVoronoi& DeviceVoronoi::operator=(DeviceVoronoi&&) noexcept = default;

void DeviceVoronoi::site_cells(std::vector<std::uint32_t>& gx, std::vector<std::uint32_t>& gy,
                               const HostParallelFor& parallel) const {
  const std::size_t n = state_->num_points;
  gx.resize(n);
  gy.resize(n);
  state_->executor.download(gx.data(), state_->buffers.site_x.data(), n, &parallel);
  state_->executor.download(gy.data(), state_->buffers.site_y.data(), n, &parallel);
}

std::vector<std::uint32_t> DeviceVoronoi::colour(float* download_ms) const {
  detail::CudaExecutor& executor = state_->executor;
  const std::size_t cells = static_cast<std::size_t>(state_->m) * state_->m;
  detail::DeviceEvent started, done;
  started.record(executor.stream());
  std::vector<std::uint32_t> out(cells);
  executor.download(out.data(), state_->buffers.colour.data(), cells);
  done.record(executor.stream());
  if (download_ms != nullptr) *download_ms = done.since(started);
  return out;
}

namespace detail {

/// Whether j is in list[0, num), sorted.
__device__ inline bool sorted_contains(const std::uint32_t* list, std::uint32_t num, std::uint32_t j) {
  std::uint32_t lo = 0, hi = num;
  while (lo < hi) {
    const std::uint32_t mid = (lo + hi) / 2;
    if (list[mid] < j)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < num && list[lo] == j;
}

using ::cdt::detail::ProbeMap;

/// The value of a key the host's part of DeviceVoronoi::remove_sites stored (every cell and site the
/// flood reads is).
template <class V>
V& at(ProbeMap<std::uint32_t, V>& map, std::uint32_t key) {
  V* value = map.find(key);
  if (value == nullptr) throw Error("DeviceVoronoi::remove_sites: the flood read beyond its cells");
  return *value;
}

/// A cleared cell's neighbours (kNone past the last) as the flood of DeviceVoronoi::remove_sites
/// starts: their colours and those sites' grid cells.
struct Around {
  std::uint32_t cell[4], colour[4], gx[4], gy[4];
};

} // namespace detail

std::vector<std::uint32_t> DeviceVoronoi::remove_sites(std::span<const std::uint32_t> removed) {
  using ::cdt::kNone;
  std::vector<std::uint32_t> owners(removed.size(), kNone);
  if (removed.empty()) return owners;
  for (std::size_t k = 0; k < removed.size(); ++k)
    if (removed[k] >= state_->num_points || (k > 0 && removed[k - 1] >= removed[k]))
      throw Error("DeviceVoronoi::remove_sites: the sites are not sorted, distinct and in range");
  ::cdt::detail::StepTrace trace("device remove sites");
  detail::CudaExecutor& executor = state_->executor;
  detail::VoronoiBuffers& b = state_->buffers;
  const std::uint32_t m = state_->m;
  const std::size_t cells = static_cast<std::size_t>(m) * m;
  const auto num = static_cast<std::uint32_t>(removed.size());
  detail::DeviceBuffer<std::uint32_t> d_removed(num);
  executor.upload(d_removed.data(), removed.data(), num);
  const std::uint32_t* list = d_removed.data();
  std::uint32_t* colour = b.colour.data();
  const std::uint32_t* gx = b.site_x.data();
  const std::uint32_t* gy = b.site_y.data();
  // The cleared cells: every cell coloured by a removed site. Regions are 4-connected to their sites,
  // so these are the cells the host's walk from each site clears. Phase 1's scratch (m * m words,
  // free between the dual's passes) holds the list.
  std::uint32_t* cleared = b.owner.data();
  const std::uint32_t num_cleared = executor.compact(
      cells, [=] __device__(std::size_t c) { return detail::sorted_contains(list, num, colour[c]); },
      cleared);
  // Per cleared cell, its new colour when no neighbour is cleared (amend::isolated_cleared_colour: most
  // of them), else kNone; and the neighbours on the grid with their colours as the flood starts (kNone
  // for cleared ones) and those sites' grid cells: all the host's flood reads for the others.
  using detail::Around;
  detail::DeviceBuffer<std::uint32_t> d_new(num_cleared + 1);
  std::uint32_t* next = d_new.data();
  detail::DeviceBuffer<Around> d_around(num_cleared + 1);
  Around* around = d_around.data();
  executor.for_each(
      num_cleared,
      [=] __device__(std::size_t k) {
        const std::uint32_t c = cleared[k];
        const auto neighbour = [&](std::uint32_t x, std::uint32_t y) {
          const std::uint32_t j = colour[static_cast<std::size_t>(y) * m + x];
          return j == kNone || detail::sorted_contains(list, num, j) ? kNone : j;
        };
        next[k] =
            ::cdt::detail::amend::isolated_cleared_colour(m, c % m, c / m, neighbour, [=](std::uint32_t j) {
              const std::int64_t dx = static_cast<std::int64_t>(c % m) - gx[j];
              const std::int64_t dy = static_cast<std::int64_t>(c / m) - gy[j];
              return dx * dx + dy * dy;
            });
        if (next[k] != kNone) return;
        Around a;
        int i = 0;
        ::cdt::detail::amend::for_each_neighbour(m, c % m, c / m, [&](std::uint32_t x, std::uint32_t y) {
          const std::uint32_t j = neighbour(x, y);
          a.cell[i] = y * m + x;
          a.colour[i] = j;
          a.gx[i] = j == kNone ? 0 : gx[j];
          a.gy[i] = j == kNone ? 0 : gy[j];
          ++i;
        });
        for (; i < 4; ++i) a.cell[i] = kNone;
        around[k] = a;
      },
      "cleared_cells");
  trace.mark("cleared cells");

  // The others (in components of two or more cleared cells) are flooded on the host.
  detail::DeviceBuffer<std::uint32_t> d_rest(num_cleared + 1);
  std::uint32_t* rest = d_rest.data();
  const std::uint32_t num_rest = executor.compact(
      num_cleared, [=] __device__(std::size_t k) { return next[k] == kNone; }, rest);
  if (num_rest > 0) {
    detail::DeviceBuffer<std::uint32_t> d_rest_cells(num_rest);
    detail::DeviceBuffer<Around> d_rest_around(num_rest);
    std::uint32_t* rest_cells = d_rest_cells.data();
    Around* rest_around = d_rest_around.data();
    executor.for_each(
        num_rest,
        [=] __device__(std::size_t r) {
          rest_cells[r] = cleared[rest[r]];
          rest_around[r] = around[rest[r]];
        },
        "gather_flooded_cells");
    std::vector<std::uint32_t> h_cleared(num_rest);
    std::vector<Around> h_around(num_rest);
    executor.download(h_cleared.data(), rest_cells, num_rest);
    executor.download(h_around.data(), rest_around, num_rest);
    detail::ProbeMap<std::uint32_t, std::uint32_t> local_colour(5 * static_cast<std::size_t>(num_rest));
    detail::ProbeMap<std::uint32_t, std::array<std::uint32_t, 2>> site_cell(
        4 * static_cast<std::size_t>(num_rest));
    for (std::uint32_t r = 0; r < num_rest; ++r) {
      const std::uint32_t c = h_cleared[r];
      local_colour.set(c, kNone);
      const Around& a = h_around[r];
      for (int i = 0; i < 4 && a.cell[i] != kNone; ++i) {
        local_colour.find_or_add(a.cell[i], a.colour[i]);
        if (a.colour[i] != kNone) site_cell.set(a.colour[i], {a.gx[i], a.gy[i]});
      }
    }
    ::cdt::detail::flood_cleared_cells(
        h_cleared, m, [&](std::uint32_t c) -> std::uint32_t& { return detail::at(local_colour, c); },
        [&](std::uint32_t j) { return detail::at(site_cell, j); });
    std::vector<std::uint32_t> h_new(num_rest);
    for (std::uint32_t r = 0; r < num_rest; ++r) h_new[r] = detail::at(local_colour, h_cleared[r]);
    executor.upload(rest_cells, h_new.data(), num_rest); // reused for the new colours
    executor.for_each(
        num_rest, [=] __device__(std::size_t r) { next[rest[r]] = rest_cells[r]; }, "scatter_flooded_cells");
  }
  trace.mark("flooded on the host");
  executor.for_each(
      num_cleared, [=] __device__(std::size_t k) { colour[cleared[k]] = next[k]; }, "recolour_cleared");
  detail::DeviceBuffer<std::uint32_t> d_owners(num);
  std::uint32_t* owner = d_owners.data();
  executor.for_each(
      num,
      [=] __device__(std::size_t k) {
        const std::uint32_t s = list[k];
        owner[k] = colour[static_cast<std::size_t>(gy[s]) * m + gx[s]];
      },
      "removed_sites_owners");
  executor.download(owners.data(), owner, num);
  trace.mark("recoloured");
  return owners;
}

std::vector<std::uint32_t> compute_digital_voronoi(std::span<const std::uint32_t> cell_owner,
                                                   std::span<const std::uint32_t> site_x,
                                                   std::span<const std::uint32_t> site_y, std::uint32_t m,
                                                   const VoronoiOptions& options, VoronoiStats* stats) {
  const DeviceVoronoi diagram(cell_owner, site_x, site_y, m, options, stats);
  return diagram.colour(stats != nullptr ? &stats->download_ms : nullptr);
}

} // namespace cdt::gpu
