// Tests of retain_freed_memory(): the process-wide memory policy for large triangulations. Each runs in
// a child process (a death test's), so that the policy never reaches the other tests. And of the
// pinned result memory's fallback (keep_pinned_results; its blocks are tested on the device).

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "cdt/cdt.hpp"
#include "memory.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#include <unistd.h>
#endif

namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kGlibcAllocator = false; // AddressSanitizer's allocator serves malloc
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kGlibcAllocator = false;
#else
constexpr bool kGlibcAllocator = true;
#endif
#else
constexpr bool kGlibcAllocator = true;
#endif

#if defined(__GLIBC__)

/// Whether every byte of [begin, end) lies in mappings of this process whose VmFlags hold `flag`
/// (/proc/self/smaps); false when that file cannot be read.
bool mapped_with_flag(std::uintptr_t begin, std::uintptr_t end, const std::string& flag) {
  std::ifstream smaps("/proc/self/smaps");
  if (!smaps) return false;
  std::string line;
  std::uintptr_t lo = 0, hi = 0, covered_to = begin;
  while (std::getline(smaps, line)) {
    unsigned long long a = 0, b = 0;
    if (std::sscanf(line.c_str(), "%llx-%llx ", &a, &b) == 2 && line.find(':') > line.find('-')) {
      lo = a;
      hi = b;
    } else if (line.rfind("VmFlags:", 0) == 0) {
      std::istringstream words(line.substr(8));
      bool has = false;
      for (std::string w; words >> w;) has = has || w == flag;
      // Mappings come in address order: extend the covered prefix of the range.
      if (has && lo <= covered_to && hi > covered_to) covered_to = hi;
    }
  }
  return covered_to >= end;
}

TEST(RetainFreedMemory, LargeBlocksComeFromTheHeapAndItIsNeverTrimmed) {
  if (!kGlibcAllocator) GTEST_SKIP() << "malloc is not glibc's in this build";
  EXPECT_EXIT(
      {
        if (!cdt::retain_freed_memory()) std::exit(2);
        // Far above the default mapping threshold: without the policy this block is a mapping of its
        // own, far above the heap, and returned to the system when freed.
        constexpr std::size_t kBytes = std::size_t{64} << 20;
        void* block = std::malloc(kBytes);
        if (block == nullptr) std::exit(3);
        if (reinterpret_cast<std::uintptr_t>(block) + kBytes > reinterpret_cast<std::uintptr_t>(sbrk(0)))
          std::exit(4); // not inside the heap
        void* const grown = sbrk(0);
        std::free(block);
        if (sbrk(0) != grown) std::exit(5); // the heap's top was given back
        // The same memory serves the next large block.
        void* again = std::malloc(kBytes);
        if (again != block) std::exit(6);
        std::free(again);
        std::exit(0);
      },
      ::testing::ExitedWithCode(0), "");
}

/// Whether the kernel lets a process advise huge pages (transparent huge pages not "never").
bool huge_pages_can_be_advised() {
  std::ifstream f("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string modes;
  return std::getline(f, modes) && modes.find("[never]") == std::string::npos;
}

TEST(RetainFreedMemory, HugePagesAdviceCoversTheHeapItGrew) {
  if (!kGlibcAllocator) GTEST_SKIP() << "malloc is not glibc's in this build";
  if (!huge_pages_can_be_advised()) GTEST_SKIP() << "transparent huge pages are off on this machine";
  EXPECT_EXIT(
      {
        malloc_trim(0); // the heap's free top is now small: the block below begins near its end
        void* const top = sbrk(0);
        constexpr std::size_t kBytes = std::size_t{32} << 20;
        if (!cdt::retain_freed_memory(kBytes)) std::exit(4);
        constexpr std::uintptr_t kHugePage = std::uintptr_t{2} << 20;
        // The advised block began within a huge page below the old top, so its whole 2 MiB pages
        // hold [begin + 2 MiB, begin + kBytes - 4 MiB), whatever its alignment.
        const auto begin = (reinterpret_cast<std::uintptr_t>(top) + kHugePage - 1) & ~(kHugePage - 1);
        const std::uintptr_t end = begin + kBytes - 2 * kHugePage;
        if (reinterpret_cast<std::uintptr_t>(sbrk(0)) < end) std::exit(2); // the heap did not grow
        std::exit(mapped_with_flag(begin + kHugePage, end, "hg") ? 0 : 3);
      },
      ::testing::ExitedWithCode(0), "");
}

#endif

// With the pinned result memory kept, large arrays allocated where the triangulation sets its output
// aside (from a pinned block where there is a device) and elsewhere hold what is written to them and are
// freed like any other. Without CUDA the memory is never kept. In a child process: a device there starts
// CUDA, which the death tests' forks must not inherit. Returns 0 when every check passed, else which one
// failed.
int large_arrays_in_and_out_of_the_scope() {
  const bool kept = cdt::keep_pinned_results(std::size_t{64} << 20);
  using Words = std::vector<std::uint32_t, cdt::DefaultInitAllocator<std::uint32_t>>;
  constexpr std::size_t kWords = cdt::detail::kPinnedArrayBytes / sizeof(std::uint32_t) + 1;
  for (const bool in_scope : {true, false}) {
    Words words;
    {
      std::optional<cdt::detail::PinnedResultScope> scope;
      if (in_scope) scope.emplace();
      words.reserve(kWords);
    }
    words.resize(kWords);
    for (std::size_t k = 0; k < kWords; ++k) words[k] = static_cast<std::uint32_t>(k * 2654435761u);
    const Words moved = std::move(words);
    if (moved.size() != kWords) return 2;
    for (std::size_t k = 0; k < kWords; ++k)
      if (moved[k] != static_cast<std::uint32_t>(k * 2654435761u)) return 3;
  }
  return cdt::keep_pinned_results(0) == kept ? 0 : 4;
}

TEST(KeepPinnedResults, LargeArraysHoldTheirValuesInAndOutOfTheScope) {
  EXPECT_EXIT(std::exit(large_arrays_in_and_out_of_the_scope()), ::testing::ExitedWithCode(0), "");
}

} // namespace
