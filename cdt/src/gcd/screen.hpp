#pragma once
// Screening the input segments against the Delaunay triangulation of the sites, before they are split.
// The per-piece work (screen_edge, screen_corridor) runs on the host and on the device
// (gpu::DeviceMesh::screen).
//
// An edge of a triangulation contains no vertex in its interior and crosses no other edge. So once the
// sites are triangulated, a segment that is an edge of the mesh (on real data nearly all of them: 98%
// of the coastlines' segments) needs no test against the others: whatever can pass through a vertex,
// cross or overlap involves a segment that is not an edge. Such a segment crosses, between its ends,
// only the triangles of its corridor, and every site on it and every edge-segment it crosses belongs
// to them; and where two segments that are no edges cross, the crossing lies in a triangle (or on an
// edge, between two) that both corridors hold. So a segment that is no edge is suspect only when a
// site lies on it, when it crosses an edge-segment, or when it crosses another whose corridor shares
// a triangle with its own; the rest (every segment of an input without crossings, but for points on
// segments) meet nothing. Two such segments can meet only by crossing properly: an end of one on the
// other is a site on it, which its walk finds, and so is an overlap. A triangle that two corridors
// share is settled by testing the two exactly. One that three or more share is a crowd (on the
// coastlines a few thousand triangles, where dense shores pass the sites' large triangles): its short
// members walk their corridors once more, each listing itself in the crowds it passes, and every pair
// of a crowd is then tested exactly. A crowd that a far piece passes (longer than kCrowdSteps times
// the vertices' even spacing: one whose walk again would cost more than the split it spares) keeps all
// its members suspect, and so does one of more than kCrowdLimit listings. The suspects are those, the
// edge-segments they cross, and the sites on them; split_pieces then resolves the suspects alone
// (cdt/src/pslg.hpp), finding in its first round exactly the pairs it would find among all. Where a
// crossing may be (a crossed edge-segment, a triangle of a crossing pair or of a crowd kept suspect),
// the triangles there, their sites and the segments on their edges are suspect too: a crossing's
// rounded vertex lies there, and the repair rounds test what passes near it.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "cdt/cdt.hpp"

#include "gcd/constraints.hpp"
#include "gcd/flip.hpp"
#include "gcd/mesh.hpp"

namespace cdt::detail {

class CpuExecutor;

struct ScreenedPieces {
  /// False when a corridor walk failed (an end not in the mesh, or a walk leaving it): every piece and
  /// site is to be treated as suspect.
  bool complete = true;
  std::vector<std::uint32_t> pieces; ///< suspect pieces: indices into the screened list, increasing
  std::vector<std::uint32_t> sites;  ///< suspect sites: mesh vertex ids, increasing
  /// A site lies on a piece or two pieces cross: the split will change the pieces. (Without, it may
  /// still, where a crowd is kept suspect.)
  bool changes = false;
};

/// Screens pieces (mesh vertex ids; the id field is ignored) against a triangulation whose vertices
/// include every end. Reads the mesh only; the result does not depend on the thread count.
ScreenedPieces screen_pieces(const MeshView& m, std::span<const ConstraintPiece2> pieces,
                             CpuExecutor& executor);

/// triangulate() on the CPU executor with the segments split before the sites are triangulated, every
/// one against every other, as the GPU backend does: what screening is compared with.
Triangulation triangulate_splitting_first(std::span<const Point> points, std::span<const Segment> segments,
                                          const Options& options);

/// A part of a long segment's walk (walk_corridor): it starts inside triangle `tri`, which the segment
/// a-b crosses as walk_entry(m, a, b, tri, at) found (kNoId: at a, as the whole walk), and ends with the
/// edge through which the segment enters triangle `stop` (kNoId: at b); met_stop tells that it did.
struct CorridorPart {
  std::uint32_t tri = kNoId;
  WalkEntry at;
  std::uint32_t stop = kNoId;
  bool met_stop = false;
};

/// Follows segment a-b through the mesh: calls on_vertex(v) for a, b and every vertex on the segment
/// between them, crossed(e) for every edge whose interior it crosses (e encoded in the triangle it
/// leaves), and along(e) for every edge it runs along, from one vertex on it to the next (e encoded in
/// either triangle at it). Returns false when the walk fails (an end has no triangle, the segment leaves the
/// mesh, or the links are inconsistent). With `part`, only that part of the walk (on_vertex(a) only for
/// a part from a): the parts of a walk between the triangles of some of its points make its calls, each
/// once.
template <class OnVertex, class Crossed, class Along>
CDT_HD bool walk_corridor(const MeshView& m, std::uint32_t a, std::uint32_t b, OnVertex&& on_vertex,
                          Crossed&& crossed, Along&& along, CorridorPart* part = nullptr) {
  std::uint32_t cur = a;
  // The edge the walk crosses next, with its ends on the left (l) and right (r) of cur -> b; kNoId
  // while the walk stands at cur.
  std::uint32_t edge = kNoId, l = kNoId, r = kNoId;
  if (part != nullptr && part->tri != kNoId) {
    edge = part->at.exit; // inside the part's triangle: its way out (walk_entry)
    l = part->at.l;
    r = part->at.r;
  } else {
    on_vertex(a);
  }
  for (std::uint32_t legs = 0; legs <= m.num_vertices; ++legs) {
    if (edge == kNoId) {
      // Around cur (counter-clockwise, then clockwise from the start when its fan is open): b itself, a
      // vertex on the open segment cur-b (the nearest one, as edges hold no vertex), or the triangle
      // that the segment leaves cur through.
      const std::uint32_t start = m.vert_tri[cur];
      if (start == kNoId || m.vert_tri[b] == kNoId) return false;
      std::uint32_t next = kNoId, wedge = kNoId;
      std::uint32_t t = start;
      bool clockwise = false;
      for (std::uint32_t steps = 0; next == kNoId && wedge == kNoId; ++steps) {
        if (steps > m.num_slots) return false;
        const std::uint32_t k = m.index_of(t, cur);
        if (k == 3) return false;
        const std::uint32_t p = m.v(t, next3(k)), q = m.v(t, prev3(k));
        // The edge cur-p is edge prev3(k) of t, the edge cur-q edge next3(k).
        if (p == b || q == b) {
          along(edge_id(t, p == b ? prev3(k) : next3(k)));
          on_vertex(b);
          return true;
        }
        const int op = orient_vertices(m, cur, p, b), oq = orient_vertices(m, cur, q, b);
        if (op == 0 && same_direction(m, cur, p, b)) next = p;
        if (oq == 0 && same_direction(m, cur, q, b)) next = q;
        if (next != kNoId) {
          along(edge_id(t, next == p ? prev3(k) : next3(k)));
          break;
        }
        if (op > 0 && oq < 0) {
          wedge = t;
          break;
        }
        const std::uint32_t e = m.adj[edge_id(t, clockwise ? prev3(k) : next3(k))];
        if (e == kNoId) {
          if (clockwise) return false;
          clockwise = true;
          t = start;
          continue;
        }
        t = edge_tri(e);
        if (t == start) return false;
      }
      if (next != kNoId) {
        cur = next;
        on_vertex(cur);
        continue;
      }
      const std::uint32_t k = m.index_of(wedge, cur);
      r = m.v(wedge, next3(k));
      l = m.v(wedge, prev3(k));
      edge = edge_id(wedge, k);
    }
    // Through the triangles.
    for (std::uint32_t steps = 0;; ++steps) {
      if (steps > m.num_slots) return false;
      crossed(edge);
      const std::uint32_t e = m.adj[edge];
      if (e == kNoId) return false;
      const std::uint32_t n = edge_tri(e);
      if (part != nullptr && n == part->stop) {
        part->met_stop = true;
        return true;
      }
      const std::uint32_t apex = m.v(n, edge_index(e));
      if (apex == b) {
        on_vertex(b);
        return true;
      }
      const int side = orient_vertices(m, cur, b, apex);
      if (side == 0) {
        cur = apex; // a vertex on the segment: on from there
        on_vertex(cur);
        edge = kNoId;
        break;
      }
      const std::uint32_t opposite = m.index_of(n, side > 0 ? l : r);
      if (opposite == 3) return false;
      edge = edge_id(n, opposite);
      (side > 0 ? l : r) = apex;
    }
  }
  return false;
}

/// The screen's first pass for piece k (mesh vertex ids a, b): when the piece is an edge of the mesh,
/// records it in piece_on (3 per slot, one entry per side of every edge) and returns true; false when
/// it is to be walked. Pieces are distinct vertex pairs, so every entry has one writer.
CDT_HD_INLINE bool screen_edge(const MeshView& m, const ConstraintPiece2& p, std::uint32_t k,
                               std::uint32_t* piece_on) {
  const std::uint32_t edge = find_mesh_edge(m, p.a, p.b);
  if (edge == kNoId) return false;
  piece_on[edge] = k;
  if (m.adj[edge] != kNoId) piece_on[m.adj[edge]] = k;
  return true;
}

/// The screen's marks around triangle t: flag(site[v]) for its corners, flag(suspect[q]) for the pieces
/// on its edges.
template <class Flag>
CDT_HD void screen_mark_triangle(const MeshView& m, std::uint32_t t, const std::uint32_t* piece_on,
                                 std::uint8_t* suspect, std::uint8_t* site, Flag&& flag) {
  for (std::uint32_t i = 0; i < 3; ++i) {
    flag(site[m.v(t, i)]);
    const std::uint32_t q = piece_on[edge_id(t, i)];
    if (q != kNoId) flag(suspect[q]);
  }
}

/// True when pieces p and q (mesh vertex ids) cross at a single point interior to both. Two pieces that
/// are no edges meet only so or where a vertex lies on one of them (see above).
CDT_HD_INLINE bool pieces_cross(const MeshView& m, const ConstraintPiece2& p, const ConstraintPiece2& q) {
  if (p.a == q.a || p.a == q.b || p.b == q.a || p.b == q.b) return false;
  const int oa = orient_vertices(m, p.a, p.b, q.a), ob = orient_vertices(m, p.a, p.b, q.b);
  if (!((oa > 0 && ob < 0) || (oa < 0 && ob > 0))) return false;
  const int oc = orient_vertices(m, q.a, q.b, p.a), od = orient_vertices(m, q.a, q.b, p.b);
  return (oc > 0 && od < 0) || (oc < 0 && od > 0);
}

/// Calls claim(t) for each triangle of the corridor of a-b: both sides of every edge it crosses or runs
/// along (two segments that cross do so inside a triangle or inside an edge, and then both pass the
/// triangles there), some more than once. crossed(e) and on_vertex(v) as walk_corridor's.
template <class OnVertex, class Crossed, class Claim>
CDT_HD bool walk_corridor_triangles(const MeshView& m, std::uint32_t a, std::uint32_t b, OnVertex&& on_vertex,
                                    Crossed&& crossed, Claim&& claim, CorridorPart* part = nullptr) {
  const auto both_sides = [&](std::uint32_t e) {
    claim(edge_tri(e));
    if (m.adj[e] != kNoId) claim(edge_tri(m.adj[e]));
  };
  return walk_corridor(
      m, a, b, on_vertex,
      [&](std::uint32_t e) {
        both_sides(e);
        crossed(e);
      },
      both_sides, part);
}

/// Pieces longer than this many times the vertices' even spacing are far: their crowds are not listed.
/// At 10M points + 1M segments (H200 machine) listing the crowds of every piece cost 5.4 ms, their
/// long pieces' walks again; the coastlines' crowds are of short pieces.
inline constexpr double kCrowdSteps = 24.0;
/// Listings a crowd holds (a piece listed once for every run of its walk through the triangle); one
/// listed more keeps its members suspect: a bound on one thread's pairs and on the lists' memory.
inline constexpr std::uint32_t kCrowdLimit = 16;

/// The squared length above which a piece is far, among num_vertices vertices in a width x height box:
/// kCrowdSteps times their spacing were they spread evenly (along the box when it is a line); infinite,
/// so that none is far, when the box has no extent or there are fewer than 3 vertices.
inline double far_piece_length2(double width, double height, std::uint32_t num_vertices) {
  const double extent = width > height ? width : height;
  if (num_vertices < 3 || !(extent > 0.0) || !(extent < std::numeric_limits<double>::infinity()))
    return std::numeric_limits<double>::infinity();
  const double far = kCrowdSteps * even_spacing(width, height, num_vertices);
  return far * far;
}

/// Whether piece p is far (longer than the square root of far2).
CDT_HD_INLINE bool piece_is_far(const MeshView& m, const ConstraintPiece2& p, double far2) {
  const double dx = m.xy[p.b].x - m.xy[p.a].x, dy = m.xy[p.b].y - m.xy[p.a].y;
  return dx * dx + dy * dy > far2;
}

/// The screen's per-slot and per-piece marks, shared by its passes (flag sets a byte to 1; only 1 is
/// ever stored, so several threads may flag the same byte).
struct ScreenMarks {
  const std::uint32_t* piece_on; ///< per edge side, the piece lying on it
  std::uint32_t* first;          ///< per slot, the first piece to claim it
  std::uint32_t* second;         ///< per slot, the second
  std::uint8_t* crowded;         ///< per slot: three or more claimed it
  std::uint8_t* far_crowd;       ///< per slot: crowded, and a far piece among them
  std::uint8_t* in_crowd;        ///< per piece: short, in a crowd (to be listed)
  std::uint8_t* suspect;         ///< per piece
  std::uint8_t* site;            ///< per vertex: suspect
  std::uint8_t* changes;         ///< one byte: the split will change the pieces
};

/// Claims triangle t for piece k (far: piece_is_far) among the pieces through it: first[t] and
/// second[t] take the first two pieces to claim it (swap(word, kNoId, k), an atomic compare-and-swap
/// returning the word's old value); a third flags crowded[t], and then either flags itself suspect and
/// the crowd far, or, short, in_crowd. A piece that claims a triangle again, from another part of its
/// walk or walked whole again, finds itself there and changes nothing, so the result does not depend
/// on the order.
template <class Flag, class Swap>
CDT_HD_INLINE void screen_claim(std::uint32_t t, std::uint32_t k, bool far, const ScreenMarks& s, Flag&& flag,
                                Swap&& swap) {
  std::uint32_t there = swap(&s.first[t], kNoId, k);
  if (there == kNoId || there == k) return;
  there = swap(&s.second[t], kNoId, k);
  if (there == kNoId || there == k) return;
  flag(s.crowded[t]);
  if (far) {
    flag(s.suspect[k]);
    flag(s.far_crowd[t]);
  } else {
    flag(s.in_crowd[k]);
  }
}

/// The screen's second pass for piece k, which is no edge. For every site strictly between its ends,
/// flag(site[v]) and flag(suspect[k]); at every edge-piece it crosses, flag(suspect[k]) and the marks
/// around the two triangles there; each triangle of its corridor it claims (screen_claim). Either
/// meeting also flags `changes`. Returns false when the walk fails.
template <class Flag, class Swap>
CDT_HD bool screen_corridor(const MeshView& m, const ConstraintPiece2& p, std::uint32_t k, double far2,
                            const ScreenMarks& s, Flag&& flag, Swap&& swap, CorridorPart* part = nullptr) {
  const bool far = piece_is_far(m, p, far2);
  return walk_corridor_triangles(
      m, p.a, p.b,
      [&](std::uint32_t v) {
        if (v == p.a || v == p.b) return;
        flag(s.site[v]);
        flag(s.suspect[k]);
        flag(*s.changes);
      },
      [&](std::uint32_t e) {
        if (s.piece_on[e] == kNoId) return;
        flag(s.suspect[k]);
        flag(*s.changes);
        screen_mark_triangle(m, edge_tri(e), s.piece_on, s.suspect, s.site, flag);
        if (m.adj[e] != kNoId)
          screen_mark_triangle(m, edge_tri(m.adj[e]), s.piece_on, s.suspect, s.site, flag);
      },
      [&](std::uint32_t t) { screen_claim(t, k, far, s, flag, swap); }, part);
}

/// The screen's third pass for triangle t, after the second pass is done everywhere: when two pieces
/// pass t, they are tested exactly (the higher against the lower) and, when they cross, flagged suspect
/// with the marks around t (and `changes`). When three or more do, the first two are marked as the
/// others marked themselves (suspect, and the crowd far, when far; else in_crowd), and a far crowd
/// gets the marks around t.
template <class Flag>
CDT_HD_INLINE void screen_settle_triangle(const MeshView& m, const ConstraintPiece2* pieces, std::uint32_t t,
                                          double far2, const ScreenMarks& s, Flag&& flag) {
  const std::uint32_t j = s.second[t];
  if (j == kNoId) return;
  const std::uint32_t i = s.first[t];
  if (s.crowded[t] != 0) {
    for (const std::uint32_t k : {i, j}) {
      if (piece_is_far(m, pieces[k], far2)) {
        flag(s.suspect[k]);
        flag(s.far_crowd[t]);
      } else {
        flag(s.in_crowd[k]);
      }
    }
    if (s.far_crowd[t] != 0) screen_mark_triangle(m, t, s.piece_on, s.suspect, s.site, flag);
    return;
  }
  const std::uint32_t lo = i < j ? i : j, hi = i < j ? j : i;
  if (!pieces_cross(m, pieces[hi], pieces[lo])) return;
  flag(*s.changes);
  flag(s.suspect[i]);
  flag(s.suspect[j]);
  screen_mark_triangle(m, t, s.piece_on, s.suspect, s.site, flag);
}

/// The crowds' lists: crowds that no far piece passes, numbered; per such crowded slot t its number
/// crowd_of[t] (the slot's first word, settled), per crowd its listings' count and up to `limit` of
/// them, crowd c's at members[c * limit].
struct CrowdLists {
  const std::uint32_t* crowd_of;
  std::uint32_t* count;
  std::uint32_t* members;
  std::uint32_t limit;
};

/// Listings each of num_crowds crowds holds: kCrowdLimit, fewer where that would take more words than
/// the mesh has slots (every crowd then fills sooner, and keeps its members suspect).
inline std::uint32_t crowd_list_limit(std::size_t num_crowds, std::uint32_t num_slots) {
  if (num_crowds == 0) return kCrowdLimit;
  const std::size_t fit = num_slots / num_crowds;
  return fit < kCrowdLimit ? static_cast<std::uint32_t>(fit) : kCrowdLimit;
}

/// The crowds' walk of piece k (in_crowd, so short): lists k in each crowd its corridor passes (once
/// for each run of its walk through the crowd; add(word) an atomic increment returning the old value),
/// or flags it suspect where the crowd is far or its list full. Returns false when the walk fails.
template <class Flag, class Add>
CDT_HD bool screen_list_in_crowds(const MeshView& m, const ConstraintPiece2& p, std::uint32_t k,
                                  const ScreenMarks& s, const CrowdLists& lists, Flag&& flag, Add&& add) {
  std::uint32_t last = kNoId;
  const auto nothing = [](std::uint32_t) {};
  return walk_corridor_triangles(m, p.a, p.b, nothing, nothing, [&](std::uint32_t t) {
    if (t == last || s.crowded[t] == 0) return;
    last = t;
    if (s.far_crowd[t] != 0) {
      flag(s.suspect[k]);
      return;
    }
    const std::uint32_t c = lists.crowd_of[t];
    const std::uint32_t at = add(&lists.count[c]);
    if (at < lists.limit) {
      lists.members[static_cast<std::size_t>(c) * lists.limit + at] = k;
    } else {
      flag(s.suspect[k]);
    }
  });
}

/// Settles crowd c in slot t once every member is listed: every two distinct members are tested
/// exactly (the higher against the lower), and those that cross are flagged suspect, with `changes`
/// and the marks around t. A crowd listed more than lists.limit times flags the listed suspect (the
/// others flagged themselves), with the marks around t.
template <class Flag>
CDT_HD_INLINE void screen_settle_crowd(const MeshView& m, const ConstraintPiece2* pieces, std::uint32_t c,
                                       std::uint32_t t, const ScreenMarks& s, const CrowdLists& lists,
                                       Flag&& flag) {
  const std::uint32_t* members = lists.members + static_cast<std::size_t>(c) * lists.limit;
  const std::uint32_t n = lists.count[c];
  if (n > lists.limit) {
    for (std::uint32_t a = 0; a < lists.limit; ++a) flag(s.suspect[members[a]]);
    screen_mark_triangle(m, t, s.piece_on, s.suspect, s.site, flag);
    return;
  }
  bool crossing = false;
  for (std::uint32_t a = 1; a < n; ++a) {
    for (std::uint32_t b = 0; b < a; ++b) {
      const std::uint32_t i = members[a], j = members[b];
      if (i == j) continue;
      const std::uint32_t lo = i < j ? i : j, hi = i < j ? j : i;
      if (!pieces_cross(m, pieces[hi], pieces[lo])) continue;
      flag(s.suspect[i]);
      flag(s.suspect[j]);
      crossing = true;
    }
  }
  if (!crossing) return;
  flag(*s.changes);
  screen_mark_triangle(m, t, s.piece_on, s.suspect, s.site, flag);
}

} // namespace cdt::detail
