// Stage 7: trixel colours (Prasad and Skourikhine 2006, sec. 2: the colour of a triangle is the mean
// of the pixels it covers). The fill rule is a symbolic perturbation of the pixel centre, decided with
// the engine's exact orient2d, so that centres on shared edges and vertices are counted exactly once.

#include "vectorize/trixels.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "cdt/detail/predicates.hpp"
#include "cdt/errors.hpp"
#include "parallel.hpp"
#include "trixel_runs.hpp"

#if TRIXEL_HAVE_CUDA
#include "edge_kernels.hpp"
#include "trixel_kernels.hpp"
#endif

namespace vectorize {
namespace {

// Calls visit(triangle, row, x_begin, x_end) for each run of pixels [x_begin, x_end) of a row whose
// centres a triangle of [tri_begin, tri_end) owns (trixel_runs.hpp), triangle after triangle.
template <class Visit>
void for_each_run(int width, int height, const cdt::Triangulation& t, Visit&& visit,
                  std::size_t tri_begin = 0, std::size_t tri_end = SIZE_MAX) {
  tri_end = std::min(tri_end, t.triangles.size());
  for (auto tri = static_cast<std::uint32_t>(tri_begin); tri < tri_end; ++tri) {
    detail::triangle_runs(t.vertices[t.triangles[tri][0]], t.vertices[t.triangles[tri][1]],
                          t.vertices[t.triangles[tri][2]], width, height,
                          [&](int row, int begin, int end) { visit(tri, row, begin, end); });
  }
}

// Each triangle's sums on the device (TrixelDevice::gpu), and, when `lab` is given, the CIELAB of the
// colour of each that owns pixels.
void gpu_trixel_sums(const Image& image, const cdt::Triangulation& t, bool opaque,
                     std::vector<detail::TrixelSums>& sums, TrixelLab* lab, const DevicePixels& on_device) {
#if TRIXEL_HAVE_CUDA
  // Only edge_classes makes the handle: it holds a gpu::DeviceImage.
  const auto* kept = static_cast<const gpu::DeviceImage*>(on_device.get());
  const bool same = kept != nullptr && kept->width() == image.width && kept->height() == image.height;
  if (lab != nullptr) lab->resize(sums.size());
  gpu::trixel_sums(image.rgba.data(), image.width, image.height, t.vertices.data(), t.vertices.size(),
                   t.triangles.data(), t.triangles.size(), opaque, sums.data(), same ? kept->data() : nullptr,
                   lab != nullptr ? lab->data() : nullptr);
#else
  (void)image, (void)t, (void)opaque, (void)sums, (void)lab, (void)on_device;
  throw cdt::DeviceError("trixel colours on the device: this build has no CUDA support");
#endif
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
// Their CIELAB, where `lab` holds the others' (not empty), is their donor's, or NaN for a sample.
void colour_slivers(const Image& image, const cdt::Triangulation& t, TrixelColours& trixels, TrixelLab& lab) {
  std::vector<std::uint32_t> frontier;
  std::vector<std::uint8_t> done(trixels.size(), 0);
  for (std::uint32_t tri = 0; tri < trixels.size(); ++tri) {
    if (trixels[tri].pixel_count > 0) {
      done[tri] = 1;
    } else {
      frontier.push_back(tri);
      if (!lab.empty()) lab[tri].fill(std::numeric_limits<double>::quiet_NaN());
    }
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
      if (!lab.empty()) lab[tri] = lab[donor];
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

bool prepare_trixels_on_device(unsigned callers) noexcept {
#if TRIXEL_HAVE_CUDA
  try {
    gpu::prepare_trixel_sums(callers);
    return true;
  } catch (...) {
    return false; // a device that fails here fails again, with its error, in colour_trixels
  }
#else
  (void)callers;
  return false;
#endif
}

TrixelColours colour_trixels(const Image& image, const cdt::Triangulation& t, unsigned threads,
                             TrixelDevice device, const DevicePixels& on_device, TrixelLab* lab_out) {
  bool opaque = true;
  if (!image.known_opaque)
    for (std::size_t i = 3; i < image.rgba.size() && opaque; i += 4) opaque = image.rgba[i] == 1.0f;
  const std::size_t count = t.triangles.size();
  std::vector<detail::TrixelSums> sums(count);
  TrixelLab lab; // from the device, when the caller asks for it: the colours' CIELAB
  if (device == TrixelDevice::gpu) {
    gpu_trixel_sums(image, t, opaque, sums, lab_out != nullptr ? &lab : nullptr, on_device);
  } else {
    // Each triangle's sums are its own and are added up by one thread in row order, so the result is
    // the same for any number of threads.
    const auto parts = static_cast<unsigned>(
        std::min<std::size_t>(resolve_threads(threads), std::max<std::size_t>(1, count / 4096)));
    const std::size_t row_floats = static_cast<std::size_t>(image.width) * 4;
    for_each_part(count, parts, [&](std::size_t first, std::size_t last, unsigned) {
      if (opaque)
        for_each_run(
            image.width, image.height, t,
            [&](std::uint32_t tri, int row, int begin, int end) {
              detail::add_run_opaque(sums[tri], image.rgba.data() + row * row_floats, begin, end);
            },
            first, last);
      else
        for_each_run(
            image.width, image.height, t,
            [&](std::uint32_t tri, int row, int begin, int end) {
              detail::add_run(sums[tri], image.rgba.data() + row * row_floats, begin, end);
            },
            first, last);
    });
  }

  TrixelColours trixels(count);
  for (std::size_t tri = 0; tri < t.triangles.size(); ++tri) {
    Trixel& trixel = trixels[tri];
    const cdt::Point& a = t.vertices[t.triangles[tri][0]];
    const cdt::Point& b = t.vertices[t.triangles[tri][1]];
    const cdt::Point& c = t.vertices[t.triangles[tri][2]];
    trixel.area = 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
    const detail::TrixelSums& s = sums[tri];
    trixel.pixel_count = s.pixel_count;
    trixel.covers_solid = s.covers_solid != 0;
    if (trixel.pixel_count == 0) continue;
    detail::trixel_rgba(s, opaque, trixel.rgba.data());
    if (opaque) trixel.covers_solid = true;
  }
  colour_slivers(image, t, trixels, lab);
  mark_solid_cover(image, t, trixels, !opaque);
  if (lab_out != nullptr) *lab_out = std::move(lab);
  return trixels;
}

} // namespace vectorize
