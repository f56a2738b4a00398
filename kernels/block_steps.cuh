#pragma once
// The executor's steps inside one thread block: for the last rounds of a round loop, whose lists are
// so short that a round of separate launches (each a few microseconds of the host's time, with a wait
// for every count) costs far more than its work. A single block runs such rounds back to back, its
// barriers taking the place of the launches' boundaries and its ordered compaction the place of CUB's,
// so the rounds are the same as the launches would make.

#include <cub/block/block_scan.cuh>

#include <cstdint>

namespace cdt::gpu::detail {

/// Threads of a block that runs rounds alone.
constexpr unsigned kBlockRoundThreads = 1024;

/// The shared memory of block_compact.
struct BlockCompactStorage {
  typename cub::BlockScan<std::uint32_t, kBlockRoundThreads>::TempStorage scan;
};

/// Every thread of the block calls f(i) for its share of i in [0, n).
template <class F>
__device__ __forceinline__ void block_for_each(std::uint32_t n, F f) {
  for (std::uint32_t i = threadIdx.x; i < n; i += kBlockRoundThreads) f(i);
}

/// Ordered stream compaction by the whole block (every thread must call it with the same n): writes the
/// i in [0, n) with keep(i) to out in increasing order and returns how many, to every thread. Ends
/// with a barrier, so out is visible to the block on return.
template <class Pred>
__device__ std::uint32_t block_compact(std::uint32_t n, Pred keep, std::uint32_t* out,
                                       BlockCompactStorage& storage) {
  std::uint32_t base = 0;
  for (std::uint32_t first = 0; first < n; first += kBlockRoundThreads) {
    const std::uint32_t i = first + threadIdx.x;
    const std::uint32_t flag = i < n && keep(i) ? 1u : 0u;
    std::uint32_t position = 0, total = 0;
    cub::BlockScan<std::uint32_t, kBlockRoundThreads>(storage.scan).ExclusiveSum(flag, position, total);
    if (flag != 0) out[base + position] = i;
    base += total;
    __syncthreads(); // the scan's storage is used again
  }
  __syncthreads();
  return base;
}

/// Exclusive prefix sum of in[0, n) into out[0, n) by the whole block (every thread must call it with
/// the same n); returns the total to every thread. Ends with a barrier.
__device__ inline std::uint32_t block_exclusive_scan(const std::uint32_t* in, std::uint32_t* out,
                                                     std::uint32_t n, BlockCompactStorage& storage) {
  std::uint32_t base = 0;
  for (std::uint32_t first = 0; first < n; first += kBlockRoundThreads) {
    const std::uint32_t i = first + threadIdx.x;
    const std::uint32_t value = i < n ? in[i] : 0u;
    std::uint32_t sum = 0, total = 0;
    cub::BlockScan<std::uint32_t, kBlockRoundThreads>(storage.scan).ExclusiveSum(value, sum, total);
    if (i < n) out[i] = base + sum;
    base += total;
    __syncthreads();
  }
  __syncthreads();
  return base;
}

} // namespace cdt::gpu::detail
