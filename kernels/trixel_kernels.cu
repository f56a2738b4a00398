// The trixel stage's per-triangle sums on the device: one thread per triangle makes its runs and adds
// up its pixels with the host's code (vectorize/src/trixel_runs.hpp), so in the host's order.
#include "trixel_kernels.hpp"

#include <cuda_runtime.h>

#include <algorithm>
#include <cstring>

#include "cdt/errors.hpp"
#include "cdt_kernels.hpp"
#include "colour_lab.hpp"
#include "cuda_check.cuh"

namespace vectorize::gpu {
namespace {

using cdt::gpu::detail::DeviceBuffer;
using cdt::gpu::detail::HeldStagingBlock;

template <bool kOpaque>
__global__ void trixel_sums_kernel(const float* __restrict__ rgba, int width, int height,
                                   const cdt::Point* __restrict__ vertices,
                                   const std::uint32_t* __restrict__ corners, std::size_t num_triangles,
                                   detail::TrixelSums* __restrict__ sums,
                                   const double* __restrict__ linear_table, double* __restrict__ lab) {
  const std::size_t tri = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x;
  if (tri >= num_triangles) return;
  const std::uint32_t* t = corners + 3 * tri;
  detail::TrixelSums s;
  const std::size_t row_floats = static_cast<std::size_t>(width) * 4;
  detail::triangle_runs(vertices[t[0]], vertices[t[1]], vertices[t[2]], width, height,
                        [&](int row, int begin, int end) {
                          const float* line = rgba + row * row_floats;
                          if constexpr (kOpaque)
                            detail::add_run_opaque(s, line, begin, end);
                          else
                            detail::add_run(s, line, begin, end);
                        });
  sums[tri] = s;
  if (lab == nullptr) return;
  double* out = lab + 3 * tri;
  if (s.pixel_count == 0) { // coloured on the host (a neighbour's colour, or a sample)
    out[0] = out[1] = out[2] = 0.0;
    return;
  }
  float colour[4];
  detail::trixel_rgba(s, kOpaque, colour);
  detail::lab_of_rgb(colour, linear_table, out);
}

std::size_t aligned(std::size_t bytes) { return (bytes + 255) / 256 * 256; }

// At most this many staging blocks are pinned for the callers (64 MB). A batch's sixteen workers on
// the H100 machine converted 200 photographs at 121-138 images/s with four against 100-124 with
// sixteen (whose pinning held up the device's start by 0.1-0.17 s), for 170-190 MB less memory.
constexpr std::size_t kMaxStagingBlocks = 4;

} // namespace

void trixel_sums(const float* rgba, int width, int height, const cdt::Point* vertices,
                 std::size_t num_vertices, const std::array<std::uint32_t, 3>* triangles,
                 std::size_t num_triangles, bool opaque, detail::TrixelSums* sums, const float* device_rgba,
                 std::array<double, 3>* lab) {
  if (num_triangles == 0) return;
  if (cdt::gpu::device_count() == 0)
    throw cdt::DeviceError("trixel colours on the device: no CUDA device is available");
  const cudaStream_t stream = cudaStreamPerThread;
  const std::size_t pixels = width > 0 && height > 0 ? static_cast<std::size_t>(width) * height : 0;
  // Three vertex indices per triangle, as std::array<std::uint32_t, 3> lays them out.
  static_assert(sizeof(std::array<std::uint32_t, 3>) == 3 * sizeof(std::uint32_t));
  const std::size_t image_bytes = 4 * pixels * sizeof(float);
  const std::size_t vertex_bytes = num_vertices * sizeof(cdt::Point);
  const std::size_t triangle_bytes = num_triangles * sizeof(triangles[0]);
  const std::size_t sum_bytes = num_triangles * sizeof(detail::TrixelSums);
  static_assert(sizeof(std::array<double, 3>) == 3 * sizeof(double));
  const std::size_t lab_bytes = lab != nullptr ? num_triangles * sizeof(lab[0]) : 0;
  const std::size_t table_bytes = lab != nullptr ? (detail::kLinearSamples + 1) * sizeof(double) : 0;
  DeviceBuffer<float> d_own(device_rgba != nullptr ? 0 : 4 * pixels);
  const float* d_rgba = device_rgba != nullptr ? device_rgba : d_own.data();
  DeviceBuffer<cdt::Point> d_vertices(num_vertices);
  DeviceBuffer<std::uint32_t> d_triangles(3 * num_triangles);
  DeviceBuffer<detail::TrixelSums> d_sums(num_triangles);
  DeviceBuffer<double> d_table(table_bytes / sizeof(double));
  DeviceBuffer<double> d_lab(lab_bytes / sizeof(double));

  // A photograph's copies fit a pinned staging block: through it they skip the driver's path for
  // pageable memory, which serialises the copies of a batch's many workers (H200 machine, sixteen
  // workers: an image's upload took 3.9 ms against 0.8 alone, and the stage 11 ms against 8 staged).
  const std::size_t vertex_at = device_rgba != nullptr ? 0 : aligned(image_bytes); // after the image's
  const std::size_t triangle_at = vertex_at + aligned(vertex_bytes);
  const std::size_t table_at = triangle_at + aligned(triangle_bytes);
  const std::size_t lab_at = aligned(sum_bytes); // downloaded after the sums
  const HeldStagingBlock block(std::max(table_at + table_bytes, lab_at + lab_bytes) <=
                               cdt::gpu::detail::kStagingBytes);
  const auto upload = [&](void* d_dst, const void* h_src, std::size_t bytes, std::size_t at) {
    if (bytes == 0) return;
    if (block.get() != nullptr) {
      std::memcpy(block.get() + at, h_src, bytes);
      h_src = block.get() + at;
    }
    CDT_CUDA_CHECK(cudaMemcpyAsync(d_dst, h_src, bytes, cudaMemcpyHostToDevice, stream));
  };
  if (device_rgba == nullptr) upload(d_own.data(), rgba, image_bytes, 0);
  upload(d_vertices.data(), vertices, vertex_bytes, vertex_at);
  upload(d_triangles.data(), triangles, triangle_bytes, triangle_at);
  // The curve's table for the colours' CIELAB (33 KB), the host's own: the device's pow rounds
  // differently.
  upload(d_table.data(), detail::srgb_linear_table(), table_bytes, table_at);
  constexpr int kThreads = 128;
  const auto blocks = static_cast<unsigned>((num_triangles + kThreads - 1) / kThreads);
  if (opaque)
    trixel_sums_kernel<true><<<blocks, kThreads, 0, stream>>>(d_rgba, width, height, d_vertices.data(),
                                                              d_triangles.data(), num_triangles,
                                                              d_sums.data(), d_table.data(), d_lab.data());
  else
    trixel_sums_kernel<false><<<blocks, kThreads, 0, stream>>>(d_rgba, width, height, d_vertices.data(),
                                                               d_triangles.data(), num_triangles,
                                                               d_sums.data(), d_table.data(), d_lab.data());
  CDT_CUDA_CHECK_LAUNCH("trixel_sums_kernel");
  // In stream order, after the uploads have read the block.
  const auto download = [&](void* h_dst, const void* d_src, std::size_t bytes, std::size_t at) {
    if (bytes == 0) return;
    CDT_CUDA_CHECK(cudaMemcpyAsync(block.get() != nullptr ? static_cast<void*>(block.get() + at) : h_dst,
                                   d_src, bytes, cudaMemcpyDeviceToHost, stream));
  };
  download(sums, d_sums.data(), sum_bytes, 0);
  download(lab, d_lab.data(), lab_bytes, lab_at);
  CDT_CUDA_CHECK(cudaStreamSynchronize(stream));
  if (block.get() != nullptr) {
    std::memcpy(sums, block.get(), sum_bytes);
    if (lab_bytes != 0) std::memcpy(lab, block.get() + lab_at, lab_bytes);
  }
}

void prepare_trixel_sums(std::size_t callers) {
  if (cdt::gpu::device_count() == 0)
    throw cdt::DeviceError("trixel colours on the device: no CUDA device is available");
  cudaFuncAttributes attributes{};
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, trixel_sums_kernel<true>));
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, trixel_sums_kernel<false>));
  cdt::gpu::reserve_memory(std::min<std::size_t>(callers, kMaxStagingBlocks), 0);
}

} // namespace vectorize::gpu
