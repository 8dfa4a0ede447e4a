"""Analytic push-recovery bounds (anklehip/analysis/bounds.py, docs/capability.md): the nominal numbers, the
limits each bound must reach, the exact exponential integral of the trapezoid push, and the LIP
bound against a direct integration of the pendulum it is derived from. Pure numpy, except one test
that reads the plant FMU's defaults.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from anklehip.analysis.bounds import (laplace_pwl, lip_force_limit, lip_impulse_limit, robot_from_plant_params,
                             static_tipping_force, sustained_push_limit, trapezoid_integral)
from anklehip.files.scenario import PushProfile, PushSegment
from conftest import NOMINAL

PARAMS = {"g": NOMINAL["G"], "m1": NOMINAL["M1"], "l1": NOMINAL["L1"], "lg1": NOMINAL["LG1"], "I1": NOMINAL["I1"],
          "m2": NOMINAL["M2"], "lg2": NOMINAL["LG2"], "I2": NOMINAL["I2"], "feet_mass": NOMINAL["FEET_MASS"],
          "feet_com_x": NOMINAL["FEET_COM_X"], "feet_com_z": NOMINAL["FEET_COM_Z"], "toe_x": NOMINAL["TOE_X"],
          "heel_x": NOMINAL["HEEL_X"], "ankle_height": NOMINAL["ANKLE_HEIGHT"], "h_push": 0.335}
R = robot_from_plant_params(PARAMS)


def test_nominal_numbers():
    """Establishes: the nominal HOAP-2 static tipping forces are those of docs/hoap2-model.md §3
    (11.97 N on the back, 7.95 N on the chest), the sustained-push limit on the back is 19.1 N, and
    the body's inertia about the ankle is docs/controller.md's I + m lg^2 = 0.505 kg m^2."""
    assert static_tipping_force(R, +1) == pytest.approx(11.97, abs=0.005)
    assert static_tipping_force(R, -1) == pytest.approx(7.95, abs=0.005)
    assert sustained_push_limit(R, +1) == pytest.approx(19.1, abs=0.05)
    assert R.I_ankle == pytest.approx(0.505, abs=0.0005)
    assert R.omega_point > R.omega_sole > R.omega      # rotational inertia slows the fall


def test_plant_fmu_defaults_give_the_nominal_robot(fmu_path):
    """Establishes: robot_from_plant_params on the plant FMU's start values gives the robot built
    from hoap2/nominal.h (the FMU is where the sweeps take their numbers from)."""
    from anklehip.running.fmu import FMUInfo
    assert robot_from_plant_params(FMUInfo.load(fmu_path("Hoap2Plant")).start_values()) == R


def test_constant_push_lip_limit_is_static_tipping():
    """Establishes: for a push that never ends and starts as a step, the LIP bound is exactly the
    static tipping force, both directions (e(0) = -Delta_eff and the steady state e = -u meet)."""
    for d in (+1, -1):
        assert lip_force_limit(R, math.inf, 0.0, d) == pytest.approx(static_tipping_force(R, d), rel=1e-12)


def test_rectangle_closed_form_and_pushprofile_break_points():
    """Establishes: the exact piecewise-linear exponential integral equals the closed forms of a
    rectangle, (1 - e^(-w D))/w, and of a trapezoid (docs/capability.md §4), and for a trapezoid the integral over PushProfile.from_segments'
    own break points (what the sweeps apply) equals trapezoid_integral and a fine quadrature."""
    w = R.omega
    D = np.array([1e-4, 0.01, 0.1, 0.5, 2.0, 10.0])
    assert np.allclose(trapezoid_integral(w, D, 0.0), -np.expm1(-w * D) / w, rtol=1e-12, atol=0)
    r = np.array([0.01, 0.05, 0.05, 0.3])
    D = np.array([0.05, 0.1, 2.0, 4.0])         # trapezoid: (1 - e^(-w r))(1 - e^(-w (D - r)))/(r w^2)
    closed = np.expm1(-w * r) * np.expm1(-w * (D - r)) / (r * w * w)
    assert np.allclose([trapezoid_integral(w, d, x) for d, x in zip(D, r)], closed, rtol=1e-12, atol=0)
    for dur, rise in ((0.1, 0.05), (0.5, 0.05), (4.0, 0.3), (1.0, 0.0)):
        prof = PushProfile.from_segments([PushSegment("pulse", t=0, force=1.0, duration=dur, rise=rise)])
        exact = laplace_pwl(prof.times, prof.values, w)
        assert trapezoid_integral(w, dur, rise) == pytest.approx(exact, rel=1e-12)
        t = np.linspace(0.0, dur, 200001)
        f = prof.value(t) * np.exp(-w * t)
        assert exact == pytest.approx(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(t)), rel=1e-6)


def test_short_push_tends_to_the_impulse_limit():
    """Establishes: as the duration goes to 0 the LIP force limit times the push's impulse per unit
    peak (D - rise) tends to J_max = m_b g Delta_eff / (h w), for rectangles and trapezoids."""
    for d in (+1, -1):
        J = lip_impulse_limit(R, d)
        assert lip_force_limit(R, 1e-6, 0.0, d) * 1e-6 == pytest.approx(J, rel=1e-5)
        assert lip_force_limit(R, 2e-6, 1e-6, d) * 1e-6 == pytest.approx(J, rel=1e-5)


def test_monotone_in_duration():
    """Establishes: a longer push of the same shape is never easier: the LIP limit decreases with
    the duration (strictly while D is not long against 1/w) towards its value for a push that never ends."""
    D = np.geomspace(0.06, 20.0, 300)
    F = lip_force_limit(R, D, 0.03)
    assert np.all(np.diff(F) <= 0) and np.all(np.diff(F[D < 2.0]) < 0)
    assert F[-1] == pytest.approx(lip_force_limit(R, math.inf, 0.03), rel=1e-6)


def test_bounds_scale_as_one_over_height():
    """Establishes: every bound is a moment limit: it scales as 1/h with the push height."""
    r2 = dataclasses.replace(R, h=2 * R.h)
    for d in (+1, -1):
        for fn in (static_tipping_force, sustained_push_limit, lip_impulse_limit):
            assert fn(r2, d) == pytest.approx(fn(R, d) / 2, rel=1e-12)
        assert np.allclose(lip_force_limit(r2, [0.1, 1.0], 0.05, d), lip_force_limit(R, [0.1, 1.0], 0.05, d) / 2)


@pytest.mark.parametrize("direction", [+1, -1])
def test_lip_limit_is_the_capture_threshold_of_the_pendulum(direction):
    """Establishes: the closed form is the threshold of the model it is derived from: integrating
    x'' = w^2 [(x - p) + (m_f/m_b)(x_f - p) + F(t) h/(m_b g)] with p at the toe (heel), from rest
    erect, a push 1 % below F_max ends with the body swinging back (captured) and 1 % above with it
    diverging over the edge."""
    w, mu, dur, rise = R.omega, R.m_f / R.m_b, 0.3, 0.05
    p = R.x_toe if direction > 0 else R.x_heel
    prof = PushProfile.from_segments([PushSegment("pulse", t=0, force=float(direction), duration=dur, rise=rise)])
    fmax = float(lip_force_limit(R, dur, rise, direction))
    F = np.array([0.99, 1.01]) * fmax

    def deriv(t, x, v):
        u = F * float(prof.value(t)) * R.h / (R.m_b * R.g)
        return v, w * w * ((x - p) + mu * (R.x_f - p) + u)

    dt, x, v = 1e-3, np.zeros(2), np.zeros(2)
    for k in range(3000):                    # RK4 over 3 s
        t = k * dt
        k1 = deriv(t, x, v)
        k2 = deriv(t + dt / 2, x + dt / 2 * k1[0], v + dt / 2 * k1[1])
        k3 = deriv(t + dt / 2, x + dt / 2 * k2[0], v + dt / 2 * k2[1])
        k4 = deriv(t + dt, x + dt * k3[0], v + dt * k3[1])
        x = x + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        v = v + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    assert direction * x[0] < 0        # 1 % below: swung back, the ZMP can come off the edge
    assert direction * x[1] > 0.1      # 1 % above: diverged over the edge
