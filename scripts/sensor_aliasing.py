#!/usr/bin/env python3
"""Why the plants' force outputs are the mean over the communication step (docs/plant.md section 5,
docs/plant3d.md section 2: give paper_five_pushes_3d for the 3D plant).

The servos' set-points change at every controller tick (1 ms), so the ground reaction ripples within
every millisecond. This script runs the first push of a scenario (default paper_five_pushes) with a
communication step of 1 ms / SUB. The controller still ticks once per millisecond, on the plant's
output of the last sub-step before its tick: the mean over the last 1/SUB ms, close to the value at
the end of the millisecond (what the plant reported before it reported the mean). It prints

  * the ripple of the ZMP within one millisecond while the hip strategy runs (phases 1-3);
  * the peak ZMP of the end-of-millisecond samples against the peak of each millisecond's mean;
  * the same push run at 1 ms, where the controller reads the millisecond's mean.

    .venv/bin/python scripts/sensor_aliasing.py [SCENARIO] [--sub 32] [--stop-time 6]
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from anklehip.running import native  # noqa: E402
from anklehip.running.master import simulate  # noqa: E402
from anklehip.files.paths import MissingFileError, find_scenario  # noqa: E402
from anklehip.files.scenario import load_scenario  # noqa: E402


def per_tick(data: np.ndarray, sub: int) -> dict[str, np.ndarray]:
    """Group the sub-step rows by controller tick. Row k holds the outputs at k h, the mean over
    [(k-1) h, k h]; the tick at j ms reads row j sub - 1 and its set-points act from there on, so the
    rows j sub - 1 + (1..sub) lie between two set-point changes; the last of them is what the next
    tick reads."""
    n = (len(data) - sub) // sub * sub
    rows = slice(sub - 1 + 1, sub - 1 + 1 + n)       # the first set-point change is after row sub - 1
    z = data["zmp_x"][rows].reshape(-1, sub)
    fz = data["fz"][rows].reshape(-1, sub)
    return {"end": z[:, -1], "mean": (fz * z).sum(1) / fz.sum(1), "ripple": z.max(1) - z.min(1),
            "active": data["phase"][rows].reshape(-1, sub).max(1) >= 1}


def measure(scenario: str = "paper_five_pushes", sub: int = 32, stop_time: float = 6.0, fmu_dir=None) -> dict:
    """The figures main() prints, in mm: ripple_max, ripple_median (phases 1-3), peak_end (the
    end-of-millisecond samples the controller read), peak_mean (the millisecond means of the same
    run), end_minus_mean (min, max in phases 1-3), peak_1ms (the run at 1 ms, on the means)."""
    base = load_scenario(find_scenario(scenario))
    if abs(base.step - 1e-3) > 1e-12:
        raise ValueError(f"{scenario}: the scenario's step is {base.step:g} s, not the controller's 1 ms")
    engine = native.default_engine()
    coarse = simulate(base, stop_time=stop_time, engine=engine, fmu_dir=fmu_dir)
    fine = simulate(dataclasses.replace(base, step=base.step / sub), stop_time=stop_time, engine=engine,
                    fmu_dir=fmu_dir)
    for r in (coarse, fine):
        if not r.complete:
            raise RuntimeError(f"{r.name}: {r.outcome} at {r.end_time:g} s")
    g = per_tick(fine.data, sub)
    act = g["active"]
    if not act.any():
        raise RuntimeError(f"{scenario}: the hip strategy never ran before {stop_time:g} s")
    d = 1e3 * (g["end"][act] - g["mean"][act])
    return {"engine": engine, "ripple_max": 1e3 * g["ripple"][act].max(),
            "ripple_median": 1e3 * float(np.median(g["ripple"][act])),
            "peak_end": 1e3 * g["end"].max(), "peak_mean": 1e3 * g["mean"].max(),
            "end_minus_mean": (d.min(), d.max()), "peak_1ms": 1e3 * coarse.data["zmp_x"].max()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario", nargs="?", default="paper_five_pushes")
    ap.add_argument("--sub", type=int, default=32, help="sub-steps per millisecond (default 32)")
    ap.add_argument("--stop-time", type=float, default=6.0, help="[s] (default 6: the first push of the main job)")
    a = ap.parse_args(argv)
    if a.sub < 2:
        ap.error("--sub must be >= 2")
    try:
        m = measure(a.scenario, a.sub, a.stop_time)
    except (MissingFileError, ValueError) as exc:      # wrong input: the scenario (ScenarioError is a ValueError)
        print(f"sensor_aliasing.py: error: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:                          # the run itself: a fall, no hip strategy
        print(f"sensor_aliasing.py: {exc}", file=sys.stderr)
        return 1
    lo, hi = m["end_minus_mean"]
    print(f"{a.scenario}, 0-{a.stop_time:g} s, step 1 ms / {a.sub}, controller ticks every 1 ms ({m['engine']} engine)")
    print(f"  ZMP ripple within one millisecond in phases 1-3: up to {m['ripple_max']:.2f} mm peak to peak "
          f"(median {m['ripple_median']:.2f} mm)")
    print(f"  controller reads the end of each millisecond: peak ZMP read {m['peak_end']:.2f} mm, peak of the "
          f"millisecond means {m['peak_mean']:.2f} mm (end minus mean in phases 1-3: {lo:+.2f} ... {hi:+.2f} mm)")
    print(f"  step 1 ms, controller reads the millisecond's mean: peak ZMP {m['peak_1ms']:.2f} mm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
