// The screen of the segments against the Delaunay mesh (cdt/src/gcd/screen.hpp) on a mesh that stays on
// the device: the same passes as the CPU executor's screen_pieces, from the same per-piece code
// (screen_edge, screen_corridor), then the suspects compacted there. Only their indices come back.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "cdt/detail/trace.hpp"
#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"
#include "device_mesh.cuh"
#include "gcd/constraints.hpp"
#include "gcd/screen.hpp"
#include "walk_parts.cuh"

namespace cdt::gpu {

using ::cdt::detail::ConstraintPiece2;
using ::cdt::detail::kNoId;
using ::cdt::detail::MeshView;
using ::cdt::detail::ScreenedPieces;

namespace detail {
namespace {

/// The indices i in [0, n) with flags[i] != 0, increasing, copied to the host.
std::vector<std::uint32_t> flagged(CudaExecutor& executor, const std::uint8_t* flags, std::size_t n) {
  DeviceBuffer<std::uint32_t> d_out(n);
  const std::uint32_t count = executor.compact(
      n, [=] __device__(std::size_t i) { return flags[i] != 0; }, d_out.data());
  std::vector<std::uint32_t> out(count);
  executor.download(out.data(), d_out.data(), count);
  return out;
}

/// Runs walk(k, part) (a corridor's walk, or its part, returning false when it fails) for every piece
/// k < n with wanted(k), the long ones in parts (walk_parts.cuh); failed is set to 1 when a walk fails,
/// again[k] marks the pieces walked whole again after parts out of order. The walks' marks must be
/// such that a walk made twice changes nothing.
template <class Wanted, class Walk>
void walk_corridors(CudaExecutor& executor, const MeshView& m, const WalkHints& hints, WalkParts& buffers,
                    std::uint32_t n, const ConstraintPiece2* pieces, std::uint8_t* again,
                    std::uint32_t* failed, Wanted wanted, Walk walk, const char* name,
                    const char* parts_name) {
  const WalkPartsView parts = plan_walk_parts(
      executor, m, hints, n, [=] __device__(std::size_t k) { return pieces[k]; }, wanted, buffers);
  if (parts.num_long > 0) executor.fill_bytes(again, 0, n);
  executor.for_each(
      n,
      [=] __device__(std::size_t k) {
        if (!wanted(k)) return;
        ::cdt::detail::CorridorPart part;
        part.stop = parts.first_stop_of(k);
        if (!walk(k, part)) atomicExch(failed, 1u);
        if (part.stop != kNoId && !part.met_stop) again[k] = 1;
      },
      name);
  if (parts.num_long == 0) return;
  executor.for_each(
      parts.num_parts,
      [=] __device__(std::size_t u) {
        const PartStart start = parts.part_start[u];
        if (start.tri == kNoId) return;
        const std::uint32_t k = parts.longs[parts.part_of[u]];
        ::cdt::detail::CorridorPart part;
        part.tri = start.tri;
        part.at = start.at;
        part.stop = parts.stop_after(static_cast<std::uint32_t>(u));
        if (!walk(k, part)) atomicExch(failed, 1u);
        if (part.stop != kNoId && !part.met_stop) again[k] = 1;
      },
      parts_name);
  executor.for_each(
      parts.num_long,
      [=] __device__(std::size_t l) {
        const std::uint32_t k = parts.longs[l];
        if (again[k] == 0) return;
        ::cdt::detail::CorridorPart whole;
        if (!walk(k, whole)) atomicExch(failed, 1u);
      },
      "screen_again");
}

} // namespace
} // namespace detail

ScreenedPieces DeviceMesh::screen(std::span<const ConstraintPiece2> host_pieces,
                                  const HostParallelFor& parallel) {
  using detail::DeviceBuffer;
  ScreenedPieces out;
  State& s = *state_;
  s.corridor_slots = {}; // an earlier screen's are stale
  ::cdt::detail::check_constraint_counts(s.num_slots, host_pieces.size());
  const std::size_t np = host_pieces.size();
  if (np == 0) return out;
  detail::CudaExecutor& executor = s.executor;
  const MeshView m = s.view();
  // Traced, each step is waited for.
  ::cdt::detail::StepTrace trace("device screen");
  const auto mark = [&](const char* step) {
    if (::cdt::detail::trace_enabled()) executor.synchronize();
    trace.mark(step);
  };

  // Uploaded and checked already when the constraints run beside the host (on a copy of the links).
  DeviceBuffer<ConstraintPiece2> d_pieces;
  const ConstraintPiece2* pieces = s.pieces_beside(host_pieces);
  if (pieces == nullptr) {
    d_pieces.resize(np);
    executor.upload(d_pieces.data(), host_pieces.data(), np, &parallel);
    detail::check_device_pieces(executor, d_pieces.data(), host_pieces, s.num_vertices);
    pieces = d_pieces.data();
  }
  // Per edge side, the piece lying on it; per piece, whether it is walked, in a crowd, suspect; per slot,
  // the first two pieces through it, whether more pass and whether a far one among them.
  DeviceBuffer<std::uint32_t> d_piece_on(3 * static_cast<std::size_t>(s.num_slots)), d_first(s.num_slots),
      d_second(s.num_slots);
  DeviceBuffer<std::uint8_t> d_walker(np), d_crowded(s.num_slots), d_far_crowd(s.num_slots), d_in_crowd(np),
      d_suspect(np), d_site(s.num_vertices);
  // Two words, read back together: whether a walk failed, and (its first byte) whether the split will
  // change the pieces.
  DeviceBuffer<std::uint32_t> d_failed(2);
  std::uint32_t* piece_on = d_piece_on.data();
  std::uint32_t* first = d_first.data();
  std::uint8_t* walker = d_walker.data();
  std::uint8_t* crowded = d_crowded.data();
  std::uint8_t* far_crowd = d_far_crowd.data();
  std::uint8_t* in_crowd = d_in_crowd.data();
  std::uint8_t* suspect = d_suspect.data();
  std::uint8_t* site = d_site.data();
  std::uint32_t* failed = d_failed.data();
  const ::cdt::detail::ScreenMarks marks{piece_on, first,     d_second.data(),
                                         crowded,  far_crowd, in_crowd,
                                         suspect,  site,      reinterpret_cast<std::uint8_t*>(failed + 1)};
  executor.fill_bytes(piece_on, 0xFF, d_piece_on.size());
  executor.fill_bytes(first, 0xFF, s.num_slots);
  executor.fill_bytes(d_second.data(), 0xFF, s.num_slots);
  executor.fill_bytes(crowded, 0, s.num_slots);
  executor.fill_bytes(far_crowd, 0, s.num_slots);
  executor.fill_bytes(in_crowd, 0, np);
  executor.fill_bytes(suspect, 0, np);
  executor.fill_bytes(site, 0, s.num_vertices);
  executor.fill_bytes(failed, 0, 2);
  executor.for_each(
      np,
      [=] __device__(std::size_t k) {
        const bool edge = ::cdt::detail::screen_edge(m, pieces[k], static_cast<std::uint32_t>(k), piece_on);
        walker[k] = edge ? 0 : 1;
      },
      "screen_edges");
  mark("edges");
  // The walks set bytes of other pieces and sites: several threads may store 1 to the same byte, which
  // is the only value stored.
  // The long pieces are walked in parts (walk_parts.cuh). Their marks are flags and claims: a part
  // walked twice, or a piece walked whole again after parts out of order, changes nothing.
  detail::DeviceBuffer<std::uint32_t> d_hint_cells;
  const detail::WalkHints hints = detail::make_walk_hints(executor, m, d_hint_cells);
  const double far2 = ::cdt::detail::far_piece_length2(hints.width, hints.height, m.num_vertices);
  detail::WalkParts walk_parts;
  DeviceBuffer<std::uint8_t> d_again(np);
  detail::walk_corridors(
      executor, m, hints, walk_parts, static_cast<std::uint32_t>(np), pieces, d_again.data(), failed,
      [=] __device__(std::size_t k) { return walker[k] != 0; },
      [=] __device__(std::size_t k, ::cdt::detail::CorridorPart & part) {
        const auto flag = [](std::uint8_t& f) { f = 1; };
        const auto swap = [](std::uint32_t* word, std::uint32_t expected, std::uint32_t v) {
          return atomicCAS(word, expected, v);
        };
        return ::cdt::detail::screen_corridor(m, pieces[k], static_cast<std::uint32_t>(k), far2, marks, flag,
                                              swap,
                                              part.tri == kNoId && part.stop == kNoId ? nullptr : &part);
      },
      "screen_corridors", "screen_corridor_parts");
  mark("corridors");
  executor.for_each(
      s.num_slots,
      [=] __device__(std::size_t t) {
        const auto flag = [](std::uint8_t& f) { f = 1; };
        ::cdt::detail::screen_settle_triangle(m, pieces, static_cast<std::uint32_t>(t), far2, marks, flag);
      },
      "screen_settle");
  mark("shared triangles");
  // The crowds no far piece passes (screen.hpp): their short members listed by another walk, then every
  // pair tested. A crowded slot's first word is settled: it now holds the crowd's number (still not
  // kNoId, which is all corridor_slots reads).
  DeviceBuffer<std::uint32_t> d_crowds(s.num_slots);
  const std::uint32_t num_crowds = executor.compact(
      s.num_slots, [=] __device__(std::size_t t) { return crowded[t] != 0 && far_crowd[t] == 0; },
      d_crowds.data());
  const std::uint32_t limit = ::cdt::detail::crowd_list_limit(num_crowds, s.num_slots);
  DeviceBuffer<std::uint32_t> d_count(num_crowds), d_members(static_cast<std::size_t>(num_crowds) * limit);
  const std::uint32_t* crowds = d_crowds.data();
  std::uint32_t* crowd_of = first;
  const ::cdt::detail::CrowdLists lists{crowd_of, d_count.data(), d_members.data(), limit};
  if (num_crowds > 0) {
    executor.fill_bytes(d_count.data(), 0, num_crowds);
    executor.for_each(
        num_crowds, [=] __device__(std::size_t c) { crowd_of[crowds[c]] = static_cast<std::uint32_t>(c); },
        "crowd_numbers");
  }
  // Short pieces of far crowds only flag themselves: they walk whether or not a crowd is listed.
  executor.for_each(
      np,
      [=] __device__(std::size_t k) {
        if (in_crowd[k] == 0) return;
        const auto flag = [](std::uint8_t& f) { f = 1; };
        const auto add = [](std::uint32_t* word) { return atomicAdd(word, 1u); };
        if (!::cdt::detail::screen_list_in_crowds(m, pieces[k], static_cast<std::uint32_t>(k), marks, lists,
                                                  flag, add))
          atomicExch(failed, 1u);
      },
      "crowd_lists");
  if (num_crowds > 0) {
    executor.for_each(
        num_crowds,
        [=] __device__(std::size_t c) {
          const auto flag = [](std::uint8_t& f) { f = 1; };
          ::cdt::detail::screen_settle_crowd(m, pieces, static_cast<std::uint32_t>(c), crowds[c], marks,
                                             lists, flag);
        },
        "crowd_settle");
  }
  mark("crowds");
  std::uint32_t words[2] = {0, 0};
  executor.download(words, failed, 2);
  if (words[0] != 0) {
    out.complete = false;
    return out;
  }
  // Where the constraints may change the slots' rows (start_early_output): a piece's flips rewrite only
  // the triangles its corridor crosses, and the links of the triangles next to those.
  if (3 * sizeof(std::uint32_t) * static_cast<std::size_t>(s.num_slots) >= detail::kOutputPartBytes) {
    s.corridor_slots.resize(s.num_slots);
    std::uint8_t* corridor = s.corridor_slots.data();
    executor.for_each(
        s.num_slots,
        [=] __device__(std::size_t t) {
          std::uint8_t where = first[t] != kNoId ? detail::kInCorridor : detail::kAwayFromCorridors;
          for (std::uint32_t i = 0; i < 3 && where == detail::kAwayFromCorridors; ++i) {
            const std::uint32_t e = m.adj[3 * t + i];
            if (e != kNoId && first[::cdt::detail::edge_tri(e)] != kNoId) where = detail::kNextToCorridor;
          }
          corridor[t] = where;
        },
        "corridor_slots");
  }
  executor.for_each(
      np,
      [=] __device__(std::size_t k) {
        if (suspect[k] == 0) return;
        site[pieces[k].a] = 1;
        site[pieces[k].b] = 1;
      },
      "screen_ends");
  out.changes = words[1] != 0;
  out.pieces = detail::flagged(executor, suspect, np);
  if (out.pieces.empty()) return out;
  out.sites = detail::flagged(executor, site, s.num_vertices);
  mark("suspects downloaded");
  return out;
}

} // namespace cdt::gpu
