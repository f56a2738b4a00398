#pragma once
// The steps of stage 2 (edge pixels), compiled for the host and, in the CUDA build, for the device
// (kernels/edge_kernels.cu): a separable Gaussian blur, the 3x3 Sobel derivatives of each colour
// channel, the channel whose gradient is longest, Canny's non-maximum suppression and double
// threshold (J. Canny, "A Computational Approach to Edge Detection", PAMI 1986), and the hysteresis.
// Each value is made by the same operations in the same order on both sides (host code is built with
// -ffp-contract=off and device code with --fmad=false, so no multiply-add is fused), so the edge maps
// are equal to the bit, and do not depend on the processor's vector instructions either.
//
// The host runs the blur tap by tap across whole rows, so that the compiler vectorises it; the device
// pixel by pixel. Both start a value with the centre tap and add the taps from the nearest outwards.

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "cdt/detail/host_device.hpp"

// The host's row loops are also built for AVX2 where the compiler can, and the processor picks its
// version at run time: twice the lanes, the same operations in each (AVX2 brings no fused
// multiply-add), so the same values.
#if defined(__GNUC__) && !defined(__clang__) && !defined(__CUDACC__) && defined(__x86_64__)
#define VECTORIZE_ROW_LOOPS __attribute__((target_clones("avx2", "default")))
#else
#define VECTORIZE_ROW_LOOPS
#endif

namespace vectorize::detail {

/// Colour values (0 to 1) are scaled by this before the blur, so that a 3x3 Sobel of a full-range step
/// (4 * kEdgeScale) still fits 16-bit derivatives, while 16-bit inputs keep 16 times the precision of
/// 8-bit ones.
constexpr float kEdgeScale = 255.0f * 16.0f;
/// Thresholds are given in the units of a Sobel filter on 8-bit values.
constexpr double kEdgeThresholdScale = kEdgeScale / 255.0;
/// The widest blur: taps reach at most this many pixels from the centre (sigma up to 50, the most
/// vectorize's --blur takes).
constexpr int kMaxBlurRadius = 200;

/// A Gaussian's taps: weight[0] at the centre, weight[i] at distance i, for i <= radius.
struct BlurTaps {
  int radius = 0; // 0: no blur
  float weight[kMaxBlurRadius + 1] = {};
};

/// The taps of a Gaussian of standard deviation sigma (pixels): round(8 sigma + 1) of them, made odd,
/// as OpenCV takes for float images (at most 2 kMaxBlurRadius + 1), normalised to sum 1 in double
/// and rounded to float. sigma <= 0: no blur.
inline BlurTaps blur_taps(double sigma) {
  BlurTaps taps;
  if (!(sigma > 0.0)) return taps;
  const double size = std::min(8.0 * sigma + 1.0, 2.0 * kMaxBlurRadius + 1.0);
  taps.radius = (static_cast<int>(std::lround(size)) | 1) / 2;
  double weight[kMaxBlurRadius + 1];
  double sum = 0.0;
  for (int i = 0; i <= taps.radius; ++i) {
    weight[i] = std::exp(-0.5 * i * i / (sigma * sigma));
    sum += i == 0 ? weight[i] : 2.0 * weight[i];
  }
  for (int i = 0; i <= taps.radius; ++i) taps.weight[i] = static_cast<float>(weight[i] / sum);
  return taps;
}

/// One tap pair of the blur added to a value: acc + w (lo + hi).
CDT_HD_INLINE float add_taps(float acc, float w, float lo, float hi) { return acc + w * (lo + hi); }

/// The Sobel derivative along x from the 3x3 neighbourhood (u: row above, d: row below, l/r: left and
/// right): the differences of the outer rows, then twice the middle row's.
CDT_HD_INLINE float sobel_x(float ul, float ur, float l, float r, float dl, float dr) {
  return ((ur - ul) + (dr - dl)) + 2.0f * (r - l);
}

/// The Sobel derivative along y: the row below's smoothed value less the row above's.
CDT_HD_INLINE float sobel_y(float ul, float u, float ur, float dl, float d, float dr) {
  return ((dl + dr) + 2.0f * d) - ((ul + ur) + 2.0f * u);
}

/// v rounded to the nearest integer, ties to even, saturated to 16 bits.
CDT_HD_INLINE int round_to_short(float v) {
  const float clamped = v < -32768.0f ? -32768.0f : (v > 32767.0f ? 32767.0f : v);
  return static_cast<int>(rintf(clamped));
}

/// The gradient of a pixel: of its three channels' (gx, gy), the longest (the first of equally long
/// ones), rounded to 16 bits, and its squared length as integers.
struct PixelGradient {
  int dx;
  int dy;
  std::uint32_t magnitude; // dx^2 + dy^2
};

CDT_HD_INLINE PixelGradient strongest_channel(float gx0, float gy0, float gx1, float gy1, float gx2,
                                              float gy2) {
  float best = gx0 * gx0 + gy0 * gy0;
  float bx = gx0;
  float by = gy0;
  const float sq1 = gx1 * gx1 + gy1 * gy1;
  if (sq1 > best) {
    best = sq1;
    bx = gx1;
    by = gy1;
  }
  const float sq2 = gx2 * gx2 + gy2 * gy2;
  if (sq2 > best) {
    bx = gx2;
    by = gy2;
  }
  const int dx = round_to_short(bx);
  const int dy = round_to_short(by);
  return {dx, dy, static_cast<std::uint32_t>(dx * dx) + static_cast<std::uint32_t>(dy * dy)}; // <= 2^31
}

/// Canny's squared thresholds: a pixel is a candidate when its squared magnitude exceeds `low` and
/// strong when it exceeds `high` (so the magnitude itself exceeds the square roots).
struct SquaredThresholds {
  std::uint64_t low = 0;
  std::uint64_t high = 0;
};

/// What the suppression makes of a pixel: not an edge, a candidate (a local maximum along its gradient
/// above the low threshold), or strong (above the high one as well).
enum : std::uint8_t { kNotEdge = 0, kCandidate = 1, kStrong = 2 };

/// The sector of a gradient's direction, with integer arithmetic (tan 22.5 degrees as 13573 / 2^15):
/// within 22.5 degrees of the x axis, of the y axis, or of a diagonal, down-right (dx and dy of the same
/// sign) or down-left.
enum : int { kAlongX = 0, kAlongY = 1, kDownRight = 2, kDownLeft = 3 };
CDT_HD_INLINE int gradient_sector(int dx, int dy) {
  const std::int64_t ax = dx < 0 ? -dx : dx;
  const std::int64_t ay = dy < 0 ? -dy : dy;
  const std::int64_t tan22_x = ax * 13573;
  const std::int64_t y_scaled = ay << 15;
  if (y_scaled < tan22_x) return kAlongX;
  if (y_scaled > tan22_x + (ax << 16)) return kAlongY;
  return (dx < 0) != (dy < 0) ? kDownLeft : kDownRight;
}

/// The class of a pixel of squared magnitude m above the low threshold, given its neighbours' against
/// and along its gradient: it must exceed the one against and at least equal the one along.
CDT_HD_INLINE std::uint8_t local_maximum_class(std::uint32_t m, std::uint32_t against, std::uint32_t along,
                                               SquaredThresholds t) {
  if (!(m > against && m >= along)) return kNotEdge;
  return m > t.high ? kStrong : kCandidate;
}

/// Non-maximum suppression and the double threshold at pixel x of a row: m is its squared magnitude,
/// up / mid / down the squared magnitudes of the rows above, at and below it (nullptr outside the
/// image; outside the image a magnitude is 0).
CDT_HD_INLINE std::uint8_t suppress(int dx, int dy, std::uint32_t m, const std::uint32_t* up,
                                    const std::uint32_t* mid, const std::uint32_t* down, int x, int width,
                                    SquaredThresholds t) {
  if (m <= t.low) return kNotEdge;
  const auto at = [width](const std::uint32_t* row, int i) -> std::uint32_t {
    return row != nullptr && i >= 0 && i < width ? row[i] : 0u;
  };
  switch (gradient_sector(dx, dy)) {
  case kAlongX:
    return local_maximum_class(m, at(mid, x - 1), at(mid, x + 1), t);
  case kAlongY:
    return local_maximum_class(m, at(up, x), at(down, x), t);
  case kDownRight:
    return local_maximum_class(m, at(up, x - 1), at(down, x + 1), t);
  default:
    return local_maximum_class(m, at(up, x + 1), at(down, x - 1), t);
  }
}

/// The thresholds of stage 2 in user units (a Sobel filter on 8-bit values); see vectorize::EdgeOptions.
struct ThresholdRule {
  double low = 0.0;
  double high = 0.0;
  double non_edge_fraction = 0.85;
  double min_auto_high = 40.0;
};

/// The k-th smallest of the values for k = floor(q * (n - 1)), q in (0, 1); 0 for none. The values'
/// floats order as they do, so a histogram of the floats' top 16 bits finds the bucket of the k-th
/// value in one pass, and a selection among that bucket's values (few) finds the value itself.
inline std::uint32_t quantile(const std::uint32_t* values, std::size_t n, double q) {
  if (n == 0) return 0;
  const auto k = static_cast<std::size_t>(q * static_cast<double>(n - 1));
  const auto bucket = [](std::uint32_t v) {
    return std::bit_cast<std::uint32_t>(static_cast<float>(v)) >> 16;
  };
  std::vector<std::size_t> count(bucket(~0u) + 1, 0);
  for (std::size_t i = 0; i < n; ++i) ++count[bucket(values[i])];
  std::uint32_t target = 0;
  std::size_t before = 0;
  while (before + count[target] <= k) before += count[target++];
  std::vector<std::uint32_t> in_bucket;
  in_bucket.reserve(count[target]);
  for (std::size_t i = 0; i < n; ++i)
    if (bucket(values[i]) == target) in_bucket.push_back(values[i]);
  const auto nth = in_bucket.begin() + static_cast<std::ptrdiff_t>(k - before);
  std::nth_element(in_bucket.begin(), nth, in_bucket.end());
  return *nth;
}

/// Whether `rule` takes its thresholds from the magnitudes' quantile.
CDT_HD_INLINE bool automatic_thresholds(const ThresholdRule& rule) {
  return rule.low == 0.0 && rule.high == 0.0;
}

/// The squared thresholds for `rule`, given the non_edge_fraction quantile of the image's squared
/// magnitudes when both of the rule's thresholds are 0 (the automatic rule; otherwise unused): the
/// high one from the quantile (at least min_auto_high) and the low one as 0.4 of it; one of them 0
/// takes it from the other by that ratio. The same operations on the host and the device (an exactly
/// rounded square root, products and floors), so the same thresholds.
CDT_HD_INLINE SquaredThresholds thresholds_from_quantile(const ThresholdRule& rule,
                                                         std::uint32_t squared_quantile) {
  constexpr double kLowRatio = 0.4;
  double high = rule.high * kEdgeThresholdScale;
  double low = rule.low * kEdgeThresholdScale;
  if (automatic_thresholds(rule)) {
    // The square root is monotonic, so the quantile of the magnitudes is the root of their squares'.
    const double q = sqrt(static_cast<double>(squared_quantile));
    const double least = rule.min_auto_high * kEdgeThresholdScale;
    high = q > least ? q : least;
    low = kLowRatio * high;
  } else if (high == 0.0) {
    high = low / kLowRatio;
  } else if (low == 0.0) {
    low = kLowRatio * high;
  }
  if (low > high) {
    const double swapped = low;
    low = high;
    high = swapped;
  }
  // A squared magnitude is an integer, so exceeding x is exceeding floor(x); beyond 2^62 nothing is.
  const auto squared_floor = [](double v) {
    const double s = floor(v * v);
    return s >= 0x1p62 ? std::uint64_t{1} << 62 : static_cast<std::uint64_t>(s);
  };
  return {squared_floor(low), squared_floor(high)};
}

/// The squared thresholds for an image whose squared magnitudes (at its shape pixels) are `squared`
/// (thresholds_from_quantile, with the quantile of the n values when the rule is automatic).
inline SquaredThresholds edge_thresholds(const ThresholdRule& rule, const std::uint32_t* squared,
                                         std::size_t n) {
  return thresholds_from_quantile(
      rule, automatic_thresholds(rule) ? quantile(squared, n, rule.non_edge_fraction) : 0u);
}

/// Hysteresis: every candidate 8-connected through candidates to a strong pixel becomes strong. After
/// it, the edges are the strong pixels.
inline void hysteresis(std::uint8_t* classes, int width, int height) {
  struct Pixel {
    int x;
    int y;
  };
  std::vector<Pixel> stack;
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* row = classes + static_cast<std::size_t>(y) * width;
    // Strong pixels are few: found by memchr, which reads the row a vector at a time.
    for (const void* at = std::memchr(row, kStrong, static_cast<std::size_t>(width)); at != nullptr;) {
      const auto x = static_cast<int>(static_cast<const std::uint8_t*>(at) - row);
      stack.push_back({x, y});
      at = x + 1 < width ? std::memchr(row + x + 1, kStrong, static_cast<std::size_t>(width - x - 1))
                         : nullptr;
    }
  }
  while (!stack.empty()) {
    const Pixel p = stack.back();
    stack.pop_back();
    const int x0 = std::max(0, p.x - 1);
    const int x1 = std::min(width - 1, p.x + 1);
    for (int y = std::max(0, p.y - 1); y <= std::min(height - 1, p.y + 1); ++y) {
      std::uint8_t* row = classes + static_cast<std::size_t>(y) * width;
      for (int x = x0; x <= x1; ++x) {
        if (row[x] != kCandidate) continue;
        row[x] = kStrong;
        stack.push_back({x, y});
      }
    }
  }
}

/// One thread's buffers for gradient_rows.
struct GradientScratch {
  std::vector<float> source;  // 3 planes of one source row, padded by the blur's radius
  std::vector<float> across;  // the rows the blur reads, blurred along x: 3 planes
  std::vector<float> blurred; // the rows the Sobel filter reads, blurred: 3 planes, padded by 1
  std::vector<float> gx;      // one row of derivatives: 3 planes
  std::vector<float> gy;
};

/// Rows [r0, r1) of the image's gradient (dx, dy, squared magnitude: width * height entries each,
/// row-major), from `source(y, planes)`, which writes row y of the colour scaled by kEdgeScale into
/// planes[c][0, width) for c = 0, 1, 2. Blur and Sobel filter replicate the border rows and columns.
/// The rows the filters read beyond [r0, r1) are computed again, so rows come out the same however the
/// image is cut into bands.
template <class Source>
VECTORIZE_ROW_LOOPS void gradient_rows(Source&& source, int width, int height, const BlurTaps& taps, int r0,
                                       int r1, std::int16_t* dx, std::int16_t* dy, std::uint32_t* magnitude,
                                       GradientScratch& s) {
  const int radius = taps.radius;
  const auto w = static_cast<std::size_t>(width);
  const int b0 = std::max(0, r0 - 1); // rows the Sobel filter reads
  const int b1 = std::min(height, r1 + 1);
  const int c0 = std::max(0, b0 - radius); // rows the blur reads
  const int c1 = std::min(height, b1 + radius);
  const auto across_rows = static_cast<std::size_t>(c1 - c0);
  const auto blurred_rows = static_cast<std::size_t>(b1 - b0);
  const std::size_t padded = w + 2 * static_cast<std::size_t>(radius);
  s.source.resize(3 * padded);
  s.across.resize(3 * across_rows * w);
  s.blurred.resize(3 * blurred_rows * (w + 2));
  s.gx.resize(3 * w);
  s.gy.resize(3 * w);
  const auto across_row = [&](int c, int y) {
    return s.across.data() +
           (static_cast<std::size_t>(c) * across_rows + static_cast<std::size_t>(y - c0)) * w;
  };
  const auto blurred_row = [&](int c, int y) { // x = 0 of a row padded by one value each side
    return s.blurred.data() +
           (static_cast<std::size_t>(c) * blurred_rows + static_cast<std::size_t>(y - b0)) * (w + 2) + 1;
  };

  for (int y = c0; y < c1; ++y) {
    float* planes[3];
    for (int c = 0; c < 3; ++c) planes[c] = s.source.data() + c * padded + radius;
    source(y, planes);
    for (int c = 0; c < 3; ++c) {
      float* __restrict p = planes[c];
      for (int i = 1; i <= radius; ++i) {
        p[-i] = p[0];
        p[width - 1 + i] = p[width - 1];
      }
      float* __restrict out = across_row(c, y);
      const float w0 = taps.weight[0];
      for (std::size_t x = 0; x < w; ++x) out[x] = radius == 0 ? p[x] : w0 * p[x];
      for (int i = 1; i <= radius; ++i) {
        const float wi = taps.weight[i];
        const float* __restrict lo = p - i;
        const float* __restrict hi = p + i;
        for (std::size_t x = 0; x < w; ++x) out[x] = add_taps(out[x], wi, lo[x], hi[x]);
      }
    }
  }
  for (int c = 0; c < 3; ++c)
    for (int y = b0; y < b1; ++y) {
      float* __restrict out = blurred_row(c, y);
      const float* __restrict centre = across_row(c, y);
      const float w0 = taps.weight[0];
      for (std::size_t x = 0; x < w; ++x) out[x] = radius == 0 ? centre[x] : w0 * centre[x];
      for (int i = 1; i <= radius; ++i) {
        const float wi = taps.weight[i];
        const float* __restrict lo = across_row(c, std::max(0, y - i));
        const float* __restrict hi = across_row(c, std::min(height - 1, y + i));
        for (std::size_t x = 0; x < w; ++x) out[x] = add_taps(out[x], wi, lo[x], hi[x]);
      }
      out[-1] = out[0];
      out[width] = out[width - 1];
    }
  for (int y = r0; y < r1; ++y) {
    for (int c = 0; c < 3; ++c) {
      const float* __restrict u = blurred_row(c, std::max(0, y - 1));
      const float* __restrict m = blurred_row(c, y);
      const float* __restrict d = blurred_row(c, std::min(height - 1, y + 1));
      float* __restrict gx = s.gx.data() + c * w;
      float* __restrict gy = s.gy.data() + c * w;
      for (std::size_t x = 0; x < w; ++x) {
        gx[x] = sobel_x(u[x - 1], u[x + 1], m[x - 1], m[x + 1], d[x - 1], d[x + 1]);
        gy[x] = sobel_y(u[x - 1], u[x], u[x + 1], d[x - 1], d[x], d[x + 1]);
      }
    }
    const float* gx = s.gx.data();
    const float* gy = s.gy.data();
    const std::size_t row = static_cast<std::size_t>(y) * w;
    for (std::size_t x = 0; x < w; ++x) {
      const PixelGradient g =
          strongest_channel(gx[x], gy[x], gx[w + x], gy[w + x], gx[2 * w + x], gy[2 * w + x]);
      dx[row + x] = static_cast<std::int16_t>(g.dx);
      dy[row + x] = static_cast<std::int16_t>(g.dy);
      magnitude[row + x] = g.magnitude;
    }
  }
}

/// Rows [r0, r1) of the suppression's classes (kNotEdge, kCandidate, kStrong) from the whole gradient.
/// Pixels away from the border read their neighbours without suppress()'s bounds checks: the same
/// classes (Edges.SuppressionRowsFollowTheStep).
VECTORIZE_ROW_LOOPS inline void suppress_rows(const std::int16_t* dx, const std::int16_t* dy,
                                              const std::uint32_t* magnitude, int width, int height,
                                              SquaredThresholds t, int r0, int r1, std::uint8_t* classes) {
  const auto w = static_cast<std::ptrdiff_t>(width);
  // A squared magnitude is at most 2^31: thresholds beyond 32 bits are beyond it.
  const auto low = static_cast<std::uint32_t>(std::min<std::uint64_t>(t.low, 0xffffffffu));
  const auto high = static_cast<std::uint32_t>(std::min<std::uint64_t>(t.high, 0xffffffffu));
  for (int y = r0; y < r1; ++y) {
    const std::size_t row = static_cast<std::size_t>(y) * static_cast<std::size_t>(width);
    const std::uint32_t* mid = magnitude + row;
    const std::uint32_t* up = y > 0 ? mid - w : nullptr;
    const std::uint32_t* down = y + 1 < height ? mid + w : nullptr;
    std::uint8_t* out = classes + row;
    if (up == nullptr || down == nullptr || width < 3) {
      for (int x = 0; x < width; ++x)
        out[x] = suppress(dx[row + x], dy[row + x], mid[x], up, mid, down, x, width, t);
      continue;
    }
    out[0] = suppress(dx[row], dy[row], mid[0], up, mid, down, 0, width, t);
    out[width - 1] = suppress(dx[row + width - 1], dy[row + width - 1], mid[width - 1], up, mid, down,
                              width - 1, width, t);
    // Inside, without branches, so that the compiler vectorises it: every neighbour read, the sector's
    // picked (gradient_sector's test in 32 bits, where none of its terms overflows).
    const std::int16_t* gx = dx + row;
    const std::int16_t* gy = dy + row;
    for (int x = 1; x + 1 < width; ++x) {
      const std::uint32_t m = mid[x];
      const int sx = gx[x];
      const int sy = gy[x];
      const auto ax = static_cast<std::uint32_t>(sx < 0 ? -sx : sx);
      const auto ay = static_cast<std::uint32_t>(sy < 0 ? -sy : sy);
      const std::uint32_t tan22_x = ax * 13573u;
      const std::uint32_t y_scaled = ay << 15;
      const bool along_x = y_scaled < tan22_x;
      const bool along_y = y_scaled > tan22_x + (ax << 16);
      const bool down_right = (sx ^ sy) >= 0;
      const std::uint32_t up_left = up[x - 1];
      const std::uint32_t up_middle = up[x];
      const std::uint32_t up_right = up[x + 1];
      const std::uint32_t left = mid[x - 1];
      const std::uint32_t right = mid[x + 1];
      const std::uint32_t down_left = down[x - 1];
      const std::uint32_t down_middle = down[x];
      const std::uint32_t down_right_value = down[x + 1];
      const std::uint32_t diagonal_against = down_right ? up_left : up_right;
      const std::uint32_t diagonal_along = down_right ? down_right_value : down_left;
      const std::uint32_t against = along_x ? left : (along_y ? up_middle : diagonal_against);
      const std::uint32_t along = along_x ? right : (along_y ? down_middle : diagonal_along);
      const unsigned kept = static_cast<unsigned>(m > low) & static_cast<unsigned>(m > against) &
                            static_cast<unsigned>(m >= along);
      out[x] =
          static_cast<std::uint8_t>(kept * (1u + static_cast<unsigned>(m > high))); // kCandidate or kStrong
    }
  }
}

} // namespace vectorize::detail
