"""Parameter sweeps with Dask: peak push force x controller variant -> outcome.

Each grid point scales the scenario's push profile so that its peak force equals the grid value
and runs the closed loop in a worker process (each worker extracts the FMUs once).
"""
from __future__ import annotations

import functools
import os

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

VARIANTS_HELP = ("NAME or NAME:config=C,controller_model=M,controller.P=V,plant.Q=W with C a named controller "
                 "configuration and M the controller FMU (sagittal or 3d; default the scenario's) "
                 "(e.g. full  ankle_only:controller.hip_strategy_enabled=0  paper:config=paper  frontal:controller_model=3d)")


@dataclass
class Variant:
    """A controller variant of a sweep: its name, controller and plant overrides and a named
    configuration (None: the scenario's). parse_variant reads "NAME:config=C,controller.P=V"."""
    name: str
    controller: dict[str, Any]
    plant: dict[str, Any]
    config: str | None = None     # a named controller configuration (None: the scenario's)
    controller_model: str | None = None   # a key of paths.CONTROLLER_FMUS (None: the scenario's)

    def as_dict(self) -> dict[str, Any]:
        """The variant as the points' specs carry it (Variant.from_dict reads it back)."""
        return {"name": self.name, "controller": self.controller, "plant": self.plant, "config": self.config,
                "controller_model": self.controller_model}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Variant":
        return cls(d["name"], d["controller"], d["plant"], d["config"], d.get("controller_model"))

    def digest(self) -> str:
        """A short hash of the variant for point ids (without controller_model when it is the
        scenario's, so journals written before it existed still resume)."""
        import hashlib
        import json
        key = [self.name, self.controller, self.plant, self.config] + ([self.controller_model] if self.controller_model else [])
        return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:8]

    def apply(self, sc, where: str = "variant"):
        """The scenario `sc` as this variant runs it (its named configuration and controller model);
        an InputError naming `where` if the controller model does not fit the scenario's plant."""
        from ..errors import InputError
        from ..files.paths import CONTROLLER_FMUS
        if self.config:
            sc.controller_config = self.config
        if self.controller_model:
            if self.controller_model not in CONTROLLER_FMUS:
                raise InputError(f"{where}: unknown controller model {self.controller_model!r} "
                                 f"(known: {', '.join(CONTROLLER_FMUS)})")
            if self.controller_model == "3d" and sc.plant_model != "3d":
                raise InputError(f"{where}: the 3D controller needs the 3D plant, and the scenario "
                                 f"{sc.name} runs plant_model = {sc.plant_model!r}")
            sc.controller_model = self.controller_model
        return sc


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
    cms = [s.split("=", 1)[1].strip() for s in items if s.startswith("controller_model=")]
    if len(cms) > 1 or (cms and not cms[0]):
        raise ScenarioError(f"--variant {spec}: give at most one non-empty controller_model=MODEL")
    c, p = parse_set([s for s in items if not s.startswith(("config=", "controller_model="))])
    return Variant(name or "default", c, p, configs[0] if configs else None, cms[0] if cms else None)


@functools.lru_cache(maxsize=4)
def cached_models(fmu_dir: str | None, plant_model: str, controller_model: str = "sagittal"):
    """The FMUs, loaded (unpacked) once per worker process and reused by its runs."""
    from .master import Models
    return Models.load(fmu_dir, plant_model=plant_model, controller_model=controller_model)


def _one(scenario_path: str, fmu_dir: str | None, peak: float, variant: Variant, engine: str = "fmpy") -> dict[str, Any]:
    from .master import simulate
    from ..files.scenario import load_scenario
    sc = variant.apply(load_scenario(scenario_path))
    base = sc.push.peak()
    if base == 0:
        raise ValueError(f"{scenario_path}: the scenario has no push to scale")
    res = simulate(sc, cached_models(fmu_dir, sc.plant_model, sc.controller_model), controller_overrides=variant.controller,
                   plant_overrides=variant.plant, push=sc.push.scaled(peak / base), progress=False, engine=engine, check_load=False)
    d = res.data
    return {"variant": variant.name, "peak_force": peak, **run_columns(res),
            "max_abs_zmp": float(np.max(np.abs(d["zmp_x"]))),
            "max_abs_hip": float(np.max(np.abs(d["theta_hip"]))),
            "final_phase": int(d["phase"][-1]) if "phase" in d.dtype.names else -1,
            "wall_time": res.wall_time, **({"error": res.message} if res.outcome == "error" else {})}


def run_columns(res) -> dict[str, Any]:
    """The columns of a run that every sweep's rows carry (force sweeps here, sweep files in
    sweepfile.py): the outcome and fall time, the deepest phase, how far the foot tipped (0 while it
    stays flat), how often the plant switched contact (including sub-millisecond switches at
    communication points), and the stepping layer's (stepping_columns)."""
    d = res.data
    names = d.dtype.names
    return {"outcome": res.outcome, "fell_at": res.fell_at if res.fell_at is not None else float("nan"),
            "max_phase": int(d["phase"].max()) if "phase" in names else -1,
            "max_abs_foot_pitch": float(np.max(np.abs(d["foot_pitch"]))) if "foot_pitch" in names else float("nan"),
            "mode_switches": int(d["mode_switches"][-1]) if "mode_switches" in names else -1,
            **stepping_columns(d)}


def stepping_columns(d) -> dict[str, int]:
    """The 3D controller's stepping layer in a run (nothing for a controller without one): the steps
    landed, and whether a step was taken at all (the layer left STAND; a step that falls before its
    landing counts)."""
    if "step_phase" not in d.dtype.names:
        return {}
    return {"steps": int(d["steps"].max()), "stepped": int(bool((d["step_phase"] != 0).any()))}


def sweep_point(spec: dict) -> dict[str, Any]:
    """One point of run_sweep (anklehip.running.points runs it on the workers)."""
    return _one(spec["scenario"], spec["fmu_dir"], spec["peak_force"], Variant.from_dict(spec["variant"]), spec["engine"])


def force_sweep_specs(scenario_path, forces, variants: list[Variant], fmu_dir: str | None, engine: str) -> list[dict]:
    """The points of a force sweep: every variant at every peak force."""
    return [{"id": f"{v.name}@{float(f)!r}#{v.digest()}", "scenario": str(scenario_path), "fmu_dir": fmu_dir,
             "peak_force": float(f), "engine": engine, "variant": v.as_dict()} for v in variants for f in forces]


def run_sweep(scenario_path: str, forces: list[float], variants: list[Variant], fmu_dir: str | None = None,
              workers: int = 2, engine: str = "fmpy", *, scheduler: str | None = None,
              journal: Path | None = None, key: str = "", restart: bool = False, worker_timeout: float | None = None):
    """Every variant at every peak force, on Dask (anklehip.running.points: a local cluster, or the
    scheduler at `scheduler` / $DASK_SCHEDULER_ADDRESS); finished points go to `journal` and a
    rerun with the same `key` skips them. Returns an anklehip.running.points.Outcome."""
    from .points import run_points
    specs = force_sweep_specs(scenario_path, forces, variants, fmu_dir, engine)
    return run_points(sweep_point, specs, workers=workers, scheduler=scheduler, journal=journal, key=key,
                      **({} if worker_timeout is None else {"worker_timeout": worker_timeout}),
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


def sweep_key(scenario_path: Path, *models) -> str:
    """What the rows of a sweep depend on besides the point itself: the scenario file and the FMUs
    (of every variant's models)."""
    import hashlib
    h = hashlib.sha256()
    paths = [scenario_path] + [p for m in models for p in (m.controller.path, m.plant.path)]
    for p in dict.fromkeys(str(p) for p in paths):
        h.update(Path(p).read_bytes())
    return h.hexdigest()[:16]


def variant_models(models, sc, variants: list[Variant], fmu_dir) -> list:
    """The FMUs each variant runs, in the variants' order (`models`, the scenario's, for those that
    keep its controller model)."""
    from .master import Models
    out = []
    for v in variants:
        cm = v.controller_model or sc.controller_model
        out.append(models if cm == sc.controller_model else
                   Models.load(fmu_dir, plant_model=sc.plant_model, controller_model=cm))
    return out


def plot_sweep(rows: list[dict[str, Any]], path: Path, title: str = "") -> Path:
    """sweep_figure as a PNG."""
    import matplotlib.pyplot as plt
    fig = sweep_figure(rows, title)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def sweep_figure(rows: list[dict[str, Any]], title: str = ""):
    """Outcome over peak push force, a row per variant: o stood (green: the ankle strategy alone,
    blue: the hip strategy too, the highest phase reached written above; purple: a step, with the 3D
    controller's stepping layer), x fell; a legend says so."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from ..analysis.capability import STRATEGY_COLOURS, strategy_of
    variants = list(dict.fromkeys(r["variant"] for r in rows))
    fig, ax = plt.subplots(figsize=(8, 2.0 + 0.7 * len(variants)), layout="constrained")
    for i, v in enumerate(variants):
        rr = [r for r in rows if r["variant"] == v]
        for r in rr:
            fell = r["outcome"] == "fell"
            ax.scatter(r["peak_force"], i, marker="x" if fell else "o", s=60,
                       c="tab:red" if fell else STRATEGY_COLOURS[strategy_of(r)])
            if not fell:
                ax.annotate(str(r["max_phase"]), (r["peak_force"], i), textcoords="offset points",
                            xytext=(0, 7), ha="center", fontsize=7)
    ax.set_yticks(range(len(variants)), variants)
    ax.set_ylim(-0.7, len(variants) - 0.3)
    ax.set_xlabel("peak push force [N]")
    ax.set_title(title or "outcome vs peak push force", fontsize=9)
    ax.grid(alpha=0.3)
    handles = [Line2D([], [], ls="", marker="o", color="tab:green", label="stood, ankle strategy only (phase 0)"),
               Line2D([], [], ls="", marker="o", color="tab:blue", label="stood, hip strategy (n: highest phase)"),
               Line2D([], [], ls="", marker="x", color="tab:red", label="fell")]
    if any(r.get("stepped", 0) for r in rows):
        handles.insert(2, Line2D([], [], ls="", marker="o", color=STRATEGY_COLOURS["step"], label="stood, a step"))
    fig.legend(handles=handles, loc="outside lower center", ncol=len(handles), fontsize=8, frameon=False)
    return fig


# ----------------------------------------------------------------------------------------------
# the API: anklehip.sweep(...)

@dataclass
class SweepResult:
    """The result of anklehip.sweep: one row per point (variant x push), the files written.

    ``points`` is the table as a NumPy structured array (text columns as str, numbers as float or
    int; a point that raised has outcome "error" and its message in ``error``), ``rows`` the same
    as dicts."""
    name: str
    rows: list[dict[str, Any]]
    total: int                          # points asked for
    resumed: int = 0                    # points taken over from an earlier run's journal (out)
    interrupted: bool = False
    wall: float = 0.0
    files: dict[str, Path] = field(default_factory=dict)
    sweep_file: Any = None              # the SweepFile of a sweep file, None for a force sweep
    scenario: Any = None                # the base Scenario
    plant_parameters: dict[str, Any] = field(default_factory=dict, repr=False)   # for the bounds

    @property
    def complete(self) -> bool:
        return not self.interrupted and len(self.rows) == self.total

    @property
    def errors(self) -> list[dict[str, Any]]:
        return [r for r in self.rows if r.get("outcome") == "error"]

    @property
    def points(self) -> np.ndarray:
        return rows_to_array(self.rows)

    def variants(self) -> list[str]:
        return list(dict.fromkeys(r["variant"] for r in self.rows if "variant" in r))

    def largest_survived(self, variant: str) -> float | None:
        """The largest |peak push force| [N] the variant survived (a force sweep), None if none."""
        ok = [r["peak_force"] for r in self.rows if r.get("variant") == variant
              and r.get("outcome") not in ("fell", "error")]
        return max(ok, key=abs) if ok else None


def rows_to_array(rows: list[dict[str, Any]]) -> np.ndarray:
    """Dict rows (the union of their keys, in order of appearance) as a structured array: a column of
    bools -> bool, of ints -> int64, of numbers -> float64 (missing: NaN), otherwise str."""
    keys = list(dict.fromkeys(k for r in rows for k in r))
    cols, dtype = {}, []
    for k in keys:
        vals = [r.get(k) for r in rows]
        present = [v for v in vals if v is not None]
        if present and all(isinstance(v, bool) for v in present) and len(present) == len(vals):
            cols[k], dt = vals, np.bool_
        elif present and all(isinstance(v, int) and not isinstance(v, bool) for v in present) \
                and len(present) == len(vals):
            cols[k], dt = vals, np.int64
        elif all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
            cols[k], dt = [np.nan if v is None else float(v) for v in vals], np.float64
        else:
            cols[k] = ["" if v is None else str(v) for v in vals]
            dt = f"U{max([1] + [len(s) for s in cols[k]])}"
        dtype.append((k, dt))
    out = np.zeros(len(rows), dtype=dtype)
    for k in keys:
        out[k] = cols[k]
    return out


def _check_pushes(models, sc, peaks, where: str) -> None:
    """The largest pushes of the sweep inside the plant's declared push range (before anything runs)."""
    from .master import PUSH, check_push_range
    base = sc.push.peak()
    for f in (min(peaks), max(peaks)):
        check_push_range(models.plant, sc.push.scaled(f / base), PUSH, f"{where} {f:g} N")


def _force_sweep(scenario, forces, variants, fmu_dir, name):
    from ..files.paths import find_scenario
    from ..files.scenario import Scenario
    from .master import Models
    from .run import scenario_of
    from ..errors import InputError
    if isinstance(scenario, Scenario):
        if scenario.path is None:
            raise InputError("sweep: a scenario object needs its file (path); give a name or a path")
        path = Path(scenario.path)
    else:
        path = find_scenario(str(scenario))
    sc = scenario_of(path)
    forces = parse_grid(forces, name["forces"]) if isinstance(forces, str) else [float(f) for f in forces]
    if not forces or not all(np.isfinite(forces)):
        raise InputError(f"{name['forces']}: finite numbers, got {forces!r}")
    variants = [v if isinstance(v, Variant) else parse_variant(v) for v in (variants or ["default"])]
    models = Models.for_scenario(sc, fmu_dir)
    _check_variants(models, sc, variants, fmu_dir, name["variants"] + " ")
    if sc.push.peak() == 0:
        raise InputError(f"{path}: the scenario has no push to scale")
    _check_pushes(models, sc, forces, f"{name['forces']}: a peak push of")
    return path, sc, forces, variants, models


def _sweep_file(name_or_path, fmu_dir):
    from ..files.paths import find_sweep_file
    from ..files.scenario import faults_from, load_scenario
    from .master import PUSH, PUSH_Y, Models, check_overrides, check_push_range
    from .sweepfile import load_sweep_file, point_setup
    path = find_sweep_file(str(name_or_path))
    sf = load_sweep_file(path)
    sc = load_scenario(sf.scenario)
    models = Models.for_scenario(sc, fmu_dir)
    where = str(path)
    for k, vals in list(sf.axes.items()) + [(k, list(r)) for k, r in sf.ranges.items()]:
        group, _, name = k.partition(".")
        for x in (min(vals), max(vals)):    # names and ranges checked here, not in every worker
            if group in ("controller", "plant"):
                check_overrides(models, {name: x} if group == "controller" else {},
                                {name: x} if group == "plant" else {}, f"{where}: {k}")
            elif group == "faults":
                faults_from({name: x}, sc.faults, f"{where}: {k}")
            elif name == "height":
                check_overrides(models, {}, {"h_push": x}, f"{where}: {k}")
    # the strongest push of the sweep within the plant's push range
    forces = sf.axes.get("push.force") or list(sf.ranges.get("push.force", ())) or [sf.push["force"]]
    angled = "angle" in sf.push or "push.angle" in sf.axes or "push.angle" in sf.ranges
    for f in (min(forces), max(forces)):
        for d in ((0.0, 90.0, 180.0, 270.0) if angled else (1, -1)):
            pt = point_setup(sf, {"push.force": f, ("push.angle" if angled else "push.direction"): d}, sc)
            check_push_range(models.plant, pt.push, PUSH, f"{where}: push.force {f:g} N")
            check_push_range(models.plant, pt.push_y, PUSH_Y, f"{where}: push.force {f:g} N")
    _check_variants(models, sc, sf.variants, fmu_dir, f"{where}: variant ")
    return path, sf, sc, models


def _check_variants(models, sc, variants: list[Variant], fmu_dir, where: str) -> None:
    """Each variant's controller model, named configuration and overrides checked against the FMUs
    it runs: a bad variant is an error here, not a traceback in every worker."""
    import copy
    from .master import check_overrides
    for v in variants:
        v.apply(copy.copy(sc), f"{where}{v.name}")
    for v, m in zip(variants, variant_models(models, sc, variants, fmu_dir)):
        m.controller.configuration(v.config or sc.controller_config, f"{where}{v.name}")
        check_overrides(m, v.controller, v.plant, f"{where}{v.name}")


def sweep(scenario, *, forces=None, variants=None, workers: int = 2, engine: str | None = None,
          scheduler: str | None = None, out=None, restart: bool = False, figures: bool = True,
          fmu_dir=None, progress: bool = True, origins: dict[str, str] | None = None,
          worker_timeout: float | None = None) -> SweepResult:
    """Many closed-loop runs on Dask, one per point; `anklehip sweep` as a function.

    With `forces`, `scenario` is a scenario (name, path or Scenario with a file) whose push is
    scaled to each peak force [N] (a list, or "start:stop:step" / "a,b,c"), for each of
    `variants` (Variant objects or specs "NAME:config=C,controller.P=V,plant.Q=W"; default one,
    the scenario as it is). Without `forces`, `scenario` is a sweep file (a name in
    scenarios/sweeps/ or a path), which says what is swept (docs/scenarios.md, "Sweep files").

    workers    processes of a local Dask cluster (1: in this process), unless `scheduler`
               (an address, else $DASK_SCHEDULER_ADDRESS) names a running one
    worker_timeout  with a scheduler that has no worker: seconds to wait for one (default 120),
               then NoWorkersError
    engine     "native" (default when built) or "fmpy"
    out        a folder: the journal (a rerun resumes, `restart` discards it), the table as CSV and
               Parquet, and with `figures` the sweep's figures; None: nothing written
    progress   a bar on a terminal, else a line per tenth of the points, on stderr (False: none)

    Raises an InputError for a wrong input before anything runs; failed points are rows with
    outcome "error"; Ctrl-C returns the points done with interrupted=True. `origins` names the
    arguments as the caller calls them in messages (the CLI's {"variants": "--variant"}).
    """
    import time
    from ..files.output import check_output_folder, output_lock
    from ..errors import InputError
    from .native import default_engine
    from .points import run_points
    engine = engine or default_engine()
    name = {"variants": "variants", "forces": "forces", "out": "out", **(origins or {})}
    if forces is None:
        if variants:
            raise InputError(f"{name['variants']}: a sweep file names its own variants ([[variant]]); they go with "
                             f"{name['forces']}")
        path, sf, sc, models = _sweep_file(scenario, fmu_dir)
        from .sweepfile import sweepfile_point
        specs, fn, title = sf.specs(str(fmu_dir) if fmu_dir else None, engine), sweepfile_point, sf.name
        vm = variant_models(models, sc, sf.variants, fmu_dir)
        key = sweep_key(path, *vm) + sweep_key(sf.scenario, *vm)
        stem, journal_name, what = "points", "points.jsonl", f"sweep file {path.name}"
    else:
        path, sc, forces, variants, models = _force_sweep(scenario, forces, variants, fmu_dir, name)
        sf = None
        specs = force_sweep_specs(path, forces, variants, str(fmu_dir) if fmu_dir else None, engine)
        fn, title, key = sweep_point, sc.name, sweep_key(path, *variant_models(models, sc, variants, fmu_dir))
        stem, journal_name, what = "sweep", "sweep.points.jsonl", f"sweep of {path.name}"
    result = SweepResult(name=title, rows=[], total=len(specs), sweep_file=sf, scenario=sc,
                         plant_parameters=bounds_parameters_of(models, sc, sf.variants[0] if sf is not None else None))
    if out is None:
        t0 = time.perf_counter()
        o = run_points(fn, specs, workers=workers, scheduler=scheduler, journal=None, key=key, what=what,
                       **({} if worker_timeout is None else {"worker_timeout": worker_timeout}),
                       label=f"sweep {title}", progress=progress)
        result.rows, result.interrupted, result.wall = o.rows, o.interrupted, time.perf_counter() - t0
        return result
    out = check_output_folder(out, name["out"])
    with output_lock(out):
        o = run_points(fn, specs, workers=workers, scheduler=scheduler, journal=out / journal_name, key=key,
                       **({} if worker_timeout is None else {"worker_timeout": worker_timeout}),
                       what=what, label=f"sweep {title}", restart=restart, progress=progress)
        result.rows, result.resumed, result.interrupted, result.wall = o.rows, o.resumed, o.interrupted, o.wall
        result.files["journal"] = out / journal_name
        if not o.rows:
            return result
        csv_path, pq_path = write_points_table(o.rows, out, stem, complete=o.complete)
        result.files.update(table=csv_path, parquet=pq_path)
        if figures and sf is None:
            ok = [r for r in o.rows if r.get("outcome") != "error"]
            if ok:
                result.files["figure"] = plot_sweep(ok, out / "sweep.png", title=f"{sc.name}: outcome vs peak push force")
        elif figures and o.complete:
            from ..analysis.capability import plot_capability, plot_points
            for i, f in enumerate(plot_points(sf, o.rows, out)):
                result.files[f"figure{i + 1}"] = f
            cap = plot_capability(sf, o.rows, out, result.plant_parameters)
            if cap:
                result.files["capability"] = cap
    return result


def bounds_parameters_of(models, sc, v: Variant | None = None) -> dict:
    """The numbers a sweep's bounds use (anklehip.analysis.bounds.bounds_parameters) for the scenario
    `sc` run by `models` with the variant `v` (a sweep: its first): the plant FMU's parameters and
    constants with the scenario's and the variant's plant overrides, completed by the generated
    robot header the plant FMU carries; and the posture in which the robot stands when the push
    comes, the controller's erect posture (theta_ankle_erect, theta_hip_erect: docs/controller.md
    section 2.1)."""
    import dataclasses

    from ..analysis.bounds import bounds_parameters, plant_header
    from ..errors import InputError
    from .master import ERECT, _erect, scenario_parameters
    over = {**sc.plant, **(v.plant if v else {})}
    out = bounds_parameters({**models.plant.start_values(), **over}, plant_header(models.plant.unzipdir))
    try:
        sc0 = dataclasses.replace(sc, controller_config=v.config) if v is not None and v.config else sc
        c_over, _ = scenario_parameters(sc0, models, v.controller if v else None, v.plant if v else None)
        out.update(zip(ERECT, _erect(models, c_over)))
    except InputError:   # no erect posture to read (e.g. a robot file's scenario): the joints' zero
        pass
    return out
