"""Hostile input to the command line and the file readers (issue 12): every input yields a result or
exactly one clear error (one of our exception classes in-process; exit 2 and one stderr line naming
the file, key, cell or option from the CLI), never a traceback, and a failed or refused run never
destroys or fakes a complete result.

The first part reproduces each defect of the audit; the second is property-based (Hypothesis) on the
loaders, in-process and derandomized (deterministic in CI), plus a handful of CLI subprocesses.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from fmpy.util import write_csv
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from anklehip import cli
from anklehip.running import run as run_module
from anklehip.errors import InputError
from anklehip.cli import main
from anklehip.analysis.compare import CompareError, CompareReport, compare, read_result_csv
from anklehip.running.fmu import FMUError
from anklehip.files.paths import MissingFileError, scenarios_dir
from anklehip.files.output import output_lock
from anklehip.files.scenario import (EXPECT_KEYS, MAX_STEPS, PUSH_KINDS, REF_KEYS, Scenario, ScenarioError,
                               load_scenario, parse_scenario, time_grid_problem)
from anklehip.running.steptest import StepTestError, StepTestResult, case_files, run_case

REPO = Path(__file__).resolve().parent.parent
STEPTESTS = Path(__file__).parent / "steptests"
GARBAGE = b"\x89PNG\r\n\x1a\n\x00\xff\xfe garbage \xc3\x28 \x80\x81"

# deterministic in CI: derandomized, no example database, no per-example deadline (a first FMU
# load takes longer than the rest)
PROPERTY = settings(derandomize=True, database=None, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


def one_error_line(err: str, *needles: str) -> str:
    """stderr holds exactly one line, an error naming all `needles`; no traceback."""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "error" in lines[0] and "Traceback" not in err, err
    for n in needles:
        assert n in lines[0], (n, lines[0])
    return lines[0]


def snapshot(folder: Path) -> dict[str, bytes]:
    """The result files of a folder (not the lock file, which holds the last owner's pid)."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file() and p.name != ".anklehip.lock"}


@pytest.fixture(scope="module")
def previous_result(tmp_path_factory, fmu_dir):
    """A folder holding a complete earlier result of ankle_small_push (0.5 s)."""
    out = tmp_path_factory.mktemp("previous") / "o"
    assert main(["run", "ankle_small_push", "--out", str(out), "--stop-time", "0.5", "--no-progress"]) == 0
    assert (out / "ankle_small_push.csv").is_file() and (out / "ankle_small_push.summary.json").is_file()
    return out


# ----------------------------------------------------------------------------------------------
# 1. binary garbage in a TOML or a CSV

def test_binary_scenario_is_one_clear_error(tmp_path, capsys):
    f = tmp_path / "garbage.toml"
    f.write_bytes(GARBAGE)
    with pytest.raises(ScenarioError, match=r"garbage.toml: line 1: not UTF-8 text \(byte 0x89\)"):
        load_scenario(f)
    assert main(["run", str(f), "--out", str(tmp_path / "o")]) == 2
    one_error_line(capsys.readouterr().err, "garbage.toml", "not UTF-8")
    assert not (tmp_path / "o").exists()


def test_binary_csv_is_one_clear_error(tmp_path, capsys):
    good = tmp_path / "good.csv"
    write_csv(good, np.array([(0.0, 1.0), (1.0, 2.0)], dtype=[("time", float), ("y", float)]))
    bad = tmp_path / "bad.csv"
    bad.write_bytes(b'"time","y"\n0,1\n' + GARBAGE)
    with pytest.raises(CompareError, match=r"reference .*bad.csv: line 3: not UTF-8 text"):
        read_result_csv(bad, "reference")
    assert main(["compare", str(good), str(bad)]) == 2
    one_error_line(capsys.readouterr().err, "bad.csv", "line 3", "not UTF-8")
    assert main(["compare", str(bad), str(good)]) == 2
    one_error_line(capsys.readouterr().err, "result", "bad.csv")


def small_case(dst: Path, steps: int = 30) -> Path:
    """The first `steps` controller steps of a committed step-test case."""
    src = case_files(STEPTESTS / "ankle_small_push")
    f = case_files(dst)
    dst.mkdir(parents=True, exist_ok=True)
    f["in"].write_text("\n".join(src["in"].read_text().splitlines()[:steps + 2]) + "\n")
    f["ref"].write_text("\n".join(src["ref"].read_text().splitlines()[:steps + 2]) + "\n")
    f["opt"].write_text(f"StartTime, 0.0\nStopTime, {steps / 1000!r}\nStepSize, 0.001\nRelTol, 1e-06\n")
    shutil.copy(src["meta"], f["meta"])
    return dst


def test_binary_files_in_a_step_test_case(tmp_path, controller_fmu, capsys):
    case = small_case(tmp_path / "case")
    assert main(["steptest", str(case)]) == 0
    capsys.readouterr()
    for key in ("in", "ref", "opt", "meta"):
        c = small_case(tmp_path / f"case_{key}")
        case_files(c)[key].write_bytes(GARBAGE)
        assert main(["steptest", str(c)]) == 2, key
        one_error_line(capsys.readouterr().err, case_files(c)[key].name, "not UTF-8")


# ----------------------------------------------------------------------------------------------
# 2.-4. --stop-time and --out are checked before the output folder is touched

@pytest.mark.parametrize("value, reason", [
    ("-1", "must be > the start time 0 s"),
    ("0", "must be > the start time 0 s"),
    ("nan", "must be a finite number, got 'nan'"),
    ("inf", "must be a finite number, got 'inf'"),
    ("1e9", f"more than the {MAX_STEPS}"),
    ("0.0005", "is not a whole number of steps of 0.001 s"),
    ("abc", "must be a finite number, got 'abc'"),
])
def test_bad_stop_time_is_refused_and_keeps_the_previous_result(previous_result, value, reason, capsys):
    before = snapshot(previous_result)
    try:
        rc = main(["run", "ankle_small_push", "--out", str(previous_result), f"--stop-time={value}"])
    except SystemExit as e:        # argparse: the value is not a finite number
        rc = e.code
    assert rc == 2
    one_error_line(capsys.readouterr().err, "--stop-time", reason)
    assert snapshot(previous_result) == before


def test_time_grid_rule():
    assert time_grid_problem(2.0, 1e-3) is None and time_grid_problem(3600.0, 1e-3) is None
    assert "more than" in time_grid_problem(3600.002, 1e-3)
    assert "more than" in time_grid_problem(1.0, 1e-300)
    assert "finite" in time_grid_problem(float("inf"), 1e-3)
    assert "whole number" in time_grid_problem(0.25, 0.1, start=0.1)
    assert time_grid_problem(0.3, 0.1, start=0.1) is None
    assert "start time" in time_grid_problem(0.1, 0.1, start=0.1)
    with pytest.raises(ScenarioError, match="stop_time: stop_time 1e\\+09 is 1e\\+12 steps"):
        parse_scenario({"stop_time": 1e9}, "x.toml")


def test_out_naming_a_file_is_refused(tmp_path, fmu_dir, capsys):
    f = tmp_path / "afile"
    f.write_text("keep me")
    for out in (f, f / "sub"):
        assert main(["run", "ankle_small_push", "--out", str(out), "--stop-time", "0.1"]) == 2
        one_error_line(capsys.readouterr().err, "--out", "afile exists and is not a folder")
    assert main(["run", "ankle_small_push", "--out", str(tmp_path / "o"), "--stop-time", "0.1",
                 "--record-steptest", str(f)]) == 2
    one_error_line(capsys.readouterr().err, "--record-steptest")
    assert not (tmp_path / "o").exists()
    assert main(["record", "ankle_small_push", str(f), "--stop-time", "0.1"]) == 2
    one_error_line(capsys.readouterr().err, "afile exists and is not a folder")
    assert f.read_text() == "keep me"


# ----------------------------------------------------------------------------------------------
# 5. out-of-range parameters: exit 2 before running, naming the key, the value and the range

def test_out_of_range_set_is_refused_before_running(previous_result, capsys):
    before = snapshot(previous_result)
    assert main(["run", "ankle_small_push", "--out", str(previous_result), "--set", "plant.m1=-5"]) == 2
    captured = capsys.readouterr()
    one_error_line(captured.err, "--set plant.m1", "-5", "[1e-06, 1000]", "ankle_small_push.toml")
    assert captured.out == ""
    for bad, needle in [("controller.Ka=nan", "must be finite"), ("controller.hip_strategy_enabled=2", "[0, 1]"),
                        ("controller.feet_offset_mode=99999999999", "outside its range"),
                        ("controller.hip_strategy_enabled=0.5", "is Integer, got 0.5")]:
        assert main(["run", "ankle_small_push", "--out", str(previous_result), "--set", bad]) == 2
        one_error_line(capsys.readouterr().err, "--set " + bad.split("=")[0], needle)
    assert snapshot(previous_result) == before


def test_out_of_range_scenario_table_is_refused(tmp_path, fmu_dir, capsys):
    f = tmp_path / "neg_g.toml"
    f.write_text("stop_time = 0.5\n[plant]\ng = -9.81\n")
    assert main(["run", str(f), "--out", str(tmp_path / "o")]) == 2
    captured = capsys.readouterr()
    one_error_line(captured.err, "neg_g.toml [plant]", "'g'", "-9.81", "[0, 100]")
    assert captured.out == "" and not (tmp_path / "o").exists()


# ----------------------------------------------------------------------------------------------
# 6. compare tolerances

@pytest.fixture(scope="module")
def two_csvs(tmp_path_factory):
    d = tmp_path_factory.mktemp("csvs")
    t = np.linspace(0, 1, 101)
    a = np.zeros(len(t), [("time", float), ("y", float), ("phase", float)])
    a["time"], a["y"], a["phase"] = t, np.sin(3 * t), (t > 0.5) * 2
    write_csv(d / "res.csv", a)
    write_csv(d / "ref.csv", a)
    return d / "res.csv", d / "ref.csv"


@pytest.mark.parametrize("option, value", [("--abs-tol", "nan"), ("--rel-tol", "-1"), ("--band-floor", "inf"),
                                           ("--dy", "-0.1"), ("--dx", "0"), ("--num", "1"), ("--t-start", "nan")])
def test_compare_refuses_bad_tolerances(two_csvs, option, value, capsys):
    with pytest.raises(SystemExit) as e:
        main(["compare", *map(str, two_csvs), f"{option}={value}"])
    assert e.value.code == 2
    one_error_line(capsys.readouterr().err, option, repr(value))


def test_compare_library_refuses_bad_tolerances(two_csvs):
    for kw in ({"abs_tol": float("nan")}, {"rel_tol": -1.0}, {"dy": float("inf")}, {"dx": 0}, {"num": 1},
               {"tolerances": {"y": {"abs_tol": -1.0}}}):
        with pytest.raises(CompareError, match="must be"):
            compare(*two_csvs, **kw)
    assert compare(*two_csvs, abs_tol=0.0, rel_tol=0.0).passed


# ----------------------------------------------------------------------------------------------
# 7. two runs into one folder: the second fails at once, naming the folder and the other's pid

HOLD_LOCK = textwrap.dedent("""
    import sys
    from anklehip.files.output import output_lock
    with output_lock(sys.argv[1]):
        print("locked", flush=True)
        sys.stdin.readline()
""")


def test_second_run_into_the_same_folder_fails_at_once(previous_result, capsys):
    before = snapshot(previous_result)
    other = subprocess.Popen([sys.executable, "-c", HOLD_LOCK, str(previous_result)], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True)
    try:
        assert other.stdout.readline().strip() == "locked"
        assert main(["run", "ankle_small_push", "--out", str(previous_result), "--stop-time", "0.2",
                     "--no-progress"]) == 2
        one_error_line(capsys.readouterr().err, str(previous_result), f"pid {other.pid}",
                       "another anklehip run")
        assert snapshot(previous_result) == before
    finally:
        other.communicate("\n", timeout=30)
    # the lock is gone with its process
    assert main(["run", "ankle_small_push", "--out", str(previous_result), "--stop-time", "0.5",
                 "--no-progress"]) == 0
    assert snapshot(previous_result).keys() == before.keys()


def test_two_concurrent_cli_runs_never_mix(tmp_path, fmu_dir):
    """Two real `anklehip run` processes into one folder: one writes its result, the other exits 2
    naming the folder (or, when the first is already done, also succeeds); the summary always
    describes the CSV next to it."""
    import json
    out = tmp_path / "o"
    cmd = lambda stop: [sys.executable, "-m", "anklehip.cli", "run", "ankle_small_push", "--out", str(out),  # noqa: E731
                        "--stop-time", stop, "--no-progress"]
    a = subprocess.Popen(cmd("6"), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    b = subprocess.Popen(cmd("3"), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    (_, ea), (_, eb) = a.communicate(timeout=120), b.communicate(timeout=120)
    assert sorted([a.returncode, b.returncode]) in ([0, 2], [0, 0]), (ea, eb)
    for rc, err in ((a.returncode, ea), (b.returncode, eb)):
        if rc == 2:
            one_error_line(err, str(out), "another anklehip run (pid")
    s = json.loads((out / "ankle_small_push.summary.json").read_text())
    d = read_result_csv(out / "ankle_small_push.csv")
    assert d["time"][-1] == pytest.approx(s["end_time"]) == pytest.approx(s["stop_time"])


# ----------------------------------------------------------------------------------------------
# 8. a run that has been computed keeps its summary; no traceback from the CLI

def test_failed_figures_do_not_lose_the_summary(tmp_path, fmu_dir, monkeypatch, capsys):
    import json

    def broken(*a, **k):
        raise RuntimeError("no display")
    monkeypatch.setattr(run_module, "make_figures", broken)
    out = tmp_path / "o"
    assert main(["run", "ankle_small_push", "--out", str(out), "--stop-time", "0.2", "--plots",
                 "--no-progress"]) == 1
    s = json.loads((out / "ankle_small_push.summary.json").read_text())
    assert s["complete"] and "figures failed: RuntimeError: no display" in s["warnings"][0]
    assert "warnings: figures failed" in capsys.readouterr().err


@pytest.mark.parametrize("args, needles", [
    (["run", "{garbage}", "--out", "{tmp}/o"], ["garbage.toml", "not UTF-8"]),
    (["run", "ankle_small_push", "--stop-time", "nan"], ["--stop-time", "'nan'"]),
    (["compare", "{garbage}", "{garbage}"], ["garbage.toml", "not UTF-8"]),
    (["steptest", "{tmp}"], ["AnkleHipController_ref.opt", "no such file"]),
    (["sweep", "ankle_small_push", "--forces", "1:nan:1"], ["--forces 1:nan:1"]),
    (["plot", "{tmp}"], ["no such file"]),
])
def test_cli_subprocess_no_traceback(tmp_path, args, needles):
    g = tmp_path / "garbage.toml"
    g.write_bytes(GARBAGE)
    argv = [a.format(garbage=g, tmp=tmp_path) for a in args]
    p = subprocess.run([sys.executable, "-m", "anklehip.cli", *argv], capture_output=True, text=True, timeout=120,
                       cwd=tmp_path)
    assert p.returncode == 2, p.stderr
    one_error_line(p.stderr, *needles)


# ----------------------------------------------------------------------------------------------
# Property tests: scenario files

SCALARS = st.one_of(st.booleans(), st.integers(-2 ** 63, 2 ** 63 - 1), st.floats(), st.text(max_size=12),
                    st.dates(), st.datetimes(), st.times())
VALUES = st.recursive(SCALARS, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner,
                                                                                           max_size=4), max_leaves=8)
NUMBERS = st.one_of(st.integers(-5, 100), st.floats(-1e3, 1e3), st.floats(),
                    st.sampled_from([0, 0.0, -0.0, 1e-300, 5e-324, 1e308, -1e308, 2 ** 63 - 1]))
ANY = NUMBERS | VALUES
PARAMS = ["Ka", "Kh", "hip_strategy_enabled", "m1", "g", "sample_period", "h_push", "feet_offset_mode", "nosuch"]


MOSTLY_NUMBERS = st.one_of(NUMBERS, NUMBERS, NUMBERS, ANY)     # one_of draws its branches evenly


def _table(keys, values=st.one_of(MOSTLY_NUMBERS, st.booleans(), st.lists(st.integers(-1, 4), max_size=3))):
    return st.fixed_dictionaries({}, optional={k: values for k in keys})


SEGMENT = st.fixed_dictionaries({"kind": st.sampled_from(PUSH_KINDS + ("shove",)) | ANY},
                                optional={k: MOSTLY_NUMBERS for k in ("t", "to", "duration", "force", "impulse",
                                                                      "rise")})
SCENARIO_DICT = st.one_of(
    st.dictionaries(st.text(max_size=10), ANY, max_size=5),
    st.fixed_dictionaries({"stop_time": NUMBERS}, optional={
        "step": st.sampled_from([1e-3, 0.01, 0.3]) | NUMBERS, "name": st.sampled_from(["h", "x y", ""]) | ANY, "description": ANY,
        "push": st.lists(SEGMENT, max_size=4) | ANY, "push_y": st.lists(SEGMENT, max_size=3) | ANY,
        "plant_model": st.sampled_from(["sagittal", "3d", "4d"]) | ANY,
        "controller_config": st.sampled_from(["default", "paper", "", "nope"]) | ANY,
        "controller": st.dictionaries(st.sampled_from(PARAMS) | st.text(max_size=6), MOSTLY_NUMBERS, max_size=4),
        "plant": st.dictionaries(st.sampled_from(PARAMS) | st.text(max_size=6), MOSTLY_NUMBERS, max_size=4) | ANY,
        "expect": _table(sorted(EXPECT_KEYS) + ["bogus"]) | ANY,
        "reference": _table(sorted(REF_KEYS)) | ANY, "tags": st.lists(ANY, max_size=3) | ANY}))


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("hostile")


@settings(PROPERTY, max_examples=300)
@given(head=st.sampled_from([b"", b"stop_time = 1\n", b"stop_time = 1\n[[push]]\nkind = 'pulse'\n"]),
       raw=st.binary(max_size=300) | st.text(max_size=300).map(str.encode))
def test_property_scenario_bytes(work, head, raw):
    f = work / "h.toml"
    f.write_bytes(head + raw)
    try:
        assert isinstance(load_scenario(f), Scenario)
        event("a scenario")
    except ScenarioError as e:
        assert "h.toml: " in str(e)
        event("ScenarioError")


@pytest.fixture(scope="module")
def models(fmu_dir):
    from anklehip.running.master import Models
    return {m: Models.load(plant_model=m) for m in ("sagittal", "3d")}


@settings(PROPERTY, max_examples=1000)
@given(data=SCENARIO_DICT)
def test_property_scenario_structures(work, models, data):
    """Random TOML-typed structures with the schema's keys: a Scenario whose run is well defined
    (finite push, a bounded number of steps) or a ScenarioError naming the file; parameter tables
    that pass the schema pass the FMU check or raise FMUError."""
    from anklehip.running.master import check_overrides
    try:
        sc = parse_scenario(data, "h.toml", work / "h.toml")
    except ScenarioError as e:
        assert str(e).startswith("h.toml: ")
        event("ScenarioError")
        return
    assert 1 <= sc.n_steps <= MAX_STEPS and np.all(np.isfinite(sc.push.values))
    assert np.all(np.isfinite(sc.push.step_averages(0.0, sc.step, min(sc.n_steps, 1000))))
    try:
        check_overrides(models[sc.plant_model], sc.controller, sc.plant, "h.toml")
        event("a scenario")
    except FMUError as e:
        assert "(h.toml [" in str(e)
        event("FMUError")


def _mutate_lines(text: str, data) -> str:
    """Drop, duplicate or rewrite a line, replace a value, or insert random characters."""
    lines = text.splitlines()
    i = data.draw(st.integers(0, max(0, len(lines) - 1)))
    op = data.draw(st.sampled_from(["drop", "dup", "value", "line", "chars", "truncate"]))
    if not lines:
        return data.draw(st.text(max_size=40))
    if op == "drop":
        del lines[i]
    elif op == "dup":
        lines.insert(i, lines[i])
    elif op == "value" and "=" in lines[i]:
        key = lines[i].split("=", 1)[0]
        lit = data.draw(st.sampled_from(["-1", "0", "nan", "inf", "-inf", "1e308", "1e-320", "true", '"x"', "[]",
                                         "[1, 2]", "{a = 1}", "1979-05-27", "99999999999999999999", "0.5",
                                         '"paper"', "3d", ""]))
        lines[i] = f"{key}= {lit}"
    elif op == "line":
        lines[i] = data.draw(st.text(max_size=30))
    elif op == "chars":
        pos = data.draw(st.integers(0, len(lines[i])))
        lines[i] = lines[i][:pos] + data.draw(st.text(min_size=1, max_size=5)) + lines[i][pos:]
    else:
        lines = lines[:i]
    return "\n".join(lines) + "\n"


COMMITTED = sorted(scenarios_dir().glob("*.toml"))


@settings(PROPERTY, max_examples=400)
@given(src=st.sampled_from(COMMITTED), data=st.data())
def test_property_mutated_committed_scenarios(work, models, src, data):
    """Mutations of the committed scenarios through the CLI's whole pre-run validation
    (anklehip.running.run.resolve with the CLI's option names: file, FMUs, configuration, parameter
    ranges, --stop-time)."""
    text = src.read_text()
    for _ in range(data.draw(st.integers(1, 3))):
        text = _mutate_lines(text, data)
    f = work / src.name
    f.write_text(text)
    stop = data.draw(st.none() | st.sampled_from([-1.0, 0.0, 0.5, 0.0005, 1e9, 2.0]))
    a = argparse.Namespace(scenario=str(f), set=None, plant=None, fmu_dir=None, controller_config=None,
                           stop_time=stop)
    try:
        sc, _ = run_module.resolve(a.scenario, plant=a.plant, controller_config=a.controller_config,
                                   stop_time=a.stop_time, fmu_dir=a.fmu_dir, origins={"stop_time": "--stop-time"})
    except InputError as e:
        assert src.name in str(e) or str(e).startswith("--stop-time"), str(e)
        event(type(e).__name__)
        return
    assert sc.name == src.stem
    event("a scenario")


# ----------------------------------------------------------------------------------------------
# Property tests: CSVs

CELLS = st.one_of(st.sampled_from(["0", "1.5", "-2e-3", "nan", "inf", "1e400", "", " ", "1 2", "x", '"3"', "0x1",
                                   "1_0", "\t4"]),
                  st.floats().map(repr), st.text(max_size=6))
HEADERS = st.lists(st.sampled_from(['"time"', "time", "Time", '"y"', "y", '"phase"', "", '""', "t"]) | st.text(max_size=5),
                   min_size=1, max_size=4).map(",".join)


@st.composite
def csv_texts(draw):
    kind = draw(st.sampled_from(["random", "structured", "structured", "structured"]))
    if kind == "random":
        return draw(st.text(max_size=120))
    header = draw(st.sampled_from(['"time","y","phase"']) | HEADERS)
    n = len(header.split(","))
    rows = []
    for k in range(draw(st.integers(0, 6))):
        cells = [repr(0.1 * k)] + [draw(st.sampled_from(["0.5", "1", "-3.25"])) for _ in range(n - 1)]
        if draw(st.integers(0, 3)) == 0:         # a bad cell
            cells[draw(st.integers(0, n - 1))] = draw(CELLS)
        if draw(st.integers(0, 5)) == 0:         # a ragged row
            cells = cells[:-1] if draw(st.booleans()) else cells + ["1"]
        rows.append(",".join(cells))
    end = draw(st.sampled_from(["\n", "\r\n", "\n\n", ""]))
    return "\n".join([header] + rows) + end


@st.composite
def valid_csv_texts(draw):
    """Well-formed CSVs with hostile values: NaN, Inf, huge, tiny, repeated or backward times."""
    n = draw(st.integers(1, 12))
    value = st.floats(-1e3, 1e3) | st.floats() | st.sampled_from([1e308, -1e308, 5e-324, 0.0])
    t = np.cumsum([draw(st.sampled_from([0.1] * 20 + [0.0, -0.05, 1e-12])) for _ in range(n)])
    rows = [f"{float(t[k])!r},{draw(value)!r},{draw(st.sampled_from([0, 1, 2, 3]))}" for k in range(n)]
    return "\n".join(['"time","y","phase"'] + rows) + "\n"


@settings(PROPERTY, max_examples=600)
@given(text=csv_texts(), binary=st.just(b"") | st.binary(max_size=4))
def test_property_csv_reader(work, text, binary):
    f = work / "h.csv"
    f.write_bytes(text.encode() + binary)
    try:
        d = read_result_csv(f, "input")
    except CompareError as e:
        assert str(e).startswith(f"input {f}: ")
        event("CompareError")
        return
    event("a result")
    assert d.dtype.names[0].lower() == "time" and len(d) >= 1
    assert all(d.dtype[n] == np.float64 for n in d.dtype.names)


@settings(PROPERTY, max_examples=300)
@given(res=csv_texts() | valid_csv_texts(), ref=valid_csv_texts(), opts=st.fixed_dictionaries({}, optional={
    "abs_tol": st.floats(0, 1), "rel_tol": st.floats(0, 1), "band_floor": st.floats(0, 1),
    "columns": st.lists(st.sampled_from(["y", "phase", "z"]), max_size=2), "t_start": st.floats(-1, 1)}))
def test_property_compare(work, res, ref, opts):
    (work / "res.csv").write_text(res)
    (work / "ref.csv").write_text(ref)
    try:
        rep = compare(work / "res.csv", work / "ref.csv", **opts)
        assert isinstance(rep, CompareReport)
        event(f"a report, passed={rep.passed}")
    except CompareError:
        event("CompareError")


@settings(PROPERTY, max_examples=120, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(option=st.sampled_from(["--abs-tol", "--rel-tol", "--dy", "--dx", "--num", "--band-floor", "--t-start",
                               "--t-stop"]),
       value=st.sampled_from(["nan", "-1", "0", "1e-3", "1e308", "inf", "x", "2", "-0"]) | st.text(max_size=4))
def test_property_compare_options(two_csvs, option, value, capsys):
    try:
        rc = main(["compare", *map(str, two_csvs), f"{option}={value}", "--failed-only"])
    except SystemExit as e:
        rc = e.code
    captured = capsys.readouterr()
    assert rc in (0, 1, 2)
    if rc == 2:        # argparse names the option; compare() names the window by its keywords
        line = one_error_line(captured.err)
        assert option in line or option[2:].replace("-", "_") in line, line


# ----------------------------------------------------------------------------------------------
# Property tests: step-test folders

@pytest.fixture(scope="module")
def base_case(work, controller_fmu) -> Path:
    case = small_case(work / "base")
    assert run_case(case, controller_fmu).passed
    return case


OPT_LINES = st.sampled_from(["StartTime, 0.0", "StartTime, 0.01", "StartTime, nan", "StopTime, 0.03", "StopTime, 0",
                             "StopTime, inf", "StopTime, 1e9", "StopTime, 0.0305", "StepSize, 0.001", "StepSize, 0",
                             "StepSize, -1", "StepSize, 1e-300", "RelTol, x", "StopTime", "a, b, c", ""])
META_LITERALS = st.sampled_from(["1", "-1", "0", "1e-9", "nan", "inf", '"x"', "true", "[1, 2]", "{ a = 1 }",
                                 "1979-05-27", "2.5", "0.001"])
META_TABLES = st.sampled_from(["source", "controller", "compare", "compare.signals.theta_ankle_ref",
                               "compare.signals", "bogus"])
META_KEYS = st.sampled_from(["scenario", "stop_time", "outcome", "Ka", "hip_strategy_enabled", "sample_period",
                             "nosuch", "abs_tol", "rel_tol", "dx", "dy", "num", "signals", "band_floor"])


@st.composite
def meta_texts(draw):
    lines = []
    for table in draw(st.lists(META_TABLES, max_size=3, unique=True)):
        lines.append(f"[{table}]")
        lines += [f"{k} = {draw(META_LITERALS)}" for k in draw(st.lists(META_KEYS, max_size=3, unique=True))]
    return "\n".join(lines) + "\n"


@st.composite
def mutated_case(draw, base: Path):
    """(file name -> new content or None to delete) for a mutation of the base case."""
    names = [p.name for p in sorted(base.iterdir())]
    op = draw(st.sampled_from(["delete", "extra", "meta", "opt", "cell", "cell", "bytes"]))
    if op == "delete":
        return {draw(st.sampled_from(names)): None}
    if op == "extra":
        return {draw(st.sampled_from(["notes.txt", "AnkleHipController_out.csv", "x.toml"])): b"\x00junk"}
    if op == "meta":
        return {"steptest.toml": draw(meta_texts()).encode()}
    if op == "opt":
        return {"AnkleHipController_ref.opt": "\n".join(draw(st.lists(OPT_LINES, max_size=5))).encode()}
    name = draw(st.sampled_from(["AnkleHipController_in.csv", "AnkleHipController_ref.csv"]))
    lines = (base / name).read_text().splitlines()
    if op == "bytes":
        raw = "\n".join(lines).encode()
        pos = draw(st.integers(0, len(raw)))
        return {name: raw[:pos] + draw(st.binary(min_size=1, max_size=4)) + raw[pos:]}
    row = draw(st.integers(0, len(lines) - 1))
    cells = lines[row].split(",")
    cells[draw(st.integers(0, len(cells) - 1))] = draw(CELLS)
    lines[row] = ",".join(cells)
    return {name: ("\n".join(lines) + "\n").encode()}


@settings(PROPERTY, max_examples=400)
@given(data=st.data())
def test_property_step_test_folders(work, base_case, controller_fmu, data):
    case = work / "mutated"
    if case.exists():
        shutil.rmtree(case)
    shutil.copytree(base_case, case)
    for name, content in data.draw(mutated_case(base_case)).items():
        if content is None:
            (case / name).unlink()
        else:
            (case / name).write_bytes(content)
    try:
        r = run_case(case, controller_fmu, work / "mutated_out")
    except (StepTestError, CompareError, FMUError) as e:
        assert str(case) in str(e) or "AnkleHipController.fmu" in str(e), str(e)
        event(type(e).__name__)
        return
    assert isinstance(r, StepTestResult) and len(r.data) >= 2
    event(f"a result, passed={r.passed}")


def test_step_test_meta_errors_name_file_and_key(tmp_path, controller_fmu):
    case = small_case(tmp_path / "c")
    f = case_files(case)
    for text, needle in [("compare = 3\n", "steptest.toml: compare: must be a table"),
                         ("[controller]\nKa = 'x'\n", "steptest.toml: controller.Ka: parameter value must be"),
                         ("[compare]\nabs_tol = nan\n", "steptest.toml: compare.abs_tol: must be finite"),
                         ("[compare]\ndx = 0\n", "steptest.toml: compare.dx: must be >= 1"),
                         ("[controller]\nsample_period = -1.0\n", "sample_period' = -1.0 is outside its range"),
                         ("[compare.signals.theta_ankle_ref]\nabs_tol = -1\n",
                          "compare.signals.theta_ankle_ref.abs_tol: must be >= 0")]:
        f["meta"].write_text(text)
        with pytest.raises((StepTestError, FMUError), match=needle.replace(".", r"\.").replace("(", r"\(")):
            run_case(case, controller_fmu)
    f["meta"].write_text("[compare.signals.theta_ankle_ref]\nabs_tol = 1e-12\n")   # applied, not ignored
    assert run_case(case, controller_fmu).passed


def test_locks_of_different_folders_are_independent(tmp_path):
    """Different folders do not block each other; the lock file holds the owner's pid."""
    with output_lock(tmp_path / "a"), output_lock(tmp_path / "b"):
        assert (tmp_path / "a" / ".anklehip.lock").read_text().strip() == str(os.getpid())


# ----------------------------------------------------------------------------------------------
# issue 33, item 9: the smaller ones

def test_toml_with_a_byte_order_mark_is_read(tmp_path, fmu_dir, capsys):
    """Editors on Windows write a UTF-8 BOM; the TOML parser alone said only "Invalid statement"."""
    sc = tmp_path / "bom.toml"
    sc.write_bytes(b"\xef\xbb\xbf" + (scenarios_dir() / "ankle_small_push.toml").read_bytes())
    assert main(["run", str(sc), "--out", str(tmp_path / "o"), "--stop-time", "0.05", "--no-progress"]) == 0
    assert load_scenario(sc).stop_time == load_scenario(scenarios_dir() / "ankle_small_push.toml").stop_time


def test_deeply_nested_toml_is_refused_before_parsing(tmp_path, capsys):
    """3 000 nested table names took 48 s to refuse (the parser is quadratic in the depth)."""
    base = (scenarios_dir() / "ankle_small_push.toml").read_text()
    deep = tmp_path / "deep.toml"
    deep.write_text(base + "\n[controller" + ".a" * 3000 + "]\nx = 1\n")
    with pytest.raises(ScenarioError, match=r"deep\.toml: invalid TOML: line \d+: a key or table nested 3001 levels "
                                            r"deep \(at most 64\)"):
        load_scenario(deep)
    many = tmp_path / "many.toml"
    many.write_text(base + "".join(f"\n[controller{'.a' * n}]" for n in range(1, 3001)) + "\n")
    import time
    t0 = time.perf_counter()
    assert main(["run", str(many), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    assert time.perf_counter() - t0 < 10
    one_error_line(capsys.readouterr().err, "many.toml", "MiB: too large for a TOML input file")


def test_a_folder_named_like_an_fmu_is_named_as_such(tmp_path, fmu_dir, capsys):
    d = tmp_path / "fmus"
    shutil.copytree(fmu_dir, d, ignore=shutil.ignore_patterns("AnkleHipController.fmu", "fmi3"))
    (d / "AnkleHipController.fmu").mkdir()
    assert main(["--fmu-dir", str(d), "run", "ankle_small_push", "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    one_error_line(capsys.readouterr().err, f"{d / 'AnkleHipController.fmu'} is a folder, not an FMU",
                   "an FMU is one zip file")


def _limited_write_run(out: Path, fmu_dir, limit: int, *extra) -> subprocess.CompletedProcess:
    """`anklehip run` whose files may not grow beyond `limit` bytes (RLIMIT_FSIZE: a write beyond
    fails with EFBIG, as a full disk fails with ENOSPC; Python ignores SIGXFSZ)."""
    import resource

    def limit_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return subprocess.run([sys.executable, "-m", "anklehip.cli", "run", "ankle_small_push", "--out", str(out),
                           "--no-progress", *extra], capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, ANKLEHIP_FMU_DIR=str(fmu_dir)), preexec_fn=limit_files)


def test_a_write_that_fails_names_the_file_and_the_reason(previous_result, fmu_dir):
    """Disk-full messages named the reason or the file, not both; the earlier result stays."""
    before = snapshot(previous_result)
    # larger than the FMUs' binaries (1.4 MB, unpacked first), smaller than the 6 s run's CSV (3 MB)
    r = _limited_write_run(previous_result, fmu_dir, 2_000_000)
    assert r.returncode == 2, r.stderr
    one_error_line(r.stderr, f"{previous_result / 'ankle_small_push.csv'}: File too large")
    assert snapshot(previous_result) == before
    assert not [p for p in previous_result.iterdir() if p.name.startswith(".ankle_small_push")]


def test_a_full_disk_is_named(tmp_path, fmu_dir):
    """The same on a real full file system (a 300 kB tmpfs; skipped where it cannot be mounted)."""
    mnt = tmp_path / "full"
    mnt.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=300k", "tmpfs", str(mnt)],
                                           capture_output=True).returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    try:
        r = subprocess.run([sys.executable, "-m", "anklehip.cli", "run", "ankle_small_push", "--out",
                            str(mnt / "o"), "--no-progress"], capture_output=True, text=True, timeout=300,
                           env=dict(os.environ, ANKLEHIP_FMU_DIR=str(fmu_dir)))
        assert r.returncode == 2 and f"{mnt / 'o' / 'ankle_small_push.csv'}: No space left on device" in r.stderr, \
            r.stderr
        assert [p.name for p in (mnt / "o").iterdir()] == [".anklehip.lock"]
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)
