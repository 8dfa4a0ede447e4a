"""Writing results: atomic files (a reader never sees a half-written one), the output folder's
lock, the file names of a run and the removal of an earlier run's files, the summary JSON."""
from __future__ import annotations

import json
import math
import os
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from fmpy.util import write_csv

try:
    import fcntl
except ImportError:     # Windows
    fcntl = None

from ..errors import InputError


def _umask() -> int:
    old = os.umask(0)
    os.umask(old)
    return old


def _publish(tmp: str, path: Path) -> None:
    """chmod to the usual mode (mkstemp creates 0600), then rename over the target."""
    os.chmod(tmp, 0o666 & ~_umask())
    os.replace(tmp, path)


@contextmanager
def _atomic(path: Path):
    """Yields (fd, temporary path) in the folder of `path`; the temporary file replaces `path` when
    the block succeeds and is removed when it fails, so a reader never sees a half-written file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        yield fd, tmp
        _publish(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def atomic_write_csv(path: Path, data: np.ndarray, columns: list[str] | None = None,
                     native: bool | None = None) -> None:
    """FMPy write_csv layout, written atomically (_atomic). `native` (default: when the native
    engine's library is built and the columns are float64/int32): by anklehip.running.native.write_csv,
    the same bytes (tests/test_native_engine.py) at 1/50 of FMPy's per-cell Python cost."""
    if columns:
        data = data[["time"] + [c for c in columns if c != "time"]]
    if native is None:
        from ..running import native as _native
        native = _native.available() and all(data.dtype[n] in (np.float64, np.int32) for n in data.dtype.names)
    with _atomic(path) as (fd, tmp):
        os.close(fd)
        if native:
            from ..running.native import write_csv as native_write_csv
            native_write_csv(tmp, data)
        else:
            write_csv(tmp, data)


def atomic_write_text(path: Path, text: str) -> None:
    with _atomic(path) as (fd, tmp):
        with os.fdopen(fd, "w") as f:
            f.write(text)


def check_output_folder(path: str | os.PathLike, option: str) -> Path:
    """An output folder that exists or can be created: the nearest existing ancestor is a
    writable folder; else an InputError naming `option`. Checked before anything runs, so a bad
    output folder costs no run, and it creates nothing."""
    p = Path(path)
    for q in [p, *p.parents]:
        if q.exists():
            if not q.is_dir():
                raise InputError(f"{option} {path}: {q} exists and is not a folder")
            if not os.access(q, os.W_OK | os.X_OK):
                raise InputError(f"{option} {path}: cannot write into {q}")
            break
    return p


def result_paths(out_dir: Path, name: str) -> dict[str, Path]:
    out_dir = Path(out_dir)
    return {"csv": out_dir / f"{name}.csv",
            "incomplete_csv": out_dir / f"{name}.incomplete.csv",
            "summary": out_dir / f"{name}.summary.json"}


FIGURE_SUFFIXES = ("_overview.png", "_fig4_joint_angles.png", "_fig5_first_cycle.png", "_frontal.png",
                   "_fig5_frontal.png", ".gif", "_reference_failed.png")


def clear_previous(out_dir: Path, name: str, keep: tuple[Path, ...] = ()) -> None:
    """Remove the files of an earlier run (data, summary, figures) except `keep`, so that nothing
    stale looks like this run's result. Call it once this run's data file is in place (`keep`):
    a run that fails before it has data to write leaves the previous result alone."""
    extra = [Path(out_dir) / f"{name}{s}" for s in FIGURE_SUFFIXES]
    keep = {Path(k) for k in keep}
    for p in list(result_paths(out_dir, name).values()) + extra:
        if p in keep:
            continue
        try:
            p.unlink()
        except FileNotFoundError:
            pass


LOCK_FILE = ".anklehip.lock"


class OutputBusyError(InputError, RuntimeError):
    """Another process is writing results into the same folder."""


@contextmanager
def output_lock(folder: Path):
    """Hold an exclusive lock on `folder` while a run writes there: fcntl.flock on
    `folder/.anklehip.lock` (which holds the owner's pid; the kernel releases the lock when the
    process ends, even on a crash). Raises OutputBusyError at once when another process holds it,
    so two runs never mix their files in one folder. Creates the folder. No lock where fcntl does
    not exist (Windows)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    if fcntl is None:
        yield
        return
    fd = os.open(folder / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            # the holder writes its pid right after taking the lock: give it a moment to do so
            pid = ""
            for _ in range(50):
                pid = os.pread(fd, 32, 0).decode(errors="replace").strip()
                if pid.isdigit():
                    break
                time.sleep(0.01)
            who = f"(pid {pid}) " if pid.isdigit() else ""
            raise OutputBusyError(f"{folder}: another anklehip run {who}is writing into this folder; "
                                  "wait for it to finish or choose another output folder") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        os.close(fd)      # releases the lock



def write_summary_json(path: Path, s: dict[str, Any]) -> None:
    atomic_write_text(path, json.dumps(s, indent=2, default=_json_default) + "\n")


def _json_default(o):
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, Path):
        return str(o)
    if isinstance(o, float) and not math.isfinite(o):
        return None
    raise TypeError(type(o).__name__)
