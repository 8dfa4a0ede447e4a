// GlueTestModel.fmu: a tiny model that exercises the parts of the glue the project's FMUs do not
// all use (constants, String/Boolean variables, calculated parameters, fmi2Discard with
// fmi2Terminated, exceptions thrown by a model, tunable-parameter rejection). Test-only; packed
// into <build>/test-fmus, not into ANKLEHIP_FMU_DIR. Used by tests/test_fmu_glue_model.py.
#include <cmath>
#include <stdexcept>

#include "fmuglue/glue.hpp"

using namespace fmuglue;

namespace {
namespace vr {
enum : fmi2ValueReference { u = 0, k = 1, n_fixed = 2, flag = 3, label = 4, y = 5, count = 6, pi = 7, fail_at = 8,
                            poison = 9, twice_k = 10, done = 11, note = 12 };
}

ModelInfo makeInfo() {
  ModelInfo m;
  m.model_name = "GlueTestModel";
  m.description = "Integrator y' = k u used to test the FMI 2.0 glue";
  m.author = "anklehip project";
  m.version = "1";
  m.default_experiment = {0.0, 1.0, 1e-6, 0.01};
  m.extra_log_categories = {{"logModel", "Model-specific messages"}};
  auto add = [&](const char* name, fmi2ValueReference r, Type t, Causality c, Variability v, const char* unit,
                 const char* d, double start = 0.0, double mn = kNoBound, double mx = kNoBound,
                 Initial ini = Initial::Default) {
    Variable x;
    x.name = name; x.vr = r; x.type = t; x.causality = c; x.variability = v; x.unit = unit;
    x.description = d; x.start = start; x.min = mn; x.max = mx; x.initial = ini;
    m.variables.push_back(x);
  };
  add("u", vr::u, Type::Real, Causality::Input, Variability::Continuous, "m", "Input", 0.0);
  add("k", vr::k, Type::Real, Causality::Parameter, Variability::Tunable, "1/s", "Gain (tunable, 0..10, not 7)", 2.0, 0.0, 10.0);
  add("n_fixed", vr::n_fixed, Type::Integer, Causality::Parameter, Variability::Fixed, "", "Fixed integer", 3, 0, 100);
  add("flag", vr::flag, Type::Boolean, Causality::Parameter, Variability::Fixed, "", "Fixed Boolean", 0);
  add("label", vr::label, Type::String, Causality::Parameter, Variability::Fixed, "", "Fixed String");
  m.variables.back().start_string = "abc";
  add("y", vr::y, Type::Real, Causality::Output, Variability::Continuous, "m", "Integral of k u");
  add("count", vr::count, Type::Integer, Causality::Output, Variability::Discrete, "", "Number of steps");
  add("pi", vr::pi, Type::Real, Causality::Output, Variability::Constant, "1", "A constant output", 3.141592653589793);
  add("fail_at", vr::fail_at, Type::Real, Causality::Parameter, Variability::Fixed, "s",
      "A step crossing this time is discarded and the model terminates", 1e9);
  add("poison", vr::poison, Type::Real, Causality::Input, Variability::Continuous, "1",
      "666 makes doStep throw a C++ exception", 0.0);
  add("twice_k", vr::twice_k, Type::Real, Causality::CalculatedParameter, Variability::Fixed, "1/s", "2 k");
  add("done", vr::done, Type::Boolean, Causality::Output, Variability::Discrete, "", "Terminated by fail_at");
  add("note", vr::note, Type::String, Causality::Output, Variability::Discrete, "", "Last message");
  return m;
}

class TestModel final : public Model {
 public:
  fmi2Status exit_initialization(Context& ctx) override {
    update_initial_outputs(ctx);
    if (ctx.string(vr::label).empty()) {
      ctx.log(kLogStatusError, fmi2Error, "label must not be empty");
      return fmi2Error;
    }
    return fmi2OK;
  }
  fmi2Status update_initial_outputs(Context& ctx) override {
    ctx.set_real(vr::twice_k, 2.0 * ctx.real(vr::k));
    ctx.set_real(vr::y, y_);
    ctx.set_integer(vr::count, count_);
    ctx.set_string(vr::note, "initialized");
    return fmi2OK;
  }
  fmi2Status tunable_parameters_changed(Context& ctx) override {
    if (ctx.real(vr::k) == 7.0) {
      ctx.log(kFirstModelCategory, fmi2Error, "k = 7 is not allowed");
      return fmi2Error;
    }
    return fmi2OK;
  }
  StepResult do_step(Context& ctx, double t, double h, bool) override {
    StepResult r;
    if (ctx.real(vr::poison) == 666.0) throw std::runtime_error("poisoned input");
    const double fail = ctx.real(vr::fail_at);
    if (t + h > fail) {
      y_ += ctx.real(vr::k) * ctx.real(vr::u) * (fail - t);
      ctx.set_real(vr::y, y_);
      ctx.set_boolean(vr::done, true);
      ctx.set_string(vr::note, "stopped");
      ctx.log(kLogEvents, fmi2OK, "fail_at reached");
      r.status = fmi2Discard;
      r.last_successful_time = fail;
      r.terminated = true;
      return r;
    }
    y_ += ctx.real(vr::k) * ctx.real(vr::u) * h;
    ++count_;
    ctx.set_real(vr::y, y_);
    ctx.set_integer(vr::count, count_);
    return r;
  }
  void save_state(StateWriter& w) const override {
    w.f64(y_);
    w.i32(count_);
  }
  bool load_state(Context&, StateReader& r, std::string& err) override {
    double y;
    std::int32_t c;
    if (!r.f64(y) || !r.i32(c)) { err = "truncated"; return false; }
    y_ = y;
    count_ = c;
    return true;
  }
  void reset(Context&) override {
    y_ = 0.0;
    count_ = 0;
  }

 private:
  double y_ = 0.0;
  int count_ = 0;
};
}  // namespace

const ModelInfo& fmuglue::modelInfo() {
  static const ModelInfo info = makeInfo();
  return info;
}
std::unique_ptr<Model> fmuglue::createModel() { return std::make_unique<TestModel>(); }
