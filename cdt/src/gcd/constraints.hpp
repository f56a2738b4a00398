#pragma once
// Step 2 of the CDT (paper section 4, Algorithms 4 and 5): inserting constraints into a triangulation by
// flipping only.
//
// Outer loop (section 4.1): one thread per pending piece walks from the fan of its first endpoint along
// the piece and marks every triangle it crosses with the piece's index by atomic minimum, so all the
// triangles of the lowest pending piece carry its index (what the proof of section 4.3 needs).
// Inner loop (section 4.2, Algorithm 5): one thread per marked triangle A looks at its next triangle C and
// previous triangle B along its piece, classifies the pairs as in Figure 4 (zero, single, double
// intersection, concave) and flips (A, C) in Case 1, 2 or 3 of Figure 5, claiming A, C (and B for the
// look-ahead cases) with a label that puts Case 1 before Case 2 before Case 3.
//
// "Intersects" always means the open piece meets the interior of the triangle; by precondition no vertex
// lies on an open piece, so a piece enters and leaves a triangle through the interiors of its edges.

#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "cdt/detail/host_device.hpp"
#include "cdt/detail/predicates.hpp"
#include "gcd/flip.hpp"
#include "gcd/mesh.hpp"

namespace cdt::detail {

class CpuExecutor;

/// One constraint piece: the segment between mesh vertices a != b; id is stored into seg on both sides of
/// the edge once it is in the mesh.
struct ConstraintPiece2 {
  std::uint32_t a, b, id;
};

struct ConstraintStats {
  std::uint64_t flips = 0;            ///< flips performed to insert the pieces
  std::uint64_t outer_iterations = 0; ///< marking passes (the last one only confirms that all are in)
  std::uint64_t inner_iterations = 0; ///< flipping passes, over all outer iterations
  std::uint64_t intersections = 0;    ///< piece-triangle intersections before the first flip (paper Fig. 13)
};

/// Makes every piece an edge of the mesh (setting seg on both sides to its id) by flips only.
/// Preconditions: the mesh is a valid triangulation containing every piece's endpoints; no piece crosses
/// another piece or passes through a vertex other than its endpoints (the caller splits them beforehand);
/// pieces do not cross constraint edges already in the mesh. inner_iterations bounds the flipping passes
/// per marking pass (the paper suggests 5 to 10; 0 counts as 1). Duplicate pieces are allowed: their edge
/// gets the smallest id. Throws Error on a violated precondition that it detects (instead of looping) and
/// when the mesh has 2^30 slots or more (the labels keep 2 bits for the case).
/// With `flipped` (one byte per slot, num_slots of them), sets flipped[t] = 1 for every slot t that a flip
/// rewrote (the others keep their value): the triangles whose edges Step 3 must check.
ConstraintStats insert_constraints(Mesh& mesh, std::span<const ConstraintPiece2> pieces,
                                   unsigned inner_iterations, CpuExecutor& executor,
                                   std::uint8_t* flipped = nullptr);

/// The same, throwing Error once more than max_inner_iterations flipping passes have run in total (a hang
/// guard for tests; the 4-argument form uses 16 n^2 + 10^7 for n vertices, far above the Theta(n^2) flips of
/// Claim 3, since every pass flips at least once).
ConstraintStats insert_constraints(Mesh& mesh, std::span<const ConstraintPiece2> pieces,
                                   unsigned inner_iterations, CpuExecutor& executor,
                                   std::uint64_t max_inner_iterations, std::uint8_t* flipped = nullptr);

/// The same result scheduled for CPU threads: one parallel pass walks every piece (setting seg for
/// the pieces that are edges already, most of them after Phase 5), then the others go in one by one by
/// Sloan's edge flipping: the edges a piece crosses wait in a queue; one whose quadrilateral is
/// strictly convex is flipped, and the new diagonal goes back into the queue while it still crosses
/// the piece. Pieces go to the fixed parts of the slots (part_lawson.hpp) by their first end; each
/// part's thread inserts its pieces in order as long as their walks and flips stay within its slots,
/// and one thread that owns every slot then inserts what the parts left, in order. The result does
/// not depend on the thread count. Algorithm 5's parallel passes spend most of their time re-reading
/// the marked triangles of every pending piece; this flips each crossing once or a few times. Same
/// preconditions, errors and `flipped` flags as insert_constraints; outer_iterations counts the
/// walking pass (1, or 2 when any piece needed flips), inner_iterations the queue's pops.
ConstraintStats insert_constraints_one_by_one(Mesh& mesh, std::span<const ConstraintPiece2> pieces,
                                              CpuExecutor& executor, std::uint8_t* flipped = nullptr);

/// The hang guard of the 4-argument insert_constraints for n vertices: 16 n^2 + 10^7 inner iterations.
std::uint64_t constraint_iteration_bound(std::uint64_t n);

/// Labels keep 2 bits for the case above the slot index: meshes of at most 2^30 slots.
inline constexpr std::uint32_t kMaxConstraintSlots = 1u << 30;

/// insert_constraints' checks before any work: the slot limit, the piece count, every piece's endpoints
/// distinct vertices of the mesh. Throws Error naming the first bad piece.
void check_constraint_pieces(std::uint32_t num_slots, std::uint32_t num_vertices,
                             std::span<const ConstraintPiece2> pieces);

/// The first two of those checks alone (the device tests the pieces on its own copy).
void check_constraint_counts(std::uint32_t num_slots, std::size_t num_pieces);

/// The spacing of num_vertices (at least 1) spread evenly over a width x height box, or along it when it
/// is a line: the unit of the pieces' lengths that decide how they are walked and screened.
inline double even_spacing(double width, double height, std::uint32_t num_vertices) {
  const double area = width * height;
  return area > 0.0 ? std::sqrt(area / num_vertices) : (width > height ? width : height) / num_vertices;
}

/// Whether a piece's endpoints are distinct vertices of a mesh of num_vertices.
CDT_HD_INLINE bool piece_endpoints_valid(const ConstraintPiece2& p, std::uint32_t num_vertices) {
  return p.a < num_vertices && p.b < num_vertices && p.a != p.b;
}

/// The error for piece k with invalid endpoints.
[[noreturn]] void throw_invalid_piece(std::size_t k, const ConstraintPiece2& p);

// --- per-element work (host and device) --------------------------------------------------------------

/// Result of a per-element step. Values from vertex_on_piece on are errors; the driver reports the one of
/// the lowest-indexed element, so the message does not depend on the thread count.
enum class ConstraintStatus : std::uint32_t {
  ok = 0,
  present = 1,              ///< the piece is already an edge of the mesh
  vertex_on_piece = 2,      ///< a mesh vertex lies on the open piece (precondition)
  crosses_constraint = 3,   ///< the piece crosses a constraint edge (precondition)
  leaves_mesh = 4,          ///< the piece leaves the triangulated domain
  endpoint_not_in_mesh = 5, ///< an endpoint has no incident triangle
  corrupt_mesh = 6,         ///< links or marks are inconsistent
};

/// What an error status means, for the message of the error it becomes.
const char* constraint_status_message(ConstraintStatus s);

/// Figure 4: what flipping a pair of adjacent triangles that a piece crosses gives.
enum class PairConfig : std::uint8_t {
  zero_intersection,   ///< the new diagonal is the piece
  single_intersection, ///< the piece meets one new triangle
  double_intersection, ///< the piece crosses the new diagonal
  concave,             ///< the quadrilateral is not strictly convex: no flip
};

/// Figure 5: why a pair (A, C) may flip. Case 1 zero or single intersection; Case 2 (B, A) and (A, C)
/// double and (B, A') single after the flip; Case 3 (A, C) double, (B, A) concave and (B, A') double
/// (3a) or single (3b) after the flip, A' being B's new next triangle.
enum class FlipCase : std::uint8_t { none, case1, case2, case3a, case3b };

/// Edges (0..2) through which a piece enters and leaves a triangle along its direction a -> b; 3 where the
/// triangle holds the endpoint instead.
struct ChainLinks {
  std::uint32_t entry = 3;
  std::uint32_t exit = 3;
};

/// What triangle A proposes: flip the pair across `edge` (encoded, A's side), for `flip_case`, claiming
/// also `prev` (B, for Cases 2 and 3).
struct FlipProposal {
  std::uint32_t edge = kNoId;
  std::uint32_t prev = kNoId;
  FlipCase flip_case = FlipCase::none;
};

/// Label of a proposal for the atomic-minimum claims: 2 bits of priority (Case 1 < Case 2 < Case 3, lower
/// wins) above 30 bits of A's slot, so labels are unique and the lowest label always holds all its claims.
CDT_HD_INLINE std::uint32_t constraint_flip_label(FlipCase c, std::uint32_t a_slot) {
  const std::uint32_t priority = c == FlipCase::case1 ? 0u : c == FlipCase::case2 ? 1u : 2u;
  return (priority << 30) | a_slot;
}

/// orient_test (flip.hpp), where an orientation the filter cannot decide sets *undecided and reads as
/// 0: the device's proposal kernel runs the filters alone, with few registers, and asks the exact tests
/// again only for the proposals that met an undecided orientation (whose other results it discards).
template <bool kExact>
CDT_HD_INLINE int orient_or_undecided(const MeshView& m, std::uint32_t a, std::uint32_t b, std::uint32_t c,
                                      bool* undecided) {
  const int sign = orient_test<kExact>(m, a, b, c);
  if (sign != kUndecided) return sign;
  *undecided = true;
  return 0;
}

/// Classifies the pair of triangles (w, u, v) and (z, v, u) sharing the edge u-v, which the piece a-b
/// crosses in its interior (so u, v are not endpoints), by the diagonal w-z a flip would create.
template <bool kExact = true>
CDT_HD inline PairConfig classify_pair(const MeshView& m, std::uint32_t w, std::uint32_t u, std::uint32_t v,
                                       std::uint32_t z, std::uint32_t a, std::uint32_t b,
                                       bool* undecided = nullptr) {
  // Strictly convex exactly when u and v lie strictly on opposite sides of the new diagonal.
  const int ou = orient_or_undecided<kExact>(m, w, z, u, undecided);
  const int ov = orient_or_undecided<kExact>(m, w, z, v, undecided);
  if (!((ou > 0 && ov < 0) || (ou < 0 && ov > 0))) return PairConfig::concave;
  if ((w == a && z == b) || (w == b && z == a)) return PairConfig::zero_intersection;
  // A diagonal from an endpoint of the piece cannot cross it. Otherwise the piece passes through the whole
  // quadrilateral (its endpoints are outside), so it crosses the diagonal iff w and z are on opposite
  // sides of its line.
  if (w == a || w == b || z == a || z == b) return PairConfig::single_intersection;
  const int ow = orient_or_undecided<kExact>(m, a, b, w, undecided);
  const int oz = orient_or_undecided<kExact>(m, a, b, z, undecided);
  return (ow > 0 && oz < 0) || (ow < 0 && oz > 0) ? PairConfig::double_intersection
                                                  : PairConfig::single_intersection;
}

/// True when the open segment a-b meets the interior of triangle t. Two convex sets have disjoint
/// interiors exactly when a line along an edge of one of them separates them (weakly).
CDT_HD inline bool triangle_crosses_segment(const MeshView& m, std::uint32_t t, std::uint32_t a,
                                            std::uint32_t b) {
  int side[3];
  for (std::uint32_t i = 0; i < 3; ++i) {
    const std::uint32_t p = m.v(t, next3(i)), q = m.v(t, prev3(i));
    if (orient_vertices(m, p, q, a) <= 0 && orient_vertices(m, p, q, b) <= 0) return false;
    side[i] = orient_vertices(m, a, b, m.v(t, i));
  }
  const bool all_left = side[0] >= 0 && side[1] >= 0 && side[2] >= 0;
  const bool all_right = side[0] <= 0 && side[1] <= 0 && side[2] <= 0;
  return !all_left && !all_right;
}

/// Entry and exit edges of triangle t, which the piece a-b intersects (see ChainLinks).
template <bool kExact = true>
CDT_HD inline ConstraintStatus chain_links(const MeshView& m, std::uint32_t t, std::uint32_t a,
                                           std::uint32_t b, ChainLinks& out, bool* undecided = nullptr) {
  out = ChainLinks{};
  const std::uint32_t ka = m.index_of(t, a), kb = m.index_of(t, b);
  if (ka < 3 && kb < 3) return ConstraintStatus::corrupt_mesh; // the piece is an edge of t: not crossing it
  if (ka < 3) {
    out.exit = ka;
    return ConstraintStatus::ok;
  }
  if (kb < 3) {
    out.entry = kb;
    return ConstraintStatus::ok;
  }
  int side[3];
  for (std::uint32_t k = 0; k < 3; ++k) {
    side[k] = orient_or_undecided<kExact>(m, a, b, m.v(t, k), undecided);
    // On the line but not an endpoint: the triangle meets the open piece, so the vertex is on it.
    if (side[k] == 0) return ConstraintStatus::vertex_on_piece;
  }
  // The piece crosses the two edges at the vertex alone on its side; walking a -> b, it enters on the
  // edge after that vertex in counter-clockwise order when the vertex is on the left.
  std::uint32_t lone = 3;
  for (std::uint32_t k = 0; k < 3; ++k) {
    if (side[k] != side[next3(k)] && side[k] != side[prev3(k)]) lone = k;
  }
  if (lone == 3) return ConstraintStatus::corrupt_mesh;
  if (side[lone] > 0) {
    out.entry = prev3(lone);
    out.exit = next3(lone);
  } else {
    out.entry = next3(lone);
    out.exit = prev3(lone);
  }
  return ConstraintStatus::ok;
}

/// Algorithm 5, lines 2-11 for triangle A marked with piece cmark[A]: determines the case of (A, C) with
/// the one-step look-ahead to B. out.flip_case is none when A proposes nothing. With kExact false
/// (orient_or_undecided's filters alone) the status and the proposal hold only when *undecided stays
/// false.
template <bool kExact = true>
CDT_HD inline ConstraintStatus propose_constraint_flip(const MeshView& m, const std::uint32_t* cmark,
                                                       const ConstraintPiece2* pieces, std::uint32_t A,
                                                       FlipProposal& out, bool* undecided = nullptr) {
  out = FlipProposal{};
  const std::uint32_t piece = cmark[A];
  if (piece == kNoId) return ConstraintStatus::ok;
  const std::uint32_t a = pieces[piece].a, b = pieces[piece].b;
  ChainLinks links;
  const ConstraintStatus status = chain_links<kExact>(m, A, a, b, links, undecided);
  if (status != ConstraintStatus::ok) return status;
  if (links.exit == 3) return ConstraintStatus::ok; // A holds b: the pair (B, A) is B's to propose
  const std::uint32_t exit_edge = edge_id(A, links.exit);
  if (m.seg[exit_edge] != kNoId) return ConstraintStatus::crosses_constraint;
  const std::uint32_t ce = m.adj[exit_edge];
  if (ce == kNoId) return ConstraintStatus::leaves_mesh;
  const std::uint32_t C = edge_tri(ce);
  if (cmark[C] != piece) return ConstraintStatus::ok;
  const std::uint32_t x = m.v(A, links.exit), p = m.v(A, next3(links.exit)), q = m.v(A, prev3(links.exit));
  const std::uint32_t y = m.v(C, edge_index(ce));
  const PairConfig ac = classify_pair<kExact>(m, x, p, q, y, a, b, undecided);
  if (ac == PairConfig::zero_intersection || ac == PairConfig::single_intersection) {
    out.edge = exit_edge;
    out.flip_case = FlipCase::case1;
    return ConstraintStatus::ok;
  }
  if (ac != PairConfig::double_intersection || links.entry == 3) return ConstraintStatus::ok;
  const std::uint32_t be = m.adj[edge_id(A, links.entry)];
  if (be == kNoId) return ConstraintStatus::leaves_mesh;
  const std::uint32_t B = edge_tri(be);
  if (cmark[B] != piece) return ConstraintStatus::ok;
  // (B, A) shares A's entry edge (x, s); after the flip the triangle of (x, s) is (x, s, y), so B's new
  // pair has the same shared edge with apex y instead of A's apex.
  const std::uint32_t w = m.v(B, edge_index(be));
  const std::uint32_t e1 = m.v(A, next3(links.entry)), e2 = m.v(A, prev3(links.entry));
  const PairConfig ba = classify_pair<kExact>(m, w, e1, e2, m.v(A, links.entry), a, b, undecided);
  if (ba != PairConfig::double_intersection && ba != PairConfig::concave) return ConstraintStatus::ok;
  const PairConfig after = classify_pair<kExact>(m, w, e1, e2, y, a, b, undecided);
  const bool after_single =
      after == PairConfig::zero_intersection || after == PairConfig::single_intersection;
  FlipCase c = FlipCase::none;
  if (ba == PairConfig::double_intersection && after_single) c = FlipCase::case2;
  if (ba == PairConfig::concave && after == PairConfig::double_intersection) c = FlipCase::case3a;
  if (ba == PairConfig::concave && after_single) c = FlipCase::case3b;
  if (c == FlipCase::none) return ConstraintStatus::ok;
  out.edge = exit_edge;
  out.prev = B;
  out.flip_case = c;
  return ConstraintStatus::ok;
}

/// One round of Algorithm 5's proposals over the active triangles act[0..n) (the executor's arrays, per
/// active triangle k unless said otherwise): the bookkeeping shared by the CPU executor's rounds and the
/// device's (launched, or in one team), so that all of them claim and flip the same pairs.
struct ConstraintRound {
  const std::uint32_t* act; ///< the active triangles' slots
  std::uint32_t* edge;      ///< the proposal's edge (kNoId: none)
  std::uint32_t* prev_tri;  ///< the third triangle it claims (cases 2 and 3: B), else kNoId
  std::uint32_t* next_tri;  ///< the triangle across the edge (C); kNoId without a proposal
  std::uint32_t* label;     ///< the proposal's label (constraint_flip_label), with a proposal
  std::uint32_t* claim;     ///< per slot, the lowest label claiming it (kNoId: none)
  std::uint8_t* own;        ///< which of its claims k holds (constraint_claims_held)
};

/// Algorithm 5, lines 2-11, once k's case is known: records the proposal and claims A, C and B (when it
/// has one) with its label through claim_min(address, label), the executor's atomic minimum.
template <class ClaimMin>
CDT_HD inline void record_constraint_proposal(const MeshView& m, const ConstraintRound& r, std::size_t k,
                                              const FlipProposal& proposal, ClaimMin&& claim_min) {
  r.edge[k] = proposal.edge;
  r.prev_tri[k] = proposal.prev;
  r.next_tri[k] = kNoId;
  if (proposal.flip_case == FlipCase::none) return;
  const std::uint32_t A = r.act[k];
  const std::uint32_t C = edge_tri(m.adj[proposal.edge]);
  const std::uint32_t label = constraint_flip_label(proposal.flip_case, A);
  r.next_tri[k] = C;
  r.label[k] = label;
  claim_min(r.claim + A, label);
  claim_min(r.claim + C, label);
  if (proposal.prev != kNoId) claim_min(r.claim + proposal.prev, label);
}

/// Algorithm 5, line 13, once every claim of the round is made: sets own[k] to the claims k holds (bit 0:
/// A, bit 1: C, bit 2: B; 0 without a proposal). The bits also say which claims k clears afterwards
/// (clear_constraint_claims), so each claim has one clearer.
CDT_HD_INLINE void constraint_claims_held(const ConstraintRound& r, std::size_t k) {
  if (r.next_tri[k] == kNoId) {
    r.own[k] = 0;
    return;
  }
  const std::uint32_t mine = r.label[k];
  r.own[k] = static_cast<std::uint8_t>((r.claim[r.act[k]] == mine ? 1u : 0u) |
                                       (r.claim[r.next_tri[k]] == mine ? 2u : 0u) |
                                       (r.prev_tri[k] != kNoId && r.claim[r.prev_tri[k]] == mine ? 4u : 0u));
}

/// Whether k's proposal flips this round: it holds every triangle it claimed.
CDT_HD_INLINE bool constraint_proposal_won(const ConstraintRound& r, std::size_t k) {
  return r.next_tri[k] != kNoId && r.own[k] == (r.prev_tri[k] != kNoId ? 7u : 3u);
}

/// Gives back the claims k holds (after the winners are listed), so the next round starts unclaimed.
CDT_HD_INLINE void clear_constraint_claims(const ConstraintRound& r, std::size_t k) {
  if (r.own[k] & 1u) r.claim[r.act[k]] = kNoId;
  if (r.own[k] & 2u) r.claim[r.next_tri[k]] = kNoId;
  if (r.own[k] & 4u) r.claim[r.prev_tri[k]] = kNoId;
}

/// Which triangles of a pair just flipped for the piece a-b meet the open piece: t = (x, p, y) and
/// u = (y, q, x), the new diagonal x-y, the old one p-q. The piece met both triangles before the flip,
/// so it crossed p-q in its interior: p and q lie strictly on either side of its line and are not its
/// endpoints, and the piece meets the quadrilateral's interior. Then two or three orientations decide
/// (a full triangle test takes up to eighteen):
/// - the diagonal is the piece: neither;
/// - the diagonal starts at an endpoint e of the piece: the piece leaves e on one side of the diagonal
///   and, being straight, stays there: the triangle on the side of the other endpoint;
/// - otherwise the piece runs through the whole quadrilateral: both when it crosses the diagonal
///   (x and y on either side of its line), else the one whose lone vertex (p or q) is on the side
///   apart from x and y.
/// Returns false, deciding nothing, when an orientation it relies on is zero (a precondition broken).
CDT_HD inline bool flipped_pair_crossings(const MeshView& m, std::uint32_t x, std::uint32_t p,
                                          std::uint32_t y, std::uint32_t q, std::uint32_t a, std::uint32_t b,
                                          bool& t_crossed, bool& u_crossed) {
  if ((x == a && y == b) || (x == b && y == a)) {
    t_crossed = u_crossed = false;
    return true;
  }
  if (p == a || p == b || q == a || q == b) return false;
  if (x == a || x == b || y == a || y == b) {
    const bool at_x = x == a || x == b;
    const std::uint32_t e = at_x ? x : y;
    const std::uint32_t z = at_x ? y : x;
    const std::uint32_t other = e == a ? b : a;
    const int side_other = orient_vertices(m, e, z, other);
    const int side_p = orient_vertices(m, e, z, p);
    if (side_other == 0 || side_p == 0) return false;
    t_crossed = side_other == side_p;
    u_crossed = !t_crossed;
    return true;
  }
  const int ox = orient_vertices(m, a, b, x), oy = orient_vertices(m, a, b, y);
  if (ox == 0 || oy == 0) return false;
  if (ox != oy) {
    t_crossed = u_crossed = true;
    return true;
  }
  const int op = orient_vertices(m, a, b, p);
  if (op == 0) return false;
  t_crossed = op != ox;
  u_crossed = !t_crossed;
  return true;
}

/// Algorithm 5, line 14, after the batch flip of the pair (t, u) for `piece` (the diagonal is edge 1 of
/// both slots): each new triangle keeps the mark only while it still intersects the piece, and a diagonal
/// that is the piece itself becomes a constraint edge at once, so no later flip can take it away.
CDT_HD inline void mark_after_flip(const MeshView& m, std::uint32_t* cmark, const ConstraintPiece2* pieces,
                                   std::uint32_t t, std::uint32_t u, std::uint32_t piece) {
  const std::uint32_t a = pieces[piece].a, b = pieces[piece].b;
  // flip_pair_contents' layout: t = (x, p, y), u = (y, q, x).
  bool t_crossed = false, u_crossed = false;
  if (!flipped_pair_crossings(m, m.v(t, 0), m.v(t, 1), m.v(t, 2), m.v(u, 1), a, b, t_crossed, u_crossed)) {
    t_crossed = triangle_crosses_segment(m, t, a, b);
    u_crossed = triangle_crosses_segment(m, u, a, b);
  }
  cmark[t] = t_crossed ? piece : kNoId;
  cmark[u] = u_crossed ? piece : kNoId;
  const std::uint32_t d0 = m.v(t, 2), d1 = m.v(t, 0); // edge 1 of t runs from vertex 2 to vertex 0
  if ((d0 == a && d1 == b) || (d0 == b && d1 == a)) {
    m.seg[edge_id(t, 1)] = pieces[piece].id;
    m.seg[edge_id(u, 1)] = pieces[piece].id;
  }
}

/// Exact: whether p and q, both on a line through a and distinct from a, lie on the same side of a.
CDT_HD_INLINE bool same_direction(const MeshView& m, std::uint32_t a, std::uint32_t p, std::uint32_t q) {
  const Vec2 pa = m.xy[a], pp = m.xy[p], pq = m.xy[q];
  const int px = (pp.x > pa.x) - (pp.x < pa.x), qx = (pq.x > pa.x) - (pq.x < pa.x);
  if (px != 0 || qx != 0) return px == qx;
  return (pp.y > pa.y) == (pq.y > pa.y);
}

/// Whether a step of a piece's insertion stayed within the slots it may touch.
enum class Reach { done, outside };

/// The encoded edge of the mesh from u to v (in one of its two triangles), kNoId when there is none: a
/// rotation around u, counter-clockwise and then clockwise when its fan is open. outside when it meets a
/// slot that owns() refuses before finding the edge. On the host vert_tri[u] is read atomically, as
/// other threads may be moving it.
template <class Owns>
CDT_HD Reach find_edge(const MeshView& m, std::uint32_t u, std::uint32_t v, Owns&& owns,
                       std::uint32_t& edge) {
  edge = kNoId;
#if defined(__CUDA_ARCH__)
  const std::uint32_t start = m.vert_tri[u];
#else
  const std::uint32_t start = std::atomic_ref<std::uint32_t>(m.vert_tri[u]).load(std::memory_order_relaxed);
#endif
  if (start == kNoId) return Reach::done;
  std::uint32_t t = start;
  bool clockwise = false;
  for (std::uint32_t steps = 0; steps <= m.num_slots; ++steps) {
    if (!owns(t)) return Reach::outside;
    const std::uint32_t k = m.index_of(t, u);
    if (k == 3) return Reach::done;
    if (m.v(t, next3(k)) == v) {
      edge = edge_id(t, prev3(k));
      return Reach::done;
    }
    if (m.v(t, prev3(k)) == v) {
      edge = edge_id(t, next3(k));
      return Reach::done;
    }
    const std::uint32_t e = m.adj[edge_id(t, clockwise ? prev3(k) : next3(k))];
    if (e == kNoId) {
      if (clockwise) return Reach::done;
      clockwise = true;
      t = start;
      continue;
    }
    t = edge_tri(e);
    if (t == start) return Reach::done;
  }
  return Reach::done;
}

/// The encoded edge of the mesh from u to v, kNoId when there is none (find_edge over the whole mesh).
CDT_HD_INLINE std::uint32_t find_mesh_edge(const MeshView& m, std::uint32_t u, std::uint32_t v) {
  std::uint32_t edge = kNoId;
  find_edge(
      m, u, v, [](std::uint32_t) { return true; }, edge);
  return edge;
}

/// The walk of a piece a -> b from edge `crossed` on (the encoded edge through which it leaves a triangle
/// already marked; l and r its ends, left and right of a -> b) towards b: calls mark(t) on every triangle
/// it enters and counts them in `crossings`, until b, or until it is about to enter triangle `stop`
/// (not marked; kNoId for none), which sets met_stop. Reads the mesh only.
template <class MarkFn>
CDT_HD ConstraintStatus walk_piece_on(const MeshView& m, std::uint32_t a, std::uint32_t b,
                                      std::uint32_t crossed, std::uint32_t l, std::uint32_t r,
                                      std::uint32_t stop, MarkFn&& mark, std::uint32_t& crossings,
                                      bool& met_stop) {
  for (std::uint32_t steps = 0; steps <= m.num_slots; ++steps) {
    if (m.seg[crossed] != kNoId) return ConstraintStatus::crosses_constraint;
    const std::uint32_t e = m.adj[crossed];
    if (e == kNoId) return ConstraintStatus::leaves_mesh;
    const std::uint32_t n = edge_tri(e);
    if (n == stop) {
      met_stop = true;
      return ConstraintStatus::ok;
    }
    const std::uint32_t apex = m.v(n, edge_index(e));
    mark(n);
    ++crossings;
    if (apex == b) return ConstraintStatus::ok;
    const int side = orient_vertices(m, a, b, apex);
    if (side == 0) return ConstraintStatus::vertex_on_piece;
    // The piece leaves n through the edge joining the apex to the crossed edge's endpoint on the other
    // side, which is the edge opposite the endpoint on the apex's side.
    const std::uint32_t opposite = m.index_of(n, side > 0 ? l : r);
    if (opposite == 3) return ConstraintStatus::corrupt_mesh;
    crossed = edge_id(n, opposite);
    (side > 0 ? l : r) = apex;
  }
  return ConstraintStatus::corrupt_mesh;
}

/// Section 4.1 for one piece a -> b: finds the triangle of a's fan that the piece leaves a through and
/// walks to b, calling mark(t) on every triangle crossed and counting them in `crossings`. Reads the mesh
/// only. Returns present (with the encoded edge a -> b side in present_edge) when the piece is an edge.
/// With `stop` (a triangle the piece crosses), the walk ends before it (walk_piece_on; met_stop tells).
template <class MarkFn>
CDT_HD ConstraintStatus walk_piece(const MeshView& m, std::uint32_t a, std::uint32_t b, MarkFn&& mark,
                                   std::uint32_t& present_edge, std::uint32_t& crossings,
                                   std::uint32_t stop = kNoId, bool* met_stop = nullptr) {
  present_edge = kNoId;
  crossings = 0;
  const std::uint32_t start = m.vert_tri[a];
  if (start == kNoId || m.vert_tri[b] == kNoId) return ConstraintStatus::endpoint_not_in_mesh;
  // Rotate counter-clockwise around a, then clockwise from the start when the fan is open (hull vertex).
  std::uint32_t first = kNoId;
  std::uint32_t t = start;
  bool clockwise = false;
  for (std::uint32_t steps = 0; first == kNoId; ++steps) {
    if (steps > m.num_slots) return ConstraintStatus::corrupt_mesh;
    const std::uint32_t k = m.index_of(t, a);
    if (k == 3) return ConstraintStatus::corrupt_mesh;
    const std::uint32_t p = m.v(t, next3(k)), q = m.v(t, prev3(k));
    if (p == b) {
      present_edge = edge_id(t, prev3(k));
      return ConstraintStatus::present;
    }
    if (q == b) {
      present_edge = edge_id(t, next3(k));
      return ConstraintStatus::present;
    }
    const int op = orient_vertices(m, a, p, b), oq = orient_vertices(m, a, q, b);
    if ((op == 0 && same_direction(m, a, p, b)) || (oq == 0 && same_direction(m, a, q, b))) {
      return ConstraintStatus::vertex_on_piece;
    }
    if (op > 0 && oq < 0) {
      first = t;
      break;
    }
    // Counter-clockwise the next triangle is across the edge (q, a), clockwise across (a, p).
    const std::uint32_t e = m.adj[edge_id(t, clockwise ? prev3(k) : next3(k))];
    if (e == kNoId) {
      if (clockwise) return ConstraintStatus::leaves_mesh;
      clockwise = true;
      t = start;
      continue;
    }
    t = edge_tri(e);
    if (t == start) return ConstraintStatus::corrupt_mesh; // a closed fan with no wedge towards b
  }
  // Walk: keep the crossed edge's endpoints on the left (l) and right (r) of a -> b.
  const std::uint32_t k = m.index_of(first, a);
  if (first == stop) { // the first waypoint's triangle is a's own
    if (met_stop != nullptr) *met_stop = true;
    return ConstraintStatus::ok;
  }
  mark(first);
  crossings = 1;
  bool stopped = false;
  const ConstraintStatus status = walk_piece_on(m, a, b, edge_id(first, k), m.v(first, prev3(k)),
                                                m.v(first, next3(k)), stop, mark, crossings, stopped);
  if (met_stop != nullptr) *met_stop = stopped;
  return status;
}

/// Where a part of a long piece's walk may start: a triangle t whose interior the piece a -> b crosses
/// with no vertex of t on the line through a and b, a and b outside t; the piece leaves t through the
/// encoded edge `exit`, from l (left of a -> b) to r (right of it), as walk_piece_on takes them.
struct WalkEntry {
  std::uint32_t exit = kNoId;
  std::uint32_t l = kNoId;
  std::uint32_t r = kNoId;
};

/// Whether triangle t is such a start for piece a -> b (WalkEntry), found by exact orientation tests:
/// the line through a and b separates one corner of t (the lone corner) from the other two, and the
/// piece's passage through t lies strictly between a and b (a behind the edge it enters by, b beyond
/// the one it leaves by). Then walk_piece_part from t makes the walk's part from t on; any t that
/// passes will do.
CDT_HD inline bool walk_entry(const MeshView& m, std::uint32_t a, std::uint32_t b, std::uint32_t t,
                              WalkEntry& out) {
  int side[3];
  for (std::uint32_t i = 0; i < 3; ++i) {
    side[i] = orient_vertices(m, a, b, m.v(t, i));
    if (side[i] == 0) return false;
  }
  if (side[0] == side[1] && side[1] == side[2]) return false;
  const std::uint32_t k = side[0] == side[1] ? 2u : side[0] == side[2] ? 1u : 0u;
  // Counter-clockwise corners: with the lone corner on the left, the piece enters by the edge from it
  // to the next corner and leaves by the edge from the previous one (the apex) to it; on the right,
  // it enters by the edge from the previous corner to it and leaves by the edge from it to the next
  // (the apex). Both edges cross the piece's line: one end on each side.
  const bool lone_left = side[k] > 0;
  const std::uint32_t lone = m.v(t, k), next = m.v(t, next3(k)), prev = m.v(t, prev3(k));
  const std::uint32_t in_l = lone_left ? lone : prev, in_r = lone_left ? next : lone;
  const std::uint32_t apex = lone_left ? prev : next;
  const std::uint32_t behind = lone_left ? next : prev; // the corner not on the exit edge
  // a behind the entry edge (across it from the apex: the piece crosses in_l -> in_r from its right to
  // its left, where t lies); b beyond the exit edge (across it from the corner not on it).
  const int a_side = orient_vertices(m, in_l, in_r, a), apex_side = orient_vertices(m, in_l, in_r, apex);
  if (a_side == 0 || a_side == apex_side) return false;
  const int b_side = orient_vertices(m, apex, lone, b), behind_side = orient_vertices(m, apex, lone, behind);
  if (b_side == 0 || b_side == behind_side) return false;
  out = lone_left ? WalkEntry{edge_id(t, next3(k)), lone, apex} : WalkEntry{edge_id(t, prev3(k)), apex, lone};
  return true;
}

/// A part of piece a -> b's walk: from triangle t (a walk_entry start; marked and counted) towards b,
/// until b or until about to enter `stop` (walk_piece_on).
template <class MarkFn>
CDT_HD ConstraintStatus walk_piece_part(const MeshView& m, std::uint32_t a, std::uint32_t b, std::uint32_t t,
                                        const WalkEntry& at, std::uint32_t stop, MarkFn&& mark,
                                        std::uint32_t& crossings, bool& met_stop) {
  crossings = 1;
  mark(t);
  return walk_piece_on(m, a, b, at.exit, at.l, at.r, stop, mark, crossings, met_stop);
}

} // namespace cdt::detail
