#!/usr/bin/env python3
"""Two builds of the same FMUs side by side: the closed loop paper_five_pushes (60 s) on the
native engine and on the FMPy master, each build's FMUs in turn (interleaved, so that both see the
same machine), medians and the ratio B/A; and whether both compute the same trajectory.

Made for the Linux binaries' glibc baseline (docs/performance.md "Compiler of the shipped
binaries"): A = a build configured with -DANKLEHIP_GLIBC_BASELINE= (the build machine's gcc and
libstdc++), B = the default build (zig cc, LLVM libc++, glibc 2.17):

  cmake -S . -B /tmp/gcc-build -DANKLEHIP_GLIBC_BASELINE= -DPython3_EXECUTABLE=$PWD/.venv/bin/python
  cmake --build /tmp/gcc-build --target AnkleHipController_fmu Hoap2Plant_fmu
  .venv/bin/python bench/fmu_builds.py /tmp/gcc-build/fmus build/fmus [--repeat 5]

--quick: one run of the scenario's first 2 s per build and engine (the test suite's check that the
benchmark still runs, tests/test_benchmarks.py; not figures to quote).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from anklehip.running.master import Models, simulate  # noqa: E402
from anklehip.files.paths import find_scenario  # noqa: E402
from anklehip.files.scenario import load_scenario  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("fmus_a", type=Path, help="FMU folder of build A")
    ap.add_argument("fmus_b", type=Path, help="FMU folder of build B")
    ap.add_argument("--scenario", default="paper_five_pushes", help="scenario (default %(default)s)")
    ap.add_argument("--repeat", type=int, default=5, help="runs per build and engine (default %(default)s)")
    ap.add_argument("--quick", action="store_true", help="one run of 2 s per build and engine (a smoke run)")
    a = ap.parse_args()
    sc = load_scenario(find_scenario(a.scenario))
    if a.quick:
        sc.stop_time, a.repeat = 2.0, 1
    builds = {"A": Models.load(a.fmus_a), "B": Models.load(a.fmus_b)}
    runs = {"native": lambda m: simulate(sc, m, engine="native"),
            "fmpy": lambda m: simulate(sc, m, progress=False)}
    print(f"{sc.name}, {sc.stop_time:g} s simulated; A = {a.fmus_a}, B = {a.fmus_b}; median of {a.repeat}")
    for engine, run in runs.items():
        times: dict[str, list[float]] = {"A": [], "B": []}
        data = {}
        for _ in range(a.repeat):
            for k, m in builds.items():
                t0 = time.perf_counter()
                data[k] = run(m).data
                times[k].append(time.perf_counter() - t0)
        ma, mb = statistics.median(times["A"]), statistics.median(times["B"])
        names = data["A"].dtype.names      # every column: the Real, Integer and Boolean signals
        dev = max(float(np.max(np.abs(data["A"][n].astype(float) - data["B"][n].astype(float)))) for n in names)
        print(f"  {engine:6s}  A {ma:6.3f} s   B {mb:6.3f} s   B/A {mb / ma:5.2f}   "
              f"largest |A - B| over {len(names)} signals: {dev:.3g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
