#!/usr/bin/env python3
"""Valgrind memcheck of a closed-loop run (controller + plant FMUs through the FMPy master).

    .venv/bin/python scripts/valgrind_closed_loop.py [SCENARIO] [--stop-time S] [--plant NAME]

Runs `anklehip run SCENARIO` under memcheck (Python with PYTHONMALLOC=malloc, so the interpreter's
own allocator hides nothing), reads Valgrind's XML report and counts, for each FMU binary, the
errors (invalid reads/writes, uninitialised values, bad frees) and the definitely lost bytes whose
stack passes through it (or through any other object built in this repository). Exit status 0
only if both are zero for every FMU and the run succeeded; errors whose stacks pass through none
of ours are listed by the library of their innermost frame (the interpreter, numpy, the loader)
and do not count. Issue 12, issue 33 / docs/reliability.md.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from anklehip.files.paths import SHIPPED  # noqa: E402  (every FMU the project ships)

FMU_BINARIES = tuple(f"{name}.so" for name in SHIPPED)


def ours(error: ET.Element) -> str | None:
    """The binary of ours on the error's stack (or its allocation stack), if any: an FMU binary, or
    any other object built in this repository (the native closed-loop engine)."""
    for frame in error.iter("frame"):
        obj = frame.findtext("obj") or ""
        for name in FMU_BINARIES:
            if obj.endswith("/" + name):
                return name
        if obj.startswith(str(ROOT) + "/") and "/site-packages/" not in obj:   # not the venv's packages
            return Path(obj).name
    return None


def library(error: ET.Element) -> str:
    """The object of the innermost frame that is not Valgrind's own (its malloc replacement): the
    library an error outside our binaries belongs to."""
    for frame in error.iter("frame"):
        obj = frame.findtext("obj") or ""
        if obj and "vgpreload" not in Path(obj).name:
            return Path(obj).name
    return "?"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default="hip_saves_push")
    ap.add_argument("--stop-time", default="1.5", help="simulated seconds (default 1.5: the push and the hip strategy)")
    ap.add_argument("--plant", default=None, choices=("sagittal", "3d"), help="plant model (default: the scenario's)")
    args = ap.parse_args(argv)
    if not FMU_BINARIES:
        print("valgrind_closed_loop: no packed FMUs in the build (bash scripts/setup.sh)", file=sys.stderr)
        return 1
    # the FMU binaries this run loads: the scenario's controller and plant
    sys.path.insert(0, str(ROOT))
    from anklehip.files.paths import CONTROLLER_FMUS, PLANT_FMUS, find_scenario
    from anklehip.files.scenario import load_scenario
    sc = load_scenario(find_scenario(args.scenario))
    plant = PLANT_FMUS[args.plant or sc.plant_model]
    used = {Path(CONTROLLER_FMUS[sc.controller_model]).stem + ".so", Path(plant).stem + ".so"}

    with tempfile.TemporaryDirectory(prefix="anklehip-valgrind-") as tmp:
        xml = Path(tmp) / "memcheck.xml"
        cmd = ["valgrind", "--tool=memcheck", "--leak-check=full", "--show-leak-kinds=definite",
               "--errors-for-leak-kinds=definite", "--track-origins=yes", "--xml=yes", f"--xml-file={xml}",
               sys.executable, "-m", "anklehip.cli", "run", args.scenario, "--stop-time", args.stop_time,
               "--out", str(Path(tmp) / "out"), "--no-progress"]
        if args.plant:
            cmd += ["--plant", args.plant]
        env = dict(os.environ, PYTHONMALLOC="malloc")
        print("+", " ".join(cmd), flush=True)
        run = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if run.returncode != 0:
            print(run.stdout[-3000:], run.stderr[-3000:], sep="\n", file=sys.stderr)
            print(f"valgrind_closed_loop: the run failed (exit {run.returncode})", file=sys.stderr)
            return 1
        root = ET.parse(xml).getroot()

    errors: dict[str, list[str]] = defaultdict(list)
    lost: dict[str, int] = defaultdict(int)
    elsewhere: dict[str, dict[str, int]] = defaultdict(lambda: defaultdict(int))
    for e in root.iter("error"):
        kind = e.findtext("kind") or "?"
        where = ours(e)
        if where is None:
            elsewhere[library(e)][kind] += 1
            continue
        if kind == "Leak_DefinitelyLost":
            xw = e.find("xwhat")
            lost[where] += int(xw.findtext("leakedbytes") or 0) if xw is not None else 0
        else:
            what = e.findtext("what") or (e.find("xwhat").findtext("text") if e.find("xwhat") is not None else "")
            errors[where].append(f"{kind}: {what}")

    print(f"{'binary of ours':<30} {'errors':>7} {'definitely lost [B]':>20}")
    for name in sorted(used | set(errors) | set(lost)):
        print(f"{name:<30} {len(errors[name]):>7} {lost[name]:>20}")
        for line in errors[name][:10]:
            print("   ", line)
    print("(not loaded by this scenario: " + (", ".join(sorted(set(FMU_BINARIES) - used)) or "none") + ")")
    # No stack of these passes through a binary of ours: attributed to the library of the innermost
    # frame besides Valgrind's own (the interpreter, numpy, lxml, the dynamic loader), listed, not counted.
    print("outside our binaries, not counted:" + ("" if elsewhere else " nothing"))
    for lib, kinds in sorted(elsewhere.items()):
        print(f"    {lib}: " + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())))
    bad = any(errors.values()) or any(lost.values())
    print("valgrind_closed_loop:", "FAILED" if bad else "clean")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
