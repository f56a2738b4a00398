# Every option carries the TRIXEL_ prefix; TrixelSummary.cmake prints them at configure time.
include_guard(GLOBAL)

set(TRIXEL_CUDA AUTO CACHE STRING
    "Build the CUDA executor: AUTO (when nvcc is found), ON (fail without nvcc), OFF")
set_property(CACHE TRIXEL_CUDA PROPERTY STRINGS AUTO ON OFF)

set(TRIXEL_VECTORIZE AUTO CACHE STRING
    "Build the vectorize pipeline and app: AUTO (when OpenCV, OpenImageIO and Cairo are found), ON (fail without them), OFF")
set_property(CACHE TRIXEL_VECTORIZE PROPERTY STRINGS AUTO ON OFF)

set(TRIXEL_IMAGE_IO oiio CACHE STRING
    "Image reader of the vectorize pipeline: oiio (OpenImageIO: PNG, JPEG, TIFF, BMP, WebP, ...) or png (libpng only, for machines without OpenImageIO)")
set_property(CACHE TRIXEL_IMAGE_IO PROPERTY STRINGS oiio png)

set(TRIXEL_CPU_LEVEL x86-64-v2 CACHE STRING
    "Instruction set of host code on x86-64 (-march=...): x86-64-v2 (SSE4.2 and POPCNT, every x86-64 CPU since about 2010; inline rounding for the per-pixel loops), x86-64-v3, native, or none for the compiler's default")
set(TRIXEL_MIMALLOC AUTO CACHE STRING
    "Link the vectorize app with mimalloc, an allocator that keeps its worker threads' many small allocations apart: AUTO (when found and no sanitizers are on), ON (fail without it), OFF (the C library's)")
set_property(CACHE TRIXEL_MIMALLOC PROPERTY STRINGS AUTO ON OFF)
option(TRIXEL_BUILD_TESTS "Build the GoogleTest suites" ${TRIXEL_TOP_LEVEL})
option(TRIXEL_BUILD_BENCHMARKS "Build the benchmark programs" ${TRIXEL_TOP_LEVEL})
option(TRIXEL_WERROR "Treat compiler warnings as errors (CI turns this on)" OFF)
set(TRIXEL_SANITIZE "" CACHE STRING
    "Sanitizers for host code, e.g. 'address,undefined' (CUDA is turned off in such a build)")

foreach(opt TRIXEL_CUDA TRIXEL_VECTORIZE TRIXEL_MIMALLOC)
  string(TOUPPER "${${opt}}" _v)
  if(NOT _v MATCHES "^(AUTO|ON|OFF)$")
    message(FATAL_ERROR "${opt} must be AUTO, ON or OFF (got '${${opt}}')")
  endif()
  set(${opt} "${_v}" CACHE STRING "" FORCE)
endforeach()
string(TOLOWER "${TRIXEL_IMAGE_IO}" _v)
if(NOT _v MATCHES "^(oiio|png)$")
  message(FATAL_ERROR "TRIXEL_IMAGE_IO must be oiio or png (got '${TRIXEL_IMAGE_IO}')")
endif()
set(TRIXEL_IMAGE_IO "${_v}" CACHE STRING "" FORCE)
