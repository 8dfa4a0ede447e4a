# -DANKLEHIP_GLIBC_BASELINE=2.17 (the default): every FMU's binaries/linux64/<ModelName>.so is
# built against that glibc, so that it loads on any Linux with glibc >= 2.17 (RHEL/CentOS 7,
# Ubuntu 14.04, Debian 8 and everything newer: the manylinux2014 baseline), not only on systems as
# new as the build machine. gcc links against the build machine's glibc: on Debian 12 the binaries
# needed GLIBC_2.35 (_dl_find_object from the static libgcc unwinder, hypot@2.35, pthread_once@2.34).
#
# An external project configures this same source tree a second time, in <build>/linux64, with
# ANKLEHIP_FMU_BINARIES_ONLY=ON and `zig cc` (PyPI package ziglang, the [build] extra of
# pyproject.toml) targeting x86_64-linux-gnu.<baseline> on the baseline x86-64 CPU: zig links
# against stubs of exactly that glibc version and brings its own C++ runtime (LLVM libc++, libc++abi,
# libunwind), linked statically and hidden. SUNDIALS and ODE are compiled from the same Debian source
# trees as this build's. add_fmu packs the .so files from ${ANKLEHIP_LINUX_BASELINE_BINARY_DIR}; this
# build's own compiler still builds every test, tool and the generator. tests/test_linux_binaries.py
# checks the highest GLIBC_ symbol version each packed binary needs.
#
# -DANKLEHIP_GLIBC_BASELINE= (empty) packs this build's own .so instead (its minimum glibc is then
# the build machine's). Not in the sanitizer build, whose binaries take their runtime from the process.
include_guard(GLOBAL)
set(ANKLEHIP_GLIBC_BASELINE "2.17" CACHE STRING
    "glibc version the packed Linux FMU binaries are built against with zig cc; empty: this build's compiler")
if(ANKLEHIP_FMU_BINARIES_ONLY OR ANKLEHIP_SANITIZE OR WIN32 OR NOT ANKLEHIP_GLIBC_BASELINE)
  return()
endif()
include(FmuBinariesSubbuild)

include(ZigToolchain)
anklehip_find_zig("ANKLEHIP_GLIBC_BASELINE=${ANKLEHIP_GLIBC_BASELINE}" "-DANKLEHIP_GLIBC_BASELINE= packs binaries built with ${CMAKE_CXX_COMPILER} instead.")

set(_lin_dir "${CMAKE_BINARY_DIR}/linux64")
set(_zig_target "x86_64-linux-gnu.${ANKLEHIP_GLIBC_BASELINE}")
anklehip_zig_toolchain(_toolchain "${_lin_dir}" "${_zig_target}" baseline x86_64)

set(ANKLEHIP_LINUX_BASELINE_BINARY_DIR "${_lin_dir}/binaries")
anklehip_fmu_binaries_subbuild(linux64_fmus "${_lin_dir}" "${_toolchain}")
message(STATUS "Linux FMU binaries: glibc ${ANKLEHIP_GLIBC_BASELINE} baseline, zig (${ANKLEHIP_ZIG}) in ${_lin_dir}")
