"""Command-line interface: ``anklehip <command> ...`` (see docs/scenarios.md, docs/step-tests.md).

Exit status: 0 success, 1 a check failed (expected outcome, comparison, step test),
2 the input is wrong (bad scenario, missing file or column, unknown parameter, bad option value,
output folder in use). An error is one line on stderr that names the file, key, cell or option
and the reason; no input ends in a Python traceback.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from . import __version__

EXIT_OK, EXIT_FAIL, EXIT_ERROR = 0, 1, 2


class UsageError(ValueError):
    """A command-line argument is wrong (the message names the option and the value)."""


DEFAULT_REF_COLUMNS = ["theta_ankle", "theta_hip", "theta_ankle_ref", "theta_hip_ref", "zmp_x", "com_x",
                       "fz", "push_force", "phase"]


def _err(msg: str) -> int:
    print(f"anklehip: error: {msg}", file=sys.stderr)
    return EXIT_ERROR


def _progress(a) -> bool | None:
    """The `progress` argument of master.simulate and make_figures for a command's --no-progress:
    False turns the bars off, None shows them when stderr is a terminal."""
    return False if getattr(a, "no_progress", False) else None


def check_output_folder(path: str | Path, option: str) -> Path:
    """An output folder that exists or can be created: the nearest existing ancestor is a
    writable folder. Checked before anything runs, so a bad --out costs no run."""
    p = Path(path)
    for q in [p, *p.parents]:
        if q.exists():
            if not q.is_dir():
                raise UsageError(f"{option} {path}: {q} exists and is not a folder")
            if not os.access(q, os.W_OK | os.X_OK):
                raise UsageError(f"{option} {path}: cannot write into {q}")
            break
    return p


def check_stop_time(sc, stop_time: float | None) -> None:
    """--stop-time: finite, after the start, a whole number of the scenario's steps, at most
    scenario.MAX_STEPS steps (scenario.time_grid_problem)."""
    from .scenario import time_grid_problem
    if stop_time is None:
        return
    problem = time_grid_problem(stop_time, sc.step)
    if problem:
        raise UsageError(f"--stop-time {stop_time:g} {problem} (scenario {_rel(sc.path) if sc.path else sc.name}, "
                         f"step {sc.step:g} s)")


# ----------------------------------------------------------------------------------------------
# helpers shared by run / record / regen-references

def decimate(data: np.ndarray, step: float, interval: float) -> np.ndarray:
    k = max(1, int(round(interval / step)))
    idx = np.arange(0, len(data), k)
    if idx[-1] != len(data) - 1:
        idx = np.append(idx, len(data) - 1)
    return data[idx]


def reference_columns(sc, data: np.ndarray) -> list[str]:
    cols = sc.reference.columns if sc.reference and sc.reference.columns else DEFAULT_REF_COLUMNS
    return [c for c in cols if c in data.dtype.names]


def compare_with_reference(sc, res):
    """Compare a run with the scenario's reference; None when it has none or the file is missing."""
    from .compare import compare
    from .scenario import ScenarioError
    r = sc.reference
    if r is None or not r.file.is_file():
        return None
    if r.signals:
        from .compare import read_result_csv
        cols = r.columns or list(read_result_csv(r.file, "reference").dtype.names[1:])
        for name in r.signals:
            if name not in cols:
                raise ScenarioError(f"{_rel(sc.path) if sc.path else sc.name}: reference.signals.{name}: "
                                    f"not a compared signal (compared: {', '.join(cols)})")
    # the reference holds every interval-th row of a run: compare the same rows of this run (a
    # 1-2 ms transient between two reference samples is not a deviation from the reference)
    return compare(decimate(res.data, res.step, r.interval), r.file, columns=r.columns, num=r.num, dx=r.dx, dy=r.dy, abs_tol=r.abs_tol,
                   rel_tol=r.rel_tol, band_floor=r.band_floor, tolerances=r.signals,
                   result_label=f"{sc.name} (this run)",
                   reference_label=_rel(r.file))


def _rel(p: Path) -> str:
    try:
        return str(Path(p).resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(p)


def geometry_for(res=None, params: dict | None = None):
    from .plots import Geometry
    return Geometry.from_parameters(params if params is not None else (res.plant_parameters if res else None))


def zmp_limits(params: dict[str, Any]) -> tuple[float, ...] | None:
    lims = []
    for k in ("zmp_limit_front", "p_lim", "zmp_limit_toe", "p_lim_toe", "zmp_lim"):
        if isinstance(params.get(k), (int, float)):
            lims.append(float(params[k]))
            break
    for k in ("zmp_limit_back", "p_lim_heel", "zmp_limit_heel"):
        if isinstance(params.get(k), (int, float)):
            v = float(params[k])
            lims.append(-abs(v))
            break
    return tuple(lims) or None


def make_figures(sc_name: str, data: np.ndarray, out: Path, res=None, animate: bool = False,
                 anim_args: dict | None = None, figures: bool = True, params: dict | None = None,
                 progress: bool | None = None) -> list[Path]:
    """The standard figures of a result (and the 3D plant's frontal one), the animation if asked;
    geometry from the run's plant parameters, or `params` for a CSV read back. `progress` as in
    master.simulate: on a terminal a bar of the figures, then one of the GIF's frames, and a line per
    file written; nothing with False (`--no-progress`) or when stderr is not a terminal."""
    import time

    from . import plots
    jobs = []
    if figures:
        zl = zmp_limits(res.controller_parameters) if res else None
        jobs = [(f"{sc_name}_overview.png", lambda p: plots.overview(data, p, title=sc_name)),
                (f"{sc_name}_fig4_joint_angles.png",
                 lambda p: plots.fig4(data, p, title=f"{sc_name}: joint angles (cf. paper Fig. 4)")),
                (f"{sc_name}_fig5_first_cycle.png",
                 lambda p: plots.fig5(data, p, zmp_limits=zl, title=f"{sc_name}: first push cycle (cf. paper Fig. 5)"))]
        if plots._has(data, "zmp_y", "com_y", "foot_roll"):   # the 3D plant's results
            jobs.append((f"{sc_name}_frontal.png",
                         lambda p: plots.frontal(data, p, title=f"{sc_name}: frontal plane and feet")))
    files = []
    bar = plots.progress_bar(len(jobs), "figures", "fig", progress) if jobs else None
    try:
        for name, draw in jobs:
            if bar is not None:
                bar.set_postfix_str(name)
            t0 = time.perf_counter()
            files.append(draw(out / name))
            if bar is not None:
                bar.update(1)
            plots.say_written(bar, files[-1], time.perf_counter() - t0)
    finally:
        if bar is not None:
            bar.close()
    if animate:
        files.append(plots.animate(data, out / f"{sc_name}.gif", geometry_for(res, params), title=sc_name,
                                   progress=progress, **(anim_args or {})))
    return files


# ----------------------------------------------------------------------------------------------
# commands

def cmd_list(a) -> int:
    from .paths import scenarios_dir
    from .scenario import ScenarioError, load_scenario
    rc = EXIT_OK
    files = sorted(scenarios_dir().glob("*.toml"))
    if not files:
        print(f"no scenarios in {scenarios_dir()}")
    for f in files:
        try:
            sc = load_scenario(f)
        except ScenarioError as e:
            print(f"{f.stem:<28} INVALID: {e}")
            rc = EXIT_ERROR
            continue
        e = sc.expect
        exp = "must fall" if e.must_fall else ("must stand" if e.must_fall is False else "")
        if e.phases_reached:
            exp += f", phases {''.join(map(str, e.phases_reached))}"
        ref = "ref" if sc.reference and sc.reference.file.is_file() else ("ref missing" if sc.reference else "")
        peak = f"{sc.push.peak():+6.1f} N" if sc.push_y.peak() == 0 else f"y {sc.push_y.peak():+4.1f} N"
        if sc.push.peak() != 0 and sc.push_y.peak() != 0:
            peak = f"{sc.push.peak():+.1f}/y{sc.push_y.peak():+.1f}"
        print(f"{sc.name:<28} {sc.plant_model:<8} {sc.stop_time:6.1f} s  peak push {peak:<8}  {exp:<24} {ref:<11} "
              f"{sc.description.splitlines()[0] if sc.description else ''}")
    return rc


def _scenario_and_models(a):
    """The scenario named on the command line with its --set overrides applied, and the FMUs, checked
    against each other. Raises ScenarioError, MissingFileError or FMUError with a message that names
    the file, key or variable."""
    from .master import Models, check_overrides
    from .paths import find_scenario
    from .scenario import ScenarioError, load_scenario, parse_set
    sc = load_scenario(find_scenario(a.scenario))
    c_set, p_set = parse_set(a.set or [])
    check_stop_time(sc, getattr(a, "stop_time", None))
    if getattr(a, "plant", None):
        sc.plant_model = a.plant
    if sc.push_y.peak() != 0 and sc.plant_model == "sagittal":
        raise ScenarioError(f"{_rel(sc.path)}: push_y: a sideways push needs the 3D plant (--plant 3d)")
    models = Models.load(a.fmu_dir, plant_model=sc.plant_model, fmi=getattr(a, "fmi", 2))
    if getattr(a, "controller_config", None):
        sc.controller_config = a.controller_config
        models.controller.configuration(sc.controller_config, "--controller-config")
    else:
        models.controller.configuration(sc.controller_config, f"{_rel(sc.path)}: controller_config")
    # names, types and ranges (the modelDescription's min/max) of the scenario's tables and of each
    # --set, before anything runs
    check_overrides(models, sc.controller, sc.plant, _rel(sc.path))
    for fmu, info, over in (("controller", models.controller, c_set), ("plant", models.plant, p_set)):
        for k, v in over.items():
            info.check_overrides({k: v}, f"--set {fmu}.{k}, scenario {_rel(sc.path)}")
    sc.controller.update(c_set)
    sc.plant.update(p_set)
    if getattr(a, "fault", None):
        from .scenario import parse_fault_options
        sc.faults = parse_fault_options(a.fault, sc.faults)
    return sc, models


def cmd_run(a) -> int:
    from .fmu import FMUError
    from .paths import MissingFileError
    from .results import output_lock
    from .scenario import ScenarioError
    try:
        sc, models = _scenario_and_models(a)
    except (ScenarioError, MissingFileError, FMUError) as e:
        return _err(str(e))
    # every argument is checked before the output folder is touched
    out = check_output_folder(a.out if a.out else Path("results") / sc.name, "--out")
    if a.record_steptest:
        check_output_folder(a.record_steptest, "--record-steptest")
    with output_lock(out):      # a second run into the same folder fails here, at once
        return _run(a, sc, models, out)


def _run(a, sc, models, out: Path) -> int:
    from .master import simulate
    from .results import (atomic_write_csv, check_expect, clear_previous, format_summary, result_paths,
                          summarize_pushes, summary_dict, write_summary_json)
    paths = result_paths(out, sc.name)
    res = simulate(sc, models, stop_time=a.stop_time, progress=_progress(a), engine=a.engine)
    csv = paths["csv"] if res.complete else paths["incomplete_csv"]
    atomic_write_csv(csv, res.data)
    # only now that this run's data are in place: the previous run's files go (its complete CSV
    # must not sit next to this run's incomplete one), the new summary is written last
    clear_previous(out, sc.name, keep=(csv,))
    files = {"csv": str(csv), "summary": str(paths["summary"])}
    pushes = summarize_pushes(res, sc.push, sc.expect.erect_tol)
    checks = check_expect(res, sc.expect) if a.stop_time is None else []
    cmp = None
    warnings: list[str] = []
    # overrides change the reference; an interrupted or failed run is not a result to compare
    changed = a.set or a.controller_config or a.fault
    if changed and sc.reference is not None and not a.no_compare:
        print("anklehip: note: --set / --controller-config / --fault change the run, so it is not compared with "
              f"{_rel(sc.reference.file)}", file=sys.stderr)
    if not a.no_compare and a.stop_time is None and not changed and res.outcome not in ("error", "interrupted"):
        try:
            rep = compare_with_reference(sc, res)
        except Exception as e:   # a broken reference must not lose the run
            rep = None
            warnings.append(f"reference comparison failed: {e}")
        if rep is None and sc.reference is not None and not sc.reference.file.is_file():
            warnings.append(f"{_rel(sc.path)}: reference.file: {_rel(sc.reference.file)} does not exist, "
                            f"the run was not compared (create it with `anklehip regen-references {sc.name}`)")
        for w in warnings:
            print(f"anklehip: warning: {w}", file=sys.stderr)
        if rep is not None:
            cmp = rep.as_dict()
            if not rep.passed:
                from .compare import plot_failed
                p = plot_failed(rep, out / f"{sc.name}_reference_failed.png")
                if p:
                    files["reference_failures_plot"] = str(p)
    # figures and the step-test case must not lose the summary of a run that has been computed
    if a.plots or a.animate:
        anim = {"fps": a.fps, "speed": a.speed, "t_start": a.anim_start, "t_stop": a.anim_stop}
        try:
            for p in make_figures(sc.name, res.data, out, res, animate=a.animate, anim_args=anim, figures=a.plots,
                                  progress=_progress(a)):
                files[p.stem] = str(p)
        except Exception as e:
            warnings.append(f"figures failed: {type(e).__name__}: {e}")
    if a.record_steptest:
        from .steptest import record_case
        try:
            record_case(res, Path(a.record_steptest), res.controller_overrides, source=sc.name)
            files["steptest_case"] = a.record_steptest
        except Exception as e:
            warnings.append(f"--record-steptest {a.record_steptest}: {type(e).__name__}: {e}")
    s = summary_dict(sc, res, pushes, checks, files, cmp)
    if warnings:
        s["warnings"] = warnings
    if a.stop_time is not None:
        # A shortened run is complete for what was asked, but it is not the scenario's result.
        s["shortened_from_stop_time"] = sc.stop_time
        print(f"anklehip: note: --stop-time {a.stop_time:g} s replaces the scenario's {sc.stop_time:g} s; "
              "its expectations and reference were not checked", file=sys.stderr)
    write_summary_json(paths["summary"], s)
    print(format_summary(s, pushes))
    if res.outcome in ("error", "interrupted"):
        return EXIT_FAIL
    # Any failed expectation, a reference outside its band, or a broken reference set-up fails the run
    # (after everything has been written).
    reference_ok = cmp is None or cmp.get("passed", True)
    failed = [c.name for c in checks if not c.ok] + ([] if reference_ok else ["reference comparison"])
    if failed or warnings:
        why = f"{len(failed)} check(s) failed: {', '.join(failed)}" if failed else "warnings: " + "; ".join(warnings)
        print(f"anklehip: {sc.name}: {why} (exit {EXIT_FAIL})", file=sys.stderr)
        return EXIT_FAIL
    return EXIT_OK


def cmd_plot(a) -> int:
    from .compare import CompareError, read_result_csv
    try:
        data = read_result_csv(a.csv, "result")
    except CompareError as e:
        return _err(str(e))
    csv = Path(a.csv)
    name = csv.name.removesuffix(".csv").removesuffix(".incomplete")
    out = Path(a.out) if a.out else csv.parent
    params = None
    if a.animate:
        try:
            from .fmu import FMUInfo
            from .paths import PLANT_FMU, find_fmu
            params = FMUInfo.load(find_fmu(PLANT_FMU, a.fmu_dir)).start_values()
        except Exception:
            params = None
    std = all(c in data.dtype.names for c in ("theta_ankle", "theta_hip", "zmp_x", "com_x"))
    if std:
        try:
            files = make_figures(name, data, out, animate=a.animate, params=params,
                                 anim_args=dict(fps=a.fps, speed=a.speed, t_start=a.anim_start, t_stop=a.anim_stop),
                                 progress=_progress(a))
        except ValueError as e:       # e.g. an animation window outside the result
            return _err(f"{csv}: {e}")
    else:
        from . import plots
        files = [plots.overview(data, out / f"{name}_overview.png", title=name)]
    for f in files:
        print(f)
    return EXIT_OK


def cmd_compare(a) -> int:
    from .compare import CompareError, compare, plot_comparison
    cols = [c.strip() for c in a.columns.split(",")] if a.columns else None
    try:
        rep = compare(a.result, a.reference, columns=cols, num=a.num, dx=a.dx, dy=a.dy, abs_tol=a.abs_tol,
                      rel_tol=a.rel_tol, band_floor=a.band_floor, t_start=a.t_start, t_stop=a.t_stop,
                      require_coverage=not a.allow_partial)
    except CompareError as e:
        return _err(str(e))
    print(rep.text(verbose=not a.failed_only))
    if a.plot:   # a passing comparison's plot is evidence too
        p = plot_comparison(rep, a.plot)
        print(f"plot of {'the failed signals' if rep.failed else 'all compared signals (all passed)'}: {p}")
    if a.json:
        Path(a.json).write_text(json.dumps(rep.as_dict(), indent=2, default=float) + "\n")
    return EXIT_OK if rep.passed else EXIT_FAIL


def cmd_steptest(a) -> int:
    from .compare import CompareError, plot_failed
    from .fmu import FMUError
    from .paths import CONTROLLER_FMU, MissingFileError, find_fmu, find_rt_runner
    from .steptest import StepTestError, failures, histogram_path, rt_histogram, run_case, run_native, summary
    if a.fail_on_miss and not a.realtime:
        return _err("--fail-on-miss needs --realtime (only a paced run has deadlines)")
    if a.histogram and not (a.realtime or a.native):
        return _err("--histogram needs --realtime or --native (a plain Python run is not timed)")
    if a.spin_us and (a.native or not a.realtime):
        return _err("--spin-us applies to the Python runner with --realtime (the native runner sleeps to "
                    "absolute deadlines with clock_nanosleep and does not spin)")
    cases = [Path(c) for c in a.cases]
    names = [c.name for c in cases]
    if (a.out or a.histogram) and len(set(names)) < len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        return _err(f"two cases are named {', '.join(dup)}: their files under --out/--histogram would collide")
    try:
        fmu = Path(a.fmu) if a.fmu else find_fmu(CONTROLLER_FMU, a.fmu_dir)
        exe = find_rt_runner() if a.native else None
    except MissingFileError as e:
        return _err(str(e))
    if a.native and exe is None:
        return _err("the native real-time runner anklehip_rt_step is not built (fmu/rt_runner; "
                    "run `bash scripts/setup.sh`), or set ANKLEHIP_RT_STEP")
    tol = dict(abs_tol=a.abs_tol, rel_tol=a.rel_tol, dx=a.dx, dy=a.dy, compare_ref=not a.no_compare)
    results = []
    for case in cases:
        out = Path(a.out) / case.name if a.out else None
        try:
            if a.native:
                r = run_native(exe, fmu, case, out, a.native_args, realtime=a.realtime, **tol)
            else:
                r = run_case(case, fmu, out, realtime=a.realtime, spin_us=a.spin_us, **tol)
        except (StepTestError, CompareError, FMUError) as e:
            print(f"anklehip: error: {case}: {e}", file=sys.stderr)
            results.append((case, None))
            continue
        results.append((case, r))
        steps = f"{len(r.data) - 1} steps" if r.data is not None else "no outputs"
        print(f"step test {case}: {steps}" + (f", outputs {r.out_csv}" if r.out_csv else ""))
        if r.report is not None:
            print(r.report.text(verbose=not a.failed_only))
            if a.plot and not r.report.passed:
                print(f"plot of the failed signals: {plot_failed(r.report, (out or case) / 'failed_signals.png')}")
        if r.rt is not None:
            print(r.rt.text())
            if a.histogram:
                dest = histogram_path(Path(a.histogram), case, len(cases))
                print(f"histogram: {rt_histogram(r.rt, dest, case.name)}")
            if out:
                out.mkdir(parents=True, exist_ok=True)
                (out / "realtime.json").write_text(json.dumps(r.rt.as_dict(), indent=2) + "\n")
                print(f"timing report: {out / 'realtime.json'}")
        why = failures(r, a.fail_on_miss)
        print(f"{case.name}: {'FAIL: ' + '; '.join(why) if why else 'PASS'}")
    text, rc = summary(results, a.fail_on_miss)
    print(text)
    return rc


def cmd_record(a) -> int:
    from .fmu import FMUError
    from .master import simulate
    from .paths import MissingFileError
    from .scenario import ScenarioError
    from .steptest import record_case
    from .results import output_lock
    try:
        sc, models = _scenario_and_models(a)
    except (ScenarioError, MissingFileError, FMUError) as e:
        return _err(str(e))
    out = check_output_folder(a.out, "OUT")
    with output_lock(out):
        res = simulate(sc, models, stop_time=a.stop_time, progress=_progress(a))
        if res.outcome in ("error", "interrupted"):
            return _err(f"the run failed: {res.message}")
        files = record_case(res, out, res.controller_overrides, source=sc.name)
    print(f"recorded {len(res.data) - 1} controller steps of {sc.name} ({res.message or res.outcome}):")
    for f in files.values():
        print(f"  {f}")
    return EXIT_OK


def _points_end(res, journal: Path, command: str) -> int:
    """The end of a run of points (anklehip.points.Outcome): each failed point's error, the
    interruption message, and the exit status (130 interrupted, 1 a point failed, else 0)."""
    for r in res.rows:
        if r.get("outcome") == "error":
            print(f"anklehip {command}: point {r['id']}: {r.get('error', '?')}", file=sys.stderr)
    if res.interrupted:
        print(f"anklehip {command}: interrupted: {len(res.rows)} of {res.total} points done, kept in "
              f"{journal}; run the same command again to finish the rest", file=sys.stderr)
        return 130
    return EXIT_FAIL if res.errors else EXIT_OK


def cmd_sweep_file(a) -> int:
    from .fmu import FMUError
    from .master import Models, check_overrides
    from .native import default_engine
    from .paths import MissingFileError
    from .points import JournalMismatch, run_points
    from .results import output_lock
    from .scenario import ScenarioError, faults_from, load_scenario
    from .sweep import sweep_key, write_points_table
    from .sweepfile import load_sweep_file, sweepfile_point
    from .paths import find_sweep_file
    try:
        path = find_sweep_file(a.scenario)
        sf = load_sweep_file(path)
        sc = load_scenario(sf.scenario)
        models = Models.load(a.fmu_dir, plant_model=sc.plant_model)
        where = str(path)
        for k, vals in list(sf.axes.items()) + [(k, list(r)) for k, r in sf.ranges.items()]:
            group, _, name = k.partition(".")
            for x in (vals[0], vals[-1]):    # names and ranges checked here, not in every worker
                if group in ("controller", "plant"):
                    check_overrides(models, {name: x} if group == "controller" else {},
                                    {name: x} if group == "plant" else {}, f"{where}: {k}")
                elif group == "faults":
                    faults_from({name: x}, sc.faults, f"{where}: {k}")
                elif name == "height":
                    check_overrides(models, {}, {"h_push": x}, f"{where}: {k}")
        for v in sf.variants:
            models.controller.configuration(v.config or sc.controller_config, f"{where}: variant {v.name}")
            check_overrides(models, v.controller, v.plant, f"{where}: variant {v.name}")
    except (ScenarioError, MissingFileError, FMUError, ValueError) as e:
        return _err(str(e))
    out = check_output_folder(a.out if a.out else Path("results") / f"sweep_{sf.name}", "--out")
    specs = sf.specs(a.fmu_dir, a.engine or default_engine())
    with output_lock(out):
        try:
            res = run_points(sweepfile_point, specs, workers=a.workers, scheduler=a.scheduler,
                             journal=out / "points.jsonl", key=sweep_key(path, models) + sweep_key(sf.scenario, models),
                             what=f"sweep file {path.name}", label=f"sweep {sf.name}", restart=a.restart)
        except JournalMismatch as e:
            return _err(str(e))
        if not res.rows:
            print("anklehip sweep: interrupted before any point finished; nothing written", file=sys.stderr)
            return 130
        csv_path, pq_path = write_points_table(res.rows, out, "points", complete=res.complete)
        figs = []
        if res.complete:
            from .capability import plot_capability, plot_points
            figs = plot_points(sf, res.rows, out)
            cap = plot_capability(sf, res.rows, out, _sweep_plant_params(a.fmu_dir, sc, sf))
            figs += [cap] if cap else []
    print(f"{sf.name}: {len(res.rows)} of {res.total} points ({res.resumed} from an earlier run), {res.wall:.1f} s")
    for v in sf.variants:
        rr = [r for r in res.rows if r.get("variant") == v.name]
        stood = sum(r["outcome"] == "completed" for r in rr)
        print(f"  {v.name:<16} {stood} of {len(rr)} stood")
    print(f"table {csv_path}\n      {pq_path}" + "".join(f"\nfigure {f}" for f in figs))
    return _points_end(res, out / "points.jsonl", "sweep")


def _sweep_plant_params(fmu_dir, sc, sf) -> dict:
    """The sagittal plant's parameters a sweep file's bounds use: the FMU's defaults with the
    scenario's and the first variant's plant overrides ({} without the sagittal plant FMU)."""
    from .fmu import FMUError, FMUInfo
    from .paths import PLANT_FMU, MissingFileError, find_fmu
    try:
        params = FMUInfo.load(find_fmu(PLANT_FMU, fmu_dir)).start_values()
    except (MissingFileError, FMUError):
        return {}
    return {**params, **sc.plant, **sf.variants[0].plant}


def cmd_sweep(a) -> int:
    if a.forces is None:
        return cmd_sweep_file(a)
    from .paths import MissingFileError, find_scenario
    from .points import JournalMismatch
    from .scenario import ScenarioError, load_scenario
    from .fmu import FMUError
    from .master import Models, check_overrides
    from .native import default_engine
    from .results import output_lock
    from .sweep import parse_grid, parse_variant, plot_sweep, run_sweep, sweep_key, write_points_table
    try:
        path = find_scenario(a.scenario)
        sc = load_scenario(path)
        forces = parse_grid(a.forces, "--forces")
        variants = [parse_variant(v) for v in (a.variant or ["default"])]
        models = Models.load(a.fmu_dir, plant_model=sc.plant_model)
        for v in variants:    # a bad variant is an error here, not a traceback in every worker
            models.controller.configuration(v.config or sc.controller_config, f"--variant {v.name}")
            check_overrides(models, v.controller, v.plant, f"--variant {v.name}")
    except (ScenarioError, MissingFileError, FMUError, ValueError) as e:
        return _err(str(e))
    if sc.push.peak() == 0:
        return _err(f"{path}: the scenario has no push to scale")
    out = check_output_folder(a.out if a.out else Path("results") / f"sweep_{sc.name}", "--out")
    with output_lock(out):
        try:
            res = run_sweep(str(path), forces, variants, a.fmu_dir, workers=a.workers,
                            engine=a.engine or default_engine(), scheduler=a.scheduler,
                            journal=out / "sweep.points.jsonl", key=sweep_key(path, models), restart=a.restart)
        except JournalMismatch as e:
            return _err(str(e))
        rows = res.rows
        if not rows:
            print(f"anklehip sweep: interrupted before any point finished; nothing written", file=sys.stderr)
            return 130
        t = write_points_table(rows, out, "sweep", complete=res.complete)
        p = plot_sweep([r for r in rows if r.get("outcome") != "error"], out / "sweep.png",
                       title=f"{sc.name}: outcome vs peak push force")
    for v in dict.fromkeys(r["variant"] for r in rows if "variant" in r):
        rr = [r for r in rows if r.get("variant") == v]
        ok = [r["peak_force"] for r in rr if r["outcome"] not in ("fell", "error")]
        print(f"{v:<16} " + "  ".join(f"{r['peak_force']:g}N:{'FELL' if r['outcome'] == 'fell' else 'ok/' + str(r['max_phase'])}"
                                       for r in rr if r["outcome"] != "error") + (f"   largest survived {max(ok, key=abs):g} N" if ok else ""))
    print(f"table {t[0]}\n      {t[1]}\nplot  {p}")
    print(f"{len(rows)} of {res.total} points ({res.resumed} from an earlier run), {res.wall:.1f} s", file=sys.stderr)
    return _points_end(res, out / "sweep.points.jsonl", "sweep")


def cmd_robustness(a) -> int:
    from .faults import KEY_BY_NAME
    from .paths import MissingFileError, find_scenario
    from .robustness import STUDIES, run_studies, study_by_label, summarize, table_markdown
    from .scenario import ScenarioError, faults_from, load_scenario
    from .sweep import parse_grid
    try:
        path = find_scenario(a.scenario)
        sc = load_scenario(path)
        studies = [study_by_label(x) for x in a.study] if a.study else list(STUDIES)
        grids = {}
        for g in a.grid or []:
            key, eq, spec = g.partition("=")
            if not eq or key not in KEY_BY_NAME:
                raise ValueError(f"--grid {g}: expected KEY=GRID with KEY one of {', '.join(KEY_BY_NAME)}")
            grids[key] = parse_grid(spec, f"--grid {key}")
        plan = []
        for st in studies:
            levels = grids.get(st.key) or parse_grid(st.levels_spec, f"the grid of study {st.label!r}")
            for x in (levels[0], levels[-1]):    # a level out of range is an error here, not in a worker
                faults_from({**st.base, st.key: int(x) if KEY_BY_NAME[st.key].integer else x}, sc.faults,
                            f"--grid {st.key}")
            plan.append((st, levels))
    except (ScenarioError, MissingFileError, ValueError) as e:
        return _err(str(e))
    from .master import Models
    from .points import JournalMismatch
    from .results import atomic_write_text, output_lock
    from .sweep import sweep_key, write_points_table
    out = check_output_folder(a.out if a.out else Path("results") / f"robustness_{sc.name}", "--out")
    with output_lock(out):
        try:
            res = run_studies(str(path), plan, a.fmu_dir, workers=a.workers, scheduler=a.scheduler,
                              journal=out / "points.jsonl",
                              key=sweep_key(path, Models.load(a.fmu_dir, plant_model=sc.plant_model)),
                              restart=a.restart)
        except JournalMismatch as e:
            return _err(str(e))
        rows = res.rows
        if not rows:
            print("anklehip robustness: interrupted before any point finished; nothing written", file=sys.stderr)
            return 130
        pts, _ = write_points_table(rows, out, "points", complete=res.complete)
        if res.interrupted:
            (out / "table.md").unlink(missing_ok=True)
            print(f"points {pts}", file=sys.stderr)
            print(f"anklehip robustness: interrupted: {len(res.rows)} of {res.total} points done, kept in "
                  f"{out / 'points.jsonl'}; run the same command again to finish the rest", file=sys.stderr)
            return 130
        table = table_markdown(summarize([r for r in rows if "study" in r]))   # not the points that raised
        atomic_write_text(out / "table.md", table)
    print(table)
    print(f"points {pts}\ntable  {out / 'table.md'}")
    failed = [r for r in rows if "study" not in r]
    for r in failed:
        print(f"anklehip robustness: point {r['id']}: {r.get('error', '?')}", file=sys.stderr)
    bad = [r for r in rows if "study" in r and not r["invariants_ok"]]
    for r in bad:
        print(f"anklehip: invariant violated: {r['study']} at {r['level']:g}: {r['outcome']} {r['message']} "
              f"(non-finite outputs {r['nonfinite_outputs']}, unflagged rows {r['unflagged_rows']}, "
              f"fault changes {r['fault_changes']} / logged {r['fault_logs']}, non-finite episodes "
              f"{r['nonfinite_episodes']} / warned {r['nonfinite_warnings']})", file=sys.stderr)
    return EXIT_OK if not bad and not failed else EXIT_FAIL


def cmd_soak(a) -> int:
    import json
    from .paths import MissingFileError
    from .fmu import FMUError
    from .results import atomic_write_csv, atomic_write_text
    from .soak import soak
    try:
        out = check_output_folder(a.out if a.out else Path("results") / "soak", "--out")
        rep = soak(a.duration, a.seed, a.fmu_dir, progress=not a.no_progress)
    except (MissingFileError, FMUError) as e:
        return _err(str(e))
    f = rep.figures()
    atomic_write_csv(out / "soak_per_second.csv", rep.per_second)
    atomic_write_text(out / "soak.json", json.dumps(
        {"duration": rep.duration, "seed": rep.seed, "message": rep.message, "figures": f,
         "posture_before_pushes": [[float(t), float(x)] for t, x in rep.posture], "problems": rep.problems},
        indent=2) + "\n")
    print(f"soak: {f['simulated_s']:g} s simulated ({rep.outcome}) with {f['pushes']} seeded random pushes "
          f"(seed {rep.seed}) in {f['wall_s']:g} s wall (real-time factor {f['real_time_factor']:g})")
    for k, v in f.items():
        if k not in ("simulated_s", "pushes", "outcome", "wall_s", "real_time_factor"):
            print(f"  {k:<40} {v:.6g}" if isinstance(v, float) else f"  {k:<40} {v}")
    print(f"  files: {out / 'soak_per_second.csv'}, {out / 'soak.json'}")
    for p in rep.problems:
        print(f"anklehip: soak: {p}", file=sys.stderr)
    return EXIT_OK if not rep.problems else EXIT_FAIL


def cmd_info(a) -> int:
    from .fmu import FMUError
    from .info import format_text, interface, resolve_fmu, select
    from .paths import MissingFileError
    try:
        info = select(interface(resolve_fmu(a.fmu, a.fmu_dir, getattr(a, "fmi", 2))), a.causality, a.name)
    except (MissingFileError, FMUError) as e:
        return _err(str(e))
    print(json.dumps(info, indent=2) if a.json else format_text(info))
    return EXIT_OK


CONTROLLER_CONFIG_HELP = ("a named controller configuration (default: the scenario's controller_config or "
                          "'default'; e.g. paper); --set overrides still apply on top")


def _variants_help() -> str:
    from .sweep import VARIANTS_HELP
    return VARIANTS_HELP


def cmd_regen(a) -> int:
    from .fmu import FMUError
    from .master import Models, simulate
    from .paths import MissingFileError, scenarios_dir
    from .results import atomic_write_csv, check_expect
    from .scenario import ScenarioError, load_scenario
    try:
        files = sorted(scenarios_dir().glob("*.toml"))
        scs = [load_scenario(f) for f in files]
        models = {m: Models.load(a.fmu_dir, plant_model=m) for m in sorted({s.plant_model for s in scs})}
    except (ScenarioError, MissingFileError, FMUError) as e:
        return _err(str(e))
    if a.names:
        unknown = set(a.names) - {s.name for s in scs}
        if unknown:
            return _err(f"unknown scenario(s): {', '.join(sorted(unknown))}")
        scs = [s for s in scs if s.name in a.names]
    rc = EXIT_OK
    for sc in scs:
        if sc.reference is None:
            print(f"{sc.name}: no [reference] table, skipped")
            continue
        res = simulate(sc, models[sc.plant_model], progress=_progress(a))
        checks = check_expect(res, sc.expect)
        bad = [c for c in checks if not c.ok]
        if bad and not a.force:
            print(f"{sc.name}: NOT written, expected outcome not met: "
                  + "; ".join(f"{c.name}: {c.detail}" for c in bad))
            rc = EXIT_FAIL
            continue
        ref = decimate(res.data, res.step, sc.reference.interval)
        cols = reference_columns(sc, res.data)
        atomic_write_csv(sc.reference.file, ref, columns=cols)
        size = sc.reference.file.stat().st_size
        print(f"{sc.name}: wrote {_rel(sc.reference.file)} ({len(ref)} rows, {len(cols)} columns, "
              f"{size / 1024:.0f} kB; {res.message or res.outcome})")
    if not a.no_steptests and not a.names:
        rc = max(rc, regen_steptests(a.fmu_dir))
    return rc


def steptests_dir() -> Path:
    from .paths import repo_root
    return repo_root() / "tests" / "steptests"


def regen_steptests(fmu_dir) -> int:
    """Re-record every committed step-test case from the scenario named in its steptest.toml."""
    from .fmu import FMUError
    from .master import Models, simulate
    from .paths import MissingFileError, find_scenario
    from .scenario import ScenarioError, load_scenario
    from .steptest import StepTestError, read_meta, record_case
    rc = EXIT_OK
    for case in sorted(p for p in steptests_dir().glob("*") if p.is_dir()):
        try:
            src = read_meta(case / "steptest.toml").get("source", {})
            if "scenario" not in src or "stop_time" not in src:
                print(f"{_rel(case)}: no [source] scenario/stop_time in steptest.toml, skipped")
                continue
            sc = load_scenario(find_scenario(src["scenario"]))
            res = simulate(sc, Models.load(fmu_dir, plant_model=sc.plant_model), stop_time=float(src["stop_time"]),
                           progress=False)
        except (StepTestError, ScenarioError, MissingFileError, FMUError) as e:
            print(f"anklehip: error: {_rel(case)}: {e}", file=sys.stderr)
            rc = EXIT_ERROR
            continue
        if res.outcome in ("error", "interrupted"):
            print(f"{_rel(case)}: run failed: {res.message}")
            rc = EXIT_FAIL
            continue
        record_case(res, case, res.controller_overrides, source=sc.name)
        print(f"{_rel(case)}: re-recorded from {sc.name} (0..{src['stop_time']} s, {res.message or res.outcome})")
    return rc


def cmd_export(a) -> int:
    from .export import write_container_fmu, write_ssp
    from .fmu import FMUError
    from .paths import MissingFileError
    from .scenario import ScenarioError
    try:
        sc, models = _scenario_and_models(a)
        if a.kind == "ssp":
            out = write_ssp(a.out or f"{sc.name}.ssp", sc, models, system_input=not a.libcosim)
        else:
            out = write_container_fmu(a.out or f"{sc.name}.fmu", sc, models)
    except (ScenarioError, MissingFileError, FMUError, OSError) as e:
        return _err(str(e))
    print(f"wrote {out}: {models.controller.name} + {models.plant.name}, parameters of {sc.name}; "
          f"drive push_force (N) at the scenario's step {sc.step:g} s (docs/integration.md)")
    if a.kind == "ssp":
        from .export import SSP_VARIANTS
        print(f"  this SSP is {SSP_VARIANTS[not a.libcosim]}")
        if a.fmi == 3:
            from .export import SSP_FMI3
            print(f"  {SSP_FMI3}")
    return EXIT_OK


# ----------------------------------------------------------------------------------------------

class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error (the usage is in --help); subcommands inherit it."""

    def error(self, message: str):
        self.exit(EXIT_ERROR, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _number(ge: float | None = None, gt: float | None = None, integer: bool = False, le: float | None = None):
    """An argparse type: a finite number (an integer with `integer`), >= ge, > gt, <= le; the error
    names the value (argparse adds the option)."""
    what = "an integer" if integer else "a finite number"
    what += f" >= {ge:g}" if ge is not None else f" > {gt:g}" if gt is not None else ""
    what += f" and <= {le:g}" if le is not None else ""

    def convert(text: str):
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}") from None
        if (not math.isfinite(v) or (ge is not None and v < ge) or (gt is not None and not v > gt)
                or (le is not None and v > le)):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
        return v
    return convert


FINITE, NON_NEGATIVE, POSITIVE = _number(), _number(ge=0.0), _number(gt=0.0)


def build_parser() -> argparse.ArgumentParser:
    from .info import CAUSALITIES
    from .scenario import MAX_STEPS
    p = _Parser(prog="anklehip", description="Ankle/hip balance control FMUs: closed-loop "
                                "scenarios, step tests, comparison, plots, sweeps, FMU interfaces.")
    p.add_argument("--fmu-dir", metavar="DIR",
                   help="folder with the .fmu files (default: $ANKLEHIP_FMU_DIR or <repo>/build/fmus)")
    p.add_argument("--fmi", type=int, choices=FMI_COMMANDS_VERSIONS, default=2,
                   help="FMI version of the FMUs: 2 (default) or 3, the FMI 3.0 twins in <fmu dir>/fmi3/ "
                        f"(commands: {', '.join(FMI3_COMMANDS)}; the FMPy engine)")
    p.add_argument("--version", action="version", version=f"anklehip {__version__}",
                   help="print the package's version and exit")
    sub = p.add_subparsers(dest="cmd", required=True, metavar="COMMAND",
                           help="what to do; `anklehip COMMAND --help` lists its options")

    def no_progress(s, what: str):
        s.add_argument("--no-progress", action="store_true",
                       help=f"no progress bars ({what}) on stderr; there are none when stderr is not a terminal")

    s = sub.add_parser("list", help="list the scenarios")
    s.set_defaults(fn=cmd_list)

    s = sub.add_parser("info", help="an FMU's interface: model, platforms, default experiment, log categories, "
                                    "parameters, inputs and outputs with units, start values and ranges")
    s.add_argument("fmu", metavar="FMU",
                   help="a .fmu file or extracted FMU folder, or a model name (e.g. AnkleHipController) looked "
                        "up in --fmu-dir / $ANKLEHIP_FMU_DIR / <repo>/build/fmus")
    s.add_argument("--json", action="store_true",
                   help="print the same content as JSON on stdout instead of the tables")
    s.add_argument("--causality", action="append", choices=CAUSALITIES, metavar="CAUSALITY",
                   help="only the variables of this causality (repeatable; one of " + ", ".join(CAUSALITIES)
                        + "; default: parameters, calculated/structural parameters, inputs, outputs)")
    s.add_argument("--name", action="append", metavar="PATTERN",
                   help="only variables whose name contains PATTERN, or matches it as a glob with * ? [ ] "
                        "(case-insensitive; repeatable: any of them)")
    s.set_defaults(fn=cmd_info)

    def anim_opts(s):
        s.add_argument("--fps", type=POSITIVE, default=20.0,
                       help="animation frames per second (default %(default)g)")
        s.add_argument("--speed", type=POSITIVE, default=1.0,
                       help="simulated seconds per second of animation (default %(default)g)")
        s.add_argument("--anim-start", type=FINITE, metavar="T0",
                       help="animation start time [s] (default: the result's first time)")
        s.add_argument("--anim-stop", type=FINITE, metavar="T1",
                       help="animation stop time [s] (default: the result's last time)")

    s = sub.add_parser("run", help="run a scenario (CSV, summary, optional plots and animation)")
    s.add_argument("scenario", help="scenario name (scenarios/<name>.toml) or path")
    s.add_argument("--out", metavar="DIR", help="output folder (default: results/<scenario>)")
    s.add_argument("--plots", action="store_true", help="write the overview, Fig. 4 and Fig. 5 PNGs")
    s.add_argument("--animate", action="store_true", help="write a stick-figure GIF")
    s.add_argument("--set", action="append", metavar="FMU.NAME=VALUE",
                   help="parameter override, e.g. controller.Ka=30 or plant.h_push=0.3 (repeatable)")
    s.add_argument("--controller-config", metavar="NAME", help=CONTROLLER_CONFIG_HELP)
    s.add_argument("--fault", action="append", metavar="NAME=VALUE",
                   help="inject a fault on top of the scenario's [faults] (repeatable), e.g. zmp_noise=0.002 "
                        "drop_rate=0.1 delay_steps=2 mass_mismatch=-0.2; the keys: docs/scenarios.md")
    s.add_argument("--plant", choices=("sagittal", "3d"),
                   help="the plant model (default: the scenario's plant_model, else sagittal)")
    s.add_argument("--stop-time", type=FINITE, metavar="T",
                   help="stop at this time [s] instead of the scenario's stop_time (no outcome or reference "
                        f"checks): > 0, a whole number of the scenario's steps, at most {MAX_STEPS} steps")
    no_progress(s, "simulated time, figures, GIF frames")
    s.add_argument("--engine", choices=("fmpy", "native"), default="fmpy",
                   help="the closed-loop master (default %(default)s): fmpy, or native (the same loop in C++, "
                        "bit-identical results, several times faster; no sensor faults or transition pushes)")
    s.add_argument("--no-compare", action="store_true", help="skip the comparison with the reference CSV")
    s.add_argument("--record-steptest", metavar="DIR", help="also write the controller's step-test case into DIR")
    anim_opts(s)
    s.set_defaults(fn=cmd_run)

    s = sub.add_parser("plot", help="plot a results CSV")
    s.add_argument("csv", metavar="CSV",
                   help="a result CSV (time in the first column), e.g. results/<scenario>/<scenario>.csv; the "
                        "standard figures need theta_ankle, theta_hip, zmp_x, com_x, else an overview of every column")
    s.add_argument("--out", metavar="DIR", help="output folder (default: the CSV's folder)")
    s.add_argument("--animate", action="store_true",
                   help="also write a stick-figure GIF <name>.gif (body sizes: the plant FMU's defaults)")
    no_progress(s, "figures, GIF frames")
    anim_opts(s)
    s.set_defaults(fn=cmd_plot)

    s = sub.add_parser("compare", help="compare a result CSV with a reference CSV (FMI cross-check band)")
    s.add_argument("result", help="the result CSV to check (time in the first column)")
    s.add_argument("reference", help="the reference CSV, e.g. scenarios/reference/<scenario>.csv")
    s.add_argument("--columns", metavar="A,B,...", help="comma-separated signals (default: all reference columns)")
    s.add_argument("--num", type=_number(ge=2, integer=True),
                   help="band samples (validate_signal num; default: max(1000, reference rows))")
    s.add_argument("--dx", type=_number(ge=1, integer=True), default=20,
                   help="band horizontal half-width in samples (default %(default)s)")
    s.add_argument("--dy", type=NON_NEGATIVE, default=0.1,
                   help="band vertical half-width relative to the signal's range (default %(default)g)")
    s.add_argument("--abs-tol", type=NON_NEGATIVE,
                   help="stricter tube: absolute tolerance, in the signal's unit (default: none)")
    s.add_argument("--rel-tol", type=NON_NEGATIVE,
                   help="stricter tube: tolerance relative to |reference| (default: none)")
    s.add_argument("--band-floor", type=NON_NEGATIVE,
                   help="minimum band half-height, in the signal's unit, for nearly constant signals (default: none)")
    s.add_argument("--t-start", type=FINITE, metavar="T0",
                   help="compare from this time [s] on (default: the reference's start)")
    s.add_argument("--t-stop", type=FINITE, metavar="T1",
                   help="compare up to this time [s] (default: the reference's end)")
    s.add_argument("--allow-partial", action="store_true", help="do not fail when the result covers less time")
    s.add_argument("--plot", metavar="PNG", help="always write a plot of reference, band/tube, result and failing "
                   "samples: of the failed signals, or of every signal when all pass")
    s.add_argument("--json", metavar="FILE", help="write the report as JSON")
    s.add_argument("--failed-only", action="store_true",
                   help="list only the failed signals (default: every compared signal)")
    s.set_defaults(fn=cmd_compare)

    s = sub.add_parser("steptest", help="step the controller FMU on recorded inputs and compare (HIL style)")
    s.add_argument("cases", nargs="+", metavar="CASE",
                   help="case folder(s) with <Model>_in.csv, _ref.csv, _ref.opt")
    s.add_argument("--fmu", help="controller FMU (default: AnkleHipController.fmu in the FMU folder)")
    s.add_argument("--out", metavar="DIR", help="write <DIR>/<case>/AnkleHipController_out.csv (default: no output files)")
    s.add_argument("--realtime", action="store_true", help="pace the steps in wall-clock time (absolute deadlines)")
    s.add_argument("--native", action="store_true",
                   help="use the native anklehip_rt_step (fmu/rt_runner): paced with --realtime, else as fast as possible")
    s.add_argument("--native-args", nargs=argparse.REMAINDER, metavar="ARG",
                   help="extra arguments for anklehip_rt_step: everything after this option (put it last)")
    s.add_argument("--spin-us", type=NON_NEGATIVE, default=0.0, metavar="US",
                   help="with --realtime, Python runner only: busy-wait the last US microseconds before a deadline "
                        "(default %(default)g)")
    s.add_argument("--histogram", metavar="PNG", help="plot execution time and lateness histograms (with several "
                   "cases one file per case: <stem>_<case>.png beside PNG)")
    s.add_argument("--fail-on-miss", action="store_true", help="with --realtime: a case with a deadline miss fails "
                   "(exit 1), for both runners")
    tol = "(default: the case's steptest.toml [compare]{})"
    s.add_argument("--abs-tol", type=NON_NEGATIVE,
                   help="tube: absolute tolerance, in the signal's unit " + tol.format(""))
    s.add_argument("--rel-tol", type=NON_NEGATIVE,
                   help="tube: tolerance relative to |reference| " + tol.format(""))
    s.add_argument("--dx", type=_number(ge=1, integer=True),
                   help="band horizontal half-width in samples " + tol.format(", else 20"))
    s.add_argument("--dy", type=NON_NEGATIVE,
                   help="band vertical half-width relative to the signal's range " + tol.format(", else 0.1"))
    s.add_argument("--no-compare", action="store_true", help="only step the FMU, do not compare with _ref.csv")
    s.add_argument("--plot", action="store_true", help="plot the failed signals (<case>/failed_signals.png)")
    s.add_argument("--failed-only", action="store_true",
                   help="list only the failed signals (default: every compared signal)")
    s.set_defaults(fn=cmd_steptest)

    s = sub.add_parser("record", help="run a scenario and write the controller's step-test case")
    s.add_argument("scenario", help="scenario name (scenarios/<name>.toml) or path")
    s.add_argument("out", metavar="OUT", help="case folder to write")
    s.add_argument("--stop-time", type=FINITE, metavar="T",
                   help="record up to this time [s] instead of the scenario's stop_time: > 0, a whole number of "
                        f"the scenario's steps, at most {MAX_STEPS} steps")
    s.add_argument("--set", action="append", metavar="FMU.NAME=VALUE",
                   help="parameter override, e.g. controller.Ka=30 (repeatable)")
    s.add_argument("--controller-config", metavar="NAME", help=CONTROLLER_CONFIG_HELP)
    no_progress(s, "simulated time")
    s.set_defaults(fn=cmd_record)

    s = sub.add_parser("sweep", help="a sweep file (scenarios/sweeps/), or a scenario's peak push force x controller "
                                     "variants, on Dask -> a table of outcomes")
    s.add_argument("scenario", help="a sweep file (name in scenarios/sweeps/ or path), or a scenario with --forces")
    s.add_argument("--forces", metavar="GRID",
                   help="with a scenario: peak forces [N], start:stop:step (inclusive) or a,b,c")
    s.add_argument("--variant", action="append", metavar="VARIANT",
                   help="repeatable: " + _variants_help() + " (default: one variant, default)")
    s.add_argument("--workers", type=_number(ge=1, integer=True), default=2, metavar="N",
                   help="processes of the local Dask cluster (default %(default)s; not used with --scheduler)")
    s.add_argument("--engine", choices=("fmpy", "native"),
                   help="the closed-loop master of each run (default: native when it is built, else fmpy)")
    s.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on the Dask scheduler at ADDRESS (e.g. tcp://host:8786; default: "
                        "$DASK_SCHEDULER_ADDRESS, else a local cluster of --workers processes)")
    s.add_argument("--restart", action="store_true",
                   help="discard the points an earlier (interrupted) run of this sweep left in --out")
    s.add_argument("--out", metavar="DIR", help="output folder (default: results/sweep_<name>); a rerun into the "
                                                "same folder skips the points already done")
    s.set_defaults(fn=cmd_sweep)

    s = sub.add_parser("robustness", help="each fault (docs/scenarios.md) swept over its levels on a scenario "
                                          "-> the largest level that still completes every push cycle (Dask)")
    s.add_argument("scenario", help="scenario name (scenarios/<name>.toml) or path")
    s.add_argument("--study", action="append", metavar="NAME",
                   help="only this study (a fault key or a study label; repeatable; default: all)")
    s.add_argument("--grid", action="append", metavar="KEY=GRID",
                   help="levels of a fault key instead of its default grid: start:stop:step or a,b,c (repeatable)")
    s.add_argument("--workers", type=_number(ge=1, integer=True), default=2, metavar="N",
                   help="processes of the local Dask cluster (default %(default)s; not used with --scheduler)")
    s.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on the Dask scheduler at ADDRESS (default: $DASK_SCHEDULER_ADDRESS, else a local cluster)")
    s.add_argument("--restart", action="store_true", help="discard the points an earlier run left in --out")
    s.add_argument("--out", metavar="DIR", help="output folder (default: results/robustness_<scenario>); a rerun "
                                                "into the same folder skips the points already done")
    s.set_defaults(fn=cmd_robustness)

    s = sub.add_parser("soak", help="one pair of FMU instances for a long time under seeded random pushes: "
                                    "posture drift, memory growth, solver statistics (docs/reliability.md)")
    s.add_argument("--duration", type=_number(gt=0, le=86400), default=3600.0, metavar="S",
                   help="simulated seconds, > 0 and <= 86400 (default %(default)g)")
    s.add_argument("--seed", type=_number(ge=0, integer=True), default=1,
                   help="seed of the push schedule, an integer >= 0 (default %(default)s)")
    s.add_argument("--out", metavar="DIR", help="output folder (default: results/soak)")
    no_progress(s, "simulated time")
    s.set_defaults(fn=cmd_soak)

    s = sub.add_parser("export", help="the closed loop of a scenario as an SSP file or as one container FMU")
    s.add_argument("kind", choices=("ssp", "container"),
                   help="ssp: an SSP file (System Structure and Parameterization) with both FMUs; "
                        "container: one co-simulation FMU holding both")
    s.add_argument("scenario", help="scenario name or path; its controller configuration and parameter overrides "
                                    "go into the artefact")
    s.add_argument("--out", metavar="FILE", help="output file (default: <scenario>.ssp / <scenario>.fmu)")
    s.add_argument("--plant", choices=("sagittal", "3d"), help="the plant model (default: the scenario's)")
    s.add_argument("--set", action="append", metavar="FMU.NAME=VALUE",
                   help="parameter override written into the artefact, e.g. controller.Ka=30 (repeatable)")
    s.add_argument("--controller-config", metavar="NAME", help=CONTROLLER_CONFIG_HELP)
    s.add_argument("--libcosim", action="store_true",
                   help="ssp: the variant for libcosim: no system-level push input (libcosim rejects its "
                        "connection); drive plant.push_force instead. Default: the variant for fmpy.ssp and SSP "
                        "tools that drive system inputs")
    s.set_defaults(fn=cmd_export)

    s = sub.add_parser("regen-references", help="re-run the scenarios and rewrite scenarios/reference/*.csv")
    s.add_argument("names", nargs="*", metavar="NAME",
                   help="only these scenarios (default: every scenario with a [reference] table, and the "
                        "step-test cases)")
    s.add_argument("--force", action="store_true", help="write even if the expected outcome is not met")
    s.add_argument("--no-steptests", action="store_true",
                   help="do not re-record the step-test cases under tests/steptests/")
    no_progress(s, "simulated time")
    s.set_defaults(fn=cmd_regen)
    return p


def _input_errors() -> tuple[type[Exception], ...]:
    """Our exception classes for wrong input; each message names the file, key, cell or option."""
    from .compare import CompareError
    from .fmu import FMUError
    from .paths import MissingFileError
    from .results import OutputBusyError
    from .scenario import ScenarioError
    from .steptest import StepTestError
    return UsageError, ScenarioError, MissingFileError, FMUError, CompareError, StepTestError, OutputBusyError


FMI_COMMANDS_VERSIONS = (2, 3)
FMI3_COMMANDS = ("run", "export", "info")   # the commands that load the FMI 3.0 twins with --fmi 3


def main(argv=None) -> int:
    p = build_parser()
    a = p.parse_args(argv)
    if a.fmi == 3 and a.cmd not in FMI3_COMMANDS:
        return _err(f"--fmi 3: `{a.cmd}` runs the FMI 2.0 FMUs only (--fmi 3 works with {', '.join(FMI3_COMMANDS)})")
    try:
        return a.fn(a)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return EXIT_OK
    except Exception as e:
        if isinstance(e, _input_errors()):
            return _err(str(e))
        if isinstance(e, OSError):      # a file or folder we cannot read or write
            return _err(f"{e.filename}: {e.strerror}" if e.filename else str(e))
        if os.environ.get("ANKLEHIP_DEBUG"):
            raise
        # a bug: still one line on stderr, not a traceback
        return _err(f"unexpected {type(e).__name__}: {e} (please report it with the command line; "
                    "ANKLEHIP_DEBUG=1 shows the traceback)")


if __name__ == "__main__":
    sys.exit(main())
