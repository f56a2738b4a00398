#pragma once
// The executor's steps inside one thread block or one cooperative grid: for the rounds of a round
// loop whose lists are too short to fill the device, where a round of separate launches (each a few
// microseconds of the host's time, with a wait for every count) costs far more than its work. One
// block (the last rounds) or one grid of resident blocks (the middle ones) runs such rounds back to
// back, its barriers taking the place of the launches' boundaries and its ordered compaction the place
// of CUB's, so the rounds are the same as the launches would make.

#include <cooperative_groups.h>
#include <cub/block/block_scan.cuh>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <optional>
#include <type_traits>

#include "cuda_check.cuh"

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

/// The block's steps as a team: one block of kBlockRoundThreads threads that runs rounds alone. The
/// round loops are written once over a team (this or GridTeam): for_each, sync, ordered compact, a
/// leader for the results, and `word`, a word every thread of the team sees (here in shared memory).
struct BlockTeam {
  BlockCompactStorage& storage;
  std::uint32_t* word;
  __device__ bool leader() const { return threadIdx.x == 0; }
  __device__ void sync() const { __syncthreads(); }
  /// The word as the team left it at its last barrier.
  __device__ std::uint32_t word_value() const { return *static_cast<volatile std::uint32_t*>(word); }
  template <class F>
  __device__ void for_each(std::uint32_t n, F f) const {
    block_for_each(n, f);
  }
  template <class Pred>
  __device__ std::uint32_t compact(std::uint32_t n, Pred keep, std::uint32_t* out) const {
    return block_compact(n, keep, out, storage);
  }
};

/// Blocks of a GridTeam at most (its compaction sums the blocks' counts in one block scan).
constexpr unsigned kMaxGridTeamBlocks = kBlockRoundThreads;

/// The whole grid of a cooperative launch (every block resident at once) as one team, for the middle
/// rounds of a loop: lists too long for one block and too short to fill the device, where a round of
/// separate launches costs 100-150 microseconds of the host's launches and waits whatever its work. Its
/// barrier is the grid's, its compaction ordered like CUB's (each block takes a contiguous range of
/// the indices, counts what it keeps, and writes after the counts of the blocks before it), so the
/// rounds are the ones the launches would make. `counts` holds kMaxGridTeamBlocks words and `word`
/// one, in device memory.
struct GridTeam {
  BlockCompactStorage& storage;
  std::uint32_t* counts;
  std::uint32_t* word;
  __device__ bool leader() const { return blockIdx.x == 0 && threadIdx.x == 0; }
  __device__ void sync() const { cooperative_groups::this_grid().sync(); }
  /// The word as the team left it at its last barrier (read from memory, not from a cached copy).
  __device__ std::uint32_t word_value() const { return *static_cast<volatile std::uint32_t*>(word); }
  template <class F>
  __device__ void for_each(std::uint32_t n, F f) const {
    const std::uint32_t stride = gridDim.x * kBlockRoundThreads;
    for (std::uint32_t i = blockIdx.x * kBlockRoundThreads + threadIdx.x; i < n; i += stride) f(i);
  }
  /// Writes the i in [0, n) with keep(i) to out in increasing order and returns how many, to every
  /// thread; keep is called twice per index (counting, then writing), so it must not change between.
  /// Ends with the grid's barrier.
  template <class Pred>
  __device__ std::uint32_t compact(std::uint32_t n, Pred keep, std::uint32_t* out) const {
    using Scan = cub::BlockScan<std::uint32_t, kBlockRoundThreads>;
    const std::uint32_t tiles = (n + kBlockRoundThreads - 1) / kBlockRoundThreads;
    const std::uint32_t span = (tiles + gridDim.x - 1) / gridDim.x * kBlockRoundThreads;
    const std::uint32_t begin = min(n, blockIdx.x * span);
    const std::uint32_t end = min(n, begin + span);
    std::uint32_t kept = 0;
    for (std::uint32_t i = begin + threadIdx.x; i < end; i += kBlockRoundThreads) kept += keep(i) ? 1u : 0u;
    std::uint32_t ignored = 0, block_kept = 0;
    Scan(storage.scan).ExclusiveSum(kept, ignored, block_kept);
    if (threadIdx.x == 0) counts[blockIdx.x] = block_kept;
    sync();
    // The blocks before this one, then all of them: each total goes to every thread of the block.
    const std::uint32_t count = threadIdx.x < gridDim.x ? counts[threadIdx.x] : 0u;
    std::uint32_t base = 0, total = 0;
    Scan(storage.scan).ExclusiveSum(threadIdx.x < blockIdx.x ? count : 0u, ignored, base);
    __syncthreads();
    Scan(storage.scan).ExclusiveSum(count, ignored, total);
    for (std::uint32_t first = begin; first < end; first += kBlockRoundThreads) {
      const std::uint32_t i = first + threadIdx.x;
      const std::uint32_t flag = i < end && keep(i) ? 1u : 0u;
      std::uint32_t position = 0, tile_kept = 0;
      __syncthreads(); // the scan's storage is used again
      Scan(storage.scan).ExclusiveSum(flag, position, tile_kept);
      if (flag != 0) out[base + position] = i;
      base += tile_kept;
    }
    sync();
    return total;
  }
};

/// Blocks of a cooperative grid of `kernel` (kBlockRoundThreads threads each, no dynamic shared
/// memory): one per multiprocessor (two per multiprocessor made the rounds slower: the grid's barrier
/// costs more), or 0 when the current device cannot launch such a grid. Computed once per device and
/// kernel.
template <class Kernel>
unsigned grid_team_blocks(Kernel kernel) {
  constexpr int kDevices = 64;
  static std::atomic<int> known[kDevices] = {};
  int device = 0;
  if (cudaGetDevice(&device) != cudaSuccess || device < 0 || device >= kDevices) return 0;
  int blocks = known[device].load(std::memory_order_relaxed);
  if (blocks == 0) {
    int cooperative = 0, sms = 0, per_sm = 0;
    if (cudaDeviceGetAttribute(&cooperative, cudaDevAttrCooperativeLaunch, device) != cudaSuccess ||
        cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device) != cudaSuccess ||
        cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, kernel, kBlockRoundThreads, 0) != cudaSuccess)
      cooperative = 0;
    blocks = cooperative != 0 && per_sm > 0 ? std::min(sms, static_cast<int>(kMaxGridTeamBlocks)) : -1;
    known[device].store(blocks, std::memory_order_relaxed);
  }
  return blocks > 0 ? static_cast<unsigned>(blocks) : 0u;
}

/// A GridTeam's device words: the blocks' counts and the team's word.
struct GridTeamScratch {
  DeviceBuffer<std::uint32_t> words{kMaxGridTeamBlocks + 1};
  std::uint32_t* counts() { return words.data(); }
  std::uint32_t* word() { return words.data() + kMaxGridTeamBlocks; }
};

/// Launches kernel(args...) as a cooperative grid of `blocks` blocks of kBlockRoundThreads threads on
/// `stream` (checked like every launch). The arguments are converted to the kernel's parameter types
/// here, as a launch with <<<>>> would: the launch copies them by address.
template <class... Params>
void launch_grid_team(void (*kernel)(Params...), unsigned blocks, cudaStream_t stream, const char* name,
                      std::type_identity_t<Params>... args) {
  void* params[] = {static_cast<void*>(&args)...};
  CDT_CUDA_CHECK(cudaLaunchCooperativeKernel(reinterpret_cast<const void*>(kernel), dim3(blocks),
                                             dim3(kBlockRoundThreads), params, 0, stream));
  check_launch(name, __FILE__, __LINE__);
}

/// A round loop's kernel for lists of at most kBlockLimit elements, in one block. Loop{}(team, a, lo,
/// hi, end) runs the loop's rounds by `team` while its list has more than lo and at most hi elements,
/// and leaves what the host needs in *end.
template <class Loop, class Args, class End, std::uint32_t kBlockLimit>
__global__ void __launch_bounds__(kBlockRoundThreads) rounds_in_block(Args a, End* end) {
  __shared__ BlockCompactStorage storage;
  __shared__ std::uint32_t word;
  Loop{}(BlockTeam{storage, &word}, a, 0, kBlockLimit, end);
}

/// The same loop's kernel for lists of more than kBlockLimit and at most kGridLimit elements, as a
/// cooperative grid.
template <class Loop, class Args, class End, std::uint32_t kBlockLimit, std::uint32_t kGridLimit>
__global__ void __launch_bounds__(kBlockRoundThreads)
    rounds_in_grid(Args a, End* end, std::uint32_t* counts, std::uint32_t* word) {
  __shared__ BlockCompactStorage storage;
  Loop{}(GridTeam{storage, counts, word}, a, kBlockLimit, kGridLimit, end);
}

/// The host's side of a round loop that runs its short lists in one block and its middle ones in a
/// cooperative grid (where the device can launch one); longer lists are the caller's, as launches.
template <class Loop, class Args, class End, std::uint32_t kBlockLimit, std::uint32_t kGridLimit>
class TeamRounds {
public:
  TeamRounds() : grid_blocks_(grid_team_blocks(rounds_in_grid<Loop, Args, End, kBlockLimit, kGridLimit>)) {}

  /// Whether a list of n elements runs in the block or the grid.
  bool takes(std::uint32_t n) const { return n <= kBlockLimit || (grid_blocks_ != 0 && n <= kGridLimit); }

  /// Launches the rounds on a list of n elements that takes() accepts (nothing waits for them). `name`
  /// names the launch in errors.
  void launch(std::uint32_t n, const Args& args, End* end, cudaStream_t stream, const char* name) {
    if (n <= kBlockLimit) {
      rounds_in_block<Loop, Args, End, kBlockLimit><<<1, kBlockRoundThreads, 0, stream>>>(args, end);
      check_launch(name, __FILE__, __LINE__);
      return;
    }
    if (!scratch_) scratch_.emplace();
    launch_grid_team(rounds_in_grid<Loop, Args, End, kBlockLimit, kGridLimit>, grid_blocks_, stream, name,
                     args, end, scratch_->counts(), scratch_->word());
  }

private:
  unsigned grid_blocks_;
  std::optional<GridTeamScratch> scratch_;
};

} // namespace cdt::gpu::detail
