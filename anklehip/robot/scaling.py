"""Gain scaling: the paper's gains and thresholds (tuned on HOAP-2) for another robot, so that the
controller behaves the same in dimensionless terms (derivation: docs/controller.md section 10).

The anchor is the robot the defaults were tuned on, with its parameters: the controller FMU's and
the plant FMU's start values (HOAP-2's, nominal.h), merged with a named configuration. Each number
keeps its ratio to the scale of its kind:

    time        T_p = sqrt(l_g / g), l_g = r_z (erect CoM above the ankle axis): T_ah, dwell and
                filter times; rates (Kpr, Kp_theta, rate tolerances) scale with 1/T_p
    eq. 11      natural frequency / (1/T_p) and damping ratio kept: Ka ~ J_a / T_p^2,
                Ca ~ J_a / T_p with J_a = I1 + m1 lg1^2 + I2 + m2 (l1 + lg2)^2
    eq. 16      the same with J_h = I2 + m2 lg2^2: Kh, Ch
    servos      the plant's PD servos the same way (ankle on J_a, hip on J_h)
    lengths     along the sole: p_lim with the toe (front) and the heel (back), margins with the
                sole length; heights: the r_z band with l_g; the push point keeps its place on
                link 2 (the same fraction of lg2 above the hip)
    forces      with the weight M g (load thresholds); moments with m g x the sole length
    angles      unchanged (dimensionless)

Servo torque and rate limits come from the robot file when it has them, else scale (torque with
m g l_g, rate with 1/T_p). On the anchor robot every ratio is exactly 1: the defaults come back
bit for bit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from .robotfile import Robot

# The robot-model numbers both FMUs take straight from the robot file.
MODEL_SHARED = ("g", "m1", "l1", "lg1", "I1", "m2", "lg2", "I2", "feet_mass", "feet_com_x", "feet_com_z",
                "toe_x", "heel_x", "ankle_height")
MODEL_CONTROLLER = ("ankle_min", "ankle_max", "hip_min", "hip_max", "sample_period")
MODEL_PLANT = ("feet_inertia",)


@dataclass(frozen=True)
class Scales:
    """The reference scales of a sagittal model (SI)."""
    g: float
    m: float            # m1 + m2
    M: float            # with the feet
    l_g: float          # erect CoM above the ankle axis
    J_a: float          # eq. 11's inertia about the ankle, erect
    J_h: float          # eq. 16's inertia about the hip
    toe: float
    heel: float         # < 0

    @property
    def T_p(self) -> float:
        """Pendulum time constant sqrt(l_g / g) [s]."""
        return math.sqrt(self.l_g / self.g)

    @property
    def sole(self) -> float:
        return self.toe - self.heel

    @classmethod
    def of(cls, v: dict[str, float]) -> "Scales":
        m = v["m1"] + v["m2"]
        l_g = (v["m1"] * v["lg1"] + v["m2"] * (v["l1"] + v["lg2"])) / m
        J_a = v["I1"] + v["m1"] * v["lg1"] ** 2 + v["I2"] + v["m2"] * (v["l1"] + v["lg2"]) ** 2
        J_h = v["I2"] + v["m2"] * v["lg2"] ** 2
        return cls(v["g"], m, m + v["feet_mass"], l_g, J_a, J_h, v["toe_x"], v["heel_x"])


@dataclass(frozen=True)
class Rule:
    """How one parameter scales: value = anchor x factor(anchor scales, robot scales)."""
    fmu: str            # controller | plant
    name: str
    kind: str           # shown in the docs' table


def _ratios(a: Scales, r: Scales) -> dict[str, float]:
    w = a.T_p / r.T_p                       # frequency ratio (1/T_p)
    return {
        "time": r.T_p / a.T_p,
        "rate": w,
        "ankle stiffness": (r.J_a / a.J_a) * w * w,
        "ankle damping": (r.J_a / a.J_a) * w,
        "hip stiffness": (r.J_h / a.J_h) * w * w,
        "hip damping": (r.J_h / a.J_h) * w,
        "toe": r.toe / a.toe,
        "heel": r.heel / a.heel,
        "sole": r.sole / a.sole,
        "height": r.l_g / a.l_g,
        "weight": (r.M * r.g) / (a.M * a.g),
        "moment": (r.m * r.g * r.sole) / (a.m * a.g * a.sole),
        "gravity torque": (r.m * r.g * r.l_g) / (a.m * a.g * a.l_g),
        "angle": 1.0,
    }


RULES = [
    Rule("controller", "Ka", "ankle stiffness"), Rule("controller", "Ca", "ankle damping"),
    Rule("controller", "Kh", "hip stiffness"), Rule("controller", "Ch", "hip damping"),
    Rule("controller", "Kpr", "rate"), Rule("controller", "Kp_theta", "rate"),
    Rule("controller", "zmp_limit_front", "toe"), Rule("controller", "zmp_limit_back", "heel"),
    Rule("controller", "T_ah", "time"),
    Rule("controller", "rz_band_low", "height"), Rule("controller", "rz_band_high", "height"),
    Rule("controller", "fallback_disturbance_tol", "moment"), Rule("controller", "fallback_hip_tol", "angle"),
    Rule("controller", "fallback_dwell", "time"),
    Rule("controller", "return_hip_angle_tol", "angle"), Rule("controller", "return_hip_rate_tol", "rate"),
    Rule("controller", "zmp_filter_tau", "time"), Rule("controller", "feet_calibration_time", "time"),
    Rule("controller", "fz_lifted", "weight"), Rule("controller", "fz_max", "weight"),
    Rule("controller", "zmp_fault_margin", "sole"), Rule("controller", "angle_fault_margin", "angle"),
    Rule("controller", "lean_tau", "time"), Rule("controller", "lean_margin", "sole"),
    Rule("controller", "lean_zmp_margin", "sole"),
    Rule("plant", "kp_ankle", "ankle stiffness"), Rule("plant", "kd_ankle", "ankle damping"),
    Rule("plant", "kp_hip", "hip stiffness"), Rule("plant", "kd_hip", "hip damping"),
    Rule("plant", "damping_ankle", "ankle damping"), Rule("plant", "damping_hip", "hip damping"),
    Rule("plant", "tau_max_ankle", "gravity torque"), Rule("plant", "tau_max_hip", "gravity torque"),
    Rule("plant", "vel_max_ankle", "rate"), Rule("plant", "vel_max_hip", "rate"),
    Rule("plant", "fall_foot_pitch", "angle"), Rule("plant", "fall_body_pitch", "angle"),
    Rule("plant", "baumgarte", "rate"),
    Rule("plant", "sensor_noise", "weight"), Rule("plant", "sensor_bias_toe", "weight"),
    Rule("plant", "sensor_bias_heel", "weight"), Rule("plant", "sensor_fmin", "weight"),
]


@dataclass
class Scaled:
    """The parameters of both FMUs for a robot, and how each was obtained."""
    controller: dict[str, Any]
    plant: dict[str, Any]
    anchor: Scales
    robot: Scales
    how: dict[tuple[str, str], str]          # (fmu, name) -> "robot file" | "scaled: <kind> x<factor>"
    h_push_fraction: float                   # the push point's height above the hip / lg2 (anchor's)

    @property
    def time_ratio(self) -> float:
        return self.robot.T_p / self.anchor.T_p


def scale(robot: Robot, controller_anchor: dict[str, Any], plant_anchor: dict[str, Any]) -> Scaled:
    """Both FMUs' parameters for `robot`: its own numbers, and the anchor's gains, thresholds and
    servo settings scaled by RULES. `controller_anchor` / `plant_anchor`: the parameters the
    defaults were tuned with (the FMUs' start values, the named configuration on top)."""
    v = robot.values()
    a = Scales.of({k: float(controller_anchor[k]) for k in ("g", "m1", "l1", "lg1", "I1", "m2", "lg2", "I2",
                                                          "feet_mass", "toe_x", "heel_x")})
    r = Scales.of(v)
    f = _ratios(a, r)
    c: dict[str, Any] = {}
    p: dict[str, Any] = {}
    how: dict[tuple[str, str], str] = {}
    for k in MODEL_SHARED:
        c[k] = p[k] = v[k]
        how[("controller", k)] = how[("plant", k)] = "robot file"
    for k in MODEL_CONTROLLER:
        c[k] = v[k]
        how[("controller", k)] = "robot file"
    for k in MODEL_PLANT:
        p[k] = v[k]
        how[("plant", k)] = "robot file"
    for rule in RULES:
        anchor = controller_anchor if rule.fmu == "controller" else plant_anchor
        out = c if rule.fmu == "controller" else p
        if rule.name in robot.servo:
            out[rule.name] = robot.servo[rule.name].value
            how[(rule.fmu, rule.name)] = "robot file"
        elif rule.name in anchor:
            out[rule.name] = float(anchor[rule.name]) * f[rule.kind]
            how[(rule.fmu, rule.name)] = f"{rule.kind} x{f[rule.kind]:.6g}"
    # The paper's estimate d = m g (p - r_x) ignores the feet: at rest it reads m g m_f x_f / M (prototype
    # finding 5, docs/controller.md 4.2). The return to the ankle strategy (the fallback, |d| <= its
    # tolerance) must be reachable at rest with a margin of 2: where the rest bias exceeds half the
    # tolerance, the feet model (feet_offset_mode 1, d = 0 at rest) replaces the paper's estimate.
    bias = rest_bias(v)
    tol = c.get("fallback_disturbance_tol")
    if int(controller_anchor.get("feet_offset_mode", 0)) == 0 and tol is not None and abs(bias) > 0.5 * tol:
        c["feet_offset_mode"] = 1
        how[("controller", "feet_offset_mode")] = (f"1: the paper's estimate reads {bias:.3g} N.m at rest, more than half "
                                                   f"of fallback_disturbance_tol {tol:.3g} N.m")
    # the push point: the same place on link 2 (exactly the anchor's h_push on the anchor robot)
    a_a, l1_a, lg2_a = (float(controller_anchor[k]) for k in ("ankle_height", "l1", "lg2"))
    h0 = float(plant_anchor["h_push"])
    frac = (h0 - a_a - l1_a) / lg2_a
    p["h_push"] = h0 + (v["ankle_height"] - a_a) + (v["l1"] - l1_a) + (h0 - a_a - l1_a) * (v["lg2"] / lg2_a - 1.0)
    how[("plant", "h_push")] = f"ankle_height + l1 + {frac:.6g} lg2 (the anchor's place on link 2)"
    return Scaled(c, p, a, r, how, frac)


def rest_bias(v: dict[str, float]) -> float:
    """The paper's disturbance estimate m g (p - r_x) of the erect robot at rest [N m]: the ZMP
    sits m_f x_f / M ahead of the body's CoM because of the feet."""
    m = v["m1"] + v["m2"]
    return m * v["g"] * v["feet_mass"] * v["feet_com_x"] / (m + v["feet_mass"])


def ratios(scaled: Scaled) -> dict[str, float]:
    return _ratios(scaled.anchor, scaled.robot)
