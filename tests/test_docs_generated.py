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
