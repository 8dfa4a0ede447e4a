"""scripts/sensor_aliasing.py, the evidence behind docs/plant.md section 5 (why Hoap2Plant's force
outputs are the mean over the communication step).

Establishes, on the first push of paper_five_pushes run with 1/32 ms communication steps: the ZMP
ripples within every millisecond while the hip strategy runs (the servos' set-points change once
per millisecond); a controller that reads the end of each millisecond reads the ripple's low side
at the peak, so it sees a lower peak than the millisecond's mean; and the run at 1 ms, where the
controller reads that mean, peaks within 0.2 mm of the sub-stepped run's means (the mean is what
the plant reports). The same on the 3D plant (paper_five_pushes_3d, docs/plant3d.md section 2)."""
from __future__ import annotations

import subprocess
import sys

import pytest

from conftest import REPO_ROOT, import_file

SCRIPT = REPO_ROOT / "scripts" / "sensor_aliasing.py"
sa = import_file(SCRIPT, "sensor_aliasing")


@pytest.mark.parametrize("scenario", ["paper_five_pushes", "paper_five_pushes_3d"])
def test_end_of_step_sampling_aliases_the_ripple(fmu_dir, scenario):
    m = sa.measure(scenario, fmu_dir=fmu_dir)
    assert m["ripple_max"] > 2.0                         # mm within one millisecond
    assert m["peak_mean"] - m["peak_end"] > 1.0          # the aliasing bias at the peak [mm]
    assert abs(m["peak_1ms"] - m["peak_mean"]) < 0.2     # the plant at 1 ms reports the mean


def test_wrong_scenario_is_exit_2():
    r = subprocess.run([sys.executable, str(SCRIPT), "no_such_scenario"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "no_such_scenario" in r.stderr and "Traceback" not in r.stderr
