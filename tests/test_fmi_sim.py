"""Our FMUs in fmi-sim (issue 28), the Rust FMI importer of the `fmi` crates (crates registry,
version 0.7.0): a third importer that shares no code with FMPy or libcosim. Each FMI 2.0 FMU the
project ships (anklehip.files.paths.SHIPPED) runs on a CSV input (conftest.fmu_inputs) in fmi-sim
and in FMPy's simulate_fmu, and the outputs agree to 1e-9 of their scale (plus 1e-9 in SI units;
the discrete ones equal), as in tests/test_independent_importer.py.

The FMI 3.0 twins: fmi-sim 0.7 refuses their descriptions at the first Float64 with a `unit`
attribute ("unknown field `unit` in element `FmiFloat64`"), although the FMI 3.0 schema allows it
there (fmi3RealBaseAttributes) and `fmpy validate` accepts them; the test below holds that, so
that a fmi-sim that reads them is noticed and joins the matrix (docs/integration.md).

Built by `bash scripts/setup.sh --fmi-sim` (cargo install into <build>/fmi-sim). Without it the
tests skip and say so, unless ANKLEHIP_REQUIRE_FMI_SIM=1 (set by `bash run.sh test`).
"""
from __future__ import annotations

import os
import shutil
import subprocess

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from conftest import SHIPPED, fmu_inputs, write_csv

REQUIRED = os.environ.get("ANKLEHIP_REQUIRE_FMI_SIM") == "1"
DISCRETE = {"phase", "fault", "phase_y", "fault_y", "fallen", "contact_mode", "input_fault"}
COUNTERS = {"cvode_steps", "rhs_evals", "root_evals", "ode_steps", "contacts", "mode_switches", "impacts"}


@pytest.fixture(scope="module")
def fmi_sim(build_dir):
    exe = build_dir / "fmi-sim" / "bin" / "fmi-sim"
    if exe.is_file():
        return exe
    found = shutil.which("fmi-sim")
    if found:
        return found
    why = f"fmi-sim not built ({exe}; `bash scripts/setup.sh --fmi-sim` builds it)"
    if REQUIRED:
        pytest.fail(f"{why} (ANKLEHIP_REQUIRE_FMI_SIM=1)")
    pytest.skip(why)


def _read(path) -> dict[str, np.ndarray]:
    """fmi-sim's CSV: numbers as printed, Booleans as true/false."""
    import csv
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    conv = {"true": 1.0, "false": 0.0}
    return {name: np.array([conv.get(r[i], None) if r[i] in conv else float(r[i]) for r in rows[1:]])
            for i, name in enumerate(rows[0])}


def _run(fmi_sim, fmu, csv_in, csv_out):
    return subprocess.run([str(fmi_sim), "--model", str(fmu), "-i", str(csv_in), "-o", str(csv_out), "co-simulation",
                           "--step", "0.001", "-n", "0", "-f", "2"], capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("name", SHIPPED)
def test_fmi_sim_runs_each_fmu_like_fmpy(fmi_sim, fmu_path, tmp_path, name):
    fmu = fmu_path(name)
    t = np.arange(2001) * 1e-3
    inp = fmu_inputs(name, t)
    csv_in = write_csv(tmp_path / "in.csv", inp)
    p = _run(fmi_sim, fmu, csv_in, tmp_path / "out.csv")
    assert p.returncode == 0, p.stderr[-3000:]
    got = _read(tmp_path / "out.csv")
    outs = [v.name for v in read_model_description(str(fmu)).modelVariables if v.causality == "output"]
    ref = simulate_fmu(str(fmu), stop_time=2.0, step_size=1e-3, output_interval=1e-3, input=inp, output=outs)
    assert len(got["time"]) == len(ref) == 2001 and np.allclose(got["time"], ref["time"], rtol=0, atol=1e-12)
    for n in outs:
        a, b = np.asarray(ref[n], float), np.asarray(got[n], float)
        if n in DISCRETE:
            assert np.array_equal(a, b), n
        elif n not in COUNTERS:
            err = float(np.max(np.abs(a - b)))
            assert err <= 1e-9 * np.max(np.abs(a)) + 1e-9, (n, err)


def test_fmi_sim_refuses_the_fmi3_twins_at_a_unit(fmi_sim, fmu_dir, tmp_path):
    twin = fmu_dir / "fmi3" / "AnkleHipController.fmu"
    csv_in = write_csv(tmp_path / "in.csv", fmu_inputs("AnkleHipController", np.arange(11) * 1e-3))
    p = _run(fmi_sim, twin, csv_in, tmp_path / "out.csv")
    assert p.returncode != 0 and 'unknown field "unit"' in p.stdout + p.stderr, (p.returncode, p.stderr[-2000:])
    assert read_model_description(str(twin)).fmiVersion == "3.0"
