// Stage 2: edge pixels. Canny (J. Canny, "A Computational Approach to Edge Detection", PAMI 1986) on
// the gradient of the colour channel that changes most at each pixel, as cv::Canny does for colour
// input; the thresholds come from the distribution of gradient magnitudes unless given.
#include "vectorize/edges.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <vector>

namespace vectorize {
namespace {

// Colour values are scaled so that a 3x3 Sobel of a full-range step (4 * kScale) still fits the
// 16-bit derivatives cv::Canny takes, while 16-bit inputs keep 16 times the precision of 8-bit ones.
constexpr float kScale = 255.0f * 16.0f;
// User thresholds are in 8-bit Sobel units.
constexpr double kThresholdScale = kScale / 255.0;
constexpr double kAutoLowRatio = 0.4;

bool is_shape(const Image& image, int x, int y) { return image.pixel(x, y)[3] >= 0.5f; }

// The image's RGB as CV_32FC3 scaled by kScale, with every no-shape pixel taking the colour of the
// nearest shape pixel: a constant fill would put a colour step right at the shape's outline (a second
// edge a pixel off the alpha edge), and leaving the stored colour would make edges inside the
// transparent area.
cv::Mat shape_colours(const Image& image, const cv::Mat& shape_mask, int num_shape) {
  cv::Mat colour(image.height, image.width, CV_32FC3);
  for (int y = 0; y < image.height; ++y) {
    auto* row = colour.ptr<cv::Vec3f>(y);
    for (int x = 0; x < image.width; ++x) {
      const float* p = image.pixel(x, y);
      row[x] = cv::Vec3f(p[0] * kScale, p[1] * kScale, p[2] * kScale);
    }
  }
  const int num_pixels = image.width * image.height;
  if (num_shape == num_pixels || num_shape == 0) return colour;

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

// The q-quantile of the values (q in (0, 1)); 0 for no values.
double quantile(std::vector<float>& values, double q) {
  if (values.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

} // namespace

EdgeMap detect_edges(const Image& image, const EdgeOptions& options) {
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
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const bool s = is_shape(image, x, y);
      shape_mask.at<std::uint8_t>(y, x) = s ? 1 : 0;
      num_shape += s ? 1 : 0;
    }
  if (num_shape == 0) return map;

  cv::Mat colour = shape_colours(image, shape_mask, num_shape);
  if (options.blur_sigma_px > 0.0)
    cv::GaussianBlur(colour, colour, cv::Size(0, 0), options.blur_sigma_px, options.blur_sigma_px,
                     cv::BORDER_REPLICATE);

  // Replicated borders: the image edge itself is not an edge (the PSLG has the border as segments).
  cv::Mat dx3;
  cv::Mat dy3;
  cv::Sobel(colour, dx3, CV_32F, 1, 0, 3, 1.0, 0.0, cv::BORDER_REPLICATE);
  cv::Sobel(colour, dy3, CV_32F, 0, 1, 3, 1.0, 0.0, cv::BORDER_REPLICATE);

  cv::Mat dx(image.height, image.width, CV_16SC1);
  cv::Mat dy(image.height, image.width, CV_16SC1);
  std::vector<float> magnitudes;
  magnitudes.reserve(static_cast<std::size_t>(num_shape));
  for (int y = 0; y < image.height; ++y) {
    const auto* gx = dx3.ptr<cv::Vec3f>(y);
    const auto* gy = dy3.ptr<cv::Vec3f>(y);
    const auto* shape = shape_mask.ptr<std::uint8_t>(y);
    auto* out_x = dx.ptr<short>(y);
    auto* out_y = dy.ptr<short>(y);
    for (int x = 0; x < image.width; ++x) {
      int best = 0;
      float best_sq = -1.0f;
      for (int c = 0; c < 3; ++c) {
        const float sq = gx[x][c] * gx[x][c] + gy[x][c] * gy[x][c];
        if (sq > best_sq) {
          best_sq = sq;
          best = c;
        }
      }
      out_x[x] = cv::saturate_cast<short>(gx[x][best]);
      out_y[x] = cv::saturate_cast<short>(gy[x][best]);
      if (shape[x]) magnitudes.push_back(std::sqrt(best_sq));
    }
  }

  double high = options.high * kThresholdScale;
  double low = options.low * kThresholdScale;
  if (high == 0.0 && low == 0.0) {
    high = std::max(quantile(magnitudes, options.non_edge_fraction), options.min_auto_high * kThresholdScale);
    low = kAutoLowRatio * high;
  } else if (high == 0.0) {
    high = low / kAutoLowRatio;
  } else if (low == 0.0) {
    low = kAutoLowRatio * high;
  }
  if (low > high) std::swap(low, high);

  cv::Mat edges;
  cv::Canny(dx, dy, edges, low, high, /*L2gradient=*/true);

  for (int y = 0; y < image.height; ++y) {
    const auto* e = edges.ptr<std::uint8_t>(y);
    const auto* shape = shape_mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < image.width; ++x) {
      if (!shape[x]) continue;
      // The inside of the shape's outline; the image border is not an outline.
      const bool outline = (x > 0 && !shape[x - 1]) || (x + 1 < image.width && !shape[x + 1]) ||
                           (y > 0 && !shape_mask.at<std::uint8_t>(y - 1, x)) ||
                           (y + 1 < image.height && !shape_mask.at<std::uint8_t>(y + 1, x));
      if (outline || e[x]) map.on[static_cast<std::size_t>(y) * image.width + x] = 1;
    }
  }
  return map;
}

} // namespace vectorize
