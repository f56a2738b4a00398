// Phase 1 of gCD, second half (paper section 3.1, Appendix A): the digital Voronoi diagram on the CPU
// executor. The per-element work of both steps, and why it is exact, is in voronoi.hpp, shared with the
// CUDA executor (kernels/voronoi_kernels.cu); this file picks the band counts, owns the buffers and
// runs the steps.
//
// Parallel Banding Algorithm (Cao, Tang, Mei, Tan and Lee, I3D 2010): pba::run_pba, with bands suited
// to a few threads. Appendix A (Algorithm A.1): a parallel scan finds the orphans, then a short
// worklist (debris are rare) finishes the set and a priority-queue flood recolours it, on the CPU as in
// the paper.

#include "gcd/voronoi.hpp"

#include <algorithm>
#include <cstdint>
#include <functional>
#include <memory>
#include <queue>
#include <string>
#include <utility>
#include <vector>

#include "cdt/detail/host_device.hpp"
#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"

namespace cdt::detail {

namespace {

using namespace pba;
using namespace amend;

/// Phase 1: bands of 8 rows, then as few column groups as give the executor enough tasks (its steps
/// run serially below a few thousand), so that each task reads long runs of a row.
std::uint32_t default_row_bands(std::uint32_t m) { return (m + 7) / 8; }
std::uint32_t default_groups(std::uint32_t m, std::uint32_t row_bands) {
  const std::uint32_t wanted = (8192 + row_bands - 1) / row_bands;
  return std::max(1u, std::min(wanted, m / 16));
}
/// Phases 2 and 3: enough (row, column band) tasks for the executor, bands of at least 16 columns so
/// the stack merges stay few.
std::uint32_t default_col_bands(std::uint32_t m) {
  std::uint32_t bands = 1;
  while (bands * 2 <= m / 16 && static_cast<std::uint64_t>(bands) * m < 16384) bands *= 2;
  return bands;
}

/// m * m uint32 left uninitialised: every step that reads such a buffer has written it first.
using Scratch = std::unique_ptr<std::uint32_t[]>;

/// Phase 3's output, the packed nearest site of every cell, by the three phases of PBA. The stack
/// buffer is handed back in `scratch` for the orphan search to reuse.
std::vector<std::uint32_t> nearest_site_positions(std::span<const std::uint32_t> cell_owner, std::uint32_t m,
                                                  CpuExecutor& executor, std::uint32_t bands,
                                                  Scratch& scratch) {
  if (m == 0 || m > kMaxGridSize) throw Error("internal error: grid size " + std::to_string(m));
  const std::size_t cells = static_cast<std::size_t>(m) * m;
  if (cell_owner.size() != cells) throw Error("internal error: cell_owner is not m * m");
  const std::uint32_t row_bands = bands != 0 ? bands : default_row_bands(m);
  PbaView v;
  static_cast<PbaLayout&>(v) = PbaLayout::make(m, row_bands, default_groups(m, std::min(row_bands, m)),
                                               bands != 0 ? bands : default_col_bands(m));

  std::vector<std::uint32_t> site(cells);
  scratch.reset(new std::uint32_t[cells]);
  std::vector<std::uint32_t> stack_size(v.stack_size_entries());
  std::vector<std::uint32_t> above(v.band_link_entries());
  std::vector<std::uint32_t> below(v.band_link_entries());
  v.owner = cell_owner.data();
  v.column = site.data();
  v.stack = scratch.get();
  v.stack_size = stack_size.data();
  v.above = above.data();
  v.below = below.data();
  run_pba(executor, v);
  return site;
}

/// colour[c] = the point kept at packed site position site[c] (kNone stays); colour may be site.
void positions_to_owners(std::span<const std::uint32_t> cell_owner, std::uint32_t m,
                         const std::uint32_t* site, std::uint32_t* colour, CpuExecutor& executor) {
  const std::uint32_t* owner = cell_owner.data();
  executor.for_each(static_cast<std::size_t>(m) * m,
                    [=](std::size_t c) { colour[c] = owner_at(owner, m, site[c]); });
}

// --- Appendix A -----------------------------------------------------------------------------------------

/// One entry of Algorithm A.1's queue: colour `cell` with `site`, at that distance. Ordered by
/// (distance, site index), the tie rule of Definition 1; the cell only makes the order total.
struct FloodEntry {
  std::int64_t distance;
  std::uint32_t site;
  std::uint32_t cell;
  friend bool operator>(const FloodEntry& a, const FloodEntry& b) {
    if (key_before(b.distance, b.site, a.distance, a.site)) return true;
    if (key_before(a.distance, a.site, b.distance, b.site)) return false;
    return a.cell > b.cell;
  }
};

/// The orphans among the cells [lo, hi) of row y, written to out; returns how many.
CDT_HD inline std::uint32_t find_orphans_in_band(const std::uint32_t* site, std::uint32_t m, std::uint32_t y,
                                                 std::uint32_t lo, std::uint32_t hi, std::uint32_t* out) {
  std::uint32_t count = 0;
  for (std::uint32_t x = lo; x < hi; ++x)
    if (is_orphan_at(site, m, x, y)) out[count++] = y * m + x;
  return count;
}

/// Every orphan of the packed nearest-site grid, in parallel per (row, column band); scratch (m * m)
/// holds each task's finds at the task's own cells until they are gathered.
std::vector<std::uint32_t> find_orphans(const std::uint32_t* site, std::uint32_t m, std::uint32_t* scratch,
                                        CpuExecutor& executor) {
  const std::uint32_t bands = default_col_bands(m);
  const std::uint32_t width = (m + bands - 1) / bands;
  std::vector<std::uint32_t> counts(static_cast<std::size_t>(bands) * m);
  std::uint32_t* count = counts.data();
  executor.for_each(counts.size(), [=](std::size_t t) {
    const auto y = static_cast<std::uint32_t>(t % m), b = static_cast<std::uint32_t>(t / m);
    const std::uint32_t lo = std::min(m, b * width), hi = std::min(m, lo + width);
    count[t] = find_orphans_in_band(site, m, y, lo, hi, scratch + static_cast<std::size_t>(y) * m + lo);
  });
  // Debris are rare: gathering them serially costs little.
  std::vector<std::uint32_t> orphans;
  for (std::size_t t = 0; t < counts.size(); ++t) {
    if (count[t] == 0) continue;
    const auto y = static_cast<std::uint32_t>(t % m), b = static_cast<std::uint32_t>(t / m);
    const std::uint32_t* found = scratch + static_cast<std::size_t>(y) * m + std::min(m, b * width);
    orphans.insert(orphans.end(), found, found + count[t]);
  }
  return orphans;
}

/// Algorithm A.1 on colour (point indices) given its orphans: the remaining debris by a worklist,
/// then the priority-queue flood. Returns the number of debris.
std::size_t recolour_debris(std::vector<std::uint32_t>& colour, std::vector<std::uint32_t> debris,
                            const GridSites& sites, std::uint32_t m) {
  if (debris.empty()) return 0;
  FloodView v;
  v.colour = colour.data();
  v.site_x = sites.gx.data();
  v.site_y = sites.gy.data();
  v.m = m;
  // Debris lose their colour; the colour goes along in the worklist to find the cells that depend on
  // them. A cell depends on a debris neighbour of its own colour, and is debris itself once it is an
  // orphan of the colouring with the debris removed.
  std::vector<std::uint32_t> debris_colour(debris.size());
  for (std::size_t k = 0; k < debris.size(); ++k) {
    debris_colour[k] = colour[debris[k]];
    colour[debris[k]] = kNone;
  }
  for (std::size_t k = 0; k < debris.size(); ++k) {
    const std::uint32_t i = debris_colour[k];
    std::uint32_t next[4];
    const std::uint32_t count = debris_successors(v, debris[k], i, next);
    for (std::uint32_t j = 0; j < count; ++j) {
      colour[next[j]] = kNone;
      debris.push_back(next[j]);
      debris_colour.push_back(i);
    }
  }

  // Algorithm A.1: seed the queue from the coloured neighbours that are closer to their own site,
  // then flood, each colour passing only to cells farther from its site (line 11).
  std::priority_queue<FloodEntry, std::vector<FloodEntry>, std::greater<>> queue;
  for (const std::uint32_t a : debris) {
    const std::uint32_t ax = a % m, ay = a / m;
    for_each_neighbour(m, ax, ay, [&](std::uint32_t x, std::uint32_t y) {
      const std::uint32_t j = colour[static_cast<std::size_t>(y) * m + x];
      if (j == kNone) return;
      const std::int64_t d = squared_distance(v, ax, ay, j);
      if (squared_distance(v, x, y, j) < d) queue.push({d, j, a});
    });
  }
  while (!queue.empty()) {
    const FloodEntry e = queue.top();
    queue.pop();
    if (colour[e.cell] != kNone) continue;
    colour[e.cell] = e.site;
    for_each_neighbour(m, e.cell % m, e.cell / m, [&](std::uint32_t x, std::uint32_t y) {
      const std::size_t c = static_cast<std::size_t>(y) * m + x;
      if (colour[c] != kNone) return;
      const std::int64_t d = squared_distance(v, x, y, e.site);
      if (d > e.distance) queue.push({d, e.site, static_cast<std::uint32_t>(c)});
    });
  }
  return debris.size();
}

} // namespace

std::vector<std::uint32_t> compute_euclidean_colouring(std::span<const std::uint32_t> cell_owner,
                                                       std::uint32_t m, CpuExecutor& executor,
                                                       std::uint32_t bands) {
  Scratch scratch;
  std::vector<std::uint32_t> colour = nearest_site_positions(cell_owner, m, executor, bands, scratch);
  positions_to_owners(cell_owner, m, colour.data(), colour.data(), executor);
  return colour;
}

std::size_t amend_to_standard_flooding(std::vector<std::uint32_t>& colour, const GridSites& sites,
                                       std::uint32_t m, CpuExecutor& executor) {
  const std::size_t cells = static_cast<std::size_t>(m) * m;
  if (colour.size() != cells) throw Error("internal error: colour is not m * m");
  // The orphan test wants packed site positions, which compute_digital_voronoi has from PBA.
  std::vector<std::uint32_t> site(cells);
  const std::uint32_t* in = colour.data();
  const std::uint32_t* gx = sites.gx.data();
  const std::uint32_t* gy = sites.gy.data();
  std::uint32_t* out = site.data();
  executor.for_each(cells,
                    [=](std::size_t c) { out[c] = in[c] == kNone ? kNone : pack(gy[in[c]], gx[in[c]]); });
  const Scratch scratch(new std::uint32_t[cells]);
  return recolour_debris(colour, find_orphans(site.data(), m, scratch.get(), executor), sites, m);
}

std::vector<std::uint32_t> remove_sites_from_colouring(std::vector<std::uint32_t>& colour,
                                                       const GridSites& sites, std::uint32_t m,
                                                       std::span<const std::uint32_t> removed) {
  if (colour.size() != static_cast<std::size_t>(m) * m) throw Error("internal error: colour is not m * m");
  // Each removed site's region is 4-connected to its own cell: a breadth-first walk finds all of it.
  std::vector<std::uint32_t> cleared;
  for (const std::uint32_t s : removed) {
    const std::size_t start = static_cast<std::size_t>(sites.gy[s]) * m + sites.gx[s];
    if (colour[start] != s) continue;
    const std::size_t first = cleared.size();
    colour[start] = kNone;
    cleared.push_back(static_cast<std::uint32_t>(start));
    for (std::size_t k = first; k < cleared.size(); ++k) {
      for_each_neighbour(m, cleared[k] % m, cleared[k] / m, [&](std::uint32_t x, std::uint32_t y) {
        const std::size_t c = static_cast<std::size_t>(y) * m + x;
        if (colour[c] != s) return;
        colour[c] = kNone;
        cleared.push_back(static_cast<std::uint32_t>(c));
      });
    }
  }
  flood_cleared_cells(
      cleared, m, [&](std::uint32_t c) -> std::uint32_t& { return colour[c]; },
      [&](std::uint32_t j) {
        return std::array<std::uint32_t, 2>{sites.gx[j], sites.gy[j]};
      });
  return cleared;
}

void flood_cleared_cells(std::span<const std::uint32_t> cleared, std::uint32_t m,
                         const std::function<std::uint32_t&(std::uint32_t cell)>& colour,
                         const std::function<std::array<std::uint32_t, 2>(std::uint32_t site)>& site_cell) {
  const auto distance = [&](std::uint32_t x, std::uint32_t y, std::uint32_t j) {
    const auto [sx, sy] = site_cell(j);
    const std::int64_t dx = static_cast<std::int64_t>(x) - sx;
    const std::int64_t dy = static_cast<std::int64_t>(y) - sy;
    return dx * dx + dy * dy;
  };
  // Algorithm A.1 without its "closer to the own site" condition at the seeds: a cleared region's
  // border need not be. The queue's order is total, so the result does not depend on the order of
  // `cleared`. Most cleared cells are alone among coloured neighbours (a removed site's region is
  // often its own cell): those take their colour at once (a queue of them all costs a cache miss per
  // entry), which the queue would also give them, since no other entry reaches them. A cell decided so
  // is no neighbour of another cleared cell, so the order of this pass does not matter either.
  std::vector<std::uint32_t> rest;
  for (const std::uint32_t a : cleared) {
    const std::uint32_t j = amend::isolated_cleared_colour(
        m, a % m, a / m, [&](std::uint32_t x, std::uint32_t y) { return colour(y * m + x); },
        [&](std::uint32_t site) { return distance(a % m, a / m, site); });
    if (j != kNone)
      colour(a) = j;
    else
      rest.push_back(a);
  }
  std::priority_queue<FloodEntry, std::vector<FloodEntry>, std::greater<>> queue;
  for (const std::uint32_t a : rest) {
    for_each_neighbour(m, a % m, a / m, [&](std::uint32_t x, std::uint32_t y) {
      const std::uint32_t j = colour(y * m + x);
      if (j != kNone) queue.push({distance(a % m, a / m, j), j, a});
    });
  }
  while (!queue.empty()) {
    const FloodEntry e = queue.top();
    queue.pop();
    std::uint32_t& here = colour(e.cell);
    if (here != kNone) continue;
    here = e.site;
    for_each_neighbour(m, e.cell % m, e.cell / m, [&](std::uint32_t x, std::uint32_t y) {
      const std::uint32_t c = y * m + x;
      if (colour(c) == kNone) queue.push({distance(x, y, e.site), e.site, c});
    });
  }
}

std::vector<std::uint32_t> compute_digital_voronoi(const GridSites& sites, std::uint32_t m,
                                                   CpuExecutor& executor) {
  Scratch scratch;
  std::vector<std::uint32_t> colour = nearest_site_positions(sites.cell_owner, m, executor, 0, scratch);
  std::vector<std::uint32_t> orphans = find_orphans(colour.data(), m, scratch.get(), executor);
  scratch.reset();
  positions_to_owners(sites.cell_owner, m, colour.data(), colour.data(), executor);
  recolour_debris(colour, std::move(orphans), sites, m);
  return colour;
}

} // namespace cdt::detail
