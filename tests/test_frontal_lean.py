"""The frontal pendulum lean on the 3D plant (docs/controller.md §11.2, F26-F29): closed loops that
pin what its unit tests (controller_c/tests/test_frontal.c) cannot, because they need the plant's
dynamics.

- F29 keeps the planned capture point inside the soles: a 12 N pulse of 0.2 s at 45° (forward and to
  the left) stands. Without F29 the plan, driven toward -D_y/(m g) while the pulse lasted, left the
  CoM moving toward the right sole's edge when it ended, and the robot fell over it 1.2 s later
  (the polar map measured it: docs/capability.md §7.7).
- The rocking hold reads the trunk's IMU: with the input imu_roll ignored (roll_rocking_y at its
  maximum, the feet never counted as rolled) a 0.2 s side pulse of 28 N that the defaults stand
  fells the robot (scripts/frontal_limits.py: 27/26 N without the roll hold).
"""
from __future__ import annotations

import dataclasses
import math

import pytest

from anklehip.files.paths import find_scenario
from anklehip.files.scenario import PushProfile, PushSegment, load_scenario
from anklehip.running import native
from anklehip.running.master import Models, simulate



def _pulse(t, force, duration, rise):
    return PushProfile.from_segments([PushSegment("pulse", t=t, force=force, duration=duration, rise=rise)])


@pytest.fixture(scope="module")
def models(fmu_dir):
    return Models.load(fmu_dir, plant_model="3d", controller_model="3d")


def test_short_oblique_pulse_stands(models):
    """12 N for 0.2 s (50 ms ramps) at 45°, on the polar map's base: stands, erect at the end."""
    base = load_scenario(find_scenario("paper_five_pushes_3d"))
    f = 12.0
    sc = dataclasses.replace(base, controller_model="3d", stop_time=6.0,
                             push=_pulse(2.0, f * math.cos(math.pi / 4), 0.2, 0.05),
                             push_y=_pulse(2.0, f * math.sin(math.pi / 4), 0.2, 0.05))
    r = simulate(sc, models, progress=False, engine=native.default_engine())
    assert r.outcome == "completed", r.message
    assert abs(r.data["phi_ref"][-1]) < 0.01 and r.data["phase_y"][-1] == 0


@pytest.mark.parametrize("roll_rocking_y, stands", [(None, True), (3.2, False)])
def test_rocking_hold_reads_the_imu(models, roll_rocking_y, stands):
    """A 28 N side pulse of 0.2 s: the defaults stand it; with the feet's roll ignored the lean
    follows the rocking after the pulse and the robot falls."""
    base = load_scenario(find_scenario("side_push_3d"))
    sc = dataclasses.replace(base, controller_model="3d", stop_time=4.0, push_y=_pulse(1.0, 28.0, 0.2, 0.05))
    over = {} if roll_rocking_y is None else {"roll_rocking_y": roll_rocking_y}
    r = simulate(sc, models, controller_overrides=over, progress=False, engine=native.default_engine())
    assert (r.outcome == "completed") == stands, (r.outcome, r.message)
