"""``anklehip robot ...``: lump a URDF or MJCF into a robot file, check one, show its scaled gains
(docs/your-robot.md).

    anklehip robot lump FILE [--out ROBOT.toml] [--keyframe NAME [--srdf SRDF]] [--joint NAME=VALUE ...]
                             [--forward +x|-x|+y|-y] [--ankle L,R --hip L,R] [--sole-tolerance M] [--name N]
    anklehip robot check ROBOT.toml
    anklehip robot scale ROBOT.toml [--controller-config NAME] [--json]

Exit status 2 with one line naming the file and the field for a description or robot file that
makes no physical sense; nothing is written then.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

from .robotfile import RobotFileError


def _pair(text: str, option: str) -> tuple[str, str]:
    parts = [x.strip() for x in text.split(",")]
    if len(parts) != 2 or not all(parts):
        raise RobotFileError(f"{option} {text}: expected LEFT,RIGHT (two joint names)")
    return parts[0], parts[1]


def _posture(items: list[str] | None) -> dict[str, float]:
    out = {}
    for it in items or []:
        name, eq, val = it.partition("=")
        try:
            v = float(val)
        except ValueError:
            v = math.nan
        if not eq or not name.strip() or not math.isfinite(v):
            raise RobotFileError(f"--joint {it}: expected NAME=VALUE with a finite value [rad or m]")
        out[name.strip()] = v
    return out


def cmd_lump(a) -> int:
    from .lump import lump_file
    robot = lump_file(a.file, posture=_posture(a.joint), keyframe=a.keyframe, srdf=a.srdf, forward=a.forward,
                      ankle=_pair(a.ankle, "--ankle") if a.ankle else None,
                      hip=_pair(a.hip, "--hip") if a.hip else None, sole_tolerance=a.sole_tolerance,
                      name=a.name, package_dirs=dict(_pair_eq(x) for x in a.package_dir or []))
    out = Path(a.out) if a.out else Path(f"{robot.name}.toml")
    robot.write(out, f"Robot file of {robot.name} (docs/your-robot.md): lumped from {Path(a.file).name} by anklehip.")
    print(summary(robot))
    print(f"wrote {out}")
    return 0


def _pair_eq(text: str) -> tuple[str, str]:
    name, eq, d = text.partition("=")
    if not eq or not name or not d:
        raise RobotFileError(f"--package-dir {text}: expected NAME=DIR")
    return name, d


def summary(robot) -> str:
    v = robot.values()
    i = robot.info
    lines = [f"robot {robot.name}: {robot.total_mass:.3f} kg (body {robot.body_mass:.3f} kg, feet {v['feet_mass']:.3f} kg), "
             f"CoM {robot.com_height:.4f} m above the ankle axis, sole {v['heel_x'] * 1000:+.1f} .. "
             f"{v['toe_x'] * 1000:+.1f} mm, ankle axis {v['ankle_height'] * 1000:.1f} mm above the ground"]
    lines.append(f"  m1 {v['m1']:.4f} kg  l1 {v['l1']:.4f} m  lg1 {v['lg1']:.4f} m  I1 {v['I1']:.5g} kg m2   "
                 f"m2 {v['m2']:.4f} kg  lg2 {v['lg2']:.4f} m  I2 {v['I2']:.5g} kg m2")
    if "ankle_joints" in i:
        lines.append(f"  ankle {', '.join(i['ankle_joints'])}; hip {', '.join(i['hip_joints'])}"
                     + (f"; knee (held) {', '.join(i['knee_joints'])}" if i.get("knee_joints") else ""))
    if "com_x" in i:
        lines.append(f"  neglected: whole-body CoM {i['com_x'] * 1000:+.1f} mm, link 1 {i['link1_com_x'] * 1000:+.1f} mm, "
                     f"link 2 {i['link2_com_x'] * 1000:+.1f} mm, hip axis {i['hip_x'] * 1000:+.1f} mm forward of the joint line")
    if "sole_bottom" in i:
        lines.append(f"  ground: {i['ground']}; the feet's collision geometry reaches {i['sole_bottom'] * 1000:+.2f} mm from it")
    srv = ", ".join(f"{k} {q.value:g} {q.unit}" for k, q in robot.servo.items())
    lines.append(f"  servo limits: {srv or 'none in the description (scaled from HOAP-2)'}")
    return "\n".join(lines)


def cmd_check(a) -> int:
    from .robotfile import load_robot
    robot = load_robot(a.robot)
    print(summary(robot))
    print(f"{a.robot}: OK")
    return 0


def cmd_scale(a) -> int:
    from ..running.master import Models
    from .experiment import find_robot, pendulum_time, tipping_forces
    from .robotfile import load_robot
    from .scaling import RULES, scale
    robot = load_robot(find_robot(a.robot))
    models = Models.load(a.fmu_dir)
    c0 = {**models.controller.start_values(), **models.controller.configuration(a.controller_config, "--controller-config")}
    p0 = models.plant.start_values()
    s = scale(robot, c0, p0)
    models.controller.check_overrides(s.controller, f"robot file {a.robot} (scaled)")
    models.plant.check_overrides(s.plant, f"robot file {a.robot} (scaled)")
    tip = tipping_forces(s.plant)
    if a.json:
        print(json.dumps({"robot": robot.name, "pendulum_time_s": pendulum_time(s.controller),
                          "static_tipping_force_N": tip, "controller": s.controller, "plant": s.plant,
                          "how": {f"{k[0]}.{k[1]}": v for k, v in s.how.items()}}, indent=1))
        return 0
    print(summary(robot))
    print(f"  l_g {s.robot.l_g:.4f} m, T_p = sqrt(l_g/g) {s.robot.T_p * 1000:.1f} ms (HOAP-2 {s.anchor.T_p * 1000:.1f} ms); "
          f"static tipping force {tip[0]:.2f} N (back) / {tip[1]:.2f} N (chest) at h_push {s.plant['h_push']:.4f} m")
    print(f"{'FMU':<11}{'parameter':<26}{'HOAP-2':>12}{robot.name:>14}  how")
    for r in RULES:
        anchor = c0 if r.fmu == "controller" else p0
        out = s.controller if r.fmu == "controller" else s.plant
        if r.name in out:
            print(f"{r.fmu:<11}{r.name:<26}{float(anchor[r.name]):>12.6g}{out[r.name]:>14.6g}  {s.how[(r.fmu, r.name)]}")
    print(f"{'plant':<11}{'h_push':<26}{float(p0['h_push']):>12.6g}{s.plant['h_push']:>14.6g}  {s.how[('plant', 'h_push')]}")
    if "feet_offset_mode" in s.controller:
        print(f"{'controller':<11}{'feet_offset_mode':<26}{int(c0['feet_offset_mode']):>12}"
              f"{s.controller['feet_offset_mode']:>14}  {s.how[('controller', 'feet_offset_mode')]}")
    return 0


def register(sub) -> None:
    """Add ``anklehip robot`` to the command line's subparsers."""
    p = sub.add_parser("robot", help="your robot: lump a URDF or MJCF into a robot file, check it, show its "
                                     "scaled gains (docs/your-robot.md)")
    rs = p.add_subparsers(dest="robot_cmd", required=True, metavar="ACTION",
                          help="lump, check or scale; `anklehip robot ACTION --help` lists its options")
    s = rs.add_parser("lump", help="lump a URDF or MJCF into a robot file (TOML, every number with its source)")
    s.add_argument("file", metavar="FILE", help="a URDF (<robot>) or MJCF (<mujoco>) file")
    s.add_argument("--out", metavar="ROBOT.toml", help="the robot file to write (default: <name>.toml)")
    s.add_argument("--name", help="the robot's name (default: the file's stem)")
    s.add_argument("--keyframe", metavar="NAME", help="the standing posture: an MJCF <key name>, or with --srdf an "
                   "SRDF <group_state name> (default: every joint at 0, MJCF: qpos0)")
    s.add_argument("--srdf", metavar="SRDF", help="the SRDF holding the --keyframe of a URDF")
    s.add_argument("--joint", action="append", metavar="NAME=VALUE",
                   help="a joint's value in the posture [rad, or m], on top of --keyframe (repeatable)")
    s.add_argument("--forward", default="+x", choices=("+x", "-x", "+y", "-y"),
                   help="the axis of the description's root frame that points forward (default %(default)s, REP 103; "
                        "iCub's root_link: -x)")
    s.add_argument("--ankle", metavar="LEFT,RIGHT", help="the ankle pitch joints (default: found: the lowest "
                   "joint about the lateral axis of each leg)")
    s.add_argument("--hip", metavar="LEFT,RIGHT", help="the hip pitch joints (default: found: the highest joint "
                   "about the lateral axis below the bodies both legs share)")
    s.add_argument("--sole-tolerance", type=float, default=0.5e-3, metavar="M",
                   help="collision points this close to the lowest one form the sole [m] (default %(default)g)")
    s.add_argument("--package-dir", action="append", metavar="NAME=DIR",
                   help="where package://NAME/ points (default: a folder NAME above the file, or ROS_PACKAGE_PATH)")
    s.set_defaults(fn=cmd_lump)
    s = rs.add_parser("check", help="read a robot file and check that it makes physical sense")
    s.add_argument("robot", metavar="ROBOT.toml", help="the robot file to read (e.g. robots/talos.toml)")
    s.set_defaults(fn=cmd_check)
    s = rs.add_parser("scale", help="the parameters both FMUs get for a robot: its numbers and the scaled gains")
    s.add_argument("robot", metavar="ROBOT", help="a robot file, or a name in robots/ (e.g. hoap2)")
    s.add_argument("--controller-config", default="default", metavar="NAME",
                   help="the named controller configuration scaled (default %(default)s)")
    s.add_argument("--json", action="store_true", help="print every parameter and how it was obtained as JSON")
    s.set_defaults(fn=cmd_scale)
