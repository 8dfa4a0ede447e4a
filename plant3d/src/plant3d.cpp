// The 3D HOAP-2 on ODE (see plant3d.hpp and docs/plant3d.md).
//
// Model assembly: the proto bodies (hoap2/bodies.h, generated from the proto data) are merged into
// 7 ODE bodies (mass, CoM and inertia combined exactly): the trunk (torso, waist, arms, neck, head:
// joints held at their posture angle) and per leg the thigh (the two hip links, point masses at the
// hip's centre, and the thigh link), the shank, and the foot (ankle link, foot link, sole sensor).
// The joints are a ball at the hip (the yaw, pitch and roll axes meet), a hinge at the knee and a
// universal joint at the ankle (pitch and roll axes meet): 12 joint coordinates, 24 constraint rows
// instead of 60 for twelve hinges between 13 bodies. ODE's dWorldStep factorises a dense matrix
// of all rows, so that is the plant's cost (docs/plant3d.md, "Speed").
// ODE keeps a body's origin at its CoM, so each body is placed at its combined CoM.
//
// Joint coordinates are computed here from the bodies' rotations (Z-Y-X at the hip, Y-X at the
// ankle, the proto's chain order), and so are their rates: qdot_i = n_i . (w_child - w_parent)
// with n_i the dual basis of the joint axes.
//
// Servos: one angular motor row per joint coordinate (an AMotor in user mode along n_i, rescaled
// to ODE's unit axis). The row drives qdot to a target with a force limit and a constraint-force-
// mixing softness; with target = kd wcmd / (kd + d) and CFM = 1 / (kd + d) the motor torque is
// kd (wcmd - qdot) - d qdot at the end of the step, i.e. the sagittal plant's PD servo with its
// velocity loop integrated implicitly (stable whatever the link inertia).
//
// Contacts: box-plane corner contacts, soft normal (ERP/CFM of a spring-damper per corner, ODE
// manual "Soft constraint and constraint force mixing") and the friction pyramid (dContactApprox1)
// with its axes along the foot.
#include "hoap2plant3d/plant3d.hpp"

#include <ode/ode.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <stdexcept>

#include "hoap2/bodies.h"
#include "hoap2/nominal.h"
#include "hoap2/servo.h"

namespace hoap2plant3d {

static_assert(sizeof(dReal) == sizeof(double), "ODE must be built in double precision");

namespace {

// M_PI is POSIX, not ISO C++ (MinGW has none); the same literal as glibc's, so the same double.
constexpr double kPi = 3.14159265358979323846;

constexpr int kMaxContacts = 8;  // per foot (box-plane gives at most 4)
// A corner whose normal force is below this fraction of the weight may lift in the next step: the
// step after starts with the contacts' inequality rows (Plant3D::within_limits).
constexpr double kNearLift = 1e-3;
// A free foot on four corners is held once no corner moves faster than this [m/s].
constexpr double kWeldSpeed = 1e-4;

// --- ODE's process-wide state: held while any Plant3D exists -----------------------------------
// dInitODE2 allocates ODE's default threading implementation and dCloseODE frees it together with
// the geometry position cache (the last destroyed geom's dxPosR): 176 bytes that a binary which
// initialised ODE once and never closed it lost at every unload (docs/reliability.md). The first
// Plant3D (World) initialises ODE, the last one destroyed closes it, counted under a mutex because
// instances live in any thread (dInitODE2 / dCloseODE are not thread-safe and ODE is static inside
// each binary, so this count is every ODE user of the binary). ODE is built without thread-local
// data (ODE_WITH_OU=OFF, cmake/OdeFromDebianSource.cmake; the CTest plant3d.ode_lifetime
// checks it): no thread holds anything of ODE, so an instance may be created, stepped and freed
// from different threads and the last one may close ODE on any of them.
[[noreturn]] void ode_throw(int num, const char* msg, va_list ap) {
  char buf[512];
  std::vsnprintf(buf, sizeof buf, msg, ap);
  throw std::runtime_error(std::string("ODE error ") + std::to_string(num) + ": " + buf);
}
thread_local std::function<void(const std::string&)>* tl_logger = nullptr;
void ode_message(int num, const char* msg, va_list ap) {
  char buf[512];
  std::vsnprintf(buf, sizeof buf, msg, ap);
  if (tl_logger && *tl_logger) (*tl_logger)(std::string("ODE message ") + std::to_string(num) + ": " + buf);
}
std::mutex ode_mutex;
int ode_users = 0;  // guarded by ode_mutex

}  // namespace

OdeUse::OdeUse() {
  std::lock_guard<std::mutex> lock(ode_mutex);
  if (ode_users == 0) {
    if (!dInitODE2(0)) throw std::runtime_error("ODE: dInitODE2 failed");
    // ODE's default error and debug handlers print and abort the process: ours throw, and the
    // FMU turns that into fmi2Error.
    dSetErrorHandler(ode_throw);
    dSetDebugHandler(ode_throw);
    dSetMessageHandler(ode_message);
  }
  ++ode_users;
}

OdeUse::~OdeUse() {
  std::lock_guard<std::mutex> lock(ode_mutex);
  if (--ode_users == 0) dCloseODE();
}

int OdeUse::users() {
  std::lock_guard<std::mutex> lock(ode_mutex);
  return ode_users;
}

namespace {

// Proto motor name -> (side, leg joint); false for joints that are not leg joints.
bool leg_joint(const char* motor, int& side, int& kind) {
  static const int kByNumber[7] = {-1, HipYaw, HipRoll, HipPitch, Knee, AnklePitch, AnkleRoll};
  int n = 0;
  if (std::sscanf(motor, "lleg_joint_%d", &n) == 1) side = Left;
  else if (std::sscanf(motor, "rleg_joint_%d", &n) == 1) side = Right;
  else return false;
  if (n < 1 || n > 6) return false;
  kind = kByNumber[n];
  return true;
}

// The pitch joints whose sense is the sagittal plant's (trunk side relative to the foot side)
// rather than the proto's (child relative to parent).
bool sagittal_sense(int kind) { return kind == HipPitch || kind == AnklePitch; }

int body_index(int side, int leg_body) { return 1 + side * kLegBodies + leg_body; }
// The ODE body a leg joint's proto body belongs to.
int leg_body_of(int kind) { return kind <= HipRoll ? Thigh : kind == Knee ? Shank : Foot; }

// The joints of a leg grouped by where their axes meet: hip (ball), knee (hinge), ankle (universal).
enum Group : int { HipGroup = 0, KneeGroup, AnkleGroup, kGroups };
constexpr int kGroupFirst[kGroups] = {HipYaw, Knee, AnklePitch};
constexpr int kGroupCount[kGroups] = {3, 1, 2};
// The axis of each joint in the zero posture, in chain order: hip z, y, x; knee y; ankle y, x.
constexpr int kCanonicalAxis[kLegJoints] = {2, 1, 0, 1, 1, 0};
int group_of(int kind) { return kind <= HipRoll ? HipGroup : kind == Knee ? KneeGroup : AnkleGroup; }
int group_parent(int side, int g) { return g == HipGroup ? 0 : body_index(side, g == KneeGroup ? Thigh : Shank); }
int group_child(int side, int g) { return body_index(side, g == HipGroup ? Thigh : g == KneeGroup ? Shank : Foot); }

void cross(const double a[3], const double b[3], double c[3]) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}
double dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
void mat_vec(const double* R, const double* v, double* out) {  // R 3x4 row-major
  for (int r = 0; r < 3; ++r) out[r] = R[r * 4] * v[0] + R[r * 4 + 1] * v[1] + R[r * 4 + 2] * v[2];
}
void mat_t_vec(const double* R, const double* v, double* out) {
  for (int c = 0; c < 3; ++c) out[c] = R[c] * v[0] + R[4 + c] * v[1] + R[8 + c] * v[2];
}

struct Mass {  // accumulated about the world origin
  double m = 0, first[3] = {0, 0, 0}, second[6] = {0, 0, 0, 0, 0, 0};  // I about the origin
  void add(const hoap2_body& b, const double off[3]) {
    const double c[3] = {b.com[0] + off[0], b.com[1] + off[1], b.com[2] + off[2]};
    m += b.mass;
    for (int i = 0; i < 3; ++i) first[i] += b.mass * c[i];
    // I_origin = I_com + m (|c|^2 E - c c^T)
    const double cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    second[0] += b.inertia[0] + b.mass * (cc - c[0] * c[0]);
    second[1] += b.inertia[1] + b.mass * (cc - c[1] * c[1]);
    second[2] += b.inertia[2] + b.mass * (cc - c[2] * c[2]);
    second[3] += b.inertia[3] - b.mass * c[0] * c[1];
    second[4] += b.inertia[4] - b.mass * c[0] * c[2];
    second[5] += b.inertia[5] - b.mass * c[1] * c[2];
  }
  void com(double c[3]) const {
    for (int i = 0; i < 3; ++i) c[i] = first[i] / m;
  }
  void inertia_about_com(double I[6]) const {
    double c[3];
    com(c);
    const double cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    I[0] = second[0] - m * (cc - c[0] * c[0]);
    I[1] = second[1] - m * (cc - c[1] * c[1]);
    I[2] = second[2] - m * (cc - c[2] * c[2]);
    I[3] = second[3] + m * c[0] * c[1];
    I[4] = second[4] + m * c[0] * c[2];
    I[5] = second[5] + m * c[1] * c[2];
  }
};

std::string body_name(int i) {
  if (i == 0) return "trunk";
  static const char* kLegBodyNames[kLegBodies] = {"thigh", "shank", "foot"};
  const int side = (i - 1) / kLegBodies;
  return std::string(side == Left ? "left_" : "right_") + kLegBodyNames[(i - 1) % kLegBodies];
}

void rot_y(double a, double R[9]) {
  const double c = std::cos(a), s = std::sin(a);
  const double r[9] = {c, 0, s, 0, 1, 0, -s, 0, c};
  std::memcpy(R, r, sizeof r);
}

}  // namespace

const char* joint_name(int j) {
  static const char* kNames[kLegJoints] = {"hip_yaw", "hip", "hip_roll", "knee", "ankle", "ankle_roll"};
  return j >= 0 && j < kLegJoints ? kNames[j] : "?";
}

double Params::mass() const {
  double m = 0;
  for (int i = 0; i < HOAP2_NUM_BODIES; ++i) m += HOAP2_BODIES[i].mass;
  return m;
}

double critical_contact_damping(double k) {
  // Eight corners at x_i = +-a from the sole centre give the pitch mode a stiffness K = 8 k a^2 and
  // a damping 8 c a^2; critical: 8 c a^2 = 2 sqrt(K J), so c = sqrt(k J / 2) / a. J: every proto
  // body in the standing posture, about the y axis through the soles' centre on the ground.
  double ankle_x = 0;
  for (const hoap2_body& b : HOAP2_BODIES)
    if (std::strcmp(b.joint, "lleg_joint_5") == 0) ankle_x = b.anchor[0];
  const double xs = ankle_x + 0.5 * (HOAP2_TOE_X + HOAP2_HEEL_X), zs = -HOAP2_ROBOT_ORIGIN_HEIGHT;
  double J = 0;
  for (const hoap2_body& b : HOAP2_BODIES) {
    const double dx = b.com[0] - xs, dz = b.com[2] - zs;
    J += b.inertia[1] + b.mass * (dx * dx + dz * dz);
  }
  const double a = 0.5 * (HOAP2_TOE_X - HOAP2_HEEL_X);
  return std::sqrt(k * J / 2.0) / a;
}

Params default_params() {
  Params p;
  p.g = HOAP2_G;
  p.contact_damping = critical_contact_damping(p.contact_stiffness);
  // pitch joints: Hoap2Plant's defaults (both legs together); the others as stiff as the ankle
  p.servo[AnklePitch] = {400.0, 20.0, 18.0, 5.0, 0.0};
  p.servo[HipPitch] = {150.0, 5.0, 18.0, 5.0, 0.0};
  p.servo[Knee] = {400.0, 20.0, 18.0, 5.0, 0.0};
  p.servo[AnkleRoll] = {400.0, 20.0, 18.0, 5.0, 0.0};
  p.servo[HipRoll] = {400.0, 20.0, 18.0, 5.0, 0.0};
  p.servo[HipYaw] = {400.0, 20.0, 18.0, 5.0, 0.0};
  return p;
}

// The ground reaction the outputs are made of, in world coordinates: the force, the first moments
// of its components about the world axes (for the centre of pressure and the ankle moment), and the
// sole-normal force of each load cell. Linear in the contact forces, so it can be averaged.
struct GroundReaction {
  double F[3] = {0, 0, 0};
  double fz_p[2] = {0, 0};     // sum of f_z p_x, f_z p_y
  double pz_f[2] = {0, 0};     // sum of p_z f_x, p_z f_y
  double cells[kLegs][kCells] = {};
  void add(const GroundReaction& g, double w) {
    for (int c = 0; c < 3; ++c) F[c] += w * g.F[c];
    for (int c = 0; c < 2; ++c) {
      fz_p[c] += w * g.fz_p[c];
      pz_f[c] += w * g.pz_f[c];
    }
    for (int s = 0; s < kLegs; ++s)
      for (int c = 0; c < kCells; ++c) cells[s][c] += w * g.cells[s][c];
  }
};

struct Plant3D::World {
  OdeUse ode;  // first member, so released last: after ~World has destroyed the ODE objects
  dWorldID world = nullptr;
  dThreadingImplementationID threading = nullptr;  // this world's own (ODE's default one is shared)
  dGeomID ground = nullptr;
  dGeomID foot_geom[kLegs] = {};
  dJointGroupID contact_group = nullptr;
  dBodyID body[kBodies] = {};
  dJointID link[kLegs][kGroups] = {};   // ball (hip), hinge (knee), universal (ankle)
  dJointID motor[kLegs][kGroups] = {};  // the servos: an AMotor in user mode, a row per joint
  double sense[kLegs][kLegJoints] = {}; // this model's joint coordinate = sense * canonical angle
  BodyInfo info[kBodies];
  JointInfo jinfo[kLegs][kLegJoints];
  // joint kinematics (refresh_kinematics): coordinates, rates, world axes (proto's sense) and the
  // dual vectors n (qdot = n . (w_child - w_parent)), all in this model's sense
  double q[kLegs][kLegJoints] = {}, qd[kLegs][kLegJoints] = {};
  double axis[kLegs][kLegJoints][3] = {}, dual[kLegs][kLegJoints][3] = {};
  // the servo law of the last step, in joint coordinates (tau read-back)
  double servo_vel[kLegs][kLegJoints] = {}, servo_gain[kLegs][kLegJoints] = {}, servo_fmax[kLegs][kLegJoints] = {};
  bool kinematics_fresh = false;  // q, qd, axis, dual are those of the bodies' current state
  double sole_corner[kLegs][kCells][3] = {};  // foot body frame, on the sole
  double sole_center[kLegs][3] = {};          // foot body frame
  double sole_len = 0, sole_width = 0, heel_x = 0;  // sole rectangle, x from the ankle axis
  double push_point[3] = {};                  // trunk body frame
  // last ODE step
  int ncontact[kLegs] = {};
  dContactGeom cg[kLegs][kMaxContacts];
  dJointFeedback fb[kLegs][kMaxContacts];        // the force of each corner contact on its foot
  dJointFeedback fb_row[kLegs][kMaxContacts][3];  // equality rows (make_contacts): normal, 2 tangents
  bool contact_rows = false;                      // the last step's contacts were equality rows
  bool welded[kLegs] = {};                         // the foot is held (an ODE kinematic body)
  unsigned broken_welds = 0;                       // the held feet the last WeldBroken step released
  dJointFeedback ankle_fb[kLegs][2];               // ankle joint and ankle servos: on the foot
  double fdir[kLegs][2] = {};                 // first friction direction of each foot's contacts
  double tau[kLegs][kLegJoints] = {};
  double max_depth = 0;
  // the ground reaction averaged over the ODE steps of the current communication step (the
  // impulse over it divided by its length): what the load cells and force outputs report
  GroundReaction reaction_sum;
  double reaction_time = 0;

  ~World() {
    if (contact_group) dJointGroupDestroy(contact_group);
    for (dGeomID g : foot_geom)
      if (g) dGeomDestroy(g);
    if (ground) dGeomDestroy(ground);
    if (world) dWorldDestroy(world);  // destroys bodies and joints
    if (threading) dThreadingFreeImplementation(threading);
  }
};

namespace {
// Joint coordinates, rates, world axes and dual vectors of both legs from the bodies' state.
void refresh_kinematics(Plant3D::World& w) {
  auto column = [](const double* Rb, int c, double out[3]) {  // ODE rotations: 3x4, row-major
    for (int r = 0; r < 3; ++r) out[r] = Rb[r * 4 + c];
  };
  for (int s = 0; s < kLegs; ++s) {
    for (int g = 0; g < kGroups; ++g) {
      const dBodyID bp = w.body[group_parent(s, g)], bc = w.body[group_child(s, g)];
      const double* Rp = dBodyGetRotation(bp);
      const double* Rc = dBodyGetRotation(bc);
      double R[3][3];  // the child's rotation relative to the parent: Rp^T Rc
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) R[r][c] = Rp[r] * Rc[c] + Rp[4 + r] * Rc[4 + c] + Rp[8 + r] * Rc[8 + c];
      double angle[3] = {}, e[3][3] = {};  // chain-order angles about the canonical axes; world axes
      if (g == HipGroup) {  // R = Rz(yaw) Ry(pitch) Rx(roll)
        angle[0] = std::atan2(R[1][0], R[0][0]);
        angle[1] = std::asin(std::clamp(-R[2][0], -1.0, 1.0));
        angle[2] = std::atan2(R[2][1], R[2][2]);
        column(Rp, 2, e[0]);
        const double c = std::cos(angle[0]), sn = std::sin(angle[0]);
        for (int r = 0; r < 3; ++r) e[1][r] = -sn * Rp[r * 4] + c * Rp[r * 4 + 1];  // Rp Rz(yaw) y
        column(Rc, 0, e[2]);
      } else if (g == KneeGroup) {  // R = Ry(q)
        angle[0] = std::atan2(R[0][2], R[0][0]);
        column(Rp, 1, e[0]);
      } else {  // R = Ry(pitch) Rx(roll)
        angle[0] = std::atan2(-R[2][0], R[0][0]);
        angle[1] = std::atan2(-R[1][2], R[1][1]);
        column(Rp, 1, e[0]);
        column(Rc, 0, e[1]);
      }
      // w_child - w_parent = sum_i qdot_i e_i; the dual basis n_i (n_i . e_j = delta_ij) reads
      // the rates. A knee has one axis; the ankle's two stay perpendicular (universal joint).
      double n[3][3];
      const int count = kGroupCount[g];
      if (count == 3) {
        cross(e[1], e[2], n[0]);
        cross(e[2], e[0], n[1]);
        cross(e[0], e[1], n[2]);
        const double det = dot(e[0], n[0]);  // cos(hip pitch): the ball's Euler singularity at 90 deg
        for (auto& v : n)
          for (double& x : v) x /= det;
      } else {
        std::memcpy(n, e, sizeof n);
      }
      const double* wp = dBodyGetAngularVel(bp);
      const double* wc = dBodyGetAngularVel(bc);
      const double wrel[3] = {wc[0] - wp[0], wc[1] - wp[1], wc[2] - wp[2]};
      for (int i = 0; i < count; ++i) {
        const int k = kGroupFirst[g] + i;
        const double sg = w.sense[s][k], proto_sign = sagittal_sense(k) ? -sg : sg;
        w.q[s][k] = sg * angle[i];
        for (int r = 0; r < 3; ++r) {
          w.dual[s][k][r] = sg * n[i][r];
          w.axis[s][k][r] = proto_sign * e[i][r];
        }
        w.qd[s][k] = dot(w.dual[s][k], wrel);
      }
    }
  }
  w.kinematics_fresh = true;
}

// The last ODE step's ground reaction from its contacts (for a held foot: weld_reactions' corner
// forces); the cells share each contact force's sole-normal component bilinearly by where it acts
// on the sole (exact for corner contacts; the cells' centre of pressure is the contacts').
GroundReaction step_reaction(const Plant3D::World& w) {
  GroundReaction g;
  for (int s = 0; s < kLegs; ++s) {
    const dBodyID foot = w.body[body_index(s, Foot)];
    const double* R = dBodyGetRotation(foot);
    const double* fp = dBodyGetPosition(foot);
    const double nz[3] = {R[2], R[6], R[10]};  // the sole's normal
    for (int i = 0; i < w.ncontact[s]; ++i) {
      const double* f = w.fb[s][i].f1;
      const double* p = w.cg[s][i].pos;
      for (int c = 0; c < 3; ++c) g.F[c] += f[c];
      for (int c = 0; c < 2; ++c) {
        g.fz_p[c] += f[2] * p[c];
        g.pz_f[c] += p[2] * f[c];
      }
      const double d[3] = {p[0] - fp[0], p[1] - fp[1], p[2] - fp[2]};
      double local[3];
      mat_t_vec(R, d, local);
      const double u = std::clamp((local[0] - w.sole_corner[s][RearLeft][0]) / w.sole_len, 0.0, 1.0);
      const double v = std::clamp((local[1] - w.sole_corner[s][FrontRight][1]) / w.sole_width, 0.0, 1.0);
      const double fn = f[0] * nz[0] + f[1] * nz[1] + f[2] * nz[2];
      g.cells[s][FrontLeft] += fn * u * v;
      g.cells[s][FrontRight] += fn * u * (1 - v);
      g.cells[s][RearLeft] += fn * (1 - u) * v;
      g.cells[s][RearRight] += fn * (1 - u) * (1 - v);
    }
  }
  return g;
}

void group_anchor(const Plant3D::World& w, int s, int g, double a[3]) {
  dVector3 v;
  const dJointID j = w.link[s][g];
  if (g == HipGroup) dJointGetBallAnchor(j, v);
  else if (g == KneeGroup) dJointGetHingeAnchor(j, v);
  else dJointGetUniversalAnchor(j, v);
  std::copy(v, v + 3, a);
}
}  // namespace

Plant3D::Plant3D(const Params& p) : P_(p), w_(std::make_unique<World>()) {
  World& w = *w_;
  w.world = dWorldCreate();
  // Without its own threading implementation a world uses ODE's process-wide default one, whose
  // job list is not synchronised: worlds stepped in parallel threads crash (measured: 20 of 20).
  w.threading = dThreadingAllocateSelfThreadedImplementation();
  dWorldSetStepThreadingImplementation(w.world, dThreadingImplementationGetFunctions(w.threading), w.threading);
  dWorldSetGravity(w.world, 0, 0, -P_.g);
  dWorldSetERP(w.world, 0.2);
  dWorldSetCFM(w.world, 1e-10);            // joints practically rigid
  dWorldSetContactSurfaceLayer(w.world, 0);
  dWorldSetAutoDisableFlag(w.world, 0);

  // 1. Which ODE body each proto body belongs to, and the combined mass of each.
  const double off[3] = {0, 0, HOAP2_ROBOT_ORIGIN_HEIGHT};  // Robot frame -> world (sole on z = 0)
  int owner[HOAP2_NUM_BODIES];
  Mass mass[kBodies];
  const hoap2_body* joint_of[kLegs][kLegJoints] = {};
  for (int i = 0; i < HOAP2_NUM_BODIES; ++i) {
    const hoap2_body& b = HOAP2_BODIES[i];
    int parent = -1;
    for (int k = 0; k < i; ++k)
      if (std::strcmp(HOAP2_BODIES[k].name, b.parent) == 0) parent = k;
    int side = 0, kind = 0;
    if (parent < 0) {
      owner[i] = 0;
    } else if (leg_joint(b.joint, side, kind)) {
      if (b.angle != 0.0) throw std::logic_error("leg joints must be at 0 in the posture");
      owner[i] = body_index(side, leg_body_of(kind));
      joint_of[side][kind] = &b;
    } else {
      owner[i] = owner[parent];
    }
    mass[owner[i]].add(b, off);
    BodyInfo& info = w.info[owner[i]];
    info.proto += (info.proto.empty() ? "" : ",") + std::string(b.name);
  }

  // 2. The bodies, at their CoM, unrotated (all leg joints at zero).
  for (int i = 0; i < kBodies; ++i) {
    BodyInfo& info = w.info[i];
    info.name = body_name(i);
    info.mass = mass[i].m;
    mass[i].com(info.com);
    mass[i].inertia_about_com(info.inertia);
    dMass m;
    dMassSetParameters(&m, info.mass, 0, 0, 0, info.inertia[0], info.inertia[1], info.inertia[2], info.inertia[3],
                       info.inertia[4], info.inertia[5]);
    w.body[i] = dBodyCreate(w.world);
    dBodySetMass(w.body[i], &m);
    dBodySetPosition(w.body[i], info.com[0], info.com[1], info.com[2]);
  }

  // 3. Per leg the ball, hinge and universal joints at the proto's anchors, and the servo motors.
  for (int s = 0; s < kLegs; ++s) {
    for (int k = 0; k < kLegJoints; ++k) {
      const hoap2_body* b = joint_of[s][k];
      if (!b) throw std::logic_error("a leg joint is missing from hoap2/bodies.h");
      const int ca = kCanonicalAxis[k];
      const double sign = b->axis[ca];
      if (std::fabs(std::fabs(sign) - 1.0) > 1e-12 || std::fabs(b->axis[(ca + 1) % 3]) > 1e-12 ||
          std::fabs(b->axis[(ca + 2) % 3]) > 1e-12)
        throw std::logic_error(std::string("unexpected axis of ") + b->joint);
      w.sense[s][k] = (sagittal_sense(k) ? -1.0 : 1.0) * sign;
      const hoap2_body* first = joint_of[s][kGroupFirst[group_of(k)]];
      for (int c = 0; c < 3; ++c)
        if (std::fabs(b->anchor[c] - first->anchor[c]) > 1e-12)
          throw std::logic_error(std::string("the axes of ") + first->joint + " and " + b->joint + " do not meet");
    }
    for (int g = 0; g < kGroups; ++g) {
      const hoap2_body* b = joint_of[s][kGroupFirst[g]];
      const double a[3] = {b->anchor[0] + off[0], b->anchor[1] + off[1], b->anchor[2] + off[2]};
      const dBodyID parent = w.body[group_parent(s, g)], child = w.body[group_child(s, g)];
      dJointID j = nullptr;
      if (g == HipGroup) {
        j = dJointCreateBall(w.world, nullptr);
        dJointAttach(j, parent, child);
        dJointSetBallAnchor(j, a[0], a[1], a[2]);
      } else if (g == KneeGroup) {
        j = dJointCreateHinge(w.world, nullptr);
        dJointAttach(j, parent, child);
        dJointSetHingeAnchor(j, a[0], a[1], a[2]);
        dJointSetHingeAxis(j, 0, 1, 0);
      } else {
        j = dJointCreateUniversal(w.world, nullptr);
        dJointAttach(j, parent, child);
        dJointSetUniversalAnchor(j, a[0], a[1], a[2]);
        // ODE recomputes the joint's reference rotations from both axes at every axis change, and
        // with parallel axes leaves its rotation matrix unset and reads it (dRFrom2Axes; Valgrind).
        // The defaults are axis 1 = +x, axis 2 = +y: axis 2 goes to +z first, so that no step is
        // parallel; the last call computes the rotations from the final axes, as before.
        dJointSetUniversalAxis2(j, 0, 0, 1);
        dJointSetUniversalAxis1(j, 0, 1, 0);  // pitch, on the shank
        dJointSetUniversalAxis2(j, 1, 0, 0);  // roll, on the foot
      }
      w.link[s][g] = j;
      if (g == AnkleGroup) dJointSetFeedback(j, &w.ankle_fb[s][0]);
      // The servos: a separate motor joint rather than the joints' own motors keeps the joints'
      // rows unbounded, which ODE's LCP factorises at once (ODE step.cpp, Stage0_Joints).
      const dJointID m = dJointCreateAMotor(w.world, nullptr);
      dJointAttach(m, parent, child);
      dJointSetAMotorMode(m, dAMotorUser);
      dJointSetAMotorNumAxes(m, kGroupCount[g]);
      w.motor[s][g] = m;
      if (g == AnkleGroup) dJointSetFeedback(m, &w.ankle_fb[s][1]);
      for (int i = 0; i < kGroupCount[g]; ++i) {
        const int k = kGroupFirst[g] + i;
        const hoap2_body* jb = joint_of[s][k];
        JointInfo& ji = w.jinfo[s][k];
        ji.name = std::string(s == Left ? "left_" : "right_") + joint_name(k);
        ji.proto = jb->joint;
        std::copy(a, a + 3, ji.anchor);
        std::copy(jb->axis, jb->axis + 3, ji.axis);
        const bool sag = sagittal_sense(k);
        ji.lo = sag ? -jb->max : jb->min;
        ji.hi = sag ? -jb->min : jb->max;
        dJointSetAMotorAxis(m, i, 0, ji.axis[0], ji.axis[1], ji.axis[2]);  // set each step
        dJointSetAMotorParam(m, dParamLoStop + dParamGroup * i, ji.lo);
        dJointSetAMotorParam(m, dParamHiStop + dParamGroup * i, ji.hi);
      }
    }
  }

  // 4. Soles: a box under each foot, its bottom ankle_height below the ankle axis, toe_x / heel_x
  //    from it (the sagittal plant's numbers); the load cells at the corners.
  const double thick = 0.02;
  w.heel_x = HOAP2_HEEL_X;
  w.sole_len = HOAP2_TOE_X - HOAP2_HEEL_X;
  w.sole_width = HOAP2_SOLE_WIDTH;
  w.ground = dCreatePlane(nullptr, 0, 0, 1, 0);
  for (int s = 0; s < kLegs; ++s) {
    const dBodyID foot = w.body[body_index(s, Foot)];
    const double* ankle = w.jinfo[s][AnklePitch].anchor;
    const double* fp = dBodyGetPosition(foot);
    const double cx = ankle[0] + 0.5 * (HOAP2_TOE_X + HOAP2_HEEL_X), cy = ankle[1],
                 sole_z = ankle[2] - HOAP2_ANKLE_HEIGHT;
    w.foot_geom[s] = dCreateBox(nullptr, w.sole_len, w.sole_width, thick);
    dGeomSetBody(w.foot_geom[s], foot);
    dGeomSetOffsetWorldPosition(w.foot_geom[s], cx, cy, sole_z + 0.5 * thick);
    const double xs[kCells] = {HOAP2_TOE_X, HOAP2_TOE_X, HOAP2_HEEL_X, HOAP2_HEEL_X};
    const double ys[kCells] = {0.5 * w.sole_width, -0.5 * w.sole_width, 0.5 * w.sole_width, -0.5 * w.sole_width};
    for (int c = 0; c < kCells; ++c) {
      w.sole_corner[s][c][0] = ankle[0] + xs[c] - fp[0];
      w.sole_corner[s][c][1] = cy + ys[c] - fp[1];
      w.sole_corner[s][c][2] = sole_z - fp[2];
    }
    w.sole_center[s][0] = cx - fp[0];
    w.sole_center[s][1] = cy - fp[1];
    w.sole_center[s][2] = sole_z - fp[2];
  }
  w.contact_group = dJointGroupCreate(0);

  // 5. The push point: on the trunk, h_push above the sole, above the middle of the hip axes.
  const double* trunk = dBodyGetPosition(w.body[0]);
  const double* hl = w.jinfo[Left][HipPitch].anchor;
  const double* hr = w.jinfo[Right][HipPitch].anchor;
  w.push_point[0] = 0.5 * (hl[0] + hr[0]) - trunk[0];
  w.push_point[1] = 0.5 * (hl[1] + hr[1]) - trunk[1];
  w.push_point[2] = P_.h_push - trunk[2];

  rng_ = P_.seed;
  evaluate_outputs();
}

Plant3D::~Plant3D() = default;

bool Plant3D::initialize(double t0) {
  World& w = *w_;
  // Posture: everything above the ankles turns about the ankle axis by theta_ankle_init, then
  // everything above the hips about the hip axis by theta_hip_init (both about +y).
  auto turn = [&](bool (*moves)(int), const double pivot[3], double angle) {
    double R[9];
    rot_y(angle, R);
    for (int i = 0; i < kBodies; ++i) {
      if (!moves(i)) continue;
      const double* p = dBodyGetPosition(w.body[i]);
      const double* Rb = dBodyGetRotation(w.body[i]);  // 3x4, row-major
      const double d[3] = {p[0] - pivot[0], p[1] - pivot[1], p[2] - pivot[2]};
      dMatrix3 Rn;
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) Rn[r * 4 + c] = R[r * 3] * Rb[c] + R[r * 3 + 1] * Rb[4 + c] + R[r * 3 + 2] * Rb[8 + c];
        Rn[r * 4 + 3] = 0;
      }
      const double np[3] = {pivot[0] + R[0] * d[0] + R[1] * d[1] + R[2] * d[2],
                            pivot[1] + R[3] * d[0] + R[4] * d[1] + R[5] * d[2],
                            pivot[2] + R[6] * d[0] + R[7] * d[1] + R[8] * d[2]};
      dBodySetRotation(w.body[i], Rn);
      dBodySetPosition(w.body[i], np[0], np[1], np[2]);
      w.kinematics_fresh = false;
    }
  };
  auto above_ankle = [](int i) { return i == 0 || (i - 1) % kLegBodies != Foot; };
  auto above_hip = [](int i) { return i == 0; };
  double a[3];
  group_anchor(w, Left, AnkleGroup, a);
  turn(above_ankle, a, P_.theta_ankle_init);
  group_anchor(w, Left, HipGroup, a);
  turn(above_hip, a, P_.theta_hip_init);

  // Settle under the initial set points (the soles on the ground, held if flat_foot_weld), then
  // start the clock.
  Inputs hold;
  hold.ref[AnklePitch] = P_.theta_ankle_init;
  hold.ref[HipPitch] = P_.theta_hip_init;
  in_ = hold;
  const int n = static_cast<int>(std::ceil(P_.settle_time / P_.internal_step - 1e-9));
  for (int side = 0; side < kLegs; ++side) weld(side, P_.flat_foot_weld);
  try {
    for (int i = 0; i < n; ++i) {
      w.reaction_sum = GroundReaction();
      w.reaction_time = 0;
      if (ode_step(P_.settle_time / n) != StepResult::Ok) return false;
      weld_resting_feet();
      if (check_fall()) {
        msg_ = "the robot falls while settling into the initial posture: " + msg_;
        return false;
      }
    }
  } catch (const std::exception& e) {
    msg_ = e.what();
    return false;
  }
  t_ = t0;
  fallen_ = false;
  stats_ = Stats();
  evaluate_outputs();
  return true;
}

namespace {
// The servo rows and the contact joints of one attempt at an ODE step. `bounded`: the motor rows
// carry their torque limit and the friction rows their pyramid (the LCP); otherwise both are
// unbounded equality rows, which ODE's LCP factorises in one go instead of pivoting row by row.
void set_motor_limits(Plant3D::World& w, bool bounded) {
  for (int s = 0; s < kLegs; ++s)
    for (int g = 0; g < kGroups; ++g)
      for (int i = 0; i < kGroupCount[g]; ++i) {
        const int k = kGroupFirst[g] + i;
        const double fmax = w.servo_fmax[s][k];
        const double len = std::sqrt(dot(w.dual[s][k], w.dual[s][k]));
        dJointSetAMotorParam(w.motor[s][g], dParamFMax + dParamGroup * i, bounded || fmax == 0 ? fmax * len : dInfinity);
      }
}
}  // namespace

void Plant3D::make_contacts(double dt, bool bounded) {
  World& w = *w_;
  // ERP and CFM of a spring k and damper c per corner (ODE manual, "Soft constraint and constraint
  // force mixing"), with the damper reduced by h k: ODE's soft row is implicit Euler of the
  // spring-damper, whose spring at x(t+h) adds h k of numerical damping (first-order error, 20 %
  // of c at h = 1 ms); with c - h k the step applies k x(t) + c v(t+h), the intended law.
  const double k = P_.contact_stiffness, c = P_.contact_damping;
  const double ce = std::max(c - dt * k, 0.1 * c);
  const double erp = dt * k / (dt * k + ce), cfm = 1.0 / (dt * k + ce);
  dJointGroupEmpty(w.contact_group);
  w.max_depth = 0;
  w.contact_rows = !bounded;
  for (int s = 0; s < kLegs; ++s) {
    const dBodyID foot = w.body[body_index(s, Foot)];
    const double* R = dBodyGetRotation(foot);
    double fx = R[0], fy = R[4];  // the foot's x axis, horizontal part: first friction direction
    const double nrm = std::hypot(fx, fy);
    fx = nrm > 1e-9 ? fx / nrm : 1.0;
    fy = nrm > 1e-9 ? fy / nrm : 0.0;
    w.fdir[s][0] = fx;
    w.fdir[s][1] = fy;
    if (w.welded[s]) {  // held: no contact rows (weld_reactions gives its corner forces)
      w.ncontact[s] = 0;
      continue;
    }
    const int n = dCollide(w.foot_geom[s], w.ground, kMaxContacts, w.cg[s], sizeof(dContactGeom));
    w.ncontact[s] = n;
    for (int i = 0; i < n; ++i) {
      const dContactGeom& g = w.cg[s][i];
      w.max_depth = std::max(w.max_depth, static_cast<double>(g.depth));
      if (!bounded) {
        // Every corner pushing and sticking: the contact's three rows as equality rows. A DBall
        // (distance) joint between the corner and a point 1 m away along a row's direction has
        // exactly that row: direction u at the corner, right-hand side ERP/h (target - distance),
        // the joint's CFM (ODE joints/dball.cpp). Normal: u = n, target 1 m + depth, the contact's
        // ERP and CFM (the soft row above); tangents: u = t1, t2 = n x t1, ERP 0 (rate only, as
        // the contact's friction rows), the world's CFM (which ODE gives the contact's friction rows:
        // the sixteen tangent rows of two flat feet are redundant, the LDLT needs it).
        const double t1[3] = {fx, fy, 0.0};
        double t2[3];
        cross(g.normal, t1, t2);
        const double* dirs[3] = {g.normal, t1, t2};
        for (int r = 0; r < 3; ++r) {
          const double* u = dirs[r];
          dJointID j = dJointCreateDBall(w.world, w.contact_group);
          dJointAttach(j, foot, nullptr);
          dJointSetDBallAnchor1(j, g.pos[0], g.pos[1], g.pos[2]);
          dJointSetDBallAnchor2(j, g.pos[0] - u[0], g.pos[1] - u[1], g.pos[2] - u[2]);
          dJointSetDBallDistance(j, r == 0 ? 1.0 + g.depth : 1.0);
          dJointSetDBallParam(j, dParamERP, r == 0 ? erp : 0.0);
          dJointSetDBallParam(j, dParamCFM, r == 0 ? cfm : dWorldGetCFM(w.world));
          dJointSetFeedback(j, &w.fb_row[s][i][r]);
        }
        continue;
      }
      dContact ct;
      std::memset(&ct, 0, sizeof ct);
      ct.geom = g;
      // the friction pyramid: |f1|, |f2| <= mu fn along the foot and across it
      ct.surface.mode = dContactApprox1 | dContactSoftERP | dContactSoftCFM | dContactFDir1;
      ct.surface.mu = P_.mu;
      ct.surface.soft_erp = erp;
      ct.surface.soft_cfm = cfm;
      ct.fdir1[0] = fx;
      ct.fdir1[1] = fy;
      ct.fdir1[2] = 0;
      dJointID cj = dJointCreateContact(w.world, w.contact_group, &ct);
      dJointAttach(cj, foot, nullptr);
      dJointSetFeedback(cj, &w.fb[s][i]);
    }
  }
}

// After an ODE step with equality contact rows: each corner's force, the sum of its three rows'.
static void sum_contact_rows(Plant3D::World& w) {
  if (!w.contact_rows) return;
  for (int s = 0; s < kLegs; ++s)
    for (int i = 0; i < w.ncontact[s]; ++i) {
      dJointFeedback& f = w.fb[s][i];
      for (int c = 0; c < 3; ++c) {
        f.f1[c] = w.fb_row[s][i][0].f1[c] + w.fb_row[s][i][1].f1[c] + w.fb_row[s][i][2].f1[c];
        f.t1[c] = w.fb_row[s][i][0].t1[c] + w.fb_row[s][i][1].t1[c] + w.fb_row[s][i][2].t1[c];
      }
    }
}

// Whether the last step's motor torques and friction forces lie within their limits, and whether
// any is within 1 % of its limit (then the next step starts bounded).
bool Plant3D::within_limits(bool& near) const {
  const World& w = *w_;
  bool ok = true;
  near = false;
  for (int s = 0; s < kLegs; ++s) {
    for (int k = 0; k < kLegJoints; ++k) {
      const double fmax = w.servo_fmax[s][k];
      if (!(fmax > 0) || fmax == dInfinity) continue;
      const double tau = std::fabs(w.servo_gain[s][k] * (w.servo_vel[s][k] - w.qd[s][k]));
      ok = ok && tau <= fmax * (1 + 1e-9);
      near = near || tau > 0.99 * fmax;
    }
    const double t1[3] = {w.fdir[s][0], w.fdir[s][1], 0.0};
    for (int i = 0; i < w.ncontact[s]; ++i) {
      const double* f = w.fb[s][i].f1;
      const double* nz = w.cg[s][i].normal;
      double t2[3];
      cross(nz, t1, t2);
      const double fn = dot(f, nz), lim = P_.mu * std::fabs(fn);
      const double f1 = std::fabs(dot(f, t1)), f2 = std::fabs(dot(f, t2));
      // an equality row may pull: then this corner lifts, and only the LCP knows how
      ok = ok && fn >= 0 && f1 <= lim * (1 + 1e-9) + 1e-12 && f2 <= lim * (1 + 1e-9) + 1e-12;
      near = near || f1 > 0.99 * lim || f2 > 0.99 * lim || fn < kNearLift * P_.mass() * P_.g;
    }
  }
  return ok;
}

Plant3D::StepResult Plant3D::ode_step(double dt, bool release) {
  World& w = *w_;
  tl_logger = &logger;
  // servos: the velocity loop is the ODE motor row (implicit), the position loop sets its target.
  // The row's unit axis u = -n/|n| (motor attached parent, child) measures u . (w_p - w_c) =
  // qdot/|n|; target, CFM and force limit are rescaled so the law holds in qdot and joint torque.
  if (!w.kinematics_fresh) refresh_kinematics(w);
  for (int s = 0; s < kLegs; ++s) {
    for (int g = 0; g < kGroups; ++g) {
      const dJointID m = w.motor[s][g];
      for (int i = 0; i < kGroupCount[g]; ++i) {
        const int k = kGroupFirst[g] + i, grp = dParamGroup * i;
        const Servo& sv = P_.servo[k];
        const double* n = w.dual[s][k];
        const double len = std::sqrt(dot(n, n));
        dJointSetAMotorAxis(m, i, 0, -n[0], -n[1], -n[2]);
        dJointSetAMotorAngle(m, i, w.q[s][k]);  // for the limit rows
        const double kd = P_.servo_on ? 0.5 * sv.kd : 0.0, d = 0.5 * sv.damping;
        const double e = in_.set_point(s, k) - w.q[s][k];  // both legs' ref + this leg's (section 3)
        const double wcmd = P_.servo_on ? hoap2_soft_sat(sv.kp / sv.kd * e, sv.vel_max) : 0.0;
        const double gain = kd + d;
        const double vel = gain > 0 ? kd * wcmd / gain : 0.0;
        w.servo_vel[s][k] = vel;
        w.servo_gain[s][k] = gain;
        w.servo_fmax[s][k] = gain > 0 ? (P_.servo_on ? 0.5 * sv.tau_max : dInfinity) : 0.0;
        if (gain > 0) {
          dJointSetAMotorParam(m, dParamVel + grp, vel / len);
          dJointSetAMotorParam(m, dParamCFM + grp, 1.0 / (gain * len * len));
        }
      }
    }
  }

  // Active-set guess: unless the last step had a torque or friction force near its limit, solve
  // with those rows unbounded; if the result breaks a limit, restore the bodies and solve again
  // bounded. A solution within the limits solves the bounded problem too, so this only saves work.
  auto push = [&] {
    if (in_.push_x != 0.0 || in_.push_y != 0.0)
      dBodyAddForceAtRelPos(w.body[0], in_.push_x, in_.push_y, 0.0, w.push_point[0], w.push_point[1], w.push_point[2]);
  };
  // A held foot is a guess of the same kind: its ground reaction must press every corner and stick;
  // if not, the foot is released onto its corner contacts and the step solved again.
  BodyState saved[kBodies];
  bool bounded = limits_near_;
  const bool any_weld = w.welded[Left] || w.welded[Right];
  if (!bounded || any_weld) save_bodies(saved);
  for (;;) {
    set_motor_limits(w, bounded);
    push();
    make_contacts(dt, bounded);
    dWorldStep(w.world, dt);
    sum_contact_rows(w);
    ++stats_.ode_steps;
    refresh_kinematics(w);
    if (const unsigned broken = weld_reactions()) {
      restore_bodies(saved);
      refresh_kinematics(w);
      w.broken_welds = broken;
      if (!release) return StepResult::WeldBroken;
      for (int s = 0; s < kLegs; ++s)
        if (broken & (1u << s)) weld(s, false);
      continue;
    }
    bool near = false;
    const bool ok = within_limits(near);
    if (ok || bounded) {
      limits_near_ = near || !ok;
      break;
    }
    restore_bodies(saved);
    refresh_kinematics(w);
    ++stats_.resolves;
    bounded = true;
  }

  // servo torques as the motor applied them (implicit law at the new rate, clamped)
  for (int s = 0; s < kLegs; ++s)
    for (int k = 0; k < kLegJoints; ++k) {
      const double fmax = w.servo_fmax[s][k];
      w.tau[s][k] = fmax > 0 ? std::clamp(w.servo_gain[s][k] * (w.servo_vel[s][k] - w.qd[s][k]), -fmax, fmax) : 0.0;
    }
  for (int i = 0; i < kBodies; ++i) {
    const double* p = dBodyGetPosition(w.body[i]);
    const double* v = dBodyGetLinearVel(w.body[i]);
    const double* om = dBodyGetAngularVel(w.body[i]);
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(p[c]) || !std::isfinite(v[c]) || !std::isfinite(om[c])) {
        msg_ = "non-finite state of body " + w.info[i].name + " after an ODE step";
        return StepResult::Error;
      }
    }
  }
  w.reaction_sum.add(step_reaction(w), dt);
  w.reaction_time += dt;
  return StepResult::Ok;
}

bool Plant3D::welded(int side) const { return w_->welded[side]; }

void Plant3D::weld(int side, bool on) {
  World& w = *w_;
  if (w.welded[side] == on) return;
  const dBodyID foot = w.body[body_index(side, Foot)];
  w.welded[side] = on;
  if (on) {
    dBodySetKinematic(foot);  // infinite mass: still while its velocity is zero
    dBodySetLinearVel(foot, 0, 0, 0);
    dBodySetAngularVel(foot, 0, 0, 0);
  } else {
    dBodySetDynamic(foot);
    ++stats_.unwelds;
  }
  w.kinematics_fresh = false;
}

// A free foot is held once its four corners press the ground inside the friction pyramid and none
// moves faster than kWeldSpeed: the contacts then hold it still, up to the springs' deflection.
void Plant3D::weld_resting_feet() {
  World& w = *w_;
  if (!P_.flat_foot_weld) return;
  for (int s = 0; s < kLegs; ++s) {
    if (w.welded[s] || w.ncontact[s] != kCells) continue;
    const dBodyID foot = w.body[body_index(s, Foot)];
    bool rest = true;
    const double t1[3] = {w.fdir[s][0], w.fdir[s][1], 0.0};
    for (int i = 0; i < kCells && rest; ++i) {
      const double* f = w.fb[s][i].f1;
      const double* nz = w.cg[s][i].normal;
      double t2[3], v[3];
      cross(nz, t1, t2);
      const double fn = dot(f, nz);
      dBodyGetPointVel(foot, w.cg[s][i].pos[0], w.cg[s][i].pos[1], w.cg[s][i].pos[2], v);
      rest = fn > 0 && std::fabs(dot(f, t1)) < P_.mu * fn && std::fabs(dot(f, t2)) < P_.mu * fn &&
             dot(v, v) < kWeldSpeed * kWeldSpeed;
    }
    if (rest) weld(s, true);
  }
}

// A held foot is static: its ground reaction balances the ankle joint's and the ankle servos' forces
// on it and its weight. Four equal corner springs under a rigid sole share the normal force and the
// tilting moments as
//   f_i = Fz/4 + Mx y_i / (4 b^2) - My x_i / (4 a^2)   (corners at x_i = +-a, y_i = +-b from the
// sole centre, moments about it, foot axes). The tangential force of a rigid sole sticking on four
// corners is statically indeterminate; the foot sticks while some split lies inside every corner's
// pyramid. The split in proportion to the corner loads, (fx_i, fy_i) = f_i ((Fx, Fy)/Fz +
// lam (-y_i, x_i)) with lam = Mz / sum f_i (x_i^2 + y_i^2), is inside them exactly when
// |Fx/Fz - lam y_i| and |Fy/Fz + lam x_i| are at most mu: the whole sole's friction, not one
// lightly loaded corner's. Written as the foot's contacts (corner positions and forces) for the
// outputs and checks.
unsigned Plant3D::weld_reactions() {
  World& w = *w_;
  unsigned broken = 0;
  const double a = 0.5 * w.sole_len, b = 0.5 * w.sole_width;
  const double xs[kCells] = {a, a, -a, -a}, ys[kCells] = {b, -b, b, -b};
  for (int s = 0; s < kLegs; ++s) {
    if (!w.welded[s]) continue;
    const dBodyID foot = w.body[body_index(s, Foot)];
    const double* R = dBodyGetRotation(foot);
    const double* pc = dBodyGetPosition(foot);
    const dJointFeedback &jf = w.ankle_fb[s][0], &mf = w.ankle_fb[s][1];
    const double mg = w.info[body_index(s, Foot)].mass * P_.g;
    const double F[3] = {-jf.f2[0] - mf.f2[0], -jf.f2[1] - mf.f2[1], -jf.f2[2] - mf.f2[2] + mg};
    double c[3], M[3];
    dBodyGetRelPointPos(foot, w.sole_center[s][0], w.sole_center[s][1], w.sole_center[s][2], c);
    const double r[3] = {pc[0] - c[0], pc[1] - c[1], pc[2] - c[2]};
    cross(r, F, M);  // moment about the sole centre: about the CoM, plus r x F
    for (int k = 0; k < 3; ++k) M[k] -= jf.t2[k] + mf.t2[k];
    double Fl[3], Ml[3];
    mat_t_vec(R, F, Fl);
    mat_t_vec(R, M, Ml);
    double fn[kCells], polar = 0;
    for (int i = 0; i < kCells; ++i) {
      fn[i] = Fl[2] / 4 + Ml[0] * ys[i] / (4 * b * b) - Ml[1] * xs[i] / (4 * a * a);
      polar += fn[i] * (xs[i] * xs[i] + ys[i] * ys[i]);
    }
    const bool loaded = Fl[2] > 0 && polar > 0;
    const double ux = loaded ? Fl[0] / Fl[2] : 0.0, uy = loaded ? Fl[1] / Fl[2] : 0.0;
    const double lam = loaded ? Ml[2] / polar : 0.0;
    const double nz[3] = {R[2], R[6], R[10]};
    w.ncontact[s] = kCells;
    for (int i = 0; i < kCells; ++i) {
      const double cx = ux - lam * ys[i], cy = uy + lam * xs[i];  // tangential / normal at corner i
      const double fl[3] = {fn[i] * cx, fn[i] * cy, fn[i]};
      if (!loaded || !(fn[i] >= 0) || std::fabs(cx) > P_.mu || std::fabs(cy) > P_.mu) broken |= 1u << s;
      dContactGeom& g = w.cg[s][i];
      dBodyGetRelPointPos(foot, w.sole_corner[s][i][0], w.sole_corner[s][i][1], w.sole_corner[s][i][2], g.pos);
      std::copy(nz, nz + 3, g.normal);
      g.depth = std::max(0.0, -static_cast<double>(g.pos[2]));
      w.max_depth = std::max(w.max_depth, static_cast<double>(g.depth));
      mat_vec(R, fl, w.fb[s][i].f1);
    }
  }
  return broken;
}


bool Plant3D::check_fall() {
  World& w = *w_;
  double ankle[3] = {0, 0, 0}, com[3] = {0, 0, 0}, m = 0;
  for (int s = 0; s < kLegs; ++s) {
    const double* R = dBodyGetRotation(w.body[body_index(s, Foot)]);
    const double tilt = std::acos(std::clamp(static_cast<double>(R[10]), -1.0, 1.0));
    if (tilt > P_.fall_foot_pitch) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "%s sole tilted %.4f rad (limit %.3f)", s == Left ? "left" : "right", tilt,
                    P_.fall_foot_pitch);
      msg_ = buf;
      return true;
    }
    double a[3];
    group_anchor(w, s, AnkleGroup, a);
    for (int c = 0; c < 3; ++c) ankle[c] += 0.5 * a[c];
  }
  for (int i = 0; i < kBodies; ++i) {
    const double* p = dBodyGetPosition(w.body[i]);
    for (int c = 0; c < 3; ++c) com[c] += w.info[i].mass * p[c];
    m += w.info[i].mass;
  }
  const double lean = std::atan2(std::hypot(com[0] / m - ankle[0], com[1] / m - ankle[1]), com[2] / m - ankle[2]);
  if (lean > P_.fall_body_pitch) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "body leans %.4f rad from the ankles (limit %.3f)", lean, P_.fall_body_pitch);
    msg_ = buf;
    return true;
  }
  return false;
}

Plant3D::Result Plant3D::fall_check() {
  if (!check_fall()) return Result::Ok;
  fallen_ = true;
  t_fall_ = t_;
  char buf[64];
  std::snprintf(buf, sizeof buf, "t=%.6f s: FALLEN: ", t_);
  msg_ = buf + msg_;
  evaluate_outputs();
  log(msg_);
  return Result::Fallen;
}

// ODE's constraint rows hold a joint or a contact at the velocity level, so its step is first-order
// accurate, with the largest error where the robot turns about a sole edge. Steps of internal_step
// while both feet are held flat; of rocking_step otherwise, and for a step in which a held foot is
// released (docs/plant3d.md section 2, "Time step").
Plant3D::Result Plant3D::do_step(double h) {
  if (fallen_) return Result::Fallen;
  if (!(h > 0) || !std::isfinite(h)) {
    msg_ = "communication step must be positive and finite";
    return Result::Error;
  }
  World& w = *w_;
  const int n = std::max(1, static_cast<int>(std::ceil(h / P_.internal_step - 1e-9)));
  const double dt = h / n, t0 = t_;
  const int m = std::max(1, static_cast<int>(std::ceil(dt / P_.rocking_step - 1e-9)));
  const int mode_before = out_.contact_mode;
  w.reaction_sum = GroundReaction();
  w.reaction_time = 0;
  try {
    for (int i = 0; i < n; ++i) {
      bool fine = m > 1;
      if (m == 1 || (w.welded[Left] && w.welded[Right])) {
        const StepResult r = ode_step(dt, m == 1);
        if (r == StepResult::Error) return Result::Error;
        if (r == StepResult::WeldBroken) {  // restored: release the feet, take it in rocking steps
          for (int s = 0; s < kLegs; ++s)
            if (w.broken_welds & (1u << s)) weld(s, false);
        } else {
          fine = false;
          weld_resting_feet();
          t_ = t0 + (i + 1) * dt;
          if (fall_check() == Result::Fallen) return Result::Fallen;
        }
      }
      for (int j = 0; fine && j < m; ++j) {
        if (ode_step(dt / m) != StepResult::Ok) return Result::Error;
        weld_resting_feet();
        t_ = t0 + i * dt + (j + 1) * (dt / m);
        if (fall_check() == Result::Fallen) return Result::Fallen;
      }
    }
  } catch (const std::exception& e) {
    msg_ = e.what();
    return Result::Error;
  }
  t_ = t0 + h;
  evaluate_outputs();
  if (out_.contact_mode != mode_before) ++stats_.mode_switches;
  return Result::Ok;
}

double Plant3D::gauss() {  // splitmix64 + Box-Muller, as the sagittal plant
  auto next = [this] {
    std::uint64_t z = (rng_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (static_cast<double>(z >> 11) + 0.5) * (1.0 / 9007199254740992.0);
  };
  const double u1 = next(), u2 = next();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

void Plant3D::evaluate_outputs() {
  World& w = *w_;
  Outputs o;
  std::memset(static_cast<void*>(&o), 0, sizeof o);  // deterministic padding (snapshots compare bytes)
  // feet frame: origin at the middle of the ankle axes (on the ground for x, y), x along the feet
  if (!w.kinematics_fresh) refresh_kinematics(w);
  double ankle[3] = {0, 0, 0}, heading[2] = {0, 0};
  for (int s = 0; s < kLegs; ++s) {
    double a[3];
    group_anchor(w, s, AnkleGroup, a);
    for (int c = 0; c < 3; ++c) ankle[c] += 0.5 * a[c];
    const double* R = dBodyGetRotation(w.body[body_index(s, Foot)]);
    heading[0] += R[0];
    heading[1] += R[4];
    o.foot_pitch += 0.5 * std::atan2(-R[8], std::hypot(R[0], R[4]));
    o.foot_roll += 0.5 * std::atan2(R[9], R[10]);
  }
  o.feet_x = ankle[0];
  o.feet_y = ankle[1];
  const double hn = std::hypot(heading[0], heading[1]);
  const double ex[2] = {heading[0] / hn, heading[1] / hn}, ey[2] = {-ex[1], ex[0]};
  auto feet_x = [&](const double* p) { return (p[0] - ankle[0]) * ex[0] + (p[1] - ankle[1]) * ex[1]; };
  auto feet_y = [&](const double* p) { return (p[0] - ankle[0]) * ey[0] + (p[1] - ankle[1]) * ey[1]; };

  // the ground reaction averaged over the communication step (the last step's before the first)
  GroundReaction g;
  if (w.reaction_time > 0) g.add(w.reaction_sum, 1.0 / w.reaction_time);
  else g = step_reaction(w);
  const double* F = g.F;
  const double* true_cells[kLegs] = {g.cells[Left], g.cells[Right]};
  o.contacts = w.ncontact[Left] + w.ncontact[Right];
  o.fx = F[0];
  o.fy = F[1];
  o.fz_true = F[2];
  // moment about the mean ankle axis: sum (p_z - a_z)(f . e_x) - ((p - a) . e_x) f_z
  o.moment_ankle = g.pz_f[0] * ex[0] + g.pz_f[1] * ex[1] - ankle[2] * (F[0] * ex[0] + F[1] * ex[1]) -
                   (g.fz_p[0] * ex[0] + g.fz_p[1] * ex[1]) + (ankle[0] * ex[0] + ankle[1] * ex[1]) * F[2];
  o.required_mu = F[2] > 0 ? std::hypot(F[0], F[1]) / F[2] : 0.0;
  if (F[2] > 0) {
    const double z[3] = {g.fz_p[0] / F[2], g.fz_p[1] / F[2], 0};
    o.zmp_true_x = feet_x(z);
    o.zmp_true_y = feet_y(z);
  }

  // the cells as the robot reads them (noise, bias), and the ZMP from them
  double sx = 0, sy = 0, toe_true = 0, heel_true = 0;
  for (int s = 0; s < kLegs; ++s) {
    const dBodyID foot = w.body[body_index(s, Foot)];
    for (int c = 0; c < kCells; ++c) {
      const bool front = c == FrontLeft || c == FrontRight;
      (front ? toe_true : heel_true) += true_cells[s][c];
      double f = true_cells[s][c] + 0.25 * (front ? P_.sensor_bias_toe : P_.sensor_bias_heel);
      if (P_.sensor_noise > 0) f += P_.sensor_noise * gauss();
      o.cell[s][c] = f;
      o.fz_foot[s] += f;
      (front ? o.f_toe : o.f_heel) += f;
      dVector3 p;
      dBodyGetRelPointPos(foot, w.sole_corner[s][c][0], w.sole_corner[s][c][1], w.sole_corner[s][c][2], p);
      sx += f * feet_x(p);
      sy += f * feet_y(p);
    }
    dVector3 v;
    dBodyGetRelPointVel(foot, w.sole_center[s][0], w.sole_center[s][1], w.sole_center[s][2], v);
    o.slip_speed[s] = std::hypot(v[0], v[1]);
  }
  o.fz = o.f_toe + o.f_heel;
  if (o.fz > P_.sensor_fmin) {
    o.zmp_x = sx / o.fz;
    o.zmp_y = sy / o.fz;
  }
  const double mg = P_.mass() * P_.g, eps = 1e-3 * mg;
  o.contact_mode = toe_true + heel_true < eps ? 3 : heel_true < eps ? 1 : toe_true < eps ? 2 : 0;

  // CoM, energy
  double com[3] = {0, 0, 0}, m = 0, ke = 0, pe = 0;
  for (int i = 0; i < kBodies; ++i) {
    const dBodyID b = w.body[i];
    const double* p = dBodyGetPosition(b);
    const double* v = dBodyGetLinearVel(b);
    const double mi = w.info[i].mass;
    for (int c = 0; c < 3; ++c) com[c] += mi * p[c];
    m += mi;
    dMass dm;
    dBodyGetMass(b, &dm);
    double wb[3], Iw[3];
    mat_t_vec(dBodyGetRotation(b), dBodyGetAngularVel(b), wb);
    mat_vec(dm.I, wb, Iw);
    ke += 0.5 * mi * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + 0.5 * (wb[0] * Iw[0] + wb[1] * Iw[1] + wb[2] * Iw[2]);
    pe += mi * P_.g * p[2];
  }
  for (double& c : com) c /= m;
  o.com_x = feet_x(com);
  o.com_y = feet_y(com);
  o.com_z = com[2] - ankle[2];
  o.energy = ke + pe;

  // joints
  for (int s = 0; s < kLegs; ++s)
    for (int k = 0; k < kLegJoints; ++k) {
      o.joint[s][k] = w.q[s][k];
      o.tau_joint[s][k] = w.tau[s][k];
    }
  for (int s = 0; s < kLegs; ++s) {
    o.theta_ankle += 0.5 * o.joint[s][AnklePitch];
    o.theta_hip += 0.5 * o.joint[s][HipPitch];
    o.dtheta_ankle += 0.5 * w.qd[s][AnklePitch];
    o.dtheta_hip += 0.5 * w.qd[s][HipPitch];
    o.tau_ankle += w.tau[s][AnklePitch];
    o.tau_hip += w.tau[s][HipPitch];
  }

  // IMU on the trunk: Z-Y-X Euler angles, body-frame rates
  const double* R = dBodyGetRotation(w.body[0]);
  o.imu_yaw = std::atan2(R[4], R[0]);
  o.imu_pitch = std::asin(std::clamp(-static_cast<double>(R[8]), -1.0, 1.0));
  o.imu_roll = std::atan2(R[9], R[10]);
  mat_t_vec(R, dBodyGetAngularVel(w.body[0]), o.gyro);

  o.fallen = fallen_;
  std::memcpy(static_cast<void*>(&out_), &o, sizeof o);
}

double Plant3D::sink_depth() const { return w_->max_depth; }

void Plant3D::push_point(double p[3]) const {
  dVector3 v;
  dBodyGetRelPointPos(w_->body[0], w_->push_point[0], w_->push_point[1], w_->push_point[2], v);
  std::copy(v, v + 3, p);
}

void Plant3D::body_rotation(int i, double R[9]) const {
  const double* Rb = dBodyGetRotation(w_->body[i]);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R[r * 3 + c] = Rb[r * 4 + c];
}

void Plant3D::com(double c[3]) const {
  double m = 0;
  c[0] = c[1] = c[2] = 0;
  for (int i = 0; i < kBodies; ++i) {
    const double* p = dBodyGetPosition(w_->body[i]);
    for (int k = 0; k < 3; ++k) c[k] += w_->info[i].mass * p[k];
    m += w_->info[i].mass;
  }
  for (int k = 0; k < 3; ++k) c[k] /= m;
}

std::vector<BodyInfo> Plant3D::bodies() const {
  std::vector<BodyInfo> v(w_->info, w_->info + kBodies);
  for (int i = 0; i < kBodies; ++i) {  // where they are now: CoM and inertia in world axes
    const dBodyID b = w_->body[i];
    std::copy(dBodyGetPosition(b), dBodyGetPosition(b) + 3, v[i].com);
    dMass m;
    dBodyGetMass(b, &m);
    const double* R = dBodyGetRotation(b);
    double Iw[3][3];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        double x = 0;
        for (int a = 0; a < 3; ++a)
          for (int d = 0; d < 3; ++d) x += R[r * 4 + a] * m.I[a * 4 + d] * R[c * 4 + d];
        Iw[r][c] = x;
      }
    const double I6[6] = {Iw[0][0], Iw[1][1], Iw[2][2], Iw[0][1], Iw[0][2], Iw[1][2]};
    std::copy(I6, I6 + 6, v[i].inertia);
  }
  return v;
}

std::vector<JointInfo> Plant3D::joints() const {
  std::vector<JointInfo> v;
  for (int s = 0; s < kLegs; ++s)
    for (int k = 0; k < kLegJoints; ++k) {
      JointInfo j = w_->jinfo[s][k];
      group_anchor(*w_, s, group_of(k), j.anchor);
      std::copy(w_->axis[s][k], w_->axis[s][k] + 3, j.axis);
      v.push_back(j);
    }
  return v;
}

void Plant3D::save_bodies(BodyState* out) const {
  for (int i = 0; i < kBodies; ++i) {
    const dBodyID b = w_->body[i];
    BodyState& st = out[i];
    std::memcpy(st.pos, dBodyGetPosition(b), sizeof st.pos);
    std::memcpy(st.quat, dBodyGetQuaternion(b), sizeof st.quat);
    std::memcpy(st.rot, dBodyGetRotation(b), sizeof st.rot);
    std::memcpy(st.lvel, dBodyGetLinearVel(b), sizeof st.lvel);
    std::memcpy(st.avel, dBodyGetAngularVel(b), sizeof st.avel);
  }
}

void Plant3D::restore_bodies(const BodyState* in) {
  w_->kinematics_fresh = false;
  for (int i = 0; i < kBodies; ++i) {
    const dBodyID b = w_->body[i];
    const BodyState& st = in[i];
    // ODE's setters renormalise the quaternion (not bit-exact); write its storage directly (the
    // getters return pointers into the body, ODE manual "Rigid body functions"), then move the
    // body by the setter so the attached geoms are updated.
    std::memcpy(const_cast<dReal*>(dBodyGetQuaternion(b)), st.quat, sizeof st.quat);
    std::memcpy(const_cast<dReal*>(dBodyGetRotation(b)), st.rot, sizeof st.rot);
    dBodySetPosition(b, st.pos[0], st.pos[1], st.pos[2]);
    dBodySetLinearVel(b, st.lvel[0], st.lvel[1], st.lvel[2]);
    dBodySetAngularVel(b, st.avel[0], st.avel[1], st.avel[2]);
  }
}

Snapshot Plant3D::snapshot() const {
  Snapshot s;
  std::memset(static_cast<void*>(&s), 0, sizeof s);  // deterministic padding
  s.magic = Snapshot().magic;
  s.version = Snapshot().version;
  s.t = t_;
  s.t_fall = t_fall_;
  s.fallen = fallen_;
  s.mode = out_.contact_mode;
  save_bodies(s.body);
  s.limits_near = limits_near_;
  for (int i = 0; i < kLegs; ++i) s.welded[i] = w_->welded[i];
  std::memcpy(static_cast<void*>(&s.in), &in_, sizeof in_);
  s.rng = rng_;
  std::memcpy(static_cast<void*>(&s.stats), &stats_, sizeof stats_);
  std::memcpy(static_cast<void*>(&s.out), &out_, sizeof out_);
  return s;
}

bool Plant3D::restore(const Snapshot& s) {
  if (s.magic != Snapshot().magic || s.version != Snapshot().version) return false;
  if (s.fallen < 0 || s.fallen > 1 || s.mode < 0 || s.mode > 3 || s.limits_near < 0 || s.limits_near > 1 ||
      s.out.contact_mode < 0 || s.out.contact_mode > 3 || s.out.contacts < 0 || !std::isfinite(s.t) ||
      !std::isfinite(s.t_fall))
    return false;
  for (const BodyState& st : s.body) {
    for (double x : st.rot) if (!std::isfinite(x)) return false;
    for (double x : st.pos) if (!std::isfinite(x)) return false;
    for (double x : st.quat) if (!std::isfinite(x)) return false;
    for (double x : st.lvel) if (!std::isfinite(x)) return false;
    for (double x : st.avel) if (!std::isfinite(x)) return false;
  }
  for (std::int32_t x : s.welded)
    if (x < 0 || x > 1) return false;
  for (int i = 0; i < kLegs; ++i) {
    const std::int64_t unwelds = stats_.unwelds;
    weld(i, s.welded[i] != 0);
    stats_.unwelds = unwelds;
  }
  restore_bodies(s.body);
  limits_near_ = s.limits_near != 0;
  t_ = s.t;
  t_fall_ = s.t_fall;
  fallen_ = s.fallen != 0;
  in_ = s.in;
  rng_ = s.rng;
  stats_ = s.stats;
  out_ = s.out;
  return true;
}

}  // namespace hoap2plant3d
