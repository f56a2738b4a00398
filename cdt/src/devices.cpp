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
    return true;
  } catch (...) {
    return false;
  }
}

} // namespace cdt
