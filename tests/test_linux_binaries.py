"""The Linux binary of every shipped FMU (binaries/linux64/<id>.so) loads on any Linux with glibc
>= 2.17 and needs nothing but glibc.

Establishes, for each packed FMU, from the ELF file itself (binutils' objdump and nm):
  - the highest GLIBC_ symbol version it requires is at most the documented baseline (2.17,
    docs/fmu.md "Platforms"); the dynamic loader refuses a library that requires a version the
    system's glibc lacks, so this is the condition for loading on RHEL 7/8/9, Ubuntu 20.04, Debian 11;
  - it requires no version of any other library (no GLIBCXX_/CXXABI_/GCC_: the C++ runtime,
    SUNDIALS and ODE are linked in) and its NEEDED libraries are glibc's own;
  - it exports nothing but the fmi2* functions (the FMI 3.0 twin's x86_64-linux binary: fmi3*).
The baseline build is cmake/LinuxBaselineFmus.cmake (zig cc against glibc 2.17 stubs); a build
configured with -DANKLEHIP_GLIBC_BASELINE= (the host compiler's binaries) fails this test on
purpose: its binaries need the build machine's glibc.
"""
from __future__ import annotations

import re
import shutil
import subprocess
import sys
import zipfile

import pytest

from conftest import SHIPPED

GLIBC_BASELINE = (2, 17)
# glibc's own libraries (libpthread and libdl are separate libraries before glibc 2.34 and stubs
# after it: a glibc 2.17 binary names them).
GLIBC_LIBRARIES = {"libc.so.6", "libm.so.6", "libpthread.so.0", "libdl.so.2", "librt.so.1",
                   "ld-linux-x86-64.so.2"}


def version_tuple(v: str) -> tuple[int, ...]:
    return tuple(int(x) for x in v.split("."))


def version_references(objdump_p: str) -> dict[str, set[str]]:
    """{library: {version names}} from the 'Version References' block of `objdump -p`."""
    refs: dict[str, set[str]] = {}
    lib = None
    block = objdump_p.split("Version References:", 1)[1] if "Version References:" in objdump_p else ""
    for line in block.splitlines():
        m = re.match(r"\s*required from (\S+):", line)
        if m:
            lib = m[1]
            refs[lib] = set()
        elif lib and (m := re.match(r"\s*0x[0-9a-f]+ 0x[0-9a-f]+ \d+ (\S+)", line)):
            refs[lib].add(m[1])
    return refs


def test_version_references_parser():
    """The parser reads objdump's format (a fixed sample, so that a silent parse failure, which
    would make the real test pass vacuously, is caught here)."""
    sample = """
Version References:
  required from libm.so.6:
    0x09691a75 0x00 04 GLIBC_2.2.5
  required from libc.so.6:
    0x0d696914 0x00 03 GLIBC_2.4
    0x06969194 0x00 02 GLIBC_2.14
"""
    assert version_references(sample) == {"libm.so.6": {"GLIBC_2.2.5"}, "libc.so.6": {"GLIBC_2.4", "GLIBC_2.14"}}


@pytest.fixture(scope="module")
def binutils():
    tools = {t: shutil.which(t) for t in ("objdump", "nm")}
    missing = [t for t, p in tools.items() if not p]
    if missing:
        pytest.fail(f"{', '.join(missing)} (binutils) needed: apt-get install binutils")
    return tools


def _fmu(fmu_path, model, fmi):
    """The FMI 2.0 FMU or its FMI 3.0 twin (fmi3/, binaries/x86_64-linux), and the binary's path in it."""
    if fmi == 2:
        return fmu_path(model), f"binaries/linux64/{model}.so"
    return fmu_path(model).parent / "fmi3" / f"{model}.fmu", f"binaries/x86_64-linux/{model}.so"


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("model", SHIPPED)
def test_linux_binary_needs_only_old_glibc(model, fmi, fmu_path, binutils, tmp_path):
    fmu, member = _fmu(fmu_path, model, fmi)
    with zipfile.ZipFile(fmu) as z:
        so = z.extract(member, tmp_path)
    p = subprocess.run([binutils["objdump"], "-p", so], capture_output=True, text=True, check=True).stdout
    needed = set(re.findall(r"^\s*NEEDED\s+(\S+)", p, re.M))
    assert needed and needed <= GLIBC_LIBRARIES, f"{model}.so needs {sorted(needed - GLIBC_LIBRARIES)}"

    refs = version_references(p)
    versions = {v for vs in refs.values() for v in vs}
    assert versions, f"{model}.so: no version references found in objdump -p (parser or binary broken)"
    foreign = sorted(v for v in versions if not v.startswith("GLIBC_"))
    assert not foreign, f"{model}.so requires versions of other libraries: {foreign}"
    glibc = [version_tuple(v.removeprefix("GLIBC_")) for v in versions if re.fullmatch(r"GLIBC_[0-9.]+", v)]
    highest = max(glibc)
    assert highest <= GLIBC_BASELINE, (
        f"{model}.so requires GLIBC_{'.'.join(map(str, highest))} > the documented baseline "
        f"{'.'.join(map(str, GLIBC_BASELINE))}: {sorted(v for v in versions)}")

    syms = subprocess.run([binutils["nm"], "-D", "--defined-only", so], capture_output=True, text=True,
                          check=True).stdout
    names = [line.split()[-1] for line in syms.splitlines() if line.strip()]
    api = f"fmi{fmi}"
    assert names and all(n.startswith(api) for n in names), [n for n in names if not n.startswith(api)]


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("model", SHIPPED)
def test_process_exits_cleanly_after_unloading(model, fmi, fmu_path):
    """A process that simulated the FMU and unloaded its binary (FMPy's simulate_fmu frees the
    instance and dlcloses the library) exits with status 0: the destructors of the binary's
    static objects ran at unload, not at process exit in an unmapped library (the crash the first
    zig build had: it links no crtbeginS.o, fmu/common/src/fmi2_api.cpp)."""
    code = ("import sys, fmpy; r = fmpy.simulate_fmu(sys.argv[1], stop_time=0.01); "
            "assert len(r) > 1; print('simulated')")
    r = subprocess.run([sys.executable, "-c", code, str(_fmu(fmu_path, model, fmi)[0])], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0 and "simulated" in r.stdout, (r.returncode, r.stderr[-2000:])
