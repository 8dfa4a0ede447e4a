/*
 * test_lean — establishes the sustained-push lean (lean_enabled; our extension, docs/controller.md
 * section 4.6), driven through the quasi-static robot of ahc_test.h (no reaction in the ZMP):
 *  A. off (the default), the lean parameters change nothing: outputs bit-identical;
 *  B. on, a sustained push on the chest: the CoM reference settles at -D/(m g), D the external
 *     moment (here = d, at rest), which puts the measured ZMP back under the ankle (|p| < 1 mm,
 *     against F h/(M g) = -24 mm without it); the robot stays in phase 2 or 3;
 *  C. on, a sustained push from behind: the CoM reference leans back and stops at
 *     heel_x + lean_margin, never beyond; the ZMP moves back by as much (45 -> 23 mm at 9 N);
 *  D. on the chest, a push beyond what the lean can take: bounded by toe_x - lean_margin;
 *  E. the CoM reference and the reference angles move continuously (no jump at any switch), the
 *     robot returns to phase 0 after the push, and phase 3 -> 0 waits for the lean to be
 *     released (|r_x_d| <= 1 mm);
 *  F. a lean_margin that leaves no room in the sole is refused with a message naming it;
 * the pendulum law (lean_law = AHC_LEAN_PENDULUM, section 4.7):
 *  G. its parameters change nothing while lean_enabled = 0 or lean_law = 0: outputs bit-identical;
 *  H. a sustained push on the chest below the trigger: in phase 0 already the CoM leans forward to
 *     -D/(m g) and the ZMP comes back under the ankle (|p| < 1.5 mm, against F h/(M g) without it),
 *     the ZMP never nearer the heel than lean_zmp_margin, and the robot erect again after the push;
 *     from behind, the lean stops lean_margin inside the heel;
 *  I. a push from the front beyond what the lean can take: the CoM reference stays lean_margin
 *     inside the toe; reference angles continuous throughout;
 *  J. the named configuration "omnidirectional" is this law; a lean_zmp_margin beyond the heel and
 *     a capture gain the sample period cannot integrate are refused, naming them.
 */
#include "ahc_test.h"

#define NMAX 20000
static ahc_outputs rec[NMAX];
static ahc_outputs rec2[NMAX];

/* Closed loop through the quasi-static robot (with the reaction in the ZMP: the moment balance
 * the lean reads is consistent only with it): push F from 0.5 s (0.5 s ramps) held until t1. */
static int run_qs(const ahc_params *p, double F, double t1, double t_end, ahc_outputs *out)
{
    return qs_run(p, F, t1, t_end, out, NMAX);
}

/* ZMP the quasi-static robot measures for these outputs (the next tick's sensor reading). */
static double zmp_of(const ahc_params *p, const ahc_outputs *o, double push)
{
    qs_robot r;
    ahc_sensors s;
    qs_init(&r, p);
    r.th1 = o->theta_ankle_ref;
    r.th2 = o->theta_hip_ref;
    qs_sense(&r, push, &s);
    return s.zmp_x;
}

int main(void)
{
    ahc_params p, q;
    const double h = 0.001;
    int n, N, i;

    /* A */
    ahc_params_default(&p);
    p.zmp_filter_tau = QS_ZMP_FILTER_TAU; /* the ideal-servo robot needs it (ahc_test.h) */
    q = p;
    q.lean_tau = 2.0;
    q.lean_margin = 0.03;
    N = run_qs(&p, 9.0, 4.0, 8.0, rec);
    CHECK(run_qs(&q, 9.0, 4.0, 8.0, rec2) == N && N > 0, "runs");
    CHECK(memcmp(rec, rec2, (size_t)N * sizeof rec[0]) == 0, "lean off: lean_tau and lean_margin change nothing");
    CHECK(rec[3000].phase == AHC_PHASE_HIP, "a 9 N push takes the default to the hip strategy");
    CHECK(fabs(zmp_of(&p, &rec[3900], 9.0) - 9.0 * 0.335 / ((p.m1 + p.m2 + p.feet_mass) * p.g)) < 0.004,
          "without the lean the ZMP stays F h/(M g) ahead: %g", zmp_of(&p, &rec[3900], 9.0));

    /* B */
    p.lean_enabled = 1;
    N = run_qs(&p, -5.0, 4.0, 10.0, rec);
    {
        const ahc_outputs *o = &rec[3900];
        const double m = p.m1 + p.m2;
        CHECK(o->phase == AHC_PHASE_HIP || o->phase == AHC_PHASE_HIP_TO_ANKLE,
              "phase 2 or 3 under the sustained push (%d)", o->phase);
        CHECK(fabs(o->com_x_desired + o->disturbance_moment / (m * p.g)) < 2e-4,
              "r_x_d = -d/(m g): %g vs %g", o->com_x_desired, -o->disturbance_moment / (m * p.g));
        CHECK(o->com_x_desired > 0.02, "leaned forward by more than 20 mm: %g", o->com_x_desired);
        CHECK(fabs(zmp_of(&p, o, -5.0)) < 0.001, "the ZMP is back under the ankle: %g", zmp_of(&p, o, -5.0));
    }

    /* E: continuity, return, 3 -> 0 waits for the lean */
    for (n = 1; n < N; ++n) {
        CHECK(fabs(rec[n].theta_ankle_ref - rec[n - 1].theta_ankle_ref) <= h * 2.0 + 1e-12 &&
                  fabs(rec[n].theta_hip_ref - rec[n - 1].theta_hip_ref) <= h * 4.0 + 1e-12,
              "reference angles continuous at tick %d", n);
        if (rec[n].phase != AHC_PHASE_ANKLE && rec[n - 1].phase != AHC_PHASE_ANKLE)
            CHECK(fabs(rec[n].com_x_desired - rec[n - 1].com_x_desired) < 2e-4, "r_x_d continuous at tick %d: %g -> %g",
                  n, rec[n - 1].com_x_desired, rec[n].com_x_desired);
        if (rec[n].phase == AHC_PHASE_ANKLE && rec[n - 1].phase == AHC_PHASE_HIP_TO_ANKLE)
            /* the switch reads the lean of this tick; the last output shows the one before */
            CHECK(fabs(rec[n - 1].com_x_desired) <= 0.001 + 1e-5, "3 -> 0 only with the lean released: %g",
                  rec[n - 1].com_x_desired);
    }
    CHECK(rec[N - 1].phase == AHC_PHASE_ANKLE, "back in phase 0 after the push (%d)", rec[N - 1].phase);

    /* C */
    N = run_qs(&p, 9.0, 4.0, 10.0, rec);
    {
        double lo = 1.0;
        for (i = 0; i < N; ++i)
            if (rec[i].phase != AHC_PHASE_ANKLE && rec[i].com_x_desired < lo) lo = rec[i].com_x_desired;
        CHECK(lo >= p.heel_x + p.lean_margin - 1e-12, "bounded by heel + margin: %g", lo);
        CHECK(lo <= p.heel_x + p.lean_margin + 1e-9, "reaches heel + margin under 9 N: %g", lo);
        CHECK(fabs(zmp_of(&p, &rec[3900], 9.0) - 0.0229) < 0.001, "ZMP 22.5 mm further back: %g",
              zmp_of(&p, &rec[3900], 9.0));
    }

    /* D */
    N = run_qs(&p, -6.0, 4.0, 10.0, rec);
    CHECK(rec[3900].phase != AHC_PHASE_ANKLE && rec[3900].com_x_desired > 0.015,
          "a front push leans towards the toe: phase %d, r_x_d %g", rec[3900].phase, rec[3900].com_x_desired);
    N = run_qs(&p, -12.0, 4.0, 10.0, rec);
    for (i = 0; i < N; ++i)
        CHECK(rec[i].phase == AHC_PHASE_ANKLE || rec[i].com_x_desired <= p.toe_x - p.lean_margin + 1e-12,
              "bounded by toe - margin at tick %d: %g", i, rec[i].com_x_desired);

    /* F */
    {
        char msg[200];
        q = p;
        q.lean_margin = 0.04;
        CHECK(ahc_params_validate(&q, msg, sizeof msg) == AHC_ERR_INCONSISTENT && strstr(msg, "lean_margin"),
              "lean_margin beyond the heel refused: %s", msg);
    }
    /* G: the pendulum law's parameters are inert unless it runs */
    ahc_params_default(&p);
    p.zmp_filter_tau = QS_ZMP_FILTER_TAU;
    q = p;
    q.lean_law = AHC_LEAN_PENDULUM;
    q.lean_zmp_margin = 0.005;
    q.lean_capture_gain = 4.0;
    N = run_qs(&p, 9.0, 4.0, 8.0, rec);
    CHECK(run_qs(&q, 9.0, 4.0, 8.0, rec2) == N && N > 0, "runs");
    CHECK(memcmp(rec, rec2, (size_t)N * sizeof rec[0]) == 0, "lean off: lean_law and its parameters change nothing");
    p.lean_enabled = 1;
    q = p;
    q.lean_zmp_margin = 0.005;
    q.lean_capture_gain = 4.0;
    N = run_qs(&p, 9.0, 4.0, 8.0, rec);
    CHECK(run_qs(&q, 9.0, 4.0, 8.0, rec2) == N && N > 0, "runs");
    CHECK(memcmp(rec, rec2, (size_t)N * sizeof rec[0]) == 0,
          "lean_law 0: lean_zmp_margin and lean_capture_gain change nothing");

    /* H: a 3 N push on the chest (F h/(M g) = -14 mm, above the -16 mm trigger) */
    CHECK(ahc_params_named(&p, "omnidirectional") == AHC_OK, "named configuration");
    p.zmp_filter_tau = QS_ZMP_FILTER_TAU;
    N = run_qs(&p, -3.0, 4.0, 8.0, rec);
    {
        const double M = p.m1 + p.m2 + p.feet_mass, m = p.m1 + p.m2;
        const ahc_outputs *o = &rec[3900];
        double pmin = 0.0;
        CHECK(N == 8000, "runs");
        for (i = 0; i < N; ++i)
            CHECK(rec[i].phase == AHC_PHASE_ANKLE, "a 3 N push stays in phase 0 (tick %d: %d)", i, rec[i].phase);
        CHECK(fabs(o->com_x + o->disturbance_moment / (m * p.g)) < 1.5e-3 && o->com_x > 0.01,
              "phase 0 leans the CoM forward to -D/(m g): %g vs %g", o->com_x, -o->disturbance_moment / (m * p.g));
        CHECK(fabs(zmp_of(&p, o, -3.0)) < 1.5e-3, "the ZMP is back under the ankle: %g (without the lean %g)",
              zmp_of(&p, o, -3.0), -3.0 * 0.335 / (M * p.g));
        for (i = 0; i < N; ++i) {
            const double z = zmp_of(&p, &rec[i], push_profile(i * p.sample_period, -3.0, 0.5, 0.5, 4.0));
            if (z < pmin) pmin = z;
        }
        CHECK(pmin > p.heel_x + p.lean_zmp_margin, "the ZMP stays lean_zmp_margin inside the heel: %g", pmin);
        CHECK(fabs(rec[N - 1].com_x) < 1e-3, "erect again 4 s after the push: CoM %g", rec[N - 1].com_x);
    }
    N = run_qs(&p, 3.0, 4.0, 8.0, rec);
    CHECK(fabs(rec[3900].com_x - (p.heel_x + p.lean_margin)) < 1e-3,
          "from behind the lean stops lean_margin inside the heel: %g", rec[3900].com_x);

    /* bumpless start and switch-on, with the link CoM offsets of the 3D plant (an erect posture
     * off zero): the first tick's ankle reference moves from the measured angle only by eq. 11's
     * one step, not by the erect angle */
    {
        ahc_controller c;
        ahc_sensors sn;
        ahc_outputs o1, o2;
        ahc_params r = p, s0;
        r.link1_com_x = 0.0044;
        r.link2_com_x = 0.0024;
        s0 = r;
        s0.lean_enabled = 0;
        CHECK(ahc_init(&c, &r) == AHC_OK, "init");
        sn.theta_ankle = -0.008;
        sn.theta_hip = -0.017;
        sn.zmp_x = 0.0;
        sn.fz = (r.m1 + r.m2 + r.feet_mass) * r.g;
        ahc_step(&c, &sn, &o1);
        CHECK(fabs(o1.theta_ankle_ref - sn.theta_ankle) < 1e-5, "bumpless start: %g from %g", o1.theta_ankle_ref,
              sn.theta_ankle);
        CHECK(ahc_init(&c, &s0) == AHC_OK, "init, lean off");
        for (i = 0; i < 500; ++i) ahc_step(&c, &sn, &o1);
        CHECK(ahc_update_params(&c, &r) == AHC_OK, "switch the pendulum lean on");
        ahc_step(&c, &sn, &o2);
        CHECK(fabs(o2.theta_ankle_ref - o1.theta_ankle_ref) < 1e-5, "bumpless switch-on: %g -> %g",
              o1.theta_ankle_ref, o2.theta_ankle_ref);
    }

    /* I: a 9 N push on the chest (target beyond the toe margin) */
    N = run_qs(&p, -9.0, 4.0, 8.0, rec);
    for (i = 0; i < N; ++i)
        CHECK(rec[i].com_x_desired <= p.toe_x - p.lean_margin + 2e-3 && rec[i].com_x_desired >= p.heel_x + p.lean_margin - 2e-3,
              "the CoM reference stays lean_margin inside the sole at tick %d: %g", i, rec[i].com_x_desired);
    for (n = 1; n < N; ++n)
        CHECK(fabs(rec[n].theta_ankle_ref - rec[n - 1].theta_ankle_ref) <= h * 2.0 + 1e-12 &&
                  fabs(rec[n].theta_hip_ref - rec[n - 1].theta_hip_ref) <= h * 4.0 + 1e-12,
              "reference angles continuous at tick %d", n);
    CHECK(rec[3900].com_x > 0.02, "leans toward the toe under 9 N on the chest: %g", rec[3900].com_x);

    /* J */
    {
        char msg[200];
        CHECK(p.lean_enabled == 1 && p.lean_law == AHC_LEAN_PENDULUM, "omnidirectional runs the pendulum lean");
        q = p;
        q.lean_zmp_margin = 0.04;
        CHECK(ahc_params_validate(&q, msg, sizeof msg) == AHC_ERR_INCONSISTENT && strstr(msg, "lean_zmp_margin"),
              "lean_zmp_margin beyond the heel refused: %s", msg);
        q = p;
        q.lean_capture_gain = 100.0;
        q.sample_period = 0.004;
        CHECK(ahc_params_validate(&q, msg, sizeof msg) == AHC_ERR_INCONSISTENT && strstr(msg, "lean_capture_gain"),
              "a capture gain too fast for the sample period refused: %s", msg);
        q.lean_enabled = 0;
        CHECK(ahc_params_validate(&q, msg, sizeof msg) == AHC_OK, "... but only when the pendulum lean runs: %s", msg);
    }
    TEST_MAIN_END();
}
