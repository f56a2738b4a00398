// Throughput of the exact predicates on the host (one thread) and, when built with CUDA and a device is
// present, on the GPU (end to end: upload, kernel, download). Two query mixes: random points, which the
// floating-point filter decides, and near-degenerate points (on a lattice, co-circular or a few ulps
// off a line), which take the exact path.
//
// usage: bench_predicates [num_queries]        prints Markdown table rows

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "cdt/detail/predicates.hpp"
#if defined(TRIXEL_HAVE_CUDA)
#include "cdt_kernels.hpp"
#endif

namespace {

struct Rng {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double unit() { return static_cast<double>(next() >> 11) / 9007199254740992.0; }
};

std::vector<double> make_queries(std::size_t num, int per_query, bool degenerate) {
  Rng rng{degenerate ? 2u : 1u};
  std::vector<double> coords(num * per_query);
  for (auto& c : coords) {
    // Degenerate mix: small integer lattice translated far away, so differences are exact but the
    // filter cannot decide the many collinear and co-circular cases.
    c = degenerate ? 1048576.0 + static_cast<double>(rng.next() % 5) : rng.unit() * 1000.0;
  }
  return coords;
}

template <class F>
double median_ms(int repeats, F&& f) {
  std::vector<double> times;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    times.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(times.begin(), times.end());
  return times[times.size() / 2];
}

void row(const char* name, const char* mix, const char* backend, std::size_t num, double ms, long checksum) {
  std::printf("| %s | %s | %s | %zu | %.2f | %.1f | %ld |\n", name, mix, backend, num, ms, num / ms / 1e3,
              checksum);
}

} // namespace

int main(int argc, char** argv) {
  const std::size_t num = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 1000000;
  std::printf("| predicate | mix | backend | queries | median ms | M queries/s | sum of signs |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- |\n");
  for (const bool degenerate : {false, true}) {
    const char* mix = degenerate ? "near-degenerate" : "random";
    const auto orient = make_queries(num, 6, degenerate);
    const auto circle = make_queries(num, 8, degenerate);
    std::vector<int> signs(num);
    auto sum = [&] {
      long s = 0;
      for (int v : signs) s += v;
      return s;
    };

    double ms = median_ms(3, [&] {
      for (std::size_t i = 0; i < num; ++i) {
        const double* c = &orient[6 * i];
        signs[i] = cdt::detail::orient2d(c[0], c[1], c[2], c[3], c[4], c[5]);
      }
    });
    const long host_orient = sum();
    row("orient2d", mix, "cpu, 1 thread", num, ms, host_orient);
    ms = median_ms(3, [&] {
      for (std::size_t i = 0; i < num; ++i) {
        const double* c = &circle[8 * i];
        signs[i] = cdt::detail::incircle(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]);
      }
    });
    const long host_circle = sum();
    row("incircle", mix, "cpu, 1 thread", num, ms, host_circle);

#if defined(TRIXEL_HAVE_CUDA)
    if (cdt::gpu::device_count() > 0) {
      cdt::gpu::orient2d_signs(orient.data(), signs.data(), num); // warm-up: context and module load
      ms = median_ms(5, [&] { cdt::gpu::orient2d_signs(orient.data(), signs.data(), num); });
      row("orient2d", mix, "gpu, with transfers", num, ms, sum());
      if (sum() != host_orient) std::fprintf(stderr, "MISMATCH: orient2d gpu vs cpu\n");
      ms = median_ms(5, [&] { cdt::gpu::incircle_signs(circle.data(), signs.data(), num); });
      row("incircle", mix, "gpu, with transfers", num, ms, sum());
      if (sum() != host_circle) std::fprintf(stderr, "MISMATCH: incircle gpu vs cpu\n");
    }
#endif
  }
#if defined(TRIXEL_HAVE_CUDA)
  // What the exact fallback costs in device memory: the driver reserves this much for every thread
  // the device can hold once a kernel that may take the fallback runs.
  if (cdt::gpu::device_count() > 0)
    std::printf("\nincircle kernel: %zu bytes of local memory a thread\n", cdt::gpu::incircle_local_bytes());
#endif
  return 0;
}
