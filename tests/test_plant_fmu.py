"""FMU-level tests of Hoap2Plant.fmu (each test says what it establishes).

Uses the packed FMU from the `fmu_path` fixture (tests/conftest.py: ANKLEHIP_FMU_DIR or
<build>/fmus). Physics tests of the plant library itself are the CTests `plant.*`
(plant/tests/test_plant_physics.cpp); the Pinocchio cross-check is tests/test_plant_crosscheck.py.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fmpy.fmi2 import fmi2Discard, fmi2LastSuccessfulTime, fmi2Terminated
from fmpy.validation import validate_fmu
from conftest import NOMINAL_MASS, Slave

G = 9.81
MASS = NOMINAL_MASS  # nominal HOAP-2 (hoap2/nominal.h)


def test_validates(plant_fmu):
    """The FMU's modelDescription.xml and archive pass FMPy's validation with no problems."""
    assert validate_fmu(str(plant_fmu)) == []


def test_standalone_simulation_with_input_csv(plant_fmu, tmp_path):
    """From an empty directory holding only the .fmu, fmpy.simulate_fmu runs the plant with an
    input CSV (a 25 N, 60 ms push on the back): the foot rocks onto the toe, lands flat again and
    the robot stands (fz = m g at the end), in a fresh process with an empty library path."""
    work = tmp_path / "empty"
    work.mkdir()
    shutil.copy(plant_fmu, work / "Hoap2Plant.fmu")
    (work / "push.csv").write_text("time,theta_ankle_ref,theta_hip_ref,push_force\n"
                                   "0,0,0,0\n0.1,0,0,0\n0.1,0,0,25\n0.16,0,0,25\n0.16,0,0,0\n1.5,0,0,0\n")
    script = (
        "import numpy as np, fmpy\n"
        "inp = np.genfromtxt('push.csv', delimiter=',', names=True)\n"
        "r = fmpy.simulate_fmu('Hoap2Plant.fmu', stop_time=1.5, step_size=1e-3, output_interval=1e-3, input=inp,\n"
        "                      output=['contact_mode', 'fz', 'foot_pitch', 'fallen', 'impacts'])\n"
        "np.save('out.npy', r)\n"
    )
    env = {"PATH": "/usr/bin:/bin", "LD_LIBRARY_PATH": ""}
    subprocess.run([sys.executable, "-c", script], cwd=work, env=env, check=True, timeout=120)
    r = np.load(work / "out.npy")
    modes = r["contact_mode"].astype(int)
    assert 1 in modes, "never rocked onto the toe"
    assert modes[-1] == 0 and not r["fallen"].any()
    assert r["foot_pitch"].max() > 0.01
    assert r["impacts"][-1] >= 1
    assert r["fz"][-1] == pytest.approx(MASS * G, rel=1e-6)


@pytest.mark.parametrize("ankle,hip", [(0.0, 0.0), (0.05, 0.0), (0.03, 0.25), (-0.02, -0.2)])
def test_static_leaned_posture(plant_unzipped, ankle, hip):
    """Started settled in a leaned posture (theta_*_init = set-points) the plant is in static
    equilibrium: zmp_x from the sole sensors equals the CoM ground projection (feet included),
    fz = m g, flat contact, no mode switches (the 60 s version is the CTest plant.static_standing)."""
    s = Slave(plant_unzipped, {"theta_ankle_init": ankle, "theta_hip_init": hip},
              inputs={"theta_ankle_ref": ankle, "theta_hip_ref": hip})
    for _ in range(2000):
        s.step()
    assert s.get("zmp_x") == pytest.approx(s.get("com_x"), abs=1e-12)
    assert s.get("fz") == pytest.approx(MASS * G, rel=1e-12)
    assert s.get("contact_mode") == 0 and s.get("mode_switches") == 0
    assert abs(s.get("theta_ankle") - ankle) < 0.01 and abs(s.get("theta_hip") - hip) < 0.01
    assert s.get("cvode_steps") > 0 and s.get("rhs_evals") > 0
    s.free()


def test_fall_discard_terminated_protocol(plant_unzipped):
    """A too-large push (60 N for 0.3 s) ends in a detected fall: doStep returns fmi2Discard,
    fmi2Terminated is true, fmi2LastSuccessfulTime is the fall time inside the failing step,
    `fallen` is true, and later steps are refused with Discard as well."""
    s = Slave(plant_unzipped)
    s.set("push_force", 60.0)
    status = None
    for _ in range(3000):
        try:
            s.step()
        except Exception as e:  # FMPy raises on fmi2Discard
            status = getattr(e, "status", None)
            break
    assert status == fmi2Discard
    t_fail_start = s.t
    assert s.fmu.getBooleanStatus(fmi2Terminated)
    t_last = s.fmu.getRealStatus(fmi2LastSuccessfulTime)
    assert t_fail_start < t_last <= t_fail_start + 1e-3
    assert s.get("fallen")
    assert abs(s.get("foot_pitch")) == pytest.approx(0.3, abs=1e-6)
    s.fmu.freeInstance()


def _rocking_run(unzipped, params=None, tolerance=None, steps=300):
    """A 25 N push of 60 ms that rocks the foot onto its toe; the outputs and the integrator's
    right-hand-side count at the end."""
    s = Slave(unzipped, params, tolerance=tolerance)
    s.set("push_force", 25.0)
    for i in range(steps):
        if i == 60:
            s.set("push_force", 0.0)
        s.step()
    out = s.outputs() + [s.get("rhs_evals")]
    s.free()
    return out


def test_importer_tolerance_rule(plant_unzipped):
    """The integrator's relative tolerance (docs/plant.md): the importer's fmi2SetupExperiment
    tolerance when it defines one, else the DefaultExperiment's (1e-8, the model's default); the
    parameter rtol, when set (> 0), wins over both. Established by equal and unequal runs: an
    undefined tolerance runs exactly like a defined 1e-8; a loose 1e-4 changes the trajectory and
    needs fewer right-hand-side evaluations; rtol=1e-10 with an importer's 1e-4 runs exactly like
    rtol=1e-10 alone."""
    from fmpy import read_model_description
    md = read_model_description(str(plant_unzipped / "modelDescription.xml"))
    assert md.defaultExperiment.tolerance == "1e-08"
    assert next(v for v in md.modelVariables if v.name == "rtol").start == "0"
    default = _rocking_run(plant_unzipped)
    assert _rocking_run(plant_unzipped, tolerance=1e-8) == default
    loose = _rocking_run(plant_unzipped, tolerance=1e-4)
    assert loose != default and loose[-1] < default[-1]
    tight = _rocking_run(plant_unzipped, {"rtol": 1e-10})
    assert tight != default and tight[-1] > default[-1]
    assert _rocking_run(plant_unzipped, {"rtol": 1e-10}, tolerance=1e-4) == tight


def test_importer_tolerance_out_of_range_is_an_error(plant_unzipped, fmu_path):
    """A tolerance the integrators cannot use (> 1e-2) fails the initialization with a message
    that names fmi2SetupExperiment; the controllers and the 3D plant (no error-controlled
    integrator) advertise no tolerance."""
    from fmpy import read_model_description
    from fmpy.fmi2 import fmi2Error, fmi2OK
    from conftest import RawModel
    inst = RawModel(plant_unzipped).instance(logging_on=True)
    assert inst.fmi2SetupExperiment(1, 0.5, 0.0, 0, 0.0) == fmi2OK
    assert inst.fmi2EnterInitializationMode() == fmi2OK
    assert inst.fmi2ExitInitializationMode() == fmi2Error
    assert any("0.5" in m and "fmi2SetupExperiment" in m for m in inst.errors()), inst.errors()
    inst.free()
    for model in ("AnkleHipController", "AnkleHipController3D", "Hoap2Plant3D"):
        assert read_model_description(str(fmu_path(model))).defaultExperiment.tolerance is None, model


def test_state_serialization_bit_for_bit(plant_unzipped):
    """A serialized FMU state taken while the foot rocks on its toe, de-serialized into a fresh
    instance, continues bit for bit like the uninterrupted run (the integrator restarted
    identically, with the step size in the state; contact mode, pivot, noise generator and
    statistics restored)."""
    params = {"sensor_noise": 0.2, "seed": 42}
    a = Slave(plant_unzipped, params, name="a")
    a.set("push_force", 25.0)
    for i in range(400):
        if i == 60:
            a.set("push_force", 0.0)
        if i == 100:
            assert a.get("contact_mode") == 1
            blob = a.fmu.serializeFMUstate(a.fmu.getFMUstate())
            t_snap = a.t
        a.step()
    names = ["theta_ankle", "theta_hip", "zmp_x", "fz", "foot_pitch", "f_toe", "energy"]
    ref_final = [a.get(n) for n in names] + [a.get("contact_mode"), a.get("rhs_evals")]
    b = Slave(plant_unzipped, params, name="b")
    st = b.fmu.deSerializeFMUstate(blob)
    b.fmu.setFMUstate(st)
    b.t = t_snap
    for i in range(100, 400):
        b.step()
    got = [b.get(n) for n in names] + [b.get("contact_mode"), b.get("rhs_evals")]
    assert got == ref_final  # exact equality
    a.free()
    b.free()


def test_sensor_noise_seeded(plant_unzipped):
    """Sole-sensor noise is off by default and, when on, reproducible per seed and different
    between seeds; its standard deviation is the parameter's."""
    def run(params):
        s = Slave(plant_unzipped, params)
        v = []
        for _ in range(500):
            s.step()
            v.append(s.get("f_toe"))
        s.free()
        return np.array(v)

    clean = run({})
    assert np.ptp(clean) < 1e-9
    a, b, c = run({"sensor_noise": 0.5, "seed": 3}), run({"sensor_noise": 0.5, "seed": 3}), run({"sensor_noise": 0.5, "seed": 4})
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert np.std(a - clean) == pytest.approx(0.5, rel=0.15)


def test_non_finite_input_contained(plant_unzipped):
    """A NaN/Inf input is contained: the step returns fmi2Warning (logged), the last finite value
    is held, and no output becomes non-finite."""
    s = Slave(plant_unzipped)
    for _ in range(10):
        s.step()
    s.set("push_force", float("nan"))
    s.set("theta_hip_ref", float("inf"))
    s.step()  # fmi2Warning does not raise in FMPy
    s.set("push_force", 0.0)
    s.set("theta_hip_ref", 0.0)
    s.step()
    for n in ["theta_ankle", "theta_hip", "zmp_x", "fz", "fx", "com_x", "energy"]:
        assert np.isfinite(s.get(n)), n
    assert s.get("contact_mode") == 0
    s.free()


def test_integrators_agree_in_the_closed_loop():
    """The two integrators (parameter `integrator`: 0 ARKODE explicit Runge-Kutta, the default;
    1 CVODE BDF) give the same closed loop on `paper_configuration` (three pushes, toe and heel
    rocking, micro-rocking at the toe edge) within 1e-6 rad, the same phase sequence and contact
    events to the millisecond, and both stay within 1e-6 rad of a tight-tolerance reference
    (BDF, rtol 1e-11)."""
    from anklehip.running.master import simulate
    from anklehip.files.paths import find_scenario
    from anklehip.files.scenario import load_scenario
    sc = load_scenario(find_scenario("paper_configuration"))
    runs = {k: simulate(sc, plant_overrides=o, stop_time=18.0, progress=False).data
            for k, o in {"erk": {"integrator": 0}, "bdf": {"integrator": 1},
                         "ref": {"integrator": 1, "rtol": 1e-11, "atol": 1e-13}}.items()}
    for k in ("erk", "bdf"):
        d, ref = runs[k], runs["ref"]
        for c in ("theta_ankle", "theta_hip", "foot_pitch"):
            assert np.max(np.abs(d[c] - ref[c])) < 1e-6, (k, c)
        np.testing.assert_array_equal(d["phase"], ref["phase"])
        np.testing.assert_array_equal(d["contact_mode"], ref["contact_mode"])
