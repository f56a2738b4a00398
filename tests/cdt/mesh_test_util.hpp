#pragma once
// Test-only helpers for the gCD mesh phases: an obviously-correct sweep triangulator, a mesh builder for
// hand-made configurations, the structural checker, the exact local Delaunay test and a serial Lawson
// reference. Independent of the code under test except for Mesh itself and link_triangles.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <set>
#include <stdexcept>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "executor/cpu_executor.hpp"
#include "gcd/mesh.hpp"

namespace trixel_test {

using Triangle = std::array<std::uint32_t, 3>;

inline int orient_of(const cdt::detail::Mesh& mesh, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  return cdt::detail::orient2d(mesh.xy[a].x, mesh.xy[a].y, mesh.xy[b].x, mesh.xy[b].y, mesh.xy[c].x,
                               mesh.xy[c].y);
}

/// A mesh of the given counter-clockwise triangles, linked by link_triangles.
inline cdt::detail::Mesh mesh_from_triangles(const std::vector<double>& x, const std::vector<double>& y,
                                             const std::vector<Triangle>& triangles) {
  cdt::detail::Mesh mesh;
  mesh.set_points(x, y);
  for (const Triangle& t : triangles) mesh.add_triangle(t[0], t[1], t[2]);
  cdt::detail::CpuExecutor serial(1);
  cdt::detail::link_triangles(mesh, serial);
  return mesh;
}

/// Triangulates distinct points by a sweep: in lexicographic (x, y) order each point is outside the hull
/// of the points before it, and is joined to every hull edge it sees strictly from outside. Collinear
/// hull vertices stay on the hull. No triangles when all points are collinear.
inline cdt::detail::Mesh sweep_triangulate(const std::vector<double>& x, const std::vector<double>& y) {
  const std::size_t n = x.size();
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t p, std::uint32_t q) { return x[p] < x[q] || (x[p] == x[q] && y[p] < y[q]); });
  const auto orient = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    return cdt::detail::orient2d(x[a], y[a], x[b], y[b], x[c], y[c]);
  };
  std::vector<Triangle> triangles;
  // The first point off the line of the first two: everything before it is a collinear chain.
  std::size_t m = 2;
  while (m < n && orient(order[0], order[1], order[m]) == 0) ++m;
  if (m >= n) return mesh_from_triangles(x, y, {});
  const bool left = orient(order[0], order[1], order[m]) > 0;
  std::vector<std::uint32_t> hull; // counter-clockwise
  for (std::size_t j = 0; j + 1 < m; ++j) {
    if (left) {
      triangles.push_back({order[j], order[j + 1], order[m]});
    } else {
      triangles.push_back({order[j + 1], order[j], order[m]});
    }
  }
  if (left) {
    for (std::size_t j = 0; j < m; ++j) hull.push_back(order[j]);
  } else {
    for (std::size_t j = m; j-- > 0;) hull.push_back(order[j]);
  }
  hull.push_back(order[m]);
  for (std::size_t k = m + 1; k < n; ++k) {
    const std::uint32_t p = order[k];
    const std::size_t h = hull.size();
    std::vector<char> visible(h);
    for (std::size_t i = 0; i < h; ++i) visible[i] = orient(hull[i], hull[(i + 1) % h], p) < 0;
    // The visible edges form one chain (p is outside a convex polygon); find where it starts.
    std::size_t s = 0;
    while (s < h && !(visible[s] && !visible[(s + h - 1) % h])) ++s;
    if (s == h) throw std::logic_error("sweep_triangulate: a point sees no hull edge (duplicate point?)");
    std::size_t e = s;
    while (visible[e % h]) {
      triangles.push_back({hull[(e + 1) % h], hull[e % h], p});
      ++e;
    }
    std::vector<std::uint32_t> next;
    for (std::size_t i = e; i <= s + h; ++i) next.push_back(hull[i % h]);
    next.push_back(p);
    hull.swap(next);
  }
  return mesh_from_triangles(x, y, triangles);
}

/// Live triangles, each rotated to start at its lowest vertex, sorted: equal sets mean equal meshes.
inline std::vector<Triangle> triangle_set(const cdt::detail::Mesh& mesh) {
  std::vector<Triangle> out;
  for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
    if (!mesh.alive(t)) continue;
    Triangle v{mesh.tri[3 * t], mesh.tri[3 * t + 1], mesh.tri[3 * t + 2]};
    std::rotate(v.begin(), std::min_element(v.begin(), v.end()), v.end());
    out.push_back(v);
  }
  std::sort(out.begin(), out.end());
  return out;
}

inline std::uint64_t directed_key(std::uint32_t from, std::uint32_t to) {
  return (std::uint64_t{from} << 32) | to;
}

/// Encoded edge (3t + i) per directed edge (from, to) of the live triangles.
inline std::unordered_map<std::uint64_t, std::uint32_t> directed_edges(const cdt::detail::Mesh& mesh) {
  std::unordered_map<std::uint64_t, std::uint32_t> edges;
  for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
    if (!mesh.alive(t)) continue;
    for (std::uint32_t i = 0; i < 3; ++i) {
      edges[directed_key(mesh.tri[3 * t + cdt::detail::next3(i)], mesh.tri[3 * t + cdt::detail::prev3(i)])] =
          3 * t + i;
    }
  }
  return edges;
}

/// Encoded edge running from a to b or from b to a, kNoId when a-b is not an edge.
inline std::uint32_t find_edge(const cdt::detail::Mesh& mesh, std::uint32_t a, std::uint32_t b) {
  for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
    if (!mesh.alive(t)) continue;
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t p = mesh.tri[3 * t + cdt::detail::next3(i)],
                          q = mesh.tri[3 * t + cdt::detail::prev3(i)];
      if ((p == a && q == b) || (p == b && q == a)) return 3 * t + i;
    }
  }
  return cdt::detail::kNoId;
}

/// Structure of a valid triangulation of a polygonal disc: live triangles counter-clockwise with distinct
/// vertices; each directed edge used once; links symmetric through the encoded edges, joining the same
/// two vertices in opposite directions, with the same constraint id on both sides; vert_tri live and
/// incident for every used vertex, kNoId for unused ones; Euler characteristic V - E + F = 1; every
/// interior vertex's fan turns exactly once around it.
inline void expect_valid_mesh(const cdt::detail::Mesh& mesh) {
  using cdt::detail::kNoId;
  using cdt::detail::next3;
  using cdt::detail::prev3;
  const std::uint32_t nv = mesh.num_vertices();
  ASSERT_EQ(mesh.vert_tri.size(), nv);
  ASSERT_EQ(mesh.adj.size(), mesh.tri.size());
  ASSERT_EQ(mesh.seg.size(), mesh.tri.size());
  std::vector<char> used(nv, 0);
  std::set<std::uint64_t> directed;
  std::uint64_t faces = 0, half_edges = 0, boundary = 0;
  for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
    if (!mesh.alive(t)) continue;
    ++faces;
    const std::uint32_t a = mesh.tri[3 * t], b = mesh.tri[3 * t + 1], c = mesh.tri[3 * t + 2];
    ASSERT_TRUE(a < nv && b < nv && c < nv) << "triangle " << t;
    ASSERT_TRUE(a != b && b != c && a != c) << "triangle " << t;
    ASSERT_GT(orient_of(mesh, a, b, c), 0) << "triangle " << t << " is not counter-clockwise";
    used[a] = used[b] = used[c] = 1;
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t from = mesh.tri[3 * t + next3(i)], to = mesh.tri[3 * t + prev3(i)];
      ASSERT_TRUE(directed.insert(directed_key(from, to)).second) << "directed edge used twice at " << t;
      ++half_edges;
      const std::uint32_t e = mesh.adj[3 * t + i];
      if (e == kNoId) {
        ++boundary;
        continue;
      }
      ASSERT_LT(e / 3, mesh.num_slots());
      ASSERT_TRUE(mesh.alive(e / 3)) << "link to a free slot at " << t;
      ASSERT_EQ(mesh.adj[e], 3 * t + i) << "asymmetric link at triangle " << t << " edge " << i;
      const std::uint32_t u = e / 3, j = e % 3;
      ASSERT_EQ(mesh.tri[3 * u + next3(j)], to) << "link joins different edges at " << t;
      ASSERT_EQ(mesh.tri[3 * u + prev3(j)], from) << "link joins different edges at " << t;
      ASSERT_EQ(mesh.seg[e], mesh.seg[3 * t + i]) << "constraint flag differs across edge at " << t;
    }
  }
  std::uint64_t vertices = 0;
  for (std::uint32_t v = 0; v < nv; ++v) {
    const std::uint32_t t = mesh.vert_tri[v];
    if (!used[v]) {
      EXPECT_EQ(t, kNoId) << "unused vertex " << v;
      continue;
    }
    ++vertices;
    ASSERT_NE(t, kNoId) << "vertex " << v;
    ASSERT_LT(t, mesh.num_slots());
    ASSERT_TRUE(mesh.alive(t)) << "vertex " << v;
    ASSERT_TRUE(mesh.tri[3 * t] == v || mesh.tri[3 * t + 1] == v || mesh.tri[3 * t + 2] == v)
        << "vertex " << v;
  }
  if (faces == 0) return;
  const std::uint64_t edges = (half_edges + boundary) / 2;
  EXPECT_EQ(static_cast<std::int64_t>(vertices) - static_cast<std::int64_t>(edges) +
                static_cast<std::int64_t>(faces),
            1);
  // Winding: at an interior vertex the triangle angles (each below pi) must add up to one full turn.
  for (std::uint32_t v = 0; v < nv; ++v) {
    if (!used[v]) continue;
    const std::uint32_t start = mesh.vert_tri[v];
    std::uint32_t t = start;
    double turn = 0;
    bool closed = false;
    for (std::uint32_t steps = 0; steps <= mesh.num_slots(); ++steps) {
      const std::uint32_t k = mesh.tri[3 * t] == v ? 0 : mesh.tri[3 * t + 1] == v ? 1 : 2;
      const std::uint32_t p = mesh.tri[3 * t + next3(k)], q = mesh.tri[3 * t + prev3(k)];
      const double px = mesh.xy[p].x - mesh.xy[v].x, py = mesh.xy[p].y - mesh.xy[v].y;
      const double qx = mesh.xy[q].x - mesh.xy[v].x, qy = mesh.xy[q].y - mesh.xy[v].y;
      turn += std::atan2(px * qy - py * qx, px * qx + py * qy);
      const std::uint32_t e = mesh.adj[3 * t + next3(k)];
      if (e == kNoId) break;
      t = e / 3;
      if (t == start) {
        closed = true;
        break;
      }
    }
    if (closed) {
      EXPECT_NEAR(turn, 2 * 3.141592653589793, 1e-6) << "fan of vertex " << v;
    }
  }
}

/// Number of non-constraint interior edges whose opposite vertex lies strictly inside the circumcircle
/// (exact incircle); each failing edge counts once per side.
inline std::size_t count_non_delaunay_edges(const cdt::detail::Mesh& mesh) {
  std::size_t bad = 0;
  for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
    if (!mesh.alive(t)) continue;
    const std::uint32_t a = mesh.tri[3 * t], b = mesh.tri[3 * t + 1], c = mesh.tri[3 * t + 2];
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t e = mesh.adj[3 * t + i];
      if (e == cdt::detail::kNoId || mesh.seg[3 * t + i] != cdt::detail::kNoId) continue;
      const std::uint32_t d = mesh.tri[e];
      if (cdt::detail::incircle(mesh.xy[a].x, mesh.xy[a].y, mesh.xy[b].x, mesh.xy[b].y, mesh.xy[c].x,
                                mesh.xy[c].y, mesh.xy[d].x, mesh.xy[d].y) > 0) {
        ++bad;
      }
    }
  }
  return bad;
}

/// Every non-constraint interior edge passes the exact incircle test (constrained Delaunay when some
/// edges carry constraint ids).
inline bool is_locally_delaunay(const cdt::detail::Mesh& mesh) { return count_non_delaunay_edges(mesh) == 0; }

/// Serial Lawson flipping with flip_edge, sweeping over all triangles until a sweep flips nothing; the
/// reference the parallel rounds are compared with. Throws after max_flips flips.
inline std::uint64_t serial_lawson(cdt::detail::Mesh& mesh, std::uint64_t max_flips = 100'000'000) {
  using cdt::detail::kNoId;
  const cdt::detail::MeshView m = mesh.view();
  std::uint64_t flips = 0;
  for (bool changed = true; changed;) {
    changed = false;
    for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
      if (!mesh.alive(t)) continue;
      for (std::uint32_t i = 0; i < 3; ++i) {
        const std::uint32_t e = m.adj[3 * t + i];
        if (e == kNoId || m.seg[3 * t + i] != kNoId) continue;
        const std::uint32_t a = m.tri[3 * t + i], b = m.tri[3 * t + cdt::detail::next3(i)],
                            c = m.tri[3 * t + cdt::detail::prev3(i)], d = m.tri[e];
        if (cdt::detail::incircle(m.xy[a].x, m.xy[a].y, m.xy[b].x, m.xy[b].y, m.xy[c].x, m.xy[c].y, m.xy[d].x,
                                  m.xy[d].y) <= 0)
          continue;
        if (orient_of(mesh, a, b, d) <= 0 || orient_of(mesh, d, c, a) <= 0) continue;
        cdt::detail::flip_edge(m, t, i);
        changed = true;
        if (++flips > max_flips) throw std::runtime_error("serial_lawson: too many flips");
        break; // t changed: its other edges are looked at in the next sweep
      }
    }
  }
  return flips;
}

/// The Delaunay triangulation (serial_lawson of a sweep) of `random` points in the unit square, drawn
/// by unit(), and beside them a k x k lattice over [1.5, 2.5) x [0, 1), column by column: vertices on
/// lines and co-circular quadruples for walks through the mesh.
template <class Unit>
inline cdt::detail::Mesh points_and_lattice_mesh(Unit&& unit, int random, int k) {
  std::vector<double> x, y;
  for (int i = 0; i < random; ++i) {
    x.push_back(unit());
    y.push_back(unit());
  }
  for (int i = 0; i < k; ++i) {
    for (int j = 0; j < k; ++j) {
      x.push_back(1.5 + static_cast<double>(i) / k);
      y.push_back(static_cast<double>(j) / k);
    }
  }
  cdt::detail::Mesh mesh = sweep_triangulate(x, y);
  serial_lawson(mesh);
  return mesh;
}

} // namespace trixel_test
