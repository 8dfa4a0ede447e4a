"""The FMI 3.0 Scheduled Execution variants of the controllers (issue 28):
build/fmus/fmi3/<Name>_se.fmu for AnkleHipController and AnkleHipController3D
(anklehip.files.paths.SCHEDULED_EXECUTION), the FMI 3.0 library of the Co-Simulation twin with a
description generated from the same variable table (fmuglue::ModelInfo::clock): one model
partition on the input clock `tick` (intervalVariability = constant, intervalDecimal = the
controller's sample period), every input and output clocked by it (docs/fmu.md, "Scheduled
Execution").

What is established here:
* the description passes FMPy's validation, declares <ScheduledExecution> (and no <CoSimulation>)
  with the twin's model identifier and instantiation token, the clock with the sample period, and
  the twin's variables with the inputs and outputs clocked (inputs discrete, as clocked variables
  are) and the parameters unchanged;
* FMPy's FMU3ScheduledExecution (instantiate, enter/exit initialization, fmi3ActivateModelPartition
  N times with the sensor inputs of a recorded closed-loop run) gives every output bit for bit as
  the Co-Simulation twin stepped tick by tick (fmi3DoStep(t_k, 1 ms)) and as the recorded FMI 2.0
  loop: the sagittal controller through hip_saves_push (all four phases), the 3D one through
  side_push_frontal (its per-leg set points read as the array q_leg_ref too);
* the rules: an activation must be the clock's next tick (a skipped or repeated tick is an error
  naming the expected time), the clock reference must be the FMU's clock, fmi3DoStep is refused on a
  Scheduled Execution instance and fmi3ActivateModelPartition on a Co-Simulation one, a
  sample_period other than the clock's interval is refused at fmi3ExitInitializationMode naming
  both.
"""
from __future__ import annotations

import ctypes
import xml.etree.ElementTree as ET
import zipfile

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave, FMU3ScheduledExecution
from fmpy.validation import validate_fmu

from anklehip.files.paths import SCHEDULED_EXECUTION

# the closed loop each controller's activations replay (and its simulated seconds)
SCENARIOS = {"AnkleHipController": ("hip_saves_push", 12.0), "AnkleHipController3D": ("side_push_frontal", 4.0)}


def test_the_list():
    assert set(SCHEDULED_EXECUTION) == set(SCENARIOS)


@pytest.fixture(scope="module", params=SCHEDULED_EXECUTION)
def model(request):
    return request.param


@pytest.fixture(scope="module")
def se_fmu(fmu_dir, model):
    p = fmu_dir / "fmi3" / f"{model}_se.fmu"
    assert p.is_file(), f"{p} is missing: add_fmu(... SCHEDULED_EXECUTION) packs it (cmake/AddFmu.cmake)"
    return p


@pytest.fixture(scope="module")
def recorded(fmu_dir, model):
    """The FMI 2.0 closed loop of the model's scenario: its controller inputs, outputs and parameters."""
    from anklehip.files.paths import find_scenario
    from anklehip.files.scenario import load_scenario
    from anklehip.running.master import Models, simulate
    scenario, seconds = SCENARIOS[model]
    sc = load_scenario(find_scenario(scenario))
    run = simulate(sc, Models.for_scenario(sc, fmu_dir, fmi=2), progress=False, stop_time=seconds)
    assert run.complete
    return run


def test_description(se_fmu, fmu_dir, model):
    NAME = model
    assert validate_fmu(str(se_fmu)) == []
    se = read_model_description(str(se_fmu))
    cs = read_model_description(str(fmu_dir / "fmi3" / f"{NAME}.fmu"))
    assert se.fmiVersion == "3.0" and se.coSimulation is None and se.modelExchange is None
    assert se.scheduledExecution.modelIdentifier == cs.coSimulation.modelIdentifier == NAME
    assert se.instantiationToken == cs.instantiationToken
    clocks = [v for v in se.modelVariables if v.type == "Clock"]
    assert len(clocks) == 1
    clock = clocks[0]
    sample = next(v for v in cs.modelVariables if v.name == "sample_period")
    assert (clock.causality, clock.intervalVariability) == ("input", "constant")
    assert float(sample.start) == 1e-3 == _interval(se_fmu)
    sv = {v.name: v for v in se.modelVariables if v.type != "Clock"}
    for v in cs.modelVariables:
        w = sv[v.name]
        assert (w.valueReference, w.type, w.causality, w.unit, w.start) == \
            (v.valueReference, v.type, v.causality, v.unit, v.start), v.name
        if v.causality in ("input", "output"):
            assert w.variability == "discrete" and [c.valueReference for c in w.clocks] == [clock.valueReference]
        else:
            assert w.variability == v.variability and not w.clocks, v.name
    # clocked outputs are no initial unknowns; the calculated parameters still are
    assert {u.variable.causality for u in se.initialUnknowns} == {"calculatedParameter"}
    # the Co-Simulation twin's binary, x86_64-linux only (its importers are tested here on Linux)
    so = f"binaries/x86_64-linux/{NAME}.so"
    with zipfile.ZipFile(se_fmu) as z, zipfile.ZipFile(fmu_dir / "fmi3" / f"{NAME}.fmu") as t:
        assert {n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") >= 2} == \
            {"x86_64-linux"}
        assert z.read(so) == t.read(so)
        assert not any(n.startswith("sources/") for n in z.namelist())


def _interval(fmu) -> float:
    """The clock's intervalDecimal, from the XML: FMPy 0.3.32 reads a Clock's intervalVariability but
    not its intervalDecimal (ModelVariable.intervalDecimal stays None)."""
    with zipfile.ZipFile(fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    (clock,) = root.iter("Clock")
    return float(clock.get("intervalDecimal"))


def _set_parameters(f, md, params):
    by_name = {v.name: v for v in md.modelVariables}
    for name, value in params.items():
        v = by_name[name]
        if v.causality != "parameter":
            continue
        if v.type == "Float64":
            f.setFloat64([v.valueReference], [float(value)])
        elif v.type == "Int32":
            f.setInt32([v.valueReference], [int(value)])
        elif v.type == "Boolean":
            f.setBoolean([v.valueReference], [bool(value)])


def _messages():
    out = []
    return out, (lambda env, status, category, message: out.append(message.decode()))


def _se(se_fmu, md, name="se"):
    f = FMU3ScheduledExecution(guid=md.instantiationToken, unzipDirectory=extract(str(se_fmu)),
                               modelIdentifier=md.scheduledExecution.modelIdentifier, instanceName=name)
    messages, log = _messages()
    f.instantiate(logMessage=log)
    return f, messages


def test_activations_equal_the_cosimulation_twin_tick_by_tick(se_fmu, fmu_dir, recorded, model):
    NAME = model
    md = read_model_description(str(se_fmu))
    cs_path = fmu_dir / "fmi3" / f"{NAME}.fmu"
    md_cs = read_model_description(str(cs_path))
    clock = next(v for v in md.modelVariables if v.type == "Clock")
    T = _interval(se_fmu)
    data, params = recorded.data, recorded.controller_parameters
    assert recorded.step == T   # the loop steps the controller once per tick
    ins = [v for v in md.modelVariables if v.causality == "input" and v.type != "Clock" and not v.dimensions]
    outs = [v for v in md.modelVariables if v.causality == "output" and not v.dimensions]
    arrays = {v.name: v for v in md.modelVariables if v.dimensions and v.causality == "output"}
    reals = [v.valueReference for v in outs if v.type == "Float64"]
    enums = [v.valueReference for v in outs if v.type == "Enumeration"]
    ints = [v.valueReference for v in outs if v.type == "Int32"]
    in_vrs = [v.valueReference for v in ins]
    var = {v.name: v for v in md.modelVariables}
    column = {var: col for col, var in recorded.controller_columns.items()}
    real_outs = [v for v in outs if v.type == "Float64"]
    assert {v.name for v in real_outs} <= set(column)
    se, se_log = _se(se_fmu, md)
    cs = FMU3Slave(guid=md_cs.instantiationToken, unzipDirectory=extract(str(cs_path)), modelIdentifier=NAME,
                   instanceName="cs")
    cs.instantiate()
    try:
        for f, m in ((se, md), (cs, md_cs)):
            _set_parameters(f, m, params)
            f.enterInitializationMode(startTime=0.0)
            f.exitInitializationMode()
        rows = len(data) - 1
        phases = set()
        for k in range(rows):
            u = [float(data[v.name][k]) for v in ins]   # the plant's outputs at t_k (no sensor faults)
            t = k * T
            se.setFloat64(in_vrs, u)
            se.activateModelPartition(clock.valueReference, t)
            cs.setFloat64(in_vrs, u)
            cs.doStep(t, T)
            a = (se.getFloat64(reals), se.getInt64(enums), se.getInt32(ints))
            b = (cs.getFloat64(reals), cs.getInt64(enums), cs.getInt32(ints))
            assert a == b, (k, t)
            phases.add(a[1][0])
            for v, x in zip(real_outs, a[0]):   # and the FMI 2.0 loop's controller columns at row k
                assert x == data[column[v.name]][k], (k, v.name)
            if arrays:   # the 3D controller's per-leg set points, clocked like their scalars
                legs = [var[f"q_{s}_{j}_ref"].valueReference for s in SIDES for j in JOINTS]
                assert se.getFloat64([arrays["q_leg_ref"].valueReference], 12) == se.getFloat64(legs)
        if model == "AnkleHipController":
            assert phases == {0, 1, 2, 3}, phases   # the run goes through all four phases
        else:   # the side push moves the frontal plane's references
            assert max(abs(x) for x in data[column["phi_ref"]]) > 1e-3
        assert not [m for m in se_log if "rror" in m], se_log
    finally:
        for f in (se, cs):
            f.terminate()
            f.freeInstance()


SIDES = ("left", "right")
JOINTS = ("hip_yaw", "hip", "hip_roll", "knee", "ankle", "ankle_roll")


def test_scheduled_execution_rules(se_fmu, fmu_dir, model):
    NAME = model
    md = read_model_description(str(se_fmu))
    clock = next(v for v in md.modelVariables if v.type == "Clock")
    sample = next(v for v in md.modelVariables if v.name == "sample_period")
    # a sample period other than the clock's
    f, log = _se(se_fmu, md, "period")
    try:
        f.setFloat64([sample.valueReference], [2e-3])
        f.enterInitializationMode(startTime=0.0)
        with pytest.raises(Exception):
            f.exitInitializationMode()
        assert any("sample_period = 0.002" in m and "tick" in m and "0.001" in m for m in log), log
    finally:
        f.freeInstance()
    f, log = _se(se_fmu, md, "rules")
    try:
        f.enterInitializationMode(startTime=0.5)
        f.exitInitializationMode()
        with pytest.raises(Exception):
            f.activateModelPartition(clock.valueReference + 1, 0.5)   # no such clock
        assert any("is not an input clock" in m for m in log), log
        # the constant interval, as an importer may ask for it
        vrs, iv, q = (ctypes.c_uint32 * 1)(clock.valueReference), (ctypes.c_double * 1)(), (ctypes.c_int * 1)(-1)
        f.getIntervalDecimal(vrs, iv, q)
        assert (iv[0], q[0]) == (1e-3, 1)   # fmi3IntervalUnchanged
        f.activateModelPartition(clock.valueReference, 0.5)
        f.activateModelPartition(clock.valueReference, 0.5 + 1e-3)
        for t in (0.5 + 1e-3, 0.5 + 3e-3):   # a repeated and a skipped tick
            log.clear()
            with pytest.raises(Exception):
                f.activateModelPartition(clock.valueReference, t)
            assert any("is not the next tick of tick, 0.502" in m for m in log), log
        f.activateModelPartition(clock.valueReference, 0.5 + 2e-3)   # refused calls changed nothing
        log.clear()
        flags, last = (ctypes.c_bool * 3)(), ctypes.c_double()
        step = f.dll.fmi3DoStep   # FMU3ScheduledExecution has no doStep: the raw call
        step.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_bool] + [ctypes.c_void_p] * 4
        assert step(f.component, 0.503, 1e-3, False, ctypes.addressof(flags), ctypes.addressof(flags) + 1,
                    ctypes.addressof(flags) + 2, ctypes.addressof(last)) == 3   # fmi3Error
        assert any("instantiated for Scheduled Execution" in m for m in log), log
    finally:
        f.freeInstance()
    # the Co-Simulation twin refuses activations
    md_cs = read_model_description(str(fmu_dir / "fmi3" / f"{NAME}.fmu"))
    cs = FMU3Slave(guid=md_cs.instantiationToken, unzipDirectory=extract(str(fmu_dir / "fmi3" / f"{NAME}.fmu")),
                   modelIdentifier=NAME, instanceName="cs")
    log, cb = _messages()
    cs.instantiate(logMessage=cb)
    try:
        cs.enterInitializationMode(startTime=0.0)
        cs.exitInitializationMode()
        with pytest.raises(Exception):
            cs.fmi3ActivateModelPartition(cs.component, clock.valueReference, 0.0)
        assert any("instantiated for Co-Simulation" in m for m in log), log
    finally:
        cs.freeInstance()


def test_plants_provide_no_scheduled_execution(fmu_dir):
    """A model without a clock refuses fmi3InstantiateScheduledExecution, naming why."""
    p = fmu_dir / "fmi3" / "Hoap2Plant.fmu"
    md = read_model_description(str(p))
    f = FMU3ScheduledExecution(guid=md.instantiationToken, unzipDirectory=extract(str(p)),
                               modelIdentifier=md.coSimulation.modelIdentifier, instanceName="x")
    log, cb = _messages()
    with pytest.raises(Exception):
        f.instantiate(logMessage=cb)
    assert any("provides no Scheduled Execution" in m for m in log), log
    assert not (fmu_dir / "fmi3" / "Hoap2Plant_se.fmu").exists()
