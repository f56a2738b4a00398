#pragma once
// Helpers the stage tests share: images made from a colour function, the CDT of points in a framed
// rectangle, and the exact check that two segments of a polyline or PSLG meet where they should not.

#include <algorithm>
#include <array>
#include <cstddef>
#include <functional>
#include <utility>
#include <vector>

#include "cdt/cdt.hpp"
#include "cdt/detail/predicates.hpp"
#include "vectorize/image.hpp"

namespace trixel_test {

/// A width x height RGBA image whose pixel (x, y) is colour(x, y).
inline vectorize::Image make_image(int width, int height,
                                   const std::function<std::array<float, 4>(int, int)>& colour) {
  vectorize::Image image;
  image.width = width;
  image.height = height;
  image.source_channels = 4;
  image.rgba.resize(static_cast<std::size_t>(width) * height * 4);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const auto c = colour(x, y);
      for (int k = 0; k < 4; ++k) image.pixel(x, y)[k] = c[k];
    }
  return image;
}

/// The CDT (CPU backend, one thread) of the points and segments with the rectangle [0, width] x
/// [0, height] as its frame: its corners after the points, its sides as segments after the segments.
inline cdt::Triangulation triangulate_rectangle(double width, double height, std::vector<cdt::Point> points,
                                                std::vector<cdt::Segment> segments = {}) {
  const auto base = static_cast<std::uint32_t>(points.size());
  points.push_back({0, 0});
  points.push_back({width, 0});
  points.push_back({width, height});
  points.push_back({0, height});
  for (std::uint32_t i = 0; i < 4; ++i) segments.push_back({base + i, base + (i + 1) % 4});
  cdt::Options options;
  options.backend = cdt::Backend::cpu;
  options.threads = 1;
  return cdt::triangulate(points, segments, options);
}

/// Exact orientation of three points of any type with x and y.
template <class P>
int orient(const P& a, const P& b, const P& c) {
  return cdt::detail::orient2d(a.x, a.y, b.x, b.y, c.x, c.y);
}

/// p within the bounding box of ab (for p collinear with a and b: on the segment).
template <class P>
bool on_box(const P& a, const P& b, const P& p) {
  return std::min(a.x, b.x) <= p.x && p.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= p.y &&
         p.y <= std::max(a.y, b.y);
}

/// Segments ab and cd meet somewhere other than at a shared end (or are the same segment).
template <class P>
bool improper(P a, P b, P c, P d) {
  const int shared = (a == c || a == d) + (b == c || b == d);
  if (shared == 2) return true;
  if (shared == 1) {
    if (a == d || b == d) std::swap(c, d);
    if (b == c) std::swap(a, b);
    return orient(a, b, d) == 0 && (b.x - a.x) * (d.x - a.x) + (b.y - a.y) * (d.y - a.y) > 0;
  }
  const int o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  return (o1 == 0 && on_box(a, b, c)) || (o2 == 0 && on_box(a, b, d)) || (o3 == 0 && on_box(c, d, a)) ||
         (o4 == 0 && on_box(c, d, b));
}

} // namespace trixel_test
