# add_fmu(NAME <ModelName> SOURCES <src>... [LINK <lib>...] [INCLUDE_DIRS <dir>...] [SCHEDULED_EXECUTION]
#         [DOCUMENTATION <file>...] [DOCUMENTATION_IMAGES <file>...] [OUTPUT_DIR <dir>]
#         [SOURCE_FMU_FILES <file>... SOURCE_FMU_HEADER_DIRS <dir>...
#          [SOURCE_FMU_DEPENDENCIES SUNDIALS|Eigen3|ODE...]])
#
# Turns a model (sources defining fmuglue::modelInfo() and fmuglue::createModel(), see
# fmu/common/README.md) into ${ANKLEHIP_FMU_DIR}/<ModelName>.fmu:
#   <ModelName>       shared library <ModelName>.so with the FMI 2.0 API of the glue; only fmi2*
#                     symbols exported (hidden visibility + version script), libstdc++/libgcc
#                     linked statically, no undefined symbols; LINK libraries must be static.
#                     With ANKLEHIP_GLIBC_BASELINE (the default) the packed .so is the one built
#                     by zig against that glibc (cmake/LinuxBaselineFmus.cmake), not this target.
#   <ModelName>_gen   generator built from the same sources: writes modelDescription.xml and
#                     documentation/index.html from the variable table.
#   <ModelName>_fmu   (ALL) packs into OUTPUT_DIR (default ${ANKLEHIP_FMU_DIR}) modelDescription.xml,
#                     binaries/linux64/<ModelName>.so (and binaries/win64/<ModelName>.dll with
#                     -DANKLEHIP_WIN64=ON, cross-built by cmake/Win64Fmus.cmake) and
#                     documentation/ (index.html + DOCUMENTATION files, DOCUMENTATION_IMAGES in
#                     documentation/images/, as docs/*.md link them) and resources/ (ModelInfo::resources)
#                     with `cmake -E tar --format=zip`.
#   With SOURCE_FMU_FILES the FMU is also a source FMU: sources/ holds those files (compiled; the
#   glue's fmi2_api.cpp, instance.cpp, state_format.cpp, model_description.cpp and plant_helpers.cpp
#   are added) at its top level and the headers under each SOURCE_FMU_HEADER_DIRS (and the glue's)
#   with their paths relative to that directory, so that sources/ is the only include directory;
#   sources/buildDescription.xml (FMI 3.0 build description, which FMI 2.0.4 adopts) lists them.
#   The FMI headers are the importer's. sources/CMakeLists.txt (fmu/common/source_fmu) builds the
#   binary with CMake and the SOURCE_FMU_DEPENDENCIES found on the system; sources/fmu_sources.cmake
#   names the files, the model and the API for it.
# Works with CMake 3.25 and 4.x.
include_guard(GLOBAL)

set(_ADD_FMU_GLUE_SRC "${CMAKE_CURRENT_LIST_DIR}/../fmu/common/src")
get_filename_component(_ADD_FMU_GLUE_SRC "${_ADD_FMU_GLUE_SRC}" ABSOLUTE)

# The FMU's shared library <target> (file <name>.so / <name>.dll): the glue's FMI <api> C API
# (fmi2_api.cpp or fmi3_api.cpp) over the model's sources or objects, exporting only the <api>*
# functions. Linux: hidden visibility + version script, libstdc++/libgcc static, no undefined
# symbols. Windows (mingw-w64): <name>.dll exporting what fmi2Functions.h / fmi3Functions.h mark
# dllexport, everything static (-static: libstdc++, libgcc, libwinpthread), so that it needs only
# Windows' own DLLs. Written to <build>/binaries/ (FMI 2.0) or <build>/binaries/fmi3/ (FMI 3.0).
function(_add_fmu_binary target name api link include_dirs)
  add_library(${target} SHARED "${_ADD_FMU_GLUE_SRC}/${api}_api.cpp" ${ARGN})
  target_link_libraries(${target} PRIVATE fmuglue ${link})
  target_include_directories(${target} PRIVATE "${_ADD_FMU_GLUE_SRC}" ${include_dirs})
  set(outdir "${CMAKE_BINARY_DIR}/binaries")
  if(api STREQUAL "fmi3")
    set(outdir "${outdir}/fmi3")
  endif()
  set_target_properties(${target} PROPERTIES PREFIX "" OUTPUT_NAME "${name}"
    POSITION_INDEPENDENT_CODE ON CXX_VISIBILITY_PRESET hidden C_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON)
  target_compile_options(${target} PRIVATE -ffunction-sections -fdata-sections)
  if(WIN32)
    set_target_properties(${target} PROPERTIES SUFFIX ".dll" RUNTIME_OUTPUT_DIRECTORY "${outdir}")
    target_link_options(${target} PRIVATE -static "LINKER:--no-undefined" "LINKER:--gc-sections"
      $<$<CONFIG:Release,MinSizeRel>:-s>)
  else()
    set(vscript "${CMAKE_CURRENT_BINARY_DIR}/${target}_exports.map")
    file(WRITE "${vscript}" "{\n  global:\n    ${api}*;\n  local:\n    *;\n};\n")
    set_target_properties(${target} PROPERTIES SUFFIX ".so" LINK_DEPENDS "${vscript}"
      LIBRARY_OUTPUT_DIRECTORY "${outdir}")
    if(ANKLEHIP_SANITIZE)
      # sanitized binaries resolve the sanitizer runtime (and the C++ runtime it wraps) from the
      # process: no static libstdc++, undefined __asan_* symbols, symbols kept for the reports
      target_link_options(${target} PRIVATE "LINKER:--version-script=${vscript}")
    elseif(ANKLEHIP_ZIG_RUNTIME)
      # zig links its libc++/libc++abi/libunwind statically; the version script hides them (zig
      # takes the script as a separate argument, not --version-script=). FMUGLUE_ZIG_RUNTIME: the
      # static objects' destructors at unload (binary_runtime.hpp).
      target_compile_definitions(${target} PRIVATE FMUGLUE_ZIG_RUNTIME)
      target_link_options(${target} PRIVATE "LINKER:--version-script,${vscript}" "LINKER:--no-undefined"
        "LINKER:--gc-sections" $<$<CONFIG:Release,MinSizeRel>:-s>)
    else()
      target_compile_definitions(${target} PRIVATE FMUGLUE_STATIC_LIBSTDCXX)  # binary_runtime.hpp frees its pool
      target_link_options(${target} PRIVATE -static-libstdc++ -static-libgcc
        "LINKER:--version-script=${vscript}" "LINKER:--no-undefined" "LINKER:--exclude-libs,ALL"
        "LINKER:--as-needed" "LINKER:--gc-sections" $<$<CONFIG:Release,MinSizeRel>:-s>)
    endif()
  endif()
endfunction()

# Packs <ANKLEHIP_FMU_DIR>/<name>.fmu (api fmi2: binaries/linux64, win64) or
# <ANKLEHIP_FMU_DIR>/fmi3/<name>.fmu (api fmi3, the FMI 3.0 twin: binaries/x86_64-linux,
# x86_64-windows) from the binary `so`, the generator's description of that version and the
# add_fmu arguments of the caller (documentation, sources). Target <name>_fmu / <name>_fmi3_fmu.
function(_add_fmu_package name api so so_dep)
  set(gen_src_names "")
  set(fmu_name ${name})
  set(bin_api ${api})  # fmi3se: the FMI 3.0 library, packed with the Scheduled Execution description
  if(api STREQUAL "fmi3se")
    set(stage "${CMAKE_CURRENT_BINARY_DIR}/${name}_se.fmu.d")
    set(fmu_dir "${ANKLEHIP_FMU_DIR}/fmi3")
    set(fmu_name ${name}_se)
    set(target ${name}_se_fmu)
    set(gen_args --fmi3-se "${stage}")
    set(linux_dir x86_64-linux)
    set(win_dir x86_64-windows)
    set(api_name "FMI 3.0")
    set(bin_api fmi3)
  elseif(api STREQUAL "fmi3")
    set(stage "${CMAKE_CURRENT_BINARY_DIR}/${name}_fmi3.fmu.d")
    set(fmu_dir "${ANKLEHIP_FMU_DIR}/fmi3")
    set(target ${name}_fmi3_fmu)
    set(gen_args --fmi3 "${stage}")
    set(linux_dir x86_64-linux)   # FMI 3.0 platform tuples
    set(win_dir x86_64-windows)
    set(api_name "FMI 3.0")
  else()
    set(stage "${CMAKE_CURRENT_BINARY_DIR}/${name}.fmu.d")
    set(fmu_dir "${ANKLEHIP_FMU_DIR}")
    set(target ${name}_fmu)
    set(gen_args "${stage}")
    set(linux_dir linux64)
    set(win_dir win64)
    set(api_name "FMI 2.0")
  endif()
  set(fmu "${fmu_dir}/${fmu_name}.fmu")
  # The project's license in documentation/licenses/ (FMI 2.0.4: the FMU's license files).
  set(license "${_ADD_FMU_GLUE_SRC}/../../../LICENSE")
  get_filename_component(license "${license}" ABSOLUTE)
  set(doc_cmds COMMAND "${CMAKE_COMMAND}" -E copy "${license}" "${stage}/documentation/licenses/LICENSE.txt")
  set(doc_deps "${license}")
  foreach(doc IN LISTS FMU_DOCUMENTATION)
    get_filename_component(doc_abs "${doc}" ABSOLUTE)
    list(APPEND doc_cmds COMMAND "${CMAKE_COMMAND}" -E copy "${doc_abs}" "${stage}/documentation/")
    list(APPEND doc_deps "${doc_abs}")
  endforeach()
  foreach(img IN LISTS FMU_DOCUMENTATION_IMAGES)
    get_filename_component(img_abs "${img}" ABSOLUTE)
    list(APPEND doc_cmds COMMAND "${CMAKE_COMMAND}" -E copy "${img_abs}" "${stage}/documentation/images/")
    list(APPEND doc_deps "${img_abs}")
  endforeach()
  set(src_cmds "")
  set(src_deps "")
  set(src_entry "")
  if(FMU_SOURCE_FMU_FILES AND NOT api STREQUAL "fmi3se")  # the Scheduled Execution variant: binaries only
    set(glue_generated "${CMAKE_BINARY_DIR}/generated")   # fmuglue/version.h
    set(glue_include "${_ADD_FMU_GLUE_SRC}/../include")
    get_filename_component(glue_include "${glue_include}" ABSOLUTE)
    set(files ${FMU_SOURCE_FMU_FILES})
    foreach(f ${api}_api.cpp api.cpp instance.cpp state_format.cpp model_description.cpp plant_helpers.cpp)
      list(APPEND files "${_ADD_FMU_GLUE_SRC}/${f}")
    endforeach()
    set(xml_files "")
    set(src_names "")
    foreach(f IN LISTS files)
      get_filename_component(f_abs "${f}" ABSOLUTE)
      get_filename_component(f_name "${f}" NAME)
      list(APPEND src_cmds COMMAND "${CMAKE_COMMAND}" -E copy "${f_abs}" "${stage}/sources/${f_name}")
      list(APPEND src_deps "${f_abs}")
      string(APPEND xml_files "      <SourceFile name=\"${f_name}\"/>\n")
      list(APPEND src_names "${f_name}")
    endforeach()
    foreach(dir IN LISTS FMU_SOURCE_FMU_HEADER_DIRS glue_include _ADD_FMU_GLUE_SRC glue_generated)
      get_filename_component(dir_abs "${dir}" ABSOLUTE)
      file(GLOB_RECURSE headers RELATIVE "${dir_abs}" CONFIGURE_DEPENDS "${dir_abs}/*.h" "${dir_abs}/*.hpp")
      foreach(h IN LISTS headers)
        list(APPEND src_cmds COMMAND "${CMAKE_COMMAND}" -E copy "${dir_abs}/${h}" "${stage}/sources/${h}")
        list(APPEND src_deps "${dir_abs}/${h}")
      endforeach()
    endforeach()
    set(deps_text "")
    if(FMU_SOURCE_FMU_DEPENDENCIES)
      string(REPLACE ";" ", " deps_text "${FMU_SOURCE_FMU_DEPENDENCIES}")
      set(deps_text " and those of the system's ${deps_text} (sources/CMakeLists.txt builds it with them)")
    endif()
    # One source file set: FMPy (0.3.32) builds only the first. The .c files are C99 and compiled
    # as C, the .cpp files as C++17 (by extension, as every C/C++ build tool does).
    set(build_xml "${CMAKE_CURRENT_BINARY_DIR}/${name}_${api}_buildDescription.xml")
    file(WRITE "${build_xml}" "<?xml version=\"1.0\" encoding=\"UTF-8\"?>
<fmiBuildDescription fmiVersion=\"3.0\">
  <BuildConfiguration modelIdentifier=\"${name}\" description=\"A shared library with the ${api_name} API; .c files are C99, .cpp files C++17; sources/ is the only include directory besides the ${api_name} headers${deps_text}\">
    <SourceFileSet language=\"C++17\">
${xml_files}      <IncludeDirectory name=\".\"/>
    </SourceFileSet>
  </BuildConfiguration>
</fmiBuildDescription>
")
    list(APPEND src_cmds COMMAND "${CMAKE_COMMAND}" -E copy "${build_xml}" "${stage}/sources/buildDescription.xml")
    list(APPEND src_deps "${build_xml}")
    # The CMake build of sources/ (any FMU of the project; the plants need it: their libraries).
    set(cmake_list "${CMAKE_CURRENT_BINARY_DIR}/${name}_${api}_fmu_sources.cmake")
    string(REPLACE ";" " " src_list "${src_names}")
    string(REPLACE ";" " " dep_list "${FMU_SOURCE_FMU_DEPENDENCIES}")
    file(WRITE "${cmake_list}" "# Generated by cmake/AddFmu.cmake: what sources/CMakeLists.txt builds.
set(FMU_NAME ${name})
set(FMU_API ${api})
set(FMU_SOURCES ${src_list})
set(FMU_DEPENDENCIES ${dep_list})
")
    set(src_cmake "${_ADD_FMU_GLUE_SRC}/../source_fmu/CMakeLists.txt")
    get_filename_component(src_cmake "${src_cmake}" ABSOLUTE)
    list(APPEND src_cmds COMMAND "${CMAKE_COMMAND}" -E copy "${cmake_list}" "${stage}/sources/fmu_sources.cmake"
                         COMMAND "${CMAKE_COMMAND}" -E copy "${src_cmake}" "${stage}/sources/CMakeLists.txt")
    list(APPEND src_deps "${cmake_list}" "${src_cmake}")
    set(src_entry sources)
    if(NOT api STREQUAL "fmi3")
      set(gen_src_names ${src_names})  # FMI 2.0 lists them in <SourceFiles>; FMI 3.0 in buildDescription.xml only
    endif()
  endif()
  # With ANKLEHIP_WIN64 the Windows sub-build's <name>.dll goes next to the .so (Win64Fmus.cmake).
  set(win_cmds "")
  set(win_deps "")
  # The Scheduled Execution variant packs x86_64-linux only: its importers (HIL schedulers, FMPy's
  # FMU3ScheduledExecution) are tested here on Linux (docs/fmu.md, "Scheduled Execution").
  if(ANKLEHIP_WIN64 AND NOT api STREQUAL "fmi3se")
    set(dll "${ANKLEHIP_WIN64_BINARY_DIR}/${name}.dll")
    if(bin_api STREQUAL "fmi3")
      set(dll "${ANKLEHIP_WIN64_BINARY_DIR}/fmi3/${name}.dll")
    endif()
    set(win_cmds COMMAND "${CMAKE_COMMAND}" -E make_directory "${stage}/binaries/${win_dir}"
                 COMMAND "${CMAKE_COMMAND}" -E copy "${dll}" "${stage}/binaries/${win_dir}/${name}.dll")
    set(win_deps "${dll}")
  endif()
  # With ANKLEHIP_AARCH64 the aarch64 sub-build's <name>.so goes to binaries/aarch64-linux in both
  # versions (Aarch64LinuxFmus.cmake says why FMI 2.0 uses the FMI 3.0 tuple).
  set(arm_cmds "")
  set(arm_deps "")
  if(ANKLEHIP_AARCH64 AND NOT api STREQUAL "fmi3se")
    set(arm_so "${ANKLEHIP_AARCH64_BINARY_DIR}/${name}.so")
    if(bin_api STREQUAL "fmi3")
      set(arm_so "${ANKLEHIP_AARCH64_BINARY_DIR}/fmi3/${name}.so")
    endif()
    set(arm_cmds COMMAND "${CMAKE_COMMAND}" -E make_directory "${stage}/binaries/aarch64-linux"
                 COMMAND "${CMAKE_COMMAND}" -E copy "${arm_so}" "${stage}/binaries/aarch64-linux/${name}.so")
    set(arm_deps "${arm_so}")
  endif()
  add_custom_command(OUTPUT "${fmu}"
    COMMAND "${CMAKE_COMMAND}" -E rm -rf "${stage}"
    COMMAND "${CMAKE_COMMAND}" -E make_directory "${stage}/binaries/${linux_dir}" "${stage}/documentation/licenses" "${stage}/documentation/images" "${stage}/resources" "${fmu_dir}"
    COMMAND $<TARGET_FILE:${name}_gen> ${gen_args} ${gen_src_names}
    COMMAND "${CMAKE_COMMAND}" -E copy "${so}" "${stage}/binaries/${linux_dir}/${name}.so"
    ${win_cmds}
    ${arm_cmds}
    ${doc_cmds}
    ${src_cmds}
    COMMAND "${CMAKE_COMMAND}" -E rm -f "${fmu}"
    COMMAND "${CMAKE_COMMAND}" -E chdir "${stage}" "${CMAKE_COMMAND}" -E tar cf "${fmu}" --format=zip
            modelDescription.xml binaries documentation resources ${src_entry}
    DEPENDS ${so_dep} ${name}_gen ${doc_deps} ${src_deps} ${win_deps} ${arm_deps}
    COMMENT "Packing ${fmu_name}.fmu (${api_name})"
    VERBATIM)
  add_custom_target(${target} ALL DEPENDS "${fmu}")
  if(ANKLEHIP_WIN64)
    add_dependencies(${target} win64_fmus)
  endif()
  if(ANKLEHIP_LINUX_BASELINE_BINARY_DIR)
    add_dependencies(${target} linux64_fmus)
  endif()
  if(ANKLEHIP_AARCH64)
    add_dependencies(${target} aarch64_fmus)
  endif()
  set_property(TARGET ${target} PROPERTY FMU_FILE "${fmu}")
  set_property(TARGET ${target} PROPERTY FMU_STAGE_DIR "${stage}")
endfunction()

function(add_fmu)
  cmake_parse_arguments(FMU "SCHEDULED_EXECUTION" "NAME;OUTPUT_DIR"
                        "SOURCES;LINK;INCLUDE_DIRS;DOCUMENTATION;DOCUMENTATION_IMAGES;SOURCE_FMU_FILES;SOURCE_FMU_HEADER_DIRS;SOURCE_FMU_DEPENDENCIES" ${ARGN})
  if(NOT FMU_NAME OR NOT FMU_SOURCES)
    message(FATAL_ERROR "add_fmu: NAME and SOURCES are required")
  endif()
  if(NOT TARGET fmuglue)
    message(FATAL_ERROR "add_fmu: target fmuglue (fmu/common) must be defined first")
  endif()
  if(NOT ANKLEHIP_FMU_DIR)
    set(ANKLEHIP_FMU_DIR "${CMAKE_BINARY_DIR}/fmus")
  endif()
  if(FMU_OUTPUT_DIR)
    set(ANKLEHIP_FMU_DIR "${FMU_OUTPUT_DIR}")
  endif()
  set(name ${FMU_NAME})

  if(ANKLEHIP_FMU_BINARIES_ONLY)
    # Another platform's binaries only (the sub-builds of cmake/FmuBinariesSubbuild.cmake; add_fmu
    # packs them): the FMI 2.0 and the FMI 3.0 library, no generator, no packing.
    _add_fmu_binary(${name} ${name} fmi2 "${FMU_LINK}" "${FMU_INCLUDE_DIRS}" ${FMU_SOURCES})
    _add_fmu_binary(${name}_fmi3 ${name} fmi3 "${FMU_LINK}" "${FMU_INCLUDE_DIRS}" ${FMU_SOURCES})
    return()
  endif()

  # Model sources compiled once, used by the shared library and by the generator.
  add_library(${name}_objs OBJECT ${FMU_SOURCES})
  target_link_libraries(${name}_objs PUBLIC fmuglue ${FMU_LINK})
  target_include_directories(${name}_objs PRIVATE ${FMU_INCLUDE_DIRS})
  set_target_properties(${name}_objs PROPERTIES POSITION_INDEPENDENT_CODE ON
    CXX_VISIBILITY_PRESET hidden C_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
  target_compile_options(${name}_objs PRIVATE -ffunction-sections -fdata-sections)

  # The FMU binary: this build's, or the glibc-baseline sub-build's (cmake/LinuxBaselineFmus.cmake).
  # The FMI 3.0 twin's binary is built beside it from the same objects (fmi3_api.cpp instead of
  # fmi2_api.cpp) and packed the same way.
  if(ANKLEHIP_LINUX_BASELINE_BINARY_DIR)
    set(so "${ANKLEHIP_LINUX_BASELINE_BINARY_DIR}/${name}.so")
    set(so_dep "${so}")
    set(so3 "${ANKLEHIP_LINUX_BASELINE_BINARY_DIR}/fmi3/${name}.so")
    set(so3_dep "${so3}")
  else()
    _add_fmu_binary(${name} ${name} fmi2 "${FMU_LINK}" "" $<TARGET_OBJECTS:${name}_objs>)
    set(so $<TARGET_FILE:${name}>)
    set(so_dep ${name})
    _add_fmu_binary(${name}_fmi3 ${name} fmi3 "${FMU_LINK}" "" $<TARGET_OBJECTS:${name}_objs>)
    set(so3 $<TARGET_FILE:${name}_fmi3>)
    set(so3_dep ${name}_fmi3)
  endif()

  # The coverage-guided FMI fuzzer of this FMU (fmu/fuzz/fmi_fuzz.cpp, docs/reliability.md): both C
  # APIs (the FMI 2.0 FMU's and its FMI 3.0 twin's) over the same glue and model objects.
  if(ANKLEHIP_FUZZ)
    target_compile_options(${name}_objs PRIVATE -fsanitize=fuzzer-no-link)
    add_executable(${name}_fuzz "${_ADD_FMU_GLUE_SRC}/../../fuzz/fmi_fuzz.cpp" "${_ADD_FMU_GLUE_SRC}/fmi2_api.cpp"
                   "${_ADD_FMU_GLUE_SRC}/fmi3_api.cpp" $<TARGET_OBJECTS:${name}_objs>)
    target_include_directories(${name}_fuzz PRIVATE "${_ADD_FMU_GLUE_SRC}")
    target_link_libraries(${name}_fuzz PRIVATE fmuglue ${FMU_LINK})
    target_compile_options(${name}_fuzz PRIVATE -fsanitize=fuzzer)
    target_link_options(${name}_fuzz PRIVATE -fsanitize=fuzzer)
  endif()

  # The generator of modelDescription.xml / documentation.
  add_executable(${name}_gen "${_ADD_FMU_GLUE_SRC}/gen_main.cpp" $<TARGET_OBJECTS:${name}_objs>)
  target_link_libraries(${name}_gen PRIVATE fmuglue ${FMU_LINK})

  _add_fmu_package(${name} fmi2 "${so}" "${so_dep}")
  _add_fmu_package(${name} fmi3 "${so3}" "${so3_dep}")
  # SCHEDULED_EXECUTION: also <ANKLEHIP_FMU_DIR>/fmi3/<name>_se.fmu, the FMI 3.0 Scheduled Execution
  # variant (the model's ModelInfo::clock): the FMI 3.0 library with its own description.
  if(FMU_SCHEDULED_EXECUTION)
    _add_fmu_package(${name} fmi3se "${so3}" "${so3_dep}")
  endif()
endfunction()
