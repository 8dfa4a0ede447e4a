// 3D plant benchmark (not a test): 10 s at 1 ms communication steps (standing, a 13 N x 150 ms
// push that rocks the robot onto its toes at 2 s, an 8 N x 1 s push at 5 s), in several
// configurations side by side: the default (feet held flat, 1 ms flat steps, 0.25 ms rocking
// steps), the same with the feet never held, the default's steps halved, and the previous
// release's configuration (corner contacts of 2e5 N/m and 1e3 N s/m, 0.5 ms steps, feet never
// held). Prints simulated seconds per wall second over the whole run and over the first 2 s
// (standing), ODE steps per communication step (re-solved and re-taken steps included), re-solves
// per 1000 steps (steps solved again with torque, friction or contact limits) and the median / p99
// time of one communication step; medians of 3 runs. Times are the thread's CPU time
// (CLOCK_THREAD_CPUTIME_ID): on a quiet machine the wall time, and unaffected by other processes.
// Build: cmake --build <dir> --target plant3d_bench
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include "hoap2plant3d/plant3d.hpp"

using namespace hoap2plant3d;

namespace {
double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
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
    std::vector<double> us, speed, stand;  // per-step wall times of all repeats; sim s / wall s of each
    Stats st;
    for (int r = 0; r < repeats; ++r) {
      Plant3D p(c.P);
      if (!p.initialize(0.0)) {
        std::printf("initialize failed: %s\n", p.message().c_str());
        return 1;
      }
      const double t0 = cpu_seconds();
      double stand_s = 0;
      for (int i = 0; i < n; ++i) {
        const double t = p.time();
        Inputs u;
        if (t >= 2.0 && t < 2.15) u.push_x = 13.0;
        if (t >= 5.0 && t < 6.0) u.push_x = 8.0;
        p.set_inputs(u);
        const double a = cpu_seconds();
        if (p.do_step(dt) != Plant3D::Result::Ok) {
          std::printf("step failed: %s\n", p.message().c_str());
          return 1;
        }
        const double w = 1e6 * (cpu_seconds() - a);
        us.push_back(w);
        if (i < n_stand) stand_s += 1e-6 * w;
      }
      speed.push_back(n * dt / (cpu_seconds() - t0));
      stand.push_back(n_stand * dt / stand_s);
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
