# anklehip_debian_source(<source package> VERSION_OF <installed binary package> MARKER <file>
#                        SOURCE_DIR <path or empty> OUT_SRC <var> OUT_ORIGIN <var>)
#
# Provides the extracted source tree of a Debian source package, for the third-party libraries the
# build compiles itself (ODE as a PIC static library; SUNDIALS and ODE for the Windows binaries).
# No third-party source is kept in this repository.
#
# A non-empty SOURCE_DIR is used as it is (it must contain MARKER). Otherwise the package is
# fetched with `apt-get source --download-only <pkg>=<version of VERSION_OF>` (the same upstream
# version and Debian patches as the installed headers and libraries; any version when that package
# is not installed), which needs a deb-src entry (scripts/setup.sh adds one) and dpkg-dev, and is
# unpacked with its Debian patches (dpkg-source -x) into ${CMAKE_BINARY_DIR}/_deps/<pkg>-src, where
# later configure runs reuse it. OUT_ORIGIN says where the tree came from (for messages, and as the
# key that makes a build of another tree start from scratch).
include_guard(GLOBAL)

function(anklehip_debian_source pkg)
  cmake_parse_arguments(DS "" "VERSION_OF;MARKER;SOURCE_DIR;OUT_SRC;OUT_ORIGIN" "" ${ARGN})
  if(DS_SOURCE_DIR)
    if(NOT EXISTS "${DS_SOURCE_DIR}/${DS_MARKER}")
      message(FATAL_ERROR "${DS_SOURCE_DIR} is not a ${pkg} source tree (no ${DS_MARKER}).")
    endif()
    set(${DS_OUT_SRC} "${DS_SOURCE_DIR}" PARENT_SCOPE)
    set(${DS_OUT_ORIGIN} "${DS_SOURCE_DIR}" PARENT_SCOPE)
    return()
  endif()

  set(deps "${CMAKE_BINARY_DIR}/_deps")
  set(debdir "${deps}/${pkg}-deb")
  set(src "${deps}/${pkg}-src")
  set(stamp "${deps}/${pkg}-src.stamp")  # the version asked for when extracted ("any": unpinned)

  set(version "")
  find_program(ANKLEHIP_DPKG_QUERY dpkg-query)
  mark_as_advanced(ANKLEHIP_DPKG_QUERY)
  if(ANKLEHIP_DPKG_QUERY AND DS_VERSION_OF)
    execute_process(COMMAND "${ANKLEHIP_DPKG_QUERY}" -W -f=\${Version} "${DS_VERSION_OF}"
                    OUTPUT_VARIABLE version RESULT_VARIABLE rc
                    OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    if(NOT rc EQUAL 0)
      set(version "")
    endif()
  endif()
  if(version)
    set(want "${version}")
    set(request "${pkg}=${version}")
  else()
    set(want "any")
    set(request "${pkg}")
  endif()

  set(have "")
  if(EXISTS "${stamp}" AND EXISTS "${src}/${DS_MARKER}")
    file(READ "${stamp}" have)
    string(STRIP "${have}" have)
  endif()
  # An unpinned request is satisfied by whatever was extracted before.
  if(NOT have OR (NOT want STREQUAL "any" AND NOT have STREQUAL want))
    find_program(ANKLEHIP_APT_GET apt-get)
    find_program(ANKLEHIP_DPKG_SOURCE dpkg-source)
    mark_as_advanced(ANKLEHIP_APT_GET ANKLEHIP_DPKG_SOURCE)
    set(alt "or pass the path of an extracted ${pkg} source tree (see the FATAL_ERROR's caller)")
    if(NOT ANKLEHIP_APT_GET)
      message(FATAL_ERROR "${pkg} source: apt-get not found (a Debian-based system is needed to "
                          "fetch Debian's ${pkg} source); ${alt}.")
    endif()
    if(NOT ANKLEHIP_DPKG_SOURCE)
      message(FATAL_ERROR "${pkg} source: dpkg-source not found: install dpkg-dev (run "
                          "scripts/setup.sh); ${alt}.")
    endif()

    message(STATUS "${pkg} source: apt-get source --download-only ${request}")
    file(REMOVE_RECURSE "${debdir}")
    file(MAKE_DIRECTORY "${debdir}")
    execute_process(COMMAND "${ANKLEHIP_APT_GET}" source --download-only "${request}"
                    WORKING_DIRECTORY "${debdir}"
                    OUTPUT_VARIABLE out ERROR_VARIABLE out RESULT_VARIABLE rc)
    file(GLOB dsc "${debdir}/${pkg}_*.dsc")
    if(NOT rc EQUAL 0 OR NOT dsc)
      if(out MATCHES "deb-src")
        set(why "no deb-src entry: run scripts/setup.sh (as root), which adds one for deb.debian.org")
      elseif(out MATCHES "find a source package|no longer downloadable|Can not find version")
        string(CONCAT why "apt has no source package ${request}: run `apt-get update` (scripts/"
               "setup.sh does it when the source index is missing), or upgrade ${DS_VERSION_OF}")
      else()
        set(why "`apt-get source --download-only ${request}` failed (network? apt lists?)")
      endif()
      message(FATAL_ERROR "${pkg} source: ${why}; ${alt}.\napt-get said:\n${out}")
    endif()
    list(GET dsc 0 dsc)

    # Extract next to the final place, then rename: an interrupted run leaves no half tree behind.
    file(REMOVE_RECURSE "${src}" "${src}.tmp" "${stamp}")
    execute_process(COMMAND "${ANKLEHIP_DPKG_SOURCE}" --no-copy -x "${dsc}" "${src}.tmp"
                    WORKING_DIRECTORY "${debdir}"
                    OUTPUT_VARIABLE out ERROR_VARIABLE out RESULT_VARIABLE rc)
    if(NOT rc EQUAL 0 OR NOT EXISTS "${src}.tmp/${DS_MARKER}")
      message(FATAL_ERROR "${pkg} source: `dpkg-source -x ${dsc}` failed:\n${out}")
    endif()
    file(RENAME "${src}.tmp" "${src}")
    file(WRITE "${stamp}" "${want}\n")
  endif()
  file(STRINGS "${src}/debian/changelog" changelog LIMIT_COUNT 1)
  string(REGEX REPLACE "^[^(]*\\(([^)]*)\\).*" "\\1" changelog "${changelog}")
  file(TIMESTAMP "${stamp}" when UTC)
  set(${DS_OUT_SRC} "${src}" PARENT_SCOPE)
  set(${DS_OUT_ORIGIN} "Debian source package ${pkg} ${changelog} (extracted ${when})" PARENT_SCOPE)
endfunction()

# anklehip_fresh_build_on_new_source(<key> <dir>...): removes the build/install dirs when the
# source (origin key) changed since the last configure: re-extracted files keep their tarball
# times, older than the objects of the previous build, so an incremental build would miss them.
function(anklehip_fresh_build_on_new_source name key)
  set(key_file "${CMAKE_BINARY_DIR}/_deps/${name}-build.source")
  set(old "")
  if(EXISTS "${key_file}")
    file(READ "${key_file}" old)
  endif()
  if(NOT old STREQUAL key)
    file(REMOVE_RECURSE ${ARGN})
    file(WRITE "${key_file}" "${key}")
  endif()
endfunction()
