#pragma once
// Phase 4 of gCD (paper section 3.4): missing points insertion (Algorithm 3) and the removal of the fake
// boundary added in Phase 2.
//
// Algorithm 3 rounds: every pending point locates its container (one triangle, or the two triangles of the
// edge it lies on) and marks it by atomic minimum of a key scattered from its index (claim_key); a point
// whose marks all survive splits its container (1 -> 3 inside a triangle, 2 -> 4 on an edge) into reused free
// slots; links are repaired in a separate step. The smallest pending key always wins, so every round
// inserts at least one point.
//
// Point location is a straight walk from a vertex towards the point rather than the paper's unspecified
// search: a visibility walk can cycle in a triangulation that is not Delaunay (ours is not until Phase 5),
// while a straight walk advances along a segment. When the segment runs exactly through a vertex (lattice
// inputs do this constantly) the walk restarts from that vertex, which is closer to the point, so no
// degenerate crossing case is ever needed.
//
// Fake boundary removal deletes the fake vertices in rounds of non-adjacent vertices with the hole machinery
// of shift.hpp; each hole is an open fan, filled up to the convex hull of its chain by fill_pockets.

#include <cstdint>
#include <span>
#include <vector>

#include "cdt/detail/host_device.hpp"
#include "cdt/detail/predicates.hpp"
#include "gcd/mesh.hpp"
#include "gcd/shift.hpp"

namespace cdt::detail {

class CpuExecutor;

struct InsertStats {
  std::uint64_t inserted = 0; ///< missing points inserted
  std::uint64_t rounds = 0;   ///< rounds of Algorithm 3
  std::uint64_t flips = 0;    ///< Lawson flips made while inserting (insert_missing_points_in_parts)
};

/// Inserts every missing point (already at its true position in mesh.x/y) by Algorithm 3: locate the
/// container (one triangle, or two when the point is on an edge) by walking from the hint, mark the container
/// with the point's index in `missing` by atomic minimum, insert the winners (1->3 split or 2->4 split on an
/// edge) reusing free slots (compaction of free slots; each insertion takes exactly two, so the prefix sum of
/// the allocation is twice the winner's rank; the mesh grows once up front when slots are short), fix links,
/// repeat. Delays a point whose hint is a missing point not yet inserted; a hint that is neither in the mesh
/// nor pending is replaced by a vertex of the mesh. Precondition: the fake boundary encloses every point
/// strictly and no point coincides with a vertex (else cdt::Error).
///
/// With `touched`, it is resized to the mesh's slots after the insertion (new entries 0) and every slot
/// a split rewrote is set to 1: the triangles whose edges may now fail the incircle test.
InsertStats insert_missing_points(Mesh& mesh, std::span<const MissingPoint> missing, CpuExecutor& executor,
                                  std::vector<std::uint8_t>* touched = nullptr);

/// The same insertions scheduled for CPU threads, with Lawson's flips after each: first the mesh is
/// flipped to Delaunay (flip_to_delaunay_in_parts), then the points go to fixed parts of the slots by
/// the triangle of their hint (part_lawson.hpp), and each part inserts its points one after the other,
/// each located by a walk from the part's last inserted point (points are numbered along a
/// space-filling curve, so the walks are short), split into the part's own new slots and followed by
/// the flips it calls for, as long as every slot involved is the part's. What the parts leave (a walk
/// or a flip that needs another part, a hint not in the mesh) is then done the same way by one thread
/// that owns every slot; only a point that walk cannot place (more than its step limit) goes to
/// insert_missing_points's rounds, without flips. `dirty` is resized to the mesh's slots and flags
/// every triangle with an edge that may still fail the incircle test, for a last
/// flip_to_delaunay_in_parts from those. rounds counts one for the parts plus the rounds; flips
/// counts the first flips and those made while inserting. With is_delaunay the mesh is known to be
/// Delaunay already, and the first flips are skipped.
InsertStats insert_missing_points_in_parts(Mesh& mesh, std::span<const MissingPoint> missing,
                                           CpuExecutor& executor, std::vector<std::uint8_t>& dirty,
                                           bool is_delaunay = false);

/// Deletes the fake boundary vertices [first_fake, num_vertices) like bad cases, except that each hole is an
/// open polygon: the region between the fake vertex's chain of neighbours and that chain's convex hull is
/// filled (a Graham-scan-like walk adding triangles at convex turns, never a zero-area one). The result
/// covers exactly the convex hull of the remaining vertices, collinear hull vertices included; then compacts
/// the triangle list (removes free slots, orders the triangles by their lowest vertex, renumbers links and
/// vert_tri) and removes the fake vertices from x/y/vert_tri. Precondition: the fake vertices are strictly
/// convex corners of the outer boundary.
///
/// With `changed` (one flag per slot on entry), the flags follow their triangles into the compacted
/// numbering, and every triangle that fills a hole is flagged too (its edges may fail the incircle test).
///
/// Without `compact` the slots stay as they are (free ones included): the compaction pays off only
/// for steps that walk the mesh afterwards (the constraints), not for points alone.
void remove_fake_boundary(Mesh& mesh, std::uint32_t first_fake, CpuExecutor& executor,
                          std::vector<std::uint8_t>* changed = nullptr, bool compact = true);

/// remove_fake_boundary's deletions alone (no compaction; the fake vertices stay in x/y with vert_tri
/// kNoId). With `ranked_as`, vertex v is ranked as vertex ranked_as[v] when the rounds are chosen: the GPU
/// backend copies the fake vertices' fans out of its mesh, numbered locally with ranked_as naming each
/// local vertex's id in the whole mesh, deletes the fake vertices on the host and writes the result back,
/// which is then what this leaves on the whole mesh, slot for slot. The fans are few triangles (about the
/// hull's vertices and the fake polygon's), but the hull's straight runs pass from fan to fan as the fake
/// vertices go, which one GPU thread per fan walks slowly. On the fans' copy, the triangles across their
/// edges need only their corners and their links back (all that the deletion reads of them), and a free
/// slot can stand for any other triangle named by a ring vertex's vert_tri.
void delete_fake_vertices(Mesh& mesh, std::uint32_t first_fake, CpuExecutor& executor,
                          const std::uint32_t* ranked_as = nullptr);

// ------------------------------------------------------------------------------------------------------------
// Per-element work (host and device).

/// Where a point lies: strictly inside triangle `tri` (edge == 3) or strictly inside its edge `edge`.
struct PointLocation {
  std::uint32_t tri = kNoId;
  std::uint32_t edge = 3;
  WorkStatus status = WorkStatus::ok;
};

CDT_HD_INLINE int sign_of_difference(double a, double b) { return (a > b) - (a < b); }

/// For q collinear with o and a (q != o): whether q lies on the ray from o through a.
CDT_HD_INLINE bool on_ray(double ox, double oy, double ax, double ay, double qx, double qy) {
  return sign_of_difference(qx, ox) == sign_of_difference(ax, ox) &&
         sign_of_difference(qy, oy) == sign_of_difference(ay, oy);
}

/// For q on the ray from o through a: whether q lies strictly before a. Exact: compares coordinates only.
CDT_HD_INLINE bool before_on_ray(double ox, double oy, double ax, double ay, double qx, double qy) {
  if (ax != ox) return ax > ox ? qx < ax : qx > ax;
  return ay > oy ? qy < ay : qy > ay;
}

/// Algorithm 3 line 3: locates (px, py) by a straight walk from vertex `origin` (in the mesh). A vertex met
/// exactly on the segment becomes the new origin; otherwise the walk crosses the edges the segment crosses,
/// with the edge's right end A and left end B strictly on either side of the line.
CDT_HD inline PointLocation locate_point(MeshView m, std::uint32_t origin, double px, double py) {
  const std::uint64_t max_steps = 8 * static_cast<std::uint64_t>(m.num_slots) + 64;
  std::uint64_t steps = 0;
  PointLocation fail;
  fail.status = WorkStatus::lost;
  for (;;) {
    const Vec2 o = m.xy[origin];
    const double ox = o.x, oy = o.y;
    if (ox == px && oy == py) return PointLocation{kNoId, 3, WorkStatus::duplicate};
    // Find the wedge of origin's fan that holds the ray towards p (any visiting order will do).
    std::uint32_t e_cross = kNoId, a = kNoId, b = kNoId, next_origin = kNoId;
    PointLocation found;
    found.status = WorkStatus::lost;
    bool closed = false;
    const bool fan_ok = visit_fan(m, origin, closed, [&](std::uint32_t t, std::uint32_t k) {
      if (++steps > max_steps) return false;
      const std::uint32_t va = m.v(t, next3(k)), vb = m.v(t, prev3(k));
      const Vec2 pa = m.xy[va], pb = m.xy[vb];
      const double ax = pa.x, ay = pa.y, bx = pb.x, by = pb.y;
      const int oa = orient2d(ox, oy, ax, ay, px, py);
      const int ob = orient2d(ox, oy, bx, by, px, py);
      // Edge (origin, va) is edge prev3(k); edge (vb, origin) is edge next3(k).
      if (oa == 0 && on_ray(ox, oy, ax, ay, px, py)) {
        if (ax == px && ay == py)
          found = PointLocation{kNoId, 3, WorkStatus::duplicate};
        else if (before_on_ray(ox, oy, ax, ay, px, py))
          found = PointLocation{t, prev3(k), WorkStatus::ok};
        else
          next_origin = va;
        return false;
      }
      if (ob == 0 && on_ray(ox, oy, bx, by, px, py)) {
        if (bx == px && by == py)
          found = PointLocation{kNoId, 3, WorkStatus::duplicate};
        else if (before_on_ray(ox, oy, bx, by, px, py))
          found = PointLocation{t, next3(k), WorkStatus::ok};
        else
          next_origin = vb;
        return false;
      }
      if (oa > 0 && ob < 0) {
        const int ab = orient2d(ax, ay, bx, by, px, py);
        if (ab > 0)
          found = PointLocation{t, 3, WorkStatus::ok};
        else if (ab == 0)
          found = PointLocation{t, k, WorkStatus::ok};
        else {
          e_cross = edge_id(t, k);
          a = va;
          b = vb;
        }
        return false;
      }
      return true;
    });
    if (!fan_ok) return fail;
    if (found.status != WorkStatus::lost) return found;
    if (next_origin == kNoId && e_cross == kNoId) return fail; // p outside the mesh as seen from origin
    if (next_origin != kNoId) {
      origin = next_origin;
      continue;
    }
    // Cross edges: the current edge goes from a (right of origin->p) to b (left) in its triangle.
    while (next_origin == kNoId) {
      if (++steps > max_steps) return fail;
      const std::uint32_t e = m.adj[e_cross];
      if (e == kNoId) return fail;
      const std::uint32_t u = edge_tri(e), j = edge_index(e);
      const std::uint32_t c = m.v(u, j); // u = (c, b, a) from index j on
      const Vec2 pa = m.xy[a], pb = m.xy[b], pc = m.xy[c];
      const double ax = pa.x, ay = pa.y, bx = pb.x, by = pb.y, cx = pc.x, cy = pc.y;
      const int s_ac = orient2d(ax, ay, cx, cy, px, py);
      const int s_cb = orient2d(cx, cy, bx, by, px, py);
      if (s_ac >= 0 && s_cb >= 0) {
        if (s_ac == 0 && s_cb == 0) return PointLocation{kNoId, 3, WorkStatus::duplicate};
        if (s_ac == 0) return PointLocation{u, next3(j), WorkStatus::ok};
        if (s_cb == 0) return PointLocation{u, prev3(j), WorkStatus::ok};
        return PointLocation{u, 3, WorkStatus::ok};
      }
      const int side = orient2d(ox, oy, px, py, cx, cy);
      if (side > 0) {
        e_cross = edge_id(u, next3(j)); // edge (a, c)
        b = c;
      } else if (side < 0) {
        e_cross = edge_id(u, prev3(j)); // edge (c, b)
        a = c;
      } else {
        next_origin = c; // c lies on the segment, strictly between origin and p
      }
    }
    origin = next_origin;
  }
}

/// Bits of the corners whose vert_tri a split rewrites: a, b, c of the first container (from the edge's
/// opposite vertex on, or from index 0 inside a triangle) and d, the apex of the second container.
enum : std::uint8_t { kSplitOwnA = 1, kSplitOwnB = 2, kSplitOwnC = 4, kSplitOwnD = 8 };

/// Where a missing point lies (Algorithm 3, lines 2-5): triangle `tri` holding it, the edge it lies
/// on (3: strictly inside), and for an edge the triangle `u` across it with that edge's index `j` there
/// (kNoId and 3 otherwise). status != ok when the walk fails, boundary_edge on a hull edge.
struct MissingPointPlace {
  std::uint32_t tri = kNoId;
  std::uint32_t edge = 3;
  std::uint32_t u = kNoId;
  std::uint32_t j = 3;
  WorkStatus status = WorkStatus::ok;
};

CDT_HD inline MissingPointPlace place_missing_point(MeshView m, std::uint32_t origin, double px, double py) {
  const PointLocation loc = locate_point(m, origin, px, py);
  MissingPointPlace out;
  out.status = loc.status;
  if (loc.status != WorkStatus::ok) return out;
  out.tri = loc.tri;
  out.edge = loc.edge;
  if (loc.edge != 3) {
    const std::uint32_t e = m.adj[3 * loc.tri + loc.edge];
    if (e == kNoId) {
      out.status = WorkStatus::boundary_edge;
      return out;
    }
    out.u = edge_tri(e);
    out.j = edge_index(e);
  }
  return out;
}

/// Algorithm 3 line 18 inside triangle t = (a, b, c): t becomes (p, b, c), s0 = (a, p, c), s1 = (a, b, p).
/// The triangle that holds old edge k of t holds it at index k, so links into t can be forwarded by
/// arithmetic (split_forward); the outer links are left pointing at the old neighbours for that repair.
CDT_HD inline void split_triangle(MeshView m, std::uint32_t p, std::uint32_t t, std::uint32_t s0,
                                  std::uint32_t s1, std::uint8_t own) {
  const std::uint32_t a = m.tri[3 * t], b = m.tri[3 * t + 1], c = m.tri[3 * t + 2];
  const std::uint32_t o1 = m.adj[3 * t + 1], o2 = m.adj[3 * t + 2];
  const std::uint32_t g1 = m.seg[3 * t + 1], g2 = m.seg[3 * t + 2];
  m.tri[3 * t] = p;
  m.adj[3 * t + 1] = edge_id(s0, 0);
  m.adj[3 * t + 2] = edge_id(s1, 0);
  m.seg[3 * t + 1] = kNoId;
  m.seg[3 * t + 2] = kNoId;
  const std::uint32_t v0[3] = {a, p, c}, l0[3] = {edge_id(t, 1), o1, edge_id(s1, 1)},
                      g0[3] = {kNoId, g1, kNoId};
  const std::uint32_t v1[3] = {a, b, p}, l1[3] = {edge_id(t, 2), edge_id(s0, 2), o2},
                      h1[3] = {kNoId, kNoId, g2};
  for (std::uint32_t i = 0; i < 3; ++i) {
    m.tri[3 * s0 + i] = v0[i];
    m.adj[3 * s0 + i] = l0[i];
    m.seg[3 * s0 + i] = g0[i];
    m.tri[3 * s1 + i] = v1[i];
    m.adj[3 * s1 + i] = l1[i];
    m.seg[3 * s1 + i] = h1[i];
  }
  m.vert_tri[p] = t;
  if (own & kSplitOwnA) m.vert_tri[a] = s0;
  if (own & kSplitOwnB) m.vert_tri[b] = t;
  if (own & kSplitOwnC) m.vert_tri[c] = t;
}

/// Algorithm 3 line 18 on edge i of t = (a, b, c) (from index i on), shared with edge j of u = (d, c, b):
/// t becomes (a, b, p), s0 = (a, p, c), u becomes (d, c, p), s1 = (d, p, b), each new triangle at the indices
/// of the triangle it came from, so every old outer edge keeps its index.
CDT_HD inline void split_edge(MeshView m, std::uint32_t p, std::uint32_t t, std::uint32_t i, std::uint32_t u,
                              std::uint32_t j, std::uint32_t s0, std::uint32_t s1, std::uint8_t own) {
  const std::uint32_t i1 = next3(i), i2 = prev3(i), j1 = next3(j), j2 = prev3(j);
  const std::uint32_t a = m.tri[3 * t + i], b = m.tri[3 * t + i1], c = m.tri[3 * t + i2],
                      d = m.tri[3 * u + j];
  const std::uint32_t t_ca = m.adj[3 * t + i1], u_bd = m.adj[3 * u + j1];
  const std::uint32_t g_bc = m.seg[3 * t + i], g_ca = m.seg[3 * t + i1], g_bd = m.seg[3 * u + j1];
  // s0 and s1 first: they copy from t and u before those change.
  m.tri[3 * s0 + i] = a;
  m.tri[3 * s0 + i1] = p;
  m.tri[3 * s0 + i2] = c;
  m.adj[3 * s0 + i] = edge_id(u, j);
  m.adj[3 * s0 + i1] = t_ca;
  m.adj[3 * s0 + i2] = edge_id(t, i1);
  m.seg[3 * s0 + i] = g_bc;
  m.seg[3 * s0 + i1] = g_ca;
  m.seg[3 * s0 + i2] = kNoId;
  m.tri[3 * s1 + j] = d;
  m.tri[3 * s1 + j1] = p;
  m.tri[3 * s1 + j2] = b;
  m.adj[3 * s1 + j] = edge_id(t, i);
  m.adj[3 * s1 + j1] = u_bd;
  m.adj[3 * s1 + j2] = edge_id(u, j1);
  m.seg[3 * s1 + j] = g_bc;
  m.seg[3 * s1 + j1] = g_bd;
  m.seg[3 * s1 + j2] = kNoId;
  m.tri[3 * t + i2] = p;
  m.adj[3 * t + i] = edge_id(s1, j);
  m.adj[3 * t + i1] = edge_id(s0, i2);
  m.seg[3 * t + i1] = kNoId;
  m.tri[3 * u + j2] = p;
  m.adj[3 * u + j] = edge_id(s0, i);
  m.adj[3 * u + j1] = edge_id(s1, j2);
  m.seg[3 * u + j1] = kNoId;
  m.vert_tri[p] = t;
  if (own & kSplitOwnA) m.vert_tri[a] = t;
  if (own & kSplitOwnB) m.vert_tri[b] = t;
  if (own & kSplitOwnC) m.vert_tri[c] = u;
  if (own & kSplitOwnD) m.vert_tri[d] = u;
}

/// Where old edge k of container x of a winning point now lives. `edge` is the point's location edge in t
/// (3: inside t), j the matching edge of the second container (any x other than t), s0/s1 its new slots (see
/// split_triangle and split_edge).
CDT_HD_INLINE std::uint32_t split_forward(std::uint32_t x, std::uint32_t k, std::uint32_t t,
                                          std::uint32_t edge, std::uint32_t j, std::uint32_t s0,
                                          std::uint32_t s1) {
  if (edge == 3) return edge_id(k == 0 ? t : k == 1 ? s0 : s1, k);
  if (x == t) return edge_id(k == prev3(edge) ? t : s0, k);
  return edge_id(k == prev3(j) ? x : s1, k);
}

/// The order in which a round's points claim their containers (Algorithm 3 line 4): the mark is the
/// atomic minimum of claim_key(q), not of the list position q itself. The missing points are listed in
/// the points' order along a space-filling curve, so the lowest position in a container is a point at
/// the edge of that container's crowd, and splitting there leaves nearly all the crowd in one child:
/// points along a line (coastlines) or in a cluster then took one round each. The key is a bijection of
/// [0, 2^31) (multiplications by odd constants and a xor-shift, each invertible modulo 2^31) that
/// scatters neighbouring positions, so a container's winner is an arbitrary member of its crowd and the
/// rounds grow with the logarithm of the crowd, as in a random binary search tree. The smallest key
/// still wins every mark it makes, so each round inserts a point; kNoId is never a key.
inline constexpr std::uint32_t kClaimMask = 0x7FFFFFFFu;
inline constexpr std::uint32_t kClaimMul0 = 0x9E3779B1u, kClaimMul1 = 0x85EBCA6Bu;

/// The inverse of an odd c modulo 2^32 (so modulo 2^31 too), by Newton's iteration x <- x (2 - c x),
/// each step doubling the correct low bits (c is its own inverse modulo 8).
constexpr std::uint32_t inverse_of_odd(std::uint32_t c) {
  std::uint32_t x = c;
  for (int i = 0; i < 5; ++i) x *= 2u - c * x;
  return x;
}
inline constexpr std::uint32_t kClaimInv0 = inverse_of_odd(kClaimMul0),
                               kClaimInv1 = inverse_of_odd(kClaimMul1);
static_assert(kClaimMul0 * kClaimInv0 == 1u && kClaimMul1 * kClaimInv1 == 1u);

/// claim_key(q) for a list position q < 2^31 (insert_missing_points takes fewer than 2^31 - 1 points).
CDT_HD_INLINE std::uint32_t claim_key(std::uint32_t q) {
  std::uint32_t a = (q * kClaimMul0) & kClaimMask;
  a ^= a >> 16; // its own inverse on 31 bits
  return (a * kClaimMul1) & kClaimMask;
}

/// The list position whose claim_key is `key`, or kNoId for kNoId (no mark).
CDT_HD_INLINE std::uint32_t claim_holder(std::uint32_t key) {
  if (key == kNoId) return kNoId;
  std::uint32_t a = (key * kClaimInv1) & kClaimMask;
  a ^= a >> 16;
  return (a * kClaimInv0) & kClaimMask;
}

// Per missing point, after the marking: which container marks it holds, and whether it won them all.
enum : std::uint8_t { kHoldsT = 1, kHoldsU = 2, kWins = 4 };

/// Algorithm 3's claims in a round, per missing point q (its position in the list): its walk's start,
/// its location (containers t and u, edges e and j) and flags, and per slot the lowest claim_key marking
/// it; what every executor's rounds write before the splits (InsertRound reads them then).
struct InsertClaims {
  const MissingPoint* points;
  std::uint32_t* start; ///< the vertex its next walk starts from
  std::uint32_t* loc_t;
  std::uint32_t* loc_e;
  std::uint32_t* loc_u;
  std::uint32_t* loc_j;
  std::uint32_t* mark;
  std::uint8_t* flags;
};

/// Algorithm 3 lines 2-5 for q: walks from its start (from `fallback` when the start is in no triangle
/// and not waiting for insertion either) to the triangle or edge holding the point, and marks the
/// containers with claim_key(q) through claim_min(address, key), the executor's atomic minimum. A start
/// that is itself pending (pending[v] != 0) delays q, the paper's delay; a failed walk goes to
/// fail(status).
template <class Pending, class ClaimMin, class Fail>
CDT_HD inline void locate_and_claim(const MeshView& m, const InsertClaims& c, std::uint32_t q,
                                    const Pending* pending, std::uint32_t fallback, ClaimMin&& claim_min,
                                    Fail&& fail) {
  c.flags[q] = 0;
  c.loc_t[q] = kNoId;
  std::uint32_t o = c.start[q];
  if (o >= m.num_vertices || m.vert_tri[o] == kNoId) {
    if (o < m.num_vertices && pending[o] != 0) return; // the paper's delay: the hint is itself waiting
    o = fallback;
    c.start[q] = o;
  }
  const std::uint32_t v = c.points[q].vertex;
  const Vec2 p = m.xy[v];
  const MissingPointPlace at = place_missing_point(m, o, p.x, p.y);
  if (at.status != WorkStatus::ok) {
    fail(at.status);
    return;
  }
  c.loc_t[q] = at.tri;
  c.loc_e[q] = at.edge;
  c.loc_u[q] = at.u;
  c.loc_j[q] = at.j;
  const std::uint32_t key = claim_key(q);
  claim_min(c.mark + at.tri, key);
  if (at.u != kNoId) claim_min(c.mark + at.u, key);
}

/// Lines 6-13 for q, once every claim is in: which container marks it holds and whether it won them all;
/// a loser keeps a container vertex, which stays in the mesh, as its next start, so its next walk is
/// short.
CDT_HD_INLINE void settle_insert_claims(const MeshView& m, const InsertClaims& c, std::uint32_t q) {
  const std::uint32_t t = c.loc_t[q], u = c.loc_u[q];
  if (t == kNoId) return;
  const std::uint32_t key = claim_key(q);
  const bool holds_t = c.mark[t] == key;
  const bool holds_u = u != kNoId && c.mark[u] == key;
  const bool wins = holds_t && (u == kNoId || holds_u);
  c.flags[q] =
      static_cast<std::uint8_t>((holds_t ? kHoldsT : 0) | (holds_u ? kHoldsU : 0) | (wins ? kWins : 0));
  if (!wins) c.start[q] = m.tri[3 * t];
}

/// Whether q inserts its point this round (settle_insert_claims decided it).
CDT_HD_INLINE bool insert_claim_won(const InsertClaims& c, std::uint32_t q) {
  return (c.flags[q] & kWins) != 0;
}

/// A loser q whose container a winner splits lies in the winner's new fan, so the winner's vertex, whose
/// fan is just those three or four triangles, is a better start than a corner of the old container:
/// without Delaunay flips between rounds the old corners of crowded regions collect huge fans, and every
/// walk starting there would scan one. After every settle_insert_claims of the round.
CDT_HD_INLINE void restart_at_winner(const InsertClaims& c, std::uint32_t q) {
  if (c.loc_t[q] == kNoId || insert_claim_won(c, q)) return;
  const std::uint32_t containers[2] = {c.loc_t[q], c.loc_u[q]};
  for (const std::uint32_t x : containers) {
    if (x == kNoId) continue;
    const std::uint32_t w = claim_holder(c.mark[x]);
    if (w != kNoId && insert_claim_won(c, w)) {
      c.start[q] = c.points[w].vertex;
      return;
    }
  }
}

/// Gives back the marks q holds, after the round's splits (each mark has one holder, which clears it, so
/// no two threads touch one mark).
CDT_HD_INLINE void clear_insert_claims(const InsertClaims& c, std::uint32_t q) {
  if (c.flags[q] & kHoldsT) c.mark[c.loc_t[q]] = kNoId;
  if (c.flags[q] & kHoldsU) c.mark[c.loc_u[q]] = kNoId;
}

/// A round of Algorithm 3 seen by one point: per missing point (by its position in the list) its
/// location (containers t and u, edges e and j; u = kNoId inside t), its new slots and its flags, and
/// per slot the lowest claim_key marking it.
struct InsertRound {
  const std::uint32_t* loc_t = nullptr;
  const std::uint32_t* loc_e = nullptr;
  const std::uint32_t* loc_u = nullptr;
  const std::uint32_t* loc_j = nullptr;
  const std::uint32_t* new0 = nullptr;
  const std::uint32_t* new1 = nullptr;
  const std::uint32_t* mark = nullptr;
  const std::uint8_t* flags = nullptr;
};

/// Algorithm 3 lines 14-16 for winner q: bit c set when the container corner c (t's corners from the
/// location edge on, then u's far corner) has its vert_tri in a container, so that this split rewrites it.
/// Decided while vert_tri is read-only.
CDT_HD inline std::uint8_t split_corner_owners(const MeshView& m, const InsertRound& r, std::uint32_t q) {
  const std::uint32_t t = r.loc_t[q], u = r.loc_u[q], e = r.loc_e[q];
  const std::uint32_t first = e == 3 ? 0 : e;
  const std::uint32_t corners[4] = {m.tri[3 * t + first], m.tri[3 * t + next3(first)],
                                    m.tri[3 * t + prev3(first)],
                                    u == kNoId ? kNoId : m.tri[3 * u + r.loc_j[q]]};
  std::uint8_t bits = 0;
  for (std::uint32_t c = 0; c < 4; ++c) {
    if (corners[c] == kNoId) continue;
    const std::uint32_t vt = m.vert_tri[corners[c]];
    if (vt == t || (u != kNoId && vt == u)) bits = static_cast<std::uint8_t>(bits | (1u << c));
  }
  return bits;
}

/// Algorithm 3 lines 20-22 for winner q, after every split of the round: its new outer edges still hold
/// their old neighbour edges; a neighbour split in this round is forwarded by arithmetic and writes its
/// own side, a static one is written from here.
CDT_HD inline void link_split_outer_edges(const MeshView& m, const InsertRound& r, std::uint32_t q) {
  const std::uint32_t t = r.loc_t[q], u = r.loc_u[q], e = r.loc_e[q], j = r.loc_j[q];
  std::uint32_t outer[4];
  std::uint32_t count = 0;
  if (e == 3) {
    outer[count++] = edge_id(t, 0);
    outer[count++] = edge_id(r.new0[q], 1);
    outer[count++] = edge_id(r.new1[q], 2);
  } else {
    outer[count++] = edge_id(t, prev3(e));
    outer[count++] = edge_id(r.new0[q], next3(e));
    outer[count++] = edge_id(u, prev3(j));
    outer[count++] = edge_id(r.new1[q], next3(j));
  }
  for (std::uint32_t k = 0; k < count; ++k) {
    const std::uint32_t ne = outer[k];
    const std::uint32_t old = m.adj[ne];
    if (old == kNoId) continue;
    const std::uint32_t x = edge_tri(old);
    const std::uint32_t w = claim_holder(r.mark[x]);
    if (w != kNoId && (r.flags[w] & kWins) != 0) {
      m.adj[ne] = split_forward(x, edge_index(old), r.loc_t[w], r.loc_e[w], r.loc_j[w], r.new0[w], r.new1[w]);
    } else {
      m.adj[old] = ne;
    }
  }
}

} // namespace cdt::detail
