"""Sweep files (`scenarios/sweeps/<name>.toml`): a base scenario, the push that is swept, the
controller variants compared, and a full grid or seeded random samples over the push's magnitude,
duration, rise time, height, onset and direction (+-1 along x, or an angle in the horizontal plane on
the 3D plant), controller and plant parameters and fault
options. Each point is one closed-loop run of the base scenario with that push and those values
(docs/scenarios.md, "Sweep files"). Errors name the file, the key and the value.

    description = "..."
    scenario = "hip_saves_push"           # the base scenario (a name in scenarios/, or a path)
    stop_time = 8.0                       # optional: instead of the scenario's
    [push]                                # the swept push; it replaces the scenario's pushes
    t = 2.0                               # onset [s]
    force = 8.0                           # peak [N] (> 0; the direction gives the sign)
    duration = 0.5                        # [s], rise included
    rise = 0.05                           # [s]
    direction = 1                         # +1 on the back (forward), -1 on the chest
    # angle = 90                          # or: the horizontal direction [deg], 0 forward (on the back),
                                          # 90 toward +y (the left), 180 on the chest; 3D plant only
    [[variant]]                           # compared configurations (default: one, the scenario's)
    name = "ankle_only"
    controller = { hip_strategy_enabled = 0 }
    config = "paper"                      # optional: a named controller configuration
    controller_model = "3d"               # optional: the controller FMU (default: the scenario's)
    [grid]                                # every combination ...
    "push.force" = "2:20:1"               # start:stop:step, a,b,c or a list of numbers
    "push.duration" = [0.1, 0.5, 1.0]
    [random]                              # ... or n seeded uniform samples
    n = 200
    seed = 1
    "push.force" = [2.0, 20.0]

Swept keys: push.force, push.duration, push.rise, push.t, push.direction, push.angle (the push's
direction [deg]: the peak force splits into the scenario's push, x, and push_y, y; not with
push.direction; off the x axis only on the 3D plant), push.height (the push point's height above
the sole, the plant's h_push); controller.<parameter>, plant.<parameter> (checked against the
FMUs); faults.<key> (docs/scenarios.md, "Fault injection").
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ..files.text import read_toml
from ..files.scenario import PushProfile, PushSegment, ScenarioError, _V
from .sweep import MAX_GRID, Variant, parse_grid, run_columns

TOP_KEYS = {"description", "scenario", "stop_time", "push", "variant", "grid", "random"}
PUSH_FIELDS = {"t": 2.0, "force": 8.0, "duration": 0.5, "rise": 0.05, "direction": 1.0}
PUSH_OPTIONAL = {"angle"}           # [push] keys without a default: the push's direction in degrees
PUSH_SWEPT = {"force", "duration", "rise", "t", "direction", "angle", "height"}
RANDOM_KEYS = {"n", "seed"}


@dataclass
class SweepFile:
    name: str
    path: Path
    scenario: Path
    description: str = ""
    stop_time: float | None = None
    push: dict[str, float] = field(default_factory=lambda: dict(PUSH_FIELDS))
    variants: list[Variant] = field(default_factory=lambda: [Variant("default", {}, {})])
    axes: dict[str, list[float]] = field(default_factory=dict)          # grid: key -> values
    ranges: dict[str, tuple[float, float]] = field(default_factory=dict)  # random: key -> (lo, hi)
    n_random: int = 0
    seed: int = 1

    def values(self) -> list[dict[str, float]]:
        """The swept values of every point (without the variant), in a fixed order."""
        if self.axes:
            keys = list(self.axes)
            grids = np.meshgrid(*[self.axes[k] for k in keys], indexing="ij")
            return [{k: float(g.flat[i]) for k, g in zip(keys, grids)} for i in range(grids[0].size)]
        rng = np.random.default_rng(self.seed)
        keys = list(self.ranges)
        u = rng.random((self.n_random, len(keys)))
        return [{k: float(lo + (hi - lo) * u[i, j]) for j, (k, (lo, hi)) in enumerate(self.ranges.items())}
                for i in range(self.n_random)]

    def specs(self, fmu_dir: str | None, engine: str) -> list[dict[str, Any]]:
        out = []
        for v in self.variants:
            vh = v.digest()
            for vals in self.values():
                pid = v.name + "|" + ",".join(f"{k}={x!r}" for k, x in vals.items()) + f"#{vh}"
                out.append({"id": pid, "sweep": str(self.path), "fmu_dir": fmu_dir, "engine": engine,
                            "variant": v.as_dict(), "values": vals})
        return out


def load_sweep_file(path: str | Path) -> SweepFile:
    path = Path(path)
    from ..files.paths import repo_root
    try:
        where = str(path.resolve().relative_to(repo_root()))
    except ValueError:
        where = str(path)
    data = read_toml(path, where, ScenarioError)
    v = _V(where)
    v.keys(data, TOP_KEYS, "", {"scenario"})
    from ..files.paths import find_scenario
    sc_name = v.str_(data["scenario"], "scenario")
    try:
        scenario = find_scenario(sc_name) if "/" not in sc_name else (path.parent / sc_name).resolve()
    except FileNotFoundError as e:
        v.fail("scenario", str(e))
    if not scenario.is_file():
        v.fail("scenario", f"{sc_name!r}: no such scenario file")
    sf = SweepFile(name=path.stem, path=path, scenario=scenario)
    if "description" in data:
        sf.description = v.str_(data["description"], "description")
    if "stop_time" in data:
        sf.stop_time = v.num(data["stop_time"], "stop_time", gt=0.0)
    if "push" in data:
        p = v.table(data["push"], "push")
        v.keys(p, set(PUSH_FIELDS) | PUSH_OPTIONAL, "push.")
        for k, x in p.items():
            sf.push[k] = v.num(x, f"push.{k}", **({"gt": 0.0} if k in ("force", "duration") else {"ge": 0.0}
                                                  if k in ("t", "rise") else {}))
    if "variant" in data:
        sf.variants = []
        for i, it in enumerate(v.list_(data["variant"], "variant")):
            it = v.table(it, f"variant[{i}]")
            v.keys(it, {"name", "controller", "plant", "config", "controller_model"}, f"variant[{i}].", {"name"})
            name = v.str_(it["name"], f"variant[{i}].name")
            if name in {x.name for x in sf.variants}:
                v.fail(f"variant[{i}].name", f"{name!r} is used twice")
            sf.variants.append(Variant(name, dict(v.table(it.get("controller", {}), f"variant[{i}].controller")),
                                       dict(v.table(it.get("plant", {}), f"variant[{i}].plant")),
                                       v.str_(it["config"], f"variant[{i}].config") if "config" in it else None,
                                       v.str_(it["controller_model"], f"variant[{i}].controller_model")
                                       if "controller_model" in it else None))
    if ("grid" in data) == ("random" in data):
        v.fail("grid", "give exactly one of [grid] (every combination) or [random] (seeded samples)")
    if "grid" in data:
        g = v.table(data["grid"], "grid")
        if not g:
            v.fail("grid", "names no key to sweep")
        n = 1
        for k, spec in g.items():
            _check_key(v, f"grid.{k}", k)
            if isinstance(spec, str):
                try:
                    vals = parse_grid(spec, f"{where}: grid.{k}")
                except ValueError as e:
                    raise ScenarioError(str(e)) from None
            else:
                vals = [v.num(x, f"grid.{k}") for x in v.list_(spec, f"grid.{k}")]
            if not vals:
                v.fail(f"grid.{k}", "no values")
            sf.axes[k] = vals
            n *= len(vals)
        if n * len(sf.variants) > MAX_GRID:
            v.fail("grid", f"{n * len(sf.variants)} points (variants included), more than {MAX_GRID}")
    else:
        r = v.table(data["random"], "random")
        if "n" not in r:
            v.fail("random.n", "required key missing (the number of samples)")
        sf.n_random = v.int_(r["n"], "random.n", ge=1)
        sf.seed = v.int_(r["seed"], "random.seed", ge=0) if "seed" in r else 1
        for k, spec in r.items():
            if k in RANDOM_KEYS:
                continue
            _check_key(v, f"random.{k}", k)
            lst = v.list_(spec, f"random.{k}")
            if len(lst) != 2:
                v.fail(f"random.{k}", f"must be [low, high], got {spec!r}")
            lo, hi = (v.num(x, f"random.{k}") for x in lst)
            if not lo < hi:
                v.fail(f"random.{k}", f"needs low < high, got {spec!r}")
            sf.ranges[k] = (lo, hi)
        if not sf.ranges:
            v.fail("random", "names no key to sweep")
        if sf.n_random * len(sf.variants) > MAX_GRID:
            v.fail("random.n", f"{sf.n_random * len(sf.variants)} points (variants included), more than {MAX_GRID}")
    _check_angle(v, sf, set(data.get("push", {})))
    return sf


def _on_x_axis(angle: float) -> bool:
    return math.remainder(angle, 180.0) == 0.0


def _check_angle(v: _V, sf: SweepFile, push_keys: set[str]) -> None:
    """push.angle (fixed or swept) excludes push.direction, and a push off the x axis needs the 3D
    plant: the base scenario's plant_model is read to tell."""
    where = [("push.angle", [sf.push["angle"]])] if "angle" in sf.push else []
    where += [(f"grid.{k}", vals) for k, vals in sf.axes.items() if k == "push.angle"]
    where += [(f"random.{k}", list(r)) for k, r in sf.ranges.items() if k == "push.angle"]
    if not where:
        return
    direction = ["push.direction"] if "direction" in push_keys else []
    direction += [f"{g}.push.direction" for g, d in (("grid", sf.axes), ("random", sf.ranges)) if "push.direction" in d]
    if direction:
        v.fail(direction[0], f"give the push's direction once: {where[0][0]} or push.direction (+-1 along x), not both")
    from ..files.scenario import load_scenario
    sc = load_scenario(sf.scenario)
    if sc.plant_model != "sagittal":
        return
    for key, vals in where:
        off = [x for x in vals if not _on_x_axis(x)] if not key.startswith("random.") else vals
        if off:
            v.fail(key, f"{off[0]:g} deg: a push off the x axis (other than 0 or 180 deg) needs the 3D plant, and the "
                        f"base scenario {sf.scenario.name} runs the sagittal plant (plant_model = \"3d\" in a scenario)")


def _check_key(v: _V, where: str, key: str) -> None:
    group, _, name = key.partition(".")
    if group == "push" and name in PUSH_SWEPT:
        return
    if group in ("controller", "plant", "faults") and name:
        return
    v.fail(where, "unknown key to sweep (push.force|duration|rise|t|direction|height, controller.P, "
                  "plant.P, faults.KEY)")


class Point(NamedTuple):
    """One point's push and overrides: the push along x (the scenario's push) and y (its push_y), the
    push along its own direction (its peak the signed force along x for push.direction, the force's
    magnitude for push.angle), and the controller, plant and fault overrides."""
    push: PushProfile
    push_y: PushProfile
    along: PushProfile
    controller: dict
    plant: dict
    faults: dict


def _pulse(sf_push: dict, force: float) -> PushProfile:
    if force == 0.0:
        return PushProfile.zero()
    return PushProfile.from_segments([PushSegment("pulse", t=sf_push["t"], force=force, duration=sf_push["duration"],
                                                  rise=sf_push["rise"])])


def point_setup(sf: SweepFile, vals: dict[str, float], scenario=None) -> Point:
    """The pushes and the controller / plant / fault overrides of one point. With push.angle the peak
    force F splits into F cos(angle) along x and F sin(angle) along y (exact on the axes:
    anklehip.analysis.bounds.push_direction)."""
    from ..analysis.bounds import push_direction
    push = dict(sf.push)
    c, p, f = {}, {}, {}
    for k, x in vals.items():
        group, _, name = k.partition(".")
        if group == "push":
            if name == "height":
                p["h_push"] = x
            else:
                push[name] = x
        elif group == "controller":
            c[name] = x
        elif group == "plant":
            p[name] = x
        else:
            f[name] = x
    if "angle" in push:
        cx, sy = (float(x) for x in push_direction(push["angle"]))
        fx, fy = push["force"] * cx, push["force"] * sy
        along = _pulse(push, push["force"])
    else:
        fx, fy = push["force"] * (1.0 if push["direction"] >= 0 else -1.0), 0.0
        along = _pulse(push, fx)
    return Point(_pulse(push, fx), _pulse(push, fy), along, c, p, f)


def sweepfile_point(spec: dict) -> dict[str, Any]:
    """One point of a sweep file (anklehip.running.points runs it on the workers): the row of the table."""
    from .master import simulate
    from ..analysis.summary import summarize_pushes
    from ..files.scenario import faults_from, load_scenario
    from .sweep import cached_models
    sf = load_sweep_file(spec["sweep"])
    sc = load_scenario(sf.scenario)
    vals = spec["values"]
    var = spec["variant"]
    Variant.from_dict(var).apply(sc)
    pt = point_setup(sf, vals, sc)
    c, p, f = pt.controller, pt.plant, pt.faults
    sc.push_y = pt.push_y        # the swept push replaces the scenario's pushes, sideways ones too
    faults = faults_from(f, sc.faults, f"{sf.path}: faults") if f else sc.faults
    engine = spec["engine"] if not (faults.sensor_active or faults.transition_push) else "fmpy"
    stop = sf.stop_time or sc.stop_time
    res = simulate(sc, cached_models(spec["fmu_dir"], sc.plant_model, sc.controller_model), controller_overrides={**var["controller"], **c},
                   plant_overrides={**var["plant"], **p}, push=pt.push, faults=faults, stop_time=stop,
                   progress=False, engine=engine, check_load=False)
    d = res.data
    ps = summarize_pushes(res, pt.along, sc.expect.erect_tol)
    s = ps[0] if ps else None
    row: dict[str, Any] = {"variant": var["name"], **vals, **run_columns(res),
                           "peak_force": pt.along.peak(), "impulse": s.impulse if s else math.nan,
                           "peak_zmp": s.peak_zmp if s else math.nan,
                           **({"peak_zmp_y": float(d["zmp_y"][np.argmax(np.abs(d["zmp_y"]))])}
                              if "zmp_y" in d.dtype.names and len(d) else {}),
                           "phases": "".join(str(x) for x in s.phases) if s else "",
                           "time_to_recover": s.time_to_recover if s and s.time_to_recover is not None else math.nan,
                           "peak_hip": s.peak_hip if s else math.nan, "peak_ankle": s.peak_ankle if s else math.nan,
                           "solver_steps": int(d["cvode_steps"][-1]) if "cvode_steps" in d.dtype.names else -1,
                           "rhs_evals": int(d["rhs_evals"][-1]) if "rhs_evals" in d.dtype.names else -1,
                           "engine": engine, "wall_time": res.wall_time}
    if res.outcome == "error":
        row["error"] = res.message
    return row
