// HOAP-2 plant simulator: CVODE (BDF, dense direct solver) integrates y = (q, qd) of the current
// contact mode; root functions locate every mode change; discrete changes re-initialize CVODE.
// CVODE is re-initialized at every communication point too: the inputs are piecewise constant
// (the RHS jumps there anyway), and a restored snapshot then continues bit for bit.
#include "hoap2plant/plant.hpp"

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

int cv_rhs(realtype t, N_Vector y, N_Vector yd, void* ud) {
  return static_cast<Plant*>(ud)->rhs(t, N_VGetArrayPointer(y), N_VGetArrayPointer(yd));
}
int cv_roots(realtype t, N_Vector y, realtype* g, void* ud) {
  return static_cast<Plant*>(ud)->roots(t, N_VGetArrayPointer(y), g);
}
void cv_err(int code, const char* module, const char* function, char* msg, void* ud) {
  auto* p = static_cast<Plant*>(ud);
  if (p->logger) {
    char buf[512];
    std::snprintf(buf, sizeof buf, "CVODE %s/%s (%d): %s", module, function, code, msg);
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

Plant::~Plant() {
  if (cvode_) CVodeFree(&cvode_);
  if (ls_) SUNLinSolFree(static_cast<SUNLinearSolver>(ls_));
  if (mat_) SUNMatDestroy(static_cast<SUNMatrix>(mat_));
  if (nv_) N_VDestroy(static_cast<N_Vector>(nv_));
  if (sunctx_) {
    SUNContext ctx = static_cast<SUNContext>(sunctx_);
    SUNContext_Free(&ctx);
  }
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
  const Vec5 q = Eigen::Map<const Vec5>(y), qd = Eigen::Map<const Vec5>(y + 5);
  const auto d = model_.dynamics(mode_, q, qd, in_[0], in_[1], in_[2], pivot_);
  for (int i = 0; i < 5; ++i) {
    yd[i] = qd[i];
    yd[5 + i] = d.qdd[i];
  }
  if (mode_ == ContactMode::Flat) yd[0] = yd[1] = yd[2] = 0.0;
  for (int i = 0; i < 10; ++i)
    if (!std::isfinite(yd[i])) return 1;  // recoverable: CVODE retries with a smaller step
  return 0;
}

int Plant::roots(double, const double* y, double* g) {
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

void Plant::accumulate_stats() {
  if (!cvode_) return;
  long int n = 0;
  if (CVodeGetNumSteps(cvode_, &n) == CV_SUCCESS) stats_.steps += n;
  if (CVodeGetNumRhsEvals(cvode_, &n) == CV_SUCCESS) stats_.rhs_evals += n;
  if (CVodeGetNumLinRhsEvals(cvode_, &n) == CV_SUCCESS) stats_.rhs_evals += n;
  if (CVodeGetNumGEvals(cvode_, &n) == CV_SUCCESS) stats_.root_evals += n;
}

bool Plant::cvode_reinit() {
  N_Vector y = static_cast<N_Vector>(nv_);
  std::memcpy(N_VGetArrayPointer(y), y_, sizeof y_);
  if (CVodeReInit(cvode_, t_, y) != CV_SUCCESS) return false;
  int dir[kNumRoots] = {-1, -1, -1, -1, -1};
  if (mode_ == ContactMode::Heel) dir[0] = +1;
  if (CVodeSetRootDirection(cvode_, dir) != CV_SUCCESS) return false;
  ++stats_.reinits;
  return true;
}

void Plant::set_mode(ContactMode m, const char* why) {
  if (m == mode_) return;
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

bool Plant::ensure_cvode() {
  const Params& P = model_.P;
  if (!cvode_) {
    SUNContext ctx = nullptr;
    if (SUNContext_Create(nullptr, &ctx) != 0) return msg_ = "SUNContext_Create failed", false;
    sunctx_ = ctx;
    N_Vector y = N_VNew_Serial(10, ctx);
    nv_ = y;
    std::memcpy(N_VGetArrayPointer(y), y_, sizeof y_);
    cvode_ = CVodeCreate(CV_BDF, ctx);
    if (!cvode_) return msg_ = "CVodeCreate failed", false;
    CVodeSetErrHandlerFn(cvode_, cv_err, this);
    if (CVodeInit(cvode_, cv_rhs, t_, y) != CV_SUCCESS) return msg_ = "CVodeInit failed", false;
    SUNMatrix A = SUNDenseMatrix(10, 10, ctx);
    mat_ = A;
    SUNLinearSolver LS = SUNLinSol_Dense(y, A, ctx);
    ls_ = LS;
    CVodeSetLinearSolver(cvode_, LS, A);
    CVodeSetUserData(cvode_, this);
    CVodeRootInit(cvode_, kNumRoots, cv_roots);
    CVodeSetNoInactiveRootWarn(cvode_);
    CVodeSetMaxNumSteps(cvode_, 100000);
  }
  if (CVodeSStolerances(cvode_, P.rtol, P.atol) != CV_SUCCESS)
    return msg_ = "bad tolerances", false;
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
  if (!ensure_cvode()) return false;
  resolve_mode("initial state");
  evaluate_outputs();
  return true;
}

void Plant::set_inputs(double a, double b, double push) {
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
      for (int i = 0; i < 5; ++i) y_[5 + i] = qd2[i];
      ++stats_.impacts;
      set_mode(m, "edge touched down (plastic impact)");
      break;
    }
  }
  resolve_mode("after event");
  return false;
}

Plant::Result Plant::do_step(double h) {
  if (fallen_) return Result::Fallen;
  if (!cvode_) return msg_ = "not initialized", Result::Error;
  for (double v : in_)
    if (!std::isfinite(v)) return msg_ = "non-finite input", Result::Error;
  const double tout = t_ + h;
  resolve_mode("inputs changed");
  if (!cvode_reinit()) return msg_ = "CVodeReInit failed", Result::Error;
  N_Vector y = static_cast<N_Vector>(nv_);
  int guard = 0;
  while (true) {
    CVodeSetStopTime(cvode_, tout);
    realtype tret = t_;
    const int flag = CVode(cvode_, tout, y, &tret, CV_NORMAL);
    if (flag < 0) {
      accumulate_stats();
      char buf[120];
      std::snprintf(buf, sizeof buf, "CVode failed with flag %d at t=%.9f", flag, tret);
      msg_ = buf;
      return Result::Error;
    }
    {
      const double x_keep = y_[0];
      std::memcpy(y_, N_VGetArrayPointer(y), sizeof y_);
      if (mode_ == ContactMode::Flat) {  // the foot is fixed: remove corrector round-off (~1e-25)
        y_[0] = x_keep;
        y_[1] = model_.P.ankle_height;
        y_[2] = y_[5] = y_[6] = y_[7] = 0.0;
      }
    }
    t_ = tret;
    if (flag == CV_ROOT_RETURN) {
      int found[kNumRoots] = {};
      CVodeGetRootInfo(cvode_, found);
      accumulate_stats();
      if (handle_roots(tret, found)) {
        evaluate_outputs();
        return Result::Fallen;
      }
      if (++guard > 1000) return msg_ = "too many events in one step (Zeno?)", Result::Error;
      if (!cvode_reinit()) return msg_ = "CVodeReInit failed", Result::Error;
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
  double Fx = 0, Fz = 0, MA = 0;
  if (mode_ != ContactMode::Airborne) {
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
  Snapshot s;
  s.t = t_;
  std::memcpy(s.y, y_, sizeof y_);
  s.mode = static_cast<int>(mode_);
  s.fallen = fallen_ ? 1 : 0;
  s.pivot[0] = pivot_.x();
  s.pivot[1] = pivot_.y();
  s.t_fall = t_fall_;
  std::memcpy(s.inputs, in_, sizeof in_);
  s.rng = rng_;
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
  for (double x : s.y)
    if (!std::isfinite(x)) return false;
  for (double x : s.inputs)
    if (!std::isfinite(x)) return false;
  t_ = s.t;
  std::memcpy(y_, s.y, sizeof y_);
  mode_ = static_cast<ContactMode>(s.mode);
  fallen_ = s.fallen != 0;
  pivot_ = Vec2(s.pivot[0], s.pivot[1]);
  t_fall_ = s.t_fall;
  std::memcpy(in_, s.inputs, sizeof in_);
  rng_ = s.rng;
  stats_ = s.stats;
  out_ = s.out;
  // CVODE is re-initialized at the start of every step, so nothing else to restore.
  return ensure_cvode();
}

}  // namespace hoap2plant
