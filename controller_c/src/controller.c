/*
 * controller.c — the four-phase ankle/hip balance controller (Nenchev & Nishio, ICRA 2010;
 * our reading in docs/controller.md §2-§4).
 *
 * Structure of one tick (ahc_step):
 *   1. classify the inputs (fault bits); on a "hold" fault freeze the reference and return;
 *   2. ZMP low-pass filter (prototype finding 1, docs/controller.md §4.2), kinematics, disturbance estimate d (finding 5);
 *   3. phase transitions, decided on the state at the start of the tick (phase_transitions);
 *   4. the control law of the (possibly new) phase, integrated over one tick (law_*):
 *      acceleration laws (eqs. 11, 16) with semi-implicit Euler  v += h a(x, v); x += h v,
 *      rate laws (eqs. 23, 25) with explicit Euler               x += h v(x);
 *   5. joint-limit clamp, outputs.
 * Reference states (th1, dth1, th2, dth2) are the controller's own (admittance view); the
 * kinematics (r_x, r_z, C1, C12) use the measured angles unless kinematics_source says otherwise.
 */
#include <math.h>
#include <string.h>

#include "ahc/controller.h"
#include "fail_message.h"
#include "transition_splines.h"

static double clampd(double v, double lo, double hi) { return v < lo ? lo : (v > hi ? hi : v); }

/* Phase 3 -> 0 waits until the lean is back within this [m] (lean_enabled; 0 otherwise). */
#define LEAN_RETURN_TOL 0.001
/* The lean holds its estimate while the ZMP is this close to the toe or heel [m]. */
#define LEAN_EDGE 0.002

static int pendulum_lean(const ahc_params *p);

/* Context of one tick: measured/derived quantities shared by the laws. */
typedef struct {
    double h;
    double rx, rz;   /* CoM projection and height from the kinematics angles (kinematics_source):
                        used by the kinematic laws (eqs. 23-24) and the phase triggers */
    double rx_meas, rz_meas; /* the same from the measured angles: the physical CoM, used by the
                                disturbance estimate and the com_x/com_z outputs */
    double a;        /* k_m lg2 C12 = second entry of J_cx (eq. 20) */
    double e2;       /* hip reference from the erect posture: th2 - th2_erect */
    double ratio;    /* reactionless ratio (eq. 15) */
    double Ja;       /* whole-body inertia about the ankle (eq. 11 denominator) */
    double d;        /* disturbance moment estimate */
    double dlean;    /* rate of the lean this tick (update_lean; 0 without it) [m/s] */
} tick_ctx;

/* ------------------------------------------------------------------------------------------- */

int ahc_init(ahc_controller *c, const ahc_params *p)
{
    int rc;
    if (!c) return AHC_ERR_NULL;
    memset(c, 0, sizeof *c);
    rc = ahc_params_validate(p, NULL, 0);
    if (rc != AHC_OK) {
        c->valid = 0;
        if (p) c->p = *p;
        return rc;
    }
    c->p = *p;
    c->valid = 1;
    ahc_reset(c);
    return AHC_OK;
}

static void compute_derived(ahc_controller *c)
{
    const ahc_params *p = &c->p;
    c->m = p->m1 + p->m2;
    c->km = p->m2 / c->m;
    c->J2 = p->link2_com_x != 0.0 ? p->I2 + p->m2 * (p->lg2 * p->lg2 + p->link2_com_x * p->link2_com_x)
                                  : p->I2 + p->m2 * p->lg2 * p->lg2;
    ahc_erect_posture(p, &c->th1_erect, &c->th2_erect);
    ahc_com(p, c->th1_erect, c->th2_erect, NULL, &c->rz_erect);
    c->zmp_alpha = p->zmp_filter_tau > 0.0 ? 1.0 - exp(-p->sample_period / p->zmp_filter_tau) : 1.0;
    c->d_alpha = p->zmp_filter_tau > 0.0 ? 1.0 - exp(-2.0 * p->sample_period / p->zmp_filter_tau) : 1.0;
    c->lean_alpha = 1.0 - exp(-2.0 * p->sample_period / p->lean_tau);
    c->omega_x = sqrt(p->g / (c->rz_erect + p->ankle_height));
}

int ahc_update_params(ahc_controller *c, const ahc_params *p)
{
    int rc;
    if (!c || !p) return AHC_ERR_NULL;
    rc = ahc_params_validate(p, NULL, 0);
    if (rc != AHC_OK) return rc;
    if (!c->valid) return ahc_init(c, p);
    {
        const int was_pendulum = pendulum_lean(&c->p);
        c->p = *p;
        compute_derived(c);
        if (pendulum_lean(p) && !was_pendulum) {
            /* the pendulum lean switched on: its plan starts at rest where the lean is (bumpless) */
            c->lean_rate = c->dth1_plan = 0.0;
            c->th1_plan = c->th1_erect + c->lean / (c->rz_erect > 1e-9 ? c->rz_erect : 1e-9);
        }
    }
    return AHC_OK;
}

void ahc_reset(ahc_controller *c)
{
    ahc_params p;
    int valid;
    if (!c) return;
    p = c->p;
    valid = c->valid;
    memset(c, 0, sizeof *c);
    c->p = p;
    c->valid = valid;
    if (!valid) return;
    compute_derived(c);
    c->th1_plan = c->th1_erect; /* the pendulum lean's plan at rest: eq. 11 about the erect posture */
    c->phase = AHC_PHASE_ANKLE;
    c->push_sign = 1;
    ahc_quintic_init(&c->kw_spline, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, p.T_ah);
    ahc_quintic_init(&c->rxd_spline, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, p.T_ah);
}

double ahc_time(const ahc_controller *c)
{
    return (double)c->tick * c->p.sample_period;
}

/* ------------------------------------------------------------------------------------------- */
/* Phase entries. Each keeps th1, dth1, th2, dth2 continuous (bumpless). */

static void enter_ankle(ahc_controller *c)
{
    /* Eq. 11 takes over the ankle with its state (th1, dth1) = current reference angle and the
     * last commanded rate; the hip keeps the eq. 25 regulator (with its bumpless offset). */
    c->phase = AHC_PHASE_ANKLE;
    c->phase_time = 0.0;
    c->fallback_timer = 0.0;
    c->k_w = 0.0;
}

static void enter_ankle_to_hip(ahc_controller *c, const tick_ctx *k, int sign)
{
    /* prototype finding 2 (docs/controller.md §4.2): r_x_d starts at the current CoM projection with the velocity v0 that
     * makes eq. 23 (k_w = 0, r_x_d = r_x) reproduce the current ankle rate exactly:
     *   dth1 = r_z/(r_z^2 + a^2) * v0   =>   v0 = dth1 (r_z^2 + a^2)/r_z,
     * i.e. the CoM velocity as eq. 23 sees it; zero acceleration; ends at (0, 0, 0). */
    const double n2 = k->rz * k->rz + k->a * k->a;
    const double v0 = (fabs(k->rz) > 1e-9) ? c->dth1 * n2 / k->rz : 0.0;
    c->phase = AHC_PHASE_ANKLE_TO_HIP;
    c->push_sign = sign;
    c->phase_time = 0.0;
    c->fallback_timer = 0.0;
    ahc_quintic_init(&c->kw_spline, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, c->p.T_ah);
    ahc_quintic_init(&c->rxd_spline, k->rx, v0, 0.0, 0.0, 0.0, 0.0, c->p.T_ah);
    c->hip_bump = 0.0; /* eq. 16 takes the hip with state (th2, dth2): continuous */
}

static void enter_hip(ahc_controller *c)
{
    c->phase = AHC_PHASE_HIP;
    c->phase_time = 0.0;
    c->fallback_timer = 0.0;
    c->k_w = 1.0;
    c->rxd = 0.0;
    c->drxd = 0.0;
    c->hip_bump = 0.0;
}

static void enter_hip_to_ankle(ahc_controller *c)
{
    /* Eq. 25 regulator dth2 = -Kp_theta th2 + b, with the bumpless offset b = dth2 + Kp_theta th2
     * at entry, decaying as exp(-Kp_theta t): the hip rate is continuous. */
    c->phase = AHC_PHASE_HIP_TO_ANKLE;
    c->phase_time = 0.0;
    c->fallback_timer = 0.0;
    c->hip_bump = c->dth2 + c->p.Kp_theta * (c->th2 - c->th2_erect);
}

/* ------------------------------------------------------------------------------------------- */

static int zmp_beyond_limit(const ahc_controller *c, int *sign)
{
    if (c->zmp_f >= c->p.zmp_limit_front) { *sign = 1; return 1; }
    if (c->zmp_f <= c->p.zmp_limit_back) { *sign = -1; return 1; }
    return 0;
}

/* All phase switches in one place (docs/controller.md §4, "The four phases"). */
static void phase_transitions(ahc_controller *c, const tick_ctx *k)
{
    const ahc_params *p = &c->p;
    int sign = 1;

    if (!p->hip_strategy_enabled) {
        /* Ankle strategy only: reaching p_lim changes nothing. */
        if (c->phase != AHC_PHASE_ANKLE) enter_ankle(c);
        return;
    }

    switch (c->phase) {
    case AHC_PHASE_ANKLE:
        /* 0 -> 1: the (filtered) ZMP reaches the safety limit on either side. */
        if (zmp_beyond_limit(c, &sign)) enter_ankle_to_hip(c, k, sign);
        break;
    case AHC_PHASE_ANKLE_TO_HIP:
        /* 1 -> 2: after T_ah (round(T_ah / h) ticks in phase 1); the duration the splines were
         * built with, in case T_ah was changed during the transition. */
        if (c->phase_time >= c->kw_spline.T - 0.5 * k->h) enter_hip(c);
        break;
    case AHC_PHASE_HIP: {
        /* 2 -> 3: paper: r_z back in the band near erect AND p on the side opposite to the push;
         * fallback (prototype finding 3, docs/controller.md §4.2): |d| small and hip near erect for fallback_dwell. */
        const double drz = k->rz - c->rz_erect;
        const int paper = drz >= p->rz_band_low && drz <= p->rz_band_high &&
                          (double)c->push_sign * c->zmp_f < 0.0;
        const int quiet = fabs(k->d) <= p->fallback_disturbance_tol && fabs(k->e2) <= p->fallback_hip_tol;
        c->fallback_timer = quiet ? c->fallback_timer + k->h : 0.0;
        if (paper || (quiet && c->fallback_timer >= p->fallback_dwell - 0.5 * k->h))
            enter_hip_to_ankle(c);
        break;
    }
    case AHC_PHASE_HIP_TO_ANKLE:
        /* A new push while returning: back to the hip strategy (k_w = 1 and r_x_d = the lean already). */
        if (zmp_beyond_limit(c, &sign)) {
            c->push_sign = sign;
            enter_hip(c);
        } else if (fabs(k->e2) <= p->return_hip_angle_tol && fabs(c->dth2) <= p->return_hip_rate_tol &&
                   (fabs(c->lean) <= LEAN_RETURN_TOL || pendulum_lean(p))) {
            /* 3 -> 0: hip back at erect (and, with the low-pass lean, the lean released: eq. 11 would
             * otherwise give way to a push that is still on; the pendulum lean goes on in phase 0). */
            enter_ankle(c);
        }
        break;
    default:
        enter_ankle(c);
        break;
    }
}

/* ------------------------------------------------------------------------------------------- */
/* Control laws; each integrates the reference over one tick. */

/* Eq. 11: th1'' = (d - Ca th1' - Ka th1) / (I + m lg^2), th1 from the erect posture. Semi-implicit
 * Euler. */
static void law_ankle_strategy(ahc_controller *c, const tick_ctx *k)
{
    const double acc = (k->d - c->p.Ca * c->dth1 - c->p.Ka * (c->th1 - c->th1_erect)) / k->Ja;
    c->dth1 += k->h * acc;
    c->th1 += k->h * c->dth1;
}

/* Eq. 16: th2'' = (m2 g (p - r_x) - Ch th2' - Kh th2) / (I2 + m2 lg2^2), with
 * m2 g (p - r_x) = k_m d, th2 from the erect posture. Semi-implicit Euler. */
static void law_hip_strategy(ahc_controller *c, const tick_ctx *k)
{
    const double acc = (c->km * k->d - c->p.Ch * c->dth2 - c->p.Kh * (c->th2 - c->th2_erect)) / c->J2;
    c->dth2 += k->h * acc;
    c->th2 += k->h * c->dth2;
}

/* Eq. 25: th2' = -Kp_theta th2 (+ decaying bumpless offset), th2 from the erect posture. Explicit
 * Euler. */
static void law_hip_regulator(ahc_controller *c, const tick_ctx *k)
{
    c->dth2 = -c->p.Kp_theta * (c->th2 - c->th2_erect) + c->hip_bump;
    c->th2 += k->h * c->dth2;
    c->hip_bump *= exp(-c->p.Kp_theta * k->h);
}

/* Eqs. 23-24: th1' = r_z/(r_z^2 + a^2) r_x_ref' + k_w ratio th2',
 *             r_x_ref' = r_x_d' + Kpr (r_x_d - r_x)   (feed-forward: prototype finding 2 (docs/controller.md §4.2)).
 * Uses the hip rate commanded this tick. Explicit Euler. */
static void law_ankle_reactionless(ahc_controller *c, const tick_ctx *k)
{
    const double n2 = k->rz * k->rz + k->a * k->a;
    const double rdot = c->drxd + c->p.Kpr * (c->rxd - k->rx);
    c->dth1 = (n2 > 1e-12 ? k->rz / n2 * rdot : 0.0) + c->k_w * k->ratio * c->dth2;
    c->th1 += k->h * c->dth1;
}

/* Sustained-push lean (our extension, not the paper's; docs/controller.md section 4.6). A constant
 * external moment D about the sole point shifts the ZMP by D/(m g) ahead of where the CoM alone
 * puts it; moving the CoM back by D/(m g) puts the ZMP back under the ankle. The lean follows the
 * moment-balance estimate of D (external_moment: the ZMP minus the reaction of the robot's own
 * motion; m g (p - r_x) would feed the lean's own motion back and oscillate) through two
 * first-order stages of lean_tau/2, so that only a sustained push moves the CoM, bounded to
 * lean_margin inside the sole: the sustained-push limit rises from m g (x_toe - r_x)/h towards
 * m g (x_toe - x_heel)/h (docs/capability.md). Phases 1-3 add it to r_x_d; phase 0 ignores it. */
static void lean_estimate(ahc_controller *c, double ext)
{
    const ahc_params *p = &c->p;
    /* The moment balance assumes the sole flat on the ground. With the ZMP at an edge the foot may
     * be rocking about it and the estimate means nothing: at the edge the push drives the ZMP to
     * (the toe for a push from behind, D > 0) the lean holds; at the opposite edge the push is
     * gone and the robot rebounds, and the lean is released (its filter runs towards 0). */
    const int at_toe = c->zmp_f >= p->toe_x - LEAN_EDGE, at_heel = c->zmp_f <= p->heel_x + LEAN_EDGE;
    if (!((at_toe && c->lean_f > 0.0) || (at_heel && c->lean_f < 0.0))) {
        const double in = (at_toe || at_heel) ? 0.0 : ext;
        c->lean_f1 += c->lean_alpha * (in - c->lean_f1);
        c->lean_f += c->lean_alpha * (c->lean_f1 - c->lean_f);
    }
}

static void update_lean(ahc_controller *c, tick_ctx *k, double ext)
{
    const ahc_params *p = &c->p;
    double next;
    if (c->phase == AHC_PHASE_ANKLE) {
        /* The lean integrates the push from the tick the hip strategy is called: a push that the
         * ankle strategy handles alone leaves no lean behind. */
        c->lean_f1 = c->lean_f = c->lean = 0.0;
        return;
    }
    lean_estimate(c, ext);
    next = clampd(-c->lean_f / (c->m * p->g), p->heel_x + p->lean_margin, p->toe_x - p->lean_margin);
    k->dlean = (next - c->lean) / k->h;
    c->lean = next;
}

/* ------------------------------------------------------------------------------------------- */
/* Beyond the paper: the sagittal pendulum lean (lean_law = AHC_LEAN_PENDULUM; our extension,
 * docs/controller.md section 4.7; the frontal lean's F26-F29 of section 11.2 on the sole's length).
 * With lean_enabled and this law the lean runs in every phase: the CoM reference is the linear
 * inverted pendulum's CoM c under the estimated moment D, c'' = w^2 (c - p + D/(m g)), its ZMP p
 * planned by capture-point feedback toward the target -D/(m g) and kept lean_zmp_margin inside toe
 * and heel, its capture point xi = c + c'/w kept lean_margin inside them; in phase 0 eq. 11 acts on
 * the ankle's deviation from the angle that carries the planned CoM. With lean_law = 0 none of this
 * runs: the paper's law (and section 4.6's lean) bit for bit. */

static int pendulum_lean(const ahc_params *p) { return p->lean_enabled && p->lean_law == AHC_LEAN_PENDULUM; }

static void update_lean_pendulum(ahc_controller *c, tick_ctx *k, double ext)
{
    const ahc_params *p = &c->p;
    const double h = k->h, w = c->omega_x, lo = p->heel_x + p->lean_margin, hi = p->toe_x - p->lean_margin;
    double off, target, xi, plo, phi, next;
    lean_estimate(c, ext);
    off = c->lean_f / (c->m * p->g);
    target = clampd(-off, lo, hi);
    xi = c->lean + c->lean_rate / w;
    /* the planned ZMP keeps its margin but where holding the target, or bringing the capture point
     * back from beyond it, needs the ZMP closer to the edge (F28's yield) */
    plo = (target + off < p->heel_x + p->lean_zmp_margin || xi < p->heel_x + p->lean_zmp_margin)
              ? p->heel_x : p->heel_x + p->lean_zmp_margin;
    phi = (target + off > p->toe_x - p->lean_zmp_margin || xi > p->toe_x - p->lean_zmp_margin)
               ? p->toe_x : p->toe_x - p->lean_zmp_margin;
    c->lean_p = clampd(xi + p->lean_capture_gain * (xi - target) + off, plo, phi);
    c->lean_rate += h * w * w * (c->lean - c->lean_p + off);
    /* F29: the capture point stays within the sole less lean_margin (capturable if the push ends now) */
    c->lean_rate = clampd(c->lean_rate, w * (lo - c->lean), w * (hi - c->lean));
    next = c->lean + h * c->lean_rate;
    if (next < lo || next > hi) {
        next = clampd(next, lo, hi);
        c->lean_rate = 0.0;
    }
    k->dlean = (next - c->lean) / h;
    c->lean = next;
}

/* Eq. 11 about the plan (phase 0): the ankle follows the angle that carries the planned CoM,
 * th1_plan = th1_erect + lean / r_z (d r_x / d th1 = r_z, eq. 20), and eq. 11's spring-damper acts
 * on the deviation from it, driven by the part of d the plan does not expect, d - m g (p_plan - lean). */
static void law_ankle_strategy_planned(ahc_controller *c, const tick_ctx *k)
{
    const double rz = k->rz > 1e-9 ? k->rz : 1e-9;
    const double plan = c->th1_erect + c->lean / rz, dplan = k->dlean / rz;
    const double dd = k->d - c->m * c->p.g * (c->lean_p - c->lean);
    double dev = c->th1 - c->th1_plan, ddev = c->dth1 - c->dth1_plan;
    ddev += k->h * (dd - c->p.Ca * ddev - c->p.Ka * dev) / k->Ja;
    dev += k->h * ddev;
    c->th1 = plan + dev;
    c->dth1 = dplan + ddev;
}

/* ------------------------------------------------------------------------------------------- */

unsigned ahc_sensor_faults(const ahc_params *p, const ahc_sensors *s)
{
    unsigned f = 0;
    if (!isfinite(s->theta_ankle))
        f |= AHC_FAULT_THETA_ANKLE_NONFINITE;
    else if (s->theta_ankle < p->ankle_min - p->angle_fault_margin ||
             s->theta_ankle > p->ankle_max + p->angle_fault_margin)
        f |= AHC_FAULT_ANGLE_RANGE;
    if (!isfinite(s->theta_hip))
        f |= AHC_FAULT_THETA_HIP_NONFINITE;
    else if (s->theta_hip < p->hip_min - p->angle_fault_margin ||
             s->theta_hip > p->hip_max + p->angle_fault_margin)
        f |= AHC_FAULT_ANGLE_RANGE;
    if (!isfinite(s->zmp_x))
        f |= AHC_FAULT_ZMP_NONFINITE;
    else if (s->zmp_x > p->toe_x + p->zmp_fault_margin || s->zmp_x < p->heel_x - p->zmp_fault_margin)
        f |= AHC_FAULT_ZMP_OUTSIDE_FOOT;
    if (!isfinite(s->fz))
        f |= AHC_FAULT_FZ_NONFINITE;
    else if (s->fz < p->fz_lifted)
        f |= AHC_FAULT_LIFTED;
    else if (s->fz > p->fz_max)
        f |= AHC_FAULT_FZ_IMPLAUSIBLE; /* never fed to the disturbance estimate */
    return f;
}

static int finite4(double a, double b, double c, double d)
{
    return isfinite(a) && isfinite(b) && isfinite(c) && isfinite(d);
}

static void write_outputs(ahc_controller *c, const tick_ctx *k, ahc_outputs *out)
{
    memset(out, 0, sizeof *out); /* deterministic padding bytes: outputs can be compared with memcmp */
    out->theta_ankle_ref = c->th1;
    out->theta_hip_ref = c->th2;
    out->dtheta_ankle_ref = c->dth1;
    out->dtheta_hip_ref = c->dth2;
    out->phase = c->phase;
    out->com_x = k->rx_meas;
    out->com_z = k->rz_meas;
    out->disturbance_moment = k->d;
    out->k_w = c->phase == AHC_PHASE_ANKLE ? 0.0 : c->k_w;
    out->com_x_desired = c->phase == AHC_PHASE_ANKLE ? k->rx : c->rxd;
    out->fault = c->fault;
    c->last_out = *out;
}

/* Paper reading of the disturbance: d = m g (p - r_x) from the filtered ZMP, with the feet handled
 * as feet_offset_mode says (prototype finding 5, docs/controller.md §4.2). */
static double disturbance_paper(ahc_controller *c, const tick_ctx *k)
{
    const ahc_params *p = &c->p;
    const double e = c->zmp_f - k->rx_meas;
    switch (p->feet_offset_mode) {
    case AHC_FEET_MODEL:
        /* Quasi-static moment balance about the ankle projection with the feet included:
         * (m + m_f) g p = m g r_x + m_f g x_f + tau_push  =>  tau_push = m g (p - r_x) + m_f g (p - x_f). */
        return c->m * p->g * e + p->feet_mass * p->g * (c->zmp_f - p->feet_com_x);
    case AHC_FEET_CALIBRATE:
        if (!c->calib_done) {
            c->calib_sum += e;
            c->calib_n++;
            if ((double)c->calib_n * k->h >= p->feet_calibration_time - 0.5 * k->h) {
                c->calib_bias = c->calib_sum / (double)c->calib_n;
                c->calib_done = 1;
            }
            return 0.0;
        }
        return c->m * p->g * (e - c->calib_bias);
    default:
        return c->m * p->g * e;
    }
}

/* Reaction-compensated disturbance (reaction_compensation = 1). Moment balance of the whole robot
 * about the sole point O under the ankle (x forward, z up, feet resting flat):
 *     p f_z = g sum_i m_i x_i + d + dH_O/dt,
 *     dH_O/dt = sum_i m_i (x_i z_i'' - z_i x_i'') - I_1 th1'' - I_2 (th1'' + th2''),
 * with z measured from the sole (ankle_height + link geometry). The measured ZMP contains the
 * reaction of the robot's own motion (dH_O/dt); eq. 11 and eq. 16 fed with it form an algebraic
 * loop (gain ~1.1 at the ankle, ~1.3 at the hip for HOAP-2). Subtracting dH_O/dt computed from the
 * measured joint angles (backward differences over the last three ticks) leaves the external
 * disturbance moment about O (raw here; disturbance_moment_balance low-passes it by two first-order
 * stages of zmp_filter_tau/2, update_lean by two of lean_tau/2). Updates the angle history. */
static double external_moment(ahc_controller *c, const ahc_sensors *s, const tick_ctx *k)
{
    const ahc_params *p = &c->p;
    const double h = p->sample_period;
    const double th1 = s->theta_ankle, th12 = s->theta_ankle + s->theta_hip;
    double w1 = 0.0, w12 = 0.0, a1 = 0.0, a12 = 0.0, raw;
    double x1, z1, x2, z2, ddx1, ddz1, ddx2, ddz2, dH, grav;
    const double S1 = sin(th1), C1 = cos(th1), S12 = sin(th12), C12 = cos(th12);

    if (c->hist_n >= 1) {
        w1 = (th1 - c->hist_th1[0]) / h;
        w12 = (th12 - c->hist_th1[0] - c->hist_th2[0]) / h;
    }
    if (c->hist_n >= 2) {
        a1 = (th1 - 2.0 * c->hist_th1[0] + c->hist_th1[1]) / (h * h);
        a12 = (th12 - 2.0 * (c->hist_th1[0] + c->hist_th2[0]) + c->hist_th1[1] + c->hist_th2[1]) / (h * h);
    }
    c->hist_th1[1] = c->hist_th1[0];
    c->hist_th2[1] = c->hist_th2[0];
    c->hist_th1[0] = s->theta_ankle;
    c->hist_th2[0] = s->theta_hip;
    if (c->hist_n < 2) c->hist_n++;

    x1 = p->lg1 * S1;
    z1 = p->ankle_height + p->lg1 * C1;
    x2 = p->l1 * S1 + p->lg2 * S12;
    z2 = p->ankle_height + p->l1 * C1 + p->lg2 * C12;
    ddx1 = p->lg1 * (C1 * a1 - S1 * w1 * w1);
    ddz1 = -p->lg1 * (S1 * a1 + C1 * w1 * w1);
    ddx2 = p->l1 * (C1 * a1 - S1 * w1 * w1) + p->lg2 * (C12 * a12 - S12 * w12 * w12);
    ddz2 = -p->l1 * (S1 * a1 + C1 * w1 * w1) - p->lg2 * (S12 * a12 + C12 * w12 * w12);
    if (p->link1_com_x != 0.0 || p->link2_com_x != 0.0) {
        /* the CoM offsets: d C added to x, -d S to z (and their second derivatives) */
        const double d1 = p->link1_com_x, d2 = p->link2_com_x;
        x1 += d1 * C1;
        z1 -= d1 * S1;
        x2 += d2 * C12;
        z2 -= d2 * S12;
        ddx1 += -d1 * (S1 * a1 + C1 * w1 * w1);
        ddz1 -= d1 * (C1 * a1 - S1 * w1 * w1);
        ddx2 += -d2 * (S12 * a12 + C12 * w12 * w12);
        ddz2 -= d2 * (C12 * a12 - S12 * w12 * w12);
    }
    dH = p->m1 * (x1 * ddz1 - z1 * ddx1) + p->m2 * (x2 * ddz2 - z2 * ddx2) - p->I1 * a1 - p->I2 * a12;

    /* Gravity moment of the measured posture, and of the feet if modelled. */
    grav = p->g * c->m * k->rx_meas;
    if (p->feet_offset_mode != AHC_FEET_IGNORE) grav += p->g * p->feet_mass * p->feet_com_x;
    raw = s->zmp_x * s->fz - grav - dH;
    return raw;
}

/* reaction_compensation = 1: the external moment, low-passed (and calibrated) for eqs. 11/16. */
static double disturbance_moment_balance(ahc_controller *c, double raw)
{
    const ahc_params *p = &c->p;
    const double h = p->sample_period;

    /* Two first-order stages of tau/2 each: the same DC gain and about the same delay as the ZMP
     * filter, but the double-differenced encoder noise is attenuated by alpha^2 instead of alpha
     * at high frequency. */
    if (!c->d_f_valid) {
        c->d_f1 = raw;
        c->d_f = raw;
    } else {
        c->d_f1 += c->d_alpha * (raw - c->d_f1);
        c->d_f += c->d_alpha * (c->d_f1 - c->d_f);
    }
    c->d_f_valid = 1;
    if (p->feet_offset_mode == AHC_FEET_CALIBRATE) {
        if (!c->calib_done) {
            c->calib_sum += c->d_f;
            c->calib_n++;
            if ((double)c->calib_n * h >= p->feet_calibration_time - 0.5 * h) {
                c->calib_bias = c->calib_sum / (double)c->calib_n;
                c->calib_done = 1;
            }
            return 0.0;
        }
        return c->d_f - c->calib_bias;
    }
    return c->d_f;
}

void ahc_step(ahc_controller *c, const ahc_sensors *s, ahc_outputs *out)
{
    const ahc_params *p = &c->p;
    tick_ctx k;
    double kin1, kin2, ext = 0.0;
    unsigned f;

    memset(&k, 0, sizeof k);
    if (!c->valid) {
        memset(out, 0, sizeof *out);
        out->fault = AHC_FAULT_NOT_INITIALIZED;
        c->tick++;
        return;
    }
    k.h = p->sample_period;
    f = ahc_sensor_faults(p, s);

    if (f & AHC_FAULT_HOLD_MASK) {
        /* Hold a safe reference: angles frozen, rates zero, timers paused, no NaN anywhere. */
        c->holding = 1;
        c->dth1 = 0.0;
        c->dth2 = 0.0;
        c->hip_bump = 0.0;
        c->fallback_timer = 0.0;
        c->fault = f;
        ahc_com(p, c->started ? c->last_th1 : c->th1, c->started ? c->last_th2 : c->th2, &k.rx, &k.rz);
        k.rx_meas = k.rx;
        k.rz_meas = k.rz;
        k.d = 0.0;
        write_outputs(c, &k, out);
        c->tick++;
        return;
    }

    if (!c->started) {
        /* Bumpless start from the robot's current posture. */
        c->th1 = clampd(s->theta_ankle, p->ankle_min, p->ankle_max);
        c->th2 = clampd(s->theta_hip, p->hip_min, p->hip_max);
        c->dth1 = c->dth2 = 0.0;
        c->started = 1;
    }
    if (c->holding) {
        /* Recovery: restart the ZMP filter and the finite differences from the fresh sample. */
        c->holding = 0;
        c->zmp_f_valid = 0;
        c->hist_n = 0;
        c->d_f_valid = 0;
    }
    c->last_th1 = s->theta_ankle;
    c->last_th2 = s->theta_hip;

    /* ZMP low-pass filter, exact discretisation of tau y' = u - y (prototype finding 1, docs/controller.md §4.2). */
    if (!c->zmp_f_valid) {
        c->zmp_f = s->zmp_x;
        c->zmp_f_valid = 1;
    } else {
        c->zmp_f += c->zmp_alpha * (s->zmp_x - c->zmp_f);
    }

    /* Kinematics. */
    kin1 = p->kinematics_source == AHC_KIN_REFERENCE ? c->th1 : s->theta_ankle;
    kin2 = p->kinematics_source == AHC_KIN_REFERENCE ? c->th2 : s->theta_hip;
    ahc_com(p, kin1, kin2, &k.rx, &k.rz);
    ahc_com(p, s->theta_ankle, s->theta_hip, &k.rx_meas, &k.rz_meas);
    k.a = p->link2_com_x != 0.0 ? c->km * (p->lg2 * cos(kin1 + kin2) - p->link2_com_x * sin(kin1 + kin2))
                                : c->km * p->lg2 * cos(kin1 + kin2);
    k.e2 = c->th2 - c->th2_erect;
    k.ratio = ahc_reactionless_ratio(p, kin1, kin2);
    k.Ja = ahc_ankle_inertia(p, kin2);

    /* Disturbance estimate d (eq. 11's m g (p - r_x); prototype findings 1 and 5, docs/controller.md §4.2). */
    if (p->reaction_compensation || p->lean_enabled) ext = external_moment(c, s, &k);
    k.d = p->reaction_compensation ? disturbance_moment_balance(c, ext)
                                   : disturbance_paper(c, &k);

    if (pendulum_lean(p))
        update_lean_pendulum(c, &k, ext);
    else if (p->lean_enabled)
        update_lean(c, &k, ext);
    else
        c->lean = 0.0; /* switched off by ahc_update_params: no lean left behind */
    phase_transitions(c, &k);

    {
        const double th1_0 = c->th1, th2_0 = c->th2;
        switch (c->phase) {
        case AHC_PHASE_ANKLE:
            law_hip_regulator(c, &k);
            if (pendulum_lean(p))
                law_ankle_strategy_planned(c, &k);
            else
                law_ankle_strategy(c, &k);
            break;
        case AHC_PHASE_ANKLE_TO_HIP: {
            double dkw;
            ahc_quintic_eval(&c->kw_spline, c->phase_time, &c->k_w, &dkw, NULL);
            ahc_quintic_eval(&c->rxd_spline, c->phase_time, &c->rxd, &c->drxd, NULL);
            if (p->lean_enabled) { /* the lean blends in with k_w */
                c->rxd += c->k_w * c->lean;
                c->drxd += dkw * c->lean + c->k_w * k.dlean;
            }
            law_hip_strategy(c, &k);
            law_ankle_reactionless(c, &k);
            break;
        }
        case AHC_PHASE_HIP:
            c->k_w = 1.0;
            c->rxd = c->lean; /* 0 unless lean_enabled */
            c->drxd = k.dlean;
            law_hip_strategy(c, &k);
            law_ankle_reactionless(c, &k);
            break;
        default: /* AHC_PHASE_HIP_TO_ANKLE */
            c->k_w = 1.0;
            c->rxd = c->lean;
            c->drxd = k.dlean;
            law_hip_regulator(c, &k);
            law_ankle_reactionless(c, &k);
            break;
        }
        if (pendulum_lean(p)) { /* the angle that carries the planned CoM, for eq. 11 in phase 0 */
            const double rz = k.rz > 1e-9 ? k.rz : 1e-9;
            c->th1_plan = c->th1_erect + c->lean / rz;
            c->dth1_plan = k.dlean / rz;
        }
        c->phase_time += k.h;

        /* Last-resort guard (cannot happen with validated params and healthy inputs). */
        if (!finite4(c->th1, c->dth1, c->th2, c->dth2) || !isfinite(c->hip_bump)) {
            c->th1 = th1_0;
            c->th2 = th2_0;
            c->dth1 = c->dth2 = c->hip_bump = 0.0;
        }
    }

    /* Joint limits: clamp the reference and stop its rate. */
    f = 0;
    if (c->th1 < p->ankle_min || c->th1 > p->ankle_max) {
        c->th1 = clampd(c->th1, p->ankle_min, p->ankle_max);
        c->dth1 = 0.0;
        f |= AHC_FAULT_REF_SATURATED;
    }
    if (c->th2 < p->hip_min || c->th2 > p->hip_max) {
        c->th2 = clampd(c->th2, p->hip_min, p->hip_max);
        c->dth2 = 0.0;
        c->hip_bump = 0.0;
        f |= AHC_FAULT_REF_SATURATED;
    }
    c->fault = f;
    write_outputs(c, &k, out);
    c->tick++;
}

/* ------------------------------------------------------------------------------------------- */

static int in_range(double x, double lo, double hi) { return isfinite(x) && x >= lo && x <= hi; }

#define STATE_FAIL(...) ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, __VA_ARGS__)

static int state_invariants(const ahc_controller *c, char *msg, size_t msg_size);


int ahc_state_validate(const ahc_controller *c, char *msg, size_t msg_size)
{
    /* Bound on every state value without a tighter physical range: rates [rad/s], moments [N m]
     * and sums that a running controller keeps many orders of magnitude below it. */
    const double big = 1e9;
    const ahc_params *p;
    ahc_controller ref;
    int rc, i;
    if (msg && msg_size > 0) msg[0] = '\0';
    if (!c) return AHC_ERR_NULL;
    if (c->valid != 0 && c->valid != 1) return STATE_FAIL("valid = %d is not 0 or 1", c->valid);
    if (!c->valid) return AHC_OK; /* ahc_step reads nothing but `valid` then */
    p = &c->p;
    rc = ahc_params_validate(p, msg, msg_size);
    if (rc != AHC_OK) return rc;

    ref = *c; /* derived constants must be those of the parameters */
    compute_derived(&ref);
    if (ref.m != c->m || ref.km != c->km || ref.J2 != c->J2 || ref.rz_erect != c->rz_erect ||
        ref.th1_erect != c->th1_erect || ref.th2_erect != c->th2_erect ||
        ref.zmp_alpha != c->zmp_alpha || ref.d_alpha != c->d_alpha || ref.lean_alpha != c->lean_alpha ||
        ref.omega_x != c->omega_x)
        return STATE_FAIL("derived constants do not match the parameters");

    {
        const struct { const char *name; int v, hi; } flags[] = {
            {"started", c->started, 1}, {"zmp_f_valid", c->zmp_f_valid, 1}, {"calib_done", c->calib_done, 1},
            {"holding", c->holding, 1}, {"d_f_valid", c->d_f_valid, 1}, {"hist_n", c->hist_n, 2},
            {"phase", c->phase, AHC_PHASE_HIP_TO_ANKLE}, {"last_out.phase", c->last_out.phase, AHC_PHASE_HIP_TO_ANKLE},
        };
        for (i = 0; i < (int)(sizeof flags / sizeof flags[0]); ++i)
            if (flags[i].v < 0 || flags[i].v > flags[i].hi)
                return STATE_FAIL("%s = %d is outside [0, %d]", flags[i].name, flags[i].v, flags[i].hi);
    }
    if (c->push_sign != 1 && c->push_sign != -1) return STATE_FAIL("push_sign = %d is not +-1", c->push_sign);
    if ((c->fault & ~(unsigned)AHC_FAULT_ALL_MASK) || (c->last_out.fault & ~(unsigned)AHC_FAULT_ALL_MASK))
        return STATE_FAIL("fault = 0x%x has undefined bits", c->fault | c->last_out.fault);

    {
        /* Values with a physical range: the reference angles are clamped to the joint limits, the
         * measured angles and the (filtered) ZMP were accepted by ahc_sensor_faults(), k_w is a weight. */
        const double am = p->angle_fault_margin, zm = p->zmp_fault_margin;
        const struct { const char *name; double v, lo, hi; } ranged[] = {
            {"th1", c->th1, p->ankle_min, p->ankle_max},
            {"th2", c->th2, p->hip_min, p->hip_max},
            {"last_th1", c->last_th1, p->ankle_min - am, p->ankle_max + am},
            {"last_th2", c->last_th2, p->hip_min - am, p->hip_max + am},
            {"hist_th1[0]", c->hist_th1[0], p->ankle_min - am, p->ankle_max + am},
            {"hist_th1[1]", c->hist_th1[1], p->ankle_min - am, p->ankle_max + am},
            {"hist_th2[0]", c->hist_th2[0], p->hip_min - am, p->hip_max + am},
            {"hist_th2[1]", c->hist_th2[1], p->hip_min - am, p->hip_max + am},
            {"zmp_f", c->zmp_f, p->heel_x - zm, p->toe_x + zm},
            {"k_w", c->k_w, 0.0, 1.0},
            {"phase_time", c->phase_time, 0.0, big},
            {"fallback_timer", c->fallback_timer, 0.0, big},
            {"kw_spline.T", c->kw_spline.T, 1e-6, 100.0},
            {"rxd_spline.T", c->rxd_spline.T, 1e-6, 100.0},
            {"last_out.k_w", c->last_out.k_w, 0.0, 1.0},
            {"lean", c->lean, p->heel_x, p->toe_x},
        };
        const struct { const char *name; double v; } bounded[] = {
            {"dth1", c->dth1}, {"dth2", c->dth2}, {"hip_bump", c->hip_bump}, {"rxd", c->rxd}, {"drxd", c->drxd},
            {"calib_sum", c->calib_sum}, {"calib_bias", c->calib_bias}, {"d_f1", c->d_f1}, {"d_f", c->d_f},
            {"lean_f1", c->lean_f1}, {"lean_f", c->lean_f}, {"lean_rate", c->lean_rate}, {"lean_p", c->lean_p},
            {"th1_plan", c->th1_plan}, {"dth1_plan", c->dth1_plan},
            {"last_out.theta_ankle_ref", c->last_out.theta_ankle_ref},
            {"last_out.theta_hip_ref", c->last_out.theta_hip_ref},
            {"last_out.dtheta_ankle_ref", c->last_out.dtheta_ankle_ref},
            {"last_out.dtheta_hip_ref", c->last_out.dtheta_hip_ref}, {"last_out.com_x", c->last_out.com_x},
            {"last_out.com_z", c->last_out.com_z}, {"last_out.disturbance_moment", c->last_out.disturbance_moment},
            {"last_out.com_x_desired", c->last_out.com_x_desired},
        };
        for (i = 0; i < (int)(sizeof ranged / sizeof ranged[0]); ++i)
            if (!in_range(ranged[i].v, ranged[i].lo, ranged[i].hi))
                return STATE_FAIL("%s = %g is outside [%g, %g]", ranged[i].name, ranged[i].v, ranged[i].lo,
                                  ranged[i].hi);
        for (i = 0; i < (int)(sizeof bounded / sizeof bounded[0]); ++i)
            if (!in_range(bounded[i].v, -big, big))
                return STATE_FAIL("%s = %g is not finite or beyond +-%g", bounded[i].name, bounded[i].v, big);
    }
    return state_invariants(c, msg, msg_size);
}

/* The relations ahc_init and ahc_step keep between the fields (each checked field is finite and in
 * range already). A forged k_w spline coefficient made k_w = -0.99 in phase 1. */
static int state_invariants(const ahc_controller *c, char *msg, size_t msg_size)
{
    const ahc_params *p = &c->p;
    const double h = p->sample_period;
    const ahc_param_info *T_ah = ahc_param_find("T_ah");
    const double ran = (double)c->tick * h; /* time the ticks ran [s] */
    int rc;

    if (c->tick > AHC_TICK_MAX) return STATE_FAIL("tick = %llu is beyond %llu", c->tick, AHC_TICK_MAX);
    /* eqs. 23-24's splines over one T_ah (in its range), from T and the start; k_w by phase */
    if (c->kw_spline.T < T_ah->min || c->kw_spline.T > T_ah->max)
        return STATE_FAIL("spline duration %g is not a T_ah in [%g, %g]", c->kw_spline.T, T_ah->min, T_ah->max);
    rc = ahc_transition_splines_check(&c->kw_spline, &c->rxd_spline, "rxd_spline", c->kw_spline.T, c->phase, c->k_w,
                                      msg, msg_size);
    if (rc != AHC_OK) return rc;
    if ((c->phase == AHC_PHASE_ANKLE_TO_HIP || c->phase == AHC_PHASE_HIP) && c->hip_bump != 0.0)
        return STATE_FAIL("hip_bump = %g in phase %d (eq. 16 holds the hip there)", c->hip_bump, c->phase);
    if (c->phase != AHC_PHASE_HIP && c->fallback_timer != 0.0)
        return STATE_FAIL("fallback_timer = %g outside phase 2", c->fallback_timer);
    /* Timers and counters advance once per tick. */
    if (c->phase_time > ran * (1.0 + 1e-6) + h || c->fallback_timer > c->phase_time * (1.0 + 1e-6) + h)
        return STATE_FAIL("phase_time = %g or fallback_timer = %g is longer than the %g s the %llu ticks ran",
                          c->phase_time, c->fallback_timer, ran, c->tick);
    if (c->calib_n > c->tick) return STATE_FAIL("calib_n = %llu is more than tick = %llu", c->calib_n, c->tick);
    if (c->tick == 0) {
        /* nothing has run since ahc_init / ahc_reset */
        if (c->started || c->holding || c->phase != AHC_PHASE_ANKLE || c->fault || c->zmp_f_valid || c->hist_n ||
            c->d_f_valid || c->calib_done || c->last_out.fault || c->last_out.phase || c->last_out.k_w != 0.0 ||
            c->th1 != 0.0 || c->th2 != 0.0 || c->dth1 != 0.0 || c->dth2 != 0.0)
            return STATE_FAIL("tick = 0 with a state that only ticks produce");
        return AHC_OK;
    }
    /* The last tick's outputs are the state it left (write_outputs). */
    if (c->holding != ((c->fault & AHC_FAULT_HOLD_MASK) != 0))
        return STATE_FAIL("holding = %d with fault = 0x%x", c->holding, c->fault);
    if (c->last_out.fault != c->fault || c->last_out.phase != c->phase ||
        c->last_out.k_w != (c->phase == AHC_PHASE_ANKLE ? 0.0 : c->k_w) || c->last_out.theta_ankle_ref != c->th1 ||
        c->last_out.theta_hip_ref != c->th2 || c->last_out.dtheta_ankle_ref != c->dth1 ||
        c->last_out.dtheta_hip_ref != c->dth2)
        return STATE_FAIL("last_out does not hold the last tick's phase, fault, k_w and references");
    return AHC_OK;
}

int ahc_state_validate_for(const ahc_controller *c, const ahc_params *p, unsigned long long tick, char *msg,
                           size_t msg_size)
{
    size_t n = 0, i;
    const ahc_param_info *t = ahc_param_table(&n);
    int rc = ahc_state_validate(c, msg, msg_size);
    if (rc != AHC_OK) return rc;
    if (!p) return AHC_ERR_NULL;
    if (!c->valid) return STATE_FAIL("the state is not initialized (valid = 0)");
    for (i = 0; i < n; ++i) {
        const char *a = (const char *)&c->p + t[i].offset, *b = (const char *)p + t[i].offset;
        if (t[i].is_int) {
            int x, y;
            memcpy(&x, a, sizeof x);
            memcpy(&y, b, sizeof y);
            if (x != y) return STATE_FAIL("%s = %d in the state, %d in the instance", t[i].name, x, y);
        } else {
            double x, y;
            memcpy(&x, a, sizeof x);
            memcpy(&y, b, sizeof y);
            if (memcmp(&x, &y, sizeof x) != 0)
                return STATE_FAIL("%s = %.17g in the state, %.17g in the instance", t[i].name, x, y);
        }
    }
    if (tick != AHC_TICK_ANY && c->tick != tick)
        return STATE_FAIL("tick = %llu in the state, %llu by the instance's clock", c->tick, tick);
    return AHC_OK;
}
