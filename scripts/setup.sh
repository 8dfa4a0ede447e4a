#!/usr/bin/env bash
# One-time (and idempotent) set-up: Debian packages, the Python virtual environment .venv with the
# project installed in editable mode, and the native build in build/ (libraries, tests, FMUs).
# Fast and silent when everything is already there; prints what it does otherwise.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

# --- Debian packages the build needs ---------------------------------------------------------
debs=(build-essential cmake libeigen3-dev libsundials-dev libode-dev python3 python3-venv python3-dev)
missing=()
for p in "${debs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing Debian packages: ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then echo "setup: need root to install ${missing[*]}" >&2; exit 1; fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# --- Python virtual environment ---------------------------------------------------------------
py="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv"
  "$py" -m venv .venv
fi
stamp=.venv/.anklehip-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  echo "setup: installing the Python package and its test dependencies into .venv"
  log=.venv/pip-install.log
  { .venv/bin/python -m pip install --upgrade pip && .venv/bin/python -m pip install -e ".[test]"; } >"$log" 2>&1 \
    || { tail -n 40 "$log"; echo "setup: pip install failed (full log: $log)" >&2; exit 1; }
  touch "$stamp"
fi

# --- Native build (controller library, plant, FMUs, native tests) -----------------------------
# The venv's bin comes first on PATH so the FMPy-pulled cmake (4.x) is used when present, as a
# user's activated venv would; the build also works with Debian's cmake 3.25.
export PATH="$root/.venv/bin:$PATH"
build="${ANKLEHIP_BUILD_DIR:-build}"
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE="$root/.venv/bin/python" >/dev/null
fi
cmake --build "$build" -j"$(nproc)" >"$build/last-build.log" 2>&1 || { cat "$build/last-build.log"; exit 1; }
