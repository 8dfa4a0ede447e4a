"""The FMI 2.0 co-simulation glue (fmu/common), exercised through each controller FMU
(AnkleHipController.fmu and AnkleHipController3D.fmu: every test taking `raw_controller` or
`controller_fmu` runs on both): state machine, get/set rules, logging, FMU state snapshots and
their serialization, binary hygiene, modelDescription.xml. Low-level calls go through ctypes
(tests/conftest.py RawModel)."""
from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile

import pytest

from conftest import (fmi2Discard, fmi2Error, fmi2OK, fmi2Warning, CONTROLLER_OUTPUTS, REPO_ROOT, SHIPPED, RawModel,
                      _unzip)

CONTROLLERS = [n for n in SHIPPED if n.startswith("AnkleHipController")]
# the 3D controller's frontal outputs, read with the sagittal ones where the FMU has them
FRONTAL_OUTPUTS = ["phi_ref", "psi_ref", "dphi_ref", "dpsi_ref", "com_y", "com_z_frontal", "disturbance_moment_y",
                   "k_w_y", "com_y_desired", "q_left_hip_roll_ref", "q_right_knee_ref", "q_left_ankle_roll_ref"]


# These override conftest's fixtures of the same names in this module: each controller FMU in turn.
@pytest.fixture(scope="module", params=CONTROLLERS)
def controller_fmu(request, fmu_path):
    return fmu_path(request.param)


@pytest.fixture(scope="module")
def controller_unzipped(controller_fmu, tmp_path_factory):
    return _unzip(controller_fmu, tmp_path_factory)


@pytest.fixture(scope="module")
def raw_controller(controller_unzipped) -> RawModel:
    return RawModel(controller_unzipped)

fmi2LastSuccessfulTime, fmi2Terminated = 2, 3


# ---------------------------------------------------------------------------------------------
# State machine: every call in every reachable state.

def _to_state(raw, state):
    inst = raw.instance()
    assert inst.c, "instantiate failed"
    if state == "instantiated":
        return inst
    if state == "error":
        assert inst.set_real({"zmp_limit_front": 0.07}) == fmi2OK  # inside bounds, beyond the toe
        assert inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0) == fmi2OK
        assert inst.fmi2EnterInitializationMode() == fmi2OK
        assert inst.fmi2ExitInitializationMode() == fmi2Error
        inst.log.clear()
        return inst
    assert inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0) == fmi2OK
    assert inst.fmi2EnterInitializationMode() == fmi2OK
    if state == "initializationMode":
        return inst
    assert inst.fmi2ExitInitializationMode() == fmi2OK
    if state == "stepComplete":
        return inst
    assert inst.fmi2Terminate() == fmi2OK
    assert state == "terminated"
    return inst


def _real_status(inst):
    v = ctypes.c_double()
    return inst.fmi2GetRealStatus(fmi2LastSuccessfulTime, ctypes.byref(v))


def _bool_status(inst):
    v = ctypes.c_int()
    return inst.fmi2GetBooleanStatus(fmi2Terminated, ctypes.byref(v))


def _get_state(inst):
    s = ctypes.c_void_p()
    st = inst.fmi2GetFMUstate(ctypes.byref(s))
    if s.value:
        inst.fmi2FreeFMUstate(ctypes.byref(s))
    return st


ALL = {"instantiated", "initializationMode", "stepComplete", "terminated", "error"}
CALLS = {
    # call name: (function, states in which it is allowed)
    "fmi2SetupExperiment": (lambda i: i.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0), {"instantiated"}),
    "fmi2EnterInitializationMode": (lambda i: i.fmi2EnterInitializationMode(), {"instantiated"}),
    "fmi2ExitInitializationMode": (lambda i: i.fmi2ExitInitializationMode(), {"initializationMode"}),
    "fmi2DoStep": (lambda i: i.fmi2DoStep(0.0, 1e-3, 1), {"stepComplete"}),
    "fmi2Terminate": (lambda i: i.fmi2Terminate(), {"stepComplete"}),
    "fmi2GetReal": (lambda i: i.get_real(["theta_ankle_ref"])[0],
                    {"initializationMode", "stepComplete", "terminated", "error"}),
    "fmi2GetInteger": (lambda i: i.get_integer(["phase"])[0],
                       {"initializationMode", "stepComplete", "terminated", "error"}),
    "fmi2SetReal": (lambda i: i.set_real({"theta_ankle": 0.01}),
                    {"instantiated", "initializationMode", "stepComplete"}),
    "fmi2GetFMUstate": (_get_state, {"instantiated", "initializationMode", "stepComplete", "terminated"}),
    "fmi2GetRealStatus": (_real_status, {"stepComplete", "terminated"}),
    "fmi2GetBooleanStatus": (_bool_status, {"stepComplete", "terminated"}),
    "fmi2CancelStep": (lambda i: i.fmi2CancelStep(), set()),
    "fmi2Reset": (lambda i: i.fmi2Reset(), ALL),
    "fmi2SetDebugLogging": (lambda i: i.fmi2SetDebugLogging(1, 0, None), ALL),
}


@pytest.mark.parametrize("state", sorted(ALL))
@pytest.mark.parametrize("call", sorted(CALLS))
def test_state_machine(raw_controller, state, call):
    inst = _to_state(raw_controller, state)
    fn, allowed = CALLS[call]
    st = fn(inst)
    if state in allowed:
        assert st in (fmi2OK, fmi2Warning), (call, state, inst.log)
    else:
        assert st == fmi2Error, (call, state)
        assert any(call in m and "state" in m for m in inst.errors()), inst.log
    inst.free()


# The rest of the FMI 2.0 co-simulation API (FMI 2.0.4 section 4.2.4, state table): the FMU-state
# functions, the typed get/set functions on variables of each kind, the status functions. Each
# entry: (function, states in which the call is legal, statuses expected there). In every other
# state the call must return fmi2Error with "<function> must not be called in state <state>" and
# leave the instance's state unchanged. The variable rules (causality/variability) are part of the
# table: a fixed parameter is settable only before fmi2ExitInitializationMode, a tunable one also
# in stepComplete, an input in all three set states, an output never.
fmi2PendingStatus = 1
_BLOB: dict[str, bytes] = {}   # GUID -> blob


def _blob(inst):
    """A serialized state of a running instance of the same FMU (made once per FMU)."""
    if inst.md.guid not in _BLOB:
        donor = RawInstanceOf(inst)
        assert donor.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0) == fmi2OK
        assert donor.fmi2EnterInitializationMode() == fmi2OK
        assert donor.fmi2ExitInitializationMode() == fmi2OK
        assert donor.fmi2DoStep(0.0, 1e-3, 1) == fmi2OK
        _BLOB[inst.md.guid] = _snapshot_bytes(donor)
        donor.free()
    return _BLOB[inst.md.guid]


def RawInstanceOf(inst):
    from conftest import RawInstance
    return RawInstance(inst.lib, inst.md, name="donor")


def _with_state_object(inst, use):
    """DeSerialize the donor blob into an FMUstate of `inst` (legal in every state of ALL), call
    use(state), free the state."""
    data = _blob(inst)
    s = ctypes.c_void_p()
    assert inst.fmi2DeSerializeFMUstate(data, len(data), ctypes.byref(s)) == fmi2OK, inst.log
    st = use(s)
    assert inst.fmi2FreeFMUstate(ctypes.byref(s)) == fmi2OK
    return st


def _deserialize(inst):
    data = _blob(inst)
    s = ctypes.c_void_p()
    st = inst.fmi2DeSerializeFMUstate(data, len(data), ctypes.byref(s))
    if s.value:
        inst.fmi2FreeFMUstate(ctypes.byref(s))
    return st


def _serialize(inst):
    def use(s):
        n = ctypes.c_size_t()
        assert inst.fmi2SerializedFMUstateSize(s, ctypes.byref(n)) == fmi2OK
        buf = ctypes.create_string_buffer(n.value)
        return inst.fmi2SerializeFMUstate(s, buf, n.value)
    return _with_state_object(inst, use)


def _status(fn_name, kind, ctype):
    def call(inst):
        v = ctype()
        return getattr(inst, fn_name)(kind, ctypes.byref(v))
    return call


_LIVE = {"instantiated", "initializationMode", "stepComplete", "terminated", "error"}
_STATE_FNS = {"instantiated", "initializationMode", "stepComplete", "terminated"}
CALLS_MORE = {
    "fmi2SetReal/input": (lambda i: i.set_real({"zmp_x": 0.001}),
                          {"instantiated", "initializationMode", "stepComplete"}, {fmi2OK}),
    "fmi2SetReal/tunable": (lambda i: i.set_real({"Ka": 41.0}),
                            {"instantiated", "initializationMode", "stepComplete"}, {fmi2OK}),
    "fmi2SetReal/fixed": (lambda i: i.set_real({"m1": 1.8}), {"instantiated", "initializationMode"}, {fmi2OK}),
    "fmi2SetReal/output": (lambda i: i.set_real({"com_x": 0.0}), set(), {fmi2OK}),
    "fmi2SetInteger/fixed": (lambda i: i.set_integer({"hip_strategy_enabled": 0}),
                             {"instantiated", "initializationMode"}, {fmi2OK}),
    "fmi2SetInteger/output": (lambda i: i.set_integer({"fault": 0}), set(), {fmi2OK}),
    "fmi2GetInteger/param": (lambda i: i.get_integer(["feet_offset_mode"])[0],
                             {"initializationMode", "stepComplete", "terminated", "error"}, {fmi2OK}),
    "fmi2GetReal/param": (lambda i: i.get_real(["m1", "Ka", "zmp_x"])[0],
                          {"initializationMode", "stepComplete", "terminated", "error"}, {fmi2OK}),
    "fmi2GetFMUstate": (_get_state, _STATE_FNS, {fmi2OK}),
    "fmi2SetFMUstate": (lambda i: _with_state_object(i, lambda s: i.fmi2SetFMUstate(s)), _LIVE, {fmi2OK}),
    "fmi2DeSerializeFMUstate": (_deserialize, _LIVE, {fmi2OK}),
    "fmi2SerializeFMUstate": (_serialize, _LIVE, {fmi2OK}),
    "fmi2GetStatus": (_status("fmi2GetStatus", 0, ctypes.c_int), {"stepComplete", "terminated"}, {fmi2Discard}),
    "fmi2GetStringStatus": (_status("fmi2GetStringStatus", fmi2PendingStatus, ctypes.c_char_p),
                            {"stepComplete", "terminated"}, {fmi2Discard}),
    "fmi2GetRealStatus": (_real_status, {"stepComplete", "terminated"}, {fmi2OK}),
    "fmi2GetBooleanStatus": (_bool_status, {"stepComplete", "terminated"}, {fmi2OK}),
    # no Integer status exists in FMI 2.0 CS: legal call, but always an (explained) error
    "fmi2GetIntegerStatus": (_status("fmi2GetIntegerStatus", 0, ctypes.c_int),
                             {"stepComplete", "terminated"}, {fmi2Error}),
}


def _state_of(inst, state):
    """Probe that `inst` is still in `state` (the states of ALL are distinguishable by calls that
    do not change the state)."""
    inst.log.clear()
    get_ok = inst.get_real(["com_z"])[0] == fmi2OK
    real_status_ok = _real_status(inst) == fmi2OK
    fixed_set_ok = inst.set_real({"m1": 1.79}) == fmi2OK  # the default value: no change
    got = {(False, False, True): "instantiated", (True, False, True): "initializationMode",
           (True, True, False): "stepComplete/terminated", (True, False, False): "error"}
    res = got.get((get_ok, real_status_ok, fixed_set_ok), "?")
    if res == "stepComplete/terminated":
        res = "terminated" if inst.fmi2DoStep(inst_time(inst), 1e-3, 1) == fmi2Error and any(
            "state terminated" in m for m in inst.errors()) else "stepComplete"
    return res


def inst_time(inst):
    v = ctypes.c_double()
    inst.fmi2GetRealStatus(fmi2LastSuccessfulTime, ctypes.byref(v))
    return v.value


@pytest.mark.parametrize("state", sorted(ALL))
@pytest.mark.parametrize("call", sorted(CALLS_MORE))
def test_state_machine_all_functions(raw_controller, state, call):
    inst = _to_state(raw_controller, state)
    fn, allowed, ok = CALLS_MORE[call]
    fname = call.split("/")[0]
    st = fn(inst)
    if state in allowed:
        assert st in ok, (call, state, st, inst.log)
        assert not any("must not be called" in m for m in inst.errors()), inst.log
    else:
        assert st == fmi2Error, (call, state, st)
        errs = inst.errors()
        assert any((fname in m and f"in state {state}" in m) or "cannot be set" in m for m in errs), errs
    if call != "fmi2SetFMUstate":  # restoring a state legitimately moves the instance to stepComplete
        assert _state_of(inst, state) == state, (call, state, inst.log)
    inst.free()


def test_unsupported_functions_are_explained(raw_controller):
    inst = _running(raw_controller)
    lib = raw_controller.lib
    vr = (ctypes.c_uint * 1)(inst.vr("theta_ankle_ref"))
    ivr = (ctypes.c_uint * 1)(inst.vr("zmp_x"))
    order = (ctypes.c_int * 1)(1)
    val = (ctypes.c_double * 1)(0.0)
    for fn, args in (("fmi2GetDirectionalDerivative", (vr, 1, ivr, 1, val, val)),
                     ("fmi2SetRealInputDerivatives", (ivr, 1, order, val)),
                     ("fmi2GetRealOutputDerivatives", (vr, 1, order, val))):
        inst.log.clear()
        assert getattr(lib, fn)(ctypes.c_void_p(inst.c), *args) == fmi2Error, fn
        assert any("not supported" in m for m in inst.errors()), (fn, inst.log)
    assert inst.fmi2DoStep(0.0, 1e-3, 1) == fmi2OK  # the instance is still usable
    inst.free()


def test_error_state_recovers_by_reset(raw_controller):
    inst = _to_state(raw_controller, "error")
    assert inst.fmi2DoStep(0.0, 1e-3, 1) == fmi2Error
    assert inst.fmi2Reset() == fmi2OK
    assert inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0) == fmi2OK
    assert inst.fmi2EnterInitializationMode() == fmi2OK
    assert inst.fmi2ExitInitializationMode() == fmi2OK
    assert inst.fmi2DoStep(0.0, 1e-3, 1) == fmi2OK
    inst.free()


def _running(raw, **kw):
    inst = raw.instance(**kw)
    assert inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0) == fmi2OK
    assert inst.fmi2EnterInitializationMode() == fmi2OK
    assert inst.fmi2ExitInitializationMode() == fmi2OK
    return inst


# ---------------------------------------------------------------------------------------------
# Get/set rules and argument checks.

def test_unknown_value_reference_and_type_mismatch(raw_controller):
    inst = _running(raw_controller)
    vr = (ctypes.c_uint * 2)(inst.vr("theta_ankle_ref"), 999999)
    out = (ctypes.c_double * 2)()
    assert inst.fmi2GetReal(vr, 2, out) == fmi2Error
    assert any("unknown value reference 999999" in m for m in inst.errors())
    ivr = (ctypes.c_uint * 1)(inst.vr("theta_ankle_ref"))
    iout = (ctypes.c_int * 1)()
    assert inst.fmi2GetInteger(ivr, 1, iout) == fmi2Error
    assert any("not Integer" in m for m in inst.errors())
    assert inst.fmi2SetReal(vr, 2, out) == fmi2Error  # unknown vr in a set: nothing is set
    assert inst.fmi2GetReal(vr, 10**9, out) == fmi2Error  # absurd array length: rejected up front
    assert any("nvr" in m for m in inst.errors())
    assert inst.fmi2GetReal(vr, 0, None) == fmi2OK  # nvr = 0 with NULL arrays is fine
    # ... also right after a set of some values: nothing of that call is set again (found by the
    # fuzzer when the glue began to reuse its index buffer between calls)
    inp = (ctypes.c_uint * 1)(inst.vr("zmp_x"))
    one = (ctypes.c_double * 1)(0.01)
    assert inst.fmi2SetReal(inp, 1, one) == fmi2OK
    assert inst.fmi2SetReal(inp, 0, None) == fmi2OK
    assert inst.fmi2SetInteger(inp, 0, None) == fmi2OK and inst.fmi2SetBoolean(inp, 0, None) == fmi2OK
    assert inst.fmi2GetReal(vr, 1, None) == fmi2Error  # NULL value array
    assert inst.fmi2GetReal(None, 1, out) == fmi2Error  # NULL vr array
    assert inst.fmi2DoStep(0.0, 1e-3, 1) == fmi2OK  # the instance is still usable
    inst.free()


def test_causality_and_variability_rules(raw_controller):
    inst = raw_controller.instance()
    # instantiated: parameters and inputs can be set, outputs cannot
    assert inst.set_real({"Ka": 41.0, "theta_ankle": 0.0}) == fmi2OK
    assert inst.set_real({"theta_ankle_ref": 1.0}) == fmi2Error
    assert any("theta_ankle_ref" in m and "cannot be set" in m for m in inst.errors())
    assert inst.set_integer({"phase": 2}) == fmi2Error
    inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0)
    inst.fmi2EnterInitializationMode()
    assert inst.set_real({"m1": 1.8}) == fmi2OK  # fixed parameter in initialization mode
    assert inst.fmi2ExitInitializationMode() == fmi2OK
    inst.log.clear()
    assert inst.set_real({"m1": 1.7}) == fmi2Error  # fixed parameter after initialization
    assert any("m1" in m for m in inst.errors())
    assert inst.set_real({"sample_period": 0.002}) == fmi2Error
    assert inst.set_real({"Ka": 45.0}) == fmi2OK  # tunable parameter after initialization
    assert inst.get_real(["Ka"]) == (fmi2OK, [45.0])
    assert inst.set_real({"Ka": -1.0}) == fmi2Error  # out of bounds: rejected, value kept
    assert any("Ka" in m and "-1" in m for m in inst.errors())
    assert inst.get_real(["Ka"]) == (fmi2OK, [45.0])
    assert inst.set_real({"Ka": float("nan")}) == fmi2Error
    assert inst.get_real(["m1"]) == (fmi2OK, [1.8])
    assert inst.fmi2DoStep(0.0, 1e-3, 1) == fmi2OK
    inst.free()


def test_parameter_bounds_checked_at_set(raw_controller):
    inst = raw_controller.instance()
    assert inst.set_real({"m1": -1.0}) == fmi2Error
    assert any('"m1"' in m and "-1" in m for m in inst.errors())
    assert inst.set_integer({"feet_offset_mode": 7}) == fmi2Error
    inst.free()


def test_instantiate_rejects_bad_arguments(raw_controller):
    bad_guid = raw_controller.instance(guid="{not-the-guid}")
    assert not bad_guid.c
    assert any("GUID" in m for m in bad_guid.errors())
    me = raw_controller.instance(fmu_type=0)  # fmi2ModelExchange
    assert not me.c
    assert any("CoSimulation" in m for m in me.errors())
    noname = raw_controller.instance(name=None)
    assert not noname.c
    raw_controller.lib.fmi2FreeInstance(None)  # must not crash
    assert raw_controller.lib.fmi2GetVersion() == b"2.0"
    assert raw_controller.lib.fmi2GetTypesPlatform() == b"default"


def test_do_step_argument_checks(raw_controller):
    inst = _running(raw_controller)
    assert inst.fmi2DoStep(0.0, 0.0, 1) == fmi2Error
    assert inst.fmi2DoStep(0.0, -1e-3, 1) == fmi2Error
    assert inst.fmi2DoStep(0.0, float("nan"), 1) == fmi2Error
    assert inst.fmi2DoStep(0.5, 1e-3, 1) == fmi2Error  # does not match the FMU time
    assert any("does not match" in m for m in inst.errors())
    assert inst.fmi2DoStep(0.0, 1e-3, 1) == fmi2OK
    v = ctypes.c_double()
    assert inst.fmi2GetRealStatus(fmi2LastSuccessfulTime, ctypes.byref(v)) == fmi2OK
    assert v.value == 1e-3
    b = ctypes.c_int(7)
    assert inst.fmi2GetBooleanStatus(fmi2Terminated, ctypes.byref(b)) == fmi2OK
    assert b.value == 0
    inst.free()


def test_stop_time_is_enforced(raw_controller):
    inst = raw_controller.instance()
    inst.fmi2SetupExperiment(0, 0.0, 0.0, 1, 0.002)
    inst.fmi2EnterInitializationMode()
    inst.fmi2ExitInitializationMode()
    assert inst.fmi2DoStep(0.0, 0.002, 1) == fmi2OK
    assert inst.fmi2DoStep(0.002, 0.001, 1) == fmi2Error
    inst.free()


# ---------------------------------------------------------------------------------------------
# Logging

def test_logging_categories(raw_controller):
    """loggingOn=true enables every category but logCalls; logCalls is switched on and off by name;
    an unknown name is an error; with loggingOn=false only errors are logged."""
    inst = raw_controller.instance(logging_on=True)
    inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0)
    assert not any(c == "logCalls" for _, c, _ in inst.log)
    cats = (ctypes.c_char_p * 1)(b"logCalls")
    assert inst.fmi2SetDebugLogging(1, 1, cats) == fmi2OK
    inst.fmi2EnterInitializationMode()
    assert any(c == "logCalls" and "fmi2EnterInitializationMode" in m for _, c, m in inst.log)
    inst.log.clear()
    assert inst.fmi2SetDebugLogging(0, 1, cats) == fmi2OK
    inst.fmi2ExitInitializationMode()
    assert not any(c == "logCalls" for _, c, _ in inst.log)
    bad = (ctypes.c_char_p * 1)(b"noSuchCategory")
    assert inst.fmi2SetDebugLogging(1, 1, bad) == fmi2Error
    assert any("noSuchCategory" in m for m in inst.errors())
    inst.free()

    quiet = raw_controller.instance(logging_on=False)
    quiet.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0)
    assert quiet.log == []
    assert quiet.fmi2DoStep(0.0, 1e-3, 1) == fmi2Error  # errors are still explained
    assert quiet.errors()
    assert quiet.fmi2SetDebugLogging(0, 0, None) == fmi2OK  # everything off, errors too
    quiet.log.clear()
    assert quiet.fmi2DoStep(0.0, 1e-3, 1) == fmi2Error
    assert quiet.log == []
    quiet.free()


# ---------------------------------------------------------------------------------------------
# FMU state and serialization

def _step(inst, t, h=1e-3):
    assert inst.fmi2DoStep(t, h, 0) in (fmi2OK, fmi2Warning)


def _push(inst, zmp):
    """The sensors of a push that moves the ZMP to `zmp` [m]: forward, and for the 3D controller
    sideways too (ZMP y, the soles' loads, the legs' roll), so that its frontal state moves."""
    inst.set_real({"zmp_x": zmp, "theta_ankle": zmp * 0.3})
    if "zmp_y" in inst.md.vars:
        zy = 0.8 * zmp
        inst.set_real({"zmp_y": zy, "fz_left": 35.0 + 400.0 * zy, "fz_right": 35.0 - 400.0 * zy,
                       "q_left_ankle_roll": zy, "q_right_ankle_roll": zy, "q_left_hip_roll": -zy,
                       "q_right_hip_roll": -zy})


def _observe(inst):
    """Every output of the controller (the 3D one's frontal ones too) after a step."""
    frontal = [n for n in FRONTAL_OUTPUTS if n in inst.md.vars]
    ints = ["phase", "fault"] + (["phase_y", "fault_y"] if frontal else [])
    return inst.get_real(CONTROLLER_OUTPUTS[:4] + CONTROLLER_OUTPUTS[5:10] + frontal)[1] + inst.get_integer(ints)[1]


def _drive(inst, t0, n, push=True):
    """n steps of 1 ms with a ramping ZMP; returns the outputs after each step."""
    out = []
    for k in range(n):
        t = t0 + k * 1e-3
        _push(inst, 0.05 * min(1.0, t / 0.5) if push else 0.0)
        _step(inst, t)
        out.append(_observe(inst))
    return out


def _snapshot_bytes(inst):
    s = ctypes.c_void_p()
    assert inst.fmi2GetFMUstate(ctypes.byref(s)) == fmi2OK
    n = ctypes.c_size_t()
    assert inst.fmi2SerializedFMUstateSize(s, ctypes.byref(n)) == fmi2OK
    buf = ctypes.create_string_buffer(n.value)
    assert inst.fmi2SerializeFMUstate(s, buf, n.value) == fmi2OK
    assert inst.fmi2FreeFMUstate(ctypes.byref(s)) == fmi2OK
    assert s.value is None
    return buf.raw


def _restore_bytes(inst, data):
    s = ctypes.c_void_p()
    st = inst.fmi2DeSerializeFMUstate(data, len(data), ctypes.byref(s))
    if st != fmi2OK:
        return st
    st = inst.fmi2SetFMUstate(s)
    inst.fmi2FreeFMUstate(ctypes.byref(s))
    return st


def test_get_set_state_reproduces_trajectory(raw_controller):
    inst = _running(raw_controller)
    _drive(inst, 0.0, 300)
    s = ctypes.c_void_p()
    assert inst.fmi2GetFMUstate(ctypes.byref(s)) == fmi2OK
    first = _drive(inst, 0.3, 700)
    assert inst.fmi2SetFMUstate(s) == fmi2OK
    again = _drive(inst, 0.3, 700)
    assert first == again
    assert inst.fmi2GetFMUstate(ctypes.byref(s)) == fmi2OK  # reuse of an existing state object
    assert inst.fmi2FreeFMUstate(ctypes.byref(s)) == fmi2OK
    inst.free()


def test_serialized_state_into_fresh_instance(raw_controller):
    a = _running(raw_controller)
    _drive(a, 0.0, 400)
    blob = _snapshot_bytes(a)
    ref = _drive(a, 0.4, 600)
    b = raw_controller.instance(name="fresh")  # only instantiated: the state carries the rest
    assert _restore_bytes(b, blob) == fmi2OK, b.log
    assert _drive(b, 0.4, 600) == ref
    a.free()
    b.free()


def test_error_state_recovers_by_restoring_a_state(raw_controller):
    good = _running(raw_controller)
    _drive(good, 0.0, 200)
    blob = _snapshot_bytes(good)
    ref = _drive(good, 0.2, 100)
    broken = _to_state(raw_controller, "error")
    assert _restore_bytes(broken, blob) == fmi2OK, broken.log
    assert _drive(broken, 0.2, 100) == ref
    good.free()
    broken.free()


def test_corrupted_serialized_state_rejected(raw_controller):
    a = _running(raw_controller)
    _drive(a, 0.0, 100)
    blob = _snapshot_bytes(a)
    ref = _drive(a, 0.1, 50)
    b = _running(raw_controller, name="victim")
    _drive(b, 0.0, 100)
    cases = {
        "empty": b"",
        "one byte": blob[:1],
        "header only": blob[:24],
        "truncated by one": blob[:-1],
        "half": blob[: len(blob) // 2],
        "trailing garbage": blob + b"\0",
        "foreign": b"PK\x03\x04" + bytes(range(256)) * 4,
    }
    for pos in (0, 9, 20, len(blob) // 2, len(blob) - 12, len(blob) - 1):
        flipped = bytearray(blob)
        flipped[pos] ^= 0x5A
        cases[f"flipped byte {pos}"] = bytes(flipped)
    for name, data in cases.items():
        b.log.clear()
        assert _restore_bytes(b, data) == fmi2Error, name
        assert b.errors(), name
    # b was not disturbed by the rejected blobs; a valid blob still restores
    assert _restore_bytes(b, blob) == fmi2OK
    assert _drive(b, 0.1, 50) == ref
    a.free()
    b.free()


def _fnv1a64(data: bytes, basis: int | None = None) -> int:
    """FNV-1a 64 (offset basis 14695981039346656037, prime 1099511628211): the state checksum."""
    h = 14695981039346656037 if basis is None else basis
    for b in data:
        h = ((h ^ b) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    return h


def test_state_from_other_model_rejected(raw_controller):
    """A blob with the right layout but another GUID (= another variable table) is rejected."""
    a = _running(raw_controller)
    blob = bytearray(_snapshot_bytes(a))
    glen = int.from_bytes(blob[16:20], "little")
    assert glen > 0
    a_blob_guid_char = blob[21]
    blob[21] = ord("0") if blob[21] != ord("0") else ord("1")  # GUID text changed ...
    blob[-8:] = _fnv1a64(bytes(blob[:-8])).to_bytes(8, "little")  # ... with a valid checksum
    b = raw_controller.instance()
    assert _restore_bytes(b, bytes(blob)) == fmi2Error
    assert any("another model" in m for m in b.errors()), b.log
    # the same bytes with the original GUID are accepted (so the GUID check is what rejected it)
    blob[21] = a_blob_guid_char
    blob[-8:] = _fnv1a64(bytes(blob[:-8])).to_bytes(8, "little")
    assert _restore_bytes(b, bytes(blob)) == fmi2OK
    a.free()
    b.free()


def test_forged_state_with_valid_checksum_rejected(raw_controller):
    """The checksum only catches accidents. A blob whose controller struct holds parameters that
    ahc_params_validate rejects (here g = NaN or sample_period-like garbage), re-signed with a
    valid checksum, must be rejected by the model's own check, not restored."""
    import struct

    a = _running(raw_controller)
    _drive(a, 0.0, 50)
    blob = bytearray(_snapshot_bytes(a))
    g = struct.pack("<d", 9.81)
    pos = blob.rfind(g)  # the last copy is ahc_controller.p.g in the model bytes (the store's is earlier)
    assert pos > 0 and blob.find(g) < pos
    for forged_g in (float("nan"), 0.0, -9.81):
        forged = bytearray(blob)
        forged[pos:pos + 8] = struct.pack("<d", forged_g)
        forged[-8:] = _fnv1a64(bytes(forged[:-8])).to_bytes(8, "little")
        b = _running(raw_controller, name="victim")
        assert _restore_bytes(b, bytes(forged)) == fmi2Error, forged_g
        assert any("rejected" in m and "g = " in m for m in b.errors()), b.log
        assert b.fmi2DoStep(0.0, 1e-3, 1) == fmi2OK  # unchanged and usable
        b.free()
    a.free()


def test_two_instances_independent(raw_controller):
    solo_a = _running(raw_controller, name="soloA")
    ref_a = _drive(solo_a, 0.0, 500, push=True)
    solo_b = _running(raw_controller, name="soloB")
    ref_b = _drive(solo_b, 0.0, 500, push=False)
    a = _running(raw_controller, name="A")
    b = _running(raw_controller, name="B")
    got_a, got_b = [], []
    for k in range(500):  # interleaved
        got_a += _drive_one(a, k, True)
        got_b += _drive_one(b, k, False)
    assert got_a == ref_a and got_b == ref_b
    assert ref_a != ref_b
    for i in (solo_a, solo_b, a, b):
        i.free()


def _drive_one(inst, k, push):
    t = k * 1e-3
    _push(inst, 0.05 * min(1.0, t / 0.5) if push else 0.0)
    _step(inst, t)
    return [_observe(inst)]


def test_reset_gives_fresh_behaviour(raw_controller):
    inst = _running(raw_controller)
    first = _drive(inst, 0.0, 200)
    assert inst.fmi2Reset() == fmi2OK
    assert inst.get_real(["Ka"])[0] == fmi2Error  # instantiated: no get
    inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0)
    inst.fmi2EnterInitializationMode()
    inst.fmi2ExitInitializationMode()
    assert _drive(inst, 0.0, 200) == first
    inst.free()


# ---------------------------------------------------------------------------------------------
# modelDescription.xml and the packed FMU

def test_validate_fmu(controller_fmu):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(controller_fmu)) == []


def test_model_description_contents(controller_fmu):
    with zipfile.ZipFile(controller_fmu) as z:
        names = set(z.namelist())
        root = ET.fromstring(z.read("modelDescription.xml"))
    assert {"modelDescription.xml", f"binaries/linux64/{controller_fmu.stem}.so",
            "documentation/index.html"} <= names
    cs = root.find("CoSimulation").attrib
    for flag in ("canHandleVariableCommunicationStepSize", "canGetAndSetFMUstate", "canSerializeFMUstate"):
        assert cs[flag] == "true"
    assert cs["needsExecutionTool"] == "false"
    assert root.find("DefaultExperiment").attrib["stepSize"] == "0.001"
    units = {u.attrib["name"] for u in root.find("UnitDefinitions")}
    cats = [c.attrib["name"] for c in root.find("LogCategories")]
    assert {"logEvents", "logCalls", "logStatusError", "logStatusWarning"} <= set(cats)
    svs = root.find("ModelVariables").findall("ScalarVariable")
    outputs, calculated = [], []
    for i, sv in enumerate(svs, start=1):
        assert sv.attrib.get("description"), sv.attrib["name"]
        real = sv.find("Real")
        if real is not None:
            assert real.attrib.get("unit") in units, sv.attrib["name"]
        if sv.attrib["causality"] == "output":
            outputs.append(i)
        if sv.attrib["causality"] == "calculatedParameter":     # the erect posture
            calculated.append(i)
    ms = root.find("ModelStructure")
    assert [int(u.attrib["index"]) for u in ms.find("Outputs")] == outputs
    # sampled outputs without direct feed-through (test_outputs_have_no_direct_feedthrough)
    assert all(u.attrib.get("dependencies") == "" for u in ms.find("Outputs"))
    # outputs have no initial attribute = "calculated": all of them are initial unknowns, with the
    # dependencies left out (= on all knowns: the initial outputs follow the measured posture)
    assert all("initial" not in sv.attrib for sv in svs if sv.attrib["causality"] == "output")
    assert [int(u.attrib["index"]) for u in ms.find("InitialUnknowns")] == sorted(outputs + calculated)
    assert len({sv.attrib["valueReference"] for sv in svs}) == len(svs)


def test_outputs_have_no_direct_feedthrough(raw_controller):
    """What dependencies="" in <Outputs> promises: setting inputs between steps does not change
    any output before the next fmi2DoStep."""
    inst = _running(raw_controller)
    _drive(inst, 0.0, 20)
    before = _observe(inst)
    assert inst.set_real({"theta_ankle": 0.2, "theta_hip": -0.3, "zmp_x": 0.04, "fz": 50.0}) == fmi2OK
    _push(inst, 0.04)     # and the 3D controller's frontal inputs
    assert _observe(inst) == before
    _step(inst, 0.02)
    assert _observe(inst) != before
    inst.free()


def test_guid_is_deterministic(controller_fmu, native_tool, tmp_path):
    """The generator reproduces the shipped modelDescription.xml byte for byte (given the source
    FMU's file list and, as SOURCE_DATE_EPOCH, its generation date), and neither the list of
    source files nor the generation date enters the GUID (the binary computes its GUID from the
    variable table alone)."""
    import xml.etree.ElementTree as ET
    from datetime import datetime
    gen = native_tool(f"{controller_fmu.stem}_gen")
    with zipfile.ZipFile(controller_fmu) as z:
        shipped = z.read("modelDescription.xml")
    root = ET.fromstring(shipped)
    sources = [f.get("name") for f in root.findall("CoSimulation/SourceFiles/File")]
    assert sources, "the controller FMU lists no source files"
    shipped_epoch = int(datetime.fromisoformat(root.get("generationDateAndTime").replace("Z", "+00:00")).timestamp())
    for sub, args, epoch in (("with", sources, shipped_epoch), ("without", [], 0)):
        (tmp_path / sub / "documentation").mkdir(parents=True)
        subprocess.run([str(gen), str(tmp_path / sub), *args], check=True,
                       env={**os.environ, "SOURCE_DATE_EPOCH": str(epoch)})
    assert (tmp_path / "with" / "modelDescription.xml").read_bytes() == shipped
    without = ET.parse(tmp_path / "without" / "modelDescription.xml").getroot()
    assert without.get("generationDateAndTime") == "1970-01-01T00:00:00Z"
    assert without.get("guid") == root.get("guid")


@pytest.mark.parametrize("model", SHIPPED)
def test_model_description_metadata(model, fmu_path):
    """Every unit has its SI base unit (J = kg.m2/s2; a unit the generator does not know fails
    the build); angles, angular rates and accelerations offer degrees and show them by default;
    the license names its text in the FMU and a URL; the generation date is an ISO 8601 UTC time."""
    from datetime import datetime
    with zipfile.ZipFile(fmu_path(model)) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
        license_text = z.read("documentation/licenses/LICENSE.txt").decode()
    units = {u.get("name"): u for u in root.find("UnitDefinitions")}
    for name, u in units.items():
        assert u.find("BaseUnit") is not None, f"{model}: unit {name} has no BaseUnit"
    if "J" in units:
        assert units["J"].find("BaseUnit").attrib == {"kg": "1", "m": "2", "s": "-2"}
    assert units["rad"].find("DisplayUnit").attrib == {"name": "deg", "factor": "57.29577951308232"}
    for sv in root.iter("ScalarVariable"):
        real = sv.find("Real")
        if real is not None and real.get("unit") in ("rad", "rad/s", "rad/s2"):
            assert real.get("displayUnit") == units[real.get("unit")].find("DisplayUnit").get("name"), sv.get("name")
    assert "https://spdx.org/licenses/BSD-2-Clause.html" in root.get("license")
    assert "documentation/licenses/LICENSE.txt" in root.get("license") and "BSD 2-Clause" in license_text
    assert datetime.strptime(root.get("generationDateAndTime"), "%Y-%m-%dT%H:%M:%SZ")
    # numbers as the shortest text that reads back exactly (no 70.23960000000001 for a computed weight
    # whose shortest form is shorter; an honest 17-digit value stays)
    for el in root.iter():
        for key in ("start", "min", "max", "factor", "nominal", "tolerance", "stepSize", "stopTime"):
            text = el.get(key)
            if text is not None and el.tag in ("Real", "DisplayUnit", "DefaultExperiment"):
                assert len(text) <= len(repr(float(text))), f"{model}: {el.tag} {key}={text}"


def test_phase_is_an_enumeration(controller_fmu, controller_unzipped):
    """The controller's phase is an FMI Enumeration whose items are the C library's phases, read
    with fmi2GetInteger (FMPy's reader resolves the declared type)."""
    from fmpy import read_model_description
    md = read_model_description(str(controller_fmu))
    phase = next(v for v in md.modelVariables if v.name == "phase")
    assert phase.type == "Enumeration" and phase.declaredType.name == "Phase"
    assert [(i.name, int(i.value)) for i in phase.declaredType.items] == [
        ("ankle", 0), ("ankle_to_hip", 1), ("hip", 2), ("hip_to_ankle", 3)]
    header = (REPO_ROOT / "controller_c" / "include" / "ahc" / "controller.h").read_text()
    for name, value in (("ANKLE", 0), ("ANKLE_TO_HIP", 1), ("HIP", 2), ("HIP_TO_ANKLE", 3)):
        assert f"AHC_PHASE_{name} = {value}" in header


def test_generator_help_and_bad_arguments(native_tool, tmp_path):
    """`<Model>_gen --help` prints its usage (exit 0); an unknown option or a missing output
    folder is refused with a message that names it (exit 2 / 1), not 'cannot write'."""
    gen = str(native_tool("AnkleHipController_gen"))
    r = subprocess.run([gen, "--help"], capture_output=True, text=True)
    assert r.returncode == 0 and "usage:" in r.stdout and "--markdown" in r.stdout
    r = subprocess.run([gen, "--bogus"], capture_output=True, text=True)
    assert r.returncode == 2 and "unknown option --bogus" in r.stderr
    r = subprocess.run([gen, str(tmp_path / "missing")], capture_output=True, text=True)
    assert r.returncode == 1 and "does not exist" in r.stderr and "missing" in r.stderr


def test_generator_markdown_of_one_causality(native_tool):
    """`<Model>_gen --markdown --causality C` prints the rows of the variables of causality C only,
    in table order, with the full table's header (docs/plant3d.md's table of the 3D plant's
    inputs); a causality no variable has, or a stray argument, is refused (exit 2)."""
    gen = str(native_tool("AnkleHipController_gen"))
    full = subprocess.run([gen, "--markdown"], capture_output=True, text=True, check=True).stdout.splitlines()
    inputs = subprocess.run([gen, "--markdown", "--causality", "input"], capture_output=True, text=True,
                            check=True).stdout.splitlines()
    assert inputs[:2] == full[:2]
    assert inputs[2:] == [row for row in full[2:] if row.split(" | ")[3] == "input"]
    assert [row.split("`")[1] for row in inputs[2:]] == ["theta_ankle", "theta_hip", "zmp_x", "fz"]
    r = subprocess.run([gen, "--markdown", "--causality", "inputs"], capture_output=True, text=True)
    assert r.returncode == 2 and "no variable of causality inputs" in r.stderr
    r = subprocess.run([gen, "--markdown", "extra"], capture_output=True, text=True)
    assert r.returncode == 2 and "usage:" in r.stderr


def test_packed_fmu_alone_in_empty_dir(controller_fmu, tmp_path):
    """Copy only the .fmu into an empty folder and simulate it from a clean process."""
    lone = tmp_path / "lone"
    lone.mkdir()
    fmu = lone / controller_fmu.name
    shutil.copy(controller_fmu, fmu)
    code = ("import fmpy, sys; r = fmpy.simulate_fmu(sys.argv[1], stop_time=0.05); "
            "assert len(r) == 51 and r['com_z'][-1] > 0.2; print('ok')")
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    p = subprocess.run([sys.executable, "-c", code, str(fmu)], cwd=lone, env=env, capture_output=True, text=True)
    assert p.returncode == 0 and "ok" in p.stdout, p.stderr


@pytest.mark.parametrize("model", SHIPPED)
def test_documentation_links_resolve_inside_the_fmu(model, fmu_path):
    """Every relative Markdown link and image of the pages packed in documentation/ points at a
    file in the FMU (the 3D plant's page carries its figures in documentation/images/); repository
    paths are named as text, not linked."""
    import posixpath
    import re
    with zipfile.ZipFile(fmu_path(model)) as z:
        names = set(z.namelist())
        pages = [n for n in names if n.startswith("documentation/") and n.endswith(".md")]
        assert pages or model == "GlueTestModel"
        for page in pages:
            for target in re.findall(r"\]\(([^)\s]+)\)", z.read(page).decode()):
                if re.match(r"[a-z]+://|#|mailto:", target):
                    continue
                path = posixpath.normpath(posixpath.join(posixpath.dirname(page), target.split("#")[0]))
                assert path in names, f"{model}: {page} links {target}, not in the FMU"
