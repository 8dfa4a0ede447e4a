"""Hostile callers: the defects an independent audit found in the FMI boundary (issue 12), each
reproduced through the raw C API (ctypes, every status visible) and kept as a regression test.

What this establishes, per FMU the project ships (the controller checks on both controllers):
- a communication step longer than the FMU's largest step is refused at once with fmi2Error and
  changes nothing (the controller used to run 1e8 ticks for h = 1e5 s, and for h >= 1.85e16 s
  overflowed its tick counter and returned fmi2OK having run nothing);
- forged FMU states with a correct checksum are either refused or, when accepted, behave: the
  following steps return OK/Warning (or Discard for a fallen plant) with finite outputs (the
  audit had 12 of 5 000 accepted forged controller blobs produce NaN with fmi2OK);
- a state pointer the instance did not create (another instance's, a freed one) is an error,
  not a dereference; states still held at fmi2FreeInstance are freed (checked by the sanitizer
  and Valgrind runs, docs/reliability.md);
- parameters outside their physical range are refused at set time naming the variable
  (sample_period = 2.2e-310 was accepted);
- an implausible normal force raises the controller's fault bit and is logged (fz = 1e300 raised
  nothing); the 3D controller logs its fault masks' changes too (it logged neither);
- out-of-range fmi2StatusKind / fmi2Type values are reported errors (undefined behaviour before;
  the UBSan run of this file checks that no enum is loaded);
- a plant logs a non-finite input once when it goes bad and once when it recovers, and reports
  it on its input_fault output (it used to log every step); a push beyond +-1000 N is refused by
  fmi2SetReal instead of ending in a CVODE failure.
"""
from __future__ import annotations

import ctypes
import math
import random
import struct
from pathlib import Path

import pytest

from conftest import SHIPPED, RawModel, fmi2Discard, fmi2Error, fmi2OK, fmi2Warning, _unzip
from test_fmu_glue import _fnv1a64, _restore_bytes, _running, _snapshot_bytes


@pytest.fixture(scope="module")
def raw_plant(plant_unzipped) -> RawModel:
    return RawModel(plant_unzipped)


@pytest.fixture(scope="module")
def raw_plant3d(fmu_path, tmp_path_factory) -> RawModel:
    return RawModel(_unzip(fmu_path("Hoap2Plant3D"), tmp_path_factory))


@pytest.fixture(scope="module")
def raw_controller3d(fmu_path, tmp_path_factory) -> RawModel:
    return RawModel(_unzip(fmu_path("AnkleHipController3D"), tmp_path_factory))


@pytest.fixture(params=["controller", "controller3d"])
def raw_ctrl(request, raw_controller, raw_controller3d) -> RawModel:
    """Each controller FMU: the sagittal one and AnkleHipController3D (the same time rule, state
    handling, parameter checks and fz plausibility; each its own tick budget, LARGEST_STEP)."""
    return {"controller": raw_controller, "controller3d": raw_controller3d}[request.param]


# The largest step each controller takes at the default 1 ms period: 1e6 sagittal ticks, 1e5 of the
# 3D controller's (each about 0.1 s of computation, docs/fmu.md).
LARGEST_STEP = {"AnkleHipController": 1000.0, "AnkleHipController3D": 100.0}


def _largest_step(raw: RawModel) -> float:
    return LARGEST_STEP[raw.identifier]


@pytest.fixture(params=["controller", "controller3d", "plant", "plant3d"])
def raw_any(request, raw_controller, raw_controller3d, raw_plant, raw_plant3d) -> RawModel:
    """Every FMU the project ships (conftest.SHIPPED)."""
    return {"controller": raw_controller, "controller3d": raw_controller3d, "plant": raw_plant,
            "plant3d": raw_plant3d}[request.param]


def _real_outputs(raw: RawModel) -> list[str]:
    return [n for n, v in raw.vars.items() if v.causality == "output" and v.type == "Real"]


def _time(inst) -> float:
    t = ctypes.c_double()
    assert inst.fmi2GetRealStatus(2, ctypes.byref(t)) == fmi2OK  # fmi2LastSuccessfulTime
    return t.value


# ---------------------------------------------------------------------------------------------
# Step size

@pytest.mark.parametrize("h", [1e5, 1.85e16, 1e303, "just beyond"])
def test_controller_refuses_steps_beyond_its_tick_budget(raw_ctrl, h):
    hmax = _largest_step(raw_ctrl)
    h = hmax * 1.001 if h == "just beyond" else h
    inst = _running(raw_ctrl)
    assert inst.fmi2DoStep(0.0, 1e-3, 0) == fmi2OK
    assert inst.fmi2DoStep(1e-3, h, 0) == fmi2Error
    assert any(f"longer than this FMU's largest step {hmax:.17g}" in m for m in inst.errors()), inst.log
    assert _time(inst) == 1e-3  # nothing ran, the time did not jump
    assert inst.fmi2DoStep(1e-3, 1e-3, 0) == fmi2OK  # and the instance is still usable
    inst.free()


def test_controller_takes_its_largest_step(raw_ctrl):
    """The largest step (LARGEST_STEP) is still accepted and runs every tick."""
    hmax = _largest_step(raw_ctrl)
    inst = _running(raw_ctrl)
    assert inst.fmi2DoStep(0.0, hmax, 0) == fmi2OK
    assert _time(inst) == hmax
    inst.free()


@pytest.mark.parametrize("raw_name,hmax", [("plant", 3600.0), ("plant3d", 25.0)])
def test_plants_refuse_steps_beyond_their_budget(raw_name, hmax, raw_plant, raw_plant3d):
    inst = _running({"plant": raw_plant, "plant3d": raw_plant3d}[raw_name])
    for h in (hmax * 1.01, 1e300):
        assert inst.fmi2DoStep(0.0, h, 0) == fmi2Error
        assert any(f"largest step {hmax:.17g}" in m for m in inst.errors()), inst.log
    assert inst.fmi2DoStep(0.0, 1e-3, 0) == fmi2OK
    inst.free()


def test_step_below_time_resolution_refused(raw_ctrl):
    inst = raw_ctrl.instance()
    assert inst.fmi2SetupExperiment(0, 0.0, 1e17, 0, 0.0) == fmi2OK
    assert inst.fmi2EnterInitializationMode() == fmi2OK
    assert inst.fmi2ExitInitializationMode() == fmi2OK
    assert inst.fmi2DoStep(1e17, 1e-3, 0) == fmi2Error
    assert any("below the time resolution" in m for m in inst.errors()), inst.log
    inst.free()


# ---------------------------------------------------------------------------------------------
# Forged states

def _forge(blob: bytes, rng: random.Random) -> bytes:
    """One forgery of a serialized state with a recomputed checksum: an 8-byte value in the payload
    replaced by NaN / +-Inf / +-1e300 / a denormal / random bits, or one byte set at random."""
    b = bytearray(blob)
    header = 8 + 4 + 4 + 4 + int.from_bytes(b[16:20], "little") + 16 + 8
    pos = rng.randrange(header, len(b) - 8 - 8)
    kind = rng.randrange(3)
    if kind == 0:
        b[pos:pos + 8] = struct.pack("<d", rng.choice([math.nan, math.inf, -math.inf, 1e300, -1e300, 5e-324]))
    elif kind == 1:
        b[pos:pos + 8] = rng.randbytes(8)
    else:
        b[pos] = rng.randrange(256)
    b[-8:] = _fnv1a64(bytes(b[:-8])).to_bytes(8, "little")
    return bytes(b)


@pytest.mark.parametrize("count", [400])
def test_forged_states_are_refused_or_harmless(raw_any, count):
    raw = raw_any
    donor = _running(raw, name="donor")
    for k in range(30):
        assert donor.fmi2DoStep(k * 1e-3, 1e-3, 0) in (fmi2OK, fmi2Warning)
    blob = _snapshot_bytes(donor)
    donor.free()
    outputs = _real_outputs(raw)
    rng = random.Random(12)
    accepted = 0
    victim = _running(raw, name="victim")
    for _ in range(count):
        forged = _forge(blob, rng)
        victim.log.clear()
        if _restore_bytes(victim, forged) != fmi2OK:
            assert victim.errors(), "a refused state says why"
            continue
        accepted += 1
        t = _time(victim)
        for k in range(5):
            st = victim.fmi2DoStep(t + k * 1e-3, 1e-3, 0)
            assert st in (fmi2OK, fmi2Warning, fmi2Discard), (st, victim.log[-3:])
            if st == fmi2Discard:
                break
            got, values = victim.get_real(outputs)
            assert got == fmi2OK and all(math.isfinite(x) for x in values), \
                [(n, x) for n, x in zip(outputs, values) if not math.isfinite(x)]
        # back to a clean state for the next forgery
        assert _restore_bytes(victim, blob) == fmi2OK, victim.errors()[-3:]
    victim.free()
    assert accepted < count  # the forgeries exercised the validation


def test_state_of_another_instance_or_freed_is_an_error(raw_ctrl):
    a, b = _running(raw_ctrl, name="a"), _running(raw_ctrl, name="b")
    s = ctypes.c_void_p()
    assert a.fmi2GetFMUstate(ctypes.byref(s)) == fmi2OK
    assert b.fmi2SetFMUstate(s) == fmi2Error
    assert any("not created by this instance" in m for m in b.errors()), b.log
    assert b.fmi2FreeFMUstate(ctypes.byref(s)) == fmi2Error  # b must not free a's state
    stale = ctypes.c_void_p(s.value)
    assert a.fmi2FreeFMUstate(ctypes.byref(s)) == fmi2OK
    assert a.fmi2SetFMUstate(stale) == fmi2Error  # freed: found nowhere, never dereferenced
    # states still held when the instance is freed are freed with it (sanitizer/Valgrind runs)
    for _ in range(3):
        held = ctypes.c_void_p()
        assert a.fmi2GetFMUstate(ctypes.byref(held)) == fmi2OK
    a.free()
    b.free()


# ---------------------------------------------------------------------------------------------
# Parameters, inputs and enums

def test_meaningless_sample_period_refused_at_set_time(raw_ctrl):
    inst = raw_ctrl.instance()
    assert inst.set_real({"sample_period": 2.2e-310}) == fmi2Error
    assert any('"sample_period" = 2.19' in m and "is outside [1e-05, 0.1]" in m for m in inst.errors()), inst.log
    inst.free()


def test_every_positive_parameter_has_a_positive_minimum(raw_any):
    """No parameter has a minimum of 0 that is really 'excluded' (FMI bounds are closed): every
    bound the FMU declares is accepted at set time, and initialization succeeds with it or names it."""
    for name, v in raw_any.vars.items():
        if v.causality != "parameter" or v.type != "Real" or v.min is None:
            continue
        inst = raw_any.instance()
        assert inst.set_real({name: float(v.min)}) == fmi2OK, (name, inst.log)
        assert inst.set_real({name: math.nextafter(float(v.min), -math.inf)}) == fmi2Error, name
        inst.free()


def test_implausible_fz_raises_and_logs_the_fault(raw_ctrl):
    inst = _running(raw_ctrl)
    assert inst.fmi2DoStep(0.0, 1e-3, 0) == fmi2OK
    assert inst.set_real({"fz": 1e300}) == fmi2OK
    assert inst.fmi2DoStep(1e-3, 1e-3, 0) == fmi2OK
    assert inst.get_integer(["fault"])[1] == [0x200]
    assert any("fz_implausible" in m for _, _, m in inst.log), inst.log
    assert inst.set_real({"fz": 70.0}) == fmi2OK
    assert inst.fmi2DoStep(2e-3, 1e-3, 0) == fmi2OK
    assert inst.get_integer(["fault"])[1] == [0]
    inst.free()


def test_implausible_zmp_y_raises_and_logs_the_frontal_fault(raw_controller3d):
    """The 3D controller logs a change of its frontal fault mask with the bits' names, as it does
    the sagittal one (it logged neither before): a lateral ZMP beyond the soles raises
    zmp_y_outside (0x4), and its return is logged as healthy."""
    inst = _running(raw_controller3d)
    assert inst.fmi2DoStep(0.0, 1e-3, 0) == fmi2OK
    assert inst.set_real({"zmp_y": 0.5}) == fmi2OK
    assert inst.fmi2DoStep(1e-3, 1e-3, 0) == fmi2OK
    assert inst.get_integer(["fault_y"])[1] == [0x4]
    assert any("frontal fault mask 0x4 (zmp_y_outside)" in m for _, _, m in inst.log), inst.log
    assert inst.set_real({"zmp_y": 0.0}) == fmi2OK
    assert inst.fmi2DoStep(2e-3, 1e-3, 0) == fmi2OK
    assert inst.get_integer(["fault_y"])[1] == [0]
    assert any("frontal fault mask 0x0 (healthy)" in m for _, _, m in inst.log), inst.log
    inst.free()


@pytest.mark.parametrize("fn,kind", [("fmi2GetRealStatus", 99), ("fmi2GetBooleanStatus", -7),
                                     ("fmi2GetStringStatus", 1 << 30), ("fmi2GetIntegerStatus", 42)])
def test_out_of_range_status_kind(raw_any, fn, kind):
    inst = _running(raw_any)
    assert inst.fmi2DoStep(0.0, 1e-3, 0) in (fmi2OK, fmi2Warning)
    value = {"fmi2GetRealStatus": ctypes.c_double, "fmi2GetStringStatus": ctypes.c_char_p}.get(fn, ctypes.c_int)()
    assert getattr(inst, fn)(kind, ctypes.byref(value)) == fmi2Error
    assert any(f"status kind {kind}" in m or "no integer status" in m for m in inst.errors()), inst.log
    inst.free()


def test_out_of_range_fmu_type(raw_ctrl):
    inst = raw_ctrl.instance(fmu_type=7)
    assert not inst.c
    assert any("fmuType 7" in m for _, _, m in inst.log), inst.log


@pytest.mark.parametrize("raw_name", ["plant", "plant3d"])
def test_plant_nonfinite_input_logged_once_and_reported(raw_name, raw_plant, raw_plant3d):
    raw = {"plant": raw_plant, "plant3d": raw_plant3d}[raw_name]
    inst = _running(raw)
    assert inst.set_real({"theta_hip_ref": math.nan}) == fmi2OK
    for k in range(100):
        assert inst.fmi2DoStep(k * 1e-3, 1e-3, 0) == fmi2Warning
    assert inst.get_integer(["input_fault"])[1] == [2]
    warnings = [m for s, _, m in inst.log if s == fmi2Warning and "theta_hip_ref" in m]
    assert len(warnings) == 1, warnings
    assert inst.set_real({"theta_hip_ref": 0.0}) == fmi2OK
    assert inst.fmi2DoStep(0.1, 1e-3, 0) == fmi2OK
    assert inst.get_integer(["input_fault"])[1] == [0]
    assert any("finite again" in m for _, _, m in inst.log), inst.log
    inst.free()


@pytest.mark.parametrize("raw_name", ["plant", "plant3d"])
def test_plant_push_beyond_range_refused_and_largest_push_is_a_fall(raw_name, raw_plant, raw_plant3d):
    raw = {"plant": raw_plant, "plant3d": raw_plant3d}[raw_name]
    inst = _running(raw)
    assert inst.set_real({"push_force": 1e308}) == fmi2Error
    assert any('"push_force" = 1e+308 is outside [-1000, 1000]' in m for m in inst.errors())
    inst.log.clear()
    assert inst.set_real({"push_force": -1000.0}) == fmi2OK
    st = fmi2OK
    for k in range(2000):
        st = inst.fmi2DoStep(k * 1e-3, 1e-3, 0)
        if st != fmi2OK:
            break
    assert st == fmi2Discard, inst.log[-3:]  # fallen, reported as a fall, not a solver error
    assert not inst.errors(), inst.errors()
    inst.free()


# ---------------------------------------------------------------------------------------------
# Load and unload

def test_load_unload_cycles_do_not_leak(raw_any, tmp_path):
    """An importer that loads and unloads the binary (FMPy does for every simulate_fmu call) used
    to lose 72 704 bytes per cycle: the statically linked libstdc++'s exception pool. The heap in
    use (glibc mallinfo2) must not grow with the number of cycles."""
    import _ctypes
    import shutil

    so = tmp_path / "copy.so"  # a path of its own, so each dlopen really loads and dlclose unloads
    shutil.copy(raw_any.lib._name, so)
    libc = ctypes.CDLL(None)

    class MallInfo2(ctypes.Structure):
        _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                                   "fsmblks", "uordblks", "fordblks", "keepcost")]

    libc.mallinfo2.restype = MallInfo2

    def cycle():
        lib = ctypes.CDLL(str(so))
        assert lib.fmi2GetVersion  # resolved: the binary is really loaded
        _ctypes.dlclose(lib._handle)

    for _ in range(5):
        cycle()
    before = libc.mallinfo2().uordblks
    for _ in range(50):
        cycle()
    growth = (libc.mallinfo2().uordblks - before) / 50
    # ctypes itself keeps ~1.8 kB per CDLL object (the same for a one-function C library); the
    # defect was 72 704 bytes per cycle
    assert growth < 10_000, f"{growth:.0f} bytes of heap lost per load/unload cycle"


# The FMI 2.0 and FMI 3.0 life cycle through raw function pointers (dlopen/dlsym of libc, no ctypes
# library object), so that one cycle of the test allocates nothing of its own that it keeps.
_c, _i, _d, _b, _sz = ctypes.c_void_p, ctypes.c_int, ctypes.c_double, ctypes.c_bool, ctypes.c_size_t
_FMI2 = {
    "fmi2Instantiate": ctypes.CFUNCTYPE(_c, ctypes.c_char_p, _i, ctypes.c_char_p, ctypes.c_char_p, _c, _i, _i),
    "fmi2SetupExperiment": ctypes.CFUNCTYPE(_i, _c, _i, _d, _d, _i, _d),
    "fmi2EnterInitializationMode": ctypes.CFUNCTYPE(_i, _c),
    "fmi2ExitInitializationMode": ctypes.CFUNCTYPE(_i, _c),
    "fmi2DoStep": ctypes.CFUNCTYPE(_i, _c, _d, _d, _i),
    "fmi2Terminate": ctypes.CFUNCTYPE(_i, _c),
    "fmi2FreeInstance": ctypes.CFUNCTYPE(None, _c),
}
_FMI3 = {
    "fmi3InstantiateCoSimulation": ctypes.CFUNCTYPE(_c, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p, _b, _b,
                                                    _b, _b, _c, _sz, _c, _c, _c),
    "fmi3EnterInitializationMode": ctypes.CFUNCTYPE(_i, _c, _b, _d, _d, _b, _d),
    "fmi3ExitInitializationMode": ctypes.CFUNCTYPE(_i, _c),
    "fmi3DoStep": ctypes.CFUNCTYPE(_i, _c, _d, _d, _b, ctypes.POINTER(_b), ctypes.POINTER(_b), ctypes.POINTER(_b),
                                   ctypes.POINTER(_d)),
    "fmi3Terminate": ctypes.CFUNCTYPE(_i, _c),
    "fmi3FreeInstance": ctypes.CFUNCTYPE(None, _c),
}
_fmi2_logger = ctypes.CFUNCTYPE(None, _c, ctypes.c_char_p, _i, ctypes.c_char_p, ctypes.c_char_p)(lambda *a: None)
_fmi3_logger = ctypes.CFUNCTYPE(None, _c, _i, ctypes.c_char_p, ctypes.c_char_p)(lambda *a: None)


def _lifecycle_heap_growth(so, fmi3: bool, token: str, resources, cycles: int) -> float:
    """Heap bytes in use (glibc mallinfo2) gained per cycle of: load the binary, instantiate, set up,
    initialize, 20 steps of 1 ms, terminate, free the instance, unload; after 3 warm-up cycles, the
    least of three batches (the sagittal plant's first batch once gained 2 816 bytes, and none after:
    something of the process allocated once, not a loss per cycle)."""
    libc = ctypes.CDLL(None)
    libc.dlopen.restype, libc.dlopen.argtypes = _c, [ctypes.c_char_p, _i]
    libc.dlsym.restype, libc.dlsym.argtypes = _c, [_c, ctypes.c_char_p]
    libc.dlclose.argtypes = [_c]

    class MallInfo2(ctypes.Structure):
        _fields_ = [(n, _sz) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks",
                                       "uordblks", "fordblks", "keepcost")]

    libc.mallinfo2.restype = MallInfo2
    RTLD_NOW, RTLD_NOLOAD = 2, 4
    path = str(so).encode()
    callbacks = (_c * 5)(ctypes.cast(_fmi2_logger, _c), ctypes.cast(libc.calloc, _c), ctypes.cast(libc.free, _c),
                         None, None)
    flags = (_b * 3)()
    last = _d()
    name, tok, res = b"leak", token.encode(), str(resources).encode()

    def cycle():
        h = libc.dlopen(path, RTLD_NOW)
        assert h, "dlopen failed"
        f = {n: proto(libc.dlsym(h, n.encode())) for n, proto in (_FMI3 if fmi3 else _FMI2).items()}
        if fmi3:
            inst = f["fmi3InstantiateCoSimulation"](name, tok, res, False, False, False, False, None, 0, None,
                                                    ctypes.cast(_fmi3_logger, _c), None)
            assert inst, "fmi3InstantiateCoSimulation failed"
            assert f["fmi3EnterInitializationMode"](inst, False, 0.0, 0.0, False, 0.0) == 0
            assert f["fmi3ExitInitializationMode"](inst) == 0
            for k in range(20):
                assert f["fmi3DoStep"](inst, k * 1e-3, 1e-3, True, flags, flags, flags, last) == 0
            assert f["fmi3Terminate"](inst) == 0
            f["fmi3FreeInstance"](inst)
        else:
            inst = f["fmi2Instantiate"](name, 1, tok, res, ctypes.addressof(callbacks), 0, 0)
            assert inst, "fmi2Instantiate failed"
            assert f["fmi2SetupExperiment"](inst, 0, 0.0, 0.0, 0, 0.0) == 0
            assert f["fmi2EnterInitializationMode"](inst) == 0
            assert f["fmi2ExitInitializationMode"](inst) == 0
            for k in range(20):
                assert f["fmi2DoStep"](inst, k * 1e-3, 1e-3, 1) == 0
            assert f["fmi2Terminate"](inst) == 0
            f["fmi2FreeInstance"](inst)
        del f
        assert libc.dlclose(h) == 0
        assert not libc.dlopen(path, RTLD_NOW | RTLD_NOLOAD), "the binary stayed loaded after dlclose"

    for _ in range(3):
        cycle()
    growth = []
    for _ in range(3):  # a leak grows every batch; a one-time allocation of the process, one at most
        before = libc.mallinfo2().uordblks
        for _ in range(cycles):
            cycle()
        growth.append((libc.mallinfo2().uordblks - before) / cycles)
    return min(growth)


@pytest.mark.parametrize("fmi3", [False, True], ids=["fmi2", "fmi3"])
@pytest.mark.parametrize("name", SHIPPED)
def test_instantiate_free_unload_cycles_do_not_leak(name, fmi3, fmu_dir, tmp_path):
    """Every FMU, FMI 2.0 and its FMI 3.0 twin, loaded, instantiated, initialized, stepped, freed
    and unloaded again and again (an importer running one simulation after another) keeps no heap
    memory: Hoap2Plant3D used to lose 176 bytes per cycle (issue 33: ODE's default threading
    implementation and its geometry position cache, allocated by dInitODE2 and its geoms, freed only
    by a dCloseODE it never called). Measured exactly (glibc's bytes in use), so a few bytes count."""
    from fmpy import extract, read_model_description

    fmu = fmu_dir / ("fmi3" if fmi3 else "") / f"{name}.fmu"
    d = Path(extract(str(fmu), unzipdir=str(tmp_path / "fmu")))
    md = read_model_description(str(d))
    ident = md.coSimulation.modelIdentifier
    so = d / "binaries" / ("x86_64-linux" if fmi3 else "linux64") / f"{ident}.so"
    resources = (str(d / "resources") + "/") if fmi3 else (d / "resources").as_uri()
    token = md.instantiationToken if fmi3 else md.guid
    growth = _lifecycle_heap_growth(so, fmi3, token, resources, cycles=10)
    assert growth == 0, f"{growth:.1f} bytes of heap lost per load/instantiate/free/unload cycle"
