#include "cpu_level.hpp"

#include <atomic>
#include <cstdlib>
#include <cstring>

namespace vectorize::detail {
namespace {

std::atomic<bool> g_allowed{true};

bool cpu_has_v3() noexcept {
#if TRIXEL_HAVE_V3_LOOPS
  static const bool has = [] {
    __builtin_cpu_init();
    const char* baseline = std::getenv("TRIXEL_CPU_BASELINE");
    const bool refused = baseline != nullptr && std::strcmp(baseline, "1") == 0;
    return !refused && __builtin_cpu_supports("x86-64-v3") != 0;
  }();
  return has;
#else
  return false;
#endif
}

} // namespace

bool v3_loops() noexcept { return cpu_has_v3() && g_allowed.load(std::memory_order_relaxed); }

void set_v3_loops(bool allowed) noexcept { g_allowed.store(allowed, std::memory_order_relaxed); }

} // namespace vectorize::detail
