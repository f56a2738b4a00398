// Phase 1 of gCD on the device (paper section 3.1, Appendix A): the colouring computed by the CUDA
// executor must be the CPU executor's, cell for cell, on the inputs the engine meets (uniform,
// Gaussian, clustered, lattice) and on dense inputs whose Euclidean colouring has debris, so that the
// amendment's worklist and flood run on the device.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "cdt/errors.hpp"
#include "cdt_kernels.hpp"
#include "executor/cpu_executor.hpp"
#include "gcd/dualize.hpp"
#include "gcd/grid_map.hpp"
#include "gcd/shift.hpp"
#include "gcd/voronoi.hpp"
#include "pslg.hpp"

namespace {

using cdt::kNone;
using cdt::detail::CpuExecutor;
using cdt::detail::GridSites;

class Rng {
public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double unit() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  std::uint32_t below(std::uint32_t n) { return static_cast<std::uint32_t>(next() % n); }
  /// Standard normal by Box-Muller (two uniforms; deterministic on every platform).
  double normal() {
    const double u = 1.0 - unit(), v = unit();
    return std::sqrt(-2.0 * std::log(u)) * std::cos(6.283185307179586 * v);
  }

private:
  std::uint64_t state_;
};

enum class Layout { uniform, gaussian, clustered, lattice };

const char* name(Layout l) {
  switch (l) {
  case Layout::uniform:
    return "uniform";
  case Layout::gaussian:
    return "gaussian";
  case Layout::clustered:
    return "clustered";
  case Layout::lattice:
    return "lattice";
  }
  return "?";
}

struct Points {
  std::vector<double> x, y;
};

Points make_points(Layout layout, std::size_t n, Rng& rng) {
  Points p;
  p.x.reserve(n);
  p.y.reserve(n);
  switch (layout) {
  case Layout::uniform:
    for (std::size_t i = 0; i < n; ++i) {
      p.x.push_back(rng.unit());
      p.y.push_back(rng.unit());
    }
    break;
  case Layout::gaussian:
    for (std::size_t i = 0; i < n; ++i) {
      p.x.push_back(rng.normal());
      p.y.push_back(rng.normal());
    }
    break;
  case Layout::clustered: {
    // A few tight clusters over a sparse background: many points share cells, most cells are far
    // from every site.
    std::vector<std::pair<double, double>> centres;
    for (int k = 0; k < 12; ++k) centres.emplace_back(rng.unit(), rng.unit());
    for (std::size_t i = 0; i < n; ++i) {
      if (i % 10 == 0) {
        p.x.push_back(rng.unit());
        p.y.push_back(rng.unit());
        continue;
      }
      const auto& c = centres[rng.below(static_cast<std::uint32_t>(centres.size()))];
      p.x.push_back(c.first + 0.01 * rng.normal());
      p.y.push_back(c.second + 0.01 * rng.normal());
    }
    break;
  }
  case Layout::lattice: {
    // A pixel lattice (integer points), a little sparser than the grid: ties everywhere.
    const auto side = static_cast<std::uint32_t>(std::ceil(std::sqrt(static_cast<double>(n))));
    for (std::uint32_t j = 0; j < side && p.x.size() < n; ++j)
      for (std::uint32_t i = 0; i < side && p.x.size() < n; ++i) {
        p.x.push_back(i);
        p.y.push_back(j);
      }
    break;
  }
  }
  return p;
}

struct Grid {
  GridSites sites;
  std::uint32_t m = 0;
};

Grid map_points(const Points& p, std::uint32_t m, CpuExecutor& executor) {
  const auto mapping = cdt::detail::make_grid_mapping(p.x, p.y, m);
  return {cdt::detail::assign_sites(mapping, p.x, p.y, executor), m};
}

/// Grid sites at integer positions through the identity mapping, as the CPU tests state them.
Grid sites_at(std::uint32_t m, const std::vector<std::pair<std::uint32_t, std::uint32_t>>& cells,
              CpuExecutor& executor) {
  cdt::detail::GridMapping identity;
  identity.m = m;
  identity.scale = 1.0;
  std::vector<double> x, y;
  for (const auto& [cx, cy] : cells) {
    x.push_back(cx);
    y.push_back(cy);
  }
  return {cdt::detail::assign_sites(identity, x, y, executor), m};
}

std::vector<std::uint32_t> on_device(const Grid& g, const cdt::gpu::VoronoiOptions& options = {},
                                     cdt::gpu::VoronoiStats* stats = nullptr) {
  return cdt::gpu::compute_digital_voronoi(g.sites.cell_owner, g.sites.gx, g.sites.gy, g.m, options, stats);
}

/// Cells where two colourings differ, with the first few named.
std::string differences(const std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b,
                        std::uint32_t m) {
  if (a.size() != b.size()) return "sizes " + std::to_string(a.size()) + " and " + std::to_string(b.size());
  std::size_t count = 0;
  std::string first;
  for (std::size_t c = 0; c < a.size(); ++c) {
    if (a[c] == b[c]) continue;
    if (++count <= 3)
      first += " (" + std::to_string(c % m) + ", " + std::to_string(c / m) + "): " + std::to_string(a[c]) +
               " vs " + std::to_string(b[c]) + ";";
  }
  return count == 0 ? "" : std::to_string(count) + " cells differ:" + first;
}

class GpuVoronoi : public ::testing::Test {
protected:
  void SetUp() override {
    if (cdt::gpu::device_count() == 0) GTEST_SKIP() << "no CUDA device available";
  }
};

// The main property: the device colouring is the CPU executor's on every layout and grid size.
// Points about m^2 / 4 (the engine's own load) down to m^2 / 64.
TEST_F(GpuVoronoi, MatchesTheCpuExecutorOnEveryLayoutAndGridSize) {
  CpuExecutor executor;
  Rng rng(42);
  std::uint64_t debris = 0;
  for (const std::uint32_t m : {64u, 128u, 256u, 512u, 1024u, 2048u, 4096u}) {
    for (const Layout layout : {Layout::uniform, Layout::gaussian, Layout::clustered, Layout::lattice}) {
      const std::size_t n = static_cast<std::size_t>(m) * m / (m <= 256 ? 4 : 16);
      const Grid g = map_points(make_points(layout, n, rng), m, executor);
      const auto expected = cdt::detail::compute_digital_voronoi(g.sites, m, executor);
      cdt::gpu::VoronoiStats stats;
      const auto colour = on_device(g, {}, &stats);
      EXPECT_EQ(differences(colour, expected, m), "") << name(layout) << " m " << m << " n " << n;
      EXPECT_GE(stats.debris, stats.orphans);
      debris += stats.debris;
      if (HasFailure()) return;
    }
  }
  EXPECT_GT(debris, 0u) << "no input had debris: the amendment did not run on the device";
}

// Dense random sites on small grids, where Euclidean colourings have debris (the CPU tests' sweep):
// the worklist and the flood must reproduce the CPU's priority-queue flood.
TEST_F(GpuVoronoi, AmendmentMatchesTheCpuOnDenseInputs) {
  CpuExecutor executor(2);
  Rng rng(2024);
  std::uint64_t debris = 0, flood_rounds = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const std::uint32_t m = 8 + rng.below(120);
    const std::uint32_t count = 2 + rng.below(m * m / 6);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> cells;
    for (std::uint32_t k = 0; k < count; ++k) cells.emplace_back(rng.below(m), rng.below(m));
    const Grid g = sites_at(m, cells, executor);
    const auto expected = cdt::detail::compute_digital_voronoi(g.sites, m, executor);
    cdt::gpu::VoronoiStats stats;
    const auto colour = on_device(g, {}, &stats);
    ASSERT_EQ(differences(colour, expected, m), "") << "trial " << trial << " m " << m << " sites " << count;
    // The same count of debris as the CPU's amendment finds on the Euclidean colouring.
    auto euclidean = cdt::detail::compute_euclidean_colouring(g.sites.cell_owner, m, executor);
    ASSERT_EQ(stats.debris, cdt::detail::amend_to_standard_flooding(euclidean, g.sites, m, executor));
    debris += stats.debris;
    flood_rounds += stats.flood_rounds;
  }
  EXPECT_GT(debris, 100u) << "too few debris to exercise the amendment";
  EXPECT_GT(flood_rounds, 200u) << "the flood never needed a second round";
}

// The CPU tests' chain: (2, 13) is debris only because (2, 12) is, so the worklist needs a second
// round to find it.
TEST_F(GpuVoronoi, DebrisReachableOnlyThroughDebrisAreFound) {
  CpuExecutor executor(1);
  const Grid g = sites_at(18, {{9, 2}, {0, 0}, {7, 1}}, executor);
  cdt::gpu::VoronoiStats stats;
  const auto colour = on_device(g, {}, &stats);
  EXPECT_EQ(stats.orphans, 1u);
  EXPECT_EQ(stats.debris, 2u);
  EXPECT_GE(stats.debris_rounds, 2u);
  EXPECT_EQ(differences(colour, cdt::detail::compute_digital_voronoi(g.sites, 18, executor), 18), "");
  EXPECT_NE(colour[12 * 18 + 2], 2u);
  EXPECT_NE(colour[13 * 18 + 2], 2u);
}

// PBA alone (Definition 1) for band counts from one band to one column or row per band: the band
// linking and stack merging on the device must not change the result.
TEST_F(GpuVoronoi, EuclideanColouringIsTheSameForEveryBandCount) {
  CpuExecutor executor;
  Rng rng(7);
  for (const std::uint32_t m : {61u, 256u, 1000u}) {
    const Grid g = map_points(make_points(Layout::uniform, m * m / 20, rng), m, executor);
    const auto expected = cdt::detail::compute_euclidean_colouring(g.sites.cell_owner, m, executor);
    for (const std::uint32_t bands : {1u, 2u, 3u, 7u, 64u, m / 2, m}) {
      cdt::gpu::VoronoiOptions options;
      options.amend = false;
      options.row_bands = bands;
      options.col_bands = bands;
      EXPECT_EQ(differences(on_device(g, options), expected, m), "") << "m " << m << " bands " << bands;
      options.amend = true;
      EXPECT_EQ(
          differences(on_device(g, options), cdt::detail::compute_digital_voronoi(g.sites, m, executor), m),
          "")
          << "amended, m " << m << " bands " << bands;
    }
  }
}

// Independent of the CPU executor: PBA on the device against the brute-force nearest site.
TEST_F(GpuVoronoi, EuclideanColouringMatchesBruteForce) {
  CpuExecutor executor(1);
  Rng rng(99);
  for (int trial = 0; trial < 20; ++trial) {
    const std::uint32_t m = 5 + rng.below(60);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> cells;
    const std::uint32_t count = 1 + rng.below(2 * m);
    for (std::uint32_t k = 0; k < count; ++k) cells.emplace_back(rng.below(m), rng.below(m));
    const Grid g = sites_at(m, cells, executor);
    std::vector<std::uint32_t> expected(static_cast<std::size_t>(m) * m, kNone);
    for (std::uint32_t y = 0; y < m; ++y)
      for (std::uint32_t x = 0; x < m; ++x) {
        std::int64_t best = -1;
        for (std::uint32_t p = 0; p < count; ++p) {
          if (g.sites.cell_owner[static_cast<std::size_t>(g.sites.gy[p]) * m + g.sites.gx[p]] != p) continue;
          const std::int64_t dx = std::int64_t{x} - g.sites.gx[p], dy = std::int64_t{y} - g.sites.gy[p];
          const std::int64_t d = dx * dx + dy * dy;
          if (best < 0 || d < best) { // points in increasing order: the first at a distance wins ties
            best = d;
            expected[static_cast<std::size_t>(y) * m + x] = p;
          }
        }
      }
    cdt::gpu::VoronoiOptions options;
    options.amend = false;
    EXPECT_EQ(differences(on_device(g, options), expected, m), "") << "trial " << trial;
  }
}

TEST_F(GpuVoronoi, NoSitesLeavesEveryCellUncoloured) {
  CpuExecutor executor(1);
  const Grid g = sites_at(16, {}, executor);
  const auto colour = on_device(g);
  EXPECT_EQ(std::count(colour.begin(), colour.end(), kNone), 256);
}

TEST_F(GpuVoronoi, OneSiteColoursEverything) {
  CpuExecutor executor(1);
  const Grid g = sites_at(1, {{0, 0}}, executor);
  EXPECT_EQ(on_device(g), std::vector<std::uint32_t>{0u});
  const Grid h = sites_at(300, {{299, 0}}, executor);
  const auto colour = on_device(h);
  EXPECT_EQ(std::count(colour.begin(), colour.end(), 0u), 300 * 300);
}

TEST_F(GpuVoronoi, InconsistentInputIsAClearError) {
  CpuExecutor executor(1);
  Grid g = sites_at(32, {{1, 2}, {30, 30}, {5, 17}}, executor);
  EXPECT_THROW(cdt::gpu::compute_digital_voronoi(g.sites.cell_owner, g.sites.gx, g.sites.gy, 0), cdt::Error);
  EXPECT_THROW(cdt::gpu::compute_digital_voronoi(g.sites.cell_owner, g.sites.gx, g.sites.gy, 31), cdt::Error);
  std::vector<std::uint32_t> short_y(g.sites.gy.begin(), g.sites.gy.end() - 1);
  EXPECT_THROW(cdt::gpu::compute_digital_voronoi(g.sites.cell_owner, g.sites.gx, short_y, 32), cdt::Error);
  // An owner index beyond the points, and an owner that sits in another cell.
  auto owners = g.sites.cell_owner;
  owners[0] = 3;
  try {
    cdt::gpu::compute_digital_voronoi(owners, g.sites.gx, g.sites.gy, 32);
    ADD_FAILURE() << "owner out of range accepted";
  } catch (const cdt::Error& e) {
    EXPECT_NE(std::string(e.what()).find("cell_owner"), std::string::npos) << e.what();
  }
  owners = g.sites.cell_owner;
  owners[0] = 1;
  EXPECT_THROW(cdt::gpu::compute_digital_voronoi(owners, g.sites.gx, g.sites.gy, 32), cdt::Error);
  // The device is still usable afterwards.
  EXPECT_EQ(on_device(g), cdt::detail::compute_digital_voronoi(g.sites, 32, executor));
}

// The memory check comes before any allocation and says what did not fit.
TEST_F(GpuVoronoi, InputBeyondTheMemoryLimitIsADeviceError) {
  CpuExecutor executor(1);
  const Grid g = sites_at(1024, {{1, 2}, {300, 30}}, executor);
  const std::size_t need = cdt::gpu::voronoi_device_bytes(1024, 2);
  EXPECT_GE(need, 3u * 1024 * 1024 * 4) << "at least the three grid-sized buffers";
  cdt::gpu::VoronoiOptions options;
  options.memory_limit = need - 1;
  try {
    on_device(g, options);
    ADD_FAILURE() << "no error below the estimate";
  } catch (const cdt::DeviceError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("1024 x 1024"), std::string::npos) << what;
    EXPECT_NE(what.find("MiB"), std::string::npos) << what;
  }
  options.memory_limit = need;
  cdt::gpu::VoronoiStats stats;
  EXPECT_EQ(on_device(g, options, &stats), cdt::detail::compute_digital_voronoi(g.sites, 1024, executor));
  EXPECT_EQ(stats.device_bytes, need);
  // The largest grid's estimate is finite and grows with the points.
  EXPECT_LT(cdt::gpu::voronoi_device_bytes(32768, 0), cdt::gpu::voronoi_device_bytes(32768, 1000000));
}

/// What cdt::triangulate computes on the host before the digital Voronoi diagram, written out here
/// step by step: the sites in the Z order of their grid cells (ties in vertex order), their grid cells
/// and owners, kept sites at their grid points, the box of both positions, the missing points.
struct HostSites {
  cdt::detail::GridMapping mapping;
  cdt::IndexArray site_vertex, site_of_vertex;
  std::vector<double> true_x, true_y, x, y;
  cdt::detail::FlagArray kept;
  cdt::detail::MissingArray missing;
  cdt::detail::Box bounds;
  GridSites grid;
};

HostSites host_sites(const std::vector<cdt::Point>& vertices, const std::vector<std::uint32_t>& sites,
                     std::uint32_t m, CpuExecutor& executor) {
  HostSites h;
  const std::size_t n = sites.size();
  std::vector<double> gx(n), gy(n);
  for (std::size_t k = 0; k < n; ++k) {
    gx[k] = vertices[sites[k]].x;
    gy[k] = vertices[sites[k]].y;
  }
  h.mapping = cdt::detail::make_grid_mapping(gx, gy, m);
  std::vector<std::uint32_t> order(n);
  for (std::size_t k = 0; k < n; ++k) order[k] = static_cast<std::uint32_t>(k);
  const auto key = [&](std::uint32_t k) {
    return cdt::detail::z_order_key(h.mapping.grid_x(gx[k]), h.mapping.grid_y(gy[k]));
  };
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return key(a) < key(b); });
  h.site_of_vertex.assign(vertices.size(), cdt::detail::kNoId);
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t v = sites[order[k]];
    h.site_vertex.push_back(v);
    h.site_of_vertex[v] = static_cast<std::uint32_t>(k);
    h.true_x.push_back(vertices[v].x);
    h.true_y.push_back(vertices[v].y);
  }
  h.grid = cdt::detail::assign_sites(h.mapping, h.true_x, h.true_y, executor);
  h.x = h.true_x;
  h.y = h.true_y;
  h.kept.assign(n, 0);
  h.bounds = {h.true_x[0], h.true_y[0], h.true_x[0], h.true_y[0]};
  for (std::size_t k = 0; k < n; ++k) {
    if (h.grid.cell_owner[static_cast<std::size_t>(h.grid.gy[k]) * m + h.grid.gx[k]] == k) {
      h.kept[k] = 1;
      h.x[k] = h.mapping.to_x(h.grid.gx[k]);
      h.y[k] = h.mapping.to_y(h.grid.gy[k]);
    }
    for (const auto& [px, py] : {std::pair{h.x[k], h.y[k]}, std::pair{h.true_x[k], h.true_y[k]}}) {
      h.bounds.min_x = std::min(h.bounds.min_x, px);
      h.bounds.min_y = std::min(h.bounds.min_y, py);
      h.bounds.max_x = std::max(h.bounds.max_x, px);
      h.bounds.max_y = std::max(h.bounds.max_y, py);
    }
  }
  for (std::size_t i = 0; i < h.grid.missing.size(); ++i)
    h.missing.push_back({h.grid.missing[i], h.grid.missing_owner[i]});
  return h;
}

// gpu::DeviceSites gives the host's numbering, cells, kept sites, missing points and box, and the
// diagram made from its cells on the device is the host's colouring: with every vertex a site and
// with some left out (duplicates), on grids from 1 to 1024 a side, with many points per cell. The
// dual's passes then take the same degenerate sites out of the diagram on both.
TEST_F(GpuVoronoi, DeviceSitesMatchTheHostSteps) {
  CpuExecutor executor(2);
  Rng rng(7);
  std::size_t missing_seen = 0;
  std::size_t degenerate_seen = 0;
  int duals_built = 0;
  for (const std::uint32_t m : {1u, 2u, 64u, 256u, 1024u}) {
    for (const Layout layout : {Layout::uniform, Layout::gaussian, Layout::clustered, Layout::lattice}) {
      for (const bool subset : {false, true}) {
        const std::size_t n = std::max<std::size_t>(3, static_cast<std::size_t>(m) * m / 2);
        const Points p = make_points(layout, n, rng);
        std::vector<cdt::Point> vertices(n);
        for (std::size_t i = 0; i < n; ++i) vertices[i] = {p.x[i], p.y[i]};
        std::vector<std::uint32_t> sites;
        for (std::uint32_t i = 0; i < n; ++i)
          if (!subset || i % 7 != 3) sites.push_back(i);
        const HostSites h = host_sites(vertices, sites, m, executor);

        cdt::detail::GridMapping mapping;
        cdt::detail::Box bounds;
        cdt::IndexArray site_vertex, site_of_vertex;
        cdt::detail::FlagArray kept;
        cdt::detail::MissingArray missing;
        cdt::gpu::DeviceSites device(vertices, sites, m, mapping, bounds, site_vertex, site_of_vertex, kept,
                                     missing);
        device.finish_downloads(); // the vertex maps come down on a thread of their own
        const std::string what =
            std::string(name(layout)) + " m " + std::to_string(m) + (subset ? " subset" : "");
        EXPECT_EQ(mapping.m, h.mapping.m) << what;
        EXPECT_EQ(mapping.scale, h.mapping.scale) << what;
        EXPECT_EQ(mapping.tx, h.mapping.tx) << what;
        EXPECT_EQ(mapping.ty, h.mapping.ty) << what;
        EXPECT_EQ(site_vertex, h.site_vertex) << what;
        EXPECT_EQ(site_of_vertex, h.site_of_vertex) << what;
        EXPECT_EQ(kept, h.kept) << what;
        ASSERT_EQ(missing.size(), h.missing.size()) << what;
        for (std::size_t i = 0; i < missing.size(); ++i) {
          EXPECT_EQ(missing[i].vertex, h.missing[i].vertex) << what << " missing " << i;
          EXPECT_EQ(missing[i].hint, h.missing[i].hint) << what << " missing " << i;
        }
        missing_seen += missing.size();
        EXPECT_EQ(bounds.min_x, h.bounds.min_x) << what;
        EXPECT_EQ(bounds.min_y, h.bounds.min_y) << what;
        EXPECT_EQ(bounds.max_x, h.bounds.max_x) << what;
        EXPECT_EQ(bounds.max_y, h.bounds.max_y) << what;
        std::vector<double> true_x, true_y, x, y;
        device.positions(x, y, &true_x, &true_y);
        EXPECT_EQ(true_x, h.true_x) << what;
        EXPECT_EQ(true_y, h.true_y) << what;
        EXPECT_EQ(x, h.x) << what;
        EXPECT_EQ(y, h.y) << what;
        cdt::gpu::DeviceVoronoi diagram(device);
        std::vector<std::uint32_t> gx, gy;
        diagram.site_cells(gx, gy);
        EXPECT_EQ(gx, h.grid.gx) << what;
        EXPECT_EQ(gy, h.grid.gy) << what;
        std::vector<std::uint32_t> colour = cdt::detail::compute_digital_voronoi(h.grid, m, executor);
        EXPECT_EQ(differences(diagram.colour(), colour, m), "") << what;
        if (HasFailure()) return;
        if (m < 64) continue;
        // The dual's passes as triangulate() runs them, on the host and from the device's sites: the same
        // degenerate sites each pass, the same colouring after their removal, the same owners of their
        // cells and the same positions after they are left out.
        std::vector<double> hx = h.x, hy = h.y;
        cdt::detail::FlagArray hkept = h.kept;
        for (int pass = 1; pass <= 8; ++pass) {
          const std::string at = what + ", pass " + std::to_string(pass);
          std::vector<std::uint32_t> degenerate, culprits;
          const cdt::detail::Mesh host =
              cdt::detail::dualize(colour, m, hx, hy, hkept, h.bounds, executor, nullptr, &degenerate);
          std::optional<cdt::gpu::DeviceMesh> on_device;
          std::vector<std::uint32_t> unreached;
          const auto outcome = diagram.complete_dual(device, bounds, on_device, unreached, &culprits);
          if (host.num_slots() > 0) {
            EXPECT_NE(outcome, cdt::gpu::DeviceVoronoi::DualOutcome::degenerate) << at;
            if (outcome == cdt::gpu::DeviceVoronoi::DualOutcome::built) {
              ++duals_built;
              std::vector<std::uint32_t> host_unreached;
              for (std::uint32_t s = 0; s < hkept.size(); ++s)
                if (hkept[s] != 0 && host.vert_tri[s] == cdt::detail::kNoId) host_unreached.push_back(s);
              EXPECT_EQ(unreached, host_unreached) << at;
            }
            break;
          }
          ASSERT_EQ(outcome, cdt::gpu::DeviceVoronoi::DualOutcome::degenerate) << at;
          EXPECT_EQ(culprits, degenerate) << at;
          degenerate_seen += degenerate.size();
          cdt::detail::remove_sites_from_colouring(colour, h.grid, m, degenerate);
          const std::vector<std::uint32_t> owners = diagram.remove_sites(culprits);
          EXPECT_EQ(differences(diagram.colour(), colour, m), "") << at;
          ASSERT_EQ(owners.size(), degenerate.size()) << at;
          for (std::size_t k = 0; k < owners.size(); ++k) {
            const std::uint32_t s = degenerate[k];
            EXPECT_EQ(owners[k], colour[static_cast<std::size_t>(h.grid.gy[s]) * m + h.grid.gx[s]]) << at;
            hkept[s] = 0;
            hx[s] = h.true_x[s];
            hy[s] = h.true_y[s];
          }
          device.leave_out(culprits);
          device.positions(x, y);
          EXPECT_EQ(x, hx) << at;
          EXPECT_EQ(y, hy) << at;
          if (HasFailure()) return;
        }
      }
    }
  }
  EXPECT_GT(missing_seen, 0u) << "no cell held two sites: the owners' minimum went untested";
  EXPECT_GT(degenerate_seen, 0u) << "no degenerate corner: the removal on the device went untested";
  EXPECT_GT(duals_built, 0) << "no dual was built from the device's sites";
}

/// Pairs of distinct points whose hashes agree in the low 32 bits (the bits the host's merge groups by;
/// the device's table starts its probes at the high bits, and distinct points share a first slot there
/// at any load), found among random points by their birthday: about ten pairs among 300000 points.
std::vector<std::pair<cdt::Point, cdt::Point>> colliding_pairs(Rng& rng) {
  std::vector<std::pair<std::uint32_t, cdt::Point>> hashed(300000);
  for (auto& [h, p] : hashed) {
    p = {rng.unit(), rng.unit()};
    h = static_cast<std::uint32_t>(cdt::detail::point_hash(p.x, p.y));
  }
  std::sort(hashed.begin(), hashed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::pair<cdt::Point, cdt::Point>> pairs;
  for (std::size_t k = 1; k < hashed.size(); ++k)
    if (hashed[k].first == hashed[k - 1].first && !(hashed[k].second == hashed[k - 1].second))
      pairs.emplace_back(hashed[k - 1].second, hashed[k].second);
  return pairs;
}

// The duplicates merged on the device (gpu::DeviceSites from the input) are the host's: the same
// representative per point, the same sites and the same pieces between them, with many copies of
// points, -0 against +0, points whose hashes collide (resolved apart from the run's first point) and no
// duplicates at all; and the sites prepared from them afterwards are those of the one-step
// construction from the host's merge.
TEST_F(GpuVoronoi, DuplicatesMergeAsOnTheHost) {
  CpuExecutor executor(2);
  Rng rng(11);
  const auto pairs = colliding_pairs(rng);
  ASSERT_GE(pairs.size(), 2u) << "no colliding hashes found: the host's grouping would go untested";
  struct Case {
    std::string name;
    std::vector<cdt::Point> points;
    std::vector<cdt::Segment> segments = {};
    bool merge_read_after_prepare = false; // else right after the merge
  };
  std::vector<Case> cases;
  {
    Case c{"distinct", {}};
    for (int i = 0; i < 50000; ++i) c.points.push_back({rng.unit(), rng.unit()});
    cases.push_back(c);
  }
  {
    Case c{"small lattice, many copies", {}};
    for (int i = 0; i < 200000; ++i) c.points.push_back({double(rng.below(300)), double(rng.below(300))});
    cases.push_back(c);
  }
  {
    // Maps and pieces of more than 4 MB: copied to the host on a thread of their own.
    Case c{"large lattice, many copies", {}};
    for (int i = 0; i < 1000000; ++i) c.points.push_back({double(rng.below(1500)), double(rng.below(1500))});
    cases.push_back(c);
    c.name += ", read after prepare()";
    c.merge_read_after_prepare = true;
    cases.push_back(c);
  }
  {
    Case c{"one point copied, signed zeros", {{0.0, 0.0}, {1.0, 0.0}, {0.0, 1.0}}};
    for (int i = 0; i < 100000; ++i) c.points.push_back({0.5, 0.25});
    for (int i = 0; i < 1000; ++i) {
      c.points.push_back({-0.0, 0.0});
      c.points.push_back({0.0, -0.0});
      c.points.push_back({-0.0, -0.0});
    }
    cases.push_back(c);
  }
  {
    // Each colliding pair's points interleaved with copies, after a random start, so that either may
    // come first in its run.
    Case c{"colliding hashes", {}};
    for (int i = 0; i < 1000; ++i) c.points.push_back({rng.unit(), rng.unit()});
    for (int copy = 0; copy < 5; ++copy) {
      for (std::size_t k = 0; k < pairs.size(); ++k) {
        const bool swap = (copy + k) % 2 == 1;
        c.points.push_back(swap ? pairs[k].second : pairs[k].first);
        c.points.push_back(swap ? pairs[k].first : pairs[k].second);
        c.points.push_back(pairs[k].second);
      }
    }
    cases.push_back(c);
  }
  std::size_t pieces_seen = 0;
  for (Case& c : cases) {
    // Segments between random points, some of them repeated, reversed, from a point to itself or
    // between two copies of a point (zero length: left out).
    const auto n = static_cast<std::uint32_t>(c.points.size());
    for (std::uint32_t k = 0; k < n / 4; ++k) {
      const cdt::Segment g{rng.below(n), rng.below(n)};
      c.segments.push_back(g);
      if (k % 5 == 0) c.segments.push_back({g.b, g.a});
      if (k % 7 == 0) c.segments.push_back(g);
      if (k % 11 == 0) c.segments.push_back({g.a, g.a});
    }
    const cdt::detail::PreparedPslg host =
        cdt::detail::merge_input(c.points, c.segments, cdt::CrossingSegments::resolve, executor);
    cdt::IndexArray duplicate_of, sites;
    cdt::detail::PieceArray pieces;
    std::size_t zero_length_segments = 0;
    cdt::gpu::DeviceSites device(c.points, c.segments, cdt::CrossingSegments::resolve, duplicate_of, sites,
                                 pieces, zero_length_segments);
    // Large maps and pieces come down on a thread of their own, started by prepare() or by
    // finish_downloads().
    const auto check_merge = [&] {
      EXPECT_EQ(zero_length_segments, host.zero_length_segments) << c.name;
      EXPECT_GT(zero_length_segments, 0u) << c.name;
      EXPECT_EQ(duplicate_of, host.duplicate_of) << c.name;
      EXPECT_EQ(sites, host.sites) << c.name;
      ASSERT_EQ(pieces.size(), host.pieces.size()) << c.name;
      for (std::size_t k = 0; k < pieces.size(); ++k) {
        EXPECT_EQ(pieces[k].a, host.pieces[k].a) << c.name << " piece " << k;
        EXPECT_EQ(pieces[k].b, host.pieces[k].b) << c.name << " piece " << k;
        EXPECT_EQ(pieces[k].segment, host.pieces[k].segment) << c.name << " piece " << k;
        if (HasFailure()) return;
      }
    };
    if (!c.merge_read_after_prepare) {
      device.finish_downloads();
      check_merge();
    }
    pieces_seen += pieces.size();
    if (HasFailure()) return;

    const std::uint32_t m = 256;
    cdt::detail::GridMapping mapping, one_mapping;
    cdt::detail::Box bounds, one_bounds;
    cdt::IndexArray site_vertex, site_of_vertex, one_site_vertex, one_site_of_vertex;
    cdt::detail::FlagArray kept, one_kept;
    cdt::detail::MissingArray missing, one_missing;
    device.prepare(m, mapping, bounds, site_vertex, site_of_vertex, kept, missing);
    cdt::gpu::DeviceSites one_step(c.points, host.sites, m, one_mapping, one_bounds, one_site_vertex,
                                   one_site_of_vertex, one_kept, one_missing);
    device.finish_downloads();
    one_step.finish_downloads();
    if (c.merge_read_after_prepare) check_merge();
    if (HasFailure()) return;
    EXPECT_EQ(mapping.scale, one_mapping.scale) << c.name;
    EXPECT_EQ(site_vertex, one_site_vertex) << c.name;
    EXPECT_EQ(site_of_vertex, one_site_of_vertex) << c.name;
    EXPECT_EQ(kept, one_kept) << c.name;
    EXPECT_EQ(missing.size(), one_missing.size()) << c.name;
    EXPECT_EQ(bounds.min_x, one_bounds.min_x) << c.name;
    EXPECT_EQ(bounds.max_y, one_bounds.max_y) << c.name;
    std::vector<double> x, y, one_x, one_y;
    device.positions(x, y);
    one_step.positions(one_x, one_y);
    EXPECT_EQ(x, one_x) << c.name;
    EXPECT_EQ(y, one_y) << c.name;
  }
  EXPECT_GT(pieces_seen, 0u);
}

} // namespace
