#!/usr/bin/env python3
"""Every performance figure in one run (figures, not pass/fail): a table on stdout and
bench/results.json. Called by `bash bench/run.sh`; docs/performance.md explains the figures.

  1. the plant alone (build/plant/plant_bench): both integrators on the standing, tracking and
     replayed closed-loop profiles;
  2. the closed loop paper_five_pushes (60 s): the FMPy master and the native engine, in process
     and through the CLI, CSV writing included;
  3. the peers on the same 60 s: FMPy's simulate_fmu on the plant FMU alone (recorded inputs), the
     closed loop as a container FMU (FMPy's container support), the Rust fmi-sim crate on the
     plant FMU with a CSV input (when installed: bench/run.sh installs it with cargo);
  4. scaling: wall time and peak memory for stop times 10 ... 600 s (fit slope), memory per run,
     the sweep's throughput in runs per minute on 1 and 2 Dask workers, and the committed capability
     map sweep (force_duration, 960 runs) on 1 and 2 workers.
Medians of repeated runs; every ratio comes from figures measured in this same run.

Usage: .venv/bin/python bench/report.py [--quick] [--out bench/results.json] [--fmi-sim PATH]

--quick: every part on a short run (the closed loop's first 5 s, scaling to 5 s, sweeps of 2 points,
a capability map of 2 x 1 points per variant), one repetition: what the test suite runs so that the
report cannot rot (tests/test_benchmarks.py); its figures are not the ones to quote.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from anklehip.running import native  # noqa: E402
from anklehip.running.master import Models, simulate  # noqa: E402
from anklehip.files.paths import build_dir, find_scenario  # noqa: E402
from anklehip.files.scenario import load_scenario  # noqa: E402

SCENARIO = "paper_five_pushes"
PLANT_INPUTS = ("theta_ankle_ref", "theta_hip_ref", "push_force")


def median_time(fn, n: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(n):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def machine() -> dict:
    cpu = ""
    try:
        cpu = next(l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name"))
    except (OSError, StopIteration):
        pass
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    import fmpy
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(), "fmpy": fmpy.__version__,
            "commit": commit, "date": time.strftime("%Y-%m-%d %H:%M:%S %Z")}


# ---------------------------------------------------------------------------------------------
def plant_alone(replay_csv: Path, repeat: int) -> list[dict]:
    exe = build_dir() / "plant" / "plant_bench"
    rows = []
    for integ in ("erk", "bdf"):
        runs: dict[str, list[dict]] = {}
        for _ in range(repeat):
            out = subprocess.run([str(exe), "all", "--replay", str(replay_csv), "--integrator", integ, "--json"],
                                 capture_output=True, text=True, check=True).stdout
            for line in out.splitlines():
                d = json.loads(line)
                runs.setdefault(d["profile"], []).append(d)
        for profile, ds in runs.items():
            med = {k: statistics.median(d[k] for d in ds) for k in ds[0] if isinstance(ds[0][k], (int, float))}
            rows.append({"profile": profile, "integrator": integ, **med})
    return rows


def closed_loop(models, sc, repeat: int, tmp: Path, quick: bool = False) -> dict:
    from fmpy.util import write_csv as fmpy_write_csv

    def fmpy_e2e():
        r = simulate(sc, models, progress=False)
        fmpy_write_csv(tmp / "fmpy.csv", r.data)
        return r

    def native_e2e():
        r = simulate(sc, models, engine="native")
        native.write_csv(tmp / "native.csv", r.data)
        return r

    t_fmpy_sim, _ = median_time(lambda: simulate(sc, models, progress=False), repeat)
    t_fmpy, r_fmpy = median_time(fmpy_e2e, max(1, repeat // 2))
    t_nat_sim, _ = median_time(lambda: simulate(sc, models, engine="native"), repeat * 2)
    t_nat, r_nat = median_time(native_e2e, repeat * 2)
    same = r_fmpy.data.tobytes() == r_nat.data.tobytes()
    cli = {}
    for engine in ("fmpy", "native"):
        cmd = [str(Path(sys.executable).parent / "anklehip"), "run", SCENARIO, "--engine", engine, "--no-progress",
               "--no-compare", "--out", str(tmp / f"cli_{engine}")] + (["--stop-time", f"{sc.stop_time:g}"] if quick else [])
        cli[engine], _ = median_time(lambda: subprocess.run(cmd, capture_output=True, cwd=ROOT, check=True),
                                     1 if quick else 3)
    T = r_nat.end_time
    return {"stop_time": T, "steps": r_nat.steps, "rows_identical": same,
            "fmpy_simulate_s": t_fmpy_sim, "fmpy_with_csv_s": t_fmpy, "native_simulate_s": t_nat_sim,
            "native_with_csv_s": t_nat, "cli_fmpy_s": cli["fmpy"], "cli_native_s": cli["native"],
            "rtf_fmpy": T / t_fmpy_sim, "rtf_native_with_csv": T / t_nat}


def find_fmi_sim(explicit: str | None) -> str | None:
    for c in ([explicit] if explicit else []) + [shutil.which("fmi-sim"),
                                                 str(Path.home() / ".cargo" / "bin" / "fmi-sim")]:
        if c and Path(c).is_file():
            return c
    return None


def peers(models, sc, nat_result, tmp: Path, fmi_sim: str | None, repeat: int) -> dict:
    from fmpy import simulate_fmu
    from anklehip.files.export import write_container_fmu
    d = nat_result.data
    T, h = nat_result.end_time, nat_result.step
    out: dict = {}
    # the plant alone on the inputs the controller gave it in the closed loop
    inp = np.zeros(len(d), dtype=[("time", np.float64)] + [(n, np.float64) for n in PLANT_INPUTS])
    inp["time"] = d["time"]
    for n in PLANT_INPUTS:
        inp[n] = d[n]
    plant_fmu = str(models.plant.path)
    out["fmpy_simulate_fmu_plant_s"], _ = median_time(
        lambda: simulate_fmu(plant_fmu, stop_time=T, step_size=h, output_interval=h, input=inp,
                             output=["theta_ankle", "zmp_x"]), repeat)
    # the closed loop as one container FMU, run by FMPy
    cont = write_container_fmu(tmp / "AnkleHipBalance.fmu", sc, models)
    cin = np.zeros(len(d), dtype=[("time", np.float64), ("push_force", np.float64)])
    cin["time"], cin["push_force"] = d["time"], d["push_force"]
    out["fmpy_container_fmu_s"], _ = median_time(
        lambda: simulate_fmu(str(cont), stop_time=T, step_size=h, output_interval=h, input=cin,
                             output=["theta_ankle", "phase"]), repeat)
    # the Rust fmi-sim crate on the plant FMU with a CSV input
    if fmi_sim:
        csv = tmp / "plant_inputs.csv"
        header = "time," + ",".join(PLANT_INPUTS)
        # '%.17e': every value has a decimal point, so the crate's CSV reader types the columns Float64
        np.savetxt(csv, np.column_stack([inp[n] for n in inp.dtype.names]), delimiter=",", header=header,
                   comments="", fmt="%.17e")
        res_csv = tmp / "fmisim.csv"
        cmd = [fmi_sim, "--model", plant_fmu, "-i", str(csv), "-o", str(res_csv), "co-simulation",
               "--step", repr(h), "-n", "0", "-s", "0", "-f", repr(T)]
        try:
            out["fmi_sim_plant_s"], _ = median_time(
                lambda: subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, check=True), repeat)
            got = np.genfromtxt(res_csv, delimiter=",", names=True)
            n = min(len(got), len(d))
            out["fmi_sim_max_abs_theta_ankle_vs_closed_loop"] = float(np.max(np.abs(got["theta_ankle"][:n]
                                                                                   - d["theta_ankle"][:n])))
        except subprocess.CalledProcessError as e:
            out["fmi_sim_error"] = (e.stderr or b"").decode(errors="replace")[-400:]
    else:
        out["fmi_sim_error"] = "fmi-sim not installed (bash bench/run.sh installs it: cargo install fmi-sim)"
    return out


SCALING_SCRIPT = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
from anklehip.running.master import Models, simulate
from anklehip.files.paths import find_scenario
from anklehip.files.output import atomic_write_csv
from anklehip.files.scenario import load_scenario
def status(key):   # kB
    return int(next(l.split()[1] for l in open("/proc/self/status") if l.startswith(key)))
T, engine, out = float(sys.argv[2]), sys.argv[3], sys.argv[4]
m = Models.load(); sc = load_scenario(find_scenario("paper_five_pushes"))
open("/proc/self/clear_refs", "w").write("5")      # the peak RSS (VmHWM) starts again from here
base = status("VmRSS:")
t = time.perf_counter()
r = simulate(sc, m, stop_time=T, engine=engine, **({} if engine == "native" else {"progress": False}))
atomic_write_csv(out, r.data)    # what `anklehip run` writes with
w = time.perf_counter() - t
print(json.dumps({"wall_s": w, "peak_rss_mb": status("VmHWM:") / 1024, "base_rss_mb": base / 1024,
                  "outcome": r.outcome}))
"""


def scaling(tmp: Path, quick: bool) -> dict:
    stops = (10, 30, 100, 300, 600) if not quick else (2, 5)
    res: dict = {"stop_times": list(stops)}
    for engine in ("native", "fmpy"):
        pts = []
        for T in (stops if engine == "native" or quick else stops[:4]):
            o = subprocess.run([sys.executable, "-c", SCALING_SCRIPT, str(ROOT), str(T), engine, str(tmp / "s.csv")],
                               capture_output=True, text=True, check=True).stdout
            pts.append({"stop_time": T, **json.loads(o)})
        Ts = np.array([p["stop_time"] for p in pts], float)
        slope, icpt = np.polyfit(Ts, [p["wall_s"] for p in pts], 1)
        mslope, micpt = np.polyfit(Ts, [p["peak_rss_mb"] - p["base_rss_mb"] for p in pts], 1)
        res[engine] = {"points": pts, "wall_s_per_sim_s": slope, "wall_s_fixed": icpt,
                       "memory_mb_per_sim_s": mslope, "memory_mb_fixed": micpt}
    return res


def sweep_throughput(quick: bool) -> dict:
    from anklehip.running.sweep import Variant, run_sweep
    path = str(find_scenario(SCENARIO))
    n = 2 if quick else 16
    forces = list(np.linspace(5.0, 7.0, n))
    out = {"runs": n}
    for engine, workers in (("native", 1), ("native", 2), ("fmpy", 2)):
        t = time.perf_counter()
        res = run_sweep(path, forces, [Variant("default", {}, {}, None)], workers=workers, engine=engine)
        w = time.perf_counter() - t
        assert res.complete and len(res.rows) == n, f"sweep {engine} on {workers} workers: {len(res.rows)} of {n} points"
        out[f"{engine}_{workers}w_runs_per_min"] = n / w * 60.0
        out[f"{engine}_{workers}w_wall_s"] = w
    return out


def capability_map_throughput(tmp: Path, quick: bool = False) -> dict:
    """The committed example sweep (scenarios/sweeps/force_duration.toml, 960 runs of up to 8 s) as
    `anklehip sweep force_duration` runs it, on 1 and 2 local Dask workers (quick: the same sweep
    file with a grid of 2 forces x 1 duration)."""
    import re
    from anklehip.cli import main as cli
    from anklehip.running.sweepfile import load_sweep_file
    from anklehip.files.paths import find_sweep_file
    path = find_sweep_file("force_duration")
    if quick:
        text = path.read_text()
        text = re.sub(r'"push.force" = \[[^\]]*\]', '"push.force" = [5, 40]', text)
        text = re.sub(r'"push.duration" = \[[^\]]*\]', '"push.duration" = [0.2]', text)
        path = tmp / "force_duration.toml"
        path.write_text(text)
    sf = load_sweep_file(path)
    n = len(sf.values()) * len(sf.variants)
    out = {"sweep": "force_duration", "runs": n}
    for workers in (1, 2):
        t = time.perf_counter()
        rc = cli(["sweep", str(path), "--workers", str(workers), "--out", str(tmp / f"cap{workers}"), "--restart"])
        w = time.perf_counter() - t
        assert rc == 0, f"anklehip sweep force_duration --workers {workers} exited {rc}"
        out[f"{workers}w_runs_per_min"] = n / w * 60.0
        out[f"{workers}w_wall_s"] = w
    return out


def fmt_table(R: dict) -> str:
    L = []
    m = R["machine"]
    L.append(f"machine: {m['cpu']} ({m['cores']} cores), Python {m['python']}, FMPy {m['fmpy']}, commit {m['commit']}")
    L.append("")
    L.append("1. plant alone (plant_bench, 1 ms steps, rtol 1e-8)")
    L.append(f"   {'profile':<9} {'integrator':<10} {'sim s/wall s':>12} {'RHS/step':>9} {'steps/step':>10} "
             f"{'median us':>9} {'p99 us':>7}")
    for r in R["plant"]:
        L.append(f"   {r['profile']:<9} {r['integrator']:<10} {r['real_time_factor']:>12.0f} {r['rhs_per_step']:>9.2f} "
                 f"{r['steps_per_step']:>10.2f} {r['median_us']:>9.2f} {r['p99_us']:>7.2f}")
    c = R["closed_loop"]
    L.append("")
    L.append(f"2. closed loop {SCENARIO} ({c['stop_time']:g} s, {c['steps']} steps; rows identical: {c['rows_identical']})")
    L.append(f"   FMPy master   simulate {c['fmpy_simulate_s']:.3f} s ({c['rtf_fmpy']:.0f}x real time), "
             f"with FMPy's CSV writer {c['fmpy_with_csv_s']:.3f} s, CLI {c['cli_fmpy_s']:.2f} s")
    L.append(f"   native        simulate {c['native_simulate_s']:.3f} s, with CSV {c['native_with_csv_s']:.3f} s "
             f"({c['rtf_native_with_csv']:.0f}x real time), CLI {c['cli_native_s']:.2f} s")
    p = R["peers"]
    L.append("")
    L.append(f"3. peers, same {c['stop_time']:g} s (wall s; ratio = peer / native engine with CSV)")
    nat = c["native_with_csv_s"]
    rows = [("native engine (both FMUs + CSV)", nat), ("our FMPy master (both FMUs)", c["fmpy_simulate_s"]),
            ("FMPy simulate_fmu, plant FMU alone", p.get("fmpy_simulate_fmu_plant_s")),
            ("container FMU of the loop, FMPy", p.get("fmpy_container_fmu_s")),
            ("Rust fmi-sim, plant FMU alone", p.get("fmi_sim_plant_s"))]
    for name, v in rows:
        L.append(f"   {name:<38} " + (f"{v:8.3f}   {v / nat:6.1f}x" if v else f"   -      ({p.get('fmi_sim_error', '')[:90]})"))
    s = R["scaling"]
    L.append("")
    L.append("4. scaling (a fresh process per point; the run and its CSV as `anklehip run` writes it)")
    for e in ("native", "fmpy"):
        d = s[e]
        pts = ", ".join(f"{q['stop_time']:g} s: {q['wall_s']:.2f} s/{q['peak_rss_mb'] - q['base_rss_mb']:.0f} MB"
                        for q in d["points"])
        L.append(f"   {e:<6} {pts}")
        L.append(f"          slope {d['wall_s_per_sim_s'] * 1e3:.2f} ms wall per simulated s "
                 f"({1 / d['wall_s_per_sim_s']:.0f}x real time), fixed {d['wall_s_fixed']:.2f} s; memory "
                 f"{d['memory_mb_per_sim_s']:.2f} MB per simulated s + {d['memory_mb_fixed']:.0f} MB")
    w = R["sweep"]
    L.append(f"   sweep ({w['runs']} runs of 60 s): native {w['native_1w_runs_per_min']:.0f} runs/min on 1 worker, "
             f"{w['native_2w_runs_per_min']:.0f} on 2; FMPy {w['fmpy_2w_runs_per_min']:.0f} on 2")
    if "capability_map" in R:
        k = R["capability_map"]
        L.append(f"   capability map ({k['sweep']}, {k['runs']} runs of up to 8 s, figures included): "
                 f"{k['1w_runs_per_min']:.0f} runs/min on 1 worker ({k['1w_wall_s']:.1f} s), "
                 f"{k['2w_runs_per_min']:.0f} on 2 ({k['2w_wall_s']:.1f} s; x{k['2w_runs_per_min'] / k['1w_runs_per_min']:.2f})")
    return "\n".join(L)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repetitions and points (a smoke run)")
    ap.add_argument("--out", default=str(ROOT / "bench" / "results.json"))
    ap.add_argument("--fmi-sim", help="the fmi-sim executable (default: on PATH or in ~/.cargo/bin)")
    a = ap.parse_args()
    if not native.available():
        print(f"bench: {native.library_path()} missing: build with bash scripts/setup.sh", file=sys.stderr)
        return 1
    repeat = 1 if a.quick else 3
    R: dict = {"machine": machine(), "quick": a.quick}
    models = Models.load()
    sc = load_scenario(find_scenario(SCENARIO))
    if a.quick:
        sc.stop_time = 5.0
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        ref = simulate(sc, models, engine="native")
        native.write_csv(tmp / "replay.csv", ref.data)
        R["plant"] = plant_alone(tmp / "replay.csv", repeat)
        R["closed_loop"] = closed_loop(models, sc, repeat, tmp, a.quick)
        R["peers"] = peers(models, sc, ref, tmp, find_fmi_sim(a.fmi_sim), repeat)
        R["scaling"] = scaling(tmp, a.quick)
        R["sweep"] = sweep_throughput(a.quick)
        R["capability_map"] = capability_map_throughput(tmp, a.quick)
    Path(a.out).write_text(json.dumps(R, indent=1) + "\n")
    print(fmt_table(R))
    print(f"\nfigures: {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
