#!/usr/bin/env python3
"""The largest side push each controller configuration stands (docs/controller.md §11.5).

For the push shape of a 3D scenario with a sideways push (default side_push_3d: a 1 s pulse with
0.3 s ramps toward +y), the push is scaled to 1 N steps upward from --from until the first fall;
the last force that stood is printed per configuration: the sagittal controller (its roll servos
hold the legs still) and the 3D controller with its defaults and with one setting changed at a
time. Runs on the native engine.

    .venv/bin/python scripts/frontal_limits.py [SCENARIO] [--from 6] [--set NAME=VALUE ...]

With --set only that configuration of the 3D controller is measured.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from anklehip.errors import InputError  # noqa: E402
from anklehip.files.paths import find_scenario  # noqa: E402
from anklehip.files.scenario import load_scenario  # noqa: E402
from anklehip.running import native  # noqa: E402
from anklehip.running.master import Models, simulate  # noqa: E402

# (label, controller model, overrides): one setting changed at a time from the 3D defaults
CONFIGURATIONS = [
    ("sagittal controller (roll servos hold)", "sagittal", {}),
    ("3D controller, defaults", "3d", {}),
    ("lateral ankle strategy only", "3d", {"hip_strategy_enabled_y": 0}),
    ("lateral lean on", "3d", {"lean_enabled_y": 1}),
    ("Ka_y 40 (Ca_y 6.83, same damping ratio)", "3d", {"Ka_y": 40.0, "Ca_y": 6.83}),
    ("Ka_y 160 (Ca_y 13.7)", "3d", {"Ka_y": 160.0, "Ca_y": 13.7}),
    ("zmp_limit_y 20 mm", "3d", {"zmp_limit_y": 0.02}),
    ("zmp_limit_y 55 mm", "3d", {"zmp_limit_y": 0.055}),
]


def largest_standing(scenario, model: str, overrides: dict, start: float, fmu_dir=None, top: float = 60.0) -> float:
    """The last force (1 N steps from `start`) at which the scenario's push stands; start - 1 if
    even `start` falls."""
    sc0 = dataclasses.replace(scenario, controller_model=model)
    models = Models.load(fmu_dir, plant_model="3d", controller_model=model)
    base = abs(sc0.push_y.peak())
    engine = native.default_engine()
    f = start
    while f <= top:
        k = f / base
        sc = dataclasses.replace(sc0, push=sc0.push.scaled(k), push_y=sc0.push_y.scaled(k))
        if simulate(sc, models, controller_overrides=overrides, progress=False, engine=engine).outcome != "completed":
            break
        f += 1.0
    return f - 1.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario", nargs="?", default="side_push_3d")
    ap.add_argument("--from", dest="start", type=float, default=6.0, help="first force tried [N] (default 6)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="measure only the 3D controller with these parameters")
    a = ap.parse_args(argv)
    try:
        sc = load_scenario(find_scenario(a.scenario))
        if sc.plant_model != "3d" or sc.push_y.peak() == 0:
            raise InputError(f"{a.scenario}: needs plant_model = \"3d\" and a push_y")
        over = {}
        for s in a.set:
            k, eq, v = s.partition("=")
            if not eq:
                raise InputError(f"--set {s}: expected NAME=VALUE")
            over[k] = float(v)
    except (InputError, ValueError) as e:
        print(f"frontal_limits.py: error: {e}", file=sys.stderr)
        return 2
    configs = [("3D controller, " + ", ".join(a.set), "3d", over)] if a.set else CONFIGURATIONS
    print(f"{a.scenario}: largest peak side force that stands [N] (1 N steps from {a.start:g} N)")
    for label, model, o in configs:
        print(f"  {label:<44} {largest_standing(sc, model, o, a.start):5.0f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
