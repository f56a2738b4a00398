#pragma once
// Lawson's flip algorithm on one CPU thread inside a part of the mesh's slots, for the CPU schedules of
// Phases 4 and 5 (flip_to_delaunay_in_parts, insert_missing_points_in_parts). A thread flips an edge
// only when both triangles and their four outer neighbours belong to its part, so parts run side by
// side without locks; an edge that needs another part is left to the caller (`defer`), which settles
// it later on one thread that owns every slot.
//
// The one array parts share is vert_tri: an entry moves only when it names a slot of the calling part
// that no longer holds the vertex, so each entry has one writer at a time (the part owning the slot it
// names), and a part reading an entry that names another part's slot never mistakes it for its own.

#include <atomic>
#include <cstdint>
#include <vector>

#include "gcd/flip.hpp"
#include "gcd/mesh.hpp"

namespace cdt::detail {

/// Slots per part: fixed, so that the parts, and with them the results, do not depend on the thread
/// count. Slots are numbered along a space-filling curve by then (by their lowest vertex), so a part of
/// consecutive slots is a compact region whose border holds a few percent of its triangles.
inline constexpr std::uint32_t kPartSlots = 1u << 14;

/// Moves vert_tri[v] from `from` to `to` when it names `from`, the calling part's slot (see above).
inline void move_vert_tri(const MeshView& m, std::uint32_t v, std::uint32_t from, std::uint32_t to) {
  std::atomic_ref<std::uint32_t> at(m.vert_tri[v]);
  if (at.load(std::memory_order_relaxed) == from) at.store(to, std::memory_order_relaxed);
}

/// flip_edge for a flip whose two slots and four outer neighbours belong to the calling thread's part,
/// with vert_tri moved as the header says.
inline void flip_edge_in_part(const MeshView& m, std::uint32_t t, std::uint32_t i) {
  const std::uint32_t u = edge_tri(m.adj[3 * t + i]);
  const std::uint32_t b = m.tri[3 * t + next3(i)], c = m.tri[3 * t + prev3(i)];
  flip_edge_links(m, t, i);
  // t = (a, b, d) and u = (d, c, a) now: b left u, c left t.
  move_vert_tri(m, b, u, t);
  move_vert_tri(m, c, t, u);
}

/// Pops encoded edges off `todo` until it is empty, flipping every edge that fails the strict incircle
/// test when owns(slot) holds for both of its triangles and their outer neighbours, and pushing the
/// four outer edges of each flip. An edge that fails, or may fail, but needs a slot the part does not
/// own is handed to defer(t) with t its triangle on the part's side, untested when its other side is
/// not the part's (that slot may be changing under another thread). Returns the flips made.
template <class Owns, class Defer>
std::uint64_t drain_in_part(const MeshView& m, std::vector<std::uint32_t>& todo, Owns&& owns, Defer&& defer) {
  const auto inside = [&](std::uint32_t e) { return e == kNoId || owns(edge_tri(e)); };
  std::uint64_t flips = 0;
  while (!todo.empty()) {
    const std::uint32_t e = todo.back();
    todo.pop_back();
    const std::uint32_t t = edge_tri(e), i = edge_index(e);
    const std::uint32_t f = m.adj[e];
    if (f == kNoId || m.seg[e] != kNoId) continue;
    if (!inside(f)) {
      defer(t);
      continue;
    }
    if (!edge_wants_flip(m, t, i)) continue;
    const std::uint32_t u = edge_tri(f), j = edge_index(f);
    if (!inside(m.adj[3 * t + next3(i)]) || !inside(m.adj[3 * t + prev3(i)]) ||
        !inside(m.adj[3 * u + next3(j)]) || !inside(m.adj[3 * u + prev3(j)])) {
      defer(t);
      continue;
    }
    flip_edge_in_part(m, t, i);
    ++flips;
    // t = (a, b, d), u = (d, c, a): their outer edges are 0 and 2; edge 1 is the new diagonal.
    todo.insert(todo.end(), {edge_id(t, 0), edge_id(t, 2), edge_id(u, 0), edge_id(u, 2)});
  }
  return flips;
}

} // namespace cdt::detail
