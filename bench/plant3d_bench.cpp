// 3D plant benchmark (not a test): 10 s at 1 ms communication steps (standing, a 13 N x 150 ms
// push that rocks the robot onto its toes at 2 s, an 8 N x 1 s push at 5 s), for several internal
// ODE steps side by side. Prints simulated seconds per wall second, ODE steps per communication
// step and the median / p99 wall time of one communication step.
// Build: cmake --build <dir> --target plant3d_bench
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "hoap2plant3d/plant3d.hpp"

using namespace hoap2plant3d;

int main() {
  std::printf("%12s %14s %14s %12s %12s\n", "step [ms]", "ODE steps/1ms", "sim s/wall s", "median [us]",
              "p99 [us]");
  for (double step : {2.5e-4, 5e-4, 1e-3}) {
    Params P = default_params();
    P.internal_step = step;
    Plant3D p(P);
    if (!p.initialize(0.0)) {
      std::printf("initialize failed: %s\n", p.message().c_str());
      return 1;
    }
    const double dt = 1e-3;
    const int n = 10000;
    std::vector<double> us(n);
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
      us[i] = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - a).count();
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::sort(us.begin(), us.end());
    std::printf("%12.3g %14.2f %14.2f %12.1f %12.1f\n", 1e3 * step,
                double(p.stats().ode_steps) / n, n * dt / wall, us[n / 2], us[n * 99 / 100]);
  }
  return 0;
}
