"""Sweep files (anklehip/sweepfile.py, `anklehip sweep FILE`): what a file may say and how a wrong
one is refused (file, key, value named; exit 2, nothing run), the points a grid and a seeded random
sample make, how a point's values become the push and the parameters, and a small sweep end to
end: one row per point with the outcome metrics, the figures, and a second run that only resumes.
"""
from __future__ import annotations

import csv
from pathlib import Path

import pytest

from anklehip.cli import main
from anklehip.paths import scenarios_dir
from anklehip.scenario import ScenarioError
from anklehip.sweepfile import load_sweep_file, point_setup

BASE = """description = "test"
scenario = "hip_saves_push"
stop_time = 4.0
[push]
t = 1.0
rise = 0.05
[[variant]]
name = "ankle_only"
controller = { hip_strategy_enabled = 0 }
[[variant]]
name = "default"
"""


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


def test_grid_and_random_points(tmp_path):
    sf = load_sweep_file(_write(tmp_path, BASE + '[grid]\n"push.force" = "4:8:2"\n"push.duration" = [0.1, 0.5]\n'))
    vals = sf.values()
    assert len(vals) == 6 and vals[0] == {"push.force": 4.0, "push.duration": 0.1}
    assert len(sf.specs(None, "native")) == 12 and len({s["id"] for s in sf.specs(None, "native")}) == 12
    r = load_sweep_file(_write(tmp_path, BASE + '[random]\nn = 5\nseed = 3\n"push.force" = [2, 20]\n'))
    a, b = r.values(), r.values()
    assert a == b and len(a) == 5 and all(2 <= x["push.force"] <= 20 for x in a)


def test_point_values_become_the_push_and_parameters(tmp_path):
    sf = load_sweep_file(_write(tmp_path, BASE + '[grid]\n"push.force" = [6]\n'))
    prof, c, p, f = point_setup(sf, {"push.force": 6.0, "push.duration": 0.4, "push.direction": -1,
                                     "push.height": 0.3, "controller.Ka": 20.0, "faults.zmp_noise": 0.001}, None)
    assert prof.peak() == -6.0 and prof.events()[0][0] == pytest.approx(1.0)
    assert p == {"h_push": 0.3} and c == {"Ka": 20.0} and f == {"zmp_noise": 0.001}


@pytest.mark.parametrize("extra,match", [
    ('nosuch = 1\n[grid]\n"push.force" = [6]\n', r"s\.toml: variant\[1\]\.nosuch: unknown key"),
    ('[grid]\n"push.weight" = [6]\n', r"grid\.push\.weight: unknown key to sweep"),
    ('[grid]\n"push.force" = "6:2"\n', r"grid\.push\.force.*6:2"),
    ('[grid]\n"push.force" = [6]\n[random]\nn = 3\n"push.force" = [1, 2]\n', r"exactly one of \[grid\]"),
    ('[random]\nn = 3\n"push.force" = [5, 2]\n', r"random\.push\.force: needs low < high"),
    ('[random]\n"push.force" = [1, 2]\n', r"random\.n: required key missing"),
])
def test_bad_files_name_the_key(tmp_path, extra, match):
    with pytest.raises(ScenarioError, match=match):
        load_sweep_file(_write(tmp_path, BASE + extra))


def test_unknown_top_level_key(tmp_path):
    with pytest.raises(ScenarioError, match=r"s\.toml: nosuch: unknown key"):
        load_sweep_file(_write(tmp_path, 'nosuch = 1\n' + BASE + '[grid]\n"push.force" = [6]\n'))


def test_cli_refuses_unknown_parameters_before_running(tmp_path, capsys):
    p = _write(tmp_path, BASE + '[grid]\n"controller.nosuch" = [1, 2]\n')
    assert main(["sweep", str(p), "--workers", "1", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "nosuch" in err and "s.toml" in err and not (tmp_path / "out" / "points.jsonl").exists()


def test_small_sweep_end_to_end_and_resume(tmp_path, capsys):
    p = _write(tmp_path, BASE + '[grid]\n"push.force" = [6, 30]\n"push.duration" = [0.2, 1.0]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(p), "--workers", "1", "--engine", "native", "--out", str(out)]) == 0
    with open(out / "points.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 8
    for col in ("variant", "push.force", "push.duration", "outcome", "fell_at", "peak_zmp", "phases",
                "time_to_recover", "peak_hip", "solver_steps", "rhs_evals"):
        assert col in rows[0]
    by = {(r["variant"], float(r["push.force"]), float(r["push.duration"])): r for r in rows}
    assert by[("default", 6.0, 0.2)]["outcome"] == "completed"
    assert by[("ankle_only", 30.0, 1.0)]["outcome"] == "fell"
    for fig in ("points_outcome.png", "points_peak_zmp.png", "points_recovery.png"):
        assert (out / fig).stat().st_size > 1000
    capsys.readouterr()
    assert main(["sweep", str(p), "--workers", "1", "--engine", "native", "--out", str(out)]) == 0
    assert "8 from an earlier run" in capsys.readouterr().out


def test_committed_sweep_files_load():
    files = sorted((scenarios_dir() / "sweeps").glob("*.toml"))
    assert files
    for f in files:
        sf = load_sweep_file(f)
        assert sf.specs(None, "native")
