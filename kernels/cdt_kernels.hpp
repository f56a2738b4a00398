#pragma once
// Host-callable entry points of the CUDA code. This header includes no CUDA header, so cdt and the
// tests can include it from plain C++.

#include <cstddef>
#include <string>

namespace cdt::gpu {

/// Number of CUDA devices this process can use; 0 without a device or driver. Never throws.
int device_count() noexcept;

/// "NAME (compute capability X.Y, N SMs, M MiB)" for device 0; throws DeviceError without a device.
std::string device_description();

/// Synchronise after every launch so a fault shows at the launch that caused it (slow; for debugging).
/// Also turned on by the environment variable TRIXEL_CUDA_SYNC=1.
void set_debug_sync(bool on) noexcept;

/// Signs of orient2d for num queries on the device; coords holds ax ay bx by cx cy per query (6 * num
/// doubles), signs receives num values in {-1, 0, 1}. Throws DeviceError on any CUDA failure.
void orient2d_signs(const double* coords, int* signs, std::size_t num);

/// Signs of incircle for num queries on the device; coords holds ax ay bx by cx cy dx dy per query
/// (8 * num doubles). Throws DeviceError on any CUDA failure.
void incircle_signs(const double* coords, int* signs, std::size_t num);

} // namespace cdt::gpu
