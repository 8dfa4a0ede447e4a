"""The figures as functions that return a Matplotlib figure (``anklehip.figures``).

Each takes what the API returns: a result of ``anklehip.run`` (or its ``signals`` array, or a
result CSV's path), a comparison report of ``anklehip.compare``, a result of ``anklehip.sweep``, or
the real-time report of a step test. Show a figure in a notebook by leaving it as a cell's value,
save it with ``fig.savefig(path)`` or ``save(fig, path)`` (which also closes it). The command line
writes the same figures (docs/python-api.md lists which command writes which).

The figures are not left open in pyplot (a notebook shows a figure once, when a cell returns it;
a script saves it): ``plt.show()`` does not show them.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["fig4", "fig5", "overview", "frontal", "frontal_cycle", "comparison", "failed_signals", "sweep", "capability",
           "rt_histogram", "save"]


def _signals(result: Any) -> np.ndarray:
    """The signals of a run's result, a RunResult, a structured array or a result CSV's path."""
    if isinstance(result, np.ndarray):
        return result
    if hasattr(result, "signals"):
        return result.signals
    if hasattr(result, "data") and isinstance(result.data, np.ndarray):
        return result.data
    if isinstance(result, (str, os.PathLike)):
        from .compare import read_result_csv
        return read_result_csv(result, "result")
    raise TypeError(f"expected a result of anklehip.run, a structured array or a CSV path, got {type(result).__name__}")


def _detached(fig):
    """The figure, no longer managed by pyplot (still drawable, savable and shown by IPython)."""
    if fig is not None:
        import matplotlib.pyplot as plt
        if plt.fignum_exists(getattr(fig, "number", -1)):
            plt.close(fig)
    return fig


def _title(result: Any, what: str) -> str:
    sc = getattr(result, "scenario", None)
    return f"{sc.name}: {what}" if sc is not None else what


def fig4(result: Any, *, title: str | None = None):
    """The paper's Fig. 4: joint angles, ZMP and phases over the whole run."""
    from . import plots
    return _detached(plots.fig4_figure(
        _signals(result), _title(result, "joint angles (cf. paper Fig. 4)") if title is None else title))


def fig5(result: Any, *, window: tuple[float, float] | None = None,
         zmp_limits: tuple[float, ...] | None = None, title: str | None = None):
    """The paper's Fig. 5: the first push cycle in detail (or `window` [s]), phases shaded, the
    ZMP limits (default: the run's controller parameters) dotted."""
    from . import plots
    if zmp_limits is None and getattr(result, "run", None) is not None:
        from ..running.run import zmp_limits as limits
        zmp_limits = limits(result.run.controller_parameters)
    return _detached(plots.fig5_figure(
        _signals(result), window=window, zmp_limits=zmp_limits,
        title=_title(result, "first push cycle (cf. paper Fig. 5)") if title is None else title))


def overview(result: Any, *, title: str | None = None):
    """All signals at a glance (any result CSV: every column when the standard ones are missing)."""
    from . import plots
    return _detached(plots.overview_figure(_signals(result), _title(result, "overview") if title is None else title))


def frontal(result: Any, *, title: str | None = None):
    """A 3D-plant run: the frontal plane and the feet (lateral ZMP and CoM, roll, pushes, slip)."""
    from . import plots
    return _detached(plots.frontal_figure(
        _signals(result), _title(result, "frontal plane and feet") if title is None else title))


def frontal_cycle(result: Any, *, window: tuple[float, float] | None = None, edge: float | None = None,
                  title: str | None = None):
    """A run of the 3D controller: the frontal plane's Fig. 5 around the first side push (or
    `window` [s]) -- lateral phases, the frontal and the legs' roll references, p_y, r_y measured
    and the controller's, r_y^d, the outer sole edges at ±`edge` [m] (default: the robot header's
    ankle_y + sole_width/2), the sideways push."""
    from . import frontal_cycle as fc
    if edge is None:
        edge = fc.plant_support_edge()
    return _detached(fc.frontal_cycle_figure(
        _signals(result), window=window, edge=edge,
        title=_title(result, "first side push (frontal plane, cf. paper Fig. 5)") if title is None else title))


def comparison(report: Any, signals: list[str] | None = None):
    """A comparison (anklehip.compare, or a run's ``comparison``): per signal the reference, the
    band and tube of the verdict, the result and the failing samples (default: the failed signals,
    or all of them when every one passed)."""
    from .compare import comparison_figure
    report = getattr(report, "comparison", report)
    if report is None:
        raise ValueError("the run was not compared with a reference (its comparison is None)")
    return _detached(comparison_figure(report, signals))


def failed_signals(report: Any):
    """comparison() of the failed signals only; None when every signal passed."""
    report = getattr(report, "comparison", report)
    if report is None or report.passed:
        return None
    return comparison(report, [s.name for s in report.failed])


def sweep(result: Any, *, title: str | None = None):
    """A force sweep (anklehip.sweep with forces): the outcome per variant over the peak push force."""
    from ..running.sweep import sweep_figure
    rows = [r for r in result.rows if r.get("outcome") != "error"]
    return _detached(sweep_figure(rows, title or f"{result.name}: outcome vs peak push force"))


def capability(result: Any):
    """A sweep file's capability map (anklehip.sweep of e.g. "force_duration"): each variant's
    survive boundary over push duration or height, with the analytic bounds; for a grid over
    push.force and push.angle (e.g. "polar_3d") the polar map, the boundary per push direction
    against the bounds in every direction; None when the sweep is neither."""
    from .capability import capability_figure
    if result.sweep_file is None:
        raise ValueError("a capability map needs a sweep file (anklehip.sweep without forces)")
    return _detached(capability_figure(result.sweep_file, result.rows, result.plant_parameters))


def rt_histogram(rt: Any, *, title: str = ""):
    """A step test's execution-time and lateness histograms (StepTestResult.rt, or the result)."""
    from ..running.steptest import rt_histogram_figure
    rt = getattr(rt, "rt", rt)
    if rt is None:
        raise ValueError("the step test was not timed (realtime=True or native=True time it)")
    return _detached(rt_histogram_figure(rt, title))


def save(fig, path: str | os.PathLike, dpi: int = 120) -> Path:
    """Write the figure (PNG, SVG, PDF: by the suffix), close it, return the path."""
    import matplotlib.pyplot as plt
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
