#pragma once
// Stage 2 of the pipeline: edge pixels of an image (Canny on a colour-aware gradient).

#include <cstdint>
#include <vector>

#include "vectorize/image.hpp"

namespace vectorize {

/// A binary edge map of width x height pixels, row-major from the top-left.
struct EdgeMap {
  int width = 0;
  int height = 0;
  /// 1 for an edge pixel, 0 otherwise; width * height entries.
  std::vector<std::uint8_t> on;

  /// Whether pixel (x, y) is an edge; 0 <= x < width, 0 <= y < height.
  bool at(int x, int y) const { return on[static_cast<std::size_t>(y) * width + x] != 0; }
};

/// Options of detect_edges(), in human units.
struct EdgeOptions {
  /// Hysteresis thresholds on the gradient magnitude, in the units of a 3x3 Sobel filter on 8-bit
  /// values (a step of k levels between flat areas has magnitude 4k). 0 derives the threshold from the
  /// image (both 0: high from a quantile of the magnitudes, low = 0.4 * high; only high given:
  /// low = 0.4 * high; only low given: high = 2.5 * low).
  double low = 0.0;
  double high = 0.0;
  /// Standard deviation of the Gaussian blur applied before the gradient, in pixels; 0 for none.
  double blur_sigma_px = 1.0;
  /// For automatic thresholds: the fraction of pixels assumed not to be edges (the high threshold is
  /// this quantile of the gradient magnitude), in (0, 1).
  double non_edge_fraction = 0.85;
  /// For automatic thresholds: the high threshold never goes below this (same units as high), so that
  /// a flat or nearly flat image yields no edges from noise.
  double min_auto_high = 40.0;
};

/// Where detect_edges() runs: on the CPU, or on the CUDA device (a build with CUDA; the same edges, the
/// same steps and order of operations).
enum class EdgeDevice { cpu, gpu };

/// Edge pixels of the image: Canny (non-maximum suppression and hysteresis) on the per-pixel gradient
/// of the colour channel with the largest gradient magnitude, after a Gaussian blur (taps reaching
/// about 4 sigma, at most 200 pixels); blur and 3x3 Sobel filter replicate the border. Pixels with
/// alpha < 0.5 are "no shape": they are never edges, their colour is replaced by the nearest shape
/// pixel's so that it neither makes edges in the transparent area nor at its border, and the shape
/// pixels that have a no-shape 4-neighbour (the inside of the shape's outline) are always edges. Grey
/// and 16-bit inputs need nothing special (Image holds floats). An empty image gives an empty map;
/// throws std::invalid_argument when image.rgba does not hold width * height * 4 values or an option
/// is out of range. On the CPU the gradient is computed in bands of rows, on up to `threads` threads
/// (0: every hardware thread). EdgeDevice::gpu makes the edges of an image without no-shape pixels on
/// the device (`threads` unused; other images stay on the CPU) and throws cdt::DeviceError on a CUDA
/// failure or in a build without CUDA. The result depends on neither `threads` nor `device`, nor on
/// the processor's vector instructions. With `keep` given, an image whose edges are made on the device
/// is left there in *keep for colour_trixels (within a bound on the device memory that images kept at
/// once take; else *keep is empty).
EdgeMap detect_edges(const Image& image, const EdgeOptions& options = {}, unsigned threads = 1,
                     EdgeDevice device = EdgeDevice::cpu, DevicePixels* keep = nullptr);

/// Prepares EdgeDevice::gpu: loads its device code, so that a first image does not wait for it (its
/// copies go through the pinned blocks prepare_trixels_on_device sets aside). Returns false, doing
/// nothing, in a build without CUDA or without a device; never throws.
bool prepare_edges_on_device() noexcept;

/// Process-wide: how many threads OpenCV's own parallel functions (the distance transform that fills
/// no-shape pixels' colours) may use; 0 or 1 runs
/// them on the calling thread. OpenCV's pool is global, so a program sets it once, before converting:
/// left alone it is every core, for each of a batch's images at once.
void set_opencv_threads(unsigned threads);

} // namespace vectorize
