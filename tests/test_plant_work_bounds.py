"""Legal parameters cannot make one FMI call of a plant run unbounded work (issue 33, findings 3
and 4). Through the raw FMI C API; what each test establishes:

- Hoap2Plant3D: internal_step and rocking_step below 10 us are refused at set time (the declared
  range; 1 us was legal, and settle_time = 0.1 s at 1 us took 38.5 s in fmi2ExitInitializationMode);
  a settling of more than 1e5 ODE steps (settle_time / internal_step) is refused by
  fmi2ExitInitializationMode at once with the reason (settle_time = 100 s took 56 s, both at their
  declared limits about 10 h), and the largest allowed one (1e5 steps) completes;
- Hoap2Plant: the integrator parameter's default (2, automatic) takes BDF when the servo gains make
  the equations stiff for the explicit method (its fastest mode above 3e5 1/s) and says so in the
  log: kp = 1e6, kd = 1e5 on both servos run a 0.5 s step at BDF's cost (the explicit integrator took
  28 s, and a 3600 s step was allowed: about 56 h); explicit integration forced with those gains is
  refused at initialization with the reason; forced with gains just below that limit, a
  communication step that would need more than 1e6 explicit steps fails with the reason instead of
  running on; the HOAP-2's own gains keep the explicit integrator (the automatic choice changes
  nothing there).
"""
from __future__ import annotations

import ctypes

import pytest

from conftest import RawModel, _unzip, fmi2Error, fmi2OK


@pytest.fixture(scope="module")
def raw3d(fmu_path, tmp_path_factory) -> RawModel:
    return RawModel(_unzip(fmu_path("Hoap2Plant3D"), tmp_path_factory))


@pytest.fixture(scope="module")
def raw_plant(plant_unzipped) -> RawModel:
    return RawModel(plant_unzipped)


def _init(inst, reals=None, integers=None):
    if reals:
        assert inst.set_real(reals) == fmi2OK, inst.errors()
    for name, v in (integers or {}).items():
        assert inst.fmi2SetInteger((ctypes.c_uint * 1)(inst.vr(name)), 1, (ctypes.c_int * 1)(v)) == fmi2OK
    assert inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0) == fmi2OK
    assert inst.fmi2EnterInitializationMode() == fmi2OK
    return inst.fmi2ExitInitializationMode()


# ---------------------------------------------------------------------------------------------
# Finding 3: the 3D plant's settling

@pytest.mark.parametrize("name", ["internal_step", "rocking_step"])
def test_ode_steps_below_10_us_are_refused_at_set_time(raw3d, name):
    inst = raw3d.instance()
    assert inst.set_real({name: 1e-6}) == fmi2Error
    assert any(f'"{name}" = 9.9999999999999995e-07 is outside [1e-05, 0.01]' in m for m in inst.errors()), inst.log
    assert inst.set_real({name: 1e-5}) == fmi2OK
    inst.free()


@pytest.mark.parametrize("settle, step", [(100.0, 1e-5), (2.0, 1e-5), (100.0, 5e-4)])
def test_settling_beyond_its_work_cap_is_refused_with_the_reason(raw3d, settle, step):
    inst = raw3d.instance()
    assert _init(inst, {"settle_time": settle, "internal_step": step}) == fmi2Error
    assert any("ODE steps: the settling in fmi2ExitInitializationMode takes at most 100000" in m
               and f"settle_time = {settle:g} s at internal_step = {step:g} s" in m for m in inst.errors()), inst.log
    inst.free()


def test_the_largest_settling_allowed_completes(raw3d):
    inst = raw3d.instance()
    assert _init(inst, {"settle_time": 100.0, "internal_step": 1e-3}) == fmi2OK, inst.errors()  # 1e5 steps
    assert inst.fmi2DoStep(0.0, 1e-3, 0) == fmi2OK
    inst.free()


# ---------------------------------------------------------------------------------------------
# Finding 4: the sagittal plant with stiff servo gains

STIFF = {"kp_ankle": 1e6, "kd_ankle": 1e5, "kp_hip": 1e6, "kd_hip": 1e5}


def _automatic_choice(inst) -> str:
    lines = [m for _, _, m in inst.log if m.startswith("integrator = 2 (automatic)")]
    assert len(lines) == 1, inst.log
    return lines[0]


def test_stiff_gains_take_bdf_by_default(raw_plant):
    inst = raw_plant.instance()
    assert _init(inst, STIFF) == fmi2OK, inst.errors()
    line = _automatic_choice(inst)
    assert "BDF (CVODE)" in line and "decays at 1.47e+07 1/s" in line, line
    inst.set_real({"theta_hip_ref": 0.05, "push_force": 5.0})
    assert inst.fmi2DoStep(0.0, 0.5, 0) == fmi2OK
    steps = inst.get_integer(["cvode_steps"])[1][0]
    assert steps < 20000, steps   # BDF: about 1e3 steps here (the explicit method took 1.67 M)
    inst.free()


def test_the_hoap2_gains_keep_the_explicit_integrator(raw_plant):
    inst = raw_plant.instance()
    assert _init(inst) == fmi2OK
    line = _automatic_choice(inst)
    assert "explicit Runge-Kutta" in line and "decays at 2.62e+03 1/s" in line, line
    inst.free()


def test_explicit_integration_forced_with_stiff_gains_is_refused_at_initialization(raw_plant):
    inst = raw_plant.instance()
    assert _init(inst, STIFF, {"integrator": 0}) == fmi2Error
    assert any("integrator = 0 (explicit Runge-Kutta) with these servo gains" in m and "1.47e+07 1/s" in m
               and "use integrator = 2 (automatic) or 1 (BDF)" in m for m in inst.errors()), inst.log
    inst.free()


def test_explicit_steps_beyond_the_budget_fail_with_the_reason(raw_plant):
    """Gains 300 times the HOAP-2's (fastest mode 7.9e5 1/s, just below the refusal): explicit
    integration is allowed, but a 30 s step would take about 7e6 stability-limited steps."""
    inst = raw_plant.instance()
    gains = {"kp_ankle": 400.0 * 300, "kd_ankle": 20.0 * 300, "kp_hip": 150.0 * 300, "kd_hip": 5.0 * 300}
    assert _init(inst, gains, {"integrator": 0}) == fmi2OK, inst.errors()
    inst.set_real({"theta_hip_ref": 0.05, "push_force": 5.0})
    assert inst.fmi2DoStep(0.0, 30.0, 0) == fmi2Error
    assert any("the explicit integrator took 1000000 steps in the communication step from t=0.000000000 to "
               "30.000000000" in m and "stiff" in m for m in inst.errors()), inst.log
    inst.free()
    auto = raw_plant.instance()                                # the same step with the default choice
    assert _init(auto, gains) == fmi2OK
    assert "BDF (CVODE)" in _automatic_choice(auto)
    auto.set_real({"theta_hip_ref": 0.05, "push_force": 5.0})
    assert auto.fmi2DoStep(0.0, 30.0, 0) == fmi2OK
    auto.free()
