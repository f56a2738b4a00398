# The instruction set of host C++ code (TRIXEL_CPU_LEVEL) on x86-64 with GCC or Clang. The compilers'
# default, the 2003 baseline, has no rounding instruction: floor and ceil, in every per-pixel loop of
# the pipeline, become library calls or long sequences. Results do not change with the level: the
# floating-point contraction that could change them is off (cdt/CMakeLists.txt).
include_guard(GLOBAL)
include(CheckCXXCompilerFlag)

set(TRIXEL_CPU_FLAG "")
string(TOLOWER "${TRIXEL_CPU_LEVEL}" _level)
if(_level AND NOT _level STREQUAL "none" AND CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$"
   AND CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
  check_cxx_compiler_flag("-march=${_level}" TRIXEL_HAVE_MARCH_${_level})
  if(TRIXEL_HAVE_MARCH_${_level})
    set(TRIXEL_CPU_FLAG "-march=${_level}")
    add_compile_options($<$<COMPILE_LANGUAGE:CXX>:${TRIXEL_CPU_FLAG}>)
  else()
    message(WARNING "TRIXEL_CPU_LEVEL=${TRIXEL_CPU_LEVEL}: the compiler does not accept -march=${_level}; using its default")
  endif()
endif()
