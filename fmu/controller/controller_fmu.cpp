// AnkleHipController.fmu: the C99 controller library (controller_c, ahc_*) behind the FMI 2.0
// co-simulation glue. Signals as docs/fmu.md names them; every ahc_params field is a parameter
// generated from ahc_param_table() with start values from ahc_params_default() (one source of
// truth). Sample grid rule (docs/fmu.md): fmi2DoStep(t, h) executes exactly the control ticks
// k >= 1 with t0 + k*T in (t, t+h], counted with an integer tick counter:
//   ticks_due = floor((t + h - t0) / T + 1e-9), run ticks while ticks_done < ticks_due.
// Outputs are held between ticks (zero-order hold).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <tuple>
#include <utility>
#include <vector>
#include <limits>
#include <string>

#include "ahc/controller.h"
#include "fmuglue/glue.hpp"
#include "ahcfmu/param_vars.hpp"

using namespace fmuglue;

namespace {

namespace vr {
enum : fmi2ValueReference {
  theta_ankle = 0, theta_hip = 1, zmp_x = 2, fz = 3,
  theta_ankle_ref = 10, theta_hip_ref = 11, dtheta_ankle_ref = 12, dtheta_hip_ref = 13, phase = 14,
  com_x = 15, com_z = 16, disturbance_moment = 17, k_w = 18, com_x_desired = 19, fault = 20,
  theta_ankle_erect = 30, theta_hip_erect = 31,  // calculated parameters
  first_param = 100  // parameter i of ahc_param_table() has value reference 100 + i
};
}

// Parameters that may be changed between steps (they do not enter derived constants or the
// phase timing): gains, thresholds, fault limits.
const char* const kTunable[] = {"Ka", "Ca", "Kh", "Ch", "Kpr", "Kp_theta", "zmp_limit_front", "zmp_limit_back",
                                "rz_band_low", "rz_band_high", "fallback_disturbance_tol", "fallback_hip_tol",
                                "fallback_dwell", "return_hip_angle_tol", "return_hip_rate_tol", "fz_lifted",
                                "zmp_fault_margin", "angle_fault_margin"};

bool isTunable(const char* name) {
  for (const char* t : kTunable)
    if (std::strcmp(t, name) == 0) return true;
  return false;
}

ModelInfo makeInfo() {
  ahc_params def;
  ahc_params_default(&def);
  const double weight = (def.m1 + def.m2 + def.feet_mass) * def.g;

  ModelInfo m;
  m.model_name = "AnkleHipController";
  m.description =
      "Ankle and hip balance strategies with smooth transitions (Nenchev & Nishio, ICRA 2010) for the "
      "HOAP-2 humanoid; sampled controller on its own grid (sample_period)";
  m.default_experiment = {0.0, 5.0, 0.0, def.sample_period};  // no integrator: no tolerance
  m.fixed_internal_step = def.sample_period;  // FMI 3.0: the control tick grid (sample_period's default)
  m.outputs_depend_on_inputs = false;
  // The FMI 3.0 Scheduled Execution variant (AnkleHipController_se.fmu): one model partition, one
  // control tick per activation of a constant clock of sample_period's default (docs/fmu.md).
  m.clock = {"tick", 1000, "The control tick: one activation runs one ahc_step on the inputs set before it", def.sample_period,
             "sample_period"};

  auto in = [&](const char* n, fmi2ValueReference r, const char* unit, const char* d, double start) {
    Variable v;
    v.name = n; v.vr = r; v.type = Type::Real; v.causality = Causality::Input;
    v.variability = Variability::Continuous; v.unit = unit; v.description = d; v.start = start;
    m.variables.push_back(v);
  };
  // initial_inputs: what writeInitialOutputs computes the output from in initialization mode
  auto out = [&](const char* n, fmi2ValueReference r, Type t, const char* unit, const char* d,
                 std::vector<std::string> initial_inputs = {}) {
    Variable v;
    v.name = n; v.vr = r; v.type = t; v.causality = Causality::Output;
    v.variability = Variability::Discrete;  // sampled: changes only at control ticks
    v.unit = unit; v.description = d;
    v.initial_inputs = std::move(initial_inputs);
    m.variables.push_back(v);
  };
  const std::vector<std::string> posture = {"theta_ankle", "theta_hip"};
  in("theta_ankle", vr::theta_ankle, "rad", "Measured ankle angle theta1 (leg link pitch relative to the foot)", 0.0);
  in("theta_hip", vr::theta_hip, "rad", "Measured hip angle theta2 (upper body pitch relative to the leg link)", 0.0);
  in("zmp_x", vr::zmp_x, "m", "Measured ZMP x from the ankle's ground projection (+ toward the toes)", 0.0);
  in("fz", vr::fz, "N", "Total normal ground force (start: the model's weight)", weight);

  out("theta_ankle_ref", vr::theta_ankle_ref, Type::Real, "rad", "Ankle joint set point", {"theta_ankle"});
  out("theta_hip_ref", vr::theta_hip_ref, Type::Real, "rad", "Hip joint set point", {"theta_hip"});
  out("dtheta_ankle_ref", vr::dtheta_ankle_ref, Type::Real, "rad/s", "Ankle reference rate");
  out("dtheta_hip_ref", vr::dtheta_hip_ref, Type::Real, "rad/s", "Hip reference rate");
  ahcfmu::addPhaseEnumeration(m);
  out("phase", vr::phase, Type::Integer, "", "Phase: 0 ankle, 1 ankle-to-hip, 2 hip, 3 hip-to-ankle");
  m.variables.back().enumeration = "Phase";
  out("com_x", vr::com_x, Type::Real, "m", "CoM ground projection r_x of the two-link model from the measured angles", posture);
  out("com_z", vr::com_z, Type::Real, "m", "CoM height r_z above the ankle joint from the measured angles", posture);
  out("disturbance_moment", vr::disturbance_moment, Type::Real, "N.m", "Disturbance moment estimate d: external moment about the sole point under the ankle (reaction_compensation = 1) or m g (p - r_x) (= 0)");
  out("k_w", vr::k_w, Type::Real, "1", "Reactionless weight of eq. 23 (0 ankle strategy, 1 hip strategy)");
  out("com_x_desired", vr::com_x_desired, Type::Real, "m", "Desired CoM projection r_x_d (= com_x in phase 0)", posture);
  out("fault", vr::fault, Type::Integer, "", "Fault bit mask (AHC_FAULT_*; 0 = healthy, docs/fmu.md)");
  for (auto [n, r, d] : {std::tuple{"theta_ankle_erect", vr::theta_ankle_erect,
                                    "Erect posture: ankle angle with the whole CoM above the ankle (0 with link1_com_x "
                                    "= link2_com_x = 0; docs/controller.md section 2.1)"},
                         std::tuple{"theta_hip_erect", vr::theta_hip_erect,
                                    "Erect posture: hip angle with link 2's CoM above the hip (0 with the CoMs on "
                                    "the joint lines)"}}) {
    Variable v;
    v.name = n; v.vr = r; v.type = Type::Real; v.causality = Causality::CalculatedParameter;
    v.variability = Variability::Fixed; v.unit = "rad"; v.description = d;
    m.variables.push_back(v);
  }

  size_t count = 0;
  const ahc_param_info* table = ahc_param_table(&count);
  ahcfmu::addParamVariables(m, table, count, vr::first_param, &def, isTunable);
  m.resources.emplace_back("configurations.toml", ahcfmu::configurationsToml("AnkleHipController"));
  return m;
}

class ControllerModel final : public Model {
 public:
  void reset(Context&) override {
    std::memset(&ctl_, 0, sizeof ctl_);
    ticks_ = 0;
    t0_ = 0.0;
    lastPhase_ = 0;
    lastFault_ = 0;
    nonfinite_ = 0;
  }

  fmi2Status exit_initialization(Context& ctx) override {
    ahc_params p;
    readParams(ctx, p);
    char msg[256] = {0};
    int rc = ahc_params_validate(&p, msg, sizeof msg);
    if (rc != AHC_OK) {
      ctx.log(kLogStatusError, fmi2Error, "invalid parameter: %s (%s)", msg, ahc_error_string(rc));
      return fmi2Error;
    }
    rc = ahc_init(&ctl_, &p);
    if (rc != AHC_OK) {
      ctx.log(kLogStatusError, fmi2Error, "ahc_init failed: %s", ahc_error_string(rc));
      return fmi2Error;
    }
    t0_ = ctx.start_time();
    ticks_ = 0;
    lastPhase_ = AHC_PHASE_ANKLE;
    lastFault_ = 0;
    nonfinite_ = 0;
    writeInitialOutputs(ctx, p);
    return fmi2OK;
  }

  fmi2Status update_initial_outputs(Context& ctx) override {
    ahc_params p;
    readParams(ctx, p);
    writeInitialOutputs(ctx, p);
    return fmi2OK;
  }

  fmi2Status tunable_parameters_changed(Context& ctx) override {
    ahc_params p = ctl_.p;
    readParams(ctx, p, /*tunableOnly=*/true);
    char msg[256] = {0};
    int rc = ahc_params_validate(&p, msg, sizeof msg);
    if (rc != AHC_OK) {
      ctx.log(kLogStatusError, fmi2Error, "invalid tunable parameter: %s", msg);
      return fmi2Error;
    }
    // The library's entry point for running instances (it recomputes the derived constants; the
    // tunable set does not enter them, so this equals a plain copy of the parameters).
    rc = ahc_update_params(&ctl_, &p);
    if (rc != AHC_OK) {
      ctx.log(kLogStatusError, fmi2Error, "ahc_update_params failed: %s", ahc_error_string(rc));
      return fmi2Error;
    }
    return fmi2OK;
  }

  // At most kMaxTicksPerStep control ticks per fmi2DoStep (1000 s at the 1 ms default period,
  // about 0.1 s of computation): a longer step is refused before anything runs.
  static constexpr double kMaxTicksPerStep = 1e6;
  double max_step_size(const Context&) const override {
    return ctl_.valid ? kMaxTicksPerStep * ctl_.p.sample_period : std::numeric_limits<double>::infinity();
  }

  StepResult do_step(Context& ctx, double t, double h, bool) override {
    StepResult r;
    if (!ctl_.valid || !(ctl_.p.sample_period > 0.0)) {  // unreachable after a successful exit_initialization
      ctx.log(kLogStatusError, fmi2Error, "t=%.9g: the controller is not initialized", t);
      r.status = fmi2Error;
      return r;
    }
    ahc_sensors s;
    s.theta_ankle = ctx.real(vr::theta_ankle);
    s.theta_hip = ctx.real(vr::theta_hip);
    s.zmp_x = ctx.real(vr::zmp_x);
    s.fz = ctx.real(vr::fz);
    const bool bad = !std::isfinite(s.theta_ankle) || !std::isfinite(s.theta_hip) || !std::isfinite(s.zmp_x) ||
                     !std::isfinite(s.fz);
    if (bad) {
      if (!nonfinite_)
        ctx.log(kLogStatusWarning, fmi2Warning,
                "t=%.9g: non-finite input (theta_ankle=%g theta_hip=%g zmp_x=%g fz=%g): holding a safe reference, "
                "fault output set",
                t, s.theta_ankle, s.theta_hip, s.zmp_x, s.fz);
      nonfinite_ = 1;
      r.status = fmi2Warning;
    } else if (nonfinite_) {
      ctx.log(kLogEvents, fmi2OK, "t=%.9g: inputs finite again", t);
      nonfinite_ = 0;
    }
    const double T = ctl_.p.sample_period;
    // t and h are finite and h <= max_step_size (the glue checked); the tick count stays within
    // AHC_TICK_MAX (2^53, where a double still counts every tick) so the cast is exact.
    const double due_d = ticksDue(t + h);
    if (!(due_d <= static_cast<double>(AHC_TICK_MAX))) {
      ctx.log(kLogStatusError, fmi2Error, "t=%.9g: a step to %.17g s passes the controller's last tick (%llu ticks of %g s)",
              t, t + h, AHC_TICK_MAX, T);
      r.status = fmi2Error;
      return r;
    }
    const unsigned long long due = due_d > 0.0 ? static_cast<unsigned long long>(due_d) : 0ull;
    ahc_outputs o = ctl_.last_out;
    bool ticked = false;
    while (ticks_ < due) {
      ahc_step(&ctl_, &s, &o);
      ++ticks_;
      ticked = true;
      if (o.phase != lastPhase_) {
        ctx.log(kLogEvents, fmi2OK, "t=%.9g: phase %d (%s) -> %d (%s)", t0_ + static_cast<double>(ticks_) * T,
                lastPhase_, ahc_phase_name(lastPhase_), o.phase, ahc_phase_name(o.phase));
        lastPhase_ = o.phase;
      }
      if (o.fault != lastFault_) {
        char buf[256];
        ahc_fault_string(o.fault, buf, sizeof buf);
        ctx.log(kLogEvents, fmi2OK, "t=%.9g: fault mask 0x%x (%s)", t0_ + static_cast<double>(ticks_) * T, o.fault,
                o.fault ? buf : "healthy");
        lastFault_ = o.fault;
      }
    }
    if (ticked) writeOutputs(ctx, o);
    return r;
  }

  void save_state(StateWriter& w) const override {
    w.u64(sizeof(ahc_controller));
    w.pod(ctl_);
    w.u64(ticks_);
    w.f64(t0_);
    w.i32(lastPhase_);
    w.u32(lastFault_);
    w.i32(nonfinite_);
  }

  // A state's bytes are untrusted (the checksum catches accidents): the controller struct must be
  // one ahc_init and ahc_step produce (ahc_state_validate) and must fit the instance it is restored
  // into (ahc_state_validate_for): the parameters the restored variables hold (a state carries its
  // parameters, docs/fmu.md section 4) and the tick count of the restored time, so that the next
  // step runs the ticks of its own length and no more. The FMU's own counters and the outputs in
  // the store must be the ones the controller's state implies.
  bool load_state(Context& ctx, StateReader& r, std::string& err) override {
    std::uint64_t size = 0;
    if (!r.u64(size) || size != sizeof(ahc_controller)) {
      err = "controller state size mismatch";
      return false;
    }
    ahc_controller c;
    std::uint64_t ticks = 0;
    double t0 = 0;
    std::int32_t phase = 0, nonfinite = 0;
    std::uint32_t fault = 0;
    if (!r.pod(c) || !r.u64(ticks) || !r.f64(t0) || !r.i32(phase) || !r.u32(fault) || !r.i32(nonfinite)) {
      err = "controller state truncated";
      return false;
    }
    if (nonfinite < 0 || nonfinite > 1) {
      err = "controller state corrupt (input flag)";
      return false;
    }
    char msg[256] = {0};
    if (!ctx.initialized()) {
      // before fmi2ExitInitializationMode the controller is what reset() left: nothing
      static const ahc_controller kEmpty{};
      if (std::memcmp(&c, &kEmpty, sizeof c) != 0 || ticks != 0 || t0 != 0.0 || phase != 0 || fault != 0 ||
          nonfinite != 0) {
        err = "controller state rejected: an instance that is not initialized holds no controller state";
        return false;
      }
    } else {
      ahc_params p;
      readParams(ctx, p);
      const double due = ticksDue(ctx.time(), t0, p.sample_period);
      if (t0 != ctx.start_time()) {
        err = "controller state rejected: its start time is not the instance's";
        return false;
      }
      if (!(due >= 0.0 && due <= static_cast<double>(AHC_TICK_MAX))) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "controller state rejected: the instance's clock (t = %.17g s) is beyond the "
                      "controller's last tick (%llu ticks of %g s)", ctx.time(), AHC_TICK_MAX, p.sample_period);
        err = buf;
        return false;
      }
      if (ahc_state_validate_for(&c, &p, static_cast<unsigned long long>(due), msg, sizeof msg) != AHC_OK) {
        err = std::string("controller state rejected: ") + msg;
        return false;
      }
      const bool ran = c.tick > 0;
      if (ticks != c.tick || phase != (ran ? c.last_out.phase : 0) || fault != (ran ? c.last_out.fault : 0u)) {
        err = "controller state rejected: the FMU's tick, phase or fault counters disagree with the controller's";
        return false;
      }
      if (!outputsMatch(ctx, c, p, err)) return false;
    }
    ctl_ = c;
    ticks_ = ticks;
    t0_ = t0;
    lastPhase_ = phase;
    lastFault_ = fault;
    nonfinite_ = nonfinite;
    return true;
  }

 private:
  static void readParams(Context& ctx, ahc_params& p, bool tunableOnly = false) {
    if (!tunableOnly) ahc_params_default(&p);
    size_t count = 0;
    const ahc_param_info* table = ahc_param_table(&count);
    ahcfmu::readParamVariables(ctx, table, count, vr::first_param, &p, tunableOnly ? isTunable : nullptr);
  }

  // The number of ticks whose times t0 + k T fall in (t0, t], by the rule of the file's header.
  double ticksDue(double t) const { return ticksDue(t, t0_, ctl_.p.sample_period); }
  static double ticksDue(double t, double t0, double T) { return std::floor((t - t0) / T + 1e-9); }

  // Outputs before the first tick: hold the measured posture (bumpless start), rates 0.
  static ahc_outputs initialOutputs(const ahc_params& p, double theta_ankle, double theta_hip) {
    auto fin = [](double x) { return std::isfinite(x) ? x : 0.0; };
    ahc_outputs o{};
    o.theta_ankle_ref = fin(theta_ankle);
    o.theta_hip_ref = fin(theta_hip);
    double rx = 0.0, rz = 0.0;
    ahc_com(&p, o.theta_ankle_ref, o.theta_hip_ref, &rx, &rz);
    o.phase = AHC_PHASE_ANKLE;
    o.com_x = fin(rx);
    o.com_z = fin(rz);
    o.com_x_desired = fin(rx);
    return o;
  }
  static void writeInitialOutputs(Context& ctx, const ahc_params& p) {
    writeOutputs(ctx, initialOutputs(p, ctx.real(vr::theta_ankle), ctx.real(vr::theta_hip)));
    double e1 = 0.0, e2 = 0.0;
    ahc_erect_posture(&p, &e1, &e2);
    ctx.set_real(vr::theta_ankle_erect, e1);
    ctx.set_real(vr::theta_hip_erect, e2);
  }

  // The output variables' values for o, in one table (written by writeOutputs, compared by outputsMatch).
  static std::vector<std::pair<fmi2ValueReference, double>> outputValues(const ahc_outputs& o) {
    return {{vr::theta_ankle_ref, o.theta_ankle_ref}, {vr::theta_hip_ref, o.theta_hip_ref},
            {vr::dtheta_ankle_ref, o.dtheta_ankle_ref}, {vr::dtheta_hip_ref, o.dtheta_hip_ref},
            {vr::phase, o.phase}, {vr::com_x, o.com_x}, {vr::com_z, o.com_z},
            {vr::disturbance_moment, o.disturbance_moment}, {vr::k_w, o.k_w}, {vr::com_x_desired, o.com_x_desired},
            {vr::fault, static_cast<double>(o.fault)}};
  }
  static bool isInteger(fmi2ValueReference r) { return r == vr::phase || r == vr::fault; }

  static void writeOutputs(Context& ctx, const ahc_outputs& o) {
    for (const auto& [r, v] : outputValues(o)) {
      if (isInteger(r)) ctx.set_integer(r, static_cast<int>(v));
      else ctx.set_real(r, v);
    }
  }

  // Whether the restored store's outputs are those the controller's state implies: the last tick's
  // (after one), else the initial ones of the held posture; the erect posture of the parameters.
  static bool outputsMatch(const Context& ctx, const ahc_controller& c, const ahc_params& p, std::string& err) {
    const ahc_outputs o = c.tick > 0 ? c.last_out
                                     : initialOutputs(p, ctx.real(vr::theta_ankle_ref), ctx.real(vr::theta_hip_ref));
    return ahcfmu::restoredOutputsAre(ctx, outputValues(o), p, vr::theta_ankle_erect, vr::theta_hip_erect, isInteger,
                                      err);
  }

  ahc_controller ctl_{};
  unsigned long long ticks_ = 0;
  double t0_ = 0.0;
  int lastPhase_ = 0;
  unsigned lastFault_ = 0;
  int nonfinite_ = 0;
};

}  // namespace

const ModelInfo& fmuglue::modelInfo() {
  static const ModelInfo info = makeInfo();
  return info;
}

std::unique_ptr<Model> fmuglue::createModel() { return std::make_unique<ControllerModel>(); }
