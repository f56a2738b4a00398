// Batch evaluation of the exact predicates on the device: the same code as the host
// (cdt/detail/predicates.hpp), used to check that device arithmetic matches the host bit for bit.

#include "cdt/detail/predicates.hpp"
#include "cdt_kernels.hpp"
#include "cuda_check.cuh"

namespace cdt::gpu {
namespace {

__global__ void orient2d_kernel(const double* __restrict__ d_coords, int* __restrict__ d_signs,
                                std::size_t num) {
  const std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x;
  if (i >= num) return;
  const double* c = d_coords + 6 * i;
  d_signs[i] = ::cdt::detail::orient2d(c[0], c[1], c[2], c[3], c[4], c[5]);
}

__global__ void incircle_kernel(const double* __restrict__ d_coords, int* __restrict__ d_signs,
                                std::size_t num) {
  const std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x;
  if (i >= num) return;
  const double* c = d_coords + 8 * i;
  d_signs[i] = ::cdt::detail::incircle(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]);
}

template <class Kernel>
void run_batch(Kernel kernel, const char* name, const double* coords, int* signs, std::size_t num,
               std::size_t per_query) {
  if (num == 0) return;
  ::cdt::gpu::detail::DeviceBuffer<double> d_coords(per_query * num);
  ::cdt::gpu::detail::DeviceBuffer<int> d_signs(num);
  CDT_CUDA_CHECK(
      cudaMemcpy(d_coords.data(), coords, per_query * num * sizeof(double), cudaMemcpyHostToDevice));
  constexpr unsigned block = 128;
  const unsigned grid = static_cast<unsigned>((num + block - 1) / block);
  kernel<<<grid, block>>>(d_coords.data(), d_signs.data(), num);
  CDT_CUDA_CHECK_LAUNCH(name);
  CDT_CUDA_CHECK(cudaMemcpy(signs, d_signs.data(), num * sizeof(int), cudaMemcpyDeviceToHost));
}

} // namespace

void orient2d_signs(const double* coords, int* signs, std::size_t num) {
  run_batch(orient2d_kernel, "orient2d_kernel", coords, signs, num, 6);
}

void incircle_signs(const double* coords, int* signs, std::size_t num) {
  run_batch(incircle_kernel, "incircle_kernel", coords, signs, num, 8);
}

std::size_t incircle_local_bytes() {
  cudaFuncAttributes attributes{};
  CDT_CUDA_CHECK(cudaFuncGetAttributes(&attributes, incircle_kernel));
  return attributes.localSizeBytes;
}

} // namespace cdt::gpu
