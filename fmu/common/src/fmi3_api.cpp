// The FMI 3.0 Co-Simulation C API, implemented once for every FMU of the project over the shared
// operations of api.hpp (the same state machine, checks, FMU states and step as the FMI 2.0 API,
// fmi2_api.cpp). Compiled into each FMU's FMI 3.0 shared library by add_fmu(); only the fmi3*
// symbols are exported. No exception crosses this boundary.
//
// What the FMI 3.0 twins declare and provide (docs/fmu.md, "FMI 3.0"): Co-Simulation without
// event mode, early return or intermediate update; Float64, Int32, Enumeration (fmi3Get/SetInt64),
// Boolean and String variables as in the FMI 2.0 description, plus the independent variable
// `time`; FMU states (get/set/serialize, the FMI 2.0 byte format: a state serialized by one
// version is de-serialized by the other). Model Exchange and Scheduled Execution are not provided.
#include <cstring>
#include <string>
#include <utility>

#include "api.hpp"
#include "binary_runtime.hpp"
#include "fmi3Functions.h"

using namespace fmuglue;
using namespace fmuglue::api;

namespace {

static_assert(fmi3OK == static_cast<int>(fmi2OK) && fmi3Warning == static_cast<int>(fmi2Warning) &&
                  fmi3Discard == static_cast<int>(fmi2Discard) && fmi3Error == static_cast<int>(fmi2Error) &&
                  fmi3Fatal == static_cast<int>(fmi2Fatal),
              "the shared operations return fmi2Status: its values must be fmi3Status's");

fmi3Status st3(fmi2Status s) { return static_cast<fmi3Status>(s); }

template <class F>
fmi3Status call(fmi3Instance c, const char* fn, F&& body) {
  return st3(guarded(c, fn, std::forward<F>(body)));
}

// Scalar variables only: one value per value reference.
bool checkCount(Instance* inst, const char* fn, size_t nvr, size_t nValues) {
  if (nvr == nValues) return true;
  inst->error("%s: nValues = %zu, but the %zu value references are scalars (one value each)", fn, nValues, nvr);
  return false;
}

// The getters and setters of a type no variable of the FMUs has: nothing to read or write.
fmi3Status noVariables(fmi3Instance c, const char* fn, const char* type, const fmi3ValueReference vr[], size_t nvr) {
  return call(c, fn, [&](Instance* inst) {
    if (!inst->allowed(kMaskGet | kMaskSet, fn)) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    return inst->error("%s: value reference %u: this FMU has no %s variables", fn, vr ? vr[0] : 0u, type);
  });
}

fmi3Status unsupported(fmi3Instance c, const char* fn, const char* why) {
  return call(c, fn, [&](Instance* inst) { return inst->error("%s is not supported (%s)", fn, why); });
}

}  // namespace

#define CALLLOG(inst, ...) \
  do { if ((inst)->logEnabled(kLogCalls)) (inst)->log(kLogCalls, fmi2OK, __VA_ARGS__); } while (0)

extern "C" {

const char* fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
  return call(c, "fmi3SetDebugLogging", [&](Instance* inst) {
    if (!inst->allowed(kLive, "fmi3SetDebugLogging")) return fmi2Error;
    fmi2Status st = inst->setDebugLogging(loggingOn, nCategories, categories);
    CALLLOG(inst, "fmi3SetDebugLogging(loggingOn=%d, nCategories=%zu)", loggingOn, nCategories);
    return st;
  });
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String, fmi3String, fmi3Boolean, fmi3Boolean,
                                          fmi3InstanceEnvironment env, fmi3LogMessageCallback logMessage) {
  if (logMessage)
    logMessage(env, fmi3Error, "logStatusError",
               (std::string(instanceName ? instanceName : "") + ": this FMU provides only Co-Simulation").c_str());
  return nullptr;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String, fmi3String, fmi3Boolean,
                                               fmi3Boolean, fmi3InstanceEnvironment env,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback,
                                               fmi3LockPreemptionCallback, fmi3UnlockPreemptionCallback) {
  if (logMessage)
    logMessage(env, fmi3Error, "logStatusError",
               (std::string(instanceName ? instanceName : "") + ": this FMU provides only Co-Simulation").c_str());
  return nullptr;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference[], size_t, fmi3InstanceEnvironment env,
                                         fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback) {
  (void)visible;
  (void)earlyReturnAllowed;  // mightReturnEarlyFromDoStep = false: never used
  Instance* inst = nullptr;
  try {
    const ModelInfo& info = modelInfo();
    const char* name = (instanceName && instanceName[0]) ? instanceName : "";
    inst = new Instance(info, name, resourcePath ? resourcePath : "", nullptr, loggingOn);
    if (logMessage) {
      inst->sink = [logMessage, env](fmi2Status status, const char* category, const char* message) {
        logMessage(env, static_cast<fmi3Status>(status), category, message);
      };
    }
    if (eventModeUsed) {
      inst->error("fmi3InstantiateCoSimulation: eventModeUsed = true, but %s has no event mode (hasEventMode = false)",
                  info.model_name.c_str());
      delete inst;
      return nullptr;
    }
    // The instantiation token is the FMI 2.0 GUID: the same model, the same FMU states.
    if (!completeInstantiation(inst, "fmi3InstantiateCoSimulation", instantiationToken)) {
      delete inst;
      return nullptr;
    }
    CALLLOG(inst, "fmi3InstantiateCoSimulation(%s, token %s, loggingOn=%d)", name, instantiationToken, loggingOn);
    return inst;
  } catch (const std::exception& e) {
    if (inst) { inst->error("fmi3InstantiateCoSimulation: %s", e.what()); delete inst; }
  } catch (...) {
    if (inst) { inst->error("fmi3InstantiateCoSimulation: unknown exception"); delete inst; }
  }
  return nullptr;
}

void fmi3FreeInstance(fmi3Instance c) {
  Instance* inst = static_cast<Instance*>(c);
  if (inst == nullptr) return;
  try {
    CALLLOG(inst, "fmi3FreeInstance");
  } catch (...) {
  }
  try {
    delete inst;
  } catch (...) {
  }
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
  return call(c, "fmi3EnterInitializationMode", [&](Instance* inst) {
    CALLLOG(inst, "fmi3EnterInitializationMode(tolDefined=%d, tol=%g, start=%g, stopDefined=%d, stop=%g)",
            toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime);
    const fmi2Status st = setupExperiment(inst, "fmi3EnterInitializationMode", toleranceDefined, tolerance, startTime,
                                          stopTimeDefined, stopTime);
    if (st != fmi2OK) return st;
    return enterInitializationMode(inst, "fmi3EnterInitializationMode");
  });
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
  return call(c, "fmi3ExitInitializationMode", [&](Instance* inst) {
    CALLLOG(inst, "fmi3ExitInitializationMode");
    return exitInitializationMode(inst, "fmi3ExitInitializationMode");  // straight to Step Mode (no event mode)
  });
}

fmi3Status fmi3EnterEventMode(fmi3Instance c) {
  return unsupported(c, "fmi3EnterEventMode", "hasEventMode = false");
}

fmi3Status fmi3Terminate(fmi3Instance c) {
  return call(c, "fmi3Terminate", [&](Instance* inst) {
    CALLLOG(inst, "fmi3Terminate");
    return terminate(inst, "fmi3Terminate");
  });
}

fmi3Status fmi3Reset(fmi3Instance c) {
  return call(c, "fmi3Reset", [&](Instance* inst) {
    CALLLOG(inst, "fmi3Reset");
    return reset(inst, "fmi3Reset");
  });
}

// ---- Get / set ------------------------------------------------------------------------------
fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 values[],
                          size_t nValues) {
  return call(c, "fmi3GetFloat64", [&](Instance* inst) {
    CALLLOG(inst, "fmi3GetFloat64(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3GetFloat64", nvr, nValues)) return fmi2Error;
    bool time = false;
    for (size_t k = 0; vr && k < nvr; ++k) time = time || vr[k] == kTimeValueReference;
    if (!time)
      return get(inst, "fmi3GetFloat64", vr, nvr, values, Access::Real, [](const Value& x) { return x.r; });
    for (size_t k = 0; k < nvr; ++k) {  // the independent variable among them: one at a time
      if (vr[k] == kTimeValueReference) {
        if (!inst->allowed(kMaskGet, "fmi3GetFloat64")) return fmi2Error;
        values[k] = inst->time;
      } else {
        const fmi2Status st =
            get(inst, "fmi3GetFloat64", vr + k, 1, values + k, Access::Real, [](const Value& x) { return x.r; });
        if (st != fmi2OK) return st;
      }
    }
    return fmi2OK;
  });
}
fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Int32 values[],
                        size_t nValues) {
  return call(c, "fmi3GetInt32", [&](Instance* inst) {
    CALLLOG(inst, "fmi3GetInt32(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3GetInt32", nvr, nValues)) return fmi2Error;
    return get(inst, "fmi3GetInt32", vr, nvr, values, Access::Int32, [](const Value& x) { return fmi3Int32(x.i); });
  });
}
fmi3Status fmi3GetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Int64 values[],
                        size_t nValues) {
  return call(c, "fmi3GetInt64", [&](Instance* inst) {  // the enumerations (FMI 3.0: Enumerations are Int64)
    CALLLOG(inst, "fmi3GetInt64(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3GetInt64", nvr, nValues)) return fmi2Error;
    return get(inst, "fmi3GetInt64", vr, nvr, values, Access::Enum, [](const Value& x) { return fmi3Int64(x.i); });
  });
}
fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Boolean values[],
                          size_t nValues) {
  return call(c, "fmi3GetBoolean", [&](Instance* inst) {
    CALLLOG(inst, "fmi3GetBoolean(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3GetBoolean", nvr, nValues)) return fmi2Error;
    return get(inst, "fmi3GetBoolean", vr, nvr, values, Access::Boolean, [](const Value& x) { return x.i != 0; });
  });
}
fmi3Status fmi3GetString(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3String values[],
                         size_t nValues) {
  return call(c, "fmi3GetString", [&](Instance* inst) {
    CALLLOG(inst, "fmi3GetString(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3GetString", nvr, nValues)) return fmi2Error;
    return get(inst, "fmi3GetString", vr, nvr, values, Access::String, [](const Value& x) { return x.s.c_str(); });
  });
}

fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Float64 values[],
                          size_t nValues) {
  return call(c, "fmi3SetFloat64", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SetFloat64(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3SetFloat64", nvr, nValues)) return fmi2Error;
    return setNumbers(inst, "fmi3SetFloat64", vr, nvr, values, Access::Real);
  });
}
fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 values[],
                        size_t nValues) {
  return call(c, "fmi3SetInt32", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SetInt32(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3SetInt32", nvr, nValues)) return fmi2Error;
    return setNumbers(inst, "fmi3SetInt32", vr, nvr, values, Access::Int32);
  });
}
fmi3Status fmi3SetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Int64 values[],
                        size_t nValues) {
  return call(c, "fmi3SetInt64", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SetInt64(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3SetInt64", nvr, nValues)) return fmi2Error;
    return setNumbers(inst, "fmi3SetInt64", vr, nvr, values, Access::Enum);
  });
}
fmi3Status fmi3SetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Boolean values[],
                          size_t nValues) {
  return call(c, "fmi3SetBoolean", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SetBoolean(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3SetBoolean", nvr, nValues)) return fmi2Error;
    return setBooleans(inst, "fmi3SetBoolean", vr, nvr, values);
  });
}
fmi3Status fmi3SetString(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3String values[],
                         size_t nValues) {
  return call(c, "fmi3SetString", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SetString(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3SetString", nvr, nValues)) return fmi2Error;
    return setStrings(inst, "fmi3SetString", vr, nvr, values);
  });
}

#define FMUGLUE_NO_VARIABLES(T, CT)                                                                           \
  fmi3Status fmi3Get##T(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, CT[], size_t) {          \
    return noVariables(c, "fmi3Get" #T, #T, vr, nvr);                                                       \
  }                                                                                                         \
  fmi3Status fmi3Set##T(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const CT[], size_t) {    \
    return noVariables(c, "fmi3Set" #T, #T, vr, nvr);                                                       \
  }
FMUGLUE_NO_VARIABLES(Float32, fmi3Float32)
FMUGLUE_NO_VARIABLES(Int8, fmi3Int8)
FMUGLUE_NO_VARIABLES(UInt8, fmi3UInt8)
FMUGLUE_NO_VARIABLES(Int16, fmi3Int16)
FMUGLUE_NO_VARIABLES(UInt16, fmi3UInt16)
FMUGLUE_NO_VARIABLES(UInt32, fmi3UInt32)
FMUGLUE_NO_VARIABLES(UInt64, fmi3UInt64)
#undef FMUGLUE_NO_VARIABLES

fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, size_t[], fmi3Binary[], size_t) {
  return noVariables(c, "fmi3GetBinary", "Binary", vr, nvr);
}
fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const size_t[],
                         const fmi3Binary[], size_t) {
  return noVariables(c, "fmi3SetBinary", "Binary", vr, nvr);
}
fmi3Status fmi3GetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Clock[]) {
  return noVariables(c, "fmi3GetClock", "Clock", vr, nvr);
}
fmi3Status fmi3SetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock[]) {
  return noVariables(c, "fmi3SetClock", "Clock", vr, nvr);
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance c, fmi3ValueReference, size_t*) {
  return unsupported(c, "fmi3GetNumberOfVariableDependencies", "see <ModelStructure> in modelDescription.xml");
}
fmi3Status fmi3GetVariableDependencies(fmi3Instance c, fmi3ValueReference, size_t[], fmi3ValueReference[], size_t[],
                                       fmi3DependencyKind[], size_t) {
  return unsupported(c, "fmi3GetVariableDependencies", "see <ModelStructure> in modelDescription.xml");
}

// ---- FMU state ------------------------------------------------------------------------------
fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState* FMUState) {
  return call(c, "fmi3GetFMUState", [&](Instance* inst) {
    CALLLOG(inst, "fmi3GetFMUState");
    return getState(inst, "fmi3GetFMUState", FMUState);
  });
}
fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState FMUState) {
  return call(c, "fmi3SetFMUState", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SetFMUState");
    return setState(inst, "fmi3SetFMUState", FMUState);
  });
}
fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState* FMUState) {
  return call(c, "fmi3FreeFMUState", [&](Instance* inst) {
    CALLLOG(inst, "fmi3FreeFMUState");
    return freeState(inst, "fmi3FreeFMUState", FMUState);
  });
}
fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState FMUState, size_t* size) {
  return call(c, "fmi3SerializedFMUStateSize", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SerializedFMUStateSize");
    return serializedStateSize(inst, "fmi3SerializedFMUStateSize", FMUState, size);
  });
}
fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size) {
  return call(c, "fmi3SerializeFMUState", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SerializeFMUState(size=%zu)", size);
    return serializeState(inst, "fmi3SerializeFMUState", FMUState, serializedState, size);
  });
}
fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState* FMUState) {
  return call(c, "fmi3DeserializeFMUState", [&](Instance* inst) {
    CALLLOG(inst, "fmi3DeserializeFMUState(size=%zu)", size);
    return deserializeState(inst, "fmi3DeserializeFMUState", serializedState, size, FMUState);
  });
}

// ---- Derivatives, configuration, clocks, discrete states: not provided ----------------------
fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference[], size_t,
                                        const fmi3ValueReference[], size_t, const fmi3Float64[], size_t,
                                        fmi3Float64[], size_t) {
  return unsupported(c, "fmi3GetDirectionalDerivative", "providesDirectionalDerivatives = false");
}
fmi3Status fmi3GetAdjointDerivative(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3ValueReference[],
                                    size_t, const fmi3Float64[], size_t, fmi3Float64[], size_t) {
  return unsupported(c, "fmi3GetAdjointDerivative", "providesAdjointDerivatives = false");
}
fmi3Status fmi3EnterConfigurationMode(fmi3Instance c) {
  return unsupported(c, "fmi3EnterConfigurationMode", "no structural parameters");
}
fmi3Status fmi3ExitConfigurationMode(fmi3Instance c) {
  return unsupported(c, "fmi3ExitConfigurationMode", "no structural parameters");
}
fmi3Status fmi3GetIntervalDecimal(fmi3Instance c, const fmi3ValueReference[], size_t, fmi3Float64[],
                                  fmi3IntervalQualifier[]) {
  return unsupported(c, "fmi3GetIntervalDecimal", "no clocks");
}
fmi3Status fmi3GetIntervalFraction(fmi3Instance c, const fmi3ValueReference[], size_t, fmi3UInt64[], fmi3UInt64[],
                                   fmi3IntervalQualifier[]) {
  return unsupported(c, "fmi3GetIntervalFraction", "no clocks");
}
fmi3Status fmi3GetShiftDecimal(fmi3Instance c, const fmi3ValueReference[], size_t, fmi3Float64[]) {
  return unsupported(c, "fmi3GetShiftDecimal", "no clocks");
}
fmi3Status fmi3GetShiftFraction(fmi3Instance c, const fmi3ValueReference[], size_t, fmi3UInt64[], fmi3UInt64[]) {
  return unsupported(c, "fmi3GetShiftFraction", "no clocks");
}
fmi3Status fmi3SetIntervalDecimal(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3Float64[]) {
  return unsupported(c, "fmi3SetIntervalDecimal", "no clocks");
}
fmi3Status fmi3SetIntervalFraction(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3UInt64[],
                                   const fmi3UInt64[]) {
  return unsupported(c, "fmi3SetIntervalFraction", "no clocks");
}
fmi3Status fmi3SetShiftDecimal(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3Float64[]) {
  return unsupported(c, "fmi3SetShiftDecimal", "no clocks");
}
fmi3Status fmi3SetShiftFraction(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3UInt64[],
                                const fmi3UInt64[]) {
  return unsupported(c, "fmi3SetShiftFraction", "no clocks");
}
fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance c) {
  return unsupported(c, "fmi3EvaluateDiscreteStates", "providesEvaluateDiscreteStates = false");
}
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean*, fmi3Boolean*, fmi3Boolean*, fmi3Boolean*,
                                    fmi3Boolean*, fmi3Float64*) {
  return unsupported(c, "fmi3UpdateDiscreteStates", "hasEventMode = false");
}

// ---- Model Exchange: not provided ---------------------------------------------------------
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) {
  return unsupported(c, "fmi3EnterContinuousTimeMode", "Co-Simulation only");
}
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean, fmi3Boolean*, fmi3Boolean*) {
  return unsupported(c, "fmi3CompletedIntegratorStep", "Co-Simulation only");
}
fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64) { return unsupported(c, "fmi3SetTime", "Co-Simulation only"); }
fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64[], size_t) {
  return unsupported(c, "fmi3SetContinuousStates", "Co-Simulation only");
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64[], size_t) {
  return unsupported(c, "fmi3GetContinuousStateDerivatives", "Co-Simulation only");
}
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64[], size_t) {
  return unsupported(c, "fmi3GetEventIndicators", "Co-Simulation only");
}
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64[], size_t) {
  return unsupported(c, "fmi3GetContinuousStates", "Co-Simulation only");
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64[], size_t) {
  return unsupported(c, "fmi3GetNominalsOfContinuousStates", "Co-Simulation only");
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t*) {
  return unsupported(c, "fmi3GetNumberOfEventIndicators", "Co-Simulation only");
}
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t*) {
  return unsupported(c, "fmi3GetNumberOfContinuousStates", "Co-Simulation only");
}

// ---- Co-Simulation --------------------------------------------------------------------------
fmi3Status fmi3EnterStepMode(fmi3Instance c) {
  return unsupported(c, "fmi3EnterStepMode", "no event mode: fmi3ExitInitializationMode enters Step Mode");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3Int32[],
                                    fmi3Float64[], size_t) {
  return unsupported(c, "fmi3GetOutputDerivatives", "maxOutputDerivativeOrder = 0");
}

fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean* eventHandlingNeeded, fmi3Boolean* terminateSimulation, fmi3Boolean* earlyReturn,
                      fmi3Float64* lastSuccessfulTime) {
  return call(c, "fmi3DoStep", [&](Instance* inst) {
    CALLLOG(inst, "fmi3DoStep(t=%.17g, h=%.17g)", t, h);
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)
      return inst->error("fmi3DoStep: an output argument (eventHandlingNeeded, terminateSimulation, earlyReturn, "
                         "lastSuccessfulTime) is NULL");
    const fmi2Status st = doStep(inst, "fmi3DoStep", t, h, noSetFMUStatePriorToCurrentPoint);
    *eventHandlingNeeded = false;
    *earlyReturn = false;
    *terminateSimulation = (st == fmi2OK || st == fmi2Warning || st == fmi2Discard) && inst->terminatedFlag;
    *lastSuccessfulTime = inst->lastSuccessfulTime;
    return st;
  });
}

// ---- Scheduled Execution: not provided ---------------------------------------------------
fmi3Status fmi3ActivateModelPartition(fmi3Instance c, fmi3ValueReference, fmi3Float64) {
  return unsupported(c, "fmi3ActivateModelPartition", "Co-Simulation only");
}

}  // extern "C"
