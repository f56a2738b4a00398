// Phase 2 of gCD (paper section 3.2): dualize the digital Voronoi diagram, complete the hull with a
// Graham-scan-like pass, enclose everything with a fake boundary of about sqrt(k) points.

#include "gcd/dualize.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <optional>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "cdt/errors.hpp"
#include "executor/cpu_executor.hpp"
#include "gcd/probe_map.hpp"

namespace cdt::detail {
namespace {

using Tri = DualTriangle;

/// Edges and vertices to 32-bit values (the completion's lookups, tens of thousands at 10^7 points).
using KeyTable = ProbeMap<std::uint64_t, std::uint32_t>;

CDT_HD_INLINE int orient(const double* x, const double* y, std::uint32_t a, std::uint32_t b,
                         std::uint32_t c) {
  return orient2d(x[a], y[a], x[b], y[b], x[c], y[c]);
}

/// The fake boundary: a regular polygon of k vertices around `bounds`, its inscribed circle three
/// times as large as the box's circumscribed one, so every site position is strictly inside.
void fake_polygon(const Box& bounds, std::uint32_t k, std::vector<Vec2>& out) {
  const double cx = 0.5 * (bounds.min_x + bounds.max_x);
  const double cy = 0.5 * (bounds.min_y + bounds.max_y);
  double half_diagonal = 0.5 * std::hypot(bounds.max_x - bounds.min_x, bounds.max_y - bounds.min_y);
  if (!(half_diagonal > 0)) half_diagonal = std::max(1.0, std::abs(cx) + std::abs(cy));
  const double radius = 3.0 * half_diagonal / std::cos(std::numbers::pi / k);
  for (std::uint32_t i = 0; i < k; ++i) {
    const double angle = 2.0 * std::numbers::pi * i / k;
    out.push_back({cx + radius * std::cos(angle), cy + radius * std::sin(angle)});
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

/// The ring between the convex hull (counter-clockwise, collinear vertices kept) and the fake polygon
/// (fake vertices first_fake .. first_fake + k - 1, counter-clockwise around it) triangulated by one
/// merge of the two cycles: each step adds the triangle of the current bridge (a fake vertex, a hull
/// vertex) with the next hull vertex or the next fake vertex, whichever is valid, the one whose
/// direction from the hull's centroid comes first when both are. Each fake vertex so takes the part of
/// the hull in its own direction, about hull size / k vertices. (Adding the fake vertices one by one,
/// each to every hull edge it sees, gave the first ones everything they saw: a straight side of the
/// hull, a lattice's or clipped points' edge of thousands of collinear vertices, went into one fake
/// vertex's fan, and each later step that walks fans, above all the fake boundary's removal, walked it
/// on one thread.) Appends the m + k triangles to out and returns true; returns false, adding nothing,
/// when some step finds neither triangle valid.
bool zip_fake_boundary(const std::vector<std::uint32_t>& hull, std::uint32_t first_fake, std::uint32_t k,
                       const double* x, const double* y, std::vector<Tri>& out) {
  const std::size_t m = hull.size();
  if (m < 3 || k < 3) return false;
  double cx = 0, cy = 0;
  for (const std::uint32_t v : hull) {
    cx += x[v];
    cy += y[v];
  }
  cx /= static_cast<double>(m);
  cy /= static_cast<double>(m);
  const auto h = [&](std::size_t j) { return hull[j % m]; };
  const auto f = [&](std::size_t i) { return first_fake + static_cast<std::uint32_t>(i % k); };
  // The segment from fake vertex fv to hull vertex j stays outside the hull: fv sees one of j's edges.
  const auto sees = [&](std::uint32_t fv, std::size_t j) {
    return orient(x, y, h(j), h(j + 1), fv) < 0 || orient(x, y, h(j + m - 1), h(j), fv) < 0;
  };
  // The first bridge: fake vertex 0 and the hull vertex it sees closest to its direction from the centroid.
  const double fx = x[first_fake] - cx, fy = y[first_fake] - cy, f_norm = std::hypot(fx, fy);
  std::size_t start = m;
  double best = -2;
  for (std::size_t j = 0; j < m; ++j) {
    const double hx = x[hull[j]] - cx, hy = y[hull[j]] - cy;
    const double norm = std::hypot(hx, hy);
    const double cosine = norm > 0 ? (hx * fx + hy * fy) / (norm * f_norm) : -2;
    if (cosine > best && sees(first_fake, j)) {
      best = cosine;
      start = j;
    }
  }
  if (start == m) return false;
  std::vector<Tri> ring;
  ring.reserve(m + k);
  std::size_t i = 0, j = 0; // the bridge: fake vertex i, hull vertex start + j
  while (i < k || j < m) {
    const std::uint32_t fi = f(i), fn = f(i + 1), hj = h(start + j), hn = h(start + j + 1);
    const bool hull_step = j < m && orient(x, y, hj, hn, fi) < 0;
    const bool fake_step = i < k && orient(x, y, fi, fn, hj) > 0 && sees(fn, start + j);
    bool take_hull = hull_step;
    if (hull_step && fake_step) {
      // Both valid: the hull's next vertex first when its direction comes before the next fake's.
      take_hull = orient2d(cx, cy, x[fn], y[fn], x[hn], y[hn]) < 0;
    } else if (!hull_step && !fake_step) {
      return false;
    }
    if (take_hull) {
      ring.push_back({hn, hj, fi});
      ++j;
    } else {
      ring.push_back({fi, fn, hj});
      ++i;
    }
  }
  out.insert(out.end(), ring.begin(), ring.end());
  return true;
}

/// The boundary cycle (counter-clockwise) through the open edges (in increasing edge order), or empty
/// when they do not form one simple cycle.
/// The open edges (indices into `open`) in the order they run around the dual's boundary, when it is
/// one simple cycle; empty otherwise.
std::vector<std::uint32_t> boundary_cycle(std::span<const OpenEdge> open) {
  KeyTable leaving(open.size()); // vertex -> the open edge leaving it
  for (std::size_t k = 0; k < open.size(); ++k) {
    if (leaving.find_or_add(open[k].from, static_cast<std::uint32_t>(k)) != nullptr)
      return {}; // two boundary edges leave one vertex: a pinch
  }
  std::vector<std::uint32_t> cycle;
  if (open.empty()) return cycle;
  cycle.reserve(open.size());
  const std::uint32_t first = static_cast<std::uint32_t>(open.size() - 1);
  std::uint32_t k = first;
  do {
    cycle.push_back(k);
    const std::uint32_t* next = leaving.find(open[k].to);
    k = next == nullptr ? kNoId : *next;
  } while (k != kNoId && k != first && cycle.size() <= open.size());
  if (k != first || cycle.size() != open.size()) return {};
  return cycle;
}

Mesh fake_polygon_only(std::span<const double> x, std::span<const double> y, const Box& bounds,
                       CpuExecutor& executor, DualizeStats* stats) {
  Mesh mesh;
  mesh.set_points(x, y);
  const auto n = static_cast<std::uint32_t>(x.size());
  constexpr std::uint32_t k = 8;
  fake_polygon(bounds, k, mesh.xy);
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

void DualCorners::mark_changed(std::span<const std::uint32_t> cells, std::uint32_t m) {
  if (stale.size() != per_row.size()) stale.assign(per_row.size(), 0);
  for (const std::uint32_t c : cells) {
    const std::uint32_t y = c / m;
    if (y > 0 && y - 1 < stale.size()) stale[y - 1] = 1;
    if (y < stale.size()) stale[y] = 1;
  }
}

Mesh dualize(std::span<const std::uint32_t> colour, std::uint32_t m, std::span<const double> x,
             std::span<const double> y, std::span<const std::uint8_t> kept, const Box& bounds,
             CpuExecutor& executor, DualizeStats* stats, std::vector<std::uint32_t>* degenerate,
             DualCorners* corners) {
  const auto n = static_cast<std::uint32_t>(x.size());
  if (colour.size() != static_cast<std::size_t>(m) * m) throw Error("internal error: colour grid size");

  // Dual triangles, one grid row of corners per task so each task appends to its own list.
  const std::uint32_t rows = m > 1 ? m - 1 : 0;
  DualCorners local;
  DualCorners& rows_of = corners != nullptr ? *corners : local;
  const bool reuse = rows_of.per_row.size() == rows && rows_of.stale.size() == rows;
  if (!reuse) {
    rows_of.per_row.assign(rows, {});
    rows_of.invalid.assign(rows, 0);
    rows_of.culprits.assign(rows, {});
  }
  auto& per_row = rows_of.per_row;
  auto& row_invalid = rows_of.invalid;
  auto& row_culprits = rows_of.culprits;
  executor.for_each_part(rows, [&](std::size_t r) {
    if (reuse && rows_of.stale[r] == 0) return;
    const auto gy = static_cast<std::uint32_t>(r);
    auto& list = per_row[r];
    list.clear();
    row_invalid[r] = 0;
    row_culprits[r].clear();
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
  rows_of.stale.clear();
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
  mesh.set_points(x, y);
  reserve_mesh_slots(mesh, n);
  mesh.grow_slots(num_dual);
  // Slots ordered by each triangle's lowest vertex (a stable radix sort, the same for any thread
  // count). Sites are numbered along a space-filling curve (triangulate.cpp), so a vertex's fan and its
  // neighbours' coordinates then sit close together in memory, and the later phases, which visit sites
  // in slot order, read them mostly from the cache.
  {
    UnzeroedVector<Tri> all(num_dual);
    std::vector<std::uint32_t> key(num_dual);
    std::vector<std::uint32_t> order(num_dual);
    executor.for_each_part(rows, [&](std::size_t r) {
      std::uint32_t k = row_start[r];
      for (const Tri& t : per_row[r]) {
        all[k] = t;
        key[k] = std::min({t.a, t.b, t.c});
        order[k] = k;
        ++k;
      }
    });
    executor.sort_pairs_by_key(key, order, std::bit_width(n));
    std::uint32_t* tri = mesh.tri.data();
    executor.for_each(num_dual, [&](std::size_t k) {
      const Tri& t = all[order[k]];
      tri[3 * k] = t.a;
      tri[3 * k + 1] = t.b;
      tri[3 * k + 2] = t.c;
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
  const std::size_t room = 3 * (2 * static_cast<std::size_t>(n) + n / 8 +
                                4 * static_cast<std::size_t>(std::sqrt(static_cast<double>(n))) + 64);
  mesh.tri.reserve(room);
  mesh.adj.reserve(room);
  mesh.seg.reserve(room);
}

std::optional<DualCompletion> plan_dual_completion(std::span<const OpenEdge> open, std::span<const Vec2> xy,
                                                   std::uint32_t num_dual, const Box& bounds) {
  std::vector<double> open_x(open.size());
  std::vector<double> open_y(open.size());
  for (std::size_t k = 0; k < open.size(); ++k) {
    open_x[k] = xy[open[k].from].x;
    open_y[k] = xy[open[k].from].y;
  }
  return plan_dual_completion(open, open_x, open_y, static_cast<std::uint32_t>(xy.size()), num_dual, bounds);
}

std::optional<DualCompletion> plan_dual_completion(std::span<const OpenEdge> open,
                                                   std::span<const double> open_x,
                                                   std::span<const double> open_y, std::uint32_t n,
                                                   std::uint32_t num_dual, const Box& bounds) {
  const std::vector<std::uint32_t> cycle = boundary_cycle(open);
  if (cycle.size() < 3) return std::nullopt;

  // The hull and the fake boundary are worked out on the boundary's vertices alone, numbered locally:
  // boundary vertex k is k, fake vertex f is boundary.size() + f.
  const auto b = static_cast<std::uint32_t>(cycle.size());
  std::vector<std::uint32_t> boundary(b);
  std::vector<double> lx(b);
  std::vector<double> ly(b);
  for (std::uint32_t k = 0; k < b; ++k) {
    boundary[k] = open[cycle[k]].from;
    lx[k] = open_x[cycle[k]];
    ly[k] = open_y[cycle[k]];
  }
  // Hull completion (Graham-scan-like): start at the lowest-leftmost boundary vertex, which is on the
  // convex hull, and fill every reflex turn with a triangle outside the current mesh.
  std::uint32_t lowest = 0;
  for (std::uint32_t k = 1; k < b; ++k) {
    if (ly[k] < ly[lowest] || (ly[k] == ly[lowest] && lx[k] < lx[lowest])) lowest = k;
  }
  std::vector<Tri> added;
  std::vector<std::uint32_t> stack;
  for (std::uint32_t i = 0; i <= b; ++i) {
    const std::uint32_t r = (lowest + i) % b;
    while (stack.size() >= 2 && orient(lx.data(), ly.data(), stack[stack.size() - 2], stack.back(), r) < 0) {
      added.push_back({stack[stack.size() - 2], r, stack.back()});
      stack.pop_back();
    }
    if (i < b) stack.push_back(r);
  }
  std::vector<std::uint32_t> hull = stack;
  DualCompletion plan;
  plan.hull_triangles = added.size();

  // Fake boundary: about sqrt(k) vertices (k = hull size), as the paper suggests, at least 8.
  const auto k_fake = std::max<std::uint32_t>(
      8, static_cast<std::uint32_t>(std::ceil(std::sqrt(static_cast<double>(hull.size())))));
  fake_polygon(bounds, k_fake, plan.fake);
  for (const Vec2& f : plan.fake) {
    lx.push_back(f.x);
    ly.push_back(f.y);
  }
  if (!zip_fake_boundary(hull, b, k_fake, lx.data(), ly.data(), added)) {
    for (std::uint32_t f = b; f < b + k_fake; ++f) add_outside_vertex(hull, f, lx.data(), ly.data(), added);
  }
  const auto global = [&](std::uint32_t local) { return local < b ? boundary[local] : n + (local - b); };
  plan.triangles.reserve(added.size());
  for (const Tri& t : added) plan.triangles.push_back({global(t.a), global(t.b), global(t.c)});

  // Links: each edge of a new triangle meets another new triangle's edge, an open edge of the dual, or
  // nothing (the fake polygon's outside). Edges are keyed by their ends, lower first; the first edge of
  // a key waits in the table for the second.
  const auto key = [](std::uint32_t from, std::uint32_t to) {
    return from < to ? (std::uint64_t{from} << 32) | to : (std::uint64_t{to} << 32) | from;
  };
  plan.adj.assign(3 * plan.triangles.size(), kNoId);
  const std::uint32_t first_new_edge = edge_id(num_dual, 0);
  const auto link = [&](std::uint32_t e, std::uint32_t to) {
    if (e >= first_new_edge) {
      plan.adj[e - first_new_edge] = to;
    } else {
      plan.links.emplace_back(e, to);
    }
  };
  struct Waiting {
    std::uint32_t edge;
    std::uint32_t from;
    bool paired;
  };
  std::vector<Waiting> waiting; // the first edge of each key
  waiting.reserve(open.size() + 3 * plan.triangles.size());
  KeyTable first_of_key(open.size() + 3 * plan.triangles.size());
  const auto meet = [&](std::uint32_t from, std::uint32_t to, std::uint32_t edge) {
    const std::uint32_t* w =
        first_of_key.find_or_add(key(from, to), static_cast<std::uint32_t>(waiting.size()));
    if (w == nullptr) {
      waiting.push_back({edge, from, false});
      return;
    }
    Waiting& other = waiting[*w];
    if (other.paired) throw Error("internal error: an edge is shared by more than two triangles");
    if (other.from == from)
      throw Error("internal error: two triangles overlap along an edge (same direction)");
    other.paired = true;
    link(other.edge, edge);
    link(edge, other.edge);
  };
  for (const OpenEdge& e : open) meet(e.from, e.to, e.edge);
  for (std::size_t k = 0; k < plan.triangles.size(); ++k) {
    const std::uint32_t v[3] = {plan.triangles[k].a, plan.triangles[k].b, plan.triangles[k].c};
    for (std::uint32_t i = 0; i < 3; ++i)
      meet(v[next3(i)], v[prev3(i)], edge_id(num_dual + static_cast<std::uint32_t>(k), i));
  }
  // Each fake vertex's first new triangle (the boundary's vertices have theirs in the dual).
  plan.fake_vert_tri.assign(k_fake, kNoId);
  for (std::size_t k = 0; k < plan.triangles.size(); ++k) {
    for (const std::uint32_t v : {plan.triangles[k].a, plan.triangles[k].b, plan.triangles[k].c}) {
      if (v >= n && plan.fake_vert_tri[v - n] == kNoId)
        plan.fake_vert_tri[v - n] = num_dual + static_cast<std::uint32_t>(k);
    }
  }
  return plan;
}

void check_missing_sites_left_out(std::span<const std::uint8_t> kept, std::span<const std::uint32_t> vert_tri,
                                  CpuExecutor& executor) {
  std::uint32_t first_bad = kNoId;
  executor.for_each(kept.size(), [&](std::size_t v) {
    if (kept[v] == 0 && vert_tri[v] != kNoId) atomic_min(&first_bad, static_cast<std::uint32_t>(v));
  });
  if (first_bad != kNoId) throw Error("internal error: a missing site was dualized");
}

Mesh complete_dual(Mesh mesh, std::span<const std::uint8_t> kept, const Box& bounds, CpuExecutor& executor,
                   DualizeStats* stats) {
  const std::uint32_t n = mesh.num_vertices();
  const std::uint32_t num_dual = mesh.num_slots();
  const MeshView m = mesh.view();
  const std::vector<std::uint32_t> open_ids =
      executor.compact(3 * static_cast<std::size_t>(num_dual), [&](std::size_t e) {
        return m.alive(static_cast<std::uint32_t>(e / 3)) && m.adj[e] == kNoId;
      });
  std::vector<OpenEdge> open(open_ids.size());
  for (std::size_t k = 0; k < open.size(); ++k) {
    const std::uint32_t e = open_ids[k];
    open[k] = {e, m.v(edge_tri(e), next3(edge_index(e))), m.v(edge_tri(e), prev3(edge_index(e)))};
  }
  const std::optional<DualCompletion> plan = plan_dual_completion(open, mesh.xy, num_dual, bounds);
  if (!plan) {
    std::vector<double> x(n), y(n);
    for (std::uint32_t v = 0; v < n; ++v) {
      x[v] = mesh.xy[v].x;
      y[v] = mesh.xy[v].y;
    }
    return fake_polygon_only(x, y, bounds, executor, stats);
  }

  mesh.xy.insert(mesh.xy.end(), plan->fake.begin(), plan->fake.end());
  for (const Tri& t : plan->triangles) mesh.add_triangle(t.a, t.b, t.c);
  std::copy(plan->adj.begin(), plan->adj.end(), mesh.adj.begin() + 3 * static_cast<std::ptrdiff_t>(num_dual));
  for (const auto& [e, to] : plan->links) mesh.adj[e] = to;
  mesh.vert_tri.resize(n);
  mesh.vert_tri.insert(mesh.vert_tri.end(), plan->fake_vert_tri.begin(), plan->fake_vert_tri.end());
  check_missing_sites_left_out(kept, mesh.vert_tri, executor);
  if (stats != nullptr) {
    *stats = DualizeStats{num_dual, plan->hull_triangles, static_cast<std::uint32_t>(plan->fake.size())};
  }
  return mesh;
}

} // namespace cdt::detail
