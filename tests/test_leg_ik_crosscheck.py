"""The leg's closed-form kinematics for any foot pose (controller_c leg_ik.h: ahc_leg_ik_pose,
ahc_leg_fk_pose; docs/controller.md §11.4 "Any foot pose") against Pinocchio (`pin`, a rigid-body
library from PyPI that shares no code with ours) on the robot's own description, hoap2/hoap2.urdf.

Pinocchio places the URDF's leg at joint angles drawn at random (both legs, 1.3 times each joint's
range, knees flexed by 1e-3 rad or more); the foot's pose relative to the trunk is the ankle joint's
frame seen from the hip yaw joint's frame before its rotation. The C library's answers come through
its dump tool `ahc_leg_ik_dump` (controller_c/tools/leg_ik_dump.c). Establishes:

  - the URDF's leg is the library's: at the zero posture the ankle is thigh + shank straight below
    the hip, the foot's axes the trunk's;
  - on the documented branch (|hip pitch|, |ankle roll| < pi/2), the C IK of Pinocchio's pose gives
    back the URDF's joint angles within 1e-9 rad, Pinocchio's forward kinematics at the C angles and
    the C forward kinematics both give the pose back within 1e-9 (m, rotation entries);
  - the limit bits the IK reports are the joints outside the URDF's own limits (an independent copy
    of the proto's), joint for joint, and its singularity bit is set exactly where the hip lies on
    the foot's x axis (within 1e-6 of the leg's length; the ankle roll undetermined).
"""
from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

from conftest import REPO_ROOT

pin = pytest.importorskip("pinocchio")

URDF = REPO_ROOT / "hoap2" / "hoap2.urdf"
# leg_ik.h's joints (AHC_LEG_* order) as the URDF's: trunk -> thigh Rz(yaw) Ry(-hip) Rx(roll) are
# joints 1 (z), 3 (y), 2 (x); the knee Ry(knee) joint 4; shank -> foot Ry(-ankle) Rx(roll) 5 and 6
URDF_JOINT = ("joint_1", "joint_3", "joint_2", "joint_4", "joint_5", "joint_6")
SENSE = np.array([1.0, -1.0, 1.0, 1.0, -1.0, 1.0])
KNEE, HIP_PITCH, ANKLE_ROLL = 3, 1, 5
N = 3000   # random joint vectors per leg


@pytest.fixture(scope="module")
def leg():
    model = pin.buildModelFromUrdf(str(URDF))
    return model, model.createData()


def foot_pose(model, data, side, q_leg):
    """Pinocchio's foot pose relative to the trunk for leg_ik.h's angles q_leg of leg `side`."""
    q = pin.neutral(model)
    ids = [model.getJointId(f"{side}leg_{j}") for j in URDF_JOINT]
    for jid, v in zip(ids, SENSE * q_leg):
        q[model.joints[jid].idx_q] = v
    pin.forwardKinematics(model, data, q)
    hip = data.oMi[model.parents[ids[0]]] * model.jointPlacements[ids[0]]
    rel = hip.inverse() * data.oMi[ids[-1]]
    return rel.translation.copy(), rel.rotation.copy()


def urdf_limits(model, side):
    ids = [model.getJointId(f"{side}leg_{j}") for j in URDF_JOINT]
    lo = np.array([model.lowerPositionLimit[model.joints[i].idx_q] for i in ids])
    hi = np.array([model.upperPositionLimit[model.joints[i].idx_q] for i in ids])
    # in leg_ik.h's senses
    return np.where(SENSE > 0, lo, -hi), np.where(SENSE > 0, hi, -lo)


def c_leg(tool, rows):
    text = "".join(f"{s} " + " ".join(repr(float(x)) for x in (*a, *R.ravel())) + "\n" for s, a, R in rows)
    out = subprocess.run([str(tool)], input=text, capture_output=True, text=True, check=True, timeout=120)
    return [json.loads(line) for line in out.stdout.splitlines()]


def test_zero_posture_is_the_librarys_leg(leg):
    model, data = leg
    nominal = (REPO_ROOT / "hoap2" / "include" / "hoap2" / "nominal.h").read_text()
    thigh = float(nominal.split("#define HOAP2_THIGH ")[1].split()[0])
    shank = float(nominal.split("#define HOAP2_SHANK ")[1].split()[0])
    for side in "lr":
        a, R = foot_pose(model, data, side, np.zeros(6))
        assert np.allclose(a, [0.0, 0.0, -(thigh + shank)], rtol=0, atol=1e-15), a
        assert np.allclose(R, np.eye(3), rtol=0, atol=1e-15), R


def test_ik_and_fk_match_pinocchio(leg, native_tool):
    model, data = leg
    tool = native_tool("ahc_leg_ik_dump")
    rng = np.random.default_rng(30)
    rows, qs, outside = [], [], []
    for k, side in enumerate("lr"):
        lo, hi = urdf_limits(model, side)
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        for _ in range(N):
            q = mid + 1.3 * half * rng.uniform(-1.0, 1.0, 6)
            q[KNEE] = max(q[KNEE], 1e-3)
            if abs(q[HIP_PITCH]) >= 0.5 * np.pi - 1e-3 or abs(q[ANKLE_ROLL]) >= 0.5 * np.pi - 1e-3:
                continue   # off the documented branch: another solution of the same pose
            a, R = foot_pose(model, data, side, q)
            rows.append((k, a, R))
            qs.append(q)
            outside.append(sum(4 << j for j in range(6) if not lo[j] <= q[j] <= hi[j]))
    res = c_leg(tool, rows)
    assert len(res) == len(rows)
    worst_q = worst_pin = worst_c = 0.0
    n_limits = 0
    for (k, a, R), q, bits, r in zip(rows, qs, outside, res):
        qc = np.array(r["q"])
        worst_q = max(worst_q, float(np.max(np.abs(qc - q))))
        a2, R2 = foot_pose(model, data, "lr"[k], qc)
        worst_pin = max(worst_pin, float(np.max(np.abs(a2 - a))), float(np.max(np.abs(R2 - R))))
        worst_c = max(worst_c, float(np.max(np.abs(np.array(r["ankle"]) - a))),
                      float(np.max(np.abs(np.array(r["R"]).reshape(3, 3) - R))))
        assert r["status"] & ~2 == bits, (q.tolist(), r["status"], bits)
        # the singularity bit: the hip (-R' a in the foot's axes) on the foot's x axis, or the gimbal
        h = -R.T @ a
        near = np.hypot(h[1], h[2]) < 1e-6 * 0.2 or np.cos(q[HIP_PITCH]) < 1e-6
        assert bool(r["status"] & 2) == near, (q.tolist(), r["status"], np.hypot(h[1], h[2]))
        n_limits += bits != 0
    print(f"{len(rows)} poses ({n_limits} beyond a limit): IK vs URDF angles {worst_q:.2g} rad, "
          f"Pinocchio FK(IK) {worst_pin:.2g}, C FK vs Pinocchio {worst_c:.2g}")
    assert worst_q <= 1e-9 and worst_pin <= 1e-9 and worst_c <= 1e-9, (worst_q, worst_pin, worst_c)
    assert n_limits > len(rows) // 4   # the limit bits were exercised
