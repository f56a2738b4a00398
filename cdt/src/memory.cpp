// Process-wide memory policy for large triangulations.
#include "cdt/cdt.hpp"

#include <cstdint>
#include <cstdlib>

#if defined(__GLIBC__)
#include <malloc.h>
#include <sys/mman.h>
#endif

namespace cdt {

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
