"""Many independent closed-loop runs ("points") on Dask, the same code path from a laptop to a
cluster: a local cluster by default, any running Dask scheduler by address (`scheduler`, else
$DASK_SCHEDULER_ADDRESS). Every finished point is appended to a journal (JSON lines) at once, so:

* a point that raises is recorded with its error (outcome "error"), the others go on;
* Ctrl-C stops cleanly: the workers ignore SIGINT, the futures are cancelled, the finished points
  stay in the journal (and in the caller's table), and no Dask shutdown noise is printed;
* a rerun with the same journal skips the points already done (a killed run loses at most the
  points in flight; a half-written last line is ignored).

Progress is a bar on a terminal and a line per tenth of the points (or 30 s) otherwise, so that it
shows in logs and CI too. The function that runs a point must be importable by the workers (a
module-level function of this package) and return a dict of plain values.
"""
from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import os
import signal
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable
from ..errors import InputError

JOURNAL_FORMAT = "anklehip-points"


class JournalMismatch(InputError):
    """The journal in the output folder belongs to other points (another definition or other FMUs)."""


@dataclass
class Outcome:
    rows: list[dict[str, Any]]          # one per finished point, in the order of the specs
    total: int
    resumed: int = 0                    # rows taken over from the journal
    interrupted: bool = False
    errors: int = 0
    wall: float = 0.0
    missing: list[str] = field(default_factory=list)   # ids of the points not done (interrupted)

    @property
    def complete(self) -> bool:
        return not self.interrupted and not self.missing


def call_point(fn: Callable[[dict], dict], spec: dict) -> dict:
    """Run one point; an exception becomes the point's recorded error (never fatal to the sweep)."""
    try:
        row = dict(fn(spec))
    except Exception as e:          # noqa: BLE001 - recorded, the sweep goes on
        row = {"outcome": "error", "error": f"{type(e).__name__}: {e}"}
    row["id"] = spec["id"]
    return row


# ---------------------------------------------------------------------------------------------
# journal

def read_journal(path: Path, key: str) -> dict[str, dict]:
    """The rows already done, by id; {} when there is no journal. Raises JournalMismatch when the
    journal was written for another key."""
    path = Path(path)
    if not path.is_file():
        return {}
    rows: dict[str, dict] = {}
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise JournalMismatch(f"{path}: cannot read the points journal: {e.strerror}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw[:e.start].count(b"\n") + 1
        # the last line a killed run may leave half-written; any other line: not our journal
        if line == 1 or b"\n" in raw[e.start:].rstrip(b"\n"):
            raise JournalMismatch(f"{path}: line {line}: not UTF-8 text (byte 0x{raw[e.start]:02x}): not a points "
                                  "journal anklehip wrote; use another output folder, or --restart to discard "
                                  "it") from None
        text = raw[:raw.rfind(b"\n", 0, e.start) + 1].decode("utf-8", errors="replace")
    lines = text.split("\n")
    if not lines or not lines[0].strip():
        return {}
    try:
        head = json.loads(lines[0])
    except json.JSONDecodeError:
        raise JournalMismatch(f"{path}: not a points journal (first line is not JSON)") from None
    if head.get("journal") != JOURNAL_FORMAT:
        raise JournalMismatch(f"{path}: not a points journal")
    if head.get("key") != key:
        raise JournalMismatch(f"{path} holds the points of another definition or of other FMUs "
                              f"({head.get('what', '?')}); use another output folder, or --restart to discard it")
    for line in lines[1:]:
        if not line.strip():
            continue
        try:
            r = json.loads(line)
        except json.JSONDecodeError:     # the half-written last line of a killed run
            continue
        if isinstance(r, dict) and "id" in r:
            rows[r["id"]] = r
    return rows


class _Journal:
    def __init__(self, path: Path | None, key: str, what: str):
        self.f = None
        if path is None:
            return
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        new = not path.is_file() or path.stat().st_size == 0
        torn = not new and not path.read_bytes().endswith(b"\n")   # a killed run's half-written last line
        self.f = open(path, "a", encoding="utf-8")
        if torn:
            self.f.write("\n")
        if new:
            self._write({"journal": JOURNAL_FORMAT, "version": 1, "key": key, "what": what})

    def _write(self, obj: dict) -> None:
        try:
            self.f.write(json.dumps(obj, allow_nan=True) + "\n")
            self.f.flush()
            os.fsync(self.f.fileno())
        except OSError as e:        # a full disk: name the journal
            from ..files.output import named
            raise named(e, self.f.name) from e

    def add(self, row: dict) -> None:
        if self.f is not None:
            self._write(row)

    def close(self) -> None:
        if self.f is not None:
            self.f.close()


# ---------------------------------------------------------------------------------------------
# progress

class _Progress:
    """A bar on a terminal; otherwise a line on stderr per tenth of the points or per 30 s; nothing
    with show=False."""

    def __init__(self, total: int, done: int, label: str, stream=None, show: bool = True):
        self.total, self.done, self.label = total, done, label
        self.stream = stream or sys.stderr
        self.show = show
        self.t0 = self.t_last = time.perf_counter()
        self.start_done = done
        self.bar = None
        self.next_line = done + max(1, total // 10)
        if not show:
            pass
        elif self.stream.isatty():
            from tqdm import tqdm
            self.bar = tqdm(total=total, initial=done, unit="pt", desc=label, leave=False, file=self.stream)
        elif total:
            print(f"{label}: {total} points" + (f", {done} already done (resumed)" if done else ""),
                  file=self.stream, flush=True)

    def update(self) -> None:
        self.done += 1
        if self.bar is not None:
            self.bar.update(1)
            return
        if not self.show:
            return
        now = time.perf_counter()
        if self.done >= self.next_line or now - self.t_last >= 30.0 or self.done == self.total:
            rate = (self.done - self.start_done) / max(now - self.t0, 1e-9) * 60.0
            left = (self.total - self.done) / rate if rate > 0 else float("nan")
            print(f"{self.label}: {self.done}/{self.total} points ({100 * self.done / self.total:.0f} %), "
                  f"{rate:.1f} per min, about {left:.1f} min left", file=self.stream, flush=True)
            self.t_last = now
            self.next_line = self.done + max(1, self.total // 10)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


# ---------------------------------------------------------------------------------------------
# Dask

# How long a sweep waits for a worker of a scheduler that has none [s] (--worker-timeout).
WORKER_TIMEOUT = 120.0


class NoWorkersError(RuntimeError):
    """The Dask scheduler had no worker within the time allowed."""


def wait_for_a_worker(client, addr: str, timeout: float) -> None:
    """Return once the scheduler has a worker; say on stderr that it has none and wait up to `timeout`
    seconds (a sweep submitted to a scheduler without workers would otherwise wait silently forever)."""
    if client.scheduler_info().get("workers"):
        return
    print(f"the Dask scheduler at {addr} has no worker; waiting up to {timeout:g} s for one "
          f"(start one with `dask worker {addr}`; --worker-timeout sets the wait)", file=sys.stderr, flush=True)
    try:
        client.wait_for_workers(1, timeout=timeout)
    except (TimeoutError, asyncio.TimeoutError, OSError) as e:
        raise NoWorkersError(f"no Dask worker connected to the scheduler at {addr} within {timeout:g} s; start workers "
                             f"with `dask worker {addr}` or wait longer with --worker-timeout") from e

def scheduler_address(scheduler: str | None) -> str | None:
    """The scheduler to use: the argument, else $DASK_SCHEDULER_ADDRESS, else None (a local cluster)."""
    return scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS") or None


@contextlib.contextmanager
def _quiet_dask():
    """Dask's own logging at ERROR, and nothing at all once we shut down after Ctrl-C."""
    names = ("distributed", "distributed.nanny", "distributed.worker", "distributed.scheduler",
             "distributed.core", "distributed.comm", "asyncio", "tornado")
    old = {n: logging.getLogger(n).level for n in names}
    for n in names:
        logging.getLogger(n).setLevel(logging.ERROR)
    try:
        yield
    finally:
        for n, lvl in old.items():
            logging.getLogger(n).setLevel(lvl)


@contextlib.contextmanager
def dask_client(workers: int, scheduler: str | None, worker_timeout: float | None = None):
    """A Client of the scheduler at `scheduler` ($DASK_SCHEDULER_ADDRESS), else of a local cluster of
    `workers` processes that ignore SIGINT (Ctrl-C reaches only this process, which then stops
    them). A scheduler without workers: a line on stderr, then up to `worker_timeout` seconds
    (default WORKER_TIMEOUT) of waiting for one, then NoWorkersError."""
    from dask.distributed import Client, LocalCluster
    addr = scheduler_address(scheduler)
    if addr:
        with Client(addr, timeout="20s") as client:
            wait_for_a_worker(client, addr, WORKER_TIMEOUT if worker_timeout is None else worker_timeout)
            yield client
        return
    # inherited by the worker processes: SIGINT ignored, Dask's logging at CRITICAL (a worker whose
    # task is cancelled at Ctrl-C logs a warning, and on a loaded machine a worker whose heartbeat
    # meets the closing scheduler logs an ERROR with a traceback, after every point is done; a
    # point's own failure reaches this process as its row)
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    old_env = os.environ.get("DASK_LOGGING__DISTRIBUTED")
    os.environ["DASK_LOGGING__DISTRIBUTED"] = "critical"
    try:
        # no dashboard; the scheduler's HTTP server (always on, for its health routes) on a free port:
        # on its default 8787, a second sweep at the same time printed a UserWarning on stderr
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                               scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})
    finally:
        signal.signal(signal.SIGINT, old)
        if old_env is None:
            os.environ.pop("DASK_LOGGING__DISTRIBUTED", None)
        else:
            os.environ["DASK_LOGGING__DISTRIBUTED"] = old_env
    try:
        with Client(cluster) as client:
            yield client
    finally:
        with contextlib.suppress(Exception):
            cluster.close(timeout=10)


def run_points(fn: Callable[[dict], dict], specs: list[dict], *, workers: int = 2, scheduler: str | None = None,
               journal: Path | None = None, key: str = "", what: str = "", label: str = "points",
               restart: bool = False, progress: bool = True,
               worker_timeout: float = WORKER_TIMEOUT) -> Outcome:
    """Run fn(spec) for every spec (each with a unique str "id") and collect the rows.

    workers <= 1 and no scheduler: in this process, one after the other (no Dask cluster).
    `journal`: where finished rows are appended (and read back on a rerun with the same `key`;
    `restart` discards it first). Ctrl-C returns what is done with interrupted=True. `progress`:
    the bar or lines on stderr (False: none). On a scheduler without workers it says so and waits
    `worker_timeout` seconds for one, then raises NoWorkersError."""
    ids = [s["id"] for s in specs]
    if len(set(ids)) != len(ids):
        raise ValueError("run_points: point ids are not unique")
    if journal is not None and restart and Path(journal).exists():
        Path(journal).unlink()
    done = read_journal(journal, key) if journal is not None else {}
    done = {i: r for i, r in done.items() if i in set(ids)}
    todo = [s for s in specs if s["id"] not in done]
    out = Outcome(rows=[], total=len(specs), resumed=len(done))
    j = _Journal(journal, key, what)
    prog = _Progress(len(specs), len(done), label, show=progress)
    t0 = time.perf_counter()
    try:
        with _quiet_dask():
            if workers <= 1 and not scheduler_address(scheduler):
                try:
                    for s in todo:
                        r = call_point(fn, s)
                        done[s["id"]] = r
                        j.add(r)
                        prog.update()
                except KeyboardInterrupt:
                    out.interrupted = True
            else:
                _run_dask(fn, todo, workers, scheduler, done, j, prog, out, worker_timeout)
    finally:
        prog.close()
        j.close()
    out.wall = time.perf_counter() - t0
    out.rows = [done[i] for i in ids if i in done]
    out.missing = [i for i in ids if i not in done]
    out.errors = sum(1 for r in out.rows if r.get("outcome") == "error")
    return out


def _silence_dask() -> None:
    for n in ("distributed", "asyncio", "tornado"):
        logging.getLogger(n).setLevel(logging.CRITICAL + 1)


def _run_dask(fn, todo, workers, scheduler, done, journal, prog, out, worker_timeout=None) -> None:
    from dask.distributed import as_completed
    try:
        with dask_client(workers, scheduler, worker_timeout) as client:
            futures = client.map(call_point, [fn] * len(todo), todo, pure=False)
            try:
                for fut in as_completed(futures):
                    r = fut.result()
                    done[r["id"]] = r
                    journal.add(r)
                    prog.update()
            except KeyboardInterrupt:
                out.interrupted = True
                _silence_dask()
                with contextlib.suppress(Exception):
                    client.cancel(futures)
    except KeyboardInterrupt:          # during the cluster's start or shutdown
        out.interrupted = True
        _silence_dask()
