// Phases 3 and 4 of gCD on the CUDA executor (paper sections 3.3 and 3.4): shifting (Algorithms 1 and
// 2), missing points (Algorithm 3) and the fake boundary's removal, on a mesh that stays on the device.
// The per-element work is cdt/src/gcd/shift.hpp's and insert.hpp's; each driver below runs the same
// steps as its CPU executor twin (cdt/src/gcd/shift.cpp, insert.cpp) in the same order with the same
// ordered compactions, so both executors leave the same mesh slot for slot. The fake boundary's removal
// is the exception: its fans go to the host, whose edits come back (DeviceMesh::remove_fake_boundary).
// The deletions', shifts' and insertions' last rounds, on short lists, run in one thread block, and the
// shifts' and insertions' middle rounds in one cooperative grid (block_steps.cuh).

#include <algorithm>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "block_steps.cuh"
#include "cdt/detail/trace.hpp"
#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"
#include "device_mesh.cuh"
#include "device_sites.cuh"
#include "gcd/insert.hpp"
#include "gcd/mesh.hpp"
#include "gcd/shift.hpp"

namespace cdt::gpu {

using ::cdt::detail::edge_id;
using ::cdt::detail::edge_index;
using ::cdt::detail::edge_tri;
using ::cdt::detail::HoleView;
using ::cdt::detail::InsertStats;
using ::cdt::detail::kLeaving;
using ::cdt::detail::kLeavingLater;
using ::cdt::detail::kLeavingNow;
using ::cdt::detail::kNoId;
using ::cdt::detail::kStays;
using ::cdt::detail::MeshView;
using ::cdt::detail::MissingArray;
using ::cdt::detail::MissingPoint;
using ::cdt::detail::next3;
using ::cdt::detail::prev3;
using ::cdt::detail::ShiftStats;
using ::cdt::detail::WorkStatus;

namespace detail {

/// Bits needed to hold every value below `limit` (dual_kernels.cu).
int bits_below(std::uint64_t limit);

/// Copies buffer b's first `used` elements into a new buffer of `count` elements whose rest is filled
/// with the byte `fill`.
template <class T>
void grow_buffer(CudaExecutor& executor, DeviceBuffer<T>& b, std::size_t used, std::size_t count, int fill) {
  DeviceBuffer<T> larger(count);
  if (used > 0)
    CDT_CUDA_CHECK(cudaMemcpyAsync(larger.data(), b.data(), used * sizeof(T), cudaMemcpyDeviceToDevice,
                                   executor.stream()));
  executor.fill_bytes(larger.data() + used, fill, count - used);
  executor.synchronize(); // the old buffer is freed next
  b = std::move(larger);
}

/// The hole rounds' scratch (cdt::detail::HoleWorkspace), grown as rounds need it.
struct DeviceHoles {
  DeviceBuffer<std::uint32_t> slot_pos, offset, count;
  DeviceBuffer<std::uint32_t> vertex, slot, outer, seg, new_edge, next, prev, ref;
  DeviceBuffer<std::uint8_t> own;

  void resize_ring(std::size_t n) {
    for (auto* b : {&vertex, &slot, &outer, &seg, &new_edge, &next, &prev, &ref}) b->resize(n);
    own.resize(n);
  }
  HoleView view() {
    return HoleView{vertex.data(), slot.data(), outer.data(), seg.data(), new_edge.data(),
                    next.data(),   prev.data(), ref.data(),   own.data()};
  }
};

/// What a round of deleted star vertices leaves for Phase 4 (the shift's after_round): the vertices
/// take their true positions and are listed as missing points with their hints.
struct DeletedStars {
  const double* true_x = nullptr;
  const double* true_y = nullptr;
  MissingPoint* out = nullptr; ///< room for every pending vertex
  std::uint32_t written = 0;
};

/// cdt::detail::delete_vertex_round on the device for star holes (the fake boundary's open fans are
/// removed on the host): active[0, n) pairwise non-adjacent.
void delete_vertex_round(DeviceMesh::State& s, const std::uint32_t* active, std::uint32_t n,
                         const std::uint8_t* leaving, std::uint32_t* hint, DeviceHoles& ws) {
  if (n == 0) return;
  if (s.num_slots >= ::cdt::detail::kBoundaryRef / 3) throw Error("internal error: too many triangle slots");
  CudaExecutor& executor = s.executor;
  const MeshView m = s.view();
  if (ws.slot_pos.size() < m.num_slots) {
    ws.slot_pos.resize(m.num_slots);
    executor.fill_bytes(ws.slot_pos.data(), 0xFF, m.num_slots);
  }
  ws.count.resize(n);
  ws.offset.resize(n);
  std::uint32_t* count = ws.count.data();
  std::uint32_t* offset = ws.offset.data();
  const FailureWord failure = s.failure();
  executor.for_each(
      n,
      [=] __device__(std::size_t i) {
        bool closed = false;
        const std::uint32_t size = ::cdt::detail::ring_size(m, active[i], closed);
        if (size == 0)
          failure.record(WorkStatus::broken_fan);
        else if (!closed)
          failure.record(WorkStatus::open_star);
        count[i] = size;
        offset[i] = size;
      },
      "hole_sizes");
  s.check(failure, "deleting vertices (fan sizes)");
  const std::uint32_t total = executor.exclusive_scan(offset, n);
  ws.resize_ring(total);
  const HoleView h = ws.view();
  std::uint32_t* slot_pos = ws.slot_pos.data();

  executor.for_each(
      n,
      [=] __device__(std::size_t i) {
        ::cdt::detail::collect_ring(m, active[i], h, offset[i], count[i], slot_pos);
      },
      "collect_ring");
  executor.for_each(
      n,
      [=] __device__(std::size_t i) {
        ::cdt::detail::mark_owned_vertices(m, h, offset[i], count[i], slot_pos);
      },
      "mark_owned_vertices");
  executor.for_each(
      n,
      [=] __device__(std::size_t i) {
        const std::uint32_t v = active[i], base = offset[i], size = count[i];
        const WorkStatus status = ::cdt::detail::cut_ears(m, h, base, size, m.xy[v].x, m.xy[v].y);
        if (hint != nullptr) hint[i] = ::cdt::detail::ring_hint(h, base, size, leaving);
        if (status != WorkStatus::ok) failure.record(status);
        m.vert_tri[v] = kNoId;
      },
      "fill_holes");
  s.check(failure, "deleting bad cases (ear cutting)");
  executor.for_each(
      n,
      [=] __device__(std::size_t i) {
        ::cdt::detail::relink_hole(m, h, offset[i], count[i], true, slot_pos);
      },
      "relink_hole");
  executor.for_each(
      n,
      [=] __device__(std::size_t i) {
        for (std::uint32_t p = offset[i]; p < offset[i] + count[i]; ++p)
          if (h.slot[p] != kNoId) slot_pos[h.slot[p]] = kNoId;
      },
      "release_slot_marks");
}

/// Lists of at most this many vertices are deleted by delete_rounds_in_block (see flip_kernels.cu).
constexpr std::uint32_t kDeleteBlockLimit = 4096;
/// The holes of a round in delete_rounds_in_block have room for this many ring positions per vertex
/// of the list it starts with; a round that needs more goes back to the launches.
constexpr std::uint32_t kDeleteBlockRingRoom = 16;

/// delete_vertices' buffers and state, for delete_rounds_in_block.
struct DeleteRounds {
  MeshView m;
  std::uint32_t* list;
  std::uint32_t* rest;
  std::uint32_t n;
  std::uint8_t* leaving;
  std::uint8_t* now;
  std::uint32_t* picked;
  std::uint32_t* active;
  std::uint32_t* hint;
  std::uint32_t* count;
  std::uint32_t* offset;
  HoleView h;
  std::uint32_t ring_capacity;
  std::uint32_t* slot_pos;
  const double* true_x; ///< null: no stars to report
  const double* true_y;
  MissingPoint* out;
  std::uint32_t written;
};

/// Which step of delete_rounds_in_block failed.
enum class DeleteStep : std::uint32_t { none, independence, fan_sizes, ear_cutting, stuck };

/// What delete_rounds_in_block leaves for the host.
struct DeleteRoundsEnd {
  std::uint32_t n;       ///< vertices left to delete
  std::uint32_t in_rest; ///< 1 when the list is in `rest`
  std::uint32_t rounds;
  std::uint32_t written;
  std::uint32_t room;   ///< 1 when the last round's holes needed more room than the block has
  DeleteStep step;      ///< the failed step, with its status
  std::uint32_t status; ///< a WorkStatus
};

/// delete_vertices' rounds (with delete_vertex_round's steps), the same steps in the same order, by one
/// block while the list has at most kDeleteBlockLimit vertices and the holes fit its ring room.
__global__ void __launch_bounds__(kBlockRoundThreads)
    delete_rounds_in_block(DeleteRounds a, DeleteRoundsEnd* end) {
  __shared__ BlockCompactStorage storage;
  __shared__ std::uint32_t failure;
  const MeshView m = a.m;
  const HoleView h = a.h;
  std::uint32_t* list = a.list;
  std::uint32_t* rest = a.rest;
  std::uint32_t n = a.n;
  std::uint32_t rounds = 0, in_rest = 0, room = 0, written = a.written;
  DeleteStep step = DeleteStep::none;
  const auto record = [&](WorkStatus status) { atomicCAS(&failure, 0u, static_cast<std::uint32_t>(status)); };
  const auto failed = [&](DeleteStep at) { // after a barrier that follows the recording step
    if (failure == 0) return false;
    step = at;
    return true;
  };
  while (n > 0 && n <= kDeleteBlockLimit) {
    if (threadIdx.x == 0) failure = 0;
    __syncthreads();
    block_for_each(n, [&](std::uint32_t i) {
      bool go = false;
      const WorkStatus status = ::cdt::detail::may_delete_now(m, list[i], a.leaving, go);
      if (status != WorkStatus::ok) record(status);
      a.now[i] = go ? 1 : 0;
    });
    __syncthreads();
    if (failed(DeleteStep::independence)) break;
    // The second pick (cdt::detail::may_delete_among_rest), as delete_vertices marks it.
    block_for_each(n, [&](std::uint32_t i) {
      if (a.now[i] != 0) a.leaving[list[i]] = kLeavingNow;
    });
    __syncthreads();
    block_for_each(n, [&](std::uint32_t i) {
      if (a.now[i] != 0) return;
      bool next = false;
      const WorkStatus status = ::cdt::detail::next_to_leaving_now(m, list[i], a.leaving, next);
      if (status != WorkStatus::ok) record(status);
      if (next) a.leaving[list[i]] = kLeavingLater;
    });
    __syncthreads();
    block_for_each(n, [&](std::uint32_t i) {
      if (a.leaving[list[i]] != kLeaving) return;
      bool go = false;
      const WorkStatus status = ::cdt::detail::may_delete_among_rest(m, list[i], a.leaving, go);
      if (status != WorkStatus::ok) record(status);
      if (go) a.now[i] = 1;
    });
    __syncthreads();
    if (failed(DeleteStep::independence)) break;
    const std::uint32_t num_active = block_compact(
        n, [&](std::uint32_t i) { return a.now[i] != 0; }, a.picked, storage);
    if (num_active == 0) {
      step = DeleteStep::stuck;
      break;
    }
    block_for_each(num_active, [&](std::uint32_t i) {
      const std::uint32_t v = list[a.picked[i]];
      a.active[i] = v;
      bool closed = false;
      const std::uint32_t size = ::cdt::detail::ring_size(m, v, closed);
      if (size == 0)
        record(WorkStatus::broken_fan);
      else if (!closed)
        record(WorkStatus::open_star);
      a.count[i] = size;
    });
    __syncthreads();
    if (failed(DeleteStep::fan_sizes)) break;
    const std::uint32_t total = block_exclusive_scan(a.count, a.offset, num_active, storage);
    if (total > a.ring_capacity) { // only the marks changed: the launches redo this round
      block_for_each(n, [&](std::uint32_t i) { a.leaving[list[i]] = kLeaving; });
      room = 1;
      break;
    }
    ++rounds;
    block_for_each(num_active, [&](std::uint32_t i) {
      ::cdt::detail::collect_ring(m, a.active[i], h, a.offset[i], a.count[i], a.slot_pos);
    });
    __syncthreads();
    block_for_each(num_active, [&](std::uint32_t i) {
      ::cdt::detail::mark_owned_vertices(m, h, a.offset[i], a.count[i], a.slot_pos);
    });
    __syncthreads();
    block_for_each(num_active, [&](std::uint32_t i) {
      const std::uint32_t v = a.active[i], base = a.offset[i], size = a.count[i];
      const WorkStatus status = ::cdt::detail::cut_ears(m, h, base, size, m.xy[v].x, m.xy[v].y);
      a.hint[i] = ::cdt::detail::ring_hint(h, base, size, a.leaving);
      if (status != WorkStatus::ok) record(status);
      m.vert_tri[v] = kNoId;
    });
    __syncthreads();
    if (failed(DeleteStep::ear_cutting)) break;
    block_for_each(num_active, [&](std::uint32_t i) {
      ::cdt::detail::relink_hole(m, h, a.offset[i], a.count[i], true, a.slot_pos);
    });
    __syncthreads();
    block_for_each(num_active, [&](std::uint32_t i) {
      for (std::uint32_t p = a.offset[i]; p < a.offset[i] + a.count[i]; ++p)
        if (h.slot[p] != kNoId) a.slot_pos[h.slot[p]] = kNoId;
    });
    __syncthreads();
    block_for_each(num_active, [&](std::uint32_t i) {
      const std::uint32_t v = a.active[i];
      a.leaving[v] = kStays;
      if (a.true_x == nullptr) return;
      m.xy[v] = {a.true_x[v], a.true_y[v]};
      a.out[written + i] = MissingPoint{v, a.hint[i]};
    });
    if (a.true_x != nullptr) written += num_active;
    const std::uint32_t num_rest = block_compact(
        n, [&](std::uint32_t i) { return a.now[i] == 0; }, a.picked, storage);
    block_for_each(num_rest, [&](std::uint32_t i) {
      rest[i] = list[a.picked[i]];
      a.leaving[rest[i]] = kLeaving;
    });
    __syncthreads();
    std::uint32_t* const swap = list;
    list = rest;
    rest = swap;
    in_rest ^= 1u;
    n = num_rest;
  }
  if (threadIdx.x == 0)
    *end = DeleteRoundsEnd{n, in_rest, rounds, written, room, step, step == DeleteStep::none ? 0u : failure};
}

/// cdt::detail::delete_vertices on the device for star holes: deletes the n vertices of `pending`
/// (leaving[v] set for each) in rounds of pairwise non-adjacent vertices, reporting to `stars` when
/// given. Returns the rounds.
std::uint64_t delete_vertices(DeviceMesh::State& s, DeviceBuffer<std::uint32_t>& pending, std::uint32_t n,
                              std::uint8_t* leaving, DeletedStars* stars) {
  CudaExecutor& executor = s.executor;
  DeviceHoles ws;
  DeviceBuffer<std::uint8_t> now_flags(n);
  DeviceBuffer<std::uint32_t> picked(n), active(n), hints(n), rest(n);
  std::uint8_t* now = now_flags.data();
  std::uint64_t rounds = 0;
  DeviceBuffer<DeleteRoundsEnd> d_end(1);
  bool in_block = true; // false for one round after the block's holes ran out of room
  // Traced: each launched round and each run of the block's rounds (every step waited for).
  ::cdt::detail::StepTrace trace("device deletion");
  const bool traced = ::cdt::detail::trace_enabled();
  while (n > 0) {
    if (in_block && n <= kDeleteBlockLimit) {
      if (s.num_slots >= ::cdt::detail::kBoundaryRef / 3)
        throw Error("internal error: too many triangle slots");
      if (ws.slot_pos.size() < s.num_slots) {
        ws.slot_pos.resize(s.num_slots);
        executor.fill_bytes(ws.slot_pos.data(), 0xFF, s.num_slots);
      }
      ws.count.resize(n);
      ws.offset.resize(n);
      const std::size_t ring = std::max<std::size_t>(ws.vertex.size(), kDeleteBlockRingRoom * std::size_t{n});
      ws.resize_ring(ring);
      const DeleteRounds args{s.view(),
                              pending.data(),
                              rest.data(),
                              n,
                              leaving,
                              now,
                              picked.data(),
                              active.data(),
                              hints.data(),
                              ws.count.data(),
                              ws.offset.data(),
                              ws.view(),
                              static_cast<std::uint32_t>(ring),
                              ws.slot_pos.data(),
                              stars != nullptr ? stars->true_x : nullptr,
                              stars != nullptr ? stars->true_y : nullptr,
                              stars != nullptr ? stars->out : nullptr,
                              stars != nullptr ? stars->written : 0};
      delete_rounds_in_block<<<1, kBlockRoundThreads, 0, executor.stream()>>>(args, d_end.data());
      check_launch("delete_rounds_in_block", __FILE__, __LINE__);
      DeleteRoundsEnd end{};
      executor.download(&end, d_end.data(), 1);
      const auto status_message = [&] {
        return ::cdt::detail::work_status_message(static_cast<WorkStatus>(end.status));
      };
      switch (end.step) {
      case DeleteStep::none:
        break;
      case DeleteStep::independence:
        throw Error(std::string("internal error: deleting vertices (Algorithm 2, independence): ") +
                    status_message());
      case DeleteStep::fan_sizes:
        throw Error(std::string("internal error: deleting vertices (fan sizes): ") + status_message());
      case DeleteStep::ear_cutting:
        throw Error(std::string("internal error: deleting bad cases (ear cutting): ") + status_message());
      case DeleteStep::stuck:
        throw Error(std::string("internal error: deleting vertices (Algorithm 2): ") +
                    ::cdt::detail::work_status_message(WorkStatus::stuck));
      }
      rounds += end.rounds;
      if (stars != nullptr) stars->written = end.written;
      if (end.in_rest != 0) std::swap(pending, rest);
      trace.count("block list", n);
      trace.count("block rounds", end.rounds);
      trace.mark("block's rounds");
      n = end.n;
      in_block = end.room == 0;
      continue;
    }
    in_block = true;
    ++rounds;
    const MeshView m = s.view();
    const std::uint32_t* list = pending.data();
    const FailureWord failure = s.failure();
    executor.for_each(
        n,
        [=] __device__(std::size_t i) {
          bool go = false;
          const WorkStatus status = ::cdt::detail::may_delete_now(m, list[i], leaving, go);
          if (status != WorkStatus::ok) failure.record(status);
          now[i] = go ? 1 : 0;
        },
        "may_delete_now");
    // The second pick (cdt::detail::may_delete_among_rest), as the host's delete_vertices marks it.
    executor.for_each(
        n,
        [=] __device__(std::size_t i) {
          if (now[i] != 0) leaving[list[i]] = kLeavingNow;
        },
        "first_pick");
    executor.for_each(
        n,
        [=] __device__(std::size_t i) {
          if (now[i] != 0) return;
          bool next = false;
          const WorkStatus status = ::cdt::detail::next_to_leaving_now(m, list[i], leaving, next);
          if (status != WorkStatus::ok) failure.record(status);
          if (next) leaving[list[i]] = kLeavingLater;
        },
        "next_to_first_pick");
    executor.for_each(
        n,
        [=] __device__(std::size_t i) {
          if (leaving[list[i]] != kLeaving) return;
          bool go = false;
          const WorkStatus status = ::cdt::detail::may_delete_among_rest(m, list[i], leaving, go);
          if (status != WorkStatus::ok) failure.record(status);
          if (go) now[i] = 1;
        },
        "second_pick");
    s.check(failure, "deleting vertices (Algorithm 2, independence)");
    const std::uint32_t num_active = executor.compact(
        n, [=] __device__(std::size_t i) { return now[i] != 0; }, picked.data());
    // The lowest-priority pending vertex has no lower leaving neighbour, so a round never comes up empty.
    if (num_active == 0)
      throw Error(std::string("internal error: deleting vertices (Algorithm 2): ") +
                  ::cdt::detail::work_status_message(WorkStatus::stuck));
    std::uint32_t* act = active.data();
    const std::uint32_t* pick = picked.data();
    executor.for_each(
        num_active, [=] __device__(std::size_t i) { act[i] = list[pick[i]]; }, "gather_active");
    std::uint32_t* hint = hints.data();
    delete_vertex_round(s, act, num_active, leaving, hint, ws);
    executor.for_each(
        num_active, [=] __device__(std::size_t i) { leaving[act[i]] = kStays; }, "clear_leaving");
    if (stars != nullptr) {
      const double* tx = stars->true_x;
      const double* ty = stars->true_y;
      MissingPoint* out = stars->out + stars->written;
      ::cdt::detail::Vec2* xy = m.xy;
      executor.for_each(
          num_active,
          [=] __device__(std::size_t i) {
            xy[act[i]] = {tx[act[i]], ty[act[i]]};
            out[i] = MissingPoint{act[i], hint[i]};
          },
          "deleted_to_missing");
      stars->written += num_active;
    }
    const std::uint32_t num_rest = executor.compact(
        n, [=] __device__(std::size_t i) { return now[i] == 0; }, picked.data());
    std::uint32_t* r = rest.data();
    executor.for_each(
        num_rest,
        [=] __device__(std::size_t i) {
          r[i] = list[pick[i]];
          leaving[r[i]] = kLeaving;
        },
        "gather_rest");
    std::swap(pending, rest);
    if (traced) executor.synchronize();
    trace.count("launched round's list", n);
    trace.count("launched round's deletions", num_active);
    trace.mark("launched round");
    n = num_rest;
  }
  return rounds;
}

/// The sites with state `wanted`, each once, in the slot order of their vert_tri (shift.cpp's
/// sites_in_slot_order); out needs room for num_sites entries. Returns how many.
std::uint32_t sites_in_slot_order(DeviceMesh::State& s, std::uint32_t num_sites, const std::uint8_t* state,
                                  std::uint8_t wanted, std::uint32_t* out) {
  const MeshView m = s.view();
  const std::uint32_t n = s.executor.compact(
      3 * static_cast<std::size_t>(m.num_slots),
      [=] __device__(std::size_t k) {
        // index_of names the first corner of v, so a triangle repeating a vertex (a corrupt mesh)
        // cannot list it twice and overrun `out`.
        const std::uint32_t v = m.tri[k];
        return v < num_sites && state[v] == wanted && m.vert_tri[v] == k / 3 &&
               m.index_of(static_cast<std::uint32_t>(k / 3), v) == k % 3;
      },
      out);
  s.executor.for_each(
      n, [=] __device__(std::size_t i) { out[i] = m.tri[out[i]]; }, "corner_vertices");
  return n;
}

/// Lists of at most this many unchecked points are shifted by one block (ShiftLoop).
constexpr std::uint32_t kShiftBlockLimit = 4096;
/// Lists of at most this many run them in a cooperative grid when the device can.
constexpr std::uint32_t kShiftGridLimit = std::uint32_t{1} << 18;

/// shift's buffers and state, for ShiftLoop.
struct ShiftRounds {
  MeshView m;
  const double* tx;
  const double* ty;
  std::uint8_t* state;
  const std::uint32_t* lower;
  std::uint8_t* ready;
  std::uint32_t* rest;
  std::uint32_t *list, *cursor, *end;                ///< the unchecked points, their neighbour lists
  std::uint32_t *next_list, *next_cursor, *next_end; ///< the next round's
  std::uint32_t n;
};

/// What ShiftLoop leaves for the host.
struct ShiftRoundsEnd {
  std::uint32_t n;       ///< points left unchecked
  std::uint32_t in_next; ///< 1 when the lists are in the next_ arrays
  std::uint32_t rounds;
  std::uint32_t status; ///< a WorkStatus: a failure of the good cases, or ok
  std::uint32_t stuck;  ///< 1 when a round checked no point
};

/// shift's rounds (Algorithm 1), the same steps in the same order, by a team (BlockTeam or GridTeam)
/// while more than `lo` and at most `hi` points are unchecked.
struct ShiftLoop {
  template <class Team>
  __device__ void operator()(const Team& team, const ShiftRounds& a, std::uint32_t lo, std::uint32_t hi,
                             ShiftRoundsEnd* end) const;
};

template <class Team>
__device__ void ShiftLoop::operator()(const Team& team, const ShiftRounds& a, std::uint32_t lo,
                                      std::uint32_t hi, ShiftRoundsEnd* end) const {
  using ::cdt::detail::kBad;
  using ::cdt::detail::kGood;
  const MeshView m = a.m;
  std::uint32_t *list = a.list, *cursor = a.cursor, *ends = a.end;
  std::uint32_t *next_list = a.next_list, *next_cursor = a.next_cursor, *next_end = a.next_end;
  std::uint32_t n = a.n, rounds = 0, in_next = 0, status = 0, stuck = 0;
  while (n > lo && n <= hi) {
    ++rounds;
    if (team.leader()) *team.word = 0;
    team.for_each(n, [&](std::uint32_t i) {
      a.ready[i] = ::cdt::detail::shift_ready(a.lower, cursor[i], ends[i], a.state) ? 1 : 0;
    });
    team.sync();
    team.for_each(n, [&](std::uint32_t i) {
      if (!a.ready[i]) return;
      const std::uint32_t v = list[i];
      bool good = false;
      const WorkStatus s = ::cdt::detail::shift_is_good(m, v, a.tx[v], a.ty[v], good);
      if (s != WorkStatus::ok) atomicCAS(team.word, 0u, static_cast<std::uint32_t>(s));
      if (good) {
        m.xy[v] = {a.tx[v], a.ty[v]};
      }
      a.state[v] = good ? kGood : kBad;
    });
    team.sync();
    if (const std::uint32_t failure = team.word_value(); failure != 0) {
      status = failure;
      break;
    }
    // The lowest-priority unchecked point is always ready, so every round checks at least one point.
    const std::uint32_t num_rest = team.compact(
        n, [&](std::uint32_t i) { return a.ready[i] == 0; }, a.rest);
    if (num_rest == n) {
      stuck = 1;
      break;
    }
    team.for_each(num_rest, [&](std::uint32_t r) {
      next_list[r] = list[a.rest[r]];
      next_cursor[r] = cursor[a.rest[r]];
      next_end[r] = ends[a.rest[r]];
    });
    team.sync();
    const auto swap = [](std::uint32_t*& x, std::uint32_t*& y) {
      std::uint32_t* const z = x;
      x = y;
      y = z;
    };
    swap(list, next_list);
    swap(cursor, next_cursor);
    swap(ends, next_end);
    in_next ^= 1u;
    n = num_rest;
  }
  if (team.leader()) *end = ShiftRoundsEnd{n, in_next, rounds, status, stuck};
}

using ShiftTeamRounds = TeamRounds<ShiftLoop, ShiftRounds, ShiftRoundsEnd, kShiftBlockLimit, kShiftGridLimit>;

/// Shifting with the sites' true positions tx, ty on the device (num_sites each).
ShiftStats shift(DeviceMesh::State& s, std::uint32_t num_sites, const double* tx, const double* ty,
                 MissingArray& missing) {
  using ::cdt::detail::kBad;
  using ::cdt::detail::kGood;
  using ::cdt::detail::kUnchecked;
  if (s.num_vertices < num_sites)
    throw Error("internal error: shift_to_true_positions: fewer vertices than sites");
  ShiftStats stats;
  CudaExecutor& executor = s.executor;
  // Traced: how the phase's rounds divide between the two algorithms (each step waited for).
  ::cdt::detail::StepTrace trace("device shift");
  const MeshView m = s.view();
  DeviceBuffer<std::uint8_t> d_state(m.num_vertices);
  std::uint8_t* state = d_state.data();
  executor.fill_bytes(state, kGood, m.num_vertices);
  executor.for_each(
      num_sites,
      [=] __device__(std::size_t v) {
        if (m.vert_tri[v] == kNoId) {
          m.xy[v] = {tx[v], ty[v]};
        } else {
          state[v] = kUnchecked;
        }
      },
      "shift_init");

  // Algorithm 1 (shift_to_true_positions in shift.cpp, step for step).
  DeviceBuffer<std::uint32_t> d_unchecked(num_sites), d_scratch(num_sites);
  std::uint32_t num = sites_in_slot_order(s, num_sites, state, kUnchecked, d_unchecked.data());
  if (num !=
      executor.compact(
          num_sites, [=] __device__(std::size_t v) { return state[v] == kUnchecked; }, d_scratch.data()))
    throw Error("internal error: shifting: a vert_tri does not point at a triangle of its vertex");
  DeviceBuffer<std::uint32_t> d_cursor(num), d_end(num);
  {
    const std::uint32_t* list = d_unchecked.data();
    std::uint32_t* cursor = d_cursor.data();
    const FailureWord failure = s.failure();
    executor.for_each(
        num,
        [=] __device__(std::size_t i) {
          std::uint32_t count = 0;
          const WorkStatus status = ::cdt::detail::lower_neighbours(m, list[i], state, nullptr, count);
          if (status != WorkStatus::ok) failure.record(status);
          cursor[i] = count;
        },
        "lower_neighbour_counts");
    s.check(failure, "shifting (Algorithm 1, neighbour lists)");
  }
  const std::uint32_t total = executor.exclusive_scan(d_cursor.data(), num);
  DeviceBuffer<std::uint32_t> d_lower(total);
  {
    const std::uint32_t* list = d_unchecked.data();
    const std::uint32_t* cursor = d_cursor.data();
    std::uint32_t* end = d_end.data();
    std::uint32_t* lower = d_lower.data();
    executor.for_each(
        num,
        [=] __device__(std::size_t i) {
          std::uint32_t count = 0;
          ::cdt::detail::lower_neighbours(m, list[i], state, lower + cursor[i], count);
          end[i] = cursor[i] + count;
        },
        "lower_neighbours");
  }
  DeviceBuffer<std::uint8_t> d_ready(num);
  DeviceBuffer<std::uint32_t> d_next_unchecked(num), d_next_cursor(num), d_next_end(num);
  const std::uint32_t* lower = d_lower.data();
  std::uint8_t* ready = d_ready.data();
  DeviceBuffer<ShiftRoundsEnd> d_block_end(1);
  ShiftTeamRounds team_rounds;
  if (::cdt::detail::trace_enabled()) executor.synchronize();
  trace.mark("set up");
  while (num > 0) {
    if (team_rounds.takes(num)) {
      const ShiftRounds args{m,
                             tx,
                             ty,
                             state,
                             lower,
                             ready,
                             d_scratch.data(),
                             d_unchecked.data(),
                             d_cursor.data(),
                             d_end.data(),
                             d_next_unchecked.data(),
                             d_next_cursor.data(),
                             d_next_end.data(),
                             num};
      team_rounds.launch(num, args, d_block_end.data(), executor.stream(), "ShiftLoop");
      ShiftRoundsEnd end{};
      executor.download(&end, d_block_end.data(), 1);
      if (end.stuck != 0)
        throw Error(std::string("internal error: shifting (Algorithm 1): ") +
                    ::cdt::detail::work_status_message(WorkStatus::stuck));
      if (end.status != 0)
        throw Error(std::string("internal error: shifting (Algorithm 1, good cases): ") +
                    ::cdt::detail::work_status_message(static_cast<WorkStatus>(end.status)));
      stats.rounds += end.rounds;
      if (end.in_next != 0) {
        std::swap(d_unchecked, d_next_unchecked);
        std::swap(d_cursor, d_next_cursor);
        std::swap(d_end, d_next_end);
      }
      trace.count("team's list", num);
      trace.count("team's rounds", end.rounds);
      trace.mark("team's rounds");
      num = end.n;
      continue;
    }
    ++stats.rounds;
    const std::uint32_t* list = d_unchecked.data();
    std::uint32_t* cursor = d_cursor.data();
    const std::uint32_t* end = d_end.data();
    executor.for_each(
        num,
        [=] __device__(std::size_t i) {
          ready[i] = ::cdt::detail::shift_ready(lower, cursor[i], end[i], state) ? 1 : 0;
        },
        "shift_ready");
    const FailureWord failure = s.failure();
    executor.for_each(
        num,
        [=] __device__(std::size_t i) {
          if (!ready[i]) return;
          const std::uint32_t v = list[i];
          bool good = false;
          const WorkStatus status = ::cdt::detail::shift_is_good(m, v, tx[v], ty[v], good);
          if (status != WorkStatus::ok) failure.record(status);
          if (good) {
            m.xy[v] = {tx[v], ty[v]};
          }
          state[v] = good ? kGood : kBad;
        },
        "shift_good_cases");
    s.check(failure, "shifting (Algorithm 1, good cases)");
    // The lowest-priority unchecked point is always ready, so every round checks at least one point.
    std::uint32_t* rest = d_scratch.data();
    const std::uint32_t num_rest = executor.compact(
        num, [=] __device__(std::size_t i) { return ready[i] == 0; }, rest);
    if (num_rest == num)
      throw Error(std::string("internal error: shifting (Algorithm 1): ") +
                  ::cdt::detail::work_status_message(WorkStatus::stuck));
    std::uint32_t* next_list = d_next_unchecked.data();
    std::uint32_t* next_cursor = d_next_cursor.data();
    std::uint32_t* next_end = d_next_end.data();
    executor.for_each(
        num_rest,
        [=] __device__(std::size_t r) {
          next_list[r] = list[rest[r]];
          next_cursor[r] = cursor[rest[r]];
          next_end[r] = end[rest[r]];
        },
        "shift_next_round");
    std::swap(d_unchecked, d_next_unchecked);
    std::swap(d_cursor, d_next_cursor);
    std::swap(d_end, d_next_end);
    if (::cdt::detail::trace_enabled()) executor.synchronize();
    trace.count("launched round's list", num);
    trace.mark("launched round");
    num = num_rest;
  }

  if (::cdt::detail::trace_enabled()) executor.synchronize();
  trace.count("sites checked", num_sites);
  trace.count("algorithm 1 rounds", stats.rounds);
  trace.mark("algorithm 1");
  // Algorithm 2: the bad cases deleted in rounds of pairwise non-adjacent vertices.
  DeviceBuffer<std::uint8_t> d_leaving(m.num_vertices);
  std::uint8_t* leaving = d_leaving.data();
  executor.fill_bytes(leaving, 0, m.num_vertices);
  executor.for_each(
      num_sites, [=] __device__(std::size_t v) { leaving[v] = state[v] == kBad ? kLeaving : kStays; },
      "leaving");
  DeviceBuffer<std::uint32_t> d_bad(num_sites);
  const std::uint32_t num_bad = sites_in_slot_order(s, num_sites, state, kBad, d_bad.data());
  stats.bad = num_bad;
  stats.shifted = executor.compact(
      num_sites, [=] __device__(std::size_t v) { return state[v] == kGood && m.vert_tri[v] != kNoId; },
      d_scratch.data());
  DeviceBuffer<MissingPoint> d_deleted(num_bad);
  DeletedStars stars{tx, ty, d_deleted.data(), 0};
  const std::uint64_t deletion_rounds = delete_vertices(s, d_bad, num_bad, leaving, &stars);
  stats.rounds += deletion_rounds;
  const std::size_t first = missing.size();
  missing.resize(first + stars.written);
  executor.download(missing.data() + first, d_deleted.data(), stars.written);
  trace.count("bad cases", num_bad);
  trace.count("deletion rounds", deletion_rounds);
  trace.mark("algorithm 2");
  return stats;
}

/// Lists of at most this many missing points are inserted by one block (InsertLoop).
constexpr std::uint32_t kInsertBlockLimit = 4096;
/// Lists of at most this many run them in a cooperative grid when the device can.
constexpr std::uint32_t kInsertGridLimit = std::uint32_t{1} << 18;

/// insert's buffers and state, for InsertLoop.
struct InsertRounds {
  MeshView m;
  const MissingPoint* points;
  std::uint32_t* remaining;
  std::uint32_t* rest;
  std::uint32_t n;
  std::uint32_t* start;
  std::uint32_t* pending;
  std::uint32_t fallback;
  std::uint8_t* made;
  const std::uint32_t* free_slots;
  std::uint32_t num_free;
  std::uint32_t cursor;
  std::uint32_t *loc_t, *loc_e, *loc_u, *loc_j, *new0, *new1, *mark;
  std::uint8_t* flags;
  std::uint8_t* own;
  std::uint32_t* picked;
  std::uint32_t* winners;
};

/// Which step of InsertLoop failed.
enum class InsertStep : std::uint32_t { none, location, stuck, slots };

/// What InsertLoop leaves for the host.
struct InsertRoundsEnd {
  std::uint32_t n;       ///< points left
  std::uint32_t in_rest; ///< 1 when the list is in `rest`
  std::uint32_t rounds;
  std::uint32_t cursor; ///< free slots used
  std::uint32_t inserted;
  InsertStep step;
  std::uint32_t status; ///< with InsertStep::location: a WorkStatus
};

/// insert's rounds (Algorithm 3), the same steps in the same order, by a team (BlockTeam or GridTeam)
/// while the list has more than `lo` and at most `hi` points.
struct InsertLoop {
  template <class Team>
  __device__ void operator()(const Team& team, const InsertRounds& a, std::uint32_t lo, std::uint32_t hi,
                             InsertRoundsEnd* end) const;
};

template <class Team>
__device__ void InsertLoop::operator()(const Team& team, const InsertRounds& a, std::uint32_t lo,
                                       std::uint32_t hi, InsertRoundsEnd* end) const {
  const MeshView m = a.m;
  std::uint32_t* remaining = a.remaining;
  std::uint32_t* rest = a.rest;
  std::uint32_t n = a.n, cursor = a.cursor;
  std::uint32_t rounds = 0, in_rest = 0, inserted = 0;
  InsertStep step = InsertStep::none;
  std::uint32_t location_status = 0;
  const ::cdt::detail::InsertRound round{a.loc_t, a.loc_e, a.loc_u, a.loc_j, a.new0, a.new1, a.mark, a.flags};
  const ::cdt::detail::InsertClaims claims{a.points, a.start, a.loc_t, a.loc_e,
                                           a.loc_u,  a.loc_j, a.mark,  a.flags};
  while (n > lo && n <= hi) {
    ++rounds;
    if (team.leader()) *team.word = 0;
    team.sync();
    // Lines 2-5: locate and mark the containers.
    team.for_each(n, [&](std::uint32_t r) {
      ::cdt::detail::locate_and_claim(
          m, claims, remaining[r], a.pending, a.fallback, ClaimMin{},
          [&](WorkStatus status) { atomicCAS(team.word, 0u, static_cast<std::uint32_t>(status)); });
    });
    team.sync();
    if (const std::uint32_t failure = team.word_value(); failure != 0) {
      step = InsertStep::location;
      location_status = failure;
      break;
    }
    // Lines 6-13: winners, and a start for the losers next round.
    team.for_each(n, [&](std::uint32_t r) { ::cdt::detail::settle_insert_claims(m, claims, remaining[r]); });
    team.sync();
    team.for_each(n, [&](std::uint32_t r) { ::cdt::detail::restart_at_winner(claims, remaining[r]); });
    team.sync();
    const std::uint32_t num_winners = team.compact(
        n, [&](std::uint32_t r) { return ::cdt::detail::insert_claim_won(claims, remaining[r]); }, a.picked);
    if (num_winners == 0) {
      step = InsertStep::stuck;
      break;
    }
    if (cursor + 2 * static_cast<std::size_t>(num_winners) > a.num_free) {
      step = InsertStep::slots;
      break;
    }
    team.for_each(num_winners, [&](std::uint32_t r) { a.winners[r] = remaining[a.picked[r]]; });
    team.sync();
    // Lines 14-16: slots by rank, and who rewrites each corner's vert_tri.
    team.for_each(num_winners, [&](std::uint32_t r) {
      const std::uint32_t q = a.winners[r];
      a.new0[q] = a.free_slots[cursor + 2 * r];
      a.new1[q] = a.free_slots[cursor + 2 * r + 1];
      a.own[q] = ::cdt::detail::split_corner_owners(m, round, q);
    });
    team.sync();
    // Lines 17-19: split the containers.
    team.for_each(num_winners, [&](std::uint32_t r) {
      const std::uint32_t q = a.winners[r];
      const std::uint32_t v = a.points[q].vertex;
      if (a.loc_e[q] == 3)
        ::cdt::detail::split_triangle(m, v, a.loc_t[q], a.new0[q], a.new1[q], a.own[q]);
      else
        ::cdt::detail::split_edge(m, v, a.loc_t[q], a.loc_e[q], a.loc_u[q], a.loc_j[q], a.new0[q], a.new1[q],
                                  a.own[q]);
      a.pending[v] = 0;
      a.made[a.loc_t[q]] = a.made[a.new0[q]] = a.made[a.new1[q]] = 1;
      if (a.loc_u[q] != kNoId) a.made[a.loc_u[q]] = 1;
    });
    team.sync();
    // Lines 20-22: outer links.
    team.for_each(num_winners,
                  [&](std::uint32_t r) { ::cdt::detail::link_split_outer_edges(m, round, a.winners[r]); });
    team.sync();
    team.for_each(n, [&](std::uint32_t r) { ::cdt::detail::clear_insert_claims(claims, remaining[r]); });
    cursor += 2 * num_winners;
    inserted += num_winners;
    const std::uint32_t num_rest = team.compact(
        n, [&](std::uint32_t r) { return !::cdt::detail::insert_claim_won(claims, remaining[r]); }, a.picked);
    team.for_each(num_rest, [&](std::uint32_t r) { rest[r] = remaining[a.picked[r]]; });
    team.sync();
    std::uint32_t* const swap = remaining;
    remaining = rest;
    rest = swap;
    in_rest ^= 1u;
    n = num_rest;
  }
  if (team.leader()) *end = InsertRoundsEnd{n, in_rest, rounds, cursor, inserted, step, location_status};
}

using InsertTeamRounds =
    TeamRounds<InsertLoop, InsertRounds, InsertRoundsEnd, kInsertBlockLimit, kInsertGridLimit>;

/// A launched insertion round's words on the device: the counts its steps size themselves by, and
/// what the host reads at its end, once.
struct InsertRoundWords {
  std::uint32_t winners;
  std::uint32_t rest;
  InsertStep step;
  std::uint32_t status; ///< with InsertStep::location: a WorkStatus
  /// The next list's length (kNoId after an error) in the low half, the round's insertions in the high.
  unsigned long long reply;
};

InsertStats insert(DeviceMesh::State& s, std::span<const MissingPoint> missing,
                   const HostParallelFor& parallel) {
  s.require_alone("insert");
  using ::cdt::detail::PointLocation;
  InsertStats stats;
  // The points taken from the sites come first (and are no longer held once copied into the list).
  DeviceBuffer<MissingPoint> first = std::move(s.missing_first);
  const std::size_t num_first = first.size();
  const std::size_t num_points = num_first + missing.size();
  if (num_points == 0) return stats;
  if (num_points >= kNoId / 2) throw Error("internal error: too many missing points");
  const auto num = static_cast<std::uint32_t>(num_points);
  CudaExecutor& executor = s.executor;
  const std::uint32_t nv = s.num_vertices;
  // Traced: the set-up's steps, the rounds of Algorithm 3 alone (the phase's count adds the fake fans'
  // flips), each launched round and each run of the team's rounds (every step waited for).
  ::cdt::detail::StepTrace trace("device missing points");
  const bool traced = ::cdt::detail::trace_enabled();
  const auto step = [&](const char* name) {
    if (traced) executor.synchronize();
    trace.mark(name);
  };

  // Every insertion takes exactly two slots, so the mesh grows once up front and no round reallocates.
  DeviceBuffer<std::uint32_t> d_free(s.num_slots + 2 * static_cast<std::size_t>(num));
  {
    const MeshView m0 = s.view();
    const std::uint32_t free_now = executor.compact(
        m0.num_slots, [=] __device__(std::size_t t) { return !m0.alive(static_cast<std::uint32_t>(t)); },
        d_free.data());
    const std::size_t need = 2 * num_points;
    if (free_now < need) {
      if (s.num_slots + (need - free_now) >= kNoId / 3)
        throw Error("internal error: too many triangle slots");
      s.grow_slots(static_cast<std::uint32_t>(need - free_now));
    }
  }
  step("slots grown");
  const MeshView m = s.view();
  s.made_by_insert.resize(m.num_slots);
  std::uint8_t* made = s.made_by_insert.data();
  executor.fill_bytes(made, 0, m.num_slots);
  const std::uint32_t num_free = executor.compact(
      m.num_slots, [=] __device__(std::size_t t) { return !m.alive(static_cast<std::uint32_t>(t)); },
      d_free.data());
  const std::uint32_t* free_slots = d_free.data();

  DeviceBuffer<MissingPoint> d_missing(num);
  if (num_first > 0)
    CDT_CUDA_CHECK(cudaMemcpyAsync(d_missing.data(), first.data(), num_first * sizeof(MissingPoint),
                                   cudaMemcpyDeviceToDevice, executor.stream()));
  first = {}; // freed in stream order after the copy: not held through the rounds
  executor.upload(d_missing.data() + num_first, missing.data(), missing.size(), &parallel);
  const MissingPoint* points = d_missing.data();
  // The checks of insert.cpp, reporting the same point: the first one (in list order) that is out of
  // range, already in the mesh, or a vertex listed before. pending first holds each vertex's first
  // listing, then whether it is pending.
  DeviceBuffer<std::uint32_t> d_pending(nv);
  std::uint32_t* pending = d_pending.data();
  executor.fill_bytes(pending, 0xFF, nv);
  DeviceBuffer<std::uint32_t> d_words(2);
  std::uint32_t* invalid = d_words.data();
  std::uint32_t* first_live = d_words.data() + 1;
  executor.fill_bytes(d_words.data(), 0xFF, 2);
  executor.for_each(
      num,
      [=] __device__(std::size_t q) {
        const std::uint32_t v = points[q].vertex;
        if (v < nv) atomicMin(pending + v, static_cast<std::uint32_t>(q));
      },
      "first_listing");
  executor.for_each(
      num,
      [=] __device__(std::size_t q) {
        const std::uint32_t v = points[q].vertex;
        if (v >= nv || m.vert_tri[v] != kNoId || pending[v] != q)
          atomicMin(invalid, static_cast<std::uint32_t>(q));
      },
      "missing_check");
  executor.for_each(
      nv, [=] __device__(std::size_t v) { pending[v] = pending[v] != kNoId ? 1u : 0u; }, "pending");
  // A start for points whose hint will never be in the mesh: a vertex of the first live triangle.
  executor.for_each(
      m.num_slots,
      [=] __device__(std::size_t t) {
        if (m.alive(static_cast<std::uint32_t>(t))) atomicMin(first_live, static_cast<std::uint32_t>(t));
      },
      "first_live_slot");
  std::uint32_t words[2] = {0, 0};
  executor.download(words, d_words.data(), 2);
  if (words[0] != kNoId) {
    MissingPoint bad{};
    executor.download(&bad, points + words[0], 1);
    const std::uint32_t v = bad.vertex;
    throw Error("internal error: missing point " + std::to_string(v) +
                (v >= nv ? " out of range" : " is already in the mesh or listed twice"));
  }
  if (words[1] == kNoId) throw Error("internal error: inserting missing points into an empty mesh");
  std::uint32_t fallback = kNoId;
  executor.download(&fallback, m.tri + 3 * static_cast<std::size_t>(words[1]), 1);
  step("points checked");

  DeviceBuffer<std::uint32_t> d_start(num), d_loc_t(num), d_loc_e(num), d_loc_u(num), d_loc_j(num),
      d_new0(num), d_new1(num), d_mark(m.num_slots), d_remaining(num), d_rest(num), d_winners(num),
      d_picked(num);
  DeviceBuffer<std::uint8_t> d_flags(num), d_own(num);
  std::uint32_t* start = d_start.data();
  std::uint32_t* loc_t = d_loc_t.data();
  std::uint32_t* loc_e = d_loc_e.data();
  std::uint32_t* loc_u = d_loc_u.data();
  std::uint32_t* loc_j = d_loc_j.data();
  std::uint32_t* new0 = d_new0.data();
  std::uint32_t* new1 = d_new1.data();
  std::uint32_t* mark = d_mark.data();
  std::uint8_t* flags = d_flags.data();
  std::uint8_t* own = d_own.data();
  const ::cdt::detail::InsertClaims claims{points, start, loc_t, loc_e, loc_u, loc_j, mark, flags};
  executor.fill_bytes(mark, 0xFF, m.num_slots);
  {
    std::uint32_t* remaining = d_remaining.data();
    executor.for_each(
        num,
        [=] __device__(std::size_t q) {
          start[q] = points[q].hint;
          remaining[q] = static_cast<std::uint32_t>(q);
        },
        "insert_init");
  }
  std::uint32_t n = num;
  std::size_t cursor = 0;

  DeviceBuffer<InsertRoundsEnd> d_end(1);
  DeviceBuffer<InsertRoundWords> d_round_words(1);
  InsertTeamRounds team_rounds;
  step("set up");
  while (n > 0) {
    if (team_rounds.takes(n)) {
      const InsertRounds args{m,
                              points,
                              d_remaining.data(),
                              d_rest.data(),
                              n,
                              start,
                              pending,
                              fallback,
                              made,
                              free_slots,
                              num_free,
                              static_cast<std::uint32_t>(cursor),
                              loc_t,
                              loc_e,
                              loc_u,
                              loc_j,
                              new0,
                              new1,
                              mark,
                              flags,
                              own,
                              d_picked.data(),
                              d_winners.data()};
      team_rounds.launch(n, args, d_end.data(), executor.stream(), "InsertLoop");
      InsertRoundsEnd end{};
      executor.download(&end, d_end.data(), 1);
      switch (end.step) {
      case InsertStep::none:
        break;
      case InsertStep::location:
        throw Error(std::string("internal error: inserting missing points (Algorithm 3, point location): ") +
                    ::cdt::detail::work_status_message(static_cast<WorkStatus>(end.status)));
      case InsertStep::stuck:
        throw Error(std::string("internal error: inserting missing points (Algorithm 3; hints may form a "
                                "cycle): ") +
                    ::cdt::detail::work_status_message(WorkStatus::stuck));
      case InsertStep::slots:
        throw Error("internal error: out of free triangle slots");
      }
      stats.rounds += end.rounds;
      stats.inserted += end.inserted;
      cursor = end.cursor;
      if (end.in_rest != 0) std::swap(d_remaining, d_rest);
      trace.count("team's list", n);
      trace.count("team's rounds", end.rounds);
      trace.mark("team's rounds");
      n = end.n;
      continue;
    }
    ++stats.rounds;
    const std::uint32_t* remaining = d_remaining.data();
    // The same steps, sized by the counts the compactions leave on the device; the host waits once,
    // for the next list's length and the round's insertions (and errors) together.
    InsertRoundWords* round_words = d_round_words.data();
    // Lines 2-5: locate and mark the containers.
    const FailureWord failure = s.failure();
    executor.for_each(
        n,
        [=] __device__(std::size_t r) {
          ::cdt::detail::locate_and_claim(m, claims, remaining[r], pending, fallback, ClaimMin{},
                                          [&](WorkStatus status) { failure.record(status); });
        },
        "locate_missing");
    // Lines 6-13: winners, and a start for the losers next round.
    executor.for_each(
        n, [=] __device__(std::size_t r) { ::cdt::detail::settle_insert_claims(m, claims, remaining[r]); },
        "insert_claims");
    executor.for_each(
        n, [=] __device__(std::size_t r) { ::cdt::detail::restart_at_winner(claims, remaining[r]); },
        "insert_restarts");
    std::uint32_t* picked = d_picked.data();
    // After a failed location nothing wins, and nothing is split.
    executor.compact_to(
        n,
        [=] __device__(std::size_t r) {
          return *failure.word == 0 && ::cdt::detail::insert_claim_won(claims, remaining[r]);
        },
        picked, &round_words->winners);
    const std::size_t base = cursor;
    executor.for_each(
        1,
        [=] __device__(std::size_t) {
          round_words->status = *failure.word;
          round_words->step = InsertStep::none;
          if (round_words->status != 0)
            round_words->step = InsertStep::location;
          else if (round_words->winners == 0)
            // The smallest located key holds every mark it made, so a round without winners means
            // none was located.
            round_words->step = InsertStep::stuck;
          else if (base + 2 * static_cast<std::size_t>(round_words->winners) > num_free)
            round_words->step = InsertStep::slots;
          if (round_words->step != InsertStep::none) round_words->winners = 0;
        },
        "insert_round_check");
    const auto num_winners = [=] __device__() -> std::size_t { return round_words->winners; };
    std::uint32_t* winners = d_winners.data();
    executor.for_each_counted(
        n, num_winners, [=] __device__(std::size_t r) { winners[r] = remaining[picked[r]]; },
        "gather_winners");
    const ::cdt::detail::InsertRound round{loc_t, loc_e, loc_u, loc_j, new0, new1, mark, flags};
    // Lines 14-16: slots by rank, and who rewrites each corner's vert_tri.
    executor.for_each_counted(
        n, num_winners,
        [=] __device__(std::size_t r) {
          const std::uint32_t q = winners[r];
          new0[q] = free_slots[base + 2 * r];
          new1[q] = free_slots[base + 2 * r + 1];
          own[q] = ::cdt::detail::split_corner_owners(m, round, q);
        },
        "insert_slots");
    // Lines 17-19: split the containers.
    executor.for_each_counted(
        n, num_winners,
        [=] __device__(std::size_t r) {
          const std::uint32_t q = winners[r];
          const std::uint32_t v = points[q].vertex;
          if (loc_e[q] == 3)
            ::cdt::detail::split_triangle(m, v, loc_t[q], new0[q], new1[q], own[q]);
          else
            ::cdt::detail::split_edge(m, v, loc_t[q], loc_e[q], loc_u[q], loc_j[q], new0[q], new1[q], own[q]);
          pending[v] = 0;
          made[loc_t[q]] = made[new0[q]] = made[new1[q]] = 1;
          if (loc_u[q] != kNoId) made[loc_u[q]] = 1;
        },
        "insert_split");
    // Lines 20-22: outer links.
    executor.for_each_counted(
        n, num_winners,
        [=] __device__(std::size_t r) { ::cdt::detail::link_split_outer_edges(m, round, winners[r]); },
        "insert_links");
    executor.for_each(
        n, [=] __device__(std::size_t r) { ::cdt::detail::clear_insert_claims(claims, remaining[r]); },
        "insert_clear_marks");
    executor.compact_to(
        n, [=] __device__(std::size_t r) { return !::cdt::detail::insert_claim_won(claims, remaining[r]); },
        picked, &round_words->rest);
    std::uint32_t* rest = d_rest.data();
    executor.for_each_counted(
        n, [=] __device__() -> std::size_t { return round_words->rest; },
        [=] __device__(std::size_t r) { rest[r] = remaining[picked[r]]; }, "gather_rest");
    executor.for_each(
        1,
        [=] __device__(std::size_t) {
          const std::uint32_t next = round_words->step == InsertStep::none ? round_words->rest : kNoId;
          round_words->reply = round_reply(next, round_words->winners);
        },
        "insert_round_end");
    const RoundReply reply = wait_for_reply(executor, &round_words->reply);
    const std::uint32_t num_rest = reply.next, num_inserted = reply.count;
    if (num_rest == kNoId) {
      InsertRoundWords failed{};
      executor.download(&failed, round_words, 1);
      if (failed.step == InsertStep::location)
        throw Error(std::string("internal error: inserting missing points (Algorithm 3, point location): ") +
                    ::cdt::detail::work_status_message(static_cast<WorkStatus>(failed.status)));
      if (failed.step == InsertStep::stuck)
        throw Error(std::string("internal error: inserting missing points (Algorithm 3; hints may form a "
                                "cycle): ") +
                    ::cdt::detail::work_status_message(WorkStatus::stuck));
      throw Error("internal error: out of free triangle slots");
    }
    cursor += 2 * static_cast<std::size_t>(num_inserted);
    stats.inserted += num_inserted;
    std::swap(d_remaining, d_rest);
    if (traced) executor.synchronize();
    trace.count("launched round's list", n);
    trace.count("launched round's insertions", num_inserted);
    trace.mark("launched round");
    n = num_rest;
  }
  trace.count("points", num_points);
  trace.count("rounds", stats.rounds);
  return stats;
}

/// The mesh's edge of a local edge of the fans' copy (global: the mesh's slot of each local slot).
__device__ inline std::uint32_t global_edge(const std::uint32_t* global, std::uint32_t le) {
  return le == kNoId ? kNoId : edge_id(global[edge_tri(le)], edge_index(le));
}

/// The fake vertices' fans, numbered locally, copied to the host for remove_on_host and written back.
/// Local slots: the fans' triangles (those with a corner >= first_fake) in slot order, then the
/// triangles across their edges (each with its corners and only its links back to the fans), then one
/// free slot standing for every other triangle that a vert_tri names. Local vertices: the corners of
/// all of them in the order of their ids, so the fake ones come last. All numbering by ordered
/// compactions, so the copy is the same on every run.
void remove_fake_fans(DeviceMesh::State& s, std::uint32_t first_fake,
                      const DeviceMesh::RemoveOnHost& remove_on_host) {
  CudaExecutor& executor = s.executor;
  const MeshView m = s.view();
  // Per slot of the mesh: its local slot (claims of the triangles across go in as kClaim | edge first).
  constexpr std::uint32_t kClaim = 0x80000000u;
  DeviceBuffer<std::uint32_t> d_local(m.num_slots), d_fans(m.num_slots);
  std::uint32_t* local = d_local.data();
  std::uint32_t* fans = d_fans.data();
  executor.fill_bytes(local, 0xFF, m.num_slots);
  const std::uint32_t num_fans = executor.compact(
      m.num_slots,
      [=] __device__(std::size_t t) {
        const std::uint32_t* c = m.tri + 3 * t;
        return c[0] != kNoId && (c[0] >= first_fake || c[1] >= first_fake || c[2] >= first_fake);
      },
      fans);
  if (num_fans == 0) return;
  if (num_fans >= kClaim / 3) throw Error("internal error: remove_fake_boundary: too many fan triangles");
  executor.for_each(
      num_fans, [=] __device__(std::size_t r) { local[fans[r]] = static_cast<std::uint32_t>(r); },
      "fan_slots");
  const std::uint32_t fan_edges = 3 * num_fans;
  executor.for_each(
      fan_edges,
      [=] __device__(std::size_t k) {
        const std::uint32_t e = m.adj[3 * fans[k / 3] + k % 3];
        if (e != kNoId) atomicMin(local + edge_tri(e), kClaim | static_cast<std::uint32_t>(k));
      },
      "claim_across");
  DeviceBuffer<std::uint32_t> d_across(fan_edges);
  std::uint32_t* across = d_across.data();
  const std::uint32_t num_across = executor.compact(
      fan_edges,
      [=] __device__(std::size_t k) {
        const std::uint32_t e = m.adj[3 * fans[k / 3] + k % 3];
        return e != kNoId && local[edge_tri(e)] == (kClaim | static_cast<std::uint32_t>(k));
      },
      across);
  const std::uint32_t num_local = num_fans + num_across; // the free slot comes after these
  DeviceBuffer<std::uint32_t> d_global(num_local);
  std::uint32_t* global = d_global.data();
  executor.for_each(
      num_local,
      [=] __device__(std::size_t q) {
        if (q < num_fans) {
          global[q] = fans[q];
          return;
        }
        const std::uint32_t k = across[q - num_fans];
        const std::uint32_t u = edge_tri(m.adj[3 * fans[k / 3] + k % 3]);
        global[q] = u;
        local[u] = static_cast<std::uint32_t>(q);
      },
      "across_slots");
  // Local vertices.
  DeviceBuffer<std::uint32_t> d_vlocal(m.num_vertices);
  std::uint32_t* vlocal = d_vlocal.data();
  executor.fill_bytes(vlocal, 0xFF, m.num_vertices);
  executor.for_each(
      num_local,
      [=] __device__(std::size_t q) {
        for (std::uint32_t j = 0; j < 3; ++j) vlocal[m.tri[3 * global[q] + j]] = 0;
      },
      "mark_fan_vertices");
  DeviceBuffer<std::uint32_t> d_ids(m.num_vertices);
  std::uint32_t* ids = d_ids.data();
  const std::uint32_t num_ids = executor.compact(
      m.num_vertices, [=] __device__(std::size_t v) { return vlocal[v] == 0; }, ids);
  executor.for_each(
      num_ids, [=] __device__(std::size_t i) { vlocal[ids[i]] = static_cast<std::uint32_t>(i); },
      "vertex_ids");

  // The copy: tri, adj, seg of num_local + 1 slots, then vert_tri and ids of the vertices, in one buffer.
  const std::size_t words = 3 * static_cast<std::size_t>(num_local + 1);
  const std::size_t copy_size = 3 * words + 2 * static_cast<std::size_t>(num_ids);
  DeviceBuffer<std::uint32_t> d_copy(copy_size);
  DeviceBuffer<::cdt::detail::Vec2> d_xy(num_ids);
  std::uint32_t* ltri = d_copy.data();
  std::uint32_t* ladj = ltri + words;
  std::uint32_t* lseg = ladj + words;
  std::uint32_t* lvt = lseg + words;
  std::uint32_t* lids = lvt + num_ids;
  ::cdt::detail::Vec2* lxy = d_xy.data();
  executor.fill_bytes(ltri, 0xFF, 3 * words);
  executor.for_each(
      fan_edges,
      [=] __device__(std::size_t k) {
        const std::uint32_t t = fans[k / 3], i = k % 3;
        const std::uint32_t e = m.adj[3 * t + i];
        ltri[k] = vlocal[m.tri[3 * t + i]];
        lseg[k] = m.seg[3 * t + i];
        if (e == kNoId) return;
        const std::uint32_t u = local[edge_tri(e)];
        ladj[k] = edge_id(u, edge_index(e));
        if (u >= num_fans) ladj[edge_id(u, edge_index(e))] = static_cast<std::uint32_t>(k);
      },
      "copy_fans");
  executor.for_each(
      num_across,
      [=] __device__(std::size_t q) {
        const std::uint32_t u = global[num_fans + q];
        for (std::uint32_t j = 0; j < 3; ++j) ltri[3 * (num_fans + q) + j] = vlocal[m.tri[3 * u + j]];
      },
      "copy_across");
  executor.for_each(
      num_ids,
      [=] __device__(std::size_t i) {
        const std::uint32_t v = ids[i];
        const std::uint32_t t = m.vert_tri[v];
        const std::uint32_t lt = t == kNoId ? kNoId : local[t];
        lvt[i] = lt != kNoId ? lt : (t == kNoId ? kNoId : num_local);
        lids[i] = v;
        lxy[i] = m.xy[v];
      },
      "copy_fan_vertices");
  std::vector<std::uint32_t> copy(copy_size);
  std::vector<::cdt::detail::Vec2> xy(num_ids);
  executor.download(copy.data(), d_copy.data(), copy_size);
  executor.download(xy.data(), lxy, xy.size());

  ::cdt::detail::Mesh host;
  host.tri.assign(copy.begin(), copy.begin() + words);
  host.adj.assign(copy.begin() + words, copy.begin() + 2 * words);
  host.seg.assign(copy.begin() + 2 * words, copy.begin() + 3 * words);
  host.vert_tri.assign(copy.begin() + 3 * words, copy.begin() + 3 * words + num_ids);
  host.xy = std::move(xy);
  const std::span<const std::uint32_t> ranked_as(copy.data() + 3 * words + num_ids, num_ids);
  const auto first_local_fake = static_cast<std::uint32_t>(
      std::lower_bound(ranked_as.begin(), ranked_as.end(), first_fake) - ranked_as.begin());
  remove_on_host(host, first_local_fake, ranked_as);
  if (host.tri.size() != words || host.adj.size() != words || host.seg.size() != words ||
      host.vert_tri.size() < first_local_fake)
    throw Error("internal error: remove_fake_boundary: the fans' copy changed size on the host");

  // Write back: the fans' slots whole, the links back from the triangles across, the real vertices'
  // vert_tri where the host changed them (compared with the copy still on the device).
  DeviceBuffer<std::uint32_t> d_back(3 * words + first_local_fake);
  std::uint32_t* btri = d_back.data();
  std::uint32_t* badj = btri + words;
  std::uint32_t* bseg = badj + words;
  std::uint32_t* bvt = bseg + words;
  executor.upload(btri, host.tri.data(), words);
  executor.upload(badj, host.adj.data(), words);
  executor.upload(bseg, host.seg.data(), words);
  executor.upload(bvt, host.vert_tri.data(), first_local_fake);
  const FailureWord failure = s.failure();
  const std::uint32_t slots = num_local;
  executor.for_each(
      fan_edges,
      [=] __device__(std::size_t k) {
        const std::uint32_t t = fans[k / 3], i = k % 3;
        const std::uint32_t lv = btri[k], le = badj[k];
        if ((lv != kNoId && lv >= num_ids) || (le != kNoId && edge_tri(le) >= slots)) {
          failure.record(WorkStatus::broken_fan);
          return;
        }
        const std::uint32_t e = m.adj[3 * t + i]; // still the old link: the triangles across are read here
        if (e != kNoId && local[edge_tri(e)] >= num_fans) {
          const std::uint32_t back = badj[edge_id(local[edge_tri(e)], edge_index(e))];
          if (back != kNoId && edge_tri(back) >= slots) {
            failure.record(WorkStatus::broken_fan);
            return;
          }
          m.adj[e] = global_edge(global, back);
        }
      },
      "write_back_links");
  executor.for_each(
      fan_edges,
      [=] __device__(std::size_t k) {
        const std::uint32_t t = fans[k / 3], i = k % 3;
        const std::uint32_t lv = btri[k], le = badj[k];
        if ((lv != kNoId && lv >= num_ids) || (le != kNoId && edge_tri(le) >= slots)) return;
        m.tri[3 * t + i] = lv == kNoId ? kNoId : lids[lv];
        m.adj[3 * t + i] = global_edge(global, le);
        m.seg[3 * t + i] = bseg[k];
      },
      "write_back_fans");
  executor.for_each(
      first_local_fake,
      [=] __device__(std::size_t i) {
        const std::uint32_t lt = bvt[i];
        if (lt == lvt[i]) return;
        if (lt != kNoId && lt >= slots) {
          failure.record(WorkStatus::broken_fan);
          return;
        }
        m.vert_tri[lids[i]] = lt == kNoId ? kNoId : global[lt];
      },
      "write_back_vert_tri");
  s.check(failure, "writing the fake boundary's removal back");
}

/// After the fake boundary's removal: the live slots compacted in the order of their lowest vertex, the
/// fake vertices dropped.
void compact_after_fake_removal(DeviceMesh::State& s, std::uint32_t first_fake) {
  CudaExecutor& executor = s.executor;
  const std::uint32_t nv = s.num_vertices;
  // Compaction ordered by each triangle's lowest vertex (remove_fake_boundary in insert.cpp: a stable
  // sort keeps the slots of one key in slot order), links and vert_tri renumbered.
  const MeshView m = s.view();
  DeviceBuffer<std::uint32_t> d_live(m.num_slots), d_key(m.num_slots);
  std::uint32_t* live = d_live.data();
  std::uint32_t* key = d_key.data();
  const std::uint32_t num_live = executor.compact(
      m.num_slots, [=] __device__(std::size_t t) { return m.alive(static_cast<std::uint32_t>(t)); }, live);
  executor.for_each(
      num_live,
      [=] __device__(std::size_t r) {
        const std::uint32_t t = live[r];
        const std::uint32_t a = m.tri[3 * t], b = m.tri[3 * t + 1], c = m.tri[3 * t + 2];
        key[r] = a < b ? (a < c ? a : c) : (b < c ? b : c);
      },
      "lowest_vertex");
  executor.sort_pairs(key, live, num_live, bits_below(nv));
  DeviceBuffer<std::uint32_t> d_new_id(m.num_slots);
  std::uint32_t* new_id = d_new_id.data();
  executor.fill_bytes(new_id, 0xFF, m.num_slots);
  executor.for_each(
      num_live, [=] __device__(std::size_t r) { new_id[live[r]] = static_cast<std::uint32_t>(r); },
      "new_ids");
  const std::size_t words = 3 * static_cast<std::size_t>(num_live);
  DeviceBuffer<std::uint32_t> d_tri(words), d_adj(words), d_seg(words);
  std::uint32_t* tri = d_tri.data();
  std::uint32_t* adj = d_adj.data();
  std::uint32_t* seg = d_seg.data();
  executor.for_each(
      num_live,
      [=] __device__(std::size_t r) {
        const std::uint32_t t = live[r];
        for (std::uint32_t i = 0; i < 3; ++i) {
          const std::uint32_t e = m.adj[3 * t + i];
          tri[3 * r + i] = m.tri[3 * t + i];
          adj[3 * r + i] = e == kNoId ? kNoId : edge_id(new_id[edge_tri(e)], edge_index(e));
          seg[3 * r + i] = m.seg[3 * t + i];
        }
      },
      "compact_slots");
  executor.for_each(
      first_fake,
      [=] __device__(std::size_t v) {
        const std::uint32_t vt = m.vert_tri[v];
        m.vert_tri[v] = vt == kNoId ? kNoId : new_id[vt];
      },
      "renumber_vert_tri");
  executor.synchronize(); // the old arrays are freed next
  s.tri = std::move(d_tri);
  s.adj = std::move(d_adj);
  s.seg = std::move(d_seg);
  s.num_slots = num_live;
  s.num_vertices = first_fake;
}

/// Device memory of a mesh with `slots` slots and nv vertices, in bytes.
std::size_t mesh_device_bytes(std::size_t slots, std::size_t nv) { return 36 * slots + 20 * nv; }

} // namespace detail

void DeviceMesh::State::grow_slots(std::uint32_t n) {
  const std::size_t used = 3 * static_cast<std::size_t>(num_slots);
  const std::size_t count = used + 3 * static_cast<std::size_t>(n);
  detail::require_device_memory(3 * 4 * count, 0,
                                "growing the mesh to " + std::to_string(count / 3) + " slots");
  detail::grow_buffer(executor, tri, used, count, 0xFF);
  detail::grow_buffer(executor, adj, used, count, 0xFF);
  detail::grow_buffer(executor, seg, used, count, 0xFF);
  num_slots += n;
}

void DeviceMesh::add_vertices(std::span<const double> x, std::span<const double> y) {
  if (x.size() != y.size()) throw Error("internal error: add_vertices: x and y differ in length");
  if (x.empty()) return;
  State& s = *state_;
  s.require_alone("add_vertices");
  const std::size_t used = s.num_vertices;
  const std::size_t count = used + x.size();
  if (count >= kNoId) throw Error("internal error: add_vertices: too many vertices");
  detail::require_device_memory(20 * count, 0, "growing the mesh to " + std::to_string(count) + " vertices");
  detail::grow_buffer(s.executor, s.xy, used, count, 0);
  detail::grow_buffer(s.executor, s.vert_tri, used, count, 0xFF);
  std::vector<::cdt::detail::Vec2> added(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) added[i] = {x[i], y[i]};
  s.executor.upload(s.xy.data() + used, added.data(), added.size());
  s.num_vertices = static_cast<std::uint32_t>(count);
}

DeviceMesh::DeviceMesh(const ::cdt::detail::Mesh& mesh) : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.allocate(mesh.num_slots(), mesh.num_vertices());
  const std::size_t words = 3 * static_cast<std::size_t>(s.num_slots);
  s.executor.upload(s.xy.data(), mesh.xy.data(), s.num_vertices);
  s.executor.upload(s.tri.data(), mesh.tri.data(), words);
  s.executor.upload(s.adj.data(), mesh.adj.data(), words);
  s.executor.upload(s.seg.data(), mesh.seg.data(), words);
  s.executor.upload(s.vert_tri.data(), mesh.vert_tri.data(), s.num_vertices);
}

void DeviceMesh::State::allocate(std::uint32_t slots, std::uint32_t nv) {
  detail::require_device_memory(detail::mesh_device_bytes(slots, nv), 0,
                                "a mesh of " + std::to_string(slots) + " triangles");
  num_slots = slots;
  num_vertices = nv;
  const std::size_t words = 3 * static_cast<std::size_t>(slots);
  xy.resize(nv);
  tri.resize(words);
  adj.resize(words);
  seg.resize(words);
  vert_tri.resize(nv);
}

DeviceMesh::DeviceMesh(std::unique_ptr<State> state) : state_(std::move(state)) {}

DeviceMesh::~DeviceMesh() = default;
DeviceMesh::DeviceMesh(DeviceMesh&&) noexcept = default;
DeviceMesh& DeviceMesh::operator=(DeviceMesh&&) noexcept = default;

ShiftStats DeviceMesh::shift(std::uint32_t num_sites, std::span<const double> true_x,
                             std::span<const double> true_y, MissingArray& missing) {
  state_->require_alone("shift");
  if (true_x.size() < num_sites || true_y.size() < num_sites)
    throw Error("internal error: shift_to_true_positions: fewer coordinates than sites");
  detail::DeviceBuffer<double> d_tx(num_sites), d_ty(num_sites);
  state_->executor.upload(d_tx.data(), true_x.data(), num_sites);
  state_->executor.upload(d_ty.data(), true_y.data(), num_sites);
  return detail::shift(*state_, num_sites, d_tx.data(), d_ty.data(), missing);
}

ShiftStats DeviceMesh::shift(std::uint32_t num_sites, const DeviceSites& sites, MissingArray& missing) {
  state_->require_alone("shift");
  const DeviceSites::State& from = sites.state();
  if (from.n < num_sites)
    throw Error("internal error: shift_to_true_positions: fewer coordinates than sites");
  return detail::shift(*state_, num_sites, from.true_x.data(), from.true_y.data(), missing);
}

InsertStats DeviceMesh::insert(std::span<const MissingPoint> missing, const HostParallelFor& parallel) {
  return detail::insert(*state_, missing, parallel);
}

void DeviceMesh::remove_fake_boundary(std::uint32_t first_fake, const RemoveOnHost& remove_on_host) {
  State& s = *state_;
  s.require_alone("remove_fake_boundary");
  if (first_fake > s.num_vertices)
    throw Error("internal error: remove_fake_boundary: first_fake beyond the vertices");
  ::cdt::detail::StepTrace trace("fake boundary");
  detail::remove_fake_fans(s, first_fake, remove_on_host);
  trace.mark("fans removed");
  detail::compact_after_fake_removal(s, first_fake);
  trace.mark("slots compacted");
}

void DeviceMesh::take_missing(DeviceSites& sites) {
  State& s = *state_;
  s.require_alone("take_missing");
  // Both executors queue on the calling thread's stream: insert() reads the list after it is written.
  s.missing_first = std::move(sites.state().missing);
}

void DeviceMesh::take_vertex_ids(DeviceSites& sites) {
  state_->vertex_ids = std::move(sites.state().site_vertex);
}

void DeviceMesh::take_pieces(DeviceSites& sites) {
  state_->ready_pieces = std::move(sites.state().mesh_pieces);
}

using detail::kOutputPartBytes;

namespace {

/// Whether output() sends segment_of_edge (`bytes` bytes, pinned) as pairs: at most two words a piece
/// are not kNoId, and those are few against the array (10^6 segments among 2 10^7 triangles: a tenth).
bool sends_segment_pairs(std::size_t bytes, std::size_t pieces) {
  return 2 * sizeof(std::uint64_t) * pieces <= bytes / 4;
}

/// segment_of_edge's words that are not kNoId, as (word, segment) pairs in pinned staging blocks: for
/// each live slot order[r] and edge i, word 3 r + i.
class SegmentPairs {
public:
  SegmentPairs() = default;
  ~SegmentPairs() {
    for (std::uint64_t* b : blocks_)
      if (b != nullptr) detail::return_staging_block(b);
  }
  SegmentPairs(const SegmentPairs&) = delete;
  SegmentPairs& operator=(const SegmentPairs&) = delete;

  /// Writes each pair's segment into host_segments at its word, spread over `parallel`.
  void scatter(std::uint32_t* host_segments, const HostParallelFor& parallel) const {
    constexpr std::size_t kPerPart = std::size_t{1} << 16;
    const std::size_t parts = (n_ + kPerPart - 1) / kPerPart;
    const auto scatter_part = [&](std::size_t p) {
      const std::size_t end = std::min<std::size_t>(n_, (p + 1) * kPerPart);
      for (std::size_t k = p * kPerPart; k < end; ++k) {
        const std::uint64_t pair = blocks_[k / kPerBlock][k % kPerBlock];
        host_segments[static_cast<std::uint32_t>(pair)] = static_cast<std::uint32_t>(pair >> 32);
      }
    };
    if (parallel) {
      parallel(parts, scatter_part);
    } else {
      for (std::size_t p = 0; p < parts; ++p) scatter_part(p);
    }
  }

  /// Lists the pairs on the device and copies them into the blocks (waits for them).
  void list(detail::CudaExecutor& executor, const ::cdt::detail::MeshView& m, const std::uint32_t* order,
            const std::uint32_t* segment_of_piece, std::size_t words) {
    detail::DeviceBuffer<std::uint32_t> at(words + 1);
    const auto segment = [=] __device__(std::size_t w) {
      const std::uint32_t piece = m.seg[3 * std::size_t{order[w / 3]} + w % 3];
      return piece == kNoId ? kNoId : segment_of_piece[piece];
    };
    n_ = executor.compact(
        words, [=] __device__(std::size_t w) { return segment(w) != kNoId; }, at.data());
    if (n_ == 0) return;
    detail::DeviceBuffer<std::uint64_t> pairs(n_);
    std::uint64_t* pair = pairs.data();
    const std::uint32_t* word = at.data();
    executor.for_each(
        n_, [=] __device__(std::size_t k) { pair[k] = std::uint64_t{segment(word[k])} << 32 | word[k]; },
        "segment_pairs");
    for (std::size_t from = 0; from < n_; from += kPerBlock) {
      blocks_.push_back(nullptr); // room first: a block taken is always held by blocks_
      blocks_.back() = static_cast<std::uint64_t*>(detail::take_staging_block());
      executor.download(blocks_.back(), pair + from, std::min<std::size_t>(kPerBlock, n_ - from));
    }
  }

private:
  static constexpr std::size_t kPerBlock = detail::kStagingBytes / sizeof(std::uint64_t);
  std::uint32_t n_ = 0;
  std::vector<std::uint64_t*> blocks_;
};

} // namespace

namespace {

/// start_early_output's copies go in parts of this many bytes: a download of more than kReplyBytes
/// that the constraints queue meanwhile waits for at most the part on the bus (about 40 microseconds).
constexpr std::size_t kEarlyPartBytes = std::size_t{2} << 20;

std::atomic<std::uint64_t> g_early_rows_sent{0}, g_early_rows_again{0};

} // namespace

EarlyOutputRows early_output_rows() noexcept {
  return EarlyOutputRows{g_early_rows_sent.load(), g_early_rows_again.load()};
}

namespace {

/// vertex_of (output()'s) on the device: the entries the device holds already (take_vertex_ids) and,
/// when it lacks some, all of them in `room`, the rest uploaded.
const std::uint32_t* device_vertex_of(DeviceMesh::State& s, std::span<const std::uint32_t> vertex_of,
                                      detail::DeviceBuffer<std::uint32_t>& room,
                                      const HostParallelFor* parallel = nullptr) {
  const std::size_t known = std::min(s.vertex_ids.size(), vertex_of.size());
  if (known == vertex_of.size()) return s.vertex_ids.data();
  room.resize(vertex_of.size());
  if (known > 0)
    CDT_CUDA_CHECK(cudaMemcpyAsync(room.data(), s.vertex_ids.data(), known * sizeof(std::uint32_t),
                                   cudaMemcpyDeviceToDevice, s.executor.stream()));
  s.executor.upload(room.data() + known, vertex_of.data() + known, vertex_of.size() - known, parallel);
  return room.data();
}

/// DeviceMesh::start_early_output's work; DeviceError when the device's memory runs short meanwhile.
bool start_early(DeviceMesh::State& s, std::span<const std::uint32_t> vertex_of, TriangleArray& triangles,
                 TriangleArray& neighbors) {
  const std::uint32_t slots = s.num_slots;
  const std::size_t bytes = 3 * sizeof(std::uint32_t) * static_cast<std::size_t>(slots);
  if (s.corridor_slots.size() != slots || bytes < kOutputPartBytes || triangles.capacity() < slots ||
      neighbors.capacity() < slots)
    return false;
  auto* host_c = reinterpret_cast<std::uint32_t*>(triangles.data());
  auto* host_nb = reinterpret_cast<std::uint32_t*>(neighbors.data());
  if (!in_result_block(host_c, bytes) || !in_result_block(host_nb, bytes)) return false;
  // The groups and ranks, and the rows of at most every slot, with room for the constraints' buffers
  // (about 64 bytes a slot), which they may not have taken yet.
  detail::require_device_memory((9 + 64) * static_cast<std::size_t>(slots) + 2 * bytes +
                                    (std::size_t{64} << 20),
                                0, "the output started early");
  detail::CudaExecutor& executor = s.executor;
  ::cdt::detail::StepTrace trace("device early output");
  auto out = std::make_unique<detail::EarlyOutput>();
  out->slots = slots;
  out->host_triangles = host_c;
  out->host_neighbors = host_nb;
  out->where = std::move(s.corridor_slots);
  out->rank.resize(static_cast<std::size_t>(slots) + 1);
  const ::cdt::detail::MeshView m = s.view();
  std::uint8_t* where = out->where.data();
  unsigned long long* rank = out->rank.data();
  executor.for_each(
      slots,
      [=] __device__(std::size_t t) {
        // A dead slot (none after the fake boundary's compaction) goes last, and output() then finds
        // fewer live slots than these rows number and sends every row again.
        if (!m.alive(static_cast<std::uint32_t>(t))) where[t] = detail::kInCorridor;
        rank[t] = where[t] == detail::kAwayFromCorridors ? 1ull
                  : where[t] == detail::kNextToCorridor  ? 1ull << 32
                                                         : 0ull;
      },
      "early_groups");
  const unsigned long long total = executor.exclusive_scan(rank, slots);
  const auto away = static_cast<std::uint32_t>(total);
  const std::uint32_t with_corners = away + static_cast<std::uint32_t>(total >> 32);
  if (with_corners < slots / 8) return false; // little to gain: the output as usual
  out->away = away;
  out->with_corners = with_corners;
  out->corners.resize(3 * static_cast<std::size_t>(with_corners));
  out->neighbours.resize(3 * static_cast<std::size_t>(away));
  std::uint32_t* c = out->corners.data();
  std::uint32_t* nb = out->neighbours.data();
  detail::DeviceBuffer<std::uint32_t> ids;
  const std::uint32_t* v_of = device_vertex_of(s, vertex_of, ids);
  const auto known = static_cast<std::uint32_t>(vertex_of.size());
  executor.for_each(
      slots,
      [=] __device__(std::size_t slot) {
        const auto t = static_cast<std::uint32_t>(slot);
        if (where[t] == detail::kInCorridor) return;
        const std::size_t k = detail::early_row(where, rank, away, with_corners, t);
        for (std::uint32_t i = 0; i < 3; ++i) {
          // A vertex without an id here (none so far) makes a row that output() sends again.
          const std::uint32_t v = m.tri[3 * t + i];
          c[3 * k + i] = v < known ? v_of[v] : kNoId;
        }
        if (where[t] != detail::kAwayFromCorridors) return;
        for (std::uint32_t i = 0; i < 3; ++i) {
          const std::uint32_t e = m.adj[3 * t + i];
          nb[3 * k + i] =
              e == kNoId ? kNoId : detail::early_row(where, rank, away, with_corners, edge_tri(e));
        }
      },
      "early_rows");
  out->copies = std::make_unique<detail::PartCopies>(executor.stream());
  out->copies->after_queued_work();
  const std::size_t part_words = std::max<std::size_t>(3, kEarlyPartBytes / sizeof(std::uint32_t) / 3 * 3);
  const std::size_t corner_words = 3 * static_cast<std::size_t>(with_corners);
  const std::size_t neighbour_words = 3 * static_cast<std::size_t>(away);
  for (std::size_t from = 0; from < corner_words; from += part_words) {
    out->copies->copy(host_c + from, c + from,
                      std::min(part_words, corner_words - from) * sizeof(std::uint32_t));
    if (from < neighbour_words)
      out->copies->copy(host_nb + from, nb + from,
                        std::min(part_words, neighbour_words - from) * sizeof(std::uint32_t));
  }
  trace.count("rows away from the corridors", away);
  trace.count("rows next to them", with_corners - away);
  trace.mark("queued");
  s.early = std::move(out);
  return true;
}

} // namespace

bool DeviceMesh::start_early_output(std::span<const std::uint32_t> vertex_of, TriangleArray& triangles,
                                    TriangleArray& neighbors) {
  State& s = *state_;
  s.early.reset();
  try {
    return start_early(s, vertex_of, triangles, neighbors);
  } catch (const DeviceError&) {
    // Short of device memory (the constraints beside it allocate too): the output as usual. Copies
    // already queued were waited for by their owner's destructor.
    s.early.reset();
    s.corridor_slots = {};
    return false;
  }
}

void DeviceMesh::output(std::span<const std::uint32_t> vertex_of,
                        std::span<const std::uint32_t> segment_of_piece, TriangleArray& triangles,
                        TriangleArray& neighbors, TriangleArray& segment_of_edge,
                        const HostParallelFor& parallel) const {
  static_assert(sizeof(std::array<std::uint32_t, 3>) == 3 * sizeof(std::uint32_t));
  State& s = *state_;
  s.require_alone("output");
  detail::CudaExecutor& executor = s.executor;
  ::cdt::detail::StepTrace trace("device output");
  const ::cdt::detail::MeshView m = s.view();
  // The rows started early, if any: their copies write into the arrays until waited for.
  const std::unique_ptr<detail::EarlyOutput> early = std::move(s.early);
  detail::DeviceBuffer<std::uint32_t> live(static_cast<std::size_t>(s.num_slots) + 1);
  const std::uint32_t count = executor.compact(
      s.num_slots, [m] __device__(std::size_t t) { return m.alive(static_cast<std::uint32_t>(t)); },
      live.data());
  const std::size_t words = 3 * static_cast<std::size_t>(count);
  const std::size_t bytes = words * sizeof(std::uint32_t);
  // The early rows stand when every slot is alive (their numbering counts them all) and the arrays
  // keep their memory.
  const bool use_early =
      early != nullptr && count == s.num_slots && early->slots <= count && triangles.capacity() >= count &&
      neighbors.capacity() >= count && static_cast<const void*>(triangles.data()) == early->host_triangles &&
      static_cast<const void*>(neighbors.data()) == early->host_neighbors &&
      in_result_block(early->host_triangles, bytes) && in_result_block(early->host_neighbors, bytes);
  if (early != nullptr && !use_early) early->copies->wait();
  detail::DeviceBuffer<std::uint32_t> index_of_slot(static_cast<std::size_t>(s.num_slots) + 1);
  std::uint32_t* index = index_of_slot.data();
  const std::uint32_t* order = live.data();
  if (use_early) {
    // Every slot is alive: the groups of the early rows (EarlyOutput), each in slot order.
    std::uint32_t* ord = live.data();
    const std::uint8_t* where = early->where.data();
    const unsigned long long* rank = early->rank.data();
    const std::uint32_t away = early->away, with_corners = early->with_corners, first_new = early->slots;
    executor.for_each(
        count,
        [=] __device__(std::size_t slot) {
          const auto t = static_cast<std::uint32_t>(slot);
          const std::uint32_t k = t < first_new ? detail::early_row(where, rank, away, with_corners, t) : t;
          index[t] = k;
          ord[k] = t;
        },
        "index_of_slot");
    early->where = {}; // freed in stream order, after the kernel
    early->rank = {};
  } else {
    executor.fill_bytes(index, 0xFF, s.num_slots);
    executor.for_each(
        count, [=] __device__(std::size_t k) { index[order[k]] = static_cast<std::uint32_t>(k); },
        "index_of_slot");
  }
  detail::DeviceBuffer<std::uint32_t> d_vertex_of;
  detail::DeviceBuffer<std::uint32_t> d_segment_of_piece(segment_of_piece.size() + 1);
  const std::uint32_t* v_of = device_vertex_of(s, vertex_of, d_vertex_of, &parallel);
  executor.upload(d_segment_of_piece.data(), segment_of_piece.data(), segment_of_piece.size(), &parallel);
  detail::DeviceBuffer<std::uint32_t> corners(words + 1);
  detail::DeviceBuffer<std::uint32_t> neighbours(words + 1);
  detail::DeviceBuffer<std::uint32_t> segments(words + 1);
  std::uint32_t* c = corners.data();
  std::uint32_t* nb = neighbours.data();
  std::uint32_t* sg = segments.data();
  const std::uint32_t* s_of = d_segment_of_piece.data();
  const auto make = [&](std::uint32_t from, std::uint32_t to) {
    executor.for_each(
        to - from,
        [=] __device__(std::size_t i) {
          const std::size_t k = from + i;
          ::cdt::detail::output_triangle(m, order[k], v_of, index, s_of, c + 3 * k, nb + 3 * k, sg + 3 * k);
        },
        "output_triangles");
  };
  // Within their room the arrays keep their memory, and their allocator writes nothing into what they
  // gain (DefaultInitAllocator): the early rows stay.
  triangles.resize(count);
  neighbors.resize(count);
  segment_of_edge.resize(count);
  const std::array<std::uint32_t*, 3> host = {reinterpret_cast<std::uint32_t*>(triangles.data()),
                                              reinterpret_cast<std::uint32_t*>(neighbors.data()),
                                              reinterpret_cast<std::uint32_t*>(segment_of_edge.data())};
  const std::array<const std::uint32_t*, 3> device = {c, nb, sg};
  const bool pinned = bytes >= kOutputPartBytes && in_result_block(host[0], bytes) &&
                      in_result_block(host[1], bytes) && in_result_block(host[2], bytes);
  trace.mark("host arrays sized");
  if (!pinned) {
    if (use_early) early->copies->wait();
    make(0, count);
    for (std::size_t a = 0; a < 3; ++a) executor.download(host[a], device[a], words, &parallel);
    trace.mark("made and downloaded");
    return;
  }
  // Into the pinned result memory the device writes directly: the triangles are made in parts, each
  // part's copies queued on a stream of their own as soon as it is made, so that the bus does not wait
  // for the whole output to be made.
  // Of segment_of_edge, when sends_segment_pairs, only the words that are not kNoId come down, as
  // (word, segment) pairs of 8 bytes, and the host fills the array with kNoId while the bus carries
  // the other two arrays (unless prefill_segments did): 16 MB on the bus instead of 240 at 10^7 points
  // and 10^6 segments.
  const bool sparse = sends_segment_pairs(bytes, segment_of_piece.size());
  // The pairs come first: queued behind the other arrays' copies, they would wait for them all.
  std::optional<SegmentPairs> pairs;
  if (sparse) {
    pairs.emplace().list(executor, m, order, s_of, words);
    trace.mark("segment pairs downloaded");
  }
  detail::PartCopies copies(executor.stream());
  const std::uint32_t part =
      static_cast<std::uint32_t>(std::max<std::size_t>(1, kOutputPartBytes / (3 * sizeof(std::uint32_t))));
  // With rows started early, the bus carries the rest first: the corners from with_corners on, the
  // neighbours from away on (and the segments of every row).
  const std::uint32_t away = use_early ? early->away : 0, with_corners = use_early ? early->with_corners : 0;
  const auto send = [&](std::size_t a, std::uint32_t from, std::uint32_t to) {
    if (from < to)
      copies.copy(host[a] + 3 * static_cast<std::size_t>(from),
                  device[a] + 3 * static_cast<std::size_t>(from),
                  3 * static_cast<std::size_t>(to - from) * sizeof(std::uint32_t));
  };
  for (std::uint32_t from = away, to = 0; from < count; from = to) {
    to = from + std::min(part, count - from);
    make(from, to);
    copies.after_queued_work();
    send(0, std::max(from, with_corners), to);
    send(1, from, to);
    if (!sparse) send(2, from, to);
  }
  // The early rows made again, to be compared with what was sent.
  for (std::uint32_t from = 0, to = 0; from < away; from = to) {
    to = from + std::min(part, away - from);
    make(from, to);
    if (!sparse) {
      copies.after_queued_work();
      send(2, from, to);
    }
  }
  // The host writes the segments while the bus carries the rows (the count below crosses the bus too,
  // behind them).
  if (pairs) {
    if (s.prefilled_segments != host[2] || s.prefilled_rows != count)
      detail::fill_host_bytes(host[2], 0xFF, bytes, &parallel);
    pairs->scatter(host[2], parallel);
    trace.mark("segments written on the host");
  }
  if (use_early) {
    // The early rows that changed after all are sent again as records (row, corners, neighbours), or,
    // should there be many, all of them.
    const std::uint32_t* ec = early->corners.data();
    const std::uint32_t* enb = early->neighbours.data();
    detail::DeviceBuffer<std::uint32_t> d_changed(static_cast<std::size_t>(with_corners) + 1);
    const std::uint32_t changed = executor.compact(
        with_corners,
        [=] __device__(std::size_t k) {
          bool same = true;
          for (std::uint32_t i = 0; i < 3; ++i)
            same = same && c[3 * k + i] == ec[3 * k + i] && (k >= away || nb[3 * k + i] == enb[3 * k + i]);
          return !same;
        },
        d_changed.data());
    trace.count("early rows changed", changed);
    g_early_rows_sent += with_corners;
    g_early_rows_again += changed > with_corners / 32 ? with_corners : changed;
    if (changed > with_corners / 32) {
      early->copies->wait();
      copies.after_queued_work();
      for (std::uint32_t from = 0, to = 0; from < with_corners; from = to) {
        to = from + std::min(part, with_corners - from);
        send(0, from, to);
        send(1, from, std::min(to, away));
      }
    } else if (changed > 0) {
      detail::DeviceBuffer<std::uint32_t> d_records(7 * static_cast<std::size_t>(changed));
      std::uint32_t* rec = d_records.data();
      const std::uint32_t* which = d_changed.data();
      executor.for_each(
          changed,
          [=] __device__(std::size_t j) {
            const std::uint32_t k = which[j];
            rec[7 * j] = k;
            for (std::uint32_t i = 0; i < 3; ++i) {
              rec[7 * j + 1 + i] = c[3 * std::size_t{k} + i];
              rec[7 * j + 4 + i] = nb[3 * std::size_t{k} + i];
            }
          },
          "early_rows_again");
      std::vector<std::uint32_t> records(7 * static_cast<std::size_t>(changed));
      executor.download(records.data(), rec, records.size());
      early->copies->wait();
      for (std::size_t j = 0; j < changed; ++j) {
        const std::size_t k = records[7 * j];
        for (std::size_t i = 0; i < 3; ++i) {
          host[0][3 * k + i] = records[7 * j + 1 + i];
          // From `away` on the neighbours are on their way already.
          if (k < away) host[1][3 * k + i] = records[7 * j + 4 + i];
        }
      }
    } else {
      early->copies->wait();
    }
    early->corners = {}; // their copies are done
    early->neighbours = {};
    trace.mark("early rows checked");
  }
  s.prefilled_segments = nullptr; // the array is the output's now
  copies.wait();
  trace.mark("made and downloaded");
}

bool DeviceMesh::prefill_segments(std::size_t pieces, TriangleArray& segment_of_edge,
                                  const HostParallelFor& parallel) {
  State& s = *state_;
  s.prefilled_segments = nullptr;
  const std::uint32_t rows = s.num_slots;
  const std::size_t bytes = 3 * sizeof(std::uint32_t) * static_cast<std::size_t>(rows);
  if (bytes < kOutputPartBytes || !sends_segment_pairs(bytes, pieces)) return false;
  if (segment_of_edge.capacity() < rows) return false; // a new array would not be pinned yet
  segment_of_edge.resize(rows);
  auto* words = reinterpret_cast<std::uint32_t*>(segment_of_edge.data());
  if (!in_result_block(words, bytes)) return false;
  detail::fill_host_bytes(words, 0xFF, bytes, &parallel);
  s.prefilled_segments = words;
  s.prefilled_rows = rows;
  return true;
}

void DeviceMesh::download(::cdt::detail::Mesh& mesh) const {
  State& s = *state_;
  const std::size_t words = 3 * static_cast<std::size_t>(s.num_slots);
  mesh.xy.resize(s.num_vertices);
  mesh.tri.resize(words);
  mesh.adj.resize(words);
  mesh.seg.resize(words);
  mesh.vert_tri.resize(s.num_vertices);
  s.executor.download(mesh.xy.data(), s.xy.data(), s.num_vertices);
  s.executor.download(mesh.tri.data(), s.tri.data(), words);
  s.executor.download(mesh.adj.data(), s.adj.data(), words);
  s.executor.download(mesh.seg.data(), s.seg.data(), words);
  s.executor.download(mesh.vert_tri.data(), s.vert_tri.data(), s.num_vertices);
}

} // namespace cdt::gpu
