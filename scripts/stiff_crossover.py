#!/usr/bin/env python3
"""Where Hoap2Plant's explicit integrator stops paying: both integrators on the same run while the
servo gains grow, with the plant's fastest mode (the rate the automatic integrator decides on,
docs/plant.md section 7, "Stiff servo gains").

    .venv/bin/python scripts/stiff_crossover.py [--fmu build/fmus/Hoap2Plant.fmu] [--stop-time 0.5]

For each gain scale s (kp and kd of both servos times s): the fastest rate |lambda| the FMU logs at
initialization, then the wall time and integrator steps of a run with 1 ms communication steps
(set points moving at every step, as the controller moves them, and a 5 N push) with integrator
= 0 (ERK) and = 1 (BDF). ERK forced with gains past the threshold is refused by the FMU: such a
row shows the run with the threshold lifted out of the way is not possible, so the row reports
the refusal. Figures, not pass/fail.
"""
from __future__ import annotations

import argparse
import ctypes
import math
import sys
import tempfile
import time
import zipfile
from pathlib import Path

from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2CallbackAllocateMemoryTYPE, \
    fmi2CallbackFreeMemoryTYPE, fmi2StepFinishedTYPE

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = {"kp_ankle": 400.0, "kd_ankle": 20.0, "kp_hip": 150.0, "kd_hip": 5.0}


def run(unzip: str, md, scale: float, integrator: int, stop: float, gains=tuple(DEFAULT)):
    log: list[str] = []

    def logger(env, name, status, category, message):
        log.append(message.decode())

    libc = ctypes.CDLL(None)
    libc.calloc.restype = ctypes.c_void_p
    libc.calloc.argtypes = [ctypes.c_size_t, ctypes.c_size_t]
    libc.free.argtypes = [ctypes.c_void_p]
    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(logger)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(lambda n, s: libc.calloc(n, s))
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(lambda p: libc.free(p))
    cb.stepFinished = fmi2StepFinishedTYPE()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="x")
    fmu.instantiate(callbacks=cb, loggingOn=True)
    try:
        fmu.setReal([vr[k] for k in gains], [DEFAULT[k] * scale for k in gains])
        fmu.setInteger([vr["integrator"]], [integrator])
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        try:
            fmu.exitInitializationMode()
        except Exception:
            return None, [m for m in log if "integrator" in m]
        refs = [vr["theta_ankle_ref"], vr["theta_hip_ref"], vr["push_force"]]
        n = int(round(stop / 1e-3))
        t0 = time.perf_counter()
        for k in range(n):
            t = k * 1e-3
            fmu.setReal(refs, [0.01 * math.sin(2 * math.pi * t), 0.02 * math.sin(2 * math.pi * t),
                               5.0 if 0.1 <= t < 0.3 else 0.0])
            fmu.doStep(t, 1e-3)
        wall = time.perf_counter() - t0
        steps = fmu.getInteger([vr["cvode_steps"]])[0]
        return (wall, steps), log
    finally:
        fmu.freeInstance()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fmu", default=str(ROOT / "build" / "fmus" / "Hoap2Plant.fmu"))
    ap.add_argument("--stop-time", type=float, default=0.5)
    ap.add_argument("--scales", default="1,10,30,100,300,500,700,1000,2500")
    ap.add_argument("--gains", default=",".join(DEFAULT), help="the gains scaled (default: all four)")
    a = ap.parse_args(argv)
    md = read_model_description(a.fmu)
    with tempfile.TemporaryDirectory() as d:
        zipfile.ZipFile(a.fmu).extractall(d)
        print(f"{'scale':>6} {'kd_ankle':>9} {'kd_hip':>8} {'fastest 1/s':>12} {'ERK wall s':>10} {'ERK steps':>10} "
              f"{'BDF wall s':>10} {'BDF steps':>10} {'ERK/BDF':>8}  automatic")
        for s in (float(x) for x in a.scales.split(",")):
            g = tuple(a.gains.split(","))
            _, log = run(d, md, s, 2, 0.001, g)
            auto = next((m for m in log if m.startswith("integrator = 2")), "")
            rate = float(auto.split("decays at ")[1].split(" ")[0]) if "decays at" in auto else float("nan")
            erk, elog = run(d, md, s, 0, a.stop_time, g)
            bdf, _ = run(d, md, s, 1, a.stop_time, g)
            choice = "BDF" if "BDF (CVODE)" in auto else "ERK"
            e = f"{erk[0]:10.3f} {erk[1]:10d}" if erk else f"{'refused':>10} {'':>10}"
            ratio = f"{erk[0] / bdf[0]:8.2f}" if erk else f"{'-':>8}"
            kd = [DEFAULT[k] * (s if k in g else 1.0) for k in ("kd_ankle", "kd_hip")]
            print(f"{s:6g} {kd[0]:9g} {kd[1]:8g} {rate:12.4g} {e} "
                  f"{bdf[0]:10.3f} {bdf[1]:10d} {ratio}  {choice}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
