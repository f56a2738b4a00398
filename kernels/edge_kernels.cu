// Stage 2 (edge pixels) on the device: one thread per pixel runs the host's steps for it
// (vectorize/src/edge_steps.hpp) in the host's order: the blur along x, the blur along y, the Sobel
// derivatives and the strongest channel, then, with the thresholds the host takes from the squared
// magnitudes, the suppression.
#include "edge_kernels.hpp"

#include <cuda_runtime.h>

#include <cstring>
#include <vector>

#include "cdt/errors.hpp"
#include "cdt_kernels.hpp"
#include "cuda_check.cuh"

namespace vectorize::gpu {
namespace {

using cdt::gpu::detail::DeviceBuffer;
using cdt::gpu::detail::HeldStagingBlock;

__device__ int clamp_index(int i, int n) { return i < 0 ? 0 : (i >= n ? n - 1 : i); }

// The colour scaled and blurred along x, into three planes (radius 0: scaled only).
__global__ void blur_across_kernel(const float* __restrict__ rgba, int width, std::size_t pixels,
                                   detail::BlurTaps taps, float* __restrict__ planes) {
  const std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x;
  if (i >= pixels) return;
  const int x = static_cast<int>(i % static_cast<std::size_t>(width));
  const float* row = rgba + (i - static_cast<std::size_t>(x)) * 4;
  for (int c = 0; c < 3; ++c) {
    const auto at = [&](int k) { return row[4 * clamp_index(k, width) + c] * detail::kEdgeScale; };
    float acc = taps.radius == 0 ? at(x) : taps.weight[0] * at(x);
    for (int k = 1; k <= taps.radius; ++k) acc = detail::add_taps(acc, taps.weight[k], at(x - k), at(x + k));
    planes[c * pixels + i] = acc;
  }
}

// The planes blurred along y.
__global__ void blur_down_kernel(const float* __restrict__ across, int width, int height, std::size_t pixels,
                                 detail::BlurTaps taps, float* __restrict__ planes) {
  const std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x;
  if (i >= pixels) return;
  const int x = static_cast<int>(i % static_cast<std::size_t>(width));
  const int y = static_cast<int>(i / static_cast<std::size_t>(width));
  for (int c = 0; c < 3; ++c) {
    const float* plane = across + c * pixels;
    const auto at = [&](int k) {
      return plane[static_cast<std::size_t>(clamp_index(k, height)) * width + x];
    };
    float acc = taps.weight[0] * at(y);
    for (int k = 1; k <= taps.radius; ++k) acc = detail::add_taps(acc, taps.weight[k], at(y - k), at(y + k));
    planes[c * pixels + i] = acc;
  }
}

__global__ void gradient_kernel(const float* __restrict__ blurred, int width, int height, std::size_t pixels,
                                std::int16_t* __restrict__ dx, std::int16_t* __restrict__ dy,
                                std::uint32_t* __restrict__ magnitude) {
  const std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x;
  if (i >= pixels) return;
  const int x = static_cast<int>(i % static_cast<std::size_t>(width));
  const int y = static_cast<int>(i / static_cast<std::size_t>(width));
  const int l = clamp_index(x - 1, width);
  const int r = clamp_index(x + 1, width);
  const std::size_t up = static_cast<std::size_t>(clamp_index(y - 1, height)) * width;
  const std::size_t mid = static_cast<std::size_t>(y) * width;
  const std::size_t down = static_cast<std::size_t>(clamp_index(y + 1, height)) * width;
  float gx[3];
  float gy[3];
  for (int c = 0; c < 3; ++c) {
    const float* p = blurred + c * pixels;
    gx[c] = detail::sobel_x(p[up + l], p[up + r], p[mid + l], p[mid + r], p[down + l], p[down + r]);
    gy[c] = detail::sobel_y(p[up + l], p[up + x], p[up + r], p[down + l], p[down + x], p[down + r]);
  }
  const detail::PixelGradient g = detail::strongest_channel(gx[0], gy[0], gx[1], gy[1], gx[2], gy[2]);
  dx[i] = static_cast<std::int16_t>(g.dx);
  dy[i] = static_cast<std::int16_t>(g.dy);
  magnitude[i] = g.magnitude;
}

__global__ void suppress_kernel(const std::int16_t* __restrict__ dx, const std::int16_t* __restrict__ dy,
                                const std::uint32_t* __restrict__ magnitude, int width, int height,
                                std::size_t pixels, detail::SquaredThresholds thresholds,
                                std::uint8_t* __restrict__ classes) {
  const std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x;
  if (i >= pixels) return;
  const int x = static_cast<int>(i % static_cast<std::size_t>(width));
  const int y = static_cast<int>(i / static_cast<std::size_t>(width));
  const std::uint32_t* mid = magnitude + (i - static_cast<std::size_t>(x));
  const std::uint32_t* up = y > 0 ? mid - width : nullptr;
  const std::uint32_t* down = y + 1 < height ? mid + width : nullptr;
  classes[i] = detail::suppress(dx[i], dy[i], mid[x], up, mid, down, x, width, thresholds);
}

} // namespace

void edge_classes(const float* rgba, int width, int height, const detail::BlurTaps& taps,
                  const detail::ThresholdRule& rule, std::uint8_t* classes) {
  if (width <= 0 || height <= 0) return;
  if (cdt::gpu::device_count() == 0)
    throw cdt::DeviceError("edges on the device: no CUDA device is available");
  const cudaStream_t stream = cudaStreamPerThread;
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  const std::size_t image_bytes = 4 * pixels * sizeof(float);
  DeviceBuffer<float> d_rgba(4 * pixels);
  DeviceBuffer<float> d_across(taps.radius > 0 ? 3 * pixels : 0);
  DeviceBuffer<float> d_blurred(3 * pixels);
  DeviceBuffer<std::int16_t> d_dx(pixels);
  DeviceBuffer<std::int16_t> d_dy(pixels);
  DeviceBuffer<std::uint32_t> d_magnitude(pixels);
  DeviceBuffer<std::uint8_t> d_classes(pixels);

  // Through a pinned staging block when the image fits one (the downloads are smaller): it skips the
  // driver's path for pageable memory, which serialises the copies of a batch's many workers.
  const HeldStagingBlock block(image_bytes <= cdt::gpu::detail::kStagingBytes);
  if (block.get() != nullptr) std::memcpy(block.get(), rgba, image_bytes);
  CDT_CUDA_CHECK(cudaMemcpyAsync(d_rgba.data(),
                                 block.get() != nullptr ? static_cast<const void*>(block.get()) : rgba,
                                 image_bytes, cudaMemcpyHostToDevice, stream));
  constexpr int kThreads = 256;
  const auto blocks = static_cast<unsigned>((pixels + kThreads - 1) / kThreads);
  if (taps.radius > 0) {
    blur_across_kernel<<<blocks, kThreads, 0, stream>>>(d_rgba.data(), width, pixels, taps, d_across.data());
    CDT_CUDA_CHECK_LAUNCH("blur_across_kernel");
    blur_down_kernel<<<blocks, kThreads, 0, stream>>>(d_across.data(), width, height, pixels, taps,
                                                      d_blurred.data());
    CDT_CUDA_CHECK_LAUNCH("blur_down_kernel");
  } else {
    blur_across_kernel<<<blocks, kThreads, 0, stream>>>(d_rgba.data(), width, pixels, taps, d_blurred.data());
    CDT_CUDA_CHECK_LAUNCH("blur_across_kernel");
  }
  gradient_kernel<<<blocks, kThreads, 0, stream>>>(d_blurred.data(), width, height, pixels, d_dx.data(),
                                                   d_dy.data(), d_magnitude.data());
  CDT_CUDA_CHECK_LAUNCH("gradient_kernel");

  // Automatic thresholds need every squared magnitude on the host, for the quantile; read where they
  // land (after the upload has read the block, in stream order).
  const bool automatic = rule.low == 0.0 && rule.high == 0.0;
  std::vector<std::uint32_t> pageable;
  const std::uint32_t* magnitudes = nullptr;
  if (automatic) {
    void* landing = block.get();
    if (landing == nullptr) {
      pageable.resize(pixels);
      landing = pageable.data();
    }
    CDT_CUDA_CHECK(cudaMemcpyAsync(landing, d_magnitude.data(), pixels * sizeof(std::uint32_t),
                                   cudaMemcpyDeviceToHost, stream));
    CDT_CUDA_CHECK(cudaStreamSynchronize(stream));
    magnitudes = static_cast<const std::uint32_t*>(landing);
  }
  const detail::SquaredThresholds thresholds =
      detail::edge_thresholds(rule, magnitudes, automatic ? pixels : 0);
  suppress_kernel<<<blocks, kThreads, 0, stream>>>(d_dx.data(), d_dy.data(), d_magnitude.data(), width,
                                                   height, pixels, thresholds, d_classes.data());
  CDT_CUDA_CHECK_LAUNCH("suppress_kernel");
  CDT_CUDA_CHECK(cudaMemcpyAsync(block.get() != nullptr ? static_cast<void*>(block.get()) : classes,
                                 d_classes.data(), pixels, cudaMemcpyDeviceToHost, stream));
  CDT_CUDA_CHECK(cudaStreamSynchronize(stream));
  if (block.get() != nullptr) std::memcpy(classes, block.get(), pixels);
}

void prepare_edge_classes() {
  if (cdt::gpu::device_count() == 0)
    throw cdt::DeviceError("edges on the device: no CUDA device is available");
  cudaFuncAttributes attributes{};
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, blur_across_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, blur_down_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, gradient_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, suppress_kernel));
}

} // namespace vectorize::gpu
