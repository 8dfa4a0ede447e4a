"""`anklehip regen-references` keeps its hands off the checkout unless asked (anklehip/running/references.py):

- --check writes nothing and names each file that would change with its largest difference (the
  signal and the time), exit 1; exit 0 when nothing would;
- --out writes the new references and step-test cases into another folder, the checkout untouched;
- without either it rewrites only the files whose bytes change (a second run touches nothing).

Runs on a copy of two scenarios and one step-test case (ANKLEHIP_ROOT), so the repository's own
golden files are never written by the suite.
"""
from __future__ import annotations

import shutil

import pytest
from fmpy.util import read_csv, write_csv

from anklehip.cli import main
from conftest import REPO_ROOT

SCENARIOS = ("ankle_small_push", "short_impact")
CASE = "ankle_small_push"


def _tree(root):
    return {p.relative_to(root).as_posix(): (p.read_bytes(), p.stat().st_mtime_ns)
            for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture
def root(tmp_path, fmu_dir, monkeypatch):
    r = tmp_path / "root"
    (r / "scenarios" / "reference").mkdir(parents=True)
    for name in SCENARIOS:
        shutil.copy(REPO_ROOT / "scenarios" / f"{name}.toml", r / "scenarios")
        shutil.copy(REPO_ROOT / "scenarios" / "reference" / f"{name}.csv", r / "scenarios" / "reference")
    shutil.copytree(REPO_ROOT / "tests" / "steptests" / CASE, r / "tests" / "steptests" / CASE)
    monkeypatch.setenv("ANKLEHIP_ROOT", str(r))
    monkeypatch.setenv("ANKLEHIP_FMU_DIR", str(fmu_dir))
    monkeypatch.chdir(tmp_path)
    return r


def test_check_out_and_rewrite_only_what_changes(root, tmp_path, capsys):
    # a reference that certainly differs from what the FMUs compute now
    ref = root / "scenarios" / "reference" / "ankle_small_push.csv"
    d = read_csv(ref)
    d["theta_hip"][100] += 0.001
    write_csv(ref, d)
    t_changed = float(d["time"][100])
    before = _tree(root)

    assert main(["regen-references", "--check", "--no-progress"]) == 1
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.startswith("ankle_small_push:"))
    assert "would change: largest difference 0.001 (theta_hip at t=" in line and f"t={t_changed:.4g} s" in line, line
    assert "step-test case ankle_small_push" in out and out.splitlines()[-1].endswith("unchanged")
    assert _tree(root) == before                      # nothing written

    elsewhere = tmp_path / "new"
    assert main(["regen-references", "--out", str(elsewhere), "--no-progress"]) == 0
    assert _tree(root) == before                      # the checkout untouched
    assert sorted(p.relative_to(elsewhere).as_posix() for p in elsewhere.rglob("*") if p.is_file()) == sorted(
        [f"reference/{n}.csv" for n in SCENARIOS]
        + [f"steptests/{CASE}/{f}" for f in ("AnkleHipController_in.csv", "AnkleHipController_ref.csv",
                                                "AnkleHipController_ref.opt", "steptest.toml")])
    new = read_csv(elsewhere / "reference" / "ankle_small_push.csv")
    assert abs(new["theta_hip"][100] - d["theta_hip"][100]) == pytest.approx(0.001, abs=1e-6)

    # write into the checkout copy: afterwards nothing would change, and a rerun touches nothing
    assert main(["regen-references", "--no-progress"]) == 0
    capsys.readouterr()
    written = _tree(root)
    assert written["scenarios/reference/ankle_small_push.csv"][0] == \
        (elsewhere / "reference" / "ankle_small_push.csv").read_bytes()
    assert main(["regen-references", "--check", "--no-progress"]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == "0 would change, 3 unchanged"
    assert main(["regen-references", "--no-progress"]) == 0
    assert _tree(root) == written                     # same bytes, same mtimes: not rewritten


def test_check_names_the_scenarios_it_was_given(root, capsys):
    assert main(["regen-references", "short_impact", "--check", "--no-progress"]) in (0, 1)
    out = capsys.readouterr().out
    assert out.startswith("short_impact: ") and "ankle_small_push" not in out
