"""Defects that real masters hit (issue 28, defects 1 and 2; issue 33, finding 8), tried as those
masters call the FMUs, through ctypes (every status visible):

* A master that computes its communication points as t_k = k*h (Simulink-style) instead of
  summing t += h: at every point, fmi2GetFMUstate + fmi2SetFMUstate and a serialized state
  de-serialized into a fresh instance must work on every FMU (canGetAndSetFMUstate = true), and the
  restored instance must continue exactly like the original.
* One time rule in the shared glue for all FMUs (docs/fmu.md, "Time"): a communication point
  within 1e-9*(1 + |t|) + 1e-6*h of the FMU's time is that time, for the plants as for the
  controller; one outside it is refused by every FMU alike.
* The plants' outputs in initialization mode: <InitialUnknowns> declares them computable from the
  parameters, so a master that propagates values inside initialization mode (OMSimulator, Dymola,
  Simulink) must read the initial posture and load, not zeros with status OK.
"""
from __future__ import annotations

import ctypes
import math

import pytest
from conftest import SHIPPED, RawModel, _unzip, fmi2Error, fmi2OK, fmi2Warning

PLANTS = ("Hoap2Plant", "Hoap2Plant3D")
ALL = SHIPPED


@pytest.fixture(scope="module")
def raw(fmu_path, tmp_path_factory):
    models = {}

    def get(name: str) -> RawModel:
        if name not in models:
            models[name] = RawModel(_unzip(fmu_path(name), tmp_path_factory))
        return models[name]

    return get


def _start(model: RawModel, name="inst", params=None, start=0.0):
    inst = model.instance(name=name)
    assert inst.c, inst.log
    assert inst.fmi2SetupExperiment(0, 0.0, start, 0, 0.0) == fmi2OK
    assert inst.fmi2EnterInitializationMode() == fmi2OK
    if params:
        assert inst.set_real(params) == fmi2OK, inst.errors()
    assert inst.fmi2ExitInitializationMode() == fmi2OK, inst.errors()
    return inst


def _serialize(inst):
    st = ctypes.c_void_p()
    assert inst.fmi2GetFMUstate(ctypes.byref(st)) == fmi2OK, inst.errors()
    n = ctypes.c_size_t()
    assert inst.fmi2SerializedFMUstateSize(st, ctypes.byref(n)) == fmi2OK
    buf = ctypes.create_string_buffer(n.value)
    assert inst.fmi2SerializeFMUstate(st, buf, n.value) == fmi2OK
    assert inst.fmi2FreeFMUstate(ctypes.byref(st)) == fmi2OK
    return buf.raw


def _outputs(model: RawModel, inst):
    names = [v.name for v in model.description.modelVariables if v.causality == "output" and v.type == "Real"]
    st, vals = inst.get_real(names)
    assert st == fmi2OK, inst.errors()
    return vals


@pytest.mark.parametrize("name", ALL)
def test_states_under_a_t_equals_k_h_master(raw, name):
    """t_k = k*h at 1 ms: fmi2GetFMUstate + fmi2SetFMUstate succeed at every one of 3 000 points
    (the plants refused 2 988 of them, from step 11 on, before issue 28), and a state serialized at
    a late point continues bit for bit in a fresh instance driven by the same master."""
    model = raw(name)
    a = _start(model, "a")
    h, n = 1e-3, 3000
    refused = []
    blob, k_blob = None, 2345
    st = ctypes.c_void_p()
    for k in range(n):
        assert a.fmi2DoStep(k * h, h, 1) in (fmi2OK, fmi2Warning), (k, a.errors())
        assert a.fmi2GetFMUstate(ctypes.byref(st)) == fmi2OK, (k, a.errors())
        if a.fmi2SetFMUstate(st) != fmi2OK:
            refused.append(k)
        if k + 1 == k_blob:
            blob = _serialize(a)
    assert a.fmi2FreeFMUstate(ctypes.byref(st)) == fmi2OK
    assert not refused, f"{name}: fmi2SetFMUstate refused at {len(refused)} of {n} points, first k={refused[0]}: " \
                        f"{a.errors()[-1:]}"
    ref = _outputs(model, a)

    b = _start(model, "b")
    state = ctypes.c_void_p()
    assert b.fmi2DeSerializeFMUstate(blob, len(blob), ctypes.byref(state)) == fmi2OK, b.errors()
    assert b.fmi2SetFMUstate(state) == fmi2OK, b.errors()
    for k in range(k_blob, n):
        assert b.fmi2DoStep(k * h, h, 1) in (fmi2OK, fmi2Warning), (k, b.errors())
    assert _outputs(model, b) == ref          # exact
    a.free()
    b.free()


@pytest.mark.parametrize("name", ALL)
def test_one_time_rule_for_every_fmu(raw, name):
    """doStep(1 + 5e-7, 1) after a step to t = 1 is inside 1e-9*(1 + |t|) + 1e-6*h (= 1.002e-6):
    every FMU accepts it (the plants refused it and stayed in the error state, issue 33 finding 8);
    a point 2e-6 off is refused by every FMU, which then still accepts the right point."""
    model = raw(name)
    inst = _start(model)
    assert inst.fmi2DoStep(0.0, 1.0, 1) in (fmi2OK, fmi2Warning), inst.errors()
    assert inst.fmi2DoStep(1.0 + 2e-6, 1.0, 1) == fmi2Error
    assert any("does not match the FMU time" in m for m in inst.errors()), inst.errors()
    assert inst.fmi2DoStep(1.0 + 5e-7, 1.0, 1) in (fmi2OK, fmi2Warning), inst.errors()
    # and the snapshot of that instance is restorable (its time is the instance's by the same rule)
    st = ctypes.c_void_p()
    assert inst.fmi2GetFMUstate(ctypes.byref(st)) == fmi2OK
    assert inst.fmi2SetFMUstate(st) == fmi2OK, inst.errors()
    assert inst.fmi2DoStep(2.0 + 5e-7, 1e-3, 1) in (fmi2OK, fmi2Warning), inst.errors()
    inst.free()


INIT = {"theta_ankle_init": 0.05, "theta_hip_init": -0.1}


@pytest.mark.parametrize("name", PLANTS)
def test_plant_outputs_in_initialization_mode(raw, name):
    """With non-zero initial angles, every output read between fmi2EnterInitializationMode and
    fmi2ExitInitializationMode equals the value after the exit (Real, Integer and Boolean), and the
    load is the robot's weight, not 0 (fz = 0 reads as a lifted robot to the controller). A
    parameter set after a read is honoured (the outputs follow it)."""
    model = raw(name)
    md = model.description
    outs = [v for v in md.modelVariables if v.causality == "output"]
    inst = model.instance()
    assert inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0) == fmi2OK
    assert inst.fmi2EnterInitializationMode() == fmi2OK
    assert inst.set_real({"theta_ankle_init": 0.02}) == fmi2OK
    st, first = inst.get_real(["theta_ankle"])              # computed for 0.02 ...
    assert st == fmi2OK and first[0] != 0.0, inst.errors()
    assert inst.set_real(INIT) == fmi2OK                    # ... and again for the final parameters
    reals = [v.name for v in outs if v.type == "Real"]
    ints = [v.name for v in outs if v.type in ("Integer", "Boolean")]
    st, r_init = inst.get_real(reals)
    assert st == fmi2OK, inst.errors()
    i_init = _ints(inst, model, ints)
    init = dict(zip(reals, r_init))
    assert inst.fmi2ExitInitializationMode() == fmi2OK, inst.errors()
    st, r_after = inst.get_real(reals)
    assert st == fmi2OK
    after = dict(zip(reals, r_after))
    assert init == after, {k: (init[k], after[k]) for k in reals if init[k] != after[k]}
    assert _ints(inst, model, ints) == i_init
    assert init["fz"] > 50.0 and math.isclose(init["fz"], init["fz_true"], rel_tol=0.05), init["fz"]
    assert abs(init["theta_ankle"] - INIT["theta_ankle_init"]) < 0.01, init["theta_ankle"]
    assert abs(init["theta_hip"] - INIT["theta_hip_init"]) < 0.01, init["theta_hip"]
    # the exit used the plant built in initialization mode: the first step is the original's
    b = _start(model, "b", params=INIT)
    assert _outputs(model, b) == r_after
    assert inst.fmi2DoStep(0.0, 1e-3, 1) == fmi2OK and b.fmi2DoStep(0.0, 1e-3, 1) == fmi2OK
    assert _outputs(model, inst) == _outputs(model, b)
    inst.free()
    b.free()


def md_type(model, name):
    return model.vars[name].type


def _ints(inst, model, names):
    out = []
    for n in names:
        val = ctypes.c_int()
        vr = (ctypes.c_uint * 1)(inst.vr(n))
        f = inst.lib.fmi2GetInteger if md_type(model, n) == "Integer" else inst.lib.fmi2GetBoolean
        assert f(inst.c, vr, 1, ctypes.byref(val)) == fmi2OK, inst.errors()
        out.append(val.value)
    return out


@pytest.mark.parametrize("name", PLANTS)
def test_plant_initial_outputs_refused_parameters(raw, name):
    """Parameters the plant cannot be built from make the fmi2Get* in initialization mode fail with
    the reason (not 0 with status OK), and the instance recovers when they are corrected."""
    model = raw(name)
    inst = model.instance()
    assert inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0) == fmi2OK
    assert inst.fmi2EnterInitializationMode() == fmi2OK
    assert inst.set_real({"h_push": 0.01}) == fmi2OK        # below the hips: refused by the plant
    st, _ = inst.get_real(["fz"])
    assert st == fmi2Error
    assert any("h_push" in m for m in inst.errors()), inst.errors()
    assert inst.set_real({"h_push": float(model.vars["h_push"].start)}) == fmi2OK
    st, fz = inst.get_real(["fz"])
    assert st == fmi2OK and fz[0] > 50.0, inst.errors()
    assert inst.fmi2ExitInitializationMode() == fmi2OK
    inst.free()
