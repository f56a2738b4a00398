#pragma once
// The one choke point through which CUDA failures become exceptions, and the device buffer.

#include <cuda_runtime.h>

#include <cstddef>
#include <functional>
#include <future>
#include <string>
#include <utility>

#include "cdt/errors.hpp"

namespace cdt::gpu::detail {

[[noreturn]] void raise_cuda_error(cudaError_t status, const char* what, const char* file, int line);

/// True when launches should be followed by a synchronisation (debug switch).
bool debug_sync() noexcept;

/// True when the executor's steps are timed one by one (TRIXEL_CUDA_PROFILE=1): each waits for the
/// work before it and for itself, and its time goes to a table by name printed to stderr at exit. For
/// finding the costly kernels; the waiting makes the whole slower.
bool profiling() noexcept;
/// Adds `milliseconds` to the profile's row `name` (a string literal or other static string).
void add_to_profile(const char* name, double milliseconds);

inline void check(cudaError_t status, const char* what, const char* file, int line) {
  if (status != cudaSuccess) raise_cuda_error(status, what, file, line);
}

/// Checks the launch just made, and with the debug switch on waits for it to finish.
inline void check_launch(const char* kernel, const char* file, int line) {
  check(cudaGetLastError(), kernel, file, line);
  if (debug_sync()) check(cudaDeviceSynchronize(), kernel, file, line);
}

/// Throws DeviceError when the device has less than `bytes` free (memory the buffer pool keeps counts as
/// free: it is given back first).
void check_free_memory(std::size_t bytes);
inline constexpr std::size_t kCheckFreeAbove = std::size_t{64} << 20;

/// The stream the calling thread queues its work on: its default stream (cudaStreamPerThread), unless a
/// PriorityStream gave it another. Executors made on the thread use it, and buffers are allocated and
/// freed in its order.
cudaStream_t thread_stream() noexcept;

/// Gives the calling thread a stream of its own of the highest priority while it lives, for work that
/// shares the device with other threads' and should go first (the constraints beside the screen). Made
/// before any executor or buffer of the thread and destroyed after them; the stream is synchronised and
/// destroyed at the end, and the thread's default stream is its stream again. Throws DeviceError.
class PriorityStream {
public:
  PriorityStream();
  ~PriorityStream();
  PriorityStream(const PriorityStream&) = delete;
  PriorityStream& operator=(const PriorityStream&) = delete;

private:
  cudaStream_t stream_ = nullptr;
};

/// Runs `task` on one of the library's side threads, beside the calling thread, and returns what says
/// when it has ended (its exceptions too, though the tasks keep their own). The side threads are kept
/// for the process's life and reused: a thread that used CUDA tears down its state in the driver when it
/// ends (its default stream among it), and that teardown, racing the driver's own threads, now and then
/// never returned (3 of 162 processes that triangulated 10^7 points and 10^6 segments 3-5 times, on the
/// H200 machine: the caller waited in the join forever; none of 289 since). Throws std::system_error
/// when no thread can be had.
std::future<void> run_beside(std::function<void()> task);

/// Device memory of `bytes` bytes for a buffer: from this library's stream-ordered pool on the calling
/// thread's stream (thread_stream; pooled = true), or with the debug switch on a plain cudaMalloc block. A
/// pooled block must be released by the thread that allocated it (the executors queue all their work
/// on that thread's stream, so the release is ordered after every use). Returns the failing status
/// with *d_ptr null.
cudaError_t device_allocate(void** d_ptr, std::size_t bytes, bool& pooled);
/// Gives a block of device_allocate back: to the pool in stream order (kept there for reuse), or
/// cudaFree.
void device_release(void* d_ptr, bool pooled) noexcept;

/// Copies up to this size go straight from pageable memory; larger ones are split into blocks of
/// this size and staged through pinned blocks, the host's memcpy of one block overlapping the bus
/// transfers of the others.
inline constexpr std::size_t kStagingBytes = std::size_t{16} << 20;
/// A pinned host block of kStagingBytes from the process's pool of them (kept and handed from one
/// user to the next; reserve_memory fills the pool, release_device empties it). Throws DeviceError.
void* take_staging_block();
/// A block of the pool when one is free, else null (pins nothing).
void* try_take_staging_block() noexcept;
/// Gives a block of take_staging_block or try_take_staging_block back to the pool.
void return_staging_block(void* block) noexcept;

/// Results of at most this many bytes come back written by a kernel into pinned memory (a reply
/// block) rather than by a copy: a copy would queue on the copy engine behind the large transfers of
/// other streams (the output started early); the kernel's writes only share the bus with them. Their
/// source must be memory the device reads (device, pinned or managed memory).
inline constexpr std::size_t kReplyBytes = 256;
/// A pinned host block of kReplyBytes from the process's pool of them (emptied by release_device), which
/// kernels write directly (unified addressing). Throws DeviceError.
void* take_reply_block();
/// Gives a block of take_reply_block back to the pool.
void return_reply_block(void* block) noexcept;

/// A free staging block held for one call (try_take_staging_block), or none when `wanted` is false or
/// every block is in use: nothing is pinned on the way, which would stall the other threads' device
/// work.
class HeldStagingBlock {
public:
  explicit HeldStagingBlock(bool wanted)
      : block_(wanted ? static_cast<unsigned char*>(try_take_staging_block()) : nullptr) {}
  HeldStagingBlock(const HeldStagingBlock&) = delete;
  HeldStagingBlock& operator=(const HeldStagingBlock&) = delete;
  ~HeldStagingBlock() {
    if (block_ != nullptr) return_staging_block(block_);
  }
  unsigned char* get() const { return block_; }

private:
  unsigned char* block_;
};

/// A device buffer owned by RAII; device memory from device_allocate, never managed memory.
/// resize() keeps the allocation when it is large enough, so one buffer serves several phases; the
/// contents are not kept when it grows.
template <class T>
class DeviceBuffer {
public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(std::size_t count) { resize(count); }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& other) noexcept
      : d_ptr_(std::exchange(other.d_ptr_, nullptr)), num_(std::exchange(other.num_, 0)),
        capacity_(std::exchange(other.capacity_, 0)), pooled_(other.pooled_) {}
  DeviceBuffer& operator=(DeviceBuffer&& other) noexcept {
    if (this != &other) {
      release();
      d_ptr_ = std::exchange(other.d_ptr_, nullptr);
      num_ = std::exchange(other.num_, 0);
      capacity_ = std::exchange(other.capacity_, 0);
      pooled_ = other.pooled_;
    }
    return *this;
  }
  ~DeviceBuffer() { release(); }

  void resize(std::size_t count) {
    if (count <= capacity_) {
      num_ = count;
      return;
    }
    release();
    // A large request is checked against the free memory first: a clear message, and no failing API
    // call for compute-sanitizer to report.
    if (count * sizeof(T) >= kCheckFreeAbove) check_free_memory(count * sizeof(T));
    void* d_new = nullptr;
    const cudaError_t status = device_allocate(&d_new, count * sizeof(T), pooled_);
    if (status != cudaSuccess) {
      cudaGetLastError(); // an allocation failure is not sticky; leave no error behind for the next check
      raise_cuda_error(status, ("cudaMalloc of " + std::to_string(count * sizeof(T)) + " bytes").c_str(),
                       __FILE__, __LINE__);
    }
    d_ptr_ = static_cast<T*>(d_new);
    capacity_ = count;
    num_ = count;
  }
  T* data() noexcept { return d_ptr_; }
  const T* data() const noexcept { return d_ptr_; }
  std::size_t size() const noexcept { return num_; }
  std::size_t capacity() const noexcept { return capacity_; }

private:
  void release() noexcept {
    // A failing cudaFree (a sticky error from an earlier fault) was already reported where it arose.
    if (d_ptr_ != nullptr) device_release(d_ptr_, pooled_);
    d_ptr_ = nullptr;
    num_ = 0;
    capacity_ = 0;
  }

  T* d_ptr_ = nullptr;
  std::size_t num_ = 0;
  std::size_t capacity_ = 0;
  bool pooled_ = false; ///< d_ptr_ came from the pool (else cudaMalloc)
};

} // namespace cdt::gpu::detail

#define CDT_CUDA_CHECK(call) ::cdt::gpu::detail::check((call), #call, __FILE__, __LINE__)
#define CDT_CUDA_CHECK_LAUNCH(name) ::cdt::gpu::detail::check_launch(name, __FILE__, __LINE__)
