// Stage 5: the PSLG for the CDT engine: polyline vertices at pixel centres, the image border as
// segments, and free interior points where the colour of a region varies.
#include "vectorize/pslg_build.hpp"

#include "vectorize/placement.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <unordered_set>
#include <utility>
#include <vector>

namespace vectorize {
namespace {

constexpr double kCentre = 0.5; // offset of a pixel's centre from its top-left corner

// A set of 64-bit keys (never all ones), by open addressing with linear probing in a power-of-two
// table kept at most half full: one flat array instead of a node per key.
class FlatSet {
public:
  // Room for n keys without growing.
  void reserve(std::size_t n) {
    std::size_t slots = 64;
    while (slots < 2 * n) slots *= 2;
    if (slots > slots_.size()) rehash(slots);
  }

  // Whether key was absent (and is now present).
  bool insert(std::uint64_t key) {
    if (2 * (size_ + 1) > slots_.size()) rehash(std::max<std::size_t>(64, 2 * slots_.size()));
    const std::size_t mask = slots_.size() - 1;
    for (std::size_t i = hash(key) & mask;; i = (i + 1) & mask) {
      std::uint64_t& slot = slots_[i];
      if (slot == key) return false;
      if (slot == kEmpty) {
        slot = key;
        ++size_;
        return true;
      }
    }
  }

private:
  static constexpr std::uint64_t kEmpty = std::numeric_limits<std::uint64_t>::max();
  static std::size_t hash(std::uint64_t key) {
    key ^= key >> 33; // a 64-bit finaliser (MurmurHash3's fmix64)
    key *= 0xff51afd7ed558ccdULL;
    key ^= key >> 33;
    key *= 0xc4ceb9fe1a85ec53ULL;
    key ^= key >> 33;
    return static_cast<std::size_t>(key);
  }
  void rehash(std::size_t slots) {
    std::vector<std::uint64_t> old = std::move(slots_);
    slots_.assign(slots, kEmpty);
    size_ = 0;
    for (const std::uint64_t key : old)
      if (key != kEmpty) insert(key);
  }

  std::vector<std::uint64_t> slots_;
  std::size_t size_ = 0;
};

class Builder {
public:
  // `segments`: about how many segments will be made (room is made for them).
  Builder(PointPlacement placement, int width, int height, std::size_t segments)
      : placement_(placement), width_(width),
        pixel_index_(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), kNoPoint) {
    segment_keys_.reserve(segments);
  }

  std::uint32_t pixel_point(const PixelPoint& p) {
    std::uint32_t& index =
        pixel_index_[static_cast<std::size_t>(p.y) * width_ + static_cast<std::size_t>(p.x)];
    if (index == kNoPoint) {
      index = static_cast<std::uint32_t>(pslg_.points.size());
      const Position at = placement_.position(p);
      pslg_.points.push_back({at.x, at.y});
    }
    return index;
  }

  std::uint32_t free_point(double x, double y) {
    pslg_.points.push_back({x, y});
    return static_cast<std::uint32_t>(pslg_.points.size() - 1);
  }

  void segment(std::uint32_t a, std::uint32_t b) {
    if (a == b) return;
    const std::uint64_t key = (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
    if (!segment_keys_.insert(key)) return;
    pslg_.segments.push_back({a, b});
    if (degree_.size() < pslg_.points.size()) degree_.resize(pslg_.points.size() * 2, 0);
    ++degree_[a];
    ++degree_[b];
  }

  // Frees the pixel index (4 bytes a pixel) once no more pixel points are asked for, before the
  // interior points' per-pixel buffers are made.
  void drop_pixel_index() { std::vector<std::uint32_t>().swap(pixel_index_); }

  std::uint32_t degree(std::uint32_t p) const { return p < degree_.size() ? degree_[p] : 0; }
  Pslg& pslg() { return pslg_; }

private:
  static constexpr std::uint32_t kNoPoint = std::numeric_limits<std::uint32_t>::max();
  PointPlacement placement_;
  std::size_t width_;
  Pslg pslg_;
  // Each pixel's point, by pixel index: polyline points are neighbouring pixels, so a flat image of
  // ids is read in runs where a hash table was read at random.
  std::vector<std::uint32_t> pixel_index_;
  FlatSet segment_keys_; // (lower << 32 | higher) point ids of the segments made

  std::vector<std::uint32_t> degree_;
};

// Samples every quarter pixel along a segment and flags the pixels they fall in, in `hit`: the image
// with a margin of kHitMargin pixels on each side, rows of `stride`. Widened by widen_hits, the
// flags are the pixels the segment passes through or next to (a pixel left unmarked has its centre at
// least half a pixel from the segment). Sampling every quarter pixel can miss a pixel whose corner the
// segment just clips, but that pixel neighbours two sampled ones and is marked by the widening.
constexpr int kHitMargin = 2;

void sample_segment(std::vector<std::uint8_t>& hit, std::size_t stride, int width, int height,
                    const cdt::Point& a, const cdt::Point& b) {
  const double length = std::hypot(b.x - a.x, b.y - a.y);
  const int steps = std::max(1, static_cast<int>(std::ceil(length / 0.25)));
  // Every sample is flagged, without asking whether it repeats the last one's pixel (most do, but
  // irregularly: a mispredicted branch costs more than the store). A sample that rounding put beyond
  // the image stays in the margin, which the widening leaves out (as its 3x3 neighbourhood misses
  // the image).
  for (int i = 0; i <= steps; ++i) {
    const double t = static_cast<double>(i) / steps;
    const int px =
        std::clamp(static_cast<int>(std::floor(a.x + t * (b.x - a.x))), -kHitMargin, width + kHitMargin - 1);
    const int py =
        std::clamp(static_cast<int>(std::floor(a.y + t * (b.y - a.y))), -kHitMargin, height + kHitMargin - 1);
    hit[static_cast<std::size_t>(py + kHitMargin) * stride + static_cast<std::size_t>(px + kHitMargin)] = 1;
  }
}

// Sets `near` (width x height) for every pixel whose 3x3 neighbourhood holds a pixel flagged in `hit`
// (sample_segment's layout): a row at a time, the OR of three rows of `hit`, then of three columns of
// that.
void widen_hits(const std::vector<std::uint8_t>& hit, std::size_t stride, std::vector<std::uint8_t>& near,
                int width, int height) {
  std::vector<std::uint8_t> down(stride);
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* here = hit.data() + static_cast<std::size_t>(y + kHitMargin) * stride;
    const std::uint8_t* above = here - stride;
    const std::uint8_t* below = here + stride;
    for (std::size_t x = 0; x < stride; ++x) down[x] = above[x] | here[x] | below[x];
    const std::uint8_t* in = down.data() + kHitMargin;
    std::uint8_t* out = near.data() + static_cast<std::size_t>(y) * width;
    for (int x = 0; x < width; ++x) out[x] = in[x - 1] | in[x] | in[x + 1];
  }
}

void add_interior_points(Builder& builder, const Image& image, const InteriorOptions& options,
                         std::size_t num_constrained_segments, bool any_no_shape) {
  const int w = image.width;
  const int h = image.height;
  std::vector<std::uint8_t> unusable(static_cast<std::size_t>(w) * h, 0);
  {
    const std::size_t stride = static_cast<std::size_t>(w) + 2 * kHitMargin;
    std::vector<std::uint8_t> hit(stride * (static_cast<std::size_t>(h) + 2 * kHitMargin), 0);
    const Pslg& pslg = builder.pslg();
    for (std::size_t s = 0; s < num_constrained_segments; ++s)
      sample_segment(hit, stride, w, h, pslg.points[pslg.segments[s].a], pslg.points[pslg.segments[s].b]);
    widen_hits(hit, stride, unusable, w, h);
  }
  if (any_no_shape) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (image.pixel(x, y)[3] < 0.5f) unusable[static_cast<std::size_t>(y) * w + x] = 1;
  }

  const int cell = options.cell_size_px;
  // Too few usable pixels say nothing about shading (the cell is mostly edges or transparency).
  const int min_count = std::max(4, cell * cell / 4);
  // A cell's point is the usable pixel whose centre is nearest the cell's centre, the first in scan
  // order among equally near ones. The distances are exact (multiples of a quarter), so a cell's pixels
  // can be put in that order, as (dx, dy) from its corner, once per cell size: the first usable one is
  // the point.
  const auto nearest_first = [](int cell_w, int cell_h) {
    std::vector<std::pair<int, int>> order;
    for (int dy = 0; dy < cell_h; ++dy)
      for (int dx = 0; dx < cell_w; ++dx) order.emplace_back(dx, dy);
    const auto squared_distance = [&](const std::pair<int, int>& p) {
      const double ex = p.first + kCentre - 0.5 * cell_w;
      const double ey = p.second + kCentre - 0.5 * cell_h;
      return ex * ex + ey * ey;
    };
    std::stable_sort(order.begin(), order.end(),
                     [&](const auto& p, const auto& q) { return squared_distance(p) < squared_distance(q); });
    return order;
  };
  const std::vector<std::pair<int, int>> whole_cell = nearest_first(cell, cell);

  for (int y0 = 0; y0 < h; y0 += cell)
    for (int x0 = 0; x0 < w; x0 += cell) {
      const int x1 = std::min(w, x0 + cell);
      const int y1 = std::min(h, y0 + cell);
      std::array<double, 3> sum{};
      std::array<double, 3> sum_sq{};
      int count = 0;
      for (int y = y0; y < y1; ++y) {
        const std::uint8_t* skip = unusable.data() + static_cast<std::size_t>(y) * w;
        for (int x = x0; x < x1; ++x) {
          if (skip[x]) continue;
          const float* p = image.pixel(x, y);
          for (int c = 0; c < 3; ++c) {
            sum[c] += p[c];
            sum_sq[c] += static_cast<double>(p[c]) * p[c];
          }
          ++count;
        }
      }
      if (count < min_count) continue;
      double variance = 0.0;
      for (int c = 0; c < 3; ++c) {
        const double mean = sum[c] / count;
        variance += std::max(0.0, sum_sq[c] / count - mean * mean);
      }
      const double std_dev = std::sqrt(variance / 3.0);
      if (!(options.min_std_dev == 0.0 || std_dev > options.min_std_dev)) continue;
      // Cells cut by the image's right or bottom side have orders of their own.
      const bool whole = x1 - x0 == cell && y1 - y0 == cell;
      const std::vector<std::pair<int, int>> cut =
          whole ? std::vector<std::pair<int, int>>{} : nearest_first(x1 - x0, y1 - y0);
      for (const auto& [dx, dy] : whole ? whole_cell : cut) {
        if (unusable[static_cast<std::size_t>(y0 + dy) * w + (x0 + dx)]) continue;
        builder.free_point(x0 + dx + kCentre, y0 + dy + kCentre); // count >= 4: one is usable
        break;
      }
    }
}

} // namespace

Pslg build_pslg(const std::vector<Polyline>& simplified, int width, int height, const Image& image,
                const InteriorOptions& options) {
  return build_pslg(simplified, width, height, image, options, PointPlacement{image});
}

Pslg build_pslg(const std::vector<Polyline>& simplified, int width, int height, const Image& image,
                const InteriorOptions& options, const PointPlacement& placement) {
  if (width < 1 || height < 1) throw std::invalid_argument("build_pslg: width and height must be >= 1");
  const bool have_image = !image.rgba.empty();
  if (have_image && (image.width != width || image.height != height ||
                     image.rgba.size() != static_cast<std::size_t>(width) * height * 4))
    throw std::invalid_argument("build_pslg: image must be empty or width x height");
  if (options.cell_size_px < 0 || !(options.min_std_dev >= 0.0))
    throw std::invalid_argument("build_pslg: cell_size_px and min_std_dev must be >= 0");
  for (const Polyline& line : simplified)
    for (const PixelPoint& p : line.points)
      if (p.x < 0 || p.y < 0 || p.x >= width || p.y >= height)
        throw std::invalid_argument("build_pslg: polyline point outside the image");

  if (placement.image() != (have_image ? &image : nullptr))
    throw std::invalid_argument("build_pslg: the point placement was made for another image");
  std::size_t polyline_points = 0;
  for (const Polyline& line : simplified) polyline_points += line.points.size();
  Builder builder(placement, width, height, polyline_points);
  std::vector<std::uint32_t> ids; // one line's point ids, reused from line to line
  for (const Polyline& line : simplified) {
    const std::size_t n = line.points.size();
    ids.resize(n);
    for (std::size_t i = 0; i < n; ++i) ids[i] = builder.pixel_point(line.points[i]);
    for (std::size_t i = 0; i + 1 < n; ++i) builder.segment(ids[i], ids[i + 1]);
    if (line.closed && n >= 3) builder.segment(ids[n - 1], ids[0]);
  }

  // Border points as (side, position along the side); sides 0 top, 1 right, 2 bottom, 3 left.
  const double w = width;
  const double h = height;
  std::array<std::vector<std::pair<double, std::uint32_t>>, 4> sides;
  const std::array<std::uint32_t, 4> corners = {builder.free_point(0.0, 0.0), builder.free_point(w, 0.0),
                                                builder.free_point(w, h), builder.free_point(0.0, h)};
  for (int s = 0; s < 4; ++s) {
    const double along = (s == 0 || s == 2) ? w : h;
    sides[s].push_back({0.0, corners[s]});
    sides[s].push_back({along, corners[(s + 1) % 4]});
  }
  // A dangling end in the outermost pixel ring would leave a half-pixel gap to the border through which
  // the regions on its two sides would connect; a segment straight out to the border closes it.
  std::unordered_set<std::uint32_t> extended;
  for (const Polyline& line : simplified) {
    if (line.closed || line.points.empty()) continue;
    for (const PixelPoint& p : {line.points.front(), line.points.back()}) {
      const std::uint32_t id = builder.pixel_point(p);
      if (builder.degree(id) > 1 || !extended.insert(id).second) continue;
      const double cx = builder.pslg().points[id].x;
      const double cy = builder.pslg().points[id].y;
      std::uint32_t border = 0;
      if (p.x == 0) {
        border = builder.free_point(0.0, cy);
        sides[3].push_back({h - cy, border});
      } else if (p.x == width - 1) {
        border = builder.free_point(w, cy);
        sides[1].push_back({cy, border});
      } else if (p.y == 0) {
        border = builder.free_point(cx, 0.0);
        sides[0].push_back({cx, border});
      } else if (p.y == height - 1) {
        border = builder.free_point(cx, h);
        sides[2].push_back({w - cx, border});
      } else {
        continue;
      }
      builder.segment(id, border);
    }
  }
  builder.drop_pixel_index();
  const std::size_t num_constrained = builder.pslg().segments.size();
  for (auto& side : sides) {
    std::sort(side.begin(), side.end());
    for (std::size_t i = 0; i + 1 < side.size(); ++i) builder.segment(side[i].second, side[i + 1].second);
  }

  if (have_image && options.cell_size_px > 0)
    add_interior_points(builder, image, options, num_constrained, placement.any_no_shape());
  return std::move(builder.pslg());
}

} // namespace vectorize
