// Phases 2 to 6 of gCD on the device against the CPU executor: the dual triangulation built from the
// colouring left on the device (DeviceVoronoi::dual, completed on the host), shifting, missing points,
// the fake boundary's removal, the segments' screen and constraints on a DeviceMesh, and Lawson flipping must
// leave the very same mesh, slot for slot and link for link, because later phases walk it in slot order
// and both executors must agree on every result.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "cdt/cdt.hpp"
#include "cdt/errors.hpp"
#include "cdt_kernels.hpp"
#include "executor/cpu_executor.hpp"
#include "gcd/constraints.hpp"
#include "gcd/dualize.hpp"
#include "gcd/flip.hpp"
#include "gcd/grid_map.hpp"
#include "gcd/insert.hpp"
#include "gcd/mesh.hpp"
#include "gcd/screen.hpp"
#include "gcd/shift.hpp"
#include "gcd/voronoi.hpp"
#include "memory.hpp"
#include "mesh_test_util.hpp"
#include "pslg.hpp"
#include "pslg_generators.hpp"

namespace {

using namespace cdt::detail;

class MeshGpu : public ::testing::Test {
protected:
  void SetUp() override {
    if (cdt::gpu::device_count() == 0) GTEST_SKIP() << "no CUDA device";
  }
};

void expect_same_mesh(const Mesh& device, const Mesh& host, const std::string& what) {
  EXPECT_EQ(device.xy, host.xy) << what;
  ASSERT_EQ(device.num_slots(), host.num_slots()) << what;
  EXPECT_EQ(device.tri, host.tri) << what;
  EXPECT_EQ(device.adj, host.adj) << what;
  EXPECT_EQ(device.seg, host.seg) << what;
  EXPECT_EQ(device.vert_tri, host.vert_tri) << what;
}

/// Points and the side of the grid to triangulate them on, named for the failure messages.
struct GridCase {
  trixel_gen::Pslg points;
  std::uint32_t m;
  const char* name;
};

/// Phase 1 and 2 inputs as triangulate() prepares them: sites on an m x m grid, kept sites moved to
/// their grid points.
struct DualInput {
  GridSites grid;
  std::uint32_t m = 0;
  std::vector<double> x, y;
  std::vector<std::uint8_t> kept;
  Box bounds;
};

DualInput dual_input(const trixel_gen::Pslg& p, std::uint32_t m, CpuExecutor& executor) {
  DualInput in;
  std::vector<double> px, py;
  for (const auto& q : p.points) {
    px.push_back(q.x);
    py.push_back(q.y);
  }
  const GridMapping mapping = make_grid_mapping(px, py, m);
  in.grid = assign_sites(mapping, px, py, executor);
  in.m = m;
  in.x = px;
  in.y = py;
  in.kept.assign(px.size(), 0);
  in.bounds = {px[0], py[0], px[0], py[0]};
  for (std::size_t s = 0; s < px.size(); ++s) {
    if (in.grid.cell_owner[static_cast<std::size_t>(in.grid.gy[s]) * m + in.grid.gx[s]] == s) {
      in.kept[s] = 1;
      in.x[s] = mapping.to_x(in.grid.gx[s]);
      in.y[s] = mapping.to_y(in.grid.gy[s]);
    }
    for (const double v : {in.x[s], px[s]}) {
      in.bounds.min_x = std::min(in.bounds.min_x, v);
      in.bounds.max_x = std::max(in.bounds.max_x, v);
    }
    for (const double v : {in.y[s], py[s]}) {
      in.bounds.min_y = std::min(in.bounds.min_y, v);
      in.bounds.max_y = std::max(in.bounds.max_y, v);
    }
  }
  return in;
}

TEST_F(MeshGpu, DualMatchesTheCpuExecutor) {
  CpuExecutor executor(4);
  const std::vector<GridCase> cases = {
      {trixel_gen::random_points(2000, trixel_gen::Distribution::uniform, 7), 128, "uniform 2000"},
      {trixel_gen::random_points(100000, trixel_gen::Distribution::uniform, 8), 1024, "uniform 100000"},
      {trixel_gen::random_points(100000, trixel_gen::Distribution::gaussian, 9), 1024, "gaussian 100000"},
      {trixel_gen::clustered(30000, 12, 10), 512, "clustered 30000"},
  };
  int compared = 0;
  for (const GridCase& c : cases) {
    DualInput in = dual_input(c.points, c.m, executor);
    std::vector<std::uint32_t> colour = compute_digital_voronoi(in.grid, in.m, executor);
    cdt::gpu::DeviceVoronoi diagram(in.grid.cell_owner, in.grid.gx, in.grid.gy, in.m);
    // Passes as triangulate() runs them: kept sites sit on grid points, so three of them can be
    // collinear at a corner; both executors must then name the same sites to take out of the diagram.
    for (int pass = 1; pass <= 8; ++pass) {
      const std::string what = std::string(c.name) + ", pass " + std::to_string(pass);
      std::vector<std::uint32_t> degenerate;
      const Mesh host = dualize(colour, in.m, in.x, in.y, in.kept, in.bounds, executor, nullptr, &degenerate);
      Mesh dual;
      dual.set_points(in.x, in.y);
      reserve_mesh_slots(dual, static_cast<std::uint32_t>(in.x.size()));
      cdt::gpu::DualStats stats;
      std::vector<std::uint32_t> culprits;
      const auto outcome = diagram.dual(dual, &stats, &culprits);
      if (host.num_slots() > 0) {
        ASSERT_EQ(outcome, cdt::gpu::DeviceVoronoi::DualOutcome::built) << what;
        EXPECT_GT(stats.dual_triangles, 0u) << what;
        const Mesh device = complete_dual(std::move(dual), in.kept, in.bounds, executor);
        expect_same_mesh(device, host, what);
        // Completed on the device, without the copy to the host: the same mesh, slot for slot.
        Mesh sites;
        sites.set_points(in.x, in.y);
        std::optional<cdt::gpu::DeviceMesh> on_device;
        std::vector<std::uint32_t> site_vert_tri;
        ASSERT_EQ(diagram.complete_dual(sites, in.bounds, on_device, site_vert_tri),
                  cdt::gpu::DeviceVoronoi::DualOutcome::built)
            << what;
        ASSERT_TRUE(on_device.has_value()) << what;
        Mesh completed;
        on_device->download(completed);
        expect_same_mesh(completed, host, what + ", completed on the device");
        ASSERT_EQ(site_vert_tri.size(), in.x.size()) << what;
        EXPECT_TRUE(std::equal(site_vert_tri.begin(), site_vert_tri.end(), host.vert_tri.begin())) << what;
        ++compared;
        break;
      }
      ASSERT_EQ(outcome, cdt::gpu::DeviceVoronoi::DualOutcome::degenerate) << what;
      ASSERT_FALSE(degenerate.empty()) << what;
      EXPECT_EQ(culprits, degenerate) << what;
      remove_sites_from_colouring(colour, in.grid, in.m, degenerate);
      // The removal on the device gives the host's colouring.
      const std::vector<std::uint32_t> owners = diagram.remove_sites(culprits);
      ASSERT_EQ(diagram.colour(), colour) << what;
      ASSERT_EQ(owners.size(), degenerate.size()) << what;
      for (std::size_t k = 0; k < owners.size(); ++k) {
        const std::uint32_t s = degenerate[k];
        EXPECT_EQ(owners[k], colour[static_cast<std::size_t>(in.grid.gy[s]) * in.m + in.grid.gx[s]]) << what;
      }
      for (const std::uint32_t s : degenerate) {
        in.kept[s] = 0;
        in.x[s] = c.points.points[s].x;
        in.y[s] = c.points.points[s].y;
      }
    }
  }
  EXPECT_EQ(compared, static_cast<int>(cases.size()));
}

// Three collinear sites meeting at one grid corner: the device must not return triangles that are not
// counter-clockwise, but name the sites to take out of the diagram as the CPU executor does.
TEST_F(MeshGpu, DualDeclinesADegenerateCorner) {
  CpuExecutor executor(1);
  trixel_gen::Pslg p;
  for (int i = 0; i < 3; ++i) p.points.push_back({static_cast<double>(i), static_cast<double>(i)});
  p.points.push_back({0, 2});
  const DualInput in = dual_input(p, 3, executor);
  const std::vector<std::uint32_t> colour = compute_digital_voronoi(in.grid, in.m, executor);
  std::vector<std::uint32_t> degenerate;
  const Mesh host = dualize(colour, in.m, in.x, in.y, in.kept, in.bounds, executor, nullptr, &degenerate);
  cdt::gpu::DeviceVoronoi diagram(in.grid.cell_owner, in.grid.gx, in.grid.gy, in.m);
  EXPECT_EQ(diagram.colour(), colour);
  Mesh dual;
  dual.set_points(in.x, in.y);
  std::vector<std::uint32_t> culprits;
  const bool accepted = diagram.dual(dual, nullptr, &culprits) == cdt::gpu::DeviceVoronoi::DualOutcome::built;
  // Whatever the CPU executor made of this diagram in one pass, the device agrees.
  EXPECT_EQ(accepted, host.num_slots() > 0);
  if (!accepted) {
    EXPECT_EQ(dual.num_slots(), 0u);
    EXPECT_EQ(culprits, degenerate);
  }
}

TEST_F(MeshGpu, FlipMatchesTheCpuExecutor) {
  struct Case {
    trixel_gen::Pslg points;
    const char* name;
  };
  const std::vector<Case> cases = {
      {trixel_gen::random_points(10, trixel_gen::Distribution::uniform, 1), "uniform 10"},
      {trixel_gen::random_points(5000, trixel_gen::Distribution::uniform, 2), "uniform 5000"},
      {trixel_gen::random_points(200000, trixel_gen::Distribution::uniform, 3), "uniform 200000"},
      {trixel_gen::random_points(50000, trixel_gen::Distribution::gaussian, 4), "gaussian 50000"},
      {trixel_gen::lattice(60), "lattice 60"}, // co-circular everywhere: only strict flips
  };
  for (const Case& c : cases) {
    std::vector<double> x, y;
    for (const auto& q : c.points.points) {
      x.push_back(q.x);
      y.push_back(q.y);
    }
    Mesh start = trixel_test::sweep_triangulate(x, y);
    // Some edges are constraints: neither executor may flip them.
    for (std::size_t e = 0; e < start.seg.size(); e += 7) {
      if (start.adj[e] == kNoId) continue;
      start.seg[e] = static_cast<std::uint32_t>(e);
      start.seg[start.adj[e]] = static_cast<std::uint32_t>(e);
    }
    Mesh host = start;
    CpuExecutor executor(4);
    const FlipStats host_stats = flip_to_delaunay(host, executor);
    Mesh device = start;
    const cdt::gpu::FlipResult device_stats = cdt::gpu::flip_to_delaunay(device);
    EXPECT_EQ(device_stats.flips, host_stats.flips) << c.name;
    EXPECT_EQ(device_stats.rounds, host_stats.rounds) << c.name;
    EXPECT_GT(device_stats.flips, 0u) << c.name << ": a sweep triangulation is not Delaunay";
    expect_same_mesh(device, host, c.name);
    trixel_test::expect_valid_mesh(device);
  }
}

} // namespace

/// A Phase 2 mesh as triangulate() leaves it (on the CPU executor), with the sites' true positions and
/// the missing points so far.
struct Phase2 {
  Mesh mesh;
  std::vector<double> true_x, true_y;
  MissingArray missing;
  std::uint32_t n = 0;
};

Phase2 phase2(const trixel_gen::Pslg& p, std::uint32_t m, CpuExecutor& executor) {
  DualInput in = dual_input(p, m, executor);
  Phase2 out;
  out.n = static_cast<std::uint32_t>(in.x.size());
  for (const auto& q : p.points) {
    out.true_x.push_back(q.x);
    out.true_y.push_back(q.y);
  }
  for (std::size_t k = 0; k < in.grid.missing.size(); ++k)
    out.missing.push_back({in.grid.missing[k], in.grid.missing_owner[k]});
  std::vector<std::uint32_t> colour = compute_digital_voronoi(in.grid, in.m, executor);
  for (int pass = 1; pass <= 8; ++pass) {
    std::vector<std::uint32_t> degenerate;
    out.mesh = dualize(colour, in.m, in.x, in.y, in.kept, in.bounds, executor, nullptr, &degenerate);
    if (out.mesh.num_slots() > 0) break;
    remove_sites_from_colouring(colour, in.grid, in.m, degenerate);
    for (const std::uint32_t s : degenerate) {
      in.kept[s] = 0;
      in.x[s] = out.true_x[s];
      in.y[s] = out.true_y[s];
      out.missing.push_back({s, out.n});
    }
  }
  for (std::uint32_t s = 0; s < out.n; ++s)
    if (in.kept[s] != 0 && out.mesh.vert_tri[s] == kNoId) out.missing.push_back({s, out.n});
  return out;
}

void expect_same_missing(const MissingArray& device, const MissingArray& host, const std::string& what) {
  ASSERT_EQ(device.size(), host.size()) << what;
  for (std::size_t k = 0; k < host.size(); ++k) {
    EXPECT_EQ(device[k].vertex, host[k].vertex) << what << ", missing point " << k;
    EXPECT_EQ(device[k].hint, host[k].hint) << what << ", missing point " << k;
  }
}

// Phase 3 (Algorithms 1 and 2) and Phase 4 (Algorithm 3, fake boundary removal) on a DeviceMesh: the
// same bad cases in the same order, the same rounds, and the same mesh after each phase; then the
// device's flips on the same mesh without a copy in between.
TEST_F(MeshGpu, ShiftAndInsertMatchTheCpuExecutor) {
  CpuExecutor executor(4);
  // Coarse grids: many points share a cell (missing points) and many shifts are bad cases.
  const std::vector<GridCase> cases = {
      {trixel_gen::random_points(2000, trixel_gen::Distribution::uniform, 17), 64, "uniform 2000"},
      {trixel_gen::random_points(100000, trixel_gen::Distribution::uniform, 18), 512, "uniform 100000"},
      {trixel_gen::random_points(60000, trixel_gen::Distribution::gaussian, 19), 256, "gaussian 60000"},
      {trixel_gen::clustered(30000, 12, 20), 256, "clustered 30000"},
      {trixel_gen::lattice(70), 64, "lattice 70"},
  };
  for (const GridCase& c : cases) {
    const Phase2 start = phase2(c.points, c.m, executor);
    ASSERT_GT(start.mesh.num_slots(), 0u) << c.name;
    Mesh host = start.mesh;
    MissingArray host_missing = start.missing;
    cdt::gpu::DeviceMesh device(start.mesh);
    MissingArray device_missing = start.missing;

    const ShiftStats host_shift =
        shift_to_true_positions(host, start.n, start.true_x, start.true_y, host_missing, executor);
    const ShiftStats device_shift = device.shift(start.n, start.true_x, start.true_y, device_missing);
    const std::string shifted = std::string(c.name) + ", after shifting";
    EXPECT_EQ(device_shift.shifted, host_shift.shifted) << shifted;
    EXPECT_EQ(device_shift.bad, host_shift.bad) << shifted;
    EXPECT_EQ(device_shift.rounds, host_shift.rounds) << shifted;
    expect_same_missing(device_missing, host_missing, shifted);
    Mesh copy;
    device.download(copy);
    expect_same_mesh(copy, host, shifted);

    const InsertStats host_insert = insert_missing_points(host, host_missing, executor);
    const FlipStats host_fans = flip_fake_fans(host, start.n, executor);
    remove_fake_boundary(host, start.n, executor);
    const InsertStats device_insert = device.insert(device_missing);
    const cdt::gpu::FlipResult device_fans = device.flip_fake_fans(start.n);
    device.remove_fake_boundary(
        start.n, [&](Mesh& fans, std::uint32_t first_fake, std::span<const std::uint32_t> ranked_as) {
          delete_fake_vertices(fans, first_fake, executor, ranked_as.data());
        });
    const std::string inserted = std::string(c.name) + ", after missing points";
    EXPECT_EQ(device_insert.inserted, host_insert.inserted) << inserted;
    EXPECT_EQ(device_insert.rounds, host_insert.rounds) << inserted;
    EXPECT_EQ(device_fans.flips, host_fans.flips) << inserted;
    EXPECT_EQ(device_fans.rounds, host_fans.rounds) << inserted;
    EXPECT_EQ(host_insert.inserted, host_missing.size()) << inserted;
    EXPECT_GT(host_missing.size(), 0u) << inserted << ": the case must exercise Algorithm 3";
    device.download(copy);
    expect_same_mesh(copy, host, inserted);
    trixel_test::expect_valid_mesh(copy);

    const FlipStats host_flips = flip_to_delaunay(host, executor);
    const cdt::gpu::FlipResult device_flips = device.flip();
    EXPECT_EQ(device_flips.flips, host_flips.flips) << c.name;
    device.download(copy);
    expect_same_mesh(copy, host, std::string(c.name) + ", after flips");
  }
}

// The sites' missing points left on the device (DeviceSites::MissingTo::device) and taken by the mesh
// (take_missing) are inserted first, then the host's list (the degenerate corners' sites, the
// unreached ones, shifting's bad cases): the same mesh, slot for slot, as with the whole list on the
// host, as triangulate() builds it.
TEST_F(MeshGpu, MissingPointsLeftOnTheDeviceComeFirst) {
  const std::vector<GridCase> cases = {
      {trixel_gen::random_points(100000, trixel_gen::Distribution::uniform, 41), 256, "uniform 100000"},
      {trixel_gen::random_points(50000, trixel_gen::Distribution::gaussian, 42), 128, "gaussian 50000"},
      {trixel_gen::lattice(90), 64, "lattice 90"},
  };
  std::size_t tails_seen = 0;
  for (const GridCase& c : cases) {
    const auto run = [&](cdt::gpu::DeviceSites::MissingTo to, std::size_t& on_device, std::size_t& tail) {
      cdt::IndexArray duplicate_of, sites, site_vertex, site_of_vertex;
      PieceArray pieces;
      std::size_t zero_length = 0;
      cdt::gpu::DeviceSites device_sites(c.points.points, {}, cdt::CrossingSegments::resolve, duplicate_of,
                                         sites, pieces, zero_length);
      GridMapping mapping;
      Box bounds;
      FlagArray kept;
      MissingArray missing;
      device_sites.prepare(c.m, mapping, bounds, site_vertex, site_of_vertex, kept, missing, {}, to);
      on_device = device_sites.missing_on_device();
      const auto n = static_cast<std::uint32_t>(sites.size());
      cdt::gpu::DeviceVoronoi diagram(device_sites);
      std::optional<cdt::gpu::DeviceMesh> mesh;
      std::vector<std::uint32_t> unreached, degenerate;
      for (int pass = 0; pass < 8; ++pass) {
        degenerate.clear();
        const auto outcome = diagram.complete_dual(device_sites, bounds, mesh, unreached, &degenerate);
        if (outcome == cdt::gpu::DeviceVoronoi::DualOutcome::built) break;
        EXPECT_EQ(outcome, cdt::gpu::DeviceVoronoi::DualOutcome::degenerate) << c.name;
        if (outcome != cdt::gpu::DeviceVoronoi::DualOutcome::degenerate) return Mesh{};
        const std::vector<std::uint32_t> owners = diagram.remove_sites(degenerate);
        device_sites.leave_out(degenerate);
        for (std::size_t k = 0; k < degenerate.size(); ++k) {
          kept[degenerate[k]] = 0;
          const std::uint32_t owner = owners[k];
          missing.push_back({degenerate[k], owner != cdt::kNone && kept[owner] != 0 ? owner : n});
        }
      }
      EXPECT_TRUE(mesh.has_value()) << c.name;
      if (!mesh) return Mesh{};
      for (const std::uint32_t s : unreached) missing.push_back({s, n});
      mesh->shift(n, device_sites, missing);
      mesh->take_missing(device_sites);
      EXPECT_EQ(device_sites.missing_on_device(), 0u) << c.name << ": taken";
      tail = missing.size();
      mesh->insert(missing);
      Mesh out;
      mesh->download(out);
      return out;
    };
    std::size_t on_device = 0, none = 0, tail = 0, whole = 0;
    const Mesh first = run(cdt::gpu::DeviceSites::MissingTo::device, on_device, tail);
    const Mesh all_on_host = run(cdt::gpu::DeviceSites::MissingTo::host, none, whole);
    if (HasFailure()) return;
    EXPECT_EQ(none, 0u) << c.name;
    EXPECT_GT(on_device, 0u) << c.name << ": the case must leave missing points on the device";
    EXPECT_EQ(on_device + tail, whole) << c.name;
    tails_seen += tail;
    expect_same_mesh(first, all_on_host, c.name);
    trixel_test::expect_valid_mesh(first);
  }
  EXPECT_GT(tails_seen, 0u) << "no point followed the device's list: the order went untested";
}

// Step 2 (Algorithms 4 and 5) on a DeviceMesh: the paper's synthetic segments inserted into a
// triangulation of their endpoints and the free points, by the same flips as the CPU executor.
/// A sweep triangulation of the PSLG's points, flipped to Delaunay when asked.
Mesh sweep_mesh(const trixel_gen::Pslg& p, bool delaunay, CpuExecutor& executor) {
  std::vector<double> x, y;
  for (const auto& q : p.points) {
    x.push_back(q.x);
    y.push_back(q.y);
  }
  Mesh mesh = trixel_test::sweep_triangulate(x, y);
  if (delaunay) flip_to_delaunay(mesh, executor);
  return mesh;
}

TEST_F(MeshGpu, ConstraintsMatchTheCpuExecutor) {
  struct Case {
    trixel_gen::Pslg pslg;
    bool delaunay; ///< start from the Delaunay triangulation (as triangulate() does) or a sweep's
    const char* name;
  };
  const std::vector<Case> cases = {
      {trixel_gen::synthetic_pslg(3000, 300, trixel_gen::Distribution::uniform, 31), true, "uniform 3000"},
      {trixel_gen::synthetic_pslg(60000, 6000, trixel_gen::Distribution::uniform, 32), true, "uniform 60000"},
      {trixel_gen::synthetic_pslg(60000, 6000, trixel_gen::Distribution::gaussian, 33), true,
       "gaussian 60000"},
      // Long thin sweep triangles: every piece crosses many of them.
      {trixel_gen::synthetic_pslg(20000, 2000, trixel_gen::Distribution::uniform, 34), false, "sweep 20000"},
  };
  CpuExecutor executor(4);
  for (const Case& c : cases) {
    const Mesh start = sweep_mesh(c.pslg, c.delaunay, executor);
    std::vector<ConstraintPiece2> pieces;
    for (std::size_t k = 0; k < c.pslg.segments.size(); ++k)
      pieces.push_back({c.pslg.segments[k].a, c.pslg.segments[k].b, static_cast<std::uint32_t>(k)});
    Mesh host = start;
    const ConstraintStats host_stats = insert_constraints(host, pieces, 8, executor);
    cdt::gpu::DeviceMesh device(start);
    const ConstraintStats device_stats = device.insert_constraints(pieces, 8);
    EXPECT_GT(host_stats.flips, 0u) << c.name;
    EXPECT_EQ(device_stats.flips, host_stats.flips) << c.name;
    EXPECT_EQ(device_stats.outer_iterations, host_stats.outer_iterations) << c.name;
    EXPECT_EQ(device_stats.inner_iterations, host_stats.inner_iterations) << c.name;
    EXPECT_EQ(device_stats.intersections, host_stats.intersections) << c.name;
    Mesh copy;
    device.download(copy);
    expect_same_mesh(copy, host, c.name);
    trixel_test::expect_valid_mesh(copy);
  }
}

// Constraints started beside the host (start_constraints), on a copy of the mesh while the mesh itself is
// screened: kept, the copy is insert_constraints' result flip for flip and the Lawson flips after them
// find the same; stopped, or failed (crossing pieces), the mesh is the one they started from and takes
// the pieces again. Nothing but the screen may use the mesh meanwhile.
TEST_F(MeshGpu, ConstraintsBesideTheHostKeepOrUndo) {
  CpuExecutor executor(4);
  const trixel_gen::Pslg pslg =
      trixel_gen::synthetic_pslg(60000, 6000, trixel_gen::Distribution::uniform, 35);
  const Mesh start = sweep_mesh(pslg, true, executor);
  std::vector<ConstraintPiece2> pieces;
  for (std::size_t k = 0; k < pslg.segments.size(); ++k)
    pieces.push_back({pslg.segments[k].a, pslg.segments[k].b, static_cast<std::uint32_t>(k)});

  cdt::gpu::DeviceMesh plain(start);
  const ScreenedPieces plain_screen = plain.screen(pieces); // no suspects: the pieces cross nothing
  ASSERT_TRUE(plain_screen.complete);
  EXPECT_FALSE(plain_screen.changes);
  const ConstraintStats plain_stats = plain.insert_constraints(pieces, 8);
  const cdt::gpu::FlipResult plain_flips = plain.flip_after_constraints();
  Mesh expected;
  plain.download(expected);
  ASSERT_GT(plain_stats.flips, 0u);

  cdt::gpu::DeviceMesh kept(start);
  EXPECT_FALSE(kept.start_constraints({}, 8)); // nothing to insert
  ASSERT_TRUE(kept.start_constraints(pieces, 8));
  EXPECT_THROW(kept.start_constraints(pieces, 8), cdt::Error); // one run at a time
  const ScreenedPieces screened = kept.screen(pieces);         // the mesh as it was
  EXPECT_TRUE(screened.complete);
  EXPECT_EQ(screened.pieces, plain_screen.pieces);
  EXPECT_EQ(screened.sites, plain_screen.sites);
  EXPECT_THROW(kept.insert_constraints(pieces, 8), cdt::Error);
  EXPECT_THROW(kept.flip(), cdt::Error);
  const std::optional<ConstraintStats> kept_stats = kept.finish_constraints(true);
  ASSERT_TRUE(kept_stats.has_value());
  EXPECT_EQ(kept_stats->flips, plain_stats.flips);
  EXPECT_EQ(kept_stats->outer_iterations, plain_stats.outer_iterations);
  EXPECT_EQ(kept_stats->inner_iterations, plain_stats.inner_iterations);
  EXPECT_EQ(kept_stats->intersections, plain_stats.intersections);
  EXPECT_EQ(kept.flip_after_constraints().flips, plain_flips.flips);
  Mesh copy;
  kept.download(copy);
  expect_same_mesh(copy, expected, "kept");
  EXPECT_THROW(kept.finish_constraints(true), cdt::Error); // nothing runs

  // Stopped at once, and after the run is done (the host's split is longer than the run).
  for (const bool after_the_run : {false, true}) {
    const std::string what = after_the_run ? "stopped after the run" : "stopped at once";
    cdt::gpu::DeviceMesh undone(start);
    ASSERT_TRUE(undone.start_constraints(pieces, 8)) << what;
    if (after_the_run) std::this_thread::sleep_for(std::chrono::milliseconds(200)); // done by then, or not
    EXPECT_FALSE(undone.finish_constraints(false).has_value()) << what;
    undone.download(copy);
    expect_same_mesh(copy, start, what);
    EXPECT_EQ(undone.insert_constraints(pieces, 8).flips, plain_stats.flips) << what;
    EXPECT_EQ(undone.flip_after_constraints().flips, plain_flips.flips) << what;
    undone.download(copy);
    expect_same_mesh(copy, expected, what + ", then inserted");
  }

  // The diagonals of a square, crossing: the run fails, and asked to keep it the mesh is as it started.
  const std::vector<double> x = {0, 2, 2, 0, 1}, y = {0, 0, 2, 2, 3};
  const Mesh small = trixel_test::sweep_triangulate(x, y);
  const std::vector<ConstraintPiece2> crossing = {{0, 2, 0}, {1, 3, 1}};
  cdt::gpu::DeviceMesh failing(small);
  ASSERT_TRUE(failing.start_constraints(crossing, 8));
  EXPECT_FALSE(failing.finish_constraints(true).has_value());
  failing.download(copy);
  expect_same_mesh(copy, small, "failed run");
  EXPECT_THROW(failing.insert_constraints(crossing, 8), cdt::Error);

  // Long pieces across the others: the screen beside the run finds the suspects the plain screen finds,
  // and the run, which meets crossing pieces, fails and leaves the mesh as it was.
  trixel_gen::Pslg crossed = pslg;
  trixel_gen::Random rng(36);
  trixel_gen::add_random_segments(crossed, 10, rng);
  std::vector<ConstraintPiece2> crossed_pieces;
  for (std::size_t k = 0; k < crossed.segments.size(); ++k)
    crossed_pieces.push_back({crossed.segments[k].a, crossed.segments[k].b, static_cast<std::uint32_t>(k)});
  const ScreenedPieces crossed_screen = cdt::gpu::DeviceMesh(start).screen(crossed_pieces);
  ASSERT_TRUE(crossed_screen.complete);
  ASSERT_FALSE(crossed_screen.pieces.empty());
  cdt::gpu::DeviceMesh beside_crossers(start);
  ASSERT_TRUE(beside_crossers.start_constraints(crossed_pieces, 8));
  const ScreenedPieces screened_beside = beside_crossers.screen(crossed_pieces);
  EXPECT_EQ(screened_beside.pieces, crossed_screen.pieces);
  EXPECT_EQ(screened_beside.sites, crossed_screen.sites);
  EXPECT_FALSE(beside_crossers.finish_constraints(true).has_value());
  beside_crossers.download(copy);
  expect_same_mesh(copy, start, "crossers");

  // A mesh destroyed while its constraints run stops and joins them.
  {
    cdt::gpu::DeviceMesh dropped(start);
    ASSERT_TRUE(dropped.start_constraints(pieces, 8));
  }
}

/// An output's rows (DeviceMesh::output) in an order of their own: each from its lowest corner, with per
/// edge the far corner of the neighbour across it (kNoId on the hull) and its segment, sorted; the same
/// for two outputs of one triangulation whatever their rows' order.
std::vector<std::array<std::uint32_t, 9>> output_rows(const cdt::TriangleArray& triangles,
                                                      const cdt::TriangleArray& neighbors,
                                                      const cdt::TriangleArray& segments) {
  std::vector<std::array<std::uint32_t, 9>> out;
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const auto& c = triangles[t];
    const std::size_t r = std::min_element(c.begin(), c.end()) - c.begin();
    std::array<std::uint32_t, 9> row{};
    for (std::size_t j = 0; j < 3; ++j) {
      const std::size_t i = (r + j) % 3;
      row[j] = c[i];
      const std::uint32_t n = neighbors[t][i];
      row[3 + j] = kNoId;
      if (n != kNoId)
        for (const std::uint32_t v : triangles[n])
          if (v != c[(i + 1) % 3] && v != c[(i + 2) % 3]) row[3 + j] = v;
      row[6 + j] = segments[t][i];
    }
    out.push_back(row);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The output started early (start_early_output, into pinned result memory): the rows away from the
// screened corridors go while the constraints run, the rest at output(). Screened with every piece,
// almost nothing is sent twice; screened with a few pieces left out, the rows their constraints changed are
// sent again as records; with half left out, so many that every early row is sent again. Each output
// is the one made without starting early.
TEST_F(MeshGpu, OutputStartedEarlyIsTheOutputMadeAtTheEnd) {
  CpuExecutor executor(8);
  const trixel_gen::Pslg pslg =
      trixel_gen::synthetic_pslg(800000, 40000, trixel_gen::Distribution::uniform, 38);
  const Mesh start = sweep_mesh(pslg, true, executor);
  ASSERT_GE(3 * sizeof(std::uint32_t) * start.num_slots(), cdt::detail::kPinnedArrayBytes);
  std::vector<ConstraintPiece2> pieces;
  for (std::size_t k = 0; k < pslg.segments.size(); ++k)
    pieces.push_back({pslg.segments[k].a, pslg.segments[k].b, static_cast<std::uint32_t>(k)});
  std::vector<std::uint32_t> vertex_of(start.num_vertices()), segment_of_piece(pieces.size());
  for (std::size_t v = 0; v < vertex_of.size(); ++v) vertex_of[v] = static_cast<std::uint32_t>(v);
  for (std::size_t k = 0; k < pieces.size(); ++k) segment_of_piece[k] = static_cast<std::uint32_t>(k);

  cdt::Triangulation plain;
  {
    cdt::gpu::DeviceMesh device(start);
    device.insert_constraints(pieces, 8);
    device.flip_after_constraints();
    device.output(vertex_of, segment_of_piece, plain.triangles, plain.neighbors, plain.segment_of_edge);
  }
  const auto expected = output_rows(plain.triangles, plain.neighbors, plain.segment_of_edge);

  // The pieces longest first: the eight left out cross many triangles.
  std::vector<ConstraintPiece2> longest = pieces;
  const auto length = [&](const ConstraintPiece2& p) {
    const Vec2 a = start.xy[p.a], b = start.xy[p.b];
    return std::hypot(a.x - b.x, a.y - b.y);
  };
  std::sort(longest.begin(), longest.end(),
            [&](const ConstraintPiece2& p, const ConstraintPiece2& q) { return length(p) > length(q); });
  std::vector<ConstraintPiece2> every_other;
  for (std::size_t k = 0; k < pieces.size(); k += 2) every_other.push_back(pieces[k]);
  ASSERT_TRUE(cdt::keep_pinned_results(std::size_t{512} << 20));
  struct Case {
    std::span<const ConstraintPiece2> screened; ///< the pieces the screen sees
    const char* name;
  };
  for (const Case c : {Case{pieces, "every piece screened"},
                       Case{std::span<const ConstraintPiece2>(longest).subspan(8), "8 left out"},
                       Case{every_other, "half left out"}}) {
    cdt::Triangulation t;
    {
      const cdt::detail::PinnedResultScope scope;
      t.triangles.reserve(start.num_slots());
      t.neighbors.reserve(start.num_slots());
      t.segment_of_edge.reserve(start.num_slots());
    }
    cdt::gpu::DeviceMesh device(start);
    const bool every = c.screened.size() == pieces.size();
    if (every) { // as triangulate() does
      ASSERT_TRUE(device.start_constraints(pieces, 8)) << c.name;
    }
    ASSERT_TRUE(device.screen(c.screened).complete) << c.name;
    const cdt::gpu::EarlyOutputRows before = cdt::gpu::early_output_rows();
    ASSERT_TRUE(device.start_early_output(vertex_of, t.triangles, t.neighbors)) << c.name;
    if (every) {
      ASSERT_TRUE(device.finish_constraints(true).has_value()) << c.name;
    } else {
      device.insert_constraints(pieces, 8);
    }
    device.flip_after_constraints();
    device.output(vertex_of, segment_of_piece, t.triangles, t.neighbors, t.segment_of_edge);
    const cdt::gpu::EarlyOutputRows after = cdt::gpu::early_output_rows();
    const std::uint64_t sent = after.sent - before.sent, again = after.again - before.again;
    EXPECT_GT(sent, t.triangles.size() / 2) << c.name;
    if (every) {
      EXPECT_LT(again, sent / 100) << c.name;
    } else if (c.screened.size() + 8 == pieces.size()) {
      EXPECT_GT(again, 0u) << c.name;
      EXPECT_LE(again, sent / 32) << c.name; // as records
    } else {
      EXPECT_EQ(again, sent) << c.name; // every early row
    }
    EXPECT_TRUE(output_rows(t.triangles, t.neighbors, t.segment_of_edge) == expected) << c.name;
  }
  ASSERT_TRUE(cdt::keep_pinned_results(0));
}

/// A mesh's live triangles with their constraint ids, each from its lowest vertex, sorted: the same for
/// two meshes that hold the same triangulation in other slots.
std::vector<std::array<std::uint32_t, 6>> triangle_set(const Mesh& mesh) {
  std::vector<std::array<std::uint32_t, 6>> out;
  for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
    if (mesh.tri[3 * t] == kNoId) continue;
    std::uint32_t r = 0;
    for (std::uint32_t i = 1; i < 3; ++i)
      if (mesh.tri[3 * t + i] < mesh.tri[3 * t + r]) r = i;
    std::array<std::uint32_t, 6> row{};
    for (std::uint32_t i = 0; i < 3; ++i) {
      row[i] = mesh.tri[3 * t + (r + i) % 3];
      row[3 + i] = mesh.seg[3 * t + (r + i) % 3];
    }
    out.push_back(row);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The constraints beside the split without the suspects: where the screen sees that the split will
// change the pieces (a piece through a vertex), the run beside it starts again without the screen's
// suspects; its ids are renumbered as a split moves the pieces; the suspects' pieces then go into the
// constrained mesh, and the Lawson flips after them check the slots of both runs. The result is the
// triangulation of every final piece inserted at once.
TEST_F(MeshGpu, ConstraintsBesideTheSplitWithoutTheSuspects) {
  CpuExecutor executor(4);
  trixel_gen::Pslg pslg = trixel_gen::synthetic_pslg(60000, 6000, trixel_gen::Distribution::uniform, 37);
  // Three points on a short horizontal line, exactly: the piece from the first to the third runs
  // through the second.
  const auto p1 = static_cast<std::uint32_t>(pslg.points.size());
  pslg.points.push_back({0.5, 0.4375});
  pslg.points.push_back({0.5 + 0x1p-20, 0.4375});
  pslg.points.push_back({0.5 + 0x1p-19, 0.4375});
  const Mesh start = sweep_mesh(pslg, true, executor);
  std::vector<ConstraintPiece2> pieces;
  for (std::size_t k = 0; k < pslg.segments.size(); ++k)
    pieces.push_back({pslg.segments[k].a, pslg.segments[k].b, static_cast<std::uint32_t>(k)});
  const auto m = static_cast<std::uint32_t>(pieces.size());
  pieces.push_back({p1, p1 + 2, m}); // through p1 + 1

  // A vertex added between the runs (as a crossing's would be), in a free spot: its slots are new.
  const double extra_x = 0.3125, extra_y = 0.6875;
  const auto extra = static_cast<std::uint32_t>(start.xy.size());

  cdt::gpu::DeviceMesh device(start);
  EXPECT_THROW(device.restart_constraints({}, 8), cdt::Error); // nothing ran
  ASSERT_TRUE(device.start_constraints(pieces, 8));
  const ScreenedPieces screen = device.screen(pieces);
  ASSERT_TRUE(screen.complete);
  EXPECT_TRUE(screen.changes);
  ASSERT_TRUE(std::binary_search(screen.pieces.begin(), screen.pieces.end(), m));
  ASSERT_TRUE(device.restart_constraints(screen.pieces, 8));
  const std::optional<ConstraintStats> before = device.finish_constraints(true);
  ASSERT_TRUE(before.has_value());
  EXPECT_GT(before->flips, 0u);
  // The split as it would be: the piece through the vertex leaves, its halves come first and last.
  const std::vector<PieceRun> runs = {{0, 1, m}};
  device.renumber_constraints(runs);
  device.check_constraints_unsplit(p1 + 1); // no constraint ends there yet
  device.add_vertices(std::vector<double>{extra_x}, std::vector<double>{extra_y});
  const std::vector<MissingPoint> fresh = {{extra, 0}};
  device.insert(fresh);
  device.flip_after_insert();
  device.check_constraints_unsplit(extra); // in no constraint
  std::vector<ConstraintPiece2> final_pieces = {{p1, p1 + 1, 0}};
  for (std::uint32_t k = 0; k < m; ++k) final_pieces.push_back({pieces[k].a, pieces[k].b, k + 1});
  final_pieces.push_back({p1 + 1, p1 + 2, m + 1});
  std::vector<ConstraintPiece2> rest = {final_pieces.front(), final_pieces.back()};
  for (const std::uint32_t k : screen.pieces)
    if (k != m) rest.push_back(final_pieces[k + 1]);
  device.insert_constraints(rest, 8, {}, true);
  device.flip_after_constraints();
  EXPECT_THROW(device.check_constraints_unsplit(p1 + 1), cdt::Error); // now both halves end there
  Mesh got;
  device.download(got);

  trixel_gen::Pslg with_extra = pslg;
  with_extra.points.push_back({extra_x, extra_y});
  cdt::gpu::DeviceMesh plain(sweep_mesh(with_extra, true, executor));
  plain.insert_constraints(final_pieces, 8);
  plain.flip_after_constraints();
  Mesh expected;
  plain.download(expected);
  EXPECT_EQ(triangle_set(got), triangle_set(expected));

  // A vertex inside a constraint already in the mesh splits it: refused.
  plain.add_vertices(std::vector<double>{0.5 + 0x1p-21}, std::vector<double>{0.4375}); // halfway p1, p1 + 1
  const std::vector<MissingPoint> inside = {{extra + 1, p1}};
  plain.insert(inside);
  EXPECT_THROW(plain.check_constraints_unsplit(extra + 1), cdt::Error);
  std::size_t constrained = 0;
  for (const std::uint32_t id : got.seg) constrained += id != kNoId ? 1 : 0;
  EXPECT_GE(constrained, 2 * final_pieces.size() - 8); // every piece (but a few on the hull) twice

  // An id in no run is an error.
  EXPECT_THROW(device.renumber_constraints(std::vector<PieceRun>{{0, 0, 5}}), cdt::Error);
}

/// A 24 x 24 lattice with fans of short pieces (screen.hpp's crowds): from (0, 0) to the vertices it
/// sees, more than kCrowdLimit; from (0, 12), three that meet nothing; from (12, 0), four that a piece
/// from (13, 0) to (12, 1) crosses; from (23, 0), two with a far piece.
trixel_gen::Pslg crowded_fans() {
  trixel_gen::Pslg p;
  constexpr std::uint32_t side = 24;
  for (std::uint32_t j = 0; j < side; ++j)
    for (std::uint32_t i = 0; i < side; ++i)
      p.points.push_back({static_cast<double>(i), static_cast<double>(j)});
  const auto at = [](std::uint32_t i, std::uint32_t j) { return j * side + i; };
  for (std::uint32_t i = 2; i < 12; ++i)
    for (std::uint32_t j = 1; j < i; ++j)
      if (std::gcd(i, j) == 1) p.segments.push_back({at(0, 0), at(i, j)});
  for (std::uint32_t i = 2; i < 5; ++i) p.segments.push_back({at(0, 12), at(i, 13)});
  for (std::uint32_t i = 2; i < 6; ++i) p.segments.push_back({at(12, 0), at(12 + i, 1)});
  for (std::uint32_t i = 2; i < 4; ++i) p.segments.push_back({at(23, 0), at(23 - i, 1)});
  p.segments.push_back({at(23, 0), at(0, 1)}); // far: longer than 24 * sqrt(23 * 23 / 576) = 23
  p.segments.push_back({at(13, 0), at(12, 1)});
  return p;
}

// The segments' screen (gcd/screen.hpp) on the device: the same suspect pieces and sites as the CPU
// executor's, on Delaunay meshes with non-crossing segments plus long ones that cross them and pass
// through vertices, on a lattice where segments overlap and run through points, and on crowds.
TEST_F(MeshGpu, ScreenMatchesTheCpuExecutor) {
  struct Case {
    trixel_gen::Pslg pslg;
    std::size_t crossers; ///< random long pieces added between random vertices
    const char* name;
  };
  const std::vector<Case> cases = {
      {trixel_gen::synthetic_pslg(3000, 300, trixel_gen::Distribution::uniform, 41), 10, "uniform 3000"},
      {trixel_gen::synthetic_pslg(60000, 6000, trixel_gen::Distribution::gaussian, 42), 40, "gaussian 60000"},
      {trixel_gen::lattice_with_segments(64, 300, 43), 0, "lattice 64"},
      {crowded_fans(), 0, "crowded fans"},
  };
  CpuExecutor executor(4);
  for (const Case& c : cases) {
    Mesh mesh = sweep_mesh(c.pslg, true, executor);
    const auto n = static_cast<std::uint32_t>(mesh.num_vertices());
    // Distinct vertex pairs, as the screen's input is.
    std::set<std::pair<std::uint32_t, std::uint32_t>> pairs;
    for (const cdt::Segment& sg : c.pslg.segments)
      if (sg.a != sg.b) pairs.insert({std::min(sg.a, sg.b), std::max(sg.a, sg.b)});
    trixel_gen::Random rng(c.crossers + 1);
    for (std::size_t k = 0; k < c.crossers; ++k) {
      const auto a = static_cast<std::uint32_t>(rng.next() % n),
                 b = static_cast<std::uint32_t>(rng.next() % n);
      if (a != b) pairs.insert({std::min(a, b), std::max(a, b)});
    }
    std::vector<ConstraintPiece2> pieces;
    for (const auto& [a, b] : pairs) pieces.push_back({a, b, 0});
    const ScreenedPieces host = screen_pieces(mesh.view(), pieces, executor);
    cdt::gpu::DeviceMesh device(mesh);
    const ScreenedPieces on_device = device.screen(pieces);
    ASSERT_TRUE(host.complete) << c.name;
    EXPECT_TRUE(on_device.complete) << c.name;
    EXPECT_FALSE(host.pieces.empty()) << c.name;
    EXPECT_LT(host.pieces.size(), pieces.size()) << c.name;
    EXPECT_EQ(on_device.pieces, host.pieces) << c.name;
    EXPECT_EQ(on_device.sites, host.sites) << c.name;
    EXPECT_TRUE(host.changes) << c.name; // long pieces across others, pieces through points
    EXPECT_EQ(on_device.changes, host.changes) << c.name;
  }
  // An end outside the mesh: the walk fails on both.
  Mesh mesh = trixel_test::sweep_triangulate({0, 1, 0, 5}, {0, 0, 1, 5});
  mesh.vert_tri[3] = kNoId;
  const std::vector<ConstraintPiece2> pieces{{0, 3, 0}};
  EXPECT_FALSE(screen_pieces(mesh.view(), pieces, executor).complete);
  cdt::gpu::DeviceMesh device(mesh);
  EXPECT_FALSE(device.screen(pieces).complete);
}

// A piece through a vertex breaks the precondition: the device reports it as the CPU executor does.
TEST_F(MeshGpu, ConstraintsReportAVertexOnAPiece) {
  const std::vector<double> x = {0, 1, 2, 1, 1}, y = {0, 0, 0, 1, -1};
  Mesh start = trixel_test::sweep_triangulate(x, y);
  const std::vector<ConstraintPiece2> pieces = {{0, 2, 0}};
  Mesh host = start;
  CpuExecutor executor(1);
  std::string host_error, device_error;
  try {
    insert_constraints(host, pieces, 8, executor);
  } catch (const cdt::Error& e) {
    host_error = e.what();
  }
  cdt::gpu::DeviceMesh device(start);
  try {
    device.insert_constraints(pieces, 8);
  } catch (const cdt::Error& e) {
    device_error = e.what();
  }
  EXPECT_FALSE(host_error.empty());
  EXPECT_EQ(device_error, host_error);
}

// Bad missing-point lists break Algorithm 3's precondition: the device names the same point with the
// same message as the CPU executor.
TEST_F(MeshGpu, InsertReportsBadMissingPointsAsTheCpuExecutor) {
  const std::vector<double> x = {0, 4, 0, 4}, y = {0, 0, 4, 4};
  Mesh start = trixel_test::sweep_triangulate(x, y);
  start.xy.push_back({1, 1}); // vertex 4, not in the mesh yet
  start.vert_tri.push_back(kNoId);
  const std::vector<MissingArray> lists = {
      {{4, 0}, {4, 0}}, // listed twice
      {{4, 0}, {9, 0}}, // out of range
      {{9, 0}, {4, 0}, {4, 0}},
      {{1, 0}}, // already in the mesh
  };
  CpuExecutor executor(1);
  for (std::size_t k = 0; k < lists.size(); ++k) {
    std::string host_error, device_error;
    Mesh host = start;
    try {
      insert_missing_points(host, lists[k], executor);
    } catch (const cdt::Error& e) {
      host_error = e.what();
    }
    cdt::gpu::DeviceMesh device(start);
    try {
      device.insert(lists[k]);
    } catch (const cdt::Error& e) {
      device_error = e.what();
    }
    EXPECT_FALSE(host_error.empty()) << "list " << k;
    EXPECT_EQ(device_error, host_error) << "list " << k;
  }
}
