"""Scenario files (TOML): schema, strict validation and the push profile.

The format is documented in docs/scenarios.md. Every error names the file, the key and the
problem, e.g. ``scenarios/x.toml: push[2].duration: must be > 0, got -1``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..running.faults import Faults, parse_faults
from .text import read_toml
from ..errors import InputError


class ScenarioError(InputError):
    """A scenario file is malformed; the message names file, key and problem."""


# The longest run a scenario, --stop-time or a step-test case may ask for, in communication steps:
# one simulated hour at the default 1 ms step. A result row takes ~0.55 kB in memory for the
# sagittal plant (~1.2 kB for the 3D plant: the master's arrays plus the structured result) and
# ~0.56 kB of CSV, written at ~45 us per row, so the bound means at most ~2 GB (3D: ~4 GB) of
# memory and a ~2 GB CSV written in ~3 minutes; beyond it numpy fails to allocate.
MAX_STEPS = 3_600_000


def time_grid_problem(stop_time: float, step: float, start: float = 0.0) -> str | None:
    """Why a run from `start` to `stop_time` in steps of `step` is not allowed, as a phrase that
    follows "stop time X" (None: it is allowed): the times must be finite, step > 0,
    stop_time > start, the span a whole number of steps (to 1e-6 of a step), 1 to MAX_STEPS of them."""
    if not math.isfinite(stop_time):
        return "is not finite"
    if not (math.isfinite(start) and math.isfinite(step) and step > 0):
        return f"cannot be reached from {start:g} s in steps of {step:g} s (need finite times and a step > 0)"
    if not stop_time > start:
        return f"must be > the start time {start:g} s"
    n = (stop_time - start) / step
    if n < 0.5:
        return f"is less than one step of {step:g} s after the start time {start:g} s"
    if n > MAX_STEPS + 0.5:
        return (f"is {n:.4g} steps of {step:g} s, more than the {MAX_STEPS} a run may have "
                f"(each step is a result row in memory and in the CSV)")
    if abs(n - round(n)) > 1e-6 * max(1.0, n):
        return f"is not a whole number of steps of {step:g} s" + (f" from {start:g} s" if start else "")
    return None


# ----------------------------------------------------------------------------------------------
# push profile

PUSH_KINDS = ("step", "ramp", "hold", "impulse", "pulse")


@dataclass(frozen=True)
class PushSegment:
    """One element of the push program (see docs/scenarios.md for the exact semantics).

    kind     step | ramp | hold | impulse | pulse
    t        absolute start time [s] (None: right after the previous segment)
    to       level after a step / at the end of a ramp [N]
    duration length [s] (ramp, hold, impulse, pulse)
    force    rectangular force on top of the level [N] (impulse/pulse)
    impulse  force x duration [N s] (impulse, alternative to force)
    rise     rise/fall time of a pulse [s] (trapezoid; 0 = rectangular)
    """
    kind: str
    t: float | None = None
    to: float | None = None
    duration: float = 0.0
    force: float | None = None
    impulse: float | None = None
    rise: float = 0.0


@dataclass(slots=True)
class PushProfile:
    """Piecewise-linear force f(t) [N] on the robot's back (+ = forward), built from segments.

    Stored as break points (times non-decreasing; a repeated time is a jump). Before the first
    break point and after the last one the force is constant (0 before, last level after).
    """
    times: np.ndarray
    values: np.ndarray
    segments: list[PushSegment] = field(default_factory=list)

    @classmethod
    def from_segments(cls, segments: list[PushSegment]) -> "PushProfile":
        ts: list[float] = [0.0]
        vs: list[float] = [0.0]
        level = 0.0
        now = 0.0
        for s in segments:
            start = now if s.t is None else s.t
            if start > now:        # the level holds between segments
                ts.append(start); vs.append(level)
            now = start
            if s.kind == "step":
                ts += [now, now]; vs += [level, s.to]
                level = s.to
            elif s.kind == "ramp":
                ts += [now, now + s.duration]; vs += [level, s.to]
                level = s.to
                now += s.duration
            elif s.kind == "hold":
                now += s.duration
                ts.append(now); vs.append(level)
            elif s.kind == "impulse":
                f = s.force if s.force is not None else s.impulse / s.duration
                ts += [now, now, now + s.duration, now + s.duration]
                vs += [level, level + f, level + f, level]
                now += s.duration
            elif s.kind == "pulse":
                f = s.force
                r = s.rise
                ts += [now, now + r, now + s.duration - r, now + s.duration]
                vs += [level, level + f, level + f, level]
                now += s.duration
            else:  # pragma: no cover - validated before
                raise ValueError(s.kind)
        return cls(np.asarray(ts, float), np.asarray(vs, float), list(segments))

    @classmethod
    def zero(cls) -> "PushProfile":
        return cls(np.array([0.0]), np.array([0.0]), [])

    def value(self, t) -> np.ndarray:
        """f(t); at a jump the value after the jump."""
        t = np.asarray(t, float)
        ts, vs = self.times, self.values
        i = np.searchsorted(ts, t, side="right") - 1
        i = np.clip(i, 0, len(ts) - 1)
        j = np.minimum(i + 1, len(ts) - 1)
        dt = ts[j] - ts[i]
        with np.errstate(invalid="ignore", divide="ignore"):
            a = np.where(dt > 0, (t - ts[i]) / np.where(dt > 0, dt, 1.0), 0.0)
        a = np.clip(a, 0.0, 1.0)
        out = vs[i] + a * (vs[j] - vs[i])
        return np.where(t < ts[0], vs[0], out)

    def integral(self, t) -> np.ndarray:
        """F(t) = integral of f from 0 to t [N s] (exact for the piecewise-linear profile)."""
        t = np.asarray(t, float)
        ts, vs = self.times, self.values
        seg = np.diff(ts) * 0.5 * (vs[:-1] + vs[1:])
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        i = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, len(ts) - 1)
        j = np.minimum(i + 1, len(ts) - 1)
        dt = ts[j] - ts[i]
        tau = np.clip(t - ts[i], 0.0, None)
        with np.errstate(invalid="ignore", divide="ignore"):
            slope = np.where(dt > 0, (vs[j] - vs[i]) / np.where(dt > 0, dt, 1.0), 0.0)
        # beyond the last break point the level is constant (slope 0)
        slope = np.where(i == len(ts) - 1, 0.0, slope)
        tau = np.where((i < len(ts) - 1), np.minimum(tau, np.where(dt > 0, dt, 0.0)), tau)
        return cum[i] + vs[i] * tau + 0.5 * slope * tau * tau

    def step_averages(self, t0: float, h: float, n: int) -> np.ndarray:
        """Force applied during each communication step [t_k, t_k + h): the mean of f over the
        step, so that every impulse is transferred exactly whatever its timing or duration."""
        edges = t0 + h * np.arange(n + 1)
        F = self.integral(edges)
        return np.diff(F) / h

    def events(self) -> list[tuple[float, float]]:
        """Intervals (start, end) during which the force differs from zero ("pushes")."""
        ts, vs = self.times, self.values
        out: list[tuple[float, float]] = []
        start = None
        for k in range(len(ts)):
            nz = vs[k] != 0.0
            if nz and start is None:
                start = ts[k - 1] if k > 0 else ts[k]
            elif not nz and start is not None:
                out.append((start, ts[k]))
                start = None
        if start is not None:
            out.append((start, math.inf))
        return out

    def peak(self) -> float:
        """Largest |f| (signed)."""
        i = int(np.argmax(np.abs(self.values)))
        return float(self.values[i])

    def scaled(self, factor: float) -> "PushProfile":
        """Every force times `factor`."""
        return PushProfile(self.times.copy(), self.values * factor, self.segments)

    def scaled_to(self, peak: float) -> "PushProfile":
        """The same shape with its peak() equal to `peak` [N] (a negative peak mirrors it)."""
        base = self.peak()
        if base == 0:
            raise ValueError("scaled_to: the profile has no force to scale (peak 0 N)")
        return self.scaled(peak / base)


# ----------------------------------------------------------------------------------------------
# expectations, reference

@dataclass(slots=True)
class Expect:
    must_fall: bool | None = None
    fall_after: float | None = None          # with must_fall: not before this time
    fall_before: float | None = None         # with must_fall: at the latest at this time
    phases_reached: list[int] = field(default_factory=list)
    phases_not_reached: list[int] = field(default_factory=list)
    min_cycles: int | None = None            # complete 0->1->2->3->0 cycles
    phases_y_reached: list[int] = field(default_factory=list)   # the 3D controller's frontal phases (phase_y)
    min_cycles_y: int | None = None          # complete frontal 0->1->2->3->0 cycles
    erect_by: float | None = None            # back in phase 0 and near erect from this time on
    erect_tol: float = 0.02                  # [rad] on |theta_ankle| and |theta_hip|
    max_abs_zmp: float | None = None         # [m]
    no_fault: bool = True
    max_abs: dict[str, float] = field(default_factory=dict)    # result column -> largest |value| allowed
    min_range: dict[str, float] = field(default_factory=dict)  # result column -> least max - min (e.g. a slide)


@dataclass(slots=True)
class Reference:
    file: Path
    columns: list[str] | None = None
    num: int | None = None   # validate_signal: samples of the band (None: max(1000, rows))
    dx: int = 20             # validate_signal: horizontal half width in samples
    dy: float = 0.1          # validate_signal: vertical width relative to the signal's range
    abs_tol: float | None = None
    rel_tol: float | None = None
    interval: float = 0.01   # sample interval of the stored reference [s]
    band_floor: float | None = None
    signals: dict[str, dict[str, float]] = field(default_factory=dict)   # per-signal overrides


@dataclass(slots=True)
class Scenario:
    """A scenario (docs/scenarios.md): how long, the pushes, the plant model, the controller
    configuration, parameter overrides ([controller], [plant]), faults, what is expected and the
    reference. load_scenario reads one from its file; change it in memory and pass it to
    anklehip.run (which copies it). Its fields are fixed: setting an unknown one is an error."""
    name: str
    path: Path | None
    description: str = ""
    stop_time: float = 10.0
    step: float = 1e-3
    push: PushProfile = field(default_factory=PushProfile.zero)
    push_y: PushProfile = field(default_factory=PushProfile.zero)   # sideways (+ left); 3D plant only
    plant_model: str = "sagittal"         # a key of paths.PLANT_FMUS
    controller_model: str = "sagittal"    # a key of paths.CONTROLLER_FMUS ("3d" needs plant_model "3d")
    controller_config: str = "default"    # a named configuration of the controller FMU
    controller: dict[str, Any] = field(default_factory=dict)
    plant: dict[str, Any] = field(default_factory=dict)
    expect: Expect = field(default_factory=Expect)
    reference: Reference | None = None
    tags: list[str] = field(default_factory=list)
    faults: Faults = field(default_factory=Faults)   # [faults]: anklehip.running.faults
    robot: str | None = None              # the robot file the scenario is written for (anklehip.robot)
    push_units: str = "SI"                # "robot": pushes and times in the robot's units (docs/your-robot.md)
    robot_run: Any = None                 # anklehip.robot.experiment.RobotRun once the robot is applied

    @property
    def n_steps(self) -> int:
        return int(round(self.stop_time / self.step))


# ----------------------------------------------------------------------------------------------
# validation helpers

class _V:
    def __init__(self, where: str):
        self.where = where

    def fail(self, key: str, msg: str):
        raise ScenarioError(f"{self.where}: {key}: {msg}")

    def table(self, d: Any, key: str) -> dict:
        if not isinstance(d, dict):
            self.fail(key, f"must be a table, got {_tname(d)}")
        return d

    def keys(self, d: dict, allowed: set[str], prefix: str, required: set[str] = frozenset()):
        for k in d:
            if k not in allowed:
                self.fail(f"{prefix}{k}", f"unknown key (allowed: {', '.join(sorted(allowed))})")
        for k in required:
            if k not in d:
                self.fail(f"{prefix}{k}", "required key missing")

    def num(self, v: Any, key: str, *, gt=None, ge=None, le=None) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.fail(key, f"must be a number, got {_tname(v)} {v!r}")
        v = float(v)
        if not math.isfinite(v):
            self.fail(key, f"must be finite, got {v}")
        if gt is not None and not v > gt:
            self.fail(key, f"must be > {gt:g}, got {v:g}")
        if ge is not None and not v >= ge:
            self.fail(key, f"must be >= {ge:g}, got {v:g}")
        if le is not None and not v <= le:
            self.fail(key, f"must be <= {le:g}, got {v:g}")
        return v

    def int_(self, v: Any, key: str, *, ge=None) -> int:
        if isinstance(v, bool) or not isinstance(v, int):
            self.fail(key, f"must be an integer, got {_tname(v)} {v!r}")
        if ge is not None and v < ge:
            self.fail(key, f"must be >= {ge}, got {v}")
        return v

    def bool_(self, v: Any, key: str) -> bool:
        if not isinstance(v, bool):
            self.fail(key, f"must be true or false, got {_tname(v)} {v!r}")
        return v

    def str_(self, v: Any, key: str) -> str:
        if not isinstance(v, str):
            self.fail(key, f"must be a string, got {_tname(v)} {v!r}")
        return v

    def list_(self, v: Any, key: str) -> list:
        if not isinstance(v, list):
            self.fail(key, f"must be an array, got {_tname(v)} {v!r}")
        return v


def _tname(v: Any) -> str:
    return {bool: "boolean", int: "integer", float: "float", str: "string", list: "array",
            dict: "table"}.get(type(v), type(v).__name__)


TOP_KEYS = {"name", "description", "stop_time", "step", "push", "push_y", "plant_model", "controller_model",
            "controller_config",
            "controller", "plant", "faults", "robot", "push_units",
            "expect", "reference", "tags"}
PUSH_UNITS = ("SI", "robot")
PUSH_KEYS = {
    "step": ({"kind", "t", "to"}, {"to"}),
    "ramp": ({"kind", "t", "to", "duration"}, {"to", "duration"}),
    "hold": ({"kind", "t", "duration"}, {"duration"}),
    "impulse": ({"kind", "t", "duration", "force", "impulse"}, {"duration"}),
    "pulse": ({"kind", "t", "duration", "force", "rise"}, {"duration", "force"}),
}
EXPECT_KEYS = {"must_fall", "fall_after", "fall_before", "phases_reached", "phases_not_reached",
               "min_cycles", "phases_y_reached", "min_cycles_y", "erect_by", "erect_tol", "max_abs_zmp", "no_fault", "max_abs", "min_range"}
REF_KEYS = {"file", "columns", "num", "dx", "dy", "abs_tol", "rel_tol", "interval", "band_floor", "signals"}
REF_SIGNAL_KEYS = {"dy", "abs_tol", "rel_tol", "band_floor"}


def _parse_push(v: _V, items: Any, stop_time: float, key: str = "push") -> PushProfile:
    items = v.list_(items, key)
    segs: list[PushSegment] = []
    now = 0.0
    for i, it in enumerate(items):
        p = f"{key}[{i}]"
        it = v.table(it, p)
        if "kind" not in it:
            v.fail(f"{p}.kind", f"required key missing (one of {', '.join(PUSH_KINDS)})")
        kind = v.str_(it["kind"], f"{p}.kind")
        if kind not in PUSH_KEYS:
            v.fail(f"{p}.kind", f"must be one of {', '.join(PUSH_KINDS)}, got {kind!r}")
        allowed, required = PUSH_KEYS[kind]
        v.keys(it, allowed, f"{p}.", required)
        t = None
        if "t" in it:
            t = v.num(it["t"], f"{p}.t", ge=0.0)
            if t < now - 1e-12:
                v.fail(f"{p}.t", f"starts at {t:g} s, before the previous segment ends at {now:g} s")
            if t > stop_time:
                v.fail(f"{p}.t", f"starts at {t:g} s, after stop_time {stop_time:g} s")
        start = now if t is None else t
        kw: dict[str, Any] = {"kind": kind, "t": t}
        if "to" in it:
            kw["to"] = v.num(it["to"], f"{p}.to")
        if "duration" in it:
            kw["duration"] = v.num(it["duration"], f"{p}.duration", gt=0.0) if kind != "hold" else \
                v.num(it["duration"], f"{p}.duration", ge=0.0)
        if kind == "impulse":
            if ("force" in it) == ("impulse" in it):
                v.fail(f"{p}", "an impulse needs exactly one of 'force' [N] or 'impulse' [N s]")
            if "force" in it:
                kw["force"] = v.num(it["force"], f"{p}.force")
            else:
                kw["impulse"] = v.num(it["impulse"], f"{p}.impulse")
        if kind == "pulse":
            kw["force"] = v.num(it["force"], f"{p}.force")
            kw["rise"] = v.num(it.get("rise", 0.0), f"{p}.rise", ge=0.0)
            if 2 * kw["rise"] > kw["duration"]:
                v.fail(f"{p}.rise", f"2 x rise ({2 * kw['rise']:g} s) exceeds duration {kw['duration']:g} s")
        seg = PushSegment(**kw)
        now = start + seg.duration
        segs.append(seg)
    profile = PushProfile.from_segments(segs)
    if not np.all(np.isfinite(profile.values)):
        v.fail(key, "the forces add up to more than a float can hold")
    return profile


def _parse_overrides(v: _V, d: Any, key: str) -> dict[str, Any]:
    d = v.table(d, key)
    out = {}
    for k, val in d.items():
        if isinstance(val, bool):
            out[k] = val
        elif isinstance(val, (int, float)):
            out[k] = v.num(val, f"{key}.{k}") if isinstance(val, float) else val
        else:
            v.fail(f"{key}.{k}", f"parameter value must be a number or boolean, got {_tname(val)} {val!r}")
    return out


def _parse_expect(v: _V, d: Any, stop_time: float) -> Expect:
    d = v.table(d, "expect")
    v.keys(d, EXPECT_KEYS, "expect.")
    e = Expect()
    if "must_fall" in d:
        e.must_fall = v.bool_(d["must_fall"], "expect.must_fall")
    for k in ("fall_after", "fall_before"):
        if k in d:
            if not e.must_fall:
                v.fail(f"expect.{k}", "only meaningful with must_fall = true")
            setattr(e, k, v.num(d[k], f"expect.{k}", ge=0.0, le=stop_time))
    for k in ("phases_reached", "phases_not_reached", "phases_y_reached"):
        if k in d:
            lst = v.list_(d[k], f"expect.{k}")
            vals = []
            for i, x in enumerate(lst):
                x = v.int_(x, f"expect.{k}[{i}]", ge=0)
                if x > 3:
                    v.fail(f"expect.{k}[{i}]", f"phases are 0..3, got {x}")
                vals.append(x)
            setattr(e, k, vals)
    both = set(e.phases_reached) & set(e.phases_not_reached)
    if both:
        v.fail("expect.phases_not_reached", f"phase(s) {sorted(both)} also listed in phases_reached")
    if "min_cycles" in d:
        e.min_cycles = v.int_(d["min_cycles"], "expect.min_cycles", ge=0)
    if "min_cycles_y" in d:
        e.min_cycles_y = v.int_(d["min_cycles_y"], "expect.min_cycles_y", ge=0)
    if "erect_by" in d:
        e.erect_by = v.num(d["erect_by"], "expect.erect_by", ge=0.0, le=stop_time)
        if e.must_fall:
            v.fail("expect.erect_by", "contradicts must_fall = true")
    if "erect_tol" in d:
        e.erect_tol = v.num(d["erect_tol"], "expect.erect_tol", gt=0.0)
    if "max_abs_zmp" in d:
        e.max_abs_zmp = v.num(d["max_abs_zmp"], "expect.max_abs_zmp", gt=0.0)
    for k in ("max_abs", "min_range"):   # tables: result column = value (the column is checked in the run)
        if k in d:
            tab = v.table(d[k], f"expect.{k}")
            setattr(e, k, {str(c): v.num(x, f"expect.{k}.{c}", gt=0.0) for c, x in tab.items()})
    if "no_fault" in d:
        e.no_fault = v.bool_(d["no_fault"], "expect.no_fault")
    return e


def _parse_reference(v: _V, d: Any, base: Path) -> Reference:
    d = v.table(d, "reference")
    v.keys(d, REF_KEYS, "reference.", {"file"})
    f = Path(v.str_(d["file"], "reference.file"))
    r = Reference(file=f if f.is_absolute() else base / f)
    if "columns" in d:
        cols = v.list_(d["columns"], "reference.columns")
        r.columns = [v.str_(c, f"reference.columns[{i}]") for i, c in enumerate(cols)]
        if not r.columns:
            v.fail("reference.columns", "must not be empty")
    if "num" in d:
        r.num = v.int_(d["num"], "reference.num", ge=2)
    if "dx" in d:
        r.dx = v.int_(d["dx"], "reference.dx", ge=1)
    if "dy" in d:
        r.dy = v.num(d["dy"], "reference.dy", ge=0.0)
    for k in ("abs_tol", "rel_tol"):
        if k in d:
            setattr(r, k, v.num(d[k], f"reference.{k}", ge=0.0))
    if "interval" in d:
        r.interval = v.num(d["interval"], "reference.interval", gt=0.0)
    if "band_floor" in d:
        r.band_floor = v.num(d["band_floor"], "reference.band_floor", ge=0.0)
    if "signals" in d:
        sig = v.table(d["signals"], "reference.signals")
        for name, tab in sig.items():
            key = f"reference.signals.{name}"
            tab = v.table(tab, key)
            v.keys(tab, REF_SIGNAL_KEYS, key + ".")
            r.signals[name] = {k: v.num(x, f"{key}.{k}", ge=0.0) for k, x in tab.items()}
    return r


def parse_scenario(data: dict, where: str = "<scenario>", path: Path | None = None) -> Scenario:
    v = _V(where)
    v.keys(data, TOP_KEYS, "")
    name = v.str_(data["name"], "name") if "name" in data else (path.stem if path else "scenario")
    if not name or any(c in name for c in "/\\ "):
        v.fail("name", f"must be a non-empty file-name-safe string, got {name!r}")
    if path is not None and "name" in data and name != path.stem:
        v.fail("name", f"{name!r} differs from the file name {path.stem!r}")
    sc = Scenario(name=name, path=path)
    if "description" in data:
        sc.description = v.str_(data["description"], "description")
    if "stop_time" not in data:
        v.fail("stop_time", "required key missing")
    sc.stop_time = v.num(data["stop_time"], "stop_time", gt=0.0)
    if "push_units" in data:
        sc.push_units = v.str_(data["push_units"], "push_units")
        if sc.push_units not in PUSH_UNITS:
            v.fail("push_units", f"must be one of {', '.join(PUSH_UNITS)}, got {sc.push_units!r}")
    if "robot" in data:
        sc.robot = v.str_(data["robot"], "robot")
        if not sc.robot:
            v.fail("robot", "must name a robot file (a path, or a name in robots/), got an empty string")
        if path is not None and ("/" in sc.robot or sc.robot.endswith(".toml")) and not Path(sc.robot).is_absolute():
            sc.robot = str(path.parent / sc.robot)     # relative to the scenario file
    if "step" in data:
        sc.step = v.num(data["step"], "step", gt=0.0, le=None if sc.push_units == "robot" else sc.stop_time)
    # in robot units stop_time counts pendulum time constants: checked once converted to seconds
    problem = time_grid_problem(sc.stop_time, sc.step) if sc.push_units == "SI" else None
    if problem:
        v.fail("step" if "step" in data else "stop_time", f"stop_time {sc.stop_time:g} {problem}")
    if "push" in data:
        sc.push = _parse_push(v, data["push"], sc.stop_time)
    if "push_y" in data:
        sc.push_y = _parse_push(v, data["push_y"], sc.stop_time, "push_y")
    if "plant_model" in data:
        from .paths import PLANT_FMUS
        sc.plant_model = v.str_(data["plant_model"], "plant_model")
        if sc.plant_model not in PLANT_FMUS:
            v.fail("plant_model", f"unknown plant model {sc.plant_model!r} (known: {', '.join(PLANT_FMUS)})")
    if sc.push_y.peak() != 0 and sc.plant_model == "sagittal":
        v.fail("push_y", "a sideways push needs plant_model = \"3d\" (the sagittal plant has no y)")
    if "controller_model" in data:
        from .paths import CONTROLLER_FMUS
        sc.controller_model = v.str_(data["controller_model"], "controller_model")
        if sc.controller_model not in CONTROLLER_FMUS:
            v.fail("controller_model", f"unknown controller model {sc.controller_model!r} "
                                       f"(known: {', '.join(CONTROLLER_FMUS)})")
        if sc.controller_model == "3d" and sc.plant_model != "3d":
            v.fail("controller_model", "the 3D controller needs plant_model = \"3d\" (it reads the 3D plant's "
                                       "lateral ZMP and joint angles)")
    if "controller_config" in data:
        sc.controller_config = v.str_(data["controller_config"], "controller_config")
        if not sc.controller_config:
            v.fail("controller_config", "must name a configuration (e.g. \"paper\"), got an empty string")
    for k in ("controller", "plant"):
        if k in data:
            setattr(sc, k, _parse_overrides(v, data[k], k))
    if "faults" in data:
        sc.faults = parse_faults(v, data["faults"])
    if "expect" in data:
        sc.expect = _parse_expect(v, data["expect"], sc.stop_time)
    if "reference" in data:
        sc.reference = _parse_reference(v, data["reference"], path.parent if path else Path("."))
    if "tags" in data:
        sc.tags = [v.str_(x, f"tags[{i}]") for i, x in enumerate(v.list_(data["tags"], "tags"))]
    return sc


def load_scenario(path: str | Path) -> Scenario:
    """A scenario from its TOML file, or by name (a file of the scenarios folder: a checkout's
    scenarios/ or the package's); a ScenarioError naming the file, key and problem."""
    path = Path(path)
    if path.suffix != ".toml" and path.parent == Path(".") and not path.is_file():
        from .paths import find_scenario
        path = find_scenario(str(path))
    where = _display(path)
    return parse_scenario(read_toml(path, where, ScenarioError), where, path)


def _display(path: Path) -> str:
    try:
        return str(path.resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def fault_options(items: list[str], where: str = "--fault") -> dict[str, Any]:
    """``["zmp_noise=0.002", "drop_mode=repeat"]`` -> {"zmp_noise": 0.002, "drop_mode": "repeat"}
    (numbers where they are numbers; stuck_at a list)."""
    d: dict[str, Any] = {}
    for it in items:
        name, eq, val = it.partition("=")
        if not eq or not name.strip():
            raise ScenarioError(f"{where} {it}: expected NAME=VALUE (e.g. zmp_noise=0.002)")
        val = val.strip()
        if name.strip() == "stuck_at":
            value: Any = [_number(x, f"{where} {it}") for x in val.split(",") if x.strip()]
        else:
            value = _int_or_float(val)
            value = val if value is None else value
        d[name.strip()] = value
    return d


def parse_fault_options(items: list[str], base: Faults | None = None, where: str = "--fault") -> Faults:
    """``--fault zmp_noise=0.002 --fault drop_mode=repeat`` on top of `base` (a scenario's faults)."""
    return faults_from(fault_options(items, where), base, where)


def faults_from(d: dict[str, Any], base: Faults | None = None, where: str = "fault options") -> Faults:
    """Fault options (a dict like a [faults] table) on top of `base`; ScenarioError naming `where`
    and the key."""
    return parse_faults(_V(where), d, "faults", base)


def _int_or_float(text: str) -> int | float | None:
    """The number a command-line value spells (an int when it is one), None if it is none."""
    try:
        return int(text)
    except ValueError:
        try:
            return float(text)
        except ValueError:
            return None


def _number(x: str, where: str) -> float:
    try:
        return float(x)
    except ValueError:
        raise ScenarioError(f"{where}: {x!r} is not a number") from None


def parse_set(items: list[str]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``--set controller.Ka=30 plant.push_height=0.3`` -> (controller, plant) overrides."""
    ctrl: dict[str, Any] = {}
    plant: dict[str, Any] = {}
    for it in items:
        if "=" not in it or "." not in it.split("=", 1)[0]:
            raise ScenarioError(f"--set {it}: expected controller.NAME=VALUE or plant.NAME=VALUE")
        key, val = it.split("=", 1)
        fmu, name = key.split(".", 1)
        if fmu not in ("controller", "plant"):
            raise ScenarioError(f"--set {it}: the prefix must be 'controller' or 'plant', got {fmu!r}")
        low = val.strip().lower()
        if low in ("true", "false"):
            value: Any = low == "true"
        else:
            value = _int_or_float(val)
            if value is None:
                raise ScenarioError(f"--set {it}: value {val!r} is not a number or true/false")
        (ctrl if fmu == "controller" else plant)[name] = value
    return ctrl, plant
