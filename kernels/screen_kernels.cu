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

} // namespace
} // namespace detail

ScreenedPieces DeviceMesh::screen(std::span<const ConstraintPiece2> host_pieces,
                                  const HostParallelFor& parallel) {
  using detail::DeviceBuffer;
  ScreenedPieces out;
  State& s = *state_;
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

  DeviceBuffer<ConstraintPiece2> d_pieces(np);
  executor.upload(d_pieces.data(), host_pieces.data(), np, &parallel);
  detail::check_device_pieces(executor, d_pieces.data(), host_pieces, s.num_vertices);
  const ConstraintPiece2* pieces = d_pieces.data();
  // Per edge side, the piece lying on it; per piece, whether it is walked, whether it shares a triangle
  // and whether it is suspect; per slot, the lowest and the highest walker through it.
  DeviceBuffer<std::uint32_t> d_piece_on(3 * static_cast<std::size_t>(s.num_slots)), d_low(s.num_slots),
      d_high(s.num_slots);
  DeviceBuffer<std::uint8_t> d_walker(np), d_shared(np), d_suspect(np), d_site(s.num_vertices);
  DeviceBuffer<std::uint32_t> d_failed(1);
  std::uint32_t* piece_on = d_piece_on.data();
  std::uint32_t* low = d_low.data();
  std::uint32_t* high = d_high.data();
  std::uint8_t* walker = d_walker.data();
  std::uint8_t* shared = d_shared.data();
  std::uint8_t* suspect = d_suspect.data();
  std::uint8_t* site = d_site.data();
  std::uint32_t* failed = d_failed.data();
  executor.fill_bytes(piece_on, 0xFF, d_piece_on.size());
  executor.fill_bytes(low, 0xFF, s.num_slots);
  executor.fill_bytes(high, 0, s.num_slots);
  executor.fill_bytes(shared, 0, np);
  executor.fill_bytes(suspect, 0, np);
  executor.fill_bytes(site, 0, s.num_vertices);
  executor.fill_bytes(failed, 0, 1);
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
  executor.for_each(
      np,
      [=] __device__(std::size_t k) {
        if (walker[k] == 0) return;
        const auto flag = [](std::uint8_t& f) { f = 1; };
        const auto lower = [](std::uint32_t* word, std::uint32_t v) { return detail::atomic_min(word, v); };
        const auto raise = [](std::uint32_t* word, std::uint32_t v) { return atomicMax(word, v); };
        if (!::cdt::detail::screen_corridor(m, pieces[k], static_cast<std::uint32_t>(k), piece_on, low, high,
                                            shared, suspect, site, flag, lower, raise))
          atomicExch(failed, 1u);
      },
      "screen_corridors");
  mark("corridors");
  executor.for_each(
      np,
      [=] __device__(std::size_t k) {
        if (shared[k] == 0) return;
        const auto flag = [](std::uint8_t& f) { f = 1; };
        if (!::cdt::detail::screen_shared_triangles(m, pieces, static_cast<std::uint32_t>(k), piece_on, low,
                                                    high, suspect, site, flag))
          atomicExch(failed, 1u);
      },
      "screen_shared");
  mark("shared triangles");
  std::uint32_t walk_failed = 0;
  executor.download(&walk_failed, failed, 1);
  if (walk_failed != 0) {
    out.complete = false;
    return out;
  }
  executor.for_each(
      np,
      [=] __device__(std::size_t k) {
        if (suspect[k] == 0) return;
        site[pieces[k].a] = 1;
        site[pieces[k].b] = 1;
      },
      "screen_ends");
  out.pieces = detail::flagged(executor, suspect, np);
  if (out.pieces.empty()) return out;
  out.sites = detail::flagged(executor, site, s.num_vertices);
  mark("suspects downloaded");
  return out;
}

} // namespace cdt::gpu
