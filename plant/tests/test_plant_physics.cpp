// Physics tests of the HOAP-2 plant library (CTest: `plant_tests <name> [erk|bdf]`, the
// integrator; ERK by default). Each test states what it establishes. Run all: `plant_tests all`.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "hoap2plant/plant.hpp"
#include "check.h"  // CHECK, g_fail (hoap2/testing)

using namespace hoap2plant;

static const double kDt = 1e-3;
// The integrator under test (second argument: erk | bdf); every test runs with either.
static Integrator g_integrator = Integrator::Erk;
static Params test_params() {
  Params P = default_params();
  P.integrator = g_integrator;
  return P;
}

// Run n communication steps of dt with an input function; returns the last result.
static Plant::Result run(Plant& p, int n, const std::function<void(double, double&, double&, double&)>& in,
                         const std::function<void(const Plant&)>& each = nullptr, double dt = kDt) {
  Plant::Result r = Plant::Result::Ok;
  for (int i = 0; i < n; ++i) {
    double a = 0, b = 0, f = 0;
    in(p.time(), a, b, f);
    p.set_inputs(a, b, f);
    r = p.do_step(dt);
    if (each) each(p);
    if (r != Plant::Result::Ok) break;
  }
  return r;
}

// Establishes: with the servos holding the erect and several leaned postures the plant is in
// static equilibrium: zmp_x (sole sensors) equals the whole-robot CoM ground projection, fz = m g,
// and the contact stays flat for 60 s with zero mode switches (no chattering).
static void test_static_standing() {
  const double postures[][2] = {{0, 0}, {0.05, 0}, {-0.03, 0}, {0.03, 0.25}, {-0.02, -0.2}, {0.1, -0.3}};
  for (auto& ps : postures) {
    Params P = test_params();
    Plant p(P);  // starts erect at rest; the servos move it to the commanded posture
    CHECK(p.initialize(0.0), "%s", p.message().c_str());
    const double mg = P.mass() * P.g;
    double max_zmp_err = 0, max_fz_err = 0, max_speed = 0;
    // smooth (cosine) 2 s transition of the set-points from erect to the posture
    auto ramp = [](double t) { return t >= 2.0 ? 1.0 : 0.5 - 0.5 * std::cos(M_PI * t / 2.0); };
    const auto r = run(p, 60000, [&](double t, double& a, double& b, double& f) { a = ps[0] * ramp(t); b = ps[1] * ramp(t); f = 0; },
                       [&](const Plant& pl) {
                         const auto& o = pl.outputs();
                         if (pl.time() < 4.0) return;  // settling
                         max_zmp_err = std::max(max_zmp_err, std::fabs(o.zmp_x - o.com_x));
                         max_fz_err = std::max(max_fz_err, std::fabs(o.fz - mg) / mg);
                         max_speed = std::max({max_speed, std::fabs(o.dtheta_ankle), std::fabs(o.dtheta_hip)});
                       });
    CHECK(r == Plant::Result::Ok, "posture (%g, %g): %s", ps[0], ps[1], p.message().c_str());
    CHECK(max_zmp_err < 1e-8, "posture (%g, %g): |zmp - com_x| = %g", ps[0], ps[1], max_zmp_err);
    CHECK(max_fz_err < 1e-8, "posture (%g, %g): |fz - mg|/mg = %g", ps[0], ps[1], max_fz_err);
    CHECK(p.stats().mode_switches == 0 && p.mode() == ContactMode::Flat, "switches %lld",
          (long long)p.stats().mode_switches);
    std::printf("  posture (%+.2f, %+.2f): com_x %+.5f m, |zmp-com_x| %.2e m, |fz-mg|/mg %.2e, "
                "max joint speed %.1e rad/s, t = 4..60 s, %lld mode switches, %lld steps\n",
                ps[0], ps[1], p.outputs().com_x, max_zmp_err, max_fz_err, max_speed,
                (long long)p.stats().mode_switches, (long long)p.stats().steps);
  }
}

// Establishes: under a slow push ramp on the back the foot tips onto its toe exactly when the
// centre of pressure reaches the toe edge, at the quasi-static force m g (x_toe - x_com) / h_push
// (within 2 %); a slow pull tips it onto the heel at m g (x_com - x_heel) / h_push.
static void test_tipping() {
  for (int sgn : {+1, -1}) {
    Params P = test_params();
    Plant p(P);
    CHECK(p.initialize(0.0), "%s", p.message().c_str());
    const double rate = 0.5;  // N/s, quasi-static
    double F_at = 0, comx_at = 0, h_at = 0;
    bool tipped = false;
    for (int i = 0; i < 60000 && !tipped; ++i) {
      const double F = sgn * rate * p.time();
      p.set_inputs(0, 0, F);
      // state before the step: candidate for the tipping instant
      const Vec5 q = p.q();
      Vec2 pos, bias;
      Eigen::Matrix<double, 2, 5> J;
      p.model().push_point(q, p.qd(), pos, J, bias);
      const double comx = p.model().com(q).x();
      const auto r = p.do_step(kDt);
      CHECK(r == Plant::Result::Ok, "%s", p.message().c_str());
      if (p.mode() != ContactMode::Flat) {
        tipped = true;
        F_at = F;
        comx_at = comx;
        h_at = pos.y();
      }
    }
    CHECK(tipped, "no tipping");
    const double edge = sgn > 0 ? P.toe_x : P.heel_x;
    const double F_pred = P.mass() * P.g * (edge - comx_at) / h_at;
    const double F_nom = P.mass() * P.g * (edge - p.model().com(Vec5(0, P.ankle_height, 0, 0, 0)).x()) / P.h_push;
    const double err = std::fabs(F_at - F_pred) / std::fabs(F_pred);
    CHECK(err < 0.02, "F_tip %g vs predicted %g (err %.3f%%)", F_at, F_pred, 100 * err);
    // the force acts at the parameter height h_push above the sole (posture deflection only)
    CHECK(std::fabs(h_at - P.h_push) < 1e-3, "push point at %g m, h_push %g m", h_at, P.h_push);
    CHECK(p.mode() == (sgn > 0 ? ContactMode::Toe : ContactMode::Heel), "mode %d", (int)p.mode());
    std::printf("  %s: tipped at F = %+.4f N, quasi-static m g (edge - x_com)/h = %+.4f N (error %.3f %%), "
                "x_com %.5f m, h %.5f m; erect-nominal prediction %+.4f N\n",
                sgn > 0 ? "push (toe)" : "pull (heel)", F_at, F_pred, 100 * err, comx_at, h_at, F_nom);
  }
}

// Establishes: with servos and damping off and the foot held flat the multibody equations are
// conservative (energy drift tiny over 5 s of large-amplitude motion); with passive joint damping
// on, the energy only decreases.
static void test_energy() {
  for (double damp : {0.0, 0.05}) {
    Params P = test_params();
    P.servo_on = false;
    P.damping_ankle = P.damping_hip = damp;
    P.force_flat = true;
    P.theta_ankle_init = 0.1;
    P.theta_hip_init = 0.3;
    P.rtol = 1e-11;
    P.atol = 1e-12;
    Plant p(P);
    CHECK(p.initialize(0.0), "%s", p.message().c_str());
    const double E0 = p.outputs().energy;
    double max_rel = 0, max_increase = 0, Eprev = E0;
    run(p, 5000, [](double, double& a, double& b, double& f) { a = b = f = 0; },
        [&](const Plant& pl) {
          const double E = pl.outputs().energy;
          max_rel = std::max(max_rel, std::fabs(E - E0) / std::fabs(E0));
          max_increase = std::max(max_increase, E - Eprev);
          Eprev = E;
        });
    const double KEmax = 0;  (void)KEmax;
    if (damp == 0.0) {
      CHECK(max_rel < 1e-7, "relative energy drift %g", max_rel);
      std::printf("  no damping: max |E - E0|/|E0| over 5 s = %.2e (E0 = %.4f J, final theta1 %.3f rad)\n",
                  max_rel, E0, p.q()[3]);
    } else {
      CHECK(max_increase < 1e-9, "energy increased by %g J", max_increase);
      CHECK(Eprev < E0 - 0.1, "energy did not decrease: %g -> %g", E0, Eprev);
      std::printf("  damping %.2f N m s/rad: E %.4f -> %.4f J, max increase between samples %.2e J\n",
                  damp, E0, Eprev, max_increase);
    }
  }
}

// Push-and-recover run (push rocks the foot onto the toe and releases): theta_ankle(t).
static std::vector<double> push_run(double rtol, double atol, std::vector<int>* modes = nullptr,
                                    Plant::Result* res = nullptr, double F = 25.0, double dur = 0.06,
                                    int nsteps = 2000, double dt = kDt) {
  Params P = test_params();
  P.rtol = rtol;
  P.atol = atol;
  Plant p(P);
  p.initialize(0.0);
  std::vector<double> traj;
  const auto r = run(p, nsteps, [&](double t, double& a, double& b, double& f) {
        a = b = 0;
        f = (t >= 0.1 - 1e-12 && t < 0.1 + dur - 1e-12) ? F : 0.0;
      },
      [&](const Plant& pl) {
        traj.push_back(pl.outputs().theta_ankle);
        traj.push_back(pl.outputs().foot_pitch);
      },
      dt);
  if (modes)
    for (auto& e : p.history) modes->push_back(e.to);
  if (res) *res = r;
  return traj;
}

// Establishes: the integration error of a push-and-recover run (with toe rocking and landing
// impact) converges with the integrator's tolerances: at every rtol from 1e-4 to 1e-9 it stays
// below rtol (the joint angles are ~0.02 rad), and it falls by more than 100 over the five
// decades (observed order reported). With 10 ms communication steps, so that the tolerance and
// not the communication step limits the integrator's steps (at 1 ms the explicit method is at its
// error floor from rtol 1e-5 on). Not asserted decade by decade: the landing's event timing makes
// single decades non-monotone.
static void test_convergence() {
  const double dt = 0.01;
  const int n = 200;
  const auto ref = push_run(1e-12, 1e-14, nullptr, nullptr, 25.0, 0.06, n, dt);
  double prev = 0, first = 0;
  std::printf("  rtol      max error (theta_ankle, foot_pitch) [rad]   ratio\n");
  for (double rtol : {1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9}) {
    const auto tr = push_run(rtol, rtol * 1e-2, nullptr, nullptr, 25.0, 0.06, n, dt);
    double e = 0;
    CHECK(tr.size() == ref.size(), "length");
    for (size_t i = 0; i < std::min(tr.size(), ref.size()); ++i) e = std::max(e, std::fabs(tr[i] - ref[i]));
    if (prev > 0)
      std::printf("  %.0e   %.3e   %.2f   (observed order in the tolerance %.2f)\n", rtol, e, prev / e,
                  std::log10(prev / e));
    else
      std::printf("  %.0e   %.3e   -\n", rtol, e);
    CHECK(e < rtol, "error %.3g above the tolerance %.0e", e, rtol);
    if (first == 0) first = e;
    prev = e;
  }
  CHECK(prev < first / 100.0, "error fell only from %.3g to %.3g over five decades of tolerance", first, prev);
}

// Establishes: restarting the integrator only where the right-hand side jumps (a changed input,
// an event) costs no accuracy. The inputs hold still, sway (a new set-point every step), hold
// again, and a push rocks the foot onto the toe and lands it; the run is compared against a
// tight-tolerance reference (rtol 1e-12) under the default policy and with a restart forced at
// every communication point (a snapshot marks a restart point), at the default tolerances.
static void test_restarts() {
  auto inputs = [](double t, double& a, double& b, double& f) {
    const double sway = (t >= 0.5 && t < 1.5) ? std::sin(2 * M_PI * (t - 0.5)) : 0.0;
    a = 0.02 * sway;
    b = 0.05 * sway;
    f = (t >= 2.0 - 1e-12 && t < 2.06 - 1e-12) ? 25.0 : 0.0;
  };
  auto trajectory = [&](double rtol, bool restart_every_step, Stats* st) {
    Params P = test_params();
    if (rtol > 0) P.rtol = rtol, P.atol = rtol * 1e-2;
    Plant p(P);
    p.initialize(0.0);
    std::vector<double> tr;
    run(p, 3000, inputs, [&](const Plant& pl) {
      tr.push_back(pl.outputs().theta_ankle);
      tr.push_back(pl.outputs().theta_hip);
      tr.push_back(pl.outputs().foot_pitch);
      if (restart_every_step) (void)pl.snapshot();
    });
    if (st) *st = p.stats();
    return tr;
  };
  const auto ref = trajectory(1e-12, true, nullptr);
  auto err = [&](const std::vector<double>& tr) {
    double e = 0;
    CHECK(tr.size() == ref.size(), "length %zu vs %zu", tr.size(), ref.size());
    for (size_t i = 0; i < std::min(tr.size(), ref.size()); ++i) e = std::max(e, std::fabs(tr[i] - ref[i]));
    return e;
  };
  Stats sp, se;
  const double e_policy = err(trajectory(0, false, &sp)), e_every = err(trajectory(0, true, &se));
  std::printf("  max error vs rtol 1e-12: restart where the RHS jumps %.2e (%lld restarts, %.2f RHS per step), "
              "restart every step %.2e (%lld restarts, %.2f RHS per step)\n",
              e_policy, (long long)sp.reinits, sp.rhs_evals / 3000.0, e_every, (long long)se.reinits, se.rhs_evals / 3000.0);
  CHECK(sp.reinits < se.reinits / 2, "the policy restarted %lld times of %lld", (long long)sp.reinits, (long long)se.reinits);
  CHECK(e_policy <= 2.0 * e_every + 1e-10, "accuracy lost: %.3g vs %.3g with a restart at every step", e_policy, e_every);
  CHECK(e_policy < 1e-6, "error %.3g rad at the default tolerances", e_policy);
}

// Establishes: the flat mode's right-hand side (Model::flat_joint_accelerations, the joints' 2 x 2
// system only) equals the joint accelerations of the full constrained dynamics (Model::dynamics,
// which tests/test_plant_crosscheck.py checks against Pinocchio) at 2 000 random states, set-points
// and pushes, including saturated servos: max relative difference below 1e-12.
static void test_flat_rhs() {
  const Params P = test_params();
  const Model m(P);
  std::uint64_t s = 7;
  auto u = [&s]() { s = s * 6364136223846793005ull + 1442695040888963407ull; return double(s >> 11) * 0x1.0p-53 * 2 - 1; };
  double worst = 0;
  for (int k = 0; k < 2000; ++k) {
    Vec5 q, qd;
    q << 0.0, P.ankle_height, 0.0, 0.4 * u(), 0.8 * u();
    qd << 0.0, 0.0, 0.0, 3.0 * u(), 6.0 * u();
    const double r1 = 0.3 * u(), r2 = 0.6 * u(), push = k % 3 ? 30.0 * u() : 0.0;
    const Vec5 full = m.dynamics(ContactMode::Flat, q, qd, r1, r2, push, Vec2::Zero()).qdd;
    const Vec2 flat = m.flat_joint_accelerations(q, qd, r1, r2, push);
    for (int j = 0; j < 2; ++j)
      worst = std::max(worst, std::fabs(flat[j] - full[3 + j]) / std::max(1.0, std::fabs(full[3 + j])));
  }
  std::printf("  2000 random flat states: max |flat RHS - full dynamics| %.2e (relative)\n", worst);
  CHECK(worst < 1e-12, "flat RHS differs from the full dynamics by %.3g", worst);
}

// Establishes: a push that rocks the foot onto its toe and is released lands the foot flat again
// through the plastic impact map (mode sequence flat -> toe -> flat, foot velocity zero after the
// impact, no bounce, no fall); a too-large push ends in a detected fall (Result::Fallen, state
// stopped at the fall time, later steps refused).
static void test_contact_events() {
  {
    // 25 N for 60 ms: rocks onto the toe (~0.024 rad), lands flat; the body's backward swing after
    // the plastic landing briefly rocks the foot onto the heel (rigid-block rocking), then it settles.
    Params P = test_params();
    Plant p(P);
    p.initialize(0.0);
    double max_pitch = 0;
    const auto r = run(p, 2000, [](double t, double& a, double& b, double& f) {
          a = b = 0;
          f = (t >= 0.1 - 1e-12 && t < 0.16 - 1e-12) ? 25.0 : 0.0;
        },
        [&](const Plant& pl) { max_pitch = std::max(max_pitch, pl.q()[2]); });
    CHECK(r == Plant::Result::Ok, "fell: %s", p.message().c_str());
    const auto& h = p.history;
    CHECK(h.size() >= 2 && h[0].to == 1, "first event is not flat -> toe");
    int landings = 0;
    for (size_t i = 0; i < h.size(); ++i) {
      const bool rocking = h[i].to == 1 || h[i].to == 2;
      CHECK(i % 2 == 0 ? rocking : h[i].to == 0, "mode sequence broken at event %zu", i);
      if (h[i].to == 0) ++landings;
    }
    CHECK(h.size() % 2 == 0 && p.mode() == ContactMode::Flat, "does not end flat");
    CHECK(p.stats().impacts == landings, "impacts %lld vs landings %d", (long long)p.stats().impacts, landings);
    CHECK(p.q()[2] == 0.0 && p.qd()[2] == 0.0 && p.qd()[0] == 0.0 && p.qd()[1] == 0.0, "foot not at rest: %g %g %g %g", p.q()[2], p.qd()[0], p.qd()[1], p.qd()[2]);
    CHECK(max_pitch > 0.01, "hardly rocked: %g", max_pitch);
    std::printf("  25 N x 60 ms push: max foot pitch %.4f rad; mode sequence flat", max_pitch);
    for (auto& e : h) std::printf(" -> %s@%.3f", mode_name(static_cast<ContactMode>(e.to)), e.t);
    std::printf(" (%d plastic landings)\n", landings);
  }
  {
    Params P = test_params();
    Plant p(P);
    p.initialize(0.0);
    std::string log;
    p.logger = [&](const std::string& s) { log += s + "\n"; };
    const auto r = run(p, 3000, [](double t, double& a, double& b, double& f) { a = b = 0; f = (t >= 0.1 && t < 0.4) ? 60.0 : 0; });
    CHECK(r == Plant::Result::Fallen, "no fall detected");
    CHECK(p.fallen() && p.fall_time() > 0.1 && p.fall_time() < 3.0, "fall time %g", p.fall_time());
    CHECK(p.time() == p.fall_time(), "state not at the fall time");
    CHECK(p.do_step(kDt) == Plant::Result::Fallen, "step after fall accepted");
    CHECK(log.find("FALLEN") != std::string::npos, "no log");
    std::printf("  60 N x 0.3 s push: fallen at t = %.6f s (%s)\n", p.fall_time(), p.message().c_str());
  }
}

// Establishes: in the flat mode the ZMP computed from the two sole load cells equals the centre of
// pressure of the constrained dynamics (also during motion); the force outputs are the mean of the
// ground reaction over the communication step, impacts included (1 ms steps against the mean of 64
// sub-steps of the same run, while the reaction ripples by up to 12 N m within a step: the servo's
// set-point jumps every millisecond, and a landing's impulse); noise is deterministic per seed.
static void test_sensors() {
  Params P = test_params();
  Plant p(P);
  p.initialize(0.0);
  double max_err = 0;
  int nflat = 0;
  run(p, 1500, [](double t, double& a, double& b, double& f) { a = 0.03 * std::sin(4 * t); b = 0.1 * std::sin(5 * t); f = t > 0.5 && t < 0.8 ? 5.0 : 0.0; },
      [&](const Plant& pl) {
        if (pl.mode() == ContactMode::Flat) {
          ++nflat;
          max_err = std::max(max_err, std::fabs(pl.outputs().zmp_x - pl.outputs().zmp_true));
        }
      });
  CHECK(nflat == 1500, "left flat mode");
  CHECK(max_err < 1e-12, "sensor zmp vs constrained CoP: %g", max_err);
  std::printf("  flat mode, moving joints + push: max |zmp_sensor - CoP| = %.2e m\n", max_err);
  // The force outputs are the mean over the communication step: a run with the same piecewise-
  // constant set-points in 1 ms steps against the mean of the same run's reaction sampled at 64
  // sub-steps (32 us steps, each output the mean over its own sub-step), with set-points that
  // change every millisecond (a servo ripple within each step) and a push with a rocking landing.
  {
    auto inputs = [](double t, double& a, double& b, double& f) {
      const double tk = std::floor(t * 1000.0 + 1e-6) / 1000.0;  // held over each millisecond
      a = 0.02 * std::sin(4 * tk);
      b = 0.1 * std::sin(5 * tk);
      f = tk >= 0.5 && tk < 0.56 ? 20.0 : 0.0;
    };
    Plant coarse(P), fine(P);
    coarse.initialize(0.0);
    fine.initialize(0.0);
    double worst_fz = 0, worst_m = 0, ripple = 0;
    bool ok = true;
    std::int64_t impacts = 0;
    for (int k = 0; k < 1500 && ok; ++k) {
      double a, b, f;
      inputs(coarse.time(), a, b, f);
      coarse.set_inputs(a, b, f);
      fine.set_inputs(a, b, f);
      ok = coarse.do_step(1e-3) == Plant::Result::Ok;
      CHECK(ok, "%s", coarse.message().c_str());
      double fz = 0, m = 0, lo = 1e9, hi = -1e9;
      for (int j = 0; j < 64 && ok; ++j) {
        ok = fine.do_step(1e-3 / 64) == Plant::Result::Ok;
        CHECK(ok, "%s", fine.message().c_str());
        fz += fine.outputs().fz_true / 64;
        m += fine.outputs().moment_ankle / 64;
        lo = std::min(lo, fine.outputs().moment_ankle);
        hi = std::max(hi, fine.outputs().moment_ankle);
      }
      worst_fz = std::max(worst_fz, std::fabs(coarse.outputs().fz_true - fz));
      worst_m = std::max(worst_m, std::fabs(coarse.outputs().moment_ankle - m));
      ripple = std::max(ripple, hi - lo);
    }
    impacts = coarse.stats().impacts;
    CHECK(impacts > 0, "no landing impact in the run");
    CHECK(worst_fz < 1e-3 && worst_m < 5e-4, "1 ms mean vs mean of 64 sub-steps: fz %g N, moment %g N m", worst_fz,
          worst_m);
    CHECK(ripple > 1000 * worst_m, "no ripple to average (%g N m)", ripple);
    std::printf("  mean over the step: 1 ms vs 64 sub-steps within %.1e N (fz), %.1e N m (moment); ripple within "
                "a step up to %.3f N m\n", worst_fz, worst_m, ripple);
  }
  auto noisy = [](std::uint64_t seed) {
    Params P = test_params();
    P.sensor_noise = 0.5;
    P.seed = seed;
    Plant p(P);
    p.initialize(0.0);
    std::vector<double> v;
    run(p, 2000, [](double, double& a, double& b, double& f) { a = b = f = 0; },
        [&](const Plant& pl) { v.push_back(pl.outputs().f_toe - pl.outputs().fz_true * 0 ); });
    return v;
  };
  const auto a = noisy(7), b = noisy(7), c = noisy(8);
  CHECK(a == b, "same seed differs");
  CHECK(a != c, "different seeds equal");
  double m = 0, s = 0;
  for (double x : a) m += x;
  m /= a.size();
  for (double x : a) s += (x - m) * (x - m);
  s = std::sqrt(s / a.size());
  CHECK(std::fabs(s - 0.5) < 0.05, "noise std %g", s);
  std::printf("  noise 0.5 N: measured std %.3f N, seeded runs reproducible\n", s);
  // off by default; a bias shifts its load cell exactly, and the sensor ZMP follows the biased cells
  CHECK(test_params().sensor_noise == 0 && test_params().sensor_bias_toe == 0 &&
            test_params().sensor_bias_heel == 0, "sensor noise/bias not off by default");
  {
    Params Pb = test_params();
    Pb.sensor_bias_toe = 2.0;
    Pb.sensor_bias_heel = -1.0;
    Plant pc(test_params()), pb(Pb);
    pc.initialize(0.0);
    pb.initialize(0.0);
    const auto &oc = pc.outputs(), &ob = pb.outputs();
    CHECK(std::fabs(ob.f_toe - oc.f_toe - 2.0) < 1e-12 && std::fabs(ob.f_heel - oc.f_heel + 1.0) < 1e-12,
          "bias not applied");
    const double zb = (ob.f_toe * Pb.toe_x + ob.f_heel * Pb.heel_x) / (ob.f_toe + ob.f_heel);
    CHECK(std::fabs(ob.zmp_x - zb) < 1e-15 && std::fabs(ob.zmp_x - oc.zmp_x) > 1e-3, "biased zmp %g", ob.zmp_x);
    std::printf("  bias (+2 N toe, -1 N heel): zmp_x %.5f m (unbiased %.5f m)\n", ob.zmp_x, oc.zmp_x);
  }
}

// Establishes: a snapshot taken mid-run (during toe rocking) and restored into a fresh instance
// continues bit for bit like the uninterrupted run (integrator re-initialized identically).
static void test_snapshot() {
  // the hip set-point changes every 0.1 s: the integrator both continues and restarts after the snapshot
  auto inputs = [](double t, double& a, double& b, double& f) { a = 0; b = 0.02 * std::floor(10 * t); f = (t >= 0.1 && t < 0.16) ? 25.0 : 0; };
  Params P = test_params();
  P.sensor_noise = 0.3;
  Plant p(P);
  p.initialize(0.0);
  run(p, 180, inputs);
  const Snapshot s = p.snapshot();
  CHECK(p.mode() == ContactMode::Toe, "snapshot not during rocking (mode %d)", (int)p.mode());
  std::vector<double> A, B;
  run(p, 800, inputs, [&](const Plant& pl) { A.push_back(pl.outputs().theta_ankle); A.push_back(pl.outputs().zmp_x); });
  Plant p2(P);
  p2.initialize(0.0);
  CHECK(p2.restore(s), "restore failed");
  run(p2, 800, inputs, [&](const Plant& pl) { B.push_back(pl.outputs().theta_ankle); B.push_back(pl.outputs().zmp_x); });
  CHECK(A.size() == B.size() && std::memcmp(A.data(), B.data(), A.size() * sizeof(double)) == 0, "not bit-identical");
  std::printf("  restored run bit-identical over %zu samples\n", A.size() / 2);
}


// Whole-system angular momentum about the ground point c (about +y, the foot-pitch sense).
static double ang_mom(const Model& m, const Vec5& q, const Vec5& qd, const Vec2& c) {
  Kinematics k;
  m.kinematics(q, qd, k);
  const double mass[3] = {m.P.feet_mass, m.P.m1, m.P.m2}, I[3] = {m.P.feet_inertia, m.P.I1, m.P.I2};
  double H = 0;
  for (int i = 0; i < 3; ++i) {
    const Vec2 v = k.J[i] * qd, r = k.p[i] - c;
    double w = 0;
    for (int j = 0; j < 5; ++j) w += k.s[i][j] * qd[j];
    H += I[i] * w + mass[i] * (r.y() * v.x() - r.x() * v.y());
  }
  return H;
}

// Establishes: the plastic impact maps conserve the right momenta.
// (a) Edge touch-down from the air (a point impact at the edge): the whole robot's angular
//     momentum about the touching edge is conserved, the edge stops (no bounce), the normal
//     impulse pushes (edge arriving vertically), the joints' conjugate momenta (M qd)_theta1,theta2 are conserved (servo
//     torques are finite: no impulsive joint torque), and kinetic energy is lost.
// (b) Landing flat from toe/heel rocking: the foot stops completely; (M qd)_theta1,theta2 are
//     conserved; the impulse's centre of pressure lies inside the sole (both edges push, so the
//     full-sole plastic stop is the consistent solution of the two-contact impact problem); the
//     angular momentum about that impulsive CoP point is conserved; kinetic energy is lost. A
//     landing-edge-only impulse (angular momentum about the landing edge conserved) would leave the
//     foot rotating back into the ground at the other edge - which is why that edge shares the
//     impulse (so the angular momentum about the landing edge alone is NOT the invariant here).
static void test_impact() {
  const Params P = test_params();
  const Model m(P);
  std::uint64_t s = 12345;
  auto U = [&]() {  // uniform in (-1, 1)
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return (static_cast<double>(s >> 11) * 0x1.0p-53) * 2.0 - 1.0;
  };
  double worst_H = 0, worst_p = 0, worst_stop = 0;
  for (int k = 0; k < 200; ++k) {
    // (a) airborne, an edge at the ground moving down
    const bool toe = k % 2 == 0;
    const double cx = toe ? P.toe_x : P.heel_x;
    Vec5 q, qd;
    q << 0.02 * U(), 0, (toe ? 1 : -1) * 0.02 * (1.5 + U()), 0.3 * U(), 0.6 * U();
    q[1] = -m.foot_point(Vec5(0, 0, q[2], 0, 0), cx, -P.ankle_height).y();  // edge exactly at z = 0
    qd << 0.3 * U(), -0.3 * (1.2 + U()), 1.0 * U(), 2.0 * U(), 3.0 * U();
    Eigen::Matrix<double, 2, 5> J;
    Vec2 bias;
    m.foot_point_jac(q, qd, cx, -P.ankle_height, J, bias);
    // the edge arrives vertically (no tangential velocity): a sticking plastic impact then always
    // pushes. (With a large tangential arrival velocity the sticking impulse can pull - see
    // docs/plant.md, known simplifications; the plant logs a warning when that happens.)
    qd[0] -= (J * qd).x();
    if ((J * qd).y() >= 0) continue;
    const Vec2 edge = m.foot_point(q, cx, -P.ankle_height);
    const Vec5 qp = m.impact(toe ? ContactMode::Toe : ContactMode::Heel, q, qd);
    Mat5 M;
    Vec5 h;
    m.mass_bias(q, qd, M, h);
    const double H0 = ang_mom(m, q, qd, edge), H1 = ang_mom(m, q, qp, edge);
    const double scale = std::sqrt(qd.dot(M * qd));
    worst_H = std::max(worst_H, std::fabs(H1 - H0) / scale);
    const Vec5 dp = M * (qp - qd);
    worst_p = std::max({worst_p, std::fabs(dp[3]) / scale, std::fabs(dp[4]) / scale});
    worst_stop = std::max(worst_stop, (J * qp).norm());
    CHECK(dp[1] > 0, "touch-down impulse pulls: %g", dp[1]);
    CHECK(m.kinetic_energy(q, qp) < m.kinetic_energy(q, qd), "touch-down gained energy");
  }
  CHECK(worst_H < 1e-12, "touch-down: angular momentum about the edge changed by %g", worst_H);
  CHECK(worst_p < 1e-12, "touch-down: joint momenta changed by %g", worst_p);
  CHECK(worst_stop < 1e-12, "touch-down: edge velocity after impact %g", worst_stop);
  std::printf("  edge touch-down (200 random states): max |dH_edge| %.1e, max |d(M qd)_joints| %.1e "
              "(relative), edge speed after %.1e m/s\n", worst_H, worst_p, worst_stop);

  double worst_H2 = 0, worst_p2 = 0, cop_min = 1, cop_max = -1, min_other = 1e9;
  for (int k = 0; k < 200; ++k) {
    // (b) rocking on the toe (k even) or heel, foot back at phi = 0, rotating into the ground
    const bool toe = k % 2 == 0;
    const double cx = toe ? P.toe_x : P.heel_x;
    Vec5 q, qd;
    q << 0, P.ankle_height, 0, 0.3 * U(), 0.6 * U();
    qd << 0, 0, (toe ? -1 : 1) * 0.6 * (1.05 + U()), 2.0 * U(), 3.0 * U();
    Eigen::Matrix<double, 2, 5> J;
    Vec2 bias;
    m.foot_point_jac(q, qd, cx, -P.ankle_height, J, bias);
    const Vec2 ve = J * qd;  // make the pivot edge's velocity zero
    qd[0] -= ve.x();
    qd[1] -= ve.y();
    const Vec5 qp = m.impact(ContactMode::Flat, q, qd);
    CHECK(qp[0] == 0 && qp[1] == 0 && qp[2] == 0, "foot not stopped");
    Mat5 M;
    Vec5 h;
    m.mass_bias(q, qd, M, h);
    const Vec5 dp = M * (qp - qd);
    const double scale = std::sqrt(qd.dot(M * qd));
    worst_p2 = std::max({worst_p2, std::fabs(dp[3]) / scale, std::fabs(dp[4]) / scale});
    const double cop = -(dp[2] + P.ankle_height * dp[0]) / dp[1];  // impulsive CoP from the ankle
    cop_min = std::min(cop_min, cop);
    cop_max = std::max(cop_max, cop);
    CHECK(dp[1] > 0 && cop > P.heel_x && cop < P.toe_x, "landing impulse CoP %g outside the sole", cop);
    const Vec2 c(cop, 0.0);
    worst_H2 = std::max(worst_H2, std::fabs(ang_mom(m, q, qp, c) - ang_mom(m, q, qd, c)) / scale);
    CHECK(m.kinetic_energy(q, qp) < m.kinetic_energy(q, qd), "landing gained energy");
    // landing-edge-only impulse: the foot would keep rotating into the ground about that edge
    const Vec5 qe = m.impact(toe ? ContactMode::Heel : ContactMode::Toe, q, qd);
    min_other = std::min(min_other, toe ? qe[2] : -qe[2]);
  }
  CHECK(worst_p2 < 1e-12, "landing: joint momenta changed by %g", worst_p2);
  CHECK(worst_H2 < 1e-12, "landing: angular momentum about the impulsive CoP changed by %g", worst_H2);
  CHECK(min_other > 0, "a landing-edge-only impulse would be consistent (%g)", min_other);
  std::printf("  flat landing (200 random rocking states): max |d(M qd)_joints| %.1e, max |dH_cop| %.1e "
              "(relative); impulsive CoP in [%.4f, %.4f] m (sole [%.4f, %.4f]); edge-only impulse "
              "leaves the foot rotating into the ground (min %.3f rad/s)\n",
              worst_p2, worst_H2, cop_min, cop_max, P.heel_x, P.toe_x, min_other);
}

// Establishes: the airborne mode and the events into and out of it. (a) Dropped from 10 mm with
// the foot pitched toes-down, the robot (servos holding it erect) flies ballistically - its CoM
// follows the free-fall parabola exactly - touches down on the toe (root on the toe height,
// plastic point impact), rocks, lands flat and stands (fz = m g). (b) The toe-to-airborne root:
// with the fall thresholds relaxed, a 60 N push topples the robot about its toe until the toe's
// normal force reaches zero (the root), and the foot leaves the ground before the fall is detected.
static void test_airborne() {
  {
    Params P = test_params();
    P.rtol = 1e-10;
    P.atol = 1e-12;
    Plant p(P);
    CHECK(p.initialize(0.0), "%s", p.message().c_str());
    Snapshot s = p.snapshot();
    const double phi0 = 0.05;
    Vec5 q0;
    q0 << 0, 0, phi0, 0, 0;
    q0[1] = 0.010 - p.model().foot_point(q0, P.toe_x, -P.ankle_height).y();  // toe 10 mm up
    const double vx0 = 0.05, vz0 = 0.1;
    for (int i = 0; i < 5; ++i) s.y[i] = q0[i];
    for (int i = 0; i < 5; ++i) s.y[5 + i] = 0;
    s.y[5] = vx0;
    s.y[6] = vz0;
    s.mode = static_cast<int>(ContactMode::Airborne);
    CHECK(p.restore(s), "restore");
    const Vec2 c0 = p.model().com(q0);
    double max_dev = 0, t_touch = -1;
    const auto r = run(p, 3000, [](double, double& a, double& b, double& f) { a = b = f = 0; },
                       [&](const Plant& pl) {
                         if (pl.mode() != ContactMode::Airborne) {
                           if (t_touch < 0) t_touch = pl.time();
                           return;
                         }
                         const double t = pl.time();
                         const Vec2 c = pl.model().com(pl.q());
                         const Vec2 ballistic(c0.x() + vx0 * t, c0.y() + vz0 * t - 0.5 * P.g * t * t);
                         max_dev = std::max(max_dev, (c - ballistic).norm());
                       });
    CHECK(r == Plant::Result::Ok, "%s", p.message().c_str());
    const auto& h = p.history;
    CHECK(!h.empty() && h[0].from == 3 && h[0].to == 1, "first event is not airborne -> toe");
    CHECK(t_touch > 0.05 && t_touch < 0.1, "touch-down at %g s", t_touch);  // 10 mm up at 0.1 m/s
    CHECK(max_dev < 1e-8, "CoM deviates from the ballistic parabola by %g m", max_dev);
    CHECK(p.mode() == ContactMode::Flat && p.stats().impacts >= 2, "mode %d, impacts %lld", (int)p.mode(),
          (long long)p.stats().impacts);
    CHECK(std::fabs(p.outputs().fz - P.mass() * P.g) < 1e-6 * P.mass() * P.g, "fz %g", p.outputs().fz);
    std::printf("  drop from 10 mm: flight %.4f s, max |CoM - ballistic| %.1e m; sequence airborne",
                h.empty() ? 0.0 : h[0].t, max_dev);
    for (auto& e : h) std::printf(" -> %s@%.3f", mode_name(static_cast<ContactMode>(e.to)), e.t);
    std::printf(" (%lld impacts), stands with fz = m g\n", (long long)p.stats().impacts);
  }
  {
    Params P = test_params();
    P.fall_foot_pitch = P.fall_body_pitch = 1.5;
    Plant p(P);
    p.initialize(0.0);
    const auto r = run(p, 3000, [](double t, double& a, double& b, double& f) { a = b = 0; f = (t >= 0.1 && t < 0.4) ? 60.0 : 0; });
    int lift = -1;
    for (size_t i = 0; i < p.history.size() && lift < 0; ++i)
      if (p.history[i].from == 1 && p.history[i].to == 3) lift = static_cast<int>(i);
    CHECK(lift >= 0 && std::string(p.history[lift].why) == "edge normal force reached zero",
          "no toe lift-off by the root function");
    CHECK(r == Plant::Result::Fallen, "no fall");
    if (lift >= 0)
      std::printf("  60 N push, thresholds 1.5 rad: toe lift-off (root) at t = %.4f s, fallen at %.4f s\n",
                  p.history[lift].t, p.fall_time());
  }
}

// ---- rigid-body rocking (Housner) -------------------------------------------------------------
// The robot with its joints frozen at q (phi = 0): total mass, CoM (x from the ankle axis, z above
// the ground) and pitch inertia about the CoM.
struct Rigid {
  double m = 0, cx = 0, cz = 0, Ic = 0;
};
static Rigid rigid_body(const Model& m, Vec5 q) {
  q[0] = 0;
  q[1] = m.P.ankle_height;
  q[2] = 0;
  Kinematics k;
  m.kinematics(q, Vec5::Zero(), k);
  const double mass[3] = {m.P.feet_mass, m.P.m1, m.P.m2}, I[3] = {m.P.feet_inertia, m.P.I1, m.P.I2};
  Rigid r;
  r.m = m.P.mass();
  for (int i = 0; i < 3; ++i) r.cx += mass[i] * k.p[i].x() / r.m, r.cz += mass[i] * k.p[i].y() / r.m;
  for (int i = 0; i < 3; ++i) r.Ic += I[i] + mass[i] * (k.p[i] - Vec2(r.cx, r.cz)).squaredNorm();
  return r;
}
// Housner's coefficient: a rigid body rotating about edge A lands on edge B; the angular momentum
// about B is conserved, so omega+ / omega- = (Ic + m (c - B).(c - A)) / (Ic + m |c - B|^2).
static double housner_r(const Rigid& b, double xa, double xb) {
  return (b.Ic + b.m * ((b.cx - xb) * (b.cx - xa) + b.cz * b.cz)) /
         (b.Ic + b.m * ((b.cx - xb) * (b.cx - xb) + b.cz * b.cz));
}
// Rocking about the edge at x = xp by the foot pitch phi, the CoM height is R cos(phi + beta) with
// R = |c - P|, sin beta = (cx - xp)/R. Energy between impacts: (1/2) I_P w^2 = m g (height rise).
static double rigid_rate2(const Rigid& b, double xp, double phi_peak, double g) {  // w^2 at phi = 0
  const double dx = b.cx - xp, R = std::hypot(dx, b.cz), beta = std::asin(dx / R);
  return 2.0 * b.m * g * (R * std::cos(phi_peak + beta) - b.cz) / (b.Ic + b.m * R * R);
}
static double rigid_peak(const Rigid& b, double xp, double w2, double g) {  // next |phi| peak
  const double dx = b.cx - xp, R = std::hypot(dx, b.cz), beta = std::asin(dx / R);
  const double Z = b.cz + (b.Ic + b.m * R * R) * w2 / (2.0 * b.m * g);
  return Z >= R ? NAN : std::fabs(beta) - std::acos(Z / R);
}

// Establishes the range of the two impact laws (docs/plant.md section 3, "Which landing law").
// (a) The locked-joint law is Housner's: at 200 random rigid rocking states (joints frozen, foot
//     rotating about one edge) a landing multiplies the foot's pitch rate by Housner's coefficient
//     computed from the robot's mass distribution, and the robot rocks on over the other edge.
// (b) Dynamically, with servos stiffened from kp = 1e3 to 1e5 N m/rad, the locked law converges to
//     rigid-body rocking: each rocking amplitude follows from the previous one by energy
//     conservation and Housner's coefficient, with an error that falls as the servos stiffen. The
//     free-joint law (default) does not converge to it: it loses less energy at each landing,
//     because the joints keep their momenta through the impact. The free law is the right limit
//     when the servos are slow compared with the impact (the default servos, 28-40 rad/s, against
//     impacts of a few ms), the locked law when they are much faster.
static void test_rocking() {
  const Params P0 = test_params();
  {
    Params P = P0;
    P.lock_joints_at_impact = true;
    const Model m(P);
    std::uint64_t s = 777;
    auto U = [&]() {
      s = s * 6364136223846793005ull + 1442695040888963407ull;
      return (static_cast<double>(s >> 11) * 0x1.0p-53) * 2.0 - 1.0;
    };
    double worst = 0;
    for (int k = 0; k < 200; ++k) {
      const bool toe = k % 2 == 0;  // rocking on the toe, landing on the heel (or vice versa)
      const double xa = toe ? P.toe_x : P.heel_x, xb = toe ? P.heel_x : P.toe_x;
      Vec5 q, qd = Vec5::Zero();
      q << 0, P.ankle_height, 0, 0.2 * U(), 0.4 * U();
      qd[2] = (toe ? -1 : 1) * (0.5 + 0.4 * U());  // rotating back into the ground
      Eigen::Matrix<double, 2, 5> J;
      Vec2 bias;
      m.foot_point_jac(q, qd, xa, -P.ankle_height, J, bias);
      const Vec2 ve = J * qd;  // rotation about edge A
      qd[0] -= ve.x();
      qd[1] -= ve.y();
      const Vec5 qp = m.impact(toe ? ContactMode::Heel : ContactMode::Toe, q, qd);
      const double r = housner_r(rigid_body(m, q), xa, xb);
      worst = std::max(worst, std::fabs(qp[2] / qd[2] - r));
      CHECK(qp[3] == qd[3] && qp[4] == qd[4], "joint rates changed");
      CHECK(r > 0, "Housner coefficient %g <= 0: the robot would not rock on", r);
    }
    CHECK(worst < 1e-12, "locked-joint landing vs Housner: max |ratio - r| = %g", worst);
    std::printf("  locked-joint landing at 200 rigid rocking states: max |phi'+/phi'- - r_Housner| = %.1e\n", worst);
  }
  // (b) rocking after a 25 N x 60 ms push, sampled every 0.1 ms
  const double J_ankle = P0.I1 + P0.m1 * P0.lg1 * P0.lg1 + P0.I2 + P0.m2 * (P0.l1 + P0.lg2) * (P0.l1 + P0.lg2);
  const double J_hip = P0.I2 + P0.m2 * P0.lg2 * P0.lg2;
  double err[2][3] = {};
  const double Ks[3] = {1e3, 1e4, 1e5};
  for (int locked = 0; locked < 2; ++locked) {
    for (int ik = 0; ik < 3; ++ik) {
      Params P = P0;
      P.lock_joints_at_impact = locked;
      P.kp_ankle = P.kp_hip = Ks[ik];
      P.kd_ankle = 2 * 0.7 * std::sqrt(Ks[ik] * J_ankle);
      P.kd_hip = 2 * 0.7 * std::sqrt(Ks[ik] * J_hip);
      P.tau_max_ankle = P.tau_max_hip = P.vel_max_ankle = P.vel_max_hip = 1e4;
      P.rtol = 1e-10;
      P.atol = 1e-12;
      Plant p(P);
      CHECK(p.initialize(0.0), "%s", p.message().c_str());
      struct Peak { double phi; Vec5 q; };
      std::vector<Peak> peaks;
      Peak cur{0, Vec5::Zero()};
      for (int i = 0; i < 15000; ++i) {
        p.set_inputs(0, 0, p.time() < 0.06 ? 25.0 : 0.0);
        if (p.do_step(1e-4) != Plant::Result::Ok) break;
        const double phi = p.q()[2];
        if (phi * cur.phi < 0 || (phi == 0 && cur.phi != 0)) {   // back at flat: excursion ends
          if (std::fabs(cur.phi) > 2e-3) peaks.push_back(cur);
          cur = Peak{0, Vec5::Zero()};
        }
        if (std::fabs(phi) > std::fabs(cur.phi)) cur = Peak{phi, p.q()};
      }
      // predicted next peak from each peak after the push: energy + Housner (+ rigid body)
      double worst = 0;
      int pairs = 0;
      for (size_t j = 0; j + 1 < peaks.size(); ++j) {
        if (peaks[j].phi * peaks[j + 1].phi >= 0) continue;
        const Rigid b = rigid_body(p.model(), peaks[j].q);
        const bool toe = peaks[j].phi > 0;
        const double xa = toe ? P.toe_x : P.heel_x, xb = toe ? P.heel_x : P.toe_x;
        const double r = housner_r(b, xa, xb);
        const double w2 = rigid_rate2(b, xa, peaks[j].phi, P.g);
        const double pred = rigid_peak(b, xb, r * r * w2, P.g);
        const double e = std::fabs(std::fabs(peaks[j + 1].phi) - pred) / pred;
        if (pairs == 0)
          std::printf("  %s joints, kp %.0e: first landing %+.2f -> %+.2f mrad (rigid body %.2f mrad, r = %.4f)\n",
                      locked ? "locked" : "free  ", Ks[ik], 1e3 * peaks[j].phi, 1e3 * peaks[j + 1].phi, 1e3 * pred, r);
        worst = std::max(worst, e);
        ++pairs;
      }
      CHECK(pairs >= 2, "%s, kp %g: only %d rocking cycles", locked ? "locked" : "free", Ks[ik], pairs);
      err[locked][ik] = worst;
    }
    std::printf("  %s joints: max relative error of the rocking amplitudes vs the rigid body: %.2f %% (kp 1e3), "
                "%.2f %% (1e4), %.2f %% (1e5)\n", locked ? "locked" : "free  ", 100 * err[locked][0],
                100 * err[locked][1], 100 * err[locked][2]);
  }
  CHECK(err[1][2] < err[1][1] && err[1][1] < err[1][0], "locked law does not converge with the servo stiffness");
  CHECK(err[1][2] < 0.01, "locked law, kp 1e5: %.3g relative error vs rigid-body rocking", err[1][2]);
  CHECK(err[0][2] > 3 * err[1][2], "free law unexpectedly close to rigid-body rocking (%.3g)", err[0][2]);
}

int main(int argc, char** argv) {
  const std::string which = argc > 1 ? argv[1] : "all";
  const std::string integrator = argc > 2 ? argv[2] : "erk";
  if (integrator != "erk" && integrator != "bdf") { std::printf("unknown integrator %s (erk | bdf)\n", integrator.c_str()); return 2; }
  g_integrator = integrator == "bdf" ? Integrator::Bdf : Integrator::Erk;
  std::printf("integrator: %s\n", integrator.c_str());
  struct T { const char* name; void (*fn)(); } tests[] = {
      {"static_standing", test_static_standing}, {"tipping", test_tipping}, {"energy", test_energy},
      {"convergence", test_convergence}, {"restarts", test_restarts}, {"flat_rhs", test_flat_rhs}, {"contact_events", test_contact_events}, {"sensors", test_sensors},
      {"snapshot", test_snapshot}, {"impact", test_impact}, {"airborne", test_airborne},
      {"rocking", test_rocking}};
  bool ran = false;
  for (auto& t : tests)
    if (which == "all" || which == t.name) {
      std::printf("[%s]\n", t.name);
      t.fn();
      ran = true;
    }
  if (!ran) { std::printf("unknown test %s\n", which.c_str()); return 2; }
  std::printf(g_fail ? "FAILED (%d)\n" : "OK\n", g_fail);
  return g_fail ? 1 : 0;
}
