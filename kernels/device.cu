// Device discovery and the error choke point of the CUDA executor.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <exception>
#include <functional>
#include <future>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#if defined(__x86_64__)
#include <emmintrin.h>
#endif
#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"

namespace cdt::gpu {
namespace {
std::atomic<bool> g_debug_sync{false};

/// The profile of TRIXEL_CUDA_PROFILE=1: milliseconds and calls by step name, printed at exit.
class Profile {
public:
  void add(const char* name, double milliseconds) {
    std::lock_guard lock(mutex_);
    Row& row = rows_[name];
    row.milliseconds += milliseconds;
    ++row.calls;
  }
  ~Profile() { print("at exit"); }
  // Prints the table and clears it.
  void print(const char* heading) {
    std::lock_guard lock(mutex_);
    if (rows_.empty()) return;
    std::vector<std::pair<std::string, Row>> rows(rows_.begin(), rows_.end());
    rows_.clear();
    std::sort(rows.begin(), rows.end(),
              [](const auto& a, const auto& b) { return a.second.milliseconds > b.second.milliseconds; });
    double total = 0;
    for (const auto& [name, row] : rows) total += row.milliseconds;
    std::fprintf(stderr, "device profile, %s (each step waited for): %.1f ms in all\n", heading, total);
    for (const auto& [name, row] : rows)
      std::fprintf(stderr, "  %-32s %10.2f ms %8llu calls\n", name.c_str(), row.milliseconds,
                   static_cast<unsigned long long>(row.calls));
  }

private:
  struct Row {
    double milliseconds = 0;
    std::uint64_t calls = 0;
  };
  std::mutex mutex_;
  std::map<std::string, Row> rows_;
};

Profile& profile() {
  static Profile table;
  return table;
}
} // namespace

namespace detail {

bool profiling() noexcept {
  static const bool from_env = [] {
    const char* v = std::getenv("TRIXEL_CUDA_PROFILE");
    return v != nullptr && std::strcmp(v, "0") != 0 && v[0] != '\0';
  }();
  return from_env;
}

void add_to_profile(const char* name, double milliseconds) { profile().add(name, milliseconds); }

double CudaExecutor::host_milliseconds() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

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

/// The calling thread's stream (thread_stream).
thread_local cudaStream_t t_thread_stream = cudaStreamPerThread;

/// Every device's buffer pool (buffer_pool), reachable for release_device.
struct BufferPools {
  std::mutex mutex;
  std::map<int, cudaMemPool_t> pools;
};

BufferPools& buffer_pools() {
  static auto* pools = new BufferPools; // never destroyed: buffers may be freed at exit
  return *pools;
}

/// The memory pool of device buffers on each device: stream-ordered (cudaMallocFromPoolAsync and
/// cudaFreeAsync on the calling thread's stream), and with no release threshold, so memory a
/// buffer frees stays in the pool for the next one instead of going back to the driver. cudaMalloc and
/// cudaFree of hundreds of megabytes cost milliseconds each, and cudaFree waits for the whole device,
/// which stalls every other thread's work on it; every triangulation frees and allocates the same sizes
/// phase after phase and call after call.
cudaMemPool_t buffer_pool(int device) {
  BufferPools& all = buffer_pools();
  std::lock_guard lock(all.mutex);
  auto& pools = all.pools;
  if (const auto it = pools.find(device); it != pools.end()) return it->second;
  cudaMemPoolProps props{};
  props.allocType = cudaMemAllocationTypePinned;
  props.location.type = cudaMemLocationTypeDevice;
  props.location.id = device;
  cudaMemPool_t pool = nullptr;
  CDT_CUDA_CHECK(cudaMemPoolCreate(&pool, &props));
  std::uint64_t keep_all = std::numeric_limits<std::uint64_t>::max();
  CDT_CUDA_CHECK(cudaMemPoolSetAttribute(pool, cudaMemPoolAttrReleaseThreshold, &keep_all));
  pools.emplace(device, pool);
  return pool;
}

/// Gives the memory the pool of the current device keeps unused back to the driver (after the calling
/// thread's queued frees are done).
void trim_buffer_pool() noexcept {
  int device = 0;
  if (cudaGetDevice(&device) != cudaSuccess) return;
  try {
    const cudaMemPool_t pool = buffer_pool(device);
    cudaStreamSynchronize(t_thread_stream);
    cudaMemPoolTrimTo(pool, 0);
  } catch (const DeviceError&) {
    // No pool: nothing to give back.
  }
}

/// A task of run_beside and what tells its caller that it has ended.
struct SideJob {
  std::function<void()> run;
  std::promise<void> ended;
};

/// The side threads of run_beside and their queue; never destroyed (idle ones wait on it at exit).
struct SideThreads {
  std::mutex mutex;
  std::condition_variable queued;
  std::deque<SideJob> queue;
  std::size_t idle = 0; ///< threads waiting for a task, or about to report one's end
};

SideThreads& side_threads() {
  static auto* threads = new SideThreads;
  return *threads;
}

void side_thread_loop(SideThreads& s) {
  std::unique_lock lock(s.mutex);
  ++s.idle;
  for (;;) {
    s.queued.wait(lock, [&] { return !s.queue.empty(); });
    --s.idle;
    SideJob task = std::move(s.queue.front());
    s.queue.pop_front();
    lock.unlock();
    std::exception_ptr failure;
    try {
      task.run();
    } catch (...) {
      failure = std::current_exception();
    }
    task.run = nullptr; // its captures go before the caller hears of the end
    // Idle again before the caller hears of the end: a task it gives next takes this thread.
    lock.lock();
    ++s.idle;
    lock.unlock();
    if (failure)
      task.ended.set_exception(failure);
    else
      task.ended.set_value();
    lock.lock();
  }
}

} // namespace

std::future<void> run_beside(std::function<void()> task) {
  SideThreads& s = side_threads();
  SideJob job{std::move(task), {}};
  std::future<void> ended = job.ended.get_future();
  {
    std::lock_guard lock(s.mutex);
    // A new thread when every idle one has a task waiting for it already (it throws before anything
    // is queued).
    if (s.idle <= s.queue.size()) std::thread(side_thread_loop, std::ref(s)).detach();
    s.queue.push_back(std::move(job));
  }
  s.queued.notify_one();
  return ended;
}

cudaStream_t thread_stream() noexcept { return t_thread_stream; }

PriorityStream::PriorityStream() {
  if (t_thread_stream != cudaStreamPerThread)
    throw Error("internal error: PriorityStream: the thread has a stream of its own already");
  int least = 0, greatest = 0;
  CDT_CUDA_CHECK(cudaDeviceGetStreamPriorityRange(&least, &greatest));
  CDT_CUDA_CHECK(cudaStreamCreateWithPriority(&stream_, cudaStreamNonBlocking, greatest));
  t_thread_stream = stream_;
}

PriorityStream::~PriorityStream() {
  // Errors were reported by the work that caused them; the buffers freed on the stream go back to the
  // pool once it is done, which destroying it does not cut short.
  cudaStreamSynchronize(stream_);
  t_thread_stream = cudaStreamPerThread;
  cudaStreamDestroy(stream_);
}

cudaError_t device_allocate(void** d_ptr, std::size_t bytes, bool& pooled) {
  *d_ptr = nullptr;
  pooled = false;
  // With the debug switch buffers are plain cudaMalloc blocks, freed at once, so that compute-sanitizer
  // sees any use of a released buffer.
  if (debug_sync()) return cudaMalloc(d_ptr, bytes);
  int device = 0;
  if (const cudaError_t status = cudaGetDevice(&device); status != cudaSuccess) return status;
  const cudaMemPool_t pool = buffer_pool(device);
  cudaError_t status = cudaMallocFromPoolAsync(d_ptr, bytes, pool, t_thread_stream);
  if (status == cudaErrorMemoryAllocation) {
    cudaGetLastError();
    trim_buffer_pool();
    status = cudaMallocFromPoolAsync(d_ptr, bytes, pool, t_thread_stream);
  }
  if (status != cudaSuccess) {
    *d_ptr = nullptr;
    return status;
  }
  pooled = true;
  return cudaSuccess;
}

void device_release(void* d_ptr, bool pooled) noexcept {
  if (d_ptr == nullptr) return;
  if (pooled)
    cudaFreeAsync(d_ptr, t_thread_stream);
  else
    cudaFree(d_ptr);
}

void check_free_memory(std::size_t bytes) {
  std::size_t free_bytes = 0, total_bytes = 0;
  CDT_CUDA_CHECK(cudaMemGetInfo(&free_bytes, &total_bytes));
  if (bytes > free_bytes) {
    trim_buffer_pool();
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
    trim_buffer_pool(); // what the pool keeps for reuse is this process's to give back
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
  // The calling thread's stream (its default stream, unless a PriorityStream gave it one): every
  // executor of a thread queues in one order, which is what lets device buffers be freed and reused in
  // stream order (see device_allocate), and threads still run side by side.
  stream_ = thread_stream();
  scalar_.resize(1);
}

namespace {
constexpr std::size_t kCopyPartBytes = std::size_t{512} << 10; ///< a host thread's share of a block
/// Downloads from this size up go through the staging blocks when host threads are given (smaller
/// ones, as an image's PSLG makes, take the driver's path and leave the other blocks unpinned).
constexpr std::size_t kHelpedDownloadBytes = std::size_t{4} << 20;

/// memcpy with non-temporal stores where the processor has them (x86-64: SSE2's streaming stores). The
/// copies in and out of the staging blocks write data no host thread reads again soon: streamed, the
/// stores do not read their lines into the cache first, a third less memory traffic for a copy.
void stream_copy(unsigned char* to, const unsigned char* from, std::size_t len) {
#if defined(__x86_64__)
  const std::size_t head = std::min(len, (16 - (reinterpret_cast<std::uintptr_t>(to) & 15)) & 15);
  std::memcpy(to, from, head);
  to += head;
  from += head;
  len -= head;
  const std::size_t body = len & ~std::size_t{63};
  for (std::size_t i = 0; i < body; i += 64) {
    const __m128i a = _mm_loadu_si128(reinterpret_cast<const __m128i*>(from + i));
    const __m128i b = _mm_loadu_si128(reinterpret_cast<const __m128i*>(from + i + 16));
    const __m128i c = _mm_loadu_si128(reinterpret_cast<const __m128i*>(from + i + 32));
    const __m128i d = _mm_loadu_si128(reinterpret_cast<const __m128i*>(from + i + 48));
    _mm_stream_si128(reinterpret_cast<__m128i*>(to + i), a);
    _mm_stream_si128(reinterpret_cast<__m128i*>(to + i + 16), b);
    _mm_stream_si128(reinterpret_cast<__m128i*>(to + i + 32), c);
    _mm_stream_si128(reinterpret_cast<__m128i*>(to + i + 48), d);
  }
  std::memcpy(to + body, from + body, len - body);
  _mm_sfence(); // the streamed stores are seen before the copy is reported done
#else
  std::memcpy(to, from, len);
#endif
}

/// Calls work(offset, bytes) over len bytes: in parts of kCopyPartBytes over `parallel` when given,
/// else at once.
template <class Work>
void in_copy_parts(std::size_t len, const HostParallelFor* parallel, Work&& work) {
  if (parallel == nullptr || !*parallel) {
    work(std::size_t{0}, len);
    return;
  }
  const std::size_t parts = (len + kCopyPartBytes - 1) / kCopyPartBytes;
  (*parallel)(parts, [&](std::size_t p) {
    const std::size_t offset = p * kCopyPartBytes;
    work(offset, std::min(kCopyPartBytes, len - offset));
  });
}

/// stream_copy of len bytes, in parts of kCopyPartBytes over `parallel` when given.
void copy_parts(void* to, const void* from, std::size_t len, const HostParallelFor* parallel) {
  in_copy_parts(len, parallel, [&](std::size_t offset, std::size_t bytes) {
    stream_copy(static_cast<unsigned char*>(to) + offset, static_cast<const unsigned char*>(from) + offset,
                bytes);
  });
}

/// memset with streamed stores (an array the host reads only much later, as stream_copy's).
void stream_fill(unsigned char* to, unsigned char byte, std::size_t len) {
#if defined(__x86_64__)
  const std::size_t head = std::min(len, (16 - (reinterpret_cast<std::uintptr_t>(to) & 15)) & 15);
  std::memset(to, byte, head);
  to += head;
  len -= head;
  const std::size_t body = len & ~std::size_t{63};
  const __m128i v = _mm_set1_epi8(static_cast<char>(byte));
  for (std::size_t i = 0; i < body; i += 64) {
    _mm_stream_si128(reinterpret_cast<__m128i*>(to + i), v);
    _mm_stream_si128(reinterpret_cast<__m128i*>(to + i + 16), v);
    _mm_stream_si128(reinterpret_cast<__m128i*>(to + i + 32), v);
    _mm_stream_si128(reinterpret_cast<__m128i*>(to + i + 48), v);
  }
  std::memset(to + body, byte, len - body);
  _mm_sfence();
#else
  std::memset(to, byte, len);
#endif
}

/// Pinned blocks of one size that no executor holds (staging blocks, reply blocks). Pinning host memory
/// costs milliseconds a call, and a triangulation's executors each use such blocks: they are kept for
/// the process's lifetime (the driver frees them at exit, release_device before) and handed from one
/// executor to the next.
struct StagingBlocks {
  std::mutex mutex;
  std::vector<void*> free;

  /// A free block, or none (null).
  void* try_take() noexcept {
    const std::lock_guard<std::mutex> lock(mutex);
    if (free.empty()) return nullptr;
    void* block = free.back();
    free.pop_back();
    return block;
  }
  /// A free block, or one of `bytes` pinned now. Throws DeviceError.
  void* take(std::size_t bytes) {
    if (void* block = try_take()) return block;
    void* block = nullptr;
    CDT_CUDA_CHECK(cudaMallocHost(&block, bytes));
    return block;
  }
  void give_back(void* block) noexcept {
    const std::lock_guard<std::mutex> lock(mutex);
    try {
      free.push_back(block);
    } catch (...) {
      cudaFreeHost(block);
    }
  }
  /// Unpins and frees the free blocks.
  void free_all() noexcept {
    const std::lock_guard<std::mutex> lock(mutex);
    for (void* block : free) cudaFreeHost(block);
    free.clear();
  }
};

StagingBlocks& staging_blocks() {
  static auto* blocks = new StagingBlocks; // never destroyed: executors may outlive static destructors
  return *blocks;
}

/// Reply blocks no executor holds (take_reply_block), kept like the staging blocks.
StagingBlocks& reply_blocks() {
  static auto* blocks = new StagingBlocks;
  return *blocks;
}

/// Copies `bytes` bytes from device memory to pinned host memory, written by the kernel itself.
__global__ void reply_kernel(const unsigned char* from, unsigned char* to, std::size_t bytes) {
  for (std::size_t i = threadIdx.x; i < bytes; i += blockDim.x) to[i] = from[i];
}
} // namespace

void fill_host_bytes(void* to, unsigned char byte, std::size_t len, const HostParallelFor* parallel) {
  in_copy_parts(len, parallel, [&](std::size_t offset, std::size_t bytes) {
    stream_fill(static_cast<unsigned char*>(to) + offset, byte, bytes);
  });
}

void* take_staging_block() { return staging_blocks().take(kStagingBytes); }

void* take_reply_block() { return reply_blocks().take(kReplyBytes); }

void return_reply_block(void* block) noexcept { reply_blocks().give_back(block); }

void* try_take_staging_block() noexcept { return staging_blocks().try_take(); }

void return_staging_block(void* block) noexcept { staging_blocks().give_back(block); }

namespace {
/// A block of the pinned result memory (keep_pinned_results).
struct ResultBlock {
  void* ptr = nullptr;
  std::size_t bytes = 0;
  bool in_use = false;
  bool pinned = true; ///< false once release_device unpinned it: freed when given back
};

struct ResultBlocks {
  std::mutex mutex;
  std::size_t limit = 0; ///< bytes
  std::size_t total = 0; ///< bytes of the pinned blocks, and of one being pinned
  std::vector<ResultBlock> blocks;
  std::atomic<bool> any{false}; ///< whether a block was ever made: most frees need no lock then
};

ResultBlocks& result_blocks() {
  static auto* blocks = new ResultBlocks; // never destroyed: result arrays may be freed at exit
  return *blocks;
}

/// Blocks are whole huge pages: the pinning's first touch faults 2 MiB at a time where the kernel lets it.
constexpr std::size_t kResultBlockAlign = std::size_t{2} << 20;

void free_result_block(const ResultBlock& b) noexcept {
  if (b.pinned) cudaHostUnregister(b.ptr);
  cudaGetLastError(); // nothing here is a caller's error
  std::free(b.ptr);
}

/// Takes the free blocks out of `all` while its total is above `room` (all of them when room is 0),
/// largest first, into `out`. Called with the lock held.
void drop_free_blocks(ResultBlocks& all, std::size_t room, std::vector<ResultBlock>& out) {
  while (all.total > room) {
    auto largest = all.blocks.end();
    for (auto it = all.blocks.begin(); it != all.blocks.end(); ++it)
      if (!it->in_use && it->pinned && (largest == all.blocks.end() || it->bytes > largest->bytes))
        largest = it;
    if (largest == all.blocks.end()) return; // the rest are in use
    all.total -= largest->bytes;
    out.push_back(*largest);
    all.blocks.erase(largest);
  }
}

/// Unpins every block before the devices' contexts go: free ones are freed, those in use freed when
/// given back.
void unpin_result_blocks() noexcept {
  ResultBlocks& all = result_blocks();
  const std::lock_guard<std::mutex> lock(all.mutex);
  for (auto it = all.blocks.begin(); it != all.blocks.end();) {
    if (it->pinned) {
      cudaHostUnregister(it->ptr);
      cudaGetLastError();
      it->pinned = false;
      all.total -= it->bytes;
    }
    if (!it->in_use) {
      std::free(it->ptr);
      it = all.blocks.erase(it);
    } else {
      ++it;
    }
  }
}
} // namespace

} // namespace detail

bool in_result_block(const void* p, std::size_t bytes) noexcept {
  detail::ResultBlocks& all = detail::result_blocks();
  if (!all.any.load(std::memory_order_acquire)) return false;
  const std::lock_guard<std::mutex> lock(all.mutex);
  const auto at = reinterpret_cast<std::uintptr_t>(p);
  for (const detail::ResultBlock& b : all.blocks) {
    const auto begin = reinterpret_cast<std::uintptr_t>(b.ptr);
    if (b.in_use && b.pinned && at >= begin && at - begin <= b.bytes && bytes <= b.bytes - (at - begin))
      return true;
  }
  return false;
}

void set_result_blocks_limit(std::size_t bytes) noexcept {
  detail::ResultBlocks& all = detail::result_blocks();
  std::vector<detail::ResultBlock> dropped;
  {
    const std::lock_guard<std::mutex> lock(all.mutex);
    all.limit = bytes;
    try {
      dropped.reserve(all.blocks.size());
    } catch (...) {
      return; // the limit holds from the next block on
    }
    detail::drop_free_blocks(all, bytes, dropped);
  }
  for (const detail::ResultBlock& b : dropped) detail::free_result_block(b);
}

void* take_result_block(std::size_t bytes) noexcept {
  using detail::kResultBlockAlign;
  detail::ResultBlocks& all = detail::result_blocks();
  if (bytes == 0 || bytes > SIZE_MAX - kResultBlockAlign) return nullptr;
  const std::size_t size = (bytes + kResultBlockAlign - 1) / kResultBlockAlign * kResultBlockAlign;
  std::vector<detail::ResultBlock> dropped;
  {
    const std::lock_guard<std::mutex> lock(all.mutex);
    if (size > all.limit) return nullptr;
    detail::ResultBlock* best = nullptr;
    for (detail::ResultBlock& b : all.blocks) {
      if (!b.in_use && b.pinned && b.bytes >= size && b.bytes / 2 <= size &&
          (best == nullptr || b.bytes < best->bytes))
        best = &b;
    }
    if (best != nullptr) {
      best->in_use = true;
      return best->ptr;
    }
    // The blocks in use, and those another thread is pinning, leave no room: nothing is dropped.
    std::size_t free_bytes = 0;
    for (const detail::ResultBlock& b : all.blocks)
      if (!b.in_use && b.pinned) free_bytes += b.bytes;
    if (all.total - free_bytes > all.limit - size) return nullptr;
    try {
      dropped.reserve(all.blocks.size());
    } catch (...) {
      return nullptr;
    }
    detail::drop_free_blocks(all, all.limit - size, dropped);
    all.total += size; // the new block's share, held while it is pinned
  }
  for (const detail::ResultBlock& b : dropped) detail::free_result_block(b);
  void* p = std::aligned_alloc(kResultBlockAlign, size);
#if defined(MADV_HUGEPAGE)
  if (p != nullptr) madvise(p, size, MADV_HUGEPAGE);
#endif
  if (p != nullptr && cudaHostRegister(p, size, cudaHostRegisterPortable) == cudaSuccess) {
    const std::lock_guard<std::mutex> lock(all.mutex);
    try {
      all.blocks.push_back(detail::ResultBlock{p, size, true, true});
      all.any.store(true, std::memory_order_release);
      return p;
    } catch (...) {
      cudaHostUnregister(p);
    }
  }
  cudaGetLastError(); // a failed pinning leaves the array to the C++ allocator
  std::free(p);
  const std::lock_guard<std::mutex> lock(all.mutex);
  all.total -= size;
  return nullptr;
}

bool give_back_result_block(void* p) noexcept {
  detail::ResultBlocks& all = detail::result_blocks();
  if (!all.any.load(std::memory_order_acquire)) return false;
  detail::ResultBlock gone;
  {
    const std::lock_guard<std::mutex> lock(all.mutex);
    const auto it = std::find_if(all.blocks.begin(), all.blocks.end(),
                                 [&](const detail::ResultBlock& b) { return b.ptr == p; });
    if (it == all.blocks.end()) return false;
    if (it->pinned && all.total <= all.limit) {
      it->in_use = false;
      return true;
    }
    // Unpinned by release_device, or beyond a lowered limit.
    if (it->pinned) all.total -= it->bytes;
    gone = *it;
    all.blocks.erase(it);
  }
  detail::free_result_block(gone);
  return true;
}

namespace detail {

CudaExecutor::~CudaExecutor() {
  // Buffers are freed by their own destructors, in stream order; errors here were reported by the call
  // that caused them. The stream is the thread's own and stays.
  cudaStreamSynchronize(stream_);
  if (h_reply_ != nullptr) return_reply_block(h_reply_);
  for (int k = 0; k < kStagingBlocks; ++k) {
    if (h_staging_[k] != nullptr) return_staging_block(h_staging_[k]);
    if (staged_[k] != nullptr) cudaEventDestroy(staged_[k]);
  }
}

void CudaExecutor::make_staging(std::size_t blocks) {
  // A copy of a few megabytes (an image's PSLG) needs one block; pinning the others would cost a
  // triangulation of it more than its copies take.
  const auto needed = static_cast<int>(std::min<std::size_t>(kStagingBlocks, blocks));
  for (int k = 0; k < needed; ++k) {
    if (h_staging_[k] == nullptr) h_staging_[k] = take_staging_block();
    if (staged_[k] == nullptr) CDT_CUDA_CHECK(cudaEventCreateWithFlags(&staged_[k], cudaEventDisableTiming));
  }
}

void CudaExecutor::copy_to_device(void* d_dst, const void* h_src, std::size_t bytes,
                                  const HostParallelFor* parallel) {
  if (bytes == 0) return;
  // From pageable memory the driver stages the copy itself, on this thread; with host threads to spread
  // the staging over, copies of a few parts or more go through the pinned blocks (the pieces of 10^6
  // segments are 12 MB).
  const bool helped = parallel != nullptr && *parallel && bytes >= 2 * kCopyPartBytes;
  if (bytes <= kStagingBytes && !helped) {
    CDT_CUDA_CHECK(cudaMemcpyAsync(d_dst, h_src, bytes, cudaMemcpyHostToDevice, stream_));
    return;
  }
  make_staging((bytes + kStagingBytes - 1) / kStagingBytes);
  auto* dst = static_cast<unsigned char*>(d_dst);
  const auto* src = static_cast<const unsigned char*>(h_src);
  for (std::size_t at = 0, k = 0; at < bytes; at += kStagingBytes, ++k) {
    const std::size_t len = std::min(kStagingBytes, bytes - at);
    const int buf = static_cast<int>(k % kStagingBlocks);
    // The block's last transfer (kStagingBlocks blocks back, or of an earlier upload) must be done
    // before it is refilled; an event never recorded counts as done.
    CDT_CUDA_CHECK(cudaEventSynchronize(staged_[buf]));
    copy_parts(h_staging_[buf], src + at, len, parallel);
    CDT_CUDA_CHECK(cudaMemcpyAsync(dst + at, h_staging_[buf], len, cudaMemcpyHostToDevice, stream_));
    CDT_CUDA_CHECK(cudaEventRecord(staged_[buf], stream_));
  }
}

void CudaExecutor::copy_to_host(void* h_dst, const void* d_src, std::size_t bytes,
                                const HostParallelFor* parallel) {
  // Into pageable memory the driver stages the copy itself, on this thread, at a few GB/s (the
  // preparation's step with the pieces of 10^6 segments, 12 MB, took 2.5-7.6 ms that way, 1.7-2.4
  // staged, on the H200 machine's hosts); with host threads to spread the staging over, copies of
  // kHelpedDownloadBytes or more go through the pinned blocks, in steps of a quarter of the copy or
  // less (whole parts, at most a block) so that the bus and the host's copies overlap.
  if (bytes == 0) return synchronize();
  if (bytes <= kReplyBytes) {
    // A count or a flag, which the host waits for: written by a kernel, it does not queue behind the
    // copies of other streams (the output's rows sent while the constraints run).
    if (h_reply_ == nullptr) h_reply_ = take_reply_block();
    reply_kernel<<<1, 64, 0, stream_>>>(static_cast<const unsigned char*>(d_src),
                                        static_cast<unsigned char*>(h_reply_), bytes);
    check_launch("reply_kernel", __FILE__, __LINE__);
    synchronize();
    std::memcpy(h_dst, h_reply_, bytes);
    return;
  }
  const bool helped = parallel != nullptr && *parallel && bytes >= kHelpedDownloadBytes;
  // Into the pinned result memory (keep_pinned_results) the device writes at the bus's speed itself.
  if ((bytes <= kStagingBytes && !helped) ||
      (bytes >= kHelpedDownloadBytes && in_result_block(h_dst, bytes))) {
    if (bytes != 0) CDT_CUDA_CHECK(cudaMemcpyAsync(h_dst, d_src, bytes, cudaMemcpyDeviceToHost, stream_));
    synchronize();
    return;
  }
  const std::size_t quarter_in_parts = (bytes / kStagingBlocks + kCopyPartBytes - 1) / kCopyPartBytes;
  const std::size_t step = std::clamp(quarter_in_parts * kCopyPartBytes, kCopyPartBytes, kStagingBytes);
  const std::size_t blocks = (bytes + step - 1) / step;
  make_staging(blocks);
  auto* dst = static_cast<unsigned char*>(h_dst);
  const auto* src = static_cast<const unsigned char*>(d_src);
  const auto drain = [&](std::size_t k) { // waits for block k and copies it out of its staging block
    const int buf = static_cast<int>(k % kStagingBlocks);
    const std::size_t at = k * step;
    CDT_CUDA_CHECK(cudaEventSynchronize(staged_[buf]));
    const std::size_t len = std::min(step, bytes - at);
    // The destination is often fresh memory: its page faults cost more than the copy, and spread
    // over threads as well as the copy does.
    copy_parts(dst + at, h_staging_[buf], len, parallel);
  };
  // Up to kStagingBlocks - 1 transfers in flight while the host drains the oldest.
  constexpr std::size_t lag = kStagingBlocks - 1;
  for (std::size_t k = 0; k < blocks; ++k) {
    const int buf = static_cast<int>(k % kStagingBlocks);
    const std::size_t at = k * step;
    // Block k - kStagingBlocks used this staging block and was drained in the last iteration; stream
    // order puts this transfer after any upload still reading it.
    CDT_CUDA_CHECK(cudaMemcpyAsync(h_staging_[buf], src + at, std::min(step, bytes - at),
                                   cudaMemcpyDeviceToHost, stream_));
    CDT_CUDA_CHECK(cudaEventRecord(staged_[buf], stream_));
    if (k >= lag) drain(k - lag);
  }
  for (std::size_t k = blocks > lag ? blocks - lag : 0; k < blocks; ++k) drain(k);
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

PartCopies::PartCopies(cudaStream_t after) : after_(after) {
  CDT_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking));
}

PartCopies::~PartCopies() {
  // Errors were reported by wait(), or are on their way out with an exception.
  cudaStreamSynchronize(stream_);
  for (cudaEvent_t e : events_) cudaEventDestroy(e);
  cudaStreamDestroy(stream_);
}

void PartCopies::after_queued_work() {
  events_.reserve(events_.size() + 1);
  cudaEvent_t event = nullptr;
  CDT_CUDA_CHECK(cudaEventCreateWithFlags(&event, cudaEventDisableTiming));
  events_.push_back(event);
  CDT_CUDA_CHECK(cudaEventRecord(event, after_));
  CDT_CUDA_CHECK(cudaStreamWaitEvent(stream_, event, 0));
}

void PartCopies::copy(void* h_dst, const void* d_src, std::size_t bytes) {
  if (bytes != 0) CDT_CUDA_CHECK(cudaMemcpyAsync(h_dst, d_src, bytes, cudaMemcpyDeviceToHost, stream_));
}

void PartCopies::wait() { CDT_CUDA_CHECK(cudaStreamSynchronize(stream_)); }

/// Threads that help a late download's own with the host's side of its copies.
constexpr std::size_t kLateCopyHelpers = 3;

struct LateDownloads::Worker {
  cudaEvent_t ready = nullptr; ///< recorded on the starting thread's stream after the data's steps
  std::exception_ptr failure;
  std::future<void> done; ///< of the copies, on a side thread (run_beside)
};

void LateDownloads::start() {
  if (copies_.empty() || worker_ != nullptr) return;
  int device = 0;
  CDT_CUDA_CHECK(cudaGetDevice(&device));
  auto worker = std::make_unique<Worker>();
  CDT_CUDA_CHECK(cudaEventCreateWithFlags(&worker->ready, cudaEventDisableTiming));
  if (const cudaError_t status = cudaEventRecord(worker->ready, thread_stream()); status != cudaSuccess) {
    cudaEventDestroy(worker->ready);
    CDT_CUDA_CHECK(status);
  }
  Worker* w = worker.get();
  w->done = run_beside([this, w, device] {
    try {
      CDT_CUDA_CHECK(cudaSetDevice(device)); // the current device is each thread's own
      CudaExecutor executor;                 // this thread's stream and staging blocks
      CDT_CUDA_CHECK(cudaStreamWaitEvent(executor.stream(), w->ready, 0));
      // The host's side of the copies, out of the staging blocks into fresh pages, is bound by the
      // pages' first touch: on one thread, the 80 MB of 10^7 points' vertex maps often outlasted the
      // device's steps beside them (waited for 10-26 ms after shifting). Helper threads share it.
      const HostParallelFor helpers = [](std::size_t parts, const std::function<void(std::size_t)>& body) {
        std::atomic<std::size_t> next{0};
        const auto take = [&] {
          for (std::size_t p = next++; p < parts; p = next++) body(p);
        };
        std::vector<std::thread> threads;
        const std::size_t extra = std::min<std::size_t>(kLateCopyHelpers, parts > 0 ? parts - 1 : 0);
        try {
          for (std::size_t k = 0; k < extra; ++k) threads.emplace_back(take);
        } catch (...) {
          // No thread to be had (system_error, bad_alloc): those started and this one do the rest.
        }
        // Joined however this thread's share ends (the copies do not throw; a future body might).
        struct Joiner {
          std::vector<std::thread>& threads;
          ~Joiner() {
            for (std::thread& t : threads) t.join();
          }
        } joiner{threads};
        take();
      };
      for (const Copy& c : copies_)
        executor.download_unprofiled(static_cast<unsigned char*>(c.h_dst),
                                     static_cast<const unsigned char*>(c.d_src), c.bytes, &helpers);
    } catch (...) {
      w->failure = std::current_exception();
    }
  });
  worker_ = worker.release();
}

void LateDownloads::wait() {
  if (worker_ == nullptr) return;
  std::unique_ptr<Worker> worker(worker_);
  worker_ = nullptr;
  worker->done.wait();
  copies_.clear();
  cudaEventDestroy(worker->ready);
  if (worker->failure) std::rethrow_exception(worker->failure);
}

LateDownloads::~LateDownloads() {
  try {
    wait();
  } catch (...) {
    // Reported by wait() when the owner asks; a destructor has no one to tell.
  }
}

} // namespace detail

void reserve_memory(std::size_t staging_blocks, std::size_t device_bytes) {
  std::vector<void*> blocks;
  blocks.reserve(staging_blocks);
  try {
    for (std::size_t k = 0; k < staging_blocks; ++k) blocks.push_back(detail::take_staging_block());
  } catch (...) {
    for (void* block : blocks) detail::return_staging_block(block);
    throw;
  }
  for (void* block : blocks) detail::return_staging_block(block);
  if (device_bytes == 0 || detail::debug_sync()) return; // with the debug switch buffers bypass the pool
  void* buffer = nullptr;
  bool pooled = false;
  CDT_CUDA_CHECK(detail::device_allocate(&buffer, device_bytes, pooled));
  detail::device_release(buffer, pooled);
  CDT_CUDA_CHECK(cudaStreamSynchronize(detail::thread_stream()));
}

void release_device() noexcept {
  detail::unpin_result_blocks();
  detail::staging_blocks().free_all();
  detail::reply_blocks().free_all();
  {
    detail::BufferPools& all = detail::buffer_pools();
    const std::lock_guard lock(all.mutex);
    for (const auto& [device, pool] : all.pools) {
      cudaSetDevice(device);
      cudaMemPoolDestroy(pool);
    }
    all.pools.clear();
  }
  int count = 0;
  if (cudaGetDeviceCount(&count) == cudaSuccess) {
    for (int device = 0; device < count; ++device) {
      cudaSetDevice(device);
      cudaDeviceReset();
    }
  }
  cudaGetLastError(); // nothing here is the caller's error
}

void print_profile(const char* heading) {
  if (detail::profiling()) profile().print(heading);
}

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
