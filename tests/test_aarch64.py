"""The aarch64 Linux binaries (issue 28): every shipped FMU, FMI 2.0 and FMI 3.0, carries
binaries/aarch64-linux/<id>.so (cmake/Aarch64LinuxFmus.cmake: zig cc for aarch64-linux-gnu.2.17,
-ffp-contract=off), and they compute what the x86-64 binaries compute.

How they are run here: `anklehip_rt_step`, cross-built for aarch64 like the FMUs, replays recorded
inputs through one FMU's aarch64 binary under Debian's qemu-user (`qemu-aarch64` with the aarch64
glibc and loader of Debian's libc6-arm64-cross), exactly as tests/test_win64.py replays the
Windows binaries under Wine: a closed-loop scenario is run on x86-64 by our master, each FMU's
inputs are written to a CSV, the x86-64 runner on linux64/<id>.so and the aarch64 runner on
aarch64-linux/<id>.so replay them, and the outputs are compared with the bounds already accepted
between Linux and Windows: 1e-12 rad for the controller, 1e-8 of each column's peak for the plants,
discrete outputs equal. (The arithmetic is IEEE-754 double on both, no FMA contraction; glibc's libm
on aarch64 may round sin, exp, pow... differently in the last bit.)

The binaries themselves are read with LLVM's tools (llvm-readelf, llvm-nm): AArch64 ELF shared
objects needing only glibc 2.17 and glibc's own libraries, exporting exactly the functions of the
x86-64 binary of the same FMU (fmi2* or fmi3*).

Needs a build with -DANKLEHIP_AARCH64=ON, qemu-user, libc6-arm64-cross and llvm (`bash
scripts/setup.sh --aarch64` installs them). Without them the tests skip and say so, unless
ANKLEHIP_REQUIRE_AARCH64=1 (set by `bash run.sh test`), which turns a missing piece into a failure.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import zipfile

import pytest

from conftest import SHIPPED
from test_linux_binaries import GLIBC_BASELINE, version_tuple
from test_win64 import _replay, _write_inputs, assert_platforms_agree, closed_loop_to_replay

REQUIRED = os.environ.get("ANKLEHIP_REQUIRE_AARCH64") == "1"
SYSROOT = "/usr/aarch64-linux-gnu"      # Debian's libc6-arm64-cross
GLIBC_LIBRARIES = {"libc.so.6", "libm.so.6", "libpthread.so.0", "libdl.so.2", "librt.so.1",
                   "ld-linux-aarch64.so.1"}


def _missing(why: str):
    if REQUIRED:
        pytest.fail(f"{why} (ANKLEHIP_REQUIRE_AARCH64=1)")
    pytest.skip(why)


def _tool(name: str) -> str:
    exe = shutil.which(name)
    if exe is None:
        _missing(f"{name} not found (`bash scripts/setup.sh --aarch64` installs it)")
    return exe


@pytest.fixture(scope="module")
def arm_fmus(fmu_dir):
    """(FMI 2.0 FMU, FMI 3.0 FMU) of each shipped model, required to carry an aarch64 binary."""
    fmus = {name: (fmu_dir / f"{name}.fmu", fmu_dir / "fmi3" / f"{name}.fmu") for name in SHIPPED}
    with zipfile.ZipFile(fmus["AnkleHipController"][0]) as z:
        if not any(n.startswith("binaries/aarch64-linux/") for n in z.namelist()):
            _missing("the FMUs were built without -DANKLEHIP_AARCH64=ON (run `bash scripts/setup.sh --aarch64`)")
    return fmus


@pytest.fixture(scope="module")
def qemu():
    exe = _tool("qemu-aarch64")
    if not os.path.isfile(f"{SYSROOT}/lib/ld-linux-aarch64.so.1"):
        _missing(f"{SYSROOT}/lib/ld-linux-aarch64.so.1 missing (Debian package libc6-arm64-cross)")
    return [exe, "-L", SYSROOT], None


@pytest.fixture(scope="module")
def arm_runner(build_dir):
    exe = build_dir / "aarch64-linux" / "fmu" / "rt_runner" / "anklehip_rt_step"
    if not exe.is_file():
        _missing(f"{exe} not built (configure with -DANKLEHIP_AARCH64=ON)")
    return exe


def _run(args) -> str:
    return subprocess.run(args, capture_output=True, text=True, check=True).stdout


def _exports(path) -> set[str]:
    out = _run([_tool("llvm-nm"), "-D", "--defined-only", str(path)])
    return {line.split()[-1] for line in out.splitlines() if line.split()[1:2] == ["T"]}


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("name", SHIPPED)
def test_aarch64_binaries(arm_fmus, name, fmi, tmp_path):
    fmu = arm_fmus[name][fmi - 2]
    x86 = "linux64" if fmi == 2 else "x86_64-linux"
    with zipfile.ZipFile(fmu) as z:
        z.extract(f"binaries/aarch64-linux/{name}.so", tmp_path)
        z.extract(f"binaries/{x86}/{name}.so", tmp_path)
    so, ref = tmp_path / "binaries/aarch64-linux" / f"{name}.so", tmp_path / "binaries" / x86 / f"{name}.so"
    readelf = _tool("llvm-readelf")
    header = _run([readelf, "-h", str(so)])
    assert re.search(r"Machine:\s+AArch64", header) and re.search(r"Type:\s+DYN", header), header
    needed = set(re.findall(r"\(NEEDED\)\s+Shared library: \[(\S+)\]", _run([readelf, "-d", str(so)])))
    assert needed and needed <= GLIBC_LIBRARIES, needed - GLIBC_LIBRARIES
    versions = set(re.findall(r"Name: (GLIBC_[0-9.]+)", _run([readelf, "-V", str(so)])))
    assert versions, "no GLIBC_ version references read: the parser or the binary is wrong"
    newest = max(version_tuple(v[len("GLIBC_"):]) for v in versions)
    assert newest <= GLIBC_BASELINE, f"{name}: needs GLIBC_{'.'.join(map(str, newest))}"
    exports = _exports(so)
    assert exports == _exports(ref), "the aarch64 and the x86-64 binary export different functions"
    assert all(e.startswith(f"fmi{fmi}") for e in exports) and f"fmi{fmi}DoStep" in exports


@pytest.mark.parametrize("fmi", [2, 3])
# the sagittal loop, the sagittal controller on the 3D plant, and the 3D controller on it
# (side_push_frontal: the frontal layer's lean and per-leg set points at work)
@pytest.mark.parametrize("scenario,stop", [("hip_saves_push", 4.0), ("diagonal_push_3d", 2.0),
                                           ("side_push_frontal", 2.5)])
def test_aarch64_binaries_replay_a_closed_loop_like_x86_64(arm_fmus, qemu, arm_runner, native_tool, fmu_dir,
                                                            tmp_path, scenario, stop, fmi):
    """FMI 2.0 and the FMI 3.0 twins: the runner reads either (binaries/aarch64-linux in both)."""
    res, n, h, t_end, cases = closed_loop_to_replay(scenario, fmu_dir, stop, fmi)
    x86_runner = native_tool("anklehip_rt_step")
    qemu_cmd, qemu_env = qemu
    for role, (info, columns, params) in cases.items():
        csv_in = _write_inputs(tmp_path / f"{role}_in.csv", res.data, columns, n)
        x86 = _replay([], None, x86_runner, info.unzipdir, csv_in, tmp_path / f"{role}_x86_64.csv", h, t_end, params)
        arm = _replay(qemu_cmd, qemu_env, arm_runner, info.unzipdir, csv_in, tmp_path / f"{role}_aarch64.csv", h,
                      t_end, params)
        assert len(x86) == len(arm) == n + 1
        assert_platforms_agree(x86, arm, role, info, scenario, ("x86_64", "aarch64"))
