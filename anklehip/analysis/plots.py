"""Figures (matplotlib, Agg): the paper's Fig. 4 and Fig. 5, an overview of any result, a
stick-figure animation (GIF)."""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np

PHASE_COLORS = {1: "#f6d55c", 2: "#ed553b", 3: "#3caea3"}
PHASE_LABELS = {0: "0 ankle", 1: "1 ankle→hip", 2: "2 hip", 3: "3 hip→ankle"}


def _has(d: np.ndarray, *names: str) -> bool:
    return all(n in d.dtype.names for n in names)


# ----------------------------------------------------------------------------------------------
# progress (figures and GIF frames), the same way as the simulation's: a tqdm bar on stderr when
# it is a terminal, nothing in logs, nothing with progress=False (`anklehip run --no-progress`)

def progress_bar(total: int, desc: str, unit: str, progress: bool | None = None):
    """A tqdm bar, or None when progress is off. `disable=None` turns it off on a non-TTY."""
    if progress is False:
        return None
    from tqdm import tqdm
    return tqdm(total=total, desc=desc, unit=unit, disable=None, leave=False, file=sys.stderr)


def say_written(bar, path: Path, seconds: float) -> None:
    """One line per file written, above the bar (only where the bar shows)."""
    if bar is not None and not bar.disable:
        bar.write(f"anklehip: wrote {path} ({seconds:.1f} s)", file=sys.stderr)


# ----------------------------------------------------------------------------------------------
# phases and legends

def shade_phases(ax, t: np.ndarray, phase: np.ndarray, legend: bool = False) -> None:
    """Shade phases 1..3 (phase 0 stays unshaded). `legend=True` adds the phase legend to the
    axes' figure, below the panels (see phase_legend); figures that use it must reserve the room
    with _layout."""
    if len(t) == 0:
        return
    ch = np.flatnonzero(np.diff(phase) != 0) + 1
    starts = np.concatenate([[0], ch])
    ends = np.concatenate([ch, [len(t) - 1]])
    for a, b in zip(starts, ends):
        p = int(phase[a])
        if p in PHASE_COLORS:
            ax.axvspan(t[a], t[b], color=PHASE_COLORS[p], alpha=0.35, lw=0)
    if legend:
        phase_legend(ax.figure, phase)


def phase_legend(fig, phase: np.ndarray):
    """One phase legend for the whole figure, in a row below the panels, outside every axes, so it
    can hide neither the data nor the signal legends. Phase 0 (ankle strategy) is the unshaded
    background: the legend says so. None when no shaded phase occurs."""
    from matplotlib.patches import Patch
    used = sorted(int(q) for q in np.unique(phase) if int(q) in PHASE_COLORS)
    if not used:
        return None
    handles = ([Patch(facecolor="white", edgecolor="0.6", label="phase 0 ankle (unshaded)")]
               + [Patch(facecolor=PHASE_COLORS[q], alpha=0.35, label=f"phase {PHASE_LABELS[q]}") for q in used])
    leg = fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=7, frameon=True,
                     borderaxespad=0.4)
    leg.set_gid("phase_legend")
    return leg


def signal_legend(ax, **kw):
    """The signals' legend of one panel, in one row at its upper right; _layout raises the panel's
    y range so that the legend sits in a band above the data."""
    n = len(ax.get_legend_handles_labels()[0])
    return ax.legend(fontsize=7, ncol=max(1, n), loc="upper right", **kw)


def _layout(fig) -> None:
    """tight_layout with room below for the figure's phase legend, then headroom above the data
    for every panel's legend (a legend inside an axes must not hide a line)."""
    r = fig.canvas.get_renderer()
    bottom = 0.0
    for leg in fig.legends:
        bb = leg.get_window_extent(r)
        bottom = max(bottom, (bb.y1 + 4) / fig.bbox.height)
    for _ in range(2):      # the new y ranges can change the tick labels, so once more
        fig.tight_layout(rect=(0, bottom, 1, 1))
        for ax in fig.axes:
            leg = ax.get_legend()
            if leg is None or not leg.get_visible():
                continue
            ab, lb = ax.get_window_extent(r), leg.get_window_extent(r)
            need = (ab.y1 - lb.y0 + 3) / ab.height          # share of the axes height from the top
            if not 0 < need < 0.8:
                continue
            lo, hi = ax.get_ylim()
            data_hi = _data_top(ax, hi)
            if (hi - data_hi) / (hi - lo) < need:
                ax.set_ylim(lo, lo + (data_hi - lo) / (1 - need))


def _data_top(ax, default: float) -> float:
    """The highest y of the axes' lines (in data units), or `default`."""
    tops = []
    for ln in ax.get_lines():
        y = np.asarray(ln.get_ydata(), dtype=float)
        if y.size and np.isfinite(y).any():
            tops.append(float(np.nanmax(y)))
    if not tops:
        return default
    lo, hi = ax.get_ylim()
    return min(hi, max(tops) + 0.03 * (hi - lo))


def _phase_axes(d: np.ndarray, t: np.ndarray, n: int, figsize, height_ratios, phase: str = "phase"):
    """n stacked axes sharing time, the phases of the column `phase` shaded on each (one phase
    legend below the panels)."""
    fig, ax = plt.subplots(n, 1, figsize=figsize, sharex=True, gridspec_kw={"height_ratios": height_ratios})
    for i, x in enumerate(ax):
        if _has(d, phase):
            shade_phases(x, t, d[phase], legend=i == 0)
        x.grid(alpha=0.3)
    return fig, ax


def _phase_axes_with_angles(d: np.ndarray, t: np.ndarray, figsize, height_ratios):
    """Four stacked axes sharing time, the phases shaded on each (one phase legend below the
    panels), the joint angles in the first."""
    fig, ax = _phase_axes(d, t, 4, figsize, height_ratios)
    ax[0].plot(t, np.degrees(d["theta_ankle"]), color="tab:blue", label="ankle θ1")
    ax[0].plot(t, np.degrees(d["theta_hip"]), color="tab:red", label="hip θ2")
    return fig, ax


def _save(fig, out: Path) -> Path:
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def fig4_figure(d: np.ndarray, title: str = ""):
    """Paper Fig. 4 as a matplotlib Figure (see fig4)."""
    t = d["time"]
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 5.5), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    if _has(d, "phase"):
        shade_phases(a1, t, d["phase"], legend=True)
        shade_phases(a2, t, d["phase"])
    a1.plot(t, np.degrees(d["theta_ankle"]), color="tab:blue", lw=1, label="ankle θ1")
    a1.plot(t, np.degrees(d["theta_hip"]), color="tab:red", lw=1, label="hip θ2")
    a1.set_ylabel("joint angle [deg]")
    signal_legend(a1)
    a1.grid(alpha=0.3)
    a1.set_title(title or "Joint angles (cf. paper Fig. 4)")
    if _has(d, "push_force"):
        a2.plot(t, d["push_force"], color="k", lw=1)
    a2.set_ylabel("push [N]")
    a2.set_xlabel("time [s]")
    a2.grid(alpha=0.3)
    _layout(fig)
    return fig


def fig4(d: np.ndarray, out: Path, title: str = "") -> Path:
    """Paper Fig. 4: ankle and hip joint angles over the whole run (+ push force, phases)."""
    return _save(fig4_figure(d, title), out)


def first_cycle_window(d: np.ndarray, pad_before: float = 0.5, pad_after: float = 1.5,
                       force: str = "push_force", phase: str = "phase") -> tuple[float, float]:
    """From just before the first push (column `force`) until the controller is back in phase 0
    (column `phase`; 2 s after the push when it never left it), plus a margin."""
    t = d["time"]
    f = d[force] if _has(d, force) else np.zeros(len(t))
    nz = np.flatnonzero(f != 0)
    if not len(nz):
        return float(t[0]), float(t[-1])
    a = float(t[nz[0]])
    end = None
    if _has(d, phase):
        ph = d[phase]
        left = np.flatnonzero((ph != 0) & (t >= a))
        if len(left):
            back = np.flatnonzero((ph == 0) & (t > t[left[0]]))
            if len(back):
                end = float(t[back[0]])
    if end is None:
        gaps = np.flatnonzero((f == 0) & (t > a))
        end = float(t[gaps[0]]) + 2.0 if len(gaps) else float(t[-1])
    return max(float(t[0]), a - pad_before), min(float(t[-1]), end + pad_after)


def fig5_figure(d: np.ndarray, window: tuple[float, float] | None = None,
                zmp_limits: tuple[float, float] | None = None, title: str = ""):
    """Paper Fig. 5 as a matplotlib Figure (see fig5)."""
    a, b = window or first_cycle_window(d)
    m = (d["time"] >= a) & (d["time"] <= b)
    d = d[m]
    t = d["time"]
    fig, ax = _phase_axes_with_angles(d, t, (9, 9), [3, 3, 2, 1.3])
    if _has(d, "theta_ankle_ref"):
        ax[0].plot(t, np.degrees(d["theta_ankle_ref"]), color="tab:blue", ls="--", lw=0.8, label="θ1 ref")
        ax[0].plot(t, np.degrees(d["theta_hip_ref"]), color="tab:red", ls="--", lw=0.8, label="θ2 ref")
    ax[0].set_ylabel("angle [deg]")
    signal_legend(ax[0])
    ax[0].set_title(title or "First push cycle (cf. paper Fig. 5)")
    ax[1].plot(t, 1000 * d["zmp_x"], color="tab:purple", label="ZMP p")
    ax[1].plot(t, 1000 * d["com_x"], color="tab:green", label="CoM projection r_x")
    if _has(d, "com_x_desired"):
        ax[1].plot(t, 1000 * d["com_x_desired"], color="tab:green", ls="--", lw=0.8, label="r_x desired")
    if zmp_limits:
        for i, z in enumerate(zmp_limits):
            ax[1].axhline(1000 * z, color="k", ls=":", lw=0.8, label="ZMP limits" if i == 0 else None)
    ax[1].set_ylabel("x [mm]")
    signal_legend(ax[1])
    ax[2].plot(t, 1000 * (d["zmp_x"] - d["com_x"]), color="k", lw=1, label="p − r_x (measured)")
    ax[2].set_ylabel("p − r_x [mm]")
    signal_legend(ax[2])
    if _has(d, "push_force"):
        ax[3].plot(t, d["push_force"], color="k", lw=1)
    ax[3].set_ylabel("push [N]")
    ax[3].set_xlabel("time [s]")
    _layout(fig)
    return fig


def fig5(d: np.ndarray, out: Path, window: tuple[float, float] | None = None,
         zmp_limits: tuple[float, float] | None = None, title: str = "") -> Path:
    """Paper Fig. 5: the first cycle in detail — joint angles, ZMP p and CoM projection r_x,
    p - r_x, push force; the four phases shaded."""
    return _save(fig5_figure(d, window, zmp_limits, title), out)


def overview_figure(d: np.ndarray, title: str = ""):
    """The overview as a matplotlib Figure (see overview)."""
    t = d["time"]
    std = _has(d, "theta_ankle", "theta_hip", "zmp_x", "com_x")
    if not std:
        cols = [c for c in d.dtype.names[1:] if d[c].ndim == 1]
        n = max(1, len(cols))
        fig, ax = plt.subplots(n, 1, figsize=(9, 1.6 * n + 0.8), sharex=True, squeeze=False)
        for x, c in zip(ax[:, 0], cols):
            x.plot(t, d[c], lw=0.9)
            x.set_ylabel(c, fontsize=7)
            x.grid(alpha=0.3)
        ax[-1, 0].set_xlabel("time [s]")
        ax[0, 0].set_title(title)
        fig.tight_layout()
        return fig
    fig, ax = _phase_axes_with_angles(d, t, (10, 9), [3, 3, 1.5, 1.2])
    ax[0].set_ylabel("angle [deg]")
    signal_legend(ax[0])
    ax[0].set_title(title)
    ax[1].plot(t, 1000 * d["zmp_x"], color="tab:purple", label="ZMP p")
    ax[1].plot(t, 1000 * d["com_x"], color="tab:green", label="CoM r_x")
    ax[1].set_ylabel("x [mm]")
    signal_legend(ax[1])
    if _has(d, "fz"):
        ax[2].plot(t, d["fz"], color="k", lw=0.8)
        ax[2].set_ylabel("fz [N]")
    if _has(d, "push_force"):
        ax[3].plot(t, d["push_force"], color="k", lw=0.9)
        ax[3].set_ylabel("push [N]")
    ax[3].set_xlabel("time [s]")
    _layout(fig)
    return fig


def overview(d: np.ndarray, out: Path, title: str = "") -> Path:
    """Any result CSV: the standard panels when the columns exist, else every column."""
    return _save(overview_figure(d, title), out)


def frontal(d: np.ndarray, out: Path, title: str = "") -> Path:
    """frontal_figure as a PNG."""
    return _save(frontal_figure(d, title), out)


def frontal_figure(d: np.ndarray, title: str = ""):
    """Results of the 3D plant: the frontal plane and the feet over time -- lateral ZMP and CoM,
    sole and trunk roll, both pushes, and where the feet are (sliding) with their slip speed."""
    t = d["time"]
    names = d.dtype.names
    fig, ax = plt.subplots(4, 1, figsize=(10, 9), sharex=True, gridspec_kw={"height_ratios": [3, 2, 1.5, 2]})
    ax[0].plot(t, 1000 * d["zmp_y"], color="tab:purple", label="ZMP y")
    ax[0].plot(t, 1000 * d["com_y"], color="tab:green", label="CoM y")
    ax[0].set_ylabel("y [mm] (+ = left)")
    ax[0].legend(fontsize=7, loc="upper right")
    ax[0].set_title(title)
    for col, lab in (("foot_roll", "soles (mean)"), ("imu_roll", "trunk (IMU)"),
                     ("q_left_ankle_roll", "left ankle roll"), ("q_left_hip_roll", "left hip roll")):
        if col in names:
            ax[1].plot(t, np.degrees(d[col]), lw=0.9, label=lab)
    ax[1].set_ylabel("roll [deg]")
    ax[1].legend(fontsize=7, ncol=4, loc="upper right")
    for col, lab in (("push_force", "push x"), ("push_force_y", "push y")):
        if col in names:
            ax[2].plot(t, d[col], lw=0.9, label=lab)
    ax[2].set_ylabel("push [N]")
    ax[2].legend(fontsize=7, loc="upper right")
    if _has(d, "feet_x", "feet_y"):
        ax[3].plot(t, 1000 * (d["feet_x"] - d["feet_x"][0]), label="feet moved, x")
        ax[3].plot(t, 1000 * (d["feet_y"] - d["feet_y"][0]), label="feet moved, y")
        ax[3].set_ylabel("[mm]")
    if _has(d, "slip_speed_left", "slip_speed_right"):
        tw = ax[3].twinx()
        tw.plot(t, 1000 * np.maximum(d["slip_speed_left"], d["slip_speed_right"]), color="0.5", lw=0.7,
                label="slip speed (max of both soles)")
        tw.set_ylabel("slip [mm/s]")
        tw.legend(fontsize=7, loc="lower right")
    ax[3].legend(fontsize=7, loc="upper left")
    ax[3].set_xlabel("time [s]")
    for x in ax:
        x.grid(alpha=0.3)
    fig.tight_layout()
    return fig


# ----------------------------------------------------------------------------------------------
# stick-figure animation

@dataclass
class Geometry:
    """Sagittal geometry for drawing [m]; defaults are the HOAP-2 numbers of docs/hoap2-model.md."""
    l1: float = 0.200
    lg2: float = 0.10
    trunk: float = 0.22          # hip -> top of the trunk (drawn)
    toe: float = 0.0575
    heel: float = -0.0375
    ankle_height: float = 0.035
    push_height: float = 0.335   # above the sole
    hip_half_width: float = 0.039   # frontal view (3D plant): ankle and hip axes from the middle
    sole_width: float = 0.065
    thigh: float | None = None      # hip -> knee, knee -> ankle [m] (frontal view); None: l1 / 2 each
    shank: float | None = None

    _names = {
        "l1": ("l1",),
        "lg2": ("lg2",),
        "toe": ("foot_toe", "toe_x", "x_toe", "l_toe", "toe"),
        "heel": ("foot_heel", "heel_x", "x_heel", "l_heel", "heel"),
        "ankle_height": ("ankle_height", "h_ankle", "foot_height", "ankle_z"),
        "push_height": ("push_height", "h_push", "push_z"),
        "thigh": ("thigh", "thigh_length"),
        "shank": ("shank", "shank_length"),
    }

    @classmethod
    def from_parameters(cls, params: dict[str, Any] | None) -> "Geometry":
        g = cls()
        if not params:
            return g
        for attr, cands in cls._names.items():
            for c in cands:
                if c in params and isinstance(params[c], (int, float)) and not isinstance(params[c], bool):
                    val = float(params[c])
                    if attr == "heel" and val > 0:
                        val = -val
                    setattr(g, attr, val)
                    break
        g.trunk = max(g.trunk, 2.2 * g.lg2)
        return g


def _rot(phi: float, x: float, z: float) -> tuple[float, float]:
    """Pitch forward by phi: an upward vector tilts toward +x."""
    c, s = math.cos(phi), math.sin(phi)
    return x * c + z * s, -x * s + z * c


class _PaletteMapper:
    """Frames (24-bit colours as uint32 0x00BBGGRR) to palette images on one palette: the 256
    commonest colours of sample frames, so the background, the artists' colours and the commonest
    anti-aliasing shades stay exact, and every other colour maps to its nearest (a lookup table,
    filled as colours turn up). PIL's quantize(palette=...) would be as fast but maps through a
    reduced-precision cache (white came out as 252, 252, 252)."""

    def __init__(self, sample: np.ndarray):
        keys, counts = np.unique(sample, return_counts=True)
        keys = keys[np.argsort(-counts, kind="stable")[:256]]
        self.rgb = np.stack([keys & 255, (keys >> 8) & 255, (keys >> 16) & 255], axis=1).astype(np.int32)
        self.lut = np.full(1 << 24, -1, np.int16)
        self.lut[keys] = np.arange(len(keys))
        flat = self.rgb.astype(np.uint8).ravel().tolist()
        self.palette = flat + flat[:3] * (256 - len(keys))

    def __call__(self, frame: np.ndarray):
        from PIL import Image
        k = frame.ravel()
        ix = self.lut[k]
        miss = ix < 0
        if miss.any():
            new = np.unique(k[miss])
            c = np.stack([new & 255, (new >> 8) & 255, (new >> 16) & 255], axis=1).astype(np.int32)
            self.lut[new] = ((c[:, None, :] - self.rgb[None, :, :]) ** 2).sum(axis=2).argmin(axis=1)
            ix = self.lut[k]
        h, w = frame.shape
        im = Image.frombuffer("P", (w, h), ix.astype(np.uint8).tobytes(), "raw", "P", 0, 1)
        im.putpalette(self.palette)
        return im


ANIMATION_DPI = 80      # 4.2 x 5 in -> 336 x 400 pixels (two views: 640 x 400)


def _rx(a: float) -> np.ndarray:
    c, s_ = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s_], [0.0, s_, c]])


def _ry(a: float) -> np.ndarray:
    c, s_ = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s_], [0.0, 1.0, 0.0], [-s_, 0.0, c]])


def _rz(a: float) -> np.ndarray:
    c, s_ = math.cos(a), math.sin(a)
    return np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]])


LEG_JOINTS = ("hip_yaw", "hip", "hip_roll", "knee", "ankle", "ankle_roll")   # Hoap2Plant3D's q_<side>_<joint>


def leg_chain(q: dict[str, float], foot_roll: float, thigh: float, shank: float):
    """One leg of the 3D plant from its foot up (controller_c/include/ahc/leg_ik.h's chain: trunk ->
    thigh Rz(yaw) Ry(-hip) Rx(hip_roll), thigh -> shank Ry(knee), shank -> foot Ry(-ankle)
    Rx(ankle_roll)), the foot rolled by foot_roll about +x: the knee and the hip relative to the
    ankle, and the trunk's orientation, in world axes. Missing joints count as 0."""
    g = {j: float(q.get(j, 0.0)) for j in LEG_JOINTS}
    R_shank = _rx(foot_roll) @ _rx(-g["ankle_roll"]) @ _ry(g["ankle"])
    R_thigh = R_shank @ _ry(-g["knee"])
    R_trunk = R_thigh @ _rx(-g["hip_roll"]) @ _ry(g["hip"]) @ _rz(-g["hip_yaw"])
    knee = R_shank @ np.array([0.0, 0.0, shank])
    return knee, knee + R_thigh @ np.array([0.0, 0.0, thigh]), R_trunk


def _frontal_pose(d: np.ndarray, k: int, g: Geometry, y0: float) -> dict:
    """Frontal (y-z) stick figure of the 3D plant at row k: both soles rolled by foot_roll about the
    outer edge they stand on; each leg from its own joint angles q_<side>_<joint> (leg_chain: the
    ankle roll, the knee and the hip roll, so that the parallelogram of the lateral ankle strategy and
    the pelvis tilt of the lateral hip strategy show), the pelvis between the two hips, the trunk at
    the IMU's roll."""
    names = d.dtype.names
    phi = float(d["foot_roll"][k])                       # + = left edge up (rotation about +x)
    yc = float(d["feet_y"][k]) - y0 if "feet_y" in names else 0.0
    w, hw = 0.5 * g.sole_width, g.hip_half_width
    thigh = g.thigh if g.thigh is not None else 0.5 * g.l1
    shank = g.shank if g.shank is not None else 0.5 * g.l1
    ya = {"left": yc + hw, "right": yc - hw}
    pivot = ya["right"] - w if phi > 1e-6 else (ya["left"] + w if phi < -1e-6 else yc)
    c, s_ = math.cos(phi), math.sin(phi)

    def turn(y, z):                                      # about +x through (pivot, 0)
        return pivot + (y - pivot) * c - z * s_, (y - pivot) * s_ + z * c

    pose = {}
    for side in ("left", "right"):
        edge_a, edge_b = turn(ya[side] - w, 0.0), turn(ya[side] + w, 0.0)
        ank = turn(ya[side], g.ankle_height)
        q = {j: d[f"q_{side}_{j}"][k] for j in LEG_JOINTS if f"q_{side}_{j}" in names}
        kn, hp, _ = leg_chain(q, phi, thigh, shank)
        knee = (ank[0] + kn[1], ank[1] + kn[2])
        hip = (ank[0] + hp[1], ank[1] + hp[2])
        pose[side] = (edge_a, edge_b, ank, hip, knee)
    mid = tuple(0.5 * (a + b) for a, b in zip(pose["left"][3], pose["right"][3]))
    roll = float(d["imu_roll"][k]) if "imu_roll" in names else phi
    top = (mid[0] - g.trunk * math.sin(roll), mid[1] + g.trunk * math.cos(roll))
    pose["trunk"] = (mid, top, roll)
    pose["zmp"] = yc + float(d["zmp_y"][k])
    pose["com"] = (yc + float(d["com_y"][k]), g.ankle_height + float(d["com_z"][k]) if "com_z" in names else 0.3)
    return pose


def animate(d: np.ndarray, out: Path, geom: Geometry | None = None, fps: float = 20.0,
            speed: float = 1.0, t_start: float | None = None, t_stop: float | None = None,
            title: str = "", progress: bool | None = None) -> Path:
    """Stick-figure GIF: foot (rocking on toe/heel), legs, trunk, push arrow, ZMP and CoM
    projection on the sole, phase and time in the corner. Results of the 3D plant (columns
    foot_roll, zmp_y, com_y) get a frontal view beside the sagittal one, with the sideways push;
    where the feet slide (feet_x, feet_y) the figure moves with them over the ground.

    The static part (axes, ground, titles) is drawn once; each frame restores it and draws only
    the moving artists (blitting), and is mapped onto one palette computed once from a few frames
    (instead of a full redraw and an adaptive palette per frame: ≈ 4x faster). `progress` as in
    master.simulate: a bar of the frames on a terminal, none with False."""
    g = geom or Geometry()
    t = d["time"]
    a = t[0] if t_start is None else t_start
    b = t[-1] if t_stop is None else t_stop
    frames = np.arange(a, b + 1e-9, speed / fps)
    if not len(frames) or a > t[-1] or b < t[0]:
        raise ValueError(f"no animation frames: the window {a:g}..{b:g} s (--anim-start/--anim-stop) is outside "
                         f"the result's {t[0]:g}..{t[-1]:g} s")
    idx = np.clip(np.searchsorted(t, frames), 0, len(t) - 1)
    names = d.dtype.names
    fmax = max(1.0, float(np.max(np.abs(d["push_force"])))) if "push_force" in names else 1.0
    frontal = _has(d, "foot_roll", "zmp_y", "com_y")
    x0 = float(d["feet_x"][0]) if "feet_x" in names else 0.0
    y0 = float(d["feet_y"][0]) if "feet_y" in names else 0.0
    slide_x = d["feet_x"] - x0 if "feet_x" in names else np.zeros(len(t))

    fig, axes = plt.subplots(1, 2 if frontal else 1, figsize=(8.0 if frontal else 4.2, 5.0), squeeze=False,
                             dpi=ANIMATION_DPI)
    ax = axes[0, 0]
    ax.set_aspect("equal")
    ax.set_xlim(min(-0.25, float(slide_x.min()) - 0.25), max(0.25, float(slide_x.max()) + 0.25))
    ax.set_ylim(-0.02, 0.62)
    ax.axhline(0, color="k", lw=1)
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(title + (" (sagittal: side view)" if frontal else ""), fontsize=9)
    foot, = ax.plot([], [], color="0.3", lw=3, solid_capstyle="butt")
    legs, = ax.plot([], [], color="tab:blue", lw=4, solid_capstyle="round")
    trunk, = ax.plot([], [], color="tab:red", lw=6, solid_capstyle="round")
    head, = ax.plot([], [], "o", color="tab:red", ms=11)
    com, = ax.plot([], [], "o", color="k", ms=5, mfc="w")
    zmp_m, = ax.plot([], [], "^", color="tab:purple", ms=8, label="ZMP")
    comp_m, = ax.plot([], [], "v", color="tab:green", ms=8, label="CoM proj.")
    arrow = ax.annotate("", xy=(0, 0), xytext=(0, 0), arrowprops=dict(arrowstyle="-|>", color="tab:orange", lw=2))
    txt = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=8, family="monospace")
    ax.legend(loc="upper right", fontsize=7)    # static: part of the background, above the figure's reach
    moving = [foot, legs, trunk, head, com, zmp_m, comp_m, arrow, txt]   # drawn per frame, in this order

    if frontal:
        fy = max(1.0, float(np.max(np.abs(d["push_force_y"])))) if "push_force_y" in names else 1.0
        ax2 = axes[0, 1]
        slide_y = d["feet_y"] - y0 if "feet_y" in names else np.zeros(len(t))
        ax2.set_aspect("equal")
        ax2.set_xlim(max(0.25, float(slide_y.max()) + 0.25), min(-0.25, float(slide_y.min()) - 0.25))  # +y (left) on the left
        ax2.set_ylim(-0.02, 0.62)
        ax2.axhline(0, color="k", lw=1)
        ax2.set_xticks([])
        ax2.set_yticks([])
        ax2.set_title("frontal plane, from behind (robot's left on the left)", fontsize=9)
        f_soles = [ax2.plot([], [], color="0.3", lw=3, solid_capstyle="butt")[0] for _ in range(2)]
        f_legs = [ax2.plot([], [], color="tab:blue", lw=4, solid_capstyle="round")[0] for _ in range(2)]
        f_pelvis, = ax2.plot([], [], color="tab:blue", lw=4, solid_capstyle="round")
        f_trunk, = ax2.plot([], [], color="tab:red", lw=6, solid_capstyle="round")
        f_head, = ax2.plot([], [], "o", color="tab:red", ms=11)
        f_com, = ax2.plot([], [], "o", color="k", ms=5, mfc="w")
        f_zmp, = ax2.plot([], [], "^", color="tab:purple", ms=8)
        f_comp, = ax2.plot([], [], "v", color="tab:green", ms=8)
        f_arrow = ax2.annotate("", xy=(0, 0), xytext=(0, 0),
                               arrowprops=dict(arrowstyle="-|>", color="tab:orange", lw=2))
        moving += [*f_soles, *f_legs, f_pelvis, f_trunk, f_head, f_com, f_zmp, f_comp, f_arrow]

    def pose(k):
        phi = float(d["foot_pitch"][k]) if "foot_pitch" in names else 0.0
        mode = int(d["contact_mode"][k]) if "contact_mode" in names else 0
        pivot = g.toe if (mode == 1 or phi > 1e-6 and mode != 2) else (g.heel if (mode == 2 or phi < -1e-6) else 0.0)
        pivot += float(slide_x[k])
        # ankle above the sole at the foot's pivot point
        px, pz = pivot, 0.0
        off = float(slide_x[k])
        ax_, az_ = _rot(phi, off - pivot, g.ankle_height)
        ank = (px + ax_, pz + az_)
        toe = (px + _rot(phi, off + g.toe - pivot, 0)[0], pz + _rot(phi, off + g.toe - pivot, 0)[1])
        heel = (px + _rot(phi, off + g.heel - pivot, 0)[0], pz + _rot(phi, off + g.heel - pivot, 0)[1])
        a1 = phi + float(d["theta_ankle"][k])
        a12 = a1 + float(d["theta_hip"][k])
        hip = (ank[0] + g.l1 * math.sin(a1), ank[1] + g.l1 * math.cos(a1))
        top = (hip[0] + g.trunk * math.sin(a12), hip[1] + g.trunk * math.cos(a12))
        return ank, toe, heel, hip, top, a12

    def update_frontal(k):
        p = _frontal_pose(d, k, g, y0)
        for i, side in enumerate(("left", "right")):
            ea, eb, ank, hip, knee = p[side]
            f_soles[i].set_data([ea[0], eb[0]], [ea[1], eb[1]])
            f_legs[i].set_data([ank[0], knee[0], hip[0]], [ank[1], knee[1], hip[1]])
        f_pelvis.set_data([p["left"][3][0], p["right"][3][0]], [p["left"][3][1], p["right"][3][1]])
        mid, top, roll = p["trunk"]
        f_trunk.set_data([mid[0], top[0]], [mid[1], top[1]])
        f_head.set_data([top[0] - 0.03 * math.sin(roll)], [top[1] + 0.03 * math.cos(roll)])
        f_com.set_data([p["com"][0]], [p["com"][1]])
        f_zmp.set_data([p["zmp"]], [0.0])
        f_comp.set_data([p["com"][0]], [0.0])
        f = float(d["push_force_y"][k]) if "push_force_y" in names else 0.0
        s = (g.push_height - mid[1]) / max(1e-6, math.cos(roll))
        py = mid[0] - s * math.sin(roll) + (-0.03 if f >= 0 else 0.03)   # on the right side for a push to the left
        L = 0.12 * f / fy
        f_arrow.xy = (py, g.push_height)
        f_arrow.set_position((py - L, g.push_height))
        f_arrow.set_visible(abs(f) > 1e-9)

    def update(i):
        k = idx[i]
        ank, toe, heel, hip, top, a12 = pose(k)
        foot.set_data([heel[0], toe[0], ank[0], heel[0]], [heel[1], toe[1], ank[1], heel[1]])
        legs.set_data([ank[0], hip[0]], [ank[1], hip[1]])
        trunk.set_data([hip[0], top[0]], [hip[1], top[1]])
        head.set_data([top[0] + 0.03 * math.sin(a12)], [top[1] + 0.03 * math.cos(a12)])
        cx = float(d["com_x"][k]) + float(slide_x[k]) if "com_x" in names else 0.0
        cz = float(d["com_z"][k]) if "com_z" in names else 0.0
        com.set_data([cx], [g.ankle_height + cz])
        zmp_m.set_data([float(d["zmp_x"][k]) + float(slide_x[k])], [0.0])
        comp_m.set_data([cx], [0.0])
        f = float(d["push_force"][k]) if "push_force" in names else 0.0
        # point on the trunk at the push height, on the back (push +x) or the chest (push -x)
        s = (g.push_height - hip[1]) / max(1e-6, math.cos(a12))
        px = hip[0] + s * math.sin(a12) + (-0.012 if f >= 0 else 0.012)
        L = 0.12 * f / fmax
        arrow.xy = (px, g.push_height)
        arrow.set_position((px - L, g.push_height))
        arrow.set_visible(abs(f) > 1e-9)
        ph = int(d["phase"][k]) if "phase" in names else -1
        extra = f"\npush y {float(d['push_force_y'][k]):+4.1f} N" if frontal and "push_force_y" in names else ""
        if "phase_y" in names:          # the 3D controller's lateral phase
            extra += f"\nlateral {PHASE_LABELS.get(int(d['phase_y'][k]), '?')}"
        txt.set_text(f"t = {t[k]:6.2f} s\nphase {PHASE_LABELS.get(ph, '?')}\npush {f:+6.1f} N{extra}")
        if frontal:
            update_frontal(k)

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    canvas = fig.canvas
    # the moving artists in the order a full draw would paint them: per axes, by zorder (stable)
    order = [m for x in fig.axes for m in sorted((m for m in moving if m.axes is x), key=lambda m: m.get_zorder())]
    bar = None
    t0 = time.perf_counter()
    try:
        for m in moving:
            m.set_animated(True)          # left out of the full draw: that is the background
        canvas.draw()
        background = canvas.copy_from_bbox(fig.bbox)
        w, h = canvas.get_width_height(physical=True)

        def render(i: int) -> np.ndarray:
            """Frame i as 24-bit colours (uint32, 0x00BBGGRR), shape (h, w)."""
            update(i)
            canvas.restore_region(background)
            for m in order:
                m.axes.draw_artist(m)
            return np.frombuffer(canvas.buffer_rgba(), "<u4").reshape(h, w) & 0xFFFFFF

        # one palette for every frame, from frames that together show every colour (the push arrows
        # only appear while there is a push)
        probe = set(np.linspace(0, len(frames) - 1, min(len(frames), 6)).astype(int).tolist())
        for col in ("push_force", "push_force_y"):
            if col in names:
                probe.add(int(np.argmax(np.abs(d[col][idx]))))
        to_palette = _PaletteMapper(np.concatenate([render(i).ravel() for i in sorted(probe)]))

        bar = progress_bar(len(frames), f"GIF {out.name}", "frame", progress)
        images = []
        for i in range(len(frames)):
            images.append(to_palette(render(i)))
            if bar is not None:
                bar.update(1)
        if bar is not None:
            bar.set_description(f"GIF {out.name}: encoding")
            bar.refresh()
        images[0].save(out, format="GIF", save_all=True, append_images=images[1:],
                       duration=int(1000 / fps), loop=0)
        say_written(bar, out, time.perf_counter() - t0)
    finally:
        if bar is not None:
            bar.close()
        plt.close(fig)
    return out
