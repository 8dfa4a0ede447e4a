// Private to the glue: the co-simulation operations shared by the FMI 2.0 API (fmi2_api.cpp) and
// the FMI 3.0 API (fmi3_api.cpp), the Reference-FMUs pattern: one model, one implementation of
// the state machine, the checks, the FMU states and the step, and two thin C APIs over it. Every
// function logs what is wrong under logStatusError and returns the status to return (the values
// of fmi2Status and fmi3Status agree from OK to Fatal). `fn` is the C function's name, for the
// messages.
#pragma once

#include <cstdint>
#include <exception>
#include <new>
#include <type_traits>
#include <vector>

#include "instance.hpp"

namespace fmuglue::api {

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

// Runs `body(inst)`; no exception crosses the C ABI: an exception is logged, the instance goes to
// the error state and the call returns fmi2Error.
template <class F>
fmi2Status guarded(void* c, const char* fn, F&& body) {
  Instance* inst = static_cast<Instance*>(c);
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

// After the instance object exists: the instance name, the GUID / instantiation token, the model.
// False (logged; the caller deletes the instance) when one of them is wrong.
bool completeInstantiation(Instance* inst, const char* fn, const char* token);

fmi2Status setupExperiment(Instance* inst, const char* fn, bool toleranceDefined, double tolerance, double startTime,
                           bool stopTimeDefined, double stopTime);
fmi2Status enterInitializationMode(Instance* inst, const char* fn);
fmi2Status exitInitializationMode(Instance* inst, const char* fn);
fmi2Status terminate(Instance* inst, const char* fn);
fmi2Status reset(Instance* inst, const char* fn);

// The variable types an access function reads or writes. FMI 2.0 reads Integer and Enumeration
// variables with fmi2Get/SetInteger; FMI 3.0 reads Integers with fmi3Get/SetInt32 and Enumerations
// with fmi3Get/SetInt64.
enum class Access { Real, IntegerOrEnum, Int32, Enum, Boolean, String };
// The store indices of vr[0..nvr) in inst->scratch_idx (reused: no allocation per call); false
// (logged) for a NULL array, an unknown value reference or one of another type.
bool resolve(Instance* inst, const char* fn, const fmi2ValueReference vr[], size_t nvr, const void* values, Access a);
// In initialization mode: the model's calculated initial values before they are read.
bool prepareGet(Instance* inst, const char* fn);
// Set checks: the variables may be set now, and numbers are legal values.
bool checkSettable(Instance* inst, const char* fn);
bool checkNumber(Instance* inst, const char* fn, int i, double v);
// Applies the values (store(value, k) for each k) and tells the model about tunable parameters.
fmi2Status commitSet(Instance* inst, const char* fn, void (*store)(Value&, size_t, const void*), const void* values);

template <class T, class Read>
fmi2Status get(Instance* inst, const char* fn, const fmi2ValueReference vr[], size_t nvr, T values[], Access a,
               Read read) {
  if (!inst->allowed(kMaskGet, fn)) return fmi2Error;
  if (!resolve(inst, fn, vr, nvr, values, a)) return fmi2Error;
  if (!prepareGet(inst, fn)) return fmi2Error;
  for (size_t k = 0; k < nvr; ++k) values[k] = read(inst->store[inst->scratch_idx[k]]);
  return fmi2OK;
}

// A set of numbers (Real, Integer, Enumeration): checked against the variables' ranges as doubles.
template <class T>
fmi2Status setNumbers(Instance* inst, const char* fn, const fmi2ValueReference vr[], size_t nvr, const T values[],
                      Access a) {
  if (!inst->allowed(kMaskSet, fn)) return fmi2Error;
  if (!resolve(inst, fn, vr, nvr, values, a)) return fmi2Error;
  if (!checkSettable(inst, fn)) return fmi2Error;
  for (size_t k = 0; k < nvr; ++k)
    if (!checkNumber(inst, fn, inst->scratch_idx[k], static_cast<double>(values[k]))) return fmi2Error;
  return commitSet(inst, fn, [](Value& x, size_t k, const void* v) {
    const T y = static_cast<const T*>(v)[k];
    if constexpr (std::is_floating_point_v<T>) x.r = static_cast<double>(y);
    else x.i = static_cast<int>(y);  // checked against the variable's range (within int) first
  }, values);
}

template <class T>
fmi2Status setBooleans(Instance* inst, const char* fn, const fmi2ValueReference vr[], size_t nvr, const T values[]) {
  if (!inst->allowed(kMaskSet, fn)) return fmi2Error;
  if (!resolve(inst, fn, vr, nvr, values, Access::Boolean)) return fmi2Error;
  if (!checkSettable(inst, fn)) return fmi2Error;
  return commitSet(inst, fn, [](Value& x, size_t k, const void* v) { x.i = static_cast<const T*>(v)[k] ? 1 : 0; },
                   values);
}

fmi2Status setStrings(Instance* inst, const char* fn, const fmi2ValueReference vr[], size_t nvr,
                      const char* const values[]);

// FMU states (the instance's own; see instance.hpp StateSnapshot).
fmi2Status getState(Instance* inst, const char* fn, void** state);
fmi2Status setState(Instance* inst, const char* fn, void* state);
fmi2Status freeState(Instance* inst, const char* fn, void** state);
fmi2Status serializedStateSize(Instance* inst, const char* fn, void* state, size_t* size);
fmi2Status serializeState(Instance* inst, const char* fn, void* state, std::uint8_t* buffer, size_t size);
fmi2Status deserializeState(Instance* inst, const char* fn, const std::uint8_t* bytes, size_t size, void** state);

// One communication step from t to t + h: the time rule (glue.hpp timesMatch), the largest step,
// the stop time, the model's step and the state it leaves (stepComplete; stepFailed with
// inst->lastSuccessfulTime and inst->terminatedFlag on fmi2Discard; error; fatal).
fmi2Status doStep(Instance* inst, const char* fn, double t, double h, bool noSetFMUStatePriorToCurrentPoint);

}  // namespace fmuglue::api
