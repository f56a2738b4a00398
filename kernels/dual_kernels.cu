// Phase 2 of gCD on the CUDA executor (paper section 3.2): the triangles dual to the digital Voronoi
// diagram, straight from the colouring Phase 1 left on the device, in the CPU executor's slot order and
// linked. The per-corner work is cdt/src/gcd/dualize.hpp's corner_triangles, the same function the CPU
// executor runs. Steps:
//   1. per grid corner, its number of triangles (or a degenerate corner, which stops here);
//   2. a prefix sum gives each corner its first slot; the triangles are written there, which is the
//      CPU executor's row-major order, then stably sorted by their lowest vertex (its counting sort);
//   3. links: every directed edge keyed by its two vertices, sorted, equal neighbours paired;
//   4. vert_tri: the highest incident slot (atomicMax), which is the CPU executor's last write.
// Hull completion and the fake boundary touch only the dual's boundary, a few thousand edges: the host
// plans them from the open edges alone (cdt::detail::plan_dual_completion), and complete_dual applies
// the plan on the device, so the mesh never leaves it (dual() copies the linked dual to the host for
// the CPU executor's complete_dual instead).

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cdt/detail/trace.hpp"
#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"
#include "device_mesh.cuh"
#include "device_sites.cuh"
#include "device_voronoi.cuh"
#include "gcd/dualize.hpp"

namespace cdt::gpu {
namespace detail {

using ::cdt::detail::DualTriangle;
using ::cdt::detail::edge_id;
using ::cdt::detail::edge_index;
using ::cdt::detail::edge_tri;
using ::cdt::detail::kNoId;
using ::cdt::detail::next3;
using ::cdt::detail::prev3;

/// Bits needed to hold every value below `limit`.
int bits_below(std::uint64_t limit) {
  int bits = 1;
  while (bits < 64 && (std::uint64_t{1} << bits) < limit) ++bits;
  return bits;
}

/// dst[0, n) = src[0, n) on the device, queued on the executor's stream.
template <class T>
void copy_on_device(CudaExecutor& executor, T* dst, const T* src, std::size_t n, const char* name) {
  executor.for_each(
      n, [=] __device__(std::size_t k) { dst[k] = src[k]; }, name);
}

/// Device memory of the dual and its links for n sites, in bytes (about 2n triangles; the sorts'
/// second buffers included).
std::size_t dual_device_bytes(std::size_t n) {
  const std::size_t slots = 2 * n + 64;
  // Sites' coordinates, unsorted and sorted triangles, keys and indices with their second buffers,
  // directed edges' 64-bit keys and ids with their second buffers, links, vert_tri, the unreached sites.
  return 16 * n + 24 * slots + 16 * slots + 3 * slots * 24 + 12 * slots + 8 * n + (std::size_t{1} << 20);
}

struct DualBuffers {
  DeviceBuffer<std::uint32_t> unsorted; ///< triangles in corner order
  DeviceBuffer<std::uint32_t> tri;      ///< triangles in slot order
  DeviceBuffer<std::uint32_t> key, index;
  DeviceBuffer<unsigned long long> edge_key;
  DeviceBuffer<std::uint32_t> edge;
  DeviceBuffer<std::uint32_t> adj;
  DeviceBuffer<std::uint32_t> vert_tri;
};

/// Links the num_slots triangles of d_tri (all live) over n vertices: d_adj and d_vert_tri as
/// cdt::detail::link_triangles leaves them. Returns false when an edge is shared by more than two
/// triangles or twice in the same direction.
bool link_on_device(CudaExecutor& executor, DualBuffers& b, std::uint32_t num_slots, std::uint32_t n) {
  const std::size_t num_edges = 3 * static_cast<std::size_t>(num_slots);
  b.edge_key.resize(num_edges);
  b.edge.resize(num_edges);
  b.adj.resize(num_edges);
  b.vert_tri.resize(n);
  const std::uint32_t* tri = b.tri.data();
  unsigned long long* key = b.edge_key.data();
  std::uint32_t* edge = b.edge.data();
  const unsigned long long nv = n;
  executor.for_each(
      num_edges,
      [=] __device__(std::size_t e) {
        const std::size_t t = e / 3;
        const auto i = static_cast<std::uint32_t>(e % 3);
        const std::uint32_t from = tri[3 * t + next3(i)], to = tri[3 * t + prev3(i)];
        const unsigned long long lo = from < to ? from : to, hi = from < to ? to : from;
        key[e] = lo * nv + hi;
        edge[e] = static_cast<std::uint32_t>(e);
      },
      "edge_keys");
  executor.sort_pairs(key, edge, num_edges, bits_below(nv * nv));
  std::uint32_t* adj = b.adj.data();
  executor.fill_bytes(adj, 0xFF, num_edges);
  auto* d_bad = executor.scalar<std::uint32_t>();
  executor.fill_bytes(d_bad, 0, 1);
  executor.for_each(
      num_edges,
      [=] __device__(std::size_t k) {
        if (k > 0 && key[k - 1] == key[k]) return;
        if (k + 1 >= num_edges || key[k + 1] != key[k]) return; // a boundary edge
        if (k + 2 < num_edges && key[k + 2] == key[k]) {
          atomicOr(d_bad, 1u);
          return;
        }
        const std::uint32_t e0 = edge[k], e1 = edge[k + 1];
        if (tri[3 * edge_tri(e0) + next3(edge_index(e0))] == tri[3 * edge_tri(e1) + next3(edge_index(e1))]) {
          atomicOr(d_bad, 2u);
          return;
        }
        adj[e0] = e1;
        adj[e1] = e0;
      },
      "pair_edges");
  std::uint32_t* vert_tri = b.vert_tri.data();
  executor.fill_bytes(vert_tri, 0, n);
  executor.for_each(
      num_slots,
      [=] __device__(std::size_t t) {
        for (std::uint32_t i = 0; i < 3; ++i)
          atomicMax(vert_tri + tri[3 * t + i], static_cast<std::uint32_t>(t + 1));
      },
      "incident_slots");
  // 0 (no incident slot) becomes kNoId, every other entry the slot itself.
  executor.for_each(
      n, [=] __device__(std::size_t v) { vert_tri[v] -= 1; }, "incident_slots_shift");
  std::uint32_t bad = 0;
  executor.download(&bad, d_bad, 1);
  return bad == 0;
}

/// A degenerate corner's four colours and their positions.
struct CornerSites {
  std::uint32_t colour[4];
  double x[4], y[4];
};

/// The sites degenerate corners make dualize take out of the diagram (sorted, distinct): the `num`
/// corners of `list` with their sites' positions gathered on the device, the culprits picked on the
/// host by the CPU executor's rule (corner_culprits).
void list_culprits(DeviceVoronoi::State& state, const std::uint32_t* list, std::uint32_t num, const double* x,
                   const double* y, std::vector<std::uint32_t>& out) {
  CudaExecutor& executor = state.executor;
  const std::uint32_t m = state.m;
  const std::uint32_t side = m - 1;
  const std::uint32_t* colour = state.buffers.colour.data();
  DeviceBuffer<CornerSites> d_corners(num);
  CornerSites* corners = d_corners.data();
  executor.for_each(
      num,
      [=] __device__(std::size_t k) {
        const std::uint32_t c = list[k];
        CornerSites corner;
        ::cdt::detail::corner_colours(colour, m, c % side, c / side, corner.colour);
        for (int i = 0; i < 4; ++i) {
          const std::uint32_t j = corner.colour[i];
          corner.x[i] = j == ::cdt::kNone ? 0.0 : x[j];
          corner.y[i] = j == ::cdt::kNone ? 0.0 : y[j];
        }
        corners[k] = corner;
      },
      "degenerate_corners");
  std::vector<CornerSites> h_corners(num);
  executor.download(h_corners.data(), corners, num);
  out.clear();
  std::vector<std::uint32_t> picked;
  for (const CornerSites& corner : h_corners) {
    // The corner's sites numbered 0..3 by their first place in it, so that equal colours stay equal.
    std::uint32_t local[4];
    for (std::uint32_t i = 0; i < 4; ++i) {
      local[i] = i;
      for (std::uint32_t j = 0; j < i; ++j)
        if (corner.colour[j] == corner.colour[i]) {
          local[i] = j;
          break;
        }
    }
    picked.clear();
    ::cdt::detail::corner_culprits(local, corner.x, corner.y, picked);
    for (const std::uint32_t i : picked) out.push_back(corner.colour[i]);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

/// The sites' positions the dual reads: those of `sites` when given, else the host's uploaded into the
/// state.
const double* site_positions_x(const DeviceVoronoi::State& state, const DeviceSites::State* sites) {
  return sites != nullptr ? sites->x.data() : state.site_x.data();
}
const double* site_positions_y(const DeviceVoronoi::State& state, const DeviceSites::State* sites) {
  return sites != nullptr ? sites->y.data() : state.site_y.data();
}

/// The part of DeviceVoronoi::dual before the copy to the host: the linked dual in b (b.tri, b.adj,
/// b.vert_tri) with num_dual slots when built. Times the steps into st.
DeviceVoronoi::DualOutcome build_dual(DeviceVoronoi::State& state, ::cdt::detail::Mesh& mesh, DualStats& st,
                                      std::vector<std::uint32_t>* degenerate, DualBuffers& b,
                                      std::uint32_t& num_dual, DeviceEvent& started, DeviceEvent& linked,
                                      const DeviceSites::State* sites = nullptr) {
  using DualOutcome = DeviceVoronoi::DualOutcome;
  DeviceVoronoi::State* state_ = &state;
  detail::CudaExecutor& executor = state_->executor;
  const std::uint32_t m = state_->m;
  const std::uint32_t n = sites != nullptr ? sites->n : mesh.num_vertices();
  mesh.tri.clear();
  mesh.adj.clear();
  mesh.seg.clear();
  mesh.vert_tri.clear();
  if (m < 2 || n < 3) return DualOutcome::declined;
  ::cdt::detail::StepTrace trace("device dual corners");
  st.device_bytes = detail::dual_device_bytes(n);
  detail::require_device_memory(st.device_bytes, 0,
                                "the dual triangulation of " + std::to_string(n) + " sites");
  trace.mark("memory checked");

  detail::DeviceEvent written;
  started.record(executor.stream());
  if (sites == nullptr) {
    state_->site_x.resize(n);
    state_->site_y.resize(n);
    std::vector<double> hx(n), hy(n);
    for (std::uint32_t v = 0; v < n; ++v) {
      hx[v] = mesh.xy[v].x;
      hy[v] = mesh.xy[v].y;
    }
    executor.upload(state_->site_x.data(), hx.data(), n);
    executor.upload(state_->site_y.data(), hy.data(), n);
    executor.synchronize(); // hx and hy go out of scope
  }
  const double* x = site_positions_x(state, sites);
  const double* y = site_positions_y(state, sites);
  const std::uint32_t* colour = state_->buffers.colour.data();
  // Phase 1's scratch of m * m words is free now: it holds the corners' counts, then their offsets.
  std::uint32_t* count = state_->buffers.stack.data();
  const std::uint32_t side = m - 1;
  const std::size_t corners = static_cast<std::size_t>(side) * side;
  // Degenerate corners are listed in Phase 1's other free scratch of m * m words, in any order.
  std::uint32_t* bad_list = state_->buffers.owner.data();
  auto* d_bad = executor.scalar<std::uint32_t>();
  executor.fill_bytes(d_bad, 0, 1);
  executor.for_each(
      corners,
      [=] __device__(std::size_t c) {
        std::uint32_t q[4];
        ::cdt::detail::corner_colours(colour, m, static_cast<std::uint32_t>(c % side),
                                      static_cast<std::uint32_t>(c / side), q);
        ::cdt::detail::DualTriangle out[2];
        const int k = ::cdt::detail::corner_triangles(q, x, y, out);
        if (k < 0) bad_list[atomicAdd(d_bad, 1u)] = static_cast<std::uint32_t>(c);
        count[c] = k < 0 ? 0u : static_cast<std::uint32_t>(k);
      },
      "corner_counts");
  std::uint32_t bad = 0;
  executor.download(&bad, d_bad, 1);
  trace.mark("counted");
  if (bad != 0) {
    if (degenerate == nullptr) return DualOutcome::declined;
    detail::list_culprits(*state_, bad_list, bad, x, y, *degenerate);
    trace.mark("culprits listed");
    return DualOutcome::degenerate;
  }
  num_dual = executor.exclusive_scan(count, corners);
  if (num_dual == 0) return DualOutcome::declined;

  b.unsorted.resize(3 * static_cast<std::size_t>(num_dual));
  b.tri.resize(3 * static_cast<std::size_t>(num_dual));
  b.key.resize(num_dual);
  b.index.resize(num_dual);
  std::uint32_t* unsorted = b.unsorted.data();
  std::uint32_t* key = b.key.data();
  std::uint32_t* index = b.index.data();
  executor.for_each(
      corners,
      [=] __device__(std::size_t c) {
        std::uint32_t q[4];
        ::cdt::detail::corner_colours(colour, m, static_cast<std::uint32_t>(c % side),
                                      static_cast<std::uint32_t>(c / side), q);
        ::cdt::detail::DualTriangle out[2];
        const int k = ::cdt::detail::corner_triangles(q, x, y, out);
        for (int j = 0; j < k; ++j) {
          const std::uint32_t at = count[c] + static_cast<std::uint32_t>(j);
          unsorted[3 * static_cast<std::size_t>(at)] = out[j].a;
          unsorted[3 * static_cast<std::size_t>(at) + 1] = out[j].b;
          unsorted[3 * static_cast<std::size_t>(at) + 2] = out[j].c;
          const std::uint32_t low = out[j].a < out[j].b ? out[j].a : out[j].b;
          key[at] = low < out[j].c ? low : out[j].c;
          index[at] = at;
        }
      },
      "corner_triangles");
  executor.sort_pairs(key, index, num_dual, detail::bits_below(n));
  std::uint32_t* tri = b.tri.data();
  executor.for_each(
      3 * static_cast<std::size_t>(num_dual),
      [=] __device__(std::size_t k) {
        tri[k] = unsorted[3 * static_cast<std::size_t>(index[k / 3]) + k % 3];
      },
      "order_slots");
  written.record(executor.stream());
  const bool linked_ok = detail::link_on_device(executor, b, num_dual, n);
  linked.record(executor.stream());
  if (!linked_ok) return DualOutcome::declined;
  st.dual_triangles = num_dual;
  st.triangles_ms = written.since(started);
  st.link_ms = linked.since(written);
  return DualOutcome::built;
}

} // namespace detail

namespace detail {
DeviceVoronoi::DualOutcome complete_dual(DeviceVoronoi::State& voronoi, ::cdt::detail::Mesh& mesh,
                                         const DeviceSites::State* sites, const ::cdt::detail::Box& bounds,
                                         std::optional<DeviceMesh>& out,
                                         std::vector<std::uint32_t>& site_vert_tri,
                                         std::vector<std::uint32_t>* degenerate);
} // namespace detail

DeviceVoronoi::DualOutcome DeviceVoronoi::dual(::cdt::detail::Mesh& mesh, DualStats* stats,
                                               std::vector<std::uint32_t>* degenerate) {
  DualStats local;
  DualStats& st = stats != nullptr ? *stats : local;
  st = DualStats{};
  detail::DualBuffers b;
  std::uint32_t num_dual = 0;
  detail::DeviceEvent started, linked, done;
  const DualOutcome outcome = detail::build_dual(*state_, mesh, st, degenerate, b, num_dual, started, linked);
  if (outcome != DualOutcome::built) return outcome;
  const std::uint32_t n = mesh.num_vertices();
  detail::CudaExecutor& executor = state_->executor;

  const std::size_t words = 3 * static_cast<std::size_t>(num_dual);
  mesh.tri.resize(words);
  mesh.adj.resize(words);
  mesh.seg.assign(words, ::cdt::detail::kNoId);
  mesh.vert_tri.resize(n);
  executor.download(mesh.tri.data(), b.tri.data(), words);
  executor.download(mesh.adj.data(), b.adj.data(), words);
  executor.download(mesh.vert_tri.data(), b.vert_tri.data(), n);
  done.record(executor.stream());
  st.download_ms = done.since(linked);
  return DualOutcome::built;
}

DeviceVoronoi::DualOutcome DeviceVoronoi::complete_dual(::cdt::detail::Mesh& mesh,
                                                        const ::cdt::detail::Box& bounds,
                                                        std::optional<DeviceMesh>& out,
                                                        std::vector<std::uint32_t>& site_vert_tri,
                                                        std::vector<std::uint32_t>* degenerate) {
  return detail::complete_dual(*state_, mesh, nullptr, bounds, out, site_vert_tri, degenerate);
}

DeviceVoronoi::DualOutcome DeviceVoronoi::complete_dual(const DeviceSites& sites,
                                                        const ::cdt::detail::Box& bounds,
                                                        std::optional<DeviceMesh>& out,
                                                        std::vector<std::uint32_t>& unreached,
                                                        std::vector<std::uint32_t>* degenerate) {
  ::cdt::detail::Mesh none;
  return detail::complete_dual(*state_, none, &sites.state(), bounds, out, unreached, degenerate);
}

namespace detail {

/// DeviceVoronoi::complete_dual, the sites' positions from the host's mesh.x, mesh.y or from `sites`;
/// site_vert_tri receives the sites' vert_tri, or with `sites` the kept sites the dual does not reach.
DeviceVoronoi::DualOutcome complete_dual(DeviceVoronoi::State& voronoi, ::cdt::detail::Mesh& mesh,
                                         const DeviceSites::State* sites, const ::cdt::detail::Box& bounds,
                                         std::optional<DeviceMesh>& out,
                                         std::vector<std::uint32_t>& site_vert_tri,
                                         std::vector<std::uint32_t>* degenerate) {
  using DualOutcome = DeviceVoronoi::DualOutcome;
  DeviceVoronoi::State* state_ = &voronoi;
  DualStats st;
  detail::DualBuffers b;
  std::uint32_t num_dual = 0;
  detail::DeviceEvent started, linked;
  ::cdt::detail::StepTrace trace("device dual");
  const DualOutcome outcome =
      detail::build_dual(*state_, mesh, st, degenerate, b, num_dual, started, linked, sites);
  if (outcome != DualOutcome::built) return outcome;
  detail::CudaExecutor& executor = state_->executor;
  trace.mark("built and linked");
  const std::uint32_t n = sites != nullptr ? sites->n : mesh.num_vertices();
  const std::size_t words = 3 * static_cast<std::size_t>(num_dual);

  // The open edges (every dual slot is live) and their ends, in increasing edge order.
  const std::uint32_t* tri = b.tri.data();
  const std::uint32_t* adj = b.adj.data();
  std::uint32_t* open_ids = b.edge.data(); // the links' scratch, 3 words per slot, free again
  const std::uint32_t num_open = executor.compact(
      words, [=] __device__(std::size_t e) { return adj[e] == ::cdt::detail::kNoId; }, open_ids);
  detail::DeviceBuffer<std::uint32_t> d_open(3 * static_cast<std::size_t>(num_open) + 1);
  std::uint32_t* open = d_open.data();
  // With each open edge, the position of its first vertex (the boundary's positions).
  detail::DeviceBuffer<double> d_open_xy(2 * static_cast<std::size_t>(num_open) + 1);
  double* open_xy = d_open_xy.data();
  const double* site_x = site_positions_x(*state_, sites);
  const double* site_y = site_positions_y(*state_, sites);
  executor.for_each(
      num_open,
      [=] __device__(std::size_t k) {
        const std::uint32_t e = open_ids[k];
        const std::uint32_t t = ::cdt::detail::edge_tri(e), i = ::cdt::detail::edge_index(e);
        const std::uint32_t from = tri[3 * t + ::cdt::detail::next3(i)];
        open[3 * k] = e;
        open[3 * k + 1] = from;
        open[3 * k + 2] = tri[3 * t + ::cdt::detail::prev3(i)];
        open_xy[k] = site_x[from];
        open_xy[num_open + k] = site_y[from];
      },
      "open_edges");
  std::vector<::cdt::detail::OpenEdge> h_open(num_open);
  std::vector<double> h_open_xy(2 * static_cast<std::size_t>(num_open));
  static_assert(sizeof(::cdt::detail::OpenEdge) == 3 * sizeof(std::uint32_t));
  executor.download(reinterpret_cast<std::uint32_t*>(h_open.data()), open,
                    3 * static_cast<std::size_t>(num_open));
  executor.download(h_open_xy.data(), open_xy, h_open_xy.size());
  trace.mark("open edges downloaded");
  const std::span<const double> all_xy(h_open_xy);
  const std::optional<::cdt::detail::DualCompletion> plan = ::cdt::detail::plan_dual_completion(
      h_open, all_xy.first(num_open), all_xy.subspan(num_open), n, num_dual, bounds);
  if (!plan) return DualOutcome::declined;
  trace.mark("completion planned");

  const auto k_fake = static_cast<std::uint32_t>(plan->fake.size());
  const auto added = static_cast<std::uint32_t>(plan->triangles.size());
  auto state = std::make_unique<DeviceMesh::State>();
  DeviceMesh::State& s = *state;
  s.allocate(num_dual + added, n + k_fake);
  const std::size_t all_words = 3 * static_cast<std::size_t>(s.num_slots);
  // The dual's arrays copied on the device, the added parts uploaded behind them.
  ::cdt::detail::Vec2* xy = s.xy.data();
  executor.for_each(
      n,
      [=] __device__(std::size_t v) {
        xy[v] = {site_x[v], site_y[v]};
      },
      "copy_xy");
  detail::copy_on_device(executor, s.tri.data(), tri, words, "copy_tri");
  detail::copy_on_device(executor, s.adj.data(), adj, words, "copy_adj");
  detail::copy_on_device(executor, s.vert_tri.data(), b.vert_tri.data(), n, "copy_vert_tri");
  executor.upload(s.xy.data() + n, plan->fake.data(), k_fake);
  static_assert(sizeof(::cdt::detail::DualTriangle) == 3 * sizeof(std::uint32_t));
  executor.upload(s.tri.data() + words, reinterpret_cast<const std::uint32_t*>(plan->triangles.data()),
                  3 * static_cast<std::size_t>(added));
  executor.upload(s.adj.data() + words, plan->adj.data(), plan->adj.size());
  executor.upload(s.vert_tri.data() + n, plan->fake_vert_tri.data(), k_fake);
  executor.fill_bytes(s.seg.data(), 0xFF, all_words);
  s.constrained = false;
  if (!plan->links.empty()) {
    static_assert(sizeof(plan->links[0]) == 2 * sizeof(std::uint32_t));
    detail::DeviceBuffer<std::uint32_t> d_links(2 * plan->links.size());
    executor.upload(d_links.data(), reinterpret_cast<const std::uint32_t*>(plan->links.data()),
                    2 * plan->links.size());
    std::uint32_t* links = d_links.data();
    std::uint32_t* new_adj = s.adj.data();
    executor.for_each(
        plan->links.size(), [=] __device__(std::size_t k) { new_adj[links[2 * k]] = links[2 * k + 1]; },
        "link_open_edges");
    executor.synchronize(); // d_links is freed at the end of this scope
  }
  trace.mark("completion queued");
  if (sites == nullptr) {
    site_vert_tri.resize(n);
    executor.download(site_vert_tri.data(), b.vert_tri.data(), n);
  } else {
    // check_missing_sites_left_out, and the kept sites left unreached, on the device: only those come
    // back (site_vert_tri holds them).
    const std::uint8_t* kept = sites->kept.data();
    const std::uint32_t* vert_tri = b.vert_tri.data();
    auto* d_dualized = executor.scalar<std::uint32_t>();
    executor.fill_bytes(d_dualized, 0, 1);
    executor.for_each(
        n,
        [=] __device__(std::size_t v) {
          if (kept[v] == 0 && vert_tri[v] != ::cdt::detail::kNoId) atomicOr(d_dualized, 1u);
        },
        "missing_sites_left_out");
    std::uint32_t dualized = 0;
    executor.download(&dualized, d_dualized, 1);
    if (dualized != 0) throw Error("internal error: a missing site was dualized");
    detail::DeviceBuffer<std::uint32_t> d_unreached(n);
    const std::uint32_t num_unreached = executor.compact(
        n, [=] __device__(std::size_t v) { return kept[v] != 0 && vert_tri[v] == ::cdt::detail::kNoId; },
        d_unreached.data());
    site_vert_tri.resize(num_unreached);
    executor.download(site_vert_tri.data(), d_unreached.data(), num_unreached);
  }
  executor.synchronize();
  trace.mark("completion applied");
  out.emplace(std::move(state));
  return DualOutcome::built;
}

} // namespace detail

} // namespace cdt::gpu
