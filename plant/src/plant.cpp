// HOAP-2 plant simulator: a SUNDIALS integrator advances y = (q, qd) of the current contact mode;
// its root functions locate every mode change; discrete changes restart it. Two integrators
// (Params::integrator, docs/plant.md section 7):
//   ERK (default): ARKODE's explicit Runge-Kutta, Cash-Karp 6(4)5 pair. A one-step method: a
//       restart costs one RHS evaluation, so the servo set-points may jump at every communication
//       point (the closed loop) at no extra cost.
//   BDF: CVODE's variable-order BDF with a dense Newton solver, for stiff settings (very high servo
//       gains). A restart drops it to order 1 with a fresh Jacobian, which costs 20-50 RHS
//       evaluations at rtol 1e-8.
// Either is restarted only where the right-hand side jumps or the state is changed from outside:
// an input that changed at a communication point, a mode switch or impact, a restore, and a
// snapshot (so that the original and any restored copy continue bit for bit). Between restarts
// they keep their step size (and BDF its order and Jacobian) across communication points.
#include "hoap2plant/plant.hpp"

#include <arkode/arkode_erkstep.h>
#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <cmath>
#include <cstdio>
#include <cstring>

namespace hoap2plant {

namespace {

// M_PI is POSIX, not ISO C++ (MinGW has none); the same literal as glibc's, so the same double.
constexpr double kPi = 3.14159265358979323846;
constexpr int kNumRoots = 5;
// The integrator's vector: the 10 states (q, qd), then the ground impulse's 3 quadrature components.
constexpr int kStateSize = 13;

int solver_rhs(realtype t, N_Vector y, N_Vector yd, void* ud) {
  return static_cast<Plant*>(ud)->rhs(t, N_VGetArrayPointer(y), N_VGetArrayPointer(yd));
}
int solver_roots(realtype t, N_Vector y, realtype* g, void* ud) {
  return static_cast<Plant*>(ud)->roots(t, N_VGetArrayPointer(y), g);
}
void solver_err(int code, const char* module, const char* function, char* msg, void* ud) {
  auto* p = static_cast<Plant*>(ud);
  if (p->logger) {
    char buf[512];
    std::snprintf(buf, sizeof buf, "SUNDIALS %s/%s (%d): %s", module, function, code, msg);
    p->logger(buf);
  }
}
inline std::uint64_t splitmix64(std::uint64_t& s) {
  std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
}  // namespace

const char* mode_name(ContactMode m) {
  switch (m) {
    case ContactMode::Flat: return "flat";
    case ContactMode::Toe: return "toe";
    case ContactMode::Heel: return "heel";
    case ContactMode::Airborne: return "airborne";
  }
  return "?";
}

Plant::Plant(const Params& p) : model_(p) {}

Plant::~Plant() { free_solver(); }

void Plant::free_solver() {
  if (solver_ && model_.P.integrator == Integrator::Bdf) CVodeFree(&solver_);
  if (solver_ && model_.P.integrator == Integrator::Erk) ERKStepFree(&solver_);
  if (ls_) SUNLinSolFree(static_cast<SUNLinearSolver>(ls_));
  if (mat_) SUNMatDestroy(static_cast<SUNMatrix>(mat_));
  if (nv_) N_VDestroy(static_cast<N_Vector>(nv_));
  if (atol_) N_VDestroy(static_cast<N_Vector>(atol_));
  if (sunctx_) {
    SUNContext ctx = static_cast<SUNContext>(sunctx_);
    SUNContext_Free(&ctx);
  }
  solver_ = ls_ = mat_ = nv_ = atol_ = sunctx_ = nullptr;
  solver_steps_counted_ = 0;
}

Vec5 Plant::q() const { return Eigen::Map<const Vec5>(y_); }
Vec5 Plant::qd() const { return Eigen::Map<const Vec5>(y_ + 5); }

double Plant::gauss() {
  // Box-Muller from two splitmix64 uniforms in (0, 1]; state advances by exactly 2 draws.
  const double u1 = (static_cast<double>(splitmix64(rng_) >> 11) + 1.0) * 0x1.0p-53;
  const double u2 = static_cast<double>(splitmix64(rng_) >> 11) * 0x1.0p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

int Plant::rhs(double, const double* y, double* yd) {
  ++stats_.rhs_evals;
  const Vec5 q = Eigen::Map<const Vec5>(y), qd = Eigen::Map<const Vec5>(y + 5);
  if (mode_ == ContactMode::Airborne) {
    const auto d = model_.dynamics(mode_, q, qd, in_[0], in_[1], in_[2], pivot_);
    for (int i = 0; i < 5; ++i) {
      yd[i] = qd[i];
      yd[5 + i] = d.qdd[i];
    }
    yd[10] = yd[11] = yd[12] = 0.0;
  } else {
    const auto d = model_.dynamics(mode_, q, qd, in_[0], in_[1], in_[2], pivot_);
    if (mode_ == ContactMode::Flat) {  // the foot is fixed: only the joints move (2 x 2 system)
      const Vec2 a = model_.flat_joint_accelerations(q, qd, in_[0], in_[1], in_[2]);
      for (int i = 0; i < 10; ++i) yd[i] = 0.0;
      yd[3] = qd[3];
      yd[4] = qd[4];
      yd[8] = a[0];
      yd[9] = a[1];
    } else {
      for (int i = 0; i < 5; ++i) {
        yd[i] = qd[i];
        yd[5 + i] = d.qdd[i];
      }
    }
    for (int i = 0; i < 3; ++i) yd[10 + i] = d.Qc[i];  // the ground impulse's quadrature
  }
  for (int i = 0; i < kStateSize; ++i)
    if (!std::isfinite(yd[i])) return 1;  // recoverable: the integrator retries with a smaller step
  return 0;
}

int Plant::roots(double, const double* y, double* g) {
  ++stats_.root_evals;
  const Params& P = model_.P;
  const Vec5 q = Eigen::Map<const Vec5>(y), qd = Eigen::Map<const Vec5>(y + 5);
  for (int i = 0; i < kNumRoots; ++i) g[i] = 1.0;
  if (P.force_flat) return 0;
  const Vec2 c = model_.com(q);
  const double lean = std::atan2(c.x() - q[0], c.y() - q[1]);
  g[3] = P.fall_foot_pitch - std::fabs(q[2]);
  g[4] = P.fall_body_pitch - std::fabs(lean);
  switch (mode_) {
    case ContactMode::Flat: {
      const auto d = model_.dynamics(mode_, q, qd, in_[0], in_[1], in_[2], pivot_);
      const double Fx = d.Qc[0], Fz = d.Qc[1], MA = d.Qc[2];
      const double mz = MA + q[1] * Fx;  // = -p Fz  (p: CoP rel. to the ankle projection)
      g[0] = Fz * P.toe_x + mz;          // moment of the reaction about the toe edge
      g[1] = -mz - Fz * P.heel_x;        // ... about the heel edge
      g[2] = Fz;
      break;
    }
    case ContactMode::Toe:
    case ContactMode::Heel: {
      const auto d = model_.dynamics(mode_, q, qd, in_[0], in_[1], in_[2], pivot_);
      g[0] = q[2];      // foot pitch back to zero: lands flat
      g[1] = d.Qc[1];   // normal force reaching zero: lift-off
      break;
    }
    case ContactMode::Airborne:
      g[0] = model_.toe(q).y();
      g[1] = model_.heel(q).y();
      break;
  }
  return 0;
}

// Integrator steps (CVODE counts from its last restart, ARKODE from its creation): add what they
// gained since the last call. RHS and root-function evaluations are counted in the callbacks.
void Plant::accumulate_stats() {
  if (!solver_) return;
  long int n = 0;
  if (model_.P.integrator == Integrator::Bdf) CVodeGetNumSteps(solver_, &n);
  else ERKStepGetNumSteps(solver_, &n);
  stats_.steps += n - solver_steps_counted_;
  solver_steps_counted_ = n;
}

// Restart the integrator from (t_, y_): BDF at order 1 with a new Jacobian and CVODE's initial
// step estimate. ERK after an input change with the step size its error controller last proposed
// (h_next_, also in the snapshot, so a restored copy restarts with the same step); after a mode
// switch or impact with ARKODE's initial step estimate, like CVODE: a rocking mode entered at rest
// starts with its landing root (foot pitch) at zero, where ARKODE switches that root off until it
// moves away from zero; a full-length first step could carry the foot's brief excursion and its
// landing unseen.
bool Plant::solver_restart() {
  N_Vector y = static_cast<N_Vector>(nv_);
  std::memcpy(N_VGetArrayPointer(y), y_, sizeof y_);
  std::memcpy(N_VGetArrayPointer(y) + 10, impulse_, sizeof impulse_);
  int dir[kNumRoots] = {-1, -1, -1, -1, -1};
  if (mode_ == ContactMode::Heel) dir[0] = +1;
  if (model_.P.integrator == Integrator::Bdf) {
    if (CVodeReInit(solver_, t_, y) != CV_SUCCESS) return false;
    if (CVodeSetRootDirection(solver_, dir) != CV_SUCCESS) return false;
    solver_steps_counted_ = 0;
  } else {
    if (ERKStepSetInitStep(solver_, event_ ? 0.0 : h_next_) != ARK_SUCCESS) return false;
    if (ERKStepReset(solver_, t_, y) != ARK_SUCCESS) return false;
    if (ERKStepSetRootDirection(solver_, dir) != ARK_SUCCESS) return false;
  }
  ++stats_.reinits;
  restart_ = event_ = false;
  return true;
}

// Advance towards tout (never past it); returns 0 at tout, 1 at a root, < 0 on failure.
int Plant::solver_advance(double tout, double& tret) {
  N_Vector y = static_cast<N_Vector>(nv_);
  int flag;
  if (model_.P.integrator == Integrator::Bdf) {
    CVodeSetStopTime(solver_, tout);
    flag = CVode(solver_, tout, y, &tret, CV_NORMAL);
    if (flag == CV_ROOT_RETURN) return 1;
  } else {
    ERKStepSetStopTime(solver_, tout);
    if (max_steps_per_call > 0) {  // what is left of this communication step's budget
      long int n = 0;
      ERKStepGetNumSteps(solver_, &n);
      const long int left = max_steps_per_call - (n - call_steps0_);
      if (left < 1) return ARK_TOO_MUCH_WORK;
      ERKStepSetMaxNumSteps(solver_, left);
    }
    flag = ERKStepEvolve(solver_, tout, y, &tret, ARK_NORMAL);
    ERKStepGetCurrentStep(solver_, &h_next_);
    if (flag == ARK_ROOT_RETURN) return 1;
  }
  return flag < 0 ? flag : 0;
}

void Plant::set_mode(ContactMode m, const char* why) {
  if (m == mode_) return;
  restart_ = event_ = true;
  if (history.size() < history_limit) history.push_back({t_, static_cast<int>(mode_), static_cast<int>(m), why});
  char buf[160];
  std::snprintf(buf, sizeof buf, "t=%.6f s: contact %s -> %s (%s)", t_, mode_name(mode_),
                mode_name(m), why);
  log(buf);
  const Vec5 q = this->q();
  if (m == ContactMode::Toe) pivot_ = Vec2(model_.toe(q).x(), 0.0);
  if (m == ContactMode::Heel) pivot_ = Vec2(model_.heel(q).x(), 0.0);
  mode_ = m;
  ++stats_.mode_switches;
}

// An impact's ground impulse: the generalized impulse M (qd+ - qd-) on the foot's coordinates
// (x, z, pitch about the ankle), as Qc's (any impulsive joint torque acts on the joint rows only).
void Plant::add_impulse(const Vec5& qd_before, const Vec5& qd_after) {
  Mat5 M;
  Vec5 hb;
  model_.mass_bias(q(), qd_before, M, hb);
  const Vec5 J = M * (qd_after - qd_before);
  for (int i = 0; i < 3; ++i) impulse_[i] += J[i];
}

// The rocking foot is back at phi = 0 (rotating into the ground): apply the landing impact and
// return the mode after it. Free joints (default): the whole sole stops the foot, the joints keep
// their momenta. Locked joints: the robot is one rigid body; the impulse acts at the landing edge
// (Housner) and the robot rocks on over that edge, unless the rigid impact leaves it rotating back
// into the ground, in which case the whole sole stops it.
ContactMode Plant::land_flat() {
  const Params& P = model_.P;
  const Vec5 q = this->q(), qd = this->qd();
  ContactMode next = ContactMode::Flat;
  Vec5 qd2;
  if (P.lock_joints_at_impact && (mode_ == ContactMode::Toe || mode_ == ContactMode::Heel)) {
    const ContactMode edge = mode_ == ContactMode::Toe ? ContactMode::Heel : ContactMode::Toe;
    qd2 = model_.impact(edge, q, qd);
    if (edge == ContactMode::Heel ? qd2[2] < 0 : qd2[2] > 0) next = edge;
  }
  if (next == ContactMode::Flat) qd2 = model_.impact(ContactMode::Flat, q, qd);
  if (qd2 != qd) ++stats_.impacts;
  add_impulse(qd, qd2);
  restart_ = event_ = true;
  for (int i = 0; i < 5; ++i) y_[5 + i] = qd2[i];
  y_[2] = 0.0;
  y_[1] = P.ankle_height;
  return next;
}

// Make the contact mode consistent with the current state and inputs (inputs are piecewise
// constant and may jump at a communication point; impacts change velocities). No cycles: a mode
// is entered at most once per call.
void Plant::resolve_mode(const char* why) {
  const Params& P = model_.P;
  if (P.force_flat) return;
  bool visited[4] = {false, false, false, false};
  for (int it = 0; it < 4; ++it) {
    visited[static_cast<int>(mode_)] = true;
    const Vec5 q = this->q(), qd = this->qd();
    const auto d = model_.dynamics(mode_, q, qd, in_[0], in_[1], in_[2], pivot_);
    ContactMode next = mode_;
    const char* reason = why;
    switch (mode_) {
      case ContactMode::Flat: {
        const double Fx = d.Qc[0], Fz = d.Qc[1], mz = d.Qc[2] + q[1] * Fx;
        if (Fz <= 0) next = ContactMode::Airborne, reason = "normal force <= 0";
        else if (Fz * P.toe_x + mz < 0) next = ContactMode::Toe, reason = "CoP beyond the toe";
        else if (-mz - Fz * P.heel_x < 0) next = ContactMode::Heel, reason = "CoP beyond the heel";
        break;
      }
      case ContactMode::Toe:
        if (d.Qc[1] < 0) next = ContactMode::Airborne, reason = "toe normal force < 0";
        else if (q[2] < 0 || (q[2] == 0 && qd[2] < 0))
          next = ContactMode::Flat, reason = "foot rotating into the ground";
        break;
      case ContactMode::Heel:
        if (d.Qc[1] < 0) next = ContactMode::Airborne, reason = "heel normal force < 0";
        else if (q[2] > 0 || (q[2] == 0 && qd[2] > 0))
          next = ContactMode::Flat, reason = "foot rotating into the ground";
        break;
      case ContactMode::Airborne:
        break;
    }
    if (next == mode_ || visited[static_cast<int>(next)]) return;
    if (next == ContactMode::Flat) next = land_flat();
    set_mode(next, reason);
  }
}

bool Plant::ensure_solver() {
  const Params& P = model_.P;
  if (!solver_) {
    SUNContext ctx = nullptr;
    if (SUNContext_Create(nullptr, &ctx) != 0) return msg_ = "SUNContext_Create failed", false;
    sunctx_ = ctx;
    N_Vector y = N_VNew_Serial(kStateSize, ctx);
    nv_ = y;
    N_VEnableFusedOps_Serial(y, SUNTRUE);  // one loop per linear combination of stages
    std::memcpy(N_VGetArrayPointer(y), y_, sizeof y_);
    std::memcpy(N_VGetArrayPointer(y) + 10, impulse_, sizeof impulse_);
    N_Vector w = N_VClone(y);
    atol_ = w;
    if (P.integrator == Integrator::Bdf) {
      solver_ = CVodeCreate(CV_BDF, ctx);
      if (!solver_) return msg_ = "CVodeCreate failed", false;
      CVodeSetErrHandlerFn(solver_, solver_err, this);
      if (CVodeInit(solver_, solver_rhs, t_, y) != CV_SUCCESS) return msg_ = "CVodeInit failed", false;
      SUNMatrix A = SUNDenseMatrix(kStateSize, kStateSize, ctx);
      mat_ = A;
      SUNLinearSolver LS = SUNLinSol_Dense(y, A, ctx);
      ls_ = LS;
      CVodeSetLinearSolver(solver_, LS, A);
      CVodeSetUserData(solver_, this);
      CVodeRootInit(solver_, kNumRoots, solver_roots);
      CVodeSetNoInactiveRootWarn(solver_);
      CVodeSetMaxNumSteps(solver_, 100000);
    } else {
      solver_ = ERKStepCreate(solver_rhs, t_, y, ctx);
      if (!solver_) return msg_ = "ERKStepCreate failed", false;
      ERKStepSetErrHandlerFn(solver_, solver_err, this);
      ERKStepSetTableNum(solver_, ARKODE_CASH_KARP_6_4_5);
      // Cubic Hermite dense output for root location: needs no RHS beyond the step's own (degree
      // 4 and 5 cost 2 more per step); error O(h^4), far below the tolerances at 1 ms steps.
      ERKStepSetInterpolantDegree(solver_, 3);
      ERKStepSetUserData(solver_, this);
      ERKStepRootInit(solver_, kNumRoots, solver_roots);
      ERKStepSetNoInactiveRootWarn(solver_);
      // No step-count limit per ERKStepEvolve call: at rest the explicit method takes
      // stability-limited steps (about 3 / 423 s with the default servos), so a long communication
      // step needs many; the whole communication step's count is bounded by max_steps_per_call.
      ERKStepSetMaxNumSteps(solver_, -1);
    }
  }
  // The impulse quadrature follows the states' steps and is left out of the error test (an
  // absolute tolerance beyond any value): it is an integral of the steps' solution, not a state.
  // The error and Newton tests take the RMS over all 13 components; tolerances scaled by
  // sqrt(10/13) make it the RMS over the 10 states that rtol and atol are about.
  const double c = std::sqrt(10.0 / kStateSize);
  N_Vector atol = static_cast<N_Vector>(atol_);
  for (int i = 0; i < kStateSize; ++i) N_VGetArrayPointer(atol)[i] = i < 10 ? c * P.atol : 1e300;
  const int tol = P.integrator == Integrator::Bdf ? CVodeSVtolerances(solver_, c * P.rtol, atol)
                                                  : ERKStepSVtolerances(solver_, c * P.rtol, atol);
  if (tol != 0) return msg_ = "bad tolerances", false;
  return true;
}

bool Plant::initialize(double t0) {
  const Params& P = model_.P;
  t_ = t0;
  fallen_ = false;
  t_fall_ = 0;
  mode_ = ContactMode::Flat;
  pivot_.setZero();
  rng_ = P.seed;
  stats_ = Stats{};
  history.clear();
  restart_ = true;
  in_[0] = P.theta_ankle_init;
  in_[1] = P.theta_hip_init;
  // Static equilibrium under the initial set-points (Newton, finite-difference Jacobian).
  Vec5 q;
  q << 0.0, P.ankle_height, 0.0, P.theta_ankle_init, P.theta_hip_init;
  const Vec5 z = Vec5::Zero();
  auto resid = [&](const Vec5& qq) {
    Mat5 M;
    Vec5 h;
    model_.mass_bias(qq, z, M, h);
    const Vec5 Q = model_.applied(qq, z, in_[0], in_[1], in_[2]);
    return Eigen::Vector2d((Q - h).tail<2>());
  };
  if (P.servo_on) {
    for (int it = 0; it < 50; ++it) {
      const Eigen::Vector2d r = resid(q);
      if (r.norm() < 1e-13) break;
      Eigen::Matrix2d Jr;
      for (int j = 0; j < 2; ++j) {
        Vec5 qq = q;
        const double e = 1e-7;
        qq[3 + j] += e;
        Jr.col(j) = (resid(qq) - r) / e;
      }
      q.tail<2>() -= Jr.fullPivLu().solve(r);
    }
  }
  for (int i = 0; i < 5; ++i) {
    y_[i] = q[i];
    y_[5 + i] = 0.0;
  }
  if (!std::isfinite(q[3]) || !std::isfinite(q[4])) {
    msg_ = "initial equilibrium failed";
    return false;
  }
  if (!ensure_solver()) return false;
  resolve_mode("initial state");
  evaluate_outputs();
  return true;
}

void Plant::set_inputs(double a, double b, double push) {
  // A changed input makes the RHS jump (bitwise comparison: -0.0 vs 0.0 or a NaN count as changes).
  if (std::memcmp(&in_[0], &a, sizeof a) || std::memcmp(&in_[1], &b, sizeof b) ||
      std::memcmp(&in_[2], &push, sizeof push)) {
    restart_ = true;
  }
  in_[0] = a;
  in_[1] = b;
  in_[2] = push;
}

bool Plant::handle_roots(double t, const int* found) {
  const Params& P = model_.P;
  (void)t;
  if (found[3] || found[4]) {
    fallen_ = true;
    t_fall_ = t_;
    char buf[200];
    const Vec5 q = this->q();
    const Vec2 c = model_.com(q);
    std::snprintf(buf, sizeof buf,
                  "t=%.6f s: FALLEN: %s (foot pitch %.4f rad, limit %.3f; body lean %.4f rad, "
                  "limit %.3f)",
                  t_, found[3] ? "foot pitch past threshold" : "body pitch past threshold", q[2],
                  P.fall_foot_pitch, std::atan2(c.x() - q[0], c.y() - q[1]), P.fall_body_pitch);
    msg_ = buf;
    log(buf);
    return true;
  }
  switch (mode_) {
    case ContactMode::Flat:
      if (found[2]) set_mode(ContactMode::Airborne, "normal force reached zero");
      else if (found[0]) set_mode(ContactMode::Toe, "CoP reached the toe edge");
      else if (found[1]) set_mode(ContactMode::Heel, "CoP reached the heel edge");
      break;
    case ContactMode::Toe:
    case ContactMode::Heel:
      if (found[1]) {
        set_mode(ContactMode::Airborne, "edge normal force reached zero");
      } else if (found[0]) {
        const ContactMode next = land_flat();
        set_mode(next, next == ContactMode::Flat ? "foot landed flat (plastic impact)"
                                                 : "foot landed and rocks on over the other edge (rigid impact)");
      }
      break;
    case ContactMode::Airborne: {
      const ContactMode m = found[0] ? ContactMode::Toe : ContactMode::Heel;
      const Vec5 qd2 = model_.impact(m, q(), qd());
      {
        // A sticking plastic point impact: if the edge arrives with a large tangential velocity
        // the impulse that stops it can have a pulling normal component (a frictional impact law
        // would be needed). Not modelled; reported (docs/plant.md, known simplifications).
        Mat5 M;
        Vec5 hb;
        model_.mass_bias(q(), qd(), M, hb);
        const double Pn = (M * (qd2 - qd()))[1];
        if (Pn < 0) {
          char buf[160];
          std::snprintf(buf, sizeof buf,
                        "t=%.6f s: warning: touch-down impulse has a pulling normal component "
                        "(%.3g N s); sticking impact assumed", t_, Pn);
          log(buf);
        }
      }
      add_impulse(qd(), qd2);
      for (int i = 0; i < 5; ++i) y_[5 + i] = qd2[i];
      ++stats_.impacts;
      restart_ = event_ = true;
      set_mode(m, "edge touched down (plastic impact)");
      break;
    }
  }
  resolve_mode("after event");
  return false;
}

Plant::Result Plant::do_step(double h) {
  if (fallen_) return Result::Fallen;
  if (!solver_) return msg_ = "not initialized", Result::Error;
  for (double v : in_)
    if (!std::isfinite(v)) return msg_ = "non-finite input", Result::Error;
  const double tout = t_ + h;
  step_t0_ = t_;
  std::memcpy(step_impulse0_, impulse_, sizeof impulse_);
  step_started_ = true;
  if (fresh_solver_) {
    // after a snapshot: the integrator a restored copy has, built anew (a reset one keeps its step
    // count, which sets how far its first step may grow: ARKODE's etamx1 vs growth)
    accumulate_stats();
    free_solver();
    if (!ensure_solver()) return Result::Error;
    fresh_solver_ = false;
  }
  if (restart_) resolve_mode("inputs changed");
  if (restart_ && !solver_restart()) return msg_ = "integrator restart failed", Result::Error;
  if (model_.P.integrator == Integrator::Erk) ERKStepGetNumSteps(solver_, &call_steps0_);
  N_Vector y = static_cast<N_Vector>(nv_);
  int guard = 0;
  while (true) {
    double tret = t_;
    const int flag = solver_advance(tout, tret);
    if (flag < 0) {
      accumulate_stats();
      char buf[400];
      if (model_.P.integrator == Integrator::Erk && flag == ARK_TOO_MUCH_WORK && max_steps_per_call > 0)
        std::snprintf(buf, sizeof buf,
                      "the explicit integrator took %ld steps in the communication step from t=%.9f to %.9f without "
                      "reaching its end, the most one step may take: the equations are stiff for it (servo gains "
                      "far above the HOAP-2's?); use the BDF integrator or shorter communication steps",
                      max_steps_per_call, step_t0_, tout);
      else
        std::snprintf(buf, sizeof buf, "%s failed with flag %d at t=%.9f",
                      model_.P.integrator == Integrator::Bdf ? "CVode" : "ERKStepEvolve", flag, tret);
      msg_ = buf;
      return Result::Error;
    }
    {
      const double x_keep = y_[0];
      std::memcpy(y_, N_VGetArrayPointer(y), sizeof y_);
      std::memcpy(impulse_, N_VGetArrayPointer(y) + 10, sizeof impulse_);
      if (mode_ == ContactMode::Flat) {  // the foot is fixed: remove corrector round-off (~1e-25)
        y_[0] = x_keep;
        y_[1] = model_.P.ankle_height;
        y_[2] = y_[5] = y_[6] = y_[7] = 0.0;
      }
    }
    t_ = tret;
    if (flag == 1) {
      int found[kNumRoots] = {};
      if (model_.P.integrator == Integrator::Bdf) CVodeGetRootInfo(solver_, found);
      else ERKStepGetRootInfo(solver_, found);
      accumulate_stats();
      if (handle_roots(tret, found)) {
        evaluate_outputs();
        return Result::Fallen;
      }
      if (++guard > 1000) return msg_ = "too many events in one step (Zeno?)", Result::Error;
      if (!solver_restart()) return msg_ = "integrator restart failed", Result::Error;
      if (t_ >= tout) break;
      continue;
    }
    accumulate_stats();
    t_ = tout;  // exact communication point (tstop)
    break;
  }
  evaluate_outputs();
  return Result::Ok;
}

void Plant::evaluate_outputs() {
  const Params& P = model_.P;
  const Vec5 q = this->q(), qd = this->qd();
  Outputs& o = out_;
  o.t = t_;
  o.theta_ankle = q[3];
  o.theta_hip = q[4];
  o.dtheta_ankle = qd[3];
  o.dtheta_hip = qd[4];
  o.foot_pitch = q[2];
  o.contact_mode = static_cast<int>(mode_);
  o.fallen = fallen_;
  const Vec2 c = model_.com(q);
  o.com_x = c.x() - q[0];
  o.com_z = c.y() - q[1];
  o.energy = model_.kinetic_energy(q, qd) + model_.potential_energy(q);
  model_.joint_torques(q, qd, in_[0], in_[1], o.tau_ankle, o.tau_hip);
  // The ground reaction: its mean over the communication step (the impulse over it divided by its
  // length, what an anti-aliased load-cell converter reads: the servos' position error jumps at
  // each set-point update, so the reaction ripples within the step); before the first step the
  // instantaneous value.
  double Fx = 0, Fz = 0, MA = 0;
  if (step_started_ && t_ > step_t0_) {
    const double h = t_ - step_t0_;
    Fx = (impulse_[0] - step_impulse0_[0]) / h;
    Fz = (impulse_[1] - step_impulse0_[1]) / h;
    MA = (impulse_[2] - step_impulse0_[2]) / h;
  } else if (mode_ != ContactMode::Airborne) {
    const auto d = model_.dynamics(mode_, q, qd, in_[0], in_[1], in_[2], pivot_);
    Fx = d.Qc[0];
    Fz = d.Qc[1];
    MA = d.Qc[2];
  }
  o.fx = Fx;
  o.fz_true = Fz;
  o.moment_ankle = MA;
  o.zmp_true = Fz > 1e-9 ? -(MA + q[1] * Fx) / Fz : 0.0;
  o.required_mu = Fz > 1e-9 ? std::fabs(Fx) / Fz : 0.0;
  // Sole load cells: two vertical (foot-frame normal) cells at the toe and heel edges. The
  // reaction expressed in the foot frame: normal Fn, tangential Ft; CoP s along the sole satisfies
  // MA = -h_a Ft - s Fn. Statics of the sole plate on two supports gives the cell loads.
  const double sp = std::sin(q[2]), cp = std::cos(q[2]);
  const double Fn = Fx * sp + Fz * cp, Ft = Fx * cp - Fz * sp;
  const double ms = -(MA + P.ankle_height * Ft);  // = s Fn
  const double L = P.toe_x - P.heel_x;
  double ft = (ms - Fn * P.heel_x) / L;
  double fh = (Fn * P.toe_x - ms) / L;
  ft += P.sensor_bias_toe;
  fh += P.sensor_bias_heel;
  if (P.sensor_noise > 0) {
    ft += P.sensor_noise * gauss();
    fh += P.sensor_noise * gauss();
  }
  o.f_toe = ft;
  o.f_heel = fh;
  o.fz = ft + fh;
  o.zmp_x = o.fz > P.sensor_fmin ? (ft * P.toe_x + fh * P.heel_x) / o.fz : 0.0;
}

Snapshot Plant::snapshot() const {
  // the original restarts at its next step exactly as a restored copy will: with a new integrator
  restart_ = fresh_solver_ = true;
  Snapshot s;
  s.t = t_;
  std::memcpy(s.y, y_, sizeof y_);
  std::memcpy(s.impulse, impulse_, sizeof impulse_);
  s.mode = static_cast<int>(mode_);
  s.fallen = fallen_ ? 1 : 0;
  s.pivot[0] = pivot_.x();
  s.pivot[1] = pivot_.y();
  s.t_fall = t_fall_;
  std::memcpy(s.inputs, in_, sizeof in_);
  s.rng = rng_;
  s.h_next = h_next_;
  s.stats = stats_;
  s.out = out_;
  return s;
}

bool Plant::restore(const Snapshot& s) {
  if (s.magic != Snapshot{}.magic || s.version != Snapshot{}.version) return false;
  if (s.mode < 0 || s.mode > 3 || s.fallen < 0 || s.fallen > 1 || s.out.contact_mode < 0 || s.out.contact_mode > 3)
    return false;
  if (!std::isfinite(s.t) || !std::isfinite(s.t_fall) || !std::isfinite(s.pivot[0]) || !std::isfinite(s.pivot[1]))
    return false;
  // every value within what a running plant can hold (a forged state must not reach the integrator;
  // finite values far beyond these made the next step's right-hand side fail): the foot within 1 km,
  // angles within 100 rad (the robot falls long before), speeds below 1 km/s and 1e4 rad/s, as the
  // 3D plant's bodies; impulses within 1e12 N s
  for (int i = 0; i < 10; ++i) {
    const double bound = i < 2 ? 1e3 : i < 5 ? 1e2 : i < 7 ? 1e3 : 1e4;
    if (!(std::fabs(s.y[i]) <= bound)) return false;
  }
  for (double x : s.impulse)
    if (!(std::fabs(x) <= 1e12)) return false;
  // the pivot is a ground point (y = 0) that a rocking foot's contact edge holds to within the
  // Baumgarte drift (micrometres): a forged one far from it made the constraint's stabilization,
  // a^2 (edge - pivot), overflow and the next step's right-hand side fail (found by the fuzzer);
  // outside the rocking modes it is the last one's, within 1 km as the foot
  if (!(s.pivot[1] == 0.0 && std::fabs(s.pivot[0]) <= 1e3)) return false;
  if (s.mode == static_cast<int>(ContactMode::Toe) || s.mode == static_cast<int>(ContactMode::Heel)) {
    const Vec5 q = Eigen::Map<const Vec5>(s.y);
    const Vec2 edge = s.mode == static_cast<int>(ContactMode::Toe) ? model_.toe(q) : model_.heel(q);
    if (!((edge - Vec2(s.pivot[0], s.pivot[1])).norm() <= 1e-3)) return false;
  }
  for (double x : s.inputs)
    if (!std::isfinite(x)) return false;
  // ERK's proposed step: 0 (estimate one) or a step that advances the time, at most 1e3 s (forged
  // ones failed the next step: a negative one with "h0 and tout - t0 inconsistent", a denormal one
  // never left t)
  if (!(s.h_next == 0.0 || (s.h_next >= 1e-12 * (1.0 + std::fabs(s.t)) && s.h_next <= 1e3))) return false;
  t_ = s.t;
  std::memcpy(y_, s.y, sizeof y_);
  std::memcpy(impulse_, s.impulse, sizeof impulse_);
  step_started_ = false;
  mode_ = static_cast<ContactMode>(s.mode);
  fallen_ = s.fallen != 0;
  pivot_ = Vec2(s.pivot[0], s.pivot[1]);
  t_fall_ = s.t_fall;
  std::memcpy(in_, s.inputs, sizeof in_);
  rng_ = s.rng;
  h_next_ = s.h_next;
  stats_ = s.stats;
  out_ = s.out;
  restart_ = true;  // the integrator's history is not in the snapshot: the next step restarts
  return ensure_solver();
}

}  // namespace hoap2plant
