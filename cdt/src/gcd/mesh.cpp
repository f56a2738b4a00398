#include "gcd/mesh.hpp"

#include <algorithm>
#include <string>

#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"

namespace cdt::detail {

std::uint32_t Mesh::add_triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  const std::uint32_t t = num_slots();
  tri.insert(tri.end(), {a, b, c});
  adj.insert(adj.end(), {kNoId, kNoId, kNoId});
  seg.insert(seg.end(), {kNoId, kNoId, kNoId});
  return t;
}

std::uint32_t Mesh::grow_slots(std::uint32_t n) {
  const std::uint32_t first = num_slots();
  tri.resize(tri.size() + 3 * static_cast<std::size_t>(n), kNoId);
  adj.resize(adj.size() + 3 * static_cast<std::size_t>(n), kNoId);
  seg.resize(seg.size() + 3 * static_cast<std::size_t>(n), kNoId);
  return first;
}

void link_triangles(Mesh& mesh, CpuExecutor& executor) {
  const std::uint32_t slots = mesh.num_slots();
  const MeshView m = mesh.view();
  // One record per directed edge (from, to), keyed by the undirected pair so the two sides of an
  // edge sort next to each other.
  struct EdgeRecord {
    std::uint64_t key;
    std::uint32_t edge;
  };
  std::vector<EdgeRecord> records(3 * static_cast<std::size_t>(slots));
  executor.for_each(records.size(), [&](std::size_t k) {
    const auto t = static_cast<std::uint32_t>(k / 3);
    const auto i = static_cast<std::uint32_t>(k % 3);
    if (!m.alive(t)) {
      records[k] = {~std::uint64_t{0}, kNoId};
      return;
    }
    const std::uint32_t from = m.v(t, next3(i));
    const std::uint32_t to = m.v(t, prev3(i));
    const std::uint64_t lo = from < to ? from : to;
    const std::uint64_t hi = from < to ? to : from;
    records[k] = {(lo << 32) | hi, edge_id(t, i)};
  });
  executor.sort(records, [](const EdgeRecord& p, const EdgeRecord& q) {
    return p.key < q.key || (p.key == q.key && p.edge < q.edge);
  });
  std::fill(mesh.adj.begin(), mesh.adj.end(), kNoId);
  const std::size_t n = records.size();
  std::size_t k = 0;
  while (k < n && records[k].edge != kNoId) {
    std::size_t end = k + 1;
    while (end < n && records[end].key == records[k].key) ++end;
    if (end - k > 2) {
      throw Error("internal error: an edge is shared by " + std::to_string(end - k) + " triangles");
    }
    if (end - k == 2) {
      const std::uint32_t e0 = records[k].edge, e1 = records[k + 1].edge;
      // Two triangles on one edge must traverse it in opposite directions.
      if (m.v(edge_tri(e0), next3(edge_index(e0))) == m.v(edge_tri(e1), next3(edge_index(e1)))) {
        throw Error("internal error: two triangles overlap along an edge (same direction)");
      }
      mesh.adj[e0] = e1;
      mesh.adj[e1] = e0;
    }
    k = end;
  }
  mesh.vert_tri.assign(mesh.num_vertices(), kNoId);
  // Any incident triangle will do; races between writers are benign but not allowed by the memory
  // model, so this runs serially (it is a single pass over the slots).
  for (std::uint32_t t = 0; t < slots; ++t) {
    if (!m.alive(t)) continue;
    for (std::uint32_t i = 0; i < 3; ++i) mesh.vert_tri[m.v(t, i)] = t;
  }
}

} // namespace cdt::detail
