"""The one-step optimum (anklehip/analysis/one_step.py, docs/capability.md section 9.3): the five-link
model from the robot file against the sagittal lump and against Pinocchio (a library we did not
write), and the optimization against what it must reproduce."""
from __future__ import annotations

import functools

import numpy as np
import pytest

from conftest import NOMINAL, REPO_ROOT

ca = pytest.importorskip("casadi")
from anklehip.analysis import one_step as os_  # noqa: E402


@functools.lru_cache(maxsize=None)
def _biped() -> os_.Biped:
    return os_.hoap2()


@functools.lru_cache(maxsize=None)
def _model() -> os_.Model:
    return os_.model(_biped())


def test_segments_add_up_to_the_sagittal_lump():
    """Establishes: the five-link split of hoap2/hoap2.urdf is the sagittal model's (hoap2/nominal.h,
    lumped from the same robot by hoap2/lump.py): the upper body is link 2 (mass, CoM above the hip,
    inertia), both legs' shanks and thighs together are link 1 (mass, CoM height, the leg length),
    the feet are the feet; the limits are the file's (9 N m, 5 rad/s per joint; the header's ranges)."""
    b = _biped()
    assert b.upper.mass == pytest.approx(NOMINAL["M2"], rel=1e-5)
    assert b.upper.com[1] == pytest.approx(NOMINAL["LG2"], rel=1e-5)
    assert b.upper.inertia == pytest.approx(NOMINAL["I2"], rel=1e-5)
    m_leg = b.shank.mass + b.thigh.mass
    assert 2 * m_leg == pytest.approx(NOMINAL["M1"], rel=1e-5)
    lg1 = (b.shank.mass * b.shank.com[1] + b.thigh.mass * (b.shank_length + b.thigh.com[1])) / m_leg
    assert lg1 == pytest.approx(NOMINAL["LG1"], rel=1e-4)
    assert b.shank_length + b.thigh_length == pytest.approx(NOMINAL["L1"], rel=1e-9)
    assert 2 * b.foot.mass == pytest.approx(NOMINAL["FEET_MASS"], rel=1e-5)
    assert (b.toe, b.heel, b.ankle_height) == pytest.approx((NOMINAL["TOE_X"], NOMINAL["HEEL_X"],
                                                              NOMINAL["ANKLE_HEIGHT"]), abs=1e-12)
    assert b.hip_range == pytest.approx((NOMINAL["HIP_MIN"], NOMINAL["HIP_MAX"]))
    assert b.ankle_range == pytest.approx((NOMINAL["ANKLE_MIN"], NOMINAL["ANKLE_MAX"]))
    assert b.knee_range == pytest.approx((NOMINAL["KNEE_MIN"], NOMINAL["KNEE_MAX"]))
    assert b.tau_max == (9.0, 9.0, 9.0) and b.vel_max == (5.0, 5.0, 5.0)


def _pinocchio(b: os_.Biped, with_swing_foot: bool):
    """The same chain in Pinocchio: revolute joints about +y from the stance ankle (ankle_height above
    the ground) up the stance leg to the hip, the upper body on it, the swing hip, knee and (with the
    foot) the swing ankle turning the foot back flat; each segment's CoM and inertia as the Biped's."""
    pin = pytest.importorskip("pinocchio")
    m = pin.Model()
    m.gravity.linear = np.array([0.0, 0.0, -b.g])

    def body(j, seg: os_.Segment, dz: float = 0.0):
        m.appendBodyToJoint(j, pin.Inertia(seg.mass, np.array([seg.com[0], 0.0, seg.com[1] + dz]),
                                           np.diag([1e-4, seg.inertia, 1e-4])), pin.SE3.Identity())

    def joint(parent, z, name):
        return m.addJoint(parent, pin.JointModelRY(), pin.SE3(np.eye(3), np.array([0.0, 0.0, z])), name)

    j0 = joint(0, b.ankle_height, "stance_ankle"); body(j0, b.shank)
    j1 = joint(j0, b.shank_length, "stance_knee"); body(j1, b.thigh)
    j2 = joint(j1, b.thigh_length, "hip"); body(j2, b.upper)
    j3 = joint(j2, 0.0, "swing_hip"); body(j3, b.thigh, -b.thigh_length)
    j4 = joint(j3, -b.thigh_length, "swing_knee"); body(j4, b.shank, -b.shank_length)
    S = [[1, 0, 0, 0, 0], [-1, 1, 0, 0, 0], [0, -1, 1, 0, 0], [0, 0, -1, 1, 0], [0, 0, 0, -1, 1]]
    if with_swing_foot:
        j5 = joint(j4, -b.shank_length, "swing_ankle"); body(j5, b.foot)
        S.append([0, 0, 0, 0, -1])
    m.addFrame(pin.Frame("swing_ankle_point", j4, pin.SE3(np.eye(3), np.array([0.0, 0.0, -b.shank_length])),
                         pin.FrameType.OP_FRAME))
    return pin, m, np.array(S, float)


def _push_force(pin, m, d, q, F):
    """The push as Pinocchio's external force on the upper body's joint, at the push point on its axis."""
    b = _biped()
    fext = [pin.Force.Zero() for _ in range(m.njoints)]
    f_loc = d.oMi[3].rotation.T @ np.array([F, 0.0, 0.0])
    dP = b.push_height - b.ankle_height - b.shank_length - b.thigh_length
    fext[3] = pin.Force(f_loc, np.cross([0.0, 0.0, dP], f_loc))
    return fext


def test_single_support_against_pinocchio():
    """Establishes: the CasADi-derived single-support equations are the rigid-body dynamics: at 20
    random states the mass matrix and bias equal Pinocchio's CRBA and nonLinearEffects mapped to the
    absolute angles (q = S phi), the accelerations under random torques and a push, with the swing
    foot held flat by the model's swing ankle torque, satisfy Pinocchio's inverse dynamics (the foot
    a sixth body on its own ankle joint), and the stance foot's ground reaction and centre of pressure equal the force
    Pinocchio transmits through the stance ankle plus the foot's weight."""
    b, mdl = _biped(), _model()
    pin, m, S = _pinocchio(b, True)
    d = m.createData()
    rng = np.random.default_rng(3)
    for _ in range(20):
        phi, dphi = rng.uniform(-0.7, 0.7, 5), rng.uniform(-4, 4, 5)
        tau, F = rng.uniform(-9, 9, 5), rng.uniform(-40, 40)
        x = np.concatenate([phi, dphi])
        M, bias = (np.array(v) for v in mdl.mass_bias(x))
        Mp = pin.crba(m, d, S @ phi)
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        assert np.allclose(M, S.T @ Mp @ S, rtol=1e-10, atol=1e-12)
        assert np.allclose(bias.ravel(), S.T @ pin.nonLinearEffects(m, d, S @ phi, S @ dphi), atol=1e-10)
        ddphi, tau_s = (np.array(v).ravel() for v in mdl.single(x, tau, F))
        pin.forwardKinematics(m, d, S @ phi)
        tq = pin.rnea(m, d, S @ phi, S @ dphi, S @ ddphi, _push_force(pin, m, d, S @ phi, F))
        # the five joints' torques map back through S; the swing ankle's holds the foot flat
        # (Pinocchio's acts on the foot, the model's tau_s on the shank)
        gen = np.array(os_.joint_map()[:5]).T @ tau + np.array([0, 0, 0, 0, 1.0]) * tau_s[0]
        assert np.allclose(S.T @ tq, gen, atol=1e-9)
        assert tq[5] == pytest.approx(-tau_s[0], abs=1e-9)
        w = d.oMi[1].act(d.f[1])
        Gx, Gz, Gcop = np.array(mdl.reaction(x, ddphi, np.zeros(2), tau, F, 1.0)).ravel()
        assert Gx == pytest.approx(w.linear[0], abs=1e-9)
        assert Gz == pytest.approx(w.linear[2] + b.foot.mass * b.g, abs=1e-9)
        assert Gcop == pytest.approx(b.foot.com[0] * b.foot.mass * b.g - w.angular[1], abs=1e-9)


def test_double_support_against_pinocchio():
    """Establishes: with both feet down, the model's equations of motion are the rigid-body dynamics:
    at 20 random states, accelerations, joint torques, front-foot forces lambda and pushes, the
    residual the optimization drives to zero is Pinocchio's inverse dynamics (lambda applied at the
    swing ankle point, the push at the push point) less the joint torques; and the front foot's
    reaction is lambda plus its weight."""
    b, mdl = _biped(), _model()
    pin, m, S = _pinocchio(b, False)
    d = m.createData()
    rng = np.random.default_rng(5)
    for _ in range(20):
        phi, dphi, ddphi = rng.uniform(-0.7, 0.7, 5), rng.uniform(-4, 4, 5), rng.uniform(-30, 30, 5)
        tau, F, lam = rng.uniform(-9, 9, 6), rng.uniform(-40, 40), rng.uniform(-50, 50, 2)
        x = np.concatenate([phi, dphi])
        residual = np.array(mdl.pinned(x, ddphi, lam, tau, F)).ravel()
        q, v, a = S @ phi, S @ dphi, S @ ddphi
        pin.forwardKinematics(m, d, q, v, a)
        fext = _push_force(pin, m, d, q, F)
        f_loc = d.oMi[5].rotation.T @ np.array([lam[0], 0.0, lam[1]])
        fext[5] = fext[5] + pin.Force(f_loc, np.cross([0.0, 0.0, -b.shank_length], f_loc))
        tq = pin.rnea(m, d, q, v, a, fext)
        gen = np.array(os_.joint_map()[:5]).T @ tau[:5] + np.array([0, 0, 0, 0, 1.0]) * tau[5]
        assert np.allclose(residual, S.T @ tq - gen, atol=1e-9)
        Gx, Gz, Gcop = np.array(mdl.front(lam, tau[5])).ravel()
        assert (Gx, Gz) == pytest.approx((lam[0], lam[1] + b.foot.mass * b.g), abs=1e-12)


@functools.lru_cache(maxsize=None)
def _coarse_optimum() -> os_.Solution:
    """The step lifting at the onset of a 1 s back push and landing 300 ms after it, on the coarse mesh."""
    return os_.solve(_biped(), duration=1.0, t_land=0.3, t_after=0.5, dt=0.05)


def test_a_coarse_optimum_steps_and_stands():
    """Establishes, on a coarse mesh (50 ms intervals; the cached values are the mesh check's finer
    ones): the optimization converges for a 1 s back push with the step landing 300 ms after the
    onset, the swing foot lands at rest on the ground L ahead and stays there (the acceleration-level
    constraint's discretisation
    drift on this mesh under 5 mm, 2.6-3.3 mm measured, and under 0.1 mm at rest), the robot is at rest
    at the end with its CoM over the feet,
    every joint stays within its range and rate, and the push it survives is larger than the
    flat-footed optimum's for the same push (docs/capability.md section 8)."""
    from anklehip.analysis import bounds as B
    b, mdl = _biped(), _model()
    s = _coarse_optimum()
    assert s.ok, s.status
    k = int(np.argmin(abs(s.t - 0.3)))
    A2, dA2, _, _ = (np.array(v).ravel() for v in mdl.points(np.concatenate([s.phi[k], s.dphi[k]])))
    assert A2 == pytest.approx([s.landing, b.ankle_height], abs=1e-8)
    assert dA2 == pytest.approx([0.0, 0.0], abs=1e-8)
    assert s.landing > 0.05
    for i in range(k, len(s.t)):
        A2 = np.array(mdl.points(np.concatenate([s.phi[i], s.dphi[i]]))[0]).ravel()
        assert A2 == pytest.approx([s.landing, b.ankle_height], abs=5e-3), f"the landed foot drifted at {s.t[i]} s"
    assert A2 == pytest.approx([s.landing, b.ankle_height], abs=1e-4)
    _, _, com, _ = (np.array(v).ravel() for v in mdl.points(np.concatenate([s.phi[-1], s.dphi[-1]])))
    assert np.allclose(s.dphi[-1], 0.0, atol=1e-8)
    assert b.heel - 1e-9 <= com[0] <= s.landing + b.toe + 1e-9
    joints = s.phi @ os_.joint_map().T
    assert joints.min(axis=0)[1] >= b.knee_range[0] - 1e-8 and joints.max(axis=0)[0] <= b.ankle_range[1] + 1e-8
    assert np.abs(s.dphi @ os_.joint_map().T).max() <= 5.0 + 1e-6
    assert s.f_peak > B.flat_footed_optimum(1.0)


def _cache() -> dict:
    from anklehip.analysis import bounds as B
    return B.load_one_step_optimum()


def _converged(points):
    """The cached points IPOPT solved on both meshes to a step forward (anklehip.analysis.bounds'
    one_step_points: not the step in place, a poorer local optimum)."""
    from anklehip.analysis import bounds as B
    series = sorted({B.one_step_series(p) for p in points})
    return [p for t, c in series for p in B.one_step_points({"points": points}, t_lift=t, clearance=c)]


def test_cache_is_current():
    """Establishes: the cached one-step optimum (scripts/one_step_optimum.py) was made by the current
    sources (the model, the collocation it borrows from flat_footed.py, the robot file); in each of
    its two series (the step lifting at the onset, skimming the ground; lifting 60 ms in, 10 mm clear)
    at least three landing times converged on both meshes to a step forward, the mesh refinement
    (50 to 25 ms) changing none of them by more than 0.5 %, the landed foot's drift under 5 mm on the
    coarse mesh and under 2.5 mm on the fine one at every one of them; the longer horizon (1 s after the push)
    changed the horizon check's point by less than 0.5 %. The points that did not converge, or whose
    meshes disagree, are in the cache as such (docs/capability.md 9.3 lists them)."""
    import hashlib
    d = _cache()
    for f, h in d["sources_sha256"].items():
        assert hashlib.sha256((REPO_ROOT / f).read_bytes()).hexdigest() == h, \
            f"{f} changed: regenerate the cache with scripts/one_step_optimum.py"
    assert not d["quick"]
    assert d["settings"]["effort"] == os_.EFFORT and d["settings"]["baumgarte"] == os_.BAUMGARTE
    good = _converged(d["points"])
    from anklehip.analysis.bounds import one_step_series
    assert {one_step_series(p) for p in d["points"]} == {(0.0, 0.0), (0.06, 0.01)}
    for series in ((0.0, 0.0), (0.06, 0.01)):
        assert len({p["t_land"] for p in good if one_step_series(p) == series}) >= 3, series
    assert max(abs(p["rel_change_mesh"]) for p in good) < 0.005
    # the landed foot's drift (the acceleration-level constraint's): under 5 mm on the coarse mesh, under
    # 2.5 mm on the fine one
    assert all(p["landed_drift"] < 0.0025 and p["landed_drift_coarse"] < 0.005 for p in good), \
        [(p["landed_drift"], p["landed_drift_coarse"]) for p in good]
    assert d["horizon_check"]["ok"] and abs(d["horizon_check"]["rel_change_horizon"]) < 0.005


def test_one_step_beats_the_flat_footed_optimum():
    """Establishes, from the cache's converged points: with a step lifting at the push's onset, the best
    landing time survives more than the flat-footed optimum of the same push (section 8) and more than
    the sustained-push limit (section 3), the sizes docs/capability.md section 9.3 states."""
    from anklehip.analysis import bounds as B
    best = max(p["f_peak"] for p in _converged(_cache()["points"]) if p["t_lift"] == 0.0)
    assert best > B.flat_footed_optimum(1.0)
    assert best > B.load_optimum()["static"]["1"]["rigid_height"]      # the sustained-push limit, 19.11 N


def test_a_later_step_that_clears_the_ground():
    """Establishes, on the coarse mesh: the step lifting 60 ms after the onset (the push-aware layer's
    decision) with its sole at least 10 mm above the ground over the middle half of the swing
    (one_step.solve's clearance; docs/capability.md section 9.3) converges, warm-started from the step
    lifting at the onset, to a step at least 100 mm forward whose swing ankle keeps that clearance at every mesh point
    of the middle half and stays above the ground for the whole swing, and it survives more than the
    sustained-push limit; a negative clearance is a ValueError."""
    from anklehip.analysis import bounds as B
    b, mdl = _biped(), _model()
    t_lift, t_land, clear = 0.06, 0.3, 0.01
    # a step at least 100 mm forward (free, the warm start may fall into the step in place, a poorer
    # local optimum: the script's best_coarse)
    s = os_.solve(b, 1.0, 0.05, t_lift, t_land, t_after=0.5, dt=0.05, clearance=clear, guess=_coarse_optimum(),
                  l_min=0.1)
    assert s.ok and s.landing > B.ONE_STEP_FORWARD, (s.status, s.landing)
    height = np.array([float(mdl.points(np.concatenate([p, v]))[0][1]) for p, v in zip(s.phi, s.dphi)])
    swing = (s.t > t_lift + 1e-9) & (s.t < t_land - 1e-9)
    mid = (s.t >= 0.75 * t_lift + 0.25 * t_land - 1e-9) & (s.t <= 0.25 * t_lift + 0.75 * t_land + 1e-9)
    assert mid.sum() >= 2
    assert height[mid].min() >= b.ankle_height + clear - 1e-7
    assert height[swing].min() >= b.ankle_height - 1e-7
    assert s.f_peak > B.load_optimum()["static"]["1"]["rigid_height"]      # the sustained-push limit, 19.11 N
    with pytest.raises(ValueError, match="clearance"):
        os_.solve(b, 1.0, 0.05, t_lift, t_land, clearance=-0.01)



def test_docs_one_step_tables_are_the_caches():
    """Establishes: the tables of docs/capability.md section 9.3 are the cache's, as
    `python -m anklehip.analysis.bounds` prints them (anklehip.analysis.bounds.one_step_table)."""
    from anklehip.analysis import bounds as B
    assert B.one_step_table() in (REPO_ROOT / "docs" / "capability.md").read_text(encoding="utf-8")
