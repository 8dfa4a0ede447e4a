// 3D plant benchmark (not a test): 10 s at 1 ms communication steps (standing, a 13 N x 150 ms
// push that rocks the robot onto its toes at 2 s, an 8 N x 1 s push at 5 s), for several internal
// ODE steps side by side (the default marked). Prints simulated seconds per wall second, ODE steps
// per communication step (re-solved steps included; medians of 3 runs; re-solves per 1000 steps: steps solved again
// with torque and friction limits) and the median / p99 wall time of one communication step.
// Build: cmake --build <dir> --target plant3d_bench
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "hoap2plant3d/plant3d.hpp"

using namespace hoap2plant3d;

int main() {
  std::printf("%14s %14s %14s %14s %12s %12s\n", "step [ms]", "ODE steps/1ms", "re-solves/1k", "sim s/wall s",
              "median [us]", "p99 [us]");
  for (double step : {2.5e-4, 5e-4, 1e-3}) {
    Params P = default_params();
    P.internal_step = step;
    const double dt = 1e-3;
    const int n = 10000, repeats = 3;
    std::vector<double> us, speed;  // per-step wall times of all repeats; sim s / wall s of each
    Stats st;
    for (int r = 0; r < repeats; ++r) {
      Plant3D p(P);
      if (!p.initialize(0.0)) {
        std::printf("initialize failed: %s\n", p.message().c_str());
        return 1;
      }
      const auto t0 = std::chrono::steady_clock::now();
      for (int i = 0; i < n; ++i) {
        const double t = p.time();
        Inputs u;
        if (t >= 2.0 && t < 2.15) u.push_x = 13.0;
        if (t >= 5.0 && t < 6.0) u.push_x = 8.0;
        p.set_inputs(u);
        const auto a = std::chrono::steady_clock::now();
        if (p.do_step(dt) != Plant3D::Result::Ok) {
          std::printf("step failed: %s\n", p.message().c_str());
          return 1;
        }
        us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - a).count());
      }
      speed.push_back(n * dt / std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      st = p.stats();
    }
    std::sort(us.begin(), us.end());
    std::sort(speed.begin(), speed.end());
    std::printf("%4s %9.3g %14.2f %14.1f %14.2f %12.1f %12.1f\n", step == default_params().internal_step ? "def" : "",
                1e3 * step, double(st.ode_steps) / n, 1e3 * double(st.resolves) / double(st.ode_steps),
                speed[repeats / 2], us[us.size() / 2], us[us.size() * 99 / 100]);
  }
  return 0;
}
