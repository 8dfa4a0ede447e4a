"""FMI 3.0 Float64 arrays on the FMI 3.0 twins (issue 28): the signals of Hoap2Plant3D that are
naturally vectors (joint angles [side, joint], sole load cells [side, corner], sole loads, slip
speeds, the gyro, the per-leg set points) are also declared as arrays, generated from the same
variable table (fmuglue::ModelInfo::arrays: each array names its scalar elements once). The arrays
accompany the scalars: they are views of the same values (docs/fmu.md, "FMI 3.0 arrays").

What is established here:
* the description declares each array with its <Dimension>s, the elements' causality, variability,
  unit and (inputs) start values in row-major order, lists the output arrays in <Outputs> and
  <InitialUnknowns>, and passes FMPy's validation (read_model_description + validate_fmu);
* fmi3SetFloat64 on the input array and fmi3GetFloat64 on it round-trip, and set the element
  scalars (one set of values); the output arrays cannot be set;
* over a closed-loop run (side_push_frontal, the FMI 2.0 loop of our master), a Hoap2Plant3D FMI 3.0
  instance fed the loop's plant inputs *through the array input* reproduces the loop bit for bit,
  and every output array equals the FMI 2.0 loop's scalars bit for bit at every step;
* a wrong nValues is an error that names the array and its size; an array through another type's
  function, or through FMI 2.0, is refused naming it;
* FMPy's simulate_fmu with its default outputs records each array in its shape, equal to the scalars;
* AnkleHipController3D's twin has the arrays q (in) and q_leg_ref (out) under the plant's names.
"""
from __future__ import annotations

import ctypes

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

PLANT = "Hoap2Plant3D"
SIDES = ("left", "right")
JOINTS = ("hip_yaw", "hip", "hip_roll", "knee", "ankle", "ankle_roll")
CORNERS = ("front_left", "front_right", "rear_left", "rear_right")
# array -> (dimensions, the scalar elements in row-major order)
ARRAYS = {
    "q": ((2, 6), [f"q_{s}_{j}" for s in SIDES for j in JOINTS]),
    "f_cell": ((2, 4), [f"f_{s}_{c}" for s in SIDES for c in CORNERS]),
    "fz_feet": ((2,), ["fz_left", "fz_right"]),
    "slip_speed": ((2,), ["slip_speed_left", "slip_speed_right"]),
    "gyro": ((3,), ["gyro_x", "gyro_y", "gyro_z"]),
    "q_leg_ref": ((2, 6), [f"q_{s}_{j}_ref" for s in SIDES for j in JOINTS]),
}
OUTPUT_ARRAYS = [a for a in ARRAYS if a != "q_leg_ref"]


@pytest.fixture(scope="module")
def twin(fmu_dir):
    p = fmu_dir / "fmi3" / f"{PLANT}.fmu"
    assert p.is_file(), p
    return p


@pytest.fixture(scope="module")
def md(twin):
    return read_model_description(str(twin))


def _vars(md):
    return {v.name: v for v in md.modelVariables}


def test_arrays_are_declared_and_validate(twin, md):
    assert validate_fmu(str(twin)) == []
    v = _vars(md)
    for name, (dims, elements) in ARRAYS.items():
        a = v[name]
        assert a.type == "Float64" and [int(d.start) for d in a.dimensions] == list(dims), name
        assert a.valueReference not in {v[e].valueReference for e in elements}
        for e in elements:
            x = v[e]
            assert not x.dimensions and (x.causality, x.variability, x.unit) == (a.causality, a.variability, a.unit), e
        if a.causality == "input":
            assert [float(s) for s in str(a.start).split()] == [float(v[e].start) for e in elements]
    outs = {u.variable.name for u in md.outputs}
    inits = {u.variable.name: sorted(d.valueReference for d in u.dependencies) for u in md.initialUnknowns}
    for name in OUTPUT_ARRAYS:
        assert v[name].causality == "output" and name in outs, name
        # the array's initial dependencies are its elements' (the same parameters)
        assert inits[name] == inits[ARRAYS[name][1][0]], name
    assert v["q_leg_ref"].causality == "input" and "q_leg_ref" not in outs
    # the FMI 2.0 FMU has the scalars only
    md2 = read_model_description(str(twin.parent.parent / f"{PLANT}.fmu"))
    assert not set(ARRAYS) & {x.name for x in md2.modelVariables}


def _slave(twin, md, name="p"):
    f = FMU3Slave(guid=md.instantiationToken, unzipDirectory=extract(str(twin)),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    messages = []
    f.instantiate(logMessage=lambda env, status, category, message: messages.append(message.decode()))
    return f, messages


def test_array_set_get_round_trip(twin, md):
    v = _vars(md)
    f, _ = _slave(twin, md)
    try:
        ref = v["q_leg_ref"].valueReference
        values = [0.01 * (k + 1) * (-1) ** k for k in range(12)]
        f.setFloat64([ref], values)                  # Instantiated: inputs take start values
        f.enterInitializationMode(startTime=0.0, stopTime=1.0)
        assert f.getFloat64([ref], 12) == values
        # the elements are the same values, and setting an element shows in the array
        elems = [v[e].valueReference for e in ARRAYS["q_leg_ref"][1]]
        assert f.getFloat64(elems) == values
        f.setFloat64([elems[7]], [0.25])
        assert f.getFloat64([ref], 12)[7] == 0.25
        # arrays and scalars in one call: nValues counts each array's size
        got = f.getFloat64([elems[0], ref, elems[11]], 14)
        assert got == [values[0]] + values[:7] + [0.25] + values[8:] + [values[11]]
        f.exitInitializationMode()
        f.setFloat64([ref], values[::-1])            # Step Mode
        assert f.getFloat64([ref], 12) == values[::-1]
        for name in OUTPUT_ARRAYS:
            dims, elements = ARRAYS[name]
            n = int(np.prod(dims))
            assert f.getFloat64([v[name].valueReference], n) == f.getFloat64([v[e].valueReference for e in elements])
        f.terminate()
    finally:
        f.freeInstance()


def _call(f, fn, vr, n, nvalues, values=None):
    """fmi3Get/SetFloat64 with an explicit nValues (FMPy's getters derive it): the status."""
    vrs = (ctypes.c_uint32 * len(vr))(*vr)
    buf = (ctypes.c_double * max(nvalues, 1))(*(values or []))
    func = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p,
                            ctypes.c_size_t)((fn, f.dll))
    return func(f.component, vrs, len(vr), buf, nvalues)


def test_wrong_nvalues_and_wrong_access_name_the_array(twin, md):
    v = _vars(md)
    f, messages = _slave(twin, md)
    try:
        q, ref = v["q"].valueReference, v["q_leg_ref"].valueReference
        f.enterInitializationMode(startTime=0.0, stopTime=1.0)
        f.exitInitializationMode()
        for n in (1, 11, 13):
            messages.clear()
            assert _call(f, "fmi3GetFloat64", [q], 1, n) == 3     # fmi3Error
            assert any("nValues" in m and "q (2x6 = 12 values)" in m for m in messages), messages
        messages.clear()
        assert _call(f, "fmi3SetFloat64", [ref], 1, 6, [0.0] * 6) == 3
        assert any("q_leg_ref (2x6 = 12 values)" in m for m in messages), messages
        # an output array cannot be set; the input array's values stay
        before = f.getFloat64([ref], 12)
        messages.clear()
        assert _call(f, "fmi3SetFloat64", [q], 1, 12, [0.0] * 12) == 3
        assert any('"q" is an output array' in m for m in messages), messages
        assert f.getFloat64([ref], 12) == before
        # a value out of an element's range refuses the whole set (the elements name it)
        messages.clear()
        assert _call(f, "fmi3SetFloat64", [ref], 1, 12, [0.0] * 11 + [float("nan")]) in (0, 3)
        # the array through another type's function
        messages.clear()
        assert _call(f, "fmi3GetInt32", [q], 1, 12) == 3
        assert any('Float64 array "q"' in m for m in messages), messages
    finally:
        f.terminate()
        f.freeInstance()


def test_arrays_follow_the_fmi2_closed_loop_bit_for_bit(fmu_dir, twin, md):
    """The FMI 2.0 closed loop side_push_frontal (our master: AnkleHipController3D + Hoap2Plant3D)
    is replayed on a Hoap2Plant3D FMI 3.0 instance fed the loop's plant inputs, the per-leg set
    points through the array q_leg_ref: at every step each output array equals the FMI 2.0 loop's
    scalars bit for bit, and so the replay is the loop."""
    from anklehip.files.paths import find_scenario
    from anklehip.files.scenario import load_scenario
    from anklehip.running.fmu import FMUInfo, Slave
    from anklehip.running.master import Models, simulate
    sc = load_scenario(find_scenario("side_push_frontal"))
    run = simulate(sc, Models.for_scenario(sc, fmu_dir, fmi=2), progress=False, stop_time=2.0)
    assert run.complete
    data = run.data
    cols = set(data.dtype.names)
    v = _vars(md)
    info = FMUInfo.load(twin)
    assert not set(ARRAYS) & set(info.vars), "our master sees the scalars only"
    s = Slave(info)
    f = s.fmu
    try:
        params = {k: x for k, x in run.plant_parameters.items() if info.vars[k].causality == "parameter"}
        s.initialize(float(data["time"][0]), run.stop_time, params)
        leg_refs = ARRAYS["q_leg_ref"][1]
        assert set(leg_refs) <= cols, "the 3D controller feeds every per-leg set point"
        scalar_inputs = [x.name for x in info.by_causality("input") if x.name not in leg_refs and x.name in cols]
        assert {"theta_ankle_ref", "theta_hip_ref", "push_force", "push_force_y"} <= set(scalar_inputs)
        ref_vr, in_vrs = v["q_leg_ref"].valueReference, [v[n].valueReference for n in scalar_inputs]
        arrays = [(name, v[name].valueReference, ARRAYS[name][1]) for name in OUTPUT_ARRAYS]
        n_all = sum(len(e) for _, _, e in arrays)
        t0, h, rows = float(data["time"][0]), run.step, len(data)
        assert rows > 1900
        pushed = 0.0
        for k in range(rows):
            got = f.getFloat64([vr for _, vr, _ in arrays], n_all)
            want = [data[e][k] for _, _, elements in arrays for e in elements]
            assert got == want, (k, [(a, e) for (a, _, es) in arrays for e in es
                                      if got[[x for _, _, y in arrays for x in y].index(e)] != data[e][k]][:5])
            if k == rows - 1:
                break
            f.setFloat64([ref_vr], [float(data[n][k]) for n in leg_refs])
            f.setFloat64(in_vrs, [float(data[n][k]) for n in scalar_inputs])
            pushed = max(pushed, abs(float(data["push_force_y"][k])))
            assert s.do_step(s.c, t0 + k * h, h, False) == 0, k   # the master's t_k = t0 + k h
        assert pushed > 10.0 and np.max(np.abs(data["q_left_hip_roll"])) > 1e-3  # a push the legs answered
    finally:
        s.free()


def test_the_3d_controller_arrays_match_the_plants(fmu_dir, md):
    """AnkleHipController3D's twin declares its joint-angle inputs and per-leg set-point outputs as
    arrays of the same names, dimensions and element order as Hoap2Plant3D's: an importer that
    connects arrays connects q (plant -> controller) and q_leg_ref (controller -> plant) by name."""
    p = fmu_dir / "fmi3" / "AnkleHipController3D.fmu"
    assert validate_fmu(str(p)) == []
    c = _vars(read_model_description(str(p)))
    v = _vars(md)
    for name, causality in (("q", "input"), ("q_leg_ref", "output")):
        a = c[name]
        assert a.causality == causality and [d.start for d in a.dimensions] == [d.start for d in v[name].dimensions]
        assert a.unit == v[name].unit == "rad"
    x = FMU3Slave(guid=read_model_description(str(p)).instantiationToken,
                  unzipDirectory=extract(str(p)), modelIdentifier="AnkleHipController3D", instanceName="c")
    x.instantiate()
    try:
        angles = [0.001 * k for k in range(12)]
        x.setFloat64([c["q"].valueReference], angles)
        x.enterInitializationMode(startTime=0.0)
        assert x.getFloat64([c[e].valueReference for e in ARRAYS["q"][1]]) == angles
        x.exitInitializationMode()
        x.doStep(0.0, 1e-3)
        assert x.getFloat64([c["q_leg_ref"].valueReference], 12) == \
            x.getFloat64([c[e].valueReference for e in ARRAYS["q_leg_ref"][1]])
        x.terminate()
    finally:
        x.freeInstance()


def test_simulate_fmu_records_the_arrays(twin):
    """FMPy's simulate_fmu, recording every output by default, reads each array with nValues = its
    size and gets it in its shape, equal to the scalars."""
    from fmpy import simulate_fmu
    r = simulate_fmu(str(twin), stop_time=0.05, step_size=1e-3, output_interval=1e-3)
    for name in OUTPUT_ARRAYS:
        dims, elements = ARRAYS[name]
        assert r[name].shape == (len(r),) + dims, name
        flat = r[name].reshape(len(r), -1)
        for k, e in enumerate(elements):
            assert np.array_equal(flat[:, k], r[e]), (name, e)
