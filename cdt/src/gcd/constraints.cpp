// Step 2 of the CDT (paper section 4, Algorithms 4 and 5): constraint insertion by flipping, with the
// outer marking loop, the inner flipping loop with the one-step look-ahead of Figure 5, atomic-minimum
// claims and compacted lists of pending pieces and active triangles.

#include "gcd/constraints.hpp"

#include <atomic>
#include <bit>
#include <deque>
#include <string>
#include <utility>
#include <vector>

#include "cdt/detail/trace.hpp"
#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"
#include "gcd/part_lawson.hpp"

namespace cdt::detail {
namespace {

// A flipping pass that flips fewer than one in this many marked triangles ends the inner loop early.
constexpr std::size_t kStalledShare = 16;

bool is_error(ConstraintStatus s) { return s >= ConstraintStatus::vertex_on_piece; }

} // namespace

const char* constraint_status_message(ConstraintStatus s) {
  switch (s) {
  case ConstraintStatus::vertex_on_piece:
    return "a vertex lies on the open piece (pieces must be split at vertices first)";
  case ConstraintStatus::crosses_constraint:
    return "the piece crosses another constraint (crossing pieces must be split first)";
  case ConstraintStatus::leaves_mesh:
    return "the piece leaves the triangulated domain";
  case ConstraintStatus::endpoint_not_in_mesh:
    return "an endpoint is not a vertex of the triangulation";
  case ConstraintStatus::corrupt_mesh:
    return "the triangulation's links or marks are inconsistent";
  default:
    return "unknown status";
  }
}

namespace {

[[noreturn]] void fail(ConstraintStatus s, std::uint32_t index, const ConstraintPiece2& p) {
  throw Error("internal error: constraint piece " + std::to_string(index) + " (" + std::to_string(p.a) +
              ", " + std::to_string(p.b) + "): " + constraint_status_message(s));
}

} // namespace

ConstraintStats insert_constraints(Mesh& mesh, std::span<const ConstraintPiece2> pieces,
                                   unsigned inner_iterations, CpuExecutor& executor, std::uint8_t* flipped) {
  return insert_constraints(mesh, pieces, inner_iterations, executor,
                            constraint_iteration_bound(mesh.num_vertices()), flipped);
}

std::uint64_t constraint_iteration_bound(std::uint64_t n) {
  // Each inner iteration that runs flips at least once and there are O(n^2) flips (paper, Claim 3), so
  // only broken code or input can reach this.
  return n < (1u << 28) ? 16 * n * n + 10'000'000 : ~std::uint64_t{0};
}

void check_constraint_counts(std::uint32_t num_slots, std::size_t num_pieces) {
  if (num_slots >= kMaxConstraintSlots)
    throw Error("too many triangles for constraint insertion (at most 2^30 slots)");
  if (num_pieces >= kNoId) throw Error("too many constraint pieces for 32-bit indices");
}

void throw_invalid_piece(std::size_t k, const ConstraintPiece2& p) {
  throw Error("internal error: constraint piece " + std::to_string(k) + " (" + std::to_string(p.a) + ", " +
              std::to_string(p.b) + ") has invalid endpoints");
}

void check_constraint_pieces(std::uint32_t num_slots, std::uint32_t num_vertices,
                             std::span<const ConstraintPiece2> pieces) {
  check_constraint_counts(num_slots, pieces.size());
  for (std::size_t k = 0; k < pieces.size(); ++k)
    if (!piece_endpoints_valid(pieces[k], num_vertices)) throw_invalid_piece(k, pieces[k]);
}

ConstraintStats insert_constraints(Mesh& mesh, std::span<const ConstraintPiece2> pieces,
                                   unsigned inner_iterations, CpuExecutor& executor,
                                   std::uint64_t max_inner_iterations, std::uint8_t* flipped) {
  ConstraintStats stats;
  const std::uint32_t slots = mesh.num_slots();
  check_constraint_pieces(slots, mesh.num_vertices(), pieces);
  if (pieces.empty()) return stats;
  const unsigned inner_limit = inner_iterations == 0 ? 1u : inner_iterations;

  const MeshView m = mesh.view();
  const ConstraintPiece2* piece = pieces.data();
  std::vector<std::uint32_t> cmark_store(slots, kNoId);
  std::vector<std::uint32_t> claim_store(slots, kNoId);
  std::uint32_t* cmark = cmark_store.data();
  std::uint32_t* claim = claim_store.data();
  FlipBatch batch(slots);

  std::vector<std::uint32_t> pending(pieces.size());
  for (std::size_t k = 0; k < pending.size(); ++k) pending[k] = static_cast<std::uint32_t>(k);
  std::vector<ConstraintStatus> walk_status, prop_status;
  std::vector<std::uint32_t> present_edge;
  std::vector<std::uint32_t> crossings;
  std::vector<std::uint32_t> prop_edge, prop_next, prop_prev, label, winner_edges;
  std::vector<std::uint8_t> owned;

  for (;;) {
    ++stats.outer_iterations;
    // Algorithm 4, line 3: marks from scratch, each piece's walk lowering them to its index.
    executor.for_each(slots, [&](std::size_t t) { cmark[t] = kNoId; });
    const std::size_t np = pending.size();
    walk_status.resize(np);
    present_edge.resize(np);
    crossings.resize(np);
    {
      const std::uint32_t* pend = pending.data();
      ConstraintStatus* st = walk_status.data();
      std::uint32_t* present = present_edge.data();
      std::uint32_t* cross = crossings.data();
      std::uint32_t error_at = kNoId;
      executor.for_each(np, [&](std::size_t k) {
        const std::uint32_t i = pend[k];
        const auto mark = [cmark, i](std::uint32_t t) { atomic_min(cmark + t, i); };
        st[k] = walk_piece(m, piece[i].a, piece[i].b, mark, present[k], cross[k]);
        if (is_error(st[k])) atomic_min(&error_at, static_cast<std::uint32_t>(k));
      });
      if (error_at != kNoId) fail(st[error_at], pend[error_at], piece[pend[error_at]]);
      if (stats.outer_iterations == 1) {
        for (std::size_t k = 0; k < np; ++k) stats.intersections += cross[k];
      }
      // A separate step from the walks, which read seg. Duplicate pieces share an edge: lowest id wins.
      executor.for_each(np, [&](std::size_t k) {
        if (st[k] != ConstraintStatus::present) return;
        const std::uint32_t id = piece[pend[k]].id;
        atomic_min(m.seg + present[k], id);
        const std::uint32_t twin = m.adj[present[k]];
        if (twin != kNoId) atomic_min(m.seg + twin, id);
      });
      const std::vector<std::uint32_t> left =
          executor.compact(np, [&](std::size_t k) { return st[k] == ConstraintStatus::ok; });
      std::vector<std::uint32_t> next(left.size());
      const std::uint32_t* l = left.data();
      std::uint32_t* out = next.data();
      executor.for_each(left.size(), [&](std::size_t k) { out[k] = pend[l[k]]; });
      pending.swap(next);
    }
    if (pending.empty()) break;

    std::vector<std::uint32_t> active =
        executor.compact(slots, [&](std::size_t t) { return cmark[t] != kNoId; });
    std::uint64_t outer_flips = 0;
    for (unsigned iteration = 0; iteration < inner_limit && !active.empty(); ++iteration) {
      if (++stats.inner_iterations > max_inner_iterations) {
        throw Error("internal error: constraint insertion did not finish within " +
                    std::to_string(max_inner_iterations) + " inner iterations");
      }
      const std::size_t na = active.size();
      prop_edge.resize(na);
      prop_next.resize(na);
      prop_prev.resize(na);
      label.resize(na);
      owned.resize(na);
      prop_status.resize(na);
      ConstraintStatus* status = prop_status.data();
      const std::uint32_t* act = active.data();
      const ConstraintRound round{act,   prop_edge.data(), prop_prev.data(), prop_next.data(), label.data(),
                                  claim, owned.data()};

      // Algorithm 5, lines 2-11: cases, then claims by atomic minimum of the label.
      std::uint32_t error_at = kNoId;
      executor.for_each(na, [&](std::size_t k) {
        FlipProposal proposal;
        status[k] = propose_constraint_flip(m, cmark, piece, act[k], proposal);
        if (is_error(status[k])) atomic_min(&error_at, static_cast<std::uint32_t>(k));
        record_constraint_proposal(m, round, k, proposal, AtomicMin{});
      });
      if (error_at != kNoId) {
        const std::uint32_t i = cmark[act[error_at]];
        fail(status[error_at], i, piece[i]);
      }
      // Algorithm 5, line 13: flip only where every claim held.
      executor.for_each(na, [&](std::size_t k) { constraint_claims_held(round, k); });
      const std::vector<std::uint32_t> winners =
          executor.compact(na, [&](std::size_t k) { return constraint_proposal_won(round, k); });
      executor.for_each(na, [&](std::size_t k) { clear_constraint_claims(round, k); });
      if (winners.empty()) break; // the lowest label holds all its claims: nothing was flippable
      winner_edges.resize(winners.size());
      {
        const std::uint32_t* w = winners.data();
        std::uint32_t* out = winner_edges.data();
        executor.for_each(winners.size(), [&](std::size_t k) { out[k] = round.edge[w[k]]; });
        batch.apply(mesh, winner_edges, executor);
        const std::uint32_t* partner = batch.partner();
        executor.for_each(winners.size(), [&](std::size_t k) {
          const std::uint32_t A = act[w[k]];
          mark_after_flip(m, cmark, piece, A, partner[A], cmark[A]);
          if (flipped != nullptr) flipped[A] = flipped[partner[A]] = 1; // pairs are disjoint: one writer
        });
      }
      stats.flips += winners.size();
      outer_flips += winners.size();
      // Triangles that stay marked without flipping belong to pieces whose other triangles carry a lower
      // piece's mark; only the next marking pass frees them. Once a pass flips only a small share of the
      // marked triangles (clustered inputs such as coastlines get there after a few passes, while long
      // pieces across a uniform mesh keep flipping about a fifth per pass), marking again is cheaper than
      // proposing over the stuck triangles until the pass limit.
      const bool stalled = winners.size() * kStalledShare < na;
      // Flips only reuse slots of marked triangles, so the marked set shrinks within the list.
      const std::vector<std::uint32_t> still =
          executor.compact(na, [&](std::size_t k) { return cmark[act[k]] != kNoId; });
      std::vector<std::uint32_t> next(still.size());
      const std::uint32_t* s = still.data();
      std::uint32_t* out = next.data();
      executor.for_each(still.size(), [&](std::size_t k) { out[k] = act[s[k]]; });
      active.swap(next);
      if (stalled) break;
    }
    // Section 4.3: the lowest pending piece has all its triangles marked and always a flippable pair.
    if (outer_flips == 0) {
      throw Error("internal error: constraint insertion made no progress with " +
                  std::to_string(pending.size()) + " pieces pending (crossing pieces?)");
    }
  }
  return stats;
}

namespace {

/// Strictly on opposite sides of the line through a and b.
bool straddles(const MeshView& m, std::uint32_t a, std::uint32_t b, std::uint32_t p, std::uint32_t q) {
  const int op = orient_vertices(m, a, b, p), oq = orient_vertices(m, a, b, q);
  return (op > 0 && oq < 0) || (op < 0 && oq > 0);
}

/// The edges that piece a-b crosses, as vertex pairs, walking from a to b like walk_piece (host only,
/// as walk_piece serves the device too) but reading only slots that owns() accepts (outside
/// otherwise). status: present (nothing crossed), ok, or an error.
template <class Owns>
Reach crossed_edges(const MeshView& m, std::uint32_t a, std::uint32_t b, Owns&& owns,
                    std::vector<std::pair<std::uint32_t, std::uint32_t>>& crossed, ConstraintStatus& status) {
  crossed.clear();
  status = ConstraintStatus::corrupt_mesh;
  // The wedge of a's fan that the piece leaves through, unless one of the fan's edges is the piece.
  const std::uint32_t start = std::atomic_ref<std::uint32_t>(m.vert_tri[a]).load(std::memory_order_relaxed);
  if (start == kNoId) {
    status = ConstraintStatus::endpoint_not_in_mesh;
    return Reach::done;
  }
  std::uint32_t t = start, first = kNoId;
  bool clockwise = false;
  for (std::uint32_t steps = 0; first == kNoId; ++steps) {
    if (steps > m.num_slots) return Reach::done;
    if (!owns(t)) return Reach::outside;
    const std::uint32_t k = m.index_of(t, a);
    if (k == 3) return Reach::done;
    const std::uint32_t p = m.v(t, next3(k)), q = m.v(t, prev3(k));
    if (p == b || q == b) {
      status = ConstraintStatus::present;
      return Reach::done;
    }
    const int op = orient_vertices(m, a, p, b), oq = orient_vertices(m, a, q, b);
    if ((op == 0 && same_direction(m, a, p, b)) || (oq == 0 && same_direction(m, a, q, b))) {
      status = ConstraintStatus::vertex_on_piece;
      return Reach::done;
    }
    if (op > 0 && oq < 0) {
      first = t;
      break;
    }
    const std::uint32_t e = m.adj[edge_id(t, clockwise ? prev3(k) : next3(k))];
    if (e == kNoId) {
      if (clockwise) {
        status = ConstraintStatus::leaves_mesh;
        return Reach::done;
      }
      clockwise = true;
      t = start;
      continue;
    }
    t = edge_tri(e);
    if (t == start) return Reach::done;
  }
  const std::uint32_t k = m.index_of(first, a);
  std::uint32_t r = m.v(first, next3(k)), l = m.v(first, prev3(k));
  std::uint32_t at = edge_id(first, k);
  for (std::uint32_t steps = 0; steps <= m.num_slots; ++steps) {
    if (m.seg[at] != kNoId) {
      status = ConstraintStatus::crosses_constraint;
      return Reach::done;
    }
    crossed.emplace_back(r, l);
    const std::uint32_t e = m.adj[at];
    if (e == kNoId) {
      status = ConstraintStatus::leaves_mesh;
      return Reach::done;
    }
    const std::uint32_t n = edge_tri(e);
    if (!owns(n)) return Reach::outside;
    const std::uint32_t apex = m.v(n, edge_index(e));
    if (apex == b) {
      status = ConstraintStatus::ok;
      return Reach::done;
    }
    const int side = orient_vertices(m, a, b, apex);
    if (side == 0) {
      status = ConstraintStatus::vertex_on_piece;
      return Reach::done;
    }
    const std::uint32_t opposite = m.index_of(n, side > 0 ? l : r);
    if (opposite == 3) return Reach::done;
    at = edge_id(n, opposite);
    (side > 0 ? l : r) = apex;
  }
  return Reach::done;
}

/// Inserts piece p (number k) by Sloan's flipping, touching only slots that owns() accepts: outside,
/// with the mesh valid and the piece perhaps part way in, as soon as a walk or a flip would need
/// another slot. Throws on a violated precondition.
template <class Owns>
Reach insert_piece(const MeshView& m, const ConstraintPiece2& p, std::uint32_t k, Owns&& owns,
                   std::uint8_t* flipped, std::vector<std::pair<std::uint32_t, std::uint32_t>>& crossed,
                   std::deque<std::pair<std::uint32_t, std::uint32_t>>& queue, ConstraintStats& stats) {
  ConstraintStatus st = ConstraintStatus::corrupt_mesh;
  if (crossed_edges(m, p.a, p.b, owns, crossed, st) == Reach::outside) return Reach::outside;
  if (is_error(st)) fail(st, k, p);
  queue.assign(crossed.begin(), crossed.end());
  // Every full turn of the queue flips at least once, and there are O(c^2) flips for c crossings
  // (Sloan); beyond that bound only a broken mesh or input can keep it going.
  const std::uint64_t c = queue.size();
  const std::uint64_t bound = (c + 1) * (c + 1) * (c + 1) + 1000;
  std::uint64_t pops = 0;
  const auto inside = [&](std::uint32_t e) { return e == kNoId || owns(edge_tri(e)); };
  while (!queue.empty()) {
    if (++pops > bound) fail(ConstraintStatus::corrupt_mesh, k, p);
    const auto [u, v] = queue.front();
    std::uint32_t e = kNoId;
    if (find_edge(m, u, v, owns, e) == Reach::outside) return Reach::outside;
    if (e == kNoId || m.adj[e] == kNoId || m.seg[e] != kNoId) fail(ConstraintStatus::corrupt_mesh, k, p);
    const std::uint32_t t = edge_tri(e), i = edge_index(e);
    const std::uint32_t f = m.adj[e];
    const std::uint32_t partner = edge_tri(f), j = edge_index(f);
    if (!owns(partner)) return Reach::outside;
    const std::uint32_t w = m.v(t, i), z = m.v(partner, j);
    queue.pop_front();
    stats.inner_iterations++;
    // Flippable when strictly convex: u and v strictly on opposite sides of the other diagonal.
    if (!straddles(m, w, z, u, v)) {
      queue.emplace_back(u, v);
      continue;
    }
    if (!inside(m.adj[3 * t + next3(i)]) || !inside(m.adj[3 * t + prev3(i)]) ||
        !inside(m.adj[3 * partner + next3(j)]) || !inside(m.adj[3 * partner + prev3(j)])) {
      return Reach::outside;
    }
    flip_edge_in_part(m, t, i);
    ++stats.flips;
    if (flipped != nullptr) flipped[t] = flipped[partner] = 1;
    // The new diagonal (w, z) is the piece itself, or crosses it still, or is clear of it.
    if (!((w == p.a && z == p.b) || (w == p.b && z == p.a)) && straddles(m, p.a, p.b, w, z))
      queue.emplace_back(w, z);
  }
  std::uint32_t e = kNoId;
  if (find_edge(m, p.a, p.b, owns, e) == Reach::outside) return Reach::outside;
  if (e == kNoId) fail(ConstraintStatus::corrupt_mesh, k, p);
  if (!inside(m.adj[e])) return Reach::outside;
  m.seg[e] = std::min(m.seg[e], p.id);
  if (m.adj[e] != kNoId) m.seg[m.adj[e]] = std::min(m.seg[m.adj[e]], p.id);
  return Reach::done;
}

} // namespace

ConstraintStats insert_constraints_one_by_one(Mesh& mesh, std::span<const ConstraintPiece2> pieces,
                                              CpuExecutor& executor, std::uint8_t* flipped) {
  ConstraintStats stats;
  const std::uint32_t slots = mesh.num_slots();
  check_constraint_pieces(slots, mesh.num_vertices(), pieces);
  if (pieces.empty()) return stats;
  const MeshView m = mesh.view();
  StepTrace trace("constraints");

  // The walking pass: which pieces are edges already (their seg is set here, the lowest id winning
  // among duplicates), and which cross triangles.
  ++stats.outer_iterations;
  const std::size_t np = pieces.size();
  std::vector<ConstraintStatus> status(np);
  std::vector<std::uint32_t> present(np), crossings(np);
  std::uint32_t error_at = kNoId;
  executor.for_each(np, [&](std::size_t k) {
    status[k] = walk_piece(
        m, pieces[k].a, pieces[k].b, [](std::uint32_t) {}, present[k], crossings[k]);
    if (is_error(status[k])) atomic_min(&error_at, static_cast<std::uint32_t>(k));
  });
  if (error_at != kNoId) fail(status[error_at], error_at, pieces[error_at]);
  executor.for_each(np, [&](std::size_t k) {
    if (status[k] != ConstraintStatus::present) return;
    atomic_min(m.seg + present[k], pieces[k].id);
    const std::uint32_t twin = m.adj[present[k]];
    if (twin != kNoId) atomic_min(m.seg + twin, pieces[k].id);
  });
  const std::vector<std::uint32_t> pending =
      executor.compact(np, [&](std::size_t k) { return status[k] == ConstraintStatus::ok; });
  for (std::size_t k = 0; k < np; ++k) stats.intersections += crossings[k];
  trace.mark("walks");
  if (pending.empty()) return stats;
  ++stats.outer_iterations;

  // The pieces by the part of the slot at their first end (part_lawson.hpp), in order within each
  // part; each part's thread inserts those that stay within its slots (walks, flips and the flips'
  // outer neighbours), as the parts of Phases 4 and 5 do, and leaves the others where they are.
  const std::uint32_t parts = (slots + kPartSlots - 1) / kPartSlots;
  std::vector<std::uint32_t> key(pending.size()), order = pending;
  executor.for_each(pending.size(),
                    [&](std::size_t r) { key[r] = m.vert_tri[pieces[pending[r]].a] / kPartSlots; });
  executor.sort_pairs_by_key(key, order, std::bit_width(parts));
  std::vector<std::uint32_t> start(parts + 1, 0);
  for (const std::uint32_t p : key) ++start[p + 1];
  for (std::uint32_t p = 0; p < parts; ++p) start[p + 1] += start[p];
  std::vector<ConstraintStats> part_stats(parts);
  std::vector<std::uint8_t> done(np, 0);
  executor.for_each_part(parts, [&](std::size_t pp) {
    const auto p = static_cast<std::uint32_t>(pp);
    const auto owns = [p](std::uint32_t t) { return t / kPartSlots == p; };
    std::vector<std::pair<std::uint32_t, std::uint32_t>> crossed;
    std::deque<std::pair<std::uint32_t, std::uint32_t>> queue;
    for (std::uint32_t r = start[p]; r < start[p + 1]; ++r) {
      const std::uint32_t k = order[r];
      // A violated precondition is left for the one thread below to meet again and report: nothing
      // is thrown out of a worker.
      try {
        if (insert_piece(m, pieces[k], k, owns, flipped, crossed, queue, part_stats[p]) == Reach::done)
          done[k] = 1;
      } catch (const Error&) {
      }
    }
  });
  for (const ConstraintStats& ps : part_stats) {
    stats.flips += ps.flips;
    stats.inner_iterations += ps.inner_iterations;
  }
  trace.mark("parts");

  // What the parts left, in order, on one thread that owns every slot.
  {
    const auto everything = [](std::uint32_t) { return true; };
    std::vector<std::pair<std::uint32_t, std::uint32_t>> crossed;
    std::deque<std::pair<std::uint32_t, std::uint32_t>> queue;
    for (const std::uint32_t k : pending)
      if (done[k] == 0) insert_piece(m, pieces[k], k, everything, flipped, crossed, queue, stats);
  }
  trace.mark("rest");
  return stats;
}

} // namespace cdt::detail
