/*
 * frontal_pose.h — the frontal model's pose (frontal_model.c), internal to controller_c: one
 * evaluation gives the CoM, its Jacobian, the lumps and the other leg's length, so that a tick
 * computes each pose once.
 */
#ifndef AHC_FRONTAL_POSE_H
#define AHC_FRONTAL_POSE_H

#include "ahc/frontal.h"

typedef struct {
    double y, z;       /* the two-link body's CoM [m] */
    double dy[2];      /* d y / d (phi, psi) */
    double other_len;  /* the non-pivot leg's hip-ankle distance */
    double ly[3], lz[3], lean[3];  /* the lumps (right leg, left leg, link 2): CoM and lean toward +y */
} ahc_frontal_pose;

void ahc_frontal_pose_at(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi,
                         ahc_frontal_pose *o);

#endif /* AHC_FRONTAL_POSE_H */
