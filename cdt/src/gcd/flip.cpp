// Phase 5 of gCD and Step 3 of the CDT (paper section 3.5; section 4, "Step 3"): parallel Lawson
// flipping with atomic-minimum claims, the two-step link update, and a compacted list of the triangles
// that still need checking.

#include "gcd/flip.hpp"

#include <string>

#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"

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

FlipStats flip_to_delaunay(Mesh& mesh, CpuExecutor& executor, const std::uint8_t* only) {
  FlipStats stats;
  const std::uint32_t slots = mesh.num_slots();
  const MeshView m = mesh.view();
  std::vector<std::uint32_t> mark(slots, kNoId);
  std::vector<std::uint8_t> in_active(slots, 0);
  FlipBatch batch(slots);
  std::uint32_t* marks = mark.data();
  std::uint8_t* active_flag = in_active.data();

  std::vector<std::uint32_t> active = executor.compact(slots, [&](std::size_t t) {
    return m.alive(static_cast<std::uint32_t>(t)) && (only == nullptr || only[t] != 0);
  });
  std::vector<std::uint32_t> proposed_edge;
  std::vector<std::uint32_t> proposed_nbr;
  std::vector<std::uint8_t> owned;
  std::vector<std::uint32_t> winner_edges;
  {
    const std::uint32_t* list = active.data();
    executor.for_each(active.size(), [&](std::size_t k) { active_flag[list[k]] = 1; });
  }

  const std::uint32_t* partner = batch.partner();
  while (!active.empty()) {
    ++stats.rounds;
    const std::size_t n = active.size();
    proposed_edge.resize(n);
    proposed_nbr.resize(n);
    owned.resize(n);
    const std::uint32_t* list = active.data();
    std::uint32_t* cand = proposed_edge.data();
    std::uint32_t* nbr = proposed_nbr.data();
    std::uint8_t* own = owned.data();

    // Propose and claim: the proposer's slot index is its label, so the lowest proposer wins.
    executor.for_each(n, [&](std::size_t k) {
      const std::uint32_t t = list[k];
      const std::uint32_t e = delaunay_flip_candidate(m, active_flag, partner, t);
      cand[k] = e;
      nbr[k] = kNoId;
      if (e == kNoId) return;
      const std::uint32_t u = edge_tri(m.adj[e]);
      nbr[k] = u;
      atomic_min(marks + t, t);
      atomic_min(marks + u, t);
    });
    // Read the claims only after every claim is in (the global synchronisation between steps); the bits
    // also say which marks this proposer must clear, so each mark has exactly one clearer.
    executor.for_each(n, [&](std::size_t k) {
      if (cand[k] == kNoId) {
        own[k] = 0;
        return;
      }
      const std::uint32_t t = list[k];
      own[k] = static_cast<std::uint8_t>((marks[t] == t ? 1u : 0u) | (marks[nbr[k]] == t ? 2u : 0u));
    });
    const std::vector<std::uint32_t> winners =
        executor.compact(n, [&](std::size_t k) { return own[k] == 3; });
    if (winners.empty()) {
      // The lowest proposer always holds both of its claims, so no winner means no proposal.
      if (!executor.compact(n, [&](std::size_t k) { return cand[k] != kNoId; }).empty()) {
        throw Error("internal error: a Delaunay flipping round claimed no pair");
      }
      break;
    }

    winner_edges.resize(winners.size());
    {
      const std::uint32_t* w = winners.data();
      std::uint32_t* out = winner_edges.data();
      executor.for_each(winners.size(), [&](std::size_t k) { out[k] = cand[w[k]]; });
    }
    batch.apply(mesh, winner_edges, executor);
    stats.flips += winners.size();

    executor.for_each(n, [&](std::size_t k) {
      if (own[k] & 1u) marks[list[k]] = kNoId;
      if (own[k] & 2u) marks[nbr[k]] = kNoId;
    });

    // Next round: proposers that could not flip yet, plus both new triangles of every flip (new
    // triangles are unmarked in the paper's terms). A losing proposer that was flipped as some winner's
    // neighbour comes in through the second list only.
    const std::vector<std::uint32_t> waiting =
        executor.compact(n, [&](std::size_t k) { return cand[k] != kNoId && partner[list[k]] == kNoId; });
    std::vector<std::uint32_t> next(waiting.size() + 2 * winners.size());
    {
      const std::uint32_t* wait = waiting.data();
      const std::uint32_t* w = winners.data();
      std::uint32_t* out = next.data();
      const std::size_t base = waiting.size();
      executor.for_each(waiting.size(), [&](std::size_t k) { out[k] = list[wait[k]]; });
      executor.for_each(winners.size(), [&](std::size_t k) {
        const std::uint32_t t = list[w[k]];
        out[base + 2 * k] = t;
        out[base + 2 * k + 1] = partner[t];
      });
    }
    executor.for_each(n, [&](std::size_t k) { active_flag[list[k]] = 0; });
    {
      const std::uint32_t* out = next.data();
      executor.for_each(next.size(), [&](std::size_t k) { active_flag[out[k]] = 1; });
    }
    active.swap(next);
  }
  return stats;
}

} // namespace cdt::detail
