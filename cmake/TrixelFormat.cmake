# 'format-check' fails when a C++/CUDA source differs from .clang-format; 'format' rewrites them.
include_guard(GLOBAL)
find_program(TRIXEL_CLANG_FORMAT NAMES clang-format clang-format-16 clang-format-15 clang-format-14)
if(TRIXEL_CLANG_FORMAT)
  file(GLOB_RECURSE _trixel_sources CONFIGURE_DEPENDS
       ${PROJECT_SOURCE_DIR}/apps/*.cpp ${PROJECT_SOURCE_DIR}/apps/*.hpp
       ${PROJECT_SOURCE_DIR}/cdt/*.cpp ${PROJECT_SOURCE_DIR}/cdt/*.hpp
       ${PROJECT_SOURCE_DIR}/kernels/*.cu ${PROJECT_SOURCE_DIR}/kernels/*.cuh ${PROJECT_SOURCE_DIR}/kernels/*.hpp
       ${PROJECT_SOURCE_DIR}/vectorize/*.cpp ${PROJECT_SOURCE_DIR}/vectorize/*.hpp
       ${PROJECT_SOURCE_DIR}/tests/*.cpp ${PROJECT_SOURCE_DIR}/tests/*.hpp ${PROJECT_SOURCE_DIR}/tests/*.cu
       ${PROJECT_SOURCE_DIR}/samples/*.cpp)
  add_custom_target(format-check
    COMMAND ${TRIXEL_CLANG_FORMAT} --dry-run --Werror ${_trixel_sources}
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    COMMENT "Checking formatting against .clang-format" VERBATIM)
  add_custom_target(format
    COMMAND ${TRIXEL_CLANG_FORMAT} -i ${_trixel_sources}
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    COMMENT "Formatting sources with .clang-format" VERBATIM)
endif()
