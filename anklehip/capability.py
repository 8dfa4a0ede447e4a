"""Figures of a sweep file's points (anklehip sweep FILE): where each configuration survives.

Two swept keys (a grid or random samples): one panel per variant over the two keys, o stood (green:
the ankle strategy alone; blue: the hip strategy ran), x fell, grey a failed point; and the same
panels coloured by the peak ZMP and by the time to recover. One swept key: the outcome along it,
one row per variant. More keys: the first two, every other value pooled.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np


def _label(key: str) -> str:
    units = {"push.force": "peak push force [N]", "push.duration": "push duration [s]", "push.rise": "rise time [s]",
             "push.t": "push onset [s]", "push.height": "push height above the sole [m]",
             "push.direction": "direction (+1 back, -1 chest)"}
    return units.get(key, key)


def swept_keys(sf) -> list[str]:
    return list(sf.axes) or list(sf.ranges)


def plot_points(sf, rows: list[dict[str, Any]], out: Path) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
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
        ax.set_title(f"{sf.name}: o stood (green ankle strategy only, blue hip strategy), x fell", fontsize=9)
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
            ax.set_xlabel(_label(kx))
            ax.grid(alpha=0.3)
        for k, setter in ((kx, axes[0][0].set_xscale), (ky, axes[0][0].set_yscale)):
            vals = [r[k] for r in rows if _finite(r.get(k))]
            if vals and min(vals) > 0 and max(vals) / min(vals) >= 20:   # e.g. durations 0.1 ... 4 s
                setter("log")
        axes[0][0].set_ylabel(_label(ky))
        if sc is not None:
            fig.colorbar(sc, ax=axes[0].tolist(), label="peak |ZMP| [mm]" if what == "peak_zmp"
                         else "time to recover after the push [s]")
        fig.suptitle(f"{sf.name}: " + {"outcome": "o stood (green ankle strategy only, blue hip strategy), x fell",
                                      "peak_zmp": "peak |ZMP| of the runs that stood; x fell",
                                      "time_to_recover": "time to recover; x fell"}[what], fontsize=10)
        p = out / fname
        fig.savefig(p, dpi=120, bbox_inches="tight")
        plt.close(fig)
        figs.append(p)
    return figs


def _finite(x) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x)


def _marker(r: dict, size: int = 60) -> dict:
    if r.get("outcome") == "error":
        return {"marker": "s", "c": "0.6", "s": size}
    if r.get("outcome") != "completed":
        return {"marker": "x", "c": "tab:red", "s": size}
    return {"marker": "o", "c": "tab:blue" if r.get("max_phase", 0) > 0 else "tab:green", "s": size}
