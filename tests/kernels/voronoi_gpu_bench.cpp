// Benchmark of Phase 1 of gCD (the amended digital Voronoi diagram): the CUDA executor against the CPU
// executor on the same machine and the same grid sites, checking that both give the same colouring.
//
//   bench_voronoi_gpu [--sizes 1024,2048,4096,8192] [--repeat 5] [--threads 0]
//
// Prints a Markdown table: the grid sites' time on the CPU executor (once; both executors start from
// them), the median of --repeat runs of each executor (the device's first call, which creates the
// CUDA context, is not timed), the device's steps by CUDA events, and cells per second.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "cdt_kernels.hpp"
#include "executor/cpu_executor.hpp"
#include "gcd/grid_map.hpp"
#include "gcd/voronoi.hpp"

namespace {

using Clock = std::chrono::steady_clock;

std::uint64_t mix(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
double unit(std::uint64_t k) { return static_cast<double>(mix(k) >> 11) * 0x1.0p-53; }

/// n points, uniform in the unit square or in 16 Gaussian clusters (sigma 0.02) over a 10% uniform
/// background.
void make_points(bool clustered, std::size_t n, std::vector<double>& x, std::vector<double>& y) {
  x.resize(n);
  y.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!clustered || i % 10 == 0) {
      x[i] = unit(4 * i);
      y[i] = unit(4 * i + 1);
      continue;
    }
    const std::uint64_t c = mix(i) % 16;
    const double r = 0.02 * std::sqrt(-2.0 * std::log(1.0 - unit(4 * i + 2)));
    const double a = 6.283185307179586 * unit(4 * i + 3);
    x[i] = unit(1000 + 2 * c) + r * std::cos(a);
    y[i] = unit(1001 + 2 * c) + r * std::sin(a);
  }
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

template <class F>
double time_ms(F&& f) {
  const auto t0 = Clock::now();
  f();
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

} // namespace

int main(int argc, char** argv) {
  std::vector<std::uint32_t> sizes = {1024, 2048, 4096, 8192};
  int repeat = 5;
  unsigned threads = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--sizes" && i + 1 < argc) {
      sizes.clear();
      const std::string list = argv[++i];
      for (std::size_t at = 0; at < list.size();) {
        const std::size_t comma = std::min(list.find(',', at), list.size());
        sizes.push_back(static_cast<std::uint32_t>(std::stoul(list.substr(at, comma - at))));
        at = comma + 1;
      }
    } else if (arg == "--repeat" && i + 1 < argc) {
      repeat = std::max(1, std::atoi(argv[++i]));
    } else if (arg == "--threads" && i + 1 < argc) {
      threads = static_cast<unsigned>(std::atoi(argv[++i]));
    } else {
      std::fprintf(stderr, "usage: %s [--sizes 1024,2048,...] [--repeat N] [--threads N]\n", argv[0]);
      return 2;
    }
  }
  if (cdt::gpu::device_count() == 0) {
    std::fprintf(stderr, "bench_voronoi_gpu: no CUDA device\n");
    return 1;
  }
  cdt::detail::CpuExecutor executor(threads);
  std::printf("device: %s; CPU executor: %u threads; median of %d runs\n\n",
              cdt::gpu::device_description().c_str(), executor.threads(), repeat);
  std::printf(
      "| m | layout | points | debris | sites (CPU) ms | CPU ms | GPU ms | upload | PBA | amend | download "
      "| CPU/GPU | GPU Mcells/s | same |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  bool all_same = true;
  bool warmed = false;
  for (const std::uint32_t m : sizes) {
    for (const bool clustered : {false, true}) {
      // One point per four cells (choose_grid_size picks m ~ sqrt(n) up to 2048: one to four cells per
      // point; past 2048, a quarter to one).
      const std::size_t n = static_cast<std::size_t>(m) * m / 4;
      std::vector<double> x, y;
      make_points(clustered, n, x, y);
      const auto mapping = cdt::detail::make_grid_mapping(x, y, m);
      cdt::detail::GridSites sites;
      const double assign_ms = time_ms([&] { sites = cdt::detail::assign_sites(mapping, x, y, executor); });
      std::vector<std::uint32_t> cpu, gpu;
      if (!warmed) {
        gpu = cdt::gpu::compute_digital_voronoi(sites.cell_owner, sites.gx, sites.gy, m);
        warmed = true;
      }
      std::vector<double> cpu_ms, gpu_ms, up, pba, amend, down;
      cdt::gpu::VoronoiStats stats;
      for (int r = 0; r < repeat; ++r) {
        cpu_ms.push_back(time_ms([&] { cpu = cdt::detail::compute_digital_voronoi(sites, m, executor); }));
        gpu_ms.push_back(time_ms([&] {
          gpu = cdt::gpu::compute_digital_voronoi(sites.cell_owner, sites.gx, sites.gy, m, {}, &stats);
        }));
        up.push_back(stats.upload_ms);
        pba.push_back(stats.pba_ms);
        amend.push_back(stats.amend_ms);
        down.push_back(stats.download_ms);
      }
      const bool same = cpu == gpu;
      all_same = all_same && same;
      const double g = median(gpu_ms);
      const double cells = static_cast<double>(m) * m;
      std::printf(
          "| %u | %s | %zu | %llu | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.0f | %s |\n", m,
          clustered ? "clustered" : "uniform", n, static_cast<unsigned long long>(stats.debris), assign_ms,
          median(cpu_ms), g, median(up), median(pba), median(amend), median(down), median(cpu_ms) / g,
          cells / (g * 1e3), same ? "yes" : "NO");
      std::fflush(stdout);
    }
  }
  return all_same ? 0 : 1;
}
