#!/usr/bin/env python3
"""Execute the example notebook(s) of docs/examples with nbclient (a Jupyter kernel of this
Python), in a temporary working folder, and write the executed notebook back (outputs included).

    run_notebook.py            execute and write docs/examples/*.ipynb
    run_notebook.py --check    execute, write nothing; exit 1 when a cell fails or a text output
                               differs from the committed one (figures are not compared)

tests/test_notebook.py runs the check, so the notebook and its committed outputs cannot rot.
Exit codes: 0 ok, 1 failed or stale (--check), 2 error.
"""
from __future__ import annotations

import argparse
import difflib
import sys
import tempfile
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((REPO_ROOT / "docs" / "examples").glob("*.ipynb"))
TIMEOUT = 600      # seconds per cell


def execute(path: Path):
    """The notebook at `path`, executed (a new object; the file is not touched)."""
    import nbformat
    from nbclient import NotebookClient
    nb = nbformat.read(path, as_version=4)
    for cell in nb.cells:      # no timestamps: the file changes only when an output does
        cell.metadata.pop("execution", None)
    with tempfile.TemporaryDirectory(prefix="anklehip-notebook-") as work:
        NotebookClient(nb, timeout=TIMEOUT, kernel_name="python3", record_timing=False,
                       resources={"metadata": {"path": work}}).execute()
    return nb


def text_outputs(nb) -> list[list[str]]:
    """Per code cell: its text outputs (stream text, text/plain results, errors); not images."""
    out = []
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        texts = []
        for o in cell.get("outputs", []):
            if o.output_type == "stream":
                texts.append(o.text)
            elif o.output_type in ("execute_result", "display_data") and "image/png" not in o.get("data", {}):
                texts.append(o.get("data", {}).get("text/plain", ""))
            elif o.output_type == "error":
                texts.append(f"{o.ename}: {o.evalue}")
        out.append(texts)
    return out


def errors(nb) -> list[str]:
    return [f"cell {i}: {o.ename}: {o.evalue}" for i, c in enumerate(nb.cells) if c.cell_type == "code"
            for o in c.get("outputs", []) if o.output_type == "error"]


def stale(committed, executed) -> list[str]:
    """Where the executed notebook's text outputs differ from the committed ones (a diff per cell)."""
    problems = []
    for i, (a, b) in enumerate(zip(text_outputs(committed), text_outputs(executed))):
        if a != b:
            diff = difflib.unified_diff("".join(a).splitlines(), "".join(b).splitlines(), "committed", "executed",
                                        lineterm="", n=1)
            problems.append(f"code cell {i}:\n" + "\n".join(list(diff)[:20]))
    return problems


def main(argv: list[str] | None = None) -> int:
    import nbformat
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 if a cell fails or an output changed")
    args = ap.parse_args(argv)
    if not NOTEBOOKS:
        print("run_notebook.py: error: no notebooks in docs/examples", file=sys.stderr)
        return 2
    rc = 0
    for path in NOTEBOOKS:
        rel = path.relative_to(REPO_ROOT)
        try:
            nb = execute(path)
        except Exception as e:      # nbclient's CellExecutionError names the cell and the traceback
            print(f"{rel}: execution failed: {e}", file=sys.stderr)
            rc = 1
            continue
        if args.check:
            problems = errors(nb) + stale(nbformat.read(path, as_version=4), nb)
            if problems:
                print(f"{rel}: outputs differ from the committed ones (regenerate with "
                      f"`.venv/bin/python scripts/run_notebook.py`):\n" + "\n".join(problems), file=sys.stderr)
                rc = 1
            else:
                print(f"{rel}: executed, outputs as committed")
        else:
            nbformat.write(nb, path)
            print(f"{rel}: executed and written")
    return rc


if __name__ == "__main__":
    sys.exit(main())
