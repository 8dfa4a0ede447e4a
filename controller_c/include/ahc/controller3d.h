/*
 * controller3d.h — the controller for a robot in 3D (docs/controller.md §11): the paper's
 * sagittal controller (controller.h, unchanged: its outputs are those of ahc_step on the same
 * sensors, bit for bit), the frontal-plane controller (frontal.h) beside it, and the legs'
 * kinematics (leg_ik.h) that turn both planes' references into per-leg joint set points. One tick,
 * in this order: the sagittal controller; the frontal angles measured on the pivot leg; the frontal
 * controller; the legs' set points. No heap, no globals, one POD struct.
 */
#ifndef AHC_CONTROLLER3D_H
#define AHC_CONTROLLER3D_H

#include "ahc/controller.h"
#include "ahc/frontal.h"
#include "ahc/leg_ik.h"
#include "ahc/stepping.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    ahc_sensors sag;                   /* theta_ankle, theta_hip (both legs' mean), zmp_x, fz     */
    double zmp_y;                      /* lateral ZMP from the mid-point between the ankles [m]   */
    double fz_left, fz_right;          /* each sole's normal load [N]                              */
    double q[2][AHC_LEG_JOINTS];       /* measured joint angles, [AHC_LEFT], [AHC_RIGHT] [rad]    */
    double imu_roll;                   /* the trunk's roll in the world (an IMU's; Hoap2Plant3D's
                                          imu_roll: + turns the top toward -y) [rad]             */
    double imu_pitch;                  /* the trunk's pitch in the world (+ forward; Hoap2Plant3D's
                                          imu_pitch); read by the stepping layer only [rad]      */
} ahc3d_sensors;

typedef struct {
    ahc_outputs sag;                   /* the sagittal controller's outputs                       */
    ahc_frontal_outputs frontal;       /* the frontal controller's outputs                        */
    /* Per-leg set points to add to the both-legs ones (theta_ankle_ref, theta_hip_ref from sag,
     * 0 for the other joints): the legs' kinematics of both planes' references minus those of the
     * sagittal references alone. Exactly 0 while the frontal references are 0. */
    double q_ref_offset[2][AHC_LEG_JOINTS];
    int legs_out_of_reach;             /* legs whose hip the kinematics could not reach (0)       */
    /* The stepping layer (stepping.h). While step.active its joint set points replace the flat-footed
     * layers': sag.theta_ankle_ref and theta_hip_ref are then the two legs' mean pitch set points and
     * q_ref_offset the rest, so that both-legs + per-leg = step.q_ref. */
    ahc_step_outputs step;
} ahc3d_outputs;

typedef struct {
    ahc_controller sag;
    ahc_frontal frontal;
    ahc_leg_geometry legs;
    ahc_stepper step;
} ahc3d;

/* Validate both parameter sets (sp and fp) and initialise, stepping off (its defaults). AHC_OK or
 * the first AHC_ERR_*. */
int ahc3d_init(ahc3d *c, const ahc_params *sp, const ahc_frontal_params *fp);
/* The same with the stepping layer's parameters (stepping.h). */
int ahc3d_init_stepping(ahc3d *c, const ahc_params *sp, const ahc_frontal_params *fp, const ahc_step_params *stp);
void ahc3d_reset(ahc3d *c);
void ahc3d_step(ahc3d *c, const ahc3d_sensors *s, ahc3d_outputs *out);
int ahc3d_state_validate(const ahc3d *c, char *msg, size_t msg_size);

#ifdef __cplusplus
}
#endif

#endif /* AHC_CONTROLLER3D_H */
