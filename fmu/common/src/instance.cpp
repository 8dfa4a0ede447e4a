// The glue's instance: logging, state checks, variable store, and the Context used by models.
#include "instance.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>

namespace fmuglue {

static const char* const kGlueCategories[] = {"logEvents",      "logStatusWarning",
                                              "logStatusDiscard", "logStatusError",
                                              "logStatusFatal", "logCalls"};

const char* stateName(State s) {
  switch (s) {
    case State::Instantiated: return "instantiated";
    case State::InitializationMode: return "initializationMode";
    case State::StepComplete: return "stepComplete";
    case State::StepInProgress: return "stepInProgress";
    case State::StepFailed: return "stepFailed";
    case State::StepCanceled: return "stepCanceled";
    case State::Terminated: return "terminated";
    case State::Error: return "error";
    case State::Fatal: return "fatal";
  }
  return "?";
}

Instance::Instance(const ModelInfo& inf, std::string nm, std::string res,
                   const fmi2CallbackFunctions* functions, bool loggingOn)
    : info(inf), name(std::move(nm)), resources(std::move(res)), ctx(*this) {
  if (functions) callbacks = *functions;
  guid = &info == &modelInfo() ? thisModelGuid() : modelGuid(info);
  fmi2ValueReference maxVr = 0;
  for (const auto& v : info.variables) maxVr = v.vr > maxVr ? v.vr : maxVr;
  vrIndex_.assign(info.variables.empty() ? 0 : static_cast<size_t>(maxVr) + 1, -1);
  for (size_t i = 0; i < info.variables.size(); ++i)
    vrIndex_[info.variables[i].vr] = static_cast<int>(i);
  // loggingOn: every category but logCalls (one line per fmi2 call would bury the events);
  // logCalls only when fmi2SetDebugLogging asks for it. Errors are always explained.
  categoryOn_.assign(kFirstModelCategory + info.extra_log_categories.size(), loggingOn);
  categoryOn_[kLogCalls] = false;
  categoryOn_[kLogStatusError] = true;
  categoryOn_[kLogStatusFatal] = true;
  resetStore();
}

void Instance::resetStore() {
  store.assign(info.variables.size(), Value{});
  for (size_t i = 0; i < info.variables.size(); ++i) {
    const Variable& v = info.variables[i];
    Value& x = store[i];
    switch (v.type) {
      case Type::Real: x.r = v.start; break;
      case Type::Integer: x.i = static_cast<int>(v.start); break;
      case Type::Boolean: x.i = v.start != 0.0 ? 1 : 0; break;
      case Type::String: x.s = v.start_string; break;
    }
  }
  initDirty = true;
}

bool Instance::logEnabled(int category) const {
  return category >= 0 && category < static_cast<int>(categoryOn_.size()) && categoryOn_[category] &&
         (callbacks.logger != nullptr || sink);
}

static const char* categoryName(const ModelInfo& info, int category) {
  if (category >= 0 && category < kFirstModelCategory) return kGlueCategories[category];
  size_t k = static_cast<size_t>(category - kFirstModelCategory);
  return k < info.extra_log_categories.size() ? info.extra_log_categories[k].name.c_str() : "log";
}

void Instance::vlog(int category, fmi2Status status, const char* fmt, va_list ap) {
  if (!logEnabled(category)) return;
  char buf[1024];
  va_list aq;
  va_copy(aq, ap);
  int n = std::vsnprintf(buf, sizeof buf, fmt, aq);
  va_end(aq);
  std::string msg = n < 0 ? std::string("(log formatting error)") : std::string(buf);
  if (sink) {
    sink(status, categoryName(info, category), msg.c_str());
    return;
  }
  // The importer's logger treats the message as a printf format: escape '%'.
  std::string esc;
  esc.reserve(msg.size());
  for (char c : msg) {
    esc += c;
    if (c == '%') esc += '%';
  }
  callbacks.logger(callbacks.componentEnvironment, name.c_str(), status,
                   categoryName(info, category), esc.c_str());
}

void Instance::log(int category, fmi2Status status, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vlog(category, status, fmt, ap);
  va_end(ap);
}

fmi2Status Instance::error(const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vlog(kLogStatusError, fmi2Error, fmt, ap);
  va_end(ap);
  return fmi2Error;
}

fmi2Status Instance::setDebugLogging(bool on, size_t n, const fmi2String categories[]) {
  if (n == 0) {
    for (size_t i = 0; i < categoryOn_.size(); ++i) categoryOn_[i] = on;
    return fmi2OK;
  }
  if (categories == nullptr) return error("fmi2SetDebugLogging: categories is NULL but nCategories = %zu", n);
  // Validate all names first so that a bad call changes nothing.
  std::vector<int> idx;
  for (size_t k = 0; k < n; ++k) {
    if (categories[k] == nullptr) return error("fmi2SetDebugLogging: category %zu is NULL", k);
    int found = -1;
    for (int c = 0; c < categoryCount(); ++c)
      if (std::strcmp(categoryName(info, c), categories[k]) == 0) found = c;
    if (found < 0) return error("fmi2SetDebugLogging: unknown log category \"%s\"", categories[k]);
    idx.push_back(found);
  }
  for (int c : idx) categoryOn_[c] = on;
  return fmi2OK;
}

bool Instance::allowed(unsigned mask, const char* function) {
  if (mask & static_cast<unsigned>(state)) return true;
  error("%s must not be called in state %s", function, stateName(state));
  return false;
}

bool Instance::settable(int idx, std::string& why) const {
  const Variable& v = info.variables[idx];
  if (v.variability == Variability::Constant) {
    why = "it is a constant";
    return false;
  }
  if (v.causality != Causality::Parameter && v.causality != Causality::Input) {
    why = "only inputs and parameters can be set";
    return false;
  }
  Initial ini = effectiveInitial(v);
  switch (state) {
    case State::Instantiated:
      if (ini == Initial::Exact || ini == Initial::Approx) return true;
      why = "its initial attribute is calculated";
      return false;
    case State::InitializationMode:
      if (ini == Initial::Exact || v.causality == Causality::Input) return true;
      why = "only initial=exact variables and inputs can be set in initialization mode";
      return false;
    case State::StepComplete:
      if (v.causality == Causality::Input) return true;
      if (v.causality == Causality::Parameter && v.variability == Variability::Tunable) return true;
      why = "after initialization only inputs and tunable parameters can be set";
      return false;
    default:
      why = "values cannot be set in this state";
      return false;
  }
}

bool valueAllowed(const Variable& v, double x, std::string& why) {
  char buf[512];
  if (v.type == Type::Boolean) {
    if (x == 0.0 || x == 1.0) return true;
    std::snprintf(buf, sizeof buf, "\"%s\" = %.17g is not a Boolean (0 or 1)", v.name.c_str(), x);
  } else if (!std::isfinite(x)) {
    if (v.causality == Causality::Input) return true;  // contained by the model (fault output)
    std::snprintf(buf, sizeof buf, "\"%s\" = %g is not a finite number", v.name.c_str(), x);
  } else if ((!std::isnan(v.min) && x < v.min) || (!std::isnan(v.max) && x > v.max)) {
    std::snprintf(buf, sizeof buf, "\"%s\" = %.17g is outside [%g, %g]", v.name.c_str(), x, v.min, v.max);
  } else {
    return true;
  }
  why = buf;
  return false;
}

// ------------------------------------------------------------------------------------------
// Context
static const Value* typedValue(const Instance& inst, fmi2ValueReference vr, Type t) {
  int i = inst.indexOf(vr);
  if (i < 0 || inst.info.variables[i].type != t) return nullptr;
  return &inst.store[i];
}

double Context::real(fmi2ValueReference vr) const {
  const Value* x = typedValue(inst_, vr, Type::Real);
  if (!x) { inst_.error("model bug: no Real variable with value reference %u", vr); return 0.0; }
  return x->r;
}
void Context::set_real(fmi2ValueReference vr, double v) {
  Value* x = const_cast<Value*>(typedValue(inst_, vr, Type::Real));
  if (!x) { inst_.error("model bug: no Real variable with value reference %u", vr); return; }
  x->r = v;
}
int Context::integer(fmi2ValueReference vr) const {
  const Value* x = typedValue(inst_, vr, Type::Integer);
  if (!x) { inst_.error("model bug: no Integer variable with value reference %u", vr); return 0; }
  return x->i;
}
void Context::set_integer(fmi2ValueReference vr, int v) {
  Value* x = const_cast<Value*>(typedValue(inst_, vr, Type::Integer));
  if (!x) { inst_.error("model bug: no Integer variable with value reference %u", vr); return; }
  x->i = v;
}
bool Context::boolean(fmi2ValueReference vr) const {
  const Value* x = typedValue(inst_, vr, Type::Boolean);
  if (!x) { inst_.error("model bug: no Boolean variable with value reference %u", vr); return false; }
  return x->i != 0;
}
void Context::set_boolean(fmi2ValueReference vr, bool v) {
  Value* x = const_cast<Value*>(typedValue(inst_, vr, Type::Boolean));
  if (!x) { inst_.error("model bug: no Boolean variable with value reference %u", vr); return; }
  x->i = v ? 1 : 0;
}
const std::string& Context::string(fmi2ValueReference vr) const {
  static const std::string empty;
  const Value* x = typedValue(inst_, vr, Type::String);
  if (!x) { inst_.error("model bug: no String variable with value reference %u", vr); return empty; }
  return x->s;
}
void Context::set_string(fmi2ValueReference vr, const std::string& v) {
  Value* x = const_cast<Value*>(typedValue(inst_, vr, Type::String));
  if (!x) { inst_.error("model bug: no String variable with value reference %u", vr); return; }
  x->s = v;
}
void Context::log(int category, fmi2Status status, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  inst_.vlog(category, status, fmt, ap);
  va_end(ap);
}
bool Context::log_enabled(int category) const { return inst_.logEnabled(category); }
const std::string& Context::instance_name() const { return inst_.name; }
const std::string& Context::resource_location() const { return inst_.resources; }
double Context::start_time() const { return inst_.startTime; }
double Context::time() const { return inst_.time; }
double Context::last_step_size() const { return inst_.lastStepSize; }
bool Context::initialized() const {
  return inst_.state != State::Instantiated && inst_.state != State::InitializationMode;
}
bool Context::stop_time_defined() const { return inst_.stopTimeDefined; }
double Context::stop_time() const { return inst_.stopTime; }
bool Context::tolerance_defined() const { return inst_.toleranceDefined; }
double Context::tolerance() const { return inst_.tolerance; }
const ModelInfo& Context::info() const { return inst_.info; }

// ------------------------------------------------------------------------------------------
// StateWriter / StateReader (little-endian host assumed: x86-64/aarch64; checked in the header
// of serialized states through the magic and the checksum).
void StateWriter::bytes(const void* p, std::size_t n) {
  const auto* b = static_cast<const std::uint8_t*>(p);
  out_.insert(out_.end(), b, b + n);
}
void StateWriter::u32(std::uint32_t v) { bytes(&v, 4); }
void StateWriter::u64(std::uint64_t v) { bytes(&v, 8); }
void StateWriter::i32(std::int32_t v) { bytes(&v, 4); }
void StateWriter::f64(double v) { bytes(&v, 8); }
void StateWriter::str(const std::string& s) {
  u64(s.size());
  bytes(s.data(), s.size());
}

bool StateReader::bytes(void* dst, std::size_t n) {
  if (n > n_ - pos_) return false;
  if (n) std::memcpy(dst, p_ + pos_, n);
  pos_ += n;
  return true;
}
bool StateReader::u32(std::uint32_t& v) { return bytes(&v, 4); }
bool StateReader::u64(std::uint64_t& v) { return bytes(&v, 8); }
bool StateReader::i32(std::int32_t& v) { return bytes(&v, 4); }
bool StateReader::f64(double& v) { return bytes(&v, 8); }
bool StateReader::str(std::string& s, std::size_t max_len) {
  std::uint64_t n = 0;
  size_t save = pos_;
  if (!u64(n)) return false;
  if (n > max_len || n > n_ - pos_) { pos_ = save; return false; }
  s.assign(reinterpret_cast<const char*>(p_ + pos_), static_cast<size_t>(n));
  pos_ += static_cast<size_t>(n);
  return true;
}

void FieldReader::operator()(const char* name, double& v) {
  if (!ok()) return;
  if (!r.f64(v)) error = std::string(name) + ": truncated";
  else if (!std::isfinite(v)) error = std::string(name) + ": not a finite number";
}
void FieldReader::operator()(const char* name, std::int32_t& v) {
  if (ok() && !r.i32(v)) error = std::string(name) + ": truncated";
}
void FieldReader::operator()(const char* name, std::int64_t& v) {
  std::uint64_t u = 0;
  if (!ok()) return;
  if (!r.u64(u)) error = std::string(name) + ": truncated";
  else if (u > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) error = std::string(name) + ": negative count";
  else v = static_cast<std::int64_t>(u);
}
void FieldReader::operator()(const char* name, std::uint64_t& v) {
  if (ok() && !r.u64(v)) error = std::string(name) + ": truncated";
}
void FieldReader::operator()(const char* name, bool& v) {
  std::uint32_t u = 0;
  if (!ok()) return;
  if (!r.u32(u)) error = std::string(name) + ": truncated";
  else if (u > 1) error = std::string(name) + ": not a Boolean (" + std::to_string(u) + ")";
  else v = u == 1;
}

}  // namespace fmuglue
