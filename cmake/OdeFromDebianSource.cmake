# Builds the Open Dynamics Engine (ODE) from Debian's own source package and provides it as the
# imported static library ODE::ode_pic for linking into FMU shared objects.
#
# Why not Debian's libode.a / libode.so:
#  - /usr/lib/<multiarch>/libode.a is compiled without -fPIC, so it cannot go into a .so;
#  - linking ODE statically keeps the FMU self-contained (no libode/libccd at run time), and with
#    -fvisibility=hidden its ODE symbols stay private to the FMU, so they cannot clash with another
#    libode (other precision, other version) already loaded into the importing process.
# ODE is built in double precision (as Debian's amd64 package), Release, without libccd, OPCODE
# (trimeshes), demos, tests and the built-in thread pool: the plant only needs box, plane, sphere
# and capsule primitives.
#
# Source: no ODE source is kept in this repository. -DANKLEHIP_ODE_SOURCE_DIR=<extracted tree>
# uses an existing tree; otherwise configure fetches it with `apt-get source` (needs a deb-src
# entry, which scripts/setup.sh adds, and dpkg-dev for dpkg-source) at the version of the
# installed libode-dev, applies the Debian patches (dpkg-source -x) and reuses it on later runs.
include_guard(GLOBAL)
include(ExternalProject)

set(ANKLEHIP_ODE_SOURCE_DIR "" CACHE PATH
    "Extracted ODE source tree; empty: fetch Debian's source package with apt-get source")

set(_ode_deps "${CMAKE_BINARY_DIR}/_deps")
set(_ode_install "${_ode_deps}/ode-install")

if(ANKLEHIP_ODE_SOURCE_DIR)
  if(NOT EXISTS "${ANKLEHIP_ODE_SOURCE_DIR}/CMakeLists.txt"
     OR NOT EXISTS "${ANKLEHIP_ODE_SOURCE_DIR}/include/ode/odeinit.h")
    message(FATAL_ERROR "ANKLEHIP_ODE_SOURCE_DIR=${ANKLEHIP_ODE_SOURCE_DIR} is not an ODE source "
                        "tree (no CMakeLists.txt or include/ode/odeinit.h).")
  endif()
  set(_ode_src "${ANKLEHIP_ODE_SOURCE_DIR}")
  set(_ode_origin "${_ode_src}")
else()
  set(_ode_debdir "${_ode_deps}/ode-deb")
  set(_ode_src "${_ode_deps}/ode-src")
  set(_ode_stamp "${_ode_deps}/ode-src.stamp")  # the version asked for when extracted ("any": unpinned)

  # Same upstream version and Debian patches as the installed headers/library, when there are any.
  set(_ode_version "")
  find_program(ANKLEHIP_DPKG_QUERY dpkg-query)
  mark_as_advanced(ANKLEHIP_DPKG_QUERY)
  if(ANKLEHIP_DPKG_QUERY)
    execute_process(COMMAND "${ANKLEHIP_DPKG_QUERY}" -W -f=\${Version} libode-dev
                    OUTPUT_VARIABLE _ode_version RESULT_VARIABLE _rc
                    OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    if(NOT _rc EQUAL 0)
      set(_ode_version "")
    endif()
  endif()
  if(_ode_version)
    set(_ode_want "${_ode_version}")
    set(_ode_pkg "ode=${_ode_version}")
  else()
    set(_ode_want "any")
    set(_ode_pkg "ode")
  endif()

  set(_ode_have "")
  if(EXISTS "${_ode_stamp}" AND EXISTS "${_ode_src}/CMakeLists.txt")
    file(READ "${_ode_stamp}" _ode_have)
    string(STRIP "${_ode_have}" _ode_have)
  endif()
  # An unpinned request is satisfied by whatever was extracted before.
  if(NOT _ode_have OR (NOT _ode_want STREQUAL "any" AND NOT _ode_have STREQUAL _ode_want))
    find_program(ANKLEHIP_APT_GET apt-get)
    find_program(ANKLEHIP_DPKG_SOURCE dpkg-source)
    mark_as_advanced(ANKLEHIP_APT_GET ANKLEHIP_DPKG_SOURCE)
    if(NOT ANKLEHIP_APT_GET)
      message(FATAL_ERROR "ODE source: apt-get not found (a Debian-based system is needed to fetch "
                          "Debian's ODE source); or pass -DANKLEHIP_ODE_SOURCE_DIR=<ODE source tree>.")
    endif()
    if(NOT ANKLEHIP_DPKG_SOURCE)
      message(FATAL_ERROR "ODE source: dpkg-source not found: install dpkg-dev (run scripts/setup.sh), "
                          "or pass -DANKLEHIP_ODE_SOURCE_DIR=<ODE source tree>.")
    endif()

    message(STATUS "ODE source: apt-get source --download-only ${_ode_pkg}")
    file(REMOVE_RECURSE "${_ode_debdir}")
    file(MAKE_DIRECTORY "${_ode_debdir}")
    execute_process(COMMAND "${ANKLEHIP_APT_GET}" source --download-only "${_ode_pkg}"
                    WORKING_DIRECTORY "${_ode_debdir}"
                    OUTPUT_VARIABLE _out ERROR_VARIABLE _out RESULT_VARIABLE _rc)
    file(GLOB _ode_dsc "${_ode_debdir}/ode_*.dsc")
    if(NOT _rc EQUAL 0 OR NOT _ode_dsc)
      if(_out MATCHES "deb-src")
        set(_why "no deb-src entry: run scripts/setup.sh (as root), which adds one for deb.debian.org")
      elseif(_out MATCHES "find a source package|no longer downloadable|Can not find version")
        string(CONCAT _why "apt has no source package ${_ode_pkg}: run `apt-get update` (scripts/"
               "setup.sh does it when the source index is missing), or upgrade libode-dev")
      else()
        set(_why "`apt-get source --download-only ${_ode_pkg}` failed (network? apt lists?)")
      endif()
      message(FATAL_ERROR "ODE source: ${_why}. Alternatively pass "
                          "-DANKLEHIP_ODE_SOURCE_DIR=<extracted ODE source tree>.\napt-get said:\n${_out}")
    endif()
    list(GET _ode_dsc 0 _ode_dsc)

    # Extract next to the final place, then rename: an interrupted run leaves no half tree behind.
    file(REMOVE_RECURSE "${_ode_src}" "${_ode_src}.tmp" "${_ode_stamp}")
    execute_process(COMMAND "${ANKLEHIP_DPKG_SOURCE}" --no-copy -x "${_ode_dsc}" "${_ode_src}.tmp"
                    WORKING_DIRECTORY "${_ode_debdir}"
                    OUTPUT_VARIABLE _out ERROR_VARIABLE _out RESULT_VARIABLE _rc)
    if(NOT _rc EQUAL 0 OR NOT EXISTS "${_ode_src}.tmp/CMakeLists.txt")
      message(FATAL_ERROR "ODE source: `dpkg-source -x ${_ode_dsc}` failed:\n${_out}")
    endif()
    file(RENAME "${_ode_src}.tmp" "${_ode_src}")
    file(WRITE "${_ode_stamp}" "${_ode_want}\n")
  endif()
  file(STRINGS "${_ode_src}/debian/changelog" _ode_cl LIMIT_COUNT 1)
  string(REGEX REPLACE "^[^(]*\\(([^)]*)\\).*" "\\1" _ode_cl "${_ode_cl}")
  file(TIMESTAMP "${_ode_stamp}" _ode_when UTC)
  set(_ode_origin "Debian source package ode ${_ode_cl} (extracted ${_ode_when})")
endif()

# Another source (tree or version) gets a fresh ODE build: re-extracted files keep their tarball
# times, older than the objects of the previous build, so an incremental build would miss them.
set(_ode_key "${_ode_origin}")
set(_ode_key_file "${_ode_deps}/ode-build.source")
set(_ode_key_old "")
if(EXISTS "${_ode_key_file}")
  file(READ "${_ode_key_file}" _ode_key_old)
endif()
if(NOT _ode_key_old STREQUAL _ode_key)
  file(REMOVE_RECURSE "${_ode_deps}/ode-build" "${_ode_deps}/ode-ep" "${_ode_install}")
  file(WRITE "${_ode_key_file}" "${_ode_key}")
endif()

set(_ode_lib "${_ode_install}/lib/${CMAKE_STATIC_LIBRARY_PREFIX}ode${CMAKE_STATIC_LIBRARY_SUFFIX}")
ExternalProject_Add(ode_pic_ext
  SOURCE_DIR "${_ode_src}"
  PREFIX "${_ode_deps}/ode-ep"
  BINARY_DIR "${_ode_deps}/ode-build"
  INSTALL_DIR "${_ode_install}"
  CMAKE_ARGS
    -DCMAKE_INSTALL_PREFIX=<INSTALL_DIR>
    -DCMAKE_INSTALL_LIBDIR=lib
    -DCMAKE_INSTALL_INCLUDEDIR=include
    -DCMAKE_BUILD_TYPE=Release
    "-DCMAKE_C_COMPILER=${CMAKE_C_COMPILER}"
    "-DCMAKE_CXX_COMPILER=${CMAKE_CXX_COMPILER}"
    # ODE 0.16 asks for cmake_minimum_required(2.8.11), which CMake 4.x refuses without this.
    -DCMAKE_POLICY_VERSION_MINIMUM=3.5
    # Hidden symbols (ODE_API is empty on ELF): nothing of ODE is exported from the FMU.
    -DCMAKE_C_FLAGS=-fvisibility=hidden
    "-DCMAKE_CXX_FLAGS=-fvisibility=hidden -fvisibility-inlines-hidden"
    -DBUILD_SHARED_LIBS=OFF
    -DCMAKE_POSITION_INDEPENDENT_CODE=ON
    -DODE_DOUBLE_PRECISION=ON
    -DODE_WITH_DEMOS=OFF
    -DODE_WITH_TESTS=OFF
    -DODE_WITH_LIBCCD=OFF
    -DODE_WITH_OPCODE=OFF
    -DODE_WITH_GIMPACT=OFF
    -DODE_WITH_OU=OFF
    # No thread pool; the threading interface (atomics, per-world self-threaded implementation)
    # stays: it is what makes separate worlds safe to step from separate threads.
    -DODE_NO_BUILTIN_THREADING_IMPL=ON
    -DCMAKE_DISABLE_FIND_PACKAGE_OpenGL=ON
  BUILD_BYPRODUCTS "${_ode_lib}"
  LOG_CONFIGURE ON LOG_BUILD ON LOG_INSTALL ON LOG_OUTPUT_ON_FAILURE ON)

# The include directory must exist at configure time for INTERFACE_INCLUDE_DIRECTORIES.
file(MAKE_DIRECTORY "${_ode_install}/include")
add_library(ODE::ode_pic STATIC IMPORTED GLOBAL)
set_target_properties(ODE::ode_pic PROPERTIES
  IMPORTED_LOCATION "${_ode_lib}"
  IMPORTED_LINK_INTERFACE_LANGUAGES CXX
  INTERFACE_INCLUDE_DIRECTORIES "${_ode_install}/include"
  # The installed ode/precision.h already defines dDOUBLE; this pins it even if another
  # ode/precision.h (e.g. /usr/include) were found first.
  INTERFACE_COMPILE_DEFINITIONS dIDEDOUBLE
  # No pthread: without the built-in thread pool and TLS (ODE_WITH_OU) libode.a calls no
  # pthread function (and glibc >= 2.34 has them in libc anyway); libstdc++ comes with the C++ link.
  INTERFACE_LINK_LIBRARIES m)
# Dependencies of an imported target are followed by every target linking it.
add_dependencies(ODE::ode_pic ode_pic_ext)
message(STATUS "ODE (static, PIC, double, hidden symbols): ${_ode_origin}")
