"""The Valgrind suppressions of the reliability check (scripts/valgrind-python.supp, issue 33): what
establishes that no suppression can hide an error of ours.

* the committed file passes scripts/valgrind_closed_loop.py's check: every frame is a fun: or an
  obj: of the interpreter, NumPy, lxml, the loader or libc, each suppression is pinned by an obj:
  line to one of them, no "..." wildcard;
* the check refuses each way a suppression could match a frame of our binaries (a wildcard, an
  obj: of ours or of any other object, no obj: pin, a stray line), so the Valgrind step (which
  runs it first, exit 2) cannot be handed such a file;
* Valgrind itself accepts the file (`valgrind --suppressions=... true` parses it), when installed.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
from valgrind_closed_loop import SUPPRESSIONS, check_suppressions  # noqa: E402

GOOD = """{
   ok
   Memcheck:Cond
   fun:maybe_small_long
   obj:*/libpython3.11.so*
}
"""


def test_committed_suppressions_name_only_foreign_frames():
    names = check_suppressions(SUPPRESSIONS.read_text())
    assert len(names) == len(set(names)) >= 10
    assert check_suppressions(GOOD) == ["ok"]


@pytest.mark.parametrize("frames,why", [
    ("   fun:maybe_small_long\n   ...\n   obj:*/libpython3.11.so*\n", "could match a frame of ours"),
    ("   obj:*/Hoap2Plant3D.so\n", "is not one of"),
    ("   obj:*\n", "could match a frame of ours"),
    ("   obj:*/libfoo.so\n", "is not one of"),
    ("   fun:maybe_small_long\n   fun:PyLong_FromString\n", "no obj: line"),
    ("   fun:maybe_small_long\n   src:longobject.c:1\n   obj:*/libpython3.11.so*\n", "could match"),
    ("   fun:maybe_small_long\n   obj:*/libpython3.11.so*\n   something\n", "is not a frame"),
])
def test_suppressions_that_could_hide_ours_are_refused(frames, why):
    with pytest.raises(ValueError, match=why):
        check_suppressions("{\n   bad\n   Memcheck:Cond\n" + frames + "}\n")


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="Valgrind is installed by scripts/setup.sh --sanitize")
def test_valgrind_parses_the_file():
    r = subprocess.run(["valgrind", "-q", f"--suppressions={SUPPRESSIONS}", "true"], capture_output=True, text=True)
    assert r.returncode == 0 and "error" not in r.stderr.lower(), r.stderr
