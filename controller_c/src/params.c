/*
 * params.c — defaults, the parameter metadata table (single source of truth for the FMU's
 * parameter variables), validation, and name helpers.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ahc/controller.h"
#include "ahc/frontal.h"
#include "fail_message.h"

void ahc_params_default(ahc_params *p)
{
    memset(p, 0, sizeof *p);
    /* model: hoap2/nominal.h (derived from the Webots proto by hoap2/lump.py) */
    p->g = HOAP2_G;
    p->m1 = HOAP2_M1;
    p->l1 = HOAP2_L1;
    p->lg1 = HOAP2_LG1;
    p->I1 = HOAP2_I1;
    p->m2 = HOAP2_M2;
    p->lg2 = HOAP2_LG2;
    p->I2 = HOAP2_I2;
    p->feet_mass = HOAP2_FEET_MASS;
    p->feet_com_x = HOAP2_FEET_COM_X;
    p->feet_com_z = HOAP2_FEET_COM_Z;
    p->toe_x = HOAP2_TOE_X;
    p->heel_x = HOAP2_HEEL_X;
    p->ankle_height = HOAP2_ANKLE_HEIGHT;
    p->ankle_min = HOAP2_ANKLE_MIN;
    p->ankle_max = HOAP2_ANKLE_MAX;
    p->hip_min = HOAP2_HIP_MIN;
    p->hip_max = HOAP2_HIP_MAX;

    /* gains: paper values read as N mm/rad -> SI (docs/controller.md §3) */
    p->Ka = 40.0;      /* paper 40000 N mm/rad   */
    p->Ca = 10.0;      /* paper 10000 N mm s/rad */
    p->Kh = 4.0;       /* paper 4000 N mm/rad    */
    p->Ch = 1.0;       /* paper 1000 N mm s/rad  */
    p->Kpr = 100.0;    /* paper, 1/s             */
    p->Kp_theta = 15.0;/* paper, 1/s             */

    /* phase logic. The paper's 45 mm limit leaves 12.5 mm to the toe, too little for the
     * transition (prototype finding 4, docs/controller.md §4.2). Defaults chosen by push sweeps on the plant FMU, one setting
     * at a time (docs/controller.md section 4.5): trigger at 25 mm, T_ah = 0.5 s. The paper's
     * numbers are the configuration "paper" (ahc_params_paper()). */
    p->hip_strategy_enabled = 1;
    p->zmp_limit_front = 0.025;
    p->zmp_limit_back = -0.016;    /* the same 43 % of the half-sole as the front limit */
    p->T_ah = 0.5;                 /* paper: 1 s; 0.5 s survives larger pushes (docs) */
    p->rz_band_low = -0.002;       /* paper: 264.5 mm < r_z < 266.5 mm, a 2 mm band below erect */
    p->rz_band_high = 0.001;
    p->fallback_disturbance_tol = 0.1;  /* ~1.6 mm of p - r_x with m g = 63.8 N */
    p->fallback_hip_tol = 0.05;
    p->fallback_dwell = 0.5;
    p->return_hip_angle_tol = 0.005;
    p->return_hip_rate_tol = 0.05;

    /* sensing */
    p->zmp_filter_tau = 0.0;       /* off, as in the paper: not needed for stability and no clear
                                      benefit in the push sweeps (docs 4.5); 0.01-0.03 s filters it */
    p->feet_offset_mode = AHC_FEET_IGNORE;  /* paper; the feet model changed no push limit (docs 4.5) */
    p->feet_calibration_time = 0.2;
    p->kinematics_source = AHC_KIN_REFERENCE; /* measured: the foot rocks toe<->heel (docs 4.4) */

    /* faults */
    p->fz_lifted = 10.0;           /* ~14 % of the robot's weight (70 N) */
    /* 10 x the weight (702 N): the sole sensors of a robot standing on its own feet never read
     * that much. The hip strategy's vertical accelerations stay within +-20 % of the weight; a
     * landing after the foot rocked reads its impulse over the sample period, up to 5.7 x the
     * weight measured (paper_configuration). A larger reading is a sensor fault, not a load to
     * balance against. */
    p->fz_max = 10.0 * (HOAP2_M1 + HOAP2_M2 + HOAP2_FEET_MASS) * HOAP2_G;
    p->zmp_fault_margin = 0.02;
    p->angle_fault_margin = 0.1;

    p->sample_period = HOAP2_SAMPLE_PERIOD;
    /* Off by default: the paper's estimate m g (p - r_x). Push sweeps on the plant, one setting at
     * a time, show the compensated estimate survives smaller pushes in every shape and is not
     * needed for stability (docs/controller.md sections 4.4-4.5). */
    p->reaction_compensation = 0;

    /* Our extension, off by default (docs/controller.md section 4.6). */
    p->lean_enabled = 0;
    p->lean_tau = 0.3;
    p->lean_margin = 0.015;
    /* its pendulum law, off (section 4.7): the frontal lean's numbers (docs/controller.md 11.2) */
    p->lean_law = AHC_LEAN_LOWPASS;
    p->lean_zmp_margin = 0.015;
    p->lean_capture_gain = 32.0;
}

void ahc_params_paper(ahc_params *p)
{
    ahc_params_default(p);
    p->zmp_limit_front = 0.045;  /* paper: p_lim = 45 mm (12.5 mm from the toe) */
    p->zmp_limit_back = -0.025;  /* same 12.5 mm margin at the heel (our symmetric extension) */
    p->T_ah = 1.0;               /* paper: 1 s */
}

/* Pushes from every direction on the 3D plant (docs/controller.md section 4.7, docs/capability.md
 * section 7.7): the default with the sagittal pendulum lean, chosen by polar limit searches one
 * setting at a time (scripts/polar_limits.py). Its frontal part is ahc_frontal_params_named's. */
static void params_omnidirectional(ahc_params *p)
{
    ahc_params_default(p);
    p->lean_enabled = 1;
    p->lean_law = AHC_LEAN_PENDULUM;
    p->lean_tau = 0.03;      /* the frontal lean's estimate */
    p->lean_margin = 0.0325; /* the plan's CoM and capture point 32.5 mm inside toe and heel */
    p->T_ah = 1.0;           /* the paper's transition time */
}

static const struct {
    const char *name;
    const char *description;
    void (*fill)(ahc_params *);
} k_configs[] = {
    {"default", "The paper's law with reference kinematics for eqs. 23-24, p_lim = 25 mm and T_ah = 0.5 s, "
                "chosen by push sweeps on the plant (docs/controller.md section 4.5)",
     ahc_params_default},
    {"paper", "Nenchev & Nishio (ICRA 2010) as published: p_lim = 45 mm, T_ah = 1 s (docs/controller.md section 4.5)",
     ahc_params_paper},
    {"omnidirectional", "Pushes from every direction on the 3D robot: the default with our sagittal pendulum lean "
                        "(lean_law = 1, lean_tau = 30 ms, lean_margin = 32.5 mm) and T_ah = 1 s; at least 80 % of the "
                        "static tipping force for 1 s pulses in every direction (docs/controller.md section 4.7)",
     params_omnidirectional},
};
#define N_CONFIGS (sizeof k_configs / sizeof k_configs[0])

size_t ahc_config_count(void) { return N_CONFIGS; }

const char *ahc_config_name(size_t i) { return i < N_CONFIGS ? k_configs[i].name : NULL; }

const char *ahc_config_description(size_t i) { return i < N_CONFIGS ? k_configs[i].description : NULL; }

int ahc_params_named(ahc_params *p, const char *name)
{
    size_t i;
    for (i = 0; name != NULL && i < N_CONFIGS; ++i) {
        if (strcmp(name, k_configs[i].name) == 0) {
            k_configs[i].fill(p);
            return AHC_OK;
        }
    }
    ahc_params_default(p);
    return AHC_ERR_UNKNOWN_NAME;
}

/* ------------------------------------------------------------------------------------------- */

#define PI_D(field, unit, lo, hi, desc) \
    { #field, unit, desc, lo, hi, offsetof(ahc_params, field), 0 }
#define PI_I(field, lo, hi, desc) \
    { #field, "", desc, lo, hi, offsetof(ahc_params, field), 1 }

/* Append new rows at the end only: the FMU derives value references from the row index.
 * Ranges are closed and physically meaningful (a positive quantity's minimum is the smallest
 * value that still means something for a legged robot, not 0 excluded): the FMU declares them as
 * min/max, so an importer is refused at set time, not only at initialization. */
static const ahc_param_info k_table[] = {
    PI_D(g, "m/s2", 0.1, 100.0, "Gravitational acceleration"),
    PI_D(m1, "kg", 0.01, 1000.0, "Mass of link 1 (both legs, ankle to hip)"),
    PI_D(l1, "m", 0.001, 10.0, "Length of link 1, ankle axis to hip axis"),
    PI_D(lg1, "m", 0.001, 10.0, "Distance ankle axis to CoM of link 1"),
    PI_D(I1, "kg.m2", 0.0, 100.0, "Inertia of link 1 about its CoM (pitch)"),
    PI_D(m2, "kg", 0.01, 1000.0, "Mass of link 2 (upper body)"),
    PI_D(lg2, "m", 0.001, 10.0, "Distance hip axis to CoM of link 2"),
    PI_D(I2, "kg.m2", 0.0, 100.0, "Inertia of link 2 about its CoM (pitch)"),
    PI_D(feet_mass, "kg", 0.0, 1000.0, "Mass of both feet (used by feet_offset_mode = 1)"),
    PI_D(feet_com_x, "m", -1.0, 1.0, "Feet CoM x forward of the ankle axis"),
    PI_D(feet_com_z, "m", 0.0, 1.0, "Feet CoM height above the sole (informational; not used by the control laws)"),
    PI_D(toe_x, "m", 0.001, 1.0, "Toe edge x from the ankle axis (> 0)"),
    PI_D(heel_x, "m", -1.0, -0.001, "Heel edge x from the ankle axis (< 0)"),
    PI_D(ankle_height, "m", 0.0, 1.0, "Ankle axis height above the sole (lever of the disturbance moment balance)"),
    PI_D(ankle_min, "rad", -3.2, 0.0, "Ankle joint lower limit"),
    PI_D(ankle_max, "rad", 0.0, 3.2, "Ankle joint upper limit"),
    PI_D(hip_min, "rad", -3.2, 0.0, "Hip joint lower limit"),
    PI_D(hip_max, "rad", 0.0, 3.2, "Hip joint upper limit"),
    PI_D(Ka, "N.m/rad", 1e-3, 1e6, "Ankle virtual stiffness (eq. 11; paper 40000 N.mm/rad)"),
    PI_D(Ca, "N.m.s/rad", 0.0, 1e6, "Ankle virtual damping (eq. 11; paper 10000 N.mm.s/rad)"),
    PI_D(Kh, "N.m/rad", 1e-3, 1e6, "Hip virtual stiffness (eq. 16; paper 4000 N.mm/rad)"),
    PI_D(Ch, "N.m.s/rad", 0.0, 1e6, "Hip virtual damping (eq. 16; paper 1000 N.mm.s/rad)"),
    PI_D(Kpr, "1/s", 1e-3, 1e6, "CoM projection feedback gain (eq. 24)"),
    PI_D(Kp_theta, "1/s", 1e-3, 1e6, "Hip return regulator gain (eq. 25)"),
    PI_I(hip_strategy_enabled, 0.0, 1.0,
         "1: ankle and hip strategies with transitions; 0: ankle strategy only"),
    PI_D(zmp_limit_front, "m", 0.001, 1.0,
         "ZMP safety limit on the toe side (x coordinate) that starts the ankle-to-hip transition"),
    PI_D(zmp_limit_back, "m", -1.0, -0.001,
         "ZMP safety limit on the heel side (x coordinate, < 0) for pushes from the front"),
    PI_D(T_ah, "s", 0.002, 100.0, "Duration of the ankle-to-hip transition"),
    PI_D(rz_band_low, "m", -1.0, 0.0,
         "Hip-to-ankle trigger: lower edge of the CoM height band relative to erect"),
    PI_D(rz_band_high, "m", 0.0, 1.0,
         "Hip-to-ankle trigger: upper edge of the CoM height band relative to erect"),
    PI_D(fallback_disturbance_tol, "N.m", 0.0, 100.0,
         "Hip-to-ankle fallback: disturbance moment magnitude below this"),
    PI_D(fallback_hip_tol, "rad", 0.0, 3.2,
         "Hip-to-ankle fallback: hip reference magnitude below this"),
    PI_D(fallback_dwell, "s", 0.0, 100.0,
         "Hip-to-ankle fallback: time both fallback conditions must hold"),
    PI_D(return_hip_angle_tol, "rad", 1e-6, 1.0,
         "Return to the ankle strategy when |hip reference| is below this"),
    PI_D(return_hip_rate_tol, "rad/s", 1e-6, 10.0,
         "Return to the ankle strategy when |hip reference rate| is below this"),
    PI_D(zmp_filter_tau, "s", 0.0, 10.0, "Time constant of the ZMP low-pass filter (0 = off)"),
    PI_I(feet_offset_mode, 0.0, 2.0,
         "Feet in the disturbance estimate: 0 ignore (paper), 1 model, 2 calibrate at rest"),
    PI_D(feet_calibration_time, "s", 0.0, 100.0,
         "Averaging time of the at-rest calibration (feet_offset_mode = 2)"),
    PI_I(kinematics_source, 0.0, 1.0,
         "Angles for r_x, r_z, C1, C12: 0 measured, 1 controller reference"),
    PI_D(fz_lifted, "N", 0.0, 1e4, "Normal force below which the robot counts as lifted"),
    PI_D(zmp_fault_margin, "m", 0.0, 1.0,
         "ZMP beyond a sole edge by more than this is a sensor fault"),
    PI_D(angle_fault_margin, "rad", 0.0, 3.2,
         "Measured angle beyond its joint limit by more than this is a sensor fault"),
    PI_D(sample_period, "s", 1e-5, 0.1, "Control period; one ahc_step advances by this (10 us to 100 ms)"),
    PI_I(reaction_compensation, 0.0, 1.0,
         "Disturbance estimate: 1 moment balance minus the measured motion's reaction, 0 paper m g (p - r_x)"),
    PI_D(fz_max, "N", 1.0, 1e5,
         "Normal force above this is an implausible sensor reading (fault, hold): several times the robot's weight"),
    PI_I(lean_enabled, 0.0, 1.0,
         "Sustained-push lean (our extension, not the paper's): 1 the CoM reference of phases 1-3 leans against the low-passed disturbance"),
    PI_D(lean_tau, "s", 0.01, 100.0, "Time constant of the disturbance low-pass the lean follows"),
    PI_D(lean_margin, "m", 0.0, 1.0, "The leaned CoM reference stays this far inside the toe and heel edges"),
    PI_D(link1_com_x, "m", -1.0, 1.0,
         "Link 1 (legs): CoM forward of the ankle-hip line, perpendicular to it (0 = on the line, paper)"),
    PI_D(link2_com_x, "m", -1.0, 1.0,
         "Link 2 (upper body): CoM forward of its line through the hip, perpendicular to it (0 = on the line, paper)"),
    PI_I(lean_law, 0.0, 1.0,
         "Sagittal lean law (with lean_enabled; our extension): 0 the low-passed disturbance in phases 1-3; 1 the inverted pendulum's CoM, its ZMP planned by capture-point feedback, in every phase"),
    PI_D(lean_zmp_margin, "m", 0.0, 1.0, "Lean law 1: the planned ZMP stays this far inside the toe and heel edges"),
    PI_D(lean_capture_gain, "1", 0.01, 100.0, "Lean law 1: the capture point converges at this multiple of the pendulum's rate"),
};

#define TABLE_LEN (sizeof k_table / sizeof k_table[0])

const ahc_param_info *ahc_param_table(size_t *count)
{
    if (count) *count = TABLE_LEN;
    return k_table;
}

const ahc_param_info *ahc_param_find(const char *name)
{
    size_t i;
    if (!name) return NULL;
    for (i = 0; i < TABLE_LEN; ++i)
        if (strcmp(k_table[i].name, name) == 0) return &k_table[i];
    return NULL;
}

/* ------------------------------------------------------------------------------------------- */


static double field_value(const ahc_params *p, const ahc_param_info *e)
{
    const char *base = (const char *)p + e->offset;
    if (e->is_int) {
        int v;
        memcpy(&v, base, sizeof v);
        return (double)v;
    }
    {
        double v;
        memcpy(&v, base, sizeof v);
        return v;
    }
}

/* Stability of semi-implicit Euler on x'' = -k x - c x' with step h (Jury criterion on
 * lambda^2 - (2 - hc - h^2 k) lambda + (1 - hc)): 0 < hc < 2 and 4 - 2hc - h^2 k > 0. */
static int symplectic_stable(double h, double k, double c)
{
    return h * c < 2.0 && 4.0 - 2.0 * h * c - h * h * k > 0.0;
}

int ahc_params_validate(const ahc_params *p, char *msg, size_t msg_size)
{
    size_t i;
    double h, Jmin;
    if (msg && msg_size > 0) msg[0] = '\0';
    if (!p) return ahc_fail_message(msg, msg_size, AHC_ERR_NULL, "params pointer is NULL");

    for (i = 0; i < TABLE_LEN; ++i) {
        const ahc_param_info *e = &k_table[i];
        const double v = field_value(p, e);
        if (!isfinite(v))
            return ahc_fail_message(msg, msg_size, AHC_ERR_NONFINITE, "%s = %g must be finite", e->name, v);
        if (v < e->min)
            return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "%s = %.6g must be >= %.6g", e->name, v, e->min);
        if (v > e->max)
            return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "%s = %.6g must be <= %.6g", e->name, v, e->max);
    }

    if (!(p->heel_x < 0.0))
        return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "heel_x = %.6g must be < 0", p->heel_x);
    if (!(p->zmp_limit_back < 0.0))
        return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE,
                    "zmp_limit_back = %.6g must be < 0 (x coordinate on the heel side)",
                    p->zmp_limit_back);
    if (!(p->zmp_limit_front < p->toe_x))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "zmp_limit_front = %.6g lies outside the foot (toe at %.6g)",
                    p->zmp_limit_front, p->toe_x);
    if (!(p->zmp_limit_back > p->heel_x))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "zmp_limit_back = %.6g lies outside the foot (heel at %.6g)",
                    p->zmp_limit_back, p->heel_x);
    if (!(p->lg1 <= p->l1))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "lg1 = %.6g must be <= l1 = %.6g (CoM of link 1 lies on the link)", p->lg1, p->l1);
    if (!(p->ankle_min < p->ankle_max))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "ankle_min = %.6g must be < ankle_max = %.6g",
                    p->ankle_min, p->ankle_max);
    if (!(p->hip_min < p->hip_max))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "hip_min = %.6g must be < hip_max = %.6g",
                    p->hip_min, p->hip_max);
    if (!(p->fz_lifted < p->fz_max))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "fz_lifted = %.6g must be < fz_max = %.6g",
                    p->fz_lifted, p->fz_max);
    if (!(p->lean_margin < p->toe_x && p->lean_margin < -p->heel_x))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "lean_margin = %.6g must be < toe_x = %.6g and < -heel_x = %.6g (the lean range must hold 0)",
                    p->lean_margin, p->toe_x, -p->heel_x);
    if (!(p->lean_zmp_margin < p->toe_x && p->lean_zmp_margin < -p->heel_x))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "lean_zmp_margin = %.6g must be < toe_x = %.6g and < -heel_x = %.6g", p->lean_zmp_margin,
                    p->toe_x, -p->heel_x);
    if (!(p->rz_band_low < p->rz_band_high))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "rz_band_low = %.6g must be < rz_band_high = %.6g", p->rz_band_low, p->rz_band_high);

    h = p->sample_period;
    if (!(p->T_ah >= 2.0 * h))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "T_ah = %.6g must be at least two sample periods (sample_period = %.6g)", p->T_ah, h);
    if (p->feet_offset_mode == AHC_FEET_CALIBRATE && !(p->feet_calibration_time >= h))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "feet_calibration_time = %.6g must be >= sample_period = %.6g with feet_offset_mode = 2",
                    p->feet_calibration_time, h);

    /* Discrete-time stability of the reference integrators at this sample period. */
    Jmin = p->I1 + p->m1 * p->lg1 * p->lg1 + p->I2 + p->m2 * (p->l1 - p->lg2) * (p->l1 - p->lg2);
    if (!symplectic_stable(h, p->Ka / Jmin, p->Ca / Jmin))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "sample_period = %.6g too large for the ankle law (Ka = %.6g, Ca = %.6g): "
                    "semi-implicit Euler unstable", h, p->Ka, p->Ca);
    {
        const double J2 = p->I2 + p->m2 * p->lg2 * p->lg2;
        if (!(J2 > 0.0) || !symplectic_stable(h, p->Kh / J2, p->Ch / J2))
            return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                        "sample_period = %.6g too large for the hip law (Kh = %.6g, Ch = %.6g): "
                        "semi-implicit Euler unstable", h, p->Kh, p->Ch);
    }
    if (p->lean_enabled && p->lean_law == AHC_LEAN_PENDULUM) {
        /* section 4.7's pendulum unclamped: c'' = -k w^2 (c - target) - (1 + k) w c' */
        double th1, th2, rz;
        ahc_erect_posture(p, &th1, &th2);
        ahc_com(p, th1, th2, NULL, &rz);
        {
            const double w = sqrt(p->g / (rz + p->ankle_height)), k = p->lean_capture_gain;
            if (!symplectic_stable(h, k * w * w, (1.0 + k) * w))
                return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                            "sample_period = %.6g too large for the pendulum lean (lean_capture_gain = %.6g): "
                            "semi-implicit Euler unstable", h, k);
        }
    }
    if (!(h * p->Kp_theta < 1.0))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "Kp_theta = %.6g too large for sample_period = %.6g (need Kp_theta * h < 1)",
                    p->Kp_theta, h);
    if (!(h * p->Kpr < 1.0))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "Kpr = %.6g too large for sample_period = %.6g (need Kpr * h < 1)", p->Kpr, h);
    return AHC_OK;
}

/* ------------------------------------------------------------------------------------------- */

const char *ahc_phase_name(int phase)
{
    switch (phase) {
    case AHC_PHASE_ANKLE: return "ankle";
    case AHC_PHASE_ANKLE_TO_HIP: return "ankle_to_hip";
    case AHC_PHASE_HIP: return "hip";
    case AHC_PHASE_HIP_TO_ANKLE: return "hip_to_ankle";
    default: return "unknown";
    }
}

const char *ahc_error_string(int code)
{
    switch (code) {
    case AHC_OK: return "ok";
    case AHC_ERR_NULL: return "NULL argument";
    case AHC_ERR_NONFINITE: return "non-finite parameter";
    case AHC_ERR_RANGE: return "parameter out of range";
    case AHC_ERR_INCONSISTENT: return "inconsistent parameters";
    case AHC_ERR_UNKNOWN_NAME: return "unknown configuration name";
    default: return "unknown error";
    }
}

typedef struct { unsigned bit; const char *name; } fault_name;

/* The names of the bits of `fault` that `names` lists, comma-separated, into msg. */
static const char *fault_names(const fault_name *names, size_t count, unsigned fault, char *msg, size_t msg_size)
{
    size_t i, used = 0;
    if (!msg || msg_size == 0) return msg;
    msg[0] = '\0';
    for (i = 0; i < count; ++i) {
        if (fault & names[i].bit) {
            int n = snprintf(msg + used, msg_size - used, "%s%s", used ? "," : "", names[i].name);
            if (n < 0 || (size_t)n >= msg_size - used) break;
            used += (size_t)n;
        }
    }
    return msg;
}

const char *ahc_fault_string(unsigned fault, char *msg, size_t msg_size)
{
    static const fault_name names[] = {
        { AHC_FAULT_THETA_ANKLE_NONFINITE, "theta_ankle_nonfinite" },
        { AHC_FAULT_THETA_HIP_NONFINITE, "theta_hip_nonfinite" },
        { AHC_FAULT_ZMP_NONFINITE, "zmp_nonfinite" },
        { AHC_FAULT_FZ_NONFINITE, "fz_nonfinite" },
        { AHC_FAULT_ZMP_OUTSIDE_FOOT, "zmp_outside_foot" },
        { AHC_FAULT_LIFTED, "lifted" },
        { AHC_FAULT_ANGLE_RANGE, "angle_range" },
        { AHC_FAULT_REF_SATURATED, "ref_saturated" },
        { AHC_FAULT_NOT_INITIALIZED, "not_initialized" },
        { AHC_FAULT_FZ_IMPLAUSIBLE, "fz_implausible" },
    };
    return fault_names(names, sizeof names / sizeof names[0], fault, msg, msg_size);
}

const char *ahc_frontal_fault_string(unsigned fault, char *msg, size_t msg_size)
{
    static const fault_name names[] = {
        { AHC_FFAULT_ZMP_Y_NONFINITE, "zmp_y_nonfinite" },
        { AHC_FFAULT_ANGLE_NONFINITE, "angle_nonfinite" },
        { AHC_FFAULT_ZMP_Y_OUTSIDE, "zmp_y_outside" },
        { AHC_FFAULT_LIFTED, "lifted" },
        { AHC_FFAULT_REF_SATURATED, "ref_saturated" },
        { AHC_FFAULT_NOT_INITIALIZED, "not_initialized" },
    };
    return fault_names(names, sizeof names / sizeof names[0], fault, msg, msg_size);
}
