/*
 * test_faults — establishes the fault handling:
 *  - each bad input (NaN / +Inf / -Inf in every sensor, a ZMP far outside the foot, fz below the
 *    lifted threshold, an angle far outside its joint range) sets exactly its documented bit;
 *  - while a hold fault lasts the outputs are finite, the reference angles are frozen at their
 *    value before the fault and the reference rates are zero;
 *  - after the input is healthy again the fault word is 0 and the controller converges to the
 *    same static lean as an instance that never saw the fault;
 *  - faults during the ankle->hip transition pause the transition (no NaN, phase kept);
 *  - a fault on the very first tick outputs the erect reference (zeros), finite;
 *  - an instance whose init failed reports AHC_FAULT_NOT_INITIALIZED with zero outputs;
 *  - a reference driven to a joint limit is clamped and flagged with the warning bit;
 *  - an implausibly large fz (above fz_max, up to DBL_MAX), for one tick or a hundred, holds the
 *    reference with its bit and is never fed to the disturbance estimate: the controller ends at
 *    the same lean as one that never saw it (audit: one fz = 1e10 sample made the robot fall).
 */
#include <float.h>

#include "ahc_test.h"

static int outputs_finite(const ahc_outputs *o)
{
    return isfinite(o->theta_ankle_ref) && isfinite(o->theta_hip_ref) && isfinite(o->dtheta_ankle_ref) &&
           isfinite(o->dtheta_hip_ref) && isfinite(o->com_x) && isfinite(o->com_z) &&
           isfinite(o->disturbance_moment) && isfinite(o->k_w) && isfinite(o->com_x_desired);
}

int main(void)
{
    ahc_params p;
    ahc_controller c, ref;
    ahc_outputs o, o_ref;
    ahc_sensors good = { 0.0, 0.0, 0.01, 70.0 };
    const double bad_values[3] = { NAN, INFINITY, -INFINITY };
    int field, bv, n;

    ahc_params_default(&p);
    ahc_params_validate(&p, NULL, 0);

    /* non-finite inputs */
    for (field = 0; field < 4; ++field) {
        for (bv = 0; bv < 3; ++bv) {
            const unsigned expect_bit = field == 0 ? AHC_FAULT_THETA_ANKLE_NONFINITE
                                      : field == 1 ? AHC_FAULT_THETA_HIP_NONFINITE
                                      : field == 2 ? AHC_FAULT_ZMP_NONFINITE
                                                   : AHC_FAULT_FZ_NONFINITE;
            ahc_sensors bad = good;
            ahc_outputs before;
            CHECK(ahc_init(&c, &p) == AHC_OK, "init");
            CHECK(ahc_init(&ref, &p) == AHC_OK, "init");
            for (n = 0; n < 300; ++n) {
                ahc_step(&c, &good, &o);
                ahc_step(&ref, &good, &o_ref);
            }
            before = o;
            if (field == 0) bad.theta_ankle = bad_values[bv];
            if (field == 1) bad.theta_hip = bad_values[bv];
            if (field == 2) bad.zmp_x = bad_values[bv];
            if (field == 3) bad.fz = bad_values[bv];
            for (n = 0; n < 200; ++n) {
                ahc_step(&c, &bad, &o);
                CHECK(o.fault == expect_bit, "field %d value %g: fault 0x%x, expected 0x%x", field, bad_values[bv],
                      o.fault, expect_bit);
                CHECK(outputs_finite(&o), "outputs finite under fault");
                CHECK(o.theta_ankle_ref == before.theta_ankle_ref && o.theta_hip_ref == before.theta_hip_ref,
                      "reference held");
                CHECK(o.dtheta_ankle_ref == 0.0 && o.dtheta_hip_ref == 0.0, "rates zero under hold");
            }
            for (n = 0; n < 6000; ++n) {
                ahc_step(&c, &good, &o);
                ahc_step(&ref, &good, &o_ref);
                if (n == 0) CHECK(o.fault == 0, "fault cleared on the first healthy tick: 0x%x", o.fault);
                CHECK(outputs_finite(&o), "finite after recovery");
            }
            CHECK_NEAR(o.theta_ankle_ref, o_ref.theta_ankle_ref, 1e-9, "recovered to the same static lean");
        }
    }

    /* range faults */
    {
        struct { ahc_sensors s; unsigned bit; const char *what; } cases[] = {
            { { 0.0, 0.0, p.toe_x + p.zmp_fault_margin + 0.001, 70.0 }, AHC_FAULT_ZMP_OUTSIDE_FOOT, "zmp beyond toe" },
            { { 0.0, 0.0, p.heel_x - p.zmp_fault_margin - 0.001, 70.0 }, AHC_FAULT_ZMP_OUTSIDE_FOOT, "zmp beyond heel" },
            { { 0.0, 0.0, 0.01, p.fz_lifted - 0.5 }, AHC_FAULT_LIFTED, "lifted" },
            { { 0.0, 0.0, 0.01, 0.0 }, AHC_FAULT_LIFTED, "fz = 0" },
            { { p.ankle_max + p.angle_fault_margin + 0.01, 0.0, 0.01, 70.0 }, AHC_FAULT_ANGLE_RANGE, "ankle range" },
            { { 0.0, p.hip_min - p.angle_fault_margin - 0.01, 0.01, 70.0 }, AHC_FAULT_ANGLE_RANGE, "hip range" },
            { { NAN, 0.0, 0.01, 0.0 }, AHC_FAULT_THETA_ANKLE_NONFINITE | AHC_FAULT_LIFTED, "combined" },
            { { 0.0, 0.0, 0.01, p.fz_max + 0.5 }, AHC_FAULT_FZ_IMPLAUSIBLE, "fz beyond fz_max" },
            { { 0.0, 0.0, 0.01, 1e300 }, AHC_FAULT_FZ_IMPLAUSIBLE, "fz = 1e300" },
        };
        size_t i;
        for (i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
            ahc_outputs before;
            CHECK(ahc_init(&c, &p) == AHC_OK, "init");
            for (n = 0; n < 300; ++n) ahc_step(&c, &good, &o);
            before = o;
            ahc_step(&c, &cases[i].s, &o);
            CHECK(o.fault == cases[i].bit, "%s: fault 0x%x expected 0x%x", cases[i].what, o.fault, cases[i].bit);
            CHECK(outputs_finite(&o), "%s: finite", cases[i].what);
            CHECK(o.theta_ankle_ref == before.theta_ankle_ref, "%s: held", cases[i].what);
            ahc_step(&c, &good, &o);
            CHECK(o.fault == 0, "%s: recovered", cases[i].what);
        }
        /* just inside the margins is healthy */
        CHECK(ahc_init(&c, &p) == AHC_OK, "init");
        {
            ahc_sensors edge = { 0.0, 0.0, p.toe_x + p.zmp_fault_margin - 0.001, p.fz_lifted + 0.5 };
            ahc_step(&c, &edge, &o);
            CHECK(o.fault == 0, "edge values are healthy: 0x%x", o.fault);
        }
    }

    /* implausible fz for 1 and 100 ticks, with both disturbance estimates */
    {
        const double fz_bad[] = { p.fz_max * 1.01, 1e4, 1e10, 1e300, DBL_MAX };
        const int ticks[] = { 1, 100 };
        size_t i, k;
        int rc_mode;
        for (rc_mode = 0; rc_mode <= 1; ++rc_mode) {
            ahc_params q = p;
            q.reaction_compensation = rc_mode;
            for (i = 0; i < sizeof fz_bad / sizeof fz_bad[0]; ++i) {
                for (k = 0; k < 2; ++k) {
                    ahc_sensors bad = good;
                    bad.fz = fz_bad[i];
                    CHECK(ahc_init(&c, &q) == AHC_OK && ahc_init(&ref, &q) == AHC_OK, "init");
                    for (n = 0; n < 300; ++n) {
                        ahc_step(&c, &good, &o);
                        ahc_step(&ref, &good, &o_ref);
                    }
                    for (n = 0; n < ticks[k]; ++n) {
                        ahc_step(&c, &bad, &o);
                        CHECK(o.fault == AHC_FAULT_FZ_IMPLAUSIBLE && outputs_finite(&o) && o.disturbance_moment == 0.0,
                              "fz = %g: fault 0x%x, d = %g", fz_bad[i], o.fault, o.disturbance_moment);
                    }
                    for (n = 0; n < 6000; ++n) {
                        ahc_step(&c, &good, &o);
                        ahc_step(&ref, &good, &o_ref);
                    }
                    CHECK(o.fault == 0 && fabs(o.disturbance_moment) < 1.0, "fz = %g: recovered, d = %g", fz_bad[i],
                          o.disturbance_moment);
                    CHECK_NEAR(o.theta_ankle_ref, o_ref.theta_ankle_ref, 1e-9, "same lean after an implausible fz");
                }
            }
        }
    }

    /* fault during the ankle->hip transition: phase kept, timers paused */
    {
        ahc_sensors push = { 0.0, 0.0, 0.04, 70.0 }, nan_s = { 0.0, 0.0, NAN, 70.0 };
        double kw_before;
        memset(&o, 0, sizeof o);
        CHECK(ahc_init(&c, &p) == AHC_OK, "init");
        for (n = 0; n < 100 && o.phase != AHC_PHASE_ANKLE_TO_HIP; ++n) ahc_step(&c, &push, &o);
        for (n = 0; n < 200; ++n) ahc_step(&c, &push, &o);
        CHECK(o.phase == AHC_PHASE_ANKLE_TO_HIP, "in phase 1");
        kw_before = o.k_w;
        for (n = 0; n < 2000; ++n) {
            ahc_step(&c, &nan_s, &o);
            CHECK(o.phase == AHC_PHASE_ANKLE_TO_HIP && o.k_w == kw_before && outputs_finite(&o),
                  "transition paused under fault");
        }
        ahc_step(&c, &push, &o);
        CHECK(o.fault == 0 && o.phase == AHC_PHASE_ANKLE_TO_HIP && o.k_w > kw_before, "transition resumes");
    }

    /* fault on the first tick */
    {
        ahc_sensors nan_s = { NAN, NAN, NAN, NAN };
        CHECK(ahc_init(&c, &p) == AHC_OK, "init");
        ahc_step(&c, &nan_s, &o);
        CHECK(outputs_finite(&o) && o.theta_ankle_ref == 0.0 && o.theta_hip_ref == 0.0, "erect hold at start");
        CHECK(o.fault == (AHC_FAULT_THETA_ANKLE_NONFINITE | AHC_FAULT_THETA_HIP_NONFINITE | AHC_FAULT_ZMP_NONFINITE |
                          AHC_FAULT_FZ_NONFINITE), "all four non-finite bits: 0x%x", o.fault);
        ahc_step(&c, &good, &o);
        CHECK(o.fault == 0 && outputs_finite(&o), "starts when healthy");
    }

    /* failed init */
    {
        ahc_params bad = p;
        bad.m1 = -1.0;
        CHECK(ahc_init(&c, &bad) == AHC_ERR_RANGE, "init fails");
        ahc_step(&c, &good, &o);
        CHECK(o.fault == AHC_FAULT_NOT_INITIALIZED && o.theta_ankle_ref == 0.0 && outputs_finite(&o),
              "not-initialized bit");
    }

    /* reference saturation at a joint limit (narrow artificial ankle range) */
    {
        ahc_params q = p;
        int seen = 0;
        q.ankle_max = 0.02;
        q.angle_fault_margin = 1.0;
        q.hip_strategy_enabled = 0;
        CHECK(ahc_init(&c, &q) == AHC_OK, "init");
        for (n = 0; n < 3000; ++n) {
            ahc_sensors s = { 0.0, 0.0, 0.03, 70.0 }; /* static lean would be ~0.05 rad */
            ahc_step(&c, &s, &o);
            CHECK(o.theta_ankle_ref <= q.ankle_max, "clamped");
            if (o.fault & AHC_FAULT_REF_SATURATED) ++seen;
            CHECK((o.fault & ~(unsigned)AHC_FAULT_REF_SATURATED) == 0, "only the warning bit");
        }
        CHECK(seen > 0 && o.theta_ankle_ref == q.ankle_max, "saturation flagged: %d ticks", seen);
    }

    {
        char buf[128];
        ahc_fault_string(AHC_FAULT_LIFTED | AHC_FAULT_ZMP_NONFINITE, buf, sizeof buf);
        CHECK(strcmp(buf, "zmp_nonfinite,lifted") == 0, "fault string: %s", buf);
    }
    TEST_MAIN_END();
}
