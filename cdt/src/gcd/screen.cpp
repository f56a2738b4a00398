// Screening the input segments against the Delaunay triangulation of the sites (see screen.hpp).

#include "gcd/screen.hpp"

#include <atomic>

#include "executor/cpu_executor.hpp"

namespace cdt::detail {

ScreenedPieces screen_pieces(const MeshView& m, std::span<const ConstraintPiece2> pieces,
                             CpuExecutor& executor) {
  ScreenedPieces out;
  // Per edge side, the piece lying on it.
  std::vector<std::uint32_t> piece_on(3 * static_cast<std::size_t>(m.num_slots), kNoId);
  std::vector<std::uint8_t> suspect(pieces.size(), 0);
  executor.for_each(pieces.size(), [&](std::size_t k) {
    if (!screen_edge(m, pieces[k], static_cast<std::uint32_t>(k), piece_on.data())) suspect[k] = 1;
  });
  const std::vector<std::uint32_t> walkers =
      executor.compact(pieces.size(), [&](std::size_t k) { return suspect[k] != 0; });
  if (walkers.empty()) return out;

  // The pieces that are no edges: the sites on them and the pieces they cross become suspect, and
  // around each such crossing the two triangles at the crossed edge.
  std::vector<std::uint8_t> site(m.num_vertices, 0);
  std::atomic<bool> failed{false};
  const auto flag = [](std::uint8_t& f) {
    std::atomic_ref<std::uint8_t>(f).store(1, std::memory_order_relaxed);
  };
  executor.for_each(walkers.size(), [&](std::size_t w) {
    if (!screen_corridor(m, pieces[walkers[w]], piece_on.data(), suspect.data(), site.data(), flag))
      failed.store(true, std::memory_order_relaxed);
  });
  if (failed.load()) {
    out.complete = false;
    return out;
  }
  out.pieces = executor.compact(pieces.size(), [&](std::size_t k) { return suspect[k] != 0; });
  out.sites = executor.compact(m.num_vertices, [&](std::size_t v) { return site[v] != 0; });
  return out;
}

} // namespace cdt::detail
