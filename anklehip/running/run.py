"""A scenario run as one call: ``anklehip.run(...)``. The closed loop, the per-push summary, the
expected-outcome checks, the comparison with the scenario's reference and, with ``out``, its files:
what ``anklehip run`` does (docs/python-api.md, docs/scenarios.md).

Everything that can be wrong with the input (the scenario, the overrides, the FMUs, parameters the
FMU refuses at initialization) raises an InputError before anything is written; a run that then
falls, fails or is interrupted returns a result that says so (and, with ``out``, writes an
``.incomplete.csv`` that never looks like a finished result).
"""
from __future__ import annotations

import copy
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from ..analysis.compare import CompareReport
from ..analysis.summary import Check, PushSummary
from ..errors import InputError
from ..files.scenario import PushProfile, Scenario
from .faults import Faults
from .master import ClosedLoop, Models, RunResult

DEFAULT_REF_COLUMNS = ["theta_ankle", "theta_hip", "theta_ankle_ref", "theta_hip_ref", "zmp_x", "com_x",
                       "fz", "push_force", "phase"]


@dataclass
class ScenarioResult:
    """The result of anklehip.run: the signals, what the run shows, and the files it wrote.

    ``signals`` is a NumPy structured array, one row per communication step: ``time`` first, then
    every output of both FMUs (controller outputs whose name a plant output has are prefixed
    ``controller.``) and the push force; ``units`` maps a column to its unit.
    """
    scenario: Scenario                     # the scenario as run (overrides applied)
    signals: np.ndarray
    outcome: str                           # completed | fell | error | interrupted
    message: str
    pushes: list[PushSummary]              # one per push of the scenario
    checks: list[Check]                    # the scenario's [expect] (none for a shortened run)
    comparison: CompareReport | None       # against the scenario's reference (None: not compared)
    files: dict[str, Path] = field(default_factory=dict)   # what was written (with `out`)
    warnings: list[str] = field(default_factory=list)      # a broken reference, failed figures, ...
    notes: list[str] = field(default_factory=list)         # why the run was not compared, ...
    run: RunResult | None = field(default=None, repr=False)  # the master's record: parameters, timing

    @property
    def units(self) -> dict[str, str]:
        return self.run.column_units if self.run else {}

    @property
    def failed_checks(self) -> list[str]:
        """The names of what failed: expectations and the reference comparison."""
        failed = [c.name for c in self.checks if not c.ok]
        if self.comparison is not None and not self.comparison.passed:
            failed.append("reference comparison")
        return failed

    @property
    def passed(self) -> bool:
        """The run ran to its end or to an expected fall, every check passed, the reference
        comparison (if any) passed and nothing went wrong on the way (no warnings)."""
        return self.outcome not in ("error", "interrupted") and not self.failed_checks and not self.warnings

    def summary(self) -> dict[str, Any]:
        """The content of <name>.summary.json."""
        from ..analysis.summary import summary_dict
        s = summary_dict(self.scenario, self.run, self.pushes, self.checks, {k: str(v) for k, v in self.files.items()},
                         self.comparison.as_dict() if self.comparison is not None else None)
        if self.warnings:
            s["warnings"] = list(self.warnings)
        if self.run is not None and self.run.stop_time != self.scenario.stop_time:
            # a shortened run is complete for what was asked, but it is not the scenario's result
            s["shortened_from_stop_time"] = self.scenario.stop_time
        return s

    def text(self) -> str:
        """The summary as `anklehip run` prints it: a line per push, per check, per file."""
        from ..analysis.summary import format_summary
        return format_summary(self.summary(), self.pushes)

    def __str__(self) -> str:
        return self.text()


# ----------------------------------------------------------------------------------------------
# the input: scenario, overrides, FMUs

def scenario_of(scenario: str | os.PathLike | Scenario) -> Scenario:
    """A Scenario from a name (scenarios/<name>.toml), a path or a Scenario (copied, so that a
    run never changes the caller's object)."""
    from ..files.paths import find_scenario
    from ..files.scenario import load_scenario
    if isinstance(scenario, Scenario):
        return copy.deepcopy(scenario)
    if not isinstance(scenario, (str, os.PathLike)):
        raise InputError(f"scenario: a name, a path or an anklehip.Scenario, got {type(scenario).__name__}")
    return load_scenario(find_scenario(os.fspath(scenario)))


def split_parameters(parameters: Mapping[str, Any] | None, origin: str = "parameters"
                     ) -> tuple[dict[str, Any], dict[str, Any]]:
    """{"controller.Ka": 30, "plant.h_push": 0.3} -> (controller, plant) overrides."""
    ctrl: dict[str, Any] = {}
    plant: dict[str, Any] = {}
    for key, val in (parameters or {}).items():
        fmu, dot, name = str(key).partition(".")
        if not dot or fmu not in ("controller", "plant") or not name:
            raise InputError(f"{origin}: key {key!r}: expected 'controller.NAME' or 'plant.NAME'")
        (ctrl if fmu == "controller" else plant)[name] = val
    return ctrl, plant


def _where(sc: Scenario) -> str:
    return _rel(sc.path) if sc.path else sc.name


def _rel(p: Path) -> str:
    try:
        return str(Path(p).resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(p)


def resolve(scenario: str | os.PathLike | Scenario, *, plant: str | None = None, controller: str | None = None,
            controller_config: str | None = None, parameters: Mapping[str, Any] | None = None,
            faults: Mapping[str, Any] | Faults | None = None, stop_time: float | None = None,
            fmu_dir: str | os.PathLike | None = None, models: Models | None = None,
            origins: Mapping[str, str] | None = None, robot: str | os.PathLike | None = None, fmi: int = 2
            ) -> tuple[Scenario, Models]:
    """The scenario with the overrides applied and its FMUs, checked against each other (names,
    types and ranges of every parameter, the configuration, the stop time) without running
    anything; an InputError naming the file, key or variable otherwise. `origins` names the
    arguments as the caller calls them in messages, e.g. {"parameters": "--set"} for the CLI.
    `robot`: run on this robot (a robot file or a name in robots/, docs/your-robot.md). `fmi`: 3 loads
    the FMI 3.0 twins (the FMPy engine only; docs/fmu.md section 8)."""
    from ..files.scenario import ScenarioError, faults_from, time_grid_problem
    from .master import check_overrides
    name = {"parameters": "parameters", "faults": "faults", "stop_time": "stop_time",
            "controller_config": "controller_config", "plant": "plant", **(origins or {})}
    sc = scenario_of(scenario)
    c_set, p_set = split_parameters(parameters, name["parameters"])
    if stop_time is not None:
        problem = time_grid_problem(stop_time, sc.step)
        if problem:
            raise InputError(f"{name['stop_time']} {stop_time:g} {problem} (scenario {_where(sc)}, step {sc.step:g} s)")
    if plant is not None:
        sc.plant_model = plant
    if controller is not None:
        sc.controller_model = controller
    if sc.controller_model == "3d" and sc.plant_model != "3d":
        raise ScenarioError(f"{_where(sc)}: the 3D controller needs the 3D plant ({name['plant']} 3d)")
    if sc.push_y.peak() != 0 and sc.plant_model == "sagittal":
        raise ScenarioError(f"{_where(sc)}: push_y: a sideways push needs the 3D plant ({name['plant']} 3d)")
    models = models or Models.load(fmu_dir, plant_model=sc.plant_model, fmi=fmi, controller_model=sc.controller_model)
    if controller_config is not None:
        sc.controller_config = controller_config
        models.controller.configuration(sc.controller_config, name["controller_config"])
    else:
        models.controller.configuration(sc.controller_config, f"{_where(sc)}: controller_config")
    # names, types and ranges (the modelDescription's min/max) of the scenario's tables and of each
    # override, before anything runs
    check_overrides(models, sc.controller, sc.plant, _where(sc))
    for fmu, info, over in (("controller", models.controller, c_set), ("plant", models.plant, p_set)):
        for k, v in over.items():
            info.check_overrides({k: v}, f"{name['parameters']} {fmu}.{k}, scenario {_where(sc)}")
    if robot is not None or sc.robot or sc.push_units != "SI":    # docs/your-robot.md
        from ..robot.experiment import apply_robot
        sc = apply_robot(sc, models, None if robot is None else str(robot))
    sc.controller.update(c_set)
    sc.plant.update(p_set)
    if isinstance(faults, Faults):
        sc.faults = faults
    elif faults:
        sc.faults = faults_from(dict(faults), sc.faults, name["faults"])
    return sc, models


# ----------------------------------------------------------------------------------------------
# the run

class PreparedRun:
    """A scenario run whose input has been checked and whose FMUs are instantiated and initialized
    (ClosedLoop): nothing can be wrong with the input any more. `run()` runs it once and, with
    `out`, writes its files (the CLI prepares first, so that a bad input never touches --out)."""

    def __init__(self, scenario: Scenario, models: Models, *, engine: str = "fmpy",
                 push: PushProfile | None = None, stop_time: float | None = None, changed: bool = False,
                 logger: Callable | None = None):
        self.scenario, self.models, self.stop_time = scenario, models, stop_time
        self.changed = changed          # overrides that make the scenario's reference not apply
        self.loop = ClosedLoop(scenario, models, push=push, stop_time=stop_time, engine=engine, logger=logger)

    def close(self) -> None:
        self.loop.close()

    def run(self, *, out: str | os.PathLike | None = None, figures: bool = False, animate: bool = False,
            animation: Mapping[str, Any] | None = None, record_steptest: str | os.PathLike | None = None,
            compare_reference: bool = True, progress: bool | None = False) -> ScenarioResult:
        from ..files.output import check_output_folder, output_lock
        try:
            if record_steptest is not None:
                check_output_folder(record_steptest, "record_steptest")
            if out is None:
                if figures or animate:
                    raise InputError("figures and animations are files: give out=<folder>")
                res = self.loop.run(progress)
                result = self._result(res, compare_reference, None)
                self._record(result, res, record_steptest)
                return result
            out = check_output_folder(out, "out")
            with output_lock(out):     # a second run into the same folder fails here, at once
                return self._write(Path(out), figures, animate, animation, record_steptest, compare_reference,
                                   progress)
        finally:
            self.close()

    def _result(self, res: RunResult, compare_reference: bool, out: Path | None) -> ScenarioResult:
        from ..analysis.summary import check_expect, summarize_pushes
        sc = self.scenario
        pushes = summarize_pushes(res, sc.push, sc.expect.erect_tol)
        checks = check_expect(res, sc.expect) if self.stop_time is None else []
        result = ScenarioResult(scenario=sc, signals=res.data, outcome=res.outcome,
                                message=res.message or res.outcome, pushes=pushes, checks=checks, comparison=None,
                                run=res)
        if self.stop_time is not None:
            result.notes.append(f"stop time {self.stop_time:g} s replaces the scenario's {sc.stop_time:g} s; "
                                "its expectations and reference were not checked")
        if self.changed and sc.reference is not None and compare_reference:
            result.notes.append("the overrides (parameters, controller configuration, faults, push, robot, plant) "
                                f"change the run, so it is not compared with {_rel(sc.reference.file)}")
        if compare_reference and self.stop_time is None and not self.changed \
                and res.outcome not in ("error", "interrupted"):
            try:
                result.comparison = compare_with_reference(sc, res)
            except Exception as e:   # a broken reference must not lose the run
                result.warnings.append(f"reference comparison failed: {e}")
            if result.comparison is None and sc.reference is not None and not sc.reference.file.is_file():
                result.warnings.append(f"{_where(sc)}: reference.file: {_rel(sc.reference.file)} does not exist, "
                                       f"the run was not compared (create it with `anklehip regen-references "
                                       f"{sc.name}`)")
            if out is not None and result.comparison is not None and not result.comparison.passed:
                from ..analysis.compare import plot_failed
                p = plot_failed(result.comparison, out / f"{sc.name}_reference_failed.png")
                if p:
                    result.files["reference_failures_plot"] = p
        return result

    def _write(self, out: Path, figures: bool, animate: bool, animation, record_steptest, compare_reference: bool,
               progress) -> ScenarioResult:
        from ..files.output import atomic_write_csv, clear_previous, result_paths, write_summary_json
        sc = self.scenario
        paths = result_paths(out, sc.name)
        res = self.loop.run(progress)
        csv = paths["csv"] if res.complete else paths["incomplete_csv"]
        atomic_write_csv(csv, res.data)
        # only now that this run's data are in place: the previous run's files go (its complete CSV
        # must not sit next to this run's incomplete one), the new summary is written last
        clear_previous(out, sc.name, keep=(csv,))
        result = self._result(res, compare_reference, out)
        result.files = {"csv": csv, "summary": paths["summary"], **result.files}
        # figures and the step-test case must not lose the summary of a run that has been computed
        if figures or animate:
            try:
                from ..analysis.bounds import plant_header
                for p in make_figures(sc.name, res.data, out, res, animate=animate, anim_args=dict(animation or {}),
                                      figures=figures, progress=progress, header=plant_header(self.models.plant.unzipdir)):
                    result.files[p.stem] = p
            except Exception as e:
                result.warnings.append(f"figures failed: {type(e).__name__}: {e}")
        self._record(result, res, record_steptest)
        write_summary_json(paths["summary"], result.summary())
        return result

    def _record(self, result: ScenarioResult, res: RunResult, folder) -> None:
        """The controller's step-test case of the run into `folder` (a failure is a warning: the
        run's result is not lost)."""
        if folder is None:
            return
        from .steptest import record_case
        try:
            record_case(res, Path(folder), res.controller_overrides, source=self.scenario.name)
            result.files["steptest_case"] = Path(folder)
        except Exception as e:
            result.warnings.append(f"record_steptest {folder}: {type(e).__name__}: {e}")


def prepare(scenario: str | os.PathLike | Scenario, *, plant: str | None = None, controller: str | None = None,
            engine: str = "fmpy",
            controller_config: str | None = None, parameters: Mapping[str, Any] | None = None,
            faults: Mapping[str, Any] | Faults | None = None, push: PushProfile | None = None,
            stop_time: float | None = None, fmu_dir: str | os.PathLike | None = None,
            models: Models | None = None, logger: Callable | None = None,
            origins: Mapping[str, str] | None = None, robot: str | os.PathLike | None = None,
            fmi: int = 2) -> PreparedRun:
    """resolve() the input, then instantiate and initialize both FMUs (ClosedLoop): a PreparedRun,
    or an InputError naming what is wrong (also the FMU's own reason when it refuses its
    parameters at initialization)."""
    own = scenario_of(scenario)
    sc, models = resolve(scenario, plant=plant, controller=controller, controller_config=controller_config,
                         parameters=parameters,
                         faults=faults, stop_time=stop_time, fmu_dir=fmu_dir, models=models, origins=origins,
                         robot=robot, fmi=fmi)
    # the scenario's reference is of its own plant, robot and parameters
    changed = (bool(parameters) or controller_config is not None or bool(faults) or push is not None
               or robot is not None or sc.plant_model != own.plant_model
               or sc.controller_model != own.controller_model)
    return PreparedRun(sc, models, engine=engine, push=push, stop_time=stop_time, changed=changed, logger=logger)


def run(scenario: str | os.PathLike | Scenario, *, plant: str | None = None, controller: str | None = None,
        engine: str = "fmpy",
        controller_config: str | None = None, parameters: Mapping[str, Any] | None = None,
        faults: Mapping[str, Any] | Faults | None = None, push: PushProfile | None = None,
        stop_time: float | None = None, compare_reference: bool = True,
        out: str | os.PathLike | None = None, figures: bool = False, animate: bool = False,
        animation: Mapping[str, Any] | None = None, record_steptest: str | os.PathLike | None = None,
        fmu_dir: str | os.PathLike | None = None, models: Models | None = None,
        logger: Callable | None = None, progress: bool | None = False,
        robot: str | os.PathLike | None = None, fmi: int = 2) -> ScenarioResult:
    """Run a scenario in closed loop and check it.

    scenario           a name (``"paper_five_pushes"``), a path to a scenario TOML, or an
                       anklehip.Scenario (e.g. from load_scenario, changed in memory)
    plant              ``"sagittal"`` or ``"3d"`` (default: the scenario's plant_model)
    controller         ``"sagittal"`` or ``"3d"``: the paper's controller or the one with the frontal
                       plane (default: the scenario's controller_model; "3d" needs the 3D plant)
    engine             ``"fmpy"`` (default) or ``"native"`` (the same loop in C++, bit-identical)
    controller_config  a named controller configuration, e.g. ``"paper"``
    parameters         overrides, e.g. ``{"controller.Ka": 30, "plant.h_push": 0.3}``
    faults             fault options on top of the scenario's [faults], e.g. ``{"zmp_noise": 0.002}``
    push               a PushProfile instead of the scenario's push (e.g. ``sc.push.scaled_to(8.0)``)
    stop_time          stop earlier [s] (then the expectations and reference are not checked)
    compare_reference  compare with the scenario's reference CSV (when no override changes the run)
    out                a folder: write <name>.csv (.incomplete.csv when the run did not end),
                       <name>.summary.json and, on request, figures, the GIF, a step-test case
    fmu_dir, models    where the FMUs are (default: docs/python-api.md), or FMUs already loaded
    robot              run on this robot: a robot file or a name in robots/ (docs/your-robot.md)
    fmi                3: the FMI 3.0 twins of the FMUs (engine ``"fmpy"``; docs/fmu.md section 8)
    logger             the FMUs' log messages (FMI logger signature); default: printed
    progress           a progress bar on stderr (None: on a terminal)

    Raises an InputError (before anything is written) for a wrong input; a fall, an error during
    the run or Ctrl-C is an `outcome` of the result.
    """
    prepared = prepare(scenario, plant=plant, controller=controller, engine=engine, controller_config=controller_config,
                       parameters=parameters, faults=faults, push=push, stop_time=stop_time, fmu_dir=fmu_dir,
                       models=models, logger=logger, robot=robot, fmi=fmi)
    return prepared.run(out=out, figures=figures, animate=animate, animation=animation,
                        record_steptest=record_steptest, compare_reference=compare_reference, progress=progress)


# ----------------------------------------------------------------------------------------------
# the reference and the figures of a run

def decimate(data: np.ndarray, step: float, interval: float) -> np.ndarray:
    """Every interval-th row (and the last), as the references store a run."""
    k = max(1, int(round(interval / step)))
    idx = np.arange(0, len(data), k)
    if idx[-1] != len(data) - 1:
        idx = np.append(idx, len(data) - 1)
    return data[idx]


def reference_columns(sc: Scenario, data: np.ndarray) -> list[str]:
    cols = sc.reference.columns if sc.reference and sc.reference.columns else DEFAULT_REF_COLUMNS
    return [c for c in cols if c in data.dtype.names]


def compare_with_reference(sc: Scenario, res: RunResult) -> CompareReport | None:
    """Compare a run with the scenario's reference; None when it has none or the file is missing."""
    from ..analysis.compare import compare, read_result_csv
    from ..files.scenario import ScenarioError
    r = sc.reference
    if r is None or not r.file.is_file():
        return None
    if r.signals:
        cols = r.columns or list(read_result_csv(r.file, "reference").dtype.names[1:])
        for name in r.signals:
            if name not in cols:
                raise ScenarioError(f"{_where(sc)}: reference.signals.{name}: "
                                    f"not a compared signal (compared: {', '.join(cols)})")
    # the reference holds every interval-th row of a run: compare the same rows of this run (a
    # 1-2 ms transient between two reference samples is not a deviation from the reference)
    return compare(decimate(res.data, res.step, r.interval), r.file, columns=r.columns, num=r.num, dx=r.dx,
                   dy=r.dy, abs_tol=r.abs_tol, rel_tol=r.rel_tol, band_floor=r.band_floor, tolerances=r.signals,
                   result_label=f"{sc.name} (this run)", reference_label=_rel(r.file))


def geometry_for(res: RunResult | None = None, params: dict | None = None):
    from ..analysis.plots import Geometry
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


def make_figures(sc_name: str, data: np.ndarray, out: Path, res: RunResult | None = None, animate: bool = False,
                 anim_args: dict | None = None, figures: bool = True, params: dict | None = None,
                 progress: bool | None = None, header: dict | None = None) -> list[Path]:
    """The standard figures of a result (and the 3D plant's frontal one, and for the 3D controller
    the frontal Fig. 5), the animation if asked; geometry from the run's plant parameters, or
    `params` for a CSV read back; the support polygon's edges from those and the plant's robot
    header (`header`: anklehip.analysis.bounds.plant_header). `progress` as in
    master.simulate: on a terminal a bar of the figures, then one of the GIF's frames, and a line per
    file written; nothing with False (`--no-progress`) or when stderr is not a terminal."""
    import time

    from ..analysis import frontal_cycle, plots
    from ..analysis.bounds import bounds_parameters
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
        if frontal_cycle.is_frontal(data):                     # the 3D controller's results
            edge = frontal_cycle.support_edge(bounds_parameters((res.plant_parameters if res else params) or {}, header or {}))
            jobs.append((f"{sc_name}_fig5_frontal.png",
                         lambda p: frontal_cycle.frontal_cycle(
                             data, p, edge=edge, title=f"{sc_name}: first side push (frontal plane, cf. paper Fig. 5)")))
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

