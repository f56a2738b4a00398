#pragma once
// The triangulation data structure shared by every phase of gCD (paper section 3: a triangle list
// of pre-allocated slots with edge-adjacency links, plus a vertex array).
//
// Conventions (the same as the public Triangulation): a triangle's vertices are counter-clockwise;
// edge i of a triangle joins its vertices (i + 1) % 3 and (i + 2) % 3, so it is opposite vertex i.
// Links name the neighbour's edge, not only the neighbour: link(t, i) = 3u + j means edge i of t is
// edge j of u. This makes every link update O(1), with no search through the neighbour.
//
// Vertex array: where the paper keeps a linked list of incident triangles per vertex, this keeps one
// incident triangle per vertex and walks the fan through the links. Every phase only needs fans
// between its parallel steps, when links are consistent, and this needs no list maintenance and a
// quarter of the memory.
//
// MeshView holds raw pointers so that per-element functions run unchanged on the host and the device.

#include <cstdint>
#include <span>
#include <vector>

#include "cdt/detail/host_device.hpp"

namespace cdt::detail {

inline constexpr std::uint32_t kNoId = 0xFFFFFFFFu;

CDT_HD_INLINE std::uint32_t next3(std::uint32_t i) { return i == 2 ? 0 : i + 1; }
CDT_HD_INLINE std::uint32_t prev3(std::uint32_t i) { return i == 0 ? 2 : i - 1; }
CDT_HD_INLINE std::uint32_t edge_id(std::uint32_t t, std::uint32_t i) { return 3 * t + i; }
CDT_HD_INLINE std::uint32_t edge_tri(std::uint32_t e) { return e / 3; }
CDT_HD_INLINE std::uint32_t edge_index(std::uint32_t e) { return e % 3; }

/// A vertex's coordinates, both in one aligned 16 bytes: a predicate reads each of its vertices in one
/// load (one memory sector on the device) rather than one from each of two arrays.
struct alignas(16) Vec2 {
  double x = 0.0;
  double y = 0.0;
  friend bool operator==(const Vec2&, const Vec2&) = default;
};

/// One triangle slot: its vertices and its links, in one aligned 32 bytes, so that a step reading or
/// rewriting a triangle touches one memory sector on the device (one cache line on the host) rather
/// than one in each of two arrays. v[0] == kNoId marks a free slot; the last two words are unused.
struct alignas(32) Slot {
  std::uint32_t v[3];    ///< counter-clockwise vertices
  std::uint32_t link[3]; ///< encoded neighbour edge across edge i, kNoId on the boundary
  std::uint32_t spare[2];
  /// Equal vertices and links (the unused words are not compared).
  friend bool operator==(const Slot& p, const Slot& q) {
    return p.v[0] == q.v[0] && p.v[1] == q.v[1] && p.v[2] == q.v[2] && p.link[0] == q.link[0] &&
           p.link[1] == q.link[1] && p.link[2] == q.link[2];
  }
};
/// A free slot: every vertex and link kNoId.
inline constexpr Slot kFreeSlot{{kNoId, kNoId, kNoId}, {kNoId, kNoId, kNoId}, {kNoId, kNoId}};

/// Raw view of a Mesh for per-element work (host or device pointers).
struct MeshView {
  Vec2* xy = nullptr;    ///< vertex coordinates
  Slot* slots = nullptr; ///< the triangles' vertices and links
  /// 3 per slot: constraint id on edge i, kNoId when not a constraint. Null in a view of a mesh without
  /// constraints (every id kNoId) given to the flips alone: rewrite_flipped_pair, edge_flip_test and
  /// fake_fan_candidate then read kNoId and skip the writes, which would keep every id kNoId.
  std::uint32_t* seg = nullptr;
  std::uint32_t* vert_tri = nullptr; ///< per vertex: one live incident triangle, kNoId when not in the mesh
  std::uint32_t num_slots = 0;
  std::uint32_t num_vertices = 0;

  /// Vertex i of slot t.
  CDT_HD std::uint32_t& v(std::uint32_t t, std::uint32_t i) const { return slots[t].v[i]; }
  /// The vertex opposite edge e (vertex edge_index(e) of slot edge_tri(e)).
  CDT_HD std::uint32_t& opposite(std::uint32_t e) const { return slots[e / 3].v[e % 3]; }
  /// The link across edge i of slot t, and across edge e.
  CDT_HD std::uint32_t& link(std::uint32_t t, std::uint32_t i) const { return slots[t].link[i]; }
  CDT_HD std::uint32_t& link(std::uint32_t e) const { return slots[e / 3].link[e % 3]; }
  CDT_HD bool alive(std::uint32_t t) const { return slots[t].v[0] != kNoId; }
  /// Index (0..2) of vertex p in triangle t, or 3 when p is not a vertex of t.
  CDT_HD std::uint32_t index_of(std::uint32_t t, std::uint32_t p) const {
    const Slot& s = slots[t];
    return s.v[0] == p ? 0 : s.v[1] == p ? 1 : s.v[2] == p ? 2 : 3;
  }
};

/// Host-side storage of a triangulation under construction.
struct Mesh {
  std::vector<Vec2> xy;
  std::vector<Slot> slots;
  std::vector<std::uint32_t> seg; ///< 3 per slot
  std::vector<std::uint32_t> vert_tri;

  std::uint32_t num_slots() const { return static_cast<std::uint32_t>(slots.size()); }
  std::uint32_t num_vertices() const { return static_cast<std::uint32_t>(xy.size()); }
  bool alive(std::uint32_t t) const { return slots[t].v[0] != kNoId; }
  std::uint32_t& v(std::uint32_t t, std::uint32_t i) { return slots[t].v[i]; }
  std::uint32_t v(std::uint32_t t, std::uint32_t i) const { return slots[t].v[i]; }
  std::uint32_t& opposite(std::uint32_t e) { return slots[e / 3].v[e % 3]; }
  std::uint32_t opposite(std::uint32_t e) const { return slots[e / 3].v[e % 3]; }
  std::uint32_t& link(std::uint32_t t, std::uint32_t i) { return slots[t].link[i]; }
  std::uint32_t link(std::uint32_t t, std::uint32_t i) const { return slots[t].link[i]; }
  std::uint32_t& link(std::uint32_t e) { return slots[e / 3].link[e % 3]; }
  std::uint32_t link(std::uint32_t e) const { return slots[e / 3].link[e % 3]; }

  /// Sets the vertices' coordinates from separate arrays of x and y (of equal lengths).
  void set_points(std::span<const double> px, std::span<const double> py) {
    xy.resize(px.size());
    for (std::size_t i = 0; i < px.size(); ++i) xy[i] = Vec2{px[i], py[i]};
  }

  /// Adds a triangle slot (a, b, c must be counter-clockwise) with no links; returns its index.
  std::uint32_t add_triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c);
  /// Makes room for n more slots (all free) and returns the first new index.
  std::uint32_t grow_slots(std::uint32_t n);

  MeshView view() {
    return MeshView{xy.data(), slots.data(), seg.data(), vert_tri.data(), num_slots(), num_vertices()};
  }
};

class CpuExecutor;

/// Recomputes every link (adj) of the live triangles from their vertices (edges bucketed by their lower
/// vertex, matched by the upper one), and
/// points vert_tri at an incident live triangle. Throws Error if an edge is shared by more than two
/// triangles or used twice in the same direction (not a valid triangulation).
void link_triangles(Mesh& mesh, CpuExecutor& executor);

/// The outer links of a flipped pair, as they were before the flip: of t = (a, b, c), its edges (c, a)
/// and (a, b); of u = (d, c, b), its edges (b, d) and (d, c).
struct FlippedPairLinks {
  std::uint32_t t_ca, t_ab, u_bd, u_dc;
};

/// Rewrites the two slots of the pair across edge i of t (t = (a, b, c), u = (c, b, d)) as t = (a, b, d)
/// and u = (d, c, a), the new diagonal as edge 1 of both: vertices, links (the outer ones still naming
/// the neighbours' edges, which are not touched) and constraint ids (moving with their edges; the
/// diagonal has none). Returns the outer links for the caller to repair.
CDT_HD inline FlippedPairLinks rewrite_flipped_pair(MeshView m, std::uint32_t t, std::uint32_t i) {
  // Both slots read and written whole: one sector each way on the device.
  const Slot st = m.slots[t];
  const std::uint32_t e = st.link[i];
  const std::uint32_t u = edge_tri(e);
  const std::uint32_t j = edge_index(e);
  const Slot su = m.slots[u];
  const std::uint32_t i1 = next3(i), i2 = prev3(i);
  const std::uint32_t j1 = next3(j), j2 = prev3(j);
  const std::uint32_t a = st.v[i], b = st.v[i1], c = st.v[i2];
  const std::uint32_t d = su.v[j];
  // Outer edges before the flip: of t, (c, a) is edge i1 and (a, b) is edge i2; of u, with
  // u = (d, c, b) in order j, j1, j2: (b, d) is edge j1 and (d, c) is edge j2.
  const FlippedPairLinks outer{st.link[i1], st.link[i2], su.link[j1], su.link[j2]};
  // New t = (a, b, d): edge 0 = (b, d), edge 1 = (d, a) (the new diagonal), edge 2 = (a, b).
  // New u = (d, c, a): edge 0 = (c, a), edge 1 = (a, d) (the diagonal), edge 2 = (d, c).
  m.slots[t] = Slot{{a, b, d}, {outer.u_bd, edge_id(u, 1), outer.t_ab}, {st.spare[0], st.spare[1]}};
  m.slots[u] = Slot{{d, c, a}, {outer.t_ca, edge_id(t, 1), outer.u_dc}, {su.spare[0], su.spare[1]}};
  if (m.seg != nullptr) { // else every id is kNoId, before and after
    const std::uint32_t s_ca = m.seg[3 * t + i1], s_ab = m.seg[3 * t + i2];
    const std::uint32_t s_bd = m.seg[3 * u + j1], s_dc = m.seg[3 * u + j2];
    m.seg[3 * t + 0] = s_bd;
    m.seg[3 * t + 1] = kNoId;
    m.seg[3 * t + 2] = s_ab;
    m.seg[3 * u + 0] = s_ca;
    m.seg[3 * u + 1] = kNoId;
    m.seg[3 * u + 2] = s_dc;
  }
  return outer;
}

/// flip_edge without the vertex array: t and u are rewritten and the four outer links updated, vert_tri
/// is left to the caller.
CDT_HD inline void flip_edge_links(MeshView m, std::uint32_t t, std::uint32_t i) {
  const std::uint32_t u = edge_tri(m.link(t, i));
  const FlippedPairLinks outer = rewrite_flipped_pair(m, t, i);
  if (outer.u_bd != kNoId) m.link(outer.u_bd) = edge_id(t, 0);
  if (outer.t_ab != kNoId) m.link(outer.t_ab) = edge_id(t, 2);
  if (outer.t_ca != kNoId) m.link(outer.t_ca) = edge_id(u, 0);
  if (outer.u_dc != kNoId) m.link(outer.u_dc) = edge_id(u, 2);
}

/// Flips edge i of triangle t with its neighbour u (the quadrilateral must be strictly convex):
/// t = (a, b, c) with edge i = (b, c) and u = (c, b, d) become t = (a, b, d) and u = (d, c, a).
/// The four outer links and vert_tri of the four vertices are updated directly, so the caller must
/// own t, u and the slots of their outer neighbours that face them. Constraint ids move with their
/// edges; the new diagonal is not a constraint.
CDT_HD inline void flip_edge(MeshView m, std::uint32_t t, std::uint32_t i) {
  const std::uint32_t u = edge_tri(m.link(t, i));
  flip_edge_links(m, t, i);
  m.vert_tri[m.v(t, 0)] = t; // a
  m.vert_tri[m.v(t, 1)] = t; // b
  m.vert_tri[m.v(u, 0)] = u; // d
  m.vert_tri[m.v(u, 1)] = u; // c
}

/// The output of slot t (cdt::Triangulation's arrays, 3 entries each): its corners as vertex ids
/// (vertex_of[site]), its neighbours as output triangle indices (index_of_slot[slot]; kNoId on the hull),
/// and per edge the input segment it lies on (segment_of_piece[constraint piece]; kNoId when none).
CDT_HD_INLINE void output_triangle(const MeshView& m, std::uint32_t t, const std::uint32_t* vertex_of,
                                   const std::uint32_t* index_of_slot, const std::uint32_t* segment_of_piece,
                                   std::uint32_t* corners, std::uint32_t* neighbours,
                                   std::uint32_t* segments) {
  for (std::uint32_t i = 0; i < 3; ++i) {
    corners[i] = vertex_of[m.v(t, i)];
    const std::uint32_t e = m.link(t, i);
    neighbours[i] = e == kNoId ? kNoId : index_of_slot[edge_tri(e)];
    const std::uint32_t piece = m.seg[3 * t + i];
    segments[i] = piece == kNoId ? kNoId : segment_of_piece[piece];
  }
}

} // namespace cdt::detail
