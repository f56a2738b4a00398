// Stage 2: edge pixels. Canny (J. Canny, "A Computational Approach to Edge Detection", PAMI 1986) on
// the gradient of the colour channel that changes most at each pixel; the thresholds come from the
// distribution of gradient magnitudes unless given. The steps themselves are in edge_steps.hpp, shared
// with the device, so that an image's edges are the same wherever they are made.
#include "vectorize/edges.hpp"

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <thread>
#include <vector>

#include "cdt/errors.hpp"
#include "edge_steps.hpp"
#include "parallel.hpp"

#if TRIXEL_HAVE_CUDA
#include "edge_kernels.hpp"
#endif

namespace vectorize {

namespace {

using detail::kEdgeScale;

// Row y of the image's RGB, scaled by kEdgeScale, into a CV_32FC3 row.
void scaled_row(const Image& image, int y, cv::Vec3f* row) {
  for (int x = 0; x < image.width; ++x) {
    const float* p = image.pixel(x, y);
    row[x] = cv::Vec3f(p[0] * kEdgeScale, p[1] * kEdgeScale, p[2] * kEdgeScale);
  }
}

// For an image with no-shape pixels: its RGB as CV_32FC3 scaled by kEdgeScale, with every no-shape pixel
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

// The edge classes of an opaque image on the device (EdgeDevice::gpu), after the hysteresis.
void gpu_edge_classes(const Image& image, const detail::BlurTaps& taps, const detail::ThresholdRule& rule,
                      std::uint8_t* classes, DevicePixels* keep) {
#if TRIXEL_HAVE_CUDA
  std::unique_ptr<gpu::DeviceImage> kept;
  gpu::edge_classes(image.rgba.data(), image.width, image.height, taps, rule, classes,
                    keep != nullptr ? &kept : nullptr);
  if (keep != nullptr) *keep = std::move(kept);
#else
  (void)image, (void)taps, (void)rule, (void)classes, (void)keep;
  throw cdt::DeviceError("edges on the device: this build has no CUDA support");
#endif
}

// The suppression's classes on the CPU: the gradient in bands of kBandRows rows (each band computes
// again the rows its filters read beyond it, so the result does not depend on the bands), shared out
// in contiguous runs over the threads; the thresholds; the suppression in the same bands.
void cpu_edge_classes(const Image& image, const cv::Mat& shape_mask, bool opaque,
                      const detail::BlurTaps& taps, const detail::ThresholdRule& rule, unsigned threads,
                      std::uint8_t* classes) {
  const int width = image.width;
  const int height = image.height;
  const std::size_t n = static_cast<std::size_t>(width) * height;
  // With no-shape pixels, the colour comes from the copy whose no-shape pixels took their nearest
  // shape pixel's colour, else straight from the image.
  const cv::Mat colour = opaque ? cv::Mat() : shape_colours(image, shape_mask);
  const auto source = [&](int y, float* const* planes) {
    if (opaque) {
      const float* p = image.pixel(0, y);
      for (int x = 0; x < width; ++x)
        for (int c = 0; c < 3; ++c) planes[c][x] = p[4 * x + c] * kEdgeScale;
    } else {
      const auto* row = colour.ptr<cv::Vec3f>(y);
      for (int x = 0; x < width; ++x)
        for (int c = 0; c < 3; ++c) planes[c][x] = row[x][c];
    }
  };
  constexpr int kBandRows = 64;
  const int num_bands = (height + kBandRows - 1) / kBandRows;
  const unsigned workers =
      std::min(resolve_threads(threads), static_cast<unsigned>(std::max(1, num_bands / 2)));
  // Every entry is written before it is read: no zero fill.
  const auto dx = std::make_unique_for_overwrite<std::int16_t[]>(n);
  const auto dy = std::make_unique_for_overwrite<std::int16_t[]>(n);
  const auto magnitude = std::make_unique_for_overwrite<std::uint32_t[]>(n);
  for_each_part(static_cast<std::size_t>(num_bands), workers,
                [&](std::size_t first, std::size_t last, unsigned) {
                  detail::GradientScratch scratch;
                  for (std::size_t band = first; band < last; ++band) {
                    const int r0 = static_cast<int>(band) * kBandRows;
                    detail::gradient_rows(source, width, height, taps, r0, std::min(height, r0 + kBandRows),
                                          dx.get(), dy.get(), magnitude.get(), scratch);
                  }
                });
  // The thresholds come from the magnitudes of shape pixels only.
  std::vector<std::uint32_t> shape_magnitudes;
  if (!opaque) {
    for (int y = 0; y < height; ++y) {
      const auto* shape = shape_mask.ptr<std::uint8_t>(y);
      for (int x = 0; x < width; ++x)
        if (shape[x]) shape_magnitudes.push_back(magnitude[static_cast<std::size_t>(y) * width + x]);
    }
  }
  const detail::SquaredThresholds thresholds =
      opaque ? detail::edge_thresholds(rule, magnitude.get(), n)
             : detail::edge_thresholds(rule, shape_magnitudes.data(), shape_magnitudes.size());
  for_each_part(static_cast<std::size_t>(num_bands), workers,
                [&](std::size_t first, std::size_t last, unsigned) {
                  const int r0 = static_cast<int>(first) * kBandRows;
                  const int r1 = std::min(height, static_cast<int>(last) * kBandRows);
                  detail::suppress_rows(dx.get(), dy.get(), magnitude.get(), width, height, thresholds, r0,
                                        r1, classes);
                });
}

} // namespace

EdgeMap detect_edges(const Image& image, const EdgeOptions& options, unsigned threads, EdgeDevice device,
                     DevicePixels* keep) {
  if (keep != nullptr) keep->reset();
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

  // The shape's pixels (alpha >= 1/2), unless the reader knows every alpha is 1.
  cv::Mat shape_mask;
  int num_shape = image.width * image.height;
  if (!image.known_opaque) {
    shape_mask.create(image.height, image.width, CV_8UC1);
    num_shape = 0;
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
  }
  if (num_shape == 0) return map;

  const bool opaque = num_shape == image.width * image.height;
  const detail::BlurTaps taps = detail::blur_taps(options.blur_sigma_px);
  const detail::ThresholdRule rule{options.low, options.high, options.non_edge_fraction,
                                   options.min_auto_high};
  const auto classes = std::make_unique_for_overwrite<std::uint8_t[]>(map.on.size());
  // The device takes opaque images; the others need the nearest-shape-pixel colours (OpenCV's distance
  // transform) and stay on the CPU. The classes are the same either way; the device's come after the
  // hysteresis.
  if (device == EdgeDevice::gpu && opaque) {
    gpu_edge_classes(image, taps, rule, classes.get(), keep);
  } else {
    cpu_edge_classes(image, shape_mask, opaque, taps, rule, threads, classes.get());
    detail::hysteresis(classes.get(), image.width, image.height);
  }

  // Without a no-shape pixel there is no outline, and the edges are Canny's.
  for (int y = 0; y < image.height; ++y) {
    const std::uint8_t* e = classes.get() + static_cast<std::size_t>(y) * image.width;
    const auto* shape = shape_mask.ptr<std::uint8_t>(y);
    std::uint8_t* on = map.on.data() + static_cast<std::size_t>(y) * image.width;
    if (opaque) {
      for (int x = 0; x < image.width; ++x) on[x] = e[x] == detail::kStrong ? 1 : 0;
      continue;
    }
    for (int x = 0; x < image.width; ++x) {
      if (!shape[x]) continue;
      // The inside of the shape's outline; the image border is not an outline.
      const bool outline = (x > 0 && !shape[x - 1]) || (x + 1 < image.width && !shape[x + 1]) ||
                           (y > 0 && !shape_mask.at<std::uint8_t>(y - 1, x)) ||
                           (y + 1 < image.height && !shape_mask.at<std::uint8_t>(y + 1, x));
      if (outline || e[x] == detail::kStrong) on[x] = 1;
    }
  }
  return map;
}

bool prepare_edges_on_device() noexcept {
#if TRIXEL_HAVE_CUDA
  try {
    gpu::prepare_edge_classes();
    return true;
  } catch (...) {
    return false; // a device that fails here fails again, with its error, in detect_edges
  }
#else
  return false;
#endif
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
