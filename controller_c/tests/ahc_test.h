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

/* Quasi-static robot: the joints follow the references with a one-tick delay (ideal servo), the
 * foot is flat, and the ZMP follows from the static moment balance about the ankle projection
 * including the feet and a horizontal push force F at height push_height above the sole:
 *   (m + m_f) g p = m g r_x + m_f g x_f + F push_height,   fz = (m + m_f) g.
 * No dynamic reaction terms (those belong to the plant). */
typedef struct {
    ahc_params p;          /* the "true" robot (same nominal numbers as the controller) */
    double th1, th2;       /* current joint angles */
    double push_height;
} qs_robot;

static inline void qs_init(qs_robot *r, const ahc_params *p)
{
    r->p = *p;
    r->th1 = 0.0;
    r->th2 = 0.0;
    r->push_height = 0.335;
}

static inline void qs_sense(const qs_robot *r, double push, ahc_sensors *s)
{
    const ahc_params *p = &r->p;
    const double m = p->m1 + p->m2, M = m + p->feet_mass;
    double rx;
    ahc_com(p, r->th1, r->th2, &rx, NULL);
    s->theta_ankle = r->th1;
    s->theta_hip = r->th2;
    s->zmp_x = (m * p->g * rx + p->feet_mass * p->g * p->feet_com_x + push * r->push_height) / (M * p->g);
    s->fz = M * p->g;
}

static inline void qs_apply(qs_robot *r, const ahc_outputs *o)
{
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

#endif /* AHC_TEST_H */
