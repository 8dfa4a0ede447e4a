"""The glue with its test-only model GlueTestModel.fmu (fmu/common/tests/glue_test_model.cpp):
constants, Boolean/String variables, calculated parameters, fmi2Discard + fmi2Terminated and the
stepFailed state, exceptions inside the model, tunable-parameter rejection."""
from __future__ import annotations

import ctypes

from conftest import fmi2Discard, fmi2Error, fmi2OK

fmi2LastSuccessfulTime, fmi2Terminated = 2, 3


def _init(raw, **reals):
    inst = raw.instance()
    assert inst.c
    if reals:
        assert inst.set_real(reals) == fmi2OK
    assert inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0) == fmi2OK
    assert inst.fmi2EnterInitializationMode() == fmi2OK
    return inst


def _vrs(inst, *names):
    return (ctypes.c_uint * len(names))(*[inst.vr(n) for n in names])


def test_validate(glue_test_fmu):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(glue_test_fmu)) == []


def test_constant_cannot_be_set_in_any_state(raw_glue_model):
    inst = raw_glue_model.instance()
    one = (ctypes.c_double * 1)(3.0)
    assert inst.fmi2SetReal(_vrs(inst, "pi"), 1, one) == fmi2Error
    assert any('"pi"' in m and "constant" in m for m in inst.errors())
    inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0)
    inst.fmi2EnterInitializationMode()
    assert inst.fmi2SetReal(_vrs(inst, "pi"), 1, one) == fmi2Error
    assert inst.get_real(["pi"]) == (fmi2OK, [3.141592653589793])
    inst.free()


def test_strings_booleans_and_calculated_parameter(raw_glue_model):
    inst = _init(raw_glue_model, k=3.0)
    assert inst.get_real(["twice_k"]) == (fmi2OK, [6.0])  # calculated in initialization mode
    s = (ctypes.c_char_p * 1)(b"hello")
    assert inst.fmi2SetString(_vrs(inst, "label"), 1, s) == fmi2OK
    null = (ctypes.c_char_p * 1)(None)
    assert inst.fmi2SetString(_vrs(inst, "label"), 1, null) == fmi2Error
    b = (ctypes.c_int * 1)(1)
    assert inst.fmi2SetBoolean(_vrs(inst, "flag"), 1, b) == fmi2OK
    assert inst.fmi2SetReal(_vrs(inst, "twice_k"), 1, (ctypes.c_double * 1)(1.0)) == fmi2Error
    assert inst.fmi2ExitInitializationMode() == fmi2OK
    out = (ctypes.c_char_p * 1)()
    assert inst.fmi2GetString(_vrs(inst, "label"), 1, out) == fmi2OK and out[0] == b"hello"
    bo = (ctypes.c_int * 1)(5)
    assert inst.fmi2GetBoolean(_vrs(inst, "flag"), 1, bo) == fmi2OK and bo[0] == 1
    assert inst.fmi2SetString(_vrs(inst, "label"), 1, s) == fmi2Error  # fixed after init
    inst.free()


def test_empty_string_parameter_fails_initialization(raw_glue_model):
    inst = raw_glue_model.instance()
    e = (ctypes.c_char_p * 1)(b"")
    assert inst.fmi2SetString(_vrs(inst, "label"), 1, e) == fmi2OK
    inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0)
    inst.fmi2EnterInitializationMode()
    assert inst.fmi2ExitInitializationMode() == fmi2Error
    assert any("label" in m for m in inst.errors())
    inst.free()


def test_discard_terminated_and_step_failed_state(raw_glue_model):
    inst = _init(raw_glue_model, fail_at=0.025, u=1.0)
    assert inst.fmi2ExitInitializationMode() == fmi2OK
    assert inst.fmi2DoStep(0.0, 0.01, 1) == fmi2OK
    assert inst.fmi2DoStep(0.01, 0.01, 1) == fmi2OK
    assert inst.fmi2DoStep(0.02, 0.01, 1) == fmi2Discard
    t = ctypes.c_double()
    assert inst.fmi2GetRealStatus(fmi2LastSuccessfulTime, ctypes.byref(t)) == fmi2OK and t.value == 0.025
    term = ctypes.c_int()
    assert inst.fmi2GetBooleanStatus(fmi2Terminated, ctypes.byref(term)) == fmi2OK and term.value == 1
    st, y = inst.get_real(["y"])
    assert st == fmi2OK and abs(y[0] - 2.0 * 0.025) < 1e-15  # outputs at the last successful time
    assert inst.fmi2DoStep(0.025, 0.01, 1) == fmi2Error  # stepFailed: no further step
    assert any("stepFailed" in m for m in inst.errors())
    assert any(c == "logStatusDiscard" for _, c, _ in inst.log)
    assert inst.fmi2Terminate() == fmi2OK  # allowed from stepFailed
    assert inst.get_real(["y"])[0] == fmi2OK  # values still readable after terminate
    inst.free()


def test_exception_in_model_does_not_cross_the_abi(raw_glue_model):
    inst = _init(raw_glue_model)
    assert inst.fmi2ExitInitializationMode() == fmi2OK
    assert inst.set_real({"poison": 666.0}) == fmi2OK
    assert inst.fmi2DoStep(0.0, 0.01, 1) == fmi2Error
    assert any("poisoned input" in m for m in inst.errors())
    assert inst.fmi2DoStep(0.0, 0.01, 1) == fmi2Error  # error state
    assert inst.fmi2Reset() == fmi2OK
    inst.free()


def test_tunable_rejected_by_model_keeps_old_value(raw_glue_model):
    inst = _init(raw_glue_model)
    assert inst.fmi2ExitInitializationMode() == fmi2OK
    assert inst.set_real({"k": 5.0}) == fmi2OK
    assert inst.set_real({"k": 7.0}) == fmi2Error
    assert any("k = 7" in m for m in inst.errors())
    assert any(c == "logModel" for _, c, _ in inst.log)  # the model's own category
    assert inst.get_real(["k"]) == (fmi2OK, [5.0])
    assert inst.set_real({"u": 1.0}) == fmi2OK
    assert inst.fmi2DoStep(0.0, 0.01, 1) == fmi2OK
    assert inst.get_real(["y"]) == (fmi2OK, [0.05])
    inst.free()


def test_atomic_set_with_one_bad_element(raw_glue_model):
    inst = _init(raw_glue_model)
    vr = _vrs(inst, "u", "k")
    vals = (ctypes.c_double * 2)(1.5, 11.0)  # k out of [0, 10]
    assert inst.fmi2SetReal(vr, 2, vals) == fmi2Error
    assert inst.get_real(["u", "k"]) == (fmi2OK, [0.0, 2.0])  # nothing was set
    inst.free()


def test_fmpy_simulation_stops_at_discard(glue_test_fmu):
    import fmpy

    r = fmpy.simulate_fmu(str(glue_test_fmu), start_values={"fail_at": 0.5}, output=["y", "count", "done"])
    assert r["time"][-1] == 0.5 and bool(r["done"][-1]) and r["count"][-1] == 50
