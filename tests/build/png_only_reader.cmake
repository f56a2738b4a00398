# cmake -P script: configure the vectorize app with the libpng reader and OpenImageIO hidden (as on a
# machine where OpenImageIO cannot go), build it, and check that it converts PNG samples to exactly
# the bytes the full build writes, and refuses other formats with a clear message.
set(tree "${WORK_DIR}/png-only-reader")
file(REMOVE_RECURSE "${tree}")
execute_process(
  COMMAND ${CMAKE_COMMAND} -S "${SOURCE_DIR}" -B "${tree}" -G "${GENERATOR}" -DCMAKE_CXX_COMPILER=${CXX}
          -DCMAKE_BUILD_TYPE=Release -DTRIXEL_CUDA=OFF -DTRIXEL_WERROR=ON -DTRIXEL_IMAGE_IO=png
          -DCMAKE_DISABLE_FIND_PACKAGE_OpenImageIO=ON -DTRIXEL_BUILD_TESTS=OFF -DTRIXEL_BUILD_BENCHMARKS=OFF
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configure with TRIXEL_IMAGE_IO=png failed")
endif()
foreach(expected "vectorize pipeline, overlays, app: ON" "PNG only")
  string(FIND "${out}" "${expected}" pos)
  if(pos EQUAL -1)
    message(FATAL_ERROR "configure output does not say '${expected}'")
  endif()
endforeach()
execute_process(COMMAND ${CMAKE_COMMAND} --build "${tree}" --target vectorize_cli RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "building the vectorize app with the libpng reader failed")
endif()
execute_process(COMMAND ldd "${tree}/bin/vectorize" OUTPUT_VARIABLE libs)
string(FIND "${libs}" "OpenImageIO" pos)
if(NOT pos EQUAL -1)
  message(FATAL_ERROR "the PNG-only build still links OpenImageIO:\n${libs}")
endif()

foreach(sample logo photo)
  set(in "${SOURCE_DIR}/samples/${sample}.png")
  execute_process(COMMAND "${tree}/bin/vectorize" "${in}" "${tree}/${sample}-png.svg" RESULT_VARIABLE rc)
  execute_process(COMMAND "${REFERENCE}" "${in}" "${tree}/${sample}-oiio.svg" RESULT_VARIABLE rc2)
  if(NOT rc EQUAL 0 OR NOT rc2 EQUAL 0)
    message(FATAL_ERROR "converting ${in} failed (libpng build: ${rc}, full build: ${rc2})")
  endif()
  file(SHA256 "${tree}/${sample}-png.svg" a)
  file(SHA256 "${tree}/${sample}-oiio.svg" b)
  if(NOT a STREQUAL b)
    message(FATAL_ERROR "${sample}: the libpng build writes a different SVG than the full build")
  endif()
endforeach()

file(WRITE "${tree}/photo.jpg" "\xFF\xD8\xFF\xE0 not really a JPEG")
execute_process(COMMAND "${tree}/bin/vectorize" "${tree}/photo.jpg" "${tree}/photo.svg"
                RESULT_VARIABLE rc ERROR_VARIABLE err)
message("${err}")
string(FIND "${err}" "photo.jpg: unsupported format: this build reads PNG only" pos)
if(NOT rc EQUAL 1 OR pos EQUAL -1 OR EXISTS "${tree}/photo.svg")
  message(FATAL_ERROR "a non-PNG input must fail with exit status 1 naming the file (got ${rc}: ${err})")
endif()
file(REMOVE_RECURSE "${tree}")
