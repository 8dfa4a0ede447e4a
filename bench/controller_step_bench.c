/*
 * controller_step_bench — cost of one ahc_step (one 1 kHz control tick) on a realistic input
 * sequence: 8 s of a quasi-static HOAP-2 closed loop with a 8 N push from behind applied and
 * released (all four phases: ankle, ankle->hip, hip, hip->ankle) plus sensor noise. The
 * sequence is recorded once in closed loop, then replayed through a fresh instance `passes`
 * times; every call is timed individually with CLOCK_MONOTONIC.
 * Prints median / min / p99 ns per step (timer overhead, measured the same way, subtracted)
 * and the batch mean. Not a test. Usage: controller_step_bench [passes (default 20)]
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ahc/controller.h"

#define N_TICKS 8000

static ahc_sensors seq[N_TICKS];

static double now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double push(double t)
{
    if (t < 0.5) return 0.0;
    if (t < 1.0) return 8.0 * (t - 0.5) / 0.5;
    if (t < 3.0) return 8.0;
    if (t < 3.5) return 8.0 * (1.0 - (t - 3.0) / 0.5);
    return 0.0;
}

/* Record the closed-loop sensor sequence (quasi-static robot: joints follow the reference with a
 * one-tick delay, ZMP from the static moment balance incl. feet and push at 0.335 m). */
static void record(const ahc_params *p)
{
    ahc_controller c;
    ahc_outputs o;
    double th1 = 0.0, th2 = 0.0;
    const double m = p->m1 + p->m2, M = m + p->feet_mass;
    unsigned long long rng = 42u;
    int n;
    ahc_init(&c, p);
    for (n = 0; n < N_TICKS; ++n) {
        double rx, noise;
        rng = rng * 6364136223846793005ULL + 1442695040888963407ULL;
        noise = ((double)(rng >> 11) / 9007199254740992.0 - 0.5) * 4e-4;
        ahc_com(p, th1, th2, &rx, NULL);
        seq[n].theta_ankle = th1;
        seq[n].theta_hip = th2;
        seq[n].zmp_x = (m * p->g * rx + p->feet_mass * p->g * p->feet_com_x + push(n * 1e-3) * 0.335) / (M * p->g) + noise;
        seq[n].fz = M * p->g;
        ahc_step(&c, &seq[n], &o);
        th1 = o.theta_ankle_ref;
        th2 = o.theta_hip_ref;
    }
}

int main(int argc, char **argv)
{
    ahc_params p;
    ahc_controller c;
    ahc_outputs o;
    int passes = argc > 1 ? atoi(argv[1]) : 20;
    size_t total, k = 0, i;
    double *dt, overhead, t0, batch, sink = 0.0;
    int pass, n, phases = 0;

    if (passes < 1) passes = 1;
    ahc_params_default(&p);
    record(&p);
    total = (size_t)passes * N_TICKS;
    dt = malloc(total * sizeof *dt);
    if (!dt) return 1;

    /* timer overhead: median of back-to-back reads */
    for (i = 0; i < 100000 && i < total; ++i) {
        const double a = now_ns();
        dt[i] = now_ns() - a;
    }
    qsort(dt, i, sizeof *dt, cmp_double);
    overhead = dt[i / 2];

    for (pass = 0; pass < passes; ++pass) {
        ahc_init(&c, &p);
        for (n = 0; n < N_TICKS; ++n) {
            const double a = now_ns();
            ahc_step(&c, &seq[n], &o);
            dt[k++] = now_ns() - a - overhead;
            sink += o.theta_ankle_ref;
            phases |= 1 << o.phase;
        }
    }
    /* batch mean without per-call timing */
    ahc_init(&c, &p);
    t0 = now_ns();
    for (pass = 0; pass < passes; ++pass) {
        ahc_reset(&c);
        for (n = 0; n < N_TICKS; ++n) ahc_step(&c, &seq[n], &o);
        sink += o.theta_ankle_ref;
    }
    batch = (now_ns() - t0) / (double)total;

    qsort(dt, total, sizeof *dt, cmp_double);
    printf("ahc_step: %zu ticks (%d passes x %d, phases seen mask 0x%x)\n", total, passes, N_TICKS, phases);
    printf("median %.1f ns/step, min %.1f ns, p99 %.1f ns (timer overhead %.1f ns subtracted); batch mean %.1f ns/step\n",
           dt[total / 2], dt[0], dt[(size_t)(0.99 * (double)(total - 1))], overhead, batch);
    if (!isfinite(sink)) printf("non-finite output\n");
    free(dt);
    return 0;
}
