#pragma once
// The triangulation data structure shared by every phase of gCD (paper section 3: a triangle list
// of pre-allocated slots with edge-adjacency links, plus a vertex array).
//
// Conventions (the same as the public Triangulation): a triangle's vertices are counter-clockwise;
// edge i of a triangle joins its vertices (i + 1) % 3 and (i + 2) % 3, so it is opposite vertex i.
// Links name the neighbour's edge, not only the neighbour: adj[3t + i] = 3u + j means edge i of t is
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

/// Raw view of a Mesh for per-element work (host or device pointers).
struct MeshView {
  Vec2* xy = nullptr;           ///< vertex coordinates
  std::uint32_t* tri = nullptr; ///< 3 per slot; tri[3t] == kNoId marks a free slot
  std::uint32_t* adj = nullptr; ///< 3 per slot: encoded neighbour edge across edge i, kNoId on the boundary
  /// 3 per slot: constraint id on edge i, kNoId when not a constraint. Null in a view of a mesh without
  /// constraints (every id kNoId) given to the flips alone: rewrite_flipped_pair, edge_flip_test and
  /// fake_fan_candidate then read kNoId and skip the writes, which would keep every id kNoId.
  std::uint32_t* seg = nullptr;
  std::uint32_t* vert_tri = nullptr; ///< per vertex: one live incident triangle, kNoId when not in the mesh
  std::uint32_t num_slots = 0;
  std::uint32_t num_vertices = 0;

  CDT_HD std::uint32_t v(std::uint32_t t, std::uint32_t i) const { return tri[3 * t + i]; }
  CDT_HD bool alive(std::uint32_t t) const { return tri[3 * t] != kNoId; }
  /// Index (0..2) of vertex p in triangle t, or 3 when p is not a vertex of t.
  CDT_HD std::uint32_t index_of(std::uint32_t t, std::uint32_t p) const {
    return tri[3 * t] == p ? 0 : tri[3 * t + 1] == p ? 1 : tri[3 * t + 2] == p ? 2 : 3;
  }
};

/// Host-side storage of a triangulation under construction.
struct Mesh {
  std::vector<Vec2> xy;
  std::vector<std::uint32_t> tri;
  std::vector<std::uint32_t> adj;
  std::vector<std::uint32_t> seg;
  std::vector<std::uint32_t> vert_tri;

  std::uint32_t num_slots() const { return static_cast<std::uint32_t>(tri.size() / 3); }
  std::uint32_t num_vertices() const { return static_cast<std::uint32_t>(xy.size()); }
  bool alive(std::uint32_t t) const { return tri[3 * t] != kNoId; }

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
    return MeshView{xy.data(),       tri.data(),  adj.data(),    seg.data(),
                    vert_tri.data(), num_slots(), num_vertices()};
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
  const std::uint32_t e = m.adj[3 * t + i];
  const std::uint32_t u = edge_tri(e);
  const std::uint32_t j = edge_index(e);
  const std::uint32_t i1 = next3(i), i2 = prev3(i);
  const std::uint32_t j1 = next3(j), j2 = prev3(j);
  const std::uint32_t a = m.tri[3 * t + i], b = m.tri[3 * t + i1], c = m.tri[3 * t + i2];
  const std::uint32_t d = m.tri[3 * u + j];
  // Outer edges before the flip: of t, (c, a) is edge i1 and (a, b) is edge i2; of u, with
  // u = (d, c, b) in order j, j1, j2: (b, d) is edge j1 and (d, c) is edge j2.
  const FlippedPairLinks outer{m.adj[3 * t + i1], m.adj[3 * t + i2], m.adj[3 * u + j1], m.adj[3 * u + j2]};
  // New t = (a, b, d): edge 0 = (b, d), edge 1 = (d, a) (the new diagonal), edge 2 = (a, b).
  // New u = (d, c, a): edge 0 = (c, a), edge 1 = (a, d) (the diagonal), edge 2 = (d, c).
  m.tri[3 * t + 0] = a;
  m.tri[3 * t + 1] = b;
  m.tri[3 * t + 2] = d;
  m.tri[3 * u + 0] = d;
  m.tri[3 * u + 1] = c;
  m.tri[3 * u + 2] = a;
  m.adj[3 * t + 0] = outer.u_bd;
  m.adj[3 * t + 1] = edge_id(u, 1);
  m.adj[3 * t + 2] = outer.t_ab;
  m.adj[3 * u + 0] = outer.t_ca;
  m.adj[3 * u + 1] = edge_id(t, 1);
  m.adj[3 * u + 2] = outer.u_dc;
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
  const std::uint32_t u = edge_tri(m.adj[3 * t + i]);
  const FlippedPairLinks outer = rewrite_flipped_pair(m, t, i);
  if (outer.u_bd != kNoId) m.adj[outer.u_bd] = edge_id(t, 0);
  if (outer.t_ab != kNoId) m.adj[outer.t_ab] = edge_id(t, 2);
  if (outer.t_ca != kNoId) m.adj[outer.t_ca] = edge_id(u, 0);
  if (outer.u_dc != kNoId) m.adj[outer.u_dc] = edge_id(u, 2);
}

/// Flips edge i of triangle t with its neighbour u (the quadrilateral must be strictly convex):
/// t = (a, b, c) with edge i = (b, c) and u = (c, b, d) become t = (a, b, d) and u = (d, c, a).
/// The four outer links and vert_tri of the four vertices are updated directly, so the caller must
/// own t, u and the slots of their outer neighbours that face them. Constraint ids move with their
/// edges; the new diagonal is not a constraint.
CDT_HD inline void flip_edge(MeshView m, std::uint32_t t, std::uint32_t i) {
  const std::uint32_t u = edge_tri(m.adj[3 * t + i]);
  flip_edge_links(m, t, i);
  m.vert_tri[m.tri[3 * t + 0]] = t; // a
  m.vert_tri[m.tri[3 * t + 1]] = t; // b
  m.vert_tri[m.tri[3 * u + 0]] = u; // d
  m.vert_tri[m.tri[3 * u + 1]] = u; // c
}

/// The output of slot t (cdt::Triangulation's arrays, 3 entries each): its corners as vertex ids
/// (vertex_of[site]), its neighbours as output triangle indices (index_of_slot[slot]; kNoId on the hull),
/// and per edge the input segment it lies on (segment_of_piece[constraint piece]; kNoId when none).
CDT_HD_INLINE void output_triangle(const MeshView& m, std::uint32_t t, const std::uint32_t* vertex_of,
                                   const std::uint32_t* index_of_slot, const std::uint32_t* segment_of_piece,
                                   std::uint32_t* corners, std::uint32_t* neighbours,
                                   std::uint32_t* segments) {
  for (std::uint32_t i = 0; i < 3; ++i) {
    corners[i] = vertex_of[m.tri[3 * t + i]];
    const std::uint32_t e = m.adj[3 * t + i];
    neighbours[i] = e == kNoId ? kNoId : index_of_slot[edge_tri(e)];
    const std::uint32_t piece = m.seg[3 * t + i];
    segments[i] = piece == kNoId ? kNoId : segment_of_piece[piece];
  }
}

} // namespace cdt::detail
