// Phase 5 of gCD and Step 3 of the CDT on the CUDA executor (paper section 3.5; section 4, "Step 3"):
// parallel Lawson flipping in rounds. The per-element work is cdt/src/gcd/flip.hpp's
// (delaunay_flip_candidate, flip_pair_contents, relink_flipped_pair), and the driver below runs the
// same steps as the CPU executor's flip_to_delaunay (cdt/src/gcd/flip.cpp) in the same order, with the
// same compactions, so both flip the same pairs in every round and end with the same mesh. The last
// rounds, on short lists, run in one thread block, the middle ones in one cooperative grid (FlipLoop,
// run by TeamRounds), the same steps.

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

#include "block_steps.cuh"
#include "cdt/detail/trace.hpp"
#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"
#include "device_mesh.cuh"
#include "gcd/flip.hpp"

namespace cdt::gpu {

using ::cdt::detail::edge_tri;
using ::cdt::detail::FlipRound;
using ::cdt::detail::kNoId;
using ::cdt::detail::MeshView;

namespace detail {

/// Device memory of a mesh (mesh_kernels.cu).
std::size_t mesh_device_bytes(std::size_t slots, std::size_t nv);

/// Device memory that flipping a mesh of num_slots slots and num_vertices vertices needs, in bytes.
std::size_t flip_device_bytes(std::size_t num_slots, std::size_t num_vertices) {
  // The mesh (tri, adj, seg; x, y, vert_tri); per slot: mark, partner, active flag, two slot lists,
  // the round's candidates, neighbours, ownership bits, winners and their edges, the last pairs and
  // vertex fixes; CUB's scratch and the executor's own.
  return 36 * num_slots + 20 * num_vertices + num_slots * (4 + 4 + 1 + 8 + 8 + 1 + 8 + 8 + 1) +
         (std::size_t{4} << 20);
}

DeviceFlipBatch::DeviceFlipBatch(CudaExecutor& executor, std::uint32_t slots)
    : partner(slots), last(slots), fix(slots / 2 + 1) {
  executor.fill_bytes(partner.data(), 0xFF, slots);
}

/// Lists of at most this many triangles are flipped by one block (FlipLoop): its rounds take 10-30
/// microseconds, against 100-150 as separate launches (each a few microseconds of the host's time, and
/// three waits for counts).
constexpr std::uint32_t kFlipBlockLimit = 4096;

/// Lists of more than kFlipBlockLimit and at most this many triangles are flipped by a cooperative grid
/// (FlipLoop), where the device can launch one: on the H200 machine the coastlines' nine middle
/// rounds of Phase 5 (197251 triangles down to 4655) took 1.17 ms there against 1.80 as launches.
constexpr std::uint32_t kFlipGridLimit = std::uint32_t{1} << 18;

/// flip_mesh's buffers and state, for FlipLoop.
struct FlipRounds {
  MeshView m;
  std::uint32_t first_fake;
  std::uint32_t* list;
  std::uint32_t* next;
  std::uint32_t n;
  std::uint8_t* active_flag;
  std::uint32_t* marks;
  std::uint32_t* partner;
  std::uint32_t* last;
  std::uint32_t num_last;
  std::uint8_t* fix;
  std::uint32_t* cand;
  std::uint32_t* nbr;
  std::uint8_t* own;
  std::uint32_t* winners;
  std::uint32_t* waiting;
};

/// What FlipLoop leaves for the host.
struct FlipRoundsEnd {
  std::uint32_t n;        ///< the list's length (0: done, else above the limit)
  std::uint32_t in_next;  ///< 1 when the list is in `next`
  std::uint32_t num_last; ///< the last batch's slots
  std::uint32_t rounds;
  unsigned long long flips;
  std::uint32_t error;      ///< 0, kLostLink or kNoPair
  std::uint32_t error_edge; ///< with kLostLink: the flipped pair's edge
};
constexpr std::uint32_t kLostLink = 1;
constexpr std::uint32_t kNoPair = 2;

/// flip_mesh's rounds, the same steps in the same order, by a team (BlockTeam or GridTeam) while the
/// list has more than `lo` and at most `hi` triangles.
struct FlipLoop {
  template <class Team>
  __device__ void operator()(const Team& team, const FlipRounds& a, std::uint32_t lo, std::uint32_t hi,
                             FlipRoundsEnd* end) const;
};

template <class Team>
__device__ void FlipLoop::operator()(const Team& team, const FlipRounds& a, std::uint32_t lo,
                                     std::uint32_t hi, FlipRoundsEnd* end) const {
  const MeshView m = a.m;
  std::uint32_t* list = a.list;
  std::uint32_t* next = a.next;
  std::uint32_t n = a.n;
  std::uint32_t num_last = a.num_last;
  std::uint32_t rounds = 0, in_next = 0, error = 0, error_edge = kNoId;
  unsigned long long flips = 0;
  while (n > lo && n <= hi) {
    ++rounds;
    const FlipRound r{list, a.cand, a.nbr, a.marks, a.own};
    team.for_each(n, [&](std::uint32_t k) {
      const std::uint32_t t = list[k];
      ::cdt::detail::record_flip_proposal(
          m, r, k,
          a.first_fake == kNoId ? ::cdt::detail::delaunay_flip_candidate(m, a.active_flag, a.partner, t)
                                : ::cdt::detail::fake_fan_candidate(m, a.active_flag, t, a.first_fake),
          ClaimMin{});
    });
    team.sync();
    team.for_each(n, [&](std::uint32_t k) { ::cdt::detail::flip_claims_held(r, k); });
    team.sync();
    const std::uint32_t num_winners = team.compact(
        n, [&](std::uint32_t k) { return ::cdt::detail::flip_proposal_won(r, k); }, a.winners);
    if (num_winners == 0) {
      // The lowest proposer always holds both of its claims, so no winner means no proposal.
      if (team.compact(
              n, [&](std::uint32_t k) { return a.cand[k] != kNoId; }, a.waiting) != 0)
        error = kNoPair;
      n = 0;
      break;
    }
    const std::uint32_t failed = team_apply_flips(team, m, a.partner, a.last, num_last, a.fix, num_winners,
                                                  [&](std::uint32_t k) { return a.cand[a.winners[k]]; });
    if (failed != kNoId) {
      error = kLostLink;
      error_edge = a.cand[a.winners[failed]];
      n = 0;
      break;
    }
    flips += num_winners;
    team.for_each(n, [&](std::uint32_t k) { ::cdt::detail::clear_flip_claims(r, k); });
    // Next round: proposers that could not flip yet, plus both new triangles of every flip.
    const std::uint32_t num_waiting = team.compact(
        n, [&](std::uint32_t k) { return ::cdt::detail::flip_proposal_waits(r, a.partner, k); }, a.waiting);
    team.for_each(num_waiting, [&](std::uint32_t k) { next[k] = list[a.waiting[k]]; });
    team.for_each(num_winners, [&](std::uint32_t k) {
      const std::uint32_t t = list[a.winners[k]];
      next[num_waiting + 2 * k] = t;
      next[num_waiting + 2 * k + 1] = a.partner[t];
    });
    team.for_each(n, [&](std::uint32_t k) { a.active_flag[list[k]] = 0; });
    team.sync();
    const std::uint32_t num_next = num_waiting + 2 * num_winners;
    team.for_each(num_next, [&](std::uint32_t k) { a.active_flag[next[k]] = 1; });
    team.sync();
    std::uint32_t* const swap = list;
    list = next;
    next = swap;
    in_next ^= 1u;
    n = num_next;
  }
  if (team.leader()) *end = FlipRoundsEnd{n, in_next, num_last, rounds, flips, error, error_edge};
}

using FlipTeamRounds = TeamRounds<FlipLoop, FlipRounds, FlipRoundsEnd, kFlipBlockLimit, kFlipGridLimit>;

/// A launched flipping round's words on the device: the counts its steps size themselves by, and
/// what the host reads at its end, once.
struct FlipRoundWords {
  std::uint32_t undecided; ///< proposers the filters left undecided, listed for the exact tests
  std::uint32_t winners;
  std::uint32_t waiting;
  std::uint32_t failed;     ///< the lowest winner whose pair lost a link, or kNoId
  std::uint32_t error;      ///< 0, kLostLink or kNoPair
  std::uint32_t error_edge; ///< with kLostLink: the flipped pair's edge
  /// The next list's length (kNoId after an error) in the low half, the round's flips in the high.
  unsigned long long reply;
};

/// The flips on a mesh on the device: flip_to_delaunay's rounds, the first over the live slots t with
/// only[t] != 0 when only is given. With first_fake given, the fake fans' flips instead
/// (fake_fan_candidate), the first round over the live slots with a fake corner.
FlipResult flip_mesh(DeviceMesh::State& s, const std::uint8_t* only, std::uint32_t first_fake = kNoId) {
  s.require_alone("flips");
  FlipResult result;
  const std::uint32_t slots = s.num_slots;
  if (slots == 0) return result;
  result.device_bytes = flip_device_bytes(slots, s.num_vertices);
  CudaExecutor& executor = s.executor;
  require_device_memory(result.device_bytes - mesh_device_bytes(slots, s.num_vertices), 0,
                        "Delaunay flipping of " + std::to_string(slots) + " triangles");
  DeviceEvent started, flipped;
  started.record(executor.stream());
  MeshView m = s.view();
  if (!s.constrained) m.seg = nullptr; // every id kNoId: the flips need not read or move them
  DeviceBuffer<std::uint32_t> d_mark(slots), d_list(slots), d_next(slots);
  DeviceBuffer<std::uint8_t> d_active_flag(slots);
  DeviceBuffer<std::uint32_t> d_cand(slots), d_nbr(slots), d_winners(slots), d_winner_edges(slots);
  DeviceBuffer<std::uint32_t> d_waiting(slots);
  DeviceBuffer<std::uint8_t> d_own(slots);
  DeviceFlipBatch batch(executor, slots);
  std::uint32_t* marks = d_mark.data();
  const std::uint32_t* partner = batch.partner.data();
  std::uint8_t* active_flag = d_active_flag.data();
  executor.fill_bytes(marks, 0xFF, slots);
  executor.fill_bytes(active_flag, 0, slots);

  std::uint32_t* list = d_list.data();
  std::uint32_t* next = d_next.data();
  std::uint32_t n = executor.compact(
      slots,
      [=] __device__(std::size_t t) {
        if (!m.alive(static_cast<std::uint32_t>(t)) || (only != nullptr && only[t] == 0)) return false;
        return first_fake == kNoId || (m.tri[3 * t] >= first_fake || m.tri[3 * t + 1] >= first_fake ||
                                       m.tri[3 * t + 2] >= first_fake);
      },
      list);
  {
    const std::uint32_t* l = list;
    executor.for_each(
        n, [=] __device__(std::size_t k) { active_flag[l[k]] = 1; }, "activate");
  }
  std::uint32_t* cand = d_cand.data();
  std::uint32_t* nbr = d_nbr.data();
  std::uint8_t* own = d_own.data();
  std::uint32_t* winners = d_winners.data();
  std::uint32_t* winner_edges = d_winner_edges.data();
  std::uint32_t* waiting = d_waiting.data();

  // A round's proposals, the fake fans' or the Delaunay flips'.
  const auto propose = [&](const FlipRound& r, std::uint32_t* undecided_count) {
    const std::uint32_t* l = r.list;
    const std::uint32_t count = n;
    if (first_fake != kNoId) {
      executor.for_each(
          count,
          [=] __device__(std::size_t k) {
            ::cdt::detail::record_flip_proposal(
                m, r, k, ::cdt::detail::fake_fan_candidate(m, active_flag, l[k], first_fake), ClaimMin{});
          },
          "flip_propose_fans");
      return;
    }
    // The predicates' filters alone first (a kernel of few registers: 44 against 84 with the exact
    // fallbacks, for sm_90), then the exact tests over the proposers they left undecided, listed in
    // `waiting` (free until the claims are read; for_each_undecided).
    std::uint32_t* undecided = waiting;
    executor.for_each(
        count,
        [=] __device__(std::size_t k) {
          bool open = false;
          ::cdt::detail::record_flip_proposal(
              m, r, k, ::cdt::detail::delaunay_flip_candidate<false>(m, active_flag, partner, l[k], &open),
              ClaimMin{});
          if (open) undecided[atomicAdd(undecided_count, 1u)] = static_cast<std::uint32_t>(k);
        },
        "flip_propose");
    for_each_undecided(
        executor, count, undecided, undecided_count,
        [=] __device__(std::uint32_t k) {
          ::cdt::detail::record_flip_proposal(
              m, r, k, ::cdt::detail::delaunay_flip_candidate(m, active_flag, partner, l[k]), ClaimMin{});
        },
        "flip_propose_exact");
  };
  DeviceBuffer<FlipRoundWords> d_words(1);
  executor.fill_bytes(&d_words.data()->undecided, 0, 1); // then zeroed by each round's end

  DeviceBuffer<FlipRoundsEnd> d_end(1);
  FlipTeamRounds team_rounds;
  // Traced, each round (or each run of rounds in a block or a grid) is waited for and timed.
  ::cdt::detail::StepTrace trace("device flips");
  const auto mark = [&](const char* step) {
    if (::cdt::detail::trace_enabled()) executor.synchronize();
    trace.mark(step);
  };
  mark("listed");
  while (n > 0) {
    trace.count("list", n);
    if (team_rounds.takes(n)) {
      team_rounds.launch(n,
                         FlipRounds{m, first_fake, list, next, n, active_flag, marks, batch.partner.data(),
                                    batch.last.data(), batch.num_last, batch.fix.data(), cand, nbr, own,
                                    winners, waiting},
                         d_end.data(), executor.stream(), "FlipLoop");
      FlipRoundsEnd end{};
      executor.download(&end, d_end.data(), 1);
      result.rounds += end.rounds;
      result.flips += end.flips;
      batch.num_last = end.num_last;
      if (end.in_next != 0) std::swap(list, next);
      if (end.error == kLostLink)
        throw Error("internal error: flipped pair at edge " + std::to_string(end.error_edge) +
                    " lost a neighbour link (the triangulation was not valid)");
      if (end.error == kNoPair) throw Error("internal error: a flipping round claimed no pair");
      n = end.n;
      trace.count("rounds in a team", end.rounds);
      mark("team rounds");
      continue;
    }
    ++result.rounds;
    const std::uint32_t* l = list;
    const FlipRound r{l, cand, nbr, marks, own};
    // The round's steps size themselves by the counts its compactions leave on the device, and the
    // host waits once, for the next list's length and the round's flips (and errors) together.
    FlipRoundWords* words = d_words.data();
    executor.fill_bytes(&words->failed, 0xFF, 1);
    propose(r, &words->undecided);
    executor.for_each(
        n, [=] __device__(std::size_t k) { ::cdt::detail::flip_claims_held(r, k); }, "flip_claims");
    executor.compact_to(
        n, [=] __device__(std::size_t k) { return ::cdt::detail::flip_proposal_won(r, k); }, winners,
        &words->winners);
    const auto num_winners = [=] __device__() -> std::size_t { return words->winners; };
    const auto num_waiting = [=] __device__() -> std::size_t { return words->waiting; };
    executor.for_each_counted(
        n, num_winners, [=] __device__(std::size_t k) { winner_edges[k] = cand[winners[k]]; },
        "winner_edges");
    apply_flips_counted(executor, batch, m, winner_edges, n, num_winners, &words->failed);
    executor.for_each(
        n, [=] __device__(std::size_t k) { ::cdt::detail::clear_flip_claims(r, k); }, "clear_claims");
    // Next round: proposers that could not flip yet, plus both new triangles of every flip.
    executor.compact_to(
        n, [=] __device__(std::size_t k) { return ::cdt::detail::flip_proposal_waits(r, partner, k); },
        waiting, &words->waiting);
    executor.for_each_counted(
        n, num_waiting, [=] __device__(std::size_t k) { next[k] = l[waiting[k]]; }, "next_waiting");
    executor.for_each_counted(
        n, num_winners,
        [=] __device__(std::size_t k) {
          const std::uint32_t at = words->waiting + 2 * static_cast<std::uint32_t>(k);
          const std::uint32_t t = l[winners[k]];
          next[at] = t;
          next[at + 1] = partner[t];
        },
        "next_flipped");
    executor.for_each(
        n, [=] __device__(std::size_t k) { active_flag[l[k]] = 0; }, "deactivate");
    {
      const std::uint32_t* nx = next;
      executor.for_each_counted(
          std::min<std::size_t>(2 * std::size_t{n}, slots),
          [=] __device__() -> std::size_t { return words->waiting + 2 * std::size_t{words->winners}; },
          [=] __device__(std::size_t k) { active_flag[nx[k]] = 1; }, "activate");
    }
    executor.for_each(
        1,
        [=] __device__(std::size_t) {
          const std::uint32_t flips = words->winners;
          std::uint32_t num_next = words->waiting + 2 * flips;
          words->error = 0;
          if (words->failed != kNoId) {
            words->error = kLostLink;
            words->error_edge = winner_edges[words->failed];
            num_next = kNoId;
          } else if (flips == 0 && words->waiting != 0) {
            // The lowest proposer always holds both of its claims, so no winner means no proposal.
            words->error = kNoPair;
            num_next = kNoId;
          }
          words->reply = round_reply(num_next, flips);
          words->undecided = 0;
        },
        "flip_round_end");
    const RoundReply reply = wait_for_reply(executor, &words->reply);
    const std::uint32_t num_next = reply.next, flips = reply.count;
    if (num_next == kNoId) {
      FlipRoundWords failure{};
      executor.download(&failure, words, 1);
      if (failure.error == kLostLink)
        throw Error("internal error: flipped pair at edge " + std::to_string(failure.error_edge) +
                    " lost a neighbour link (the triangulation was not valid)");
      throw Error("internal error: a flipping round claimed no pair");
    }
    batch.num_last = 2 * flips;
    result.flips += flips;
    std::swap(list, next);
    n = num_next;
    trace.count("flipped", flips);
    mark("round");
  }
  flipped.record(executor.stream());
  result.flip_ms = flipped.since(started);
  return result;
}

} // namespace detail

FlipResult DeviceMesh::flip_fake_fans(std::uint32_t first_fake) {
  return detail::flip_mesh(*state_, nullptr, first_fake);
}

FlipResult DeviceMesh::flip() { return detail::flip_mesh(*state_, nullptr); }

FlipResult DeviceMesh::flip_after_insert() {
  const detail::DeviceBuffer<std::uint8_t>& made = state_->made_by_insert;
  if (made.size() != state_->num_slots) return flip(); // no insert since the mesh changed size
  return detail::flip_mesh(*state_, made.data());
}

FlipResult DeviceMesh::flip_after_constraints() {
  const detail::DeviceBuffer<std::uint8_t>& flipped = state_->flipped_by_constraints;
  if (flipped.size() != state_->num_slots) return FlipResult{}; // no constraints were inserted
  return detail::flip_mesh(*state_, flipped.data());
}

FlipResult flip_to_delaunay(::cdt::detail::Mesh& mesh) {
  using Clock = std::chrono::steady_clock;
  const auto started = Clock::now();
  DeviceMesh device(mesh);
  const auto uploaded = Clock::now();
  FlipResult result = device.flip();
  const auto flipped = Clock::now();
  device.download(mesh);
  const auto done = Clock::now();
  result.upload_ms = std::chrono::duration<float, std::milli>(uploaded - started).count();
  result.download_ms = std::chrono::duration<float, std::milli>(done - flipped).count();
  return result;
}

} // namespace cdt::gpu
