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


def _rk4(deriv, n: int = 3000, dt: float = 1e-3) -> np.ndarray:
    """x after n RK4 steps of x'' = deriv(t, x, v)[1] from rest at 0 (x, v: arrays of two runs)."""
    x, v = np.zeros(2), np.zeros(2)
    for k in range(n):
        t = k * dt
        k1 = deriv(t, x, v)
        k2 = deriv(t + dt / 2, x + dt / 2 * k1[0], v + dt / 2 * k1[1])
        k3 = deriv(t + dt / 2, x + dt / 2 * k2[0], v + dt / 2 * k2[1])
        k4 = deriv(t + dt, x + dt * k3[0], v + dt * k3[1])
        x = x + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        v = v + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    return x


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

    x = _rk4(deriv)
    assert direction * x[0] < 0        # 1 % below: swung back, the ZMP can come off the edge
    assert direction * x[1] > 0.1      # 1 % above: diverged over the edge


# ---------------------------------------------------------------------------------------------
# every horizontal direction: the robot on both feet (docs/capability.md section 7)

from anklehip.analysis.bounds import (HEADER_NAMES, bounds_parameters, lip_force_limit_3d,  # noqa: E402
                                      lip_impulse_limit_3d, plant_header, push_direction, stance_from_params,
                                      static_tipping_force_3d, sustained_push_limit_3d, tipping_edge)

FRONTAL = {k: NOMINAL[m] for k, m in HEADER_NAMES.items() if k not in PARAMS}
ST = stance_from_params({**PARAMS, **FRONTAL})           # the sagittal model on two feet: x_b = 0
ST3 = dataclasses.replace(ST, x_b=0.003, y_b=0.0004, y_f=-0.0002)   # CoMs off the centre: the general case
ANGLES = np.arange(0.0, 360.0, 7.5)


def test_on_the_x_axis_the_bounds_are_the_sagittal_ones():
    """Establishes: pushes at 0 deg (on the back) and 180 deg (on the chest), also written as 360,
    -180 or 540 deg, give exactly (bit for bit) the sagittal functions' bounds for the robot whose
    body CoM stands over the ankles, and the direction's components are exact on the axes."""
    assert [tuple(map(float, push_direction(a))) for a in (0, 90, 180, 270, 360, -90)] == \
        [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0), (1.0, 0.0), (0.0, -1.0)]
    D = np.array([0.1, 0.2, 0.5, 1.0, 4.0, math.inf])
    for a, d in ((0, 1), (360, 1), (180, -1), (-180, -1), (540, -1)):
        assert static_tipping_force_3d(ST, a) == static_tipping_force(R, d)
        assert sustained_push_limit_3d(ST, a) == sustained_push_limit(R, d)
        assert lip_impulse_limit_3d(ST, a) == lip_impulse_limit(R, d)
        assert np.array_equal(lip_force_limit_3d(ST, a, D, 0.05), lip_force_limit(R, D, 0.05, d))


def _soles_hull(st):
    """The support polygon computed independently: scipy's convex hull of the two soles' 8 corners, as
    half-planes A z + b <= 0."""
    from scipy.spatial import ConvexHull
    b, half = st.body, st.sole_width / 2
    corners = [(x, s * st.ankle_y + e) for s in (-1, 1) for e in (-half, half) for x in (b.x_heel, b.x_toe)]
    eq = ConvexHull(np.array(corners)).equations
    return eq[:, :2], eq[:, 2]


@pytest.mark.parametrize("st", [ST, ST3], ids=["centred", "off-centre"])
def test_static_and_sustained_bounds_are_the_linear_programs(st):
    """Establishes: in every direction (every 7.5 deg) the static tipping force is the largest push whose
    centre of pressure c + F h u/(M g) still lies in the convex hull of the two soles, and the
    sustained-push limit the largest F with M g p = m_b g c_b + m_f g c_f + F h u for some centre of
    pressure p and body CoM c_b both in the hull: each solved as a linear program by scipy (HiGHS)
    on the hull scipy computes, against the closed forms, to 1e-9."""
    from scipy.optimize import linprog
    A, b0 = _soles_hull(st)
    r = st.body
    c = np.array(st.com)
    cf = np.array([r.x_f, st.y_f])
    for a in ANGLES:
        u = np.array([float(x) for x in push_direction(a)])
        # static: max F, A (c + F k u) + b <= 0 with k = h/(M g)
        k = r.h / (r.m_tot * r.g)
        lp = linprog([-1.0], A_ub=(A @ u)[:, None] * k, b_ub=-(A @ c + b0), bounds=[(0, None)])
        assert lp.status == 0 and static_tipping_force_3d(st, a) == pytest.approx(-lp.fun, rel=1e-9), a
        # sustained: variables p (2), c_b (2), F; M p - m_b c_b - F (h/g) u = m_f c_f; p, c_b in the hull
        n = len(b0)
        A_ub = np.zeros((2 * n, 5))
        A_ub[:n, 0:2], A_ub[n:, 2:4] = A, A
        A_eq = np.hstack([r.m_tot * np.eye(2), -r.m_b * np.eye(2), -(r.h / r.g) * u[:, None]])
        lp = linprog([0, 0, 0, 0, -1.0], A_ub=A_ub, b_ub=np.concatenate([-b0, -b0]), A_eq=A_eq, b_eq=r.m_f * cf,
                     bounds=[(None, None)] * 4 + [(0, None)])
        assert lp.status == 0 and sustained_push_limit_3d(st, a) == pytest.approx(-lp.fun, rel=1e-9), a


def test_the_edge_the_robot_tips_over():
    """Establishes: tipping_edge names the edge the ray from the CoM meets: toe, left, heel, right on the
    axes, and the corner exactly in the corner's direction (with the CoM off the centre)."""
    assert [tipping_edge(ST3, a) for a in (0, 90, 180, 270)] == ["toe edge", "left edge", "heel edge", "right edge"]
    cx, cy = ST3.com
    corner = math.degrees(math.atan2(ST3.y_edge - cy, ST3.body.x_toe - cx))
    assert tipping_edge(ST3, corner) == "toe-left corner"
    assert tipping_edge(ST3, corner - 0.5) == "toe edge" and tipping_edge(ST3, corner + 0.5) == "left edge"
    assert static_tipping_force_3d(ST3, corner) == pytest.approx(
        ST3.body.m_tot * ST3.body.g * math.hypot(ST3.body.x_toe - cx, ST3.y_edge - cy) / ST3.body.h, rel=1e-12)


def test_constant_push_lip_limit_is_static_tipping_in_every_direction():
    """Establishes: for a push that never ends and starts as a step, the LIP bound is the static tipping
    force in every direction (each axis' e(0) = -Delta and steady state meet)."""
    for st in (ST, ST3):
        assert np.allclose(lip_force_limit_3d(st, ANGLES, math.inf, 0.0), static_tipping_force_3d(st, ANGLES),
                           rtol=1e-12, atol=0)


@pytest.mark.parametrize("angle", [40.0, 75.0, 130.0, 250.0, 300.0])
def test_lip_limit_3d_is_the_capture_threshold_of_both_pendulums(angle):
    """Establishes: the bound in an oblique direction is the threshold of the model it is derived from:
    integrating the sagittal pendulum (omega_x) and the lateral one (omega_y) together, each with the
    centre of pressure at the edge its push component points at (the corner), from rest erect, a
    push 1 % below the bound leaves both axes swinging back and 1 % above tips at least one over."""
    st, dur, rise = ST3, 0.3, 0.05
    r = st.body
    cx, cy = (float(x) for x in push_direction(angle))
    mu = r.m_f / r.m_b
    # per axis, from the erect body CoM: omega, the edge the push component points at, the feet's CoM, the component
    axes = [(r.omega, (r.x_toe if cx > 0 else r.x_heel) - st.x_b, r.x_f - st.x_b, cx),
            (st.omega_y, (st.y_edge if cy > 0 else -st.y_edge) - st.y_b, st.y_f - st.y_b, cy)]
    prof = PushProfile.from_segments([PushSegment("pulse", t=0, force=1.0, duration=dur, rise=rise)])
    fmax = float(lip_force_limit_3d(st, angle, dur, rise))
    F = np.array([0.99, 1.01]) * fmax
    ends = []
    for w, p, xf, comp in axes:
        def deriv(t, x, v):
            u = comp * F * float(prof.value(t)) * r.h / (r.m_b * r.g)
            return v, w * w * ((x - p) + mu * (xf - p) + u)
        ends.append(np.sign(p) * _rk4(deriv))      # > 0: over the edge's side
    below, above = [e[0] for e in ends], [e[1] for e in ends]
    assert all(e < 0 for e in below), below          # 1 % below: every axis swings back
    assert max(above) > 0.1, above                   # 1 % above: one axis diverges over its edge


def test_nominal_numbers_in_every_direction():
    """Establishes: the HOAP-2 numbers of docs/capability.md section 7 and issue 29: the soles span
    +-71.5 mm; a side push tips the erect robot at 14.97 N (m g 71.5 mm / h = 14.9 N in the issue, the
    feet's own mass counted exactly) and a flat-footed strategy holds at most 28.6 N sideways (the
    issue's ~29 N); the lateral pendulum is faster than the sagittal one and slower than a point mass;
    the parallelogram alone carries the body CoM 67 mm sideways within the hip's adduction limit."""
    assert ST.y_edge == pytest.approx(0.0715, abs=1e-12)
    assert static_tipping_force_3d(ST, 90) == pytest.approx(14.97, abs=0.005)
    assert sustained_push_limit_3d(ST, 90) == pytest.approx(28.61, abs=0.005)
    assert ST.body.omega < ST.omega_y < ST.body.omega_point
    assert ST.omega_y == pytest.approx(5.614, abs=5e-4)
    assert ST.parallelogram_reach == pytest.approx(0.0671, abs=5e-5)
    assert ST.roll_max == NOMINAL["HIP_ADDUCTION_MAX"]


def test_the_3d_plants_numbers(fmu_path):
    """Establishes: the numbers the bounds read for Hoap2Plant3D are the generated header's (which the
    source FMU carries) with the plant's link CoM offsets: the body CoM stands 3 mm ahead of the
    ankles with the joints at zero, and over them (to 1e-12 m) in the controller's erect posture,
    which is how a sweep on the plant sees it (anklehip.running.sweep.bounds_parameters_of). For
    Hoap2Plant, whose links carry their CoMs on the joint lines, the stance at 0 deg gives the
    sagittal bounds of its own parameters."""
    from anklehip.files.scenario import Scenario
    from anklehip.running.fmu import FMUInfo
    from anklehip.running.master import Models
    from anklehip.running.sweep import bounds_parameters_of
    p3 = FMUInfo.load(fmu_path("Hoap2Plant3D"))
    header = plant_header(p3.unzipdir)
    assert header == NOMINAL
    st0 = stance_from_params(bounds_parameters(p3.start_values(), header))
    m1, m2 = NOMINAL["M1"], NOMINAL["M2"]
    assert st0.x_b == pytest.approx((m1 * NOMINAL["LINK1_COM_X"] + m2 * NOMINAL["LINK2_COM_X"]) / (m1 + m2), rel=1e-12)
    p = bounds_parameters_of(Models.load(plant_model="3d"), Scenario("bounds", None, plant_model="3d"))
    assert p["theta_ankle_erect"] < 0 and p["theta_hip_erect"] < 0
    st = stance_from_params(p, p["theta_ankle_erect"], p["theta_hip_erect"])
    assert abs(st.x_b) < 1e-12 and st.body == ST.body
    sag = FMUInfo.load(fmu_path("Hoap2Plant"))
    ps = bounds_parameters(sag.start_values(), plant_header(sag.unzipdir))
    assert static_tipping_force_3d(stance_from_params(ps), 0) == static_tipping_force(robot_from_plant_params(ps))


# the bounds against the 3D plant (Hoap2Plant3D, docs/plant3d.md)

HELD = ("ankle", "hip", "knee", "ankle_roll", "hip_roll", "hip_yaw")
STIFF = {**{f"kp_{j}": 1e4 for j in HELD}, **{f"kd_{j}": 200.0 for j in HELD}}    # the joints held: a rigid robot


@pytest.fixture(scope="module")
def plant3d(fmu_path, tmp_path_factory):
    """The unzipped Hoap2Plant3D and the Stance its numbers give with the joints at zero (the posture
    the plant holds without a controller)."""
    import zipfile

    from anklehip.running.fmu import FMUInfo
    path = fmu_path("Hoap2Plant3D")
    d = tmp_path_factory.mktemp("plant3d_bounds")
    with zipfile.ZipFile(path) as z:
        z.extractall(d)
    info = FMUInfo.load(path)
    return d, stance_from_params(bounds_parameters(info.start_values(), plant_header(info.unzipdir)))


def _tipping_force_3d(unzipped, st, angle: float, rate: float = 1.0, edge: float = 1e-4):
    """A slow push ramp (rate N/s) toward `angle` on the plant with its joints held stiff at zero: the
    force at which the contacts' centre of pressure comes within `edge` of the support polygon's
    boundary (the robot starts to turn about that edge), and the centre of pressure then."""
    from conftest import Slave
    s = Slave(unzipped, STIFF)
    cx, cy = (float(x) for x in push_direction(angle))
    (toe, _), _, (heel, w), _ = st.polygon()
    try:
        while s.t < 40.0:
            f = rate * s.t
            s.set("push_force", f * cx)
            s.set("push_force_y", f * cy)
            s.step()
            px, py = s.get("zmp_true"), s.get("zmp_true_y")
            if min(toe - px, px - heel, w - py, py + w) < edge:
                return f, px, py
    finally:
        s.free()
    raise AssertionError(f"no tipping toward {angle} deg up to {f:g} N")


def test_static_tipping_force_holds_on_the_3d_plant(plant3d):
    """Establishes: the static tipping force in every direction is the 3D plant's: with the joints held
    stiff (a rigid robot standing at the joints' zero, its CoM 3.1 mm ahead of the ankles as the
    bounds compute it from the plant's link CoM offsets), a slow push ramp tips the robot -- its
    centre of pressure reaches the support polygon's boundary -- at the bound's force within 2 %,
    on the edge the bound names: to the side (90 and 270 deg: over the outer sole edge, after the
    other sole has unloaded), and obliquely onto the toes (45 deg), the left edge (60 deg) and the
    heels (150, 225 deg)."""
    unzipped, st = plant3d
    (toe, _), _, (heel, w), _ = st.polygon()
    rows = []
    for angle in (45.0, 60.0, 90.0, 150.0, 225.0, 270.0):
        f, px, py = _tipping_force_3d(unzipped, st, angle)
        bound = static_tipping_force_3d(st, angle)
        edge = tipping_edge(st, angle)
        dist = {"toe edge": toe - px, "heel edge": px - heel, "left edge": w - py, "right edge": py + w}[edge]
        rows.append(f"{angle:5.0f} deg: tips at {f:6.3f} N, bound {bound:6.3f} N ({100 * (f / bound - 1):+.2f} %), "
                    f"over the {edge}, centre of pressure ({1000 * px:.1f}, {1000 * py:.1f}) mm")
        assert f == pytest.approx(bound, rel=0.02), rows[-1]
        assert dist < 1e-4, rows[-1]
    print("\n" + "\n".join(rows))


def _free_fall_rate(unzipped, free: tuple[str, ...], com: str, zmp: str, window: tuple[float, float]) -> tuple[float, float]:
    """The robot on the plant with the joints in `free` passive (no servo, no damping) and the others
    held stiff, falling from rest: omega from a least-squares fit of com'' = omega^2 (com - zmp) over
    the samples with |com| in `window` (the linear range), and the largest trunk roll meanwhile."""
    from conftest import Slave
    params = {**STIFF, "settle_time": 0.0}
    for j in free:
        params.update({f"kp_{j}": 0.0, f"kd_{j}": 1e-6, f"damping_{j}": 0.0})
    s = Slave(unzipped, params)
    c, p, roll = [], [], []
    for _ in range(700):
        s.step()
        c.append(s.get(com))
        p.append(s.get(zmp))
        roll.append(s.get("imu_roll"))
    s.free()
    c, p = np.array(c), np.array(p)
    acc = (c[2:] - 2 * c[1:-1] + c[:-2]) / 1e-6
    pm = 0.5 * (p[1:-1] + p[2:])          # the zmp outputs are step means: centred on the sample
    m = (np.abs(c[1:-1]) > window[0]) & (np.abs(c[1:-1]) < window[1])
    x = (c[1:-1] - pm)[m]
    assert m.sum() > 100
    return math.sqrt(float(np.dot(x, acc[m]) / np.dot(x, x))), float(np.max(np.abs(roll)))


def test_pendulum_rates_are_the_3d_plants(plant3d):
    """Establishes: the LIP rates the bounds use are the 3D plant's. Released with its ankle and hip roll
    joints passive (the rest held), the robot falls sideways in the double-support parallelogram:
    the trunk does not roll (below 1e-8 rad) and the whole-robot CoM obeys
    y'' = omega_y^2 (y - p_y) with the contacts' centre of pressure p_y, omega_y = Stance.omega_y
    within 0.5 % (the upper body's roll inertia does not enter). Released with its ankle pitch
    passive, it falls forward as a rigid body about the ankles, omega_x = the sagittal omega within
    0.5 %."""
    unzipped, st = plant3d
    wy, roll = _free_fall_rate(unzipped, ("ankle_roll", "hip_roll"), "com_y", "zmp_true_y", (5e-4, 5e-3))
    wx, _ = _free_fall_rate(unzipped, ("ankle",), "com_x", "zmp_true", (3.5e-3, 8e-3))
    print(f"\nomega_y {wy:.4f} 1/s (plant) vs {st.omega_y:.4f} (bounds); trunk roll < {roll:.1e} rad; "
          f"omega_x {wx:.4f} vs {st.body.omega:.4f}")
    assert roll < 1e-8
    assert wy == pytest.approx(st.omega_y, rel=0.005)
    assert wx == pytest.approx(st.body.omega, rel=0.005)


def test_docs_tables_are_the_modules():
    """Establishes: the stance and per-direction tables of docs/capability.md section 7.5 are what
    `python -m anklehip.analysis.bounds` prints for the 3D plant in the default controller's erect
    posture (the numbers a sweep on it uses)."""
    from anklehip.analysis.bounds import direction_table, stance_table
    from anklehip.files.scenario import Scenario
    from anklehip.running.master import Models
    from anklehip.running.sweep import bounds_parameters_of
    from conftest import REPO_ROOT
    p = bounds_parameters_of(Models.load(plant_model="3d"), Scenario("bounds", None, plant_model="3d"))
    st = stance_from_params(p, p["theta_ankle_erect"], p["theta_hip_erect"])
    doc = (REPO_ROOT / "docs" / "capability.md").read_text()
    assert stance_table(st) in doc
    assert direction_table(st) in doc


# ---------------------------------------------------------------------------------------------
# N-step capturability of the LIP with a maximum step length (Koolen et al. 2012; docs/capability.md section 9)

from anklehip.analysis.bounds import (capture_margin, first_step_deadline, n_step_force_limit,  # noqa: E402
                                      n_step_impulse_limit, step_reach, sustained_push_limit_stepped)

L_MAX, DT_S = 0.1249, 0.127


def test_capture_margins_are_koolens_recursion():
    """Establishes: capture_margin is Koolen et al.'s d_N of the LIP with a finite foot (IJRR 2012,
    section 5): d_0 = r_max, d_N = (d_{N-1} - r_max + l_max) e^(-w dt_s) + r_max, its limit
    r_max + l_max e^(-w dt_s)/(1 - e^(-w dt_s)) for N -> inf; the point foot (r_max = 0) gives
    d_1 = l_max e^(-w dt_s); the margins grow with N and stay below the limit."""
    w, rm = R.omega, 0.06
    d = rm
    for n in range(12):
        assert capture_margin(rm, L_MAX, w, DT_S, n) == pytest.approx(d, rel=1e-13)
        d = (d - rm + L_MAX) * math.exp(-w * DT_S) + rm
    E = math.exp(-w * DT_S)
    assert capture_margin(rm, L_MAX, w, DT_S, math.inf) == pytest.approx(rm + L_MAX * E / (1 - E), rel=1e-13)
    assert capture_margin(rm, L_MAX, w, DT_S, 400) == pytest.approx(capture_margin(rm, L_MAX, w, DT_S, math.inf), rel=1e-12)
    assert capture_margin(0.0, L_MAX, w, DT_S, 1) == pytest.approx(L_MAX * E, rel=1e-13)
    dn = capture_margin(rm, L_MAX, w, DT_S, np.array([0, 1, 2, 3, math.inf]))
    assert np.all(np.diff(dn) > 0)


def test_zero_steps_is_the_lip_bound():
    """Establishes: 0 steps is exactly the LIP bound of the ankle strategy with the sole as the foot
    (force and impulse, both directions), and 0-length steps add nothing."""
    D = np.array([0.1, 0.3, 1.0, 4.0])
    for d in (+1, -1):
        assert np.allclose(n_step_force_limit(R, D, 0.05, d, 0, L_MAX, DT_S), lip_force_limit(R, D, 0.05, d), rtol=1e-13)
        assert n_step_impulse_limit(R, d, 0, L_MAX, DT_S) == pytest.approx(lip_impulse_limit(R, d), rel=1e-13)
        assert np.allclose(n_step_force_limit(R, D, 0.05, d, 3, 0.0, DT_S), lip_force_limit(R, D, 0.05, d), rtol=1e-13)
        assert sustained_push_limit_stepped(R, 0.0, d) == pytest.approx(sustained_push_limit(R, d), rel=1e-13)


@pytest.mark.parametrize("steps, dur, first", [(1, 0.3, None), (2, 0.3, None), (1, 1.0, 0.3), (2, 1.0, 0.36)])
def test_n_step_bound_is_the_capture_threshold_of_the_stepping_pendulum(steps, dur, first):
    """Establishes: n_step_force_limit is the threshold of the model it is derived from: the pendulum
    of test_lip_limit_is_the_capture_threshold_of_the_pendulum whose foot (sole edge and feet
    with it) moves l_max forward at dt_s, 2 dt_s, ... (or, with dt_first, at dt_first,
    dt_first + dt_s, ...): a push 1 % below the bound ends swinging back over the last foot,
    1 % above it diverges over that foot's edge (0.3 s pushes; 1 s ones whose first step lands
    at 0.3 and 0.36 s, docs/capability.md section 9.2)."""
    w, mu, rise = R.omega, R.m_f / R.m_b, 0.05
    prof = PushProfile.from_segments([PushSegment("pulse", t=0, force=1.0, duration=dur, rise=rise)])
    fmax = float(n_step_force_limit(R, dur, rise, 1, steps, L_MAX, DT_S, dt_first=first))
    assert fmax > float(lip_force_limit(R, dur, rise, 1))
    F = np.array([0.99, 1.01]) * fmax
    t1 = DT_S if first is None else first

    def shift(t):
        return L_MAX * min(steps, 0 if t < t1 - 1e-12 else 1 + math.floor((t - t1) / DT_S + 1e-12))

    def deriv(t, x, v):
        p, xf = R.x_toe + shift(t), R.x_f + shift(t)
        u = F * float(prof.value(t)) * R.h / (R.m_b * R.g)
        return v, w * w * ((x - p) + mu * (xf - p) + u)

    x = _rk4(deriv, n=4000, dt=1e-3 / 1)
    last = steps * L_MAX
    assert x[0] - last < 0             # 1 % below: swung back behind the last foot's ankle
    assert x[1] - last > 0.1           # 1 % above: diverged over its edge


def test_first_step_deadline_inverts_the_bound():
    """Establishes: a first step landing later than DT_S lowers the N-step bound (e^(-w dt_first) in
    capture_margin's last stage; dt_first = DT_S is the default), and first_step_deadline is that
    bound's inverse: the landing time at which the bound equals the force; inf for a push the flat
    foot captures, nan for one no landing of N steps can."""
    w, rm = R.omega, 0.06
    assert capture_margin(rm, L_MAX, w, DT_S, 3, dt_first=DT_S) == pytest.approx(capture_margin(rm, L_MAX, w, DT_S, 3),
                                                                                    rel=1e-13)
    d1 = capture_margin(rm, L_MAX, w, DT_S, 1, dt_first=0.3)
    assert d1 == pytest.approx(rm + L_MAX * math.exp(-w * 0.3), rel=1e-13)
    assert capture_margin(rm, L_MAX, w, DT_S, 2, dt_first=0.3) == pytest.approx(
        (capture_margin(rm, L_MAX, w, DT_S, 1) - rm + L_MAX) * math.exp(-w * 0.3) + rm, rel=1e-13)
    late = [float(n_step_force_limit(R, 1.0, 0.05, 1, 1, L_MAX, DT_S, dt_first=t)) for t in (DT_S, 0.2, 0.4, 0.8)]
    assert np.all(np.diff(late) < 0) and late[-1] > float(lip_force_limit(R, 1.0, 0.05, 1))
    for steps in (1, 2, math.inf):
        for force in (18.0, 22.0):
            t = first_step_deadline(R, force, 1.0, 0.05, 1, steps, L_MAX, DT_S)
            assert 0 < t < 1
            assert float(n_step_force_limit(R, 1.0, 0.05, 1, steps, L_MAX, DT_S, dt_first=t)) == pytest.approx(force,
                                                                                                              rel=1e-12)
    assert first_step_deadline(R, 0.9 * float(lip_force_limit(R, 1.0, 0.05, 1)), 1.0, 0.05, 1, 1, L_MAX, DT_S) == math.inf
    assert math.isnan(first_step_deadline(R, 100.0, 1.0, 0.05, 1, 1, L_MAX, DT_S))


def test_hoap2_step_reach():
    """Establishes: HOAP-2's step from its numbers (docs/capability.md section 9): legs of thigh + shank
    = 0.2 m, the pelvis lowered 10 mm, reach 2 sqrt(L^2 - (L - 0.01)^2) = 124.9 mm between the
    ankles; the swing leg's 2 x 0.318 rad at the hip's 5 rad/s: 127 ms; a lowering that needs more
    leg pitch than the ankle's range is refused."""
    p = {**PARAMS, "thigh": NOMINAL["THIGH"], "shank": NOMINAL["SHANK"], "ankle_min": NOMINAL["ANKLE_MIN"],
         "ankle_max": NOMINAL["ANKLE_MAX"], "hip_min": NOMINAL["HIP_MIN"], "hip_max": NOMINAL["HIP_MAX"],
         "vel_max_hip": 5.0}
    l, t = step_reach(p)
    assert l == pytest.approx(2 * math.sqrt(0.2 ** 2 - 0.19 ** 2), rel=1e-12) and l == pytest.approx(L_MAX, abs=1e-4)
    assert t == pytest.approx(2 * math.asin(l / 0.4) / 5.0, rel=1e-12) and t == pytest.approx(DT_S, abs=5e-4)
    with pytest.raises(ValueError, match="ankle_max"):
        step_reach(p, hip_drop=0.15)


def test_docs_n_step_table_is_the_modules(fmu_path):
    """Establishes: the N-step tables of docs/capability.md sections 9 and 9.2 are what `python -m
    anklehip.analysis.bounds` prints for the sagittal plant FMU's robot (n_step_table,
    step_timing_table)."""
    from anklehip.analysis.bounds import n_step_table, step_timing_table
    from anklehip.running.fmu import FMUInfo
    from conftest import REPO_ROOT
    plant = FMUInfo.load(fmu_path("Hoap2Plant"))
    params = bounds_parameters(plant.start_values(), plant_header(plant.unzipdir))
    doc = (REPO_ROOT / "docs" / "capability.md").read_text()
    assert n_step_table(params) in doc
    assert step_timing_table(params) in doc


SIDE = {**PARAMS, "l1": NOMINAL["L1"], "I1_roll": NOMINAL["I1_ROLL"], "ankle_y": NOMINAL["ANKLE_Y"],
        "sole_width": NOMINAL["SOLE_WIDTH"], "thigh": NOMINAL["THIGH"], "shank": NOMINAL["SHANK"],
        "hip_y": NOMINAL["HIP_Y"], "hip_abduction_max": NOMINAL["HIP_ABDUCTION_MAX"],
        "hip_adduction_max": NOMINAL["HIP_ADDUCTION_MAX"], "vel_max_hip": 5.0}


@pytest.mark.parametrize("dt", [0.108, 0.15])
def test_side_step_bound_is_the_capture_threshold_of_the_lateral_pendulum(dt):
    """Establishes: SideSteps.side_step is the threshold of the model it is derived from, checked by
    integrating that model: the pendulum (omega) starts at the mid-plane with the capture point 1 %
    below or above the bound, its CoP on the right sole's inner edge until the left foot lands
    `width` from the right ankle at dt, then on the landed sole's outer edge: below, it swings back
    inside that edge; above, it diverges over it."""
    from anklehip.analysis.bounds import side_steps
    s = side_steps(SIDE)
    a, w, om = s.ankle_y, s.half_sole, s.omega
    xi0 = np.array([0.99, 1.01]) * s.side_step(dt)
    y, v = np.zeros(2), om * xi0          # the CoM at the mid-plane, moving toward +y
    h = 1e-4
    for k in range(int(3.0 / h)):
        p = -a + w if k * h < dt else -a + s.width + w
        v = v + h * om * om * (y - p)
        y = y + h * v
    edge = -a + s.width + w
    assert y[0] < edge and y[1] > edge + 0.1


def test_side_steps_of_hoap2():
    """Establishes: HOAP-2's sideways step bounds (docs/capability.md section 9.1): the side step by
    the loaded leg gains over the flat-footed stance only when it lands within ln(W / 2 ankle_y) /
    omega of the decision (equal there, less after, e.g. at the controller's 0.2 s swing), at most
    22.6 mm at the hip servo's speed; the crossover gains nothing, the hip's adduction limit keeping
    the crossing ankle short of the stance ankle (it would gain with a hip that adducts further)."""
    from anklehip.analysis.bounds import side_steps
    s = side_steps(SIDE)
    assert s.width == pytest.approx(0.039 + 0.039 + 0.2 * math.sin(NOMINAL["HIP_ABDUCTION_MAX"]), rel=1e-12)
    assert s.side_step(s.break_even) == pytest.approx(s.flat, abs=1e-12)
    assert s.side_step(s.dt_min) - s.flat == pytest.approx(0.0226, abs=1e-4)
    assert s.side_step(0.2) < s.flat < s.side_step(0.9 * s.break_even)
    assert s.cross_ankle < s.ankle_y and s.crossover(s.dt_min) == s.flat
    wide = side_steps({**SIDE, "hip_adduction_max": 1.0})
    assert wide.cross_ankle > wide.ankle_y and wide.crossover(wide.dt_min) > wide.flat


def test_docs_side_step_table_is_the_modules(fmu_path):
    """Establishes: the sideways table of docs/capability.md section 9.1 is what `python -m
    anklehip.analysis.bounds` prints for the sagittal plant FMU's robot (side_step_table)."""
    from anklehip.analysis.bounds import side_step_table
    from anklehip.running.fmu import FMUInfo
    from conftest import REPO_ROOT
    plant = FMUInfo.load(fmu_path("Hoap2Plant"))
    table = side_step_table(bounds_parameters(plant.start_values(), plant_header(plant.unzipdir)))
    assert table in (REPO_ROOT / "docs" / "capability.md").read_text()


def test_one_step_optimum_is_the_best_converged_forward_step():
    """Establishes: one_step_optimum (docs/capability.md section 9.3) is the largest force among the
    cache's points IPOPT solved on both meshes to a step forward, with that point's landing time (the
    26.1 N, 200 ms the docs state); points that did not converge, stepped in place or whose meshes
    disagree are not among one_step_points; an uncached push is an InputError naming the push and
    the script."""
    from anklehip.analysis import bounds as B
    from anklehip.errors import InputError
    data = B.load_one_step_optimum()
    pts = B.one_step_points(data)
    assert pts and all(p["ok"] and p["landing"] > B.ONE_STEP_FORWARD and abs(p["rel_change_mesh"]) < 0.005
                       for p in pts)
    f, t = B.one_step_optimum(1.0, 0.05, data=data)
    assert f == max(p["f_peak"] for p in pts) and t == next(p["t_land"] for p in pts if p["f_peak"] == f)
    assert (round(f, 1), t) == (26.1, 0.2)
    # a larger force that did not converge, or stepped in place, does not count
    base = dict(pts[0], t_land=0.15, f_peak=99.0)
    for bad in (dict(base, ok=False), dict(base, landing=0.0), dict(base, rel_change_mesh=0.3)):
        extra = dict(data, points=data["points"] + [bad])
        assert bad not in B.one_step_points(extra) and B.one_step_optimum(1.0, 0.05, data=extra) == (f, t)
    with pytest.raises(InputError, match=r"0\.5 s back push.*one_step_optimum\.py"):
        B.one_step_optimum(0.5, 0.05, data=data)
