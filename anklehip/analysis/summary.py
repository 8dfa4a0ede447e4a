"""What a run shows: the per-push summary, the expected-outcome checks, the summary dict and text."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..running.master import RunResult
from ..files.scenario import Expect, PushProfile, Scenario

PHASE_NAMES = {0: "ankle", 1: "ankle->hip", 2: "hip", 3: "hip->ankle"}


# ----------------------------------------------------------------------------------------------
# per-push summary

@dataclass
class PushSummary:
    """One push of a run: when, how strong (peak force [N], impulse [N s]), the peak ZMP [m] and
    when, the controller phases it caused, the peak joint angles [rad], and when the robot was
    back in phase 0 and erect (None: it was not, before the next push or the end)."""
    index: int
    start: float
    end: float
    peak_force: float
    impulse: float
    peak_zmp: float
    peak_zmp_time: float
    phases: list[int]
    peak_hip: float
    peak_ankle: float
    recovered_at: float | None          # first time after the push from which the robot stays
    time_to_recover: float | None       # in phase 0 and within erect_tol of erect (window end)

    def line(self) -> str:
        ph = "".join(str(p) for p in self.phases) or "-"
        rec = f"{self.time_to_recover:6.2f} s" if self.time_to_recover is not None else "   never"
        return (f"push {self.index + 1}: t={self.start:6.2f}-{self.end:6.2f} s  peak {self.peak_force:+7.2f} N  "
                f"impulse {self.impulse:+6.2f} N s  peak ZMP {1000 * self.peak_zmp:+6.1f} mm  "
                f"phases {ph:<5} peak hip {math.degrees(self.peak_hip):+6.2f} deg  "
                f"recovered {rec} after the push")


def push_windows(push: PushProfile, t_end: float, merge_gap: float = 0.0) -> list[tuple[float, float, float]]:
    """(start, end, window end) per push; a window lasts until the next push starts."""
    ev = [(a, min(b, t_end)) for a, b in push.events() if a < t_end]
    out = []
    for i, (a, b) in enumerate(ev):
        w = ev[i + 1][0] if i + 1 < len(ev) else t_end
        out.append((a, b, w))
    return out


def summarize_pushes(res: RunResult, push: PushProfile, erect_tol: float = 0.02) -> list[PushSummary]:
    d = res.data
    t = d["time"]
    names = d.dtype.names
    phase = d["phase"] if "phase" in names else np.zeros(len(t), int)
    th1, th2 = d["theta_ankle"], d["theta_hip"]
    zmp = d["zmp_x"]
    f = d["push_force"]
    out = []
    for i, (a, b, w) in enumerate(push_windows(push, float(t[-1]))):
        m = (t >= a) & (t <= w)
        if not m.any():
            continue
        mp = (t >= a) & (t < max(b, a + res.step))
        fpk = f[mp][np.argmax(np.abs(f[mp]))] if mp.any() else 0.0
        imp = float(push.integral(b) - push.integral(a)) if math.isfinite(b) else float("nan")
        iz = np.argmax(np.abs(zmp[m]))
        ph = sorted(set(int(x) for x in np.unique(phase[m])))
        ok = (phase == 0) & (np.abs(th1 - res.erect[0]) <= erect_tol) & (np.abs(th2 - res.erect[1]) <= erect_tol)
        after = (t >= b) & (t <= w)
        rec = None
        if after.any() and not (res.fell and w >= res.end_time):
            okw = ok[after]
            if okw[-1]:
                bad = np.flatnonzero(~okw)
                k0 = bad[-1] + 1 if len(bad) else 0
                rec = float(t[after][k0])
        out.append(PushSummary(index=i, start=a, end=b, peak_force=float(fpk), impulse=imp,
                               peak_zmp=float(zmp[m][iz]), peak_zmp_time=float(t[m][iz]), phases=ph,
                               peak_hip=float(th2[m][np.argmax(np.abs(th2[m]))]),
                               peak_ankle=float(th1[m][np.argmax(np.abs(th1[m]))]),
                               recovered_at=rec, time_to_recover=None if rec is None else rec - b))
    return out


def count_cycles(phase: np.ndarray) -> int:
    """Complete push cycles in a phase signal: excursions from phase 0 that enter phase 1 first,
    reach phase 2, and come back to 0 from phase 3 (2 <-> 3 back-and-forth inside allowed)."""
    if not len(phase):
        return 0
    ch = np.flatnonzero(np.diff(phase) != 0) + 1
    seq = [int(phase[0])] + [int(phase[i]) for i in ch]
    n = 0
    exc: list[int] | None = None
    for p in seq:
        if p == 0:
            if exc and exc[0] == 1 and 2 in exc and exc[-1] == 3:
                n += 1
            exc = []
        elif exc is not None:
            exc.append(p)
    return n


# ----------------------------------------------------------------------------------------------
# expectations

@dataclass
class Check:
    """One expectation of the scenario's [expect] table and whether the run met it."""
    name: str
    ok: bool
    detail: str


def check_expect(res: RunResult, e: Expect) -> list[Check]:
    d = res.data
    t = d["time"]
    names = d.dtype.names
    out: list[Check] = []
    if res.outcome in ("error", "interrupted"):
        out.append(Check("run", False, res.message))
        return out
    if e.must_fall is not None:
        if e.must_fall:
            ok = res.fell
            det = res.message if res.fell else "did not fall"
            if ok and e.fall_after is not None and res.fell_at < e.fall_after:
                ok, det = False, f"fell at {res.fell_at:.3f} s, before {e.fall_after:g} s"
            if ok and e.fall_before is not None and res.fell_at > e.fall_before:
                ok, det = False, f"fell at {res.fell_at:.3f} s, after {e.fall_before:g} s"
            out.append(Check("must_fall", ok, det))
        else:
            out.append(Check("must_not_fall", not res.fell, res.message if res.fell else "stood"))
    phase = d["phase"] if "phase" in names else None
    if phase is not None:
        seen = set(int(x) for x in np.unique(phase))
        for p in e.phases_reached:
            out.append(Check(f"phase {p} reached", p in seen, f"phases seen: {sorted(seen)}"))
        for p in e.phases_not_reached:
            det = f"phases seen: {sorted(seen)}"
            if p in seen:
                det += f"; phase {p} first at t={t[np.argmax(phase == p)]:.3f} s"
            out.append(Check(f"phase {p} not reached", p not in seen, det))
        if e.min_cycles is not None:
            n = count_cycles(phase)
            out.append(Check("cycles", n >= e.min_cycles, f"{n} complete 0-1-2-3-0 cycles (need {e.min_cycles})"))
    if e.phases_y_reached or e.min_cycles_y is not None:
        # the 3D controller's frontal phases (a result without phase_y fails these checks)
        phase_y = d["phase_y"] if "phase_y" in names else None
        seen_y = set(int(x) for x in np.unique(phase_y)) if phase_y is not None else set()
        det = f"frontal phases seen: {sorted(seen_y)}" if phase_y is not None else "no phase_y column (not the 3D controller)"
        for p in e.phases_y_reached:
            out.append(Check(f"frontal phase {p} reached", p in seen_y, det))
        if e.min_cycles_y is not None:
            n = count_cycles(phase_y) if phase_y is not None else 0
            out.append(Check("frontal cycles", n >= e.min_cycles_y,
                             f"{n} complete frontal 0-1-2-3-0 cycles (need {e.min_cycles_y})"))
    if e.erect_by is not None:
        m = t >= e.erect_by
        if res.end_time < e.erect_by or not m.any():
            out.append(Check("erect_by", False, f"run ended at {res.end_time:.3f} s before {e.erect_by:g} s"))
        else:
            e1, e2 = res.erect
            ok = (np.abs(d["theta_ankle"][m] - e1) <= e.erect_tol) & (np.abs(d["theta_hip"][m] - e2) <= e.erect_tol)
            if phase is not None:
                ok &= phase[m] == 0
            det = f"phase 0 and |theta - theta_erect| <= {e.erect_tol:g} rad from {e.erect_by:g} s"
            if {"phase_y", "phi_ref", "psi_ref"} <= set(names):
                # the 3D controller: erect in the frontal plane too (frontal phase 0, legs and
                # upper body back to level within the same tolerance)
                ok &= (d["phase_y"][m] == 0) & (np.abs(d["phi_ref"][m]) <= e.erect_tol) & \
                      (np.abs(d["psi_ref"][m]) <= e.erect_tol)
                det += " (both planes: phase_y 0, |phi_ref|, |psi_ref| too)"
            if e1 or e2:
                det += f" (erect posture {e1:+.4f}, {e2:+.4f} rad)"
            if not ok.all():
                k = np.argmax(~ok)
                det += (f": violated at t={t[m][k]:.3f} s (phase {int(phase[m][k]) if phase is not None else '?'}, "
                        f"theta_ankle {d['theta_ankle'][m][k]:+.4f}, theta_hip {d['theta_hip'][m][k]:+.4f})")
            out.append(Check("erect_by", bool(ok.all()), det))
    if e.max_abs_zmp is not None:
        z = np.abs(d["zmp_x"])
        k = int(np.argmax(z))
        out.append(Check("max_abs_zmp", bool(z[k] <= e.max_abs_zmp),
                         f"max |zmp_x| {1000 * z[k]:.1f} mm at t={t[k]:.3f} s (limit {1000 * e.max_abs_zmp:.1f} mm)"))
    for col, limit in e.max_abs.items():
        if col not in names:
            out.append(Check(f"max_abs {col}", False, f"expect.max_abs.{col}: no column {col!r} in the results"))
            continue
        a = np.abs(d[col])
        k = int(np.argmax(a))
        out.append(Check(f"max_abs {col}", bool(a[k] <= limit), f"max |{col}| {a[k]:.4g} at t={t[k]:.3f} s (limit {limit:g})"))
    for col, least in e.min_range.items():
        if col not in names:
            out.append(Check(f"min_range {col}", False, f"expect.min_range.{col}: no column {col!r} in the results"))
            continue
        rng = float(np.max(d[col]) - np.min(d[col]))
        out.append(Check(f"min_range {col}", rng >= least, f"{col} spans {rng:.4g} (need {least:g})"))
    if e.no_fault and "fault" in names:
        f = d["fault"]
        bad = np.flatnonzero(f != 0)
        out.append(Check("no_fault", len(bad) == 0,
                         "no fault" if not len(bad) else f"fault {int(f[bad[0]])} at t={t[bad[0]]:.3f} s"))
    return out


# ----------------------------------------------------------------------------------------------
# summary

def summary_dict(sc: Scenario, res: RunResult, pushes: list[PushSummary], checks: list[Check],
                 files: dict[str, str], comparison: dict | None = None) -> dict[str, Any]:
    d = res.data
    names = d.dtype.names
    return {
        "scenario": sc.name,
        "description": sc.description,
        "outcome": res.outcome,
        "complete": res.complete,
        "message": res.message or ("completed" if res.complete else res.outcome),
        "fell_at": res.fell_at,
        "end_time": res.end_time,
        "stop_time": res.stop_time,
        "step": res.step,
        "steps": res.steps,
        "wall_time_s": round(res.wall_time, 3),
        "real_time_factor": round(res.end_time / res.wall_time, 2) if res.wall_time > 0 else None,
        "max_abs_zmp_m": float(np.max(np.abs(d["zmp_x"]))) if "zmp_x" in names else None,
        "max_abs_theta_hip_rad": float(np.max(np.abs(d["theta_hip"]))) if "theta_hip" in names else None,
        "phases_seen": sorted(int(x) for x in np.unique(d["phase"])) if "phase" in names else None,
        "cycles": count_cycles(d["phase"]) if "phase" in names else None,
        "pushes": [p.__dict__ for p in pushes],
        "checks": [c.__dict__ for c in checks],
        "expectations_met": all(c.ok for c in checks),
        "comparison": comparison,
        "controller_config": sc.controller_config,
        "overrides": {"controller": sc.controller, "plant": sc.plant},
        "faults": res.faults,
        "transition_pushes": res.transition_pushes,
        "files": files,
        **({"robot": robot_summary(sc, res, pushes)} if getattr(sc, "robot_run", None) is not None else {}),
    }


def robot_summary(sc: Scenario, res: RunResult, pushes: list[PushSummary]) -> dict[str, Any]:
    """The robot a scenario ran on (anklehip.robot) and the run in its units: each push's peak force
    as a fraction of the static tipping force, peak ZMP as a fraction of the toe (heel for a push on
    the chest), recovery time in pendulum time constants."""
    run = sc.robot_run
    s = run.summary()
    toe, heel = s["toe_x_m"], s["heel_x_m"]
    s["pushes"] = [{"peak_force_fraction": p.peak_force / (run.tipping[0] if p.peak_force >= 0 else -run.tipping[1]),
                    "peak_zmp_fraction": abs(p.peak_zmp) / (toe if p.peak_zmp >= 0 else -heel),
                    "peak_hip_rad": p.peak_hip,
                    "recovery_T_p": None if p.time_to_recover is None else p.time_to_recover / run.T_p}
                   for p in pushes]
    return s


def format_summary(s: dict[str, Any], pushes: list[PushSummary]) -> str:
    lines = [f"scenario {s['scenario']}: {s['message']}  ({s['end_time']:.3f} of {s['stop_time']:g} s simulated, "
             f"{s['steps']} steps, wall {s['wall_time_s']:.2f} s, real-time factor {s['real_time_factor']})"]
    r = s.get("robot")
    if r:
        lines.append(f"  robot {r['name']}: {r['mass_kg']:.2f} kg, CoM {r['com_height_m']:.3f} m above the ankle, "
                     f"T_p {1000 * r['pendulum_time_s']:.1f} ms, static tipping force {r['static_tipping_force_N'][0]:.2f} N; "
                     f"times x{r['time_factor']:.4g}, forces x{r['force_factor'][0]:.4g} (docs/your-robot.md)")
    for i, p in enumerate(pushes):
        lines.append("  " + p.line())
        if r and i < len(r["pushes"]):
            q = r["pushes"][i]
            rec = f"{q['recovery_T_p']:.2f} T_p" if q["recovery_T_p"] is not None else "never"
            lines.append(f"          robot units: peak {q['peak_force_fraction']:.3f} of the tipping force, peak ZMP "
                         f"{q['peak_zmp_fraction']:.3f} of the sole edge, recovered after {rec}")
    for c in s["checks"]:
        lines.append(f"  [{'PASS' if c['ok'] else 'FAIL'}] {c['name']}: {c['detail']}")
    if s.get("comparison"):
        cmp = s["comparison"]
        lines.append(f"  [{'PASS' if cmp['passed'] else 'FAIL'}] reference {cmp['reference']}: "
                     f"{cmp['n_failed']} of {cmp['n_signals']} signals outside the band")
    for w in s.get("warnings", []):
        lines.append(f"  [WARN] {w}")
    for k, v in s["files"].items():
        lines.append(f"  {k}: {v}")
    return "\n".join(lines)
