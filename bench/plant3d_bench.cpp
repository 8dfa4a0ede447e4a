// 3D plant benchmark (not a test): 10 s at 1 ms communication steps (standing, a 13 N x 150 ms
// push that rocks the robot onto its toes at 2 s, an 8 N x 1 s push at 5 s), in several
// configurations side by side: the default (feet held flat, 1 ms flat steps, 0.25 ms rocking
// steps), the same with the feet never held, the default's steps halved, and the previous
// release's configuration (corner contacts of 2e5 N/m and 1e3 N s/m, 0.5 ms steps, feet never
// held). Prints simulated seconds per CPU second over the whole run and over the first 2 s
// (standing), ODE steps per communication step (re-solved and re-taken steps included), re-solves
// per 1000 steps (steps solved again with torque, friction or contact limits) and the median / p99
// time of one communication step. The rates are the thread's CPU time over whole runs (medians of
// 3; CLOCK_THREAD_CPUTIME_ID, unaffected by other processes; on a quiet machine the wall time); it
// is read only at the start, after the standing part and at the end, because one reading is a
// system call of about 0.6 us, a tenth of a standing step. The per-step times come from one more
// run timed by the monotonic clock (vDSO, tens of ns): wall time, as a real-time loop sees it.
// Build: cmake --build <dir> --target plant3d_bench
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include "hoap2plant3d/plant3d.hpp"

using namespace hoap2plant3d;

namespace {
double seconds(clockid_t clock) {
  timespec ts;
  clock_gettime(clock, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

Inputs bench_inputs(double t) {  // two pushes: one rocks the robot onto its toes, one it stands
  Inputs u;
  if (t >= 2.0 && t < 2.15) u.push_x = 13.0;
  if (t >= 5.0 && t < 6.0) u.push_x = 8.0;
  return u;
}

struct Config {
  const char* name;
  Params P;
};

Config make(const char* name, void (*edit)(Params&)) {
  Params P = default_params();
  edit(P);
  return {name, P};
}
}  // namespace

int main() {
  const Config configs[] = {
      make("default", [](Params&) {}),
      make("feet never held", [](Params& p) { p.flat_foot_weld = false; }),
      make("steps halved", [](Params& p) { p.internal_step *= 0.5; p.rocking_step *= 0.5; }),
      make("previous release", [](Params& p) {
        p.contact_stiffness = 2e5;
        p.contact_damping = 1e3;
        p.internal_step = p.rocking_step = 5e-4;
        p.flat_foot_weld = false;
      }),
  };
  std::printf("%-18s %14s %14s %14s %14s %12s %12s\n", "configuration", "sim s/CPU s", "standing", "ODE steps/1ms",
              "re-solves/1k", "median [us]", "p99 [us]");
  for (const Config& c : configs) {
    const double dt = 1e-3;
    const int n = 10000, repeats = 3, n_stand = 2000;
    std::vector<double> speed, stand, us;  // sim s / CPU s of each run; per-step wall times [us]
    Stats st;
    for (int r = 0; r <= repeats; ++r) {  // runs 0..repeats-1: rates; the last: per-step times
      const bool per_step = r == repeats;
      Plant3D p(c.P);
      if (!p.initialize(0.0)) {
        std::printf("initialize failed: %s\n", p.message().c_str());
        return 1;
      }
      const double t0 = seconds(CLOCK_THREAD_CPUTIME_ID);
      double t_stand = t0;
      for (int i = 0; i < n; ++i) {
        if (i == n_stand && !per_step) t_stand = seconds(CLOCK_THREAD_CPUTIME_ID);
        p.set_inputs(bench_inputs(p.time()));
        const double a = per_step ? seconds(CLOCK_MONOTONIC) : 0.0;
        if (p.do_step(dt) != Plant3D::Result::Ok) {
          std::printf("step failed: %s\n", p.message().c_str());
          return 1;
        }
        if (per_step) us.push_back(1e6 * (seconds(CLOCK_MONOTONIC) - a));
      }
      if (!per_step) {
        const double t1 = seconds(CLOCK_THREAD_CPUTIME_ID);
        speed.push_back(n * dt / (t1 - t0));
        stand.push_back(n_stand * dt / (t_stand - t0));
      }
      st = p.stats();
    }
    std::sort(us.begin(), us.end());
    std::sort(speed.begin(), speed.end());
    std::sort(stand.begin(), stand.end());
    std::printf("%-18s %14.1f %14.1f %14.2f %14.1f %12.1f %12.1f\n", c.name, speed[repeats / 2], stand[repeats / 2],
                double(st.ode_steps) / n, 1e3 * double(st.resolves) / double(st.ode_steps), us[us.size() / 2],
                us[us.size() * 99 / 100]);
  }
  return 0;
}
