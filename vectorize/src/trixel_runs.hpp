#pragma once
// The per-triangle work of stage 7 (trixel colours), compiled for the host and, in the CUDA build,
// for the device (kernels/trixel_kernels.cu), so that both make the same runs of pixels and add them up
// in the same order, operation for operation: the sums, and so the colours, are equal to the bit.
//
// The fill rule: a pixel centre p belongs to the triangle whose interior contains p + (eps, eps^2) for
// an infinitesimal eps > 0. On edge a->b of a counter-clockwise triangle (interior on its left) the
// moved point's orientation is orient(a, b, p) + (b.x - a.x) eps^2 - (b.y - a.y) eps, so a zero
// orientation is decided by the sign of -(b.y - a.y), then of (b.x - a.x). The moved point never lies
// on a line through p, hence in exactly one triangle of a mesh that covers a neighbourhood of p.

#include <cmath>
#include <cstdint>

#include "cdt/cdt.hpp"
#include "cdt/detail/host_device.hpp"
#include "cdt/detail/predicates.hpp"

namespace vectorize::detail {

CDT_HD_INLINE double min_of(double a, double b) { return b < a ? b : a; }
CDT_HD_INLINE double max_of(double a, double b) { return a < b ? b : a; }
CDT_HD_INLINE double clamp_to(double v, double lo, double hi) { return min_of(max_of(v, lo), hi); }
CDT_HD_INLINE int min_of(int a, int b) { return b < a ? b : a; }
CDT_HD_INLINE int max_of(int a, int b) { return a < b ? b : a; }

// Does the interior of the counter-clockwise triangle abc contain p moved as the fill rule says?
CDT_HD_INLINE bool owns(const cdt::Point& a, const cdt::Point& b, const cdt::Point& c, double px, double py) {
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
CDT_HD_INLINE bool on_fine_grid(double v) {
  const double scaled = v * 16.0;
  return fabs(v) < 1048576.0 && scaled == floor(scaled);
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
  CDT_HD_INLINE bool clear_of_row(double yc) const { return (yc - sy) * (yc - ey) > 0.0; }

  CDT_HD_INLINE double at(double yc, int i) const { return dx * (yc - sy) - dy * (i + 0.5 - sx); }
};

// Narrows the run [begin, end) of owned centres of row yc to the edge's half-plane. With dy < 0 the
// function grows with x and the edge bounds the run from the left (ties owned); with dy > 0 it falls
// and bounds it from the right (ties not owned); a horizontal edge owns the whole row or none of it.
// The crossing is estimated in floating point, then the bound is settled by exact evaluations, one or
// two steps from the estimate.
CDT_HD_INLINE void narrow_run(const EdgeHalfPlane& h, double yc, int width, int& begin, int& end) {
  if (h.dy == 0.0) {
    const double e = h.dx * (yc - h.sy);
    if (!(e > 0.0 || (e == 0.0 && h.dx > 0.0))) end = begin;
    return;
  }
  const double crossing = h.sx + (yc - h.sy) * h.inverse_slope;
  int i = static_cast<int>(clamp_to(ceil(crossing - 0.5), 0.0, static_cast<double>(width)));
  if (h.dy < 0.0) { // first i with E >= 0
    while (i > 0 && h.at(yc, i - 1) >= 0.0) --i;
    while (i < width && h.at(yc, i) < 0.0) ++i;
    begin = max_of(begin, i);
  } else { // first i with E <= 0
    while (i > 0 && h.at(yc, i - 1) <= 0.0) --i;
    while (i < width && h.at(yc, i) > 0.0) ++i;
    end = min_of(end, i);
  }
}

// Calls visit(row, x_begin, x_end) for each run of pixels [x_begin, x_end) of a row whose centres the
// counter-clockwise triangle abc owns, row by row from the top. A triangle with fine-grid coordinates
// (nearly all of them: vertices at pixel centres) is the intersection of its edges' half-planes, each
// settled exactly with a few multiplications (narrow_run). Otherwise rows and runs are first estimated
// in floating point, then every candidate is decided exactly with orient2d; the estimate is off by far
// less than a pixel, so probing one pixel beyond each end finds the exact run (a convex set meets a row
// of centres in one run).
template <class Visit>
CDT_HD_INLINE void triangle_runs(const cdt::Point& a, const cdt::Point& b, const cdt::Point& c, int width,
                                 int height, Visit&& visit) {
  if (width <= 0 || height <= 0) return; // no pixel centre (and the row bounds below need one)
  const double y_min = min_of(min_of(a.y, b.y), c.y);
  const double y_max = max_of(max_of(a.y, b.y), c.y);
  if (on_fine_grid(a.x) && on_fine_grid(a.y) && on_fine_grid(b.x) && on_fine_grid(b.y) && on_fine_grid(c.x) &&
      on_fine_grid(c.y)) {
    EdgeHalfPlane edges[3];
    const cdt::Point* v[3] = {&a, &b, &c};
    for (int i = 0; i < 3; ++i) {
      const cdt::Point& s = *v[i];
      const cdt::Point& e = *v[(i + 1) % 3];
      const double dx = e.x - s.x;
      const double dy = e.y - s.y;
      edges[i] = {s.x, s.y, dx, dy, dy != 0.0 ? dx / dy : 0.0, e.y};
    }
    // Rows whose centres lie within [y_min, y_max]; the half-planes settle the rest exactly.
    const int row_lo = static_cast<int>(clamp_to(ceil(y_min - 0.5), 0.0, static_cast<double>(height)));
    const int row_hi = static_cast<int>(clamp_to(floor(y_max - 0.5), -1.0, static_cast<double>(height - 1)));
    for (int row = row_lo; row <= row_hi; ++row) {
      const double yc = row + 0.5;
      int begin = 0;
      int end = width;
      for (const EdgeHalfPlane& h : edges) {
        if (h.clear_of_row(yc)) continue;
        narrow_run(h, yc, width, begin, end);
        if (begin >= end) break;
      }
      if (begin < end) visit(row, begin, end);
    }
    return;
  }
  // One row of slack on each side absorbs the rounding of y - 0.5.
  const double row_lo = clamp_to(ceil(y_min - 0.5) - 1.0, 0.0, static_cast<double>(height - 1));
  const double row_hi = clamp_to(floor(y_max - 0.5) + 1.0, 0.0, static_cast<double>(height - 1));
  for (int row = static_cast<int>(row_lo); row <= static_cast<int>(row_hi); ++row) {
    const double yc = row + 0.5;
    double x_lo = INFINITY;
    double x_hi = -INFINITY;
    const cdt::Point* v[3] = {&a, &b, &c};
    for (int i = 0; i < 3; ++i) {
      const cdt::Point& s = *v[i];
      const cdt::Point& e = *v[(i + 1) % 3];
      if (yc < min_of(s.y, e.y) || yc > max_of(s.y, e.y)) continue;
      double x0 = s.x;
      double x1 = e.x;
      if (s.y != e.y) {
        const double x = s.x + (yc - s.y) * (e.x - s.x) / (e.y - s.y);
        x0 = x1 = clamp_to(x, min_of(s.x, e.x), max_of(s.x, e.x));
      }
      x_lo = min_of(x_lo, min_of(x0, x1));
      x_hi = max_of(x_hi, max_of(x0, x1));
    }
    if (x_lo > x_hi) continue; // the row misses the triangle
    const int first = static_cast<int>(clamp_to(ceil(x_lo - 0.5) - 1.0, 0.0, static_cast<double>(width - 1)));
    const int last = static_cast<int>(clamp_to(floor(x_hi - 0.5) + 1.0, 0.0, static_cast<double>(width - 1)));
    int begin = first;
    while (begin <= last && !owns(a, b, c, begin + 0.5, yc)) ++begin;
    if (begin > last) continue;
    while (begin > 0 && owns(a, b, c, begin - 0.5, yc)) --begin;
    int end = begin + 1;
    while (end < width && owns(a, b, c, end + 0.5, yc)) ++end;
    visit(row, begin, end);
  }
}

/// What a triangle's owned pixels add up to: straight and alpha-weighted (premultiplied) RGB, alpha,
/// their number, and whether one of them is solid (alpha 1).
struct TrixelSums {
  double premultiplied[3] = {0, 0, 0};
  double straight[3] = {0, 0, 0};
  double alpha = 0;
  std::uint32_t pixel_count = 0;
  std::uint32_t covers_solid = 0; // 0 or 1
};

// Adds the pixels [begin, end) of a row of RGBA floats to s, in order. The products go through the
// predicates' unfused operations, so that the device rounds them as the host does.
CDT_HD_INLINE void add_run(TrixelSums& s, const float* row, int begin, int end) {
  for (int x = begin; x < end; ++x) {
    const float* p = row + 4 * x;
    const double alpha = p[3];
    for (int ch = 0; ch < 3; ++ch) {
      s.premultiplied[ch] = cdt::detail::fadd(s.premultiplied[ch], cdt::detail::fmul(p[ch], alpha));
      s.straight[ch] = cdt::detail::fadd(s.straight[ch], p[ch]);
    }
    s.alpha = cdt::detail::fadd(s.alpha, alpha);
    if (p[3] >= 1.0f) s.covers_solid = 1;
  }
  s.pixel_count += static_cast<std::uint32_t>(end - begin);
}

// The same for an image without transparency (every alpha exactly 1): the premultiplied sums would be
// the straight ones and the alpha sum the pixel count, exactly, so only the straight sums are made, in
// the same order: the colours come out the same to the bit.
CDT_HD_INLINE void add_run_opaque(TrixelSums& s, const float* row, int begin, int end) {
  double r = s.straight[0], g = s.straight[1], b = s.straight[2];
  const float* p = row + 4 * begin;
  for (int x = begin; x < end; ++x, p += 4) {
    r = cdt::detail::fadd(r, p[0]);
    g = cdt::detail::fadd(g, p[1]);
    b = cdt::detail::fadd(b, p[2]);
  }
  s.straight[0] = r;
  s.straight[1] = g;
  s.straight[2] = b;
  s.pixel_count += static_cast<std::uint32_t>(end - begin);
}

// The colour of a triangle that owns pixels (s.pixel_count > 0) from its sums: alpha the plain mean,
// RGB the alpha-weighted mean (the plain one where every alpha is 0); with `opaque` (every alpha of the
// image 1, only the straight sums made) the plain mean and alpha 1.
CDT_HD_INLINE void trixel_rgba(const TrixelSums& s, bool opaque, float* rgba) {
  const double n = s.pixel_count;
  if (opaque) {
    for (int ch = 0; ch < 3; ++ch) rgba[ch] = static_cast<float>(s.straight[ch] / n);
    rgba[3] = 1.0f;
    return;
  }
  for (int ch = 0; ch < 3; ++ch)
    rgba[ch] = static_cast<float>(s.alpha > 0 ? s.premultiplied[ch] / s.alpha : s.straight[ch] / n);
  rgba[3] = static_cast<float>(s.alpha / n);
}

} // namespace vectorize::detail
