# anklehip_fmu_binaries_subbuild(<target> <folder> <toolchain file>)
#
# Configures this same source tree a second time, in <folder>, with the toolchain file and
# ANKLEHIP_FMU_BINARIES_ONLY=ON: it builds only the FMUs' shared libraries (into <folder>/binaries),
# with SUNDIALS and ODE compiled from the Debian source trees this build already extracted, the
# same build type, FMI headers and Eigen. <target> builds it; add_fmu packs its binaries. Used for
# the Windows binaries (cmake/Win64Fmus.cmake) and the glibc-baseline Linux binaries
# (cmake/LinuxBaselineFmus.cmake).
include_guard(GLOBAL)
include(ExternalProject)

function(anklehip_fmu_binaries_subbuild target dir toolchain)
  ExternalProject_Add(${target}
    SOURCE_DIR "${PROJECT_SOURCE_DIR}"
    PREFIX "${dir}-ep"
    BINARY_DIR "${dir}"
    CMAKE_ARGS
      "-DCMAKE_TOOLCHAIN_FILE=${toolchain}"
      -DANKLEHIP_FMU_BINARIES_ONLY=ON
      "-DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE}"
      "-DFMI2_INCLUDE_DIR=${FMI2_INCLUDE_DIR}"
      "-DEigen3_DIR=${Eigen3_DIR}"
      "-DANKLEHIP_ODE_SOURCE_DIR=${_ode_src}"
      "-DANKLEHIP_SUNDIALS_SOURCE_DIR=${_sun_src}"
    # The sources are this project's own: let the sub-build decide what is out of date, every time.
    BUILD_ALWAYS ON
    INSTALL_COMMAND ""
    LOG_CONFIGURE ON LOG_BUILD ON LOG_OUTPUT_ON_FAILURE ON)
endfunction()
