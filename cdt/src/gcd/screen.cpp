// Screening the input segments against the Delaunay triangulation of the sites (see screen.hpp).

#include "gcd/screen.hpp"

#include <atomic>

#include "executor/cpu_executor.hpp"

namespace cdt::detail {

ScreenedPieces screen_pieces(const MeshView& m, std::span<const ConstraintPiece2> pieces,
                             CpuExecutor& executor) {
  ScreenedPieces out;
  // Per edge side, the piece lying on it; per piece, whether it is walked.
  std::vector<std::uint32_t> piece_on(3 * static_cast<std::size_t>(m.num_slots), kNoId);
  std::vector<std::uint8_t> walker(pieces.size(), 0);
  executor.for_each(pieces.size(), [&](std::size_t k) {
    if (!screen_edge(m, pieces[k], static_cast<std::uint32_t>(k), piece_on.data())) walker[k] = 1;
  });
  const std::vector<std::uint32_t> walkers =
      executor.compact(pieces.size(), [&](std::size_t k) { return walker[k] != 0; });
  if (walkers.empty()) return out;

  // The pieces that are no edges walk their corridors: the sites on them, the edge-pieces they cross,
  // the triangles they share; then those that share one settle it.
  std::vector<std::uint8_t> suspect(pieces.size(), 0), shared(pieces.size(), 0), site(m.num_vertices, 0);
  std::vector<std::uint32_t> low(m.num_slots, kNoId), high(m.num_slots, 0);
  std::atomic<bool> failed{false};
  const auto flag = [](std::uint8_t& f) {
    std::atomic_ref<std::uint8_t>(f).store(1, std::memory_order_relaxed);
  };
  const auto lower = [](std::uint32_t* word, std::uint32_t k) { return atomic_min(word, k); };
  const auto raise = [](std::uint32_t* word, std::uint32_t k) { return atomic_max(word, k); };
  executor.for_each(walkers.size(), [&](std::size_t w) {
    const std::uint32_t k = walkers[w];
    if (!screen_corridor(m, pieces[k], k, piece_on.data(), low.data(), high.data(), shared.data(),
                         suspect.data(), site.data(), flag, lower, raise))
      failed.store(true, std::memory_order_relaxed);
  });
  if (failed.load()) {
    out.complete = false;
    return out;
  }
  const std::vector<std::uint32_t> sharers =
      executor.compact(pieces.size(), [&](std::size_t k) { return shared[k] != 0; });
  executor.for_each(sharers.size(), [&](std::size_t w) {
    if (!screen_shared_triangles(m, pieces.data(), sharers[w], piece_on.data(), low.data(), high.data(),
                                 suspect.data(), site.data(), flag))
      failed.store(true, std::memory_order_relaxed);
  });
  if (failed.load()) {
    out.complete = false;
    return out;
  }
  // Every suspect's ends are suspect sites.
  executor.for_each(pieces.size(), [&](std::size_t k) {
    if (suspect[k] == 0) return;
    flag(site[pieces[k].a]);
    flag(site[pieces[k].b]);
  });
  out.pieces = executor.compact(pieces.size(), [&](std::size_t k) { return suspect[k] != 0; });
  out.sites = executor.compact(m.num_vertices, [&](std::size_t v) { return site[v] != 0; });
  return out;
}

} // namespace cdt::detail
