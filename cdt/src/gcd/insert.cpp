// Phase 4 of gCD (paper section 3.4): missing points insertion (Algorithm 3) and fake boundary removal; the
// host drivers that sequence the data-parallel steps. Per-element work is in insert.hpp and shift.hpp.

#include "gcd/insert.hpp"

#include <algorithm>
#include <atomic>
#include <bit>
#include <numeric>
#include <ranges>
#include <string>
#include <vector>

#include "cdt/detail/trace.hpp"
#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"
#include "gcd/part_lawson.hpp"

namespace cdt::detail {

InsertStats insert_missing_points(Mesh& mesh, std::span<const MissingPoint> missing, CpuExecutor& executor,
                                  std::vector<std::uint8_t>* touched) {
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
  if (touched != nullptr) touched->resize(m.num_slots, 0);
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
  const InsertClaims claims{missing.data(), start.data(), loc_t.data(), loc_e.data(),
                            loc_u.data(),   loc_j.data(), mark.data(),  flags.data()};

  while (!remaining.empty()) {
    ++stats.rounds;
    const std::size_t n = remaining.size();
    // Lines 2-5: locate and mark the containers.
    executor.for_each(n, [&](std::size_t r) {
      locate_and_claim(m, claims, remaining[r], pending.data(), fallback, AtomicMin{},
                       [&](WorkStatus status) { failure.record(status); });
    });
    failure.check("inserting missing points (Algorithm 3, point location)");
    // Lines 6-13: winners, and a start for the losers next round.
    executor.for_each(n, [&](std::size_t r) { settle_insert_claims(m, claims, remaining[r]); });
    executor.for_each(n, [&](std::size_t r) { restart_at_winner(claims, remaining[r]); });
    std::vector<std::uint32_t> winners =
        executor.compact(n, [&](std::size_t r) { return insert_claim_won(claims, remaining[r]); });
    // The smallest located key holds every mark it made, so a round without winners means none was located.
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
      if (touched != nullptr) {
        for (const std::uint32_t x : {loc_t[q], loc_u[q], new0[q], new1[q]})
          if (x != kNoId) (*touched)[x] = 1;
      }
    });
    // Lines 20-22: outer links.
    executor.for_each(num_winners, [&](std::size_t r) { link_split_outer_edges(m, round, winners[r]); });
    executor.for_each(n, [&](std::size_t r) { clear_insert_claims(claims, remaining[r]); });
    cursor += 2 * num_winners;
    stats.inserted += num_winners;
    std::vector<std::uint32_t> rest =
        executor.compact(n, [&](std::size_t r) { return !insert_claim_won(claims, remaining[r]); });
    for (auto& x : rest) x = remaining[x];
    remaining.swap(rest);
  }
  return stats;
}

namespace {

/// Where a walk inside a part ended.
enum class PartWalk { inside, on_edge, left_part, failed };

/// A visibility walk from triangle t towards (px, py) over the part's triangles (owns), at most
/// kMaxPartWalk steps: crosses the first edge (in an order that turns with the step count, so that it
/// cannot cycle for long) that has the point strictly on its far side. Ends inside a triangle, strictly
/// inside one of its edges (edge), or, when the next triangle is another part's or there is none, the
/// point is a vertex or the walk is too long, without a place.
constexpr std::uint32_t kMaxPartWalk = 4096;

template <class Owns>
PartWalk walk_in_part(const MeshView& m, Owns&& owns, std::uint32_t& t, double px, double py,
                      std::uint32_t& edge) {
  for (std::uint32_t step = 0; step < kMaxPartWalk; ++step) {
    if (!owns(t)) return PartWalk::left_part;
    std::uint32_t zeros = 0;
    std::uint32_t next = kNoId;
    for (std::uint32_t r = 0; r < 3 && next == kNoId; ++r) {
      const std::uint32_t k = (step + r) % 3;
      const std::uint32_t a = m.tri[3 * t + next3(k)], b = m.tri[3 * t + prev3(k)];
      const int o = orient2d(m.xy[a].x, m.xy[a].y, m.xy[b].x, m.xy[b].y, px, py);
      if (o < 0) {
        next = m.adj[3 * t + k];
        if (next == kNoId) return PartWalk::failed;
      } else if (o == 0) {
        ++zeros;
        edge = k;
      }
    }
    if (next == kNoId) {
      if (zeros == 0) return PartWalk::inside;
      return zeros == 1 ? PartWalk::on_edge : PartWalk::failed;
    }
    t = edge_tri(next);
  }
  return PartWalk::failed;
}

/// Points the neighbour across encoded edge ne (just moved into a new slot) back at it.
inline void relink_outer(const MeshView& m, std::uint32_t ne) {
  const std::uint32_t old = m.adj[ne];
  if (old != kNoId) m.adj[old] = ne;
}

} // namespace

InsertStats insert_missing_points_in_parts(Mesh& mesh, std::span<const MissingPoint> missing,
                                           CpuExecutor& executor, std::vector<std::uint8_t>& dirty,
                                           bool is_delaunay) {
  InsertStats stats;
  const std::size_t num = missing.size();
  // Each insertion's flips below assume a Delaunay mesh around it.
  StepTrace tr("insert");
  if (!is_delaunay) stats.flips = flip_to_delaunay_in_parts(mesh, executor).flips;
  tr.mark("sites' mesh flipped");
  const std::uint32_t slots_before = mesh.num_slots();
  dirty.assign(slots_before, 0);
  if (num == 0) return stats;
  const std::uint32_t nv = mesh.num_vertices();
  if (num >= kNoId / 2) throw Error("internal error: too many missing points");
  // Per vertex, its place in `missing` (kNoId for the others).
  std::vector<std::uint32_t> place(nv, kNoId);
  for (std::size_t q = 0; q < num; ++q) {
    const std::uint32_t v = missing[q].vertex;
    if (v >= nv || mesh.vert_tri[v] != kNoId || place[v] != kNoId)
      throw Error("internal error: missing point " + std::to_string(v) +
                  " out of range, already in the mesh or listed twice");
    place[v] = static_cast<std::uint32_t>(q);
  }
  // A start in the mesh for each point: its hint, or when that is a missing point too, the hint's hint
  // (a few steps at most); kNoId when none is found.
  std::vector<std::uint32_t> from(num);
  executor.for_each(num, [&](std::size_t q) {
    std::uint32_t h = missing[q].hint;
    for (int step = 0; step < 4 && h < nv && mesh.vert_tri[h] == kNoId && place[h] != kNoId; ++step)
      h = missing[place[h]].hint;
    from[q] = h < nv && mesh.vert_tri[h] != kNoId ? h : kNoId;
  });

  // Each point's part: that of its hint's triangle (none when the hint is not in the mesh yet). The
  // points of a part in the order of their vertices, which follows a space-filling curve.
  const std::uint32_t parts = (slots_before + kPartSlots - 1) / kPartSlots;
  std::vector<std::uint32_t> order(num);
  std::vector<std::uint32_t> key(num);
  executor.for_each(num, [&](std::size_t q) {
    key[q] = missing[q].vertex;
    order[q] = static_cast<std::uint32_t>(q);
  });
  executor.sort_pairs_by_key(key, order, std::bit_width(nv));
  executor.for_each(num, [&](std::size_t k) {
    const std::uint32_t h = from[order[k]];
    key[k] = h == kNoId ? parts : mesh.vert_tri[h] / kPartSlots;
  });
  executor.sort_pairs_by_key(key, order, std::bit_width(parts));
  // Where each part's points start, from the sorted parts; the points with no part come last.
  std::vector<std::uint32_t> start(parts + 2, 0);
  for (const std::uint32_t p : key) ++start[p + 1];
  for (std::uint32_t p = 0; p <= parts; ++p) start[p + 1] += start[p];

  // New slots: two per point, after the existing ones, in part order (the points with no part last).
  if (static_cast<std::uint64_t>(slots_before) + 2ull * num >= kNoId / 3)
    throw Error("internal error: too many triangle slots");
  mesh.grow_slots(static_cast<std::uint32_t>(2 * num));
  const MeshView m = mesh.view();
  std::vector<std::uint32_t> owner(m.num_slots);
  executor.for_each(slots_before,
                    [&](std::size_t t) { owner[t] = static_cast<std::uint32_t>(t) / kPartSlots; });
  executor.for_each_part(parts + 1, [&](std::size_t p) {
    for (std::uint32_t k = start[p]; k < start[p + 1]; ++k) {
      owner[slots_before + 2 * k] = static_cast<std::uint32_t>(p);
      owner[slots_before + 2 * k + 1] = static_cast<std::uint32_t>(p);
    }
  });
  dirty.assign(m.num_slots, 0);
  std::vector<std::uint8_t> inserted(num, 0);

  // Inserts the points order[k] for the given k, each located by a walk over the slots it owns from
  // the last point placed (else from its hint), split into its own two new slots and followed at once
  // by its Lawson flips; a point whose walk, split or flips would need a slot it does not own is left
  // out (split) or deferred to `defer` (flips). Returns the flips made.
  const auto insert_points = [&](auto&& ks, auto&& owns, auto&& defer) {
    std::vector<std::uint32_t> todo;
    std::uint32_t last = kNoId;
    std::uint64_t flips = 0;
    for (const std::uint32_t k : ks) {
      const std::uint32_t q = order[k];
      const std::uint32_t v = missing[q].vertex;
      const double px = m.xy[v].x, py = m.xy[v].y;
      std::uint32_t t = kNoId, edge = 3;
      PartWalk where = PartWalk::failed;
      for (const std::uint32_t origin : {last, from[q]}) {
        if (origin == kNoId) continue;
        t = std::atomic_ref<std::uint32_t>(m.vert_tri[origin]).load(std::memory_order_relaxed);
        if (t == kNoId || !owns(t)) continue;
        where = walk_in_part(m, owns, t, px, py, edge);
        if (where == PartWalk::inside || where == PartWalk::on_edge) break;
      }
      const std::uint32_t s0 = slots_before + 2 * k, s1 = s0 + 1;
      if (where == PartWalk::inside) {
        // t = (a, b, c) -> (v, b, c), s0 = (a, v, c), s1 = (a, b, v); s0 and s1 take t's edges 1 and 2.
        const std::uint32_t n1 = m.adj[3 * t + 1], n2 = m.adj[3 * t + 2];
        if ((n1 != kNoId && !owns(edge_tri(n1))) || (n2 != kNoId && !owns(edge_tri(n2)))) continue;
        const std::uint32_t a = m.tri[3 * t];
        split_triangle(m, v, t, s0, s1, 0);
        relink_outer(m, edge_id(s0, 1));
        relink_outer(m, edge_id(s1, 2));
        move_vert_tri(m, a, t, s0);
        todo.insert(todo.end(), {edge_id(t, 0), edge_id(s0, 1), edge_id(s1, 2)});
      } else if (where == PartWalk::on_edge) {
        // Edge i of t = (a, b, c) is edge j of u = (d, c, b): t -> (a, b, v), s0 = (a, v, c),
        // u -> (d, c, v), s1 = (d, v, b); s0 takes t's edge i1, s1 takes u's edge j1.
        const std::uint32_t i = edge, f = m.adj[3 * t + i];
        if (f == kNoId || !owns(edge_tri(f))) continue;
        const std::uint32_t u = edge_tri(f), j = edge_index(f);
        const std::uint32_t n_t = m.adj[3 * t + next3(i)], n_u = m.adj[3 * u + next3(j)];
        if ((n_t != kNoId && !owns(edge_tri(n_t))) || (n_u != kNoId && !owns(edge_tri(n_u)))) continue;
        const std::uint32_t b = m.tri[3 * t + next3(i)], c = m.tri[3 * t + prev3(i)];
        split_edge(m, v, t, i, u, j, s0, s1, 0);
        relink_outer(m, edge_id(s0, next3(i)));
        relink_outer(m, edge_id(s1, next3(j)));
        move_vert_tri(m, b, u, t);
        move_vert_tri(m, c, t, u);
        todo.insert(todo.end(), {edge_id(t, prev3(i)), edge_id(s0, next3(i)), edge_id(u, prev3(j)),
                                 edge_id(s1, next3(j))});
      } else {
        continue;
      }
      inserted[q] = 1;
      last = v;
      flips += drain_in_part(m, todo, owns, defer);
    }
    return flips;
  };

  tr.mark("points by part");
  std::vector<std::uint64_t> part_flips(parts, 0);
  executor.for_each_part(parts, [&](std::size_t pp) {
    const auto p = static_cast<std::uint32_t>(pp);
    part_flips[p] = insert_points(
        std::views::iota(start[p], start[p + 1]), [&](std::uint32_t t) { return owner[t] == p; },
        [&](std::uint32_t t) { dirty[t] = 1; });
  });
  tr.mark("parts");
  stats.rounds = 1;
  for (const std::uint64_t f : part_flips) stats.flips += f;

  // What the parts left (points near their borders, points with no part), on one thread that owns
  // every slot: the same insertion with flips, far cheaper than Algorithm 3's rounds (each about ten
  // passes over its points). It starts from the dirty triangles' flips: the parts' deferred edges.
  {
    std::vector<std::uint32_t> todo;
    for (std::uint32_t t = 0; t < m.num_slots; ++t) {
      if (dirty[t] == 0) continue;
      dirty[t] = 0;
      if (m.alive(t))
        for (std::uint32_t i = 0; i < 3; ++i) todo.push_back(edge_id(t, i));
    }
    const auto everything = [](std::uint32_t) { return true; };
    const auto none = [](std::uint32_t) {};
    stats.flips += drain_in_part(m, todo, everything, none);
    std::vector<std::uint32_t> left;
    for (std::uint32_t k = 0; k < num; ++k)
      if (inserted[order[k]] == 0) left.push_back(k);
    stats.flips += insert_points(left, everything, none);
  }
  tr.mark("tail");

  // The rest by Algorithm 3's rounds, without flips: their triangles are dirty.
  const std::vector<std::uint32_t> rest =
      executor.compact(num, [&](std::size_t q) { return inserted[q] == 0; });
  stats.inserted = num - rest.size();
  if (!rest.empty()) {
    MissingArray left(rest.size());
    executor.for_each(rest.size(), [&](std::size_t k) { left[k] = missing[rest[k]]; });
    const InsertStats r = insert_missing_points(mesh, left, executor, &dirty);
    stats.rounds += r.rounds;
    stats.inserted += r.inserted;
  }
  tr.mark("rounds");
  return stats;
}

void delete_fake_vertices(Mesh& mesh, std::uint32_t first_fake, CpuExecutor& executor,
                          const std::uint32_t* ranked_as) {
  const std::uint32_t nv = mesh.num_vertices();
  if (first_fake > nv) throw Error("internal error: remove_fake_boundary: first_fake beyond the vertices");
  const MeshView m = mesh.view();
  std::vector<std::uint8_t> leaving(nv, 0);
  executor.for_each(nv - first_fake, [&](std::size_t i) {
    leaving[first_fake + i] = m.vert_tri[first_fake + i] != kNoId ? kLeaving : kStays;
  });
  std::vector<std::uint32_t> fakes =
      executor.compact(nv - first_fake, [&](std::size_t i) { return leaving[first_fake + i] != kStays; });
  for (auto& f : fakes) f += first_fake;
  delete_vertices(
      mesh, std::move(fakes), HoleShape::open_fan, leaving,
      [](std::span<const std::uint32_t>, std::span<const std::uint32_t>) {}, executor, ranked_as);
}

void remove_fake_boundary(Mesh& mesh, std::uint32_t first_fake, CpuExecutor& executor,
                          std::vector<std::uint8_t>* changed, bool compact) {
  const std::uint32_t nv = mesh.num_vertices();
  // The fake vertices' fans: the holes are filled into these slots.
  if (changed != nullptr) {
    const MeshView m = mesh.view();
    std::vector<std::uint8_t>& flag = *changed;
    executor.for_each(m.num_slots, [&](std::size_t t) {
      if (!m.alive(static_cast<std::uint32_t>(t))) return;
      for (std::uint32_t i = 0; i < 3; ++i)
        if (m.tri[3 * t + i] >= first_fake) flag[t] = 1;
    });
  }
  delete_fake_vertices(mesh, first_fake, executor);

  if (!compact) {
    mesh.xy.resize(first_fake);
    mesh.vert_tri.resize(first_fake);
    return;
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
  // Only live slots' entries of new_id are read (links and vert_tri name live slots), and the new
  // arrays are written whole before they are copied back into the mesh's own storage.
  UnzeroedVector<std::uint32_t> new_id(m.num_slots);
  executor.for_each(live.size(), [&](std::size_t r) { new_id[live[r]] = static_cast<std::uint32_t>(r); });
  UnzeroedVector<std::uint32_t> tri(3 * live.size()), adj(3 * live.size()), seg(3 * live.size());
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
  if (changed != nullptr) {
    std::vector<std::uint8_t> moved(live.size());
    executor.for_each(live.size(), [&](std::size_t r) { moved[r] = (*changed)[live[r]]; });
    changed->swap(moved);
  }
  mesh.tri.resize(tri.size());
  mesh.adj.resize(adj.size());
  mesh.seg.resize(seg.size());
  executor.for_each(tri.size(), [&](std::size_t k) {
    mesh.tri[k] = tri[k];
    mesh.adj[k] = adj[k];
    mesh.seg[k] = seg[k];
  });
  mesh.xy.resize(first_fake);
  mesh.vert_tri.resize(first_fake);
}

} // namespace cdt::detail
