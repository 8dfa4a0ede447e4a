// The FMI 2.0 co-simulation C API, implemented once for every FMU of the project.
// Compiled into each FMU's shared library by add_fmu(); only the fmi2* symbols are exported.
// No exception crosses this boundary: every entry point catches everything.
#include <cmath>
#include <cstring>
#include <exception>
#include <new>

#include "instance.hpp"

using namespace fmuglue;

namespace {

constexpr unsigned S(State s) { return static_cast<unsigned>(s); }
constexpr unsigned kInst = S(State::Instantiated), kInit = S(State::InitializationMode),
                   kComplete = S(State::StepComplete), kInProgress = S(State::StepInProgress),
                   kFailed = S(State::StepFailed), kCanceled = S(State::StepCanceled),
                   kTerminated = S(State::Terminated), kErr = S(State::Error);
constexpr unsigned kLive = kInst | kInit | kComplete | kInProgress | kFailed | kCanceled | kTerminated | kErr;
constexpr unsigned kMaskGet = kInit | kComplete | kFailed | kCanceled | kTerminated | kErr;
constexpr unsigned kMaskSet = kInst | kInit | kComplete;
constexpr unsigned kMaskState = kInst | kInit | kComplete | kFailed | kCanceled | kTerminated;
constexpr unsigned kMaskStatus = kComplete | kInProgress | kFailed | kCanceled | kTerminated;

Instance* toInst(fmi2Component c) { return static_cast<Instance*>(c); }

// The instance's own FMU state behind the importer's pointer, or nullptr (logged). The pointer is
// looked up, never dereferenced first: a freed, forged or foreign pointer is an error, not a crash.
StateSnapshot* toSnap(Instance* inst, fmi2FMUstate s, const char* fn) {
  if (s == nullptr) { inst->error("%s: FMUstate is NULL", fn); return nullptr; }
  auto it = inst->states.find(s);
  if (it == inst->states.end()) {
    inst->error("%s: FMUstate %p was not created by this instance or was already freed (move a state to another "
                "instance with fmi2SerializeFMUstate and fmi2DeSerializeFMUstate)", fn, s);
    return nullptr;
  }
  return it->second.get();
}

StateSnapshot* newSnap(Instance* inst) {
  auto snap = std::make_unique<StateSnapshot>();
  StateSnapshot* p = snap.get();
  inst->states.emplace(p, std::move(snap));
  return p;
}

// The fmi2StatusKind / fmi2Type the caller passed, as the integer it is: an out-of-range value is
// an error to report, and loading it as the enum type would be undefined behaviour.
template <class Enum>
int enumValue(const Enum& e) {
  static_assert(sizeof(Enum) == sizeof(int), "FMI 2.0 enums are int-sized");
  int v;
  std::memcpy(&v, &e, sizeof v);
  return v;
}

// Common checks of fmi2Get*/fmi2Set* arguments; returns the store indices in `idx`.
bool resolve(Instance* inst, const char* fn, const fmi2ValueReference vr[], size_t nvr, const void* values,
             Type t, std::vector<int>& idx) {
  idx.clear();  // a reused buffer: never leave the previous call's indices in it
  if (nvr == 0) return true;
  if (vr == nullptr) { inst->error("%s: vr is NULL with nvr = %zu", fn, nvr); return false; }
  if (values == nullptr) { inst->error("%s: value array is NULL with nvr = %zu", fn, nvr); return false; }
  if (nvr > inst->info.variables.size() * 16 + 1024) {
    inst->error("%s: nvr = %zu is larger than any legal request", fn, nvr);
    return false;
  }
  idx.resize(nvr);
  for (size_t k = 0; k < nvr; ++k) {
    int i = inst->indexOf(vr[k]);
    if (i < 0) { inst->error("%s: unknown value reference %u (element %zu)", fn, vr[k], k); return false; }
    if (inst->info.variables[i].type != t) {
      inst->error("%s: value reference %u is %s \"%s\", not %s", fn, vr[k],
                  xmlName(inst->info.variables[i].type), inst->info.variables[i].name.c_str(), xmlName(t));
      return false;
    }
    idx[k] = i;
  }
  return true;
}

void prepareGet(Instance* inst) {
  if (inst->state == State::InitializationMode && inst->initDirty) {
    inst->model->update_initial_outputs(inst->ctx);
    inst->initDirty = false;
  }
}

template <class F>
fmi2Status guarded(fmi2Component c, const char* fn, F&& body) {
  Instance* inst = toInst(c);
  if (inst == nullptr) return fmi2Error;
  try {
    return body(inst);
  } catch (const std::bad_alloc&) {
    inst->error("%s: out of memory", fn);
  } catch (const std::exception& e) {
    inst->error("%s: %s", fn, e.what());
  } catch (...) {
    inst->error("%s: unknown exception", fn);
  }
  inst->state = State::Error;
  return fmi2Error;
}

// Apply a set after all values were checked; calls the tunable hook when needed.
template <class Store>
fmi2Status commitSet(Instance* inst, const char* fn, const std::vector<int>& idx, Store store) {
  // After initialization a set that includes a (tunable) parameter may be rejected by the model:
  // keep the old values for that case only (inputs, set at every step, need no copy).
  bool anyTunable = false;
  if (inst->state == State::StepComplete)
    for (int i : idx)
      if (inst->info.variables[i].causality == Causality::Parameter) anyTunable = true;
  std::vector<Value> old;
  if (anyTunable)
    for (int i : idx) old.push_back(inst->store[i]);
  for (size_t k = 0; k < idx.size(); ++k) store(inst->store[idx[k]], k);
  if (inst->state == State::InitializationMode || inst->state == State::Instantiated) inst->initDirty = true;
  if (anyTunable) {
    fmi2Status st = inst->model->tunable_parameters_changed(inst->ctx);
    if (st == fmi2Error || st == fmi2Fatal) {
      for (size_t k = 0; k < idx.size(); ++k) inst->store[idx[k]] = old[k];
      inst->model->tunable_parameters_changed(inst->ctx);
      return inst->error("%s: the model rejected the new tunable parameter values (previous values kept)", fn);
    }
    return st;
  }
  return fmi2OK;
}

bool checkSettable(Instance* inst, const char* fn, const std::vector<int>& idx) {
  std::string why;
  for (int i : idx) {
    if (!inst->settable(i, why)) {
      inst->error("%s: \"%s\" cannot be set in state %s: %s", fn, inst->info.variables[i].name.c_str(),
                  stateName(inst->state), why.c_str());
      return false;
    }
  }
  return true;
}

bool checkNumber(Instance* inst, const char* fn, int i, double v) {
  std::string why;
  if (valueAllowed(inst->info.variables[i], v, why)) return true;
  inst->error("%s: %s", fn, why.c_str());
  return false;
}

}  // namespace

#if defined(FMUGLUE_STATIC_LIBSTDCXX)
// The statically linked libstdc++ allocates its exception emergency pool (72 704 bytes) when the
// binary is loaded and never frees it, so an importer that loads and unloads the FMU repeatedly
// lost that much every time. __gnu_cxx::__freeres(), libstdc++'s hook for memory checkers, frees
// it when the binary is unloaded (the pool is private to this binary: its libstdc++ is hidden).
namespace __gnu_cxx {
void __freeres() noexcept;
}
__attribute__((destructor)) static void releaseStaticRuntime() { __gnu_cxx::__freeres(); }
#endif

#if defined(FMUGLUE_ZIG_RUNTIME)
// zig links no crtbeginS.o, whose destructor calls __cxa_finalize(&__dso_handle) when the binary
// is unloaded: the destructors of this binary's static objects (registered with __cxa_atexit)
// then stayed in the process's exit list, and the process crashed at exit calling into the
// unmapped binary after an importer's dlclose. This destructor does what crtbeginS.o does.
extern "C" void __cxa_finalize(void* dso);
extern "C" __attribute__((visibility("hidden"))) void* __dso_handle;
__attribute__((destructor)) static void finalizeStaticObjects() { __cxa_finalize(&__dso_handle); }
#endif

#define CALLLOG(inst, ...) \
  do { if ((inst)->logEnabled(kLogCalls)) (inst)->log(kLogCalls, fmi2OK, __VA_ARGS__); } while (0)

extern "C" {

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
  return guarded(c, "fmi2SetDebugLogging", [&](Instance* inst) {
    if (!inst->allowed(kLive, "fmi2SetDebugLogging")) return fmi2Error;
    fmi2Status st = inst->setDebugLogging(loggingOn != fmi2False, nCategories, categories);
    CALLLOG(inst, "fmi2SetDebugLogging(loggingOn=%d, nCategories=%zu)", loggingOn, nCategories);
    return st;
  });
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions* functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
  (void)visible;
  Instance* inst = nullptr;
  try {
    const ModelInfo& info = modelInfo();
    const char* name = (instanceName && instanceName[0]) ? instanceName : "";
    inst = new Instance(info, name, fmuResourceLocation ? fmuResourceLocation : "", functions,
                        loggingOn != fmi2False);
    if (name[0] == '\0') { inst->error("fmi2Instantiate: missing instance name"); delete inst; return nullptr; }
    if (functions == nullptr) { delete inst; return nullptr; }
    if (enumValue(fmuType) != fmi2CoSimulation) {
      inst->error("fmi2Instantiate: fmuType %d: %s supports only fmi2CoSimulation (%d)", enumValue(fmuType),
                  info.model_name.c_str(), static_cast<int>(fmi2CoSimulation));
      delete inst;
      return nullptr;
    }
    if (fmuGUID == nullptr || inst->guid != fmuGUID) {
      inst->error("fmi2Instantiate: GUID \"%s\" does not match this FMU's \"%s\"", fmuGUID ? fmuGUID : "(null)",
                  inst->guid.c_str());
      delete inst;
      return nullptr;
    }
    inst->model = createModel();
    if (!inst->model) { inst->error("fmi2Instantiate: the model could not be created"); delete inst; return nullptr; }
    inst->model->reset(inst->ctx);
    CALLLOG(inst, "fmi2Instantiate(%s, GUID %s, loggingOn=%d)", name, fmuGUID, loggingOn);
    return inst;
  } catch (const std::exception& e) {
    if (inst) { inst->error("fmi2Instantiate: %s", e.what()); delete inst; }
  } catch (...) {
    if (inst) { inst->error("fmi2Instantiate: unknown exception"); delete inst; }
  }
  return nullptr;
}

void fmi2FreeInstance(fmi2Component c) {
  Instance* inst = toInst(c);
  if (inst == nullptr) return;
  try {
    CALLLOG(inst, "fmi2FreeInstance");
  } catch (...) {
  }
  try {
    delete inst;
  } catch (...) {
  }
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
  return guarded(c, "fmi2SetupExperiment", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SetupExperiment(tolDefined=%d, tol=%g, start=%g, stopDefined=%d, stop=%g)", toleranceDefined,
            tolerance, startTime, stopTimeDefined, stopTime);
    if (!inst->allowed(kInst, "fmi2SetupExperiment")) return fmi2Error;
    if (!std::isfinite(startTime)) return inst->error("fmi2SetupExperiment: startTime %g is not finite", startTime);
    if (stopTimeDefined && !(stopTime >= startTime))
      return inst->error("fmi2SetupExperiment: stopTime %g < startTime %g", stopTime, startTime);
    if (toleranceDefined && !(tolerance > 0.0))
      return inst->error("fmi2SetupExperiment: tolerance %g must be positive", tolerance);
    inst->startTime = startTime;
    inst->time = startTime;
    inst->stopTimeDefined = stopTimeDefined != fmi2False;
    inst->stopTime = stopTime;
    inst->toleranceDefined = toleranceDefined != fmi2False;
    inst->tolerance = tolerance;
    return fmi2OK;
  });
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
  return guarded(c, "fmi2EnterInitializationMode", [&](Instance* inst) {
    CALLLOG(inst, "fmi2EnterInitializationMode");
    if (!inst->allowed(kInst, "fmi2EnterInitializationMode")) return fmi2Error;
    inst->state = State::InitializationMode;
    inst->initDirty = true;
    return fmi2OK;
  });
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
  return guarded(c, "fmi2ExitInitializationMode", [&](Instance* inst) {
    CALLLOG(inst, "fmi2ExitInitializationMode");
    if (!inst->allowed(kInit, "fmi2ExitInitializationMode")) return fmi2Error;
    fmi2Status st = inst->model->exit_initialization(inst->ctx);
    if (st == fmi2Error || st == fmi2Fatal || st == fmi2Discard || st == fmi2Pending) {
      inst->state = st == fmi2Fatal ? State::Fatal : State::Error;
      return inst->error("fmi2ExitInitializationMode: initialization failed (see the messages above); "
                         "call fmi2Reset or fmi2FreeInstance");
    }
    inst->state = State::StepComplete;
    inst->time = inst->startTime;
    inst->lastSuccessfulTime = inst->startTime;
    inst->terminatedFlag = false;
    inst->initDirty = false;
    return st;
  });
}

fmi2Status fmi2Terminate(fmi2Component c) {
  return guarded(c, "fmi2Terminate", [&](Instance* inst) {
    CALLLOG(inst, "fmi2Terminate");
    if (!inst->allowed(kComplete | kFailed | kCanceled, "fmi2Terminate")) return fmi2Error;
    inst->model->terminate(inst->ctx);
    inst->state = State::Terminated;
    return fmi2OK;
  });
}

fmi2Status fmi2Reset(fmi2Component c) {
  return guarded(c, "fmi2Reset", [&](Instance* inst) {
    CALLLOG(inst, "fmi2Reset");
    if (!inst->allowed(kLive & ~kInProgress, "fmi2Reset")) return fmi2Error;
    inst->resetStore();
    inst->state = State::Instantiated;
    inst->time = inst->startTime = 0.0;
    inst->stopTimeDefined = inst->toleranceDefined = false;
    inst->stopTime = inst->tolerance = 0.0;
    inst->lastSuccessfulTime = 0.0;
    inst->terminatedFlag = false;
    inst->model->reset(inst->ctx);
    return fmi2OK;
  });
}

// ---- Get ------------------------------------------------------------------------------------
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  return guarded(c, "fmi2GetReal", [&](Instance* inst) {
    CALLLOG(inst, "fmi2GetReal(nvr=%zu)", nvr);
    if (!inst->allowed(kMaskGet, "fmi2GetReal")) return fmi2Error;
    std::vector<int>& idx = inst->scratch_idx;  // reused: no allocation per call
    if (!resolve(inst, "fmi2GetReal", vr, nvr, value, Type::Real, idx)) return fmi2Error;
    prepareGet(inst);
    for (size_t k = 0; k < nvr; ++k) value[k] = inst->store[idx[k]].r;
    return fmi2OK;
  });
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
  return guarded(c, "fmi2GetInteger", [&](Instance* inst) {
    CALLLOG(inst, "fmi2GetInteger(nvr=%zu)", nvr);
    if (!inst->allowed(kMaskGet, "fmi2GetInteger")) return fmi2Error;
    std::vector<int>& idx = inst->scratch_idx;  // reused: no allocation per call
    if (!resolve(inst, "fmi2GetInteger", vr, nvr, value, Type::Integer, idx)) return fmi2Error;
    prepareGet(inst);
    for (size_t k = 0; k < nvr; ++k) value[k] = inst->store[idx[k]].i;
    return fmi2OK;
  });
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
  return guarded(c, "fmi2GetBoolean", [&](Instance* inst) {
    CALLLOG(inst, "fmi2GetBoolean(nvr=%zu)", nvr);
    if (!inst->allowed(kMaskGet, "fmi2GetBoolean")) return fmi2Error;
    std::vector<int>& idx = inst->scratch_idx;  // reused: no allocation per call
    if (!resolve(inst, "fmi2GetBoolean", vr, nvr, value, Type::Boolean, idx)) return fmi2Error;
    prepareGet(inst);
    for (size_t k = 0; k < nvr; ++k) value[k] = inst->store[idx[k]].i ? fmi2True : fmi2False;
    return fmi2OK;
  });
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
  return guarded(c, "fmi2GetString", [&](Instance* inst) {
    CALLLOG(inst, "fmi2GetString(nvr=%zu)", nvr);
    if (!inst->allowed(kMaskGet, "fmi2GetString")) return fmi2Error;
    std::vector<int>& idx = inst->scratch_idx;  // reused: no allocation per call
    if (!resolve(inst, "fmi2GetString", vr, nvr, value, Type::String, idx)) return fmi2Error;
    prepareGet(inst);
    for (size_t k = 0; k < nvr; ++k) value[k] = inst->store[idx[k]].s.c_str();
    return fmi2OK;
  });
}

// ---- Set ------------------------------------------------------------------------------------
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
  return guarded(c, "fmi2SetReal", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SetReal(nvr=%zu)", nvr);
    if (!inst->allowed(kMaskSet, "fmi2SetReal")) return fmi2Error;
    std::vector<int>& idx = inst->scratch_idx;  // reused: no allocation per call
    if (!resolve(inst, "fmi2SetReal", vr, nvr, value, Type::Real, idx)) return fmi2Error;
    if (!checkSettable(inst, "fmi2SetReal", idx)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k)
      if (!checkNumber(inst, "fmi2SetReal", idx[k], value[k])) return fmi2Error;
    return commitSet(inst, "fmi2SetReal", idx, [&](Value& x, size_t k) { x.r = value[k]; });
  });
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
  return guarded(c, "fmi2SetInteger", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SetInteger(nvr=%zu)", nvr);
    if (!inst->allowed(kMaskSet, "fmi2SetInteger")) return fmi2Error;
    std::vector<int>& idx = inst->scratch_idx;  // reused: no allocation per call
    if (!resolve(inst, "fmi2SetInteger", vr, nvr, value, Type::Integer, idx)) return fmi2Error;
    if (!checkSettable(inst, "fmi2SetInteger", idx)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k)
      if (!checkNumber(inst, "fmi2SetInteger", idx[k], static_cast<double>(value[k]))) return fmi2Error;
    return commitSet(inst, "fmi2SetInteger", idx, [&](Value& x, size_t k) { x.i = value[k]; });
  });
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
  return guarded(c, "fmi2SetBoolean", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SetBoolean(nvr=%zu)", nvr);
    if (!inst->allowed(kMaskSet, "fmi2SetBoolean")) return fmi2Error;
    std::vector<int>& idx = inst->scratch_idx;  // reused: no allocation per call
    if (!resolve(inst, "fmi2SetBoolean", vr, nvr, value, Type::Boolean, idx)) return fmi2Error;
    if (!checkSettable(inst, "fmi2SetBoolean", idx)) return fmi2Error;
    return commitSet(inst, "fmi2SetBoolean", idx, [&](Value& x, size_t k) { x.i = value[k] != fmi2False; });
  });
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
  return guarded(c, "fmi2SetString", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SetString(nvr=%zu)", nvr);
    if (!inst->allowed(kMaskSet, "fmi2SetString")) return fmi2Error;
    std::vector<int>& idx = inst->scratch_idx;  // reused: no allocation per call
    if (!resolve(inst, "fmi2SetString", vr, nvr, value, Type::String, idx)) return fmi2Error;
    if (!checkSettable(inst, "fmi2SetString", idx)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k)
      if (value[k] == nullptr) return inst->error("fmi2SetString: value %zu is NULL", k);
    return commitSet(inst, "fmi2SetString", idx, [&](Value& x, size_t k) { x.s = value[k]; });
  });
}

// ---- FMU state ------------------------------------------------------------------------------
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* FMUstate) {
  return guarded(c, "fmi2GetFMUstate", [&](Instance* inst) {
    CALLLOG(inst, "fmi2GetFMUstate");
    if (!inst->allowed(kMaskState, "fmi2GetFMUstate")) return fmi2Error;
    if (FMUstate == nullptr) return inst->error("fmi2GetFMUstate: FMUstate pointer is NULL");
    StateSnapshot* snap = nullptr;
    if (*FMUstate != nullptr) {
      snap = toSnap(inst, *FMUstate, "fmi2GetFMUstate");
      if (!snap) return fmi2Error;
    }
    std::vector<std::uint8_t> bytes = encodeState(*inst);
    if (!snap) snap = newSnap(inst);
    snap->bytes = std::move(bytes);
    *FMUstate = snap;
    return fmi2OK;
  });
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
  return guarded(c, "fmi2SetFMUstate", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SetFMUstate");
    if (!inst->allowed(kMaskState | kErr, "fmi2SetFMUstate")) return fmi2Error;
    StateSnapshot* snap = toSnap(inst, FMUstate, "fmi2SetFMUstate");
    if (!snap) return fmi2Error;
    std::string err;
    if (!decodeState(*inst, snap->bytes.data(), snap->bytes.size(), err))
      return inst->error("fmi2SetFMUstate: %s", err.c_str());
    return fmi2OK;
  });
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* FMUstate) {
  return guarded(c, "fmi2FreeFMUstate", [&](Instance* inst) {
    CALLLOG(inst, "fmi2FreeFMUstate");
    if (FMUstate == nullptr) return inst->error("fmi2FreeFMUstate: FMUstate pointer is NULL");
    if (*FMUstate == nullptr) return fmi2OK;
    if (!toSnap(inst, *FMUstate, "fmi2FreeFMUstate")) return fmi2Error;
    inst->states.erase(*FMUstate);
    *FMUstate = nullptr;
    return fmi2OK;
  });
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t* size) {
  return guarded(c, "fmi2SerializedFMUstateSize", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SerializedFMUstateSize");
    if (!inst->allowed(kMaskState | kErr, "fmi2SerializedFMUstateSize")) return fmi2Error;
    StateSnapshot* snap = toSnap(inst, FMUstate, "fmi2SerializedFMUstateSize");
    if (!snap) return fmi2Error;
    if (size == nullptr) return inst->error("fmi2SerializedFMUstateSize: size is NULL");
    *size = snap->bytes.size();
    return fmi2OK;
  });
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
  return guarded(c, "fmi2SerializeFMUstate", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SerializeFMUstate(size=%zu)", size);
    if (!inst->allowed(kMaskState | kErr, "fmi2SerializeFMUstate")) return fmi2Error;
    StateSnapshot* snap = toSnap(inst, FMUstate, "fmi2SerializeFMUstate");
    if (!snap) return fmi2Error;
    if (serializedState == nullptr) return inst->error("fmi2SerializeFMUstate: buffer is NULL");
    if (size < snap->bytes.size())
      return inst->error("fmi2SerializeFMUstate: buffer of %zu bytes is smaller than the state (%zu bytes)", size,
                         snap->bytes.size());
    std::memcpy(serializedState, snap->bytes.data(), snap->bytes.size());
    return fmi2OK;
  });
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate* FMUstate) {
  return guarded(c, "fmi2DeSerializeFMUstate", [&](Instance* inst) {
    CALLLOG(inst, "fmi2DeSerializeFMUstate(size=%zu)", size);
    if (!inst->allowed(kMaskState | kErr, "fmi2DeSerializeFMUstate")) return fmi2Error;
    if (FMUstate == nullptr) return inst->error("fmi2DeSerializeFMUstate: FMUstate pointer is NULL");
    if (serializedState == nullptr) return inst->error("fmi2DeSerializeFMUstate: bytes are NULL");
    const auto* p = reinterpret_cast<const std::uint8_t*>(serializedState);
    // Check the blob completely (header, checksum, values and the model's part) by decoding it
    // into this instance and restoring the instance's own state afterwards.
    const State saved = inst->state;
    if (saved == State::Error) inst->state = State::Instantiated;  // encodeState needs a non-error state to snapshot
    std::vector<std::uint8_t> backup = encodeState(*inst);
    inst->state = saved;
    std::string err;
    if (!decodeState(*inst, p, size, err)) return inst->error("fmi2DeSerializeFMUstate: %s", err.c_str());
    std::string err2;
    const bool restored = decodeState(*inst, backup.data(), backup.size(), err2);
    inst->state = saved;
    if (!restored)
      return inst->error("fmi2DeSerializeFMUstate: internal error restoring the instance: %s", err2.c_str());
    StateSnapshot* snap = nullptr;
    if (*FMUstate != nullptr) {
      snap = toSnap(inst, *FMUstate, "fmi2DeSerializeFMUstate");
      if (!snap) return fmi2Error;
    } else {
      snap = newSnap(inst);
    }
    snap->bytes.assign(p, p + size);
    *FMUstate = snap;
    return fmi2OK;
  });
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference[], size_t,
                                        const fmi2ValueReference[], size_t, const fmi2Real[], fmi2Real[]) {
  return guarded(c, "fmi2GetDirectionalDerivative", [&](Instance* inst) {
    return inst->error("fmi2GetDirectionalDerivative is not supported (providesDirectionalDerivative=false)");
  });
}

// ---- Co-simulation --------------------------------------------------------------------------
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference[], size_t, const fmi2Integer[],
                                       const fmi2Real[]) {
  return guarded(c, "fmi2SetRealInputDerivatives", [&](Instance* inst) {
    return inst->error("fmi2SetRealInputDerivatives is not supported (canInterpolateInputs=false)");
  });
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference[], size_t, const fmi2Integer[],
                                        fmi2Real[]) {
  return guarded(c, "fmi2GetRealOutputDerivatives", [&](Instance* inst) {
    return inst->error("fmi2GetRealOutputDerivatives is not supported (maxOutputDerivativeOrder=0)");
  });
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  return guarded(c, "fmi2DoStep", [&](Instance* inst) {
    CALLLOG(inst, "fmi2DoStep(t=%.17g, h=%.17g)", t, h);
    if (!inst->allowed(kComplete, "fmi2DoStep")) return fmi2Error;
    if (!std::isfinite(t) || !std::isfinite(h) || !(h > 0.0))
      return inst->error("fmi2DoStep: invalid communication point %g or step size %g (must be > 0)", t, h);
    const double hmax = inst->model->max_step_size(inst->ctx);
    if (h > hmax)
      return inst->error("fmi2DoStep: communication step %.17g s is longer than this FMU's largest step %.17g s; "
                         "split it into shorter steps", h, hmax);
    if (t + h == t)
      return inst->error("fmi2DoStep: step size %g is below the time resolution at t = %.17g", h, t);
    double tol = 1e-9 * (1.0 + std::fabs(inst->time)) + 1e-6 * h;
    if (std::fabs(t - inst->time) > tol)
      return inst->error("fmi2DoStep: currentCommunicationPoint %.17g does not match the FMU time %.17g", t,
                         inst->time);
    if (inst->stopTimeDefined && t + h > inst->stopTime + 1e-9 * (1.0 + std::fabs(inst->stopTime)) + 1e-6 * h)
      return inst->error("fmi2DoStep: step to %.17g goes beyond the stop time %.17g", t + h, inst->stopTime);
    StepResult r = inst->model->do_step(inst->ctx, t, h, noSetFMUStatePriorToCurrentPoint != fmi2False);
    switch (r.status) {
      case fmi2OK:
      case fmi2Warning:
        inst->time = t + h;
        inst->lastSuccessfulTime = inst->time;
        inst->terminatedFlag = r.terminated;
        return r.status;
      case fmi2Discard:
        inst->state = State::StepFailed;
        inst->lastSuccessfulTime = r.last_successful_time;
        inst->time = r.last_successful_time;
        inst->terminatedFlag = r.terminated;
        inst->log(kLogStatusDiscard, fmi2Discard, "fmi2DoStep: step discarded at t=%.17g (terminated=%d)",
                  r.last_successful_time, r.terminated ? 1 : 0);
        return fmi2Discard;
      case fmi2Fatal:
        inst->state = State::Fatal;
        inst->log(kLogStatusFatal, fmi2Fatal, "fmi2DoStep: fatal error in the model");
        return fmi2Fatal;
      default:
        inst->state = State::Error;
        return inst->error("fmi2DoStep: the model failed in the step from %.17g (see the messages above)", t);
    }
  });
}

fmi2Status fmi2CancelStep(fmi2Component c) {
  return guarded(c, "fmi2CancelStep", [&](Instance* inst) {
    CALLLOG(inst, "fmi2CancelStep");
    if (!inst->allowed(kInProgress, "fmi2CancelStep")) return fmi2Error;
    return fmi2OK;
  });
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* value) {
  return guarded(c, "fmi2GetStatus", [&](Instance* inst) {
    if (!inst->allowed(kMaskStatus, "fmi2GetStatus")) return fmi2Error;
    if (value == nullptr) return inst->error("fmi2GetStatus: value is NULL");
    (void)s;
    inst->log(kLogStatusDiscard, fmi2Discard, "fmi2GetStatus: no asynchronous step is pending");
    return fmi2Discard;
  });
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value) {
  return guarded(c, "fmi2GetRealStatus", [&](Instance* inst) {
    if (!inst->allowed(kMaskStatus, "fmi2GetRealStatus")) return fmi2Error;
    if (value == nullptr) return inst->error("fmi2GetRealStatus: value is NULL");
    if (enumValue(s) != fmi2LastSuccessfulTime)
      return inst->error("fmi2GetRealStatus: status kind %d: only fmi2LastSuccessfulTime is provided", enumValue(s));
    *value = inst->lastSuccessfulTime;
    return fmi2OK;
  });
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer* value) {
  return guarded(c, "fmi2GetIntegerStatus", [&](Instance* inst) {
    if (!inst->allowed(kMaskStatus, "fmi2GetIntegerStatus")) return fmi2Error;
    if (value == nullptr) return inst->error("fmi2GetIntegerStatus: value is NULL");
    (void)s;
    return inst->error("fmi2GetIntegerStatus: no integer status is defined by FMI 2.0 co-simulation");
  });
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean* value) {
  return guarded(c, "fmi2GetBooleanStatus", [&](Instance* inst) {
    if (!inst->allowed(kMaskStatus, "fmi2GetBooleanStatus")) return fmi2Error;
    if (value == nullptr) return inst->error("fmi2GetBooleanStatus: value is NULL");
    if (enumValue(s) != fmi2Terminated)
      return inst->error("fmi2GetBooleanStatus: status kind %d: only fmi2Terminated is provided", enumValue(s));
    *value = inst->terminatedFlag ? fmi2True : fmi2False;
    return fmi2OK;
  });
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String* value) {
  return guarded(c, "fmi2GetStringStatus", [&](Instance* inst) {
    if (!inst->allowed(kMaskStatus, "fmi2GetStringStatus")) return fmi2Error;
    if (value == nullptr) return inst->error("fmi2GetStringStatus: value is NULL");
    if (enumValue(s) != fmi2PendingStatus)
      return inst->error("fmi2GetStringStatus: status kind %d: only fmi2PendingStatus is provided", enumValue(s));
    *value = "";
    return fmi2Discard;
  });
}

// Model-exchange functions are not provided (co-simulation only); the importer never needs them.
}  // extern "C"
