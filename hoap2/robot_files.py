#!/usr/bin/env python3
"""Write the HOAP-2's robot descriptions and its robot file from hoap2/webots_hoap2.toml.

No URDF or MJCF of the HOAP-2 is published; these are generated from the same transcription of the
Webots proto as hoap2/include/hoap2/nominal.h (docs/hoap2-model.md), with the same numbers:

    hoap2/hoap2.urdf    every body (mass, CoM, inertia), every hinge (axis, limits, the proto's
                        maxTorque / maxVelocity as effort / velocity), the feet's bounding boxes as
                        collision geometry, sole frames l_sole / r_sole (REP 120) on the ground of
                        the proto's standing height
    hoap2/hoap2.srdf    the standing posture of the balance experiments, group_state "standing"
                        (arms hanging: shoulder pitch +pi/2)
    hoap2/hoap2.xml     the same robot as MJCF: free-floating torso at the proto's standing height
                        over a floor plane, keyframe "standing"
    robots/hoap2.toml   the robot file (docs/your-robot.md) with the numbers of nominal.h, which the
                        FMUs' defaults are: `anklehip run ... --robot hoap2` is today's run

    python3 hoap2/robot_files.py --write    regenerate them
    python3 hoap2/robot_files.py --check    exit 1 if a committed file differs

Link frames: the proto's Solid frames moved to their hinge's anchor (the two coincide in the
HOAP-2), axes of the parent Solid; a Solid's own rotation (the sole sensors) goes into its
inertia. Numbers are written in full precision (repr), so lumping the URDF reproduces
hoap2/lump.py's derivation to rounding.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
import lump as L  # noqa: E402  (hoap2/lump.py: the transcription and its rules)

URDF = HERE / "hoap2.urdf"
SRDF = HERE / "hoap2.srdf"
MJCF = HERE / "hoap2.xml"
ROBOT = ROOT / "robots" / "hoap2.toml"
SOLES = {"lleg_foot": "l_sole", "rleg_foot": "r_sole"}      # REP 120 frame names
POSTURE_NAME = "standing"


def num(x: float) -> str:
    """A number in full precision, no '-0'."""
    x = float(x)
    if x == 0:
        return "0"
    s = repr(x)
    return s[:-2] if s.endswith(".0") else s


def vec(v) -> str:
    return " ".join(num(x) for x in v)


def frames(data: dict) -> dict:
    """Per body: its link frame relative to the parent's (origin xyz in the parent link frame,
    rotation R_p of the parent's Solid) and the Solid's offset and rotation in its own link frame."""
    out = {}
    for b in data["body"]:
        R_s = np.eye(3)
        if "rotation" in b:
            *ax, ang = b["rotation"]
            R_s = L.rotation(ax, ang)
        t = np.array(b.get("translation", [0, 0, 0]), float)
        anchor = np.array(b["joint"]["anchor"], float) if "joint" in b else t
        out[b["name"]] = {"R": R_s, "off": t - anchor, "anchor": anchor}
    for b in data["body"]:
        f = out[b["name"]]
        if b["parent"]:
            p = out[b["parent"]]
            f["xyz"] = p["off"] + p["R"] @ f["anchor"]
            f["R_joint"] = p["R"]
        else:
            f["xyz"], f["R_joint"] = np.zeros(3), np.eye(3)
    return out


def inertial(b: dict, f: dict) -> tuple[np.ndarray, np.ndarray]:
    """CoM in the link frame and the inertia about it (link axes), as hoap2/lump.py places them."""
    if "com" in b:
        com, I = np.array(b["com"], float), L.inertia_matrix(b["inertia"])
    else:      # Webots: the bounding box's centre and the inertia of that box with that mass
        com, I = np.array(b["bounding_box"]["translation"], float), L.box_inertia(b["mass"], b["bounding_box"]["size"])
    R = f["R"]
    return f["off"] + R @ com, R @ I @ R.T


def rpy(R: np.ndarray) -> np.ndarray:
    """URDF roll, pitch, yaw of a rotation matrix (R = Rz(y) Ry(p) Rx(r))."""
    p = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    return np.array([math.atan2(R[2, 1], R[2, 2]), p, math.atan2(R[1, 0], R[0, 0])])


def quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    w = math.sqrt(max(0.0, 1 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    return np.array([w, x, y, z])


def ankle_height(data: dict) -> float:
    """The ankle pitch axis above the ground in the proto's standing height (hoap2/lump.py)."""
    return L.lumped(data)["ankle_height"]


def header(kind: str, data: dict) -> list[str]:
    """The XML comment at the top (no double hyphen inside: XML forbids it in comments)."""
    src = data["source"]
    a, b = "<!--", "-->"
    return [f"{a} The Fujitsu HOAP-2, {kind}. GENERATED by hoap2/robot_files.py from hoap2/webots_hoap2.toml, the",
            f"     numbers of the Webots model {src['repository']} {src['path']} at commit",
            f"     {src['commit']} (docs/hoap2-model.md). Do not edit: change the data or the script",
            "     and rerun hoap2/robot_files.py with its write option (a test checks it).",
            "     x forward, y left, z up; SI units. The standing posture of the balance experiments (arms",
            f"     hanging) is the {'SRDF group_state' if kind == 'URDF' else 'keyframe'} \"{POSTURE_NAME}\". {b}"]


def urdf_text(data: dict | None = None) -> str:
    data = data or L.load()
    F = frames(data)
    m = data["motors"]
    fb = data["foot_box"]
    ah = ankle_height(data)
    out = ['<?xml version="1.0"?>', *header("URDF", data),
           '<robot name="hoap2">']
    for b in data["body"]:
        f = F[b["name"]]
        com, I = inertial(b, f)
        out += [f'  <link name="{b["name"]}">',
                "    <inertial>",
                f'      <origin xyz="{vec(com)}" rpy="0 0 0"/>',
                f'      <mass value="{num(b["mass"])}"/>',
                f'      <inertia ixx="{num(I[0, 0])}" ixy="{num(I[0, 1])}" ixz="{num(I[0, 2])}" '
                f'iyy="{num(I[1, 1])}" iyz="{num(I[1, 2])}" izz="{num(I[2, 2])}"/>',
                "    </inertial>"]
        if b["name"] in SOLES:
            out += ["    <collision>",
                    f'      <origin xyz="{vec(f["off"] + f["R"] @ np.array(fb["translation"], float))}" '
                    f'rpy="{vec(rpy(f["R"]))}"/>',
                    f'      <geometry><box size="{vec(fb["size"])}"/></geometry>',
                    "    </collision>"]
        out.append("  </link>")
        if b["parent"]:
            j = b.get("joint")
            jn = j["name"] if j else f"{b['name']}_fixed"
            out.append(f'  <joint name="{jn}" type="{"revolute" if j else "fixed"}">')
            out += [f'    <parent link="{b["parent"]}"/>', f'    <child link="{b["name"]}"/>',
                    f'    <origin xyz="{vec(f["xyz"])}" rpy="{vec(rpy(f["R_joint"]))}"/>']
            if j:
                out += [f'    <axis xyz="{vec(j["axis"])}"/>',
                        f'    <limit lower="{num(j["min"])}" upper="{num(j["max"])}" effort="{num(m["max_torque"])}" '
                        f'velocity="{num(m["max_velocity"])}"/>']
            out.append("  </joint>")
    for foot, sole in SOLES.items():      # massless frames on the ground (REP 120)
        f = F[foot]
        out += [f'  <link name="{sole}"/>',
                f'  <joint name="{sole}_fixed" type="fixed">', f'    <parent link="{foot}"/>',
                f'    <child link="{sole}"/>', f'    <origin xyz="{vec(f["off"] + np.array([0, 0, -ah]))}" rpy="0 0 0"/>',
                "  </joint>"]
    out += ["</robot>", ""]
    return "\n".join(out)


def srdf_text(data: dict | None = None) -> str:
    data = data or L.load()
    joints = [b["joint"]["name"] for b in data["body"] if "joint" in b]
    out = ['<?xml version="1.0"?>', *header("URDF", data),
           '<robot name="hoap2">', '  <group name="whole_body">']
    out += [f'    <joint name="{j}"/>' for j in joints]
    out += ["  </group>", f'  <group_state name="{POSTURE_NAME}" group="whole_body">']
    out += [f'    <joint name="{j}" value="{num(L.POSTURE.get(j, 0.0))}"/>' for j in joints]
    out += ["  </group_state>", "</robot>", ""]
    return "\n".join(out)


def mjcf_text(data: dict | None = None) -> str:
    data = data or L.load()
    F = frames(data)
    m = data["motors"]
    fb = data["foot_box"]
    ah = ankle_height(data)
    height = data["source"]["robot_origin_height"]
    kids: dict[str, list[dict]] = {}
    for b in data["body"]:
        kids.setdefault(b["parent"], []).append(b)
    joints: list[str] = []

    def body(b: dict, depth: int) -> list[str]:
        ind = "  " * depth
        f = F[b["name"]]
        com, I = inertial(b, f)
        pos = f["xyz"] + (np.array([0, 0, height]) if not b["parent"] else 0)
        lines = [f'{ind}<body name="{b["name"]}" pos="{vec(pos)}" quat="{vec(quat(f["R_joint"]))}">']
        if not b["parent"]:
            lines.append(f'{ind}  <freejoint name="root"/>')
        lines.append(f'{ind}  <inertial pos="{vec(com)}" mass="{num(b["mass"])}" '
                     f'fullinertia="{vec([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])}"/>')
        if "joint" in b:
            j = b["joint"]
            joints.append(j["name"])
            lines.append(f'{ind}  <joint name="{j["name"]}" type="hinge" pos="0 0 0" axis="{vec(j["axis"])}" '
                         f'range="{num(j["min"])} {num(j["max"])}" '
                         f'actuatorfrcrange="{num(-m["max_torque"])} {num(m["max_torque"])}"/>')
        if b["name"] in SOLES:
            c = f["off"] + f["R"] @ np.array(fb["translation"], float)
            lines.append(f'{ind}  <geom name="{b["name"]}_box" type="box" size="{vec(np.array(fb["size"]) / 2)}" '
                         f'pos="{vec(c)}" quat="{vec(quat(f["R"]))}"/>')
            lines.append(f'{ind}  <site name="{SOLES[b["name"]]}" pos="{vec(f["off"] + np.array([0, 0, -ah]))}"/>')
        for c in kids.get(b["name"], []):
            lines += body(c, depth + 1)
        lines.append(f"{ind}</body>")
        return lines

    tree = body(kids[""][0], 2)
    qpos = [0.0, 0.0, height, 1.0, 0.0, 0.0, 0.0] + [L.POSTURE.get(j, 0.0) for j in joints]
    hdr = header("MJCF", data)
    out = ['<?xml version="1.0"?>', *hdr, '<mujoco model="hoap2">',
           '  <compiler angle="radian" autolimits="true" inertiafromgeom="false"/>',
           '  <option gravity="0 0 -9.81"/>',
           "  <worldbody>",
           '    <geom name="floor" type="plane" size="0 0 0.05"/>', *tree, "  </worldbody>",
           "  <keyframe>", f'    <key name="{POSTURE_NAME}" qpos="{vec(qpos)}"/>', "  </keyframe>",
           "</mujoco>", ""]
    return "\n".join(out)


def robot_text() -> str:
    """robots/hoap2.toml: nominal.h's numbers (the FMUs' defaults), each with its derivation."""
    sys.path.insert(0, str(ROOT))
    from anklehip.robot.robotfile import MODEL, SERVO, Quantity, Robot
    data = L.load()
    n = L.lumped(data)
    header = {key: macro for macro, key, _ in L.MACROS}
    doc = {key: d.replace("\n *", "").strip() for _, key, d in L.MACROS}

    def nominal(key: str) -> Quantity:
        # the header's literal (6 significant digits), so that the FMUs' defaults are these numbers
        return Quantity(float(L.fmt(n[key]).strip("()")), MODEL[key].unit,
                        f"nominal.h HOAP2_{header[key]}: {doc[key]}")
    model = {k: nominal(k) for k in MODEL if k in header}
    model["sole_width"] = nominal("sole_width") if "sole_width" in header else \
        Quantity(float(data["foot_box"]["size"][1]), "m", "foot bounding box (webots_hoap2.toml foot_box.size)")
    model = {k: model[k] for k in MODEL}
    mt = data["motors"]
    line = {b["joint"]["name"]: b["lines"]["joint"] for b in data["body"] if "joint" in b}
    servo = {}
    for j, motor in (("ankle", "lleg_joint_5"), ("hip", "lleg_joint_3")):
        servo[f"tau_max_{j}"] = Quantity(2 * mt["max_torque"], SERVO[f"tau_max_{j}"].unit,
                                         f"2 motors (lleg/rleg) x maxTorque {num(mt['max_torque'])} N.m "
                                         f"({motor}: proto line {line[motor] + 7})")
        servo[f"vel_max_{j}"] = Quantity(mt["max_velocity"], SERVO[f"vel_max_{j}"].unit,
                                         f"maxVelocity {num(mt['max_velocity'])} rad/s ({motor}: proto line {line[motor] + 4})")
    servo = {k: servo[k] for k in SERVO}
    info = {"total_mass": n["total_mass"], "link1_com_x": n["link1_com_x"], "link2_com_x": n["link2_com_x"],
            "notes": ["the numbers of hoap2/include/hoap2/nominal.h (6 significant digits), the FMUs' defaults: "
                      "lumping hoap2/hoap2.urdf with the standing posture gives the full-precision values"]}
    src = data["source"]
    robot = Robot("hoap2", model, servo, info,
                  {"file": "hoap2/webots_hoap2.toml", "proto": f"{src['repository']} {src['path']} @ {src['commit']}",
                   "posture": "all joints 0, shoulder pitch +pi/2 (arms hanging)", "forward": "+x"})
    return robot.to_toml("The Fujitsu HOAP-2 (robot file, docs/your-robot.md). GENERATED by hoap2/robot_files.py "
                         "from hoap2/webots_hoap2.toml\nthrough hoap2/lump.py; do not edit: run "
                         "`python3 hoap2/robot_files.py --write` (a test checks it).")


def generated() -> dict[Path, str]:
    data = L.load()
    return {URDF: urdf_text(data), SRDF: srdf_text(data), MJCF: mjcf_text(data), ROBOT: robot_text()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--write", action="store_true", help="write the files")
    g.add_argument("--check", action="store_true", help="exit 1 if a committed file is stale")
    a = ap.parse_args(argv)
    files = generated()
    if a.write:
        for p, text in files.items():
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_text(text)
            print(f"wrote {p.relative_to(ROOT)}")
        return 0
    stale = [p for p, t in files.items() if not p.is_file() or p.read_text() != t]
    for p in stale:
        print(f"{p.relative_to(ROOT)} is stale: run python3 hoap2/robot_files.py --write", file=sys.stderr)
    if not stale:
        print(f"{', '.join(p.name for p in files)} match the data")
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
