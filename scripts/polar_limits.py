#!/usr/bin/env python3
"""The polar map's boundary in a few directions, quickly (docs/capability.md §7.7, docs/controller.md §4.7).

Each point is exactly a point of `scenarios/sweeps/polar_3d.toml` (its scenario, push, grid of peak
forces and 6 s runs, through the sweep's own point function), for one configuration of the 3D
controller: the table of docs/controller.md §4.7 (the default, the configuration omnidirectional, and
that configuration with one setting changed at a time), or one named configuration (--config) with
parameters changed (--set). Instead of the whole
grid it searches each direction and duration upward along the sweep's forces, from the grid force
below --start-fraction of the static tipping force (which must stand; else it steps down), to the
first fall, and prints the last force that stood with its fraction of the static tipping force.

    .venv/bin/python scripts/polar_limits.py [--config NAME] [--set NAME=VALUE ...]
        [--angle DEG ...] [--duration S ...] [--model 3d|sagittal]

About 10-40 s per direction and duration on the shared 2-core machine (native engine); the whole
table (both durations) about 10 minutes.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from anklehip.errors import InputError  # noqa: E402
from anklehip.files.paths import find_sweep_file  # noqa: E402
from anklehip.files.scenario import load_scenario  # noqa: E402
from anklehip.running import native  # noqa: E402
from anklehip.running.sweep import Variant, bounds_parameters_of, cached_models  # noqa: E402
from anklehip.running.sweepfile import load_sweep_file, sweepfile_point  # noqa: E402

# the directions where the default 3D controller is below 80 % of the static bound (docs/capability.md §7.7)
WEAK = [0.0, 15.0, 30.0, 45.0, 120.0, 135.0, 150.0, 165.0, 180.0]

# (label, named configuration, overrides): docs/controller.md §4.7's table, one setting at a time
CONFIGURATIONS = [
    ("3D controller, defaults", None, {}),
    ("defaults, sagittal lean_enabled 1 (the low-pass lean of section 4.6)", None, {"lean_enabled": 1}),
    ("omnidirectional", "omnidirectional", {}),
    ("  lean_enabled 0", "omnidirectional", {"lean_enabled": 0}),
    ("  lean_law 0 (the low-pass lean)", "omnidirectional", {"lean_law": 0}),
    ("  lean_tau 0.02 s", "omnidirectional", {"lean_tau": 0.02}),
    ("  lean_tau 0.05 s", "omnidirectional", {"lean_tau": 0.05}),
    ("  lean_tau 0.1 s", "omnidirectional", {"lean_tau": 0.1}),
    ("  lean_margin 15 mm (the low-pass lean's)", "omnidirectional", {"lean_margin": 0.015}),
    ("  lean_margin 25 mm", "omnidirectional", {"lean_margin": 0.025}),
    ("  lean_margin 30 mm", "omnidirectional", {"lean_margin": 0.03}),
    ("  lean_margin 35 mm", "omnidirectional", {"lean_margin": 0.035}),
    ("  T_ah 0.5 s (the default's)", "omnidirectional", {"T_ah": 0.5}),
    ("  T_ah 0.75 s", "omnidirectional", {"T_ah": 0.75}),
    ("  T_ah 1.5 s", "omnidirectional", {"T_ah": 1.5}),
    ("  lean_capture_gain 16", "omnidirectional", {"lean_capture_gain": 16.0}),
    ("  lean_zmp_margin 5 mm", "omnidirectional", {"lean_zmp_margin": 0.005}),
    ("  lean_zmp_margin 25 mm", "omnidirectional", {"lean_zmp_margin": 0.025}),
    ("  hip_strategy_enabled 0 (ankle strategy only)", "omnidirectional", {"hip_strategy_enabled": 0}),
]


def static_bounds(sf, variant: Variant, angles) -> list[float]:
    """The static tipping force [N] at each angle for the sweep's plant in the variant's erect posture."""
    from anklehip.analysis.bounds import static_tipping_force_3d
    from anklehip.analysis.capability import stance_of
    sc = variant.apply(load_scenario(sf.scenario))
    models = cached_models(None, sc.plant_model, sc.controller_model)
    st = stance_of(bounds_parameters_of(models, sc, variant))
    return [float(static_tipping_force_3d(st, a)) for a in angles]


def stands(sf, variant: Variant, angle: float, duration: float, force: float, engine: str) -> bool:
    spec = {"sweep": str(sf.path), "fmu_dir": None, "engine": engine, "variant": variant.as_dict(),
            "values": {"push.angle": angle, "push.force": force, "push.duration": duration}}
    return sweepfile_point(spec)["outcome"] == "completed"


def boundary(sf, variant: Variant, angle: float, duration: float, start: float, engine: str) -> float:
    """The last grid force that stood going up from the grid force at or below `start` (stepping
    down first while that one falls); 0 if even the smallest falls."""
    forces = sorted(sf.axes["push.force"])
    i = max([j for j, f in enumerate(forces) if f <= start] or [0])
    while not stands(sf, variant, angle, duration, forces[i], engine):
        if i == 0:
            return 0.0
        i -= 1
    while i + 1 < len(forces) and stands(sf, variant, angle, duration, forces[i + 1], engine):
        i += 1
    return forces[i]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default=None, help="a named controller configuration (default: the scenario's)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="a controller parameter")
    ap.add_argument("--angle", action="append", type=float, help=f"push direction [deg] (default {WEAK})")
    ap.add_argument("--duration", action="append", type=float, help="pulse duration [s] (default 1 and 0.2)")
    ap.add_argument("--model", default="3d", choices=["3d", "sagittal"], help="controller FMU (default 3d)")
    ap.add_argument("--start-fraction", type=float, default=0.6,
                    help="first force tried, as a fraction of the static tipping force (default 0.6)")
    a = ap.parse_args(argv)
    try:
        sf = load_sweep_file(find_sweep_file("polar_3d"))
        bad = [s for s in a.set if "=" not in s]
        if bad:
            raise InputError(f"--set {bad[0]}: expected NAME=VALUE")
        over = {k: float(v) for k, v in (s.split("=", 1) for s in a.set)}
    except (InputError, ValueError) as e:
        print(f"polar_limits.py: error: {e}", file=sys.stderr)
        return 2
    angles = a.angle or WEAK
    durations = a.duration or [1.0, 0.2]
    engine = native.default_engine()
    if a.set or a.config or a.model != "3d":
        label = ", ".join([f"configuration {a.config}"] * bool(a.config) + a.set) or "defaults"
        configs = [(f"{a.model} controller, {label}", a.config, over)]
    else:
        configs = CONFIGURATIONS
    try:
        static = static_bounds(sf, Variant("bounds", {}, {}, None, a.model), angles)
        return _table(sf, configs, angles, durations, static, a, engine)
    except InputError as e:   # an unknown configuration or parameter, a value out of range
        print(f"polar_limits.py: error: {e}", file=sys.stderr)
        return 2


def _table(sf, configs, angles, durations, static, a, engine) -> int:
    print("largest peak force that stood [N] (fraction of the static tipping force), polar_3d's pulses")
    print(f"  {'angle [deg]':<52}" + "".join(f"{x:>13g}" for x in angles))
    print(f"  {'static tipping force [N]':<52}" + "".join(f"{x:>13.1f}" for x in static))
    print(f"  {'80 % of it, up to the grid [N]':<52}" + "".join(f"{math.ceil(0.8 * x - 1e-9):>13d}" for x in static))
    for label, config, o in configs:
        variant = Variant("probe", o, {}, config, a.model)
        for d in durations:
            cells = [boundary(sf, variant, ang, d, a.start_fraction * s, engine) for ang, s in zip(angles, static)]
            print(f"  {f'{label}, {d:g} s':<52}" + "".join(f"{f:>7g} ({f / s:.2f})" for f, s in zip(cells, static)),
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
