// Plant defaults = the HOAP-2 nominal numbers shared with the controller (one source of truth:
// controller_c/include/ahc/hoap2_model.h). Plant-only numbers (servo, foot inertia, push height,
// fall thresholds) are documented in docs/plant.md.
#include "ahc/hoap2_model.h"
#include "hoap2plant/model.hpp"

namespace hoap2plant {

Params default_params() {
  Params p;
  p.g = AHC_HOAP2_G;
  p.m1 = AHC_HOAP2_M1;
  p.l1 = AHC_HOAP2_L1;
  p.lg1 = AHC_HOAP2_LG1;
  p.I1 = AHC_HOAP2_I1;
  p.m2 = AHC_HOAP2_M2;
  p.lg2 = AHC_HOAP2_LG2;
  p.I2 = AHC_HOAP2_I2;
  p.feet_mass = AHC_HOAP2_FEET_MASS;
  p.feet_com_x = AHC_HOAP2_FEET_COM_X;
  p.feet_com_z = AHC_HOAP2_FEET_COM_Z;
  p.toe_x = AHC_HOAP2_TOE_X;
  p.heel_x = AHC_HOAP2_HEEL_X;
  p.ankle_height = AHC_HOAP2_ANKLE_HEIGHT;
  // Both feet as a 0.095 m x 0.04 m slab about its CoM: m (L^2 + H^2) / 12 (plant-only number).
  p.feet_inertia = 6.0e-4;
  return p;
}

}  // namespace hoap2plant
