#pragma once
// Annotations for code compiled both by the host compiler and by nvcc for the device.
// Public headers never include CUDA headers; this only expands to CUDA keywords under nvcc.

#if defined(__CUDACC__)
#define CDT_HD __host__ __device__
#define CDT_HD_INLINE __host__ __device__ __forceinline__
#define CDT_HD_NOINLINE __host__ __device__ __noinline__ inline
#else
#define CDT_HD
#define CDT_HD_INLINE inline
#define CDT_HD_NOINLINE inline
#endif
