/*
 * leg_ik.c — analytic inverse and forward kinematics of a leg, foot flat or at any pose (leg_ik.h).
 *
 * Chain, trunk to foot:  R_foot = R_trunk Rz(yaw) Ry(-hip) Rx(hip_roll) Ry(knee) Ry(-ankle) Rx(ankle_roll).
 * With the foot flat (R_foot = I) the shank is at R_S = Rx(-ankle_roll) Ry(ankle), the thigh at
 * R_S Ry(-knee), and the hip relative to the ankle is R_S v with
 *   v = (-t sin knee, 0, s + t cos knee)   (s: shank, t: thigh).
 * Inverse: |hip| fixes the knee (law of cosines); hip = Rx(-roll) Ry(ankle) v gives the ankle roll
 * from the hip's (y, z) and the ankle pitch from the angle between v and the hip in the leg's plane;
 * then M = R_trunk^T R_S Ry(-knee) = Rz(yaw) Ry(-hip) Rx(hip_roll) gives the hip's three angles
 * (Z-Y-X Euler angles).
 * Any foot pose (ahc_leg_ik_pose): the same closed form in the foot's frame — the hip there is
 * -Rf^T ankle, the trunk's orientation Rf^T (Rf: the foot's relative to the trunk).
 */
#include <math.h>
#include <string.h>

#include "ahc/leg_ik.h"
#include "hoap2/nominal.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* the threshold of the singularity report (AHC_LEG_IK_SINGULAR) */
#define AHC_LEG_IK_SINGULAR_TOL 1e-6

static void rot_x(double a, double R[9])
{
    const double c = cos(a), s = sin(a);
    const double r[9] = {1, 0, 0, 0, c, -s, 0, s, c};
    memcpy(R, r, sizeof r);
}

static void rot_y(double a, double R[9])
{
    const double c = cos(a), s = sin(a);
    const double r[9] = {c, 0, s, 0, 1, 0, -s, 0, c};
    memcpy(R, r, sizeof r);
}

static void rot_z(double a, double R[9])
{
    const double c = cos(a), s = sin(a);
    const double r[9] = {c, -s, 0, s, c, 0, 0, 0, 1};
    memcpy(R, r, sizeof r);
}

static void mul(const double A[9], const double B[9], double C[9])
{
    double t[9];
    int i, j;
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j) t[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
    memcpy(C, t, sizeof t);
}

/* C = A^T B */
static void mul_tn(const double A[9], const double B[9], double C[9])
{
    double t[9];
    int i, j;
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j) t[3 * i + j] = A[i] * B[j] + A[3 + i] * B[3 + j] + A[6 + i] * B[6 + j];
    memcpy(C, t, sizeof t);
}

static void mul_v(const double A[9], const double v[3], double out[3])
{
    double t[3];
    int i;
    for (i = 0; i < 3; ++i) t[i] = A[3 * i] * v[0] + A[3 * i + 1] * v[1] + A[3 * i + 2] * v[2];
    memcpy(out, t, sizeof t);
}

/* The closed form (the comment at the top). hip: the hip centre relative to the ankle centre, R: the
 * trunk's orientation, both in the foot's axes. general = 0: ahc_leg_ik's arithmetic, bit for bit
 * (the 3D controller's results depend on it); general = 1 (ahc_leg_ik_pose): the ankle-roll branch
 * with |roll| <= pi/2 (the hip may be below the ankle in the foot's frame), the ankle pitch wrapped
 * to (-pi, pi], the hip's angles by a two-step decomposition that stays exact near the gimbal (hip
 * pitch +-pi/2), and the singularities reported. Returns the status bits (UNREACHABLE, SINGULAR). */
static int leg_ik_core(const ahc_leg_geometry *g, const double hip[3], const double R[9], double q[AHC_LEG_JOINTS],
                       int general)
{
    const double t = g->thigh, s = g->shank;
    const double len = sqrt(hip[0] * hip[0] + hip[1] * hip[1] + hip[2] * hip[2]);
    double ck = (len * len - t * t - s * s) / (2.0 * t * s);
    double knee, Rs[9], Ra[9], M[9];
    int out = 0;
    /* a straight leg is at ck = 1 up to rounding: out of reach only beyond that */
    if (ck > 1.0) {
        out = ck > 1.0 + 1e-9;
        ck = 1.0;
    } else if (ck < -1.0) {
        out = ck < -1.0 - 1e-9;
        ck = -1.0;
    }
    knee = acos(ck);
    q[AHC_LEG_KNEE] = knee;
    {
        /* the roll from the hip's (y, z), the pitch from the angle between v and the hip; general:
         * (y, z) taken with the sign of z, so that |roll| <= pi/2 */
        const double sz = general && hip[2] < 0.0 ? -1.0 : 1.0;
        const double ryz = sqrt(hip[1] * hip[1] + hip[2] * hip[2]), sk = sqrt(1.0 - ck * ck);
        q[AHC_LEG_ANKLE_ROLL] = atan2(sz * hip[1], sz * hip[2]);
        q[AHC_LEG_ANKLE_PITCH] = atan2(hip[0], sz * ryz) - atan2(-t * sk, s + t * ck);
        if (general) {
            if (!(ryz > 0.0)) q[AHC_LEG_ANKLE_ROLL] = 0.0;   /* not atan2(-0, -0) = -pi */
            if (q[AHC_LEG_ANKLE_PITCH] > M_PI) q[AHC_LEG_ANKLE_PITCH] -= 2.0 * M_PI;
            else if (q[AHC_LEG_ANKLE_PITCH] <= -M_PI) q[AHC_LEG_ANKLE_PITCH] += 2.0 * M_PI;
            /* the hip on the foot's x axis: the roll undetermined (0 taken) */
            if (ryz < AHC_LEG_IK_SINGULAR_TOL * (t + s)) out |= AHC_LEG_IK_SINGULAR;
        }
        /* the thigh's orientation R_S Ry(-knee), R_S = Rx(-ankle_roll) Ry(ankle): cos and sin of
         * the roll straight from the hip's (y, z) */
        {
            const double cr = ryz > 0.0 ? sz * hip[2] / ryz : 1.0, sr = ryz > 0.0 ? sz * hip[1] / ryz : 0.0;
            const double r[9] = {1, 0, 0, 0, cr, sr, 0, -sr, cr};   /* Rx(-roll) */
            memcpy(Rs, r, sizeof r);
        }
    }
    rot_y(q[AHC_LEG_ANKLE_PITCH] - knee, Ra);
    mul(Rs, Ra, Rs);
    mul_tn(R, Rs, M);   /* M = R^T R_thigh = Rz(yaw) Ry(-hip) Rx(hip_roll) */
    if (!general) {
        q[AHC_LEG_HIP_YAW] = atan2(M[3], M[0]);
        q[AHC_LEG_HIP_PITCH] = asin(M[6] > 1.0 ? 1.0 : (M[6] < -1.0 ? -1.0 : M[6]));
        q[AHC_LEG_HIP_ROLL] = atan2(M[7], M[8]);
        return out;
    }
    {
        /* yaw from M's first column (cos hip (cos yaw, sin yaw, .)), then N = Rz(-yaw) M =
         * Ry(-hip) Rx(roll) = [ch, sh sr, sh cr; 0, cr, -sr; sh, ch sr, ch cr] (sh, ch: sin, cos
         * hip): roll and hip from entries that do not vanish with cos hip, so that the pose is met
         * exactly whatever yaw was taken at the gimbal */
        const double ch = sqrt(M[0] * M[0] + M[3] * M[3]);
        double yaw = atan2(M[3], M[0]), cy, sy;
        if (ch < AHC_LEG_IK_SINGULAR_TOL) out |= AHC_LEG_IK_SINGULAR;
        if (ch < 1e-10) yaw = 0.0;   /* the gimbal: yaw and hip roll turn about one axis; yaw 0 */
        cy = cos(yaw);
        sy = sin(yaw);
        q[AHC_LEG_HIP_YAW] = yaw;
        q[AHC_LEG_HIP_PITCH] = atan2(M[6], cy * M[0] + sy * M[3]);
        q[AHC_LEG_HIP_ROLL] = atan2(sy * M[2] - cy * M[5], cy * M[4] - sy * M[1]);
    }
    return out;
}

int ahc_leg_ik(const ahc_leg_geometry *g, const double hip[3], const double R[9], double q[AHC_LEG_JOINTS])
{
    return leg_ik_core(g, hip, R, q, 0);
}

void ahc_leg_fk(const ahc_leg_geometry *g, const double q[AHC_LEG_JOINTS], double hip[3], double R[9])
{
    double Rs[9], Rt[9], A[9];
    const double v[3] = {-g->thigh * sin(q[AHC_LEG_KNEE]), 0.0, g->shank + g->thigh * cos(q[AHC_LEG_KNEE])};
    rot_x(-q[AHC_LEG_ANKLE_ROLL], Rs);
    rot_y(q[AHC_LEG_ANKLE_PITCH], A);
    mul(Rs, A, Rs);                       /* shank */
    mul_v(Rs, v, hip);
    rot_y(-q[AHC_LEG_KNEE], A);
    mul(Rs, A, Rt);                       /* thigh */
    /* trunk = thigh (Rz(yaw) Ry(-hip) Rx(roll))^T = thigh Rx(-roll) Ry(hip) Rz(-yaw) */
    rot_x(-q[AHC_LEG_HIP_ROLL], A);
    mul(Rt, A, Rt);
    rot_y(q[AHC_LEG_HIP_PITCH], A);
    mul(Rt, A, Rt);
    rot_z(-q[AHC_LEG_HIP_YAW], A);
    mul(Rt, A, R);
}

int ahc_legs_from_planes(const ahc_leg_geometry *g, double th1, double th2, double phi, double psi,
                         double q[2][AHC_LEG_JOINTS])
{
    const int pivot = psi >= 0.0 ? AHC_RIGHT : AHC_LEFT, other = 1 - pivot;
    const double side = pivot == AHC_RIGHT ? 1.0 : -1.0;   /* +1: the other leg is the left one */
    const double L = g->thigh + g->shank;
    double R[9], A[9], hp[3], ho[3], across[3];
    const double pelvis[3] = {0.0, side * 2.0 * g->hip_y, 0.0};
    int out;
    /* the pivot leg straight: u = Rx(-phi) (sin th1, 0, cos th1) */
    hp[0] = L * sin(th1);
    hp[1] = L * cos(th1) * sin(phi);
    hp[2] = L * cos(th1) * cos(phi);
    /* the trunk: Rx(-psi) Ry(th1 + th2) */
    rot_x(-psi, R);
    rot_y(th1 + th2, A);
    mul(R, A, R);
    /* the other hip, from the other ankle (2 ankle_y across) */
    mul_v(R, pelvis, across);
    ho[0] = hp[0] + across[0];
    ho[1] = hp[1] + across[1] - side * 2.0 * g->ankle_y;
    ho[2] = hp[2] + across[2];
    out = ahc_leg_ik(g, hp, R, q[pivot]);
    if (psi == 0.0 && g->hip_y == g->ankle_y) {
        /* the parallelogram (pelvis level, hips as far apart as the ankles): both legs at the same
         * pose relative to their ankles (ho = hp, up to the rounding of adding and taking away
         * 2 b = 2 a): one leg's angles, and half the work */
        memcpy(q[other], q[pivot], sizeof q[pivot]);
        return 2 * out;
    }
    out += ahc_leg_ik(g, ho, R, q[other]);
    return out;
}

void ahc_legs_frontal_angles(const ahc_leg_geometry *g, const double q[2][AHC_LEG_JOINTS], int pivot_right,
                             double *phi, double *psi)
{
    double hip[3], R[9];
    ahc_leg_fk(g, q[pivot_right ? AHC_RIGHT : AHC_LEFT], hip, R);
    /* phi: the hip's lean seen along x; psi: the trunk's y axis R e_y = (., cos psi, -sin psi) */
    *phi = atan2(hip[1], hip[2]);
    *psi = atan2(-R[7], R[4]);
}

/* ---- Any foot pose ------------------------------------------------------------------------------ */

void ahc_leg_limits_hoap2(int side, ahc_leg_limits *lim)
{
    /* outward is + on the left leg: a yaw about +z turns its toes, a roll about +x moves its foot, to +y */
    const int left = side == AHC_LEFT;
    lim->lo[AHC_LEG_HIP_YAW] = left ? -HOAP2_HIP_YAW_IN_MAX : -HOAP2_HIP_YAW_OUT_MAX;
    lim->hi[AHC_LEG_HIP_YAW] = left ? HOAP2_HIP_YAW_OUT_MAX : HOAP2_HIP_YAW_IN_MAX;
    lim->lo[AHC_LEG_HIP_PITCH] = HOAP2_HIP_MIN;
    lim->hi[AHC_LEG_HIP_PITCH] = HOAP2_HIP_MAX;
    lim->lo[AHC_LEG_HIP_ROLL] = left ? -HOAP2_HIP_ADDUCTION_MAX : -HOAP2_HIP_ABDUCTION_MAX;
    lim->hi[AHC_LEG_HIP_ROLL] = left ? HOAP2_HIP_ABDUCTION_MAX : HOAP2_HIP_ADDUCTION_MAX;
    lim->lo[AHC_LEG_KNEE] = HOAP2_KNEE_MIN;
    lim->hi[AHC_LEG_KNEE] = HOAP2_KNEE_MAX;
    lim->lo[AHC_LEG_ANKLE_PITCH] = HOAP2_ANKLE_MIN;
    lim->hi[AHC_LEG_ANKLE_PITCH] = HOAP2_ANKLE_MAX;
    lim->lo[AHC_LEG_ANKLE_ROLL] = -HOAP2_ANKLE_ROLL_MAX;
    lim->hi[AHC_LEG_ANKLE_ROLL] = HOAP2_ANKLE_ROLL_MAX;
}

int ahc_leg_limits_check(const ahc_leg_limits *lim, const double q[AHC_LEG_JOINTS])
{
    int j, bits = 0;
    for (j = 0; j < AHC_LEG_JOINTS; ++j)
        if (!(q[j] >= lim->lo[j] && q[j] <= lim->hi[j])) bits |= AHC_LEG_IK_LIMIT(j);
    return bits;
}

const char *ahc_leg_joint_name(int j)
{
    static const char *const names[AHC_LEG_JOINTS] = {"hip_yaw", "hip", "hip_roll", "knee", "ankle", "ankle_roll"};
    return j >= 0 && j < AHC_LEG_JOINTS ? names[j] : "?";
}

int ahc_leg_ik_pose(const ahc_leg_geometry *g, const ahc_leg_limits *lim, const double ankle[3], const double Rf[9],
                    double q[AHC_LEG_JOINTS])
{
    /* in the foot's frame: the hip at -Rf^T ankle, the trunk at Rf^T */
    double hip[3], Rt[9];
    int i, j, status;
    for (i = 0; i < 3; ++i) {
        hip[i] = -(Rf[i] * ankle[0] + Rf[3 + i] * ankle[1] + Rf[6 + i] * ankle[2]);
        for (j = 0; j < 3; ++j) Rt[3 * i + j] = Rf[3 * j + i];
    }
    status = leg_ik_core(g, hip, Rt, q, 1);
    if (lim) status |= ahc_leg_limits_check(lim, q);
    return status;
}

void ahc_leg_fk_pose(const ahc_leg_geometry *g, const double q[AHC_LEG_JOINTS], double ankle[3], double Rf[9])
{
    /* down the chain: the thigh at Rz(yaw) Ry(-hip) Rx(roll), the knee t below the hip along it,
     * the shank at thigh Ry(knee), the ankle s below the knee, the foot at shank Ry(-ankle) Rx(roll) */
    double Rt[9], A[9], knee[3], shin[3];
    const double down_t[3] = {0.0, 0.0, -g->thigh}, down_s[3] = {0.0, 0.0, -g->shank};
    rot_z(q[AHC_LEG_HIP_YAW], Rt);
    rot_y(-q[AHC_LEG_HIP_PITCH], A);
    mul(Rt, A, Rt);
    rot_x(q[AHC_LEG_HIP_ROLL], A);
    mul(Rt, A, Rt);
    mul_v(Rt, down_t, knee);
    rot_y(q[AHC_LEG_KNEE], A);
    mul(Rt, A, Rt);
    mul_v(Rt, down_s, shin);
    ankle[0] = knee[0] + shin[0];
    ankle[1] = knee[1] + shin[1];
    ankle[2] = knee[2] + shin[2];
    rot_y(-q[AHC_LEG_ANKLE_PITCH], A);
    mul(Rt, A, Rt);
    rot_x(q[AHC_LEG_ANKLE_ROLL], A);
    mul(Rt, A, Rf);
}
