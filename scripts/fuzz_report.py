#!/usr/bin/env python3
"""One FMU's fuzzing figures for scripts/fuzz.sh (docs/reliability.md section 3): from the libFuzzer
log, its final statistics and the deep programs' counters; from a -print_coverage run over the final
corpus, the functions and edges of our sources the inputs reach, by folder.

    .venv/bin/python scripts/fuzz_report.py FMU LOG COVERAGE CORPUS WALL_S [--figures FILE]

Prints one summary line and the coverage table; with --figures appends a Markdown table row.
"""
from __future__ import annotations

import argparse
import re
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# our sources, by the folder a function's file lies in (the rest: the harness, ODE, SUNDIALS, libc++).
# plant/src and plant3d/src are compiled without coverage instrumentation (CMakeLists.txt: tracing
# every floating-point loop would slow the sanitized tests 300-fold), so they never appear here.
FOLDERS = ("fmu/common/src", "fmu/common/include", "fmu/controller", "fmu/controller3d", "fmu/plant3d", "fmu/plant",
           "controller_c/src")


def stats(log: str) -> dict:
    def grab(pattern, cast=float, default=None):
        m = re.findall(pattern, log, re.M)
        return cast(m[-1]) if m else default
    return {"runs": grab(r"^stat::number_of_executed_units:\s*(\d+)", int, 0),
            "rate": grab(r"^stat::average_exec_per_sec:\s*(\d+)", int, 0),
            "edges": grab(r"cov: (\d+)", int, 0),
            "deep": re.findall(r"deep programs: (\d+), successful steps (\d+) \(([\d.]+) per program\) of (\d+), "
                               r"bit-exact restores (\d+), forged states (\d+) \((\d+) accepted\)", log)}


def coverage(text: str) -> dict[str, list[int]]:
    """folder -> [functions reached, functions, edges reached, edges] over our sources."""
    by: dict[str, list[int]] = defaultdict(lambda: [0, 0, 0, 0])
    for m in re.finditer(r"^(COVERED|UNCOVERED)_FUNC: hits: (\d+) edges: (\d+)/(\d+) (.*?) (\S+):\d+$", text, re.M):
        kind, _, e_hit, e_all, _, path = m.groups()
        rel = Path(path).resolve()
        try:
            rel = rel.relative_to(ROOT)
        except ValueError:
            continue
        folder = next((f for f in FOLDERS if str(rel).startswith(f + "/")), None)
        if folder is None:
            continue
        c = by[folder]
        c[0] += kind == "COVERED"
        c[1] += 1
        c[2] += int(e_hit)
        c[3] += int(e_all)
    return dict(by)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("fmu")
    ap.add_argument("log", type=Path)
    ap.add_argument("coverage", type=Path)
    ap.add_argument("corpus", type=Path)
    ap.add_argument("wall", type=float)
    ap.add_argument("--figures", type=Path)
    a = ap.parse_args(argv)
    s = stats(a.log.read_text(errors="replace"))
    cov = coverage(a.coverage.read_text(errors="replace")) if a.coverage.is_file() else {}
    n_corpus = sum(1 for _ in a.corpus.iterdir())
    deep = s["deep"][-1] if s["deep"] else None
    per = f"{float(deep[2]):.1f}" if deep else "-"
    print(f"   {a.fmu}: {s['runs']} inputs in {a.wall:.0f} s ({s['rate']}/s), {s['edges']} edges, corpus {n_corpus} "
          f"inputs, no finding")
    if deep:
        print(f"      deep programs {deep[0]}: {per} successful steps per program ({deep[1]} of {deep[3]} steps), "
              f"{deep[4]} bit-exact restores compared, {deep[5]} forged states ({deep[6]} accepted and behaved)")
    fn = [0, 0]
    for folder in FOLDERS:
        if folder in cov:
            c = cov[folder]
            fn[0] += c[0]
            fn[1] += c[1]
            print(f"      coverage {folder + '/':<22} functions {c[0]:>4} of {c[1]:<4} edges {c[2]:>5} of {c[3]:<5} "
                  f"({100 * c[2] / max(1, c[3]):.0f} %)")
    if a.figures:
        with open(a.figures, "a") as f:
            f.write(f"| {a.fmu} | {s['runs']:,} | {s['rate']} | {s['edges']} | {n_corpus} | "
                    f"{deep[0] if deep else '-'} | {per} | {fn[0]} of {fn[1]} |\n".replace(",", " "))
    return 0


if __name__ == "__main__":
    sys.exit(main())
