#pragma once
// The state of gpu::DeviceMesh, shared by the files that implement its steps: shifting, missing
// points and the fake boundary (mesh_kernels.cu), Lawson flips (flip_kernels.cu).

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <future>
#include <memory>
#include <span>
#include <string>

#include "block_steps.cuh"
#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"
#include "gcd/constraints.hpp"
#include "gcd/flip.hpp"
#include "gcd/mesh.hpp"
#include "gcd/shift.hpp"

namespace cdt::gpu {
namespace detail {

/// The device side of cdt::detail::WorkFailure: the first failure of a step, in one device word.
struct FailureWord {
  std::uint32_t* word = nullptr;
  __device__ void record(::cdt::detail::WorkStatus s) const {
    atomicCAS(word, 0u, static_cast<std::uint32_t>(s));
  }
};

/// The device's atomic minimum, for the rounds' claims (record_flip_proposal, record_constraint_proposal,
/// locate_and_claim); the CPU executor's is cdt::detail::AtomicMin.
struct ClaimMin {
  __device__ void operator()(std::uint32_t* at, std::uint32_t value) const { atomicMin(at, value); }
};

/// A launched round's reply word, the one value the host waits for: the next list's length in the low
/// half (kNoId after an error, whose details the round's other words hold), the round's flips or
/// insertions in the high half.
__device__ inline unsigned long long round_reply(std::uint32_t next, std::uint32_t count) {
  return next | static_cast<unsigned long long>(count) << 32;
}

/// A reply word, unpacked.
struct RoundReply {
  std::uint32_t next;
  std::uint32_t count;
};

/// Waits for the round queued before it and reads its reply word.
inline RoundReply wait_for_reply(CudaExecutor& executor, const unsigned long long* d_reply) {
  unsigned long long reply = 0;
  executor.download(&reply, d_reply, 1);
  return {static_cast<std::uint32_t>(reply), static_cast<std::uint32_t>(reply >> 32)};
}

/// A launched round's proposals are made in two kernels: the predicates' filters alone (few registers),
/// which list the elements they leave undecided, then the exact tests over that list. Undecided tests
/// are rare on most inputs (none on uniform points, a few per million on the coastlines) and common on
/// degenerate ones (lattices). The exact kernel runs this many threads per listed element, one working
/// and the others idle, up to a warp each while the round's list length `bound` leaves room: the exact
/// tests are long chains of dependent steps, and one a warp keeps as many of them in flight as the
/// whole list's kernel did (packed 32 a warp, the coastlines' took three times as long).
__device__ inline std::uint32_t exact_spread(std::uint32_t undecided, std::size_t bound) {
  if (undecided == 0) return 1;
  const std::size_t room = bound / undecided;
  return room >= 32 ? 32u : room < 1 ? 1u : static_cast<std::uint32_t>(room);
}

/// The exact kernel: f(k) for every element k of list[0, *count), which a filter kernel queued before
/// it appended to (count <= bound, the round's list length), exact_spread threads each. Nothing waits.
template <class F>
void for_each_undecided(CudaExecutor& executor, std::size_t bound, const std::uint32_t* list,
                        const std::uint32_t* count, F f, const char* name) {
  executor.for_each_counted(
      bound, [=] __device__() -> std::size_t { return std::size_t{*count} * exact_spread(*count, bound); },
      [=] __device__(std::size_t j) {
        const std::uint32_t spread = exact_spread(*count, bound);
        if (j % spread == 0) f(list[j / spread]);
      },
      name);
}

/// cdt::detail::FlipBatch on the device: a batch of disjoint flips, and per slot the partner of the
/// last batch's pairs (kNoId for the slots of no pair).
struct DeviceFlipBatch {
  DeviceBuffer<std::uint32_t> partner; ///< per slot
  DeviceBuffer<std::uint32_t> last;    ///< the last batch's slots, whose partner entries are reset next
  DeviceBuffer<std::uint8_t> fix;      ///< per pair: flip_pair_contents' vertex fixes
  std::uint32_t num_last = 0;

  DeviceFlipBatch(CudaExecutor& executor, std::uint32_t slots);
};

/// FlipBatch::apply for a batch whose size, num_winners(), the device knows and the host need not:
/// flips the pairs across edges[0, num_winners()) (disjoint, each flippable), then relinks them; the
/// lowest batch index whose pair lost a link (the mesh was not valid) goes to *failed (set to kNoId
/// beforehand), and nothing waits. `bound` is at least the batch's size; the caller sets
/// batch.num_last to twice the batch's size once it knows it.
template <class Count>
void apply_flips_counted(CudaExecutor& executor, DeviceFlipBatch& batch, const ::cdt::detail::MeshView& m,
                         const std::uint32_t* edges, std::uint32_t bound, Count num_winners,
                         std::uint32_t* failed) {
  std::uint32_t* partner = batch.partner.data();
  std::uint32_t* last = batch.last.data();
  std::uint8_t* fix = batch.fix.data();
  {
    const std::uint32_t* old = last;
    executor.for_each(
        batch.num_last, [=] __device__(std::size_t k) { partner[old[k]] = ::cdt::detail::kNoId; },
        "partner_reset");
  }
  // The pairs are disjoint, so each slot's partner entry has one writer.
  executor.for_each_counted(
      bound, num_winners,
      [=] __device__(std::size_t k) {
        const std::uint32_t t = ::cdt::detail::edge_tri(edges[k]);
        const std::uint32_t u = ::cdt::detail::edge_tri(m.adj[edges[k]]);
        partner[t] = u;
        partner[u] = t;
        last[2 * k] = t;
        last[2 * k + 1] = u;
      },
      "partner_set");
  executor.for_each_counted(
      bound, num_winners,
      [=] __device__(std::size_t k) { fix[k] = ::cdt::detail::flip_pair_contents(m, edges[k]); },
      "flip_contents");
  executor.for_each_counted(
      bound, num_winners,
      [=] __device__(std::size_t k) {
        if (!::cdt::detail::relink_flipped_pair(m, partner, ::cdt::detail::edge_tri(edges[k]), fix[k]))
          atomicMin(failed, static_cast<std::uint32_t>(k));
      },
      "flip_relink");
}

/// apply_flips_counted by a whole team (BlockTeam or GridTeam; every thread calls it, with the same
/// arguments): flips the pairs across edge_of(k) for k in [0, n) with the batch's partner, last
/// (num_last of them from the last batch, updated) and fix arrays. Returns to every thread the lowest k
/// whose pair lost a link, or kNoId (in the team's word). Ends with the team's barrier.
template <class Team, class EdgeOf>
__device__ std::uint32_t team_apply_flips(const Team& team, const ::cdt::detail::MeshView& m,
                                          std::uint32_t* partner, std::uint32_t* last,
                                          std::uint32_t& num_last, std::uint8_t* fix, std::uint32_t n,
                                          EdgeOf edge_of) {
  using ::cdt::detail::edge_tri;
  team.for_each(num_last, [&](std::uint32_t k) { partner[last[k]] = ::cdt::detail::kNoId; });
  if (team.leader()) *team.word = ::cdt::detail::kNoId;
  team.sync();
  team.for_each(n, [&](std::uint32_t k) {
    const std::uint32_t e = edge_of(k);
    const std::uint32_t t = edge_tri(e);
    const std::uint32_t u = edge_tri(m.adj[e]);
    partner[t] = u;
    partner[u] = t;
    last[2 * k] = t;
    last[2 * k + 1] = u;
  });
  num_last = 2 * n;
  team.sync();
  team.for_each(n, [&](std::uint32_t k) { fix[k] = ::cdt::detail::flip_pair_contents(m, edge_of(k)); });
  team.sync();
  team.for_each(n, [&](std::uint32_t k) {
    if (!::cdt::detail::relink_flipped_pair(m, partner, edge_tri(edge_of(k)), fix[k]))
      atomicMin(team.word, k);
  });
  team.sync();
  return team.word_value();
}

/// check_constraint_pieces' test of every piece, on the device's copy of host_pieces (one pass instead of
/// a serial loop over millions on the host); throws the same Error for the first bad piece.
void check_device_pieces(CudaExecutor& executor, const ::cdt::detail::ConstraintPiece2* pieces,
                         std::span<const ::cdt::detail::ConstraintPiece2> host_pieces,
                         std::uint32_t num_vertices);

/// Throws Error unless the pieces at `pieces` on the device are host_pieces (a debug check of pieces
/// made on the device).
void check_same_pieces(CudaExecutor& executor, const ::cdt::detail::ConstraintPiece2* pieces,
                       std::span<const ::cdt::detail::ConstraintPiece2> host_pieces);

/// Device memory of a mesh of `slots` triangles over nv vertices, in bytes.
std::size_t mesh_device_bytes(std::size_t slots, std::size_t nv);

/// insert_constraints running on a side thread (DeviceMesh::start_constraints, run_beside) on a copy of
/// the mesh's links, which becomes the mesh when kept. The destructor stops it at its next step and
/// waits for it.
/// Its buffers are allocated and released by the owner's thread.
struct ConstraintsBeside {
  std::future<void> done;
  std::atomic<bool> stop{false}; ///< set by the owner: the run returns at its next step
  std::exception_ptr failure;    ///< what the run threw
  ::cdt::detail::ConstraintStats stats;
  cudaEvent_t ready = nullptr; ///< recorded on the owner's stream once the copies are made
  std::span<const ::cdt::detail::ConstraintPiece2> host_pieces; ///< the caller's
  DeviceBuffer<::cdt::detail::ConstraintPiece2> pieces;         ///< host_pieces uploaded and checked
  DeviceBuffer<std::uint32_t> tri, adj, seg, vert_tri;          ///< the copy of the links the run changes
  DeviceBuffer<std::uint8_t> flipped; ///< per slot of the copy, 1 where the run flipped
  DeviceBuffer<std::uint32_t> only;   ///< the pieces pending at the start, when not every one

  ConstraintsBeside() = default;
  ConstraintsBeside(const ConstraintsBeside&) = delete;
  ConstraintsBeside& operator=(const ConstraintsBeside&) = delete;
  ~ConstraintsBeside() {
    stop = true;
    if (done.valid()) done.wait();
    if (ready != nullptr) cudaEventDestroy(ready);
  }
};

/// The output's arrays are made and copied in parts of about this many bytes each when the device writes
/// them into pinned memory.
constexpr std::size_t kOutputPartBytes = std::size_t{16} << 20;

/// Where a slot lies against the screened corridors (DeviceMesh::State::corridor_slots): the
/// constraints' flips rewrite the triangles in a corridor, and the links of those next to one.
enum : std::uint8_t { kAwayFromCorridors = 0, kNextToCorridor = 1, kInCorridor = 2 };

/// The output's rows that the constraints leave alone, made and on their way into the result while
/// the constraints run (DeviceMesh::start_early_output); output() makes the rest. The output's rows
/// then come in three groups, each in slot order: the slots away from the corridors (both arrays sent
/// early), those next to a corridor (their corners sent early), and the others (the corridors' and
/// any made later).
struct EarlyOutput {
  std::uint32_t slots = 0;        ///< the mesh's slots when it started, every one alive
  std::uint32_t away = 0;         ///< rows [0, away): corners and neighbours sent
  std::uint32_t with_corners = 0; ///< rows [0, with_corners): corners sent
  const void* host_triangles = nullptr;
  const void* host_neighbors = nullptr;
  DeviceBuffer<std::uint8_t> where; ///< per slot, kAwayFromCorridors, kNextToCorridor or kInCorridor
  /// per slot, how many slots before it are away from the corridors (low word) and next to one (high)
  DeviceBuffer<unsigned long long> rank;
  DeviceBuffer<std::uint32_t> corners, neighbours; ///< the rows as sent
  std::unique_ptr<PartCopies> copies; ///< declared last: waited for before the buffers it reads go
};

/// The output row of slot t < EarlyOutput::slots.
__device__ __forceinline__ std::uint32_t early_row(const std::uint8_t* where, const unsigned long long* rank,
                                                   std::uint32_t away, std::uint32_t with_corners,
                                                   std::uint32_t t) {
  const auto before_away = static_cast<std::uint32_t>(rank[t]);
  const auto before_next = static_cast<std::uint32_t>(rank[t] >> 32);
  if (where[t] == kAwayFromCorridors) return before_away;
  if (where[t] == kNextToCorridor) return away + before_next;
  return with_corners + (t - before_away - before_next);
}

} // namespace detail

struct DeviceMesh::State {
  detail::CudaExecutor executor; // declared first: destroyed after the buffers queued on its stream
  detail::DeviceBuffer<::cdt::detail::Vec2> xy;
  detail::DeviceBuffer<std::uint32_t> tri, adj, seg, vert_tri;
  std::uint32_t num_slots = 0;
  std::uint32_t num_vertices = 0;
  /// Whether seg may hold constraint ids: false for a mesh made on the device until constraints are
  /// inserted into it (every id kNoId), when the flips leave seg alone (MeshView::seg).
  bool constrained = true;
  detail::DeviceBuffer<std::uint32_t> failure_word{1};
  /// Per slot, 1 where the last insert_constraints flipped it (empty before the first call).
  detail::DeviceBuffer<std::uint8_t> flipped_by_constraints;
  /// Per slot, 1 where the last insert() split a triangle or made one (for flip_after_insert(); empty
  /// before the first call).
  detail::DeviceBuffer<std::uint8_t> made_by_insert;
  /// The missing points taken from DeviceSites (take_missing), inserted first by the next insert().
  detail::DeviceBuffer<::cdt::detail::MissingPoint> missing_first;
  /// The first entries of output()'s vertex_of, already on the device (take_vertex_ids; else empty).
  detail::DeviceBuffer<std::uint32_t> vertex_ids;
  /// The constraints' pieces in mesh ids, already on the device (take_pieces; else empty): taken by
  /// start_constraints when they are as many as the host's.
  detail::DeviceBuffer<::cdt::detail::ConstraintPiece2> ready_pieces;
  /// segment_of_edge's words filled with kNoId by prefill_segments (null when not), for that many rows.
  const std::uint32_t* prefilled_segments = nullptr;
  std::uint32_t prefilled_rows = 0;
  /// Per slot, where the last screen() found it against the corridors (kInCorridor...; empty when it
  /// did not look: small meshes), for start_early_output().
  detail::DeviceBuffer<std::uint8_t> corridor_slots;
  /// The output's rows started early (start_early_output; else null).
  std::unique_ptr<detail::EarlyOutput> early;
  /// The constraints started beside the host (start_constraints; else null). Declared last: it is
  /// stopped and joined before the buffers it uses go.
  std::unique_ptr<detail::ConstraintsBeside> beside;

  /// Throws Error naming `step` while constraints run beside the host (they become the mesh when kept).
  void require_alone(const char* step) const {
    if (beside)
      throw Error(std::string("internal error: ") + step + " while constraints run beside the host");
  }

  /// The pieces that the constraints beside the host uploaded and checked, when they run on `host` (the
  /// same array; else null): screen() takes them from there.
  const ::cdt::detail::ConstraintPiece2*
  pieces_beside(std::span<const ::cdt::detail::ConstraintPiece2> host) const;

  ::cdt::detail::MeshView view() {
    return ::cdt::detail::MeshView{xy.data(),       tri.data(), adj.data(),  seg.data(),
                                   vert_tri.data(), num_slots,  num_vertices};
  }

  /// A clear failure word for the next step.
  detail::FailureWord failure() {
    executor.fill_bytes(failure_word.data(), 0, 1);
    return detail::FailureWord{failure_word.data()};
  }

  /// WorkFailure::check: throws Error naming `step` when an element of it recorded a failure (waits
  /// for the step).
  void check(const detail::FailureWord& failure, const char* step) {
    std::uint32_t code = 0;
    executor.download(&code, failure.word, 1);
    if (code != 0)
      throw Error(std::string("internal error: ") + step + ": " +
                  ::cdt::detail::work_status_message(static_cast<::cdt::detail::WorkStatus>(code)));
  }

  /// Sizes every array for `slots` triangles over nv vertices (contents left as they are), after
  /// checking that the device has the memory.
  void allocate(std::uint32_t slots, std::uint32_t nv);

  /// Mesh::grow_slots: n more free slots at the end (the arrays are copied into larger buffers).
  void grow_slots(std::uint32_t n);
};

} // namespace cdt::gpu
