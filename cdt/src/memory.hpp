#pragma once
// The pinned result memory (keep_pinned_results) as the triangulation uses it.

namespace cdt::detail {

/// While one is alive on a thread, large arrays that thread allocates with DefaultInitAllocator come
/// from the pinned result memory, when the process keeps it and has room (the GPU backend's output
/// arrays, set aside at the start of a triangulation). Nests.
class PinnedResultScope {
public:
  PinnedResultScope() noexcept;
  ~PinnedResultScope();
  PinnedResultScope(const PinnedResultScope&) = delete;
  PinnedResultScope& operator=(const PinnedResultScope&) = delete;
};

} // namespace cdt::detail
