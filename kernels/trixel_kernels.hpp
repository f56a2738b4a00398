#pragma once
// Host-callable entry point of vectorize's CUDA code: the trixel stage's per-triangle sums on the
// device. This header includes no CUDA header.

#include <array>
#include <cstddef>
#include <cstdint>

#include "cdt/cdt.hpp"
#include "trixel_runs.hpp" // vectorize/src: the per-triangle work, shared with the host

namespace vectorize::gpu {

/// sums[t], for each of the num_triangles counter-clockwise triangles (vertex indices into vertices),
/// over the pixel centres it owns of the width x height image of RGBA floats `rgba` (row-major), as
/// the host makes them with detail::triangle_runs and detail::add_run (detail::add_run_opaque when
/// `opaque`, the image having no alpha below 1): the same values to the bit. Runs on the calling
/// thread's default stream (cudaStreamPerThread) and returns when the sums are in host memory; copies
/// that fit go through a free one of the pinned staging blocks the CDT engine's copies use
/// (cdt::gpu::reserve_memory, prepare_trixel_sums). `device_rgba`, when not null, holds the same
/// pixels on the device already (a DeviceImage of edge_classes), which are then not copied. `lab`,
/// when not null, receives for each triangle that owns pixels the CIELAB of its colour
/// (detail::trixel_rgba, then detail::lab_of_rgb with detail::srgb_linear_table: the host's values to
/// the bit), and zeros for the others. Throws cdt::DeviceError on any CUDA failure.
void trixel_sums(const float* rgba, int width, int height, const cdt::Point* vertices,
                 std::size_t num_vertices, const std::array<std::uint32_t, 3>* triangles,
                 std::size_t num_triangles, bool opaque, detail::TrixelSums* sums,
                 const float* device_rgba = nullptr, std::array<double, 3>* lab = nullptr);

/// Loads trixel_sums' device code and pins a staging block (16 MB) for each of `callers` threads that
/// will call it at once, at most 4, so that the calls do not wait for either (loading a kernel module
/// and pinning host memory hold the driver's lock, stalling every other thread's device work). A call
/// holds a block only while it copies, so a few serve many callers; one that finds none free copies
/// from pageable memory instead. Throws cdt::DeviceError.
void prepare_trixel_sums(std::size_t callers);

} // namespace vectorize::gpu
