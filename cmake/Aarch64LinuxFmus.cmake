# -DANKLEHIP_AARCH64=ON: every FMU also gets binaries/aarch64-linux/<ModelName>.so, in its FMI 2.0
# and its FMI 3.0 form (ARM HIL rigs and embedded PCs; docs/fmu.md, "Platforms").
#
# An external project configures this same source tree a third time, in <build>/aarch64-linux, with
# ANKLEHIP_FMU_BINARIES_ONLY=ON and `zig cc` targeting aarch64-linux-gnu.2.17 (glibc 2.17, the first
# with aarch64, on the baseline ARMv8-A CPU): the FMUs' shared libraries, SUNDIALS and ODE from the
# Debian source trees this build extracted, and anklehip_rt_step for aarch64, which the suite runs
# under Debian's qemu-user on the aarch64 binaries (tests/test_aarch64.py; its loader and glibc come
# from Debian's libc6-arm64-cross). `bash scripts/setup.sh --aarch64` installs both.
#
# The platform folder is FMI 3.0's tuple `aarch64-linux` in both FMUs: FMI 2.0 defines folder names
# for x86 only (win32/win64/linux32/linux64/darwin64), and `linux64` would make x86-64 importers try
# an ARM binary; FMI 2.0.4 importers that know the tuples, and our runners, look there.
include_guard(GLOBAL)
option(ANKLEHIP_AARCH64 "Also cross-build every FMU's aarch64 Linux binary (zig cc) and rt_step for qemu" OFF)
if(NOT ANKLEHIP_AARCH64 OR ANKLEHIP_FMU_BINARIES_ONLY)
  return()
endif()
include(FmuBinariesSubbuild)
include(ZigToolchain)
anklehip_find_zig("ANKLEHIP_AARCH64=ON" "or configure with -DANKLEHIP_AARCH64=OFF.")

set(_arm_dir "${CMAKE_BINARY_DIR}/aarch64-linux")
# -ffp-contract=off: no fused multiply-add where x86-64's baseline has none (clang contracts a*b+c
# on aarch64 by default), so that both compute the same roundings.
anklehip_zig_toolchain(_arm_toolchain "${_arm_dir}" "aarch64-linux-gnu.2.17" baseline aarch64 -ffp-contract=off)
set(ANKLEHIP_AARCH64_BINARY_DIR "${_arm_dir}/binaries")
anklehip_fmu_binaries_subbuild(aarch64_fmus "${_arm_dir}" "${_arm_toolchain}")
message(STATUS "aarch64 Linux FMU binaries: zig (${ANKLEHIP_ZIG}) in ${_arm_dir}")
