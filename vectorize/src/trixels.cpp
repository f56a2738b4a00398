// Stage 7: trixel colours (Prasad and Skourikhine 2006, sec. 2: the colour of a triangle is the mean
// of the pixels it covers). The fill rule is a symbolic perturbation of the pixel centre, decided with
// the engine's exact orient2d, so that centres on shared edges and vertices are counted exactly once.

#include "vectorize/trixels.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "parallel.hpp"

namespace vectorize {
namespace {

// Does the interior of the counter-clockwise triangle abc contain p + (eps, eps^2) for an infinitesimal
// eps > 0? On edge a->b (interior on its left) the perturbed point's orientation is
// orient(a, b, p) + (b.x - a.x) eps^2 - (b.y - a.y) eps, so a zero orientation is decided by the sign
// of -(b.y - a.y), then of (b.x - a.x). The perturbed point never lies on a line through p, hence in
// exactly one triangle of a mesh that covers a neighbourhood of p.
bool owns(const cdt::Point& a, const cdt::Point& b, const cdt::Point& c, double px, double py) {
  const cdt::Point* v[3] = {&a, &b, &c};
  for (int i = 0; i < 3; ++i) {
    const cdt::Point& s = *v[i];
    const cdt::Point& e = *v[(i + 1) % 3];
    const int o = cdt::detail::orient2d(s.x, s.y, e.x, e.y, px, py);
    if (o < 0) return false;
    if (o == 0 && !(e.y < s.y || (e.y == s.y && e.x > s.x))) return false;
  }
  return true;
}

// Coordinates that are multiples of 1/16 below 2^20 in magnitude: differences of them and of pixel
// centres have at most 25 significant bits, so an edge function (a difference of two products of such
// differences) is exact in double arithmetic. Pixel centres, corners and the points placed on outlines
// of hard-edged shapes are such coordinates.
bool on_fine_grid(double v) {
  const double scaled = v * 16.0;
  return std::abs(v) < 1048576.0 && scaled == std::floor(scaled);
}

// One edge s->e of a triangle as a half-plane over the pixel centres (i + 0.5, yc) of a row: the
// centre is owned (as far as this edge decides) when the edge function
// E = (e.x - s.x)(yc - s.y) - (e.y - s.y)(cx - s.x) is positive, or zero and the fill rule's tie-break
// (e.y < s.y, or e.y == s.y and e.x > s.x) says so. Exact for fine-grid coordinates (on_fine_grid).
struct EdgeHalfPlane {
  double sx;
  double sy;
  double dx;
  double dy;
  double inverse_slope; // dx / dy, for the estimate of the crossing; unused when dy == 0
  double ey;            // sy + dy

  // Whether the edge's ends lie strictly on one side of row yc. The other two edges then meet the row
  // where the triangle does, at points strictly inside this edge's half-plane: it decides nothing.
  bool clear_of_row(double yc) const { return (yc - sy) * (yc - ey) > 0.0; }

  double at(double yc, int i) const { return dx * (yc - sy) - dy * (i + 0.5 - sx); }
};

// Narrows the run [begin, end) of owned centres of row yc to the edge's half-plane. With dy < 0 the
// function grows with x and the edge bounds the run from the left (ties owned); with dy > 0 it falls
// and bounds it from the right (ties not owned); a horizontal edge owns the whole row or none of it.
// The crossing is estimated in floating point, then the bound is settled by exact evaluations, one or
// two steps from the estimate.
[[gnu::always_inline]] inline void narrow_run(const EdgeHalfPlane& h, double yc, int width, int& begin,
                                              int& end) {
  if (h.dy == 0.0) {
    const double e = h.dx * (yc - h.sy);
    if (!(e > 0.0 || (e == 0.0 && h.dx > 0.0))) end = begin;
    return;
  }
  const double crossing = h.sx + (yc - h.sy) * h.inverse_slope;
  int i = static_cast<int>(std::clamp(std::ceil(crossing - 0.5), 0.0, static_cast<double>(width)));
  if (h.dy < 0.0) { // first i with E >= 0
    while (i > 0 && h.at(yc, i - 1) >= 0.0) --i;
    while (i < width && h.at(yc, i) < 0.0) ++i;
    begin = std::max(begin, i);
  } else { // first i with E <= 0
    while (i > 0 && h.at(yc, i - 1) <= 0.0) --i;
    while (i < width && h.at(yc, i) > 0.0) ++i;
    end = std::min(end, i);
  }
}

// Calls visit(triangle, row, x_begin, x_end) for each run of pixels [x_begin, x_end) of a row whose
// centres the triangle owns. A triangle with fine-grid coordinates (nearly all of them: vertices at
// pixel centres) is the intersection of its edges' half-planes, each settled exactly with a few
// multiplications (narrow_run). Otherwise rows and runs are first estimated in floating point, then
// every candidate is decided exactly with orient2d; the estimate is off by far less than a pixel, so
// probing one pixel beyond each end finds the exact run (a convex set meets a row of centres in one
// run).
template <class Visit>
void for_each_run(int width, int height, const cdt::Triangulation& t, Visit&& visit,
                  std::size_t tri_begin = 0, std::size_t tri_end = SIZE_MAX) {
  if (width <= 0 || height <= 0) return;
  tri_end = std::min(tri_end, t.triangles.size());
  for (auto tri = static_cast<std::uint32_t>(tri_begin); tri < tri_end; ++tri) {
    const cdt::Point& a = t.vertices[t.triangles[tri][0]];
    const cdt::Point& b = t.vertices[t.triangles[tri][1]];
    const cdt::Point& c = t.vertices[t.triangles[tri][2]];
    if (on_fine_grid(a.x) && on_fine_grid(a.y) && on_fine_grid(b.x) && on_fine_grid(b.y) &&
        on_fine_grid(c.x) && on_fine_grid(c.y)) {
      std::array<EdgeHalfPlane, 3> edges;
      const cdt::Point* v[3] = {&a, &b, &c};
      for (int i = 0; i < 3; ++i) {
        const cdt::Point& s = *v[i];
        const cdt::Point& e = *v[(i + 1) % 3];
        const double dx = e.x - s.x;
        const double dy = e.y - s.y;
        edges[i] = {s.x, s.y, dx, dy, dy != 0.0 ? dx / dy : 0.0, e.y};
      }
      // Rows whose centres lie within [y_min, y_max]; the half-planes settle the rest exactly.
      const int row_lo = static_cast<int>(
          std::clamp(std::ceil(std::min({a.y, b.y, c.y}) - 0.5), 0.0, static_cast<double>(height)));
      const int row_hi = static_cast<int>(
          std::clamp(std::floor(std::max({a.y, b.y, c.y}) - 0.5), -1.0, static_cast<double>(height - 1)));
      for (int row = row_lo; row <= row_hi; ++row) {
        const double yc = row + 0.5;
        int begin = 0;
        int end = width;
        for (const EdgeHalfPlane& h : edges) {
          if (h.clear_of_row(yc)) continue;
          narrow_run(h, yc, width, begin, end);
          if (begin >= end) break;
        }
        if (begin < end) visit(tri, row, begin, end);
      }
      continue;
    }
    const double y_min = std::min({a.y, b.y, c.y});
    const double y_max = std::max({a.y, b.y, c.y});
    // One row of slack on each side absorbs the rounding of y - 0.5.
    const double row_lo = std::clamp(std::ceil(y_min - 0.5) - 1.0, 0.0, static_cast<double>(height - 1));
    const double row_hi = std::clamp(std::floor(y_max - 0.5) + 1.0, 0.0, static_cast<double>(height - 1));
    for (int row = static_cast<int>(row_lo); row <= static_cast<int>(row_hi); ++row) {
      const double yc = row + 0.5;
      double x_lo = INFINITY;
      double x_hi = -INFINITY;
      const cdt::Point* v[3] = {&a, &b, &c};
      for (int i = 0; i < 3; ++i) {
        const cdt::Point& s = *v[i];
        const cdt::Point& e = *v[(i + 1) % 3];
        if (yc < std::min(s.y, e.y) || yc > std::max(s.y, e.y)) continue;
        double x0 = s.x;
        double x1 = e.x;
        if (s.y != e.y) {
          const double x = s.x + (yc - s.y) * (e.x - s.x) / (e.y - s.y);
          x0 = x1 = std::clamp(x, std::min(s.x, e.x), std::max(s.x, e.x));
        }
        x_lo = std::min({x_lo, x0, x1});
        x_hi = std::max({x_hi, x0, x1});
      }
      if (x_lo > x_hi) continue; // the row misses the triangle
      const int first =
          static_cast<int>(std::clamp(std::ceil(x_lo - 0.5) - 1.0, 0.0, static_cast<double>(width - 1)));
      const int last =
          static_cast<int>(std::clamp(std::floor(x_hi - 0.5) + 1.0, 0.0, static_cast<double>(width - 1)));
      int begin = first;
      while (begin <= last && !owns(a, b, c, begin + 0.5, yc)) ++begin;
      if (begin > last) continue;
      while (begin > 0 && owns(a, b, c, begin - 0.5, yc)) --begin;
      int end = begin + 1;
      while (end < width && owns(a, b, c, end + 0.5, yc)) ++end;
      visit(tri, row, begin, end);
    }
  }
}

// Bilinear interpolation between pixel centres, clamped at the border, of premultiplied colour so that
// the RGB under transparent pixels does not bleed in.
std::array<float, 4> sample(const Image& image, double x, double y) {
  const double fx = std::clamp(x - 0.5, 0.0, static_cast<double>(image.width - 1));
  const double fy = std::clamp(y - 0.5, 0.0, static_cast<double>(image.height - 1));
  const int x0 = static_cast<int>(fx);
  const int y0 = static_cast<int>(fy);
  const int x1 = std::min(x0 + 1, image.width - 1);
  const int y1 = std::min(y0 + 1, image.height - 1);
  const double tx = fx - x0;
  const double ty = fy - y0;
  const float* p[4] = {image.pixel(x0, y0), image.pixel(x1, y0), image.pixel(x0, y1), image.pixel(x1, y1)};
  const double w[4] = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
  double premultiplied[3] = {0, 0, 0};
  double straight[3] = {0, 0, 0};
  double alpha = 0;
  for (int k = 0; k < 4; ++k) {
    for (int ch = 0; ch < 3; ++ch) {
      premultiplied[ch] += w[k] * p[k][ch] * p[k][3];
      straight[ch] += w[k] * p[k][ch];
    }
    alpha += w[k] * p[k][3];
  }
  std::array<float, 4> out{};
  for (int ch = 0; ch < 3; ++ch)
    out[ch] = static_cast<float>(alpha > 0 ? premultiplied[ch] / alpha : straight[ch]);
  out[3] = static_cast<float>(alpha);
  return out;
}

// Whether the interior of the counter-clockwise triangle abc and the open unit square of pixel (x, y)
// meet (separating axes: the square's two, and each edge of the triangle, exactly).
bool meets_square(const cdt::Point& a, const cdt::Point& b, const cdt::Point& c, int x, int y) {
  if (std::max({a.x, b.x, c.x}) <= x || std::min({a.x, b.x, c.x}) >= x + 1.0) return false;
  if (std::max({a.y, b.y, c.y}) <= y || std::min({a.y, b.y, c.y}) >= y + 1.0) return false;
  const cdt::Point* v[3] = {&a, &b, &c};
  for (int i = 0; i < 3; ++i) {
    const cdt::Point& s = *v[i];
    const cdt::Point& e = *v[(i + 1) % 3];
    bool any_inside = false;
    for (const auto& [cx, cy] :
         {std::pair{x, y}, std::pair{x + 1, y}, std::pair{x, y + 1}, std::pair{x + 1, y + 1}})
      any_inside = any_inside || cdt::detail::orient2d(s.x, s.y, e.x, e.y, cx, cy) > 0;
    if (!any_inside) return false;
  }
  return true;
}

// Sets covers_solid for triangles that own no solid pixel centre but reach into a solid pixel. Only
// an image with transparency (any_clear: some alpha below 1) needs the search: without it every
// triangle covers solid pixels.
void mark_solid_cover(const Image& image, const cdt::Triangulation& t, TrixelColours& trixels,
                      bool any_clear) {
  for (std::uint32_t tri = 0; tri < trixels.size(); ++tri) {
    Trixel& trixel = trixels[tri];
    if (trixel.covers_solid) continue;
    if (!any_clear) {
      trixel.covers_solid = true;
      continue;
    }
    const cdt::Point& a = t.vertices[t.triangles[tri][0]];
    const cdt::Point& b = t.vertices[t.triangles[tri][1]];
    const cdt::Point& c = t.vertices[t.triangles[tri][2]];
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({a.x, b.x, c.x}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({a.y, b.y, c.y}))));
    const int x1 = std::min(image.width - 1, static_cast<int>(std::floor(std::max({a.x, b.x, c.x}))));
    const int y1 = std::min(image.height - 1, static_cast<int>(std::floor(std::max({a.y, b.y, c.y}))));
    for (int y = y0; y <= y1 && !trixel.covers_solid; ++y)
      for (int x = x0; x <= x1 && !trixel.covers_solid; ++x)
        trixel.covers_solid = image.pixel(x, y)[3] >= 1.0f && meets_square(a, b, c, x, y);
  }
}

// Triangles that own no pixel centre (slivers along edges) take the colour of the neighbour across a
// non-constraint edge that owns the most pixels, found breadth-first: no constraint lies between them,
// so they are the same area of the image, whereas a sample at the sliver's centroid may fall on the
// other side of the edge the sliver follows (an outline sliver would turn transparent and let the
// background through the shape's rim). Slivers walled in by constraints are sampled.
void colour_slivers(const Image& image, const cdt::Triangulation& t, TrixelColours& trixels) {
  std::vector<std::uint32_t> frontier;
  std::vector<std::uint8_t> done(trixels.size(), 0);
  for (std::uint32_t tri = 0; tri < trixels.size(); ++tri) {
    if (trixels[tri].pixel_count > 0)
      done[tri] = 1;
    else
      frontier.push_back(tri);
  }
  // Each pass settles the slivers next to a settled triangle, from the state before the pass, so the
  // result does not depend on the order of the slivers.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> settled; // (sliver, donor)
  while (!frontier.empty()) {
    settled.clear();
    std::vector<std::uint32_t> rest;
    for (const std::uint32_t tri : frontier) {
      std::uint32_t donor = cdt::kNone;
      for (int i = 0; i < 3; ++i) {
        const std::uint32_t other = t.neighbors[tri][i];
        if (other == cdt::kNone || t.segment_of_edge[tri][i] != cdt::kNone || !done[other]) continue;
        if (donor == cdt::kNone || trixels[other].pixel_count > trixels[donor].pixel_count ||
            (trixels[other].pixel_count == trixels[donor].pixel_count && other < donor))
          donor = other;
      }
      if (donor == cdt::kNone)
        rest.push_back(tri);
      else
        settled.emplace_back(tri, donor);
    }
    if (settled.empty()) break;
    for (const auto& [tri, donor] : settled) {
      trixels[tri].rgba = trixels[donor].rgba;
      done[tri] = 1;
    }
    frontier = std::move(rest);
  }
  if (image.width <= 0 || image.height <= 0) return;
  for (const std::uint32_t tri : frontier) {
    const cdt::Point& a = t.vertices[t.triangles[tri][0]];
    const cdt::Point& b = t.vertices[t.triangles[tri][1]];
    const cdt::Point& c = t.vertices[t.triangles[tri][2]];
    trixels[tri].rgba = sample(image, (a.x + b.x + c.x) / 3.0, (a.y + b.y + c.y) / 3.0);
  }
}

} // namespace

std::vector<std::uint32_t> owner_of_pixels(int width, int height, const cdt::Triangulation& t) {
  std::vector<std::uint32_t> owner(static_cast<std::size_t>(std::max(width, 0)) * std::max(height, 0),
                                   cdt::kNone);
  for_each_run(width, height, t, [&](std::uint32_t tri, int row, int begin, int end) {
    std::fill_n(owner.begin() + static_cast<std::ptrdiff_t>(row) * width + begin, end - begin, tri);
  });
  return owner;
}

TrixelColours colour_trixels(const Image& image, const cdt::Triangulation& t, unsigned threads) {
  struct Sums {
    double premultiplied[3] = {0, 0, 0};
    double straight[3] = {0, 0, 0};
    double alpha = 0;
  };
  std::vector<Sums> sums(t.triangles.size());
  TrixelColours trixels(t.triangles.size());
  // Each triangle's sums are its own and are added up by one thread in row order, so the result is the
  // same for any number of threads.
  const auto accumulate = [&](std::uint32_t tri, int row, int begin, int end) {
    Sums& s = sums[tri];
    for (int x = begin; x < end; ++x) {
      const float* p = image.pixel(x, row);
      for (int ch = 0; ch < 3; ++ch) {
        s.premultiplied[ch] += static_cast<double>(p[ch]) * p[3];
        s.straight[ch] += p[ch];
      }
      s.alpha += p[3];
      if (p[3] >= 1.0f) trixels[tri].covers_solid = true;
    }
    trixels[tri].pixel_count += static_cast<std::uint32_t>(end - begin);
  };
  // Without transparency (every alpha exactly 1) the premultiplied sums are the straight ones and the
  // alpha sum is the pixel count, exactly: only the straight sums are kept, in the same order, so the
  // colours are the same to the bit.
  const auto accumulate_opaque = [&](std::uint32_t tri, int row, int begin, int end) {
    Sums& s = sums[tri];
    double r = s.straight[0], g = s.straight[1], b = s.straight[2];
    const float* p = image.pixel(begin, row);
    for (int x = begin; x < end; ++x, p += 4) {
      r += p[0];
      g += p[1];
      b += p[2];
    }
    s.straight[0] = r;
    s.straight[1] = g;
    s.straight[2] = b;
    trixels[tri].pixel_count += static_cast<std::uint32_t>(end - begin);
  };
  bool opaque = true;
  for (std::size_t i = 3; i < image.rgba.size() && opaque; i += 4) opaque = image.rgba[i] == 1.0f;
  const std::size_t count = t.triangles.size();
  const auto parts = static_cast<unsigned>(
      std::min<std::size_t>(resolve_threads(threads), std::max<std::size_t>(1, count / 4096)));
  for_each_part(count, parts, [&](std::size_t first, std::size_t last, unsigned) {
    if (opaque)
      for_each_run(image.width, image.height, t, accumulate_opaque, first, last);
    else
      for_each_run(image.width, image.height, t, accumulate, first, last);
  });

  for (std::size_t tri = 0; tri < t.triangles.size(); ++tri) {
    Trixel& trixel = trixels[tri];
    const cdt::Point& a = t.vertices[t.triangles[tri][0]];
    const cdt::Point& b = t.vertices[t.triangles[tri][1]];
    const cdt::Point& c = t.vertices[t.triangles[tri][2]];
    trixel.area = 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
    if (trixel.pixel_count == 0) continue;
    const Sums& s = sums[tri];
    const double n = trixel.pixel_count;
    if (opaque) {
      for (int ch = 0; ch < 3; ++ch) trixel.rgba[ch] = static_cast<float>(s.straight[ch] / n);
      trixel.rgba[3] = 1.0f;
      trixel.covers_solid = true;
      continue;
    }
    for (int ch = 0; ch < 3; ++ch)
      trixel.rgba[ch] = static_cast<float>(s.alpha > 0 ? s.premultiplied[ch] / s.alpha : s.straight[ch] / n);
    trixel.rgba[3] = static_cast<float>(s.alpha / n);
  }
  colour_slivers(image, t, trixels);
  mark_solid_cover(image, t, trixels, !opaque);
  return trixels;
}

} // namespace vectorize
