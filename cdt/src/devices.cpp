// Which devices the GPU backend can use.
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

} // namespace cdt
