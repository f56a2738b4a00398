#pragma once
// The state of gpu::DeviceVoronoi, shared by the files that implement its steps: Phase 1 computes the
// colouring into these buffers (voronoi_kernels.cu), Phase 2 reads it there (dual_kernels.cu).

#include <cstddef>
#include <cstdint>

#include "cdt_kernels.hpp"
#include "cuda_check.cuh"
#include "cuda_executor.cuh"

namespace cdt::gpu {
namespace detail {

/// Device buffers of one computation. The m*m buffers change roles between the steps (see below) so
/// that the estimate of voronoi_device_bytes holds for any number of debris.
struct VoronoiBuffers {
  DeviceBuffer<std::uint32_t>
      owner; ///< cell owners; after step 2: the debris' old colours, then the flood's next colours
  DeviceBuffer<std::uint32_t> colour;     ///< PBA's column and site output; after step 2: the colouring
  DeviceBuffer<std::uint32_t> stack;      ///< PBA's stacks; after step 1: the list of debris cells
  DeviceBuffer<std::uint32_t> stack_size; ///< PBA
  DeviceBuffer<std::uint32_t> above, below;
  DeviceBuffer<std::uint32_t> site_x, site_y;
  DeviceBuffer<std::uint8_t> successors; ///< per debris of the last round: which neighbours became debris
};

} // namespace detail

struct DeviceVoronoi::State {
  detail::CudaExecutor executor; // declared first: destroyed after the buffers queued on its stream
  detail::VoronoiBuffers buffers;
  std::uint32_t m = 0;
  std::size_t num_points = 0;
  /// Phase 2 from the host's positions (dual's mesh.x, mesh.y): the sites' positions; from DeviceSites
  /// the dual reads them there instead.
  detail::DeviceBuffer<double> site_x, site_y;
};

} // namespace cdt::gpu
