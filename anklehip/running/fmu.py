"""Loading FMUs with FMPy: extract once, read the model description, instantiate co-simulation
slaves, apply parameter overrides, and fast (allocation-free) ctypes access for inner loops.

FMI 2.0 and FMI 3.0 FMUs alike (the FMI 3.0 twins, docs/fmu.md "FMI 3.0"): an FMI 3.0 FMU's
variables carry the FMI 2.0 type names here (Float64 -> Real, Int32 -> Integer; Enumeration and
Boolean as they are), and its Slave offers the same raw entry points as an FMI 2.0 one."""
from __future__ import annotations

import atexit
import collections
import ctypes
import math
import os
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from ..errors import InputError

# FMI 2.0 status codes and status kinds
OK, WARNING, DISCARD, ERROR, FATAL, PENDING = range(6)
STATUS_NAMES = ["OK", "Warning", "Discard", "Error", "Fatal", "Pending"]
FMI2_LAST_SUCCESSFUL_TIME = 2
FMI2_TERMINATED = 3


class FMUError(InputError, RuntimeError):
    """An FMU that does not load, does not fit, or refuses a value; the message names the FMU and why."""


@dataclass(frozen=True)
class Var:
    name: str
    vr: int
    type: str            # Real | Integer | Boolean | String | Enumeration
    causality: str
    variability: str
    start: Any
    unit: str | None
    description: str | None
    min: float | None = None     # the modelDescription's range (inclusive), None: unbounded
    max: float | None = None


class FMUInfo:
    """A packed FMU, extracted once per process; variables by name."""

    _cache: dict[tuple[str, float], "FMUInfo"] = {}

    def __init__(self, path: Path):
        self.path = Path(path)
        self.md = read_model_description(str(self.path))
        if self.md.coSimulation is None:
            raise FMUError(f"{self.path.name}: not a co-simulation FMU")
        self.model_identifier = self.md.coSimulation.modelIdentifier
        self.unzipdir = extract(str(self.path))
        self._configurations: dict[str, dict[str, Any]] | None = None
        atexit.register(shutil.rmtree, self.unzipdir, True)
        self.fmi_version = 3 if str(self.md.fmiVersion).startswith("3") else 2
        self.vars: dict[str, Var] = {}
        for v in self.md.modelVariables:
            if v.causality == "independent":      # FMI 3.0's `time`: not a signal of the loop
                continue
            if getattr(v, "dimensions", None):     # an FMI 3.0 array: a view of scalars the loop has (docs/fmu.md)
                continue
            start = v.start
            vtype = FMI3_TYPES.get(v.type, v.type)
            if start is not None:
                if vtype == "Real":
                    start = float(start)
                elif vtype in ("Integer", "Enumeration"):
                    start = int(start)
                elif vtype == "Boolean":
                    start = str(start).lower() in ("true", "1")
            unit = v.unit if vtype == "Real" else None
            if unit is None and vtype == "Real" and v.declaredType is not None:
                unit = getattr(v.declaredType, "unit", None)
            self.vars[v.name] = Var(v.name, v.valueReference, vtype, v.causality, v.variability,
                                    start, unit, v.description, _bound(v, "min"), _bound(v, "max"))

    @classmethod
    def load(cls, path: str | os.PathLike) -> "FMUInfo":
        path = Path(path).resolve()
        try:
            key = (str(path), path.stat().st_mtime)
            if key not in cls._cache:
                cls._cache[key] = cls(path)
        except FMUError:
            raise
        except Exception as e:   # a missing, unreadable or corrupt file (zip, XML) is not an FMU
            raise FMUError(f"{path}: not a readable FMU: {type(e).__name__}: {e}") from None
        return cls._cache[key]

    @property
    def name(self) -> str:
        return self.path.name

    def by_causality(self, causality: str) -> list[Var]:
        return [v for v in self.vars.values() if v.causality == causality]

    def parameters(self) -> dict[str, Var]:
        return {v.name: v for v in self.vars.values() if v.causality == "parameter"}

    def constants(self) -> dict[str, Any]:
        """The constant outputs and their values: numbers of the model (e.g. Hoap2Plant3D's
        robot numbers that the controller's model needs, named after its parameters)."""
        return {v.name: v.start for v in self.vars.values()
                if v.causality == "output" and v.variability == "constant" and v.start is not None}

    def start_values(self) -> dict[str, Any]:
        return {v.name: v.start for v in self.vars.values() if v.start is not None}

    def var(self, name: str) -> Var:
        try:
            return self.vars[name]
        except KeyError:
            raise FMUError(f"{self.name} has no variable {name!r}") from None

    def default_step(self) -> float | None:
        de = self.md.defaultExperiment
        return float(de.stepSize) if de is not None and de.stepSize else None

    def configurations(self) -> dict[str, dict[str, Any]]:
        """Named parameter configurations shipped in resources/configurations.toml (generated from
        the model's own code): name -> {"description": str, parameter: value, ...}."""
        if self._configurations is None:
            import tomllib
            f = Path(self.unzipdir) / "resources" / "configurations.toml"
            try:
                self._configurations = tomllib.loads(f.read_text()) if f.is_file() else {}
            except (OSError, tomllib.TOMLDecodeError) as e:
                raise FMUError(f"{self.name}: resources/configurations.toml is unreadable: {e}") from None
        return self._configurations

    def configuration(self, name: str, origin: str = "") -> dict[str, Any]:
        """The parameter values of the named configuration (those that differ from the defaults)."""
        confs = self.configurations()
        if name not in confs:
            src = f" ({origin})" if origin else ""
            known = ", ".join(confs) or "none"
            raise FMUError(f"{self.name} has no configuration {name!r}{src}; known: {known}")
        return {k: v for k, v in confs[name].items() if k != "description"}

    def check_overrides(self, overrides: dict[str, Any], origin: str = "") -> None:
        """Every override names a parameter and has its type, a finite value and a value inside
        the range of the modelDescription; else an FMUError naming the parameter, the value, the
        allowed values and `origin` (where the value came from)."""
        params = self.parameters()
        for k, val in overrides.items():
            src = f" ({origin})" if origin else ""
            if k not in params:
                near = [p for p in params if p.lower() == k.lower() or k.lower() in p.lower()]
                hint = f"; did you mean {', '.join(near[:4])}?" if near else ""
                raise FMUError(f"{self.name} has no parameter {k!r}{src}{hint}")
            v = params[k]
            if v.variability == "constant":
                raise FMUError(f"{self.name}: parameter {k!r} is a constant{src}")
            if v.type == "Boolean":
                if not isinstance(val, bool) and val not in (0, 1):
                    raise FMUError(f"{self.name}: parameter {k!r} is Boolean, got {val!r}{src}")
                continue
            if v.type == "Real" and isinstance(val, bool):
                raise FMUError(f"{self.name}: parameter {k!r} is Real, got boolean {val}{src}")
            if not isinstance(val, (bool, int, float)):
                raise FMUError(f"{self.name}: parameter {k!r} is {v.type}, got {type(val).__name__} {val!r}{src}")
            if isinstance(val, float) and not math.isfinite(val):
                raise FMUError(f"{self.name}: parameter {k!r} must be finite, got {val}{src}")
            if v.type in ("Integer", "Enumeration") and isinstance(val, float) and not val.is_integer():
                raise FMUError(f"{self.name}: parameter {k!r} is Integer, got {val!r}{src}")
            lo, hi = v.min, v.max
            if v.type in ("Integer", "Enumeration"):    # fmi2Integer is a 32-bit int
                lo = max(lo, INT32_MIN) if lo is not None else INT32_MIN
                hi = min(hi, INT32_MAX) if hi is not None else INT32_MAX
            if (lo is not None and val < lo) or (hi is not None and val > hi):
                unit = f" {v.unit}" if v.unit else ""
                rng = f"[{'-inf' if lo is None else f'{lo:g}'}, {'inf' if hi is None else f'{hi:g}'}]{unit}"
                raise FMUError(f"{self.name}: parameter {k!r} = {val!r} is outside its range {rng}{src}")


INT32_MIN, INT32_MAX = -2 ** 31, 2 ** 31 - 1
# FMI 3.0 type names of the variables our FMUs have, as their FMI 2.0 names
FMI3_TYPES = {"Float64": "Real", "Int32": "Integer"}


def _bound(v, attr: str) -> float | None:
    """A variable's min or max from the modelDescription (or its declared type), as a float."""
    b = getattr(v, attr, None)
    if b is None and v.declaredType is not None:
        b = getattr(v.declaredType, attr, None)
    try:
        return float(b) if b is not None else None
    except ValueError:
        return None


_vr_t = ctypes.c_uint
_proto = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p)
_proto_dostep = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int)


class Slave:
    """An instantiated, initialized co-simulation slave with raw ctypes entry points.

    ``get_real(vr_ptr, n, dst_addr)`` etc. take plain integer addresses (of ctypes arrays or numpy
    buffers), so that an inner loop can read outputs straight into preallocated result arrays.

    The FMU's log messages go to `logger` (FMI's signature: env, instance, status, category,
    message) when given, else to stdout as FMPy prints them (``[WARNING] ...``). Those of the set-up
    (instantiation, parameters, initialization) are held back until it succeeds: when it fails, the
    FMUError names the FMU and carries its own reason instead.
    """

    def __new__(cls, info: FMUInfo, *args, **kwargs):
        if cls is Slave and info.fmi_version == 3:
            return super().__new__(Slave3)
        return super().__new__(cls)

    def __init__(self, info: FMUInfo, instance_name: str | None = None, logging: bool = False,
                 logger=None, log_categories: list[str] | None = None):
        from fmpy import calloc, free
        from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                               fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
        self.info = info
        self._freed = True
        self._logger = logger
        self._held: list[tuple[int, str]] | None = []     # the set-up's messages, until it succeeds
        # the latest warnings and errors (status, category, message), for the reason of a failure
        self.messages: collections.deque[tuple[int, str, str]] = collections.deque(maxlen=20)
        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(self._log)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        try:
            self.fmu = FMU2Slave(guid=info.md.guid, unzipDirectory=info.unzipdir,
                                 modelIdentifier=info.model_identifier,
                                 instanceName=instance_name or info.model_identifier)
        except Exception as e:     # no binary for this platform, a corrupt or unloadable library
            raise FMUError(f"{info.path}: its binary cannot be loaded: {_reason(e)}") from None
        try:
            self.fmu.instantiate(loggingOn=logging, callbacks=self._callbacks)
        except Exception as e:
            self.fmu.freeLibrary()
            raise FMUError(f"{info.path}: fmi2Instantiate failed{self._why(e)}") from None
        self._freed = False
        if log_categories:     # only these categories (e.g. logEvents, logStatusWarning), not logCalls
            self.fmu.setDebugLogging(True, list(log_categories))
        self.c = self.fmu.component
        dll = self.fmu.dll
        self.get_real = _proto(("fmi2GetReal", dll))
        self.set_real = _proto(("fmi2SetReal", dll))
        self.get_integer = _proto(("fmi2GetInteger", dll))
        self.set_integer = _proto(("fmi2SetInteger", dll))
        self.get_boolean = _proto(("fmi2GetBoolean", dll))
        self.do_step = _proto_dostep(("fmi2DoStep", dll))

    def _log(self, env, instance, status, category, message) -> None:
        """The FMI logger callback: never raises (it runs inside the FMU's call)."""
        try:
            if status >= WARNING:
                text = message.decode("utf-8", "replace").replace("%%", "%")
                self.messages.append((status, category.decode("utf-8", "replace") if category else "", text))
            if self._logger is not None:
                self._logger(env, instance, status, category, message)
            elif self._held is not None:
                self._held.append((status, message.decode("utf-8", "replace").replace("%%", "%")))
            else:
                print(f"[{STATUS_NAMES[status].upper() if 0 <= status < 6 else status}] "
                      f"{message.decode('utf-8', 'replace').replace('%%', '%')}")
        except Exception:
            pass

    def _why(self, e: Exception | None = None) -> str:
        """': <the FMU's error messages>' (else the exception's text) for an FMUError."""
        # the FMU's own reasons; not the glue's follow-up that points at them ("see the messages above")
        msgs = [(s, m) for s, _, m in self.messages if "see the messages above" not in m]
        errors = [m for s, m in msgs if s >= ERROR] or [m for _, m in msgs]
        if errors:
            return ": " + "; ".join(dict.fromkeys(errors))
        return f" ({_reason(e)})" if e is not None else ""

    def _release_held(self) -> None:
        held, self._held = self._held or [], None
        for status, text in held:
            print(f"[{STATUS_NAMES[status].upper() if 0 <= status < 6 else status}] {text}")

    def set_values(self, values: dict[str, Any]) -> None:
        for name, val in values.items():
            v = self.info.var(name)
            try:
                if v.type == "Real":
                    self.fmu.setReal([v.vr], [float(val)])
                elif v.type in ("Integer", "Enumeration"):
                    self.fmu.setInteger([v.vr], [int(val)])
                elif v.type == "Boolean":
                    self.fmu.setBoolean([v.vr], [bool(val)])
                else:
                    self.fmu.setString([v.vr], [str(val)])
            except Exception as e:    # FMPy's FMICallException: the FMU refused the value (it logs why)
                raise FMUError(f"{self.info.name} refused {name} = {val!r}{self._why(e)}") from None

    def get_values(self, names: list[str]) -> dict[str, Any]:
        out = {}
        for name in names:
            v = self.info.var(name)
            if v.type == "Real":
                out[name] = self.fmu.getReal([v.vr])[0]
            elif v.type in ("Integer", "Enumeration"):
                out[name] = self.fmu.getInteger([v.vr])[0]
            elif v.type == "Boolean":
                out[name] = bool(self.fmu.getBoolean([v.vr])[0])
        return out

    def initialize(self, start_time: float, stop_time: float, parameters: dict[str, Any],
                   tolerance: float | None = None) -> None:
        """setupExperiment, parameters (before initialization, as FMI 2.0 allows for
        variables with initial exact/approx), enter/exit initialization mode. An FMUError naming
        the FMU and its own reason (its log) when it refuses a value or the initialization, e.g.
        parameters that are each in range but inconsistent together."""
        for call, args in (("fmi2SetupExperiment", dict(tolerance=tolerance, startTime=start_time, stopTime=stop_time)),
                           ("parameters", None), ("fmi2EnterInitializationMode", None),
                           ("fmi2ExitInitializationMode", None)):
            try:
                if call == "parameters":
                    self.set_values(parameters)
                elif call == "fmi2SetupExperiment":
                    self.fmu.setupExperiment(**args)
                elif call == "fmi2EnterInitializationMode":
                    self.fmu.enterInitializationMode()
                else:
                    self.fmu.exitInitializationMode()
            except FMUError:
                raise
            except Exception as e:
                what = "refused its parameters at initialization" if call == "fmi2ExitInitializationMode" \
                    else f"{call} failed"
                raise FMUError(f"{self.info.name} {what}{self._why(e)}") from None
        self._release_held()

    def terminated_status(self) -> tuple[bool, float | None]:
        """After a Discard: (terminated?, last successful time)."""
        term, last = False, None
        try:
            term = self.fmu.getBooleanStatus(FMI2_TERMINATED)
        except Exception:
            pass
        try:
            last = self.fmu.getRealStatus(FMI2_LAST_SUCCESSFUL_TIME)
        except Exception:
            pass
        return term, last

    def free(self, terminate: bool = True) -> None:
        if self._freed:
            return
        self._freed = True
        if terminate:
            try:
                self.fmu.terminate()
            except Exception:
                pass
        try:
            self.fmu.freeInstance()
        except Exception:
            pass


def _reason(e: Exception) -> str:
    return f"{type(e).__name__}: {e}" if str(e) else type(e).__name__


def vr_array(vrs: list[int]) -> ctypes.Array:
    return (_vr_t * max(1, len(vrs)))(*vrs)


def addr(obj) -> int:
    return ctypes.addressof(obj)


class Slave3(Slave):
    """An FMI 3.0 Co-Simulation slave with the entry points of an FMI 2.0 Slave: get_real(c, vr,
    n, dst) etc. call fmi3GetFloat64/Int32/Int64/Boolean (Enumerations are Int64 in FMI 3.0,
    Booleans one byte: both are read into the caller's 32-bit integers), and do_step(c, t, h,
    noSet) calls fmi3DoStep and keeps its terminateSimulation / lastSuccessfulTime for
    terminated_status(). Slave(info) returns one for an FMI 3.0 FMU."""

    def __init__(self, info: FMUInfo, instance_name: str | None = None, logging: bool = False,
                 logger=None, log_categories: list[str] | None = None):
        from fmpy.fmi3 import FMU3Slave
        self.info = info
        name = instance_name or info.model_identifier
        self.fmu = FMU3Slave(guid=info.md.instantiationToken, unzipDirectory=info.unzipdir,
                             modelIdentifier=info.model_identifier, instanceName=name)
        log_message = None
        if logger is not None:     # the FMI 2.0 logger's arguments (env, instance, status, category, message)
            def log_message(env, status, category, message, _name=name.encode()):
                logger(env, _name, status, category, message)
        self.fmu.instantiate(loggingOn=logging, logMessage=log_message)
        if log_categories:
            self.fmu.setDebugLogging(True, list(log_categories))
        self.c = self.fmu.component
        dll = self.fmu.dll
        proto5 = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p,
                                  ctypes.c_size_t)
        f64get, f64set = proto5(("fmi3GetFloat64", dll)), proto5(("fmi3SetFloat64", dll))
        self._i32get, self._i64get = proto5(("fmi3GetInt32", dll)), proto5(("fmi3GetInt64", dll))
        self._bget = proto5(("fmi3GetBoolean", dll))
        self._step = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_bool,
                                      ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)(
            ("fmi3DoStep", dll))
        self.get_real = lambda c, vr, n, dst: f64get(c, vr, n, dst, n)
        self.set_real = lambda c, vr, n, src: f64set(c, vr, n, src, n)
        self._enum_vrs = {v.vr for v in info.vars.values() if v.type == "Enumeration"}
        self._i64 = ctypes.c_int64()
        self._bools = (ctypes.c_bool * max(1, len(info.vars)))()
        self._flags = (ctypes.c_bool * 3)()
        self._last = ctypes.c_double()
        self._terminated, self._last_time = False, None
        self._freed = False

    def get_integer(self, c, vr, n, dst) -> int:
        """Integer and Enumeration outputs into 32-bit integers at dst (fmi3GetInt32 / fmi3GetInt64)."""
        base = ctypes.addressof(vr)
        vrs = (ctypes.c_uint * n).from_address(base)
        st = 0
        for k in range(n):
            if vrs[k] in self._enum_vrs:
                st |= self._i64get(c, base + 4 * k, 1, ctypes.addressof(self._i64), 1)
                ctypes.c_int32.from_address(dst + 4 * k).value = self._i64.value
            else:
                st |= self._i32get(c, base + 4 * k, 1, dst + 4 * k, 1)
        return st

    def get_boolean(self, c, vr, n, dst) -> int:
        """Boolean outputs (one byte each in FMI 3.0) into 32-bit integers at dst."""
        st = self._bget(c, vr, n, self._bools, n)
        for k in range(n):
            ctypes.c_int32.from_address(dst + 4 * k).value = int(self._bools[k])
        return st

    def do_step(self, c, t, h, no_set_prior) -> int:
        f = self._flags
        st = self._step(c, t, h, bool(no_set_prior), ctypes.addressof(f), ctypes.addressof(f) + 1,
                        ctypes.addressof(f) + 2, ctypes.addressof(self._last))
        self._terminated, self._last_time = bool(f[1]), self._last.value
        return st

    def set_values(self, values: dict[str, Any]) -> None:
        for name, val in values.items():
            v = self.info.var(name)
            try:
                if v.type == "Real":
                    self.fmu.setFloat64([v.vr], [float(val)])
                elif v.type == "Integer":
                    self.fmu.setInt32([v.vr], [int(val)])
                elif v.type == "Enumeration":
                    self.fmu.setInt64([v.vr], [int(val)])
                elif v.type == "Boolean":
                    self.fmu.setBoolean([v.vr], [bool(val)])
                else:
                    self.fmu.setString([v.vr], [str(val)])
            except Exception as e:    # FMPy's FMICallException: the FMU refused the value (it logs why)
                raise FMUError(f"{self.info.name} refused {name} = {val!r}: {e}") from None

    def get_values(self, names: list[str]) -> dict[str, Any]:
        out = {}
        for name in names:
            v = self.info.var(name)
            if v.type == "Real":
                out[name] = self.fmu.getFloat64([v.vr])[0]
            elif v.type == "Integer":
                out[name] = self.fmu.getInt32([v.vr])[0]
            elif v.type == "Enumeration":
                out[name] = self.fmu.getInt64([v.vr])[0]
            elif v.type == "Boolean":
                out[name] = bool(self.fmu.getBoolean([v.vr])[0])
        return out

    def initialize(self, start_time: float, stop_time: float, parameters: dict[str, Any],
                   tolerance: float | None = None) -> None:
        """Parameters (in the Instantiated state, as FMI 3.0 allows for initial exact/approx), then
        enter (with the experiment) and exit initialization mode."""
        self.set_values(parameters)
        self.fmu.enterInitializationMode(tolerance=tolerance, startTime=start_time, stopTime=stop_time)
        self.fmu.exitInitializationMode()

    def terminated_status(self) -> tuple[bool, float | None]:
        """After a Discard: (terminated?, last successful time) from the last fmi3DoStep."""
        return self._terminated, self._last_time
