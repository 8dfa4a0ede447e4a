#!/usr/bin/env python3
"""The largest side push each controller configuration stands (docs/controller.md §11.5).

Three push shapes, toward +y and toward -y, on side_push_3d's base (the 3D plant, the push at the trunk's push
point): a short pulse (0.2 s, 50 ms ramps), a 1 s pulse (0.3 s ramps: the scenario's own) and a
slow push (5 s, 1 s ramps). Each is scaled in 1 N steps upward from --from until the first fall;
the last force that stood is printed per configuration: the sagittal controller (its roll servos
hold the legs still), the 3D controller with its defaults, and the defaults with one setting
changed at a time. Runs on the native engine (about 25 minutes for the whole table).

    .venv/bin/python scripts/frontal_limits.py [--from 6] [--shape 0.2s|1s|slow ...] [--config NAME] [--set NAME=VALUE ...]

With --set or --config only that configuration of the 3D controller is measured (--config: a named
configuration, e.g. omnidirectional, with the --set parameters on top).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from anklehip.errors import InputError  # noqa: E402
from anklehip.files.paths import find_scenario  # noqa: E402
from anklehip.files.scenario import PushProfile, PushSegment, load_scenario  # noqa: E402
from anklehip.running import native  # noqa: E402
from anklehip.running.master import Models, simulate  # noqa: E402

# (label, controller model, overrides): one setting changed at a time from the 3D defaults
CONFIGURATIONS = [
    ("sagittal controller (roll servos hold)", "sagittal", {}),
    ("3D controller, defaults", "3d", {}),
    ("the paper's reading (configuration paper)", "3d", {"Ka_y": 19.0, "Ca_y": 4.75, "hip_strategy_enabled_y": 1,
                                                         "lean_enabled_y": 0}),
    ("the first defaults (low-pass lean, tau 0.2 s, fz hold 3 N, no roll hold)", "3d",
     {"lean_law_y": 0, "lean_tau_y": 0.2, "fz_rocking_y": 3.0, "roll_rocking_y": 3.2, "rocking_dwell_y": 0.0}),
    ("lateral hip strategy on", "3d", {"hip_strategy_enabled_y": 1}),
    ("lateral lean off", "3d", {"lean_enabled_y": 0}),
    ("lean_law_y 0 (the low-pass lean)", "3d", {"lean_law_y": 0}),
    ("Ka_y 19 (Ca_y 4.75, the sagittal gains')", "3d", {"Ka_y": 19.0, "Ca_y": 4.75}),
    ("Ka_y 160 (Ca_y 13.7)", "3d", {"Ka_y": 160.0, "Ca_y": 13.7}),
    ("Ka_y 400 (Ca_y 21.6)", "3d", {"Ka_y": 400.0, "Ca_y": 21.6}),
    ("lean_tau_y 0.02 s", "3d", {"lean_tau_y": 0.02}),
    ("lean_tau_y 0.05 s", "3d", {"lean_tau_y": 0.05}),
    ("lean_tau_y 0.1 s", "3d", {"lean_tau_y": 0.1}),
    ("lean_capture_gain_y 4", "3d", {"lean_capture_gain_y": 4.0}),
    ("lean_capture_gain_y 16", "3d", {"lean_capture_gain_y": 16.0}),
    ("lean_zmp_margin_y 5 mm", "3d", {"lean_zmp_margin_y": 0.005}),
    ("lean_zmp_margin_y 25 mm", "3d", {"lean_zmp_margin_y": 0.025}),
    ("lean_margin_y 5 mm", "3d", {"lean_margin_y": 0.005}),
    ("lean_margin_y 15 mm (the sagittal lean's)", "3d", {"lean_margin_y": 0.015}),
    ("roll_rocking_y 3.2 rad (no roll hold: imu_roll unused)", "3d", {"roll_rocking_y": 3.2}),
    ("roll_rocking_y 0.005 rad", "3d", {"roll_rocking_y": 0.005}),
    ("roll_rocking_y 0.02 rad", "3d", {"roll_rocking_y": 0.02}),
    ("rocking_dwell_y 0", "3d", {"rocking_dwell_y": 0.0}),
    ("rocking_dwell_y 0.15 s", "3d", {"rocking_dwell_y": 0.15}),
    ("fz_rocking_y 3 N (an unloaded sole holds the lean too)", "3d", {"fz_rocking_y": 3.0}),
    ("two changes: lateral hip strategy on, zmp_limit_y 65 mm", "3d", {"hip_strategy_enabled_y": 1, "zmp_limit_y": 0.065}),
]

# push shapes: (duration [s], rise [s], stop time [s]); the push starts at 1 s
SHAPES = {"0.2s": (0.2, 0.05, 4.0), "1s": (1.0, 0.3, 4.0), "slow": (5.0, 1.0, 9.0)}


def largest_standing(scenario, model: str, overrides: dict, shape: str, start: float, fmu_dir=None,
                     top: float = 60.0, sign: float = 1.0) -> float:
    """The last force (1 N steps from `start`) at which the push shape toward +y (sign -1: toward
    -y) stands; start - 1 if even `start` falls."""
    duration, rise, stop = SHAPES[shape]
    models = Models.load(fmu_dir, plant_model="3d", controller_model=model)
    engine = native.default_engine()
    f = start
    while f <= top:
        push_y = PushProfile.from_segments([PushSegment("pulse", t=1.0, force=sign * f, duration=duration, rise=rise)])
        sc = dataclasses.replace(scenario, controller_model=model, push_y=push_y, stop_time=stop)
        if simulate(sc, models, controller_overrides=overrides, progress=False, engine=engine).outcome != "completed":
            break
        f += 1.0
    return f - 1.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--from", dest="start", type=float, default=6.0, help="first force tried [N] (default 6)")
    ap.add_argument("--shape", action="append", choices=list(SHAPES), help="push shapes (default: all three)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="measure only the 3D controller with these parameters")
    ap.add_argument("--config", default=None, help="measure only the 3D controller in this named configuration")
    a = ap.parse_args(argv)
    try:
        sc = load_scenario(find_scenario("side_push_3d"))
        if a.config:
            sc = dataclasses.replace(sc, controller_config=a.config)
        over = {}
        for s in a.set:
            k, eq, v = s.partition("=")
            if not eq:
                raise InputError(f"--set {s}: expected NAME=VALUE")
            over[k] = float(v)
    except (InputError, ValueError) as e:
        print(f"frontal_limits.py: error: {e}", file=sys.stderr)
        return 2
    shapes = a.shape or list(SHAPES)
    label = ", ".join([f"configuration {a.config}"] * bool(a.config) + a.set)
    configs = [("3D controller, " + label, "3d", over)] if label else CONFIGURATIONS
    print(f"largest peak side force that stands [N], 1 N steps from {a.start:g} N, toward +y / toward -y")
    print(f"  {'configuration':<72}" + "".join(f"{s:>9}" for s in shapes))
    for label, model, o in configs:
        row = [f"{largest_standing(sc, model, o, shape, a.start, sign=+1):.0f}/"
               f"{largest_standing(sc, model, o, shape, a.start, sign=-1):.0f}" for shape in shapes]
        print(f"  {label:<72}" + "".join(f"{x:>9}" for x in row), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
