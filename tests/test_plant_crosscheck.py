"""Independent cross-check of the HOAP-2 plant's multibody equations against Pinocchio (`pin`).

Establishes: at random states (foot floating, arbitrary joint angles and velocities, servo torques
and a push) the plant's mass matrix M(q), bias forces h(q, qd) (Coriolis/centrifugal + gravity)
and the push's generalized force equal those of the same chain built in Pinocchio (a rigid-body
library from PyPI that shares no code with the plant), and the flat-mode ground reaction
(Fx, Fz, moment about the ankle, hence the centre of pressure) satisfies Pinocchio's inverse
dynamics and the momentum balance m * a_com = F_ground + F_push + m g.

The plant's numbers come from its native dump tool `plant_dump` (built with the plant library).
"""
from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

RTOL = 1e-10


def _pin_model(p):
    """Pinocchio chain: PX, PZ (ankle position), RY foot pitch, RY ankle, RY hip (q = x z phi th1 th2)."""
    model = pin.Model()
    model.gravity.linear = np.array([0.0, 0.0, -p["g"]])
    eye = pin.SE3.Identity()
    jx = model.addJoint(0, pin.JointModelPX(), eye, "x")
    jz = model.addJoint(jx, pin.JointModelPZ(), eye, "z")
    jf = model.addJoint(jz, pin.JointModelRY(), eye, "foot_pitch")

    def inertia(m, com, iyy):
        # planar motion about y: only Iyy matters; Ixx, Izz set to the same value for a valid tensor
        return pin.Inertia(m, np.array(com), np.diag([iyy, iyy, iyy]))

    model.appendBodyToJoint(jf, inertia(p["feet_mass"], [p["feet_com_x"], 0, p["feet_com_z"] - p["ankle_height"]],
                                        p["feet_inertia"]), eye)
    ja = model.addJoint(jf, pin.JointModelRY(), eye, "ankle")
    model.appendBodyToJoint(ja, inertia(p["m1"], [0, 0, p["lg1"]], p["I1"]), eye)
    jh = model.addJoint(ja, pin.JointModelRY(), pin.SE3(np.eye(3), np.array([0, 0, p["l1"]])), "hip")
    model.appendBodyToJoint(jh, inertia(p["m2"], [0, 0, p["lg2"]], p["I2"]), eye)
    d_push = p["h_push"] - p["ankle_height"] - p["l1"]
    fid = model.addFrame(pin.Frame("push", jh, 0, pin.SE3(np.eye(3), np.array([0, 0, d_push])), pin.FrameType.OP_FRAME))
    return model, fid


def _states(n, seed=12345):
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(n):
        q = [rng.uniform(-0.1, 0.1), rng.uniform(0.0, 0.06), rng.uniform(-0.3, 0.3), rng.uniform(-0.6, 0.6),
             rng.uniform(-1.0, 1.0)]
        qd = list(rng.uniform(-2.0, 2.0, 5))
        refs = [q[3] + rng.uniform(-0.2, 0.2), q[4] + rng.uniform(-0.2, 0.2)]
        push = rng.uniform(-30, 30)
        rows.append(q + qd + refs + [push])
    return rows


@pytest.fixture(scope="module")
def dump(native_tool):
    tool = native_tool("plant_dump")
    rows = _states(60)
    text = "\n".join(" ".join(repr(float(v)) for v in r) for r in rows) + "\n"
    out = subprocess.run([str(tool)], input=text, capture_output=True, text=True, check=True, timeout=60).stdout
    lines = [json.loads(l) for l in out.splitlines() if l.strip()]
    return lines[0]["params"], rows, lines[1:]


def test_mass_matrix_bias_and_push_match_pinocchio(dump):
    """M(q), h(q, qd) and the push's generalized force agree with Pinocchio to ~1e-10 (relative)."""
    p, rows, res = dump
    model, fid = _pin_model(p)
    data = model.createData()
    assert len(res) == len(rows) == 60
    for r, d in zip(rows, res):
        q, v, push = np.array(r[:5]), np.array(r[5:10]), r[12]
        M_pin = pin.crba(model, data, q)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        h_pin = pin.rnea(model, data, q, v, np.zeros(5))
        M = np.array(d["M"]).reshape(5, 5)
        h = np.array(d["h"])
        np.testing.assert_allclose(M, M_pin, rtol=RTOL, atol=RTOL * np.abs(M_pin).max())
        np.testing.assert_allclose(h, h_pin, rtol=RTOL, atol=RTOL * np.abs(h_pin).max())
        # push: J_push^T (F, 0, 0) from Pinocchio's frame Jacobian (world-aligned)
        J = pin.computeFrameJacobian(model, data, q, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        Q_push_pin = J[0, :] * push
        Q = np.array(d["Q"])
        np.testing.assert_allclose(Q[:3], Q_push_pin[:3], rtol=RTOL, atol=1e-12 * max(1.0, abs(push)))
        # the CoM agrees as well
        com = pin.centerOfMass(model, data, q)
        np.testing.assert_allclose(d["com"], [com[0], com[2]], rtol=RTOL, atol=1e-13)


def test_flat_mode_ground_reaction_matches_pinocchio(dump):
    """Flat mode (foot fixed): Pinocchio's inverse dynamics with the plant's joint accelerations
    reproduces the servo torques (joint rows) and the plant's ground reaction (foot rows); the
    reaction forces satisfy the momentum balance of the whole robot; the CoP follows."""
    p, rows, res = dump
    model, fid = _pin_model(p)
    data = model.createData()
    mass = p["feet_mass"] + p["m1"] + p["m2"]
    for r, d in zip(rows, res):
        q = np.array(r[:5])
        v = np.array(r[5:10])
        v[:3] = 0.0  # flat mode: foot at rest
        q[1] = p["ankle_height"]
        q[2] = 0.0
        push = r[12]
        # recompute the plant's flat-mode quantities at this flat state
        d = _dump_one(dump_tool_cache["tool"], list(q) + list(v) + r[10:13])
        a = np.array(d["qdd_flat"])
        assert np.all(a[:3] == 0.0)
        Q = np.array(d["Q"])
        Qc = np.array(d["Qc_flat"])
        tau_id = pin.rnea(model, data, q, v, a)  # generalized forces that produce qdd
        scale = np.abs(tau_id).max()
        # joint rows: applied torques (servo + push) produce exactly these accelerations
        np.testing.assert_allclose(tau_id[3:], Q[3:], rtol=RTOL, atol=RTOL * scale)
        # foot rows: ground reaction = required generalized force - applied (push) force
        np.testing.assert_allclose(Qc[:3], tau_id[:3] - Q[:3], rtol=RTOL, atol=RTOL * scale)
        assert np.all(Qc[3:] == 0.0)
        # momentum balance with Pinocchio's CoM acceleration
        pin.centerOfMass(model, data, q, v, a)
        acom = data.acom[0]
        Fx, Fz, MA = Qc[0], Qc[1], Qc[2]
        assert Fx + push == pytest.approx(mass * acom[0], rel=1e-10, abs=1e-9)
        assert Fz == pytest.approx(mass * (acom[2] + p["g"]), rel=1e-10, abs=1e-9)
        # CoP from the reaction (the formula the plant's sensors reproduce in flat mode)
        cop = -(MA + p["ankle_height"] * Fx) / Fz
        cop_pin = -((tau_id[2] - Q[2]) + p["ankle_height"] * (tau_id[0] - Q[0])) / (tau_id[1] - Q[1])
        assert cop == pytest.approx(cop_pin, rel=1e-9, abs=1e-12)


dump_tool_cache: dict = {}


@pytest.fixture(scope="module", autouse=True)
def _tool(native_tool):
    dump_tool_cache["tool"] = native_tool("plant_dump")


def _dump_one(tool, row):
    out = subprocess.run([str(tool)], input=" ".join(repr(float(x)) for x in row) + "\n", capture_output=True,
                         text=True, check=True, timeout=30).stdout.splitlines()
    return json.loads(out[1])
