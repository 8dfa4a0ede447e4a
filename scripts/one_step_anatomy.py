#!/usr/bin/env python3
"""What the one-step optimum does, against what the stepping layer does (docs/capability.md §9.3).

1. The one-step optimum (anklehip.analysis.one_step) of the 1 s back push (50 ms ramps) for the step
   lifting 60 ms after the onset with its sole 10 mm clear over mid-swing and landing 300 ms after
   it, on the 50 ms mesh, warm-started as scripts/one_step_optimum.py's chain starts (from the step
   lifting at the onset, solved from rest); about 30 s. Its motion at mesh points (TIMES) from the onset
   to 1.2 s: the whole robot's CoM ahead of the stance ankle and its height change, the pushed
   pendulum's capture point xi + u ahead of the stance ankle (xi = c + c'/omega, omega = sqrt(g / c_z),
   u = F h / (m g) with the push then), the upper body's pitch (+ forward), the stance ankle's and
   knee's angles and the swing ankle's place.
2. The stepping layer on the 3D plant (Hoap2Plant3D, the 3D controller with stepping on; its defaults,
   or --set NAME=VALUE ...) under the same push at --force N (default 16 N): the same quantities
   from the plant's truth at the same times (the stance ankle is the ankles' mid-point at the onset:
   the feet stand side by side; the joints as measured, the trunk's pitch from the IMU), up to a fall,
   and the layer's landing point, both soles' loads and the trunk's roll.

    .venv/bin/python scripts/one_step_anatomy.py [--force N] [--set NAME=VALUE ...]
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from anklehip.analysis import one_step as os_  # noqa: E402
from anklehip.analysis.bounds import is_step_forward  # noqa: E402
from anklehip.analysis.flat_footed import push_shape  # noqa: E402
import stepping_trials as st  # noqa: E402  (scripts/: the plant runs and the Pinocchio legs)

DURATION, RISE, T_AFTER, DT = 1.0, 0.05, 0.5, 0.05   # as scripts/one_step_optimum.py's coarse mesh
T_LIFT, T_LAND, CLEARANCE = 0.06, 0.3, 0.01           # its second series' 300 ms point
TIMES = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.6, 0.8, 1.0, 1.2)


def optimum():
    bp = os_.hoap2()
    seed = os_.solve(bp, DURATION, RISE, 0.0, T_LAND, t_after=T_AFTER, dt=DT)
    sol = os_.solve(bp, DURATION, RISE, T_LIFT, T_LAND, t_after=T_AFTER, dt=DT, guess=seed, clearance=CLEARANCE)
    if not (sol.ok or "Acceptable" in sol.status) or not is_step_forward(True, sol.landing):
        raise SystemExit(f"one_step_anatomy: the optimum did not converge to a step forward ({sol.status}, "
                         f"landing {sol.landing:.3f} m)")
    return bp, sol


def optimum_rows(bp, sol):
    mdl = os_.model(bp)
    Jm = os_.joint_map()
    rows = []
    com0 = None
    for t in TIMES:
        k = int(np.argmin(abs(sol.t - t)))
        if abs(sol.t[k] - t) > 1e-9:
            continue
        x = np.concatenate([sol.phi[k], sol.dphi[k]])
        ankle, _, com, _ = (np.asarray(v, float).ravel() for v in mdl.points(x))
        eps = 1e-6   # the CoM's rate along the motion, by a forward difference
        com_e = np.asarray(mdl.points(np.concatenate([sol.phi[k] + eps * sol.dphi[k], sol.dphi[k]]))[2], float).ravel()
        rate = (com_e - com) / eps
        com0 = com if com0 is None else com0
        omega = math.sqrt(bp.g / com[1])
        u = sol.f_peak * float(push_shape(t, DURATION, RISE)) * bp.push_height / (bp.mass * bp.g)
        q = Jm @ sol.phi[k]
        hip = bp.shank_length * math.sin(sol.phi[k][0]) + bp.thigh_length * math.sin(sol.phi[k][1])
        rows.append((t, com[0], com[1] - com0[1], com[0] + rate[0] / omega + u, hip, sol.phi[k][2], q[0], q[1],
                     ankle[0], ankle[1] - bp.ankle_height))
    return rows


def stance_hip_ahead(legs, d, k, side):
    """The stance leg's hip pitch axis ahead of its ankle pitch axis [m] at row k, from the plant's measured
    joints and IMU: the robot file's legs through Pinocchio as `stepping_trials.py --swing` reads them
    (stepping_trials.measured_pose; tests/test_leg_ik_crosscheck.py checks the joints' map)."""
    model, data, _ = legs
    R = st.measured_pose(legs, d, k)
    at = lambda j: data.oMi[model.getJointId(f"{side[0]}leg_{j}")].translation
    return float((R @ (at("joint_3") - at("joint_5")))[0])   # hip pitch (joint_3) over ankle pitch (joint_5)


def layer_rows(force, settings):
    from anklehip.files.paths import find_scenario
    from anklehip.files.scenario import load_scenario
    from anklehip.running import native
    from anklehip.running.master import Models
    scenario = load_scenario(find_scenario("paper_five_pushes_3d"))
    models = Models.load(None, plant_model="3d", controller_model="3d")
    r = st.run(scenario, models, native.default_engine(), force, DURATION, {"stepping_enabled": 1, **settings})
    d = r.data
    t = d["time"] - st.ONSET
    k0 = int(np.argmin(abs(t)))
    g = r.controller_parameters["g"]
    swing = st.col(d, "swing_side")
    legs = st.urdf_legs()
    stance = None
    rows = []
    for tt in TIMES:
        k = int(np.argmin(abs(t - tt)))
        if abs(t[k] - tt) > 1e-6:   # the run ended (a fall)
            break
        if stance is None and swing[k] >= 0:
            stance = "right" if swing[k] == 0 else "left"
        side = stance or "left"
        c = d["com_x"][k] + d["feet_x"][k] - d["feet_x"][k0]
        rows.append((tt, c, d["com_z"][k] - d["com_z"][k0], st.pushed_capture_point(r, k, k0, g),
                     stance_hip_ahead(legs, d, k, side), d["imu_pitch"][k],
                     st.col(d, f"q_{side}_ankle")[k], st.col(d, f"q_{side}_knee")[k], st.col(d, "steps")[k],
                     st.col(d, "landing_x")[k], d[f"fz_{side}"][k], d["fz_left" if side == "right" else "fz_right"][k],
                     d["imu_roll"][k]))
    return r, rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--force", type=float, default=16.0, help="the push on the layer [N] (default 16)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="a controller parameter")
    args = ap.parse_args(argv)
    settings = {}
    for kv in args.set:
        k, _, v = kv.partition("=")
        try:
            settings[k] = float(v)
        except ValueError:
            print(f"one_step_anatomy: --set {kv!r}: need NAME=NUMBER", file=sys.stderr)
            return 2
    try:   # the plant first: a wrong setting is refused before the solve
        r, rows = layer_rows(args.force, settings)
    except (KeyError, ValueError) as e:
        print(f"one_step_anatomy: {e}", file=sys.stderr)
        return 2
    bp, sol = optimum()
    print(f"The one-step optimum: {sol.f_peak:.2f} N, the step lifting {1000 * T_LIFT:.0f} ms after the onset "
          f"(sole {1000 * CLEARANCE:.0f} mm clear), landing {1000 * T_LAND:.0f} ms after it "
          f"{1000 * sol.landing:.0f} mm ahead (50 ms mesh; IPOPT: {sol.status}). Times after the onset.")
    print()
    print("| t [ms] | CoM ahead of the stance ankle [mm] | CoM height change [mm] | pushed capture point xi + u ahead "
          "of the stance ankle [mm] | stance hip ahead of its ankle [mm] | upper body pitch [rad] | stance ankle [rad] | stance knee [rad] | "
          "swing ankle ahead [mm] | swing ankle up [mm] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for t, c, dz, xi, hip, pitch, qa, qk, sx, sz in optimum_rows(bp, sol):
        print(f"| {1000 * t:.0f} | {1000 * c:.0f} | {1000 * dz:+.0f} | {1000 * xi:.0f} | {1000 * hip:.0f} | {pitch:+.2f} | {qa:+.2f} | "
              f"{qk:+.2f} | {1000 * sx:.0f} | {1000 * sz:.0f} |")
    end = "stood" if r.outcome != "fell" else f"fell at {r.end_time:.2f} s"
    print()
    print(f"The stepping layer on Hoap2Plant3D, {args.force:g} N ({end}; "
          + (", ".join(args.set) if args.set else "its defaults") + "):")
    print()
    print("| t [ms] | CoM ahead of the stance ankle [mm] | CoM height change [mm] | pushed capture point xi + u ahead "
          "of the stance ankle [mm] | stance hip ahead of its ankle [mm] | trunk pitch (IMU) [rad] | stance ankle [rad] | stance knee [rad] | steps landed | "
          "landing point ahead [mm] | stance (rear) sole's load [N] | the other sole's [N] | trunk roll (IMU) [rad] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for t, c, dz, xi, hip, pitch, qa, qk, n, land, f_stance, f_other, roll in rows:
        print(f"| {1000 * t:.0f} | {1000 * c:.0f} | {1000 * dz:+.0f} | {1000 * xi:.0f} | {1000 * hip:.0f} | {pitch:+.2f} | {qa:+.2f} | "
              f"{qk:+.2f} | {int(n)} | {1000 * land:.0f} | {f_stance:.0f} | {f_other:.0f} | {roll:+.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
