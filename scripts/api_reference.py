#!/usr/bin/env python3
"""Print the reference of the public Python API (anklehip.__all__ and anklehip.figures) as Markdown:
every function's signature and docstring, every result class's fields, properties and methods.
The generated section of docs/python-api.md (scripts/update_docs.py runs this; the docstrings are
the one source)."""
from __future__ import annotations

import dataclasses
import inspect
import sys
import textwrap
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import anklehip  # noqa: E402

SECTIONS = [
    ("Running", ["run", "ScenarioResult", "PushSummary", "Check", "load_scenario", "Scenario", "PushProfile", "PushSegment", "scenarios"]),
    ("Sweeps", ["sweep", "SweepResult", "Variant"]),
    ("Comparing", ["compare", "CompareReport"]),
    ("Step tests", ["steptest", "StepTestResult", "steptest_cases"]),
    ("Files and FMUs", ["locations", "fmu_path", "fmu_info"]),
    ("Errors", ["InputError"]),
]


def _doc(obj) -> str:
    """The docstring: its first paragraph as text, the rest as a text block (it is laid out in
    columns)."""
    doc = inspect.getdoc(obj) or ""
    if not doc:
        return ""
    head, _, rest = doc.partition("\n\n")
    out = " ".join(head.split()) + "\n"
    if rest.strip():
        out += "\n```text\n" + rest.rstrip() + "\n```\n"
    return out


def _ann(a) -> str:
    return (a if isinstance(a, str) else str(getattr(a, "__name__", a))).replace("'", "").replace('"', "")


def _param(p: inspect.Parameter) -> str:
    s = p.name if p.kind is not p.VAR_KEYWORD else f"**{p.name}"
    if p.annotation is not p.empty:
        s += f": {_ann(p.annotation)}"
    if p.default is not p.empty:
        s += f" = {p.default!r}"
    return s


def _signature(name: str, obj) -> str:
    sig = inspect.signature(obj)
    params = [_param(p) for p in sig.parameters.values() if p.name not in ("self", "cls")]
    kw = [i for i, p in enumerate(q for q in sig.parameters.values() if q.name not in ("self", "cls"))
          if p.kind == p.KEYWORD_ONLY]
    if kw:
        params.insert(kw[0], "*")
    ret = sig.return_annotation
    ret = "" if ret is sig.empty else f" -> {_ann(ret)}"
    text = f"{name}({', '.join(params)}){ret}"
    if len(text) > 100:        # one parameter a line
        text = f"{name}(\n" + "".join(f"    {p},\n" for p in params) + f"){ret}"
    return f"```python\n{text}\n```\n"


def _function(qual: str, obj) -> str:
    return f"### `{qual}`\n\n" + _signature(qual, obj) + "\n" + _doc(obj)


def _class(qual: str, cls) -> str:
    out = f"### `{qual}`\n\n" + _doc(cls)
    if dataclasses.is_dataclass(cls):
        rows = [f"| `{f.name}` | `{f.type}` |" for f in dataclasses.fields(cls) if not f.name.startswith("_")]
        out += "\n| field | type |\n|---|---|\n" + "\n".join(rows) + "\n"
    members = []
    for n, m in inspect.getmembers(cls):
        if n.startswith("_") or n in {f.name for f in dataclasses.fields(cls)} if dataclasses.is_dataclass(cls) else n.startswith("_"):
            continue
        if isinstance(m, property) or inspect.isfunction(m) or isinstance(inspect.getattr_static(cls, n), classmethod):
            if isinstance(m, property):
                label = f"`.{n}`"
            else:
                sig = _signature("", m).split("\n")[1]
                label = f"`.{n}{sig}`" if len(sig) < 90 else f"`.{n}(...)`"
            first = (inspect.getdoc(m) or "").split("\n\n")[0]
            members.append(f"- {label}: {' '.join(first.split())}" if first else f"- {label}")
    if members:
        out += "\n" + "\n".join(members) + "\n"
    return out


def main() -> int:
    parts = []
    for title, names in SECTIONS:
        parts.append(f"## {title}\n")
        for n in names:
            obj = getattr(anklehip, n)
            parts.append(_class(f"anklehip.{n}", obj) if inspect.isclass(obj) else _function(f"anklehip.{n}", obj))
    figs = anklehip.figures
    parts.append("## Figures: `anklehip.figures`\n\n" + " ".join(textwrap.dedent(figs.__doc__).split("\n\n")[0].split())
                 + "\n")
    for n in figs.__all__:
        parts.append(_function(f"anklehip.figures.{n}", getattr(figs, n)))
    print("\n".join(parts).rstrip())
    return 0


if __name__ == "__main__":
    sys.exit(main())
