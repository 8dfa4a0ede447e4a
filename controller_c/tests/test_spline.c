/*
 * test_spline — establishes the quintic splines used for k_w and r_x_d:
 *  - random boundary conditions (position, velocity, acceleration at both ends) are met exactly
 *    (to round-off) and the derivatives returned by ahc_quintic_eval agree with finite
 *    differences of the value;
 *  - the rest-to-rest spline 0 -> 1 (k_w) has zero end velocity and acceleration, is monotonic,
 *    symmetric (x(T/2) = 1/2) and peaks at 15/8 / T in velocity;
 *  - a rest-to-rest spline from r0 to 0 (r_x_d with zero initial velocity) is monotonic;
 *  - evaluation clamps t outside [0, T] to the end values.
 */
#include "ahc_test.h"

int main(void)
{
    ahc_quintic q;
    unsigned long long rng = 99u;
    int i, k;
    double x, v, a;

    for (i = 0; i < 100; ++i) {
        const double x0 = test_rand(&rng, -1, 1), v0 = test_rand(&rng, -1, 1), a0 = test_rand(&rng, -1, 1);
        const double x1 = test_rand(&rng, -1, 1), v1 = test_rand(&rng, -1, 1), a1 = test_rand(&rng, -1, 1);
        const double T = test_rand(&rng, 0.1, 3.0);
        const double eps = 1e-5;
        double xp, xm, vp, vm, tm;
        ahc_quintic_init(&q, x0, v0, a0, x1, v1, a1, T);
        ahc_quintic_eval(&q, 0.0, &x, &v, &a);
        CHECK_NEAR(x, x0, 1e-12, "x(0)");
        CHECK_NEAR(v, v0, 1e-12, "v(0)");
        CHECK_NEAR(a, a0, 1e-12, "a(0)");
        ahc_quintic_eval(&q, T, &x, &v, &a);
        CHECK_NEAR(x, x1, 1e-9, "x(T)");
        CHECK_NEAR(v, v1, 1e-8, "v(T)");
        CHECK_NEAR(a, a1, 1e-7, "a(T)");
        tm = 0.37 * T;
        ahc_quintic_eval(&q, tm + eps, &xp, &vp, NULL);
        ahc_quintic_eval(&q, tm - eps, &xm, &vm, NULL);
        ahc_quintic_eval(&q, tm, &x, &v, &a);
        CHECK_NEAR(v, (xp - xm) / (2 * eps), 1e-5, "v = dx/dt");
        CHECK_NEAR(a, (vp - vm) / (2 * eps), 1e-4, "a = dv/dt");
    }

    /* k_w: 0 -> 1 over T_ah = 1 s */
    ahc_quintic_init(&q, 0, 0, 0, 1, 0, 0, 1.0);
    {
        double prev = -1.0, vmax = 0.0;
        for (k = 0; k <= 10000; ++k) {
            ahc_quintic_eval(&q, k * 1e-4, &x, &v, NULL);
            CHECK(x >= prev, "k_w monotonic at t=%g", k * 1e-4);
            CHECK(x >= -1e-15 && x <= 1 + 1e-15, "k_w in [0,1]");
            if (v > vmax) vmax = v;
            prev = x;
        }
        CHECK_NEAR(vmax, 15.0 / 8.0, 1e-6, "peak rate of the rest-to-rest quintic");
    }
    ahc_quintic_eval(&q, 0.5, &x, NULL, NULL);
    CHECK_NEAR(x, 0.5, 1e-15, "symmetric midpoint");
    ahc_quintic_eval(&q, 1.0, &x, &v, &a);
    CHECK_NEAR(x, 1.0, 1e-14, "k_w(T)");
    CHECK_NEAR(v, 0.0, 1e-12, "k_w'(T)");
    CHECK_NEAR(a, 0.0, 1e-11, "k_w''(T)");
    ahc_quintic_eval(&q, 5.0, &x, &v, &a);
    CHECK(x == 1.0 || fabs(x - 1.0) < 1e-14, "clamped beyond T: %g", x);
    CHECK_NEAR(v, 0.0, 1e-12, "clamped v beyond T");
    ahc_quintic_eval(&q, -1.0, &x, &v, NULL);
    CHECK(x == 0.0 && v == 0.0, "clamped before 0: %g %g", x, v);

    /* r_x_d from 0.012 m (rest) to 0 */
    ahc_quintic_init(&q, 0.012, 0, 0, 0, 0, 0, 1.0);
    {
        double prev = 1.0;
        for (k = 0; k <= 1000; ++k) {
            ahc_quintic_eval(&q, k * 1e-3, &x, NULL, NULL);
            CHECK(x <= prev, "r_x_d monotonic at t=%g", k * 1e-3);
            prev = x;
        }
    }
    TEST_MAIN_END();
}
