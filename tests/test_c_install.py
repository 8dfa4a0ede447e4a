"""The C library as a package (docs/controller.md, "Building against the library"): `cmake --install`
puts libahc.a, self-contained headers (ahc/controller.h and the generated hoap2/nominal.h it
includes), a CMake package and a pkg-config file into a prefix, and a program outside this build
(tests/c_consumer) builds against that prefix both ways -- find_package(ahc) and pkg-config -- and
runs: the controller it links reaches the ankle->hip transition."""
from __future__ import annotations

import os
import shutil
import subprocess

import pytest

from conftest import REPO_ROOT

CONSUMER = REPO_ROOT / "tests" / "c_consumer"
HEADERS = ("ahc/controller.h", "ahc/frontal.h", "ahc/leg_ik.h", "ahc/stepping.h", "ahc/controller3d.h")
INSTALLED = {*(f"include/{h}" for h in HEADERS), "include/hoap2/nominal.h", "lib/libahc.a",
             "lib/cmake/ahc/ahcConfig.cmake", "lib/cmake/ahc/ahcConfigVersion.cmake",
             "lib/cmake/ahc/ahcTargets.cmake", "lib/pkgconfig/ahc.pc"}


def _run(cmd, **kw):
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=300, **kw)
    assert r.returncode == 0, f"{' '.join(map(str, cmd))} exited {r.returncode}:\n{r.stdout}\n{r.stderr}"
    return r


@pytest.fixture(scope="module", params=["controller_c alone", "the whole build"])
def prefix(request, build_dir, tmp_path_factory):
    """`cmake --install` into a fresh prefix (nothing but the C library): of controller_c configured
    on its own with a C compiler only (the one-line build of docs/controller.md), and of the whole
    build (scripts/setup.sh's)."""
    cmake = shutil.which("cmake")
    p = tmp_path_factory.mktemp("ahc") / "prefix"
    if request.param == "controller_c alone":
        b = p.parent / "build-ahc"
        _run([cmake, "-S", REPO_ROOT / "controller_c", "-B", b], env=_clean_env())
        _run([cmake, "--build", b, "-j2"], env=_clean_env())
        _run(["ctest", "--test-dir", b, "--output-on-failure"], env=_clean_env())
        _run([cmake, "--install", b, "--prefix", p])
    else:
        _run([cmake, "--install", build_dir, "--prefix", p])
    files = {q.relative_to(p).as_posix() for q in p.rglob("*") if q.is_file()}
    files = {f.replace("lib64/", "lib/") for f in files if not f.startswith("lib/cmake/ahc/ahcTargets-")}
    assert files == INSTALLED, f"installed: {sorted(files)}"
    return p


def _libdir(prefix):
    return next(d for d in (prefix / "lib", prefix / "lib64") if (d / "libahc.a").is_file())


def _clean_env():
    """No trace of this repository's build: the consumer sees the prefix only."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ANKLEHIP", "CMAKE_", "PKG_CONFIG"))}
    env.pop("CPATH", None)
    env.pop("C_INCLUDE_PATH", None)
    env.pop("LIBRARY_PATH", None)
    return env


def _check_consumer(exe):
    r = _run([exe])
    assert r.stdout.startswith("ahc ok: phase 1 (") or r.stdout.startswith("ahc ok: phase 2 ("), r.stdout
    assert "nominal mass 6.5041 kg" in r.stdout      # HOAP2_M1 + HOAP2_M2 from the installed nominal.h


@pytest.mark.parametrize("header", HEADERS)
def test_headers_are_self_contained(prefix, header):
    """Each public header (the sagittal controller's, the frontal layer's, the legs' kinematics and
    the 3D controller's) compiles alone with the prefix's include folder (the first compile of the
    issue failed: "hoap2/nominal.h: No such file")."""
    src = prefix.parent / "only_header.c"
    src.write_text(f'#include "{header}"\nint main(void) {{ return 0; }}\n')
    _run([shutil.which("cc"), "-std=c99", "-Wall", "-Werror", "-I", prefix / "include", src,
          "-o", prefix.parent / "only_header"], env=_clean_env())


def test_consumer_with_find_package(prefix, tmp_path):
    b = tmp_path / "build"
    cmake = shutil.which("cmake")
    _run([cmake, "-S", CONSUMER, "-B", b, f"-DCMAKE_PREFIX_PATH={prefix}", "-DCMAKE_BUILD_TYPE=Release"],
         env=_clean_env())
    _run([cmake, "--build", b], env=_clean_env())
    # the imported target points into the prefix, never into this repository
    targets = (_libdir(prefix) / "cmake" / "ahc" / "ahcTargets.cmake").read_text()
    assert str(REPO_ROOT) not in targets
    _check_consumer(b / "ahc_consumer")


def test_consumer_with_pkg_config(prefix, tmp_path):
    env = dict(_clean_env(), PKG_CONFIG_PATH=str(_libdir(prefix) / "pkgconfig"))
    flags = _run([shutil.which("pkg-config") or "pkg-config", "--cflags", "--libs", "ahc"], env=env).stdout.split()
    assert "-lahc" in flags and "-lm" in flags
    exe = tmp_path / "ahc_consumer"
    _run([shutil.which("cc"), "-std=c99", CONSUMER / "main.c", "-o", exe, *flags], env=env)
    _check_consumer(exe)


def test_consumer_from_the_sources(tmp_path):
    """The line without an install: the sources and both include folders, and -lm."""
    exe = tmp_path / "ahc_consumer"
    srcs = sorted((REPO_ROOT / "controller_c" / "src").glob("*.c"))
    _run([shutil.which("cc"), "-std=c99", "-I", REPO_ROOT / "controller_c" / "include", "-I",
          REPO_ROOT / "hoap2" / "include", CONSUMER / "main.c", *srcs, "-lm", "-o", exe], env=_clean_env())
    _check_consumer(exe)
