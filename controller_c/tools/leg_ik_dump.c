/*
 * leg_ik_dump.c — the leg's kinematics for any foot pose (leg_ik.h) on poses read from stdin, for
 * the cross-check against Pinocchio (tests/test_leg_ik_crosscheck.py). HOAP-2's geometry and
 * limits (hoap2/nominal.h).
 *
 * Input lines: "side ax ay az R00 R01 R02 R10 R11 R12 R20 R21 R22" (side 0 left, 1 right; the
 * ankle centre relative to the hip centre in the trunk's axes [m], the foot's orientation relative
 * to the trunk, row-major). Output: one JSON line per input line, {"status": s, "q": [6 angles,
 * AHC_LEG_* order]} of ahc_leg_ik_pose with that side's limits, and {"ankle": [...], "R": [...]}
 * of ahc_leg_fk_pose at those angles.
 */
#include <stdio.h>

#include "ahc/leg_ik.h"
#include "hoap2/nominal.h"

int main(void)
{
    const ahc_leg_geometry g = {HOAP2_THIGH, HOAP2_SHANK, HOAP2_HIP_Y, HOAP2_ANKLE_Y};
    int side;
    double a[3], R[9];
    while (scanf("%d %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf", &side, &a[0], &a[1], &a[2], &R[0], &R[1], &R[2],
                 &R[3], &R[4], &R[5], &R[6], &R[7], &R[8]) == 13) {
        ahc_leg_limits lim;
        double q[AHC_LEG_JOINTS], a2[3], R2[9];
        int j, status;
        ahc_leg_limits_hoap2(side ? AHC_RIGHT : AHC_LEFT, &lim);
        status = ahc_leg_ik_pose(&g, &lim, a, R, q);
        ahc_leg_fk_pose(&g, q, a2, R2);
        printf("{\"status\": %d, \"q\": [", status);
        for (j = 0; j < AHC_LEG_JOINTS; ++j) printf("%s%.17g", j ? ", " : "", q[j]);
        printf("], \"ankle\": [%.17g, %.17g, %.17g], \"R\": [", a2[0], a2[1], a2[2]);
        for (j = 0; j < 9; ++j) printf("%s%.17g", j ? ", " : "", R2[j]);
        printf("]}\n");
    }
    return 0;
}
