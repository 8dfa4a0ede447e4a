#!/usr/bin/env bash
# One-time (and idempotent) set-up: Debian packages, the Python virtual environment .venv with the
# project installed in editable mode, and the native build in build/ (libraries, tests, FMUs).
# Fast and silent when everything is already there; prints what it does otherwise.
#   --win64     also the Windows 64-bit binaries of every FMU (mingw-w64 cross build, packed next to
#               linux64) and Wine to run them (tests/test_win64.py); kept on for later runs.
#   --aarch64   also the aarch64 Linux binaries of every FMU (zig cc, packed as
#               binaries/aarch64-linux) and an aarch64 anklehip_rt_step, and Debian's qemu-user and
#               libc6-arm64-cross to run them (tests/test_aarch64.py); kept on for later runs.
#               llvm (llvm-nm, llvm-readelf) to check the cross-built binaries comes with it.
#   --fmi-sim   also the Rust FMI importer fmi-sim 0.7 (crates registry; Debian's libclang-dev for
#               its bindgen build) in <build>/fmi-sim, for tests/test_fmi_sim.py; needs Rust's cargo.
#   --sanitize  also the reliability build in <build>/sanitize: every native target with clang,
#               AddressSanitizer + UndefinedBehaviorSanitizer and a libFuzzer harness per FMU, and
#               Valgrind (scripts/reliability.sh, docs/reliability.md).
set -euo pipefail
win64=0
sanitize=0
aarch64=0
fmisim=0
for arg in "$@"; do
  case "$arg" in
    --win64) win64=1 ;;
    --sanitize) sanitize=1 ;;
    --aarch64) aarch64=1 ;;
    --fmi-sim) fmisim=1 ;;
    *) echo "usage: bash scripts/setup.sh [--win64] [--sanitize] [--aarch64] [--fmi-sim]" >&2; exit 2 ;;
  esac
done
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

# --- Debian source entry (deb-src) ------------------------------------------------------------
# The build compiles ODE from Debian's source package (cmake/OdeFromDebianSource.cmake: Debian's
# libode.a is not position independent), fetched with `apt-get source`, which needs a deb-src
# entry for deb.debian.org and its source index.
apt_updated=0
has_debsrc() {
  local f
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [ -f "$f" ] && grep -Eq '^[[:space:]]*deb-src[[:space:]].*deb\.debian\.org/debian/?([[:space:]]|$)' "$f" && return 0
  done
  for f in /etc/apt/sources.list.d/*.sources; do
    # deb822: one stanza per paragraph; enabled, Types with deb-src, URIs on deb.debian.org/debian
    [ -f "$f" ] && awk -v RS= '
      /(^|\n)Types:[^\n]*deb-src/ && /(^|\n)URIs:[^\n]*deb\.debian\.org\/debian\/?([ \t\n]|$)/ &&
      !/(^|\n)Enabled:[ \t]*no/ { found = 1 } END { exit !found }' "$f" && return 0
  done
  return 1
}
if ! has_debsrc; then
  if [ "$(id -u)" -ne 0 ]; then echo "setup: need root to add a deb-src entry for deb.debian.org" >&2; exit 1; fi
  # Mirror the deb entry of debian.sources (URIs, Signed-By), main component only.
  codename="$(. /etc/os-release && echo "${VERSION_CODENAME:-bookworm}")"
  uris=http://deb.debian.org/debian
  signed=/usr/share/keyrings/debian-archive-keyring.gpg
  if [ -f /etc/apt/sources.list.d/debian.sources ]; then
    stanza="$(awk -v RS= '/(^|\n)Types:[^\n]*deb/ && /(^|\n)URIs:[^\n]*deb\.debian\.org\/debian\/?([ \t\n]|$)/ { print; exit }' \
      /etc/apt/sources.list.d/debian.sources)"
    u="$(sed -n 's/^URIs:[[:space:]]*//p' <<<"$stanza" | head -n1)"; [ -n "$u" ] && uris="$u"
    s="$(sed -n 's/^Signed-By:[[:space:]]*//p' <<<"$stanza" | head -n1)"; [ -n "$s" ] && signed="$s"
  fi
  echo "setup: adding deb-src entry /etc/apt/sources.list.d/anklehip-deb-src.sources"
  printf 'Types: deb-src\nURIs: %s\nSuites: %s %s-updates\nComponents: main\nSigned-By: %s\n' \
    "$uris" "$codename" "$codename" "$signed" >/etc/apt/sources.list.d/anklehip-deb-src.sources
  apt-get update -qq
  apt_updated=1
elif ! compgen -G '/var/lib/apt/lists/deb.debian.org_debian_dists_*_main_source_Sources*' >/dev/null; then
  # The entry is there, but its source index was never downloaded.
  if [ "$(id -u)" -ne 0 ]; then echo "setup: need root to run apt-get update (no Debian source index)" >&2; exit 1; fi
  echo "setup: downloading the Debian source index (apt-get update)"
  apt-get update -qq
  apt_updated=1
fi

# --- Debian packages the build needs ---------------------------------------------------------
# dpkg-dev: dpkg-source, to unpack Debian's ODE source package. pkgconf: pkg-config, for the test that
# builds a program against the installed C library (tests/test_c_install.py).
debs=(build-essential cmake dpkg-dev libeigen3-dev libsundials-dev libode-dev pkgconf python3 python3-venv python3-dev)
# --win64: the posix-thread mingw-w64 C/C++ cross compilers (with binutils, objdump) and Wine.
[ "$win64" -eq 1 ] && debs+=(gcc-mingw-w64-x86-64-posix g++-mingw-w64-x86-64-posix wine64)
# --sanitize: clang with its sanitizer and libFuzzer runtimes, the OpenMP runtime SUNDIALS' CMake
# package asks clang for, llvm-symbolizer for readable reports, and Valgrind.
[ "$sanitize" -eq 1 ] && debs+=(clang libclang-rt-dev libomp-dev llvm valgrind)
# --aarch64: qemu-user (qemu-aarch64), the aarch64 glibc and loader it runs the runner with, llvm.
[ "$aarch64" -eq 1 ] && debs+=(qemu-user libc6-arm64-cross llvm)
# --fmi-sim: libclang for the bindgen step of fmi-sim's build.
[ "$fmisim" -eq 1 ] && debs+=(libclang-dev)
missing=()
for p in "${debs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing Debian packages: ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then echo "setup: need root to install ${missing[*]}" >&2; exit 1; fi
  export DEBIAN_FRONTEND=noninteractive
  [ "$apt_updated" -eq 1 ] || apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# --- A moved or copied checkout: a .venv or build folder made for another path is rebuilt ------
build="${ANKLEHIP_BUILD_DIR:-build}"
bash scripts/check_location.sh "$root" "$build"

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
  { .venv/bin/python -m pip install --upgrade pip && .venv/bin/python -m pip install -e ".[test,build,robot]"; } >"$log" 2>&1 \
    || { tail -n 40 "$log"; echo "setup: pip install failed (full log: $log)" >&2; exit 1; }
  touch "$stamp"
fi

# --- Native build (controller library, plant, FMUs, native tests) -----------------------------
# The venv's bin comes first on PATH so the FMPy-pulled cmake (4.x) is used when present, as a
# user's activated venv would; the build also works with Debian's cmake 3.25.
export PATH="$root/.venv/bin:$PATH"
win_flag=()
[ "$win64" -eq 1 ] && win_flag+=(-DANKLEHIP_WIN64=ON)
[ "$aarch64" -eq 1 ] && win_flag+=(-DANKLEHIP_AARCH64=ON)
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE="$root/.venv/bin/python" "${win_flag[@]}" >/dev/null
else
  if [ "$win64" -eq 1 ] && ! grep -q '^ANKLEHIP_WIN64:BOOL=ON' "$build/CMakeCache.txt"; then
    echo "setup: enabling the Windows 64-bit FMU binaries in $build"
    cmake -S . -B "$build" -DANKLEHIP_WIN64=ON >/dev/null
  fi
  if [ "$aarch64" -eq 1 ] && ! grep -q '^ANKLEHIP_AARCH64:BOOL=ON' "$build/CMakeCache.txt"; then
    echo "setup: enabling the aarch64 Linux FMU binaries in $build"
    cmake -S . -B "$build" -DANKLEHIP_AARCH64=ON >/dev/null
  fi
fi
cmake --build "$build" -j"$(nproc)" >"$build/last-build.log" 2>&1 || { cat "$build/last-build.log"; exit 1; }

# --- Reliability build (--sanitize) -----------------------------------------------------------
if [ "$sanitize" -eq 1 ]; then
  sbuild="$build/sanitize"
  if [ ! -f "$sbuild/CMakeCache.txt" ]; then
    echo "setup: configuring the sanitizer and fuzzing build in $sbuild"
    CC=clang CXX=clang++ cmake -S . -B "$sbuild" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DANKLEHIP_FUZZ=ON \
      -DPython3_EXECUTABLE="$root/.venv/bin/python" >/dev/null
  fi
  cmake --build "$sbuild" -j"$(nproc)" >"$sbuild/last-build.log" 2>&1 || { cat "$sbuild/last-build.log"; exit 1; }
fi

# --- fmi-sim (--fmi-sim) ----------------------------------------------------------------------
# An FMI importer that shares no code with FMPy or libcosim (Rust; FMI 2.0 and 3.0), built once
# from the crates registry into <build>/fmi-sim (tests/test_fmi_sim.py, docs/integration.md).
# Unoptimised (--debug, with Rust's overflow checks): 3.3 min to compile on the 2-core machine
# against 7.3 min for a release build, and its tests run in 12 s instead of 6 s. The benchmark
# (bench/report.py, docs/performance.md) times a release fmi-sim on PATH, not this one.
if [ "$fmisim" -eq 1 ] && [ ! -x "$build/fmi-sim/bin/fmi-sim" ]; then
  cargo_bin="$(command -v cargo || true)"
  [ -n "$cargo_bin" ] || [ ! -x "$HOME/.cargo/bin/cargo" ] || cargo_bin="$HOME/.cargo/bin/cargo"
  if [ -z "$cargo_bin" ]; then echo "setup: --fmi-sim needs Rust's cargo (https://rustup.rs)" >&2; exit 1; fi
  echo "setup: building fmi-sim 0.7.0 (cargo install --debug) into $build/fmi-sim"
  log="$build/fmi-sim-install.log"
  "$cargo_bin" install fmi-sim --version 0.7.0 --debug --root "$build/fmi-sim" >"$log" 2>&1 \
    || { tail -n 40 "$log"; echo "setup: cargo install fmi-sim failed (full log: $log)" >&2; exit 1; }
fi
