// Stage 2 (edge pixels) on the device: one thread per pixel runs the host's steps for it
// (vectorize/src/edge_steps.hpp) in the host's order: the blur along x, the blur along y, the Sobel
// derivatives and the strongest channel, then, with the thresholds the host takes from the squared
// magnitudes (their quantile selected on the device too), the suppression.
#include "edge_kernels.hpp"

#include <cuda_runtime.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <stdexcept>
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

// The k-th smallest of n values by radix selection, all on the device: three passes count the values
// that agree with the bits found so far by their next bits (11, 11 and 10 from the top), each count
// in a block's shared memory first, and a one-block step after each finds the bin of rank k among
// them. Exactly the k-th smallest, whatever the values.
struct Selection {
  std::uint32_t prefix;    // the bits of the k-th value found so far
  std::uint32_t mask;      // which bits those are
  unsigned long long rank; // the value's rank among those that agree with them
};
constexpr int kSelectBins = 2048;
constexpr int kSelectThreads = 1024;
struct SelectPass {
  int shift;
  int bits;
};
constexpr SelectPass kSelectPasses[] = {{21, 11}, {10, 11}, {0, 10}};

__global__ void select_start_kernel(Selection* selection, unsigned long long* counts, unsigned long long k) {
  for (int b = threadIdx.x; b < kSelectBins; b += blockDim.x) counts[b] = 0;
  if (threadIdx.x == 0) *selection = {0, 0, k};
}

__global__ void select_count_kernel(const std::uint32_t* __restrict__ values, std::size_t n,
                                    const Selection* __restrict__ selection, int shift,
                                    std::uint32_t bin_mask, unsigned long long* __restrict__ counts) {
  __shared__ unsigned long long local[kSelectBins];
  for (int b = threadIdx.x; b < kSelectBins; b += blockDim.x) local[b] = 0;
  __syncthreads();
  const std::uint32_t prefix = selection->prefix;
  const std::uint32_t mask = selection->mask;
  for (std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x; i < n;
       i += static_cast<std::size_t>(gridDim.x) * blockDim.x) {
    const std::uint32_t v = values[i];
    if ((v & mask) == prefix) atomicAdd(&local[(v >> shift) & bin_mask], 1ull);
  }
  __syncthreads();
  for (int b = threadIdx.x; b < kSelectBins; b += blockDim.x)
    if (local[b] != 0) atomicAdd(&counts[b], local[b]);
}

// One block of kSelectThreads: the counts' running sums, the bin whose range holds the rank, and the
// counts zeroed for the next pass.
__global__ void select_pick_kernel(unsigned long long* __restrict__ counts, int shift, int bits,
                                   Selection* __restrict__ selection) {
  __shared__ unsigned long long sums[kSelectBins];
  const Selection s = *selection;
  for (int b = threadIdx.x; b < kSelectBins; b += blockDim.x) {
    sums[b] = counts[b];
    counts[b] = 0;
  }
  __syncthreads();
  for (int offset = 1; offset < kSelectBins; offset <<= 1) {
    unsigned long long add[kSelectBins / kSelectThreads];
    for (int j = 0; j < kSelectBins / kSelectThreads; ++j) {
      const int b = threadIdx.x + j * kSelectThreads;
      add[j] = b >= offset ? sums[b - offset] : 0;
    }
    __syncthreads();
    for (int j = 0; j < kSelectBins / kSelectThreads; ++j) sums[threadIdx.x + j * kSelectThreads] += add[j];
    __syncthreads();
  }
  for (int j = 0; j < kSelectBins / kSelectThreads; ++j) {
    const int b = threadIdx.x + j * kSelectThreads;
    const unsigned long long below = b > 0 ? sums[b - 1] : 0;
    if (below <= s.rank && s.rank < sums[b]) {
      const std::uint32_t bin_mask = ((1u << bits) - 1) << shift;
      *selection = {s.prefix | static_cast<std::uint32_t>(b) << shift, s.mask | bin_mask, s.rank - below};
    }
  }
}

// Enqueues on `stream` the selection of the k-th smallest of the n values (k < n) into
// selection->prefix.
void enqueue_kth_smallest(const std::uint32_t* values, std::size_t n, std::size_t k, Selection* selection,
                          unsigned long long* counts, cudaStream_t stream) {
  select_start_kernel<<<1, kSelectThreads, 0, stream>>>(selection, counts, k);
  CDT_CUDA_CHECK_LAUNCH("select_start_kernel");
  // Enough blocks to fill the device a few times over, each counting a stretch of values.
  constexpr std::size_t kValuesPerBlock = 16 * kSelectThreads;
  const auto blocks =
      static_cast<unsigned>(std::min<std::size_t>((n + kValuesPerBlock - 1) / kValuesPerBlock, 256));
  for (const SelectPass& pass : kSelectPasses) {
    select_count_kernel<<<blocks, kSelectThreads, 0, stream>>>(values, n, selection, pass.shift,
                                                               (1u << pass.bits) - 1, counts);
    CDT_CUDA_CHECK_LAUNCH("select_count_kernel");
    select_pick_kernel<<<1, kSelectThreads, 0, stream>>>(counts, pass.shift, pass.bits, selection);
    CDT_CUDA_CHECK_LAUNCH("select_pick_kernel");
  }
}

// The thresholds of `rule`, with the selected quantile when there is one (the automatic rule).
__global__ void thresholds_kernel(detail::ThresholdRule rule, const Selection* selection,
                                  detail::SquaredThresholds* thresholds) {
  *thresholds = detail::thresholds_from_quantile(rule, selection != nullptr ? selection->prefix : 0u);
}

__global__ void suppress_kernel(const std::int16_t* __restrict__ dx, const std::int16_t* __restrict__ dy,
                                const std::uint32_t* __restrict__ magnitude, int width, int height,
                                std::size_t pixels, const detail::SquaredThresholds* __restrict__ thresholds,
                                std::uint8_t* __restrict__ classes) {
  const std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x;
  if (i >= pixels) return;
  const int x = static_cast<int>(i % static_cast<std::size_t>(width));
  const int y = static_cast<int>(i / static_cast<std::size_t>(width));
  const std::uint32_t* mid = magnitude + (i - static_cast<std::size_t>(x));
  const std::uint32_t* up = y > 0 ? mid - width : nullptr;
  const std::uint32_t* down = y + 1 < height ? mid + width : nullptr;
  classes[i] = detail::suppress(dx[i], dy[i], mid[x], up, mid, down, x, width, *thresholds);
}

// The hysteresis (detail::hysteresis's result) as connected components: every edge pixel (candidate
// or strong) starts as its own set, sets of 8-neighbours are joined (a union-find whose links only
// ever point to lower pixel indices, joined by compare-and-swap, so concurrent joins need no lock),
// and a candidate in a set with a strong pixel becomes strong. The components are unique, so the
// classes are the host's whatever order the joins take.
constexpr std::uint32_t kNoLabel = 0xFFFFFFFFu;

// Volatile reads: the links other threads' joins are changing come from memory, not an old copy.
__device__ std::uint32_t label_root(const volatile std::uint32_t* label, std::uint32_t i) {
  for (std::uint32_t up = label[i]; up != i; up = label[i]) i = up;
  return i;
}

__device__ void join_labels(std::uint32_t* label, std::uint32_t a, std::uint32_t b) {
  for (;;) {
    a = label_root(label, a);
    b = label_root(label, b);
    if (a == b) return;
    if (a > b) {
      const std::uint32_t t = a;
      a = b;
      b = t;
    }
    // b is a root: link it below a unless another join linked it first.
    const std::uint32_t was = atomicCAS(label + b, b, a);
    if (was == b) return;
    b = was;
  }
}

__global__ void hysteresis_labels_kernel(const std::uint8_t* __restrict__ classes, std::size_t pixels,
                                         std::uint32_t* __restrict__ label) {
  const std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x;
  if (i >= pixels) return;
  label[i] = classes[i] != detail::kNotEdge ? static_cast<std::uint32_t>(i) : kNoLabel;
}

__global__ void hysteresis_join_kernel(const std::uint8_t* __restrict__ classes, int width, int height,
                                       std::size_t pixels, std::uint32_t* label) {
  const std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x;
  if (i >= pixels || classes[i] == detail::kNotEdge) return;
  const int x = static_cast<int>(i % static_cast<std::size_t>(width));
  const int y = static_cast<int>(i / static_cast<std::size_t>(width));
  // Four of the eight neighbours: the other four join this pixel from their side.
  const int dxs[4] = {1, -1, 0, 1};
  const int dys[4] = {0, 1, 1, 1};
  for (int k = 0; k < 4; ++k) {
    const int nx = x + dxs[k];
    const int ny = y + dys[k];
    if (nx < 0 || nx >= width || ny >= height) continue;
    const std::size_t j = static_cast<std::size_t>(ny) * width + nx;
    if (classes[j] != detail::kNotEdge)
      join_labels(label, static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j));
  }
}

__global__ void hysteresis_roots_kernel(const std::uint8_t* __restrict__ classes, std::size_t pixels,
                                        std::uint32_t* label, std::uint8_t* __restrict__ strong_root) {
  const std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x;
  if (i >= pixels || classes[i] == detail::kNotEdge) return;
  const std::uint32_t root = label_root(label, static_cast<std::uint32_t>(i));
  label[i] = root; // still a link to an ancestor for the others' walks
  if (classes[i] == detail::kStrong) strong_root[root] = 1;
}

__global__ void hysteresis_apply_kernel(std::uint8_t* __restrict__ classes, std::size_t pixels,
                                        const std::uint32_t* __restrict__ label,
                                        const std::uint8_t* __restrict__ strong_root) {
  const std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x;
  if (i >= pixels || classes[i] != detail::kCandidate) return;
  if (strong_root[label[i]] != 0) classes[i] = detail::kStrong;
}

/// Queues the hysteresis of the width x height classes d_classes on `stream`, with d_label (a word per
/// pixel) and d_strong_root (a byte per pixel) as scratch.
void enqueue_hysteresis(std::uint8_t* d_classes, int width, int height, std::uint32_t* d_label,
                        std::uint8_t* d_strong_root, cudaStream_t stream) {
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  constexpr int kThreads = 256;
  const auto blocks = static_cast<unsigned>((pixels + kThreads - 1) / kThreads);
  CDT_CUDA_CHECK(cudaMemsetAsync(d_strong_root, 0, pixels, stream));
  hysteresis_labels_kernel<<<blocks, kThreads, 0, stream>>>(d_classes, pixels, d_label);
  CDT_CUDA_CHECK_LAUNCH("hysteresis_labels_kernel");
  hysteresis_join_kernel<<<blocks, kThreads, 0, stream>>>(d_classes, width, height, pixels, d_label);
  CDT_CUDA_CHECK_LAUNCH("hysteresis_join_kernel");
  hysteresis_roots_kernel<<<blocks, kThreads, 0, stream>>>(d_classes, pixels, d_label, d_strong_root);
  CDT_CUDA_CHECK_LAUNCH("hysteresis_roots_kernel");
  hysteresis_apply_kernel<<<blocks, kThreads, 0, stream>>>(d_classes, pixels, d_label, d_strong_root);
  CDT_CUDA_CHECK_LAUNCH("hysteresis_apply_kernel");
}
} // namespace

namespace {
std::atomic<std::size_t> g_kept_bytes{0}; // held by the DeviceImages alive
} // namespace

DeviceImage::~DeviceImage() {
  if (pixels_ == nullptr) return;
  cdt::gpu::detail::device_release(pixels_, pooled_);
  g_kept_bytes.fetch_sub(4 * static_cast<std::size_t>(width_) * height_ * sizeof(float));
}

std::unique_ptr<DeviceImage> DeviceImage::make(int width, int height) {
  const std::size_t bytes = 4 * static_cast<std::size_t>(width) * height * sizeof(float);
  if (g_kept_bytes.fetch_add(bytes) + bytes > kKeptImageBytes) {
    g_kept_bytes.fetch_sub(bytes);
    return nullptr;
  }
  std::unique_ptr<DeviceImage> image(new DeviceImage);
  void* pixels = nullptr;
  if (cdt::gpu::detail::device_allocate(&pixels, bytes, image->pooled_) != cudaSuccess) {
    cudaGetLastError(); // not sticky: the caller's own buffer tries again and reports a failure
    g_kept_bytes.fetch_sub(bytes);
    return nullptr;
  }
  image->pixels_ = static_cast<float*>(pixels);
  image->width_ = width;
  image->height_ = height;
  return image;
}

void edge_classes(const float* rgba, int width, int height, const detail::BlurTaps& taps,
                  const detail::ThresholdRule& rule, std::uint8_t* classes,
                  std::unique_ptr<DeviceImage>* kept) {
  if (kept != nullptr) kept->reset();
  if (width <= 0 || height <= 0) return;
  if (cdt::gpu::device_count() == 0)
    throw cdt::DeviceError("edges on the device: no CUDA device is available");
  const cudaStream_t stream = cudaStreamPerThread;
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  const std::size_t image_bytes = 4 * pixels * sizeof(float);
  // The image's device copy: kept for the trixel colours when asked and within the bound, else a
  // buffer of this call.
  std::unique_ptr<DeviceImage> keep = kept != nullptr ? DeviceImage::make(width, height) : nullptr;
  DeviceBuffer<float> d_own(keep ? 0 : 4 * pixels);
  float* const d_rgba = keep ? keep->pixels_ : d_own.data();
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
  CDT_CUDA_CHECK(cudaMemcpyAsync(d_rgba,
                                 block.get() != nullptr ? static_cast<const void*>(block.get()) : rgba,
                                 image_bytes, cudaMemcpyHostToDevice, stream));
  constexpr int kThreads = 256;
  const auto blocks = static_cast<unsigned>((pixels + kThreads - 1) / kThreads);
  if (taps.radius > 0) {
    blur_across_kernel<<<blocks, kThreads, 0, stream>>>(d_rgba, width, pixels, taps, d_across.data());
    CDT_CUDA_CHECK_LAUNCH("blur_across_kernel");
    blur_down_kernel<<<blocks, kThreads, 0, stream>>>(d_across.data(), width, height, pixels, taps,
                                                      d_blurred.data());
    CDT_CUDA_CHECK_LAUNCH("blur_down_kernel");
  } else {
    blur_across_kernel<<<blocks, kThreads, 0, stream>>>(d_rgba, width, pixels, taps, d_blurred.data());
    CDT_CUDA_CHECK_LAUNCH("blur_across_kernel");
  }
  gradient_kernel<<<blocks, kThreads, 0, stream>>>(d_blurred.data(), width, height, pixels, d_dx.data(),
                                                   d_dy.data(), d_magnitude.data());
  CDT_CUDA_CHECK_LAUNCH("gradient_kernel");

  // The automatic thresholds come from the quantile of every squared magnitude, selected where they are
  // (the host's quantile() in edge_thresholds gives the same value): the host waits once, for the
  // classes.
  DeviceBuffer<detail::SquaredThresholds> d_thresholds(1);
  DeviceBuffer<Selection> d_selection;
  DeviceBuffer<unsigned long long> d_counts;
  if (detail::automatic_thresholds(rule)) {
    d_selection.resize(1);
    d_counts.resize(kSelectBins);
    // The rank quantile() takes.
    const auto k = static_cast<std::size_t>(rule.non_edge_fraction * static_cast<double>(pixels - 1));
    enqueue_kth_smallest(d_magnitude.data(), pixels, k, d_selection.data(), d_counts.data(), stream);
  }
  thresholds_kernel<<<1, 1, 0, stream>>>(rule, d_selection.data(), d_thresholds.data());
  CDT_CUDA_CHECK_LAUNCH("thresholds_kernel");
  suppress_kernel<<<blocks, kThreads, 0, stream>>>(d_dx.data(), d_dy.data(), d_magnitude.data(), width,
                                                   height, pixels, d_thresholds.data(), d_classes.data());
  CDT_CUDA_CHECK_LAUNCH("suppress_kernel");
  // The magnitudes are read: their buffer takes the hysteresis' labels.
  DeviceBuffer<std::uint8_t> d_strong_root(pixels);
  enqueue_hysteresis(d_classes.data(), width, height, d_magnitude.data(), d_strong_root.data(), stream);
  CDT_CUDA_CHECK(cudaMemcpyAsync(block.get() != nullptr ? static_cast<void*>(block.get()) : classes,
                                 d_classes.data(), pixels, cudaMemcpyDeviceToHost, stream));
  CDT_CUDA_CHECK(cudaStreamSynchronize(stream));
  if (block.get() != nullptr) std::memcpy(classes, block.get(), pixels);
  if (kept != nullptr) *kept = std::move(keep);
}

void prepare_edge_classes() {
  if (cdt::gpu::device_count() == 0)
    throw cdt::DeviceError("edges on the device: no CUDA device is available");
  cudaFuncAttributes attributes{};
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, blur_across_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, blur_down_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, gradient_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, suppress_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, select_start_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, select_count_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, select_pick_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, thresholds_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, hysteresis_labels_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, hysteresis_join_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, hysteresis_roots_kernel));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, hysteresis_apply_kernel));
}

void hysteresis(std::uint8_t* classes, int width, int height) {
  if (width <= 0 || height <= 0) return;
  if (cdt::gpu::device_count() == 0) throw cdt::DeviceError("hysteresis: no CUDA device is available");
  const cudaStream_t stream = cudaStreamPerThread;
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  DeviceBuffer<std::uint8_t> d_classes(pixels), d_strong_root(pixels);
  DeviceBuffer<std::uint32_t> d_label(pixels);
  CDT_CUDA_CHECK(cudaMemcpyAsync(d_classes.data(), classes, pixels, cudaMemcpyHostToDevice, stream));
  enqueue_hysteresis(d_classes.data(), width, height, d_label.data(), d_strong_root.data(), stream);
  CDT_CUDA_CHECK(cudaMemcpyAsync(classes, d_classes.data(), pixels, cudaMemcpyDeviceToHost, stream));
  CDT_CUDA_CHECK(cudaStreamSynchronize(stream));
}

std::uint32_t kth_smallest(const std::uint32_t* values, std::size_t n, std::size_t k) {
  if (k >= n) throw std::invalid_argument("kth_smallest: k must be below n");
  if (cdt::gpu::device_count() == 0) throw cdt::DeviceError("kth_smallest: no CUDA device is available");
  const cudaStream_t stream = cudaStreamPerThread;
  DeviceBuffer<std::uint32_t> d_values(n);
  DeviceBuffer<Selection> d_selection(1);
  DeviceBuffer<unsigned long long> d_counts(kSelectBins);
  CDT_CUDA_CHECK(
      cudaMemcpyAsync(d_values.data(), values, n * sizeof(std::uint32_t), cudaMemcpyHostToDevice, stream));
  enqueue_kth_smallest(d_values.data(), n, k, d_selection.data(), d_counts.data(), stream);
  Selection selection{};
  CDT_CUDA_CHECK(
      cudaMemcpyAsync(&selection, d_selection.data(), sizeof selection, cudaMemcpyDeviceToHost, stream));
  CDT_CUDA_CHECK(cudaStreamSynchronize(stream));
  return selection.prefix;
}

} // namespace vectorize::gpu
