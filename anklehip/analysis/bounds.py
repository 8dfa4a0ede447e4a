"""Analytic bounds of push recovery without stepping, for the sagittal HOAP-2 model (docs/capability.md).

The robot as the bounds see it: the two-link body (links 1 and 2, mass m_b) erect, its CoM over the
ankle axis (x = 0); the feet (m_f, CoM at x_f) flat on the ground, toe at x_toe, heel at x_heel;
a horizontal push F (+ forward, i.e. on the back; - on the chest) at the height h above the sole.
x is measured from the ankle axis (forward +), heights above the sole. Pure numpy, no FMU calls.

* static_tipping_force: the constant push that tips the erect robot onto the toe (heel).
* sustained_push_limit: the largest constant push any flat-footed strategy can hold, the body CoM
  leaned to the opposite edge.
* lip_force_limit / lip_impulse_limit: the linear inverted pendulum bound of the ankle strategy
  (the body rigid, no angular momentum about its CoM, the ZMP at the edge from the push onset).

    python -m anklehip.analysis.bounds       # the nominal numbers (docs/capability.md)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Robot:
    """The numbers the bounds need (SI). Body links: mass, CoM height above the sole, pitch inertia
    about the own CoM. The erect body's CoM is at x = 0."""
    g: float
    m1: float
    z1: float
    I1: float
    m2: float
    z2: float
    I2: float
    ankle_height: float
    m_f: float          # feet
    x_f: float
    x_toe: float
    x_heel: float
    h: float            # push height above the sole

    @property
    def m_b(self) -> float:
        return self.m1 + self.m2

    @property
    def m_tot(self) -> float:
        return self.m_b + self.m_f

    @property
    def z_b(self) -> float:
        """Body CoM height above the sole."""
        return (self.m1 * self.z1 + self.m2 * self.z2) / self.m_b

    @property
    def I_b(self) -> float:
        """Body pitch inertia about its own CoM (erect)."""
        zb = self.z_b
        return self.I1 + self.I2 + self.m1 * (self.z1 - zb) ** 2 + self.m2 * (self.z2 - zb) ** 2

    @property
    def I_ankle(self) -> float:
        """Body pitch inertia about the ankle axis (erect)."""
        return self.I_b + self.m_b * (self.z_b - self.ankle_height) ** 2

    @property
    def I_sole(self) -> float:
        """Body pitch inertia about the sole point under the ankle: sum of I_i + m_i z_i^2."""
        return self.I_b + self.m_b * self.z_b ** 2

    @property
    def omega(self) -> float:
        """LIP rate [1/s] of the rigid body pivoting about the ankle axis (the model's kinematics),
        rotational inertia included: omega^2 = m_b g z_a / (m_b z_b z_a + I_b), z_a = z_b - ankle_height.
        The bounds use this one."""
        za = self.z_b - self.ankle_height
        return math.sqrt(self.m_b * self.g * za / (self.m_b * self.z_b * za + self.I_b))

    @property
    def omega_sole(self) -> float:
        """The same for a rigid body pivoting on the sole point: omega^2 = m_b g z_b / I_sole."""
        return math.sqrt(self.m_b * self.g * self.z_b / self.I_sole)

    @property
    def omega_point(self) -> float:
        """Point-mass LIP (no rotational inertia): omega^2 = g / z_b."""
        return math.sqrt(self.g / self.z_b)


def robot_from_plant_params(params: dict) -> Robot:
    """A Robot from the plant FMU's parameters (start values merged with any overrides; names g,
    m1, l1, lg1, I1, m2, lg2, I2, feet_mass, feet_com_x, toe_x, heel_x, ankle_height, h_push)."""
    p = {k: float(v) for k, v in params.items() if isinstance(v, (int, float))}
    a = p["ankle_height"]
    return Robot(g=p["g"], m1=p["m1"], z1=a + p["lg1"], I1=p["I1"], m2=p["m2"], z2=a + p["l1"] + p["lg2"],
                 I2=p["I2"], ankle_height=a, m_f=p["feet_mass"], x_f=p["feet_com_x"], x_toe=p["toe_x"],
                 x_heel=p["heel_x"], h=p["h_push"])


def _edge_moment(r: Robot, direction: float) -> float:
    """m_b * Delta_eff [kg m]: the first moment of the erect robot's masses about the edge the push
    tips it onto (the toe for direction +1, the heel for -1), positive when the robot stands."""
    if direction >= 0:
        return r.m_b * r.x_toe + r.m_f * (r.x_toe - r.x_f)
    return r.m_b * (-r.x_heel) + r.m_f * (r.x_f - r.x_heel)


def static_tipping_force(r: Robot, direction: float = +1) -> float:
    """Constant push [N, magnitude] that tips the erect robot onto the toe (direction +1, push on
    the back) or the heel (-1, on the chest): moment balance about that edge,
    F h = g [m_b (x_toe - 0) + m_f (x_toe - x_f)].
    Assumes: erect posture held rigidly (no lean), feet flat, push horizontal at h."""
    return r.g * _edge_moment(r, direction) / r.h


def sustained_push_limit(r: Robot, direction: float = +1) -> float:
    """Largest constant push [N, magnitude] any flat-footed strategy can hold without stepping:
    the ZMP at the toe and the body CoM leaned to the heel (mirrored for a push on the chest),
    F h = g [m_b (x_toe - x_heel) + m_f (x_toe - x_f)].
    Assumes: the body CoM stays over the sole (the robot still stands if the push stops), h
    unchanged by the lean (small angles), feet flat, push horizontal."""
    if direction >= 0:
        m = r.m_b * (r.x_toe - r.x_heel) + r.m_f * (r.x_toe - r.x_f)
    else:
        m = r.m_b * (r.x_toe - r.x_heel) + r.m_f * (r.x_f - r.x_heel)
    return r.g * m / r.h


def laplace_pwl(times, values, omega: float):
    """Integral of f(t) e^(-omega t) dt from times[..., 0] to infinity, exact for the piecewise-linear
    f through the break points (times, values) along the last axis (a repeated time is a jump),
    constant at the last value after the last break point (as anklehip.files.scenario.PushProfile)."""
    t = np.asarray(times, float)
    v = np.asarray(values, float)
    t0, t1, v0, v1 = t[..., :-1], t[..., 1:], v[..., :-1], v[..., 1:]
    dt = t1 - t0
    e0 = np.exp(-omega * t0)
    d = -e0 * np.expm1(-omega * dt)                 # e^(-w t0) - e^(-w t1), accurate for short segments
    with np.errstate(invalid="ignore", divide="ignore"):
        # the linear part: (v1 - v0) [d / (w^2 dt) - e^(-w t1) / w]
        lin = np.where(dt > 0, d / (omega ** 2 * np.where(dt > 0, dt, 1.0)) - (e0 - d) / omega, 0.0)
    seg = v0 * d / omega + (v1 - v0) * lin
    tail = v[..., -1] * np.exp(-omega * t[..., -1]) / omega
    return seg.sum(axis=-1) + tail


def trapezoid_integral(omega: float, duration, rise: float = 0.0):
    """Integral of s(t) e^(-omega t) dt for the sweeps' trapezoid push normalised to peak 1: from
    t = 0, up in `rise`, held, down in `rise`, zero after `duration` (rise and fall included), the
    break points of PushProfile.from_segments([PushSegment("pulse", t=0, force=1, duration, rise)]).
    Vectorised over duration; duration = inf is a push that never ends; rise is clipped to duration/2."""
    D = np.asarray(duration, float)
    r = np.minimum(rise, D / 2)
    inf = np.isinf(D)
    Df = np.where(inf, 2 * r, D)
    times = np.stack([np.zeros_like(D), r, Df - r, Df], axis=-1)
    values = np.where(inf[..., None], [0.0, 1.0, 1.0, 1.0], [0.0, 1.0, 1.0, 0.0])
    return laplace_pwl(times, values, omega)


def lip_force_limit(r: Robot, duration, rise: float = 0.0, direction: float = +1, omega: float | None = None):
    """Largest peak force [N, magnitude] of a trapezoid push (duration, rise; see trapezoid_integral)
    after which the ankle strategy can still be capturable:
    F_max = m_b g Delta_eff / (h omega integral s(t) e^(-omega t) dt), m_b g Delta_eff = F_static h.
    Assumes: linear inverted pendulum of the rigid erect body pivoting about the ankle (rotational
    inertia included, omega = r.omega unless given), no angular momentum about the CoM from the hip,
    the ZMP at the toe (heel for direction -1) from the push onset, feet flat, the robot erect and at
    rest before the push. A necessary condition: above it no flat-footed ankle strategy recovers;
    below it recovery is possible in the model, not guaranteed. Vectorised over duration; a
    constant push (duration inf, rise 0) gives static_tipping_force."""
    w = r.omega if omega is None else omega
    return r.g * _edge_moment(r, direction) / (r.h * w * trapezoid_integral(w, duration, rise))


def lip_impulse_limit(r: Robot, direction: float = +1, omega: float | None = None) -> float:
    """Largest impulse [N s, magnitude] of a very short push the ankle strategy can absorb:
    J_max = m_b g Delta_eff / (h omega), the limit of F_max * duration for duration -> 0.
    Assumes what lip_force_limit assumes."""
    w = r.omega if omega is None else omega
    return r.g * _edge_moment(r, direction) / (r.h * w)


NOMINAL_DURATIONS = (0.1, 0.15, 0.2, 0.3, 0.5, 1.0, 2.0, 4.0)   # scenarios/sweeps/force_duration.toml


def nominal_table(params: dict, durations=NOMINAL_DURATIONS, rise: float = 0.05) -> str:
    """The numbers of docs/capability.md as a markdown table."""
    r = robot_from_plant_params(params)

    def both(fn, fmt, unit):     # back / chest
        return f"{fn(r, 1):{fmt}} / {fn(r, -1):{fmt}} {unit}"

    rows = [("m_b = m1 + m2 (body)", f"{r.m_b:.4f} kg"), ("m_f (feet)", f"{r.m_f:.4f} kg"),
            ("x_f (feet CoM)", f"{1000 * r.x_f:.2f} mm"), ("x_toe", f"{1000 * r.x_toe:.1f} mm"),
            ("x_heel", f"{1000 * r.x_heel:.1f} mm"), ("h (push height)", f"{r.h:.3f} m"),
            ("z_b (body CoM above the sole)", f"{r.z_b:.4f} m"), ("I_b (body, about its CoM)", f"{r.I_b:.4f} kg·m²"),
            ("I_ankle (body, about the ankle axis)", f"{r.I_ankle:.4f} kg·m²"),
            ("I_s (body, about the sole point)", f"{r.I_sole:.4f} kg·m²"),
            ("ω, rigid body about the ankle (used)", f"{r.omega:.3f} s⁻¹"),
            ("ω, rigid body about the sole point", f"{r.omega_sole:.3f} s⁻¹"),
            ("ω, point mass √(g/z_b)", f"{r.omega_point:.3f} s⁻¹"),
            ("static tipping force, back / chest", both(static_tipping_force, ".2f", "N")),
            ("sustained-push limit, back / chest", both(sustained_push_limit, ".2f", "N")),
            ("LIP impulse limit, back / chest", both(lip_impulse_limit, ".3f", "N·s"))]
    fb, fc = lip_force_limit(r, durations, rise, 1), lip_force_limit(r, durations, rise, -1)
    for d, a, b in zip(durations, fb, fc):
        rows.append((f"LIP force limit, {d:g} s push ({1000 * rise:g} ms rise), back / chest", f"{a:.2f} / {b:.2f} N"))
    return "\n".join(["| quantity | value |", "|---|---|"] + [f"| {q} | {v} |" for q, v in rows])


if __name__ == "__main__":      # pragma: no cover - prints the doc's table
    import argparse
    from ..running.fmu import FMUInfo
    from ..files.paths import PLANT_FMU, find_fmu
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fmu-dir")
    print(nominal_table(FMUInfo.load(find_fmu(PLANT_FMU, ap.parse_args().fmu_dir)).start_values()))
