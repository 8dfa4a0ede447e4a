#!/usr/bin/env python3
"""The stepping layer on the 3D plant, measured (docs/controller.md §12.4).

Back pushes (0.2 s and 1 s pulses, 50 ms ramps, at the trunk's push point, from 1 s; runs of 6 s) on
paper_five_pushes_3d's base, run with the 3D controller:

1. flat-footed (stepping on, its thresholds out of reach and the lean rule off, so that the layer
   only estimates): the range of the capture point's x that each push produced and whether the
   robot stood. The pushes that stand keep the capture point inside the soles: the evidence for
   the decision's thresholds (and the trunk's largest forward lean, for step_trigger_lean's);
2. stepping on, the layer's defaults (or --set NAME=VALUE ...): the outcome, the steps landed, where
   the first step landed against where it was sent, the fastest joint set point rate asked of the
   servos during the swing (Hoap2Plant3D's vel_max is 5 rad/s), and how long the swing knee's set
   point stays straight from the swing's start (the foot lifts off then);
3. side (90 deg) and diagonal (45 and 30 deg: back and left) pushes, stepping on and flat-footed
   (stepping on, its thresholds out of reach, the lean rule off): the outcome and the steps landed.

    .venv/bin/python scripts/stepping_trials.py [--config NAME] [--set NAME=VALUE ...]
    .venv/bin/python scripts/stepping_trials.py --sweep NAME=V1,V2,... [--set ...]
    .venv/bin/python scripts/stepping_trials.py --map [--set ...]
    .venv/bin/python scripts/stepping_trials.py --map --sweep NAME=V1,V2,... [--set ...]
    .venv/bin/python scripts/stepping_trials.py --landing [--set ...]
    .venv/bin/python scripts/stepping_trials.py --touchdown [--set ...]
    .venv/bin/python scripts/stepping_trials.py --swing [--set ...]
    .venv/bin/python scripts/stepping_trials.py --lasting [--ablation] [--set ...]

--map: the boundary (the largest force below which every 1 N step stands) of back pushes of each
duration, flat-footed (the 3D controller's defaults, stepping off) and with stepping, and their ratio.

--sweep: one stepping parameter over its values (the others as --set or the defaults), on 0.2 s back
pushes of 20-30 N: a table of the outcome (S stood, F fell) and the steps landed per force.

--map --sweep NAME=V1,...: the boundaries with stepping for each value of one parameter (a row each),
under the flat-footed ones.

--landing: 1 s back pushes of 8-20 N with stepping: when the layer decided and when its first step
landed, after the push onset, against the LIP's one-step bound for a first step landing then
(docs/capability.md §9.2: anklehip.analysis.bounds.n_step_force_limit with dt_first), where the
centre of pressure lay against the bound's (at the toe: the feet's before the decision, the stance
sole's alone in the swing, and how long its heel carried nothing), and how far
the pushed pendulum's capture point (the plant's CoM, xi = c + c'/omega, plus u = F h_push / (m g))
lay beyond the landed sole's toe at the landing, when the swing sole first carried a fifth of the
weight (which may be before the layer counts the landing), the range of the layer's push_moment
estimate from the decision on against the plant's push moment, and the time the pushed pendulum left
from the decision to land a step of step_length_max (the ZMP at the stance toe, the push at its peak)
against the time the layer took; then the same with the decision set 100 ms after the onset
(step_trigger_time), whatever the layer's rules.

--swing: 1 s back pushes of 8-20 N with stepping: the first swing as the plant's joints and IMU put it
(hoap2/hoap2.urdf's legs through Pinocchio, as tests/test_leg_ik_crosscheck.py maps them; the trunk's
attitude from the IMU), from the swing's start to the swing sole's first load (a fifth of the weight)
or the layer's landing: how high the swing sole's lowest corner rose above the stance sole's, its
largest pitch toes down relative to the stance sole, the stance sole's own largest pitch toes down
(rolling onto its toe edge), how far the trunk pitched forward meanwhile,
and where the swing ankle was, ahead of the stance ankle, when the sole came down against where the
layer sent it.

--lasting: 1 s back pushes with scenarios/step_lasting_push_3d.toml's settings (the 3D controller's
configuration lasting_push, docs/controller.md §12.6; runs of 8 s): stood or fell for every force of 8-24 N, with the push's
ramps of 20, 50 and 100 ms and onsets at 1, 1.011 and 1.37 s; then 19-23 N on plant variants (the
contacts 4 times stiffer and softer, both ODE steps 16 times shorter, noisy load cells, friction 0.6);
with --ablation, then, one at a time, each of the settings back at the layer's default: how many of
those 153 pushes stand (some 15 minutes).

--touchdown: what the first landing does to the robot, over back pushes around the stepping boundary
of each duration: the time no sole touches the ground after it, the largest sole load within 0.3 s of
it, and the largest change of a joint set point in one tick after it.

Runs on the native engine in well under a minute.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from anklehip.files.paths import find_scenario  # noqa: E402
from anklehip.files.scenario import PushProfile, PushSegment, load_scenario  # noqa: E402
from anklehip.running import native  # noqa: E402
from anklehip.running.fmu import FMUError  # noqa: E402
from anklehip.running.master import Models, simulate  # noqa: E402

FLAT = [(14, 0.2), (17, 0.2), (19, 0.2), (20, 0.2), (21, 0.2), (22, 0.2), (-10, 0.2), (-13, 0.2), (-14, 0.2),
        (8, 1.0), (9, 1.0), (10, 1.0), (-6, 1.0), (-7, 1.0)]
STEPPING = [(20, 0.2), (21, 0.2), (22, 0.2), (23, 0.2), (24, 0.2), (26, 0.2), (10, 1.0), (12, 1.0)]
MAP_DURATIONS = (0.15, 0.2, 0.3, 0.5, 1.0)
SIDEWAYS = [(90, 20), (90, 24), (90, 28), (90, 32), (45, 20), (45, 24), (45, 28), (45, 32), (30, 20), (30, 24), (30, 26),
            (30, 28), (30, 32)]  # (direction [deg], force [N]), 0.2 s
JOINTS = ("hip_yaw", "hip", "hip_roll", "knee", "ankle", "ankle_roll")
ONSET = 1.0  # every push's onset [s]
# --touchdown: per duration [s], the forces [N] from the flat-footed boundary to past the stepping one
TOUCHDOWN_FORCES = {0.15: (28, 44), 0.2: (20, 32), 0.3: (15, 21), 0.5: (11, 14), 1.0: (10, 12)}


def run(scenario, models, engine, force, duration, overrides, angle=0.0, *, onset=ONSET, rise=0.05, stop_time=6.0,
        plant=None):
    a = np.radians(angle)
    push, push_y = (PushProfile.from_segments([PushSegment("pulse", t=onset, force=float(f), duration=duration, rise=rise)])
                    for f in (force * np.cos(a), force * np.sin(a)))
    sc = dataclasses.replace(scenario, controller_model="3d", push=push, stop_time=stop_time,
                             **({"push_y": push_y} if angle else {}))
    return simulate(sc, models, controller_overrides=overrides, plant_overrides=plant, progress=False, engine=engine)


def col(d, name):
    for n in (name, "controller." + name):
        if n in d.dtype.names:
            return d[n]
    raise KeyError(name)


def set_point(d, side, joint):
    """The joint's set point: the both-legs output plus the per-leg one (Hoap2Plant3D's rule)."""
    per_leg = col(d, f"q_{side}_{joint}_ref")
    both = {"hip": "theta_hip_ref", "ankle": "theta_ankle_ref"}.get(joint)
    return per_leg + col(d, both) if both else per_leg


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="a stepping (or any controller) parameter for part 2")
    ap.add_argument("--config", metavar="NAME",
                    help="the controller's named configuration (e.g. lasting_push, docs/controller.md §12.6) under "
                         "any --set")
    ap.add_argument("--sweep", metavar="NAME=V1,V2,...",
                    help="one parameter over these values, on 0.2 s back pushes of 20-30 N; with --map, the boundaries "
                         "per value (nothing else runs)")
    ap.add_argument("--landing", action="store_true",
                    help="1 s back pushes: the decision's and the first landing's time against the one-step bound "
                         "(nothing else runs)")
    ap.add_argument("--touchdown", action="store_true",
                    help="pushes around the stepping boundary: flight, load and set-point steps after the first "
                         "landing (nothing else runs)")
    ap.add_argument("--swing", action="store_true",
                    help="1 s back pushes: the first swing's clearance, foot pitch and reach from the plant's joints "
                         "(nothing else runs)")
    ap.add_argument("--lasting", action="store_true",
                    help="1 s back pushes with scenarios/step_lasting_push_3d.toml's settings over forces, ramps, "
                         "onsets, plant variants and each setting left out (nothing else runs)")
    ap.add_argument("--ablation", action="store_true",
                    help="with --lasting: then each setting back at its default, one at a time (some 15 minutes)")
    ap.add_argument("--map", action="store_true",
                    help="the boundaries of back pushes per duration, flat-footed and with stepping (nothing else runs)")
    args = ap.parse_args(argv)
    extra = {}
    for kv in args.set:
        k, _, v = kv.partition("=")
        extra[k] = float(v)
    scenario = load_scenario(find_scenario("paper_five_pushes_3d"))
    models = Models.load(None, plant_model="3d", controller_model="3d")
    if args.config:
        try:
            named = models.controller.configuration(args.config, "--config")
        except FMUError as e:
            print(f"stepping_trials.py: {e}", file=sys.stderr)
            return 2
        args.set = [f"{k}={v:g}" for k, v in named.items()] + args.set
        extra = {**named, **extra}
    engine = native.default_engine()
    def boundary(duration, overrides):
        force = 1
        while force < 80 and run(scenario, models, engine, force, duration, overrides).outcome == "completed":
            force += 1
        return force - 1

    if args.lasting:
        return lasting(models, engine, extra, args.ablation)
    if args.landing:
        return landing_times(scenario, models, engine, extra, args.set)
    if args.touchdown:
        return touchdowns(scenario, models, engine, extra, args.set)
    if args.swing:
        return swings(scenario, models, engine, {"stepping_enabled": 1, **extra}, args.set)
    if args.map and args.sweep:
        name, _, values = args.sweep.partition("=")
        print("back pushes (50 ms ramps): the boundary, the largest force [N] below which every 1 N step stands, "
              f"with stepping for each {name}" + (f" ({', '.join(args.set)})" if args.set else ""))
        print(f"| {name} | " + " | ".join(f"{d:g} s" for d in MAP_DURATIONS) + " |")
        print("|---|" + "---|" * len(MAP_DURATIONS))
        print("| flat-footed | " + " | ".join(str(boundary(d, {"stepping_enabled": 0})) for d in MAP_DURATIONS) + " |")
        for v in values.split(","):
            over = {"stepping_enabled": 1, **extra, name: float(v)}
            print(f"| {v} | " + " | ".join(str(boundary(d, over)) for d in MAP_DURATIONS) + " |")
        return 0
    if args.map:
        print("back pushes (50 ms ramps): the boundary, the largest force [N] below which every 1 N step stands")
        print("| duration [s] | flat-footed | stepping | stepping / flat-footed |")
        print("|---|---|---|---|")
        for duration in MAP_DURATIONS:
            flat = boundary(duration, {"stepping_enabled": 0})
            step = boundary(duration, {"stepping_enabled": 1, **extra})
            print(f"| {duration:g} | {flat} | {step} | {step / flat:.2f} |")
        return 0
    if args.sweep:
        name, _, values = args.sweep.partition("=")
        forces = range(20, 31)
        print(f"0.2 s back pushes, stepping on{' (' + ', '.join(args.set) + ')' if args.set else ''}: "
              f"S stood, F fell, and the steps landed")
        print(f"| {name} | " + " | ".join(f"{f} N" for f in forces) + " | stood |")
        print("|---|" + "---|" * (len(forces) + 1))
        for v in values.split(","):
            cells = []
            for force in forces:
                r = run(scenario, models, engine, force, 0.2, {"stepping_enabled": 1, **extra, name: float(v)})
                cells.append(("S" if r.outcome == "completed" else "F") + str(int(col(r.data, "steps")[-1])))
            print(f"| {v} | " + " | ".join(cells) + f" | {sum(c[0] == 'S' for c in cells)} |")
        return 0

    print("1. flat-footed: the capture point of the stepping layer's estimate (thresholds out of reach)")
    print("| push [N] | duration [s] | stood | capture point x, min .. max [mm] | trunk lean, largest forward [rad] |")
    print("|---|---|---|---|---|")
    watch = {"stepping_enabled": 1, "step_trigger_x": 1.0, "step_trigger_y": 1.0, "step_trigger_lean": 0.0}
    for force, duration in FLAT:
        r = run(scenario, models, engine, force, duration, watch)
        xi = col(r.data, "capture_point_x")
        lean = col(r.data, "imu_pitch") - col(r.data, "imu_pitch")[0]  # from the pitch at rest
        print(f"| {force:+d} | {duration:g} | {'yes' if r.outcome == 'completed' else 'no, at %.2f s' % r.end_time} | "
              f"{1e3 * xi.min():+.1f} .. {1e3 * xi.max():+.1f} | {lean.max():.2f} |")

    print("\n2. stepping on" + (f" ({', '.join(args.set)})" if args.set else " (the layer's defaults)"))
    print("| push [N] | duration [s] | outcome | steps | first landing x, sent -> landed [mm] | "
          "fastest set point rate in the swing [rad/s] (joint) | swing knee straight from the swing's start [ms] "
          "(its sole's largest load [N]) |")
    print("|---|---|---|---|---|---|---|")
    for force, duration in STEPPING:
        r = run(scenario, models, engine, force, duration, {"stepping_enabled": 1, **extra})
        d = r.data
        phase = col(d, "step_phase")
        land = col(d, "landing_x")
        sent = landed = float("nan")
        swing = np.flatnonzero(phase == 2)
        if swing.size:
            sent = land[swing[-1]]
            after = np.flatnonzero((phase == 3) & (np.arange(len(phase)) > swing[0]))
            if after.size:
                landed = land[after[0]]
        dt = float(d["time"][1] - d["time"][0])
        stepping = phase == 2  # the swing
        fastest, which = 0.0, "-"
        for side in ("left", "right"):
            for joint in JOINTS:
                q = set_point(d, side, joint)
                rate = np.abs(np.diff(q)) / dt
                rate = rate[stepping[1:] & stepping[:-1]]
                if rate.size and rate.max() > fastest:
                    fastest, which = float(rate.max()), f"{side} {joint}"
        print(f"| {force:+d} | {duration:g} | {outcome(r)} | {int(col(d, 'steps')[-1])} | "
              f"{1e3 * sent:.0f} -> {1e3 * landed:.0f} | {fastest:.1f} ({which}) | {straight_swing(d)} |")

    print("\n3. side and diagonal pushes (0.2 s), stepping on" + (f" ({', '.join(args.set)})" if args.set else "")
          + " and flat-footed")
    print("| direction [deg] | push [N] | stepping: outcome, steps | flat-footed: outcome |")
    print("|---|---|---|---|")
    for angle, force in SIDEWAYS:
        r = run(scenario, models, engine, force, 0.2, {"stepping_enabled": 1, **extra}, angle)
        f = run(scenario, models, engine, force, 0.2, watch, angle)
        print(f"| {angle} | {force} | {outcome(r)}, {int(col(r.data, 'steps')[-1])} | {outcome(f)} |")
    return 0


LANDING_FORCES = range(8, 21, 2)


def landing_times(scenario, models, engine, extra, settings) -> int:
    from anklehip.analysis import bounds as B
    from anklehip.files.paths import PLANT_FMU, find_fmu
    from anklehip.running.fmu import FMUInfo
    plant = FMUInfo.load(find_fmu(PLANT_FMU))
    params = B.bounds_parameters(plant.start_values(), B.plant_header(plant.unzipdir))
    robot, (l_max, dt_s) = B.robot_from_plant_params(params), B.step_reach(params)
    for set_time in (None, ONSET + 0.1):
        over = {"stepping_enabled": 1, **extra, **({"step_trigger_time": set_time} if set_time else {})}
        print(("" if set_time is None else "\n") + "1 s back pushes (50 ms ramps), stepping on"
              + (f" ({', '.join(settings)})" if settings else "")
              + ("" if set_time is None else f", the decision at {set_time:g} s (step_trigger_time)")
              + ": times after the push onset [ms]; the bound: the LIP capturable in one step landing then (§9.2)")
        landing_table(scenario, models, engine, over, robot, l_max, dt_s)
    return 0


def landing_table(scenario, models, engine, overrides, robot, l_max, dt_s):
    from anklehip.analysis import bounds as B
    print(f"| push [N] | outcome | decision | first step lands | one-step bound for that landing [N] | landed ahead [mm] "
          f"| before the decision: the feet's CoP within 2.5 mm of the toes [%] "
          f"| stance sole alone: its CoP from its ankle, mean [mm] (toe {1000 * robot.x_toe:.0f}) "
          f"| stance sole alone: its heel unloaded [%] "
          f"| capture point under the push at the landing, beyond the front toe [mm] "
          f"| the swing sole first carries a fifth of the weight [ms] "
          f"| push_moment from the decision to the end, min .. max [N m] (the push's F h_push) "
          f"| from the decision: the time the pushed pendulum leaves to land a step of step_length_max / the layer's "
          f"[ms] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for force in LANDING_FORCES:
        r = run(scenario, models, engine, force, 1.0, overrides)
        t, phase, steps = r.data["time"], col(r.data, "step_phase"), col(r.data, "steps")
        decided, landed = np.flatnonzero(phase != 0), np.flatnonzero(steps >= 1)
        cells = [f"{1000 * (t[i[0]] - ONSET):.0f}" if i.size else "-" for i in (decided, landed)]
        bound = (f"{float(B.n_step_force_limit(robot, 1.0, 0.05, 1, 1, l_max, dt_s, dt_first=t[landed[0]] - ONSET)):.1f}"
                 if landed.size else "-")
        swing = (phase == 2) & (steps == 0)
        ahead = f"{1000 * col(r.data, 'landing_x')[landed[0]]:.0f}" if landed.size else "-"
        zmp, heel = stance_sole_alone(r.data, swing, decided)
        # the LIP bound's ZMP is at the toe from the onset: how much of the flat-footed time before the
        # decision the feet's CoP (zmp_x, from the ankles side by side) was there
        at_toe = "-"
        if decided.size:
            before = (t >= ONSET) & (t < t[decided[0]])
            at_toe = f"{100 * np.mean(col(r.data, 'zmp_x')[before] > robot.x_toe - 0.0025):.0f}"
        # the pushed pendulum's capture point the tick before the layer counts the landing, against the
        # front toe (the landing point plus the sole's toe)
        beyond = "-"
        if landed.size:
            k = landed[0] - 1
            beyond = f"{1000 * (pushed_capture_point(r, k, decided[0], robot.g) - col(r.data, 'landing_x')[landed[0]] - robot.x_toe):+.0f}"
        # the time the pushed pendulum leaves a step of step_length_max from the decision: with the ZMP
        # at the stance toe and the push at its peak, the pushed capture point's distance d beyond the
        # toe grows as d e^(omega T), and the landed toe holds it while d e^(omega T) <= L (both feet
        # side by side at the decision)
        budget = "-"
        if decided.size:
            k = decided[0]
            d = pushed_capture_point(r, k, k, robot.g, force) - robot.x_toe
            L = r.controller_parameters["step_length_max"]
            omega = pendulum_omega(r, k, robot.g)
            took = f"{1000 * (t[landed[0]] - t[k]):.0f}" if landed.size else "-"
            budget = ("no limit" if d <= 0 else f"{1000 * max(np.log(L / d) / omega, 0.0):.0f}") + f" / {took}"
        # the swing sole's first load after lift-off (the plant's load cells, a fifth of the weight: the
        # layer's step_touchdown_fz), which may come before the layer counts the landing (it waits for
        # the foot within step_touchdown_tol of its landing point)
        touch = "-"
        if swing.any():
            k = first_load(r.data, int(np.flatnonzero(swing)[0]))
            if k is not None:
                touch = f"{1000 * (t[k] - ONSET):.0f}"
        # the momentum observer's estimate through the step (docs/controller.md §12.5: the plan keeps the
        # decision's), against the moment the plant applies
        moment = "-"
        if decided.size:
            m = col(r.data, "push_moment")[decided[0]:]
            moment = f"{m.min():+.1f} .. {m.max():+.1f} ({force * r.plant_parameters['h_push']:.1f})"
        print(f"| {force} | {outcome(r)} | {cells[0]} | {cells[1]} | {bound} | {ahead} | {at_toe} | {zmp} | {heel} | {beyond} "
              f"| {touch} | {moment} | {budget} |")


def pendulum_omega(r, k, g):
    """The pendulum's frequency at row k, sqrt(g / z), z the plant's CoM height above the ground (its
    com_z is above the ankles)."""
    return np.sqrt(g / (r.data["com_z"][k] + r.controller_parameters["ankle_height"]))


def pushed_capture_point(r, k, decided, g, force=None):
    """The pushed pendulum's capture point xi + u at row k in the step's frame (the ankles' mid-point at
    the decision row), from the plant's truth (its CoM and the push it applies at h_push; the layer's
    estimates are jolted when a sole touches down): xi = c + c'/omega (c' over the 10 rows before k),
    omega from the CoM's height above the ground, u = F h_push / (m g), where a sole's ZMP must be to
    hold it; F the push at row k, or `force`."""
    t, n = r.data["time"], 10
    # the plant's com_x is from the ankles' mid-point, which moves with the swing foot; the step
    # frame's origin is that mid-point (feet_x, world) when the step was decided
    c = r.data["com_x"] + r.data["feet_x"] - r.data["feet_x"][decided]
    xi = c[k] + (c[k] - c[k - n]) / (t[k] - t[k - n]) / pendulum_omega(r, k, g)
    u = (r.data["push_force"][k] if force is None else force) * r.plant_parameters["h_push"] / r.data["fz"][0]
    return xi + u


def first_load(d, k0):
    """The first row from k0, the start of a swing, at which the swing sole, having lifted (under 1 N),
    carries a fifth of the weight again (the plant's load cells; the layer's step_touchdown_fz): None
    if it does not."""
    load = col(d, "fz_left" if col(d, "swing_side")[k0] == 0 else "fz_right")[k0:]
    lifted = np.flatnonzero(load < 1.0)
    if not lifted.size:
        return None
    down = np.flatnonzero(load[lifted[0]:] > 0.2 * d["fz"][0])
    return k0 + int(lifted[0] + down[0]) if down.size else None


# leg_ik.h's joints (AHC_LEG_* order, the plant's) as hoap2/hoap2.urdf's and their senses
# (tests/test_leg_ik_crosscheck.py, which checks the mapping against the C kinematics to 1e-9)
URDF_JOINT = ("joint_1", "joint_3", "joint_2", "joint_4", "joint_5", "joint_6")
URDF_SENSE = (1.0, -1.0, 1.0, 1.0, -1.0, 1.0)


def urdf_legs():
    """hoap2/hoap2.urdf through Pinocchio: its model, data and, per leg, the configuration indices of
    JOINTS (URDF_JOINT)."""
    import pinocchio as pin
    root = Path(__file__).resolve().parents[1]
    model = pin.buildModelFromUrdf(str(root / "hoap2" / "hoap2.urdf"))
    idx = {side: [model.joints[model.getJointId(f"{side[0]}leg_{j}")].idx_q for j in URDF_JOINT]
           for side in ("left", "right")}
    return model, model.createData(), idx


def measured_pose(legs, d, k):
    """The robot file's legs at row k's measured joints (forward kinematics into legs' data, the trunk's
    frame), and the IMU's attitude R = Ry(pitch) Rx(roll) that turns that frame into the world's."""
    import pinocchio as pin
    model, data, idx = legs
    q = pin.neutral(model)
    for side in ("left", "right"):
        for i, (j, sense) in enumerate(zip(JOINTS, URDF_SENSE)):
            q[idx[side][i]] = sense * col(d, f"q_{side}_{j}")[k]
    pin.framesForwardKinematics(model, data, q)
    roll, pitch = d["imu_roll"][k], d["imu_pitch"][k]
    cr, sr, cp, sp = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch)
    return np.array([[cp, sp * sr, sp * cr], [0.0, cr, -sr], [-sp, cp * sr, cp * cr]])


def swings(scenario, models, engine, overrides, settings) -> int:
    legs = urdf_legs()
    model, data, _ = legs
    sole = {side: model.getFrameId(f"{side[0]}_sole") for side in ("left", "right")}
    print("1 s back pushes (50 ms ramps), stepping on" + (f" ({', '.join(settings)})" if settings else "")
          + ": the first swing from the plant's joints and IMU, from its start to the swing sole's first load "
            "(a fifth of the weight) or the landing; times after the push onset [ms]")
    print("| push [N] | outcome | swing starts | swing sole comes down | its lowest corner above the stance sole's, "
          "highest [mm] | its pitch toes down relative to the stance sole, largest [rad] | the stance sole's pitch toes down, largest [rad] | the trunk's pitch, change "
          "[rad] | swing ankle ahead of the stance ankle when it comes down [mm] | sent to [mm] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for force in LANDING_FORCES:
        r = run(scenario, models, engine, force, 1.0, overrides)
        d, t = r.data, r.data["time"]
        phase, steps = col(d, "step_phase"), col(d, "steps")
        first = np.flatnonzero(phase == 2)
        if not first.size:
            print(f"| {force} | {outcome(r)} | - | - | - | - | - | - | - | - |")
            continue
        k0 = int(first[0])
        swing_side = "left" if col(d, "swing_side")[k0] == 0 else "right"
        stance_side = "right" if swing_side == "left" else "left"
        cp = r.controller_parameters
        corners = np.array([(x, y, 0.0) for x in (cp["toe_x"], cp["heel_x"])
                            for y in (cp["sole_width"] / 2, -cp["sole_width"] / 2)])
        # to the swing sole's first load, or the tick the layer counts the landing (or leaves the swing)
        k1 = first_load(d, k0)
        k1 = len(t) - 1 if k1 is None else k1
        left = np.flatnonzero((phase[k0:] != 2) | (steps[k0:] > 0))
        if left.size:
            k1 = min(k1, k0 + int(left[0]))
        rise, pitch, tip, ahead = -np.inf, -np.inf, -np.inf, np.nan
        for k in range(k0, k1 + 1):
            R = measured_pose(legs, d, k)
            pose = {side: (R @ data.oMf[sole[side]].translation, R @ data.oMf[sole[side]].rotation)
                    for side in ("left", "right")}
            low = {side: min((p + Rs @ c)[2] for c in corners) for side, (p, Rs) in pose.items()}
            rise = max(rise, low[swing_side] - low[stance_side])
            rel = pose[stance_side][1].T @ pose[swing_side][1]
            tip = max(tip, float(np.arcsin(np.clip(-pose[stance_side][1][2, 0], -1.0, 1.0))))
            pitch = max(pitch, float(np.arcsin(np.clip(-rel[2, 0], -1.0, 1.0))))
            ahead = (pose[swing_side][0] - pose[stance_side][0])[0]
        trunk = d["imu_pitch"][k1] - d["imu_pitch"][k0]
        print(f"| {force} | {outcome(r)} | {1000 * (t[k0] - ONSET):.0f} | {1000 * (t[k1] - ONSET):.0f} | "
              f"{1000 * rise:.1f} | {pitch:+.3f} | {tip:+.3f} | {trunk:+.3f} | {1000 * ahead:.0f} | "
              f"{1000 * col(d, 'landing_x')[k1 - 1]:.0f} |")
    return 0


def stance_sole_alone(d, swing, decided) -> tuple[str, str]:
    """In the first swing, while the swing sole carries nothing (< 1 N): the stance sole's centre of
    pressure from its own ankle, mean [mm], and the share of that time its heel cells carry nothing
    (< 1 N: the sole on its toe edge) [%]. The plant's zmp_x is from the ankles' mid-point, which
    moves with the swing foot; the stance ankle stays where the mid-point was at the decision (the
    feet side by side)."""
    if not swing.any():
        return "-", "-"
    swing_side = "left" if col(d, "swing_side")[np.flatnonzero(swing)[0]] == 0 else "right"
    stance = "right" if swing_side == "left" else "left"
    alone = swing & (col(d, f"fz_{swing_side}") < 1.0)
    if not alone.any():
        return "-", "-"
    cop = col(d, "zmp_x") + col(d, "feet_x") - col(d, "feet_x")[decided[0]]
    heel = col(d, f"f_{stance}_rear_left") + col(d, f"f_{stance}_rear_right")
    return f"{1000 * cop[alone].mean():.0f}", f"{100 * np.mean(heel[alone] < 1.0):.0f}"


def straight_swing(d) -> str:
    """How long the first swing's knee set point stays straight (< 0.01 rad) from the swing's start
    [ms], and the largest load its sole carries meanwhile [N]."""
    phase = col(d, "step_phase")
    swing = np.flatnonzero(phase == 2)
    if not swing.size:
        return "-"
    k0 = k = int(swing[0])
    side = "left" if col(d, "swing_side")[k0] == 0 else "right"
    knee, load = set_point(d, side, "knee"), col(d, f"fz_{side}")
    while phase[k] == 2 and knee[k] < 0.01:
        k += 1
    return f"{1000 * (d['time'][k] - d['time'][k0]):.0f} ({float(np.max(load[k0:k], initial=0.0)):.0f})"


def after_landing(d):
    """After the first landing of a run that stepped (None if none landed): the longest time [s] no
    sole touches the ground, the largest sole load [N] within 0.3 s, the largest change of a joint
    set point in one tick [rad] (while the step goes on)."""
    steps, phase, t = col(d, "steps"), col(d, "step_phase"), d["time"]
    if steps[-1] < 1:
        return None
    k = int(np.argmax(steps >= 1))
    dt = float(t[1] - t[0])
    air = np.concatenate(([0], (col(d, "contacts")[k:] == 0).astype(int), [0]))
    edges = np.flatnonzero(np.diff(air))
    flight = float(np.max(edges[1::2] - edges[::2], initial=0)) * dt
    load = float(np.max(np.maximum(col(d, "fz_left"), col(d, "fz_right"))[k:k + int(round(0.3 / dt))]))
    stepping = phase[k:] != 0
    jump = max(float(np.max(np.abs(np.diff(set_point(d, side, joint)[k:]))[stepping[1:]], initial=0.0))
               for side in ("left", "right") for joint in JOINTS)
    return flight, load, jump


def touchdowns(scenario, models, engine, extra, settings) -> int:
    print("back pushes (50 ms ramps) around the stepping boundary, stepping on" + (f" ({', '.join(settings)})" if settings else "")
          + ": after the first landing, the longest time no sole touches the ground, the largest sole load within 0.3 s, "
            "the largest change of a joint set point in one tick")
    print("| duration [s] | pushes [N] | stepped | stood | off the ground > 5 ms | longest off the ground [ms] "
          "| sole load, median / largest [N] | set-point change in a tick, median / largest [rad] |")
    print("|---|---|---|---|---|---|---|---|")
    for duration, (lo, hi) in TOUCHDOWN_FORCES.items():
        rows = []
        for force in range(lo, hi + 1):
            r = run(scenario, models, engine, force, duration, {"stepping_enabled": 1, **extra})
            a = after_landing(r.data)
            if a:
                rows.append((r.outcome == "completed", *a))
        stood, flight, load, jump = (np.array(c) for c in zip(*rows))
        print(f"| {duration:g} | {lo}-{hi} | {len(rows)} | {int(stood.sum())} | {int((flight > 0.005).sum())} | "
              f"{1000 * flight.max():.0f} | {np.median(load):.0f} / {load.max():.0f} | "
              f"{np.median(jump):.3f} / {jump.max():.3f} |")
    return 0


LASTING_FORCES = range(8, 25)
LASTING_PUSHES = [(rise, onset) for rise in (0.02, 0.05, 0.1) for onset in (1.0, 1.011, 1.37)]  # (ramp, onset) [s]
# the plant's contact damping stays critical for its stiffness (docs/plant3d.md: c ~ sqrt(k))
LASTING_PLANTS = {"the default plant": {},
                  "contacts 4x stiffer": {"contact_stiffness": 8e8, "contact_damping": 3.35e5},
                  "contacts 4x softer": {"contact_stiffness": 5e7, "contact_damping": 8.375e4},
                  "ODE steps 1/16 ms": {"internal_step": 6.25e-5, "rocking_step": 6.25e-5},
                  "load cells' noise 0.5 N": {"sensor_noise": 0.5},
                  "friction 0.6": {"mu": 0.6}}


def lasting(models, engine, extra, ablation=False) -> int:
    """1 s back pushes with step_lasting_push_3d's settings (docs/controller.md §12.6)."""
    scenario = load_scenario(find_scenario("step_lasting_push_3d"))
    settings = {**models.controller.configuration(scenario.controller_config), **scenario.controller, **extra}
    def stood(force, overrides, rise=0.05, onset=ONSET, plant=None):
        r = run(scenario, models, engine, force, 1.0, overrides, rise=rise, onset=onset, stop_time=8.0, plant=plant)
        return r.outcome == "completed"

    print(f"1 s back pushes, step_lasting_push_3d's settings (configuration {scenario.controller_config})"
          + (f" and {extra}" if extra else "")
          + ": S stood to 8 s, F fell")
    print("| ramp [ms] | onset [s] | " + " | ".join(f"{f} N" for f in LASTING_FORCES) + " |")
    print("|---|---|" + "---|" * len(LASTING_FORCES))
    for rise, onset in LASTING_PUSHES:
        cells = ["S" if stood(f, settings, rise, onset) else "F" for f in LASTING_FORCES]
        print(f"| {1000 * rise:.0f} | {onset:g} | " + " | ".join(cells) + " |")

    forces = range(19, 24)
    print("\nthe same settings on plant variants (50 ms ramps, onset 1 s)")
    print("| plant | " + " | ".join(f"{f} N" for f in forces) + " |")
    print("|---|" + "---|" * len(forces))
    for name, plant in LASTING_PLANTS.items():
        print(f"| {name} | " + " | ".join("S" if stood(f, settings, plant=plant) else "F" for f in forces) + " |")

    if not ablation:
        return 0
    forces = LASTING_FORCES
    defaults = {name: models.controller.vars[name].start for name in settings}  # the FMU's start values
    def count(overrides):
        return sum(stood(f, overrides, rise, onset) for rise, onset in LASTING_PUSHES for f in forces)
    print("\neach setting back at the layer's default, one at a time: how many of the "
          f"{len(LASTING_PUSHES) * len(forces)} pushes of {forces[0]}-{forces[-1]} N (the ramps and onsets above) stand")
    print("| setting | its value -> the default | stood |")
    print("|---|---|---|")
    print(f"| none | - | {count(settings)} |")
    for name, value in settings.items():
        if name == "stepping_enabled":
            continue
        print(f"| `{name}` | {value:g} -> {defaults[name]:g} | {count({**settings, name: defaults[name]})} |")
    return 0


def outcome(r) -> str:
    return "stood" if r.outcome == "completed" else f"fell at {r.end_time:.2f} s"


if __name__ == "__main__":
    sys.exit(main())
