/*
 * test_stepping.c — the stepping layer (stepping.h, docs/controller.md §12) on a kinematic robot
 * that follows its joint references exactly: the estimate and the plan agree, the swing foot lands
 * where it was sent, the phases run in order, and the references are continuous across every switch.
 * A restored state is validated: forged phases, flags, references and quintics (the swing foot's and
 * the trunk's: a NaN coefficient was accepted before and made the references NaN) are refused, every
 * genuine state of a step accepted.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ahc/controller3d.h"
#include "ahc/stepping.h"
#include "ahc_test.h"
#include "hoap2/nominal.h"

/* The trunk's attitude of a robot standing flat on leg `side` with joint angles q: the IMU's
 * roll and pitch (R_trunk = Rf^T, Rf the foot's attitude relative to the trunk). */
static void imu_of(const ahc_leg_geometry *g, const double q[AHC_LEG_JOINTS], double *roll, double *pitch)
{
    double a[3], Rf[9];
    ahc_leg_fk_pose(g, q, a, Rf);
    /* R = Rf^T: R[6] = Rf[2], R[7] = Rf[5], R[8] = Rf[8] */
    *pitch = asin(-Rf[2]);
    *roll = atan2(Rf[5], Rf[8]);
}

static void defaults(ahc_params *sp, ahc_frontal_params *fp, ahc_step_params *st)
{
    ahc_params_default(sp);
    ahc_frontal_params_default(fp);
    ahc_step_params_default(st);
    st->stepping_enabled = 1;
    st->step_servo_lead = st->step_servo_lead_hip = 0.0; /* the kinematic robot has no servo lag */
}

/* What a kinematic run shows (kinematic_run). */
typedef struct {
    int started, ended, steps, phases_seen, n_seq, seq[16];
    double landing[2], max_jump, max_com_err, max_rate[AHC_LEG_JOINTS];
    double max_swing_step; /* the swing leg's largest set-point change in a tick while it swings [rad] */
    double rest_planned;  /* the first SETTLE's planned end (the closing step's earliest start) [s] */
    double close_start;   /* the closing step's weight shift began [s]                         */
    double close_capture[2]; /* the capture point when the closing step's swing began [m]         */
    /* the first swing's foot, placed by its set points through the measured pelvis (the stance
     * leg's measured joints and the IMU), from the blend's end to the plan's landing time: */
    double max_swing_miss;  /* largest horizontal distance from the plan's place for it [m]         */
    double max_swing_tilt;  /* largest tilt of its sole from flat in the world [rad]                */
    double late_swing_min_z; /* its lowest height above the ground over the last 20 % of the swing [m] */
} kinematic_result;

/* What the kinematic robot's measurements do differently from its references while the first step
 * swings: the stance leg yields (its hip pitches `stance_yield` more than asked, the trunk turning
 * with it over the flat stance foot: the IMU says so too), or the swing leg's joints stay as they
 * were at the swing's start (`swing_frozen`: the body carries the leg, not its plan). */
typedef struct {
    double stance_yield;
    int swing_frozen;
} kinematic_opts;

/* The swing foot's ankle relative to the stance ankle, and its sole's tilt from flat, for the
 * stance leg's measured joints q_stance, the swing leg's q_swing and the trunk's measured roll and
 * pitch. */
static void swing_foot_from_stance(const ahc_leg_geometry *g, int swing, const double q_stance[AHC_LEG_JOINTS],
                                   const double q_swing[AHC_LEG_JOINTS], double roll, double pitch, double rel[3],
                                   double *tilt, double *hip_to_ankle)
{
    double a_st[3], a_sw[3], Rst[9], Rsw[9], d[3], cr = cos(roll), sr = sin(roll), cp = cos(pitch), sp = sin(pitch);
    /* the trunk's attitude R = Ry(pitch) Rx(roll), as the layer's */
    const double R[9] = {cp, sp * sr, sp * cr, 0.0, cr, -sr, -sp, cp * sr, cp * cr};
    int i;
    ahc_leg_fk_pose(g, q_stance, a_st, Rst);
    ahc_leg_fk_pose(g, q_swing, a_sw, Rsw);
    a_st[1] += swing == AHC_LEFT ? -g->hip_y : g->hip_y;
    a_sw[1] += swing == AHC_LEFT ? g->hip_y : -g->hip_y;
    for (i = 0; i < 3; ++i) d[i] = a_sw[i] - a_st[i];
    for (i = 0; i < 3; ++i) rel[i] = R[3 * i] * d[0] + R[3 * i + 1] * d[1] + R[3 * i + 2] * d[2];
    /* the sole's normal in the world, R Rsw e_z: its horizontal part is the tilt's sine */
    *tilt = asin(fmin(1.0, hypot(R[0] * Rsw[2] + R[1] * Rsw[5] + R[2] * Rsw[8], R[3] * Rsw[2] + R[4] * Rsw[5] + R[5] * Rsw[8])));
    *hip_to_ankle = sqrt(a_sw[0] * a_sw[0] + (a_sw[1] - (swing == AHC_LEFT ? g->hip_y : -g->hip_y)) * (a_sw[1] - (swing == AHC_LEFT ? g->hip_y : -g->hip_y)) + a_sw[2] * a_sw[2]);
}

/* A robot falling forward about its ankles (both legs pitched by th, all else 0) until the step
 * starts; then its joints are the step's references of the tick before. For `unrest` seconds after
 * the first SETTLE's planned end the right sole reads no load (the robot not yet at rest). */
static void kinematic_run_with(const ahc_step_params *st, double unrest, const kinematic_opts *o, kinematic_result *r)
{
    ahc_params sp;
    ahc_frontal_params fp;
    static ahc_stepper c;
    ahc_step_outputs out;
    ahc_step_sensors s;
    const ahc_leg_geometry g = ahc_test_hoap2_legs();
    double flat[2][AHC_LEG_JOINTS], prev[2][AHC_LEG_JOINTS];
    double th = 0.0, dth = 0.0, t, frozen[AHC_LEG_JOINTS];
    const double weight = HOAP2_TOTAL_MASS * HOAP2_G;
    int k, side, j, last_phase = AHC_STEP_STAND, swings = 0;
    memset(r, 0, sizeof *r);
    r->late_swing_min_z = INFINITY;
    r->rest_planned = r->close_start = -1.0;
    ahc_params_default(&sp);
    ahc_frontal_params_default(&fp);
    CHECK(ahc_step_init(&c, st, &sp, &fp) == AHC_OK, "init");
    memset(&s, 0, sizeof s);
    memset(prev, 0, sizeof prev);
    for (k = 0; k < 6000; ++k) {
        t = k * sp.sample_period;
        if (!r->started) {
            /* an inverted pendulum falling forward from rest */
            const double omega2 = HOAP2_G / 0.26;
            if (k > 100) {
                dth += omega2 * sin(th + 0.002) * sp.sample_period;
                th += dth * sp.sample_period;
            }
            memset(flat, 0, sizeof flat);
            for (side = 0; side < 2; ++side) flat[side][AHC_LEG_ANKLE_PITCH] = th;
            memcpy(s.q, flat, sizeof flat);
            s.imu_pitch = th;
            s.imu_roll = 0.0;
            s.fz_left = s.fz_right = 0.5 * weight;
        } else {
            memset(flat, 0, sizeof flat); /* the flat-footed layers would hold the erect posture */
            /* exact tracking: the references of the tick before */
            memcpy(s.q, prev, sizeof prev);
            if (o && out.phase == AHC_STEP_SWING && swings == 1) {
                const int stance = out.swing_side == AHC_LEFT ? AHC_RIGHT : AHC_LEFT;
                s.q[stance][AHC_LEG_HIP_PITCH] += o->stance_yield;
                if (o->swing_frozen) memcpy(s.q[out.swing_side], frozen, sizeof frozen);
            }
            {
                const int stance = out.phase == AHC_STEP_SWING || out.phase == AHC_STEP_CLOSE
                                       ? (out.swing_side == AHC_LEFT ? AHC_RIGHT : AHC_LEFT)
                                       : AHC_LEFT;
                imu_of(&g, s.q[stance], &s.imu_roll, &s.imu_pitch);
                if (out.phase == AHC_STEP_SWING || out.phase == AHC_STEP_CLOSE) {
                    /* the swing sole carries the weight once its plan has brought it down */
                    const int down = c.phase_time >= c.swing_time;
                    s.fz_left = out.swing_side == AHC_LEFT ? (down ? weight : 0.0) : weight;
                    s.fz_right = out.swing_side == AHC_RIGHT ? (down ? weight : 0.0) : weight;
                } else {
                    s.fz_left = s.fz_right = 0.5 * weight;
                    /* (this tick's phase time: the last one's and a tick) */
                    const double pt = c.phase_time + sp.sample_period;
                    if (out.phase == AHC_STEP_SETTLE && c.close_stage == 1 && pt >= c.phase_duration - 1e-9 &&
                        pt < c.phase_duration + unrest - 1e-9)
                        s.fz_right = 0.0;
                }
            }
        }
        ahc_step_step(&c, &s, (const double(*)[AHC_LEG_JOINTS])flat, &out);
        if (out.phase == AHC_STEP_SWING && last_phase != AHC_STEP_SWING && ++swings == 1)
            memcpy(frozen, s.q[out.swing_side], sizeof frozen);
        if (out.phase == AHC_STEP_SWING && swings == 1 && c.phase_time > st->step_blend_time + sp.sample_period &&
            c.phase_time <= c.swing_time) {
            const int sw = out.swing_side, stance = sw == AHC_LEFT ? AHC_RIGHT : AHC_LEFT;
            double rel[3], tilt, reach;
            swing_foot_from_stance(&g, sw, s.q[stance], out.q_ref[sw], s.imu_roll, s.imu_pitch, rel, &tilt, &reach);
            /* (where the plan's place lies beyond the leg's reach, the layer brings the foot short) */
            if (reach < c.l1 * cos(0.1) - 1e-6)
                r->max_swing_miss = fmax(r->max_swing_miss, hypot(c.feet[stance][0] + rel[0] - c.swing_pos[0],
                                                                  c.feet[stance][1] + rel[1] - c.swing_pos[1]));
            r->max_swing_tilt = fmax(r->max_swing_tilt, tilt);
            if (c.phase_time >= 0.8 * c.swing_time) r->late_swing_min_z = fmin(r->late_swing_min_z, rel[2]);
        }
        if (out.phase == AHC_STEP_SETTLE && c.close_stage == 1 && r->rest_planned < 0.0)
            r->rest_planned = t + c.phase_duration - c.phase_time;
        if (out.phase == AHC_STEP_SHIFT && c.close_stage == 2 && r->close_start < 0.0) r->close_start = t;
        if (out.phase == AHC_STEP_CLOSE && last_phase != AHC_STEP_CLOSE) {
            r->close_capture[0] = out.capture[0];
            r->close_capture[1] = out.capture[1];
        }
        if (out.active) {
            double jump = 0.0;
            if (r->started)
                for (side = 0; side < 2; ++side)
                    for (j = 0; j < AHC_LEG_JOINTS; ++j) jump = fmax(jump, fabs(out.q_ref[side][j] - prev[side][j]));
            else
                for (side = 0; side < 2; ++side)
                    for (j = 0; j < AHC_LEG_JOINTS; ++j) jump = fmax(jump, fabs(out.q_ref[side][j] - flat[side][j]));
            if (getenv("STEP_DEBUG") && r->started)
                for (side = 0; side < 2; ++side)
                    for (j = 0; j < AHC_LEG_JOINTS; ++j)
                        if (fabs(out.q_ref[side][j] - prev[side][j]) > 0.005)
                            fprintf(stderr, "rate tick %d phase %d t %.4f side %d joint %d: %.1f rad/s\n", k, out.phase,
                                    c.phase_time, side, j, (out.q_ref[side][j] - prev[side][j]) / sp.sample_period);
            r->max_jump = fmax(r->max_jump, jump);
            if (r->started && (out.phase == AHC_STEP_SWING || out.phase == AHC_STEP_CLOSE))
                for (j = 0; j < AHC_LEG_JOINTS; ++j)
                    r->max_swing_step = fmax(r->max_swing_step, fabs(out.q_ref[out.swing_side][j] - prev[out.swing_side][j]));
            if (r->started)
                for (side = 0; side < 2; ++side)
                    for (j = 0; j < AHC_LEG_JOINTS; ++j)
                        r->max_rate[j] = fmax(r->max_rate[j], fabs(out.q_ref[side][j] - prev[side][j]) / sp.sample_period);
            memcpy(prev, out.q_ref, sizeof prev);
            r->started = 1;
            if (out.phase != AHC_STEP_STAND && c.phase_time > 0.05)
                r->max_com_err = fmax(r->max_com_err, hypot(out.com[0] - out.com_ref[0], out.com[1] - out.com_ref[1]));
        } else if (r->started) {
            r->ended = 1;
            break;
        }
        if (out.phase != last_phase) {
            r->phases_seen |= 1 << out.phase;
            if (r->n_seq < 16) r->seq[r->n_seq++] = out.phase;
            if (last_phase == AHC_STEP_SWING) {
                r->landing[0] = out.landing[0];
                r->landing[1] = out.landing[1];
            }
            last_phase = out.phase;
        }
    }
    r->steps = out.steps;
}

static void kinematic_run(const ahc_step_params *st, double unrest, kinematic_result *r)
{
    kinematic_run_with(st, unrest, NULL, r);
}

static void test_kinematic_step(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    kinematic_result r;
    /* the recovery step, at rest on the feet apart, the closing step, at rest together, standing */
    static const int expected[] = {AHC_STEP_SHIFT, AHC_STEP_SWING, AHC_STEP_TRANSFER, AHC_STEP_SETTLE,
                                   AHC_STEP_SHIFT, AHC_STEP_CLOSE, AHC_STEP_SETTLE, AHC_STEP_STAND};
    defaults(&sp, &fp, &st);
    kinematic_run(&st, 0.0, &r);
    CHECK(r.started, "a step started");
    CHECK(r.ended, "the step ended within 6 s");
    CHECK(r.phases_seen == ((1 << AHC_STEP_SHIFT) | (1 << AHC_STEP_SWING) | (1 << AHC_STEP_TRANSFER) |
                            (1 << AHC_STEP_CLOSE) | (1 << AHC_STEP_SETTLE) | (1 << AHC_STEP_STAND)),
          "every phase ran (mask 0x%x)", r.phases_seen);
    CHECK(r.steps == 2, "two steps landed (%d)", r.steps);
    CHECK(r.n_seq == 8 && memcmp(r.seq, expected, sizeof expected) == 0,
          "the phases in order: shift, swing, transfer, settle, shift, close, settle, stand (%d phases)", r.n_seq);
    CHECK(r.landing[0] > 0.02, "the first step went forward (landing x %.4f)", r.landing[0]);
    CHECK(r.max_jump < 0.02, "the references move at most 0.02 rad per tick (%.4f)", r.max_jump);
    CHECK(r.max_com_err < 2e-3, "the estimate follows the plan's CoM within 2 mm (%.5f)", r.max_com_err);
    printf("kinematic step: landing (%.4f, %.4f), largest step of a reference %.5f rad/tick, CoM estimate - plan %.2e m\n",
           r.landing[0], r.landing[1], r.max_jump, r.max_com_err);
    /* what the plan asks of the servos (Hoap2Plant3D's vel_max: 5 rad/s; docs/controller.md §12.4) */
    printf("kinematic step: fastest planned joint rates [rad/s]: hip yaw %.1f, hip pitch %.1f, hip roll %.1f, knee %.1f, "
           "ankle pitch %.1f, ankle roll %.1f\n",
           r.max_rate[0], r.max_rate[1], r.max_rate[2], r.max_rate[3], r.max_rate[4], r.max_rate[5]);
}

/* step_swing_rate_max: the swing leg's set points move at most that fast while it swings (the
 * kinematic plan asks up to 12.9 rad/s of the knee, so 5 rad/s, Hoap2Plant3D's servo rate, is a
 * limit that acts), and the steps still run to the end. */
static void test_swing_rate_max(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    kinematic_result free_run, limited;
    defaults(&sp, &fp, &st);
    kinematic_run(&st, 0.0, &free_run);
    st.step_swing_rate_max = 5.0;
    kinematic_run(&st, 0.0, &limited);
    CHECK(free_run.max_swing_step > 5.0 * sp.sample_period * 1.5,
          "without the limit the swing leg moves faster than 5 rad/s (%.2f rad/s)", free_run.max_swing_step / sp.sample_period);
    CHECK(limited.max_swing_step <= 5.0 * sp.sample_period * (1.0 + 1e-12),
          "with step_swing_rate_max 5 rad/s it moves at most that (%.4f rad/s)", limited.max_swing_step / sp.sample_period);
    CHECK(limited.ended && limited.steps == 2, "both steps run to the end (%d steps)", limited.steps);
    CHECK(limited.max_jump < 0.02, "the references move at most 0.02 rad per tick (%.4f)", limited.max_jump);
}

/* step_swing_measured: a stance leg that yields 0.05 rad at the hip turns the trunk with it; the
 * plan's swing leg, set for the planned trunk, then carries its foot away from where the plan puts
 * it, and the swing set from the pelvis as measured puts it there (to 1e-9 tracking exactly, within
 * 0.5 mm with the yield) and flat. */
static void test_swing_measured(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    kinematic_result exact, planned, measured;
    const kinematic_opts yields = {0.05, 0};
    defaults(&sp, &fp, &st);
    st.step_swing_measured = 1.0;
    kinematic_run_with(&st, 0.0, NULL, &exact);
    kinematic_run_with(&st, 0.0, &yields, &measured);
    st.step_swing_measured = 0.0;
    kinematic_run_with(&st, 0.0, &yields, &planned);
    CHECK(exact.max_swing_miss < 1e-9 && exact.max_swing_tilt < 1e-9,
          "tracking exactly, the measured swing puts the foot where the plan does, flat (%.2e m, %.2e rad)",
          exact.max_swing_miss, exact.max_swing_tilt);
    CHECK(planned.max_swing_miss > 5e-3 && planned.max_swing_tilt > 0.04,
          "the stance leg yielding, the plan's swing misses by more than 5 mm, tilted (%.4f m, %.3f rad)",
          planned.max_swing_miss, planned.max_swing_tilt);
    /* (within 0.5 mm, not 1e-9: the stance hip's yaw of a few mrad turns the trunk in a way the IMU's
     * roll and pitch, all the layer reads of its attitude, do not carry) */
    CHECK(measured.max_swing_miss < 5e-4 && measured.max_swing_tilt < 1e-9,
          "the stance leg yielding, the measured swing puts the foot where the plan does within 0.5 mm, flat (%.2e m, %.2e rad)",
          measured.max_swing_miss, measured.max_swing_tilt);
    CHECK(measured.ended && measured.steps == 2, "both steps run to the end (%d steps)", measured.steps);
    CHECK(measured.max_jump < 0.06, "the references move at most 0.06 rad per tick (%.4f)", measured.max_jump);
}

/* step_swing_hold: a swing leg whose joints do not move is carried by the body, its ankle at least
 * 16 mm short of the landing point; held within 15 mm, past mid-swing the plan keeps the foot at its
 * peak (0.452 step_height) instead of bringing it down on time. */
static void test_swing_hold(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    kinematic_result on_time, held;
    const kinematic_opts frozen = {0.0, 1};
    defaults(&sp, &fp, &st);
    kinematic_run_with(&st, 0.0, &frozen, &on_time);
    st.step_swing_hold = 0.015;
    kinematic_run_with(&st, 0.0, &frozen, &held);
    CHECK(on_time.late_swing_min_z < 0.2 * 0.452 * st.step_height,
          "on time, the foot's set point comes down over the swing's last 20 %% (lowest %.4f m)", on_time.late_swing_min_z);
    CHECK(held.late_swing_min_z > 0.9 * 0.452 * st.step_height && held.late_swing_min_z < 1.1 * 0.452 * st.step_height,
          "held, it stays at the peak, 0.452 step_height = %.4f m (lowest %.4f m)", 0.452 * st.step_height,
          held.late_swing_min_z);
}

/* The closing step's rest (step_close_rest): off, it starts at SETTLE's planned end; on (the default), it waits
 * while a sole reads no load, and starts on the first tick at rest; a robot that never comes to
 * rest gets it step_close_wait after the planned end. */
static void test_close_rest(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    kinematic_result r;
    const double dt = 0.001;
    defaults(&sp, &fp, &st);
    st.step_close_rest = 0.0;
    kinematic_run(&st, 0.3, &r);
    CHECK(r.rest_planned > 0.0 && fabs(r.close_start - r.rest_planned) < 1.5 * dt,
          "off: the closing step at SETTLE's planned end (%.4f vs %.4f s), a sole unloaded or not", r.close_start,
          r.rest_planned);
    st.step_close_rest = 0.005;
    kinematic_run(&st, 0.0, &r);
    CHECK(fabs(r.close_start - r.rest_planned) < 1.5 * dt, "on, at rest: at the planned end (%.4f vs %.4f s)",
          r.close_start, r.rest_planned);
    kinematic_run(&st, 0.3, &r);
    CHECK(fabs(r.close_start - (r.rest_planned + 0.3)) < 1.5 * dt,
          "on, a sole unloaded 0.3 s: the closing step when it is loaded again (%.4f vs %.4f s)", r.close_start,
          r.rest_planned + 0.3);
    CHECK(r.ended && r.steps == 2, "... and both steps run to the end (%d steps)", r.steps);
    st.step_close_wait = 0.2;
    kinematic_run(&st, 0.3, &r);
    CHECK(fabs(r.close_start - (r.rest_planned + 0.2)) < 1.5 * dt,
          "on, never at rest within step_close_wait 0.2 s: the closing step then (%.4f vs %.4f s)", r.close_start,
          r.rest_planned + 0.2);
    st.step_close_wait = 1.0;
    st.step_close_rest = 1e-6;
    kinematic_run(&st, 0.0, &r);
    CHECK(r.close_start > r.rest_planned + 1.5 * dt,
          "a capture point never within 1 um of the CoM (it moves): the closing step waits (%.4f vs %.4f s)",
          r.close_start, r.rest_planned);
}

/* The closing step's weight shift (step_close_inset): the capture point ends step_close_inset inside
 * of the landed ankle, toward the other foot, whatever the recovery step's step_shift_inset. */
static void test_close_inset(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    kinematic_result r;
    const double insets[] = {0.0, 0.01, 0.02};
    size_t i;
    defaults(&sp, &fp, &st);
    for (i = 0; i < sizeof insets / sizeof insets[0]; ++i) {
        double aim;
        st.step_close_inset = insets[i];
        kinematic_run(&st, 0.0, &r);
        /* the landed foot's side: the closing foot goes to the other one */
        aim = r.landing[1] + (r.landing[1] > 0.0 ? -1.0 : 1.0) * insets[i];
        CHECK(r.ended && r.steps == 2, "close inset %g: both steps run to the end (%d steps)", insets[i], r.steps);
        CHECK(fabs(r.close_capture[1] - aim) < 2e-3,
              "close inset %g: the capture point at the closing swing's start %.4f m, aimed at %.4f m (the landed "
              "ankle at %.4f m)", insets[i], r.close_capture[1], aim, r.landing[1]);
        CHECK(fabs(r.close_capture[0] - r.landing[0]) < 2e-3,
              "close inset %g: ... over the landed ankle in x (%.4f vs %.4f m)", insets[i], r.close_capture[0],
              r.landing[0]);
    }
}

/* Validation names the parameter and its value. */
/* The named stepping configurations (ahc_step_params_named): lasting_push is the stepping layer on
 * with docs/controller.md §12.6's settings and valid on HOAP-2; an unknown name (or NULL) is an error
 * that leaves the defaults. */
static void test_named_step_configs(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st, def;
    char msg[256];
    size_t i;
    defaults(&sp, &fp, &st);
    memset(&def, 0x5a, sizeof def); /* (the padding as the one below: the structs compare bytewise) */
    ahc_step_params_default(&def);
    CHECK(ahc_step_config_count() == 1 && strcmp(ahc_step_config_name(0), "lasting_push") == 0 &&
              ahc_step_config_name(1) == NULL && ahc_step_config_description(0) != NULL &&
              ahc_step_config_description(1) == NULL,
          "one named stepping configuration, lasting_push");
    CHECK(ahc_step_params_named(&st, "lasting_push") == AHC_OK, "lasting_push by name");
    CHECK(st.stepping_enabled == 1 && st.step_push_estimate == 2 && st.step_trigger_lean == 0.0 &&
              st.step_length_max == 0.2 && st.step_swing_time == 0.15 && st.step_shift_time_max == 0.0 &&
              st.step_feet_tilt_gain == 1.0 && st.step_settle_on_axis == 1 && st.step_close == 0,
          "its settings (docs/controller.md 12.6)");
    CHECK(ahc_step_params_validate(&st, &sp, &fp, msg, sizeof msg) == AHC_OK, "valid on HOAP-2: %s", msg);
    for (i = 0; i < 2; ++i) {
        memset(&st, 0x5a, sizeof st);
        CHECK(ahc_step_params_named(&st, i ? NULL : "Lasting_push") == AHC_ERR_UNKNOWN_NAME &&
                  memcmp(&st, &def, sizeof st) == 0,
              "an unknown name is AHC_ERR_UNKNOWN_NAME and leaves the defaults (%s)", i ? "NULL" : "Lasting_push");
    }
    CHECK(ahc_step_params_named(NULL, "lasting_push") == AHC_ERR_NULL, "NULL parameters: AHC_ERR_NULL");
}

static void test_params(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    char msg[256];
    size_t n = 0, i;
    const ahc_param_info *t = ahc_step_param_table(&n);
    defaults(&sp, &fp, &st);
    CHECK(ahc_step_params_validate(&st, &sp, &fp, msg, sizeof msg) == AHC_OK, "defaults valid: %s", msg);
    st.step_swing_time = 0.0;
    CHECK(ahc_step_params_validate(&st, &sp, &fp, msg, sizeof msg) == AHC_ERR_RANGE && strstr(msg, "step_swing_time"),
          "a zero swing time is refused naming it: %s", msg);
    defaults(&sp, &fp, &st);
    st.step_width_max = 0.05;
    CHECK(ahc_step_params_validate(&st, &sp, &fp, msg, sizeof msg) == AHC_ERR_INCONSISTENT && strstr(msg, "step_width_max"),
          "a width below the stance is refused: %s", msg);
    defaults(&sp, &fp, &st);
    st.step_height = NAN;
    CHECK(ahc_step_params_validate(&st, &sp, &fp, msg, sizeof msg) == AHC_ERR_NONFINITE, "NaN refused: %s", msg);
    for (i = 0; i < n; ++i) CHECK(ahc_step_param_find(t[i].name) == &t[i], "find %s", t[i].name);
    CHECK(ahc_step_param_find("no_such") == NULL, "unknown name");
}

/* With stepping off the 3D controller is the flat-footed layers alone: the outputs of an instance
 * with other stepping parameters equal those of ahc3d_init's, bit for bit, and the layer never acts. */
static void test_off_is_flat_footed(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    static ahc3d a, b;
    ahc3d_sensors s;
    ahc3d_outputs oa, ob;
    int k, differ = 0, active = 0;
    defaults(&sp, &fp, &st);
    st.stepping_enabled = 0;
    st.step_trigger_x = -0.05; /* would step at once if it were on */
    st.step_height = 0.03;
    CHECK(ahc3d_init(&a, &sp, &fp) == AHC_OK, "init a");
    CHECK(ahc3d_init_stepping(&b, &sp, &fp, &st) == AHC_OK, "init b");
    memset(&s, 0, sizeof s);
    s.sag.fz = s.fz_left + s.fz_right;
    for (k = 0; k < 3000; ++k) {
        const double t = k * sp.sample_period;
        s.sag.theta_ankle = 0.02 * sin(3.0 * t);
        s.sag.theta_hip = -0.01 * sin(2.0 * t);
        s.sag.zmp_x = 0.03 * sin(5.0 * t);
        s.zmp_y = 0.02 * sin(4.0 * t);
        s.fz_left = s.fz_right = 35.0;
        s.sag.fz = 70.0;
        s.q[0][AHC_LEG_ANKLE_PITCH] = s.q[1][AHC_LEG_ANKLE_PITCH] = s.sag.theta_ankle;
        s.q[0][AHC_LEG_HIP_PITCH] = s.q[1][AHC_LEG_HIP_PITCH] = s.sag.theta_hip;
        s.imu_pitch = s.sag.theta_ankle + s.sag.theta_hip;
        ahc3d_step(&a, &s, &oa);
        ahc3d_step(&b, &s, &ob);
        differ |= memcmp(&oa, &ob, sizeof oa) != 0;
        active |= ob.step.active || ob.step.phase != AHC_STEP_STAND;
    }
    CHECK(!differ, "stepping off: the outputs do not depend on the stepping parameters");
    CHECK(!active, "stepping off: the layer never acts");
}

/* A capture point beyond the left sole's outer edge steps out with the left foot; one ahead of the
 * toes steps with the foot away from its lateral side. */
static void test_foot_choice(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    static ahc_stepper c;
    ahc_step_sensors s;
    ahc_step_outputs out;
    const double flat[2][AHC_LEG_JOINTS] = {{0}};
    int k, side;
    const double weight = HOAP2_TOTAL_MASS * HOAP2_G;
    struct { double roll, pitch; int swing; const char *what; } cases[] = {
        {-0.3, 0.0, AHC_LEFT, "falling to the left: the left foot steps out"},
        {0.3, 0.0, AHC_RIGHT, "falling to the right: the right foot steps out"},
    };
    for (side = 0; side < 2; ++side) {
        defaults(&sp, &fp, &st);
        st.step_trigger_y = 0.0; /* side steps at the outer sole edges (the default waits 100 mm beyond) */
        CHECK(ahc_step_init(&c, &st, &sp, &fp) == AHC_OK, "init");
        memset(&s, 0, sizeof s);
        s.fz_left = s.fz_right = 0.5 * weight;
        for (k = 0; k < 400; ++k) {
            /* the whole robot turns about the feet's outer edge, faster and faster */
            const double a = cases[side].roll * (k > 50 ? (k - 50) * (k - 50) / 350.0 / 350.0 : 0.0);
            s.imu_roll = a;
            s.q[0][AHC_LEG_ANKLE_ROLL] = s.q[1][AHC_LEG_ANKLE_ROLL] = 0.0;
            ahc_step_step(&c, &s, flat, &out);
            if (out.phase != AHC_STEP_STAND) break;
        }
        CHECK(out.phase != AHC_STEP_STAND && out.swing_side == cases[side].swing, "%s (phase %d, swing %d, capture y %.4f)",
              cases[side].what, out.phase, out.swing_side, out.capture[1]);
    }
}

/* A forged state is refused. */
/* Every state the validation accepts steps with finite set points: a genuine state with one 8-byte
 * slot overwritten (at each aligned offset after the parameters, and straddling two fields, as a
 * re-signed blob can be), by values at and beyond what the validation allows; each accepted forgery
 * is stepped for 10 ticks. Returns the number accepted; *bad the number that gave a non-finite
 * set point. (The deep fuzzer found a forged phase time of -1.4e308 accepted, its step non-finite.) */
static int forged_steps(const ahc_stepper *genuine, int *bad)
{
    static const double values[] = {NAN, INFINITY, -1e308, 1e308, 999.0, -999.0, 1e3 * 1.001, 0.5, -0.5, 1e-300};
    static ahc_stepper f;
    ahc_step_sensors s;
    ahc_step_outputs out;
    const double flat[2][AHC_LEG_JOINTS] = {{0}};
    const size_t first = offsetof(ahc_stepper, tick);
    size_t off;
    int accepted = 0, shift, v, k, side, j;
    memset(&s, 0, sizeof s);
    s.fz_left = s.fz_right = 35.0;
    *bad = 0;
    for (shift = 0; shift < 8; shift += 7)
        for (off = first + (size_t)shift; off + 8 <= sizeof f; off += 8)
            for (v = 0; v < (int)(sizeof values / sizeof values[0]); ++v) {
                int finite = 1;
                f = *genuine;
                memcpy((char *)&f + off, &values[v], 8);
                if (ahc_step_state_validate(&f, NULL, 0) != AHC_OK) continue;
                accepted++;
                for (k = 0; k < 10; ++k) {
                    ahc_step_step(&f, &s, f.phase == AHC_STEP_STAND ? flat : NULL, &out);
                    for (side = 0; side < 2; ++side)
                        for (j = 0; j < AHC_LEG_JOINTS; ++j) finite = finite && isfinite(out.q_ref[side][j]);
                }
                if (!finite && !(*bad)++)
                    printf("forged stepping state: offset %zu = %g accepted, then a non-finite set point\n", off, values[v]);
            }
    return accepted;
}

static void test_state_validate(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    static ahc_stepper c, f;
    char msg[200];
    defaults(&sp, &fp, &st);
    CHECK(ahc_step_init(&c, &st, &sp, &fp) == AHC_OK, "init");
    CHECK(ahc_step_state_validate(&c, msg, sizeof msg) == AHC_OK, "fresh state valid: %s", msg);
    f = c;
    f.phase = 9;
    CHECK(ahc_step_state_validate(&f, msg, sizeof msg) != AHC_OK, "phase 9 refused");
    f = c;
    f.phase = AHC_STEP_SWING;
    f.swing_side = -1;
    CHECK(ahc_step_state_validate(&f, msg, sizeof msg) != AHC_OK, "a swing without a swing foot refused");
    f = c;
    f.c0[0] = INFINITY;
    CHECK(ahc_step_state_validate(&f, msg, sizeof msg) != AHC_OK, "a non-finite reference refused");
    {
        /* mid-swing: the swing foot's and the trunk's quintics are state too (before, a NaN or 1e308
         * coefficient was accepted and the next tick's joint references were not finite) */
        static ahc_stepper run;
        ahc_step_params go = st;
        ahc_step_sensors s;
        ahc_step_outputs out;
        const double flat[2][AHC_LEG_JOINTS] = {{0}};
        static ahc_stepper swing;
        int k, side, j, finite = 1, have_swing = 0, refused = 0, reloading = 0;
        go.step_trigger_x = -0.05; /* steps at once */
        CHECK(ahc_step_init(&run, &go, &sp, &fp) == AHC_OK, "init");
        memset(&s, 0, sizeof s);
        s.fz_left = s.fz_right = 35.0;
        for (k = 0; k < 3000; ++k) { /* every genuine state of a step is accepted */
            /* the swing sole carries nothing while it swings: the soles' loaded time restarts from 0 */
            const int swinging = run.phase == AHC_STEP_SWING || run.phase == AHC_STEP_CLOSE;
            s.fz_left = swinging && run.swing_side == AHC_LEFT ? 0.0 : swinging ? 70.0 : 35.0;
            s.fz_right = swinging && run.swing_side == AHC_RIGHT ? 0.0 : swinging ? 70.0 : 35.0;
            ahc_step_step(&run, &s, flat, &out);
            reloading |= run.obs_loaded_time < run.p.step_impact_hold;
            if (ahc_step_state_validate(&run, msg, sizeof msg) != AHC_OK && !refused++)
                CHECK(0, "tick %d (phase %d) refused: %s", k, run.phase, msg);
            if (!have_swing && run.phase == AHC_STEP_SWING && run.phase_time > 0.02) {
                swing = run;
                have_swing = 1;
            }
            if (k % 150 == 0) { /* forgeries of states through the step: SHIFT, SWING, TRANSFER, SETTLE ... */
                int bad, n = forged_steps(&run, &bad);
                CHECK(n > 0 && bad == 0, "tick %d (phase %d): %d of %d accepted forgeries stepped non-finite", k,
                      run.phase, bad, n);
            }
        }
        CHECK(have_swing && run.steps >= 1, "a step ran (%d)", run.steps);
        CHECK(reloading, "states with the soles' loaded time below step_impact_hold were among them");
        run = swing;
        f = run;
        f.swing[0].c[3] = NAN;
        CHECK(ahc_step_state_validate(&f, msg, sizeof msg) != AHC_OK, "a NaN swing coefficient refused");
        f = run;
        f.swing[1].c[5] = 1e308;
        CHECK(ahc_step_state_validate(&f, msg, sizeof msg) != AHC_OK, "a 1e308 swing coefficient refused");
        f = run;
        f.pitch_plan.T = -1.0;
        CHECK(ahc_step_state_validate(&f, msg, sizeof msg) != AHC_OK, "a negative pitch plan duration refused");
        f = run;
        f.pitch_plan.c[0] = INFINITY;
        CHECK(ahc_step_state_validate(&f, msg, sizeof msg) != AHC_OK, "an infinite pitch plan refused");
        /* what such a state did: the next tick's references not finite */
        f = run;
        f.swing[0].c[3] = NAN;
        ahc_step_step(&f, &s, flat, &out);
        for (side = 0; side < 2; ++side)
            for (j = 0; j < AHC_LEG_JOINTS; ++j) finite = finite && isfinite(out.q_ref[side][j]);
        CHECK(!finite, "the refused forgery is one that breaks the references");
    }
    CHECK(ahc_step_state_consistent(&c, &sp, &fp, msg, sizeof msg) == AHC_OK, "consistent with its parameters: %s", msg);
    f = c;
    f.g = 9.0;
    CHECK(ahc_step_state_consistent(&f, &sp, &fp, msg, sizeof msg) == AHC_ERR_INCONSISTENT && strstr(msg, "g = "),
          "a copy of g that is not the parameters' refused: %s", msg);
    f = c;
    f.p.step_swing_time = -1.0;
    CHECK(ahc_step_state_consistent(&f, &sp, &fp, msg, sizeof msg) == AHC_ERR_RANGE && strstr(msg, "step_swing_time"),
          "an invalid stepping parameter refused: %s", msg);
}

/* Non-finite readings in the middle of a step: the step goes on as planned and every output stays
 * finite. */
static void test_nonfinite_inputs(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    static ahc_stepper c;
    ahc_step_sensors s;
    ahc_step_outputs out;
    const double flat[2][AHC_LEG_JOINTS] = {{0}};
    int k, side, j, finite = 1, stepped = 0;
    defaults(&sp, &fp, &st);
    st.step_trigger_x = -0.05; /* steps at once */
    CHECK(ahc_step_init(&c, &st, &sp, &fp) == AHC_OK, "init");
    memset(&s, 0, sizeof s);
    s.fz_left = s.fz_right = 35.0;
    for (k = 0; k < 2000; ++k) {
        if (k % 7 == 3 && k > 100) {
            s.imu_pitch = NAN;
            s.q[k % 2][k % AHC_LEG_JOINTS] = NAN;
            s.fz_left = INFINITY;
        } else {
            memset(&s, 0, sizeof s);
            s.fz_left = s.fz_right = 35.0;
        }
        ahc_step_step(&c, &s, flat, &out);
        stepped |= out.phase != AHC_STEP_STAND;
        for (side = 0; side < 2; ++side)
            for (j = 0; j < AHC_LEG_JOINTS; ++j) finite = finite && isfinite(out.q_ref[side][j]);
        finite = finite && isfinite(out.capture[0]) && isfinite(out.capture[1]) && isfinite(out.landing[0]) &&
                 isfinite(out.com_ref[0]) && isfinite(out.zmp_plan[1]);
    }
    CHECK(stepped, "a step ran");
    CHECK(finite, "every output finite through non-finite readings");
    CHECK(ahc_step_state_validate(&c, NULL, 0) == AHC_OK, "the state stays valid");
    {
        /* huge finite readings (an FMU input may be any finite value): every state of the steps that
         * follow is one the restore accepts (a 1e30 trunk pitch at a decision made a pitch plan the
         * restore refused, found by the deep fuzzer), every output finite */
        static const double huge[] = {1e30, -1e30, 1e300};
        char msgbuf[200];
        int h, refused = 0;
        for (h = 0; h < 3; ++h) {
            CHECK(ahc_step_init(&c, &st, &sp, &fp) == AHC_OK, "init");
            for (k = 0; k < 1500; ++k) {
                memset(&s, 0, sizeof s);
                s.fz_left = s.fz_right = 35.0;
                if (k % 11 == 5 && k > 20) {
                    s.imu_pitch = huge[h];
                    s.q[k % 2][k % AHC_LEG_JOINTS] = huge[h];
                    s.zmp_x = huge[h];
                    s.fz_right = fabs(huge[h]);
                }
                ahc_step_step(&c, &s, c.phase == AHC_STEP_STAND ? flat : NULL, &out);
                for (side = 0; side < 2; ++side)
                    for (j = 0; j < AHC_LEG_JOINTS; ++j) finite = finite && isfinite(out.q_ref[side][j]);
                if (ahc_step_state_validate(&c, msgbuf, sizeof msgbuf) != AHC_OK && !refused++)
                    CHECK(0, "tick %d (reading %g, phase %d) refused: %s", k, huge[h], c.phase, msgbuf);
            }
        }
        CHECK(finite, "every output finite through huge readings");
        CHECK(refused == 0, "every state through huge readings is one the restore accepts (%d refused)", refused);
    }
}

/* While a step runs the flat-footed layers rest, and the 3D controller's fault masks still report
 * the readings: a non-finite one raises its non-finite bits (fault and fault_y) on that tick; a
 * finite one raises nothing, though the measured ZMP, from the ankles' mid-point, lies beyond the
 * toes of feet side by side (the landed foot is ahead) and a landing's load exceeds fz_max. */
static void test_faults_while_stepping(void)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    static ahc3d c;
    ahc3d_sensors s;
    ahc3d_outputs o;
    int k, steps_ticks = 0, flagged = 0, nan_ticks = 0, false_alarms = 0, frontal_flagged = 0, prev = AHC_STEP_STAND;
    defaults(&sp, &fp, &st);
    st.stepping_enabled = 1;
    st.step_trigger_time = 0.1;
    CHECK(ahc3d_init_stepping(&c, &sp, &fp, &st) == AHC_OK, "init");
    for (k = 0; k < 1500; ++k) {
        const int bad = k % 50 == 25;
        memset(&s, 0, sizeof s);
        s.fz_left = s.fz_right = 35.0;
        s.sag.fz = k % 50 == 40 ? 1.5 * sp.fz_max : 70.0; /* a landing's impact, now and then */
        s.sag.zmp_x = 0.1;                                /* beyond the toes of feet side by side */
        if (bad) s.sag.theta_ankle = s.zmp_y = NAN;
        ahc3d_step(&c, &s, &o);
        /* (the tick a step starts on, the flat-footed layers ran and classified as ever) */
        if (o.step.phase == AHC_STEP_STAND || prev == AHC_STEP_STAND) {
            prev = o.step.phase;
            continue;
        }
        prev = o.step.phase;
        steps_ticks++;
        if (bad) {
            nan_ticks++;
            flagged += (o.sag.fault & AHC_FAULT_THETA_ANKLE_NONFINITE) != 0;
            frontal_flagged += (o.frontal.fault & AHC_FFAULT_ZMP_Y_NONFINITE) != 0;
        } else {
            false_alarms += o.sag.fault != 0 || o.frontal.fault != 0;
        }
    }
    CHECK(steps_ticks > 200, "a step ran");
    CHECK(nan_ticks > 3 && flagged == nan_ticks, "every non-finite reading in the step raises its sagittal bit");
    CHECK(frontal_flagged == nan_ticks, "and its frontal bit");
    CHECK(false_alarms == 0, "finite readings raise no fault while stepping");
}

/* The second trigger (the trunk leaning step_trigger_lean toward the edge the measured ZMP is at)
 * and the impact hold, on a robot standing still, its feet flat, its trunk leaned forward by the
 * hips: the step starts on the tick the rule says, and not otherwise. With jump_tick > 0 the trunk's
 * pitch jumps by 0.05 rad on that tick (the estimate's capture point with it, as a foot slapping
 * down moves it). */
/* The tick the first step starts (-1: none in 200 ticks) on a robot standing still, its legs
 * upright and its trunk leaning `lean` forward and `roll` sideways (+: top toward -y); the measured
 * ZMP at zmp_x; from jump_tick on the trunk reads 0.05 rad more (an impact). *xi_y, if given: the
 * estimate's lateral capture point on the last tick. */
static int first_step_tick_at(double trigger_lean, double lean, double zmp_x, double trigger_x, int jump_tick,
                              double roll, double trigger_time, double *xi_y)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params st;
    static ahc_stepper c;
    ahc_step_sensors s;
    ahc_step_outputs out;
    const double flat[2][AHC_LEG_JOINTS] = {{0}};
    double e1, e2;
    int k;
    defaults(&sp, &fp, &st);
    st.step_trigger_lean = trigger_lean;
    st.step_trigger_x = trigger_x;
    st.step_trigger_time = trigger_time;
    CHECK(ahc_step_init(&c, &st, &sp, &fp) == AHC_OK, "init");
    ahc_erect_posture(&sp, &e1, &e2);
    memset(&s, 0, sizeof s);
    s.fz_left = s.fz_right = 35.0;
    s.zmp_x = zmp_x;
    s.imu_roll = roll;
    s.q[0][AHC_LEG_HIP_PITCH] = s.q[1][AHC_LEG_HIP_PITCH] = lean; /* the legs stay upright */
    s.q[0][AHC_LEG_HIP_ROLL] = s.q[1][AHC_LEG_HIP_ROLL] = roll;
    for (k = 1; k <= 200; ++k) {
        s.imu_pitch = e1 + e2 + lean + (jump_tick > 0 && k >= jump_tick ? 0.05 : 0.0);
        ahc_step_step(&c, &s, flat, &out);
        if (xi_y) *xi_y = out.capture[1];
        if (out.phase != AHC_STEP_STAND) return k;
    }
    return -1;
}

static int first_step_tick(double trigger_lean, double lean, double zmp_x, double trigger_x, int jump_tick)
{
    return first_step_tick_at(trigger_lean, lean, zmp_x, trigger_x, jump_tick, 0.0, 0.0, NULL);
}

static void test_triggers(void)
{
    const double toe = HOAP2_TOE_X, m = 0.01; /* step_zmp_margin's default */
    const int k0 = first_step_tick(0.4, 0.45, toe - 0.5 * m, 1.0, 0);
    CHECK(k0 == 21, "leaned 0.45 rad > step_trigger_lean 0.4 with the ZMP at the toe: a step at once (tick %d)", k0);
    CHECK(first_step_tick(0.4, 0.45, toe - 2.0 * m, 1.0, 0) < 0, "the same lean with the ZMP inside the sole: no step");
    CHECK(first_step_tick(0.4, 0.35, toe - 0.5 * m, 1.0, 0) < 0, "a lean below step_trigger_lean: no step");
    CHECK(first_step_tick(0.0, 0.45, toe - 0.5 * m, 1.0, 0) < 0, "step_trigger_lean 0: the rule is off");
    {
        /* a sagittal rule: the same lean with the capture point beyond a sole's inner edge (the
         * robot rolled toward -y) starts no step (upright across, k0 above, it does) */
        double xi_y = 0.0;
        const double inner = HOAP2_ANKLE_Y - 0.5 * HOAP2_SOLE_WIDTH;
        CHECK(first_step_tick_at(0.4, 0.45, toe - 0.5 * m, 1.0, 0, 0.2, 0.0, &xi_y) < 0 && fabs(xi_y) > inner,
              "leaned 0.45 rad at the toe, the capture point %.4f m sideways, beyond the inner edge %.4f m: no step",
              xi_y, inner);
    }
    CHECK(first_step_tick(0.0, 0.0, 0.0, -0.05, 0) == 21, "the capture point beyond the edge: a step at once");
    {
        /* the impact on tick 40 (the step started on 21) and on tick 15 (before it may start): the
         * step waits step_impact_hold (20 ms) after the capture point last moved faster than the
         * pendulum allows; the estimate's low-passed rate spreads the jump over some 30 ticks, so
         * the step starts some 50 ticks after the jump, and it does start */
        const int k15 = first_step_tick(0.0, 0.0, 0.0, -0.05, 15);
        CHECK(first_step_tick(0.0, 0.0, 0.0, -0.05, 40) == 21, "an impact after the step started changes nothing");
        CHECK(k15 >= 35 && k15 <= 100, "an impact on tick 15: the step starts 20 ms after the capture point settles "
              "(tick %d)", k15);
    }
    {
        /* step_trigger_time: a robot standing still (no rule would fire) steps on the first tick at or
         * after the set time, an impact 5 ticks before notwithstanding; not within the estimate's
         * first 20 ticks */
        const int k = first_step_tick_at(0.4, 0.0, 0.0, 1.0, 0, 0.0, 0.1, NULL);
        CHECK(k == 100 || k == 101, "step_trigger_time 0.1 s: a step on tick 100 (tick %d)", k);
        CHECK(first_step_tick_at(0.4, 0.0, 0.0, 1.0, 95, 0.0, 0.1, NULL) == k, "... after an impact on tick 95 too");
        CHECK(first_step_tick_at(0.4, 0.0, 0.0, 1.0, 0, 0.0, 0.015, NULL) < 0, "step_trigger_time 15 ms: no step");
    }
}

/* Starts c standing still under an external moment M with parameters st: legs straight, trunk
 * upright, feet flat, the measured ZMP where the balance of a standing robot under M puts it,
 * p f_z = m g c_x + M (M = 0: the static balance; the ankles' mid-point is the frame's origin). Runs
 * the first tick and leaves in *s the sensors for the next ones. */
static void stand_under_moment(ahc_stepper *c, const ahc_step_params *st, double M, ahc_step_sensors *s)
{
    ahc_params sp;
    ahc_frontal_params fp;
    ahc_step_params unused;
    ahc_step_outputs out;
    const double flat[2][AHC_LEG_JOINTS] = {{0}};
    double mg;
    defaults(&sp, &fp, &unused);
    CHECK(ahc_step_init(c, st, &sp, &fp) == AHC_OK, "init");
    mg = (sp.m1 + sp.m2 + sp.feet_mass) * sp.g;
    memset(s, 0, sizeof *s);
    s->fz_left = s->fz_right = 0.5 * mg;
    ahc_step_step(c, s, flat, &out);
    s->zmp_x = (mg * out.com[0] + M) / mg;
}

/* The stepping defaults with the capture-point rule at trigger_x, the lean rule off, the observer at
 * `gain` and step_push_estimate `estimate`. */
static void moment_params(ahc_step_params *st, double trigger_x, double gain, int estimate)
{
    ahc_params sp;
    ahc_frontal_params fp;
    defaults(&sp, &fp, st);
    st->step_trigger_x = trigger_x;
    st->step_trigger_lean = 0.0;
    st->step_observer_gain = gain;
    st->step_push_estimate = estimate;
}

/* A robot standing still under an external moment M (stand_under_moment) for `ticks` ticks or to the
 * first step, with moment_params; returns the tick the first step started (-1: none) and the last
 * estimate in *moment. */
static int standing_under_moment(double M, double gain, int ticks, double trigger_x, int estimate, double *moment)
{
    ahc_step_params st;
    static ahc_stepper c;
    ahc_step_sensors s;
    ahc_step_outputs out;
    const double flat[2][AHC_LEG_JOINTS] = {{0}};
    int k;
    moment_params(&st, trigger_x, gain, estimate);
    stand_under_moment(&c, &st, M, &s);
    for (k = 2; k <= ticks + 1; ++k) {
        ahc_step_step(&c, &s, flat, &out);
        *moment = out.push_moment;
        if (out.phase != AHC_STEP_STAND) return k;
    }
    return -1;
}

/* The momentum observer (push_moment): the estimate follows M as a first-order lag of bandwidth
 * step_observer_gain (no rule fires: the layer only estimates). */
static double observed_moment(double M, double gain, int ticks)
{
    double moment = NAN;
    CHECK(standing_under_moment(M, gain, ticks, 1.0, 0, &moment) < 0, "no step");
    return moment;
}

/* The observer's first estimate comes on tick 6 of standing_under_moment, once five ticks of H fill
 * its median (no start on the raw H of an impact's ticks), 4 ticks after its first H. */
#define OBSERVER_START 4

static void test_push_observer(void)
{
    const double M = 2.0, K = 50.0;
    /* 1 / K after the observer starts: on the 6th tick, once five ticks of H fill its median */
    const double lag = observed_moment(M, K, OBSERVER_START + 20);
    CHECK(fabs(observed_moment(0.0, K, 300)) < 1e-9, "at rest in static balance: no moment (%g N m)",
          observed_moment(0.0, K, 300));
    CHECK(fabs(observed_moment(M, K, 300) - M) < 1e-4 * M, "a standing robot under %g N m: the estimate %g N m", M,
          observed_moment(M, K, 300));
    CHECK(lag > 0.55 * M && lag < 0.7 * M, "after 1/K the estimate is about 1 - 1/e of the moment (%g of %g)", lag, M);
    CHECK(observed_moment(M, 2.0 * K, OBSERVER_START + 10) > 0.55 * M &&
              observed_moment(M, 2.0 * K, OBSERVER_START + 10) < 0.7 * M,
          "twice the gain: the same fraction in half the time");
}

/* step_push_estimate 2 decides on the pushed pendulum's capture point xi + u: a robot standing still
 * under a moment whose u = M / (m g) lies beyond the toe steps once the estimate gets there
 * (u reaches the toe when 1 - e^(-K t) = toe m g / M); with 1 (and 0) the decision reads xi, which
 * stays at rest, and no step starts; nor with 2 under a moment whose u stays inside the sole. (The
 * 1 s pushes of docs/controller.md §12.5 run this rule on the plant.) */
static void test_push_decision(void)
{
    const double K = 20.0, /* the toe reached after the layer's first 20 ticks, when it may step */ mg = (HOAP2_TOTAL_MASS) * HOAP2_G, M = 2.0 * HOAP2_TOE_X * mg;
    const int expected = OBSERVER_START + 2 + (int)ceil(-log(1.0 - 0.5) / K / HOAP2_SAMPLE_PERIOD);
    double moment;
    const int k2 = standing_under_moment(M, K, 300, 0.0, 2, &moment);
    CHECK(k2 >= expected - 2 && k2 <= expected + 2, "u = twice the toe, step_push_estimate 2: a step on tick %d "
          "(the estimate reaches the toe on tick %d), the estimate %g N m", k2, expected, moment);
    CHECK(standing_under_moment(M, K, 300, 0.0, 1, &moment) < 0, "... 1: no step");
    CHECK(standing_under_moment(M, K, 300, 0.0, 0, &moment) < 0, "... 0: no step");
    CHECK(standing_under_moment(0.8 * HOAP2_TOE_X * mg, K, 300, 0.0, 2, &moment) < 0,
          "u = 0.8 toe, step_push_estimate 2: no step");
}

/* step_push_estimate 1 plans the step with the estimate at its decision: two robots standing under
 * the same moment step at the same set time; afterwards one's measured ZMP moves by 10 mm (the
 * observer's estimate then differs by m g 10 mm), and their references stay bit-identical to the
 * step's end. (A plan that followed the estimate turned its swings at lift-off and
 * touch-down into the pendulum's, and a step from rest with no push fell: docs/controller.md §12.5.) */
static void test_push_planned_at_decision(void)
{
    ahc_step_params st;
    static ahc_stepper c[2];
    ahc_step_sensors s[2];
    ahc_step_outputs out[2];
    const double flat[2][AHC_LEG_JOINTS] = {{0}};
    const double mg = HOAP2_TOTAL_MASS * HOAP2_G, M = 0.5 * HOAP2_TOE_X * mg;
    int k, r, side, j, stepping = 0, identical = 1;
    moment_params(&st, 1.0, 50.0, 1); /* no rule fires: the step starts at the set time */
    st.step_trigger_time = 0.1;
    for (r = 0; r < 2; ++r) stand_under_moment(&c[r], &st, M, &s[r]);
    for (k = 2; k < 3000; ++k) {
        for (r = 0; r < 2; ++r) ahc_step_step(&c[r], &s[r], flat, &out[r]);
        if (out[0].phase == AHC_STEP_STAND && stepping) break;
        if (out[0].phase == AHC_STEP_STAND) continue;
        if (!stepping) s[1].zmp_x += 0.01; /* from the tick after the decision */
        stepping = 1;
        for (side = 0; side < 2; ++side)
            for (j = 0; j < AHC_LEG_JOINTS; ++j)
                identical = identical && memcmp(&out[0].q_ref[side][j], &out[1].q_ref[side][j], sizeof(double)) == 0;
        identical = identical && out[0].phase == out[1].phase &&
                    memcmp(out[0].com_ref, out[1].com_ref, sizeof out[0].com_ref) == 0;
    }
    CHECK(stepping && k < 3000, "the step started at the set time and ended");
    CHECK(fabs(out[1].push_moment - out[0].push_moment - 0.01 * mg) < 0.05 * 0.01 * mg,
          "the estimates differ by m g 10 mm (%g N m, expected %g)", out[1].push_moment - out[0].push_moment, 0.01 * mg);
    CHECK(identical, "the step's references are the same whatever the estimate does after the decision");
}

/* On one foot and through the landed foot's transfer the estimate holds (the observer's model has
 * no soles' impacts, docs/controller.md §12.5): a robot standing under a moment steps at a set time;
 * while it swings and transfers its measured ZMP jumps by 30 mm either way every tick, as at an
 * impact, and push_moment stays bit-identical to its value at lift-off. With both feet down again
 * the observer restarts from the held value (its first estimate is the held one) and is back at the
 * moment by the step's end. */
static void test_push_held_on_one_foot(void)
{
    ahc_step_params st;
    static ahc_stepper c;
    ahc_step_sensors s;
    ahc_step_outputs out;
    const double flat[2][AHC_LEG_JOINTS] = {{0}};
    const double mg = HOAP2_TOTAL_MASS * HOAP2_G, M = 0.5 * HOAP2_TOE_X * mg;
    double zmp, held = NAN, prev = NAN, first_after = NAN;
    int k, held_ticks = 0, holds_still = 1;
    moment_params(&st, 1.0, 50.0, 0);
    st.step_trigger_time = 0.1;
    stand_under_moment(&c, &st, M, &s);
    zmp = s.zmp_x;
    for (k = 2; k < 3000; ++k) {
        const int holds = c.phase == AHC_STEP_SWING || c.phase == AHC_STEP_TRANSFER; /* the phase this tick runs in */
        s.zmp_x = holds ? zmp + (k % 2 ? 0.03 : -0.03) : zmp;
        ahc_step_step(&c, &s, flat, &out);
        if (holds) {
            if (isnan(held)) held = prev;
            holds_still = holds_still && out.push_moment == held;
            ++held_ticks;
        } else if (!isnan(held) && isnan(first_after)) {
            first_after = out.push_moment;
        }
        prev = out.push_moment;
        if (out.phase == AHC_STEP_STAND && !isnan(first_after)) break;
    }
    CHECK(held_ticks > 100 && holds_still, "through SWING and TRANSFER (%d ticks) the estimate holds at %g N m",
          held_ticks, held);
    CHECK(first_after == held, "both feet down, the observer restarts from the held estimate (%g, held %g N m)",
          first_after, held);
    CHECK(k < 3000 && fabs(prev - M) < 0.02 * M,
          "at the step's end the estimate is back at the moment (%g N m, applied %g)", prev, M);
}

/* The trunk's and the stance sole's feedback (step_trunk_gain, step_stance_tilt_gain) and the trunk
 * plan's lean back (step_trunk_back), docs/controller.md §12.5: robots in lockstep on the same
 * readings (standing still, pitched forward by 0.02 rad on flat joints, both soles loaded), stepping at
 * a set time. Once a switch's blend is out, the trunk gain moves only the supporting legs' hip pitch
 * set points, by -gain (measured pitch - the plan's); the tilt gain only the stance ankle's on one
 * foot, by gain times the stance sole's pitch (here the IMU's: the joints are flat); everything else
 * is bit-identical. The lean back: the plan's pitch is erect - step_trunk_back step_pitch_time after
 * the decision, and erect again step_pitch_time after the landing. */
static void test_trunk_and_tilt_feedback(void)
{
    enum { PLAIN, TRUNK, TILT, BACK, ROBOTS };
    ahc_step_params st[ROBOTS];
    static ahc_stepper c[ROBOTS];
    ahc_step_sensors s;
    ahc_step_outputs out[ROBOTS];
    const double flat[2][AHC_LEG_JOINTS] = {{0}};
    const double theta = 0.02;
    double worst_trunk = 0.0, worst_tilt = 0.0, back_at_swing = NAN, back_after = NAN, t_land = -1.0;
    int k, r, side, j, others_same = 1, compared = 0, tilted_ticks = 0, landed_phase_seen = 0;
    for (r = 0; r < ROBOTS; ++r) {
        moment_params(&st[r], 1.0, 50.0, 0); /* no rule fires: the step starts at the set time */
        st[r].step_trigger_time = 0.1;
    }
    st[TRUNK].step_trunk_gain = 2.0;
    st[TILT].step_stance_tilt_gain = 3.0;
    st[BACK].step_trunk_back = 0.3;
    st[BACK].step_pitch_time = 0.08; /* (the step in place lands 0.1 s into its swing) */
    for (r = 0; r < ROBOTS; ++r) stand_under_moment(&c[r], &st[r], 0.0, &s);
    s.imu_pitch = theta;
    s.zmp_x = 0.0;
    for (k = 2; k < 4000; ++k) {
        double plan_pitch;
        for (r = 0; r < ROBOTS; ++r) ahc_step_step(&c[r], &s, flat, &out[r]);
        if (out[PLAIN].phase == AHC_STEP_STAND && c[PLAIN].steps > 0) break;
        if (!out[PLAIN].active) continue;
        /* the pitch the plan used this tick (its clock has moved on by a tick) */
        ahc_quintic_eval(&c[PLAIN].pitch_plan, c[PLAIN].pitch_time - c[PLAIN].dt, &plan_pitch, NULL, NULL);
        if (t_land < 0.0 && out[BACK].phase != AHC_STEP_TRANSFER && c[BACK].pitch_time - c[BACK].dt >= st[BACK].step_pitch_time &&
            isnan(back_at_swing))
            ahc_quintic_eval(&c[BACK].pitch_plan, c[BACK].pitch_time - c[BACK].dt, &back_at_swing, NULL, NULL);
        if (out[BACK].phase == AHC_STEP_TRANSFER && t_land < 0.0) t_land = k * c[BACK].dt;
        if (t_land >= 0.0 && k * c[BACK].dt >= t_land + st[BACK].step_pitch_time && isnan(back_after)) {
            ahc_quintic_eval(&c[BACK].pitch_plan, c[BACK].pitch_time - c[BACK].dt, &back_after, NULL, NULL);
            landed_phase_seen = out[BACK].phase;
        }
        if (c[PLAIN].blend_time < st[PLAIN].step_blend_time + c[PLAIN].dt || c[TRUNK].blend_time < st[TRUNK].step_blend_time + c[TRUNK].dt ||
            c[TILT].blend_time < st[TILT].step_blend_time + c[TILT].dt || out[TRUNK].phase != out[PLAIN].phase ||
            out[TILT].phase != out[PLAIN].phase)
            continue;
        ++compared;
        for (side = 0; side < 2; ++side) {
            const int one_foot = out[PLAIN].phase == AHC_STEP_SWING || out[PLAIN].phase == AHC_STEP_CLOSE;
            const int supporting = !(one_foot && side == out[PLAIN].swing_side);
            for (j = 0; j < AHC_LEG_JOINTS; ++j) {
                const double d_trunk = out[TRUNK].q_ref[side][j] - out[PLAIN].q_ref[side][j];
                const double d_tilt = out[TILT].q_ref[side][j] - out[PLAIN].q_ref[side][j];
                if (j == AHC_LEG_HIP_PITCH && supporting)
                    worst_trunk = fmax(worst_trunk, fabs(d_trunk + 2.0 * (theta - plan_pitch)));
                else
                    others_same = others_same && d_trunk == 0.0;
                if (j == AHC_LEG_ANKLE_PITCH && one_foot && supporting) {
                    worst_tilt = fmax(worst_tilt, fabs(d_tilt - 3.0 * theta));
                    ++tilted_ticks;
                } else {
                    others_same = others_same && d_tilt == 0.0;
                }
            }
        }
    }
    CHECK(k < 4000 && compared > 500 && tilted_ticks > 40, "the steps ran to the end (%d ticks compared, %d on one foot)",
          compared, tilted_ticks);
    CHECK(worst_trunk < 1e-12, "the trunk gain moves the supporting hips by -2 (pitch - plan) (worst %.2e rad)", worst_trunk);
    CHECK(worst_tilt < 1e-9, "the tilt gain moves the stance ankle by 3 x the sole's pitch (worst %.2e rad)", worst_tilt);
    CHECK(others_same, "every other set point is bit-identical to the plain layer's");
    CHECK(fabs(back_at_swing - (c[BACK].pitch_erect - 0.3)) < 1e-12,
          "the lean back: the plan's pitch is erect - 0.3 rad step_pitch_time after the decision (%.6f, erect %.6f)",
          back_at_swing, c[BACK].pitch_erect);
    CHECK(t_land > 0.0 && fabs(back_after - c[BACK].pitch_erect) < 1e-12,
          "and erect step_pitch_time after the landing (%.6f, phase %d)", back_after, landed_phase_seen);
}

/* The feet-apart options of docs/controller.md §12.6. step_feet_tilt_gain: robots in lockstep on the
 * same readings (standing still, pitched forward by 0.02 rad on flat joints: each sole pitched by it),
 * stepping at a set time; once a switch's blend is out, the gain moves only the ankles' pitch set
 * points on both feet (SHIFT, TRANSFER, SETTLE), each by gain times its sole's pitch, and on one foot
 * nothing. step_settle_on_axis: the same robots in SETTLE, their feet then put one ahead of the other
 * (the left 180 mm ahead) and the step's push estimate set, so that the CoM reference rests behind
 * the feet's mid-point; after 3 s the plain layer's reference rests across at the mid-point, the
 * axis layer's on the line between the ankles at its x, both at the same x. */
static void test_feet_apart_options(void)
{
    enum { PLAIN, FEET, AXIS, ROBOTS };
    ahc_step_params st[ROBOTS];
    static ahc_stepper c[ROBOTS];
    ahc_step_sensors s;
    ahc_step_outputs out[ROBOTS];
    const double flat[2][AHC_LEG_JOINTS] = {{0}};
    const double theta = 0.02, gain = 1.5, M = 4.0;
    double worst = 0.0, u, axis_y;
    int k, r, side, j, others_same = 1, compared = 0, on_two = 0, on_one = 0;
    for (r = 0; r < ROBOTS; ++r) {
        moment_params(&st[r], 1.0, 50.0, 2); /* no rule fires: the step starts at the set time */
        st[r].step_trigger_time = 0.1;
        st[r].step_close = 0;
    }
    st[FEET].step_feet_tilt_gain = gain;
    st[AXIS].step_settle_on_axis = 1;
    for (r = 0; r < ROBOTS; ++r) stand_under_moment(&c[r], &st[r], 0.0, &s);
    s.imu_pitch = theta;
    s.zmp_x = 0.0;
    for (k = 2; k < 3000; ++k) {
        for (r = 0; r < ROBOTS; ++r) ahc_step_step(&c[r], &s, flat, &out[r]);
        if (out[PLAIN].phase == AHC_STEP_SETTLE && c[PLAIN].phase_time > 0.5) break;
        if (!out[PLAIN].active || c[PLAIN].blend_time < st[PLAIN].step_blend_time + c[PLAIN].dt ||
            c[FEET].blend_time < st[FEET].step_blend_time + c[FEET].dt || out[FEET].phase != out[PLAIN].phase)
            continue;
        ++compared;
        {
            const int one_foot = out[PLAIN].phase == AHC_STEP_SWING || out[PLAIN].phase == AHC_STEP_CLOSE;
            on_one += one_foot;
            on_two += !one_foot;
            for (side = 0; side < 2; ++side)
                for (j = 0; j < AHC_LEG_JOINTS; ++j) {
                    const double d = out[FEET].q_ref[side][j] - out[PLAIN].q_ref[side][j];
                    if (j == AHC_LEG_ANKLE_PITCH && !one_foot) worst = fmax(worst, fabs(d - gain * theta));
                    else others_same = others_same && d == 0.0;
                }
        }
    }
    CHECK(k < 3000 && on_two > 300 && on_one > 40, "the step ran into SETTLE (%d ticks on both feet, %d on one)", on_two,
          on_one);
    CHECK(worst < 1e-9, "on both feet the ankles' pitch moves by 1.5 x the sole's pitch (worst %.2e rad)", worst);
    CHECK(others_same, "every other set point, and all on one foot, bit-identical to the plain layer's");
    /* the settling on the feet one ahead of the other, under the step's push estimate */
    for (r = 0; r < ROBOTS; ++r) {
        c[r].feet[AHC_LEFT][0] += 0.18;
        for (j = 0; j < 2; ++j) c[r].settle_mid[j] = 0.5 * (c[r].feet[AHC_LEFT][j] + c[r].feet[AHC_RIGHT][j]);
        c[r].push_planned = M;
    }
    for (k = 0; k < 3000; ++k)
        for (r = 0; r < ROBOTS; ++r) ahc_step_step(&c[r], &s, flat, &out[r]);
    u = M / (c[PLAIN].mass * c[PLAIN].g);
    axis_y = c[AXIS].feet[AHC_RIGHT][1] + (c[AXIS].cref[0] - c[AXIS].feet[AHC_RIGHT][0]) /
                                             (c[AXIS].feet[AHC_LEFT][0] - c[AXIS].feet[AHC_RIGHT][0]) *
                                             (c[AXIS].feet[AHC_LEFT][1] - c[AXIS].feet[AHC_RIGHT][1]);
    CHECK(out[PLAIN].phase == AHC_STEP_SETTLE && out[AXIS].phase == AHC_STEP_SETTLE, "both still settle (%d, %d)",
          out[PLAIN].phase, out[AXIS].phase);
    CHECK(fabs(c[PLAIN].cref[0] - (c[PLAIN].settle_mid[0] - u)) < 1e-4 && fabs(c[AXIS].cref[0] - c[PLAIN].cref[0]) < 1e-4,
          "both CoM references rest u = %.1f mm behind the mid-point (%.4f, %.4f; mid %.4f)", 1e3 * u, c[PLAIN].cref[0],
          c[AXIS].cref[0], c[PLAIN].settle_mid[0]);
    CHECK(fabs(c[PLAIN].cref[1] - c[PLAIN].settle_mid[1]) < 1e-4, "the plain one across at the mid-point (%.4f, mid %.4f)",
          c[PLAIN].cref[1], c[PLAIN].settle_mid[1]);
    CHECK(fabs(c[AXIS].cref[1] - axis_y) < 1e-4 && fabs(axis_y - c[AXIS].settle_mid[1]) > 0.01,
          "the axis one on the line between the ankles at its x (%.4f, the line %.4f, mid %.4f)", c[AXIS].cref[1], axis_y,
          c[AXIS].settle_mid[1]);
}

int main(void)
{
    test_faults_while_stepping();
    test_feet_apart_options();
    test_named_step_configs();
    test_push_observer();
    test_push_decision();
    test_push_planned_at_decision();
    test_push_held_on_one_foot();
    test_triggers();
    test_close_rest();
    test_close_inset();
    test_nonfinite_inputs();
    test_params();
    test_off_is_flat_footed();
    test_foot_choice();
    test_state_validate();
    test_kinematic_step();
    test_swing_rate_max();
    test_swing_measured();
    test_swing_hold();
    test_trunk_and_tilt_feedback();
    TEST_MAIN_END();
}
