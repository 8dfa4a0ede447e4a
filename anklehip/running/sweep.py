"""Parameter sweeps with Dask: peak push force x controller variant -> outcome.

Each grid point scales the scenario's push profile so that its peak force equals the grid value
and runs the closed loop in a worker process (each worker extracts the FMUs once).
"""
from __future__ import annotations

import functools
import os

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
    from ..files.scenario import ScenarioError, parse_set
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
    from ..files.scenario import load_scenario
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
            "wall_time": res.wall_time, **({"error": res.message} if res.outcome == "error" else {})}


def _variant_hash(v: Variant) -> str:
    import hashlib
    import json
    d = json.dumps([v.name, v.controller, v.plant, v.config], sort_keys=True)
    return hashlib.sha256(d.encode()).hexdigest()[:8]


def sweep_point(spec: dict) -> dict[str, Any]:
    """One point of run_sweep (anklehip.running.points runs it on the workers)."""
    v = spec["variant"]
    return _one(spec["scenario"], spec["fmu_dir"], spec["peak_force"],
                Variant(v["name"], v["controller"], v["plant"], v["config"]), spec["engine"])


def run_sweep(scenario_path: str, forces: list[float], variants: list[Variant], fmu_dir: str | None = None,
              workers: int = 2, engine: str = "fmpy", *, scheduler: str | None = None,
              journal: Path | None = None, key: str = "", restart: bool = False):
    """Every variant at every peak force, on Dask (anklehip.running.points: a local cluster, or the
    scheduler at `scheduler` / $DASK_SCHEDULER_ADDRESS); finished points go to `journal` and a
    rerun with the same `key` skips them. Returns an anklehip.running.points.Outcome."""
    from .points import run_points
    specs = [{"id": f"{v.name}@{float(f)!r}#{_variant_hash(v)}", "scenario": str(scenario_path), "fmu_dir": fmu_dir,
              "peak_force": float(f), "engine": engine,
              "variant": {"name": v.name, "controller": v.controller, "plant": v.plant, "config": v.config}}
             for v in variants for f in forces]
    return run_points(sweep_point, specs, workers=workers, scheduler=scheduler, journal=journal, key=key,
                      what=f"sweep of {Path(scenario_path).name}", label="sweep", restart=restart)


def write_table(rows: list[dict[str, Any]], path: Path) -> Path:
    """CSV with a header (the union of the rows' keys, in order of appearance); fields quoted where
    needed (variant names may contain commas)."""
    import csv
    path.parent.mkdir(parents=True, exist_ok=True)
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    return path


def write_points_table(rows: list[dict[str, Any]], out: Path, name: str, complete: bool) -> tuple[Path, Path]:
    """The per-point table as CSV and Parquet: <name>.csv / <name>.parquet when every point is done,
    <name>.incomplete.* otherwise (never named like a finished sweep); the other pair is removed."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    from ..files.output import _atomic
    stem, other = (name, f"{name}.incomplete") if complete else (f"{name}.incomplete", name)
    for suffix in (".csv", ".parquet"):
        (out / f"{other}{suffix}").unlink(missing_ok=True)
    csv_path, pq_path = out / f"{stem}.csv", out / f"{stem}.parquet"
    with _atomic(csv_path) as (fd, tmp):
        os.close(fd)
        write_table(rows, Path(tmp))
    fields = list(dict.fromkeys(k for r in rows for k in r))
    table = pa.Table.from_pylist([{k: r.get(k) for k in fields} for r in rows])
    with _atomic(pq_path) as (fd, tmp):
        os.close(fd)
        pq.write_table(table, tmp)
    return csv_path, pq_path


def sweep_key(scenario_path: Path, models) -> str:
    """What the rows of a sweep depend on besides the point itself: the scenario file and the FMUs."""
    import hashlib
    h = hashlib.sha256()
    for p in (scenario_path, models.controller.path, models.plant.path):
        h.update(Path(p).read_bytes())
    return h.hexdigest()[:16]


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
