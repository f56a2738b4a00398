#pragma once
// A triangulation's triangles as a list that depends on the triangle set alone: each triangle's
// corners as coordinates (so that vertices numbered differently, such as those added at crossings,
// compare by where they are), rotated to start at the lexicographically first corner, the list sorted.

#include <algorithm>
#include <array>
#include <vector>

#include "cdt/cdt.hpp"

namespace trixel_test {

using Corner = std::array<double, 2>;
using TriangleCorners = std::array<Corner, 3>;

inline std::vector<TriangleCorners> canonical_triangles(const cdt::Triangulation& t) {
  std::vector<TriangleCorners> out;
  out.reserve(t.triangles.size());
  for (const auto& tri : t.triangles) {
    TriangleCorners c;
    for (int i = 0; i < 3; ++i) c[i] = {t.vertices[tri[i]].x, t.vertices[tri[i]].y};
    std::rotate(c.begin(), std::min_element(c.begin(), c.end()), c.end());
    out.push_back(c);
  }
  std::sort(out.begin(), out.end());
  return out;
}

} // namespace trixel_test
