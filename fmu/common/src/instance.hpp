// Private to the glue: one FMU instance (state machine, variable store, logging settings).
#pragma once

#include <cstdarg>
#include <functional>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "fmuglue/glue.hpp"

namespace fmuglue {

enum class State : unsigned {
  Instantiated = 1u << 0,
  InitializationMode = 1u << 1,
  StepComplete = 1u << 2,
  StepInProgress = 1u << 3,
  StepFailed = 1u << 4,
  StepCanceled = 1u << 5,
  Terminated = 1u << 6,
  Error = 1u << 7,
  Fatal = 1u << 8,
};
const char* stateName(State s);

struct Value {
  double r = 0.0;
  int i = 0;  // Integer and Boolean
  std::string s;
};

// An fmi2FMUstate: the serialized bytes of a snapshot (state_format.cpp). Owned by the instance
// that created it (Instance::states), so fmi2FreeInstance frees the states the importer still
// holds, and a pointer is only dereferenced after it was found there.
struct StateSnapshot {
  std::vector<std::uint8_t> bytes;
};

class Instance {
 public:
  Instance(const ModelInfo& info, std::string name, std::string resources,
           const fmi2CallbackFunctions* functions, bool loggingOn);

  // --- logging ---
  void vlog(int category, fmi2Status status, const char* fmt, va_list ap);
  void log(int category, fmi2Status status, const char* fmt, ...) FMUGLUE_PRINTF_FORMAT(4, 5);
  // Logs under logStatusError and returns fmi2Error.
  fmi2Status error(const char* fmt, ...) FMUGLUE_PRINTF_FORMAT(2, 3);
  bool logEnabled(int category) const;
  int categoryCount() const { return static_cast<int>(categoryOn_.size()); }
  fmi2Status setDebugLogging(bool on, size_t n, const fmi2String categories[]);

  // --- state machine ---
  bool allowed(unsigned mask, const char* function);

  // --- store ---
  int indexOf(fmi2ValueReference vr) const {
    return vr < vrIndex_.size() ? vrIndex_[vr] : -1;
  }
  // The FMI 3.0 array variable with this value reference (ModelInfo::arrays), or nullptr.
  const ArrayVariable* arrayOf(fmi2ValueReference vr) const {
    for (const auto& a : info.arrays)  // a handful per FMU
      if (a.vr == vr) return &a;
    return nullptr;
  }
  void resetStore();
  // Whether variable `idx` may be set in the current state (and why not).
  bool settable(int idx, std::string& why) const;

  const ModelInfo& info;
  std::string name;
  std::string resources;
  fmi2CallbackFunctions callbacks{};
  // The FMI 3.0 API's logMessage callback (fmi3_api.cpp): when set, messages go there (status,
  // category, message; not a printf format) instead of callbacks.logger.
  std::function<void(fmi2Status, const char*, const char*)> sink;
  std::string guid;
  State state = State::Instantiated;
  double time = 0.0;
  double startTime = 0.0;
  double stopTime = 0.0;
  bool stopTimeDefined = false;
  double tolerance = 0.0;
  bool toleranceDefined = false;
  double lastSuccessfulTime = 0.0;
  double lastStepSize = 0.0;  // h of the last successful fmi2DoStep: the time rule's tolerance for a restored state
  bool terminatedFlag = false;
  // Instantiated by fmi3InstantiateScheduledExecution: stepped by fmi3ActivateModelPartition (one
  // tick of ModelInfo::clock), not by fmi3DoStep.
  bool scheduled = false;
  bool initDirty = true;
  std::vector<Value> store;
  std::unique_ptr<Model> model;
  Context ctx;
  std::unordered_map<const void*, std::unique_ptr<StateSnapshot>> states;
  std::vector<int> scratch_idx;  // the store indices of the current get/set call (fmi2_api.cpp)
  std::vector<fmi2ValueReference> scratch_vr;  // an fmi3SetFloat64's value references, arrays flattened

 private:
  std::vector<int> vrIndex_;
  std::vector<bool> categoryOn_;
};

// Whether `x` is a legal value of `v` (Real, Integer or Boolean as a double), else `why` names the
// variable, the value and the rule. The one rule for values set by the importer and values
// restored from an FMU state: parameters finite and within [min, max]; inputs within [min, max]
// or non-finite (a sensor fault the model contains and reports); Booleans 0 or 1.
bool valueAllowed(const Variable& v, double x, std::string& why);

// Serialized-state codec (state_format.cpp).
std::vector<std::uint8_t> encodeState(Instance& inst);
// Decodes and applies; on failure nothing is changed and `err` says why.
bool decodeState(Instance& inst, const std::uint8_t* p, std::size_t n, std::string& err);
// FNV-1a, 64 bits (Fowler, Noll, Vo; http://www.isthe.com/chongo/tech/comp/fnv/): offset basis
// 14695981039346656037, prime 1099511628211. The checksum of serialized FMU states (format 3; formats
// 1-2 used the basis 1469598103934665603, one digit short) and the GUID's hash.
inline constexpr std::uint64_t kFnv1a64OffsetBasis = 14695981039346656037ull;
std::uint64_t fnv1a64(const void* p, std::size_t n, std::uint64_t h = kFnv1a64OffsetBasis);

}  // namespace fmuglue
