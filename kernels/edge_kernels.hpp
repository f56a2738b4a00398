#pragma once
// Host-callable entry point of stage 2 (edge pixels) on the device. This header includes no CUDA
// header.

#include <cstddef>
#include <cstdint>
#include <memory>

#include "edge_steps.hpp" // vectorize/src: the steps, shared with the host

namespace vectorize::gpu {

/// An image's RGBA floats left on the device by edge_classes, so that trixel_sums need not copy them
/// there again; its device memory is freed with it (before the device is given back, then). Made by
/// edge_classes only.
class DeviceImage {
public:
  DeviceImage(const DeviceImage&) = delete;
  DeviceImage& operator=(const DeviceImage&) = delete;
  ~DeviceImage();
  const float* data() const { return pixels_; }
  int width() const { return width_; }
  int height() const { return height_; }

private:
  friend void edge_classes(const float*, int, int, const detail::BlurTaps&, const detail::ThresholdRule&,
                           std::uint8_t*, std::unique_ptr<DeviceImage>*);
  DeviceImage() = default;
  /// Device memory for a width x height image, or null when the images kept at once would take more
  /// than kKeptImageBytes or the memory is not there.
  static std::unique_ptr<DeviceImage> make(int width, int height);
  float* pixels_ = nullptr;
  int width_ = 0;
  int height_ = 0;
  bool pooled_ = false;
};

/// The edge classes (detail::kNotEdge, kCandidate or kStrong, after the hysteresis: the edges are the
/// strong pixels), width * height of them row-major, of the opaque width x height image of RGBA floats
/// `rgba` (row-major), as the host makes them with detail::gradient_rows (the colour scaled by
/// detail::kEdgeScale), detail::edge_thresholds over every pixel's squared magnitude,
/// detail::suppress_rows and detail::hysteresis: the same classes. Runs on the calling thread's default
/// stream (cudaStreamPerThread) and returns when they are in host memory; copies that fit go through a free
/// one of the pinned staging blocks the CDT engine's copies use. With `kept` given, the image is left on the
/// device in *kept for a later trixel_sums, unless the images kept at once would take more than
/// kKeptImageBytes (*kept is then empty). Throws cdt::DeviceError on any CUDA failure.
void edge_classes(const float* rgba, int width, int height, const detail::BlurTaps& taps,
                  const detail::ThresholdRule& rule, std::uint8_t* classes,
                  std::unique_ptr<DeviceImage>* kept = nullptr);

/// The most device memory the images kept by edge_classes hold at once.
inline constexpr std::size_t kKeptImageBytes = std::size_t{1} << 30;

/// The k-th smallest (from 0) of the n values, selected on the device as edge_classes selects the
/// automatic thresholds' quantile (for tests). Throws std::invalid_argument unless k < n, and
/// cdt::DeviceError on any CUDA failure.
std::uint32_t kth_smallest(const std::uint32_t* values, std::size_t n, std::size_t k);

/// detail::hysteresis of the width x height classes, on the device (for tests): the same classes.
/// Throws cdt::DeviceError on any CUDA failure.
void hysteresis(std::uint8_t* classes, int width, int height);

/// Loads edge_classes' device code, so that a first call does not wait for it (loading a kernel holds
/// the driver's lock, stalling every other thread's device work). Its copies use the staging blocks
/// prepare_trixel_sums pins. Throws cdt::DeviceError.
void prepare_edge_classes();

} // namespace vectorize::gpu
