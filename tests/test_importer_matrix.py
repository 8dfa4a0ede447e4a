"""The importer matrix of docs/integration.md ("What is tested where") is held to the build and to
the suite (issue 28): its rows are exactly the (FMU, FMI version, platform folder) triples of the
packed FMUs, every row names each importer column, and every cell that says a binary is tested
names a test that exists in tests/. So a new platform or FMI version cannot ship without a row,
and the table cannot claim a test that is not there."""
from __future__ import annotations

import re
import zipfile

from anklehip.files.paths import SCHEDULED_EXECUTION
from conftest import REPO_ROOT, SHIPPED

COLUMNS = ["FMU", "FMI", "platform", "FMPy", "libcosim", "fmi-sim 0.7", "native runner (x86-64 Linux)",
           "Wine (runner for Windows)", "qemu-aarch64 (runner for aarch64)", "t = k·h master (ctypes)"]


def _matrix():
    text = (REPO_ROOT / "docs" / "integration.md").read_text()
    section = text.split("## What is tested where", 1)[1]
    lines = [ln for ln in section.splitlines() if ln.startswith("| FMU |") or re.match(r"\| \w+ \| [23]\.0 \|", ln)]
    header = [c.strip() for c in lines[0].strip("|").split("|")]
    rows = [[c.strip() for c in ln.strip("|").split("|")] for ln in lines[1:]]
    return header, rows


def _platforms(fmu) -> set[str]:
    with zipfile.ZipFile(fmu) as z:
        return {n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") >= 2}


def test_matrix_rows_are_the_shipped_binaries(fmu_dir):
    header, rows = _matrix()
    assert header == COLUMNS
    assert all(len(r) == len(COLUMNS) for r in rows), [r for r in rows if len(r) != len(COLUMNS)]
    documented = {(r[0], r[1], r[2]) for r in rows}
    assert len(documented) == len(rows), "a row is repeated"
    shipped = set()
    for name in SHIPPED:
        for version, fmu in (("2.0", fmu_dir / f"{name}.fmu"), ("3.0", fmu_dir / "fmi3" / f"{name}.fmu")):
            shipped |= {(name, version, p) for p in _platforms(fmu)}
    for name in SCHEDULED_EXECUTION:   # the Scheduled Execution variants (FMI 3.0 only)
        shipped |= {(f"{name}_se", "3.0", p) for p in _platforms(fmu_dir / "fmi3" / f"{name}_se.fmu")}
    assert shipped <= documented, f"shipped but not in the matrix: {sorted(shipped - documented)}"
    # a build without the optional platforms ships fewer; the matrix may list those (CI builds all)
    optional = {"win64", "x86_64-windows", "aarch64-linux"}
    assert {d for d in documented - shipped if d[2] not in optional} == set(), "in the matrix but not shipped"


def test_every_tested_cell_names_an_existing_test():
    _, rows = _matrix()
    named = 0
    for r in rows:
        for cell in r[3:]:
            assert cell == "—" or cell.startswith("untested (") or cell.startswith("✓ `"), (r[:3], cell)
            m = re.fullmatch(r"✓ `(test_\w+\.py)::(test_\w+)`", cell)
            if cell.startswith("✓"):
                assert m, (r[:3], cell)
                path = REPO_ROOT / "tests" / m[1]
                assert path.is_file() and f"def {m[2]}(" in path.read_text(), (r[:3], cell)
                named += 1
    assert named >= 3 * 6 + 3 * 2, "every binary is run by at least one importer, x86-64 Linux by more"
    for r in rows:
        assert any(c.startswith("✓") for c in r[3:]), f"{r[:3]} is run by no importer"
