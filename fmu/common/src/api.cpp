// The co-simulation operations shared by the FMI 2.0 and the FMI 3.0 API (api.hpp).
#include "api.hpp"

#include <cmath>
#include <cstring>
#include <limits>

namespace fmuglue::api {

bool completeInstantiation(Instance* inst, const char* fn, const char* token) {
  if (inst->name.empty()) {
    inst->error("%s: missing instance name", fn);
    return false;
  }
  if (token == nullptr || inst->guid != token) {
    inst->error("%s: GUID / instantiation token \"%s\" does not match this FMU's \"%s\"", fn, token ? token : "(null)",
                inst->guid.c_str());
    return false;
  }
  inst->model = createModel();
  if (!inst->model) {
    inst->error("%s: the model could not be created", fn);
    return false;
  }
  inst->model->reset(inst->ctx);
  return true;
}

fmi2Status setupExperiment(Instance* inst, const char* fn, bool toleranceDefined, double tolerance, double startTime,
                           bool stopTimeDefined, double stopTime) {
  if (!inst->allowed(kInst, fn)) return fmi2Error;
  if (!std::isfinite(startTime)) return inst->error("%s: startTime %g is not finite", fn, startTime);
  if (stopTimeDefined && !(stopTime >= startTime))
    return inst->error("%s: stopTime %g < startTime %g", fn, stopTime, startTime);
  if (toleranceDefined && !(tolerance > 0.0)) return inst->error("%s: tolerance %g must be positive", fn, tolerance);
  inst->startTime = startTime;
  inst->time = startTime;
  inst->lastSuccessfulTime = startTime;  // a state got now has time = last successful time (decodeState)
  inst->stopTimeDefined = stopTimeDefined;
  inst->stopTime = stopTime;
  inst->toleranceDefined = toleranceDefined;
  inst->tolerance = tolerance;
  return fmi2OK;
}

fmi2Status enterInitializationMode(Instance* inst, const char* fn) {
  if (!inst->allowed(kInst, fn)) return fmi2Error;
  inst->state = State::InitializationMode;
  inst->initDirty = true;
  return fmi2OK;
}

fmi2Status exitInitializationMode(Instance* inst, const char* fn) {
  if (!inst->allowed(kInit, fn)) return fmi2Error;
  fmi2Status st = inst->model->exit_initialization(inst->ctx);
  if (st == fmi2Error || st == fmi2Fatal || st == fmi2Discard || st == fmi2Pending) {
    inst->state = st == fmi2Fatal ? State::Fatal : State::Error;
    return inst->error("%s: initialization failed (see the messages above); reset or free the instance", fn);
  }
  inst->state = State::StepComplete;
  inst->time = inst->startTime;
  inst->lastSuccessfulTime = inst->startTime;
  inst->lastStepSize = 0.0;
  inst->terminatedFlag = false;
  inst->initDirty = false;
  return st;
}

fmi2Status terminate(Instance* inst, const char* fn) {
  if (!inst->allowed(kComplete | kFailed | kCanceled, fn)) return fmi2Error;
  inst->model->terminate(inst->ctx);
  inst->state = State::Terminated;
  return fmi2OK;
}

fmi2Status reset(Instance* inst, const char* fn) {
  if (!inst->allowed(kLive & ~kInProgress, fn)) return fmi2Error;
  inst->resetStore();
  inst->state = State::Instantiated;
  inst->time = inst->startTime = 0.0;
  inst->stopTimeDefined = inst->toleranceDefined = false;
  inst->stopTime = inst->tolerance = 0.0;
  inst->lastSuccessfulTime = 0.0;
  inst->lastStepSize = 0.0;
  inst->terminatedFlag = false;
  inst->model->reset(inst->ctx);
  return fmi2OK;
}

// ---- Get / set ------------------------------------------------------------------------------
static bool accessMatches(const Variable& v, Access a) {
  switch (a) {
    case Access::Real: return v.type == Type::Real;
    case Access::IntegerOrEnum: return v.type == Type::Integer;
    case Access::Int32: return v.type == Type::Integer && v.enumeration.empty();
    case Access::Enum: return v.type == Type::Integer && !v.enumeration.empty();
    case Access::Boolean: return v.type == Type::Boolean;
    case Access::String: return v.type == Type::String;
  }
  return false;
}
static const char* accessName(Access a) {
  switch (a) {
    case Access::Real: return "Real";
    case Access::IntegerOrEnum: return "Integer";
    case Access::Int32: return "Int32";
    case Access::Enum: return "Enumeration";
    case Access::Boolean: return "Boolean";
    case Access::String: return "String";
  }
  return "?";
}

bool resolve(Instance* inst, const char* fn, const fmi2ValueReference vr[], size_t nvr, const void* values, Access a) {
  std::vector<int>& idx = inst->scratch_idx;
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
    if (i < 0) {
      if (const ArrayVariable* arr = inst->arrayOf(vr[k]))
        inst->error("%s: value reference %u (element %zu) is the FMI 3.0 Float64 array \"%s\" of %zu values: "
                    "fmi3GetFloat64 / fmi3SetFloat64 with nValues counting them, or its elements' own value references",
                    fn, vr[k], k, arr->name.c_str(), arr->elements.size());
      else
        inst->error("%s: unknown value reference %u (element %zu)", fn, vr[k], k);
      return false;
    }
    const Variable& v = inst->info.variables[i];
    if (!accessMatches(v, a)) {
      inst->error("%s: value reference %u is %s \"%s\", not %s", fn, vr[k], xmlTypeName(v), v.name.c_str(),
                  accessName(a));
      return false;
    }
    idx[k] = i;
  }
  return true;
}

bool prepareGet(Instance* inst, const char* fn) {
  if (inst->state == State::InitializationMode && inst->initDirty) {
    const fmi2Status st = inst->model->update_initial_outputs(inst->ctx);
    if (st == fmi2Error || st == fmi2Fatal) {
      inst->error("%s: the initial values cannot be computed (see the messages above)", fn);
      return false;
    }
    inst->initDirty = false;
  }
  return true;
}

bool checkSettable(Instance* inst, const char* fn) {
  std::string why;
  for (int i : inst->scratch_idx) {
    if (!inst->settable(i, why)) {
      inst->error("%s: \"%s\" cannot be set in state %s: %s", fn, inst->info.variables[i].name.c_str(),
                  stateName(inst->state), why.c_str());
      return false;
    }
  }
  return true;
}

bool checkNumber(Instance* inst, const char* fn, int i, double v) {
  const Variable& var = inst->info.variables[i];
  std::string why;
  if (var.type == Type::Integer && !(v >= std::numeric_limits<int>::min() && v <= std::numeric_limits<int>::max())) {
    inst->error("%s: \"%s\" = %.17g is outside the 32-bit integers", fn, var.name.c_str(), v);
    return false;
  }
  if (valueAllowed(var, v, why)) return true;
  inst->error("%s: %s", fn, why.c_str());
  return false;
}

fmi2Status commitSet(Instance* inst, const char* fn, void (*store)(Value&, size_t, const void*), const void* values) {
  const std::vector<int>& idx = inst->scratch_idx;
  // After initialization a set that includes a (tunable) parameter may be rejected by the model:
  // keep the old values for that case only (inputs, set at every step, need no copy).
  bool anyTunable = false;
  if (inst->state == State::StepComplete)
    for (int i : idx)
      if (inst->info.variables[i].causality == Causality::Parameter) anyTunable = true;
  std::vector<Value> old;
  if (anyTunable)
    for (int i : idx) old.push_back(inst->store[i]);
  for (size_t k = 0; k < idx.size(); ++k) store(inst->store[idx[k]], k, values);
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

fmi2Status setStrings(Instance* inst, const char* fn, const fmi2ValueReference vr[], size_t nvr,
                      const char* const values[]) {
  if (!inst->allowed(kMaskSet, fn)) return fmi2Error;
  if (!resolve(inst, fn, vr, nvr, values, Access::String)) return fmi2Error;
  if (!checkSettable(inst, fn)) return fmi2Error;
  for (size_t k = 0; k < nvr; ++k)
    if (values[k] == nullptr) return inst->error("%s: value %zu is NULL", fn, k);
  return commitSet(inst, fn, [](Value& x, size_t k, const void* v) { x.s = static_cast<const char* const*>(v)[k]; },
                   values);
}

// ---- FMU states -----------------------------------------------------------------------------
// The instance's own FMU state behind the importer's pointer, or nullptr (logged). The pointer is
// looked up, never dereferenced first: a freed, forged or foreign pointer is an error, not a crash.
static StateSnapshot* toSnap(Instance* inst, void* s, const char* fn) {
  if (s == nullptr) { inst->error("%s: FMUstate is NULL", fn); return nullptr; }
  auto it = inst->states.find(s);
  if (it == inst->states.end()) {
    inst->error("%s: FMUstate %p was not created by this instance or was already freed (move a state to another "
                "instance by serializing and de-serializing it)", fn, s);
    return nullptr;
  }
  return it->second.get();
}

static StateSnapshot* newSnap(Instance* inst) {
  auto snap = std::make_unique<StateSnapshot>();
  StateSnapshot* p = snap.get();
  inst->states.emplace(p, std::move(snap));
  return p;
}

fmi2Status getState(Instance* inst, const char* fn, void** state) {
  if (!inst->allowed(kMaskState, fn)) return fmi2Error;
  if (state == nullptr) return inst->error("%s: FMUstate pointer is NULL", fn);
  StateSnapshot* snap = nullptr;
  if (*state != nullptr) {
    snap = toSnap(inst, *state, fn);
    if (!snap) return fmi2Error;
  }
  std::vector<std::uint8_t> bytes = encodeState(*inst);
  if (!snap) snap = newSnap(inst);
  snap->bytes = std::move(bytes);
  *state = snap;
  return fmi2OK;
}

fmi2Status setState(Instance* inst, const char* fn, void* state) {
  if (!inst->allowed(kMaskState | kErr, fn)) return fmi2Error;
  StateSnapshot* snap = toSnap(inst, state, fn);
  if (!snap) return fmi2Error;
  std::string err;
  if (!decodeState(*inst, snap->bytes.data(), snap->bytes.size(), err)) return inst->error("%s: %s", fn, err.c_str());
  return fmi2OK;
}

fmi2Status freeState(Instance* inst, const char* fn, void** state) {
  if (state == nullptr) return inst->error("%s: FMUstate pointer is NULL", fn);
  if (*state == nullptr) return fmi2OK;
  if (!toSnap(inst, *state, fn)) return fmi2Error;
  inst->states.erase(*state);
  *state = nullptr;
  return fmi2OK;
}

fmi2Status serializedStateSize(Instance* inst, const char* fn, void* state, size_t* size) {
  if (!inst->allowed(kMaskState | kErr, fn)) return fmi2Error;
  StateSnapshot* snap = toSnap(inst, state, fn);
  if (!snap) return fmi2Error;
  if (size == nullptr) return inst->error("%s: size is NULL", fn);
  *size = snap->bytes.size();
  return fmi2OK;
}

fmi2Status serializeState(Instance* inst, const char* fn, void* state, std::uint8_t* buffer, size_t size) {
  if (!inst->allowed(kMaskState | kErr, fn)) return fmi2Error;
  StateSnapshot* snap = toSnap(inst, state, fn);
  if (!snap) return fmi2Error;
  if (buffer == nullptr) return inst->error("%s: buffer is NULL", fn);
  if (size < snap->bytes.size())
    return inst->error("%s: buffer of %zu bytes is smaller than the state (%zu bytes)", fn, size, snap->bytes.size());
  std::memcpy(buffer, snap->bytes.data(), snap->bytes.size());
  return fmi2OK;
}

fmi2Status deserializeState(Instance* inst, const char* fn, const std::uint8_t* p, size_t size, void** state) {
  if (!inst->allowed(kMaskState | kErr, fn)) return fmi2Error;
  if (state == nullptr) return inst->error("%s: FMUstate pointer is NULL", fn);
  if (p == nullptr) return inst->error("%s: bytes are NULL", fn);
  // Check the blob completely (header, checksum, values and the model's part) by decoding it into
  // a scratch instance of the same model: this instance is not touched, whatever state it is in.
  {
    Instance scratch(inst->info, inst->name, inst->resources, nullptr, false);
    scratch.model = createModel();
    scratch.model->reset(scratch.ctx);
    std::string err;
    if (!decodeState(scratch, p, size, err)) return inst->error("%s: %s", fn, err.c_str());
  }
  StateSnapshot* snap = nullptr;
  if (*state != nullptr) {
    snap = toSnap(inst, *state, fn);
    if (!snap) return fmi2Error;
  } else {
    snap = newSnap(inst);
  }
  snap->bytes.assign(p, p + size);
  *state = snap;
  return fmi2OK;
}

// ---- The step -------------------------------------------------------------------------------
fmi2Status doStep(Instance* inst, const char* fn, double t, double h, bool noSetPrior) {
  if (!inst->allowed(kComplete, fn)) return fmi2Error;
  if (!std::isfinite(t) || !std::isfinite(h) || !(h > 0.0))
    return inst->error("%s: invalid communication point %g or step size %g (must be > 0)", fn, t, h);
  const double hmax = inst->model->max_step_size(inst->ctx);
  if (h > hmax)
    return inst->error("%s: communication step %.17g s is longer than this FMU's largest step %.17g s; "
                       "split it into shorter steps", fn, h, hmax);
  if (t + h == t) return inst->error("%s: step size %g is below the time resolution at t = %.17g", fn, h, t);
  if (!timesMatch(t, inst->time, h))  // the one time rule (glue.hpp): t = k*h and summed points alike
    return inst->error("%s: currentCommunicationPoint %.17g does not match the FMU time %.17g (tolerance %.3g s)", fn,
                       t, inst->time, timeTolerance(inst->time, h));
  if (inst->stopTimeDefined && t + h > inst->stopTime && !timesMatch(t + h, inst->stopTime, h))
    return inst->error("%s: step to %.17g goes beyond the stop time %.17g", fn, t + h, inst->stopTime);
  StepResult r = inst->model->do_step(inst->ctx, t, h, noSetPrior);
  switch (r.status) {
    case fmi2OK:
    case fmi2Warning:
      inst->time = t + h;
      inst->lastSuccessfulTime = inst->time;
      inst->lastStepSize = h;
      inst->terminatedFlag = r.terminated;
      return r.status;
    case fmi2Discard:
      inst->state = State::StepFailed;
      inst->lastSuccessfulTime = r.last_successful_time;
      inst->time = r.last_successful_time;
      inst->lastStepSize = h;
      inst->terminatedFlag = r.terminated;
      inst->log(kLogStatusDiscard, fmi2Discard, "%s: step discarded at t=%.17g (terminated=%d)", fn,
                r.last_successful_time, r.terminated ? 1 : 0);
      return fmi2Discard;
    case fmi2Fatal:
      inst->state = State::Fatal;
      inst->log(kLogStatusFatal, fmi2Fatal, "%s: fatal error in the model", fn);
      return fmi2Fatal;
    default:
      inst->state = State::Error;
      return inst->error("%s: the model failed in the step from %.17g (see the messages above)", fn, t);
  }
}

}  // namespace fmuglue::api
