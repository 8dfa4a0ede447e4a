// Plant benchmark (not a test): 10 s at 1 ms communication steps on two input profiles.
//   standing  - constant set-points; a 25 N x 60 ms push at 2 s (rocks the foot onto the toe and
//               lands it) and an 8 N x 1 s push at 5 s: the right-hand side jumps 4 times.
//   tracking  - the same pushes, with set-points that change at every communication step (a
//               0.5 Hz sway of 0.02 rad at the ankle and 0.05 rad at the hip), as in the closed
//               loop, where the controller's outputs change in most steps.
// Prints simulated seconds per wall second, RHS evaluations and CVODE steps per communication
// step, and the median / p99 wall time of one step.
//   build/plant/plant_bench [standing|tracking|all] [--repeat N]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "hoap2plant/plant.hpp"

using namespace hoap2plant;

static int bench(const char* profile, bool tracking) {
  Params P = default_params();
  Plant p(P);
  if (!p.initialize(0.0)) { std::printf("initialize failed: %s\n", p.message().c_str()); return 1; }
  const double dt = 1e-3, w = 2 * 3.14159265358979323846 * 0.5;
  const int n = 10000;
  std::vector<double> us(n);
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) {
    const double t = i * dt;
    double f = 0;
    if (t >= 2.0 && t < 2.06) f = 25.0;
    if (t >= 5.0 && t < 6.0) f = 8.0;
    const double s = tracking ? std::sin(w * t) : 0.0;
    p.set_inputs(0.02 * s, 0.05 * s, f);
    const auto a = std::chrono::steady_clock::now();
    if (p.do_step(dt) != Plant::Result::Ok) { std::printf("%s: step failed: %s\n", profile, p.message().c_str()); return 1; }
    us[i] = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - a).count();
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::sort(us.begin(), us.end());
  const Stats& st = p.stats();
  std::printf("plant_bench %s: %.1f s simulated, 1 ms steps, rtol %.0e\n", profile, n * dt, P.rtol);
  std::printf("  real-time factor     %.1f simulated s / wall s (wall %.3f s)\n", n * dt / wall, wall);
  std::printf("  RHS evals            %.2f per step (%lld)\n", double(st.rhs_evals) / n, (long long)st.rhs_evals);
  std::printf("  CVODE steps          %.2f per step; restarts %lld, root evals %lld, mode switches %lld\n",
              double(st.steps) / n, (long long)st.reinits, (long long)st.root_evals, (long long)st.mode_switches);
  std::printf("  per 1 ms step        median %.2f us, p99 %.2f us, max %.1f us\n", us[n / 2], us[n * 99 / 100], us[n - 1]);
  return 0;
}

int main(int argc, char** argv) {
  std::string which = "all";
  int repeat = 1;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--repeat") && i + 1 < argc) repeat = std::atoi(argv[++i]);
    else which = argv[i];
  }
  int rc = 0;
  for (int r = 0; r < repeat; ++r) {
    if (which == "all" || which == "standing") rc |= bench("standing", false);
    if (which == "all" || which == "tracking") rc |= bench("tracking", true);
  }
  return rc;
}
