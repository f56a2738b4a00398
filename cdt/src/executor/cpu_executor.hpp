#pragma once
// The CPU executor of gCD: the data-parallel steps the algorithm is written in (for-each-index,
// prefix sum, stream compaction, sort, atomic minimum), run on a pool of threads. The CUDA executor
// in kernels/ provides the same steps on the GPU; per-element work is shared between the two.

#include <algorithm>
#include <atomic>
#include <bit>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "cdt/cdt.hpp"

namespace cdt::detail {

/// A buffer whose new elements start unwritten, for a step that writes every element itself in
/// parallel: a std::vector would first zero it on one thread, which at millions of elements costs
/// about as much as the parallel step.
template <class T>
using UnzeroedVector = std::vector<T, DefaultInitAllocator<T>>;

/// Lowers *address to value if value is smaller; returns the previous value. Safe against concurrent
/// callers on the same address (the paper's atomic minimum marking).
inline std::uint32_t atomic_min(std::uint32_t* address, std::uint32_t value) {
  std::atomic_ref<std::uint32_t> ref(*address);
  std::uint32_t current = ref.load(std::memory_order_relaxed);
  while (value < current && !ref.compare_exchange_weak(current, value, std::memory_order_relaxed)) {
  }
  return current;
}

/// atomic_min as a function object, for the rounds' claims (record_flip_proposal,
/// record_constraint_proposal, locate_and_claim); the device's is cdt::gpu::detail::ClaimMin.
struct AtomicMin {
  void operator()(std::uint32_t* address, std::uint32_t value) const { atomic_min(address, value); }
};

/// Raises *address to value if value is larger; returns the previous value. Safe against concurrent
/// callers on the same address.
inline std::uint32_t atomic_max(std::uint32_t* address, std::uint32_t value) {
  std::atomic_ref<std::uint32_t> ref(*address);
  std::uint32_t current = ref.load(std::memory_order_relaxed);
  while (value > current && !ref.compare_exchange_weak(current, value, std::memory_order_relaxed)) {
  }
  return current;
}

/// The number of bits needed to write every value below `count`: the key_bits of
/// CpuExecutor::sort_pairs_by_key for keys below count.
inline int bits_below(std::size_t count) { return count <= 1 ? 0 : std::bit_width(count - 1); }

/// A fixed pool of worker threads running data-parallel steps. Each step returns only when every
/// element is done, which is the global synchronisation the algorithm relies on between steps. An
/// exception thrown by an element's work, on any thread, ends the step early (no further chunks are
/// handed out; those begun finish) and is rethrown to the step's caller, the first one only; the pool
/// stays usable.
class CpuExecutor {
public:
  /// threads == 0 uses every hardware thread.
  explicit CpuExecutor(unsigned threads = 0);
  ~CpuExecutor();
  CpuExecutor(const CpuExecutor&) = delete;
  CpuExecutor& operator=(const CpuExecutor&) = delete;

  unsigned threads() const noexcept { return num_threads_; }

  /// Calls f(i) for every i in [0, n) in parallel. f must be safe to run concurrently for distinct i.
  template <class F>
  void for_each(std::size_t n, F&& f) {
    // Several chunks per thread for balance, but not so small that handing them out dominates.
    for_each_from(n, kSerialBelow, 1024, f);
  }

  /// for_each for elements that cost a microsecond or more each (a segment scanning the cells it
  /// meets): parallel from a few dozen elements, handed out in small chunks, where for_each runs a few
  /// thousand such elements on the calling thread alone.
  template <class F>
  void for_each_costly(std::size_t n, F&& f) {
    for_each_from(n, kCostlySerialBelow, 1, f);
  }

  /// Calls f(p) for every part p in [0, parts) in parallel, one part at a time per thread: for steps
  /// cut into a few large parts (blocks of a scan, of a compaction, of a sort pass).
  template <class F>
  void for_each_part(std::size_t parts, F&& f) {
    if (parts == 0) return;
    if (num_threads_ == 1 || parts == 1) {
      for (std::size_t p = 0; p < parts; ++p) f(p);
      return;
    }
    run_chunks(parts, 1, [&f](std::size_t begin, std::size_t end) {
      for (std::size_t p = begin; p < end; ++p) f(p);
    });
  }

  /// Folds [0, n) in contiguous parts on the threads and joins the parts' results in order: each part
  /// starts from init and takes its elements in increasing order through fold(acc, i); then
  /// join(result, next) adds the next part's accumulator to the result (a bounding box, a count, the
  /// first index that fails a check). The result does not depend on the thread count.
  template <class T, class Fold, class Join>
  T reduce(std::size_t n, const T& init, Fold&& fold, Join&& join) {
    if (n == 0) return init;
    const std::size_t parts = std::min<std::size_t>(kReduceParts, n);
    std::vector<T> acc(parts, init);
    for_each_part(parts, [&](std::size_t p) {
      for (std::size_t i = n * p / parts; i < n * (p + 1) / parts; ++i) fold(acc[p], i);
    });
    T result = acc[0];
    for (std::size_t p = 1; p < parts; ++p) join(result, acc[p]);
    return result;
  }

  /// Exclusive prefix sum of v in place; returns the total.
  template <class T, class Alloc>
  T exclusive_scan(std::vector<T, Alloc>& v) {
    const std::size_t n = v.size();
    if (num_threads_ == 1 || n < kSerialBelow) {
      T sum{};
      for (auto& x : v) {
        const T value = x;
        x = sum;
        sum += value;
      }
      return sum;
    }
    // Two passes over fixed blocks: block totals, then each block scanned from its offset.
    const std::size_t blocks = num_threads_ * 4;
    const std::size_t block = (n + blocks - 1) / blocks;
    std::vector<T> totals(blocks, T{});
    for_each_part(blocks, [&](std::size_t b) {
      T sum{};
      for (std::size_t i = b * block; i < std::min(n, (b + 1) * block); ++i) sum += v[i];
      totals[b] = sum;
    });
    T running{};
    for (auto& t : totals) {
      const T value = t;
      t = running;
      running += value;
    }
    for_each_part(blocks, [&](std::size_t b) {
      T sum = totals[b];
      for (std::size_t i = b * block; i < std::min(n, (b + 1) * block); ++i) {
        const T value = v[i];
        v[i] = sum;
        sum += value;
      }
    });
    return running;
  }

  /// The indices i in [0, n) for which keep(i) is true, in increasing order (stream compaction), in
  /// a std::vector or another vector of 32-bit indices (Out) with room for at least `room` of them.
  template <class Out = std::vector<std::uint32_t>, class Pred>
  Out compact(std::size_t n, Pred&& keep, std::size_t room = 0) {
    Out out;
    out.reserve(room);
    if (num_threads_ == 1 || n < kSerialBelow) {
      for (std::size_t i = 0; i < n; ++i)
        if (keep(i)) out.push_back(static_cast<std::uint32_t>(i));
      return out;
    }
    const std::size_t blocks = num_threads_ * 4;
    const std::size_t block = (n + blocks - 1) / blocks;
    std::vector<std::uint32_t> counts(blocks, 0);
    std::vector<std::uint8_t> flags(n);
    for_each_part(blocks, [&](std::size_t b) {
      std::uint32_t c = 0;
      for (std::size_t i = b * block; i < std::min(n, (b + 1) * block); ++i) {
        flags[i] = keep(i) ? 1 : 0;
        c += flags[i];
      }
      counts[b] = c;
    });
    const std::uint32_t total = exclusive_scan(counts);
    out.resize(total);
    for_each_part(blocks, [&](std::size_t b) {
      std::uint32_t at = counts[b];
      for (std::size_t i = b * block; i < std::min(n, (b + 1) * block); ++i)
        if (flags[i]) out[at++] = static_cast<std::uint32_t>(i);
    });
    return out;
  }

  /// Sorts v by less (not stable).
  template <class T, class Less>
  void sort(std::vector<T>& v, Less less) {
    const std::size_t n = v.size();
    if (num_threads_ == 1 || n < 4 * kSerialBelow) {
      std::sort(v.begin(), v.end(), less);
      return;
    }
    // Sort equal slices in parallel, then merge pairs of runs in parallel rounds.
    const std::size_t parts = num_threads_;
    std::vector<std::size_t> bounds(parts + 1);
    for (std::size_t p = 0; p <= parts; ++p) bounds[p] = n * p / parts;
    for_each_part(parts,
                  [&](std::size_t p) { std::sort(v.begin() + bounds[p], v.begin() + bounds[p + 1], less); });
    for (std::size_t width = 1; width < parts; width *= 2) {
      const std::size_t pairs = (parts + 2 * width - 1) / (2 * width);
      for_each_part(pairs, [&](std::size_t k) {
        const std::size_t lo = 2 * width * k;
        const std::size_t mid = std::min(parts, lo + width);
        const std::size_t hi = std::min(parts, lo + 2 * width);
        if (mid < hi)
          std::inplace_merge(v.begin() + bounds[lo], v.begin() + bounds[mid], v.begin() + bounds[hi], less);
      });
    }
  }

  /// Sorts the pairs (keys[i], values[i]) by key, stably: pairs with equal keys keep their order. Only
  /// the low key_bits bits of the keys are looked at (the others must be zero). A radix sort, 11 bits
  /// a pass, each pass counted and scattered by blocks in parallel: linear in n, where a comparison
  /// sort of the same pairs costs several times more.
  void sort_pairs_by_key(std::vector<std::uint32_t>& keys, std::vector<std::uint32_t>& values, int key_bits);

private:
  /// for_each with n below serial_below on the calling thread, else in chunks of at least min_chunk.
  template <class F>
  void for_each_from(std::size_t n, std::size_t serial_below, std::size_t min_chunk, F& f) {
    if (n == 0) return;
    if (num_threads_ == 1 || n < serial_below) {
      for (std::size_t i = 0; i < n; ++i) f(i);
      return;
    }
    const std::size_t chunk = std::max<std::size_t>(min_chunk, n / (std::size_t{num_threads_} * 8));
    run_chunks(n, chunk, [&f](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) f(i);
    });
  }

  static constexpr std::size_t kSerialBelow = 4096;
  static constexpr std::size_t kCostlySerialBelow = 64;
  static constexpr std::size_t kReduceParts = 64;

  void run_chunks(std::size_t n, std::size_t chunk,
                  const std::function<void(std::size_t, std::size_t)>& body);
  /// Takes chunks of the current step until none are left, counting the finished elements in
  /// finished_; an exception ends the handing out, and the elements never handed out count as finished.
  void take_chunks(const std::function<void(std::size_t, std::size_t)>& body, std::size_t n,
                   std::size_t chunk) noexcept;
  void worker_loop(unsigned index);

  unsigned num_threads_ = 1;
  std::vector<std::thread> workers_;
  // A step is published by setting body_, n_, chunk_ and next_ and then raising generation_ to an odd
  // value; it is done when finished_ (its elements finished, or given up after an exception) reaches n_.
  // The caller waits for the elements, not for the workers: a worker that wakes late, or whose core
  // is taken by another busy thread (the device's waiting thread beside a full pool), finds no chunk
  // left and costs the step nothing, where waiting for every worker to check in cost a scheduler tick
  // (4 ms) now and then. After a step generation_ goes even (closed); a worker counts itself in busy_
  // before it looks at a step and checks generation_ again after, and the caller sets the next step's
  // fields only once busy_ is 0, so no worker reads a step's fields while they change. Both sides spin
  // a little (yielding their core) before they sleep on the condition variables, so that back-to-back
  // steps do not wait for sleeping threads to wake: a step of 8192 elements on 2 threads took about
  // 5 us instead of 24-30, 12 instead of 39 with 4 threads on 2 cores; the host's parts of a GPU
  // triangulation are many such small steps (the split of the suspect pieces: dozens of steps on a
  // few thousand elements).
  std::mutex mutex_;
  std::condition_variable start_;
  std::condition_variable done_;
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<unsigned> busy_{0};
  std::atomic<std::size_t> finished_{0};
  std::atomic<bool> stop_{false};
  unsigned sleepers_ = 0;        // workers asleep on start_ (under mutex_)
  bool caller_sleeping_ = false; // the caller asleep on done_ (under mutex_)
  // The current step: chunks handed out dynamically so uneven per-element work balances.
  const std::function<void(std::size_t, std::size_t)>* body_ = nullptr;
  std::size_t n_ = 0;
  std::size_t chunk_ = 0;
  std::atomic<std::size_t> next_{0};
  // The current step's first exception (under failure_mutex_), rethrown by run_chunks.
  std::mutex failure_mutex_;
  std::exception_ptr failure_;
  // Scratch of sort_pairs_by_key, reused from call to call.
  std::vector<std::uint32_t> sort_keys_;
  std::vector<std::uint32_t> sort_values_;
};

} // namespace cdt::detail
