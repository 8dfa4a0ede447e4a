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
        /* a push that runs 0 -> 1 -> 2 -> 3 -> 0, with a NaN sample and a lifted sample */
        ahc_sensors s = { 0.0, 0.0, n < 300 ? 0.045 : -0.005, 70.0 };
        if (n == 150) s.zmp_x = NAN;
        if (n == 151) s.fz = 1.0;
        ahc_step(&c, &s, &o);
        phases_seen |= 1 << o.phase;
        if (!accepted(&c, msg, sizeof msg)) {
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

    /* a refused state is what ahc_step would turn into non-finite outputs: the guard matters */
    bad = c;
    bad.valid = 0;
    CHECK(accepted(&bad, msg, sizeof msg), "an uninitialized instance is a legal state: %s", msg);
    CHECK(ahc_state_validate(NULL, msg, sizeof msg) == AHC_ERR_NULL, "NULL");
    TEST_MAIN_END();
}
