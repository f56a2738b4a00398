// verify(): exact checks of a triangulation against its input (see cdt/verify.hpp).
//
// Why these checks suffice for "the domain is the convex hull": every triangle is counter-clockwise,
// every edge is shared by at most two triangles lying on opposite sides of it, the boundary is one
// closed, locally convex cycle that turns around exactly once, and V - E + F = 1. The mesh is then a
// disc mapped into the plane without folds, whose boundary is a convex polygon: it covers the polygon
// exactly once. The explicit point-in-hull test adds a direct check for vertices the mesh does not use.
//
// Segments are checked in O(log) each rather than walked edge by edge, so that many overlapping input
// segments cannot make the check quadratic: straight runs of constraint edges are numbered once
// ("chains"), and a segment is present when the edge leaving rep(a) toward rep(b) and the edge arriving
// at rep(b) from rep(a) lie on one chain, in that order. A segment split at a rounded crossing point is
// not straight any more; only for those is the chain searched edge by edge, within a tolerance of a
// few hundred ulps (see BentChainSearch). A missing segment is walked once more, to say where it stops.
//
// Large triangulations are checked on every hardware thread (2M points and 200K segments took one
// thread 6.2 s): each check runs over contiguous parts of its triangles, edges, vertices or segments,
// each part into a report of its own, and the parts' reports are joined in order, so that the report
// is the one a single loop gives.

#include "cdt/verify.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <optional>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>

#include "cdt/detail/predicates.hpp"
#include "cdt/detail/trace.hpp"
#include "executor/cpu_executor.hpp"

namespace cdt {
namespace {

using detail::incircle;
using detail::incircle_perturbed;
using detail::orient2d;

int orient(const Point& a, const Point& b, const Point& c) { return orient2d(a.x, a.y, b.x, b.y, c.x, c.y); }

/// Counts every problem and keeps the first few messages.
class Reporter {
public:
  explicit Reporter(VerifyReport& report) : report_(report) {}
  template <class... Parts>
  void add(const Parts&... parts) {
    ++report_.num_problems;
    if (!keeping()) return;
    std::ostringstream message;
    message.precision(17);
    (message << ... << parts);
    report_.problems.push_back(message.str());
  }
  /// Counts a problem without describing it (its message would not be kept).
  void tally() { ++report_.num_problems; }
  /// Whether the next message will be kept: expensive diagnostics are only worth it then.
  bool keeping() const { return report_.problems.size() < VerifyReport::kMaxKept; }
  /// Adds the problems of a later part of a check: its count, and its messages while there is room.
  void join(const VerifyReport& part) {
    report_.num_problems += part.num_problems;
    for (const std::string& message : part.problems) {
      if (!keeping()) break;
      report_.problems.push_back(message);
    }
  }

private:
  VerifyReport& report_;
};

/// A check's parts: at most this many, of at least kPartSize elements.
constexpr std::size_t kMaxParts = 64;
constexpr std::size_t kPartSize = std::size_t{1} << 14;

/// Runs check(k, reporter) for every k in [0, n) in contiguous parts on the executor's threads, each
/// part into a report of its own, then joins the parts' reports to `report` in order: the report one
/// loop over k gives (check must only read shared data).
template <class Check>
void check_in_parts(detail::CpuExecutor& executor, std::size_t n, Reporter& report, Check&& check) {
  const std::size_t parts = std::min(kMaxParts, n / kPartSize + 1);
  if (parts == 1 || executor.threads() == 1) {
    for (std::size_t k = 0; k < n; ++k) check(k, report);
    return;
  }
  std::vector<VerifyReport> found(parts);
  // A part's exception (std::bad_alloc) reaches this thread through the executor.
  executor.for_each_part(parts, [&](std::size_t p) {
    Reporter part(found[p]);
    for (std::size_t k = n * p / parts; k < n * (p + 1) / parts; ++k) check(k, part);
  });
  for (const VerifyReport& part : found) report.join(part);
}

using Triangle = std::array<std::uint32_t, 3>;

std::string id_or_none(std::uint32_t id) { return id == kNone ? std::string("none") : std::to_string(id); }

constexpr std::uint32_t next(std::uint32_t i) { return i == 2 ? 0 : i + 1; }
constexpr std::uint32_t prev(std::uint32_t i) { return i == 0 ? 2 : i - 1; }

/// Edge i of a triangle, as the directed pair it has in counter-clockwise order.
std::pair<std::uint32_t, std::uint32_t> edge_of(const Triangle& tri, std::uint32_t i) {
  return {tri[next(i)], tri[prev(i)]};
}

/// The edge of u that is (p, q) reversed, or 3 when u has none or more than one.
std::uint32_t reversed_edge(const Triangle& u, std::uint32_t p, std::uint32_t q) {
  std::uint32_t found = 3;
  for (std::uint32_t j = 0; j < 3; ++j) {
    if (u[next(j)] == q && u[prev(j)] == p) {
      if (found != 3) return 3;
      found = j;
    }
  }
  return found;
}

// --- sizes and indices -------------------------------------------------------------------------------

/// Checks what every later check indexes with. Returns false when they cannot run safely.
bool check_sizes(const Triangulation& t, std::span<const Point> points, std::span<const Segment> segments,
                 detail::CpuExecutor& executor, Reporter& report) {
  const std::size_t num_t = t.triangles.size();
  bool ok = true;
  if (t.neighbors.size() != num_t || t.segment_of_edge.size() != num_t) {
    report.add("sizes differ: ", num_t, " triangles, ", t.neighbors.size(), " neighbour triples, ",
               t.segment_of_edge.size(), " segment_of_edge triples");
    ok = false;
  }
  if (t.duplicate_of.size() != points.size()) {
    report.add("duplicate_of has ", t.duplicate_of.size(), " entries for ", points.size(), " input points");
    ok = false;
  }
  if (t.vertices.size() < points.size()) {
    report.add("only ", t.vertices.size(), " vertices for ", points.size(), " input points");
    ok = false;
  }
  if (t.vertices.size() >= kNone || num_t >= kNone) {
    report.add("more than 2^32 - 2 vertices or triangles");
    ok = false;
  }
  if (!ok) return false;
  std::atomic<bool> unsafe{false}; // set by the parts below
  check_in_parts(executor, t.vertices.size(), report, [&](std::size_t v, Reporter& found) {
    // Exact predicates (and the angular sorts built on them) need finite coordinates.
    if (!std::isfinite(t.vertices[v].x) || !std::isfinite(t.vertices[v].y)) {
      found.add("vertex ", v, " has a non-finite coordinate (", t.vertices[v].x, ", ", t.vertices[v].y, ")");
      unsafe.store(true, std::memory_order_relaxed);
    }
  });
  check_in_parts(executor, points.size(), report, [&](std::size_t i, Reporter& found) {
    const Point& v = t.vertices[i];
    const Point& p = points[i];
    if (std::bit_cast<std::uint64_t>(v.x) != std::bit_cast<std::uint64_t>(p.x) ||
        std::bit_cast<std::uint64_t>(v.y) != std::bit_cast<std::uint64_t>(p.y)) {
      found.add("vertex ", i, " (", v.x, ", ", v.y, ") differs from input point ", i, " (", p.x, ", ", p.y,
                ")");
    }
  });
  check_in_parts(executor, num_t, report, [&](std::size_t k, Reporter& found) {
    for (std::uint32_t i = 0; i < 3; ++i) {
      if (t.triangles[k][i] >= t.vertices.size()) {
        found.add("triangle ", k, " has vertex index ", t.triangles[k][i], ", beyond the ", t.vertices.size(),
                  " vertices");
        unsafe.store(true, std::memory_order_relaxed);
      }
      if (t.neighbors[k][i] != kNone && t.neighbors[k][i] >= num_t) {
        found.add("triangle ", k, " has neighbour index ", t.neighbors[k][i], ", beyond the ", num_t,
                  " triangles");
      }
      if (t.segment_of_edge[k][i] != kNone && t.segment_of_edge[k][i] >= segments.size()) {
        found.add("edge ", i, " of triangle ", k, " names segment ", t.segment_of_edge[k][i], ", beyond the ",
                  segments.size(), " segments");
      }
    }
  });
  check_in_parts(executor, points.size(), report, [&](std::size_t i, Reporter& found) {
    if (t.duplicate_of[i] >= points.size()) {
      found.add("duplicate_of[", i, "] = ", t.duplicate_of[i], " is not an input point");
      unsafe.store(true, std::memory_order_relaxed);
    }
  });
  return !unsafe.load();
}

// --- triangles and links -----------------------------------------------------------------------------

void check_orientation(const Triangulation& t, detail::CpuExecutor& executor, Reporter& report) {
  check_in_parts(executor, t.triangles.size(), report, [&](std::size_t k, Reporter& found) {
    const Triangle& tri = t.triangles[k];
    const int o = orient(t.vertices[tri[0]], t.vertices[tri[1]], t.vertices[tri[2]]);
    if (o <= 0) {
      found.add("triangle ", k, " (", tri[0], ", ", tri[1], ", ", tri[2], ") is ",
                o == 0 ? "degenerate (collinear vertices)" : "clockwise");
    }
  });
}

/// True when neighbour k of t is a proper link: a triangle holding the edge reversed, linked back.
bool linked_back(const Triangulation& t, std::uint32_t k, std::uint32_t i, std::uint32_t& u,
                 std::uint32_t& j) {
  u = t.neighbors[k][i];
  if (u == kNone || u >= t.triangles.size()) return false;
  const auto [p, q] = edge_of(t.triangles[k], i);
  j = reversed_edge(t.triangles[u], p, q);
  return j != 3 && t.neighbors[u][j] == k;
}

void check_links(const Triangulation& t, detail::CpuExecutor& executor, Reporter& report) {
  const auto num_t = static_cast<std::uint32_t>(t.triangles.size());
  check_in_parts(executor, num_t, report, [&](std::size_t index, Reporter& found) {
    const auto k = static_cast<std::uint32_t>(index);
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t u = t.neighbors[k][i];
      if (u == kNone || u >= num_t) continue;
      const auto [p, q] = edge_of(t.triangles[k], i);
      const std::uint32_t j = reversed_edge(t.triangles[u], p, q);
      if (j == 3) {
        found.add("triangle ", k, " names ", u, " as its neighbour across edge (", p, ", ", q, "), but ", u,
                  " does not have that edge reversed exactly once");
      } else if (t.neighbors[u][j] != k) {
        found.add("link not symmetric: triangle ", k, " -> ", u, " across edge (", p, ", ", q, "), but ", u,
                  " -> ", id_or_none(t.neighbors[u][j]));
      } else if (k < u && t.segment_of_edge[k][i] != t.segment_of_edge[u][j]) {
        found.add("edge (", p, ", ", q, ") is constraint ", id_or_none(t.segment_of_edge[k][i]),
                  " in triangle ", k, " but ", id_or_none(t.segment_of_edge[u][j]), " in triangle ", u);
      }
    }
  });
}

/// Each undirected edge once, with the triangle edges (3 * triangle + i) that hold it.
struct EdgeTable {
  struct Entry {
    std::uint64_t key; // (min vertex << 32) | max vertex
    std::uint32_t slot;
  };
  std::vector<Entry> entries;       // sorted by key
  std::vector<std::uint32_t> first; // group g is entries[first[g] .. first[g + 1])
  std::size_t num_edges() const { return first.size() - 1; }
  std::uint32_t low(std::size_t g) const { return static_cast<std::uint32_t>(entries[first[g]].key >> 32); }
  std::uint32_t high(std::size_t g) const { return static_cast<std::uint32_t>(entries[first[g]].key); }
};

/// Every triangle's edges grouped by their two vertices: sorted by (key, slot). The slots are first
/// sorted by their edge's lower vertex (a radix sort, stable, so that each vertex's run keeps its
/// slots in order), then each run, a few slots for most vertices, by the higher vertex: a comparison
/// sort of all 3n entries took most of the verifier's time.
EdgeTable collect_edges(const Triangulation& t, detail::CpuExecutor& executor) {
  const std::size_t n = 3 * t.triangles.size();
  const auto key_of = [&](std::uint32_t slot) {
    const auto [p, q] = edge_of(t.triangles[slot / 3], slot % 3);
    return (std::uint64_t{std::min(p, q)} << 32) | std::max(p, q);
  };
  std::vector<std::uint32_t> low(n), slot(n);
  executor.for_each(t.triangles.size(), [&](std::size_t k) {
    for (std::uint32_t i = 0; i < 3; ++i) {
      const auto [p, q] = edge_of(t.triangles[k], i);
      low[3 * k + i] = std::min(p, q);
      slot[3 * k + i] = static_cast<std::uint32_t>(3 * k + i);
    }
  });
  executor.sort_pairs_by_key(low, slot, detail::bits_below(t.vertices.size()));
  // The runs of one lower vertex, each sorted by (key, slot) on its own.
  std::vector<std::uint32_t> run =
      executor.compact(n, [&](std::size_t e) { return e == 0 || low[e] != low[e - 1]; });
  run.push_back(static_cast<std::uint32_t>(n));
  EdgeTable table;
  table.entries.resize(n);
  executor.for_each(run.size() - 1, [&](std::size_t r) {
    const auto begin = table.entries.begin() + run[r];
    const auto end = table.entries.begin() + run[r + 1];
    for (auto e = begin; e != end; ++e) {
      const std::uint32_t s = slot[static_cast<std::size_t>(e - table.entries.begin())];
      *e = {key_of(s), s};
    }
    std::sort(begin, end, [](const EdgeTable::Entry& a, const EdgeTable::Entry& b) {
      return a.key != b.key ? a.key < b.key : a.slot < b.slot;
    });
  });
  const std::vector<EdgeTable::Entry>& entries = table.entries;
  table.first = executor.compact(
      entries.size(), [&](std::size_t e) { return e == 0 || entries[e].key != entries[e - 1].key; });
  table.first.push_back(static_cast<std::uint32_t>(entries.size()));
  return table;
}

void check_edge_sharing(const Triangulation& t, const EdgeTable& edges, detail::CpuExecutor& executor,
                        Reporter& report) {
  check_in_parts(executor, edges.num_edges(), report, [&](std::size_t g, Reporter& found) {
    const std::uint32_t begin = edges.first[g];
    const std::uint32_t end = edges.first[g + 1];
    if (end - begin > 2) {
      found.add("edge (", edges.low(g), ", ", edges.high(g), ") is in ", end - begin, " triangles, first ",
                edges.entries[begin].slot / 3, " and ", edges.entries[begin + 1].slot / 3);
    } else if (end - begin == 2) {
      const std::uint32_t s0 = edges.entries[begin].slot;
      const std::uint32_t s1 = edges.entries[begin + 1].slot;
      const auto d0 = edge_of(t.triangles[s0 / 3], s0 % 3);
      const auto d1 = edge_of(t.triangles[s1 / 3], s1 % 3);
      if (d0 == d1) {
        found.add("triangles ", s0 / 3, " and ", s1 / 3, " overlap: both have edge (", d0.first, ", ",
                  d0.second, ") in the same direction");
      } else if (t.neighbors[s0 / 3][s0 % 3] == kNone || t.neighbors[s1 / 3][s1 % 3] == kNone) {
        found.add("edge (", edges.low(g), ", ", edges.high(g), ") is shared by triangles ", s0 / 3, " and ",
                  s1 / 3, " but marked as a hull edge (no neighbour)");
      }
    }
  });
}

// --- the domain --------------------------------------------------------------------------------------

/// True when p, on the line through a and r, lies strictly between them.
bool strictly_between(const Point& a, const Point& r, const Point& p) {
  if (a.x != r.x) return a.x < r.x ? (a.x < p.x && p.x < r.x) : (r.x < p.x && p.x < a.x);
  return a.y < r.y ? (a.y < p.y && p.y < r.y) : (r.y < p.y && p.y < a.y);
}

/// Point in a strictly convex counter-clockwise polygon (boundary counts as inside), O(log n): the fan
/// from c[0] is searched for the wedge holding p.
bool inside_convex(const std::vector<Point>& c, const Point& p) {
  const std::size_t m = c.size();
  if (orient(c[0], c[1], p) < 0 || orient(c[0], c[m - 1], p) > 0) return false;
  std::size_t lo = 1;
  std::size_t hi = m - 2; // largest k in [1, m-2] with orient(c0, ck, p) >= 0
  while (lo < hi) {
    const std::size_t mid = (lo + hi + 1) / 2;
    if (orient(c[0], c[mid], p) >= 0) {
      lo = mid;
    } else {
      hi = mid - 1;
    }
  }
  return orient(c[lo], c[lo + 1], p) >= 0;
}

void check_hull(const Triangulation& t, std::span<const Point> points, const EdgeTable& edges,
                const std::vector<std::uint8_t>& used, detail::CpuExecutor& executor, Reporter& report) {
  const auto num_t = static_cast<std::uint32_t>(t.triangles.size());
  if (num_t == 0) {
    report.add("no triangles");
    return;
  }
  const std::size_t num_used = executor.reduce(
      used.size(), std::size_t{0}, [&](std::size_t& c, std::size_t v) { c += used[v]; },
      [](std::size_t& c, std::size_t part) { c += part; });
  const auto euler = static_cast<std::int64_t>(num_used) - static_cast<std::int64_t>(edges.num_edges()) +
                     static_cast<std::int64_t>(num_t);
  if (euler != 1) {
    report.add("Euler characteristic V - E + F = ", num_used, " - ", edges.num_edges(), " + ", num_t, " = ",
               euler, ", not 1: the mesh is not one disc (a hole, or several pieces)");
  }

  // Hull edges run counter-clockwise around the domain, so each vertex starts at most one.
  std::vector<std::uint32_t> hull_next(t.vertices.size(), kNone);
  std::size_t num_hull = 0;
  std::uint32_t start = kNone;
  bool pinched = false;
  const std::vector<std::uint32_t> hull_slots = executor.compact(
      3 * std::size_t{num_t}, [&](std::size_t slot) { return t.neighbors[slot / 3][slot % 3] == kNone; });
  for (const std::uint32_t slot : hull_slots) { // in slot order, as one loop over the triangles
    const auto [p, q] = edge_of(t.triangles[slot / 3], slot % 3);
    ++num_hull;
    start = p;
    if (hull_next[p] != kNone) {
      report.add("vertex ", p, " starts two hull edges (to ", hull_next[p], " and ", q,
                 "): the domain is pinched");
      pinched = true;
    }
    hull_next[p] = q;
  }
  if (num_hull < 3) {
    report.add("only ", num_hull, " hull edges");
    return;
  }
  if (pinched) return;
  std::vector<std::uint32_t> cycle;
  for (std::uint32_t v = start; cycle.size() <= num_hull;) {
    cycle.push_back(v);
    v = hull_next[v];
    if (v == kNone || v == start) break;
  }
  if (cycle.size() != num_hull || hull_next[cycle.back()] != start) {
    report.add("hull edges do not form one closed cycle: the cycle through vertex ", start, " has ",
               cycle.size(), " of the ", num_hull, " hull edges (a hole, or an open boundary)");
    return;
  }

  // Convex: no reflex turn, and a straight turn must go on, not back.
  const std::size_t h = cycle.size();
  std::vector<Point> corners;
  bool convex = true;
  for (std::size_t k = 0; k < h; ++k) {
    const Point& a = t.vertices[cycle[k]];
    const Point& b = t.vertices[cycle[(k + 1) % h]];
    const Point& c = t.vertices[cycle[(k + 2) % h]];
    const int o = orient(a, b, c);
    if (o < 0) {
      report.add("hull is not convex: reflex turn at vertex ", cycle[(k + 1) % h]);
      convex = false;
    } else if (o == 0 && !strictly_between(a, c, b)) {
      report.add("hull folds back at vertex ", cycle[(k + 1) % h]);
      convex = false;
    } else if (o > 0) {
      corners.push_back(b);
    }
  }
  if (!convex) return;
  // With only left turns, the boundary turns around once exactly when x goes up once and down once.
  int changes = 0;
  int first_sign = 0;
  int last_sign = 0;
  for (std::size_t k = 0; k < h; ++k) {
    const double x0 = t.vertices[cycle[k]].x;
    const double x1 = t.vertices[cycle[(k + 1) % h]].x;
    const int sign = (x1 > x0) - (x1 < x0);
    if (sign == 0) continue;
    if (first_sign == 0) first_sign = sign;
    if (last_sign != 0 && sign != last_sign) ++changes;
    last_sign = sign;
  }
  if (last_sign != first_sign) ++changes;
  if (changes != 2 || corners.size() < 3) {
    report.add("hull turns around ", changes / 2, " times, not once");
    return;
  }
  // corners[k] is the vertex after cycle[k]; any rotation is the same polygon.
  check_in_parts(executor, t.vertices.size(), report, [&](std::size_t v, Reporter& found) {
    if (v < points.size() && t.duplicate_of[v] != v) return; // at its representative's place
    if (!inside_convex(corners, t.vertices[v])) found.add("vertex ", v, " lies outside the hull");
  });
}

// --- duplicates and use ------------------------------------------------------------------------------

void check_duplicates(const Triangulation& t, std::span<const Point> points,
                      const std::vector<std::uint8_t>& used, detail::CpuExecutor& executor,
                      Reporter& report) {
  const auto num_points = static_cast<std::uint32_t>(points.size());
  check_in_parts(executor, num_points, report, [&](std::size_t index, Reporter& found) {
    const auto i = static_cast<std::uint32_t>(index);
    const std::uint32_t r = t.duplicate_of[i];
    if (r == i) {
      if (used[i] == 0) found.add("input point ", i, " is used by no triangle");
      return;
    }
    if (t.duplicate_of[r] != r) {
      found.add("duplicate_of[", i, "] = ", r, ", which is not a representative (duplicate_of[", r,
                "] = ", t.duplicate_of[r], ")");
    } else if (!(points[r] == points[i])) {
      found.add("point ", i, " is mapped to ", r, " but their coordinates differ");
    }
    if (used[i] != 0) {
      found.add("duplicate point ", i, " is used by a triangle instead of its representative ", r);
    }
  });
  for (std::size_t v = num_points; v < t.vertices.size(); ++v) {
    if (used[v] == 0) report.add("added vertex ", v, " is used by no triangle");
  }
  // Identical points must share one representative, or the mesh would hold two vertices at one place.
  std::vector<std::uint32_t> order(num_points);
  executor.for_each(num_points, [&](std::size_t i) { order[i] = static_cast<std::uint32_t>(i); });
  executor.sort(order, [&](std::uint32_t i, std::uint32_t j) {
    if (points[i].x != points[j].x) return points[i].x < points[j].x;
    if (points[i].y != points[j].y) return points[i].y < points[j].y;
    return i < j;
  });
  check_in_parts(executor, order.size(), report, [&](std::size_t k, Reporter& found) {
    if (k == 0) return;
    const std::uint32_t i = order[k - 1];
    const std::uint32_t j = order[k];
    if (points[i] == points[j] && t.duplicate_of[i] != t.duplicate_of[j]) {
      found.add("points ", i, " and ", j, " are identical but not merged");
    }
  });
}

// --- segments ----------------------------------------------------------------------------------------

/// The mesh edges around each vertex, sorted counter-clockwise by direction: entry e is the directed
/// edge from(e) -> to(e). Directions are compared exactly: half-plane by coordinate comparisons, then
/// orient2d.
class Adjacency {
public:
  Adjacency(const Triangulation& t, const EdgeTable& edges, detail::CpuExecutor& executor)
      : t_(t), edges_(edges) {
    const std::size_t num_v = t.vertices.size();
    const auto usable = [&](std::size_t g) {
      // A zero-length edge has no direction; its triangle is reported as degenerate already.
      return !(t.vertices[edges.low(g)] == t.vertices[edges.high(g)]);
    };
    // Each edge's two ends, (low, g) then (high, g), in the order of the groups; an unusable edge's
    // ends get the key num_v, sorted past every vertex. A stable sort by vertex then leaves each
    // vertex's entries in the order of their groups, the order of one loop over the groups.
    const std::size_t ends = 2 * edges.num_edges();
    std::vector<std::uint32_t> vertex(ends), group(ends);
    executor.for_each(edges.num_edges(), [&](std::size_t g) {
      const bool ok = usable(g);
      vertex[2 * g] = ok ? edges.low(g) : static_cast<std::uint32_t>(num_v);
      vertex[2 * g + 1] = ok ? edges.high(g) : static_cast<std::uint32_t>(num_v);
      group[2 * g] = group[2 * g + 1] = static_cast<std::uint32_t>(g);
    });
    executor.sort_pairs_by_key(vertex, group, detail::bits_below(num_v + 1));
    // start[v]: the first entry of vertex v (entries of vertices without any start where the next
    // vertex's do).
    std::vector<std::uint32_t> start(num_v + 1);
    const std::size_t n = static_cast<std::size_t>(
        std::lower_bound(vertex.begin(), vertex.end(), static_cast<std::uint32_t>(num_v)) - vertex.begin());
    executor.for_each(n + 1, [&](std::size_t e) {
      const std::size_t from = e == 0 ? 0 : std::size_t{vertex[e - 1]} + 1;
      const std::size_t to = e == n ? num_v : vertex[e];
      for (std::size_t v = from; v <= to; ++v) start[v] = static_cast<std::uint32_t>(e);
    });
    vertex.resize(n);
    from_ = std::move(vertex);
    group.resize(n);
    group_ = std::move(group);
    to_.resize(n);
    executor.for_each(n, [&](std::size_t e) {
      const std::uint32_t g = group_[e];
      to_[e] = from_[e] == edges.low(g) ? edges.high(g) : edges.low(g);
    });
    // Each vertex's entries sorted by direction, the vertices in parallel.
    executor.for_each(num_v, [&](std::size_t v) {
      thread_local std::vector<std::pair<std::uint32_t, std::uint32_t>> scratch;
      scratch.clear();
      for (std::uint32_t e = start[v]; e < start[v + 1]; ++e) scratch.emplace_back(to_[e], group_[e]);
      const Point& c = t.vertices[v];
      std::sort(scratch.begin(), scratch.end(), [&](const auto& a, const auto& b) {
        return before(c, t.vertices[a.first], false, t.vertices[b.first], false);
      });
      for (std::uint32_t e = start[v]; e < start[v + 1]; ++e) {
        to_[e] = scratch[e - start[v]].first;
        group_[e] = scratch[e - start[v]].second;
      }
    });
    start_ = std::move(start);
  }

  std::size_t num_entries() const { return to_.size(); }
  std::uint32_t begin_of(std::uint32_t v) const { return start_[v]; }
  std::uint32_t end_of(std::uint32_t v) const { return start_[v + 1]; }
  std::uint32_t from(std::uint32_t e) const { return from_[e]; }
  std::uint32_t to(std::uint32_t e) const { return to_[e]; }
  bool is_constraint(std::uint32_t e) const {
    const std::uint32_t slot = edges_.entries[edges_.first[group_[e]]].slot;
    return t_.segment_of_edge[slot / 3][slot % 3] != kNone;
  }

  /// The nearest edge leaving v in the direction of target (of v - target when away is set), or kNone.
  std::uint32_t toward(std::uint32_t v, const Point& target, bool away) const {
    const Point& c = t_.vertices[v];
    if (c == target) return kNone;
    const auto begin = to_.begin() + start_[v];
    const auto end = to_.begin() + start_[v + 1];
    // kNone stands for the target direction in the comparisons.
    const auto [lo, hi] = std::equal_range(begin, end, kNone, [&](std::uint32_t a, std::uint32_t b) {
      const Point& pa = a == kNone ? target : t_.vertices[a];
      const Point& pb = b == kNone ? target : t_.vertices[b];
      return before(c, pa, a == kNone && away, pb, b == kNone && away);
    });
    std::uint32_t best = kNone;
    for (auto it = lo; it != hi; ++it) {
      const auto e = static_cast<std::uint32_t>(it - to_.begin());
      if (best == kNone || nearer(c, t_.vertices[to_[e]], t_.vertices[to_[best]])) best = e;
    }
    return best;
  }

private:
  /// Half-plane of direction p - c (c - p when flipped): 0 for angles in [0, pi), 1 for [pi, 2 pi).
  static int half(const Point& c, const Point& p, bool flipped) {
    const bool upper = p.y > c.y || (p.y == c.y && p.x > c.x);
    return upper != flipped ? 0 : 1;
  }
  /// Counter-clockwise angular order of directions from c.
  static bool before(const Point& c, const Point& p, bool p_flipped, const Point& q, bool q_flipped) {
    const int hp = half(c, p, p_flipped);
    const int hq = half(c, q, q_flipped);
    if (hp != hq) return hp < hq;
    return orient(c, p, q) * (p_flipped ? -1 : 1) * (q_flipped ? -1 : 1) > 0;
  }
  /// Of two points on one ray from c, whether p is nearer to c.
  static bool nearer(const Point& c, const Point& p, const Point& q) {
    if (p.x != q.x) return c.x < p.x ? p.x < q.x : p.x > q.x;
    return c.y < p.y ? p.y < q.y : p.y > q.y;
  }

  const Triangulation& t_;
  const EdgeTable& edges_;
  std::vector<std::uint32_t> start_; // vertex v owns entries start_[v] .. start_[v + 1]
  std::vector<std::uint32_t> from_;
  std::vector<std::uint32_t> to_;
  std::vector<std::uint32_t> group_;
};

/// Straight runs of constraint edges: every directed constraint edge e gets the id of its run and its
/// rank along it, so that "is there a straight constraint path from e to f" is one comparison.
class Chains {
public:
  Chains(const Triangulation& t, const Adjacency& adj, detail::CpuExecutor& executor)
      : chain_(adj.num_entries()), rank_(adj.num_entries()) { // written below, in parallel
    const auto n = static_cast<std::uint32_t>(adj.num_entries());
    // Which entries are constraint edges (each a few lookups, done once), and each one's straight
    // continuation.
    detail::UnzeroedVector<std::uint8_t> constraint(n);
    executor.for_each(n, [&](std::size_t e) {
      constraint[e] = adj.is_constraint(static_cast<std::uint32_t>(e)) ? 1 : 0;
      chain_[e] = kNone;
      rank_[e] = 0;
    });
    detail::UnzeroedVector<std::uint32_t> ahead(n);
    detail::UnzeroedVector<std::uint32_t> predecessor(n);
    executor.for_each(n, [&](std::size_t index) {
      const auto e = static_cast<std::uint32_t>(index);
      ahead[e] = kNone;
      predecessor[e] = kNone;
      if (constraint[e] == 0) return;
      const std::uint32_t s = adj.toward(adj.to(e), t.vertices[adj.from(e)], true);
      if (s != kNone && constraint[s] != 0) ahead[e] = s;
    });
    // The first edge (lowest index) to name a continuation takes it.
    executor.for_each(n, [&](std::size_t e) {
      if (ahead[e] != kNone) detail::atomic_min(&predecessor[ahead[e]], static_cast<std::uint32_t>(e));
    });
    const auto successor = [&](std::uint32_t e) {
      const std::uint32_t s = ahead[e];
      return s != kNone && predecessor[s] == e ? s : kNone;
    };
    // Each chain from its first edge: every edge has at most one predecessor, so the chains are
    // disjoint paths, walked in parallel.
    executor.for_each(n, [&](std::size_t index) {
      const auto e = static_cast<std::uint32_t>(index);
      if (constraint[e] == 0 || predecessor[e] != kNone) return;
      std::uint32_t r = 0;
      for (std::uint32_t f = e; f != kNone && chain_[f] == kNone; f = successor(f)) {
        chain_[f] = e;
        rank_[f] = r++;
      }
    });
  }
  /// Whether a straight run of constraint edges starts with edge first and reaches edge last.
  bool connects(std::uint32_t first, std::uint32_t last) const {
    return chain_[first] != kNone && chain_[first] == chain_[last] && rank_[first] <= rank_[last];
  }

private:
  detail::UnzeroedVector<std::uint32_t> chain_;
  detail::UnzeroedVector<std::uint32_t> rank_;
};

/// Walks segment s edge by edge from rep(a) toward rep(b) and reports where the chain of constraint
/// edges breaks. Only run for a failing segment whose message will be kept.
void explain_missing_segment(const Triangulation& t, const Adjacency& adj, std::size_t s, std::uint32_t ra,
                             std::uint32_t rb, Reporter& report) {
  const Point& target = t.vertices[rb];
  std::uint32_t v = ra;
  for (std::size_t steps = 0; v != rb && steps <= t.vertices.size(); ++steps) {
    const std::uint32_t e = adj.toward(v, target, false);
    if (e == kNone) {
      report.add("segment ", s, " (", ra, " -> ", rb, ") is missing: no mesh edge leaves vertex ", v,
                 " toward ", rb);
      return;
    }
    const std::uint32_t w = adj.to(e);
    if (!strictly_between(t.vertices[v], target, t.vertices[w]) && w != rb) {
      report.add("segment ", s, " (", ra, " -> ", rb, ") is missing: edge (", v, ", ", w, ") passes beyond ",
                 rb);
      return;
    }
    if (!adj.is_constraint(e)) {
      report.add("segment ", s, " (", ra, " -> ", rb, "): edge (", v, ", ", w, ") on it is not a constraint");
      return;
    }
    v = w;
  }
  report.add("segment ", s, " (", ra, " -> ", rb, "): its constraint edges do not form one straight chain");
}

/// Finds a segment's chain when it bends. A crossing point rounded to doubles lies a little off both
/// segments it splits (it may even stick out of their extent by an ulp); it may coincide with an input
/// point and reuse it; and the bent pieces can in turn pass exactly through other vertices a few ulps
/// off the segment. So the chain must run from rep(a) to rep(b) along constraint edges through vertices
/// on the segment or within `tolerance` of it (and of its bounding box). Only constraint edges near the
/// segment are explored, so the search stays on the chain and the few constraints touching it.
class BentChainSearch {
public:
  BentChainSearch(const Triangulation& t, const Adjacency& adj, double tolerance)
      : t_(t), adj_(adj), tolerance_(tolerance), stamp_(t.vertices.size(), 0) {}

  bool present(const Point& pa, const Point& pb, std::uint32_t ra, std::uint32_t rb) {
    ++current_;
    const double dx = pb.x - pa.x;
    const double dy = pb.y - pa.y;
    const double reach = tolerance_ * std::max(std::abs(dx), std::abs(dy));
    const double lo_x = std::min(pa.x, pb.x) - tolerance_;
    const double hi_x = std::max(pa.x, pb.x) + tolerance_;
    const double lo_y = std::min(pa.y, pb.y) - tolerance_;
    const double hi_y = std::max(pa.y, pb.y) + tolerance_;
    stack_.assign(1, ra);
    stamp_[ra] = current_;
    while (!stack_.empty()) {
      const std::uint32_t v = stack_.back();
      stack_.pop_back();
      if (v == rb) return true;
      for (std::uint32_t e = adj_.begin_of(v); e < adj_.end_of(v); ++e) {
        const std::uint32_t w = adj_.to(e);
        if (stamp_[w] == current_ || !adj_.is_constraint(e)) continue;
        const Point& q = t_.vertices[w];
        if (q.x < lo_x || q.x > hi_x || q.y < lo_y || q.y > hi_y) continue;
        if (std::abs(dx * (q.y - pa.y) - dy * (q.x - pa.x)) > reach && orient(pa, pb, q) != 0) continue;
        stamp_[w] = current_;
        stack_.push_back(w);
      }
    }
    return false;
  }

private:
  const Triangulation& t_;
  const Adjacency& adj_;
  double tolerance_;
  std::vector<std::uint32_t> stamp_;
  std::vector<std::uint32_t> stack_;
  std::uint32_t current_ = 0;
};

/// How far a bent chain may stray from its segment: 2^10 units of roundoff of the largest coordinate,
/// room for the rounding of crossing points and a few rounds of repairs.
double bend_tolerance(const Triangulation& t, detail::CpuExecutor& executor) {
  const double magnitude = executor.reduce(
      t.vertices.size(), 0.0,
      [&](double& m, std::size_t v) {
        m = std::max({m, std::abs(t.vertices[v].x), std::abs(t.vertices[v].y)});
      },
      [](double& m, double part) { m = std::max(m, part); });
  return 1024.0 * detail::kEpsilon * magnitude;
}

void check_segments(const Triangulation& t, std::span<const Point> points, std::span<const Segment> segments,
                    const Adjacency& adj, detail::CpuExecutor& executor, Reporter& report) {
  const Chains chains(t, adj, executor);
  // Whether each segment lies on one straight chain (in parallel); the others are looked at in order.
  std::vector<std::uint8_t> straight(segments.size(), 0);
  executor.for_each(segments.size(), [&](std::size_t s) {
    const Segment& g = segments[s];
    if (g.a >= points.size() || g.b >= points.size()) return;
    const std::uint32_t ra = t.duplicate_of[g.a];
    const std::uint32_t rb = t.duplicate_of[g.b];
    if (ra == rb) return;
    // The first edge of the chain leaves ra toward rb; the last arrives at rb from ra's side.
    const std::uint32_t first = adj.toward(ra, t.vertices[rb], false);
    const std::uint32_t back = adj.toward(rb, t.vertices[ra], false);
    const std::uint32_t last = back == kNone ? kNone : adj.toward(adj.to(back), t.vertices[rb], false);
    straight[s] = first != kNone && last != kNone && adj.to(last) == rb && chains.connects(first, last) &&
                  orient(points[g.a], points[g.b], t.vertices[adj.to(first)]) == 0;
  });
  BentChainSearch bent(t, adj, bend_tolerance(t, executor));
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const Segment& g = segments[s];
    if (g.a >= points.size() || g.b >= points.size()) {
      report.add("segment ", s, " (", g.a, ", ", g.b, ") refers to a point beyond the ", points.size(),
                 " points");
      continue;
    }
    const std::uint32_t ra = t.duplicate_of[g.a];
    const std::uint32_t rb = t.duplicate_of[g.b];
    if (ra == rb) continue;
    if (straight[s] != 0 || bent.present(points[g.a], points[g.b], ra, rb)) continue;
    if (report.keeping()) {
      explain_missing_segment(t, adj, s, ra, rb, report);
    } else {
      report.tally();
    }
  }
}

// --- Delaunay ----------------------------------------------------------------------------------------

void check_delaunay(const Triangulation& t, detail::CpuExecutor& executor, Reporter& report) {
  const auto num_t = static_cast<std::uint32_t>(t.triangles.size());
  check_in_parts(executor, num_t, report, [&](std::size_t index, Reporter& found) {
    const auto k = static_cast<std::uint32_t>(index);
    const Triangle& tri = t.triangles[k];
    for (std::uint32_t i = 0; i < 3; ++i) {
      std::uint32_t u = kNone;
      std::uint32_t j = 3;
      if (!linked_back(t, k, i, u, j) || u < k) continue;
      if (t.segment_of_edge[k][i] != kNone || t.segment_of_edge[u][j] != kNone) continue;
      // (a, b, c) is tri rotated so that the shared edge is a-b: still counter-clockwise.
      const Point& a = t.vertices[tri[next(i)]];
      const Point& b = t.vertices[tri[prev(i)]];
      const Point& c = t.vertices[tri[i]];
      const Point& d = t.vertices[t.triangles[u][j]];
      if (incircle_perturbed(a.x, a.y, b.x, b.y, c.x, c.y, d.x, d.y) > 0) {
        const bool inside = incircle(a.x, a.y, b.x, b.y, c.x, c.y, d.x, d.y) > 0;
        found.add("edge (", tri[next(i)], ", ", tri[prev(i)], ") between triangles ", k, " and ", u,
                  " is not locally Delaunay: vertex ", t.triangles[u][j],
                  inside ? " lies inside the circumcircle of " : " lies on the circumcircle of ", k,
                  inside ? "" : " and the tie-break among co-circular points keeps the other diagonal");
      }
    }
  });
}

} // namespace

VerifyReport verify(const Triangulation& t, std::span<const Point> points, std::span<const Segment> segments,
                    unsigned threads) {
  VerifyReport result;
  Reporter report(result);
  detail::StepTrace trace("verify");
  // By default every hardware thread for a large mesh and one (no thread started) for a small one;
  // one too when no thread can be had.
  std::optional<detail::CpuExecutor> pool;
  const unsigned wanted = threads != 0 ? threads : t.triangles.size() >= kPartSize ? 0u : 1u;
  if (wanted != 1) {
    try {
      pool.emplace(wanted);
    } catch (const std::system_error&) {
      pool.reset();
    }
  }
  if (!pool) pool.emplace(1);
  detail::CpuExecutor& executor = *pool;
  if (!check_sizes(t, points, segments, executor, report)) return result;
  trace.mark("sizes");
  std::vector<std::uint8_t> used(t.vertices.size(), 0);
  executor.for_each(t.triangles.size(), [&](std::size_t k) {
    // Many triangles share a vertex: the same byte written by several threads, atomically.
    for (std::uint32_t v : t.triangles[k])
      std::atomic_ref<std::uint8_t>(used[v]).store(1, std::memory_order_relaxed);
  });
  trace.mark("used vertices");
  check_orientation(t, executor, report);
  trace.mark("orientation");
  check_links(t, executor, report);
  trace.mark("links");
  const EdgeTable edges = collect_edges(t, executor);
  trace.mark("edge table");
  check_edge_sharing(t, edges, executor, report);
  trace.mark("edge sharing");
  check_hull(t, points, edges, used, executor, report);
  trace.mark("hull");
  check_duplicates(t, points, used, executor, report);
  trace.mark("duplicates");
  const Adjacency adjacency(t, edges, executor);
  trace.mark("adjacency");
  check_segments(t, points, segments, adjacency, executor, report);
  trace.mark("segments");
  check_delaunay(t, executor, report);
  trace.mark("delaunay");
  return result;
}

} // namespace cdt
