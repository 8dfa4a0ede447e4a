"""Closed-loop co-simulation master: Hoap2Plant.fmu + AnkleHipController.fmu on FMPy.

Fixed communication step h, Gauss–Seidel order per step k (t_k = k h):

    plant outputs(t_k) -> controller inputs -> controller doStep(t_k, h) -> controller outputs
    -> plant inputs (+ push force) -> plant doStep(t_k, h)

Result row k holds the plant outputs at t_k, the controller outputs read after the controller's
step from t_k (i.e. the command the plant receives during [t_k, t_k + h)) and the push force
applied during [t_k, t_k + h) (the step average of the profile). The last row holds the plant
outputs at the end (stop time or the last successful time before a fall) with the controller and
push columns repeated from the row before.

The inner loop makes only raw ctypes calls with prebuilt value-reference arrays and reads the
outputs straight into preallocated numpy arrays (no per-step allocation or dictionary look-up).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..errors import InputError, Terminated
from .faults import SENSED_PREFIX, Faults, SensorChannel, TransitionPush, parameter_faults
from .fmu import DISCARD, STATUS_NAMES, FMUError, FMUInfo, Slave, vr_array
from ..files.paths import CONTROLLER_FMUS, PLANT_FMUS, find_fmu
from ..files.scenario import PushProfile, PushSegment, Scenario, ScenarioError, time_grid_problem

CONTROLLER_INPUTS = ("theta_ankle", "theta_hip", "zmp_x", "fz")
CONTROLLER_REFS = ("theta_ankle_ref", "theta_hip_ref")
PUSH = "push_force"
PUSH_Y = "push_force_y"     # the 3D plant's sideways push (scenario key push_y)
CLASH_PREFIX = "controller."
ENGINES = ("fmpy", "native")


@dataclass
class RunResult:
    name: str
    data: np.ndarray                       # structured array, 'time' first
    outcome: str                           # completed | fell | error | interrupted
    end_time: float
    stop_time: float
    step: float
    wall_time: float
    message: str = ""
    fell_at: float | None = None
    controller_initial: dict[str, float] = field(default_factory=dict)
    controller_parameters: dict[str, Any] = field(default_factory=dict)
    controller_config: str = "default"
    controller_overrides: dict[str, Any] = field(default_factory=dict)   # config + scenario + caller
    plant_parameters: dict[str, Any] = field(default_factory=dict)
    controller_columns: dict[str, str] = field(default_factory=dict)   # column -> FMU variable
    controller_inputs: tuple[str, ...] = CONTROLLER_INPUTS   # the controller FMU's inputs, in its order
    column_units: dict[str, str] = field(default_factory=dict)
    faults: dict[str, Any] = field(default_factory=dict)     # the injected faults (non-default keys)
    transition_pushes: list[float] = field(default_factory=list)   # start times of the transition pushes
    erect: tuple[float, float] = (0.0, 0.0)   # the controller's erect posture (theta_ankle, theta_hip) [rad]

    @property
    def complete(self) -> bool:
        return self.outcome == "completed"

    @property
    def fell(self) -> bool:
        return self.outcome == "fell"

    @property
    def steps(self) -> int:
        return max(0, len(self.data) - 1)

    def column(self, name: str) -> np.ndarray:
        return self.data[name]


@dataclass
class Models:
    controller: FMUInfo
    plant: FMUInfo

    @classmethod
    def load(cls, fmu_dir=None, controller: str | Path | None = None,
             plant: str | Path | None = None, plant_model: str = "sagittal", fmi: int = 2,
             controller_model: str = "sagittal") -> "Models":
        """The controller FMU and the plant FMU: `controller` / `plant` (paths) or the FMUs of
        `controller_model` and `plant_model` (keys of paths.CONTROLLER_FMUS and PLANT_FMUS:
        "sagittal" or "3d"); fmi=3: the FMI 3.0 twins."""
        if plant_model not in PLANT_FMUS:
            raise FMUError(f"unknown plant model {plant_model!r} (known: {', '.join(PLANT_FMUS)})")
        if controller_model not in CONTROLLER_FMUS:
            raise FMUError(f"unknown controller model {controller_model!r} (known: {', '.join(CONTROLLER_FMUS)})")
        c = Path(controller) if controller else find_fmu(CONTROLLER_FMUS[controller_model], fmu_dir, fmi)
        p = Path(plant) if plant else find_fmu(PLANT_FMUS[plant_model], fmu_dir, fmi)
        return cls(FMUInfo.load(c), FMUInfo.load(p))

    @classmethod
    def for_scenario(cls, scenario, fmu_dir=None, fmi: int = 2) -> "Models":
        """The FMUs a scenario names (its plant_model and controller_model)."""
        return cls.load(fmu_dir, plant_model=scenario.plant_model, controller_model=scenario.controller_model, fmi=fmi)


def check_overrides(models: Models, controller: dict, plant: dict, origin: str = "") -> None:
    models.controller.check_overrides(controller, origin and f"{origin} [controller]")
    models.plant.check_overrides(plant, origin and f"{origin} [plant]")


class _Layout:
    """Column layout of the result arrays and the value-reference arrays of the loop."""

    def __init__(self, models: Models):
        ci, pi = models.controller, models.plant
        p_out = [v for v in pi.by_causality("output")]
        c_out = [v for v in ci.by_causality("output")]
        c_in = [v for v in ci.by_causality("input")]
        p_in = [v for v in pi.by_causality("input")]
        pnames = {v.name for v in p_out}
        # connections by name (docs/scenarios.md, "The co-simulation master")
        for v in c_in:
            if v.name not in pnames:
                raise FMUError(f"{ci.name} input {v.name!r} has no matching {pi.name} output")
            if v.type != "Real":
                raise FMUError(f"{ci.name} input {v.name!r}: only Real inputs are supported")
        cnames = {v.name for v in c_out}
        pushes = [PUSH, PUSH_Y]
        for v in p_in:
            if v.type != "Real":
                raise FMUError(f"{pi.name} input {v.name!r}: only Real inputs are supported")
        if PUSH not in {v.name for v in p_in}:
            raise FMUError(f"{pi.name} has no input {PUSH!r}")
        # plant inputs no controller output feeds (the 3D plant's roll/yaw/knee set points) stay at
        # their start values; every controller output the plant has as an input is connected
        self.unconnected = [v.name for v in p_in if v.name not in pushes and v.name not in cnames]
        # plant reals: controller inputs first (same order), so that the controller's setReal
        # reads them straight from the plant's output row
        cin_names = [v.name for v in c_in]
        p_real = [pi.vars[n] for n in cin_names] + [v for v in p_out if v.type == "Real" and v.name not in cin_names]
        # plant inputs fed by the controller, then the push: contiguous in the row
        p_in_ctrl = [v for v in p_in if v.name not in pushes and v.name in cnames]
        c_feed = [ci.vars[v.name] for v in p_in_ctrl]
        self.push_cols = [n for n in pushes if n in {v.name for v in p_in}]
        c_other = [v for v in c_out if v.type == "Real" and v.name not in {x.name for x in c_feed}]
        self.p_real, self.c_feed, self.c_other = p_real, c_feed, c_other
        self.p_in = p_in_ctrl + [pi.vars[n] for n in self.push_cols]
        self.c_in = c_in
        self.p_int = [v for v in p_out if v.type in ("Integer", "Enumeration")]
        self.p_bool = [v for v in p_out if v.type == "Boolean"]
        self.c_int = [v for v in c_out if v.type in ("Integer", "Enumeration")]
        self.c_bool = [v for v in c_out if v.type == "Boolean"]

        def cname(v):
            return CLASH_PREFIX + v.name if v.name in pnames else v.name
        self.real_cols = ([v.name for v in p_real] + [cname(v) for v in c_feed] + self.push_cols
                          + [cname(v) for v in c_other])
        self.int_cols = ([v.name for v in self.p_int] + [v.name for v in self.p_bool]
                         + [cname(v) for v in self.c_int] + [cname(v) for v in self.c_bool])
        self.controller_columns = {cname(v): v.name for v in c_feed + c_other + self.c_int + self.c_bool}
        self.units = {}
        for v in p_real:
            self.units[v.name] = v.unit or ""
        for v in c_feed + c_other:
            self.units[cname(v)] = v.unit or ""
        for n in self.push_cols:
            self.units[n] = pi.vars[n].unit or "N"
        self.off_feed = len(p_real)                   # controller refs + push(es) start here
        self.off_push = self.off_feed + len(c_feed)
        self.off_cother = self.off_push + len(self.push_cols)
        self.n_real = len(self.real_cols)
        self.off_pbool = len(self.p_int)
        self.off_cint = self.off_pbool + len(self.p_bool)
        self.off_cbool = self.off_cint + len(self.c_int)
        self.n_int = len(self.int_cols)
        self.all_cols = ["time"] + self.real_cols + self.int_cols


def scenario_parameters(scenario: Scenario, models: Models, controller_overrides: dict | None = None,
                        plant_overrides: dict | None = None, faults: Faults | None = None
                        ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The controller's and the plant's parameter values a scenario sets (checked against the
    FMUs). Precedence: the plant's robot numbers (its constant outputs named after controller
    parameters, e.g. Hoap2Plant3D's link CoM offsets: the controller knows the robot it stands
    on) < the named configuration < the scenario's [controller] / [plant] tables < the caller's
    overrides < the parameter faults (torque_scale, mass/length_mismatch: scaled from the values
    so far)."""
    origin = str(scenario.path) if scenario.path else scenario.name
    params = models.controller.parameters()
    robot = {k: v for k, v in models.plant.constants().items() if k in params}
    c_over = {**robot,
              **models.controller.configuration(scenario.controller_config, f"{origin}: controller_config"),
              **scenario.controller, **(controller_overrides or {})}
    p_over = dict(scenario.plant, **(plant_overrides or {}))
    check_overrides(models, c_over, p_over, origin)
    faults = faults if faults is not None else scenario.faults
    fc, fp = parameter_faults(faults, {**models.controller.start_values(), **c_over},
                              {**models.plant.start_values(), **p_over})
    if fc or fp:
        c_over, p_over = {**c_over, **fc}, {**p_over, **fp}
        check_overrides(models, fc, fp, f"{origin} [faults]")
    return c_over, p_over


class ClosedLoop:
    """One closed-loop run, prepared: the scenario's parameters checked against the FMUs (names,
    types, ranges, the push against the plant's push input), the result arrays allocated, and both
    FMUs instantiated and initialized with their parameters. Everything that can be wrong with the
    input is found here, as an InputError (ScenarioError, FMUError) naming what is wrong, before
    the caller has written anything; `run()` then runs the loop (once).

    `faults` replaces the scenario's [faults]; `log_categories` switches those log categories of
    both FMUs on (for `logger`; by default only errors are logged). `engine`: "fmpy" (this module's
    loop on FMPy) or "native" (the same loop in C++, anklehip.running.native: bit-identical rows;
    no sensor faults, transition pushes, log categories or progress bar; its FMUs are checked here
    with FMPy, then instantiated again by the C++ engine; `check_load=False` skips that check, for
    the many runs of a sweep whose FMUs and parameters were checked once).
    """

    def __init__(self, scenario: Scenario, models: Models | None = None, *, fmu_dir=None,
                 controller_overrides: dict | None = None, plant_overrides: dict | None = None,
                 push: PushProfile | None = None, stop_time: float | None = None,
                 logger: Callable | None = None, faults: Faults | None = None,
                 log_categories: list[str] | None = None, engine: str = "fmpy", check_load: bool = True):
        if engine not in ENGINES:
            raise InputError(f"engine {engine!r}: one of {', '.join(ENGINES)}")
        models = models or Models.for_scenario(scenario, fmu_dir)
        if engine == "native" and 3 in (models.controller.fmi_version, models.plant.fmi_version):
            raise ScenarioError(f"{scenario.path or scenario.name}: the native engine runs FMI 2.0 FMUs only; "
                                "run the FMI 3.0 twins with the FMPy engine (--engine fmpy)")
        if scenario.robot_run is None and (scenario.robot or scenario.push_units != "SI"):
            from ..robot.experiment import apply_robot    # the scenario's robot file / robot units
            scenario = apply_robot(scenario, models)
        faults = faults if faults is not None else scenario.faults
        c_over, p_over = scenario_parameters(scenario, models, controller_overrides, plant_overrides, faults)
        L = _Layout(models)
        h = scenario.step
        T = stop_time if stop_time is not None else scenario.stop_time
        problem = time_grid_problem(T, h)
        if problem:
            raise ScenarioError(f"{scenario.path or scenario.name}: stop time {T:g} {problem}")
        N = int(round(T / h))
        t0 = 0.0
        push = push if push is not None else scenario.push
        # every force inside the plant's declared range, before any array holds one
        check_push_range(models.plant, push, PUSH, f"{scenario.path or scenario.name}: push")
        if PUSH_Y in L.push_cols:
            check_push_range(models.plant, scenario.push_y, PUSH_Y, f"{scenario.path or scenario.name}: push_y")

        R = np.zeros((N + 1, max(1, L.n_real)), dtype=np.float64)
        I = np.zeros((N + 1, max(1, L.n_int)), dtype=np.int32)
        R[:N, L.off_push] = push.step_averages(t0, h, N)
        if PUSH_Y in L.push_cols:
            R[:N, L.off_push + 1] = scenario.push_y.step_averages(t0, h, N)
        elif scenario.push_y.peak() != 0:
            raise FMUError(f"{scenario.path or scenario.name}: push_y needs a plant with the input {PUSH_Y!r} ({models.plant.name} has none)")
        R[N, L.off_push:L.off_cother] = R[N - 1, L.off_push:L.off_cother] if N else 0.0
        push_starts = [a for a, _ in push.events()]
        sensors = (SensorChannel(faults, [v.name for v in L.c_in], R, h, N, push_starts)
                   if faults.sensor_active else None)
        extra_push = None
        i_phase = -1
        if faults.transition_push:
            if "phase" not in [v.name for v in L.c_int]:
                raise FMUError(f"faults.transition_push needs a controller with a 'phase' output")
            pulse = PushProfile.from_segments([PushSegment("pulse", t=0.0, force=faults.transition_push,
                                                           duration=faults.transition_push_duration,
                                                           rise=faults.transition_push_rise)])
            m = int(math.ceil(faults.transition_push_duration / h - 1e-9))
            extra_push = TransitionPush(R, L.off_push, pulse.step_averages(0.0, h, m), faults.transition_phase, N)
            i_phase = L.off_cint + [v.name for v in L.c_int].index("phase")
        if engine == "native" and (sensors is not None or extra_push is not None or log_categories):
            what = "log categories" if log_categories else "the sensor faults and transition pushes of [faults]"
            raise ScenarioError(f"{scenario.path or scenario.name}: the native engine does not support {what}; "
                                "run it with the FMPy engine (--engine fmpy)")
        if extra_push is not None:
            check_push_range(models.plant, pulse, PUSH, f"{scenario.path or scenario.name}: faults.transition_push")
        self.scenario, self.models, self.engine, self.faults = scenario, models, engine, faults
        self.controller_parameters, self.plant_parameters = c_over, p_over
        self.step, self.stop_time = h, T
        self._L, self._R, self._I, self._t0, self._N, self._push = L, R, I, t0, N, push
        self._sensors, self._extra_push, self._i_phase = sensors, extra_push, i_phase
        self._ran = False
        self._ctrl = self._plant = None
        if engine == "native" and not check_load:
            self.erect = _erect(models, c_over)
            return
        ctrl = plant = None
        try:
            ctrl = Slave(models.controller, "controller", logger=logger, log_categories=log_categories)
            plant = Slave(models.plant, "plant", logger=logger, log_categories=log_categories)
            ctrl.initialize(t0, T, c_over)
            plant.initialize(t0, T, p_over)
            self.erect = _erect(models, c_over, ctrl)
        except BaseException:
            for s in (plant, ctrl):
                if s is not None:
                    s.free(terminate=False)
            raise
        if engine == "native":      # they load and accept their parameters; the C++ engine makes its own
            ctrl.free()
            plant.free()
        else:
            self._ctrl, self._plant = ctrl, plant

    def close(self) -> None:
        """Free the FMU instances of a loop that will not run."""
        for s in (self._plant, self._ctrl):
            if s is not None:
                s.free(terminate=False)
        self._ctrl = self._plant = None

    def __enter__(self) -> "ClosedLoop":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    def run(self, progress: bool | None = None) -> RunResult:
        """Run the loop; never raises for a fall (outcome 'fell'), an FMU error during the run
        (outcome 'error', the data kept up to it) or Ctrl-C (outcome 'interrupted')."""
        if self._ran:
            raise RuntimeError("a ClosedLoop runs once; prepare another")
        self._ran = True
        scenario, models, L, R, I = self.scenario, self.models, self._L, self._R, self._I
        t0, h, T, N, push, faults = self._t0, self.step, self.stop_time, self._N, self._push, self.faults
        c_over, p_over, sensors, extra_push, i_phase = (self.controller_parameters, self.plant_parameters,
                                                        self._sensors, self._extra_push, self._i_phase)
        engine, ctrl, plant = self.engine, self._ctrl, self._plant
        outcome, message, fell_at = "completed", "", None
        last = N
        wall0 = time.perf_counter()
        c_init: dict[str, float] = {}
        failed_at = -1
        j = 0
        bar = None
        native_end = None
        try:
            if engine == "native":
                from .native import run_loop
                native_end = run_loop(models, L, R, I, t0, h, T, N, c_over, p_over)
                c_init, failed_at = native_end.c_init, native_end.failed_at
                sc, sp, st = native_end.status_ctrl, native_end.status_plant, native_end.status_io
                j = failed_at if failed_at >= 0 else N
            else:
                c_init = ctrl.get_values([v.name for v in L.c_feed + L.c_other + L.c_int + L.c_bool])

                pc, cc = plant.c, ctrl.c
                p_getR, p_getI, p_getB, p_setR, p_step = (plant.get_real, plant.get_integer, plant.get_boolean,
                                                           plant.set_real, plant.do_step)
                c_getR, c_getI, c_getB, c_setR, c_step = (ctrl.get_real, ctrl.get_integer, ctrl.get_boolean,
                                                           ctrl.set_real, ctrl.do_step)
                vr_pR = vr_array([v.vr for v in L.p_real]); n_pR = len(L.p_real)
                vr_pI = vr_array([v.vr for v in L.p_int]); n_pI = len(L.p_int)
                vr_pB = vr_array([v.vr for v in L.p_bool]); n_pB = len(L.p_bool)
                vr_cin = vr_array([v.vr for v in L.c_in]); n_cin = len(L.c_in)
                vr_cF = vr_array([v.vr for v in L.c_feed]); n_cF = len(L.c_feed)
                vr_cO = vr_array([v.vr for v in L.c_other]); n_cO = len(L.c_other)
                vr_cI = vr_array([v.vr for v in L.c_int]); n_cI = len(L.c_int)
                vr_cB = vr_array([v.vr for v in L.c_bool]); n_cB = len(L.c_bool)
                vr_pin = vr_array([v.vr for v in L.p_in]); n_pin = len(L.p_in)
                baseR, sR = R.ctypes.data, R.strides[0]
                baseI, sI = I.ctypes.data, I.strides[0]
                oF, oO = 8 * L.off_feed, 8 * L.off_cother
                oPB, oCI, oCB = 4 * L.off_pbool, 4 * L.off_cint, 4 * L.off_cbool
                if sensors is not None:     # the controller reads the faulty channel's rows, not the plant's
                    inject, baseS, sS = sensors.apply, sensors.S.ctypes.data, sensors.S.strides[0]

                if progress is None:
                    progress = T >= 5.0
                if progress:
                    from tqdm import tqdm
                    bar = tqdm(total=round(T, 6), unit="s sim", disable=None, leave=False,
                               bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s sim [{elapsed}<{remaining}]")
                chunk = 1000
                k = 0
                while k < N:
                    kend = min(N, k + chunk)
                    for j in range(k, kend):
                        t = t0 + j * h
                        rR = baseR + j * sR
                        rI = baseI + j * sI
                        st = p_getR(pc, vr_pR, n_pR, rR)
                        if n_pI:
                            st |= p_getI(pc, vr_pI, n_pI, rI)
                        if n_pB:
                            st |= p_getB(pc, vr_pB, n_pB, rI + oPB)
                        if sensors is None:
                            st |= c_setR(cc, vr_cin, n_cin, rR)
                        else:
                            inject(j)
                            st |= c_setR(cc, vr_cin, n_cin, baseS + j * sS)
                        sc = c_step(cc, t, h, 1)
                        st |= c_getR(cc, vr_cF, n_cF, rR + oF)
                        if n_cO:
                            st |= c_getR(cc, vr_cO, n_cO, rR + oO)
                        if n_cI:
                            st |= c_getI(cc, vr_cI, n_cI, rI + oCI)
                        if n_cB:
                            st |= c_getB(cc, vr_cB, n_cB, rI + oCB)
                        if extra_push is not None:
                            extra_push.after_controller(j, int(I[j, i_phase]))
                        st |= p_setR(pc, vr_pin, n_pin, rR + oF)
                        sp = p_step(pc, t, h, 1)
                        if sp > 1 or sc > 1 or st > 1:
                            failed_at = j
                            break
                    if failed_at >= 0:
                        break
                    if bar is not None:
                        bar.update(round((kend - k) * h, 9))
                    k = kend
                if bar is not None:
                    bar.close()
                    bar = None

            if failed_at >= 0:
                k = failed_at
                t = t0 + k * h
                if sc > 1:
                    raise FMUError(f"{models.controller.name}: fmi2DoStep at t={t:.4f} s returned {STATUS_NAMES[sc]}")
                if st > 1 and sp <= 1:
                    raise FMUError(f"get/set of values failed at t={t:.4f} s (status {st})")
                if native_end is not None:
                    term, t_last = native_end.plant_terminated, native_end.plant_last_time
                else:
                    term, t_last = plant.terminated_status()
                if sp == DISCARD:
                    outcome = "fell"
                    fell_at = t_last if t_last is not None else t
                    message = f"fell at t={fell_at:.3f} s" + ("" if term else " (plant discarded the step)")
                else:
                    raise FMUError(f"{models.plant.name}: fmi2DoStep at t={t:.4f} s returned {STATUS_NAMES[sp]}")
                # the plant's outputs at the last successful time close the record (the native engine
                # has read them)
                last = k + 1
                if native_end is None:
                    R[last, :] = R[k, :]
                    I[last, :] = I[k, :]
                    p_getR(pc, vr_pR, n_pR, baseR + last * sR)
                    if n_pI:
                        p_getI(pc, vr_pI, n_pI, baseI + last * sI)
                    if n_pB:
                        p_getB(pc, vr_pB, n_pB, baseI + last * sI + oPB)
                t_end = fell_at
                if "fallen" in [v.name for v in L.p_bool] and not I[last, L.off_pbool + [v.name for v in L.p_bool].index("fallen")]:
                    # a discard without a fall (e.g. the integrator gave up) is an error, not a fall
                    outcome, fell_at = "error", None
                    message = (f"{models.plant.name} discarded the step at t={t:.4f} s without falling "
                               f"(terminated={term}, last successful time {t_last})")
            else:
                if native_end is None:
                    rR, rI = baseR + N * sR, baseI + N * sI
                    R[N, :] = R[N - 1, :]
                    I[N, :] = I[N - 1, :]
                    p_getR(pc, vr_pR, n_pR, rR)
                    if n_pI:
                        p_getI(pc, vr_pI, n_pI, rI)
                    if n_pB:
                        p_getB(pc, vr_pB, n_pB, rI + oPB)
                t_end = t0 + N * h
        except KeyboardInterrupt as e:      # Ctrl-C, or SIGTERM/SIGHUP through the CLI (errors.Terminated)
            last = max(j - 1, 0)
            t_end = t0 + last * h
            why = str(e) if isinstance(e, Terminated) else "interrupted by the user"
            outcome, message = "interrupted", f"{why}; data kept up to t={t_end:.3f} s"
        except Exception as e:   # keep what was computed, mark it as an error
            last = failed_at if failed_at >= 0 else max(j - 1, 0)
            t_end = t0 + last * h
            outcome, message = "error", f"error, data kept up to t={t_end:.3f} s: {type(e).__name__}: {e}"
        finally:
            if bar is not None:            # interrupted or failed mid-run: do not leave the bar behind
                bar.close()
            self._ctrl = self._plant = None
            for s in (plant, ctrl):
                if s is not None:
                    s.free(terminate=outcome == "completed")
        wall = time.perf_counter() - wall0

        times = t0 + h * np.arange(last + 1)
        if failed_at >= 0 and last == failed_at + 1:      # closed by the plant's outputs after a discard
            times[-1] = max(t_end, times[-2])
        extra: dict[str, np.ndarray] = {}
        if sensors is not None:        # the last row repeats the controller side, like its outputs
            if last > 0:
                sensors.S[last] = sensors.S[last - 1]
            extra = {SENSED_PREFIX + v.name: sensors.S[:last + 1, i] for i, v in enumerate(L.c_in)}
            for v in L.c_in:
                L.units[SENSED_PREFIX + v.name] = L.units.get(v.name, "")
        data = _structured(L, times, R[:last + 1], I[:last + 1], extra)
        res = RunResult(name=scenario.name, data=data, outcome=outcome, end_time=float(times[-1]),
                        stop_time=T, step=h, wall_time=wall, message=message, fell_at=fell_at,
                        controller_initial=c_init,
                        controller_parameters={**models.controller.start_values(), **c_over},
                        controller_config=scenario.controller_config, controller_overrides=c_over,
                        plant_parameters={**models.plant.start_values(), **p_over},
                        controller_columns=L.controller_columns, column_units=L.units,
                        controller_inputs=tuple(v.name for v in L.c_in),   # the 3D controller's too
                        faults=faults.non_default(),
                        transition_pushes=[t0 + j * h for j in extra_push.starts] if extra_push is not None else [],
                        erect=self.erect)
        # a plant that signals a fall only through its 'fallen' output
        if outcome == "completed" and "fallen" in data.dtype.names and data["fallen"].any():
            i = int(np.argmax(data["fallen"] != 0))
            res.outcome, res.fell_at = "fell", float(data["time"][i])
            res.message = f"fell at t={res.fell_at:.3f} s (fallen output; the plant did not discard)"
        return res


def simulate(scenario: Scenario, models: Models | None = None, *, fmu_dir=None,
             controller_overrides: dict | None = None, plant_overrides: dict | None = None,
             push: PushProfile | None = None, stop_time: float | None = None,
             progress: bool | None = None, logger: Callable | None = None,
             faults: Faults | None = None, log_categories: list[str] | None = None,
             engine: str = "fmpy", check_load: bool = True) -> RunResult:
    """Run one closed-loop scenario: ClosedLoop(...).run(progress). Raises an InputError
    (ScenarioError, FMUError) for what ClosedLoop checks; never raises for a fall."""
    return ClosedLoop(scenario, models, fmu_dir=fmu_dir, controller_overrides=controller_overrides,
                      plant_overrides=plant_overrides, push=push, stop_time=stop_time, logger=logger,
                      faults=faults, log_categories=log_categories, engine=engine,
                      check_load=check_load).run(progress)


def check_push_range(plant: FMUInfo, push: PushProfile, variable: str, where: str) -> None:
    """Every force of the push profile inside the range the plant FMU declares for its push input
    (e.g. Hoap2Plant's push_force: [-1000, 1000] N); else a ScenarioError naming `where`."""
    v = plant.vars.get(variable)
    if v is None or not len(push.values):
        return
    lo, hi = float(np.min(push.values)), float(np.max(push.values))
    unit = f" {v.unit}" if v.unit else ""
    for x in (lo, hi):
        if (v.min is not None and x < v.min) or (v.max is not None and x > v.max):
            raise ScenarioError(f"{where}: a force of {x:g}{unit} is outside the range of {plant.name}'s input "
                                f"{variable}, [{_g(v.min)}, {_g(v.max)}]{unit}")


def _g(x: float | None) -> str:
    return "-inf" if x is None else f"{x:g}"


ERECT = ("theta_ankle_erect", "theta_hip_erect")


def _erect(models: Models, c_over: dict[str, Any], ctrl: "Slave | None" = None) -> tuple[float, float]:
    """The controller's erect posture: its calculated parameters (docs/controller.md section 2.1),
    read from the loop's initialized instance or, for a sweep's unchecked native run, from one of
    its own; (0, 0) for a controller FMU without them."""
    if not all(n in models.controller.vars for n in ERECT):
        return (0.0, 0.0)
    own = ctrl is None
    try:
        if own:
            ctrl = Slave(models.controller, "erect")
            ctrl.initialize(0.0, 1.0, c_over)
        v = ctrl.get_values(list(ERECT))
        return (float(v[ERECT[0]]), float(v[ERECT[1]]))
    finally:
        if own and ctrl is not None:
            ctrl.free()


def _structured(L: _Layout, times, R, I, extra: dict[str, np.ndarray] | None = None) -> np.ndarray:
    """The result table: time, the real columns, `extra` real columns (e.g. sensed.*), the integers."""
    extra = extra or {}
    dt = np.dtype([("time", np.float64)] + [(c, np.float64) for c in L.real_cols] + [(c, np.float64) for c in extra]
                  + [(c, np.int32) for c in L.int_cols])
    out = np.empty(len(times), dtype=dt)
    out["time"] = times
    for c, x in extra.items():
        out[c] = x
    # the real and the integer columns are contiguous in a record: one strided copy each
    n, nr, ni = len(times), len(L.real_cols), len(L.int_cols)
    if nr:
        np.ndarray((n, nr), np.float64, out, dt.fields[L.real_cols[0]][1], (dt.itemsize, 8))[...] = R[:, :nr]
    if ni:
        np.ndarray((n, ni), np.int32, out, dt.fields[L.int_cols[0]][1], (dt.itemsize, 4))[...] = I[:, :ni]
    return out
