/*
 * test_kinematics — establishes that the model helpers are right:
 *  - ahc_com at the erect pose equals the closed-form erect CoM height of hoap2/nominal.h;
 *  - the CoM Jacobian x row (eq. 20) equals central finite differences of ahc_com at random
 *    postures (tolerance from the O(eps^2) truncation + round-off of the difference quotient);
 *  - the reactionless ratio (eq. 15) keeps r_x fixed to first order: moving (dth1, dth2) =
 *    (ratio, 1) * delta changes r_x by O(delta^2) (bounded by the second derivatives), whereas a
 *    hip-only motion changes it by O(delta) — so the check can fail;
 *  - ahc_ankle_inertia equals the parallel-axis sum at the erect pose.
 */
#include "ahc_test.h"

int main(void)
{
    ahc_params p;
    unsigned long long rng = 12345u;
    int i;
    double rz0, rx0;
    ahc_params_default(&p);

    ahc_com(&p, 0.0, 0.0, &rx0, &rz0);
    CHECK_NEAR(rx0, 0.0, 1e-15, "erect r_x");
    CHECK_NEAR(rz0, HOAP2_ERECT_COM_Z, 1e-15, "erect r_z");
    CHECK_NEAR(rz0, 0.2608, 5e-4, "erect r_z of the Webots-derived model (~0.261 m; paper ~0.265 m)");

    for (i = 0; i < 200; ++i) {
        const double th1 = test_rand(&rng, -0.8, 0.8);
        const double th2 = test_rand(&rng, -1.2, 1.1);
        const double eps = 1e-6;
        double J[2], xp, xm, fd1, fd2, ratio, d, rxa, rxb, lin, hiponly;
        ahc_com_jacobian_x(&p, th1, th2, J);
        ahc_com(&p, th1 + eps, th2, &xp, NULL);
        ahc_com(&p, th1 - eps, th2, &xm, NULL);
        fd1 = (xp - xm) / (2 * eps);
        ahc_com(&p, th1, th2 + eps, &xp, NULL);
        ahc_com(&p, th1, th2 - eps, &xm, NULL);
        fd2 = (xp - xm) / (2 * eps);
        /* truncation |f'''| eps^2 / 6 <= 0.3 m * 1e-12 / 6; round-off ~ 1e-16 * 0.3 / 1e-6 */
        CHECK_NEAR(J[0], fd1, 1e-9, "J_cx[0] = d r_x / d th1");
        CHECK_NEAR(J[1], fd2, 1e-9, "J_cx[1] = d r_x / d th2");

        /* eq. 15 equals -J[1]/J[0] (the reactionless condition J_cx [ratio, 1]^T = 0) */
        ratio = ahc_reactionless_ratio(&p, th1, th2);
        CHECK_NEAR(ratio, -J[1] / J[0], 1e-12, "reactionless ratio vs -J1/J0");

        /* first-order invariance: |dr_x| <= 0.5 * |H| * |dq|^2 with |H| <= max second derivative
         * of r_x (<= (m1 lg1 + m2 (l1 + lg2))/m = 0.256 m per rad^2 per direction, x (1+|ratio|)^2) */
        d = 1e-3;
        ahc_com(&p, th1, th2, &rxa, NULL);
        ahc_com(&p, th1 + ratio * d, th2 + d, &rxb, NULL);
        lin = fabs(rxb - rxa);
        CHECK(lin <= 0.5 * 0.26 * (1 + fabs(ratio)) * (1 + fabs(ratio)) * d * d,
              "reactionless motion moved r_x by %.3g at th=(%.3f, %.3f)", lin, th1, th2);
        ahc_com(&p, th1, th2 + d, &rxb, NULL);
        hiponly = fabs(rxb - rxa);
        /* hip-only motion moves r_x by |J[1]| d (first order), far above the bound when C12 != 0 */
        if (fabs(J[1]) > 0.01) CHECK(hiponly > 10.0 * lin, "hip-only %.3g vs reactionless %.3g", hiponly, lin);
    }

    CHECK_NEAR(ahc_ankle_inertia(&p, 0.0),
               p.I1 + p.m1 * p.lg1 * p.lg1 + p.I2 + p.m2 * (p.l1 + p.lg2) * (p.l1 + p.lg2), 1e-14,
               "ankle inertia erect");
    CHECK_NEAR(ahc_ankle_inertia(&p, 0.0), 0.5049, 5e-4, "ankle inertia erect ~0.505 kg m^2");
    TEST_MAIN_END();
}
