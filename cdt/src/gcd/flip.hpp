#pragma once
// Phase 5 of gCD and Step 3 of the CDT (paper section 3.5; section 4, "Step 3"): Lawson flipping to the
// (constrained) Delaunay triangulation in parallel rounds, plus the race-free parallel flip of a batch of
// disjoint triangle pairs (section 3.5, the two-step link update through temporary storage), which
// constraint insertion (section 4.2, Algorithm 5 line 14) shares.
//
// Rounds: every active triangle t proposes one failing edge towards a neighbour u it is responsible for
// (u > t, or u inactive: the paper's "ti checks tj only if i < j" while keeping pairs with an unmarked
// side checked), claims t and u with atomic minimum of t, and flips only if both claims held. The
// smallest proposer always wins both claims, so every round with a proposal flips at least once.

#include <cstdint>
#include <span>
#include <vector>

#include "cdt/detail/host_device.hpp"
#include "cdt/detail/predicates.hpp"
#include "gcd/mesh.hpp"

namespace cdt::detail {

class CpuExecutor;

struct FlipStats {
  std::uint64_t flips = 0;  ///< edge flips performed
  std::uint64_t rounds = 0; ///< parallel rounds (each a propose / claim / flip / relink sequence)
};

/// Flips every non-constraint edge that fails the strict incircle test until none does. Constraint edges
/// (seg != kNoId) are never flipped. Preconditions: mesh is a valid triangulation (CCW, links symmetric,
/// vert_tri incident). Only strict incircle results flip, so co-circular input terminates; the result
/// does not depend on the executor's thread count.
///
/// With `only` (one byte per slot), the first round checks only the live slots t with only[t] != 0: the
/// caller knows that every edge between two other slots passes the test (Step 3 after Phase 5, where
/// only the triangles that constraint insertion flipped can have failing edges).
FlipStats flip_to_delaunay(Mesh& mesh, CpuExecutor& executor, const std::uint8_t* only = nullptr);

/// The same flips to the same end, scheduled for CPU threads: the slots are cut into fixed parts of
/// consecutive slots (spatially compact, as the phases before number them along a space-filling
/// curve); each part runs Lawson's algorithm with a stack on one thread, flipping the edges whose
/// flips touch only its own slots, and the triangles it must leave (edges to or flips touching another
/// part) are then worked by one thread that owns every slot. Every flip makes the triangulation
/// strictly more Delaunay, so the result is the Delaunay triangulation either way (unique for points in
/// general position; with co-circular points, one of them). The parts do not depend on the thread
/// count, and neither does the result. Counts one iteration when the parts left anything to that
/// thread.
FlipStats flip_to_delaunay_in_parts(Mesh& mesh, CpuExecutor& executor, const std::uint8_t* only = nullptr);

/// Before the fake boundary's removal (Phase 4 with the paper's rounds): flips, in the same rounds as
/// flip_to_delaunay, every edge between a fake vertex (first_fake or above) and a real one whose flip is
/// strictly convex and joins two real vertices (fake_fan_candidate), starting from the triangles with a
/// fake corner. Algorithm 3 inserts without flips, so every missing point outside the sites' hull ends
/// in the fan of a fake vertex, and removing a fake vertex walks and refills its fan on one thread; the
/// flips leave the fans convex chains. Each flip lowers the number of fake-real edges, so they end.
FlipStats flip_fake_fans(Mesh& mesh, std::uint32_t first_fake, CpuExecutor& executor);

// --- per-element work (host and device) --------------------------------------------------------------

CDT_HD_INLINE int orient_vertices(const MeshView& m, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  const Vec2 pa = m.xy[a], pb = m.xy[b], pc = m.xy[c];
  return orient2d(pa.x, pa.y, pb.x, pb.y, pc.x, pc.y);
}

/// True when flipping edge i of t (t = (a, b, c), neighbour (c, b, d)) gives two counter-clockwise
/// triangles (a, b, d) and (d, c, a), i.e. the quadrilateral a b d c is strictly convex.
CDT_HD_INLINE bool flip_is_convex(const MeshView& m, std::uint32_t t, std::uint32_t i) {
  const std::uint32_t e = m.adj[3 * t + i];
  const std::uint32_t a = m.v(t, i), b = m.v(t, next3(i)), c = m.v(t, prev3(i));
  const std::uint32_t d = m.v(edge_tri(e), edge_index(e));
  return orient_vertices(m, a, b, d) > 0 && orient_vertices(m, d, c, a) > 0;
}

/// orient_vertices (kExact), or orient2d's filter alone on the same vertices (kUndecided when it cannot
/// decide).
template <bool kExact>
CDT_HD_INLINE int orient_test(const MeshView& m, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  if constexpr (kExact)
    return orient_vertices(m, a, b, c);
  else {
    const Vec2 pa = m.xy[a], pb = m.xy[b], pc = m.xy[c];
    return orient2d_filter(pa.x, pa.y, pb.x, pb.y, pc.x, pc.y);
  }
}

/// Whether edge i of t is to be flipped (1) or not (0): it is not a constraint, has a neighbour, fails
/// the incircle test with ties perturbed (incircle_perturbed: of two triangulations of four co-circular
/// points one passes, so every order of flips, on any executor, ends in the same triangulation) and can
/// be flipped (strictly convex quadrilateral, as flip_is_convex; the incircle test implies it in a
/// valid triangulation, the orient2d check keeps a corrupt or constrained neighbourhood from producing
/// inverted triangles). With kExact false only the predicates' floating-point filters are asked, and a
/// test they cannot decide gives kUndecided: a device kernel without the exact fallbacks holds far
/// fewer registers, and leaves the rare undecided edges to a second one with them.
template <bool kExact>
CDT_HD_INLINE int edge_flip_test(const MeshView& m, std::uint32_t t, std::uint32_t i) {
  const std::uint32_t e = m.adj[3 * t + i];
  if (e == kNoId || (m.seg != nullptr && m.seg[3 * t + i] != kNoId)) return 0;
  const std::uint32_t a = m.v(t, 0), b = m.v(t, 1), c = m.v(t, 2);
  const std::uint32_t d = m.v(edge_tri(e), edge_index(e));
  int sign;
  const Vec2 pa = m.xy[a], pb = m.xy[b], pc = m.xy[c], pd = m.xy[d];
  if constexpr (kExact) {
    sign = incircle_perturbed(pa.x, pa.y, pb.x, pb.y, pc.x, pc.y, pd.x, pd.y);
  } else {
    double det;
    sign = incircle_filter(pa.x, pa.y, pb.x, pb.y, pc.x, pc.y, pd.x, pd.y, det);
    if (sign == kUndecided) return kUndecided;
  }
  if (sign <= 0) return 0;
  const std::uint32_t p = m.v(t, i), q = m.v(t, next3(i)), r = m.v(t, prev3(i));
  const int first = orient_test<kExact>(m, p, q, d);
  if (first == kUndecided) return kUndecided;
  if (first <= 0) return 0;
  const int second = orient_test<kExact>(m, d, r, p);
  if (second == kUndecided) return kUndecided;
  return second > 0 ? 1 : 0;
}

/// True when edge i of t is to be flipped (edge_flip_test with the exact predicates).
CDT_HD_INLINE bool edge_wants_flip(const MeshView& m, std::uint32_t t, std::uint32_t i) {
  return edge_flip_test<true>(m, t, i) == 1;
}

/// The encoded edge 3t + i that active triangle t proposes to flip this round, or kNoId. t checks the
/// edge to neighbour u only when u > t or u is not active: each pair is checked once per round, and a
/// pair stays checked as long as one side is active. partner (FlipBatch::partner of the last round's
/// flips) spares a test whose answer is known: a pair flipped last round has as edge 1 the diagonal it
/// flipped to, which passes the incircle test strictly (of four points in strictly convex position that
/// fail it across one diagonal, the other diagonal passes), so skipping it changes nothing. With kExact
/// false (edge_flip_test's filters alone), a test the filters cannot decide ends the search with
/// kNoId and `undecided` set; the exact search then gives the proposal.
template <bool kExact = true>
CDT_HD inline std::uint32_t delaunay_flip_candidate(const MeshView& m, const std::uint8_t* active,
                                                    const std::uint32_t* partner, std::uint32_t t,
                                                    bool* undecided = nullptr) {
  const bool fresh = partner[t] != kNoId;
  for (std::uint32_t i = 0; i < 3; ++i) {
    if (fresh && i == 1) continue;
    const std::uint32_t e = m.adj[3 * t + i];
    if (e == kNoId) continue;
    const std::uint32_t u = edge_tri(e);
    if (u < t && active[u]) continue;
    const int want = edge_flip_test<kExact>(m, t, i);
    if constexpr (!kExact) {
      if (want == kUndecided) {
        *undecided = true;
        return kNoId;
      }
    }
    if (want == 1) return edge_id(t, i);
  }
  return kNoId;
}

/// flip_fake_fans' rule: the encoded edge 3t + i that active triangle t proposes to flip, or kNoId. Edge
/// i joins a fake vertex and a real one, the corners across it on both sides are real, and its flip is
/// strictly convex. Each pair is checked once per round, as in delaunay_flip_candidate.
CDT_HD inline std::uint32_t fake_fan_candidate(const MeshView& m, const std::uint8_t* active, std::uint32_t t,
                                               std::uint32_t first_fake) {
  for (std::uint32_t i = 0; i < 3; ++i) {
    const std::uint32_t e = m.adj[3 * t + i];
    if (e == kNoId || (m.seg != nullptr && m.seg[3 * t + i] != kNoId)) continue;
    const std::uint32_t u = edge_tri(e);
    if (u < t && active[u]) continue;
    const std::uint32_t a = m.v(t, i), b = m.v(t, next3(i)), c = m.v(t, prev3(i));
    const std::uint32_t d = m.v(u, edge_index(e));
    if (a >= first_fake || d >= first_fake || (b >= first_fake) == (c >= first_fake)) continue;
    if (flip_is_convex(m, t, i)) return edge_id(t, i);
  }
  return kNoId;
}

/// A flipping round's proposals (Phase 5, Step 3, the fake fans' flips), per proposer k of the round's
/// list: the arrays that every executor's rounds share.
struct FlipRound {
  const std::uint32_t* list; ///< the active triangles' slots
  std::uint32_t* cand;       ///< the edge list[k] proposes to flip (kNoId: none)
  std::uint32_t* nbr;        ///< the triangle across it, with a proposal
  std::uint32_t* marks;      ///< per slot, the lowest proposer claiming it (kNoId: none)
  std::uint8_t* own;         ///< which of its two claims k holds (flip_claims_held)
};

/// Records k's proposal, edge e of list[k] (kNoId: none), and claims both triangles of the pair through
/// claim_min(address, label), the executor's atomic minimum. The proposer's slot is its label, so the
/// lowest proposer wins.
template <class ClaimMin>
CDT_HD inline void record_flip_proposal(const MeshView& m, const FlipRound& r, std::size_t k, std::uint32_t e,
                                        ClaimMin&& claim_min) {
  r.cand[k] = e;
  r.nbr[k] = kNoId;
  if (e == kNoId) return;
  const std::uint32_t t = r.list[k];
  const std::uint32_t u = edge_tri(m.adj[e]);
  r.nbr[k] = u;
  claim_min(r.marks + t, t);
  claim_min(r.marks + u, t);
}

/// Which of its claims k holds (bit 0 its own triangle, bit 1 the one across), read once every claim of
/// the round is in; the bits also say which marks k clears, so each mark has one clearer.
CDT_HD_INLINE void flip_claims_held(const FlipRound& r, std::size_t k) {
  if (r.cand[k] == kNoId) {
    r.own[k] = 0;
    return;
  }
  const std::uint32_t t = r.list[k];
  r.own[k] = static_cast<std::uint8_t>((r.marks[t] == t ? 1u : 0u) | (r.marks[r.nbr[k]] == t ? 2u : 0u));
}

/// Whether k's proposal flips this round: it holds both triangles.
CDT_HD_INLINE bool flip_proposal_won(const FlipRound& r, std::size_t k) { return r.own[k] == 3; }

/// Gives back the claims k holds (after the winners are listed), so the next round starts unclaimed.
CDT_HD_INLINE void clear_flip_claims(const FlipRound& r, std::size_t k) {
  if (r.own[k] & 1u) r.marks[r.list[k]] = kNoId;
  if (r.own[k] & 2u) r.marks[r.nbr[k]] = kNoId;
}

/// Whether k proposed and neither of its triangles was flipped this round (partner: the batch's pairs):
/// it proposes again next round. A proposer flipped as some winner's neighbour comes back as one of the
/// new triangles instead.
CDT_HD_INLINE bool flip_proposal_waits(const FlipRound& r, const std::uint32_t* partner, std::size_t k) {
  return r.cand[k] != kNoId && partner[r.list[k]] == kNoId;
}

/// First step of a parallel flip: rewrites the contents of the pair across encoded edge e = 3t + i in
/// the layout of flip_edge (t = (a, b, d), u = (d, c, a), the diagonal is edge 1 of both), writing only
/// the two slots it owns. Outer links keep naming the neighbours' edges as they were before the batch;
/// relink_flipped_pair fixes them once every pair of the batch has been rewritten. Returns which
/// vertex-array entries must move (bit 0: vert_tri[b] was u, bit 1: vert_tri[c] was t), decided here
/// because nobody writes vert_tri during this step.
CDT_HD inline std::uint8_t flip_pair_contents(const MeshView& m, std::uint32_t e) {
  const std::uint32_t t = edge_tri(e), i = edge_index(e);
  const std::uint32_t u = edge_tri(m.adj[e]);
  const std::uint32_t b = m.tri[3 * t + next3(i)], c = m.tri[3 * t + prev3(i)];
  const std::uint8_t fix =
      static_cast<std::uint8_t>((m.vert_tri[b] == u ? 1u : 0u) | (m.vert_tri[c] == t ? 2u : 0u));
  rewrite_flipped_pair(m, t, i);
  return fix;
}

/// Encoded edge of t running from vertex `from` to vertex `to`, or kNoId.
CDT_HD_INLINE std::uint32_t find_directed_edge(const MeshView& m, std::uint32_t t, std::uint32_t from,
                                               std::uint32_t to) {
  for (std::uint32_t i = 0; i < 3; ++i) {
    if (m.v(t, next3(i)) == from && m.v(t, prev3(i)) == to) return edge_id(t, i);
  }
  return kNoId;
}

/// Second step of a parallel flip, for the pair whose first slot is t (partner[t] is the second). For
/// each of the four outer edges: a neighbour that did not flip in this batch gets its link rewritten
/// here (only this pair faces that edge, so the write is exclusive); a neighbour that did flip has moved
/// the shared edge into itself or its partner, where it is found by its vertices, and fixes its own side.
/// Also applies the vertex-array moves decided by flip_pair_contents. Returns false when an edge cannot
/// be found (corrupt input).
CDT_HD inline bool relink_flipped_pair(const MeshView& m, const std::uint32_t* partner, std::uint32_t t,
                                       std::uint8_t vertex_fix) {
  const std::uint32_t u = partner[t];
  const std::uint32_t pair[2] = {t, u};
  bool ok = true;
  for (const std::uint32_t x : pair) {
    for (std::uint32_t k = 0; k < 3; k += 2) {
      const std::uint32_t e = m.adj[3 * x + k];
      if (e == kNoId) continue;
      const std::uint32_t n = edge_tri(e);
      if (partner[n] == kNoId) {
        m.adj[e] = edge_id(x, k);
        continue;
      }
      const std::uint32_t from = m.v(x, next3(k)), to = m.v(x, prev3(k));
      std::uint32_t found = find_directed_edge(m, n, to, from);
      if (found == kNoId) found = find_directed_edge(m, partner[n], to, from);
      if (found == kNoId) {
        ok = false;
        continue;
      }
      m.adj[3 * x + k] = found;
    }
  }
  if (vertex_fix & 1u) m.vert_tri[m.v(t, 1)] = t;
  if (vertex_fix & 2u) m.vert_tri[m.v(u, 1)] = u;
  return ok;
}

// --- host driver of a batch of flips -----------------------------------------------------------------

/// Flips batches of pairwise disjoint triangle pairs in parallel without races: contents first
/// (flip_pair_contents), then links (relink_flipped_pair), with a global synchronisation between the two
/// steps. Holds the per-slot temporary storage, allocated once per phase.
class FlipBatch {
public:
  explicit FlipBatch(std::uint32_t num_slots);

  /// Flips the pair across each encoded edge (t's side). The pairs must be disjoint, the quadrilaterals
  /// strictly convex; constraint ids move with their edges and the new diagonal (edge 1 of both slots)
  /// is not a constraint. Throws Error when the links are inconsistent.
  void apply(Mesh& mesh, std::span<const std::uint32_t> edges, CpuExecutor& executor);

  /// Per slot, the other slot of its pair in the last batch, kNoId when it did not flip. Valid until the
  /// next apply().
  const std::uint32_t* partner() const { return partner_.data(); }

  /// Forgets the last batch: every partner entry becomes kNoId again.
  void forget(CpuExecutor& executor);

private:
  std::vector<std::uint32_t> partner_;
  std::vector<std::uint32_t> last_pairs_; // the slots of the last batch, so partner_ resets in O(batch)
  std::vector<std::uint8_t> vertex_fix_;
};

} // namespace cdt::detail
