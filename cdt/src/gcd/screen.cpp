// Screening the input segments against the Delaunay triangulation of the sites (see screen.hpp).

#include "gcd/screen.hpp"

#include <atomic>

#include "executor/cpu_executor.hpp"

namespace cdt::detail {

ScreenedPieces screen_pieces(const MeshView& m, std::span<const ConstraintPiece2> pieces,
                             CpuExecutor& executor) {
  ScreenedPieces out;
  // Per edge side, the piece lying on it. Pieces are distinct vertex pairs, so every entry has one
  // writer.
  std::vector<std::uint32_t> piece_on(3 * static_cast<std::size_t>(m.num_slots), kNoId);
  std::vector<std::uint8_t> suspect(pieces.size(), 0);
  executor.for_each(pieces.size(), [&](std::size_t k) {
    const ConstraintPiece2& p = pieces[k];
    const std::uint32_t edge = find_mesh_edge(m, p.a, p.b);
    if (edge == kNoId) {
      suspect[k] = 1;
      return;
    }
    piece_on[edge] = static_cast<std::uint32_t>(k);
    if (m.adj[edge] != kNoId) piece_on[m.adj[edge]] = static_cast<std::uint32_t>(k);
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
  const auto mark_triangle = [&](std::uint32_t t) {
    for (std::uint32_t i = 0; i < 3; ++i) {
      flag(site[m.v(t, i)]);
      const std::uint32_t q = piece_on[edge_id(t, i)];
      if (q != kNoId) flag(suspect[q]);
    }
  };
  executor.for_each(walkers.size(), [&](std::size_t w) {
    const ConstraintPiece2& p = pieces[walkers[w]];
    const bool walked = walk_corridor(
        m, p.a, p.b, [&](std::uint32_t v) { flag(site[v]); },
        [&](std::uint32_t e) {
          if (piece_on[e] == kNoId) return;
          mark_triangle(edge_tri(e));
          if (m.adj[e] != kNoId) mark_triangle(edge_tri(m.adj[e]));
        });
    if (!walked) failed.store(true, std::memory_order_relaxed);
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
