"""The commands of the command line, each a thin layer over the Python API (anklehip.run,
anklehip.sweep, anklehip.compare, anklehip.steptest, ...): parse the options into the API's
arguments, call it, print what it returns, choose the exit status (docs/scenarios.md).

Exit status: 0 success, 1 a check failed, 2 the input is wrong (an InputError; nothing written).
"""
from __future__ import annotations

import json
import math
import shutil
import statistics
import sys
from pathlib import Path
from typing import Any

from .parser import EXIT_ERROR, EXIT_FAIL, EXIT_OK

# the API's arguments as the command line calls them, for its error messages
ORIGINS = {"parameters": "--set", "faults": "--fault", "stop_time": "--stop-time",
           "controller_config": "--controller-config", "plant": "--plant"}


def _progress(a) -> bool | None:
    """The API's `progress` for a command's --no-progress: False turns the bars off, None shows
    them when stderr is a terminal."""
    return False if getattr(a, "no_progress", False) else None


def _note(msg: str) -> None:
    print(f"anklehip: note: {msg}", file=sys.stderr)


def _set(items: list[str] | None) -> dict[str, Any]:
    """--set controller.Ka=30 ... -> the API's parameters {"controller.Ka": 30, ...}."""
    from ..files.scenario import parse_set
    c, p = parse_set(items or [])
    return {**{f"controller.{k}": v for k, v in c.items()}, **{f"plant.{k}": v for k, v in p.items()}}


def _rel(p: Path | str) -> str:
    from ..running.run import _rel as rel
    return rel(Path(p))


# ----------------------------------------------------------------------------------------------
# list, where, info

def cmd_list(a) -> int:
    from ..files.paths import scenarios_dir, source_of
    from ..files.scenario import ScenarioError, load_scenario
    folder = scenarios_dir()
    files = sorted(folder.glob("*.toml"))
    width = max(80, min(140, shutil.get_terminal_size((100, 24)).columns))
    rows, rc = [], EXIT_OK
    for f in files:
        try:
            sc = load_scenario(f)
        except ScenarioError as e:
            rows.append((f.stem, "INVALID", "", "", "", "", str(e)))
            rc = EXIT_ERROR
            continue
        e = sc.expect
        exp = "fall" if e.must_fall else ("stand" if e.must_fall is False else "-")
        if e.phases_reached:
            exp += f", phases {''.join(map(str, e.phases_reached))}"
        ref = ("yes" if sc.reference.file.is_file() else "missing") if sc.reference else "-"
        px, py = sc.push.peak(), sc.push_y.peak()
        push = f"{px:+.1f}" + (f", y {py:+.1f}" if py else "") if px or not py else f"y {py:+.1f}"
        desc = sc.description.splitlines()[0] if sc.description else ""
        rows.append((sc.name, sc.plant_model, f"{sc.stop_time:g} s", f"{push} N", exp, ref, desc))
    head = ("scenario", "plant", "stop", "peak push", "expected", "ref", "description")
    w = [max(len(r[i]) for r in rows + [head]) for i in range(6)]
    for r in [head] + rows:
        line = "  ".join(c.ljust(w[i]) for i, c in enumerate(r[:6]))
        room = width - len(line) - 2
        d = r[6] if len(r[6]) <= room else r[6][:max(0, room - 1)] + "…"
        print(f"{line}  {d}".rstrip())
    print(f"{len(files)} scenarios in {folder} ({source_of(folder)}); run one with `anklehip run NAME`"
          if files else f"no scenarios in {folder}")
    return rc


def cmd_where(a) -> int:
    from ..files.paths import locations
    loc = locations(a.fmu_dir)
    w = max(len(k) for k in loc)
    for k, v in loc.items():
        print(f"{k:<{w}}  {v or '(none)'}")
    return EXIT_OK


def cmd_info(a) -> int:
    from ..files.info import format_text, interface, resolve_fmu, select
    info = select(interface(resolve_fmu(a.fmu, a.fmu_dir, a.fmi)), a.causality, a.name)
    print(json.dumps(info, indent=2) if a.json else format_text(info))
    return EXIT_OK


# ----------------------------------------------------------------------------------------------
# run, record, plot

def cmd_run(a) -> int:
    from ..files.output import check_output_folder
    from ..running.run import prepare
    if a.out:      # every argument is checked before anything runs or is written
        check_output_folder(a.out, "--out")
    if a.record_steptest:
        check_output_folder(a.record_steptest, "--record-steptest")
    # the scenario, the overrides and the FMUs: loaded, checked, instantiated and initialized
    prepared = prepare(a.scenario, plant=a.plant, controller=a.controller_model, engine=a.engine,
                       controller_config=a.controller_config,
                       parameters=_set(a.set), faults=_faults(a), stop_time=a.stop_time, fmu_dir=a.fmu_dir,
                       origins=ORIGINS, robot=a.robot, fmi=a.fmi)
    sc = prepared.scenario
    try:
        out = check_output_folder(a.out or Path("results") / sc.name, "--out")
    except Exception:
        prepared.close()
        raise
    anim = {"fps": a.fps, "speed": a.speed, "t_start": a.anim_start, "t_stop": a.anim_stop}
    r = prepared.run(out=out, figures=a.plots, animate=a.animate, animation=anim,
                     record_steptest=a.record_steptest, compare_reference=not a.no_compare,
                     progress=_progress(a))
    for n in r.notes:
        _note(n)
    for w in r.warnings:
        print(f"anklehip: warning: {w}", file=sys.stderr)
    print(r.text())
    if r.outcome in ("error", "interrupted"):
        return EXIT_FAIL
    # a failed expectation, a reference outside its band or a broken reference set-up fails the run
    # (after everything has been written)
    if not r.passed:
        failed = r.failed_checks
        why = f"{len(failed)} check(s) failed: {', '.join(failed)}" if failed else "warnings: " + "; ".join(r.warnings)
        print(f"anklehip: {sc.name}: {why} (exit {EXIT_FAIL})", file=sys.stderr)
        return EXIT_FAIL
    return EXIT_OK


def _faults(a) -> dict[str, Any] | None:
    from ..files.scenario import fault_options
    return fault_options(a.fault) if getattr(a, "fault", None) else None


def cmd_record(a) -> int:
    from ..files.output import check_output_folder, output_lock
    from ..running.run import prepare
    from ..running.steptest import record_case
    if a.out and a.out_pos and Path(a.out) != Path(a.out_pos):
        return _err(f"two case folders given: OUT {a.out_pos} and --out {a.out}")
    given = a.out or a.out_pos
    if given:
        check_output_folder(given, "OUT")
    prepared = prepare(a.scenario, controller_config=a.controller_config, parameters=_set(a.set),
                       stop_time=a.stop_time, fmu_dir=a.fmu_dir, origins=ORIGINS)
    sc = prepared.scenario
    out = check_output_folder(given or Path("results") / "steptests" / sc.name, "OUT")
    try:
        with output_lock(out):
            res = prepared.loop.run(_progress(a))
            if res.outcome in ("error", "interrupted"):
                return _err(f"the run failed: {res.message}")
            files = record_case(res, out, res.controller_overrides, source=sc.name)
    finally:
        prepared.close()
    print(f"recorded {len(res.data) - 1} controller steps of {sc.name} ({res.message or res.outcome}):")
    for f in files.values():
        print(f"  {f}")
    return EXIT_OK


def cmd_plot(a) -> int:
    from ..analysis import plots
    from ..analysis.compare import read_result_csv
    from ..running.run import make_figures
    data = read_result_csv(a.csv, "result")
    csv = Path(a.csv)
    name = csv.name.removesuffix(".csv").removesuffix(".incomplete")
    out = Path(a.out) if a.out else csv.parent
    params = header = None
    frontal = "phase_y" in data.dtype.names     # the 3D controller's result: its plant is the 3D one
    if a.animate or frontal:
        try:
            from ..analysis.bounds import plant_header
            from ..files.paths import PLANT_FMU, PLANT_FMUS, find_fmu
            from ..running.fmu import FMUInfo
            info = FMUInfo.load(find_fmu(PLANT_FMUS["3d"] if frontal else PLANT_FMU, a.fmu_dir))
            params, header = info.start_values(), plant_header(info.unzipdir)   # the header: the stance width
        except Exception:
            params = header = None
    if all(c in data.dtype.names for c in ("theta_ankle", "theta_hip", "zmp_x", "com_x")):
        try:
            files = make_figures(name, data, out, animate=a.animate, params=params, header=header,
                                 anim_args=dict(fps=a.fps, speed=a.speed, t_start=a.anim_start, t_stop=a.anim_stop),
                                 progress=_progress(a))
        except ValueError as e:       # e.g. an animation window outside the result
            return _err(f"{csv}: {e}")
    else:
        files = [plots.overview(data, out / f"{name}_overview.png", title=name)]
    for f in files:
        print(f)
    return EXIT_OK


# ----------------------------------------------------------------------------------------------
# compare, steptest

def cmd_compare(a) -> int:
    from ..analysis.compare import compare, plot_comparison
    from ..files.output import atomic_write_text
    cols = [c.strip() for c in a.columns.split(",")] if a.columns else None
    rep = compare(a.result, a.reference, columns=cols, num=a.num, dx=a.dx, dy=a.dy, abs_tol=a.abs_tol,
                  rel_tol=a.rel_tol, band_floor=a.band_floor, t_start=a.t_start, t_stop=a.t_stop,
                  require_coverage=not a.allow_partial, progress=_progress(a))
    print(rep.text(verbose=not a.failed_only))
    if a.plot:   # a passing comparison's plot is evidence too
        p = plot_comparison(rep, a.plot)
        print(f"plot of {'the failed signals' if rep.failed else 'all compared signals (all passed)'}: {p}")
    if a.json:
        atomic_write_text(Path(a.json), json.dumps(rep.as_dict(), indent=2, default=float) + "\n")
    return EXIT_OK if rep.passed else EXIT_FAIL


def cmd_steptest(a) -> int:
    from ..errors import InputError
    from ..files.paths import find_steptest_case
    from ..running.steptest import failures, histogram_path, rt_histogram, steptest, summary
    if a.fail_on_miss and not a.realtime:
        return _err("--fail-on-miss needs --realtime (only a paced run has deadlines)")
    if a.histogram and not (a.realtime or a.native):
        return _err("--histogram needs --realtime or --native (a plain Python run is not timed)")
    if a.spin_us and (a.native or not a.realtime):
        return _err("--spin-us applies to the Python runner with --realtime (the native runner sleeps to "
                    "absolute deadlines with clock_nanosleep and does not spin)")
    cases = []
    for c in a.cases:
        try:
            cases.append(find_steptest_case(c))
        except InputError:
            cases.append(Path(c))      # reported below as a case that could not run
    names = [c.name for c in cases]
    out_root = Path(a.out) if a.out else (Path("results") / "steptest" if a.plot else None)
    if (out_root or a.histogram) and len(set(names)) < len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        return _err(f"two cases are named {', '.join(dup)}: their files under --out/--histogram would collide")
    results = []
    for case in cases:
        out = out_root / case.name if out_root else None
        try:
            r = steptest(case, fmu=a.fmu, out=out, realtime=a.realtime, native=a.native, native_args=a.native_args,
                         spin_us=a.spin_us, abs_tol=a.abs_tol, rel_tol=a.rel_tol, dx=a.dx, dy=a.dy,
                         compare=not a.no_compare, plot=a.plot, fmu_dir=a.fmu_dir)
        except InputError as e:
            print(f"anklehip: error: {case}: {e}", file=sys.stderr)
            results.append((case, None))
            continue
        results.append((case, r))
        steps = f"{len(r.data) - 1} steps" if r.data is not None else "no outputs"
        print(f"step test {case}: {steps}" + (f", outputs {r.out_csv}" if r.out_csv else ""))
        if r.report is not None:
            print(r.report.text(verbose=not a.failed_only))
        if r.plot:
            print(f"plot of the failed signals: {r.plot}")
        if r.rt is not None:
            print(r.rt.text())
            if a.histogram:
                dest = histogram_path(Path(a.histogram), case, len(cases))
                print(f"histogram: {rt_histogram(r.rt, dest, case.name)}")
            if out:
                print(f"timing report: {out / 'realtime.json'}")
        why = failures(r, a.fail_on_miss)
        print(f"{case.name}: {'FAIL: ' + '; '.join(why) if why else 'PASS'}")
    text, rc = summary(results, a.fail_on_miss)
    print(text)
    return rc


# ----------------------------------------------------------------------------------------------
# sweep, robustness, soak

def cmd_sweep(a) -> int:
    from ..running.sweep import parse_grid, parse_variant, sweep
    from ..files.output import check_output_folder
    if a.forces is None and a.variant:
        return _err("--variant goes with --forces (a sweep file names its own variants)")
    if a.out:
        check_output_folder(a.out, "--out")
    if a.forces is not None:
        from ..files.scenario import load_scenario
        from ..files.paths import find_scenario
        name = load_scenario(find_scenario(a.scenario)).name
    else:
        from ..files.paths import find_sweep_file
        from ..running.sweepfile import load_sweep_file
        name = load_sweep_file(find_sweep_file(a.scenario)).name
    out = Path(a.out) if a.out else Path("results") / f"sweep_{name}"
    try:
        forces = parse_grid(a.forces, "--forces") if a.forces is not None else None
    except ValueError as e:
        return _err(str(e))
    variants = [parse_variant(v) for v in a.variant] if a.variant else None
    res = sweep(a.scenario, forces=forces, variants=variants, workers=a.workers, engine=a.engine,
                scheduler=a.scheduler, worker_timeout=a.worker_timeout, out=out, restart=a.restart, fmu_dir=a.fmu_dir,
                origins={"variants": "--variant", "forces": "--forces", "out": "--out"})
    if not res.rows:
        print("anklehip sweep: interrupted before any point finished; nothing written", file=sys.stderr)
        return 130
    if res.sweep_file is not None:
        print(f"{res.name}: {len(res.rows)} of {res.total} points ({res.resumed} from an earlier run), "
              f"{res.wall:.1f} s")
        for v in res.sweep_file.variants:
            rr = [r for r in res.rows if r.get("variant") == v.name]
            stood = [r for r in rr if r["outcome"] == "completed"]
            rec = [r["time_to_recover"] for r in stood if math.isfinite(r.get("time_to_recover", math.nan))]
            print(f"  {v.name:<16} {len(stood)} of {len(rr)} stood" + (
                f", {len(rec)} of them erect again (median recovery {statistics.median(rec):.2f} s)" if rec else ""))
        _print_boundaries(res.sweep_file, res.rows, res.plant_parameters)
        figs = [f for k, f in res.files.items() if k.startswith("figure") or k == "capability"]
        print(f"table {res.files['table']}\n      {res.files['parquet']}" + "".join(f"\nfigure {f}" for f in figs))
    else:
        for v in res.variants():
            rr = [r for r in res.rows if r.get("variant") == v and r["outcome"] != "error"]
            best = res.largest_survived(v)
            print(f"{v:<16} " + "  ".join(f"{r['peak_force']:g}N:{'FELL' if r['outcome'] == 'fell' else 'ok/' + str(r['max_phase'])}"
                                           for r in rr) + (f"   largest survived {best:g} N" if best is not None else ""))
        print(f"table {res.files['table']}\n      {res.files['parquet']}"
              + (f"\nplot  {res.files['figure']}" if "figure" in res.files else ""))
        print(f"{len(res.rows)} of {res.total} points ({res.resumed} from an earlier run), {res.wall:.1f} s",
              file=sys.stderr)
    return _points_end(res, res.files["journal"], "sweep")


def _print_boundaries(sf, rows, plant_params: dict | None = None) -> None:
    """A force grid over a push's duration or height: per variant and per x, the largest force that
    stood with every smaller one standing too (the capability map's boundary; >= when all stood).
    A force grid over push.angle: the same per direction, a block per duration or height, with the
    bounds in those directions (the polar map's)."""
    from ..analysis.capability import (bound_lines, capability_key, panel_rows, polar_bounds, polar_panels, stance_of,
                                       survive_boundary)
    kx = capability_key(sf)
    if kx is not None:
        print(f"largest push.force that stood, every smaller one standing too [N], by {kx}:")
        for v in sf.variants:
            xs, fs, top = survive_boundary(rows, v.name, kx)
            print(f"  {v.name:<16} " + "  ".join(f"{x:g}: {'>=' if t else ''}{f:g}" for x, f, t in zip(xs, fs, top)))
        for line in bound_lines(sf, plant_params or {}):     # the bounds at the same x (docs/capability.md)
            print(line)
        return
    stance = stance_of(plant_params or {})
    for panel in polar_panels(sf) or []:
        key, value = panel
        print("largest push.force that stood, every smaller one standing too [N], by push.angle [deg]"
              + (f", {key} = {value:g}:" if key else ":"))
        for v in sf.variants:
            xs, fs, top = survive_boundary(panel_rows(rows, panel), v.name, "push.angle")
            print(f"  {v.name:<16} " + "  ".join(f"{x:g}: {'>=' if t else ''}{f:g}" for x, f, t in zip(xs, fs, top)))
        if stance is not None:
            angles = sorted(set(sf.axes["push.angle"]))
            b = polar_bounds(stance, angles, panel, sf.push)
            for name, label in (("static", "static tipping"), ("lip", "LIP bound"), ("sustained", "sustained limit")):
                print(f"  {label:<16} " + "  ".join(f"{x:g}: {f:.1f}" for x, f in zip(angles, b[name])))


def _points_end(res, journal: Path, command: str) -> int:
    """The end of a run of points: each failed point's error, the interruption message, and the
    exit status (130 interrupted, 1 a point failed, else 0)."""
    for r in res.rows:
        if r.get("outcome") == "error":
            print(f"anklehip {command}: point {r['id']}: {r.get('error', '?')}", file=sys.stderr)
    if res.interrupted:
        print(f"anklehip {command}: interrupted: {len(res.rows)} of {res.total} points done, kept in "
              f"{journal}; run the same command again to finish the rest", file=sys.stderr)
        return 130
    return EXIT_FAIL if any(r.get("outcome") == "error" for r in res.rows) else EXIT_OK


def cmd_robustness(a) -> int:
    from ..files.output import atomic_write_text, check_output_folder, output_lock
    from ..files.paths import find_scenario
    from ..files.scenario import faults_from, load_scenario
    from ..running.faults import KEY_BY_NAME
    from ..running.master import Models
    from ..running.robustness import STUDIES, run_studies, study_by_label, summarize, table_markdown
    from ..running.sweep import parse_grid, sweep_key, write_points_table
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
    except ValueError as e:
        return _err(str(e))
    out = check_output_folder(a.out if a.out else Path("results") / f"robustness_{sc.name}", "--out")
    models = Models.for_scenario(sc, a.fmu_dir)
    with output_lock(out):
        res = run_studies(str(path), plan, a.fmu_dir, workers=a.workers, scheduler=a.scheduler,
                          journal=out / "points.jsonl", key=sweep_key(path, models), restart=a.restart,
                          worker_timeout=a.worker_timeout)
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
    from ..files.output import atomic_write_csv, atomic_write_text, check_output_folder
    from ..running.soak import soak
    out = check_output_folder(a.out if a.out else Path("results") / "soak", "--out")
    rep = soak(a.duration, a.seed, a.fmu_dir, progress=not a.no_progress)
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


# ----------------------------------------------------------------------------------------------
# export, regen-references

def cmd_export(a) -> int:
    from ..files.export import write_container_fmu, write_ssp
    from ..files.output import check_output_folder
    from ..running.run import resolve
    sc, models = resolve(a.scenario, plant=a.plant, controller_config=a.controller_config, parameters=_set(a.set),
                         fmu_dir=a.fmu_dir, origins=ORIGINS, fmi=a.fmi)
    suffix = ".ssp" if a.kind == "ssp" else ".fmu"
    dest = Path(a.out) if a.out else Path("results") / sc.name / f"{sc.name}{suffix}"
    check_output_folder(dest.parent, "--out")
    if a.kind == "ssp":
        out = write_ssp(dest, sc, models, system_input=not a.libcosim)
    else:
        out = write_container_fmu(dest, sc, models)
    from ..files.export import system_inputs
    pushes = " and ".join(v.name for v in system_inputs(models))
    print(f"wrote {out}: {models.controller.name} + {models.plant.name}, parameters of {sc.name}; "
          f"drive {pushes} (N) at the scenario's step {sc.step:g} s (docs/integration.md)")
    if a.kind == "ssp":
        from ..files.export import SSP_FMI3, SSP_VARIANTS
        print(f"  this SSP is {SSP_VARIANTS[not a.libcosim]}")
        if a.fmi == 3:
            print(f"  {SSP_FMI3}")
    return EXIT_OK


def cmd_regen(a) -> int:
    from ..running.references import regenerate
    return regenerate(a.names, out=a.out, check=a.check, force=a.force, steptests=not a.no_steptests,
                      fmu_dir=a.fmu_dir, progress=_progress(a))


def _err(msg: str) -> int:
    print(f"anklehip: error: {msg}", file=sys.stderr)
    return EXIT_ERROR
