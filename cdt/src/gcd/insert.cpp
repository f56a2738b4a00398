// Phase 4 of gCD (paper section 3.4): missing points insertion (Algorithm 3) and fake boundary removal; the
// host drivers that sequence the data-parallel steps. Per-element work is in insert.hpp and shift.hpp.

#include "gcd/insert.hpp"

#include <algorithm>
#include <bit>
#include <numeric>
#include <string>
#include <vector>

#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"

namespace cdt::detail {

InsertStats insert_missing_points(Mesh& mesh, std::span<const MissingPoint> missing, CpuExecutor& executor) {
  InsertStats stats;
  const std::size_t num = missing.size();
  if (num == 0) return stats;
  const std::uint32_t nv = mesh.num_vertices();
  if (num >= kNoId / 2) throw Error("internal error: too many missing points");

  // Every insertion takes exactly two slots, so the mesh grows once up front and no round reallocates.
  {
    const MeshView m0 = mesh.view();
    const std::size_t free_now =
        executor.compact(m0.num_slots, [&](std::size_t t) { return !m0.alive(t); }).size();
    const std::size_t need = 2 * num;
    if (free_now < need) {
      if (mesh.num_slots() + (need - free_now) >= kNoId / 3)
        throw Error("internal error: too many triangle slots");
      mesh.grow_slots(static_cast<std::uint32_t>(need - free_now));
    }
  }
  const MeshView m = mesh.view();
  const std::vector<std::uint32_t> free_slots =
      executor.compact(m.num_slots, [&](std::size_t t) { return !m.alive(t); });

  std::vector<std::uint8_t> pending(nv, 0);
  for (const MissingPoint& p : missing) {
    if (p.vertex >= nv)
      throw Error("internal error: missing point " + std::to_string(p.vertex) + " out of range");
    if (m.vert_tri[p.vertex] != kNoId || pending[p.vertex] != 0)
      throw Error("internal error: missing point " + std::to_string(p.vertex) +
                  " is already in the mesh or listed twice");
    pending[p.vertex] = 1;
  }
  // A start for points whose hint will never be in the mesh: any vertex of a live triangle (they all stay).
  std::uint32_t fallback = kNoId;
  for (std::uint32_t t = 0; t < m.num_slots && fallback == kNoId; ++t)
    if (m.alive(t)) fallback = m.tri[3 * t];
  if (fallback == kNoId) throw Error("internal error: inserting missing points into an empty mesh");

  std::vector<std::uint32_t> start(num), loc_t(num), loc_e(num), loc_u(num), loc_j(num), new0(num), new1(num);
  std::vector<std::uint8_t> flags(num), own(num);
  for (std::size_t q = 0; q < num; ++q) start[q] = missing[q].hint;
  std::vector<std::uint32_t> mark(m.num_slots, kNoId);
  std::vector<std::uint32_t> remaining(num);
  std::iota(remaining.begin(), remaining.end(), 0u);
  std::size_t cursor = 0;
  WorkFailure failure;

  while (!remaining.empty()) {
    ++stats.rounds;
    const std::size_t n = remaining.size();
    // Lines 2-5: locate and mark the containers.
    executor.for_each(n, [&](std::size_t r) {
      const auto q = remaining[r];
      flags[q] = 0;
      loc_t[q] = kNoId;
      std::uint32_t o = start[q];
      if (o >= nv || m.vert_tri[o] == kNoId) {
        if (o < nv && pending[o] != 0) return; // the paper's delay: the hint is itself waiting
        o = fallback;
        start[q] = o;
      }
      const std::uint32_t v = missing[q].vertex;
      const MissingPointPlace at = place_missing_point(m, o, m.x[v], m.y[v]);
      if (at.status != WorkStatus::ok) {
        failure.record(at.status);
        return;
      }
      loc_t[q] = at.tri;
      loc_e[q] = at.edge;
      loc_u[q] = at.u;
      loc_j[q] = at.j;
      atomic_min(&mark[at.tri], q);
      if (at.u != kNoId) atomic_min(&mark[at.u], q);
    });
    failure.check("inserting missing points (Algorithm 3, point location)");

    // Lines 6-13: a point whose marks all survived wins; a loser keeps a container vertex, which stays in the
    // mesh, as its next start, so its next walk is short.
    executor.for_each(n, [&](std::size_t r) {
      const auto q = remaining[r];
      const std::uint32_t t = loc_t[q], u = loc_u[q];
      if (t == kNoId) return;
      const bool holds_t = mark[t] == q;
      const bool holds_u = u != kNoId && mark[u] == q;
      const bool wins = holds_t && (u == kNoId || holds_u);
      flags[q] =
          static_cast<std::uint8_t>((holds_t ? kHoldsT : 0) | (holds_u ? kHoldsU : 0) | (wins ? kWins : 0));
      if (!wins) start[q] = m.tri[3 * t];
    });
    // A loser whose container a winner splits lies in the winner's new fan, so the winner's vertex, whose
    // fan is just those three or four triangles, is a better start than a corner of the old container:
    // without Delaunay flips between rounds the old corners of crowded regions collect huge fans, and
    // every walk starting there would scan one.
    executor.for_each(n, [&](std::size_t r) {
      const auto q = remaining[r];
      if (loc_t[q] == kNoId || (flags[q] & kWins) != 0) return;
      for (const std::uint32_t c : {loc_t[q], loc_u[q]}) {
        if (c == kNoId) continue;
        const std::uint32_t w = mark[c];
        if (w != kNoId && (flags[w] & kWins) != 0) {
          start[q] = missing[w].vertex;
          return;
        }
      }
    });
    std::vector<std::uint32_t> winners =
        executor.compact(n, [&](std::size_t r) { return (flags[remaining[r]] & kWins) != 0; });
    // The smallest located index holds every mark it made, so a round without winners means none was located.
    if (winners.empty()) failure.record(WorkStatus::stuck);
    failure.check("inserting missing points (Algorithm 3; hints may form a cycle)");
    for (auto& w : winners) w = remaining[w];
    const std::size_t num_winners = winners.size();
    if (cursor + 2 * num_winners > free_slots.size())
      throw Error("internal error: out of free triangle slots");

    const InsertRound round{loc_t.data(), loc_e.data(), loc_u.data(), loc_j.data(),
                            new0.data(),  new1.data(),  mark.data(),  flags.data()};
    // Lines 14-16: slots by rank, and who rewrites each corner's vert_tri.
    executor.for_each(num_winners, [&](std::size_t r) {
      const auto q = winners[r];
      new0[q] = free_slots[cursor + 2 * r];
      new1[q] = free_slots[cursor + 2 * r + 1];
      own[q] = split_corner_owners(m, round, q);
    });
    // Lines 17-19: split the containers.
    executor.for_each(num_winners, [&](std::size_t r) {
      const auto q = winners[r];
      const std::uint32_t v = missing[q].vertex;
      if (loc_e[q] == 3)
        split_triangle(m, v, loc_t[q], new0[q], new1[q], own[q]);
      else
        split_edge(m, v, loc_t[q], loc_e[q], loc_u[q], loc_j[q], new0[q], new1[q], own[q]);
      pending[v] = 0;
    });
    // Lines 20-22: outer links.
    executor.for_each(num_winners, [&](std::size_t r) { link_split_outer_edges(m, round, winners[r]); });
    // Each mark has exactly one holder, which clears it, so no two threads touch one mark.
    executor.for_each(n, [&](std::size_t r) {
      const auto q = remaining[r];
      if (flags[q] & kHoldsT) mark[loc_t[q]] = kNoId;
      if (flags[q] & kHoldsU) mark[loc_u[q]] = kNoId;
    });
    cursor += 2 * num_winners;
    stats.inserted += num_winners;
    std::vector<std::uint32_t> rest =
        executor.compact(n, [&](std::size_t r) { return (flags[remaining[r]] & kWins) == 0; });
    for (auto& x : rest) x = remaining[x];
    remaining.swap(rest);
  }
  return stats;
}

void remove_fake_boundary(Mesh& mesh, std::uint32_t first_fake, CpuExecutor& executor) {
  const std::uint32_t nv = mesh.num_vertices();
  if (first_fake > nv) throw Error("internal error: remove_fake_boundary: first_fake beyond the vertices");
  {
    const MeshView m = mesh.view();
    std::vector<std::uint8_t> leaving(nv, 0);
    executor.for_each(nv - first_fake, [&](std::size_t i) {
      leaving[first_fake + i] = m.vert_tri[first_fake + i] != kNoId ? 1 : 0;
    });
    std::vector<std::uint32_t> fakes =
        executor.compact(nv - first_fake, [&](std::size_t i) { return leaving[first_fake + i] != 0; });
    for (auto& f : fakes) f += first_fake;
    delete_vertices(
        mesh, std::move(fakes), HoleShape::open_fan, leaving,
        [](std::span<const std::uint32_t>, std::span<const std::uint32_t>) {}, executor);
  }

  // Compaction, ordered by each triangle's lowest vertex; links and vert_tri are renumbered. Sites are
  // numbered along a space-filling curve (triangulate.cpp), so this puts neighbouring triangles next to
  // each other in memory, also the ones Algorithm 3 created at the end of the slot array, and the
  // remaining steps (constraints, flips) mostly read cached slots. A stable radix sort keeps the
  // result independent of the thread count.
  const MeshView m = mesh.view();
  std::vector<std::uint32_t> live;
  {
    const std::vector<std::uint32_t> alive =
        executor.compact(m.num_slots, [&](std::size_t t) { return m.alive(t); });
    std::vector<std::uint32_t> key(alive.size());
    executor.for_each(alive.size(), [&](std::size_t r) {
      const std::uint32_t t = alive[r];
      key[r] = std::min({m.tri[3 * t], m.tri[3 * t + 1], m.tri[3 * t + 2]});
    });
    live = alive;
    executor.sort_pairs_by_key(key, live, std::bit_width(nv));
  }
  std::vector<std::uint32_t> new_id(m.num_slots, kNoId);
  executor.for_each(live.size(), [&](std::size_t r) { new_id[live[r]] = static_cast<std::uint32_t>(r); });
  std::vector<std::uint32_t> tri(3 * live.size()), adj(3 * live.size()), seg(3 * live.size());
  executor.for_each(live.size(), [&](std::size_t r) {
    const std::uint32_t t = live[r];
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t e = m.adj[3 * t + i];
      tri[3 * r + i] = m.tri[3 * t + i];
      adj[3 * r + i] = e == kNoId ? kNoId : edge_id(new_id[edge_tri(e)], edge_index(e));
      seg[3 * r + i] = m.seg[3 * t + i];
    }
  });
  executor.for_each(first_fake, [&](std::size_t v) {
    const std::uint32_t vt = m.vert_tri[v];
    m.vert_tri[v] = vt == kNoId ? kNoId : new_id[vt];
  });
  mesh.tri.swap(tri);
  mesh.adj.swap(adj);
  mesh.seg.swap(seg);
  mesh.x.resize(first_fake);
  mesh.y.resize(first_fake);
  mesh.vert_tri.resize(first_fake);
}

} // namespace cdt::detail
