"""The wheel (setup.py, README "Installing the wheel"): built with `python -m build`, installed with
pip into a fresh virtual environment outside the checkout, where no compiler is on PATH and no build
tree on any path, it runs the main job and passes its checks.

Establishes:
  - `python -m build --wheel --no-isolation` makes one platform wheel (py3-none-manylinux_2_17_x86_64)
    holding the package, every shipped FMU (anklehip.files.paths.SHIPPED) exactly as the build packed
    it (linux64 and win64 binaries), the native engine built against glibc 2.17 (nothing else needed,
    only ahn_* exported),
    the scenarios with their references and sweep files, and the step-test cases;
  - its size is the one README.md states;
  - `pip install --only-binary=:all: <wheel>` into a venv made from the base interpreter, then, with
    PATH = that venv's bin and a folder of compilers that fail and record being called, HOME and
    LANG only, from a folder outside the checkout: `anklehip where` names the package's data and no
    checkout; `anklehip run paper_five_pushes` exits 0 with every check and the reference comparison
    passing; the native engine of the wheel gives the same CSV bytes as the FMPy master; the
    package, its data and sys.path lie outside the checkout; no compiler was called.
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from conftest import REPO_ROOT, SHIPPED
from test_linux_binaries import GLIBC_BASELINE, GLIBC_LIBRARIES, version_references, version_tuple

COMPILERS = ("cc", "gcc", "g++", "c++", "clang", "clang++", "cmake", "make", "ld", "zig", "x86_64-linux-gnu-gcc")
FMUS = SHIPPED


def _run(cmd, timeout=600, **kw):
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=timeout, **kw)
    assert r.returncode == 0, f"{' '.join(map(str, cmd))} exited {r.returncode}:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r


@pytest.fixture(scope="module")
def wheel(build_dir, tmp_path_factory) -> Path:
    dist = tmp_path_factory.mktemp("dist")
    env = dict(os.environ, ANKLEHIP_BUILD_DIR=str(build_dir))
    _run([sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", dist], cwd=REPO_ROOT, env=env)
    wheels = list(dist.glob("*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


def test_wheel_contents(wheel, build_dir, tmp_path):
    assert wheel.name == "anklehip-0.1.0-py3-none-manylinux_2_17_x86_64.manylinux2014_x86_64.whl"
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        data = {n.split("anklehip/data/", 1)[1]: n for n in names if "anklehip/data/" in n}
        for m in FMUS:
            packed = z.read(data[f"fmus/{m}.fmu"])
            assert packed == (build_dir / "fmus" / f"{m}.fmu").read_bytes(), f"{m}.fmu differs from the build's"
            (tmp_path / f"{m}.fmu").write_bytes(packed)
            with zipfile.ZipFile(tmp_path / f"{m}.fmu") as f:
                assert {f"binaries/linux64/{m}.so", f"binaries/win64/{m}.dll"} <= set(f.namelist()), m
        lib = tmp_path / "libanklehip_closed_loop.so"
        lib.write_bytes(z.read(data["lib/libanklehip_closed_loop.so"]))
    repo = {p.relative_to(REPO_ROOT / "scenarios").as_posix() for p in (REPO_ROOT / "scenarios").rglob("*")
            if p.is_file() and p.suffix in (".toml", ".csv")}
    assert {k.removeprefix("scenarios/") for k in data if k.startswith("scenarios/")} == repo
    cases = {p.relative_to(REPO_ROOT / "tests" / "steptests").as_posix()
             for p in (REPO_ROOT / "tests" / "steptests").rglob("*") if p.is_file()}
    assert {k.removeprefix("steptests/") for k in data if k.startswith("steptests/")} == cases
    assert any(n.endswith("anklehip/cli/__init__.py") for n in names)
    assert any(n.endswith("anklehip/analysis/data/flat_footed_optimum.json") for n in names)   # the cached optimum
    # the native engine: glibc 2.17, nothing but glibc, only its own entry points exported
    p = _run(["objdump", "-p", lib]).stdout
    needed = set(re.findall(r"^\s*NEEDED\s+(\S+)", p, re.M))
    assert needed and needed <= GLIBC_LIBRARIES, needed
    versions = {v for vs in version_references(p).values() for v in vs}
    assert versions and all(v.startswith("GLIBC_") for v in versions), versions
    assert max(version_tuple(v.removeprefix("GLIBC_")) for v in versions if re.fullmatch(r"GLIBC_[0-9.]+", v)) \
        <= GLIBC_BASELINE
    syms = _run(["nm", "-D", "--defined-only", lib]).stdout.split("\n")
    assert sorted(s.split()[-1] for s in syms if s.strip()) == ["ahn_run_closed_loop", "ahn_write_csv"]


def test_readme_states_the_wheel_size(wheel):
    text = (REPO_ROOT / "README.md").read_text()
    m = re.search(r"the wheel \((\d+(?:\.\d+)?) MB\)", text)
    assert m, "README.md does not state the wheel's size as 'the wheel (X MB)'"
    size = wheel.stat().st_size / 1e6
    assert abs(float(m[1]) - size) <= 0.1 * size, f"README says {m[1]} MB, the wheel has {size:.2f} MB"


@pytest.fixture(scope="module")
def venv(wheel, tmp_path_factory) -> Path:
    """A fresh venv from the base interpreter with the wheel installed (binary packages only)."""
    d = tmp_path_factory.mktemp("venv") / "v"
    base = getattr(sys, "_base_executable", None) or sys.executable
    _run([base, "-m", "venv", d])
    env = {k: v for k, v in os.environ.items() if k.startswith("PIP_") or k in ("HOME", "LANG", "PATH",
                                                                                   "SSL_CERT_FILE")}
    _run([d / "bin" / "python", "-m", "pip", "install", "--only-binary=:all:", "--no-input", wheel], env=env,
         timeout=1200)
    return d


@pytest.fixture(scope="module")
def bare(venv, tmp_path_factory):
    """Run a command of the venv as a user without a compiler or a checkout would: PATH = the
    venv's bin + failing compilers that record each call, HOME and LANG only, in a folder outside the
    checkout. Returns (run, the record of compiler calls)."""
    root = tmp_path_factory.mktemp("bare")
    poison, work = root / "no-compilers", root / "work"
    poison.mkdir()
    work.mkdir()
    calls = root / "compiler-calls"
    for c in COMPILERS:
        f = poison / c
        f.write_text(f'#!/bin/sh\necho "$0 $*" >> {calls}\nexit 127\n')
        f.chmod(0o755)
    env = {"PATH": f"{venv / 'bin'}:{poison}", "HOME": os.environ.get("HOME", str(root)), "LANG": "C.UTF-8"}
    assert str(REPO_ROOT) not in str(work) and str(REPO_ROOT) not in str(venv)

    def run(*args, check=True):
        r = subprocess.run([str(a) for a in args], cwd=work, env=env, capture_output=True, text=True, timeout=600)
        if check:
            assert r.returncode == 0, f"{args} exited {r.returncode}:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
        return r
    run.work = work
    return run, calls


def test_installed_wheel_runs_the_main_job(bare, venv):
    run, calls = bare
    where = run("anklehip", "where").stdout
    data = next(venv.glob("lib/python3*/site-packages/anklehip/data"))
    assert re.search(r"^checkout +\(none\)$", where, re.M), where
    for name in [f"{m}.fmu" for m in FMUS] + ["native engine", "scenarios", "step-test cases"]:
        line = next(x for x in where.splitlines() if x.startswith(name))
        assert str(data) in line, line

    listed = run("anklehip", "list").stdout.splitlines()
    assert listed[0].startswith("scenario") and any(ln.startswith("paper_five_pushes ") for ln in listed)
    assert str(data / "scenarios") in listed[-1] and "(package)" in listed[-1], listed[-1]

    r = run("anklehip", "run", "paper_five_pushes")
    assert "[FAIL]" not in r.stdout and "0 of 9 signals outside the band" in r.stdout, r.stdout
    s = json.loads((run.work / "results" / "paper_five_pushes" / "paper_five_pushes.summary.json").read_text())
    assert s["expectations_met"] and s["comparison"]["passed"] and s["cycles"] == 5

    # the wheel's native engine: the same rows, the same bytes
    run("anklehip", "run", "paper_five_pushes", "--engine", "native", "--out", "native")
    assert (run.work / "native" / "paper_five_pushes.csv").read_bytes() == \
        (run.work / "results" / "paper_five_pushes" / "paper_five_pushes.csv").read_bytes()

    # the API from the installed package: nothing of the checkout on any path
    code = ("import anklehip, sys, json; from anklehip.files import paths; "
            "print(json.dumps({'file': anklehip.__file__, 'path': sys.path, 'fmu': str(anklehip.fmu_path('Hoap2Plant')), "
            "'scenarios': anklehip.scenarios(), 'cases': anklehip.steptest_cases(), "
            "'checkout': str(paths.checkout_root())}))")
    info = json.loads(run("python", "-c", code).stdout)
    assert info["checkout"] == "None"
    for p in [info["file"], info["fmu"], *info["path"]]:
        assert str(REPO_ROOT) not in p, p
    assert "paper_five_pushes" in info["scenarios"] and "chest_push_hip_cycle" in info["cases"]

    # a shipped step-test case by name, and a clear error for what the wheel does not ship
    assert "PASS" in run("anklehip", "steptest", "chest_push_hip_cycle").stdout
    r = run("anklehip", "steptest", "chest_push_hip_cycle", "--native", check=False)
    assert r.returncode == 2 and "anklehip_rt_step is not built" in r.stderr, r.stderr
    assert not calls.exists(), f"a compiler was called:\n{calls.read_text()}"
