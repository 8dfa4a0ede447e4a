"""Lumping a humanoid into the sagittal model of the controller and the sagittal plant: the rule of
hoap2/lump.py (docs/hoap2-model.md section 2), for any URDF or MJCF (docs/your-robot.md).

    feet    everything below the ankle pitch axes (the subtrees of both ankle pitch joints)
    link 1  both legs between the ankle and hip pitch axes (the subtrees of the hip pitch joints
            without the feet)
    link 2  everything else: everything above the hip pitch axes

Each lump's mass, CoM and pitch inertia about its own CoM (every body's inertia in the world frame
plus m ((x - x_c)^2 + (z - z_c)^2)); lengths from the pitch axes: l1 and lg1 above the ankle axis,
lg2 above the hip axis (both the mean of left and right), the feet's CoM forward of the ankle axis
and above the sole. The sole: the feet's collision geometry (boxes, spheres, cylinders, the convex
hull of a mesh) within `sole_tolerance` of its lowest point; toe and heel are its extreme x from
the ankle axis. The ground: the world's plane (MJCF), else the sole frames (REP 120: l_sole,
r_sole; links or sites named *_sole*), else the lowest point of the feet's collision geometry.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .description import Body, Description, load_description
from .robotfile import Quantity, Robot, RobotFileError, check_physics

G = 9.81                   # standard gravity [m/s^2]; the description does not say
SAMPLE_PERIOD = 0.001      # control period [s] unless given (the paper's 1 ms)
PITCH_COS = 1 - 1e-6       # a joint is a pitch joint when |axis . y| exceeds this
SOLE_TOLERANCE = 0.5e-3    # [m] collision points this close to the lowest one form the sole
FOOT_SEARCH = 0.005        # [m] bodies whose geometry reaches this close to the lowest point touch the ground


@dataclass
class Lump:
    mass: float
    com: np.ndarray
    Iyy: float                 # pitch inertia about its own CoM


def lump(bodies: list[Body]) -> Lump:
    """Mass, CoM and pitch inertia of a set of bodies (hoap2/lump.py's lump()). The sums are exactly
    rounded (math.fsum), so the result does not depend on the bodies' order: callers pass sets, whose
    order follows Python's hash seed, and a last-bit change there made IPOPT stop the one-step
    optimum on a different iterate from one run to the next (docs/capability.md section 9.3)."""
    m = math.fsum(b.mass for b in bodies)
    if not m > 0:
        return Lump(0.0, np.zeros(3), 0.0)
    c = np.array([math.fsum(b.mass * b.com[i] for b in bodies) for i in range(3)]) / m
    iyy = math.fsum(b.inertia[1, 1] + b.mass * ((b.com[0] - c[0]) ** 2 + (b.com[2] - c[2]) ** 2) for b in bodies)
    return Lump(m, c, float(iyy))


@dataclass
class Legs:
    """The pitch joints of both legs (left first) and the lumps' body names."""
    ankle: tuple[str, str]
    hip: tuple[str, str]
    knees: list[str]
    feet: list[str]
    link1: list[str]
    link2: list[str]
    contact: tuple[list[str], list[str]]      # bodies whose collision geometry touches the ground


def _joint_body(d: Description) -> dict[str, str]:
    return {b.joint.name: n for n, b in d.bodies.items() if b.joint is not None}


def find_legs(d: Description, ankle: tuple[str, str] | None = None, hip: tuple[str, str] | None = None) -> Legs:
    """The ankle and hip pitch joints of both legs: on the way from each foot (a body touching the
    ground) up to the bodies both legs share, the first and the last joint turning about y.
    `ankle`, `hip` (left, right joint names) override the search."""
    where = str(d.path)
    pts = [(n, b.points) for n, b in d.bodies.items() if len(b.points)]
    if not pts:
        raise RobotFileError(f"{where}: feet: no collision geometry at all: a robot file needs the feet's "
                             "geometry (the sole: box, sphere, cylinder or mesh)")
    zmin = min(float(p[:, 2].min()) for _, p in pts)
    touching = [n for n, p in pts if p[:, 2].min() <= zmin + FOOT_SEARCH]
    sides = ([n for n in touching if _mean_y(d.bodies[n]) > 0], [n for n in touching if _mean_y(d.bodies[n]) < 0])
    jb = _joint_body(d)
    if ankle is None or hip is None:
        if not sides[0] or not sides[1]:
            raise RobotFileError(
                f"{where}: feet: the lowest collision geometry ({', '.join(touching)}) is not on both sides "
                "(y > 0 and y < 0): a humanoid standing on two feet is needed (is --forward right? are the "
                "feet's collision shapes there?)")
        paths = [d.path_to_root(s[0]) for s in sides]
        shared = set(paths[0]) & set(paths[1])
        found = []
        for path in paths:
            leg = []
            for n in path:
                if n in shared:
                    break
                j = d.bodies[n].joint
                if j is not None and j.kind in ("revolute", "continuous") and abs(j.axis[1]) > PITCH_COS:
                    leg.append(j.name)
            if len(leg) < 2:
                raise RobotFileError(
                    f"{where}: legs: between the foot {path[0]} and the body both legs share, "
                    f"{len(leg)} joint(s) turn about the lateral (y) axis; an ankle and a hip pitch joint are "
                    "needed (give them with --ankle LEFT,RIGHT --hip LEFT,RIGHT)")
            found.append(leg)
        ankle = ankle or (found[0][0], found[1][0])
        hip = hip or (found[0][-1], found[1][-1])
        knees = found[0][1:-1] + found[1][1:-1]
    else:
        knees = []
    for role, names in (("ankle", ankle), ("hip", hip)):
        for n in names:
            if n not in jb:
                raise RobotFileError(f"{where}: --{role} {n}: no such joint (or a fixed one)")
            j = d.bodies[jb[n]].joint
            if abs(j.axis[1]) <= PITCH_COS:
                raise RobotFileError(f"{where}: --{role} {n}: its axis {np.round(j.axis, 6).tolist()} is not the "
                                     "lateral (y) axis in this posture")
    feet = sorted({x for a in ankle for x in d.subtree(jb[a])})
    legs = sorted({x for h in hip for x in d.subtree(jb[h])} - set(feet))
    if not set(feet) <= {x for h in hip for x in d.subtree(jb[h])}:
        raise RobotFileError(f"{where}: --ankle/--hip: the ankle joints must lie below the hip joints")
    rest = [n for n in d.bodies if n not in feet and n not in legs]
    for s, side in zip(sides, ("left", "right")):
        for n in s:
            if n not in feet:
                raise RobotFileError(f"{where}: feet: {n} touches the ground but is not below the ankle pitch "
                                     f"joints {', '.join(ankle)} ({side} side)")
    return Legs(tuple(ankle), tuple(hip), knees, feet, legs, rest, sides)


def _mean_y(b: Body) -> float:
    return float(b.points[:, 1].mean()) if len(b.points) else float(b.com[1])


def _theta_limits(j, where: str, role: str) -> tuple[float, float, str]:
    """The joint's limits as the sagittal angle (+ = the body above pitches forward): the child is
    the lower body, so theta = -q (axis . y)."""
    s = -1.0 if j.axis[1] > 0 else 1.0
    if j.lower is None or j.upper is None or j.kind == "continuous":
        return -math.pi, math.pi, f"{j.name}: no position limits in the description: +-pi"
    a, b = sorted((s * j.lower, s * j.upper))
    sign = "theta = -q" if s < 0 else "theta = q"
    return a, b, f"{j.name} limits [{j.lower:g}, {j.upper:g}] rad, {sign} (axis {'+' if s < 0 else '-'}y)"


def lump_description(d: Description, ankle=None, hip=None, sole_tolerance: float = SOLE_TOLERANCE,
                     name: str | None = None, g: float = G, sample_period: float = SAMPLE_PERIOD) -> Robot:
    """The robot file of a description in its posture."""
    where = str(d.path)
    legs = find_legs(d, ankle, hip)
    B = d.bodies
    jb = _joint_body(d)
    aj = [B[jb[n]].joint for n in legs.ankle]
    hj = [B[jb[n]].joint for n in legs.hip]
    ankle_p = np.mean([j.anchor for j in aj], axis=0)
    hip_p = np.mean([j.anchor for j in hj], axis=0)
    f, l1, l2 = (lump([B[n] for n in names]) for names in (legs.feet, legs.link1, legs.link2))
    for lp, what in ((l1, "link1"), (l2, "link2")):
        if not lp.mass > 0:
            raise RobotFileError(f"{where}: {what}: no mass between the joints that bound it")

    # the sole: the feet's collision geometry near its lowest point
    fpts = [B[n].points for n in legs.feet if len(B[n].points)]
    P = np.vstack(fpts)
    zc = float(P[:, 2].min())
    sole = P[P[:, 2] <= zc + sole_tolerance]
    widths = []
    for side in (legs.contact[0], legs.contact[1]):
        sp = np.vstack([B[n].points for n in side]) if side else np.zeros((0, 3))
        sp = sp[sp[:, 2] <= zc + sole_tolerance] if len(sp) else sp
        if len(sp):
            widths.append(float(sp[:, 1].max() - sp[:, 1].min()))
    feet_soles = {k: v for k, v in d.sole_frames.items() if _owner(d, k) in legs.feet}
    if d.ground_z is not None:
        ground, gsrc = d.ground_z, d.ground_source
    elif feet_soles:
        ground = float(np.mean([v[2] for v in feet_soles.values()]))
        gsrc = f"the sole frames {', '.join(sorted(feet_soles))} (REP 120)"
    else:
        ground, gsrc = zc, "the lowest point of the feet's collision geometry"
    ankle_height = float(ankle_p[2] - ground)
    toe, heel = float(sole[:, 0].max() - ankle_p[0]), float(sole[:, 0].min() - ankle_p[0])

    fb = ", ".join(legs.feet)
    q = Quantity
    ax = f"mean of {legs.ankle[0]} and {legs.ankle[1]}"
    hx = f"mean of {legs.hip[0]} and {legs.hip[1]}"
    lim = {}
    for role, js in (("ankle", aj), ("hip", hj)):
        lo, hi, srcs = [], [], []
        for j in js:
            a, b, s = _theta_limits(j, where, role)
            lo.append(a), hi.append(b), srcs.append(s)
        lim[role] = (max(lo), min(hi), "; ".join(srcs) + ("" if len(set(zip(lo, hi))) == 1 else
                                                           " (left and right differ: the narrower range)"))
    model = {
        "g": q(g, "m/s2", "standard gravity (not in the description)"),
        "m1": q(l1.mass, "kg", f"sum of the masses of {', '.join(legs.link1)}"),
        "l1": q(float(hip_p[2] - ankle_p[2]), "m", f"hip pitch axes ({hx}) above the ankle pitch axes ({ax})"),
        "lg1": q(float(l1.com[2] - ankle_p[2]), "m", "CoM of link 1 above the ankle pitch axes"),
        "I1": q(l1.Iyy, "kg.m2", "link 1: each body's inertia (world axes) + m ((x - x_c)^2 + (z - z_c)^2)"),
        "m2": q(l2.mass, "kg", f"sum of the masses of the {len(legs.link2)} bodies above the hip pitch axes"),
        "lg2": q(float(l2.com[2] - hip_p[2]), "m", "CoM of link 2 above the hip pitch axes"),
        "I2": q(l2.Iyy, "kg.m2", "link 2: each body's inertia (world axes) + m ((x - x_c)^2 + (z - z_c)^2)"),
        "feet_mass": q(f.mass, "kg", f"sum of the masses of {fb}"),
        "feet_com_x": q(float(f.com[0] - ankle_p[0]), "m", "CoM of the feet forward of the ankle pitch axes"),
        "feet_com_z": q(float(f.com[2] - ground), "m", f"CoM of the feet above the ground ({gsrc})"),
        "feet_inertia": q(f.Iyy, "kg.m2", "feet: each body's inertia (world axes) + m ((x - x_c)^2 + (z - z_c)^2)"),
        "toe_x": q(toe, "m", f"foremost point of the feet's collision geometry within {sole_tolerance * 1000:g} mm "
                             "of its lowest point, from the ankle axes"),
        "heel_x": q(heel, "m", "hindmost point of that sole, from the ankle axes"),
        "ankle_height": q(ankle_height, "m", f"ankle pitch axes ({ax}) above the ground ({gsrc})"),
        "sole_width": q(float(np.mean(widths)) if widths else 0.0, "m",
                        "lateral extent of one foot's sole points (mean of left and right)"),
        "ankle_min": q(lim["ankle"][0], "rad", lim["ankle"][2]),
        "ankle_max": q(lim["ankle"][1], "rad", lim["ankle"][2]),
        "hip_min": q(lim["hip"][0], "rad", lim["hip"][2]),
        "hip_max": q(lim["hip"][1], "rad", lim["hip"][2]),
        "sample_period": q(sample_period, "s", "the paper's 1 ms (not in the description)"),
    }
    servo = {}
    for role, js in (("ankle", aj), ("hip", hj)):
        eff = [j.effort for j in js]
        if all(e is not None and e > 0 for e in eff):
            servo[f"tau_max_{role}"] = q(float(sum(eff)), "N.m", " + ".join(f"{j.name} effort {j.effort:g}" for j in js))
        vel = [j.velocity for j in js]
        if all(v is not None and v > 0 for v in vel):
            servo[f"vel_max_{role}"] = q(float(min(vel)), "rad/s", ", ".join(f"{j.name} velocity {j.velocity:g}" for j in js))

    whole = lump(list(B.values()))
    info = {
        "total_mass": whole.mass,
        "com_x": float(whole.com[0] - ankle_p[0]),
        "com_height": float(whole.com[2] - ground),
        "link1_com_x": float(l1.com[0] - ankle_p[0]),
        "link2_com_x": float(l2.com[0] - hip_p[0]),
        "hip_x": float(hip_p[0] - ankle_p[0]),
        "sole_bottom": float(zc - ground),
        "ground": gsrc,
        "ankle_joints": list(legs.ankle),
        "hip_joints": list(legs.hip),
        "knee_joints": legs.knees,
        "feet": legs.feet,
        "link1": legs.link1,
        "link2": legs.link2,
        "notes": [
            "neglected by the sagittal models (their links carry the CoM on the joint line): link1_com_x, "
            "link2_com_x (CoM forward of the ankle / hip axis), hip_x (hip axis forward of the ankle axis)",
            *d.notes,
        ],
    }
    if not heel <= info["com_x"] <= toe:
        raise RobotFileError(
            f"{where}: posture ({d.posture_source}): the whole-body CoM lies {info['com_x'] * 1000:.1f} mm from the "
            f"ankle axes, outside the sole [{heel * 1000:.1f}, {toe * 1000:.1f}] mm: the robot cannot stand there")
    digest = hashlib.sha256(Path(d.path).read_bytes()).hexdigest()
    source = {"file": Path(d.path).name, "sha256": digest, "format": d.kind, "posture": d.posture_source,
              "sole_tolerance": sole_tolerance}
    robot = Robot(name or Path(d.path).stem, model, servo, info, source)
    check_physics(robot, where)
    return robot


def _owner(d: Description, sole_name: str) -> str:
    """The body a sole frame belongs to (a URDF link is itself a body; an MJCF site is not: its
    nearest body by position)."""
    if sole_name in d.bodies:
        return sole_name
    p = d.sole_frames[sole_name]
    return min(d.bodies, key=lambda n: float(np.linalg.norm(d.bodies[n].origin - p)))


def lump_file(path: str | Path, posture: dict[str, float] | None = None, keyframe: str | None = None,
              srdf: str | Path | None = None, forward: str = "+x", ankle=None, hip=None,
              sole_tolerance: float = SOLE_TOLERANCE, name: str | None = None,
              package_dirs: dict[str, str] | None = None, sample_period: float = SAMPLE_PERIOD) -> Robot:
    """Lump a URDF or MJCF into a robot file (anklehip.robot.Robot; .write(path) writes it).

    posture: joint -> value [rad, m] on top of `keyframe` (an MJCF <key>, or an SRDF <group_state>
    with `srdf`); other joints at 0. forward: the description's forward axis (+x, -x, +y, -y).
    ankle, hip: (left, right) pitch joint names, found by default. Raises RobotFileError naming the
    file and the field."""
    if not (math.isfinite(sole_tolerance) and 0 <= sole_tolerance <= 0.05):
        raise RobotFileError(f"--sole-tolerance {sole_tolerance}: must be a finite length in [0, 0.05] m")
    if not (math.isfinite(sample_period) and sample_period > 0):
        raise RobotFileError(f"sample_period {sample_period}: must be a finite time > 0 s")
    d = load_description(path, posture, keyframe, srdf, forward, package_dirs)
    robot = lump_description(d, ankle, hip, sole_tolerance, name, sample_period=sample_period)
    robot.source["forward"] = forward
    if srdf:
        robot.source["srdf"] = Path(srdf).name
    return robot
