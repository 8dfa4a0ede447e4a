"""The package's error classes: every wrong input is an InputError whose message names the file,
key, cell, option or variable and the reason (the command line exits 2 for it)."""
from __future__ import annotations


class InputError(ValueError):
    """Wrong input: a bad scenario, a missing file or column, an unknown parameter, a value outside
    its range, an FMU that does not load or refuses its parameters, an output folder in use."""
