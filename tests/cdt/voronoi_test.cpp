// Tests of Phase 1 of gCD (paper section 3.1, Appendices A and B): the exact grid mapping, the grid
// sites, the Euclidean colouring by the Parallel Banding Algorithm against brute force, and the
// amendment against a plain Standard flooding.

#include "gcd/grid_map.hpp"
#include "gcd/voronoi.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <queue>
#include <tuple>
#include <utility>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"

namespace {

using cdt::kNone;
using cdt::detail::CpuExecutor;
using cdt::detail::GridMapping;
using cdt::detail::GridSites;

// splitmix64: deterministic on every standard library, unlike std:: distributions.
class SplitMix64 {
public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform-enough integer in [0, n).
  std::uint32_t below(std::uint32_t n) { return static_cast<std::uint32_t>(next() % n); }
  /// Uniform in [0, 1).
  double unit() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * unit(); }

private:
  std::uint64_t state_;
};

struct GridPoint {
  std::uint32_t x, y;
};

/// Grid sites of integer points through the identity mapping (scale 1, no translation), so tests state
/// site positions directly; points sharing a cell become missing points as in the real pipeline.
GridSites sites_at(std::uint32_t m, const std::vector<GridPoint>& points, CpuExecutor& executor) {
  GridMapping identity;
  identity.m = m;
  identity.scale = 1.0;
  std::vector<double> x, y;
  for (const GridPoint& p : points) {
    x.push_back(p.x);
    y.push_back(p.y);
  }
  return cdt::detail::assign_sites(identity, x, y, executor);
}

std::int64_t squared_distance(const GridSites& s, std::uint32_t x, std::uint32_t y, std::uint32_t site) {
  const std::int64_t dx = static_cast<std::int64_t>(x) - s.gx[site];
  const std::int64_t dy = static_cast<std::int64_t>(y) - s.gy[site];
  return dx * dx + dy * dy;
}

std::vector<std::uint32_t> kept_sites(const GridSites& s) {
  std::vector<std::uint32_t> kept;
  for (const std::uint32_t owner : s.cell_owner)
    if (owner != kNone) kept.push_back(owner);
  std::sort(kept.begin(), kept.end());
  return kept;
}

/// Definition 1 by brute force: the nearest kept site, ties to the smaller index.
std::vector<std::uint32_t> brute_force_colouring(const GridSites& s, std::uint32_t m) {
  const std::vector<std::uint32_t> kept = kept_sites(s);
  std::vector<std::uint32_t> colour(static_cast<std::size_t>(m) * m, kNone);
  for (std::uint32_t y = 0; y < m; ++y)
    for (std::uint32_t x = 0; x < m; ++x) {
      std::int64_t best = std::numeric_limits<std::int64_t>::max();
      for (const std::uint32_t p : kept) { // increasing, so strict < keeps the smaller index
        const std::int64_t d = squared_distance(s, x, y, p);
        if (d < best) {
          best = d;
          colour[static_cast<std::size_t>(y) * m + x] = p;
        }
      }
    }
  return colour;
}

/// The Standard flooding, written plainly: one priority queue from all sites at once, ordered by
/// (distance, site index); a colour passes to a 4-neighbour only when that neighbour is farther from
/// the colour's site (Algorithm A.1, line 11).
std::vector<std::uint32_t> standard_flooding(const GridSites& s, std::uint32_t m) {
  struct Entry {
    std::int64_t d;
    std::uint32_t site, x, y;
    bool operator>(const Entry& o) const { return std::tie(d, site, y, x) > std::tie(o.d, o.site, o.y, o.x); }
  };
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  for (const std::uint32_t p : kept_sites(s)) queue.push({0, p, s.gx[p], s.gy[p]});
  std::vector<std::uint32_t> colour(static_cast<std::size_t>(m) * m, kNone);
  while (!queue.empty()) {
    const Entry e = queue.top();
    queue.pop();
    std::uint32_t& c = colour[static_cast<std::size_t>(e.y) * m + e.x];
    if (c != kNone) continue;
    c = e.site;
    const int dx[4] = {-1, 1, 0, 0};
    const int dy[4] = {0, 0, -1, 1};
    for (int k = 0; k < 4; ++k) {
      const std::int64_t nx = static_cast<std::int64_t>(e.x) + dx[k];
      const std::int64_t ny = static_cast<std::int64_t>(e.y) + dy[k];
      if (nx < 0 || ny < 0 || nx >= m || ny >= m) continue;
      const auto ux = static_cast<std::uint32_t>(nx), uy = static_cast<std::uint32_t>(ny);
      const std::int64_t d = squared_distance(s, ux, uy, e.site);
      if (d > e.d && colour[static_cast<std::size_t>(uy) * m + ux] == kNone) queue.push({d, e.site, ux, uy});
    }
  }
  return colour;
}

/// 1 for the cells 4-connected to their own site through their own colour (the bulks).
std::vector<std::uint8_t> bulk_cells(const std::vector<std::uint32_t>& colour, const GridSites& s,
                                     std::uint32_t m) {
  std::vector<std::uint8_t> in_bulk(colour.size(), 0);
  std::vector<std::uint32_t> todo;
  for (const std::uint32_t p : kept_sites(s)) {
    const std::size_t start = static_cast<std::size_t>(s.gy[p]) * m + s.gx[p];
    if (colour[start] != p) continue;
    in_bulk[start] = 1;
    todo.assign(1, static_cast<std::uint32_t>(start));
    while (!todo.empty()) {
      const std::uint32_t c = todo.back();
      todo.pop_back();
      const std::uint32_t x = c % m, y = c / m;
      const auto visit = [&](std::uint32_t nx, std::uint32_t ny) {
        const std::size_t n = static_cast<std::size_t>(ny) * m + nx;
        if (colour[n] == p && !in_bulk[n]) {
          in_bulk[n] = 1;
          todo.push_back(static_cast<std::uint32_t>(n));
        }
      };
      if (x > 0) visit(x - 1, y);
      if (x + 1 < m) visit(x + 1, y);
      if (y > 0) visit(x, y - 1);
      if (y + 1 < m) visit(x, y + 1);
    }
  }
  return in_bulk;
}

/// The index order decides ties, so tests shuffle it to keep it unrelated to position.
void shuffle(std::vector<GridPoint>& points, SplitMix64& rng) {
  for (std::size_t i = points.size(); i > 1; --i)
    std::swap(points[i - 1], points[rng.below(static_cast<std::uint32_t>(i))]);
}

std::vector<GridPoint> random_points(std::uint32_t m, std::uint32_t count, SplitMix64& rng) {
  std::vector<GridPoint> points;
  for (std::uint32_t i = 0; i < count; ++i) points.push_back({rng.below(m), rng.below(m)});
  return points;
}

/// Sites on a lattice with steps (sx, sy): every cell between them is at equal distance from several.
std::vector<GridPoint> lattice_points(std::uint32_t m, std::uint32_t sx, std::uint32_t sy, std::uint32_t ox,
                                      std::uint32_t oy) {
  std::vector<GridPoint> points;
  for (std::uint32_t y = oy; y < m; y += sy)
    for (std::uint32_t x = ox; x < m; x += sx) points.push_back({x, y});
  return points;
}

/// Named site sets with many ties and degenerate layouts, for grid side m.
std::vector<std::vector<GridPoint>> awkward_site_sets(std::uint32_t m, SplitMix64& rng) {
  std::vector<std::vector<GridPoint>> sets;
  const std::uint32_t last = m - 1;
  sets.push_back({{m / 2, m / 3}});                             // a single site
  sets.push_back({{0, 0}});                                     // a single site in a corner
  sets.push_back({{0, 0}, {last, last}});                       // opposite corners: a diagonal of ties
  sets.push_back({{0, 0}, {last, 0}, {0, last}, {last, last}}); // all corners
  sets.push_back(lattice_points(m, 2, 2, 0, 0));
  sets.push_back(lattice_points(m, 3, 5, 1, 2));
  sets.push_back(lattice_points(m, 4, 4, 1, 1));
  std::vector<GridPoint> row, column, diagonal, steep, pairs;
  for (std::uint32_t k = 0; k < m; k += 1 + rng.below(3)) {
    row.push_back({k, m / 2});
    column.push_back({m / 3, k});
    diagonal.push_back({k, k});
    if (2 * k < m) steep.push_back({k, 2 * k});
  }
  sets.push_back(row);      // collinear, horizontal
  sets.push_back(column);   // collinear, vertical
  sets.push_back(diagonal); // collinear at 45 degrees: ties along both axes
  sets.push_back(steep);
  // Symmetric pairs about a cell: their bisector runs through grid points.
  for (std::uint32_t k = 0; k < m / 4; ++k) {
    const std::uint32_t cx = 1 + rng.below(m - 2), cy = 1 + rng.below(m - 2);
    const std::uint32_t r = 1 + rng.below(std::min({cx, cy, m - 1 - cx, m - 1 - cy}) + 1);
    if (cx >= r && cx + r < m) {
      pairs.push_back({cx - r, cy});
      pairs.push_back({cx + r, cy});
    }
    if (cy >= r && cy + r < m) {
      pairs.push_back({cx, cy - r});
      pairs.push_back({cx, cy + r});
    }
  }
  sets.push_back(pairs);
  for (auto& s : sets) shuffle(s, rng);
  return sets;
}

// --- grid mapping (Appendix B) ---------------------------------------------------------------------

/// True when g * scale + t is computed without rounding: both error terms are zero.
bool exact_grid_position(double g, double scale, double t) {
  double product, product_error, sum, sum_error;
  cdt::detail::two_product(g, scale, product, product_error);
  cdt::detail::two_sum(product, t, sum, sum_error);
  return product_error == 0.0 && sum_error == 0.0;
}

/// Significant bits of a positive double's mantissa.
int mantissa_bits(double v) {
  int e = 0;
  const double f = std::frexp(v, &e); // [0.5, 1)
  const auto bits = static_cast<std::uint64_t>(std::ldexp(f, 53));
  return 53 - std::countr_zero(bits);
}

struct Box {
  std::vector<double> x, y;
};

/// n points in a box of the given extents and lower corner, magnitude-free.
Box random_box(std::size_t n, double x0, double wx, double y0, double wy, SplitMix64& rng) {
  Box b;
  for (std::size_t i = 0; i < n; ++i) {
    b.x.push_back(x0 + wx * rng.unit());
    b.y.push_back(y0 + wy * rng.unit());
  }
  // The box's corners themselves, which decide the mapping.
  b.x.push_back(x0);
  b.y.push_back(y0);
  b.x.push_back(x0 + wx);
  b.y.push_back(y0 + wy);
  return b;
}

/// Checks every Appendix B promise of a mapping for the points: exact grid positions for all g (or
/// the ends and a sample for large m), the scale's mantissa width, every point inside the grid at its
/// nearest lower-left grid point, and monotonicity.
void expect_valid_mapping(const GridMapping& map, const Box& b, SplitMix64& rng) {
  const std::uint32_t m = map.m;
  ASSERT_GT(map.scale, 0.0);
  EXPECT_LE(mantissa_bits(map.scale), 52 - std::bit_width(m - 1)) << "scale " << map.scale << " m " << m;
  std::vector<std::uint32_t> gs;
  if (m <= 4096) {
    for (std::uint32_t g = 0; g < m; ++g) gs.push_back(g);
  } else {
    for (std::uint32_t g = 0; g < 64; ++g) gs.insert(gs.end(), {g, m - 1 - g});
    for (int k = 0; k < 2000; ++k) gs.push_back(rng.below(m));
  }
  for (const std::uint32_t g : gs) {
    ASSERT_TRUE(exact_grid_position(g, map.scale, map.tx)) << "x, g " << g << " m " << m;
    ASSERT_TRUE(exact_grid_position(g, map.scale, map.ty)) << "y, g " << g << " m " << m;
  }
  for (std::size_t i = 0; i < b.x.size(); ++i) {
    const std::uint32_t gx = map.grid_x(b.x[i]), gy = map.grid_y(b.y[i]);
    ASSERT_LT(gx, m);
    ASSERT_LT(gy, m);
    // The nearest lower-left grid point, exactly (to_x is exact, so these comparisons are too).
    EXPECT_LE(map.to_x(gx), b.x[i]);
    EXPECT_LE(map.to_y(gy), b.y[i]);
    if (gx + 1 < m) {
      EXPECT_GT(map.to_x(gx + 1), b.x[i]);
    }
    if (gy + 1 < m) {
      EXPECT_GT(map.to_y(gy + 1), b.y[i]);
    }
    // Nothing is clamped: the bounding box fits (a last cell holds at most one scale more).
    if (gx + 1 == m) {
      EXPECT_LT(b.x[i] - map.to_x(gx), map.scale * (1 + 1e-12));
    }
    if (gy + 1 == m) {
      EXPECT_LT(b.y[i] - map.to_y(gy), map.scale * (1 + 1e-12));
    }
  }
  std::vector<double> xs = b.x;
  std::sort(xs.begin(), xs.end());
  for (std::size_t i = 1; i < xs.size(); ++i) ASSERT_LE(map.grid_x(xs[i - 1]), map.grid_x(xs[i]));
  for (const double x : xs) ASSERT_LE(map.grid_x(x), map.grid_x(std::nextafter(x, HUGE_VAL)));
}

// The documented rule, its clamps, the exact power-of-two boundaries, and the coarser step past 2048.
TEST(GridMap, ChooseGridSizeIsABoundedPowerOfTwo) {
  using cdt::detail::choose_grid_size;
  EXPECT_EQ(choose_grid_size(0), 256u);
  EXPECT_EQ(choose_grid_size(3), 256u);
  EXPECT_EQ(choose_grid_size(65536), 256u); // sqrt(n) = 256 exactly
  EXPECT_EQ(choose_grid_size(65537), 512u);
  EXPECT_EQ(choose_grid_size(1000000), 1024u);
  EXPECT_EQ(choose_grid_size(4194304), 2048u); // sqrt(n) = 2048 exactly
  EXPECT_EQ(choose_grid_size(4194305), 2048u); // past 2048: one power of two coarser
  EXPECT_EQ(choose_grid_size(10000000), 2048u);
  EXPECT_EQ(choose_grid_size(16777216), 2048u); // sqrt(n) = 4096 exactly
  EXPECT_EQ(choose_grid_size(16777217), 4096u);
  EXPECT_EQ(choose_grid_size(67108864), 4096u); // sqrt(n) = 8192 exactly
  EXPECT_EQ(choose_grid_size(67108865), 8192u);
  EXPECT_EQ(choose_grid_size(std::numeric_limits<std::size_t>::max()), 8192u); // clamped
  for (std::size_t n = 1; n < 100000000; n = n * 3 + 1) {
    const std::uint32_t m = choose_grid_size(n);
    EXPECT_TRUE(std::has_single_bit(m));
    const double root = std::sqrt(static_cast<double>(n));
    if (root <= 2048) {
      if (m > 256) {
        EXPECT_GE(static_cast<double>(m), root);
        EXPECT_LT(static_cast<double>(m), 2 * root);
      }
    } else if (m < 8192) {
      EXPECT_GE(static_cast<double>(m), root / 2);
      EXPECT_LT(static_cast<double>(m), root);
    }
  }
}

// The CPU executor's coarser rule: sqrt(n / 8), clamped to [32, 8192].
TEST(GridMap, ChooseGridSizeForTheHostIsCoarser) {
  using cdt::detail::choose_grid_size;
  using cdt::detail::GridFor;
  EXPECT_EQ(choose_grid_size(0, GridFor::host), 32u);
  EXPECT_EQ(choose_grid_size(8192, GridFor::host), 32u); // sqrt(n / 8) = 32 exactly
  EXPECT_EQ(choose_grid_size(8193, GridFor::host), 64u);
  EXPECT_EQ(choose_grid_size(23746, GridFor::host), 64u); // vectorize's PSLG of kodim05
  EXPECT_EQ(choose_grid_size(65536, GridFor::host), 128u);
  EXPECT_EQ(choose_grid_size(524288, GridFor::host), 256u); // sqrt(n / 8) = 256 exactly
  EXPECT_EQ(choose_grid_size(524289, GridFor::host), 512u);
  EXPECT_EQ(choose_grid_size(1000000, GridFor::host), 512u);
  EXPECT_EQ(choose_grid_size(1949580, GridFor::host), 512u); // the GSHHG coastlines
  EXPECT_EQ(choose_grid_size(10000000, GridFor::host), 2048u);
  // Points alone: sqrt(n / 16).
  EXPECT_EQ(choose_grid_size(1000000, GridFor::host_points), 256u);
  EXPECT_EQ(choose_grid_size(1048576, GridFor::host_points), 256u);
  EXPECT_EQ(choose_grid_size(1048577, GridFor::host_points), 512u);
  EXPECT_EQ(choose_grid_size(10000000, GridFor::host_points), 1024u);
  EXPECT_EQ(choose_grid_size(std::numeric_limits<std::size_t>::max(), GridFor::host), 8192u);
  for (std::size_t n = 1; n < 100000000; n = n * 3 + 1) {
    const std::uint32_t m = choose_grid_size(n, GridFor::host);
    EXPECT_TRUE(std::has_single_bit(m));
    EXPECT_LE(m, choose_grid_size(n, GridFor::device));
    if (m > 32 && m < 8192) {
      EXPECT_GE(static_cast<double>(m), std::sqrt(static_cast<double>(n) / 8));
      EXPECT_LT(static_cast<double>(m), 2 * std::sqrt(static_cast<double>(n) / 8));
    }
  }
}

// Appendix B's whole point: the inverse mapping must be exact for inputs of any magnitude and offset.
TEST(GridMap, GridPositionsAreExactForWildMagnitudesAndOffsets) {
  SplitMix64 rng(0xB0B);
  const std::uint32_t sizes[] = {1, 2, 3, 7, 256, 1000, 2048, 8192, 32768};
  for (int trial = 0; trial < 300; ++trial) {
    const double extent = std::pow(10.0, rng.uniform(-9.0, 12.0));
    const double aspect = std::pow(10.0, rng.uniform(-3.0, 3.0));
    double x0 = 0.0, y0 = 0.0;
    switch (trial % 5) {
    case 0:
      break; // at the origin
    case 1:
      x0 = -extent * rng.uniform(0.0, 1.0);
      y0 = -extent;
      break; // straddling it, negative
    case 2:
      x0 = std::pow(10.0, rng.uniform(-9.0, 15.0));
      y0 = -x0 * 3;
      break; // Case 2: far away
    case 3:
      x0 = -std::pow(10.0, rng.uniform(3.0, 15.0));
      y0 = 1e15;
      break;
    default:
      x0 = extent * rng.uniform(-4.0, 4.0);
      y0 = extent * rng.uniform(-4.0, 4.0);
      break; // Case 1
    }
    const Box b = random_box(200, x0, extent, y0, extent * aspect, rng);
    const std::uint32_t m = sizes[trial % std::size(sizes)];
    const GridMapping map = cdt::detail::make_grid_mapping(b.x, b.y, m);
    ASSERT_EQ(map.m, m);
    expect_valid_mapping(map, b, rng);
    if (HasFatalFailure()) {
      ADD_FAILURE() << "trial " << trial << " extent " << extent << " x0 " << x0 << " y0 " << y0;
      return;
    }
  }
}

// Points on one line give a box of zero height (or width): one axis has no extent to scale by.
TEST(GridMap, SingleAxisDegenerateBoxesMapExactly) {
  SplitMix64 rng(7);
  for (const double offset : {0.0, -3.5e7, 1e12, 1e-9}) {
    Box horizontal = random_box(100, offset, 1e-3, 0.0, 0.0, rng);
    for (double& y : horizontal.y) y = offset + 17.25;
    const GridMapping h = cdt::detail::make_grid_mapping(horizontal.x, horizontal.y, 1024);
    expect_valid_mapping(h, horizontal, rng);
    for (const double y : horizontal.y) EXPECT_EQ(h.grid_y(y), 0u);
    Box vertical = random_box(100, offset, 0.0, -offset, 5e4, rng);
    const GridMapping v = cdt::detail::make_grid_mapping(vertical.x, vertical.y, 512);
    expect_valid_mapping(v, vertical, rng);
  }
}

// One point, or many copies of it, has no extent at all and must still get a usable mapping.
TEST(GridMap, CoincidentPointsGetAPositiveScale) {
  SplitMix64 rng(3);
  for (const double p : {0.0, 1.0, -2.5e-200, 6.02e23}) {
    Box b;
    b.x.assign(5, p);
    b.y.assign(5, -p);
    const GridMapping map = cdt::detail::make_grid_mapping(b.x, b.y, 256);
    expect_valid_mapping(map, b, rng);
    EXPECT_EQ(map.grid_x(p), 0u);
    EXPECT_EQ(map.grid_y(-p), 0u);
  }
}

TEST(GridMap, RejectsNonFiniteCoordinatesAndBadSizes) {
  const std::vector<double> x = {0.0, 1.0, NAN}, y = {0.0, 1.0, 2.0};
  try {
    cdt::detail::make_grid_mapping(x, y, 256);
    FAIL() << "no error";
  } catch (const cdt::InvalidInputError& e) {
    EXPECT_EQ(e.kind(), cdt::InvalidInputError::Kind::non_finite_coordinate);
    EXPECT_EQ(e.item(), 2u);
  }
  const std::vector<double> inf = {0.0, HUGE_VAL, 1.0};
  EXPECT_THROW(cdt::detail::make_grid_mapping(inf, y, 256), cdt::InvalidInputError);
  EXPECT_THROW(cdt::detail::make_grid_mapping(y, y, 0), cdt::Error);
  EXPECT_THROW(cdt::detail::make_grid_mapping(y, y, cdt::detail::kMaxGridSize + 1), cdt::Error);
}

// Points sharing a cell: the one nearest its grid point is kept (the lowest index among equally near
// ones), the rest are missing points.
TEST(GridMap, AssignSitesKeepsThePointNearestTheGridPoint) {
  CpuExecutor executor(2);
  // In grid units through the identity mapping: 0.9, 0.2 and 0.0 fall in cell 0, whose grid point
  // (0, 0) is point 5 itself; 3.0 (twice, equally near) and 3.99 in cell 3 of row 1.
  const std::vector<double> x = {3.0, 0.9, 0.2, 3.0, 5.5, 0.0, 3.99};
  const std::vector<double> y = {1.0, 0.0, 0.5, 1.0, 7.0, 0.0, 1.5};
  GridMapping identity;
  identity.m = 8;
  identity.scale = 1.0;
  const GridSites s = cdt::detail::assign_sites(identity, x, y, executor);
  EXPECT_EQ(s.gx, (std::vector<std::uint32_t>{3, 0, 0, 3, 5, 0, 3}));
  EXPECT_EQ(s.gy, (std::vector<std::uint32_t>{1, 0, 0, 1, 7, 0, 1}));
  EXPECT_EQ(s.cell_owner[0], 5u);         // the nearest, though not the lowest index
  EXPECT_EQ(s.cell_owner[1 * 8 + 3], 0u); // the lowest of two equally near
  EXPECT_EQ(s.cell_owner[7 * 8 + 5], 4u);
  EXPECT_EQ(std::count(s.cell_owner.begin(), s.cell_owner.end(), kNone), 64 - 3);
  EXPECT_EQ(s.missing, (std::vector<std::uint32_t>{1, 2, 3, 6}));
  EXPECT_EQ(s.missing_owner, (std::vector<std::uint32_t>{5, 5, 0, 0}));
}

TEST(GridMap, GridPointDistanceKeyOrdersByDistance) {
  GridMapping identity;
  identity.m = 8;
  identity.scale = 1.0;
  const auto key = [&](double x, double y) {
    return cdt::detail::grid_point_distance_key(identity, x, y, identity.grid_x(x), identity.grid_y(y));
  };
  EXPECT_EQ(key(2.0, 3.0), 0u);
  EXPECT_LT(key(2.1, 3.0), key(2.0, 3.2));
  EXPECT_LT(key(2.0, 3.2), key(2.15, 3.15));
  EXPECT_LT(key(2.15, 3.15), key(2.9, 3.9));
  EXPECT_EQ(key(2.3, 3.4), key(2.4, 3.3));
}

// The atomic minimum must make the kept point independent of thread timing on a contended input.
TEST(GridMap, AssignSitesMatchesASerialReferenceUnderContention) {
  SplitMix64 rng(11);
  std::vector<double> x, y;
  for (int i = 0; i < 200000; ++i) {
    x.push_back(rng.uniform(-1.0, 1.0));
    y.push_back(rng.uniform(-1.0, 1.0) * 1e-3);
  }
  // The y extent is so small that all points share one row of 256 cells: heavy contention.
  const GridMapping map = cdt::detail::make_grid_mapping(x, y, 256);
  CpuExecutor executor(4);
  const GridSites s = cdt::detail::assign_sites(map, x, y, executor);
  std::vector<std::uint32_t> owner(256 * 256, kNone);
  std::vector<std::uint32_t> missing, missing_owner;
  // One point after the other: the nearest its grid point, the first of equally near ones.
  std::vector<std::uint32_t> least(256 * 256, kNone);
  for (std::uint32_t i = 0; i < x.size(); ++i) {
    const std::uint32_t gx = map.grid_x(x[i]), gy = map.grid_y(y[i]);
    const std::uint32_t key = cdt::detail::grid_point_distance_key(map, x[i], y[i], gx, gy);
    std::uint32_t& o = owner[gy * 256 + gx];
    if (o == kNone || key < least[gy * 256 + gx]) {
      o = i;
      least[gy * 256 + gx] = key;
    }
  }
  for (std::uint32_t i = 0; i < x.size(); ++i) {
    const std::uint32_t o = owner[map.grid_y(y[i]) * 256 + map.grid_x(x[i])];
    if (o != i) {
      missing.push_back(i);
      missing_owner.push_back(o);
    }
  }
  EXPECT_EQ(s.cell_owner, owner);
  EXPECT_EQ(s.missing, missing);
  EXPECT_EQ(s.missing_owner, missing_owner);
  EXPECT_GT(missing.size(), 100000u);
}

// --- Euclidean colouring (PBA) -------------------------------------------------------------------

/// PBA with the automatic and several explicit band counts must equal brute force: odd counts leave
/// bands unpaired in merge rounds, bands of 3 or 4 lines make many merge rounds that copy stack tails,
/// and m bands are one line each.
void expect_pba_matches_brute_force(const GridSites& s, std::uint32_t m, CpuExecutor& executor) {
  const std::vector<std::uint32_t> expected = brute_force_colouring(s, m);
  for (const std::uint32_t bands : {0u, 1u, 2u, 3u, 5u, 8u, m / 4, m / 3, m}) {
    const std::vector<std::uint32_t> colour =
        cdt::detail::compute_euclidean_colouring(s.cell_owner, m, executor, bands);
    ASSERT_EQ(colour.size(), expected.size());
    for (std::size_t c = 0; c < colour.size(); ++c)
      ASSERT_EQ(colour[c], expected[c])
          << "m " << m << " bands " << bands << " cell (" << c % m << ", " << c / m << ")";
  }
}

TEST(Voronoi, MatchesBruteForceOnRandomSites) {
  CpuExecutor executor(2);
  SplitMix64 rng(42);
  for (const std::uint32_t m : {8u, 13u, 32u, 64u, 100u, 128u}) {
    for (const std::uint32_t count : {2u, 5u, m / 2, m, 4 * m}) {
      const GridSites s = sites_at(m, random_points(m, count, rng), executor);
      expect_pba_matches_brute_force(s, m, executor);
      if (HasFatalFailure()) return;
    }
  }
}

// Lattices, collinear sites, symmetric pairs and corners put many cells at equal distance from
// several sites, so any phase that breaks ties differently from Definition 1 shows here.
TEST(Voronoi, MatchesBruteForceOnTiesAndDegenerateLayouts) {
  CpuExecutor executor(2);
  SplitMix64 rng(5);
  for (const std::uint32_t m : {8u, 9u, 31u, 64u, 128u}) {
    for (const auto& points : awkward_site_sets(m, rng)) {
      const GridSites s = sites_at(m, points, executor);
      expect_pba_matches_brute_force(s, m, executor);
      if (HasFatalFailure()) return;
    }
  }
}

// With the same cells occupied, only the index order decides ties: reversing it must flip them.
TEST(Voronoi, TiesGoToTheSmallerIndexWhicheverWayTheyAreNumbered) {
  CpuExecutor executor(1);
  const std::uint32_t m = 16;
  std::vector<GridPoint> points = lattice_points(m, 4, 4, 0, 0);
  const GridSites forward = sites_at(m, points, executor);
  std::reverse(points.begin(), points.end());
  const GridSites backward = sites_at(m, points, executor);
  const auto a = cdt::detail::compute_euclidean_colouring(forward.cell_owner, m, executor);
  const auto b = cdt::detail::compute_euclidean_colouring(backward.cell_owner, m, executor);
  EXPECT_EQ(a, brute_force_colouring(forward, m));
  EXPECT_EQ(b, brute_force_colouring(backward, m));
  // Cell (2, 2) is equidistant from the sites at (0, 0), (4, 0), (0, 4), (4, 4): indices 0, 1, 4, 5
  // forward; the smallest of the reversed numbering is the site at (4, 4).
  EXPECT_EQ(a[2 * m + 2], 0u);
  EXPECT_EQ(backward.gx[b[2 * m + 2]], 4u);
  EXPECT_EQ(backward.gy[b[2 * m + 2]], 4u);
}

// A grid without sites has no proximate sites in any row: every phase must cope with empty stacks.
TEST(Voronoi, NoSitesLeavesEveryCellUncoloured) {
  CpuExecutor executor(1);
  const GridSites s = sites_at(16, {}, executor);
  const auto colour = cdt::detail::compute_digital_voronoi(s, 16, executor);
  EXPECT_EQ(std::count(colour.begin(), colour.end(), kNone), 256);
}

// Large enough that every PBA step and the orphan scan run on several threads at once.
TEST(Voronoi, ParallelRunsMatchBruteForceOnALargerGrid) {
  SplitMix64 rng(99);
  const std::uint32_t m = 512;
  CpuExecutor serial(1), parallel(4);
  const GridSites s = sites_at(m, random_points(m, 60, rng), parallel);
  const auto expected = brute_force_colouring(s, m);
  EXPECT_EQ(cdt::detail::compute_euclidean_colouring(s.cell_owner, m, parallel), expected);
  EXPECT_EQ(cdt::detail::compute_euclidean_colouring(s.cell_owner, m, parallel, 32), expected);
  EXPECT_EQ(cdt::detail::compute_digital_voronoi(s, m, parallel),
            cdt::detail::compute_digital_voronoi(s, m, serial));
}

// --- amendment (Appendix A) ----------------------------------------------------------------------

/// Runs the amendment on the Euclidean colouring of s and checks it against the reference flooding,
/// connectivity and the unchanged bulks. Returns the number of debris found.
std::size_t check_amendment(const GridSites& s, std::uint32_t m, CpuExecutor& executor) {
  const std::vector<std::uint32_t> euclidean = brute_force_colouring(s, m);
  std::vector<std::uint32_t> amended = euclidean;
  const std::size_t debris = cdt::detail::amend_to_standard_flooding(amended, s, m, executor);
  const std::vector<std::uint32_t> reference = standard_flooding(s, m);
  EXPECT_EQ(amended, reference) << "m " << m;
  const std::vector<std::uint8_t> bulk_before = bulk_cells(euclidean, s, m);
  const std::vector<std::uint8_t> bulk_after = bulk_cells(amended, s, m);
  std::size_t changed = 0, not_in_bulk = 0;
  for (std::size_t c = 0; c < amended.size(); ++c) {
    EXPECT_TRUE(bulk_after[c]) << "cell (" << c % m << ", " << c / m << ") not connected to its site";
    if (bulk_before[c]) {
      EXPECT_EQ(amended[c], euclidean[c]) << "bulk cell changed";
    }
    changed += amended[c] != euclidean[c];
    not_in_bulk += !bulk_before[c];
  }
  // The debris found are exactly the cells outside the 4-connected bulks: every debris cell is outside
  // one, every changed cell was a debris cell.
  EXPECT_EQ(debris, not_in_bulk);
  EXPECT_LE(changed, debris);
  return debris;
}

// Algorithm A.1 must reproduce the Standard flooding exactly; the sweep is dense enough in sites for
// Euclidean colourings with debris to occur, which the final check makes sure of.
TEST(Voronoi, AmendmentEqualsStandardFlooding) {
  CpuExecutor executor(2);
  SplitMix64 rng(2024);
  std::size_t debris = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const std::uint32_t m = 8 + rng.below(57);
    const std::uint32_t count = 2 + rng.below(m * m / 8);
    const GridSites s = sites_at(m, random_points(m, count, rng), executor);
    debris += check_amendment(s, m, executor);
    if (HasFailure()) {
      ADD_FAILURE() << "trial " << trial;
      return;
    }
  }
  EXPECT_GT(debris, 0u) << "no input had debris: the amendment was not exercised";
}

// The same on layouts full of ties, where the flooding's tie rule matters.
TEST(Voronoi, AmendmentEqualsStandardFloodingOnTies) {
  CpuExecutor executor(2);
  SplitMix64 rng(77);
  for (const std::uint32_t m : {8u, 16u, 33u, 64u}) {
    for (const auto& points : awkward_site_sets(m, rng)) {
      check_amendment(sites_at(m, points, executor), m, executor);
      if (HasFailure()) return;
    }
  }
}

// A debris cell behind another: site 2 at (7, 1) owns (2, 12) and (2, 13) by distance, but (2, 12)
// is cut off (its neighbours towards the site have colours 0 and 1) and (2, 13) reaches the site only
// through (2, 12). Random inputs rarely have such chains, so this pins the worklist that finds them.
TEST(Voronoi, DebrisReachableOnlyThroughDebrisAreDebris) {
  CpuExecutor executor(1);
  constexpr std::uint32_t m = 18;
  const GridSites s = sites_at(m, {{9, 2}, {0, 0}, {7, 1}}, executor);
  const std::vector<std::uint32_t> euclidean = brute_force_colouring(s, m);
  const auto at = [](std::uint32_t x, std::uint32_t y) { return static_cast<std::size_t>(y) * m + x; };
  ASSERT_EQ(euclidean[at(2, 12)], 2u);
  ASSERT_EQ(euclidean[at(2, 13)], 2u);
  ASSERT_EQ(euclidean[at(3, 12)], 0u);
  ASSERT_EQ(euclidean[at(2, 11)], 1u);
  ASSERT_EQ(euclidean[at(3, 13)], 0u);
  EXPECT_EQ(check_amendment(s, m, executor), 2u);
  const auto colour = cdt::detail::compute_digital_voronoi(s, m, executor);
  EXPECT_NE(colour[at(2, 12)], 2u);
  EXPECT_NE(colour[at(2, 13)], 2u);
}

// The public entry point end to end on dense inputs (where debris occur): connected regions, each
// holding its own site, and the same result as the two steps run separately.
TEST(Voronoi, DigitalVoronoiHasConnectedRegionsContainingTheirSites) {
  CpuExecutor executor(2);
  SplitMix64 rng(8);
  std::size_t debris = 0;
  for (int trial = 0; trial < 50; ++trial) {
    const std::uint32_t m = 64;
    const GridSites s = sites_at(m, random_points(m, 300 + rng.below(600), rng), executor);
    const auto colour = cdt::detail::compute_digital_voronoi(s, m, executor);
    const auto bulk = bulk_cells(colour, s, m);
    EXPECT_EQ(std::count(bulk.begin(), bulk.end(), 1), static_cast<std::ptrdiff_t>(m * m));
    for (const std::uint32_t p : kept_sites(s)) EXPECT_EQ(colour[s.gy[p] * m + s.gx[p]], p);
    auto euclidean = cdt::detail::compute_euclidean_colouring(s.cell_owner, m, executor);
    debris += cdt::detail::amend_to_standard_flooding(euclidean, s, m, executor);
    EXPECT_EQ(euclidean, colour);
  }
  EXPECT_GT(debris, 0u);
}

} // namespace

namespace {

/// Sites taken out of a colouring, written plainly: each removed site's 4-connected region around its
/// cell is cleared, then one priority queue over every cleared cell, ordered by (distance, site, cell),
/// gives each the colour of the first entry to reach it.
std::vector<std::uint32_t> remove_sites_plainly(std::vector<std::uint32_t> colour, const GridSites& s,
                                                std::uint32_t m, const std::vector<std::uint32_t>& removed) {
  const auto in_grid = [&](std::int64_t x, std::int64_t y) { return x >= 0 && y >= 0 && x < m && y < m; };
  const int dx[4] = {-1, 1, 0, 0};
  const int dy[4] = {0, 0, -1, 1};
  std::vector<std::uint32_t> cleared;
  for (const std::uint32_t site : removed) {
    std::vector<std::uint32_t> stack{s.gy[site] * m + s.gx[site]};
    if (colour[stack[0]] != site) continue;
    colour[stack[0]] = kNone;
    while (!stack.empty()) {
      const std::uint32_t c = stack.back();
      stack.pop_back();
      cleared.push_back(c);
      for (int k = 0; k < 4; ++k) {
        const std::int64_t x = c % m + dx[k], y = c / m + dy[k];
        if (!in_grid(x, y) || colour[y * m + x] != site) continue;
        colour[y * m + x] = kNone;
        stack.push_back(static_cast<std::uint32_t>(y * m + x));
      }
    }
  }
  using Entry = std::tuple<std::int64_t, std::uint32_t, std::uint32_t>; // distance, site, cell
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  const auto push_from = [&](std::uint32_t c, std::uint32_t site) {
    for (int k = 0; k < 4; ++k) {
      const std::int64_t x = c % m + dx[k], y = c / m + dy[k];
      if (in_grid(x, y) && colour[y * m + x] == kNone)
        queue.push({squared_distance(s, static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y), site),
                    site, static_cast<std::uint32_t>(y * m + x)});
    }
  };
  for (std::uint32_t c = 0; c < m * m; ++c)
    if (colour[c] != kNone) push_from(c, colour[c]);
  while (!queue.empty()) {
    const auto [d, site, c] = queue.top();
    queue.pop();
    if (colour[c] != kNone) continue;
    colour[c] = site;
    push_from(c, site);
  }
  return colour;
}

// Removing sites (the degenerate corners' middle sites) floods their regions from the neighbours like
// one queue over all of them, both where a cleared cell stands alone among coloured cells (taken at
// once) and where cleared cells touch (flooded); dense sites make both common.
TEST(Voronoi, RemovedSitesAreFloodedLikeOneQueue) {
  CpuExecutor executor(2);
  SplitMix64 rng(515);
  std::size_t alone = 0, touching = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const std::uint32_t m = 8 + rng.below(57);
    const std::uint32_t count = 2 + rng.below(m * m);
    const GridSites s = sites_at(m, random_points(m, count, rng), executor);
    std::vector<std::uint32_t> colour = cdt::detail::compute_digital_voronoi(s, m, executor);
    std::vector<std::uint32_t> removed;
    for (const std::uint32_t site : kept_sites(s))
      if (rng.below(100) < 5u + static_cast<std::uint32_t>(trial % 40)) removed.push_back(site);
    const std::vector<std::uint32_t> expected = remove_sites_plainly(colour, s, m, removed);
    std::vector<std::uint8_t> is_cleared(colour.size(), 0);
    const std::vector<std::uint32_t> cleared =
        cdt::detail::remove_sites_from_colouring(colour, s, m, removed);
    for (const std::uint32_t c : cleared) is_cleared[c] = 1;
    for (const std::uint32_t c : cleared) {
      bool touches = false;
      cdt::detail::amend::for_each_neighbour(m, c % m, c / m, [&](std::uint32_t x, std::uint32_t y) {
        touches = touches || is_cleared[y * m + x] != 0;
      });
      ++(touches ? touching : alone);
    }
    ASSERT_EQ(colour, expected) << "trial " << trial << ", m " << m << ", " << removed.size() << " removed";
  }
  EXPECT_GT(alone, 100u);
  EXPECT_GT(touching, 100u);
}

} // namespace
