/*
 * leg_ik.h — the legs' analytic inverse and forward kinematics, feet flat on the ground, for the
 * 3D controller (docs/controller.md §11.4), and for any foot pose (ahc_leg_ik_pose, below). A leg as HOAP-2's (hoap2/bodies.h): a hip whose yaw,
 * pitch and roll axes meet (trunk -> thigh: Rz(yaw) Ry(-hip) Rx(hip_roll)), a knee (thigh ->
 * shank: Ry(knee), + = flexed), an ankle whose pitch and roll axes meet (shank -> foot:
 * Ry(-ankle) Rx(ankle_roll)). The pitch angles are in the sagittal sense (+ = the body above
 * pitches forward: theta_ankle, theta_hip), the others in the Webots proto's (a roll turns the
 * child about +x), as Hoap2Plant3D's joint outputs q_<side>_<joint>. World: x forward, y left,
 * z up; a foot flat means its frame is the world's.
 */
#ifndef AHC_LEG_IK_H
#define AHC_LEG_IK_H

#ifdef __cplusplus
extern "C" {
#endif

/* Joint order of a leg, trunk to foot (the 3D plant's). */
enum {
    AHC_LEG_HIP_YAW = 0,
    AHC_LEG_HIP_PITCH,
    AHC_LEG_HIP_ROLL,
    AHC_LEG_KNEE,
    AHC_LEG_ANKLE_PITCH,
    AHC_LEG_ANKLE_ROLL,
    AHC_LEG_JOINTS
};
enum { AHC_LEFT = 0, AHC_RIGHT = 1 };

typedef struct {
    double thigh, shank;   /* hip -> knee, knee -> ankle [m]                                     */
    double hip_y, ankle_y; /* hips and ankles across from the mid-plane [m]                      */
} ahc_leg_geometry;

/* The joint angles that put the hip centre at hip (relative to the ankle centre, world axes) with
 * the trunk at orientation R (row-major 3x3, world), the foot flat. Returns 0, or 1 when the hip is
 * out of the leg's reach (the knee straight, the leg pointing at the hip). */
int ahc_leg_ik(const ahc_leg_geometry *g, const double hip[3], const double R[9], double q[AHC_LEG_JOINTS]);

/* Forward: the hip centre relative to the ankle centre and the trunk orientation, foot flat. */
void ahc_leg_fk(const ahc_leg_geometry *g, const double q[AHC_LEG_JOINTS], double hip[3], double R[9]);

/* Both legs' joint angles for the sagittal angles (th1: the legs' pitch, th2: the hip pitch) and
 * the frontal ones (phi, psi; frontal.h), feet flat: the pivot leg (the right one for psi >= 0,
 * else the left) straight, leaning by th1 forward and phi sideways; the trunk at
 * Rx(-psi) Ry(th1 + th2); the other leg from its ankle to its hip. q[AHC_LEFT], q[AHC_RIGHT].
 * Returns the number of legs out of reach (0 normally). */
int ahc_legs_from_planes(const ahc_leg_geometry *g, double th1, double th2, double phi, double psi,
                         double q[2][AHC_LEG_JOINTS]);

/* The frontal angles of measured joint angles: phi the lean of the pivot leg (pivot_right: the
 * right leg, else the left) toward +y, psi the trunk's lean toward +y (from the pivot leg's chain). */
void ahc_legs_frontal_angles(const ahc_leg_geometry *g, const double q[2][AHC_LEG_JOINTS], int pivot_right,
                             double *phi, double *psi);

/* ---- Any foot pose (docs/controller.md §11.4, "Any foot pose") ------------------------------ */

/* Joint limits of a leg, in the senses above [rad]. */
typedef struct {
    double lo[AHC_LEG_JOINTS], hi[AHC_LEG_JOINTS];
} ahc_leg_limits;

/* HOAP-2's limits for one side (AHC_LEFT, AHC_RIGHT), from hoap2/nominal.h: the hip yaw and hip
 * roll limits mirror between the legs (outward is + on the left leg, - on the right). */
void ahc_leg_limits_hoap2(int side, ahc_leg_limits *lim);

/* The joints outside their limits: bit AHC_LEG_IK_LIMIT(j) set for each joint j with q[j] < lo[j]
 * or q[j] > hi[j] (NaN too); 0 when all are within. */
int ahc_leg_limits_check(const ahc_leg_limits *lim, const double q[AHC_LEG_JOINTS]);

/* "hip_yaw", "hip", "hip_roll", "knee", "ankle", "ankle_roll" (the 3D plant's names), or "?" */
const char *ahc_leg_joint_name(int j);

/* Status bits of ahc_leg_ik_pose (0: solved, every joint within its limits). */
#define AHC_LEG_IK_UNREACHABLE 1        /* the ankle beyond the leg's reach: the knee straight, the
                                           leg pointing at it, the foot at the orientation asked */
#define AHC_LEG_IK_SINGULAR 2           /* near a singularity (|cos hip| or the hip's distance from
                                           the foot's x axis below 1e-6 of scale): yaw and hip roll,
                                           or the ankle roll, are ill-determined (the pose is met) */
#define AHC_LEG_IK_LIMIT(j) (4 << (j))  /* joint j (AHC_LEG_*) outside its limits (not clamped) */

/* The six joint angles that put the ankle centre at `ankle` (relative to the hip centre, trunk
 * axes) with the foot at orientation Rf (relative to the trunk, row-major 3x3), in closed form.
 * The solution taken: knee >= 0 (HOAP-2's flexes forward), |ankle roll| <= pi/2, |hip pitch| <=
 * pi/2, every angle in (-pi, pi]: within HOAP-2's limits the only one (but for the knee's 1 deg of
 * hyperextension). lim: the limits to report (NULL: none). Returns a combination of the status
 * bits; q is always filled (out of reach: the nearest straight-knee pose; at a singularity: hip
 * yaw 0 at the hip's, ankle roll 0 at the ankle's). */
int ahc_leg_ik_pose(const ahc_leg_geometry *g, const ahc_leg_limits *lim, const double ankle[3], const double Rf[9],
                    double q[AHC_LEG_JOINTS]);

/* Forward: the ankle centre relative to the hip centre (trunk axes) and the foot's orientation
 * relative to the trunk, along the chain trunk -> thigh -> shank -> foot. */
void ahc_leg_fk_pose(const ahc_leg_geometry *g, const double q[AHC_LEG_JOINTS], double ankle[3], double Rf[9]);

#ifdef __cplusplus
}
#endif

#endif /* AHC_LEG_IK_H */
