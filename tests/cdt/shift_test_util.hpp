#pragma once
// Test fixtures for Phases 3 and 4 (paper sections 3.3-3.4), independent of Phases 1 and 2: a plain sweep
// triangulator stands in for the dualized digital Voronoi diagram, and an independent checker verifies the
// triangulation after each phase. Test-only code: obviously correct before fast.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "executor/cpu_executor.hpp"
#include "gcd/flip.hpp"
#include "gcd/insert.hpp"
#include "gcd/mesh.hpp"
#include "gcd/shift.hpp"

namespace shift_test {

using cdt::detail::kNoId;
using cdt::detail::orient2d;

/// CCW triangles (vertex ids, 3 per triangle) of the convex hull of the points `ids` (distinct coordinates),
/// by a left-to-right sweep: each new point, lexicographically the largest so far, is outside the current
/// hull and is joined to every hull edge it sees strictly. Empty when all points are collinear.
inline std::vector<std::uint32_t> sweep_triangulate(const std::vector<double>& x,
                                                    const std::vector<double>& y,
                                                    std::vector<std::uint32_t> ids) {
  std::sort(ids.begin(), ids.end(),
            [&](std::uint32_t a, std::uint32_t b) { return x[a] < x[b] || (x[a] == x[b] && y[a] < y[b]); });
  std::vector<std::uint32_t> tris;
  const std::size_t n = ids.size();
  if (n < 3) return tris;
  auto orient = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    return orient2d(x[a], y[a], x[b], y[b], x[c], y[c]);
  };
  std::size_t j = 2;
  while (j < n && orient(ids[0], ids[1], ids[j]) == 0) ++j;
  if (j == n) return tris;
  const int side = orient(ids[0], ids[1], ids[j]);
  // The hull as a circular doubly linked list indexed by vertex id.
  std::map<std::uint32_t, std::uint32_t> next_of, prev_of;
  auto link = [&](std::uint32_t a, std::uint32_t b) {
    next_of[a] = b;
    prev_of[b] = a;
  };
  for (std::size_t i = 0; i + 1 < j; ++i) {
    if (side > 0)
      tris.insert(tris.end(), {ids[i], ids[i + 1], ids[j]});
    else
      tris.insert(tris.end(), {ids[i + 1], ids[i], ids[j]});
  }
  if (side > 0) {
    for (std::size_t i = 0; i + 1 < j; ++i) link(ids[i], ids[i + 1]);
    link(ids[j - 1], ids[j]);
    link(ids[j], ids[0]);
  } else {
    link(ids[0], ids[j]);
    link(ids[j], ids[j - 1]);
    for (std::size_t i = j - 1; i > 0; --i) link(ids[i], ids[i - 1]);
  }
  std::uint32_t last = ids[j];
  for (std::size_t k = j + 1; k < n; ++k) {
    const std::uint32_t q = ids[k];
    std::uint32_t right = last;
    while (orient(right, next_of[right], q) < 0) {
      tris.insert(tris.end(), {right, q, next_of[right]});
      right = next_of[right];
    }
    std::uint32_t left = last;
    while (orient(prev_of[left], left, q) < 0) {
      tris.insert(tris.end(), {prev_of[left], q, left});
      left = prev_of[left];
    }
    if (left == last && right == last) return {}; // cannot happen for a lexicographic maximum; fail loudly
    link(left, q);
    link(q, right);
    last = q;
  }
  return tris;
}

/// Lawson flips to a Delaunay triangulation (strict incircle, so co-circular lattices terminate).
inline void lawson_flip(cdt::detail::Mesh& mesh) {
  using namespace cdt::detail;
  MeshView m = mesh.view();
  std::vector<std::uint32_t> stack;
  for (std::uint32_t e = 0; e < 3 * m.num_slots; ++e) stack.push_back(e);
  while (!stack.empty()) {
    const std::uint32_t e = stack.back();
    stack.pop_back();
    const std::uint32_t t = edge_tri(e), i = edge_index(e);
    const std::uint32_t f = m.adj[e];
    if (!m.alive(t) || f == kNoId) continue;
    const std::uint32_t a = m.v(t, i), b = m.v(t, next3(i)), c = m.v(t, prev3(i));
    const std::uint32_t u = edge_tri(f), d = m.v(u, edge_index(f));
    if (incircle(m.xy[a].x, m.xy[a].y, m.xy[b].x, m.xy[b].y, m.xy[c].x, m.xy[c].y, m.xy[d].x, m.xy[d].y) <= 0)
      continue;
    if (orient2d(m.xy[a].x, m.xy[a].y, m.xy[b].x, m.xy[b].y, m.xy[d].x, m.xy[d].y) <= 0) continue;
    if (orient2d(m.xy[d].x, m.xy[d].y, m.xy[c].x, m.xy[c].y, m.xy[a].x, m.xy[a].y) <= 0) continue;
    flip_edge(m, t, i);
    for (std::uint32_t k = 0; k < 3; ++k) {
      stack.push_back(edge_id(t, k));
      stack.push_back(edge_id(u, k));
    }
  }
}

/// Input of Phases 3-4 as Phase 2 would hand it over.
struct Fixture {
  cdt::detail::Mesh mesh;
  std::uint32_t num_sites = 0;
  std::vector<double> true_x, true_y;
  cdt::detail::MissingArray missing; ///< sites sharing a grid cell with a kept site
};

struct FixtureOptions {
  double cell = 1.0;       ///< grid spacing (a power of two, so snapping is exact)
  std::uint32_t fakes = 8; ///< fake boundary vertices
  bool delaunay = true;    ///< Lawson-flip the initial triangulation (closer to Phase 2's output)
};

/// Snaps the sites to the grid (x' = floor(x / cell) * cell), keeps the lowest index per cell (the others
/// become missing points hinted at it), adds a fake boundary polygon far outside, triangulates the snapped
/// kept sites plus the fake vertices and links the mesh.
inline Fixture make_fixture(std::vector<double> tx, std::vector<double> ty, FixtureOptions opt = {}) {
  using namespace cdt::detail;
  Fixture f;
  const auto n = static_cast<std::uint32_t>(tx.size());
  f.num_sites = n;
  f.true_x = std::move(tx);
  f.true_y = std::move(ty);
  Mesh& mesh = f.mesh;
  mesh.xy.resize(n);
  std::map<std::pair<double, double>, std::uint32_t> kept;
  std::vector<std::uint32_t> ids;
  double lo_x = f.true_x[0], hi_x = lo_x, lo_y = f.true_y[0], hi_y = lo_y;
  for (std::uint32_t v = 0; v < n; ++v) {
    mesh.xy[v].x = std::floor(f.true_x[v] / opt.cell) * opt.cell;
    mesh.xy[v].y = std::floor(f.true_y[v] / opt.cell) * opt.cell;
    lo_x = std::min(lo_x, f.true_x[v]);
    hi_x = std::max(hi_x, f.true_x[v]);
    lo_y = std::min(lo_y, f.true_y[v]);
    hi_y = std::max(hi_y, f.true_y[v]);
    const auto [it, fresh] = kept.emplace(std::make_pair(mesh.xy[v].x, mesh.xy[v].y), v);
    if (fresh)
      ids.push_back(v);
    else
      f.missing.push_back(MissingPoint{v, it->second});
  }
  // A regular polygon around the bounding box, far enough that every site is strictly inside.
  const double cx = std::floor((lo_x + hi_x) / 2), cy = std::floor((lo_y + hi_y) / 2);
  const double radius = 4 * std::max({hi_x - lo_x, hi_y - lo_y, 1.0}) + 16 * opt.cell;
  for (std::uint32_t k = 0; k < opt.fakes; ++k) {
    const double angle = 2 * std::numbers::pi * (k + 0.5) / opt.fakes;
    mesh.xy.push_back({std::round(cx + radius * std::cos(angle)), std::round(cy + radius * std::sin(angle))});
    ids.push_back(n + k);
  }
  std::vector<double> grid_x, grid_y;
  for (const Vec2& p : mesh.xy) {
    grid_x.push_back(p.x);
    grid_y.push_back(p.y);
  }
  const std::vector<std::uint32_t> tris = sweep_triangulate(grid_x, grid_y, ids);
  for (std::size_t k = 0; k < tris.size(); k += 3) mesh.add_triangle(tris[k], tris[k + 1], tris[k + 2]);
  CpuExecutor serial(1);
  link_triangles(mesh, serial);
  if (opt.delaunay) lawson_flip(mesh);
  return f;
}

/// Whether p lies on the boundary of the convex polygon `hull` (CCW, strictly convex). Exact.
inline bool on_hull_boundary(const std::vector<double>& x, const std::vector<double>& y,
                             const std::vector<std::uint32_t>& hull, std::uint32_t p) {
  for (std::size_t i = 0; i < hull.size(); ++i) {
    const std::uint32_t a = hull[i], b = hull[(i + 1) % hull.size()];
    if (orient2d(x[a], y[a], x[b], y[b], x[p], y[p]) != 0) continue;
    if (std::min(x[a], x[b]) <= x[p] && x[p] <= std::max(x[a], x[b]) && std::min(y[a], y[b]) <= y[p] &&
        y[p] <= std::max(y[a], y[b]))
      return true;
  }
  return false;
}

/// Strictly convex hull (CCW, no collinear vertices) of `ids` by Andrew's monotone chain.
inline std::vector<std::uint32_t> strict_hull(const std::vector<double>& x, const std::vector<double>& y,
                                              std::vector<std::uint32_t> ids) {
  std::sort(ids.begin(), ids.end(),
            [&](std::uint32_t a, std::uint32_t b) { return x[a] < x[b] || (x[a] == x[b] && y[a] < y[b]); });
  const std::size_t n = ids.size();
  if (n < 3) return ids;
  std::vector<std::uint32_t> h(2 * n);
  std::size_t k = 0;
  auto turns_left = [&](std::uint32_t p) {
    return orient2d(x[h[k - 2]], y[h[k - 2]], x[h[k - 1]], y[h[k - 1]], x[p], y[p]) > 0;
  };
  for (std::size_t i = 0; i < n; ++i) {
    while (k >= 2 && !turns_left(ids[i])) --k;
    h[k++] = ids[i];
  }
  for (std::size_t i = n - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && !turns_left(ids[i])) --k;
    h[k++] = ids[i];
  }
  h.resize(k - 1);
  return h;
}

/// Checks that the mesh is a valid triangulation of the convex hull of the vertices it uses: live triangles
/// strictly CCW, links symmetric through encoded edges with matching endpoints, vert_tri incident (kNoId
/// exactly for unused vertices), every vertex fan connected, Euler characteristic of a disk, a single convex
/// boundary loop through exactly the used vertices on the hull boundary, and total area equal to the hull's.
/// With convex_hull false (a hand-made non-convex region) the last three checks become: one boundary loop
/// whose polygon area equals the triangles' area. Returns an empty string when valid, else the first problem
/// found.
inline std::string check_mesh(const cdt::detail::Mesh& mesh, bool convex_hull = true) {
  using namespace cdt::detail;
  std::ostringstream err;
  const std::uint32_t slots = mesh.num_slots(), nv = mesh.num_vertices();
  std::vector<double> x, y;
  for (const Vec2& p : mesh.xy) {
    x.push_back(p.x);
    y.push_back(p.y);
  }
  if (mesh.tri.size() != mesh.adj.size() || mesh.tri.size() != mesh.seg.size() || mesh.vert_tri.size() != nv)
    return "array sizes disagree";
  std::vector<std::uint32_t> incident(nv, 0);
  std::uint64_t faces = 0, boundary = 0;
  long double area = 0;
  std::map<std::uint32_t, std::uint32_t> boundary_next; // directed boundary edges, from -> to
  for (std::uint32_t t = 0; t < slots; ++t) {
    if (mesh.tri[3 * t] == kNoId) {
      if (mesh.tri[3 * t + 1] != kNoId || mesh.tri[3 * t + 2] != kNoId) return "half-freed slot";
      continue;
    }
    ++faces;
    const std::uint32_t a = mesh.tri[3 * t], b = mesh.tri[3 * t + 1], c = mesh.tri[3 * t + 2];
    if (a >= nv || b >= nv || c >= nv || a == b || b == c || a == c) {
      err << "triangle " << t << " has bad vertices";
      return err.str();
    }
    if (orient2d(x[a], y[a], x[b], y[b], x[c], y[c]) <= 0) {
      err << "triangle " << t << " (" << a << ", " << b << ", " << c << ") is not strictly CCW";
      return err.str();
    }
    area += (static_cast<long double>(x[b]) - x[a]) * (static_cast<long double>(y[c]) - y[a]) -
            (static_cast<long double>(y[b]) - y[a]) * (static_cast<long double>(x[c]) - x[a]);
    ++incident[a];
    ++incident[b];
    ++incident[c];
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t from = mesh.tri[3 * t + next3(i)], to = mesh.tri[3 * t + prev3(i)];
      const std::uint32_t e = mesh.adj[3 * t + i];
      if (e == kNoId) {
        ++boundary;
        if (!boundary_next.emplace(from, to).second) {
          err << "vertex " << from << " starts two boundary edges";
          return err.str();
        }
        continue;
      }
      const std::uint32_t u = edge_tri(e), j = edge_index(e);
      if (u >= slots || mesh.tri[3 * u] == kNoId || mesh.adj[e] != edge_id(t, i)) {
        err << "link of triangle " << t << " edge " << i << " is not symmetric";
        return err.str();
      }
      if (mesh.tri[3 * u + next3(j)] != to || mesh.tri[3 * u + prev3(j)] != from) {
        err << "triangle " << t << " edge " << i << " and its neighbour disagree on the endpoints";
        return err.str();
      }
    }
  }
  if (faces == 0) return "no triangles";
  std::vector<std::uint32_t> used;
  for (std::uint32_t v = 0; v < nv; ++v) {
    const std::uint32_t vt = mesh.vert_tri[v];
    if (incident[v] == 0) {
      if (vt != kNoId) {
        err << "unused vertex " << v << " has vert_tri " << vt;
        return err.str();
      }
      continue;
    }
    used.push_back(v);
    if (vt >= slots || mesh.tri[3 * vt] == kNoId ||
        (mesh.tri[3 * vt] != v && mesh.tri[3 * vt + 1] != v && mesh.tri[3 * vt + 2] != v)) {
      err << "vert_tri of vertex " << v << " is not an incident live triangle";
      return err.str();
    }
    // The fan walked from vert_tri through the links must reach every incident triangle (no pinched vertex).
    std::uint32_t t = vt, count = 0;
    for (std::uint32_t guard = 0; guard <= incident[v]; ++guard) { // rotate clockwise to the fan's start
      const std::uint32_t k = mesh.tri[3 * t] == v ? 0 : mesh.tri[3 * t + 1] == v ? 1 : 2;
      const std::uint32_t e = mesh.adj[3 * t + prev3(k)];
      if (e == kNoId || edge_tri(e) == vt) break;
      t = edge_tri(e);
    }
    const std::uint32_t start = t;
    do {
      ++count;
      const std::uint32_t k = mesh.tri[3 * t] == v ? 0 : mesh.tri[3 * t + 1] == v ? 1 : 2;
      const std::uint32_t e = mesh.adj[3 * t + next3(k)];
      t = e == kNoId ? kNoId : edge_tri(e);
    } while (t != kNoId && t != start && count <= incident[v]);
    if (count != incident[v]) {
      err << "fan of vertex " << v << " reaches " << count << " of its " << incident[v] << " triangles";
      return err.str();
    }
  }
  // Euler characteristic of a triangulated disk: V - E + F = 1.
  const std::int64_t edges = static_cast<std::int64_t>((3 * faces + boundary) / 2);
  if (static_cast<std::int64_t>(used.size()) - edges + static_cast<std::int64_t>(faces) != 1)
    return "Euler characteristic is not 1";
  // A single boundary loop with no right turn...
  const std::uint32_t first = boundary_next.begin()->first;
  std::vector<std::uint32_t> loop{first};
  for (std::uint32_t v = boundary_next[first]; v != first; v = boundary_next[v]) {
    if (loop.size() > boundary || !boundary_next.count(v)) return "boundary edges do not form one loop";
    loop.push_back(v);
  }
  if (loop.size() != boundary) return "boundary edges do not form one loop";
  long double loop_area = 0;
  for (std::size_t i = 0; i < loop.size(); ++i) {
    const std::uint32_t a = loop[i], b = loop[(i + 1) % loop.size()];
    loop_area += static_cast<long double>(x[a]) * y[b] - static_cast<long double>(x[b]) * y[a];
  }
  auto same_area = [](long double p, long double q) {
    return std::fabs(static_cast<double>(p - q)) <= 1e-9 * std::fabs(static_cast<double>(q));
  };
  if (!same_area(area, loop_area)) {
    err << "triangles cover " << static_cast<double>(area / 2) << ", the boundary loop "
        << static_cast<double>(loop_area / 2);
    return err.str();
  }
  if (!convex_hull) return {};
  for (std::size_t i = 0; i < loop.size(); ++i) {
    const std::uint32_t a = loop[i], b = loop[(i + 1) % loop.size()], c = loop[(i + 2) % loop.size()];
    if (orient2d(x[a], y[a], x[b], y[b], x[c], y[c]) < 0) {
      err << "boundary turns right at vertex " << b;
      return err.str();
    }
  }
  // The loop runs through exactly the used vertices on the boundary of their convex hull, and the triangles
  // cover the hull's area (which rules out a loop that winds twice).
  const std::vector<std::uint32_t> hull = strict_hull(x, y, used);
  std::vector<std::uint32_t> expected;
  for (std::uint32_t v : used)
    if (on_hull_boundary(x, y, hull, v)) expected.push_back(v);
  std::vector<std::uint32_t> got = loop;
  std::sort(got.begin(), got.end());
  if (got != expected) {
    err << "boundary has " << got.size() << " vertices, the hull boundary " << expected.size();
    return err.str();
  }
  long double hull_area = 0;
  for (std::size_t i = 0; i < hull.size(); ++i) {
    const std::uint32_t a = hull[i], b = hull[(i + 1) % hull.size()];
    hull_area += static_cast<long double>(x[a]) * y[b] - static_cast<long double>(x[b]) * y[a];
  }
  if (!same_area(area, hull_area)) {
    err << "triangles cover " << static_cast<double>(area / 2) << ", the hull "
        << static_cast<double>(hull_area / 2);
    return err.str();
  }
  return {};
}

/// The whole of Phases 3-4 on a fixture, checking the mesh after each step.
struct RunResult {
  cdt::detail::ShiftStats shift;
  cdt::detail::InsertStats insert;
  std::size_t missing = 0;       ///< points handed to Phase 4 (phase-1 missing plus bad cases)
  std::size_t delayed_hints = 0; ///< missing points whose hint was out of the mesh when Phase 4 began
  std::uint64_t last_flips = 0;  ///< flips after the fake boundary's removal (in_parts only)
  std::string error;             ///< the first failed check, with its step; empty when all passed
};

/// Runs shift, insert and fake boundary removal; after the last, checks that exactly the sites are used, each
/// at its true position, and that no free slot is left. With in_parts, the CPU schedule of triangulate():
/// the sites' mesh made Delaunay, the points inserted by parts with their flips, the fake boundary removed,
/// and the flips from the triangles the parts left, so that the result is the Delaunay triangulation.
inline RunResult run_phases(Fixture& f, cdt::detail::CpuExecutor& executor, bool in_parts = false) {
  using namespace cdt::detail;
  RunResult r;
  Mesh& mesh = f.mesh;
  if (std::string e = check_mesh(mesh); !e.empty()) {
    r.error = "fixture: " + e;
    return r;
  }
  MissingArray missing = f.missing;
  r.shift = shift_to_true_positions(mesh, f.num_sites, f.true_x, f.true_y, missing, executor);
  if (std::string e = check_mesh(mesh); !e.empty()) {
    r.error = "after shift: " + e;
    return r;
  }
  for (std::uint32_t v = 0; v < f.num_sites; ++v) {
    if (mesh.xy[v].x != f.true_x[v] || mesh.xy[v].y != f.true_y[v]) {
      r.error = "after shift: site " + std::to_string(v) + " is not at its true position";
      return r;
    }
  }
  r.missing = missing.size();
  for (const MissingPoint& p : missing)
    r.delayed_hints += p.hint < mesh.num_vertices() && mesh.vert_tri[p.hint] == kNoId ? 1 : 0;
  std::vector<std::uint8_t> dirty;
  r.insert = in_parts ? insert_missing_points_in_parts(mesh, missing, executor, dirty)
                      : insert_missing_points(mesh, missing, executor);
  if (std::string e = check_mesh(mesh); !e.empty()) {
    r.error = "after insert: " + e;
    return r;
  }
  if (!in_parts) {
    // The rounds leave the fake vertices' fans as chains that no strictly convex flip shortens.
    flip_fake_fans(mesh, f.num_sites, executor);
    if (std::string e = check_mesh(mesh); !e.empty()) {
      r.error = "after the fake fans' flips: " + e;
      return r;
    }
    const MeshView m = mesh.view();
    const std::vector<std::uint8_t> none_active(m.num_slots, 0);
    for (std::uint32_t t = 0; t < m.num_slots; ++t) {
      if (m.alive(t) && fake_fan_candidate(m, none_active.data(), t, f.num_sites) != kNoId) {
        r.error = "after the fake fans' flips: triangle " + std::to_string(t) + " can still flip a fan edge";
        return r;
      }
    }
  }
  remove_fake_boundary(mesh, f.num_sites, executor, in_parts ? &dirty : nullptr);
  if (std::string e = check_mesh(mesh); !e.empty()) {
    r.error = "after fake boundary removal: " + e;
    return r;
  }
  if (in_parts) {
    if (dirty.size() != mesh.num_slots()) {
      r.error = "after fake boundary removal: the flags do not follow the slots";
      return r;
    }
    r.last_flips = flip_to_delaunay_in_parts(mesh, executor, dirty.data()).flips;
    if (std::string e = check_mesh(mesh); !e.empty()) {
      r.error = "after the last flips: " + e;
      return r;
    }
  }
  if (mesh.num_vertices() != f.num_sites) {
    r.error = "fake vertices left in x/y/vert_tri";
    return r;
  }
  for (std::uint32_t v = 0; v < f.num_sites; ++v) {
    if (mesh.vert_tri[v] == kNoId) {
      r.error = "site " + std::to_string(v) + " is not in the final triangulation";
      return r;
    }
    if (mesh.xy[v].x != f.true_x[v] || mesh.xy[v].y != f.true_y[v]) {
      r.error = "site " + std::to_string(v) + " moved";
      return r;
    }
  }
  for (std::uint32_t t = 0; t < mesh.num_slots(); ++t) {
    if (!mesh.alive(t)) {
      r.error = "free slot left after compaction";
      return r;
    }
  }
  return r;
}

} // namespace shift_test
