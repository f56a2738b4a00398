// Process-wide memory policy for large triangulations.
#include "cdt/cdt.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace cdt {

bool retain_freed_memory() noexcept {
#if defined(__GLIBC__)
  // No block gets its own mapping, and the heap's top is never given back (-1 turns trimming off): every
  // large array then comes from memory the process already touched once it has freed an earlier one.
  const bool no_maps = mallopt(M_MMAP_MAX, 0) == 1;
  const bool no_trim = mallopt(M_TRIM_THRESHOLD, -1) == 1;
  return no_maps && no_trim;
#else
  return false;
#endif
}

} // namespace cdt
