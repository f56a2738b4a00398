#include "gcd/mesh.hpp"

#include <algorithm>
#include <atomic>
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
  const std::size_t words = tri.size() + 3 * static_cast<std::size_t>(n);
  if (words > tri.capacity()) {
    // A reallocation copies every slot on one thread (8 million slots: a third of a second on a 2-core
    // machine); with room for an eighth more, the next small growth (the vertices the split adds)
    // copies nothing.
    const std::size_t room = words + words / 8;
    tri.reserve(room);
    adj.reserve(room);
    seg.reserve(room);
  }
  tri.resize(words, kNoId);
  adj.resize(words, kNoId);
  seg.resize(words, kNoId);
  return first;
}

void link_triangles(Mesh& mesh, CpuExecutor& executor) {
  const std::uint32_t slots = mesh.num_slots();
  const std::uint32_t nv = mesh.num_vertices();
  const MeshView m = mesh.view();
  // Directed edges bucketed by their lower vertex (a counting sort, linear time): the two sides of an
  // undirected edge land in the same small bucket, where they are matched by their upper vertex. Every
  // buffer is written whole by a parallel step.
  UnzeroedVector<std::uint32_t> start(static_cast<std::size_t>(nv) + 1);
  executor.for_each(start.size(), [&](std::size_t v) { start[v] = 0; });
  executor.for_each(slots, [&](std::size_t k) {
    const auto t = static_cast<std::uint32_t>(k);
    if (!m.alive(t)) return;
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t from = m.v(t, next3(i)), to = m.v(t, prev3(i));
      std::atomic_ref<std::uint32_t>(start[from < to ? from : to]).fetch_add(1, std::memory_order_relaxed);
    }
  });
  executor.exclusive_scan(start); // the last entry, zero before, becomes the total
  UnzeroedVector<std::uint32_t> fill(nv);
  executor.for_each(nv, [&](std::size_t v) { fill[v] = start[v]; });
  // Each entry: the edge's upper vertex (high half) and its encoded id (low half), so matching needs
  // no further lookups. Scattered in any order: each bucket is sorted below.
  UnzeroedVector<std::uint64_t> bucket(start[nv]);
  std::uint32_t* cursor = fill.data();
  std::uint64_t* out = bucket.data();
  executor.for_each(slots, [&, cursor, out](std::size_t k) {
    const auto t = static_cast<std::uint32_t>(k);
    if (!m.alive(t)) return;
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t from = m.v(t, next3(i)), to = m.v(t, prev3(i));
      const std::uint64_t hi = from < to ? to : from;
      const std::uint32_t at = std::atomic_ref<std::uint32_t>(cursor[from < to ? from : to])
                                   .fetch_add(1, std::memory_order_relaxed);
      out[at] = (hi << 32) | edge_id(t, i);
    }
  });
  std::uint32_t* adj = mesh.adj.data();
  executor.for_each(mesh.adj.size(), [adj](std::size_t e) { adj[e] = kNoId; });
  // The lowest vertex with a bad edge, so that the error does not depend on the thread count.
  std::uint32_t first_bad = kNoId;
  UnzeroedVector<std::uint8_t> bad(nv);
  executor.for_each(nv, [&, adj](std::size_t v) {
    bad[v] = 0;
    std::uint64_t* first = bucket.data() + start[v];
    std::uint64_t* last = bucket.data() + start[v + 1];
    // A bucket holds about a vertex's degree: insertion sort, unless a large fan makes it worth more.
    if (last - first > 32) {
      std::sort(first, last);
    } else {
      for (std::uint64_t* k = first + 1; k < last; ++k) {
        const std::uint64_t key = *k;
        std::uint64_t* j = k;
        for (; j > first && *(j - 1) > key; --j) *j = *(j - 1);
        *j = key;
      }
    }
    for (std::uint64_t* k = first; k < last;) {
      std::uint64_t* end = k + 1;
      while (end < last && (*end >> 32) == (*k >> 32)) ++end;
      if (end - k > 2) {
        bad[v] = 1; // an edge shared by more than two triangles
      } else if (end - k == 2) {
        const auto e0 = static_cast<std::uint32_t>(k[0]), e1 = static_cast<std::uint32_t>(k[1]);
        // Two triangles on one edge must traverse it in opposite directions.
        if (m.v(edge_tri(e0), next3(edge_index(e0))) == m.v(edge_tri(e1), next3(edge_index(e1)))) {
          bad[v] = 2;
        } else {
          adj[e0] = e1;
          adj[e1] = e0;
        }
      }
      k = end;
    }
    if (bad[v] != 0) atomic_min(&first_bad, static_cast<std::uint32_t>(v));
  });
  const std::uint8_t bad_kind = first_bad == kNoId ? 0 : bad[first_bad];
  if (bad_kind == 1) throw Error("internal error: an edge is shared by more than two triangles");
  if (bad_kind == 2) throw Error("internal error: two triangles overlap along an edge (same direction)");
  // Each vertex's incident triangle: the highest live slot that has it, found by an atomic maximum of
  // t + 1 over 0 (none), so the result does not depend on the thread count.
  mesh.vert_tri.resize(nv);
  std::uint32_t* vert_tri = mesh.vert_tri.data();
  executor.for_each(nv, [vert_tri](std::size_t v) { vert_tri[v] = 0; });
  executor.for_each(slots, [&, vert_tri](std::size_t k) {
    const auto t = static_cast<std::uint32_t>(k);
    if (!m.alive(t)) return;
    for (std::uint32_t i = 0; i < 3; ++i) atomic_max(vert_tri + m.v(t, i), t + 1);
  });
  executor.for_each(nv,
                    [vert_tri](std::size_t v) { vert_tri[v] = vert_tri[v] == 0 ? kNoId : vert_tri[v] - 1; });
}

} // namespace cdt::detail
