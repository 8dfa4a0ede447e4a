"""Soak test: the closed loop (sagittal plant + controller) for a long time under seeded random pushes.

One pair of FMU instances runs the whole time (that is the point: state, memory and solver
behaviour of instances that live for an hour). The loop keeps no trajectory, only one row of
statistics per simulated second, so the process memory it measures is the FMUs' and the loop's,
not a growing result table.

Pushes: one every `gap` (uniform in [10, 14] s by default, first at 5 s), a trapezoid with a random
rise (0.1-0.5 s) and total duration (2 rise + 0.2 ... 2 s); forward (on the back, 2-8 N) with
probability 0.7, else backward (on the chest, -5...-2 N): inside the survivable range (a paper-shaped
pulse falls from 9.75 N on the back and -6.75 N on the chest, docs/scenarios.md).

Checks (SoakReport.problems): no fall, no error, the controller's fault output stays 0 and its
outputs finite; in the 0.5 s before every push and at the end, |theta_ankle| and |theta_hip| stay
below `erect_tol` (0.005 rad: no drift of the erect posture); the process's resident memory does not
grow after a warm-up minute (by more than 32 KiB: eight pages); the integrator's work per quiet simulated second (phase 0, no push for 5 s) in
the last quarter of the run is within 10 % of the first quarter (medians).
"""
from __future__ import annotations

import ctypes
import math
import os
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .fmu import vr_array
from ..files.scenario import PushProfile, PushSegment

WARMUP = 60.0          # [s] simulated; memory growth is measured from here
PRE_PUSH = 0.5         # [s] the posture window before each push
COUNTERS = ("cvode_steps", "rhs_evals", "root_evals", "mode_switches")


def random_pushes(duration: float, seed: int, gap: tuple[float, float] = (10.0, 14.0),
                  first: float = 5.0) -> PushProfile:
    rng = np.random.default_rng(seed)
    segs = []
    t = first
    while True:
        rise = float(rng.uniform(0.1, 0.5))
        dur = float(rng.uniform(2 * rise + 0.2, max(2.0, 2 * rise + 0.2)))
        force = float(rng.uniform(2.0, 8.0)) if rng.random() < 0.7 else float(rng.uniform(-5.0, -2.0))
        if t + dur + PRE_PUSH > duration:
            break
        segs.append(PushSegment("pulse", t=t, force=round(force, 3), duration=round(dur, 3), rise=round(rise, 3)))
        t = round(t + dur + float(rng.uniform(*gap)), 3)
    return PushProfile.from_segments(segs)


def rss_kib() -> int:
    """Resident set size of this process [KiB] (Linux /proc; 0 elsewhere)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") // 1024
    except (OSError, ValueError, IndexError):
        return 0


@dataclass
class SoakReport:
    duration: float
    seed: int
    end_time: float
    outcome: str                     # completed | fell | error
    message: str
    pushes: int
    wall_time: float
    per_second: np.ndarray           # structured: one row per simulated second
    posture: list[tuple[float, float]] = field(default_factory=list)   # (time of the window end, max |theta|)
    erect_tol: float = 0.005
    problems: list[str] = field(default_factory=list)

    def figures(self) -> dict[str, Any]:
        s = self.per_second
        warm = s[s["time"] >= WARMUP] if len(s) else s
        rss_growth = int(warm["rss_kib"][-1] - warm["rss_kib"][0]) if len(warm) > 1 else 0
        quiet = s[quiet_seconds(s)]
        q = max(1, len(s) // 4)
        first = quiet[quiet["time"] <= s["time"][q - 1]] if len(s) else quiet
        last = quiet[quiet["time"] > s["time"][-q]] if len(s) else quiet
        med = lambda a, c: float(np.median(a[c])) if len(a) else math.nan  # noqa: E731
        return {
            "simulated_s": self.end_time, "pushes": self.pushes, "outcome": self.outcome,
            "wall_s": round(self.wall_time, 1), "real_time_factor": round(self.end_time / self.wall_time, 1),
            "worst_posture_before_push_rad": max((p for _, p in self.posture), default=math.nan),
            "rss_kib_after_warmup": int(warm["rss_kib"][0]) if len(warm) else 0,
            "rss_growth_kib": rss_growth,
            "quiet_seconds": len(quiet),
            "cvode_steps_per_quiet_s_first_quarter": med(first, "cvode_steps"),
            "cvode_steps_per_quiet_s_last_quarter": med(last, "cvode_steps"),
            "rhs_evals_per_quiet_s_first_quarter": med(first, "rhs_evals"),
            "rhs_evals_per_quiet_s_last_quarter": med(last, "rhs_evals"),
            "cvode_steps_per_s_max": int(s["cvode_steps"].max()) if len(s) else 0,
            "mode_switches": int(s["mode_switches"].sum()) if len(s) else 0,
        }

    def check(self, rss_tol_kib: int = 32, solver_tol: float = 0.10) -> list[str]:
        f = self.figures()
        p = []
        if self.outcome != "completed":
            p.append(f"the run did not complete: {self.outcome} ({self.message})")
        s = self.per_second
        if len(s) and s["fault"].any():
            i = int(np.argmax(s["fault"] != 0))
            p.append(f"controller fault 0x{int(s['fault'][i]):x} in the second ending at t={s['time'][i]:g} s")
        if len(s) and not s["outputs_finite"].all():
            p.append("a controller output was not finite")
        for t, th in self.posture:
            if not th < self.erect_tol:
                p.append(f"posture before t={t:.2f} s: max |theta| {th:.5f} rad >= {self.erect_tol} rad")
        if f["rss_growth_kib"] > rss_tol_kib:
            p.append(f"resident memory grew by {f['rss_growth_kib']} KiB after the warm-up (tolerance {rss_tol_kib})")
        for c in ("cvode_steps", "rhs_evals"):
            a, b = f[f"{c}_per_quiet_s_first_quarter"], f[f"{c}_per_quiet_s_last_quarter"]
            if math.isnan(a) or math.isnan(b):      # too short a run to have quiet seconds in both quarters
                continue
            if not (abs(b / a - 1) <= solver_tol if a > 0 else b == a):
                p.append(f"{c} per quiet second changed from {a:g} (first quarter) to {b:g} (last quarter)")
        self.problems = p
        return p


QUIET_AFTER = 5        # [s] a quiet second: phase 0, no push in it nor in the 5 s before


def quiet_seconds(s: np.ndarray) -> np.ndarray:
    """Mask of the per-second rows in which the robot stands at rest: phase 0, no push during the
    second or the QUIET_AFTER seconds before it (nor the start's settling)."""
    recent = np.convolve(s["push"].astype(int), np.ones(QUIET_AFTER + 1, int))[:len(s)] > 0
    return (s["max_phase"] == 0) & ~recent & (s["time"] > QUIET_AFTER)


PER_SECOND_DTYPE = [("time", float), ("rss_kib", np.int64), ("push", np.int8), ("max_abs_theta", float),
                    ("max_phase", np.int8), ("fault", np.int32), ("outputs_finite", np.int8)] + \
                   [(c, np.int64) for c in COUNTERS]


def soak(duration: float = 3600.0, seed: int = 1, fmu_dir=None, step: float = 1e-3, erect_tol: float = 0.005,
         progress: bool = False) -> SoakReport:
    from .fmu import DISCARD, Slave
    from .master import Models
    models = Models.load(fmu_dir, plant_model="sagittal")
    ci, pi = models.controller, models.plant
    push = random_pushes(duration, seed)
    n = int(round(duration / step))
    per_s = int(round(1.0 / step))
    starts = [a for a, _ in push.events()]
    # The push force and the pre-push posture windows are made one simulated second at a time, into
    # buffers reused every second, so that nothing the loop holds grows with the duration. (Whole-run
    # tables of 9 B per step made the resident memory 83 MB for an hour and 367 MB for ten, flat
    # after the warm-up: docs/reliability.md section 5.) The force is bit for bit what
    # push.step_averages(0, step, n) gives: the same edges step * k.
    windows = [(int(round((a - PRE_PUSH) / step)), int(round(a / step))) for a in starts[1:] + [duration]]
    window_end_steps = {hi - 1: a for (_, hi), a in zip(windows, starts[1:] + [duration])}
    # every array the loop writes is written once here, so that its pages are resident before
    # the memory baseline (np.zeros maps pages lazily: they would count as growth)
    force = np.zeros(per_s)
    force.fill(0.0)
    in_window = np.zeros(per_s, bool)
    in_window.fill(False)

    def second_from(k0: int) -> None:
        m = min(per_s, n - k0)
        force[:m] = np.diff(push.integral(step * np.arange(k0, k0 + m + 1))) / step
        in_window[:] = False
        for lo, hi in windows:
            if hi > k0 and lo < k0 + m:
                in_window[max(lo, k0) - k0:min(hi, k0 + m) - k0] = True

    c_in = [v.name for v in ci.by_causality("input")]
    c_out_real = [v.name for v in ci.by_causality("output") if v.type == "Real"]
    p_in = [v.name for v in pi.by_causality("input") if v.name != "push_force"]
    vr = lambda info, names: vr_array([info.vars[x].vr for x in names])  # noqa: E731
    vr_p_out, vr_c_in = vr(pi, c_in), vr(ci, c_in)
    vr_c_out = vr(ci, c_out_real)
    i_feed = [c_out_real.index(x) for x in p_in]
    vr_p_in = vr(pi, p_in + ["push_force"])
    vr_c_int = vr(ci, ["phase", "fault"])
    vr_counters = vr(pi, list(COUNTERS))
    sens = (ctypes.c_double * len(c_in))()
    cout = (ctypes.c_double * len(c_out_real))()
    pin = (ctypes.c_double * (len(p_in) + 1))()
    cint = (ctypes.c_int * 2)()
    cnt = (ctypes.c_int * len(COUNTERS))()
    ia, ih = c_in.index("theta_ankle"), c_in.index("theta_hip")

    rows = np.zeros(n // per_s + 1, dtype=PER_SECOND_DTYPE)
    rows.fill(0)
    posture_t = np.full(len(window_end_steps), np.nan)
    posture_th = np.full(len(window_end_steps), np.nan)
    n_posture = 0
    outcome, message = "completed", ""
    ctrl = Slave(ci, "controller")
    plant = Slave(pi, "plant")
    wall0 = time.perf_counter()
    k = 0
    row = 0
    try:
        ctrl.initialize(0.0, duration, {})
        plant.initialize(0.0, duration, {})
        pc, cc = plant.c, ctrl.c
        p_getR, p_getI, p_setR, p_step = plant.get_real, plant.get_integer, plant.set_real, plant.do_step
        c_getR, c_getI, c_setR, c_step = ctrl.get_real, ctrl.get_integer, ctrl.set_real, ctrl.do_step
        prev = np.zeros(len(COUNTERS), np.int64)
        sec_theta, sec_phase, sec_fault, sec_finite, sec_push = 0.0, 0, 0, True, False
        win_theta = 0.0
        bar = None
        if progress:
            from tqdm import tqdm
            bar = tqdm(total=duration, unit="s sim", leave=False, disable=None)   # off on a non-TTY
        for k in range(n):
            t = k * step
            if k % per_s == 0:
                second_from(k)
            ks = k % per_s
            st = p_getR(pc, vr_p_out, len(c_in), sens)
            st |= c_setR(cc, vr_c_in, len(c_in), sens)
            sc = c_step(cc, t, step, 1)
            st |= c_getR(cc, vr_c_out, len(c_out_real), cout)
            st |= c_getI(cc, vr_c_int, 2, cint)
            for j, i in enumerate(i_feed):
                pin[j] = cout[i]
            pin[len(p_in)] = force[ks]
            st |= p_setR(pc, vr_p_in, len(p_in) + 1, pin)
            sp = p_step(pc, t, step, 1)
            if sp > 1 or sc > 1 or st > 1:
                outcome = "fell" if sp == DISCARD else "error"
                message = f"t={t:.3f} s: plant status {sp}, controller status {sc}, get/set status {st}"
                break
            th = max(abs(sens[ia]), abs(sens[ih]))
            sec_theta = max(sec_theta, th)
            sec_phase = max(sec_phase, cint[0])
            sec_fault |= cint[1]
            sec_push = sec_push or force[ks] != 0.0
            if not math.isfinite(sum(cout)):    # NaN / Inf propagate through the sum
                sec_finite = False
            if in_window[ks]:
                win_theta = max(win_theta, th)
                if k in window_end_steps:
                    posture_t[n_posture], posture_th[n_posture] = window_end_steps[k], win_theta
                    n_posture += 1
                    win_theta = 0.0
            if (k + 1) % per_s == 0:
                p_getI(pc, vr_counters, len(COUNTERS), cnt)
                now = np.array(cnt[:], np.int64)
                rows[row] = (t + step, rss_kib(), int(sec_push), sec_theta, sec_phase,
                             sec_fault, int(sec_finite), *(now - prev))
                prev = now
                row += 1
                sec_theta, sec_phase, sec_fault, sec_finite, sec_push = 0.0, 0, 0, True, False
                if bar is not None:
                    bar.update(1.0)
        else:
            k = n
        if bar is not None:
            bar.close()
    except Exception as e:      # keep the statistics gathered so far
        outcome, message = "error", f"{type(e).__name__}: {e}"
    finally:
        for s in (plant, ctrl):
            s.free(terminate=outcome == "completed")
    rep = SoakReport(duration=duration, seed=seed, end_time=k * step, outcome=outcome, message=message,
                     pushes=len(starts), wall_time=time.perf_counter() - wall0, per_second=rows[:row],
                     posture=list(zip(posture_t[:n_posture].tolist(), posture_th[:n_posture].tolist())),
                     erect_tol=erect_tol)
    rep.check()
    return rep
