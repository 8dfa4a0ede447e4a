/*
 * frontal.h — the paper's ankle and hip strategies with transitions, read in the frontal plane
 * (docs/controller.md §11). Our derivation: the paper (Nenchev & Nishio, ICRA 2010) treats the
 * sagittal plane only; every frontal equation is numbered F<n> after the sagittal equation it
 * mirrors (F11 mirrors eq. 11, ...).
 *
 * The frontal model, both feet flat on the ground (double support), knees straight at rest:
 *   phi  the lean of the straight ("pivot") leg toward +y (left), about its ankle roll axis [rad];
 *   psi  the lean of link 2 (pelvis and everything above it) toward +y, from level [rad].
 * With psi = 0 both legs lean by phi and, with the pelvis, form a parallelogram: link 2 translates
 * sideways without rolling (the lateral ankle strategy). Leaning link 2 toward +y lowers the left
 * hip: it turns about the right hip, on top of the right leg, which stays straight (the pivot), and
 * the left knee flexes to shorten the left leg (the lateral hip strategy); psi < 0 mirrors it. The
 * lateral position y is measured from the mid-point between the ankles, heights from the ankle
 * axes. Same properties as controller.h: C99, no heap, no globals, one POD struct per instance.
 */
#ifndef AHC_FRONTAL_H
#define AHC_FRONTAL_H

#include <stddef.h>

#include "ahc/controller.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The frontal phases mirror the sagittal ones (AHC_PHASE_*: 0 ankle, 1 ankle->hip, 2 hip,
 * 3 hip->ankle), with the lateral ZMP as the trigger. */

/* Frontal fault bits (ahc_frontal_outputs.fault); "hold" as in controller.h. */
enum {
    AHC_FFAULT_ZMP_Y_NONFINITE  = 1u << 0, /* hold: zmp_y is NaN or Inf                            */
    AHC_FFAULT_ANGLE_NONFINITE  = 1u << 1, /* hold: a measured frontal angle (or the feet's roll) is
                                              NaN or Inf                                         */
    AHC_FFAULT_ZMP_Y_OUTSIDE    = 1u << 2, /* hold: zmp_y beyond the soles' outer edges by more than
                                              zmp_fault_margin_y                                   */
    AHC_FFAULT_LIFTED           = 1u << 3, /* hold: fz below the sagittal fz_lifted, or not finite  */
    AHC_FFAULT_REF_SATURATED    = 1u << 4, /* warning: a frontal reference was clamped this tick   */
    AHC_FFAULT_NOT_INITIALIZED  = 1u << 5  /* hold: ahc_frontal_step on an instance whose init failed */
};
#define AHC_FFAULT_HOLD_MASK                                                                       \
    (AHC_FFAULT_ZMP_Y_NONFINITE | AHC_FFAULT_ANGLE_NONFINITE | AHC_FFAULT_ZMP_Y_OUTSIDE |          \
     AHC_FFAULT_LIFTED | AHC_FFAULT_NOT_INITIALIZED)
#define AHC_FFAULT_ALL_MASK (AHC_FFAULT_HOLD_MASK | AHC_FFAULT_REF_SATURATED)

/* Parameters (SI). Every field is listed in ahc_frontal_param_table(). */
typedef struct {
    int frontal_enabled;            /* 0: the frontal layer outputs phi = psi = 0 and phase 0            */
    /* model of the robot (hoap2/nominal.h); the masses and lengths shared with the sagittal model
     * (g, m1, m2, l1, lg1, lg2, sample_period) are taken from the sagittal ahc_params */
    double hip_y;           /* hip joints across from the mid-plane [m]                          */
    double ankle_y;         /* ankle joints across from the mid-plane [m]                        */
    double thigh;           /* hip -> knee axis [m]                                              */
    double shank;           /* knee -> ankle axes [m]; thigh + shank = l1                        */
    double I1_roll;         /* roll inertia of both legs' link-1 parts, each about its own CoM   */
    double I2_roll;         /* roll inertia of link 2 about its CoM [kg m^2]                     */
    double link1_com_y;     /* each leg's CoM outward of its ankle-hip line [m]                  */
    double link2_com_y;     /* link 2's CoM left of the mid-plane at rest [m]                    */
    double sole_width;      /* one sole [m], centred under its ankle                            */
    double ankle_roll_max;  /* ankle roll limit, either way [rad]                                */
    double hip_abduction_max; /* hip roll limit outward [rad]                                    */
    double hip_adduction_max; /* hip roll limit inward [rad]                                     */
    double knee_max;        /* knee flexion limit [rad]                                          */
    /* gains (the sagittal ones' frontal counterparts, docs/controller.md §11) */
    double Ka_y;            /* lateral ankle virtual stiffness, F11 [N m/rad]                    */
    double Ca_y;            /* lateral ankle virtual damping, F11 [N m s/rad]                    */
    double Kh_y;            /* lateral hip virtual stiffness, F16 [N m/rad]                      */
    double Ch_y;            /* lateral hip virtual damping, F16 [N m s/rad]                      */
    double Kpr_y;           /* lateral CoM feedback, F24 [1/s]                                   */
    double Kp_psi;          /* lateral hip return regulator, F25 [1/s]                           */
    /* phase logic */
    int hip_strategy_enabled_y; /* 1: all four phases; 0: the lateral ankle strategy only          */
    double zmp_limit_y;     /* |zmp_y| at which the lateral hip strategy starts [m] (> 0)        */
    double T_ah_y;          /* duration of the lateral ankle->hip transition [s]                 */
    double rz_band_low_y;   /* hip->ankle: the frontal model's CoM height minus its erect height
                               within [rz_band_low_y, rz_band_high_y] [m] ...                   */
    double rz_band_high_y;
    double fallback_disturbance_tol_y; /* fallback 2->3: |d_y| <= this [N m] ...                 */
    double fallback_hip_tol_y;         /* ... and |psi_ref| <= this [rad] ...                    */
    double fallback_dwell_y;           /* ... continuously for this time [s]                     */
    double return_psi_tol;      /* 3 -> 0 when |psi_ref| <= this [rad] ...                        */
    double return_psi_rate_tol; /* ... and |dpsi_ref| <= this [rad/s]                             */
    /* sensing and faults */
    double zmp_filter_tau_y;    /* first-order low-pass of zmp_y [s] (0 = off)                   */
    double zmp_fault_margin_y;  /* zmp_y beyond the outer sole edges by more than this: fault [m] */
    /* the lateral lean (docs/controller.md §11.2: the sagittal lean_enabled's law, §4.6, over the
     * two soles' width, in every phase) */
    int lean_enabled_y;         /* 1: the CoM reference leans against the low-passed external
                                   moment, -D_y/(m g), bounded by the soles: F11 around it in
                                   phase 0, r_y_d in phases 1-3                                 */
    double lean_tau_y;          /* time constant of that low-pass (two stages of lean_tau_y/2) [s] */
    double lean_margin_y;       /* the leaned CoM reference stays this far inside the outer edges [m] */
    double fz_rocking_y;        /* a sole loaded less than this is lifted: the lean holds [N]   */
    /* how the lean moves (docs/controller.md §11.2) */
    int lean_law_y;             /* AHC_LEAN_LOWPASS: the lean is -D_y/(m g) low-passed (§4.6's law);
                                   AHC_LEAN_PENDULUM: the CoM reference is the linear inverted
                                   pendulum's under the low-passed D_y, its ZMP planned by
                                   capture-point feedback toward -D_y/(m g), inside the soles   */
    double lean_zmp_margin_y;   /* AHC_LEAN_PENDULUM: the planned ZMP stays this far inside the
                                   outer edges [m]                                               */
    double lean_capture_gain_y; /* AHC_LEAN_PENDULUM: the capture point converges at this
                                   multiple of the pendulum's rate [-]                          */
    double roll_rocking_y;      /* the feet rolled more than this (foot_roll): the robot rocks on a
                                   sole's edge, the lean holds [rad]                             */
    double rocking_dwell_y;     /* ... and holds until the feet have lain flat this long [s]     */
} ahc_frontal_params;

/* lean_law_y: AHC_LEAN_LOWPASS, AHC_LEAN_PENDULUM (controller.h) */

/* HOAP-2 defaults (hoap2/nominal.h) and the frontal gains (docs/controller.md §11). */
void ahc_frontal_params_default(ahc_frontal_params *f);

/* The paper's strategies read in the frontal plane with none of our choices (§11.2-11.3): the
 * sagittal gains carried over (Ka_y 19, Ca_y 4.75), the lateral hip strategy on, no lateral lean.
 * The frontal part of the named configuration "paper". */
void ahc_frontal_params_paper(ahc_frontal_params *f);
/* The frontal part of the named configurations of ahc_params_named ("default", "paper", "omnidirectional"):
 * AHC_OK, or AHC_ERR_UNKNOWN_NAME (f then the defaults). */
int ahc_frontal_params_named(ahc_frontal_params *f, const char *name);

/* Validate f against itself and the sagittal model sp. AHC_OK or AHC_ERR_*, message as
 * ahc_params_validate. */
int ahc_frontal_params_validate(const ahc_frontal_params *f, const ahc_params *sp, char *msg, size_t msg_size);

/* Parameter metadata, one row per field (the same row type and rules as ahc_param_table: rows are
 * only appended, the FMU derives value references from the index). */
const ahc_param_info *ahc_frontal_param_table(size_t *count);
const ahc_param_info *ahc_frontal_param_find(const char *name);

/* Writes a comma-separated list of the set AHC_FFAULT_* bits' names ("" for 0); returns msg (the
 * frontal twin of ahc_fault_string). */
const char *ahc_frontal_fault_string(unsigned fault, char *msg, size_t msg_size);

/* Frontal sensors: the lateral ZMP and the measured frontal angles (ahc3d computes phi and psi from
 * the legs' joint angles, ahc_leg_frontal_angles). */
typedef struct {
    double zmp_y;   /* ZMP, y from the mid-point between the ankles [m]                          */
    double phi;     /* measured lean of the pivot leg [rad]                                      */
    double psi;     /* measured lean of link 2 [rad]                                             */
    double fz;      /* total normal force [N]                                                    */
    double fz_left, fz_right; /* each sole's normal load [N]: the frontal moment balance holds only
                                 with both soles on the ground                                  */
    double foot_roll; /* the feet's roll toward +y [rad]: the trunk's measured lean minus psi; 0 while
                         the soles lie flat, the robot rocking on a sole's edge otherwise         */
} ahc_frontal_sensors;

typedef struct {
    double phi_ref, psi_ref;     /* frontal references [rad]                                       */
    double dphi_ref, dpsi_ref;   /* their rates [rad/s]                                            */
    int phase;                   /* AHC_PHASE_* of the frontal plane                               */
    double com_y;                /* CoM of the frontal model from the measured angles, y [m]       */
    double com_z;                /* its height above the ankle axes [m]                           */
    double disturbance_moment;   /* d_y = m g (p_y - r_y) [N m]                                     */
    double k_w;                  /* F23's reactionless weight                                      */
    double com_y_desired;        /* r_y_d in phases 1-3; com_y in phase 0 [m]                      */
    unsigned fault;              /* AHC_FFAULT_* bits                                              */
} ahc_frontal_outputs;

/* Instance: plain old data (snapshot = memcpy). Fields are private. */
typedef struct {
    ahc_frontal_params f;
    ahc_params sp;            /* the sagittal model's numbers it shares (copy)                   */
    int valid;
    /* derived constants */
    double m, km, Jphi, Jpsi, rz_erect, zmp_alpha;
    /* time */
    unsigned long long tick;
    int started;
    /* references */
    double phi, dphi, psi, dpsi, psi_bump;
    /* phase machine */
    int phase, push_sign;
    double phase_time, fallback_timer;
    ahc_quintic kw_spline, ryd_spline;
    double k_w, ryd, dryd;
    /* sensing */
    double zmp_f;
    int zmp_f_valid;
    double last_phi, last_psi;
    /* the lean (lean_enabled_y): the lumps' measured CoMs and leans one and two ticks ago, the
     * two-stage low-pass of the external moment, the lean [m] */
    double hist_y[2][3], hist_z[2][3], hist_lean[2][3];
    int hist_n;
    double lean_alpha, lean_f1, lean_f, lean;
    /* AHC_LEAN_PENDULUM: the planned CoM's rate, the pendulum's rate, the planned ZMP, the legs'
     * lean that carries the planned CoM and its rate */
    double lean_rate, omega_y, lean_p, phi_plan, dphi_plan;
    double flat_time;           /* how long the feet have lain flat (|foot_roll| <= roll_rocking_y) [s] */
    unsigned fault;
    int holding;
    ahc_frontal_outputs last_out;
} ahc_frontal;

/* Validate (ahc_frontal_params_validate), copy both parameter sets, reset. */
int ahc_frontal_init(ahc_frontal *c, const ahc_frontal_params *f, const ahc_params *sp);
void ahc_frontal_reset(ahc_frontal *c);
/* One tick of sp.sample_period. Never writes NaN/Inf. */
void ahc_frontal_step(ahc_frontal *c, const ahc_frontal_sensors *s, ahc_frontal_outputs *out);
/* The AHC_FFAULT_* bits the sensor readings alone raise (ahc_frontal_step classifies every tick's
 * readings so): zmp_y or a frontal angle non-finite, zmp_y beyond the soles, a lifted robot. */
unsigned ahc_frontal_sensor_faults(const ahc_frontal *c, const ahc_frontal_sensors *s);
/* Whether c holds a state init and step could have produced (as ahc_state_validate). */
int ahc_frontal_state_validate(const ahc_frontal *c, char *msg, size_t msg_size);

/* --- the frontal model (pure functions; docs/controller.md §11.1) ---------------------------- */
/* CoM of the two-link body in the frontal plane: y from the mid-point between the ankles, z above
 * the ankle axes (F2). Either pointer may be NULL. */
void ahc_frontal_com(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi,
                     double *ry, double *rz);
/* The lateral CoM Jacobian J = [d r_y/d phi, d r_y/d psi] (F20). */
void ahc_frontal_com_jacobian(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi,
                              double J[2]);
/* F15: dphi/dpsi that keeps r_y still, -J[1]/J[0] (0 if J[0] vanishes). */
double ahc_frontal_reactionless_ratio(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi);
/* F11's inertia: the parallelogram's about phi, I1_roll + m1 (lg1^2 + c1y^2) + m2 l1^2 (link 2
 * translates without rolling). */
double ahc_frontal_ankle_inertia(const ahc_frontal_params *f, const ahc_params *sp);
/* F16's inertia: link 2 turning about the pivot hip, I2_roll + m2 |c2 - hip|^2. */
double ahc_frontal_hip_inertia(const ahc_frontal_params *f, const ahc_params *sp);
/* The model's three lumps at (phi, psi): [0] the right leg's link-1 part, [1] the left leg's, [2]
 * link 2: their CoMs (y, z from the ankles' mid-point at ankle height) and leans toward +y [rad]. */
void ahc_frontal_lumps(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi,
                       double y[3], double z[3], double lean[3]);
/* The other (non-pivot) leg's hip-ankle distance at (phi, psi) [m]: l1 at psi = 0, shorter as |psi|
 * grows; the knee flexes to make it. */
double ahc_frontal_other_leg_length(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi);

#ifdef __cplusplus
}
#endif

#endif /* AHC_FRONTAL_H */
