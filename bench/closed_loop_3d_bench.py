#!/usr/bin/env python3
"""The closed loop on the 3D plant (not a test): the main job, paper_five_pushes (60 s), on
Hoap2Plant3D with the controller FMU, side by side in one run:

* the native engine (anklehip.running.native) with the CSV written, and the FMPy master;
* the plant as it ships (feet held flat, 1 ms / 0.25 ms steps, stiff contacts) and in the previous
  release's configuration (corner contacts of 2e5 N/m and 1e3 N s/m, 0.5 ms steps, feet never held).

Prints the median wall time of `--repeat` runs (default 3), the real-time factor (simulated s per
wall s) and the process's CPU time per run (unaffected by other processes on a busy machine).

Usage:  .venv/bin/python bench/closed_loop_3d_bench.py [--repeat N]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from anklehip.files.paths import find_scenario  # noqa: E402
from anklehip.files.scenario import load_scenario  # noqa: E402
from anklehip.running import native  # noqa: E402
from anklehip.running.master import Models, simulate  # noqa: E402

PREVIOUS = {"contact_stiffness": 2e5, "contact_damping": 1e3, "internal_step": 5e-4, "rocking_step": 5e-4,
            "flat_foot_weld": False}


def measure(fn, repeat: int) -> tuple[float, float]:
    """Median wall and CPU seconds of fn()."""
    wall, cpu = [], []
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - w0)
        cpu.append(time.process_time() - c0)
    return statistics.median(wall), statistics.median(cpu)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    sc = load_scenario(find_scenario("paper_five_pushes"))
    sc.plant_model = "3d"
    models = Models.load(plant_model="3d")
    T = sc.stop_time
    engines = ["native", "fmpy"] if native.available() else ["fmpy"]
    print(f"paper_five_pushes on Hoap2Plant3D ({T:g} s), medians of {a.repeat}")
    print(f"{'plant configuration':<20} {'engine':<12} {'wall [s]':>9} {'x real time':>12} {'CPU [s]':>9} {'x (CPU)':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        for label, plant in (("as shipped", {}), ("previous release", PREVIOUS)):
            for engine in engines:
                def one():
                    r = simulate(sc, models, plant_overrides=plant, engine=engine)
                    assert r.outcome == "completed", r.message
                    if engine == "native":
                        native.write_csv(Path(tmp) / "run.csv", r.data)
                wall, cpu = measure(one, a.repeat)
                what = engine + (" +CSV" if engine == "native" else "")
                print(f"{label:<20} {what:<12} {wall:9.3f} {T / wall:12.1f} {cpu:9.3f} {T / cpu:9.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
