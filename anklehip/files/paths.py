"""Where things are: scenarios, sweep files, step-test cases, the packed FMUs and native tools.

Each is looked up in this order (docs/python-api.md, "Where anklehip finds things"):

1. an explicit argument: a path, ``fmu_dir=`` / ``--fmu-dir``;
2. environment variables: ``ANKLEHIP_FMU_DIR`` (FMU folders, separated by ``os.pathsep``),
   ``ANKLEHIP_NATIVE_LIB`` and ``ANKLEHIP_RT_STEP`` (native tools), ``ANKLEHIP_ROOT`` (a checkout:
   its ``scenarios/``, ``tests/steptests/`` and ``build/``), ``ANKLEHIP_BUILD_DIR`` (its build folder);
3. the checkout this package runs from (an editable install: ``<repo>/scenarios``,
   ``<repo>/build/fmus``);
4. the installed package's own data (the wheel: ``anklehip/data/``).
"""
from __future__ import annotations

import difflib
import os
from pathlib import Path

from ..errors import InputError

CONTROLLER_FMU = "AnkleHipController.fmu"
PLANT_FMU = "Hoap2Plant.fmu"
# The plant models a scenario may name (key plant_model, CLI --plant): the sagittal plant (CVODE)
# and the 3D plant on the Open Dynamics Engine (docs/plant3d.md).
PLANT_FMUS = {"sagittal": PLANT_FMU, "3d": "Hoap2Plant3D.fmu"}
# The controller models (key controller_model, CLI --controller-model): the paper's sagittal controller
# and the controller for a robot in 3D, with the frontal plane (docs/controller.md section 11); the
# 3D controller needs the 3D plant's signals.
CONTROLLER_FMUS = {"sagittal": CONTROLLER_FMU, "3d": "AnkleHipController3D.fmu"}
FMUS = (*CONTROLLER_FMUS.values(), *PLANT_FMUS.values())
# The model names (modelIdentifier, file stem) of every FMU the project ships: the one list the wheel
# (setup.py) and every FMI check in tests/ and scripts/ iterate over, so a new FMU joins them all.
SHIPPED = tuple(f.removesuffix(".fmu") for f in FMUS)
# The FMI 3.0 Scheduled Execution variants, <fmu dir>/fmi3/<name>_se.fmu (x86_64-linux; docs/fmu.md):
# the models of SHIPPED that declare a clock. The FMI 3.0 checks that apply iterate over them too.
SCHEDULED_EXECUTION = ("AnkleHipController", "AnkleHipController3D")
RT_RUNNER = "anklehip_rt_step"
NATIVE_LIBRARY = "libanklehip_closed_loop.so"

_PACKAGE = Path(__file__).resolve().parents[1]


class MissingFileError(InputError, FileNotFoundError):
    """A file the package needs (FMU, executable, scenario) is not there."""


def checkout_root() -> Path | None:
    """The checkout whose files are used: $ANKLEHIP_ROOT, else the source tree this package runs
    from (it holds pyproject.toml and scenarios/), else None (an installed wheel)."""
    env = os.environ.get("ANKLEHIP_ROOT")
    if env:
        p = Path(env).resolve()
        if not p.is_dir():
            raise MissingFileError(f"ANKLEHIP_ROOT={env}: no such folder (it names a checkout of the project)")
        return p
    here = _PACKAGE.parent
    if (here / "pyproject.toml").is_file() and (here / "scenarios").is_dir():
        return here
    return None


def package_data() -> Path | None:
    """The installed package's data folder (FMUs, scenarios, step-test cases, the native engine),
    None when the package has none (a checkout)."""
    d = _PACKAGE / "data"
    return d if d.is_dir() else None


def repo_root() -> Path:
    """The checkout (checkout_root), else the working directory."""
    return checkout_root() or Path.cwd()


def build_dir() -> Path | None:
    """The checkout's native build folder: $ANKLEHIP_BUILD_DIR (relative to the checkout), else
    <checkout>/build; None without a checkout."""
    root = checkout_root()
    env = os.environ.get("ANKLEHIP_BUILD_DIR")
    if env:
        p = Path(env)
        return p if p.is_absolute() else (root or Path.cwd()) / p
    return root / "build" if root else None


def _data_folder(checkout_sub: str, package_sub: str, what: str) -> Path:
    root = checkout_root()
    if root is not None:
        return root / checkout_sub
    data = package_data()
    if data is not None:
        return data / package_sub
    raise MissingFileError(f"no {what}: this anklehip has neither a checkout nor package data; set ANKLEHIP_ROOT "
                           "to a checkout of the project, or install the wheel")


def scenarios_dir() -> Path:
    """The scenarios: <checkout>/scenarios, else the package's data/scenarios."""
    return _data_folder("scenarios", "scenarios", "scenarios")


def steptests_dir() -> Path:
    """The recorded step-test cases: <checkout>/tests/steptests, else the package's data/steptests."""
    return _data_folder("tests/steptests", "steptests", "step-test cases")


def source_of(path: Path) -> str:
    """'package' when `path` lies in the installed package's data, else 'checkout'."""
    data = package_data()
    try:
        if data is not None:
            Path(path).resolve().relative_to(data)
            return "package"
    except ValueError:
        pass
    return "checkout"


def fmu_dirs(fmu_dir: str | os.PathLike | None = None) -> list[Path]:
    """The folders searched for FMUs, in order: `fmu_dir` alone when given (it must exist), else
    $ANKLEHIP_FMU_DIR, else <build>/fmus of the checkout and the package's data/fmus."""
    if fmu_dir:
        d = Path(fmu_dir)
        if not d.is_dir():
            raise MissingFileError(f"--fmu-dir {fmu_dir}: " + ("not a folder" if d.exists() else "no such folder"))
        return [d]
    env = os.environ.get("ANKLEHIP_FMU_DIR")
    if env:
        return [Path(p) for p in env.split(os.pathsep) if p]
    dirs = []
    b = build_dir()
    if b is not None:
        dirs.append(b / "fmus")
    data = package_data()
    if data is not None:
        dirs.append(data / "fmus")
    return dirs


FMI_VERSIONS = (2, 3)


def find_fmu(filename: str, fmu_dir: str | os.PathLike | None = None, fmi: int = 2) -> Path:
    """Path of a packed FMU; a clear error naming the folders tried and the fix when it is missing.
    fmi=3: its FMI 3.0 twin, in the fmi3/ folder beside the FMI 2.0 FMUs (the build's layout)."""
    if fmi not in FMI_VERSIONS:
        raise ValueError(f"FMI version {fmi!r}: one of {', '.join(map(str, FMI_VERSIONS))}")
    dirs = fmu_dirs(fmu_dir)
    if fmi == 3:
        dirs = [d / "fmi3" for d in dirs]
    for d in dirs:
        p = d / filename
        if p.is_file():
            return p
        if p.is_dir():
            raise MissingFileError(f"{p} is a folder, not an FMU: an FMU is one zip file named {filename} (an "
                                   "extracted FMU is not looked up; zip it or rebuild the FMUs with "
                                   "`bash scripts/setup.sh`)")
    where = ", ".join(str(d) for d in dirs) or "no folder (no checkout, no package data)"
    raise MissingFileError(
        f"{filename} not found in {where}. Build the FMUs with `bash scripts/setup.sh` in a checkout, "
        f"install the anklehip wheel, or point --fmu-dir / ANKLEHIP_FMU_DIR at the folder that holds {filename}.")


def _find_toml(name_or_path: str, folder: Path, what: str, hint: str = "") -> Path:
    """A TOML file given by name (<folder>/<name>.toml) or by path; a clear error naming what is
    known, with the nearest names when it is a typo."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.parent != Path("."):
        if p.is_file():
            return p
        raise MissingFileError(f"{what} file {p} not found")
    cand = folder / f"{name_or_path}.toml"
    if cand.is_file():
        return cand
    names = sorted(q.stem for q in folder.glob("*.toml"))
    near = difflib.get_close_matches(name_or_path, names, n=3, cutoff=0.6)
    mean = f"; did you mean {' or '.join(near)}?" if near else ""
    raise MissingFileError(f"no {what} named {name_or_path!r} in {folder}{mean} (known: {', '.join(names) or 'none'})"
                           f"{hint}")


def find_scenario(name_or_path: str) -> Path:
    """A scenario given by name (scenarios/<name>.toml) or by path."""
    return _find_toml(name_or_path, scenarios_dir(), "scenario")


def scenarios() -> list[str]:
    """The names of the scenarios (scenarios_dir()), e.g. for anklehip.run(name)."""
    return sorted(p.stem for p in scenarios_dir().glob("*.toml"))


def fmu_path(model: str, fmu_dir: str | os.PathLike | None = None) -> Path:
    """The packed FMU of a model, e.g. fmu_path("AnkleHipController") for your own tool."""
    return find_fmu(model if model.endswith(".fmu") else f"{model}.fmu", fmu_dir)


def find_sweep_file(name_or_path: str) -> Path:
    """A sweep file given by name (scenarios/sweeps/<name>.toml) or by path."""
    return _find_toml(name_or_path, scenarios_dir() / "sweeps", "sweep file", "; a scenario needs --forces")


def find_steptest_case(name_or_path: str | os.PathLike) -> Path:
    """A step-test case folder given by path, or by name (a folder of steptests_dir())."""
    p = Path(name_or_path)
    if p.is_dir() or p.parent != Path(".") or p.exists():
        return p
    folder = steptests_dir()
    if (folder / p).is_dir():
        return folder / p
    names = sorted(q.name for q in folder.glob("*") if q.is_dir())
    near = difflib.get_close_matches(str(p), names, n=3, cutoff=0.6)
    mean = f"; did you mean {' or '.join(near)}?" if near else ""
    raise MissingFileError(f"{p}: no such case folder here, and no step-test case of that name in {folder}{mean} "
                           f"(known: {', '.join(names) or 'none'})")


def native_library() -> Path | None:
    """The native closed-loop engine's library: $ANKLEHIP_NATIVE_LIB, else the checkout's build,
    else the package's data/lib; None when there is none."""
    env = os.environ.get("ANKLEHIP_NATIVE_LIB")
    if env:
        return Path(env)
    b = build_dir()
    cands = [b / "fmu" / "closed_loop" / NATIVE_LIBRARY] if b is not None else []
    data = package_data()
    if data is not None:
        cands.append(data / "lib" / NATIVE_LIBRARY)
    return next((c for c in cands if c.is_file()), cands[0] if cands else None)


def find_rt_runner() -> Path | None:
    """The native real-time step-test executable (fmu/rt_runner) in the checkout's build folder,
    or $ANKLEHIP_RT_STEP; None if not built (the wheel does not ship it)."""
    env = os.environ.get("ANKLEHIP_RT_STEP")
    if env and Path(env).is_file():
        return Path(env)
    root = build_dir()
    if root is None:
        return None
    for cand in (root / "fmu" / "rt_runner" / RT_RUNNER, root / "bin" / RT_RUNNER, root / RT_RUNNER):
        if cand.is_file() and os.access(cand, os.X_OK):
            return cand
    return None


def locations(fmu_dir: str | os.PathLike | None = None) -> dict[str, str | None]:
    """Where this anklehip takes things from (what `anklehip where` prints): the checkout, the
    package data, the scenarios, the step-test cases, each FMU, the native engine and the
    real-time runner; None for what is not there."""
    def attempt(fn):
        try:
            p = fn()
            return str(p) if p is not None and Path(p).exists() else None
        except MissingFileError:
            return None
    out: dict[str, str | None] = {
        "checkout": attempt(checkout_root), "package data": attempt(package_data),
        "scenarios": attempt(scenarios_dir), "step-test cases": attempt(steptests_dir)}
    for f in FMUS:
        out[f] = attempt(lambda f=f: find_fmu(f, fmu_dir))
    out["native engine"] = attempt(native_library)
    out["real-time runner"] = attempt(find_rt_runner)
    return out
