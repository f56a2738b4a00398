// Which devices the GPU backend can use, and starting CUDA ahead of the first triangulation.
#include <array>

#include "cdt/cdt.hpp"

#if defined(TRIXEL_HAVE_CUDA)
#include "cdt_kernels.hpp"
#endif

namespace cdt {

int gpu_device_count() noexcept {
#if defined(TRIXEL_HAVE_CUDA)
  return gpu::device_count();
#else
  return 0;
#endif
}

bool start_gpu() noexcept {
  if (gpu_device_count() == 0) return false;
  // A small PSLG with a segment crossing another and points on a segment: the triangulation goes
  // through every phase, which loads the kernels a small input launches (CUDA loads each kernel on its
  // first launch; a large input's first rounds may still load a few).
  const std::array<Point, 12> points = {
      {{0, 0}, {8, 0}, {8, 8}, {0, 8}, {1, 1}, {7, 7}, {1, 7}, {7, 1}, {4, 2}, {2, 5}, {6, 5}, {4, 4}}};
  const std::array<Segment, 4> segments = {{{4, 5}, {6, 7}, {0, 2}, {8, 9}}};
  Options options;
  options.backend = Backend::gpu;
  try {
    (void)triangulate(points, segments, options);
  } catch (...) {
    return false;
  }
#if defined(TRIXEL_HAVE_CUDA)
  // What the first triangulations of a few hundred thousand points each, on two threads, would
  // otherwise allocate on the way: a pinned staging block each for their uploads, and device memory.
  // Without this, the first two calls of a batch of photographs took 100-200 ms more than the others
  // (H200 machine). Best effort: the memory is only set aside, and a failure here changes nothing.
  try {
    constexpr std::size_t kStagingBlocks = 2;
    constexpr std::size_t kDeviceBytes = std::size_t{256} << 20;
    gpu::reserve_memory(kStagingBlocks, kDeviceBytes);
  } catch (...) {
  }
#endif
  return true;
}

void stop_gpu() noexcept {
#if defined(TRIXEL_HAVE_CUDA)
  if (gpu_device_count() > 0) gpu::release_device();
#endif
}

} // namespace cdt
