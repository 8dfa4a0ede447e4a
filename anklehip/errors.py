"""The package's error classes: every wrong input is an InputError whose message names the file,
key, cell, option or variable and the reason (the command line exits 2 for it)."""
from __future__ import annotations


class InputError(ValueError):
    """Wrong input: a bad scenario, a missing file or column, an unknown parameter, a value outside
    its range, an FMU that does not load or refuses its parameters, an output folder in use."""


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP (a `kill`, a closed terminal, a batch system's time limit) ends a command as
    Ctrl-C does: a run keeps the data computed so far as <name>.incomplete.csv. Raised by the
    command line's signal handler (cli.main)."""

    def __init__(self, signame: str = "SIGTERM"):
        super().__init__(f"terminated by {signame}")
        self.signame = signame
