// Device discovery and the error choke point of the CUDA executor.

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <string>

#include "cdt_kernels.hpp"
#include "cuda_check.cuh"

namespace cdt::gpu {
namespace {
std::atomic<bool> g_debug_sync{false};
}

namespace detail {

void raise_cuda_error(cudaError_t status, const char* what, const char* file, int line) {
  throw DeviceError(std::string("CUDA error ") + cudaGetErrorName(status) + " (" +
                    cudaGetErrorString(status) + ") in " + what + " at " + file + ":" + std::to_string(line));
}

bool debug_sync() noexcept {
  static const bool from_env = [] {
    const char* v = std::getenv("TRIXEL_CUDA_SYNC");
    return v != nullptr && std::strcmp(v, "0") != 0 && v[0] != '\0';
  }();
  return from_env || g_debug_sync.load(std::memory_order_relaxed);
}

} // namespace detail

void set_debug_sync(bool on) noexcept { g_debug_sync.store(on, std::memory_order_relaxed); }

int device_count() noexcept {
  int count = 0;
  // Without a driver or device this reports an error; that simply means "no GPU".
  if (cudaGetDeviceCount(&count) != cudaSuccess) {
    cudaGetLastError(); // clear the sticky error state
    return 0;
  }
  return count;
}

std::string device_description() {
  if (device_count() == 0) throw DeviceError("no CUDA device is available");
  cudaDeviceProp prop{};
  CDT_CUDA_CHECK(cudaGetDeviceProperties(&prop, 0));
  return std::string(prop.name) + " (compute capability " + std::to_string(prop.major) + "." +
         std::to_string(prop.minor) + ", " + std::to_string(prop.multiProcessorCount) + " SMs, " +
         std::to_string(prop.totalGlobalMem >> 20) + " MiB)";
}

} // namespace cdt::gpu
