#!/usr/bin/env python3
"""Derive the HOAP-2 nominal numbers from the Webots model and write include/hoap2/nominal.h.

Reads hoap2/webots_hoap2.toml (the proto's masses, centres of mass, inertias and joints, each
with its proto line), places every body in the posture the balance experiments use (all joints at
zero, knees straight, arms hanging: shoulder pitch +pi/2) and lumps the bodies into the sagittal
model of the controller and the plant (docs/hoap2-model.md):

    feet    both ankle-pitch links, both feet and their sole sensors (below the ankle pitch axes)
    link 1  both legs between the ankle and hip pitch axes (hip pitch, hip roll and knee links)
    link 2  everything above the hip pitch axes: torso, waist, hip-yaw links, arms, head

    python3 hoap2/lump.py            print the derivation (per-body table and the lumps)
    python3 hoap2/lump.py --write    regenerate hoap2/include/hoap2/nominal.h and bodies.h
    python3 hoap2/lump.py --check    exit 1 if a committed header differs from the derivation
    python3 hoap2/lump.py --json     the lumps and every body in the robot frame, for other models

Only numpy and the standard library; no project imports (controller, plants and tests read
the generated header or call lumped()).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DATA = HERE / "webots_hoap2.toml"
HEADER = HERE / "include" / "hoap2" / "nominal.h"
BODIES_HEADER = HERE / "include" / "hoap2" / "bodies.h"

# The posture of the balance experiments: every joint at zero except the shoulders' pitch, which
# turns the arms (pointing forward at zero in the proto) down along the trunk.
POSTURE = {"larm_joint_1": math.pi / 2, "rarm_joint_1": math.pi / 2}

FEET = ("ankle_pitch", "foot", "touch")
LINK1 = ("hip_pitch", "hip_roll", "knee")

# Numbers that are not in the proto (cited where they come from).
G = 9.81                  # standard gravity [m/s^2]
SAMPLE_PERIOD = 0.001     # HOAP-2 control period [s] (Nenchev & Nishio 2010: 1 ms)


def rotation(axis, angle: float) -> np.ndarray:
    """Rotation matrix about a unit axis (Rodrigues), right-handed as in Webots."""
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def inertia_matrix(i6) -> np.ndarray:
    """Webots inertiaMatrix [I11 I22 I33, I12 I13 I23] as a symmetric 3x3 matrix."""
    i11, i22, i33, i12, i13, i23 = i6
    return np.array([[i11, i12, i13], [i12, i22, i23], [i13, i23, i33]], float)


def box_inertia(mass: float, size) -> np.ndarray:
    a, b, c = size
    return mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


@dataclass
class Body:
    """One proto body placed in the Robot frame."""
    name: str
    mass: float
    com: np.ndarray         # Robot frame [m]
    inertia: np.ndarray     # about its CoM, Robot-frame axes [kg m^2]
    rot: np.ndarray         # Solid frame -> Robot frame
    origin: np.ndarray      # Solid origin, Robot frame
    joint: dict | None      # the joint to the parent, axis and anchor in the Robot frame


def load(path: Path = DATA) -> dict:
    with open(path, "rb") as f:
        return tomllib.load(f)


def place(data: dict, posture: dict[str, float] = POSTURE) -> dict[str, Body]:
    """Forward kinematics of the proto tree at the given joint positions (default: 0)."""
    unknown = set(posture) - {b["joint"]["name"] for b in data["body"] if "joint" in b}
    if unknown:
        raise ValueError(f"posture names unknown joints: {sorted(unknown)}")
    placed: dict[str, Body] = {}
    for b in data["body"]:   # parents come first in the file
        if b["parent"]:
            p = placed[b["parent"]]
            R0, o0 = p.rot, p.origin
        else:
            R0, o0 = np.eye(3), np.zeros(3)
        R_local = np.eye(3)
        t_local = np.array(b.get("translation", [0, 0, 0]), float)
        joint = None
        if "joint" in b:
            j = b["joint"]
            q = posture.get(j["name"], 0.0)
            anchor = np.array(j["anchor"], float)
            Rj = rotation(j["axis"], q)
            # the child turns about the axis through the anchor (both in the parent's frame)
            t_local = anchor + Rj @ (t_local - anchor)
            R_local = Rj
            joint = {"name": j["name"], "angle": q, "axis": (R0 @ np.asarray(j["axis"], float)).tolist(),
                     "anchor": (o0 + R0 @ anchor).tolist(), "min": j["min"], "max": j["max"]}
        if "rotation" in b:
            *ax, ang = b["rotation"]
            R_local = R_local @ rotation(ax, ang)
        R = R0 @ R_local
        origin = o0 + R0 @ t_local
        if "com" in b:
            com_local = np.array(b["com"], float)
            I_local = inertia_matrix(b["inertia"])
        else:   # Webots: CoM at the bounding box's centre, inertia of that box with that mass
            bb = b["bounding_box"]
            com_local = np.array(bb["translation"], float)
            I_local = box_inertia(b["mass"], bb["size"])
        placed[b["name"]] = Body(b["name"], float(b["mass"]), origin + R @ com_local, R @ I_local @ R.T, R,
                                 origin, joint)
    return placed


@dataclass
class Lump:
    mass: float
    com: np.ndarray       # Robot frame
    Iyy: float            # pitch inertia about its own CoM [kg m^2]


def lump(bodies: list[Body]) -> Lump:
    m = sum(b.mass for b in bodies)
    c = sum(b.mass * b.com for b in bodies) / m
    # pitch (y) inertia: own inertias + parallel axis in the sagittal (x, z) plane
    iyy = sum(b.inertia[1, 1] + b.mass * ((b.com[0] - c[0]) ** 2 + (b.com[2] - c[2]) ** 2) for b in bodies)
    return Lump(m, c, iyy)


def roll_inertia(bodies: list[Body]) -> tuple[float, np.ndarray, float]:
    """Mass, CoM and roll (x) inertia about the own CoM of a group of bodies (parallel axes in the
    frontal y-z plane)."""
    m = sum(b.mass for b in bodies)
    c = sum(b.mass * b.com for b in bodies) / m
    ixx = sum(b.inertia[0, 0] + b.mass * ((b.com[1] - c[1]) ** 2 + (b.com[2] - c[2]) ** 2) for b in bodies)
    return m, c, ixx


def pitch_limits(joint: dict) -> tuple[float, float]:
    """A pitch joint's (min, max) as the sagittal angle theta = -q (axis . y) (docs/controller.md
    conventions): for HOAP-2's axes (0 1 0) the proto's hip pitch range -1.431..+1.239 rad is
    theta2 in -1.239..+1.431 rad (the trunk pitches forward up to 82 deg)."""
    s = -1.0 if joint["axis"][1] > 0 else 1.0
    a, b = sorted((s * joint["min"], s * joint["max"]))
    return a, b


def group_of(name: str) -> str:
    part = name.split("_", 1)[1] if name.startswith(("lleg_", "rleg_")) else ""
    if part in FEET:
        return "feet"
    if part in LINK1:
        return "link1"
    return "link2"


def lumped(data: dict | None = None) -> dict:
    """The sagittal model's nominal numbers (SI), derived from the proto data."""
    data = data or load()
    bodies = place(data)
    groups = {g: lump([b for b in bodies.values() if group_of(b.name) == g]) for g in ("feet", "link1", "link2")}
    # pitch axes: mean of left and right (they differ only in y)
    ankle = np.mean([bodies[f"{s}_ankle_pitch"].joint["anchor"] for s in ("lleg", "rleg")], axis=0)
    hip = np.mean([bodies[f"{s}_hip_pitch"].joint["anchor"] for s in ("lleg", "rleg")], axis=0)
    ankle_height = data["source"]["robot_origin_height"] + ankle[2]   # ankle axis above the ground
    fb = data["foot_box"]
    # toe/heel/width from the foot box; the foot frame's origin is the ankle pitch axis
    toe = fb["translation"][0] + fb["size"][0] / 2
    heel = fb["translation"][0] - fb["size"][0] / 2
    f, l1, l2 = groups["feet"], groups["link1"], groups["link2"]
    # the pitch limits as the sagittal angles: + when the body above the joint pitches forward; the
    # joint turns the lower body (its child) by q about its axis, so theta = -q (axis . y)
    lim = {b.joint["name"]: pitch_limits(b.joint) for b in bodies.values() if b.joint}
    ankle_lim, hip_lim = lim["lleg_joint_5"], lim["lleg_joint_3"]
    if ankle_lim != lim["rleg_joint_5"] or hip_lim != lim["rleg_joint_3"]:
        raise ValueError("left and right pitch limits differ in the proto data")
    frontal = frontal_numbers(bodies)
    return {
        "g": G,
        "m1": l1.mass, "l1": float(hip[2] - ankle[2]), "lg1": float(l1.com[2] - ankle[2]), "I1": l1.Iyy,
        "m2": l2.mass, "lg2": float(l2.com[2] - hip[2]), "I2": l2.Iyy,
        "feet_mass": f.mass, "feet_com_x": float(f.com[0] - ankle[0]),
        "feet_com_z": float(f.com[2] - ankle[2] + ankle_height), "feet_inertia": f.Iyy,
        "toe_x": toe, "heel_x": heel, "ankle_height": float(ankle_height), "sole_width": fb["size"][1],
        "ankle_min": ankle_lim[0], "ankle_max": ankle_lim[1], "hip_min": hip_lim[0], "hip_max": hip_lim[1],
        "sample_period": SAMPLE_PERIOD,
        # neglected by the sagittal models (their links carry the CoM on the joint line), reported:
        "link1_com_x": float(l1.com[0] - ankle[0]), "link2_com_x": float(l2.com[0] - hip[0]),
        "total_mass": sum(b.mass for b in bodies.values()),
        **frontal,
    }


def frontal_numbers(bodies: dict[str, Body]) -> dict:
    """The frontal plane's numbers (docs/controller.md, the frontal plane): where the hips and ankles
    are across, the leg's segments, each leg's link-1 part and link 2 in roll, and the roll and knee
    limits. Lateral positions are given outward from the robot's mid-plane (left and right alike;
    the proto is mirror-symmetric to the digits checked here)."""
    def anchor(side, part):
        return np.array(bodies[f"{side}_{part}"].joint["anchor"])
    out = {}
    for name, part in (("hip_y", "hip_roll"), ("ankle_y", "foot")):
        ys = [abs(anchor(s, part)[1]) for s in ("lleg", "rleg")]
        if abs(ys[0] - ys[1]) > 1e-9:
            raise ValueError(f"left and right {part} axes are not symmetric: {ys}")
        out[name] = ys[0]
    out["thigh"] = float(anchor("lleg", "hip_roll")[2] - anchor("lleg", "knee")[2])
    out["shank"] = float(anchor("lleg", "knee")[2] - anchor("lleg", "foot")[2])
    legs = [roll_inertia([b for b in bodies.values() if b.name.startswith(s) and group_of(b.name) == "link1"])
            for s in ("lleg_", "rleg_")]
    (ml, cl, il), (mr, cr, ir) = legs
    out["link1_com_y"] = float(cl[1] - anchor("lleg", "foot")[1])      # the left leg's, outward +
    out["I1_roll"] = il + ir
    m2, c2, i2 = roll_inertia([b for b in bodies.values() if group_of(b.name) == "link2"])
    out["link2_com_y"] = float(c2[1])
    out["I2_roll"] = i2
    j = {b.joint["name"]: b.joint for b in bodies.values() if b.joint}
    out["ankle_roll_max"] = j["lleg_joint_6"]["max"]
    # the left hip roll turns the thigh about +x: + moves the foot outward (abduction)
    out["hip_abduction_max"], out["hip_adduction_max"] = j["lleg_joint_2"]["max"], -j["lleg_joint_2"]["min"]
    out["knee_min"], out["knee_max"] = j["lleg_joint_4"]["min"], j["lleg_joint_4"]["max"]
    # the left hip yaw turns the thigh about +z: + turns the toes outward
    out["hip_yaw_out_max"], out["hip_yaw_in_max"] = j["lleg_joint_1"]["max"], -j["lleg_joint_1"]["min"]
    return out


# ------------------------------------------------------------------------------------------------
# The generated header: one macro per number, with what it is and how it was derived.

MACROS = [
    ("G", "g", "Gravitational acceleration [m/s^2] (standard gravity; not from the proto)."),
    ("M1", "m1", "Mass of link 1 [kg]: both legs between the ankle and hip pitch axes (hip pitch, hip roll and\n"
                 " * knee links of both legs, knee straight)."),
    ("L1", "l1", "Length of link 1 [m]: ankle pitch axis -> hip pitch axis (knee and ankle anchors 0.1 m each)."),
    ("LG1", "lg1", "Ankle pitch axis -> CoM of link 1, along the link [m]."),
    ("I1", "I1", "Pitch inertia of link 1 about its own CoM [kg m^2] (proto inertias + parallel axes)."),
    ("M2", "m2", "Mass of link 2 [kg]: everything above the hip pitch axes (torso, waist, hip-yaw links, arms,\n"
                 " * head)."),
    ("LG2", "lg2", "Hip pitch axis -> CoM of link 2, along the link [m] (arms hanging)."),
    ("I2", "I2", "Pitch inertia of link 2 about its own CoM [kg m^2] (arms hanging)."),
    ("FEET_MASS", "feet_mass", "Mass of both feet [kg]: ankle-pitch links, feet and sole sensors."),
    ("FEET_COM_X", "feet_com_x", "CoM of the feet, x forward of the ankle axis [m]."),
    ("FEET_COM_Z", "feet_com_z", "CoM of the feet, height above the sole [m]."),
    ("FEET_INERTIA", "feet_inertia", "Pitch inertia of both feet about their CoM [kg m^2]."),
    ("TOE_X", "toe_x", "Toe edge of the sole, x from the ankle axis [m] (foot bounding box)."),
    ("HEEL_X", "heel_x", "Heel edge of the sole, x from the ankle axis [m] (foot bounding box)."),
    ("ANKLE_HEIGHT", "ankle_height", "Height of the ankle pitch axis above the sole [m] (the proto's standing height\n"
                                     " * 0.29 m of the Robot origin minus 0.055 + 0.1 + 0.1)."),
    ("SOLE_WIDTH", "sole_width", "Width of one sole [m] (foot bounding box)."),
    ("ANKLE_MIN", "ankle_min", "Ankle pitch lower limit [rad] (theta1 = -q of lleg/rleg_joint_5)."),
    ("ANKLE_MAX", "ankle_max", "Ankle pitch upper limit [rad]."),
    ("HIP_MIN", "hip_min", "Hip pitch lower limit [rad] (theta2 = -q of lleg/rleg_joint_3: the proto's -max)."),
    ("HIP_MAX", "hip_max", "Hip pitch upper limit [rad] (the proto's -min)."),
    ("LINK1_COM_X", "link1_com_x", "Informational, not used by the sagittal models: CoM of link 1 forward of the ankle-hip\n"
                                   " * line in the proto [m] (the sagittal links carry their CoM on the joint line)."),
    ("LINK2_COM_X", "link2_com_x", "Informational, not used by the sagittal models: CoM of link 2 forward of the hip axis\n"
                                   " * in the proto posture [m]."),
    ("SAMPLE_PERIOD", "sample_period", "Control period of the HOAP-2 [s] (not from the proto)."),
    # the frontal plane (docs/controller.md, the frontal plane; lateral positions outward from the mid-plane)
    ("HIP_Y", "hip_y", "Frontal plane: the hip joints (their yaw, roll and pitch axes meet) across from the mid-plane [m]."),
    ("ANKLE_Y", "ankle_y", "Frontal plane: the ankle joints (pitch and roll axes meet) across from the mid-plane [m];\n"
                           " * the stance width is twice this, each sole centred under its ankle."),
    ("THIGH", "thigh", "Hip axes -> knee axis [m] (knee straight)."),
    ("SHANK", "shank", "Knee axis -> ankle axes [m]; THIGH + SHANK = L1."),
    ("LINK1_COM_Y", "link1_com_y", "Frontal plane: each leg's link-1 CoM outward of its ankle-hip line [m]."),
    ("I1_ROLL", "I1_roll", "Roll inertia of link 1 [kg m^2]: each leg's about its own CoM, both legs summed."),
    ("LINK2_COM_Y", "link2_com_y", "Frontal plane: CoM of link 2 left of the mid-plane [m] (arms hanging)."),
    ("I2_ROLL", "I2_roll", "Roll inertia of link 2 about its own CoM [kg m^2] (arms hanging)."),
    ("ANKLE_ROLL_MAX", "ankle_roll_max", "Ankle roll limit [rad], either way (lleg/rleg_joint_6)."),
    ("HIP_ABDUCTION_MAX", "hip_abduction_max", "Hip roll limit outward (the foot away from the mid-plane) [rad]."),
    ("HIP_ADDUCTION_MAX", "hip_adduction_max", "Hip roll limit inward [rad]."),
    ("KNEE_MIN", "knee_min", "Knee lower limit [rad] (+ = flexed; the proto's lleg_joint_4)."),
    ("KNEE_MAX", "knee_max", "Knee upper limit [rad]."),
    ("HIP_YAW_OUT_MAX", "hip_yaw_out_max", "Hip yaw limit outward (the toes turned away from the mid-plane) [rad]."),
    ("HIP_YAW_IN_MAX", "hip_yaw_in_max", "Hip yaw limit inward [rad]."),
]


def fmt(x: float) -> str:
    """A model number as a C literal: 6 significant digits, a decimal point, negatives in parentheses."""
    s = f"{x:.6g}"
    if "e" not in s and "." not in s:
        s += ".0"
    return f"({s})" if s.startswith("-") else s


def header_text(n: dict | None = None) -> str:
    n = n or lumped()
    src = load()["source"]
    lines = [
        "/*",
        " * hoap2/nominal.h - nominal numbers of the Fujitsu HOAP-2, lumped into the sagittal plane (both",
        " * legs together), SI units. GENERATED by hoap2/lump.py from hoap2/webots_hoap2.toml; do not edit:",
        " * change the data or the script and run `python3 hoap2/lump.py --write` (a test checks it).",
        " *",
        " * The one source of truth for these numbers: the controller's defaults (controller_c), the",
        " * sagittal plant's defaults (plant/) and the 3D plant read this header. Pure C (C99 / C++),",
        " * macros only, no dependencies.",
        " *",
        f" * Source: the Webots model of HOAP-2, {src['repository']} {src['path']}",
        f" * at commit {src['commit']} (\"{src['title'].split(';')[1].strip()}\").",
        " * Posture: all joints at zero (knees straight), arms hanging (shoulder pitch +pi/2).",
        " * Derivation: docs/hoap2-model.md.",
        " *",
        " * Conventions: x forward (toward the toes), z up; x positions from the ankle pitch axis, heights",
        " * from the sole unless stated.",
        " */",
        "#ifndef HOAP2_NOMINAL_H",
        "#define HOAP2_NOMINAL_H",
        "",
    ]
    for macro, key, doc in MACROS:
        lines += [f"/* {doc} */", f"#define HOAP2_{macro} {fmt(n[key])}"]
    lines += [
        "",
        "/* --- derived ------------------------------------------------------------------------------- */",
        "/* Mass of the two-link body above the ankle [kg] (m = m1 + m2 of the paper). */",
        "#define HOAP2_BODY_MASS (HOAP2_M1 + HOAP2_M2)",
        f"/* Total robot mass incl. feet [kg] ({n['total_mass']:.5g} kg, the proto's \"7 kg\"). */",
        "#define HOAP2_TOTAL_MASS (HOAP2_M1 + HOAP2_M2 + HOAP2_FEET_MASS)",
        "/* Erect CoM height of the two-link body above the ankle axis [m]: (m1 lg1 + m2 (l1 + lg2)) / m. */",
        "#define HOAP2_ERECT_COM_Z ((HOAP2_M1 * HOAP2_LG1 + HOAP2_M2 * (HOAP2_L1 + HOAP2_LG2)) / HOAP2_BODY_MASS)",
        "",
        "#endif /* HOAP2_NOMINAL_H */",
        "",
    ]
    return "\n".join(lines)


def c_num(x: float) -> str:
    """A number as a C double literal that reads back to the same double (repr is shortest round-trip)."""
    s = repr(float(x))
    return s if ("." in s or "e" in s or "inf" in s or "nan" in s) else s + ".0"


def bodies_header_text() -> str:
    """hoap2/bodies.h: every proto body placed in the posture, for the 3D plant (full precision)."""
    data = load()
    bodies = place(data)
    parents = {b["name"]: b["parent"] for b in data["body"]}
    src = data["source"]
    v3 = lambda a: "{" + ", ".join(c_num(c) for c in a) + "}"  # noqa: E731
    rows = []
    for b in bodies.values():
        I = b.inertia
        j = b.joint or {"name": "", "angle": 0.0, "axis": [0, 0, 0], "anchor": [0, 0, 0], "min": 0.0, "max": 0.0}
        rows.append(
            f"    {{\"{b.name}\", \"{parents[b.name]}\", {c_num(b.mass)}, {v3(b.com)},\n"
            f"     {v3([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])},\n"
            f"     \"{j['name']}\", {v3(j['axis'])}, {v3(j['anchor'])}, {c_num(j['angle'])}, {c_num(j['min'])}, "
            f"{c_num(j['max'])}}},")
    fb = data["foot_box"]
    lines = [
        "/*",
        " * hoap2/bodies.h - every body of the Fujitsu HOAP-2 Webots model placed in the standing posture,",
        " * for the 3D plant. GENERATED by hoap2/lump.py from hoap2/webots_hoap2.toml; do not edit: change",
        " * the data or the script and run `python3 hoap2/lump.py --write` (a test checks it).",
        " *",
        f" * Source: {src['repository']} {src['path']} at commit {src['commit']}.",
        " * Frame: the Robot node's, x forward, y left, z up, origin at the waist pitch axis",
        f" * ({c_num(data['source']['robot_origin_height'])} m above the ground when standing). Posture: all joints 0, shoulder pitch",
        " * +pi/2 (arms hanging), as hoap2/nominal.h. SI units; full double precision.",
        " */",
        "#ifndef HOAP2_BODIES_H",
        "#define HOAP2_BODIES_H",
        "",
        "typedef struct hoap2_body {",
        "  const char *name;    /* the proto's Solid (DEF) name, as in webots_hoap2.toml */",
        "  const char *parent;  /* the body it hangs from; \"\" = the Robot node (torso) */",
        "  double mass;         /* [kg] */",
        "  double com[3];       /* centre of mass, Robot frame [m] */",
        "  double inertia[6];   /* about the CoM, Robot axes: Ixx Iyy Izz Ixy Ixz Iyz [kg m^2] */",
        "  const char *joint;   /* motor name of the hinge to the parent; \"\" = fixed to the parent */",
        "  double axis[3];      /* hinge axis, Robot frame (the proto's positive sense) */",
        "  double anchor[3];    /* a point of the hinge axis, Robot frame [m] */",
        "  double angle;        /* the hinge's position in the posture [rad] */",
        "  double min, max;     /* the proto's position limits [rad] */",
        "} hoap2_body;",
        "",
        "/* Parents come before their children. */",
        "static const hoap2_body HOAP2_BODIES[] = {",
        *rows,
        "};",
        f"#define HOAP2_NUM_BODIES {len(rows)}",
        "",
        "/* Height of the Robot origin above the ground when standing [m]. */",
        f"#define HOAP2_ROBOT_ORIGIN_HEIGHT {c_num(data['source']['robot_origin_height'])}",
        "/* Bounding box of each foot (the contact geometry), in the foot's frame: origin on the ankle",
        " * pitch axis, centre and size [m]. */",
        f"#define HOAP2_FOOT_BOX_CENTER {v3(fb['translation'])}",
        f"#define HOAP2_FOOT_BOX_SIZE {v3(fb['size'])}",
        "",
        "#endif /* HOAP2_BODIES_H */",
        "",
    ]
    return "\n".join(lines)


def report(n: dict) -> str:
    data = load()
    bodies = place(data)
    out = [f"{'body':<22}{'group':<7}{'mass':>10}{'x':>10}{'y':>10}{'z':>10}{'Iyy':>12}"]
    for b in bodies.values():
        out.append(f"{b.name:<22}{group_of(b.name):<7}{b.mass:>10.6f}{b.com[0]:>10.5f}{b.com[1]:>10.5f}"
                   f"{b.com[2]:>10.5f}{b.inertia[1, 1]:>12.3e}")
    out.append("")
    w = max(len(k) for k in n)
    out += [f"{k:<{w}} = {v:.6g}" for k, v in n.items()]
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--write", action="store_true", help="regenerate include/hoap2/nominal.h")
    g.add_argument("--check", action="store_true", help="exit 1 if the header is stale")
    g.add_argument("--json", action="store_true", help="print the lumps and all placed bodies as JSON")
    a = ap.parse_args(argv)
    n = lumped()
    generated = {HEADER: header_text(n), BODIES_HEADER: bodies_header_text()}
    if a.write:
        for path, text in generated.items():
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
            print(f"wrote {path}")
    elif a.check:
        stale = [p for p, text in generated.items() if not p.is_file() or p.read_text() != text]
        for p in stale:
            print(f"{p} is stale: run python3 hoap2/lump.py --write", file=sys.stderr)
        if stale:
            return 1
        print(f"{', '.join(p.name for p in generated)} match the derivation")
    elif a.json:
        bodies = place(load())
        print(json.dumps({"sagittal": n, "posture": POSTURE,
                          "bodies": {k: {"mass": b.mass, "com": b.com.tolist(), "inertia": b.inertia.tolist(),
                                         "origin": b.origin.tolist(), "joint": b.joint} for k, b in bodies.items()}},
                         indent=1))
    else:
        print(report(n))
    return 0


if __name__ == "__main__":
    sys.exit(main())
