// Phase 1 of gCD, second half (paper section 3.1, Appendix A): the digital Voronoi diagram.
//
// Euclidean colouring (Definition 1) by the Parallel Banding Algorithm of Cao, Tang, Mei, Tan and Lee
// (I3D 2010), in its three phases:
//   1. per column: the nearest occupied cell in that column for every cell, by a sweep down and a
//      sweep up inside bands of rows, the bands linked by their first and last occupied cells;
//   2. per row: the "proximate sites", the lower envelope of the column candidates' distance
//      parabolas, by a stack inside bands of columns, the bands' stacks then merged in pairs;
//   3. per row: every cell coloured by walking the proximate sites.
// Everything is exact in 64-bit integers, and the tie rule of Definition 1 (the smaller point index
// wins) is built into every comparison, so the result is the brute-force nearest site exactly.
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
//
// Appendix A (Algorithm A.1): the Euclidean colouring may leave "debris", cells not connected to
// their own site through their own colour; the Standard flooding never produces such cells, and its
// dual is a triangulation while the Euclidean colouring's may not be. Connectivity is 4-connectivity:
// the flooding passes a colour only between the 4 neighbours of N(A), so its regions are 4-connected,
// and a cell touching its region only diagonally can never be reached by it.
// Debris are found as the complement of the cells that a *monotone* 4-connected path of their own
// colour joins to their site, each step strictly closer to the site. Those cells keep their colour in
// the Standard flooding by induction on the distance (the flooding inserts (A, i) from the closer
// neighbour, and (A, i) is A's smallest key), which is exactly what the proof of Algorithm A.1 needs of
// the cells it leaves alone; the tests check that this also leaves every 4-connected bulk unchanged.
// The test is local: a cell is an "orphan" when neither neighbour one step towards its site has its
// colour; orphans are debris, and debris spread only away from the site, to cells whose closer
// neighbours of their colour are all debris. A parallel scan finds the orphans, then a short worklist
// (debris are rare) finishes the set and a priority-queue flood recolours it, on the CPU as in the
// paper.

#include "gcd/voronoi.hpp"

#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>
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

// --- Parallel Banding Algorithm ------------------------------------------------------------------------

/// Columns whose running state pba_link_bands keeps in registers at a time.
inline constexpr std::uint32_t kLinkChunk = 64;

/// Raw view of the PBA buffers so the per-element functions run unchanged on a device.
struct PbaView {
  const std::uint32_t* owner = nullptr; ///< m*m: point kept in the cell or kNone
  std::uint32_t* column = nullptr;      ///< m*m: phase 1's nearest occupied row in the column; phase 3's site
  std::uint32_t* stack = nullptr;       ///< m*m: per row, proximate sites as packed (row, column)
  std::uint32_t* stack_size = nullptr;  ///< m*col_bands: entries of band b's stack of row y at y*col_bands+b
  std::uint32_t* above = nullptr;       ///< row_bands*m: nearest occupied row above row band b in column x
  std::uint32_t* below = nullptr;       ///< row_bands*m: nearest occupied row below row band b in column x
  std::uint32_t m = 0;
  std::uint32_t row_bands = 1, row_band_height = 0; ///< phase 1: bands of rows
  std::uint32_t group_width = 0;                    ///< phase 1: columns per task
  std::uint32_t col_bands = 1, col_band_width = 0;  ///< phases 2 and 3: bands of columns

  CDT_HD std::uint32_t row_begin(std::uint32_t b) const {
    return b * row_band_height < m ? b * row_band_height : m;
  }
  CDT_HD std::uint32_t col_begin(std::uint32_t b) const {
    return b * col_band_width < m ? b * col_band_width : m;
  }
  CDT_HD std::uint32_t group_begin(std::uint32_t g) const {
    return g * group_width < m ? g * group_width : m;
  }
  CDT_HD std::uint32_t groups() const { return (m + group_width - 1) / group_width; }
  CDT_HD std::size_t at(std::uint32_t x, std::uint32_t y) const {
    return static_cast<std::size_t>(y) * m + x;
  }
  CDT_HD std::uint32_t owner_of(std::uint32_t packed) const;
};

// Sites are packed as (row, column), 16 bits each (m <= kMaxGridSize); kNone stays free.
CDT_HD_INLINE std::uint32_t pack(std::uint32_t row, std::uint32_t col) { return (row << 16) | col; }
CDT_HD_INLINE std::uint32_t packed_row(std::uint32_t p) { return p >> 16; }
CDT_HD_INLINE std::uint32_t packed_col(std::uint32_t p) { return p & 0xFFFFu; }

CDT_HD inline std::uint32_t PbaView::owner_of(std::uint32_t packed) const {
  return owner[at(packed_col(packed), packed_row(packed))];
}

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
// columns, reading memory along rows, the order a CPU prefers (one thread per column, the order a GPU
// prefers, strides by m cells). The per-column running state lives in the band's own row of above
// and below, so a device can run the same functions with groups of one column.

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
  PbaView v;
  v.m = m;
  v.row_bands = std::min(bands != 0 ? bands : default_row_bands(m), m);
  v.col_bands = std::min(bands != 0 ? bands : default_col_bands(m), m);
  v.row_band_height = (m + v.row_bands - 1) / v.row_bands;
  const std::uint32_t wanted_groups = default_groups(m, v.row_bands);
  v.group_width = (m + wanted_groups - 1) / wanted_groups;
  v.col_band_width = (m + v.col_bands - 1) / v.col_bands;

  std::vector<std::uint32_t> site(cells);
  scratch.reset(new std::uint32_t[cells]);
  std::vector<std::uint32_t> stack_size(static_cast<std::size_t>(m) * v.col_bands);
  std::vector<std::uint32_t> above(static_cast<std::size_t>(v.row_bands) * m);
  std::vector<std::uint32_t> below(static_cast<std::size_t>(v.row_bands) * m);
  v.owner = cell_owner.data();
  v.column = site.data();
  v.stack = scratch.get();
  v.stack_size = stack_size.data();
  v.above = above.data();
  v.below = below.data();

  // Task index = band * tasks per band + task: one thread's run of tasks stays in one band on
  // neighbouring lines or groups, which share cache lines.
  const std::uint32_t groups = v.groups();
  const std::size_t group_tasks = static_cast<std::size_t>(v.row_bands) * groups;
  executor.for_each(group_tasks, [&v, groups](std::size_t t) {
    pba_band_ends(v, static_cast<std::uint32_t>(t / groups), static_cast<std::uint32_t>(t % groups));
  });
  executor.for_each(groups, [&v](std::size_t g) { pba_link_bands(v, static_cast<std::uint32_t>(g)); });
  executor.for_each(group_tasks, [&v, groups](std::size_t t) {
    pba_column_sweep(v, static_cast<std::uint32_t>(t / groups), static_cast<std::uint32_t>(t % groups));
  });

  const std::size_t row_tasks = static_cast<std::size_t>(v.col_bands) * m;
  executor.for_each(row_tasks, [&v](std::size_t t) {
    pba_band_stack(v, static_cast<std::uint32_t>(t % v.m), static_cast<std::uint32_t>(t / v.m));
  });
  // Pairwise merges: after the round with group width w, the groups of 2w bands hold merged stacks.
  for (std::uint32_t width = 1; width < v.col_bands; width *= 2) {
    const std::uint32_t pairs = (v.col_bands + 2 * width - 1) / (2 * width);
    executor.for_each(static_cast<std::size_t>(pairs) * m, [&v, width](std::size_t t) {
      const auto left = static_cast<std::uint32_t>(t / v.m) * 2 * width;
      if (left + width < v.col_bands)
        pba_merge_stacks(v, static_cast<std::uint32_t>(t % v.m), left, left + width);
    });
  }
  executor.for_each(row_tasks, [&v](std::size_t t) {
    pba_colour_band(v, static_cast<std::uint32_t>(t % v.m), static_cast<std::uint32_t>(t / v.m));
  });
  return site;
}

/// colour[c] = the point kept at packed site position site[c] (kNone stays); colour may be site.
void positions_to_owners(std::span<const std::uint32_t> cell_owner, std::uint32_t m,
                         const std::uint32_t* site, std::uint32_t* colour, CpuExecutor& executor) {
  const std::uint32_t* owner = cell_owner.data();
  executor.for_each(static_cast<std::size_t>(m) * m, [=](std::size_t c) {
    const std::uint32_t p = site[c];
    colour[c] = p == kNone ? kNone : owner[static_cast<std::size_t>(packed_row(p)) * m + packed_col(p)];
  });
}

// --- Appendix A -----------------------------------------------------------------------------------------

/// True when cell (x, y) is not its own site and neither neighbour one step closer to its site (in x
/// and in y: the only neighbours strictly closer to it) has the same site: no monotone path of its
/// colour reaches it. site: packed nearest-site positions (phase 3 of PBA), so the test reads only
/// the cell's neighbourhood. Uncoloured cells are never orphans.
CDT_HD inline bool is_orphan_at(const std::uint32_t* site, std::uint32_t m, std::uint32_t x,
                                std::uint32_t y) {
  const std::uint32_t p = site[static_cast<std::size_t>(y) * m + x];
  if (p == kNone) return false;
  const std::uint32_t sx = packed_col(p), sy = packed_row(p);
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

/// One entry of Algorithm A.1's queue: colour `cell` with `site`, at that distance. Ordered by
/// (distance, site index), the tie rule of Definition 1; the cell only makes the order total.
struct FloodEntry {
  std::int64_t distance;
  std::uint32_t site;
  std::uint32_t cell;
  friend bool operator>(const FloodEntry& a, const FloodEntry& b) {
    if (a.distance != b.distance) return a.distance > b.distance;
    if (a.site != b.site) return a.site > b.site;
    return a.cell > b.cell;
  }
};

/// Calls f(neighbour cell x, y) for the 4 neighbours of (x, y) inside the grid.
template <class F>
void for_each_neighbour(std::uint32_t m, std::uint32_t x, std::uint32_t y, F&& f) {
  if (x > 0) f(x - 1, y);
  if (x + 1 < m) f(x + 1, y);
  if (y > 0) f(x, y - 1);
  if (y + 1 < m) f(x, y + 1);
}

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
    for_each_neighbour(m, debris[k] % m, debris[k] / m, [&](std::uint32_t x, std::uint32_t y) {
      const std::size_t c = static_cast<std::size_t>(y) * m + x;
      if (colour[c] == i && is_orphan(v, x, y)) {
        colour[c] = kNone;
        debris.push_back(static_cast<std::uint32_t>(c));
        debris_colour.push_back(i);
      }
    });
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

void remove_sites_from_colouring(std::vector<std::uint32_t>& colour, const GridSites& sites, std::uint32_t m,
                                 std::span<const std::uint32_t> removed) {
  if (colour.size() != static_cast<std::size_t>(m) * m) throw Error("internal error: colour is not m * m");
  FloodView v;
  v.colour = colour.data();
  v.site_x = sites.gx.data();
  v.site_y = sites.gy.data();
  v.m = m;
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
  // Flood the cleared cells from every coloured neighbour, nearest site first (Algorithm A.1 without
  // its "closer to the own site" condition at the seeds: a cleared region's border need not be).
  std::priority_queue<FloodEntry, std::vector<FloodEntry>, std::greater<>> queue;
  const auto push_neighbours = [&](std::uint32_t cell) {
    const std::uint32_t j = colour[cell];
    for_each_neighbour(m, cell % m, cell / m, [&](std::uint32_t x, std::uint32_t y) {
      const std::size_t c = static_cast<std::size_t>(y) * m + x;
      if (colour[c] == kNone) queue.push({squared_distance(v, x, y, j), j, static_cast<std::uint32_t>(c)});
    });
  };
  for (const std::uint32_t a : cleared) {
    for_each_neighbour(m, a % m, a / m, [&](std::uint32_t x, std::uint32_t y) {
      const std::size_t c = static_cast<std::size_t>(y) * m + x;
      const std::uint32_t j = colour[c];
      if (j != kNone) queue.push({squared_distance(v, a % m, a / m, j), j, a});
    });
  }
  while (!queue.empty()) {
    const FloodEntry e = queue.top();
    queue.pop();
    if (colour[e.cell] != kNone) continue;
    colour[e.cell] = e.site;
    push_neighbours(e.cell);
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
