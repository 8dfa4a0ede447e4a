// HOAP-2 sagittal-plane multibody model: parameters, kinematics, mass matrix, bias forces,
// contact constraints and the constrained dynamics of each contact mode.
//
// Generalized coordinates q = (x, z, phi, theta1, theta2):
//   (x, z)  position of the ankle joint axis in the world (x forward, z up, ground at z = 0),
//   phi     foot pitch (rotation about +y; positive = toes down / "pitches forward"),
//   theta1  ankle angle (leg link relative to the foot, positive = leg pitches forward),
//   theta2  hip angle (upper body relative to the leg link, positive = trunk pitches forward).
// Absolute link angles: a_foot = phi, a1 = phi + theta1, a2 = phi + theta1 + theta2.
// A body-frame point (cx forward, cz up) of a body with absolute angle a lies at
//   r(a) = (cx cos a + cz sin a, -cx sin a + cz cos a) relative to its frame origin.
#pragma once

#include <Eigen/Dense>
#include <cstdint>

namespace hoap2plant {

using Vec5 = Eigen::Matrix<double, 5, 1>;
using Mat5 = Eigen::Matrix<double, 5, 5>;
using Vec2 = Eigen::Vector2d;

enum class ContactMode : int { Flat = 0, Toe = 1, Heel = 2, Airborne = 3 };
// The integrator (plant.cpp): ARKODE explicit Runge-Kutta or CVODE BDF (stiff settings).
enum class Integrator : int { Erk = 0, Bdf = 1 };

struct Params {
  // --- model (defaults from hoap2/nominal.h, the nominal numbers shared with the controller) ---
  double g = 9.81;         // gravity [m/s^2]
  double m1 = 0, l1 = 0, lg1 = 0, I1 = 0;   // link 1: legs (knee rigid, straight)
  double m2 = 0, lg2 = 0, I2 = 0;           // link 2: waist, trunk, arms, head
  double feet_mass = 0;       // both feet incl. ankle links and sole plates [kg]
  double feet_inertia = 0;       // foot inertia about its CoM [kg m^2]
  double feet_com_x = 0;   // foot CoM forward of the ankle axis [m]
  double feet_com_z = 0;   // foot CoM height above the sole [m]
  double ankle_height = 0; // ankle axis height above the sole [m]
  double toe_x = 0;        // toe edge, forward of the ankle axis [m] (> 0)
  double heel_x = 0;       // heel edge, forward of the ankle axis [m] (< 0)
  // --- joint servos: cascaded P position -> P velocity (PD when unsaturated) ---
  bool servo_on = true;
  double kp_ankle = 400.0, kd_ankle = 20.0;   // [N m/rad], [N m s/rad] (both legs together)
  double kp_hip = 150.0, kd_hip = 5.0;
  double tau_max_ankle = 18.0, tau_max_hip = 18.0;  // [N m] 2 x 9 N m (Webots HOAP-2 motors)
  double vel_max_ankle = 5.0, vel_max_hip = 5.0;    // [rad/s] (Webots HOAP-2 motors)
  double damping_ankle = 0.0, damping_hip = 0.0;    // passive viscous joint damping [N m s/rad]
  // --- push ---
  double h_push = 0.335;   // height above the sole of the push point in the erect posture [m]
  // --- fall detection ---
  double fall_foot_pitch = 0.3;  // |phi| beyond this = fallen [rad]
  double fall_body_pitch = 0.6;  // |lean of the ankle->CoM line| beyond this = fallen [rad]
  // --- contact ---
  double baumgarte = 20.0; // pivot-constraint stabilization rate in the rocking modes [1/s]
  // Impact law (docs/plant.md section 3): false = the servos transmit no impulsive torque (joint
  // momenta conserved; right when the servos are slow compared with the impact), true = the servos
  // hold the joints rigid through the impact (joint rates unchanged; the whole robot rocks like one
  // rigid body, Housner's law; right when the servos are much faster than the impact).
  bool lock_joints_at_impact = false;
  // --- sole sensors ---
  double sensor_noise = 0.0;     // std dev of each load cell's white noise [N]
  double sensor_bias_toe = 0.0;  // [N]
  double sensor_bias_heel = 0.0; // [N]
  std::uint64_t seed = 1;
  double sensor_fmin = 1.0;      // below this total load the sensor ZMP reads 0 [N]
  // --- initial posture: servo set-points held before t0 (the plant starts at rest in static
  //     equilibrium under them, foot flat) ---
  double theta_ankle_init = 0.0, theta_hip_init = 0.0;
  // --- integrator ---
  Integrator integrator = Integrator::Erk;
  double rtol = 1e-8, atol = 1e-10;
  bool force_flat = false;  // hold the foot flat whatever the reaction (tests only)

  double mass() const { return feet_mass + m1 + m2; }
};

// Defaults: the HOAP-2 nominal numbers shared with the controller (hoap2/nominal.h).
Params default_params();

struct Kinematics {
  // CoM positions (world), Jacobians (2x5) and bias accelerations (Jdot qdot) of the 3 bodies.
  Vec2 p[3];
  Eigen::Matrix<double, 2, 5> J[3];
  Vec2 b[3];
  double s[3][5];  // angular-velocity row of each body (constant)
};

class Model {
 public:
  explicit Model(const Params& p) : P(p) {}
  Params P;

  // Point (cx, cz) of body 0 (foot, relative to the ankle) in world coordinates.
  Vec2 foot_point(const Vec5& q, double cx, double cz) const;
  // Its Jacobian (2x5) and bias acceleration Jdot qdot.
  void foot_point_jac(const Vec5& q, const Vec5& qd, double cx, double cz,
                      Eigen::Matrix<double, 2, 5>& J, Vec2& bias) const;
  Vec2 toe(const Vec5& q) const { return foot_point(q, P.toe_x, -P.ankle_height); }
  Vec2 heel(const Vec5& q) const { return foot_point(q, P.heel_x, -P.ankle_height); }
  // Push point (on link 2's axis) and its Jacobian.
  void push_point(const Vec5& q, const Vec5& qd, Vec2& pos, Eigen::Matrix<double, 2, 5>& J,
                  Vec2& bias) const;

  void kinematics(const Vec5& q, const Vec5& qd, Kinematics& k) const;
  // Mass matrix M(q) and bias h(q, qd) = Coriolis/centrifugal + gravity:  M qdd + h = Q.
  void mass_bias(const Vec5& q, const Vec5& qd, Mat5& M, Vec5& h) const;
  Vec2 com(const Vec5& q) const;  // whole-robot CoM (feet included), world
  double kinetic_energy(const Vec5& q, const Vec5& qd) const;
  double potential_energy(const Vec5& q) const;

  // Joint torques of the servos (+ passive damping) for the given set-points.
  void joint_torques(const Vec5& q, const Vec5& qd, double ref1, double ref2, double& tau1,
                     double& tau2) const;
  // Generalized applied forces: joint torques + horizontal push on link 2.
  Vec5 applied(const Vec5& q, const Vec5& qd, double ref1, double ref2, double push) const;

  struct Dyn {
    Vec5 qdd;
    Vec5 Qc;  // generalized ground force J^T lambda: (Fx, Fz, moment about the ankle, 0, 0)
  };
  // Constrained dynamics in the given mode. pivot: ground point of the rocking edge.
  Dyn dynamics(ContactMode mode, const Vec5& q, const Vec5& qd, double ref1, double ref2,
               double push, const Vec2& pivot) const;
  // The joint accelerations (theta1'', theta2'') with the foot flat, as dynamics(Flat, ...).qdd
  // but without the ground reaction: the right-hand side of the flat mode, where the integrator
  // spends most of its evaluations. Only links 1 and 2 enter (the foot does not move with the
  // joints): the 2 x 2 joint block of M, the joints' bias forces and torques.
  Vec2 flat_joint_accelerations(const Vec5& q, const Vec5& qd, double ref1, double ref2, double push) const;
  // Plastic impact onto the constraint set of `mode` (velocities satisfying J qd = 0); with
  // P.lock_joints_at_impact the joint rates are held too (impulsive joint torques).
  Vec5 impact(ContactMode mode, const Vec5& q, const Vec5& qd) const;
  // The largest |lambda| [1/s] of the equations of motion linearised at rest in posture q, the
  // set points at q's joint angles, over the contact modes the foot stands or rocks in (flat, on
  // the toe, on the heel): the rate that bounds an explicit integrator's stable step (docs/plant.md
  // section 7, "Stiff servo gains").
  double fastest_rate(const Vec5& q) const;
};

}  // namespace hoap2plant
