// Step 2 of the CDT on the CUDA executor (paper section 4, Algorithms 4 and 5): constraint insertion
// by flipping on a mesh that stays on the device. The per-element work is cdt/src/gcd/constraints.hpp's
// (walk_piece, propose_constraint_flip, mark_after_flip) and the flips are FlipBatch's; the driver runs
// the same steps as the CPU executor's insert_constraints (cdt/src/gcd/constraints.cpp) in the same
// order with the same ordered compactions, so both insert the pieces by the same flips. Inner iterations
// on short lists run in one thread block, on middle ones in one cooperative grid (ConstraintLoop, run by
// TeamRounds), the same steps; on long ones as launches whose counts stay on the device, the host
// waiting once an iteration (ConstraintIterationWords) and once a marking pass (OuterWords).

#include <cooperative_groups.h>
#include <cooperative_groups/reduce.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <optional>
#include <string>
#include <system_error>
#include <utility>

#include "block_steps.cuh"
#include "cdt/detail/trace.hpp"
#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"
#include "device_mesh.cuh"
#include "gcd/constraints.hpp"
#include "pslg.hpp"
#include "walk_parts.cuh"

namespace cdt::gpu {

using ::cdt::detail::ConstraintPiece2;
using ::cdt::detail::ConstraintRound;
using ::cdt::detail::ConstraintStats;
using ::cdt::detail::ConstraintStatus;
using ::cdt::detail::edge_tri;
using ::cdt::detail::FlipCase;
using ::cdt::detail::FlipProposal;
using ::cdt::detail::kNoId;
using ::cdt::detail::MeshView;

namespace detail {
namespace {

// A flipping pass that flips fewer than one in this many marked triangles ends the inner loop early
// (constraints.cpp).
constexpr std::uint32_t kStalledShare = 16;

__device__ bool is_error(ConstraintStatus s) { return s >= ConstraintStatus::vertex_on_piece; }

/// The error of element `at` (the lowest failing one) of a step, as the CPU executor reports it.
[[noreturn]] void fail(CudaExecutor& executor, const ConstraintStatus* d_status, std::uint32_t at,
                       std::uint32_t piece_index, std::span<const ConstraintPiece2> pieces) {
  ConstraintStatus status{};
  executor.download(&status, d_status + at, 1);
  const ConstraintPiece2& p = pieces[piece_index];
  throw Error("internal error: constraint piece " + std::to_string(piece_index) + " (" + std::to_string(p.a) +
              ", " + std::to_string(p.b) + "): " + ::cdt::detail::constraint_status_message(status));
}

/// Lists of at most this many marked triangles run their inner iterations in one block
/// (ConstraintLoop).
constexpr std::uint32_t kConstraintBlockLimit = 4096;

/// Lists of at most this many run them in a cooperative grid when the device can.
constexpr std::uint32_t kConstraintGridLimit = std::uint32_t{1} << 18;

/// insert_constraints' buffers and state, for ConstraintLoop.
struct ConstraintRounds {
  MeshView m;
  const ConstraintPiece2* piece;
  std::uint32_t* cmark;
  std::uint32_t* claim;
  std::uint8_t* flipped;
  std::uint32_t* partner;
  std::uint32_t* last;
  std::uint32_t num_last;
  std::uint8_t* fix;
  std::uint32_t* active;
  std::uint32_t* next_active;
  std::uint32_t na;
  std::uint32_t iterations_left; ///< of this outer iteration's inner limit
  std::uint32_t allowed;         ///< inner iterations before the bound of the whole insertion
  ConstraintStatus* status;
  std::uint32_t *edge, *next_tri, *prev_tri, *label, *picked;
  std::uint8_t* own;
};

/// Why ConstraintLoop stopped, besides the list's length or the inner limit.
enum class ConstraintStop : std::uint32_t { none, no_winners, stalled, proposal_error, lost_link, too_many };

/// What ConstraintLoop leaves for the host.
struct ConstraintRoundsEnd {
  std::uint32_t na;         ///< marked triangles left in the list
  std::uint32_t in_next;    ///< 1 when the list is in `next_active`
  std::uint32_t iterations; ///< inner iterations run
  std::uint32_t num_last;   ///< the last batch's slots
  unsigned long long flips;
  ConstraintStop stop;
  std::uint32_t error_at;    ///< with proposal_error: the element
  std::uint32_t error_piece; ///< and its piece; with lost_link: the flipped pair's edge
};

/// A marking pass's words on the device: the counts its steps size themselves by, and what the host
/// reads at its end, once.
struct OuterWords {
  unsigned long long crossings; ///< the first pass's piece-triangle crossings
  std::uint32_t left;           ///< pieces walked and not present
  std::uint32_t marked;         ///< triangles marked by them
  std::uint32_t first_error;    ///< the lowest walk that failed, or kNoId
};

/// A launched inner iteration's words on the device: the counts its steps size themselves by, and what
/// the host reads at its end, once.
struct ConstraintIterationWords {
  std::uint32_t undecided; ///< proposals the filter left undecided, listed for the exact tests
  std::uint32_t error_at;  ///< the lowest element whose proposal failed, or kNoId
  std::uint32_t failed;    ///< the lowest winner whose pair lost a link, or kNoId
  std::uint32_t winners;
  std::uint32_t still; ///< marked triangles left in the list
  /// The next list's length (kNoId after an error) in the low half, the iteration's flips in the high.
  unsigned long long reply;
};

/// insert_constraints' inner iterations (Algorithm 5), the same steps in the same order, by a team
/// (BlockTeam or GridTeam) while the list has more than `lo` and at most `hi` triangles.
struct ConstraintLoop {
  template <class Team>
  __device__ void operator()(const Team& team, const ConstraintRounds& a, std::uint32_t lo, std::uint32_t hi,
                             ConstraintRoundsEnd* end) const;
};

template <class Team>
__device__ void ConstraintLoop::operator()(const Team& team, const ConstraintRounds& a, std::uint32_t lo,
                                           std::uint32_t hi, ConstraintRoundsEnd* end) const {
  const MeshView m = a.m;
  std::uint32_t* act = a.active;
  std::uint32_t* next = a.next_active;
  std::uint32_t na = a.na, num_last = a.num_last, iterations = 0, in_next = 0;
  std::uint32_t error_at = kNoId, error_piece = kNoId;
  unsigned long long flips = 0;
  ConstraintStop stop = ConstraintStop::none;
  while (na > lo && na <= hi && iterations < a.iterations_left) {
    if (iterations == a.allowed) {
      stop = ConstraintStop::too_many;
      break;
    }
    ++iterations;
    if (team.leader()) *team.word = kNoId;
    team.sync();
    const ConstraintRound round{act, a.edge, a.prev_tri, a.next_tri, a.label, a.claim, a.own};
    // Algorithm 5, lines 2-11: cases, then claims by atomic minimum of the label.
    team.for_each(na, [&](std::uint32_t k) {
      FlipProposal proposal;
      a.status[k] = ::cdt::detail::propose_constraint_flip(m, a.cmark, a.piece, act[k], proposal);
      if (is_error(a.status[k])) atomicMin(team.word, k);
      ::cdt::detail::record_constraint_proposal(m, round, k, proposal, ClaimMin{});
    });
    team.sync();
    if (const std::uint32_t first = team.word_value(); first != kNoId) {
      stop = ConstraintStop::proposal_error;
      error_at = first;
      error_piece = a.cmark[act[first]];
      break;
    }
    // Algorithm 5, line 13: flip only where every claim held.
    team.for_each(na, [&](std::uint32_t k) { ::cdt::detail::constraint_claims_held(round, k); });
    team.sync();
    std::uint32_t* winners = a.picked;
    const std::uint32_t num_winners = team.compact(
        na, [&](std::uint32_t k) { return ::cdt::detail::constraint_proposal_won(round, k); }, winners);
    team.for_each(na, [&](std::uint32_t k) { ::cdt::detail::clear_constraint_claims(round, k); });
    team.sync();
    if (num_winners == 0) { // the lowest label holds all its claims: nothing was flippable
      stop = ConstraintStop::no_winners;
      break;
    }
    const std::uint32_t lost = team_apply_flips(team, m, a.partner, a.last, num_last, a.fix, num_winners,
                                                [&](std::uint32_t k) { return a.edge[winners[k]]; });
    if (lost != kNoId) {
      stop = ConstraintStop::lost_link;
      error_piece = a.edge[winners[lost]];
      break;
    }
    team.for_each(num_winners, [&](std::uint32_t k) {
      const std::uint32_t A = act[winners[k]];
      ::cdt::detail::mark_after_flip(m, a.cmark, a.piece, A, a.partner[A], a.cmark[A]);
      a.flipped[A] = a.flipped[a.partner[A]] = 1;
    });
    team.sync();
    flips += num_winners;
    // The stalled rule of constraints.cpp: marking again beats proposing over stuck triangles.
    const bool stalled = static_cast<std::uint64_t>(num_winners) * kStalledShare < na;
    std::uint32_t* still = a.picked;
    const std::uint32_t num_still = team.compact(
        na, [&](std::uint32_t k) { return a.cmark[act[k]] != kNoId; }, still);
    team.for_each(num_still, [&](std::uint32_t k) { next[k] = act[still[k]]; });
    team.sync();
    std::uint32_t* const swap = act;
    act = next;
    next = swap;
    in_next ^= 1u;
    na = num_still;
    if (stalled) {
      stop = ConstraintStop::stalled;
      break;
    }
  }
  if (team.leader())
    *end = ConstraintRoundsEnd{na, in_next, iterations, num_last, flips, stop, error_at, error_piece};
}

using ConstraintTeamRounds = TeamRounds<ConstraintLoop, ConstraintRounds, ConstraintRoundsEnd,
                                        kConstraintBlockLimit, kConstraintGridLimit>;

} // namespace

WalkHints make_walk_hints(CudaExecutor& executor, const MeshView& m, DeviceBuffer<std::uint32_t>& cells) {
  WalkHints h;
  if (m.num_vertices < 3) return h;
  const Extent box = box_of(executor, m.num_vertices, m.xy);
  const double width = box.max_x - box.min_x, height = box.max_y - box.min_y;
  h.width = width;
  h.height = height;
  const double extent = width > height ? width : height;
  if (!(extent > 0.0) || !std::isfinite(extent)) return h;
  h.side = static_cast<std::uint32_t>(std::clamp(std::sqrt(m.num_vertices / 4.0), 1.0, 2048.0));
  h.x0 = box.min_x;
  h.y0 = box.min_y;
  h.inverse_cell = h.side / extent;
  if (!std::isfinite(h.inverse_cell)) {
    WalkHints box_only;
    box_only.width = width;
    box_only.height = height;
    return box_only;
  }
  h.part_length = kPartSteps * ::cdt::detail::even_spacing(width, height, m.num_vertices);
  cells.resize(static_cast<std::size_t>(h.side) * h.side);
  executor.fill_bytes(cells.data(), 0xFF, cells.size());
  std::uint32_t* cell = cells.data();
  h.cell = cell;
  const WalkHints hints = h;
  executor.for_each(
      m.num_vertices,
      [=] __device__(std::size_t v) {
        if (m.vert_tri[v] != kNoId) cell[hints.cell_of(m.xy[v].x, m.xy[v].y)] = static_cast<std::uint32_t>(v);
      },
      "walk_hints");
  return h;
}

void check_device_pieces(CudaExecutor& executor, const ConstraintPiece2* pieces,
                         std::span<const ConstraintPiece2> host_pieces, std::uint32_t num_vertices) {
  if (host_pieces.empty()) return;
  DeviceBuffer<std::uint32_t> d_bad(1);
  std::uint32_t* bad = d_bad.data();
  executor.fill_bytes(bad, 0xFF, 1);
  executor.for_each(
      host_pieces.size(),
      [=] __device__(std::size_t k) {
        if (!::cdt::detail::piece_endpoints_valid(pieces[k], num_vertices))
          atomicMin(bad, static_cast<std::uint32_t>(k));
      },
      "check_pieces");
  std::uint32_t first = kNoId;
  executor.download(&first, bad, 1);
  if (first != kNoId) ::cdt::detail::throw_invalid_piece(first, host_pieces[first]);
}

void check_same_pieces(CudaExecutor& executor, const ConstraintPiece2* pieces,
                       std::span<const ConstraintPiece2> host_pieces) {
  if (host_pieces.empty()) return;
  DeviceBuffer<ConstraintPiece2> d_host(host_pieces.size());
  executor.upload(d_host.data(), host_pieces.data(), host_pieces.size());
  DeviceBuffer<std::uint32_t> d_first(1);
  std::uint32_t* first = d_first.data();
  executor.fill_bytes(first, 0xFF, 1);
  const ConstraintPiece2* host = d_host.data();
  executor.for_each(
      host_pieces.size(),
      [=] __device__(std::size_t k) {
        if (pieces[k].a != host[k].a || pieces[k].b != host[k].b || pieces[k].id != host[k].id)
          atomicMin(first, static_cast<std::uint32_t>(k));
      },
      "same_pieces");
  std::uint32_t at = kNoId;
  executor.download(&at, first, 1);
  if (at != kNoId)
    throw Error("internal error: the device's piece " + std::to_string(at) + " differs from the host's");
}

/// insert_constraints on the mesh `m` (on the device) by `executor`; `checked_pieces`, when given, are
/// host_pieces on the device, already checked (else they are uploaded and checked here). A run given
/// `stop` returns at its next step once it is set, the mesh part way.
ConstraintStats insert_constraints(CudaExecutor& executor, const MeshView& m,
                                   std::span<const ConstraintPiece2> host_pieces, unsigned inner_iterations,
                                   std::uint8_t* flipped, const HostParallelFor& parallel,
                                   const ConstraintPiece2* checked_pieces = nullptr,
                                   const std::atomic<bool>* stop = nullptr,
                                   const std::uint32_t* only = nullptr, std::uint32_t num_only = 0) {
  ConstraintStats stats;
  const std::uint32_t slots = m.num_slots;
  ::cdt::detail::check_constraint_counts(slots, host_pieces.size());
  if (host_pieces.empty() || (only != nullptr && num_only == 0)) return stats;
  // Traced, the set-up's steps, each outer iteration's walk and inner iterations are waited for and
  // timed.
  ::cdt::detail::StepTrace trace("device constraints");
  const auto mark = [&](const char* step) {
    if (::cdt::detail::trace_enabled()) executor.synchronize();
    trace.mark(step);
  };
  const std::uint64_t max_inner_iterations = ::cdt::detail::constraint_iteration_bound(m.num_vertices);
  const unsigned inner_limit = inner_iterations == 0 ? 1u : inner_iterations;
  const auto num_pieces = static_cast<std::uint32_t>(host_pieces.size());

  const auto stopped = [stop] { return stop != nullptr && stop->load(std::memory_order_relaxed); };
  DeviceBuffer<ConstraintPiece2> d_pieces;
  if (checked_pieces == nullptr) {
    d_pieces.resize(num_pieces);
    executor.upload(d_pieces.data(), host_pieces.data(), num_pieces, &parallel);
    check_device_pieces(executor, d_pieces.data(), host_pieces, m.num_vertices);
    mark("pieces uploaded");
  }
  const ConstraintPiece2* piece = checked_pieces != nullptr ? checked_pieces : d_pieces.data();
  DeviceBuffer<std::uint32_t> d_cmark(slots), d_claim(slots);
  std::uint32_t* cmark = d_cmark.data();
  std::uint32_t* claim = d_claim.data();
  executor.fill_bytes(claim, 0xFF, slots);
  DeviceFlipBatch batch(executor, slots);

  DeviceBuffer<std::uint32_t> d_pending(num_pieces), d_next_pending(num_pieces), d_left(num_pieces);
  DeviceBuffer<ConstraintStatus> d_walk_status(num_pieces);
  DeviceBuffer<std::uint32_t> d_present(num_pieces), d_crossings(num_pieces);
  // Every piece pending, or those listed in `only` (device indices).
  const std::uint32_t np_first = only != nullptr ? num_only : num_pieces;
  {
    std::uint32_t* pending = d_pending.data();
    executor.for_each(
        np_first,
        [=] __device__(std::size_t k) {
          pending[k] = only != nullptr ? only[k] : static_cast<std::uint32_t>(k);
        },
        "pieces_pending");
  }
  std::uint32_t np = np_first;
  // The proposals' buffers, per active triangle (at most every slot).
  DeviceBuffer<std::uint32_t> d_active(slots), d_next_active(slots), d_picked(slots);
  DeviceBuffer<std::uint32_t> d_edge(slots), d_next_tri(slots), d_prev_tri(slots), d_label(slots);
  DeviceBuffer<std::uint32_t> d_winner_edges(slots);
  DeviceBuffer<ConstraintIterationWords> d_words(1);
  executor.fill_bytes(&d_words.data()->undecided, 0, 1); // then zeroed by each iteration's end
  DeviceBuffer<std::uint8_t> d_own(slots);
  DeviceBuffer<ConstraintStatus> d_prop_status(slots);
  // A marking pass's counts and its walks' first error, read by the host once a pass.
  DeviceBuffer<OuterWords> d_outer(1);
  // The inner iterations in a block or a grid, for every outer iteration.
  DeviceBuffer<ConstraintRoundsEnd> d_block_end(1);
  ConstraintTeamRounds team_rounds;
  std::uint32_t* error_at = &d_outer.data()->first_error;
  // The long pieces' walks in parts (walk_parts.cuh): the grid of hints, the parts' buffers; per
  // pending piece whether its first part met the second's start; per part its status and crossings;
  // per long piece whether it is walked whole again.
  DeviceBuffer<std::uint32_t> d_hint_cells;
  mark("buffers");
  const WalkHints hints = make_walk_hints(executor, m, d_hint_cells);
  WalkParts walk_parts;
  DeviceBuffer<std::uint32_t> d_part_cross, d_again;
  DeviceBuffer<std::uint8_t> d_met, d_redo;
  DeviceBuffer<ConstraintStatus> d_part_status;

  mark("walk hints");

  for (;;) {
    if (stopped()) return stats;
    ++stats.outer_iterations;
    std::uint32_t na = 0;
    trace.count("pieces walked", np);
    // Algorithm 4, line 3: marks from scratch, each piece's walk lowering them to its index.
    executor.fill_bytes(cmark, 0xFF, slots);
    {
      const std::uint32_t* pend = d_pending.data();
      ConstraintStatus* st = d_walk_status.data();
      std::uint32_t* present = d_present.data();
      std::uint32_t* cross = d_crossings.data();
      executor.fill_bytes(error_at, 0xFF, 1);
      // The long pieces' walks in parts (walk_parts.cuh): the first part here, the others below.
      const WalkPartsView parts = plan_walk_parts(
          executor, m, hints, np, [=] __device__(std::size_t k) { return piece[pend[k]]; },
          [] __device__(std::size_t) { return true; }, walk_parts);
      d_met.resize(np);
      std::uint8_t* met = d_met.data();
      executor.for_each(
          np,
          [=] __device__(std::size_t k) {
            const std::uint32_t i = pend[k];
            const auto mark = [cmark, i](std::uint32_t t) { atomicMin(cmark + t, i); };
            bool met_stop = false;
            st[k] = ::cdt::detail::walk_piece(m, piece[i].a, piece[i].b, mark, present[k], cross[k],
                                              parts.first_stop_of(k), &met_stop);
            met[k] = met_stop ? 1 : 0;
            if (is_error(st[k])) atomicMin(error_at, static_cast<std::uint32_t>(k));
          },
          "walk_pieces");
      if (parts.num_long > 0) {
        // The parts after the first, each to the next part's start.
        const std::uint32_t num_long = parts.num_long, num_parts = parts.num_parts;
        d_part_status.resize(num_parts);
        d_part_cross.resize(num_parts);
        ConstraintStatus* part_status = d_part_status.data();
        std::uint32_t* part_cross = d_part_cross.data();
        executor.for_each(
            num_parts,
            [=] __device__(std::size_t u) {
              part_status[u] = ConstraintStatus::ok;
              part_cross[u] = 0;
              const PartStart start = parts.part_start[u];
              if (start.tri == kNoId) return;
              const std::uint32_t i = pend[parts.longs[parts.part_of[u]]];
              const std::uint32_t stop = parts.stop_after(static_cast<std::uint32_t>(u));
              const auto mark = [cmark, i](std::uint32_t t) { atomicMin(cmark + t, i); };
              bool met_stop = false;
              ConstraintStatus status = ::cdt::detail::walk_piece_part(
                  m, piece[i].a, piece[i].b, start.tri, start.at, stop, mark, part_cross[u], met_stop);
              // A part that reached b before the next one's start: the parts were out of order.
              if (status == ConstraintStatus::ok && stop != kNoId && !met_stop)
                status = ConstraintStatus::corrupt_mesh;
              part_status[u] = status;
            },
            "walk_parts");
        // Each long piece's status is its parts' first that is not ok, its crossings their sum; parts
        // out of order (a part ending at b, or the first part not meeting the second's start) walk
        // the piece whole again.
        d_redo.resize(num_long);
        std::uint8_t* redo = d_redo.data();
        executor.for_each(
            num_long,
            [=] __device__(std::size_t l) {
              const std::uint32_t k = parts.longs[l];
              redo[l] = 0;
              if (st[k] != ConstraintStatus::ok) return; // present, or an error before the first stop
              bool in_order = parts.first_stop[k] == kNoId || met[k] != 0;
              ConstraintStatus status = ConstraintStatus::ok;
              std::uint32_t crossings = cross[k];
              for (std::uint32_t u = parts.long_first[l]; u < parts.end_of(l); ++u) {
                if (part_status[u] == ConstraintStatus::corrupt_mesh && parts.part_start[u].tri != kNoId) {
                  in_order = false;
                  break;
                }
                crossings += part_cross[u];
                if (part_status[u] != ConstraintStatus::ok) {
                  status = part_status[u];
                  break;
                }
              }
              if (!in_order) {
                redo[l] = 1;
                return;
              }
              st[k] = status;
              cross[k] = crossings;
              if (is_error(status)) atomicMin(error_at, k);
            },
            "join_parts");
        d_again.resize(num_long);
        const std::uint32_t num_redo = executor.compact(
            num_long, [=] __device__(std::size_t l) { return redo[l] != 0; }, d_again.data());
        if (num_redo > 0) {
          const std::uint32_t* again = d_again.data();
          executor.for_each(
              num_redo,
              [=] __device__(std::size_t r) {
                const std::uint32_t k = parts.longs[again[r]];
                const std::uint32_t i = pend[k];
                const auto mark = [cmark, i](std::uint32_t t) { atomicMin(cmark + t, i); };
                st[k] = ::cdt::detail::walk_piece(m, piece[i].a, piece[i].b, mark, present[k], cross[k]);
                if (is_error(st[k])) atomicMin(error_at, k);
              },
              "walk_pieces_whole");
        }
      }
      // The rest of the marking pass is queued before the host waits, once, for its counts and for
      // the walks' first error (OuterWords::first_error, which the walks lowered); after an error
      // nothing else is used.
      OuterWords* words = d_outer.data();
      if (stats.outer_iterations == 1) {
        unsigned long long* sum = &words->crossings;
        executor.fill_bytes(sum, 0, 1);
        // One atomic a warp: one a piece, all on one address, took 1.3 ms for the coastlines' 1.8
        // million pieces (H200).
        executor.for_each(
            np,
            [=] __device__(std::size_t k) {
              namespace cg = cooperative_groups;
              const cg::coalesced_group active = cg::coalesced_threads();
              const unsigned long long total = cg::reduce(active, static_cast<unsigned long long>(cross[k]),
                                                          cg::plus<unsigned long long>());
              if (active.thread_rank() == 0) atomicAdd(sum, total);
            },
            "sum_crossings");
      }
      // A separate step from the walks, which read seg. Duplicate pieces share an edge: lowest id wins.
      executor.for_each(
          np,
          [=] __device__(std::size_t k) {
            if (st[k] != ConstraintStatus::present) return;
            const std::uint32_t id = piece[pend[k]].id;
            atomicMin(m.seg + present[k], id);
            const std::uint32_t twin = m.adj[present[k]];
            if (twin != kNoId) atomicMin(m.seg + twin, id);
          },
          "present_pieces");
      std::uint32_t* left = d_left.data();
      executor.compact_to(
          np, [=] __device__(std::size_t k) { return st[k] == ConstraintStatus::ok; }, left, &words->left);
      std::uint32_t* next = d_next_pending.data();
      executor.for_each_counted(
          np, [=] __device__() -> std::size_t { return words->left; },
          [=] __device__(std::size_t k) { next[k] = pend[left[k]]; }, "next_pending");
      // Algorithm 5's list: the marked triangles (none are left when every piece is present).
      executor.compact_to(
          slots, [=] __device__(std::size_t t) { return cmark[t] != kNoId; }, d_active.data(),
          &words->marked);
      OuterWords counts{};
      executor.download(&counts, words, 1);
      if (counts.first_error != kNoId) {
        std::uint32_t index = 0;
        executor.download(&index, pend + counts.first_error, 1);
        fail(executor, st, counts.first_error, index, host_pieces);
      }
      if (stats.outer_iterations == 1) stats.intersections = counts.crossings;
      std::swap(d_pending, d_next_pending);
      np = counts.left;
      na = counts.marked;
    }
    mark("walked");
    if (np == 0) break;
    trace.count("marked triangles", na);
    const std::uint64_t inner_before = stats.inner_iterations;
    std::uint64_t outer_flips = 0;
    unsigned iteration = 0;
    while (iteration < inner_limit && na > 0) {
      if (stopped()) return stats;
      if (team_rounds.takes(na)) {
        const std::uint64_t allowed =
            max_inner_iterations - std::min(max_inner_iterations, stats.inner_iterations);
        const ConstraintRounds args{m,
                                    piece,
                                    cmark,
                                    claim,
                                    flipped,
                                    batch.partner.data(),
                                    batch.last.data(),
                                    batch.num_last,
                                    batch.fix.data(),
                                    d_active.data(),
                                    d_next_active.data(),
                                    na,
                                    inner_limit - iteration,
                                    static_cast<std::uint32_t>(std::min<std::uint64_t>(allowed, kNoId)),
                                    d_prop_status.data(),
                                    d_edge.data(),
                                    d_next_tri.data(),
                                    d_prev_tri.data(),
                                    d_label.data(),
                                    d_picked.data(),
                                    d_own.data()};
        team_rounds.launch(na, args, d_block_end.data(), executor.stream(), "ConstraintLoop");
        ConstraintRoundsEnd end{};
        executor.download(&end, d_block_end.data(), 1);
        iteration += end.iterations;
        stats.inner_iterations += end.iterations;
        if (end.stop == ConstraintStop::too_many)
          throw Error("internal error: constraint insertion did not finish within " +
                      std::to_string(max_inner_iterations) + " inner iterations");
        if (end.stop == ConstraintStop::proposal_error)
          fail(executor, d_prop_status.data(), end.error_at, end.error_piece, host_pieces);
        if (end.stop == ConstraintStop::lost_link) // as the launched iterations report it
          throw Error("internal error: flipped pair at edge " + std::to_string(end.error_piece) +
                      " lost a neighbour link (the triangulation was not valid)");
        stats.flips += end.flips;
        outer_flips += end.flips;
        batch.num_last = end.num_last;
        if (end.in_next != 0) std::swap(d_active, d_next_active);
        na = end.na;
        if (end.stop != ConstraintStop::none) break; // no winners, or stalled: mark again
        continue;
      }
      ++iteration;
      if (++stats.inner_iterations > max_inner_iterations) {
        throw Error("internal error: constraint insertion did not finish within " +
                    std::to_string(max_inner_iterations) + " inner iterations");
      }
      const std::uint32_t* act = d_active.data();
      ConstraintStatus* status = d_prop_status.data();
      std::uint8_t* own = d_own.data();
      const ConstraintRound round{
          act, d_edge.data(), d_prev_tri.data(), d_next_tri.data(), d_label.data(), claim, own};
      // The iteration's steps size themselves by the counts its compactions leave on the device, and
      // the host waits once, for the next list's length and the flips (and errors) together.
      ConstraintIterationWords* words = d_words.data();
      executor.fill_bytes(&words->error_at, 0xFF, 2); // error_at and failed

      // Algorithm 5, lines 2-11: cases, then claims by atomic minimum of the label.
      // orient2d's filter alone first (a kernel of 64 registers against 85 with the exact fallback, for
      // sm_90: four blocks on a multiprocessor instead of three); the proposals that met an orientation
      // it could not decide are listed and made again with the exact tests (for_each_undecided).
      const auto propose = [=] __device__(std::size_t k, const FlipProposal& proposal,
                                          ConstraintStatus found) {
        status[k] = found;
        if (is_error(found)) atomicMin(&words->error_at, static_cast<std::uint32_t>(k));
        ::cdt::detail::record_constraint_proposal(m, round, k, proposal, ClaimMin{});
      };
      // The undecided go to the next list's buffer, free until the iteration's end.
      std::uint32_t* undecided = d_next_active.data();
      std::uint32_t* undecided_count = &words->undecided;
      executor.for_each_64(
          na,
          [=] __device__(std::size_t k) {
            FlipProposal proposal;
            bool open = false;
            const ConstraintStatus found =
                ::cdt::detail::propose_constraint_flip<false>(m, cmark, piece, act[k], proposal, &open);
            if (open) {
              round.next_tri[k] = kNoId;
              undecided[atomicAdd(undecided_count, 1u)] = static_cast<std::uint32_t>(k);
              return;
            }
            propose(k, proposal, found);
          },
          "propose_constraint_flips");
      for_each_undecided(
          executor, na, undecided, undecided_count,
          [=] __device__(std::uint32_t k) {
            FlipProposal proposal;
            propose(k, proposal, ::cdt::detail::propose_constraint_flip(m, cmark, piece, act[k], proposal));
          },
          "propose_constraint_flips_exact");
      // Algorithm 5, line 13: flip only where every claim held; after a proposal's error, nowhere (the
      // host reports it once the iteration's reply is in).
      executor.for_each(
          na, [=] __device__(std::size_t k) { ::cdt::detail::constraint_claims_held(round, k); },
          "constraint_claims");
      std::uint32_t* winners = d_picked.data();
      executor.compact_to(
          na,
          [=] __device__(std::size_t k) {
            return words->error_at == kNoId && ::cdt::detail::constraint_proposal_won(round, k);
          },
          winners, &words->winners);
      executor.for_each(
          na, [=] __device__(std::size_t k) { ::cdt::detail::clear_constraint_claims(round, k); },
          "clear_constraint_claims");
      const auto num_winners = [=] __device__() -> std::size_t { return words->winners; };
      std::uint32_t* winner_edges = d_winner_edges.data();
      executor.for_each_counted(
          na, num_winners, [=] __device__(std::size_t k) { winner_edges[k] = round.edge[winners[k]]; },
          "constraint_winner_edges");
      apply_flips_counted(executor, batch, m, winner_edges, na, num_winners, &words->failed);
      {
        const std::uint32_t* partner = batch.partner.data();
        executor.for_each_counted(
            na, num_winners,
            [=] __device__(std::size_t k) {
              const std::uint32_t A = act[winners[k]];
              ::cdt::detail::mark_after_flip(m, cmark, piece, A, partner[A], cmark[A]);
              flipped[A] = flipped[partner[A]] = 1; // the pairs are disjoint: one writer per slot
            },
            "mark_after_flip");
      }
      // Flips only reuse slots of marked triangles, so the marked set shrinks within the list.
      std::uint32_t* still = d_picked.data(); // the winners' list is read by then
      executor.compact_to(
          na, [=] __device__(std::size_t k) { return cmark[act[k]] != kNoId; }, still, &words->still);
      std::uint32_t* next = d_next_active.data();
      executor.for_each_counted(
          na, [=] __device__() -> std::size_t { return words->still; },
          [=] __device__(std::size_t k) { next[k] = act[still[k]]; }, "next_active");
      executor.for_each(
          1,
          [=] __device__(std::size_t) {
            const bool failed = words->error_at != kNoId || words->failed != kNoId;
            words->reply = round_reply(failed ? kNoId : words->still, words->winners);
            words->undecided = 0;
          },
          "constraint_iteration_end");
      const RoundReply reply = wait_for_reply(executor, &words->reply);
      const std::uint32_t num_still = reply.next, num_flips = reply.count;
      if (num_still == kNoId) {
        ConstraintIterationWords failure{};
        executor.download(&failure, words, 1);
        if (failure.error_at != kNoId) {
          std::uint32_t A = 0, index = 0;
          executor.download(&A, act + failure.error_at, 1);
          executor.download(&index, cmark + A, 1);
          fail(executor, status, failure.error_at, index, host_pieces);
        }
        std::uint32_t edge = kNoId;
        executor.download(&edge, winner_edges + failure.failed, 1);
        throw Error("internal error: flipped pair at edge " + std::to_string(edge) +
                    " lost a neighbour link (the triangulation was not valid)");
      }
      batch.num_last = 2 * num_flips;
      if (num_flips == 0) break; // the lowest label holds all its claims: nothing was flippable
      stats.flips += num_flips;
      outer_flips += num_flips;
      // The stalled rule of constraints.cpp: marking again beats proposing over stuck triangles.
      const bool stalled = static_cast<std::uint64_t>(num_flips) * kStalledShare < na;
      std::swap(d_active, d_next_active);
      na = num_still;
      if (stalled) break;
    }
    trace.count("inner iterations", stats.inner_iterations - inner_before);
    trace.count("flips", outer_flips);
    mark("flipped");
    // Section 4.3: the lowest pending piece has all its triangles marked and always a flippable pair.
    if (outer_flips == 0) {
      throw Error("internal error: constraint insertion made no progress with " + std::to_string(np) +
                  " pieces pending (crossing pieces?)");
    }
  }
  return stats;
}

} // namespace detail

ConstraintStats DeviceMesh::insert_constraints(std::span<const ConstraintPiece2> pieces,
                                               unsigned inner_iterations, const HostParallelFor& parallel,
                                               bool more) {
  State& s = *state_;
  s.require_alone("insert_constraints");
  detail::CudaExecutor& executor = s.executor;
  detail::DeviceBuffer<std::uint8_t>& flipped = s.flipped_by_constraints;
  if (more && s.constrained && flipped.size() > 0) {
    // The slots the earlier run flipped and those the last insert() made stay flagged; slots added
    // since (the added vertices') start clear.
    const std::size_t had = std::min<std::size_t>(flipped.size(), s.num_slots);
    detail::DeviceBuffer<std::uint8_t> grown(s.num_slots);
    executor.fill_bytes(grown.data(), 0, s.num_slots);
    CDT_CUDA_CHECK(
        cudaMemcpyAsync(grown.data(), flipped.data(), had, cudaMemcpyDeviceToDevice, executor.stream()));
    if (s.made_by_insert.size() > 0) {
      const std::uint8_t* made = s.made_by_insert.data();
      std::uint8_t* into = grown.data();
      executor.for_each(
          std::min<std::size_t>(s.made_by_insert.size(), s.num_slots),
          [=] __device__(std::size_t t) { into[t] |= made[t]; }, "flags_of_insert");
    }
    std::swap(flipped, grown);
  } else {
    flipped.resize(s.num_slots);
    executor.fill_bytes(flipped.data(), 0, s.num_slots);
  }
  s.constrained = true;
  return detail::insert_constraints(executor, s.view(), pieces, inner_iterations, flipped.data(), parallel);
}

namespace {

/// Copies the mesh's links into the run's buffers (sized here) on the owner's stream and starts the run
/// of insert_constraints on them on a side thread (the pending pieces: every one, or `only`).
void launch_beside(DeviceMesh::State& s, detail::ConstraintsBeside& beside, unsigned inner_iterations,
                   const std::uint32_t* only, std::uint32_t num_only) {
  detail::CudaExecutor& executor = s.executor;
  const std::size_t words = 3 * static_cast<std::size_t>(s.num_slots);
  const cudaStream_t stream = executor.stream();
  beside.tri.resize(words);
  beside.adj.resize(words);
  beside.seg.resize(words);
  beside.vert_tri.resize(s.num_vertices);
  beside.flipped.resize(s.num_slots);
  const auto copy_words = [stream](std::uint32_t* dst, const std::uint32_t* src, std::size_t n) {
    if (n > 0)
      CDT_CUDA_CHECK(cudaMemcpyAsync(dst, src, n * sizeof(std::uint32_t), cudaMemcpyDeviceToDevice, stream));
  };
  copy_words(beside.tri.data(), s.tri.data(), words);
  copy_words(beside.adj.data(), s.adj.data(), words);
  copy_words(beside.seg.data(), s.seg.data(), words);
  copy_words(beside.vert_tri.data(), s.vert_tri.data(), s.num_vertices);
  executor.fill_bytes(beside.flipped.data(), 0, s.num_slots);
  if (beside.ready == nullptr)
    CDT_CUDA_CHECK(cudaEventCreateWithFlags(&beside.ready, cudaEventDisableTiming));
  CDT_CUDA_CHECK(cudaEventRecord(beside.ready, stream));
  int device = 0;
  CDT_CUDA_CHECK(cudaGetDevice(&device));
  detail::ConstraintsBeside* run = &beside;
  const ::cdt::detail::MeshView copy{s.xy.data(),          run->tri.data(), run->adj.data(), run->seg.data(),
                                     run->vert_tri.data(), s.num_slots,     s.num_vertices};
  const std::span<const ConstraintPiece2> pieces = run->host_pieces;
  const auto body = [run, copy, pieces, inner_iterations, device, only, num_only] {
    try {
      CDT_CUDA_CHECK(cudaSetDevice(device)); // the current device is each thread's own
      // On a stream of the highest priority, ahead of the screen that the owner's thread runs
      // meanwhile: sharing the device evenly, these constraints (the longer work) finished well after
      // the screen and the split and were what the triangulation waited for.
      detail::PriorityStream first;
      // An executor of this thread's own: its stream, and its scratch words and buffers.
      detail::CudaExecutor own;
      try {
        CDT_CUDA_CHECK(cudaStreamWaitEvent(own.stream(), run->ready, 0)); // after the copies
        run->stats = detail::insert_constraints(own, copy, pieces, inner_iterations, run->flipped.data(), {},
                                                run->pieces.data(), &run->stop, only, num_only);
        own.synchronize(); // everything it queued is done before the owner goes on
      } catch (...) {
        run->failure = std::current_exception();
        own.synchronize(); // the executor's destructor waits too, and reports nothing
      }
    } catch (...) {
      if (!run->failure) run->failure = std::current_exception();
    }
  };
  run->done = detail::run_beside(body);
}

} // namespace

bool DeviceMesh::start_constraints(std::span<const ConstraintPiece2> pieces, unsigned inner_iterations,
                                   const HostParallelFor& parallel) {
  State& s = *state_;
  if (s.beside) throw Error("internal error: start_constraints: constraints already run beside the host");
  ::cdt::detail::check_constraint_counts(s.num_slots, pieces.size());
  if (pieces.empty()) return false;
  // The copy of the links (36 bytes a slot, 4 a vertex), the flags of its flips and the pieces; the
  // constraints' own buffers (about 64 bytes a slot, 32 a piece, as insert_constraints allocates them)
  // and a screen's beside them (about 24 a slot, 4 a piece), with room to spare: else the caller
  // inserts them after its split.
  const std::size_t slots = s.num_slots, np = pieces.size();
  const std::size_t needed = (36 + 1 + 64 + 24) * slots + 4 * static_cast<std::size_t>(s.num_vertices) +
                             (12 + 32 + 4) * np + (std::size_t{64} << 20);
  try {
    detail::require_device_memory(needed, 0, "constraints beside the host");
  } catch (const DeviceError&) {
    return false;
  }
  // Without the memory after all (another process took it meanwhile), or without a thread to be had,
  // nothing is started: the caller inserts the constraints after its split. (A bad piece is an Error.)
  std::unique_ptr<detail::ConstraintsBeside> beside;
  try {
    beside = std::make_unique<detail::ConstraintsBeside>();
    beside->host_pieces = pieces;
    ::cdt::detail::StepTrace trace("device constraints beside");
    if (s.ready_pieces.size() == np) {
      // Made on the device from the same PSLG (take_pieces); with the debug switch compared with the
      // host's.
      beside->pieces = std::move(s.ready_pieces);
      if (detail::debug_sync()) detail::check_same_pieces(s.executor, beside->pieces.data(), pieces);
    } else {
      beside->pieces.resize(np);
      s.executor.upload(beside->pieces.data(), pieces.data(), np, &parallel);
    }
    s.ready_pieces = {};
    if (::cdt::detail::trace_enabled()) s.executor.synchronize();
    trace.mark("pieces uploaded");
    detail::check_device_pieces(s.executor, beside->pieces.data(), pieces, s.num_vertices);
    trace.mark("pieces checked");
    launch_beside(s, *beside, inner_iterations, nullptr, 0);
    trace.mark("started");
  } catch (const DeviceError&) {
    return false;
  } catch (const std::system_error&) {
    return false;
  }
  s.beside = std::move(beside);
  return true;
}

bool DeviceMesh::restart_constraints(std::span<const std::uint32_t> skip, unsigned inner_iterations) {
  State& s = *state_;
  if (!s.beside) throw Error("internal error: restart_constraints: no constraints run beside the host");
  // The run is stopped at its next step; its pieces (uploaded and checked) and buffers serve the new one.
  std::unique_ptr<detail::ConstraintsBeside> old = std::move(s.beside);
  old->stop = true;
  old->done.wait();
  try {
    auto beside = std::make_unique<detail::ConstraintsBeside>();
    beside->host_pieces = old->host_pieces;
    std::swap(beside->pieces, old->pieces);
    std::swap(beside->tri, old->tri);
    std::swap(beside->adj, old->adj);
    std::swap(beside->seg, old->seg);
    std::swap(beside->vert_tri, old->vert_tri);
    std::swap(beside->flipped, old->flipped);
    // The pending list: every piece but the skipped ones.
    const auto np = static_cast<std::uint32_t>(beside->host_pieces.size());
    detail::CudaExecutor& executor = s.executor;
    detail::DeviceBuffer<std::uint32_t> d_skip(skip.size());
    executor.upload(d_skip.data(), skip.data(), skip.size());
    detail::DeviceBuffer<std::uint8_t> d_left_out(np);
    std::uint8_t* left_out = d_left_out.data();
    executor.fill_bytes(left_out, 0, np);
    const std::uint32_t* skipped = d_skip.data();
    executor.for_each(
        skip.size(),
        [=] __device__(std::size_t k) {
          if (skipped[k] < np) left_out[skipped[k]] = 1;
        },
        "skipped_pieces");
    beside->only.resize(np);
    const std::uint32_t num_only = executor.compact(
        np, [=] __device__(std::size_t k) { return left_out[k] == 0; }, beside->only.data());
    launch_beside(s, *beside, inner_iterations, beside->only.data(), num_only);
    s.beside = std::move(beside);
  } catch (const DeviceError&) {
    return false;
  } catch (const std::system_error&) {
    return false;
  }
  return true;
}

void DeviceMesh::renumber_constraints(std::span<const ::cdt::detail::PieceRun> runs) {
  State& s = *state_;
  s.require_alone("renumber_constraints");
  if (!s.constrained) return;
  detail::CudaExecutor& executor = s.executor;
  detail::DeviceBuffer<::cdt::detail::PieceRun> d_runs(runs.size());
  if (!runs.empty()) executor.upload(d_runs.data(), runs.data(), runs.size());
  const ::cdt::detail::PieceRun* run = d_runs.data();
  const auto num_runs = static_cast<std::uint32_t>(runs.size());
  std::uint32_t* seg = s.seg.data();
  const detail::FailureWord failure = s.failure();
  executor.for_each(
      3 * static_cast<std::size_t>(s.num_slots),
      [=] __device__(std::size_t w) {
        const std::uint32_t id = seg[w];
        if (id == kNoId) return;
        const std::uint32_t to = ::cdt::detail::moved_piece(run, num_runs, id);
        if (to == kNoId) failure.record(::cdt::detail::WorkStatus::stuck);
        seg[w] = to;
      },
      "renumber_constraints");
  s.check(failure, "renumbering the constraints after the split (an id of a piece that left)");
}

void DeviceMesh::check_constraints_unsplit(std::uint32_t first) {
  State& s = *state_;
  s.require_alone("check_constraints_unsplit");
  if (!s.constrained) return;
  const ::cdt::detail::MeshView m = s.view();
  const detail::FailureWord failure = s.failure();
  s.executor.for_each(
      m.num_slots,
      [=] __device__(std::size_t t) {
        if (!m.alive(static_cast<std::uint32_t>(t))) return;
        for (std::uint32_t i = 0; i < 3; ++i) {
          const std::uint32_t v = m.tri[3 * t + i];
          if (v < first || v >= m.num_vertices) continue;
          // The two edges at corner i (edge k is opposite corner k).
          if (m.seg[3 * t + (i + 1) % 3] != kNoId || m.seg[3 * t + (i + 2) % 3] != kNoId)
            failure.record(::cdt::detail::WorkStatus::stuck);
        }
      },
      "constraints_unsplit");
  std::uint32_t code = 0;
  s.executor.download(&code, failure.word, 1);
  if (code != 0) throw Error("a vertex added at a crossing lies on a constraint piece already inserted");
}

const ConstraintPiece2* DeviceMesh::State::pieces_beside(std::span<const ConstraintPiece2> host) const {
  return beside && beside->host_pieces.data() == host.data() && beside->host_pieces.size() == host.size()
             ? beside->pieces.data()
             : nullptr;
}

std::optional<ConstraintStats> DeviceMesh::finish_constraints(bool keep) {
  State& s = *state_;
  if (!s.beside) throw Error("internal error: finish_constraints: no constraints run beside the host");
  const std::unique_ptr<detail::ConstraintsBeside> run = std::move(s.beside);
  if (!keep) run->stop = true;
  run->done.wait();
  if (run->failure) {
    try {
      std::rethrow_exception(run->failure);
    } catch (const Error&) {
      // DeviceError too (the run's buffers beside the screen's, say): the caller's own insertion meets
      // it again, or not, with the pieces it has.
      keep = false;
    }
  }
  if (!keep) return std::nullopt; // the mesh itself was not touched
  // The copy becomes the mesh; the mesh's old arrays go with `run`, after the work queued on them.
  std::swap(s.tri, run->tri);
  std::swap(s.adj, run->adj);
  std::swap(s.seg, run->seg);
  std::swap(s.vert_tri, run->vert_tri);
  std::swap(s.flipped_by_constraints, run->flipped);
  s.constrained = true;
  // The last insert()'s slots are flipped to Delaunay already; a later insert_constraints with `more`
  // adds only the slots of an insert() after this.
  s.made_by_insert = {};
  return run->stats;
}

} // namespace cdt::gpu
