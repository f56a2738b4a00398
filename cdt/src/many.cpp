// triangulate_many(): many framed inputs side by side in one triangulation, cut back into one each.
//
// Why the cut is exact: in a framed input every point lies in the bounding box and the box's sides are
// covered by segments, so in the triangulation of the whole the box is a union of triangles whose
// corners are the input's own points (a triangle of three box points lies inside the box, which is
// convex). Every edge inside the box that is no constraint is shared by two of these triangles and is
// locally Delaunay under the one perturbed incircle test, and a triangulation of the box with that
// property is the unique CDT of the input. Translation by whole numbers, checked to be exact, changes
// no predicate and no lexicographic order, so the tie-breaking perturbation is the same too.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <optional>
#include <utility>
#include <vector>

#include "cdt/cdt.hpp"

namespace cdt {
namespace {

struct Box {
  double x0, y0, x1, y1;
};

// Whether the segments lying on one side cover it from lo to hi.
bool covered(std::vector<std::pair<double, double>>& pieces, double lo, double hi) {
  std::sort(pieces.begin(), pieces.end());
  double reach = lo;
  for (const auto& [from, to] : pieces) {
    if (from > reach) return false;
    reach = std::max(reach, to);
  }
  return reach >= hi;
}

// The input's bounding box when the input is framed by it: every side covered by segments (so the four
// corners are points). Anything else, malformed inputs included, gets nullopt and is triangulated on
// its own, which reports what is wrong with it.
std::optional<Box> frame_of(const Input& in) {
  if (in.points.size() < 4 || in.segments.size() < 4) return std::nullopt;
  Box b{in.points[0].x, in.points[0].y, in.points[0].x, in.points[0].y};
  for (const Point& p : in.points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return std::nullopt;
    b.x0 = std::min(b.x0, p.x);
    b.x1 = std::max(b.x1, p.x);
    b.y0 = std::min(b.y0, p.y);
    b.y1 = std::max(b.y1, p.y);
  }
  if (!(b.x0 < b.x1 && b.y0 < b.y1)) return std::nullopt;
  std::vector<std::pair<double, double>> sides[4]; // x = x0, x = x1, y = y0, y = y1
  for (const Segment& s : in.segments) {
    if (s.a >= in.points.size() || s.b >= in.points.size()) return std::nullopt;
    const Point& p = in.points[s.a];
    const Point& q = in.points[s.b];
    const auto along_y = std::minmax(p.y, q.y);
    const auto along_x = std::minmax(p.x, q.x);
    if (p.x == q.x && p.x == b.x0) sides[0].push_back(along_y);
    if (p.x == q.x && p.x == b.x1) sides[1].push_back(along_y);
    if (p.y == q.y && p.y == b.y0) sides[2].push_back(along_x);
    if (p.y == q.y && p.y == b.y1) sides[3].push_back(along_x);
  }
  if (!covered(sides[0], b.y0, b.y1) || !covered(sides[1], b.y0, b.y1) || !covered(sides[2], b.x0, b.x1) ||
      !covered(sides[3], b.x0, b.x1)) {
    return std::nullopt;
  }
  return b;
}

// a + b without rounding (the error term of Knuth's TwoSum is zero).
bool adds_exactly(double a, double b) {
  const double s = a + b;
  const double bv = s - a;
  const double av = s - bv;
  return (a - av) + (b - bv) == 0.0;
}

std::size_t zero_length_segments(const Input& in) {
  std::size_t n = 0;
  for (const Segment& s : in.segments) n += s.a == s.b || in.points[s.a] == in.points[s.b];
  return n;
}

ManyResult alone(const Input& in, const Options& options) {
  ManyResult r;
  try {
    r.triangulation = triangulate(in.points, in.segments, options);
  } catch (...) {
    r.error = std::current_exception();
  }
  return r;
}

struct Placed {
  std::size_t input; // index into the inputs
  double dx = 0.0;   // its translation
  double dy = 0.0;
  std::uint32_t first_point = 0;
  std::uint32_t first_segment = 0;
};

// Triangulates the placed inputs together and cuts the result into theirs; false (and nothing written)
// when the result cannot be cut, or when some input gained vertices at crossings.
bool together(std::span<const Input> inputs, const std::vector<Placed>& placed, const Options& options,
              std::vector<ManyResult>& out, std::vector<std::size_t>& redo) {
  std::vector<Point> points;
  std::vector<Segment> segments;
  const Placed& last = placed.back();
  points.reserve(last.first_point + inputs[last.input].points.size());
  segments.reserve(last.first_segment + inputs[last.input].segments.size());
  for (const Placed& p : placed) {
    const Input& in = inputs[p.input];
    for (const Point& q : in.points) points.push_back({q.x + p.dx, q.y + p.dy});
    for (const Segment& s : in.segments) segments.push_back({s.a + p.first_point, s.b + p.first_point});
  }
  Triangulation whole;
  try {
    whole = triangulate(points, segments, options);
  } catch (...) {
    return false;
  }
  const std::size_t num_points = points.size();
  const std::size_t k = placed.size();
  std::vector<std::uint32_t> owner(whole.vertices.size(), kNone);
  for (std::uint32_t j = 0; j < k; ++j) {
    const std::size_t end = j + 1 < k ? placed[j + 1].first_point : num_points;
    std::fill(owner.begin() + placed[j].first_point, owner.begin() + static_cast<std::ptrdiff_t>(end), j);
  }

  // Each triangle's input: the one of its input-point corners; kNone for the triangles between frames
  // (corners of different inputs).
  const std::size_t num_triangles = whole.triangles.size();
  std::vector<std::uint32_t> tri_owner(num_triangles, kNone);
  std::vector<char> gained(k, 0);
  for (std::size_t t = 0; t < num_triangles; ++t) {
    std::uint32_t o = kNone;
    bool mixed = false;
    bool added = false;
    for (const std::uint32_t v : whole.triangles[t]) {
      if (v >= num_points) {
        added = true;
        continue;
      }
      if (o == kNone) o = owner[v];
      mixed |= owner[v] != o;
    }
    if (o == kNone) return false; // corners all added at crossings: each input is triangulated alone
    if (mixed) {
      if (added) return false;
      continue;
    }
    if (added) gained[o] = 1;
    tri_owner[t] = o;
  }

  // Cut: each input's triangles, renumbered in their order in the whole.
  std::vector<std::uint32_t> local(num_triangles, kNone);
  std::vector<std::uint32_t> count(k, 0);
  for (std::size_t t = 0; t < num_triangles; ++t) {
    if (tri_owner[t] != kNone) local[t] = count[tri_owner[t]]++;
  }
  for (std::uint32_t j = 0; j < k; ++j) {
    const Placed& p = placed[j];
    const Input& in = inputs[p.input];
    if (gained[j]) {
      redo.push_back(p.input);
      continue;
    }
    Triangulation& t = out[p.input].triangulation;
    t.vertices.assign(in.points.begin(), in.points.end());
    t.duplicate_of.resize(in.points.size());
    for (std::size_t i = 0; i < in.points.size(); ++i)
      t.duplicate_of[i] = whole.duplicate_of[p.first_point + i] - p.first_point;
    t.triangles.resize(count[j]);
    t.neighbors.resize(count[j]);
    t.segment_of_edge.resize(count[j]);
    t.stats = whole.stats;
    t.stats.inputs = static_cast<std::uint32_t>(k);
    t.stats.added_vertices = 0;
    t.stats.zero_length_segments = zero_length_segments(in);
  }
  for (std::size_t t = 0; t < num_triangles; ++t) {
    const std::uint32_t j = tri_owner[t];
    if (j == kNone || gained[j]) continue;
    const Placed& p = placed[j];
    Triangulation& r = out[p.input].triangulation;
    const std::uint32_t at = local[t];
    for (int e = 0; e < 3; ++e) {
      r.triangles[at][e] = whole.triangles[t][e] - p.first_point;
      const std::uint32_t n = whole.neighbors[t][e];
      r.neighbors[at][e] = n != kNone && tri_owner[n] == j ? local[n] : kNone;
      const std::uint32_t s = whole.segment_of_edge[t][e];
      r.segment_of_edge[at][e] = s == kNone ? kNone : s - p.first_segment;
    }
  }
  return true;
}

} // namespace

std::vector<ManyResult> triangulate_many(std::span<const Input> inputs, const Options& options) {
  std::vector<ManyResult> out(inputs.size());
  std::vector<std::size_t> framed;
  std::vector<Box> boxes;
  std::vector<std::size_t> redo;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const std::optional<Box> box = frame_of(inputs[i]);
    if (box) {
      framed.push_back(i);
      boxes.push_back(*box);
    } else {
      redo.push_back(i);
    }
  }
  if (framed.size() < 2) {
    redo.insert(redo.end(), framed.begin(), framed.end());
    framed.clear();
  }
  if (!framed.empty()) {
    // Cells of whole-number size on a near-square grid, one frame in each; every frame is moved by
    // whole numbers to its cell, which it ends strictly before the next cell begins.
    double width = 0.0;
    double height = 0.0;
    for (const Box& b : boxes) {
      width = std::max(width, std::ceil(b.x1 - b.x0) + 1.0);
      height = std::max(height, std::ceil(b.y1 - b.y0) + 1.0);
    }
    const auto columns = static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(framed.size()))));
    std::vector<Placed> placed;
    std::uint32_t num_points = 0;
    std::uint32_t num_segments = 0;
    for (std::size_t f = 0; f < framed.size(); ++f) {
      const Input& in = inputs[framed[f]];
      const Box& b = boxes[f];
      Placed p{framed[f]};
      const double column = static_cast<double>(f % columns), row = static_cast<double>(f / columns);
      p.dx = column * width - std::floor(b.x0);
      p.dy = row * height - std::floor(b.y0);
      bool exact = std::isfinite(p.dx) && std::isfinite(p.dy) && in.points.size() + num_points < kNone / 2 &&
                   in.segments.size() + num_segments < kNone / 2;
      for (std::size_t i = 0; exact && i < in.points.size(); ++i)
        exact = adds_exactly(in.points[i].x, p.dx) && adds_exactly(in.points[i].y, p.dy);
      // Its cell holds it, ending strictly before the next cell's start as that cell computes it: past
      // 2^53 the cells' margin of 1 rounds away, and frames would touch.
      exact = exact && b.x0 + p.dx >= column * width && b.x1 + p.dx < (column + 1.0) * width &&
              b.y0 + p.dy >= row * height && b.y1 + p.dy < (row + 1.0) * height;
      if (!exact) {
        redo.push_back(framed[f]);
        continue;
      }
      p.first_point = num_points;
      p.first_segment = num_segments;
      num_points += static_cast<std::uint32_t>(in.points.size());
      num_segments += static_cast<std::uint32_t>(in.segments.size());
      placed.push_back(p);
    }
    if (placed.size() < 2 || !together(inputs, placed, options, out, redo)) {
      for (const Placed& p : placed) redo.push_back(p.input);
    }
  }
  std::sort(redo.begin(), redo.end());
  redo.erase(std::unique(redo.begin(), redo.end()), redo.end());
  for (const std::size_t i : redo) out[i] = alone(inputs[i], options);
  return out;
}

} // namespace cdt
