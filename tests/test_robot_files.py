"""Robot files (docs/your-robot.md): the HOAP-2's URDF / MJCF generated from the Webots
transcription, the lumper against hoap2/lump.py (round trip) and against Pinocchio (an independent
reader and independent rigid-body algorithms), the example robots' files, and the refusal of
descriptions and robot files that make no physical sense.

Establishes: lumping hoap2/hoap2.urdf (SRDF posture) and hoap2/hoap2.xml (keyframe) reproduces
the derivation behind nominal.h to 1e-9 and each header literal exactly; for those and for Talos,
iCub, Romeo and G1 the lumps recombine to Pinocchio's whole-body mass, CoM and centroidal pitch
inertia, and each lump equals Pinocchio's sum over its joints, to 1e-9; wrong input exits 2
naming the file and the field and writes nothing.
"""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from conftest import NOMINAL, REPO_ROOT, import_file
from anklehip.robot import RobotFileError, load_robot, lump_file
from anklehip.robot.description import forward_rotation, load_description
from anklehip.robot.lump import find_legs, lump, lump_description

lump_py = import_file(REPO_ROOT / "hoap2" / "lump.py", "hoap2_lump")
robot_files = import_file(REPO_ROOT / "hoap2" / "robot_files.py", "hoap2_robot_files")
examples = import_file(REPO_ROOT / "scripts" / "example_robots.py", "example_robots")

HOAP2 = {"urdf": dict(path=REPO_ROOT / "hoap2" / "hoap2.urdf", srdf=REPO_ROOT / "hoap2" / "hoap2.srdf",
                      keyframe="standing"),
         "mjcf": dict(path=REPO_ROOT / "hoap2" / "hoap2.xml", keyframe="standing")}
TOL = 1e-9


def close(a, b, tol=TOL) -> bool:
    return abs(a - b) <= tol * max(1.0, abs(b))


def test_hoap2_files_are_generated():
    for path, text in robot_files.generated().items():
        assert path.read_text() == text, f"{path} is stale: python3 hoap2/robot_files.py --write"
    r = subprocess.run([sys.executable, str(REPO_ROOT / "hoap2" / "robot_files.py"), "--check"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("kind", ["urdf", "mjcf"])
def test_hoap2_round_trip(kind):
    """The generated description, lumped by the generic lumper, gives hoap2/lump.py's numbers to 1e-9
    and therefore nominal.h's literals (6 significant digits) exactly."""
    robot = lump_file(**HOAP2[kind])
    derived = lump_py.lumped()
    v = robot.values()
    header = {key: macro for macro, key, _ in lump_py.MACROS}
    for k, x in v.items():
        if k in derived:
            assert close(x, derived[k]), (k, x, derived[k])
        if k in header:
            assert lump_py.fmt(x) == lump_py.fmt(derived[k]), k
            assert float(lump_py.fmt(x).strip("()")) == NOMINAL[header[k]], k
    for k in ("link1_com_x", "link2_com_x", "total_mass"):
        assert close(robot.info[k], derived[k]), k
    # the servo limits: the proto's 9 N m per motor, both legs; 5 rad/s (MJCF has no rate limits)
    assert (v["tau_max_ankle"], v["tau_max_hip"]) == (18.0, 18.0)
    assert (v.get("vel_max_ankle"), v.get("vel_max_hip")) == ((5.0, 5.0) if kind == "urdf" else (None, None))
    # the lumper found the pitch joints the header names
    assert robot.info["ankle_joints"] == ["lleg_joint_5", "rleg_joint_5"]
    assert robot.info["hip_joints"] == ["lleg_joint_3", "rleg_joint_3"]
    assert robot.info["knee_joints"] == ["lleg_joint_4", "rleg_joint_4"]


def test_hoap2_robot_file_holds_the_fmu_defaults(fmu_path):
    """robots/hoap2.toml = nominal.h = the controllers' and the sagittal plant's start values, bit for bit."""
    from anklehip.running.fmu import FMUInfo
    robot = load_robot(REPO_ROOT / "robots" / "hoap2.toml")
    header = {key: macro for macro, key, _ in lump_py.MACROS}
    for k, q in robot.model.items():
        assert q.value == NOMINAL[header[k]], k
    for fmu in ("AnkleHipController", "AnkleHipController3D", "Hoap2Plant"):
        start = FMUInfo.load(fmu_path(fmu)).start_values()
        for k, x in robot.values().items():
            if k in start:
                assert float(start[k]) == x, f"{fmu}.{k}"


def test_hoap2_hip_limits_are_theta2():
    """The hip pitch joint turns the leg by q about +y: the trunk pitches forward for q < 0, so
    theta2's range is the proto's mirrored (nominal.h since issue 32)."""
    j = next(b["joint"] for b in lump_py.load()["body"] if b.get("joint", {}).get("name") == "lleg_joint_3")
    assert (NOMINAL["HIP_MIN"], NOMINAL["HIP_MAX"]) == (-j["max"], -j["min"])
    # a +0.1 rad hip pitch moves the trunk's CoM backwards: theta2 = -0.1
    base = lump_py.place(lump_py.load())
    bent = lump_py.place(lump_py.load(), {**lump_py.POSTURE, "lleg_joint_3": 0.1, "rleg_joint_3": 0.1})
    # q = +0.1 swings the leg backwards under the trunk: the trunk pitches backwards relative to the leg
    assert bent["lleg_knee"].com[0] < base["lleg_knee"].com[0] - 0.005


# ----------------------------------------------------------------------------------------------
# Pinocchio

def _example_cases():
    return [pytest.param(dict(path=examples.robots_dir() / ex.file, **ex.options), id=ex.name)
            for ex in examples.EXAMPLES]


def _pin_model(path, kind):
    """Pinocchio's model: a URDF with a free-flyer root (so that the root link's inertia is a body of
    its own, not the universe's), an MJCF as its <freejoint> says."""
    import pinocchio as pin
    if kind == "urdf":
        return pin, pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    return pin, pin.buildModelFromMJCF(str(path))


def _pin_q(pin, model, d):
    """Pinocchio's configuration of the description's posture (and, for a free root, its placement)."""
    q = pin.neutral(model)
    for jid in range(1, model.njoints):
        name = model.names[jid]
        j = model.joints[jid]
        if j.nq == 7:        # free flyer: the root body's placement in the world
            root = next(b for b in d.bodies.values() if b.parent is None)
            q[j.idx_q:j.idx_q + 3] = root.origin
        elif name in d.posture:
            if j.nq == 1:
                q[j.idx_q] = d.posture[name]
            elif j.nq == 2:
                q[j.idx_q:j.idx_q + 2] = [math.cos(d.posture[name]), math.sin(d.posture[name])]
    return q


@pytest.mark.parametrize("case", [pytest.param(HOAP2["urdf"], id="hoap2-urdf"), pytest.param(HOAP2["mjcf"], id="hoap2-mjcf"),
                                  *_example_cases()])
def test_lumps_match_pinocchio(case):
    case = dict(case)
    path = case.pop("path")
    forward = case.pop("forward", "+x")
    d = load_description(path, forward=forward, **{k: v for k, v in case.items() if k in ("keyframe", "srdf")})
    robot = lump_description(d)
    legs = find_legs(d)
    pin, model = _pin_model(path, d.kind)
    data = model.createData()
    q = _pin_q(pin, model, d)
    pin.forwardKinematics(model, data, q)
    R = forward_rotation(forward)
    # whole body: mass, CoM, centroidal inertia (pitch)
    pin.centerOfMass(model, data, q)
    pin.ccrba(model, data, q, np.zeros(model.nv))
    com = R @ data.com[0]
    Ig = R @ data.Ig.inertia @ R.T
    lumps = [lump([d.bodies[n] for n in names]) for names in (legs.feet, legs.link1, legs.link2)]
    M = sum(x.mass for x in lumps)
    c = sum(x.mass * x.com for x in lumps) / M
    Iyy = sum(x.Iyy + x.mass * ((x.com[0] - c[0]) ** 2 + (x.com[2] - c[2]) ** 2) for x in lumps)
    assert close(M, data.mass[0]) and close(robot.info["total_mass"], data.mass[0])
    assert np.allclose(c, com, rtol=0, atol=TOL)
    assert close(Iyy, Ig[1, 1]), (Iyy, Ig[1, 1])
    # each lump: Pinocchio's bodies (a joint and the fixed links it carries) grouped by subtree
    body_of = {b.joint.name: n for n, b in d.bodies.items() if b.joint is not None}
    for names, mine in zip((legs.feet, legs.link1, legs.link2), lumps):
        m, mc, parts = 0.0, np.zeros(3), []
        for jid in range(1, model.njoints):
            owner = body_of.get(model.names[jid])
            if owner is None and model.joints[jid].nq == 7:
                owner = next(b.name for b in d.bodies.values() if b.parent is None)
            if owner not in names:
                continue
            Y = model.inertias[jid]
            M_i = data.oMi[jid]
            ci = R @ (M_i.rotation @ Y.lever + M_i.translation)
            Ii = R @ M_i.rotation @ Y.inertia @ M_i.rotation.T @ R.T
            parts.append((Y.mass, ci, Ii))
        m = sum(p[0] for p in parts)
        mc = sum(p[0] * p[1] for p in parts) / m
        iyy = sum(p[2][1, 1] + p[0] * ((p[1][0] - mc[0]) ** 2 + (p[1][2] - mc[2]) ** 2) for p in parts)
        assert close(m, mine.mass), (m, mine.mass)
        assert np.allclose(mc, mine.com, rtol=0, atol=TOL)
        assert close(iyy, mine.Iyy), (iyy, mine.Iyy)


# ----------------------------------------------------------------------------------------------
# the example robots

def test_example_robot_files_are_the_lumping():
    for ex in examples.EXAMPLES:
        assert examples.path_of(ex.name).read_text() == examples.robot_text(ex), \
            f"robots/{ex.name}.toml is stale: python scripts/example_robots.py --write"


def test_example_robots_are_what_their_descriptions_say():
    """Independent sanity figures: the masses the descriptions sum to, straight legs, soles where the
    feet are (iCub's COLLADA feet laid along x by their up axis)."""
    r = {ex.name: load_robot(examples.path_of(ex.name)) for ex in examples.EXAMPLES}
    assert r["talos"].info["total_mass"] == pytest.approx(90.27, abs=0.01)
    assert r["g1"].info["total_mass"] == pytest.approx(33.34, abs=0.01)
    assert r["romeo"].info["total_mass"] == pytest.approx(40.53, abs=0.01)
    assert r["icub"].info["total_mass"] == pytest.approx(28.35, abs=0.01)
    for rb in r.values():
        v = rb.values()
        assert abs(rb.info["hip_x"]) < 1e-5          # straight legs: the hip above the ankle
        assert 0.12 < v["toe_x"] - v["heel_x"] < 0.25    # a foot 12-25 cm long
        assert 0.04 < v["sole_width"] < 0.15
        assert abs(rb.info["sole_bottom"]) < 1e-3    # the collision geometry reaches the ground
    assert r["icub"].value("toe_x") > 2 * -r["icub"].value("heel_x")     # the ankle near the heel


# ----------------------------------------------------------------------------------------------
# wrong input

GOOD = (REPO_ROOT / "robots" / "hoap2.toml").read_text()


def _cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "anklehip", *map(str, args)], capture_output=True, text=True, cwd=cwd)


@pytest.mark.parametrize("edit,field", [
    (("m1 = { value = 1.79416,", "m1 = { value = -1.0,"), "model.m1"),
    (("lg2 = { value = 0.101597,", "lg2 = { value = -0.6,"), "model.lg2"),        # the CoM below the sole
    (("toe_x = { value = 0.0575,", "toe_x = { value = -0.0375,"), "model.toe_x"),  # a sole of zero length
    (("I2 = { value = 0.0239911,", "I2 = { value = -0.1,"), "model.I2"),
    (('unit = "kg.m2", source = "nominal.h HOAP2_I1', 'unit = "g.cm2", source = "nominal.h HOAP2_I1'), "model.I1.unit"),
    (("m2 = { value = 4.70997,", "m2 = { value = nan,"), "model.m2"),
])
def test_bad_robot_file_refused_and_nothing_run(tmp_path, edit, field):
    bad = tmp_path / "bad.toml"
    assert edit[0] in GOOD
    bad.write_text(GOOD.replace(edit[0], edit[1], 1))
    with pytest.raises(RobotFileError, match=f"bad.toml: {field.replace('.', '[.]')}"):
        load_robot(bad)
    out = tmp_path / "out"
    r = _cli("run", "paper_five_pushes", "--robot", bad, "--out", out, "--no-progress")
    assert r.returncode == 2, r.stderr
    assert "bad.toml" in r.stderr and field in r.stderr and r.stderr.count("\n") == 1
    assert not out.exists()


def test_urdf_without_feet_refused(tmp_path):
    text = (REPO_ROOT / "hoap2" / "hoap2.urdf").read_text()
    import re
    feetless = re.sub(r"\s*<collision>.*?</collision>", "", text, flags=re.S)
    p = tmp_path / "feetless.urdf"
    p.write_text(feetless)
    out = tmp_path / "feetless.toml"
    r = _cli("robot", "lump", p, "--out", out)
    assert r.returncode == 2 and "feetless.urdf: feet:" in r.stderr, r.stderr
    assert not out.exists()
    # one foot only: refused as well
    one = text.replace('<collision>', '<!--', 1).replace('</collision>', '-->', 1)
    p.write_text(one)
    r = _cli("robot", "lump", p, "--out", out)
    assert r.returncode == 2 and "feet:" in r.stderr and "both sides" in r.stderr, r.stderr


@pytest.mark.parametrize("args,needle", [
    (["--joint", "nosuch=1"], "unknown joints: nosuch"),
    (["--joint", "larm_joint_1=abc"], "--joint larm_joint_1=abc"),
    (["--keyframe", "standing"], "SRDF"),                               # a URDF's postures live in an SRDF
    (["--srdf", "{srdf}", "--keyframe", "nope"], "no group_state named 'nope'"),
    (["--ankle", "lleg_joint_2,rleg_joint_2", "--hip", "lleg_joint_3,rleg_joint_3"], "not the lateral (y) axis"),
    (["--joint", "lleg_joint_5=0.6", "--joint", "rleg_joint_5=0.6"], "outside the sole"),   # leaning: cannot stand
])
def test_bad_lump_options_refused(tmp_path, args, needle):
    srdf = REPO_ROOT / "hoap2" / "hoap2.srdf"
    out = tmp_path / "x.toml"
    r = _cli("robot", "lump", REPO_ROOT / "hoap2" / "hoap2.urdf", "--out", out,
             *[a.format(srdf=srdf) for a in args])
    assert r.returncode == 2 and needle in r.stderr, r.stderr
    assert not out.exists()


def test_lump_cli_writes_a_checked_robot_file(tmp_path):
    out = tmp_path / "h.toml"
    r = _cli("robot", "lump", REPO_ROOT / "hoap2" / "hoap2.xml", "--keyframe", "standing", "--name", "h", "--out", out)
    assert r.returncode == 0, r.stderr
    assert f"wrote {out}" in r.stdout and "lleg_joint_5, rleg_joint_5" in r.stdout
    robot = load_robot(out)
    assert robot.name == "h" and robot.source["format"] == "mjcf" and robot.source["posture"] == "keyframe 'standing'"
    assert all(q.source for q in robot.model.values())            # every number says where it came from
    r = _cli("robot", "check", out)
    assert r.returncode == 0 and "OK" in r.stdout
    # a plain number (a measurement) is read with its SI unit
    plain = out.read_text().replace("m1 = { value =", "m1 = 1.8\nx_m1 = { value =")
    assert load_robot(out).value("m1") == pytest.approx(lump_py.lumped()["m1"], rel=1e-12)
    assert "unknown quantity" in str(pytest.raises(RobotFileError, lambda: _write_load(tmp_path, plain)).value)


def _write_load(tmp_path, text):
    p = tmp_path / "plain.toml"
    p.write_text(text)
    return load_robot(p)
