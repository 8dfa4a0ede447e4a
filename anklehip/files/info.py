"""`anklehip info FMU`: an FMU's interface the way a user needs it to set the FMU up.

Unlike ``fmpy info`` (inputs and outputs only), this lists the model's identity (name, FMI
version, GUID, generation tool and date, license), where it runs (the platforms under
``binaries/``, C sources), its default experiment and log categories, and a table per causality
(parameters, calculated parameters, inputs, outputs; locals on request) with each variable's type,
unit and display unit, start value, range, variability and description; Enumeration variables with
their items. The model description is read with FMPy's ``read_model_description``; nothing is
extracted or loaded.

``interface(path)`` returns the content as a JSON-ready dict (``anklehip info --json`` prints
it), ``select`` filters it by causality and name, ``format_text`` renders it as text.
"""
from __future__ import annotations

import fnmatch
import math
import os
import zipfile
from pathlib import Path
from typing import Any

from ..running.fmu import FMUError
from .paths import MissingFileError, find_fmu, fmu_dirs

# Every FMI causality, in the order of the tables; the default selection leaves out the
# internals (local) and the independent variable (time).
CAUSALITIES = ("parameter", "calculatedParameter", "structuralParameter", "input", "output", "local",
               "independent")
DEFAULT_CAUSALITIES = ("parameter", "calculatedParameter", "structuralParameter", "input", "output")
TITLES = {"parameter": "parameters", "calculatedParameter": "calculated parameters",
          "structuralParameter": "structural parameters", "input": "inputs", "output": "outputs",
          "local": "local variables", "independent": "independent variable"}

_REAL = {"Real", "Float32", "Float64"}
_INTEGER = {"Integer", "Enumeration", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64"}

# co-simulation / model-exchange capabilities worth knowing when setting an FMU up
_CAPABILITIES = {
    "canHandleVariableCommunicationStepSize": "variable communication step size",
    "canInterpolateInputs": "interpolates inputs",
    "canGetAndSetFMUstate": "get/set FMU state",
    "canSerializeFMUstate": "serialize FMU state",
    "providesDirectionalDerivative": "directional derivatives",
    "canBeInstantiatedOnlyOncePerProcess": "only one instance per process",
    "needsExecutionTool": "needs its execution tool",
}


# ----------------------------------------------------------------------------------------------
# finding and reading the FMU

def resolve_fmu(name_or_path: str, fmu_dir: str | os.PathLike | None = None, fmi: int = 2) -> Path:
    """An FMU given by path (a .fmu file or an extracted FMU folder), or by model name
    (``AnkleHipController`` or ``AnkleHipController.fmu``), looked up like the package's own FMUs
    (--fmu-dir, else $ANKLEHIP_FMU_DIR, else the checkout's build/fmus and the package's data;
    anklehip.files.paths.fmu_dirs). A MissingFileError names what
    was tried and the FMUs that are there."""
    p = Path(name_or_path)
    if p.exists():
        return p
    if p.parent != Path(".") or not name_or_path:
        raise MissingFileError(f"{name_or_path}: no such file")
    filename = name_or_path if name_or_path.endswith(".fmu") else f"{name_or_path}.fmu"
    fmu_dirs(fmu_dir)      # a --fmu-dir that does not exist is an error of its own
    try:
        return find_fmu(filename, fmu_dir, fmi)
    except MissingFileError:
        pass
    dirs = [Path(fmu_dir)] if fmu_dir else fmu_dirs()
    known = sorted({f.stem for d in dirs if d.is_dir() for f in d.glob("*.fmu")})
    where = ", ".join(str(d) for d in dirs)
    cwd = "no such file here, and " if name_or_path.endswith(".fmu") else ""
    raise MissingFileError(
        f"{name_or_path}: {cwd}no {filename} in {where} (FMUs there: {', '.join(known) or 'none'}; "
        "give a path, or build the FMUs with `bash scripts/setup.sh`)")


def _members(path: Path) -> list[str]:
    """The archive's (or extracted folder's) file names, '/'-separated; FMUError when it is not
    an FMU container or has no modelDescription.xml at its root."""
    if path.is_dir():
        if not (path / "modelDescription.xml").is_file():
            raise FMUError(f"{path}: no modelDescription.xml in this folder (an extracted FMU has it at its root)")
        return ["modelDescription.xml"] + [q.relative_to(path).as_posix() for sub in ("binaries", "sources")
                                           for q in (path / sub).rglob("*") if q.is_file()]
    try:
        with zipfile.ZipFile(path) as z:
            names = z.namelist()
    except zipfile.BadZipFile:
        raise FMUError(f"{path}: not a ZIP archive (an FMU is a ZIP file with modelDescription.xml "
                       "at its root)") from None
    except OSError as e:
        raise FMUError(f"{path}: cannot read it: {e.strerror or e}") from None
    if "modelDescription.xml" not in names:
        nested = [n for n in names if n.endswith("/modelDescription.xml")]
        hint = (f"; found {nested[0]}: zip the FMU's contents, not its folder" if nested
                else " (not an FMU)")
        raise FMUError(f"{path}: no modelDescription.xml at the root of the archive{hint}")
    return names


def _read(path: Path):
    """FMPy's model description; when it does not validate, read without validation and return
    the problems."""
    from fmpy.model_description import ValidationError, read_model_description
    try:
        return read_model_description(str(path), validate=True), []
    except ValidationError as e:
        problems = list(e.problems)
    except Exception as e:
        raise FMUError(f"{path}: modelDescription.xml: {_reason(e)}") from None
    try:
        return read_model_description(str(path), validate=False), problems
    except Exception as e:
        raise FMUError(f"{path}: modelDescription.xml: {_reason(e)}") from None


def _reason(e: Exception) -> str:
    return f"{type(e).__name__}: {e}" if str(e) else type(e).__name__


# ----------------------------------------------------------------------------------------------
# the content

def _typed(text: str | None, vtype: str) -> Any:
    """A start/min/max/item attribute as a JSON value of the variable's type (the text itself when
    it does not parse, e.g. an FMI 3 array start; non-finite numbers as text, JSON has none)."""
    if text is None:
        return None
    try:
        if vtype in _REAL:
            x = float(text)
            return x if math.isfinite(x) else str(x)
        if vtype in _INTEGER:
            return int(text)
        if vtype == "Boolean":
            return str(text).strip().lower() in ("true", "1")
    except ValueError:
        return text
    return text


def _variable(v) -> dict[str, Any]:
    dt = v.declaredType

    def attr(name: str):
        x = getattr(v, name, None)
        return x if x is not None else (getattr(dt, name, None) if dt is not None else None)

    row: dict[str, Any] = {
        "name": v.name, "value_reference": v.valueReference, "causality": v.causality,
        "variability": v.variability, "initial": v.initial, "type": v.type,
        "declared_type": dt.name if dt is not None else None,
        "unit": attr("unit"), "display_unit": attr("displayUnit"),
        "start": _typed(v.start, v.type), "min": _typed(attr("min"), v.type), "max": _typed(attr("max"), v.type),
        "description": v.description,
    }
    if v.type == "Enumeration":
        row["items"] = [{"value": _typed(it.value, "Integer"), "name": it.name, "description": it.description}
                        for it in (dt.items if dt is not None else [])]
    return row


def _capabilities(iface) -> dict[str, Any]:
    d: dict[str, Any] = {"modelIdentifier": iface.modelIdentifier}
    for k in _CAPABILITIES:
        if hasattr(iface, k):
            d[k] = bool(getattr(iface, k))
    return d


def interface(path: str | os.PathLike) -> dict[str, Any]:
    """Everything `anklehip info` shows about the FMU at `path` (a .fmu file or an extracted
    folder), JSON-ready: identity, platforms, default experiment, log categories, display units
    and every variable by causality. FMUError (naming the file) when it is not a readable FMU."""
    path = Path(path)
    if not path.exists():
        raise MissingFileError(f"{path}: no such file")
    names = _members(path)
    md, problems = _read(path)
    platforms = sorted({n.split("/")[1] for n in names
                        if n.startswith("binaries/") and n.count("/") >= 2 and not n.endswith("/")})
    de = md.defaultExperiment
    experiment = None
    if de is not None:
        experiment = {k: _typed(getattr(de, a), "Real") for k, a in
                      (("start_time", "startTime"), ("stop_time", "stopTime"), ("step_size", "stepSize"),
                       ("tolerance", "tolerance")) if getattr(de, a) is not None}
    units = {}
    for u in md.unitDefinitions:
        if u.displayUnits:
            units[u.name] = {d.name: {"factor": float(d.factor), "offset": float(d.offset)} for d in u.displayUnits}
    variables: dict[str, list[dict[str, Any]]] = {}
    for v in md.modelVariables:
        variables.setdefault(v.causality, []).append(_variable(v))
    return {
        "file": str(path),
        "model_name": md.modelName,
        "description": md.description,
        "fmi_version": md.fmiVersion,
        "guid": md.guid,
        "version": md.version,
        "author": md.author,
        "copyright": md.copyright,
        "license": md.license,
        "generation_tool": md.generationTool,
        "generation_date_and_time": md.generationDateAndTime,
        "platforms": platforms,
        "sources": any(n.startswith("sources/") and not n.endswith("/") for n in names),
        "co_simulation": _capabilities(md.coSimulation) if md.coSimulation is not None else None,
        "model_exchange": _capabilities(md.modelExchange) if md.modelExchange is not None else None,
        "default_experiment": experiment,
        "log_categories": [{"name": c.name, "description": c.description} for c in md.logCategories],
        "display_units": units,
        "counts": {c: len(variables.get(c, [])) for c in CAUSALITIES if variables.get(c)},
        "variables": {c: variables[c] for c in CAUSALITIES if c in variables},
        "validation_problems": problems,
    }


def name_matches(name: str, patterns: list[str]) -> bool:
    """Whether `name` matches any pattern: a glob (with * ? [) over the whole name, else a
    substring; both case-insensitive."""
    n = name.lower()
    for p in patterns:
        q = p.lower()
        if any(c in q for c in "*?[") and fnmatch.fnmatchcase(n, q):
            return True
        if not any(c in q for c in "*?[") and q in n:
            return True
    return False


def select(info: dict[str, Any], causalities: list[str] | None = None,
           names: list[str] | None = None) -> dict[str, Any]:
    """`info` with only the variables of these causalities (default: DEFAULT_CAUSALITIES; each
    asked-for causality gets a table, empty or not) whose names match `names` (name_matches)."""
    asked = list(dict.fromkeys(causalities)) if causalities else None
    keep = asked or [c for c in DEFAULT_CAUSALITIES if c in info["variables"] or c in ("parameter", "input", "output")]
    out = dict(info)
    out["variables"] = {c: [v for v in info["variables"].get(c, []) if not names or name_matches(v["name"], names)]
                        for c in CAUSALITIES if c in keep}
    out["selection"] = {"causality": keep, "name": list(names or [])}
    return out


# ----------------------------------------------------------------------------------------------
# text

def _num(x: Any) -> str:
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, float):
        s = repr(x)                   # shortest exact text: 9.81, 1e-08, 70.23854052
        return s[:-2] if s.endswith(".0") else s
    if isinstance(x, str):
        return repr(x) if x == "" else x
    return str(x)


def _start(v: dict[str, Any]) -> str:
    s = v["start"]
    if v["type"] == "String" and s is not None:
        return repr(s)
    if v.get("items") and s is not None:
        label = next((it["name"] for it in v["items"] if it["value"] == s), None)
        return f"{s} ({label})" if label else _num(s)
    return _num(s)


def _table(rows: list[dict[str, Any]]) -> list[str]:
    head = ["name", "type", "unit (display)", "start", "min", "max", "variability", "description"]
    cells = []
    for v in rows:
        unit = v["unit"] or "-"
        if v["display_unit"] and v["display_unit"] != v["unit"]:
            unit += f" ({v['display_unit']})"
        cells.append([v["name"], v["type"], unit, _start(v), _num(v["min"]), _num(v["max"]),
                      v["variability"] or "-", v["description"] or ""])
    widths = [max(len(r[i]) for r in [head] + cells) for i in range(len(head) - 1)]

    def line(r):
        return ("  " + "  ".join(c.ljust(w) for c, w in zip(r, widths)) + "  " + r[-1]).rstrip()

    out = [line(head)]
    for v, r in zip(rows, cells):
        out.append(line(r))
        if v.get("items") is not None:
            items = ", ".join(f"{it['value']}={it['name']}" for it in v["items"]) or "none"
            of = f" (type {v['declared_type']})" if v["declared_type"] else ""
            out.append(f"      items{of}: {items}")
    return out


_KINDS = (("co_simulation", "co-simulation"), ("model_exchange", "model exchange"))


def format_text(info: dict[str, Any]) -> str:
    """The text of `anklehip info`: the header, then a table per selected causality."""
    lines = [f"{Path(info['file']).name}  ({info['file']})"]

    def field(label: str, value: Any):
        if value not in (None, "", []):
            lines.append(f"  {label:<20}{value}")

    field("model name", info["model_name"])
    field("description", info["description"])
    kinds = [label for k, label in _KINDS if info[k]]
    field("FMI version", info["fmi_version"] + (f" ({', '.join(kinds)})" if kinds else ""))
    field("GUID", info["guid"])
    field("version", info["version"])
    field("author", info["author"])
    field("copyright", info["copyright"])
    field("license", info["license"])
    gen = ", ".join(x for x in (info["generation_tool"], info["generation_date_and_time"]) if x)
    field("generated by", gen)
    plats = ", ".join(info["platforms"]) or "none (no binaries/)"
    field("platforms", plats + (" + C sources (sources/)" if info["sources"] else ""))
    for k, label in _KINDS:
        caps = info[k]
        if caps:
            flags = [_CAPABILITIES[c] for c, on in caps.items() if c in _CAPABILITIES and on]
            field(label, f"model identifier {caps['modelIdentifier']}" + (f"; {', '.join(flags)}" if flags else ""))
    de = info["default_experiment"]
    if de:
        parts = [f"{lab} {_num(de[k])} s" for k, lab in (("start_time", "start"), ("stop_time", "stop"),
                                                          ("step_size", "step")) if k in de]
        if "tolerance" in de:
            parts.append(f"tolerance {_num(de['tolerance'])}")
        field("default experiment", ", ".join(parts))
    else:
        field("default experiment", "none")
    if info["display_units"]:
        field("display units", ", ".join(
            f"1 {u} = {_num(f['factor'])} {d}" + (f" + {_num(f['offset'])}" if f["offset"] else "")
            for u, ds in info["display_units"].items() for d, f in ds.items()))
    if info["log_categories"]:
        lines.append("  log categories")
        w = max(len(c["name"]) for c in info["log_categories"])
        for c in info["log_categories"]:
            lines.append(f"    {c['name']:<{w}}  {c['description'] or ''}".rstrip())
    for p in info["validation_problems"]:
        lines.append(f"  warning: modelDescription.xml does not validate: {p}")

    sel = info.get("selection", {})
    names = sel.get("name") or []
    for c, rows in info["variables"].items():
        total = info["counts"].get(c, 0)
        n = f"{len(rows)} of {total}" if names and len(rows) != total else str(len(rows))
        lines += ["", f"{TITLES[c][0].upper() + TITLES[c][1:]} ({n})"]
        if rows:
            lines += _table(rows)
        else:
            lines.append("  none" + (f" matching {', '.join(names)}" if names and total else ""))
    hidden = {c: k for c, k in info["counts"].items() if c not in info["variables"]}
    if hidden:
        lines += ["", "not shown: " + ", ".join(f"{k} {TITLES[c] if k != 1 else TITLES[c].removesuffix('s')}"
                                                for c, k in hidden.items())
                  + " (choose with --causality)"]
    return "\n".join(lines)


def signal_units(fmu_dir: str | os.PathLike | None = None) -> dict[str, str]:
    """The unit of every Real variable of the package's FMUs, by name as a result's column is named
    (a controller output also as ``controller.<name>``): what a figure labels its axes with when it
    has only a CSV. Best effort: {} for FMUs that are not found."""
    from .paths import FMUS, MissingFileError
    key = str(fmu_dir) if fmu_dir else ""
    if key in _UNITS:
        return _UNITS[key]
    units: dict[str, str] = {}
    for f in FMUS:
        try:
            md, _ = _read(find_fmu(f, fmu_dir))
        except (MissingFileError, FMUError):
            continue
        for v in md.modelVariables:
            u = getattr(v, "unit", None) or (getattr(v.declaredType, "unit", None) if v.declaredType else None)
            if v.type in _REAL and u:
                units.setdefault(v.name, u)
                if f.startswith("AnkleHip"):
                    units.setdefault("controller." + v.name, u)
    _UNITS[key] = units
    return units


_UNITS: dict[str, dict[str, str]] = {}
