"""Step tests of the controller FMU alone (FMI cross-check layout), recorder, real-time pacing."""
import json
import re
from pathlib import Path

import numpy as np
import pytest
from fmpy.util import read_csv, write_csv

from anklehip.cli import main
from anklehip.files.paths import CONTROLLER_FMU, find_fmu, find_rt_runner
from anklehip.running.steptest import case_files, read_opt, run_case

CASES = sorted(p for p in (Path(__file__).parent / "steptests").iterdir() if p.is_dir()) \
    if (Path(__file__).parent / "steptests").is_dir() else []


@pytest.fixture(scope="module")
def controller_fmu():
    return find_fmu(CONTROLLER_FMU)


def test_committed_cases_exist():
    assert len(CASES) >= 2, "commit step-test cases under tests/steptests/ (anklehip record ...)"
    for c in CASES:
        f = case_files(c)
        assert f["in"].is_file() and f["ref"].is_file() and f["opt"].is_file(), c
        assert read_opt(f["opt"])["StepSize"] == pytest.approx(1e-3)


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_committed_case_passes(controller_fmu, case, tmp_path):
    r = run_case(case, controller_fmu, tmp_path)
    assert r.report is not None and r.report.passed, r.report.text(verbose=False)
    assert (tmp_path / "AnkleHipController_out.csv").is_file()


def test_record_then_steptest_round_trip(controller_fmu, tmp_path, capsys, monkeypatch):
    case = tmp_path / "case"
    assert main(["record", "ankle_small_push", str(case), "--stop-time", "1.5"]) == 0
    f = case_files(case)
    inp, ref = read_csv(f["in"]), read_csv(f["ref"])
    assert inp.dtype.names == ("time", "theta_ankle", "theta_hip", "zmp_x", "fz")
    assert len(ref) == len(inp) + 1 and ref["time"][-1] == pytest.approx(1.5)
    assert main(["steptest", str(case), "--out", str(tmp_path / "out")]) == 0
    assert "PASS" in capsys.readouterr().out
    # a tampered reference fails, with the signal and the time named, and a non-zero exit
    ref["theta_ankle_ref"][1000:] += 0.01
    write_csv(f["ref"], ref)
    # the plot goes to a results folder (--out, default results/steptest/<case>), never into the case
    before = sorted(p.name for p in case.iterdir())
    monkeypatch.chdir(tmp_path)
    assert main(["steptest", str(case), "--failed-only", "--plot"]) == 1
    out = capsys.readouterr().out
    assert "[FAIL] theta_ankle_ref" in out and "first at t=1.0000" in out
    assert (tmp_path / "results" / "steptest" / "case" / "failed_signals.png").is_file()
    assert main(["steptest", str(case), "--plot", "--out", str(tmp_path / "o")]) == 1
    assert (tmp_path / "o" / "case" / "failed_signals.png").is_file()
    assert sorted(p.name for p in case.iterdir()) == before


def test_realtime_pacing_reports_percentiles(controller_fmu, tmp_path):
    case = CASES[0]
    short = tmp_path / "short"
    short.mkdir()
    f, g = case_files(case), case_files(short)
    g["in"].write_text(f["in"].read_text())
    g["ref"].write_text(f["ref"].read_text())
    g["opt"].write_text("StartTime, 0\nStopTime, 0.3\nStepSize, 0.001\nRelTol, 1e-6\n")
    if f["meta"].is_file():
        g["meta"].write_text(f["meta"].read_text())
    r = run_case(short, controller_fmu, tmp_path / "o", realtime=True, compare_ref=False)
    rt = r.rt
    assert len(rt.exec_us) == 300 and rt.period_us == pytest.approx(1000.0)
    d = rt.as_dict()
    assert set(d["exec_us"]) == {"p50", "p99", "p99.9", "max"}
    assert 0 < d["exec_us"]["p50"] < 1000 and d["lateness_us"]["p50"] >= 0
    assert main(["steptest", str(short), "--realtime", "--no-compare", "--histogram",
                 str(tmp_path / "h.png")]) == 0
    assert (tmp_path / "h.png").stat().st_size > 1000


def test_native_runner_matches_reference(controller_fmu, tmp_path):
    assert find_rt_runner() is not None, "anklehip_rt_step not built: run `bash scripts/setup.sh`"
    assert main(["steptest", str(CASES[0]), "--native", "--out", str(tmp_path)]) == 0


def test_case_errors_are_clear(controller_fmu, tmp_path, capsys):
    bad = tmp_path / "bad"
    bad.mkdir()
    assert main(["steptest", str(bad)]) == 2
    assert "AnkleHipController_ref.opt: no such file" in capsys.readouterr().err
    (bad / "AnkleHipController_ref.opt").write_text("StartTime, 0\nStopTime, 0.01\nStepSize, 0.001\n")
    t = np.arange(0, 0.011, 0.001)
    d = np.zeros(len(t), [("time", float), ("theta_ankle", float), ("zmp_x", float)])
    d["time"] = t
    write_csv(bad / "AnkleHipController_in.csv", d)
    assert main(["steptest", str(bad), "--no-compare"]) == 2
    assert "AnkleHipController_in.csv lacks column(s) theta_hip, fz" in capsys.readouterr().err


def test_inputs_that_do_not_cover_the_run_are_an_error(controller_fmu, tmp_path, capsys):
    case = tmp_path / "short_in"
    case.mkdir()
    f = case_files(case)
    f["opt"].write_text("StartTime, 0\nStopTime, 0.02\nStepSize, 0.001\n")
    t = np.arange(0, 0.0105, 0.001)            # inputs up to 0.01 s, the run needs 0..0.019 s
    d = np.zeros(len(t), [("time", float), ("theta_ankle", float), ("theta_hip", float), ("zmp_x", float),
                          ("fz", float)])
    d["time"], d["fz"] = t, 70.0
    write_csv(f["in"], d)
    assert main(["steptest", str(case), "--no-compare"]) == 2
    err = capsys.readouterr().err
    assert "AnkleHipController_in.csv: the inputs cover t=0..0.01 s, the step test needs 0..0.019 s" in err
    d["time"][5] = d["time"][4]
    write_csv(f["in"], d)
    f["opt"].write_text("StartTime, 0\nStopTime, 0.01\nStepSize, 0.001\n")
    assert main(["steptest", str(case), "--no-compare"]) == 2
    assert "time must increase strictly; row 7" in capsys.readouterr().err


def test_case_works_with_fmpy_simulate_fmu(controller_fmu):
    """The cross-check layout is tool-neutral: FMPy's own simulate_fmu reproduces the reference."""
    from fmpy import simulate_fmu

    from anklehip.analysis.compare import compare
    case = [c for c in CASES if c.name == "chest_push_hip_cycle"][0]
    f = case_files(case)
    opt = read_opt(f["opt"])
    res = simulate_fmu(str(controller_fmu), fmi_type="CoSimulation", input=read_csv(f["in"]),
                       start_time=opt["StartTime"], stop_time=opt["StopTime"], step_size=opt["StepSize"],
                       output_interval=opt["StepSize"])
    rep = compare(res, f["ref"], abs_tol=1e-9, rel_tol=1e-6)
    assert rep.passed, rep.text(verbose=False)


# ----------------------------------------------------------------------------------------------
# `--realtime`, `--native`: the verdict rule, realtime.json, histograms, the summary

RUNNERS = ["python", "native"]


def _runner_args(runner: str) -> list[str]:
    if runner == "native":
        assert find_rt_runner() is not None, "anklehip_rt_step not built: run `bash scripts/setup.sh`"
        return ["--native"]
    return []


def _impossible_case(tmp_path: Path, name: str) -> Path:
    """A case paced at 100 ns (1000 steps): no runner keeps that deadline, every run misses."""
    case = tmp_path / name
    case.mkdir()
    f, g = case_files(CASES[0]), case_files(case)
    g["in"].write_text(f["in"].read_text())
    g["opt"].write_text("StartTime, 0\nStopTime, 0.0001\nStepSize, 1e-07\nRelTol, 1e-6\n")
    return case


def _documented_realtime_json_keys() -> set[str]:
    """The keys of the realtime.json table in docs/step-tests.md."""
    doc = (Path(__file__).parents[1] / "docs" / "step-tests.md").read_text()
    table = doc[doc.index("**`realtime.json`**"):].split("\n\n")[1]
    return set(re.findall(r"^\| `([^`]+)` \|", table, re.M))


@pytest.mark.parametrize("runner", RUNNERS)
def test_fail_on_miss_fails_an_impossible_deadline(controller_fmu, tmp_path, capsys, runner):
    case = _impossible_case(tmp_path, "tight")
    args = ["steptest", str(case), "--realtime", "--no-compare"] + _runner_args(runner)
    assert main(args + ["--fail-on-miss"]) == 1
    out = capsys.readouterr().out
    assert re.search(r"^tight: FAIL: [1-9]\d* deadline misses \(--fail-on-miss\)$", out, re.M), out
    assert main(args) == 0          # without --fail-on-miss the misses are reported, not failing
    out = capsys.readouterr().out
    assert "tight: PASS" in out and "not failing the run (no --fail-on-miss)" in out


def test_fail_on_miss_and_histogram_need_a_timed_run(controller_fmu, capsys):
    assert main(["steptest", str(CASES[0]), "--native", "--fail-on-miss"]) == 2
    assert "--fail-on-miss needs --realtime" in capsys.readouterr().err
    assert main(["steptest", str(CASES[0]), "--histogram", "h.png"]) == 2
    assert "--histogram needs --realtime or --native" in capsys.readouterr().err
    for extra in (["--native", "--realtime"], []):    # the native runner does not spin; nor an unpaced run
        assert main(["steptest", str(CASES[0]), "--spin-us", "50", *extra]) == 2
        assert "--spin-us applies to the Python runner with --realtime" in capsys.readouterr().err


@pytest.mark.parametrize("runner", RUNNERS)
def test_realtime_json_per_case_with_the_documented_keys(controller_fmu, tmp_path, runner):
    cases = [_impossible_case(tmp_path, n) for n in ("a", "b")]
    out = tmp_path / "out"
    assert main(["steptest", *map(str, cases), "--realtime", "--no-compare", "--out", str(out)]
                + _runner_args(runner)) == 0
    keys = _documented_realtime_json_keys()
    assert {"runner", "mode", "deadline_misses", "exec_us", "lateness_us"} <= keys
    for c in cases:
        d = json.loads((out / c.name / "realtime.json").read_text())
        assert set(d) == keys
        assert d["runner"] == runner and d["mode"] == "realtime" and d["steps"] == 1000
        assert d["period_us"] == pytest.approx(0.1) and d["deadline_misses"] > 0
        assert set(d["exec_us"]) == set(d["lateness_us"]) == {"p50", "p99", "p99.9", "max"}
        assert 0 < d["exec_us"]["p50"] <= d["exec_us"]["p99"] <= d["exec_us"]["max"]
        if runner == "native":        # the count is the runner's, step by step
            tim = np.genfromtxt(out / c.name / "timings.csv", delimiter=",", names=True)
            assert d["deadline_misses"] == int(tim["miss"].sum())


def test_native_fast_run_writes_realtime_json_without_deadlines(controller_fmu, tmp_path):
    case = _impossible_case(tmp_path, "fast")
    assert main(["steptest", str(case), "--no-compare", "--out", str(tmp_path / "o")] + _runner_args("native")) == 0
    d = json.loads((tmp_path / "o" / "fast" / "realtime.json").read_text())
    assert d["mode"] == "fast" and d["deadline_misses"] is None and d["lateness_us"] == {}
    assert d["steps"] == 1000 and d["exec_us"]["max"] > 0


@pytest.mark.parametrize("runner", RUNNERS)
def test_histogram_per_case(controller_fmu, tmp_path, capsys, runner):
    cases = [_impossible_case(tmp_path, n) for n in ("a", "b")]
    h = tmp_path / "rt.png"
    assert main(["steptest", *map(str, cases), "--realtime", "--no-compare", "--histogram", str(h)]
                + _runner_args(runner)) == 0
    files = [tmp_path / "rt_a.png", tmp_path / "rt_b.png"]
    assert all(f.stat().st_size > 1000 for f in files) and not h.exists()
    assert files[0].read_bytes() != files[1].read_bytes()
    out = capsys.readouterr().out
    assert f"histogram: {files[0]}" in out and f"histogram: {files[1]}" in out
    # a single case keeps the name it was given
    assert main(["steptest", str(cases[0]), "--realtime", "--no-compare", "--histogram", str(h)]
                + _runner_args(runner)) == 0
    assert h.stat().st_size > 1000


@pytest.mark.parametrize("runner", RUNNERS)
def test_summary_at_the_end_of_a_multi_case_run(controller_fmu, tmp_path, capsys, runner):
    cases = [_impossible_case(tmp_path, "a"), _impossible_case(tmp_path, "b"), tmp_path / "missing"]
    assert main(["steptest", *map(str, cases), "--realtime", "--no-compare", "--fail-on-miss"]
                + _runner_args(runner)) == 2
    out = capsys.readouterr().out
    lines = out[out.index("summary:"):].splitlines()
    assert lines[0] == "summary: 3 cases: 0 passed, 2 failed (a, b), 1 could not run (missing)"
    m = re.fullmatch(r"  deadline misses: (\d+) in total \(a (\d+), b (\d+)\); failing the run \(--fail-on-miss\)",
                     lines[1])
    assert m and int(m[1]) == int(m[2]) + int(m[3]) > 0, lines[1]
    assert re.fullmatch(rf"  worst-case doStep execution: [\d.]+ µs \([ab], {runner} runner; period 0.1 µs\)",
                        lines[2]), lines[2]
    assert lines[3].startswith("exit 2 (0: every case passed; 1: a case failed: ") and len(lines) == 4


def test_summary_of_a_passing_run(controller_fmu, capsys):
    assert main(["steptest", str(CASES[0]), str(CASES[1]), "--failed-only"]) == 0
    out = capsys.readouterr().out
    assert "summary: 2 cases: 2 passed, 0 failed, 0 could not run\n" in out
    assert "  worst-case doStep execution: not measured (use --realtime or --native)\nexit 0 (" in out


def test_histogram_is_readable():
    """Log µs axis with labelled units, the period as a red line, median/p99/max labelled without
    overlapping each other or the bars, the legend outside the data."""
    from anklehip.running.steptest import RTStats, rt_histogram_figure
    rng = np.random.default_rng(1)
    exec_us = np.concatenate([rng.lognormal(0.0, 0.3, 5000), [2.5, 2.6, 15.0]])   # ~1 µs, a few outliers
    late_us = rng.lognormal(np.log(80.0), 0.4, len(exec_us))
    fig = rt_histogram_figure(RTStats(period_us=1000.0, exec_us=exec_us, late_us=late_us, misses=0), "synthetic")
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    assert len(fig.axes) == 2
    for ax in fig.axes:
        assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
        assert "[µs]" in ax.get_xlabel() and ax.get_ylabel()
        lo, hi = ax.get_xlim()
        assert lo <= np.min(late_us if "lateness" in ax.get_xlabel() else exec_us) and hi >= 1000.0
        assert any(line.get_xdata()[0] == 1000.0 and line.get_color() == "tab:red" for line in ax.get_lines())
        labels = {t.get_text().split()[0]: t for t in ax.texts}
        assert {"median", "p99", "max", "period"} <= set(labels), list(labels)
        boxes = [t.get_window_extent(renderer) for t in labels.values()]
        assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
        tallest = max(p.get_height() for p in ax.patches)
        bar_top = ax.transData.transform((lo, tallest))[1]
        assert all(b.y0 > bar_top for b in boxes)
        assert ax.get_legend().get_window_extent(renderer).y1 <= ax.get_window_extent(renderer).y0
    import matplotlib.pyplot as plt
    plt.close(fig)
