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

  // Each triangle rotated to start at its lowest vertex (edge i is opposite corner i, so its neighbour
  // and segment turn with it).
  for (std::size_t k = 0; k < num_triangles; ++k) {
    auto& tri = t.triangles[k];
    const int r = tri[1] < tri[0] && tri[1] < tri[2] ? 1 : tri[2] < tri[0] && tri[2] < tri[1] ? 2 : 0;
    if (r == 0) continue;
    std::rotate(tri.begin(), tri.begin() + r, tri.end());
    std::rotate(t.neighbors[k].begin(), t.neighbors[k].begin() + r, t.neighbors[k].end());
    std::rotate(t.segment_of_edge[k].begin(), t.segment_of_edge[k].begin() + r, t.segment_of_edge[k].end());
  }

  // Counting sort by the first vertex; a vertex is the lowest corner of few triangles, whose order by
  // the other two is settled by insertion sort.
  std::vector<std::uint32_t> start(num_vertices + 1, 0);
  for (const auto& tri : t.triangles) ++start[tri[0] + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<std::uint32_t> order(num_triangles);
  {
    std::vector<std::uint32_t> next(start.begin(), start.end() - 1);
    for (std::size_t k = 0; k < num_triangles; ++k)
      order[next[t.triangles[k][0]]++] = static_cast<std::uint32_t>(k);
  }
  const auto before = [&](std::uint32_t a, std::uint32_t b) {
    const auto& p = t.triangles[a];
    const auto& q = t.triangles[b];
    return p[1] < q[1] || (p[1] == q[1] && p[2] < q[2]);
  };
  for (std::size_t v = 0; v < num_vertices; ++v) {
    const auto first = order.begin() + start[v];
    const auto last = order.begin() + start[v + 1];
    for (auto i = first + (first == last ? 0 : 1); i < last; ++i)
      for (auto j = i; j != first && before(*j, *(j - 1)); --j) std::iter_swap(j, j - 1);
  }

  std::vector<std::uint32_t> position(num_triangles);
  for (std::size_t k = 0; k < num_triangles; ++k) position[order[k]] = static_cast<std::uint32_t>(k);
  TriangleArray triangles(num_triangles);
  TriangleArray neighbors(num_triangles);
  TriangleArray segments(num_triangles);
  for (std::size_t k = 0; k < num_triangles; ++k) {
    const std::uint32_t from = order[k];
    triangles[k] = t.triangles[from];
    segments[k] = t.segment_of_edge[from];
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t u = t.neighbors[from][i];
      neighbors[k][i] = u == kNone ? kNone : position[u];
    }
  }
  t.triangles = std::move(triangles);
  t.neighbors = std::move(neighbors);
  t.segment_of_edge = std::move(segments);
}

} // namespace cdt
