#pragma once
// Phase 3 of gCD, shifting (paper section 3.3). Algorithm 1 moves each kept site from its grid position
// (x' of Appendix B) to its true coordinates when the move keeps its star valid (a good case); Algorithm 2
// deletes the others (bad cases) in rounds of non-adjacent vertices and re-triangulates each star-shaped
// hole by ear cutting into the slots of the deleted fan, so that Phase 4 (insert.hpp) can insert them again.
//
// The hole machinery here (fan collection into prefix-sum scratch, slot reuse, link repair between holes of
// the same round) also deletes the fake boundary in Phase 4 (section 3.4), whose holes are open fans.
//
// Every geometric decision is an exact orient2d sign. Per-element work is in CDT_HD functions over MeshView
// and plain arrays, so the CUDA executor can run it unchanged; the drivers in shift.cpp only sequence the
// data-parallel steps. Per-element functions cannot throw on the device: they return a WorkStatus that the
// driver turns into cdt::Error after the step.
//
// Priorities. The paper orders neighbours by point index. Inputs from image chains or lattices arrive in
// spatial order, where index order makes a whole row one dependency chain (a round per point of it); a
// bijective hash of the index is still a strict total order, so two neighbours never act in the same round,
// but its dependency chains are O(log n) long in expectation.

#include <atomic>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "cdt/cdt.hpp"
#include "cdt/detail/host_device.hpp"
#include "cdt/detail/predicates.hpp"
#include "gcd/mesh.hpp"

namespace cdt::detail {

class CpuExecutor;

/// A site that is not in the mesh and must be inserted by Phase 4.
struct MissingPoint {
  std::uint32_t vertex; ///< the site (its mesh.x/y already hold its true position)
  std::uint32_t hint;   ///< a vertex near it, to start point location from
};

/// The missing points of a triangulation, with the allocator of its large arrays (cdt.hpp): sized
/// without a zero fill, since every element is written (10^7 points: 3-6 million missing points, whose
/// serial zero fill cost as much as their parallel copy from the device).
using MissingArray = std::vector<MissingPoint, DefaultInitAllocator<MissingPoint>>;

struct ShiftStats {
  std::uint64_t shifted = 0; ///< good cases: sites moved in place
  std::uint64_t bad = 0;     ///< bad cases: sites deleted and appended to the missing points
  std::uint64_t rounds = 0;  ///< parallel rounds of Algorithm 1 plus those of Algorithm 2
};

/// Moves every kept site (vertices 0..num_sites-1 that are in the mesh) to (true_x[v], true_y[v]). Good cases
/// (the point stays inside the kernel of its star: all fan triangles stay CCW with neighbours static) move in
/// parallel rounds (Algorithm 1: a point moves in a round only when all its lower-priority neighbours are
/// checked); bad cases are deleted (Algorithm 2: non-adjacent deletions in parallel rounds, fan slots
/// recorded with a prefix sum, star-shaped hole re-triangulated by ear cutting into the same slots, links
/// fixed) and appended to `missing` with a remaining neighbour as hint. Afterwards every vertex still in the
/// mesh is at its true position, and so is every site not in the mesh (ready for insert_missing_points).
/// Preconditions: the phase-2 contract (sites strictly inside the fake boundary, every triangle strictly CCW,
/// links consistent); true_x/true_y hold num_sites finite values, pairwise distinct points.
ShiftStats shift_to_true_positions(Mesh& mesh, std::uint32_t num_sites, std::span<const double> true_x,
                                   std::span<const double> true_y, MissingArray& missing,
                                   CpuExecutor& executor);

// ------------------------------------------------------------------------------------------------------------
// Per-element work, shared with Phase 4 (host and device).

/// Outcome of one element's work; anything but ok is an internal error (the mesh broke a precondition).
enum class WorkStatus : std::uint32_t {
  ok = 0,
  broken_fan,    ///< a fan walk neither closed nor ended within the number of slots
  no_ear,        ///< ear cutting or the pocket fill found no strictly CCW triangle to create
  open_star,     ///< a site to shift or delete lies on the mesh boundary
  closed_fake,   ///< a fake boundary vertex is not on the mesh boundary
  lost,          ///< point location left the mesh or ran longer than the mesh
  duplicate,     ///< a missing point coincides with a vertex of the mesh
  boundary_edge, ///< a missing point lies on the outer boundary of the mesh
  stuck,         ///< a round made no progress
};

/// What a failure means, for the message of the error it becomes.
const char* work_status_message(WorkStatus s);

/// Records the first failure of a parallel step; the driver checks it after the step (host only).
class WorkFailure {
public:
  void record(WorkStatus s) {
    std::uint32_t expected = 0;
    code_.compare_exchange_strong(expected, static_cast<std::uint32_t>(s), std::memory_order_relaxed);
  }
  /// Throws cdt::Error("internal error: ...") naming `step` when a failure was recorded.
  void check(const char* step) const;

private:
  std::atomic<std::uint32_t> code_{0};
};

/// Vertex states of Algorithm 1; sites outside the mesh and fake vertices count as checked and static.
enum ShiftState : std::uint8_t { kUnchecked = 0, kGood = 1, kBad = 2 };

/// Strict total order on vertices for the independent-set rounds (see the file comment).
CDT_HD_INLINE std::uint32_t vertex_priority(std::uint32_t v) {
  // Odd multiplications and right xor-shifts are bijections of 32-bit words: no two vertices tie.
  v *= 0x9E3779B1u;
  v ^= v >> 15;
  v *= 0x85EBCA77u;
  v ^= v >> 13;
  return v;
}

/// The triangle after t counter-clockwise around its vertex at index k (across the edge from that vertex to
/// vertex k + 2), or kNoId on the mesh boundary.
CDT_HD_INLINE std::uint32_t fan_ccw(MeshView m, std::uint32_t t, std::uint32_t k) {
  const std::uint32_t e = m.adj[3 * t + next3(k)];
  return e == kNoId ? kNoId : edge_tri(e);
}

/// The triangle before t clockwise around its vertex at index k, or kNoId on the mesh boundary.
CDT_HD_INLINE std::uint32_t fan_cw(MeshView m, std::uint32_t t, std::uint32_t k) {
  const std::uint32_t e = m.adj[3 * t + prev3(k)];
  return e == kNoId ? kNoId : edge_tri(e);
}

/// The first triangle of v's fan in counter-clockwise order: for an open fan the one on the boundary, for a
/// closed fan vert_tri[v]. Sets `closed`. kNoId when v is not in the mesh or the walk does not end.
CDT_HD inline std::uint32_t fan_start(MeshView m, std::uint32_t v, bool& closed) {
  closed = false;
  const std::uint32_t first = m.vert_tri[v];
  if (first == kNoId) return kNoId;
  std::uint32_t t = first;
  for (std::uint32_t steps = 0; steps <= m.num_slots; ++steps) {
    const std::uint32_t k = m.index_of(t, v);
    if (k == 3) return kNoId;
    const std::uint32_t u = fan_cw(m, t, k);
    if (u == kNoId) return t;
    if (u == first) {
      closed = true;
      return first;
    }
    t = u;
  }
  return kNoId;
}

/// Calls visit(t, k) for each triangle t of v's fan in counter-clockwise order (k: v's index in t) until
/// visit returns false. Returns false when the fan is broken; sets `closed`.
template <class Visit>
CDT_HD bool walk_fan(MeshView m, std::uint32_t v, bool& closed, Visit&& visit) {
  const std::uint32_t first = fan_start(m, v, closed);
  if (first == kNoId) return false;
  std::uint32_t t = first;
  for (std::uint32_t steps = 0; steps <= m.num_slots; ++steps) {
    const std::uint32_t k = m.index_of(t, v);
    if (k == 3) return false;
    if (!visit(t, k)) return true;
    t = fan_ccw(m, t, k);
    if (t == kNoId || t == first) return closed == (t == first);
  }
  return false;
}

/// Calls visit(t, k) once for each triangle t of v's fan (k: v's index in t) until visit returns false:
/// counter-clockwise from vert_tri[v], then, for an open fan, clockwise from the triangle before vert_tri[v].
/// For order-independent work this is a single pass around a closed fan, where walk_fan first walks around it
/// to find where it starts. Returns false when the fan is broken; `closed` is only meaningful when every
/// triangle was visited.
template <class Visit>
CDT_HD bool visit_fan(MeshView m, std::uint32_t v, bool& closed, Visit&& visit) {
  closed = false;
  const std::uint32_t first = m.vert_tri[v];
  if (first == kNoId) return false;
  std::uint32_t t = first;
  std::uint32_t steps = 0;
  for (;;) {
    if (++steps > m.num_slots + 1) return false;
    const std::uint32_t k = m.index_of(t, v);
    if (k == 3) return false;
    if (!visit(t, k)) return true;
    t = fan_ccw(m, t, k);
    if (t == first) {
      closed = true;
      return true;
    }
    if (t == kNoId) break;
  }
  t = fan_cw(m, first, m.index_of(first, v));
  while (t != kNoId) {
    if (++steps > m.num_slots + 1) return false;
    const std::uint32_t k = m.index_of(t, v);
    if (k == 3) return false;
    if (!visit(t, k)) return true;
    t = fan_cw(m, t, k);
  }
  return true;
}

/// Calls visit(w) once for each neighbour w of v until it returns false; false if the fan is broken.
template <class Visit>
CDT_HD bool walk_neighbours(MeshView m, std::uint32_t v, Visit&& visit) {
  bool closed = false;
  bool more = true;
  return visit_fan(m, v, closed, [&](std::uint32_t t, std::uint32_t k) {
    more = visit(m.v(t, next3(k)));
    // The far vertex of the counter-clockwise end of an open fan is a neighbour no triangle starts with.
    if (more && m.adj[3 * t + next3(k)] == kNoId) more = visit(m.v(t, prev3(k)));
    return more;
  });
}

/// Algorithm 1, first round: the number of neighbours of site v with state 0 (unchecked) and a lower
/// priority, written to lower (when not null). Readiness in later rounds then reads only these lists.
CDT_HD inline WorkStatus lower_neighbours(MeshView m, std::uint32_t v, const std::uint8_t* state,
                                          std::uint32_t* lower, std::uint32_t& count) {
  count = 0;
  const std::uint32_t pv = vertex_priority(v);
  const bool ok = walk_neighbours(m, v, [&](std::uint32_t w) {
    if (state[w] == 0 && vertex_priority(w) < pv) {
      if (lower != nullptr) lower[count] = w;
      ++count;
    }
    return true;
  });
  return ok ? WorkStatus::ok : WorkStatus::broken_fan;
}

/// Algorithm 1 line 4: whether every listed lower neighbour is checked. A checked vertex stays checked, so
/// the cursor only moves forward and all rounds together read each list once.
CDT_HD_INLINE bool shift_ready(const std::uint32_t* lower, std::uint32_t& cursor, std::uint32_t end,
                               const std::uint8_t* state) {
  while (cursor < end && state[lower[cursor]] != 0) ++cursor;
  return cursor == end;
}

/// Algorithm 1 line 6: whether moving v to (tx, ty) with its neighbours static keeps every fan triangle
/// strictly CCW, that is, (tx, ty) lies in the open kernel of v's star. An open star (a site on the mesh
/// boundary, which the fake boundary rules out) is never good; its deletion then reports it.
CDT_HD inline WorkStatus shift_is_good(MeshView m, std::uint32_t v, double tx, double ty, bool& good) {
  good = true;
  bool closed = false;
  const bool ok = visit_fan(m, v, closed, [&](std::uint32_t t, std::uint32_t k) {
    const std::uint32_t a = m.v(t, next3(k)), b = m.v(t, prev3(k));
    const Vec2 pa = m.xy[a], pb = m.xy[b];
    if (orient2d(tx, ty, pa.x, pa.y, pb.x, pb.y) <= 0) good = false;
    return good;
  });
  if (!ok) return WorkStatus::broken_fan;
  if (good && !closed) good = false;
  return WorkStatus::ok;
}

/// States of Algorithm 2's vertices (the `leaving` arrays): every state but kStays is leaving. Between
/// rounds a vertex still to delete is kLeaving; within a round the first pick is marked kLeavingNow, and
/// the rest next to it kLeavingLater, before the second pick (see may_delete_among_rest).
enum LeavingState : std::uint8_t { kStays = 0, kLeaving = 1, kLeavingNow = 2, kLeavingLater = 3 };

/// The rank of vertex w in the independent-set rounds: its priority, or that of ranked_as[w] (a
/// copied-out part of a mesh deletes in the order of the whole).
CDT_HD_INLINE std::uint32_t ranked_priority(std::uint32_t w, const std::uint32_t* ranked_as) {
  return vertex_priority(ranked_as != nullptr ? ranked_as[w] : w);
}

/// Sets now to whether no neighbour w of v with rival(leaving[w]) ranks lower than v; broken_fan when
/// v's fan is broken. Both picks of Algorithm 2's rounds below.
template <class Rival>
CDT_HD inline WorkStatus lowest_among(MeshView m, std::uint32_t v, const std::uint8_t* leaving, bool& now,
                                      const std::uint32_t* ranked_as, Rival&& rival) {
  now = true;
  const std::uint32_t pv = ranked_priority(v, ranked_as);
  const bool ok = walk_neighbours(m, v, [&](std::uint32_t w) {
    if (rival(leaving[w]) && ranked_priority(w, ranked_as) < pv) now = false;
    return now;
  });
  return ok ? WorkStatus::ok : WorkStatus::broken_fan;
}

/// Algorithm 2 line 3: whether leaving vertex v may go this round, i.e. no leaving neighbour has a lower
/// priority (so the vertices deleted together are pairwise non-adjacent and their fans disjoint). With
/// `ranked_as`, vertex w is ranked as vertex ranked_as[w].
CDT_HD inline WorkStatus may_delete_now(MeshView m, std::uint32_t v, const std::uint8_t* leaving, bool& now,
                                        const std::uint32_t* ranked_as = nullptr) {
  return lowest_among(m, v, leaving, now, ranked_as, [](std::uint8_t state) { return state != kStays; });
}

/// Whether a neighbour of v is in the round's first pick (leaving[w] == kLeavingNow).
CDT_HD inline WorkStatus next_to_leaving_now(MeshView m, std::uint32_t v, const std::uint8_t* leaving,
                                             bool& next) {
  next = false;
  const bool ok = walk_neighbours(m, v, [&](std::uint32_t w) {
    if (leaving[w] == kLeavingNow) next = true;
    return !next;
  });
  return ok ? WorkStatus::ok : WorkStatus::broken_fan;
}

/// The round's second pick. A vertex of the first pick (a local minimum of the priorities among the
/// leaving vertices) often keeps a neighbour out whose other neighbours could go; Algorithm 2's
/// independent set then grows by a vertex v with leaving[v] == kLeaving (not in the first pick, not next
/// to it) when no neighbour that is still kLeaving has a lower priority. Such vertices are pairwise
/// non-adjacent and next to no vertex of the first pick, so the round's set stays independent (the
/// coastlines: 10 rounds instead of 21).
CDT_HD inline WorkStatus may_delete_among_rest(MeshView m, std::uint32_t v, const std::uint8_t* leaving,
                                               bool& now, const std::uint32_t* ranked_as = nullptr) {
  return lowest_among(m, v, leaving, now, ranked_as, [](std::uint8_t state) { return state == kLeaving; });
}

/// Number of ring vertices of v's fan (as many as triangles when closed, one more when open); 0 if broken.
CDT_HD inline std::uint32_t ring_size(MeshView m, std::uint32_t v, bool& closed) {
  std::uint32_t n = 0;
  if (!visit_fan(m, v, closed, [&](std::uint32_t, std::uint32_t) {
        ++n;
        return true;
      }))
    return 0;
  return closed ? n : n + 1;
}

/// Scratch of the holes of one round, indexed by ring position: a hole owns positions [base, base + count)
/// given by a prefix sum of its ring sizes (Algorithm 2 line 8). Position i describes ring vertex i and the
/// hole's boundary edge from ring vertex i to ring vertex i + 1 (the last position of an open fan has none).
struct HoleView {
  std::uint32_t* vertex = nullptr;   ///< ring vertex
  std::uint32_t* slot = nullptr;     ///< fan triangle holding boundary edge i; its slot is reused
  std::uint32_t* outer = nullptr;    ///< encoded edge across boundary edge i before the round (kNoId: none)
  std::uint32_t* seg = nullptr;      ///< constraint id of boundary edge i
  std::uint32_t* new_edge = nullptr; ///< new encoded edge of boundary edge i (kNoId: on the outer boundary)
  std::uint32_t* next = nullptr;     ///< ear cutting: next live position; pocket fill: the stack
  std::uint32_t* prev = nullptr;     ///< ear cutting: previous live position
  std::uint32_t* ref = nullptr;      ///< hole edge from vertex i to its current successor (see kBoundaryRef)
  std::uint8_t* own = nullptr;       ///< 1: this hole rewrites vert_tri of vertex i; 2: it has done so
};

/// A hole edge is either still an original boundary edge (top bit set, low bits its position) or an edge of
/// a triangle already created in the hole (encoded edge). Encoded edges stay below 2^31: slots < 2^31 / 3.
inline constexpr std::uint32_t kBoundaryRef = 0x80000000u;

/// Algorithm 2 line 10: records v's fan in positions [base, base + count) and marks its slots in slot_pos.
CDT_HD inline void collect_ring(MeshView m, std::uint32_t v, HoleView h, std::uint32_t base,
                                std::uint32_t count, std::uint32_t* slot_pos) {
  std::uint32_t pos = base;
  bool closed = false;
  walk_fan(m, v, closed, [&](std::uint32_t t, std::uint32_t k) {
    h.vertex[pos] = m.v(t, next3(k));
    h.slot[pos] = t;
    h.outer[pos] = m.adj[3 * t + k];
    h.seg[pos] = m.seg[3 * t + k];
    h.new_edge[pos] = kNoId;
    slot_pos[t] = pos;
    if (!closed && pos + 2 == base + count) h.vertex[pos + 1] = m.v(t, prev3(k));
    ++pos;
    return true;
  });
  if (!closed) {
    h.slot[base + count - 1] = kNoId;
    h.outer[base + count - 1] = kNoId;
    h.seg[base + count - 1] = kNoId;
    h.new_edge[base + count - 1] = kNoId;
  }
}

/// Algorithm 2 lines 12-14: a ring vertex whose vert_tri is one of this hole's slots gets it rewritten by
/// this hole only; every other vert_tri keeps pointing at a live triangle. Read-only on the mesh.
CDT_HD inline void mark_owned_vertices(MeshView m, HoleView h, std::uint32_t base, std::uint32_t count,
                                       const std::uint32_t* slot_pos) {
  for (std::uint32_t i = base; i < base + count; ++i) {
    const std::uint32_t p = slot_pos[m.vert_tri[h.vertex[i]]];
    h.own[i] = (p != kNoId && p >= base && p < base + count) ? 1 : 0;
  }
}

/// Sets edge j of new triangle s to hole edge `ref`: an original boundary edge is remembered for the link
/// repair; an edge of an earlier triangle of the same hole is linked both ways (both slots are this hole's).
CDT_HD_INLINE void attach_hole_edge(MeshView m, HoleView h, std::uint32_t ref, std::uint32_t s,
                                    std::uint32_t j) {
  const std::uint32_t e = edge_id(s, j);
  if (ref & kBoundaryRef) {
    const std::uint32_t pos = ref & ~kBoundaryRef;
    h.new_edge[pos] = e;
    m.seg[e] = h.seg[pos];
    m.adj[e] = kNoId;
  } else {
    m.adj[e] = ref;
    m.adj[ref] = e;
    m.seg[e] = kNoId;
  }
}

/// Writes triangle (a, b, c) at ring positions pa, pb, pc into slot s; edges 0 and 2 come from the ring, edge
/// 1 (c, a) becomes the ring edge after pa. Takes vert_tri of the owned corners.
CDT_HD inline void emit_hole_triangle(MeshView m, HoleView h, std::uint32_t s, std::uint32_t pa,
                                      std::uint32_t pb, std::uint32_t pc) {
  m.tri[3 * s + 0] = h.vertex[pa];
  m.tri[3 * s + 1] = h.vertex[pb];
  m.tri[3 * s + 2] = h.vertex[pc];
  attach_hole_edge(m, h, h.ref[pb], s, 0);
  attach_hole_edge(m, h, h.ref[pa], s, 2);
  m.adj[3 * s + 1] = kNoId;
  m.seg[3 * s + 1] = kNoId;
  h.ref[pa] = edge_id(s, 1);
  const std::uint32_t corners[3] = {pa, pb, pc};
  for (std::uint32_t p : corners) {
    if (h.own[p] != 0) {
      m.vert_tri[h.vertex[p]] = s;
      h.own[p] = 2;
    }
  }
}

CDT_HD_INLINE void release_slot(MeshView m, std::uint32_t s) {
  for (std::uint32_t i = 0; i < 3; ++i) {
    m.tri[3 * s + i] = kNoId;
    m.adj[3 * s + i] = kNoId;
    m.seg[3 * s + i] = kNoId;
  }
}

/// Algorithm 2 line 16: triangulates the star-shaped hole of a deleted interior vertex whose old position
/// (kx, ky) lies in the open kernel of the ring. An ear (a, b, c) is taken when b is a strictly convex corner
/// and the kernel point is strictly on the far side of the diagonal a-c: the ear then lies in the two fan
/// triangles at b, which hold no other vertex, and the kernel point stays in the open kernel of what remains.
/// When no such ear exists (the kernel point on every candidate diagonal) a strictly convex corner whose
/// closed triangle holds no other ring vertex is taken instead; a simple polygon always has one, and after it
/// only that exact test is used. The d - 2 triangles reuse the first d - 2 fan slots; the last two are freed.
CDT_HD inline WorkStatus cut_ears(MeshView m, HoleView h, std::uint32_t base, std::uint32_t count, double kx,
                                  double ky) {
  const std::uint32_t last = base + count - 1;
  for (std::uint32_t i = base; i <= last; ++i) {
    h.next[i] = i == last ? base : i + 1;
    h.prev[i] = i == base ? last : i - 1;
    h.ref[i] = kBoundaryRef | i;
  }
  auto pt = [&](std::uint32_t p) { return m.xy[h.vertex[p]]; };
  auto turns_left = [](const Vec2& p, const Vec2& q, const Vec2& r) {
    return orient2d(p.x, p.y, q.x, q.y, r.x, r.y);
  };
  auto convex = [&](std::uint32_t b) { return turns_left(pt(h.prev[b]), pt(b), pt(h.next[b])) > 0; };
  auto kernel_ear = [&](std::uint32_t b) {
    const Vec2 pa = pt(h.prev[b]), pb = pt(b), pc = pt(h.next[b]);
    return turns_left(pa, pb, pc) > 0 && orient2d(pa.x, pa.y, pc.x, pc.y, kx, ky) > 0;
  };
  auto empty_ear = [&](std::uint32_t b) {
    if (!convex(b)) return false;
    const std::uint32_t a = h.prev[b], c = h.next[b];
    const Vec2 pa = pt(a), pb = pt(b), pc = pt(c);
    for (std::uint32_t w = h.next[c]; w != a; w = h.next[w]) {
      const Vec2 pw = pt(w);
      if (turns_left(pa, pb, pw) >= 0 && turns_left(pb, pc, pw) >= 0 && turns_left(pc, pa, pw) >= 0)
        return false;
    }
    return true;
  };
  std::uint32_t live = count;
  std::uint32_t used = 0;
  std::uint32_t cur = base;
  bool kernel_valid = true;
  while (live > 3) {
    std::uint32_t ear = kNoId;
    if (kernel_valid) {
      std::uint32_t b = cur;
      for (std::uint32_t tries = 0; tries < live && ear == kNoId; ++tries, b = h.next[b])
        if (kernel_ear(b)) ear = b;
    }
    if (ear == kNoId) {
      std::uint32_t b = cur;
      for (std::uint32_t tries = 0; tries < live && ear == kNoId; ++tries, b = h.next[b])
        if (empty_ear(b)) ear = b;
      if (ear == kNoId) return WorkStatus::no_ear;
      kernel_valid = false;
    }
    const std::uint32_t a = h.prev[ear], c = h.next[ear];
    emit_hole_triangle(m, h, h.slot[base + used++], a, ear, c);
    h.next[a] = c;
    h.prev[c] = a;
    --live;
    cur = a;
  }
  const std::uint32_t a = cur, b = h.next[a], c = h.next[b];
  if (turns_left(pt(a), pt(b), pt(c)) <= 0) return WorkStatus::no_ear;
  const std::uint32_t s = h.slot[base + used++];
  emit_hole_triangle(m, h, s, a, b, c);
  // The closing triangle's edge 1 is the ring edge after c, not a new diagonal.
  attach_hole_edge(m, h, h.ref[c], s, 1);
  for (std::uint32_t i = used; i < count; ++i) release_slot(m, h.slot[base + i]);
  return WorkStatus::ok;
}

/// A hint for the missing point that a deleted star vertex becomes: the first ring vertex of its hole
/// that is not leaving (leaving may be null), or the first ring vertex when all are.
CDT_HD inline std::uint32_t ring_hint(HoleView h, std::uint32_t base, std::uint32_t count,
                                      const std::uint8_t* leaving) {
  for (std::uint32_t p = base; p < base + count; ++p)
    if (leaving == nullptr || leaving[h.vertex[p]] == 0) return h.vertex[p];
  return h.vertex[base];
}

/// Section 3.4, fake boundary removal: fills the open hole of a deleted boundary vertex f whose chain of
/// neighbours c_0..c_m runs counter-clockwise around f. What must be filled is the region between the chain
/// and its convex hull on f's side, so that the mesh stays convex: a Graham-scan-like walk keeps a stack of
/// the hull so far and, while the stack's last two vertices and the next chain vertex turn strictly left (the
/// chain bends away from f), adds that triangle and pops. Collinear turns add nothing, so collinear vertices
/// stay on the hull edge and no zero-area triangle is made. At most m - 1 triangles reuse the m fan slots;
/// the rest are freed; chain edges left on the hull become outer boundary edges.
CDT_HD inline WorkStatus fill_pockets(MeshView m, HoleView h, std::uint32_t base, std::uint32_t count) {
  std::uint32_t* stack = h.next + base;
  std::uint32_t top = 0;
  std::uint32_t used = 0;
  stack[top++] = base;
  for (std::uint32_t c = base + 1; c < base + count; ++c) {
    std::uint32_t edge_in = kBoundaryRef | (c - 1); // the hole edge from the stack top to c
    while (top >= 2) {
      const std::uint32_t a = stack[top - 2], b = stack[top - 1];
      const std::uint32_t va = h.vertex[a], vb = h.vertex[b], vc = h.vertex[c];
      const Vec2 pa = m.xy[va], pb = m.xy[vb], pc = m.xy[vc];
      if (orient2d(pa.x, pa.y, pb.x, pb.y, pc.x, pc.y) <= 0) break;
      h.ref[b] = edge_in;
      emit_hole_triangle(m, h, h.slot[base + used++], a, b, c);
      edge_in = h.ref[a];
      --top;
    }
    h.ref[stack[top - 1]] = edge_in;
    stack[top++] = c;
  }
  for (std::uint32_t i = used; i + 1 < count; ++i) release_slot(m, h.slot[base + i]);
  return WorkStatus::ok;
}

/// The encoded edge that now holds old edge e: e itself when its triangle was not deleted this round, else
/// the edge of the new triangle of that hole (kNoId when that hole left it on the outer boundary).
CDT_HD_INLINE std::uint32_t forward_hole_edge(HoleView h, const std::uint32_t* slot_pos, std::uint32_t e) {
  const std::uint32_t p = slot_pos[edge_tri(e)];
  return p == kNoId ? e : h.new_edge[p];
}

/// Algorithm 2 lines 18-20: links the hole's boundary edges to the triangles across them. A hole writes its
/// own new edges and the far side only when that side is static; a far side in another hole of the same
/// round is written by that hole, so no two threads write one link. Open fans also give owned ring vertices
/// left without a new triangle a triangle across their boundary edges.
CDT_HD inline void relink_hole(MeshView m, HoleView h, std::uint32_t base, std::uint32_t count, bool closed,
                               const std::uint32_t* slot_pos) {
  const std::uint32_t edges = closed ? count : count - 1;
  for (std::uint32_t i = base; i < base + edges; ++i) {
    const std::uint32_t out = h.outer[i];
    const std::uint32_t target = out == kNoId ? kNoId : forward_hole_edge(h, slot_pos, out);
    if (h.new_edge[i] != kNoId) m.adj[h.new_edge[i]] = target;
    if (out != kNoId && slot_pos[edge_tri(out)] == kNoId) m.adj[out] = h.new_edge[i];
  }
  if (closed) return;
  for (std::uint32_t i = base; i < base + count; ++i) {
    if (h.own[i] != 1) continue;
    std::uint32_t t = kNoId;
    if (i > base && h.outer[i - 1] != kNoId) {
      const std::uint32_t e = forward_hole_edge(h, slot_pos, h.outer[i - 1]);
      if (e != kNoId) t = edge_tri(e);
    }
    if (t == kNoId && i < base + edges && h.outer[i] != kNoId) {
      const std::uint32_t e = forward_hole_edge(h, slot_pos, h.outer[i]);
      if (e != kNoId) t = edge_tri(e);
    }
    // kNoId only when the vertex has no triangle left (all sites collinear; the caller rejects that input).
    m.vert_tri[h.vertex[i]] = t;
    h.own[i] = 2;
  }
}

// ------------------------------------------------------------------------------------------------------------
// Host driver of one hole round, shared with the fake boundary removal.

enum class HoleShape {
  star,     ///< interior vertex: closed ring, re-triangulated by cut_ears
  open_fan, ///< vertex on the outer boundary: open chain, filled by fill_pockets
};

/// Buffers of the hole rounds, kept between rounds so they are allocated once.
struct HoleWorkspace {
  std::vector<std::uint32_t> slot_pos; ///< per slot: ring position while its triangle is deleted, else kNoId
  std::vector<std::uint32_t> offset;   ///< per active vertex: first ring position (prefix sum)
  std::vector<std::uint32_t> count;    ///< per active vertex: ring size
  std::vector<std::uint32_t> vertex, slot, outer, seg, new_edge, next, prev, ref;
  std::vector<std::uint8_t> own;

  void resize_ring(std::size_t n);
  HoleView view();
};

/// One round of Algorithm 2 (lines 8-20) on `active`, vertices that are pairwise non-adjacent: records their
/// fans, re-triangulates the holes into the same slots (freeing the spare ones), repairs links and vert_tri,
/// and takes the vertices out of the mesh (vert_tri = kNoId). For star holes, hint[i] (when hint is not null)
/// receives a ring vertex of active[i] with leaving == 0, or any ring vertex when there is none.
void delete_vertex_round(Mesh& mesh, std::span<const std::uint32_t> active, HoleShape shape,
                         const std::uint8_t* leaving, std::uint32_t* hint, HoleWorkspace& workspace,
                         CpuExecutor& executor);

/// Algorithm 2's outer loop: deletes every vertex with leaving[v] == kLeaving (listed in `pending`) in
/// rounds of pairwise non-adjacent vertices (each round's first pick and second pick, see
/// may_delete_among_rest), setting leaving[v] = kStays as it goes, and calls after_round(active, hints)
/// after each round (hints only for star holes). Vertices are ranked as may_delete_now ranks them with
/// `ranked_as`. Returns the number of rounds.
std::uint64_t delete_vertices(
    Mesh& mesh, std::vector<std::uint32_t> pending, HoleShape shape, std::vector<std::uint8_t>& leaving,
    const std::function<void(std::span<const std::uint32_t>, std::span<const std::uint32_t>)>& after_round,
    CpuExecutor& executor, const std::uint32_t* ranked_as = nullptr);

} // namespace cdt::detail
