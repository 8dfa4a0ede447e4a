/*
 * test_phases — establishes the phase machine of docs/controller.md:
 *  A. 0 -> 1 fires on exactly the first tick where the filtered ZMP reaches zmp_limit_front
 *     (push from behind) or zmp_limit_back (push from the front); the filter is recomputed here;
 *  B. phase 1 lasts exactly T_ah (round(T_ah / h) ticks), also when T_ah is changed meanwhile;
 *     k_w rises monotonically 0 -> 1;
 *  C. 2 -> 3 paper condition: fires on exactly the tick where r_z is in the band AND p is on the
 *     side opposite to the push; not when only one of them holds; mirrored for front pushes.
 *     C1 with the defaults (kinematics_source = reference: r_z of the reference angles at the
 *     start of the tick, i.e. of the previous tick's outputs); C2 with kinematics_source =
 *     measured, where the test steps the measured hip angle (a pure trigger-logic check; those
 *     one-tick steps are unphysical accelerations, so the paper-literal estimator is used there);
 *  D. 2 -> 3 fallback: fires after exactly fallback_dwell of |d| <= tol and |th2_ref| <= tol;
 *  E. 3 -> 0 fires on the first tick after |th2_ref| <= tol and |dth2_ref| <= tol;
 *     3 -> 2 when the ZMP reaches a limit again;
 *  F. the sequence 0 -> 1 -> 2 -> 3 -> 0 for a push applied and removed, from behind and from
 *     the front (with the reaction in the ZMP both return through the paper condition, ~0.1 s
 *     after the release; without it p never goes behind the ankle and a push from behind
 *     returns through the fallback, prototype finding 3 (docs/controller.md §4.2)), driven through the
 *     quasi-static robot of ahc_test.h with the reaction of its own motion in the ZMP (physically
 *     consistent for the default estimator); the front response mirrors the back one;
 *  G. every switch is bumpless: reference angles move by at most h * rate per tick, and the
 *     reference rates change at a switch by no more than the largest change of an ordinary tick;
 *  H. ankle-only mode never leaves phase 0 and the ZMP limit changes nothing (bit-identical).
 */
#include "ahc_test.h"

#define NMAX 20000
static ahc_outputs rec[NMAX];
static ahc_outputs rec2[NMAX];

/* Robot held erect (at rest): the physically consistent normal force is the weight (m + m_f) g;
 * the moment-balance estimate is then d = zmp (m + m_f) g - m_f g x_f. */
static double weight(void)
{
    ahc_params q;
    ahc_params_default(&q);
    return (q.m1 + q.m2 + q.feet_mass) * q.g;
}

static ahc_sensors erect_sensors(double zmp)
{
    ahc_sensors s;
    s.theta_ankle = 0.0;
    s.theta_hip = 0.0;
    s.zmp_x = zmp;
    s.fz = weight();
    return s;
}

/* Drive a controller with held-erect sensors at a constant ZMP until it is in `phase`. */
static int drive_to_phase(ahc_controller *c, double zmp, int phase, int max_ticks)
{
    ahc_sensors s = erect_sensors(zmp);
    ahc_outputs o;
    int n;
    for (n = 0; n < max_ticks; ++n) {
        ahc_step(c, &s, &o);
        if (o.phase == phase) return 1;
    }
    return 0;
}

/* Closed-loop run through the quasi-static robot (push held until 3 s); returns the number of ticks. */
static int run_qs(const ahc_params *p, double F, double t_end, ahc_outputs *out)
{
    return qs_run(p, F, 3.0, t_end, out, NMAX);
}

/* Bumpless check. Angles: |th_n - th_{n-1}| <= h |dth_n| (no jump beyond one tick's rate).
 * Rates at a switch tick: the change must not exceed what one tick of the acceleration laws
 * allows, h * (|d| + C |dth| + K |th|) / J (eqs. 11/16 with the values of the previous tick),
 * or the largest change of an ordinary (non-switch) tick, whichever is larger. A non-bumpless
 * switch (e.g. eq. 25 entered without the offset: a step of Kp_theta th2 + dth2 ~ 1 rad/s, or
 * eq. 23 entered with zero CoM velocity: ~0.1 rad/s) exceeds both by an order of magnitude. */
static void check_bumpless(const ahc_params *p, const ahc_outputs *o, int N, const char *what)
{
    const double h = p->sample_period;
    const double km = p->m2 / (p->m1 + p->m2), J2 = p->I2 + p->m2 * p->lg2 * p->lg2;
    int n, switches = 0;
    double ordinary1 = 0.0, ordinary2 = 0.0;
    for (n = 1; n < N; ++n) {
        if (o[n].phase == o[n - 1].phase) {
            const double d1 = fabs(o[n].dtheta_ankle_ref - o[n - 1].dtheta_ankle_ref);
            const double d2 = fabs(o[n].dtheta_hip_ref - o[n - 1].dtheta_hip_ref);
            if (d1 > ordinary1) ordinary1 = d1;
            if (d2 > ordinary2) ordinary2 = d2;
        }
        CHECK(fabs(o[n].theta_ankle_ref - o[n - 1].theta_ankle_ref) <= h * fabs(o[n].dtheta_ankle_ref) + 1e-12,
              "%s: ankle angle jump at tick %d", what, n);
        CHECK(fabs(o[n].theta_hip_ref - o[n - 1].theta_hip_ref) <= h * fabs(o[n].dtheta_hip_ref) + 1e-12,
              "%s: hip angle jump at tick %d", what, n);
    }
    for (n = 1; n < N; ++n) {
        if (o[n].phase != o[n - 1].phase) {
            const ahc_outputs *a = &o[n - 1];
            const double d1 = fabs(o[n].dtheta_ankle_ref - a->dtheta_ankle_ref);
            const double d2 = fabs(o[n].dtheta_hip_ref - a->dtheta_hip_ref);
            const double dd = fabs(o[n].disturbance_moment);
            const double A1 = (dd + p->Ca * fabs(a->dtheta_ankle_ref) + p->Ka * fabs(a->theta_ankle_ref)) /
                              ahc_ankle_inertia(p, a->theta_hip_ref);
            const double A2 = (km * dd + p->Ch * fabs(a->dtheta_hip_ref) + p->Kh * fabs(a->theta_hip_ref)) / J2;
            const double b1 = fmax(ordinary1, h * A1), b2 = fmax(ordinary2, h * A2);
            ++switches;
            printf("%s: switch %d->%d at t=%.3f s: |d dth1| = %.3g (bound %.3g), |d dth2| = %.3g (bound %.3g)\n",
                   what, a->phase, o[n].phase, n * h, d1, b1, d2, b2);
            CHECK(d1 <= b1 + 1e-12, "%s: ankle rate bump %.3g at switch tick %d", what, d1, n);
            CHECK(d2 <= b2 + 1e-12, "%s: hip rate bump %.3g at switch tick %d", what, d2, n);
        }
    }
    CHECK(switches >= 4, "%s: %d switches", what, switches);
}

static int compress_phases(const ahc_outputs *o, int N, int *seq, int maxlen)
{
    int n, len = 0;
    for (n = 0; n < N; ++n)
        if (len == 0 || seq[len - 1] != o[n].phase) {
            if (len == maxlen) return len + 1;
            seq[len++] = o[n].phase;
        }
    return len;
}

int main(void)
{
    ahc_params p;
    ahc_controller c;
    ahc_outputs o;
    ahc_sensors s;
    int n, side;
    double h;

    ahc_params_default(&p);
    p.zmp_filter_tau = QS_ZMP_FILTER_TAU; /* the quasi-static robot has an ideal servo (ahc_test.h) */
    h = p.sample_period;

    /* ---- A. 0 -> 1 trigger, both sides, with the ZMP filter ---- */
    for (side = 0; side < 2; ++side) {
        const double alpha = 1.0 - exp(-h / p.zmp_filter_tau);
        const double lim = side == 0 ? p.zmp_limit_front : p.zmp_limit_back;
        const double slope = side == 0 ? 0.0173 : -0.0131; /* m/s, generic */
        double y = 0.0;
        int expected = -1, got = -1;
        CHECK(ahc_init(&c, &p) == AHC_OK, "init");
        for (n = 0; n < 5000; ++n) {
            const double z = slope * n * h;
            s = erect_sensors(z);
            y = n == 0 ? z : y + alpha * (z - y);
            if (expected < 0 && (side == 0 ? y >= lim : y <= lim)) expected = n;
            ahc_step(&c, &s, &o);
            if (got < 0 && o.phase == AHC_PHASE_ANKLE_TO_HIP) got = n;
            if (got < 0) CHECK(o.phase == AHC_PHASE_ANKLE, "still phase 0 before the trigger");
        }
        CHECK(expected > 0 && got == expected, "side %d: trigger at tick %d, expected %d", side, got, expected);
    }

    /* ---- B. phase 1 lasts T_ah; k_w monotonic ---- */
    {
        const double Ts[2] = { 1.0, 0.25 };
        int k;
        for (k = 0; k < 2; ++k) {
            int count = 0;
            double kw_prev = -1.0;
            ahc_params q = p;
            q.T_ah = Ts[k];
            CHECK(ahc_init(&c, &q) == AHC_OK, "init");
            CHECK(drive_to_phase(&c, 0.04, AHC_PHASE_ANKLE_TO_HIP, 100), "reach phase 1");
            s = erect_sensors(0.04);
            count = 1; /* the trigger tick itself is in phase 1 */
            for (n = 0; n < 5000; ++n) {
                if (n == 10) {
                    /* changing T_ah during the transition does not change its duration */
                    ahc_params u = q;
                    u.T_ah = 0.5 * q.T_ah;
                    CHECK(ahc_update_params(&c, &u) == AHC_OK, "update");
                }
                ahc_step(&c, &s, &o);
                if (o.phase != AHC_PHASE_ANKLE_TO_HIP) break;
                CHECK(o.k_w >= kw_prev, "k_w monotonic");
                kw_prev = o.k_w;
                ++count;
            }
            CHECK(o.phase == AHC_PHASE_HIP, "phase 2 after phase 1 (got %d)", o.phase);
            CHECK(count == (int)(q.T_ah / h + 0.5), "phase 1 lasted %d ticks, T_ah/h = %g", count, q.T_ah / h);
            CHECK(o.k_w == 1.0 && o.com_x_desired == 0.0, "k_w = 1, r_x_d = 0 in phase 2");
            CHECK(kw_prev > 0.999 && kw_prev < 1.0, "k_w just below 1 at the end of phase 1: %g", kw_prev);
        }
    }

    /* ---- C1. 2 -> 3 paper condition, defaults (reference kinematics), no ZMP filter ---- */
    for (side = 0; side < 2; ++side) {
        const double sg = side == 0 ? 1.0 : -1.0;
        ahc_params q = p;
        ahc_outputs prev;
        double rz0, drz = 0.0;
        int in_band = 0;
        q.zmp_filter_tau = 0.0;
        CHECK(q.kinematics_source == AHC_KIN_REFERENCE, "default kinematics source");
        ahc_com(&q, 0.0, 0.0, NULL, &rz0);
        CHECK(ahc_init(&c, &q) == AHC_OK, "init");
        CHECK(drive_to_phase(&c, sg * 0.045, AHC_PHASE_HIP, 3000), "reach phase 2");
        s = erect_sensors(sg * 0.045);
        for (n = 0; n < 200; ++n) ahc_step(&c, &s, &o);
        prev = o;
        /* reference hip bent (~0.5 rad): reference r_z out of band; p opposite: no switch */
        ahc_com(&q, prev.theta_ankle_ref, prev.theta_hip_ref, NULL, &drz);
        drz -= rz0;
        CHECK(drz < q.rz_band_low, "side %d: band check setup, reference r_z - erect = %.4f", side, drz);
        s = erect_sensors(-sg * 0.005);
        ahc_step(&c, &s, &o);
        CHECK(o.phase == AHC_PHASE_HIP, "side %d: no switch with reference r_z out of band", side);
        /* p on the push side (d ~ 0.84 N m: fallback not involved) while eq. 16 relaxes the
         * reference hip to ~0.14 rad, into the band: no switch on any tick */
        s = erect_sensors(sg * 0.012);
        prev = o;
        for (n = 0; n < 5000 && !in_band; ++n) {
            ahc_com(&q, prev.theta_ankle_ref, prev.theta_hip_ref, NULL, &drz);
            drz -= rz0;
            in_band = drz >= q.rz_band_low && drz <= q.rz_band_high;
            if (in_band) break;
            ahc_step(&c, &s, &o);
            CHECK(o.phase == AHC_PHASE_HIP, "side %d: no switch with p on the push side", side);
            CHECK(fabs(o.disturbance_moment) > q.fallback_disturbance_tol, "fallback not involved");
            prev = o;
        }
        CHECK(in_band && n > 10, "side %d: reference r_z entered the band after %d ticks (hip %.3f)", side, n,
              prev.theta_hip_ref);
        /* one more tick on the push side with r_z in band: no switch */
        ahc_step(&c, &s, &o);
        CHECK(o.phase == AHC_PHASE_HIP, "side %d: no switch with p on the push side, r_z in band", side);
        ahc_com(&q, o.theta_ankle_ref, o.theta_hip_ref, NULL, &drz);
        drz -= rz0;
        CHECK(drz >= q.rz_band_low && drz <= q.rz_band_high, "side %d: still in band (%.4f)", side, drz);
        /* both: switch on this very tick */
        s = erect_sensors(-sg * 0.001);
        ahc_step(&c, &s, &o);
        CHECK(o.phase == AHC_PHASE_HIP_TO_ANKLE, "side %d: paper condition switches to phase 3 (got %d)", side,
              o.phase);
    }

    /* ---- C2. the same trigger on measured kinematics (kinematics_source = measured; the
     *      measured hip is stepped, so the paper-literal estimator: reaction_compensation = 0) ---- */
    for (side = 0; side < 2; ++side) {
        const double sg = side == 0 ? 1.0 : -1.0;
        ahc_params q = p;
        q.zmp_filter_tau = 0.0;
        q.kinematics_source = AHC_KIN_MEASURED;
        q.reaction_compensation = 0;
        CHECK(ahc_init(&c, &q) == AHC_OK, "init");
        CHECK(drive_to_phase(&c, sg * 0.045, AHC_PHASE_HIP, 3000), "reach phase 2");
        s = erect_sensors(sg * 0.045);
        for (n = 0; n < 200; ++n) ahc_step(&c, &s, &o);
        /* r_z out of band (hip 0.3 rad: 3.2 mm below erect), p opposite: no switch */
        s.theta_ankle = 0.0;
        s.theta_hip = sg * 0.3;
        s.zmp_x = -sg * 0.005;
        ahc_step(&c, &s, &o);
        CHECK(o.phase == AHC_PHASE_HIP, "side %d: no switch with r_z out of band (r_z - erect = %.4f)", side,
              o.com_z - HOAP2_ERECT_COM_Z);
        CHECK(o.com_z - HOAP2_ERECT_COM_Z < q.rz_band_low, "band check setup");
        /* r_z in band (hip 0.1 rad: 0.36 mm below), p on the push side: no switch */
        s.theta_hip = sg * 0.1;
        s.zmp_x = sg * 0.012;
        ahc_step(&c, &s, &o);
        CHECK(o.phase == AHC_PHASE_HIP, "side %d: no switch with p on the push side", side);
        CHECK(fabs(o.disturbance_moment) > q.fallback_disturbance_tol, "fallback not involved");
        /* both: switch on this very tick */
        s.zmp_x = -sg * 0.001;
        ahc_step(&c, &s, &o);
        CHECK(o.phase == AHC_PHASE_HIP_TO_ANKLE, "side %d: paper condition switches to phase 3 (got %d)", side,
              o.phase);
    }

    /* ---- D. fallback after exactly fallback_dwell ---- */
    {
        ahc_params q = p;
        int quiet = 0, switched = -1, expected = -1;
        double th2_prev;
        const double m = q.m1 + q.m2, M = m + q.feet_mass;
        const double p_rest = q.feet_mass * q.feet_com_x / M; /* d = 0 at the erect pose */
        q.zmp_filter_tau = 0.0;
        q.feet_offset_mode = AHC_FEET_MODEL;   /* so that the estimate is exactly 0 at rest */
        CHECK(ahc_init(&c, &q) == AHC_OK, "init");
        CHECK(drive_to_phase(&c, 0.045, AHC_PHASE_HIP, 3000), "reach phase 2");
        for (n = 0; n < 300; ++n) { s = erect_sensors(0.045); ahc_step(&c, &s, &o); }
        th2_prev = o.theta_hip_ref;
        CHECK(th2_prev > q.fallback_hip_tol, "hip bent before release: %g", th2_prev);
        s = erect_sensors(p_rest);
        for (n = 0; n < 5000 && switched < 0; ++n) {
            ahc_step(&c, &s, &o);
            /* the decision at tick n uses d of tick n and th2_ref at the start of tick n */
            quiet = (fabs(o.disturbance_moment) <= q.fallback_disturbance_tol && fabs(th2_prev) <= q.fallback_hip_tol)
                        ? quiet + 1 : 0;
            if (expected < 0 && quiet == (int)(q.fallback_dwell / h + 0.5)) expected = n;
            if (o.phase == AHC_PHASE_HIP_TO_ANKLE) switched = n;
            th2_prev = o.theta_hip_ref;
        }
        CHECK(fabs(o.disturbance_moment) < 1e-9, "d = 0 at rest with feet modelled: %g", o.disturbance_moment);
        CHECK(expected > 0 && switched == expected, "fallback switch at %d, expected %d", switched, expected);

        /* ---- E. 3 -> 0 exactly at the tolerance ---- */
        {
            ahc_outputs prev = o;
            int back = -1;
            for (n = 0; n < 5000 && back < 0; ++n) {
                const int cond = fabs(prev.theta_hip_ref) <= q.return_hip_angle_tol &&
                                 fabs(prev.dtheta_hip_ref) <= q.return_hip_rate_tol;
                ahc_step(&c, &s, &o);
                if (o.phase == AHC_PHASE_ANKLE) {
                    back = n;
                    CHECK(cond, "3 -> 0 switched with |th2| = %g, |dth2| = %g", prev.theta_hip_ref,
                          prev.dtheta_hip_ref);
                } else {
                    CHECK(!cond, "3 -> 0 missed at tick %d", n);
                    CHECK(o.phase == AHC_PHASE_HIP_TO_ANKLE, "stays in 3");
                }
                prev = o;
            }
            CHECK(back >= 0, "returned to phase 0 (phase %d, th2 %g, dth2 %g)", o.phase, o.theta_hip_ref,
                  o.dtheta_hip_ref);
        }
        /* 3 -> 2 on a new push */
        CHECK(ahc_init(&c, &q) == AHC_OK, "init");
        CHECK(drive_to_phase(&c, 0.045, AHC_PHASE_HIP, 3000), "reach phase 2");
        for (n = 0; n < 300; ++n) { s = erect_sensors(0.045); ahc_step(&c, &s, &o); }
        s = erect_sensors(p_rest);
        CHECK(drive_to_phase(&c, p_rest, AHC_PHASE_HIP_TO_ANKLE, 5000), "reach phase 3");
        s = erect_sensors(q.zmp_limit_back - 0.001);
        ahc_step(&c, &s, &o);
        CHECK(o.phase == AHC_PHASE_HIP, "3 -> 2 on a new push from the front (got %d)", o.phase);
    }

    /* ---- F + G. full sequence through the quasi-static robot, both push directions ---- */
    {
        const double F = 8.0, t_end = 8.0;
        int N1, N2, seq[8], len;
        double max2_back = 0.0, min2_front = 0.0;
        N1 = run_qs(&p, F, t_end, rec);
        N2 = run_qs(&p, -F, t_end, rec2);
        CHECK(N1 == (int)(t_end / h + 0.5) && N2 == N1, "runs complete");
        len = compress_phases(rec, N1, seq, 8);
        CHECK(len == 5 && seq[0] == 0 && seq[1] == 1 && seq[2] == 2 && seq[3] == 3 && seq[4] == 0,
              "push from behind: phase sequence of length %d (%d %d %d %d %d)", len, seq[0], seq[1], seq[2],
              seq[3], seq[4]);
        len = compress_phases(rec2, N2, seq, 8);
        CHECK(len == 5 && seq[0] == 0 && seq[1] == 1 && seq[2] == 2 && seq[3] == 3 && seq[4] == 0,
              "push from the front: phase sequence of length %d (%d %d %d %d %d)", len, seq[0], seq[1], seq[2],
              seq[3], seq[4]);
        for (n = 0; n < N1; ++n) {
            if (rec[n].theta_hip_ref > max2_back) max2_back = rec[n].theta_hip_ref;
            if (rec2[n].theta_hip_ref < min2_front) min2_front = rec2[n].theta_hip_ref;
            CHECK(rec[n].fault == 0 && rec2[n].fault == 0, "no faults");
        }
        printf("push from behind: max hip %.3f rad; from the front: min hip %.3f rad\n", max2_back, min2_front);
        /* hip strategy bends the hip toward the push direction's side: m2 g (p - r_x)/Kh ~ km F h / Kh */
        CHECK(max2_back > 0.3 && min2_front < -0.3, "hip strategy used in both directions");
        for (n = 0; n < N1; ++n)
            if (rec[n].phase == AHC_PHASE_HIP && rec[n - 1].phase == AHC_PHASE_HIP) {
                /* during the hip strategy the CoM is held near the ankle (r_x_d = 0) */
                CHECK(fabs(rec[n].com_x) < 2e-3, "CoM held near r_x_d = 0 in phase 2: %g at %d", rec[n].com_x, n);
                break;
            }
        CHECK(fabs(rec[N1 - 1].theta_ankle_ref) < 1e-3 && fabs(rec[N1 - 1].theta_hip_ref) < 1e-3,
              "back to erect after the push (behind): %g %g", rec[N1 - 1].theta_ankle_ref,
              rec[N1 - 1].theta_hip_ref);
        CHECK(fabs(rec2[N2 - 1].theta_ankle_ref) < 1e-3 && fabs(rec2[N2 - 1].theta_hip_ref) < 1e-3,
              "back to erect after the push (front)");
        check_bumpless(&p, rec, N1, "behind");
        check_bumpless(&p, rec2, N2, "front");
    }

    /* ---- H. ankle strategy only ---- */
    {
        ahc_params q = p;
        const double F = 8.0, t_end = 6.0;
        int N1, N2;
        q.hip_strategy_enabled = 0;
        N1 = run_qs(&q, F, t_end, rec);
        q.zmp_limit_front = 0.045;
        q.zmp_limit_back = -0.030;
        N2 = run_qs(&q, F, t_end, rec2);
        CHECK(N1 == N2 && N1 > 0, "runs");
        for (n = 0; n < N1; ++n) CHECK(rec[n].phase == AHC_PHASE_ANKLE && rec[n].k_w == 0.0, "phase 0 only");
        CHECK(memcmp(rec, rec2, sizeof(ahc_outputs) * (size_t)N1) == 0, "ZMP limit changes nothing in ankle-only mode");
        {
            double zmax = 0.0;
            for (n = 0; n < N1; ++n)
                if (rec[n].theta_ankle_ref > zmax) zmax = rec[n].theta_ankle_ref;
            /* the paper's estimate sees the share m/M of the push moment F h (feet ignored) */
            const double share = q.feet_offset_mode == AHC_FEET_IGNORE
                                     ? (q.m1 + q.m2) / (q.m1 + q.m2 + q.feet_mass) : 1.0;
            CHECK_NEAR(zmax, share * F * 0.335 / q.Ka, 2e-3, "ankle-only: lean (m/M) F h / Ka during the push");
        }
    }
    TEST_MAIN_END();
}
