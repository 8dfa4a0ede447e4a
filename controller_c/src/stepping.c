/*
 * stepping.c — the recovery step (stepping.h, docs/controller.md §12).
 */
#include <math.h>
#include <string.h>

#include "ahc/stepping.h"
#include "hoap2/nominal.h"
#include "param_rows.h"


/* ---- parameters ---------------------------------------------------------------------------- */

void ahc_step_params_default(ahc_step_params *p)
{
    memset(p, 0, sizeof *p);
    p->stepping_enabled = 0;
    p->step_trigger_x = 0.0;
    p->step_trigger_y = 0.1; /* a side step cannot gain on this robot (docs/capability.md §9.1) */
    p->step_swing_time = 0.2;
    p->step_height = 0.025;
    p->step_length_max = 0.12;
    p->step_width_max = 0.16;
    p->step_pelvis_drop = 0.01;
    p->step_drop_time = 0.25;
    p->step_shift_time_max = 0.1;
    p->step_pitch_time = 0.17;
    p->step_hip_hike = 0.1;
    p->step_lead_max = 0.1;
    p->step_touchdown_after = 0.5;
    p->step_pelvis_rate = 0.1;
    p->step_touchdown_tol = 0.03;
    p->step_lead_tau = 0.03;
    p->step_dcm_gain = 0.0;
    p->step_shift_inset = 0.035;
    p->step_dcm_feedback = 0;
    p->step_zmp_margin = 0.01;
    p->step_touchdown_fz = 0.2 * HOAP2_TOTAL_MASS * HOAP2_G;
    p->step_transfer_time_min = 0.05;
    p->step_settle_time = 0.5;
    p->step_blend_time = 0.05;
    p->step_velocity_tau = 0.01;
    p->step_servo_lead = 0.05;      /* Hoap2Plant3D's ankle, knee, roll and yaw servos: kd/kp = 20/400 */
    p->step_servo_lead_hip = 5.0 / 150.0; /* its hip pitch servo: 5/150                           */
    p->step_close = 1;
    p->step_close_shift_time = 0.4;
    p->step_close_swing_time = 0.4;
    p->step_trigger_lean = 0.35;
    p->step_impact_hold = 0.02;
    p->step_close_rest = 0.005;
    p->step_close_rest_tilt = 0.02;
    p->step_close_wait = 1.0;
    p->step_close_inset = 0.01;
    p->step_trigger_time = 0.0;
    p->step_push_estimate = 0;
    p->step_observer_gain = 50.0;
    p->step_swing_rate_max = 0.0;
    p->step_swing_measured = 0.0;
    p->step_swing_hold = 0.0;
    p->step_trunk_back = 0.0;
    p->step_trunk_gain = 0.0;
    p->step_stance_tilt_gain = 0.0;
    p->step_feet_tilt_gain = 0.0;
    p->step_settle_on_axis = 0;
}

/* 1 s back pushes above the sustained-push limit, held with one step (docs/controller.md §12.6,
 * each setting measured one at a time by scripts/stepping_trials.py --lasting --ablation): the
 * decision on the pushed pendulum's capture point alone and the step under the push as estimated
 * (§12.1, §12.4-12.5), steps up to 200 mm with the hips leading, a quick step, and the robot left at
 * rest on the feet apart. */
static void step_params_lasting_push(ahc_step_params *p)
{
    ahc_step_params_default(p);
    p->stepping_enabled = 1;
    p->step_push_estimate = 2;
    p->step_trigger_lean = 0.0;
    p->step_length_max = 0.2;
    p->step_swing_measured = 1.0;
    p->step_swing_hold = 0.04;
    p->step_trunk_back = 0.5;
    p->step_trunk_gain = 3.0;
    p->step_stance_tilt_gain = 3.0;
    p->step_shift_time_max = 0.0;
    p->step_swing_time = 0.15;
    p->step_feet_tilt_gain = 1.0;
    p->step_settle_on_axis = 1;
    p->step_settle_time = 1.0;
    p->step_close = 0;
}

static const struct {
    const char *name;
    const char *description;
    void (*fill)(ahc_step_params *);
} k_step_configs[] = {
    {"lasting_push", "1 s back pushes above the sustained-push limit (19.1 N) on the 3D robot, held with one step: "
                     "the stepping layer on, the push-aware decision and step up to 200 mm with the hips leading, a "
                     "quick step, the robot left at rest on the feet apart; on short pushes it falls, so not the "
                     "default (docs/controller.md section 12.6)",
     step_params_lasting_push},
};
#define N_STEP_CONFIGS (sizeof k_step_configs / sizeof k_step_configs[0])

size_t ahc_step_config_count(void) { return N_STEP_CONFIGS; }

const char *ahc_step_config_name(size_t i) { return i < N_STEP_CONFIGS ? k_step_configs[i].name : NULL; }

const char *ahc_step_config_description(size_t i) { return i < N_STEP_CONFIGS ? k_step_configs[i].description : NULL; }

int ahc_step_params_named(ahc_step_params *p, const char *name)
{
    size_t i;
    if (!p) return AHC_ERR_NULL;
    for (i = 0; name && i < N_STEP_CONFIGS; ++i)
        if (strcmp(name, k_step_configs[i].name) == 0) {
            k_step_configs[i].fill(p);
            return AHC_OK;
        }
    ahc_step_params_default(p);
    return AHC_ERR_UNKNOWN_NAME;
}

#define SD(field, unit, lo, hi, desc) \
    { #field, unit, desc, lo, hi, offsetof(ahc_step_params, field), 0 }
#define SI(field, lo, hi, desc) \
    { #field, "", desc, lo, hi, offsetof(ahc_step_params, field), 1 }

/* Append new rows at the end only (value references). */
static const ahc_param_info k_stable[] = {
    SI(stepping_enabled, 0.0, 1.0, "Stepping: 1 a recovery step when the capture point leaves the feet; 0 never"),
    SD(step_trigger_x, "m", -0.05, 1.0, "Step when the capture point lies beyond the toe or heel edge by more than this (< 0: inside the sole)"),
    SD(step_trigger_y, "m", 0.0, 1.0, "Step when the capture point lies beyond the outer sole edges by more than this"),
    SD(step_swing_time, "s", 0.05, 2.0, "Planned duration of the swing"),
    SD(step_height, "m", 0.0, 0.1, "Scale of the swing foot's lift: its planned lift peaks at mid-swing at 0.452 times this"),
    SD(step_length_max, "m", 0.0, 0.3, "Landing ankle at most this far forward or back of the stance ankle"),
    SD(step_width_max, "m", 0.0, 0.4, "Landing ankle at most this far sideways from the stance ankle"),
    SD(step_pelvis_drop, "m", 0.0, 0.1, "The hips lower by this while stepping (the legs' reach)"),
    SD(step_zmp_margin, "m", 0.0, 0.1, "Planned ZMPs stay this far inside the sole edges"),
    SD(step_touchdown_fz, "N", 0.0, 1e4, "The swing sole has landed when it carries this"),
    SD(step_transfer_time_min, "s", 0.0, 2.0, "Both feet down after a landing for at least this"),
    SD(step_settle_time, "s", 0.05, 5.0, "Duration of the settling to rest over the feet after the steps"),
    SD(step_blend_time, "s", 0.001, 1.0, "Quintic blend of the joint references at the start and end of a step"),
    SD(step_velocity_tau, "s", 0.0, 1.0, "Low-pass time constant of the CoM rate estimate"),
    SD(step_servo_lead, "s", 0.0, 1.0, "Servo lead kd/kp of every joint but the hip pitch: the reference leads by this times its rate"),
    SD(step_servo_lead_hip, "s", 0.0, 1.0, "Servo lead kd/kp of the hip pitch"),
    SI(step_close, 0.0, 1.0, "1: a second step brings the feet back together"),
    SD(step_drop_time, "s", 0.01, 2.0, "The hips lower by step_pelvis_drop over this time from the decision (a quintic)"),
    SD(step_shift_time_max, "s", 0.0, 1.0, "The weight shift before the swing lasts at most this (0: the foot lifts at once)"),
    SD(step_hip_hike, "rad", 0.0, 0.5, "The pelvis rolls the swing hip up by this at mid-swing"),
    SD(step_lead_max, "rad", 0.0, 1.0, "The servo lead adds at most this to a joint reference"),
    SD(step_touchdown_after, "1", 0.0, 1.0, "A load on the swing sole counts as the landing after this fraction of the swing"),
    SD(step_pelvis_rate, "m/s", 0.001, 10.0, "The hips' planned height rises at most this fast (it lowers at once)"),
    SD(step_touchdown_tol, "m", 0.0, 1.0, "A loaded swing sole counts as landed only this close to its landing point"),
    SD(step_lead_tau, "s", 0.0, 1.0, "Low-pass time constant of the reference rate the servo lead multiplies"),
    SD(step_shift_inset, "m", 0.0, 0.05, "The weight shift moves the capture point to this far inside of the stance ankle (toward the other foot)"),
    SI(step_dcm_feedback, 0.0, 1.0, "1: the pendulum reference's ZMP tracks the measured capture point (Englsberger et al. 2015); 0: the open-loop pendulum"),
    SD(step_dcm_gain, "1/s", 0.0, 100.0, "Capture-point feedback gain: the planned ZMP moves by (1 + gain / omega) times the capture point's error"),
    SD(step_pitch_time, "s", 0.05, 5.0, "The trunk's pitch returns to erect over this (a quintic from the measured pitch and rate at the decision and at the landing)"),
    SD(step_close_shift_time, "s", 0.05, 2.0, "The closing step (at rest after the recovery step): the weight shift onto the landed foot takes this"),
    SD(step_close_swing_time, "s", 0.05, 2.0, "The closing step's swing takes this"),
    SD(step_trigger_lean, "rad", 0.0, 1.5, "Step also when the trunk leans this far from erect toward the toe or heel edge the measured ZMP is within step_zmp_margin of (the hip strategy at its limit), the capture point between the soles' inner edges; 0: off"),
    SD(step_impact_hold, "s", 0.0, 1.0, "No step starts for this long after the capture point jumped faster than twice what the pendulum allows (an impact)"),
    SD(step_close_rest, "m", 0.0, 0.1, "The closing step waits for rest: the capture point within this of the CoM, both soles carrying step_touchdown_fz and flat within step_close_rest_tilt; 0: it starts after SETTLE's planned time"),
    SD(step_close_rest_tilt, "rad", 0.001, 0.5, "The closing step's rest: each sole flat within this"),
    SD(step_close_wait, "s", 0.0, 10.0, "The closing step waits for rest at most this long after SETTLE's planned time"),
    SD(step_close_inset, "m", 0.0, 0.05, "The closing step's weight shift moves the capture point this far inside of the landed ankle (toward the other foot)"),
    SD(step_trigger_time, "s", 0.0, 1e6, "A step starts at the first tick at or after this time (ticks x sample_period from the start) whatever the decision rules, if the robot stands then: experiments on the decision's timing; 0: off"),
    SI(step_push_estimate, 0.0, 2.0, "The estimated external pitching moment (push_moment) in the step: 1 in its plan (the weight shift, the landing point, the CoM reference); 2 in the decision too (the capture point beyond the feet is xi + u, u = push_moment / (m g)); 0 nowhere"),
    SD(step_observer_gain, "1/s", 1.0, 500.0, "The momentum observer's gain: push_moment follows the external moment as a first-order lag of this bandwidth"),
    SD(step_swing_rate_max, "rad/s", 0.0, 1e3, "The swing leg's joint set points move at most this fast while it swings (a tick's change at most this x sample_period); 0: no limit"),
    SD(step_swing_measured, "1", 0.0, 1.0, "The swing leg's set points put its foot where the plan sends it from the pelvis as measured (the stance leg's joints and the IMU) by this weight, from the plan's pelvis by 1 minus it: 1 corrects the swing for the trunk's deviation from the plan"),
    SD(step_swing_hold, "m", 0.0, 1.0, "Past mid-swing the swing foot comes down only as its measured ankle nears the landing point: its planned height stays at least its peak times a quintic of the distance left over this; 0: it comes down on time"),
    SD(step_trunk_back, "rad", 0.0, 1.0, "The step's trunk pitch plan aims this far back of erect, reached over step_pitch_time from the decision, back to erect over step_pitch_time from the landing: the hips lead the CoM; 0: the trunk returns to erect from the decision"),
    SD(step_trunk_gain, "1", 0.0, 20.0, "The supporting legs' hip pitch set points move by this times the trunk's measured pitch less the plan's, against it: trunk attitude feedback through the hips; 0: off"),
    SD(step_stance_tilt_gain, "1", 0.0, 20.0, "On one foot the stance ankle's pitch set point moves by this times the stance sole's measured pitch (toes down +): the ankle yields as the sole rolls onto its toe or heel; 0: off"),
    SD(step_feet_tilt_gain, "1", 0.0, 20.0, "On both feet (the weight shift, the landed foot's transfer, the settling) each ankle's pitch set point moves by this times its sole's measured pitch (toes down +): the ankles yield as the soles roll onto an edge; 0: off"),
    SI(step_settle_on_axis, 0.0, 1.0, "1: the settling holds the capture point, across, on the line between the ankles at the CoM reference's x (the feet one ahead of the other: the middle of their support there); 0: at the feet's mid-point"),
};
#define STABLE_LEN (sizeof k_stable / sizeof k_stable[0])

const ahc_param_info *ahc_step_param_table(size_t *count)
{
    if (count) *count = STABLE_LEN;
    return k_stable;
}

const ahc_param_info *ahc_step_param_find(const char *name) { return ahc_rows_find(k_stable, STABLE_LEN, name); }

const char *ahc_step_phase_name(int phase)
{
    static const char *const names[AHC_STEP_PHASES] = {"stand", "shift", "swing", "transfer", "close", "settle"};
    return phase >= 0 && phase < AHC_STEP_PHASES ? names[phase] : "?";
}

int ahc_step_params_validate(const ahc_step_params *p, const ahc_params *sp, const ahc_frontal_params *fp, char *msg,
                             size_t msg_size)
{
    int rc;
    if (msg && msg_size > 0) msg[0] = '\0';
    if (!p || !sp || !fp) return ahc_fail_message(msg, msg_size, AHC_ERR_NULL, "params pointer is NULL");
    rc = ahc_frontal_params_validate(fp, sp, msg, msg_size);
    if (rc != AHC_OK) return rc;
    rc = ahc_rows_check(k_stable, STABLE_LEN, p, msg, msg_size);
    if (rc != AHC_OK) return rc;
    if (!(2.0 * p->step_zmp_margin < fp->sole_width) || !(2.0 * p->step_zmp_margin < sp->toe_x - sp->heel_x))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "step_zmp_margin = %.6g leaves no room on a sole (%.6g x %.6g m)", p->step_zmp_margin,
                    sp->toe_x - sp->heel_x, fp->sole_width);
    if (!(p->step_width_max >= 2.0 * fp->ankle_y))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "step_width_max = %.6g must be >= the stance width 2 ankle_y = %.6g", p->step_width_max,
                    2.0 * fp->ankle_y);
    if (!(p->step_pelvis_drop + p->step_height < 0.5 * sp->l1))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "step_pelvis_drop + step_height = %.6g must be < l1 / 2 = %.6g",
                    p->step_pelvis_drop + p->step_height, 0.5 * sp->l1);
    return AHC_OK;
}

/* ---- small vector helpers -------------------------------------------------------------------- */

static void rot_trunk(double roll, double pitch, double R[9])
{
    /* R = Ry(pitch) Rx(roll): the IMU's Z-Y-X angles without the yaw */
    const double cp = cos(pitch), sp = sin(pitch), cr = cos(roll), sr = sin(roll);
    R[0] = cp; R[1] = sp * sr; R[2] = sp * cr;
    R[3] = 0;  R[4] = cr;      R[5] = -sr;
    R[6] = -sp; R[7] = cp * sr; R[8] = cp * cr;
}

static void mv(const double R[9], const double v[3], double o[3])
{
    int i;
    for (i = 0; i < 3; ++i) o[i] = R[3 * i] * v[0] + R[3 * i + 1] * v[1] + R[3 * i + 2] * v[2];
}

static void mtv(const double R[9], const double v[3], double o[3])
{
    int i;
    for (i = 0; i < 3; ++i) o[i] = R[i] * v[0] + R[3 + i] * v[1] + R[6 + i] * v[2];
}

static double clampd(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

static double hip_offset_y(const ahc_stepper *c, int side) { return side == AHC_LEFT ? c->hip_y : -c->hip_y; }

/* ---- the lumped model's CoM ----------------------------------------------------------------- */

/* The lumped model's bodies: link 2, each leg's link-1 part, each foot. */
enum { BODY_TRUNK = 0, BODY_LEG = 1, BODY_FOOT = 3, BODIES = 5 };

static double body_mass(const ahc_stepper *c, int b)
{
    return b == BODY_TRUNK ? c->m2 : b < BODY_FOOT ? 0.5 * c->m1 : 0.5 * c->feet_mass;
}

/* The bodies' CoMs for the pelvis centre P, trunk attitude R, both ankles (world) and feet at Rfw
 * (world); also each leg's hip. */
static void bodies_of(const ahc_stepper *c, const double P[3], const double R[9], double ankle[2][3],
                      double Rfw[2][9], double pts[BODIES][3], double hips[2][3])
{
    const double k1 = c->lg1 / c->l1;
    double v[3], w[3];
    int s, i;
    /* link 2: its CoM lg2 up the trunk, link2_com_x ahead */
    v[0] = c->link2_com_x; v[1] = 0.0; v[2] = c->lg2;
    mv(R, v, w);
    for (i = 0; i < 3; ++i) pts[BODY_TRUNK][i] = P[i] + w[i];
    for (s = 0; s < 2; ++s) {
        v[0] = 0.0; v[1] = hip_offset_y(c, s); v[2] = 0.0;
        mv(R, v, w);
        for (i = 0; i < 3; ++i) hips[s][i] = P[i] + w[i];
        /* each leg's link-1 part: lg1 up the ankle-hip line */
        for (i = 0; i < 3; ++i) pts[BODY_LEG + s][i] = ankle[s][i] + k1 * (hips[s][i] - ankle[s][i]);
        /* each foot */
        v[0] = c->feet_com_x; v[1] = 0.0; v[2] = c->feet_com_z - c->ankle_height;
        mv(Rfw[s], v, w);
        for (i = 0; i < 3; ++i) pts[BODY_FOOT + s][i] = ankle[s][i] + w[i];
    }
}

/* The CoM for the pelvis centre P, trunk attitude R, both ankles (world) and feet at Rfw (world). */
static void com_of(const ahc_stepper *c, const double P[3], const double R[9], double ankle[2][3],
                   double Rfw[2][9], double com[3])
{
    /* summed link 2, then each leg with its foot */
    static const int order[BODIES] = {BODY_TRUNK, BODY_LEG, BODY_FOOT, BODY_LEG + 1, BODY_FOOT + 1};
    double pts[BODIES][3], hips[2][3];
    int b, i;
    bodies_of(c, P, R, ankle, Rfw, pts, hips);
    for (i = 0; i < 3; ++i) {
        double sum = 0.0;
        for (b = 0; b < BODIES; ++b) sum += body_mass(c, order[b]) * pts[order[b]][i];
        com[i] = sum / c->mass;
    }
}

/* The measured configuration: both ankles and the pelvis relative to the anchor's ankle at `at`
 * (world), the feet's attitudes, from the joint angles and the trunk's attitude R. */
static void measured_configuration(const ahc_stepper *c, const double q[2][AHC_LEG_JOINTS], const double R[9],
                                   int anchor, const double at[3], double P[3], double ankle[2][3],
                                   double Rfw[2][9])
{
    double rel[2][3];
    int s, i;
    for (s = 0; s < 2; ++s) {
        double a[3], Rf[9], v[3];
        ahc_leg_fk_pose(&c->legs, q[s], a, Rf);
        a[1] += hip_offset_y(c, s); /* the ankle from the pelvis centre, trunk axes */
        mv(R, a, rel[s]);
        (void)v;
        /* the foot's attitude in the world: R Rf */
        {
            int r, k;
            for (r = 0; r < 3; ++r)
                for (k = 0; k < 3; ++k)
                    Rfw[s][3 * r + k] = R[3 * r] * Rf[k] + R[3 * r + 1] * Rf[3 + k] + R[3 * r + 2] * Rf[6 + k];
        }
    }
    for (i = 0; i < 3; ++i) P[i] = at[i] - rel[anchor][i];
    for (s = 0; s < 2; ++s)
        for (i = 0; i < 3; ++i) ankle[s][i] = P[i] + rel[s][i];
}

void ahc_step_com(const ahc_stepper *c, const double q[2][AHC_LEG_JOINTS], double roll, double pitch, int anchor,
                  double com[3], double pelvis[3])
{
    double R[9], ankle[2][3], Rfw[2][9];
    const double at[3] = {0, 0, 0};
    rot_trunk(roll, pitch, R);
    measured_configuration(c, q, R, anchor, at, pelvis, ankle, Rfw);
    com_of(c, pelvis, R, ankle, Rfw, com);
}

/* ---- init ------------------------------------------------------------------------------------ */

int ahc_step_init(ahc_stepper *c, const ahc_step_params *p, const ahc_params *sp, const ahc_frontal_params *fp)
{
    int rc;
    if (!c) return AHC_ERR_NULL;
    memset(c, 0, sizeof *c);
    rc = ahc_step_params_validate(p, sp, fp, NULL, 0);
    if (p) c->p = *p;
    if (rc != AHC_OK) return rc;
    c->g = sp->g;
    c->m1 = sp->m1;
    c->m2 = sp->m2;
    c->l1 = sp->l1;
    c->lg1 = sp->lg1;
    c->lg2 = sp->lg2;
    c->link2_com_x = sp->link2_com_x;
    c->I1 = sp->I1;
    c->I2 = sp->I2;
    c->feet_mass = sp->feet_mass;
    c->feet_com_x = sp->feet_com_x;
    c->feet_com_z = sp->feet_com_z;
    c->ankle_height = sp->ankle_height;
    c->mass = sp->m1 + sp->m2 + sp->feet_mass;
    c->toe_x = sp->toe_x;
    c->heel_x = sp->heel_x;
    c->sole_width = fp->sole_width;
    c->hip_y = fp->hip_y;
    c->ankle_y = fp->ankle_y;
    c->legs.thigh = fp->thigh;
    c->legs.shank = fp->shank;
    c->legs.hip_y = fp->hip_y;
    c->legs.ankle_y = fp->ankle_y;
    c->dt = sp->sample_period;
    /* the pendulum's height: the erect CoM above the ground */
    c->z_com = (sp->m1 * sp->lg1 + sp->m2 * (sp->l1 + sp->lg2)) / (sp->m1 + sp->m2) + sp->ankle_height;
    c->omega = sqrt(c->g / c->z_com);
    {
        double e1, e2;
        ahc_erect_posture(sp, &e1, &e2);
        c->pitch_erect = e1 + e2;
    }
    c->valid = 1;
    ahc_step_reset(c);
    return AHC_OK;
}

void ahc_step_reset(ahc_stepper *c)
{
    if (!c) return;
    {
        const double pitch_erect = c->pitch_erect;
        memset(&c->tick, 0, sizeof *c - offsetof(ahc_stepper, tick));
        c->pitch_erect = pitch_erect;
    }
    c->phase = AHC_STEP_STAND;
    c->swing_side = -1;
    c->obs_loaded_time = c->p.step_impact_hold; /* the robot starts on both feet */
    c->feet[AHC_LEFT][1] = c->ankle_y;
    c->feet[AHC_RIGHT][1] = -c->ankle_y;
}

/* The CoM reference's reach: it stays within REF_MAX [m] of the frame's origin and moves at most
 * REF_RATE_MAX [m/s] (a reference beyond them, on a robot that does not follow it, is of a robot that
 * has fallen); with them every value the plan keeps stays within STEP_STATE_MAX, which a restored
 * state's must too (ahc_step_state_validate). */
#define REF_MAX 100.0
#define REF_RATE_MAX 100.0
/* The trunk's pitch plan starts from the measured pitch and rate within these [rad], [rad/s]. */
#define PITCH_PLAN_MAX 1.6
#define PITCH_RATE_PLAN_MAX 50.0
#define STEP_STATE_MAX 1e3

/* ---- the estimate ----------------------------------------------------------------------------- */

static int stance_of(const ahc_stepper *c) { return c->swing_side == AHC_LEFT ? AHC_RIGHT : AHC_LEFT; }
static int one_foot(int phase) { return phase == AHC_STEP_SWING || phase == AHC_STEP_CLOSE; }

/* The measured configuration in the step's frame: the anchor foot (the stance foot, or the more
 * loaded one on both feet) at its place, turned about the sole edge it rocks on when the trunk's
 * attitude and the joints say it is tilted. */
static void estimate_on(const ahc_stepper *c, const ahc_step_sensors *s, int anchor, double P[3], double ankle[2][3],
                        double Rfw[2][9], double com[3])
{
    double R[9], at[3], cf[3], Fc[3];
    const double *F;
    int i, k;
    rot_trunk(s->imu_roll, s->imu_pitch, R);
    at[0] = c->feet[anchor][0];
    at[1] = c->feet[anchor][1];
    at[2] = c->ankle_height;
    measured_configuration(c, s->q, R, anchor, at, P, ankle, Rfw);
    /* the contact edge of the anchor foot, in its frame: the toe when it pitches toes down, the heel
     * otherwise; the left edge when it rolls left edge down */
    F = Rfw[anchor];
    cf[0] = F[6] < 0.0 ? c->toe_x : c->heel_x;
    cf[1] = F[7] < 0.0 ? 0.5 * c->sole_width : -0.5 * c->sole_width;
    cf[2] = -c->ankle_height;
    mv(F, cf, Fc);
    for (i = 0; i < 3; ++i) {
        const double shift = cf[i] - Fc[i]; /* the edge stays where the flat foot has it */
        P[i] += shift;
        for (k = 0; k < 2; ++k) ankle[k][i] += shift;
    }
    com_of(c, P, R, ankle, Rfw, com);
}

/* The measured configuration in the step's frame, anchored on the feet where they were put: on the
 * stance foot while one foot swings; on both feet otherwise, each anchor weighted by its sole's load
 * (so that the estimate moves continuously as the load moves between the feet). */
static void estimate(const ahc_stepper *c, const ahc_step_sensors *s, double P[3], double ankle[2][3],
                     double Rfw[2][9], double com[3])
{
    double w_left, sum;
    if (one_foot(c->phase)) {
        estimate_on(c, s, stance_of(c), P, ankle, Rfw, com);
        return;
    }
    sum = s->fz_left + s->fz_right;
    w_left = (isfinite(sum) && sum > 1e-6) ? clampd(s->fz_left / sum, 0.0, 1.0) : 0.5;
    estimate_on(c, s, AHC_LEFT, P, ankle, Rfw, com);
    if (w_left < 1.0) {
        double P2[3], ankle2[2][3], Rfw2[2][9], com2[3];
        int i, k;
        estimate_on(c, s, AHC_RIGHT, P2, ankle2, Rfw2, com2);
        for (i = 0; i < 3; ++i) {
            P[i] = w_left * P[i] + (1.0 - w_left) * P2[i];
            com[i] = w_left * com[i] + (1.0 - w_left) * com2[i];
            for (k = 0; k < 2; ++k) ankle[k][i] = w_left * ankle[k][i] + (1.0 - w_left) * ankle2[k][i];
        }
    }
}

/* The momentum observer: the external pitching moment about the ground (a push), from the sagittal
 * angular momentum balance of the whole robot about the frame's origin O on the ground (x forward,
 * z up, + pitching forward):
 *     dH/dt = m g c_x - p f_z + M_ext,   H = sum_b m_b (z_b x_b' - x_b z_b') + I2 pitch' + I1/2 sum legs' pitch',
 * p and f_z the measured ZMP and load, the bodies' motion the measured configuration's finite
 * differences. The residual r = K (H - integral of (m g c_x - p f_z + r)) follows M_ext as a
 * first-order lag of bandwidth K (step_observer_gain), with no second derivative of a measurement
 * (the generalized-momentum observer of De Luca and Mattone 2003, here for the whole robot).
 * The estimate holds on one foot and through the landed foot's transfer (SWING, CLOSE, TRANSFER),
 * and from a sole's unloading until both soles have carried step_touchdown_fz for step_impact_hold:
 * the model has no soles' impacts, whose momentum jumps it took for pushes of tens of N m (and a
 * robot settling after a step rocks from foot to foot, docs/controller.md §12.5). It then restarts
 * from the held value. */
static void observe_push(ahc_stepper *c, const ahc_step_sensors *s, const double P[3], double ankle[2][3],
                         double Rfw[2][9], const double com[3])
{
    double R[9], pts[BODIES][3], hips[2][3], leg[2], H = 0.0, torque, fz, px;
    int b, i, finite = 1, have_median;
    const int both_loaded = s->fz_left >= c->p.step_touchdown_fz && s->fz_right >= c->p.step_touchdown_fz;
    c->obs_loaded_time = both_loaded ? c->obs_loaded_time + c->dt : 0.0;
    if (one_foot(c->phase) || c->phase == AHC_STEP_TRANSFER || c->obs_loaded_time < c->p.step_impact_hold - 1e-12) {
        c->obs_valid = 0;
        return;
    }
    rot_trunk(s->imu_roll, s->imu_pitch, R);
    bodies_of(c, P, R, ankle, Rfw, pts, hips);
    for (b = 0; b < 2; ++b) leg[b] = atan2(hips[b][0] - ankle[b][0], hips[b][2] - ankle[b][2]);
    fz = s->fz_left + s->fz_right;
    /* the measured ZMP is from the ankles' mid-point (the plant's feet frame) */
    px = s->zmp_x + 0.5 * (ankle[AHC_LEFT][0] + ankle[AHC_RIGHT][0]);
    for (b = 0; b < BODIES; ++b)
        for (i = 0; i < 3; ++i) finite = finite && isfinite(pts[b][i]);
    finite = finite && isfinite(leg[0]) && isfinite(leg[1]) && isfinite(fz) && isfinite(px) && isfinite(com[0]) &&
             isfinite(s->imu_pitch);
    if (!finite) return; /* a non-finite reading: the estimate holds */
    if (c->obs_valid) {
        for (b = 0; b < BODIES; ++b) {
            const double vx = (pts[b][0] - c->obs_body_prev[b][0]) / c->dt, vz = (pts[b][2] - c->obs_body_prev[b][2]) / c->dt;
            H += body_mass(c, b) * (pts[b][2] * vx - pts[b][0] * vz);
        }
        H += (c->I2 * (s->imu_pitch - c->obs_pitch_prev) +
              0.5 * c->I1 * ((leg[0] - c->obs_leg_prev[0]) + (leg[1] - c->obs_leg_prev[1]))) / c->dt;
        torque = c->mass * c->g * com[0] - px * fz;
        if (!isfinite(torque) || !isfinite(H)) return; /* readings finite but too large to multiply: the estimate holds */
        {
            /* the median of the last five ticks' H: a jump of the estimate (a sole unloading, the foot's
             * rocking edge changing) moves the bodies by a millimetre in a tick, and their finite
             * differences would put a spike of some 50 N m into the estimate for a tick or two */
            double h5[5], Hm = H;
            int n = c->obs_Hn, k, j;
            have_median = n == 4;
            if (have_median) {
                h5[0] = H;
                for (k = 0; k < 4; ++k) h5[k + 1] = c->obs_H[k];
                for (k = 1; k < 5; ++k)
                    for (j = k; j > 0 && h5[j - 1] > h5[j]; --j) {
                        const double tmp = h5[j];
                        h5[j] = h5[j - 1];
                        h5[j - 1] = tmp;
                    }
                Hm = h5[2];
            }
            for (k = (n < 4 ? n : 3); k > 0; --k) c->obs_H[k] = c->obs_H[k - 1];
            c->obs_H[0] = H;
            if (n < 4) c->obs_Hn = n + 1;
            H = Hm;
        }
        if (c->obs_valid == 1 && have_median) {
            /* (re)start once the median has five ticks: the prediction where the estimate is (a
             * restart on the raw H of an impact's ticks put a spike of 40 N m into the estimate) */
            c->obs_pred = H - c->push_moment / c->p.step_observer_gain;
            c->obs_valid = 2;
        } else if (c->obs_valid == 2) {
            c->obs_pred += (torque + c->push_moment) * c->dt;
        }
        if (c->obs_valid == 2) c->push_moment = c->p.step_observer_gain * (H - c->obs_pred);
    } else {
        c->obs_valid = 1;
        c->obs_Hn = 0;
    }
    for (b = 0; b < BODIES; ++b)
        for (i = 0; i < 3; ++i) c->obs_body_prev[b][i] = pts[b][i];
    c->obs_leg_prev[0] = leg[0];
    c->obs_leg_prev[1] = leg[1];
    c->obs_pitch_prev = s->imu_pitch;
}

/* The external moment as the ZMP offset it asks for, u = M / (m g): the pendulum under a push moves
 * as c'' = omega^2 (c - p + u) (0 unless step_push_estimate). Standing, the estimate now; through a
 * step, the estimate at its decision: the observer's model leaves out the swing and the impacts, and
 * its estimate swings by tens of N m at the soles' impacts (docs/controller.md §12.5), which a
 * plan following it turned into the pendulum's. */
static double push_offset(const ahc_stepper *c)
{
    if (!c->p.step_push_estimate) return 0.0;
    return (c->phase == AHC_STEP_STAND ? c->push_moment : c->push_planned) / (c->mass * c->g);
}

/* ---- the plan --------------------------------------------------------------------------------- */

static double smooth01(double s)
{
    s = clampd(s, 0.0, 1.0);
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s));
}

/* The swing foot's planned lift over the swing's time fraction u, per step_height: u^3 (1-u)^3 / 0.03456,
 * symmetric about mid-swing, where it peaks at 0.452 (0.03456 = 0.4^2 0.6^3 is the peak of u^2 (1-u)^3,
 * up early and down late, which an earlier comment here named; every measurement of docs/controller.md
 * §12 was made with the formula as it is). */
static double swing_lift(double u) { return u * u * u * (1.0 - u) * (1.0 - u) * (1.0 - u) / 0.03456; }

/* The sole box of foot `side` shrunk by the ZMP margin: [x lo, x hi, y lo, y hi]. */
static void sole_box(const ahc_stepper *c, int side, double b[4])
{
    const double m = c->p.step_zmp_margin;
    b[0] = c->feet[side][0] + c->heel_x + m;
    b[1] = c->feet[side][0] + c->toe_x - m;
    b[2] = c->feet[side][1] - 0.5 * c->sole_width + m;
    b[3] = c->feet[side][1] + 0.5 * c->sole_width - m;
}

/* The CoM reference's state now: the pendulum over the phase's planned ZMP, integrated tick by
 * tick (pendulum_tick). */
static void reference(const ahc_stepper *c, double t, double r[2], double v[2], double a[2])
{
    int i;
    (void)t;
    for (i = 0; i < 2; ++i) {
        r[i] = c->cref[i];
        v[i] = c->vref[i];
        a[i] = c->omega * c->omega * (r[i] - c->zmp[i] + (i == 0 ? push_offset(c) : 0.0));
    }
}

static void begin_phase(ahc_stepper *c, int phase, double duration)
{
    double r[2], v[2], a[2];
    int i;
    reference(c, c->phase_time, r, v, a);
    for (i = 0; i < 2; ++i) {
        c->c0[i] = r[i];
        c->v0[i] = v[i];
    }
    c->phase = phase;
    c->phase_time = 0.0;
    c->phase_duration = duration;
    (void)a;
}

/* The capture point of the reference at the phase's start. */
static double xi0(const ahc_stepper *c, int i)
{
    return c->c0[i] + c->v0[i] / c->omega + (i == 0 ? push_offset(c) : 0.0);
}

/* A phase on one foot: the ZMP holds the capture point over the stance sole, or at the sole's edge. */
static void plan_one_foot(ahc_stepper *c)
{
    double b[4];
    sole_box(c, stance_of(c), b);
    c->zmp[0] = clampd(xi0(c, 0), b[0], b[1]);
    c->zmp[1] = clampd(xi0(c, 1), b[2], b[3]);
}

/* The shortest time T >= T_min (to 1 s, in 5 ms steps) in which a ZMP inside [lo, hi] moves the
 * capture point from x0 to target: p = (target - x0 E) / (1 - E), E = e^(omega T). */
static double pendulum_transfer(const ahc_stepper *c, double x0, double target, double lo, double hi, double T_min,
                                double *p)
{
    double T;
    if (fabs(target - x0) < 1e-9) {
        *p = clampd(target, lo, hi);
        return T_min;
    }
    for (T = T_min > 0.005 ? T_min : 0.005; T < 1.0; T += 0.005) {
        const double E = exp(c->omega * T), z = (target - x0 * E) / (1.0 - E);
        if (z >= lo && z <= hi) {
            *p = z;
            return T;
        }
    }
    *p = clampd(x0, lo, hi);
    return 1.0;
}

/* The landing point for the swing foot from the capture point xi predicted at touch-down, within
 * the reach and clear of the stance foot. */
static void landing_point(const ahc_stepper *c, const double xi[2], double L[2])
{
    const int a = stance_of(c);
    const double sigma = c->swing_side == AHC_LEFT ? 1.0 : -1.0; /* the swing foot's side */
    const double dx = clampd(xi[0] - c->feet[a][0], -c->p.step_length_max, c->p.step_length_max);
    const double dy = clampd(sigma * (xi[1] - c->feet[a][1]), 2.0 * c->ankle_y, c->p.step_width_max);
    L[0] = c->feet[a][0] + dx;
    L[1] = c->feet[a][1] + sigma * dy;
}

static void plan_swing_xy(ahc_stepper *c, const double target[2], double T_left)
{
    int i;
    for (i = 0; i < 2; ++i) {
        c->landing[i] = target[i];
        ahc_quintic_init(&c->swing[i], c->swing_pos[i], c->swing_vel[i], c->swing_acc[i], target[i], 0.0, 0.0,
                         T_left > c->dt ? T_left : c->dt);
    }
}

/* Blend out the jump of the references at this switch, from the step's last set points. */
static void blend_from_last(ahc_stepper *c)
{
    int side, j;
    c->blend_time = 0.0;
    c->blend_from_flat = 0;
    for (side = 0; side < 2; ++side)
        for (j = 0; j < AHC_LEG_JOINTS; ++j) c->blend_from[side][j] = NAN;
}

static void start_swing(ahc_stepper *c, int phase, const double target[2], double swing_time)
{
    int i;
    begin_phase(c, phase, swing_time);
    c->swing_time = swing_time;
    plan_one_foot(c);
    for (i = 0; i < 2; ++i) {
        c->swing_from[i] = c->feet[c->swing_side][i];
        c->swing_pos[i] = c->swing_from[i];
        c->swing_vel[i] = c->swing_acc[i] = 0.0;
    }
    plan_swing_xy(c, target, swing_time);
    /* the swing foot is placed in the world from now on, through the stance foot's measured tilt
     * (plan_joints): the references' jump is blended out */
    c->tilt_valid = 0;
    blend_from_last(c);
}

/* Both soles' bounding box, step_zmp_margin inside: where a ZMP on both feet can be. */
static void support_box(const ahc_stepper *c, double lo[2], double hi[2])
{
    double b[2][4];
    sole_box(c, AHC_LEFT, b[0]);
    sole_box(c, AHC_RIGHT, b[1]);
    lo[0] = fmin(b[0][0], b[1][0]); hi[0] = fmax(b[0][1], b[1][1]);
    lo[1] = fmin(b[0][2], b[1][2]); hi[1] = fmax(b[0][3], b[1][3]);
}

/* On both feet: the planned ZMP (c->zmp) that brings the reference's capture point to target in the
 * shortest time >= T_min, both axes in the longer of their times; returns that time. */
static double plan_transfer(ahc_stepper *c, const double target[2], double T_min)
{
    double lo[2], hi[2], p[2], T[2], E;
    int i;
    support_box(c, lo, hi);
    for (i = 0; i < 2; ++i) T[i] = pendulum_transfer(c, xi0(c, i), target[i], lo[i], hi[i], T_min, &p[i]);
    T[0] = fmax(T[0], T[1]);
    E = exp(c->omega * T[0]);
    for (i = 0; i < 2; ++i)
        c->zmp[i] = fabs(target[i] - xi0(c, i)) < 1e-9 ? clampd(target[i], lo[i], hi[i])
                                                       : clampd((target[i] - xi0(c, i) * E) / (1.0 - E), lo[i], hi[i]);
    return T[0];
}

static void start_transfer(ahc_stepper *c)
{
    begin_phase(c, AHC_STEP_TRANSFER, 0.0);
    c->phase_duration = plan_transfer(c, c->feet[c->swing_side], c->p.step_transfer_time_min);
}

/* The supporting legs' planned knee bend at this point of the step: they shorten by
 * step_pelvis_drop as two equal leg segments would by a knee flexing along a quintic over
 * step_drop_time (the knee's rate stays bounded at the straight leg, where the length's would not). */
static double drop_knee(const ahc_stepper *c)
{
    const double knee_max = 2.0 * acos(1.0 - c->p.step_pelvis_drop / c->l1);
    return knee_max * smooth01(c->step_clock / c->p.step_drop_time);
}

/* Where the closing step puts the other foot: beside the landed one (c->swing_side), the stance
 * width across. */
static void beside_landed(const ahc_stepper *c, double target[2])
{
    const int landed = c->swing_side;
    target[0] = c->feet[landed][0];
    target[1] = c->feet[landed][1] + (landed == AHC_LEFT ? -2.0 : 2.0) * c->ankle_y;
}

/* The feet more than 5 mm from side by side at the stance width. */
static int feet_apart(const ahc_stepper *c)
{
    double t[2];
    const int other = c->swing_side == AHC_LEFT ? AHC_RIGHT : AHC_LEFT;
    beside_landed(c, t);
    return hypot(c->feet[other][0] - t[0], c->feet[other][1] - t[1]) > 0.005;
}

/* SETTLE: the pendulum's ZMP, inside both soles, brings the capture point over the feet's mid-point
 * in the shortest time (as TRANSFER's), then holds it there: the CoM comes to rest over it. After
 * the recovery step with the feet apart and step_close, the legs stay bent for the closing step
 * that follows; otherwise they stretch back over SETTLE. */
static void start_settle(ahc_stepper *c)
{
    int i;
    begin_phase(c, AHC_STEP_SETTLE, 0.0);
    for (i = 0; i < 2; ++i) c->settle_mid[i] = 0.5 * (c->feet[AHC_LEFT][i] + c->feet[AHC_RIGHT][i]);
    c->settle_capture_time = plan_transfer(c, c->settle_mid, 0.0);
    c->phase_duration = c->settle_capture_time + c->p.step_settle_time;
    if (c->close_stage == 0) {
        c->knee_settle = drop_knee(c);
        c->close_stage = c->p.step_close && feet_apart(c) ? 1 : 0;
    } else {
        c->close_stage = 3; /* after the closing step */
    }
}

/* At rest on both feet (the closing step's start, step_close_rest > 0): the capture point within
 * step_close_rest of the CoM (the CoM slower than omega step_close_rest), each sole carrying
 * step_touchdown_fz and flat within step_close_rest_tilt. */
static int at_rest(const ahc_stepper *c, const ahc_step_sensors *s, const double xi[2], const double Rfw[2][9])
{
    int side;
    if (!(hypot(xi[0] - c->com_prev[0], xi[1] - c->com_prev[1]) <= c->p.step_close_rest)) return 0;
    if (!(s->fz_left > c->p.step_touchdown_fz && s->fz_right > c->p.step_touchdown_fz)) return 0;
    for (side = 0; side < 2; ++side)
        if (!(acos(clampd(Rfw[side][8], -1.0, 1.0)) <= c->p.step_close_rest_tilt)) return 0;
    return 1;
}

/* The closing step's weight shift, from rest: the capture point to step_close_inset inside of the
 * landed ankle, in step_close_shift_time at least. */
static void start_close_shift(ahc_stepper *c)
{
    double aim[2];
    const int landed = c->swing_side;
    begin_phase(c, AHC_STEP_SHIFT, 0.0);
    aim[0] = c->feet[landed][0];
    aim[1] = c->feet[landed][1] + (landed == AHC_LEFT ? -1.0 : 1.0) * c->p.step_close_inset;
    c->phase_duration = plan_transfer(c, aim, c->p.step_close_shift_time);
    c->close_stage = 2;
}

/* SETTLE's hold with step_settle_on_axis: across, the line between the ankles at the CoM
 * reference's x (with the feet one ahead of the other, a point between them is inside their support
 * only near that line: the feet's mid-point lies on it, a CoM held back by a push does not), blended
 * into the mid-point as the feet come side by side (their x apart less than a sole's length). */
static void settle_on_axis(const ahc_stepper *c, double hold[2])
{
    const double *back = c->feet[AHC_LEFT][0] <= c->feet[AHC_RIGHT][0] ? c->feet[AHC_LEFT] : c->feet[AHC_RIGHT];
    const double *front = back == c->feet[AHC_LEFT] ? c->feet[AHC_RIGHT] : c->feet[AHC_LEFT];
    const double dx = front[0] - back[0];
    const double w = clampd(dx / (c->toe_x - c->heel_x), 0.0, 1.0);
    const double t = dx > 0.0 ? clampd((c->cref[0] - back[0]) / dx, 0.0, 1.0) : 0.5;
    hold[0] = c->settle_mid[0];
    hold[1] = c->settle_mid[1] + w * (back[1] + t * (front[1] - back[1]) - c->settle_mid[1]);
}

/* One tick of the pendulum reference: its ZMP is the
 * phase's planned one moved by the capture point's error, p = zmp + (1 + step_dcm_gain / omega)
 * (xi_measured - xi_reference) (the capture-point tracking law of Englsberger et al. 2015), inside
 * the support (the stance sole, or both soles' bounding box, step_zmp_margin inside); the reference
 * then moves as the pendulum over p. Returns p. */
static void pendulum_tick(ahc_stepper *c, const double xi_meas[2], double p_out[2])
{
    double lo[2], hi[2];
    /* a capture point held at rest (SETTLE's mid-point once reached, the closing swing's point over
     * the stance foot) is held by the reference's own feedback, d xi / dt = -omega (xi - hold): the
     * open-loop pendulum would diverge from any rounding at e^(omega t) */
    const double *hold = c->phase == AHC_STEP_SETTLE && c->phase_time >= c->settle_capture_time ? c->settle_mid
                         : c->phase == AHC_STEP_CLOSE                                           ? c->zmp
                                                                                                : NULL;
    double on_axis[2];
    int i;
    if (hold == c->settle_mid && c->p.step_settle_on_axis) {
        settle_on_axis(c, on_axis);
        hold = on_axis;
    }
    if (one_foot(c->phase)) {
        double b[4];
        sole_box(c, stance_of(c), b);
        lo[0] = b[0]; hi[0] = b[1]; lo[1] = b[2]; hi[1] = b[3];
    } else {
        support_box(c, lo, hi);
    }
    for (i = 0; i < 2; ++i) {
        /* the push as estimated: the reference moves as the pushed pendulum, its capture point the
         * pushed one (xi_meas too) */
        const double u = i == 0 ? push_offset(c) : 0.0;
        const double xi_ref = c->cref[i] + c->vref[i] / c->omega + u;
        const double fb = c->p.step_dcm_feedback ? (1.0 + c->p.step_dcm_gain / c->omega) * (xi_meas[i] - xi_ref) : 0.0;
        const double plan = hold ? hold[i] + 2.0 * (xi_ref - hold[i]) : c->zmp[i];
        const double p = clampd(plan + fb, lo[i], hi[i]);
        c->vref[i] = clampd(c->vref[i] + c->omega * c->omega * (c->cref[i] - p + u) * c->dt, -REF_RATE_MAX, REF_RATE_MAX);
        c->cref[i] = clampd(c->cref[i] + c->vref[i] * c->dt, -REF_MAX, REF_MAX);
        p_out[i] = p;
    }
}

/* ---- the joints ------------------------------------------------------------------------------- */

/* The swing leg stays bent by at least 0.2 rad at the knee: its foot, d from the hip, comes short
 * horizontally of a place the leg cannot reach (a straight leg's knee rate is unbounded). */
static void within_swing_reach(const ahc_stepper *c, double d[3])
{
    const double reach = c->l1 * cos(0.1 * smooth01(c->phase_time / (0.3 * c->swing_time))), hor = hypot(d[0], d[1]);
    if (hypot(hor, d[2]) > reach && hor > 0.0) {
        const double k = sqrt(fmax(reach * reach - d[2] * d[2], 0.0)) / hor;
        d[0] *= k;
        d[1] *= k;
    }
}

/* The planned joint angles: the pelvis that carries the CoM reference r over the feet (the stance
 * sole flat), the trunk at roll and pitch. The plan's frame is the stance foot's; when the stance
 * foot turns on a sole edge (c->tilt, measured) the world turns with it in that frame, and the swing
 * foot's place in the world, flat, swing_z above the ground, is put into the plan's frame: it lands
 * where the ground is. With step_swing_measured the swing leg is also set from the measured pelvis
 * P_meas and trunk attitude R_meas (read only then). */
static void plan_joints(ahc_stepper *c, const double r[2], double leg, double roll, double pitch,
                        double swing_z, const double P_meas[3], const double R_meas[9], double q[2][AHC_LEG_JOINTS])
{
    double R[9], Rt[9], ankle[2][3], Rfw[2][9], P[3], com[3];
    const double kfac = (c->m2 + c->m1 * c->lg1 / c->l1) / c->mass; /* d com / d pelvis */
    int s, i, j;
    rot_trunk(roll, pitch, R);
    for (s = 0; s < 2; ++s) {
        const int swinging = one_foot(c->phase) && s == c->swing_side;
        ankle[s][0] = swinging ? c->swing_pos[0] : c->feet[s][0];
        ankle[s][1] = swinging ? c->swing_pos[1] : c->feet[s][1];
        ankle[s][2] = swinging ? swing_z : c->ankle_height;
        for (i = 0; i < 9; ++i) Rfw[s][i] = (i % 4 == 0) ? 1.0 : 0.0;
    }
    /* the CoM is affine in the pelvis position: one correction from a first guess is exact (a vertical
     * move of the pelvis leaves the CoM's x and y where they are) */
    P[0] = r[0];
    P[1] = r[1];
    P[2] = c->ankle_height + leg;
    com_of(c, P, R, ankle, Rfw, com);
    P[0] += (r[0] - com[0]) / kfac;
    P[1] += (r[1] - com[1]) / kfac;
    /* the height: the supporting legs' hips `leg` from their ankles (the lowest of them on two feet) */
    {
        double z = 1e9;
        for (s = 0; s < 2; ++s) {
            double v[3], hip[3], h2;
            if (one_foot(c->phase) && s == c->swing_side) continue;
            v[0] = 0.0; v[1] = hip_offset_y(c, s); v[2] = 0.0;
            mv(R, v, hip);
            h2 = (P[0] + hip[0] - ankle[s][0]) * (P[0] + hip[0] - ankle[s][0]) +
                 (P[1] + hip[1] - ankle[s][1]) * (P[1] + hip[1] - ankle[s][1]);
            z = fmin(z, ankle[s][2] + sqrt(fmax(leg * leg - h2, 0.25 * leg * leg)) - hip[2]);
        }
        /* the height rises at most step_pelvis_rate (a foot leaving the support raises the constraint
         * at once) and lowers at once: a landed foot far ahead is within its leg's reach from the
         * landing on (lowered at the rate, the landed leg was driven straight into the ground and
         * threw the robot off it; the landing's jump is blended out, docs/controller.md §12.4) */
        if (c->pelvis_z_valid) z = fmin(z, c->pelvis_z + c->p.step_pelvis_rate * c->dt);
        c->pelvis_z = z;
        c->pelvis_z_valid = 1;
        P[2] = z;
    }
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j) Rt[3 * i + j] = R[3 * j + i]; /* the flat foot relative to the trunk */
    for (s = 0; s < 2; ++s) {
        double hip[3], d[3], rel[3], v[3], Rf[9];
        const int swinging = one_foot(c->phase) && s == c->swing_side;
        if (swinging) {
            /* the world in the plan's frame: turned by the stance foot's tilt about its contact edge */
            double Rtilt[9], e[3], w[3], tmp[3];
            const int a = stance_of(c);
            rot_trunk(c->tilt[1], c->tilt[0], Rtilt);
            e[0] = c->feet[a][0] + (c->tilt[0] > 0.0 ? c->toe_x : c->heel_x);
            e[1] = c->feet[a][1] + (c->tilt[1] < 0.0 ? 0.5 : -0.5) * c->sole_width;
            e[2] = 0.0;
            for (i = 0; i < 3; ++i) w[i] = ankle[s][i] - e[i];
            mtv(Rtilt, w, tmp);
            for (i = 0; i < 3; ++i) ankle[s][i] = e[i] + tmp[i];
            /* the foot flat in the world: Rtilt^T in the plan's frame, R^T Rtilt^T from the trunk */
            for (i = 0; i < 3; ++i)
                for (j = 0; j < 3; ++j)
                    Rf[3 * i + j] = R[i] * Rtilt[3 * j] + R[3 + i] * Rtilt[3 * j + 1] + R[6 + i] * Rtilt[3 * j + 2];
        } else {
            for (i = 0; i < 9; ++i) Rf[i] = Rt[i];
        }
        v[0] = 0.0; v[1] = hip_offset_y(c, s); v[2] = 0.0;
        mv(R, v, hip);
        for (i = 0; i < 3; ++i) d[i] = ankle[s][i] - (P[i] + hip[i]);
        if (swinging) within_swing_reach(c, d);
        mtv(R, d, rel);
        ahc_leg_ik_pose(&c->legs, NULL, rel, Rf, q[s]);
        if (swinging && c->p.step_swing_measured > 0.0) {
            /* the same place in the world from the pelvis as measured: the foot flat in the world */
            const double w = c->p.step_swing_measured;
            double qm[AHC_LEG_JOINTS], Rfm[9], target[3];
            target[0] = c->swing_pos[0];
            target[1] = c->swing_pos[1];
            target[2] = swing_z;
            mv(R_meas, v, hip);
            for (i = 0; i < 3; ++i) d[i] = target[i] - (P_meas[i] + hip[i]);
            within_swing_reach(c, d);
            mtv(R_meas, d, rel);
            for (i = 0; i < 3; ++i)
                for (j = 0; j < 3; ++j) Rfm[3 * i + j] = R_meas[3 * j + i];
            ahc_leg_ik_pose(&c->legs, NULL, rel, Rfm, qm);
            for (j = 0; j < AHC_LEG_JOINTS; ++j) q[s][j] = (1.0 - w) * q[s][j] + w * qm[j];
        }
    }
}

/* ---- one tick --------------------------------------------------------------------------------- */

/* The set points plus the blended-out jump of the last switch; the swing leg's rate-limited to
 * step_swing_rate_max (its plan jumps where the foot first comes within the leg's reach,
 * docs/controller.md §12.4 item 4). */
static void blend(ahc_stepper *c, ahc_step_outputs *out)
{
    const double w = 1.0 - smooth01(c->blend_time / c->p.step_blend_time);
    const double dq_max = c->p.step_swing_rate_max * c->dt;
    int side, j;
    for (side = 0; side < 2; ++side)
        for (j = 0; j < AHC_LEG_JOINTS; ++j) {
            out->q_ref[side][j] += w * c->blend_from[side][j];
            if (dq_max > 0.0 && one_foot(c->phase) && side == c->swing_side)
                out->q_ref[side][j] = clampd(out->q_ref[side][j], c->q_out[side][j] - dq_max, c->q_out[side][j] + dq_max);
            c->q_out[side][j] = out->q_ref[side][j];
        }
    c->blend_time += c->dt;
}

/* The feet's lateral mid-line: y half-way between the ankles. */
static double feet_mid_y(const ahc_stepper *c) { return 0.5 * (c->feet[AHC_LEFT][1] + c->feet[AHC_RIGHT][1]); }

static void start_step(ahc_stepper *c, const double com[2], const double xi[2])
{
    const double w2 = 0.5 * c->sole_width;
    int sigma_swing, i;
    /* which foot: outward toward a capture point beyond the outer edges; otherwise the stance foot
     * is the one on the capture point's side */
    if (xi[1] > c->feet[AHC_LEFT][1] + w2 + c->p.step_trigger_y) c->swing_side = AHC_LEFT;
    else if (xi[1] < c->feet[AHC_RIGHT][1] - w2 - c->p.step_trigger_y) c->swing_side = AHC_RIGHT;
    else c->swing_side = xi[1] >= feet_mid_y(c) ? AHC_RIGHT : AHC_LEFT;
    sigma_swing = c->swing_side == AHC_LEFT ? 1 : -1;
    for (i = 0; i < 2; ++i) {
        c->c0[i] = c->cref[i] = clampd(com[i], -REF_MAX, REF_MAX);
        c->v0[i] = c->vref[i] = clampd(c->com_rate[i], -REF_RATE_MAX, REF_RATE_MAX);
    }
    c->phase_time = 0.0;
    c->step_clock = 0.0;
    /* SHIFT: the ZMP toward the swing foot's outer edge moves the capture point over the stance ankle */
    {
        const int a = stance_of(c);
        double b[4], T = 0.0;
        const double p_y = c->feet[c->swing_side][1] + sigma_swing * (w2 - c->p.step_zmp_margin);
        /* the target: the stance ankle, step_shift_inset toward the other foot */
        const double aim = c->feet[a][1] + sigma_swing * c->p.step_shift_inset;
        const double ratio = (aim - p_y) / (xi[1] - p_y);
        if (ratio > 1.0) T = fmin(log(ratio) / c->omega, c->p.step_shift_time_max);
        sole_box(c, a, b);
        c->zmp[0] = clampd(xi[0], b[0], b[1]);
        c->zmp[1] = p_y;
        c->phase = AHC_STEP_SHIFT;
        c->phase_duration = T;
    }
}

static void next_phase_after_shift(ahc_stepper *c, const double xi_meas[2])
{
    double L[2], xi_T[2], b[4];
    int i;
    /* the landing point from the measured capture point, predicted at touch-down under the stance
     * ZMP the swing will hold */
    sole_box(c, stance_of(c), b);
    for (i = 0; i < 2; ++i) {
        const double p = clampd(xi_meas[i], b[2 * i], b[2 * i + 1]);
        xi_T[i] = p + (xi_meas[i] - p) * exp(c->omega * c->p.step_swing_time);
    }
    landing_point(c, xi_T, L);
    start_swing(c, AHC_STEP_SWING, L, c->p.step_swing_time);
}

void ahc_step_step(ahc_stepper *c, const ahc_step_sensors *s, const double flat_q[2][AHC_LEG_JOINTS],
                   ahc_step_outputs *out)
{
    double P[3], ankle[2][3], Rfw[2][9], com[3], xi[2], xi_push[2];
    int i, side, j;
    memset(out, 0, sizeof *out);
    out->swing_side = -1;
    if (!c || !c->valid) return;
    /* the estimate: the CoM and its low-passed rate, the capture point */
    estimate(c, s, P, ankle, Rfw, com);
    if (!isfinite(com[0]) || !isfinite(com[1])) {
        /* a non-finite reading: the estimate holds (the step, if one runs, goes on as planned) */
    } else if (!c->est_valid) {
        for (i = 0; i < 2; ++i) {
            c->com_prev[i] = com[i];
            c->com_rate[i] = 0.0;
        }
        c->pitch_prev = s->imu_pitch;
        c->pitch_rate = 0.0;
        c->est_valid = 1;
    } else {
        const double a = c->p.step_velocity_tau > 0.0 ? 1.0 - exp(-c->dt / c->p.step_velocity_tau) : 1.0;
        for (i = 0; i < 2; ++i) {
            c->com_rate[i] += a * ((com[i] - c->com_prev[i]) / c->dt - c->com_rate[i]);
            c->com_prev[i] = com[i];
        }
        c->pitch_rate += a * ((s->imu_pitch - c->pitch_prev) / c->dt - c->pitch_rate);
        c->pitch_prev = s->imu_pitch;
    }
    for (i = 0; i < 2; ++i) xi[i] = c->com_prev[i] + c->com_rate[i] / c->omega;
    observe_push(c, s, P, ankle, Rfw, com);
    /* the capture point under the push as estimated: where the feet's ZMP must come to hold it */
    xi_push[0] = xi[0] + push_offset(c);
    xi_push[1] = xi[1];
    c->tick++;
    {
        /* an impact: the capture point moves faster than twice what any ZMP on the feet could
         * drive, |xi'| = omega |xi - p| at the farthest corner of the feet's box */
        double lo[2], hi[2], far2 = 0.0;
        support_box(c, lo, hi);
        for (i = 0; i < 2; ++i) {
            const double d = fmax(fabs(xi[i] - lo[i]), fabs(xi[i] - hi[i]));
            far2 += d * d;
        }
        c->since_impact += c->dt;
        if (c->tick > 1 && hypot(xi[0] - c->xi_prev[0], xi[1] - c->xi_prev[1]) > 2.0 * c->omega * sqrt(far2) * c->dt)
            c->since_impact = 0.0;
        c->xi_prev[0] = xi[0];
        c->xi_prev[1] = xi[1];
    }

    if (c->phase == AHC_STEP_STAND) {
        const double w2 = 0.5 * c->sole_width;
        const double x_front = fmax(c->feet[0][0], c->feet[1][0]) + c->toe_x;
        const double x_back = fmin(c->feet[0][0], c->feet[1][0]) + c->heel_x;
        /* the hip strategy at its limit: the trunk leans step_trigger_lean toward the sole edge the
         * measured ZMP has reached (within step_zmp_margin) — a sagittal rule, so only while the
         * capture point lies between the soles' inner edges (an oblique push's lean stepped and
         * fell where the flat-footed layers stand: docs/controller.md §12.1) */
        const double lean = c->pitch_prev - c->pitch_erect, m = c->p.step_zmp_margin;
        const double inner = c->ankle_y - w2; /* the soles' inner edges, from the mid-line */
        const int at_limit = c->p.step_trigger_lean > 0.0 && fabs(xi[1] - feet_mid_y(c)) < inner &&
                             ((s->zmp_x > x_front - m && lean > c->p.step_trigger_lean) ||
                              (s->zmp_x < x_back + m && lean < -c->p.step_trigger_lean));
        /* the capture point beyond an edge of the feet by step_trigger_x or _y (forward and back,
         * with step_push_estimate 2, the pushed pendulum's: xi + u) */
        const double xi_x = c->p.step_push_estimate == 2 ? xi_push[0] : xi[0];
        const int beyond = xi_x > x_front + c->p.step_trigger_x || xi_x < x_back - c->p.step_trigger_x ||
                           xi[1] > c->feet[AHC_LEFT][1] + w2 + c->p.step_trigger_y ||
                           xi[1] < c->feet[AHC_RIGHT][1] - w2 - c->p.step_trigger_y;
        /* a step at a set time (step_trigger_time), whatever the rules and the impact hold */
        const double t_set = c->p.step_trigger_time;
        const int at_set_time = t_set > 0.0 && (double)c->tick * c->dt >= t_set && (double)(c->tick - 1) * c->dt < t_set;
        const int trigger = c->p.stepping_enabled && c->est_valid && c->tick > 20 && flat_q &&
                            (((beyond || at_limit) && c->since_impact >= c->p.step_impact_hold - 1e-12) || at_set_time);
        if (trigger) {
            /* from the measured pitch and rate, within what a trunk that has not fallen does (a
             * reading of 1e30 made a plan whose genuine state the restore refused) */
            ahc_quintic_init(&c->pitch_plan, clampd(c->pitch_prev, -PITCH_PLAN_MAX, PITCH_PLAN_MAX),
                             clampd(c->pitch_rate, -PITCH_RATE_PLAN_MAX, PITCH_RATE_PLAN_MAX), 0.0,
                             c->pitch_erect - c->p.step_trunk_back, 0.0, 0.0, c->p.step_pitch_time);
            c->pitch_time = 0.0;
            c->push_planned = c->push_moment;
            start_step(c, c->com_prev, xi_push); /* the estimate (held through a non-finite reading) */
            c->q_prev_valid = 0;
            c->pelvis_z_valid = 0;
            c->blend_from_flat = 1;
            c->blend_time = 0.0;
            /* the jump from the flat-footed layers' set points is blended out */
            for (side = 0; side < 2; ++side)
                for (j = 0; j < AHC_LEG_JOINTS; ++j) c->blend_from[side][j] = NAN; /* set below */
        }
    } else {
        /* advance the step's clock and phases */
        const double T = c->dt;
        c->phase_time += T;
        c->step_clock += T;
        switch (c->phase) {
        case AHC_STEP_SHIFT:
            if (c->phase_time >= c->phase_duration) {
                if (c->close_stage == 2) {
                    double target[2];
                    beside_landed(c, target);
                    c->swing_side = stance_of(c); /* the other foot swings */
                    start_swing(c, AHC_STEP_CLOSE, target, c->p.step_close_swing_time);
                } else {
                    next_phase_after_shift(c, xi_push);
                }
            }
            break;
        case AHC_STEP_SWING:
        case AHC_STEP_CLOSE: {
            const double fz_swing = c->swing_side == AHC_LEFT ? s->fz_left : s->fz_right;
            const double Tsw = c->swing_time;
            for (i = 0; i < 2; ++i)
                ahc_quintic_eval(&c->swing[i], c->phase_time - (Tsw - c->swing[i].T), &c->swing_pos[i],
                                 &c->swing_vel[i], &c->swing_acc[i]);
            /* the landing point follows the measured capture point through the swing's first 60 % */
            if (c->phase == AHC_STEP_SWING && c->phase_time < 0.6 * Tsw) {
                double b[4], xi_T[2], L[2];
                sole_box(c, stance_of(c), b);
                for (i = 0; i < 2; ++i) {
                    const double p = c->zmp[i];
                    xi_T[i] = p + (xi_push[i] - p) * exp(c->omega * (Tsw - c->phase_time));
                }
                landing_point(c, xi_T, L);
                if (fabs(L[0] - c->landing[0]) > 1e-4 || fabs(L[1] - c->landing[1]) > 1e-4)
                    plan_swing_xy(c, L, Tsw - c->phase_time);
            }
            /* landed: the swing sole carries step_touchdown_fz late enough in the swing, within
             * step_touchdown_tol of where it was sent (a foot that touches early and short is still
             * swinging); or the swing is over by 0.15 s */
            const double miss = hypot(ankle[c->swing_side][0] - c->landing[0], ankle[c->swing_side][1] - c->landing[1]);
            if ((fz_swing > c->p.step_touchdown_fz && c->phase_time > c->p.step_touchdown_after * Tsw &&
                 miss <= c->p.step_touchdown_tol) ||
                c->phase_time > Tsw + 0.15) {
                /* touch-down: the foot is where the measurement puts it */
                const int landed = c->swing_side;
                if (isfinite(ankle[landed][0]) && isfinite(ankle[landed][1])) {
                    c->landing[0] = ankle[landed][0];
                    c->landing[1] = ankle[landed][1];
                } /* else (a non-finite reading): where it was sent */
                c->feet[landed][0] = c->landing[0];
                c->feet[landed][1] = c->landing[1];
                c->steps++;
                /* the landed foot's place is measured, not planned: the legs' references move with
                 * it, and that jump is blended out */
                blend_from_last(c);
                if (c->phase == AHC_STEP_SWING && c->p.step_trunk_back > 0.0) {
                    /* the trunk back to erect from where its plan is, over step_pitch_time */
                    double pitch_now, pitch_rate_now;
                    ahc_quintic_eval(&c->pitch_plan, c->pitch_time, &pitch_now, &pitch_rate_now, NULL);
                    ahc_quintic_init(&c->pitch_plan, pitch_now, pitch_rate_now, 0.0, c->pitch_erect, 0.0, 0.0,
                                     c->p.step_pitch_time);
                    c->pitch_time = 0.0;
                }
                if (c->phase == AHC_STEP_SWING) {
                    /* both feet down: the reference goes on from where it is (starting it again from the
                     * measured state, with the jump blended out, fell in every trial: docs §12.4) */
                    start_transfer(c);
                } else {
                    start_settle(c);
                }
            }
            break;
        }
        case AHC_STEP_TRANSFER:
            if (c->phase_time >= c->phase_duration) start_settle(c);
            break;
        case AHC_STEP_SETTLE:
            if (c->phase_time < c->phase_duration) break;
            if (c->close_stage == 1) {
                /* on the feet apart: the closing step, at rest (or after SETTLE's planned time) */
                if (c->p.step_close_rest <= 0.0 || at_rest(c, s, xi, (const double(*)[9])Rfw) ||
                    c->phase_time >= c->phase_duration + c->p.step_close_wait)
                    start_close_shift(c);
            } else if (c->close_stage == 3 || !feet_apart(c)) {
                /* done: the flat-footed layers take over (ahc3d restarts them); the step's frame
                 * becomes the feet's new one */
                const double mx = 0.5 * (c->feet[0][0] + c->feet[1][0]), my = 0.5 * (c->feet[0][1] + c->feet[1][1]);
                for (side = 0; side < 2; ++side) {
                    c->feet[side][0] -= mx;
                    c->feet[side][1] -= my;
                }
                c->com_prev[0] -= mx;
                c->com_prev[1] -= my;
                c->xi_prev[0] -= mx; /* the new frame is not an impact */
                c->xi_prev[1] -= my;
                for (i = 0; i < BODIES; ++i) {
                    c->obs_body_prev[i][0] -= mx;
                    c->obs_body_prev[i][1] -= my;
                }
                if (c->obs_valid) { /* the observer restarts about the new origin */
                    c->obs_valid = 1;
                    c->obs_Hn = 0;
                }
                c->phase = AHC_STEP_STAND;
                c->swing_side = -1;
                c->close_stage = 0;
                c->blend_time = 0.0;
            } /* else (step_close 0, the feet apart): the robot stays at rest on them, in SETTLE (the
               * flat-footed layers stand on the feet side by side) */
            break;
        default:
            break;
        }
    }

    /* outputs */
    out->phase = c->phase;
    out->swing_side = c->swing_side;
    out->steps = c->steps;
    for (i = 0; i < 2; ++i) {
        out->com[i] = c->com_prev[i];
        out->com_rate[i] = c->com_rate[i];
        out->capture[i] = xi[i];
        out->landing[i] = c->landing[i];
    }
    out->push_moment = c->push_moment;
    if (c->phase != AHC_STEP_STAND) {
        double r[2], v[2], a[2], q[2][AHC_LEG_JOINTS], z, pitch, roll = 0.0, swing_z = c->ankle_height, lead_alpha;
        double stance_sole_pitch = NAN; /* on one foot: the stance sole's measured pitch (toes down +) */
        /* the supporting legs' length (drop_knee); the hips' height follows from the legs' lean */
        double knee = drop_knee(c);
        double p_cmd[2];
        pendulum_tick(c, xi_push, p_cmd);
        reference(c, c->phase_time, r, v, a);
        ahc_quintic_eval(&c->pitch_plan, c->pitch_time, &pitch, NULL, NULL);
        c->pitch_time += c->dt;
        if (c->close_stage == 1 || c->close_stage == 2) knee = c->knee_settle; /* bent for the closing step */
        else if (c->phase == AHC_STEP_SETTLE) knee = c->knee_settle * (1.0 - smooth01(c->phase_time / c->phase_duration));
        z = c->l1 * cos(0.5 * knee);
        if (one_foot(c->phase)) {
            const double Tsw = c->swing_time, u = c->phase_time / Tsw;
            if (u <= 1.0) {
                const double b = u * (1.0 - u);
                swing_z = c->ankle_height + c->p.step_height * swing_lift(u);
                /* the hip hike: the pelvis rolls the swing hip up, which lifts a straight swing leg
                 * (the knee's servo is slow at the straight leg) */
                roll = (c->swing_side == AHC_LEFT ? 1.0 : -1.0) * c->p.step_hip_hike * 16.0 * b * b;
            } else {
                swing_z = c->ankle_height - 0.1 * (c->phase_time - Tsw); /* reach for the ground */
            }
            if (c->p.step_swing_hold > 0.0 && u > 0.5) {
                /* past its peak the foot comes down only as its measured ankle nears the landing point */
                const double *sw = ankle[c->swing_side];
                const double left = hypot(sw[0] - c->landing[0], sw[1] - c->landing[1]);
                swing_z = fmax(swing_z, c->ankle_height + c->p.step_height * swing_lift(0.5) *
                                                              smooth01(left / c->p.step_swing_hold));
            }
        }
        if (one_foot(c->phase)) {
            /* the stance foot's tilt (pitch toes down +, roll left edge up +), low-passed */
            const double *F = Rfw[stance_of(c)];
            const double tp = asin(clampd(-F[6], -1.0, 1.0)), tr = atan2(F[7], F[8]);
            stance_sole_pitch = tp;
            const double al = c->p.step_velocity_tau > 0.0 ? 1.0 - exp(-c->dt / c->p.step_velocity_tau) : 1.0;
            if (isfinite(tp) && isfinite(tr)) {
                const double w = c->tilt_valid ? al : 1.0;
                c->tilt[0] += w * (clampd(tp, -0.3, 0.3) - c->tilt[0]);
                c->tilt[1] += w * (clampd(tr, -0.3, 0.3) - c->tilt[1]);
                c->tilt_valid = 1;
            }
        } else {
            c->tilt[0] = c->tilt[1] = 0.0;
        }
        {
            double R_meas[9] = {0};
            if (c->p.step_swing_measured > 0.0) rot_trunk(s->imu_roll, s->imu_pitch, R_meas);
            plan_joints(c, r, z, roll, pitch, swing_z, P, R_meas, q);
        }
        /* feedback on what the joints did not do: the trunk's pitch through the supporting hips, the
         * supporting soles' roll onto an edge through their ankles (docs/controller.md §12.5) */
        if (c->p.step_trunk_gain > 0.0 && isfinite(s->imu_pitch))
            for (side = 0; side < 2; ++side)
                if (!(one_foot(c->phase) && side == c->swing_side))
                    q[side][AHC_LEG_HIP_PITCH] -= c->p.step_trunk_gain * (s->imu_pitch - pitch);
        if (one_foot(c->phase) && c->p.step_stance_tilt_gain > 0.0 && isfinite(stance_sole_pitch))
            q[stance_of(c)][AHC_LEG_ANKLE_PITCH] += c->p.step_stance_tilt_gain * stance_sole_pitch;
        if (!one_foot(c->phase) && c->p.step_feet_tilt_gain > 0.0)
            for (side = 0; side < 2; ++side) {
                const double sole_pitch = asin(clampd(-Rfw[side][6], -1.0, 1.0));
                if (isfinite(sole_pitch)) q[side][AHC_LEG_ANKLE_PITCH] += c->p.step_feet_tilt_gain * sole_pitch;
            }
        lead_alpha = c->p.step_lead_tau > 0.0 ? 1.0 - exp(-c->dt / c->p.step_lead_tau) : 1.0;
        for (side = 0; side < 2; ++side)
            for (j = 0; j < AHC_LEG_JOINTS; ++j) {
                const double lead = j == AHC_LEG_HIP_PITCH ? c->p.step_servo_lead_hip : c->p.step_servo_lead;
                /* the plan's rate, low-passed over step_lead_tau so that the lead moves smoothly when
                 * the plan's rate changes at once (a switch, a landing) */
                const double rate = c->q_prev_valid ? (q[side][j] - c->q_prev[side][j]) / c->dt : 0.0;
                double cmd;
                if (!c->q_prev_valid) c->q_rate[side][j] = 0.0;
                c->q_rate[side][j] += lead_alpha * (rate - c->q_rate[side][j]);
                cmd = q[side][j] + clampd(lead * c->q_rate[side][j], -c->p.step_lead_max, c->p.step_lead_max);
                if (isnan(c->blend_from[side][j]))
                    c->blend_from[side][j] = (c->blend_from_flat && flat_q ? flat_q[side][j] : c->q_out[side][j]) - cmd;
                out->q_ref[side][j] = cmd;
                c->q_prev[side][j] = q[side][j];
            }
        c->q_prev_valid = 1;
        for (i = 0; i < 2; ++i) {
            out->com_ref[i] = r[i];
            out->zmp_plan[i] = p_cmd[i];
        }
        out->active = 1;
        blend(c, out);
    } else {
        ahc_step_handover(c, flat_q, out);
    }
}

void ahc_step_handover(ahc_stepper *c, const double flat_q[2][AHC_LEG_JOINTS], ahc_step_outputs *out)
{
    int side, j;
    if (!c || !c->valid || c->phase != AHC_STEP_STAND || !flat_q || c->steps == 0 ||
        c->blend_time >= c->p.step_blend_time)
        return;
    /* after a step: from the step's last set points to the flat-footed layers' */
    if (c->blend_time == 0.0)
        for (side = 0; side < 2; ++side)
            for (j = 0; j < AHC_LEG_JOINTS; ++j) c->blend_from[side][j] = c->q_out[side][j] - flat_q[side][j];
    for (side = 0; side < 2; ++side)
        for (j = 0; j < AHC_LEG_JOINTS; ++j) out->q_ref[side][j] = flat_q[side][j];
    out->active = 1;
    blend(c, out);
}

int ahc_step_state_consistent(const ahc_stepper *c, const ahc_params *sp, const ahc_frontal_params *fp, char *msg,
                              size_t msg_size)
{
    ahc_stepper fresh;
    int rc;
    if (msg && msg_size > 0) msg[0] = '\0';
    if (!c || !sp || !fp) return ahc_fail_message(msg, msg_size, AHC_ERR_NULL, "state pointer is NULL");
    if (!c->valid) return AHC_OK;
    rc = ahc_step_init(&fresh, &c->p, sp, fp);
    if (rc != AHC_OK) {
        ahc_step_params_validate(&c->p, sp, fp, msg, msg_size);
        return rc;
    }
    {
        /* the robot's numbers the layer copied at init must be the parameters' */
        const struct { const char *name; double a, b; } v[] = {
            {"g", c->g, fresh.g}, {"mass", c->mass, fresh.mass}, {"m1", c->m1, fresh.m1}, {"m2", c->m2, fresh.m2},
            {"lg1", c->lg1, fresh.lg1}, {"l1", c->l1, fresh.l1}, {"lg2", c->lg2, fresh.lg2},
            {"link2_com_x", c->link2_com_x, fresh.link2_com_x}, {"I1", c->I1, fresh.I1}, {"I2", c->I2, fresh.I2}, {"feet_mass", c->feet_mass, fresh.feet_mass},
            {"feet_com_x", c->feet_com_x, fresh.feet_com_x}, {"feet_com_z", c->feet_com_z, fresh.feet_com_z},
            {"ankle_height", c->ankle_height, fresh.ankle_height}, {"toe_x", c->toe_x, fresh.toe_x},
            {"heel_x", c->heel_x, fresh.heel_x}, {"sole_width", c->sole_width, fresh.sole_width},
            {"hip_y", c->hip_y, fresh.hip_y}, {"ankle_y", c->ankle_y, fresh.ankle_y}, {"omega", c->omega, fresh.omega},
            {"z_com", c->z_com, fresh.z_com}, {"thigh", c->legs.thigh, fresh.legs.thigh},
            {"shank", c->legs.shank, fresh.legs.shank}, {"legs.hip_y", c->legs.hip_y, fresh.legs.hip_y},
            {"legs.ankle_y", c->legs.ankle_y, fresh.legs.ankle_y}, {"sample_period", c->dt, fresh.dt},
            {"pitch_erect", c->pitch_erect, fresh.pitch_erect}};
        size_t i;
        for (i = 0; i < sizeof v / sizeof v[0]; ++i)
            if (memcmp(&v[i].a, &v[i].b, sizeof(double)) != 0)
                return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                            "%s = %.17g in the stepping layer's copy, %.17g from the robot's parameters", v[i].name,
                            v[i].a, v[i].b);
    }
    return ahc_step_state_validate(c, msg, msg_size);
}

int ahc_step_state_validate(const ahc_stepper *c, char *msg, size_t msg_size)
{
    int side, j, i;
    if (msg && msg_size > 0) msg[0] = '\0';
    if (!c) return ahc_fail_message(msg, msg_size, AHC_ERR_NULL, "state pointer is NULL");
    if (!c->valid) return AHC_OK;
    if (c->phase < 0 || c->phase >= AHC_STEP_PHASES)
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "stepping phase %d outside 0..%d", c->phase, AHC_STEP_PHASES - 1);
    if (c->swing_side < -1 || c->swing_side > 1 || (c->phase != AHC_STEP_STAND && c->swing_side < 0))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "stepping swing side %d invalid", c->swing_side);
    if (c->steps < 0 || c->est_valid < 0 || c->est_valid > 1 || c->q_prev_valid < 0 || c->q_prev_valid > 1 ||
        c->tilt_valid < 0 || c->tilt_valid > 1 || c->pelvis_z_valid < 0 || c->pelvis_z_valid > 1 ||
        c->blend_from_flat < 0 || c->blend_from_flat > 1 || c->close_stage < 0 || c->close_stage > 3 ||
        c->obs_valid < 0 || c->obs_valid > 2 || c->obs_Hn < 0 || c->obs_Hn > 4 || c->obs_loaded_time < 0.0 ||
        (c->close_stage != 0 && c->phase == AHC_STEP_STAND))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "stepping counters or flags corrupt");
    if (!(c->swing_time >= 0.0 && c->swing_time <= 2.0) || ((c->phase == AHC_STEP_SWING || c->phase == AHC_STEP_CLOSE) && !(c->swing_time > 0.0)))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "stepping swing time %g invalid", c->swing_time);
    {
        /* the clocks: from 0 to the time since the start (the tick count's), each at most a tick
         * more than it can have run; the soles' loaded time starts at step_impact_hold (and drops
         * to 0 when a sole unloads) */
        const double elapsed = (double)c->tick * c->dt * (1.0 + 1e-12) + c->dt;
        const double clocks[] = {c->phase_time, c->step_clock, c->blend_time, c->pitch_time, c->since_impact};
        /* the plan's values (positions [m], rates [m/s], angles [rad], times [s]): finite and within
         * STEP_STATE_MAX, which the plan keeps them in (the CoM reference's REF_MAX, REF_RATE_MAX);
         * a forged phase time of -1.4e308 was accepted and made the next tick's set points
         * non-finite */
        const double v[] = {c->phase_duration, c->knee_settle, c->c0[0], c->c0[1], c->v0[0], c->v0[1], c->cref[0],
                            c->cref[1], c->vref[0], c->vref[1], c->zmp[0], c->zmp[1], c->settle_mid[0], c->settle_mid[1],
                            c->settle_capture_time, c->tilt[0], c->tilt[1], c->pelvis_z, c->feet[0][0], c->feet[0][1],
                            c->feet[1][0], c->feet[1][1], c->landing[0], c->landing[1], c->swing_from[0],
                            c->swing_from[1], c->swing_pos[0], c->swing_pos[1], c->swing_vel[0], c->swing_vel[1],
                            c->swing_acc[0], c->swing_acc[1]};
        /* the measured ones (the estimate, the observer): finite, whatever the sensors read */
        const double measured[] = {c->xi_prev[0], c->xi_prev[1], c->pitch_prev, c->pitch_rate, c->com_prev[0],
                                   c->com_prev[1], c->com_rate[0], c->com_rate[1], c->obs_pred, c->push_moment,
                                   c->push_planned, c->obs_pitch_prev, c->obs_leg_prev[0], c->obs_leg_prev[1],
                                   c->obs_H[0], c->obs_H[1], c->obs_H[2], c->obs_H[3]};
        for (i = 0; i < (int)(sizeof measured / sizeof measured[0]); ++i)
            if (!isfinite(measured[i]))
                return ahc_fail_message(msg, msg_size, AHC_ERR_NONFINITE, "stepping estimate value %d not finite", i);
        for (i = 0; i < (int)(sizeof clocks / sizeof clocks[0]); ++i)
            if (!(clocks[i] >= -1e-12 && clocks[i] <= elapsed))
                return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "stepping clock %d = %g outside [0, %g] s (the time since the start)",
                                        i, clocks[i], elapsed);
        for (i = 0; i < (int)(sizeof v / sizeof v[0]); ++i) {
            if (!isfinite(v[i])) return ahc_fail_message(msg, msg_size, AHC_ERR_NONFINITE, "stepping state value %d not finite", i);
            if (!(fabs(v[i]) <= STEP_STATE_MAX))
                return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "stepping state value %d = %g beyond %g", i, v[i], STEP_STATE_MAX);
        }
        if (!(c->obs_loaded_time <= elapsed + c->p.step_impact_hold)) /* (>= 0: the flags' check) */
            return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "stepping loaded time %g beyond %g s (the time since the start and step_impact_hold)",
                                    c->obs_loaded_time, elapsed + c->p.step_impact_hold);
        if (!(c->phase_duration >= 0.0 && c->settle_capture_time >= 0.0))
            return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "stepping phase duration negative");
    }
    for (side = 0; side < 2; ++side)
        for (j = 0; j < AHC_LEG_JOINTS; ++j)
            if (!isfinite(c->q_out[side][j]) || !(fabs(c->q_prev[side][j]) <= STEP_STATE_MAX) ||
                !isfinite(c->q_rate[side][j]) || isinf(c->blend_from[side][j]))
                return ahc_fail_message(msg, msg_size, AHC_ERR_NONFINITE,
                                        "stepping joint reference not finite (or a planned angle beyond %g)", STEP_STATE_MAX);
    for (i = 0; i < BODIES; ++i)
        for (j = 0; j < 3; ++j)
            if (!isfinite(c->obs_body_prev[i][j]))
                return ahc_fail_message(msg, msg_size, AHC_ERR_NONFINITE, "stepping observer state not finite");
    {
        /* the swing foot's and the trunk's quintics: T within the parameters' longest (5 s), every
         * coefficient finite, and sum |c_k| T^k (a bound on |x(t)| over [0, T]) below 1e9 (m, rad),
         * far beyond any plan's (tens at most) but short of overflow: a forged NaN coefficient was
         * accepted before and made the next tick's joint references NaN */
        const ahc_quintic *q[3] = {&c->swing[0], &c->swing[1], &c->pitch_plan};
        for (i = 0; i < 3; ++i) {
            double bound = 0.0, Tk = 1.0;
            if (!(q[i]->T >= 0.0 && q[i]->T <= 5.0))
                return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "stepping quintic %d: duration %g outside [0, 5] s", i, q[i]->T);
            for (j = 0; j < 6; ++j) {
                if (!isfinite(q[i]->c[j]))
                    return ahc_fail_message(msg, msg_size, AHC_ERR_NONFINITE, "stepping quintic %d: coefficient %d not finite", i, j);
                bound += fabs(q[i]->c[j]) * Tk;
                Tk *= q[i]->T;
            }
            if (!(bound <= 1e9))
                return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "stepping quintic %d: values up to %g", i, bound);
        }
    }
    return AHC_OK;
}
