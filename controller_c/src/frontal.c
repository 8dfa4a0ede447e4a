/*
 * frontal.c — the four-phase ankle/hip controller in the frontal plane (docs/controller.md §11):
 * the sagittal controller's structure (controller.c) with the frontal model of frontal_model.c.
 *
 * One tick: classify the inputs (hold on a fault); filter zmp_y; the frontal kinematics and the
 * disturbance d_y = m g (p_y - r_y); the phase switches; the law of the phase:
 *   phase 0  F11 phi (lateral ankle strategy), F25 psi (regulator to level);
 *   phase 1  F16 psi (lateral hip strategy), F23 phi with k_w: 0 -> 1 and r_y_d: r_y -> 0 (quintics);
 *   phase 2  F16 psi, F23 phi with k_w = 1, r_y_d = 0;
 *   phase 3  F25 psi, F23 phi; back to 0 when link 2 is level again.
 * The kinematic laws (F23-F24) use the reference angles (the sagittal default, kinematics_source
 * = reference); d_y and the com_y output the measured ones.
 */
#include <math.h>
#include <string.h>

#include "ahc/frontal.h"
#include "frontal_pose.h"
#include "param_rows.h"
#include "transition_splines.h"


static double clampd(double v, double lo, double hi) { return v < lo ? lo : (v > hi ? hi : v); }

/* The lean holds its estimate while the ZMP is this close to an outer edge [m] (as controller.c). */
#define LEAN_EDGE 0.002

/* ------------------------------------------------------------------------------------------- */
/* Parameters */

void ahc_frontal_params_default(ahc_frontal_params *f)
{
    memset(f, 0, sizeof *f);
    f->frontal_enabled = 1;
    f->hip_y = HOAP2_HIP_Y;
    f->ankle_y = HOAP2_ANKLE_Y;
    f->thigh = HOAP2_THIGH;
    f->shank = HOAP2_SHANK;
    f->I1_roll = HOAP2_I1_ROLL;
    f->I2_roll = HOAP2_I2_ROLL;
    f->link1_com_y = HOAP2_LINK1_COM_Y;
    f->link2_com_y = HOAP2_LINK2_COM_Y;
    f->sole_width = HOAP2_SOLE_WIDTH;
    f->ankle_roll_max = HOAP2_ANKLE_ROLL_MAX;
    f->hip_abduction_max = HOAP2_HIP_ABDUCTION_MAX;
    f->hip_adduction_max = HOAP2_HIP_ADDUCTION_MAX;
    f->knee_max = HOAP2_KNEE_MAX;
    /* The sagittal gains carried over at the same natural frequency and damping ratio on the
     * frontal inertias (docs/controller.md §11.3): K_y = K J_y / J, C_y = C J_y / J, with the
     * erect sagittal inertias J = 0.505 (ankle) and 0.073 kg m^2 (hip): Ka_y 19, Ca_y 4.75 (the
     * configuration "paper"); the default ankle is stiffer, on evidence (§11.5): 250 N m/rad at
     * the same damping ratio. */
    f->Ka_y = 250.0;
    f->Ca_y = 17.1;
    f->Kh_y = 5.0;
    f->Ch_y = 1.25;
    f->Kpr_y = 100.0;
    f->Kp_psi = 15.0;
    f->hip_strategy_enabled_y = 0;  /* the lateral hip strategy stands smaller pushes (§11.5) */
    f->zmp_limit_y = 0.035;
    f->T_ah_y = 0.5;
    f->rz_band_low_y = -0.002;
    f->rz_band_high_y = 0.001;
    f->fallback_disturbance_tol_y = 0.1;
    f->fallback_hip_tol_y = 0.05;
    f->fallback_dwell_y = 0.5;
    f->return_psi_tol = 0.005;
    f->return_psi_rate_tol = 0.05;
    f->zmp_filter_tau_y = 0.0;
    f->zmp_fault_margin_y = 0.02;
    f->lean_enabled_y = 1;
    f->lean_tau_y = 0.03;
    f->lean_margin_y = 0.01;
    f->fz_rocking_y = 0.0;
    f->lean_law_y = AHC_LEAN_PENDULUM;
    f->lean_zmp_margin_y = 0.015;
    f->lean_capture_gain_y = 32.0;
    f->roll_rocking_y = 0.01;
    f->rocking_dwell_y = 0.05;
}

void ahc_frontal_params_paper(ahc_frontal_params *f)
{
    ahc_frontal_params_default(f);
    f->Ka_y = 19.0;
    f->Ca_y = 4.75;
    f->hip_strategy_enabled_y = 1;
    f->lean_enabled_y = 0;
}

int ahc_frontal_params_named(ahc_frontal_params *f, const char *name)
{
    if (name && strcmp(name, "default") == 0) {
        ahc_frontal_params_default(f);
        return AHC_OK;
    }
    if (name && strcmp(name, "paper") == 0) {
        ahc_frontal_params_paper(f);
        return AHC_OK;
    }
    if (name && strcmp(name, "omnidirectional") == 0) {
        /* the frontal defaults (docs/controller.md section 4.7) */
        ahc_frontal_params_default(f);
        return AHC_OK;
    }
    ahc_frontal_params_default(f);
    return AHC_ERR_UNKNOWN_NAME;
}

#define FD(field, unit, lo, hi, desc) \
    { #field, unit, desc, lo, hi, offsetof(ahc_frontal_params, field), 0 }
#define FI(field, lo, hi, desc) \
    { #field, "", desc, lo, hi, offsetof(ahc_frontal_params, field), 1 }

/* Append new rows at the end only (value references). The names carry their plane: the FMU
 * lists them beside the sagittal parameters. */
static const ahc_param_info k_ftable[] = {
    FI(frontal_enabled, 0.0, 1.0, "Frontal plane: 1 the lateral ankle and hip strategies run; 0 the frontal references stay 0"),
    FD(hip_y, "m", 0.001, 1.0, "Frontal model: hip joints across from the mid-plane"),
    FD(ankle_y, "m", 0.001, 1.0, "Frontal model: ankle joints across from the mid-plane (half the stance width)"),
    FD(thigh, "m", 0.001, 10.0, "Leg: hip axes to knee axis"),
    FD(shank, "m", 0.001, 10.0, "Leg: knee axis to ankle axes"),
    FD(I1_roll, "kg.m2", 0.0, 100.0, "Roll inertia of both legs' link-1 parts, each about its own CoM"),
    FD(I2_roll, "kg.m2", 0.0, 100.0, "Roll inertia of link 2 (upper body) about its CoM"),
    FD(link1_com_y, "m", -1.0, 1.0, "Each leg's link-1 CoM outward of its ankle-hip line"),
    FD(link2_com_y, "m", -1.0, 1.0, "Link 2's CoM left of the mid-plane"),
    FD(sole_width, "m", 0.001, 1.0, "Width of one sole, centred under its ankle"),
    FD(ankle_roll_max, "rad", 0.001, 3.2, "Ankle roll limit, either way"),
    FD(hip_abduction_max, "rad", 0.0, 3.2, "Hip roll limit outward (foot away from the mid-plane)"),
    FD(hip_adduction_max, "rad", 0.0, 3.2, "Hip roll limit inward"),
    FD(knee_max, "rad", 0.01, 3.2, "Knee flexion limit"),
    FD(Ka_y, "N.m/rad", 1e-3, 1e6, "Lateral ankle virtual stiffness (F11, the frontal eq. 11)"),
    FD(Ca_y, "N.m.s/rad", 0.0, 1e6, "Lateral ankle virtual damping (F11)"),
    FD(Kh_y, "N.m/rad", 1e-3, 1e6, "Lateral hip virtual stiffness (F16, the frontal eq. 16)"),
    FD(Ch_y, "N.m.s/rad", 0.0, 1e6, "Lateral hip virtual damping (F16)"),
    FD(Kpr_y, "1/s", 1e-3, 1e6, "Lateral CoM feedback gain (F24)"),
    FD(Kp_psi, "1/s", 1e-3, 1e6, "Lateral hip return regulator gain (F25)"),
    FI(hip_strategy_enabled_y, 0.0, 1.0, "Frontal plane: 1 ankle and hip strategies with transitions; 0 lateral ankle strategy only"),
    FD(zmp_limit_y, "m", 0.001, 1.0, "|zmp_y| that starts the lateral ankle-to-hip transition"),
    FD(T_ah_y, "s", 0.002, 100.0, "Duration of the lateral ankle-to-hip transition"),
    FD(rz_band_low_y, "m", -1.0, 0.0, "Lateral hip-to-ankle trigger: lower edge of the frontal CoM height band relative to erect"),
    FD(rz_band_high_y, "m", 0.0, 1.0, "Lateral hip-to-ankle trigger: upper edge of that band"),
    FD(fallback_disturbance_tol_y, "N.m", 0.0, 100.0, "Lateral hip-to-ankle fallback: |d_y| below this"),
    FD(fallback_hip_tol_y, "rad", 0.0, 3.2, "Lateral hip-to-ankle fallback: |psi reference| below this"),
    FD(fallback_dwell_y, "s", 0.0, 100.0, "Lateral hip-to-ankle fallback: time both conditions must hold"),
    FD(return_psi_tol, "rad", 1e-6, 1.0, "Return to the lateral ankle strategy when |psi reference| is below this"),
    FD(return_psi_rate_tol, "rad/s", 1e-6, 10.0, "... and |psi reference rate| below this"),
    FD(zmp_filter_tau_y, "s", 0.0, 10.0, "Time constant of the zmp_y low-pass filter (0 = off)"),
    FD(zmp_fault_margin_y, "m", 0.0, 1.0, "zmp_y beyond the soles' outer edges by more than this is a sensor fault"),
    FI(lean_enabled_y, 0.0, 1.0, "Frontal sustained-push lean: 1 the CoM reference leans against the low-passed lateral disturbance, in every phase"),
    FD(lean_tau_y, "s", 0.01, 100.0, "Time constant of the lateral disturbance low-pass the lean follows"),
    FD(lean_margin_y, "m", 0.0, 1.0, "The leaned CoM reference stays this far inside the soles' outer edges"),
    FD(fz_rocking_y, "N", 0.0, 1e4, "A sole with less normal load than this counts as lifted: the lateral lean holds (0: never)"),
    FI(lean_law_y, 0.0, 1.0, "Frontal lean law: 0 the low-passed disturbance (the sagittal lean's); 1 the inverted pendulum's CoM, its ZMP planned by capture-point feedback"),
    FD(lean_zmp_margin_y, "m", 0.0, 1.0, "Lean law 1: the planned ZMP stays this far inside the soles' outer edges"),
    FD(lean_capture_gain_y, "1", 0.01, 100.0, "Lean law 1: the capture point converges at this multiple of the pendulum's rate"),
    FD(roll_rocking_y, "rad", 0.0, 3.2, "The feet rolled more than this (imu_roll against the legs' kinematics): the robot rocks on a sole's edge, the lateral lean holds"),
    FD(rocking_dwell_y, "s", 0.0, 10.0, "The lateral lean holds until the feet have lain flat again for this long"),
};
#define FTABLE_LEN (sizeof k_ftable / sizeof k_ftable[0])

const ahc_param_info *ahc_frontal_param_table(size_t *count)
{
    if (count) *count = FTABLE_LEN;
    return k_ftable;
}

const ahc_param_info *ahc_frontal_param_find(const char *name) { return ahc_rows_find(k_ftable, FTABLE_LEN, name); }

/* Semi-implicit Euler on x'' = -k x - c x' is stable for 0 < hc < 2 and 4 - 2hc - h^2 k > 0. */
static int symplectic_stable(double h, double k, double c)
{
    return h * c < 2.0 && 4.0 - 2.0 * h * c - h * h * k > 0.0;
}

int ahc_frontal_params_validate(const ahc_frontal_params *f, const ahc_params *sp, char *msg, size_t msg_size)
{
    double h, edge;
    int rc;
    if (msg && msg_size > 0) msg[0] = '\0';
    if (!f || !sp) return ahc_fail_message(msg, msg_size, AHC_ERR_NULL, "params pointer is NULL");
    rc = ahc_params_validate(sp, msg, msg_size);
    if (rc != AHC_OK) return rc;
    rc = ahc_rows_check(k_ftable, FTABLE_LEN, f, msg, msg_size);
    if (rc != AHC_OK) return rc;
    if (!(fabs(f->thigh + f->shank - sp->l1) <= 1e-6 * sp->l1))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "thigh + shank = %.6g must equal l1 = %.6g (the straight leg)", f->thigh + f->shank, sp->l1);
    edge = f->ankle_y + 0.5 * f->sole_width;
    if (!(f->zmp_limit_y < edge))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "zmp_limit_y = %.6g lies outside the soles (outer edges at +-%.6g)", f->zmp_limit_y, edge);
    if (!(f->lean_margin_y < edge))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "lean_margin_y = %.6g must be < the soles' outer edge %.6g (the lean range must hold 0)",
                    f->lean_margin_y, edge);
    if (!(f->lean_zmp_margin_y < edge))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "lean_zmp_margin_y = %.6g must be < the soles' outer edge %.6g", f->lean_zmp_margin_y, edge);
    if (!(f->rz_band_low_y < f->rz_band_high_y))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "rz_band_low_y = %.6g must be < rz_band_high_y = %.6g",
                    f->rz_band_low_y, f->rz_band_high_y);
    h = sp->sample_period;
    if (!(f->T_ah_y >= 2.0 * h))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "T_ah_y = %.6g must be at least two sample periods (sample_period = %.6g)", f->T_ah_y, h);
    {
        const double Jphi = ahc_frontal_ankle_inertia(f, sp), Jpsi = ahc_frontal_hip_inertia(f, sp);
        if (!(Jphi > 0.0) || !symplectic_stable(h, f->Ka_y / Jphi, f->Ca_y / Jphi))
            return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                        "sample_period = %.6g too large for the lateral ankle law (Ka_y = %.6g, Ca_y = %.6g): "
                        "semi-implicit Euler unstable", h, f->Ka_y, f->Ca_y);
        if (!(Jpsi > 0.0) || !symplectic_stable(h, f->Kh_y / Jpsi, f->Ch_y / Jpsi))
            return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                        "sample_period = %.6g too large for the lateral hip law (Kh_y = %.6g, Ch_y = %.6g): "
                        "semi-implicit Euler unstable", h, f->Kh_y, f->Ch_y);
    }
    if (f->lean_enabled_y && f->lean_law_y == AHC_LEAN_PENDULUM) {
        /* F26-F28 unclamped: c'' = -k w^2 (c - target) - (1 + k) w c' */
        double rz;
        ahc_frontal_com(f, sp, 0.0, 0.0, NULL, &rz);
        {
            const double w = sqrt(sp->g / (rz + sp->ankle_height)), k = f->lean_capture_gain_y;
            if (!symplectic_stable(h, k * w * w, (1.0 + k) * w))
                return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                            "sample_period = %.6g too large for the pendulum lean (lean_capture_gain_y = %.6g): "
                            "semi-implicit Euler unstable", h, k);
        }
    }
    if (!(h * f->Kp_psi < 1.0))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "Kp_psi = %.6g too large for sample_period = %.6g (need Kp_psi * h < 1)", f->Kp_psi, h);
    if (!(h * f->Kpr_y < 1.0))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT,
                    "Kpr_y = %.6g too large for sample_period = %.6g (need Kpr_y * h < 1)", f->Kpr_y, h);
    return AHC_OK;
}

/* ------------------------------------------------------------------------------------------- */
/* Instance */

static void compute_derived(ahc_frontal *c)
{
    c->m = c->sp.m1 + c->sp.m2;
    c->km = c->sp.m2 / c->m;
    c->Jphi = ahc_frontal_ankle_inertia(&c->f, &c->sp);
    c->Jpsi = ahc_frontal_hip_inertia(&c->f, &c->sp);
    ahc_frontal_com(&c->f, &c->sp, 0.0, 0.0, NULL, &c->rz_erect);
    c->zmp_alpha = c->f.zmp_filter_tau_y > 0.0 ? 1.0 - exp(-c->sp.sample_period / c->f.zmp_filter_tau_y) : 1.0;
    c->lean_alpha = 1.0 - exp(-2.0 * c->sp.sample_period / c->f.lean_tau_y);
    c->omega_y = sqrt(c->sp.g / (c->rz_erect + c->sp.ankle_height));
}

int ahc_frontal_init(ahc_frontal *c, const ahc_frontal_params *f, const ahc_params *sp)
{
    int rc;
    if (!c) return AHC_ERR_NULL;
    memset(c, 0, sizeof *c);
    rc = ahc_frontal_params_validate(f, sp, NULL, 0);
    if (f) c->f = *f;
    if (sp) c->sp = *sp;
    if (rc != AHC_OK) return rc;
    c->valid = 1;
    ahc_frontal_reset(c);
    return AHC_OK;
}

void ahc_frontal_reset(ahc_frontal *c)
{
    ahc_frontal_params f;
    ahc_params sp;
    int valid;
    if (!c) return;
    f = c->f;
    sp = c->sp;
    valid = c->valid;
    memset(c, 0, sizeof *c);
    c->f = f;
    c->sp = sp;
    c->valid = valid;
    if (!valid) return;
    compute_derived(c);
    c->phase = AHC_PHASE_ANKLE;
    c->push_sign = 1;
    ahc_quintic_init(&c->kw_spline, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, f.T_ah_y);
    ahc_quintic_init(&c->ryd_spline, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, f.T_ah_y);
}

/* Context of one tick. */
typedef struct {
    double h;
    double ry, rz;          /* frontal CoM from the reference angles (kinematic laws, triggers) */
    double ry_meas, rz_meas;/* ... from the measured angles (disturbance, outputs) */
    double J[2];            /* lateral CoM Jacobian at the reference angles (F20) */
    double ratio;           /* F15 */
    double d;               /* d_y */
    double dlean;           /* the lean's rate this tick [m/s] */
} fctx;

/* ------------------------------------------------------------------------------------------- */
/* Phase entries: the references stay continuous (docs/controller.md §4.1, the same rules). */

static void enter_ankle(ahc_frontal *c)
{
    c->phase = AHC_PHASE_ANKLE;
    c->phase_time = 0.0;
    c->fallback_timer = 0.0;
    c->k_w = 0.0;
}

static void enter_ankle_to_hip(ahc_frontal *c, const fctx *k, int sign)
{
    /* r_y_d starts at r_y with the velocity that makes F23 (k_w = 0) reproduce the current phi rate. */
    const double n2 = k->J[0] * k->J[0] + k->J[1] * k->J[1];
    const double v0 = fabs(k->J[0]) > 1e-9 ? c->dphi * n2 / k->J[0] : 0.0;
    c->phase = AHC_PHASE_ANKLE_TO_HIP;
    c->push_sign = sign;
    c->phase_time = 0.0;
    c->fallback_timer = 0.0;
    ahc_quintic_init(&c->kw_spline, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, c->f.T_ah_y);
    ahc_quintic_init(&c->ryd_spline, k->ry, v0, 0.0, 0.0, 0.0, 0.0, c->f.T_ah_y);
    c->psi_bump = 0.0;
}

static void enter_hip(ahc_frontal *c)
{
    c->phase = AHC_PHASE_HIP;
    c->phase_time = 0.0;
    c->fallback_timer = 0.0;
    c->k_w = 1.0;
    c->ryd = 0.0;
    c->dryd = 0.0;
    c->psi_bump = 0.0;
}

static void enter_hip_to_ankle(ahc_frontal *c)
{
    c->phase = AHC_PHASE_HIP_TO_ANKLE;
    c->phase_time = 0.0;
    c->fallback_timer = 0.0;
    c->psi_bump = c->dpsi + c->f.Kp_psi * c->psi;
}

static int zmp_beyond_limit(const ahc_frontal *c, int *sign)
{
    if (c->zmp_f >= c->f.zmp_limit_y) { *sign = 1; return 1; }
    if (c->zmp_f <= -c->f.zmp_limit_y) { *sign = -1; return 1; }
    return 0;
}

/* The frontal phase switches, as the sagittal ones (controller.c phase_transitions). */
static void phase_transitions(ahc_frontal *c, const fctx *k)
{
    const ahc_frontal_params *f = &c->f;
    int sign = 1;
    if (!f->hip_strategy_enabled_y) {
        if (c->phase != AHC_PHASE_ANKLE) enter_ankle(c);
        return;
    }
    switch (c->phase) {
    case AHC_PHASE_ANKLE:
        if (zmp_beyond_limit(c, &sign)) enter_ankle_to_hip(c, k, sign);
        break;
    case AHC_PHASE_ANKLE_TO_HIP:
        if (c->phase_time >= c->kw_spline.T - 0.5 * k->h) enter_hip(c);
        break;
    case AHC_PHASE_HIP: {
        /* 2 -> 3: the frontal CoM height back in its band near erect and the lateral ZMP on the
         * side opposite to the push; or the fallback. */
        const double drz = k->rz - c->rz_erect;
        const int paper = drz >= f->rz_band_low_y && drz <= f->rz_band_high_y &&
                          (double)c->push_sign * c->zmp_f < 0.0;
        const int quiet = fabs(k->d) <= f->fallback_disturbance_tol_y && fabs(c->psi) <= f->fallback_hip_tol_y;
        c->fallback_timer = quiet ? c->fallback_timer + k->h : 0.0;
        if (paper || (quiet && c->fallback_timer >= f->fallback_dwell_y - 0.5 * k->h)) enter_hip_to_ankle(c);
        break;
    }
    case AHC_PHASE_HIP_TO_ANKLE:
        if (zmp_beyond_limit(c, &sign)) {
            c->push_sign = sign;
            enter_hip(c);
        } else if (fabs(c->psi) <= f->return_psi_tol && fabs(c->dpsi) <= f->return_psi_rate_tol) {
            enter_ankle(c);
        }
        break;
    default:
        enter_ankle(c);
        break;
    }
}

/* ------------------------------------------------------------------------------------------- */
/* The laws; each integrates the reference over one tick (as controller.c). */

/* F11: phi'' = (d_y - Ca_y phi' - Ka_y (phi - phi_lean)) / J_phi (semi-implicit Euler); phi_lean =
 * lean / J[0], the lean of the legs that moves the CoM by the lateral lean (0 without it). */
static void law_ankle_strategy(ahc_frontal *c, const fctx *k)
{
    const double phi_lean = fabs(k->J[0]) > 1e-9 ? c->lean / k->J[0] : 0.0;
    const double acc = (k->d - c->f.Ca_y * c->dphi - c->f.Ka_y * (c->phi - phi_lean)) / c->Jphi;
    c->dphi += k->h * acc;
    c->phi += k->h * c->dphi;
}

/* F11 about the pendulum's plan (lean_law_y = AHC_LEAN_PENDULUM): the legs follow the planned CoM,
 * phi_plan = lean / J[0], and F11's spring-damper acts on the deviation from it, driven by the part
 * of d_y the plan does not expect, d_y - m g (p_plan - lean). */
static void law_ankle_strategy_planned(ahc_frontal *c, const fctx *k)
{
    const double j0 = fabs(k->J[0]) > 1e-9 ? k->J[0] : 1e-9;
    const double plan = c->lean / j0, dplan = k->dlean / j0;
    const double dd = k->d - c->m * c->sp.g * (c->lean_p - c->lean);
    double dev = c->phi - c->phi_plan, ddev = c->dphi - c->dphi_plan;
    ddev += k->h * (dd - c->f.Ca_y * ddev - c->f.Ka_y * dev) / c->Jphi;
    dev += k->h * ddev;
    c->phi = plan + dev;
    c->dphi = dplan + ddev;
}

/* F16: psi'' = (k_m d_y - Ch_y psi' - Kh_y psi) / J_psi. */
static void law_hip_strategy(ahc_frontal *c, const fctx *k)
{
    const double acc = (c->km * k->d - c->f.Ch_y * c->dpsi - c->f.Kh_y * c->psi) / c->Jpsi;
    c->dpsi += k->h * acc;
    c->psi += k->h * c->dpsi;
}

/* F25: psi' = -Kp_psi psi (+ decaying bumpless offset). */
static void law_hip_regulator(ahc_frontal *c, const fctx *k)
{
    c->dpsi = -c->f.Kp_psi * c->psi + c->psi_bump;
    c->psi += k->h * c->dpsi;
    c->psi_bump *= exp(-c->f.Kp_psi * k->h);
}

/* F23-F24: phi' = J0/(J0^2 + J1^2) r_y_ref' + k_w ratio psi',  r_y_ref' = r_y_d' + Kpr_y (r_y_d - r_y). */
static void law_ankle_reactionless(ahc_frontal *c, const fctx *k)
{
    const double n2 = k->J[0] * k->J[0] + k->J[1] * k->J[1];
    const double rdot = c->dryd + c->f.Kpr_y * (c->ryd - k->ry);
    c->dphi = (n2 > 1e-12 ? k->J[0] / n2 * rdot : 0.0) + c->k_w * k->ratio * c->dpsi;
    c->phi += k->h * c->dphi;
}

/* The external moment about the ground line under the ankles' mid-point (x axis), from the moment
 * balance of the frontal model (the sagittal external_moment's, docs/controller.md §4.4):
 *     p_y f_z = g sum_i m_i y_i + D_y + dH,   dH = sum_i m_i (y_i z_i'' - z_i y_i'') - sum_i I_i lean_i'',
 * the lumps' accelerations by backward differences of their measured CoMs over the last three
 * ticks, z from the sole. Updates the history. */
static double external_moment(ahc_frontal *c, const ahc_frontal_sensors *s, const ahc_frontal_pose *pm)
{
    const double h = c->sp.sample_period, a = c->sp.ankle_height;
    const double mass[3] = {0.5 * c->sp.m1, 0.5 * c->sp.m1, c->sp.m2};
    const double inertia[3] = {0.5 * c->f.I1_roll, 0.5 * c->f.I1_roll, c->f.I2_roll};
    const double *y = pm->ly, *z = pm->lz, *lean = pm->lean;
    double grav = 0.0, dH = 0.0;
    int i;
    for (i = 0; i < 3; ++i) {
        grav += mass[i] * y[i];
        if (c->hist_n >= 2) {
            const double ddy = (y[i] - 2.0 * c->hist_y[0][i] + c->hist_y[1][i]) / (h * h);
            const double ddz = (z[i] - 2.0 * c->hist_z[0][i] + c->hist_z[1][i]) / (h * h);
            const double ddl = (lean[i] - 2.0 * c->hist_lean[0][i] + c->hist_lean[1][i]) / (h * h);
            dH += mass[i] * (y[i] * ddz - (z[i] + a) * ddy) - inertia[i] * ddl;
        }
        c->hist_y[1][i] = c->hist_y[0][i];
        c->hist_z[1][i] = c->hist_z[0][i];
        c->hist_lean[1][i] = c->hist_lean[0][i];
        c->hist_y[0][i] = y[i];
        c->hist_z[0][i] = z[i];
        c->hist_lean[0][i] = lean[i];
    }
    if (c->hist_n < 2) c->hist_n++;
    return s->zmp_y * s->fz - c->sp.g * grav - dH;
}

/* The lateral lean (docs/controller.md §11.2). Its estimate is the sagittal update_lean's
 * (controller.c) over the soles' width: the external moment D_y low-passed, held while the ZMP is at
 * the edge the push drives it to and released at the other, and held while a sole is unloaded (the
 * robot may rock on the other's edge: the moment balance assumes both soles flat). Its target is
 * -D_y/(m g), bounded lean_margin_y inside the outer edges. lean_law_y says how the CoM reference
 * moves there: AHC_LEAN_LOWPASS, as the target itself (§4.6's law); AHC_LEAN_PENDULUM, as the
 * linear inverted pendulum's CoM under D_y, F26-F28, its ZMP planned by capture-point feedback
 * toward the target and kept lean_zmp_margin_y inside the soles: the CoM starts away from the
 * push at the pendulum's rate as soon as the estimate moves. Unlike the sagittal lean it acts in
 * every phase (F11 leans the legs by it: the evidence of §11.5). Returns the lean's rate this tick. */
static double update_lean(ahc_frontal *c, double ext, const ahc_frontal_sensors *s)
{
    const ahc_frontal_params *f = &c->f;
    const double edge = f->ankle_y + 0.5 * f->sole_width, h = c->sp.sample_period;
    double next;
    int rocking;
    {
        const int at_pos = c->zmp_f >= edge - LEAN_EDGE, at_neg = c->zmp_f <= -edge + LEAN_EDGE;
        /* one sole unloaded (fz_rocking_y), or the feet rolled or flat for less than rocking_dwell_y:
         * the robot may rock on a sole's edge, the balance means nothing (hold) */
        const double fz_min = s->fz_left < s->fz_right ? s->fz_left : s->fz_right;
        c->flat_time = fabs(s->foot_roll) > f->roll_rocking_y ? 0.0 : c->flat_time + h;
        rocking = (f->fz_rocking_y > 0.0 && !(fz_min >= f->fz_rocking_y)) || c->flat_time < f->rocking_dwell_y ||
                  fabs(s->foot_roll) > f->roll_rocking_y;
        if (!rocking && !((at_pos && c->lean_f > 0.0) || (at_neg && c->lean_f < 0.0))) {
            const double in = (at_pos || at_neg) ? 0.0 : ext;
            c->lean_f1 += c->lean_alpha * (in - c->lean_f1);
            c->lean_f += c->lean_alpha * (c->lean_f1 - c->lean_f);
        }
    }
    next = clampd(-c->lean_f / (c->m * c->sp.g), -edge + f->lean_margin_y, edge - f->lean_margin_y);
    if (f->lean_law_y == AHC_LEAN_PENDULUM && rocking) {
        /* rocking on an edge: the plan holds at rest (moving the legs on a rolled foot only rolls it
         * more), its ZMP the static one */
        c->lean_rate = 0.0;
        c->lean_p = c->lean + c->lean_f / (c->m * c->sp.g);
        next = c->lean;
    } else if (f->lean_law_y == AHC_LEAN_PENDULUM) {
        /* F26 the pendulum's CoM c under the estimated moment, c'' = w^2 (c - p + D_y/(m g)); F27 its
         * capture point xi = c + c'/w; F28 the planned ZMP p = xi + k (xi - target) + D_y/(m g),
         * inside the soles, which makes xi' = -k w (xi - target) while p is not clamped */
        const double w = c->omega_y, off = c->lean_f / (c->m * c->sp.g);
        const double xi = c->lean + c->lean_rate / w;
        /* the margin yields where holding the target, or bringing the capture point back from
         * beyond it, needs the ZMP closer to the edge */
        const double pm = fabs(next + off) > edge - f->lean_zmp_margin_y || fabs(xi) > edge - f->lean_zmp_margin_y
                              ? edge : edge - f->lean_zmp_margin_y;
        const double p = clampd(xi + f->lean_capture_gain_y * (xi - next) + off, -pm, pm);
        const double B = edge - f->lean_margin_y;
        c->lean_p = p;
        c->lean_rate += h * w * w * (c->lean - p + off);
        /* F29: the capture point stays within +-B, so that the pendulum stays capturable over the
         * soles if the push ends now (its offset D_y/(m g) gone) */
        c->lean_rate = clampd(c->lean_rate, w * (-B - c->lean), w * (B - c->lean));
        next = c->lean + h * c->lean_rate;
        if (fabs(next) > edge - f->lean_margin_y) {
            next = clampd(next, -edge + f->lean_margin_y, edge - f->lean_margin_y);
            c->lean_rate = 0.0;
        }
    }
    {
        const double rate = (next - c->lean) / h;
        c->lean = next;
        return rate;
    }
}

/* ------------------------------------------------------------------------------------------- */

unsigned ahc_frontal_sensor_faults(const ahc_frontal *c, const ahc_frontal_sensors *s)
{
    unsigned fl = 0;
    const double edge = c->f.ankle_y + 0.5 * c->f.sole_width + c->f.zmp_fault_margin_y;
    if (!isfinite(s->zmp_y))
        fl |= AHC_FFAULT_ZMP_Y_NONFINITE;
    else if (fabs(s->zmp_y) > edge)
        fl |= AHC_FFAULT_ZMP_Y_OUTSIDE;
    if (!isfinite(s->phi) || !isfinite(s->psi) || !isfinite(s->foot_roll)) fl |= AHC_FFAULT_ANGLE_NONFINITE;
    if (!isfinite(s->fz) || s->fz < c->sp.fz_lifted) fl |= AHC_FFAULT_LIFTED;
    return fl;
}

static void write_outputs(ahc_frontal *c, const fctx *k, ahc_frontal_outputs *out)
{
    memset(out, 0, sizeof *out);
    out->phi_ref = c->phi;
    out->psi_ref = c->psi;
    out->dphi_ref = c->dphi;
    out->dpsi_ref = c->dpsi;
    out->phase = c->phase;
    out->com_y = k->ry_meas;
    out->com_z = k->rz_meas;
    out->disturbance_moment = k->d;
    out->k_w = c->phase == AHC_PHASE_ANKLE ? 0.0 : c->k_w;
    out->com_y_desired = c->phase == AHC_PHASE_ANKLE ? k->ry : c->ryd;
    out->fault = c->fault;
    c->last_out = *out;
}

/* Whether the legs can take (phi, psi) within their joint limits, the feet flat: the ankle rolls
 * (each leg's lean), the pivot hip's roll toward the other leg (adduction), the other hip's away
 * from it (abduction; each hip's roll is the trunk's lean minus its leg's) and the other knee
 * (the hip-ankle distance it must make). */
static int feasible(const ahc_frontal *c, double phi, double psi)
{
    const ahc_frontal_params *f = &c->f;
    ahc_frontal_pose o;
    const double *lean = o.lean;
    const double lmin = sqrt(f->thigh * f->thigh + f->shank * f->shank + 2.0 * f->thigh * f->shank * cos(f->knee_max));
    const int pivot = psi >= 0.0 ? 0 : 1, other = 1 - pivot;   /* lumps: 0 right leg, 1 left leg */
    const double sgn = psi >= 0.0 ? 1.0 : -1.0;
    if (psi == 0.0 && f->hip_y == f->ankle_y) {
        /* the parallelogram: both legs lean by phi, both hips roll by -phi, the knees straight */
        return fabs(phi) <= f->ankle_roll_max && -phi <= f->hip_adduction_max && -phi <= f->hip_abduction_max;
    }
    ahc_frontal_pose_at(f, &c->sp, phi, psi, &o);
    if (fabs(lean[0]) > f->ankle_roll_max || fabs(lean[1]) > f->ankle_roll_max) return 0;
    if (sgn * (psi - lean[pivot]) > f->hip_adduction_max) return 0;
    if (sgn * (psi - lean[other]) > f->hip_abduction_max) return 0;
    if (o.other_len < lmin) return 0;
    return 1;
}

/* The references stay inside what the legs can do: phi within the ankle roll limit, then psi
 * brought back toward level (bisection) until the pose is feasible. */
static unsigned clamp_references(ahc_frontal *c)
{
    const ahc_frontal_params *f = &c->f;
    unsigned fl = 0;
    if (fabs(c->phi) > f->ankle_roll_max) {
        c->phi = clampd(c->phi, -f->ankle_roll_max, f->ankle_roll_max);
        c->dphi = 0.0;
        fl |= AHC_FFAULT_REF_SATURATED;
    }
    if (!feasible(c, c->phi, c->psi)) {
        double lo = 0.0, hi = 1.0;   /* the fraction of psi kept */
        int i;
        if (feasible(c, c->phi, 0.0)) {
            for (i = 0; i < 30; ++i) {
                const double mid = 0.5 * (lo + hi);
                if (feasible(c, c->phi, mid * c->psi)) lo = mid; else hi = mid;
            }
        }
        c->psi *= lo;
        c->dpsi = 0.0;
        c->psi_bump = 0.0;
        fl |= AHC_FFAULT_REF_SATURATED;
    }
    return fl;
}

void ahc_frontal_step(ahc_frontal *c, const ahc_frontal_sensors *s, ahc_frontal_outputs *out)
{
    fctx k;
    ahc_frontal_pose pm;
    unsigned fl;
    memset(&k, 0, sizeof k);
    if (!c->valid) {
        memset(out, 0, sizeof *out);
        out->fault = AHC_FFAULT_NOT_INITIALIZED;
        c->tick++;
        return;
    }
    k.h = c->sp.sample_period;
    if (!c->f.frontal_enabled) {
        /* the frontal layer off: level, centred references (exactly 0), nothing else computed */
        c->fault = 0;
        memset(out, 0, sizeof *out);
        c->last_out = *out;
        c->tick++;
        return;
    }
    fl = ahc_frontal_sensor_faults(c, s);
    if (fl & AHC_FFAULT_HOLD_MASK) {
        /* hold a safe reference: angles frozen, rates 0, timers paused */
        c->holding = 1;
        c->dphi = c->dpsi = c->psi_bump = 0.0;
        c->fallback_timer = 0.0;
        c->fault = fl;
        ahc_frontal_com(&c->f, &c->sp, c->started ? c->last_phi : c->phi, c->started ? c->last_psi : c->psi,
                        &k.ry, &k.rz);
        k.ry_meas = k.ry;
        k.rz_meas = k.rz;
        write_outputs(c, &k, out);
        c->tick++;
        return;
    }
    if (!c->started) {
        /* bumpless start from the robot's current posture */
        c->phi = clampd(s->phi, -c->f.ankle_roll_max, c->f.ankle_roll_max);
        c->psi = s->psi;
        c->dphi = c->dpsi = 0.0;
        c->started = 1;
    }
    if (c->holding) {
        c->holding = 0;
        c->zmp_f_valid = 0;
        c->hist_n = 0;
    }
    c->last_phi = s->phi;
    c->last_psi = s->psi;
    if (!c->zmp_f_valid) {
        c->zmp_f = s->zmp_y;
        c->zmp_f_valid = 1;
    } else {
        c->zmp_f += c->zmp_alpha * (s->zmp_y - c->zmp_f);
    }
    /* kinematics: the laws on the reference angles, the disturbance on the measured ones */
    {
        ahc_frontal_pose pr;
        ahc_frontal_pose_at(&c->f, &c->sp, s->phi, s->psi, &pm);
        ahc_frontal_pose_at(&c->f, &c->sp, c->phi, c->psi, &pr);
        k.ry_meas = pm.y;
        k.rz_meas = pm.z;
        k.ry = pr.y;
        k.rz = pr.z;
        k.J[0] = pr.dy[0];
        k.J[1] = pr.dy[1];
    }
    k.ratio = fabs(k.J[0]) > 1e-12 ? -k.J[1] / k.J[0] : 0.0;
    k.d = c->m * c->sp.g * (c->zmp_f - k.ry_meas);   /* d_y = m g (p_y - r_y) */
    if (c->f.lean_enabled_y) {
        const double ext = external_moment(c, s, &pm);
        k.dlean = update_lean(c, ext, s);
    } else {
        c->lean = 0.0;
    }

    phase_transitions(c, &k);
    switch (c->phase) {
    case AHC_PHASE_ANKLE:
        law_hip_regulator(c, &k);
        if (c->f.lean_enabled_y && c->f.lean_law_y == AHC_LEAN_PENDULUM)
            law_ankle_strategy_planned(c, &k);
        else
            law_ankle_strategy(c, &k);
        break;
    case AHC_PHASE_ANKLE_TO_HIP: {
        double dkw;
        ahc_quintic_eval(&c->kw_spline, c->phase_time, &c->k_w, &dkw, NULL);
        ahc_quintic_eval(&c->ryd_spline, c->phase_time, &c->ryd, &c->dryd, NULL);
        c->ryd += c->k_w * c->lean;   /* the lean blends in with k_w (0 without lean_enabled_y) */
        c->dryd += dkw * c->lean + c->k_w * k.dlean;
        law_hip_strategy(c, &k);
        law_ankle_reactionless(c, &k);
        break;
    }
    case AHC_PHASE_HIP:
        c->k_w = 1.0;
        c->ryd = c->lean;
        c->dryd = k.dlean;
        law_hip_strategy(c, &k);
        law_ankle_reactionless(c, &k);
        break;
    default: /* AHC_PHASE_HIP_TO_ANKLE */
        c->k_w = 1.0;
        c->ryd = c->lean;
        c->dryd = k.dlean;
        law_hip_regulator(c, &k);
        law_ankle_reactionless(c, &k);
        break;
    }
    if (c->f.lean_enabled_y && c->f.lean_law_y == AHC_LEAN_PENDULUM) {
        const double j0 = fabs(k.J[0]) > 1e-9 ? k.J[0] : 1e-9;
        c->phi_plan = c->lean / j0;
        c->dphi_plan = k.dlean / j0;
    }
    c->phase_time += k.h;
    c->fault = clamp_references(c);
    write_outputs(c, &k, out);
    c->tick++;
}

int ahc_frontal_state_validate(const ahc_frontal *c, char *msg, size_t msg_size)
{
    int rc;
    ahc_frontal fresh;
    if (msg && msg_size > 0) msg[0] = '\0';
    if (!c) return ahc_fail_message(msg, msg_size, AHC_ERR_NULL, "state pointer is NULL");
    if (c->valid != 0 && c->valid != 1) return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "valid = %d must be 0 or 1", c->valid);
    if (!c->valid) return AHC_OK;
    rc = ahc_frontal_params_validate(&c->f, &c->sp, msg, msg_size);
    if (rc != AHC_OK) return rc;
    /* the derived constants must be the parameters' */
    memset(&fresh, 0, sizeof fresh);
    fresh.f = c->f;
    fresh.sp = c->sp;
    compute_derived(&fresh);
    if (fresh.m != c->m || fresh.km != c->km || fresh.Jphi != c->Jphi || fresh.Jpsi != c->Jpsi ||
        fresh.rz_erect != c->rz_erect || fresh.zmp_alpha != c->zmp_alpha || fresh.lean_alpha != c->lean_alpha ||
        fresh.omega_y != c->omega_y)
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "derived constants do not match the parameters");
    if (c->phase < AHC_PHASE_ANKLE || c->phase > AHC_PHASE_HIP_TO_ANKLE)
        return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "phase = %d", c->phase);
    if (c->push_sign != 1 && c->push_sign != -1) return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "push_sign = %d", c->push_sign);
    if ((c->started != 0 && c->started != 1) || (c->holding != 0 && c->holding != 1) ||
        (c->zmp_f_valid != 0 && c->zmp_f_valid != 1) || c->hist_n < 0 || c->hist_n > 2)
        return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "a flag is not 0 or 1");
    {
        const double v[] = {c->phi, c->dphi, c->psi, c->dpsi, c->psi_bump, c->phase_time, c->fallback_timer,
                            c->k_w, c->ryd, c->dryd, c->zmp_f, c->last_phi, c->last_psi, c->lean_f1, c->lean_f,
                            c->lean, c->lean_rate, c->lean_p, c->phi_plan, c->dphi_plan, c->flat_time};
        size_t i;
        for (i = 0; i < sizeof v / sizeof v[0]; ++i)
            if (!isfinite(v[i])) return ahc_fail_message(msg, msg_size, AHC_ERR_NONFINITE, "state value %u is not finite", (unsigned)i);
    }
    if (c->k_w < 0.0 || c->k_w > 1.0) return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "k_w = %g outside [0, 1]", c->k_w);
    /* eqs. 23-24's splines over T_ah_y, from T and the start (a forged k_w coefficient put k_w
     * outside [0, 1] on the next tick); k_w by phase */
    rc = ahc_transition_splines_check(&c->kw_spline, &c->ryd_spline, "ryd_spline", c->f.T_ah_y, c->phase, c->k_w, msg,
                                      msg_size);
    if (rc != AHC_OK) return rc;
    if (c->flat_time < 0.0) return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "flat_time = %g must be >= 0", c->flat_time);
    if (fabs(c->phi) > c->f.ankle_roll_max || fabs(c->psi) > 1.5)
        return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "frontal reference outside the legs' range");
    if ((c->fault & ~(unsigned)AHC_FFAULT_ALL_MASK) != 0)
        return ahc_fail_message(msg, msg_size, AHC_ERR_RANGE, "fault = %u has undefined bits", c->fault);
    return AHC_OK;
}
