#pragma once
// The one choke point through which CUDA failures become exceptions.

#include <cuda_runtime.h>

#include <string>

#include "cdt/errors.hpp"

namespace cdt::gpu::detail {

[[noreturn]] void raise_cuda_error(cudaError_t status, const char* what, const char* file, int line);

/// True when launches should be followed by a synchronisation (debug switch).
bool debug_sync() noexcept;

inline void check(cudaError_t status, const char* what, const char* file, int line) {
  if (status != cudaSuccess) raise_cuda_error(status, what, file, line);
}

/// Checks the launch just made, and with the debug switch on waits for it to finish.
inline void check_launch(const char* kernel, const char* file, int line) {
  check(cudaGetLastError(), kernel, file, line);
  if (debug_sync()) check(cudaDeviceSynchronize(), kernel, file, line);
}

/// A device buffer owned by RAII; plain cudaMalloc, never managed memory.
template <class T>
class DeviceBuffer {
public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(std::size_t count) { resize(count); }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  ~DeviceBuffer() {
    if (d_ptr_ != nullptr) cudaFree(d_ptr_);
  }
  void resize(std::size_t count) {
    if (count <= capacity_) {
      num_ = count;
      return;
    }
    if (d_ptr_ != nullptr) cudaFree(d_ptr_);
    d_ptr_ = nullptr;
    capacity_ = 0;
    check(cudaMalloc(reinterpret_cast<void**>(&d_ptr_), count * sizeof(T)), "cudaMalloc", __FILE__, __LINE__);
    capacity_ = count;
    num_ = count;
  }
  T* data() noexcept { return d_ptr_; }
  const T* data() const noexcept { return d_ptr_; }
  std::size_t size() const noexcept { return num_; }

private:
  T* d_ptr_ = nullptr;
  std::size_t num_ = 0;
  std::size_t capacity_ = 0;
};

} // namespace cdt::gpu::detail

#define CDT_CUDA_CHECK(call) ::cdt::gpu::detail::check((call), #call, __FILE__, __LINE__)
#define CDT_CUDA_CHECK_LAUNCH(name) ::cdt::gpu::detail::check_launch(name, __FILE__, __LINE__)
