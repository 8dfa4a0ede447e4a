"""Sweeps on Dask (anklehip/running/points.py, anklehip sweep): the same points whether they run one by one,
on a local cluster of two worker processes or on a separately started `dask scheduler` +
`dask worker` reached by address; a killed sweep resumes to the same table; Ctrl-C stops cleanly
and keeps the finished points; a point that fails is recorded with its error and the others run;
a journal of another sweep is refused by name.
"""
from __future__ import annotations

import contextlib
import csv
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from anklehip.running.master import Models
from anklehip.files.paths import find_scenario
from anklehip.running.points import JournalMismatch
from anklehip.running.sweep import Variant, run_sweep, sweep_key

ANKLEHIP = str(Path(sys.executable).parent / "anklehip")
DASK = str(Path(sys.executable).parent / "dask")
SCENARIO = "hip_saves_push"
FORCES = [7.0, 9.0, 11.0]
VARIANTS = [Variant("full", {}, {}), Variant("ankle_only", {"hip_strategy_enabled": 0}, {})]


def _strip(rows):
    """The rows without what depends on the machine (wall time); NaN as None, to compare."""
    return [{k: (None if v != v else v) for k, v in r.items() if k != "wall_time"} for r in rows]


def _table(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return [{k: v for k, v in r.items() if k != "wall_time"} for r in csv.DictReader(f)]


@pytest.fixture(scope="module")
def one_by_one():
    res = run_sweep(str(find_scenario(SCENARIO)), FORCES, VARIANTS, workers=1, engine="native")
    assert res.complete and len(res.rows) == 6
    return _strip(res.rows)


def test_local_cluster_equals_one_by_one(one_by_one):
    res = run_sweep(str(find_scenario(SCENARIO)), FORCES, VARIANTS, workers=2, engine="native")
    assert res.complete
    assert _strip(res.rows) == one_by_one


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stop(proc) -> None:
    proc.terminate()
    try:
        proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()


@contextlib.contextmanager
def _scheduler():
    """`dask scheduler` on a free port of 127.0.0.1, listening: yields its address and the environment
    to start its clients in; stopped (by its pid) on the way out."""
    port = _free_port()
    env = {**os.environ, "DASK_LOGGING__DISTRIBUTED": "error"}
    sched = subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    try:
        deadline = time.time() + 60
        while True:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1).close()
                break
            except OSError:
                assert time.time() < deadline, "dask scheduler did not start"
                time.sleep(0.2)
        yield f"tcp://127.0.0.1:{port}", env
    finally:
        _stop(sched)


def test_real_scheduler_and_worker_by_address(one_by_one, tmp_path):
    """`dask scheduler` and `dask worker` started here on 127.0.0.1 (stopped by their pids): the
    sweep reaches them by --scheduler and by $DASK_SCHEDULER_ADDRESS, and the scheduler's
    worker ran the points."""
    with _scheduler() as (addr, env):
        worker = subprocess.Popen([DASK, "worker", addr, "--nworkers", "1", "--nthreads", "1", "--no-dashboard",
                                   "--name", "anklehip-test-worker"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        try:
            from dask.distributed import Client
            with Client(addr, timeout="30s") as c:
                c.wait_for_workers(1, timeout=60)
            res = run_sweep(str(find_scenario(SCENARIO)), FORCES, VARIANTS, workers=1, engine="native", scheduler=addr)
            assert res.complete and _strip(res.rows) == one_by_one
            out = tmp_path / "by_env"
            r = subprocess.run([ANKLEHIP, "sweep", SCENARIO, "--forces", "7,9,11", "--variant", "full", "--engine",
                                "native", "--out", str(out)], capture_output=True, text=True, timeout=300,
                               env={**env, "DASK_SCHEDULER_ADDRESS": addr})
            assert r.returncode == 0, r.stderr
            got = [(x["peak_force"], x["outcome"], x["max_phase"], x["max_abs_zmp"]) for x in _table(out / "sweep.csv")]
            assert got == [(str(x["peak_force"]), x["outcome"], str(x["max_phase"]), str(x["max_abs_zmp"]))
                           for x in one_by_one if x["variant"] == "full"]
            with Client(addr, timeout="30s") as c:
                logs = c.run(lambda dask_worker: dask_worker.state.executed_count)
            assert sum(logs.values()) >= 9      # 6 + 3 points ran on the scheduler's worker
        finally:
            _stop(worker)


def _sweep_cmd(out: Path, *extra: str) -> list[str]:
    return [ANKLEHIP, "sweep", "paper_five_pushes", "--forces", "4:7:0.5", "--variant", "full",
            "--variant", "ankle_only:controller.hip_strategy_enabled=0", "--workers", "2", "--engine", "fmpy",
            "--out", str(out), *extra]


def _journal_rows(out: Path) -> int:
    p = out / "sweep.points.jsonl"
    return max(0, len(p.read_text().splitlines()) - 1) if p.is_file() else 0


def _wait_for_rows(proc, out: Path, n: int, timeout: float = 120) -> None:
    deadline = time.time() + timeout
    while _journal_rows(out) < n:
        assert proc.poll() is None, "the sweep ended before it was stopped"
        assert time.time() < deadline, "no progress"
        time.sleep(0.1)


@pytest.fixture(scope="module")
def full_table(tmp_path_factory):
    out = tmp_path_factory.mktemp("full")
    r = subprocess.run(_sweep_cmd(out), capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    return _table(out / "sweep.csv")


def test_killed_sweep_resumes_to_the_same_table(full_table, tmp_path):
    out = tmp_path / "killed"
    p = subprocess.Popen(_sweep_cmd(out), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    _wait_for_rows(p, out, 4)
    os.killpg(p.pid, signal.SIGKILL)        # the sweep and its workers, as a crash would
    p.wait(timeout=30)
    done = _journal_rows(out)
    assert 4 <= done < 14
    r = subprocess.run(_sweep_cmd(out), capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert f"({done} from an earlier run)" in r.stderr
    assert _table(out / "sweep.csv") == full_table


def test_ctrl_c_stops_cleanly_and_keeps_the_finished_points(full_table, tmp_path):
    out = tmp_path / "interrupted"
    p = subprocess.Popen(_sweep_cmd(out), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for_rows(p, out, 3)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "Traceback" not in err and "Task exception" not in err and "WARNING" not in err, err
    assert len(err.splitlines()) <= 20, err
    assert "run the same command again" in err
    assert (out / "sweep.incomplete.csv").is_file() and not (out / "sweep.csv").exists()
    r = subprocess.run(_sweep_cmd(out), capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert _table(out / "sweep.csv") == full_table
    assert not (out / "sweep.incomplete.csv").exists()


def test_two_sweeps_at_once_print_no_port_warning(tmp_path):
    """A local cluster's scheduler serves HTTP (its health routes) on a free port, not Dask's
    default 8787: with 8787 taken (by another sweep, here a socket), a sweep printed "UserWarning:
    Port 8787 is already in use" on stderr."""
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", 8787))
            s.listen()
        except OSError:
            pass            # taken already: the case under test
        r = subprocess.run([ANKLEHIP, "sweep", SCENARIO, "--forces", "7,9", "--variant", "full", "--workers", "2",
                            "--engine", "native", "--out", str(tmp_path / "out")],
                           capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "8787" not in r.stderr and "Warning" not in r.stderr, r.stderr


def test_a_failing_point_is_recorded_and_the_others_run(tmp_path):
    """h_push below the hip passes the parameter's range but not the plant's own check at
    initialization: those points are errors in the table, the variant next to it runs."""
    out = tmp_path / "failing"
    r = subprocess.run([ANKLEHIP, "sweep", SCENARIO, "--forces", "7,9", "--variant", "full",
                        "--variant", "low:plant.h_push=0.1", "--workers", "1", "--engine", "native", "--out", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 1
    rows = _table(out / "sweep.csv")
    assert [x["outcome"] for x in rows if x["variant"] == "full"] == ["completed", "completed"]
    bad = [x for x in rows if x["variant"] == "low"]
    assert len(bad) == 2 and all(x["outcome"] == "error" and "h_push" in x["error"] for x in bad)
    assert "h_push" in r.stderr


def test_journal_of_another_sweep_is_refused(tmp_path):
    sc = tmp_path / "mine.toml"
    sc.write_text(find_scenario(SCENARIO).read_text())
    models = Models.load()
    journal = tmp_path / "j.jsonl"
    run_sweep(str(sc), [7.0], VARIANTS[:1], workers=1, engine="native", journal=journal, key=sweep_key(sc, models))
    sc.write_text(sc.read_text().replace("stop_time", "# edited\nstop_time", 1))
    with pytest.raises(JournalMismatch, match="--restart"):
        run_sweep(str(sc), [7.0], VARIANTS[:1], workers=1, engine="native", journal=journal,
                  key=sweep_key(sc, models))
    res = run_sweep(str(sc), [7.0], VARIANTS[:1], workers=1, engine="native", journal=journal,
                    key=sweep_key(sc, models), restart=True)
    assert res.complete and res.resumed == 0


def test_scheduler_without_workers_says_so_and_gives_up_after_the_timeout(tmp_path):
    """A scheduler with no worker (issue 33: the sweep waited silently forever): a line says so and
    how to start one, and after --worker-timeout the command ends with the reason."""
    with _scheduler() as (addr, env):
        t0 = time.time()
        r = subprocess.run([ANKLEHIP, "sweep", SCENARIO, "--forces", "7,9", "--scheduler", addr,
                            "--worker-timeout", "2", "--out", str(tmp_path / "out")],
                           capture_output=True, text=True, timeout=120, env=env)
        assert time.time() - t0 < 60
        assert r.returncode == 2, r.stderr
        assert f"the Dask scheduler at {addr} has no worker; waiting up to 2 s" in r.stderr, r.stderr
        assert f"no Dask worker connected to the scheduler at {addr} within 2 s" in r.stderr, r.stderr
        assert "Traceback" not in r.stderr


def test_journal_that_is_not_utf8_is_refused_naming_the_file(tmp_path):
    """Not an "unexpected UnicodeDecodeError" without the file (issue 33); a half-written last line,
    which a killed run may leave, is dropped instead."""
    sc = tmp_path / "mine.toml"
    sc.write_text(find_scenario(SCENARIO).read_text())
    models = Models.load()
    journal = tmp_path / "j.jsonl"
    run_sweep(str(sc), [7.0, 8.0], VARIANTS[:1], workers=1, engine="native", journal=journal,
              key=sweep_key(sc, models))
    good = journal.read_bytes()
    journal.write_bytes(good + b'{"id": "half\xff\xfe')               # the last line: dropped
    res = run_sweep(str(sc), [7.0, 8.0], VARIANTS[:1], workers=1, engine="native", journal=journal,
                    key=sweep_key(sc, models))
    assert res.complete and res.resumed == 2
    lines = good.split(b"\n")
    journal.write_bytes(lines[0] + b"\n\xff\xfe garbage\n" + b"\n".join(lines[1:]))
    with pytest.raises(JournalMismatch, match=r"j\.jsonl: line 2: not UTF-8 text \(byte 0xff\)"):
        run_sweep(str(sc), [7.0, 8.0], VARIANTS[:1], workers=1, engine="native", journal=journal,
                  key=sweep_key(sc, models))
