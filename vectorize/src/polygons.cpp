// Stage 9: region boundaries. Each ring follows boundary edges (region on the left); at a vertex the
// walk turns to the next boundary edge of the same region counter-clockwise, rotating through the
// triangles outside the region, so that pinch vertices split rings instead of joining them.

#include "vectorize/polygons.hpp"

#include <array>
#include <cstddef>
#include <utility>

namespace vectorize {
namespace {

std::uint32_t slot_of(const std::array<std::uint32_t, 3>& triangle, std::uint32_t vertex) {
  return triangle[0] == vertex ? 0u : triangle[1] == vertex ? 1u : 2u;
}

class Tracer {
public:
  // hull_out: each hull vertex's outgoing hull edge's triangle (see trace_polygons).
  Tracer(const cdt::Triangulation& t, const std::vector<std::uint32_t>& region,
         const std::vector<std::uint32_t>& hull_out)
      : t_(t), region_(region), hull_out_(hull_out) {}

  // The boundary edge (triangle, edge index) that follows boundary edge `edge` of `tri`, at its end
  // vertex c[edge + 2].
  std::pair<std::uint32_t, std::uint32_t> next(std::uint32_t tri, std::uint32_t edge) const {
    const std::uint32_t region = region_[tri];
    const std::uint32_t vertex = t_.triangles[tri][(edge + 2) % 3];
    std::uint32_t current = tri;
    std::uint32_t slot = (edge + 2) % 3;
    // Rotate counter-clockwise around the vertex: leave each triangle through its edge
    // c[slot + 2] - c[slot], which is edge index slot + 1. Beyond the hull, come back in through the
    // vertex's outgoing hull edge.
    for (;;) {
      std::uint32_t across = t_.neighbors[current][(slot + 1) % 3];
      if (across == cdt::kNone) across = hull_out_[vertex];
      const std::uint32_t across_slot = slot_of(t_.triangles[across], vertex);
      if (region_[across] == region) return {across, (across_slot + 2) % 3};
      current = across;
      slot = across_slot;
    }
  }

private:
  const cdt::Triangulation& t_;
  const std::vector<std::uint32_t>& region_;
  const std::vector<std::uint32_t>& hull_out_;
};

} // namespace

std::vector<RegionPolygon> trace_polygons(const cdt::Triangulation& t, const Regions& regions,
                                          TransparentRegions transparent) {
  const std::vector<std::uint32_t>& region_of = regions.region_of_triangle;
  std::vector<RegionPolygon> by_region(regions.regions.size());
  for (std::uint32_t r = 0; r < by_region.size(); ++r) by_region[r].region = r;

  // The hull edge c[i+1] -> c[i+2] has the domain on its left; the domain is convex, so each hull
  // vertex starts exactly one of them. Found in the pass for the boundary edges, which hull edges are.
  std::vector<std::uint32_t> hull_out(t.vertices.size(), cdt::kNone);
  const Tracer tracer(t, region_of, hull_out);
  // Each triangle's boundary edges (bits 0-2) and those walked (bits 3-5); and the boundary edges by
  // the vertex they start at (tri * 3 + edge, grouped by vertex): where a region leaves a vertex by one
  // boundary edge only (everywhere but at its pinches), that edge follows the region's boundary edge
  // that ends there, found without walking round the vertex through the triangles outside the region
  // (the walk's scattered reads were most of this stage).
  const std::size_t n = t.triangles.size();
  std::vector<std::uint8_t> flags(n, 0);
  std::vector<std::uint32_t> first_leaving(t.vertices.size() + 1, 0);
  for (std::uint32_t tri = 0; tri < n; ++tri)
    for (std::uint32_t edge = 0; edge < 3; ++edge) {
      const std::uint32_t other = t.neighbors[tri][edge];
      const std::uint32_t from = t.triangles[tri][(edge + 1) % 3];
      if (other == cdt::kNone) hull_out[from] = tri;
      if (other == cdt::kNone || region_of[other] != region_of[tri]) {
        flags[tri] |= static_cast<std::uint8_t>(1u << edge);
        ++first_leaving[from + 1];
      }
    }
  for (std::size_t v = 0; v + 1 < first_leaving.size(); ++v) first_leaving[v + 1] += first_leaving[v];
  // Each leaving edge with its triangle's region and its end vertex, so that the walk reads one run of
  // these per vertex and neither the triangles nor their regions.
  struct Leaving {
    std::uint32_t edge; // tri * 3 + edge index
    std::uint32_t region;
    std::uint32_t end; // the vertex it ends at
  };
  std::vector<Leaving> leaving(first_leaving.back());
  {
    std::vector<std::uint32_t> cursor(first_leaving.begin(), first_leaving.end() - 1);
    for (std::uint32_t tri = 0; tri < n; ++tri)
      for (std::uint32_t edge = 0; edge < 3; ++edge)
        if ((flags[tri] >> edge) & 1u) {
          const std::uint32_t end = t.triangles[tri][(edge + 2) % 3];
          leaving[cursor[t.triangles[tri][(edge + 1) % 3]]++] = {3 * tri + edge, region_of[tri], end};
        }
  }

  std::vector<std::uint32_t> walked; // a ring's vertices, collected here and then copied at their size
  for (std::uint32_t tri = 0; tri < n; ++tri) {
    const std::uint32_t r = region_of[tri];
    if (transparent == TransparentRegions::skip && regions.regions[r].transparent) continue;
    for (std::uint32_t edge = 0; edge < 3; ++edge) {
      if ((flags[tri] & (9u << edge)) != (1u << edge)) continue; // not a boundary edge, or walked
      Ring ring;
      const std::uint32_t first = 3 * tri + edge;
      std::uint32_t current = first;
      std::uint32_t start = t.triangles[tri][(edge + 1) % 3];
      std::uint32_t end = t.triangles[tri][(edge + 2) % 3];
      walked.clear();
      do {
        flags[current / 3] |= static_cast<std::uint8_t>(8u << (current % 3));
        walked.push_back(start);
        // The next edge: the region's one edge leaving `end`, or at a pinch (several), the walk's.
        std::uint32_t found = cdt::kNone;
        bool pinch = false;
        for (std::uint32_t k = first_leaving[end]; k < first_leaving[end + 1]; ++k) {
          if (leaving[k].region != r) continue;
          if (found != cdt::kNone) {
            pinch = true;
            break;
          }
          found = k;
        }
        start = end;
        if (!pinch && found != cdt::kNone) { // none cannot happen on a valid mesh
          const Leaving& next = leaving[found];
          current = next.edge;
          end = next.end;
        } else {
          const auto [next_tri, next_edge] = tracer.next(current / 3, current % 3);
          current = 3 * next_tri + next_edge;
          end = t.triangles[next_tri][(next_edge + 2) % 3];
        }
      } while (current != first);
      ring.vertices.assign(walked.begin(), walked.end());

      ring.points.reserve(ring.vertices.size());
      for (std::uint32_t v : ring.vertices) ring.points.push_back(t.vertices[v]);
      // Shoelace about the first point, which keeps the products small for far-from-origin rings.
      const cdt::Point origin = ring.points.front();
      double twice_area = 0.0;
      for (std::size_t k = 1; k + 1 < ring.points.size(); ++k) {
        const cdt::Point& p = ring.points[k];
        const cdt::Point& q = ring.points[k + 1];
        twice_area += (p.x - origin.x) * (q.y - origin.y) - (q.x - origin.x) * (p.y - origin.y);
      }
      ring.signed_area = 0.5 * twice_area;
      by_region[r].rings.push_back(std::move(ring));
    }
  }

  std::vector<RegionPolygon> out;
  for (RegionPolygon& polygon : by_region)
    if (!polygon.rings.empty()) out.push_back(std::move(polygon));
  return out;
}

} // namespace vectorize
