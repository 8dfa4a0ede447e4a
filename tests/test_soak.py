"""Soak (anklehip.running.soak): the CI version of the one-hour run of docs/reliability.md.

Five simulated minutes of seeded random pushes on one pair of FMU instances: no fall, no fault,
the erect posture comes back under 0.005 rad before every push, resident memory flat after the
warm-up minute, CVODE's work per quiet second the same at the end as at the start. The checker
itself is tested on doctored statistics, so that a green soak means something.
"""
from __future__ import annotations

import numpy as np
import pytest

from anklehip.running.soak import SoakReport, quiet_seconds, random_pushes


@pytest.fixture(scope="module")
def five_minutes(fmu_dir):
    from anklehip.running.soak import soak
    return soak(300.0, seed=11, fmu_dir=fmu_dir)


def test_five_minute_soak_has_no_problem(five_minutes):
    r = five_minutes
    assert r.outcome == "completed", r.message
    assert r.problems == []
    f = r.figures()
    assert r.pushes >= 20 and len(r.posture) == r.pushes       # a window before every push but the first + the end
    assert f["worst_posture_before_push_rad"] < 0.005
    assert f["rss_kib_after_warmup"] > 0 and f["rss_growth_kib"] <= 32
    assert f["quiet_seconds"] > 100
    # the pushes did something: contact switches, phases beyond 0
    assert f["mode_switches"] > 0 and r.per_second["max_phase"].max() >= 2


def test_push_schedule_is_seeded_and_survivable():
    a, b, c = random_pushes(600, 3), random_pushes(600, 3), random_pushes(600, 4)
    assert np.array_equal(a.values, b.values) and not np.array_equal(a.values, c.values)
    for s in a.segments:
        assert -5.0 <= s.force <= 8.0 and abs(s.force) >= 2.0
        assert 2 * s.rise <= s.duration <= 2.0 + 1e-9
    ev = a.events()
    gaps = [ev[i + 1][0] - ev[i][1] for i in range(len(ev) - 1)]
    assert min(gaps) >= 10.0 - 1e-9 and max(gaps) <= 14.0 + 1e-9


def _report(**cols):
    n = 400
    s = np.zeros(n, dtype=[("time", float), ("rss_kib", np.int64), ("push", np.int8), ("max_abs_theta", float),
                           ("max_phase", np.int8), ("fault", np.int32), ("outputs_finite", np.int8),
                           ("cvode_steps", np.int64), ("rhs_evals", np.int64), ("root_evals", np.int64),
                           ("mode_switches", np.int64)])
    s["time"] = np.arange(1, n + 1)
    s["rss_kib"] = 50_000
    s["outputs_finite"] = 1
    s["cvode_steps"], s["rhs_evals"] = 2000, 15000
    for k, v in cols.items():
        s[k] = v
    return SoakReport(duration=n, seed=0, end_time=n, outcome="completed", message="", pushes=0, wall_time=1.0,
                      per_second=s, posture=[(10.0, 0.001)])


def test_checker_flags_each_problem():
    assert _report().check() == []
    rss = np.full(400, 50_000)
    rss[:30] = 40_000          # before the warm-up minute: not counted
    rss[200:] = 50_040         # ten pages after it: counted
    assert "resident memory grew by 40 KiB after the warm-up (tolerance 32)" in _report(rss_kib=rss).check()[0]
    steps = np.full(400, 2000)
    steps[300:] = 2500
    assert "cvode_steps per quiet second changed from 2000" in _report(cvode_steps=steps).check()[0]
    fault = np.zeros(400, int)
    fault[123] = 0x10
    assert "controller fault 0x10 in the second ending at t=124 s" in _report(fault=fault).check()[0]
    r = _report()
    r.posture = [(42.0, 0.006)]
    assert "posture before t=42.00 s: max |theta| 0.00600 rad" in r.check()[0]


def test_quiet_seconds_exclude_pushes_and_their_aftermath():
    r = _report()
    s = r.per_second
    s["push"][100:102] = 1
    s["max_phase"][100:104] = 3
    q = quiet_seconds(s)
    assert not q[:5].any() and q[5:100].all() and not q[100:107].any() and q[107:].all()


def test_soak_memory_does_not_grow_with_its_duration(fmu_dir):
    """What the soak holds besides one row per simulated second does not depend on how long it
    runs (issue 33: whole-run tables of the push force and the posture windows, 9 B per 1 ms step,
    made the resident memory 83 MB for an hour and 367 MB for ten). Peak traced allocations
    (NumPy's included) of a 20 s and a 100 s soak: the 80 000 more steps added 3.2 MB before."""
    import tracemalloc
    from anklehip.running.soak import soak
    peaks = []
    for d in (20.0, 100.0):
        tracemalloc.start()
        r = soak(d, seed=5, fmu_dir=fmu_dir)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        assert r.outcome == "completed", r.message
    assert peaks[1] - peaks[0] < 100_000, peaks      # 80 rows of statistics: a few kB
