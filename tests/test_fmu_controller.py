"""AnkleHipController.fmu against the C library (controller_c) itself: bit-for-bit outputs and
phase sequence on a push profile, the sample-grid rule for any communication step, parameter
validation at fmi2ExitInitializationMode, NaN/Inf containment, event logging, parameters generated
from ahc_param_table(). The C library's results come from the native driver ahc_csv_driver
(fmu/controller/ahc_csv_driver.c), which steps ahc_step directly on the same CSV."""
from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest

from conftest import (CONTROLLER_OUTPUTS, fmi2Error, fmi2OK, fmi2Warning, read_csv_exact, sensor_signals,
                      write_csv)


def _driver(native_tool, csv_in, csv_out, *params):
    subprocess.run([str(native_tool("ahc_csv_driver")), str(csv_in), str(csv_out), *params], check=True)
    return read_csv_exact(csv_out)


def _simulate(fmu, csv_in, step, stop, **kw):
    import fmpy
    from fmpy.util import read_csv

    return fmpy.simulate_fmu(str(fmu), input=read_csv(str(csv_in)), step_size=step, output_interval=step, stop_time=stop,
                             output=CONTROLLER_OUTPUTS, **kw)


def _assert_identical(sim, ref):
    """sim: FMPy result (row 0 = t0, then one row per communication point); ref: driver rows t1..tN."""
    assert len(sim) == len(ref) + 1
    assert np.array_equal(sim["time"][1:], ref["time"])
    for name in CONTROLLER_OUTPUTS:
        a = np.asarray(sim[name][1:], dtype=float)
        b = np.asarray(ref[name], dtype=float)
        bad = np.flatnonzero(a != b)
        assert bad.size == 0, f"{name} differs first at t={ref['time'][bad[0]]}: {a[bad[0]]!r} != {b[bad[0]]!r}"


def _phase_sequence(phase):
    seq = [int(phase[0])]
    for p in phase[1:]:
        if int(p) != seq[-1]:
            seq.append(int(p))
    return seq


@pytest.fixture(scope="module")
def push_case(tmp_path_factory):
    d = tmp_path_factory.mktemp("push")
    t = np.arange(3001) * 0.001  # the exact grid FMPy uses: start + n * step
    return write_csv(d / "AnkleHipController_in.csv", sensor_signals(t, peak=9.0)), d


def test_push_profile_bit_for_bit_with_c_library(controller_fmu, native_tool, push_case):
    csv_in, d = push_case
    sim = _simulate(controller_fmu, csv_in, 0.001, 3.0)
    ref = _driver(native_tool, csv_in, d / "ref.csv")
    _assert_identical(sim, ref)
    seq = _phase_sequence(sim["phase"])
    assert seq[:3] == [0, 1, 2], seq  # the push drives the controller through the transition
    assert np.all(np.isfinite(sim["theta_ankle_ref"]))


def test_paper_limit_and_ankle_only_bit_for_bit(controller_fmu, native_tool, push_case):
    csv_in, d = push_case
    params = {"zmp_limit_front": 0.045, "hip_strategy_enabled": 0}
    sim = _simulate(controller_fmu, csv_in, 0.001, 3.0, start_values=params)
    ref = _driver(native_tool, csv_in, d / "ref_ankle_only.csv", *(f"{k}={v}" for k, v in params.items()))
    _assert_identical(sim, ref)
    assert set(np.unique(sim["phase"])) == {0}  # ankle strategy only: the limit changes nothing


@pytest.mark.parametrize("step", [0.0025, 0.0004, 0.003])
def test_sample_grid_for_steps_not_multiple_of_period(controller_fmu, native_tool, tmp_path, step):
    """fmi2DoStep(t, h) runs exactly the ticks k*T in (t, t+h]; inputs are held over the step."""
    n = int(round(1.5 / step))
    t = np.arange(n + 1) * step
    csv_in = write_csv(tmp_path / "in.csv", sensor_signals(t, peak=9.0))
    sim = _simulate(controller_fmu, csv_in, step, t[-1])
    ref = _driver(native_tool, csv_in, tmp_path / "ref.csv")
    _assert_identical(sim, ref)


def test_ticks_counted_on_the_grid(raw_controller):
    """Sub-period steps: outputs change only when a tick time k*T is reached; a long step runs
    all the ticks it covers (robust to floating-point accumulation of t)."""
    inst = raw_controller.instance()
    inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0)
    inst.fmi2EnterInitializationMode()
    inst.fmi2ExitInitializationMode()
    inst.set_real({"zmp_x": 0.02})
    t, h, changed_at = 0.0, 0.0001, []
    last = inst.get_real(["theta_ankle_ref"])[1][0]
    for i in range(100):  # 10 ms in 0.1 ms steps (t accumulates rounding errors)
        assert inst.fmi2DoStep(t, h, 1) == fmi2OK
        t += h
        v = inst.get_real(["theta_ankle_ref"])[1][0]
        if v != last:
            changed_at.append(i)
        last = v
    assert changed_at == list(range(9, 100, 10))  # exactly at the ticks 1, 2, ... 10 ms

    one = raw_controller.instance()
    one.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0)
    one.fmi2EnterInitializationMode()
    one.fmi2ExitInitializationMode()
    one.set_real({"zmp_x": 0.02})
    assert one.fmi2DoStep(0.0, 0.01, 1) == fmi2OK  # one long step = 10 ticks
    assert one.get_real(["theta_ankle_ref"]) == inst.get_real(["theta_ankle_ref"])
    inst.free()
    one.free()


def test_state_restore_mid_run_bit_for_bit(controller_fmu, push_case):
    """FMPy-level: serialize at t = 1.0 s, restore into a fresh instance, same remaining trajectory."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.util import read_csv

    csv_in, _ = push_case
    sig = read_csv(str(csv_in))
    unzip = extract(str(controller_fmu))
    md = read_model_description(unzip)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    ins = ["theta_ankle", "theta_hip", "zmp_x", "fz"]
    outs_r = [vr[n] for n in CONTROLLER_OUTPUTS if n not in ("phase", "fault")]
    outs_i = [vr["phase"], vr["fault"]]

    def new(name):
        f = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=name)
        f.instantiate()
        return f

    def run(f, k0, k1):
        rows = []
        for k in range(k0, k1):
            f.setReal([vr[n] for n in ins], [float(sig[n][k]) for n in ins])
            f.doStep(currentCommunicationPoint=k * 0.001, communicationStepSize=0.001)
            rows.append(tuple(f.getReal(outs_r)) + tuple(f.getInteger(outs_i)))
        return rows

    # Snapshot 100 ticks before the ankle->hip transition so that the restored part contains it.
    probe = new("probe")
    probe.setupExperiment(startTime=0.0)
    probe.enterInitializationMode()
    probe.exitInitializationMode()
    k_trans = next(k for k, r in enumerate(run(probe, 0, len(sig))) if r[-2] == 1)
    probe.terminate()
    k0 = max(1, k_trans - 100)
    k1 = min(len(sig), k0 + 2000)

    a = new("a")
    a.setupExperiment(startTime=0.0)
    a.enterInitializationMode()
    a.exitInitializationMode()
    run(a, 0, k0)
    state = a.getFMUstate()
    blob = a.serializeFMUstate(state)
    rest = run(a, k0, k1)
    a.setFMUstate(state)
    assert run(a, k0, k1) == rest
    a.freeFMUstate(state)
    b = new("b")
    state_b = b.deSerializeFMUstate(blob)
    b.setFMUstate(state_b)
    b.freeFMUstate(state_b)
    assert run(b, k0, k1) == rest
    assert {r[-2] for r in rest} >= {0, 1, 2}  # the restored part contains the transition
    a.terminate(); a.freeInstance()
    b.terminate(); b.freeInstance()


def test_invalid_parameter_rejected_at_exit_initialization(raw_controller):
    inst = raw_controller.instance()
    assert inst.set_real({"zmp_limit_front": 0.07}) == fmi2OK  # within its bounds, beyond the toe
    inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0)
    inst.fmi2EnterInitializationMode()
    assert inst.fmi2ExitInitializationMode() == fmi2Error
    msgs = " ".join(inst.errors())
    assert "zmp_limit_front" in msgs and "0.07" in msgs, msgs
    inst.free()


def test_nonfinite_inputs_contained(raw_controller):
    inst = raw_controller.instance()
    inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0)
    inst.fmi2EnterInitializationMode()
    inst.fmi2ExitInitializationMode()
    t = 0.0
    for _ in range(50):
        assert inst.fmi2DoStep(t, 1e-3, 1) == fmi2OK
        t += 1e-3
    for bad in (float("nan"), float("inf"), -float("inf")):
        inst.log.clear()
        assert inst.set_real({"zmp_x": bad, "theta_ankle": bad}) == fmi2OK
        assert inst.fmi2DoStep(t, 1e-3, 1) == fmi2Warning
        t += 1e-3
        st, vals = inst.get_real(CONTROLLER_OUTPUTS[:4] + CONTROLLER_OUTPUTS[5:10])
        assert st == fmi2OK and all(math.isfinite(v) for v in vals), vals
        assert inst.get_integer(["fault"])[1][0] != 0
    inst.set_real({"zmp_x": 0.0, "theta_ankle": 0.0})
    for _ in range(20):
        assert inst.fmi2DoStep(t, 1e-3, 1) == fmi2OK
        t += 1e-3
    assert inst.get_integer(["fault"])[1][0] == 0  # recovered
    inst.free()


def test_nonfinite_input_logs_warning(raw_controller):
    inst = raw_controller.instance()
    inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0)
    inst.fmi2EnterInitializationMode()
    inst.fmi2ExitInitializationMode()
    inst.set_real({"fz": float("nan")})
    assert inst.fmi2DoStep(0.0, 1e-3, 1) == fmi2Warning
    warnings = [m for s, c, m in inst.log if s == fmi2Warning and c == "logStatusWarning"]
    assert warnings and "non-finite" in warnings[0]
    inst.free()


def test_phase_changes_logged_as_events(raw_controller):
    inst = raw_controller.instance(logging_on=True)   # logCalls stays off unless asked for
    inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0)
    inst.fmi2EnterInitializationMode()
    inst.fmi2ExitInitializationMode()
    sig = sensor_signals(np.arange(1500) * 0.001, peak=9.0)
    for k in range(1500):
        inst.set_real({n: float(sig[n][k]) for n in ("theta_ankle", "theta_hip", "zmp_x", "fz")})
        assert inst.fmi2DoStep(k * 0.001, 0.001, 1) == fmi2OK
    events = [m for s, c, m in inst.log if c == "logEvents"]
    assert any("phase 0" in m and "-> 1" in m for m in events), events
    assert not any(c == "logCalls" for _, c, _ in inst.log)
    inst.free()


def test_parameters_generated_from_c_table(controller_fmu):
    from fmpy import read_model_description

    md = read_model_description(str(controller_fmu))
    params = [v for v in md.modelVariables if v.causality == "parameter"]
    names = {v.name for v in params}
    assert {"m1", "l1", "lg1", "I1", "m2", "lg2", "I2", "Ka", "Ca", "Kh", "Ch", "Kpr", "Kp_theta",
            "zmp_limit_front", "T_ah", "sample_period", "hip_strategy_enabled"} <= names
    by = {v.name: v for v in params}
    assert float(by["Ka"].start) == 40.0 and by["Ka"].unit == "N.m/rad" and by["Ka"].variability == "tunable"
    assert float(by["sample_period"].start) == 0.001 and by["sample_period"].variability == "fixed"
    for v in params:
        assert v.description and v.min is not None and v.max is not None, v.name
        if v.type == "Real":
            assert v.unit is not None, v.name
    ins = [v.name for v in md.modelVariables if v.causality == "input"]
    outs = [v.name for v in md.modelVariables if v.causality == "output"]
    assert ins == ["theta_ankle", "theta_hip", "zmp_x", "fz"]
    assert outs == CONTROLLER_OUTPUTS
