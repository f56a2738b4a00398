// Stage 10: SVG output. Coordinates are quantised to integers once (units of 10^-precision pixels) and
// relative moves are differences of those integers, so relative path data never drift and a vertex
// shared by two regions lands on the same spot in both paths.

#include "vectorize/svg.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <numeric>
#include <stdexcept>
#include <string>
#include <string_view>

namespace vectorize {
namespace {

// A sign, a point and up to 20 digits (decimals <= 18: zeros before a small value stay within them).
constexpr std::size_t kCompactDecimalChars = 48;

// compact_decimal() written into out (kCompactDecimalChars at least), without allocating: the path data
// of an image has hundreds of thousands of numbers. Returns the length; *has_point, when given, says
// whether the number has a decimal point.
std::size_t write_compact_decimal(std::int64_t units, int decimals, char* out, bool* has_point = nullptr) {
  decimals = std::clamp(decimals, 0, 18);
  char digits[kCompactDecimalChars];
  const std::uint64_t magnitude =
      units < 0 ? -static_cast<std::uint64_t>(units) : static_cast<std::uint64_t>(units);
  auto count = static_cast<std::size_t>(std::to_chars(digits, digits + 24, magnitude).ptr - digits);
  const auto places = static_cast<std::size_t>(decimals);
  if (count <= places) { // leading zeros, so that a digit stands before the point
    std::memmove(digits + places + 1 - count, digits, count);
    std::memset(digits, '0', places + 1 - count);
    count = places + 1;
  }
  std::size_t whole = count - places;
  std::size_t fraction = places;
  while (fraction > 0 && digits[whole + fraction - 1] == '0') --fraction;
  std::size_t length = 0;
  if (units < 0) out[length++] = '-';
  if (!(whole == 1 && digits[0] == '0' && fraction > 0)) { // ".5" is a valid SVG number
    std::memcpy(out + length, digits, whole);
    length += whole;
  }
  if (fraction > 0) {
    out[length++] = '.';
    std::memcpy(out + length, digits + whole, fraction);
    length += fraction;
  }
  if (has_point != nullptr) *has_point = fraction > 0;
  return length;
}

// std::llround(v) (halves away from zero), without the library call where v is below 2^52 in magnitude:
// there the integer part converts exactly and v minus it is exact. Path data rounds two coordinates per
// vertex.
std::int64_t round_to_integer(double v) {
  constexpr double kExact = 4503599627370496.0; // 2^52
  if (!(std::abs(v) < kExact)) return std::llround(v);
  const auto whole = static_cast<std::int64_t>(v); // towards zero
  const double rest = v - static_cast<double>(whole);
  return rest >= 0.5 ? whole + 1 : rest <= -0.5 ? whole - 1 : whole;
}

// Appends path commands and numbers, leaving out every separator the SVG path grammar can do without.
// Appends each piece (strings and characters) to the text.
template <class... Pieces>
void append(std::string& text, const Pieces&... pieces) {
  ((text += pieces), ...);
}

// Path data appended to a document's text.
class PathData {
public:
  PathData(std::string& text, int decimals) : text_(text), decimals_(decimals) {}

  // A command letter; a repeat of the previous one is implied by the grammar (except after moveto,
  // whose implied repeat is an absolute lineto, so it is never elided here).
  void command(char letter) {
    if (letter == last_command_ && letter != 'M' && letter != 'z') return;
    text_ += letter;
    last_command_ = letter;
    previous_had_point_ = false;
    after_command_ = true;
  }

  void number(std::int64_t units) {
    char buffer[kCompactDecimalChars + 1];
    bool has_point = false;
    const std::size_t length = write_compact_decimal(units, decimals_, buffer + 1, &has_point);
    const char front = buffer[1];
    const bool needs_separator = !after_command_ && front != '-' && !(front == '.' && previous_had_point_);
    buffer[0] = ' ';
    text_.append(needs_separator ? buffer : buffer + 1, length + (needs_separator ? 1 : 0));
    previous_had_point_ = has_point;
    after_command_ = false;
  }

private:
  std::string& text_;
  int decimals_;
  char last_command_ = 0;
  bool previous_had_point_ = false;
  bool after_command_ = true;
};

void append_path_data(std::string& text, const RegionPolygon& polygon, int precision) {
  static constexpr double kPowersOfTen[] = {1.0, 10.0, 100.0, 1e3, 1e4, 1e5, 1e6}; // precision 0 to 6
  const double scale = kPowersOfTen[precision];
  PathData d(text, precision);
  for (const Ring& ring : polygon.rings) {
    std::int64_t x = round_to_integer(ring.points.front().x * scale);
    std::int64_t y = round_to_integer(ring.points.front().y * scale);
    d.command('M');
    d.number(x);
    d.number(y);
    for (std::size_t k = 1; k < ring.points.size(); ++k) {
      const std::int64_t nx = round_to_integer(ring.points[k].x * scale);
      const std::int64_t ny = round_to_integer(ring.points[k].y * scale);
      const std::int64_t dx = nx - x;
      const std::int64_t dy = ny - y;
      if (dx == 0 && dy == 0) continue; // two vertices closer than the precision: one is enough
      if (dy == 0) {
        d.command('h');
        d.number(dx);
      } else if (dx == 0) {
        d.command('v');
        d.number(dy);
      } else {
        d.command('l');
        d.number(dx);
        d.number(dy);
      }
      x = nx;
      y = ny;
    }
    d.command('z');
  }
}

// A short id for the k-th drawn path: a..z, A..Z, then two letters and more.
void append_element_id(std::string& text, std::size_t k) {
  static constexpr char letters[] = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ";
  char id[16];
  std::size_t length = 0;
  do {
    id[length++] = letters[k % 52];
    k = k / 52;
  } while (k-- > 0);
  std::reverse(id, id + length);
  text.append(id, length);
}

constexpr float kSolid = 0.75f;

// Drawn without opacity: opaque enough, or covering part of a solid pixel, which must not let the
// background through (a thin rim region averaging solid pixels with the anti-aliased ones beside them).
bool drawn_solid(const Region& region) { return region.alpha >= kSolid || region.covers_solid; }

// ` opacity=".73"` for a translucent region (two decimals), nothing for a solid one.
void append_opacity_attribute(std::string& text, const Region& region) {
  if (drawn_solid(region)) return;
  const auto hundredths = std::clamp<long long>(std::llround(region.alpha * 100.0), 1, 99);
  char number[kCompactDecimalChars];
  text += " opacity=\"";
  text.append(number, write_compact_decimal(hundredths, 2, number));
  text += '"';
}

} // namespace

std::string compact_decimal(std::int64_t units, int decimals) {
  char text[kCompactDecimalChars];
  return {text, write_compact_decimal(units, decimals, text)};
}

Seams parse_seams(std::string_view name) {
  if (name == "none") return Seams::none;
  if (name == "stroke") return Seams::stroke;
  if (name == "underlay") return Seams::underlay;
  throw std::invalid_argument("unknown seam style '" + std::string(name) +
                              "' (choose none, stroke or underlay)");
}

std::string svg_colour(const std::array<float, 3>& rgb) {
  static constexpr char hex[] = "0123456789abcdef";
  int byte[3];
  for (int c = 0; c < 3; ++c)
    byte[c] = static_cast<int>(std::lround(std::clamp(static_cast<double>(rgb[c]), 0.0, 1.0) * 255.0));
  const bool short_form = std::all_of(byte, byte + 3, [](int b) { return b % 17 == 0; });
  std::string out = "#";
  for (int c = 0; c < 3; ++c) {
    if (short_form) {
      out += hex[byte[c] / 17];
    } else {
      out += hex[byte[c] >> 4];
      out += hex[byte[c] & 15];
    }
  }
  return out;
}

std::string svg_document(const std::vector<RegionPolygon>& polygons, const Regions& regions, int width,
                         int height, const SvgOptions& options) {
  if (options.precision < 0 || options.precision > 6)
    throw std::invalid_argument("write_svg: precision must be 0 to 6, got " +
                                std::to_string(options.precision));
  if (!(options.seam_width >= 0) || !std::isfinite(options.seam_width))
    throw std::invalid_argument("write_svg: seam_width must be finite and >= 0");

  std::vector<std::size_t> order(polygons.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const Region& ra = regions.regions[polygons[a].region];
    const Region& rb = regions.regions[polygons[b].region];
    if (ra.area != rb.area) return ra.area > rb.area;
    return polygons[a].region < polygons[b].region;
  });

  // The document is appended to one string: about a million characters for a photograph, in pieces of
  // a few characters each, which a stream's per-insertion overhead made several milliseconds.
  std::string out;
  std::size_t ring_points = 0;
  for (const RegionPolygon& polygon : polygons)
    for (const Ring& ring : polygon.rings) ring_points += ring.points.size();
  out.reserve(1024 + 96 * polygons.size() + 8 * ring_points);
  const std::string w = std::to_string(width);
  const std::string h = std::to_string(height);
  append(out,
         "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"", w,
         "\" height=\"", h, "\" viewBox=\"0 0 ", w, ' ', h, "\">\n");
  const double seam_width = options.seam_width > 0           ? options.seam_width
                            : options.seams == Seams::stroke ? 0.5
                                                             : 3.0;
  // The seam width as a compact number at a fixed 3 decimals.
  const std::string seam = compact_decimal(std::llround(seam_width * 1000.0), 3);
  std::vector<std::size_t> drawn;
  for (std::size_t index : order) {
    const RegionPolygon& polygon = polygons[index];
    if (!regions.regions[polygon.region].transparent && !polygon.rings.empty()) drawn.push_back(index);
  }
  // Translucent regions (alpha from 0.5 to 0.75) are drawn with their opacity and exactly: the underlay
  // covers only solid ones.
  const auto solid = [&](std::size_t index) { return drawn_solid(regions.regions[polygons[index].region]); };
  std::vector<std::size_t> clear; // transparent regions, which the underlay must leave alone
  for (std::size_t index : order) {
    const RegionPolygon& polygon = polygons[index];
    if (regions.regions[polygon.region].transparent && !polygon.rings.empty()) clear.push_back(index);
  }
  // The attributes and data of a drawn path, from the fill to the end of the element.
  const auto append_drawn_path = [&](const RegionPolygon& polygon, bool stroke, bool color) {
    const Region& region = regions.regions[polygon.region];
    const std::string colour = svg_colour(region.rgb);
    append(out, "fill=\"", colour);
    if (stroke) append(out, "\" stroke=\"", colour);
    if (color) append(out, "\" color=\"", colour);
    out += '"';
    append_opacity_attribute(out, region);
    out += " d=\"";
    append_path_data(out, polygon, options.precision);
    out += "\"/>\n";
  };

  switch (options.seams) {
  case Seams::none:
    for (const std::size_t index : drawn) {
      out += "<path ";
      append_drawn_path(polygons[index], false, false);
    }
    break;
  case Seams::stroke:
    append(out, "<g stroke-width=\"", seam, "\" stroke-linejoin=\"round\">\n");
    for (const std::size_t index : drawn) {
      out += "<path ";
      append_drawn_path(polygons[index], true, false);
    }
    out += "</g>\n";
    break;
  case Seams::underlay:
    // The underlay refers to the paths below by id; each path carries its colour as `color` too, so
    // that the underlay's stroke="currentColor" strokes it in its own colour.
    if (!clear.empty()) {
      // The underlay must not paint over transparent areas: the shape's outline already lies on the
      // edge of its rim pixels (PointPlacement), so anything beyond it would colour clear pixels. A
      // luminance mask: white everywhere, transparent regions black.
      append(out, "<mask id=\"opaque\" maskUnits=\"userSpaceOnUse\" x=\"0\" y=\"0\" width=\"", w,
             "\" height=\"", h, "\">\n<rect width=\"", w, "\" height=\"", h,
             "\" fill=\"#fff\"/>\n<g fill=\"#000\">\n");
      for (std::size_t index : clear) {
        out += "<path d=\"";
        append_path_data(out, polygons[index], options.precision);
        out += "\"/>\n";
      }
      out += "</g>\n</mask>\n";
    }
    append(out, "<g stroke=\"currentColor\" stroke-width=\"", seam, "\" stroke-linejoin=\"round\"",
           clear.empty() ? "" : " mask=\"url(#opaque)\"", ">\n");
    for (std::size_t k = 0; k < drawn.size(); ++k) {
      if (!solid(drawn[k])) continue;
      out += "<use href=\"#";
      append_element_id(out, k);
      out += "\"/>\n";
    }
    out += "</g>\n";
    for (std::size_t k = 0; k < drawn.size(); ++k) {
      out += "<path id=\"";
      append_element_id(out, k);
      out += "\" ";
      append_drawn_path(polygons[drawn[k]], false, true);
    }
    break;
  }
  out += "</svg>\n";
  return out;
}

void write_svg(std::ostream& out, const std::vector<RegionPolygon>& polygons, const Regions& regions,
               int width, int height, const SvgOptions& options) {
  out << svg_document(polygons, regions, width, height, options);
}

} // namespace vectorize
