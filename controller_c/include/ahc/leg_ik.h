/*
 * leg_ik.h — the legs' analytic inverse and forward kinematics, feet flat on the ground, for the
 * 3D controller (docs/controller.md §11.4). A leg as HOAP-2's (hoap2/bodies.h): a hip whose yaw,
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

#ifdef __cplusplus
}
#endif

#endif /* AHC_LEG_IK_H */
