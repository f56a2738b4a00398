// The CUDA executor's primitives against host computations: for_each, exclusive scan, stream
// compaction (also by a block and by a cooperative grid as teams), sorts, atomic minimum under
// contention, the device-memory check and CUDA errors turned into DeviceError. Device lambdas live in
// free functions: nvcc does not allow them in the private TestBody of a gtest fixture.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <future>
#include <numeric>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "block_steps.cuh"
#include "cdt/cdt.hpp"
#include "cdt/errors.hpp"
#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"

namespace {

using cdt::gpu::detail::CudaExecutor;
using cdt::gpu::detail::DeviceBuffer;

std::uint64_t mix(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

template <class T>
std::vector<T> random_values(std::size_t n, std::uint64_t seed, std::uint64_t below) {
  std::vector<T> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<T>(mix(seed * 1000003 + i) % below);
  return v;
}

template <class T>
DeviceBuffer<T> to_device(CudaExecutor& ex, const std::vector<T>& h) {
  DeviceBuffer<T> d(h.size());
  ex.upload(d.data(), h.data(), h.size());
  return d;
}

template <class T>
std::vector<T> to_host(CudaExecutor& ex, const DeviceBuffer<T>& d, std::size_t n) {
  std::vector<T> h(n);
  ex.download(h.data(), d.data(), n);
  return h;
}

/// How often for_each called f(i), per i.
std::vector<std::uint32_t> visits(CudaExecutor& ex, std::size_t n) {
  DeviceBuffer<std::uint32_t> d_count(n);
  ex.fill_bytes(d_count.data(), 0, n);
  std::uint32_t* count = d_count.data();
  ex.for_each(n, [=] __device__(std::size_t i) { atomicAdd(count + i, 1u); });
  return to_host(ex, d_count, n);
}

std::vector<std::uint32_t> compact_multiples_of(CudaExecutor& ex, const std::vector<std::uint32_t>& h,
                                                std::uint32_t k) {
  DeviceBuffer<std::uint32_t> d_in = to_device(ex, h);
  DeviceBuffer<std::uint32_t> d_out(h.size());
  const std::uint32_t* in = d_in.data();
  const std::uint32_t count = ex.compact(
      h.size(), [=] __device__(std::size_t i) { return in[i] % k == 0; }, d_out.data());
  return to_host(ex, d_out, count);
}

/// The i in [0, n) with in[i] % k == 0, compacted with the count left on the device, then gathered and
/// doubled by for_each_counted steps reading that count (the grid sized by n, the count's bound); each
/// counted step also writes a sentinel past the count, which must stay untouched.
std::vector<std::uint32_t> counted_multiples_of(CudaExecutor& ex, const std::vector<std::uint32_t>& h,
                                                std::uint32_t k) {
  DeviceBuffer<std::uint32_t> d_in = to_device(ex, h);
  DeviceBuffer<std::uint32_t> d_picked(h.size()), d_out(h.size() + 1), d_count(1);
  const std::uint32_t* in = d_in.data();
  std::uint32_t* picked = d_picked.data();
  std::uint32_t* out = d_out.data();
  const std::uint32_t* count = d_count.data();
  ex.fill_bytes(out, 0xFF, h.size() + 1);
  ex.compact_to(
      h.size(), [=] __device__(std::size_t i) { return in[i] % k == 0; }, picked, d_count.data());
  const auto counted = [=] __device__() -> std::size_t { return *count; };
  ex.for_each_counted(
      h.size(), counted, [=] __device__(std::size_t j) { out[j] = in[picked[j]]; }, "gather");
  ex.for_each_counted(
      h.size(), counted, [=] __device__(std::size_t j) { out[j] = 2 * out[j]; }, "double");
  std::uint32_t n = 0;
  ex.download(&n, count, 1);
  std::vector<std::uint32_t> got = to_host(ex, d_out, n + 1);
  EXPECT_EQ(got.back(), 0xFFFFFFFFu) << "a counted step wrote past its count";
  got.pop_back();
  return got;
}

/// Two ordered compactions by a team, back to back: the i in [0, n) with in[i] % k == 0 to out, then
/// the j of those whose out[j] is even to out + n; the counts to count[0, 2).
template <class Team>
__device__ void team_compactions(const Team& team, const std::uint32_t* in, std::uint32_t n, std::uint32_t k,
                                 std::uint32_t* out, std::uint32_t* count) {
  const std::uint32_t kept = team.compact(
      n, [&](std::uint32_t i) { return in[i] % k == 0; }, out);
  const std::uint32_t even = team.compact(
      kept, [&](std::uint32_t j) { return out[j] % 2 == 0; }, out + n);
  if (team.leader()) {
    count[0] = kept;
    count[1] = even;
  }
}

__global__ void __launch_bounds__(cdt::gpu::detail::kBlockRoundThreads)
    block_team_compactions(const std::uint32_t* in, std::uint32_t n, std::uint32_t k, std::uint32_t* out,
                           std::uint32_t* count) {
  __shared__ cdt::gpu::detail::BlockCompactStorage storage;
  __shared__ std::uint32_t word;
  team_compactions(cdt::gpu::detail::BlockTeam{storage, &word}, in, n, k, out, count);
}

__global__ void __launch_bounds__(cdt::gpu::detail::kBlockRoundThreads)
    grid_team_compactions(const std::uint32_t* in, std::uint32_t n, std::uint32_t k, std::uint32_t* out,
                          std::uint32_t* count, std::uint32_t* counts, std::uint32_t* word) {
  __shared__ cdt::gpu::detail::BlockCompactStorage storage;
  team_compactions(cdt::gpu::detail::GridTeam{storage, counts, word}, in, n, k, out, count);
}

/// team_compactions by one block (blocks == 0) or a cooperative grid of `blocks` blocks: the two lists.
std::pair<std::vector<std::uint32_t>, std::vector<std::uint32_t>>
team_compacted(CudaExecutor& ex, const std::vector<std::uint32_t>& h, std::uint32_t k, unsigned blocks) {
  const auto n = static_cast<std::uint32_t>(h.size());
  DeviceBuffer<std::uint32_t> d_in = to_device(ex, h);
  DeviceBuffer<std::uint32_t> d_out(2 * std::size_t{n} + 1), d_count(2);
  if (blocks == 0) {
    block_team_compactions<<<1, cdt::gpu::detail::kBlockRoundThreads, 0, ex.stream()>>>(
        d_in.data(), n, k, d_out.data(), d_count.data());
    CDT_CUDA_CHECK_LAUNCH("block_team_compactions");
  } else {
    cdt::gpu::detail::GridTeamScratch scratch;
    cdt::gpu::detail::launch_grid_team(grid_team_compactions, blocks, ex.stream(), "grid_team_compactions",
                                       d_in.data(), n, k, d_out.data(), d_count.data(), scratch.counts(),
                                       scratch.word());
    ex.synchronize(); // before the scratch goes
  }
  const auto count = to_host(ex, d_count, 2);
  std::vector<std::uint32_t> kept(count[0]), even(count[1]);
  if (count[0] != 0) ex.download(kept.data(), d_out.data(), count[0]);
  if (count[1] != 0) ex.download(even.data(), d_out.data() + n, count[1]);
  return {kept, even};
}

/// Every thread lowers slot i % slots to its value; returns the slots and, per thread, the value it saw.
std::pair<std::vector<std::uint32_t>, std::vector<std::uint32_t>>
contended_minimum(CudaExecutor& ex, const std::vector<std::uint32_t>& values, std::uint32_t slots) {
  DeviceBuffer<std::uint32_t> d_values = to_device(ex, values);
  DeviceBuffer<std::uint32_t> d_slots(slots);
  DeviceBuffer<std::uint32_t> d_seen(values.size());
  ex.fill_bytes(d_slots.data(), 0xFF, slots);
  const std::uint32_t* v = d_values.data();
  std::uint32_t* slot = d_slots.data();
  std::uint32_t* seen = d_seen.data();
  ex.for_each(values.size(), [=] __device__(std::size_t i) {
    seen[i] = cdt::gpu::detail::atomic_min(slot + i % slots, v[i]);
  });
  return {to_host(ex, d_slots, slots), to_host(ex, d_seen, values.size())};
}

class GpuExecutor : public ::testing::Test {
protected:
  void SetUp() override {
    if (cdt::gpu::device_count() == 0) GTEST_SKIP() << "no CUDA device available";
  }
};

TEST_F(GpuExecutor, ForEachVisitsEveryIndexOnce) {
  CudaExecutor ex;
  // The largest size is beyond one grid of the executor's blocks: the kernel's stride loop must run.
  for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{1000}, std::size_t{40'000'003}}) {
    const auto count = visits(ex, n);
    const auto wrong = std::count_if(count.begin(), count.end(), [](std::uint32_t c) { return c != 1; });
    EXPECT_EQ(wrong, 0) << "n " << n;
  }
}

TEST_F(GpuExecutor, ExclusiveScanMatchesHost) {
  CudaExecutor ex;
  for (const std::size_t n : {std::size_t{1}, std::size_t{777}, std::size_t{(1u << 20) + 7}}) {
    const auto h = random_values<std::uint32_t>(n, n, 100);
    std::vector<std::uint32_t> expected(n);
    std::exclusive_scan(h.begin(), h.end(), expected.begin(), 0u);
    DeviceBuffer<std::uint32_t> d = to_device(ex, h);
    const std::uint32_t total = ex.exclusive_scan(d.data(), n);
    EXPECT_EQ(total, std::accumulate(h.begin(), h.end(), 0u)) << "n " << n;
    EXPECT_EQ(to_host(ex, d, n), expected) << "n " << n;
  }
  // 64-bit sums beyond 2^32: the total must not wrap.
  const auto big = random_values<std::uint64_t>(100000, 5, 1ull << 40);
  DeviceBuffer<std::uint64_t> d = to_device(ex, big);
  EXPECT_EQ(ex.exclusive_scan(d.data(), big.size()),
            std::accumulate(big.begin(), big.end(), std::uint64_t{0}));
  EXPECT_EQ(ex.exclusive_scan(d.data(), 0), 0u);
}

TEST_F(GpuExecutor, CompactKeepsSelectedIndicesInOrder) {
  CudaExecutor ex;
  for (const std::size_t n : {std::size_t{1}, std::size_t{5000}, std::size_t{3'000'001}}) {
    const auto h = random_values<std::uint32_t>(n, 17 + n, 1000);
    for (const std::uint32_t k : {1u, 3u, 1001u}) { // all, a third, none
      std::vector<std::uint32_t> expected;
      for (std::size_t i = 0; i < n; ++i)
        if (h[i] % k == 0) expected.push_back(static_cast<std::uint32_t>(i));
      EXPECT_EQ(compact_multiples_of(ex, h, k), expected) << "n " << n << " k " << k;
    }
  }
}

TEST_F(GpuExecutor, CountedStepsReadTheCountTheDeviceLeft) {
  CudaExecutor ex;
  for (const std::size_t n : {std::size_t{1}, std::size_t{5000}, std::size_t{3'000'001}}) {
    const auto h = random_values<std::uint32_t>(n, 41 + n, 1000);
    for (const std::uint32_t k : {1u, 3u, 1001u}) { // all, a third, none
      std::vector<std::uint32_t> expected;
      for (std::size_t i = 0; i < n; ++i)
        if (h[i] % k == 0) expected.push_back(2 * h[i]);
      EXPECT_EQ(counted_multiples_of(ex, h, k), expected) << "n " << n << " k " << k;
    }
  }
}

TEST_F(GpuExecutor, TeamsCompactInOrderLikeCub) {
  CudaExecutor ex;
  const unsigned device_blocks = cdt::gpu::detail::grid_team_blocks(grid_team_compactions);
  if (device_blocks == 0) GTEST_SKIP() << "this device cannot launch cooperative grids";
  // One block, grids of a few blocks (many tiles each, uneven ranges) and the device's whole grid (some
  // blocks with an empty range); lengths around a block's width and up to tens of tiles a block, small
  // enough for the sanitizers.
  for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{1023}, std::size_t{1025},
                              std::size_t{5000}, std::size_t{70'001}}) {
    const auto h = random_values<std::uint32_t>(n, 29 + n, 1000);
    for (const std::uint32_t k : {1u, 3u, 1001u}) { // all, a third, none
      std::vector<std::uint32_t> kept, even;
      for (std::size_t i = 0; i < n; ++i)
        if (h[i] % k == 0) kept.push_back(static_cast<std::uint32_t>(i));
      for (std::size_t j = 0; j < kept.size(); ++j)
        if (kept[j] % 2 == 0) even.push_back(static_cast<std::uint32_t>(j));
      for (const unsigned blocks : {0u, 3u, 7u, device_blocks}) {
        const auto [got_kept, got_even] = team_compacted(ex, h, k, blocks);
        EXPECT_EQ(got_kept, kept) << "n " << n << " k " << k << " blocks " << blocks;
        EXPECT_EQ(got_even, even) << "n " << n << " k " << k << " blocks " << blocks;
      }
    }
  }
}

TEST_F(GpuExecutor, SortKeysMatchesStdSort) {
  CudaExecutor ex;
  for (const std::size_t n : {std::size_t{2}, std::size_t{1000}, std::size_t{2'000'003}}) {
    auto h = random_values<std::uint32_t>(n, 3 * n, 0xFFFFFFFFull);
    DeviceBuffer<std::uint32_t> d = to_device(ex, h);
    ex.sort_keys(d.data(), n);
    std::sort(h.begin(), h.end());
    EXPECT_EQ(to_host(ex, d, n), h) << "n " << n;
  }
  auto h64 = random_values<std::uint64_t>(300000, 9, ~0ull);
  DeviceBuffer<std::uint64_t> d64 = to_device(ex, h64);
  ex.sort_keys(d64.data(), h64.size());
  std::sort(h64.begin(), h64.end());
  EXPECT_EQ(to_host(ex, d64, h64.size()), h64);
}

TEST_F(GpuExecutor, SortPairsIsAStableSortByKey) {
  CudaExecutor ex;
  const std::size_t n = 1'500'000;
  const auto keys = random_values<std::uint32_t>(n, 11, 5000); // many equal keys: stability shows
  std::vector<std::uint32_t> values(n);
  std::iota(values.begin(), values.end(), 0u);
  DeviceBuffer<std::uint32_t> d_keys = to_device(ex, keys);
  DeviceBuffer<std::uint32_t> d_values = to_device(ex, values);
  ex.sort_pairs(d_keys.data(), d_values.data(), n);
  std::stable_sort(values.begin(), values.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return keys[a] < keys[b]; });
  std::vector<std::uint32_t> sorted_keys(n);
  for (std::size_t i = 0; i < n; ++i) sorted_keys[i] = keys[values[i]];
  EXPECT_EQ(to_host(ex, d_keys, n), sorted_keys);
  EXPECT_EQ(to_host(ex, d_values, n), values);
}

// Millions of threads on a handful of words: the minimum must be exact and no thread may see a value
// below the final minimum of its slot or above its slot's starting value.
TEST_F(GpuExecutor, AtomicMinUnderContention) {
  CudaExecutor ex;
  const std::uint32_t slots = 7;
  const auto values = random_values<std::uint32_t>(4'000'000, 23, 0xFFFFFFF0ull);
  const auto [result, seen] = contended_minimum(ex, values, slots);
  std::vector<std::uint32_t> expected(slots, cdt::kNone);
  for (std::size_t i = 0; i < values.size(); ++i)
    expected[i % slots] = std::min(expected[i % slots], values[i]);
  EXPECT_EQ(result, expected);
  std::size_t bad = 0, saw_start = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    bad += seen[i] < expected[i % slots];
    saw_start += seen[i] == cdt::kNone;
  }
  EXPECT_EQ(bad, 0u);
  EXPECT_EQ(saw_start, slots) << "exactly one thread per slot finds it untouched";
}

TEST_F(GpuExecutor, MemoryCheckNamesTheInputAndTheShortfall) {
  const auto memory = cdt::gpu::detail::device_memory();
  ASSERT_GT(memory.total_bytes, 0u);
  try {
    cdt::gpu::detail::require_device_memory(memory.total_bytes + (std::size_t{1} << 30), 0,
                                            "a huge test input");
    ADD_FAILURE() << "no error for more memory than the device has";
  } catch (const cdt::DeviceError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("a huge test input"), std::string::npos) << what;
    EXPECT_NE(what.find("MiB"), std::string::npos) << what;
    EXPECT_NE(what.find("free"), std::string::npos) << what;
  }
  EXPECT_THROW(cdt::gpu::detail::require_device_memory(2 << 20, 1 << 20, "x"), cdt::DeviceError);
  EXPECT_NO_THROW(cdt::gpu::detail::require_device_memory(1 << 20, 2 << 20, "x"));
  EXPECT_NO_THROW(cdt::gpu::detail::require_device_memory(1 << 20, 0, "x"));
}

// An allocation beyond the device's memory is a DeviceError saying so (checked before cudaMalloc, so
// compute-sanitizer sees no failing call), and leaves the device usable.
TEST_F(GpuExecutor, AllocationBeyondTheDeviceIsADeviceError) {
  try {
    DeviceBuffer<std::uint8_t> too_big(std::size_t{1} << 52);
    ADD_FAILURE() << "a 4 PiB allocation succeeded";
  } catch (const cdt::DeviceError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot allocate 4294967296 MiB"), std::string::npos) << e.what();
  }
  CudaExecutor ex;
  const auto count = visits(ex, 100);
  EXPECT_EQ(std::count(count.begin(), count.end(), 1u), 100);
}

// Every failing CUDA call becomes a DeviceError naming the error, the call and the place.
TEST_F(GpuExecutor, CudaFailuresBecomeDeviceErrorsNamingTheCall) {
  try {
    CDT_CUDA_CHECK(cudaErrorInvalidValue);
    ADD_FAILURE() << "no error thrown";
  } catch (const cdt::DeviceError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("cudaErrorInvalidValue"), std::string::npos) << what;
    EXPECT_NE(what.find("executor_gpu_test.cu:"), std::string::npos) << what;
  }
}

// Large copies go through the pinned staging blocks in pieces, small ones directly: both must move
// every byte, also when an upload and a download follow each other.
TEST_F(GpuExecutor, LargeAndSmallCopiesRoundTrip) {
  CudaExecutor ex;
  for (const std::size_t n :
       {std::size_t{3}, std::size_t{2'097'152}, std::size_t{2'097'153}, std::size_t{9'000'001}}) {
    const auto h = random_values<std::uint32_t>(n, n, 0xFFFFFFFFull);
    DeviceBuffer<std::uint32_t> d = to_device(ex, h);
    const auto h2 = random_values<std::uint32_t>(n, n + 1, 0xFFFFFFFFull);
    DeviceBuffer<std::uint32_t> d2 = to_device(ex, h2); // reuses the staging blocks right away
    EXPECT_EQ(to_host(ex, d, n), h) << "n " << n;
    EXPECT_EQ(to_host(ex, d2, n), h2) << "n " << n;
  }
}

// p[i] the 400th step of a hash chain from i, p2[i] its complement: slow enough that a copy not waiting
// for it would read what was there before.
void make_slow_values(CudaExecutor& ex, std::uint32_t* p, std::uint32_t* p2, std::size_t n) {
  ex.for_each(n, [=] __device__(std::size_t i) {
    std::uint32_t h = static_cast<std::uint32_t>(i);
    for (int r = 0; r < 400; ++r) h = h * 2654435761u + 0x9E3779B9u;
    p[i] = h;
    p2[i] = h ^ 0xFFFFFFFFu;
  });
}

void fill_indices(CudaExecutor& ex, std::uint32_t* p, std::size_t n) {
  ex.for_each(n, [=] __device__(std::size_t i) { p[i] = static_cast<std::uint32_t>(i); });
}

// LateDownloads copy on a thread of their own what the stream made before start(), however long that
// takes, small copies and copies through the staging blocks alike; the destructor waits as wait() does.
TEST_F(GpuExecutor, LateDownloadsCopyWhatTheStreamMadeBeforeThem) {
  using cdt::gpu::detail::LateDownloads;
  CudaExecutor ex;
  for (const std::size_t n : {std::size_t{5}, std::size_t{9'000'001}}) {
    DeviceBuffer<std::uint32_t> d(n), d2(n), d3(n);
    std::uint32_t* p = d.data();
    std::uint32_t* p2 = d2.data();
    std::uint32_t* p3 = d3.data();
    make_slow_values(ex, p, p2, n);
    std::vector<std::uint32_t> h(n, 0), h2(n, 0);
    {
      LateDownloads late;
      late.add(h.data(), p, n);
      late.start();
      LateDownloads left; // waited for by its destructor alone
      left.add(h2.data(), p2, n);
      left.start();
      fill_indices(ex, p3, n); // the stream goes on meanwhile
      late.wait();
      late.wait(); // nothing left to wait for
    }
    const auto expect_made = [&](std::size_t i) {
      std::uint32_t want = static_cast<std::uint32_t>(i);
      for (int r = 0; r < 400; ++r) want = want * 2654435761u + 0x9E3779B9u;
      EXPECT_EQ(h[i], want) << "n " << n << ", element " << i;
      EXPECT_EQ(h2[i], want ^ 0xFFFFFFFFu) << "n " << n << ", element " << i;
    };
    for (std::size_t i = 0; i < n; i += n < 10000 ? 1 : 997) expect_made(i); // a sample of the long one
    expect_made(n - 1);
  }
}

TEST_F(GpuExecutor, DebugSyncStillGivesTheSameResults) {
  cdt::gpu::set_debug_sync(true);
  CudaExecutor ex;
  const auto h = random_values<std::uint32_t>(100000, 1, 50);
  const auto kept = compact_multiples_of(ex, h, 7);
  cdt::gpu::set_debug_sync(false);
  std::vector<std::uint32_t> expected;
  for (std::size_t i = 0; i < h.size(); ++i)
    if (h[i] % 7 == 0) expected.push_back(static_cast<std::uint32_t>(i));
  EXPECT_EQ(kept, expected);
}

/// Threads of this process, from /proc.
std::size_t threads_of_this_process() {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator("/proc/self/task")) ++n;
  return n;
}

// run_beside: tasks given while every side thread is busy get a thread of their own (two tasks that wait
// for each other both end), the threads stay and take later tasks, and a task's exception reaches the
// caller. No device needed: the side threads are host threads.
TEST(RunBeside, RunsTasksSideBySideOnThreadsThatStay) {
  using cdt::gpu::detail::run_beside;
  using namespace std::chrono_literals;
  std::promise<void> first_started, second_started;
  std::shared_future<void> first_up = first_started.get_future().share();
  std::shared_future<void> second_up = second_started.get_future().share();
  std::thread::id first_id, second_id;
  std::future<void> first = run_beside([&] {
    first_id = std::this_thread::get_id();
    first_started.set_value();
    if (second_up.wait_for(20s) != std::future_status::ready) throw std::runtime_error("second never ran");
  });
  std::future<void> second = run_beside([&] {
    second_id = std::this_thread::get_id();
    second_started.set_value();
    if (first_up.wait_for(20s) != std::future_status::ready) throw std::runtime_error("first never ran");
  });
  ASSERT_EQ(first.wait_for(30s), std::future_status::ready);
  ASSERT_EQ(second.wait_for(30s), std::future_status::ready);
  EXPECT_NO_THROW(first.get());
  EXPECT_NO_THROW(second.get());
  EXPECT_NE(first_id, second_id);
  EXPECT_NE(first_id, std::this_thread::get_id());
  // Its threads are idle again (counted so before their tasks' ends were told): later tasks, one after
  // another, run on them, not on new ones.
  const std::size_t threads_before = threads_of_this_process();
  for (int k = 0; k < 4; ++k) {
    std::thread::id id;
    run_beside([&] { id = std::this_thread::get_id(); }).get();
    EXPECT_NE(id, std::this_thread::get_id());
  }
  EXPECT_EQ(threads_of_this_process(), threads_before);
  std::future<void> failing = run_beside([] { throw std::runtime_error("the task's own failure"); });
  try {
    failing.get();
    ADD_FAILURE() << "the task's exception did not reach the caller";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "the task's own failure");
  }
}

} // namespace
