#include "executor/cpu_executor.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <numeric>
#include <set>
#include <thread>
#include <utility>
#include <vector>

namespace {

using cdt::detail::CpuExecutor;

TEST(CpuExecutor, ForEachVisitsEveryIndexOnce) {
  for (unsigned threads : {1u, 2u, 7u}) {
    CpuExecutor ex(threads);
    for (std::size_t n : {std::size_t{0}, std::size_t{5}, std::size_t{100000}}) {
      std::vector<std::atomic<int>> seen(n);
      ex.for_each(n, [&](std::size_t i) { seen[i].fetch_add(1); });
      for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(seen[i].load(), 1) << "threads " << threads << " n " << n;
    }
  }
}

TEST(CpuExecutor, ForEachCostlyVisitsEveryIndexOnceAndSpreadsFewIndices) {
  for (unsigned threads : {1u, 2u, 7u}) {
    CpuExecutor ex(threads);
    for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{63}, std::size_t{64}, std::size_t{3000},
                          std::size_t{100000}}) {
      std::vector<std::atomic<int>> seen(n);
      ex.for_each_costly(n, [&](std::size_t i) { seen[i].fetch_add(1); });
      for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(seen[i].load(), 1) << "threads " << threads << " n " << n;
    }
  }
  // A few hundred indices (for_each runs them on the calling thread) reach both threads: each index
  // waits (up to a few seconds) until a second thread has taken one.
  CpuExecutor ex(2);
  std::mutex mutex;
  std::set<std::thread::id> ids;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  ex.for_each_costly(300, [&](std::size_t) {
    {
      const std::lock_guard lock(mutex);
      ids.insert(std::this_thread::get_id());
    }
    for (;;) {
      {
        const std::lock_guard lock(mutex);
        if (ids.size() >= 2) return;
      }
      if (std::chrono::steady_clock::now() > give_up) return;
      std::this_thread::yield();
    }
  });
  EXPECT_EQ(ids.size(), 2u);
}

// An element's exception, thrown on whichever thread ran it, reaches the step's caller (the pool would
// otherwise end the process), the step stops handing out work, and the pool runs the next steps.
TEST(CpuExecutor, AnElementsExceptionReachesTheCallerAndThePoolGoesOn) {
  struct Thrown {
    std::size_t at;
  };
  for (unsigned threads : {1u, 2u, 7u}) {
    CpuExecutor ex(threads);
    for (const std::size_t bad : {std::size_t{0}, std::size_t{54321}, std::size_t{99999}}) {
      std::atomic<std::size_t> visited{0};
      try {
        ex.for_each(100000, [&](std::size_t i) {
          if (i == bad) throw Thrown{i};
          visited.fetch_add(1);
        });
        ADD_FAILURE() << "no exception, threads " << threads << " bad " << bad;
      } catch (const Thrown& e) {
        EXPECT_EQ(e.at, bad) << "threads " << threads;
      }
      EXPECT_LT(visited.load(), std::size_t{100000}) << "threads " << threads;
      // Every thread throws: one exception comes back, the others are dropped.
      EXPECT_THROW(ex.for_each_part(64, [](std::size_t p) { throw Thrown{p}; }), Thrown);
      // The pool is whole: the next steps visit every index once.
      std::vector<std::atomic<int>> seen(100000);
      ex.for_each(seen.size(), [&](std::size_t i) { seen[i].fetch_add(1); });
      EXPECT_TRUE(
          std::all_of(seen.begin(), seen.end(), [](const std::atomic<int>& k) { return k.load() == 1; }))
          << "threads " << threads;
      std::vector<std::uint32_t> v(50000);
      std::iota(v.rbegin(), v.rend(), 0u);
      ex.sort(v, std::less<>());
      EXPECT_TRUE(std::is_sorted(v.begin(), v.end())) << "threads " << threads;
    }
  }
}

// A step ends when its elements are done, not when every worker has looked in: workers that wake late
// (more threads than cores, and here a thread spinning beside them) may meet the next step's fields
// being set. Thousands of back-to-back steps of a few elements to a few thousand, some of them
// throwing, each visit every index once.
TEST(CpuExecutor, BackToBackSmallStepsBesideABusyThreadVisitEveryIndexOnce) {
  // Spins until the test ends, however it ends.
  struct BusyThread {
    std::atomic<bool> stop{false};
    std::thread thread{[this] {
      while (!stop.load(std::memory_order_relaxed)) {
      }
    }};
    ~BusyThread() {
      stop.store(true);
      thread.join();
    }
  } busy;
  struct Thrown {};
  for (unsigned threads : {2u, 3u, 9u}) {
    CpuExecutor ex(threads);
    std::vector<std::atomic<int>> seen(5000);
    for (std::size_t step = 0; step < 3000; ++step) {
      const std::size_t n = (step * 2654435761u) % seen.size();
      for (std::size_t i = 0; i < n; ++i) seen[i].store(0, std::memory_order_relaxed);
      if (step % 97 == 5 && n > 0) {
        EXPECT_THROW(ex.for_each_costly(n,
                                        [&](std::size_t i) {
                                          if (i == n / 2) throw Thrown{};
                                        }),
                     Thrown);
        continue;
      }
      ex.for_each_costly(n, [&](std::size_t i) { seen[i].fetch_add(1, std::memory_order_relaxed); });
      for (std::size_t i = 0; i < n; ++i)
        ASSERT_EQ(seen[i].load(std::memory_order_relaxed), 1) << "threads " << threads << " step " << step;
    }
  }
}

TEST(CpuExecutor, ScanCompactAndSortMatchSerialResults) {
  CpuExecutor ex(4);
  std::vector<std::uint32_t> v(200003);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<std::uint32_t>((i * 2654435761u) % 7);
  std::vector<std::uint32_t> expected(v.size());
  std::exclusive_scan(v.begin(), v.end(), expected.begin(), 0u);
  const std::uint32_t total = std::accumulate(v.begin(), v.end(), 0u);
  auto scanned = v;
  EXPECT_EQ(ex.exclusive_scan(scanned), total);
  EXPECT_EQ(scanned, expected);

  const auto kept = ex.compact(v.size(), [&](std::size_t i) { return v[i] == 3; });
  std::vector<std::uint32_t> serial;
  for (std::size_t i = 0; i < v.size(); ++i)
    if (v[i] == 3) serial.push_back(static_cast<std::uint32_t>(i));
  EXPECT_EQ(kept, serial);

  auto sorted = v;
  ex.sort(sorted, [](std::uint32_t a, std::uint32_t b) { return a < b; });
  EXPECT_TRUE(std::is_sorted(sorted.begin(), sorted.end()));
  EXPECT_EQ(std::accumulate(sorted.begin(), sorted.end(), 0u), total);
}

TEST(CpuExecutor, ForEachPartVisitsEveryPartOnceAndRunsPartsConcurrently) {
  for (unsigned threads : {1u, 2u, 5u}) {
    CpuExecutor ex(threads);
    for (std::size_t parts : {std::size_t{0}, std::size_t{1}, std::size_t{3}, std::size_t{40}}) {
      std::vector<std::atomic<int>> seen(parts);
      ex.for_each_part(parts, [&](std::size_t p) { seen[p].fetch_add(1); });
      for (std::size_t p = 0; p < parts; ++p) ASSERT_EQ(seen[p].load(), 1) << threads << " " << parts;
    }
  }
  // Two parts on two threads: each waits (up to a few seconds) for the other to have started, which only
  // happens when they run at the same time; a serial run would see both waits time out.
  CpuExecutor ex(2);
  std::atomic<int> started{0};
  std::atomic<int> met{0};
  ex.for_each_part(2, [&](std::size_t) {
    started.fetch_add(1);
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (started.load() < 2 && std::chrono::steady_clock::now() < give_up) std::this_thread::yield();
    if (started.load() == 2) met.fetch_add(1);
  });
  EXPECT_GE(met.load(), 1);
}

TEST(CpuExecutor, SortPairsByKeyMatchesAStableSort) {
  for (unsigned threads : {1u, 2u, 5u}) {
    CpuExecutor ex(threads);
    for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{1000}, std::size_t{100003}}) {
      for (const int bits : {1, 7, 11, 12, 23, 32}) {
        std::vector<std::uint32_t> keys(n);
        std::vector<std::uint32_t> values(n);
        std::uint64_t state = 12345 + n + static_cast<std::uint64_t>(bits);
        const std::uint64_t mask = bits == 32 ? 0xFFFFFFFFull : (1ull << bits) - 1;
        for (std::size_t i = 0; i < n; ++i) {
          state = state * 6364136223846793005ull + 1442695040888963407ull;
          // Few distinct keys in the low half of the inputs, so stability is tested on long runs.
          const std::uint64_t r = state >> 16;
          keys[i] = static_cast<std::uint32_t>((i % 2 == 0 ? r % 5 : r) & mask);
          values[i] = static_cast<std::uint32_t>(i);
        }
        std::vector<std::pair<std::uint32_t, std::uint32_t>> expected(n);
        for (std::size_t i = 0; i < n; ++i) expected[i] = {keys[i], values[i]};
        std::stable_sort(expected.begin(), expected.end(),
                         [](const auto& a, const auto& b) { return a.first < b.first; });
        ex.sort_pairs_by_key(keys, values, bits);
        ASSERT_EQ(keys.size(), n);
        for (std::size_t i = 0; i < n; ++i) {
          ASSERT_EQ(keys[i], expected[i].first) << threads << " threads, n " << n << ", bits " << bits;
          ASSERT_EQ(values[i], expected[i].second) << threads << " threads, n " << n << ", bits " << bits;
        }
      }
    }
  }
}

// The paper's marking relies on the smallest index winning however the threads interleave.
TEST(CpuExecutor, ReduceJoinsThePartsInOrder) {
  // A sum, and the first index failing a check (each part stops at its own first failure), for sizes
  // below, at and above the number of parts, on one and on several threads.
  for (const unsigned threads : {1u, 4u}) {
    CpuExecutor executor(threads);
    for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{63}, std::size_t{64},
                                std::size_t{1000}, std::size_t{100003}}) {
      const std::uint64_t sum = executor.reduce(
          n, std::uint64_t{0}, [](std::uint64_t& acc, std::size_t i) { acc += i; },
          [](std::uint64_t& acc, const std::uint64_t& part) { acc += part; });
      EXPECT_EQ(sum, n == 0 ? 0 : std::uint64_t{n} * (n - 1) / 2) << n << " elements, " << threads;
      // Fails at every multiple of 7 from n / 3 on: the first failure is the least such index.
      const std::size_t first = executor.reduce(
          n, n,
          [&](std::size_t& acc, std::size_t i) {
            if (acc == n && i >= n / 3 && i % 7 == 0) acc = i;
          },
          [](std::size_t& acc, const std::size_t& part) { acc = std::min(acc, part); });
      std::size_t expected = n;
      for (std::size_t i = n / 3; i < n; ++i)
        if (i % 7 == 0) {
          expected = i;
          break;
        }
      EXPECT_EQ(first, expected) << n << " elements, " << threads;
    }
  }
}

TEST(CpuExecutor, AtomicMinKeepsTheSmallestValue) {
  CpuExecutor ex(4);
  std::vector<std::uint32_t> marks(64, 0xFFFFFFFFu);
  ex.for_each(100000, [&](std::size_t i) {
    cdt::detail::atomic_min(&marks[i % 64], static_cast<std::uint32_t>(100000 - i));
  });
  for (std::size_t k = 0; k < 64; ++k) {
    // The smallest value written to slot k is 100000 - i for the largest i with i % 64 == k.
    const std::size_t largest = 99999 - ((99999 - k) % 64);
    EXPECT_EQ(marks[k], 100000 - largest);
  }
}

TEST(CpuExecutor, AtomicMaxKeepsTheLargest) {
  cdt::detail::CpuExecutor ex(4);
  std::vector<std::uint32_t> marks(64, 0);
  ex.for_each(100000, [&](std::size_t i) {
    cdt::detail::atomic_max(&marks[i % 64], static_cast<std::uint32_t>(i + 1));
  });
  for (std::size_t k = 0; k < 64; ++k) {
    // The largest value written to slot k is i + 1 for the largest i with i % 64 == k.
    const std::size_t largest = 99999 - ((99999 - k) % 64);
    EXPECT_EQ(marks[k], largest + 1);
  }
}

} // namespace
