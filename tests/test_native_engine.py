"""The native closed-loop engine (fmu/closed_loop, anklehip/running/native.py) against the FMPy master.

Establishes: on every committed scenario (sagittal and 3D plants, with the controller it names) the
native engine gives the FMPy
master's result bit for bit (every row, every column, outcome, message, controller start values),
and its CSV writer gives FMPy's write_csv bytes, so `anklehip run --engine native` writes the same
CSV file; edge values (NaN, infinities, -0.0, subnormals, the bounds of positional notation)
format as FMPy's writer does; what the native engine cannot do ([faults] sensor faults) is refused
with a message that names the scenario and the way out; a run that falls ends the same way in both.
"""
from __future__ import annotations

import filecmp

import numpy as np
import pytest
from fmpy.util import write_csv as fmpy_write_csv

from anklehip.running import native
from anklehip.cli import main
from anklehip.running.faults import Faults
from anklehip.running.master import Models, simulate
from anklehip.files.paths import scenarios_dir
from anklehip.files.scenario import ScenarioError, load_scenario

pytestmark = pytest.mark.skipif(not native.available(), reason="libanklehip_closed_loop not built")

SCENARIOS = sorted(p.stem for p in scenarios_dir().glob("*.toml"))


@pytest.fixture(scope="module")
def models():
    """(plant model, controller model) -> Models; the scenarios name both."""
    return {(p, c): Models.load(plant_model=p, controller_model=c)
            for p in ("sagittal", "3d") for c in ("sagittal", "3d")}


def _same(a, b):
    assert a.outcome == b.outcome and a.message == b.message and a.fell_at == b.fell_at
    assert a.end_time == b.end_time and a.controller_initial == b.controller_initial
    assert a.data.dtype == b.data.dtype
    assert a.data.tobytes() == b.data.tobytes()


@pytest.mark.parametrize("name", SCENARIOS)
def test_every_scenario_bit_for_bit(models, name, tmp_path):
    sc = load_scenario(scenarios_dir() / f"{name}.toml")
    m = models[sc.plant_model, sc.controller_model]
    a = simulate(sc, m, progress=False)
    b = simulate(sc, m, engine="native")
    _same(a, b)
    fmpy_write_csv(tmp_path / "fmpy.csv", a.data)
    native.write_csv(tmp_path / "native.csv", b.data)
    assert filecmp.cmp(tmp_path / "fmpy.csv", tmp_path / "native.csv", shallow=False)


def test_a_fall_ends_the_same(models):
    """A push the robot cannot survive: the plant discards the step, both engines report the fall
    at the same time and close the record with the same last row."""
    sc = load_scenario(scenarios_dir() / "hip_saves_push.toml")
    push = sc.push.scaled(3.0)
    a = simulate(sc, models["sagittal", "sagittal"], push=push, progress=False)
    b = simulate(sc, models["sagittal", "sagittal"], push=push, engine="native")
    assert a.outcome == "fell"
    _same(a, b)


def test_csv_edge_values(tmp_path):
    x = np.array([0.0, -0.0, 1.0, -1.5, 1e-4, 9.999999999999999e-05, 1e-5, 1e16, 9999999999999998.0, 1e22,
                  123456.789, 0.1, 1 / 3, 2.0 ** -1074, 1.7976931348623157e308, float("nan"), float("inf"),
                  float("-inf"), 5e-324, 1e-310, 100.0, 12345678901234567.0, 3.0e-7, -2.5e+200])
    d = np.zeros(len(x), dtype=[("time", np.float64), ("v", np.float64), ("i", np.int32)])
    d["time"] = np.arange(len(x)) * 0.001
    d["v"] = x
    d["i"] = np.arange(len(x)) * -123456 + 2147483647
    fmpy_write_csv(tmp_path / "a.csv", d)
    native.write_csv(tmp_path / "b.csv", d)
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


def test_cli_engine_native_writes_the_same_files(tmp_path):
    for engine in ("fmpy", "native"):
        assert main(["run", "hip_saves_push", "--engine", engine, "--no-progress", "--out", str(tmp_path / engine)]) == 0
    assert filecmp.cmp(tmp_path / "fmpy" / "hip_saves_push.csv", tmp_path / "native" / "hip_saves_push.csv",
                       shallow=False)


def test_sensor_faults_refused(models):
    sc = load_scenario(scenarios_dir() / "hip_saves_push.toml")
    with pytest.raises(ScenarioError, match=r"hip_saves_push.*native engine.*--engine fmpy"):
        simulate(sc, models["sagittal", "sagittal"], faults=Faults(zmp_noise=0.001), engine="native")
    # parameter faults are parameters: the native engine runs them, like the FMPy master
    a = simulate(sc, models["sagittal", "sagittal"], faults=Faults(torque_scale=0.8), progress=False, stop_time=3.0)
    b = simulate(sc, models["sagittal", "sagittal"], faults=Faults(torque_scale=0.8), engine="native", stop_time=3.0)
    _same(a, b)


def test_cli_refuses_faults_with_native(tmp_path, capsys):
    rc = main(["run", "hip_saves_push", "--engine", "native", "--fault", "zmp_noise=0.001", "--no-progress",
               "--out", str(tmp_path)])
    assert rc != 0
    assert "--engine fmpy" in capsys.readouterr().err
