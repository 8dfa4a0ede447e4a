/*
 * leg_ik_bench — cost of the leg's closed-form kinematics for any foot pose (controller_c
 * leg_ik.h): ahc_leg_ik_pose (with HOAP-2's limits reported), ahc_leg_fk_pose, and the foot-flat
 * ahc_leg_ik the 3D controller uses today, on 4096 poses made by the forward kinematics of random
 * joint vectors inside HOAP-2's limits (both legs). Each call timed individually with
 * CLOCK_MONOTONIC (timer overhead, measured the same way, subtracted): median / min / p99 ns per
 * call, and the batch mean of untimed calls. Not a test. Usage: leg_ik_bench [passes (default 50)]
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "ahc/leg_ik.h"
#include "hoap2/nominal.h"

#define N_POSES 4096

static double ankle[N_POSES][3], Rf[N_POSES][9], qs[N_POSES][AHC_LEG_JOINTS], hip[N_POSES][3], Rt[N_POSES][9];
static int side[N_POSES];

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

static double uniform(unsigned long long *s, double lo, double hi)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return lo + (hi - lo) * (double)(*s >> 11) / 9007199254740992.0;
}

enum { IK_POSE, FK_POSE, IK_FLAT };

static double sink;

static void call(int what, const ahc_leg_geometry *g, const ahc_leg_limits lim[2], int n)
{
    double q[AHC_LEG_JOINTS], a[3], R[9];
    switch (what) {
    case IK_POSE:
        sink += ahc_leg_ik_pose(g, &lim[side[n]], ankle[n], Rf[n], q) + q[AHC_LEG_HIP_YAW];
        break;
    case FK_POSE:
        ahc_leg_fk_pose(g, qs[n], a, R);
        sink += a[0] + R[1];
        break;
    default:
        sink += ahc_leg_ik(g, hip[n], Rt[n], q) + q[AHC_LEG_HIP_YAW];
        break;
    }
}

int main(int argc, char **argv)
{
    static const char *const names[3] = {"ahc_leg_ik_pose", "ahc_leg_fk_pose", "ahc_leg_ik (foot flat)"};
    const ahc_leg_geometry g = {HOAP2_THIGH, HOAP2_SHANK, HOAP2_HIP_Y, HOAP2_ANKLE_Y};
    ahc_leg_limits lim[2];
    int passes = argc > 1 ? atoi(argv[1]) : 50, n, j, what, pass;
    unsigned long long st = 1;
    size_t total, k, i;
    double *dt, overhead;
    if (passes < 1) passes = 1;
    ahc_leg_limits_hoap2(AHC_LEFT, &lim[0]);
    ahc_leg_limits_hoap2(AHC_RIGHT, &lim[1]);
    for (n = 0; n < N_POSES; ++n) {
        side[n] = n & 1;
        for (j = 0; j < AHC_LEG_JOINTS; ++j) qs[n][j] = uniform(&st, lim[side[n]].lo[j], lim[side[n]].hi[j]);
        ahc_leg_fk_pose(&g, qs[n], ankle[n], Rf[n]);
        ahc_leg_fk(&g, qs[n], hip[n], Rt[n]);
    }
    total = (size_t)passes * N_POSES;
    dt = malloc(total * sizeof *dt);
    if (!dt) return 1;
    for (i = 0; i < 100000 && i < total; ++i) {
        const double a = now_ns();
        dt[i] = now_ns() - a;
    }
    qsort(dt, i, sizeof *dt, cmp_double);
    overhead = dt[i / 2];
    printf("timer overhead %.1f ns subtracted; %d poses inside HOAP-2's limits, %d passes\n", overhead, N_POSES, passes);
    for (what = IK_POSE; what <= IK_FLAT; ++what) {
        double t0, batch;
        k = 0;
        for (pass = 0; pass < passes; ++pass)
            for (n = 0; n < N_POSES; ++n) {
                const double a = now_ns();
                call(what, &g, lim, n);
                dt[k++] = now_ns() - a - overhead;
            }
        t0 = now_ns();
        for (pass = 0; pass < passes; ++pass)
            for (n = 0; n < N_POSES; ++n) call(what, &g, lim, n);
        batch = (now_ns() - t0) / (double)total;
        qsort(dt, total, sizeof *dt, cmp_double);
        printf("%-24s median %.1f ns/call, min %.1f ns, p99 %.1f ns; batch mean %.1f ns/call\n", names[what],
               dt[total / 2], dt[0], dt[(size_t)(0.99 * (double)(total - 1))], batch);
    }
    if (!isfinite(sink)) printf("non-finite output\n");
    free(dt);
    return 0;
}
