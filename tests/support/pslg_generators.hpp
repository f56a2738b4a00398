#pragma once
// Input generators for tests and benchmarks, deterministic for a seed (splitmix64; no std::random
// distributions, whose output differs between standard libraries).
//
// synthetic_pslg follows the paper's experiments (section 5.1): random non-crossing constraints of
// many lengths first, then random points that lie on no constraint.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "cdt/cdt.hpp"
#include "cdt/detail/predicates.hpp"

namespace trixel_gen {

class Random {
public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform integer in [lo, hi].
  std::int64_t range(std::int64_t lo, std::int64_t hi) {
    return lo + static_cast<std::int64_t>(next() % static_cast<std::uint64_t>(hi - lo + 1));
  }
  /// Uniform in [0, 1).
  double unit() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
  /// Standard normal (Box-Muller).
  double normal() {
    const double u = std::max(unit(), 1e-300);
    return std::sqrt(-2.0 * std::log(u)) * std::cos(6.283185307179586 * unit());
  }

private:
  std::uint64_t state_;
};

enum class Distribution { uniform, gaussian };

struct Pslg {
  std::vector<cdt::Point> points;
  std::vector<cdt::Segment> segments;
};

inline cdt::Point random_point(Random& rng, Distribution d) {
  if (d == Distribution::uniform) return {rng.unit(), rng.unit()};
  // Gaussian around the centre, clipped into the unit square.
  const auto clip = [](double v) { return std::clamp(v, 0.0, 1.0 - 1e-12); };
  return {clip(0.5 + 0.15 * rng.normal()), clip(0.5 + 0.15 * rng.normal())};
}

inline Pslg random_points(std::size_t n, Distribution d, std::uint64_t seed) {
  Random rng(seed);
  Pslg p;
  p.points.reserve(n);
  for (std::size_t i = 0; i < n; ++i) p.points.push_back(random_point(rng, d));
  return p;
}

/// k x k integer lattice (co-circular everywhere).
inline Pslg lattice(std::uint32_t k) {
  Pslg p;
  for (std::uint32_t y = 0; y < k; ++y)
    for (std::uint32_t x = 0; x < k; ++x) p.points.push_back({double(x), double(y)});
  return p;
}

/// Points in `clusters` tight Gaussian blobs.
inline Pslg clustered(std::size_t n, std::uint32_t clusters, std::uint64_t seed) {
  Random rng(seed);
  std::vector<cdt::Point> centres(clusters);
  for (auto& c : centres) c = {rng.unit(), rng.unit()};
  Pslg p;
  for (std::size_t i = 0; i < n; ++i) {
    const cdt::Point& c = centres[i % clusters];
    p.points.push_back({c.x + 0.01 * rng.normal(), c.y + 0.01 * rng.normal()});
  }
  return p;
}

namespace detail {

inline bool segments_cross_or_touch(const cdt::Point& a, const cdt::Point& b, const cdt::Point& c,
                                    const cdt::Point& d) {
  using cdt::detail::orient2d;
  const int o1 = orient2d(a.x, a.y, b.x, b.y, c.x, c.y), o2 = orient2d(a.x, a.y, b.x, b.y, d.x, d.y);
  const int o3 = orient2d(c.x, c.y, d.x, d.y, a.x, a.y), o4 = orient2d(c.x, c.y, d.x, d.y, b.x, b.y);
  if (o1 * o2 > 0 || o3 * o4 > 0) return false;
  if (o1 == 0 && o2 == 0) { // collinear: overlapping extents?
    const auto lo = [](double p, double q) { return std::min(p, q); };
    const auto hi = [](double p, double q) { return std::max(p, q); };
    return lo(a.x, b.x) <= hi(c.x, d.x) && lo(c.x, d.x) <= hi(a.x, b.x) && lo(a.y, b.y) <= hi(c.y, d.y) &&
           lo(c.y, d.y) <= hi(a.y, b.y);
  }
  return true;
}

/// Uniform grid over the unit square listing the segments that pass near each cell.
class SegmentGrid {
public:
  explicit SegmentGrid(std::uint32_t side) : side_(side), cells_(static_cast<std::size_t>(side) * side) {}
  /// Calls f once for every cell near the segment a-b: the cells of samples a quarter cell apart and
  /// their 3 x 3 neighbourhoods, a superset of the cells the segment passes through.
  template <class F>
  void for_cells(const cdt::Point& a, const cdt::Point& b, F&& f) const {
    std::vector<std::size_t> seen;
    any_sample(a, b, [&](std::int64_t cx, std::int64_t cy) {
      for (std::int64_t y = std::max<std::int64_t>(0, cy - 1); y <= std::min<std::int64_t>(side_ - 1, cy + 1);
           ++y)
        for (std::int64_t x = std::max<std::int64_t>(0, cx - 1);
             x <= std::min<std::int64_t>(side_ - 1, cx + 1); ++x)
          seen.push_back(static_cast<std::size_t>(y) * side_ + static_cast<std::size_t>(x));
      return false;
    });
    std::sort(seen.begin(), seen.end());
    seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
    for (std::size_t c : seen) f(c);
  }
  /// Whether pred(c) holds for a cell c that the segment a-b passes through, sampled a quarter cell
  /// apart (no neighbourhoods, so it may miss a cell the segment clips); stops at the first one. A
  /// cheap first test: a crossing found here is certain, none found is settled by for_cells.
  template <class Pred>
  bool any_sampled_cell(const cdt::Point& a, const cdt::Point& b, Pred&& pred) const {
    std::size_t last = static_cast<std::size_t>(-1);
    return any_sample(a, b, [&](std::int64_t cx, std::int64_t cy) {
      const std::size_t c = static_cast<std::size_t>(cy) * side_ + static_cast<std::size_t>(cx);
      if (c == last) return false;
      last = c;
      return static_cast<bool>(pred(c));
    });
  }
  /// The cell holding point q.
  std::size_t cell_of(const cdt::Point& q) const {
    return static_cast<std::size_t>(coordinate_cell(q.y)) * side_ +
           static_cast<std::size_t>(coordinate_cell(q.x));
  }
  std::vector<std::uint32_t>& at(std::size_t c) { return cells_[c]; }
  const std::vector<std::uint32_t>& at(std::size_t c) const { return cells_[c]; }

private:
  /// Calls f(cx, cy) for the cells of samples of the segment a-b a quarter cell apart, in order, until
  /// it returns true; returns whether it did.
  template <class F>
  bool any_sample(const cdt::Point& a, const cdt::Point& b, F&& f) const {
    const double length = std::hypot(b.x - a.x, b.y - a.y);
    const auto steps = static_cast<std::size_t>(std::ceil(length * side_ * 4)) + 1;
    for (std::size_t k = 0; k <= steps; ++k) {
      const double t = static_cast<double>(k) / static_cast<double>(steps);
      if (f(coordinate_cell(a.x + t * (b.x - a.x)), coordinate_cell(a.y + t * (b.y - a.y)))) return true;
    }
    return false;
  }
  std::int64_t coordinate_cell(double v) const {
    return static_cast<std::int64_t>(std::min<double>(side_ - 1, std::max(0.0, v * side_)));
  }

  std::uint32_t side_;
  std::vector<std::vector<std::uint32_t>> cells_;
};

} // namespace detail

/// The paper's synthetic PSLG: num_segments random non-crossing segments whose lengths spread over
/// three orders of magnitude (log-uniform from 1e-4 to 0.1 of the unit square, with a few up to 0.5),
/// then num_points - 2 * num_segments further random points on no segment.
inline Pslg synthetic_pslg(std::size_t num_points, std::size_t num_segments, Distribution d,
                           std::uint64_t seed) {
  Random rng(seed);
  Pslg p;
  const auto side =
      static_cast<std::uint32_t>(std::clamp<double>(std::sqrt(double(num_segments) * 2), 16, 2048));
  detail::SegmentGrid grid(side);
  std::size_t attempts = 0;
  while (p.segments.size() < num_segments && attempts < 50 * num_segments + 1000) {
    ++attempts;
    const cdt::Point a = random_point(rng, d);
    const double length = rng.unit() < 0.01 ? 0.1 + 0.4 * rng.unit() : 1e-4 * std::pow(1000.0, rng.unit());
    const double angle = 6.283185307179586 * rng.unit();
    const cdt::Point b{a.x + length * std::cos(angle), a.y + length * std::sin(angle)};
    if (b.x < 0 || b.x >= 1 || b.y < 0 || b.y >= 1) continue;
    // Most long candidates cross something on their way: find that cheaply before the full check.
    const auto crosses_in = [&](std::size_t c) {
      for (std::uint32_t s : grid.at(c)) {
        const auto& q = p.segments[s];
        if (detail::segments_cross_or_touch(a, b, p.points[q.a], p.points[q.b])) return true;
      }
      return false;
    };
    if (grid.any_sampled_cell(a, b, crosses_in)) continue;
    bool ok = true;
    grid.for_cells(a, b, [&](std::size_t c) {
      if (ok && crosses_in(c)) ok = false;
    });
    if (!ok) continue;
    const auto ia = static_cast<std::uint32_t>(p.points.size());
    p.points.push_back(a);
    p.points.push_back(b);
    const auto id = static_cast<std::uint32_t>(p.segments.size());
    p.segments.push_back({ia, ia + 1});
    grid.for_cells(a, b, [&](std::size_t c) { grid.at(c).push_back(id); });
  }
  while (p.points.size() < num_points) {
    const cdt::Point q = random_point(rng, d);
    // A segment through q passes through q's own cell, which lists it: no neighbours to check.
    bool on_segment = false;
    for (std::uint32_t s : grid.at(grid.cell_of(q))) {
      const auto& g = p.segments[s];
      const cdt::Point &a = p.points[g.a], &b = p.points[g.b];
      if (cdt::detail::orient2d(a.x, a.y, b.x, b.y, q.x, q.y) == 0) on_segment = true;
    }
    if (!on_segment) p.points.push_back(q);
  }
  return p;
}

/// `tries` segments between random points of p, less those whose two points are the same: long
/// segments that cross many others.
inline void add_random_segments(Pslg& p, std::size_t tries, Random& rng) {
  for (std::size_t k = 0; k < tries; ++k) {
    const auto a = static_cast<std::uint32_t>(rng.next() % p.points.size());
    const auto b = static_cast<std::uint32_t>(rng.next() % p.points.size());
    if (a != b) p.segments.push_back({a, b});
  }
}

/// k x k lattice with random segments between lattice points (crossings and overlaps included).
inline Pslg lattice_with_segments(std::uint32_t k, std::size_t num_segments, std::uint64_t seed) {
  Random rng(seed);
  Pslg p = lattice(k);
  for (std::size_t s = 0; s < num_segments; ++s) {
    const auto a = static_cast<std::uint32_t>(rng.next() % p.points.size());
    const std::uint32_t dx = static_cast<std::uint32_t>(rng.next() % 5),
                        dy = static_cast<std::uint32_t>(rng.next() % 5);
    const std::uint32_t ax = a % k, ay = a / k;
    const std::uint32_t bx = std::min(k - 1, ax + dx), by = std::min(k - 1, ay + dy);
    const std::uint32_t b = by * k + bx;
    if (a != b) p.segments.push_back({a, b});
  }
  return p;
}

// A frame [0, w] x [0, h]: its corners and its sides, each side split at `cuts` points on it.
inline void add_frame(Pslg& p, double w, double h, int cuts) {
  const auto side = [&](cdt::Point from, cdt::Point to) {
    auto previous = static_cast<std::uint32_t>(p.points.size());
    p.points.push_back(from);
    for (int c = 1; c <= cuts; ++c) {
      const double t = static_cast<double>(c) / (cuts + 1);
      p.points.push_back(
          {std::floor(from.x + t * (to.x - from.x)), std::floor(from.y + t * (to.y - from.y))});
      const auto at = static_cast<std::uint32_t>(p.points.size() - 1);
      p.segments.push_back({previous, at});
      previous = at;
    }
    p.points.push_back(to);
    p.segments.push_back({previous, static_cast<std::uint32_t>(p.points.size() - 1)});
  };
  side({0, 0}, {w, 0});
  side({w, 0}, {w, h});
  side({w, h}, {0, h});
  side({0, h}, {0, 0});
}

// Pixel centres of a w x h image, some of them, with horizontal and vertical runs between them as
// segments, inside a frame: the kind of PSLG
// the vectorizer makes.
inline Pslg framed_pixels(int w, int h, std::uint64_t seed, int cuts = 2) {
  Random rng(seed);
  Pslg p;
  std::vector<std::int64_t> index(static_cast<std::size_t>(w) * h, -1);
  const auto point = [&](int x, int y) {
    std::int64_t& i = index[static_cast<std::size_t>(y) * w + x];
    if (i < 0) {
      i = static_cast<std::int64_t>(p.points.size());
      p.points.push_back({x + 0.5, y + 0.5});
    }
    return static_cast<std::uint32_t>(i);
  };
  for (int k = 0; k < w * h / 6; ++k)
    point(static_cast<int>(rng.next() % w), static_cast<int>(rng.next() % h));
  for (int k = 0; k < w * h / 40; ++k) {
    const int x = static_cast<int>(rng.next() % w);
    const int y = static_cast<int>(rng.next() % h);
    const int run = 1 + static_cast<int>(rng.next() % 6);
    const bool horizontal = rng.next() % 2 == 0;
    // Unit steps, so that where runs cross there is a point: no vertex is added.
    for (int s = 0; s < run; ++s) {
      const int x1 = horizontal ? x + s : x;
      const int y1 = horizontal ? y : y + s;
      const int x2 = horizontal ? x1 + 1 : x1;
      const int y2 = horizontal ? y1 : y1 + 1;
      if (x2 < w && y2 < h) p.segments.push_back({point(x1, y1), point(x2, y2)});
    }
  }
  add_frame(p, w, h, cuts);
  return p;
}

/// Up to 200 points near (base, base) and (base, -base), base 1, 1e15 or 1e-15: within 8 units in the
/// last place, within 1e-12 or 1e-6 relatively, or anywhere in the square of side 4 base; with up to
/// 80 random segments among them: crossings whose rounded points land near other pieces and sites.
inline Pslg nearly_overlapping(std::uint64_t seed) {
  Random rng(seed);
  Pslg in;
  const auto n = static_cast<std::size_t>(rng.range(6, 200));
  const double base = std::array<double, 3>{1.0, 1e15, 1e-15}[rng.range(0, 2)];
  const auto near = [&](double v) {
    for (std::int64_t steps = rng.range(-8, 8); steps != 0; steps += steps > 0 ? -1 : 1)
      v = std::nextafter(v, steps > 0 ? 2 * std::abs(v) : -2 * std::abs(v));
    return v;
  };
  const auto jitter = [&](double scale) { return (2 * rng.unit() - 1) * 1e-12 * scale; };
  for (std::size_t i = 0; i < n; ++i) {
    const double side = rng.range(0, 1) ? base : -base;
    switch (rng.range(0, 3)) {
    case 0:
    case 1:
      in.points.push_back({near(base), near(side)});
      break;
    case 2:
      in.points.push_back({base * (1 + jitter(rng.range(0, 1) ? 1 : 1e6)), side * (1 + jitter(1))});
      break;
    default:
      in.points.push_back({base * (4 * rng.unit() - 2), base * (4 * rng.unit() - 2)});
    }
  }
  add_random_segments(in, static_cast<std::size_t>(rng.range(2, 80)), rng);
  return in;
}

} // namespace trixel_gen
