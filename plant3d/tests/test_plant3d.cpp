// Physics and engineering tests of the 3D plant (CTest: `plant3d_tests <name>`; `all` runs every
// one). Each test states what it establishes; the figures it prints are quoted in docs/plant3d.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "hoap2/nominal.h"
#include "hoap2plant3d/plant3d.hpp"
#include "check.h"  // CHECK, g_fail (hoap2/testing)

using namespace hoap2plant3d;

static const double kDt = 1e-3;  // communication step [s]

// Run n communication steps; push(t) gives the push force (x, y); each() sees the plant after each.
static Plant3D::Result run(Plant3D& p, int n, const std::function<void(double, Inputs&)>& in,
                           const std::function<void(const Plant3D&)>& each = nullptr) {
  Plant3D::Result r = Plant3D::Result::Ok;
  for (int i = 0; i < n; ++i) {
    Inputs u;
    u.ref[AnklePitch] = p.params().theta_ankle_init;
    u.ref[HipPitch] = p.params().theta_hip_init;
    if (in) in(p.time(), u);
    p.set_inputs(u);
    r = p.do_step(kDt);
    if (each) each(p);
    if (r != Plant3D::Result::Ok) break;
  }
  return r;
}

// Establishes: after settling, the robot held by its servos stands still (CoM drift over 10 s
// below 0.1 mm), the sensor ZMP equals the CoM's ground projection (statics: the contact forces
// carry the weight through the CoM) within 1 mm in x and y, the load cells carry the weight, and
// the contact mode never changes.
static void test_standing_still() {
  Plant3D p(default_params());
  CHECK(p.initialize(0.0), "%s", p.message().c_str());
  double c0[3], c[3];
  p.com(c0);
  double worst_zmp = 0;
  const auto r = run(p, 10000, nullptr, [&](const Plant3D& q) {
    const Outputs& o = q.outputs();
    worst_zmp = std::max({worst_zmp, std::fabs(o.zmp_x - o.com_x), std::fabs(o.zmp_y - o.com_y)});
  });
  CHECK(r == Plant3D::Result::Ok, "%s", p.message().c_str());
  p.com(c);
  const double drift = std::sqrt((c[0] - c0[0]) * (c[0] - c0[0]) + (c[1] - c0[1]) * (c[1] - c0[1]) +
                                 (c[2] - c0[2]) * (c[2] - c0[2]));
  const Outputs& o = p.outputs();
  const double mg = p.params().mass() * p.params().g;
  CHECK(drift < 1e-4, "CoM drift %g m", drift);
  CHECK(worst_zmp < 1e-3, "|ZMP - CoM| up to %g m", worst_zmp);
  CHECK(std::fabs(o.fz - mg) < 1e-3 * mg, "fz %g N, m g %g N", o.fz, mg);
  CHECK(p.stats().mode_switches == 0 && o.contact_mode == 0, "mode %d, %lld switches", o.contact_mode,
        (long long)p.stats().mode_switches);
  std::printf("  10 s standing: CoM drift %.3g m, max |ZMP - CoM| %.3g m, fz %.6f N (m g %.6f N), CoM x %.5f m\n",
              drift, worst_zmp, o.fz, mg, o.com_x);
}

// Establishes: the soft contact behaves as the spring it is tuned to be: at rest the soles sink
// less than 0.5 mm, and the corner penetrations times the corner stiffness carry the weight.
static void test_sinkage() {
  Plant3D p(default_params());
  CHECK(p.initialize(0.0), "%s", p.message().c_str());
  run(p, 500, nullptr);
  const double depth = p.sink_depth();
  CHECK(depth > 0 && depth < 5e-4, "sinkage %g m", depth);
  // mean penetration: weight / (corners x k) (all 8 corners loaded while standing)
  const double mg = p.params().mass() * p.params().g;
  const double mean = mg / (p.outputs().contacts * p.params().contact_stiffness);
  CHECK(p.outputs().contacts == 8, "%d corner contacts", p.outputs().contacts);
  CHECK(depth > mean && depth < 3 * mean, "deepest corner %g m, mean spring deflection %g m", depth, mean);
  std::printf("  at rest: deepest corner %.4g mm, weight / (8 k) = %.4g mm\n", 1e3 * depth, 1e3 * mean);
}

// Establishes: under a slow push ramp with the joints held, the heels (toes) lift when the push
// moment about the toe (heel) edge equals the weight's, F = m g (x_edge - x_com) / h, with x_com
// and h measured at that instant (within 2 %).
static void tipping(int sgn) {
  Params P = default_params();
  Plant3D p(P);
  CHECK(p.initialize(0.0), "%s", p.message().c_str());
  const double rate = 1.0;  // N/s: quasi-static
  double F_at = 0, comx_at = 0, h_at = 0;
  bool tipped = false;
  for (int i = 0; i < 20000 && !tipped; ++i) {
    const double F = sgn * rate * p.time();
    double pp[3];
    p.push_point(pp);
    const double comx = p.outputs().com_x;
    Inputs u;
    u.push_x = F;
    p.set_inputs(u);
    const auto r = p.do_step(kDt);
    CHECK(r == Plant3D::Result::Ok, "%s", p.message().c_str());
    if (p.outputs().contact_mode != 0) {
      tipped = true;
      F_at = F;
      comx_at = comx;
      h_at = pp[2];
    }
  }
  CHECK(tipped, "no tipping");
  const double edge = sgn > 0 ? HOAP2_TOE_X : HOAP2_HEEL_X;
  const double F_pred = P.mass() * P.g * (edge - comx_at) / h_at;
  const double err = std::fabs(F_at - F_pred) / std::fabs(F_pred);
  CHECK(err < 0.02, "F_tip %g vs predicted %g (err %.3f%%)", F_at, F_pred, 100 * err);
  CHECK(p.outputs().contact_mode == (sgn > 0 ? 1 : 2), "mode %d", p.outputs().contact_mode);
  std::printf("  %s: lifted at F = %+.4f N, m g (edge - x_com)/h = %+.4f N (error %.3f %%), x_com %.5f m, h %.5f m\n",
              sgn > 0 ? "push (toes)" : "pull (heels)", F_at, F_pred, 100 * err, comx_at, h_at);
}
static void test_tipping_toe() { tipping(+1); }
static void test_tipping_heel() { tipping(-1); }

// Establishes: the solution converges as the internal ODE step shrinks (the largest pointwise
// foot-pitch error, at the heels' landing, falls with every halving), and the default step is the
// one this study picks: the largest whose foot-pitch error over a rocking push response is below
// 1 % of the response (RMS) with the peak within 0.5 %. Reference: a 1/32 ms step.
struct Trace {
  std::vector<double> pitch, hip, comx;
};
static Trace push_response(double step) {
  Params P = default_params();
  P.internal_step = step;
  Plant3D p(P);
  CHECK(p.initialize(0.0), "%s", p.message().c_str());
  Trace tr;
  run(p, 1500, [](double t, Inputs& u) { u.push_x = (t >= 0.1 && t < 0.25) ? 14.0 : 0.0; },
      [&](const Plant3D& q) {
        tr.pitch.push_back(q.outputs().foot_pitch);
        tr.hip.push_back(q.outputs().theta_hip);
        tr.comx.push_back(q.outputs().com_x);
      });
  return tr;
}
static double max_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) m = std::max(m, std::fabs(a[i] - b[i]));
  return a.size() == b.size() ? m : INFINITY;
}
static double max_abs(const std::vector<double>& a) {
  double m = 0;
  for (double x : a) m = std::max(m, std::fabs(x));
  return m;
}
static double rms_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(s / a.size());
}
static void test_convergence() {
  const double def = default_params().internal_step;
  const double steps[] = {1e-3, 5e-4, 2.5e-4, 1.25e-4};
  const Trace ref = push_response(1e-3 / 32);
  const double peak = max_abs(ref.pitch);
  std::printf("  14 N push for 0.15 s, joints held; reference step %.4g ms; peak foot pitch %.4f rad, CoM x %.4f m\n",
              1e3 * 1e-3 / 32, peak, max_abs(ref.comx));
  std::printf("  %9s %12s %12s %12s %12s %12s\n", "step [ms]", "pitch max", "pitch rms", "pitch peak", "hip max",
              "CoM x max");
  double prev = 0, chosen = 0;
  for (double s : steps) {
    const Trace tr = push_response(s);
    CHECK(tr.pitch.size() == ref.pitch.size(), "the run at %g ms stopped early", 1e3 * s);
    const double e = max_diff(tr.pitch, ref.pitch), rms = rms_diff(tr.pitch, ref.pitch) / peak;
    const double pk = std::fabs(max_abs(tr.pitch) - peak) / peak;
    std::printf("  %9.4g %12.3e %11.2f%% %11.2f%% %12.3e %12.3e\n", 1e3 * s, e, 100 * rms, 100 * pk,
                max_diff(tr.hip, ref.hip), max_diff(tr.comx, ref.comx));
    if (prev > 0) CHECK(e < 0.75 * prev, "error did not shrink: %g after %g", e, prev);
    prev = e;
    // the rule that chose the default: the largest step whose foot-pitch error over the run is
    // below 1 % of the peak (RMS) and whose peak is within 0.5 %
    if (chosen == 0 && rms < 0.01 && pk < 0.005) chosen = s;
  }
  CHECK(chosen == def, "the study picks %g ms, the default is %g ms", 1e3 * chosen, 1e3 * def);
  std::printf("  default step %.4g ms: the largest with RMS error < 1 %% and peak error < 0.5 %%\n", 1e3 * def);
}

// Establishes: a snapshot restored into a fresh instance continues bit for bit like the original
// (ODE world: bodies' positions, quaternions, rotation matrices and velocities; inputs, noise
// generator, statistics), also with sensor noise on and during a rocking motion.
static void test_snapshot() {
  Params P = default_params();
  P.sensor_noise = 0.5;
  auto push = [](double t, Inputs& u) { u.push_x = (t >= 0.1 && t < 0.25) ? 13.0 : 0.0; };
  Plant3D a(P);
  CHECK(a.initialize(0.0), "%s", a.message().c_str());
  run(a, 200, push);  // mid-push
  const Snapshot s = a.snapshot();
  run(a, 400, push);
  Plant3D b(P);
  CHECK(b.restore(s), "restore failed");
  run(b, 400, push);
  CHECK(std::memcmp(&a.outputs(), &b.outputs(), sizeof(Outputs)) == 0, "outputs differ after restore");
  const Snapshot sa = a.snapshot(), sb = b.snapshot();
  CHECK(std::memcmp(&sa, &sb, sizeof(Snapshot)) == 0, "states differ after restore");
  CHECK(a.time() == b.time() && a.outputs().foot_pitch == b.outputs().foot_pitch, "t %g/%g", a.time(), b.time());
  Snapshot bad = s;
  bad.magic = 0;
  Plant3D c(P);
  CHECK(!c.restore(bad), "a snapshot with a wrong magic was accepted");
  bad = s;
  bad.body[3].pos[2] = NAN;
  CHECK(!c.restore(bad), "a snapshot with a NaN position was accepted");
  std::printf("  restored at t=0.2 s into a fresh instance: identical bytes at t=0.6 s (foot pitch %.6g rad)\n",
              b.outputs().foot_pitch);
}

// Establishes: instances are independent, also when run concurrently in threads (ODE's global
// initialisation happens once; each instance owns its world): results equal a sequential run's.
static void test_instances() {
  auto one = [](double force, Outputs& out) {
    Plant3D p(default_params());
    if (!p.initialize(0.0)) return;
    run(p, 600, [force](double t, Inputs& u) { u.push_x = t >= 0.1 && t < 0.2 ? force : 0.0; });
    out = p.outputs();
  };
  const double forces[4] = {4.0, -5.0, 8.0, 11.0};
  Outputs seq[4], par[4];
  for (int i = 0; i < 4; ++i) one(forces[i], seq[i]);
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i) threads.emplace_back(one, forces[i], std::ref(par[i]));
  for (auto& t : threads) t.join();
  for (int i = 0; i < 4; ++i)
    CHECK(std::memcmp(&seq[i], &par[i], sizeof(Outputs)) == 0, "instance %d differs when run in a thread", i);
  CHECK(seq[0].foot_pitch != seq[2].foot_pitch, "different pushes gave the same result");
  std::printf("  4 instances in 4 threads = sequential, bit for bit\n");
}

// Establishes: statics of the servo chain in a leaning posture: at rest the hip servos carry the
// moment of the weight above the hips about the hip axes, the ankle servos that of everything
// above the ankles (within 0.5 %), and the implicit ODE motor gives the PD law's torque kp e.
static void test_joint_statics() {
  Params P = default_params();
  P.theta_hip_init = 0.2;
  P.theta_ankle_init = -0.05;
  Plant3D p(P);
  CHECK(p.initialize(0.0), "%s", p.message().c_str());
  run(p, 1000, nullptr);
  const auto bodies = p.bodies();
  const auto joints = p.joints();
  // gravity moment about +y through an axis at x_axis: sum m g (x_i - x_axis) (+ = pitching forward)
  auto moment = [&](double x_axis, bool (*above)(const std::string&)) {
    double M = 0;
    for (const auto& b : bodies)
      if (above(b.name)) M += b.mass * P.g * (b.com[0] - x_axis);
    return M;
  };
  // the hip links are point masses on the hip axes (they belong to the thigh), the ankle link rides
  // with the foot while the ankle roll is held
  auto above_hip = [](const std::string& n) { return n == "trunk"; };
  auto above_ankle = [](const std::string& n) { return n.find("foot") == std::string::npos; };
  const double x_hip = joints[HipPitch].anchor[0], x_ankle = joints[AnklePitch].anchor[0];
  const Outputs& o = p.outputs();
  const double M_hip = moment(x_hip, above_hip), M_ankle = moment(x_ankle, above_ankle);
  CHECK(std::fabs(o.tau_hip + M_hip) < 5e-3 * std::fabs(M_hip), "hip servos %g N m, gravity moment %g N m", o.tau_hip,
        M_hip);
  CHECK(std::fabs(o.tau_ankle + M_ankle) < 5e-3 * std::fabs(M_ankle), "ankle servos %g N m, gravity moment %g N m",
        o.tau_ankle, M_ankle);
  const double pd_hip = P.servo[HipPitch].kp * (P.theta_hip_init - o.theta_hip);
  CHECK(std::fabs(o.tau_hip - pd_hip) < 1e-3 * std::fabs(pd_hip), "hip torque %g, kp e %g", o.tau_hip, pd_hip);
  std::printf("  hip servos %.5f N m vs gravity moment %.5f N m; ankle servos %.5f N m vs %.5f N m; "
              "hip kp e %.5f N m\n", o.tau_hip, -M_hip, o.tau_ankle, -M_ankle, pd_hip);
}

// Establishes: the joint coordinates read from the ball, hinge and universal joints are the
// proto's: with gravity off and every joint of both legs driven to a different angle, each
// converges to its set point, and the foot's orientation relative to the trunk equals the product
// of the proto's six joint rotations (its axes, its senses, its chain order) at those angles.
static void test_kinematics() {
  Params P = default_params();
  P.g = 0.0;
  P.mu = 0.0;  // no load from the ground either: the feet slide where the legs put them
  Plant3D p(P);
  CHECK(p.initialize(0.0), "%s", p.message().c_str());
  const double ref[kLegJoints] = {0.12, 0.2, 0.07, 0.4, -0.15, -0.06};  // this model's sense
  run(p, 2000, [&](double, Inputs& u) { std::copy(ref, ref + kLegJoints, u.ref); });
  const Outputs& o = p.outputs();
  auto rot = [](const double a[3], double q, double R[9]) {  // Rodrigues
    const double c = std::cos(q), s = std::sin(q), v = 1 - c;
    const double r[9] = {c + a[0] * a[0] * v,        a[0] * a[1] * v - a[2] * s, a[0] * a[2] * v + a[1] * s,
                         a[1] * a[0] * v + a[2] * s, c + a[1] * a[1] * v,        a[1] * a[2] * v - a[0] * s,
                         a[2] * a[0] * v - a[1] * s, a[2] * a[1] * v + a[0] * s, c + a[2] * a[2] * v};
    std::copy(r, r + 9, R);
  };
  auto mul = [](const double A[9], const double B[9], double C[9]) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) C[r * 3 + c] = A[r * 3] * B[c] + A[r * 3 + 1] * B[3 + c] + A[r * 3 + 2] * B[6 + c];
  };
  double Rt[9], worst_q = 0, worst_R = 0;
  p.body_rotation(0, Rt);
  for (int s = 0; s < kLegs; ++s) {
    double chain[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, tmp[9], Rj[9];
    for (int k = 0; k < kLegJoints; ++k) {
      worst_q = std::max(worst_q, std::fabs(o.joint[s][k] - ref[k]));
      // the proto's zero-posture axes (world axes of the unrotated robot) and its sense
      const bool sag = k == HipPitch || k == AnklePitch;
      const double axis0[kLegJoints][3] = {{0, 0, 1}, {0, 1, 0}, {1, 0, 0}, {0, 1, 0}, {0, 1, 0}, {1, 0, 0}};
      rot(axis0[k], sag ? -o.joint[s][k] : o.joint[s][k], Rj);
      mul(chain, Rj, tmp);
      std::copy(tmp, tmp + 9, chain);
    }
    double Rf[9], rel[9];
    p.body_rotation(1 + s * kLegBodies + Foot, Rf);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) rel[r * 3 + c] = Rt[r] * Rf[c] + Rt[3 + r] * Rf[3 + c] + Rt[6 + r] * Rf[6 + c];
    for (int i = 0; i < 9; ++i) worst_R = std::max(worst_R, std::fabs(rel[i] - chain[i]));
  }
  CHECK(worst_q < 1e-4, "a joint is %g rad from its set point", worst_q);
  CHECK(worst_R < 1e-9, "foot orientation differs from the proto chain by %g", worst_R);
  std::printf("  12 joints at their set points within %.2g rad; foot orientation = proto chain within %.2g\n",
              worst_q, worst_R);
}

int main(int argc, char** argv) {
  const std::string which = argc > 1 ? argv[1] : "all";
  struct T {
    const char* name;
    void (*fn)();
  } tests[] = {{"standing_still", test_standing_still}, {"sinkage", test_sinkage},
               {"tipping_toe", test_tipping_toe},       {"tipping_heel", test_tipping_heel},
               {"convergence", test_convergence},       {"snapshot", test_snapshot},
               {"instances", test_instances},           {"joint_statics", test_joint_statics},
               {"kinematics", test_kinematics}};
  bool ran = false;
  for (auto& t : tests)
    if (which == "all" || which == t.name) {
      std::printf("[%s]\n", t.name);
      t.fn();
      ran = true;
    }
  if (!ran) {
    std::printf("unknown test %s\n", which.c_str());
    return 2;
  }
  std::printf(g_fail ? "FAILED (%d)\n" : "OK\n", g_fail);
  return g_fail ? 1 : 0;
}
