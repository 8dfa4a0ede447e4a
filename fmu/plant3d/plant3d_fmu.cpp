// Hoap2Plant3D.fmu: the 3D HOAP-2 on the Open Dynamics Engine (plant3d/) behind the FMI 2.0
// co-simulation glue (fmu/common). Every signal Hoap2Plant has and the controller or the tooling
// uses keeps its name, unit and meaning (docs/plant3d.md section 4), so AnkleHipController.fmu
// and every scenario connect unchanged; the 3D signals are added beside them. Servo parameters
// are named as Hoap2Plant's (kp_ankle, ...), for both legs together.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "fmuglue/glue.hpp"
#include "hoap2/nominal.h"
#include "hoap2plant3d/plant3d.hpp"

using namespace fmuglue;
using namespace hoap2plant3d;

namespace {

// Largest push magnitude accepted [N]: 14 times the robot's weight, far beyond any push it can
// survive (about 11 N held statically) yet still a force the integrator resolves into a
// fall. A larger value is refused by fmi2SetReal, naming the variable and the range.
constexpr double kMaxPush = 1000.0;

namespace vr {
enum : fmi2ValueReference {
  // inputs: the sagittal two, the push, then the other set points
  theta_ankle_ref = 0, theta_hip_ref = 1, push_force = 2, push_force_y = 3,
  theta_ankle_roll_ref = 4, theta_hip_roll_ref = 5, theta_hip_yaw_ref = 6, theta_knee_ref = 7,
  // outputs shared with Hoap2Plant (same value references)
  theta_ankle = 10, theta_hip = 11, dtheta_ankle = 12, dtheta_hip = 13, zmp_x = 14, fz = 15, fx = 16,
  com_x = 17, com_z = 18, foot_pitch = 19, contact_mode = 20, fallen = 21, f_toe = 22, f_heel = 23,
  required_mu = 24, zmp_true = 25, fz_true = 26, energy = 27, tau_ankle = 28, tau_hip = 29,
  moment_ankle = 30, input_fault = 31,
  // 3D outputs
  zmp_y = 50, fy = 51, com_y = 52, foot_roll = 53, zmp_true_y = 54, fz_left = 55, fz_right = 56,
  slip_speed_left = 57, slip_speed_right = 58, imu_roll = 59, imu_pitch = 60, imu_yaw = 61,
  gyro_x = 62, gyro_y = 63, gyro_z = 64, sink_depth = 65, feet_x = 66, feet_y = 67,
  first_cell = 70,         // 8 load cells
  first_joint = 80,        // 12 joint angles
  ode_steps = 95, mode_switches = 96, contacts = 97, held_feet = 98,
  link1_com_x = 170, link2_com_x = 171,  // constants: the robot's CoM offsets for the controller
  first_real_param = 100,  // 100 + index into realParams()
  servo_on = 190, seed = 191, flat_foot_weld = 192,
  first_leg_ref = 200,     // 12 per-leg set points q_<side>_<joint>_ref: 200 + side * 6 + joint
  // FMI 3.0 arrays (views of the scalars above, ModelInfo::arrays)
  q = 300, f_cell = 301, fz_feet = 302, slip_speed = 303, gyro = 304, q_leg_ref = 305,
};
}

// The shortest ODE step (internal_step, rocking_step) [s]: 1/84 of the contacts' time constant
// c/k = 0.84 ms and a third of the 1/32 ms reference step of the step studies (docs/plant3d.md
// section 2): ODE's first-order error is resolved there; shorter steps only cost time.
constexpr double kMinOdeStep = 1e-5;

// The most ODE steps one call may take: one fmi2DoStep (max_step_size) and the settling into the
// initial posture in fmi2ExitInitializationMode (settle_time / internal_step), 1 to 3 s of
// computation at 10-25 us per step.
constexpr double kMaxOdeStepsPerCall = 1e5;

// A Real parameter: name, unit, description, bounds, and where it lives in Params.
struct RealParam {
  std::string name, unit, description;
  double min, max;
  std::function<double&(Params&)> field;
};

const std::vector<RealParam>& realParams() {
  static const std::vector<RealParam> table = [] {
    std::vector<RealParam> t = {
        {"g", "m/s2", "Gravitational acceleration", 0.0, 100.0, [](Params& p) -> double& { return p.g; }},
        {"mu", "", "Coulomb friction coefficient of the soles (friction pyramid along the foot axes)", 0.0, 100.0,
         [](Params& p) -> double& { return p.mu; }},
        {"contact_stiffness", "N/m", "Normal stiffness of each sole-corner contact (ODE ERP/CFM equivalent)", 1.0, 1e9,
         [](Params& p) -> double& { return p.contact_stiffness; }},
        {"contact_damping", "N.s/m", "Normal damping of each sole-corner contact", 0.0, 1e7,
         [](Params& p) -> double& { return p.contact_damping; }},
        {"internal_step", "s",
         "ODE step while both feet are held flat (upper bound; equal steps in a communication step)", kMinOdeStep, 0.01,
         [](Params& p) -> double& { return p.internal_step; }},
        {"h_push", "m", "Height of the push point above the sole (erect posture), on the trunk above the hips", 0.0, 10.0,
         [](Params& p) -> double& { return p.h_push; }},
        {"fall_foot_pitch", "rad", "Fallen when a sole tilts more than this", 1e-3, 1.5,
         [](Params& p) -> double& { return p.fall_foot_pitch; }},
        {"fall_body_pitch", "rad", "Fallen when the ankle->CoM line leans more than this", 1e-3, 1.5,
         [](Params& p) -> double& { return p.fall_body_pitch; }},
        {"sensor_noise", "N", "Std deviation of the white noise of each of the 8 sole load cells (0 = off)", 0.0, 1e4,
         [](Params& p) -> double& { return p.sensor_noise; }},
        {"sensor_bias_toe", "N", "Bias of the four toe load cells together", -1e4, 1e4,
         [](Params& p) -> double& { return p.sensor_bias_toe; }},
        {"sensor_bias_heel", "N", "Bias of the four heel load cells together", -1e4, 1e4,
         [](Params& p) -> double& { return p.sensor_bias_heel; }},
        {"sensor_fmin", "N", "Below this total load the sensor ZMP reads 0", 0.0, 1e4,
         [](Params& p) -> double& { return p.sensor_fmin; }},
        {"theta_ankle_init", "rad", "Initial ankle set-point (the robot settles under it before the start)",
         HOAP2_ANKLE_MIN, HOAP2_ANKLE_MAX, [](Params& p) -> double& { return p.theta_ankle_init; }},
        {"theta_hip_init", "rad", "Initial hip set-point (the robot settles under it before the start)", -1.2, 1.2,
         [](Params& p) -> double& { return p.theta_hip_init; }},
        {"settle_time", "s", "Settling time under the initial set-points before the start", 0.0, 100.0,
         [](Params& p) -> double& { return p.settle_time; }},
    };
    struct Field {
      const char* prefix;
      const char* unit;
      const char* what;
      double Servo::*member;
      double min, max;
    };
    const Field fields[] = {
        {"kp_", "N.m/rad", "servo position gain", &Servo::kp, 0.0, 1e6},
        {"kd_", "N.m.s/rad", "servo velocity gain (> 0)", &Servo::kd, 1e-6, 1e5},
        {"tau_max_", "N.m", "servo torque limit", &Servo::tau_max, 1e-6, 1e4},
        {"vel_max_", "rad/s", "servo velocity limit", &Servo::vel_max, 1e-6, 1e3},
        {"damping_", "N.m.s/rad", "passive viscous damping", &Servo::damping, 0.0, 1e4},
    };
    for (int k = 0; k < kLegJoints; ++k) {
      for (const Field& f : fields) {
        double Servo::*m = f.member;
        t.push_back({std::string(f.prefix) + joint_name(k), f.unit,
                     std::string(joint_name(k)) + " " + f.what + ", both legs together (each leg's joint: half)",
                     f.min, f.max, [k, m](Params& p) -> double& { return p.servo[k].*m; }});
      }
    }
    // appended: value references are 100 + the row index
    t.push_back({"rocking_step", "s",
                 "ODE step while a foot rocks or lifts, and for a step in which a held foot is released (upper bound; "
                 "equal steps in an internal step)",
                 kMinOdeStep, 0.01, [](Params& p) -> double& { return p.rocking_step; }});
    return t;
  }();
  return table;
}

const char* kCellNames[kCells] = {"front_left", "front_right", "rear_left", "rear_right"};
const char* kSideNames[kLegs] = {"left", "right"};
// Per leg joint: the both-legs input its per-leg input is added to, and the sense both share with
// the output q_<side>_<joint> (docs/plant3d.md section 3; the same for both legs, not mirrored).
const char* kBothLegsRef[kLegJoints] = {"theta_hip_yaw_ref", "theta_hip_ref",   "theta_hip_roll_ref",
                                        "theta_knee_ref",    "theta_ankle_ref", "theta_ankle_roll_ref"};
const char* kJointWords[kLegJoints] = {"hip yaw", "hip pitch", "hip roll", "knee", "ankle pitch", "ankle roll"};
const char* kJointSense[kLegJoints] = {
    "+ = toes turned to the left, about +z",
    "sagittal sense, + = trunk pitched forward relative to the thigh: hip flexion",
    "+ = foot swung to the left relative to the trunk, about +x",
    "+ = flexed",
    "sagittal sense, + = shank pitched forward relative to the foot",
    "+ = the foot's left edge up relative to the shank, about +x"};
std::string legRefName(int side, int k) { return std::string("q_") + kSideNames[side] + "_" + joint_name(k) + "_ref"; }

ModelInfo makeInfo() {
  Params def = default_params();
  ModelInfo m;
  m.model_name = "Hoap2Plant3D";
  m.description =
      "HOAP-2 humanoid in 3D on the Open Dynamics Engine: trunk with arms and head, two legs of six servo "
      "joints, box soles on the ground with Coulomb friction, eight sole load cells, trunk IMU, push, fall "
      "detection; the signals of Hoap2Plant under the same names";
  m.default_experiment = {0.0, 5.0, 0.0, 1e-3};  // ODE's fixed-step integrator: no tolerance
  m.outputs_depend_on_inputs = false;
  m.extra_log_categories = {{"logOde", "ODE messages"}};
  auto add = [&](const std::string& n, fmi2ValueReference r, Type t, Causality c, Variability v, const char* unit,
                 const std::string& d, double start = 0.0, double mn = kNoBound, double mx = kNoBound) {
    Variable x;
    x.name = n; x.vr = r; x.type = t; x.causality = c; x.variability = v; x.unit = unit; x.description = d;
    x.start = start; x.min = mn; x.max = mx;
    m.variables.push_back(x);
  };
  const auto In = Causality::Input, Out = Causality::Output, Par = Causality::Parameter;
  const auto Cont = Variability::Continuous, Disc = Variability::Discrete, Fix = Variability::Fixed;
  const auto R = Type::Real, I = Type::Integer, B = Type::Boolean;
  add("theta_ankle_ref", vr::theta_ankle_ref, R, In, Cont, "rad", "Ankle pitch set point, both legs", 0.0);
  add("theta_hip_ref", vr::theta_hip_ref, R, In, Cont, "rad", "Hip pitch set point, both legs", 0.0);
  add("push_force", vr::push_force, R, In, Cont, "N", "Horizontal force on the trunk, x (+ forward)", 0.0, -kMaxPush,
      kMaxPush);
  add("push_force_y", vr::push_force_y, R, In, Cont, "N", "Horizontal force on the trunk, y (+ to the left)", 0.0,
      -kMaxPush, kMaxPush);
  add("theta_ankle_roll_ref", vr::theta_ankle_roll_ref, R, In, Cont, "rad", "Ankle roll set point, both legs", 0.0);
  add("theta_hip_roll_ref", vr::theta_hip_roll_ref, R, In, Cont, "rad", "Hip roll set point, both legs", 0.0);
  add("theta_hip_yaw_ref", vr::theta_hip_yaw_ref, R, In, Cont, "rad", "Hip yaw set point, both legs", 0.0);
  add("theta_knee_ref", vr::theta_knee_ref, R, In, Cont, "rad", "Knee set point, both legs (+ = flexed)", 0.0);
  for (int s = 0; s < kLegs; ++s)
    for (int k = 0; k < kLegJoints; ++k)
      add(legRefName(s, k), vr::first_leg_ref + s * kLegJoints + k, R, In, Cont, "rad",
          std::string(s == Left ? "Left" : "Right") + " " + kJointWords[k] + " set point, this leg only: added to " +
              kBothLegsRef[k] + " (" + kJointSense[k] + ")",
          0.0);

  add("theta_ankle", vr::theta_ankle, R, Out, Cont, "rad", "Ankle pitch (leg relative to foot), mean of both legs");
  add("theta_hip", vr::theta_hip, R, Out, Cont, "rad", "Hip pitch (trunk relative to leg), mean of both legs");
  add("dtheta_ankle", vr::dtheta_ankle, R, Out, Cont, "rad/s", "Ankle pitch rate, mean of both legs");
  add("dtheta_hip", vr::dtheta_hip, R, Out, Cont, "rad/s", "Hip pitch rate, mean of both legs");
  add("zmp_x", vr::zmp_x, R, Out, Cont, "m", "ZMP from the eight sole load cells, x from the ankles (feet frame); 0 when unloaded; mean over the communication step");
  add("zmp_y", vr::zmp_y, R, Out, Cont, "m", "ZMP from the load cells, y from the middle of the ankles (feet frame) (mean over the communication step)");
  add("fz", vr::fz, R, Out, Cont, "N", "Total normal force: sum of the eight load cells (mean over the communication step)");
  add("fx", vr::fx, R, Out, Cont, "N", "Horizontal ground reaction force, x (+ forward) (mean over the communication step)");
  add("fy", vr::fy, R, Out, Cont, "N", "Horizontal ground reaction force, y (+ left) (mean over the communication step)");
  add("com_x", vr::com_x, R, Out, Cont, "m", "Whole-robot CoM, x from the ankles (feet frame)");
  add("com_y", vr::com_y, R, Out, Cont, "m", "Whole-robot CoM, y from the middle of the ankles (feet frame)");
  add("com_z", vr::com_z, R, Out, Cont, "m", "Whole-robot CoM, height above the ankle axes");
  add("foot_pitch", vr::foot_pitch, R, Out, Cont, "rad", "Sole pitch, mean of both feet (+ = toes down)");
  add("foot_roll", vr::foot_roll, R, Out, Cont, "rad", "Sole roll, mean of both feet (+ = left edge up)");
  add("contact_mode", vr::contact_mode, I, Out, Disc, "", "Contact of both feet: 0 flat, 1 on toes, 2 on heels, 3 airborne");
  add("fallen", vr::fallen, B, Out, Disc, "", "The robot has fallen (sole tilt or body lean past threshold)");
  add("f_toe", vr::f_toe, R, Out, Cont, "N", "Toe load cells of both feet: sole-normal force, mean over the communication step, with noise/bias if enabled");
  add("f_heel", vr::f_heel, R, Out, Cont, "N", "Heel load cells of both feet");
  add("required_mu", vr::required_mu, R, Out, Cont, "", "Friction coefficient required to prevent slip |f_horizontal|/fz");
  add("zmp_true", vr::zmp_true, R, Out, Cont, "m", "Centre of pressure of the contact forces, x (no sensor model) (mean over the communication step)");
  add("zmp_true_y", vr::zmp_true_y, R, Out, Cont, "m", "Centre of pressure of the contact forces, y");
  add("fz_true", vr::fz_true, R, Out, Cont, "N", "Vertical ground reaction of the contact forces (mean over the communication step)");
  add("moment_ankle", vr::moment_ankle, R, Out, Cont, "N.m", "Ground reaction moment about the mean ankle axis (foot-pitch sense) (mean over the communication step)");
  add("energy", vr::energy, R, Out, Cont, "J", "Mechanical energy (kinetic + potential)");
  add("tau_ankle", vr::tau_ankle, R, Out, Cont, "N.m", "Ankle pitch servo torque, both legs");
  add("tau_hip", vr::tau_hip, R, Out, Cont, "N.m", "Hip pitch servo torque, both legs");
  add("fz_left", vr::fz_left, R, Out, Cont, "N", "Left sole load (its four cells)");
  add("fz_right", vr::fz_right, R, Out, Cont, "N", "Right sole load (its four cells)");
  add("slip_speed_left", vr::slip_speed_left, R, Out, Cont, "m/s", "Horizontal speed of the left sole's centre");
  add("slip_speed_right", vr::slip_speed_right, R, Out, Cont, "m/s", "Horizontal speed of the right sole's centre");
  add("feet_x", vr::feet_x, R, Out, Cont, "m", "Where the feet stand: x of the middle of the ankles on the ground, world");
  add("feet_y", vr::feet_y, R, Out, Cont, "m", "Where the feet stand: y of the middle of the ankles on the ground, world");
  add("imu_roll", vr::imu_roll, R, Out, Cont, "rad", "Trunk roll (Z-Y-X Euler angles)");
  add("imu_pitch", vr::imu_pitch, R, Out, Cont, "rad", "Trunk pitch (+ = leaning forward)");
  add("imu_yaw", vr::imu_yaw, R, Out, Cont, "rad", "Trunk yaw");
  add("gyro_x", vr::gyro_x, R, Out, Cont, "rad/s", "Trunk angular velocity, trunk x axis");
  add("gyro_y", vr::gyro_y, R, Out, Cont, "rad/s", "Trunk angular velocity, trunk y axis");
  add("gyro_z", vr::gyro_z, R, Out, Cont, "rad/s", "Trunk angular velocity, trunk z axis");
  add("sink_depth", vr::sink_depth, R, Out, Cont, "m", "Deepest sole-corner penetration into the ground (last ODE step)");
  for (int s = 0; s < kLegs; ++s)
    for (int c = 0; c < kCells; ++c)
      add(std::string("f_") + kSideNames[s] + "_" + kCellNames[c], vr::first_cell + s * kCells + c, R, Out, Cont, "N",
          std::string("Load cell under the ") + kCellNames[c] + " corner of the " + kSideNames[s] + " sole (mean over the communication step)");
  for (int s = 0; s < kLegs; ++s)
    for (int k = 0; k < kLegJoints; ++k)
      add(std::string("q_") + kSideNames[s] + "_" + joint_name(k), vr::first_joint + s * kLegJoints + k, R, Out, Cont,
          "rad", std::string(kSideNames[s]) + " " + joint_name(k) + " joint angle");
  add("input_fault", vr::input_fault, I, Out, Disc, "",
      "Inputs held at their last finite value because they are NaN/Inf: bit i = input i in the order theta_ankle_ref, "
      "theta_hip_ref, push_force, push_force_y, theta_ankle_roll_ref, theta_hip_roll_ref, theta_hip_yaw_ref, "
      "theta_knee_ref, then bit 8 + 6 side + joint = q_<side>_<joint>_ref (left, right; hip_yaw, hip, hip_roll, knee, "
      "ankle, ankle_roll) (0 = healthy)");
  add("ode_steps", vr::ode_steps, I, Out, Disc, "", "ODE steps so far");
  add("mode_switches", vr::mode_switches, I, Out, Disc, "", "Contact mode switches so far");
  add("contacts", vr::contacts, I, Out, Disc, "", "Sole-corner contacts in the last ODE step (a held foot: 4)");
  add("held_feet", vr::held_feet, I, Out, Disc, "",
      "Feet held flat (flat_foot_weld): 0 none, 1 left, 2 right, 3 both");
  // The robot's numbers that the controller's sagittal model needs beyond the lumped masses and
  // lengths, named after the controller's parameters (docs/plant3d.md section 6, docs/fmu.md).
  const auto Const = Variability::Constant;
  add("link1_com_x", vr::link1_com_x, R, Out, Const, "m",
      "Constant: link 1's CoM (both legs) forward of the ankle-hip line; set the controller's link1_com_x to it",
      HOAP2_LINK1_COM_X);
  add("link2_com_x", vr::link2_com_x, R, Out, Const, "m",
      "Constant: link 2's CoM (upper body) forward of its line through the hip; set the controller's link2_com_x to it",
      HOAP2_LINK2_COM_X);

  // FMI 3.0: the signals that are naturally vectors also as Float64 arrays of the scalars above
  // (docs/fmu.md, "FMI 3.0 arrays"): [side][joint] and [side][cell] in the scalars' order (left, right;
  // hip_yaw, hip, hip_roll, knee, ankle, ankle_roll; front_left, front_right, rear_left, rear_right).
  auto range = [](fmi2ValueReference first, int n) {
    std::vector<fmi2ValueReference> v(n);
    for (int i = 0; i < n; ++i) v[i] = first + static_cast<fmi2ValueReference>(i);
    return v;
  };
  m.arrays = {
      {"q", vr::q, "Joint angles [side, joint] (sides left, right; joints hip_yaw, hip, hip_roll, knee, ankle, "
                   "ankle_roll): q_<side>_<joint>", {kLegs, kLegJoints}, range(vr::first_joint, kLegs * kLegJoints)},
      {"f_cell", vr::f_cell, "Sole load cells [side, corner] (sides left, right; corners front_left, front_right, "
                             "rear_left, rear_right): f_<side>_<corner>", {kLegs, kCells}, range(vr::first_cell, kLegs * kCells)},
      {"fz_feet", vr::fz_feet, "Sole loads [side] (left, right): fz_left, fz_right", {kLegs}, {vr::fz_left, vr::fz_right}},
      {"slip_speed", vr::slip_speed, "Sole slip speeds [side] (left, right): slip_speed_left, slip_speed_right", {kLegs},
       {vr::slip_speed_left, vr::slip_speed_right}},
      {"gyro", vr::gyro, "Trunk angular velocity [axis] (the trunk's x, y, z axes): gyro_x, gyro_y, gyro_z", {3}, {vr::gyro_x, vr::gyro_y, vr::gyro_z}},
      {"q_leg_ref", vr::q_leg_ref, "Per-leg set points [side, joint], the same values as q_<side>_<joint>_ref (setting "
                                   "either sets both: connect one of them)", {kLegs, kLegJoints},
       range(vr::first_leg_ref, kLegs * kLegJoints)},
  };

  const auto& params = realParams();
  for (size_t i = 0; i < params.size(); ++i) {
    const RealParam& p = params[i];
    add(p.name, vr::first_real_param + static_cast<fmi2ValueReference>(i), R, Par, Fix, p.unit.c_str(), p.description,
        p.field(def), p.min, p.max);
  }
  add("servo_on", vr::servo_on, B, Par, Fix, "", "Joint servos active (false: joints passive)", def.servo_on ? 1 : 0);
  add("seed", vr::seed, I, Par, Fix, "", "Seed of the sensor-noise generator (splitmix64)", double(def.seed), 0, 2147483647);
  add("flat_foot_weld", vr::flat_foot_weld, B, Par, Fix, "",
      "A foot resting flat, sticking, is held still (the rigid limit of its corner contacts) until its ground "
      "reaction would lift a corner or slip; false: always on the corner contacts",
      def.flat_foot_weld ? 1 : 0);
  return m;
}

int clampi(std::int64_t v) { return v > 2147483647 ? 2147483647 : static_cast<int>(v); }

// The Real inputs in input_fault's bit order: the eight of before, then the per-leg set points.
constexpr int kBothLegInputs = 8, kFirstLegRef = kBothLegInputs, kInputs = kBothLegInputs + kLegs * kLegJoints;
struct InputTable {
  fmi2ValueReference vr[kInputs];
  std::string name[kInputs];
  const char* c_name[kInputs];
};
const InputTable& inputTable() {
  static const InputTable t = [] {
    InputTable x{{vr::theta_ankle_ref, vr::theta_hip_ref, vr::push_force, vr::push_force_y, vr::theta_ankle_roll_ref,
                  vr::theta_hip_roll_ref, vr::theta_hip_yaw_ref, vr::theta_knee_ref},
                 {"theta_ankle_ref", "theta_hip_ref", "push_force", "push_force_y", "theta_ankle_roll_ref",
                  "theta_hip_roll_ref", "theta_hip_yaw_ref", "theta_knee_ref"},
                 {}};
    for (int s = 0; s < kLegs; ++s)
      for (int k = 0; k < kLegJoints; ++k) {
        const int i = kFirstLegRef + s * kLegJoints + k;
        x.vr[i] = vr::first_leg_ref + s * kLegJoints + k;
        x.name[i] = legRefName(s, k);
      }
    for (int i = 0; i < kInputs; ++i) x.c_name[i] = x.name[i].c_str();
    return x;
  }();
  return t;
}

// The plant's parameters from the parameter variables (range-checked by the glue).
Params paramsFromStore(const Context& ctx) {
  Params p = default_params();
  const auto& params = realParams();
  for (size_t i = 0; i < params.size(); ++i)
    params[i].field(p) = ctx.real(vr::first_real_param + static_cast<fmi2ValueReference>(i));
  p.servo_on = ctx.boolean(vr::servo_on);
  p.seed = static_cast<std::uint64_t>(ctx.integer(vr::seed));
  p.flat_foot_weld = ctx.boolean(vr::flat_foot_weld);
  return p;
}

// The checks that involve several parameters; false with the reason in `why`.
bool paramsConsistent(const Params& p, std::string& why) {
  char buf[320];
  // the settling's ODE steps, counted as Plant3D::initialize counts them
  const double settle_steps = std::ceil(p.settle_time / p.internal_step - 1e-9);
  if (!(p.h_push > HOAP2_ANKLE_HEIGHT + HOAP2_L1)) {
    std::snprintf(buf, sizeof buf, "h_push (%g m) must be above the hips (%g m)", p.h_push,
                  HOAP2_ANKLE_HEIGHT + HOAP2_L1);
  } else if (settle_steps > kMaxOdeStepsPerCall) {
    std::snprintf(buf, sizeof buf,
                  "settle_time = %g s at internal_step = %g s is %.0f ODE steps: the settling in "
                  "fmi2ExitInitializationMode takes at most %.0f (settle_time / internal_step <= %.0f); shorten "
                  "settle_time (with the default servos the robot is at rest to round-off after 5 s) or lengthen "
                  "internal_step",
                  p.settle_time, p.internal_step, settle_steps, kMaxOdeStepsPerCall, kMaxOdeStepsPerCall);
  } else {
    return true;
  }
  why = buf;
  return false;
}

// A restored snapshot's rigid bodies must be ones a simulation can have (a state's bytes are
// untrusted input; finiteness alone let a forged 1e70 quaternion through, and ODE's next step
// then failed): unit quaternions, rotation matrices (ODE's 3x4 layout) with unit rows, positions
// within 1 km of the origin, speeds below 1 km/s and 1e4 rad/s. False with the first violation.
bool plausibleBodies(const Snapshot& s, std::string& why) {
  auto bad = [&](const char* what, int b) {
    why = std::string("invalid plant snapshot: body ") + std::to_string(b) + " " + what;
    return false;
  };
  for (int b = 0; b < kBodies; ++b) {
    const BodyState& x = s.body[b];
    const double qn = x.quat[0] * x.quat[0] + x.quat[1] * x.quat[1] + x.quat[2] * x.quat[2] + x.quat[3] * x.quat[3];
    if (!(std::fabs(qn - 1.0) <= 1e-6)) return bad("quaternion is not a unit quaternion", b);
    for (int r = 0; r < 3; ++r) {
      const double* row = x.rot + 4 * r;
      if (!(std::fabs(row[0] * row[0] + row[1] * row[1] + row[2] * row[2] - 1.0) <= 1e-6))
        return bad("rotation matrix is not a rotation", b);
    }
    for (int k = 0; k < 3; ++k) {
      if (!(std::fabs(x.pos[k]) <= 1e3)) return bad("position is more than 1 km away", b);
      if (!(std::fabs(x.lvel[k]) <= 1e3)) return bad("speed is above 1 km/s", b);
      if (!(std::fabs(x.avel[k]) <= 1e4)) return bad("angular speed is above 1e4 rad/s", b);
    }
  }
  return true;
}

class Plant3DFmu : public Model {
 public:
  void reset(Context&) override {
    plant_.reset();
    built_from_.clear();
  }

  // 2: field by field, parameters from the store; 3: the held feet; 4: the per-leg set points
  // (inputs and last finite inputs) and each joint's servo torque
  std::uint32_t state_version() const override { return 4; }

  // The initial outputs in initialization mode (<InitialUnknowns>: computed from the parameters,
  // after the settling): the plant is built there and kept for fmi2ExitInitializationMode while
  // the parameters stay.
  fmi2Status update_initial_outputs(Context& ctx) override { return build(ctx); }
  fmi2Status exit_initialization(Context& ctx) override { return build(ctx); }

  fmi2Status build(Context& ctx) {
    std::vector<double> key = initialKey(ctx);
    if (plant_ && key == built_from_) return fmi2OK;  // built for an fmi2Get* in initialization mode
    plant_.reset();
    built_from_.clear();
    const Params p = paramsFromStore(ctx);
    std::string why;
    if (!paramsConsistent(p, why)) {
      ctx.log(kLogStatusError, fmi2Error, "%s", why.c_str());
      return fmi2Error;
    }
    try {
      plant_ = std::make_unique<Plant3D>(p);
    } catch (const std::exception& e) {
      ctx.log(kLogStatusError, fmi2Error, "building the ODE model failed: %s", e.what());
      return fmi2Error;
    }
    attach(ctx);
    const bool ok = plant_->initialize(ctx.start_time());
    if (!ok) {
      ctx.log(kLogStatusError, fmi2Error, "plant initialization failed: %s", plant_->message().c_str());
      plant_.reset();
      return fmi2Error;
    }
    for (int i = 0; i < kInputs; ++i) last_in_[i] = 0.0;
    last_in_[0] = p.theta_ankle_init;
    last_in_[1] = p.theta_hip_init;
    write_outputs(ctx);
    detach();
    built_from_ = std::move(key);
    return fmi2OK;
  }

  // At most kMaxOdeStepsPerCall ODE steps per fmi2DoStep (25 s at the default 0.25 ms rocking
  // step): a longer step is refused before anything runs.
  double max_step_size(const Context&) const override {
    return plant_ ? kMaxOdeStepsPerCall * std::min(plant_->params().internal_step, plant_->params().rocking_step)
                  : std::numeric_limits<double>::infinity();
  }

  StepResult do_step(Context& ctx, double t, double h, bool) override {
    StepResult res;
    if (!plantMayStep(ctx, plant_ != nullptr, t, h, plant_ ? plant_->time() : 0.0, plant_ && plant_->fallen(),
                      plant_ ? plant_->fall_time() : 0.0, res))
      return res;
    attach(ctx);
    double in[kInputs];
    const InputTable& inputs = inputTable();
    const fmi2Status st = readFiniteInputs(ctx, t, kInputs, inputs.vr, inputs.c_name, last_in_, in, vr::input_fault);
    Inputs pin;
    pin.ref[AnklePitch] = in[0];
    pin.ref[HipPitch] = in[1];
    pin.push_x = in[2];
    pin.push_y = in[3];
    pin.ref[AnkleRoll] = in[4];
    pin.ref[HipRoll] = in[5];
    pin.ref[HipYaw] = in[6];
    pin.ref[Knee] = in[7];
    for (int s = 0; s < kLegs; ++s)
      for (int k = 0; k < kLegJoints; ++k) pin.leg_ref[s][k] = in[kFirstLegRef + s * kLegJoints + k];
    plant_->set_inputs(pin);
    const auto r = plant_->do_step(plantStepTo(t, h, plant_->time()));  // to the master's t + h
    write_outputs(ctx);
    detach();
    const PlantOutcome outcome = r == Plant3D::Result::Ok       ? PlantOutcome::Ok
                                 : r == Plant3D::Result::Fallen ? PlantOutcome::Fallen
                                                                : PlantOutcome::Error;
    return plantStepResult(ctx, outcome, st, plant_->fall_time(), plant_->message());
  }

  // The parameters are not in the model's part of the state: load_state rebuilds them from the
  // restored (and checked) parameter variables, as exit_initialization does.
  void save_state(StateWriter& w) const override {
    const Snapshot snap = plant_ ? plant_->snapshot() : Snapshot();
    writePlantState(w, plant_ ? &snap : nullptr, last_in_, kInputs);
  }

  bool load_state(Context& ctx, StateReader& r, std::string& err) override {
    bool has = false;
    Snapshot s;
    double li[kInputs];
    if (!readPlantState(ctx, r, has, s, li, kInputs, err)) return false;
    built_from_.clear();
    if (!has) {
      plant_.reset();
      return true;
    }
    if (!plausibleBodies(s, err)) return false;
    const Params p = paramsFromStore(ctx);
    if (!paramsConsistent(p, err)) return false;
    std::unique_ptr<Plant3D> fresh;
    try {
      fresh = std::make_unique<Plant3D>(p);
    } catch (const std::exception& e) {
      return err = std::string("invalid plant parameters in the state: ") + e.what(), false;
    }
    if (!fresh->restore(s)) return err = "invalid plant snapshot (contact mode, flags or state out of range)", false;
    plant_ = std::move(fresh);
    std::memcpy(last_in_, li, sizeof li);
    return true;
  }

 private:
  void attach(Context& ctx) {
    ctx_ = &ctx;
    plant_->logger = [this](const std::string& s) {
      if (!ctx_) return;
      if (s.rfind("ODE", 0) == 0) ctx_->log(kFirstModelCategory, fmi2Warning, "%s", s.c_str());
      else ctx_->log(kLogEvents, fmi2OK, "%s", s.c_str());
    };
  }
  void detach() { ctx_ = nullptr; }

  void write_outputs(Context& ctx) {
    const Outputs& o = plant_->outputs();
    const std::pair<fmi2ValueReference, double> reals[] = {
        {vr::theta_ankle, o.theta_ankle}, {vr::theta_hip, o.theta_hip}, {vr::dtheta_ankle, o.dtheta_ankle},
        {vr::dtheta_hip, o.dtheta_hip}, {vr::zmp_x, o.zmp_x}, {vr::zmp_y, o.zmp_y}, {vr::fz, o.fz}, {vr::fx, o.fx},
        {vr::fy, o.fy}, {vr::com_x, o.com_x}, {vr::com_y, o.com_y}, {vr::com_z, o.com_z},
        {vr::foot_pitch, o.foot_pitch}, {vr::foot_roll, o.foot_roll}, {vr::f_toe, o.f_toe}, {vr::f_heel, o.f_heel},
        {vr::required_mu, o.required_mu}, {vr::zmp_true, o.zmp_true_x}, {vr::zmp_true_y, o.zmp_true_y},
        {vr::fz_true, o.fz_true}, {vr::moment_ankle, o.moment_ankle}, {vr::energy, o.energy},
        {vr::tau_ankle, o.tau_ankle}, {vr::tau_hip, o.tau_hip}, {vr::fz_left, o.fz_foot[Left]},
        {vr::fz_right, o.fz_foot[Right]}, {vr::slip_speed_left, o.slip_speed[Left]},
        {vr::slip_speed_right, o.slip_speed[Right]}, {vr::imu_roll, o.imu_roll}, {vr::imu_pitch, o.imu_pitch},
        {vr::imu_yaw, o.imu_yaw}, {vr::gyro_x, o.gyro[0]}, {vr::gyro_y, o.gyro[1]}, {vr::gyro_z, o.gyro[2]},
        {vr::sink_depth, plant_->sink_depth()}, {vr::feet_x, o.feet_x}, {vr::feet_y, o.feet_y}};
    for (const auto& [ref, v] : reals) ctx.set_real(ref, v);
    for (int s = 0; s < kLegs; ++s) {
      for (int c = 0; c < kCells; ++c) ctx.set_real(vr::first_cell + s * kCells + c, o.cell[s][c]);
      for (int k = 0; k < kLegJoints; ++k) ctx.set_real(vr::first_joint + s * kLegJoints + k, o.joint[s][k]);
    }
    ctx.set_integer(vr::contact_mode, o.contact_mode);
    ctx.set_integer(vr::contacts, o.contacts);
    ctx.set_boolean(vr::fallen, o.fallen);
    ctx.set_integer(vr::ode_steps, clampi(plant_->stats().ode_steps));
    ctx.set_integer(vr::mode_switches, clampi(plant_->stats().mode_switches));
    ctx.set_integer(vr::held_feet, (plant_->welded(Left) ? 1 : 0) + (plant_->welded(Right) ? 2 : 0));
  }

  std::unique_ptr<Plant3D> plant_;
  std::vector<double> built_from_;  // initialKey() of plant_ while it is the initialization mode's
  Context* ctx_ = nullptr;
  double last_in_[kInputs] = {};
};

}  // namespace

const ModelInfo& fmuglue::modelInfo() {
  static const ModelInfo info = makeInfo();
  return info;
}

std::unique_ptr<Model> fmuglue::createModel() { return std::make_unique<Plant3DFmu>(); }
