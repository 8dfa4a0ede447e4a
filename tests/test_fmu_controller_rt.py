"""The native real-time runner fmu/rt_runner (anklehip_rt_step): paced and fast runs of each
controller FMU (AnkleHipController, and AnkleHipController3D on a push in both planes) on a short
sensor CSV; every output identical to FMPy's simulate_fmu bit for bit, and the timing report and
the per-step timings (with the deadline misses) have their fields."""
from __future__ import annotations

import re
import subprocess

import numpy as np
import pytest

from conftest import SHIPPED, _unzip, fmu_inputs, read_csv_exact, write_csv

CONTROLLERS = [n for n in SHIPPED if n.startswith("AnkleHipController")]


@pytest.fixture(scope="module", params=CONTROLLERS)
def short_case(request, fmu_path, tmp_path_factory):
    """(controller name, its FMU, unzipped, input CSV of 0.4 s, folder)."""
    name = request.param
    d = tmp_path_factory.mktemp("rt")
    t = np.arange(401) * 0.001  # 0.4 s; the 3D controller's lateral push starts at 0.5 s: ramp it earlier
    rows = fmu_inputs(name, t)
    if "zmp_y" in rows.dtype.names:
        rows = fmu_inputs(name, t + 0.6)
        rows["time"] = t
    fmu = fmu_path(name)
    return name, fmu, _unzip(fmu, tmp_path_factory), write_csv(d / f"{name}_in.csv", rows), d


def _outputs(fmu):
    from fmpy import read_model_description
    return [v.name for v in read_model_description(str(fmu)).modelVariables if v.causality == "output"]


def _fmpy(controller_fmu, csv_in, stop):
    import fmpy
    from fmpy.util import read_csv

    return fmpy.simulate_fmu(str(controller_fmu), input=read_csv(str(csv_in)), step_size=0.001,
                             output_interval=0.001, stop_time=stop, output=_outputs(controller_fmu))


@pytest.mark.parametrize("mode", ["realtime", "fast"])
def test_rt_runner_matches_fmpy(native_tool, short_case, mode):
    name, controller_fmu, controller_unzipped, csv_in, d = short_case
    out, timings = d / f"out_{mode}.csv", d / f"timings_{mode}.csv"
    cmd = [str(native_tool("anklehip_rt_step")), "--fmu-dir", str(controller_unzipped), "--input", str(csv_in),
           "--output", str(out), "--timings", str(timings)]
    if mode == "fast":
        cmd.append("--fast")
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    rep = p.stdout
    for field in (f"model: {name}\n", f"mode: {mode}", "steps: 400", "doStep_us:", "lateness_us:",
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
    outs = _outputs(controller_fmu)
    assert set(outs) <= set(got.dtype.names), set(outs) - set(got.dtype.names)
    for n in outs:
        a, b = np.asarray(got[n], float), np.asarray(ref[n], float)
        assert np.array_equal(a, b), (n, np.flatnonzero(a != b)[:5])
    tim = read_csv_exact(timings)
    assert len(tim) == 400 and np.all(tim["exec_ns"] > 0)
    assert tim.dtype.names == ("step", "time", "exec_ns", "lateness_ns", "miss")
    if mode == "realtime":
        assert tim["miss"].sum() == int(re.search(r"deadline_misses: (\d+)", rep)[1])
    else:
        assert not tim["miss"].any()


def test_rt_runner_flags_each_missed_deadline(native_tool, short_case):
    """At a 100 ns period every step overruns: the report counts the misses, timings.csv marks
    each one (anklehip steptest --native --fail-on-miss and realtime.json use the column)."""
    _, _, controller_unzipped, csv_in, d = short_case
    timings = d / "timings_tight.csv"
    p = subprocess.run([str(native_tool("anklehip_rt_step")), "--fmu-dir", str(controller_unzipped), "--input",
                        str(csv_in), "--step", "1e-7", "--stop-time", "1e-4", "--timings", str(timings)],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    misses = int(re.search(r"deadline_misses: (\d+)", p.stdout)[1])
    tim = read_csv_exact(timings)
    assert len(tim) == 1000 and misses > 0 and tim["miss"].sum() == misses
    assert set(np.unique(tim["miss"])) <= {0.0, 1.0}


def test_rt_runner_usage_errors(native_tool, short_case, tmp_path):
    exe = str(native_tool("anklehip_rt_step"))
    _, _, controller_unzipped, csv_in, _ = short_case
    assert subprocess.run([exe], capture_output=True).returncode == 2
    p = subprocess.run([exe, "--fmu-dir", str(tmp_path), "--input", str(csv_in)], capture_output=True, text=True)
    assert p.returncode == 1 and "modelDescription.xml" in p.stderr
    p = subprocess.run([exe, "--fmu-dir", str(controller_unzipped), "--input", str(csv_in), "--fast",
                        "--param", "zmp_limit_front=0.07"], capture_output=True, text=True)
    assert p.returncode == 1 and "zmp_limit_front" in p.stderr
