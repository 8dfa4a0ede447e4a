// The HOAP-2 in 3D on the Open Dynamics Engine: trunk (torso, waist, arms, head), two legs of six
// joints each, box feet on a plane with Coulomb friction, position servos, eight sole load cells,
// an IMU on the trunk, push input and fall detection (docs/plant3d.md).
//
// World frame: x forward, y left, z up, ground plane z = 0. Joint angles use the sagittal plant's
// sense for the pitch joints (theta_ankle: leg relative to foot, theta_hip: trunk relative to leg,
// positive = pitching forward, i.e. about +y) and the Webots proto's sense for the others.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace hoap2plant3d {

// The six joints of a leg, trunk to foot, in the proto's chain order.
enum LegJoint : int { HipYaw = 0, HipPitch, HipRoll, Knee, AnklePitch, AnkleRoll, kLegJoints };
enum Side : int { Left = 0, Right = 1, kLegs };
// The four load cells under each sole, at its corners.
enum Cell : int { FrontLeft = 0, FrontRight, RearLeft, RearRight, kCells };
// The rigid bodies of a leg. The three hip axes meet in one point and the proto's two hip links
// between them are point masses at that point, so the hip is a ball joint and those links belong
// to the thigh exactly; the two ankle axes meet too (a universal joint), the ankle link between
// them goes with the foot (docs/plant3d.md, "Model").
enum LegBody : int { Thigh = 0, Shank, Foot, kLegBodies };
// The 7 rigid bodies: the trunk, then each leg's thigh, shank and foot (left, then right).
constexpr int kBodies = 1 + kLegs * kLegBodies;

const char* joint_name(int j);  // "hip_yaw", "hip", "hip_roll", "knee", "ankle", "ankle_roll"

// A position servo, the sagittal plant's model: velocity command wcmd = sat(kp/kd (ref - q),
// vel_max), torque = kd (wcmd - qdot) - damping qdot, limited to tau_max. Gains are for both legs
// together (as Hoap2Plant's), each leg's joint gets half of kp, kd, damping and tau_max.
struct Servo {
  double kp, kd, tau_max, vel_max, damping;
};

struct Params {
  double g = 9.81;
  bool servo_on = true;
  Servo servo[kLegJoints] = {};      // per joint kind (default_params())
  // --- contact: each sole a box on the plane z = 0, corner contacts ---
  double mu = 1.0;                   // Coulomb friction coefficient (pyramid, axes along the foot)
  // A sole resting flat (four corners on the ground, sticking, at rest) is held still, the rigid
  // limit of its corner contacts, until its ground reaction would pull a corner or slip (docs
  // section 2, "Flat feet"); false: always on the corner contacts
  bool flat_foot_weld = true;
  // normal spring-damper of each corner contact: the stiffness is chosen by the contact study (test
  // plant3d.contact_study: rocking converges to a rigid block's), the damping by default_params()
  // as the critical damping of the sole-pitch mode (critical_contact_damping)
  double contact_stiffness = 2e8;    // [N/m]
  double contact_damping = 0.0;      // [N s/m]
  // ODE steps inside a communication step (upper bounds, equal steps) [s]: internal_step while
  // both feet are held flat, rocking_step otherwise and for a step in which a held foot is
  // released; chosen by the convergence studies (tests plant3d.convergence, plant3d.flat_convergence)
  double internal_step = 1e-3;
  double rocking_step = 2.5e-4;
  // --- push: horizontal force at a trunk point, h_push above the sole in the erect posture ---
  double h_push = 0.335;
  // --- fall detection ---
  double fall_foot_pitch = 0.3;      // a sole tilted more than this [rad]
  double fall_body_pitch = 0.6;      // the ankle -> CoM line leaning more than this [rad]
  // --- load cells ---
  double sensor_noise = 0.0;         // std dev of each cell's white noise [N]
  double sensor_bias_toe = 0.0;      // bias of the toe cells together (a quarter on each) [N]
  double sensor_bias_heel = 0.0;     // bias of the heel cells together [N]
  double sensor_fmin = 1.0;          // below this total load the sensor ZMP reads 0 [N]
  std::uint64_t seed = 1;
  // --- initial posture: the set-points held while the robot settles before t0 ---
  double theta_ankle_init = 0.0, theta_hip_init = 0.0;
  double settle_time = 1.0;          // [s] of settling before t0 (the robot starts at rest)

  double mass() const;               // whole robot [kg]
};

Params default_params();

// The per-corner damping that makes the robot's pitch mode on its eight corner springs of
// stiffness k critically damped (the whole robot rigid, standing, pitching about the soles' centre
// line): c = sqrt(k J / 2) / a, J its inertia about that line, a half the sole length.
double critical_contact_damping(double k);

// The servos' set points (docs/plant3d.md section 3): leg `side`'s joint k is driven to
// ref[k] + leg_ref[side][k], each joint in its own sense (the pitch joints in the sagittal sense,
// the others in the proto's, the same for both legs). ref[] drives both legs alike (the sagittal
// controller's theta_ankle_ref, theta_hip_ref, ...); leg_ref[][] moves one leg alone. With leg_ref
// all 0 the set points are ref[] bit for bit (x + 0 == x; only a -0 reference becomes +0).
struct Inputs {
  double ref[kLegJoints] = {};              // set points, both legs alike [rad]
  double leg_ref[kLegs][kLegJoints] = {};   // per-leg set points, added to ref[] [rad]
  double push_x = 0.0, push_y = 0.0;        // [N], world frame
  double set_point(int side, int k) const { return ref[k] + leg_ref[side][k]; }
};

struct Outputs {
  // The sagittal plant's signals (same names and meaning in the FMU).
  double theta_ankle = 0, theta_hip = 0, dtheta_ankle = 0, dtheta_hip = 0;  // mean of both legs
  double zmp_x = 0, zmp_y = 0;       // sensor ZMP in the feet frame (origin: mid-ankle on the ground)
  double fz = 0;                     // sum of the eight cells [N]
  double f_toe = 0, f_heel = 0;      // front cells, rear cells (both feet) [N]
  double fx = 0, fy = 0;             // horizontal ground reaction, world [N]
  double fz_true = 0, zmp_true_x = 0, zmp_true_y = 0;  // contact forces, no sensor model
  double moment_ankle = 0;           // ground reaction moment about the mean ankle axis (foot-pitch sense)
  double com_x = 0, com_y = 0, com_z = 0;  // whole-robot CoM, feet frame; z above the ankle axis
  double foot_pitch = 0, foot_roll = 0;    // mean of both soles (+ pitch = toes down, + roll = left side up)
  int contact_mode = 0;              // 0 flat, 1 on toes, 2 on heels, 3 airborne (both feet together)
  int contacts = 0;                  // corner contacts in the last ODE step
  bool fallen = false;
  double required_mu = 0;            // |horizontal| / normal ground force
  double energy = 0;                 // kinetic + potential [J]
  double tau_ankle = 0, tau_hip = 0; // servo torques, both legs [N m]
  double cell[kLegs][kCells] = {};   // the eight load cells [N]
  double fz_foot[kLegs] = {};        // normal load of each foot (cells) [N]
  double slip_speed[kLegs] = {};     // horizontal speed of each sole's centre [m/s]
  double feet_x = 0, feet_y = 0;     // the feet frame's origin (mid-ankle, on the ground), world [m]
  double joint[kLegs][kLegJoints] = {};  // all twelve joint angles [rad]
  double tau_joint[kLegs][kLegJoints] = {};  // each joint's servo torque, in the joint's sense [N m]
  double imu_roll = 0, imu_pitch = 0, imu_yaw = 0;  // trunk orientation (Z-Y-X Euler) [rad]
  double gyro[3] = {};               // trunk angular velocity, trunk frame [rad/s]
};

struct Stats {
  std::int64_t ode_steps = 0;      // ODE steps taken, re-solved ones included
  std::int64_t resolves = 0;       // steps solved again with torque / friction limits (see ode_step)
  std::int64_t mode_switches = 0;
  std::int64_t unwelds = 0;        // flat feet released onto their corner contacts
};

// One body's state: all ODE keeps of it between steps (the rotation matrix is stored too, so a
// restore needs no renormalisation and is bit for bit).
struct BodyState {
  double pos[3], quat[4], rot[12], lvel[3], avel[3];
};

// Everything that determines the future, bit for bit (plain old data).
struct Snapshot {
  std::uint32_t magic = 0x48335053u;  // "H3PS"
  std::uint32_t version = 4;          // 4: the per-leg set points (Inputs::leg_ref), Outputs::tau_joint
  double t = 0, t_fall = 0;
  std::int32_t fallen = 0, mode = 0;
  std::int32_t limits_near = 0, pad = 0;
  std::int32_t welded[kLegs] = {};    // the feet held flat (Params::flat_foot_weld)
  BodyState body[kBodies] = {};
  Inputs in;
  std::uint64_t rng = 0;
  Stats stats;
  Outputs out;
};

// Every field of a Snapshot, in a fixed order: f(name, field). For field-by-field serialization
// (no padding bytes in FMU states, every value validated on the way in). Keep in step with the
// structs: a missing field breaks the bit-for-bit restore test (test_plant3d_fmu.py).
template <class S, class F>
void visit_fields(S& s, F&& f) {
  f("t", s.t);
  f("t_fall", s.t_fall);
  f("fallen", s.fallen);
  f("mode", s.mode);
  f("limits_near", s.limits_near);
  for (auto& x : s.welded) f("welded", x);
  for (auto& b : s.body) {
    for (auto& x : b.pos) f("body.pos", x);
    for (auto& x : b.quat) f("body.quat", x);
    for (auto& x : b.rot) f("body.rot", x);
    for (auto& x : b.lvel) f("body.lvel", x);
    for (auto& x : b.avel) f("body.avel", x);
  }
  for (auto& x : s.in.ref) f("inputs.ref", x);
  for (auto& leg : s.in.leg_ref) for (auto& x : leg) f("inputs.leg_ref", x);
  f("inputs.push_x", s.in.push_x);
  f("inputs.push_y", s.in.push_y);
  f("rng", s.rng);
  f("stats.ode_steps", s.stats.ode_steps);
  f("stats.resolves", s.stats.resolves);
  f("stats.mode_switches", s.stats.mode_switches);
  f("stats.unwelds", s.stats.unwelds);
  auto& o = s.out;
  for (auto* x : {&o.theta_ankle, &o.theta_hip, &o.dtheta_ankle, &o.dtheta_hip, &o.zmp_x, &o.zmp_y, &o.fz, &o.f_toe,
                  &o.f_heel, &o.fx, &o.fy, &o.fz_true, &o.zmp_true_x, &o.zmp_true_y, &o.moment_ankle, &o.com_x,
                  &o.com_y, &o.com_z, &o.foot_pitch, &o.foot_roll, &o.required_mu, &o.energy, &o.tau_ankle,
                  &o.tau_hip, &o.feet_x, &o.feet_y, &o.imu_roll, &o.imu_pitch, &o.imu_yaw})
    f("outputs", *x);
  for (auto& leg : o.cell) for (auto& x : leg) f("outputs.cell", x);
  for (auto& x : o.fz_foot) f("outputs.fz_foot", x);
  for (auto& x : o.slip_speed) f("outputs.slip_speed", x);
  for (auto& leg : o.joint) for (auto& x : leg) f("outputs.joint", x);
  for (auto& leg : o.tau_joint) for (auto& x : leg) f("outputs.tau_joint", x);
  for (auto& x : o.gyro) f("outputs.gyro", x);
  f("outputs.contact_mode", o.contact_mode);
  f("outputs.contacts", o.contacts);
  f("outputs.fallen", o.fallen);
}

// The assembled model, for inspection (tests lump it back into the sagittal numbers).
struct BodyInfo {
  std::string name;        // "trunk", "left_hip_yaw", ...
  std::string proto;       // the proto bodies merged into it, comma separated
  double mass;
  double com[3];           // world [m]
  double inertia[6];       // about the CoM, world axes: Ixx Iyy Izz Ixy Ixz Iyz
};
struct JointInfo {
  std::string name;        // "left_hip", ...
  std::string proto;       // the proto's motor name
  double anchor[3], axis[3];
  double lo, hi;           // limits, this model's sense [rad]
};

// ODE's process-wide state (dInitODE2 ... dCloseODE), held by every Plant3D: the first holder
// initialises ODE, the last one released closes it (plant3d.cpp). Thread-safe; any thread.
class OdeUse {
 public:
  OdeUse();   // throws std::runtime_error if ODE cannot be initialised
  ~OdeUse();
  OdeUse(const OdeUse&) = delete;
  OdeUse& operator=(const OdeUse&) = delete;
  static int users();  // holders now (0: ODE is closed)
};

class Plant3D {
 public:
  explicit Plant3D(const Params& p);  // builds the robot in the zero posture, at rest on the ground
  ~Plant3D();
  Plant3D(const Plant3D&) = delete;
  Plant3D& operator=(const Plant3D&) = delete;

  // Move to the initial posture and settle for settle_time under it; then time is t0.
  bool initialize(double t0);
  void set_inputs(const Inputs& in) { in_ = in; }
  enum class Result { Ok, Fallen, Error };
  Result do_step(double h);           // t -> t + h (ODE steps of internal_step / rocking_step)
  bool welded(int side) const;        // the foot is held flat (Params::flat_foot_weld)

  const Params& params() const { return P_; }
  const Outputs& outputs() const { return out_; }
  const Stats& stats() const { return stats_; }
  double time() const { return t_; }
  bool fallen() const { return fallen_; }
  double fall_time() const { return t_fall_; }
  const std::string& message() const { return msg_; }

  Snapshot snapshot() const;
  bool restore(const Snapshot& s);

  std::vector<BodyInfo> bodies() const;
  std::vector<JointInfo> joints() const;
  double sink_depth() const;          // deepest corner penetration in the last step [m]
  void push_point(double p[3]) const; // where the push acts now, world [m]
  void com(double c[3]) const;        // whole-robot CoM, world [m]
  void body_rotation(int i, double R[9]) const;  // body i's rotation, world, row-major

  std::function<void(const std::string&)> logger;

  struct World;                        // the ODE objects (plant3d.cpp)

 private:
  enum class StepResult { Ok, Error, WeldBroken };
  // One ODE step. A held foot whose ground reaction breaks the contact's limits is released and
  // the step taken again if `release`, otherwise the bodies are restored and WeldBroken returned.
  StepResult ode_step(double dt, bool release = true);
  void weld(int side, bool on);       // hold a foot still (ODE kinematic body) or free it
  void weld_resting_feet();           // hold every free foot that rests flat, sticking, at rest
  unsigned weld_reactions();          // held feet: corner forces from their ground reaction; the
                                      // bit of each foot whose reaction breaks the contact's limits
  Result fall_check();                // after a step: Fallen (time, message, log) or Ok
  void make_contacts(double dt, bool bounded);
  bool within_limits(bool& near) const;
  void save_bodies(BodyState* out) const;
  void restore_bodies(const BodyState* in);
  void evaluate_outputs();
  bool check_fall();
  double gauss();
  void log(const std::string& s) {
    if (logger) logger(s);
  }

  Params P_;
  std::unique_ptr<World> w_;
  double t_ = 0;
  bool fallen_ = false;
  bool limits_near_ = false;          // the last step had a torque or friction force near its limit
  double t_fall_ = 0;
  Inputs in_;
  std::uint64_t rng_ = 0;
  Stats stats_;
  Outputs out_;
  std::string msg_;
};


}  // namespace hoap2plant3d
