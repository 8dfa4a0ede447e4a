// FMI 2.0 co-simulation glue shared by every FMU of the project.
//
// An FMU is defined by three things (see fmu/common/README.md):
//   1. a ModelInfo: model name, description, default experiment, extra log categories and the
//      variable table (one Variable per FMU variable; the only place a variable is described);
//   2. a class derived from fmuglue::Model (the behaviour: initialization, doStep, state hooks);
//   3. the two functions fmuglue::modelInfo() and fmuglue::createModel() defined by the FMU.
// The glue implements every fmi2* function (state machine, checks, logging, FMU state and its
// serialization) and generates modelDescription.xml from the same ModelInfo at build time.
//
// The glue holds the value of every variable in a store owned by the instance; the model reads
// inputs/parameters from it and writes outputs into it through the Context. Nothing is global:
// every instance owns its store, its model object and its logging settings.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "fmi2Functions.h"

namespace fmuglue {

inline constexpr unsigned kGlueInterfaceVersion = 1;  // bumped on incompatible API changes

enum class Type { Real, Integer, Boolean, String };
enum class Causality { Parameter, CalculatedParameter, Input, Output, Local, Independent };
enum class Variability { Constant, Fixed, Tunable, Discrete, Continuous };
// Initial::Default means "the FMI 2.0 default for this causality/variability combination".
enum class Initial { Default, Exact, Approx, Calculated };

inline constexpr double kNoBound = std::numeric_limits<double>::quiet_NaN();

// One FMU variable. Value references must be unique within the whole table (across types).
// `start` is used for Real/Integer/Boolean (Boolean: 0 or 1), `start_string` for String.
// Variables with initial=calculated have no start value (start is ignored for them).
// `min`/`max`: NaN = no bound (Real and Integer only); the glue rejects sets outside the bounds.
struct Variable {
  std::string name;
  fmi2ValueReference vr = 0;
  Type type = Type::Real;
  Causality causality = Causality::Local;
  Variability variability = Variability::Continuous;
  Initial initial = Initial::Default;
  std::string unit;         // Real only; "" = dimensionless/no unit. Declared in <UnitDefinitions>.
  std::string description;  // required (the generator refuses an empty description)
  double start = 0.0;
  std::string start_string;
  double min = kNoBound;
  double max = kNoBound;
};

// Extra log category declared by a model (the glue declares its own, see LogCategory).
struct LogCategoryInfo {
  std::string name;
  std::string description;
};

struct DefaultExperiment {
  double start_time = 0.0;
  double stop_time = 1.0;
  double tolerance = 1e-6;
  double step_size = 1e-3;
};

struct ModelInfo {
  std::string model_name;        // also the modelIdentifier (the .so name)
  std::string description;
  // Project metadata shared by every FMU of the project; the version is CMake's PROJECT_VERSION.
  std::string author = "anklehip project";
  std::string version = ANKLEHIP_VERSION;
  std::string copyright;
  std::string license = "see the project repository";
  DefaultExperiment default_experiment;
  std::vector<Variable> variables;
  std::vector<LogCategoryInfo> extra_log_categories;  // indices kFirstModelCategory, +1, ...
  // Outputs whose value at a communication point depends directly on inputs set at that point.
  // false (typical for a sampled controller or an integrating plant): the <Outputs> entries get
  // dependencies="" (no direct feed-through), so masters see no algebraic loop.
  bool outputs_depend_on_inputs = false;
  bool can_handle_variable_step = true;
  bool can_interpolate_inputs = false;
  // Files the generator writes into the FMU's resources/ folder: (file name, content).
  std::vector<std::pair<std::string, std::string>> resources;
};

// Log categories declared by the glue for every FMU (in this order in <LogCategories>).
enum LogCategory : int {
  kLogEvents = 0,         // "logEvents": discrete events (phase changes, contact changes, ...)
  kLogStatusWarning = 1,  // "logStatusWarning"
  kLogStatusDiscard = 2,  // "logStatusDiscard"
  kLogStatusError = 3,    // "logStatusError"
  kLogStatusFatal = 4,    // "logStatusFatal"
  kLogCalls = 5,          // "logCalls": every fmi2* call with its arguments
  kFirstModelCategory = 6 // first index of ModelInfo::extra_log_categories
};

// Result of Model::doStep.
struct StepResult {
  fmi2Status status = fmi2OK;     // OK, Warning, Discard or Error
  // With fmi2Discard: the time up to which the step succeeded (fmi2LastSuccessfulTime) and
  // whether the slave wants to stop (fmi2Terminated). The outputs in the store must be the
  // values at last_successful_time.
  double last_successful_time = 0.0;
  bool terminated = false;
};

// Bounds-checked byte writer/reader for model state (FMU state snapshots and serialization).
class StateWriter {
 public:
  explicit StateWriter(std::vector<std::uint8_t>& out) : out_(out) {}
  void bytes(const void* p, std::size_t n);
  void u32(std::uint32_t v);
  void u64(std::uint64_t v);
  void i32(std::int32_t v);
  void f64(double v);
  void str(const std::string& s);  // u64 length + bytes
  // Trivially copyable values (e.g. a POD controller struct) as raw bytes.
  template <class T> void pod(const T& v) { bytes(&v, sizeof(T)); }

 private:
  std::vector<std::uint8_t>& out_;
};

class StateReader {
 public:
  StateReader(const std::uint8_t* p, std::size_t n) : p_(p), n_(n) {}
  // Every getter returns false (and reads nothing) if fewer bytes remain than requested.
  bool bytes(void* dst, std::size_t n);
  bool u32(std::uint32_t& v);
  bool u64(std::uint64_t& v);
  bool i32(std::int32_t& v);
  bool f64(double& v);
  bool str(std::string& s, std::size_t max_len = (1u << 20));
  template <class T> bool pod(T& v) { return bytes(&v, sizeof(T)); }
  std::size_t remaining() const { return n_ - pos_; }
  bool at_end() const { return pos_ == n_; }

 private:
  const std::uint8_t* p_;
  std::size_t n_;
  std::size_t pos_ = 0;
};

class Instance;  // the glue's instance (opaque to models)

// What a model sees of its instance: the variable store, logging and the experiment set-up.
// Accessing a value reference that is not in the table or has another type is a programming
// error: the getter returns 0/""/false and the setter does nothing, and an error is logged.
class Context {
 public:
  explicit Context(Instance& inst) : inst_(inst) {}

  double real(fmi2ValueReference vr) const;
  void set_real(fmi2ValueReference vr, double v);
  int integer(fmi2ValueReference vr) const;
  void set_integer(fmi2ValueReference vr, int v);
  bool boolean(fmi2ValueReference vr) const;
  void set_boolean(fmi2ValueReference vr, bool v);
  const std::string& string(fmi2ValueReference vr) const;
  void set_string(fmi2ValueReference vr, const std::string& v);

  // printf-style logging through the importer's callback, if the category is enabled.
  // category: a LogCategory or kFirstModelCategory + index into extra_log_categories.
  void log(int category, fmi2Status status, const char* fmt, ...)
#if defined(__GNUC__)
      __attribute__((format(printf, 4, 5)))
#endif
      ;
  bool log_enabled(int category) const;

  const std::string& instance_name() const;
  const std::string& resource_location() const;  // fmuResourceLocation as given (may be "")
  double start_time() const;                     // from fmi2SetupExperiment
  bool stop_time_defined() const;
  double stop_time() const;
  bool tolerance_defined() const;
  double tolerance() const;
  const ModelInfo& info() const;

 private:
  Instance& inst_;
};

// The behaviour of one FMU. One object per fmi2Instantiate; never shared between instances.
// Exceptions thrown by any hook are caught by the glue (fmi2Error + log; fatal from doStep).
class Model {
 public:
  virtual ~Model() = default;

  // Called after fmi2Instantiate and after fmi2Reset, when the store holds the start values.
  // Bring the model to its freshly-instantiated state.
  virtual void reset(Context& /*ctx*/) {}

  // Called at fmi2ExitInitializationMode: read parameters and inputs from the store, validate
  // them (return fmi2Error after logging which parameter and value is wrong), initialize, and
  // write the initial outputs into the store.
  virtual fmi2Status exit_initialization(Context& ctx) = 0;

  // Called before a fmi2Get* in initialization mode if values were set since the last call, so
  // calculated outputs/calculated parameters can be provided. Default: nothing.
  virtual void update_initial_outputs(Context& /*ctx*/) {}

  // Called after tunable parameters were set in stepComplete state (once per fmi2Set* call that
  // touched a tunable parameter). Validate and apply; on fmi2Error the glue restores the previous
  // values of the variables set by that call and returns fmi2Error (the instance stays usable).
  virtual fmi2Status tunable_parameters_changed(Context& /*ctx*/) { return fmi2OK; }

  // Advance from t to t + h. Inputs are in the store; write outputs into it.
  virtual StepResult do_step(Context& ctx, double t, double h, bool no_set_prior_state) = 0;

  // Called at fmi2Terminate. Default: nothing.
  virtual void terminate(Context& /*ctx*/) {}

  // FMU state: everything of the model that is not in the variable store (internal states,
  // integrator state, counters). The glue saves the store, the time and its own state itself.
  // load_state must check what it reads (StateReader returns false on a short read), return
  // false with a message in `err` on malformed data, and must leave the model unchanged then.
  virtual void save_state(StateWriter& w) const = 0;
  virtual bool load_state(StateReader& r, std::string& err) = 0;
  // Increase when the layout written by save_state changes; stored in and checked against
  // serialized FMU states.
  virtual std::uint32_t state_version() const { return 1; }
};

// ---- Defined once per FMU by the FMU's own sources -------------------------------------------
const ModelInfo& modelInfo();                  // the variable table etc. (built once, immutable)
std::unique_ptr<Model> createModel();          // a new model object for a new instance

// ---- Helpers for plant models (the sagittal and the 3D plant share their doStep rules) -------
// Reads n Real inputs into `in`. A non-finite value is logged with its name and replaced by the
// last finite one, kept in `last` (the input is contained, never propagated). Returns fmi2Warning
// if any input was replaced, else fmi2OK.
fmi2Status readFiniteInputs(Context& ctx, double t, int n, const fmi2ValueReference* vrs,
                            const char* const* names, double* last, double* in);
// How a plant's step ended, and the doStep result for it: Ok gives `ok_status`; Fallen gives
// fmi2Discard with fmi2Terminated at fall_time, the message logged; Error gives fmi2Error.
enum class PlantOutcome { Ok, Fallen, Error };
StepResult plantStepResult(Context& ctx, PlantOutcome outcome, fmi2Status ok_status, double fall_time,
                           const std::string& message);
// doStep on a plant that has already fallen: fmi2Discard, terminated, at the fall time.
StepResult alreadyFallen(Context& ctx, double fall_time);

// ---- Utilities used by the generator and the tests ------------------------------------------
// Checks the table (unique names/vrs, legal causality/variability/initial combinations, start
// values where required, bounds containing start, descriptions present). Empty string = OK.
std::string validateModelInfo(const ModelInfo& info);
// Deterministic GUID derived from the whole ModelInfo (any change in the table changes it).
std::string modelGuid(const ModelInfo& info);
// The complete modelDescription.xml text.
std::string modelDescriptionXml(const ModelInfo& info);
// The modelDescription.xml spelling of each enum value ("" for Initial::Default): one table for the
// XML, the generated documentation and log messages.
const char* xmlName(Type t);
const char* xmlName(Causality c);
const char* xmlName(Variability v);
const char* xmlName(Initial i);
// The effective initial attribute of a variable (resolves Initial::Default per FMI 2.0).
Initial effectiveInitial(const Variable& v);

}  // namespace fmuglue
