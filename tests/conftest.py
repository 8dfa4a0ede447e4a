"""Shared pytest fixtures: where the built FMUs and native tools are, and a thin ctypes wrapper
around an FMU binary for low-level FMI 2.0 calls (state-machine and serialization tests).

FMUs: ``$ANKLEHIP_FMU_DIR`` (first of several folders separated by os.pathsep that exists), else
``<repo>/build/fmus``. Native tools: ``$ANKLEHIP_BUILD_DIR`` (default ``<repo>/build``). Nothing is
skipped silently: a missing FMU or tool fails the test with the command that builds it.
"""
from __future__ import annotations

import ctypes
import os
import zipfile
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent
BUILD_HINT = "run `bash scripts/setup.sh` (or point ANKLEHIP_FMU_DIR / ANKLEHIP_BUILD_DIR at your build)"


def _build_dir() -> Path:
    env = os.environ.get("ANKLEHIP_BUILD_DIR")
    if env:
        p = Path(env)
        return p if p.is_absolute() else REPO_ROOT / p
    return REPO_ROOT / "build"


def _fmu_dirs() -> list[Path]:
    env = os.environ.get("ANKLEHIP_FMU_DIR")
    if env:
        return [Path(p) for p in env.split(os.pathsep) if p]
    return [_build_dir() / "fmus"]


@pytest.fixture(scope="session")
def build_dir() -> Path:
    """The native build folder (ANKLEHIP_BUILD_DIR, default <repo>/build)."""
    d = _build_dir()
    if not d.is_dir():
        pytest.fail(f"build folder {d} does not exist: {BUILD_HINT}")
    return d


@pytest.fixture(scope="session")
def fmu_dir() -> Path:
    """Folder with the packed FMUs (ANKLEHIP_FMU_DIR, default <repo>/build/fmus)."""
    for d in _fmu_dirs():
        if d.is_dir() and any(d.glob("*.fmu")):
            return d
    pytest.fail(f"no packed FMUs in {', '.join(map(str, _fmu_dirs()))}: {BUILD_HINT}")


@pytest.fixture(scope="session")
def fmu_path(fmu_dir):
    """fmu_path('AnkleHipController') -> Path of the packed .fmu, failing clearly if missing."""

    def find(name: str) -> Path:
        for d in [fmu_dir] + _fmu_dirs():
            p = d / f"{name}.fmu"
            if p.is_file():
                return p
        pytest.fail(f"{name}.fmu not found in {fmu_dir}: {BUILD_HINT}")

    return find


@pytest.fixture(scope="session")
def native_tool(build_dir):
    """native_tool('ahc_csv_driver') -> Path of an executable built somewhere under the build dir."""

    def find(name: str) -> Path:
        hits = [p for p in build_dir.rglob(name) if p.is_file() and os.access(p, os.X_OK)]
        if not hits:
            pytest.fail(f"native tool {name} not found under {build_dir}: {BUILD_HINT}")
        return sorted(hits, key=lambda p: len(p.parts))[0]

    return find


@pytest.fixture(scope="session")
def controller_fmu(fmu_path) -> Path:
    return fmu_path("AnkleHipController")


def _unzip(fmu: Path, tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp(fmu.stem)
    with zipfile.ZipFile(fmu) as z:
        z.extractall(d)
    return d


@pytest.fixture(scope="session")
def controller_unzipped(controller_fmu, tmp_path_factory) -> Path:
    return _unzip(controller_fmu, tmp_path_factory)


@pytest.fixture(scope="session")
def plant_fmu(fmu_path) -> Path:
    return fmu_path("Hoap2Plant")


@pytest.fixture(scope="session")
def plant_unzipped(plant_fmu, tmp_path_factory) -> Path:
    return _unzip(plant_fmu, tmp_path_factory)


# ---------------------------------------------------------------------------------------------
# Low-level ctypes access to an FMU binary (no FMPy wrapper, so every status is visible).

fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending = range(6)
fmi2CoSimulation = 1

LOGGER = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_char_p)
ALLOC = ctypes.CFUNCTYPE(ctypes.c_void_p, ctypes.c_size_t, ctypes.c_size_t)
FREE = ctypes.CFUNCTYPE(None, ctypes.c_void_p)
STEPFINISHED = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_int)


class CallbackFunctions(ctypes.Structure):
    _fields_ = [("logger", LOGGER), ("allocateMemory", ALLOC), ("freeMemory", FREE),
                ("stepFinished", STEPFINISHED), ("componentEnvironment", ctypes.c_void_p)]


_libc = ctypes.CDLL(None)
_libc.calloc.restype = ctypes.c_void_p
_libc.calloc.argtypes = [ctypes.c_size_t, ctypes.c_size_t]
_libc.free.argtypes = [ctypes.c_void_p]


class RawInstance:
    """One FMU instance driven through ctypes; every call returns the raw fmi2Status and the
    logged messages are collected in .log as (status, category, message)."""

    def __init__(self, lib, md, name="inst", guid=None, logging_on=True, fmu_type=fmi2CoSimulation):
        self.lib, self.md = lib, md
        self.log: list[tuple[int, str, str]] = []

        def logger(env, inst, status, category, message):
            self.log.append((status, (category or b"").decode(), (message or b"").decode().replace("%%", "%")))

        self._logger = LOGGER(logger)
        self._alloc = ALLOC(lambda n, s: _libc.calloc(n, s))
        self._free = FREE(lambda p: _libc.free(p))
        self._cb = CallbackFunctions(self._logger, self._alloc, self._free, STEPFINISHED(), None)
        self.c = lib.fmi2Instantiate(name.encode() if name is not None else None, fmu_type,
                                     (guid if guid is not None else md.guid).encode(), b"file:///tmp",
                                     ctypes.byref(self._cb), 0, 1 if logging_on else 0)

    def __getattr__(self, fn):  # inst.fmi2DoStep(t, h, 1) -> lib.fmi2DoStep(c, t, h, 1)
        f = getattr(self.lib, fn)
        return lambda *a: f(self.c, *a)

    def vr(self, name):
        return self.md.vars[name].valueReference

    def set_real(self, names_values):
        vrs = (ctypes.c_uint * len(names_values))(*[self.vr(n) for n in names_values])
        vals = (ctypes.c_double * len(names_values))(*names_values.values())
        return self.lib.fmi2SetReal(self.c, vrs, len(names_values), vals)

    def get_real(self, names):
        vrs = (ctypes.c_uint * len(names))(*[self.vr(n) for n in names])
        vals = (ctypes.c_double * len(names))()
        st = self.lib.fmi2GetReal(self.c, vrs, len(names), vals)
        return st, list(vals)

    def set_integer(self, names_values):
        vrs = (ctypes.c_uint * len(names_values))(*[self.vr(n) for n in names_values])
        vals = (ctypes.c_int * len(names_values))(*names_values.values())
        return self.lib.fmi2SetInteger(self.c, vrs, len(names_values), vals)

    def get_integer(self, names):
        vrs = (ctypes.c_uint * len(names))(*[self.vr(n) for n in names])
        vals = (ctypes.c_int * len(names))()
        st = self.lib.fmi2GetInteger(self.c, vrs, len(names), vals)
        return st, list(vals)

    def errors(self):
        return [m for s, c, m in self.log if s >= fmi2Error]

    def free(self):
        if self.c:
            self.lib.fmi2FreeInstance(self.c)
            self.c = None


class RawModel:
    def __init__(self, unzipdir: Path):
        from fmpy import read_model_description

        d = read_model_description(str(unzipdir))
        self.guid = d.guid
        self.identifier = d.coSimulation.modelIdentifier
        self.vars = {v.name: v for v in d.modelVariables}
        self.description = d
        so = unzipdir / "binaries" / "linux64" / f"{self.identifier}.so"
        self.lib = ctypes.CDLL(str(so))
        L = self.lib
        c, u, d_, i, sz = ctypes.c_void_p, ctypes.c_uint, ctypes.c_double, ctypes.c_int, ctypes.c_size_t
        P = ctypes.POINTER
        L.fmi2Instantiate.restype = c
        L.fmi2Instantiate.argtypes = [ctypes.c_char_p, i, ctypes.c_char_p, ctypes.c_char_p, c, i, i]
        L.fmi2FreeInstance.argtypes = [c]
        L.fmi2FreeInstance.restype = None
        L.fmi2SetupExperiment.argtypes = [c, i, d_, d_, i, d_]
        for f in ("fmi2EnterInitializationMode", "fmi2ExitInitializationMode", "fmi2Terminate", "fmi2Reset",
                  "fmi2CancelStep"):
            getattr(L, f).argtypes = [c]
        L.fmi2SetDebugLogging.argtypes = [c, i, sz, P(ctypes.c_char_p)]
        for t, ct in (("Real", d_), ("Integer", i), ("Boolean", i), ("String", ctypes.c_char_p)):
            getattr(L, f"fmi2Get{t}").argtypes = [c, P(u), sz, P(ct)]
            getattr(L, f"fmi2Set{t}").argtypes = [c, P(u), sz, P(ct)]
        L.fmi2DoStep.argtypes = [c, d_, d_, i]
        L.fmi2GetFMUstate.argtypes = [c, P(c)]
        L.fmi2SetFMUstate.argtypes = [c, c]
        L.fmi2FreeFMUstate.argtypes = [c, P(c)]
        L.fmi2SerializedFMUstateSize.argtypes = [c, c, P(sz)]
        L.fmi2SerializeFMUstate.argtypes = [c, c, ctypes.c_char_p, sz]
        L.fmi2DeSerializeFMUstate.argtypes = [c, ctypes.c_char_p, sz, P(c)]
        L.fmi2GetStatus.argtypes = [c, i, P(i)]
        L.fmi2GetRealStatus.argtypes = [c, i, P(d_)]
        L.fmi2GetIntegerStatus.argtypes = [c, i, P(i)]
        L.fmi2GetBooleanStatus.argtypes = [c, i, P(i)]
        L.fmi2GetStringStatus.argtypes = [c, i, P(ctypes.c_char_p)]
        L.fmi2GetTypesPlatform.restype = ctypes.c_char_p
        L.fmi2GetVersion.restype = ctypes.c_char_p

    def instance(self, **kw) -> RawInstance:
        return RawInstance(self.lib, self, **kw)


@pytest.fixture(scope="session")
def raw_controller(controller_unzipped) -> RawModel:
    return RawModel(controller_unzipped)


# ---------------------------------------------------------------------------------------------
# Sensor signals for the controller FMU: a push on the back through a quasi-static sensor model.

def push_force(t, peak=9.0, t_on=0.2, rise=0.4, t_off=1.2, fall=0.4):
    """Trapezoidal push [N] on the back: 0 -> peak over `rise` from t_on, held, back to 0 from t_off."""
    import numpy as np

    t = np.asarray(t, dtype=float)
    up = np.clip((t - t_on) / rise, 0.0, 1.0)
    down = np.clip((t - t_off) / fall, 0.0, 1.0)
    return peak * (up - down)


def sensor_signals(times, peak=9.0):
    """Quasi-static HOAP-2 sensor model (sagittal): the push F at h = 0.335 m above the sole shifts
    the ZMP by F h / (m g) and the compliant ankle leans by F h / Ka; the hip stays erect; the normal
    force is the weight. Returns a structured array (time, theta_ankle, theta_hip, zmp_x, fz)."""
    import numpy as np

    m, g, h, ka = 7.16, 9.81, 0.335, 40.0
    t = np.asarray(times, dtype=float)
    f = push_force(t, peak=peak)
    rows = np.zeros(t.size, dtype=[("time", float), ("theta_ankle", float), ("theta_hip", float),
                                   ("zmp_x", float), ("fz", float)])
    rows["time"] = t
    rows["theta_ankle"] = f * h / ka
    rows["theta_hip"] = 0.0
    rows["zmp_x"] = f * h / (m * g) + 0.01 * (m - 6.5) / m  # + the feet's small offset
    rows["fz"] = m * g
    return rows


def write_csv(path, rows):
    """CSV with a header and repr-exact numbers (FMPy's read_csv reads them back bit for bit)."""
    names = rows.dtype.names
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        for r in rows:
            f.write(",".join(repr(float(r[n])) for n in names) + "\n")
    return path


def read_csv_exact(path):
    import numpy as np

    return np.genfromtxt(path, delimiter=",", names=True, dtype=float)


CONTROLLER_OUTPUTS = ["theta_ankle_ref", "theta_hip_ref", "dtheta_ankle_ref", "dtheta_hip_ref", "phase", "com_x",
                      "com_z", "disturbance_moment", "k_w", "com_x_desired", "fault"]


@pytest.fixture(scope="session")
def glue_test_fmu(build_dir) -> Path:
    """The test-only GlueTestModel.fmu (fmu/common/tests), packed into <build>/test-fmus."""
    p = build_dir / "test-fmus" / "GlueTestModel.fmu"
    if not p.is_file():
        pytest.fail(f"{p} not found: {BUILD_HINT}")
    return p


@pytest.fixture(scope="session")
def raw_glue_model(glue_test_fmu, tmp_path_factory) -> RawModel:
    d = tmp_path_factory.mktemp("GlueTestModel")
    with zipfile.ZipFile(glue_test_fmu) as z:
        z.extractall(d)
    return RawModel(d)
