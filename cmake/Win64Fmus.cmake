# -DANKLEHIP_WIN64=ON: every FMU also gets binaries/win64/<ModelName>.dll.
#
# An external project configures this same source tree a second time, in <build>/win64, with the
# mingw-w64 toolchain (cmake/toolchains/mingw-w64-x86_64.cmake) and ANKLEHIP_FMU_BINARIES_ONLY=ON:
# it builds only the FMUs' DLLs, statically linked, with SUNDIALS (cmake/SundialsFromDebianSource)
# and ODE (cmake/OdeFromDebianSource, over the SUNDIALS and ODE trees this build already extracted) compiled from
# Debian's source packages. The DLLs land in ${ANKLEHIP_WIN64_BINARY_DIR}; add_fmu packs each next
# to its .so. modelDescription.xml comes from this (Linux) build: same sources, same variable table.
# Needs g++-mingw-w64-x86-64-posix (scripts/setup.sh --win64 installs it).
include_guard(GLOBAL)
if(NOT ANKLEHIP_WIN64 OR ANKLEHIP_FMU_BINARIES_ONLY)
  return()
endif()
include(ExternalProject)

find_program(ANKLEHIP_MINGW_CXX x86_64-w64-mingw32-g++-posix)
if(NOT ANKLEHIP_MINGW_CXX)
  message(FATAL_ERROR "ANKLEHIP_WIN64=ON needs the mingw-w64 cross compiler "
                      "x86_64-w64-mingw32-g++-posix: run `bash scripts/setup.sh --win64` (as root), "
                      "or apt-get install g++-mingw-w64-x86-64-posix.")
endif()

set(_win_dir "${CMAKE_BINARY_DIR}/win64")
set(ANKLEHIP_WIN64_BINARY_DIR "${_win_dir}/binaries")
# The same build type as this build (Release unless asked otherwise).
set(_win_args
  "-DCMAKE_TOOLCHAIN_FILE=${PROJECT_SOURCE_DIR}/cmake/toolchains/mingw-w64-x86_64.cmake"
  -DANKLEHIP_FMU_BINARIES_ONLY=ON
  "-DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE}"
  "-DFMI2_INCLUDE_DIR=${FMI2_INCLUDE_DIR}"
  "-DEigen3_DIR=${Eigen3_DIR}"
  "-DANKLEHIP_ODE_SOURCE_DIR=${_ode_src}"
  "-DANKLEHIP_SUNDIALS_SOURCE_DIR=${_sun_src}")
ExternalProject_Add(win64_fmus
  SOURCE_DIR "${PROJECT_SOURCE_DIR}"
  PREFIX "${_win_dir}-ep"
  BINARY_DIR "${_win_dir}"
  CMAKE_ARGS ${_win_args}
  # The sources are this project's own: let the sub-build decide what is out of date, every time.
  BUILD_ALWAYS ON
  INSTALL_COMMAND ""
  LOG_CONFIGURE ON LOG_BUILD ON LOG_OUTPUT_ON_FAILURE ON)
message(STATUS "Windows 64-bit FMU binaries: mingw-w64 (${ANKLEHIP_MINGW_CXX}) in ${_win_dir}")
