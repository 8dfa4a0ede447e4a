// The HOAP-2 plant as a time-stepped simulator: contact-mode state machine driven by CVODE root
// functions, joint servos, sole sensors, push input, fall detection, snapshots.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "hoap2plant/model.hpp"

namespace hoap2plant {

struct Stats {
  std::int64_t steps = 0;      // integrator steps
  std::int64_t rhs_evals = 0;  // RHS evaluations (incl. finite-difference Jacobian)
  std::int64_t root_evals = 0; // root-function evaluations
  std::int64_t mode_switches = 0;
  std::int64_t impacts = 0;
  std::int64_t reinits = 0;
};

struct Outputs {
  double t = 0;
  double theta_ankle = 0, theta_hip = 0, dtheta_ankle = 0, dtheta_hip = 0;
  double zmp_x = 0;        // from the sole load cells (as the robot's electronics compute it)
  double fz = 0;           // sum of the sole load cells [N]
  double f_toe = 0, f_heel = 0;  // load cells (with noise/bias if enabled) [N]
  double zmp_true = 0;     // centre of pressure of the constrained dynamics (no sensor model)
  double fz_true = 0, fx = 0, moment_ankle = 0;  // ground reaction (world), moment about ankle
  double com_x = 0, com_z = 0;  // whole-robot CoM rel. to the ankle's ground projection / ankle
  double foot_pitch = 0;
  int contact_mode = 0;
  bool fallen = false;
  double required_mu = 0;  // |Fx| / Fz
  double energy = 0;       // kinetic + potential [J]
  double tau_ankle = 0, tau_hip = 0;  // joint torques applied (servo + passive damping) [N m]
};

// Plain-old-data snapshot: everything that determines the future (bit for bit).
struct Snapshot {
  std::uint32_t magic = 0x48325053u;  // "H2PS"
  std::uint32_t version = 3;  // 2: h_next; 3: impulse
  double t = 0;
  double y[10] = {};
  double impulse[3] = {};     // ground impulse since the start: integrals of Fx, Fz, moment_ankle
  std::int32_t mode = 0;
  std::int32_t fallen = 0;
  double pivot[2] = {};
  double t_fall = 0;
  double inputs[3] = {};
  std::uint64_t rng = 0;
  double h_next = 0;
  Stats stats;
  Outputs out;
};

// Every field of a Snapshot (and of its Stats and Outputs), in a fixed order: f(name, field).
// For field-by-field serialization (FMU states carry no padding bytes and are validated field by
// field on the way in). Keep in step with the structs: a missing field breaks the bit-for-bit
// restore test (test_plant_fmu.py).
template <class S, class F>
void visit_fields(S& s, F&& f) {
  f("t", s.t);
  for (auto& y : s.y) f("y", y);
  for (auto& x : s.impulse) f("impulse", x);
  f("mode", s.mode);
  f("fallen", s.fallen);
  for (auto& x : s.pivot) f("pivot", x);
  f("t_fall", s.t_fall);
  for (auto& x : s.inputs) f("inputs", x);
  f("rng", s.rng);
  f("h_next", s.h_next);
  auto& st = s.stats;
  f("stats.steps", st.steps);
  f("stats.rhs_evals", st.rhs_evals);
  f("stats.root_evals", st.root_evals);
  f("stats.mode_switches", st.mode_switches);
  f("stats.impacts", st.impacts);
  f("stats.reinits", st.reinits);
  auto& o = s.out;
  for (auto* x : {&o.t, &o.theta_ankle, &o.theta_hip, &o.dtheta_ankle, &o.dtheta_hip, &o.zmp_x, &o.fz, &o.f_toe,
                  &o.f_heel, &o.zmp_true, &o.fz_true, &o.fx, &o.moment_ankle, &o.com_x, &o.com_z, &o.foot_pitch,
                  &o.required_mu, &o.energy, &o.tau_ankle, &o.tau_hip})
    f("outputs", *x);
  f("outputs.contact_mode", o.contact_mode);
  f("outputs.fallen", o.fallen);
}

struct ModeEvent {
  double t;
  int from, to;
  const char* why;
};

class Plant {
 public:
  explicit Plant(const Params& p);
  ~Plant();
  Plant(const Plant&) = delete;
  Plant& operator=(const Plant&) = delete;

  // Start at rest, foot flat, in static equilibrium under the servo set-points
  // (theta_ankle_init, theta_hip_init). Returns false (see message()) on failure.
  bool initialize(double t0);
  void set_inputs(double theta_ankle_ref, double theta_hip_ref, double push_force);
  enum class Result { Ok, Fallen, Error };
  // Advance from the current time t to t + h. On a fall the state stops at the fall time.
  Result do_step(double h);

  const Outputs& outputs() const { return out_; }
  const Stats& stats() const { return stats_; }
  double time() const { return t_; }
  bool fallen() const { return fallen_; }
  double fall_time() const { return t_fall_; }
  ContactMode mode() const { return mode_; }
  const std::string& message() const { return msg_; }
  const Model& model() const { return model_; }
  Vec5 q() const;
  Vec5 qd() const;

  Snapshot snapshot() const;
  bool restore(const Snapshot& s);

  std::function<void(const std::string&)> logger;  // events (mode switches, falls)
  std::vector<ModeEvent> history;  // diagnostics (the first history_limit switches), not in the snapshot
  std::size_t history_limit = 100000;
  // The explicit integrator's steps one do_step may take (0: no limit); beyond, the step fails with
  // the reason (stiff equations). Not in the snapshot: a setting of the owner (the FMU: 1e6).
  long max_steps_per_call = 0;

  // integrator callbacks
  int rhs(double t, const double* y, double* ydot);
  int roots(double t, const double* y, double* g);

 private:
  void evaluate_outputs();
  void resolve_mode(const char* why);
  ContactMode land_flat();
  void add_impulse(const Vec5& qd_before, const Vec5& qd_after);  // an impact's ground impulse
  void set_mode(ContactMode m, const char* why);
  bool handle_roots(double t, const int* found);
  bool solver_restart();
  int solver_advance(double tout, double& tret);
  bool ensure_solver();
  void free_solver();
  void accumulate_stats();
  void log(const std::string& s) {
    if (logger) logger(s);
  }
  double gauss();

  Model model_;
  double t_ = 0;
  double y_[10] = {};
  // The ground impulse since the start, (Fx, Fz, moment about the ankle) integrated with the state
  // (three quadrature components of the integrator's vector, left out of its error test) plus the
  // impacts' impulses. The force outputs are its mean over the communication step (evaluate_outputs).
  double impulse_[3] = {};
  double step_t0_ = 0, step_impulse0_[3] = {};  // at the start of the current do_step
  bool step_started_ = false;
  ContactMode mode_ = ContactMode::Flat;
  Vec2 pivot_ = Vec2::Zero();
  bool fallen_ = false;
  double t_fall_ = 0;
  double in_[3] = {0, 0, 0};
  std::uint64_t rng_ = 0;
  Stats stats_;
  Outputs out_;
  std::string msg_;
  // Restart the integrator at the next step: the RHS jumped or the state changed from outside. Mutable:
  // taking a snapshot marks a restart point (const snapshot(), bit-for-bit restores).
  mutable bool restart_ = true;
  // Build the integrator anew at the next step (after a snapshot, as a restored copy does): one that
  // is only reset keeps state the snapshot does not carry (its step count, which bounds how far
  // its first step may grow), and the copies parted by 1e-11 rad.
  mutable bool fresh_solver_ = false;
  bool event_ = false;  // a mode switch or impact since the last restart (plant.cpp, solver_restart)
  long int solver_steps_counted_ = 0;  // the integrator's step count already in stats_.steps
  double h_next_ = 0;  // ERK: the step size its controller proposed last (0: estimate one)
  long int call_steps0_ = 0;  // ERK's step count when the current do_step began
  // SUNDIALS
  void* sunctx_ = nullptr;
  void* solver_ = nullptr;  // CVODE (Integrator::Bdf) or ARKODE ERKStep (Integrator::Erk) memory
  void* nv_ = nullptr;
  void* atol_ = nullptr;   // the integrator's absolute tolerances (N_Vector)
  void* mat_ = nullptr;
  void* ls_ = nullptr;
};

const char* mode_name(ContactMode m);

}  // namespace hoap2plant
