"""Where things live: the repository root, the scenarios, the packed FMUs, native tools.

FMUs are looked up in the folder(s) named by the environment variable ``ANKLEHIP_FMU_DIR``
(several folders may be given, separated by ``os.pathsep``), else in ``<repo>/build/fmus``
(``<build>/fmus`` with ``ANKLEHIP_BUILD_DIR`` when that is set), the folder that
``bash scripts/setup.sh`` fills; the FMI 3.0 twins in the ``fmi3/`` folder inside each.
"""
from __future__ import annotations

import os
from pathlib import Path

CONTROLLER_FMU = "AnkleHipController.fmu"
PLANT_FMU = "Hoap2Plant.fmu"
# The plant models a scenario may name (key plant_model, CLI --plant): the sagittal plant (CVODE)
# and the 3D plant on the Open Dynamics Engine (docs/plant3d.md).
PLANT_FMUS = {"sagittal": PLANT_FMU, "3d": "Hoap2Plant3D.fmu"}
RT_RUNNER = "anklehip_rt_step"


class MissingFileError(FileNotFoundError):
    """A file the package needs (FMU, executable, scenario) is not there."""


def repo_root() -> Path:
    """The repository root: the folder above the package when it holds pyproject.toml
    (editable install / source checkout), else ANKLEHIP_ROOT, else the working directory."""
    env = os.environ.get("ANKLEHIP_ROOT")
    if env:
        return Path(env).resolve()
    here = Path(__file__).resolve().parent.parent
    if (here / "pyproject.toml").is_file() and (here / "scenarios").is_dir():
        return here
    return Path.cwd()


def build_dir() -> Path:
    env = os.environ.get("ANKLEHIP_BUILD_DIR")
    if env:
        p = Path(env)
        return p if p.is_absolute() else repo_root() / p
    return repo_root() / "build"


def fmu_dirs() -> list[Path]:
    env = os.environ.get("ANKLEHIP_FMU_DIR")
    if env:
        return [Path(p) for p in env.split(os.pathsep) if p]
    return [build_dir() / "fmus"]


FMI_VERSIONS = (2, 3)


def find_fmu(filename: str, fmu_dir: str | os.PathLike | None = None, fmi: int = 2) -> Path:
    """Path of a packed FMU; a clear error naming the file and the fix when it is missing. fmi=3:
    its FMI 3.0 twin, in the fmi3/ folder beside the FMI 2.0 FMUs (the build's layout)."""
    if fmi not in FMI_VERSIONS:
        raise ValueError(f"FMI version {fmi!r}: one of {', '.join(map(str, FMI_VERSIONS))}")
    dirs = [Path(fmu_dir)] if fmu_dir else fmu_dirs()
    if fmi == 3:
        dirs = [d / "fmi3" for d in dirs]
    for d in dirs:
        p = d / filename
        if p.is_file():
            return p
    where = ", ".join(str(d) for d in dirs)
    raise MissingFileError(
        f"{filename} not found in {where}. Build the FMUs with `bash scripts/setup.sh` "
        f"(or point ANKLEHIP_FMU_DIR at the folder that holds {filename}).")


def scenarios_dir() -> Path:
    return repo_root() / "scenarios"


def _find_toml(name_or_path: str, folder: Path, what: str, hint: str = "") -> Path:
    """A TOML file given by name (<folder>/<name>.toml) or by path; a clear error naming what is known."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.parent != Path("."):
        if p.is_file():
            return p
        raise MissingFileError(f"{what} file {p} not found")
    cand = folder / f"{name_or_path}.toml"
    if cand.is_file():
        return cand
    known = ", ".join(sorted(q.stem for q in folder.glob("*.toml"))) or "none"
    raise MissingFileError(f"no {what} named {name_or_path!r} in {folder} (known: {known}){hint}")


def find_scenario(name_or_path: str) -> Path:
    """A scenario given by name (scenarios/<name>.toml) or by path."""
    return _find_toml(name_or_path, scenarios_dir(), "scenario")


def find_sweep_file(name_or_path: str) -> Path:
    """A sweep file given by name (scenarios/sweeps/<name>.toml) or by path."""
    return _find_toml(name_or_path, scenarios_dir() / "sweeps", "sweep file", "; a scenario needs --forces")



def find_rt_runner() -> Path | None:
    """The native real-time step-test executable (fmu/rt_runner) in the build folder
    ($ANKLEHIP_BUILD_DIR, default <repo>/build), or $ANKLEHIP_RT_STEP; None if not built."""
    env = os.environ.get("ANKLEHIP_RT_STEP")
    if env and Path(env).is_file():
        return Path(env)
    for root in [build_dir()]:
        for cand in (root / "fmu" / "rt_runner" / RT_RUNNER, root / "bin" / RT_RUNNER, root / RT_RUNNER):
            if cand.is_file() and os.access(cand, os.X_OK):
                return cand
    return None
