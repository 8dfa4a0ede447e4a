"""A figure the docs quote in several places has one source, and every place agrees with it:

- the number of runs of the committed capability maps `anklehip sweep force_duration` and
  `anklehip sweep polar_3d`: computed from their files in scenarios/sweeps/ (variants x grid), in
  README.md, docs/*.md and the file's own comment;
- the benchmark figures of README.md: each is the one docs/performance.md states (bench/run.sh
  measures them there);
- the controller's time per tick, wherever it is quoted.
(The wheel's size in README.md: tests/test_wheel.py.)
"""
from __future__ import annotations

import re

import pytest

from conftest import REPO_ROOT

DOCS = [REPO_ROOT / "README.md", *sorted((REPO_ROOT / "docs").glob("*.md"))]


@pytest.mark.parametrize("name,least", [("force_duration", 4), ("polar_3d", 3), ("stepping_3d", 3),
                                        ("stepping_polar_3d", 2)])
def test_capability_map_run_count_is_the_sweep_files(name, least):
    from anklehip.running.sweepfile import load_sweep_file
    f = REPO_ROOT / "scenarios" / "sweeps" / f"{name}.toml"
    n = len(load_sweep_file(f).specs(None, "native"))
    quoted = []
    for p in DOCS + [f]:
        text = p.read_text()
        # the sweep's own name, not a longer one ending in it (stepping_polar_3d is not polar_3d)
        for m in re.finditer(r"(?<![\w])" + name + r"[^\n]{0,80}?\(?(\d[\d ]*) (?:closed-loop )?runs", text):
            quoted.append((p.name, int(m[1].replace(" ", ""))))
        for m in re.finditer(r"\((\d+) runs", text) if p == f else []:
            quoted.append((p.name, int(m[1])))
    assert len(quoted) >= least, quoted
    assert all(q == n for _, q in quoted), (n, quoted)


def test_readme_benchmark_figures_are_performance_mds():
    readme = (REPO_ROOT / "README.md").read_text()
    para = readme[readme.index("Benchmarks (`bash bench/run.sh`"):]
    para = para[:para.index("\n\n")]
    perf = (REPO_ROOT / "docs" / "performance.md").read_text()
    figures = re.findall(r"(\d+(?:\.\d+)?)(?: ?(?:ns|µs|×)| simulated seconds| on the closed loop| runs)", para)
    assert len(figures) >= 7, figures
    missing = [x for x in figures if not re.search(rf"(?<![\d.]){re.escape(x)}(?![\d])", perf)]
    assert not missing, f"README.md quotes {missing}, which docs/performance.md does not state"


def test_controller_tick_is_quoted_alike():
    perf = (REPO_ROOT / "docs" / "performance.md").read_text()
    source = re.search(r"The controller's tick\s+is (\d+) ns", perf)[1]
    quoted = [(p.name, m[1]) for p in DOCS for m in re.finditer(r"(\d+) ns (?:per tick|\(median\))", p.read_text())]
    assert quoted and all(q == source for _, q in quoted), (source, quoted)

