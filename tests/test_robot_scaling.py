"""The gain-scaling rule and the paper's experiment on other robots (docs/controller.md section 10,
docs/your-robot.md).

Establishes: on the HOAP-2 the rule returns both FMUs' defaults exactly (default and paper
configurations), so `--robot hoap2` is today's paper_five_pushes bit for bit; on every other robot
the dimensionless numbers the rule keeps are the HOAP-2's; the scaled paper_five_pushes passes on
Talos, iCub, Romeo and G1 (five 0->1->2->3->0 cycles, no fall, erect at the end) with the peak ZMP
as a fraction of the toe within 0.05 of the HOAP-2's push by push and recovery within 5 pendulum
time constants, and docs/your-robot.md's table is what the runs give; a scenario written in robot
units is the SI one on the HOAP-2; the FMUs accept a 95 kg robot.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import REPO_ROOT, import_file
from anklehip.running.master import Models, simulate
from anklehip.robot import load_robot
from anklehip.robot.experiment import apply_robot, find_robot, pendulum_time, tipping_forces
from anklehip.robot.robotfile import Quantity
from anklehip.robot.scaling import RULES, Scales, scale
from anklehip.files.scenario import load_scenario

examples = import_file(REPO_ROOT / "scripts" / "example_robots.py", "example_robots")
ROBOTS = [ex.name for ex in examples.EXAMPLES]


@pytest.fixture(scope="module")
def models(fmu_dir):
    return Models.load(fmu_dir)


def anchors(models, config="default"):
    c = {**models.controller.start_values(), **models.controller.configuration(config, "test")}
    return c, models.plant.start_values()


@pytest.mark.parametrize("config", ["default", "paper"])
def test_scaling_is_anchored_on_hoap2(models, config):
    c0, p0 = anchors(models, config)
    s = scale(load_robot(REPO_ROOT / "robots" / "hoap2.toml"), c0, p0)
    for fmu, got, start in (("controller", s.controller, c0), ("plant", s.plant, p0)):
        for k, x in got.items():
            assert x == start[k], f"{fmu}.{k}: {x!r} != default {start[k]!r}"
    assert {r.name for r in RULES if r.fmu == "controller"} <= set(s.controller)
    assert s.plant["h_push"] == p0["h_push"]
    assert "feet_offset_mode" not in s.controller          # HOAP-2 keeps the paper's estimate


def _dimensionless(c: dict, p: dict) -> dict[str, float]:
    sc = Scales.of({k: float(c[k]) for k in ("g", "m1", "l1", "lg1", "I1", "m2", "lg2", "I2", "feet_mass", "toe_x", "heel_x")})
    wp = 1 / sc.T_p
    out = {}
    for name, J, K, C in (("ankle", sc.J_a, c["Ka"], c["Ca"]), ("hip", sc.J_h, c["Kh"], c["Ch"]),
                          ("servo ankle", sc.J_a, p["kp_ankle"], p["kd_ankle"]),
                          ("servo hip", sc.J_h, p["kp_hip"], p["kd_hip"])):
        out[f"{name} omega/omega_p"] = math.sqrt(K / J) / wp          # natural frequency
        out[f"{name} zeta"] = C / (2 * math.sqrt(K * J))              # damping ratio
    out.update({"Kpr T_p": c["Kpr"] * sc.T_p, "Kp_theta T_p": c["Kp_theta"] * sc.T_p, "T_ah / T_p": c["T_ah"] / sc.T_p,
                "p_lim / toe": c["zmp_limit_front"] / sc.toe, "p_back / heel": c["zmp_limit_back"] / sc.heel,
                "rz band / l_g": c["rz_band_low"] / sc.l_g, "dwell / T_p": c["fallback_dwell"] / sc.T_p,
                "fz_max / weight": c["fz_max"] / (sc.M * sc.g),
                "push point on link 2": (p["h_push"] - p["ankle_height"] - p["l1"]) / p["lg2"]})
    return out


@pytest.mark.parametrize("name", ROBOTS)
def test_scaling_keeps_the_dimensionless_numbers(models, name):
    c0, p0 = anchors(models)
    hoap2 = _dimensionless(c0, p0)
    s = scale(load_robot(find_robot(name)), c0, p0)
    got = _dimensionless(s.controller, s.plant)
    for k, x in hoap2.items():
        assert got[k] == pytest.approx(x, rel=1e-12), k
    # the scaled parameters are inside the FMUs' ranges and pass the controller's own validation
    models.controller.check_overrides(s.controller, name)
    models.plant.check_overrides(s.plant, name)


def test_servo_limits_come_from_the_robot_file_else_scale(models):
    c0, p0 = anchors(models)
    talos = load_robot(find_robot("talos"))
    s = scale(talos, c0, p0)
    assert s.plant["tau_max_ankle"] == 320.0 and s.plant["vel_max_hip"] == 5.8
    bare = load_robot(find_robot("talos"))
    bare.servo = {}
    s = scale(bare, c0, p0)
    g = (s.robot.m * s.robot.g * s.robot.l_g) / (s.anchor.m * s.anchor.g * s.anchor.l_g)
    assert s.plant["tau_max_ankle"] == pytest.approx(18.0 * g, rel=1e-12)
    assert s.plant["vel_max_ankle"] == pytest.approx(5.0 * s.anchor.T_p / s.robot.T_p, rel=1e-12)


def test_fmus_accept_a_95_kg_robot(models):
    """Talos scaled up to 95 kg (every mass and inertia x 95/90.3): both FMUs take it and it stands."""
    talos = load_robot(find_robot("talos"))
    k = 95.0 / talos.total_mass
    for key in ("m1", "m2", "feet_mass", "I1", "I2", "feet_inertia"):
        q = talos.model[key]
        talos.model[key] = Quantity(q.value * k, q.unit, q.source)
    assert talos.total_mass == pytest.approx(95.0)
    sc = apply_robot(load_scenario(REPO_ROOT / "scenarios" / "ankle_small_push.toml"), models, talos)
    res = simulate(sc, models, engine="fmpy", progress=False)
    assert res.complete and not res.fell


def _run(models, sc, engine="native"):
    from anklehip.running.native import default_engine
    return simulate(sc, models, engine=default_engine() if engine == "native" else engine, progress=False)


def test_robot_hoap2_is_todays_run(models):
    sc = load_scenario(REPO_ROOT / "scenarios" / "paper_five_pushes.toml")
    today = _run(models, sc, "fmpy")
    on = apply_robot(sc, models, "hoap2")
    assert on.robot_run.time_factor == 1.0 and on.robot_run.force_factor == (1.0, 1.0)
    again = _run(models, on, "fmpy")
    assert today.data.dtype == again.data.dtype
    for name in today.data.dtype.names:
        assert np.array_equal(today.data[name], again.data[name]), name


@pytest.fixture(scope="module")
def runs(models):
    return {name: examples.run(name, models) for name in ["hoap2"] + ROBOTS}


@pytest.mark.parametrize("name", ROBOTS)
def test_paper_five_pushes_on_every_robot(runs, name):
    r = runs[name]
    assert r["passed"], [f"{c.name}: {c.detail}" for c in r["checks"] if not c.ok]
    res = r["result"]
    assert res.complete and not res.fell
    ref = runs["hoap2"]["robot"]["pushes"]
    pushes = r["robot"]["pushes"]
    assert len(pushes) == len(ref) == 5
    for i, (p, q, s) in enumerate(zip(pushes, ref, r["pushes"])):
        assert s.phases == [0, 1, 2, 3], f"push {i + 1}: phases {s.phases}"
        # the same push in the robot's units: the same fraction of the tipping force
        assert p["peak_force_fraction"] == pytest.approx(q["peak_force_fraction"], rel=1e-3)
        assert abs(p["peak_zmp_fraction"] - q["peak_zmp_fraction"]) <= 0.05, (i, p, q)
        assert p["recovery_T_p"] is not None and p["recovery_T_p"] <= 5.0, (i, p)


def test_docs_table_is_what_the_runs_give(runs):
    assert examples.doc_table() == examples.table(runs), "docs/your-robot.md: python scripts/example_robots.py --write"


def test_robot_units_scenario(models, tmp_path):
    """paper_five_pushes written in robot units (tipping-force fractions, T_p) is the SI scenario
    on the HOAP-2, and carries over to Talos like --robot does."""
    sc = load_scenario(REPO_ROOT / "scenarios" / "paper_five_pushes.toml")
    c0, p0 = anchors(models)
    T, (Fb, Fc) = pendulum_time(c0), tipping_forces({**p0, **c0})
    lines = ['push_units = "robot"', f"stop_time = {sc.stop_time / T!r}", "step = 0.001",
             "[expect]", "must_fall = false", "min_cycles = 5", f"erect_by = {sc.expect.erect_by / T!r}"]
    for s in sc.push.segments:
        lines += ["[[push]]", 'kind = "pulse"', f"t = {s.t / T!r}", f"force = {s.force / Fb!r}",
                  f"duration = {s.duration / T!r}", f"rise = {s.rise / T!r}"]
    p = tmp_path / "relative.toml"
    p.write_text("\n".join(lines) + "\n")
    rel = apply_robot(load_scenario(p), models)
    assert rel.stop_time == pytest.approx(sc.stop_time, abs=1e-9)
    assert np.allclose(rel.push.times, sc.push.times, atol=1e-9)
    assert np.allclose(rel.push.values, sc.push.values, atol=1e-9)
    assert rel.expect.erect_by == pytest.approx(sc.expect.erect_by)
    talos_rel = apply_robot(load_scenario(p), models, "talos")
    talos_si = apply_robot(sc, models, "talos")
    assert np.allclose(talos_rel.push.times, talos_si.push.times, atol=1e-9)
    assert np.allclose(talos_rel.push.values, talos_si.push.values, rtol=1e-9)
    assert talos_rel.stop_time == talos_si.stop_time
    # the scenario key robot: the scenario's own robot, its SI pushes taken as they are
    q = tmp_path / "on_talos.toml"
    q.write_text(f'robot = "talos"\nstop_time = 2.0\n[[push]]\nkind = "pulse"\nt = 0.5\nforce = 30.0\nduration = 0.5\n')
    on = apply_robot(load_scenario(q), models)
    assert on.robot_run.robot.name == "talos" and on.robot_run.time_factor == 1.0
    assert on.push.peak() == 30.0 and on.controller["m2"] == load_robot(find_robot("talos")).value("m2")
