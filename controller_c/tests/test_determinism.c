/*
 * test_determinism — establishes that the controller is a pure function of its parameters and
 * input sequence:
 *  - two runs with the same inputs give bit-identical outputs (memcmp);
 *  - two instances stepped interleaved with different inputs give exactly what each gives
 *    alone (no shared/global state);
 *  - a memcpy snapshot taken mid-run (during the ankle->hip transition) and restored into a
 *    fresh struct continues bit-identically (the instance is plain old data);
 *  - ahc_reset returns to the state of a fresh ahc_init.
 * The input sequence is a closed loop through the quasi-static robot (with the reaction of its
 * own motion in the ZMP: physically consistent for the default estimator) with a push that drives
 * the controller through all four phases, plus measurement noise from a fixed-seed generator:
 * ZMP +-0.2 mm, fz +-0.5 N, ankle angle +-1e-6 rad. The angle noise is kept small on purpose:
 * the default disturbance estimate differentiates the measured angles twice (backward
 * differences at 1 ms), so i.i.d. angle noise of +-1e-4 rad gives ~2 N m rms in d (and +-1e-5
 * rad ~0.2 N m), above fallback_disturbance_tol = 0.1 N m: the hip->ankle fallback would never
 * fire (known limitation, docs/controller.md).
 */
#include "ahc_test.h"

#define N 7000
static ahc_outputs a[N], b[N], c2[N];

static void sensors_at(qs_robot *r, int n, double F, unsigned long long *rng, ahc_sensors *s)
{
    qs_sense(r, push_profile(n * 1e-3, F, 0.5, 0.5, 3.0), s);
    s->zmp_x += test_rand(rng, -2e-4, 2e-4);
    s->fz += test_rand(rng, -0.5, 0.5);
    s->theta_ankle += test_rand(rng, -1e-6, 1e-6);
}

static void run_alone(const ahc_params *p, double F, unsigned long long seed, ahc_outputs *out)
{
    ahc_controller c;
    qs_robot r;
    ahc_sensors s;
    int n;
    ahc_init(&c, p);
    qs_init(&r, p);
    r.reaction = 1;
    for (n = 0; n < N; ++n) {
        sensors_at(&r, n, F, &seed, &s);
        ahc_step(&c, &s, &out[n]);
        qs_apply(&r, &out[n]);
    }
}

int main(void)
{
    ahc_params p;
    int n, phases_seen = 0;
    ahc_params_default(&p);

    run_alone(&p, 8.0, 1u, a);
    run_alone(&p, 8.0, 1u, b);
    CHECK(memcmp(a, b, sizeof a) == 0, "same inputs, bit-identical outputs");
    for (n = 0; n < N; ++n) phases_seen |= 1 << a[n].phase;
    CHECK(phases_seen == 15, "input sequence exercises all phases (mask %d)", phases_seen);

    /* interleaved instances with different pushes */
    run_alone(&p, -6.0, 7u, c2);
    {
        ahc_controller x, y;
        qs_robot rx, ry;
        ahc_sensors s;
        ahc_outputs ox, oy;
        unsigned long long sx = 1u, sy = 7u;
        int same = 1;
        ahc_init(&x, &p);
        ahc_init(&y, &p);
        qs_init(&rx, &p);
        rx.reaction = 1;
        qs_init(&ry, &p);
        ry.reaction = 1;
        for (n = 0; n < N; ++n) {
            sensors_at(&rx, n, 8.0, &sx, &s);
            ahc_step(&x, &s, &ox);
            qs_apply(&rx, &ox);
            sensors_at(&ry, n, -6.0, &sy, &s);
            ahc_step(&y, &s, &oy);
            qs_apply(&ry, &oy);
            if (memcmp(&ox, &a[n], sizeof ox) != 0 || memcmp(&oy, &c2[n], sizeof oy) != 0) same = 0;
        }
        CHECK(same, "interleaved instances equal the solo runs");
    }

    /* snapshot / restore via memcpy */
    {
        ahc_controller x, snap, restored;
        qs_robot r, r_snap;
        ahc_sensors s;
        ahc_outputs o;
        unsigned long long seed = 1u, seed_snap = 0u;
        int k = -1, same = 1;
        ahc_init(&x, &p);
        qs_init(&r, &p);
        r.reaction = 1;
        for (n = 0; n < N; ++n) {
            if (k < 0 && n > 0 && a[n - 1].phase == AHC_PHASE_ANKLE_TO_HIP) {
                memcpy(&snap, &x, sizeof snap);
                r_snap = r;
                seed_snap = seed;
                k = n;
            }
            sensors_at(&r, n, 8.0, &seed, &s);
            ahc_step(&x, &s, &o);
            qs_apply(&r, &o);
        }
        CHECK(k > 0, "snapshot taken in phase 1");
        memset(&restored, 0xA5, sizeof restored);
        memcpy(&restored, &snap, sizeof restored);
        for (n = k; n < N; ++n) {
            sensors_at(&r_snap, n, 8.0, &seed_snap, &s);
            ahc_step(&restored, &s, &o);
            qs_apply(&r_snap, &o);
            if (memcmp(&o, &a[n], sizeof o) != 0) same = 0;
        }
        CHECK(same, "restored snapshot continues bit-identically");

        /* reset equals fresh init */
        {
            ahc_controller fresh;
            ahc_init(&fresh, &p);
            ahc_reset(&x);
            CHECK(memcmp(&fresh, &x, sizeof x) == 0, "reset == fresh init");
        }
    }
    TEST_MAIN_END();
}
