// Phase 2 of gCD (paper section 3.2): dualize the digital Voronoi diagram, complete the hull with a
// Graham-scan-like pass, enclose everything with a fake boundary of about sqrt(k) points.

#include "gcd/dualize.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"

namespace cdt::detail {
namespace {

using Tri = DualTriangle;

CDT_HD_INLINE int orient(const double* x, const double* y, std::uint32_t a, std::uint32_t b,
                         std::uint32_t c) {
  return orient2d(x[a], y[a], x[b], y[b], x[c], y[c]);
}

/// The fake boundary: a regular polygon of k vertices around `bounds`, its inscribed circle three
/// times as large as the box's circumscribed one, so every site position is strictly inside.
void add_fake_polygon(Mesh& mesh, const Box& bounds, std::uint32_t k) {
  const double cx = 0.5 * (bounds.min_x + bounds.max_x);
  const double cy = 0.5 * (bounds.min_y + bounds.max_y);
  double half_diagonal = 0.5 * std::hypot(bounds.max_x - bounds.min_x, bounds.max_y - bounds.min_y);
  if (!(half_diagonal > 0)) half_diagonal = std::max(1.0, std::abs(cx) + std::abs(cy));
  const double radius = 3.0 * half_diagonal / std::cos(std::numbers::pi / k);
  for (std::uint32_t i = 0; i < k; ++i) {
    const double angle = 2.0 * std::numbers::pi * i / k;
    mesh.x.push_back(cx + radius * std::cos(angle));
    mesh.y.push_back(cy + radius * std::sin(angle));
  }
}

/// Adds outside vertex f to the convex hull `hull` (counter-clockwise), emitting a triangle for every
/// hull edge that f sees strictly from outside.
void add_outside_vertex(std::vector<std::uint32_t>& hull, std::uint32_t f, const double* x, const double* y,
                        std::vector<Tri>& out) {
  const std::size_t k = hull.size();
  std::vector<std::uint8_t> visible(k);
  bool any = false;
  for (std::size_t i = 0; i < k; ++i) {
    visible[i] = orient(x, y, hull[i], hull[(i + 1) % k], f) < 0;
    any = any || visible[i];
  }
  if (!any) throw Error("internal error: fake boundary vertex inside the hull");
  // The visible edges form one cyclic run; find where it starts.
  std::size_t start = 0;
  while (!(visible[start] && !visible[(start + k - 1) % k])) ++start;
  std::vector<std::uint32_t> next;
  next.reserve(k + 1);
  std::size_t i = start;
  while (visible[i % k]) {
    out.push_back({hull[(i + 1) % k], hull[i % k], f});
    ++i;
  }
  // New hull: f, then from the end of the visible run around to its start.
  next.push_back(f);
  for (std::size_t j = i; j <= start + k; ++j) next.push_back(hull[j % k]);
  hull.swap(next);
}

/// The sites' boundary cycle (counter-clockwise), or empty when the boundary is not one simple cycle.
std::vector<std::uint32_t> boundary_cycle(const Mesh& mesh) {
  std::vector<std::uint32_t> next(mesh.num_vertices(), kNoId);
  std::size_t edges = 0;
  std::uint32_t first = kNoId;
  for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
    if (!mesh.alive(t)) continue;
    for (std::uint32_t i = 0; i < 3; ++i) {
      if (mesh.adj[3 * t + i] != kNoId) continue;
      const std::uint32_t from = mesh.tri[3 * t + next3(i)];
      const std::uint32_t to = mesh.tri[3 * t + prev3(i)];
      if (next[from] != kNoId) return {}; // two boundary edges leave one vertex: a pinch
      next[from] = to;
      first = from;
      ++edges;
    }
  }
  std::vector<std::uint32_t> cycle;
  if (first == kNoId) return cycle;
  std::uint32_t v = first;
  do {
    cycle.push_back(v);
    v = next[v];
  } while (v != kNoId && v != first && cycle.size() <= edges);
  if (v != first || cycle.size() != edges) return {};
  return cycle;
}

Mesh fake_polygon_only(std::span<const double> x, std::span<const double> y, const Box& bounds,
                       CpuExecutor& executor, DualizeStats* stats) {
  Mesh mesh;
  mesh.x.assign(x.begin(), x.end());
  mesh.y.assign(y.begin(), y.end());
  const auto n = static_cast<std::uint32_t>(x.size());
  constexpr std::uint32_t k = 8;
  add_fake_polygon(mesh, bounds, k);
  for (std::uint32_t i = 1; i + 1 < k; ++i) mesh.add_triangle(n, n + i, n + i + 1);
  link_triangles(mesh, executor);
  if (stats != nullptr) *stats = DualizeStats{0, 0, k};
  return mesh;
}

} // namespace

void corner_culprits(const std::uint32_t q[4], const double* x, const double* y,
                     std::vector<std::uint32_t>& out) {
  std::uint32_t ring[4];
  int n = 0;
  for (int k = 0; k < 4; ++k) {
    if (q[k] != q[(k + 3) % 4]) ring[n++] = q[k];
  }
  if (n == 3 && orient(x, y, ring[0], ring[1], ring[2]) == 0) {
    const auto key = [&](std::uint32_t v) { return std::pair{x[v], y[v]}; };
    std::uint32_t sorted[3] = {ring[0], ring[1], ring[2]};
    std::sort(sorted, sorted + 3, [&](std::uint32_t a, std::uint32_t b) { return key(a) < key(b); });
    out.push_back(sorted[1]);
    return;
  }
  out.insert(out.end(), ring, ring + n);
}

Mesh dualize(std::span<const std::uint32_t> colour, std::uint32_t m, std::span<const double> x,
             std::span<const double> y, std::span<const std::uint8_t> kept, const Box& bounds,
             CpuExecutor& executor, DualizeStats* stats, std::vector<std::uint32_t>* degenerate) {
  const auto n = static_cast<std::uint32_t>(x.size());
  if (colour.size() != static_cast<std::size_t>(m) * m) throw Error("internal error: colour grid size");

  // Dual triangles, one grid row of corners per task so each task appends to its own list.
  const std::uint32_t rows = m > 1 ? m - 1 : 0;
  std::vector<std::vector<Tri>> per_row(rows);
  std::vector<std::uint8_t> row_invalid(rows, 0);
  std::vector<std::vector<std::uint32_t>> row_culprits(degenerate != nullptr ? rows : 0);
  executor.for_each_part(rows, [&](std::size_t r) {
    const auto gy = static_cast<std::uint32_t>(r);
    auto& list = per_row[r];
    for (std::uint32_t gx = 0; gx + 1 < m; ++gx) {
      std::uint32_t q[4];
      corner_colours(colour.data(), m, gx, gy, q);
      Tri out[2];
      const int count = corner_triangles(q, x.data(), y.data(), out);
      if (count < 0) {
        row_invalid[r] = 1;
        if (degenerate != nullptr) corner_culprits(q, x.data(), y.data(), row_culprits[r]);
        continue;
      }
      for (int k = 0; k < count; ++k) list.push_back(out[k]);
    }
  });
  const bool invalid =
      std::any_of(row_invalid.begin(), row_invalid.end(), [](std::uint8_t v) { return v != 0; });
  // Row lists concatenated by a prefix sum, each row copied into the mesh by its own task.
  std::vector<std::uint32_t> row_start(rows + 1, 0);
  for (std::uint32_t r = 0; r < rows; ++r)
    row_start[r + 1] = row_start[r] + static_cast<std::uint32_t>(per_row[r].size());
  const std::uint32_t num_dual = row_start[rows];
  if (invalid && degenerate != nullptr) {
    degenerate->clear();
    for (const auto& list : row_culprits) degenerate->insert(degenerate->end(), list.begin(), list.end());
    std::sort(degenerate->begin(), degenerate->end());
    degenerate->erase(std::unique(degenerate->begin(), degenerate->end()), degenerate->end());
    return Mesh{};
  }
  if (invalid || num_dual == 0) return fake_polygon_only(x, y, bounds, executor, stats);

  Mesh mesh;
  mesh.x.assign(x.begin(), x.end());
  mesh.y.assign(y.begin(), y.end());
  reserve_mesh_slots(mesh, n);
  mesh.grow_slots(num_dual);
  // Slots ordered by each triangle's lowest vertex (a stable radix sort, the same for any thread
  // count). Sites are numbered along a space-filling curve (triangulate.cpp), so a vertex's fan and its
  // neighbours' coordinates then sit close together in memory, and the later phases, which visit sites
  // in slot order, read them mostly from the cache.
  {
    std::vector<std::uint32_t> key(num_dual);
    std::vector<std::uint32_t> order(num_dual);
    executor.for_each_part(rows, [&](std::size_t r) {
      std::uint32_t k = row_start[r];
      for (const Tri& t : per_row[r]) {
        key[k] = std::min({t.a, t.b, t.c});
        order[k] = k;
        ++k;
      }
    });
    executor.sort_pairs_by_key(key, order, std::bit_width(n));
    // order[k] is the position of the k-th triangle in the rows' concatenation: find its row.
    std::uint32_t* tri = mesh.tri.data();
    executor.for_each(num_dual, [&](std::size_t k) {
      const std::uint32_t at = order[k];
      const auto row = static_cast<std::size_t>(std::upper_bound(row_start.begin(), row_start.end(), at) -
                                                row_start.begin() - 1);
      const Tri& t = per_row[row][at - row_start[row]];
      std::uint32_t* out = tri + 3 * k;
      out[0] = t.a;
      out[1] = t.b;
      out[2] = t.c;
    });
  }
  try {
    link_triangles(mesh, executor);
  } catch (const Error&) {
    return fake_polygon_only(x, y, bounds, executor, stats);
  }
  return complete_dual(std::move(mesh), kept, bounds, executor, stats);
}

void reserve_mesh_slots(Mesh& mesh, std::uint32_t n) {
  const std::size_t room = 3 * (2 * static_cast<std::size_t>(n) +
                                4 * static_cast<std::size_t>(std::sqrt(static_cast<double>(n))) + 64);
  mesh.tri.reserve(room);
  mesh.adj.reserve(room);
  mesh.seg.reserve(room);
}

Mesh complete_dual(Mesh mesh, std::span<const std::uint8_t> kept, const Box& bounds, CpuExecutor& executor,
                   DualizeStats* stats) {
  const std::uint32_t n = mesh.num_vertices();
  const std::uint32_t num_dual = mesh.num_slots();
  std::vector<std::uint32_t> boundary = boundary_cycle(mesh);
  if (boundary.size() < 3) return fake_polygon_only(mesh.x, mesh.y, bounds, executor, stats);

  // Hull completion (Graham-scan-like): start at the lowest-leftmost boundary vertex, which is on the
  // convex hull, and fill every reflex turn with a triangle outside the current mesh.
  const double* px = mesh.x.data();
  const double* py = mesh.y.data();
  const auto lowest =
      std::min_element(boundary.begin(), boundary.end(), [&](std::uint32_t a, std::uint32_t b) {
        return py[a] < py[b] || (py[a] == py[b] && px[a] < px[b]);
      });
  std::rotate(boundary.begin(), lowest, boundary.end());
  std::vector<Tri> added;
  std::vector<std::uint32_t> stack;
  for (std::size_t i = 0; i <= boundary.size(); ++i) {
    const std::uint32_t r = boundary[i % boundary.size()];
    while (stack.size() >= 2 && orient(px, py, stack[stack.size() - 2], stack.back(), r) < 0) {
      added.push_back({stack[stack.size() - 2], r, stack.back()});
      stack.pop_back();
    }
    if (i < boundary.size()) stack.push_back(r);
  }
  std::vector<std::uint32_t> hull = stack;
  const auto hull_triangles = added.size();

  // Fake boundary: about sqrt(k) vertices (k = hull size), as the paper suggests, at least 8.
  const auto k_fake = std::max<std::uint32_t>(
      8, static_cast<std::uint32_t>(std::ceil(std::sqrt(static_cast<double>(hull.size())))));
  add_fake_polygon(mesh, bounds, k_fake);
  px = mesh.x.data();
  py = mesh.y.data();
  for (std::uint32_t f = n; f < n + k_fake; ++f) add_outside_vertex(hull, f, px, py, added);
  const std::uint32_t first_added = mesh.num_slots();
  for (const Tri& t : added) mesh.add_triangle(t.a, t.b, t.c);
  link_new_triangles(mesh, first_added, executor);
  for (std::uint32_t v = 0; v < n; ++v) {
    if (kept[v] == 0 && mesh.vert_tri[v] != kNoId) throw Error("internal error: a missing site was dualized");
  }
  if (stats != nullptr) *stats = DualizeStats{num_dual, hull_triangles, k_fake};
  return mesh;
}

} // namespace cdt::detail
