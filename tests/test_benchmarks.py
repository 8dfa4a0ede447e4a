"""Every benchmark still runs (issue 33, item 10): `bash bench/run.sh --quick` runs each benchmark
command in its quick mode (short runs, one repetition) and must reach its end, printing every
figure; bench/report.py writes its JSON (here into a temporary file, never over
bench/results.json). No timing is asserted: the figures of a quick run on a loaded machine mean
nothing; what is held is that each benchmark runs and prints what docs/performance.md quotes
(`bash bench/run.sh` crashed at its last step, bench/report.py's sweep part, before).
"""
from __future__ import annotations

import json
import os
import re
import subprocess

from conftest import REPO_ROOT


def test_every_benchmark_runs_to_the_end_in_its_quick_mode(tmp_path, fmu_dir):
    out = tmp_path / "results.json"
    committed = (REPO_ROOT / "bench" / "results.json").read_bytes()
    env = dict(os.environ, ANKLEHIP_FMU_DIR=str(fmu_dir))
    r = subprocess.run(["bash", str(REPO_ROOT / "bench" / "run.sh"), "--quick", "--out", str(out)],
                       capture_output=True, text=True, timeout=1800, cwd=REPO_ROOT, env=env)
    assert r.returncode == 0, (r.stdout[-3000:], r.stderr[-3000:])
    o = r.stdout
    # each benchmark's section and a figure of each
    for header, figure in [
            ("== controller: ahc_step", r"median [\d.]+ ns/step"),
            ("== leg IK", r"ahc_leg_ik_pose\s+median [\d.]+ ns/call"),
            ("== 3D plant: Hoap2Plant3D model on ODE", r"default\s+[\d.]+\s+[\d.]+"),
            ("== closed loop on the 3D plant", r"as shipped\s+native \+CSV\s+[\d.]+"),
            ("== closed loop, FMPy master", r"real-time factor [\d.]+"),
            ("== plant, closed loop, peers, scaling", r"1\. plant alone"),
    ]:
        assert header in o, header
        assert re.search(figure, o), figure
    for line in ("2. closed loop paper_five_pushes", "3. peers", "4. scaling", "sweep (2 runs", "capability map"):
        assert line in o, line
    R = json.loads(out.read_text())
    assert R["quick"] is True
    assert {"plant", "closed_loop", "peers", "scaling", "sweep", "capability_map"} <= set(R)
    assert R["closed_loop"]["rows_identical"] is True
    assert all(p["outcome"] == "completed" for e in ("native", "fmpy") for p in R["scaling"][e]["points"])
    assert R["sweep"]["native_2w_runs_per_min"] > 0 and R["capability_map"]["2w_runs_per_min"] > 0
    assert (REPO_ROOT / "bench" / "results.json").read_bytes() == committed      # the quoted figures untouched


def test_the_benchmarks_outside_run_sh_run_in_their_quick_mode(fmu_dir):
    """bench/fmu_builds.py (two builds side by side: here the same build twice, whose trajectories
    must then agree exactly) and scripts/stiff_crossover.py (the integrators' crossover that sets
    Hoap2Plant's automatic choice, docs/plant.md section 7) on short runs."""
    py = str(REPO_ROOT / ".venv" / "bin" / "python")
    r = subprocess.run([py, str(REPO_ROOT / "bench" / "fmu_builds.py"), str(fmu_dir), str(fmu_dir), "--quick"],
                       capture_output=True, text=True, timeout=600, cwd=REPO_ROOT)
    assert r.returncode == 0, r.stderr[-3000:]
    rows = re.findall(r"^\s+(native|fmpy)\s+A\s+[\d.]+ s\s+B\s+[\d.]+ s\s+B/A\s+[\d.]+\s+largest \|A - B\| over (\d+) "
                      r"signals: (\S+)$", r.stdout, re.M)
    assert [x[0] for x in rows] == ["native", "fmpy"], r.stdout
    assert all(int(n) > 10 and float(d) == 0.0 for _, n, d in rows), r.stdout   # the same FMUs: the same run
    r = subprocess.run([py, str(REPO_ROOT / "scripts" / "stiff_crossover.py"), "--fmu", str(fmu_dir / "Hoap2Plant.fmu"),
                        "--stop-time", "0.02", "--scales", "1,2500"],
                       capture_output=True, text=True, timeout=600, cwd=REPO_ROOT)
    assert r.returncode == 0, r.stderr[-3000:]
    rows = [ln.split() for ln in r.stdout.splitlines()[1:]]
    assert [row[0] for row in rows] == ["1", "2500"], r.stdout
    assert rows[0][-1] == "ERK" and rows[1][-1] == "BDF", r.stdout  # the automatic choice at both ends
