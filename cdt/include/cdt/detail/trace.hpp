#pragma once
// Step timings for profiling the pipeline from the outside: with the environment variable
// TRIXEL_CDT_TRACE set (to anything but 0), every mark() prints the milliseconds since the last one
// to stderr, as "trace <scope>: <step> <ms>", and count() a size. Costs one clock read per mark
// otherwise nothing.

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace cdt::detail {

inline bool trace_enabled() {
  static const bool on = [] {
    const char* v = std::getenv("TRIXEL_CDT_TRACE");
    return v != nullptr && v[0] != '\0' && std::strcmp(v, "0") != 0;
  }();
  return on;
}

class StepTrace {
public:
  explicit StepTrace(const char* scope) : scope_(scope), on_(trace_enabled()), last_(Clock::now()) {}
  void mark(const char* step) {
    if (!on_) return;
    const auto now = Clock::now();
    std::fprintf(stderr, "trace %s: %s %.1f\n", scope_, step,
                 std::chrono::duration<double, std::milli>(now - last_).count());
    last_ = now;
  }
  /// Prints "trace <scope>: <what> = <n>" (a size worth knowing beside the times), costing no time mark.
  void count(const char* what, unsigned long long n) const {
    if (on_) std::fprintf(stderr, "trace %s: %s = %llu\n", scope_, what, n);
  }

private:
  using Clock = std::chrono::steady_clock;
  const char* scope_;
  bool on_;
  Clock::time_point last_;
};

} // namespace cdt::detail
