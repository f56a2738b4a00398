// Triangle-for-triangle equality with CGAL's constrained Delaunay triangulation on inputs in general
// position (random doubles), where the CDT is unique.
#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>
#include <vector>

#include "cdt/cdt.hpp"
#include "pslg_generators.hpp"

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_2<std::uint32_t, K>;
using Fb = CGAL::Constrained_triangulation_face_base_2<K>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<K, Tds, CGAL::Exact_predicates_tag>;

using TriangleSet = std::vector<std::array<std::uint32_t, 3>>;

std::array<std::uint32_t, 3> canonical(std::array<std::uint32_t, 3> t) {
  std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end()); // keeps the orientation
  return t;
}

TriangleSet cgal_triangles(const trixel_gen::Pslg& in) {
  Cdt cdt;
  std::vector<Cdt::Vertex_handle> handles;
  for (std::uint32_t i = 0; i < in.points.size(); ++i) {
    handles.push_back(cdt.insert(K::Point_2(in.points[i].x, in.points[i].y)));
    handles.back()->info() = i;
  }
  for (const auto& s : in.segments) cdt.insert_constraint(handles[s.a], handles[s.b]);
  TriangleSet out;
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    out.push_back(canonical({f->vertex(0)->info(), f->vertex(1)->info(), f->vertex(2)->info()}));
  }
  std::sort(out.begin(), out.end());
  return out;
}

TriangleSet our_triangles(const trixel_gen::Pslg& in) {
  const cdt::Triangulation t = cdt::triangulate(in.points, in.segments);
  TriangleSet out;
  for (const auto& tri : t.triangles) out.push_back(canonical(tri));
  std::sort(out.begin(), out.end());
  return out;
}

TEST(TriangulateCgal, PointsOnlyMatchCgal) {
  for (std::size_t n : {10u, 100u, 1000u, 10000u, 100000u}) {
    const auto in = trixel_gen::random_points(n, trixel_gen::Distribution::uniform, 100 + n);
    EXPECT_EQ(our_triangles(in), cgal_triangles(in)) << n << " points";
  }
}

TEST(TriangulateCgal, PointsAndSegmentsMatchCgal) {
  for (std::size_t n : {100u, 1000u, 10000u, 100000u}) {
    const auto in = trixel_gen::synthetic_pslg(n, n / 10, trixel_gen::Distribution::uniform, 200 + n);
    EXPECT_EQ(our_triangles(in), cgal_triangles(in)) << n << " points, " << in.segments.size() << " segments";
  }
}

} // namespace
