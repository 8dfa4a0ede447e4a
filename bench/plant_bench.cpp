// Plant benchmark (not a test): 10 s at 1 ms communication steps on two input profiles.
//   standing  - constant set-points; a 25 N x 60 ms push at 2 s (rocks the foot onto the toe and
//               lands it) and an 8 N x 1 s push at 5 s: the right-hand side jumps 4 times.
//   tracking  - the same pushes, with set-points that change at every communication step (a
//               0.5 Hz sway of 0.02 rad at the ankle and 0.05 rad at the hip), as in the closed
//               loop, where the controller's outputs change in most steps.
// Prints simulated seconds per wall second, RHS evaluations and CVODE steps per communication
// step, and the median / p99 wall time of one step.
//   replay    - the set-points and push of a closed-loop result CSV (--replay FILE: the columns
//               theta_ankle_ref, theta_hip_ref, push_force of e.g. results/paper_five_pushes/
//               paper_five_pushes.csv), so the plant sees what it sees in the closed loop.
//   build/plant/plant_bench [standing|tracking|replay|all] [--repeat N] [--replay FILE]
//                           [--integrator erk|bdf] [--json]   (--json: one JSON object per run)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "hoap2plant/plant.hpp"

using namespace hoap2plant;

struct Inputs {
  std::vector<double> ankle, hip, push;
};

// The three input columns of a closed-loop result CSV (FMPy layout: quoted header names).
static bool read_replay(const std::string& path, Inputs& in) {
  std::ifstream f(path);
  std::string line, cell;
  if (!f || !std::getline(f, line)) return std::printf("cannot read %s\n", path.c_str()), false;
  std::vector<std::string> names;
  std::stringstream hs(line);
  while (std::getline(hs, cell, ',')) names.push_back(cell.size() > 1 && cell[0] == '"' ? cell.substr(1, cell.size() - 2) : cell);
  int col[3] = {-1, -1, -1};
  const char* want[3] = {"theta_ankle_ref", "theta_hip_ref", "push_force"};
  for (int k = 0; k < 3; ++k)
    for (size_t c = 0; c < names.size(); ++c)
      if (names[c] == want[k]) col[k] = static_cast<int>(c);
  for (int k = 0; k < 3; ++k)
    if (col[k] < 0) return std::printf("%s: no column %s\n", path.c_str(), want[k]), false;
  while (std::getline(f, line)) {
    std::stringstream ls(line);
    double v[3] = {0, 0, 0};
    for (int c = 0; std::getline(ls, cell, ','); ++c)
      for (int k = 0; k < 3; ++k)
        if (c == col[k]) v[k] = std::strtod(cell.c_str(), nullptr);
    in.ankle.push_back(v[0]);
    in.hip.push_back(v[1]);
    in.push.push_back(v[2]);
  }
  return !in.ankle.empty();
}

static Integrator g_integrator = Integrator::Erk;
static bool g_json = false;

static int bench(const char* profile, const Inputs& in) {
  Params P = default_params();
  P.integrator = g_integrator;
  Plant p(P);
  if (!p.initialize(0.0)) { std::printf("initialize failed: %s\n", p.message().c_str()); return 1; }
  const double dt = 1e-3;
  const int n = static_cast<int>(in.ankle.size());
  std::vector<double> us(n);
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) {
    p.set_inputs(in.ankle[i], in.hip[i], in.push[i]);
    const auto a = std::chrono::steady_clock::now();
    if (p.do_step(dt) != Plant::Result::Ok) { std::printf("%s: step failed: %s\n", profile, p.message().c_str()); return 1; }
    us[i] = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - a).count();
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::sort(us.begin(), us.end());
  const Stats& st = p.stats();
  const char* integ = P.integrator == Integrator::Erk ? "erk" : "bdf";
  if (g_json) {
    std::printf("{\"profile\": \"%s\", \"integrator\": \"%s\", \"simulated_s\": %.3f, \"wall_s\": %.6f, "
                "\"real_time_factor\": %.2f, \"rhs_per_step\": %.3f, \"steps_per_step\": %.3f, \"restarts\": %lld, "
                "\"root_evals_per_step\": %.3f, \"median_us\": %.3f, \"p99_us\": %.3f, \"max_us\": %.1f}\n",
                profile, integ, n * dt, wall, n * dt / wall, double(st.rhs_evals) / n, double(st.steps) / n,
                (long long)st.reinits, double(st.root_evals) / n, us[n / 2], us[n * 99 / 100], us[n - 1]);
    return 0;
  }
  std::printf("plant_bench %s: %.1f s simulated, 1 ms steps, rtol %.0e, %s\n", profile, n * dt, P.rtol,
              P.integrator == Integrator::Erk ? "ERK (ARKODE)" : "BDF (CVODE)");
  std::printf("  real-time factor     %.1f simulated s / wall s (wall %.3f s)\n", n * dt / wall, wall);
  std::printf("  RHS evals            %.2f per step (%lld)\n", double(st.rhs_evals) / n, (long long)st.rhs_evals);
  std::printf("  integrator steps     %.2f per step; restarts %lld, root evals %.2f per step, mode switches %lld\n",
              double(st.steps) / n, (long long)st.reinits, double(st.root_evals) / n, (long long)st.mode_switches);
  std::printf("  per 1 ms step        median %.2f us, p99 %.2f us, max %.1f us\n", us[n / 2], us[n * 99 / 100], us[n - 1]);
  return 0;
}

// 10 s: the pushes of the standing profile, with or without the sway of the set-points.
static Inputs synthetic(bool tracking) {
  Inputs in;
  const double dt = 1e-3, w = 2 * 3.14159265358979323846 * 0.5;
  for (int i = 0; i < 10000; ++i) {
    const double t = i * dt;
    double f = 0;
    if (t >= 2.0 && t < 2.06) f = 25.0;
    if (t >= 5.0 && t < 6.0) f = 8.0;
    const double s = tracking ? std::sin(w * t) : 0.0;
    in.ankle.push_back(0.02 * s);
    in.hip.push_back(0.05 * s);
    in.push.push_back(f);
  }
  return in;
}

int main(int argc, char** argv) {
  std::string which = "all", replay;
  int repeat = 1;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--repeat") && i + 1 < argc) repeat = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--replay") && i + 1 < argc) replay = argv[++i];
    else if (!std::strcmp(argv[i], "--integrator") && i + 1 < argc) {
      const std::string v = argv[++i];
      if (v != "erk" && v != "bdf") return std::printf("--integrator erk | bdf\n"), 2;
      g_integrator = v == "bdf" ? Integrator::Bdf : Integrator::Erk;
    } else if (!std::strcmp(argv[i], "--json")) g_json = true;
    else which = argv[i];
  }
  Inputs rec;
  if (!replay.empty() && !read_replay(replay, rec)) return 2;
  int rc = 0;
  for (int r = 0; r < repeat; ++r) {
    if (which == "all" || which == "standing") rc |= bench("standing", synthetic(false));
    if (which == "all" || which == "tracking") rc |= bench("tracking", synthetic(true));
    if (!replay.empty() && (which == "all" || which == "replay")) rc |= bench("replay", rec);
  }
  return rc;
}
