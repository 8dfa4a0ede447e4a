/*
 * frontal_model.c — kinematics of the frontal model (docs/controller.md §11.1). Pure functions.
 *
 * Frontal plane (y left, z up), origin at the mid-point between the ankle axes, at their height.
 * For psi >= 0 the right leg is the pivot: its ankle A_R = (-a, 0), its hip
 *   H_R = A_R + l1 (sin phi, cos phi);
 * link 2 turns about H_R: the pelvis axis e = (cos psi, -sin psi) points from the right hip to the
 * left one, its normal n = (sin psi, cos psi) up through link 2, so
 *   H_L = H_R + 2 b e,   c2 = H_R + (b + y2) e + lg2 n   (link 2's CoM);
 * the right leg's CoM lies lg1 along it and c1y outward (-y) of it; the left leg, from A_L = (a, 0)
 * to H_L, is taken as straight at the fraction lg1/l1 of its chord (its knee flexes when psi > 0,
 * which moves its CoM off the chord by a second-order amount), c1y outward (+y). psi < 0 is the
 * mirror image: r_y(phi, psi; y2) = -r_y(-phi, -psi; -y2), r_z likewise with z unchanged.
 */
#include <math.h>

#include "frontal_pose.h"

typedef ahc_frontal_pose frontal_pose;

/* The model for psi >= 0 (right leg the pivot), link 2's lateral CoM offset y2. */
static void pose_right_pivot(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi,
                             double y2, frontal_pose *o)
{
    const double a = f->ankle_y, b = f->hip_y, L = sp->l1, t = sp->lg1, g2 = sp->lg2, c1 = f->link1_com_y;
    const double m1h = 0.5 * sp->m1, m2 = sp->m2, m = sp->m1 + sp->m2;
    const double sf = sin(phi), cf = cos(phi), sp_ = sin(psi), cp = cos(psi);
    /* the pivot (right) leg */
    const double hRy = -a + L * sf, hRz = L * cf;
    const double yR = -a + t * sf - c1 * cf, zR = t * cf + c1 * sf;
    /* link 2 */
    const double ey = cp, ez = -sp_, ny = sp_, nz = cp;
    const double y2c = hRy + (b + y2) * ey + g2 * ny, z2c = hRz + (b + y2) * ez + g2 * nz;
    /* the other (left) leg: the chord from A_L to H_L */
    const double wy = hRy + 2.0 * b * ey - a, wz = hRz + 2.0 * b * ez;
    const double len = sqrt(wy * wy + wz * wz);
    const double uy = wy / len, uz = wz / len;
    const double yL = a + (t / L) * wy + c1 * uz, zL = (t / L) * wz - c1 * uy;
    o->y = (m1h * (yR + yL) + m2 * y2c) / m;
    o->z = (m1h * (zR + zL) + m2 * z2c) / m;
    o->other_len = len;
    o->ly[0] = yR; o->lz[0] = zR; o->lean[0] = phi;
    o->ly[1] = yL; o->lz[1] = zL; o->lean[1] = atan2(wy, wz);
    o->ly[2] = y2c; o->lz[2] = z2c; o->lean[2] = psi;
    {
        /* derivatives: d H_R/d phi = L (cf, -sf); d e/d psi = -n; d n/d psi = e */
        const double dw_phi_y = L * cf, dw_phi_z = -L * sf;
        const double dw_psi_y = -2.0 * b * ny, dw_psi_z = -2.0 * b * nz;
        /* d u_z = (dw_z - u_z (u . dw)) / len */
        const double duz_phi = (dw_phi_z - uz * (uy * dw_phi_y + uz * dw_phi_z)) / len;
        const double duz_psi = (dw_psi_z - uz * (uy * dw_psi_y + uz * dw_psi_z)) / len;
        const double dyR_phi = t * cf + c1 * sf;
        const double dy2_phi = L * cf, dy2_psi = -(b + y2) * ny + g2 * ey;
        const double dyL_phi = (t / L) * dw_phi_y + c1 * duz_phi, dyL_psi = (t / L) * dw_psi_y + c1 * duz_psi;
        o->dy[0] = (m1h * (dyR_phi + dyL_phi) + m2 * dy2_phi) / m;
        o->dy[1] = (m1h * dyL_psi + m2 * dy2_psi) / m;
    }
}

void ahc_frontal_pose_at(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi,
                         frontal_pose *o)
{
    if (psi >= 0.0) {
        pose_right_pivot(f, sp, phi, psi, f->link2_com_y, o);
    } else {
        /* the mirror image: y -> -y, angles -> -angles; derivatives d(-y)/d(-q) = dy/dq */
        int i;
        double t;
        pose_right_pivot(f, sp, -phi, -psi, -f->link2_com_y, o);
        o->y = -o->y;
        /* the mirror's right leg is the real left one */
        t = o->ly[0]; o->ly[0] = o->ly[1]; o->ly[1] = t;
        t = o->lz[0]; o->lz[0] = o->lz[1]; o->lz[1] = t;
        t = o->lean[0]; o->lean[0] = o->lean[1]; o->lean[1] = t;
        for (i = 0; i < 3; ++i) {
            o->ly[i] = -o->ly[i];
            o->lean[i] = -o->lean[i];
        }
    }
}

void ahc_frontal_lumps(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi,
                       double y[3], double z[3], double lean[3])
{
    frontal_pose o;
    int i;
    ahc_frontal_pose_at(f, sp, phi, psi, &o);
    for (i = 0; i < 3; ++i) {
        y[i] = o.ly[i];
        z[i] = o.lz[i];
        lean[i] = o.lean[i];
    }
}

void ahc_frontal_com(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi,
                     double *ry, double *rz)
{
    frontal_pose o;
    ahc_frontal_pose_at(f, sp, phi, psi, &o);
    if (ry) *ry = o.y;
    if (rz) *rz = o.z;
}

void ahc_frontal_com_jacobian(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi,
                              double J[2])
{
    frontal_pose o;
    ahc_frontal_pose_at(f, sp, phi, psi, &o);
    J[0] = o.dy[0];
    J[1] = o.dy[1];
}

double ahc_frontal_reactionless_ratio(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi)
{
    double J[2];
    ahc_frontal_com_jacobian(f, sp, phi, psi, J);
    return fabs(J[0]) > 1e-12 ? -J[1] / J[0] : 0.0;
}

double ahc_frontal_ankle_inertia(const ahc_frontal_params *f, const ahc_params *sp)
{
    return f->I1_roll + sp->m1 * (sp->lg1 * sp->lg1 + f->link1_com_y * f->link1_com_y) + sp->m2 * sp->l1 * sp->l1;
}

double ahc_frontal_hip_inertia(const ahc_frontal_params *f, const ahc_params *sp)
{
    const double dy = f->hip_y + f->link2_com_y;
    return f->I2_roll + sp->m2 * (sp->lg2 * sp->lg2 + dy * dy);
}

double ahc_frontal_other_leg_length(const ahc_frontal_params *f, const ahc_params *sp, double phi, double psi)
{
    frontal_pose o;
    ahc_frontal_pose_at(f, sp, phi, psi, &o);
    return o.other_len;
}
