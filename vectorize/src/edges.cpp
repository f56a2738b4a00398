// Stage 2: edge pixels. Canny (J. Canny, "A Computational Approach to Edge Detection", PAMI 1986) on
// the gradient of the colour channel that changes most at each pixel, as cv::Canny does for colour
// input; the thresholds come from the distribution of gradient magnitudes unless given.
#include "vectorize/edges.hpp"

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

#include "edges_row.hpp"
#include "parallel.hpp"

#if defined(__SSE4_1__)
#include <smmintrin.h>
#endif

namespace vectorize {

namespace detail {

void strongest_channel_row(const float* gx, const float* gy, const std::uint8_t* shape, int width,
                           short* out_x, short* out_y, std::vector<float>& squared) {
  int x = 0;
#if defined(__SSE4_1__)
  // Four pixels at a time: the same products, sums, comparisons and rounding in lanes.
  const auto channels = [](const float* p, __m128& c0, __m128& c1, __m128& c2) {
    const __m128 a = _mm_loadu_ps(p);     // r0 g0 b0 r1
    const __m128 b = _mm_loadu_ps(p + 4); // g1 b1 r2 g2
    const __m128 c = _mm_loadu_ps(p + 8); // b2 r3 g3 b3
    // Each channel's four values gathered as lanes 0 and 2 of two vectors, then joined.
    const auto join = [](__m128 low, __m128 high) {
      return _mm_shuffle_ps(low, high, _MM_SHUFFLE(2, 0, 2, 0));
    };
    c0 = join(_mm_shuffle_ps(a, a, _MM_SHUFFLE(0, 3, 0, 0)), _mm_shuffle_ps(b, c, _MM_SHUFFLE(0, 1, 0, 2)));
    c1 = join(_mm_shuffle_ps(a, b, _MM_SHUFFLE(0, 0, 0, 1)), _mm_shuffle_ps(b, c, _MM_SHUFFLE(0, 2, 0, 3)));
    c2 = join(_mm_shuffle_ps(a, b, _MM_SHUFFLE(0, 1, 0, 2)), _mm_shuffle_ps(c, c, _MM_SHUFFLE(0, 3, 0, 0)));
  };
  float lengths[4];
  for (; x + 4 <= width; x += 4) {
    __m128 x0, x1, x2, y0, y1, y2;
    channels(gx + 3 * x, x0, x1, x2);
    channels(gy + 3 * x, y0, y1, y2);
    __m128 best = _mm_set1_ps(-1.0f);
    __m128 best_x = x0;
    __m128 best_y = y0;
    for (const auto& [cx, cy] : {std::pair{x0, y0}, std::pair{x1, y1}, std::pair{x2, y2}}) {
      const __m128 sq = _mm_add_ps(_mm_mul_ps(cx, cx), _mm_mul_ps(cy, cy));
      const __m128 longer = _mm_cmpgt_ps(sq, best);
      best = _mm_blendv_ps(best, sq, longer);
      best_x = _mm_blendv_ps(best_x, cx, longer);
      best_y = _mm_blendv_ps(best_y, cy, longer);
    }
    const __m128i rounded_x = _mm_cvtps_epi32(best_x); // out of range: INT_MIN, as cvRound gives
    const __m128i rounded_y = _mm_cvtps_epi32(best_y);
    _mm_storel_epi64(reinterpret_cast<__m128i*>(out_x + x), _mm_packs_epi32(rounded_x, rounded_x));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(out_y + x), _mm_packs_epi32(rounded_y, rounded_y));
    _mm_storeu_ps(lengths, best);
    for (int k = 0; k < 4; ++k)
      if (shape[x + k]) squared.push_back(lengths[k]);
  }
#endif
  for (; x < width; ++x) {
    int best = 0;
    float best_sq = -1.0f;
    for (int c = 0; c < 3; ++c) {
      const float sq = gx[3 * x + c] * gx[3 * x + c] + gy[3 * x + c] * gy[3 * x + c];
      if (sq > best_sq) {
        best_sq = sq;
        best = c;
      }
    }
    out_x[x] = cv::saturate_cast<short>(gx[3 * x + best]);
    out_y[x] = cv::saturate_cast<short>(gy[3 * x + best]);
    if (shape[x]) squared.push_back(best_sq);
  }
}

} // namespace detail

namespace {

// Colour values are scaled so that a 3x3 Sobel of a full-range step (4 * kScale) still fits the
// 16-bit derivatives cv::Canny takes, while 16-bit inputs keep 16 times the precision of 8-bit ones.
constexpr float kScale = 255.0f * 16.0f;
// User thresholds are in 8-bit Sobel units.
constexpr double kThresholdScale = kScale / 255.0;
constexpr double kAutoLowRatio = 0.4;

// Row y of the image's RGB, scaled by kScale, into a CV_32FC3 row.
void scaled_row(const Image& image, int y, cv::Vec3f* row) {
  for (int x = 0; x < image.width; ++x) {
    const float* p = image.pixel(x, y);
    row[x] = cv::Vec3f(p[0] * kScale, p[1] * kScale, p[2] * kScale);
  }
}

// For an image with no-shape pixels: its RGB as CV_32FC3 scaled by kScale, with every no-shape pixel
// taking the colour of the nearest shape pixel: a constant fill would put a colour step right at the
// shape's outline (a second edge a pixel off the alpha edge), and leaving the stored colour would make
// edges inside the transparent area.
cv::Mat shape_colours(const Image& image, const cv::Mat& shape_mask) {
  cv::Mat colour(image.height, image.width, CV_32FC3);
  for (int y = 0; y < image.height; ++y) scaled_row(image, y, colour.ptr<cv::Vec3f>(y));
  const int num_pixels = image.width * image.height;

  // distanceTransform measures to the nearest zero pixel, so shape pixels are the zeros; with
  // DIST_LABEL_PIXEL each zero pixel has its own label, read back at the zero pixels themselves.
  cv::Mat not_shape;
  cv::compare(shape_mask, 0, not_shape, cv::CMP_EQ);
  cv::Mat distance;
  cv::Mat labels;
  cv::distanceTransform(not_shape, distance, labels, cv::DIST_L2, cv::DIST_MASK_5, cv::DIST_LABEL_PIXEL);
  std::vector<cv::Point> label_pixel(static_cast<std::size_t>(num_pixels) + 1, cv::Point(-1, -1));
  for (int y = 0; y < image.height; ++y) {
    const auto* lab = labels.ptr<int>(y);
    const auto* shape = shape_mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < image.width; ++x)
      if (shape[x] && lab[x] >= 0 && lab[x] <= num_pixels)
        label_pixel[static_cast<std::size_t>(lab[x])] = {x, y};
  }
  for (int y = 0; y < image.height; ++y) {
    const auto* lab = labels.ptr<int>(y);
    const auto* shape = shape_mask.ptr<std::uint8_t>(y);
    auto* row = colour.ptr<cv::Vec3f>(y);
    for (int x = 0; x < image.width; ++x) {
      if (shape[x] || lab[x] < 0 || lab[x] > num_pixels) continue;
      const cv::Point src = label_pixel[static_cast<std::size_t>(lab[x])];
      if (src.x >= 0) row[x] = colour.at<cv::Vec3f>(src.y, src.x);
    }
  }
  return colour;
}

// The gradient of the colour channel that changes most, rows [r0, r1) of it, into dx and dy
// (CV_16S), and the squared magnitudes at shape pixels appended to `squared`. The colour comes from
// `colour` when given (whole image), else straight from the image. Blur and Sobel run on a band of
// rows that reaches as far beyond [r0, r1) as their kernels do, as regions of interest inside it:
// OpenCV filters read the band's rows around a region and extrapolate only past the band's own
// ends, which are the image's ends or far enough out. So every row comes out as it would from the
// whole image, with a few kilobytes of buffers instead of four float copies of the image.
struct GradientBand {
  const Image& image;
  const cv::Mat& colour; // empty: read the image
  const cv::Mat& shape_mask;
  double sigma;
  int blur_radius;
  cv::Mat& dx;
  cv::Mat& dy;

  void operator()(int r0, int r1, std::vector<float>& squared, cv::Mat& band, cv::Mat& blurred, cv::Mat& dx3,
                  cv::Mat& dy3) const {
    const int h = image.height;
    const int b0 = std::max(0, r0 - 1); // rows the Sobel filters read
    const int b1 = std::min(h, r1 + 1);
    const int c0 = sigma > 0.0 ? std::max(0, b0 - blur_radius) : b0; // rows the blur reads
    const int c1 = sigma > 0.0 ? std::min(h, b1 + blur_radius) : b1;
    cv::Mat source;
    if (!colour.empty()) {
      source = colour.rowRange(c0, c1);
    } else {
      band.create(c1 - c0, image.width, CV_32FC3);
      for (int y = c0; y < c1; ++y) scaled_row(image, y, band.ptr<cv::Vec3f>(y - c0));
      source = band;
    }
    cv::Mat smooth; // rows [b0, b1)
    if (sigma > 0.0) {
      blurred.create(b1 - b0, image.width, CV_32FC3);
      cv::GaussianBlur(source.rowRange(b0 - c0, b1 - c0), blurred, cv::Size(0, 0), sigma, sigma,
                       cv::BORDER_REPLICATE);
      smooth = blurred;
    } else {
      smooth = source;
    }
    // Replicated borders: the image edge itself is not an edge (the PSLG has the border as segments).
    const cv::Mat rows = smooth.rowRange(r0 - b0, r1 - b0);
    cv::Sobel(rows, dx3, CV_32F, 1, 0, 3, 1.0, 0.0, cv::BORDER_REPLICATE);
    cv::Sobel(rows, dy3, CV_32F, 0, 1, 3, 1.0, 0.0, cv::BORDER_REPLICATE);
    for (int y = r0; y < r1; ++y) {
      detail::strongest_channel_row(dx3.ptr<float>(y - r0), dy3.ptr<float>(y - r0),
                                    shape_mask.ptr<std::uint8_t>(y), image.width, dx.ptr<short>(y),
                                    dy.ptr<short>(y), squared);
    }
  }
};

// The q-quantile of the values (q in (0, 1)), all finite and >= 0: the k-th smallest for
// k = floor(q * (n - 1)); 0 for no values. A non-negative float's bits order as the number does, so a
// histogram of their top 16 bits finds the bucket of the k-th value in one pass, and a selection among
// that bucket's values (a small share of an image's) finds the value itself.
double quantile(const std::vector<float>& values, double q) {
  if (values.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(q * static_cast<double>(values.size() - 1));
  const auto bucket = [](float v) { return std::bit_cast<std::uint32_t>(v) >> 16; };
  std::vector<std::size_t> count(std::size_t{1} << 16, 0);
  for (const float v : values) ++count[bucket(v)];
  std::uint32_t target = 0;
  std::size_t before = 0;
  while (before + count[target] <= k) before += count[target++];
  std::vector<float> in_bucket;
  in_bucket.reserve(count[target]);
  for (const float v : values)
    if (bucket(v) == target) in_bucket.push_back(v);
  const auto nth = in_bucket.begin() + static_cast<std::ptrdiff_t>(k - before);
  std::nth_element(in_bucket.begin(), nth, in_bucket.end());
  return *nth;
}

} // namespace

EdgeMap detect_edges(const Image& image, const EdgeOptions& options, unsigned threads) {
  if (image.width < 0 || image.height < 0 ||
      image.rgba.size() != static_cast<std::size_t>(image.width) * image.height * 4)
    throw std::invalid_argument("detect_edges: image.rgba must hold width * height * 4 values");
  if (!(options.low >= 0.0) || !(options.high >= 0.0) || !(options.blur_sigma_px >= 0.0) ||
      !(options.non_edge_fraction > 0.0 && options.non_edge_fraction < 1.0) ||
      !(options.min_auto_high >= 0.0))
    throw std::invalid_argument(
        "detect_edges: thresholds and sigma must be >= 0, non_edge_fraction in (0, 1)");

  EdgeMap map;
  map.width = image.width;
  map.height = image.height;
  map.on.assign(static_cast<std::size_t>(image.width) * image.height, 0);
  if (image.width == 0 || image.height == 0) return map;

  cv::Mat shape_mask(image.height, image.width, CV_8UC1);
  int num_shape = 0;
  for (int y = 0; y < image.height; ++y) {
    const float* rgba = image.pixel(0, y);
    auto* shape = shape_mask.ptr<std::uint8_t>(y);
    int row_shape = 0;
    for (int x = 0; x < image.width; ++x) {
      const int s = rgba[4 * x + 3] >= 0.5f ? 1 : 0; // alpha >= 1/2: shape
      shape[x] = static_cast<std::uint8_t>(s);
      row_shape += s;
    }
    num_shape += row_shape;
  }
  if (num_shape == 0) return map;

  const cv::Mat colour =
      num_shape < image.width * image.height ? shape_colours(image, shape_mask) : cv::Mat();
  // OpenCV's Gaussian kernel for a float image has round(8 sigma + 1), made odd, taps: it reaches no
  // further than ceil(4 sigma) + 1 rows.
  const int blur_radius =
      options.blur_sigma_px > 0.0 ? static_cast<int>(std::ceil(4.0 * options.blur_sigma_px)) + 1 : 0;
  cv::Mat dx(image.height, image.width, CV_16SC1);
  cv::Mat dy(image.height, image.width, CV_16SC1);
  const GradientBand gradient{image, colour, shape_mask, options.blur_sigma_px, blur_radius, dx, dy};
  // Bands of kBandRows rows, shared out in contiguous runs over the threads; the squared magnitudes
  // are only used through a quantile, which does not depend on their order.
  constexpr int kBandRows = 32;
  const int num_bands = (image.height + kBandRows - 1) / kBandRows;
  const unsigned workers =
      std::min(resolve_threads(threads), static_cast<unsigned>(std::max(1, num_bands / 4)));
  std::vector<std::vector<float>> squared_magnitudes(workers);
  for_each_part(static_cast<std::size_t>(num_bands), workers,
                [&](std::size_t first, std::size_t last, unsigned k) {
                  cv::Mat band, blurred, dx3, dy3;
                  std::vector<float>& mine = squared_magnitudes[k];
                  mine.reserve(static_cast<std::size_t>(num_shape) / workers + image.width);
                  for (std::size_t band_index = first; band_index < last; ++band_index) {
                    const int r0 = static_cast<int>(band_index) * kBandRows;
                    gradient(r0, std::min(image.height, r0 + kBandRows), mine, band, blurred, dx3, dy3);
                  }
                });
  std::vector<float>& all_squared = squared_magnitudes[0];
  for (std::size_t k = 1; k < squared_magnitudes.size(); ++k)
    all_squared.insert(all_squared.end(), squared_magnitudes[k].begin(), squared_magnitudes[k].end());

  double high = options.high * kThresholdScale;
  double low = options.low * kThresholdScale;
  if (high == 0.0 && low == 0.0) {
    // The square root is monotonic, so the quantile of the magnitudes is the root of their squares'.
    const auto square = static_cast<float>(quantile(all_squared, options.non_edge_fraction));
    high = std::max(static_cast<double>(std::sqrt(square)), options.min_auto_high * kThresholdScale);
    low = kAutoLowRatio * high;
  } else if (high == 0.0) {
    high = low / kAutoLowRatio;
  } else if (low == 0.0) {
    low = kAutoLowRatio * high;
  }
  if (low > high) std::swap(low, high);

  cv::Mat edges;
  cv::Canny(dx, dy, edges, low, high, /*L2gradient=*/true);

  // Without a no-shape pixel there is no outline, and the edges are Canny's.
  const bool has_outline = num_shape < image.width * image.height;
  for (int y = 0; y < image.height; ++y) {
    const auto* e = edges.ptr<std::uint8_t>(y);
    const auto* shape = shape_mask.ptr<std::uint8_t>(y);
    std::uint8_t* on = map.on.data() + static_cast<std::size_t>(y) * image.width;
    if (!has_outline) {
      for (int x = 0; x < image.width; ++x) on[x] = e[x] != 0 ? 1 : 0;
      continue;
    }
    for (int x = 0; x < image.width; ++x) {
      if (!shape[x]) continue;
      // The inside of the shape's outline; the image border is not an outline.
      const bool outline = (x > 0 && !shape[x - 1]) || (x + 1 < image.width && !shape[x + 1]) ||
                           (y > 0 && !shape_mask.at<std::uint8_t>(y - 1, x)) ||
                           (y + 1 < image.height && !shape_mask.at<std::uint8_t>(y + 1, x));
      if (outline || e[x]) on[x] = 1;
    }
  }
  return map;
}

void set_opencv_threads(unsigned threads) {
  // No more than the machine runs at once: OpenCV's TBB back end refuses (and prints a warning for)
  // more workers than that.
  const unsigned cores = std::thread::hardware_concurrency();
  if (cores > 0) threads = std::min(threads, cores);
  // OpenCV reads 0 as "no threads: run on the caller's thread".
  cv::setNumThreads(threads <= 1 ? 0 : static_cast<int>(threads));
}

} // namespace vectorize
