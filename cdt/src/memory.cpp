// Process-wide memory policy for large triangulations, and the pinned result memory.
#include "memory.hpp"

#include "cdt/cdt.hpp"

#include <cstdint>
#include <cstdlib>

#if defined(__GLIBC__)
#include <malloc.h>
#include <sys/mman.h>
#endif

#if defined(TRIXEL_HAVE_CUDA)
#include "cdt_kernels.hpp"
#endif

namespace cdt {

namespace detail {
namespace {
thread_local int pinned_scopes = 0; // PinnedResultScopes alive on this thread
} // namespace

PinnedResultScope::PinnedResultScope() noexcept { ++pinned_scopes; }
PinnedResultScope::~PinnedResultScope() { --pinned_scopes; }

void* take_pinned_array(std::size_t bytes) noexcept {
#if defined(TRIXEL_HAVE_CUDA)
  if (pinned_scopes > 0) return gpu::take_result_block(bytes);
#else
  (void)bytes;
#endif
  return nullptr;
}

bool give_back_pinned_array(void* p) noexcept {
#if defined(TRIXEL_HAVE_CUDA)
  return gpu::give_back_result_block(p);
#else
  (void)p;
  return false;
#endif
}
} // namespace detail

bool keep_pinned_results(std::size_t max_bytes) noexcept {
#if defined(TRIXEL_HAVE_CUDA)
  gpu::set_result_blocks_limit(max_bytes); // touches no CUDA call until a block is pinned or unpinned
  return true;
#else
  (void)max_bytes;
  return false;
#endif
}

bool retain_freed_memory(std::size_t huge_page_bytes) noexcept {
#if defined(__GLIBC__)
  // No block gets its own mapping, and the heap's top is never given back (-1 turns trimming off): every
  // large array then comes from memory the process already touched once it has freed an earlier one.
  const bool no_maps = mallopt(M_MMAP_MAX, 0) == 1;
  const bool no_trim = mallopt(M_TRIM_THRESHOLD, -1) == 1;
  if (!no_maps || !no_trim) return false;
  if (huge_page_bytes == 0) return true;
#if defined(MADV_HUGEPAGE)
  // A block as large as asked grows the heap's top (no block is mapped on its own now); freed, it stays
  // there (no trimming) with the advice on its whole 2 MiB pages, and later arrays are carved from it.
  void* block = std::malloc(huge_page_bytes);
  if (block == nullptr) return false;
  constexpr std::uintptr_t kHugePage = std::uintptr_t{2} << 20;
  const auto begin = (reinterpret_cast<std::uintptr_t>(block) + kHugePage - 1) & ~(kHugePage - 1);
  const auto end = (reinterpret_cast<std::uintptr_t>(block) + huge_page_bytes) & ~(kHugePage - 1);
  const bool advised =
      end > begin && madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE) == 0;
  std::free(block);
  return advised;
#else
  return false;
#endif
#else
  (void)huge_page_bytes;
  return false;
#endif
}

} // namespace cdt
