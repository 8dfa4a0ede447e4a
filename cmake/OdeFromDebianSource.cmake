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
include(DebianSource)
include(ExternalCompilerArgs)

set(ANKLEHIP_ODE_SOURCE_DIR "" CACHE PATH
    "Extracted ODE source tree; empty: fetch Debian's source package with apt-get source")

set(_ode_deps "${CMAKE_BINARY_DIR}/_deps")
set(_ode_install "${_ode_deps}/ode-install")
anklehip_debian_source(ode VERSION_OF libode-dev MARKER include/ode/odeinit.h
                       SOURCE_DIR "${ANKLEHIP_ODE_SOURCE_DIR}" OUT_SRC _ode_src OUT_ORIGIN _ode_origin)
anklehip_fresh_build_on_new_source(ode "${_ode_origin}"
                                   "${_ode_deps}/ode-build" "${_ode_deps}/ode-ep" "${_ode_install}")

# ODE's CMakeLists names its static Release library ode_doubles on Windows.
if(WIN32)
  set(_ode_name ode_doubles)
else()
  set(_ode_name ode)
endif()
set(_ode_lib "${_ode_install}/lib/${CMAKE_STATIC_LIBRARY_PREFIX}${_ode_name}${CMAKE_STATIC_LIBRARY_SUFFIX}")
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
    ${ANKLEHIP_EXTERNAL_COMPILER_ARGS}
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
