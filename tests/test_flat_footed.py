"""The flat-footed optimum (anklehip/analysis/flat_footed.py, its cache anklehip/analysis/data/
flat_footed_optimum.json made by scripts/flat_footed_optimum.py, docs/capability.md section 8):
the model against Pinocchio, the optimization against the analytic bounds it must reproduce in
their limits, one point re-solved against the cache, and the cache against the robot, the
analytic bounds and the measured boundaries. The full optimization is not re-run here (about
30 min); the one re-solved point takes about 20 s.
"""
from __future__ import annotations

import functools
import hashlib
import math
import re

import numpy as np
import pytest

from anklehip.analysis import bounds as B
from conftest import NOMINAL, REPO_ROOT

ca = pytest.importorskip("casadi")
from anklehip.analysis import flat_footed as ff  # noqa: E402

# the nominal robot from the header with the plant's default servo limits and the 3D plant's mu (the
# cache's own numbers are checked against the FMUs below)
PARAMS = {**{k: NOMINAL[m] for k, m in B.HEADER_NAMES.items() if m in NOMINAL}, "h_push": 0.335,
          "tau_max_ankle": 18.0, "tau_max_hip": 18.0, "vel_max_ankle": 5.0, "vel_max_hip": 5.0, "mu": 1.0}


@functools.lru_cache(maxsize=None)
def _data() -> dict:
    """The cache (read once; a missing cache fails the tests that need it, not the collection)."""
    return B.load_optimum()


def _pinocchio_model(pb: ff.Problem):
    """The same two links built in Pinocchio (a library we did not write): revolute joints about +y
    at the ankle (ankle_height above the sole) and the hip (l1 up link 1), the links' CoMs on
    their axes; the push point on link 2's axis."""
    pin = pytest.importorskip("pinocchio")
    r = pb.robot
    a, lg1, lg2 = r.ankle_height, r.z1 - r.ankle_height, r.z2 - r.ankle_height - pb.l1
    m = pin.Model()
    m.gravity.linear = np.array([0.0, 0.0, -r.g])
    j1 = m.addJoint(0, pin.JointModelRY(), pin.SE3(np.eye(3), np.array([0.0, 0.0, a])), "ankle")
    m.appendBodyToJoint(j1, pin.Inertia(r.m1, np.array([0.0, 0.0, lg1]), np.diag([1e-3, r.I1, 1e-3])), pin.SE3.Identity())
    j2 = m.addJoint(j1, pin.JointModelRY(), pin.SE3(np.eye(3), np.array([0.0, 0.0, pb.l1])), "hip")
    m.appendBodyToJoint(j2, pin.Inertia(r.m2, np.array([0.0, 0.0, lg2]), np.diag([1e-3, r.I2, 1e-3])), pin.SE3.Identity())
    return pin, m, r.h - a - pb.l1


def test_model_against_pinocchio():
    """Establishes: the CasADi-derived two-link equations are the rigid-body dynamics: at 20 random
    states the mass matrix and bias (Coriolis + gravity) equal Pinocchio's CRBA and
    nonLinearEffects, the accelerations under random torques and a push equal the inverse dynamics
    (RNEA with the push as an external force), and the ground reaction (Fx, Fz) and the ZMP's
    moment Fz * p equal the force Pinocchio transmits through the ankle plus the feet's weight."""
    pb = ff.problem_from_params(PARAMS)
    pin, m, dP = _pinocchio_model(pb)
    d = m.createData()
    accel, contact, _, mass_bias = ff.model_functions(pb)
    r = pb.robot
    rng = np.random.default_rng(7)
    for _ in range(20):
        q, v = rng.uniform(-0.8, 0.8, 2), rng.uniform(-4, 4, 2)
        tau, F = rng.uniform(-18, 18, 2), rng.uniform(-60, 60)
        M, bias = (np.array(x) for x in mass_bias(q, v))
        Mp_ = pin.crba(m, d, q)
        Mp_ = np.triu(Mp_) + np.triu(Mp_, 1).T
        assert np.allclose(M, Mp_, rtol=1e-12, atol=1e-14)
        assert np.allclose(bias.ravel(), pin.nonLinearEffects(m, d, q, v), rtol=1e-12, atol=1e-12)
        ddq = np.array(accel(q, v, tau, F)).ravel()
        pin.forwardKinematics(m, d, q)
        R = d.oMi[2].rotation
        f_loc = R.T @ np.array([F, 0.0, 0.0])
        fext = [pin.Force.Zero() for _ in range(m.njoints)]
        fext[2] = pin.Force(f_loc, np.cross([0.0, 0.0, dP], f_loc))
        assert np.allclose(pin.rnea(m, d, q, v, ddq, fext), tau, rtol=1e-10, atol=1e-10)
        w = d.oMi[1].act(d.f[1])          # what the feet exert on the body through the ankle, world, about the origin
        Fx, Fz, Mp = np.array(contact(q, v, tau, F)).ravel()
        assert Fx == pytest.approx(w.linear[0], abs=1e-9)
        assert Fz == pytest.approx(w.linear[2] + r.m_f * r.g, abs=1e-9)
        assert Mp == pytest.approx(-(w.angular[1] - r.x_f * r.m_f * r.g), abs=1e-9)


@pytest.mark.parametrize("direction", [+1, -1])
def test_statics_reproduce_the_analytic_bounds(direction):
    """Establishes: the optimization's statics are the analytic bounds' (anklehip.analysis.bounds):
    with both joints locked the largest constant push is the static tipping force; with the push's
    moment arm held at h (the small-angle assumption of the sustained-push limit) the largest push
    held in a posture with the body CoM over the sole is the sustained-push limit (to 1e-6); with the
    model's own geometry it is larger (the lean lowers the body-fixed push point: legs forward, trunk
    back) but within 40 % (measured: +20 % on the back, +31 % on the chest)."""
    pb = ff.problem_from_params(PARAMS, direction)
    r = pb.robot
    assert ff.static_optimum(ff.problem_from_params(PARAMS, direction, locked="both")) == \
        pytest.approx(B.static_tipping_force(r, direction), rel=1e-6)
    assert ff.static_optimum(pb, rigid_height=True) == pytest.approx(B.sustained_push_limit(r, direction), rel=1e-6)
    nonlinear = ff.static_optimum(pb)
    assert B.sustained_push_limit(r, direction) < nonlinear < 1.4 * B.sustained_push_limit(r, direction)


def test_one_point_reproduces_the_cache_and_the_hip_locked_optimum_is_the_lip_bound():
    """Establishes: (1) re-solving the cache's first point (0.1 s push on the back, 50 ms rise) on the
    coarse mesh with the script's settings gives the cached coarse value (to 1e-6: the cache is
    what the code computes); (2) with the hip locked, the optimum of the same push is the LIP bound
    of the ankle strategy (the rigid body about the ankle with the ZMP at the toe from the onset)
    to 1 %: the nonlinear model and the limits reproduce the linear bound where it applies; (3) the
    hip adds: the optimum with the hip free is above it."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("ffo", REPO_ROOT / "scripts" / "flat_footed_optimum.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    params = dict(_data()["parameters"])
    pt = _data()["points"][0]
    assert (pt["direction"], pt["rise"], pt["duration"]) == (1, 0.05, 0.1)
    point = {k: pt[k] for k in ("direction", "rise", "height", "duration")}
    s = script.solve_point(params, point, script.coarse_dt(point), script.T_AFTER)
    assert s.ok
    assert s.f_peak == pytest.approx(pt["f_peak_coarse"], rel=1e-6)
    pb = ff.problem_from_params(params, 1, locked="hip")
    hip_locked = ff.solve(pb, 0.1, 0.05, dt=script.coarse_dt(point))
    lip = float(B.lip_force_limit(pb.robot, 0.1, 0.05, 1))
    assert hip_locked.ok and hip_locked.f_peak == pytest.approx(lip, rel=0.01)
    assert s.f_peak > 1.05 * hip_locked.f_peak


def test_cache_is_current(fmu_path):
    """Establishes: the cache was made by the current model source (sha256 of flat_footed.py), for the
    robot the plant FMUs describe (every number the optimum depends on equals bounds_parameters of
    Hoap2Plant.fmu and its header; mu of Hoap2Plant3D.fmu), every point solved (IPOPT success on
    both meshes), the mesh refinement changed no point by more than 0.5 %, the longer horizon none
    by more than 0.5 %."""
    from anklehip.running.fmu import FMUInfo
    src = (REPO_ROOT / "anklehip" / "analysis" / "flat_footed.py").read_bytes()
    assert _data()["model_sha256"] == hashlib.sha256(src).hexdigest(), \
        "flat_footed.py changed: regenerate the cache with scripts/flat_footed_optimum.py"
    plant = FMUInfo.load(fmu_path("Hoap2Plant"))
    p = B.bounds_parameters(plant.start_values(), B.plant_header(plant.unzipdir))
    assert B.optimum_matches(_data(), p) == []
    assert _data()["parameters"]["h_push"] == p["h_push"]
    assert _data()["parameters"]["mu"] == FMUInfo.load(fmu_path("Hoap2Plant3D")).start_values()["mu"]
    assert all(x["ok"] for x in _data()["points"])
    assert max(abs(x["rel_change_mesh"]) for x in _data()["points"]) < 0.005
    assert _data()["horizon_check"] and max(abs(x["rel_change_horizon"]) for x in _data()["horizon_check"]) < 0.005


def _cached(direction, rise=0.05, h=None):
    h = _data()["parameters"]["h_push"] if h is None else h
    rows = sorted((x for x in _data()["points"] if x["direction"] == direction and x["rise"] == rise
                   and x["height"] == h), key=lambda x: x["duration"])
    return np.array([x["duration"] for x in rows]), np.array([x["f_peak"] for x in rows])


@pytest.mark.parametrize("direction", [+1, -1])
def test_optimum_between_the_bounds(direction):
    """Establishes: the cached optimum sits where physics puts it: never below the LIP bound of the
    ankle strategy (the hip can only add), decreasing with the push's duration and converged by 2 s
    (a longer push of 50 ms rise is a step push: 2 s and 4 s within 0.5 %), below the model's static
    optimum (a push that lasts must be held), the slow pushes (1 s ramps) above the static optimum
    (the optimizer knows the push ramps down slowly: it leans into it and rides it back, section
    8.5) and decreasing with duration, above the static tipping force everywhere, and (on the back) F h within 10 % across the cached heights (moment limits)."""
    r = ff.problem_from_params(_data()["parameters"], direction).robot
    D, F = _cached(direction)
    assert np.all(np.diff(F) < 0)
    assert np.all(F >= 0.999 * B.lip_force_limit(r, D, 0.05, direction))
    assert np.all(F > B.static_tipping_force(r, direction))
    static = _data()["static"][str(direction)]["nonlinear"]
    assert F[-1] <= static and F[-1] == pytest.approx(F[-2], rel=0.005)     # 2 s and 4 s: a step push
    if direction > 0:          # a slow ramp lets the clairvoyant optimum lean into the push and ride it back
        Ds, Fs = _cached(1, rise=1.0)
        assert np.all(np.diff(Fs) < 0) and np.all(Fs > static)
    if direction > 0:          # the height grid: on the back, as the force x height sweep pushes
        hs = sorted({x["height"] for x in _data()["points"] if x["direction"] == 1 and x["duration"] == 1.0
                     and x["rise"] == 0.05})
        fh = [B.flat_footed_optimum(1.0, 0.05, 1, h, data=_data()) * h for h in hs]
        assert len(hs) >= 5 and max(fh) / min(fh) < 1.10


def _measured():
    """The measured boundaries of docs/capability.md "Measured maps" (force x duration, on the back):
    {variant: (durations, forces, at_least)}, at_least where every force tried stood (">= F")."""
    doc = (REPO_ROOT / "docs" / "capability.md").read_text()
    doc = doc[doc.index("## Measured maps"):]
    lines = doc[doc.index("| duration [s] | 0.1 |"):].splitlines()
    durations = [float(x) for x in lines[0].strip("|").split("|")[1:]]
    out = {}
    for line in lines[2:]:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if not line.startswith("|") or cells[0] in ("LIP bound", "flat-footed optimum"):
            break
        out[cells[0]] = (durations, [float(c.replace("≥", "").strip()) for c in cells[1:]],
                         ["≥" in c for c in cells[1:]])
    return out


def test_measured_boundaries_below_the_optimum_and_the_docs_fractions():
    """Establishes: every configuration's measured boundary on the back (docs/capability.md, Measured
    maps) is below the flat-footed optimum at every duration (the optimum is a bound: a controller
    above it would have to rock the foot), and the table of fractions in docs/capability.md
    section 8 is the measured boundaries divided by the cached optimum."""
    meas = _measured()
    assert set(meas) == {"ankle_only", "paper", "default", "lean"}
    doc = (REPO_ROOT / "docs" / "capability.md").read_text()
    for name, (D, F, ge) in meas.items():
        opt = B.flat_footed_optimum(D, 0.05, 1, data=_data())
        assert np.all(np.array(F) < opt), name
        row = f"| {name} | " + " | ".join(f"{'≥ ' if g else ''}{100 * f / o:.0f} %" for f, o, g in zip(F, opt, ge)) + " |"
        assert row in doc, row


def test_interpolation_and_errors():
    """Establishes: flat_footed_optimum returns the cached values at cached points (both directions,
    heights), interpolates between them monotonically, and raises InputError naming the range for
    a duration, rise or height outside the cache and for a robot other than the cached one."""
    from anklehip.errors import InputError
    for x in _data()["points"]:
        assert B.flat_footed_optimum(x["duration"], x["rise"], x["direction"], x["height"], data=_data()) == \
            pytest.approx(x["f_peak"], rel=1e-12)
    D, F = _cached(1)
    mid = B.flat_footed_optimum(np.sqrt(D[:-1] * D[1:]), data=_data())
    assert np.all((mid < F[:-1]) & (mid > F[1:]))
    with pytest.raises(InputError, match="outside the cached 0.1..4 s"):
        B.flat_footed_optimum(0.05, data=_data())
    with pytest.raises(InputError, match="rise 0.2 s is not cached"):
        B.flat_footed_optimum(1.0, 0.2, data=_data())
    with pytest.raises(InputError, match="height 0.6 m"):
        B.flat_footed_optimum(1.0, 0.05, 1, 0.6, data=_data())
    other = {**_data()["parameters"], "m2": 5.0}
    with pytest.raises(InputError, match="m2 differ"):
        B.flat_footed_optimum(1.0, params=other, data=_data())
    assert B.flat_footed_optimum(1.0, params={**_data()["parameters"], "thigh": 0.1}, data=_data()) == \
        pytest.approx(_cached(1)[1][list(D).index(1.0)])


def test_docs_optimum_table_is_the_cache():
    """Establishes: the table of docs/capability.md section 8 is what `python -m anklehip.analysis.bounds`
    prints from the cache (optimum_table)."""
    doc = (REPO_ROOT / "docs" / "capability.md").read_text()
    assert B.optimum_table(_data()) in doc
    assert re.search(r"flat_footed_optimum\.py", doc)
    assert math.isfinite(_data()["static"]["1"]["nonlinear"])


def test_capability_maps_draw_the_optimum_and_the_stepping_bounds(tmp_path):
    """Establishes: the capability map over force x duration draws the flat-footed optimum beside the
    analytic bounds (its values those of flat_footed_optimum inside the cached durations, absent
    outside), and over force x height too; the printed bound lines carry it; a stepping map adds
    the N-step bounds (1, 2, inf steps) and the sustained limit after a step, whose 1-step line is
    n_step_force_limit, and the one-step optimum (section 9.3) as a star at the cached 1 s push with
    its landing time, printed under a stepping sweep's bounds too; a robot other than the cached one
    gets neither optimum and says why."""
    import matplotlib
    matplotlib.use("Agg")
    from anklehip.analysis.capability import bound_lines, capability_figure
    from anklehip.running.sweepfile import load_sweep_file
    head = ('description = "t"\nscenario = "hip_saves_push"\nstop_time = 4.0\n[push]\nt = 1.0\nrise = 0.05\n'
            '[[variant]]\nname = "a"\n')
    p = tmp_path / "s.toml"
    p.write_text(head + '[grid]\n"push.force" = [4, 8]\n"push.duration" = [0.1, 0.5, 4.0]\n')
    sf = load_sweep_file(p)
    fig = capability_figure(sf, [], PARAMS)
    lines = {ln.get_label(): ln for ln in fig.axes[0].get_lines()}
    opt = next(v for k, v in lines.items() if k.startswith("flat-footed optimum"))
    x, y = (np.asarray(a, float) for a in opt.get_data())
    inside = (x >= 0.1) & (x <= 4.0)
    assert np.isnan(y[~inside]).all() and np.isfinite(y[inside]).all()
    assert np.allclose(y[inside], B.flat_footed_optimum(x[inside], data=_data()), rtol=1e-12)
    assert not any(k.startswith("LIP capturable") for k in lines)
    text = "\n".join(bound_lines(sf, PARAMS))
    assert "flat-footed opt." in text and "LIP bound" in text
    fig = capability_figure(sf, [], PARAMS, stepping=True)
    lines = {ln.get_label(): ln for ln in fig.axes[0].get_lines()}
    one = next(v for k, v in lines.items() if k.startswith("LIP capturable in 1 step "))
    l_max, dt_s = B.step_reach(PARAMS)
    x, y = (np.asarray(a, float) for a in one.get_data())
    r = B.robot_from_plant_params(PARAMS)
    assert np.allclose(y, B.n_step_force_limit(r, x, 0.05, 1, 1, l_max, dt_s), rtol=1e-12)
    assert any(k.startswith("LIP capturable in ∞ steps") for k in lines)
    assert "sustained-push limit after one step" in lines
    # the one-step optimum (section 9.3): a star at the cached 1 s push, its force and landing time
    f1, t1 = B.one_step_optimum(1.0, 0.05)
    star = next(v for k, v in lines.items() if k.startswith("one-step optimum"))
    assert star.get_label().endswith(f"landing {1000 * t1:.0f} ms after the onset)")
    assert [float(a) for a in star.get_xdata()] == [1.0] and [float(a) for a in star.get_ydata()] == [f1]
    q = tmp_path / "step.toml"
    q.write_text(head.replace('scenario = "hip_saves_push"', 'scenario = "step_recovery_3d"')
                 + 'controller = { stepping_enabled = 1 }\n[grid]\n"push.force" = [4, 8]\n"push.duration" = [0.5, 1.0]\n')
    assert f"  one-step opt.    1: {f1:.1f} (landing {1000 * t1:.0f} ms)" in bound_lines(load_sweep_file(q), PARAMS)
    fig = capability_figure(sf, [], {**PARAMS, "m2": 5.0}, stepping=True)
    assert not any(ln.get_label().startswith(("flat-footed", "one-step")) for ln in fig.axes[0].get_lines())
    assert "m2 differ" in fig.axes[0].get_title()
    p.write_text(head.replace("rise = 0.05", "rise = 0.05\nduration = 1.0") +
                 '[grid]\n"push.force" = [4, 8]\n"push.height" = [0.26, 0.46]\n')
    fig = capability_figure(load_sweep_file(p), [], PARAMS)
    opt = next(ln for ln in fig.axes[0].get_lines() if ln.get_label().startswith("flat-footed optimum"))
    x, y = (np.asarray(a, float) for a in opt.get_data())
    assert np.isfinite(y[(x >= 0.26) & (x <= 0.46)]).all()
    fin = np.isfinite(y)
    assert y[fin][np.argmin(x[fin])] > y[fin][np.argmax(x[fin])]       # lower pushes: more force
