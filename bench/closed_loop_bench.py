#!/usr/bin/env python3
"""Closed-loop co-simulation benchmark (not a test): prints

* the master's wall time for a scenario and its real-time factor (uninstrumented run),
* the median wall time per closed-loop step, split into the plant's fmi2DoStep, the controller's
  fmi2DoStep and the rest (get/set calls through ctypes and the Python loop),
* the cost of one FMPy call: the raw ctypes entry point with prebuilt arrays (what the master
  uses) against FMU2Slave.getReal/setReal (which build ctypes arrays on every call),
* the same closed loop written with FMU2Slave's high-level methods, for comparison.

Usage:  .venv/bin/python bench/closed_loop_bench.py [SCENARIO] [--stop-time T] [--quick]
(--quick: every run only 2 s long, for the test suite's check that the benchmark still runs)
FMUs: $ANKLEHIP_FMU_DIR or <repo>/build/fmus.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from anklehip.running.fmu import Slave, vr_array
from anklehip.running.master import Models, _Layout, simulate
from anklehip.files.paths import find_scenario
from anklehip.files.scenario import load_scenario


def instrumented(models: Models, sc, T: float):
    L = _Layout(models)
    h = sc.step
    n = int(round(T / h))
    push = sc.push.step_averages(0.0, h, n)
    ctrl, plant = Slave(models.controller, "c"), Slave(models.plant, "p")
    ctrl.initialize(0.0, T, sc.controller)
    plant.initialize(0.0, T, sc.plant)
    R = np.zeros(len(L.real_cols))
    I = np.zeros(max(1, len(L.int_cols)), np.int32)
    bR, bI = R.ctypes.data, I.ctypes.data
    vpR, vpI, vpB = (vr_array([v.vr for v in x]) for x in (L.p_real, L.p_int, L.p_bool))
    vcin, vcF, vcO, vcI = (vr_array([v.vr for v in x]) for x in (L.c_in, L.c_feed, L.c_other, L.c_int))
    vpin = vr_array([v.vr for v in L.p_in])
    npR, npI, npB, ncin, ncF, ncO, ncI, npin = (len(x) for x in (L.p_real, L.p_int, L.p_bool, L.c_in, L.c_feed,
                                                                   L.c_other, L.c_int, L.p_in))
    oF, oO, oPB, oCI = 8 * L.off_feed, 8 * L.off_cother, 4 * L.off_pbool, 4 * L.off_cint
    tot = np.zeros(n, np.int64)
    tp = np.zeros(n, np.int64)
    tc = np.zeros(n, np.int64)
    clk = time.perf_counter_ns
    pc, cc = plant.c, ctrl.c
    for k in range(n):
        t = k * h
        a = clk()
        plant.get_real(pc, vpR, npR, bR)
        plant.get_integer(pc, vpI, npI, bI)
        plant.get_boolean(pc, vpB, npB, bI + oPB)
        ctrl.set_real(cc, vcin, ncin, bR)
        b = clk()
        sc_ = ctrl.do_step(cc, t, h, 1)
        c = clk()
        ctrl.get_real(cc, vcF, ncF, bR + oF)
        ctrl.get_real(cc, vcO, ncO, bR + oO)
        ctrl.get_integer(cc, vcI, ncI, bI + oCI)
        R[L.off_push] = push[k]
        plant.set_real(pc, vpin, npin, bR + oF)
        d = clk()
        sp = plant.do_step(pc, t, h, 1)
        e = clk()
        tot[k], tc[k], tp[k] = e - a, c - b, e - d
        if sp > 1 or sc_ > 1:
            n = k + 1
            break
    ctrl.free()
    plant.free()
    return tot[:n] / 1e3, tp[:n] / 1e3, tc[:n] / 1e3


def call_overhead(models: Models, n: int = 20000):
    s = Slave(models.controller, "c")
    s.initialize(0.0, 1.0, {})
    names = ["theta_ankle", "theta_hip", "zmp_x", "fz"]
    vrs = [models.controller.vars[x].vr for x in names]
    va = vr_array(vrs)
    buf = np.zeros(4)
    clk = time.perf_counter_ns
    a = clk()
    for _ in range(n):
        s.get_real(s.c, va, 4, buf.ctypes.data)
    raw_get = (clk() - a) / n / 1e3
    a = clk()
    for _ in range(n):
        s.set_real(s.c, va, 4, buf.ctypes.data)
    raw_set = (clk() - a) / n / 1e3
    a = clk()
    for _ in range(n):
        s.fmu.getReal(vrs)
    hi_get = (clk() - a) / n / 1e3
    vals = [0.0, 0.0, 0.0, 70.0]
    a = clk()
    for _ in range(n):
        s.fmu.setReal(vrs, vals)
    hi_set = (clk() - a) / n / 1e3
    s.free()
    return raw_get, raw_set, hi_get, hi_set


def high_level_loop(models: Models, sc, T: float) -> float:
    """The same closed loop with FMU2Slave.getReal/setReal/doStep and name look-ups."""
    ctrl, plant = Slave(models.controller, "c"), Slave(models.plant, "p")
    ctrl.initialize(0.0, T, sc.controller)
    plant.initialize(0.0, T, sc.plant)
    cv, pv = models.controller.vars, models.plant.vars
    h = sc.step
    n = int(round(T / h))
    push = sc.push.step_averages(0.0, h, n)
    ins = ["theta_ankle", "theta_hip", "zmp_x", "fz"]
    a = time.perf_counter()
    for k in range(n):
        y = plant.fmu.getReal([pv[x].vr for x in ins])
        ctrl.fmu.setReal([cv[x].vr for x in ins], y)
        ctrl.fmu.doStep(k * h, h)
        u = ctrl.fmu.getReal([cv["theta_ankle_ref"].vr, cv["theta_hip_ref"].vr])
        plant.fmu.setReal([pv["theta_ankle_ref"].vr, pv["theta_hip_ref"].vr, pv["push_force"].vr], u + [push[k]])
        try:
            plant.fmu.doStep(k * h, h)
        except Exception:
            n = k + 1
            break
    wall = time.perf_counter() - a
    ctrl.free()
    plant.free()
    return wall / n * 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario", nargs="?", default="paper_five_pushes")
    ap.add_argument("--stop-time", type=float, help="instrumented/high-level runs: simulate only this long "
                    "(default: min(scenario, 20 s))")
    ap.add_argument("--quick", action="store_true", help="every run 2 s long (a smoke run, not figures to quote)")
    a = ap.parse_args()
    sc = load_scenario(find_scenario(a.scenario))
    models = Models.load()
    T = 2.0 if a.quick else a.stop_time or min(sc.stop_time, 20.0)

    res = simulate(sc, models, progress=False, stop_time=T if a.quick else None)
    print(f"scenario {sc.name}: {res.message or res.outcome}, {res.end_time:.3f} s simulated in {res.steps} steps "
          f"of {1e3 * sc.step:g} ms")
    print(f"  master (uninstrumented): wall {res.wall_time:.3f} s, {1e6 * res.wall_time / max(1, res.steps):.1f} µs/step "
          f"mean, real-time factor {res.end_time / res.wall_time:.2f}")

    tot, tp, tc = instrumented(models, sc, T)
    other = tot - tp - tc
    print(f"  instrumented, first {T:g} s ({len(tot)} steps), median [µs]: step {np.median(tot):.1f}  "
          f"plant doStep {np.median(tp):.1f}  controller doStep {np.median(tc):.1f}  get/set+loop {np.median(other):.1f}")
    print(f"                                     p99 [µs]: step {np.percentile(tot, 99):.1f}  "
          f"plant doStep {np.percentile(tp, 99):.1f}  controller doStep {np.percentile(tc, 99):.1f}")
    print(f"  mean share of the step: plant {100 * tp.sum() / tot.sum():.0f} %, controller {100 * tc.sum() / tot.sum():.0f} %, "
          f"FMPy/ctypes get/set + Python {100 * other.sum() / tot.sum():.0f} %")

    rg, rs, hg, hs = call_overhead(models)
    print(f"  one call, 4 reals [µs]: raw ctypes fmi2GetReal {rg:.2f}, fmi2SetReal {rs:.2f};  "
          f"FMU2Slave.getReal {hg:.2f}, .setReal {hs:.2f}")
    hl = high_level_loop(models, sc, T)
    print(f"  same loop with FMU2Slave methods: {hl:.1f} µs/step (mean) vs {np.mean(tot):.1f} µs/step (mean, raw)")


if __name__ == "__main__":
    main()
