/*
 * test_ankle_strategy — establishes the ankle strategy (paper eq. 11):
 *  1. Open loop (robot held erect, constant measured ZMP p0, no ZMP filter, feet ignored):
 *     the reference obeys J th'' + Ca th' + Ka th = d0 from rest, so it must follow the
 *     analytic second-order step response (J = whole-body inertia about the ankle) and settle
 *     at th1 = d0/Ka. Run twice: with the paper-literal estimator (reaction_compensation = 0,
 *     d0 = m g (p0 - r_x), fz = 70 N is ignored) and with the default moment balance
 *     (reaction_compensation = 1; robot at rest, so dH_O = 0 and d0 = p0 fz - g m r_x = m g p0
 *     with the physically consistent fz = m g of a robot without feet). Tolerance for the
 *     transient: semi-implicit Euler is first order; its error on this response is bounded by
 *     ~ h (|s1| + |s2|) th_ss (poles s1, s2), ~2 % here; a wrong inertia or gain gives >10 %.
 *  2. Closed loop with the defaults through the quasi-static robot with the reaction of its own
 *     motion in the ZMP (joints follow the reference, constant push, default ZMP filter, feet
 *     modelled): the reference converges to the static lean th1 = F h / Ka, the estimate d to
 *     the push moment F h, and the hip stays erect.
 *  3. Feet (prototype finding 5, docs/controller.md §4.2), static quasi-static robot: the feet handling of modes 1 and 2
 *     removes the rest offset (no lean without a push) with either estimator; feet ignored,
 *     the paper-literal estimator (reaction_compensation = 0) leans by ~ m_f g (x_f - r_x)/Ka
 *     (fixed point with r_x ~ r_z th), the moment balance by exactly m_f g x_f / Ka.
 *  4. Bumpless start: the first reference equals the measured posture (within one tick of
 *     motion), and the hip is then brought back to erect by the eq. 25 regulator (rate -Kp th2).
 */
#include "ahc_test.h"

static double step_response(double t, double J, double Ca, double Ka, double xss)
{
    const double wn = sqrt(Ka / J), zeta = Ca / (2.0 * sqrt(Ka * J));
    if (zeta > 1.0) {
        const double r = wn * sqrt(zeta * zeta - 1.0);
        const double s1 = -zeta * wn + r, s2 = -zeta * wn - r;
        return xss * (1.0 + (s2 * exp(s1 * t) - s1 * exp(s2 * t)) / (s1 - s2));
    } else if (zeta < 1.0) {
        const double wd = wn * sqrt(1.0 - zeta * zeta);
        return xss * (1.0 - exp(-zeta * wn * t) * (cos(wd * t) + zeta * wn / wd * sin(wd * t)));
    }
    return xss * (1.0 - exp(-wn * t) * (1.0 + wn * t));
}

int main(void)
{
    ahc_params p;
    ahc_controller c;
    ahc_outputs o;
    ahc_sensors s;
    int n, N, rc;
    double m, J, p0, xss, maxerr = 0.0, h, poles;

    /* ---- 1. open loop, analytic; rc = reaction_compensation ---- */
    for (rc = 0; rc <= 1; ++rc) {
        maxerr = 0.0;
        ahc_params_default(&p);
        p.hip_strategy_enabled = 0;
        p.zmp_filter_tau = 0.0;
        p.feet_offset_mode = AHC_FEET_IGNORE;
        p.reaction_compensation = rc;
        CHECK(ahc_init(&c, &p) == AHC_OK, "init");
        m = p.m1 + p.m2;
        J = ahc_ankle_inertia(&p, 0.0);
        h = p.sample_period;
        p0 = 0.02;
        xss = m * p.g * p0 / p.Ka;
        poles = (p.Ca / J); /* |s1| + |s2| = Ca/J for real poles */
        s.theta_ankle = 0.0;
        s.theta_hip = 0.0;
        s.zmp_x = p0;
        s.fz = rc ? m * p.g : 70.0; /* rc = 0 ignores fz; rc = 1 needs the consistent fz = m g */
        N = 5000;
        for (n = 1; n <= N; ++n) {
            double ref;
            ahc_step(&c, &s, &o);
            ref = step_response(n * h, J, p.Ca, p.Ka, xss);
            if (fabs(o.theta_ankle_ref - ref) > maxerr) maxerr = fabs(o.theta_ankle_ref - ref);
            CHECK(o.phase == AHC_PHASE_ANKLE, "phase %d", o.phase);
            if (n == 100) CHECK(fabs(o.theta_ankle_ref - ref) <= 1.5 * h * poles * xss,
                                "t = 0.1 s: %.6g vs analytic %.6g", o.theta_ankle_ref, ref);
        }
        printf("open loop (reaction_compensation %d): static lean %.6f rad, analytic %.6f; max transient error %.3g rad (%.2f %% of static)\n",
               rc, o.theta_ankle_ref, xss, maxerr, 100.0 * maxerr / xss);
        CHECK_NEAR(o.theta_ankle_ref, xss, 1e-9, "static lean m g p / Ka");
        CHECK_NEAR(o.dtheta_ankle_ref, 0.0, 1e-9, "rate at rest");
        CHECK(maxerr <= 1.5 * h * poles * xss, "transient error %.3g > bound %.3g", maxerr, 1.5 * h * poles * xss);
        CHECK_NEAR(o.disturbance_moment, m * p.g * p0, 1e-12, "disturbance output m g (p - r_x)");
        CHECK_NEAR(o.theta_hip_ref, 0.0, 1e-15, "hip stays erect");

        /* a different stiffness must give a visibly different response (the test can fail) */
        CHECK(fabs(step_response(0.1, J, p.Ca, 1.2 * p.Ka, xss) - step_response(0.1, J, p.Ca, p.Ka, xss)) >
                  3.0 * maxerr, "analytic comparison is discriminating");
    }

    /* ---- 2. closed loop through the quasi-static robot ----
     * With the feet modelled the estimate is the push moment F h and the robot leans F h / Ka;
     * with the paper's estimate (feet ignored, the default) it is m g (p - r_x), which sees the
     * share m/M of the push moment plus the feet's small offset. */
    {
        int feet;
        for (feet = 0; feet <= 1; ++feet) {
            qs_robot r;
            const double F = 4.0;
            ahc_params_default(&p);
            p.hip_strategy_enabled = 0;
            p.feet_offset_mode = feet ? AHC_FEET_MODEL : AHC_FEET_IGNORE;
            p.zmp_filter_tau = QS_ZMP_FILTER_TAU; /* ideal-servo model (ahc_test.h) */
            CHECK(ahc_init(&c, &p) == AHC_OK, "init");
            qs_init(&r, &p);
            r.reaction = 1; /* physically consistent sensor model */
            for (n = 0; n < 8000; ++n) {
                qs_sense(&r, F, &s);
                ahc_step(&c, &s, &o);
                qs_apply(&r, &o);
            }
            qs_sense(&r, F, &s);
            {
                const double m = p.m1 + p.m2, M = m + p.feet_mass;
                const double pm_rx = s.zmp_x - o.com_x; /* measured p - r_x */
                printf("closed loop, feet %s: th1 = %.6f, F h / Ka = %.6f, d = %.6f N m\n", feet ? "modelled" : "ignored",
                       o.theta_ankle_ref, F * r.push_height / p.Ka, o.disturbance_moment);
                if (feet) {
                    CHECK_NEAR(o.theta_ankle_ref, F * r.push_height / p.Ka, 1e-6, "static lean F h / Ka");
                    CHECK_NEAR(o.disturbance_moment, F * r.push_height, 1e-5, "d equals the push moment");
                    /* Ka th1 = m g (p - r_x) + m_f g (p - x_f) */
                    CHECK_NEAR(p.Ka * o.theta_ankle_ref, m * p.g * pm_rx + p.feet_mass * p.g * (s.zmp_x - p.feet_com_x),
                               1e-4, "Ka th1 = m g (p - r_x) + feet term");
                } else {
                    CHECK_NEAR(p.Ka * o.theta_ankle_ref, m * p.g * pm_rx, 1e-4, "Ka th1 = m g (p - r_x) (paper)");
                    CHECK_NEAR(o.theta_ankle_ref, m / M * F * r.push_height / p.Ka, 1e-3, "lean ~ (m/M) F h / Ka");
                }
                CHECK_NEAR(o.theta_hip_ref, 0.0, 1e-9, "hip erect");
            }
        }
    }

    /* ---- 3. feet offset (lesson 5) ---- */
    {
        qs_robot r;
        int mode;
        for (rc = 0; rc <= 1; ++rc)
        for (mode = 0; mode <= 2; ++mode) {
            ahc_params_default(&p);
            p.feet_offset_mode = mode;
            p.reaction_compensation = rc;
            CHECK(ahc_init(&c, &p) == AHC_OK, "init");
            qs_init(&r, &p);
            r.reaction = rc; /* the sensor world each estimator is meant for (ahc_test.h) */
            for (n = 0; n < 5000; ++n) {
                qs_sense(&r, 0.0, &s);
                ahc_step(&c, &s, &o);
                qs_apply(&r, &o);
            }
            printf("reaction_compensation %d, feet mode %d: rest lean %.6f rad\n", rc, mode, o.theta_ankle_ref);
            if (mode == AHC_FEET_IGNORE && rc) {
                /* moment balance without the feet: d = p fz - g m r_x = m_f g x_f exactly */
                CHECK_NEAR(o.theta_ankle_ref, p.feet_mass * p.g * p.feet_com_x / p.Ka, 1e-9,
                           "moment-balance rest lean m_f g x_f / Ka");
            } else if (mode == AHC_FEET_IGNORE) {
                /* equilibrium: Ka th = m g (p - r_x) with p = (m r_x + m_f x_f)/M, r_x ~ r_z th */
                const double m_ = p.m1 + p.m2, M = m_ + p.feet_mass;
                const double rz = HOAP2_ERECT_COM_Z;
                const double th = m_ * p.g * p.feet_mass * p.feet_com_x / M /
                                  (p.Ka + m_ * p.g * p.feet_mass * rz / M);
                CHECK_NEAR(o.theta_ankle_ref, th, 2e-5, "paper-literal rest lean (lesson 5)");
                CHECK(o.theta_ankle_ref > 5e-4, "rest lean present without feet handling");
            } else {
                CHECK(fabs(o.theta_ankle_ref) < 1e-6, "no rest lean with feet mode %d: %.3g", mode,
                      o.theta_ankle_ref);
            }
        }
    }
    /* ---- 4. bumpless start from a non-erect posture ---- */
    {
        const double th1_0 = 0.1, th2_0 = 0.2;
        ahc_params_default(&p);
        CHECK(ahc_init(&c, &p) == AHC_OK, "init");
        s.theta_ankle = th1_0;
        s.theta_hip = th2_0;
        s.zmp_x = 0.01;
        s.fz = 70.0;
        ahc_step(&c, &s, &o);
        CHECK(fabs(o.theta_ankle_ref - th1_0) <= p.sample_period * fabs(o.dtheta_ankle_ref) + 1e-15,
              "ankle starts at the measured angle: %g", o.theta_ankle_ref);
        CHECK_NEAR(o.theta_hip_ref, th2_0 * (1.0 - p.Kp_theta * p.sample_period), 1e-15,
                   "hip starts at the measured angle, first regulator step");
        CHECK_NEAR(o.dtheta_hip_ref, -p.Kp_theta * th2_0, 1e-15, "eq. 25 rate");
    }
    TEST_MAIN_END();
}
