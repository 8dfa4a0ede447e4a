// Plant benchmark (not a test): a 10 s standing + push run at 1 ms communication steps.
// Prints simulated seconds per wall second, RHS evaluations per second, and the median / p99
// wall time of one 1 ms communication step.  Build: cmake --build <dir> --target plant_bench
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "hoap2plant/plant.hpp"

using namespace hoap2plant;

int main() {
  Params P = default_params();
  Plant p(P);
  p.initialize(0.0);
  const double dt = 1e-3;
  const int n = 10000;
  std::vector<double> us(n);
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) {
    const double t = p.time();
    // standing, a 25 N x 60 ms push at 2 s (rocks onto the toe and lands), a 8 N x 1 s push at 5 s
    double f = 0;
    if (t >= 2.0 && t < 2.06) f = 25.0;
    if (t >= 5.0 && t < 6.0) f = 8.0;
    p.set_inputs(0.0, 0.0, f);
    const auto a = std::chrono::steady_clock::now();
    if (p.do_step(dt) != Plant::Result::Ok) { std::printf("step failed: %s\n", p.message().c_str()); return 1; }
    us[i] = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - a).count();
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::vector<double> s = us;
  std::sort(s.begin(), s.end());
  const Stats& st = p.stats();
  std::printf("plant_bench: %.1f s simulated (standing + 25 N rocking push + 8 N push), 1 ms steps, rtol %.0e\n",
              n * dt, P.rtol);
  std::printf("  wall time            %.3f s\n", wall);
  std::printf("  real-time factor     %.1f simulated s / wall s\n", n * dt / wall);
  std::printf("  RHS evals            %lld (%.2f M/s, %.1f per step)\n", (long long)st.rhs_evals,
              st.rhs_evals / wall * 1e-6, double(st.rhs_evals) / n);
  std::printf("  CVODE steps          %lld (%.1f per comm. step), root evals %lld, mode switches %lld\n",
              (long long)st.steps, double(st.steps) / n, (long long)st.root_evals, (long long)st.mode_switches);
  std::printf("  per 1 ms step        median %.1f us, p99 %.1f us, max %.1f us\n", s[n / 2], s[n * 99 / 100],
              s[n - 1]);
  return 0;
}
