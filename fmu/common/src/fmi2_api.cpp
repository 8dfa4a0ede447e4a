// The FMI 2.0 co-simulation C API, implemented once for every FMU of the project over the shared
// operations of api.hpp (the FMI 3.0 API, fmi3_api.cpp, is the other one). Compiled into each FMU's
// FMI 2.0 shared library by add_fmu(); only the fmi2* symbols are exported. No exception crosses
// this boundary: every entry point catches everything.
#include <cstring>

#include "api.hpp"
#include "binary_runtime.hpp"

using namespace fmuglue;
using namespace fmuglue::api;

namespace {

// The fmi2StatusKind / fmi2Type the caller passed, as the integer it is: an out-of-range value is
// an error to report, and loading it as the enum type would be undefined behaviour.
template <class Enum>
int enumValue(const Enum& e) {
  static_assert(sizeof(Enum) == sizeof(int), "FMI 2.0 enums are int-sized");
  int v;
  std::memcpy(&v, &e, sizeof v);
  return v;
}

}  // namespace

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
    if (!completeInstantiation(inst, "fmi2Instantiate", fmuGUID)) { delete inst; return nullptr; }
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
  Instance* inst = static_cast<Instance*>(c);
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
    return setupExperiment(inst, "fmi2SetupExperiment", toleranceDefined != fmi2False, tolerance, startTime,
                           stopTimeDefined != fmi2False, stopTime);
  });
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
  return guarded(c, "fmi2EnterInitializationMode", [&](Instance* inst) {
    CALLLOG(inst, "fmi2EnterInitializationMode");
    return enterInitializationMode(inst, "fmi2EnterInitializationMode");
  });
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
  return guarded(c, "fmi2ExitInitializationMode", [&](Instance* inst) {
    CALLLOG(inst, "fmi2ExitInitializationMode");
    return exitInitializationMode(inst, "fmi2ExitInitializationMode");
  });
}

fmi2Status fmi2Terminate(fmi2Component c) {
  return guarded(c, "fmi2Terminate", [&](Instance* inst) {
    CALLLOG(inst, "fmi2Terminate");
    return terminate(inst, "fmi2Terminate");
  });
}

fmi2Status fmi2Reset(fmi2Component c) {
  return guarded(c, "fmi2Reset", [&](Instance* inst) {
    CALLLOG(inst, "fmi2Reset");
    return reset(inst, "fmi2Reset");
  });
}

// ---- Get ------------------------------------------------------------------------------------
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  return guarded(c, "fmi2GetReal", [&](Instance* inst) {
    CALLLOG(inst, "fmi2GetReal(nvr=%zu)", nvr);
    return get(inst, "fmi2GetReal", vr, nvr, value, Access::Real, [](const Value& x) { return x.r; });
  });
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
  return guarded(c, "fmi2GetInteger", [&](Instance* inst) {
    CALLLOG(inst, "fmi2GetInteger(nvr=%zu)", nvr);
    return get(inst, "fmi2GetInteger", vr, nvr, value, Access::IntegerOrEnum, [](const Value& x) { return x.i; });
  });
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
  return guarded(c, "fmi2GetBoolean", [&](Instance* inst) {
    CALLLOG(inst, "fmi2GetBoolean(nvr=%zu)", nvr);
    return get(inst, "fmi2GetBoolean", vr, nvr, value, Access::Boolean,
               [](const Value& x) { return x.i ? fmi2True : fmi2False; });
  });
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
  return guarded(c, "fmi2GetString", [&](Instance* inst) {
    CALLLOG(inst, "fmi2GetString(nvr=%zu)", nvr);
    return get(inst, "fmi2GetString", vr, nvr, value, Access::String, [](const Value& x) { return x.s.c_str(); });
  });
}

// ---- Set ------------------------------------------------------------------------------------
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
  return guarded(c, "fmi2SetReal", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SetReal(nvr=%zu)", nvr);
    return setNumbers(inst, "fmi2SetReal", vr, nvr, value, Access::Real);
  });
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
  return guarded(c, "fmi2SetInteger", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SetInteger(nvr=%zu)", nvr);
    return setNumbers(inst, "fmi2SetInteger", vr, nvr, value, Access::IntegerOrEnum);
  });
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
  return guarded(c, "fmi2SetBoolean", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SetBoolean(nvr=%zu)", nvr);
    return setBooleans(inst, "fmi2SetBoolean", vr, nvr, value);
  });
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
  return guarded(c, "fmi2SetString", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SetString(nvr=%zu)", nvr);
    return setStrings(inst, "fmi2SetString", vr, nvr, value);
  });
}

// ---- FMU state ------------------------------------------------------------------------------
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* FMUstate) {
  return guarded(c, "fmi2GetFMUstate", [&](Instance* inst) {
    CALLLOG(inst, "fmi2GetFMUstate");
    return getState(inst, "fmi2GetFMUstate", FMUstate);
  });
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
  return guarded(c, "fmi2SetFMUstate", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SetFMUstate");
    return setState(inst, "fmi2SetFMUstate", FMUstate);
  });
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* FMUstate) {
  return guarded(c, "fmi2FreeFMUstate", [&](Instance* inst) {
    CALLLOG(inst, "fmi2FreeFMUstate");
    return freeState(inst, "fmi2FreeFMUstate", FMUstate);
  });
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t* size) {
  return guarded(c, "fmi2SerializedFMUstateSize", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SerializedFMUstateSize");
    return serializedStateSize(inst, "fmi2SerializedFMUstateSize", FMUstate, size);
  });
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
  return guarded(c, "fmi2SerializeFMUstate", [&](Instance* inst) {
    CALLLOG(inst, "fmi2SerializeFMUstate(size=%zu)", size);
    return serializeState(inst, "fmi2SerializeFMUstate", FMUstate, reinterpret_cast<std::uint8_t*>(serializedState),
                          size);
  });
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate* FMUstate) {
  return guarded(c, "fmi2DeSerializeFMUstate", [&](Instance* inst) {
    CALLLOG(inst, "fmi2DeSerializeFMUstate(size=%zu)", size);
    return deserializeState(inst, "fmi2DeSerializeFMUstate", reinterpret_cast<const std::uint8_t*>(serializedState),
                            size, FMUstate);
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
    return doStep(inst, "fmi2DoStep", t, h, noSetFMUStatePriorToCurrentPoint != fmi2False);
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
