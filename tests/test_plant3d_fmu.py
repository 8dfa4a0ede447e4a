"""Hoap2Plant3D.fmu, the HOAP-2 in 3D on the Open Dynamics Engine (docs/plant3d.md); each test
says what it establishes. The physics of the plant library alone are the CTests `plant3d.*`
(plant3d/tests/test_plant3d.cpp); the figures of both are quoted in docs/plant3d.md.
"""
from __future__ import annotations

import ctypes
import json
import subprocess
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi2 import fmi2LastSuccessfulTime
from fmpy.validation import validate_fmu

from conftest import NOMINAL, REPO_ROOT, Slave

PLANT3D = "Hoap2Plant3D"
SIDES = ("left", "right")
JOINTS = ("hip_yaw", "hip", "hip_roll", "knee", "ankle", "ankle_roll")   # the proto's chain order
BOTH_LEGS = {"hip_yaw": "theta_hip_yaw_ref", "hip": "theta_hip_ref", "hip_roll": "theta_hip_roll_ref",
             "knee": "theta_knee_ref", "ankle": "theta_ankle_ref", "ankle_roll": "theta_ankle_roll_ref"}
LEG_REFS = [f"q_{s}_{j}_ref" for s in SIDES for j in JOINTS]   # input_fault bits 8...19, in this order


@pytest.fixture(scope="module")
def fmu3d(fmu_path) -> Path:
    return fmu_path(PLANT3D)


@pytest.fixture(scope="module")
def unzipped3d(fmu3d, tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("plant3d")
    with zipfile.ZipFile(fmu3d) as z:
        z.extractall(d)
    return d


# ------------------------------------------------------------------------------------------------
# the model: lumped back into the sagittal plane it gives the sagittal plant's numbers

def _lump(bodies):
    m = sum(b["mass"] for b in bodies)
    c = sum(b["mass"] * np.array(b["com"]) for b in bodies) / m
    iyy = sum(b["inertia"][1] + b["mass"] * ((b["com"][0] - c[0]) ** 2 + (b["com"][2] - c[2]) ** 2) for b in bodies)
    return m, c, iyy


def test_3d_model_lumps_to_the_sagittal_nominal_numbers(native_tool):
    """Establishes: the ODE model as assembled (7 bodies merged from the proto's 28, placed at their
    CoM, joints at the proto's anchors) lumped into the sagittal plane -- both legs together, arms
    and head into the upper body -- gives m1, m2, l1, lg1, lg2, I1, I2 and the foot numbers of
    hoap2/nominal.h (which the sagittal plant and the controller use), to the header's precision.
    The sagittal model counts the hip-yaw link (a point mass on the hip axes, part of the 3D thigh)
    in the upper body: it is moved across by its proto mass."""
    out = subprocess.run([str(native_tool("plant3d_tool")), "describe"], capture_output=True, text=True, check=True)
    model = json.loads(out.stdout)
    bodies = {b["name"]: b for b in model["bodies"]}
    joints = {j["name"]: j for j in model["joints"]}
    assert len(bodies) == 7 and len(joints) == 12
    side = ("left", "right")
    proto = {b["name"]: b for b in tomllib.loads((REPO_ROOT / "hoap2" / "webots_hoap2.toml").read_text())["body"]}
    yaw = {s: {"mass": proto[f"{s[0]}leg_hip_yaw"]["mass"], "com": joints[f"{s}_hip"]["anchor"], "inertia": [0] * 6}
           for s in side}
    assert all(f"{s[0]}leg_hip_yaw" in bodies[f"{s}_thigh"]["proto"].split(",") for s in side)
    minus = {s: dict(yaw[s], mass=-yaw[s]["mass"]) for s in side}
    feet = _lump([bodies[f"{s}_foot"] for s in side])
    link1 = _lump([bodies[f"{s}_{k}"] for s in side for k in ("thigh", "shank")] + [minus[s] for s in side])
    link2 = _lump([bodies["trunk"]] + [yaw[s] for s in side])
    ankle = np.mean([joints[f"{s}_ankle"]["anchor"] for s in side], axis=0)
    hip = np.mean([joints[f"{s}_hip"]["anchor"] for s in side], axis=0)
    got = {
        "M1": link1[0], "M2": link2[0], "FEET_MASS": feet[0],
        "L1": hip[2] - ankle[2], "LG1": link1[1][2] - ankle[2], "LG2": link2[1][2] - hip[2],
        "I1": link1[2], "I2": link2[2], "FEET_INERTIA": feet[2],
        "FEET_COM_X": feet[1][0] - ankle[0], "FEET_COM_Z": feet[1][2],   # the sole is at z = 0
        "ANKLE_HEIGHT": ankle[2], "LINK1_COM_X": link1[1][0] - ankle[0], "LINK2_COM_X": link2[1][0] - hip[0],
    }
    for k, v in got.items():
        assert v == pytest.approx(NOMINAL[k], rel=2e-5, abs=1e-8), k
    # both legs' joint axes: pitch along y, roll along x, yaw along z
    for s in side:
        assert joints[f"{s}_ankle"]["axis"] == [0, 1, 0] and joints[f"{s}_hip"]["axis"] == [0, 1, 0]
        assert joints[f"{s}_ankle_roll"]["axis"] == [1, 0, 0] and joints[f"{s}_hip_yaw"]["axis"] == [0, 0, 1]


# ------------------------------------------------------------------------------------------------
# the FMU as an artefact

def test_fmu_validates_and_names_the_sagittal_signals(fmu3d, plant_fmu):
    """Establishes: FMPy's validation finds nothing; every output and input of Hoap2Plant exists in
    the 3D FMU with the same causality, type and unit (so the controller FMU, the scenarios, the
    plots and the comparisons work on either plant), and the extra set points start at 0."""
    assert validate_fmu(str(fmu3d)) == []
    md2 = {v.name: v for v in read_model_description(str(plant_fmu)).modelVariables}
    md3 = {v.name: v for v in read_model_description(str(fmu3d)).modelVariables}
    solver_stats = {"cvode_steps", "rhs_evals", "root_evals", "impacts"}   # CVODE's; the 3D plant has ode_steps
    for name, v in md2.items():
        if v.causality in ("input", "output") and name not in solver_stats:
            assert name in md3, name
            w = md3[name]
            assert (w.causality, w.type, w.unit) == (v.causality, v.type, v.unit), name
    for name in ("push_force_y", "theta_ankle_roll_ref", "theta_hip_roll_ref", "theta_hip_yaw_ref", "theta_knee_ref"):
        assert md3[name].causality == "input" and float(md3[name].start) == 0.0
    # servo parameters under Hoap2Plant's names, same defaults
    for name in ("kp_ankle", "kd_ankle", "kp_hip", "kd_hip", "tau_max_ankle", "tau_max_hip", "vel_max_ankle",
                 "vel_max_hip", "h_push", "fall_foot_pitch", "fall_body_pitch"):
        assert float(md3[name].start) == float(md2[name].start), name


def test_per_leg_set_points_are_appended_and_pair_with_the_joint_outputs(fmu3d):
    """Establishes the per-leg inputs' place in the variable table (docs/plant3d.md section 3): one
    Real input `q_<side>_<joint>_ref` [rad] per joint output `q_<side>_<joint>` (the same names, so
    output and input pair), start 0, continuous; their value references are appended (200 + 6 side
    + joint) and every variable of before keeps its own (the eight inputs 0-7, input_fault 31, the
    joint outputs 80-91), so importers keep their wiring; input_fault names the new bits."""
    md = {v.name: v for v in read_model_description(str(fmu3d)).modelVariables}
    for i, name in enumerate(LEG_REFS):
        v = md[name]
        assert (v.causality, v.type, v.variability, v.unit, float(v.start)) == ("input", "Real", "continuous", "rad", 0.0)
        assert v.valueReference == 200 + i, name
        assert md[name[:-len("_ref")]].causality == "output"
        assert BOTH_LEGS[name.split("_", 2)[2][:-len("_ref")]] in v.description, v.description
    before = ["theta_ankle_ref", "theta_hip_ref", "push_force", "push_force_y", "theta_ankle_roll_ref",
              "theta_hip_roll_ref", "theta_hip_yaw_ref", "theta_knee_ref"]
    assert [md[n].valueReference for n in before] == list(range(8))
    assert md["input_fault"].valueReference == 31
    assert [md[n[:-len("_ref")]].valueReference for n in LEG_REFS] == list(range(80, 92))
    assert sorted(n for n, v in md.items() if v.causality == "input") == sorted(before + LEG_REFS)
    vrs = [v.valueReference for v in md.values()]
    assert len(vrs) == len(set(vrs))
    assert "bit 8 + 6 side + joint = q_<side>_<joint>_ref" in md["input_fault"].description


# ------------------------------------------------------------------------------------------------
# the per-leg set points (docs/plant3d.md section 3)

def test_per_leg_inputs_drive_their_own_joints(unzipped3d):
    """Establishes the FMU's mapping of all twelve per-leg inputs and the rule: with gravity off, no
    friction and the feet not held (the robot floats, as in CTest plant3d.per_leg_set_points), the both-legs inputs and
    a different per-leg value on every one of the twelve joints; each output q_<side>_<joint> reaches
    its both-legs input plus its own per-leg input, within 1e-4 rad."""
    both = {"hip_yaw": 0.12, "hip": 0.2, "hip_roll": 0.07, "knee": 0.4, "ankle": -0.15, "ankle_roll": -0.06}
    leg = {"left": (-0.25, -0.3, -0.2, 0.3, 0.1, 0.15), "right": (0.1, 0.15, -0.05, -0.2, -0.1, 0.05)}
    # two held feet would close the chain; floating, the robot tilts but cannot fall
    s = Slave(unzipped3d, {"g": 0.0, "mu": 0.0, "flat_foot_weld": False, "fall_foot_pitch": 1.5,
                           "fall_body_pitch": 1.5})
    for _ in range(1000):
        for j in JOINTS:
            s.set(BOTH_LEGS[j], both[j])
        for side in SIDES:
            for j, x in zip(JOINTS, leg[side]):
                s.set(f"q_{side}_{j}_ref", x)
        assert s.step() == 0
    worst = 0.0
    for side in SIDES:
        for j, x in zip(JOINTS, leg[side]):
            worst = max(worst, abs(s.get(f"q_{side}_{j}") - (both[j] + x)))
    s.free()
    assert worst < 1e-4, worst


def _leg_run(unzipped: Path, inputs, steps: int = 1500) -> np.ndarray:
    """Every Real output after each step, the inputs set by inputs(k, set) before step k; the
    master's points t_k = k h."""
    s = Slave(unzipped)
    rows = []
    for k in range(steps):
        s.set("push_force", 7.0 if 300 <= k < 700 else 0.0)
        s.set("push_force_y", 5.0 if 500 <= k < 900 else 0.0)
        s.set("theta_hip_ref", 0.1 * np.sin(2 * np.pi * k * 1e-3))
        inputs(k, s.set)
        s.fmu.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
        rows.append(s.outputs())
    s.free()
    return np.array(rows)


def test_zero_per_leg_inputs_leave_the_plant_bit_for_bit(unzipped3d):
    """Establishes: per-leg inputs at 0 change nothing. A run with a push forward, a push sideways
    and a moving hip set point, the per-leg inputs never set, equals bit for bit the same run with
    all twelve set to 0 every step, and the run that drives both knees by the per-leg inputs
    (q_left_knee_ref = q_right_knee_ref = 0.05, theta_knee_ref = 0) equals the run that drives them
    by theta_knee_ref = 0.05 (the rule's sum: 0 + x = x + 0 = x). With both, the knees' set point
    is the sum: 0.05 + 0.02 differs from 0.05."""
    plain = _leg_run(unzipped3d, lambda k, set_: None)
    zeros = _leg_run(unzipped3d, lambda k, set_: [set_(n, 0.0) for n in LEG_REFS])
    assert np.array_equal(plain, zeros)
    by_both = _leg_run(unzipped3d, lambda k, set_: set_("theta_knee_ref", 0.05))
    by_legs = _leg_run(unzipped3d, lambda k, set_: [set_(f"q_{side}_knee_ref", 0.05) for side in SIDES])
    assert np.array_equal(by_both, by_legs)
    assert not np.array_equal(plain, by_both)
    summed = _leg_run(unzipped3d, lambda k, set_: [set_("theta_knee_ref", 0.05)] +
                      [set_(f"q_{side}_knee_ref", 0.02) for side in SIDES])
    assert not np.array_equal(summed, by_both)


def test_per_leg_input_moves_its_leg_in_double_support(unzipped3d):
    """Establishes: on the ground, a per-leg input moves its own leg's joint and the other leg's
    same joint far less. The left knee flexed by 0.2 rad alone, both feet down: the left knee
    follows, the right knee stays within a tenth of it, and the robot stands."""
    s = Slave(unzipped3d)
    for k in range(2000):
        s.set("q_left_knee_ref", 0.2 * min(1.0, k / 1000))
        assert s.step() == 0
    left, right = s.get("q_left_knee"), s.get("q_right_knee")
    fallen = s.get("fallen")
    s.free()
    assert not fallen
    assert left > 0.1 and abs(right) < 0.1 * left, (left, right)


# ------------------------------------------------------------------------------------------------
# FMI behaviour: state, bad input, falls

def test_state_restored_bit_for_bit_into_a_fresh_instance(unzipped3d):
    """Establishes: fmi2GetFMUstate + serialization captures the whole ODE world (bodies, servo
    inputs, noise generator); deserialized into a new instance it continues with exactly the
    same outputs as the original, mid-push and with sensor noise on."""
    params = {"sensor_noise": 0.3}
    a = Slave(unzipped3d, params, "a")
    for k in range(300):
        a.set("push_force", 13.0 if 100 <= k < 250 else 0.0)
        a.set("q_left_hip_roll_ref", -0.0002 * k)       # per-leg set points in the state
        a.set("q_right_knee_ref", 0.0003 * k)
        assert a.step() == 0
    blob = a.fmu.serializeFMUstate(a.fmu.getFMUstate())
    t_snap = a.t   # the restored instance continues from the state's time with the same master

    def after(s):
        # the right knee's input goes bad: both hold its last finite value, which the state carries
        s.set("push_force", 0.0)
        s.set("q_right_knee_ref", float("nan"))
        s.step()
        assert s.get("input_fault") == 1 << (8 + LEG_REFS.index("q_right_knee_ref"))
        return s.outputs()
    ref = [after(a) for _ in range(300)]
    b = Slave(unzipped3d, params, "b")
    b.fmu.setFMUstate(b.fmu.deSerializeFMUstate(blob))
    b.t = t_snap
    got = [after(b) for _ in range(300)]
    assert np.array_equal(np.array(ref), np.array(got))
    assert a.get("q_right_knee") > 0.05       # held at 0.0897, not dropped to 0
    a.free()
    b.free()


def test_non_finite_input_is_contained_and_logged(unzipped3d):
    """Establishes: a NaN push is not propagated: the step returns fmi2Warning, the log names the
    input, the last finite value is held and every output stays finite."""
    from conftest import RawModel, fmi2OK, fmi2Warning
    raw = RawModel(unzipped3d)
    inst = raw.instance(name="nan")
    assert inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0) == fmi2OK
    assert inst.fmi2EnterInitializationMode() == fmi2OK
    assert inst.fmi2ExitInitializationMode() == fmi2OK
    assert inst.set_real({"push_force": float("nan")}) == fmi2OK
    assert inst.fmi2DoStep(ctypes.c_double(0.0), ctypes.c_double(1e-3), 1) == fmi2Warning
    assert any("push_force" in m for _, _, m in inst.log), inst.log
    outs = [n for n, v in inst.md.vars.items() if v.causality == "output" and v.type == "Real"]
    st, vals = inst.get_real(outs)
    assert st == fmi2OK and all(np.isfinite(vals))
    inst.free()


def test_non_finite_per_leg_input_is_held_with_its_own_bit(unzipped3d):
    """Establishes: a per-leg input that goes NaN or Inf is treated as the other inputs are: the
    step returns fmi2Warning, one warning names the input and its input_fault bit (8 + 6 side +
    joint), the joint keeps its last finite set point, and the bit clears when the input is finite
    again. The bits of before keep their meaning (push_force: bit 2)."""
    from conftest import RawModel, fmi2OK, fmi2Warning
    raw = RawModel(unzipped3d)
    inst = raw.instance(name="nan")
    assert inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0) == fmi2OK
    assert inst.fmi2EnterInitializationMode() == fmi2OK
    assert inst.fmi2ExitInitializationMode() == fmi2OK
    h, k = 1e-3, 0

    def step():
        nonlocal k
        st = inst.fmi2DoStep(ctypes.c_double(k * h), ctypes.c_double(h), 1)
        k += 1
        return st
    assert inst.set_real({"q_right_knee_ref": 0.1}) == fmi2OK
    for _ in range(500):
        assert step() == fmi2OK
    bit = 8 + LEG_REFS.index("q_right_knee_ref")
    assert bit == 17
    for bad in (float("nan"), float("inf")):
        assert inst.set_real({"q_right_knee_ref": bad, "push_force": float("nan")}) == fmi2OK
        for _ in range(300):
            assert step() == fmi2Warning
        assert inst.get_integer(["input_fault"]) == (fmi2OK, [(1 << bit) | (1 << 2)])
        assert inst.set_real({"q_right_knee_ref": 0.1, "push_force": 0.0}) == fmi2OK
        assert step() == fmi2OK and inst.get_integer(["input_fault"]) == (fmi2OK, [0])
    warnings = [m for st, _, m in inst.log if st == fmi2Warning and "q_right_knee_ref" in m]
    assert len(warnings) == 2 and "input_fault bit 17" in warnings[0], warnings
    st, (q,) = inst.get_real(["q_right_knee"])
    assert st == fmi2OK and abs(q - 0.1) < 0.02, q   # held at 0.1 throughout, never driven to 0 or Inf
    inst.free()


def test_fall_is_a_discard_with_the_last_successful_time(unzipped3d):
    """Establishes: a push far above the tipping force makes the robot fall; the FMU reports
    fmi2Discard, fmi2Terminated and the fall time as fmi2LastSuccessfulTime, and `fallen`."""
    from fmpy.fmi2 import fmi2Discard, fmi2LastSuccessfulTime, fmi2Terminated
    s = Slave(unzipped3d)
    st = 0
    for _ in range(3000):
        s.set("push_force", 30.0)
        try:
            s.step()
        except Exception as e:   # FMPy raises on fmi2Discard
            st = getattr(e, "status", None)
            break
    assert st == fmi2Discard
    assert s.fmu.getBooleanStatus(fmi2Terminated)
    t_fall = s.fmu.getRealStatus(fmi2LastSuccessfulTime)
    assert 0.0 < t_fall <= s.t + 1e-3 and s.get("fallen")   # s.t: start of the failing step
    s.free()


# ------------------------------------------------------------------------------------------------
# cross-validation against the sagittal plant (docs/plant3d.md section 6)

def _tipping_force(unzipped: Path, params: dict, rate: float = 1.0, sign: float = 1.0):
    s = Slave(unzipped, params)
    s.set("theta_ankle_ref", params.get("theta_ankle_init", 0.0))   # the servos hold the initial posture
    k = 0
    while k < 30000:
        f = sign * rate * s.t
        s.set("push_force", f)
        assert s.step() == 0
        k += 1
        if s.get("contact_mode") != 0:
            break
    out = (f, s.get("com_x"), s.get("contact_mode"))
    s.free()
    return out


@pytest.mark.parametrize("sign", [1.0, -1.0], ids=["push_toe", "pull_heel"])
def test_tipping_force_equals_the_sagittal_plants(unzipped3d, plant_unzipped, sign):
    """Establishes: with the joints held and the robot standing with its CoM where the sagittal
    plant's is (the 3D robot leans back by the small angle that moves its CoM, 3 mm ahead of the
    ankles because the proto's link CoMs sit off the joint line, onto the sagittal model's), a
    slow push ramp lifts the heels (a pull the toes) at the same force as in Hoap2Plant, within 2 %.
    The sagittal model's knees are rigid, so the 3D knee servos are made stiff for this comparison
    (with the default knee servo the pull lifts the toes 3 % earlier: the knees give 1 mm)."""
    lean = _lean_onto_the_sagittal_com(unzipped3d, plant_unzipped)
    # the sagittal model's knees are rigid: make the 3D knees stiff as well
    f3, cx3, mode3 = _tipping_force(unzipped3d, {"theta_ankle_init": lean, "kp_knee": 1e4, "kd_knee": 200.0}, sign=sign)
    f2, cx2, mode2 = _tipping_force(plant_unzipped, {}, sign=sign)
    assert mode3 == mode2 == (1 if sign > 0 else 2)
    assert f3 == pytest.approx(f2, rel=0.02), (f3, f2, cx3, cx2)
    print(f"{'heels' if sign > 0 else 'toes'} lift at {f3:+.3f} N (3D) vs {f2:+.3f} N (sagittal): "
          f"{100 * (f3 / f2 - 1):+.2f} %")


def _step_push(unzipped: Path, params: dict, force: float, t_push: float = 0.2, t_end: float = 3.0):
    """A push of `force` from t_push on, held until the robot falls: times, foot pitch, fall time."""
    s = Slave(unzipped, params)
    s.set("theta_ankle_ref", params.get("theta_ankle_init", 0.0))
    t, pitch, t_fall = [], [], None
    while s.t < t_end:
        s.set("push_force", force if s.t >= t_push - 1e-9 else 0.0)
        try:
            s.step()
        except Exception:   # fmi2Discard: fallen
            t_fall = s.fmu.getRealStatus(fmi2LastSuccessfulTime)
            break
        t.append(s.t)
        pitch.append(s.get("foot_pitch"))
    s.free()
    return np.array(t), np.array(pitch), t_fall


def _lean_onto_the_sagittal_com(unzipped3d, plant_unzipped) -> float:
    """The ankle angle that puts the 3D robot's CoM where the sagittal plant's is."""
    s = Slave(unzipped3d)
    s.step()
    com_x3, com_z3 = s.get("com_x"), s.get("com_z")
    s.free()
    sag = Slave(plant_unzipped)
    sag.step()
    com_x2 = sag.get("com_x")
    sag.free()
    return float(-np.arcsin((com_x3 - com_x2) / com_z3))


def test_step_push_above_tipping_falls_like_the_sagittal_plant(unzipped3d, plant_unzipped):
    """Establishes (cross-check 3): a step push 50 % above the tipping force, held, tips both plants
    over their toes the same way: the foot pitch of the 3D plant follows the sagittal plant's until
    the fall (the times at which the foot reaches 0.05, 0.1 and 0.2 rad, and the fall, agree within
    3 %; the largest pitch difference before the fall is below 0.02 rad). Same set-up as the
    tipping comparison: CoM placed alike, stiff 3D knees."""
    lean = _lean_onto_the_sagittal_com(unzipped3d, plant_unzipped)
    f2, _, _ = _tipping_force(plant_unzipped, {}, sign=1.0)
    force = 1.5 * f2
    t3, p3, fall3 = _step_push(unzipped3d, {"theta_ankle_init": lean, "kp_knee": 1e4, "kd_knee": 200.0}, force)
    t2, p2, fall2 = _step_push(plant_unzipped, {}, force)
    assert fall2 is not None and fall3 is not None, (fall2, fall3)
    crossings = []
    for level in (0.05, 0.1, 0.2):
        c2, c3 = t2[np.argmax(p2 >= level)], t3[np.argmax(p3 >= level)]
        assert c3 - 0.2 == pytest.approx(c2 - 0.2, rel=0.03), (level, c2, c3)
        crossings.append(f"{level} rad at {c3:.3f}/{c2:.3f} s")
    assert fall3 - 0.2 == pytest.approx(fall2 - 0.2, rel=0.03), (fall2, fall3)
    n = min(len(t2), len(t3))
    worst = float(np.max(np.abs(p3[:n] - p2[:n])))
    assert worst < 0.02, worst
    print(f"step push {force:.2f} N: fall at {fall3:.4f} s (3D) vs {fall2:.4f} s (sagittal); "
          f"largest foot-pitch difference {worst:.4f} rad; " + ", ".join(crossings))


def test_paper_pushes_on_the_3d_plant_match_the_sagittal_plants():
    """Establishes (cross-check 4, issue 27): the main job on the 3D plant, with no override
    (`anklehip run paper_five_pushes --plant 3d`: the controller gets the plant's link CoM offsets
    from its constants, nothing else changes): five 0->1->2->3->0 cycles, no fall; phase 2 of every
    push ends by the paper's condition (the ZMP on the side opposite the push, p < 0, at the 2->3
    switch, not the fallback); per push the peak hip angle and the peak ZMP within 5 % and the
    recovery time within 25 % of the sagittal plant's. Check 4b: with the 3D knees made stiff (the
    sagittal knees are rigid) the peak ZMP and the peak hip angle measured from the controller's
    erect posture agree within 0.5 %."""
    import dataclasses

    from anklehip.running.master import Models, simulate
    from anklehip.files.paths import scenarios_dir
    from anklehip.analysis.summary import count_cycles, summarize_pushes
    from anklehip.files.scenario import load_scenario

    base = load_scenario(scenarios_dir() / "paper_five_pushes.toml")
    runs = {}
    stiff_knees = {"kp_knee": 1e5, "kd_knee": 2000.0}     # the sagittal model's knees are rigid
    for label, plant, overrides in (("sagittal", "sagittal", None), ("3d", "3d", None),
                                    ("3d, stiff knees", "3d", stiff_knees)):
        sc = dataclasses.replace(base, plant_model=plant)
        res = simulate(sc, Models.load(plant_model=plant), plant_overrides=overrides, progress=False)
        assert res.outcome == "completed", res.message
        runs[label] = (res, summarize_pushes(res, sc.push, sc.expect.erect_tol))
    res3, p3 = runs["3d"]
    assert res3.controller_overrides == {"link1_com_x": NOMINAL["LINK1_COM_X"],
                                         "link2_com_x": NOMINAL["LINK2_COM_X"]}, res3.controller_overrides
    assert count_cycles(res3.data["phase"]) == 5
    d = res3.data
    to3 = np.flatnonzero((d["phase"][1:] == 3) & (d["phase"][:-1] == 2)) + 1
    assert len(to3) == 5, d["time"][to3]
    assert np.all(d["zmp_x"][to3] < 0), ("phase 2 ended by the fallback", d["time"][to3], d["zmp_x"][to3])
    for i, (a, b) in enumerate(zip(p3, runs["sagittal"][1])):
        assert a.phases == [0, 1, 2, 3], (i, a.phases)
        assert a.peak_hip == pytest.approx(b.peak_hip, rel=0.05), (i, a.peak_hip, b.peak_hip)
        assert a.peak_zmp == pytest.approx(b.peak_zmp, rel=0.05), (i, a.peak_zmp, b.peak_zmp)
        assert a.time_to_recover == pytest.approx(b.time_to_recover, rel=0.25), (i, a.time_to_recover, b.time_to_recover)
        print(f"push {i + 1}: peak hip {np.degrees(a.peak_hip):.2f} vs {np.degrees(b.peak_hip):.2f} deg "
              f"({100 * (a.peak_hip / b.peak_hip - 1):+.1f} %), peak ZMP {1000 * a.peak_zmp:.1f} vs "
              f"{1000 * b.peak_zmp:.1f} mm ({100 * (a.peak_zmp / b.peak_zmp - 1):+.1f} %), recovery "
              f"{a.time_to_recover:.3f} vs {b.time_to_recover:.3f} s")
    # check 4b: with stiff knees what is left is the erect hip angle (the controller's, from the
    # link CoM offsets): the ZMP and the hip's excursion from erect agree within 0.5 %
    hip_erect = runs["3d, stiff knees"][0].erect[1]
    for i, (a, b) in enumerate(zip(runs["3d, stiff knees"][1], runs["sagittal"][1])):
        assert a.peak_zmp == pytest.approx(b.peak_zmp, rel=0.005), (i, a.peak_zmp, b.peak_zmp)
        assert a.peak_hip - hip_erect == pytest.approx(b.peak_hip, rel=0.005), (i, a.peak_hip, hip_erect, b.peak_hip)
        print(f"push {i + 1}, stiff knees: peak ZMP {100 * (a.peak_zmp / b.peak_zmp - 1):+.2f} %, hip from erect "
              f"{100 * ((a.peak_hip - hip_erect) / b.peak_hip - 1):+.2f} %")

def test_closed_loop_converges_at_the_default_steps():
    """Establishes (docs/plant3d.md section 2, "Time steps, on evidence"): the closed loop on the 3D
    plant has converged in the plant's internal steps. The first push of the main job on this plant,
    run as shipped (1 ms flat, 0.25 ms rocking) and with both steps at 1/32 ms, peaks at the same ZMP
    and hip angle within 0.2 % and crosses the same phases. The force outputs are the communication
    step's mean (section 2, "Force outputs"); sampled at the end of the last internal step they
    would vary by several per cent over the same range."""
    from anklehip.running.master import Models, simulate
    from anklehip.files.paths import scenarios_dir
    from anklehip.files.scenario import load_scenario

    base = load_scenario(scenarios_dir() / "paper_five_pushes_3d.toml")
    models = Models.load(plant_model="3d")
    peaks = {}
    for label, steps in (("default", {}), ("1/32 ms", {"internal_step": 1e-3 / 32, "rocking_step": 1e-3 / 32})):
        res = simulate(base, models, plant_overrides=steps, stop_time=6.0, progress=False)
        assert res.outcome == "completed", res.message
        d = res.data
        peaks[label] = (float(d["zmp_x"].max()), float(d["theta_hip"].max()), sorted(set(d["phase"].tolist())))
    (z1, h1, ph1), (z2, h2, ph2) = peaks["default"], peaks["1/32 ms"]
    assert ph1 == ph2 == [0, 1, 2, 3]
    assert z1 == pytest.approx(z2, rel=0.002) and h1 == pytest.approx(h2, rel=0.002), peaks
    print(f"first push: peak ZMP {1e3 * z1:.3f} mm (default steps) vs {1e3 * z2:.3f} mm (1/32 ms), "
          f"peak hip {h1:.5f} vs {h2:.5f} rad")


@pytest.mark.parametrize("scenario, force, falls", [
    ("side_push_3d", 15.0, False), ("side_push_3d", 16.0, True),
    ("diagonal_push_3d", 8.5, False), ("diagonal_push_3d", 9.0, True)])
def test_side_and_diagonal_push_limits(scenario, force, falls):
    """Establishes the limits docs/plant3d.md section 6 quotes (checks 5 and 5b) for the sagittal
    controller on the 3D plant: the side push's shape (1 s, 0.3 s ramps, toward +y) is survived at
    15 N and fells the robot at 16 N; the diagonal push's shape (as much forward as to the left)
    is survived at 8.5 N each way and fells it at 9 N each way. Both scenarios' pushes are scaled
    to that peak, each component alike."""
    import dataclasses

    from anklehip.running.master import Models, simulate
    from anklehip.files.paths import scenarios_dir
    from anklehip.files.scenario import load_scenario

    sc = load_scenario(scenarios_dir() / f"{scenario}.toml")
    k = force / abs(sc.push_y.peak())
    sc = dataclasses.replace(sc, push=sc.push.scaled(k), push_y=sc.push_y.scaled(k))
    res = simulate(sc, Models.load(plant_model="3d"), progress=False)
    assert res.outcome == ("fell" if falls else "completed"), (res.outcome, res.fell_at)
    print(f"{scenario} at {force:g} N: {res.outcome}, |zmp_y| up to {1e3 * np.max(np.abs(res.data['zmp_y'])):.1f} mm")


# ------------------------------------------------------------------------------------------------
# the master connects a controller's per-leg outputs by name

def _stand_in_controller(controller_fmu: Path, folder: Path, old: str, new: str) -> Path:
    """A stand-in for a controller with per-leg outputs: the controller FMU with its output `old`
    renamed `new` in modelDescription.xml (the binary serves the value reference, whatever its name)."""
    out = folder / "StandInController.fmu"
    with zipfile.ZipFile(controller_fmu) as zin, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                assert text.count(f'name="{old}"') == 1
                data = text.replace(f'name="{old}"', f'name="{new}"').encode()
            zout.writestr(item, data)
    return out


@pytest.mark.parametrize("engine", ["fmpy", "native"])
def test_master_connects_a_controller_output_to_the_per_leg_input_of_its_name(controller_fmu, fmu3d, unzipped3d,
                                                                             tmp_path, engine):
    """Establishes: the master (both engines) connects every controller output to the plant input
    of the same name, so a frontal controller's outputs q_<side>_<joint>_ref reach the per-leg
    set points without any wiring. A stand-in controller whose output com_x_desired is renamed
    q_left_hip_roll_ref runs the main job's first push on the 3D plant; the result carries the
    column, and the plant alone, replayed at the same points with the recorded set points, pushes
    and that column as its inputs, computes every recorded plant output bit for bit (so the plant
    received exactly that signal on that input in the closed loop)."""
    from anklehip.running.master import Models, simulate
    from anklehip.files.paths import scenarios_dir
    from anklehip.files.scenario import load_scenario

    stand_in = _stand_in_controller(controller_fmu, tmp_path, "com_x_desired", "q_left_hip_roll_ref")
    sc = load_scenario(scenarios_dir() / "paper_five_pushes_3d.toml")
    res = simulate(sc, Models.load(controller=stand_in, plant=fmu3d), stop_time=4.0, progress=False, engine=engine)
    assert res.outcome == "completed", res.message
    d = res.data
    assert res.controller_columns["q_left_hip_roll_ref"] == "q_left_hip_roll_ref"
    signal = d["q_left_hip_roll_ref"]
    assert np.max(np.abs(signal)) > 1e-3 and np.ptp(signal) > 1e-3, (signal.min(), signal.max())
    s = Slave(unzipped3d)
    inputs = ["theta_ankle_ref", "theta_hip_ref", "push_force", "push_force_y", "q_left_hip_roll_ref"]
    outs = [v.name for v in s.md.modelVariables if v.causality == "output" and v.type == "Real"
            and v.variability != "constant" and v.name in d.dtype.names]
    assert "q_left_hip_roll" in outs and len(outs) > 50
    h = sc.step
    for k in range(len(d) - 1):
        for n in inputs:
            s.set(n, d[n][k])
        s.fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
        got = s.fmu.getReal([s.var[n].valueReference for n in outs])
        want = [d[n][k + 1] for n in outs]
        assert got == want, (k, [(n, a, b) for n, a, b in zip(outs, got, want) if a != b][:3])
    s.free()
