"""The flat-footed optimum (docs/capability.md section 8): the largest push any flat-footed controller
could survive, by trajectory optimization on the sagittal model with the robot's limits.

The model is the sagittal plant's (docs/plant.md sections 1-2) with the feet held flat: the feet
are at rest, the two joints (ankle theta1, hip theta2; + when the body above pitches forward) are
the coordinates and their torques the controls. The two-link equations are derived here from the
Lagrangian with CasADi symbolics from the plant's masses, lengths and inertias (Robot, l1); the
ground reaction follows from the whole robot's momentum and angular momentum about the ground
point under the ankle, so the centre of pressure (ZMP) and the friction demand are functions of
the state, the torques and the push.

The optimal control problem, for a push F(t) = direction * F_peak * s(t) (s the sweeps' trapezoid,
anklehip.analysis.bounds.trapezoid_integral) at the height h:

    maximise F_peak over the joint torques tau(t) on [0, T], T = duration + t_after,
    subject to  the dynamics, from rest erect (q = 0, q' = 0) at the push onset,
                x_heel <= ZMP <= x_toe and Fz >= 0 (the feet stay flat: no rocking, no lift-off),
                |Fx| <= mu Fz (friction cone),
                |tau_i| <= tau_max_i, |q_i'| <= vel_max_i (servo limits), q_min <= q <= q_max,
                q'(T) = 0 and the robot's CoM over the sole at T (at rest and standing: a
                capturable state, the controller then holds it and straightens up quasi-statically).

Transcription: direct collocation, Radau IIA of degree 3 (order 5) on a mesh aligned with the push's
break points (0, rise, duration - rise, duration), the torques a value per collocation point; the
path constraints at every collocation point and at the initial state; F_peak is a decision
variable, so the optimum is one NLP (no bisection: IPOPT cannot prove an NLP infeasible, and
maximising F_peak directly gives the boundary as a KKT point). IPOPT (MUMPS), tol 1e-9. The
objective carries a small torque-smoothness term (REG) that makes the torques unique where the
force does not decide them; its effect on F_peak is measured in docs/capability.md section 8.

CasADi is imported when a function here is called; reading the cached optimum
(anklehip.analysis.bounds.flat_footed_optimum) needs only numpy.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .bounds import Robot, robot_from_plant_params

# CasADi's default IPOPT settings with a tight tolerance and no printing
IPOPT_OPTIONS = {"ipopt.tol": 1e-9, "ipopt.acceptable_tol": 1e-7, "ipopt.max_iter": 3000, "ipopt.print_level": 0,
                 "print_time": False, "ipopt.sb": "yes", "ipopt.mu_strategy": "adaptive", "expand": True}
DEGREE = 3          # Radau collocation points per interval
REG = 1e-6          # weight of the torques' squared steps between collocation points [1/(N m)^2], against F_peak [N]


@dataclass(frozen=True)
class Limits:
    """The robot's limits the optimum respects (SI): servo torque and velocity per joint (both legs'
    motors together, the plant's tau_max_*, vel_max_*), the pitch joint ranges (the header's
    ANKLE_MIN ... HIP_MAX) and the sole's friction coefficient."""
    tau_ankle: float
    tau_hip: float
    vel_ankle: float
    vel_hip: float
    ankle_min: float
    ankle_max: float
    hip_min: float
    hip_max: float
    mu: float


@dataclass(frozen=True)
class Problem:
    """The robot, its link 1 length, its limits, and the push direction (+1 on the back, -1 on the
    chest); joints locked by name ("hip", "both") for the checks against the analytic bounds."""
    robot: Robot
    l1: float
    limits: Limits
    direction: int = 1
    locked: str = ""


# the plant's and the header's names of the limits (bounds_parameters gives both)
LIMIT_NAMES = {"tau_ankle": "tau_max_ankle", "tau_hip": "tau_max_hip", "vel_ankle": "vel_max_ankle",
               "vel_hip": "vel_max_hip", "ankle_min": "ankle_min", "ankle_max": "ankle_max",
               "hip_min": "hip_min", "hip_max": "hip_max"}


def problem_from_params(params: dict, direction: int = 1, mu: float | None = None, locked: str = "") -> Problem:
    """A Problem from bounds_parameters' numbers (the plant FMU's parameters completed by its header):
    the Robot, l1, the servo limits and joint ranges; the friction coefficient mu unless params have
    it (the sagittal plant assumes sticking; scripts/flat_footed_optimum.py takes Hoap2Plant3D's)."""
    p = {k: float(v) for k, v in params.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}
    missing = [n for n in LIMIT_NAMES.values() if n not in p] + (["mu"] if mu is None and "mu" not in p else [])
    if missing:
        raise KeyError(f"the flat-footed optimum needs the plant's/header's {', '.join(missing)}")
    lim = Limits(**{k: p[n] for k, n in LIMIT_NAMES.items()}, mu=mu if mu is not None else p["mu"])
    return Problem(robot_from_plant_params(params), p["l1"], lim, direction, locked)


# ---------------------------------------------------------------------------------------------
# the model

def model_functions(pb: Problem):
    """CasADi functions of the flat-footed two-link model:
    accel(q, dq, tau, F) -> q'' (2), and
    contact(q, dq, tau, F) -> (Fx, Fz, Mp) the ground reaction on the robot (horizontal, vertical)
    and Mp = Fz * ZMP (the ZMP's moment form, no division), and
    statics(q) -> (x_com of the whole robot, x_body of the body CoM, z of the push point).
    Lagrangian of the links on the fixed feet: T = sum m_i |v_i|^2/2 + I_i a_i'^2/2,
    V = g sum m_i z_i; M(q) q'' + (d(M q')/dq) q' - dT/dq + dV/dq = tau + J_P^T (F, 0)."""
    import casadi as ca
    r = pb.robot
    a, l1 = r.ankle_height, pb.l1
    lg1, lg2 = r.z1 - a, r.z2 - a - l1
    dP = r.h - a - l1                     # push point along link 2's axis from the hip (docs/plant.md section 6)
    q, dq, tau = ca.SX.sym("q", 2), ca.SX.sym("dq", 2), ca.SX.sym("tau", 2)
    F = ca.SX.sym("F")
    t1, t12 = q[0], q[0] + q[1]
    p1 = ca.vertcat(lg1 * ca.sin(t1), a + lg1 * ca.cos(t1))
    hip = ca.vertcat(l1 * ca.sin(t1), a + l1 * ca.cos(t1))
    p2 = hip + lg2 * ca.vertcat(ca.sin(t12), ca.cos(t12))
    pP = hip + dP * ca.vertcat(ca.sin(t12), ca.cos(t12))
    J1, J2, JP = (ca.jacobian(p, q) for p in (p1, p2, pP))
    v1, v2 = J1 @ dq, J2 @ dq
    w1, w2 = dq[0], dq[0] + dq[1]
    T = 0.5 * (r.m1 * ca.dot(v1, v1) + r.m2 * ca.dot(v2, v2) + r.I1 * w1 ** 2 + r.I2 * w2 ** 2)
    V = r.g * (r.m1 * p1[1] + r.m2 * p2[1])
    M = ca.hessian(T, dq)[0]
    bias = ca.jacobian(M @ dq, q) @ dq - ca.gradient(T, q) + ca.gradient(V, q)
    ddq = ca.solve(M, tau + JP.T @ ca.vertcat(F, 0) - bias)
    # CoM accelerations J q'' + (dJ/dt) q'
    acc1 = J1 @ ddq + ca.jacobian(v1, q) @ dq
    acc2 = J2 @ ddq + ca.jacobian(v2, q) @ dq
    dw1, dw2 = ddq[0], ddq[0] + ddq[1]
    mf, xf = r.m_f, r.x_f
    # momentum: Fx + F = sum m a_x; Fz = sum m (a_z + g) + m_f g
    Fx = r.m1 * acc1[0] + r.m2 * acc2[0] - F
    Fz = r.m1 * (acc1[1] + r.g) + r.m2 * (acc2[1] + r.g) + mf * r.g
    # angular momentum about the ground point p under the ankle's ground projection, the reaction at
    # p = ZMP having no moment there: Fz p = sum m_i [x_i (a_zi + g) - z_i a_xi] - sum I_i a_i'' + F z_P + m_f g x_f
    Mp = (r.m1 * (p1[0] * (acc1[1] + r.g) - p1[1] * acc1[0]) + r.m2 * (p2[0] * (acc2[1] + r.g) - p2[1] * acc2[0])
          - r.I1 * dw1 - r.I2 * dw2 + F * pP[1] + mf * r.g * xf)
    x_body = (r.m1 * p1[0] + r.m2 * p2[0]) / r.m_b
    x_com = (r.m_b * x_body + mf * xf) / r.m_tot
    return (ca.Function("accel", [q, dq, tau, F], [ddq]),
            ca.Function("contact", [q, dq, tau, F], [ca.vertcat(Fx, Fz, Mp)]),
            ca.Function("statics", [q], [ca.vertcat(x_com, x_body, pP[1])]),
            ca.Function("mass_bias", [q, dq], [M, bias]))


def radau_coefficients(d: int = DEGREE):
    """(tau, C, D) of Radau IIA collocation of degree d on [0, 1] with the interval start added:
    tau = [0, tau_1 .. tau_d], C[j, r] = L_j'(tau_r), D[j] = L_j(1) for the Lagrange basis L_j."""
    import casadi as ca
    tau = np.array([0.0] + list(ca.collocation_points(d, "radau")))
    C = np.zeros((d + 1, d + 1))
    D = np.zeros(d + 1)
    for j in range(d + 1):
        others = np.delete(tau, j)
        Lj = np.poly1d(others, r=True) / np.prod(tau[j] - others)
        D[j] = Lj(1.0)
        dL = np.polyder(Lj)
        C[j] = [dL(t) for t in tau]
    return tau, C, D


def mesh(duration: float, rise: float, t_after: float, dt: float) -> np.ndarray:
    """The mesh points on [0, duration + t_after]: the push's break points (0, rise, duration - rise,
    duration) and, between them, equal intervals no longer than dt (at least one per segment)."""
    r = min(rise, duration / 2)
    br = sorted({0.0, r, duration - r, duration, duration + t_after})
    pts = [0.0]
    for a, b in zip(br[:-1], br[1:]):
        if b - a <= 1e-12:
            continue
        n = max(1, math.ceil((b - a) / dt - 1e-9))
        pts += list(np.linspace(a, b, n + 1)[1:])
    return np.array(pts)


def push_shape(t, duration: float, rise: float):
    """s(t), the trapezoid normalised to peak 1 (PushProfile's pulse: up in rise, held, down in rise)."""
    t = np.asarray(t, float)
    r = min(rise, duration / 2)
    if r <= 0:
        return np.where((t >= 0) & (t < duration), 1.0, 0.0)
    return np.clip(np.minimum(t / r, (duration - t) / r), 0.0, 1.0)


@dataclass
class Solution:
    """One solved point: the optimum peak force [N, magnitude] and the trajectory at the mesh points
    (t, q, dq), the torques at the collocation points and the ZMP at the mesh points (with the
    torque of the interval's first collocation point); ok False when IPOPT did not report success."""
    f_peak: float
    ok: bool
    status: str
    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    tau: np.ndarray
    zmp: np.ndarray
    n_intervals: int
    seconds: float


def solve(pb: Problem, duration: float, rise: float, dt: float = 0.02, t_after: float = 1.5,
          f_guess: float | None = None) -> Solution:
    """The largest peak force [N] of the trapezoid (duration, rise) at the robot's h in pb.direction
    that the flat-footed robot survives (module docstring), on a mesh of intervals <= dt."""
    import time

    import casadi as ca
    t0 = time.perf_counter()
    accel, contact, statics, _ = model_functions(pb)
    lim, r = pb.limits, pb.robot
    tau_c, C, D = radau_coefficients()
    tm = mesh(duration, rise, t_after, dt)
    N = len(tm) - 1
    opti = ca.Opti()
    Fp = opti.variable()
    X = opti.variable(4, N + 1)          # (q1, q2, dq1, dq2) at the mesh points
    U = opti.variable(2, N * DEGREE)     # torques at the collocation points
    Xc = [opti.variable(4, DEGREE) for _ in range(N)]
    sgn = float(pb.direction)
    lo = np.array([lim.ankle_min, lim.hip_min, -lim.vel_ankle, -lim.vel_hip])
    hi = np.array([lim.ankle_max, lim.hip_max, lim.vel_ankle, lim.vel_hip])
    lock = {"": [], "hip": [1], "both": [0, 1]}[pb.locked]

    def path(x, u, f):
        Fx, Fz, Mp = (contact(x[0:2], x[2:4], u, f)[i] for i in range(3))
        opti.subject_to(Mp - Fz * r.x_heel >= 0)      # ZMP >= heel
        opti.subject_to(Fz * r.x_toe - Mp >= 0)       # ZMP <= toe
        opti.subject_to(Fz >= 0)
        opti.subject_to(opti.bounded(-lim.mu * Fz, Fx, lim.mu * Fz))

    opti.subject_to(X[:, 0] == 0)
    path(X[:, 0], U[:, 0], sgn * Fp * float(push_shape(0.0, duration, rise)))
    for k in range(N):
        h = tm[k + 1] - tm[k]
        xs = [X[:, k]] + [Xc[k][:, j] for j in range(DEGREE)]
        for j in range(1, DEGREE + 1):
            tj = tm[k] + tau_c[j] * h
            f = sgn * Fp * float(push_shape(tj, duration, rise))
            x, u = xs[j], U[:, k * DEGREE + j - 1]
            ddq = accel(x[0:2], x[2:4], u, f)
            for i in lock:                            # a locked joint: its torque holds it (q = q' = 0 follow)
                opti.subject_to(ddq[i] == 0)
            opti.subject_to(sum(C[i, j] * xs[i] for i in range(DEGREE + 1)) == h * ca.vertcat(x[2:4], ddq))
            opti.subject_to(opti.bounded(lo, x, hi))
            opti.subject_to(opti.bounded(-lim.tau_ankle, u[0], lim.tau_ankle))
            opti.subject_to(opti.bounded(-lim.tau_hip, u[1], lim.tau_hip))
            path(x, u, f)
        opti.subject_to(X[:, k + 1] == sum(D[i] * xs[i] for i in range(DEGREE + 1)))
    opti.subject_to(opti.bounded(lo, X[:, N], hi))
    # at rest at T, the whole robot's CoM over the sole: the controller can hold it and straighten up
    opti.subject_to(X[2:4, N] == 0)
    xc = statics(X[0:2, N])[0]
    opti.subject_to(opti.bounded(r.x_heel, xc, r.x_toe))
    opti.subject_to(Fp >= 0)
    dU = U[:, 1:] - U[:, :-1]
    opti.minimize(-Fp + REG * ca.sumsqr(dU))
    opti.set_initial(Fp, f_guess if f_guess is not None else 10.0)
    opti.set_initial(X, 0)
    opti.set_initial(U, 0)
    opti.solver("ipopt", IPOPT_OPTIONS)
    try:
        sol = opti.solve()
        ok, get = True, sol.value
    except RuntimeError:
        ok, get = False, opti.debug.value
    status = opti.stats()["return_status"]
    Xv, Uv, F = np.atleast_2d(get(X)), np.atleast_2d(get(U)), float(get(Fp))
    zmp = np.full(N, np.nan)
    for k in range(N):
        Fx, Fz, Mp = np.array(contact(Xv[0:2, k], Xv[2:4, k], Uv[:, k * DEGREE],
                                      sgn * F * float(push_shape(tm[k], duration, rise)))).ravel()
        zmp[k] = Mp / Fz
    return Solution(F, ok, status, tm, Xv[0:2].T, Xv[2:4].T, Uv.T, zmp, N, time.perf_counter() - t0)


def static_optimum(pb: Problem, rigid_height: bool = False) -> float:
    """The largest constant push [N] the robot holds in a static posture: q' = q'' = 0, the ZMP in the
    sole, the body CoM over the sole (it still stands when the push stops), joint and torque limits.
    rigid_height: the push's moment arm held at h whatever the lean (the small-angle assumption of
    anklehip.analysis.bounds.sustained_push_limit, which this then equals)."""
    import casadi as ca
    accel, contact, statics, _ = model_functions(pb)
    lim, r = pb.limits, pb.robot
    opti = ca.Opti()
    q, u, Fp = opti.variable(2), opti.variable(2), opti.variable()
    f = pb.direction * Fp
    rest = ca.DM.zeros(2)
    Fx, Fz, Mp = (contact(q, rest, u, f)[i] for i in range(3))
    st = statics(q)
    if rigid_height:
        Mp = Mp + f * (r.h - st[2])
    opti.subject_to(accel(q, rest, u, f) == 0)          # the torques hold the posture
    opti.subject_to(Mp - Fz * r.x_heel >= 0)
    opti.subject_to(Fz * r.x_toe - Mp >= 0)
    opti.subject_to(opti.bounded(r.x_heel, st[1], r.x_toe))
    opti.subject_to(opti.bounded([lim.ankle_min, lim.hip_min], q, [lim.ankle_max, lim.hip_max]))
    opti.subject_to(opti.bounded([-lim.tau_ankle, -lim.tau_hip], u, [lim.tau_ankle, lim.tau_hip]))
    opti.subject_to(opti.bounded(-lim.mu * Fz, Fx, lim.mu * Fz))
    if pb.locked in ("hip", "both"):
        opti.subject_to(q[1] == 0)
    if pb.locked == "both":
        opti.subject_to(q[0] == 0)
    opti.minimize(-Fp)
    opti.set_initial(Fp, 10.0)
    opti.solver("ipopt", IPOPT_OPTIONS)
    return float(opti.solve().value(Fp))


def with_height(pb: Problem, h: float) -> Problem:
    """The same problem with the push at height h above the sole."""
    return dataclasses.replace(pb, robot=dataclasses.replace(pb.robot, h=h))
