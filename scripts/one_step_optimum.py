"""Make the cached one-step optimum, anklehip/analysis/data/one_step_optimum.json (docs/capability.md
section 9.3): for the 1 s back push (50 ms rise, at the scenarios' push point) the largest peak force
HOAP-2 survives with one recovery step, by trajectory optimization on the whole robot's sagittal
five-link model (anklehip.analysis.one_step: CasADi, IPOPT, Radau collocation), over the step's
landing time, in two series (SERIES): the step lifting at the push's onset, its sole free to skim the
ground; and lifting 60 ms into the push, its sole 10 mm clear of the ground over mid-swing.

Each point is solved on two meshes (intervals of at most DT and DT/2): the coarse one by continuation
from its neighbour in landing time, the better of two local optima (best_coarse: the problem has a
poorer one, the step in place); the fine one warm-started from the coarse one (fine). The finer value
is cached with the relative change between the two (the convergence check) and the landed foot's drift
on each (landed_drift: it must shrink as the mesh refines). One point is solved again
with a longer horizon after the push (the horizon check). The file records the settings and the
sha256 of the sources the optimum depends on (the model, the collocation it borrows, the robot file),
so a stale cache is detected (tests/test_one_step.py). It is written whole or not at all. About
75 min with two jobs (15 to 22 min for the first series alone).

    .venv/bin/python scripts/one_step_optimum.py [--out FILE] [--jobs 2] [--quick]
"""
from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from anklehip.analysis import one_step as os_  # noqa: E402
from anklehip.analysis.bounds import is_step_forward  # noqa: E402

OUT_FILE = "one_step_optimum.json"
DURATION, RISE = 1.0, 0.05
DT = 0.05                       # the coarse mesh's longest interval [s]; the cached value is DT/2's
T_AFTER = 0.5                   # horizon after the push [s]
T_AFTER_CHECK = 1.0             # the horizon check's
# the series (t_lift [s], clearance [m]): the step lifting at the push's onset, its sole free to skim the
# ground; and lifting 60 ms in (the push-aware stepping layer decides 46-70 ms into 12-20 N pushes,
# docs/capability.md 9.2), its sole 10 mm clear over mid-swing (docs/capability.md 9.3)
SERIES = ((0.0, 0.0), (0.06, 0.01))
LANDINGS = (0.2, 0.25, 0.3, 0.35, 0.4)
SEED_LANDING = 0.3              # each chain starts here, from rest
FORWARD = 0.1                   # [m] the forced step's least length (best_coarse)


def sources() -> dict:
    """sha256 of every file the cached numbers depend on."""
    files = ["anklehip/analysis/one_step.py", "anklehip/analysis/flat_footed.py", "hoap2/hoap2.urdf",
             "hoap2/hoap2.srdf"]
    return {f: hashlib.sha256((ROOT / f).read_bytes()).hexdigest() for f in files}


def best_coarse(bp, t_lift: float, t_land: float, clearance: float, guess) -> "os_.Solution":
    """The coarse optimum of a point: the better of two local optima, each from `guess`: the free problem,
    and a step forced FORWARD ahead, then released (the problem has a poorer local optimum, the step
    in place, that a warm start from another landing time can fall into)."""
    kw = dict(t_after=T_AFTER, dt=DT, clearance=clearance)
    free = os_.solve(bp, DURATION, RISE, t_lift, t_land, guess=guess, **kw)
    forced = os_.solve(bp, DURATION, RISE, t_lift, t_land, guess=guess, l_min=FORWARD, **kw)
    released = os_.solve(bp, DURATION, RISE, t_lift, t_land, guess=forced, **kw)
    done = [s for s in (free, released) if s.ok] or [free, released]
    return max(done, key=lambda s: s.f_peak)


def coarse_chain(t_lift: float, clearance: float, landings) -> dict:
    """The coarse optima of one series (lift time, clearance), by continuation over the landing time outward from
    SEED_LANDING (the first from the lift-at-onset seed)."""
    bp = os_.hoap2()
    seed = os_.solve(bp, DURATION, RISE, 0.0, SEED_LANDING, t_after=T_AFTER, dt=DT)
    order = sorted(landings, key=lambda t: (abs(t - SEED_LANDING), t))
    coarse = {}
    for t_land in order:
        near = min(coarse, key=lambda t: abs(t - t_land)) if coarse else None
        coarse[t_land] = best_coarse(bp, t_lift, t_land, clearance, coarse[near] if near is not None else seed)
    return coarse


def fine(t_lift: float, t_land: float, clearance: float, coarse: "os_.Solution") -> "os_.Solution":
    """The fine optimum of a point, warm-started from its coarse one; when IPOPT stops short of its
    acceptable level (its iteration limit), once more from where it stopped (a restart resets its
    barrier parameter). When that is not a converged step forward (anklehip.analysis.bounds'
    is_step_forward: the warm start fell into the step in place, or did not converge), the coarse
    mesh's way out too: a step forced FORWARD ahead from the coarse optimum, then released; the best
    converged step forward of them all. The seconds are all the solves'."""
    bp = os_.hoap2()
    kw = dict(t_after=T_AFTER, dt=DT / 2, clearance=clearance)
    tried = [os_.solve(bp, DURATION, RISE, t_lift, t_land, guess=coarse, **kw)]
    if not tried[-1].ok:
        tried.append(os_.solve(bp, DURATION, RISE, t_lift, t_land, guess=tried[-1], **kw))

    def forward(s):
        return is_step_forward(s.ok, s.landing)

    seconds = sum(s.seconds for s in tried)
    if not forward(tried[-1]):
        # the forced solve is not a candidate: its least step length is not the problem's
        forced = os_.solve(bp, DURATION, RISE, t_lift, t_land, guess=coarse, l_min=FORWARD, **kw)
        tried.append(os_.solve(bp, DURATION, RISE, t_lift, t_land, guess=forced, **kw))
        seconds += forced.seconds + tried[-1].seconds
    good = [s for s in tried if forward(s)]
    best = max(good, key=lambda s: s.f_peak) if good else tried[-1]
    best.seconds = seconds
    return best


def landed_drift(s: "os_.Solution", t_land: float) -> float:
    """The largest distance [m] of the landed ankle from where it landed (L, ankle_height) at the mesh
    points from the landing on: the acceleration-level constraint's discretisation drift
    (docs/capability.md 9.3), which must shrink as the mesh refines."""
    import numpy as np
    bp = os_.hoap2()
    mdl = os_.model(bp)
    after = s.t >= t_land - 1e-9
    ankle = np.array([np.array(mdl.points(np.concatenate([p, v]))[0]).ravel() for p, v in zip(s.phi[after], s.dphi[after])])
    return float(np.hypot(ankle[:, 0] - s.landing, ankle[:, 1] - bp.ankle_height).max())


def row(t_lift: float, clearance: float, t_land: float, c: "os_.Solution", f: "os_.Solution", quick: bool) -> dict:
    r = {"duration": DURATION, "rise": RISE, "t_lift": t_lift, "clearance": clearance, "t_land": t_land, "dt": DT if quick else DT / 2,
         "f_peak": f.f_peak, "landing": f.landing, "ok": bool(c.ok and f.ok), "status": f.status,
         "f_peak_coarse": c.f_peak, "status_coarse": c.status,
         "rel_change_mesh": (f.f_peak - c.f_peak) / f.f_peak, "intervals": f.n_intervals,
         "seconds": round(c.seconds + (0.0 if quick else f.seconds), 1),
         "max_stance_ankle": float(abs(f.phi[:, 0]).max()),
         "landed_drift": landed_drift(f, t_land), "landed_drift_coarse": landed_drift(c, t_land)}
    print(f"lift {t_lift:g} clearance {clearance:g} land {t_land:g}: {f.f_peak:.3f} N, L {1000 * f.landing:.0f} mm ({f.status}; "
          f"coarse {c.f_peak:.3f}, {100 * r['rel_change_mesh']:+.3f} %) {r['seconds']:.0f} s", flush=True)
    return r


def horizon_check() -> dict:
    bp = os_.hoap2()
    base = os_.solve(bp, DURATION, RISE, 0.0, SEED_LANDING, t_after=T_AFTER, dt=DT)
    longer = os_.solve(bp, DURATION, RISE, 0.0, SEED_LANDING, t_after=T_AFTER_CHECK, dt=DT, guess=base)
    return {"t_lift": 0.0, "t_land": SEED_LANDING, "dt": DT, "t_after": T_AFTER_CHECK, "f_peak_coarse": longer.f_peak,
            "status": longer.status, "ok": bool(base.ok and longer.ok),
            "rel_change_horizon": (longer.f_peak - base.f_peak) / base.f_peak}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "anklehip" / "analysis" / "data" / OUT_FILE))
    ap.add_argument("--jobs", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--quick", action="store_true", help="two points on the coarse mesh only (a smoke test)")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    landings = (SEED_LANDING, 0.25) if a.quick else LANDINGS
    series = SERIES[:1] if a.quick else SERIES
    with ProcessPoolExecutor(max_workers=max(1, a.jobs)) as pool:
        horizon = None if a.quick else pool.submit(horizon_check)
        chains = {s: pool.submit(coarse_chain, *s, landings) for s in series}
        coarse = {s: c.result() for s, c in chains.items()}
        fines = {(s, tl): pool.submit(fine, s[0], tl, s[1], c) for s in series for tl, c in coarse[s].items()
                 if not a.quick}
        points = [row(*s, tl, coarse[s][tl], fines[s, tl].result() if fines else coarse[s][tl], a.quick)
                  for s in series for tl in sorted(coarse[s])]
        horizon = horizon.result() if horizon else None
    data = {
        "about": "the one-step optimum: the largest peak force [N] of a 1 s back push (50 ms rise) HOAP-2 survives "
                 "with one recovery step lifting at t_lift and landing at rest at t_land, its sole at least clearance [m] "
                 "above the ground over mid-swing, by trajectory optimization "
                 "(anklehip.analysis.one_step); made by scripts/one_step_optimum.py",
        "made": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "sources_sha256": sources(),
        "settings": {"dt_coarse": DT, "t_after": T_AFTER, "degree": os_.DEGREE, "reg": os_.REG, "effort": os_.EFFORT,
                     "baumgarte": os_.BAUMGARTE, "push_height": os_.hoap2().push_height, "mu": os_.hoap2().mu,
                     "ipopt": {k: v for k, v in os_.IPOPT_OPTIONS.items() if k.startswith("ipopt.")}},
        "quick": a.quick,
        "points": points,
        "horizon_check": horizon,
        "seconds": round(time.perf_counter() - t0, 1),
    }
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=out.parent, prefix=out.name + ".", suffix=".tmp")
    with os.fdopen(fd, "w") as fh:
        json.dump(data, fh, indent=1)
        fh.write("\n")
    os.replace(tmp, out)
    print(f"wrote {out} ({len(points)} points, {data['seconds']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
