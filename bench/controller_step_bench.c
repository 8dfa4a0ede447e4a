/*
 * controller_step_bench — cost of one control tick on a realistic input sequence, side by side:
 * ahc_step (the paper's sagittal controller) and ahc3d_step (the 3D controller: the sagittal one,
 * the frontal one and the legs' kinematics). 8 s of a quasi-static HOAP-2 closed loop with a 8 N
 * push from behind applied and released (all four sagittal phases) plus sensor noise; for the 3D
 * controller also a 12 N push toward +y (the lateral lean and the legs' per-leg set points) and
 * the twelve joint angles from the legs' kinematics of the last references. Each sequence is
 * recorded once in closed loop, then replayed through a fresh instance `passes` times; every call
 * is timed individually with CLOCK_MONOTONIC.
 * Prints median / min / p99 ns per step (timer overhead, measured the same way, subtracted) and
 * the batch mean. Not a test. Usage: controller_step_bench [passes (default 20)]
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ahc/controller.h"
#include "ahc/controller3d.h"

#define N_TICKS 8000

static ahc_sensors seq[N_TICKS];
static ahc3d_sensors seq3[N_TICKS];

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

static double push_y(double t)
{
    if (t < 1.0) return 0.0;
    if (t < 1.3) return 12.0 * (t - 1.0) / 0.3;
    if (t < 1.7) return 12.0;
    if (t < 2.0) return 12.0 * (2.0 - t) / 0.3;
    return 0.0;
}

/* The 3D sequence: the sagittal sensors as record(), the joints from the legs' kinematics of the
 * last references (one tick late), the lateral ZMP from the frontal moment balance with the push. */
static void record3d(const ahc_params *p, const ahc_frontal_params *f)
{
    ahc3d c;
    ahc3d_outputs o;
    double th1 = 0.0, th2 = 0.0, phi = 0.0, psi = 0.0;
    const double m = p->m1 + p->m2, M = m + p->feet_mass;
    unsigned long long rng = 43u;
    int n;
    ahc3d_init(&c, p, f);
    for (n = 0; n < N_TICKS; ++n) {
        double rx, ry, noise;
        rng = rng * 6364136223846793005ULL + 1442695040888963407ULL;
        noise = ((double)(rng >> 11) / 9007199254740992.0 - 0.5) * 4e-4;
        ahc_com(p, th1, th2, &rx, NULL);
        ahc_frontal_com(f, p, phi, psi, &ry, NULL);
        seq3[n].sag.theta_ankle = th1;
        seq3[n].sag.theta_hip = th2;
        seq3[n].sag.zmp_x = (m * p->g * rx + p->feet_mass * p->g * p->feet_com_x + push(n * 1e-3) * 0.335) / (M * p->g) + noise;
        seq3[n].sag.fz = M * p->g;
        seq3[n].zmp_y = (m * p->g * ry + push_y(n * 1e-3) * 0.335) / (M * p->g) + noise;
        seq3[n].fz_left = seq3[n].fz_right = 0.5 * M * p->g;
        ahc_legs_from_planes(&c.legs, th1, th2, phi, psi, seq3[n].q);
        ahc3d_step(&c, &seq3[n], &o);
        th1 = o.sag.theta_ankle_ref;
        th2 = o.sag.theta_hip_ref;
        phi = o.frontal.phi_ref;
        psi = o.frontal.psi_ref;
    }
}

typedef struct {
    ahc_params p;
    ahc_frontal_params f;
    ahc_controller c;
    ahc3d c3;
    ahc_step_params st;
    double sink;
    int phases;
} bench_state;

static void init2(bench_state *b) { ahc_init(&b->c, &b->p); }
static void init3(bench_state *b) { ahc3d_init(&b->c3, &b->p, &b->f); }
/* the stepping layer on and triggered at once (its threshold inside the soles): a step runs through
 * most of the sequence, each tick estimating the CoM, planning and solving both legs' IK */
static void init3s(bench_state *b) { ahc3d_init_stepping(&b->c3, &b->p, &b->f, &b->st); }

static void step2(bench_state *b, int n)
{
    ahc_outputs o;
    ahc_step(&b->c, &seq[n], &o);
    b->sink += o.theta_ankle_ref;
    b->phases |= 1 << o.phase;
}

static void step3(bench_state *b, int n)
{
    ahc3d_outputs o;
    ahc3d_step(&b->c3, &seq3[n], &o);
    b->sink += o.sag.theta_ankle_ref + o.q_ref_offset[0][2];
    b->phases |= 1 << o.sag.phase;
}

static void step3s(bench_state *b, int n)
{
    ahc3d_outputs o;
    ahc3d_step(&b->c3, &seq3[n], &o);
    b->sink += o.sag.theta_ankle_ref + o.q_ref_offset[0][2];
    b->phases |= 1 << o.step.phase; /* here: the stepping phases seen */
}

/* Times `step` over the sequence `passes` times, a fresh instance (`init`) per pass; prints its line. */
static void run(const char *name, void (*init)(bench_state *), void (*step)(bench_state *, int), bench_state *b,
                int passes, double overhead, double *dt)
{
    const size_t total = (size_t)passes * N_TICKS;
    size_t k = 0;
    double t0, batch;
    int pass, n;
    b->phases = 0;
    for (pass = 0; pass < passes; ++pass) {
        init(b);
        for (n = 0; n < N_TICKS; ++n) {
            const double a = now_ns();
            step(b, n);
            dt[k++] = now_ns() - a - overhead;
        }
    }
    /* batch mean without per-call timing */
    t0 = now_ns();
    for (pass = 0; pass < passes; ++pass) {
        init(b);
        for (n = 0; n < N_TICKS; ++n) step(b, n);
    }
    batch = (now_ns() - t0) / (double)total;
    qsort(dt, total, sizeof *dt, cmp_double);
    printf("%-15s %zu ticks (%d passes x %d, phases seen mask 0x%x): median %.1f ns/step, min %.1f ns, "
           "p99 %.1f ns; batch mean %.1f ns/step\n",
           name, total, passes, N_TICKS, b->phases, dt[total / 2], dt[0], dt[(size_t)(0.99 * (double)(total - 1))],
           batch);
}

int main(int argc, char **argv)
{
    static bench_state b;
    int passes = argc > 1 ? atoi(argv[1]) : 20;
    size_t total, i;
    double *dt, overhead;

    if (passes < 1) passes = 1;
    ahc_params_default(&b.p);
    ahc_frontal_params_default(&b.f);
    record(&b.p);
    record3d(&b.p, &b.f);
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
    printf("timer overhead %.1f ns subtracted\n", overhead);
    run("ahc_step", init2, step2, &b, passes, overhead, dt);
    run("ahc3d_step", init3, step3, &b, passes, overhead, dt);
    ahc_step_params_default(&b.st);
    b.st.stepping_enabled = 1;
    b.st.step_trigger_x = -0.05;
    run("ahc3d_step+step", init3s, step3s, &b, passes, overhead, dt);
    if (!isfinite(b.sink)) printf("non-finite output\n");
    free(dt);
    return 0;
}
