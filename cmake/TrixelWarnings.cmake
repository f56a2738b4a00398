# One INTERFACE target carries the warning flags; project targets link it privately so that
# consumers of the libraries never inherit them.
include_guard(GLOBAL)

add_library(trixel_warnings INTERFACE)
target_compile_options(trixel_warnings INTERFACE
  $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wpedantic -Wshadow>
  $<$<COMPILE_LANGUAGE:CUDA>:-Xcompiler=-Wall,-Wextra,-Wshadow>)
if(TRIXEL_WERROR)
  target_compile_options(trixel_warnings INTERFACE
    $<$<COMPILE_LANGUAGE:CXX>:-Werror>
    $<$<COMPILE_LANGUAGE:CUDA>:-Werror=all-warnings -Xcompiler=-Werror>)
endif()
