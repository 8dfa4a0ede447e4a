// Hoap2Plant.fmu: the HOAP-2 sagittal plant (plant/, hoap2plant::Plant) behind the FMI 2.0
// co-simulation glue (fmu/common). Signals as docs/plant.md names them; model parameters carry the same
// names as the controller's ahc_params fields where they mean the same thing; start values come
// from hoap2plant::default_params() (which reads hoap2/nominal.h: one source of truth).
// Outputs are sampled at the communication points (no direct feed-through).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "fmuglue/glue.hpp"
#include "hoap2plant/plant.hpp"
#include "hoap2/nominal.h"

using namespace fmuglue;
using hoap2plant::Params;
using hoap2plant::Plant;

namespace {

// Largest push magnitude accepted [N]: 14 times the robot's weight, far beyond any push it can
// survive (about 11 N held statically) yet still a force the integrator resolves into a
// fall. A larger value is refused by fmi2SetReal, naming the variable and the range.
constexpr double kMaxPush = 1000.0;

namespace vr {
enum : fmi2ValueReference {
  // inputs
  theta_ankle_ref = 0, theta_hip_ref = 1, push_force = 2,
  // outputs
  theta_ankle = 10, theta_hip = 11, dtheta_ankle = 12, dtheta_hip = 13, zmp_x = 14, fz = 15, fx = 16,
  com_x = 17, com_z = 18, foot_pitch = 19, contact_mode = 20, fallen = 21, f_toe = 22, f_heel = 23,
  required_mu = 24, zmp_true = 25, fz_true = 26, energy = 27, tau_ankle = 28, tau_hip = 29,
  moment_ankle = 30, input_fault = 31,
  cvode_steps = 40, rhs_evals = 41, root_evals = 42, mode_switches = 43, impacts = 44,
  // parameters: 100 + index into kParams; then the non-Real ones
  first_real_param = 100,
  servo_on = 190, seed = 191, lock_joints_at_impact = 192, integrator = 193
};
}

// Real parameters: name, member, unit, description, min, max.
struct RealParam {
  const char* name;
  double Params::*field;
  const char* unit;
  const char* description;
  double min, max;
};

// The relative tolerances the integrators are used with (the parameter rtol, or the importer's).
constexpr double kMinRtol = 1e-14, kMaxRtol = 1e-2;
// The smallest servo velocity gain other than 0 (the 3D plant's minimum).
constexpr double kMinServoKd = 1e-6;

// The parameter `integrator`: 0 ERK, 1 BDF (hoap2plant::Integrator), 2 automatic.
constexpr int kIntegratorAuto = 2;
// The fastest rate |lambda| of the linearised equations (Model::fastest_rate) above which the
// automatic choice takes BDF: about where the explicit method's stability-limited steps start to
// cost more than BDF's (docs/plant.md section 7, "Stiff servo gains": scripts/stiff_crossover.py).
constexpr double kStiffRate = 3e5;

// Explicit integration is refused above this rate (ten times kStiffRate): its stability limits its
// steps to about 3.3 / rate (1e-6 s there), and it takes far longer than BDF (the audit's gains,
// kp = 1e6 and kd = 1e5: 7 times for 20 ms of motion, 300 times for a 0.5 s step).
constexpr double kErkRefusedRate = 10.0 * kStiffRate;
// The explicit integrator's steps in one fmi2DoStep (about 5 s of computation): beyond, the step
// fails with the reason. At the HOAP-2's gains a communication step of an hour at rest takes few.
constexpr long kMaxErkStepsPerStep = 1000000;

// The fastest rate of the plant built from p in its initial posture at rest (foot flat, the joints
// at their initial set points): what decides the automatic integrator and refuses ERK.
double fastestRate(const Params& p) {
  hoap2plant::Vec5 q;
  q << 0.0, p.ankle_height, 0.0, p.theta_ankle_init, p.theta_hip_init;
  return hoap2plant::Model(p).fastest_rate(q);
}

const RealParam kParams[] = {
    {"g", &Params::g, "m/s2", "Gravitational acceleration", 0.0, 100.0},
    {"m1", &Params::m1, "kg", "Mass of link 1 (both legs, knee straight)", 1e-6, 1e3},
    {"l1", &Params::l1, "m", "Length of link 1, ankle axis -> hip axis", 1e-6, 10.0},
    {"lg1", &Params::lg1, "m", "Ankle axis -> CoM of link 1", -10.0, 10.0},
    {"I1", &Params::I1, "kg.m2", "Inertia of link 1 about its CoM (pitch)", 0.0, 1e3},
    {"m2", &Params::m2, "kg", "Mass of link 2 (waist, trunk, arms, head)", 1e-6, 1e3},
    {"lg2", &Params::lg2, "m", "Hip axis -> CoM of link 2", -10.0, 10.0},
    {"I2", &Params::I2, "kg.m2", "Inertia of link 2 about its CoM (pitch)", 0.0, 1e3},
    {"feet_mass", &Params::feet_mass, "kg", "Mass of both feet (incl. ankle links, sole plates)", 1e-6, 1e3},
    {"feet_inertia", &Params::feet_inertia, "kg.m2", "Inertia of both feet about their CoM (pitch)", 0.0, 1e3},
    {"feet_com_x", &Params::feet_com_x, "m", "Feet CoM, x forward of the ankle axis", -1.0, 1.0},
    {"feet_com_z", &Params::feet_com_z, "m", "Feet CoM, height above the sole", -1.0, 1.0},
    {"toe_x", &Params::toe_x, "m", "Toe edge of the sole, x from the ankle axis (> 0)", 1e-6, 1.0},
    {"heel_x", &Params::heel_x, "m", "Heel edge of the sole, x from the ankle axis (< 0)", -1.0, -1e-6},
    {"ankle_height", &Params::ankle_height, "m", "Ankle axis height above the sole", 1e-6, 1.0},
    {"kp_ankle", &Params::kp_ankle, "N.m/rad", "Ankle servo position gain (both legs; PD when unsaturated)", 0.0, 1e6},
    {"kd_ankle", &Params::kd_ankle, "N.m.s/rad", "Ankle servo velocity gain", 0.0, 1e5},
    {"kp_hip", &Params::kp_hip, "N.m/rad", "Hip servo position gain (both legs)", 0.0, 1e6},
    {"kd_hip", &Params::kd_hip, "N.m.s/rad", "Hip servo velocity gain", 0.0, 1e5},
    {"tau_max_ankle", &Params::tau_max_ankle, "N.m", "Ankle servo torque limit (2 motors x 9 N.m)", 1e-6, 1e4},
    {"tau_max_hip", &Params::tau_max_hip, "N.m", "Hip servo torque limit (2 motors x 9 N.m)", 1e-6, 1e4},
    {"vel_max_ankle", &Params::vel_max_ankle, "rad/s", "Ankle servo velocity limit", 1e-6, 1e3},
    {"vel_max_hip", &Params::vel_max_hip, "rad/s", "Hip servo velocity limit", 1e-6, 1e3},
    {"damping_ankle", &Params::damping_ankle, "N.m.s/rad", "Passive viscous damping of the ankle joint", 0.0, 1e4},
    {"damping_hip", &Params::damping_hip, "N.m.s/rad", "Passive viscous damping of the hip joint", 0.0, 1e4},
    {"h_push", &Params::h_push, "m", "Height of the push point above the sole (erect posture), on link 2", 0.0, 10.0},
    {"fall_foot_pitch", &Params::fall_foot_pitch, "rad", "Fallen when |foot pitch| exceeds this", 1e-3, 1.5},
    {"fall_body_pitch", &Params::fall_body_pitch, "rad", "Fallen when the ankle->CoM line leans more than this", 1e-3, 1.5},
    {"baumgarte", &Params::baumgarte, "1/s", "Pivot-constraint stabilization rate in the rocking modes", 0.0, 1e4},
    {"sensor_noise", &Params::sensor_noise, "N", "Std deviation of the white noise of each sole load cell (0 = off)", 0.0, 1e4},
    {"sensor_bias_toe", &Params::sensor_bias_toe, "N", "Bias of the toe load cell", -1e4, 1e4},
    {"sensor_bias_heel", &Params::sensor_bias_heel, "N", "Bias of the heel load cell", -1e4, 1e4},
    {"sensor_fmin", &Params::sensor_fmin, "N", "Below this total load the sensor ZMP reads 0", 0.0, 1e4},
    {"theta_ankle_init", &Params::theta_ankle_init, "rad", "Initial ankle set-point (starts at rest in static equilibrium under it)", HOAP2_ANKLE_MIN, HOAP2_ANKLE_MAX},
    {"theta_hip_init", &Params::theta_hip_init, "rad", "Initial hip set-point (starts at rest in static equilibrium under it)", HOAP2_HIP_MIN, HOAP2_HIP_MAX},
    {"rtol", &Params::rtol, "", "Relative tolerance of the integrator; 0: the importer's fmi2SetupExperiment tolerance "
     "when it defines one, else the DefaultExperiment's (docs/plant.md)", 0.0, kMaxRtol},
    {"atol", &Params::atol, "", "Absolute tolerance of the integrator (all states)", 1e-16, 1e-2},
};
constexpr int kNumParams = sizeof(kParams) / sizeof(kParams[0]);

ModelInfo makeInfo() {
  Params def = hoap2plant::default_params();
  def.rtol = 0.0;  // the parameter's start: the experiment's tolerance (paramsFromStore)
  ModelInfo m;
  m.model_name = "Hoap2Plant";
  m.description =
      "HOAP-2 humanoid in the sagittal plane: foot (flat / toe / heel / airborne contact, SUNDIALS root "
      "functions), legs and upper body, PD joint servos, sole load cells, push on the back, fall detection";
  m.default_experiment = {0.0, 5.0, hoap2plant::default_params().rtol, 1e-3};
  m.outputs_depend_on_inputs = false;
  m.extra_log_categories = {{"logSolver", "Integrator (ARKODE / CVODE) messages"}};
  auto add = [&](const char* n, fmi2ValueReference r, Type t, Causality c, Variability v, const char* unit,
                 const char* d, double start = 0.0, double mn = kNoBound, double mx = kNoBound) {
    Variable x;
    x.name = n; x.vr = r; x.type = t; x.causality = c; x.variability = v; x.unit = unit; x.description = d;
    x.start = start; x.min = mn; x.max = mx;
    m.variables.push_back(x);
  };
  const auto In = Causality::Input, Out = Causality::Output, Par = Causality::Parameter;
  const auto Cont = Variability::Continuous, Disc = Variability::Discrete, Fix = Variability::Fixed;
  add("theta_ankle_ref", vr::theta_ankle_ref, Type::Real, In, Cont, "rad", "Ankle servo set point", 0.0);
  add("theta_hip_ref", vr::theta_hip_ref, Type::Real, In, Cont, "rad", "Hip servo set point", 0.0);
  add("push_force", vr::push_force, Type::Real, In, Cont, "N", "Horizontal force on the back of link 2 (+ forward)", 0.0,
      -kMaxPush, kMaxPush);

  add("theta_ankle", vr::theta_ankle, Type::Real, Out, Cont, "rad", "Ankle angle theta1 (leg relative to foot)");
  add("theta_hip", vr::theta_hip, Type::Real, Out, Cont, "rad", "Hip angle theta2 (upper body relative to leg)");
  add("dtheta_ankle", vr::dtheta_ankle, Type::Real, Out, Cont, "rad/s", "Ankle angular velocity");
  add("dtheta_hip", vr::dtheta_hip, Type::Real, Out, Cont, "rad/s", "Hip angular velocity");
  add("zmp_x", vr::zmp_x, Type::Real, Out, Cont, "m", "ZMP from the sole load cells, x from the ankle (foot frame); 0 when unloaded; mean over the communication step");
  add("fz", vr::fz, Type::Real, Out, Cont, "N", "Total normal force: sum of the sole load cells (mean over the communication step)");
  add("fx", vr::fx, Type::Real, Out, Cont, "N", "Horizontal ground reaction force (+ forward) (mean over the communication step)");
  add("com_x", vr::com_x, Type::Real, Out, Cont, "m", "Whole-robot CoM (feet included), x from the ankle");
  add("com_z", vr::com_z, Type::Real, Out, Cont, "m", "Whole-robot CoM (feet included), height above the ankle axis");
  add("foot_pitch", vr::foot_pitch, Type::Real, Out, Cont, "rad", "Foot pitch (+ = toes down)");
  add("contact_mode", vr::contact_mode, Type::Integer, Out, Disc, "", "Contact: 0 flat, 1 on toe, 2 on heel, 3 airborne");
  add("fallen", vr::fallen, Type::Boolean, Out, Disc, "", "The robot has fallen (foot or body pitch past threshold)");
  add("f_toe", vr::f_toe, Type::Real, Out, Cont, "N", "Toe load cell: foot-normal force, mean over the communication step, with noise/bias if enabled");
  add("f_heel", vr::f_heel, Type::Real, Out, Cont, "N", "Heel load cell: foot-normal force, mean over the communication step, with noise/bias if enabled");
  add("required_mu", vr::required_mu, Type::Real, Out, Cont, "", "Friction coefficient required to prevent slip |fx|/fz");
  add("zmp_true", vr::zmp_true, Type::Real, Out, Cont, "m", "Centre of pressure of the constrained dynamics (no sensor model) (mean over the communication step)");
  add("fz_true", vr::fz_true, Type::Real, Out, Cont, "N", "Vertical ground reaction of the constrained dynamics (mean over the communication step)");
  add("moment_ankle", vr::moment_ankle, Type::Real, Out, Cont, "N.m", "Ground reaction moment about the ankle axis (foot-pitch sense) (mean over the communication step)");
  add("energy", vr::energy, Type::Real, Out, Cont, "J", "Mechanical energy (kinetic + potential)");
  add("tau_ankle", vr::tau_ankle, Type::Real, Out, Cont, "N.m", "Ankle joint torque (servo + passive damping)");
  add("tau_hip", vr::tau_hip, Type::Real, Out, Cont, "N.m", "Hip joint torque (servo + passive damping)");
  add("input_fault", vr::input_fault, Type::Integer, Out, Disc, "",
      "Inputs held at their last finite value because they are NaN/Inf: bit 0 theta_ankle_ref, 1 theta_hip_ref, "
      "2 push_force (0 = healthy)");
  add("cvode_steps", vr::cvode_steps, Type::Integer, Out, Disc, "", "Integrator steps so far (ARKODE ERKStep or CVODE, per the integrator parameter)");
  add("rhs_evals", vr::rhs_evals, Type::Integer, Out, Disc, "", "Right-hand-side evaluations so far (incl. Jacobian)");
  add("root_evals", vr::root_evals, Type::Integer, Out, Disc, "", "Root-function evaluations so far");
  add("mode_switches", vr::mode_switches, Type::Integer, Out, Disc, "", "Contact mode switches so far");
  add("impacts", vr::impacts, Type::Integer, Out, Disc, "", "Plastic impacts (landings) so far");

  for (int i = 0; i < kNumParams; ++i) {
    const RealParam& p = kParams[i];
    add(p.name, vr::first_real_param + i, Type::Real, Par, Fix, p.unit, p.description, def.*(p.field), p.min, p.max);
  }
  add("servo_on", vr::servo_on, Type::Boolean, Par, Fix, "", "Joint servos active (false: joints passive)", def.servo_on ? 1 : 0);
  add("lock_joints_at_impact", vr::lock_joints_at_impact, Type::Boolean, Par, Fix, "",
      "Impact law: true = servos hold the joints rigid through an impact (rigid-body rocking, for servos much "
      "faster than the contact); false = no impulsive joint torque (for slow servos)", def.lock_joints_at_impact ? 1 : 0);
  add("seed", vr::seed, Type::Integer, Par, Fix, "", "Seed of the sensor-noise generator (splitmix64)", double(def.seed), 0, 2147483647);
  add("integrator", vr::integrator, Type::Integer, Par, Fix, "",
      "2 (default): automatic, explicit Runge-Kutta unless the servo gains make the equations stiff for it, "
      "then BDF (docs/plant.md section 7); 0: explicit Runge-Kutta (ARKODE ERKStep, Cash-Karp 6(4)5; fast where "
      "the inputs change at every communication point; refused with stiff gains); 1: BDF (CVODE, dense Newton)",
      kIntegratorAuto, 0, 2);
  return m;
}

int clampi(std::int64_t v) { return v > 2147483647 ? 2147483647 : static_cast<int>(v); }

// The plant's parameters from the parameter variables (range-checked by the glue), with the
// checks that involve several of them; false with the reason in `why`.
bool paramsFromStore(const Context& ctx, Params& p, std::string& why) {
  p = hoap2plant::default_params();
  for (int i = 0; i < kNumParams; ++i) p.*(kParams[i].field) = ctx.real(vr::first_real_param + i);
  p.servo_on = ctx.boolean(vr::servo_on);
  p.lock_joints_at_impact = ctx.boolean(vr::lock_joints_at_impact);
  p.seed = static_cast<std::uint64_t>(ctx.integer(vr::seed));
  const int integrator = ctx.integer(vr::integrator);
  const double rate = fastestRate(p);
  p.integrator = integrator == 1 || (integrator == kIntegratorAuto && rate > kStiffRate) ? hoap2plant::Integrator::Bdf
                                                                                        : hoap2plant::Integrator::Erk;
  char buf[400];
  // The integrator's relative tolerance: the parameter rtol when set (> 0, the user's explicit
  // choice); else the importer's fmi2SetupExperiment tolerance when it defines one; else the
  // model's default, which the DefaultExperiment advertises.
  const bool rtol_is_parameter = p.rtol > 0.0;
  if (!rtol_is_parameter) p.rtol = ctx.tolerance_defined() ? ctx.tolerance() : hoap2plant::default_params().rtol;
  if (!(p.rtol >= kMinRtol && p.rtol <= kMaxRtol)) {
    std::snprintf(buf, sizeof buf, "relative tolerance %g (%s) is outside [%g, %g]", p.rtol,
                  rtol_is_parameter ? "parameter rtol" : "fmi2SetupExperiment's tolerance", kMinRtol, kMaxRtol);
  } else if ((p.kd_ankle > 0.0 && p.kd_ankle < kMinServoKd) || (p.kd_hip > 0.0 && p.kd_hip < kMinServoKd)) {
    // the servo's position loop commands kp / kd times the error as a rate: a denormal kd made it
    // infinite and the right-hand side NaN (found by forging states within the ranges)
    std::snprintf(buf, sizeof buf, "kd_ankle = %g, kd_hip = %g N.m.s/rad: a servo velocity gain is 0 (no velocity "
                  "loop) or at least %g", p.kd_ankle, p.kd_hip, kMinServoKd);
  } else if (integrator == 0 && rate > kErkRefusedRate) {
    std::snprintf(buf, sizeof buf, "integrator = 0 (explicit Runge-Kutta) with these servo gains: the fastest mode of "
                  "the plant decays at %.3g 1/s, which limits its steps to about %.2g s (%.3g steps per simulated "
                  "second); use integrator = 2 (automatic) or 1 (BDF)", rate, 3.3 / rate, rate / 3.3);
  } else if (!(p.toe_x > p.heel_x)) {
    std::snprintf(buf, sizeof buf, "toe_x (%g) must be > heel_x (%g)", p.toe_x, p.heel_x);
  } else if (p.h_push <= p.ankle_height + p.l1) {
    std::snprintf(buf, sizeof buf, "h_push (%g m) must be above the hip (ankle_height + l1 = %g m)", p.h_push,
                  p.ankle_height + p.l1);
  } else {
    return true;
  }
  why = buf;
  return false;
}

class PlantFmu : public Model {
 public:
  void reset(Context&) override {
    plant_.reset();
    built_from_.clear();
  }

  std::uint32_t state_version() const override { return 2; }  // 2: field by field, parameters from the store

  // The initial outputs in initialization mode (<InitialUnknowns>: computed from the parameters):
  // the plant is built there and kept for fmi2ExitInitializationMode while the parameters stay.
  fmi2Status update_initial_outputs(Context& ctx) override { return build(ctx); }
  fmi2Status exit_initialization(Context& ctx) override { return build(ctx); }

  fmi2Status build(Context& ctx) {
    std::vector<double> key = initialKey(ctx);
    if (plant_ && key == built_from_) return fmi2OK;  // built for an fmi2Get* in initialization mode
    plant_.reset();
    built_from_.clear();
    Params p;
    std::string why;
    if (!paramsFromStore(ctx, p, why)) {
      ctx.log(kLogStatusError, fmi2Error, "%s", why.c_str());
      return fmi2Error;
    }
    plant_ = std::make_unique<Plant>(p);
    attach(ctx);
    if (ctx.integer(vr::integrator) == kIntegratorAuto)
      ctx.log(kLogEvents, fmi2OK, "integrator = 2 (automatic): %s (the fastest mode decays at %.3g 1/s; BDF above %g)",
              p.integrator == hoap2plant::Integrator::Bdf ? "BDF (CVODE)" : "explicit Runge-Kutta (ARKODE ERKStep)",
              fastestRate(p), kStiffRate);
    const bool ok = plant_->initialize(ctx.start_time());
    if (!ok) {
      ctx.log(kLogStatusError, fmi2Error, "plant initialization failed: %s", plant_->message().c_str());
      plant_.reset();
      return fmi2Error;
    }
    last_in_[0] = p.theta_ankle_init;
    last_in_[1] = p.theta_hip_init;
    last_in_[2] = 0.0;
    write_outputs(ctx);
    detach();
    built_from_ = std::move(key);
    return fmi2OK;
  }

  // The integrator adapts its steps (1000 s at rest take microseconds), but a step of 1e300 s breaks its
  // time arithmetic: communication steps are bounded at a simulated hour.
  double max_step_size(const Context&) const override { return 3600.0; }

  StepResult do_step(Context& ctx, double t, double h, bool) override {
    StepResult res;
    if (!plantMayStep(ctx, plant_ != nullptr, t, h, plant_ ? plant_->time() : 0.0, plant_ && plant_->fallen(),
                      plant_ ? plant_->fall_time() : 0.0, res))
      return res;
    attach(ctx);
    static const fmi2ValueReference kInputVr[3] = {vr::theta_ankle_ref, vr::theta_hip_ref, vr::push_force};
    static const char* const kInputNames[3] = {"theta_ankle_ref", "theta_hip_ref", "push_force"};
    double in[3];
    const fmi2Status st = readFiniteInputs(ctx, t, 3, kInputVr, kInputNames, last_in_, in, vr::input_fault);
    plant_->set_inputs(in[0], in[1], in[2]);
    const auto r = plant_->do_step(plantStepTo(t, h, plant_->time()));  // to the master's t + h
    write_outputs(ctx);
    detach();
    const PlantOutcome outcome = r == Plant::Result::Ok       ? PlantOutcome::Ok
                                 : r == Plant::Result::Fallen ? PlantOutcome::Fallen
                                                              : PlantOutcome::Error;
    return plantStepResult(ctx, outcome, st, plant_->fall_time(), plant_->message());
  }

  // The parameters are not in the model's part of the state: load_state rebuilds them from the
  // restored (and checked) parameter variables, as exit_initialization does.
  void save_state(StateWriter& w) const override {
    const hoap2plant::Snapshot snap = plant_ ? plant_->snapshot() : hoap2plant::Snapshot();
    writePlantState(w, plant_ ? &snap : nullptr, last_in_, 3);
  }

  bool load_state(Context& ctx, StateReader& r, std::string& err) override {
    bool has = false;
    hoap2plant::Snapshot s;
    double li[3];
    Params p;
    if (!readPlantState(ctx, r, has, s, li, 3, err)) return false;
    built_from_.clear();
    if (!has) {
      plant_.reset();
      return true;
    }
    if (!paramsFromStore(ctx, p, err)) return false;
    auto fresh = std::make_unique<Plant>(p);
    if (!fresh->restore(s)) return err = "invalid plant snapshot (contact mode, flags or state out of range)", false;
    plant_ = std::move(fresh);  // the integrator restarts from the snapshot at the next step
    std::memcpy(last_in_, li, sizeof li);
    return true;
  }

 private:
  void attach(Context& ctx) {
    ctx_ = &ctx;
    // no mode-switch history: it would grow the memory of a long run with every contact switch
    // (found by the soak, docs/reliability.md); the switches are logged under logEvents
    plant_->history_limit = 0;
    plant_->max_steps_per_call = kMaxErkStepsPerStep;
    plant_->logger = [this](const std::string& s) {
      if (!ctx_) return;
      if (s.rfind("SUNDIALS", 0) == 0) ctx_->log(kFirstModelCategory, fmi2Warning, "%s", s.c_str());
      else ctx_->log(kLogEvents, fmi2OK, "%s", s.c_str());
    };
  }
  void detach() { ctx_ = nullptr; }

  void write_outputs(Context& ctx) {
    const auto& o = plant_->outputs();
    ctx.set_real(vr::theta_ankle, o.theta_ankle);
    ctx.set_real(vr::theta_hip, o.theta_hip);
    ctx.set_real(vr::dtheta_ankle, o.dtheta_ankle);
    ctx.set_real(vr::dtheta_hip, o.dtheta_hip);
    ctx.set_real(vr::zmp_x, o.zmp_x);
    ctx.set_real(vr::fz, o.fz);
    ctx.set_real(vr::fx, o.fx);
    ctx.set_real(vr::com_x, o.com_x);
    ctx.set_real(vr::com_z, o.com_z);
    ctx.set_real(vr::foot_pitch, o.foot_pitch);
    ctx.set_integer(vr::contact_mode, o.contact_mode);
    ctx.set_boolean(vr::fallen, o.fallen);
    ctx.set_real(vr::f_toe, o.f_toe);
    ctx.set_real(vr::f_heel, o.f_heel);
    ctx.set_real(vr::required_mu, o.required_mu);
    ctx.set_real(vr::zmp_true, o.zmp_true);
    ctx.set_real(vr::fz_true, o.fz_true);
    ctx.set_real(vr::moment_ankle, o.moment_ankle);
    ctx.set_real(vr::energy, o.energy);
    ctx.set_real(vr::tau_ankle, o.tau_ankle);
    ctx.set_real(vr::tau_hip, o.tau_hip);
    const auto& s = plant_->stats();
    ctx.set_integer(vr::cvode_steps, clampi(s.steps));
    ctx.set_integer(vr::rhs_evals, clampi(s.rhs_evals));
    ctx.set_integer(vr::root_evals, clampi(s.root_evals));
    ctx.set_integer(vr::mode_switches, clampi(s.mode_switches));
    ctx.set_integer(vr::impacts, clampi(s.impacts));
  }

  std::unique_ptr<Plant> plant_;
  std::vector<double> built_from_;  // initialKey() of plant_ while it is the initialization mode's
  Context* ctx_ = nullptr;
  double last_in_[3] = {0, 0, 0};
};

}  // namespace

const ModelInfo& fmuglue::modelInfo() {
  static const ModelInfo info = makeInfo();
  return info;
}

std::unique_ptr<Model> fmuglue::createModel() { return std::make_unique<PlantFmu>(); }
