"""The example notebook docs/examples/python_api.ipynb runs (nbclient, a kernel of this Python, in a
temporary folder) without an error, and every text output is the one committed: the notebook shows
the API as it is (scripts/run_notebook.py; regenerate with `.venv/bin/python scripts/run_notebook.py`)."""
from __future__ import annotations

import subprocess
import sys

from conftest import REPO_ROOT


def test_example_notebook_runs_and_its_outputs_are_current(fmu_dir):
    r = subprocess.run([sys.executable, str(REPO_ROOT / "scripts" / "run_notebook.py"), "--check"], cwd=REPO_ROOT,
                       capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, f"scripts/run_notebook.py --check exited {r.returncode}:\n{r.stdout}\n{r.stderr[-4000:]}"
    assert "outputs as committed" in r.stdout
