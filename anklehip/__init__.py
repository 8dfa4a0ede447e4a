"""Ankle and hip balance strategies with smooth transitions (Nenchev & Nishio, ICRA 2010) as FMI 2.0
co-simulation FMUs, and the Python API to run, sweep, compare and step-test them.

    import anklehip
    r = anklehip.run("paper_five_pushes")          # closed loop: signals, pushes, checks, comparison
    r.passed, r.signals["theta_hip"], r.pushes[0].peak_zmp
    anklehip.figures.fig4(r)                       # a Matplotlib figure
    s = anklehip.sweep("hip_saves_push", forces="7:12:0.5",
                       variants=["full", "ankle_only:controller.hip_strategy_enabled=0"])
    s.points                                       # a NumPy structured array, one row per run
    anklehip.compare("results/x/x.csv", "scenarios/reference/x.csv")
    anklehip.steptest("chest_push_hip_cycle")

The reference is docs/python-api.md. The package is grouped by job: ``anklehip.running`` (FMUs,
the closed loop, step tests, sweeps), ``anklehip.analysis`` (summaries, comparison, bounds,
figures), ``anklehip.files`` (where things are, scenarios, results on disk), ``anklehip.cli``.
Importing the package is cheap: each name below is imported when first used.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

__version__ = "0.1.0"

# name -> (module, attribute); the public API, imported on first use (PEP 562)
_API = {
    "run": ("running.run", "run"),
    "ScenarioResult": ("running.run", "ScenarioResult"),
    "PushSummary": ("analysis.summary", "PushSummary"),
    "Check": ("analysis.summary", "Check"),
    "sweep": ("running.sweep", "sweep"),
    "SweepResult": ("running.sweep", "SweepResult"),
    "Variant": ("running.sweep", "Variant"),
    "compare": ("analysis.compare", "compare"),
    "CompareReport": ("analysis.compare", "CompareReport"),
    "steptest": ("running.steptest", "steptest"),
    "steptest_cases": ("running.steptest", "steptest_cases"),
    "StepTestResult": ("running.steptest", "StepTestResult"),
    "load_scenario": ("files.scenario", "load_scenario"),
    "scenarios": ("files.paths", "scenarios"),
    "fmu_path": ("files.paths", "fmu_path"),
    "locations": ("files.paths", "locations"),
    "fmu_info": ("files.info", "interface"),
    "Scenario": ("files.scenario", "Scenario"),
    "PushProfile": ("files.scenario", "PushProfile"),
    "PushSegment": ("files.scenario", "PushSegment"),
    "InputError": ("errors", "InputError"),
    "figures": ("analysis.figures", None),
}
__all__ = ["__version__", *_API]

if TYPE_CHECKING:   # what a type checker and an IDE see
    from .analysis import figures
    from .analysis.compare import CompareReport, compare
    from .analysis.summary import Check, PushSummary
    from .errors import InputError
    from .files.info import interface as fmu_info
    from .files.paths import fmu_path, locations, scenarios
    from .files.scenario import PushProfile, PushSegment, Scenario, load_scenario
    from .running.run import ScenarioResult, run
    from .running.steptest import StepTestResult, steptest, steptest_cases
    from .running.sweep import SweepResult, Variant, sweep


def __getattr__(name: str):
    if name not in _API:
        raise AttributeError(f"module 'anklehip' has no attribute {name!r}")
    import importlib
    module, attr = _API[name]
    mod = importlib.import_module(f".{module}", __name__)
    value = mod if attr is None else getattr(mod, attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(list(globals()) + list(_API))
