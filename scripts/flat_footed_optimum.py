"""Make the cached flat-footed optimum, anklehip/analysis/data/flat_footed_optimum.json (docs/capability.md
section 8): for every push of the grid below, the largest peak force any flat-footed controller
survives, by trajectory optimization (anklehip.analysis.flat_footed: CasADi, IPOPT, Radau
collocation). Each point is solved on two meshes (intervals of at most DT and DT/2): the finer
one's value is cached with the relative change between the two (the convergence check); a few
points are solved again with a longer horizon after the push (the horizon check); and the static
optimum of the same model (a push that never ends) per direction.

The robot's numbers are the plant FMUs' (Hoap2Plant: masses, lengths, inertias, sole, push height,
servo limits; completed by the robot header it carries: the joint ranges, leg segments; Hoap2Plant3D:
the friction coefficient mu), recorded in the file with the settings and the sha256 of the model's
source, so a stale cache is detected (tests/test_flat_footed.py, anklehip.analysis.bounds.optimum_matches).
The file is written whole or not at all; an interrupted run resumes from its journal
(<out>.partial.jsonl). About 40 min on one core of a loaded machine.

    .venv/bin/python scripts/flat_footed_optimum.py [--fmu-dir build/fmus] [--out FILE] [--quick] [--reg-check]
"""
from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from anklehip.analysis import flat_footed as ff  # noqa: E402
from anklehip.analysis.bounds import (NOMINAL_DURATIONS, OPTIMUM_FILE, bounds_parameters,  # noqa: E402
                                      optimum_parameters, plant_header)

DT = 0.02             # the coarse mesh's longest interval [s] for pushes up to 1 s; the cached value is the mesh of DT/2
DT_LONG = 0.04        # the same for longer pushes (their hold is smooth; the solves' cost grows with the intervals)
T_AFTER = 1.5         # horizon after the push [s]
T_AFTER_CHECK = 3.0   # the horizon check's
HEIGHTS = (0.26, 0.30, 0.38, 0.42, 0.46)          # scenarios/sweeps/force_height.toml (1 s pushes, 50 ms rise)
SLOW_DURATIONS = (2.5, 3.0, 4.0, 6.0)             # scenarios/sweeps/slow_push.toml (1 s ramps)


def grid(h0: float) -> list[dict]:
    """The cached pushes: the force x duration sweep's (50 ms rise, every duration) on the back and on
    the chest; the force x height sweep's (1 s, 50 ms rise, every height) and the slow pushes' (1 s
    ramps) on the back, as those sweeps push."""
    pts = [dict(direction=d, rise=0.05, height=h0, duration=D) for d in (1, -1) for D in NOMINAL_DURATIONS]
    pts += [dict(direction=1, rise=0.05, height=h, duration=1.0) for h in HEIGHTS]
    pts += [dict(direction=1, rise=1.0, height=h0, duration=D) for D in SLOW_DURATIONS]
    return pts


def robot_parameters(fmu_dir) -> dict:
    """bounds_parameters of the sagittal plant FMU (and its header), with the 3D plant's mu."""
    from anklehip.files.paths import PLANT_FMU, PLANT_FMUS, find_fmu
    from anklehip.running.fmu import FMUInfo
    plant = FMUInfo.load(find_fmu(PLANT_FMU, fmu_dir))
    p = bounds_parameters(plant.start_values(), plant_header(plant.unzipdir))
    p["mu"] = float(FMUInfo.load(find_fmu(PLANT_FMUS["3d"], fmu_dir)).start_values()["mu"])
    return p


def source_hash() -> str:
    """sha256 of the model and transcription's source (anklehip/analysis/flat_footed.py)."""
    return hashlib.sha256((ROOT / "anklehip" / "analysis" / "flat_footed.py").read_bytes()).hexdigest()


def coarse_dt(pt: dict) -> float:
    """The coarse mesh of a point: DT for pushes up to 1 s, DT_LONG for longer ones."""
    return DT if pt["duration"] <= 1.0 else DT_LONG


def solve_point(params: dict, pt: dict, dt: float, t_after: float, f_guess=None) -> ff.Solution:
    pb = ff.with_height(ff.problem_from_params(params, pt["direction"]), pt["height"])
    return ff.solve(pb, pt["duration"], pt["rise"], dt=dt, t_after=t_after, f_guess=f_guess)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fmu-dir", help="folder of the plant FMUs (default: the checkout's build)")
    ap.add_argument("--out", default=str(ROOT / "anklehip" / "analysis" / "data" / OPTIMUM_FILE))
    ap.add_argument("--quick", action="store_true", help="two points on the coarse mesh only (a smoke test)")
    ap.add_argument("--reg-check", action="store_true",
                    help="the smoothness term's effect: the 0.2 s push on the back, coarse mesh, with and without it")
    a = ap.parse_args(argv)
    params = robot_parameters(a.fmu_dir)
    if a.reg_check:
        pt = dict(direction=1, rise=0.05, height=params["h_push"], duration=0.2)
        with_reg = solve_point(params, pt, coarse_dt(pt), T_AFTER)
        reg, ff.REG = ff.REG, 0.0
        without = solve_point(params, pt, coarse_dt(pt), T_AFTER)
        ff.REG = reg
        print(f"REG {reg:g}: {with_reg.f_peak:.6f} N ({with_reg.status}); REG 0: {without.f_peak:.6f} N "
              f"({without.status}); difference {without.f_peak - with_reg.f_peak:+.6f} N")
        return 0
    h0 = params["h_push"]
    pts = grid(h0)[:2] if a.quick else grid(h0)
    t_start = time.perf_counter()
    out = []
    # points already solved (this robot, this model, these settings) are kept in a journal next to
    # the output, so an interrupted run resumes; the journal is removed when the file is written
    journal = Path(a.out + ".partial.jsonl")
    key = json.dumps([source_hash(), optimum_parameters(params), params["mu"], DT, DT_LONG, T_AFTER, a.quick])
    done = {}
    if journal.is_file():
        for line in journal.read_text().splitlines():
            j = json.loads(line)
            if j.get("key") == key:
                done[json.dumps(j["point"], sort_keys=True)] = j["row"]
    for i, pt in enumerate(pts):
        pk = json.dumps(pt, sort_keys=True)
        if pk in done:
            out.append(done[pk])
            print(f"[{i + 1}/{len(pts)}] {pt}: {done[pk]['f_peak']:.3f} N (from {journal.name})", flush=True)
            continue
        dt = coarse_dt(pt)
        c = solve_point(params, pt, dt, T_AFTER)
        if a.quick:
            f = c
        else:
            f = solve_point(params, pt, dt / 2, T_AFTER, f_guess=c.f_peak)
        row = {**pt, "dt": dt / (1 if a.quick else 2), "f_peak": f.f_peak, "ok": bool(c.ok and f.ok), "status": f.status,
               "f_peak_coarse": c.f_peak, "status_coarse": c.status,
               "rel_change_mesh": (f.f_peak - c.f_peak) / f.f_peak if f.f_peak else math.nan,
               "intervals": f.n_intervals, "seconds": round(c.seconds + (0 if a.quick else f.seconds), 1),
               "peak_zmp": float(max(abs(f.zmp.max()), abs(f.zmp.min()))),
               "max_hip_rate": float(abs(f.dq[:, 1]).max()), "max_ankle_rate": float(abs(f.dq[:, 0]).max()),
               "max_hip_torque": float(abs(f.tau[:, 1]).max()), "max_ankle_torque": float(abs(f.tau[:, 0]).max())}
        out.append(row)
        with journal.open("a") as fh:
            fh.write(json.dumps({"key": key, "point": pt, "row": row}) + "\n")
        print(f"[{i + 1}/{len(pts)}] dir {pt['direction']:+d} rise {pt['rise']:g} h {pt['height']:g} "
              f"D {pt['duration']:g}: {f.f_peak:.3f} N ({f.status}; coarse {c.f_peak:.3f}, "
              f"{100 * row['rel_change_mesh']:+.3f} %) {row['seconds']:.0f} s", flush=True)
    horizon, static = [], {}
    if not a.quick:
        for pt in [p for p in pts if p["height"] == h0 and p["rise"] == 0.05 and p["duration"] in (0.1, 1.0, 4.0)]:
            s = solve_point(params, pt, coarse_dt(pt), T_AFTER_CHECK)
            base = next(r["f_peak_coarse"] for r in out if all(r[k] == pt[k] for k in pt))
            horizon.append({**pt, "t_after": T_AFTER_CHECK, "f_peak_coarse": s.f_peak, "status": s.status,
                            "rel_change_horizon": (s.f_peak - base) / base})
            print(f"horizon check {pt}: {s.f_peak:.3f} N against {base:.3f} N", flush=True)
        for d in (1, -1):
            pb = ff.problem_from_params(params, d)
            static[str(d)] = {"nonlinear": ff.static_optimum(pb), "rigid_height": ff.static_optimum(pb, True)}
    data = {
        "about": "the flat-footed optimum: largest peak force [N] of a trapezoid push any flat-footed controller "
                 "survives (docs/capability.md section 8); made by scripts/flat_footed_optimum.py",
        "made": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "command": "python scripts/flat_footed_optimum.py" + (" --quick" if a.quick else ""),
        "model_sha256": source_hash(),
        "parameters": {**optimum_parameters(params), "mu": params["mu"]},
        "settings": {"transcription": f"direct collocation, Radau IIA degree {ff.DEGREE}, torques at the collocation "
                                      "points, mesh aligned with the push's break points",
                     "dt": "per point (its dt): the coarse mesh's halved", "dt_coarse": [DT, DT_LONG],
                     "dt_coarse_rule": "DT up to 1 s pushes, DT_LONG beyond", "t_after": T_AFTER, "reg": ff.REG,
                     "ipopt": {k: v for k, v in ff.IPOPT_OPTIONS.items() if k.startswith("ipopt.")}},
        "points": out, "horizon_check": horizon, "static": static,
        "seconds": round(time.perf_counter() - t_start),
    }
    dest = Path(a.out)
    dest.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=dest.parent, prefix=".flat_footed.", suffix=".tmp")
    with os.fdopen(fd, "w") as fh:
        json.dump(data, fh, indent=1)
        fh.write("\n")
    os.replace(tmp, dest)
    journal.unlink(missing_ok=True)
    print(f"wrote {dest} ({len(out)} points, {data['seconds']} s)")
    return 0 if all(r["ok"] for r in out) else 1


if __name__ == "__main__":
    sys.exit(main())
