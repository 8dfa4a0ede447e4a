# Locates the FMI 2.0 headers shipped with the installed FMPy package (<fmpy>/c-code); the
# headers are never copied into this repository. Defines the interface target FMI2::Headers.
if(NOT FMI2_INCLUDE_DIR)
  find_package(Python3 COMPONENTS Interpreter REQUIRED)
  execute_process(
    COMMAND "${Python3_EXECUTABLE}" -c "import fmpy, os; print(os.path.join(os.path.dirname(fmpy.__file__), 'c-code'))"
    OUTPUT_VARIABLE _fmpy_ccode OUTPUT_STRIP_TRAILING_WHITESPACE
    RESULT_VARIABLE _fmpy_rc ERROR_QUIET)
  if(NOT _fmpy_rc EQUAL 0 OR NOT EXISTS "${_fmpy_ccode}/fmi2Functions.h")
    message(FATAL_ERROR "FMI 2.0 headers not found: ${Python3_EXECUTABLE} cannot import fmpy. "
                        "Run scripts/setup.sh, or pass -DPython3_EXECUTABLE=<python with fmpy> "
                        "or -DFMI2_INCLUDE_DIR=<dir with fmi2Functions.h>.")
  endif()
  set(FMI2_INCLUDE_DIR "${_fmpy_ccode}" CACHE PATH "Directory with the FMI 2.0 headers (from FMPy)")
endif()
message(STATUS "FMI 2.0 headers: ${FMI2_INCLUDE_DIR}")
add_library(FMI2::Headers INTERFACE IMPORTED)
set_target_properties(FMI2::Headers PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${FMI2_INCLUDE_DIR}")
