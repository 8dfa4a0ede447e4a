#!/usr/bin/env python3
"""Valgrind memcheck of a closed-loop run (controller + plant FMUs through the FMPy master).

    .venv/bin/python scripts/valgrind_closed_loop.py [SCENARIO] [--stop-time S] [--plant NAME]

Runs `anklehip run SCENARIO` under memcheck (Python with PYTHONMALLOC=malloc, so the interpreter's
own allocator hides nothing), reads Valgrind's XML report and counts, for each FMU binary, the
errors (invalid reads/writes, uninitialised values, bad frees) and the definitely lost bytes whose
stack passes through it. Exit status 0 only if both are zero for every FMU and the run succeeded;
errors outside our binaries (the interpreter, numpy) are listed but do not count. Issue 12 /
docs/reliability.md.
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

from anklehip.files.paths import SHIPPED  # every FMU the project ships

FMU_BINARIES = tuple(f"{name}.so" for name in SHIPPED)


def ours(error: ET.Element) -> str | None:
    """The FMU binary on the error's stack (or its allocation stack), if any."""
    for frame in error.iter("frame"):
        obj = frame.findtext("obj") or ""
        for name in FMU_BINARIES:
            if obj.endswith("/" + name):
                return name
    return None


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default="hip_saves_push")
    ap.add_argument("--stop-time", default="1.5", help="simulated seconds (default 1.5: the push and the hip strategy)")
    ap.add_argument("--plant", default=None, help="plant FMU name (default: the scenario's)")
    args = ap.parse_args(argv)

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
    elsewhere: dict[str, int] = defaultdict(int)
    for e in root.iter("error"):
        kind = e.findtext("kind") or "?"
        where = ours(e)
        if where is None:
            elsewhere[kind] += 1
            continue
        if kind == "Leak_DefinitelyLost":
            xw = e.find("xwhat")
            lost[where] += int(xw.findtext("leakedbytes") or 0) if xw is not None else 0
        else:
            what = e.findtext("what") or (e.find("xwhat").findtext("text") if e.find("xwhat") is not None else "")
            errors[where].append(f"{kind}: {what}")

    print(f"{'FMU binary':<26} {'errors':>7} {'definitely lost [B]':>20}")
    for name in FMU_BINARIES:
        print(f"{name:<26} {len(errors[name]):>7} {lost[name]:>20}")
        for line in errors[name][:10]:
            print("   ", line)
    print("(outside the FMU binaries, not counted: "
          + (", ".join(f"{n} {k}" for k, n in sorted(elsewhere.items())) or "nothing") + ")")
    bad = any(errors.values()) or any(lost.values())
    print("valgrind_closed_loop:", "FAILED" if bad else "clean")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
