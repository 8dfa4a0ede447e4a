"""The generated sections of docs/*.md (variable tables between `<!-- BEGIN GENERATED: ... -->` /
`<!-- END GENERATED -->`) match what the build's generators print now.

Runs `scripts/update_docs.py --check` against the build folder of tests/conftest.py
(ANKLEHIP_BUILD_DIR, default <repo>/build). Fix a failure with
`.venv/bin/python scripts/update_docs.py`.
"""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

from conftest import REPO_ROOT

SCRIPT = REPO_ROOT / "scripts" / "update_docs.py"


def test_generated_doc_sections_are_current(build_dir):
    env = dict(os.environ, ANKLEHIP_BUILD_DIR=str(build_dir))
    r = subprocess.run([sys.executable, str(SCRIPT), "--check"], cwd=REPO_ROOT, env=env,
                       capture_output=True, text=True, timeout=120)
    if r.returncode != 0:
        pytest.fail(f"scripts/update_docs.py --check exited {r.returncode}:\n{r.stdout}{r.stderr}", pytrace=False)


def test_controller_parameter_table_defaults_are_the_fmus(fmu_path):
    """docs/controller.md section 7 (written for C users, not generated) states each parameter's
    default and range; every one equals the controller FMU's start value and min/max (so a change of defaults, or of the
    HOAP-2 numbers, cannot leave the table behind)."""
    import re

    from anklehip.running.fmu import FMUInfo

    params = FMUInfo.load(fmu_path("AnkleHipController")).parameters()
    text = (REPO_ROOT / "docs" / "controller.md").read_text()
    section = text[text.index("## 7. Parameters"):text.index("## 8.")]
    rows = re.findall(r"^\| `(\w+)` \| [^|]* \| ([^|]*) \| \[([^,]*), ([^]]*)\] \|", section, re.M)
    assert len(rows) == len(params), f"table has {len(rows)} rows, the FMU {len(params)} parameters"
    for name, default, lo, hi in rows:
        assert float(default) == pytest.approx(float(params[name].start), rel=1e-12, abs=0), name
        assert (float(lo), float(hi)) == (float(params[name].min), float(params[name].max)), name
