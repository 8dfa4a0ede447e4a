"""scripts/check_location.sh, run by scripts/setup.sh before it builds: a checkout that was moved
or copied with its .venv and build folder gets both made afresh (the venv's editable install and
the CMake cache point at the old tree); a checkout in place is left alone; a build folder outside
the checkout that belongs to another tree is refused, not deleted."""
from __future__ import annotations

import subprocess

from conftest import REPO_ROOT

SCRIPT = REPO_ROOT / "scripts" / "check_location.sh"


def _tree(co, venv_for, build, src_for, bin_for):
    (co / ".venv" / "bin").mkdir(parents=True)
    (co / ".venv" / "bin" / "activate").write_text(f'# This file must be used with "source"\nVIRTUAL_ENV="{venv_for}"\nexport VIRTUAL_ENV\n')
    build.mkdir(parents=True)
    (build / "CMakeCache.txt").write_text(f"CMAKE_CACHEFILE_DIR:INTERNAL={bin_for}\nCMAKE_HOME_DIRECTORY:INTERNAL={src_for}\n")


def _run(co, build):
    return subprocess.run(["bash", str(SCRIPT), str(co), str(build)], capture_output=True, text=True, timeout=60)


def test_a_checkout_in_place_is_left_alone(tmp_path):
    co = tmp_path / "co"
    _tree(co, co / ".venv", co / "build", co, co / "build")
    r = _run(co, "build")
    assert r.returncode == 0 and r.stdout == "" and r.stderr == ""
    assert (co / ".venv" / "bin" / "activate").exists() and (co / "build" / "CMakeCache.txt").exists()


def test_a_moved_checkout_gets_a_new_venv_and_build(tmp_path):
    old, co = tmp_path / "old", tmp_path / "moved"
    _tree(co, old / ".venv", co / "build", old, old / "build")
    # newer Pythons' activate script exports it, after a cygwin branch
    activate = co / ".venv" / "bin" / "activate"
    activate.write_text('if [ "${OSTYPE:-}" = "cygwin" ] ; then\n    export VIRTUAL_ENV=$(cygpath "C:\\x")\n'
                        f'else\n    export VIRTUAL_ENV="{old / ".venv"}"\nfi\n')
    r = _run(co, "build")
    assert r.returncode == 0, r.stderr
    assert not (co / ".venv").exists() and not (co / "build").exists()
    assert f"made for {old / '.venv'}" in r.stdout and f"configured for the sources in {old}" in r.stdout


def test_a_foreign_build_folder_outside_the_checkout_is_refused(tmp_path):
    co, other, build = tmp_path / "co", tmp_path / "other", tmp_path / "shared-build"
    _tree(co, co / ".venv", build, other, build)
    r = _run(co, build)
    assert r.returncode == 1 and "ANKLEHIP_BUILD_DIR" in r.stderr and str(other) in r.stderr
    assert (build / "CMakeCache.txt").exists()
