# Builds SUNDIALS (ARKODE, CVODE, serial N_Vector, dense matrix and linear solver; static, PIC,
# Release) from Debian's source package, and defines the same imported targets as Debian's
# find_package(SUNDIALS) (SUNDIALS::arkode_static, SUNDIALS::cvode_static, ...), so plant/ links
# either without change. Used for every build but the sanitizer build (ANKLEHIP_SYSTEM_SUNDIALS):
#  - Debian's libsundials binaries (6.4.1+dfsg1-3) are compiled without optimization (every
#    function spills its locals to the stack; N_VLinearCombination_Serial costs 1 200 instructions
#    for 10-element vectors), which made the integrator's own arithmetic cost more than the model's;
#  - the Windows binaries cross-built with mingw-w64 (cmake/Win64Fmus.cmake) need it anyway.
#
# Source: -DANKLEHIP_SUNDIALS_SOURCE_DIR=<extracted tree>, or Debian's source package at the version
# of the installed libsundials-dev (cmake/DebianSource.cmake), the same code as Debian's binaries.
# Options as Debian's build where they matter for the numbers (double precision, 64-bit indices);
# everything the plant does not use is off.
include_guard(GLOBAL)
include(ExternalProject)
include(DebianSource)
include(ExternalCompilerArgs)

set(ANKLEHIP_SUNDIALS_SOURCE_DIR "" CACHE PATH
    "Extracted SUNDIALS source tree; empty: fetch Debian's source package with apt-get source")

set(_sun_deps "${CMAKE_BINARY_DIR}/_deps")
set(_sun_install "${_sun_deps}/sundials-install")
anklehip_debian_source(sundials VERSION_OF libsundials-dev MARKER include/cvode/cvode.h
                       SOURCE_DIR "${ANKLEHIP_SUNDIALS_SOURCE_DIR}" OUT_SRC _sun_src OUT_ORIGIN _sun_origin)
anklehip_fresh_build_on_new_source(sundials "${_sun_origin}"
                                   "${_sun_deps}/sundials-build" "${_sun_deps}/sundials-ep" "${_sun_install}")

set(_sun_modules arkode cvode nvecserial sunmatrixdense sunlinsoldense)
set(_sun_libs "")
foreach(m IN LISTS _sun_modules)
  list(APPEND _sun_libs
       "${_sun_install}/lib/${CMAKE_STATIC_LIBRARY_PREFIX}sundials_${m}${CMAKE_STATIC_LIBRARY_SUFFIX}")
endforeach()
ExternalProject_Add(sundials_ext
  SOURCE_DIR "${_sun_src}"
  PREFIX "${_sun_deps}/sundials-ep"
  BINARY_DIR "${_sun_deps}/sundials-build"
  INSTALL_DIR "${_sun_install}"
  CMAKE_ARGS
    -DCMAKE_INSTALL_PREFIX=<INSTALL_DIR>
    -DCMAKE_INSTALL_LIBDIR=lib
    -DCMAKE_BUILD_TYPE=Release
    -DCMAKE_POSITION_INDEPENDENT_CODE=ON
    ${ANKLEHIP_EXTERNAL_COMPILER_ARGS}
    -DBUILD_SHARED_LIBS=OFF
    -DBUILD_STATIC_LIBS=ON
    -DSUNDIALS_PRECISION=double
    -DSUNDIALS_INDEX_SIZE=64
    -DBUILD_ARKODE=ON -DBUILD_CVODE=ON -DBUILD_CVODES=OFF -DBUILD_IDA=OFF -DBUILD_IDAS=OFF
    -DBUILD_KINSOL=OFF
    -DBUILD_FORTRAN_MODULE_INTERFACE=OFF
    -DEXAMPLES_ENABLE_C=OFF -DEXAMPLES_ENABLE_CXX=OFF -DEXAMPLES_INSTALL=OFF
    -DSUNDIALS_TEST_UNITTESTS=OFF
    -DENABLE_MPI=OFF -DENABLE_OPENMP=OFF -DENABLE_PTHREAD=OFF -DENABLE_LAPACK=OFF -DENABLE_KLU=OFF
  BUILD_BYPRODUCTS ${_sun_libs}
  LOG_CONFIGURE ON LOG_BUILD ON LOG_INSTALL ON LOG_OUTPUT_ON_FAILURE ON)

file(MAKE_DIRECTORY "${_sun_install}/include")
foreach(m IN LISTS _sun_modules)
  add_library(SUNDIALS::${m}_static STATIC IMPORTED GLOBAL)
  set_target_properties(SUNDIALS::${m}_static PROPERTIES
    IMPORTED_LOCATION "${_sun_install}/lib/${CMAKE_STATIC_LIBRARY_PREFIX}sundials_${m}${CMAKE_STATIC_LIBRARY_SUFFIX}"
    IMPORTED_LINK_INTERFACE_LANGUAGES C
    INTERFACE_INCLUDE_DIRECTORIES "${_sun_install}/include")
  add_dependencies(SUNDIALS::${m}_static sundials_ext)
endforeach()
# The dense linear solver calls the dense matrix module; CVODE the linear-solver interface.
set_property(TARGET SUNDIALS::sunlinsoldense_static APPEND PROPERTY INTERFACE_LINK_LIBRARIES
             SUNDIALS::sunmatrixdense_static)
message(STATUS "SUNDIALS (static, PIC, Release, double, 64-bit indices): ${_sun_origin}")
