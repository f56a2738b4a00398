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

void CpuExecutor::run_chunks(std::size_t n, const std::function<void(std::size_t, std::size_t)>& body) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    body_ = &body;
    n_ = n;
    // Several chunks per thread for balance, but not so small that handing them out dominates.
    chunk_ = std::max<std::size_t>(1024, n / (static_cast<std::size_t>(num_threads_) * 8));
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
