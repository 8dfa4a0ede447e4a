// Rigid-block rocking on a flat sole (Housner 1963): the reference of the 3D plant's contact study
// (test plant3d.contact_study, docs/plant3d.md section 2).
//
// One rigid body (mass m, CoM (cx, cz), inertia Ic about the CoM for rotation about y) stands on a
// rigid floor on a sole from heel_x to toe_x (z = 0). It rests flat while the moments about both
// edges hold it down, rotates about the toe (phi > 0, heel up) or the heel (phi < 0, toe up)
// otherwise, and lands with a plastic point impact at the other edge: the angular momentum about
// the landing edge is conserved, so the rate is multiplied by Housner's coefficient
//   r = (Ic + m (c - B).(c - A)) / (Ic + m |c - B|^2)   (rotating about A, landing on B),
// and the block rocks on over B. About an edge E the motion is one degree of freedom,
//   (Ic + m |c - E|^2) phi'' = m g X_c(phi) + F(t) Z_p(phi),
// with X_c the CoM's horizontal distance from E and Z_p the height of the push point above E, both
// after turning the body by phi about E. Integrated by RK4 at a fixed step, edge crossings located
// by bisection to 1e-13 s.
#pragma once

#include <cmath>
#include <functional>
#include <vector>

namespace rigid_rocking {

struct Block {
  double m, Ic, cx, cz;    // mass [kg], inertia about the CoM [kg m^2], CoM x and height [m]
  double px, pz;           // where the horizontal push acts [m]
  double toe_x, heel_x;    // sole edges [m]
  double g;
};

struct Result {
  std::vector<double> t, phi;      // sampled every `sample` s
};

// Pitch trace of the block under push F(t) (piecewise constant between its switch times, which
// must be multiples of dt), from flat at rest at t = 0 to t_end. Rocking ends, the block resting
// flat, when a landing ends an excursion smaller than min_amp (the Zeno tail of plastic rocking).
inline Result simulate(const Block& b, const std::function<double(double)>& F, double t_end, double sample,
                       double dt = 1e-6, double min_amp = 1e-7) {
  Result res;
  int edge = 0;  // 0 flat, +1 on the toe, -1 on the heel
  double phi = 0, w = 0, t = 0, peak = 0;
  auto pivot = [&](int e) { return e > 0 ? b.toe_x : b.heel_x; };
  auto accel = [&](int e, double ph, double force) {
    const double ex = pivot(e), c = std::cos(ph), s = std::sin(ph);
    const double dx = b.cx - ex, dz = b.cz, qx = b.px - ex, qz = b.pz;
    const double X = dx * c + dz * s, Zp = -qx * s + qz * c;
    return (b.m * b.g * X + force * Zp) / (b.Ic + b.m * (dx * dx + dz * dz));
  };
  auto rk4 = [&](int e, double& ph, double& om, double h, double force) {
    const double k1p = om, k1w = accel(e, ph, force);
    const double k2p = om + 0.5 * h * k1w, k2w = accel(e, ph + 0.5 * h * k1p, force);
    const double k3p = om + 0.5 * h * k2w, k3w = accel(e, ph + 0.5 * h * k2p, force);
    const double k4p = om + h * k3w, k4w = accel(e, ph + h * k3p, force);
    ph += h / 6 * (k1p + 2 * k2p + 2 * k3p + k4p);
    om += h / 6 * (k1w + 2 * k2w + 2 * k3w + k4w);
  };
  auto housner = [&](int from) {  // rotating about edge `from`, landing on the other one
    const double ax = pivot(from) - b.cx, bx = pivot(-from) - b.cx, z = -b.cz;
    return (b.Ic + b.m * (ax * bx + z * z)) / (b.Ic + b.m * (bx * bx + z * z));
  };
  double next_sample = 0;
  const long n = std::lround(t_end / dt);
  for (long i = 0; i < n; ++i) {
    while (t >= next_sample - 1e-12) {
      res.t.push_back(next_sample);
      res.phi.push_back(phi);
      next_sample += sample;
    }
    const double force = F(t + 0.5 * dt);
    if (edge == 0) {  // flat: lifts onto the edge whose moment turns the body off the floor
      if (accel(+1, 0, force) > 0) edge = +1;
      else if (accel(-1, 0, force) < 0) edge = -1;
    }
    if (edge != 0) {
      double ph = phi, om = w;
      rk4(edge, ph, om, dt, force);
      if (ph * edge < 0) {  // crossed phi = 0 within this step: locate the landing
        double lo = 0, hi = dt;
        while (hi - lo > 1e-13) {
          const double mid = 0.5 * (lo + hi);
          double p2 = phi, w2 = w;
          rk4(edge, p2, w2, mid, force);
          (p2 * edge < 0 ? hi : lo) = mid;
        }
        double p2 = phi, w2 = w;
        rk4(edge, p2, w2, hi, force);
        phi = 0;
        if (std::fabs(peak) < min_amp) {  // at rest
          edge = 0;
          w = 0;
        } else {  // plastic impact on the other edge, rocking on over it
          edge = -edge;
          w = housner(-edge) * w2;
          rk4(edge, phi, w, dt - hi, force);
        }
        peak = 0;
      } else {
        phi = ph;
        w = om;
      }
      if (std::fabs(phi) > std::fabs(peak)) peak = phi;
    }
    t = (i + 1) * dt;
  }
  return res;
}

}  // namespace rigid_rocking
