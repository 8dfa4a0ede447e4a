"""The frontal plane's counterpart of the paper's Fig. 5 (docs/controller.md §11): a run of the 3D
controller (AnkleHipController3D: the column ``phase_y``) around its first side push -- the lateral
phases shaded, the frontal references φ and ψ (F11, F16, F23-F25), the legs' roll set points
against the measured roll angles, the lateral ZMP p_y with the support polygon's outer edges, the
measured CoM r_y, the controller's own r_y (F2, from the measured joint angles) and its r_y^d, and
the sideways push."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .plots import _has, _layout, _phase_axes, _save, first_cycle_window, signal_legend

# the legs' roll joints drawn, with their colours
LEG_ROLLS = (("left", "hip_roll", "tab:blue"), ("left", "ankle_roll", "tab:cyan"),
             ("right", "hip_roll", "tab:red"), ("right", "ankle_roll", "tab:orange"))


def is_frontal(d: np.ndarray) -> bool:
    """Whether a result has the 3D controller's frontal outputs (the figure is drawn for it)."""
    return _has(d, "phase_y", "zmp_y")


def support_edge(params: dict[str, Any] | None) -> float | None:
    """The outer sole edges' distance from the mid-plane [m], both feet flat: ankle_y + sole_width/2,
    from the run's parameters (the 3D controller publishes both, from the generated robot header;
    a plant header read by anklehip.analysis.bounds.header_numbers gives the same names); None when
    either is missing."""
    if not params:
        return None
    try:
        return float(params["ankle_y"]) + 0.5 * float(params["sole_width"])
    except (KeyError, TypeError, ValueError):
        return None


def plant_support_edge(fmu_dir=None) -> float | None:
    """support_edge of the 3D plant FMU (its parameters and the robot header it was built from);
    None when the FMU is not found."""
    try:
        from ..files.paths import PLANT_FMUS, find_fmu
        from ..running.fmu import FMUInfo
        from .bounds import bounds_parameters, plant_header
        info = FMUInfo.load(find_fmu(PLANT_FMUS["3d"], fmu_dir))
    except Exception:
        return None
    return support_edge(bounds_parameters(info.start_values(), plant_header(info.unzipdir)))


def _controller_com_y(d: np.ndarray) -> str | None:
    """The controller's own r_y column: ``controller.com_y`` when the plant's com_y took the name."""
    for c in ("controller.com_y", "controller_com_y"):
        if c in d.dtype.names:
            return c
    return None


def frontal_cycle_figure(d: np.ndarray, window: tuple[float, float] | None = None,
                         edge: float | None = None, title: str = ""):
    """Fig. 5 for the frontal plane as a matplotlib Figure (see frontal_cycle). `window` [s] as
    fig5's (default: from just before the first sideways push until the lateral phase is back at 0,
    or 2 s after the push, plus a margin); `edge` [m]: the support polygon's outer edges at ±edge."""
    a, b = window or first_cycle_window(d, force="push_force_y", phase="phase_y")
    d = d[(d["time"] >= a) & (d["time"] <= b)]
    t = d["time"]
    names = d.dtype.names
    fig, ax = _phase_axes(d, t, 5, (9, 11), [2.2, 2.2, 3, 1.6, 1.2], phase="phase_y")
    # 1: the frontal references (F11, F16 and the transitions F23-F25)
    ax[0].plot(t, np.degrees(d["phi_ref"]), color="tab:blue", label="φ ref (pivot leg's lean)")
    ax[0].plot(t, np.degrees(d["psi_ref"]), color="tab:red", label="ψ ref (link 2's lean)")
    ax[0].set_ylabel("frontal ref [deg]")
    ax[0].set_title(title or "First side push (the frontal plane, cf. paper Fig. 5)")
    signal_legend(ax[0])
    # 2: each leg's hip-roll and ankle-roll: measured (solid) and set point (dashed)
    for side, joint, color in LEG_ROLLS:
        q, lab = f"q_{side}_{joint}", f"{side} {joint.replace('_', ' ')}"
        if q in names:
            ax[1].plot(t, np.degrees(d[q]), color=color, lw=1.0, label=lab)
        if q + "_ref" in names:
            ax[1].plot(t, np.degrees(d[q + "_ref"]), color=color, ls="--", lw=0.8, label=lab + " ref")
    ax[1].set_ylabel("leg roll [deg]")
    ax[1].legend(fontsize=6, ncol=4, loc="upper right")
    # 3: lateral ZMP, the CoM measured and as the controller sees it, its r_y^d, the support edges
    ax[2].plot(t, 1000 * d["zmp_y"], color="tab:purple", label="ZMP p_y")
    if "com_y" in names:
        ax[2].plot(t, 1000 * d["com_y"], color="tab:green", label="CoM r_y (measured)")
    est = _controller_com_y(d)
    if est:
        ax[2].plot(t, 1000 * d[est], color="tab:olive", ls="-.", lw=0.9, label="r_y (controller, F2)")
    if "com_y_desired" in names:
        ax[2].plot(t, 1000 * d["com_y_desired"], color="tab:green", ls="--", lw=0.8, label="r_y^d")
    if edge:
        for i, s in enumerate((1, -1)):
            ax[2].axhline(1000 * s * edge, color="k", ls=":", lw=0.8, label="outer sole edges" if i == 0 else None)
    ax[2].set_ylabel("y [mm] (+ = left)")
    signal_legend(ax[2])
    # 4: p_y - r_y, the disturbance moment's lever (d_y = m g (p_y - r_y))
    if "com_y" in names:
        ax[3].plot(t, 1000 * (d["zmp_y"] - d["com_y"]), color="k", lw=1, label="p_y − r_y (measured)")
    ax[3].set_ylabel("p_y − r_y [mm]")
    signal_legend(ax[3])
    # 5: the sideways push
    if "push_force_y" in names:
        ax[4].plot(t, d["push_force_y"], color="k", lw=1)
    ax[4].set_ylabel("push y [N]")
    ax[4].set_xlabel("time [s]")
    _layout(fig)
    return fig


def frontal_cycle(d: np.ndarray, out: Path, window: tuple[float, float] | None = None,
                  edge: float | None = None, title: str = "") -> Path:
    """frontal_cycle_figure as a PNG."""
    return _save(frontal_cycle_figure(d, window, edge, title), out)
