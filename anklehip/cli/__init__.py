"""Command-line interface: ``anklehip <command> ...`` (docs/scenarios.md, docs/step-tests.md), a thin
layer over the Python API (docs/python-api.md): the parser (cli.parser) and the commands
(cli.commands).

Exit status: 0 success, 1 a check failed (expected outcome, comparison, step test),
2 the input is wrong (bad scenario, missing file or column, unknown parameter, bad option value,
parameters the FMU refuses, output folder in use): an InputError, before anything is written.
An error is one line on stderr that names the file, key, cell or option and the reason; no input
ends in a Python traceback.
"""
from __future__ import annotations

import contextlib
import os
import signal
import sys

from ..errors import InputError, Terminated
from ..files.output import os_error_message
from ..running.points import NoWorkersError
from .parser import EXIT_ERROR, EXIT_FAIL, EXIT_OK, FMI3_COMMANDS, build_parser

__all__ = ["main", "build_parser", "UsageError", "EXIT_OK", "EXIT_FAIL", "EXIT_ERROR"]


class UsageError(InputError):
    """A command-line argument is wrong (the message names the option and the value)."""


def _err(msg: str) -> int:
    print(f"anklehip: error: {msg}", file=sys.stderr)
    return EXIT_ERROR


def _terminate(signum, frame):
    raise Terminated(signal.Signals(signum).name)


_swallowed: BaseException | None = None   # an interrupt a finalizer could not pass on (_redeliver)


def _redeliver(previous):
    """An unraisable-exception hook: a Ctrl-C or a kill whose KeyboardInterrupt is raised inside a
    finalizer (a __del__, a file the garbage collector closes) cannot leave it; Python prints it as
    "Exception ignored in ..." with a traceback and the command goes on as if never interrupted. This
    hook keeps it and raises it again 1 ms later from SIGALRM, in the command's own flow (again, if
    that lands in a finalizer too); every other unraisable exception goes to `previous`."""
    def hook(u):
        global _swallowed
        if u.exc_type is not None and issubclass(u.exc_type, KeyboardInterrupt):
            _swallowed = u.exc_value if u.exc_value is not None else u.exc_type()
            signal.setitimer(signal.ITIMER_REAL, 0.001)
        else:
            previous(u)
    return hook


def _raise_swallowed(signum, frame):
    global _swallowed
    e, _swallowed = _swallowed, None
    if e is not None:
        raise e


@contextlib.contextmanager
def _ending_signals_interrupt():
    """SIGTERM and SIGHUP raise Terminated (a KeyboardInterrupt) in the main thread while a command
    runs, so a kill ends a run as Ctrl-C does (the data so far as <name>.incomplete.csv, no half
    result that looks complete), also when it lands in a finalizer (_redeliver); the previous
    handlers afterwards."""
    import threading
    global _swallowed
    names = [n for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n)]
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {n: signal.signal(getattr(signal, n), _terminate) for n in names}
    redeliver = hasattr(signal, "setitimer")          # not on Windows
    if redeliver:
        old_hook, old_alarm = sys.unraisablehook, signal.signal(signal.SIGALRM, _raise_swallowed)
        sys.unraisablehook = _redeliver(old_hook)
    try:
        yield
    finally:
        if redeliver:      # the command is over: an interrupt still held comes after its work
            _swallowed = None
            signal.setitimer(signal.ITIMER_REAL, 0)
            sys.unraisablehook = old_hook
            signal.signal(signal.SIGALRM, old_alarm)
        for n, h in old.items():
            signal.signal(getattr(signal, n), h)


def main(argv=None) -> int:
    try:
        # imported before the handlers: a kill while the interpreter still imports ends it at once
        # (nothing touched yet); a Terminated raised during these imports once crashed the
        # interpreter's exit (SIGTERM 0.3 s after the start: "Fatal Python error ... finalizing")
        import matplotlib
        matplotlib.use("Agg")          # the command line only writes figures (the API leaves the backend alone)
        from . import commands
        with _ending_signals_interrupt():
            p = build_parser()
            a = p.parse_args(argv)
            if a.fmi == 3 and a.cmd not in FMI3_COMMANDS:
                return _err(f"--fmi 3: `{a.cmd}` runs the FMI 2.0 FMUs only (--fmi 3 works with "
                            f"{', '.join(FMI3_COMMANDS)})")
            return (a.fn if callable(a.fn) else getattr(commands, f"cmd_{a.fn}"))(a)   # robot: its own module
    except KeyboardInterrupt as e:
        print(str(e) if isinstance(e, Terminated) else "interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return EXIT_OK
    except InputError as e:
        return _err(str(e))
    except NoWorkersError as e:
        return _err(str(e))
    except OSError as e:      # a file or folder we cannot read or write: name both, and the reason
        return _err(os_error_message(e))
    except Exception as e:
        if os.environ.get("ANKLEHIP_DEBUG"):
            raise
        # a bug: still one line on stderr, not a traceback
        return _err(f"unexpected {type(e).__name__}: {e} (please report it with the command line; "
                    "ANKLEHIP_DEBUG=1 shows the traceback)")


if __name__ == "__main__":
    sys.exit(main())
