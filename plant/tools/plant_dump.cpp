// plant_dump: prints the plant model's parameters, and for each state read from stdin
// (one line: x z phi theta1 theta2  xd zd phid theta1d theta2d  ref1 ref2 push) the mass matrix
// M, the bias vector h (Coriolis/centrifugal + gravity), the applied generalized force Q
// (servo torques + push), and the flat-mode constrained dynamics (qdd, ground reaction J^T lambda)
// as one JSON object per line. Used by tests/test_plant_crosscheck.py (Pinocchio cross-check).
#include <cstdio>
#include <iostream>

#include "hoap2plant/model.hpp"

using namespace hoap2plant;

static void vec(const char* name, const double* v, int n, bool comma = true) {
  std::printf("\"%s\": [", name);
  for (int i = 0; i < n; ++i) std::printf("%s%.17g", i ? ", " : "", v[i]);
  std::printf("]%s", comma ? ", " : "");
}

int main() {
  const Params P = default_params();
  const Model model(P);
  std::printf("{\"params\": {\"g\": %.17g, \"m1\": %.17g, \"l1\": %.17g, \"lg1\": %.17g, "
              "\"I1\": %.17g, \"m2\": %.17g, \"lg2\": %.17g, \"I2\": %.17g, \"feet_mass\": %.17g, "
              "\"feet_inertia\": %.17g, \"feet_com_x\": %.17g, \"feet_com_z\": %.17g, "
              "\"ankle_height\": %.17g, \"toe_x\": %.17g, \"heel_x\": %.17g, \"h_push\": %.17g}}\n",
              P.g, P.m1, P.l1, P.lg1, P.I1, P.m2, P.lg2, P.I2, P.feet_mass, P.feet_inertia,
              P.feet_com_x, P.feet_com_z, P.ankle_height, P.toe_x, P.heel_x, P.h_push);
  double v[13];
  while (true) {
    for (double& x : v)
      if (!(std::cin >> x)) return 0;
    Vec5 q, qd;
    for (int i = 0; i < 5; ++i) {
      q[i] = v[i];
      qd[i] = v[5 + i];
    }
    Mat5 M;
    Vec5 h;
    model.mass_bias(q, qd, M, h);
    const Vec5 Q = model.applied(q, qd, v[10], v[11], v[12]);
    const auto d = model.dynamics(ContactMode::Flat, q, qd, v[10], v[11], v[12], Vec2::Zero());
    const Vec2 c = model.com(q);
    std::printf("{");
    Eigen::Matrix<double, 5, 5, Eigen::RowMajor> Mr = M;
    vec("M", Mr.data(), 25);
    vec("h", h.data(), 5);
    vec("Q", Q.data(), 5);
    vec("qdd_flat", d.qdd.data(), 5);
    vec("Qc_flat", d.Qc.data(), 5);
    vec("com", c.data(), 2, false);
    std::printf("}\n");
    std::fflush(stdout);
  }
}
