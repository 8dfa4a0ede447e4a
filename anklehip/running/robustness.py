"""Robustness study: each fault of anklehip.running.faults swept over its levels on one scenario (Dask).

For every fault the closed loop runs once per level (the other faults as the scenario sets
them). A run *survives* when the robot stands to the end and completes the scenario's
``expect.min_cycles`` push cycles (0 -> 1 -> 2 -> 3 -> 0; unset, one per push where the scenario
expects the hip strategy, phase 3 in ``expect.phases_reached``, and none otherwise, as in the 3D
stepping and side-push scenarios), and no more cycles than it has pushes (a cycle without a push is
the hip strategy set off by the fault). Whatever the level, every run must also
keep the invariants (``invariants_ok``):

* the controller never emits a non-finite value (every real controller output, every row);
* every step whose inputs had a non-finite value raises a non-finite fault bit (bits 0-3 of
  ``fault``, or, with the 3D controller, bits 0-1 of ``fault_y``);
* every change of a fault mask is logged (logEvents "fault mask ..."; the 3D controller's frontal
  one "frontal fault mask ...") and every episode of non-finite input is warned about once
  (logStatusWarning "non-finite input ...");
* the outcome is "completed" or "fell": a falling robot is reported as fallen, never as an error.

The table gives, per fault, the range of levels around the harmless one (the faults' default) in
which every level survives, and what happened at the first level beyond it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .faults import KEY_BY_NAME, SENSED_PREFIX, Faults

NONFINITE_BITS = 0xF      # AHC_FAULT_{THETA_ANKLE,THETA_HIP,ZMP,FZ}_NONFINITE
NONFINITE_BITS_Y = 0x3    # AHC_FFAULT_{ZMP_Y,ANGLE}_NONFINITE (the 3D controller's fault_y)
LOG_CATEGORIES = ["logEvents", "logStatusWarning"]


@dataclass(frozen=True)
class Study:
    label: str
    key: str                                   # the swept fault key
    base: dict[str, Any] = field(default_factory=dict)   # other fault options of this study
    controller: dict[str, Any] = field(default_factory=dict)   # controller parameter overrides of this study
    grid: str = ""          # levels (anklehip.running.sweep.parse_grid); "" = the fault key's default grid

    @property
    def levels_spec(self) -> str:
        return self.grid or KEY_BY_NAME[self.key].grid

    @property
    def default(self) -> float:
        return getattr(Faults(), self.key)


STUDIES: tuple[Study, ...] = (
    Study("ZMP noise", "zmp_noise"),
    Study("ZMP bias", "zmp_bias"),
    Study("ZMP bias, feet_offset_mode = 2", "zmp_bias", controller={"feet_offset_mode": 2}),
    Study("joint-angle noise", "angle_noise"),
    Study("ankle-angle bias", "ankle_bias"),
    Study("hip-angle bias", "hip_bias"),
    Study("lost packets (NaN)", "drop_rate", {"drop_mode": "nan"}, grid="0:0.8:0.05"),
    Study("lost packets (repeat)", "drop_rate", {"drop_mode": "repeat"}, grid="0,0.2,0.4,0.6,0.8,0.9,0.95,0.98,0.99"),
    Study("stuck zmp_x at each push", "stuck_for", {"stuck_signal": "zmp_x"}, grid="0:1.5:0.125"),
    Study("stuck theta_ankle at each push", "stuck_for", {"stuck_signal": "theta_ankle"}, grid="0,0.25,0.5,1,2,4,8"),
    Study("sensor delay", "delay_steps"),
    Study("servo torque limit", "torque_scale"),
    Study("model masses", "mass_mismatch"),
    Study("model lengths", "length_mismatch"),
    Study("push entering phase 1 (ankle->hip)", "transition_push", {"transition_phase": 1}, grid="0:8:0.5"),
    Study("push entering phase 3 (hip->ankle)", "transition_push", {"transition_phase": 3}, grid="0:20:1"),
)


def study_by_label(label: str) -> Study:
    for s in STUDIES:
        if s.label == label or s.key == label:
            return s
    raise ValueError(f"unknown study {label!r} (known: {', '.join(s.label for s in STUDIES)})")


def run_point(scenario_path: str, fmu_dir: str | None, study: Study, level: float) -> dict[str, Any]:
    """One closed-loop run of `study` at `level`: the row of points.csv."""
    from .master import Models, simulate
    from ..analysis.summary import count_cycles
    from ..files.scenario import faults_from, load_scenario
    sc = load_scenario(scenario_path)
    key = KEY_BY_NAME[study.key]
    faults = faults_from({**study.base, study.key: int(level) if key.integer else float(level)}, sc.faults,
                         f"study {study.label!r}")
    warnings: list[str] = []
    events: list[str] = []

    def logger(env, instance, status, category, message):
        (warnings if category == b"logStatusWarning" else events).append(message.decode(errors="replace"))

    res = simulate(sc, Models.for_scenario(sc, fmu_dir), faults=faults, progress=False,
                   controller_overrides=study.controller, log_categories=LOG_CATEGORIES, logger=logger)
    d = res.data[:-1] if len(res.data) > 1 else res.data     # the last row repeats the controller side
    ctrl_real = [c for c in res.controller_columns if d.dtype[c].kind == "f"]
    nonfinite_out = int(sum(np.count_nonzero(~np.isfinite(d[c])) for c in ctrl_real))
    sensed = [c for c in d.dtype.names if c.startswith(SENSED_PREFIX)]
    bad_in = np.zeros(len(d), bool)
    for c in sensed:
        bad_in |= ~np.isfinite(d[c])
    fault = d["fault"].astype(np.int64)
    fault_y = d["fault_y"].astype(np.int64) if "fault_y" in d.dtype.names else np.zeros_like(fault)
    unflagged = int(np.count_nonzero(bad_in & ((fault & NONFINITE_BITS) == 0) & ((fault_y & NONFINITE_BITS_Y) == 0)))
    episodes = int(np.count_nonzero(bad_in & ~np.concatenate([[False], bad_in[:-1]])))
    changes = sum(int(np.count_nonzero(f != np.concatenate([[0], f[:-1]]))) for f in (fault, fault_y))
    fault_logs = sum("fault mask" in m for m in events)    # either mask's (the frontal: "frontal fault mask")
    nonfinite_logs = sum("non-finite input" in m for m in warnings)
    need = sc.expect.min_cycles if sc.expect.min_cycles is not None else (
        len(sc.push.events()) if 3 in sc.expect.phases_reached else 0)    # a cycle per push where the hip strategy is expected
    most = max(need, len(sc.push.events()))     # more cycles than pushes: the hip strategy without a push
    cycles = count_cycles(res.data["phase"])
    ok = (nonfinite_out == 0 and unflagged == 0 and fault_logs == changes and nonfinite_logs == episodes
          and res.outcome in ("completed", "fell"))
    return {"study": study.label, "key": study.key, "level": level, "outcome": res.outcome,
            "survived": res.outcome == "completed" and need <= cycles <= most, "cycles": cycles,
            "cycles_needed": need, "cycles_most": most,
            "fell_at": res.fell_at if res.fell_at is not None else math.nan,
            "nonfinite_outputs": nonfinite_out, "nonfinite_input_rows": int(np.count_nonzero(bad_in)),
            "unflagged_rows": unflagged, "nonfinite_episodes": episodes, "nonfinite_warnings": nonfinite_logs,
            "fault_changes": changes, "fault_logs": fault_logs, "fault_bits": int(np.bitwise_or.reduce(fault)),
            "transition_pushes": len(res.transition_pushes), "invariants_ok": ok, "message": res.message,
            "wall_time": round(res.wall_time, 3)}


def robustness_point(spec: dict) -> dict[str, Any]:
    """One point of run_studies (anklehip.running.points runs it on the workers)."""
    return run_point(spec["scenario"], spec["fmu_dir"], study_by_label(spec["study"]), spec["level"])


def run_studies(scenario_path: str, studies: list[tuple[Study, list[float]]], fmu_dir: str | None = None,
                workers: int = 2, *, scheduler: str | None = None, journal: Path | None = None, key: str = "",
                restart: bool = False, worker_timeout: float | None = None):
    """Every study at every level, on Dask (anklehip.running.points, like the sweeps: journal, resumption,
    clean Ctrl-C). Returns an anklehip.running.points.Outcome."""
    from .points import run_points
    specs = [{"id": f"{s.label}@{float(x)!r}", "scenario": str(scenario_path), "fmu_dir": fmu_dir,
              "study": s.label, "level": float(x)} for s, levels in studies for x in levels]
    return run_points(robustness_point, specs, workers=workers, scheduler=scheduler, journal=journal, key=key,
                      **({} if worker_timeout is None else {"worker_timeout": worker_timeout}),
                      what=f"robustness of {Path(scenario_path).name}", label="robustness", restart=restart)


def _side(rows: list[dict], levels: list[float]) -> tuple[float | None, dict | None, bool]:
    """Walking out from the harmless level: (last level survived, first row that did not, grid end reached)."""
    by = {r["level"]: r for r in rows}
    last = None
    for x in levels:
        if not by[x]["survived"]:
            return last, by[x], False
        last = x
    return last, None, True


def summarize(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per study: the interval of levels around the harmless one in which every level survives,
    and on each side the first level that did not (None: the grid ends first)."""
    out = []
    for label in dict.fromkeys(r["study"] for r in rows):
        rr = [r for r in rows if r["study"] == label]
        st = study_by_label(label)
        d = st.default
        levels = sorted({r["level"] for r in rr})
        lo, fail_lo, _ = _side(rr, sorted((x for x in levels if x <= d), reverse=True))
        hi, fail_hi, _ = _side(rr, [x for x in levels if x >= d])
        out.append({"study": label, "key": st.key, "unit": KEY_BY_NAME[st.key].unit, "default": d,
                    "levels": levels, "low": lo, "high": hi, "fail_low": fail_lo, "fail_high": fail_hi,
                    "runs": len(rr), "invariants_ok": all(r["invariants_ok"] for r in rr),
                    "fault_bits": int(np.bitwise_or.reduce([int(r["fault_bits"]) for r in rr]))})
    return out


def _failure(r: dict | None) -> str:
    if r is None:
        return ""
    if r["outcome"] == "fell":
        return f"{r['level']:g}: fell at {r['fell_at']:.2f} s"
    if r["outcome"] != "completed":
        return f"{r['level']:g}: {r['outcome']}"
    if r["cycles"] > r["cycles_most"]:
        return f"{r['level']:g}: {r['cycles']} cycles for {r['cycles_most']} pushes"
    return f"{r['level']:g}: {r['cycles']} of {r['cycles_needed']} cycles"


def table_markdown(summary: list[dict[str, Any]]) -> str:
    """The robustness table (docs/scenarios.md). "(end)": the grid ended before a failure."""
    lines = ["| fault | key [unit] | levels swept | all cycles complete for | first failure beyond | "
             "fault bits seen | invariants |",
             "|---|---|---|---|---|---|---|"]
    for s in summary:
        lv, d = s["levels"], s["default"]
        if s["low"] is None and s["high"] is None:
            span = "none"
        else:
            lo = s["low"] if s["low"] is not None else d
            hi = s["high"] if s["high"] is not None else d
            lo_s = f"{lo:g}" + (" (end)" if lo == lv[0] and lo != d and s["fail_low"] is None else "")
            hi_s = f"{hi:g}" + (" (end)" if hi == lv[-1] and hi != d and s["fail_high"] is None else "")
            span = lo_s if lo == hi else f"{lo_s} … {hi_s}"
        fails = "; ".join(x for x in (_failure(s["fail_low"]), _failure(s["fail_high"])) if x) or "none in the grid"
        unit = f" [{s['unit']}]" if s["unit"] else ""
        bits = f"0x{s['fault_bits']:x}" if s["fault_bits"] else "0"
        inv = f"held in {s['runs']} runs" if s["invariants_ok"] else "**VIOLATED**"
        lines.append(f"| {s['study']} | `{s['key']}`{unit} | {lv[0]:g} … {lv[-1]:g} ({len(lv)}) | {span} | "
                     f"{fails} | {bits} | {inv} |")
    return "\n".join(lines) + "\n"
