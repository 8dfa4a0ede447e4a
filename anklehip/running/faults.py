"""Fault injection for closed-loop runs: the scenario table ``[faults]``.

Three kinds of fault, each with a level (KEYS is the one table of them: parser, CLI help, sweep
grids and docs/scenarios.md all read it):

* **sensor faults** act on the wire from the plant's outputs to the controller's inputs, in the
  master (so they work with either plant): noise and bias on the ZMP and the joint angles, lost
  sensor packets (all four inputs NaN, or the previous packet repeated), a sensor stuck at the
  value it read when an episode began, and a delay of whole communication steps. Applied in the
  order delay -> bias + noise -> stuck -> drop. The values the controller received are recorded in
  the result as ``sensed.<input>`` columns.
* **parameter faults** change what the FMUs are given: the plant's servo torque limits scaled by
  ``torque_scale``, the controller's model masses / lengths off by ``mass_mismatch`` /
  ``length_mismatch`` (a fraction; the plant keeps its values).
* **a push during a transition**: an extra pulse on the robot's back that starts in the step in
  which the controller's phase enters ``transition_phase`` (once per push cycle: re-armed when
  the phase returns to 0).

Every random draw comes from ``numpy.random.default_rng(seed)``: a run is reproducible.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

CONTROLLER_SIGNALS = ("theta_ankle", "theta_hip", "zmp_x", "fz")
DROP_MODES = ("nan", "repeat")
# The controller's model of the robot (controller parameters) the mismatch faults scale. Inertias
# scale with mass and with length squared.
MODEL_MASSES = ("m1", "m2", "feet_mass")
MODEL_LENGTHS = ("l1", "lg1", "lg2")
# and, where the controller has them (the 3D one), the leg's segments, whose sum must stay l1
MODEL_LEG_SEGMENTS = ("thigh", "shank")
MODEL_INERTIAS = ("I1", "I2")
SENSED_PREFIX = "sensed."


@dataclass(frozen=True)
class FaultKey:
    name: str
    unit: str
    lo: float
    hi: float
    what: str
    grid: str = ""          # the robustness sweep's default levels (anklehip sweep-faults), "" = not swept
    integer: bool = False


KEYS: tuple[FaultKey, ...] = (
    FaultKey("zmp_noise", "m", 0.0, 0.1, "std deviation of white noise on zmp_x", "0:0.03:0.0025"),
    FaultKey("zmp_bias", "m", -0.1, 0.1, "constant offset on zmp_x", "-0.03:0.03:0.0025"),
    FaultKey("angle_noise", "rad", 0.0, 0.5, "std deviation of white noise on theta_ankle and theta_hip",
             "0:0.15:0.01"),
    FaultKey("ankle_bias", "rad", -0.5, 0.5, "constant offset on theta_ankle", "-0.1:0.1:0.0125"),
    FaultKey("hip_bias", "rad", -0.5, 0.5, "constant offset on theta_hip", "-0.3:0.5:0.05"),
    FaultKey("drop_rate", "", 0.0, 1.0, "probability that a sensor packet (all four inputs) is lost; "
             "see drop_mode", "0:0.8:0.1"),
    FaultKey("stuck_for", "s", 0.0, 3600.0, "each stuck-sensor episode lasts this long; see stuck_signal, stuck_at",
             "0:1.5:0.25"),
    FaultKey("delay_steps", "steps", 0, 1000, "every input arrives this many communication steps late",
             "0,1,2,5,10,20,50,100,200,500,1000", integer=True),
    FaultKey("torque_scale", "", 0.01, 10.0, "the plant's servo torque limits (every tau_max* parameter) times this",
             "1,0.8,0.6,0.4,0.3,0.25,0.2,0.175,0.15,0.125,0.1"),
    FaultKey("mass_mismatch", "", -0.5, 0.5, "the controller's model masses m1, m2, feet_mass (and I1, I2) "
             "times (1 + this)", "-0.5:0.5:0.05"),
    FaultKey("length_mismatch", "", -0.5, 0.5, "the controller's model lengths l1, lg1, lg2 (and the 3D "
             "controller's thigh and shank) times (1 + this) (I1, I2 times its square)", "-0.5:0.5:0.05"),
    FaultKey("transition_push", "N", -1000.0, 1000.0, "peak of an extra pulse (+ = on the back) that starts when "
             "the phase enters transition_phase", "0:10:1"),
    FaultKey("transition_push_duration", "s", 0.002, 10.0, "total duration of the transition push"),
    FaultKey("transition_push_rise", "s", 0.0, 5.0, "rise (and fall) time of the transition push"),
    FaultKey("transition_phase", "", 1, 3, "the phase whose entry triggers the transition push "
             "(1 ankle->hip, 2 hip, 3 hip->ankle)", integer=True),
    FaultKey("seed", "", 0, 2147483647, "seed of the noise and packet-loss draws", integer=True),
)
KEY_BY_NAME = {k.name: k for k in KEYS}
STRING_KEYS = {"drop_mode": DROP_MODES, "stuck_signal": CONTROLLER_SIGNALS}
ALL_KEYS = set(KEY_BY_NAME) | set(STRING_KEYS) | {"stuck_at"}


@dataclass
class Faults:
    zmp_noise: float = 0.0
    zmp_bias: float = 0.0
    angle_noise: float = 0.0
    ankle_bias: float = 0.0
    hip_bias: float = 0.0
    drop_rate: float = 0.0
    drop_mode: str = "nan"
    stuck_signal: str = "zmp_x"
    stuck_for: float = 0.0
    stuck_at: list[float] | None = None    # episode starts [s]; None: the start of every push
    delay_steps: int = 0
    torque_scale: float = 1.0
    mass_mismatch: float = 0.0
    length_mismatch: float = 0.0
    transition_push: float = 0.0
    transition_push_duration: float = 0.3
    transition_push_rise: float = 0.1
    transition_phase: int = 3
    seed: int = 1

    @property
    def sensor_active(self) -> bool:
        return bool(self.zmp_noise or self.zmp_bias or self.angle_noise or self.ankle_bias or self.hip_bias
                    or self.drop_rate or self.stuck_for or self.delay_steps)

    def non_default(self) -> dict[str, Any]:
        d = Faults()
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) != getattr(d, f.name)}


def parse_faults(v, d: Any, key: str = "faults", base: Faults | None = None) -> Faults:
    """The ``[faults]`` table (or --fault overrides) on top of `base`; `v` is the scenario
    validator (scenario._V): every error names the key, the value and the allowed range."""
    d = v.table(d, key)
    v.keys(d, ALL_KEYS, key + ".")
    out = replace(base) if base is not None else Faults()
    for name, x in d.items():
        k = f"{key}.{name}"
        if name in STRING_KEYS:
            s = v.str_(x, k)
            if s not in STRING_KEYS[name]:
                v.fail(k, f"must be one of {', '.join(STRING_KEYS[name])}, got {s!r}")
            setattr(out, name, s)
        elif name == "stuck_at":
            out.stuck_at = sorted(v.num(t, f"{k}[{i}]", ge=0.0) for i, t in enumerate(v.list_(x, k)))
        else:
            fk = KEY_BY_NAME[name]
            if fk.integer:
                n = v.int_(x, k, ge=int(fk.lo))
                if n > fk.hi:
                    v.fail(k, f"must be <= {fk.hi:g}, got {n}")
                setattr(out, name, n)
            else:
                setattr(out, name, v.num(x, k, ge=fk.lo, le=fk.hi))
    if 2 * out.transition_push_rise > out.transition_push_duration:
        v.fail(f"{key}.transition_push_rise", f"2 x rise ({out.transition_push_rise:g} s) exceeds the duration "
               f"({out.transition_push_duration:g} s)")
    return out


def parameter_faults(f: Faults, controller: dict[str, Any], plant: dict[str, Any]) -> tuple[dict, dict]:
    """Overrides the parameter faults add: `controller` / `plant` are the FMUs' effective values
    (start values + the run's overrides). Returns (controller overrides, plant overrides)."""
    c: dict[str, Any] = {}
    p: dict[str, Any] = {}
    if f.torque_scale != 1.0:
        p = {n: float(x) * f.torque_scale for n, x in plant.items() if n.startswith("tau_max")}
    ms, ls = 1.0 + f.mass_mismatch, 1.0 + f.length_mismatch
    if ms != 1.0 or ls != 1.0:
        for n in MODEL_MASSES:
            c[n] = float(controller[n]) * ms
        for n in MODEL_LENGTHS:
            c[n] = float(controller[n]) * ls
        for n in MODEL_LEG_SEGMENTS:
            if n in controller:
                c[n] = float(controller[n]) * ls
        for n in MODEL_INERTIAS:
            c[n] = float(controller[n]) * ms * ls * ls
    return c, p


def stuck_mask(f: Faults, push_starts: list[float], h: float, n: int) -> np.ndarray | None:
    """Rows (0..n) at which the stuck sensor holds; None when no episode."""
    if not f.stuck_for:
        return None
    starts = f.stuck_at if f.stuck_at is not None else push_starts
    t = h * np.arange(n + 1)
    m = np.zeros(n + 1, bool)
    for a in starts:
        m |= (t >= a - 1e-9 * h) & (t < a + f.stuck_for - 1e-9 * h)
    return m if m.any() else None


class SensorChannel:
    """The faulty wire plant -> controller: ``apply(j)`` writes row j of `S` (what the
    controller receives) from rows <= j of `R` (the plant's outputs, inputs in `inputs` order
    in the first columns)."""

    def __init__(self, f: Faults, inputs: list[str], R: np.ndarray, h: float, n_steps: int,
                 push_starts: list[float]):
        self.R = R
        self.n = n = len(inputs)
        self.S = np.zeros((R.shape[0], n))
        self.delay = f.delay_steps
        idx = {s: i for i, s in enumerate(inputs)}
        sigma = np.zeros(n)
        bias = np.zeros(n)
        for name, s, b in (("zmp_x", f.zmp_noise, f.zmp_bias), ("theta_ankle", f.angle_noise, f.ankle_bias),
                           ("theta_hip", f.angle_noise, f.hip_bias)):
            if name in idx:
                sigma[idx[name]], bias[idx[name]] = s, b
        rng = np.random.default_rng(f.seed)
        # one stream per draw kind, so that e.g. adding packet loss leaves the noise unchanged
        noise_rng, drop_rng = rng.spawn(2)
        self.offset = bias + sigma * noise_rng.standard_normal((R.shape[0], n)) if sigma.any() else bias
        self.per_row_offset = sigma.any()
        self.drop = drop_rng.random(R.shape[0]) < f.drop_rate if f.drop_rate > 0 else None
        self.drop_nan = f.drop_mode == "nan"
        self.stuck = stuck_mask(f, push_starts, h, n_steps)
        self.stuck_i = idx.get(f.stuck_signal, -1)
        if self.stuck is not None and self.stuck_i < 0:
            raise ValueError(f"faults.stuck_signal {f.stuck_signal!r} is not a controller input ({', '.join(inputs)})")
        self.held = math.nan

    def apply(self, j: int) -> None:
        v = self.R[j - self.delay if j >= self.delay else 0, :self.n] + (
            self.offset[j] if self.per_row_offset else self.offset)
        st = self.stuck
        if st is not None and st[j]:
            if j == 0 or not st[j - 1]:
                self.held = v[self.stuck_i]
            v[self.stuck_i] = self.held
        if self.drop is not None and self.drop[j]:
            if self.drop_nan:
                v[:] = math.nan
            elif j > 0:
                v = self.S[j - 1]
        self.S[j] = v


@dataclass
class TransitionPush:
    """An extra pulse added to the push column from the step in which the phase enters `phase`."""
    R: np.ndarray
    col: int
    profile: np.ndarray        # the pulse's step averages from its first step
    phase: int
    n_steps: int
    armed: bool = True
    starts: list[int] = field(default_factory=list)

    def after_controller(self, j: int, phase: int) -> None:
        if phase == 0:
            self.armed = True
        elif phase == self.phase and self.armed:
            self.armed = False
            m = min(len(self.profile), self.n_steps - j)
            self.R[j:j + m, self.col] += self.profile[:m]
            self.starts.append(j)
