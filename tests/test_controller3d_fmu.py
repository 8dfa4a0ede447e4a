"""AnkleHipController3D.fmu: the sagittal controller, the frontal-plane controller and the legs'
kinematics behind the glue (docs/controller.md §11, docs/fmu.md §9).

Establishes:
- its sagittal variables are AnkleHipController.fmu's (names, value references, types, units,
  start values), and on the same inputs its sagittal outputs equal that FMU's bit for bit, with the
  frontal layer off and on (the paper's law is untouched by the frontal plane);
- with the frontal layer off its per-leg set points are exactly 0 (the 3D plant then moves as under
  the sagittal FMU);
- a state restored into a fresh instance continues bit for bit;
- a non-finite input is held and logged (fmi2Warning), outputs stay finite;
- a scenario names its controller (controller_model); the 3D controller needs the 3D plant (a
  clear error otherwise)."""
from __future__ import annotations

import math
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave

SIDES, JOINTS = ("left", "right"), ("hip_yaw", "hip", "hip_roll", "knee", "ankle", "ankle_roll")
SAGITTAL_IN = ("theta_ankle", "theta_hip", "zmp_x", "fz")


@pytest.fixture(scope="module")
def fmu3d(fmu_path) -> Path:
    return fmu_path("AnkleHipController3D")


def _unzip(fmu: Path, tmp: Path) -> Path:
    d = tmp / fmu.stem
    with zipfile.ZipFile(fmu) as z:
        z.extractall(d)
    return d


class Inst:
    def __init__(self, unz: Path, params: dict | None = None, name: str = "c"):
        self.md = read_model_description(str(unz / "modelDescription.xml"))
        self.var = {v.name: v for v in self.md.modelVariables}
        self.log = []
        self.f = FMU2Slave(guid=self.md.guid, unzipDirectory=str(unz),
                           modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.f.instantiate(loggingOn=True, callbacks=None)
        self.f.setupExperiment(startTime=0.0)
        self.f.enterInitializationMode()
        for k, val in (params or {}).items():
            self.set(k, val)
        self.f.exitInitializationMode()
        self.t = 0.0

    def set(self, n, x):
        v = self.var[n]
        if v.type == "Real":
            self.f.setReal([v.valueReference], [float(x)])
        else:
            self.f.setInteger([v.valueReference], [int(x)])

    def get(self, names):
        out = []
        for n in names:
            v = self.var[n]
            out.append(self.f.getReal([v.valueReference])[0] if v.type == "Real"
                       else self.f.getInteger([v.valueReference])[0])
        return out

    def step(self, h=1e-3):
        st = self.f.doStep(self.t, h)
        self.t += h
        return st


def _inputs(k: int, lateral: float) -> dict:
    """Plausible sensor signals at tick k: a push-like sagittal swing, a lateral ZMP swing of
    amplitude `lateral`, joint angles consistent with a small parallel lean."""
    t = k * 1e-3
    phi = 0.02 * math.sin(3.0 * t) * (lateral > 0)
    d = {"theta_ankle": 0.03 * math.sin(2.0 * t), "theta_hip": 0.15 * math.sin(1.3 * t) ** 2,
         "zmp_x": 0.035 * math.sin(2.0 * t), "fz": 70.2 + 2.0 * math.sin(9.0 * t),
         "zmp_y": lateral * math.sin(2.7 * t)}
    for s in SIDES:
        for j in JOINTS:
            d[f"q_{s}_{j}"] = {"ankle_roll": phi, "hip_roll": -phi, "ankle": d["theta_ankle"],
                               "hip": d["theta_hip"]}.get(j, 0.0)
    return d


def test_sagittal_variables_are_the_sagittal_fmus(fmu3d, controller_fmu):
    a = {v.name: v for v in read_model_description(str(controller_fmu)).modelVariables}
    b = {v.name: v for v in read_model_description(str(fmu3d)).modelVariables}
    for name, v in a.items():
        assert name in b, name
        w = b[name]
        assert (w.valueReference, w.type, w.causality, w.variability, w.unit, w.start) == \
               (v.valueReference, v.type, v.causality, v.variability, v.unit, v.start), name
    for s in SIDES:
        for j in JOINTS:
            assert b[f"q_{s}_{j}"].causality == "input" and b[f"q_{s}_{j}_ref"].causality == "output"


@pytest.mark.parametrize("frontal", [0, 1], ids=["frontal_off", "frontal_on"])
def test_sagittal_outputs_bit_identical_to_the_sagittal_fmu(fmu3d, controller_fmu, tmp_path, frontal):
    u3, u2 = _unzip(fmu3d, tmp_path), _unzip(controller_fmu, tmp_path)
    c3 = Inst(u3, {"frontal_enabled": frontal, "hip_strategy_enabled_y": 1})   # every frontal phase
    c2 = Inst(u2)
    outs = [v.name for v in c2.md.modelVariables if v.causality == "output"]
    legs = [f"q_{s}_{j}_ref" for s in SIDES for j in JOINTS]
    phases_y = set()
    for k in range(4000):
        u = _inputs(k, 0.045)
        for n, x in u.items():
            c3.set(n, x)
            if n in SAGITTAL_IN:
                c2.set(n, x)
        c3.step()
        c2.step()
        a, b = c3.get(outs), c2.get(outs)
        assert a == b, (k, [(n, x, y) for n, x, y in zip(outs, a, b) if x != y])
        offsets = c3.get(legs)
        if not frontal:
            assert all(x == 0.0 for x in offsets), (k, offsets)
        phases_y.add(c3.get(["phase_y"])[0])
    if frontal:   # the lateral ZMP swing (45 mm) runs the frontal phases, which left the sagittal alone
        assert {0, 1, 2} <= phases_y, phases_y


def test_state_restored_bit_for_bit_into_a_fresh_instance(fmu3d, tmp_path):
    u = _unzip(fmu3d, tmp_path)
    a = Inst(u, name="a")
    for k in range(1500):
        for n, x in _inputs(k, 0.05).items():
            a.set(n, x)
        a.step()
    state = a.f.serializeFMUstate(a.f.getFMUstate())
    b = Inst(u, name="b")
    b.f.setFMUstate(b.f.deSerializeFMUstate(state))
    b.t = a.t
    outs = [v.name for v in a.md.modelVariables if v.causality == "output"]
    for k in range(1500, 3000):
        for inst in (a, b):
            for n, x in _inputs(k, 0.05).items():
                inst.set(n, x)
            inst.step()
        assert a.get(outs) == b.get(outs), k


# a step starts at once (docs/controller.md §12): the threshold 50 mm inside the toe edge, the trunk
# pitched forward (the CoM estimate ahead of it)
STEPPING_NOW = {"stepping_enabled": 1, "step_trigger_x": -0.05}
LEANING = {"imu_pitch": 0.2}


def test_stepping_off_by_default_and_its_outputs_at_rest(fmu3d, tmp_path):
    """The stepping layer's variables exist; off by default it never leaves phase 0."""
    u = _unzip(fmu3d, tmp_path)
    c = Inst(u)
    assert c.var["stepping_enabled"].start in ("0", 0)
    assert c.var["imu_pitch"].causality == "input" and c.var["imu_pitch"].valueReference == 8
    assert c.var["step_phase"].valueReference == 71
    for k in range(600):
        for n, x in _inputs(k, 0.05).items():
            c.set(n, x)
        c.step()
        assert c.get(["step_phase", "steps", "swing_side"]) == [0, 0, -1], k


def test_a_step_is_logged_and_its_state_restored_bit_for_bit(fmu3d, tmp_path, capfd):
    """With stepping on, a step runs through its phases (logged), and a state saved in the middle of
    the swing, restored into a fresh instance, continues bit for bit."""
    u = _unzip(fmu3d, tmp_path)
    a = Inst(u, params=STEPPING_NOW, name="a")
    phases = set()
    for k in range(150):
        for n, x in {**_inputs(k, 0.0), **LEANING}.items():
            a.set(n, x)
        a.step()
        phases.add(a.get(["step_phase"])[0])
    assert 1 in phases or 2 in phases, phases
    logged = capfd.readouterr().out
    assert "stepping phase 0 (stand) -> 1 (shift)" in logged, logged[-2000:]
    state = a.f.serializeFMUstate(a.f.getFMUstate())
    b = Inst(u, params=STEPPING_NOW, name="b")
    check = Inst(u, params=STEPPING_NOW, name="check")   # every state of the step is accepted
    b.f.setFMUstate(b.f.deSerializeFMUstate(state))
    b.t = a.t
    outs = [v.name for v in a.md.modelVariables if v.causality == "output"]
    for k in range(150, 900):
        for inst in (a, b):
            for n, x in {**_inputs(k, 0.0), **LEANING}.items():
                inst.set(n, x)
            inst.step()
        assert a.get(outs) == b.get(outs), k
        if k % 10 == 0:
            check.f.setFMUstate(check.f.deSerializeFMUstate(a.f.serializeFMUstate(a.f.getFMUstate())))
            phases.add(a.get(["step_phase"])[0])
    assert {2, 3} <= phases, phases
    # the state carries the stepping parameters with it (docs/fmu.md: parameters are restored with the
    # state), as it carries the other planes'
    saved = a.get(["step_height"])
    c = Inst(u, params={**STEPPING_NOW, "step_height": saved[0] + 0.005}, name="c")
    c.f.setFMUstate(c.f.deSerializeFMUstate(state))
    assert c.get(["step_height"]) == saved


def test_non_finite_input_is_held_and_logged(fmu3d, tmp_path, capfd):
    u = _unzip(fmu3d, tmp_path)
    c = Inst(u)
    for k in range(200):
        for n, x in _inputs(k, 0.02).items():
            c.set(n, x)
        c.step()
    capfd.readouterr()
    c.set("q_left_knee", float("nan"))
    c.step()
    logged = capfd.readouterr().out
    assert "[WARNING]" in logged and "non-finite input" in logged, logged
    outs = [v.name for v in c.md.modelVariables if v.causality == "output" and v.type == "Real"]
    assert all(np.isfinite(c.get(outs)))
    assert c.get(["fault_y"])[0] != 0


def test_scenario_names_its_controller(tmp_path):
    from anklehip.files.scenario import ScenarioError, load_scenario
    p = tmp_path / "s.toml"
    p.write_text('plant_model = "3d"\ncontroller_model = "3d"\nstop_time = 1.0\n')
    assert load_scenario(p).controller_model == "3d"
    p.write_text('controller_model = "3d"\nstop_time = 1.0\n')
    with pytest.raises(ScenarioError, match="controller_model.*needs plant_model"):
        load_scenario(p)
    p.write_text('plant_model = "3d"\ncontroller_model = "4d"\nstop_time = 1.0\n')
    with pytest.raises(ScenarioError, match="unknown controller model '4d'"):
        load_scenario(p)


def test_cli_refuses_the_3d_controller_on_the_sagittal_plant(tmp_path, capsys):
    from anklehip.cli import main
    assert main(["run", "ankle_small_push", "--controller-model", "3d", "--out", str(tmp_path / "o")]) == 2
    assert "3D controller needs the 3D plant" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_frontal_limits_script(tmp_path):
    """scripts/frontal_limits.py (docs/controller.md §11.5): with the frontal layer off the 3D
    controller stands the 1 s side push up to the static side-tipping force, as the sagittal
    controller does (15 N); a malformed --set is refused (exit 2)."""
    import subprocess
    import sys

    from conftest import REPO_ROOT
    script = str(REPO_ROOT / "scripts" / "frontal_limits.py")
    r = subprocess.run([sys.executable, script, "--shape", "1s", "--from", "14", "--set", "frontal_enabled=0"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().splitlines()[-1].split()[-1] == "15/15", r.stdout
    r = subprocess.run([sys.executable, script, "--set", "Ka_y"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "--set Ka_y" in r.stderr and "Traceback" not in r.stderr
