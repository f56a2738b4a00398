// Screening the input segments against the Delaunay triangulation of the sites (see screen.hpp).

#include "gcd/screen.hpp"

#include <atomic>

#include "box.hpp"
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
  // the triangles they claim; then each triangle that two or more claimed is settled.
  std::vector<std::uint8_t> suspect(pieces.size(), 0), site(m.num_vertices, 0), crowded(m.num_slots, 0),
      far_crowd(m.num_slots, 0), in_crowd(pieces.size(), 0);
  std::vector<std::uint32_t> first(m.num_slots, kNoId), second(m.num_slots, kNoId);
  std::atomic<bool> failed{false};
  std::uint8_t changes = 0;
  const ScreenMarks marks{piece_on.data(), first.data(),   second.data(), crowded.data(), far_crowd.data(),
                          in_crowd.data(), suspect.data(), site.data(),   &changes};
  const auto flag = [](std::uint8_t& f) {
    std::atomic_ref<std::uint8_t>(f).store(1, std::memory_order_relaxed);
  };
  const auto swap = [](std::uint32_t* word, std::uint32_t expected, std::uint32_t k) {
    std::atomic_ref<std::uint32_t>(*word).compare_exchange_strong(expected, k, std::memory_order_relaxed);
    return expected; // the word's old value, whether or not it was swapped
  };
  // The vertices' box, for which pieces are far.
  const Box box = m.num_vertices == 0
                      ? Box{}
                      : box_of_points(
                            m.num_vertices, [&](std::size_t v) -> const Vec2& { return m.xy[v]; }, executor);
  const double far2 = far_piece_length2(box.max_x - box.min_x, box.max_y - box.min_y, m.num_vertices);
  executor.for_each(walkers.size(), [&](std::size_t w) {
    const std::uint32_t k = walkers[w];
    if (!screen_corridor(m, pieces[k], k, far2, marks, flag, swap))
      failed.store(true, std::memory_order_relaxed);
  });
  if (failed.load()) {
    out.complete = false;
    return out;
  }
  executor.for_each(m.num_slots, [&](std::size_t t) {
    screen_settle_triangle(m, pieces.data(), static_cast<std::uint32_t>(t), far2, marks, flag);
  });
  // The crowds no far piece passes: their short members listed by another walk, then every pair tested.
  const std::vector<std::uint32_t> listed =
      executor.compact(pieces.size(), [&](std::size_t k) { return in_crowd[k] != 0; });
  if (!listed.empty()) {
    const std::vector<std::uint32_t> crowds =
        executor.compact(m.num_slots, [&](std::size_t t) { return crowded[t] != 0 && far_crowd[t] == 0; });
    // A crowded slot's first word is settled: it now holds the crowd's number.
    std::uint32_t* crowd_of = first.data();
    executor.for_each(crowds.size(),
                      [&](std::size_t c) { crowd_of[crowds[c]] = static_cast<std::uint32_t>(c); });
    const std::uint32_t limit = crowd_list_limit(crowds.size(), m.num_slots);
    std::vector<std::uint32_t> count(crowds.size(), 0), members(crowds.size() * limit);
    const CrowdLists lists{crowd_of, count.data(), members.data(), limit};
    const auto add = [](std::uint32_t* word) {
      return std::atomic_ref<std::uint32_t>(*word).fetch_add(1, std::memory_order_relaxed);
    };
    executor.for_each(listed.size(), [&](std::size_t w) {
      const std::uint32_t k = listed[w];
      if (!screen_list_in_crowds(m, pieces[k], k, marks, lists, flag, add))
        failed.store(true, std::memory_order_relaxed);
    });
    if (failed.load()) {
      out.complete = false;
      return out;
    }
    executor.for_each(crowds.size(), [&](std::size_t c) {
      screen_settle_crowd(m, pieces.data(), static_cast<std::uint32_t>(c), crowds[c], marks, lists, flag);
    });
  }
  out.changes = changes != 0;
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
