// Stage 10: SVG output. Coordinates are quantised to integers once (units of 10^-precision pixels) and
// relative moves are differences of those integers, so relative path data never drift and a vertex
// shared by two regions lands on the same spot in both paths.

#include "vectorize/svg.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <numeric>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace vectorize {
namespace {

// A sign, a point and up to 20 digits (decimals <= 18: zeros before a small value stay within them).
constexpr std::size_t kCompactDecimalChars = 48;

// The decimal digits of v, written to end just before `end`; returns where they start.
char* write_digits_backwards(std::uint64_t v, char* end) {
  do {
    *--end = static_cast<char>('0' + v % 10);
    v /= 10;
  } while (v != 0);
  return end;
}

constexpr std::uint64_t power_of_ten(int n) { return n == 0 ? 1 : 10 * power_of_ten(n - 1); }

// compact_decimal() written into out (kCompactDecimalChars at least), without allocating: the path data
// of an image has hundreds of thousands of numbers. Returns the length; *has_point says whether the
// number has a decimal point. The places are a template argument so that the whole part and the
// fraction come from a division by a constant, which the compiler turns into a multiplication.
template <int Decimals>
std::size_t write_compact_decimal(std::int64_t units, char* out, bool* has_point) {
  static_assert(Decimals >= 0 && Decimals <= 18);
  const std::uint64_t magnitude =
      units < 0 ? -static_cast<std::uint64_t>(units) : static_cast<std::uint64_t>(units);
  const std::uint64_t whole = magnitude / power_of_ten(Decimals);
  std::uint64_t fraction = magnitude % power_of_ten(Decimals);
  std::size_t places = Decimals;
  if (fraction != 0)
    while (fraction % 10 == 0) { // no trailing zeros
      fraction /= 10;
      --places;
    }
  std::size_t length = 0;
  if (units < 0) out[length++] = '-';
  if (whole != 0 || fraction == 0) { // ".5" is a valid SVG number
    std::size_t count = 1;
    for (std::uint64_t rest = whole; rest >= 10; rest /= 10) ++count;
    write_digits_backwards(whole, out + length + count);
    length += count;
  }
  if (fraction != 0) {
    out[length++] = '.';
    char* const end = out + length + places;
    const char* first = write_digits_backwards(fraction, end);
    std::memset(out + length, '0', static_cast<std::size_t>(first - (out + length))); // leading zeros
    length += places;
  }
  *has_point = fraction != 0;
  return length;
}

// write_compact_decimal() for decimals chosen at run time (clamped to 0..18).
std::size_t write_compact_decimal(std::int64_t units, int decimals, char* out) {
  using Writer = std::size_t (*)(std::int64_t, char*, bool*);
  static constexpr auto writers = []<std::size_t... D>(std::index_sequence<D...>) {
    return std::array<Writer, sizeof...(D)>{&write_compact_decimal<static_cast<int>(D)>...};
  }
  (std::make_index_sequence<19>{});
  bool has_point = false;
  return writers[static_cast<std::size_t>(std::clamp(decimals, 0, 18))](units, out, &has_point);
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
// A document's text, written in place: the string is kept longer than what has been written (its
// tail is slack that resize() zero-filled), so that a piece of a few characters is stored directly
// instead of through a call to append and its capacity check; finish() cuts it to length.
class Text {
public:
  explicit Text(std::size_t expected) { text_.resize(std::max<std::size_t>(expected, 4096)); }

  // Where to write n more characters (then advance() by as many as were written).
  char* room(std::size_t n) {
    if (text_.size() - size_ < n) [[unlikely]]
      grow(n);
    return text_.data() + size_;
  }
  void advance(std::size_t n) { size_ += n; }

  // A string literal: its length known when compiled, the copy inlined.
  template <std::size_t N>
  Text& operator+=(const char (&piece)[N]) {
    std::memcpy(room(N - 1), piece, N - 1);
    size_ += N - 1;
    return *this;
  }
  Text& operator+=(std::string_view piece) {
    std::memcpy(room(piece.size()), piece.data(), piece.size());
    size_ += piece.size();
    return *this;
  }
  Text& operator+=(char c) {
    *room(1) = c;
    ++size_;
    return *this;
  }

  std::string finish() && {
    text_.resize(size_);
    return std::move(text_);
  }

private:
  [[gnu::noinline]] void grow(std::size_t n) { text_.resize(std::max(2 * text_.size(), size_ + n)); }

  std::string text_;
  std::size_t size_ = 0;
};

// Appends each piece (strings and characters) to the text.
template <class... Pieces>
void append(Text& text, const Pieces&... pieces) {
  ((text += pieces), ...);
}

// Path data appended to a document's text, with numbers of Decimals places.
template <int Decimals>
class PathData {
public:
  explicit PathData(Text& text) : text_(text) {}

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
    // The number starts with '-', with its point (below 1 in magnitude, not 0), or with a digit.
    const bool starts_with_point = units > 0 && units < static_cast<std::int64_t>(power_of_ten(Decimals));
    const bool needs_separator = !after_command_ && units >= 0 && !(starts_with_point && previous_had_point_);
    char* out = text_.room(kCompactDecimalChars + 1);
    *out = ' ';
    out += needs_separator ? 1 : 0;
    bool has_point = false;
    const std::size_t length = write_compact_decimal<Decimals>(units, out, &has_point);
    text_.advance(length + (needs_separator ? 1 : 0));
    previous_had_point_ = has_point;
    after_command_ = false;
  }

private:
  Text& text_;
  char last_command_ = 0;
  bool previous_had_point_ = false;
  bool after_command_ = true;
};

template <int Precision>
void append_path_data(Text& text, const RegionPolygon& polygon) {
  static constexpr double kPowersOfTen[] = {1.0, 10.0, 100.0, 1e3, 1e4, 1e5, 1e6}; // precision 0 to 6
  const double scale = kPowersOfTen[Precision];
  PathData<Precision> d(text);
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

void append_path_data(Text& text, const RegionPolygon& polygon, int precision) {
  switch (precision) {
  case 0:
    return append_path_data<0>(text, polygon);
  case 1:
    return append_path_data<1>(text, polygon);
  case 2:
    return append_path_data<2>(text, polygon);
  case 3:
    return append_path_data<3>(text, polygon);
  case 4:
    return append_path_data<4>(text, polygon);
  case 5:
    return append_path_data<5>(text, polygon);
  default:
    return append_path_data<6>(text, polygon);
  }
}

// A short id for the k-th drawn path: a..z, A..Z, then two letters and more.
void append_element_id(Text& text, std::size_t k) {
  static constexpr char letters[] = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ";
  char id[16];
  std::size_t length = 0;
  do {
    id[length++] = letters[k % 52];
    k = k / 52;
  } while (k-- > 0);
  std::reverse(id, id + length);
  text += std::string_view(id, length);
}

constexpr float kSolid = 0.75f;

// Drawn without opacity: opaque enough, or covering part of a solid pixel, which must not let the
// background through (a thin rim region averaging solid pixels with the anti-aliased ones beside them).
bool drawn_solid(const Region& region) { return region.alpha >= kSolid || region.covers_solid; }

// ` opacity=".73"` for a translucent region (two decimals), nothing for a solid one.
void append_opacity_attribute(Text& text, const Region& region) {
  if (drawn_solid(region)) return;
  const auto hundredths = std::clamp<long long>(std::llround(region.alpha * 100.0), 1, 99);
  char number[kCompactDecimalChars];
  text += " opacity=\"";
  text += std::string_view(number, write_compact_decimal(hundredths, 2, number));
  text += '"';
}

// The polygons' indices by decreasing region area, then increasing region id, ties in index order (a
// stable sort). A comparison sort mispredicts about every other comparison of areas; a least
// significant digit first radix sort of the region ids and then the areas, 11 bits a pass, has no
// data-dependent branch, and a pass whose digit is the same for every key is skipped.
std::vector<std::uint32_t> drawing_order(const std::vector<RegionPolygon>& polygons, const Regions& regions) {
  const std::size_t n = polygons.size();
  // Area as an unsigned key whose order is the reverse of the areas' (larger area, smaller key): the
  // bits of a non-negative double ordered as the value, those of a negative one reversed. -0 and +0
  // compare equal, so both are +0 here.
  const auto area_key = [&](std::size_t i) {
    const double area = regions.regions[polygons[i].region].area;
    const auto bits = std::bit_cast<std::uint64_t>(area == 0.0 ? 0.0 : area);
    const std::uint64_t ascending = (bits >> 63) != 0 ? ~bits : bits | (std::uint64_t{1} << 63);
    return ~ascending;
  };
  struct Item {
    std::uint64_t area;
    std::uint32_t region;
    std::uint32_t index;
  };
  std::vector<Item> items(n);
  std::vector<Item> spare(n);
  for (std::size_t i = 0; i < n; ++i)
    items[i] = {area_key(i), polygons[i].region, static_cast<std::uint32_t>(i)};
  constexpr int kBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kBits;
  std::vector<std::uint32_t> count(kBuckets);
  const auto pass = [&](auto digit) {
    std::fill(count.begin(), count.end(), 0u);
    for (const Item& item : items) ++count[digit(item)];
    if (count[digit(items.front())] == n) return; // one digit for all: the order stands
    std::uint32_t sum = 0;
    for (std::uint32_t& c : count) sum += std::exchange(c, sum);
    for (const Item& item : items) spare[count[digit(item)]++] = item;
    items.swap(spare);
  };
  if (n > 1) {
    for (int shift = 0; shift < 32; shift += kBits)
      pass([shift](const Item& item) { return (item.region >> shift) & (kBuckets - 1); });
    for (int shift = 0; shift < 64; shift += kBits)
      pass([shift](const Item& item) {
        return static_cast<std::size_t>(item.area >> shift) & (kBuckets - 1);
      });
  }
  std::vector<std::uint32_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = items[i].index;
  return order;
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

  const std::vector<std::uint32_t> order = drawing_order(polygons, regions);

  // The document is appended to one string: about a million characters for a photograph, in pieces of
  // a few characters each, which a stream's per-insertion overhead made several milliseconds.
  std::size_t ring_points = 0;
  for (const RegionPolygon& polygon : polygons)
    for (const Ring& ring : polygon.rings) ring_points += ring.points.size();
  Text out(1024 + 96 * polygons.size() + 8 * ring_points);
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
  for (const std::size_t index : order) {
    const RegionPolygon& polygon = polygons[index];
    if (!regions.regions[polygon.region].transparent && !polygon.rings.empty()) drawn.push_back(index);
  }
  // Translucent regions (alpha from 0.5 to 0.75) are drawn with their opacity and exactly: the underlay
  // covers only solid ones.
  const auto solid = [&](std::size_t index) { return drawn_solid(regions.regions[polygons[index].region]); };
  std::vector<std::size_t> clear; // transparent regions, which the underlay must leave alone
  for (const std::size_t index : order) {
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
  return std::move(out).finish();
}

void write_svg(std::ostream& out, const std::vector<RegionPolygon>& polygons, const Regions& regions,
               int width, int height, const SvgOptions& options) {
  out << svg_document(polygons, regions, width, height, options);
}

} // namespace vectorize
