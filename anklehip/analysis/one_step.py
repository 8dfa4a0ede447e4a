"""The one-step optimum (docs/capability.md section 9.3): the largest push a robot could survive with
one recovery step, by trajectory optimization on a sagittal five-link model with the robot's limits.

The model: the stance shank and thigh, the upper body (everything above the hip pitch axes), the
swing thigh and shank, in the sagittal plane; the coordinates are the five segments' absolute
pitch angles phi (0 upright, + leaning forward: the shank and thigh from their lower joint up, the
upper body from the hip up, the swing thigh and shank the same way, from the knee and the ankle
up). The segments' masses, CoMs and pitch inertias are the robot file's bodies lumped per segment
(biped_from_description: the rule of anklehip.robot.lump, split at the knees), each leg's the mean
of left and right. The joints: stance ankle phi0, stance knee phi0 - phi1, stance hip phi2 - phi1,
swing hip phi2 - phi3, swing knee phi4 - phi3 (the knees + flexed, the hips in the sagittal model's
sense: + the trunk forward of the thigh), swing ankle phi4 (its foot held flat). The equations come
from the Lagrangian with CasADi symbolics.

The phases, for a push F(t) = F_peak s(t) on the back (s the trapezoid of flat_footed.push_shape) at
the height h of the upper body's axis (the sagittal plant's push point):

    [0, t_lift]      both feet down, side by side: the swing ankle held at the stance ankle (the two
                     soles one support in the sagittal plane); the ground reaction of both under the
                     stance foot's constraints;
    [t_lift, t_land] the stance foot alone (flat), the swing foot flat above the ground;
    t_land           the swing foot lands at rest (no impact) at its ankle L ahead, L <= l_max;
    [t_land, T]      both feet down, apart: the front ankle pinned (a constraint force lambda), its foot
                     loaded through lambda and the front ankle torque;
    T = duration + t_after: at rest, the whole robot's CoM between the rear heel and the front toe
                     (the robot stands; the controller straightens up quasi-statically).

Every phase keeps each loaded sole's centre of pressure between its heel and toe, its normal force
>= 0 and its friction within mu, the joints within their ranges, torques and rates (per joint: the
robot file's effort and velocity limits), the swing foot above the ground: over the middle half of the
swing (from a quarter of the swing's time after the lift to a quarter before the landing) at least
`clearance` above it (0 by default: the foot may skim the ground, touching it without load).

Transcription: direct collocation, Radau IIA of degree 3 (flat_footed.radau_coefficients) on a mesh
aligned with the push's and the phases' break points; the torques a value per collocation point;
F_peak a decision variable maximised (one NLP), with two small terms: the torques' squared steps
(REG) and their squares' integral relative to the limits (EFFORT: on two feet apart three torques
are free). IPOPT (MUMPS), tol 1e-9. With both feet down the equations of motion are imposed
implicitly (phi'' and the front foot's force lambda variables at each collocation point; with both
legs straight the explicit pinned equations are singular), the feet's places at the acceleration
level: side by side, the swing leg's angular accelerations equal the stance leg's (from rest side by
side, the collocation keeps the angles equal exactly) and the legs' torques their twin's (the split
of the load is not determined); landed, the front ankle's acceleration zero with Baumgarte's
feedback on its velocity and place from the landing's (BAUMGARTE). Constraints that would be
imposed twice (the twin legs' limits, the two soles side by side, the ground clearance at the
landing) are imposed once: duplicated active constraints, and the front ankle's place imposed at
every collocation point (ill-conditioned as 1/h^2), kept IPOPT from converging on finer meshes.

CasADi is imported when a function here is called.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .flat_footed import DEGREE, IPOPT_OPTIONS, push_shape, radau_coefficients

REG = 1e-6          # weight of the torques' squared steps between collocation points, against F_peak [N]
BAUMGARTE = 20.0    # [1/s]: the landed foot's constraint drift decays at this rate (critically damped)
EFFORT = 1e-3       # weight of the integral of the torques' squares (relative to their limits) [N/s]
JOINTS = ("stance ankle", "stance knee", "stance hip", "swing hip", "swing knee")


@dataclass(frozen=True)
class Segment:
    """A rigid segment: mass [kg], CoM (forward, up) from its lower joint in the standing posture [m]
    (the upper body: from the hip pitch axes; the foot: from the ankle pitch axis), pitch inertia
    about the CoM [kg m^2]."""
    mass: float
    com: tuple[float, float]
    inertia: float


@dataclass(frozen=True)
class Biped:
    """The sagittal five-link biped (module docstring) and its limits, SI."""
    g: float
    ankle_height: float        # ankle pitch axis above the sole
    shank_length: float        # ankle to knee pitch axes
    thigh_length: float        # knee to hip pitch axes
    shank: Segment
    thigh: Segment
    upper: Segment
    foot: Segment
    toe: float                 # the sole's front edge forward of the ankle axis
    heel: float                # its back edge (< 0)
    ankle_range: tuple[float, float]
    knee_range: tuple[float, float]    # flexion + (the robot's knee sense)
    hip_range: tuple[float, float]     # the trunk forward of the thigh + (the sagittal model's sense)
    tau_max: tuple[float, float, float]   # per joint: ankle, knee, hip [N m]
    vel_max: tuple[float, float, float]   # [rad/s]
    mu: float
    push_height: float         # above the ground

    @property
    def mass(self) -> float:
        return self.upper.mass + 2 * (self.shank.mass + self.thigh.mass + self.foot.mass)


def biped_from_description(path, srdf=None, keyframe: str | None = None, mu: float = 1.0,
                           push_height: float = 0.335, g: float = 9.81) -> Biped:
    """The Biped of a robot file (URDF or MJCF, anklehip.robot.description) in its standing posture:
    the legs' pitch joints found as anklehip.robot.lump.find_legs does, one knee per leg; each
    segment's bodies lumped (mass, CoM, pitch inertia about the CoM); the joints' ranges, efforts
    and velocities from the file (the narrower of left and right). mu and the push height are not
    in a robot file (defaults: Hoap2Plant3D's mu, the scenarios' push point)."""
    from ..robot.description import load_description
    from ..robot.lump import _joint_body, find_legs, lump, lump_description
    from ..robot.robotfile import RobotFileError
    d = load_description(path, srdf=srdf, keyframe=keyframe)
    legs = find_legs(d)
    where = str(d.path)
    if len(legs.knees) != 2:
        raise RobotFileError(f"{where}: legs: {len(legs.knees)} pitch joints between the ankles and the hips "
                             f"({', '.join(legs.knees) or 'none'}); the five-link model needs one knee per leg")
    jb, B = _joint_body(d), d.bodies
    per_leg = []
    for side in range(2):
        ankle, knee, hip = (B[jb[n]] for n in (legs.ankle[side], legs.knees[side], legs.hip[side]))
        feet = set(d.subtree(jb[legs.ankle[side]]))
        below_knee = set(d.subtree(jb[legs.knees[side]]))
        shank = lump([B[n] for n in below_knee - feet])
        thigh = lump([B[n] for n in set(d.subtree(jb[legs.hip[side]])) - below_knee])
        foot = lump([B[n] for n in feet])
        a, k, h = ankle.joint.anchor, knee.joint.anchor, hip.joint.anchor
        per_leg.append(dict(
            shank=(shank.mass, shank.com[0] - a[0], shank.com[2] - a[2], shank.Iyy),
            thigh=(thigh.mass, thigh.com[0] - k[0], thigh.com[2] - k[2], thigh.Iyy),
            foot=(foot.mass, foot.com[0] - a[0], foot.com[2] - a[2], foot.Iyy),
            shank_length=k[2] - a[2], thigh_length=h[2] - k[2], ankle_z=a[2], hip=h,
            joints=(ankle.joint, knee.joint, hip.joint)))
    upper = lump([B[n] for n in legs.link2])
    hip = np.mean([leg["hip"] for leg in per_leg], axis=0)

    def mean_segment(name):
        v = np.mean([leg[name] for leg in per_leg], axis=0)
        return Segment(float(v[0]), (float(v[1]), float(v[2])), float(v[3]))

    # the ground and the sole as the sagittal lump finds them
    sagittal = lump_description(d).model
    ankle_height = float(sagittal["ankle_height"].value)

    def limits(i, flip):
        lo, hi, eff, vel = [], [], [], []
        for leg in per_leg:
            j = leg["joints"][i]
            s = -1.0 if flip(j) else 1.0
            a, b = (s * j.lower, s * j.upper) if j.lower is not None and j.upper is not None else (-math.pi, math.pi)
            lo.append(min(a, b)), hi.append(max(a, b))
            eff.append(j.effort if j.effort else math.inf), vel.append(j.velocity if j.velocity else math.inf)
        return (max(lo), min(hi)), min(eff), min(vel)

    # the file's senses: a joint about +y turns the part below it backward (the knee flexes, the ankle
    # tips the shank forward: +; the hip tips the trunk forward of the thigh: its angle's negative)
    ankle_r, ankle_t, ankle_v = limits(0, lambda j: j.axis[1] < 0)
    knee_r, knee_t, knee_v = limits(1, lambda j: j.axis[1] < 0)
    hip_r, hip_t, hip_v = limits(2, lambda j: j.axis[1] > 0)
    return Biped(g=g, ankle_height=ankle_height,
                 shank_length=float(np.mean([leg["shank_length"] for leg in per_leg])),
                 thigh_length=float(np.mean([leg["thigh_length"] for leg in per_leg])),
                 shank=mean_segment("shank"), thigh=mean_segment("thigh"),
                 upper=Segment(upper.mass, (float(upper.com[0] - hip[0]), float(upper.com[2] - hip[2])), upper.Iyy),
                 foot=mean_segment("foot"),
                 toe=float(sagittal["toe_x"].value), heel=float(sagittal["heel_x"].value),
                 ankle_range=ankle_r, knee_range=knee_r, hip_range=hip_r,
                 tau_max=(ankle_t, knee_t, hip_t), vel_max=(ankle_v, knee_v, hip_v), mu=mu,
                 push_height=push_height)


def hoap2() -> Biped:
    """HOAP-2 from its robot file (hoap2/hoap2.urdf, SRDF posture "standing")."""
    root = Path(__file__).resolve().parents[2] / "hoap2"
    return biped_from_description(root / "hoap2.urdf", srdf=root / "hoap2.srdf", keyframe="standing")


# ---------------------------------------------------------------------------------------------
# the model

def _rot(phi, v):
    """A segment-fixed vector (forward, up) of the standing posture, the segment pitched by phi."""
    import casadi as ca
    c, s = ca.cos(phi), ca.sin(phi)
    return ca.vertcat(v[0] * c + v[1] * s, -v[0] * s + v[1] * c)


def joint_map() -> np.ndarray:
    """The joint angles (JOINTS, then the swing ankle) as a linear map of phi."""
    return np.array([[1, 0, 0, 0, 0], [1, -1, 0, 0, 0], [0, -1, 1, 0, 0], [0, 0, 1, -1, 0], [0, 0, 0, -1, 1],
                     [0, 0, 0, 0, 1]], float)


@dataclass
class Model:
    """CasADi functions of the five-link model (x = (phi, phi')):
    single(x, tau5, F) -> (phi'', tau_s)   with the swing foot in the air, held flat by its ankle
                         torque tau_s (+ on the shank);
    pinned(x, phi'', lambda, tau6, F) -> the residual of the equations of motion with both feet down
                         (tau6: the five joints and the front ankle; lambda the force the front foot
                         exerts on the chain at its ankle): zero for the motion;
    points(x) -> (swing ankle, its velocity, whole-body CoM with both feet, push point);
    foot_acc(x, phi'') -> the swing ankle's acceleration;
    reaction(x, phi'', lambda, tau_ankle, F, with_swing_foot) -> (Gx, Gz, Gz * cop) of the stance
                         foot's ground reaction, cop its centre of pressure from its ankle;
    front(lambda, tau_front_ankle) -> (Gx, Gz, Gz * cop) of the front foot;
    mass_bias(x) -> (M, bias) of the single-support equations (for the checks)."""
    single: object
    pinned: object
    points: object
    foot_acc: object
    reaction: object
    front: object
    mass_bias: object


def model(bp: Biped) -> Model:
    import casadi as ca
    a, ls, lt = bp.ankle_height, bp.shank_length, bp.thigh_length
    phi, dphi = ca.SX.sym("phi", 5), ca.SX.sym("dphi", 5)
    ddphi_s, lam = ca.SX.sym("ddphi", 5), ca.SX.sym("lam", 2)
    tau5, tau_f, F = ca.SX.sym("tau", 5), ca.SX.sym("tau_front"), ca.SX.sym("F")
    up = lambda p: ca.vertcat(ca.sin(p), ca.cos(p))
    A = ca.vertcat(0, a)
    K = A + ls * up(phi[0])
    H = K + lt * up(phi[1])
    K2 = H - lt * up(phi[3])
    A2 = K2 - ls * up(phi[4])
    P = H + (bp.push_height - a - ls - lt) * up(phi[2])
    links = [(bp.shank, A + _rot(phi[0], bp.shank.com), 0), (bp.thigh, K + _rot(phi[1], bp.thigh.com), 1),
             (bp.upper, H + _rot(phi[2], bp.upper.com), 2),
             # the swing thigh and shank: their CoMs from their lower joints, which move
             (bp.thigh, K2 + _rot(phi[3], bp.thigh.com), 3), (bp.shank, A2 + _rot(phi[4], bp.shank.com), 4)]
    swing_foot = A2 + ca.vertcat(bp.foot.com[0], bp.foot.com[1])

    def lagrange(bodies, q, dq, w):
        """M(q), bias(q, q') of bodies (segment, CoM, its angular rate from w = dq's)."""
        T = V = 0
        for seg, p, k in bodies:
            v = ca.jacobian(p, q) @ dq
            T += 0.5 * seg.mass * ca.dot(v, v) + 0.5 * seg.inertia * w[k] ** 2
            V += seg.mass * bp.g * p[1]
        M = ca.hessian(T, dq)[0]
        return M, ca.jacobian(M @ dq, q) @ dq - ca.gradient(T, q) + ca.gradient(V, q)

    Jj = ca.DM(joint_map()[:5])
    JP, JA2 = ca.jacobian(P, phi), ca.jacobian(A2, phi)
    Q = Jj.T @ tau5 + JP.T @ ca.vertcat(F, 0)
    # in the air the swing foot is a sixth body, turned by phi5 (its pitch); its ankle torque tau_s
    # (+ on the shank, - on the foot) holds it flat: phi5 = phi5' = phi5'' = 0 solve for tau_s
    phi5, dphi5 = ca.SX.sym("phi5"), ca.SX.sym("dphi5")
    q6, dq6 = ca.vertcat(phi, phi5), ca.vertcat(dphi, dphi5)
    foot6 = A2 + _rot(phi5, bp.foot.com)
    M6, b6 = lagrange(links + [(bp.foot, foot6, 5)], q6, dq6, dq6)
    M6, b6 = (ca.substitute(e, ca.vertcat(phi5, dphi5), ca.DM.zeros(2)) for e in (M6, b6))
    e4 = ca.DM([0, 0, 0, 0, 1])
    aug = ca.blockcat([[M6[:5, :5], -e4], [M6[5:, :5], ca.DM.ones(1, 1)]])
    air = ca.solve(aug, ca.vertcat(Q - b6[:5], -b6[5]))
    single, tau_swing_ankle = air[:5], air[5]
    M_air, b_air = M6[:5, :5], b6[:5]
    air_bodies = links + [(bp.foot, swing_foot, None)]
    # both feet down: M phi'' + b = Q + e4 tau_front + JA2^T lambda (the residual; the swing foot's
    # place is a constraint of the problem, lambda a variable: with both legs straight the split of
    # the load between the feet is not determined by the dynamics)
    M_pin, b_pin = lagrange(links, phi, dphi, dphi)
    pinned = M_pin @ ddphi_s + b_pin - Q - e4 * tau_f - JA2.T @ lam
    x = ca.vertcat(phi, dphi)

    # the stance foot's ground reaction: the chain's momentum gives the force R its ankle carries,
    # the foot's balance about its ankle the centre of pressure (the stance ankle torque tau0 acts on
    # the shank, its reaction on the foot): cop Gz = -a Gx + x_f m_f g - tau0
    def reaction_of(bodies, ddp, lam_, tau0, push):
        Rx = -push - lam_[0]
        Rz = -lam_[1]
        for seg, p, k in bodies:
            J = ca.jacobian(p, phi)
            acc = J @ ddp + ca.jacobian(J @ dphi, phi) @ dphi
            Rx += seg.mass * acc[0]
            Rz += seg.mass * (acc[1] + bp.g)
        Gx, Gz = Rx, Rz + bp.foot.mass * bp.g
        return ca.vertcat(Gx, Gz, -a * Gx + bp.foot.com[0] * bp.foot.mass * bp.g - tau0)

    with_foot = ca.SX.sym("with_swing_foot")
    r_air = reaction_of(air_bodies, ddphi_s, ca.DM.zeros(2), tau5[0], F)
    r_pin = reaction_of(links, ddphi_s, lam, tau5[0], F)
    # the front foot: the chain pulls it with -lambda and turns it with -tau_front
    Gf = lam + ca.vertcat(0, bp.foot.mass * bp.g)
    front = ca.vertcat(Gf[0], Gf[1], -a * Gf[0] + bp.foot.com[0] * bp.foot.mass * bp.g - tau_f)
    m_all = bp.mass
    com = (sum(seg.mass * p for seg, p, _ in links) + bp.foot.mass * swing_foot
           + bp.foot.mass * (A + ca.vertcat(bp.foot.com[0], bp.foot.com[1]))) / m_all
    return Model(
        single=ca.Function("single", [x, tau5, F], [single, tau_swing_ankle]),
        pinned=ca.Function("pinned", [x, ddphi_s, lam, ca.vertcat(tau5, tau_f), F], [pinned]),
        points=ca.Function("points", [x], [A2, JA2 @ dphi, com, P]),
        foot_acc=ca.Function("foot_acc", [x, ddphi_s], [JA2 @ ddphi_s + ca.jacobian(JA2 @ dphi, phi) @ dphi]),
        reaction=ca.Function("reaction", [x, ddphi_s, lam, tau5, F, with_foot],
                             [with_foot * r_air + (1 - with_foot) * r_pin]),
        front=ca.Function("front", [lam, tau_f], [front]),
        mass_bias=ca.Function("mass_bias", [x], [M_air, b_air]))


# ---------------------------------------------------------------------------------------------
# the optimal control problem

@dataclass
class Solution:
    """One solved point: the optimum peak force [N], where the step landed (its ankle, forward of the
    stance ankle) [m], the trajectory at the mesh points (t, phi, phi'), the torques at the
    collocation points (the five joints, then the front ankle); ok False when IPOPT did not report success."""
    f_peak: float
    landing: float
    ok: bool
    status: str
    t: np.ndarray
    phi: np.ndarray
    dphi: np.ndarray
    tau: np.ndarray
    n_intervals: int
    seconds: float


def solve(bp: Biped, duration: float = 1.0, rise: float = 0.05, t_lift: float = 0.0, t_land: float = 0.3,
          l_max: float | None = None, t_after: float = 1.0, dt: float = 0.02, l_min: float = 0.0,
          guess: Solution | None = None, clearance: float = 0.0) -> Solution:
    """The largest peak force [N] of the back push (duration, rise) at bp.push_height that the robot
    survives by one step lifting at t_lift and landing at t_land (module docstring), its landing at
    least l_min and at most l_max ahead (None: wherever the legs reach), the swing sole at least `clearance`
    [m] above the ground over the middle half of the swing, on a mesh of intervals <= dt; from `guess`
    (another mesh's solution, interpolated) or from rest."""
    import casadi as ca
    if not 0.0 <= t_lift < t_land < duration + t_after:
        raise ValueError(f"one_step.solve: need 0 <= t_lift ({t_lift}) < t_land ({t_land}) < "
                         f"duration + t_after ({duration + t_after})")
    if not clearance >= 0.0:
        raise ValueError(f"one_step.solve: clearance {clearance} m: need >= 0")
    t0 = time.perf_counter()
    from .flat_footed import mesh
    mdl = model(bp)
    tau_c, C, D = radau_coefficients()
    # the push's mesh (flat_footed.mesh) with the lift and the landing added as break points
    tm = np.union1d(mesh(duration, rise, t_after, dt), [t_lift, t_land])
    N = len(tm) - 1
    k_lift = int(np.argmin(abs(tm - t_lift)))
    k_land = int(np.argmin(abs(tm - t_land)))
    Jm = joint_map()
    t_max = np.array([bp.tau_max[i] for i in (0, 1, 2, 2, 1, 0)])       # the five joints, the front ankle
    v_max = np.array([bp.vel_max[i] for i in (0, 1, 2, 2, 1, 0)])
    q_lo = np.array([bp.ankle_range[0], bp.knee_range[0], bp.hip_range[0], bp.hip_range[0], bp.knee_range[0],
                     bp.ankle_range[0]])
    q_hi = np.array([bp.ankle_range[1], bp.knee_range[1], bp.hip_range[1], bp.hip_range[1], bp.knee_range[1],
                     bp.ankle_range[1]])

    opti = ca.Opti()
    Fp, L = opti.variable(), opti.variable()
    X = opti.variable(10, N + 1)
    U = opti.variable(6, N * DEGREE)
    Xc = [opti.variable(10, DEGREE) for _ in range(N)]

    def sole(G):
        """A loaded sole: G = (Gx, Gz, Gz cop): cop between heel and toe, Gz >= 0, friction."""
        opti.subject_to(G[2] - bp.heel * G[1] >= 0)
        opti.subject_to(bp.toe * G[1] - G[2] >= 0)
        opti.subject_to(G[1] >= 0)
        opti.subject_to(opti.bounded(-bp.mu * G[1], G[0], bp.mu * G[1]))

    def node(x, u, f, phase, landing=False, clear=0.0):
        """The dynamics' phi'' and the path constraints at a collocation point of a phase: 'together'
        (both feet down, side by side: the legs move as one), 'landed' (both feet down, the front
        ankle at L) or 'air' (the stance foot alone, its swing sole at least `clear` above the ground)."""
        # the limits (side by side, the other leg's joints and torques are this leg's: bounded once,
        # as duplicated active constraints leave IPOPT's multipliers undetermined)
        n = 3 if phase == "together" else 6
        j, dj = (Jm @ x[0:5])[:n], (Jm @ x[5:10])[:n]
        opti.subject_to(opti.bounded(q_lo[:n], j, q_hi[:n]))
        opti.subject_to(opti.bounded(-v_max[:n], dj, v_max[:n]))
        opti.subject_to(opti.bounded(-t_max[:n], u[:n], t_max[:n]))
        if phase != "air":
            ddphi, lam = opti.variable(5), opti.variable(2)
            opti.set_initial(lam, [0.0, 0.5 * bp.mass * bp.g])
            opti.subject_to(mdl.pinned(x, ddphi, lam, u, f) == 0)
            if phase == "together":
                # the swing thigh and shank turn with the stance ones (from rest side by side: the
                # collocation keeps a linear relation of the accelerations in the angles exactly)
                opti.subject_to(ddphi[3] == ddphi[1])
                opti.subject_to(ddphi[4] == ddphi[0])
                # the legs side by side share the load: each joint's torque equals its twin's
                # (the split is not determined by the dynamics)
                opti.subject_to(u[3:6] == u[2::-1])
            else:
                # the front ankle held at (L, ankle height) from the landing's place and rest on: its
                # acceleration zero, with Baumgarte's feedback against the drift of the discretisation
                # (the place itself at every collocation point, index 3, is ill-conditioned as
                # O(1/h^2) and stalled IPOPT on fine meshes)
                A2, dA2 = mdl.points(x)[0:2]
                opti.subject_to(mdl.foot_acc(x, ddphi) + 2 * BAUMGARTE * dA2
                                + BAUMGARTE ** 2 * (A2 - ca.vertcat(L, bp.ankle_height)) == 0)
            rear, front = mdl.reaction(x, ddphi, lam, u[0:5], f, 0.0), mdl.front(lam, u[5])
            if phase == "together":
                sole(rear + front)      # one sole (each sole's constraints would be the same ones)
            else:
                sole(rear)
                sole(front)
        else:
            ddphi, tau_s = mdl.single(x, u[0:5], f)
            opti.subject_to(opti.bounded(-t_max[5], tau_s, t_max[5]))
            opti.subject_to(u[5] == 0)
            sole(mdl.reaction(x, ddphi, ca.DM.zeros(2), u[0:5], f, 1.0))
            if not landing:             # there the landing's equality holds (the same constraint)
                opti.subject_to(mdl.points(x)[0][1] >= bp.ankle_height + clear)
        return ddphi

    opti.subject_to(X[:, 0] == 0)
    for k in range(N):
        h = tm[k + 1] - tm[k]
        phase = "together" if k < k_lift else ("air" if k < k_land else "landed")
        xs = [X[:, k]] + [Xc[k][:, j] for j in range(DEGREE)]
        for j in range(1, DEGREE + 1):
            f = Fp * float(push_shape(tm[k] + tau_c[j] * h, duration, rise))
            x, u = xs[j], U[:, k * DEGREE + j - 1]
            tc = tm[k] + tau_c[j] * h
            mid = 0.75 * t_lift + 0.25 * t_land <= tc <= 0.25 * t_lift + 0.75 * t_land
            ddphi = node(x, u, f, phase, landing=k == k_land - 1 and j == DEGREE, clear=clearance if mid else 0.0)
            opti.subject_to(sum(C[i, j] * xs[i] for i in range(DEGREE + 1)) == h * ca.vertcat(x[5:10], ddphi))
        opti.subject_to(X[:, k + 1] == sum(D[i] * xs[i] for i in range(DEGREE + 1)))
    # the landing: at rest, on the ground, L ahead
    A2, dA2, _, _ = mdl.points(X[:, k_land])
    opti.subject_to(A2 == ca.vertcat(L, bp.ankle_height))
    opti.subject_to(dA2 == 0)
    opti.subject_to(L >= l_min)
    if l_max is not None:
        opti.subject_to(L <= l_max)
    # at rest at T, the CoM between the rear heel and the front toe
    com = mdl.points(X[:, N])[2]
    opti.subject_to(X[5:10, N] == 0)
    opti.subject_to(opti.bounded(bp.heel, com[0], L + bp.toe))
    opti.subject_to(Fp >= 0)
    # the torques' steps, and their sizes weighted by the intervals (the closed chain on two feet
    # leaves three torques free: their smallest use is chosen)
    effort = sum((tm[k + 1] - tm[k]) * ca.sumsqr(ca.diag(1.0 / t_max) @ U[:, k * DEGREE:(k + 1) * DEGREE])
                 for k in range(N))
    opti.minimize(-Fp + REG * ca.sumsqr(U[:, 1:] - U[:, :-1]) + EFFORT * effort)
    if guess is not None:
        xg = np.array([np.interp(tm, guess.t, col) for col in np.hstack([guess.phi, guess.dphi]).T])
        opti.set_initial(X, xg)
        for k in range(N):
            h = tm[k + 1] - tm[k]
            tc = tm[k] + tau_c[1:] * h
            opti.set_initial(Xc[k], np.array([np.interp(tc, tm, row) for row in xg]))
        tg = np.repeat(guess.t[:-1], DEGREE) + np.tile(tau_c[1:], len(guess.t) - 1) * np.repeat(np.diff(guess.t), DEGREE)
        tu = np.repeat(tm[:-1], DEGREE) + np.tile(tau_c[1:], N) * np.repeat(np.diff(tm), DEGREE)
        opti.set_initial(U, np.array([np.interp(tu, tg, col) for col in guess.tau.T]))
        opti.set_initial(Fp, guess.f_peak)
        opti.set_initial(L, guess.landing)
    else:
        opti.set_initial(Fp, 10.0)
        opti.set_initial(L, 0.05)
    opti.solver("ipopt", IPOPT_OPTIONS)
    try:
        sol = opti.solve()
        ok, get = True, sol.value
    except RuntimeError:
        ok, get = False, opti.debug.value
    status = opti.stats()["return_status"]
    Xv, Uv, F, Lv = np.atleast_2d(get(X)), np.atleast_2d(get(U)), float(get(Fp)), float(get(L))
    return Solution(F, Lv, ok, status, tm, Xv[0:5].T, Xv[5:10].T, Uv.T, N, time.perf_counter() - t0)
