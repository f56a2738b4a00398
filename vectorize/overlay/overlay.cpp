#include "vectorize/overlay.hpp"

#include <cairo-pdf.h>
#include <cairo-svg.h>
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <system_error>

#include "vectorize/errors.hpp"

namespace vectorize {

// Drawing goes to a recording surface so the same strokes can be replayed onto a raster, SVG or PDF
// surface when saved.
struct OverlayCanvas::State {
  int width = 0;
  int height = 0;
  cairo_surface_t* background = nullptr; // ARGB32, the dimmed input
  cairo_surface_t* recording = nullptr;
  cairo_t* cr = nullptr;

  ~State() {
    if (cr != nullptr) cairo_destroy(cr);
    if (recording != nullptr) cairo_surface_destroy(recording);
    if (background != nullptr) cairo_surface_destroy(background);
  }
};

namespace {

std::uint8_t to_byte(float v) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}

} // namespace

OverlayCanvas::OverlayCanvas(const Image& input, double dim) : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.width = input.width;
  s.height = input.height;
  s.background = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, input.width, input.height);
  if (cairo_surface_status(s.background) != CAIRO_STATUS_SUCCESS) {
    throw Error("cannot create a " + std::to_string(input.width) + " x " + std::to_string(input.height) +
                " overlay surface");
  }
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

  cairo_rectangle_t extents{0, 0, static_cast<double>(input.width), static_cast<double>(input.height)};
  s.recording = cairo_recording_surface_create(CAIRO_CONTENT_COLOR_ALPHA, &extents);
  s.cr = cairo_create(s.recording);
  cairo_set_line_join(s.cr, CAIRO_LINE_JOIN_ROUND);
  cairo_set_line_cap(s.cr, CAIRO_LINE_CAP_ROUND);
}

OverlayCanvas::~OverlayCanvas() = default;

int OverlayCanvas::width() const noexcept { return state_->width; }
int OverlayCanvas::height() const noexcept { return state_->height; }

void OverlayCanvas::polyline(const float* xy, int num_points, bool closed, const float rgba[4],
                             double width) {
  if (num_points < 2) return;
  cairo_t* cr = state_->cr;
  cairo_new_path(cr);
  cairo_move_to(cr, xy[0], xy[1]);
  for (int i = 1; i < num_points; ++i) cairo_line_to(cr, xy[2 * i], xy[2 * i + 1]);
  if (closed) cairo_close_path(cr);
  cairo_set_source_rgba(cr, rgba[0], rgba[1], rgba[2], rgba[3]);
  cairo_set_line_width(cr, width);
  cairo_stroke(cr);
}

namespace {

void paint_onto(cairo_surface_t* target, cairo_surface_t* background, cairo_surface_t* recording) {
  cairo_t* cr = cairo_create(target);
  cairo_set_source_surface(cr, background, 0, 0);
  cairo_pattern_set_filter(cairo_get_source(cr), CAIRO_FILTER_NEAREST);
  cairo_paint(cr);
  cairo_set_source_surface(cr, recording, 0, 0);
  cairo_paint(cr);
  cairo_destroy(cr);
}

} // namespace

void OverlayCanvas::save(const std::filesystem::path& path, OverlayFormat format) const {
  const State& s = *state_;
  std::filesystem::path tmp = path;
  tmp += ".tmp";
  const std::string tmp_name = tmp.string();
  cairo_status_t status = CAIRO_STATUS_SUCCESS;
  switch (format) {
  case OverlayFormat::png: {
    cairo_surface_t* target = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, s.width, s.height);
    paint_onto(target, s.background, s.recording);
    status = cairo_surface_write_to_png(target, tmp_name.c_str());
    cairo_surface_destroy(target);
    break;
  }
  case OverlayFormat::svg:
  case OverlayFormat::pdf: {
    cairo_surface_t* target = format == OverlayFormat::svg
                                  ? cairo_svg_surface_create(tmp_name.c_str(), s.width, s.height)
                                  : cairo_pdf_surface_create(tmp_name.c_str(), s.width, s.height);
    paint_onto(target, s.background, s.recording);
    cairo_surface_finish(target);
    status = cairo_surface_status(target);
    cairo_surface_destroy(target);
    break;
  }
  }
  std::error_code ec;
  if (status != CAIRO_STATUS_SUCCESS) {
    std::filesystem::remove(tmp, ec);
    throw FileError(path, std::string("cannot write overlay: ") + cairo_status_to_string(status));
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw FileError(path, "cannot write overlay: " + ec.message());
  }
}

} // namespace vectorize
