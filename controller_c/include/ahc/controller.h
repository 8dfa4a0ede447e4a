/*
 * controller.h — public C99 API of the ankle/hip balance controller with smooth transitions
 * (Nenchev & Nishio, "Ankle and Hip Balance Control Strategies with Transitions", ICRA 2010),
 * for a planar double inverted pendulum on the ankle (HOAP-2 defaults in hoap2/nominal.h).
 *
 * Properties: C99, no heap, no globals, only libc + libm; deterministic; one POD struct per
 * instance (ahc_controller contains no pointers, so it can be snapshotted with memcpy).
 * Units are SI everywhere. Sign conventions: docs/controller.md (x forward, angles positive
 * when the body above the joint pitches forward, x measured from the ankle's ground projection).
 * Full documentation: docs/controller.md.
 */
#ifndef AHC_CONTROLLER_H
#define AHC_CONTROLLER_H

#include <stddef.h>

#include "hoap2/nominal.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---------------------------------------------------------------------------------------------
 * Phases (paper section on transitions; our reading, docs/controller.md)
 * ------------------------------------------------------------------------------------------- */
enum {
    AHC_PHASE_ANKLE = 0,         /* ankle strategy (eq. 11), hip held erect (eq. 25)           */
    AHC_PHASE_ANKLE_TO_HIP = 1,  /* quintic k_w 0->1 and r_x_d -> 0 over T_ah (eqs. 16, 23, 24) */
    AHC_PHASE_HIP = 2,           /* hip strategy: eq. 16 hip, eq. 23 ankle with k_w = 1, r_x_d = 0 */
    AHC_PHASE_HIP_TO_ANKLE = 3   /* hip regulator (eq. 25), ankle eq. 23; back to 0 when erect  */
};

/* ---------------------------------------------------------------------------------------------
 * Fault bits (ahc_outputs.fault). 0 = healthy.
 * "Hold" bits: while any of them is set the controller holds a safe reference (angles frozen at
 * the value of the fault onset, reference rates 0, phase timers paused) and recovers when all
 * inputs are healthy again. Warning bits do not trigger the hold.
 * ------------------------------------------------------------------------------------------- */
enum {
    AHC_FAULT_THETA_ANKLE_NONFINITE = 1u << 0, /* hold: theta_ankle is NaN or Inf               */
    AHC_FAULT_THETA_HIP_NONFINITE   = 1u << 1, /* hold: theta_hip is NaN or Inf                 */
    AHC_FAULT_ZMP_NONFINITE         = 1u << 2, /* hold: zmp_x is NaN or Inf                     */
    AHC_FAULT_FZ_NONFINITE          = 1u << 3, /* hold: fz is NaN or Inf                        */
    AHC_FAULT_ZMP_OUTSIDE_FOOT      = 1u << 4, /* hold: zmp_x beyond toe/heel by > zmp_fault_margin */
    AHC_FAULT_LIFTED                = 1u << 5, /* hold: fz < fz_lifted (robot lifted / no contact) */
    AHC_FAULT_ANGLE_RANGE           = 1u << 6, /* hold: a measured angle outside its joint limits
                                                  by more than angle_fault_margin              */
    AHC_FAULT_REF_SATURATED         = 1u << 7, /* warning: a reference angle was clamped to its
                                                  joint limit this tick                         */
    AHC_FAULT_NOT_INITIALIZED       = 1u << 8, /* hold: ahc_step called on an instance whose
                                                  ahc_init failed (outputs are zeros)           */
    AHC_FAULT_FZ_IMPLAUSIBLE        = 1u << 9  /* hold: fz > fz_max, more than the robot can
                                                  load its own feet with                        */
};
/* Mask of all bits that cause the hold. */
#define AHC_FAULT_HOLD_MASK                                                                       \
    (AHC_FAULT_THETA_ANKLE_NONFINITE | AHC_FAULT_THETA_HIP_NONFINITE | AHC_FAULT_ZMP_NONFINITE | \
     AHC_FAULT_FZ_NONFINITE | AHC_FAULT_ZMP_OUTSIDE_FOOT | AHC_FAULT_LIFTED |                     \
     AHC_FAULT_ANGLE_RANGE | AHC_FAULT_NOT_INITIALIZED | AHC_FAULT_FZ_IMPLAUSIBLE)
/* Mask of every defined bit. */
#define AHC_FAULT_ALL_MASK (AHC_FAULT_HOLD_MASK | AHC_FAULT_REF_SATURATED)

/* Error codes of ahc_params_validate / ahc_init. */
enum {
    AHC_OK = 0,
    AHC_ERR_NULL = 1,          /* a NULL pointer argument                                      */
    AHC_ERR_NONFINITE = 2,     /* a parameter is NaN or Inf                                    */
    AHC_ERR_RANGE = 3,         /* a parameter is outside its allowed range                     */
    AHC_ERR_INCONSISTENT = 4,  /* parameters contradict each other (e.g. ZMP limit outside foot) */
    AHC_ERR_UNKNOWN_NAME = 5   /* no configuration of that name (ahc_params_named)             */
};

/* Handling of the feet in the disturbance estimate (prototype finding 5, docs/controller.md §4.2). */
enum {
    AHC_FEET_IGNORE = 0,    /* paper literal (default): d = m g (p - r_x); the feet bias d by
                               ~ +0.03 N m (a 0.66 mrad lean at rest)                           */
    AHC_FEET_MODEL = 1,     /* include the feet's weight: d = m g (p - r_x) + m_f g (p - x_f)   */
    AHC_FEET_CALIBRATE = 2  /* zero d at rest: the mean of (p - r_x), or of d with
                               reaction_compensation, over feet_calibration_time after
                               init/reset is subtracted (robot must stand still then)         */
};

/* Source of the kinematic quantities r_x, r_z, C1, C12 of the kinematic laws (eqs. 15, 23, 24)
 * and the phase triggers. The disturbance estimate and the com_x/com_z outputs always use the
 * measured angles. */
enum {
    AHC_KIN_MEASURED = 0,   /* measured joint angles (our first reading of the paper): eq. 24's
                               CoM feedback at Kpr = 100/s then closes through the servo, which is
                               unstable unless the servo is much faster than 100 rad/s          */
    AHC_KIN_REFERENCE = 1   /* the controller's own reference angles (default): eqs. 23-24 are a
                               resolved-rate reference generator, the servo follows it          */
};

/* ---------------------------------------------------------------------------------------------
 * Parameters (SI). Every field is listed in ahc_param_table().
 * ------------------------------------------------------------------------------------------- */
typedef struct {
    /* model of the robot (controller's internal model) */
    double g;              /* gravitational acceleration [m/s^2]                                 */
    double m1;             /* mass of link 1 (legs) [kg]                                         */
    double l1;             /* length of link 1, ankle -> hip [m]                                 */
    double lg1;            /* ankle -> CoM of link 1 [m]                                         */
    double I1;             /* inertia of link 1 about its CoM [kg m^2]                           */
    double m2;             /* mass of link 2 (upper body) [kg]                                   */
    double lg2;            /* hip -> CoM of link 2 [m]                                           */
    double I2;             /* inertia of link 2 about its CoM [kg m^2]                           */
    double feet_mass;      /* mass of both feet [kg]                                             */
    double feet_com_x;     /* feet CoM, x forward of the ankle [m]                               */
    double feet_com_z;     /* feet CoM, height above the sole [m]                                */
    double toe_x;          /* toe edge x from the ankle [m] (> 0)                                */
    double heel_x;         /* heel edge x from the ankle [m] (< 0)                               */
    double ankle_height;   /* ankle axis height above the sole [m]                               */
    double ankle_min;      /* ankle joint lower limit [rad]                                      */
    double ankle_max;      /* ankle joint upper limit [rad]                                      */
    double hip_min;        /* hip joint lower limit [rad]                                        */
    double hip_max;        /* hip joint upper limit [rad]                                        */

    /* gains (paper values read as N mm/rad, converted to SI; docs/controller.md) */
    double Ka;             /* ankle virtual stiffness, eq. 11 [N m/rad]                          */
    double Ca;             /* ankle virtual damping, eq. 11 [N m s/rad]                          */
    double Kh;             /* hip virtual stiffness, eq. 16 [N m/rad]                            */
    double Ch;             /* hip virtual damping, eq. 16 [N m s/rad]                            */
    double Kpr;            /* CoM feedback gain, eq. 24 [1/s]                                    */
    double Kp_theta;       /* hip return regulator gain, eq. 25 [1/s]                            */

    /* phase logic */
    int hip_strategy_enabled;   /* 1: full controller; 0: ankle strategy only (limits ignored)  */
    double zmp_limit_front;     /* ZMP safety limit, toe side, x coordinate [m] (> 0)            */
    double zmp_limit_back;      /* ZMP safety limit, heel side, x coordinate [m] (< 0)           */
    double T_ah;                /* duration of the ankle->hip transition [s]                     */
    double rz_band_low;         /* hip->ankle trigger: r_z - r_z_erect >= rz_band_low [m]        */
    double rz_band_high;        /* hip->ankle trigger: r_z - r_z_erect <= rz_band_high [m]       */
    double fallback_disturbance_tol; /* fallback trigger: |d| <= this [N m] ...                 */
    double fallback_hip_tol;         /* ... and |theta2_ref| <= this [rad] ...                  */
    double fallback_dwell;           /* ... continuously for this time [s]                      */
    double return_hip_angle_tol;     /* phase 3 -> 0 when |theta2_ref| <= this [rad] ...        */
    double return_hip_rate_tol;      /* ... and |dtheta2_ref| <= this [rad/s]                   */

    /* sensing */
    double zmp_filter_tau;      /* time constant of the first-order ZMP low-pass [s] (0 = off)   */
    int feet_offset_mode;       /* AHC_FEET_IGNORE / AHC_FEET_MODEL / AHC_FEET_CALIBRATE         */
    double feet_calibration_time; /* averaging time of AHC_FEET_CALIBRATE [s]                    */
    int kinematics_source;      /* AHC_KIN_MEASURED / AHC_KIN_REFERENCE                          */

    /* faults */
    double fz_lifted;           /* fz below this counts as lifted [N]                            */
    double zmp_fault_margin;    /* zmp_x beyond the sole edge by more than this is a fault [m]   */
    double angle_fault_margin;  /* measured angle beyond its joint limit by more than this is a
                                   fault [rad]                                                   */

    /* timing */
    double sample_period;       /* one ahc_step advances by this [s]                             */

    /* sensing (appended: the parameter table's row order is stable) */
    int reaction_compensation;  /* 1: the disturbance estimate subtracts the rate of change of
                                   angular momentum of the measured joint motion (moment balance
                                   about the sole point, docs/controller.md "disturbance
                                   estimate"); 0 (default): paper literal, d = m g (p - r_x)   */
    double fz_max;              /* fz above this is an implausible reading (fault, hold) [N]     */

    /* sustained-push lean: our extension, not the paper's (docs/controller.md section 4.6) */
    int lean_enabled;           /* 1: in phases 1-3 r_x_d leans the CoM against the low-passed
                                   external moment D (moment balance), -D/(m g), bounded by the
                                   sole; 0 (default): the paper's r_x_d (bit-identical outputs)  */
    double lean_tau;            /* time constant of the external-moment low-pass the lean follows
                                   (two first-order stages of lean_tau/2) [s]                    */
    double lean_margin;         /* the leaned CoM reference stays this far inside toe and heel [m] */

    /* model of the robot, appended: where each link's CoM lies off its joint line (forward of it,
     * perpendicular to it, in the link's own frame) [m]. 0 (default) is the paper's model, CoMs on
     * the joint lines; the whole-body kinematics use them, and they define the erect posture
     * (docs/controller.md section 2.1) */
    double link1_com_x;         /* link 1's CoM forward of the ankle-hip line [m]                 */
    double link2_com_x;         /* link 2's CoM forward of its line through the hip [m]           */

    /* the sagittal pendulum lean, appended: our extension, not the paper's (docs/controller.md
     * section 4.7; used only with lean_enabled) */
    int lean_law;               /* AHC_LEAN_LOWPASS (default): section 4.6's lean, in phases 1-3;
                                   AHC_LEAN_PENDULUM: the linear inverted pendulum's CoM under the
                                   estimated moment, its ZMP planned by capture-point feedback, in
                                   every phase (eq. 11 follows the plan in phase 0)               */
    double lean_zmp_margin;     /* AHC_LEAN_PENDULUM: the planned ZMP stays this far inside toe and
                                   heel [m]                                                      */
    double lean_capture_gain;   /* AHC_LEAN_PENDULUM: the capture point converges at this multiple
                                   of the pendulum's rate [1]                                    */
} ahc_params;

/* lean_law (and the frontal lean_law_y) */
enum { AHC_LEAN_LOWPASS = 0, AHC_LEAN_PENDULUM = 1 };

/* Fill with the HOAP-2 defaults (hoap2/nominal.h) and the SI gains. */
void ahc_params_default(ahc_params *p);

/* The paper's configuration (ahc_params_named(p, "paper")): the paper's numbers and law wherever
 * the paper states them and they are stable on a plant (docs/controller.md section 4.5). */
void ahc_params_paper(ahc_params *p);

/* Named configurations, selectable by name: index 0 is "default" (ahc_params_default), then
 * "paper", then "omnidirectional" (the default with the sagittal pendulum lean, section 4.7). ahc_config_name / ahc_config_description return NULL past the end. The controller
 * FMU lists them, with the parameter values that differ from the defaults, in
 * resources/configurations.toml (generated from these functions). */
size_t ahc_config_count(void);
const char *ahc_config_name(size_t i);
const char *ahc_config_description(size_t i);
/* Fill p with the named configuration. AHC_OK, or AHC_ERR_UNKNOWN_NAME for an unknown name (or NULL) (p is then
 * filled with the defaults). */
int ahc_params_named(ahc_params *p, const char *name);

/* Validate. Returns AHC_OK (0) or an AHC_ERR_* code; on error writes a message naming the field
 * and its value into msg (if msg != NULL and msg_size > 0), e.g. "m1 = -1 must be > 0". */
int ahc_params_validate(const ahc_params *p, char *msg, size_t msg_size);

/* Parameter metadata: one row per ahc_params field, in declaration order. The single source of
 * truth for the FMU's parameter variables (start values come from ahc_params_default).
 * name = field name; offset = offsetof(ahc_params, field); is_int = 1 for int fields.
 * min/max: the allowed closed range. */
typedef struct {
    const char *name;
    const char *unit;        /* SI unit string ("kg", "m", "N.m/rad", "1/s", "s", "" ...)     */
    const char *description;
    double min, max;
    size_t offset;
    int is_int;
} ahc_param_info;

const ahc_param_info *ahc_param_table(size_t *count);
/* Row order is stable: new parameters are only ever appended (the FMU derives value references
 * from the row index). */

/* Look up a row by name (NULL if unknown). */
const ahc_param_info *ahc_param_find(const char *name);

/* ---------------------------------------------------------------------------------------------
 * Signals
 * ------------------------------------------------------------------------------------------- */
typedef struct {
    double theta_ankle;   /* measured ankle angle theta_1 [rad]                                */
    double theta_hip;     /* measured hip angle theta_2 [rad]                                  */
    double zmp_x;         /* measured ZMP, x from the ankle projection [m]                     */
    double fz;            /* total normal ground force [N]                                     */
} ahc_sensors;

typedef struct {
    double theta_ankle_ref;    /* ankle joint set point [rad]                                  */
    double theta_hip_ref;      /* hip joint set point [rad]                                    */
    double dtheta_ankle_ref;   /* ankle reference rate [rad/s]                                 */
    double dtheta_hip_ref;     /* hip reference rate [rad/s]                                   */
    int phase;                 /* AHC_PHASE_*                                                  */
    double com_x;              /* CoM projection r_x of the two-link body [m]                  */
    double com_z;              /* CoM height r_z above the ankle [m]                           */
    double disturbance_moment; /* d: external moment about the sole point under the ankle
                                  (reaction_compensation) or m g (p - r_x) [N m]            */
    double k_w;                /* reactionless weight of eq. 23 [1]                            */
    double com_x_desired;      /* r_x_d in phases 1-3; equals com_x in phase 0 [m]             */
    unsigned fault;            /* AHC_FAULT_* bit mask; 0 = healthy                            */
} ahc_outputs;

/* Quintic polynomial x(t) = sum c[i] t^i on [0, T]; evaluation clamps t to [0, T]. */
typedef struct {
    double c[6];
    double T;
} ahc_quintic;

/* ---------------------------------------------------------------------------------------------
 * Instance: plain old data, no pointers; copy it with memcpy to snapshot/restore.
 * Treat the fields as private; they may change between versions.
 * ------------------------------------------------------------------------------------------- */
typedef struct {
    ahc_params p;             /* copy of the parameters                                      */
    int valid;                /* 1 after a successful ahc_init                               */
    /* derived constants */
    double m;                 /* m1 + m2                                                     */
    double km;                /* m2 / m                                                      */
    double J2;                /* I2 + m2 lg2^2 (eq. 16 denominator)                          */
    double rz_erect;          /* erect CoM height of the model                               */
    double th1_erect, th2_erect; /* the erect posture: the whole CoM above the ankle and link
                                 2's above the hip (0, 0 with the CoMs on the joint lines) [rad] */
    double zmp_alpha;         /* ZMP filter coefficient 1 - exp(-h/tau)                      */
    /* time */
    unsigned long long tick;  /* number of completed ahc_step calls                          */
    int started;              /* reference states initialised from the first valid angles    */
    /* reference states (the controller's own "admittance" model) */
    double th1, dth1, th2, dth2;
    double hip_bump;          /* bumpless offset of the eq. 25 regulator [rad/s]             */
    /* phase machine */
    int phase;
    int push_sign;            /* +1 push from behind (toe-side limit), -1 from the front     */
    double phase_time;        /* time spent in the current phase [s]                         */
    double fallback_timer;    /* time the fallback condition has held [s]                    */
    ahc_quintic kw_spline;    /* k_w: 0 -> 1 over T_ah                                       */
    ahc_quintic rxd_spline;   /* r_x_d: (r_x, v0, 0) -> (0, 0, 0) over T_ah                  */
    double k_w, rxd, drxd;    /* current values                                              */
    /* sensing */
    double zmp_f;             /* filtered ZMP [m]                                            */
    int zmp_f_valid;
    double calib_sum;         /* AHC_FEET_CALIBRATE accumulator                              */
    double calib_bias;        /* subtracted from p - r_x [m] (or from d [N m] with
                                 reaction_compensation)                                  */
    unsigned long long calib_n;
    int calib_done;
    double last_th1, last_th2; /* last healthy measured angles                                */
    double hist_th1[2], hist_th2[2]; /* measured angles one and two ticks ago (finite differences) */
    int hist_n;               /* number of valid entries in hist_* (0..2)                     */
    double d_f1, d_f;         /* two-stage filtered disturbance estimate (reaction_compensation
                                 = 1): first stage, output [N m]                             */
    double d_alpha;           /* coefficient of each stage, 1 - exp(-2 h/tau)                  */
    int d_f_valid;
    /* sustained-push lean (lean_enabled) */
    double lean_f1, lean_f;   /* two-stage low-pass of the external moment [N m]: 1st, output  */
    double lean_alpha;        /* coefficient of each stage, 1 - exp(-2 h/lean_tau)             */
    double lean;              /* CoM offset -lean_f/(m g) clamped to the sole [m]              */
    /* the pendulum lean (lean_law = AHC_LEAN_PENDULUM): the pendulum's rate, its CoM's rate [m/s],
     * its planned ZMP [m], and the ankle angle and rate that carry the planned CoM */
    double omega_x, lean_rate, lean_p, th1_plan, dth1_plan;
    /* faults */
    unsigned fault;           /* bits of the last tick                                       */
    int holding;              /* 1 while a hold fault is active                              */
    ahc_outputs last_out;     /* outputs of the last tick                                    */
} ahc_controller;

/* Validate params, copy them and reset. Returns AHC_OK or the AHC_ERR_* code of
 * ahc_params_validate (the instance is then marked invalid and ahc_step outputs zeros with
 * AHC_FAULT_NOT_INITIALIZED). */
int ahc_init(ahc_controller *c, const ahc_params *p);

/* Back to t = 0 with the same parameters. */
void ahc_reset(ahc_controller *c);

/* Change parameters of a running instance without resetting its state (e.g. tunable FMU
 * parameters): validates, copies and recomputes the derived constants. On error the instance
 * keeps its old parameters and the AHC_ERR_* code is returned. A running ankle->hip transition
 * keeps the duration it started with. Do not write c->p directly. */
int ahc_update_params(ahc_controller *c, const ahc_params *p);

/* One control tick of p.sample_period: reads the sensors, updates the state, writes the outputs.
 * Never writes NaN/Inf to the outputs. s and out must not be NULL. */
void ahc_step(ahc_controller *c, const ahc_sensors *s, ahc_outputs *out);

/* The AHC_FAULT_* bits the sensor readings alone raise (ahc_step classifies every tick's readings
 * so): non-finite values, angles outside the joint ranges, a ZMP beyond the foot, a lifted or an
 * implausibly loaded robot. */
unsigned ahc_sensor_faults(const ahc_params *p, const ahc_sensors *s);

/* Largest tick count a state may hold: 2^53, where a double still counts every tick (285 000
 * years at 1 ms). ahc_state_validate refuses a larger one; a caller that converts a time into a
 * tick count (the FMU) refuses a step that would pass it. */
#define AHC_TICK_MAX 9007199254740992ULL

/* Whether c holds a state that ahc_init and ahc_step could have produced: valid parameters,
 * derived constants that match them, flags 0/1, phase and counters in range, every stored value
 * finite and within its physical range, and the invariants the controller keeps between them:
 * the splines are the quintics their endpoints define (k_w: 0 -> 1 over T; r_x_d: from its
 * stored start to rest), k_w is 0 in phase 0 and 1 in phases 2-3, the last outputs are the
 * reference states, the timers fit in the ticks run, tick <= AHC_TICK_MAX. For snapshots restored
 * from untrusted bytes (a checksum catches accidents, not forgeries). AHC_OK, or AHC_ERR_* with a
 * message naming the field. */
int ahc_state_validate(const ahc_controller *c, char *msg, size_t msg_size);

/* ahc_state_validate, and whether c fits the instance it is restored into: an initialized state
 * (valid = 1) whose parameters equal *p field by field, bit for bit (a snapshot carries its
 * parameters: restore them together with it, or refuse it), and whose tick count is `tick`, the
 * number of ticks the instance's clock has run (AHC_TICK_ANY: not checked). A state with another
 * tick count would make the next call run the difference at once. AHC_OK, or AHC_ERR_* with a
 * message naming the field (e.g. "Ka = 41 in the state, 40 in the instance"). */
#define AHC_TICK_ANY (~0ULL)
int ahc_state_validate_for(const ahc_controller *c, const ahc_params *p, unsigned long long tick, char *msg,
                           size_t msg_size);

/* Time of the controller [s] = tick * sample_period. */
double ahc_time(const ahc_controller *c);

/* ---------------------------------------------------------------------------------------------
 * Pure helpers (model of docs/controller.md §2; useful to tests and other components)
 * ------------------------------------------------------------------------------------------- */
/* CoM of the two-link body: rx = (m1 lg1 S1 + m2 (l1 S1 + lg2 S12))/m,
 *                           rz = (m1 lg1 C1 + m2 (l1 C1 + lg2 C12))/m,
 * each link's CoM moved by its offset d_i = link<i>_com_x forward of its joint line (lg_i S + d_i C
 * for x, lg_i C - d_i S for z).  Either pointer may be NULL. */
void ahc_com(const ahc_params *p, double th1, double th2, double *rx, double *rz);

/* x row of the CoM Jacobian (eq. 20): J[0] = d rx/d th1 = r_z,
 * J[1] = d rx/d th2 = k_m (lg2 C12 - d2 S12). */
void ahc_com_jacobian_x(const ahc_params *p, double th1, double th2, double J[2]);

/* The erect posture: link 2's CoM above the hip and the whole CoM above the ankle,
 *   th1 + th2 = -atan2(d2, lg2),   th1 = -atan2(m1 d1, m1 lg1 + m2 l1);  both 0 when d1 = d2 = 0. */
void ahc_erect_posture(const ahc_params *p, double *th1, double *th2);

/* Reactionless ratio of eq. 15: dth1/dth2 that keeps rx fixed,
 * -m2 lg2 C12 / ((m1 lg1 + m2 l1) C1 + m2 lg2 C12). Returns 0 if the denominator vanishes. */
double ahc_reactionless_ratio(const ahc_params *p, double th1, double th2);

/* Whole-body inertia about the ankle axis with the hip at th2 (the I + m lg^2 of eq. 11):
 * I1 + m1 lg1^2 + I2 + m2 (l1^2 + lg2^2 + 2 l1 lg2 cos th2). */
double ahc_ankle_inertia(const ahc_params *p, double th2);

/* Quintic with x(0)=x0, x'(0)=v0, x''(0)=a0, x(T)=x1, x'(T)=v1, x''(T)=a1 (T > 0). */
void ahc_quintic_init(ahc_quintic *q, double x0, double v0, double a0,
                      double x1, double v1, double a1, double T);
/* Value, first and second derivative at t (clamped to [0, T]); any output pointer may be NULL. */
void ahc_quintic_eval(const ahc_quintic *q, double t, double *x, double *v, double *a);

/* Human-readable names. */
const char *ahc_phase_name(int phase);
const char *ahc_error_string(int code);
/* Writes a comma-separated list of the set fault bits' names ("" for 0); returns msg. */
const char *ahc_fault_string(unsigned fault, char *msg, size_t msg_size);

#ifdef __cplusplus
}
#endif

#endif /* AHC_CONTROLLER_H */
