#!/usr/bin/env python3
"""Valgrind memcheck of a closed-loop run (controller + plant FMUs through the FMPy master).

    .venv/bin/python scripts/valgrind_closed_loop.py [SCENARIO] [--stop-time S] [--plant NAME]
    .venv/bin/python scripts/valgrind_closed_loop.py --fmi3-extras

--fmi3-extras runs, instead of a closed loop, what the loop does not call (issue 28): the
controller's FMI 3.0 Scheduled Execution variant activated tick by tick through a push's sensor
signals (FMPy's FMU3ScheduledExecution) and the 3D plant's FMI 3.0 twin stepped with its per-leg
set points set through the array q_leg_ref and every output array read (and one wrong nValues).

Runs `anklehip run SCENARIO` under memcheck (Python with PYTHONMALLOC=malloc, so the interpreter's
own allocator hides nothing), reads Valgrind's XML report and counts, for each FMU binary, the
errors (invalid reads/writes, uninitialised values, bad frees) and the definitely lost bytes whose
stack passes through it (or through any other object built in this repository). Exit status 0
only if both are zero for every FMU and the run succeeded. The known errors of the interpreter,
NumPy, lxml and the loader are suppressed by scripts/valgrind-python.supp (--suppressions; each
suppression is checked to name only frames of those libraries, so none can hide an error of ours)
and counted by name; errors whose stacks pass through none of ours and that no suppression matched
are listed by the library of their innermost frame and do not count. Issue 12, issue 33 /
docs/reliability.md, "Valgrind suppressions".
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
SUPPRESSIONS = ROOT / "scripts" / "valgrind-python.supp"
# The only objects a suppression may name: the interpreter, NumPy, lxml, the loader and libc. None
# of them is built here, and a suppression names its frames by these or by functions inside them.
ALLOWED_OBJ = ("*/libpython3.11.so*", "*/numpy/_core/_multiarray_umath.cpython-311-*.so",
               "*/lxml/etree.cpython-311-*.so", "*/ld-linux-x86-64.so.2", "*/libc.so.6")


def check_suppressions(text: str) -> list[str]:
    """The suppressions' names, or ValueError naming the first that could match a frame of ours:
    a "..." wildcard, an obj: outside ALLOWED_OBJ, no obj: line pinning it to such a library, or a
    line that is not a frame."""
    names: list[str] = []
    lines = [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.strip().startswith("#")]
    i = 0
    while i < len(lines):
        if lines[i] != "{":
            raise ValueError(f"expected '{{' at {lines[i]!r}")
        end = lines.index("}", i)
        body = lines[i + 1:end]
        if len(body) < 3:
            raise ValueError(f"suppression at {body!r}: a name, a kind and frames expected")
        name, frames = body[0], body[2:]
        if frames and frames[0].startswith("match-leak-kinds:"):
            frames = frames[1:]
        for f in frames:
            if f in ("...", "fun:*", "obj:*") or f.startswith("src:"):
                raise ValueError(f"suppression {name}: {f!r} could match a frame of ours")
            if not (f.startswith("fun:") or f.startswith("obj:")):
                raise ValueError(f"suppression {name}: {f!r} is not a frame")
            if f.startswith("obj:") and f[4:] not in ALLOWED_OBJ:
                raise ValueError(f"suppression {name}: {f!r} is not one of {', '.join(ALLOWED_OBJ)}")
        if not any(f.startswith("obj:") for f in frames):
            raise ValueError(f"suppression {name}: no obj: line pins it to a library that is not ours")
        names.append(name)
        i = end + 1
    return names


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


def drive_fmi3_extras(fmu_dir: Path, ticks: int, steps: int) -> None:
    """The --fmi3-extras program (run under memcheck): Scheduled Execution and arrays."""
    import math
    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3ScheduledExecution, FMU3Slave
    se = fmu_dir / "fmi3" / "AnkleHipController_se.fmu"
    md = read_model_description(str(se))
    var = {v.name: v for v in md.modelVariables}
    f = FMU3ScheduledExecution(guid=md.instantiationToken, unzipDirectory=extract(str(se)),
                               modelIdentifier=md.scheduledExecution.modelIdentifier, instanceName="se")
    f.instantiate()
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    ins = [var[n].valueReference for n in ("theta_ankle", "theta_hip", "zmp_x", "fz")]
    outs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Float64"]
    for k in range(ticks):   # a forward lean whose ZMP passes the toe-side limit: the hip strategy
        t = k * 1e-3
        lean = 0.03 * math.sin(math.pi * min(t, 1.0))
        f.setFloat64(ins, [lean, -0.5 * lean, 0.9 * lean, 70.2])
        f.activateModelPartition(var["tick"].valueReference, t)
        f.getFloat64(outs)
        f.getInt64([var["phase"].valueReference])
    f.terminate()
    f.freeInstance()
    p3 = fmu_dir / "fmi3" / "Hoap2Plant3D.fmu"
    md = read_model_description(str(p3))
    var = {v.name: v for v in md.modelVariables}
    arrays = [v for v in md.modelVariables if v.dimensions and v.causality == "output"]
    sizes = [math.prod(int(d.start) for d in v.dimensions) for v in arrays]
    f = FMU3Slave(guid=md.instantiationToken, unzipDirectory=extract(str(p3)),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="plant")
    f.instantiate()
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    for k in range(steps):
        f.setFloat64([var["q_leg_ref"].valueReference], [0.02 * math.sin(1e-2 * k + j) for j in range(12)])
        f.doStep(k * 1e-3, 1e-3)
        f.getFloat64([v.valueReference for v in arrays], sum(sizes))
    try:
        f.getFloat64([arrays[0].valueReference], sizes[0] - 1)   # refused: nValues is the array's size
        raise SystemExit("a wrong nValues was accepted")
    except Exception as e:
        if isinstance(e, SystemExit):
            raise
    f.terminate()
    f.freeInstance()


def main(argv: list[str] | None = None) -> int:
    if argv is None and sys.argv[1:2] == ["--drive-fmi3-extras"]:   # the program memcheck runs
        drive_fmi3_extras(Path(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]))
        return 0
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default="hip_saves_push")
    ap.add_argument("--stop-time", default="1.5", help="simulated seconds (default 1.5: the push and the hip strategy)")
    ap.add_argument("--plant", default=None, choices=("sagittal", "3d"), help="plant model (default: the scenario's)")
    ap.add_argument("--suppressions", default=str(SUPPRESSIONS),
                    help="Valgrind suppressions of errors outside our binaries (default: %(default)s); "
                         "'' for none")
    ap.add_argument("--keep-xml", default=None, help="also copy Valgrind's XML report here")
    ap.add_argument("--fmi3-extras", action="store_true",
                    help="instead of a closed loop: the controller's Scheduled Execution variant and the 3D plant's "
                         "FMI 3.0 arrays (see above)")
    args = ap.parse_args(argv)
    if not FMU_BINARIES:
        print("valgrind_closed_loop: no packed FMUs in the build (bash scripts/setup.sh)", file=sys.stderr)
        return 1
    # the FMU binaries this run loads: the scenario's controller and plant
    sys.path.insert(0, str(ROOT))
    from anklehip.files.paths import CONTROLLER_FMUS, PLANT_FMUS, find_fmu, find_scenario
    from anklehip.files.scenario import load_scenario
    if args.fmi3_extras:
        used = {"AnkleHipController.so", "Hoap2Plant3D.so"}
    else:
        sc = load_scenario(find_scenario(args.scenario))
        plant = PLANT_FMUS[args.plant or sc.plant_model]
        used = {Path(CONTROLLER_FMUS[sc.controller_model]).stem + ".so", Path(plant).stem + ".so"}

    with tempfile.TemporaryDirectory(prefix="anklehip-valgrind-") as tmp:
        xml = Path(tmp) / "memcheck.xml"
        supp = []
        if args.suppressions:
            try:
                check_suppressions(Path(args.suppressions).read_text())
            except (OSError, ValueError) as e:
                print(f"valgrind_closed_loop: {args.suppressions}: {e}", file=sys.stderr)
                return 2
            supp = [f"--suppressions={args.suppressions}"]
        cmd = ["valgrind", "--tool=memcheck", "--leak-check=full", "--show-leak-kinds=definite",
               "--errors-for-leak-kinds=definite", "--track-origins=yes", "--xml=yes", f"--xml-file={xml}",
               "--gen-suppressions=all", *supp, sys.executable]
        if args.fmi3_extras:   # 1500 ticks (1.5 s) and 300 plant steps
            cmd += [__file__, "--drive-fmi3-extras", str(find_fmu("AnkleHipController.fmu").parent), "1500", "300"]
        else:
            cmd += ["-m", "anklehip.cli", "run", args.scenario, "--stop-time", args.stop_time,
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
        if args.keep_xml:
            Path(args.keep_xml).write_bytes(xml.read_bytes())
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
    # No stack of these passes through a binary of ours, and no suppression matched them: attributed
    # to the library of the innermost frame besides Valgrind's own, listed (something new to look
    # at), not counted.
    print("outside our binaries, not suppressed, not counted:" + ("" if elsewhere else " nothing"))
    for lib, kinds in sorted(elsewhere.items()):
        print(f"    {lib}: " + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())))
    counts = root.find("suppcounts")
    used_supp = [(p.findtext("name"), int(p.findtext("count") or 0)) for p in (counts.iter("pair") if counts is not None else [])]
    print("suppressed (" + (Path(args.suppressions).name if args.suppressions else "no suppressions file") + "):"
          + ("" if used_supp else " nothing"))
    for name, count in sorted(used_supp):
        print(f"    {name}: {count}")
    bad = any(errors.values()) or any(lost.values())
    print("valgrind_closed_loop:", "FAILED" if bad else "clean")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
