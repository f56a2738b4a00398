# All dependencies come from the system (Debian packages); nothing is downloaded.
include_guard(GLOBAL)

# --- CLI11 (apps) ------------------------------------------------------------------------------
find_package(CLI11 CONFIG QUIET)
if(NOT TARGET CLI11::CLI11)
  find_path(TRIXEL_CLI11_INCLUDE_DIR CLI/CLI.hpp)
  if(TRIXEL_CLI11_INCLUDE_DIR)
    add_library(CLI11::CLI11 INTERFACE IMPORTED)
    target_include_directories(CLI11::CLI11 INTERFACE "${TRIXEL_CLI11_INCLUDE_DIR}")
  endif()
endif()
if(TARGET CLI11::CLI11)
  set(TRIXEL_HAVE_CLI11 ON)
else()
  set(TRIXEL_HAVE_CLI11 OFF)
endif()

# --- vectorize: OpenCV, OpenImageIO, Cairo ---------------------------------------------------------
set(TRIXEL_HAVE_VECTORIZE OFF)
set(TRIXEL_VECTORIZE_REASON "TRIXEL_VECTORIZE=OFF")
if(NOT TRIXEL_VECTORIZE STREQUAL "OFF")
  set(_missing "")
  find_package(OpenCV QUIET COMPONENTS core imgproc)
  if(NOT OpenCV_FOUND)
    list(APPEND _missing "OpenCV (libopencv-dev)")
  endif()
  # OpenImageIO is located by hand: Debian's exported config fails hard when the optional
  # openimageio-tools package (its command-line tools) is not installed.
  find_path(TRIXEL_OIIO_INCLUDE_DIR OpenImageIO/imageio.h)
  find_library(TRIXEL_OIIO_LIBRARY OpenImageIO)
  find_library(TRIXEL_OIIO_UTIL_LIBRARY OpenImageIO_Util)
  if(TRIXEL_OIIO_INCLUDE_DIR AND TRIXEL_OIIO_LIBRARY AND TRIXEL_OIIO_UTIL_LIBRARY
     AND NOT CMAKE_DISABLE_FIND_PACKAGE_OpenImageIO)
    if(NOT TARGET OpenImageIO::OpenImageIO)
      add_library(OpenImageIO::OpenImageIO UNKNOWN IMPORTED)
      set_target_properties(OpenImageIO::OpenImageIO PROPERTIES
        IMPORTED_LOCATION "${TRIXEL_OIIO_LIBRARY}"
        INTERFACE_INCLUDE_DIRECTORIES "${TRIXEL_OIIO_INCLUDE_DIR}"
        INTERFACE_LINK_LIBRARIES "${TRIXEL_OIIO_UTIL_LIBRARY}")
    endif()
    file(STRINGS "${TRIXEL_OIIO_INCLUDE_DIR}/OpenImageIO/oiioversion.h" _oiio_v
         REGEX "^#define OIIO_VERSION_(MAJOR|MINOR|PATCH) ")
    string(REGEX REPLACE ".*MAJOR ([0-9]+).*MINOR ([0-9]+).*PATCH ([0-9]+).*" "\\1.\\2.\\3"
           OpenImageIO_VERSION "${_oiio_v}")
  else()
    list(APPEND _missing "OpenImageIO (libopenimageio-dev)")
  endif()
  find_package(PkgConfig QUIET)
  if(PkgConfig_FOUND)
    pkg_check_modules(CAIRO QUIET IMPORTED_TARGET cairo)
  endif()
  if(NOT TARGET PkgConfig::CAIRO)
    list(APPEND _missing "Cairo (libcairo2-dev, found through pkg-config)")
  endif()
  if(NOT TRIXEL_HAVE_CLI11)
    list(APPEND _missing "CLI11 (libcli11-dev)")
  endif()
  if(_missing)
    list(JOIN _missing ", " _m)
    if(TRIXEL_VECTORIZE STREQUAL "ON")
      message(FATAL_ERROR "TRIXEL_VECTORIZE=ON but these are missing: ${_m}")
    endif()
    set(TRIXEL_VECTORIZE_REASON "missing ${_m}")
  else()
    set(TRIXEL_HAVE_VECTORIZE ON)
    set(TRIXEL_VECTORIZE_REASON "OpenCV ${OpenCV_VERSION}, OpenImageIO ${OpenImageIO_VERSION}, Cairo ${CAIRO_VERSION}")
  endif()
endif()

# --- tests and benchmarks ------------------------------------------------------------------------
set(TRIXEL_HAVE_GTEST OFF)
if(TRIXEL_BUILD_TESTS)
  find_package(GTest QUIET)
  if(GTest_FOUND)
    set(TRIXEL_HAVE_GTEST ON)
  else()
    message(FATAL_ERROR "TRIXEL_BUILD_TESTS=ON needs GoogleTest (libgtest-dev); "
                        "install it or configure with -DTRIXEL_BUILD_TESTS=OFF")
  endif()
endif()

# CGAL is an oracle for tests and benchmarks only, never a dependency of the shipped targets.
set(TRIXEL_HAVE_CGAL OFF)
if(TRIXEL_BUILD_TESTS OR TRIXEL_BUILD_BENCHMARKS)
  set(CGAL_DATA_DIR "unused") # keeps CGAL's config from probing for data files
  find_package(CGAL CONFIG QUIET)
  if(CGAL_FOUND)
    set(TRIXEL_HAVE_CGAL ON)
  endif()
endif()
