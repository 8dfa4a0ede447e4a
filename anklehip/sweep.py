"""Parameter sweeps with Dask: peak push force x controller variant -> outcome.

Each grid point scales the scenario's push profile so that its peak force equals the grid value
and runs the closed loop in a worker process (each worker extracts the FMUs once).
"""
from __future__ import annotations

import functools

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

VARIANTS_HELP = ("NAME or NAME:config=C,controller.P=V,plant.Q=W with C a named controller configuration "
                 "(e.g. full  ankle_only:controller.hip_strategy_enabled=0  paper:config=paper)")


@dataclass
class Variant:
    name: str
    controller: dict[str, Any]
    plant: dict[str, Any]
    config: str | None = None     # a named controller configuration (None: the scenario's)


MAX_GRID = 10_000     # grid points: each is a closed-loop run


def parse_grid(spec: str, what: str = "grid") -> list[float]:
    """'2:12:1' (start:stop:step, inclusive) or '3,5,8'; a ValueError naming `what` and the spec."""
    parts = spec.split(":") if ":" in spec else [x for x in spec.split(",") if x.strip()]
    try:
        vals = [float(x) for x in parts]
    except ValueError:
        raise ValueError(f"{what} {spec}: expected start:stop:step or a,b,c (numbers)") from None
    if not vals or not all(np.isfinite(vals)) or (":" in spec and len(vals) != 3):
        raise ValueError(f"{what} {spec}: expected start:stop:step or a,b,c (finite numbers)")
    if ":" in spec:
        a, b, s = vals
        if s <= 0 or b < a:
            raise ValueError(f"{what} {spec}: need start <= stop and step > 0")
        if (b - a) / s > MAX_GRID:
            raise ValueError(f"{what} {spec}: more than {MAX_GRID} grid points")
        return [float(round(x, 9)) + 0.0 for x in np.arange(a, b + s / 2, s)]   # + 0.0: no -0
    return vals


def parse_variant(spec: str) -> Variant:
    from .scenario import ScenarioError, parse_set
    name, _, rest = spec.partition(":")
    items = [s.strip() for s in rest.split(",") if s.strip()]
    configs = [s.split("=", 1)[1].strip() for s in items if s.startswith("config=")]
    if len(configs) > 1 or (configs and not configs[0]):
        raise ScenarioError(f"--variant {spec}: give at most one non-empty config=NAME")
    c, p = parse_set([s for s in items if not s.startswith("config=")])
    return Variant(name or "default", c, p, configs[0] if configs else None)


@functools.lru_cache(maxsize=4)
def cached_models(fmu_dir: str | None, plant_model: str):
    """The FMUs, loaded (unpacked) once per worker process and reused by its runs."""
    from .master import Models
    return Models.load(fmu_dir, plant_model=plant_model)


def _one(scenario_path: str, fmu_dir: str | None, peak: float, variant: Variant, engine: str = "fmpy") -> dict[str, Any]:
    from .master import simulate
    from .scenario import load_scenario
    sc = load_scenario(scenario_path)
    if variant.config:
        sc.controller_config = variant.config
    base = sc.push.peak()
    if base == 0:
        raise ValueError(f"{scenario_path}: the scenario has no push to scale")
    res = simulate(sc, cached_models(fmu_dir, sc.plant_model), controller_overrides=variant.controller,
                   plant_overrides=variant.plant, push=sc.push.scaled(peak / base), progress=False, engine=engine)
    d = res.data
    return {"variant": variant.name, "peak_force": peak, "outcome": res.outcome,
            "fell_at": res.fell_at if res.fell_at is not None else float("nan"),
            "max_phase": int(d["phase"].max()) if "phase" in d.dtype.names else -1,
            "max_abs_zmp": float(np.max(np.abs(d["zmp_x"]))),
            "max_abs_hip": float(np.max(np.abs(d["theta_hip"]))),
            # how far the foot tipped (0 while it stays flat), how often the plant switched contact
            # (including sub-millisecond switches at communication points), the last phase
            "max_abs_foot_pitch": float(np.max(np.abs(d["foot_pitch"]))) if "foot_pitch" in d.dtype.names else float("nan"),
            "mode_switches": int(d["mode_switches"][-1]) if "mode_switches" in d.dtype.names else -1,
            "final_phase": int(d["phase"][-1]) if "phase" in d.dtype.names else -1,
            "wall_time": res.wall_time}


def run_sweep(scenario_path: str, forces: list[float], variants: list[Variant], fmu_dir: str | None = None,
              workers: int = 2, engine: str = "fmpy") -> list[dict[str, Any]]:
    import dask
    return _compute([dask.delayed(_one)(str(scenario_path), fmu_dir, float(f), v, engine)
                     for v in variants for f in forces], workers)


def _compute(tasks: list, workers: int) -> list[dict[str, Any]]:
    """Dask: in this process (workers <= 1) or on a local cluster of `workers` processes."""
    import dask
    if workers <= 1:
        return list(dask.compute(*tasks, scheduler="synchronous"))
    from dask.distributed import Client, LocalCluster
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cl, \
            Client(cl) as client:
        futs = client.compute(tasks)
        import sys
        if sys.stderr.isatty():
            try:
                from dask.distributed import progress
                progress(futs)
            except Exception:
                pass
        return client.gather(futs)


def write_table(rows: list[dict[str, Any]], path: Path) -> Path:
    """CSV with a header; fields quoted where needed (variant names may contain commas)."""
    import csv
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    return path


def plot_sweep(rows: list[dict[str, Any]], path: Path, title: str = "") -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    variants = list(dict.fromkeys(r["variant"] for r in rows))
    fig, ax = plt.subplots(figsize=(8, 1.2 + 0.7 * len(variants)))
    for i, v in enumerate(variants):
        rr = [r for r in rows if r["variant"] == v]
        for r in rr:
            fell = r["outcome"] == "fell"
            ax.scatter(r["peak_force"], i, marker="x" if fell else "o", s=60,
                       c="tab:red" if fell else ("tab:green" if r["max_phase"] <= 0 else "tab:blue"))
            if not fell:
                ax.annotate(str(r["max_phase"]), (r["peak_force"], i), textcoords="offset points",
                            xytext=(0, 7), ha="center", fontsize=7)
    ax.set_yticks(range(len(variants)), variants)
    ax.set_ylim(-0.7, len(variants) - 0.3)
    ax.set_xlabel("peak push force [N]")
    ax.set_title(title or "outcome (o stood, number = highest phase; x fell)", fontsize=9)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
