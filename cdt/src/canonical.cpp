// canonicalize(): one order for a triangle set, whatever backend or schedule listed it.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <vector>

#include "cdt/cdt.hpp"

namespace cdt {

void canonicalize(Triangulation& t) {
  const std::size_t num_vertices = t.vertices.size();
  const std::size_t num_triangles = t.triangles.size();
  const std::size_t first_added = std::min(t.duplicate_of.size(), num_vertices);

  // Added vertices in lexicographic order of their coordinates (they are distinct points).
  if (first_added < num_vertices) {
    std::vector<std::uint32_t> order(num_vertices - first_added);
    std::iota(order.begin(), order.end(), static_cast<std::uint32_t>(first_added));
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
      const Point& p = t.vertices[a];
      const Point& q = t.vertices[b];
      return p.x < q.x || (p.x == q.x && p.y < q.y);
    });
    std::vector<std::uint32_t> renumbered(num_vertices);
    std::iota(renumbered.begin(), renumbered.begin() + static_cast<std::ptrdiff_t>(first_added), 0u);
    PointArray vertices(t.vertices.begin(), t.vertices.end());
    for (std::size_t k = 0; k < order.size(); ++k) {
      renumbered[order[k]] = static_cast<std::uint32_t>(first_added + k);
      vertices[first_added + k] = t.vertices[order[k]];
    }
    t.vertices = std::move(vertices);
    for (auto& tri : t.triangles)
      for (std::uint32_t& v : tri) v = renumbered[v];
  }

  // Each triangle turned to start at its lowest vertex (edge i is opposite corner i, so its neighbour
  // and segment turn with it); counted by that vertex.
  std::vector<std::uint8_t> turn(num_triangles);
  std::vector<std::uint32_t> start(num_vertices + 1, 0);
  for (std::size_t k = 0; k < num_triangles; ++k) {
    const auto& tri = t.triangles[k];
    const int r = tri[1] < tri[0] ? (tri[2] < tri[1] ? 2 : 1) : (tri[2] < tri[0] ? 2 : 0);
    turn[k] = static_cast<std::uint8_t>(r);
    ++start[tri[r] + 1];
  }
  std::partial_sum(start.begin(), start.end(), start.begin());
  // Counting sort by the lowest vertex; a vertex is the lowest corner of few triangles, whose order by
  // the other two is settled by insertion sort.
  constexpr int kAfter[5] = {0, 1, 2, 0, 1}; // kAfter[r + i] = (r + i) % 3
  const auto corner = [&](std::uint32_t k, int i) { return t.triangles[k][kAfter[turn[k] + i]]; };
  std::vector<std::uint32_t> order(num_triangles);
  for (std::size_t k = 0; k < num_triangles; ++k)
    order[start[corner(static_cast<std::uint32_t>(k), 0)]++] = static_cast<std::uint32_t>(k);
  // start[v] is now where vertex v's triangles end.
  const auto before = [&](std::uint32_t a, std::uint32_t b) {
    const std::uint32_t a1 = corner(a, 1), b1 = corner(b, 1);
    return a1 < b1 || (a1 == b1 && corner(a, 2) < corner(b, 2));
  };
  std::uint32_t bucket_begin = 0;
  for (std::size_t v = 0; v < num_vertices; ++v) {
    const std::uint32_t bucket_end = start[v];
    for (std::uint32_t i = bucket_begin + 1; i < bucket_end; ++i)
      for (std::uint32_t j = i; j > bucket_begin && before(order[j], order[j - 1]); --j)
        std::swap(order[j], order[j - 1]);
    bucket_begin = bucket_end;
  }

  std::vector<std::uint32_t> position(num_triangles);
  for (std::size_t k = 0; k < num_triangles; ++k) position[order[k]] = static_cast<std::uint32_t>(k);
  TriangleArray triangles(num_triangles);
  TriangleArray neighbors(num_triangles);
  TriangleArray segments(num_triangles);
  for (std::size_t k = 0; k < num_triangles; ++k) {
    const std::uint32_t from = order[k];
    const int r = turn[from];
    for (int i = 0; i < 3; ++i) {
      const int e = kAfter[r + i];
      triangles[k][i] = t.triangles[from][e];
      segments[k][i] = t.segment_of_edge[from][e];
      const std::uint32_t u = t.neighbors[from][e];
      neighbors[k][i] = u == kNone ? kNone : position[u];
    }
  }
  t.triangles = std::move(triangles);
  t.neighbors = std::move(neighbors);
  t.segment_of_edge = std::move(segments);
}

} // namespace cdt
