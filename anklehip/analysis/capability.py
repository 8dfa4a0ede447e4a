"""Figures of a sweep file's points (anklehip sweep FILE): where each configuration survives.

Two swept keys (a grid or random samples): one panel per variant over the two keys, o stood (green:
the ankle strategy alone; blue: the hip strategy ran), x fell, grey a failed point; and the same
panels coloured by the peak ZMP and by the time to recover. One swept key: the outcome along it,
one row per variant. More keys: the first two, every other value pooled.

A grid over push.force and push.duration (or push.height) also gives the capability map
(`capability.png`): each variant's survive/fall boundary over the other key, with the analytic
bounds of anklehip/analysis/bounds.py (docs/capability.md). A grid over push.force and push.angle
(and at most one of push.duration, push.height: a panel per value) gives the polar capability map
instead (`capability.png`): each variant's boundary per push direction against the bounds in
every direction (docs/capability.md section 7). On the sagittal maps the flat-footed optimum (the
cached trajectory optimum, docs/capability.md section 8) is drawn beside the analytic bounds, and on
a stepping sweep's map the N-step capturability bounds (section 9) and the one-step optimum (the
cached trajectory optimum of the whole robot stepping once, section 9.3).
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np


def _label(key: str) -> str:
    units = {"push.force": "peak push force [N]", "push.duration": "push duration [s]", "push.rise": "rise time [s]",
             "push.t": "push onset [s]", "push.height": "push height above the sole [m]",
             "push.direction": "direction (+1 back, -1 chest)",
             "push.angle": "push direction [deg] (0 forward, 90 toward +y, the left)"}
    return units.get(key, key)


def swept_keys(sf) -> list[str]:
    return list(sf.axes) or list(sf.ranges)


def plot_points(sf, rows: list[dict[str, Any]], out: Path) -> list[Path]:
    import matplotlib.pyplot as plt
    keys = swept_keys(sf)
    variants = [v.name for v in sf.variants]
    out = Path(out)
    figs = []
    if len(keys) == 1:
        k = keys[0]
        fig, ax = plt.subplots(figsize=(8, 1.2 + 0.7 * len(variants)))
        for i, v in enumerate(variants):
            for r in (r for r in rows if r.get("variant") == v):
                ax.scatter(r[k], i, **_marker(r))
        ax.set_yticks(range(len(variants)), variants)
        ax.set_ylim(-0.7, len(variants) - 0.3)
        ax.set_xlabel(_label(k))
        ax.set_title(f"{sf.name}: o stood, x fell; the strategy used: green the ankle strategy alone, blue the hip strategy, purple a step", fontsize=9)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        p = out / "points_outcome.png"
        fig.savefig(p, dpi=120)
        plt.close(fig)
        return [p]
    kx, ky = keys[0], keys[1]
    for what, fname in (("outcome", "points_outcome.png"), ("peak_zmp", "points_peak_zmp.png"),
                        ("time_to_recover", "points_recovery.png")):
        fig, axes = plt.subplots(1, len(variants), figsize=(4.2 * len(variants) + 0.8, 4.0), squeeze=False,
                                 sharex=True, sharey=True)
        sc = None
        for ax, v in zip(axes[0], variants):
            rr = [r for r in rows if r.get("variant") == v]
            if what == "outcome":
                for r in rr:
                    ax.scatter(r[kx], r[ky], **_marker(r, size=28))
                stood = sum(r["outcome"] == "completed" for r in rr)
                ax.set_title(f"{v}: {stood} of {len(rr)} stood", fontsize=9)
            else:
                ok = [r for r in rr if r["outcome"] == "completed" and _finite(r.get(what))]
                fell = [r for r in rr if r["outcome"] != "completed"]
                scale = 1000.0 if what == "peak_zmp" else 1.0
                sc = ax.scatter([r[kx] for r in ok], [r[ky] for r in ok], c=[scale * abs(r[what]) for r in ok],
                                cmap="viridis", s=28, vmin=0.0)
                ax.scatter([r[kx] for r in fell], [r[ky] for r in fell], marker="x", c="tab:red", s=24)
                ax.set_title(v, fontsize=9)
            ax.grid(alpha=0.3)
        fig.supxlabel(_label(kx), fontsize=10)   # one label for the panels (theirs overlapped)
        for k, which in ((kx, "x"), (ky, "y")):
            vals = [r[k] for r in rows if _finite(r.get(k))]
            if vals and min(vals) > 0 and max(vals) / min(vals) >= 20:   # e.g. durations 0.1 ... 4 s
                _plain_log(axes[0][0], which)
        axes[0][0].set_ylabel(_label(ky))
        if sc is not None:
            fig.colorbar(sc, ax=axes[0].tolist(), label="peak |ZMP| [mm]" if what == "peak_zmp"
                         else "time to recover after the push [s]")
        fig.suptitle(f"{sf.name}: " + {"outcome": "o stood, x fell; the strategy used: green the ankle strategy alone, blue the hip strategy, purple a step",
                                      "peak_zmp": "peak |ZMP| of the runs that stood; x fell",
                                      "time_to_recover": "time to recover; x fell"}[what], fontsize=10)
        p = out / fname
        fig.savefig(p, dpi=120, bbox_inches="tight")
        plt.close(fig)
        figs.append(p)
    return figs


def _plain_log(ax, which: str) -> None:
    """ax's `which` ("x" or "y") axis logarithmic, labelled 1, 2, 5 per decade in plain numbers (the
    default labels its minor ticks "2x10^0 3x10^0 ..." and they run into each other)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    if which == "x":
        ax.set_xscale("log")
        axis = ax.xaxis
    else:
        ax.set_yscale("log")
        axis = ax.yaxis
    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
    axis.set_minor_formatter(NullFormatter())


def _finite(x) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x)


def _marker(r: dict, size: int = 60) -> dict:
    if r.get("outcome") == "error":
        return {"marker": "s", "c": "0.6", "s": size}
    return {"marker": "o" if r.get("outcome") == "completed" else "x", "c": STRATEGY_COLOURS[strategy_of(r)], "s": size}


# the strategy a run used, as Stephens (2007) draws decision surfaces: a step (the stepping layer
# left STAND), else the hip strategy (sagittal phase 1 or later), else the ankle strategy alone
STRATEGY_COLOURS = {"ankle": "tab:green", "hip": "tab:blue", "step": "tab:purple"}


def strategy_of(r: dict) -> str:
    if r.get("stepped", 0):
        return "step"
    return "hip" if r.get("max_phase", 0) > 0 else "ankle"


# ---------------------------------------------------------------------------------------------
# capability map: survive/fall boundary per variant against the analytic bounds

CAPABILITY_X = ("push.duration", "push.height")


def polar_panels(sf) -> list[tuple[str | None, float | None]] | None:
    """The panels of the polar capability map: a grid over push.force and push.angle gives one panel
    [(None, None)]; with a third key among CAPABILITY_X, a panel per value [(key, value), ...] in the
    grid's order. None for any other sweep (random samples included)."""
    keys = list(sf.axes)
    if not {"push.force", "push.angle"} <= set(keys) or len(keys) > 3:
        return None
    rest = [k for k in keys if k not in ("push.force", "push.angle")]
    if not rest:
        return [(None, None)]
    if rest[0] not in CAPABILITY_X:
        return None
    return [(rest[0], float(x)) for x in dict.fromkeys(sf.axes[rest[0]])]


def capability_key(sf) -> str | None:
    """The x key of the capability map: a grid over push.force and one of CAPABILITY_X; else None."""
    keys = list(sf.axes)
    if len(keys) != 2 or "push.force" not in keys:
        return None
    kx = keys[0] if keys[1] == "push.force" else keys[1]
    return kx if kx in CAPABILITY_X else None


def survive_boundary(rows: list[dict[str, Any]], variant: str, kx: str,
                     ky: str = "push.force") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each value of kx (sorted) among the variant's rows: the largest force ky at which the
    robot stood with every smaller force at that x standing too (0 when the smallest one fell; an
    error counts as not standing), and whether every force tried there stood (the true boundary
    is then higher). Returns (x, force, all_stood) arrays. The row of a point that raised
    (anklehip.running.points) carries only its id and outcome: it is not seen here."""
    by_x: dict[float, list[tuple[float, bool]]] = {}
    for r in rows:
        if r.get("variant") == variant:
            by_x.setdefault(float(r[kx]), []).append((float(r[ky]), r.get("outcome") == "completed"))
    xs, fs, top = [], [], []
    for x in sorted(by_x):
        best, all_stood = 0.0, True
        for f, stood in sorted(by_x[x]):
            if not stood:
                all_stood = False
                break
            best = f
        xs.append(x); fs.append(best); top.append(all_stood)
    return np.array(xs), np.array(fs), np.array(top, bool)


def _axis_ends(xs: np.ndarray, log: bool) -> tuple[float, float]:
    """The x range of the map: half a grid step (geometric on a log axis) beyond the first and last x."""
    u = np.log(xs) if log else np.asarray(xs, float)
    half = (u[1] - u[0]) / 2 if len(u) > 1 else (0.2 if log else 0.05 * max(abs(u[0]), 1e-3))
    half_end = (u[-1] - u[-2]) / 2 if len(u) > 1 else half
    lo, hi = u[0] - half, u[-1] + half_end
    return (math.exp(lo), math.exp(hi)) if log else (lo, hi)


def plot_capability(sf, rows: list[dict[str, Any]], out: Path, plant_params: dict) -> Path | None:
    """capability_figure (the polar map for a grid over push.force and push.angle) as
    <out>/capability.png; None when there is none."""
    fig = capability_figure(sf, rows, plant_params)
    if fig is None:
        return None
    import matplotlib.pyplot as plt
    p = Path(out) / "capability.png"
    fig.savefig(p, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return p


def _bounds_along(sf, plant_params: dict, rise: float):
    """The bounds along the sweep's fixed push direction: (static(r), sustained(r), lip(r, durations),
    at_height(h) -> r, the plant's push height, "on the back" or the like); r a Robot for
    push.direction (the sagittal functions), a Stance for push.angle (the 3D ones). None when the
    parameters do not describe the robot."""
    import dataclasses

    from . import bounds as B
    angle = sf.push.get("angle")
    if angle is None:
        try:
            robot = B.robot_from_plant_params(plant_params)
        except KeyError:
            return None
        d = 1 if sf.push["direction"] >= 0 else -1
        return (lambda r: B.static_tipping_force(r, d), lambda r: B.sustained_push_limit(r, d),
                lambda r, dur: B.lip_force_limit(r, dur, rise, d), lambda h: dataclasses.replace(robot, h=h),
                robot.h, "on the back" if d > 0 else "on the chest")
    stance = stance_of(plant_params)
    if stance is None:
        return None
    return (lambda s: B.static_tipping_force_3d(s, angle), lambda s: B.sustained_push_limit_3d(s, angle),
            lambda s, dur: B.lip_force_limit_3d(s, angle, dur, rise),
            lambda h: dataclasses.replace(stance, body=dataclasses.replace(stance.body, h=h)),
            stance.body.h, f"toward {angle:g} deg")



def sweep_steps(sf) -> bool:
    """Whether a sweep declares stepping: a variant whose controller overrides switch on a parameter
    whose name has "step" in it (e.g. stepping_enabled = 1). Its map then shows the N-step bounds."""
    return any(("step" in k) and bool(v) for x in sf.variants for k, v in x.controller.items())


def optimum_curve(plant_params: dict, direction: int, rise: float, kx: str, xx, h0: float, dur: float):
    """The flat-footed optimum (anklehip.analysis.bounds.flat_footed_optimum) along the map's x: over
    durations at the height h0, or over heights for the push of duration dur; NaN where x is outside
    the cache. (values, None), or (None, the reason) when the cache does not apply to this push or
    robot (another rise, a stale cache)."""
    from ..errors import InputError
    from . import bounds as B
    xx = np.asarray(xx, float)
    y = np.full(xx.shape, np.nan)
    try:
        data = B.load_optimum()
        bad = B.optimum_matches(data, plant_params)
        if bad:
            return None, f"flat-footed optimum cached for another robot ({', '.join(bad)} differ)"
        if kx == "push.duration":
            ds = [p["duration"] for p in data["points"] if p["direction"] == direction and p["ok"]
                  and math.isclose(p["rise"], rise, abs_tol=1e-12) and math.isclose(p["height"], h0, rel_tol=1e-9)]
            if len(ds) < 2:
                return None, f"flat-footed optimum not cached for {1000 * rise:g} ms rises at h = {h0:g} m"
            m = (xx >= min(ds)) & (xx <= max(ds))
            y[m] = B.flat_footed_optimum(xx[m], rise, direction, h0, data=data)
            return y, None
        for i, h in enumerate(xx):
            try:
                y[i] = B.flat_footed_optimum(dur, rise, direction, h, data=data)
            except InputError:
                pass
        return (y, None) if np.isfinite(y).any() else (None, f"flat-footed optimum not cached for {dur:g} s pushes "
                                                              f"of {1000 * rise:g} ms rise over heights")
    except InputError as e:
        return None, str(e)


def cached_points(direction: int, rise: float, kx: str, h0: float, dur: float) -> list[dict]:
    """The cache's points on a map's line: at the height h0 over durations, or of duration dur over
    heights ([] without a cache)."""
    from ..errors import InputError
    from .bounds import load_optimum
    try:
        pts = load_optimum()["points"]
    except InputError:
        return []
    same = [p for p in pts if p["direction"] == direction and p["ok"] and math.isclose(p["rise"], rise, abs_tol=1e-12)]
    if kx == "push.duration":
        return [p for p in same if math.isclose(p["height"], h0, rel_tol=1e-9)]
    return [p for p in same if math.isclose(p["duration"], dur, rel_tol=1e-9)]


def one_step_point(plant_params: dict, direction: int, rise: float, kx: str, h0: float):
    """The one-step optimum (anklehip.analysis.bounds.one_step_optimum) on a stepping map over push
    durations: ([(duration, force, landing time) per cached push duration], None), or ([], the reason)
    where it does not apply: another map, a push on the chest, another robot than the HOAP-2 both
    optimum caches were made for (the flat-footed cache's robot check), another push height or rise."""
    from ..errors import InputError
    from . import bounds as B
    if kx != "push.duration" or direction != 1:
        return [], None
    try:
        if B.optimum_matches(B.load_optimum(), plant_params):
            return [], None          # another robot: the flat-footed optimum's reason is given
        data = B.load_one_step_optimum()
    except InputError as e:
        return [], str(e)
    if not math.isclose(data["settings"]["push_height"], h0, rel_tol=1e-9):
        return [], f"one-step optimum cached at h = {data['settings']['push_height']:g} m only"
    out = []
    for dur in sorted({p["duration"] for p in data["points"]}):
        try:
            f, t = B.one_step_optimum(dur, rise, data=data)
        except InputError:
            continue
        out.append((dur, f, t))
    return out, None if out else f"one-step optimum not cached for {1000 * rise:g} ms rises"


def stepping_curves(plant_params: dict, robot, direction: int, rise: float, kx: str, xx, dur: float, at_height):
    """The N-step capturability bounds (anklehip.analysis.bounds.n_step_force_limit, N = 1, 2, inf)
    along the map's x with HOAP-2's step (step_reach), and the sustained-push limit after one step:
    {label: values}; {} when the parameters do not give the leg."""
    from . import bounds as B
    try:
        l_max, dt_s = B.step_reach(plant_params)
    except (KeyError, ValueError):
        return {}
    out = {}
    for n in (1, 2, math.inf):
        lab = f"LIP capturable in {'∞' if math.isinf(n) else n} step{'s' if n != 1 else ''} (l_max {1000 * l_max:.0f} mm, {1000 * dt_s:.0f} ms)"
        if kx == "push.duration":
            out[lab] = np.asarray(B.n_step_force_limit(robot, xx, rise, direction, n, l_max, dt_s))
        else:
            out[lab] = np.array([float(B.n_step_force_limit(at_height(h), dur, rise, direction, n, l_max, dt_s)) for h in xx])
    lab = "sustained-push limit after one step"
    out[lab] = (np.full(np.shape(xx), B.sustained_push_limit_stepped(robot, l_max, direction)) if kx == "push.duration"
                else np.array([B.sustained_push_limit_stepped(at_height(h), l_max, direction) for h in xx]))
    return out


def bound_lines(sf, plant_params: dict) -> list[str]:
    """The bounds at the grid's x values as text lines (printed by anklehip sweep under the boundaries):
    static tipping, sustained, LIP, the flat-footed optimum, and on a stepping sweep the N-step
    bounds. [] when the sweep has no capability map along a push property, or a fixed push.angle."""
    kx = capability_key(sf)
    if kx is None or sf.push.get("angle") is not None:
        return []
    from . import bounds as B
    try:
        robot = B.robot_from_plant_params(plant_params)
    except KeyError:
        return []
    import dataclasses
    d = 1 if sf.push["direction"] >= 0 else -1
    rise, dur = sf.push["rise"], sf.push["duration"]
    xv = np.array(sorted(set(sf.axes[kx])), float)
    at = (lambda x: robot) if kx == "push.duration" else (lambda x: dataclasses.replace(robot, h=x))
    rows = {"static tipping": [B.static_tipping_force(at(x), d) for x in xv],
            "sustained limit": [B.sustained_push_limit(at(x), d) for x in xv],
            "LIP bound": [float(B.lip_force_limit(at(x), x if kx == "push.duration" else dur, rise, d)) for x in xv]}
    opt, why = optimum_curve(plant_params, d, rise, kx, xv, robot.h, dur)
    if opt is not None:
        rows["flat-footed opt."] = list(opt)
    one = []
    if sweep_steps(sf):
        for k, v in stepping_curves(plant_params, robot, d, rise, kx, xv, dur, at).items():
            rows[k.split(" (")[0].replace("LIP capturable in", "LIP,")] = list(v)
        one, why_one = one_step_point(plant_params, d, rise, kx, robot.h)
        why = why or why_one
    out = [f"  {k:<16} " + "  ".join(f"{x:g}: {f:.1f}" for x, f in zip(xv, vals)) for k, vals in rows.items()]
    if one:
        out.append(f"  {'one-step opt.':<16} " + "  ".join(f"{x:g}: {f:.1f} (landing {1000 * t:.0f} ms)"
                                                           for x, f, t in one))
    if why:
        out.append(f"  ({why})")
    return out


def capability_figure(sf, rows: list[dict[str, Any]], plant_params: dict, stepping: bool | None = None):
    """The capability map: one axes, x = push.duration (log) or push.height, y = peak push force; each
    variant's survive/fall boundary (survive_boundary) as a step line, each value held back to the
    previous x (a longer or higher push is harder), the best variant's region shaded, and the
    analytic bounds: static tipping, sustained-push limit and the LIP bound of the ankle strategy.
    Forces are magnitudes (push.direction -1: on the chest, bounds mirrored). The bounds use
    plant_params (the plant FMU's defaults with the scenario's and the first variant's overrides).
    A grid over push.force and push.angle gives polar_figure instead. None when the sweep is
    neither, or the parameters are not the robot's (the sagittal model's; for the polar map also
    the stance's: anklehip.analysis.bounds.stance_from_params). A fixed push.angle gives the
    bounds in that direction. On the sagittal model the flat-footed optimum is drawn too where it is
    cached for this robot and push (optimum_curve); stepping (default: sweep_steps(sf)) adds the
    N-step capturability bounds (stepping_curves)."""
    if polar_panels(sf) is not None:
        return polar_figure(sf, rows, plant_params)

    kx = capability_key(sf)
    if kx is None:
        return None
    rise, dur = sf.push["rise"], sf.push["duration"]
    bounds = _bounds_along(sf, plant_params, rise)
    if bounds is None:
        return None
    static_of, sustained_of, lip_of, at_height, h0, side = bounds
    import matplotlib.pyplot as plt
    xv = np.array(sorted(set(sf.axes[kx])), float)
    log = kx == "push.duration" and xv[0] > 0
    fig, ax = plt.subplots(figsize=(8, 5.2))
    names = [x.name for x in sf.variants]
    boundaries = {v: survive_boundary(rows, v, kx) for v in names}
    # A longer (or higher) push is harder: the force that stood at x also stands for every x' between
    # the previous grid value and x. Each step is drawn back to the previous x: an inner estimate.
    x0, x1 = _axis_ends(xv, log)
    best = [max([float(fs[xs == x][0]) for xs, fs, _ in boundaries.values() if x in xs], default=0.0) for x in xv]
    ax.stairs(best, np.concatenate([[x0], xv]), fill=True, color="tab:green", alpha=0.10, lw=0)   # the best variant
    for i, v in enumerate(names):     # earlier variants drawn wider: equal boundaries stay visible
        xs, fs, top = boundaries[v]
        if not len(xs):
            continue
        c = f"C{i}"
        ax.stairs(fs, np.concatenate([[x0], xs]), baseline=None, color=c, lw=1.3 + 1.2 * (len(names) - 1 - i), label=v)
        ax.plot(xs[~top], fs[~top], "o", color=c, ms=4)
        ax.plot(xs[top], fs[top], "^", color=c, ms=7)
    # the analytic bounds over x
    xx = np.geomspace(x0, x1, 400) if log else np.linspace(max(x0, 1e-3), x1, 400)
    if kx == "push.duration":
        r0 = at_height(h0)
        static = np.full_like(xx, static_of(r0))
        sustained = np.full_like(xx, sustained_of(r0))
        lip = np.asarray(lip_of(r0, xx))
        lip_label = f"LIP bound of the ankle strategy ({1000 * rise:g} ms rise/fall, h = {h0:.3f} m)"
        shape = f"trapezoid push {side}, rise/fall {1000 * rise:g} ms, at h = {h0:.3f} m"
    else:
        hs = [at_height(h) for h in xx]
        static = np.array([static_of(r) for r in hs])
        sustained = np.array([sustained_of(r) for r in hs])
        lip = np.array([float(lip_of(r, dur)) for r in hs])
        lip_label = f"LIP bound of the ankle strategy ({dur:g} s push, {1000 * rise:g} ms rise/fall)"
        shape = f"trapezoid push {side}, {dur:g} s, rise/fall {1000 * rise:g} ms"
    ax.plot(xx, static, "--", color="k", lw=1.3, label="static tipping force (erect, rigid)")
    ax.plot(xx, sustained, ":", color="0.35", lw=1.6, label="sustained-push limit (any flat-footed strategy)")
    ax.plot(xx, lip, "-", color="k", lw=1.3, label=lip_label)
    tops = [float(np.max(sustained))]
    why = None
    if sf.push.get("angle") is None:       # the sagittal model's: the optimum and the stepping bounds
        d = 1 if sf.push["direction"] >= 0 else -1
        robot = at_height(h0)
        opt, why = optimum_curve(plant_params, d, rise, kx, xx, h0, dur)
        if opt is not None:       # the cached points as dots, the line between them interpolated
            ax.plot(xx, opt, "-", color="tab:purple", lw=2.0, alpha=0.8,
                    label="flat-footed optimum (trajectory optimization, any flat-footed controller)")
            xc = np.array(sorted({p[kx.split(".")[1]] for p in cached_points(d, rise, kx, h0, dur)}))
            xc = xc[(xc >= xx[0]) & (xc <= xx[-1])]
            if len(xc):
                yc, _ = optimum_curve(plant_params, d, rise, kx, xc, h0, dur)
                ax.plot(xc, yc, "o", color="tab:purple", ms=4, alpha=0.8)
        if sweep_steps(sf) if stepping is None else stepping:
            for j, (lab, y) in enumerate(stepping_curves(plant_params, robot, d, rise, kx, xx, dur, at_height).items()):
                ax.plot(xx, y, "-." if "steps" in lab or "step (" in lab else ":", color=f"C{6 + j}", lw=1.2, label=lab)
                if "1 step (" in lab or "after one step" in lab:     # the y range: what one step allows at the far x
                    tops.append(float(y[-1]))
            one, why_one = one_step_point(plant_params, d, rise, kx, h0)
            why = why or why_one
            for k, (x, f, t) in enumerate(one):
                ax.plot([x], [f], "*", color="tab:purple", ms=13, zorder=5,
                        label=f"one-step optimum (trajectory optimization, the step landing {1000 * t:.0f} ms "
                              f"after the onset)" if k == 0 else None)
                tops.append(f)
    fmax = max([max(sf.axes["push.force"])] + tops)
    ax.set_ylim(0.0, 1.15 * fmax)
    ax.set_xlim(xx[0], xx[-1])
    if log:
        ax.set_xscale("log")
        ax.set_xticks(xv, [f"{x:g}" for x in xv])
        ax.minorticks_off()
    ax.set_xlabel(_label(kx))
    ax.set_ylabel(f"peak push force {side} [N]")
    ax.grid(alpha=0.3)
    note = "steps: largest force that stood with every smaller one (o), held back to the previous x; ^ all stood"
    errors = sum(r.get("outcome") == "error" for r in rows)
    if errors:
        note += f"; {errors} points failed (error), see points.csv"
    if any(v.plant != sf.variants[0].plant for v in sf.variants):
        note += f"; bounds for the plant of variant {sf.variants[0].name}"
    if why:
        note += f"\n({why})"
    ax.set_title(f"{sf.name}: capability map, {shape}\n{note}", fontsize=9)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, fontsize=8, frameon=False)
    return fig


# ---------------------------------------------------------------------------------------------
# the polar capability map: the boundary per push direction against the bounds in every direction

def stance_of(plant_params: dict):
    """The Stance of a sweep's plant parameters (anklehip.running.sweep: the plant's numbers completed
    by its header, standing in the controller's erect posture); None when they do not describe one."""
    from .bounds import stance_from_params
    try:
        return stance_from_params(plant_params, plant_params.get("theta_ankle_erect", 0.0),
                                  plant_params.get("theta_hip_erect", 0.0))
    except KeyError:
        return None


def polar_bounds(stance, angles, panel: tuple[str | None, float | None], push: dict) -> dict[str, np.ndarray]:
    """The three bounds [N] at the angles [deg] for one panel of the polar map: the push's duration
    and rise from the sweep's [push] unless the panel is a duration; its height the stance's unless
    the panel is a height."""
    import dataclasses

    from .bounds import lip_force_limit_3d, static_tipping_force_3d, sustained_push_limit_3d
    key, value = panel
    if key == "push.height":
        stance = dataclasses.replace(stance, body=dataclasses.replace(stance.body, h=value))
    duration = value if key == "push.duration" else push["duration"]
    a = np.asarray(angles, float)
    return {"static": np.asarray(static_tipping_force_3d(stance, a)),
            "sustained": np.asarray(sustained_push_limit_3d(stance, a)),
            "lip": np.asarray(lip_force_limit_3d(stance, a, duration, push["rise"]))}


def panel_rows(rows, panel):
    """The rows of one panel of the polar map (all of them without a third key)."""
    key, value = panel
    return rows if key is None else [r for r in rows if key in r and float(r[key]) == value]


def polar_figure(sf, rows: list[dict[str, Any]], plant_params: dict):
    """The polar capability map: a polar panel per value of the grid's third key (push.duration or
    push.height; one panel without one), seen from above with the robot facing up (0 deg, forward,
    at the top; 90 deg, toward +y, to the left). Per variant and push direction, the largest force
    that stood with every smaller one standing too (survive_boundary over push.angle; ^ where every
    force tried stood), the tested directions joined by lines; and the bounds in every direction
    (static tipping, sustained-push limit, LIP bound of the CoP-only strategy for the panel's
    duration) for the first variant's plant in the controller's erect posture. None without a
    stance in plant_params."""
    stance = stance_of(plant_params)
    panels = polar_panels(sf)
    if stance is None or panels is None:
        return None
    import matplotlib.pyplot as plt

    from .bounds import sustained_push_limit_3d
    names = [x.name for x in sf.variants]
    n = len(panels)
    fig, axes = plt.subplots(1, n, figsize=(5.4 * n + 0.6, 6.6), subplot_kw={"projection": "polar"}, squeeze=False)
    th = np.linspace(0.0, 360.0, 721)
    fmax = max(sf.axes["push.force"])
    rmax = 1.08 * max(fmax, float(np.max(sustained_push_limit_3d(stance, th))))
    for ax, panel in zip(axes[0], panels):
        ax.set_theta_zero_location("N")
        b = polar_bounds(stance, th, panel, sf.push)
        t = np.radians(th)
        for i, v in enumerate(names):
            xs, fs, top = survive_boundary(panel_rows(rows, panel), v, "push.angle")
            if not len(xs):
                continue
            c = f"C{i}"
            order = np.argsort(np.mod(xs, 360.0))
            ang = np.radians(np.mod(xs[order], 360.0))
            f, tp = fs[order], top[order]
            closed = len(xs) > 2 and np.ptp(np.mod(xs, 360.0)) > 180.0
            ax.plot(np.append(ang, ang[0]) if closed else ang, np.append(f, f[0]) if closed else f, "-", color=c,
                    lw=1.2 + 1.0 * (len(names) - 1 - i), label=v)
            ax.plot(ang[~tp], f[~tp], "o", color=c, ms=4)
            ax.plot(ang[tp], f[tp], "^", color=c, ms=7)
        ax.plot(t, b["static"], "--", color="k", lw=1.2, label="static tipping force (erect, rigid)")
        ax.plot(t, b["sustained"], ":", color="0.35", lw=1.5, label="sustained-push limit (any flat-footed strategy)")
        ax.plot(t, b["lip"], "-", color="k", lw=1.1, label="LIP bound of the CoP-only strategy")
        ax.set_ylim(0.0, rmax)
        ax.set_rlabel_position(112.5)
        ax.tick_params(labelsize=7)
        key, value = panel
        what = (f"{sf.push['duration']:g} s pushes" if key is None else f"{value:g} s pushes"
                if key == "push.duration" else f"pushes at h = {value:g} m")
        ax.set_title(what, fontsize=9, pad=14)
    rise = 1000 * sf.push["rise"]
    dur = "" if any(k == "push.duration" for k, _ in panels) else f", {sf.push['duration']:g} s"
    h = "" if any(k == "push.height" for k, _ in panels) else f", at h = {stance.body.h:.3f} m"
    note = ("radius: largest peak force [N] that stood with every smaller one (o; ^ all stood), per push direction, "
            "seen from above (0 deg forward, 90 deg to the left)")
    errors = sum(r.get("outcome") == "error" for r in rows)
    if errors:
        note += f"; {errors} points failed (error), see points.csv"
    if any(v.plant != sf.variants[0].plant for v in sf.variants):
        note += f"; bounds for the plant of variant {sf.variants[0].name}"
    fig.suptitle(f"{sf.name}: polar capability map, trapezoid pushes{dur}, rise/fall {rise:g} ms{h}\n{note}",
                 fontsize=9)
    handles, labels = axes[0][0].get_legend_handles_labels()
    leg = fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8, frameon=False)
    below = leg.get_window_extent(fig.canvas.get_renderer()).height / fig.bbox.height   # the panels above it
    fig.tight_layout(rect=(0, below + 0.04, 1, 0.93))
    return fig
