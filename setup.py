"""The wheel's build steps beyond pyproject.toml (README, "Installing the wheel"):

    bash scripts/setup.sh --win64                       # the native build, FMUs with win64 binaries
    .venv/bin/python -m build --wheel --no-isolation    # -> dist/anklehip-<version>-py3-none-manylinux...whl
    ANKLEHIP_BUILD_DIR=$PWD/build .venv/bin/python -m build --no-isolation   # the sdist too, and the wheel from it

The wheel holds the package and, as package data (anklehip/data/, found by anklehip.files.paths
when there is no checkout), what the native build made and the repository's data:

    fmus/       the FMUs exactly as they ship (anklehip.files.paths.SHIPPED) (binaries/linux64 built against glibc 2.17, binaries/win64)
    lib/        libanklehip_closed_loop.so, the native closed-loop engine of the glibc-2.17 sub-build
    scenarios/  the scenarios with their references and sweep files
    steptests/  the recorded step-test cases

It is tagged manylinux_2_17_x86_64 (the native engine is a Linux x86-64 library; the FMUs' own
binaries carry no Python ABI). The build folder is $ANKLEHIP_BUILD_DIR or build/; a missing piece is
an error naming it. An editable install (scripts/setup.sh) takes none of this: it runs from the
checkout. tests/test_wheel.py builds the wheel and installs it where no compiler and no checkout is.
"""
from __future__ import annotations

import os
import shutil
import sys
import zipfile
from pathlib import Path

from setuptools import setup
from setuptools.command.build import build
from setuptools.command.build_py import build_py

try:
    from setuptools.command.bdist_wheel import bdist_wheel
except ImportError:            # setuptools < 70.1
    from wheel.bdist_wheel import bdist_wheel

ROOT = Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT))
from anklehip.files.paths import SHIPPED as FMUS  # noqa: E402  (the package's one list; importing it is cheap)
PLATFORMS = ("linux64", "win64")
NATIVE = "libanklehip_closed_loop.so"
PLATFORM_TAG = "manylinux_2_17_x86_64.manylinux2014_x86_64"


def build_dir() -> Path:
    env = os.environ.get("ANKLEHIP_BUILD_DIR")
    return (ROOT / env if env and not os.path.isabs(env) else Path(env)) if env else ROOT / "build"


def package_data_sources() -> dict[str, Path]:
    """Destination in anklehip/data -> source; a SystemExit naming what is missing and the fix."""
    b = build_dir()
    hint = ("build it first: `bash scripts/setup.sh --win64`, then `python -m build --wheel` in the checkout (to build "
            "from an sdist, set ANKLEHIP_BUILD_DIR to the checkout's build folder)")
    src: dict[str, Path] = {}
    for name in FMUS:
        fmu = b / "fmus" / f"{name}.fmu"
        if not fmu.is_file():
            raise SystemExit(f"setup.py: {fmu} is missing: {hint}")
        with zipfile.ZipFile(fmu) as z:
            have = {n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") >= 2}
        missing = [p for p in PLATFORMS if p not in have]
        if missing:
            raise SystemExit(f"setup.py: {fmu} has no binaries/{', '.join(missing)}: the wheel ships the FMUs with "
                             f"{' and '.join(PLATFORMS)} binaries; {hint}")
        src[f"fmus/{name}.fmu"] = fmu
    lib = b / "linux64" / "binaries" / NATIVE
    if not lib.is_file():
        raise SystemExit(f"setup.py: {lib} is missing (the glibc-2.17 build of the native engine, "
                         f"cmake/LinuxBaselineFmus.cmake): {hint}")
    src[f"lib/{NATIVE}"] = lib
    for f in sorted((ROOT / "scenarios").rglob("*")):
        if f.is_file() and f.suffix in (".toml", ".csv"):
            src[f"scenarios/{f.relative_to(ROOT / 'scenarios').as_posix()}"] = f
    for f in sorted((ROOT / "tests" / "steptests").rglob("*")):
        if f.is_file():
            src[f"steptests/{f.relative_to(ROOT / 'tests' / 'steptests').as_posix()}"] = f
    return src


class BuildPy(build_py):
    """The package, plus anklehip/data/ from the native build and the repository (not for an
    editable install, which runs from the checkout)."""

    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            return
        data = Path(self.build_lib) / "anklehip" / "data"
        if data.exists():
            shutil.rmtree(data)
        for dest, src in package_data_sources().items():
            target = data / dest
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, target)


class Build(build):
    """setuptools' scratch folder inside the CMake build folder, not beside it (build/ is CMake's)."""

    def initialize_options(self):
        super().initialize_options()
        self.build_base = str(build_dir() / "python-wheel")


class PlatformWheel(bdist_wheel):
    """py3-none-manylinux_2_17_x86_64: native code (ctypes, no Python ABI) for glibc >= 2.17."""

    def finalize_options(self):
        super().finalize_options()
        self.root_is_pure = False

    def get_tag(self):
        return "py3", "none", PLATFORM_TAG


setup(cmdclass={"build_py": BuildPy, "build": Build, "bdist_wheel": PlatformWheel})
