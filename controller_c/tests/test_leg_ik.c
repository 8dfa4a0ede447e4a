/*
 * test_leg_ik.c — the leg's closed-form inverse kinematics for any foot pose (ahc_leg_ik_pose,
 * docs/controller.md §11.4 "Any foot pose"). Establishes:
 *   - HOAP-2's limits (ahc_leg_limits_hoap2) are the proto's (hoap2/bodies.h) in this library's
 *     senses, on both legs;
 *   - the pose forward kinematics (down the chain) and the foot-flat one (ahc_leg_fk, up the chain
 *     in the foot's frame) describe the same leg;
 *   - FK(IK(pose)) = pose within 1e-9 (position [m] and rotation entries) over 200 000 random joint
 *     vectors inside each leg's limits, with no status bit; IK(FK(q)) = q within 1e-9 wherever the
 *     knee is flexed by 1e-5 rad or more (the solution is then unique within the limits; the
 *     straight knee's angle is ill-conditioned: its error there is printed); a hyperextended knee
 *     (HOAP-2's 1 deg below 0) comes back as its mirror solution, the pose met;
 *   - FK(IK(pose)) = pose for 100 000 random poses over the whole of SO(3) and the leg's reach
 *     (the hip below the ankle in the foot's frame included), with the branch taken as documented;
 *   - the foot-flat IK (ahc_leg_ik) agrees with the pose IK on foot-flat poses;
 *   - out of reach: the status bit, the knee straight, the leg pointing at the target, the foot's
 *     orientation met; a pose at exactly the reach is not flagged;
 *   - a joint beyond its limit is reported by its own bit, not clamped;
 *   - the singularities (hip pitch +-pi/2: yaw and hip roll share an axis; the hip on the foot's
 *     x axis: the ankle roll undetermined) are flagged, the documented angle is 0 and the pose met.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ahc/leg_ik.h"
#include "ahc_test.h"
#include "hoap2/bodies.h"
#include "hoap2/nominal.h"

#define PI 3.14159265358979323846


static double max_abs_diff(const double *a, const double *b, int n)
{
    double m = 0.0;
    int i;
    for (i = 0; i < n; ++i) m = fmax(m, fabs(a[i] - b[i]));
    return m;
}

/* a rotation from a unit quaternion (w, x, y, z) */
static void quat_rot(const double qq[4], double R[9])
{
    const double w = qq[0], x = qq[1], y = qq[2], z = qq[3];
    R[0] = 1 - 2 * (y * y + z * z); R[1] = 2 * (x * y - w * z);     R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z);     R[4] = 1 - 2 * (x * x + z * z); R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y);     R[7] = 2 * (y * z + w * x);     R[8] = 1 - 2 * (x * x + y * y);
}

static void test_limits_are_the_protos(void)
{
    /* the proto's joint of each leg joint, and its sense here (-1: the sagittal pitch joints) */
    static const char *const motor[AHC_LEG_JOINTS] = {"joint_1", "joint_3", "joint_2", "joint_4", "joint_5", "joint_6"};
    static const double sense[AHC_LEG_JOINTS] = {1, -1, 1, 1, -1, 1};
    int side, j;
    size_t b;
    for (side = 0; side < 2; ++side) {
        ahc_leg_limits lim;
        ahc_leg_limits_hoap2(side, &lim);
        for (j = 0; j < AHC_LEG_JOINTS; ++j) {
            char name[32];
            int found = 0;
            snprintf(name, sizeof name, "%s_%s", side == AHC_LEFT ? "lleg" : "rleg", motor[j]);
            for (b = 0; b < sizeof HOAP2_BODIES / sizeof HOAP2_BODIES[0]; ++b) {
                const hoap2_body *h = &HOAP2_BODIES[b];
                if (strcmp(h->joint, name) != 0) continue;
                found = 1;
                CHECK_NEAR(lim.lo[j], sense[j] > 0 ? h->min : -h->max, 1e-12, name);
                CHECK_NEAR(lim.hi[j], sense[j] > 0 ? h->max : -h->min, 1e-12, name);
            }
            CHECK(found, "%s not in hoap2/bodies.h", name);
        }
    }
    CHECK(strcmp(ahc_leg_joint_name(AHC_LEG_HIP_ROLL), "hip_roll") == 0 && strcmp(ahc_leg_joint_name(9), "?") == 0,
          "joint names");
}

static void test_two_forward_chains(void)
{
    const ahc_leg_geometry g = ahc_test_hoap2_legs();
    unsigned long long st = 3;
    double worst = 0.0;
    int n, i;
    for (n = 0; n < 2000; ++n) {
        double q[AHC_LEG_JOINTS], ankle[3], Rf[9], hip[3], Rt[9], hip2[3], Rt2[9];
        for (i = 0; i < AHC_LEG_JOINTS; ++i) q[i] = test_rand(&st, -PI, PI);
        ahc_leg_fk_pose(&g, q, ankle, Rf);
        ahc_leg_fk(&g, q, hip, Rt);
        for (i = 0; i < 3; ++i) {
            int k;
            hip2[i] = -(Rf[i] * ankle[0] + Rf[3 + i] * ankle[1] + Rf[6 + i] * ankle[2]);
            for (k = 0; k < 3; ++k) Rt2[3 * i + k] = Rf[3 * k + i];
        }
        worst = fmax(worst, fmax(max_abs_diff(hip, hip2, 3), max_abs_diff(Rt, Rt2, 9)));
    }
    CHECK(worst < 1e-14, "ahc_leg_fk and ahc_leg_fk_pose differ by %g", worst);
    printf("  two forward chains agree within %.2g\n", worst);
}

/* FK(IK) and IK(FK) over random joint vectors inside each leg's limits */
static void test_round_trips_within_limits(void)
{
    const ahc_leg_geometry g = ahc_test_hoap2_legs();
    unsigned long long st = 11;
    double worst_p = 0.0, worst_R = 0.0, worst_q = 0.0, worst_q_straight = 0.0;
    int side, n, j, flagged = 0, mirrored = 0;
    for (side = 0; side < 2; ++side) {
        ahc_leg_limits lim;
        ahc_leg_limits_hoap2(side, &lim);
        for (n = 0; n < 100000; ++n) {
            double q[AHC_LEG_JOINTS], q2[AHC_LEG_JOINTS], ankle[3], Rf[9], ankle2[3], Rf2[9];
            int status;
            for (j = 0; j < AHC_LEG_JOINTS; ++j) q[j] = test_rand(&st, lim.lo[j], lim.hi[j]);
            if (n % 10 == 0) q[AHC_LEG_KNEE] = test_rand(&st, 0.0, 1e-3);   /* near the straight knee */
            ahc_leg_fk_pose(&g, q, ankle, Rf);
            status = ahc_leg_ik_pose(&g, &lim, ankle, Rf, q2);
            /* a hyperextended knee comes back as the mirror solution, whose other joints may be
             * beyond their limits near them: reported, as it should */
            if (status != 0 && q[AHC_LEG_KNEE] >= 0.0) ++flagged;
            ahc_leg_fk_pose(&g, q2, ankle2, Rf2);
            worst_p = fmax(worst_p, max_abs_diff(ankle, ankle2, 3));
            worst_R = fmax(worst_R, max_abs_diff(Rf, Rf2, 9));
            if (q[AHC_LEG_KNEE] < 0.0) {
                /* the knee's hyperextension: the mirror solution, knee -q */
                ++mirrored;
                CHECK_NEAR(q2[AHC_LEG_KNEE], -q[AHC_LEG_KNEE], 1e-7, "hyperextended knee: |knee|");
            } else if (q[AHC_LEG_KNEE] >= 1e-5) {
                worst_q = fmax(worst_q, max_abs_diff(q, q2, AHC_LEG_JOINTS));
            } else {
                worst_q_straight = fmax(worst_q_straight, max_abs_diff(q, q2, AHC_LEG_JOINTS));
            }
        }
    }
    CHECK(flagged == 0, "%d poses inside the limits flagged", flagged);
    CHECK(worst_p <= 1e-9 && worst_R <= 1e-9, "FK(IK): position %g m, rotation %g", worst_p, worst_R);
    CHECK(worst_q <= 1e-9, "IK(FK): joint angles %g rad", worst_q);
    CHECK(mirrored > 0, "no hyperextended knee sampled");
    printf("  200000 joint vectors inside the limits: FK(IK) position %.2g m, rotation %.2g; IK(FK) %.2g rad\n"
           "  (knee >= 1e-5 rad), %.2g rad for knees below 1e-5 rad; %d hyperextended knees mirrored\n",
           worst_p, worst_R, worst_q, worst_q_straight, mirrored);
}

/* FK(IK) over random poses anywhere: the foot at any orientation, the ankle anywhere in reach */
static void test_any_pose(void)
{
    const ahc_leg_geometry g = ahc_test_hoap2_legs();
    const double L = g.thigh + g.shank;
    unsigned long long st = 5;
    double worst_p = 0.0, worst_R = 0.0;
    int n, j, below = 0, unreachable = 0, branch = 0;
    for (n = 0; n < 100000; ++n) {
        double qq[4], nrm, Rf[9], ankle[3], q[AHC_LEG_JOINTS], ankle2[3], Rf2[9], dir[3], r;
        int status;
        do {
            for (j = 0; j < 4; ++j) qq[j] = test_rand(&st, -1.0, 1.0);
            nrm = sqrt(qq[0] * qq[0] + qq[1] * qq[1] + qq[2] * qq[2] + qq[3] * qq[3]);
        } while (nrm > 1.0 || nrm < 1e-3);
        for (j = 0; j < 4; ++j) qq[j] /= nrm;
        quat_rot(qq, Rf);
        do {
            for (j = 0; j < 3; ++j) dir[j] = test_rand(&st, -1.0, 1.0);
            nrm = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
        } while (nrm > 1.0 || nrm < 1e-3);
        r = test_rand(&st, 0.02, 1.0) * L;
        for (j = 0; j < 3; ++j) ankle[j] = r * dir[j] / nrm;
        /* the hip below the ankle in the foot's frame: the ankle-roll branch |roll| <= pi/2 */
        if (Rf[2] * ankle[0] + Rf[5] * ankle[1] + Rf[8] * ankle[2] > 0.0) ++below;
        status = ahc_leg_ik_pose(&g, NULL, ankle, Rf, q);
        if (status & AHC_LEG_IK_UNREACHABLE) ++unreachable;
        if (!(q[AHC_LEG_KNEE] >= 0.0 && q[AHC_LEG_KNEE] <= PI && fabs(q[AHC_LEG_ANKLE_ROLL]) <= 0.5 * PI &&
              fabs(q[AHC_LEG_HIP_PITCH]) <= 0.5 * PI))
            ++branch;
        for (j = 0; j < AHC_LEG_JOINTS; ++j)
            if (!(q[j] > -PI && q[j] <= PI)) ++branch;
        ahc_leg_fk_pose(&g, q, ankle2, Rf2);
        worst_p = fmax(worst_p, max_abs_diff(ankle, ankle2, 3));
        worst_R = fmax(worst_R, max_abs_diff(Rf, Rf2, 9));
    }
    CHECK(unreachable == 0, "%d poses in reach flagged out of reach", unreachable);
    CHECK(branch == 0, "%d solutions off the documented branch", branch);
    CHECK(below > 10000, "only %d poses with the hip below the ankle", below);
    CHECK(worst_p <= 1e-9 && worst_R <= 1e-9, "FK(IK) anywhere: position %g m, rotation %g", worst_p, worst_R);
    printf("  100000 poses over SO(3) x the reach (%d with the hip below the ankle): FK(IK) position %.2g m, "
           "rotation %.2g\n", below, worst_p, worst_R);
}

static void test_flat_foot_agrees(void)
{
    const ahc_leg_geometry g = ahc_test_hoap2_legs();
    unsigned long long st = 17;
    double worst = 0.0;
    int n, j;
    for (n = 0; n < 2000; ++n) {
        double q[AHC_LEG_JOINTS], hip[3], Rt[9], qa[AHC_LEG_JOINTS], qb[AHC_LEG_JOINTS], ankle[3], Rf[9];
        q[AHC_LEG_HIP_YAW] = test_rand(&st, -0.3, 0.3);
        q[AHC_LEG_HIP_PITCH] = test_rand(&st, -0.6, 0.6);
        q[AHC_LEG_HIP_ROLL] = test_rand(&st, -0.3, 0.3);
        q[AHC_LEG_KNEE] = test_rand(&st, 0.05, 1.5);
        q[AHC_LEG_ANKLE_PITCH] = test_rand(&st, -0.6, 0.6);
        q[AHC_LEG_ANKLE_ROLL] = test_rand(&st, -0.3, 0.3);
        ahc_leg_fk(&g, q, hip, Rt);       /* the hip over a flat foot, the trunk at Rt */
        CHECK(ahc_leg_ik(&g, hip, Rt, qa) == 0, "foot-flat pose %d", n);
        /* the same pose seen from the trunk: the foot at Rt^T, the ankle at -Rt^T hip */
        for (j = 0; j < 3; ++j) {
            int k;
            ankle[j] = -(Rt[j] * hip[0] + Rt[3 + j] * hip[1] + Rt[6 + j] * hip[2]);
            for (k = 0; k < 3; ++k) Rf[3 * j + k] = Rt[3 * k + j];
        }
        CHECK(ahc_leg_ik_pose(&g, NULL, ankle, Rf, qb) == 0, "pose %d", n);
        worst = fmax(worst, max_abs_diff(qa, qb, AHC_LEG_JOINTS));
    }
    CHECK(worst < 1e-12, "foot-flat IK and pose IK differ by %g rad", worst);
    printf("  foot-flat IK = pose IK within %.2g rad\n", worst);
}

static void test_named_poses(void)
{
    const ahc_leg_geometry g = ahc_test_hoap2_legs();
    ahc_leg_limits lim;
    /* a swing foot: the right ankle 5 cm forward, 2 cm out, 3 cm lifted from standing straight
     * (0.2 m below the hip), the foot yawed out 0.3 rad, its sole pitched toes-up 0.1 rad */
    const double ankle[3] = {0.05, -0.02, -(HOAP2_THIGH + HOAP2_SHANK) + 0.03};
    const double cy = cos(-0.3), sy = sin(-0.3), cp = cos(-0.1), sp = sin(-0.1);
    /* Rz(yaw) Ry(pitch) */
    const double Rf[9] = {cy * cp, -sy, cy * sp, sy * cp, cy, sy * sp, -sp, 0.0, cp};
    double q[AHC_LEG_JOINTS], a2[3], R2[9];
    ahc_leg_limits_hoap2(AHC_RIGHT, &lim);
    CHECK(ahc_leg_ik_pose(&g, &lim, ankle, Rf, q) == 0, "the swing foot is within reach and limits");
    ahc_leg_fk_pose(&g, q, a2, R2);
    CHECK(max_abs_diff(ankle, a2, 3) < 1e-15 && max_abs_diff(Rf, R2, 9) < 1e-15, "swing foot met");
    CHECK(q[AHC_LEG_HIP_YAW] < -0.2 && q[AHC_LEG_KNEE] > 0.3, "swing foot: yaw %g, knee %g", q[AHC_LEG_HIP_YAW],
          q[AHC_LEG_KNEE]);
    /* the standing leg: everything 0 */
    {
        const double a0[3] = {0.0, 0.0, -(HOAP2_THIGH + HOAP2_SHANK)}, I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        int j;
        CHECK(ahc_leg_ik_pose(&g, &lim, a0, I, q) == 0, "standing straight");
        for (j = 0; j < AHC_LEG_JOINTS; ++j) CHECK(fabs(q[j]) < 1e-7, "standing straight: %s %g", ahc_leg_joint_name(j), q[j]);
    }
}

static void test_out_of_reach(void)
{
    const ahc_leg_geometry g = ahc_test_hoap2_legs();
    const double L = g.thigh + g.shank;
    unsigned long long st = 23;
    int n, j;
    for (n = 0; n < 1000; ++n) {
        double q0[AHC_LEG_JOINTS], q[AHC_LEG_JOINTS], ankle[3], Rf[9], target[3], a2[3], R2[9], d;
        const double k = test_rand(&st, 1.0 + 1e-6, 1.5);
        int status;
        for (j = 0; j < AHC_LEG_JOINTS; ++j) q0[j] = test_rand(&st, -1.0, 1.0);
        q0[AHC_LEG_KNEE] = 0.0;
        ahc_leg_fk_pose(&g, q0, ankle, Rf);    /* a straight leg: |ankle| = L */
        for (j = 0; j < 3; ++j) target[j] = k * ankle[j];
        status = ahc_leg_ik_pose(&g, NULL, target, Rf, q);
        CHECK(status & AHC_LEG_IK_UNREACHABLE, "%g L flagged out of reach", k);
        CHECK(q[AHC_LEG_KNEE] == 0.0, "out of reach: knee straight (%g)", q[AHC_LEG_KNEE]);
        ahc_leg_fk_pose(&g, q, a2, R2);
        d = sqrt(target[0] * target[0] + target[1] * target[1] + target[2] * target[2]);
        for (j = 0; j < 3; ++j) CHECK_NEAR(a2[j], L * target[j] / d, 1e-14, "out of reach: toward the target");
        CHECK(max_abs_diff(Rf, R2, 9) < 1e-14, "out of reach: the foot's orientation met");
        CHECK(!(ahc_leg_ik_pose(&g, NULL, ankle, Rf, q) & AHC_LEG_IK_UNREACHABLE), "exactly at reach: not flagged");
    }
}

static void test_limits_reported(void)
{
    const ahc_leg_geometry g = ahc_test_hoap2_legs();
    int side, j;
    for (side = 0; side < 2; ++side) {
        ahc_leg_limits lim;
        ahc_leg_limits_hoap2(side, &lim);
        for (j = 0; j < AHC_LEG_JOINTS; ++j) {
            /* a mid pose, then joint j 0.05 rad beyond its upper limit */
            double q[AHC_LEG_JOINTS], q2[AHC_LEG_JOINTS], ankle[3], Rf[9];
            int k, status;
            for (k = 0; k < AHC_LEG_JOINTS; ++k) q[k] = 0.5 * (lim.lo[k] + lim.hi[k]);
            q[j] = lim.hi[j] + 0.05;
            ahc_leg_fk_pose(&g, q, ankle, Rf);
            status = ahc_leg_ik_pose(&g, &lim, ankle, Rf, q2);
            CHECK(status == AHC_LEG_IK_LIMIT(j), "%s beyond its limit: status %d", ahc_leg_joint_name(j), status);
            CHECK_NEAR(q2[j], q[j], 1e-9, "not clamped");
            /* and below the lower limit, where the documented branch reaches it (the knee's lower
             * limit is the mirror solution's: checked on the angles) */
            q[j] = lim.lo[j] - 0.05;
            if (j == AHC_LEG_KNEE) {
                CHECK(ahc_leg_limits_check(&lim, q) == AHC_LEG_IK_LIMIT(AHC_LEG_KNEE), "knee below its limit");
                continue;
            }
            ahc_leg_fk_pose(&g, q, ankle, Rf);
            status = ahc_leg_ik_pose(&g, &lim, ankle, Rf, q2);
            CHECK(status == AHC_LEG_IK_LIMIT(j), "%s below its limit: status %d", ahc_leg_joint_name(j), status);
            CHECK_NEAR(q2[j], q[j], 1e-9, "not clamped");
        }
        {
            double q[AHC_LEG_JOINTS] = {0, 0, 0, NAN, 0, 0};
            CHECK(ahc_leg_limits_check(&lim, q) == AHC_LEG_IK_LIMIT(AHC_LEG_KNEE), "NaN reported");
        }
    }
}

static void test_singularities(void)
{
    const ahc_leg_geometry g = ahc_test_hoap2_legs();
    double q[AHC_LEG_JOINTS], q2[AHC_LEG_JOINTS], ankle[3], Rf[9], a2[3], R2[9];
    int status;
    /* the hip's gimbal: hip pitch pi/2 (yaw and hip roll about one axis); both signs */
    {
        const double qs[2][AHC_LEG_JOINTS] = {{0.3, 0.5 * PI, 0.2, 0.7, 0.1, -0.1}, {-0.2, -0.5 * PI, 0.4, 0.5, -0.2, 0.1}};
        int i;
        for (i = 0; i < 2; ++i) {
            memcpy(q, qs[i], sizeof q);
            ahc_leg_fk_pose(&g, q, ankle, Rf);
            status = ahc_leg_ik_pose(&g, NULL, ankle, Rf, q2);
            CHECK(status & AHC_LEG_IK_SINGULAR, "hip gimbal flagged (status %d)", status);
            CHECK(q2[AHC_LEG_HIP_YAW] == 0.0, "gimbal: yaw 0 (%g)", q2[AHC_LEG_HIP_YAW]);
            ahc_leg_fk_pose(&g, q2, a2, R2);
            CHECK(max_abs_diff(ankle, a2, 3) < 1e-12 && max_abs_diff(Rf, R2, 9) < 1e-12, "gimbal: pose met (%g, %g)",
                  max_abs_diff(ankle, a2, 3), max_abs_diff(Rf, R2, 9));
            /* 1e-3 rad away: not flagged, and the angles recovered */
            q[AHC_LEG_HIP_PITCH] -= (i == 0 ? 1e-3 : -1e-3);
            ahc_leg_fk_pose(&g, q, ankle, Rf);
            status = ahc_leg_ik_pose(&g, NULL, ankle, Rf, q2);
            CHECK(status == 0 && max_abs_diff(q, q2, AHC_LEG_JOINTS) < 1e-9, "1 mrad from the gimbal: %d, %g", status,
                  max_abs_diff(q, q2, AHC_LEG_JOINTS));
        }
    }
    /* the hip on the foot's x axis (the shank and thigh folded along the sole): ankle roll 0 */
    {
        const double a[3] = {0.0, 0.0, -0.15};
        const double Ry[9] = {0, 0, -1, 0, 1, 0, 1, 0, 0};   /* Ry(-pi/2): the hip at +x of the foot */
        status = ahc_leg_ik_pose(&g, NULL, a, Ry, q2);
        CHECK(status & AHC_LEG_IK_SINGULAR, "ankle singularity flagged (status %d)", status);
        CHECK(q2[AHC_LEG_ANKLE_ROLL] == 0.0, "ankle singularity: roll 0 (%g)", q2[AHC_LEG_ANKLE_ROLL]);
        ahc_leg_fk_pose(&g, q2, a2, R2);
        CHECK(max_abs_diff(a, a2, 3) < 1e-12 && max_abs_diff(Ry, R2, 9) < 1e-12, "ankle singularity: pose met");
    }
    /* the ankle at the hip (knee folded to pi, beyond its limit) */
    {
        const double a[3] = {0.0, 0.0, 0.0}, I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        ahc_leg_limits lim;
        ahc_leg_limits_hoap2(AHC_LEFT, &lim);
        status = ahc_leg_ik_pose(&g, &lim, a, I, q2);
        CHECK(status & AHC_LEG_IK_LIMIT(AHC_LEG_KNEE), "the ankle at the hip: the knee beyond its limit (%d)", status);
        ahc_leg_fk_pose(&g, q2, a2, R2);
        CHECK(max_abs_diff(a, a2, 3) < 1e-12 && max_abs_diff(I, R2, 9) < 1e-12, "ankle at the hip: pose met (%g %g)",
              max_abs_diff(a, a2, 3), max_abs_diff(I, R2, 9));

    }
}

int main(void)
{
    test_limits_are_the_protos();
    test_two_forward_chains();
    test_round_trips_within_limits();
    test_any_pose();
    test_flat_foot_agrees();
    test_named_poses();
    test_out_of_reach();
    test_limits_reported();
    test_singularities();
    TEST_MAIN_END();
}
