"""scripts/deviation_sweeps.py, the evidence behind docs/controller.md section 4.5: a tiny grid runs
end to end (one configuration of round 2, one push shape, two forces, no Dask cluster) and writes
the per-run CSV and the summary table; the limit metrics count a force only when every weaker one
also passes; the built-in configurations are unique and match the FMU's named configurations."""
from __future__ import annotations

import csv
import subprocess
import sys

from conftest import REPO_ROOT, import_file

SCRIPT = REPO_ROOT / "scripts" / "deviation_sweeps.py"
ds = import_file(SCRIPT, "deviation_sweeps")


def test_tiny_sweep_end_to_end(fmu_dir, tmp_path):
    name = next(iter(ds.ROUNDS["2"]))        # the default configuration
    r = subprocess.run([sys.executable, str(SCRIPT), "--round", "2", "--only", name, "--shape", "short",
                        "--forces", "3:13:10", "--workers", "1", "--fmu-dir", str(fmu_dir), "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(open(tmp_path / "points.csv")))
    assert [(row["variant"], float(row["peak_force"])) for row in rows] == [(name, 3.0), (name, 13.0)]
    assert rows[0]["outcome"] == "completed" and float(rows[0]["max_abs_foot_pitch"]) == 0.0
    assert rows[1]["outcome"] == "fell"       # 13 N is above the static tipping force (11.97 N)
    assert "3 / 3 N" in (tmp_path / "table.md").read_text()


def test_limits_need_every_weaker_push():
    rows = [{"peak_force": f, "outcome": o, "max_abs_foot_pitch": p, "final_phase": 0}
            for f, o, p in [(3, "completed", 0.0), (4, "completed", 0.01), (5, "fell", 0.3), (6, "completed", 0.0)]]
    assert ds.limit(rows, [3, 4, 5, 6], ds.stood) == 4      # 6 N stood, but 5 N fell
    assert ds.limit(rows, [3, 4, 5, 6], ds.clean) == 3      # the foot tipped at 4 N


def test_configurations_are_full_and_paper_matches_the_fmu(fmu_path):
    from anklehip.running.fmu import FMUInfo
    info = FMUInfo.load(fmu_path("AnkleHipController"))
    params = info.parameters()
    for rnd in ds.ROUNDS.values():
        for settings in rnd.values():
            assert set(ds.FIRST_RELEASE) <= set(settings)    # every deviation written out in full
    # the default and the named "paper" configuration of round 2 are the FMU's
    defaults = {k: params[k].start for k in ds.DEFAULT}
    assert ds.DEFAULT == defaults
    assert ds.PAPER == {**defaults, **info.configuration("paper")}
