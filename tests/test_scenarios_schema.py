"""Scenario files: strict validation and push-profile semantics (no FMU needed)."""
from pathlib import Path

import numpy as np
import pytest

from anklehip.files.paths import scenarios_dir
from anklehip.files.scenario import (PushProfile, PushSegment, ScenarioError, load_scenario, parse_scenario,
                               parse_set)


def write(tmp_path: Path, text: str, name: str = "x.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def error_of(tmp_path, text) -> str:
    with pytest.raises(ScenarioError) as e:
        load_scenario(write(tmp_path, text))
    return str(e.value)


def test_committed_scenarios_are_valid():
    files = sorted(scenarios_dir().glob("*.toml"))
    assert files, "no scenarios committed"
    for f in files:
        sc = load_scenario(f)
        assert sc.name == f.stem
        assert sc.n_steps > 0
        if sc.reference is not None:
            assert sc.reference.file.parent.name == "reference"


def test_minimal(tmp_path):
    sc = load_scenario(write(tmp_path, "stop_time = 2.0\n"))
    assert sc.name == "x" and sc.step == 1e-3 and sc.n_steps == 2000
    assert sc.push.peak() == 0.0


@pytest.mark.parametrize("text, expected", [
    ("stop_time = 1\nfoo = 3\n", "x.toml: foo: unknown key"),
    ("step = 0.001\n", "x.toml: stop_time: required key missing"),
    ("stop_time = -1\n", "x.toml: stop_time: must be > 0, got -1"),
    ("stop_time = 'a'\n", "x.toml: stop_time: must be a number, got string 'a'"),
    ("stop_time = 1\nstep = 0.0003\n", "x.toml: step: stop_time 1 is not a whole number of steps"),
    ("stop_time = 1\n[[push]]\nkind = 'ramp'\nto = 3\nduration = -1\n", "x.toml: push[0].duration: must be > 0, got -1"),
    ("stop_time = 1\n[[push]]\nkind = 'ramp'\nto = 3\n", "x.toml: push[0].duration: required key missing"),
    ("stop_time = 1\n[[push]]\nkind = 'shove'\n", "x.toml: push[0].kind: must be one of"),
    ("stop_time = 1\n[[push]]\nkind = 'step'\nto = 1\nduration = 2\n", "x.toml: push[0].duration: unknown key"),
    ("stop_time = 1\n[[push]]\nkind = 'impulse'\nduration = 0.01\n", "push[0]: an impulse needs exactly one of"),
    ("stop_time = 5\n[[push]]\nkind = 'hold'\nduration = 2\n[[push]]\nkind = 'step'\nt = 1\nto = 2\n",
     "x.toml: push[1].t: starts at 1 s, before the previous segment ends at 2 s"),
    ("stop_time = 5\n[[push]]\nkind = 'step'\nt = 7\nto = 2\n", "push[0].t: starts at 7 s, after stop_time 5 s"),
    ("stop_time = 5\n[[push]]\nkind = 'pulse'\nforce = 3\nduration = 1\nrise = 0.6\n", "push[0].rise: 2 x rise"),
    ("stop_time = 5\n[controller]\nKa = 'x'\n", "x.toml: controller.Ka: parameter value must be a number or boolean"),
    ("stop_time = 5\n[expect]\nmust_fall = 1\n", "x.toml: expect.must_fall: must be true or false, got integer 1"),
    ("stop_time = 5\n[expect]\nphases_reached = [0, 4]\n", "x.toml: expect.phases_reached[1]: phases are 0..3, got 4"),
    ("stop_time = 5\n[expect]\nphases_y_reached = [5]\n", "x.toml: expect.phases_y_reached[0]: phases are 0..3, got 5"),
    ("stop_time = 5\n[expect]\nmin_cycles_y = -1\n", "x.toml: expect.min_cycles_y"),
    ("stop_time = 5\n[expect]\nerect_by = 9\n", "x.toml: expect.erect_by: must be <= 5, got 9"),
    ("stop_time = 5\n[expect]\nfall_before = 3\n", "expect.fall_before: only meaningful with must_fall = true"),
    ("stop_time = 5\n[expect]\nwhatever = 3\n", "x.toml: expect.whatever: unknown key"),
    ("stop_time = 5\n[expect]\nmax_abs = { zmp_y = -1 }\n", "x.toml: expect.max_abs.zmp_y: must be > 0, got -1"),
    ("stop_time = 5\n[expect]\nmin_range = 3\n", "x.toml: expect.min_range: must be a table"),
    ("stop_time = 5\n[reference]\ncolumns = ['a']\n", "x.toml: reference.file: required key missing"),
    ("stop_time = 5\nname = 'y'\n", "x.toml: name: 'y' differs from the file name 'x'"),
    ("stop_time = [\n", "x.toml: invalid TOML"),
])
def test_errors_name_file_key_and_problem(tmp_path, text, expected):
    assert expected in error_of(tmp_path, text)


def test_push_semantics():
    # step to 2 N at 1 s, ramp to 4 N over 1 s, hold 1 s, impulse of 0.5 N s over 10 ms, step to 0
    segs = [PushSegment("step", t=1.0, to=2.0), PushSegment("ramp", to=4.0, duration=1.0),
            PushSegment("hold", duration=1.0), PushSegment("impulse", impulse=0.5, duration=0.01),
            PushSegment("step", to=0.0)]
    p = PushProfile.from_segments(segs)
    assert p.value(0.5) == 0 and p.value(1.0) == 2.0 and p.value(1.5) == pytest.approx(3.0)
    assert p.value(2.5) == 4.0 and p.value(3.005) == pytest.approx(54.0) and p.value(3.02) == 0.0
    assert p.integral(10.0) == pytest.approx(3 + 4 + 0.5 + 0.04)  # ramp, hold, impulse on the 4 N level
    f = p.step_averages(0.0, 1e-3, 5000)
    assert f.sum() * 1e-3 == pytest.approx(p.integral(5.0), rel=1e-12)
    assert p.events() == [(1.0, 3.01)]


def test_short_impulse_is_conserved_off_grid():
    p = PushProfile.from_segments([PushSegment("impulse", t=0.10025, impulse=0.3, duration=0.0004)])
    f = p.step_averages(0.0, 1e-3, 1000)
    assert f.sum() * 1e-3 == pytest.approx(0.3, rel=1e-12)
    assert np.count_nonzero(f) == 1 and f[100] == pytest.approx(300.0)


def test_pulse_trapezoid():
    p = PushProfile.from_segments([PushSegment("pulse", t=1.0, force=-6.0, duration=1.0, rise=0.25)])
    assert p.value(1.125) == pytest.approx(-3.0) and p.value(1.5) == -6.0 and p.value(2.5) == 0
    assert p.integral(3.0) == pytest.approx(-6.0 * 0.75)
    assert p.peak() == -6.0


def test_parse_set():
    c, p = parse_set(["controller.Ka=30", "plant.noise=true", "controller.n=3"])
    assert c == {"Ka": 30, "n": 3} and p == {"noise": True}
    with pytest.raises(ScenarioError, match="prefix must be 'controller' or 'plant'"):
        parse_set(["robot.Ka=3"])
    with pytest.raises(ScenarioError, match="is not a number"):
        parse_set(["controller.Ka=abc"])


def test_parse_scenario_from_dict():
    sc = parse_scenario({"stop_time": 3.0, "push": [{"kind": "pulse", "t": 1, "force": 5, "duration": 0.5}],
                         "expect": {"must_fall": False, "phases_reached": [0]}}, "mem")
    assert sc.expect.must_fall is False and sc.push.peak() == 5


def test_generic_expectations_check_named_columns():
    """max_abs and min_range check any result column; a column the run does not have fails the
    check with a message naming the key and the column."""
    import numpy as np
    from anklehip.analysis.summary import check_expect
    from anklehip.files.scenario import Expect

    class Res:
        outcome, fell, message = "completed", False, ""
        data = np.array([(0.0, 0.0, 1.0), (0.1, 0.02, 1.3)], dtype=[("time", float), ("zmp_y", float), ("feet_x", float)])
    checks = {c.name: c for c in check_expect(Res(), Expect(max_abs={"zmp_y": 0.01, "nope": 1.0},
                                                           min_range={"feet_x": 0.2}))}
    assert not checks["max_abs zmp_y"].ok and "0.02" in checks["max_abs zmp_y"].detail
    assert not checks["max_abs nope"].ok and "expect.max_abs.nope" in checks["max_abs nope"].detail
    assert checks["min_range feet_x"].ok and "0.3" in checks["min_range feet_x"].detail


def test_frontal_phase_expectations():
    """phases_y_reached and min_cycles_y check the 3D controller's frontal phase (phase_y) as
    phases_reached and min_cycles check the sagittal one; a result without phase_y (the sagittal
    controller) fails them, saying so."""
    import numpy as np
    from anklehip.analysis.summary import check_expect
    from anklehip.files.scenario import Expect

    def res(cols):
        class Res:
            outcome, fell, message = "completed", False, ""
        n = len(next(iter(cols.values())))
        Res.data = np.zeros(n, dtype=[("time", float)] + [(k, float) for k in cols])
        Res.data["time"] = np.arange(n) * 0.1
        for k, v in cols.items():
            Res.data[k] = v
        return Res()

    e = Expect(phases_y_reached=[0, 1, 2, 3], min_cycles_y=1)
    ok = {c.name: c for c in check_expect(res({"phase_y": [0, 1, 2, 3, 0]}), e)}
    assert all(ok[f"frontal phase {p} reached"].ok for p in range(4)) and ok["frontal cycles"].ok
    part = {c.name: c for c in check_expect(res({"phase_y": [0, 1, 2, 2]}), e)}
    assert not part["frontal phase 3 reached"].ok and "[0, 1, 2]" in part["frontal phase 3 reached"].detail
    assert not part["frontal cycles"].ok and "0 complete" in part["frontal cycles"].detail
    none = {c.name: c for c in check_expect(res({"zmp_y": [0.0, 0.0]}), e)}
    assert not none["frontal phase 0 reached"].ok and "no phase_y" in none["frontal phase 0 reached"].detail
