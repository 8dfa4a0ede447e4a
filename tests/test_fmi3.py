"""The FMI 3.0 Co-Simulation twins of the shipped FMUs (issue 28): build/fmus/fmi3/<Name>.fmu, the
same model behind the glue's FMI 3.0 API (fmu/common/src/fmi3_api.cpp over the operations it shares
with the FMI 2.0 API) and a description generated from the same variable table.

What is established here:
* each twin passes `fmpy validate` and declares exactly the FMI 2.0 FMU's variables (names, value
  references, types, causality, variability, units, start values, ranges, enumeration items) plus
  FMI 3.0's independent variable `time`; the instantiation token is the FMI 2.0 GUID;
* FMPy's `simulate_fmu` runs each twin (FMI 3.0 Co-Simulation) to the FMI 2.0 FMU's outputs bit
  for bit on the same inputs;
* the closed loop on the twins (`anklehip run --fmi 3`, our master on FMPy's FMU3Slave) is
  bit-identical to the FMI 2.0 loop, sagittal and 3D;
* an FMU state serialized by an FMI 2.0 instance continues bit for bit in an FMI 3.0 instance
  (the same byte format and model), and vice versa;
* the FMI 3.0 rules the twins follow: Enumerations through fmi3Get/SetInt64 (not Int32), the time
  through fmi3GetFloat64, no event mode, nValues checked, the t = k*h time rule, outputs in
  initialization mode.
"""
from __future__ import annotations

import ctypes
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

from conftest import SHIPPED, fmu_inputs

NAMES = SHIPPED
FMI3_TYPES = {"Float64": "Real", "Int32": "Integer"}


@pytest.fixture(scope="module")
def twins(fmu_dir):
    out = {}
    for name in NAMES:
        p2, p3 = fmu_dir / f"{name}.fmu", fmu_dir / "fmi3" / f"{name}.fmu"
        assert p3.is_file(), f"{p3} is missing: the build packs every FMU's FMI 3.0 twin (cmake/AddFmu.cmake)"
        out[name] = (p2, p3)
    return out


@pytest.mark.parametrize("name", NAMES)
def test_twin_validates_and_declares_the_same_variables(twins, name):
    p2, p3 = twins[name]
    assert validate_fmu(str(p3)) == []
    md2, md3 = read_model_description(str(p2)), read_model_description(str(p3))
    assert md3.fmiVersion == "3.0" and md3.instantiationToken == md2.guid
    assert md3.coSimulation.modelIdentifier == md2.coSimulation.modelIdentifier
    assert md3.coSimulation.canGetAndSetFMUstate and md3.coSimulation.canSerializeFMUstate
    time = [v for v in md3.modelVariables if v.causality == "independent"]
    assert [v.name for v in time] == ["time"] and time[0].type == "Float64"

    def key(v, fmi3):
        t = FMI3_TYPES.get(v.type, v.type) if fmi3 else v.type
        items = [(i.name, int(i.value)) for i in v.declaredType.items] if v.type == "Enumeration" else None
        return (v.name, v.valueReference, t, v.causality, v.variability, v.unit, v.start, v.min, v.max,
                v.description, items)

    # the FMI 3.0 arrays (views of scalars both versions have, test_fmi3_arrays.py) aside
    arrays = {v.valueReference for v in md3.modelVariables if v.dimensions}
    vars3 = [key(v, True) for v in md3.modelVariables if v.causality != "independent" and not v.dimensions]
    assert vars3 == [key(v, False) for v in md2.modelVariables]
    # the same model structure, with value references
    outs2 = [u.variable.valueReference for u in md2.outputs]
    assert [u.variable.valueReference for u in md3.outputs if u.variable.valueReference not in arrays] == outs2
    init2 = {u.variable.valueReference: sorted(d.valueReference for d in u.dependencies) for u in md2.initialUnknowns}
    init3 = {u.variable.valueReference: sorted(d.valueReference for d in u.dependencies) for u in md3.initialUnknowns
             if u.variable.valueReference not in arrays}
    assert init3 == init2
    with zipfile.ZipFile(p3) as z:
        names = z.namelist()
    assert f"binaries/x86_64-linux/{md3.coSimulation.modelIdentifier}.so" in names
    assert not any(n.startswith("binaries/linux64/") for n in names)


def _inputs(name):
    t = np.arange(2001) * 1e-3
    rows = fmu_inputs(name, t)
    if name != "Hoap2Plant3D":
        return rows
    # the 3D plant: a per-leg set point too (its value reference is one of those appended in issue 29)
    legs = np.zeros(len(t), dtype=rows.dtype.descr + [("q_right_knee_ref", float)])
    for n in rows.dtype.names:
        legs[n] = rows[n]
    legs["q_right_knee_ref"] = 0.1 * np.sin(np.pi * t)
    return legs


@pytest.mark.parametrize("name", NAMES)
def test_simulate_fmu_on_fmi3_equals_fmi2(twins, name):
    """FMPy's simulate_fmu on the twin (FMI 3.0 Co-Simulation: fmi3InstantiateCoSimulation,
    fmi3DoStep) gives the FMI 2.0 FMU's outputs bit for bit on the same input."""
    p2, p3 = twins[name]
    inp = _inputs(name)
    md2 = read_model_description(str(p2))
    outs = [v.name for v in md2.modelVariables if v.causality == "output"]
    r2 = simulate_fmu(str(p2), stop_time=2.0, step_size=1e-3, output_interval=1e-3, input=inp, output=outs)
    r3 = simulate_fmu(str(p3), stop_time=2.0, step_size=1e-3, output_interval=1e-3, input=inp, output=outs)
    assert len(r2) == len(r3) == 2001
    for n in outs:
        assert np.array_equal(r2[n], r3[n]), n


@pytest.mark.parametrize("scenario", ["hip_saves_push", "side_push_3d", "side_push_frontal"])
def test_closed_loop_on_fmi3_is_bit_identical(fmu_dir, scenario):
    """Our master on the FMI 3.0 twins (FMPy's FMU3Slave, fmi3GetFloat64/Int32/Int64/Boolean,
    fmi3DoStep) computes every column of the FMI 2.0 loop bit for bit, through a fall too: the
    sagittal loop, the sagittal controller falling on the 3D plant, and the 3D controller
    (AnkleHipController3D) standing the side push on it."""
    from anklehip.running.master import Models, simulate
    from anklehip.files.paths import find_scenario
    from anklehip.files.scenario import load_scenario
    sc = load_scenario(find_scenario(scenario))
    models = {fmi: Models.for_scenario(sc, fmu_dir, fmi=fmi) for fmi in (2, 3)}
    runs = {fmi: simulate(sc, models[fmi], progress=False, stop_time=min(sc.stop_time, 4.0)) for fmi in (2, 3)}
    a, b = runs[2], runs[3]
    # the run names every input of its controller (what a replay or a recorded step test feeds it)
    inputs = tuple(v.name for v in models[2].controller.by_causality("input"))
    assert a.controller_inputs == b.controller_inputs == inputs
    assert (a.outcome, a.fell_at, a.message) == (b.outcome, b.fell_at, b.message)
    assert a.data.dtype == b.data.dtype and len(a.data) == len(b.data) > 1000
    for n in a.data.dtype.names:
        assert np.array_equal(a.data[n], b.data[n]), n
    assert a.controller_initial == b.controller_initial


def test_cli_fmi_option(fmu_dir, tmp_path, capsys):
    """`anklehip --fmi 3 run` writes the FMI 2.0 run's CSV byte for byte; commands that do not run
    the twins refuse --fmi 3 with exit 2, and so does the native engine."""
    from anklehip.cli import main
    outs = {}
    for fmi in (2, 3):
        out = tmp_path / f"fmi{fmi}"
        assert main(["--fmu-dir", str(fmu_dir), "--fmi", str(fmi), "run", "ankle_small_push", "--stop-time", "1",
                     "--out", str(out)]) == 0
        outs[fmi] = (out / "ankle_small_push.csv").read_bytes()
    assert outs[2] == outs[3]
    capsys.readouterr()
    assert main(["--fmu-dir", str(fmu_dir), "--fmi", "3", "sweep", "slow_push"]) == 2
    assert "--fmi 3" in capsys.readouterr().err
    assert main(["--fmu-dir", str(fmu_dir), "--fmi", "3", "run", "ankle_small_push", "--stop-time", "1",
                 "--engine", "native", "--out", str(tmp_path / "native")]) == 2
    assert "native engine runs FMI 2.0" in capsys.readouterr().err
    assert main(["--fmu-dir", str(fmu_dir), "--fmi", "3", "info", "AnkleHipController", "--json"]) == 0
    assert '"3.0"' in capsys.readouterr().out


# ---------------------------------------------------------------------------------------------
# FMI 3.0 calls, through FMPy's low-level FMU3Slave

def _fmu3(p3, tmp_path, name="inst"):
    from fmpy import extract
    from fmpy.fmi3 import FMU3Slave
    md = read_model_description(str(p3))
    d = extract(str(p3), unzipdir=str(tmp_path / name))
    fmu = FMU3Slave(guid=md.instantiationToken, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName=name)
    return md, fmu


def _fmu2(p2, tmp_path, name="inst2"):
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave
    md = read_model_description(str(p2))
    d = extract(str(p2), unzipdir=str(tmp_path / name))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName=name)
    return md, fmu


@pytest.mark.parametrize("name", ["AnkleHipController", "AnkleHipController3D", "Hoap2Plant"])
def test_states_move_between_fmi_versions(twins, tmp_path, name):
    """A state serialized by the FMI 2.0 FMU is de-serialized by its FMI 3.0 twin (and back) and
    continues bit for bit: one byte format, one model."""
    p2, p3 = twins[name]
    md2, f2 = _fmu2(p2, tmp_path)
    md3, f3 = _fmu3(p3, tmp_path)
    vr = {v.name: v.valueReference for v in md2.modelVariables}
    real_outs = [v.valueReference for v in md2.modelVariables if v.causality == "output" and v.type == "Real"]
    inp = "push_force" if name.startswith("Hoap2Plant") else "zmp_y" if name.endswith("3D") else "theta_ankle"
    f2.instantiate()
    f2.setupExperiment(startTime=0.0)
    f2.enterInitializationMode()
    f2.exitInitializationMode()
    f3.instantiate()
    f3.enterInitializationMode(startTime=0.0)
    f3.exitInitializationMode()
    h = 1e-3
    for k in range(200):
        f2.setReal([vr[inp]], [0.02 if k > 50 else 0.0])
        f2.doStep(k * h, h)
    blob = f2.serializeFMUstate(f2.getFMUstate())
    f3.setFMUState(f3.deserializeFMUState(blob))
    ref, got = [], []
    for k in range(200, 400):
        f2.setReal([vr[inp]], [0.01])
        f2.doStep(k * h, h)
        f3.setFloat64([vr[inp]], [0.01])
        f3.doStep(k * h, h)
        ref.append(f2.getReal(real_outs))
        got.append(f3.getFloat64(real_outs))
    assert ref == got
    # and back: the FMI 3.0 instance's state into the FMI 2.0 one
    blob3 = f3.serializeFMUState(f3.getFMUState())
    f2.setFMUstate(f2.deSerializeFMUstate(blob3))
    f2.doStep(400 * h, h)
    f3.doStep(400 * h, h)
    assert f2.getReal(real_outs) == f3.getFloat64(real_outs)
    for f in (f2, f3):
        f.terminate()
        f.freeInstance()


@pytest.mark.parametrize("name", NAMES)
def test_fmi3_states_under_a_t_equals_k_h_master(twins, tmp_path, name):
    """The t = k*h master of tests/test_importer_time_and_init.py on the FMI 3.0 API: fmi3GetFMUState
    + fmi3SetFMUState at each of 1 500 points, and the time there read from `time`."""
    p2, p3 = twins[name]
    md, fmu = _fmu3(p3, tmp_path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu.instantiate()
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    h = 1e-3
    for k in range(1500):
        fmu.doStep(k * h, h)
        fmu.setFMUState(fmu.getFMUState())       # FMPy raises on fmi3Error
    assert fmu.getFloat64([vr["time"]]) == [1499 * h + h]
    fmu.terminate()
    fmu.freeInstance()


def test_fmi3_rules(twins, tmp_path):
    """Enumerations are read with fmi3GetInt64 (fmi3GetInt32 on `phase` is refused, naming it), the
    independent variable through fmi3GetFloat64, nValues must match, eventModeUsed is refused
    (hasEventMode = false)."""
    from fmpy.fmi3 import fmi3Error
    p2, p3 = twins["AnkleHipController"]
    md, fmu = _fmu3(p3, tmp_path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    messages = []
    with pytest.raises(Exception):
        fmu.instantiate(eventModeUsed=True, logMessage=lambda env, st, cat, msg: messages.append(msg.decode()))
    assert any("eventModeUsed" in m for m in messages), messages
    fmu.instantiate(logMessage=lambda env, st, cat, msg: messages.append(msg.decode()))
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    for k in range(50):
        fmu.doStep(k * 1e-3, 1e-3)
        fmu.setFMUState(fmu.getFMUState())
    assert fmu.getFloat64([vr["time"]]) == [50 * 1e-3]
    assert fmu.getInt64([vr["phase"]]) == [0]
    messages.clear()
    vrs = (ctypes.c_uint * 1)(vr["phase"])
    out = (ctypes.c_int32 * 1)()
    assert fmu.dll.fmi3GetInt32(fmu.component, vrs, 1, out, 1) == fmi3Error
    assert any("phase" in m and "Enumeration" in m for m in messages), messages
    vrs2 = (ctypes.c_uint * 2)(vr["theta_ankle_ref"], vr["k_w"])
    vals = (ctypes.c_double * 3)()
    assert fmu.dll.fmi3GetFloat64(fmu.component, vrs2, 2, vals, 3) == fmi3Error
    assert any("nValues" in m for m in messages), messages
    fmu.terminate()
    fmu.freeInstance()


@pytest.mark.parametrize("name", ["Hoap2Plant", "Hoap2Plant3D"])
def test_fmi3_plant_outputs_in_initialization_mode(twins, tmp_path, name):
    """fmi3GetFloat64 between fmi3EnterInitializationMode and fmi3ExitInitializationMode gives the
    initial posture and load (the same rule as FMI 2.0, tests/test_importer_time_and_init.py)."""
    p2, p3 = twins[name]
    md, fmu = _fmu3(p3, tmp_path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu.instantiate()
    fmu.setFloat64([vr["theta_ankle_init"]], [0.05])
    fmu.enterInitializationMode(startTime=0.0)
    theta, fz = fmu.getFloat64([vr["theta_ankle"], vr["fz"]])
    fmu.exitInitializationMode()
    assert fz > 50.0 and abs(theta - 0.05) < 0.01
    assert fmu.getFloat64([vr["theta_ankle"], vr["fz"]]) == [theta, fz]
    fmu.terminate()
    fmu.freeInstance()


@pytest.mark.parametrize("name", NAMES)
def test_native_runner_on_fmi3_equals_fmi2(twins, native_tool, tmp_path, name):
    """Our C++ importer (anklehip_rt_step, which reads FMI 2.0 and 3.0 descriptions and calls
    fmi3InstantiateCoSimulation / fmi3DoStep / fmi3GetInt64 ...) writes the same output CSV for the
    twin as for the FMI 2.0 FMU, byte for byte."""
    from conftest import write_csv
    runner = native_tool("anklehip_rt_step")
    csv_in = write_csv(tmp_path / "in.csv", _inputs(name))
    out = {}
    for fmi, fmu in zip((2, 3), twins[name]):
        d = tmp_path / f"fmi{fmi}"
        with zipfile.ZipFile(fmu) as z:
            z.extractall(d)
        import subprocess
        p = subprocess.run([str(runner), "--fmu-dir", str(d), "--input", str(csv_in), "--output", str(d / "out.csv"),
                            "--fast", "--step", "0.001"], capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, p.stderr
        out[fmi] = (d / "out.csv").read_bytes()
    assert out[2] == out[3] and out[2].count(b"\n") == 2002   # header + 2001 rows


def test_export_of_the_twins(fmu_dir, tmp_path, capsys):
    """`anklehip --fmi 3 export ssp` packs the FMI 3.0 twins into a schema-valid SSP and says which
    tools it is for; a container FMU (FMPy's, FMI 2.0 components) is refused with the reason."""
    from fmpy.ssp.ssd import read_ssd
    from anklehip.cli import main
    ssp = tmp_path / "p5.ssp"
    assert main(["--fmu-dir", str(fmu_dir), "--fmi", "3", "export", "ssp", "hip_saves_push", "--out", str(ssp)]) == 0
    assert "FMI 3.0" in capsys.readouterr().out
    read_ssd(str(ssp), validate=True)
    with zipfile.ZipFile(ssp) as z:
        md = read_model_description(z.open("resources/AnkleHipController.fmu"))
    assert md.fmiVersion == "3.0"
    assert main(["--fmu-dir", str(fmu_dir), "--fmi", "3", "export", "container", "hip_saves_push",
                 "--out", str(tmp_path / "c.fmu")]) == 2
    assert "FMI 2.0 FMUs" in capsys.readouterr().err and not (tmp_path / "c.fmu").exists()
