# cmake -P script: options that must stop configuration with a clear message.
function(expect_configure_failure name expected)
  set(tree "${WORK_DIR}/option-errors-${name}")
  file(REMOVE_RECURSE "${tree}")
  execute_process(
    COMMAND ${CMAKE_COMMAND} -E env CUDACXX=/nonexistent/nvcc PATH=/usr/bin:/bin
            ${CMAKE_COMMAND} -S "${SOURCE_DIR}" -B "${tree}" -G "${GENERATOR}" -DCMAKE_CXX_COMPILER=${CXX}
            -DTRIXEL_BUILD_TESTS=OFF -DTRIXEL_BUILD_BENCHMARKS=OFF ${ARGN}
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  file(REMOVE_RECURSE "${tree}")
  if(rc EQUAL 0)
    message(FATAL_ERROR "${name}: configuration succeeded but should have failed")
  endif()
  string(FIND "${out}${err}" "${expected}" pos)
  if(pos EQUAL -1)
    message(FATAL_ERROR "${name}: message lacks '${expected}':\n${out}${err}")
  endif()
  message("${name}: failed as expected with '${expected}'")
endfunction()

expect_configure_failure(cuda_on_without_nvcc "TRIXEL_CUDA=ON but no CUDA compiler was found" -DTRIXEL_CUDA=ON)
expect_configure_failure(bad_cuda_value "TRIXEL_CUDA must be AUTO, ON or OFF" -DTRIXEL_CUDA=maybe)
expect_configure_failure(bad_mimalloc_value "TRIXEL_MIMALLOC must be AUTO, ON or OFF" -DTRIXEL_MIMALLOC=maybe)
expect_configure_failure(mimalloc_with_sanitizers "TRIXEL_MIMALLOC=ON cannot be combined with TRIXEL_SANITIZE"
                         -DTRIXEL_MIMALLOC=ON -DTRIXEL_SANITIZE=address)
