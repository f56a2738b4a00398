#include "executor/cpu_executor.hpp"

namespace cdt::detail {

CpuExecutor::CpuExecutor(unsigned threads) {
  num_threads_ = threads != 0 ? threads : std::max(1u, std::thread::hardware_concurrency());
  // The calling thread takes part in every step, so the pool holds one thread fewer.
  for (unsigned i = 1; i < num_threads_; ++i) workers_.emplace_back([this, i] { worker_loop(i); });
}

CpuExecutor::~CpuExecutor() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  start_.notify_all();
  for (auto& w : workers_) w.join();
}

void CpuExecutor::run_chunks(std::size_t n, std::size_t chunk,
                             const std::function<void(std::size_t, std::size_t)>& body) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    body_ = &body;
    n_ = n;
    chunk_ = chunk;
    next_.store(0, std::memory_order_relaxed);
    pending_ = static_cast<unsigned>(workers_.size());
    ++generation_;
  }
  start_.notify_all();
  for (;;) {
    const std::size_t begin = next_.fetch_add(chunk_, std::memory_order_relaxed);
    if (begin >= n) break;
    body(begin, std::min(n, begin + chunk_));
  }
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [this] { return pending_ == 0; });
  body_ = nullptr;
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
  for (;;) {
    const std::function<void(std::size_t, std::size_t)>* body;
    std::size_t n;
    std::size_t chunk;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      start_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
      body = body_;
      n = n_;
      chunk = chunk_;
    }
    for (;;) {
      const std::size_t begin = next_.fetch_add(chunk, std::memory_order_relaxed);
      if (begin >= n) break;
      (*body)(begin, std::min(n, begin + chunk));
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (--pending_ == 0) done_.notify_one();
    }
  }
}

} // namespace cdt::detail
