"""Step tests of the controller FMU alone (FMI cross-check layout), recorder, real-time pacing."""
from pathlib import Path

import numpy as np
import pytest
from fmpy.util import read_csv, write_csv

from anklehip.cli import main
from anklehip.paths import CONTROLLER_FMU, find_fmu, find_rt_runner
from anklehip.steptest import case_files, read_opt, run_case

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


def test_record_then_steptest_round_trip(controller_fmu, tmp_path, capsys):
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
    assert main(["steptest", str(case), "--failed-only", "--plot"]) == 1
    out = capsys.readouterr().out
    assert "[FAIL] theta_ankle_ref" in out and "first at t=1.0000" in out
    assert (case / "failed_signals.png").is_file()


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

    from anklehip.compare import compare
    case = [c for c in CASES if c.name == "chest_push_hip_cycle"][0]
    f = case_files(case)
    opt = read_opt(f["opt"])
    res = simulate_fmu(str(controller_fmu), fmi_type="CoSimulation", input=read_csv(f["in"]),
                       start_time=opt["StartTime"], stop_time=opt["StopTime"], step_size=opt["StepSize"],
                       output_interval=opt["StepSize"])
    rep = compare(res, f["ref"], abs_tol=1e-9, rel_tol=1e-6)
    assert rep.passed, rep.text(verbose=False)
