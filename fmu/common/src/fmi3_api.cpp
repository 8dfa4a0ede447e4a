// The FMI 3.0 Co-Simulation C API, implemented once for every FMU of the project over the shared
// operations of api.hpp (the same state machine, checks, FMU states and step as the FMI 2.0 API,
// fmi2_api.cpp). Compiled into each FMU's FMI 3.0 shared library by add_fmu(); only the fmi3*
// symbols are exported. No exception crosses this boundary.
//
// What the FMI 3.0 twins declare and provide (docs/fmu.md, "FMI 3.0"): Co-Simulation without
// event mode, early return or intermediate update; Float64, Int32, Enumeration (fmi3Get/SetInt64),
// Boolean and String variables as in the FMI 2.0 description, plus the independent variable
// `time`; FMU states (get/set/serialize, the FMI 2.0 byte format: a state serialized by one
// version is de-serialized by the other); FMI 3.0 Float64 arrays (ModelInfo::arrays, views of scalar
// variables). With a ModelInfo::clock the same library is the Scheduled Execution variant's
// binary too (fmi3InstantiateScheduledExecution, fmi3ActivateModelPartition). Model Exchange is not
// provided.
#include <cmath>
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

// Scalar variables only: one value per value reference (an array among them is named: only
// fmi3Get/SetFloat64 take arrays).
bool checkCount(Instance* inst, const char* fn, const fmi3ValueReference vr[], size_t nvr, size_t nValues) {
  for (size_t k = 0; vr && k < nvr && !inst->info.arrays.empty(); ++k)
    if (const ArrayVariable* a = inst->arrayOf(vr[k])) {
      inst->error("%s: value reference %u is the Float64 array \"%s\": fmi3GetFloat64 / fmi3SetFloat64 read and "
                  "write it", fn, vr[k], a->name.c_str());
      return false;
    }
  if (nvr == nValues) return true;
  inst->error("%s: nValues = %zu, but the %zu value references are scalars (one value each)", fn, nValues, nvr);
  return false;
}

// fmi3Get/SetFloat64: the values the value references take (FMI 3.0 section 2.2.6.2: nValues is
// the total of their sizes): one per scalar and for `time`, an array's size per array (ModelInfo::
// arrays). `plain`: scalars only (the fast path). False (logged, naming the arrays) on a mismatch.
bool checkFloat64Count(Instance* inst, const char* fn, const fmi3ValueReference vr[], size_t nvr, size_t nValues,
                       bool& plain) {
  plain = true;
  if (vr == nullptr) return checkCount(inst, fn, vr, nvr, nValues);  // resolve() reports the NULL array
  size_t need = 0;
  std::string arrays;
  for (size_t k = 0; k < nvr; ++k) {
    if (vr[k] == kTimeValueReference) {
      plain = false;
      ++need;
    } else if (const ArrayVariable* a = inst->arrayOf(vr[k])) {
      plain = false;
      need += a->elements.size();
      std::string dims;
      for (int d : a->dimensions) dims += (dims.empty() ? "" : "x") + std::to_string(d);
      arrays += (arrays.empty() ? "" : ", ") + a->name + " (" + dims + " = " + std::to_string(a->elements.size()) +
                " values)";
    } else {
      ++need;
    }
  }
  if (need == nValues) return true;
  if (arrays.empty()) return checkCount(inst, fn, vr, nvr, nValues);
  inst->error("%s: nValues = %zu, but the %zu value references take %zu values: the arrays %s, one for each scalar",
              fn, nValues, nvr, need, arrays.c_str());
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

#define CALLLOG(inst, ...) \
  do { if ((inst)->logEnabled(kLogCalls)) (inst)->log(kLogCalls, fmi2OK, __VA_ARGS__); } while (0)

}  // namespace

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

}  // extern "C"

namespace {
// An instance of either interface (scheduled: Scheduled Execution, else Co-Simulation). The
// instantiation token is the FMI 2.0 GUID: the same model, the same FMU states.
fmi3Instance instantiate(const char* fn, bool scheduled, fmi3String instanceName, fmi3String instantiationToken,
                         fmi3String resourcePath, fmi3Boolean loggingOn, bool eventModeUsed,
                         fmi3InstanceEnvironment env, fmi3LogMessageCallback logMessage) {
  Instance* inst = nullptr;
  try {
    const ModelInfo& info = modelInfo();
    const char* name = (instanceName && instanceName[0]) ? instanceName : "";
    inst = new Instance(info, name, resourcePath ? resourcePath : "", nullptr, loggingOn);
    inst->scheduled = scheduled;
    if (logMessage) {
      inst->sink = [logMessage, env](fmi2Status status, const char* category, const char* message) {
        logMessage(env, static_cast<fmi3Status>(status), category, message);
      };
    }
    if (eventModeUsed) {
      inst->error("%s: eventModeUsed = true, but %s has no event mode (hasEventMode = false)", fn,
                  info.model_name.c_str());
      delete inst;
      return nullptr;
    }
    if (scheduled && !(info.clock.interval > 0.0)) {
      inst->error("%s: %s provides no Scheduled Execution (no model partition); instantiate it for Co-Simulation",
                  fn, info.model_name.c_str());
      delete inst;
      return nullptr;
    }
    if (!completeInstantiation(inst, fn, instantiationToken)) {
      delete inst;
      return nullptr;
    }
    CALLLOG(inst, "%s(%s, token %s, loggingOn=%d)", fn, name, instantiationToken, loggingOn);
    return inst;
  } catch (const std::exception& e) {
    if (inst) { inst->error("%s: %s", fn, e.what()); delete inst; }
  } catch (...) {
    if (inst) { inst->error("%s: unknown exception", fn); delete inst; }
  }
  return nullptr;
}
}  // namespace

extern "C" {

// Scheduled Execution (docs/fmu.md): one model partition, ModelInfo::clock; no output clocks, so
// the clock-update and preemption callbacks are never called (one partition cannot preempt itself).
fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment env, fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback, fmi3LockPreemptionCallback,
                                               fmi3UnlockPreemptionCallback) {
  (void)visible;
  return instantiate("fmi3InstantiateScheduledExecution", true, instanceName, instantiationToken, resourcePath,
                     loggingOn, false, env, logMessage);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference[], size_t, fmi3InstanceEnvironment env,
                                         fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback) {
  (void)visible;
  (void)earlyReturnAllowed;  // mightReturnEarlyFromDoStep = false: never used
  return instantiate("fmi3InstantiateCoSimulation", false, instanceName, instantiationToken, resourcePath, loggingOn,
                     eventModeUsed, env, logMessage);
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
    const char* fn = "fmi3ExitInitializationMode";
    const ScheduledClock& clock = inst->info.clock;
    if (inst->scheduled && !clock.period_parameter.empty() && inst->state == State::InitializationMode) {
      // one activation is one step of the model's own period: the two must be the same
      for (size_t i = 0; i < inst->info.variables.size(); ++i) {
        const Variable& v = inst->info.variables[i];
        if (v.name == clock.period_parameter && inst->store[i].r != clock.interval)
          return inst->error("%s: %s = %.17g s, but the Scheduled Execution clock %s ticks every %.17g s "
                             "(intervalVariability = constant) and one activation is one %s: set %s to %.17g s or use "
                             "the Co-Simulation FMU", fn, v.name.c_str(), inst->store[i].r, clock.name.c_str(),
                             clock.interval, v.name.c_str(), v.name.c_str(), clock.interval);
      }
    }
    // straight to Step Mode (Co-Simulation, no event mode) or Clock Activation Mode (Scheduled Execution)
    return exitInitializationMode(inst, fn);
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
    CALLLOG(inst, "fmi3GetFloat64(nvr=%zu, nValues=%zu)", nvr, nValues);
    const char* fn = "fmi3GetFloat64";
    auto real = [](const Value& x) { return x.r; };
    bool plain = true;
    if (!checkFloat64Count(inst, fn, vr, nvr, nValues, plain)) return fmi2Error;
    if (plain) return get(inst, fn, vr, nvr, values, Access::Real, real);
    if (values == nullptr) return inst->error("%s: value array is NULL with nValues = %zu", fn, nValues);
    size_t off = 0;  // the independent variable or arrays among them: one value reference at a time
    for (size_t k = 0; k < nvr; ++k) {
      fmi2Status st = fmi2OK;
      if (vr[k] == kTimeValueReference) {
        if (!inst->allowed(kMaskGet, fn)) return fmi2Error;
        values[off++] = inst->time;
      } else if (const ArrayVariable* a = inst->arrayOf(vr[k])) {
        st = get(inst, fn, a->elements.data(), a->elements.size(), values + off, Access::Real, real);
        off += a->elements.size();
      } else {
        st = get(inst, fn, vr + k, 1, values + off, Access::Real, real);
        ++off;
      }
      if (st != fmi2OK) return st;
    }
    return fmi2OK;
  });
}
fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Int32 values[],
                        size_t nValues) {
  return call(c, "fmi3GetInt32", [&](Instance* inst) {
    CALLLOG(inst, "fmi3GetInt32(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3GetInt32", vr, nvr, nValues)) return fmi2Error;
    return get(inst, "fmi3GetInt32", vr, nvr, values, Access::Int32, [](const Value& x) { return fmi3Int32(x.i); });
  });
}
fmi3Status fmi3GetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Int64 values[],
                        size_t nValues) {
  return call(c, "fmi3GetInt64", [&](Instance* inst) {  // the enumerations (FMI 3.0: Enumerations are Int64)
    CALLLOG(inst, "fmi3GetInt64(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3GetInt64", vr, nvr, nValues)) return fmi2Error;
    return get(inst, "fmi3GetInt64", vr, nvr, values, Access::Enum, [](const Value& x) { return fmi3Int64(x.i); });
  });
}
fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Boolean values[],
                          size_t nValues) {
  return call(c, "fmi3GetBoolean", [&](Instance* inst) {
    CALLLOG(inst, "fmi3GetBoolean(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3GetBoolean", vr, nvr, nValues)) return fmi2Error;
    return get(inst, "fmi3GetBoolean", vr, nvr, values, Access::Boolean, [](const Value& x) { return x.i != 0; });
  });
}
fmi3Status fmi3GetString(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3String values[],
                         size_t nValues) {
  return call(c, "fmi3GetString", [&](Instance* inst) {
    CALLLOG(inst, "fmi3GetString(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3GetString", vr, nvr, nValues)) return fmi2Error;
    return get(inst, "fmi3GetString", vr, nvr, values, Access::String, [](const Value& x) { return x.s.c_str(); });
  });
}

fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Float64 values[],
                          size_t nValues) {
  return call(c, "fmi3SetFloat64", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SetFloat64(nvr=%zu, nValues=%zu)", nvr, nValues);
    const char* fn = "fmi3SetFloat64";
    bool plain = true;
    if (!checkFloat64Count(inst, fn, vr, nvr, nValues, plain)) return fmi2Error;
    if (plain) return setNumbers(inst, fn, vr, nvr, values, Access::Real);
    // Arrays among them: their elements' value references in their place, one set (all or nothing).
    std::vector<fmi2ValueReference>& flat = inst->scratch_vr;
    flat.clear();
    for (size_t k = 0; k < nvr; ++k) {
      if (vr[k] == kTimeValueReference)
        return inst->error("%s: value reference %u is the independent variable time: it cannot be set", fn, vr[k]);
      const ArrayVariable* a = inst->arrayOf(vr[k]);
      if (!a) {
        flat.push_back(vr[k]);
        continue;
      }
      const Variable& first = inst->info.variables[inst->indexOf(a->elements.front())];
      if (first.causality != Causality::Input)
        return inst->error("%s: \"%s\" is an %s array: it cannot be set", fn, a->name.c_str(), xmlName(first.causality));
      flat.insert(flat.end(), a->elements.begin(), a->elements.end());
    }
    return setNumbers(inst, fn, flat.data(), flat.size(), values, Access::Real);
  });
}
fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 values[],
                        size_t nValues) {
  return call(c, "fmi3SetInt32", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SetInt32(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3SetInt32", vr, nvr, nValues)) return fmi2Error;
    return setNumbers(inst, "fmi3SetInt32", vr, nvr, values, Access::Int32);
  });
}
fmi3Status fmi3SetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Int64 values[],
                        size_t nValues) {
  return call(c, "fmi3SetInt64", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SetInt64(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3SetInt64", vr, nvr, nValues)) return fmi2Error;
    return setNumbers(inst, "fmi3SetInt64", vr, nvr, values, Access::Enum);
  });
}
fmi3Status fmi3SetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Boolean values[],
                          size_t nValues) {
  return call(c, "fmi3SetBoolean", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SetBoolean(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3SetBoolean", vr, nvr, nValues)) return fmi2Error;
    return setBooleans(inst, "fmi3SetBoolean", vr, nvr, values);
  });
}
fmi3Status fmi3SetString(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3String values[],
                         size_t nValues) {
  return call(c, "fmi3SetString", [&](Instance* inst) {
    CALLLOG(inst, "fmi3SetString(nvr=%zu)", nvr);
    if (!checkCount(inst, "fmi3SetString", vr, nvr, nValues)) return fmi2Error;
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
// The Scheduled Execution clock's interval (constant: the description's intervalDecimal).
fmi3Status fmi3GetIntervalDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
  return call(c, "fmi3GetIntervalDecimal", [&](Instance* inst) {
    const char* fn = "fmi3GetIntervalDecimal";
    if (!inst->allowed(kMaskGet, fn)) return fmi2Error;
    if (nvr > 0 && (!vr || !intervals || !qualifiers)) return inst->error("%s: an array is NULL with nvr = %zu", fn, nvr);
    const ScheduledClock& clock = inst->info.clock;
    for (size_t k = 0; k < nvr; ++k) {
      if (!(clock.interval > 0.0) || vr[k] != clock.vr)
        return inst->error("%s: value reference %u is no clock of this FMU", fn, vr[k]);
      intervals[k] = clock.interval;
      qualifiers[k] = fmi3IntervalUnchanged;
    }
    return fmi2OK;
  });
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
    if (inst->scheduled)
      return inst->error("fmi3DoStep: the instance was instantiated for Scheduled Execution: "
                         "fmi3ActivateModelPartition runs its model partition");
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

// ---- Scheduled Execution ----------------------------------------------------------------
// One tick of the one model partition: the clocked inputs set since the last activation in, the
// model's step from activationTime over the clock's interval (the same do_step a Co-Simulation
// fmi3DoStep(activationTime, interval) runs), the clocked outputs out. activationTime must be the
// clock's next tick (start time + k * interval, by the glue's time rule, glue.hpp timesMatch): a
// tick cannot be skipped or repeated, the controller's states advance one period per tick.
fmi3Status fmi3ActivateModelPartition(fmi3Instance c, fmi3ValueReference clockReference, fmi3Float64 activationTime) {
  return call(c, "fmi3ActivateModelPartition", [&](Instance* inst) {
    const char* fn = "fmi3ActivateModelPartition";
    CALLLOG(inst, "%s(clockReference=%u, activationTime=%.17g)", fn, clockReference, activationTime);
    if (!inst->scheduled)
      return inst->error("%s: the instance was instantiated for Co-Simulation: fmi3DoStep steps it", fn);
    if (!inst->allowed(kComplete, fn)) return fmi2Error;
    const ScheduledClock& clock = inst->info.clock;
    if (clockReference != clock.vr)
      return inst->error("%s: clockReference %u is not an input clock of this FMU (its one clock is %s, value "
                         "reference %u)", fn, clockReference, clock.name.c_str(), clock.vr);
    if (!std::isfinite(activationTime) || !timesMatch(activationTime, inst->time, clock.interval))
      return inst->error("%s: activationTime %.17g s is not the next tick of %s, %.17g s (every %.17g s from the "
                         "start time %.17g s; tolerance %.3g s)", fn, activationTime, clock.name.c_str(), inst->time,
                         clock.interval, inst->startTime, timeTolerance(inst->time, clock.interval));
    return doStep(inst, fn, activationTime, clock.interval, false);
  });
}

}  // extern "C"
