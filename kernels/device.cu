// Device discovery and the error choke point of the CUDA executor.

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <utility>
#include <string>

#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"

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

namespace {

/// Blocks of at least this size are kept for reuse when released; smaller ones are freed.
constexpr std::size_t kKeepAbove = std::size_t{1} << 20;

/// Released device blocks kept for reuse, by size, per device.
struct KeptBlocks {
  std::mutex mutex;
  std::multimap<std::size_t, std::pair<int, void*>> blocks; ///< bytes -> (device, pointer)
};

KeptBlocks& kept_blocks() {
  static KeptBlocks* kept = new KeptBlocks; // never destroyed: blocks may be released at exit
  return *kept;
}

/// cudaFree of every kept block of the current device.
void free_kept_blocks() noexcept {
  int device = 0;
  if (cudaGetDevice(&device) != cudaSuccess) return;
  KeptBlocks& kept = kept_blocks();
  std::lock_guard lock(kept.mutex);
  for (auto it = kept.blocks.begin(); it != kept.blocks.end();) {
    if (it->second.first == device) {
      cudaFree(it->second.second);
      it = kept.blocks.erase(it);
    } else {
      ++it;
    }
  }
}

} // namespace

cudaError_t device_allocate(void** d_ptr, std::size_t bytes) {
  *d_ptr = nullptr;
  int device = 0;
  if (const cudaError_t status = cudaGetDevice(&device); status != cudaSuccess) return status;
  if (bytes >= kKeepAbove) {
    // A kept block of the size asked for, or up to a quarter larger.
    KeptBlocks& kept = kept_blocks();
    std::lock_guard lock(kept.mutex);
    for (auto it = kept.blocks.lower_bound(bytes); it != kept.blocks.end() && it->first <= bytes + bytes / 4;
         ++it) {
      if (it->second.first != device) continue;
      *d_ptr = it->second.second;
      kept.blocks.erase(it);
      return cudaSuccess;
    }
  }
  cudaError_t status = cudaMalloc(d_ptr, bytes);
  if (status == cudaErrorMemoryAllocation) {
    cudaGetLastError();
    free_kept_blocks();
    status = cudaMalloc(d_ptr, bytes);
  }
  if (status != cudaSuccess) *d_ptr = nullptr;
  return status;
}

void device_release(void* d_ptr, std::size_t bytes) noexcept {
  if (d_ptr == nullptr) return;
  int device = 0;
  // With the debug switch every block is freed at once, so that compute-sanitizer sees any use of a
  // released buffer.
  if (bytes < kKeepAbove || debug_sync() || cudaGetDevice(&device) != cudaSuccess ||
      cudaDeviceSynchronize() != cudaSuccess) {
    cudaFree(d_ptr);
    return;
  }
  KeptBlocks& kept = kept_blocks();
  std::lock_guard lock(kept.mutex);
  kept.blocks.emplace(bytes, std::make_pair(device, d_ptr));
}

void check_free_memory(std::size_t bytes) {
  std::size_t free_bytes = 0, total_bytes = 0;
  CDT_CUDA_CHECK(cudaMemGetInfo(&free_bytes, &total_bytes));
  if (bytes > free_bytes) {
    free_kept_blocks();
    CDT_CUDA_CHECK(cudaMemGetInfo(&free_bytes, &total_bytes));
  }
  if (bytes > free_bytes)
    throw DeviceError("cannot allocate " + std::to_string(bytes >> 20) +
                      " MiB of device memory: " + std::to_string(free_bytes >> 20) + " MiB free of " +
                      std::to_string(total_bytes >> 20) + " MiB");
}

DeviceMemory device_memory() {
  DeviceMemory memory;
  CDT_CUDA_CHECK(cudaMemGetInfo(&memory.free_bytes, &memory.total_bytes));
  return memory;
}

void require_device_memory(std::size_t needed_bytes, std::size_t limit_bytes, const std::string& what) {
  const auto mib = [](std::size_t bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB"; };
  if (limit_bytes != 0) {
    if (needed_bytes > limit_bytes)
      throw DeviceError(what + " needs " + mib(needed_bytes) + " of device memory, more than the limit of " +
                        mib(limit_bytes) + " it was given");
    return;
  }
  DeviceMemory memory = device_memory();
  if (needed_bytes > memory.free_bytes) {
    free_kept_blocks(); // blocks kept for reuse are this process's to give back
    memory = device_memory();
  }
  if (needed_bytes > memory.free_bytes)
    throw DeviceError(what + " needs " + mib(needed_bytes) + " of device memory, but the device has only " +
                      mib(memory.free_bytes) + " free (of " + mib(memory.total_bytes) +
                      "); use a smaller grid or the CPU backend");
}

CudaExecutor::CudaExecutor() {
  if (device_count() == 0) throw DeviceError("no CUDA device is available");
  int device = 0;
  CDT_CUDA_CHECK(cudaGetDevice(&device));
  int sms = 0;
  CDT_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device));
  // Enough blocks of 256 threads to fill every SM several times; longer ranges loop in the kernel.
  max_blocks_ = static_cast<std::size_t>(sms > 0 ? sms : 1) * 32;
  CDT_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking));
  try {
    scalar_.resize(1);
  } catch (...) {
    cudaStreamDestroy(stream_);
    throw;
  }
}

CudaExecutor::~CudaExecutor() {
  // Buffers are freed by their own destructors (cudaFree waits for the device); errors here were
  // reported by the call that caused them.
  if (stream_ != nullptr) cudaStreamSynchronize(stream_);
  for (int k = 0; k < 2; ++k) {
    if (h_staging_[k] != nullptr) cudaFreeHost(h_staging_[k]);
    if (staged_[k] != nullptr) cudaEventDestroy(staged_[k]);
  }
  if (stream_ != nullptr) cudaStreamDestroy(stream_);
}

namespace {
/// Copies up to this size go straight from pageable memory; larger ones are split into blocks of
/// this size and staged through two pinned blocks, the host's memcpy of one block overlapping the
/// bus transfer of the other.
constexpr std::size_t kStagingBytes = std::size_t{8} << 20;
constexpr std::size_t kCopyPartBytes = std::size_t{512} << 10; ///< a host thread's share of a block
} // namespace

void CudaExecutor::make_staging() {
  for (int k = 0; k < 2; ++k) {
    if (h_staging_[k] == nullptr) CDT_CUDA_CHECK(cudaMallocHost(&h_staging_[k], kStagingBytes));
    if (staged_[k] == nullptr) CDT_CUDA_CHECK(cudaEventCreateWithFlags(&staged_[k], cudaEventDisableTiming));
  }
}

void CudaExecutor::copy_to_device(void* d_dst, const void* h_src, std::size_t bytes) {
  if (bytes == 0) return;
  if (bytes <= kStagingBytes) {
    CDT_CUDA_CHECK(cudaMemcpyAsync(d_dst, h_src, bytes, cudaMemcpyHostToDevice, stream_));
    return;
  }
  make_staging();
  auto* dst = static_cast<unsigned char*>(d_dst);
  const auto* src = static_cast<const unsigned char*>(h_src);
  for (std::size_t at = 0, k = 0; at < bytes; at += kStagingBytes, ++k) {
    const std::size_t len = std::min(kStagingBytes, bytes - at);
    const int buf = static_cast<int>(k % 2);
    // The block's last transfer (two blocks back, or of an earlier upload) must be done before it is
    // refilled; an event never recorded counts as done.
    CDT_CUDA_CHECK(cudaEventSynchronize(staged_[buf]));
    std::memcpy(h_staging_[buf], src + at, len);
    CDT_CUDA_CHECK(cudaMemcpyAsync(dst + at, h_staging_[buf], len, cudaMemcpyHostToDevice, stream_));
    CDT_CUDA_CHECK(cudaEventRecord(staged_[buf], stream_));
  }
}

void CudaExecutor::copy_to_host(void* h_dst, const void* d_src, std::size_t bytes,
                                const HostParallelFor* parallel) {
  if (bytes <= kStagingBytes) {
    if (bytes != 0) CDT_CUDA_CHECK(cudaMemcpyAsync(h_dst, d_src, bytes, cudaMemcpyDeviceToHost, stream_));
    synchronize();
    return;
  }
  make_staging();
  auto* dst = static_cast<unsigned char*>(h_dst);
  const auto* src = static_cast<const unsigned char*>(d_src);
  const std::size_t blocks = (bytes + kStagingBytes - 1) / kStagingBytes;
  const auto drain = [&](std::size_t k) { // waits for block k and copies it out of its staging block
    const int buf = static_cast<int>(k % 2);
    const std::size_t at = k * kStagingBytes;
    CDT_CUDA_CHECK(cudaEventSynchronize(staged_[buf]));
    const std::size_t len = std::min(kStagingBytes, bytes - at);
    const auto* from = static_cast<const unsigned char*>(h_staging_[buf]);
    if (parallel == nullptr || !*parallel) {
      std::memcpy(dst + at, from, len);
      return;
    }
    // The destination is often fresh memory: its page faults cost more than the copy, and spread
    // over threads as well as the copy does.
    const std::size_t parts = (len + kCopyPartBytes - 1) / kCopyPartBytes;
    (*parallel)(parts, [&](std::size_t p) {
      const std::size_t offset = p * kCopyPartBytes;
      std::memcpy(dst + at + offset, from + offset, std::min(kCopyPartBytes, len - offset));
    });
  };
  for (std::size_t k = 0; k < blocks; ++k) {
    const int buf = static_cast<int>(k % 2);
    const std::size_t at = k * kStagingBytes;
    // Block k - 2 used this staging block and was drained in the last iteration; stream order puts
    // this transfer after any upload still reading it.
    CDT_CUDA_CHECK(cudaMemcpyAsync(h_staging_[buf], src + at, std::min(kStagingBytes, bytes - at),
                                   cudaMemcpyDeviceToHost, stream_));
    CDT_CUDA_CHECK(cudaEventRecord(staged_[buf], stream_));
    if (k >= 1) drain(k - 1);
  }
  drain(blocks - 1);
  synchronize();
}

DeviceEvent::DeviceEvent() { CDT_CUDA_CHECK(cudaEventCreate(&event_)); }
DeviceEvent::~DeviceEvent() {
  if (event_ != nullptr) cudaEventDestroy(event_);
}
void DeviceEvent::record(cudaStream_t stream) { CDT_CUDA_CHECK(cudaEventRecord(event_, stream)); }
float DeviceEvent::since(const DeviceEvent& start) const {
  CDT_CUDA_CHECK(cudaEventSynchronize(event_));
  float ms = 0;
  CDT_CUDA_CHECK(cudaEventElapsedTime(&ms, start.event_, event_));
  return ms;
}

void CudaExecutor::synchronize() { CDT_CUDA_CHECK(cudaStreamSynchronize(stream_)); }

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
