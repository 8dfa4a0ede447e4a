#!/usr/bin/env bash
# A moved or copied checkout (called by scripts/setup.sh before it builds anything):
#   bash scripts/check_location.sh <checkout> <build folder>
# A virtual environment records its own path (the #! lines of its scripts, the editable install
# of the package) and a CMake build its source and build folders. Copied or moved with the
# checkout they still point at the old tree: `anklehip run` would read the old tree's scenarios
# and cmake refuses the cache. Each one made for another path is removed here, and said so, so
# that setup.sh makes it afresh (a build folder outside the checkout is not deleted: an error says
# so). Paths are compared with symbolic links resolved.
set -euo pipefail
root="$(cd "$1" && pwd -P)"
build="$2"
case "$build" in /*) ;; *) build="$root/$build" ;; esac
same() { [ "$(realpath -m -- "$1")" = "$(realpath -m -- "$2")" ]; }

venv="$root/.venv"
if [ -d "$venv" ]; then
  # VIRTUAL_ENV="/path" or export VIRTUAL_ENV="/path" (newer Pythons), the first absolute one
  made_for="$(grep -E '^ *(export +)?VIRTUAL_ENV=["'"'"']?/' "$venv/bin/activate" 2>/dev/null | head -n1 |
              sed -E 's/^ *(export +)?VIRTUAL_ENV=//' | tr -d "\"'")"
  if [ -z "$made_for" ] || ! same "$made_for" "$venv"; then
    echo "setup: $venv was made for ${made_for:-an unknown folder} (a moved or copied checkout): recreating it"
    rm -rf "$venv"
  fi
fi

cache="$build/CMakeCache.txt"
if [ -f "$cache" ]; then
  src="$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$cache")"
  bin="$(sed -n 's/^CMAKE_CACHEFILE_DIR:INTERNAL=//p' "$cache")"
  if ! same "$src" "$root" || ! same "$bin" "$build"; then
    case "$(realpath -m -- "$build")/" in
      "$root"/*)
        echo "setup: $build was configured for the sources in $src (build folder $bin), not $root: building it afresh"
        rm -rf "$build" ;;
      *)  # outside the checkout (ANKLEHIP_BUILD_DIR): not ours to delete
        echo "setup: $build was configured for the sources in $src (build folder $bin), not $root;" \
             "remove it or set ANKLEHIP_BUILD_DIR to another folder" >&2
        exit 1 ;;
    esac
  fi
fi
