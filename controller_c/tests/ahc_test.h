/*
 * ahc_test.h — tiny test harness for the controller tests (own code, no third-party framework)
 * and a quasi-static sensor model of the robot shared by several tests.
 */
#ifndef AHC_TEST_H
#define AHC_TEST_H

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ahc/controller.h"
#include "ahc/leg_ik.h"

/* HOAP-2's legs (hoap2/nominal.h), for the leg-kinematics tests. */
static inline ahc_leg_geometry ahc_test_hoap2_legs(void)
{
    ahc_leg_geometry g;
    g.thigh = HOAP2_THIGH;
    g.shank = HOAP2_SHANK;
    g.hip_y = HOAP2_HIP_Y;
    g.ankle_y = HOAP2_ANKLE_Y;
    return g;
}

static int ahc_test_failures = 0;
static int ahc_test_checks = 0;

#define CHECK(cond, ...)                                                              \
    do {                                                                              \
        ++ahc_test_checks;                                                            \
        if (!(cond)) {                                                                \
            ++ahc_test_failures;                                                      \
            fprintf(stderr, "%s:%d: CHECK(%s) failed: ", __FILE__, __LINE__, #cond);  \
            fprintf(stderr, __VA_ARGS__);                                             \
            fprintf(stderr, "\n");                                                    \
        }                                                                             \
    } while (0)

#define CHECK_NEAR(a, b, tol, what)                                                   \
    do {                                                                              \
        const double ahc_a_ = (a), ahc_b_ = (b), ahc_t_ = (tol);                      \
        CHECK(fabs(ahc_a_ - ahc_b_) <= ahc_t_, "%s: %.12g vs %.12g (|diff| %.3g > tol %.3g)", \
              what, ahc_a_, ahc_b_, fabs(ahc_a_ - ahc_b_), ahc_t_);                   \
    } while (0)

#define TEST_MAIN_END()                                                               \
    do {                                                                              \
        printf("%d checks, %d failures\n", ahc_test_checks, ahc_test_failures);       \
        return ahc_test_failures == 0 && ahc_test_checks > 0 ? 0 : 1;                 \
    } while (0)

/* Deterministic pseudo-random numbers in [lo, hi) (LCG; reproducible on every platform). */
static inline double test_rand(unsigned long long *state, double lo, double hi)
{
    *state = *state * 6364136223846793005ULL + 1442695040888963407ULL;
    return lo + (hi - lo) * (double)(*state >> 11) / 9007199254740992.0;
}

/* Rigid-body terms of the two-link body on a flat, resting foot (conventions of docs/controller.md:
 * x forward, z up from the SOLE, angles positive pitching forward), for given joint angles,
 * rates and accelerations:
 *   dH_O = sum_i m_i (x_i z_i'' - z_i x_i'') - I1 th1'' - I2 (th1'' + th2'')
 *        = minus the rate of change of the body's angular momentum about the sole point O under
 *          the ankle (y axis), so that the moment balance about O reads
 *          p f_z = g (sum_i m_i x_i + m_f x_f) + d_ext + dH_O;
 *   mzdd = sum_i m_i z_i''  (f_z = (m + m_f) g + mzdd);
 *   Hy   = the angular momentum about O itself, sum_i m_i (z_i x_i' - x_i z_i') + I1 th1' +
 *          I2 (th1' + th2') (dHy/dt = -dH_O; lets a test check dH_O by differentiation).
 * Written out per link (position, velocity, acceleration of each CoM) independently of the
 * controller's implementation. Any output pointer may be NULL. */
static inline void test_body_dynamics(const ahc_params *p, double th1, double th2, double w1, double w2,
                                      double a1, double a2, double *dH_O, double *mzdd, double *Hy)
{
    const double q[2] = { th1, th1 + th2 }, w[2] = { w1, w1 + w2 }, a[2] = { a1, a1 + a2 };
    /* CoM i = ankle + sum over segments j <= i of L_ij (sin q_j, cos q_j) */
    const double L[2][2] = { { p->lg1, 0.0 }, { p->l1, p->lg2 } };
    const double m[2] = { p->m1, p->m2 }, I[2] = { p->I1, p->I2 };
    double dH = 0.0, mz = 0.0, H = 0.0;
    int i, j;
    for (i = 0; i < 2; ++i) {
        double x = 0.0, z = p->ankle_height, vx = 0.0, vz = 0.0, ax = 0.0, az = 0.0;
        for (j = 0; j <= i; ++j) {
            const double S = sin(q[j]), C = cos(q[j]), l = L[i][j];
            x += l * S;
            z += l * C;
            vx += l * C * w[j];
            vz -= l * S * w[j];
            ax += l * (C * a[j] - S * w[j] * w[j]);
            az -= l * (S * a[j] + C * w[j] * w[j]);
        }
        dH += m[i] * (x * az - z * ax) - I[i] * a[i];
        mz += m[i] * az;
        H += m[i] * (z * vx - x * vz) + I[i] * w[i];
    }
    if (dH_O) *dH_O = dH;
    if (mzdd) *mzdd = mz;
    if (Hy) *Hy = H;
}

/* Quasi-static robot: the joints follow the references with a one-tick delay (ideal servo), the
 * foot is flat, and the ZMP follows from the moment balance about the sole point under the ankle
 * including the feet and a horizontal push force F at height push_height above the sole:
 *   reaction = 0 (static): (m + m_f) g p = m g r_x + m_f g x_f + F push_height, fz = (m + m_f) g;
 *   reaction = 1 (physically consistent for moving joints): p fz = g (m r_x + m_f x_f) +
 *     F push_height + dH_O, fz = (m + m_f) g + sum m_i z_i'', with the joint rates and
 *     accelerations of the robot's own (discrete) motion taken as backward differences over its
 *     last three ticks (test_body_dynamics).
 * reaction = 0 is the world of the paper-literal estimator (reaction_compensation = 0): fed with
 * the reaction through an ideal one-tick servo, eq. 11/16 close an algebraic loop of gain >= 1
 * (docs/controller.md 4.4). A real servo's finite bandwidth breaks that loop (the plant, and
 * test_closed_loop_dynamic's servo lag, are stable without a ZMP filter); this ideal-servo model
 * needs the ZMP filter (prototype finding 1, docs/controller.md §4.2), so the tests that use reaction = 1 with the paper's
 * estimate set zmp_filter_tau = QS_ZMP_FILTER_TAU. */
#define QS_ZMP_FILTER_TAU 0.02
typedef struct {
    ahc_params p;          /* the "true" robot (same nominal numbers as the controller) */
    double th1, th2;       /* current joint angles */
    double push_height;
    int reaction;          /* 1: include the reaction of the robot's own motion (see above) */
    double prev1[2], prev2[2]; /* angles one and two ticks ago */
    int nprev;             /* valid entries of prev* (0..2) */
} qs_robot;

static inline void qs_init(qs_robot *r, const ahc_params *p)
{
    memset(r, 0, sizeof *r);
    r->p = *p;
    r->th1 = 0.0;
    r->th2 = 0.0;
    r->push_height = 0.335;
    r->reaction = 0;
}

static inline void qs_sense(const qs_robot *r, double push, ahc_sensors *s)
{
    const ahc_params *p = &r->p;
    const double m = p->m1 + p->m2, M = m + p->feet_mass, h = p->sample_period;
    double rx, dH = 0.0, mzdd = 0.0;
    ahc_com(p, r->th1, r->th2, &rx, NULL);
    if (r->reaction && r->nprev >= 1) {
        const double w1 = (r->th1 - r->prev1[0]) / h, w2 = (r->th2 - r->prev2[0]) / h;
        const double a1 = r->nprev >= 2 ? (r->th1 - 2.0 * r->prev1[0] + r->prev1[1]) / (h * h) : 0.0;
        const double a2 = r->nprev >= 2 ? (r->th2 - 2.0 * r->prev2[0] + r->prev2[1]) / (h * h) : 0.0;
        test_body_dynamics(p, r->th1, r->th2, w1, w2, a1, a2, &dH, &mzdd, NULL);
    }
    s->theta_ankle = r->th1;
    s->theta_hip = r->th2;
    s->fz = M * p->g + mzdd;
    s->zmp_x = (m * p->g * rx + p->feet_mass * p->g * p->feet_com_x + push * r->push_height + dH) / s->fz;
}

static inline void qs_apply(qs_robot *r, const ahc_outputs *o)
{
    r->prev1[1] = r->prev1[0];
    r->prev2[1] = r->prev2[0];
    r->prev1[0] = r->th1;
    r->prev2[0] = r->th2;
    if (r->nprev < 2) r->nprev++;
    r->th1 = o->theta_ankle_ref;
    r->th2 = o->theta_hip_ref;
}

/* Trapezoidal push profile: 0 until t0, ramp to F over rise, hold until t1, ramp down over rise. */
static inline double push_profile(double t, double F, double t0, double rise, double t1)
{
    if (t < t0) return 0.0;
    if (t < t0 + rise) return F * (t - t0) / rise;
    if (t < t1) return F;
    if (t < t1 + rise) return F * (1.0 - (t - t1) / rise);
    return 0.0;
}

/* Closed loop of a fresh controller through the quasi-static robot with the reaction of its own
 * motion in the ZMP; push F from 0.5 s with 0.5 s ramps, held until t1. Records at most nmax
 * ticks of outputs; returns their number (0 if p is invalid). */
static inline int qs_run(const ahc_params *p, double F, double t1, double t_end, ahc_outputs *out, int nmax)
{
    ahc_controller c;
    qs_robot r;
    ahc_sensors s;
    int n, N = (int)(t_end / p->sample_period + 0.5);
    if (ahc_init(&c, p) != AHC_OK) return 0;
    qs_init(&r, p);
    r.reaction = 1;
    for (n = 0; n < N && n < nmax; ++n) {
        qs_sense(&r, push_profile(n * p->sample_period, F, 0.5, 0.5, t1), &s);
        ahc_step(&c, &s, &out[n]);
        qs_apply(&r, &out[n]);
    }
    return n;
}

#endif /* AHC_TEST_H */
