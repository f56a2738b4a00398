#include "vectorize/overlay.hpp"

#include <cairo-pdf.h>
#include <cairo-svg.h>
#include <cairo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "vectorize/errors.hpp"
#include "vectorize/pipeline.hpp"

namespace vectorize {

OverlayFormat parse_overlay_format(std::string_view name) {
  if (name == "png") return OverlayFormat::png;
  if (name == "svg") return OverlayFormat::svg;
  if (name == "pdf") return OverlayFormat::pdf;
  throw std::invalid_argument("unknown overlay format '" + std::string(name) +
                              "' (expected png, svg or pdf)");
}

const char* overlay_extension(OverlayFormat format) noexcept {
  switch (format) {
  case OverlayFormat::png:
    return "png";
  case OverlayFormat::svg:
    return "svg";
  case OverlayFormat::pdf:
    return "pdf";
  }
  return "png";
}

// Drawing is kept as a list of operations, replayed onto a raster, SVG or PDF surface when saved, with
// or without the dimmed input under them. (Painting a Cairo recording surface into an SVG surface would
// do the same, but Cairo 1.16's SVG backend keeps references to such sources that are never released.)
struct OverlayCanvas::State {
  int width = 0;
  int height = 0;
  cairo_surface_t* background = nullptr; // ARGB32, the dimmed input
  // Pixel layers painted by operations; owned here.
  std::vector<cairo_surface_t*> images;
  std::vector<std::function<void(cairo_t*)>> operations;

  ~State() {
    for (cairo_surface_t* image : images) cairo_surface_destroy(image);
    if (background != nullptr) cairo_surface_destroy(background);
  }
};

namespace {

std::uint8_t to_byte(float v) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}

cairo_surface_t* create_image_surface(int width, int height) {
  cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, width, height);
  if (cairo_surface_status(surface) != CAIRO_STATUS_SUCCESS) {
    cairo_surface_destroy(surface);
    throw Error("cannot create a " + std::to_string(width) + " x " + std::to_string(height) +
                " overlay surface");
  }
  return surface;
}

// Cairo writes into memory; the file is then written through write_file_atomically(), the one place
// that handles temporary names, renaming and cleaning up after an interrupt.
cairo_status_t append_to_string(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

void write_encoded(const std::filesystem::path& path, const std::string& bytes, cairo_status_t status,
                   const char* what) {
  if (status != CAIRO_STATUS_SUCCESS) {
    throw FileError(path, std::string("cannot write ") + what + ": " + cairo_status_to_string(status));
  }
  write_file_atomically(path, bytes);
}

} // namespace

OverlayCanvas::OverlayCanvas(const Image& input, double dim) : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.width = input.width;
  s.height = input.height;
  s.background = create_image_surface(input.width, input.height);
  cairo_surface_flush(s.background);
  unsigned char* data = cairo_image_surface_get_data(s.background);
  const int stride = cairo_image_surface_get_stride(s.background);
  const float keep = static_cast<float>(1.0 - std::clamp(dim, 0.0, 1.0));
  for (int y = 0; y < input.height; ++y) {
    auto* row = reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(y) * stride);
    for (int x = 0; x < input.width; ++x) {
      const float* p = input.pixel(x, y);
      // Composite over a grey checkerboard so transparent areas read as "nothing here".
      const float checker = (((x / 8) + (y / 8)) % 2 == 0) ? 0.35f : 0.25f;
      float rgb[3];
      for (int c = 0; c < 3; ++c) rgb[c] = (p[c] * p[3] + checker * (1.0f - p[3])) * keep;
      row[x] = 0xFF000000u | (std::uint32_t{to_byte(rgb[0])} << 16) | (std::uint32_t{to_byte(rgb[1])} << 8) |
               std::uint32_t{to_byte(rgb[2])};
    }
  }
  cairo_surface_mark_dirty(s.background);
}

OverlayCanvas::~OverlayCanvas() = default;

int OverlayCanvas::width() const noexcept { return state_->width; }
int OverlayCanvas::height() const noexcept { return state_->height; }

namespace {

using Colour = std::array<float, 4>;

Colour colour_of(const float rgba[4]) { return {rgba[0], rgba[1], rgba[2], rgba[3]}; }

void set_colour(cairo_t* cr, const Colour& c) { cairo_set_source_rgba(cr, c[0], c[1], c[2], c[3]); }

void trace(cairo_t* cr, const std::vector<float>& xy, bool closed) {
  cairo_new_path(cr);
  cairo_move_to(cr, xy[0], xy[1]);
  for (std::size_t i = 2; i + 1 < xy.size(); i += 2) cairo_line_to(cr, xy[i], xy[i + 1]);
  if (closed) cairo_close_path(cr);
}

} // namespace

void OverlayCanvas::polyline(const float* xy, int num_points, bool closed, const float rgba[4], double width,
                             double dash) {
  if (num_points < 2) return;
  std::vector<float> points(xy, xy + 2 * static_cast<std::size_t>(num_points));
  state_->operations.push_back(
      [points = std::move(points), closed, colour = colour_of(rgba), width, dash](cairo_t* cr) {
        trace(cr, points, closed);
        set_colour(cr, colour);
        cairo_set_line_width(cr, width);
        if (dash > 0) cairo_set_dash(cr, &dash, 1, 0.0);
        cairo_stroke(cr);
        if (dash > 0) cairo_set_dash(cr, nullptr, 0, 0.0);
      });
}

void OverlayCanvas::segments(const float* xy, std::size_t num_segments, const float rgba[4], double width) {
  if (num_segments == 0) return;
  std::vector<float> ends(xy, xy + 4 * num_segments);
  state_->operations.push_back([ends = std::move(ends), colour = colour_of(rgba), width](cairo_t* cr) {
    cairo_new_path(cr);
    for (std::size_t i = 0; i + 3 < ends.size(); i += 4) {
      cairo_move_to(cr, ends[i], ends[i + 1]);
      cairo_line_to(cr, ends[i + 2], ends[i + 3]);
    }
    set_colour(cr, colour);
    cairo_set_line_width(cr, width);
    cairo_stroke(cr);
  });
}

void OverlayCanvas::fill_polygon(const float* xy, int num_points, const float rgba[4], double seam) {
  if (num_points < 3) return;
  std::vector<float> points(xy, xy + 2 * static_cast<std::size_t>(num_points));
  state_->operations.push_back([points = std::move(points), colour = colour_of(rgba), seam](cairo_t* cr) {
    trace(cr, points, true);
    set_colour(cr, colour);
    if (seam > 0) {
      cairo_fill_preserve(cr);
      cairo_set_line_width(cr, seam);
      cairo_stroke(cr);
    } else {
      cairo_fill(cr);
    }
  });
}

void OverlayCanvas::dots(const float* xy, std::size_t num_points, double radius, const float rgba[4]) {
  if (num_points == 0) return;
  std::vector<float> centres(xy, xy + 2 * num_points);
  state_->operations.push_back([centres = std::move(centres), colour = colour_of(rgba), radius](cairo_t* cr) {
    cairo_new_path(cr);
    for (std::size_t i = 0; i + 1 < centres.size(); i += 2) {
      cairo_new_sub_path(cr);
      cairo_arc(cr, centres[i], centres[i + 1], radius, 0.0, 2.0 * M_PI);
    }
    set_colour(cr, colour);
    cairo_fill_preserve(cr);
    cairo_set_source_rgba(cr, 0, 0, 0, 0.8 * colour[3]);
    cairo_set_line_width(cr, std::max(0.25, radius * 0.3));
    cairo_stroke(cr);
  });
}

void OverlayCanvas::pixels(const std::uint8_t* mask, const float rgba[4]) {
  State& s = *state_;
  cairo_surface_t* image = create_image_surface(s.width, s.height);
  s.images.push_back(image);
  cairo_surface_flush(image);
  unsigned char* data = cairo_image_surface_get_data(image);
  const int stride = cairo_image_surface_get_stride(image);
  // ARGB32 is premultiplied.
  const float a = std::clamp(rgba[3], 0.0f, 1.0f);
  const std::uint32_t colour =
      (std::uint32_t{to_byte(a)} << 24) | (std::uint32_t{to_byte(rgba[0] * a)} << 16) |
      (std::uint32_t{to_byte(rgba[1] * a)} << 8) | std::uint32_t{to_byte(rgba[2] * a)};
  for (int y = 0; y < s.height; ++y) {
    auto* row = reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(y) * stride);
    const std::uint8_t* m = mask + static_cast<std::size_t>(y) * s.width;
    for (int x = 0; x < s.width; ++x) row[x] = m[x] != 0 ? colour : 0u;
  }
  cairo_surface_mark_dirty(image);
  s.operations.push_back([image](cairo_t* cr) {
    cairo_set_source_surface(cr, image, 0, 0);
    cairo_pattern_set_filter(cairo_get_source(cr), CAIRO_FILTER_NEAREST);
    cairo_paint(cr);
  });
}

namespace {

void paint_onto(cairo_surface_t* target, cairo_surface_t* background,
                const std::vector<std::function<void(cairo_t*)>>& operations) {
  cairo_t* cr = cairo_create(target);
  if (background != nullptr) {
    cairo_set_source_surface(cr, background, 0, 0);
    cairo_pattern_set_filter(cairo_get_source(cr), CAIRO_FILTER_NEAREST);
    cairo_paint(cr);
  }
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  for (const auto& operation : operations) operation(cr);
  cairo_destroy(cr);
}

} // namespace

void OverlayCanvas::save(const std::filesystem::path& path, OverlayFormat format,
                         OverlayBackground background) const {
  const State& s = *state_;
  std::string bytes;
  cairo_surface_t* under = background == OverlayBackground::dimmed_input ? s.background : nullptr;
  cairo_status_t status = CAIRO_STATUS_SUCCESS;
  switch (format) {
  case OverlayFormat::png: {
    cairo_surface_t* target = create_image_surface(s.width, s.height);
    paint_onto(target, under, s.operations);
    status = cairo_surface_write_to_png_stream(target, append_to_string, &bytes);
    cairo_surface_destroy(target);
    break;
  }
  case OverlayFormat::svg:
  case OverlayFormat::pdf: {
    cairo_surface_t* target =
        format == OverlayFormat::svg
            ? cairo_svg_surface_create_for_stream(append_to_string, &bytes, s.width, s.height)
            : cairo_pdf_surface_create_for_stream(append_to_string, &bytes, s.width, s.height);
    // One SVG unit per image pixel (Cairo's default is points, which viewers scale by 4/3).
    if (format == OverlayFormat::svg) cairo_svg_surface_set_document_unit(target, CAIRO_SVG_UNIT_PX);
    paint_onto(target, under, s.operations);
    cairo_surface_finish(target);
    status = cairo_surface_status(target);
    cairo_surface_destroy(target);
    break;
  }
  }
  write_encoded(path, bytes, status, "overlay");
}

void save_image_png(const Image& image, const std::filesystem::path& path) {
  cairo_surface_t* surface = create_image_surface(image.width, image.height);
  cairo_surface_flush(surface);
  unsigned char* data = cairo_image_surface_get_data(surface);
  const int stride = cairo_image_surface_get_stride(surface);
  for (int y = 0; y < image.height; ++y) {
    auto* row = reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(y) * stride);
    for (int x = 0; x < image.width; ++x) {
      const float* p = image.pixel(x, y);
      const float a = std::clamp(p[3], 0.0f, 1.0f);
      row[x] = (std::uint32_t{to_byte(a)} << 24) | (std::uint32_t{to_byte(p[0] * a)} << 16) |
               (std::uint32_t{to_byte(p[1] * a)} << 8) | std::uint32_t{to_byte(p[2] * a)};
    }
  }
  cairo_surface_mark_dirty(surface);
  std::string bytes;
  const cairo_status_t status = cairo_surface_write_to_png_stream(surface, append_to_string, &bytes);
  cairo_surface_destroy(surface);
  write_encoded(path, bytes, status, "image");
}

} // namespace vectorize
