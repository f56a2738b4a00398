# cmake -P script: configure with OpenCV, OpenImageIO and pkg-config (so Cairo) hidden, build the
# cdt tests, run them.
set(tree "${WORK_DIR}/without-image-libraries")
file(REMOVE_RECURSE "${tree}")
execute_process(
  COMMAND ${CMAKE_COMMAND} -S "${SOURCE_DIR}" -B "${tree}" -G "${GENERATOR}" -DCMAKE_CXX_COMPILER=${CXX}
          -DCMAKE_BUILD_TYPE=Debug -DTRIXEL_CUDA=OFF -DTRIXEL_WERROR=ON
          -DCMAKE_DISABLE_FIND_PACKAGE_OpenCV=ON -DCMAKE_DISABLE_FIND_PACKAGE_OpenImageIO=ON
          -DCMAKE_DISABLE_FIND_PACKAGE_PkgConfig=ON
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configure without image libraries failed")
endif()
foreach(expected "vectorize pipeline, overlays, app: OFF" "skipped: vectorize_core" "missing OpenCV")
  string(FIND "${out}" "${expected}" pos)
  if(pos EQUAL -1)
    message(FATAL_ERROR "configure output does not say '${expected}'")
  endif()
endforeach()
execute_process(COMMAND ${CMAKE_COMMAND} --build "${tree}" --target cdt_tests cdt_cli
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "building cdt without image libraries failed")
endif()
execute_process(COMMAND ${CMAKE_CTEST_COMMAND} --test-dir "${tree}" -R "^(Predicates|Io)\\." --no-tests=error
                        --output-on-failure
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cdt tests failed in the tree without image libraries")
endif()
file(REMOVE_RECURSE "${tree}")
