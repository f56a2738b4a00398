// make_samples: writes the small sample images that exercise the vectorizer (see README.md).
//
// Usage: make_samples <output-dir>
//
// Every image is procedural and deterministic: the only randomness comes from a fixed-seed
// splitmix64 generator, never from <random> distributions, whose output differs between standard
// libraries. Re-running the program therefore reproduces the committed PNGs.
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

namespace {

namespace fs = std::filesystem;

constexpr double pi = 3.14159265358979323846;

// --- Small vector and colour types ------------------------------------------------------------

struct Vec2 {
  double x = 0.0;
  double y = 0.0;
};

Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
Vec2 operator*(Vec2 a, double s) { return {a.x * s, a.y * s}; }
double dot(Vec2 a, Vec2 b) { return a.x * b.x + a.y * b.y; }
double length(Vec2 a) { return std::sqrt(dot(a, a)); }
double cross(Vec2 a, Vec2 b) { return a.x * b.y - a.y * b.x; }

struct Color {
  double r = 0.0;
  double g = 0.0;
  double b = 0.0;
};

Color operator+(Color a, Color b) { return {a.r + b.r, a.g + b.g, a.b + b.b}; }
Color operator*(Color a, double s) { return {a.r * s, a.g * s, a.b * s}; }

Color mix(Color a, Color b, double t) { return a * (1.0 - t) + b * t; }

// Colours are written as sRGB bytes in the code so they can be compared with a colour picker.
constexpr Color from_hex(std::uint32_t rgb) {
  return {((rgb >> 16) & 0xFF) / 255.0, ((rgb >> 8) & 0xFF) / 255.0, (rgb & 0xFF) / 255.0};
}

// Straight (non-premultiplied) colour plus coverage, as a shading function returns it.
struct Rgba {
  Color rgb;
  double a = 1.0;
};

double clamp01(double v) { return std::clamp(v, 0.0, 1.0); }

double smoothstep(double edge0, double edge1, double v) {
  const double t = clamp01((v - edge0) / (edge1 - edge0));
  return t * t * (3.0 - 2.0 * t);
}

// --- Deterministic randomness -----------------------------------------------------------------

// The splitmix64 finaliser: a good 64-bit mixer, so lattice coordinates can be hashed directly
// into noise values without keeping a table.
std::uint64_t mix64(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

class SplitMix64 {
public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}

  std::uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ULL;
    return mix64(state_);
  }

private:
  std::uint64_t state_;
};

// 53 bits give every double in [0, 1) on a uniform grid, identically on every platform.
double hash01(std::int64_t x, std::int64_t y, std::uint64_t seed) {
  const std::uint64_t key = mix64(static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ULL ^
                                  static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4FULL ^ seed);
  return static_cast<double>(key >> 11) * 0x1.0p-53;
}

// Value noise rather than gradient noise: it is enough for texture and trivially reproducible.
double value_noise(double x, double y, std::uint64_t seed) {
  const double fx = std::floor(x);
  const double fy = std::floor(y);
  const auto ix = static_cast<std::int64_t>(fx);
  const auto iy = static_cast<std::int64_t>(fy);
  const double tx = smoothstep(0.0, 1.0, x - fx);
  const double ty = smoothstep(0.0, 1.0, y - fy);
  const double top = std::lerp(hash01(ix, iy, seed), hash01(ix + 1, iy, seed), tx);
  const double bottom = std::lerp(hash01(ix, iy + 1, seed), hash01(ix + 1, iy + 1, seed), tx);
  return std::lerp(top, bottom, ty);
}

// Fractal sum of value noise, normalised to [0, 1].
double fbm(double x, double y, std::uint64_t seed, int octaves) {
  double sum = 0.0;
  double amplitude = 1.0;
  double total = 0.0;
  for (int octave = 0; octave < octaves; ++octave) {
    sum += amplitude * value_noise(x, y, seed + static_cast<std::uint64_t>(octave));
    total += amplitude;
    amplitude *= 0.5;
    x *= 2.03; // not exactly 2, so the lattices of successive octaves do not line up
    y *= 2.03;
  }
  return sum / total;
}

// --- Images and rendering ---------------------------------------------------------------------

struct Image {
  Image(int w, int h, int c)
      : width(w), height(h), channels(c), values(static_cast<std::size_t>(w) * h * c, 0.0) {}

  double& at(int x, int y, int c) { return values[(static_cast<std::size_t>(y) * width + x) * channels + c]; }
  double at(int x, int y, int c) const {
    return values[(static_cast<std::size_t>(y) * width + x) * channels + c];
  }

  int width;
  int height;
  int channels;
  std::vector<double> values; // kept unclamped until quantisation so shading never clips early
};

// A regular grid rather than a jittered one: the coverage of a straight edge then stays constant
// along its length, which is what the anti-aliasing of real raster art looks like.
constexpr int samples_per_axis = 4;
constexpr int samples_per_pixel = samples_per_axis * samples_per_axis;

Vec2 sample_position(int x, int y, int sample) {
  const double step = 1.0 / samples_per_axis;
  return {x + (sample % samples_per_axis + 0.5) * step, y + (sample / samples_per_axis + 0.5) * step};
}

// Averages premultiplied colour so partly covered pixels keep the shape's colour, not a blend with
// the (meaningless) colour of fully transparent samples.
template <class ShadeFn>
Image render(int width, int height, int channels, const ShadeFn& shade) {
  Image image(width, height, channels);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      Color sum;
      double coverage = 0.0;
      for (int s = 0; s < samples_per_pixel; ++s) {
        const Rgba sample = shade(sample_position(x, y, s));
        sum = sum + sample.rgb * sample.a;
        coverage += sample.a;
      }
      const Color rgb = coverage > 0.0 ? sum * (1.0 / coverage) : Color{};
      image.at(x, y, 0) = rgb.r;
      image.at(x, y, 1) = rgb.g;
      image.at(x, y, 2) = rgb.b;
      if (channels == 4) image.at(x, y, 3) = coverage / samples_per_pixel;
    }
  }
  return image;
}

// Ordered (Bayer) dither instead of random dither: smooth ramps do not band, and the repeating
// pattern still compresses well.
constexpr std::array<int, 16> bayer4 = {0, 8, 2, 10, 12, 4, 14, 6, 3, 11, 1, 9, 15, 7, 13, 5};

std::vector<std::uint8_t> quantise(const Image& image, bool dither) {
  std::vector<std::uint8_t> bytes(image.values.size());
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const double offset = dither ? (bayer4[(y % 4) * 4 + x % 4] + 0.5) / 16.0 : 0.5;
      for (int c = 0; c < image.channels; ++c) {
        const double level = std::floor(clamp01(image.at(x, y, c)) * 255.0 + offset);
        bytes[(static_cast<std::size_t>(y) * image.width + x) * image.channels + c] =
            static_cast<std::uint8_t>(std::min(level, 255.0));
      }
    }
  }
  return bytes;
}

// Writes to a temporary name first so an interrupted run never leaves a truncated sample behind.
void write_png(const fs::path& path, const Image& image, bool dither) {
  const std::vector<std::uint8_t> bytes = quantise(image, dither);
  const fs::path tmp = fs::path(path).replace_extension(".tmp.png");

  const auto discard = [&tmp](const std::string& what) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw std::runtime_error(what);
  };

  auto out = OIIO::ImageOutput::create(tmp.string());
  if (!out) throw std::runtime_error("no PNG writer for " + tmp.string() + ": " + OIIO::geterror());

  OIIO::ImageSpec spec(image.width, image.height, image.channels, OIIO::TypeDesc::UINT8);
  // Our alpha is straight already; without this OIIO would treat the pixels as premultiplied and
  // divide the colour of every edge pixel by its alpha once more.
  if (image.channels == 4) spec.attribute("oiio:UnassociatedAlpha", 1);
  spec.attribute("png:compressionLevel", 9);

  if (!out->open(tmp.string(), spec)) discard("cannot open " + tmp.string() + ": " + out->geterror());
  if (!out->write_image(OIIO::TypeDesc::UINT8, bytes.data())) {
    const std::string error = out->geterror();
    out->close();
    discard("cannot write " + tmp.string() + ": " + error);
  }
  if (!out->close()) discard("cannot finish " + tmp.string() + ": " + out->geterror());
  out.reset();

  std::error_code error;
  fs::rename(tmp, path, error);
  if (error) discard("cannot rename " + tmp.string() + " to " + path.string() + ": " + error.message());
}

// --- logo.png: flat colours, holes and transparency -------------------------------------------

double sd_circle(Vec2 p, Vec2 centre, double radius) { return length(p - centre) - radius; }

double sd_rounded_box(Vec2 p, Vec2 centre, Vec2 half_size, double corner) {
  const Vec2 q{std::abs(p.x - centre.x) - half_size.x + corner,
               std::abs(p.y - centre.y) - half_size.y + corner};
  const Vec2 outside{std::max(q.x, 0.0), std::max(q.y, 0.0)};
  return length(outside) + std::min(std::max(q.x, q.y), 0.0) - corner;
}

bool inside_triangle(Vec2 p, Vec2 a, Vec2 b, Vec2 c) {
  const double ab = cross(b - a, p - a);
  const double bc = cross(c - b, p - b);
  const double ca = cross(a - c, p - c);
  return (ab >= 0.0 && bc >= 0.0 && ca >= 0.0) || (ab <= 0.0 && bc <= 0.0 && ca <= 0.0);
}

Image make_logo() {
  constexpr Color teal = from_hex(0x1B8A96);
  constexpr Color coral = from_hex(0xE8524A);
  constexpr Color orange = from_hex(0xF5A623);
  constexpr Color purple = from_hex(0x6A3FA0);

  return render(256, 256, 4, [&](Vec2 p) -> Rgba {
    // Painter's order: later shapes cover earlier ones, so the triangle shares an edge with the
    // box (two colours meeting) while the other shapes only meet the transparent background.
    const Vec2 triangle_a{64.0, 238.0};
    const Vec2 triangle_b{150.0, 114.0};
    const Vec2 triangle_c{236.0, 238.0};
    if (inside_triangle(p, triangle_a, triangle_b, triangle_c)) return {purple, 1.0};

    // A box with a rectangular hole: the hole must come out as a second boundary, not be filled.
    const bool in_box = sd_rounded_box(p, {184.0, 80.0}, {52.0, 52.0}, 16.0) < 0.0;
    const bool in_box_hole = sd_rounded_box(p, {184.0, 80.0}, {18.0, 26.0}, 0.0) < 0.0;
    if (in_box && !in_box_hole) return {orange, 1.0};

    // A ring with an island in its hole: boundary nesting three levels deep.
    const Vec2 ring_centre{72.0, 80.0};
    if (sd_circle(p, ring_centre, 14.0) < 0.0) return {coral, 1.0};
    const double ring = std::max(sd_circle(p, ring_centre, 56.0), -sd_circle(p, ring_centre, 30.0));
    if (ring < 0.0) return {teal, 1.0};

    return {Color{}, 0.0};
  });
}

// --- strokes.png: constant-width pen strokes --------------------------------------------------

using Polyline = std::vector<Vec2>;

// Coverage of round-pen strokes, one bit per subsample: strokes are few and thin, so stamping each
// segment into its bounding box is far cheaper than testing every segment at every sample.
class StrokeCanvas {
public:
  StrokeCanvas(int w, int h) : width_(w), height_(h), masks_(static_cast<std::size_t>(w) * h, 0) {}

  void stroke(const Polyline& points, double radius) {
    if (points.size() == 1) stamp_segment(points[0], points[0], radius);
    for (std::size_t i = 1; i < points.size(); ++i) stamp_segment(points[i - 1], points[i], radius);
  }

  double coverage(int x, int y) const {
    return std::popcount(masks_[static_cast<std::size_t>(y) * width_ + x]) /
           static_cast<double>(samples_per_pixel);
  }

private:
  void stamp_segment(Vec2 a, Vec2 b, double radius) {
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min(a.x, b.x) - radius)));
    const int x1 = std::min(width_ - 1, static_cast<int>(std::ceil(std::max(a.x, b.x) + radius)));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min(a.y, b.y) - radius)));
    const int y1 = std::min(height_ - 1, static_cast<int>(std::ceil(std::max(a.y, b.y) + radius)));
    const Vec2 ab = b - a;
    const double ab_length2 = dot(ab, ab);
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        std::uint16_t& mask = masks_[static_cast<std::size_t>(y) * width_ + x];
        for (int s = 0; s < samples_per_pixel; ++s) {
          const Vec2 p = sample_position(x, y, s);
          const double t = ab_length2 > 0.0 ? std::clamp(dot(p - a, ab) / ab_length2, 0.0, 1.0) : 0.0;
          if (length(p - (a + ab * t)) <= radius) mask = static_cast<std::uint16_t>(mask | (1u << s));
        }
      }
    }
  }

  int width_;
  int height_;
  std::vector<std::uint16_t> masks_;
};

static_assert(samples_per_pixel <= 16, "StrokeCanvas keeps one bit per subsample in 16 bits");

Polyline cubic(Vec2 p0, Vec2 p1, Vec2 p2, Vec2 p3, int steps = 24) {
  Polyline points;
  for (int i = 0; i <= steps; ++i) {
    const double t = static_cast<double>(i) / steps;
    const double u = 1.0 - t;
    points.push_back(p0 * (u * u * u) + p1 * (3.0 * u * u * t) + p2 * (3.0 * u * t * t) + p3 * (t * t * t));
  }
  return points;
}

// Angles in radians, counter-clockwise in the y-up glyph space.
Polyline arc(Vec2 centre, Vec2 radii, double from, double to, int steps = 32) {
  Polyline points;
  for (int i = 0; i <= steps; ++i) {
    const double angle = std::lerp(from, to, static_cast<double>(i) / steps);
    points.push_back({centre.x + radii.x * std::cos(angle), centre.y + radii.y * std::sin(angle)});
  }
  return points;
}

Polyline join(Polyline first, const Polyline& second) {
  first.insert(first.end(), second.begin(), second.end());
  return first;
}

struct Glyph {
  double advance = 0.0;
  std::vector<Polyline> strokes; // in x-height units, baseline at y = 0, y pointing up
};

// Hand-built letters of the word "trixel": made of lines, arcs and Bezier curves so the sample needs
// no font, and every curve is one a vectorizer must follow with a constant-width stroke.
std::vector<Glyph> trixel_glyphs() {
  std::vector<Glyph> glyphs;
  glyphs.push_back({0.85,
                    {join({{0.3, 1.55}}, cubic({0.3, 0.25}, {0.3, -0.05}, {0.6, -0.05}, {0.8, 0.15})),
                     {{0.0, 1.0}, {0.72, 1.0}}}});
  glyphs.push_back(
      {0.8, {{{0.1, 1.0}, {0.1, 0.0}}, cubic({0.1, 0.55}, {0.2, 0.95}, {0.5, 1.08}, {0.75, 0.88})}});
  glyphs.push_back({0.45, {{{0.15, 1.0}, {0.15, 0.0}}, {{0.15, 1.42}}}});
  glyphs.push_back({0.85, {{{0.0, 1.0}, {0.72, 0.0}}, {{0.72, 1.0}, {0.0, 0.0}}}});
  glyphs.push_back({0.95, {join({{0.02, 0.5}}, arc({0.42, 0.5}, {0.4, 0.5}, 0.0, 2.0 * pi - 0.75))}});
  glyphs.push_back(
      {0.6, {join({{0.15, 1.85}}, cubic({0.15, 0.2}, {0.15, -0.05}, {0.35, -0.05}, {0.5, 0.08}))}});
  return glyphs;
}

Image make_strokes() {
  constexpr int width = 320;
  constexpr int height = 240;
  constexpr Color paper = from_hex(0xF6F1E4);
  constexpr Color ink = from_hex(0x1E2030);
  constexpr double pen = 2.6;      // radius: strokes about 5 px wide
  constexpr double fine_pen = 1.0; // radius: a 2 px hairline, the thinnest a vectorizer should keep

  StrokeCanvas canvas(width, height);

  // A row of cursive loops (a prolate trochoid), like a handwriting exercise: self-crossing strokes.
  Polyline loops;
  for (int i = 0; i <= 900; ++i) {
    const double t = -0.5 * pi + 5.5 * 2.0 * pi * i / 900.0;
    loops.push_back({30.0 + 5.0 * t + 13.0 * std::sin(t), 58.0 + 20.0 * std::cos(t)});
  }
  canvas.stroke(loops, pen);

  // A spiral: curvature that changes continuously.
  Polyline spiral;
  for (int i = 0; i <= 400; ++i) {
    const double angle = 4.0 * pi * i / 400.0;
    const double radius = 3.0 + 2.2 * angle;
    spiral.push_back({268.0 + radius * std::cos(angle), 56.0 - radius * std::sin(angle)});
  }
  canvas.stroke(spiral, pen);

  // The word, slanted like handwriting.
  const Vec2 origin{34.0, 168.0};
  const double scale = 38.0;
  const double slant = 0.22;
  double cursor = 0.0;
  for (const Glyph& glyph : trixel_glyphs()) {
    for (const Polyline& glyph_stroke : glyph.strokes) {
      Polyline mapped;
      for (const Vec2 g : glyph_stroke) {
        mapped.push_back({origin.x + scale * (cursor + g.x + slant * g.y), origin.y - scale * g.y});
      }
      canvas.stroke(mapped, pen);
    }
    cursor += glyph.advance + 0.22;
  }

  // An underline flourish drawn with a finer pen.
  canvas.stroke(cubic({30.0, 196.0}, {110.0, 214.0}, {200.0, 176.0}, {292.0, 198.0}, 64), fine_pen);

  Image image(width, height, 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Color c = mix(paper, ink, canvas.coverage(x, y));
      image.at(x, y, 0) = c.r;
      image.at(x, y, 1) = c.g;
      image.at(x, y, 2) = c.b;
    }
  }
  return image;
}

// --- gradient.png: smooth shading only --------------------------------------------------------

double gaussian(Vec2 p, Vec2 centre, double sigma) {
  const Vec2 d = p - centre;
  return std::exp(-dot(d, d) / (2.0 * sigma * sigma));
}

Image make_gradient() {
  constexpr int size = 256;
  constexpr Color deep_blue = from_hex(0x1C2E6E);
  constexpr Color warm = from_hex(0xF29E4C);
  constexpr Color magenta = from_hex(0xD14B9A);
  constexpr Color mint = from_hex(0x6FD6A8);

  return render(size, size, 3, [&](Vec2 p) -> Rgba {
    const Vec2 uv = p * (1.0 / size);
    // A diagonal linear ramp, lit by a broad radial highlight: no edge anywhere, only slopes.
    Color c = mix(deep_blue, warm, smoothstep(-0.1, 1.1, 0.65 * uv.x + 0.45 * uv.y));
    const double highlight = std::pow(clamp01(1.0 - length(uv - Vec2{0.38, 0.36}) / 0.75), 2.0);
    c = c + Color{1.0, 0.95, 0.85} * (0.28 * highlight);
    // Two soft blobs, wide enough that their falloff spans dozens of pixels.
    c = mix(c, magenta, 0.75 * gaussian(uv, {0.74, 0.30}, 0.11));
    c = mix(c, mint, 0.65 * gaussian(uv, {0.28, 0.76}, 0.10));
    return {c, 1.0};
  });
}

// --- photo.png: hard edges and smooth shading together ----------------------------------------

// Lambert shading of a sphere (or a squashed one): enough to make round objects read as 3D.
double sphere_light(Vec2 p, Vec2 centre, Vec2 radii) {
  const double nx = (p.x - centre.x) / radii.x;
  const double ny = (p.y - centre.y) / radii.y;
  const double nz = std::sqrt(std::max(0.0, 1.0 - nx * nx - ny * ny));
  // Light from the upper right, where the sun is; y points down in image space.
  const double lx = 0.55;
  const double ly = -0.55;
  const double lz = 0.63;
  return std::max(0.0, nx * lx + ny * ly + nz * lz);
}

Image make_photo() {
  // The scene is laid out on a 320x240 canvas but rendered smaller: grain makes every pixel cost
  // bytes, and the sample should stay small enough to keep in the repository.
  constexpr int width = 288;
  constexpr int height = 216;
  constexpr double canvas_scale = 320.0 / width;

  SplitMix64 rng(0x7A1C0DE5EED5ULL);
  const std::uint64_t cloud_seed = rng.next();
  const std::uint64_t far_ridge_seed = rng.next();
  const std::uint64_t near_ridge_seed = rng.next();
  const std::uint64_t grass_seed = rng.next();
  const std::uint64_t leaf_seed = rng.next();
  const std::uint64_t grain_seed = rng.next();

  const auto far_ridge = [=](double x) {
    return 118.0 + 34.0 * (fbm(x / 60.0, 0.5, far_ridge_seed, 4) - 0.5);
  };
  const auto near_ridge = [=](double x) {
    return 160.0 + 40.0 * (fbm(x / 110.0, 0.5, near_ridge_seed, 3) - 0.5) + 0.06 * (x - 160.0);
  };

  const Vec2 sun{252.0, 48.0};
  const double sun_radius = 15.0;

  const double house_left = 52.0;
  const double house_right = 100.0;
  const double house_side = 114.0; // the side wall, seen at an angle, ends here
  const double house_ground = near_ridge(83.0) + 10.0;
  const double house_eaves = house_ground - 30.0;
  const Vec2 roof_peak{76.0, house_eaves - 24.0};

  const double tree_x = 178.0;
  const double tree_ground = near_ridge(tree_x) + 22.0;
  const Vec2 crown{tree_x, tree_ground - 46.0};
  const double crown_radius = 21.0;

  const Vec2 rock{244.0, 212.0};
  const Vec2 rock_radii{26.0, 15.0};

  constexpr Color sky_top = from_hex(0x2F5FA8);
  constexpr Color sky_horizon = from_hex(0xD8E4EC);
  constexpr Color sun_color = from_hex(0xFFF3C8);
  constexpr Color glow = from_hex(0xFFD08A);
  constexpr Color far_hill = from_hex(0x6F8F96);
  constexpr Color grass = from_hex(0x4E8A2E);
  constexpr Color grass_dark = from_hex(0x2A5418);
  constexpr Color wall = from_hex(0xEADCC0);
  constexpr Color roof = from_hex(0xA8382A);
  constexpr Color window_color = from_hex(0x2E3F56);
  constexpr Color door = from_hex(0x6B4427);
  constexpr Color bark = from_hex(0x5A3B1E);
  constexpr Color leaves = from_hex(0x2F6B24);
  constexpr Color stone = from_hex(0x8E8A84);

  Image image = render(width, height, 3, [&](Vec2 pixel) -> Rgba {
    const Vec2 p = pixel * canvas_scale;
    // Objects in front first, so each sample resolves to exactly one surface.
    if (sd_circle(p, crown, crown_radius) < 0.0) {
      const double texture = fbm(p.x / 4.0, p.y / 4.0, leaf_seed, 2) - 0.5;
      return {leaves * (0.35 + 0.9 * sphere_light(p, crown, {crown_radius, crown_radius}) + 0.35 * texture),
              1.0};
    }
    if (std::abs(p.x - tree_x) < 4.0 && p.y > crown.y && p.y < tree_ground) {
      return {bark * (p.x > tree_x ? 1.15 : 0.8), 1.0}; // lit and shaded halves of the trunk
    }
    if (const Vec2 d{(p.x - rock.x) / rock_radii.x, (p.y - rock.y) / rock_radii.y}; dot(d, d) < 1.0) {
      return {stone * (0.3 + 0.95 * sphere_light(p, rock, rock_radii)), 1.0};
    }
    if (inside_triangle(p, {house_left - 6.0, house_eaves}, roof_peak, {house_right + 6.0, house_eaves})) {
      return {roof * (0.85 + 0.3 * (p.y - roof_peak.y) / (house_eaves - roof_peak.y)), 1.0};
    }
    // The side roof, seen at an angle: a quad from the ridge back over the side wall, in shade.
    const Vec2 eave_front{house_right + 6.0, house_eaves};
    const Vec2 ridge_back{house_side + 4.0, roof_peak.y + 0.15 * (house_side + 4.0 - roof_peak.x)};
    const Vec2 eave_back{house_side + 4.0, house_eaves + 0.15 * (house_side + 4.0 - eave_front.x)};
    if (inside_triangle(p, roof_peak, ridge_back, eave_back) ||
        inside_triangle(p, roof_peak, eave_back, eave_front)) {
      return {roof * 0.62, 1.0};
    }
    if (p.y > house_eaves && p.y < house_ground && p.x > house_left && p.x < house_side) {
      if (p.x >= house_right) return {wall * 0.72, 1.0}; // side wall in shade
      if (p.x > 60.0 && p.x < 74.0 && p.y > house_eaves + 7.0 && p.y < house_eaves + 19.0) {
        const bool frame = std::abs(p.x - 67.0) < 0.8 || std::abs(p.y - (house_eaves + 13.0)) < 0.8;
        return {frame ? wall : window_color, 1.0};
      }
      if (p.x > 80.0 && p.x < 92.0 && p.y > house_eaves + 10.0) return {door, 1.0};
      return {wall * (0.95 + 0.1 * (p.y - house_eaves) / (house_ground - house_eaves)), 1.0};
    }

    const double near_top = near_ridge(p.x);
    if (p.y > near_top) {
      const double depth = p.y - near_top;
      const double texture = fbm(p.x / 16.0, p.y / 6.0, grass_seed, 3) - 0.5;
      Color c = mix(grass, grass_dark, smoothstep(0.0, 90.0, depth)) * (1.0 + 0.28 * texture);
      // Soft shadows of the tree and the rock, cast away from the sun.
      const double tree_shadow = gaussian({(p.x - tree_x + 20.0) * 0.45, p.y - tree_ground}, {0.0, 0.0}, 5.0);
      const double rock_shadow = gaussian({(p.x - rock.x + 14.0) * 0.5, p.y - rock.y - 9.0}, {0.0, 0.0}, 5.0);
      c = c * (1.0 - 0.45 * std::max(tree_shadow, rock_shadow));
      return {c, 1.0};
    }

    const double far_top = far_ridge(p.x);
    if (p.y > far_top) {
      const double texture = fbm(p.x / 14.0, p.y / 7.0, far_ridge_seed + 17, 3) - 0.5;
      // Aerial perspective: the far hills fade towards the sky colour near their crest.
      const double haze = 0.35 * (1.0 - smoothstep(0.0, 30.0, p.y - far_top));
      return {mix(far_hill * (1.0 + 0.18 * texture), sky_horizon, haze), 1.0};
    }

    Color c = mix(sky_top, sky_horizon, std::pow(clamp01(p.y / 140.0), 1.4));
    const double clouds = smoothstep(0.52, 0.78, fbm(p.x / 70.0, p.y / 22.0, cloud_seed, 4));
    c = mix(c, Color{0.97, 0.97, 0.98}, 0.7 * clouds);
    const double d = length(p - sun);
    c = c + glow * (0.45 * std::exp(-std::max(0.0, d - sun_radius) / 22.0));
    c = mix(c, sun_color, smoothstep(sun_radius + 1.5, sun_radius - 1.5, d));
    return {c, 1.0};
  });

  // Film grain per pixel, not per sample (supersampling would average it away), and equal in all
  // channels so it reads as luminance noise rather than coloured speckle. Under one 8-bit step:
  // enough to break up flat runs as sensor noise does, small enough to keep the file compact.
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const double grain = (hash01(x, y, grain_seed) - 0.5) * (1.6 / 255.0);
      for (int c = 0; c < 3; ++c) image.at(x, y, c) += grain;
    }
  }
  return image;
}

struct Sample {
  const char* file_name;
  Image (*make)();
  bool dither;
};

} // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <output-dir>\n", argc > 0 ? argv[0] : "make_samples");
    return 1;
  }
  try {
    const fs::path dir = argv[1];
    fs::create_directories(dir);
    const std::array<Sample, 4> samples = {{
        {"logo.png", make_logo, false},
        {"strokes.png", make_strokes, false},
        {"gradient.png", make_gradient, true},
        {"photo.png", make_photo, false},
    }};
    for (const Sample& sample : samples) {
      const Image image = sample.make();
      const fs::path path = dir / sample.file_name;
      write_png(path, image, sample.dither);
      std::printf("wrote %s (%dx%d, %d channels)\n", path.string().c_str(), image.width, image.height,
                  image.channels);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_samples: %s\n", e.what());
    return 1;
  }
  return 0;
}
