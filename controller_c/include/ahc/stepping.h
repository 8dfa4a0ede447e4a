/*
 * stepping.h — the third strategy of the paper's Fig. 1: a recovery step, beside the ankle and hip
 * strategies of both planes (docs/controller.md §12). Our design: the paper names stepping as its
 * next step and gives no law for it.
 *
 * The decision: the instantaneous capture point xi = c + c'/omega of the linear inverted pendulum
 * (omega = sqrt(g / z_c), c the CoM from the measured joint angles and the trunk's IMU) leaves the
 * feet's support polygon by more than step_trigger_x (toward the toes or the heels) or
 * step_trigger_y (sideways). The flat-footed strategies cannot bring a capture point back from
 * there (docs/capability.md §8-9). And (docs/controller.md §12.1) the hip strategy at its limit —
 * the trunk leaning step_trigger_lean toward the sole edge the measured ZMP is at, with the capture
 * point between the soles' inner edges (a sagittal push). No step starts within step_impact_hold
 * of an impact (the capture point jumping faster than any ZMP on the feet could move it: a foot
 * slapping down, not a fall).
 *
 * The step, as phases that continue the paper's Table I (AHC_STEP_*):
 *   SHIFT     both feet down: the CoM reference's pendulum moves the capture point over the stance
 *             foot (skipped when it is there already, or for a side step outward);
 *   SWING     one foot down: the stance foot's ZMP holds the capture point, or slows it at the
 *             sole's edge; the swing foot lifts, travels to the landing point (the capture point
 *             predicted at touch-down, within the leg's reach and clear of the stance foot) and
 *             comes down; it has landed when its sole carries step_touchdown_fz;
 *   TRANSFER  both feet down, apart: the capture point is moved over the foot that landed;
 *   SETTLE    both feet down: the CoM reference comes to rest over the feet's mid-point; with
 *             step_close, then — once the robot is measured at rest (step_close_rest: the capture
 *             point near the CoM, both soles loaded and flat) — the closing step, slower than the
 *             recovery step:
 *   SHIFT     the capture point moves over the landed foot, in step_close_shift_time;
 *   CLOSE     one foot down: the other one is brought beside it, in step_close_swing_time;
 *   SETTLE    both feet down, together: the CoM reference comes to rest over the feet, the legs
 *             stretch back to the erect height; then the sagittal and frontal controllers take
 *             over from the last references (bumpless), in phase 0.
 * The CoM reference is the pendulum's under a constant planned ZMP in each phase (SETTLE: a quintic),
 * so the feet's ZMP is where the plan puts it while the robot follows its references. The joint set
 * points are the legs' analytic inverse kinematics (leg_ik.h, ahc_leg_ik_pose) of the pelvis that
 * carries that CoM and of the feet, plus each servo's lead (its kd/kp) times the reference's rate.
 * Every switch blends the references with a quintic weight (eqs. 23-24's) over step_blend_time.
 *
 * The push, estimated (docs/controller.md §12.5): a momentum observer on the whole robot's angular
 * momentum about the ground gives the external pitching moment (push_moment); with
 * step_push_estimate the plan uses it, and the decision too (off by default: both made every
 * boundary worse).
 *
 * Frame: the ground frame fixed when the step is decided, its origin the mid-point between the
 * ankles' ground projections, x forward, y left, z up; the feet flat in it.
 * C99, no heap, no globals, one POD struct.
 */
#ifndef AHC_STEPPING_H
#define AHC_STEPPING_H

#include <stddef.h>

#include "ahc/controller.h"
#include "ahc/frontal.h"
#include "ahc/leg_ik.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Stepping phases (ahc_step_outputs.phase): the paper's Table I has the flat-footed phases 0-3 of
 * each plane; while a step runs, this is the phase. */
enum {
    AHC_STEP_STAND = 0,    /* no step: the ankle and hip strategies act                         */
    AHC_STEP_SHIFT = 1,    /* both feet: the capture point moves over the stance foot           */
    AHC_STEP_SWING = 2,    /* one foot: the other swings to the landing point                   */
    AHC_STEP_TRANSFER = 3, /* both feet, apart: the capture point moves over the landed foot     */
    AHC_STEP_CLOSE = 4,    /* one foot: the other is brought beside it (after a SETTLE and SHIFT) */
    AHC_STEP_SETTLE = 5    /* both feet: to rest; at the end, erect and back to STAND            */
};
#define AHC_STEP_PHASES 6

/* Parameters (SI). Every field is listed in ahc_step_param_table(). The robot's geometry is the
 * sagittal and frontal parameters' (sole, ankles, hips, legs, masses). */
typedef struct {
    int stepping_enabled;      /* 0: never steps (the outputs are those of the flat-footed layers) */
    double step_trigger_x;     /* the capture point beyond the toe or heel edge by this: step [m]  */
    double step_trigger_y;     /* ... beyond the outer sole edges by this: step [m]                */
    double step_swing_time;    /* the swing's planned duration [s]                                 */
    double step_height;        /* the swing foot's lift [m]                                        */
    double step_length_max;    /* the landing ankle at most this far from the stance ankle,
                                  forward or back [m]                                             */
    double step_width_max;     /* ... and sideways (ankle to ankle) [m]                            */
    double step_pelvis_drop;   /* the hips lower by this while stepping (the legs' reach) [m]      */
    double step_zmp_margin;    /* planned ZMPs stay this far inside the sole edges [m]             */
    double step_touchdown_fz;  /* the swing sole carries this: it has landed [N]                   */
    double step_transfer_time_min; /* TRANSFER lasts at least this [s]                              */
    double step_settle_time;   /* SETTLE's duration [s]                                            */
    double step_blend_time;    /* quintic blend of the references at every switch [s]              */
    double step_velocity_tau;  /* low-pass of the CoM's finite-difference rate [s]                 */
    double step_servo_lead;    /* the servos' kd/kp: the reference leads by this times its rate,
                                  every joint but the hip pitch [s]                               */
    double step_servo_lead_hip; /* ... the hip pitch servo's [s]                                    */
    int step_close;            /* 1: a second step brings the feet back together                   */
    double step_drop_time;     /* the hips lower by step_pelvis_drop over this time [s]            */
    double step_shift_time_max; /* SHIFT lasts at most this [s] (0: the foot lifts at once)         */
    double step_pitch_time;    /* the trunk's pitch returns to erect over this [s]                 */
    double step_hip_hike;      /* the pelvis rolls the swing hip up by this at mid-swing [rad]     */
    double step_lead_max;      /* the servo lead adds at most this to a reference [rad]            */
    double step_touchdown_after; /* a load on the swing sole is the landing after this fraction of
                                    the swing [-]                                                 */
    double step_pelvis_rate;   /* the hips' planned height moves at most this fast [m/s]          */
    double step_touchdown_tol; /* a loaded swing sole has landed only this close to its target [m] */
    double step_lead_tau;      /* low-pass of the reference rate the servo lead multiplies [s]    */
    double step_shift_inset;   /* SHIFT moves the capture point this far inside of the stance ankle [m] */
    int step_dcm_feedback;     /* 1: the reference's ZMP tracks the measured capture point           */
    double step_dcm_gain;      /* capture-point feedback: the planned ZMP moves by (1 + gain/omega)
                                  times the measured minus the reference capture point [1/s]     */
    double step_close_shift_time; /* the closing step's weight shift onto the landed foot [s]       */
    double step_close_swing_time; /* the closing step's swing [s]                                   */
    double step_trigger_lean;  /* step also when the trunk leans this far from erect toward the sole
                                  edge the measured ZMP is at (the hip strategy at its limit), the
                                  capture point between the soles' inner edges; 0: off [rad]     */
    double step_impact_hold;   /* no step starts for this long after an impact (the capture point
                                  jumping faster than the pendulum allows) [s]                    */
    double step_close_rest;    /* the closing step waits for rest: the capture point within this of
                                  the CoM, both soles loaded and flat; 0: it starts after SETTLE's
                                  planned time [m]                                                */
    double step_close_rest_tilt; /* ... each sole flat within this [rad]                           */
    double step_close_wait;    /* ... for at most this after SETTLE's planned time [s]            */
    double step_close_inset;   /* the closing step's weight shift moves the capture point this far
                                  inside of the landed ankle, toward the other foot [m]          */
    double step_trigger_time;  /* a step starts at the first tick at or after this time since the
                                  start (tick x sample_period), whatever the rules, if standing then:
                                  experiments on the decision's timing; 0: off [s]               */
    int step_push_estimate;    /* the external moment estimate (a momentum observer) in the step:
                                  1 in the plan (the weight shift, the landing point, the CoM
                                  reference); 2 in the decision too (xi + u); 0 nowhere          */
    double step_observer_gain; /* the momentum observer's gain: the estimate follows the external
                                  moment with this bandwidth [1/s]                               */
    double step_swing_rate_max; /* the swing leg's set points move at most this fast while it swings
                                  (docs/controller.md §12.4 item 4); 0: no limit [rad/s]          */
    double step_swing_measured; /* the swing leg's set points from the measured pelvis (the stance
                                  leg's joints and the IMU) rather than the plan's, by this weight
                                  (0: the plan's; 1: the measured one's) [1]                     */
    double step_swing_hold;    /* the swing foot stays at step_height until its measured ankle is
                                  within this of the landing point; 0: off [m]                   */
    double step_trunk_back;    /* the step's trunk plan aims this far back of erect (reached over
                                  step_pitch_time from the decision; back to erect over it from the
                                  landing): the hips lead the CoM, as in the one-step optimum
                                  (docs/capability.md §9.3); 0: erect [rad]                      */
    double step_trunk_gain;    /* the supporting legs' hip pitch set points take the trunk's measured
                                  pitch error times this back out; 0: off [1]                    */
    double step_stance_tilt_gain; /* on one foot, the stance ankle's pitch set point moves by the
                                  stance sole's measured pitch (toes down +) times this: the ankle
                                  yields as the sole rolls onto its edge; 0: off [1]             */
    double step_feet_tilt_gain; /* on both feet, each ankle's pitch set point moves by its sole's
                                  measured pitch (toes down +) times this; 0: off [1]            */
    int step_settle_on_axis;   /* 1: SETTLE holds the capture point, across, on the line between the
                                  ankles at the CoM reference's x (the feet one ahead of the other:
                                  the middle of their support there); 0: at the feet's mid-point */
} ahc_step_params;

/* HOAP-2 defaults (docs/controller.md §12): stepping off. */
void ahc_step_params_default(ahc_step_params *p);

/* The stepping layer's named configurations (the 3D controller's, beside ahc_params_named's, whose
 * stepping part is the defaults): "lasting_push", the settings that hold 1 s back pushes above the
 * sustained-push limit with one step (docs/controller.md §12.6; not the default: on short pushes
 * they fall). ahc_step_config_name / _description return NULL past the end. The 3D controller FMU
 * lists them, with the values that differ from the defaults, in resources/configurations.toml. */
size_t ahc_step_config_count(void);
const char *ahc_step_config_name(size_t i);
const char *ahc_step_config_description(size_t i);
/* Fill p with the named configuration: AHC_OK, or AHC_ERR_UNKNOWN_NAME for an unknown name (or NULL)
 * (p is then the defaults). */
int ahc_step_params_named(ahc_step_params *p, const char *name);
/* Validate against itself and the robot (sp, fp). AHC_OK or AHC_ERR_*, message as ahc_params_validate. */
int ahc_step_params_validate(const ahc_step_params *p, const ahc_params *sp, const ahc_frontal_params *fp, char *msg,
                             size_t msg_size);
/* Parameter metadata (the same row type and rules as ahc_param_table: rows are only appended). */
const ahc_param_info *ahc_step_param_table(size_t *count);
const ahc_param_info *ahc_step_param_find(const char *name);
const char *ahc_step_phase_name(int phase);

/* What the stepping layer reads: the legs' joint angles, the trunk's attitude, the soles' loads. */
typedef struct {
    double q[2][AHC_LEG_JOINTS]; /* [AHC_LEFT], [AHC_RIGHT], leg_ik.h's senses [rad]              */
    double imu_roll, imu_pitch;  /* the trunk's roll (+ top toward -y) and pitch (+ forward) [rad] */
    double fz_left, fz_right;    /* each sole's normal load [N]                                     */
    double zmp_x;                /* the measured ZMP, x from the ankles' mid-point [m]              */
} ahc_step_sensors;

typedef struct {
    int active;                  /* 1: the joint set points below replace the flat-footed layers' */
    int phase;                   /* AHC_STEP_*                                                     */
    int swing_side;              /* AHC_LEFT, AHC_RIGHT; -1 while standing                         */
    int steps;                   /* steps landed since the start                                   */
    double q_ref[2][AHC_LEG_JOINTS]; /* the legs' set points while active [rad]                    */
    double com[2], com_rate[2];  /* the CoM's estimate, ground frame of the feet at rest / of the
                                    step [m], [m/s]                                               */
    double capture[2];           /* the instantaneous capture point [m]                            */
    double com_ref[2];           /* the CoM reference while active [m]                             */
    double zmp_plan[2];          /* the ZMP the reference's pendulum plans in this phase [m]        */
    double landing[2];           /* the swing foot's landing point (ankle) while active [m]        */
    double push_moment;          /* the external pitching moment about the ground, estimated (+ tips
                                    the robot forward: a push on the back) [N m]                  */
} ahc_step_outputs;

/* Instance: plain old data (snapshot = memcpy). Fields are private. */
typedef struct {
    ahc_step_params p;
    int valid;
    /* the robot, from the sagittal and frontal parameters */
    double g, mass, m1, m2, lg1, l1, lg2, link2_com_x, feet_mass, feet_com_x, feet_com_z, ankle_height;
    double toe_x, heel_x, sole_width, hip_y, ankle_y, omega, z_com;
    double I1, I2;              /* link 1's (both legs) and link 2's pitch inertia about their CoMs */
    ahc_leg_geometry legs;
    double dt;
    unsigned long long tick;
    /* the estimate */
    int est_valid;
    double com_prev[2], com_rate[2];
    /* the step */
    int phase, swing_side, steps;
    double phase_time;
    double feet[2][2];          /* both ankles' ground points in the step's frame [m]           */
    double zmp[2];              /* this phase's planned ZMP [m]                                   */
    double phase_duration;
    double c0[2], v0[2];        /* the CoM reference at the phase's start                          */
    double cref[2], vref[2];    /* the CoM reference and its rate now                              */
    double settle_mid[2];       /* SETTLE: the feet's mid-point                                     */
    double settle_capture_time; /* SETTLE: when the capture point reaches it [s]                    */
    double swing_from[2], landing[2];
    ahc_quintic swing[2];       /* the swing foot's x, y                                           */
    double swing_pos[2], swing_vel[2], swing_acc[2];
    double pitch_prev, pitch_rate; /* the trunk's measured pitch and its low-passed rate            */
    ahc_quintic pitch_plan;     /* the trunk's pitch reference, from the decision or the landing    */
    double pitch_time;          /* time on pitch_plan [s]                                          */
    double pitch_erect;         /* the sagittal model's erect trunk pitch (theta1 + theta2)         */
    double step_clock;          /* time since the decision [s]                                     */
    double tilt[2];             /* the stance foot's measured pitch and roll, low-passed [rad]      */
    int tilt_valid;
    double pelvis_z;            /* the hips' planned height last tick [m]                           */
    int pelvis_z_valid;
    double knee_settle;         /* the legs' planned knee bend at SETTLE's start [rad]              */
    int close_stage;            /* the closing step: 0 none, 1 at rest on the feet apart (SETTLE),
                                   2 its weight shift and swing (SHIFT, CLOSE), 3 the last SETTLE   */
    double swing_time;          /* the running swing's planned duration [s]                        */
    double xi_prev[2];          /* last tick's capture point [m]                                    */
    double since_impact;        /* time since the capture point last jumped faster than the
                                   pendulum can move it (an impact) [s]                            */
    double q_prev[2][AHC_LEG_JOINTS];   /* last tick's planned joint angles (rates)                 */
    double q_rate[2][AHC_LEG_JOINTS];   /* their low-passed rates (the servo lead)                  */
    int q_prev_valid;
    double q_out[2][AHC_LEG_JOINTS];    /* last tick's set points                                   */
    double blend_from[2][AHC_LEG_JOINTS]; /* the set points' offset blended out after a switch      */
    double blend_time;
    int blend_from_flat;        /* the pending blend starts from the flat-footed layers' set points
                                   (the decision), else from the step's last ones (a landing)     */
    /* the momentum observer (push_moment): the sagittal angular momentum about the frame's origin
     * from the lumped bodies' finite-difference motion, and its prediction from the known moments */
    int obs_valid;
    double obs_body_prev[5][3]; /* the lumped bodies' CoMs last tick (link 2, legs, feet) [m]       */
    double obs_leg_prev[2];     /* each leg's link-1 pitch last tick [rad]                          */
    double obs_pitch_prev;      /* the trunk's pitch last tick [rad]                                */
    double obs_pred;            /* the angular momentum the known moments predict [N m s]          */
    double obs_H[4];            /* the last four ticks' angular momentum (the median of five) [N m s] */
    int obs_Hn;                 /* how many of them are held                                        */
    double push_moment;         /* the estimate [N m]                                               */
    double push_planned;        /* the estimate at the step's decision: the push the step plans with [N m] */
    double obs_loaded_time;     /* how long both soles have carried step_touchdown_fz [s]          */
} ahc_stepper;

int ahc_step_init(ahc_stepper *c, const ahc_step_params *p, const ahc_params *sp, const ahc_frontal_params *fp);
void ahc_step_reset(ahc_stepper *c);
/* One tick. flat_q: the flat-footed layers' set points this tick (both legs' plus per-leg), so that
 * a step starts from them without a jump. out->active says whether the step's set points apply. */
void ahc_step_step(ahc_stepper *c, const ahc_step_sensors *s, const double flat_q[2][AHC_LEG_JOINTS],
                   ahc_step_outputs *out);
/* The tick a step ends (out->phase back to AHC_STEP_STAND), after ahc_step_step without flat_q:
 * the flat-footed layers' first set points flat_q, the step's last ones blended into them. A no-op
 * otherwise. */
void ahc_step_handover(ahc_stepper *c, const double flat_q[2][AHC_LEG_JOINTS], ahc_step_outputs *out);
int ahc_step_state_validate(const ahc_stepper *c, char *msg, size_t msg_size);
/* ahc_step_state_validate, and the robot's numbers the layer copied equal to those of sp and fp
 * (a restored state must not carry other ones). */
int ahc_step_state_consistent(const ahc_stepper *c, const ahc_params *sp, const ahc_frontal_params *fp, char *msg,
                              size_t msg_size);

/* The CoM of the lumped model (both legs' link-1 parts, link 2, the feet) for joint angles q and the
 * trunk's attitude, relative to the ankle of `anchor` (AHC_LEFT, AHC_RIGHT) flat on the ground, in
 * world axes [m]; also the pelvis centre (the hips' mid-point). Exposed for the tests. */
void ahc_step_com(const ahc_stepper *c, const double q[2][AHC_LEG_JOINTS], double roll, double pitch, int anchor,
                  double com[3], double pelvis[3]);

#ifdef __cplusplus
}
#endif

#endif /* AHC_STEPPING_H */
