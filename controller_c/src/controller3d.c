/*
 * controller3d.c — the sagittal and frontal controllers side by side and the legs' set points
 * (controller3d.h, docs/controller.md §11.4).
 */
#include <math.h>
#include <string.h>

#include "ahc/controller3d.h"

static void geometry(ahc3d *c)
{
    c->legs.thigh = c->frontal.f.thigh;
    c->legs.shank = c->frontal.f.shank;
    c->legs.hip_y = c->frontal.f.hip_y;
    c->legs.ankle_y = c->frontal.f.ankle_y;
}

int ahc3d_init(ahc3d *c, const ahc_params *sp, const ahc_frontal_params *fp)
{
    ahc_step_params stp;
    ahc_step_params_default(&stp);
    return ahc3d_init_stepping(c, sp, fp, &stp);
}

int ahc3d_init_stepping(ahc3d *c, const ahc_params *sp, const ahc_frontal_params *fp, const ahc_step_params *stp)
{
    int rc;
    if (!c) return AHC_ERR_NULL;
    memset(c, 0, sizeof *c);
    rc = ahc_init(&c->sag, sp);
    if (rc != AHC_OK) return rc;
    rc = ahc_frontal_init(&c->frontal, fp, sp);
    geometry(c);
    if (rc != AHC_OK) return rc;
    return ahc_step_init(&c->step, stp, sp, fp);
}

void ahc3d_reset(ahc3d *c)
{
    ahc_reset(&c->sag);
    ahc_frontal_reset(&c->frontal);
    ahc_step_reset(&c->step);
    geometry(c);
}

/* The frontal layer's sensors: the frontal angles measured on the pivot leg the frontal reference
 * names (NaN when a joint reading is not finite); without `angles`, 0 in their place when the
 * readings are finite (for the sensor checks, which read only whether they are). */
static void frontal_sensors(const ahc3d *c, const ahc3d_sensors *s, int angles, ahc_frontal_sensors *fs)
{
    int side, j, finite = 1;
    fs->zmp_y = s->zmp_y;
    fs->fz = s->sag.fz;
    fs->fz_left = s->fz_left;
    fs->fz_right = s->fz_right;
    fs->phi = fs->psi = NAN;
    for (side = 0; side < 2; ++side)
        for (j = 0; j < AHC_LEG_JOINTS; ++j) finite = finite && isfinite(s->q[side][j]);
    if (finite && angles) ahc_legs_frontal_angles(&c->legs, s->q, c->frontal.psi >= 0.0, &fs->phi, &fs->psi);
    else if (finite) fs->phi = fs->psi = 0.0;
    /* the feet's roll toward +y: the trunk's lean toward +y (-imu_roll) less link 2's lean on flat feet */
    fs->foot_roll = -s->imu_roll - fs->psi;
}

/* The flat-footed layers: the paper's sagittal controller, the frontal one, the legs' set points. */
static void flat_footed(ahc3d *c, const ahc3d_sensors *s, ahc3d_outputs *out)
{
    ahc_frontal_sensors fs;
    int side, j;
    /* 1. the paper's controller, on the sagittal sensors alone */
    ahc_step(&c->sag, &s->sag, &out->sag);
    /* 2. the frontal angles */
    frontal_sensors(c, s, 1, &fs);
    /* 3. the frontal controller */
    ahc_frontal_step(&c->frontal, &fs, &out->frontal);
    /* 4. the legs: both planes' references minus the sagittal ones alone, which are the pitch
     * angles th1, th2 on both legs (the straight legs' kinematics, leg_ik.h) */
    if (out->frontal.phi_ref != 0.0 || out->frontal.psi_ref != 0.0) {
        double full[2][AHC_LEG_JOINTS];
        const double th1 = out->sag.theta_ankle_ref, th2 = out->sag.theta_hip_ref;
        out->legs_out_of_reach = ahc_legs_from_planes(&c->legs, th1, th2, out->frontal.phi_ref,
                                                      out->frontal.psi_ref, full);
        for (side = 0; side < 2; ++side) {
            for (j = 0; j < AHC_LEG_JOINTS; ++j) out->q_ref_offset[side][j] = full[side][j];
            out->q_ref_offset[side][AHC_LEG_ANKLE_PITCH] -= th1;
            out->q_ref_offset[side][AHC_LEG_HIP_PITCH] -= th2;
        }
    }
}

/* Both legs' joint set points of the outputs: both-legs + per-leg. */
static void joint_set_points(const ahc3d_outputs *out, double q[2][AHC_LEG_JOINTS])
{
    int side, j;
    for (side = 0; side < 2; ++side)
        for (j = 0; j < AHC_LEG_JOINTS; ++j) q[side][j] = out->q_ref_offset[side][j];
    for (side = 0; side < 2; ++side) {
        q[side][AHC_LEG_ANKLE_PITCH] += out->sag.theta_ankle_ref;
        q[side][AHC_LEG_HIP_PITCH] += out->sag.theta_hip_ref;
    }
}

/* The stepping layer's set points as both-legs pitch (the legs' mean) + per-leg. */
static void from_step(ahc3d_outputs *out)
{
    int side, j;
    double (*q)[AHC_LEG_JOINTS] = out->step.q_ref;
    const double th1 = 0.5 * (q[0][AHC_LEG_ANKLE_PITCH] + q[1][AHC_LEG_ANKLE_PITCH]);
    const double th2 = 0.5 * (q[0][AHC_LEG_HIP_PITCH] + q[1][AHC_LEG_HIP_PITCH]);
    out->sag.theta_ankle_ref = th1;
    out->sag.theta_hip_ref = th2;
    out->sag.dtheta_ankle_ref = out->sag.dtheta_hip_ref = 0.0;
    for (side = 0; side < 2; ++side)
        for (j = 0; j < AHC_LEG_JOINTS; ++j) out->q_ref_offset[side][j] = q[side][j];
    for (side = 0; side < 2; ++side) {
        out->q_ref_offset[side][AHC_LEG_ANKLE_PITCH] -= th1;
        out->q_ref_offset[side][AHC_LEG_HIP_PITCH] -= th2;
    }
}

/* The sensor faults reported while a step runs: the non-finite readings and angles outside the
 * joint ranges. Not an implausible load: a landing's impact reads above fz_max (10 x the weight) for
 * a sample (704 N on Hoap2Plant3D under a 17.5 mm ZMP bias). */
#define STEP_SENSOR_FAULTS                                                                        \
    (AHC_FAULT_THETA_ANKLE_NONFINITE | AHC_FAULT_THETA_HIP_NONFINITE | AHC_FAULT_ZMP_NONFINITE | \
     AHC_FAULT_FZ_NONFINITE | AHC_FAULT_ANGLE_RANGE)
#define STEP_FRONTAL_SENSOR_FAULTS (AHC_FFAULT_ZMP_Y_NONFINITE | AHC_FFAULT_ANGLE_NONFINITE)

void ahc3d_step(ahc3d *c, const ahc3d_sensors *s, ahc3d_outputs *out)
{
    ahc_step_sensors ss;
    double flat_q[2][AHC_LEG_JOINTS];
    int stepping, side, j;
    memset(out, 0, sizeof *out);
    if (!c->step.p.stepping_enabled || !c->step.valid) {
        /* stepping off: the flat-footed layers alone, as before the stepping layer existed */
        flat_footed(c, s, out);
        out->step.swing_side = -1;
        return;
    }
    for (side = 0; side < 2; ++side)
        for (j = 0; j < AHC_LEG_JOINTS; ++j) ss.q[side][j] = s->q[side][j];
    ss.imu_roll = s->imu_roll;
    ss.imu_pitch = s->imu_pitch;
    ss.fz_left = s->fz_left;
    ss.fz_right = s->fz_right;
    ss.zmp_x = s->sag.zmp_x;
    stepping = c->step.phase != AHC_STEP_STAND;
    if (!stepping) {
        flat_footed(c, s, out);
        joint_set_points(out, flat_q);
        ahc_step_step(&c->step, &ss, (const double(*)[AHC_LEG_JOINTS])flat_q, &out->step);
    } else {
        /* while a step runs the flat-footed layers rest; when it ends they restart from the posture
         * (their bumpless start) and the step's last set points blend into theirs */
        ahc_step_step(&c->step, &ss, NULL, &out->step);
        if (out->step.phase != AHC_STEP_STAND) {
            ahc_frontal_sensors fs;
            /* the resting layers' clocks run on (their tick counts are the instance's time) */
            c->sag.tick++;
            c->frontal.tick++;
            /* and their sensor checks report on (the step holds its estimate through a bad reading):
             * those that hold whatever the stance (STEP_SENSOR_FAULTS); a ZMP beyond the feet side
             * by side, or a lifted robot, is not a fault while the feet are apart or one swings */
            frontal_sensors(c, s, 0, &fs);
            out->sag.fault = ahc_sensor_faults(&c->sag.p, &s->sag) & STEP_SENSOR_FAULTS;
            out->frontal.fault = ahc_frontal_sensor_faults(&c->frontal, &fs) & STEP_FRONTAL_SENSOR_FAULTS;
        } else {
            const unsigned long long sag_tick = c->sag.tick, frontal_tick = c->frontal.tick;
            ahc_reset(&c->sag);
            ahc_frontal_reset(&c->frontal);
            c->sag.tick = sag_tick;
            c->frontal.tick = frontal_tick;
            {
                ahc_step_outputs keep = out->step;
                flat_footed(c, s, out);
                out->step = keep;
            }
            joint_set_points(out, flat_q);
            ahc_step_handover(&c->step, (const double(*)[AHC_LEG_JOINTS])flat_q, &out->step);
        }
    }
    if (out->step.active) from_step(out);
}

int ahc3d_state_validate(const ahc3d *c, char *msg, size_t msg_size)
{
    int rc;
    if (!c) return AHC_ERR_NULL;
    rc = ahc_state_validate(&c->sag, msg, msg_size);
    if (rc != AHC_OK) return rc;
    rc = ahc_frontal_state_validate(&c->frontal, msg, msg_size);
    if (rc != AHC_OK) return rc;
    rc = c->frontal.valid ? ahc_step_state_consistent(&c->step, &c->sag.p, &c->frontal.f, msg, msg_size)
                          : ahc_step_state_validate(&c->step, msg, msg_size);
    if (rc != AHC_OK) return rc;
    if (c->legs.thigh != c->frontal.f.thigh || c->legs.shank != c->frontal.f.shank ||
        c->legs.hip_y != c->frontal.f.hip_y || c->legs.ankle_y != c->frontal.f.ankle_y)
        return AHC_ERR_INCONSISTENT;
    if (c->frontal.valid) {
        /* the frontal layer's copy of the sagittal parameters must be the sagittal layer's */
        size_t n, i;
        const ahc_param_info *t = ahc_param_table(&n);
        for (i = 0; i < n; ++i) {
            const char *x = (const char *)&c->frontal.sp + t[i].offset, *y = (const char *)&c->sag.p + t[i].offset;
            if (memcmp(x, y, t[i].is_int ? sizeof(int) : sizeof(double)) != 0) return AHC_ERR_INCONSISTENT;
        }
    }
    return AHC_OK;
}
