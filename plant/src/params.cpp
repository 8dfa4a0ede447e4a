// Plant defaults = the HOAP-2 nominal numbers shared with the controller (one source of truth:
// hoap2/include/hoap2/nominal.h). Plant-only numbers (servo, push height,
// fall thresholds) are documented in docs/plant.md.
#include "hoap2/nominal.h"
#include "hoap2plant/model.hpp"

namespace hoap2plant {

Params default_params() {
  Params p;
  p.g = HOAP2_G;
  p.m1 = HOAP2_M1;
  p.l1 = HOAP2_L1;
  p.lg1 = HOAP2_LG1;
  p.I1 = HOAP2_I1;
  p.m2 = HOAP2_M2;
  p.lg2 = HOAP2_LG2;
  p.I2 = HOAP2_I2;
  p.feet_mass = HOAP2_FEET_MASS;
  p.feet_com_x = HOAP2_FEET_COM_X;
  p.feet_com_z = HOAP2_FEET_COM_Z;
  p.toe_x = HOAP2_TOE_X;
  p.heel_x = HOAP2_HEEL_X;
  p.ankle_height = HOAP2_ANKLE_HEIGHT;
  p.feet_inertia = HOAP2_FEET_INERTIA;
  return p;
}

}  // namespace hoap2plant
