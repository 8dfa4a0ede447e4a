/* The servo model's saturation, shared by the sagittal plant (plant/) and the 3D plant (plant3d/):
 * HOAP-2's joint servos as both plants model them (docs/plant.md section 4, "Joint servos"). Hand-written, not
 * generated. C99 and C++. */
#ifndef HOAP2_SERVO_H
#define HOAP2_SERVO_H

#include <math.h>

/* Soft saturation: the identity for |u| <= 0.8 L, a smooth (C2) tanh approach to +-L beyond.
 * L <= 0 (or NaN) means no limit. */
static inline double hoap2_soft_sat(double u, double L) {
  if (!(L > 0)) return u;
  const double a = 0.8 * L, au = fabs(u);
  if (au <= a) return u;
  const double w = L - a;
  const double v = a + w * tanh((au - a) / w);
  return u < 0 ? -v : v;
}

#endif
