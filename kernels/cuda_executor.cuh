#pragma once
// The CUDA executor of gCD: the data-parallel steps the algorithm is written in (for-each-index,
// prefix sum, stream compaction, sort, atomic minimum) on the calling thread's default CUDA stream
// (so threads run side by side, and device buffers are freed and reused in stream order), the same steps as
// the CPU executor (cdt/src/executor/cpu_executor.hpp) so that per-element work written once with CDT_HD runs
// on both. Scan, compaction and sorts are CUB's; for_each launches a grid-stride kernel over a functor
// or an extended lambda (nvcc --extended-lambda).
//
// Work is queued on the executor's stream and nothing waits for the device except the calls that
// return a value computed there (a scan's total, a compaction's count, download); with the debug
// switch (set_debug_sync, TRIXEL_CUDA_SYNC=1) every launch is followed by a synchronisation so that a
// fault is reported at the launch that caused it.

#include <cuda_runtime.h>

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>
#include <cub/device/device_select.cuh>
#include <thrust/iterator/counting_iterator.h>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "cdt_kernels.hpp"
#include "cuda_check.cuh"

namespace cdt::gpu::detail {

/// Lowers *address to value if value is smaller; returns the previous value (the CPU executor's
/// atomic_min on the device: the paper's atomic minimum marking).
__device__ __forceinline__ std::uint32_t atomic_min(std::uint32_t* address, std::uint32_t value) {
  return atomicMin(address, value);
}

template <class F>
__global__ void for_each_kernel(std::size_t n, F f) {
  const std::size_t stride = static_cast<std::size_t>(gridDim.x) * blockDim.x;
  for (std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x; i < n; i += stride)
    f(i);
}

/// for_each_kernel held to 64 registers a thread (four blocks of 256 threads on a multiprocessor), for
/// steps a little above that whose occupancy would otherwise drop to three blocks.
template <class F>
__global__ void __launch_bounds__(256, 4) for_each_kernel_64(std::size_t n, F f) {
  const std::size_t stride = static_cast<std::size_t>(gridDim.x) * blockDim.x;
  for (std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x; i < n; i += stride)
    f(i);
}

/// for_each_kernel over [0, count()), count() read on the device as the kernel starts: for a list
/// whose length an earlier step left in device memory, with no wait for the host to learn it.
template <class Count, class F>
__global__ void for_each_counted_kernel(Count count, F f) {
  const std::size_t n = count();
  const std::size_t stride = static_cast<std::size_t>(gridDim.x) * blockDim.x;
  for (std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x; i < n; i += stride)
    f(i);
}

/// keep(i) for the indices of a counting iterator: CUB sees a functor whose result type is declared,
/// never the lambda's own (which host code may not ask an extended device lambda for).
template <class Pred>
struct IndexPredicate {
  Pred keep;
  __device__ bool operator()(std::uint32_t i) const {
    return static_cast<bool>(keep(static_cast<std::size_t>(i)));
  }
};

/// Single-thread step of exclusive_scan: the last input before the scan, plus the last output after
/// it, is the total.
template <class T>
struct ScanTotal {
  const T* d_values;
  std::size_t n;
  T* d_total;
  bool add;
  __device__ void operator()(std::size_t) const {
    *d_total = add ? *d_total + d_values[n - 1] : d_values[n - 1];
  }
};

/// Bytes of device memory free and in total on the current device.
struct DeviceMemory {
  std::size_t free_bytes = 0;
  std::size_t total_bytes = 0;
};
DeviceMemory device_memory();

/// Throws DeviceError naming `what`, the bytes it needs and the bytes available when needed_bytes is
/// more than limit_bytes (0: the current device's free memory). Called before any allocation of a
/// step, so an input that cannot fit fails at once with a clear message rather than half way.
void require_device_memory(std::size_t needed_bytes, std::size_t limit_bytes, const std::string& what);

/// A CUDA event for timing work on a stream without waiting for it.
class DeviceEvent {
public:
  DeviceEvent();
  ~DeviceEvent();
  DeviceEvent(const DeviceEvent&) = delete;
  DeviceEvent& operator=(const DeviceEvent&) = delete;
  void record(cudaStream_t stream);
  /// Milliseconds from `start` to this event; waits for this event.
  float since(const DeviceEvent& start) const;

private:
  cudaEvent_t event_ = nullptr;
};

/// Sets len bytes of host memory at `to` to `byte`, spread over `parallel` when given; streamed
/// stores, for arrays the host does not read again soon.
void fill_host_bytes(void* to, unsigned char byte, std::size_t len, const HostParallelFor* parallel);

/// Device to host copies into pinned memory on a stream of their own, each after the work queued on
/// another stream before it (after_queued_work): a step's parts are copied while it makes the next
/// ones. wait() waits for them all and reports their errors; the destructor waits too, so that no
/// copy outlives the buffers it reads.
class PartCopies {
public:
  /// Throws DeviceError.
  explicit PartCopies(cudaStream_t after);
  ~PartCopies();
  PartCopies(const PartCopies&) = delete;
  PartCopies& operator=(const PartCopies&) = delete;
  /// The copies queued from now on start once the work queued on `after` so far is done.
  void after_queued_work();
  /// Queues a copy of `bytes` bytes from d_src on the device to h_dst (pinned).
  void copy(void* h_dst, const void* d_src, std::size_t bytes);
  void wait();

private:
  cudaStream_t after_;
  cudaStream_t stream_ = nullptr;
  std::vector<cudaEvent_t> events_;
};

/// Copies of device arrays to host memory made on a thread of their own, after the work queued so far
/// on the calling thread's stream: for results the host reads only much later, so that the device's
/// next steps and the host's part of the copies run side by side. Both sides of every copy must stay
/// allocated, and untouched by the host, until wait() returns or the object is destroyed.
class LateDownloads {
public:
  LateDownloads() = default;
  ~LateDownloads(); ///< waits for the copies; a failure is dropped (wait() reports it)
  LateDownloads(const LateDownloads&) = delete;
  LateDownloads& operator=(const LateDownloads&) = delete;

  /// Queues a copy of n elements, started by start().
  template <class T>
  void add(T* h_dst, const T* d_src, std::size_t n) {
    if (n > 0) copies_.push_back({h_dst, d_src, n * sizeof(T)});
  }
  /// Starts the queued copies, once the work queued so far on the calling thread's stream is done.
  void start();
  /// Waits for the copies; throws DeviceError should one have failed. Nothing to wait for: returns.
  void wait();

private:
  struct Copy {
    void* h_dst;
    const void* d_src;
    std::size_t bytes;
  };
  struct Worker;
  std::vector<Copy> copies_;
  Worker* worker_ = nullptr;
};

class CudaExecutor {
public:
  /// Uses the current device; throws DeviceError when there is none.
  CudaExecutor();
  ~CudaExecutor();
  CudaExecutor(const CudaExecutor&) = delete;
  CudaExecutor& operator=(const CudaExecutor&) = delete;

  cudaStream_t stream() const noexcept { return stream_; }

  /// Calls f(i) on the device for every i in [0, n). f must be a device-callable functor or an
  /// extended lambda (__device__ or __host__ __device__), safe to run concurrently for distinct i.
  template <class F>
  void for_each(std::size_t n, F f, const char* name = "for_each_kernel") {
    launch_for_each(for_each_kernel<F>, n, f, name);
  }

  /// for_each with at most 64 registers a thread (for_each_kernel_64).
  template <class F>
  void for_each_64(std::size_t n, F f, const char* name = "for_each_kernel_64") {
    launch_for_each(for_each_kernel_64<F>, n, f, name);
  }

  /// for_each over [0, count()), where count() is a device functor reading a length that queued work
  /// leaves in device memory; `bound`, at least that length, sizes the grid. Nothing waits.
  template <class Count, class F>
  void for_each_counted(std::size_t bound, Count count, F f, const char* name = "for_each_counted_kernel") {
    if (bound == 0) return;
    timed(name, [&] {
      for_each_counted_kernel<<<grid_for(bound), kBlock, 0, stream_>>>(count, f);
      check_launch(name, __FILE__, __LINE__);
    });
  }

  /// The same as for_each: the CPU executor runs a few large parts differently from many small
  /// elements, the device does not.
  template <class F>
  void for_each_part(std::size_t n, F f, const char* name = "for_each_part_kernel") {
    for_each(n, f, name);
  }

  /// Exclusive prefix sum of d_values[0, n) in place; returns the total (waits for it).
  template <class T>
  T exclusive_scan(T* d_values, std::size_t n) {
    if (n == 0) return T{};
    T* d_total = scalar<T>();
    for_each(1, ScanTotal<T>{d_values, n, d_total, false}, "scan_last_input");
    std::size_t bytes = 0;
    CDT_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(nullptr, bytes, d_values, d_values, n, stream_));
    CDT_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(temp(bytes), bytes, d_values, d_values, n, stream_));
    check_launch("cub::DeviceScan::ExclusiveSum", __FILE__, __LINE__);
    for_each(1, ScanTotal<T>{d_values, n, d_total, true}, "scan_total");
    T total{};
    download(&total, d_total, 1);
    return total;
  }

  /// Stream compaction: writes the indices i in [0, n) with keep(i) true to d_out in increasing order
  /// and returns how many (waits for the count). d_out needs room for all n; n < 2^32.
  template <class Pred>
  std::uint32_t compact(std::size_t n, Pred keep, std::uint32_t* d_out) {
    if (n == 0) return 0;
    if (n > std::numeric_limits<std::uint32_t>::max()) throw Error("compact: more than 2^32 - 1 items");
    const thrust::counting_iterator<std::uint32_t> first(0);
    auto* d_count = scalar<std::uint32_t>();
    const IndexPredicate<Pred> pred{keep};
    std::uint32_t count = 0;
    timed("compact", [&] {
      std::size_t bytes = 0;
      CDT_CUDA_CHECK(cub::DeviceSelect::If(nullptr, bytes, first, d_out, d_count, n, pred, stream_));
      CDT_CUDA_CHECK(cub::DeviceSelect::If(temp(bytes), bytes, first, d_out, d_count, n, pred, stream_));
      check_launch("cub::DeviceSelect::If", __FILE__, __LINE__);
      download(&count, d_count, 1);
    });
    return count;
  }

  /// compact() leaving the count in device memory (*d_count) instead of waiting for it: for the
  /// for_each_counted steps after it. d_count must not be the executor's scalar().
  template <class Pred>
  void compact_to(std::size_t n, Pred keep, std::uint32_t* d_out, std::uint32_t* d_count) {
    if (n == 0) return fill_bytes(d_count, 0, 1);
    if (n > std::numeric_limits<std::uint32_t>::max()) throw Error("compact: more than 2^32 - 1 items");
    const thrust::counting_iterator<std::uint32_t> first(0);
    const IndexPredicate<Pred> pred{keep};
    timed("compact", [&] {
      std::size_t bytes = 0;
      CDT_CUDA_CHECK(cub::DeviceSelect::If(nullptr, bytes, first, d_out, d_count, n, pred, stream_));
      CDT_CUDA_CHECK(cub::DeviceSelect::If(temp(bytes), bytes, first, d_out, d_count, n, pred, stream_));
      check_launch("cub::DeviceSelect::If", __FILE__, __LINE__);
    });
  }

  /// Sorts d_keys[0, n) ascending (radix sort on bits [0, end_bit)); unsigned integer keys.
  template <class K>
  void sort_keys(K* d_keys, std::size_t n, int end_bit = static_cast<int>(8 * sizeof(K))) {
    if (n < 2) return;
    cub::DoubleBuffer<K> keys(d_keys, reinterpret_cast<K*>(alternate(n * sizeof(K))));
    timed("sort_keys", [&] {
      std::size_t bytes = 0;
      CDT_CUDA_CHECK(cub::DeviceRadixSort::SortKeys(nullptr, bytes, keys, n, 0, end_bit, stream_));
      CDT_CUDA_CHECK(cub::DeviceRadixSort::SortKeys(temp(bytes), bytes, keys, n, 0, end_bit, stream_));
      check_launch("cub::DeviceRadixSort::SortKeys", __FILE__, __LINE__);
    });
    if (keys.Current() != d_keys)
      CDT_CUDA_CHECK(
          cudaMemcpyAsync(d_keys, keys.Current(), n * sizeof(K), cudaMemcpyDeviceToDevice, stream_));
  }

  /// Sorts d_keys[0, n) ascending and permutes d_values alongside (stable radix sort).
  template <class K, class V>
  void sort_pairs(K* d_keys, V* d_values, std::size_t n, int end_bit = static_cast<int>(8 * sizeof(K))) {
    if (n < 2) return;
    const std::size_t values_at = round_up(n * sizeof(K));
    unsigned char* d_alt = alternate(values_at + n * sizeof(V));
    cub::DoubleBuffer<K> keys(d_keys, reinterpret_cast<K*>(d_alt));
    cub::DoubleBuffer<V> values(d_values, reinterpret_cast<V*>(d_alt + values_at));
    timed("sort_pairs", [&] {
      std::size_t bytes = 0;
      CDT_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, bytes, keys, values, n, 0, end_bit, stream_));
      CDT_CUDA_CHECK(
          cub::DeviceRadixSort::SortPairs(temp(bytes), bytes, keys, values, n, 0, end_bit, stream_));
      check_launch("cub::DeviceRadixSort::SortPairs", __FILE__, __LINE__);
    });
    if (keys.Current() != d_keys)
      CDT_CUDA_CHECK(
          cudaMemcpyAsync(d_keys, keys.Current(), n * sizeof(K), cudaMemcpyDeviceToDevice, stream_));
    if (values.Current() != d_values)
      CDT_CUDA_CHECK(
          cudaMemcpyAsync(d_values, values.Current(), n * sizeof(V), cudaMemcpyDeviceToDevice, stream_));
  }

  /// Host to device copy of n elements, queued on the stream. The host data is read before the call
  /// returns; large arrays go through pinned staging blocks, so they move at the bus's speed instead
  /// of the driver's pageable-memory path; their host side (into the staging blocks) spreads over
  /// `parallel` when it is given.
  template <class T>
  void upload(T* d_dst, const T* h_src, std::size_t n, const HostParallelFor* parallel = nullptr) {
    copy_to_device(d_dst, h_src, n * sizeof(T), parallel);
  }

  /// Device to host copy of n elements; waits for it and for all work queued before it. Large copies
  /// spread their host side (out of the pinned staging blocks) over `parallel` when it is given; small
  /// ones (kReplyBytes) are written by a kernel, so d_src must be memory the device reads.
  template <class T>
  void download(T* h_dst, const T* d_src, std::size_t n, const HostParallelFor* parallel = nullptr) {
    // A count or a flag is part of the step that made it.
    if (n * sizeof(T) <= sizeof(unsigned long long))
      copy_to_host(h_dst, d_src, n * sizeof(T), parallel);
    else
      timed("download", [&] { copy_to_host(h_dst, d_src, n * sizeof(T), parallel); });
  }

  /// download() without a profile row: for a thread of its own beside the one profiled.
  template <class T>
  void download_unprofiled(T* h_dst, const T* d_src, std::size_t n,
                           const HostParallelFor* parallel = nullptr) {
    copy_to_host(h_dst, d_src, n * sizeof(T), parallel);
  }

  /// Sets n elements of d_dst to the byte value `byte` (0 or 0xFF fill 32-bit words with 0 or kNone).
  template <class T>
  void fill_bytes(T* d_dst, int byte, std::size_t n) {
    if (n == 0) return;
    CDT_CUDA_CHECK(cudaMemsetAsync(d_dst, byte, n * sizeof(T), stream_));
  }

  /// Waits for everything queued on the executor's stream; reports a fault of any of it.
  void synchronize();

  /// A device scratch word of type T (at most 8 bytes), for counts and flags; one per executor,
  /// reused by the next call that asks for one.
  template <class T>
  T* scalar() {
    static_assert(sizeof(T) <= sizeof(unsigned long long));
    return reinterpret_cast<T*>(scalar_.data());
  }

  /// Reusable temporary storage of at least `bytes` bytes (CUB's scratch). Growing it frees the old
  /// block, which cudaFree does only once the device is done with it.
  void* temp(std::size_t bytes) {
    if (bytes > temp_.size()) temp_.resize(bytes);
    return temp_.data();
  }

private:
  template <class F>
  void launch_for_each(void (*kernel)(std::size_t, F), std::size_t n, F f, const char* name) {
    if (n == 0) return;
    timed(name, [&] {
      kernel<<<grid_for(n), kBlock, 0, stream_>>>(n, f);
      check_launch(name, __FILE__, __LINE__);
    });
  }

  /// Threads of a block of the for-each kernels, and the blocks of a grid-stride launch over n
  /// elements (one element a thread, at most max_blocks_ blocks).
  static constexpr unsigned kBlock = 256;
  unsigned grid_for(std::size_t n) const {
    const std::size_t blocks = (n + kBlock - 1) / kBlock;
    return static_cast<unsigned>(blocks < max_blocks_ ? blocks : max_blocks_);
  }

  static constexpr std::size_t round_up(std::size_t bytes) { return (bytes + 255) / 256 * 256; }

  /// Runs launch(); when profiling, waits for the work before it and for it, and adds its time to the
  /// profile under `name`.
  template <class Launch>
  void timed(const char* name, Launch&& launch) {
    if (!profiling()) return launch();
    synchronize();
    const double start = host_milliseconds();
    launch();
    synchronize();
    add_to_profile(name, host_milliseconds() - start);
  }
  static double host_milliseconds();

  /// The sorts' second buffers: a reusable block of at least `bytes` bytes.
  unsigned char* alternate(std::size_t bytes) {
    if (bytes > alternate_.size()) alternate_.resize(bytes);
    return alternate_.data();
  }

  void copy_to_device(void* d_dst, const void* h_src, std::size_t bytes, const HostParallelFor* parallel);
  void copy_to_host(void* h_dst, const void* d_src, std::size_t bytes, const HostParallelFor* parallel);
  /// The first `blocks` pinned staging blocks (from the process's pool, at most kStagingBlocks) and
  /// their events, each taken on first use and kept.
  void make_staging(std::size_t blocks);

  static void check_launch(const char* name, const char* file, int line) {
    ::cdt::gpu::detail::check_launch(name, file, line);
  }

  cudaStream_t stream_ = nullptr;
  std::size_t max_blocks_ = 1;
  DeviceBuffer<unsigned char> temp_;
  DeviceBuffer<unsigned char> alternate_;
  DeviceBuffer<unsigned long long> scalar_;
  /// Four blocks of 16 MiB (64 MiB pinned per executor that copies more than a block): 10^7 triangles'
  /// output (720 MB) comes down in 27 ms instead of 37-48 with two blocks of 8 MiB.
  static constexpr int kStagingBlocks = 4;
  /// A pinned block of kReplyBytes that kernels write small results into (copy_to_host), taken on
  /// first use and given back to its pool when the executor goes.
  void* h_reply_ = nullptr;
  void* h_staging_[kStagingBlocks] = {}; ///< pinned host memory, kStagingBytes each; back to the pool
                                         ///< when the executor goes
  cudaEvent_t staged_[kStagingBlocks] = {};
};

} // namespace cdt::gpu::detail
