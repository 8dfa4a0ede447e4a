"""Fault injection (anklehip.running.faults, the scenario table [faults]) and the robustness study.

What these tests establish:
* the faulty sensor channel does exactly what docs/scenarios.md says (delay in whole steps, exact
  bias, noise of the stated standard deviation, seeded; lost packets as NaN or a repeat; a stuck
  sensor holding the value it read when the episode began), on synthetic plant rows;
* the parameter faults scale exactly the documented parameters; bad options name the key;
* in the closed loop: the controller receives the faulty values (sensed.* columns), a NaN packet
  always raises a non-finite fault bit and is logged, a fall under a fault is reported as a fall,
  the transition push starts in the step the phase is entered, once per cycle;
* the robustness table reports the survived interval and the first failure on each side.
"""
from __future__ import annotations

import math
import numpy as np
import pytest

from anklehip.running.faults import KEYS, Faults, SensorChannel, TransitionPush, parameter_faults
from anklehip.files.scenario import ScenarioError, faults_from, parse_fault_options

INPUTS = ["theta_ankle", "theta_hip", "zmp_x", "fz"]


def _rows(n=2000, seed=0):
    """Synthetic plant rows: controller inputs first, then an unrelated column."""
    rng = np.random.default_rng(seed)
    R = np.cumsum(rng.normal(size=(n + 1, 5)), axis=0)
    return R


def _channel(R, **kw):
    f = faults_from(kw)
    ch = SensorChannel(f, INPUTS, R, 1e-3, len(R) - 1, push_starts=[0.5, 1.2])
    for j in range(len(R) - 1):
        ch.apply(j)
    return ch.S[:-1], f


def test_no_sensor_fault_passes_the_plant_rows_unchanged():
    R = _rows()
    S, _ = _channel(R, delay_steps=0, drop_rate=0.0, zmp_bias=0.0)
    assert np.array_equal(S, R[:-1, :4])


@pytest.mark.parametrize("d", [1, 2, 7])
def test_delay_is_whole_steps_and_holds_the_first_row_before_the_start(d):
    R = _rows()
    S, _ = _channel(R, delay_steps=d)
    assert np.array_equal(S[d:], R[:-1 - d, :4])
    assert np.array_equal(S[:d], np.repeat(R[:1, :4], d, axis=0))


def test_bias_is_exact_and_only_on_its_signal():
    R = _rows()
    S, _ = _channel(R, zmp_bias=0.01, ankle_bias=-0.02, hip_bias=0.03)
    assert np.array_equal(S, R[:-1, :4] + np.array([-0.02, 0.03, 0.01, 0.0]))


def test_noise_has_the_stated_deviation_and_is_seeded():
    R = _rows(20000)
    S, _ = _channel(R, zmp_noise=0.004, angle_noise=0.01, seed=3)
    e = S - R[:-1, :4]
    assert e[:, 3].tolist() == [0.0] * len(e)            # fz is not touched
    for i, sd in ((0, 0.01), (1, 0.01), (2, 0.004)):
        assert abs(e[:, i].std() / sd - 1) < 0.03       # 20 000 samples: 1.5 % standard error of s/sigma
        assert abs(e[:, i].mean()) < 4 * sd / math.sqrt(len(e))
    S2, _ = _channel(R, zmp_noise=0.004, angle_noise=0.01, seed=3)
    S3, _ = _channel(R, zmp_noise=0.004, angle_noise=0.01, seed=4)
    assert np.array_equal(S, S2) and not np.array_equal(S, S3)
    # adding packet loss draws from its own stream: the noise of the kept samples is unchanged
    S4, _ = _channel(R, zmp_noise=0.004, angle_noise=0.01, seed=3, drop_rate=0.5, drop_mode="nan")
    kept = np.isfinite(S4[:, 0])
    assert np.array_equal(S4[kept], S[kept])


def test_lost_packets_nan_and_repeat():
    R = _rows(20000)
    S, _ = _channel(R, drop_rate=0.1, drop_mode="nan", seed=5)
    lost = np.isnan(S).all(axis=1)
    assert (np.isnan(S).any(axis=1) == lost).all()          # a packet is lost as a whole
    assert abs(lost.mean() - 0.1) < 0.01
    assert np.array_equal(S[~lost], R[:-1, :4][~lost])
    S, _ = _channel(R, drop_rate=0.1, drop_mode="repeat", seed=5)
    same = (S[1:] == S[:-1]).all(axis=1)
    assert np.array_equal(np.flatnonzero(same) + 1, np.flatnonzero(lost[1:]) + 1)   # the same draws
    # a repeat is the previous *received* packet (a run of losses keeps the last good one)
    for j in np.flatnonzero(lost[1:]) + 1:
        assert np.array_equal(S[j], S[j - 1])


def test_stuck_sensor_holds_the_value_read_when_the_episode_began():
    R = _rows()
    S, _ = _channel(R, stuck_for=0.2, stuck_signal="zmp_x", zmp_bias=0.05)   # episodes at the pushes 0.5, 1.2 s
    for a in (500, 1200):
        assert (S[a:a + 200, 2] == R[a, 2] + 0.05).all()
        assert S[a + 200, 2] == R[a + 200, 2] + 0.05              # released after 0.2 s
        assert S[a - 1, 2] == R[a - 1, 2] + 0.05
    assert np.array_equal(S[:, [0, 1, 3]], R[:-1, [0, 1, 3]])       # the other signals move
    S, _ = _channel(R, stuck_for=0.1, stuck_signal="theta_hip", stuck_at=[0.05])
    assert (S[50:150, 1] == R[50, 1]).all() and S[150, 1] == R[150, 1]


def test_parameter_faults_scale_exactly_the_documented_parameters():
    ctrl = {"m1": 2.0, "m2": 4.0, "feet_mass": 1.0, "l1": 0.2, "lg1": 0.1, "lg2": 0.1, "I1": 0.01, "I2": 0.02,
            "Ka": 40.0}
    plant = {"tau_max_ankle": 18.0, "tau_max_hip": 18.0, "kp_ankle": 100.0}
    c, p = parameter_faults(Faults(mass_mismatch=0.2, length_mismatch=-0.1, torque_scale=0.5), ctrl, plant)
    assert p == {"tau_max_ankle": 9.0, "tau_max_hip": 9.0}
    assert c["m1"] == pytest.approx(2.4) and c["m2"] == pytest.approx(4.8) and c["feet_mass"] == pytest.approx(1.2)
    assert c["l1"] == pytest.approx(0.18) and c["lg2"] == pytest.approx(0.09)
    assert c["I2"] == pytest.approx(0.02 * 1.2 * 0.81)
    assert "Ka" not in c
    assert parameter_faults(Faults(), ctrl, plant) == ({}, {})
    # the 3D controller's leg segments scale with l1, whose sum they must stay
    c3, _ = parameter_faults(Faults(length_mismatch=-0.1), {**ctrl, "thigh": 0.1, "shank": 0.1}, plant)
    assert c3["thigh"] + c3["shank"] == pytest.approx(c3["l1"]) == pytest.approx(0.18)


@pytest.mark.parametrize("opts, needle", [
    (["zmp_nois=1"], "faults.zmp_nois: unknown key"),
    (["zmp_noise=-1"], "faults.zmp_noise: must be >= 0"),
    (["delay_steps=1.5"], "faults.delay_steps: must be an integer"),
    (["drop_mode=zero"], "faults.drop_mode: must be one of nan, repeat"),
    (["stuck_signal=fx"], "faults.stuck_signal: must be one of"),
    (["stuck_at=1,x"], "'x' is not a number"),
    (["transition_push_rise=0.2", "transition_push_duration=0.3"], "faults.transition_push_rise: 2 x rise"),
    (["mass_mismatch"], "expected NAME=VALUE"),
])
def test_bad_fault_options_name_the_key(opts, needle):
    with pytest.raises(ScenarioError) as e:
        parse_fault_options(opts)
    assert needle in str(e.value)


def test_scenario_faults_table_and_overrides(tmp_path):
    from anklehip.files.scenario import load_scenario
    p = tmp_path / "s.toml"
    p.write_text('stop_time = 1.0\n[faults]\nzmp_noise = 0.001\nstuck_at = [0.5, 0.2]\n')
    sc = load_scenario(p)
    assert sc.faults.zmp_noise == 0.001 and sc.faults.stuck_at == [0.2, 0.5]
    f = parse_fault_options(["delay_steps=2"], sc.faults)
    assert (f.zmp_noise, f.delay_steps) == (0.001, 2)
    p.write_text('stop_time = 1.0\n[faults]\nzmp_noise = "x"\n')
    with pytest.raises(ScenarioError, match=r"s.toml: faults.zmp_noise: must be a number"):
        load_scenario(p)


def test_transition_push_once_per_cycle():
    R = np.zeros((101, 3))
    tp = TransitionPush(R, 1, np.array([1.0, 2.0, 3.0]), phase=3, n_steps=100)
    phases = [0] * 5 + [1] * 5 + [3] * 5 + [2] * 2 + [3] * 3 + [0] * 10 + [3] * 70
    for j, ph in enumerate(phases):
        tp.after_controller(j, ph)
    assert tp.starts == [10, 30]        # not again at the re-entry at 17 (no phase 0 in between)
    assert R[10:13, 1].tolist() == [1.0, 2.0, 3.0] and R[30:33, 1].tolist() == [1.0, 2.0, 3.0]
    assert R[:, 1].sum() == 12.0


def test_fault_keys_documented():
    """docs/scenarios.md lists every fault key with its unit and range (the parser's table)."""
    import re
    from pathlib import Path
    text = (Path(__file__).resolve().parents[1] / "docs" / "scenarios.md").read_text()
    rows = {m[0]: (m[1], m[2], m[3]) for m in
            re.findall(r"^\| `(\w+)` \| ([^|]*?) \| \[([^,]*), ([^]]*)\] \|", text, re.M)}
    for k in KEYS:
        assert k.name in rows, f"docs/scenarios.md: fault key {k.name} missing"
        unit, lo, hi = rows[k.name]
        assert unit.strip() == (k.unit or "–") and float(lo) == k.lo and float(hi) == k.hi, k.name


# ------------------------------------------------------------------------------------------------
# closed loop (hip_saves_push: one push through all four phases, 12 s, ~1 s per run)

@pytest.fixture(scope="module")
def hip_run(fmu_dir):
    from anklehip.running.master import Models, simulate
    from anklehip.files.paths import find_scenario
    from anklehip.files.scenario import load_scenario
    sc = load_scenario(find_scenario("hip_saves_push"))
    models = Models.load(fmu_dir)

    def run(**kw):
        return simulate(sc, models, faults=faults_from(kw), progress=False)
    return run


def test_closed_loop_controller_receives_the_delayed_values(hip_run):
    r = hip_run(delay_steps=2, ankle_bias=0.001)
    d = r.data
    assert r.outcome == "completed"
    assert np.array_equal(d["sensed.theta_ankle"][2:-1], d["theta_ankle"][:-3] + 0.001)
    assert np.array_equal(d["sensed.fz"][2:-1], d["fz"][:-3])
    assert r.faults == {"delay_steps": 2, "ankle_bias": 0.001}


def test_closed_loop_transition_push_starts_when_the_phase_is_entered(hip_run):
    base = hip_run()
    r = hip_run(transition_push=3.0, transition_phase=3, transition_push_duration=0.2, transition_push_rise=0.0)
    d = r.data
    j = int(np.argmax(d["phase"] == 3))
    assert r.transition_pushes == [pytest.approx(d["time"][j])]
    extra = d["push_force"] - base.data["push_force"][:len(d)]
    assert np.all(extra[:j] == 0) and np.allclose(extra[j:j + 200], 3.0) and np.all(extra[j + 200:] == 0)


@pytest.mark.parametrize("study, level, survives", [
    ("lost packets (NaN)", 0.05, True),        # NaN packets: fault bits, warnings, still a full cycle
    ("servo torque limit", 0.1, False),        # 1.8 N m servos: falls, reported as a fall
    ("push entering phase 3 (hip->ankle)", 25.0, False),
])
def test_closed_loop_invariants_hold(fmu_dir, study, level, survives):
    from anklehip.files.paths import find_scenario
    from anklehip.running.robustness import run_point, study_by_label
    r = run_point(str(find_scenario("hip_saves_push")), str(fmu_dir), study_by_label(study), level)
    assert r["invariants_ok"], r
    assert r["survived"] == survives, r
    assert r["outcome"] in ("completed", "fell")
    if study.startswith("lost"):
        assert r["nonfinite_input_rows"] > 100 and r["unflagged_rows"] == 0
        assert r["fault_bits"] & 0xF == 0xF
        assert r["nonfinite_warnings"] == r["nonfinite_episodes"] > 10
        assert r["fault_logs"] == r["fault_changes"] > 10
    if not survives:
        assert r["outcome"] == "fell" and r["fell_at"] > 1.0


def test_robustness_summary_interval_and_first_failures():
    from anklehip.running.robustness import summarize, table_markdown

    def row(level, ok, outcome="completed", cycles=5):
        return {"study": "ZMP bias", "key": "zmp_bias", "level": level, "survived": ok, "outcome": outcome,
                "cycles": cycles, "cycles_needed": 5, "cycles_most": 5, "fell_at": 20.5 if outcome == "fell" else math.nan,
                "invariants_ok": True, "fault_bits": 0}
    rows = [row(-0.02, False, "fell"), row(-0.01, True), row(0.0, True), row(0.01, True), row(0.02, False, cycles=4),
            row(0.03, True)]
    s = summarize(rows)[0]
    assert (s["low"], s["high"]) == (-0.01, 0.01)
    line = table_markdown([s]).splitlines()[-1]
    assert "| -0.01 … 0.01 |" in line and "-0.02: fell at 20.50 s; 0.02: 4 of 5 cycles" in line
    s = summarize([row(0.0, True), row(0.01, True)])[0]
    assert "| 0 … 0.01 (end) |" in table_markdown([s])


def test_robustness_cli(tmp_path, fmu_dir, capsys):
    from anklehip.cli import main
    out = tmp_path / "rb"
    args = ["--fmu-dir", str(fmu_dir), "robustness", "hip_saves_push", "--study", "delay_steps", "--workers", "1",
            "--out", str(out)]
    assert main(args + ["--grid", "delay_steps=0,1"]) == 0
    assert "| sensor delay | `delay_steps` [steps] | 0 … 1 (2) | 0 … 1 (end) |" in (out / "table.md").read_text()
    assert len((out / "points.csv").read_text().splitlines()) == 3
    capsys.readouterr()
    assert main(args + ["--grid", "delay_step=0,1"]) == 2
    assert "--grid delay_step=0,1: expected KEY=GRID" in capsys.readouterr().err
    assert main(args + ["--grid", "delay_steps=0,5000"]) == 2
    assert "faults.delay_steps: must be <= 1000, got 5000" in capsys.readouterr().err


@pytest.mark.parametrize("scenario, study, level", [
    ("step_recovery_3d", "lost packets (NaN)", 0.05),   # NaN packets through the recovery step
    ("side_push_frontal", "lost packets (NaN)", 0.05),  # both fault masks change and are logged
    ("step_recovery_3d", "model lengths", -0.1),        # the 3D controller's segments scale with l1
])
def test_closed_loop_invariants_hold_on_the_3d_controller(fmu_dir, scenario, study, level):
    """The invariants on AnkleHipController3D: a non-finite reading raises a non-finite bit of fault
    or fault_y also while a step runs (the flat-footed layers rest then), each change of either
    mask is logged once, the mismatched model is accepted; these scenarios expect no hip-strategy
    cycle, so standing to the end is surviving."""
    from anklehip.files.paths import find_scenario
    from anklehip.running.robustness import run_point, study_by_label
    r = run_point(str(find_scenario(scenario)), str(fmu_dir), study_by_label(study), level)
    assert r["invariants_ok"], r
    assert r["outcome"] == "completed" and r["survived"] and r["cycles_needed"] == 0, r
    if study.startswith("lost"):
        assert r["nonfinite_input_rows"] > 100 and r["unflagged_rows"] == 0
        assert r["fault_logs"] == r["fault_changes"] > 10
