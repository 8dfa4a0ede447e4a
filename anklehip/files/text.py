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


def read_toml(path: str | Path, where: str, error: type[Exception]) -> dict[str, Any]:
    """The file as TOML; `error` naming `where` and the reason when it is not."""
    text = read_text(path, where, error)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise error(f"{where}: invalid TOML: {e}") from None
    except RecursionError:
        raise error(f"{where}: invalid TOML: arrays or tables nested too deep") from None
