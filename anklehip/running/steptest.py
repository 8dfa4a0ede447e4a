"""HIL-style step tests of the controller FMU alone (FMI cross-check file layout).

A case is a folder with

    <Model>_in.csv    time + the controller inputs (theta_ankle, theta_hip, zmp_x, fz)
    <Model>_ref.csv   time + the reference outputs
    <Model>_ref.opt   StartTime, StopTime, StepSize, RelTol (one "Name, value" per line)
    steptest.toml     optional (ours): [controller] parameter overrides, [compare] tolerances,
                      [source] where the case came from

Timing convention (the one FMPy's simulate_fmu and the cross-check tools use): the inputs are
set at the communication point t_k, then doStep(t_k, h); the outputs read after the step are
recorded at t_k + h; the first output row (t = StartTime) holds the outputs after initialization.
"""
from __future__ import annotations

import math
import os
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis.compare import CompareReport, compare, read_result_csv
from ..files.text import read_text, read_toml
from .fmu import FMUError, FMUInfo, Slave, vr_array
from .master import RunResult
from ..files.output import atomic_write_csv, atomic_write_text
from ..files.scenario import REF_SIGNAL_KEYS, _parse_overrides, _V, time_grid_problem
from ..errors import InputError

MODEL = "AnkleHipController"
DEFAULT_TOL = {"abs_tol": 1e-9, "rel_tol": 1e-6}     # our FMU against its own recording: tight


class StepTestError(InputError):
    pass


def case_files(case_dir: Path, model: str = MODEL) -> dict[str, Path]:
    case_dir = Path(case_dir)
    return {"in": case_dir / f"{model}_in.csv", "ref": case_dir / f"{model}_ref.csv",
            "opt": case_dir / f"{model}_ref.opt", "meta": case_dir / "steptest.toml"}


def read_opt(path: Path) -> dict[str, float]:
    if not path.is_file():
        raise StepTestError(f"{path}: no such file (the case needs StartTime/StopTime/StepSize/RelTol)")
    text = read_text(path, str(path), StepTestError)
    opts: dict[str, float] = {}
    for i, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        parts = [p.strip() for p in line.split(",")]
        if len(parts) != 2:
            raise StepTestError(f"{path}:{i}: expected 'Name, value', got {line!r}")
        try:
            opts[parts[0]] = float(parts[1])
        except ValueError:
            raise StepTestError(f"{path}:{i}: {parts[0]}: not a number: {parts[1]!r}") from None
        if not math.isfinite(opts[parts[0]]):
            raise StepTestError(f"{path}:{i}: {parts[0]}: must be finite, got {parts[1]!r}")
    for k in ("StartTime", "StopTime", "StepSize"):
        if k not in opts:
            raise StepTestError(f"{path}: {k} missing")
    if not opts["StepSize"] > 0:
        raise StepTestError(f"{path}: StepSize: must be > 0, got {opts['StepSize']:g}")
    problem = time_grid_problem(opts["StopTime"], opts["StepSize"], opts["StartTime"])
    if problem:
        raise StepTestError(f"{path}: StopTime {opts['StopTime']:g} {problem}")
    opts.setdefault("RelTol", 1e-6)
    return opts


def write_opt(path: Path, start: float, stop: float, step: float, reltol: float = 1e-6) -> None:
    atomic_write_text(path, f"StartTime, {float(start)!r}\nStopTime, {float(stop)!r}\nStepSize, {float(step)!r}\n"
                            f"RelTol, {float(reltol)!r}\n")


# ----------------------------------------------------------------------------------------------
# recording from a closed-loop run

def record_case(res: RunResult, out_dir: Path, controller_overrides: dict[str, Any] | None = None,
                source: str = "", model: str = MODEL, stop_time: float | None = None) -> dict[str, Path]:
    """Write the controller's inputs and outputs of a closed-loop run as a step-test case."""
    d = res.data
    n_steps = len(d) - 1            # the controller stepped at rows 0 .. n-1
    if stop_time is not None:
        n_steps = min(n_steps, int(round(stop_time / res.step)))
    if n_steps < 1:
        raise StepTestError("the run has no controller steps to record")
    h = res.step
    t_in = h * np.arange(n_steps)
    inp = np.zeros(n_steps, dtype=[("time", float)] + [(c, float) for c in res.controller_inputs])
    inp["time"] = t_in
    for c in res.controller_inputs:
        inp[c] = d[c][:n_steps]
    cols = list(res.controller_columns.items())       # result column -> FMU variable
    dt = [("time", float)] + [(var, d[col].dtype) for col, var in cols]
    ref = np.zeros(n_steps + 1, dtype=dt)
    ref["time"] = h * np.arange(n_steps + 1)
    for col, var in cols:
        ref[var][0] = res.controller_initial.get(var, d[col][0])
        ref[var][1:] = d[col][:n_steps]
    f = case_files(out_dir, model)
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    atomic_write_csv(f["in"], inp)
    atomic_write_csv(f["ref"], ref)
    write_opt(f["opt"], 0.0, float(ref["time"][-1]), h)
    meta = ["# step-test case recorded by `anklehip record` (see docs/step-tests.md)",
            "[source]", f"scenario = {_toml_str(source or res.name)}", f"stop_time = {float(ref['time'][-1])!r}",
            f"outcome = {_toml_str(res.outcome)}", "",
            "[controller]"]
    for k, v in (controller_overrides or {}).items():
        meta.append(f"{k} = {_toml_value(v)}")
    meta += ["", "[compare]", f"abs_tol = {DEFAULT_TOL['abs_tol']:g}", f"rel_tol = {DEFAULT_TOL['rel_tol']:g}", ""]
    atomic_write_text(f["meta"], "\n".join(meta))
    return f


def _toml_str(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("inf" if v > 0 else "-inf") if not math.isnan(v) else "nan"
    return repr(v)


def read_meta(path: Path) -> dict[str, Any]:
    """steptest.toml, checked: [source] (scenario, stop_time, outcome), [controller] parameter
    values (numbers or booleans; names are checked against the FMU when the case runs),
    [compare] tolerances (as in a scenario's [reference] table)."""
    if not path.is_file():
        return {}
    where = str(path)
    meta = read_toml(path, where, StepTestError)
    v = _StepTestV(where)
    v.keys(meta, {"source", "controller", "compare"}, "")
    src = v.table(meta.get("source", {}), "source")
    v.keys(src, {"scenario", "stop_time", "outcome"}, "source.")
    for k in ("scenario", "outcome"):
        if k in src:
            v.str_(src[k], f"source.{k}")
    if "stop_time" in src:
        v.num(src["stop_time"], "source.stop_time", gt=0.0)
    if "controller" in meta:
        meta["controller"] = _parse_overrides(v, meta["controller"], "controller")
    cmp = v.table(meta.get("compare", {}), "compare")
    v.keys(cmp, {"abs_tol", "rel_tol", "dx", "dy", "num", "signals"}, "compare.")
    for k in ("abs_tol", "rel_tol", "dy"):
        if k in cmp:
            v.num(cmp[k], f"compare.{k}", ge=0.0)
    if "dx" in cmp:
        v.int_(cmp["dx"], "compare.dx", ge=1)
    if "num" in cmp:
        v.int_(cmp["num"], "compare.num", ge=2)
    for name, tab in v.table(cmp.get("signals", {}), "compare.signals").items():
        tab = v.table(tab, f"compare.signals.{name}")
        v.keys(tab, REF_SIGNAL_KEYS, f"compare.signals.{name}.")
        for k, x in tab.items():
            v.num(x, f"compare.signals.{name}.{k}", ge=0.0)
    return meta


class _StepTestV(_V):
    """The scenario file checks, raising StepTestError."""

    def fail(self, key: str, msg: str):
        raise StepTestError(f"{self.where}: {key}: {msg}")


# ----------------------------------------------------------------------------------------------
# running

@dataclass
class RTStats:
    """Per-step timings of one run, in µs: ``exec_us`` the duration of each fmi2DoStep alone,
    ``late_us`` how long after its deadline each step started. ``misses`` counts the deadline
    misses (steps whose work — set inputs, doStep, get outputs — finished after the next deadline);
    it is None for a run that was not paced (the native runner's fast mode), which has no
    deadlines and no lateness."""
    period_us: float
    exec_us: np.ndarray
    late_us: np.ndarray
    misses: int | None
    spin_us: float = 0.0
    runner: str = "python"          # "python" (run_controller) or "native" (anklehip_rt_step)

    @property
    def paced(self) -> bool:
        return self.misses is not None

    @classmethod
    def from_timings(cls, path: Path, period_us: float, paced: bool) -> RTStats:
        """The per-step ``--timings`` CSV of anklehip_rt_step: step,time,exec_ns,lateness_ns,miss."""
        tm = np.genfromtxt(path, delimiter=",", names=True, ndmin=1)
        if "miss" not in (tm.dtype.names or ()):
            raise StepTestError(f"{path}: no 'miss' column: this anklehip_rt_step is older than the "
                                "anklehip package, rebuild it (cmake --build build --target anklehip_rt_step)")
        return cls(period_us=period_us, exec_us=tm["exec_ns"] / 1e3,
                   late_us=tm["lateness_ns"] / 1e3 if paced else np.zeros(0),
                   misses=int(np.sum(tm["miss"])) if paced else None, runner="native")

    def pct(self, v: np.ndarray) -> dict[str, float]:
        """p50/p99/p99.9/max by nearest rank (each one a measured value, as anklehip_rt_step
        reports them)."""
        if not len(v):
            return {}
        return {"p50": float(np.percentile(v, 50, method="inverted_cdf")),
                "p99": float(np.percentile(v, 99, method="inverted_cdf")),
                "p99.9": float(np.percentile(v, 99.9, method="inverted_cdf")), "max": float(np.max(v))}

    def as_dict(self) -> dict[str, Any]:
        """The content of realtime.json (docs/step-tests.md, "Real-time pacing")."""
        return {"runner": self.runner, "mode": "realtime" if self.paced else "fast",
                "period_us": self.period_us, "steps": int(len(self.exec_us)), "deadline_misses": self.misses,
                "exec_us": self.pct(self.exec_us), "lateness_us": self.pct(self.late_us), "spin_us": self.spin_us}

    def text(self) -> str:
        f = lambda d: "  ".join(f"{k} {v:8.1f}" for k, v in d.items())  # noqa: E731
        head = (f"real-time: period {self.period_us:.0f} µs, {len(self.exec_us)} steps, {self.misses} deadline misses"
                if self.paced else f"timing, not paced (fast): {len(self.exec_us)} steps, no deadlines")
        lines = [f"{head} ({self.runner} runner)", f"  doStep execution [µs]  {f(self.pct(self.exec_us))}"]
        if self.paced:
            lines.append(f"  wake-up lateness [µs]  {f(self.pct(self.late_us))}")
        return "\n".join(lines)


@dataclass
class StepTestResult:
    """The result of anklehip.steptest: the controller's outputs (``data``, a structured array),
    the comparison with the case's reference (``report``), the timing of a paced or native run
    (``rt``), the files written. ``passed`` is the verdict of `anklehip steptest`."""
    case: Path
    out_csv: Path | None
    data: np.ndarray | None             # the outputs; None when the native runner failed
    report: CompareReport | None
    rt: RTStats | None = None
    runner_error: str | None = None     # why the native runner failed (its exit status)
    plot: Path | None = None            # failed_signals.png, when asked for and a signal failed

    @property
    def passed(self) -> bool:
        return not failures(self)


def run_controller(fmu: Path | FMUInfo, inputs: np.ndarray, start: float, stop: float, step: float,
                   parameters: dict[str, Any] | None = None, outputs: list[str] | None = None,
                   realtime: bool = False, spin_us: float = 0.0, source: str = "input CSV",
                   parameters_origin: str = "step-test case") -> tuple[np.ndarray, RTStats | None]:
    """Step the controller FMU alone on recorded inputs; outputs in the cross-check convention.

    The inputs must cover every communication point start, start + h, ..., stop - h (they are
    interpolated linearly onto that grid, exactly where the grids match); ``source`` names them in
    error messages."""
    info = fmu if isinstance(fmu, FMUInfo) else FMUInfo.load(fmu)
    parameters = parameters or {}
    info.check_overrides(parameters, parameters_origin)
    in_vars = info.by_causality("input")
    names = inputs.dtype.names
    missing = [v.name for v in in_vars if v.name not in names[1:]]
    if missing:
        raise StepTestError(f"{source} lacks column(s) {', '.join(missing)} for the inputs of {info.name} "
                            f"(it has: {', '.join(names[1:])})")
    out_vars = [v for v in info.by_causality("output")]
    if outputs is not None:
        unknown = [o for o in outputs if o not in {v.name for v in out_vars}]
        if unknown:
            raise StepTestError(f"{info.name} has no output(s) {', '.join(unknown)}")
        out_vars = [v for v in out_vars if v.name in outputs]
    n = int(round((stop - start) / step))
    if n < 1:
        raise StepTestError("nothing to step: StopTime - StartTime < StepSize")
    t_in = np.asarray(inputs[names[0]], float)
    tk = start + step * np.arange(n)
    if not np.all(np.isfinite(t_in)):
        raise StepTestError(f"{source}: the time column {names[0]!r} has NaN/Inf at row "
                            f"{int(np.argmax(~np.isfinite(t_in))) + 2}")
    if len(t_in) > 1 and np.any(np.diff(t_in) <= 0):
        k = int(np.argmax(np.diff(t_in) <= 0))
        raise StepTestError(f"{source}: time must increase strictly; row {k + 3} has t={t_in[k + 1]:g} "
                            f"after t={t_in[k]:g}")
    eps = 1e-9 * max(1.0, abs(tk[-1]))
    if t_in[0] > tk[0] + eps or t_in[-1] < tk[-1] - eps:
        raise StepTestError(f"{source}: the inputs cover t={t_in[0]:g}..{t_in[-1]:g} s, the step test needs "
                            f"{tk[0]:g}..{tk[-1]:g} s (StartTime .. StopTime - StepSize of the .opt file)")
    U = np.empty((n, len(in_vars)), float)
    for j, v in enumerate(in_vars):
        # NaN/Inf inputs are passed on: the FMU must contain them (docs/fmu.md, fault bits)
        U[:, j] = np.interp(tk, t_in, np.asarray(inputs[v.name], float))   # exact on a matching grid
    reals = [v for v in out_vars if v.type == "Real"]
    ints = [v for v in out_vars if v.type in ("Integer", "Enumeration")]
    bools = [v for v in out_vars if v.type == "Boolean"]
    R = np.zeros((n + 1, max(1, len(reals))))
    I = np.zeros((n + 1, max(1, len(ints) + len(bools))), np.int32)
    s = Slave(info, "steptest")
    rt = None
    try:
        s.initialize(start, stop, parameters)
        vin = vr_array([v.vr for v in in_vars]); nin = len(in_vars)
        vR = vr_array([v.vr for v in reals]); nR = len(reals)
        vI = vr_array([v.vr for v in ints]); nI = len(ints)
        vB = vr_array([v.vr for v in bools]); nB = len(bools)
        bR, sR, bI, sI, bU, sU = R.ctypes.data, R.strides[0], I.ctypes.data, I.strides[0], U.ctypes.data, U.strides[0]
        oB = 4 * nI
        gR, gI, gB, setR, step_fn, c = s.get_real, s.get_integer, s.get_boolean, s.set_real, s.do_step, s.c

        def read_outputs(row: int) -> int:
            """Outputs straight into row `row` of R and I; returns the OR of the fmi2 statuses."""
            r, i = bR + row * sR, bI + row * sI
            st = gR(c, vR, nR, r) if nR else 0
            if nI:
                st |= gI(c, vI, nI, i)
            if nB:
                st |= gB(c, vB, nB, i + oB)
            return st

        st = read_outputs(0)
        if not realtime:
            for k in range(n):
                st |= setR(c, vin, nin, bU + k * sU)
                sd = step_fn(c, start + k * step, step, 1)
                st |= read_outputs(k + 1)
                if sd > 1 or st > 1:
                    raise FMUError(f"{info.name}: step at t={start + k * step:.6f} s failed (doStep status {sd}, "
                                   f"get/set status {st})")
        else:
            ex = np.zeros(n)
            late = np.zeros(n)
            misses = 0
            pns = int(round(step * 1e9))
            clock = time.perf_counter_ns
            sleep = time.sleep
            spin_ns = int(spin_us * 1000)
            t0 = clock() + 2 * pns
            for k in range(n):
                deadline = t0 + k * pns
                now = clock()
                if now < deadline - spin_ns:
                    sleep((deadline - spin_ns - now) * 1e-9)
                while spin_ns and clock() < deadline:
                    pass
                wake = clock()
                st |= setR(c, vin, nin, bU + k * sU)
                a = clock()
                sd = step_fn(c, start + k * step, step, 1)
                b = clock()
                st |= read_outputs(k + 1)
                done = clock()
                ex[k] = b - a
                late[k] = wake - deadline
                if done > deadline + pns:
                    misses += 1
                if sd > 1 or st > 1:
                    raise FMUError(f"{info.name}: step at t={start + k * step:.6f} s failed (status {sd}/{st})")
            rt = RTStats(period_us=step * 1e6, exec_us=ex / 1000.0, late_us=late / 1000.0, misses=misses,
                         spin_us=spin_us)
    finally:
        s.free()
    dt = [("time", float)] + [(v.name, float) for v in reals] + [(v.name, np.int32) for v in ints + bools]
    out = np.zeros(n + 1, dtype=dt)
    out["time"] = start + step * np.arange(n + 1)
    for j, v in enumerate(reals):
        out[v.name] = R[:, j]
    for j, v in enumerate(ints + bools):
        out[v.name] = I[:, j]
    # keep the model's output order
    order = ["time"] + [v.name for v in out_vars]
    return out[order], rt


def _compare(data: np.ndarray, ref: np.ndarray, meta: dict[str, Any], result_label: str, reference_label: str,
             abs_tol: float | None = None, rel_tol: float | None = None, dx: int | None = None,
             dy: float | None = None, num: int | None = None) -> CompareReport:
    """Every reference column against the run's outputs, with the case's [compare] tolerances
    unless given here (the command line's)."""
    cm = dict(meta.get("compare", {}))
    return compare(data, ref, columns=list(ref.dtype.names[1:]), num=num or cm.get("num"), dx=dx or cm.get("dx", 20),
                   dy=dy if dy is not None else cm.get("dy", 0.1),
                   abs_tol=abs_tol if abs_tol is not None else cm.get("abs_tol"),
                   rel_tol=rel_tol if rel_tol is not None else cm.get("rel_tol"),
                   tolerances=cm.get("signals"), result_label=result_label, reference_label=reference_label)


def _reference(f: dict[str, Path], compare_ref: bool) -> np.ndarray | None:
    if not compare_ref:
        return None
    if not f["ref"].is_file():
        raise StepTestError(f"{f['ref']}: no such file (use --no-compare to only produce outputs)")
    return read_result_csv(f["ref"], "reference")


def run_case(case_dir: Path, fmu: Path, out_dir: Path | None = None, *, realtime: bool = False,
             spin_us: float = 0.0, abs_tol: float | None = None, rel_tol: float | None = None,
             dx: int | None = None, dy: float | None = None, num: int | None = None,
             model: str = MODEL, compare_ref: bool = True) -> StepTestResult:
    case_dir = Path(case_dir)
    f = case_files(case_dir, model)
    if not case_dir.is_dir():
        raise StepTestError(f"{case_dir}: no such case folder")
    opts = read_opt(f["opt"])
    meta = read_meta(f["meta"])
    inputs = read_result_csv(f["in"], "input")
    params = dict(meta.get("controller", {}))
    ref = _reference(f, compare_ref)
    data, rt = run_controller(fmu, inputs, opts["StartTime"], opts["StopTime"], opts["StepSize"],
                              params, outputs=None, realtime=realtime, spin_us=spin_us, source=str(f["in"]),
                              parameters_origin=f"{f['meta']} [controller]")
    out_csv = None
    if out_dir is not None:
        out_csv = Path(out_dir) / f"{model}_out.csv"
        atomic_write_csv(out_csv, data)
    report = None
    if ref is not None:
        report = _compare(data, ref, meta, str(out_csv or "output"), str(f["ref"]), abs_tol=abs_tol,
                          rel_tol=rel_tol, dx=dx, dy=dy, num=num)
    return StepTestResult(case=case_dir, out_csv=out_csv, data=data, report=report, rt=rt)


def run_native(exe: Path, fmu: Path, case_dir: Path, out_dir: Path | None = None, extra: list[str] | None = None,
               *, realtime: bool = False, abs_tol: float | None = None, rel_tol: float | None = None,
               dx: int | None = None, dy: float | None = None, num: int | None = None,
               model: str = MODEL, compare_ref: bool = True) -> StepTestResult:
    """run_case on the native executable ``anklehip_rt_step`` (fmu/rt_runner): paced with
    ``realtime``, else as fast as possible; its outputs are compared with the reference like the
    Python runner's, its per-step timings (timings.csv) become ``rt``. Without ``out_dir`` the
    runner's files go to a temporary folder that is removed afterwards."""
    import tempfile
    case_dir = Path(case_dir)
    f = case_files(case_dir, model)
    if not case_dir.is_dir():
        raise StepTestError(f"{case_dir}: no such case folder")
    opts = read_opt(f["opt"])
    if opts["StartTime"] != 0.0:
        raise StepTestError(f"{f['opt']}: the native runner starts at t = 0 (StartTime {opts['StartTime']:g})")
    meta = read_meta(f["meta"])
    read_result_csv(f["in"], "input")          # a malformed cell is an error naming it (the runner reads 0)
    ref = _reference(f, compare_ref)
    info = FMUInfo.load(fmu)
    params = dict(meta.get("controller", {}))
    info.check_overrides(params, f"{f['meta']} [controller]")
    with tempfile.TemporaryDirectory(prefix="rt_step_") as tmp:
        work = Path(out_dir) if out_dir is not None else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        out_csv, timings = work / f"{model}_out.csv", work / "timings.csv"
        cmd = [str(exe), "--fmu-dir", str(info.unzipdir), "--input", str(f["in"]), "--output", str(out_csv),
               "--step", repr(opts["StepSize"]), "--stop-time", repr(opts["StopTime"]), "--timings", str(timings)]
        for k, v in params.items():
            cmd += ["--param", f"{k}={int(v) if isinstance(v, bool) else v}"]
        if not realtime:
            cmd.append("--fast")
        cmd += extra or []
        print("+ " + " ".join(cmd), flush=True)
        # its report is printed from timings.csv below, the same way as the Python runner's
        p = subprocess.run(cmd, env=os.environ.copy(), stdout=subprocess.PIPE, text=True)
        if p.returncode != 0:
            print(p.stdout, end="", flush=True)
            return StepTestResult(case=case_dir, out_csv=None, data=None, report=None,
                                  runner_error=f"anklehip_rt_step exited with {p.returncode}")
        rt = RTStats.from_timings(timings, opts["StepSize"] * 1e6, paced=realtime)
        data = read_result_csv(out_csv, "native runner output")
    out_label = str(out_csv) if out_dir is not None else "native runner output"
    report = None
    if ref is not None:
        report = _compare(data, ref, meta, out_label, str(f["ref"]), abs_tol=abs_tol, rel_tol=rel_tol, dx=dx,
                          dy=dy, num=num)
    return StepTestResult(case=case_dir, out_csv=out_csv if out_dir is not None else None, data=data,
                          report=report, rt=rt)


# ----------------------------------------------------------------------------------------------
# the verdict, shared by both runners

def failures(r: StepTestResult, fail_on_miss: bool = False) -> list[str]:
    """Why a case that ran fails ([] when it passes) — the one rule of `anklehip steptest` for the
    Python and the native runner: the runner failed, a signal is outside its tolerance, or, with
    ``fail_on_miss``, a deadline was missed."""
    why = []
    if r.runner_error:
        why.append(r.runner_error)
    if r.report is not None and not r.report.passed:
        why.append(f"{len(r.report.failed)} of {len(r.report.signals)} signals outside tolerance")
    if fail_on_miss and r.rt is not None and r.rt.misses:
        why.append(f"{r.rt.misses} deadline misses (--fail-on-miss)")
    return why


def summary(results: list[tuple[Path, StepTestResult | None]], fail_on_miss: bool = False) -> tuple[str, int]:
    """The closing summary of a step-test run and its exit status: 0 when every case passes,
    1 when a case fails (see failures), 2 when a case could not run (malformed case, missing file;
    its result is None)."""
    ran = [(c, r) for c, r in results if r is not None]
    failed = [c.name for c, r in ran if failures(r, fail_on_miss)]
    broken = [c.name for c, r in results if r is None]
    code = 2 if broken else 1 if failed else 0
    named = lambda names: f" ({', '.join(names)})" if names else ""  # noqa: E731
    lines = [f"summary: {len(results)} case{'s' if len(results) != 1 else ''}: {len(ran) - len(failed)} passed, "
             f"{len(failed)} failed{named(failed)}, {len(broken)} could not run{named(broken)}"]
    paced = [(c, r.rt) for c, r in ran if r.rt is not None and r.rt.paced]
    if paced:
        total = sum(rt.misses for _, rt in paced)
        lines.append(f"  deadline misses: {total} in total ("
                     + ", ".join(f"{c.name} {rt.misses}" for c, rt in paced) + ")"
                     + ("" if not total else "; failing the run (--fail-on-miss)" if fail_on_miss
                        else "; not failing the run (no --fail-on-miss)"))
    else:
        lines.append("  deadline misses: not measured (no --realtime)")
    timed = [(c, r.rt) for c, r in ran if r.rt is not None and len(r.rt.exec_us)]
    if timed:
        c, rt = max(timed, key=lambda x: float(np.max(x[1].exec_us)))
        lines.append(f"  worst-case doStep execution: {np.max(rt.exec_us):.1f} µs ({c.name}, {rt.runner} runner; "
                     f"period {rt.period_us:g} µs)")
    else:
        lines.append("  worst-case doStep execution: not measured (use --realtime or --native)")
    lines.append(f"exit {code} (0: every case passed; 1: a case failed: a signal outside tolerance, a runner "
                 f"error or, with --fail-on-miss, a deadline miss; 2: a case could not run)")
    return "\n".join(lines), code


# ----------------------------------------------------------------------------------------------
# the execution-time histogram

def histogram_path(png: Path, case: Path, n_cases: int) -> Path:
    """Where --histogram PNG goes for a case: PNG itself for a single case, else one file per case
    beside it, named after the case: <stem>_<case><suffix> (rt.png -> rt_ankle_small_push.png)."""
    png = Path(png)
    return png if n_cases == 1 else png.with_name(f"{png.stem}_{Path(case).name}{png.suffix or '.png'}")


def _us(x: float) -> str:
    """A time in µs for a label: 3 significant digits, no exponent (0.852, 3.04, 396, 3455)."""
    return f"{x:.0f}" if abs(x) >= 100 else f"{x:.3g}"


def rt_histogram(rt: RTStats, out: Path, title: str = "") -> Path:
    """rt_histogram_figure as a PNG."""
    from ..analysis.plots import _save
    return _save(rt_histogram_figure(rt, title), out)


def rt_histogram_figure(rt: RTStats, title: str = ""):
    """Histograms of the execution time and the wake-up lateness on log-log axes in µs (20 bins a
    decade), the period as a red line, median/p99/max as labelled lines (one row of labels each,
    above the bars), the legend below the panels."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), layout="constrained")
    panels = (("fmi2DoStep execution time", rt.exec_us, f"deadline: period {rt.period_us:g} µs" if rt.paced
               else f"period {rt.period_us:g} µs (the deadline when paced)"),
              ("wake-up lateness (step start − its deadline)", rt.late_us,
               f"period {rt.period_us:g} µs (a step this late misses its deadline)"))
    for ax, (name, v, period_label) in zip(axes, panels):
        ax.set_title(name, fontsize=10)
        if not len(v):
            ax.text(0.5, 0.5, "not paced (--native without --realtime):\nno deadlines, no lateness",
                    ha="center", va="center", transform=ax.transAxes)
            ax.set_xticks([])
            ax.set_yticks([])
            continue
        floor = 0.01                                   # 10 ns; 0 (coarse clocks) lands in the first bin
        lo = 10 ** math.floor(math.log10(max(float(np.min(v)), floor)))
        right_end = 2 * max(float(np.max(v)), rt.period_us)
        hi = 10 ** math.ceil(math.log10(right_end))
        bins = np.logspace(math.log10(lo), math.log10(hi), 20 * round(math.log10(hi / lo)) + 1)
        counts, _, _ = ax.hist(np.clip(v, lo, None), bins=bins, color="tab:blue", alpha=0.75,
                               label=f"{len(v)} steps, 20 bins per decade")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(lo, right_end)
        # the tallest bar reaches 55 % of the height (log scale): the labels go above it
        ax.set_ylim(0.6, 0.6 * (float(np.max(counts)) / 0.6) ** (1 / 0.55))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
        ax.set_xlabel(f"{name.split(' (')[0]} [µs], log scale")
        ax.set_ylabel("steps per bin, log scale")
        ax.grid(alpha=0.3, which="major")
        ax.axvline(rt.period_us, color="tab:red", lw=2, label=period_label)
        p = rt.pct(v)
        marks = (("median", p["p50"], "tab:green", "-"), ("p99", p["p99"], "tab:orange", "--"),
                 ("max", p["max"], "tab:purple", ":"), ("period", rt.period_us, "tab:red", None))
        for i, (label, x, color, ls) in enumerate(marks):
            text = f"{label} {_us(x)} µs"
            if ls:
                ax.axvline(x, color=color, ls=ls, lw=1.5, label=text)
            # one row per label (they never overlap), left of the line when it is in the right part
            right = math.log10(max(x, lo) / lo) / math.log10(right_end / lo) > 0.7
            ax.annotate(text, xy=(x, 0.96 - 0.08 * i), xycoords=("data", "axes fraction"),
                        xytext=(-4 if right else 4, 0), textcoords="offset points", ha="right" if right else "left",
                        va="top", fontsize=8, color=color,
                        bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8))
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.18), ncol=2, fontsize=8, frameon=False)
    mode = (f"paced at {rt.period_us:g} µs, {rt.misses} deadline misses" if rt.paced
            else "not paced (fast)")
    fig.suptitle(f"{title}: {rt.runner} runner, {len(rt.exec_us)} steps, {mode}", fontsize=10)
    return fig


# ----------------------------------------------------------------------------------------------
# the API: anklehip.steptest(...)

def steptest(case: str | Path, *, fmu: str | Path | None = None, out: str | Path | None = None,
             realtime: bool = False, native: bool = False, native_args: list[str] | None = None,
             spin_us: float = 0.0, abs_tol: float | None = None, rel_tol: float | None = None,
             dx: int | None = None, dy: float | None = None, compare: bool = True, plot: bool = False,
             fmu_dir: str | Path | None = None) -> StepTestResult:
    """Step the controller FMU on a recorded case and compare its outputs with the case's
    reference (HIL style; docs/step-tests.md); `anklehip steptest` for one case.

    case        a case folder (<Model>_in.csv, _ref.csv, _ref.opt, steptest.toml), or the name of a
                shipped case (anklehip.steptest_cases())
    fmu         the controller FMU (default: AnkleHipController.fmu where the package finds FMUs)
    out         a folder for <Model>_out.csv, realtime.json (paced or native runs) and, with `plot`,
                failed_signals.png (a failing comparison's signals); None: nothing written
    realtime    pace the steps in wall-clock time (absolute deadlines); `spin_us`: busy-wait the
                last microseconds before each (Python runner)
    native      the native runner anklehip_rt_step (a checkout's build) instead of Python
    abs_tol ... the comparison's tolerances (default: the case's steptest.toml [compare])

    Raises an InputError for a malformed case or a missing file.
    """
    import json

    from ..files.paths import CONTROLLER_FMU, find_fmu, find_rt_runner, find_steptest_case
    from ..files.output import atomic_write_text, check_output_folder
    from ..errors import InputError
    case = find_steptest_case(case)
    fmu = Path(fmu) if fmu else find_fmu(CONTROLLER_FMU, fmu_dir)
    if plot and out is None:
        raise InputError("plot: the plot is a file, give out=<folder>")
    if out is not None:
        out = check_output_folder(out, "out")
    tol = dict(abs_tol=abs_tol, rel_tol=rel_tol, dx=dx, dy=dy, compare_ref=compare)
    if native:
        exe = find_rt_runner()
        if exe is None:
            raise InputError("the native real-time runner anklehip_rt_step is not built (fmu/rt_runner in a "
                             "checkout: `bash scripts/setup.sh`), or set ANKLEHIP_RT_STEP")
        r = run_native(exe, fmu, case, out, native_args, realtime=realtime, **tol)
    else:
        r = run_case(case, fmu, out, realtime=realtime, spin_us=spin_us, **tol)
    if out is not None and r.rt is not None:
        atomic_write_text(Path(out) / "realtime.json", json.dumps(r.rt.as_dict(), indent=2) + "\n")
    if plot and r.report is not None and not r.report.passed:
        from ..analysis.compare import plot_failed
        r.plot = plot_failed(r.report, Path(out) / "failed_signals.png")
    return r


def steptest_cases() -> list[str]:
    """The names of the step-test cases that come with the package (or the checkout)."""
    from ..files.paths import steptests_dir
    d = steptests_dir()
    return sorted(p.name for p in d.glob("*") if p.is_dir() and (p / "steptest.toml").is_file())
