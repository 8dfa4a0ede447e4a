/*
 * test_state_validate — establishes that ahc_state_validate accepts every state the controller
 * reaches and refuses forged ones:
 *  - every state of a run through all four phases, with sensor faults, and of a fresh instance
 *    is accepted;
 *  - each field that a forged snapshot could break (NaN or a huge value in a reference state, the
 *    disturbance filter, the ZMP filter, a spline; flags outside 0/1; phase, push sign, fault
 *    bits, derived constants, parameters) is refused with a message naming the field
 *    (audit: a blob with NaN in the disturbance filter was accepted and the next step output
 *    disturbance_moment = NaN).
 *  - the invariants between fields (issue 33): a k_w spline coefficient forged from 80 to -80
 *    (k_w = -0.99 in phase 1 before), an r_x_d spline that does not end at rest, k_w or hip_bump
 *    that do not belong to the phase, timers longer than the ticks run, last outputs that are not
 *    the references, a tick count beyond AHC_TICK_MAX are refused;
 *  - ahc_state_validate_for refuses a state whose parameters differ from the instance's (Ka 41
 *    in the state, 40 in the instance) or whose tick count is not the instance's clock, and
 *    accepts every state of the run against its own parameters and tick.
 */
#include "ahc_test.h"

static int accepted(const ahc_controller *c, char *msg, size_t n) { return ahc_state_validate(c, msg, n) == AHC_OK; }

int main(void)
{
    ahc_params p;
    ahc_controller c, bad;
    ahc_outputs o;
    char msg[256];
    int n, phases_seen = 0;

    ahc_params_default(&p);
    p.reaction_compensation = 1; /* exercises the disturbance filter state */
    CHECK(ahc_init(&c, &p) == AHC_OK, "init");
    CHECK(accepted(&c, msg, sizeof msg), "fresh instance: %s", msg);
    for (n = 0; n < 8000; ++n) {
        unsigned long long tick_before = c.tick;
        /* a push that runs 0 -> 1 -> 2 -> 3 -> 0, with a NaN sample and a lifted sample */
        ahc_sensors s = { 0.0, 0.0, n < 300 ? 0.045 : -0.005, 70.0 };
        if (n == 150) s.zmp_x = NAN;
        if (n == 151) s.fz = 1.0;
        ahc_step(&c, &s, &o);
        phases_seen |= 1 << o.phase;
        if (!accepted(&c, msg, sizeof msg) || ahc_state_validate_for(&c, &p, tick_before + 1, msg, sizeof msg)) {
            CHECK(0, "tick %d (phase %d) refused: %s", n, o.phase, msg);
            break;
        }
    }
    CHECK(phases_seen == 0xF, "all four phases visited (mask 0x%x)", phases_seen);

#define REFUSED(field_expr, value, name)                                                      \
    do {                                                                                      \
        bad = c;                                                                              \
        field_expr = value;                                                                   \
        CHECK(!accepted(&bad, msg, sizeof msg) && strstr(msg, name) != NULL,                  \
              "forged %s = %g: %s", name, (double)(value), msg);                              \
    } while (0)

    REFUSED(bad.d_f, NAN, "d_f");
    REFUSED(bad.d_f1, INFINITY, "d_f1");
    REFUSED(bad.dth1, 1e300, "dth1");
    REFUSED(bad.th1, 1.0e3, "th1");
    REFUSED(bad.th2, NAN, "th2");
    REFUSED(bad.zmp_f, 1e308, "zmp_f");
    REFUSED(bad.k_w, 2.0, "k_w");
    REFUSED(bad.hip_bump, -INFINITY, "hip_bump");
    REFUSED(bad.calib_sum, NAN, "calib_sum");
    REFUSED(bad.last_th1, 50.0, "last_th1");
    REFUSED(bad.hist_th2[1], NAN, "hist_th2[1]");
    REFUSED(bad.phase_time, -1.0, "phase_time");
    REFUSED(bad.kw_spline.T, 0.0, "kw_spline.T");
    REFUSED(bad.rxd_spline.c[3], NAN, "spline coefficient");
    REFUSED(bad.last_out.disturbance_moment, NAN, "last_out.disturbance_moment");
    REFUSED(bad.started, 7, "started");
    REFUSED(bad.holding, -1, "holding");
    REFUSED(bad.hist_n, 3, "hist_n");
    REFUSED(bad.phase, 4, "phase");
    REFUSED(bad.push_sign, 0, "push_sign");
    REFUSED(bad.valid, 2, "valid");
    REFUSED(bad.fault, 1u << 20, "fault");
    REFUSED(bad.m, 1.0, "derived constants");
    REFUSED(bad.zmp_alpha, 0.5, "derived constants");
    REFUSED(bad.p.sample_period, 2.2e-310, "sample_period");
    REFUSED(bad.p.Ka, NAN, "Ka");

    /* invariants between fields: a state in each phase, forged the way a re-signed blob can be */
    {
        ahc_controller run, in_phase[4];
        int have[4] = {0, 0, 0, 0}, ph;
        CHECK(ahc_init(&run, &p) == AHC_OK, "init");
        for (n = 0; n < 8000; ++n) {
            ahc_sensors s = { 0.0, 0.0, n < 300 ? 0.045 : -0.005, 70.0 };
            ahc_step(&run, &s, &o);
            if (!have[o.phase] && (run.phase_time > 0.005 || o.phase == AHC_PHASE_HIP)) {
                in_phase[o.phase] = run;
                have[o.phase] = 1;
            }
        }
        CHECK(have[0] && have[1] && have[2] && have[3], "a state in every phase");
        c = in_phase[AHC_PHASE_ANKLE_TO_HIP];
        CHECK(c.kw_spline.c[3] == 80.0, "T_ah = 0.5 s: k_w's t^3 coefficient is 80 (%g)", c.kw_spline.c[3]);
        REFUSED(bad.kw_spline.c[3], -80.0, "kw_spline coefficient 3");
        REFUSED(bad.rxd_spline.c[4], bad.rxd_spline.c[4] + 1.0, "rxd_spline coefficient 4");
        REFUSED(bad.rxd_spline.c[2], 0.01, "rxd_spline coefficient 2");
        REFUSED(bad.rxd_spline.T, 0.7, "spline durations");
        REFUSED(bad.kw_spline.T, 1000.0, "kw_spline.T");
        REFUSED(bad.hip_bump, 0.1, "hip_bump");
        REFUSED(bad.last_out.theta_hip_ref, bad.th2 + 0.01, "last_out");
        REFUSED(bad.phase_time, 1e6, "phase_time");
        REFUSED(bad.tick, AHC_TICK_MAX + 1, "tick");
        REFUSED(bad.calib_n, bad.tick + 1, "calib_n");
        c = in_phase[AHC_PHASE_ANKLE];
        REFUSED(bad.k_w, 0.5, "k_w");
        REFUSED(bad.fallback_timer, 0.1, "fallback_timer");
        REFUSED(bad.holding, 1, "holding");
        c = in_phase[AHC_PHASE_HIP];
        REFUSED(bad.k_w, 0.99, "k_w");
        c = in_phase[AHC_PHASE_HIP_TO_ANKLE];
        REFUSED(bad.k_w, 0.0, "k_w");
        CHECK(ahc_init(&c, &p) == AHC_OK, "init");
        REFUSED(bad.started, 1, "tick = 0");
        REFUSED(bad.th1, 0.01, "tick = 0");

        /* against the instance: parameters and tick */
        for (ph = 0; ph < 4; ++ph) {
            ahc_params q = p;
            c = in_phase[ph];
            CHECK(ahc_state_validate_for(&c, &p, c.tick, msg, sizeof msg) == AHC_OK, "phase %d: %s", ph, msg);
            CHECK(ahc_state_validate_for(&c, &p, AHC_TICK_ANY, msg, sizeof msg) == AHC_OK, "phase %d: %s", ph, msg);
            q.Ka = 41.0;
            c.p.Ka = 40.0;
            CHECK(ahc_state_validate_for(&c, &q, c.tick, msg, sizeof msg) == AHC_ERR_INCONSISTENT &&
                      strstr(msg, "Ka = 40 in the state, 41 in the instance"), "Ka mismatch: %s", msg);
            c = in_phase[ph];
            q = p;
            q.lean_enabled = 1;
            CHECK(ahc_state_validate_for(&c, &q, c.tick, msg, sizeof msg) == AHC_ERR_INCONSISTENT &&
                      strstr(msg, "lean_enabled = 0 in the state, 1 in the instance"), "integer mismatch: %s", msg);
            CHECK(ahc_state_validate_for(&c, &p, c.tick + 1000000, msg, sizeof msg) == AHC_ERR_INCONSISTENT &&
                      strstr(msg, "by the instance's clock"), "tick mismatch: %s", msg);
        }
        bad = in_phase[0];
        bad.valid = 0;
        CHECK(ahc_state_validate_for(&bad, &p, AHC_TICK_ANY, msg, sizeof msg) == AHC_ERR_INCONSISTENT,
              "not initialized: %s", msg);
        CHECK(ahc_state_validate_for(&in_phase[0], NULL, 0, msg, sizeof msg) == AHC_ERR_NULL, "NULL params");
    }

    /* the shortest legal transition: its splines' higher coefficients are about 1e14 (a bound of
     * +-1e9 on every coefficient refused this genuine state; found by the deep fuzzer) */
    {
        ahc_params q = p;
        ahc_controller run;
        int in_transition = 0;
        q.T_ah = ahc_param_find("T_ah")->min;
        CHECK(ahc_init(&run, &q) == AHC_OK, "init with T_ah = %g", q.T_ah);
        for (n = 0; n < 2000 && !in_transition; ++n) {
            ahc_sensors s = { 0.0, 0.0, n < 300 ? 0.045 : -0.005, 70.0 };
            ahc_step(&run, &s, &o);
            in_transition = o.phase == AHC_PHASE_ANKLE_TO_HIP;
        }
        CHECK(in_transition && fabs(run.kw_spline.c[5]) > 1e9, "T_ah = %g: phase 1 with k_w's t^5 coefficient %g",
              q.T_ah, run.kw_spline.c[5]);
        CHECK(accepted(&run, msg, sizeof msg), "T_ah = %g in phase 1: %s", q.T_ah, msg);
        c = run;
        REFUSED(bad.rxd_spline.c[0], 1e12, "rxd_spline coefficient 0");
        REFUSED(bad.kw_spline.c[5], INFINITY, "spline coefficient 5");
    }

    /* a refused state is what ahc_step would turn into non-finite outputs: the guard matters */
    bad = c;
    bad.valid = 0;
    CHECK(accepted(&bad, msg, sizeof msg), "an uninitialized instance is a legal state: %s", msg);
    CHECK(ahc_state_validate(NULL, msg, sizeof msg) == AHC_ERR_NULL, "NULL");
    TEST_MAIN_END();
}
