"""Regenerating the golden files: each scenario with a [reference] table is re-run and its reference
CSV rewritten, and each recorded step-test case re-recorded from the scenario its steptest.toml
names (`anklehip regen-references`, docs/step-tests.md).

A file is rewritten only when its bytes change; ``check`` writes nothing and reports, per file,
whether it would change and the largest difference; ``out`` writes the new files into another
folder (``<out>/reference/``, ``<out>/steptests/<case>/``) and leaves the checkout alone. The files
of an installed package are never written: without ``out`` they go to results/references.
"""
from __future__ import annotations

import filecmp
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError

STATUSES = ("unchanged", "changed", "new", "not written", "failed", "skipped")


@dataclass
class Regenerated:
    """What happened to one golden file or case."""
    name: str              # the scenario or the case
    path: Path | None      # the file or case folder (written, or that would be)
    status: str            # one of STATUSES
    detail: str = ""

    def line(self, check: bool) -> str:
        verb = {"changed": "would change" if check else "rewritten", "new": "would be created" if check else "created",
                "unchanged": "unchanged", "not written": "NOT written", "failed": "FAILED",
                "skipped": "skipped"}[self.status]
        where = f" {self.path}" if self.path is not None else ""
        return f"{self.name}:{where} {verb}" + (f": {self.detail}" if self.detail else "")


def csv_difference(new: np.ndarray, old_path: Path) -> str:
    """How a table differs from a CSV file: the largest absolute difference (its column and time)
    and how many rows differ, or what does not match (columns, rows)."""
    from ..analysis.compare import CompareError, read_result_csv
    try:
        old = read_result_csv(old_path, "old file")
    except CompareError as e:
        return f"the old file does not read as a result CSV ({e})"
    if list(old.dtype.names) != list(new.dtype.names):
        return f"columns {', '.join(old.dtype.names[1:])} -> {', '.join(new.dtype.names[1:])}"
    if len(old) != len(new):
        return f"{len(old)} -> {len(new)} rows"
    best, where, rows = 0.0, "", np.zeros(len(new), bool)
    for c in new.dtype.names:
        d = np.abs(np.asarray(new[c], float) - np.asarray(old[c], float))
        d = np.where(np.isnan(d), np.inf, d)
        rows |= d > 0
        k = int(np.argmax(d))
        if d[k] > best:
            best, where = float(d[k]), f"{c} at t={float(new['time'][k]):.4g} s"
    if best == 0:
        return "the same numbers, other digits"
    return f"largest difference {best:.3g} ({where}), {int(rows.sum())} of {len(new)} rows differ"


def _publish(src: Path, dst: Path) -> None:
    """Copy src over dst atomically."""
    from ..files.output import _atomic
    import os
    with _atomic(dst) as (fd, tmp):
        with os.fdopen(fd, "wb") as f:
            f.write(src.read_bytes())


def _compare_and_publish(name: str, new: Path, dst: Path, check: bool, table: np.ndarray | None) -> Regenerated:
    if not dst.is_file():
        if not check:
            _publish(new, dst)
        return Regenerated(name, dst, "new")
    if filecmp.cmp(new, dst, shallow=False):
        return Regenerated(name, dst, "unchanged")
    detail = csv_difference(table, dst) if table is not None else "the text differs"
    if not check:
        _publish(new, dst)
    return Regenerated(name, dst, "changed", detail)


def _targets(out: str | Path | None) -> tuple[Path | None, str | None]:
    """(the output root or None for the files themselves, a note about where they go)."""
    from ..files.paths import checkout_root
    if out is not None:
        return Path(out), None
    if checkout_root() is None:
        return Path("results") / "references", ("the scenarios come with the installed package, which is not "
                                                "written: the new files go to results/references")
    return None, None


def regenerate(names: list[str] | None = None, *, out: str | Path | None = None, check: bool = False,
               force: bool = False, steptests: bool = True, fmu_dir: str | Path | None = None,
               progress: bool | None = False, report=print) -> int:
    """Re-run the scenarios with a [reference] table (or only `names`) and, unless `names` or
    `steptests=False`, re-record the step-test cases; `report` gets a line per file. Returns the
    exit status: 0 nothing wrong (with `check`: nothing would change), 1 a file would change
    (`check`), a run did not meet its expectations (not written unless `force`) or failed."""
    from ..analysis.summary import check_expect
    from ..files.output import atomic_write_csv, check_output_folder
    from ..files.paths import scenarios_dir
    from ..files.scenario import load_scenario
    from .master import Models, simulate
    from .run import decimate, reference_columns
    root, note = _targets(out)
    if root is not None:
        check_output_folder(root, "--out")
    if note:
        report(f"note: {note}")
    scs = [load_scenario(f) for f in sorted(scenarios_dir().glob("*.toml"))]
    if names:
        import difflib
        known = [s.name for s in scs]
        unknown = [n for n in names if n not in known]
        if unknown:
            near = [m for n in unknown for m in difflib.get_close_matches(n, known, n=2)]
            raise InputError(f"unknown scenario(s): {', '.join(unknown)}"
                             + (f"; did you mean {' or '.join(near)}?" if near else ""))
        scs = [s for s in scs if s.name in names]
    models = {m: Models.load(fmu_dir, plant_model=m[0], controller_model=m[1])
              for m in sorted({(s.plant_model, s.controller_model) for s in scs})}
    items: list[Regenerated] = []
    with tempfile.TemporaryDirectory(prefix="anklehip-regen-") as tmp:
        for sc in scs:
            if sc.reference is None:
                items.append(Regenerated(sc.name, None, "skipped", "no [reference] table"))
                report(items[-1].line(check))
                continue
            res = simulate(sc, models[sc.plant_model, sc.controller_model], progress=progress)
            bad = [c for c in check_expect(res, sc.expect) if not c.ok]
            dst = sc.reference.file if root is None else root / "reference" / sc.reference.file.name
            if bad and not force:
                items.append(Regenerated(sc.name, dst, "not written", "expected outcome not met: "
                                         + "; ".join(f"{c.name}: {c.detail}" for c in bad)))
            else:
                cols = reference_columns(sc, res.data)
                table = decimate(res.data, res.step, sc.reference.interval)[["time"] + [c for c in cols if c != "time"]]
                new = Path(tmp) / f"{sc.name}.csv"
                atomic_write_csv(new, table)
                items.append(_compare_and_publish(sc.name, new, dst, check, table))
                items[-1].detail += f"{'; ' if items[-1].detail else ''}{len(table)} rows, {len(cols)} columns, " \
                                    f"{res.message or res.outcome}"
            report(items[-1].line(check))
        if steptests and not names:
            for it in _steptests(root, check, fmu_dir, Path(tmp)):
                items.append(it)
                report(it.line(check))
    wrong = [i for i in items if i.status in ("not written", "failed")]
    changed = [i for i in items if i.status in ("changed", "new")]
    verb = "would change" if check else "written"
    report(f"{len(changed)} {verb}, {sum(i.status == 'unchanged' for i in items)} unchanged"
           + (f", {len(wrong)} not written or failed" if wrong else ""))
    return 1 if wrong or (check and changed) else 0


def _steptests(root: Path | None, check: bool, fmu_dir, tmp: Path) -> list[Regenerated]:
    """Re-record every step-test case from the scenario named in its steptest.toml [source]."""
    from ..files.paths import find_scenario, steptests_dir
    from ..files.scenario import load_scenario
    from .master import Models, simulate
    from .steptest import StepTestError, case_files, read_meta, record_case
    from ..analysis.compare import read_result_csv
    out: list[Regenerated] = []
    for case in sorted(p for p in steptests_dir().glob("*") if p.is_dir()):
        name = f"step-test case {case.name}"
        try:
            src = read_meta(case / "steptest.toml").get("source", {})
            if "scenario" not in src or "stop_time" not in src:
                out.append(Regenerated(name, case, "skipped", "no [source] scenario/stop_time in steptest.toml"))
                continue
            sc = load_scenario(find_scenario(src["scenario"]))
            res = simulate(sc, Models.for_scenario(sc, fmu_dir), stop_time=float(src["stop_time"]),
                           progress=False)
        except (StepTestError, InputError) as e:
            out.append(Regenerated(name, case, "failed", str(e)))
            continue
        if res.outcome in ("error", "interrupted"):
            out.append(Regenerated(name, case, "failed", f"the run failed: {res.message}"))
            continue
        new_dir = tmp / "steptests" / case.name
        new = record_case(res, new_dir, res.controller_overrides, source=sc.name)
        dst_dir = case if root is None else root / "steptests" / case.name
        parts = []
        for key, f in new.items():
            dst = case_files(dst_dir)[key]
            table = read_result_csv(f) if f.suffix == ".csv" else None
            r = _compare_and_publish(name, f, dst, check, table)
            if r.status != "unchanged":
                parts.append(f"{dst.name} {r.status}" + (f" ({r.detail})" if r.detail else ""))
        status = "unchanged" if not parts else ("new" if all(" new" in p for p in parts) else "changed")
        out.append(Regenerated(name, dst_dir, status, "; ".join(parts)))
    return out

