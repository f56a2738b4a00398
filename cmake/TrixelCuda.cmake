# CUDA is optional: found with check_language so a machine without nvcc still configures.
# A machine with nvcc but no GPU builds everything; GPU tests skip at run time.
include_guard(GLOBAL)

set(TRIXEL_HAVE_CUDA OFF)
set(TRIXEL_CUDA_REASON "TRIXEL_CUDA=OFF")

if(TRIXEL_SANITIZE AND NOT TRIXEL_CUDA STREQUAL "OFF")
  # Host sanitizers and the CUDA runtime do not mix well; a sanitizer build checks host code only.
  if(TRIXEL_CUDA STREQUAL "ON")
    message(FATAL_ERROR "TRIXEL_SANITIZE cannot be combined with TRIXEL_CUDA=ON")
  endif()
  set(TRIXEL_CUDA_REASON "sanitizer build (TRIXEL_SANITIZE=${TRIXEL_SANITIZE})")
elseif(NOT TRIXEL_CUDA STREQUAL "OFF")
  include(CheckLanguage)
  check_language(CUDA)
  if(CMAKE_CUDA_COMPILER)
    # Explicit architectures, never 'native' (CI has no GPU): Turing to Ada as machine code,
    # Hopper (sm_90) as machine code plus PTX so newer GPUs can JIT-compile it.
    if(NOT DEFINED CMAKE_CUDA_ARCHITECTURES)
      set(CMAKE_CUDA_ARCHITECTURES "75-real;80-real;86-real;89-real;90-real;90-virtual"
          CACHE STRING "CUDA architectures to build for")
    endif()
    enable_language(CUDA)
    find_package(CUDAToolkit REQUIRED)
    # Device code shares C++20 headers with the host. CMake before 3.26 does not know nvcc's C++20
    # flag although nvcc 12+ accepts it; teach it, so CUDA_STANDARD 20 works on CMake 3.25 and 4.x.
    if(NOT CMAKE_CUDA20_STANDARD_COMPILE_OPTION AND CMAKE_CUDA_COMPILER_VERSION VERSION_GREATER_EQUAL 12.0)
      set(CMAKE_CUDA20_STANDARD_COMPILE_OPTION "-std=c++20")
      set(CMAKE_CUDA20_EXTENSION_COMPILE_OPTION "-std=c++20")
    endif()
    set(TRIXEL_HAVE_CUDA ON)
    set(TRIXEL_CUDA_REASON "nvcc ${CMAKE_CUDA_COMPILER_VERSION}, architectures ${CMAKE_CUDA_ARCHITECTURES}")
  elseif(TRIXEL_CUDA STREQUAL "ON")
    message(FATAL_ERROR "TRIXEL_CUDA=ON but no CUDA compiler was found "
                        "(put nvcc on PATH or set CUDACXX, or configure with -DTRIXEL_CUDA=AUTO)")
  else()
    set(TRIXEL_CUDA_REASON "no CUDA compiler found (nvcc not on PATH, CUDACXX unset)")
  endif()
endif()
