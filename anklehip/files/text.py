"""Reading the text files users give us (scenarios, CSVs, step-test options): one clear error,
naming the file and the reason, for a file that is missing, unreadable, binary or not TOML."""
from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any


def read_text(path: str | Path, where: str, error: type[Exception]) -> str:
    """The file as UTF-8 text; `error` with a message that starts with `where` when it cannot be
    read or is not UTF-8 (binary garbage, another encoding)."""
    try:
        raw = Path(path).read_bytes()
    except OSError as e:
        raise error(f"{where}: cannot read: {e.strerror}") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw[:e.start].count(b"\n") + 1
        raise error(f"{where}: line {line}: not UTF-8 text (byte 0x{raw[e.start]:02x}); "
                    "is it a binary file?") from None


# Our TOML files (scenarios, sweeps, robots, step-test options) are a few kB: a larger one is not
# one of them, and Python's TOML parser takes time quadratic in the depth of nested table names
# (3 000 nested tables, 9 MB: 14 s), so both are refused before it parses.
TOML_MAX_BYTES = 1 << 20
TOML_MAX_DEPTH = 64


def _toml_depth_problem(text: str) -> str | None:
    """The first line whose table header or dotted key names more than TOML_MAX_DEPTH levels."""
    for n, line in enumerate(text.splitlines(), 1):
        s = line.lstrip()
        if not s or s[0] == "#":
            continue
        head = s.split("=", 1)[0] if s[0] != "[" else s.split("]", 1)[0]
        if head.count(".") + 1 > TOML_MAX_DEPTH:
            return f"line {n}: a key or table nested {head.count('.') + 1} levels deep (at most {TOML_MAX_DEPTH})"
    return None


def read_toml(path: str | Path, where: str, error: type[Exception]) -> dict[str, Any]:
    """The file as TOML; `error` naming `where` and the reason when it is not. A UTF-8 byte-order
    mark (which some editors write) is ignored."""
    try:
        size = Path(path).stat().st_size
    except OSError:
        size = 0                     # read_text names the reason
    if size > TOML_MAX_BYTES:
        raise error(f"{where}: {size / 2**20:.1f} MiB: too large for a TOML input file of anklehip "
                    f"(at most {TOML_MAX_BYTES >> 20} MiB)")
    text = read_text(path, where, error)
    if text.startswith("\ufeff"):
        text = text[1:]
    deep = _toml_depth_problem(text)
    if deep:
        raise error(f"{where}: invalid TOML: {deep}")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise error(f"{where}: invalid TOML: {e}") from None
    except RecursionError:
        raise error(f"{where}: invalid TOML: arrays or tables nested too deep") from None
