# TRIXEL_SANITIZE=address,undefined instruments every host target of the build.
include_guard(GLOBAL)
if(TRIXEL_SANITIZE)
  add_compile_options(-fsanitize=${TRIXEL_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${TRIXEL_SANITIZE})
endif()
