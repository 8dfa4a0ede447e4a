"""Comparison of a result CSV with a reference CSV, signal by signal.

Per continuous (float) signal two criteria (docs/step-tests.md):

* the FMI cross-check band, computed by FMPy's ``fmpy.util.validate_signal``: the reference is
  resampled on ``num`` uniform points (default: max(1000, number of reference samples); FMPy's
  cross-check default is 1000), widened by a running min/max over ``dx`` samples
  (horizontal tolerance) and by ``dy`` times the signal's range (vertical tolerance; half a unit
  for a constant zero signal, ``dy`` times the value for another constant);
* optionally a minimum band half-height ``band_floor`` (absolute), for nearly constant signals
  whose range-relative band would be ~0;
* optionally a stricter tube: |y(t) - y_ref(t)| <= abs_tol + rel_tol |y_ref(t)| at every result
  sample inside the reference's time span (y_ref interpolated linearly).

A signal whose values are all integers in both files (phase, fault, booleans) is discrete and is
compared exactly instead: every result sample inside the reference's time span (its first and last
sample included) must equal the reference's value at that time; a result sample that falls
between two reference samples may equal either of them. The band's horizontal tolerance and the
tolerances do not apply to it (they would let a phase off by 3 pass near a switch or at the ends).

``SignalResult.outside`` marks the result samples the verdict counts as failing; the plot draws
exactly those, with the band and the tube the verdict used.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..files.text import read_text
from ..errors import InputError


class CompareError(InputError):
    """The files cannot be compared (missing file or column, empty file, bad time column)."""


@dataclass
class SignalResult:
    name: str
    passed: bool
    discrete: bool = False
    n_samples: int = 0
    n_outside: int = 0
    first_outside: float | None = None       # first time outside the band or the tube (or differing)
    max_dev: float = 0.0                      # largest |y - y_ref| (interpolated; discrete: _discrete_deviation)
    max_dev_time: float | None = None
    max_excess: float = 0.0                   # largest distance outside the band
    message: str = ""
    band: tuple[np.ndarray, np.ndarray, np.ndarray] | None = field(default=None, repr=False)  # t_band, lo, hi
    tube: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)  # lo, hi at the result's times
    outside: np.ndarray | None = field(default=None, repr=False)  # result samples that fail (the verdict's)

    def line(self) -> str:
        v = "PASS" if self.passed else "FAIL"
        s = f"[{v}] {self.name:<24} max |dev| {self.max_dev:.4g}"
        if self.max_dev_time is not None:
            s += f" at t={self.max_dev_time:.4f}"
        if not self.passed:
            s += f"; {self.n_outside}/{self.n_samples} samples {'differ' if self.discrete else 'outside'}"
            if self.first_outside is not None:
                s += f", first at t={self.first_outside:.4f}"
        if self.message:
            s += f"; {self.message}"
        return s


@dataclass
class CompareReport:
    """The result of anklehip.compare: a SignalResult per compared signal (verdict, largest
    deviation, failing samples, the band and tube used), notes, the signals' units, and both
    tables (for the figure). ``passed`` when every signal passed."""
    result: str
    reference: str
    signals: list[SignalResult]
    extra_columns: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    units: dict[str, str] = field(default_factory=dict)     # a signal's unit ('' unknown or none)
    t_res: np.ndarray | None = field(default=None, repr=False)
    t_ref: np.ndarray | None = field(default=None, repr=False)
    res: np.ndarray | None = field(default=None, repr=False)
    ref: np.ndarray | None = field(default=None, repr=False)

    @property
    def passed(self) -> bool:
        return all(s.passed for s in self.signals)

    @property
    def failed(self) -> list[SignalResult]:
        return [s for s in self.signals if not s.passed]

    def text(self, verbose: bool = True) -> str:
        lines = [f"compare {self.result} with reference {self.reference}"]
        lines += [f"  note: {n}" for n in self.notes]
        for s in self.signals:
            if verbose or not s.passed:
                lines.append("  " + s.line())
        lines.append(f"  {'PASS' if self.passed else 'FAIL'}: {len(self.failed)} of {len(self.signals)} "
                     f"signals failed")
        return "\n".join(lines)

    def as_dict(self) -> dict[str, Any]:
        return {"result": self.result, "reference": self.reference, "passed": self.passed,
                "n_signals": len(self.signals), "n_failed": len(self.failed),
                "failed": [s.name for s in self.failed], "notes": self.notes,
                "signals": {s.name: {"passed": s.passed, "discrete": s.discrete, "max_dev": s.max_dev,
                                     "max_dev_time": s.max_dev_time, "first_outside": s.first_outside,
                                     "n_outside": s.n_outside, "n_samples": s.n_samples,
                                     "message": s.message} for s in self.signals}}


def read_result_csv(path: str | Path, what: str = "file") -> np.ndarray:
    """A CSV in FMPy's read_csv/write_csv layout (header of quoted names, time first, one number
    per cell) as a structured float array. Missing, unreadable, binary, empty and malformed files
    are a CompareError naming `what`, the file and, for a bad cell, its line and column."""
    path = Path(path)
    if not path.is_file():
        raise CompareError(f"{what} {path}: no such file")
    text = read_text(path, f"{what} {path}", CompareError)
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")   # read_csv's line ends
    if lines[-1] == "":
        lines.pop()
    if not lines or not lines[0].strip():
        raise CompareError(f"{what} {path}: empty file")
    if len(lines) < 2 or not lines[1].strip():
        raise CompareError(f"{what} {path}: no data rows (header only)")
    names = [n.strip().strip('"') for n in lines[0].split(",")]
    if names[0].lower() != "time":
        raise CompareError(f"{what} {path}: the first column must be the time column 'time' "
                           f"(FMI cross-check / FMPy CSV layout), got {names[0]!r}")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup or "" in names:
        raise CompareError(f"{what} {path}: line 1: " + (f"column name(s) {', '.join(map(repr, dup))} appear more "
                                                          "than once" if dup else "a column without a name"))
    body = lines[1:]
    n = len(names)
    if all(line.count(",") == n - 1 and line.strip() for line in body):
        try:    # every line has its cells: parse them all at once (numpy, in C)
            flat = np.array(",".join(body).split(","), dtype=np.float64)
            out = np.empty(len(body), dtype=[(nm, np.float64) for nm in names])
            out.view(np.float64).reshape(len(body), n)[...] = flat.reshape(len(body), n)
            return out
        except ValueError:
            pass    # a cell that is not a number: the loop below names it
    rows = []
    for i, line in enumerate(body, 2):
        cells = line.split(",")
        if not line.strip():
            raise CompareError(f"{what} {path}: not a valid result CSV: line {i}: empty line")
        if len(cells) != len(names):
            raise CompareError(f"{what} {path}: not a valid result CSV: line {i}: {len(cells)} cells, "
                               f"the header has {len(names)} columns")
        try:
            rows.append(tuple(map(float, cells)))
        except ValueError:
            name, cell = next((n, c) for n, c in zip(names, cells) if not _is_number(c))
            raise CompareError(f"{what} {path}: not a valid result CSV: line {i}, column {name!r}: "
                               f"value {cell!r} is not a number") from None
    return np.array(rows, dtype=[(n, np.float64) for n in names])


def _is_number(cell: str) -> bool:
    try:
        float(cell)
        return True
    except ValueError:
        return False


def _time(data: np.ndarray, label: str) -> np.ndarray:
    t = np.asarray(data[data.dtype.names[0]], dtype=float).copy()
    if len(t) and not np.all(np.isfinite(t)):
        raise CompareError(f"{label}: the time column {data.dtype.names[0]!r} has NaN/Inf values")
    if len(t) > 1 and np.any(np.diff(t) < 0):
        k = int(np.argmax(np.diff(t) < 0))
        raise CompareError(f"{label}: time goes backwards at row {k + 2} (t={t[k]:g} -> {t[k + 1]:g})")
    return t


MAX_REPEATS = 1000      # rows at one time stamp a reference may have (events repeat a time once or twice)


def band_times(t_ref: np.ndarray, label: str = "reference") -> tuple[np.ndarray, int]:
    """The reference's time stamps made strictly increasing for FMPy's validate_signal, and how
    many were repeated. validate_signal adds 1e-13 to a repeated time until it is larger, which
    never happens where 1e-13 is below one ULP (t >= 1024 s) and takes forever for a long run of
    repeats: we move each repeat one ULP after the one before instead, so FMPy's loop has nothing to
    do. A time column that does not advance, or a time repeated more than MAX_REPEATS times, is a
    CompareError."""
    t = np.array(t_ref, dtype=float)
    if len(t) > 1 and t[-1] == t[0]:
        raise CompareError(f"{label}: the time column does not advance (t = {t[0]:g} s in all {len(t)} rows): "
                           "nothing to compare over")
    bad = np.diff(t) <= 0
    repeats = int(bad.sum())
    for _ in range(MAX_REPEATS + 1):
        if not bad.any():
            return t, repeats
        i = np.flatnonzero(bad) + 1
        t[i] = np.nextafter(t[i - 1], np.inf)
        bad = np.diff(t) <= 0
    k = int(np.argmax(np.diff(np.asarray(t_ref, float)) <= 0))
    raise CompareError(f"{label}: more than {MAX_REPEATS} rows at one time stamp (from row {k + 2}, "
                       f"t = {t_ref[k]:g} s): not a time series FMPy's band can be built on")


def _is_discrete(*arrays: np.ndarray) -> bool:
    """All finite values are integers of an fmi2Integer's (32-bit) range, e.g. phase or fault; 1e20
    is an integral float, not a discrete signal."""
    for a in arrays:
        a = a[np.isfinite(a)]
        if a.size == 0 or not np.all(a == np.round(a)) or np.max(np.abs(a)) > 2 ** 31:
            return False
    return True


def _discrete_deviation(t: np.ndarray, y: np.ndarray, t_ref: np.ndarray, y_ref: np.ndarray) -> np.ndarray:
    """|y - y_ref| for a discrete signal: at a reference sample's time its value; between two
    reference samples (another time grid) the nearer in value of the two (so a switch between
    them is not a difference, a wrong value is); at a repeated time (an event) either row's value."""
    last = len(t_ref) - 1
    before = y_ref[np.clip(np.searchsorted(t_ref, t, side="right") - 1, 0, last)]
    after = y_ref[np.clip(np.searchsorted(t_ref, t, side="left"), 0, last)]
    return np.minimum(np.abs(y - before), np.abs(y - after))


# A reference sample whose distance from the median is this many times the range of all the other
# samples is taken for a corrupt cell (one 1e30 cell made the band 1e29 high: anything passed).
OUTLIER_RATIO = 1e6


def _isolated_outlier(y: np.ndarray) -> tuple[int, float] | None:
    """(index, ratio) of a single sample that alone makes the signal's range, else None."""
    if len(y) < 3:
        return None
    med = float(np.median(y))
    k = int(np.argmax(np.abs(y - med)))
    off = abs(float(y[k]) - med)
    rest = np.delete(y, k)
    span = float(np.ptp(rest))
    if span > 0:
        return (k, off / span) if off > OUTLIER_RATIO * span else None
    return (k, math.inf) if off > OUTLIER_RATIO * max(1.0, abs(med)) else None


def compare_signal(name: str, t: np.ndarray, y: np.ndarray, t_ref: np.ndarray, y_ref: np.ndarray, *,
                   num: int | None = None, dx: int = 20, dy: float = 0.1, abs_tol: float | None = None,
                   rel_tol: float | None = None, band_floor: float | None = None,
                   require_coverage: bool = True, t_band_ref: np.ndarray | None = None) -> SignalResult:
    """One signal against its reference (the module's docstring says how). `t_band_ref`: the
    reference's times as band_times(t_ref) made them (computed here when not given)."""
    from fmpy.util import validate_signal
    try:
        import scipy.ndimage  # noqa: F401  (validate_signal needs scipy)
    except ImportError:
        raise CompareError("fmpy.util.validate_signal needs SciPy: `.venv/bin/python -m pip install scipy`") from None

    y = np.asarray(y, float)
    y_ref = np.asarray(y_ref, float)
    r = SignalResult(name=name, passed=True)
    if len(t_ref) < 2:
        r.passed, r.message = False, "reference has fewer than 2 samples"
        return r
    nan_ref = ~np.isfinite(y_ref)
    if nan_ref.any():
        r.passed = False
        r.message = f"reference has NaN/Inf at t={t_ref[np.argmax(nan_ref)]:.6g}"
        return r
    spike = _isolated_outlier(y_ref)
    if spike is not None:
        k, ratio = spike
        r.passed = False
        r.message = (f"reference has an isolated value {y_ref[k]:.6g} at t={t_ref[k]:.6g} s, "
                     + (f"{ratio:.3g} times the range of its other samples" if math.isfinite(ratio) else
                        "where every other sample is the same")
                     + ": a corrupt cell? (the band's height is dy times the signal's range, so it would let "
                       "anything pass)")
        return r
    inside = (t >= t_ref[0]) & (t <= t_ref[-1])
    r.n_samples = int(inside.sum())
    msgs = []
    nan = ~np.isfinite(y) & inside
    r.discrete = _is_discrete(y, y_ref)

    if r.discrete:
        # exact comparison at every sample, the first and last included: validate_signal's band
        # would allow dx band samples of time shift and skips the end samples, so a phase or fault
        # flag off by 3 could pass; no tolerance applies either
        dev = _discrete_deviation(t, y, t_ref, y_ref)
        out = inside & ~(dev == 0)            # NaN differs too
        if (out & ~nan).any():
            msgs.append("discrete signal: compared exactly")
    else:
        if num is None:
            # FMPy's cross-check default is 1000 band samples; a finer reference gets one band
            # sample per reference sample, else features shorter than the band spacing fall
            # between band samples and an identical result is reported outside the band
            num = max(1000, len(t_ref))
        # the FMI cross-check band (FMPy's implementation)
        yv = np.where(np.isfinite(y), y, 0.0)
        if t_band_ref is None:
            t_band_ref, _ = band_times(t_ref)
        t_band, y_min, y_max, i_out = validate_signal(t=np.asarray(t, float), y=yv, t_ref=t_band_ref.copy(),
                                                      y_ref=y_ref, num=num, dx=dx, dy=dy)
        i_out = np.asarray(i_out, bool)
        if band_floor:
            # widen the band to at least +-band_floor around the reference (validate_signal's
            # vertical width is dy x the signal's range, which is ~0 for a nearly constant signal
            # such as fz)
            y_band = np.interp(t_band, t_ref, y_ref)
            y_min = np.minimum(y_min, y_band - band_floor)
            y_max = np.maximum(y_max, y_band + band_floor)
        r.band = (t_band, y_min, y_max)
        lo = np.interp(t, t_band, y_min)
        hi = np.interp(t, t_band, y_max)
        if band_floor:
            i_out = ((yv < lo) | (yv > hi)) & (t > t_band[0]) & (t < t_band[-1])
        band_ok = not i_out.any()
        exc = np.where(inside & np.isfinite(y), np.maximum(lo - y, y - hi), 0.0)
        r.max_excess = float(max(0.0, exc.max())) if len(exc) else 0.0
        if not band_ok:
            msgs.append(f"outside the band by up to {r.max_excess:.4g}")
        out = i_out | nan

        # deviation from the (linearly interpolated) reference, and the optional tube around it
        yr_at = np.interp(t, t_ref, y_ref)
        dev = np.abs(y - yr_at)
        if abs_tol is not None or rel_tol is not None:
            lim = (abs_tol or 0.0) + (rel_tol or 0.0) * np.abs(yr_at)
            r.tube = (yr_at - lim, yr_at + lim)
            tube_out = inside & ~(dev <= lim)
            if tube_out.any():
                k = int(np.argmax(tube_out))
                msgs.append(f"outside the tube (abs {abs_tol or 0:g}, rel {rel_tol or 0:g}) from t={t[k]:.6g}")
            out |= tube_out

    dev_in = np.where(inside, dev, 0.0)
    if inside.any():
        if nan.any():
            k = int(np.argmax(nan))
            r.max_dev, r.max_dev_time = math.inf, float(t[k])
            msgs.append(f"NaN/Inf in the result at t={t[k]:.6g}")
        else:
            k = int(np.argmax(dev_in))
            r.max_dev, r.max_dev_time = float(dev_in[k]), float(t[k])
    r.outside = out
    r.n_outside = int(out.sum())
    if out.any():
        r.first_outside = float(t[int(np.argmax(out))])
    if require_coverage:
        tol = 1e-9 * max(1.0, abs(t_ref[-1]))
        if len(t) == 0 or t[0] > t_ref[0] + tol or t[-1] < t_ref[-1] - tol:
            span = f"{t[0]:.6g}..{t[-1]:.6g}" if len(t) else "nothing"
            msgs.append(f"result covers {span}, reference {t_ref[0]:.6g}..{t_ref[-1]:.6g}")
            r.passed = False
            if r.first_outside is None and len(t):
                r.first_outside = float(min(t[-1], t_ref[-1]))
    r.passed = r.passed and not out.any()
    r.message = "; ".join(msgs)
    return r


def compare(result: np.ndarray | str | Path, reference: np.ndarray | str | Path, *,
            columns: list[str] | None = None, num: int | None = None, dx: int = 20, dy: float = 0.1,
            abs_tol: float | None = None, rel_tol: float | None = None, band_floor: float | None = None,
            tolerances: dict[str, dict[str, float]] | None = None,
            t_start: float | None = None, t_stop: float | None = None,
            require_coverage: bool = True, result_label: str | None = None,
            reference_label: str | None = None, units: dict[str, str] | None = None,
            progress: bool | None = False) -> CompareReport:
    """Compare every reference column (or ``columns``) of ``result`` with ``reference``.

    ``result`` and ``reference``: CSV files (FMPy's layout, time first), structured arrays, or a
    result of anklehip.run. Raises CompareError when a compared column is missing in either file,
    or when a file is empty or has a bad time column. ``tolerances`` may override
    abs_tol/rel_tol/dy/band_floor per signal. ``band_floor`` widens the band to at least
    +-band_floor around the reference. ``units``: the signals' units for the report's figure
    (default: those of the package's FMUs' variables of the same names, and the result's own).
    ``progress``: a bar on stderr over reading and the signals (None: on a terminal).
    """
    _check_options(dict(dy=dy, abs_tol=abs_tol, rel_tol=rel_tol, band_floor=band_floor))
    for name, tol in (tolerances or {}).items():
        _check_options(tol, f"{name}.")
    if isinstance(dx, bool) or not isinstance(dx, (int, np.integer)) or dx < 1:
        raise CompareError(f"dx: must be an integer >= 1, got {dx!r}")
    if num is not None and (isinstance(num, bool) or not isinstance(num, (int, np.integer)) or num < 2):
        raise CompareError(f"num: must be an integer >= 2, got {num!r}")
    for k, v in (("t_start", t_start), ("t_stop", t_stop)):
        if v is not None and not math.isfinite(v):
            raise CompareError(f"{k}: must be finite, got {v!r}")
    if hasattr(result, "signals") and isinstance(getattr(result, "signals"), np.ndarray):   # anklehip.run's result
        units = {**getattr(result, "units", {}), **(units or {})}
        result_label = result_label or f"{result.scenario.name} (this run)"
        result = result.signals
    res_label = result_label or (str(result) if not isinstance(result, np.ndarray) else "result")
    ref_label = reference_label or (str(reference) if not isinstance(reference, np.ndarray) else "reference")
    bar = _bar(progress, "compare")
    try:
        return _compare(result, reference, res_label, ref_label, bar, columns=columns, num=num, dx=dx, dy=dy,
                        abs_tol=abs_tol, rel_tol=rel_tol, band_floor=band_floor, tolerances=tolerances,
                        t_start=t_start, t_stop=t_stop, require_coverage=require_coverage, units=units)
    finally:
        if bar is not None:
            bar.close()


def _bar(progress: bool | None, desc: str):
    """A tqdm bar on stderr (None: only on a terminal), or None."""
    if progress is False:
        return None
    from tqdm import tqdm
    return tqdm(total=2, desc=desc, unit="step", leave=False, disable=None if progress is None else False,
                bar_format="{desc}: {n}/{total} {postfix} [{elapsed}]")


def _step(bar, what: str, add_total: int = 0) -> None:
    if bar is not None:
        if add_total:
            bar.total += add_total
        bar.set_postfix_str(what, refresh=False)
        bar.update(1)


def _compare(result, reference, res_label: str, ref_label: str, bar, *, columns, num, dx, dy, abs_tol, rel_tol,
             band_floor, tolerances, t_start, t_stop, require_coverage, units) -> CompareReport:
    if bar is not None:
        bar.set_postfix_str(f"reading {res_label}")
    res = read_result_csv(result, "result") if not isinstance(result, np.ndarray) else result
    _step(bar, f"reading {ref_label}")
    ref = read_result_csv(reference, "reference") if not isinstance(reference, np.ndarray) else reference
    _step(bar, "")
    if len(res) == 0:
        raise CompareError(f"result {res_label}: no data rows")
    if len(ref) == 0:
        raise CompareError(f"reference {ref_label}: no data rows")
    t_res = _time(res, f"result {res_label}")
    t_ref = _time(ref, f"reference {ref_label}")
    res_cols = list(res.dtype.names[1:])
    ref_cols = list(ref.dtype.names[1:])
    notes = []
    if columns is None:
        columns = ref_cols
    else:
        miss_ref = [c for c in columns if c not in ref_cols]
        if miss_ref:
            raise CompareError(f"reference {ref_label}: missing column(s) {', '.join(miss_ref)} "
                               f"(it has: {', '.join(ref_cols)})")
    missing = [c for c in columns if c not in res_cols]
    if missing:
        raise CompareError(f"result {res_label}: missing column(s) {', '.join(missing)} that the reference "
                           f"{ref_label} has")
    extra = [c for c in res_cols if c not in columns]
    if extra and columns is ref_cols:
        notes.append(f"{len(extra)} result column(s) not in the reference, not compared: {', '.join(extra[:8])}"
                     + (" ..." if len(extra) > 8 else ""))
    unknown_tol = [c for c in (tolerances or {}) if c not in columns]
    if unknown_tol:
        raise CompareError(f"tolerances given for signal(s) that are not compared: {', '.join(unknown_tol)} "
                           f"(compared: {', '.join(columns)})")
    if t_start is not None or t_stop is not None:
        a = -math.inf if t_start is None else t_start
        b = math.inf if t_stop is None else t_stop
        mr, mf = (t_res >= a) & (t_res <= b), (t_ref >= a) & (t_ref <= b)
        res, t_res, ref, t_ref = res[mr], t_res[mr], ref[mf], t_ref[mf]
        if len(t_ref) < 2:
            raise CompareError(f"reference {ref_label}: fewer than 2 samples in the window t_start..t_stop = "
                               f"{a:g}..{b:g}")
    t_band_ref, repeats = band_times(t_ref, f"reference {ref_label}")
    if repeats:
        notes.append(f"the reference repeats {repeats} time stamp(s) (events); for the band each repeat is "
                     "taken one ULP after the row before")
    if bar is not None:
        bar.total += len(columns)
    signals = []
    for c in columns:
        if bar is not None:
            bar.set_postfix_str(c)
        tol = (tolerances or {}).get(c, {})
        if res[c].ndim > 1 or ref[c].ndim > 1:
            raise CompareError(f"column {c}: array-valued columns are not supported")
        with np.errstate(invalid="ignore", over="ignore"):   # values near 1.8e308: an infinite band or deviation
            signals.append(compare_signal(c, t_res, res[c], t_ref, ref[c], num=num, dx=dx,
                                          dy=tol.get("dy", dy), abs_tol=tol.get("abs_tol", abs_tol),
                                          rel_tol=tol.get("rel_tol", rel_tol),
                                          band_floor=tol.get("band_floor", band_floor),
                                          require_coverage=require_coverage, t_band_ref=t_band_ref))
        if bar is not None:
            bar.update(1)
    if units is None or any(c not in units for c in columns):
        from ..files.info import signal_units
        units = {**signal_units(), **(units or {})}
    return CompareReport(result=res_label, reference=ref_label, signals=signals, extra_columns=extra,
                         notes=notes, t_res=t_res, t_ref=t_ref, res=res, ref=ref,
                         units={c: units.get(c, "") for c in columns})


def _check_options(opts: dict[str, Any], prefix: str = "") -> None:
    """Tolerances and band widths are finite numbers >= 0 (None: not given); NaN would fail every
    signal, a negative value every sample."""
    for k, v in opts.items():
        if v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not (
                math.isfinite(v) and v >= 0):
            raise CompareError(f"{prefix}{k}: must be a finite number >= 0, got {v!r}")


def comparison_figure(report: CompareReport, signals: list[str] | None = None):
    """A matplotlib Figure, one panel per signal (default: the failed signals, or every compared
    signal when all passed): reference, the band and the tube that the verdict used, the result,
    and in red exactly the result samples that the verdict counts as failing. Each panel's header
    is the signal's verdict line (wrapped to the panel's width), its y axis the signal's unit."""
    import textwrap

    from matplotlib.figure import Figure
    sig = {s.name: s for s in report.signals}
    names = signals or [s.name for s in (report.failed or report.signals)]
    fig = Figure(figsize=(9, 2.6 * len(names) + 1.0), layout="constrained")
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    for ax, name in zip(axes, names):
        s = sig[name]
        step = "steps-post" if s.discrete else "default"
        if s.band is not None:
            ax.fill_between(s.band[0], s.band[1], s.band[2], color="tab:blue", alpha=0.18, lw=0, label="band")
        if s.tube is not None:
            ax.fill_between(report.t_res, s.tube[0], s.tube[1], color="tab:orange", alpha=0.35, lw=0,
                            label="tube (abs/rel tol)")
        ax.plot(report.t_ref, report.ref[name], color="tab:blue", lw=1, drawstyle=step,
                label="reference" + (" (discrete: exact)" if s.discrete else ""))
        y = np.asarray(report.res[name], float)
        ax.plot(report.t_res, y, color="k", lw=0.8, drawstyle=step, label="result")
        if s.outside is not None and s.outside.any():
            ax.plot(report.t_res[s.outside], y[s.outside], ".", color="tab:red", ms=4,
                    label=f"failing samples ({s.n_outside})")
        if s.first_outside is not None:
            ax.axvline(s.first_outside, color="tab:red", lw=0.8, ls=":", label=f"first failure t={s.first_outside:.4g}")
        unit = report.units.get(name, "")
        ax.set_ylabel(f"{name} [{unit}]" if unit else name, fontsize=8)
        ax.set_title("\n".join(textwrap.wrap(s.line(), 115)), fontsize=8, loc="left")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    axes[-1].set_xlabel("time [s]")
    head = (f"{'PASS' if report.passed else 'FAIL'}: {report.result} vs {report.reference} "
            f"({len(report.failed)} of {len(report.signals)} signals failed)")
    fig.suptitle("\n".join(textwrap.wrap(head, 110)), fontsize=9)
    return fig


def plot_comparison(report: CompareReport, out: str | Path, signals: list[str] | None = None) -> Path:
    """Write comparison_figure(report, signals) as a PNG (also when every signal passed)."""
    fig = comparison_figure(report, signals)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    return out


def plot_failed(report: CompareReport, out: str | Path, signals: list[str] | None = None) -> Path | None:
    """plot_comparison of the failed signals (or ``signals``); None, nothing written, if none failed."""
    names = signals or [s.name for s in report.failed]
    return plot_comparison(report, out, names) if names else None
