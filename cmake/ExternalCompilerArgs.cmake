# ANKLEHIP_EXTERNAL_COMPILER_ARGS: the CMake arguments that make an external project (ODE,
# SUNDIALS) compile with this build's compilers, or with its toolchain file when cross-compiling.
include_guard(GLOBAL)
if(CMAKE_TOOLCHAIN_FILE)
  set(ANKLEHIP_EXTERNAL_COMPILER_ARGS "-DCMAKE_TOOLCHAIN_FILE=${CMAKE_TOOLCHAIN_FILE}")
else()
  set(ANKLEHIP_EXTERNAL_COMPILER_ARGS "-DCMAKE_C_COMPILER=${CMAKE_C_COMPILER}"
                                      "-DCMAKE_CXX_COMPILER=${CMAKE_CXX_COMPILER}")
endif()
