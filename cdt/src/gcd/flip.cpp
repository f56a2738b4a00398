// Phase 5 of gCD and Step 3 of the CDT (paper section 3.5; section 4, "Step 3"): parallel Lawson
// flipping with atomic-minimum claims, the two-step link update, and a compacted list of the triangles
// that still need checking.

#include "gcd/flip.hpp"

#include <algorithm>
#include <string>

#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"
#include "gcd/part_lawson.hpp"

namespace cdt::detail {

FlipBatch::FlipBatch(std::uint32_t num_slots) : partner_(num_slots, kNoId) {}

void FlipBatch::apply(Mesh& mesh, std::span<const std::uint32_t> edges, CpuExecutor& executor) {
  const MeshView m = mesh.view();
  std::uint32_t* partner = partner_.data();
  {
    std::uint32_t* last = last_pairs_.data();
    executor.for_each(last_pairs_.size(), [&](std::size_t k) { partner[last[k]] = kNoId; });
  }
  const std::size_t n = edges.size();
  last_pairs_.resize(2 * n);
  vertex_fix_.resize(n);
  std::uint32_t* last = last_pairs_.data();
  std::uint8_t* fix = vertex_fix_.data();
  const std::uint32_t* edge = edges.data();
  // The pairs are disjoint, so each slot's partner entry has one writer.
  executor.for_each(n, [&](std::size_t k) {
    const std::uint32_t t = edge_tri(edge[k]);
    const std::uint32_t u = edge_tri(m.adj[edge[k]]);
    partner[t] = u;
    partner[u] = t;
    last[2 * k] = t;
    last[2 * k + 1] = u;
  });
  executor.for_each(n, [&](std::size_t k) { fix[k] = flip_pair_contents(m, edge[k]); });
  std::uint32_t failed = kNoId;
  executor.for_each(n, [&](std::size_t k) {
    if (!relink_flipped_pair(m, partner, edge_tri(edge[k]), fix[k])) {
      atomic_min(&failed, static_cast<std::uint32_t>(k));
    }
  });
  if (failed != kNoId) {
    throw Error("internal error: flipped pair at edge " + std::to_string(edge[failed]) +
                " lost a neighbour link (the triangulation was not valid)");
  }
}

namespace {

/// The parallel rounds of Phase 5 (propose, claim by atomic minimum, flip the winners' batch), with the
/// per-slot state they keep from round to round. With first_fake given, the rounds of flip_fake_fans
/// instead (fake_fan_candidate proposes).
class FlipRounds {
public:
  FlipRounds(Mesh& mesh, CpuExecutor& executor, std::uint32_t first_fake = kNoId)
      : mesh_(mesh), executor_(executor), first_fake_(first_fake), mark_(mesh.num_slots(), kNoId),
        active_(mesh.num_slots(), 0), batch_(mesh.num_slots()) {}

  /// Flags the slots of `list` as active (the paper's marked triangles of the coming round).
  void activate(const std::vector<std::uint32_t>& list) {
    const std::uint32_t* l = list.data();
    std::uint8_t* flag = active_.data();
    executor_.for_each(list.size(), [&](std::size_t k) { flag[l[k]] = 1; });
  }

  /// One round over `list` (flagged active): returns the next round's list, flagged active in its place,
  /// or an empty list when no triangle proposed a flip. Adds the round and its flips to `stats`.
  std::vector<std::uint32_t> round(const std::vector<std::uint32_t>& active, FlipStats& stats) {
    ++stats.rounds;
    const MeshView m = mesh_.view();
    const std::size_t n = active.size();
    proposed_edge_.resize(n);
    proposed_nbr_.resize(n);
    owned_.resize(n);
    const std::uint32_t* list = active.data();
    std::uint32_t* cand = proposed_edge_.data();
    std::uint32_t* nbr = proposed_nbr_.data();
    std::uint8_t* own = owned_.data();
    std::uint32_t* marks = mark_.data();
    std::uint8_t* active_flag = active_.data();
    const std::uint32_t* partner = batch_.partner();

    const FlipRound r{list, cand, nbr, marks, own};
    executor_.for_each(n, [&](std::size_t k) {
      const std::uint32_t t = list[k];
      record_flip_proposal(m, r, k,
                           first_fake_ == kNoId ? delaunay_flip_candidate(m, active_flag, partner, t)
                                                : fake_fan_candidate(m, active_flag, t, first_fake_),
                           AtomicMin{});
    });
    // Read the claims only after every claim is in (the global synchronisation between steps).
    executor_.for_each(n, [&](std::size_t k) { flip_claims_held(r, k); });
    const std::vector<std::uint32_t> winners =
        executor_.compact(n, [&](std::size_t k) { return flip_proposal_won(r, k); });
    if (winners.empty()) {
      // The lowest proposer always holds both of its claims, so no winner means no proposal.
      if (!executor_.compact(n, [&](std::size_t k) { return cand[k] != kNoId; }).empty()) {
        throw Error("internal error: a flipping round claimed no pair");
      }
      executor_.for_each(n, [&](std::size_t k) { active_flag[list[k]] = 0; });
      return {};
    }

    winner_edges_.resize(winners.size());
    {
      const std::uint32_t* w = winners.data();
      std::uint32_t* out = winner_edges_.data();
      executor_.for_each(winners.size(), [&](std::size_t k) { out[k] = cand[w[k]]; });
    }
    batch_.apply(mesh_, winner_edges_, executor_);
    stats.flips += winners.size();

    executor_.for_each(n, [&](std::size_t k) { clear_flip_claims(r, k); });

    // Next round: proposers that could not flip yet, plus both new triangles of every flip (new
    // triangles are unmarked in the paper's terms).
    const std::vector<std::uint32_t> waiting =
        executor_.compact(n, [&](std::size_t k) { return flip_proposal_waits(r, partner, k); });
    std::vector<std::uint32_t> next(waiting.size() + 2 * winners.size());
    {
      const std::uint32_t* wait = waiting.data();
      const std::uint32_t* w = winners.data();
      std::uint32_t* out = next.data();
      const std::size_t base = waiting.size();
      executor_.for_each(waiting.size(), [&](std::size_t k) { out[k] = list[wait[k]]; });
      executor_.for_each(winners.size(), [&](std::size_t k) {
        const std::uint32_t t = list[w[k]];
        out[base + 2 * k] = t;
        out[base + 2 * k + 1] = partner[t];
      });
    }
    executor_.for_each(n, [&](std::size_t k) { active_flag[list[k]] = 0; });
    activate(next);
    return next;
  }

  /// Clears the active flags of `list` and forgets the last batch's pairs: after flips made outside the
  /// rounds, a pair of the last batch no longer holds its fresh diagonal as edge 1.
  void reset(const std::vector<std::uint32_t>& list) {
    const std::uint32_t* l = list.data();
    std::uint8_t* flag = active_.data();
    executor_.for_each(list.size(), [&](std::size_t k) { flag[l[k]] = 0; });
    batch_.forget(executor_);
  }

private:
  Mesh& mesh_;
  CpuExecutor& executor_;
  std::uint32_t first_fake_;
  std::vector<std::uint32_t> mark_;
  std::vector<std::uint8_t> active_;
  FlipBatch batch_;
  std::vector<std::uint32_t> proposed_edge_;
  std::vector<std::uint32_t> proposed_nbr_;
  std::vector<std::uint8_t> owned_;
  std::vector<std::uint32_t> winner_edges_;
};

} // namespace

void FlipBatch::forget(CpuExecutor& executor) {
  std::uint32_t* partner = partner_.data();
  const std::uint32_t* last = last_pairs_.data();
  executor.for_each(last_pairs_.size(), [&](std::size_t k) { partner[last[k]] = kNoId; });
  last_pairs_.clear();
}

namespace {

/// Whether slot t is checked at first: live, and flagged in `only` when it is given.
bool checked_at_first(const MeshView& m, const std::uint8_t* only, std::uint32_t t) {
  return m.alive(t) && (only == nullptr || only[t] != 0);
}

} // namespace

FlipStats flip_to_delaunay(Mesh& mesh, CpuExecutor& executor, const std::uint8_t* only) {
  FlipStats stats;
  const std::uint32_t slots = mesh.num_slots();
  const MeshView m = mesh.view();
  FlipRounds rounds(mesh, executor);
  std::vector<std::uint32_t> active = executor.compact(
      slots, [&](std::size_t t) { return checked_at_first(m, only, static_cast<std::uint32_t>(t)); });
  rounds.activate(active);
  while (!active.empty()) active = rounds.round(active, stats);
  return stats;
}

FlipStats flip_fake_fans(Mesh& mesh, std::uint32_t first_fake, CpuExecutor& executor) {
  FlipStats stats;
  const MeshView m = mesh.view();
  FlipRounds rounds(mesh, executor, first_fake);
  std::vector<std::uint32_t> active = executor.compact(m.num_slots, [&](std::size_t t) {
    const auto s = static_cast<std::uint32_t>(t);
    return m.alive(s) && (m.v(s, 0) >= first_fake || m.v(s, 1) >= first_fake || m.v(s, 2) >= first_fake);
  });
  rounds.activate(active);
  while (!active.empty()) active = rounds.round(active, stats);
  return stats;
}

FlipStats flip_to_delaunay_in_parts(Mesh& mesh, CpuExecutor& executor, const std::uint8_t* only) {
  FlipStats stats;
  const std::uint32_t slots = mesh.num_slots();
  if (slots == 0) return stats;
  const MeshView m = mesh.view();
  const std::uint32_t parts = (slots + kPartSlots - 1) / kPartSlots;
  const auto part_of = [](std::uint32_t t) { return t / kPartSlots; };
  std::vector<std::vector<std::uint32_t>> stack(parts);    // edges to test, per part
  std::vector<std::vector<std::uint32_t>> deferred(parts); // slots with an edge to another part, per part
  std::vector<std::uint64_t> part_flips(parts, 0);
  std::vector<std::uint8_t> is_deferred(slots, 0);
  const auto defer = [&](std::uint32_t p, std::uint32_t t) {
    if (is_deferred[t] == 0) {
      is_deferred[t] = 1;
      deferred[p].push_back(t);
    }
  };
  // Drains part p's stack; the triangles it must leave wait for the next parallel round.
  const auto drain = [&](std::uint32_t p) {
    part_flips[p] += drain_in_part(
        m, stack[p], [&](std::uint32_t t) { return part_of(t) == p; }, [&](std::uint32_t t) { defer(p, t); });
  };

  // First, every edge of the triangles to check, each edge once when both sides are to be checked.
  executor.for_each_part(parts, [&](std::size_t pp) {
    const auto p = static_cast<std::uint32_t>(pp);
    const std::uint32_t lo = p * kPartSlots;
    const std::uint32_t hi = std::min(slots, lo + kPartSlots);
    const auto checked = [&](std::uint32_t t) { return checked_at_first(m, only, t); };
    for (std::uint32_t t = lo; t < hi; ++t) {
      if (!checked(t)) continue;
      for (std::uint32_t i = 0; i < 3; ++i) {
        const std::uint32_t e = m.adj[3 * t + i];
        if (e == kNoId) continue;
        const std::uint32_t u = edge_tri(e);
        if (u >= lo && u < hi && u < t && checked(u)) continue;
        stack[p].push_back(edge_id(t, i));
      }
    }
    // Popped from the back: reversed, the part is worked through in slot order.
    std::reverse(stack[p].begin(), stack[p].end());
    drain(p);
  });
  // What the parts left, on one thread that owns every slot: Lawson's algorithm from the deferred
  // triangles' edges. For the few percent of triangles on the parts' borders this costs far less than
  // the parallel rounds, each about ten passes over its triangles.
  std::vector<std::uint32_t> tail;
  for (const auto& list : deferred)
    for (const std::uint32_t t : list)
      for (std::uint32_t i = 0; i < 3; ++i) tail.push_back(edge_id(t, i));
  if (!tail.empty()) {
    ++stats.rounds;
    stats.flips += drain_in_part(
        m, tail, [](std::uint32_t) { return true; }, [](std::uint32_t) {});
  }
  for (const std::uint64_t f : part_flips) stats.flips += f;
  return stats;
}

} // namespace cdt::detail
