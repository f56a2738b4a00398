#include "executor/cpu_executor.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <numeric>
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

// The paper's marking relies on the smallest index winning however the threads interleave.
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

} // namespace
