"""The native real-time runner fmu/rt_runner (anklehip_rt_step): paced and fast runs of the
controller FMU on a short sensor CSV; outputs identical to FMPy's simulate_fmu bit for bit, and
the timing report and the per-step timings (with the deadline misses) have their fields."""
from __future__ import annotations

import re
import subprocess

import numpy as np
import pytest

from conftest import CONTROLLER_OUTPUTS, read_csv_exact, sensor_signals, write_csv


@pytest.fixture(scope="module")
def short_case(tmp_path_factory):
    d = tmp_path_factory.mktemp("rt")
    t = np.arange(401) * 0.001  # 0.4 s
    return write_csv(d / "AnkleHipController_in.csv", sensor_signals(t, peak=9.0)), d


def _fmpy(controller_fmu, csv_in, stop):
    import fmpy
    from fmpy.util import read_csv

    return fmpy.simulate_fmu(str(controller_fmu), input=read_csv(str(csv_in)), step_size=0.001,
                             output_interval=0.001, stop_time=stop, output=CONTROLLER_OUTPUTS)


@pytest.mark.parametrize("mode", ["realtime", "fast"])
def test_rt_runner_matches_fmpy(controller_fmu, controller_unzipped, native_tool, short_case, mode):
    csv_in, d = short_case
    out, timings = d / f"out_{mode}.csv", d / f"timings_{mode}.csv"
    cmd = [str(native_tool("anklehip_rt_step")), "--fmu-dir", str(controller_unzipped), "--input", str(csv_in),
           "--output", str(out), "--timings", str(timings)]
    if mode == "fast":
        cmd.append("--fast")
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    rep = p.stdout
    for field in ("model: AnkleHipController", f"mode: {mode}", "steps: 400", "doStep_us:", "lateness_us:",
                  "deadline_misses:"):
        assert field in rep, rep
    m = re.search(r"doStep_us: p50=([\d.]+) p99=([\d.]+) p99\.9=([\d.]+) max=([\d.]+)", rep)
    assert m, rep
    p50, p99, p999, mx = map(float, m.groups())
    assert 0 < p50 <= p99 <= p999 <= mx
    if mode == "realtime":
        assert re.search(r"lateness_us: p50=[\d.]+ p99=[\d.]+ p99\.9=[\d.]+ max=[\d.]+", rep), rep
        assert re.search(r"deadline_misses: \d+", rep), rep

    got = read_csv_exact(out)
    ref = _fmpy(controller_fmu, csv_in, 0.4)
    assert len(got) == len(ref) == 401
    assert np.array_equal(got["time"], ref["time"])
    for name in CONTROLLER_OUTPUTS:
        a, b = np.asarray(got[name], float), np.asarray(ref[name], float)
        assert np.array_equal(a, b), (name, np.flatnonzero(a != b)[:5])
    tim = read_csv_exact(timings)
    assert len(tim) == 400 and np.all(tim["exec_ns"] > 0)
    assert tim.dtype.names == ("step", "time", "exec_ns", "lateness_ns", "miss")
    if mode == "realtime":
        assert tim["miss"].sum() == int(re.search(r"deadline_misses: (\d+)", rep)[1])
    else:
        assert not tim["miss"].any()


def test_rt_runner_flags_each_missed_deadline(controller_unzipped, native_tool, short_case):
    """At a 100 ns period every step overruns: the report counts the misses, timings.csv marks
    each one (anklehip steptest --native --fail-on-miss and realtime.json use the column)."""
    csv_in, d = short_case
    timings = d / "timings_tight.csv"
    p = subprocess.run([str(native_tool("anklehip_rt_step")), "--fmu-dir", str(controller_unzipped), "--input",
                        str(csv_in), "--step", "1e-7", "--stop-time", "1e-4", "--timings", str(timings)],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    misses = int(re.search(r"deadline_misses: (\d+)", p.stdout)[1])
    tim = read_csv_exact(timings)
    assert len(tim) == 1000 and misses > 0 and tim["miss"].sum() == misses
    assert set(np.unique(tim["miss"])) <= {0.0, 1.0}


def test_rt_runner_usage_errors(controller_unzipped, native_tool, short_case, tmp_path):
    exe = str(native_tool("anklehip_rt_step"))
    csv_in, _ = short_case
    assert subprocess.run([exe], capture_output=True).returncode == 2
    p = subprocess.run([exe, "--fmu-dir", str(tmp_path), "--input", str(csv_in)], capture_output=True, text=True)
    assert p.returncode == 1 and "modelDescription.xml" in p.stderr
    p = subprocess.run([exe, "--fmu-dir", str(controller_unzipped), "--input", str(csv_in), "--fast",
                        "--param", "zmp_limit_front=0.07"], capture_output=True, text=True)
    assert p.returncode == 1 and "zmp_limit_front" in p.stderr
