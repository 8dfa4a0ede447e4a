/*
 * leg_ik.c — analytic inverse and forward kinematics of a leg with the foot flat (leg_ik.h).
 *
 * Chain, trunk to foot:  R_foot = R_trunk Rz(yaw) Ry(-hip) Rx(hip_roll) Ry(knee) Ry(-ankle) Rx(ankle_roll).
 * With the foot flat (R_foot = I) the shank is at R_S = Rx(-ankle_roll) Ry(ankle), the thigh at
 * R_S Ry(-knee), and the hip relative to the ankle is R_S v with
 *   v = (-t sin knee, 0, s + t cos knee)   (s: shank, t: thigh).
 * Inverse: |hip| fixes the knee (law of cosines); hip = Rx(-roll) Ry(ankle) v gives the ankle roll
 * from the hip's (y, z) and the ankle pitch from the angle between v and the hip in the leg's plane;
 * then M = R_trunk^T R_S Ry(-knee) = Rz(yaw) Ry(-hip) Rx(hip_roll) gives the hip's three angles
 * (Z-Y-X Euler angles).
 */
#include <math.h>
#include <string.h>

#include "ahc/leg_ik.h"

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

int ahc_leg_ik(const ahc_leg_geometry *g, const double hip[3], const double R[9], double q[AHC_LEG_JOINTS])
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
        /* the roll from the hip's (y, z), the pitch from the angle between v and the hip */
        const double ryz = sqrt(hip[1] * hip[1] + hip[2] * hip[2]), sk = sqrt(1.0 - ck * ck);
        q[AHC_LEG_ANKLE_ROLL] = atan2(hip[1], hip[2]);
        q[AHC_LEG_ANKLE_PITCH] = atan2(hip[0], ryz) - atan2(-t * sk, s + t * ck);
        /* the thigh's orientation R_S Ry(-knee), R_S = Rx(-ankle_roll) Ry(ankle): cos and sin of
         * the roll straight from the hip's (y, z) */
        {
            const double cr = ryz > 0.0 ? hip[2] / ryz : 1.0, sr = ryz > 0.0 ? hip[1] / ryz : 0.0;
            const double r[9] = {1, 0, 0, 0, cr, sr, 0, -sr, cr};   /* Rx(-roll) */
            memcpy(Rs, r, sizeof r);
        }
    }
    rot_y(q[AHC_LEG_ANKLE_PITCH] - knee, Ra);
    mul(Rs, Ra, Rs);
    mul_tn(R, Rs, M);   /* M = R^T R_thigh = Rz(yaw) Ry(-hip) Rx(hip_roll) */
    q[AHC_LEG_HIP_YAW] = atan2(M[3], M[0]);
    q[AHC_LEG_HIP_PITCH] = asin(M[6] > 1.0 ? 1.0 : (M[6] < -1.0 ? -1.0 : M[6]));
    q[AHC_LEG_HIP_ROLL] = atan2(M[7], M[8]);
    return out;
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
