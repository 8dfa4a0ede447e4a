// AnkleHipController3D.fmu: the controller for a robot in 3D (controller_c's ahc3d: the paper's
// sagittal controller unchanged, the frontal-plane controller beside it, the legs' kinematics) behind
// the FMI glue. A second FMU beside AnkleHipController.fmu rather than more variables on it
// (docs/fmu.md §9): the sagittal FMU stays the paper's unit with four inputs; this one takes the 3D
// robot's signals by Hoap2Plant3D's names and gives per-leg set points. Its sagittal variables have
// the sagittal FMU's names, value references and meaning, and for the same inputs the same values
// bit for bit (tests/test_controller3d_fmu.py). The sample grid rule is the sagittal FMU's.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "ahcfmu/param_vars.hpp"
#include "ahc/controller3d.h"
#include "fmuglue/glue.hpp"

using namespace fmuglue;

namespace {

// configurations.toml's frontal rows of a named configuration (ahc_frontal_params_named)
std::string frontalRows(const char* config) {
  ahc_frontal_params def, f;
  ahc_frontal_params_default(&def);
  ahc_frontal_params_named(&f, config);
  size_t count = 0;
  const ahc_param_info* table = ahc_frontal_param_table(&count);
  return ahcfmu::differingRows(table, count, &f, &def);
}

// configurations.toml's stepping configurations (ahc_step_params_named): the 3D controller's own,
// their sagittal and frontal parts the defaults
std::string stepConfigs() {
  ahc_step_params def, p;
  ahc_step_params_default(&def);
  size_t count = 0;
  const ahc_param_info* table = ahc_step_param_table(&count);
  std::string s;
  for (size_t c = 0; c < ahc_step_config_count(); ++c) {
    ahc_step_params_named(&p, ahc_step_config_name(c));
    s += std::string("\n[") + ahc_step_config_name(c) + "]\ndescription = \"" + ahc_step_config_description(c) + "\"\n";
    s += ahcfmu::differingRows(table, count, &p, &def);
  }
  return s;
}

namespace vr {
enum : fmi2ValueReference {
  // the sagittal FMU's
  theta_ankle = 0, theta_hip = 1, zmp_x = 2, fz = 3,
  theta_ankle_ref = 10, theta_hip_ref = 11, dtheta_ankle_ref = 12, dtheta_hip_ref = 13, phase = 14,
  com_x = 15, com_z = 16, disturbance_moment = 17, k_w = 18, com_x_desired = 19, fault = 20,
  theta_ankle_erect = 30, theta_hip_erect = 31,
  // the frontal plane
  zmp_y = 4, fz_left = 5, fz_right = 6, imu_roll = 7, imu_pitch = 8,
  first_joint = 40,  // q_<side>_<joint>: 40 + 6 side + joint (AHC_LEFT, AHC_RIGHT; leg_ik.h order)
  phi_ref = 60, psi_ref = 61, dphi_ref = 62, dpsi_ref = 63, phase_y = 64, com_y = 65, com_z_frontal = 66,
  disturbance_moment_y = 67, k_w_y = 68, com_y_desired = 69, fault_y = 70,
  // the stepping layer
  step_phase = 71, swing_side = 72, steps = 73, capture_point_x = 74, capture_point_y = 75, landing_x = 76,
  landing_y = 77, com_ref_x = 78, com_ref_y = 79, zmp_plan_x = 92, zmp_plan_y = 93, push_moment = 94,
  first_joint_ref = 80,  // q_<side>_<joint>_ref: 80 + 6 side + joint
  first_param = 100,     // row i of ahc_param_table()
  first_frontal_param = 400,  // row i of ahc_frontal_param_table()
  first_step_param = 600,     // row i of ahc_step_param_table()
  q = 300, q_leg_ref = 301,   // FMI 3.0 arrays of the q_<side>_<joint> inputs and _ref outputs
  tick = 1000                 // the Scheduled Execution variant's clock
};
}

// Hoap2Plant3D's joint and side names (its outputs q_<side>_<joint>), in leg_ik.h's order.
const char* const kSide[2] = {"left", "right"};
const char* const kJoint[AHC_LEG_JOINTS] = {"hip_yaw", "hip", "hip_roll", "knee", "ankle", "ankle_roll"};

bool isTunable(const char* name) {
  static const char* const k[] = {"Ka", "Ca", "Kh", "Ch", "Kpr", "Kp_theta", "zmp_limit_front", "zmp_limit_back",
                                  "rz_band_low", "rz_band_high", "fallback_disturbance_tol", "fallback_hip_tol",
                                  "fallback_dwell", "return_hip_angle_tol", "return_hip_rate_tol", "fz_lifted",
                                  "zmp_fault_margin", "angle_fault_margin", "Ka_y", "Ca_y", "Kh_y", "Ch_y", "Kpr_y",
                                  "Kp_psi", "zmp_limit_y", "rz_band_low_y", "rz_band_high_y",
                                  "fallback_disturbance_tol_y", "fallback_hip_tol_y", "fallback_dwell_y",
                                  "return_psi_tol", "return_psi_rate_tol", "zmp_fault_margin_y"};
  for (const char* t : k)
    if (std::strcmp(t, name) == 0) return true;
  return false;
}

fmi2ValueReference jointVr(fmi2ValueReference first, int side, int joint) {
  return first + static_cast<fmi2ValueReference>(AHC_LEG_JOINTS * side + joint);
}

ModelInfo makeInfo() {
  ahc_params def;
  ahc_frontal_params fdef;
  ahc_params_default(&def);
  ahc_frontal_params_default(&fdef);
  const double weight = (def.m1 + def.m2 + def.feet_mass) * def.g;

  ModelInfo m;
  m.model_name = "AnkleHipController3D";
  m.description =
      "Ankle and hip balance strategies with smooth transitions (Nenchev & Nishio, ICRA 2010) in the sagittal "
      "plane and, read the same way, in the frontal plane, for a humanoid on both feet (HOAP-2 defaults); "
      "per-leg joint set points; sampled controller on its own grid (sample_period)";
  m.default_experiment = {0.0, 5.0, 0.0, def.sample_period};
  m.fixed_internal_step = def.sample_period;
  m.outputs_depend_on_inputs = false;

  auto in = [&](const std::string& n, fmi2ValueReference r, const char* unit, const std::string& d, double start) {
    Variable v;
    v.name = n; v.vr = r; v.type = Type::Real; v.causality = Causality::Input;
    v.variability = Variability::Continuous; v.unit = unit; v.description = d; v.start = start;
    m.variables.push_back(v);
  };
  auto out = [&](const std::string& n, fmi2ValueReference r, Type t, const char* unit, const std::string& d,
                 std::vector<std::string> initial_inputs = {}) {
    Variable v;
    v.name = n; v.vr = r; v.type = t; v.causality = Causality::Output;
    v.variability = Variability::Discrete;
    v.unit = unit; v.description = d;
    v.initial_inputs = std::move(initial_inputs);
    m.variables.push_back(v);
  };
  const std::vector<std::string> posture = {"theta_ankle", "theta_hip"};
  in("theta_ankle", vr::theta_ankle, "rad", "Measured ankle pitch theta1 (leg relative to the foot), mean of both legs", 0.0);
  in("theta_hip", vr::theta_hip, "rad", "Measured hip pitch theta2 (upper body relative to the leg), mean of both legs", 0.0);
  in("zmp_x", vr::zmp_x, "m", "Measured ZMP x from the ankles (+ toward the toes)", 0.0);
  in("fz", vr::fz, "N", "Total normal ground force (start: the model's weight)", weight);
  in("zmp_y", vr::zmp_y, "m", "Measured ZMP y from the mid-point between the ankles (+ left)", 0.0);
  in("fz_left", vr::fz_left, "N", "Left sole's normal load (start: half the model's weight)", 0.5 * weight);
  in("fz_right", vr::fz_right, "N", "Right sole's normal load (start: half the model's weight)", 0.5 * weight);
  in("imu_roll", vr::imu_roll, "rad", "Trunk roll in the world, an IMU's (+ turns the top toward -y; Hoap2Plant3D's imu_roll)",
     0.0);
  in("imu_pitch", vr::imu_pitch, "rad",
     "Trunk pitch in the world, an IMU's (+ forward; Hoap2Plant3D's imu_pitch); read by the stepping layer only", 0.0);
  for (int s = 0; s < 2; ++s)
    for (int j = 0; j < AHC_LEG_JOINTS; ++j)
      in(std::string("q_") + kSide[s] + "_" + kJoint[j], jointVr(vr::first_joint, s, j), "rad",
         std::string("Measured ") + kSide[s] + " " + kJoint[j] +
             " joint angle (Hoap2Plant3D's sense: pitch joints sagittal, the others the proto's)",
         0.0);

  out("theta_ankle_ref", vr::theta_ankle_ref, Type::Real, "rad", "Ankle pitch set point, both legs", {"theta_ankle"});
  out("theta_hip_ref", vr::theta_hip_ref, Type::Real, "rad", "Hip pitch set point, both legs", {"theta_hip"});
  out("dtheta_ankle_ref", vr::dtheta_ankle_ref, Type::Real, "rad/s", "Ankle reference rate");
  out("dtheta_hip_ref", vr::dtheta_hip_ref, Type::Real, "rad/s", "Hip reference rate");
  ahcfmu::addPhaseEnumeration(m);
  out("phase", vr::phase, Type::Integer, "", "Sagittal phase: 0 ankle, 1 ankle-to-hip, 2 hip, 3 hip-to-ankle");
  m.variables.back().enumeration = "Phase";
  out("com_x", vr::com_x, Type::Real, "m", "CoM ground projection r_x of the sagittal model from the measured angles", posture);
  out("com_z", vr::com_z, Type::Real, "m", "CoM height r_z of the sagittal model", posture);
  out("disturbance_moment", vr::disturbance_moment, Type::Real, "N.m", "Sagittal disturbance moment estimate d");
  out("k_w", vr::k_w, Type::Real, "1", "Sagittal reactionless weight of eq. 23");
  out("com_x_desired", vr::com_x_desired, Type::Real, "m", "Desired CoM projection r_x_d (= com_x in phase 0)", posture);
  out("fault", vr::fault, Type::Integer, "", "Sagittal fault bit mask (AHC_FAULT_*; docs/fmu.md)");

  out("phi_ref", vr::phi_ref, Type::Real, "rad", "Frontal reference phi: the pivot leg's lean toward +y");
  out("psi_ref", vr::psi_ref, Type::Real, "rad", "Frontal reference psi: link 2's (the upper body's) lean toward +y");
  out("dphi_ref", vr::dphi_ref, Type::Real, "rad/s", "Rate of phi_ref");
  out("dpsi_ref", vr::dpsi_ref, Type::Real, "rad/s", "Rate of psi_ref");
  out("phase_y", vr::phase_y, Type::Integer, "", "Frontal phase: 0 ankle, 1 ankle-to-hip, 2 hip, 3 hip-to-ankle");
  m.variables.back().enumeration = "Phase";
  out("com_y", vr::com_y, Type::Real, "m", "CoM y of the frontal model from the measured angles (from the ankles' mid-point)");
  out("com_z_frontal", vr::com_z_frontal, Type::Real, "m", "CoM height of the frontal model above the ankle axes");
  out("disturbance_moment_y", vr::disturbance_moment_y, Type::Real, "N.m", "Frontal disturbance moment d_y = m g (p_y - r_y)");
  out("k_w_y", vr::k_w_y, Type::Real, "1", "Frontal reactionless weight (F23)");
  out("com_y_desired", vr::com_y_desired, Type::Real, "m", "Desired CoM y r_y_d (= com_y in phase 0)");
  out("fault_y", vr::fault_y, Type::Integer, "", "Frontal fault bit mask (AHC_FFAULT_*; docs/fmu.md)");
  out("step_phase", vr::step_phase, Type::Integer, "",
      "Stepping phase: 0 stand, 1 shift, 2 swing, 3 transfer, 4 close, 5 settle (docs/controller.md section 12)");
  out("swing_side", vr::swing_side, Type::Integer, "", "The swinging (or last swung) foot while stepping: 0 left, 1 right, -1 none");
  out("steps", vr::steps, Type::Integer, "", "Steps landed since the start");
  out("capture_point_x", vr::capture_point_x, Type::Real, "m",
      "Instantaneous capture point x of the stepping layer's CoM estimate (from the ankles' mid-point at rest)");
  out("capture_point_y", vr::capture_point_y, Type::Real, "m", "Instantaneous capture point y (+ left)");
  out("landing_x", vr::landing_x, Type::Real, "m", "The swing foot's planned landing point (ankle) x, in the step's frame");
  out("landing_y", vr::landing_y, Type::Real, "m", "The swing foot's planned landing point (ankle) y");
  out("com_ref_x", vr::com_ref_x, Type::Real, "m", "The stepping layer's CoM reference x while a step runs, in the step's frame");
  out("com_ref_y", vr::com_ref_y, Type::Real, "m", "The stepping layer's CoM reference y while a step runs");
  out("zmp_plan_x", vr::zmp_plan_x, Type::Real, "m", "The ZMP the step's CoM reference plans in this phase, x");
  out("zmp_plan_y", vr::zmp_plan_y, Type::Real, "m", "The ZMP the step's CoM reference plans in this phase, y");
  out("push_moment", vr::push_moment, Type::Real, "N.m",
      "The stepping layer's estimate of the external pitching moment about the ground (+ tips the robot forward: a push "
      "on the back), from its momentum observer; held on one foot, through the landed foot's transfer and until both "
      "soles carry load again (the observer's model has no impacts); 0 with stepping off");
  for (int s = 0; s < 2; ++s)
    for (int j = 0; j < AHC_LEG_JOINTS; ++j)
      out(std::string("q_") + kSide[s] + "_" + kJoint[j] + "_ref", jointVr(vr::first_joint_ref, s, j), Type::Real,
          "rad",
          std::string("Per-leg set point of the ") + kSide[s] + " " + kJoint[j] +
              ", added to the both-legs one (Hoap2Plant3D's rule; 0 while the frontal references are 0)");
  for (auto [n, r, d] : {std::tuple{"theta_ankle_erect", vr::theta_ankle_erect, "Erect posture: ankle pitch"},
                         std::tuple{"theta_hip_erect", vr::theta_hip_erect, "Erect posture: hip pitch"}}) {
    Variable v;
    v.name = n; v.vr = r; v.type = Type::Real; v.causality = Causality::CalculatedParameter;
    v.variability = Variability::Fixed; v.unit = "rad"; v.description = d;
    m.variables.push_back(v);
  }
  size_t count = 0;
  const ahc_param_info* table = ahc_param_table(&count);
  ahcfmu::addParamVariables(m, table, count, vr::first_param, &def, isTunable);
  table = ahc_frontal_param_table(&count);
  ahcfmu::addParamVariables(m, table, count, vr::first_frontal_param, &fdef, isTunable);
  ahc_step_params stdef;
  ahc_step_params_default(&stdef);
  table = ahc_step_param_table(&count);
  ahcfmu::addParamVariables(m, table, count, vr::first_step_param, &stdef, isTunable);
  // the named configurations of both planes
  m.resources.emplace_back("configurations.toml", ahcfmu::configurationsToml("AnkleHipController3D", frontalRows, stepConfigs));
  // FMI 3.0: the legs' joint angles in and per-leg set points out also as [side, joint] arrays, named as
  // Hoap2Plant3D's (q out of the plant, q_leg_ref into it: the arrays connect by name too); docs/fmu.md §8
  std::vector<fmi2ValueReference> q_in, q_out;
  for (int s = 0; s < 2; ++s)
    for (int j = 0; j < AHC_LEG_JOINTS; ++j) {
      q_in.push_back(jointVr(vr::first_joint, s, j));
      q_out.push_back(jointVr(vr::first_joint_ref, s, j));
    }
  m.arrays = {{"q", vr::q, "Measured joint angles [side, joint] (sides left, right; joints hip_yaw, hip, hip_roll, knee, "
                           "ankle, ankle_roll): q_<side>_<joint>", {2, AHC_LEG_JOINTS}, q_in},
              {"q_leg_ref", vr::q_leg_ref, "Per-leg set points [side, joint]: q_<side>_<joint>_ref", {2, AHC_LEG_JOINTS},
               q_out}};
  // the FMI 3.0 Scheduled Execution variant (AnkleHipController3D_se.fmu), as AnkleHipController's
  m.clock = {"tick", vr::tick, "The control tick: one activation runs one ahc3d_step on the inputs set before it",
             def.sample_period, "sample_period"};
  return m;
}

class Controller3DModel final : public Model {
 public:
  void reset(Context&) override {
    std::memset(&ctl_, 0, sizeof ctl_);
    ticks_ = 0;
    t0_ = 0.0;
    lastPhase_ = lastPhaseY_ = 0;
    lastFault_ = lastFaultY_ = 0;
    nonfinite_ = 0;
    lastStepPhase_ = 0;
  }

  fmi2Status exit_initialization(Context& ctx) override {
    ahc_params p;
    ahc_frontal_params f;
    ahc_step_params st;
    readParams(ctx, p, f, st);
    char msg[256] = {0};
    const int rc = ahc_step_params_validate(&st, &p, &f, msg, sizeof msg);
    if (rc != AHC_OK) {
      ctx.log(kLogStatusError, fmi2Error, "invalid parameter: %s (%s)", msg, ahc_error_string(rc));
      return fmi2Error;
    }
    if (ahc3d_init_stepping(&ctl_, &p, &f, &st) != AHC_OK) {
      ctx.log(kLogStatusError, fmi2Error, "ahc3d_init failed");
      return fmi2Error;
    }
    t0_ = ctx.start_time();
    ticks_ = 0;
    lastPhase_ = lastPhaseY_ = AHC_PHASE_ANKLE;
    lastFault_ = lastFaultY_ = 0;
    nonfinite_ = 0;
    lastStepPhase_ = 0;
    writeInitialOutputs(ctx, p);
    return fmi2OK;
  }

  fmi2Status update_initial_outputs(Context& ctx) override {
    ahc_params p;
    ahc_frontal_params f;
    ahc_step_params st;
    readParams(ctx, p, f, st);
    writeInitialOutputs(ctx, p);
    return fmi2OK;
  }

  fmi2Status tunable_parameters_changed(Context& ctx) override {
    ahc_params p = ctl_.sag.p;
    ahc_frontal_params f = ctl_.frontal.f;
    size_t n = 0;
    const ahc_param_info* t = ahc_param_table(&n);
    ahcfmu::readParamVariables(ctx, t, n, vr::first_param, &p, isTunable);
    t = ahc_frontal_param_table(&n);
    ahcfmu::readParamVariables(ctx, t, n, vr::first_frontal_param, &f, isTunable);
    char msg[256] = {0};
    if (ahc_frontal_params_validate(&f, &p, msg, sizeof msg) != AHC_OK) {
      ctx.log(kLogStatusError, fmi2Error, "invalid tunable parameter: %s", msg);
      return fmi2Error;
    }
    // the tunable set enters no derived constant: a copy into both layers is all it takes
    if (ahc_update_params(&ctl_.sag, &p) != AHC_OK) return fmi2Error;
    ctl_.frontal.f = f;
    ctl_.frontal.sp = p;
    return fmi2OK;
  }

  // At most kMaxTicksPerStep control ticks per fmi2DoStep (100 s at the 1 ms default period): a
  // 3D tick costs 0.75-1.4 us (bench/controller_step_bench), so a step's computation stays near
  // 0.1 s, as the sagittal FMU's 1e6 ticks of 0.15 us do; a longer step is refused before anything runs.
  static constexpr double kMaxTicksPerStep = 1e5;
  double max_step_size(const Context&) const override {
    return ctl_.sag.valid ? kMaxTicksPerStep * ctl_.sag.p.sample_period : std::numeric_limits<double>::infinity();
  }

  StepResult do_step(Context& ctx, double t, double h, bool) override {
    StepResult r;
    if (!ctl_.sag.valid) {
      ctx.log(kLogStatusError, fmi2Error, "t=%.9g: the controller is not initialized", t);
      r.status = fmi2Error;
      return r;
    }
    ahc3d_sensors s;
    s.sag.theta_ankle = ctx.real(vr::theta_ankle);
    s.sag.theta_hip = ctx.real(vr::theta_hip);
    s.sag.zmp_x = ctx.real(vr::zmp_x);
    s.sag.fz = ctx.real(vr::fz);
    s.zmp_y = ctx.real(vr::zmp_y);
    s.fz_left = ctx.real(vr::fz_left);
    s.fz_right = ctx.real(vr::fz_right);
    s.imu_roll = ctx.real(vr::imu_roll);
    s.imu_pitch = ctx.real(vr::imu_pitch);
    bool bad = !std::isfinite(s.sag.theta_ankle) || !std::isfinite(s.sag.theta_hip) || !std::isfinite(s.sag.zmp_x) ||
               !std::isfinite(s.sag.fz) || !std::isfinite(s.zmp_y) || !std::isfinite(s.fz_left) ||
               !std::isfinite(s.fz_right) || !std::isfinite(s.imu_roll) || !std::isfinite(s.imu_pitch);
    for (int side = 0; side < 2; ++side)
      for (int j = 0; j < AHC_LEG_JOINTS; ++j) {
        s.q[side][j] = ctx.real(jointVr(vr::first_joint, side, j));
        bad = bad || !std::isfinite(s.q[side][j]);
      }
    if (bad) {
      if (!nonfinite_)
        ctx.log(kLogStatusWarning, fmi2Warning,
                "t=%.9g: non-finite input: holding a safe reference, fault outputs set", t);
      nonfinite_ = 1;
      r.status = fmi2Warning;
    } else if (nonfinite_) {
      ctx.log(kLogEvents, fmi2OK, "t=%.9g: inputs finite again", t);
      nonfinite_ = 0;
    }
    const double T = ctl_.sag.p.sample_period;
    const double due_d = std::floor((t + h - t0_) / T + 1e-9);
    if (!(due_d <= static_cast<double>(AHC_TICK_MAX))) {  // as the sagittal FMU: the cast below stays exact
      ctx.log(kLogStatusError, fmi2Error, "t=%.9g: a step to %.17g s passes the controller's last tick (%llu ticks of %g s)",
              t, t + h, AHC_TICK_MAX, T);
      r.status = fmi2Error;
      return r;
    }
    const unsigned long long due = due_d > 0.0 ? static_cast<unsigned long long>(due_d) : 0ull;
    bool ticked = false;
    while (ticks_ < due) {
      ahc3d_step(&ctl_, &s, &out_);
      ++ticks_;
      ticked = true;
      const double tk = t0_ + static_cast<double>(ticks_) * T;
      if (out_.sag.phase != lastPhase_) {
        ctx.log(kLogEvents, fmi2OK, "t=%.9g: phase %d (%s) -> %d (%s)", tk, lastPhase_, ahc_phase_name(lastPhase_),
                out_.sag.phase, ahc_phase_name(out_.sag.phase));
        lastPhase_ = out_.sag.phase;
      }
      if (out_.step.phase != lastStepPhase_) {
        ctx.log(kLogEvents, fmi2OK, "t=%.9g: stepping phase %d (%s) -> %d (%s), swing foot %s, landing (%.4f, %.4f) m", tk,
                lastStepPhase_, ahc_step_phase_name(lastStepPhase_), out_.step.phase,
                ahc_step_phase_name(out_.step.phase), out_.step.swing_side == AHC_LEFT ? "left" : out_.step.swing_side == AHC_RIGHT ? "right" : "none",
                out_.step.landing[0], out_.step.landing[1]);
        lastStepPhase_ = out_.step.phase;
      }
      if (out_.frontal.phase != lastPhaseY_) {
        ctx.log(kLogEvents, fmi2OK, "t=%.9g: frontal phase %d (%s) -> %d (%s)", tk, lastPhaseY_,
                ahc_phase_name(lastPhaseY_), out_.frontal.phase, ahc_phase_name(out_.frontal.phase));
        lastPhaseY_ = out_.frontal.phase;
      }
      // a change of either fault mask is logged with its bits' names, as the sagittal FMU does
      if (out_.sag.fault != lastFault_) {
        char buf[256];
        ahc_fault_string(out_.sag.fault, buf, sizeof buf);
        ctx.log(kLogEvents, fmi2OK, "t=%.9g: fault mask 0x%x (%s)", tk, out_.sag.fault,
                out_.sag.fault ? buf : "healthy");
        lastFault_ = out_.sag.fault;
      }
      if (out_.frontal.fault != lastFaultY_) {
        char buf[256];
        ahc_frontal_fault_string(out_.frontal.fault, buf, sizeof buf);
        ctx.log(kLogEvents, fmi2OK, "t=%.9g: frontal fault mask 0x%x (%s)", tk, out_.frontal.fault,
                out_.frontal.fault ? buf : "healthy");
        lastFaultY_ = out_.frontal.fault;
      }
    }
    if (ticked) writeOutputs(ctx, out_);
    return r;
  }

  void save_state(StateWriter& w) const override {
    w.u64(sizeof(ahc3d));
    w.pod(ctl_);
    w.pod(out_);
    w.u64(ticks_);
    w.f64(t0_);
    w.i32(lastPhase_);
    w.i32(lastPhaseY_);
    w.u32(lastFault_);
    w.u32(lastFaultY_);
    w.i32(nonfinite_);
    w.i32(lastStepPhase_);
  }

  bool load_state(Context& ctx, StateReader& r, std::string& err) override {
    std::uint64_t size = 0;
    if (!r.u64(size) || size != sizeof(ahc3d)) {
      err = "controller state size mismatch";
      return false;
    }
    ahc3d c;
    ahc3d_outputs o;
    std::uint64_t ticks = 0;
    double t0 = 0;
    std::int32_t phase = 0, phase_y = 0, nonfinite = 0, step_phase = 0;
    std::uint32_t fault = 0, fault_y = 0;
    if (!r.pod(c) || !r.pod(o) || !r.u64(ticks) || !r.f64(t0) || !r.i32(phase) || !r.i32(phase_y) ||
        !r.u32(fault) || !r.u32(fault_y) || !r.i32(nonfinite) || !r.i32(step_phase)) {
      err = "controller state truncated";
      return false;
    }
    char msg[256] = {0};
    if (ahc3d_state_validate(&c, msg, sizeof msg) != AHC_OK) {
      err = std::string("controller state rejected: ") + msg;
      return false;
    }
    // the start time is the instance's once initialized (before, t0 is 0 whatever the set-up says)
    if (t0 != (ctx.initialized() ? ctx.start_time() : 0.0) || ticks != c.sag.tick || ticks != c.frontal.tick ||
        phase < 0 || phase > 3 || phase_y < 0 || phase_y > 3 || (fault & ~unsigned(AHC_FAULT_ALL_MASK)) ||
        (fault_y & ~unsigned(AHC_FFAULT_ALL_MASK)) || nonfinite < 0 || nonfinite > 1 || step_phase < 0 ||
        step_phase >= AHC_STEP_PHASES || (c.step.valid && c.step.p.stepping_enabled && ticks != c.step.tick)) {
      err = "controller state corrupt (start time, tick counters, phases, fault masks or input flag)";
      return false;
    }
    // As the sagittal FMU (issue 33, findings 1-2): an initialized state must fit the instance it
    // is restored into: the parameters its restored variables hold (both planes', and the frontal
    // controller's copy of the sagittal ones) and the tick count of the restored time, so that the
    // next step runs the ticks of its own length and no more.
    if (ctx.initialized() && c.sag.valid) {
      ahc_params p;
      ahc_frontal_params f;
      ahc_step_params st;
      readParams(ctx, p, f, st);
      const double due = std::floor((ctx.time() - t0) / p.sample_period + 1e-9);
      if (!(due >= 0.0 && due <= static_cast<double>(AHC_TICK_MAX))) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "controller state rejected: the instance's clock (t = %.17g s) is beyond the "
                      "controller's last tick (%llu ticks of %g s)", ctx.time(), AHC_TICK_MAX, p.sample_period);
        err = buf;
        return false;
      }
      if (ahc_state_validate_for(&c.sag, &p, static_cast<unsigned long long>(due), msg, sizeof msg) != AHC_OK) {
        err = std::string("controller state rejected: ") + msg;
        return false;
      }
      size_t n = 0;
      const ahc_param_info* table = ahc_frontal_param_table(&n);
      std::string why = ahcfmu::firstDifferingParam(table, n, &c.frontal.f, &f);
      if (why.empty()) {
        table = ahc_param_table(&n);
        why = ahcfmu::firstDifferingParam(table, n, &c.frontal.sp, &p);
      }
      if (why.empty()) {
        table = ahc_step_param_table(&n);
        why = ahcfmu::firstDifferingParam(table, n, &c.step.p, &st);
      }
      if (!why.empty()) {
        err = "controller state rejected: " + why;
        return false;
      }
      if (!outputsMatch(ctx, c, o, ticks, p, err)) return false;
    } else if (ctx.initialized() != (c.sag.valid != 0)) {
      err = ctx.initialized() ? "controller state rejected: the state is not initialized (valid = 0)"
                              : "controller state rejected: an instance that is not initialized holds no controller "
                                "state";
      return false;
    }
    ctl_ = c;
    out_ = o;
    ticks_ = ticks;
    t0_ = t0;
    lastPhase_ = phase;
    lastPhaseY_ = phase_y;
    lastFault_ = fault;
    lastFaultY_ = fault_y;
    nonfinite_ = nonfinite;
    lastStepPhase_ = step_phase;
    return true;
  }

 private:
  static void readParams(Context& ctx, ahc_params& p, ahc_frontal_params& f, ahc_step_params& st) {
    ahc_params_default(&p);
    ahc_frontal_params_default(&f);
    ahc_step_params_default(&st);
    size_t n = 0;
    const ahc_param_info* t = ahc_param_table(&n);
    ahcfmu::readParamVariables(ctx, t, n, vr::first_param, &p);
    t = ahc_frontal_param_table(&n);
    ahcfmu::readParamVariables(ctx, t, n, vr::first_frontal_param, &f);
    t = ahc_step_param_table(&n);
    ahcfmu::readParamVariables(ctx, t, n, vr::first_step_param, &st);
  }

  // Before the first tick: the sagittal outputs as the sagittal FMU's (the measured posture held,
  // rates 0), the frontal ones at rest.
  static ahc3d_outputs initialOutputs(const ahc_params& p, double theta_ankle, double theta_hip) {
    auto fin = [](double x) { return std::isfinite(x) ? x : 0.0; };
    const double th1 = fin(theta_ankle), th2 = fin(theta_hip);
    double rx = 0.0, rz = 0.0;
    ahc_com(&p, th1, th2, &rx, &rz);
    ahc3d_outputs o;
    std::memset(&o, 0, sizeof o);
    o.step.swing_side = -1;
    o.sag.theta_ankle_ref = th1;
    o.sag.theta_hip_ref = th2;
    o.sag.com_x = o.sag.com_x_desired = fin(rx);
    o.sag.com_z = fin(rz);
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
  static std::vector<std::pair<fmi2ValueReference, double>> outputValues(const ahc3d_outputs& o) {
    std::vector<std::pair<fmi2ValueReference, double>> v = {
        {vr::theta_ankle_ref, o.sag.theta_ankle_ref}, {vr::theta_hip_ref, o.sag.theta_hip_ref},
        {vr::dtheta_ankle_ref, o.sag.dtheta_ankle_ref}, {vr::dtheta_hip_ref, o.sag.dtheta_hip_ref},
        {vr::phase, o.sag.phase}, {vr::com_x, o.sag.com_x}, {vr::com_z, o.sag.com_z},
        {vr::disturbance_moment, o.sag.disturbance_moment}, {vr::k_w, o.sag.k_w},
        {vr::com_x_desired, o.sag.com_x_desired}, {vr::fault, o.sag.fault},
        {vr::phi_ref, o.frontal.phi_ref}, {vr::psi_ref, o.frontal.psi_ref}, {vr::dphi_ref, o.frontal.dphi_ref},
        {vr::dpsi_ref, o.frontal.dpsi_ref}, {vr::phase_y, o.frontal.phase}, {vr::com_y, o.frontal.com_y},
        {vr::com_z_frontal, o.frontal.com_z}, {vr::disturbance_moment_y, o.frontal.disturbance_moment},
        {vr::k_w_y, o.frontal.k_w}, {vr::com_y_desired, o.frontal.com_y_desired}, {vr::fault_y, o.frontal.fault},
        {vr::step_phase, o.step.phase}, {vr::swing_side, o.step.swing_side}, {vr::steps, o.step.steps},
        {vr::capture_point_x, o.step.capture[0]}, {vr::capture_point_y, o.step.capture[1]},
        {vr::landing_x, o.step.landing[0]}, {vr::landing_y, o.step.landing[1]},
        {vr::com_ref_x, o.step.com_ref[0]}, {vr::com_ref_y, o.step.com_ref[1]},
        {vr::zmp_plan_x, o.step.zmp_plan[0]}, {vr::zmp_plan_y, o.step.zmp_plan[1]},
        {vr::push_moment, o.step.push_moment}};
    for (int s = 0; s < 2; ++s)
      for (int j = 0; j < AHC_LEG_JOINTS; ++j) v.emplace_back(jointVr(vr::first_joint_ref, s, j), o.q_ref_offset[s][j]);
    return v;
  }
  static bool isInteger(fmi2ValueReference r) {
    return r == vr::phase || r == vr::fault || r == vr::phase_y || r == vr::fault_y || r == vr::step_phase ||
           r == vr::swing_side || r == vr::steps;
  }

  static void writeOutputs(Context& ctx, const ahc3d_outputs& o) {
    for (const auto& [r, v] : outputValues(o)) {
      if (isInteger(r)) ctx.set_integer(r, static_cast<int>(v));
      else ctx.set_real(r, v);
    }
  }

  // Whether a restored state's outputs are those its controller implies. Before the first tick: the
  // initial ones of the held posture. After: the stored last outputs o, which must be the
  // controller's — its stepping layer's phase, swing side and steps, and while no step drives the
  // legs (o.step.active 0) both planes' last outputs — and the output variables must be o's; the
  // erect posture the parameters'.
  static bool outputsMatch(const Context& ctx, const ahc3d& c, const ahc3d_outputs& stored, unsigned long long ticks,
                           const ahc_params& p, std::string& err) {
    const ahc3d_outputs o =
        ticks > 0 ? stored : initialOutputs(p, ctx.real(vr::theta_ankle_ref), ctx.real(vr::theta_hip_ref));
    if (ticks > 0) {
      const bool stepping = c.step.valid && c.step.p.stepping_enabled;
      const bool step_ok = stepping ? o.step.phase == c.step.phase && o.step.swing_side == c.step.swing_side &&
                                          o.step.steps == c.step.steps && (o.step.active == 0 || o.step.active == 1)
                                    : o.step.phase == 0 && o.step.swing_side == -1 && o.step.active == 0;
      const ahc_outputs& a = c.sag.last_out;
      const ahc_frontal_outputs& b = c.frontal.last_out;
      const bool flat_ok =
          o.step.active ||
          (o.sag.theta_ankle_ref == a.theta_ankle_ref && o.sag.theta_hip_ref == a.theta_hip_ref &&
           o.sag.dtheta_ankle_ref == a.dtheta_ankle_ref && o.sag.dtheta_hip_ref == a.dtheta_hip_ref &&
           o.sag.phase == a.phase && o.sag.com_x == a.com_x && o.sag.com_z == a.com_z &&
           o.sag.disturbance_moment == a.disturbance_moment && o.sag.k_w == a.k_w &&
           o.sag.com_x_desired == a.com_x_desired && o.sag.fault == a.fault && o.frontal.phi_ref == b.phi_ref &&
           o.frontal.psi_ref == b.psi_ref && o.frontal.dphi_ref == b.dphi_ref && o.frontal.dpsi_ref == b.dpsi_ref &&
           o.frontal.phase == b.phase && o.frontal.com_y == b.com_y && o.frontal.com_z == b.com_z &&
           o.frontal.disturbance_moment == b.disturbance_moment && o.frontal.k_w == b.k_w &&
           o.frontal.com_y_desired == b.com_y_desired && o.frontal.fault == b.fault);
      if (!step_ok || !flat_ok) {
        err = std::string("controller state rejected: the stored last outputs are not the controller's (") +
              (step_ok ? "the flat-footed layers' last outputs" : "the stepping layer's phase, swing side or steps") +
              ")";
        return false;
      }
    }
    return ahcfmu::restoredOutputsAre(ctx, outputValues(o), p, vr::theta_ankle_erect, vr::theta_hip_erect, isInteger,
                                      err);
  }

  ahc3d ctl_{};
  ahc3d_outputs out_{};
  unsigned long long ticks_ = 0;
  double t0_ = 0.0;
  int lastPhase_ = 0, lastPhaseY_ = 0;
  unsigned lastFault_ = 0, lastFaultY_ = 0;  // the fault masks last logged
  int nonfinite_ = 0;
  int lastStepPhase_ = 0;
};

}  // namespace

const ModelInfo& fmuglue::modelInfo() {
  static const ModelInfo info = makeInfo();
  return info;
}

std::unique_ptr<Model> fmuglue::createModel() { return std::make_unique<Controller3DModel>(); }
