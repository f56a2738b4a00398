#include "executor/cpu_executor.hpp"

#include <chrono>
#include <utility>

namespace cdt::detail {

CpuExecutor::CpuExecutor(unsigned threads) {
  num_threads_ = threads != 0 ? threads : std::max(1u, std::thread::hardware_concurrency());
  // The calling thread takes part in every step, so the pool holds one thread fewer.
  for (unsigned i = 1; i < num_threads_; ++i) workers_.emplace_back([this, i] { worker_loop(i); });
}

CpuExecutor::~CpuExecutor() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_.store(true, std::memory_order_release);
  }
  start_.notify_all();
  for (auto& w : workers_) w.join();
}

namespace {

/// How long a thread spins for the next step, or for the end of its step, before it sleeps. It spins
/// by yielding its core: a thread it waits for may be on the same core (more threads than cores, or
/// the driver's and other libraries' threads beside them), where spinning on a pause instruction
/// would hold it off for the whole spin (measured: median steps of 60 us against 5-10).
constexpr auto kSpin = std::chrono::microseconds(50);

/// Spins until ready() or kSpin has passed; returns ready().
template <class Ready>
bool spin_until(Ready&& ready) {
  const auto until = std::chrono::steady_clock::now() + kSpin;
  for (;;) {
    for (int k = 0; k < 8; ++k) {
      if (ready()) return true;
      std::this_thread::yield();
    }
    if (std::chrono::steady_clock::now() >= until) return ready();
  }
}

} // namespace

void CpuExecutor::run_chunks(std::size_t n, std::size_t chunk,
                             const std::function<void(std::size_t, std::size_t)>& body) {
  // The last step is closed (generation_ even); a worker still counted in busy_ may be reading its
  // fields, which it leaves at once (no chunk left). Wait for it before setting this step's.
  while (busy_.load(std::memory_order_seq_cst) != 0) std::this_thread::yield();
  body_ = &body;
  n_ = n;
  chunk_ = chunk;
  next_.store(0, std::memory_order_relaxed);
  finished_.store(0, std::memory_order_relaxed);
  // Wake as many sleepers as there are chunks for them (the caller takes one itself).
  const std::size_t chunks = (n + chunk - 1) / chunk;
  std::size_t wake = 0;
  {
    // Under the mutex: a worker about to sleep checks generation_ under it, so none misses the step.
    std::lock_guard<std::mutex> lock(mutex_);
    generation_.fetch_add(1, std::memory_order_seq_cst); // odd: open
    wake = std::min<std::size_t>(sleepers_, chunks - 1);
  }
  for (std::size_t k = 0; k < wake; ++k) start_.notify_one();
  take_chunks(body, n, chunk);
  const auto done = [this] { return finished_.load(std::memory_order_acquire) == n_; };
  if (!spin_until(done)) {
    std::unique_lock<std::mutex> lock(mutex_);
    caller_sleeping_ = true;
    done_.wait(lock, done);
    caller_sleeping_ = false;
  }
  // Closed. body_ is left as it is: a worker that came in just before may still read it (and find no
  // chunk); the next step sets it once busy_ is 0.
  generation_.fetch_add(1, std::memory_order_seq_cst);
  // Every element is done: nobody writes failure_ now.
  if (failure_) std::rethrow_exception(std::exchange(failure_, nullptr));
}

void CpuExecutor::take_chunks(const std::function<void(std::size_t, std::size_t)>& body, std::size_t n,
                              std::size_t chunk) noexcept {
  for (;;) {
    const std::size_t begin = next_.fetch_add(chunk, std::memory_order_relaxed);
    if (begin >= n) return;
    const std::size_t end = std::min(n, begin + chunk);
    std::size_t count = end - begin;
    try {
      body(begin, end);
    } catch (...) {
      {
        std::lock_guard<std::mutex> lock(failure_mutex_);
        if (!failure_) failure_ = std::current_exception();
      }
      // No more chunks for anyone: the step ends once those begun are done. The elements not handed
      // out yet count as finished here. (A thread that took its chunk's start before this exchange
      // still runs that chunk; the value stays at n or above.)
      const std::size_t unclaimed = next_.exchange(n, std::memory_order_relaxed);
      if (unclaimed < n) count += n - unclaimed;
    }
    if (finished_.fetch_add(count, std::memory_order_acq_rel) + count == n) {
      // The last elements: wake the caller should it be asleep (checked under the mutex, where the
      // caller decides to sleep).
      std::lock_guard<std::mutex> lock(mutex_);
      if (caller_sleeping_) done_.notify_one();
    }
  }
}

void CpuExecutor::sort_pairs_by_key(std::vector<std::uint32_t>& keys, std::vector<std::uint32_t>& values,
                                    int key_bits) {
  const std::size_t n = keys.size();
  if (n < 2 || key_bits <= 0) return;
  constexpr int kBits = 11;
  constexpr std::size_t kDigits = std::size_t{1} << kBits;
  // Blocks of consecutive pairs: each counts its digits, then scatters them to the slots that follow
  // the same digit's pairs of every earlier block, which keeps the sort stable.
  const std::size_t blocks = num_threads_ == 1 || n < 4 * kSerialBelow ? 1 : std::size_t{num_threads_} * 2;
  const std::size_t block = (n + blocks - 1) / blocks;
  std::vector<std::size_t> offset(blocks * kDigits);
  // The scatter targets are kept between calls: fresh pages of a large buffer cost a page fault each,
  // which on many threads costs more than the sort itself.
  std::vector<std::uint32_t>& keys_out = sort_keys_;
  std::vector<std::uint32_t>& values_out = sort_values_;
  keys_out.resize(n);
  values_out.resize(n);
  for (int shift = 0; shift < key_bits; shift += kBits) {
    const std::uint32_t mask = static_cast<std::uint32_t>(kDigits - 1);
    const auto digit = [&](std::uint32_t key) { return (key >> shift) & mask; };
    for_each_part(blocks, [&](std::size_t b) {
      std::size_t* count = offset.data() + b * kDigits;
      std::fill(count, count + kDigits, std::size_t{0});
      for (std::size_t i = b * block; i < std::min(n, (b + 1) * block); ++i) ++count[digit(keys[i])];
    });
    std::size_t sum = 0;
    bool one_digit = false;
    for (std::size_t d = 0; d < kDigits; ++d) {
      std::size_t digit_total = 0;
      for (std::size_t b = 0; b < blocks; ++b) {
        const std::size_t value = offset[b * kDigits + d];
        offset[b * kDigits + d] = sum + digit_total;
        digit_total += value;
      }
      one_digit = one_digit || digit_total == n;
      sum += digit_total;
    }
    if (one_digit) continue; // every key has the same digit here: the pass would not move anything
    for_each_part(blocks, [&](std::size_t b) {
      std::size_t* slot = offset.data() + b * kDigits;
      for (std::size_t i = b * block; i < std::min(n, (b + 1) * block); ++i) {
        const std::size_t at = slot[digit(keys[i])]++;
        keys_out[at] = keys[i];
        values_out[at] = values[i];
      }
    });
    keys.swap(keys_out);
    values.swap(values_out);
  }
}

void CpuExecutor::worker_loop(unsigned) {
  std::uint64_t seen = 0;
  // An open step this worker has not been in yet (or the pool's end).
  const auto ready = [&] {
    const std::uint64_t g = generation_.load(std::memory_order_acquire);
    return ((g & 1) != 0 && g != seen) || stop_.load(std::memory_order_acquire);
  };
  for (;;) {
    if (!spin_until(ready)) {
      std::unique_lock<std::mutex> lock(mutex_);
      ++sleepers_;
      start_.wait(lock, ready);
      --sleepers_;
    }
    if (stop_.load(std::memory_order_acquire)) return;
    const std::uint64_t g = generation_.load(std::memory_order_seq_cst);
    if ((g & 1) == 0 || g == seen) continue;
    // Counted in before the step's fields are read, and the step checked again after: either the
    // caller sees this worker in busy_ before it sets the next step's fields, or this worker sees the
    // step closed and leaves without reading them.
    busy_.fetch_add(1, std::memory_order_seq_cst);
    if (generation_.load(std::memory_order_seq_cst) == g) {
      seen = g;
      take_chunks(*body_, n_, chunk_);
    }
    busy_.fetch_sub(1, std::memory_order_seq_cst);
  }
}

} // namespace cdt::detail
