/*
 * hoap2_model.h — nominal numbers of the Fujitsu HOAP-2 humanoid lumped into the sagittal plane
 * (both legs together), SI units.
 *
 * THE single source of truth for these numbers: the C controller's defaults (ahc_params_default)
 * and the C++ plant's defaults both include this header. Pure C (C99 / C++ compatible), macros
 * only, no dependencies.
 *
 * Source: DESIGN.md section 5, derived from the public Webots model of HOAP-2
 * (cyberbotics/webots, projects/robots/fujitsu/hoap2/protos/Hoap2.proto: "50 cm high, 7 kg,
 * 25 degrees of freedom"), link masses summed and lumped into a planar double inverted pendulum
 * on the ankle: link 1 = shanks + thighs + hip pitch links of both legs (knee straight),
 * link 2 = waist, trunk, arms and head. Derivation: docs/controller.md.
 *
 * Conventions (DESIGN section 3): x forward (toward the toes), z up; angles positive when the
 * body above the joint pitches forward; x positions measured from the ankle joint's ground
 * projection; heights from the sole unless stated.
 */
#ifndef AHC_HOAP2_MODEL_H
#define AHC_HOAP2_MODEL_H

/* Gravitational acceleration [m/s^2] (standard gravity). */
#define AHC_HOAP2_G 9.81

/* --- link 1: legs (shank + thigh + hip pitch links, both legs, knee straight) ---------------- */
/* Mass of link 1 [kg] (sum of the Webots leg link masses above the ankle, both legs). */
#define AHC_HOAP2_M1 1.79
/* Length of link 1 [m]: ankle pitch axis -> hip pitch axis (ankle->knee 0.100 + knee->hip 0.100). */
#define AHC_HOAP2_L1 0.200
/* Distance ankle axis -> CoM of link 1 [m]. */
#define AHC_HOAP2_LG1 0.138
/* Moment of inertia of link 1 about its own CoM, pitch axis [kg m^2]. */
#define AHC_HOAP2_I1 0.008

/* --- link 2: upper body (waist, trunk, arms, head) ------------------------------------------ */
/* Mass of link 2 [kg]. */
#define AHC_HOAP2_M2 4.71
/* Distance hip pitch axis -> CoM of link 2 [m]. */
#define AHC_HOAP2_LG2 0.10
/* Moment of inertia of link 2 about its own CoM, pitch axis [kg m^2]. */
#define AHC_HOAP2_I2 0.047

/* --- feet (both, incl. ankle links and sole plates) ----------------------------------------- */
/* Mass of both feet [kg]. Total robot mass = M1 + M2 + FEET_MASS = 7.16 kg. */
#define AHC_HOAP2_FEET_MASS 0.66
/* CoM of the feet, x forward of the ankle axis [m]. */
#define AHC_HOAP2_FEET_COM_X 0.010
/* CoM of the feet, height above the sole [m]. */
#define AHC_HOAP2_FEET_COM_Z 0.015
/* Toe edge of the sole, x from the ankle axis [m] (positive, forward). */
#define AHC_HOAP2_TOE_X 0.0575
/* Heel edge of the sole, x from the ankle axis [m] (negative, backward). Sole length 0.095 m. */
#define AHC_HOAP2_HEEL_X (-0.0375)
/* Height of the ankle pitch axis above the sole [m]. */
#define AHC_HOAP2_ANKLE_HEIGHT 0.035
/* Width of one sole [m] (not used by the sagittal controller; for the plant / visualisation). */
#define AHC_HOAP2_SOLE_WIDTH 0.065

/* --- joint limits [rad] ---------------------------------------------------------------------- */
/* Ankle pitch range (theta_1, leg relative to foot). */
#define AHC_HOAP2_ANKLE_MIN (-1.06)
#define AHC_HOAP2_ANKLE_MAX 1.06
/* Hip pitch range (theta_2, upper body relative to leg); + = bending forward. */
#define AHC_HOAP2_HIP_MIN (-1.43)
#define AHC_HOAP2_HIP_MAX 1.24

/* --- derived, for convenience ---------------------------------------------------------------- */
/* Mass of the two-link body above the ankle [kg] (m = m1 + m2 of the paper). */
#define AHC_HOAP2_BODY_MASS (AHC_HOAP2_M1 + AHC_HOAP2_M2)
/* Total robot mass incl. feet [kg]. */
#define AHC_HOAP2_TOTAL_MASS (AHC_HOAP2_M1 + AHC_HOAP2_M2 + AHC_HOAP2_FEET_MASS)
/* Erect CoM height of the two-link body above the ankle axis [m] (theta1 = theta2 = 0):
 * (m1 lg1 + m2 (l1 + lg2)) / m  ~= 0.2554 m. */
#define AHC_HOAP2_ERECT_COM_Z \
    ((AHC_HOAP2_M1 * AHC_HOAP2_LG1 + AHC_HOAP2_M2 * (AHC_HOAP2_L1 + AHC_HOAP2_LG2)) / AHC_HOAP2_BODY_MASS)

/* Control period of the HOAP-2 [s]. */
#define AHC_HOAP2_SAMPLE_PERIOD 0.001

#endif /* AHC_HOAP2_MODEL_H */
