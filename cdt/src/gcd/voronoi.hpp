#pragma once
// Phase 1 of gCD, second half (paper section 3.1 and Appendix A): the digital Voronoi diagram of the
// grid sites, computed as a Euclidean colouring by the Parallel Banding Algorithm (Cao, Tang, Mei,
// Tan, Lee, I3D 2010) and amended to the Standard-flooding result, whose dual is a valid
// triangulation (Algorithm A.1).
//
// The second half of this header is the per-element work of both steps (namespaces pba and amend),
// written once for the host and the device: voronoi.cpp runs it on the CPU executor and
// kernels/voronoi_kernels.cu on the CUDA executor, so the two give the same colouring by construction.
// It needs the C++ standard library only and includes no CUDA header.

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "cdt/detail/host_device.hpp"
#include "gcd/grid_map.hpp"

namespace cdt::detail {

class CpuExecutor;

/// colour[gy*m+gx] = the kept point nearest to grid point (gx,gy) (squared Euclidean distance, exact in
/// 64-bit integers); ties broken by the smaller point index (Definition 1), then amended (Appendix A)
/// so that every colour region is connected to its own site (the Standard-flooding result, whose dual
/// is a valid triangulation). Every cell is coloured unless there is no kept point at all (then every
/// cell is kNone). sites.cell_owner must have m * m entries.
std::vector<std::uint32_t> compute_digital_voronoi(const GridSites& sites, std::uint32_t m,
                                                   CpuExecutor& executor);

// --- the two steps, exposed for tests ----------------------------------------------------------------

/// The Euclidean colouring of Definition 1 by the Parallel Banding Algorithm, before the amendment:
/// colour[gy*m+gx] = the owner of the nearest occupied cell, ties to the smaller owner index; kNone
/// everywhere when no cell is occupied. cell_owner: m * m point indices or kNone (GridSites).
/// bands = 0 picks the number of bands from m; tests pass other counts (any in [1, m]) to exercise
/// the band merging, which must not change the result.
std::vector<std::uint32_t> compute_euclidean_colouring(std::span<const std::uint32_t> cell_owner,
                                                       std::uint32_t m, CpuExecutor& executor,
                                                       std::uint32_t bands = 0);

/// Takes the sites in `removed` out of an amended colouring, in place: their regions are cleared and
/// flooded from the neighbouring regions, nearest site first, so every region stays connected to its
/// site. Used when a degenerate corner (three collinear sites meeting at a grid corner) makes the dual
/// invalid: the middle site leaves the diagram and is inserted later as a missing point. Returns the
/// cells that changed colour.
std::vector<std::uint32_t> remove_sites_from_colouring(std::vector<std::uint32_t>& colour,
                                                       const GridSites& sites, std::uint32_t m,
                                                       std::span<const std::uint32_t> removed);

/// The flood of remove_sites_from_colouring on any store of the colouring: the `cleared` cells (kNone)
/// take the colours of their neighbours, nearest site first. colour(c) is cell c's colour, writable;
/// site_cell(j) site j's grid cell (x, y). Only the cleared cells and their 4-neighbours are read or
/// written, and only the sites colouring those neighbours asked for, so a caller may hold just those
/// (the CUDA executor does). Every cleared cell next to a coloured one ends coloured.
void flood_cleared_cells(std::span<const std::uint32_t> cleared, std::uint32_t m,
                         const std::function<std::uint32_t&(std::uint32_t cell)>& colour,
                         const std::function<std::array<std::uint32_t, 2>(std::uint32_t site)>& site_cell);

/// Algorithm A.1 on a Euclidean colouring of sites, in place: the debris (cells that no 4-connected
/// path of their own colour reaches from their site; see voronoi.cpp for the exact test) are
/// uncoloured and flooded again from their neighbours. Returns the number of debris cells, each of
/// which may have received its old colour back.
std::size_t amend_to_standard_flooding(std::vector<std::uint32_t>& colour, const GridSites& sites,
                                       std::uint32_t m, CpuExecutor& executor);

// =====================================================================================================
// Per-element work, shared by the CPU and the CUDA executor.
// =====================================================================================================

// --- Parallel Banding Algorithm ------------------------------------------------------------------------
//
// Euclidean colouring (Definition 1) in the three phases of PBA:
//   1. per column: the nearest occupied cell in that column for every cell, by a sweep down and a
//      sweep up inside bands of rows, the bands linked by their first and last occupied cells;
//   2. per row: the "proximate sites", the lower envelope of the column candidates' distance
//      parabolas, by a stack inside bands of columns, the bands' stacks then merged in pairs;
//   3. per row: every cell coloured by walking the proximate sites.
// Everything is exact in 64-bit integers, and the tie rule of Definition 1 (the smaller point index
// wins) is built into every comparison, so the result is the brute-force nearest site exactly, for
// every choice of band counts: an executor picks the counts that suit it.
//
// Ties in phase 1: two candidates of a column at the same vertical distance from row y are at the same
// distance from every cell of row y, so keeping the smaller index there is what Definition 1 keeps.
// Ties in phases 2 and 3: for candidates a, b of row y in columns xa < xb, whether b beats a at
// column px, that is (d_b(px), b's index) < (d_a(px), a's index), switches from false to true exactly
// once as px grows, because d_a(px) - d_b(px) is linear and increasing in px. The switch point
//   t(a, b) = the smallest integer px at which b beats a
// (computed with the tie rule at an integer crossing) is all the envelope needs: b between a and c
// wins some column of the grid iff clamp(t(a, b)) < clamp(t(b, c)) (clamped to [0, m]), the stack
// keeps the clamped switch points strictly increasing, and the winner at px is the stack entry k with
// t(k-1, k) <= px < t(k, k+1). Per px the (distance, index) keys form a total order, which makes
// pairwise tests between stack neighbours sufficient. Because beating is monotone, "t(b, c) <= T" is
// the same as "c beats b at column T": the stack tests and phase 3 compare two distances and divide
// only once per pushed entry.
namespace pba {

/// Columns whose running state pba_link_bands keeps in registers at a time.
inline constexpr std::uint32_t kLinkChunk = 64;

// Sites are packed as (row, column), 16 bits each (m <= kMaxGridSize); kNone stays free.
CDT_HD_INLINE std::uint32_t pack(std::uint32_t row, std::uint32_t col) { return (row << 16) | col; }
CDT_HD_INLINE std::uint32_t packed_row(std::uint32_t p) { return p >> 16; }
CDT_HD_INLINE std::uint32_t packed_col(std::uint32_t p) { return p & 0xFFFFu; }

/// How the grid is cut into tasks; any counts give the same colouring.
struct PbaLayout {
  std::uint32_t m = 0;
  std::uint32_t row_bands = 1, row_band_height = 0; ///< phase 1: bands of rows
  std::uint32_t group_width = 0;                    ///< phase 1: columns per task
  std::uint32_t col_bands = 1, col_band_width = 0;  ///< phases 2 and 3: bands of columns

  /// Layout of an m x m grid (1 <= m <= kMaxGridSize) for the wanted counts, each clamped to [1, m].
  static PbaLayout make(std::uint32_t m, std::uint32_t row_bands, std::uint32_t groups,
                        std::uint32_t col_bands) {
    const auto clamp = [m](std::uint32_t v) { return v < 1 ? 1u : v > m ? m : v; };
    PbaLayout l;
    l.m = m;
    l.row_bands = clamp(row_bands);
    l.row_band_height = (m + l.row_bands - 1) / l.row_bands;
    const std::uint32_t g = clamp(groups);
    l.group_width = (m + g - 1) / g;
    l.col_bands = clamp(col_bands);
    l.col_band_width = (m + l.col_bands - 1) / l.col_bands;
    return l;
  }
  CDT_HD std::uint32_t groups() const { return (m + group_width - 1) / group_width; }
  /// Tasks of the phase-1 steps (row band, column group) and of phases 2 and 3 (row, column band).
  CDT_HD std::size_t group_tasks() const { return static_cast<std::size_t>(row_bands) * groups(); }
  CDT_HD std::size_t row_tasks() const { return static_cast<std::size_t>(col_bands) * m; }
  /// Pairs of groups per row in the merge round that joins groups of `width` column bands into
  /// groups of 2 * width, and the round's tasks: one per (row, pair).
  CDT_HD std::uint32_t merge_pairs(std::uint32_t width) const {
    return (col_bands + 2 * width - 1) / (2 * width);
  }
  CDT_HD std::size_t merge_tasks(std::uint32_t width) const {
    return static_cast<std::size_t>(merge_pairs(width)) * m;
  }
  /// Entries of the buffers below: m * m for owner, column and stack.
  std::size_t stack_size_entries() const { return static_cast<std::size_t>(m) * col_bands; }
  std::size_t band_link_entries() const { return static_cast<std::size_t>(row_bands) * m; }
};

/// Raw view of the PBA buffers (host or device pointers) so the per-element functions run unchanged on
/// either side.
struct PbaView : PbaLayout {
  const std::uint32_t* owner = nullptr; ///< m*m: point kept in the cell or kNone
  std::uint32_t* column = nullptr;      ///< m*m: phase 1's nearest occupied row in the column; phase 3's site
  std::uint32_t* stack = nullptr;       ///< m*m: per row, proximate sites as packed (row, column)
  std::uint32_t* stack_size = nullptr;  ///< m*col_bands: entries of band b's stack of row y at y*col_bands+b
  std::uint32_t* above = nullptr;       ///< row_bands*m: nearest occupied row above row band b in column x
  std::uint32_t* below = nullptr;       ///< row_bands*m: nearest occupied row below row band b in column x

  CDT_HD std::uint32_t row_begin(std::uint32_t b) const {
    return b * row_band_height < m ? b * row_band_height : m;
  }
  CDT_HD std::uint32_t col_begin(std::uint32_t b) const {
    return b * col_band_width < m ? b * col_band_width : m;
  }
  CDT_HD std::uint32_t group_begin(std::uint32_t g) const {
    return g * group_width < m ? g * group_width : m;
  }
  CDT_HD std::size_t at(std::uint32_t x, std::uint32_t y) const {
    return static_cast<std::size_t>(y) * m + x;
  }
  CDT_HD std::uint32_t owner_of(std::uint32_t packed) const {
    return owner[at(packed_col(packed), packed_row(packed))];
  }
};

/// floor(n / d) for d > 0.
CDT_HD_INLINE std::int64_t floor_div(std::int64_t n, std::int64_t d) {
  const std::int64_t q = n / d;
  return (n % d != 0 && n < 0) ? q - 1 : q;
}

/// t(a, b) for proximate-site candidates a and b (packed, column of a < column of b) of row y: the
/// smallest integer column at which b beats a under Definition 1.
CDT_HD inline std::int64_t switch_point(const PbaView& v, std::uint32_t a, std::uint32_t b, std::uint32_t y) {
  const std::int64_t xa = packed_col(a);
  const std::int64_t xb = packed_col(b);
  const std::int64_t ya = static_cast<std::int64_t>(packed_row(a)) - y;
  const std::int64_t yb = static_cast<std::int64_t>(packed_row(b)) - y;
  // b beats a at px iff px * den > num, or equal with b's index smaller.
  const std::int64_t num = (xb * xb - xa * xa) + (yb * yb - ya * ya);
  const std::int64_t den = 2 * (xb - xa);
  const std::int64_t q = floor_div(num, den);
  if (q * den != num) return q + 1;
  return v.owner_of(b) < v.owner_of(a) ? q : q + 1;
}

/// Whether site b beats site a (both packed) at cell (px, y) under Definition 1. Phase 3 walks with
/// this instead of switch points: no division, and the owners are read only on an exact tie.
CDT_HD inline bool beats(const PbaView& v, std::uint32_t b, std::uint32_t a, std::uint32_t px,
                         std::uint32_t y) {
  const std::int64_t ax = static_cast<std::int64_t>(px) - packed_col(a);
  const std::int64_t ay = static_cast<std::int64_t>(y) - packed_row(a);
  const std::int64_t bx = static_cast<std::int64_t>(px) - packed_col(b);
  const std::int64_t by = static_cast<std::int64_t>(y) - packed_row(b);
  const std::int64_t da = ax * ax + ay * ay;
  const std::int64_t db = bx * bx + by * by;
  return db < da || (db == da && v.owner_of(b) < v.owner_of(a));
}

// Phase 1 tasks are (row band, column group): a task walks its band row by row across the group's
// columns, reading memory along rows, the order a CPU prefers; a device runs groups of one column, one
// thread per column, so neighbouring threads read neighbouring cells. The per-column running state
// lives in the band's own row of above and below.

/// Phase 1, first step: the first and last occupied rows of row band b in the columns of group g,
/// parked in below and above until pba_link_bands turns them into the neighbouring bands' nearest.
CDT_HD inline void pba_band_ends(const PbaView& v, std::uint32_t b, std::uint32_t g) {
  const std::uint32_t lo = v.row_begin(b), hi = v.row_begin(b + 1);
  const std::uint32_t x0 = v.group_begin(g), x1 = v.group_begin(g + 1);
  std::uint32_t* first = v.below + static_cast<std::size_t>(b) * v.m;
  std::uint32_t* last = v.above + static_cast<std::size_t>(b) * v.m;
  for (std::uint32_t x = x0; x < x1; ++x) first[x] = last[x] = kNone;
  for (std::uint32_t y = lo; y < hi; ++y) {
    const std::uint32_t* owners = v.owner + v.at(0, y);
    for (std::uint32_t x = x0; x < x1; ++x) {
      if (owners[x] == kNone) continue;
      if (first[x] == kNone) first[x] = y;
      last[x] = y;
    }
  }
}

/// Phase 1, second step (O(row bands) per column): above[b] becomes the last occupied row of the
/// bands before b, below[b] the first occupied row of the bands after b, for the columns of group g.
CDT_HD inline void pba_link_bands(const PbaView& v, std::uint32_t g) {
  const std::uint32_t x1 = v.group_begin(g + 1);
  for (std::uint32_t x0 = v.group_begin(g); x0 < x1; x0 += kLinkChunk) {
    const std::uint32_t n = x1 - x0 < kLinkChunk ? x1 - x0 : kLinkChunk;
    std::uint32_t run[kLinkChunk];
    for (std::uint32_t k = 0; k < n; ++k) run[k] = kNone;
    for (std::uint32_t b = 0; b < v.row_bands; ++b) {
      std::uint32_t* slot = v.above + static_cast<std::size_t>(b) * v.m + x0;
      for (std::uint32_t k = 0; k < n; ++k) {
        const std::uint32_t last = slot[k];
        slot[k] = run[k];
        if (last != kNone) run[k] = last;
      }
    }
    for (std::uint32_t k = 0; k < n; ++k) run[k] = kNone;
    for (std::uint32_t b = v.row_bands; b > 0; --b) {
      std::uint32_t* slot = v.below + static_cast<std::size_t>(b - 1) * v.m + x0;
      for (std::uint32_t k = 0; k < n; ++k) {
        const std::uint32_t first = slot[k];
        slot[k] = run[k];
        if (first != kNone) run[k] = first;
      }
    }
  }
}

/// Phase 1, third step: the nearest occupied row in each column of group g for every row of row
/// band b: a sweep down and a sweep up, each starting from the neighbouring bands' nearest sites.
CDT_HD inline void pba_column_sweep(const PbaView& v, std::uint32_t b, std::uint32_t g) {
  const std::uint32_t lo = v.row_begin(b), hi = v.row_begin(b + 1);
  const std::uint32_t x0 = v.group_begin(g), x1 = v.group_begin(g + 1);
  std::uint32_t* nearest = v.above + static_cast<std::size_t>(b) * v.m;
  for (std::uint32_t y = lo; y < hi; ++y) {
    const std::uint32_t* owners = v.owner + v.at(0, y);
    std::uint32_t* out = v.column + v.at(0, y);
    for (std::uint32_t x = x0; x < x1; ++x) {
      if (owners[x] != kNone) nearest[x] = y;
      out[x] = nearest[x];
    }
  }
  nearest = v.below + static_cast<std::size_t>(b) * v.m;
  for (std::uint32_t y = hi; y > lo; --y) {
    const std::uint32_t row = y - 1;
    std::uint32_t* out = v.column + v.at(0, row);
    for (std::uint32_t x = x0; x < x1; ++x) {
      const std::uint32_t up = out[x];
      if (up == row) { // occupied: the down sweep wrote the cell's own row
        nearest[x] = row;
        continue;
      }
      const std::uint32_t down = nearest[x];
      if (down == kNone) continue; // the nearest above stays, kNone or not
      std::uint32_t best = down;
      if (up != kNone) {
        const std::uint32_t du = row - up, dd = down - row;
        if (du < dd || (du == dd && v.owner[v.at(x, up)] < v.owner[v.at(x, down)])) best = up;
      }
      out[x] = best;
    }
  }
}

/// switch_point clamped to [0, m]. Comparing clamped switch points removes exactly the candidates
/// that win no column of the grid: b wins the columns [t(a, b), t(b, c)) of [0, m), which is empty iff
/// clamp(t(a, b)) >= clamp(t(b, c)). Columns outside the grid need no answer, and clamped values fit
/// the 32-bit slots they are kept in.
CDT_HD inline std::uint32_t clamped_switch_point(const PbaView& v, std::uint32_t a, std::uint32_t b,
                                                 std::uint32_t y) {
  const std::int64_t t = switch_point(v, a, b, y);
  return t <= 0 ? 0u : t >= v.m ? v.m : static_cast<std::uint32_t>(t);
}

/// Pushes candidate c onto the proximate-site stack s of row y (size entries; t[k] holds the clamped
/// switch point of s[k-1] and s[k]), first removing the entries that c leaves without a column to
/// win. Returns whether any entry was removed.
/// The top entry falls out iff clamp(t(top, c)) <= t[top], i.e. iff c already beats the top at column
/// t[top] (beating only switches on as the column grows), or t[top] = m: one distance comparison and
/// no division per test; the one division per push computes the new entry's switch point.
CDT_HD inline bool push_proximate(const PbaView& v, std::uint32_t* s, std::uint32_t* t, std::uint32_t& size,
                                  std::uint32_t c, std::uint32_t y) {
  bool removed = false;
  while (size >= 2 && (t[size - 1] >= v.m || beats(v, c, s[size - 1], t[size - 1], y))) {
    --size;
    removed = true;
  }
  if (size > 0) t[size] = clamped_switch_point(v, s[size - 1], c, y);
  s[size++] = c;
  return removed;
}

/// Phase 2, first step: the proximate sites of row y among the candidates of the columns of column
/// band b, stored in place at the band's own columns of the row. Their switch points go to the same
/// columns of the candidate row: a stack never holds more entries than candidates already read.
CDT_HD inline void pba_band_stack(const PbaView& v, std::uint32_t y, std::uint32_t b) {
  const std::uint32_t lo = v.col_begin(b), hi = v.col_begin(b + 1);
  std::uint32_t* s = v.stack + v.at(lo, y);
  std::uint32_t* t = v.column + v.at(lo, y);
  std::uint32_t size = 0;
  for (std::uint32_t x = lo; x < hi; ++x) {
    const std::uint32_t row = v.column[v.at(x, y)];
    if (row != kNone) push_proximate(v, s, t, size, pack(row, x), y);
  }
  v.stack_size[static_cast<std::size_t>(y) * v.col_bands + b] = size;
}

/// Phase 2, merge step: appends the stack of column-band group `right` of row y to that of group
/// `left`. Only the right stack's first entries can fall out (its inner triples are already valid),
/// so the merge stops at the first right entry after the first that removes nothing and copies the
/// rest with their switch points. Writes never overtake reads: the left group's stack fits in its
/// own columns.
CDT_HD inline void pba_merge_stacks(const PbaView& v, std::uint32_t y, std::uint32_t left,
                                    std::uint32_t right) {
  std::uint32_t* s = v.stack + v.at(v.col_begin(left), y);
  std::uint32_t* t = v.column + v.at(v.col_begin(left), y);
  const std::uint32_t* r = v.stack + v.at(v.col_begin(right), y);
  const std::uint32_t* rt = v.column + v.at(v.col_begin(right), y);
  std::uint32_t& left_size = v.stack_size[static_cast<std::size_t>(y) * v.col_bands + left];
  const std::uint32_t right_size = v.stack_size[static_cast<std::size_t>(y) * v.col_bands + right];
  std::uint32_t size = left_size;
  for (std::uint32_t j = 0; j < right_size; ++j) {
    if (!push_proximate(v, s, t, size, r[j], y) && j >= 1) {
      for (std::uint32_t k = j + 1; k < right_size; ++k) {
        s[size] = r[k];
        t[size] = rt[k];
        ++size;
      }
      break;
    }
  }
  left_size = size;
}

/// Phase 3: the nearest site (packed) of every cell of column band b of row y, from the row's merged
/// proximate sites; kNone when there is no site at all.
CDT_HD inline void pba_colour_band(const PbaView& v, std::uint32_t y, std::uint32_t b) {
  const std::uint32_t lo = v.col_begin(b), hi = v.col_begin(b + 1);
  const std::uint32_t* s = v.stack + v.at(0, y);
  const std::uint32_t size = v.stack_size[static_cast<std::size_t>(y) * v.col_bands];
  std::uint32_t* out = v.column + v.at(0, y);
  if (size == 0) {
    for (std::uint32_t x = lo; x < hi; ++x) out[x] = kNone;
    return;
  }
  // The winner at lo: the first entry that its successor does not beat there (beating switches on
  // from left to right along the stack).
  std::uint32_t first = 0, last = size - 1;
  while (first < last) {
    const std::uint32_t mid = first + (last - first) / 2;
    if (beats(v, s[mid + 1], s[mid], lo, y)) {
      first = mid + 1;
    } else {
      last = mid;
    }
  }
  std::uint32_t k = first;
  for (std::uint32_t x = lo; x < hi; ++x) {
    while (k + 1 < size && beats(v, s[k + 1], s[k], x, y)) ++k;
    out[x] = s[k];
  }
}

/// The point kept at packed site position p (kNone stays kNone): phase 3's output turned into colours.
CDT_HD_INLINE std::uint32_t owner_at(const std::uint32_t* owner, std::uint32_t m, std::uint32_t p) {
  return p == kNone ? kNone : owner[static_cast<std::size_t>(packed_row(p)) * m + packed_col(p)];
}

/// The three phases of PBA on an executor: v.column receives the packed nearest site of every cell
/// (kNone when no cell is occupied). Task indices: t = band * (groups) + group in phase 1 and
/// t = row * (bands or pairs) + band or pair in phases 2 and 3, so the tasks next to each other (one
/// thread's run on a CPU, one warp on a device) work on neighbouring columns; each task walks a whole
/// column or row, so a CPU runs even a few of them in parallel (for_each_part): of neighbouring rows in
/// phase 1, of one row in phases 2 and 3. (On an H100 the row-major order of phases 2 and 3 timed
/// the same as one row per neighbouring task: those steps are bound by each task's serial walk
/// through its stack, not by the order of the tasks.) Each for_each is a global barrier.
template <class Executor>
void run_pba(Executor& executor, const PbaView& v) {
  const std::uint32_t groups = v.groups();
  executor.for_each_part(v.group_tasks(), [v, groups] CDT_HD(std::size_t t) {
    pba_band_ends(v, static_cast<std::uint32_t>(t / groups), static_cast<std::uint32_t>(t % groups));
  });
  executor.for_each_part(groups,
                         [v] CDT_HD(std::size_t g) { pba_link_bands(v, static_cast<std::uint32_t>(g)); });
  executor.for_each_part(v.group_tasks(), [v, groups] CDT_HD(std::size_t t) {
    pba_column_sweep(v, static_cast<std::uint32_t>(t / groups), static_cast<std::uint32_t>(t % groups));
  });
  executor.for_each_part(v.row_tasks(), [v] CDT_HD(std::size_t t) {
    pba_band_stack(v, static_cast<std::uint32_t>(t / v.col_bands),
                   static_cast<std::uint32_t>(t % v.col_bands));
  });
  // Pairwise merges: after the round with group width w, the groups of 2w bands hold merged stacks.
  for (std::uint32_t width = 1; width < v.col_bands; width *= 2) {
    const std::uint32_t pairs = v.merge_pairs(width);
    executor.for_each_part(v.merge_tasks(width), [v, width, pairs] CDT_HD(std::size_t t) {
      const auto left = static_cast<std::uint32_t>(t % pairs) * 2 * width;
      if (left + width < v.col_bands)
        pba_merge_stacks(v, static_cast<std::uint32_t>(t / pairs), left, left + width);
    });
  }
  executor.for_each_part(v.row_tasks(), [v] CDT_HD(std::size_t t) {
    pba_colour_band(v, static_cast<std::uint32_t>(t / v.col_bands),
                    static_cast<std::uint32_t>(t % v.col_bands));
  });
}

} // namespace pba

// --- Appendix A -----------------------------------------------------------------------------------------
//
// The Euclidean colouring may leave "debris", cells not connected to their own site through their own
// colour; the Standard flooding never produces such cells, and its dual is a triangulation while the
// Euclidean colouring's may not be. Connectivity is 4-connectivity: the flooding passes a colour only
// between the 4 neighbours of N(A), so its regions are 4-connected, and a cell touching its region only
// diagonally can never be reached by it.
// Debris are found as the complement of the cells that a *monotone* 4-connected path of their own
// colour joins to their site, each step strictly closer to the site. Those cells keep their colour in
// the Standard flooding by induction on the distance (the flooding inserts (A, i) from the closer
// neighbour, and (A, i) is A's smallest key), which is exactly what the proof of Algorithm A.1 needs of
// the cells it leaves alone; the tests check that this also leaves every 4-connected bulk unchanged.
// The test is local: a cell is an "orphan" when neither neighbour one step towards its site has its
// colour; orphans are debris, and debris spread only away from the site, to cells whose closer
// neighbours of their colour are all debris (debris_successors). The set of debris does not depend on
// the order in which they are found, because a cell depends only on cells strictly closer to its site.
//
// The flood (Algorithm A.1, lines 3-13) gives every debris cell A the colour i with the smallest key
// (|A - p_i|^2, i) among its neighbours B coloured i with |B - p_i| < |A - p_i| (flood_colour): the
// priority queue pops keys in increasing order, so when A is coloured every neighbour whose colour
// offers A a smaller key is coloured already. That equation has one solution (take the smallest key
// at which two solutions differ: its supporting neighbour has a smaller key, so it agrees in both), so
// the CPU executor's priority queue and the CUDA executor's rounds of flood_colour until nothing
// changes give the same colouring.
namespace amend {

/// True when cell (x, y) is not its own site and neither neighbour one step closer to its site (in x
/// and in y: the only neighbours strictly closer to it) has the same site: no monotone path of its
/// colour reaches it. site: packed nearest-site positions (phase 3 of PBA), so the test reads only
/// the cell's neighbourhood. Uncoloured cells are never orphans.
CDT_HD inline bool is_orphan_at(const std::uint32_t* site, std::uint32_t m, std::uint32_t x,
                                std::uint32_t y) {
  const std::uint32_t p = site[static_cast<std::size_t>(y) * m + x];
  if (p == kNone) return false;
  const std::uint32_t sx = pba::packed_col(p), sy = pba::packed_row(p);
  if (x == sx && y == sy) return false;
  if (x != sx && site[static_cast<std::size_t>(y) * m + (x < sx ? x + 1 : x - 1)] == p) return false;
  if (y != sy && site[static_cast<std::size_t>(y < sy ? y + 1 : y - 1) * m + x] == p) return false;
  return true;
}

/// Raw view of a colouring and the sites' grid positions (colours are point indices).
struct FloodView {
  std::uint32_t* colour = nullptr;
  const std::uint32_t* site_x = nullptr;
  const std::uint32_t* site_y = nullptr;
  std::uint32_t m = 0;
};

CDT_HD_INLINE std::int64_t squared_distance(const FloodView& v, std::uint32_t x, std::uint32_t y,
                                            std::uint32_t site) {
  const std::int64_t dx = static_cast<std::int64_t>(x) - v.site_x[site];
  const std::int64_t dy = static_cast<std::int64_t>(y) - v.site_y[site];
  return dx * dx + dy * dy;
}

/// The flood's order on (distance, site) keys: the tie rule of Definition 1.
CDT_HD_INLINE bool key_before(std::int64_t d1, std::uint32_t s1, std::int64_t d2, std::uint32_t s2) {
  return d1 < d2 || (d1 == d2 && s1 < s2);
}

/// Calls f(neighbour x, y) for the 4 neighbours of (x, y) inside the grid.
template <class F>
CDT_HD_INLINE void for_each_neighbour(std::uint32_t m, std::uint32_t x, std::uint32_t y, F&& f) {
  if (x > 0) f(x - 1, y);
  if (x + 1 < m) f(x + 1, y);
  if (y > 0) f(x, y - 1);
  if (y + 1 < m) f(x, y + 1);
}

/// is_orphan_at on a colouring by point indices (the worklist's view, where debris are uncoloured).
CDT_HD inline bool is_orphan(const FloodView& v, std::uint32_t x, std::uint32_t y) {
  const std::uint32_t i = v.colour[static_cast<std::size_t>(y) * v.m + x];
  if (i == kNone) return false;
  const std::uint32_t sx = v.site_x[i], sy = v.site_y[i];
  if (x == sx && y == sy) return false;
  if (x != sx && v.colour[static_cast<std::size_t>(y) * v.m + (x < sx ? x + 1 : x - 1)] == i) return false;
  if (y != sy && v.colour[static_cast<std::size_t>(y < sy ? y + 1 : y - 1) * v.m + x] == i) return false;
  return true;
}

/// The cells that become debris because debris cell `cell`, whose colour was i, has been uncoloured:
/// its neighbours of colour i that are now orphans. Writes them to out (at most 4); returns how many.
/// Two neighbours of one cell are not neighbours of each other, so uncoloring one of them does not
/// change the test of another.
CDT_HD inline std::uint32_t debris_successors(const FloodView& v, std::uint32_t cell, std::uint32_t i,
                                              std::uint32_t out[4]) {
  std::uint32_t count = 0;
  for_each_neighbour(v.m, cell % v.m, cell / v.m, [&](std::uint32_t x, std::uint32_t y) {
    const std::size_t c = static_cast<std::size_t>(y) * v.m + x;
    if (v.colour[c] == i && is_orphan(v, x, y)) out[count++] = static_cast<std::uint32_t>(c);
  });
  return count;
}

/// The colour that Algorithm A.1 gives cell (x, y) when its neighbours have their final colours: the
/// smallest key (distance from the cell, site) among the neighbours' colours i for which the
/// neighbour is strictly closer to p_i than the cell (line 5 and line 11); kNone when there is none.
CDT_HD inline std::uint32_t flood_colour(const FloodView& v, std::uint32_t x, std::uint32_t y) {
  std::uint32_t best = kNone;
  std::int64_t best_distance = 0;
  for_each_neighbour(v.m, x, y, [&](std::uint32_t nx, std::uint32_t ny) {
    const std::uint32_t j = v.colour[static_cast<std::size_t>(ny) * v.m + nx];
    if (j == kNone || j == best) return;
    const std::int64_t d = squared_distance(v, x, y, j);
    if (!(squared_distance(v, nx, ny, j) < d)) return;
    if (best == kNone || key_before(d, j, best_distance, best)) {
      best = j;
      best_distance = d;
    }
  });
  return best;
}

/// The colour flood_cleared_cells gives a cleared cell (x, y) none of whose neighbours is uncoloured
/// (cleared or kNone): the flood reaches such a cell only from its seeds, so it takes the smallest
/// key (distance from the cell, site) among its neighbours' colours. kNone when a neighbour is
/// uncoloured: the cell is left to the flood. colour(nx, ny) is a neighbour's colour (kNone when
/// uncoloured), distance(j) the squared distance from the cell to site j's grid cell.
template <class Colour, class Distance>
CDT_HD_INLINE std::uint32_t isolated_cleared_colour(std::uint32_t m, std::uint32_t x, std::uint32_t y,
                                                    const Colour& colour, const Distance& distance) {
  std::uint32_t best = kNone;
  std::int64_t best_distance = 0;
  bool isolated = true;
  for_each_neighbour(m, x, y, [&](std::uint32_t nx, std::uint32_t ny) {
    const std::uint32_t j = colour(nx, ny);
    if (j == kNone) {
      isolated = false;
      return;
    }
    const std::int64_t d = distance(j);
    if (best == kNone || key_before(d, j, best_distance, best)) {
      best = j;
      best_distance = d;
    }
  });
  return isolated ? best : kNone;
}

} // namespace amend

} // namespace cdt::detail
