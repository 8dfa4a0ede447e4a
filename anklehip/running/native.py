"""The native closed-loop engine: libanklehip_closed_loop (fmu/closed_loop/closed_loop.cpp) through
ctypes.

`anklehip.running.master.simulate(..., engine="native")` prepares the run exactly as for FMPy (layout,
result arrays, push columns, parameters) and hands the loop to the library, which loads both FMUs'
binaries with dlopen and makes the same FMI calls in the same order: the result rows are
bit-identical (tests/test_native_engine.py). `write_csv` writes a result table in FMPy's
write_csv layout, byte for byte, about 50 times faster.

The library is looked up as $ANKLEHIP_NATIVE_LIB, else in the checkout's <build>/fmu/closed_loop/,
else in the installed package's data/lib/ (anklehip.files.paths.native_library).
"""
from __future__ import annotations

import ctypes
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..files.paths import NATIVE_LIBRARY as LIBRARY, MissingFileError, native_library

_u32p = ctypes.POINTER(ctypes.c_uint32)
_i32p = ctypes.POINTER(ctypes.c_int32)
_f64p = ctypes.POINTER(ctypes.c_double)


class _Fmu(ctypes.Structure):
    _fields_ = [("unzipdir", ctypes.c_char_p), ("model_identifier", ctypes.c_char_p),
                ("guid", ctypes.c_char_p), ("instance_name", ctypes.c_char_p),
                ("n_params", ctypes.c_int32), ("param_vr", _u32p), ("param_kind", ctypes.c_char_p),
                ("param_real", _f64p), ("param_int", _i32p), ("param_str", ctypes.POINTER(ctypes.c_char_p))]


_LAYOUT_ARRAYS = ("p_real", "p_int", "p_bool", "c_in", "c_feed", "c_other", "c_int", "c_bool", "p_in")


class _Layout(ctypes.Structure):
    _fields_ = ([(n, _u32p) for n in _LAYOUT_ARRAYS] + [("n_" + n, ctypes.c_int32) for n in _LAYOUT_ARRAYS]
                + [(n, ctypes.c_int32) for n in ("off_feed", "off_cother", "off_pbool", "off_cint", "off_cbool",
                                                 "n_real", "n_int")])


class _Run(ctypes.Structure):
    _fields_ = [("controller", _Fmu), ("plant", _Fmu), ("layout", _Layout),
                ("t0", ctypes.c_double), ("h", ctypes.c_double), ("stop_time", ctypes.c_double),
                ("n_steps", ctypes.c_int64), ("R", _f64p), ("I", _i32p),
                ("c_init_real", _f64p), ("c_init_int", _i32p), ("log_errors", ctypes.c_int32),
                ("setup_failed", ctypes.c_int32), ("failed_at", ctypes.c_int64),
                ("status_ctrl", ctypes.c_int32), ("status_plant", ctypes.c_int32), ("status_io", ctypes.c_int32),
                ("plant_terminated", ctypes.c_int32), ("plant_last_time", ctypes.c_double),
                ("wall_seconds", ctypes.c_double), ("message", ctypes.c_char * 1024)]


_lib = None


def library_path() -> Path | None:
    return native_library()


def available() -> bool:
    p = library_path()
    return sys.platform.startswith("linux") and p is not None and p.is_file()


def default_engine() -> str:
    """The engine for many runs (sweeps): native when the library is built, else FMPy."""
    return "native" if available() else "fmpy"


def _load():
    global _lib
    if _lib is None:
        p = library_path()
        if p is None or not p.is_file():
            raise MissingFileError(f"{p or LIBRARY} not found: the native engine is built by `bash scripts/setup.sh` "
                                   "and shipped in the Linux wheel (or point ANKLEHIP_NATIVE_LIB at "
                                   "libanklehip_closed_loop.so)")
        lib = ctypes.CDLL(str(p))
        lib.ahn_run_closed_loop.argtypes = [ctypes.POINTER(_Run)]
        lib.ahn_run_closed_loop.restype = ctypes.c_int
        lib.ahn_write_csv.argtypes = [ctypes.c_char_p, ctypes.c_int32, ctypes.POINTER(ctypes.c_char_p),
                                      ctypes.c_char_p, ctypes.POINTER(ctypes.c_void_p),
                                      ctypes.POINTER(ctypes.c_int64), ctypes.c_int64, ctypes.c_char_p,
                                      ctypes.c_int32]
        lib.ahn_write_csv.restype = ctypes.c_int
        _lib = lib
    return _lib


@dataclass
class LoopEnd:
    """What the loop leaves for master.simulate to decide the outcome from."""
    failed_at: int                 # step whose calls failed, -1 when all ran
    status_ctrl: int
    status_plant: int
    status_io: int
    plant_terminated: bool
    plant_last_time: float | None
    c_init: dict[str, Any]
    wall: float


def _vrs(vars_) -> ctypes.Array:
    return (ctypes.c_uint32 * max(1, len(vars_)))(*[v.vr for v in vars_])


def _fmu(info, instance_name: str, parameters: dict[str, Any], keep: list) -> _Fmu:
    """The C description of one FMU and its parameter values (in the caller's order, as
    anklehip.running.fmu.Slave.set_values sets them); `keep` holds the buffers alive."""
    n = len(parameters)
    vr = (ctypes.c_uint32 * max(1, n))()
    kind = bytearray()
    real = (ctypes.c_double * max(1, n))()
    ints = (ctypes.c_int32 * max(1, n))()
    strs = (ctypes.c_char_p * max(1, n))()
    for i, (name, val) in enumerate(parameters.items()):
        v = info.var(name)
        vr[i] = v.vr
        if v.type == "Real":
            kind += b"R"
            real[i] = float(val)
        elif v.type in ("Integer", "Enumeration"):
            kind += b"I"
            ints[i] = int(val)
        elif v.type == "Boolean":
            kind += b"B"
            ints[i] = 1 if bool(val) else 0
        else:
            kind += b"S"
            strs[i] = str(val).encode()
    kind = bytes(kind) or b"\0"
    enc = [str(info.unzipdir).encode(), info.model_identifier.encode(), info.md.guid.encode(),
           instance_name.encode(), kind]
    keep += [vr, real, ints, strs] + enc
    return _Fmu(enc[0], enc[1], enc[2], enc[3], n, vr, enc[4], real, ints, strs)


def run_loop(models, L, R: np.ndarray, I: np.ndarray, t0: float, h: float, stop_time: float, n_steps: int,
             c_over: dict[str, Any], p_over: dict[str, Any], log_errors: bool = True) -> LoopEnd:
    """Instantiate both FMUs, run the closed loop over the rows of R and I (C-contiguous, the push
    columns filled) and close the record; raises FMUError when loading or initialization fails."""
    from .fmu import FMUError
    lib = _load()
    assert R.flags.c_contiguous and I.flags.c_contiguous and R.dtype == np.float64 and I.dtype == np.int32
    keep: list = []
    layout = _Layout()
    for name in _LAYOUT_ARRAYS:
        vars_ = getattr(L, name)
        arr = _vrs(vars_)
        keep.append(arr)
        setattr(layout, name, ctypes.cast(arr, _u32p))
        setattr(layout, "n_" + name, len(vars_))
    layout.off_feed, layout.off_cother = L.off_feed, L.off_cother
    layout.off_pbool, layout.off_cint, layout.off_cbool = L.off_pbool, L.off_cint, L.off_cbool
    layout.n_real, layout.n_int = R.shape[1], I.shape[1]
    n_cr, n_ci = len(L.c_feed) + len(L.c_other), len(L.c_int) + len(L.c_bool)
    c_real = np.zeros(max(1, n_cr))
    c_int = np.zeros(max(1, n_ci), dtype=np.int32)
    run = _Run(controller=_fmu(models.controller, "controller", c_over, keep),
               plant=_fmu(models.plant, "plant", p_over, keep), layout=layout,
               t0=t0, h=h, stop_time=stop_time, n_steps=n_steps,
               R=R.ctypes.data_as(_f64p), I=I.ctypes.data_as(_i32p),
               c_init_real=c_real.ctypes.data_as(_f64p), c_init_int=c_int.ctypes.data_as(_i32p),
               log_errors=1 if log_errors else 0)
    lib.ahn_run_closed_loop(ctypes.byref(run))
    if run.setup_failed:
        raise FMUError(f"native engine: {run.message.decode(errors='replace')}")
    names = [v.name for v in L.c_feed + L.c_other]
    c_init: dict[str, Any] = {n: float(c_real[i]) for i, n in enumerate(names)}
    c_init.update({v.name: int(c_int[i]) for i, v in enumerate(L.c_int)})
    c_init.update({v.name: bool(c_int[len(L.c_int) + i]) for i, v in enumerate(L.c_bool)})
    last = run.plant_last_time
    return LoopEnd(failed_at=run.failed_at, status_ctrl=run.status_ctrl, status_plant=run.status_plant,
                   status_io=run.status_io, plant_terminated=run.plant_terminated == 1,
                   plant_last_time=None if last != last else float(last), c_init=c_init,
                   wall=run.wall_seconds)


def write_csv(path, data: np.ndarray) -> None:
    """`data` (a structured array of float64 and int32 columns) as CSV in FMPy's write_csv layout."""
    lib = _load()
    names = data.dtype.names
    kinds, cols, strides, keep = bytearray(), (ctypes.c_void_p * len(names))(), (ctypes.c_int64 * len(names))(), []
    for i, n in enumerate(names):
        col = data[n]
        if col.dtype == np.float64:
            kinds += b"f"
        elif col.dtype == np.int32:
            kinds += b"i"
        else:
            raise TypeError(f"column {n!r}: {col.dtype} (only float64 and int32 columns)")
        keep.append(col)
        cols[i] = col.ctypes.data
        strides[i] = col.strides[0] if col.ndim else 0
    enc = [n.encode() for n in names]
    cnames = (ctypes.c_char_p * len(names))(*enc)
    err = ctypes.create_string_buffer(512)
    rc = lib.ahn_write_csv(str(path).encode(), len(names), cnames, bytes(kinds), cols, strides, len(data), err, 512)
    if rc:      # errno, err its strerror (a full disk: ENOSPC)
        raise OSError(rc, err.value.decode(errors="replace"), str(path))
