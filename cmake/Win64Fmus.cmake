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
include(FmuBinariesSubbuild)

find_program(ANKLEHIP_MINGW_CXX x86_64-w64-mingw32-g++-posix)
if(NOT ANKLEHIP_MINGW_CXX)
  message(FATAL_ERROR "ANKLEHIP_WIN64=ON needs the mingw-w64 cross compiler "
                      "x86_64-w64-mingw32-g++-posix: run `bash scripts/setup.sh --win64` (as root), "
                      "or apt-get install g++-mingw-w64-x86-64-posix.")
endif()

set(_win_dir "${CMAKE_BINARY_DIR}/win64")
set(ANKLEHIP_WIN64_BINARY_DIR "${_win_dir}/binaries")
anklehip_fmu_binaries_subbuild(win64_fmus "${_win_dir}" "${PROJECT_SOURCE_DIR}/cmake/toolchains/mingw-w64-x86_64.cmake")
message(STATUS "Windows 64-bit FMU binaries: mingw-w64 (${ANKLEHIP_MINGW_CXX}) in ${_win_dir}")
