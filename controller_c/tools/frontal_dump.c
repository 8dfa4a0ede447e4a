/*
 * frontal_dump.c — the frontal model's numbers (docs/controller.md §11.1) at the configurations read
 * from stdin, for the cross-check against Pinocchio (tests/test_frontal_crosscheck.py).
 *
 * Input: lines "phi psi" [rad]. Output: a first JSON line with the model's constants (the inertias
 * F11's J_phi and F16's J_psi, the masses and lengths), then one JSON line per input line: the
 * frontal CoM r_y, r_z (F2), the lateral CoM Jacobian J (F20), the other leg's hip-ankle distance,
 * and both legs' joint angles from the legs' kinematics with the sagittal angles 0
 * (ahc_legs_from_planes; AHC_LEG_* order, left then right) and how many legs were out of reach.
 */
#include <stdio.h>

#include "ahc/controller3d.h"

int main(void)
{
    ahc_params sp;
    ahc_frontal_params f;
    ahc_leg_geometry g;
    double phi, psi;
    ahc_params_default(&sp);
    ahc_frontal_params_default(&f);
    g.thigh = f.thigh;
    g.shank = f.shank;
    g.hip_y = f.hip_y;
    g.ankle_y = f.ankle_y;
    printf("{\"J_phi\": %.17g, \"J_psi\": %.17g, \"m1\": %.17g, \"m2\": %.17g, \"l1\": %.17g, \"lg1\": %.17g, "
           "\"lg2\": %.17g, \"hip_y\": %.17g, \"ankle_y\": %.17g, \"thigh\": %.17g, \"shank\": %.17g, "
           "\"I1_roll\": %.17g, \"I2_roll\": %.17g, \"link1_com_y\": %.17g, \"link2_com_y\": %.17g}\n",
           ahc_frontal_ankle_inertia(&f, &sp), ahc_frontal_hip_inertia(&f, &sp), sp.m1, sp.m2, sp.l1, sp.lg1,
           sp.lg2, f.hip_y, f.ankle_y, f.thigh, f.shank, f.I1_roll, f.I2_roll, f.link1_com_y, f.link2_com_y);
    while (scanf("%lf %lf", &phi, &psi) == 2) {
        double ry, rz, J[2], q[2][AHC_LEG_JOINTS];
        int side, j, out;
        ahc_frontal_com(&f, &sp, phi, psi, &ry, &rz);
        ahc_frontal_com_jacobian(&f, &sp, phi, psi, J);
        out = ahc_legs_from_planes(&g, 0.0, 0.0, phi, psi, q);
        printf("{\"phi\": %.17g, \"psi\": %.17g, \"r_y\": %.17g, \"r_z\": %.17g, \"J\": [%.17g, %.17g], "
               "\"other_len\": %.17g, \"out_of_reach\": %d, \"q\": [",
               phi, psi, ry, rz, J[0], J[1], ahc_frontal_other_leg_length(&f, &sp, phi, psi), out);
        for (side = 0; side < 2; ++side) {
            printf("%s[", side ? ", " : "");
            for (j = 0; j < AHC_LEG_JOINTS; ++j) printf("%s%.17g", j ? ", " : "", q[side][j]);
            printf("]");
        }
        printf("]}\n");
    }
    return 0;
}
