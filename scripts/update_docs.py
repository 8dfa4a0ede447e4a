#!/usr/bin/env python3
"""Refresh the generated sections of docs/*.md from the build products (stdlib only).

A generated section is everything between a marker pair

    <!-- BEGIN GENERATED: AnkleHipController_gen --markdown -->
    ...
    <!-- END GENERATED -->

The BEGIN marker names the command: an executable found under the build folder
($ANKLEHIP_BUILD_DIR, default <repo>/build; relative paths are taken from the repo root), or a
Python script of scripts/ (a name ending in .py, run with this Python), and its arguments. Its
standard output replaces the section's content.

    update_docs.py           rewrite every stale section
    update_docs.py --check   write nothing; exit 1 naming each stale file/section

Exit codes: 0 up to date (or updated), 1 stale (--check), 2 error (missing generator, bad markers).
"""
from __future__ import annotations

import argparse
import difflib
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
DOCS_DIR = REPO_ROOT / "docs"
SETUP_HINT = "run `bash scripts/setup.sh` first (or point ANKLEHIP_BUILD_DIR at your build)"

# Sections that must exist; a doc that lost its markers is an error, not "up to date".
REQUIRED = {
    "docs/fmu.md": ["AnkleHipController_gen --markdown", "AnkleHipController3D_gen --markdown"],
    "docs/plant.md": ["Hoap2Plant_gen --markdown"],
    "docs/plant3d.md": ["Hoap2Plant3D_gen --markdown --causality input"],
    "docs/python-api.md": ["api_reference.py"],
}

BEGIN_RE = re.compile(r"^<!-- BEGIN GENERATED: (?P<cmd>.+?) -->[ \t]*$", re.M)
END_RE = re.compile(r"^<!-- END GENERATED -->[ \t]*$", re.M)


class DocsError(Exception):
    pass


def build_dir() -> Path:
    env = os.environ.get("ANKLEHIP_BUILD_DIR")
    if env:
        p = Path(env)
        return p if p.is_absolute() else REPO_ROOT / p
    return REPO_ROOT / "build"


def find_tool(name: str, bdir: Path) -> Path:
    if "/" in name or not name:
        raise DocsError(f"generator name {name!r} must be a bare executable name")
    if not bdir.is_dir():
        raise DocsError(f"build folder {bdir} does not exist: {SETUP_HINT}")
    hits = [p for p in bdir.rglob(name) if p.is_file() and os.access(p, os.X_OK)]
    if not hits:
        raise DocsError(f"generator {name} not found under {bdir}: {SETUP_HINT}")
    return sorted(hits, key=lambda p: (len(p.parts), str(p)))[0]


def run_generator(cmd: str, bdir: Path, cache: dict[str, str]) -> str:
    if cmd in cache:
        return cache[cmd]
    argv = shlex.split(cmd)
    if not argv:
        raise DocsError("empty generator command in a BEGIN GENERATED marker")
    if argv[0].endswith(".py"):
        script = REPO_ROOT / "scripts" / argv[0]
        if "/" in argv[0] or not script.is_file():
            raise DocsError(f"generator script {argv[0]} is not a script of scripts/")
        exe, prefix = script, [sys.executable, str(script)]
    else:
        exe = find_tool(argv[0], bdir)
        prefix = [str(exe)]
    r = subprocess.run([*prefix, *argv[1:]], capture_output=True, text=True)
    if r.returncode != 0:
        raise DocsError(f"`{exe} {' '.join(argv[1:])}` failed (exit {r.returncode}):\n{r.stderr.strip()}")
    if not r.stdout.strip():
        raise DocsError(f"`{exe} {' '.join(argv[1:])}` printed nothing")
    cache[cmd] = r.stdout
    return r.stdout


def regenerate(text: str, rel: str, bdir: Path, cache: dict[str, str]) -> tuple[str, list[str], list[str]]:
    """Return (new text, commands of all sections, commands of the sections that changed)."""
    out: list[str] = []
    found: list[str] = []
    changed: list[str] = []
    pos = 0
    while True:
        b = BEGIN_RE.search(text, pos)
        if not b:
            stray = END_RE.search(text, pos)
            if stray:
                line = text.count("\n", 0, stray.start()) + 1
                raise DocsError(f"{rel}:{line}: END GENERATED without a BEGIN GENERATED")
            break
        line = text.count("\n", 0, b.start()) + 1
        e = END_RE.search(text, b.end())
        nb = BEGIN_RE.search(text, b.end())
        if not e or (nb and nb.start() < e.start()):
            raise DocsError(f"{rel}:{line}: BEGIN GENERATED ({b['cmd']}) without a matching END GENERATED")
        cmd = b["cmd"].strip()
        body = "\n\n" + run_generator(cmd, bdir, cache).rstrip("\n") + "\n\n"
        old = text[b.end():e.start()]
        if old != body:
            changed.append(f"{cmd} (line {line})")
        found.append(cmd)
        out.append(text[pos:b.end()])
        out.append(body)
        out.append(e.group(0))
        pos = e.end()
    out.append(text[pos:])
    return "".join(out), found, changed


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 if a generated section is stale")
    args = ap.parse_args(argv)

    bdir = build_dir()
    cache: dict[str, str] = {}
    stale: list[str] = []
    try:
        files = sorted(DOCS_DIR.glob("*.md"))
        for path in files:
            rel = path.relative_to(REPO_ROOT).as_posix()
            text = path.read_text(encoding="utf-8")
            new, found, changed = regenerate(text, rel, bdir, cache)
            for cmd in REQUIRED.get(rel, []):
                if cmd not in found:
                    raise DocsError(f"{rel}: no `<!-- BEGIN GENERATED: {cmd} -->` section (markers removed?)")
            if not changed:
                continue
            if args.check:
                for c in changed:
                    stale.append(f"{rel}: generated section `{c}` is stale")
                diff = difflib.unified_diff(text.splitlines(), new.splitlines(), f"a/{rel}", f"b/{rel}",
                                            n=0, lineterm="")
                lines = list(diff)
                print("\n".join(lines[:40] + (["..."] if len(lines) > 40 else [])), file=sys.stderr)
            else:
                path.write_text(new, encoding="utf-8")
                print(f"updated {rel}: {', '.join(changed)}")
        for rel in REQUIRED:
            if not (REPO_ROOT / rel).is_file():
                raise DocsError(f"{rel} does not exist")
    except DocsError as exc:
        print(f"update_docs.py: error: {exc}", file=sys.stderr)
        return 2

    if stale:
        print("\n".join(stale) + "\nregenerate with `.venv/bin/python scripts/update_docs.py`")
        return 1
    if args.check:
        print("generated doc sections are up to date")
    return 0


if __name__ == "__main__":
    sys.exit(main())
