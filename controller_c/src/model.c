/*
 * model.c — kinematics of the planar double inverted pendulum (docs/controller.md §2) and the quintic
 * splines, and the invariants of the transition's splines in a restored state. Pure functions, no state.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>

#include "ahc/controller.h"
#include "fail_message.h"
#include "transition_splines.h"

/* The CoM offsets d1, d2 enter only when set, so that the paper's model (both 0) computes exactly
 * the paper's expressions, bit for bit. */
static int has_offsets(const ahc_params *p) { return p->link1_com_x != 0.0 || p->link2_com_x != 0.0; }

void ahc_com(const ahc_params *p, double th1, double th2, double *rx, double *rz)
{
    const double m = p->m1 + p->m2;
    const double s1 = sin(th1), c1 = cos(th1);
    const double s12 = sin(th1 + th2), c12 = cos(th1 + th2);
    if (has_offsets(p)) {
        const double d1 = p->link1_com_x, d2 = p->link2_com_x;
        if (rx) *rx = (p->m1 * (p->lg1 * s1 + d1 * c1) + p->m2 * (p->l1 * s1 + p->lg2 * s12 + d2 * c12)) / m;
        if (rz) *rz = (p->m1 * (p->lg1 * c1 - d1 * s1) + p->m2 * (p->l1 * c1 + p->lg2 * c12 - d2 * s12)) / m;
        return;
    }
    if (rx) *rx = (p->m1 * p->lg1 * s1 + p->m2 * (p->l1 * s1 + p->lg2 * s12)) / m;
    if (rz) *rz = (p->m1 * p->lg1 * c1 + p->m2 * (p->l1 * c1 + p->lg2 * c12)) / m;
}

/* Paper eq. 20: J_cx = [r_z, k_m lg2 C12] (with link 2's offset: k_m (lg2 C12 - d2 S12)). */
void ahc_com_jacobian_x(const ahc_params *p, double th1, double th2, double J[2])
{
    const double km = p->m2 / (p->m1 + p->m2);
    double rz = 0.0;
    ahc_com(p, th1, th2, NULL, &rz);
    J[0] = rz;
    J[1] = has_offsets(p) ? km * (p->lg2 * cos(th1 + th2) - p->link2_com_x * sin(th1 + th2))
                          : p->m2 / (p->m1 + p->m2) * p->lg2 * cos(th1 + th2);
}

/* Paper eq. 15: the ankle rate that keeps r_x still while the hip moves, -J_cx[1] / J_cx[0]. */
double ahc_reactionless_ratio(const ahc_params *p, double th1, double th2)
{
    const double c1 = cos(th1), c12 = cos(th1 + th2);
    double num, den;
    if (has_offsets(p)) {
        const double s1 = sin(th1), s12 = sin(th1 + th2);
        num = p->m2 * (p->lg2 * c12 - p->link2_com_x * s12);
        den = p->m1 * (p->lg1 * c1 - p->link1_com_x * s1) + p->m2 * p->l1 * c1 + num;
    } else {
        num = p->m2 * p->lg2 * c12;
        den = (p->m1 * p->lg1 + p->m2 * p->l1) * c1 + num;
    }
    if (fabs(den) < 1e-12) return 0.0;
    return -num / den;
}

/* Eq. 11's inertia about the ankle: I1 + m1 |c1|^2 + I2 + m2 |hip + c2|^2, with
 * |hip + c2|^2 = l1^2 + lg2^2 + d2^2 + 2 l1 (lg2 cos th2 - d2 sin th2). */
double ahc_ankle_inertia(const ahc_params *p, double th2)
{
    if (has_offsets(p)) {
        const double d1 = p->link1_com_x, d2 = p->link2_com_x;
        return p->I1 + p->m1 * (p->lg1 * p->lg1 + d1 * d1) + p->I2 +
               p->m2 * (p->l1 * p->l1 + p->lg2 * p->lg2 + d2 * d2 + 2.0 * p->l1 * (p->lg2 * cos(th2) - d2 * sin(th2)));
    }
    return p->I1 + p->m1 * p->lg1 * p->lg1 + p->I2 +
           p->m2 * (p->l1 * p->l1 + p->lg2 * p->lg2 + 2.0 * p->l1 * p->lg2 * cos(th2));
}

void ahc_erect_posture(const ahc_params *p, double *th1, double *th2)
{
    double t1 = 0.0, t12 = 0.0;
    if (has_offsets(p)) {
        t12 = -atan2(p->link2_com_x, p->lg2);
        t1 = -atan2(p->m1 * p->link1_com_x, p->m1 * p->lg1 + p->m2 * p->l1);
    }
    if (th1) *th1 = t1;
    if (th2) *th2 = t12 - t1;
}

void ahc_quintic_init(ahc_quintic *q, double x0, double v0, double a0,
                      double x1, double v1, double a1, double T)
{
    /* x(t) = c0 + c1 t + c2 t^2 + c3 t^3 + c4 t^4 + c5 t^5; closed-form solution of the six
     * boundary conditions. */
    const double T2 = T * T, T3 = T2 * T, T4 = T3 * T, T5 = T4 * T;
    const double dx = x1 - x0;
    q->T = T;
    q->c[0] = x0;
    q->c[1] = v0;
    q->c[2] = 0.5 * a0;
    q->c[3] = (20.0 * dx - (8.0 * v1 + 12.0 * v0) * T - (3.0 * a0 - a1) * T2) / (2.0 * T3);
    q->c[4] = (-30.0 * dx + (14.0 * v1 + 16.0 * v0) * T + (3.0 * a0 - 2.0 * a1) * T2) / (2.0 * T4);
    q->c[5] = (12.0 * dx - 6.0 * (v1 + v0) * T - (a0 - a1) * T2) / (2.0 * T5);
}

void ahc_quintic_eval(const ahc_quintic *q, double t, double *x, double *v, double *a)
{
    const double *c = q->c;
    if (t < 0.0) t = 0.0;
    if (t > q->T) t = q->T;
    if (x) *x = c[0] + t * (c[1] + t * (c[2] + t * (c[3] + t * (c[4] + t * c[5]))));
    if (v) *v = c[1] + t * (2.0 * c[2] + t * (3.0 * c[3] + t * (4.0 * c[4] + t * 5.0 * c[5])));
    if (a) *a = 2.0 * c[2] + t * (6.0 * c[3] + t * (12.0 * c[4] + t * 20.0 * c[5]));
}

int ahc_fail_message(char *msg, size_t n, int code, const char *fmt, ...)
{
    if (msg && n > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(msg, n, fmt, ap);
        va_end(ap);
    }
    return code;
}

int ahc_transition_splines_check(const ahc_quintic *kw, const ahc_quintic *rd, const char *rd_name, double T,
                                 int phase, double k_w, char *msg, size_t msg_size)
{
    ahc_quintic q;
    int i;
    for (i = 0; i < 2; ++i)
        if (!(fabs(rd->c[i]) <= 1e9))
            return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "%s coefficient %d = %g is not finite or beyond +-1e9", rd_name, i,
                               rd->c[i]);
    for (i = 0; i < 6; ++i)
        if (!isfinite(kw->c[i]) || !isfinite(rd->c[i]))
            return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "spline coefficient %d is not finite", i);
    if (kw->T != T || rd->T != T)
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "spline durations %g and %g are not the transition's %g", kw->T, rd->T, T);
    ahc_quintic_init(&q, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, T);
    for (i = 0; i < 6; ++i)
        if (q.c[i] != kw->c[i])
            return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "kw_spline coefficient %d = %g is not the 0 -> 1 quintic's %g", i,
                               kw->c[i], q.c[i]);
    ahc_quintic_init(&q, rd->c[0], rd->c[1], 0.0, 0.0, 0.0, 0.0, T);
    for (i = 0; i < 6; ++i)
        if (q.c[i] != rd->c[i])
            return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "%s coefficient %d = %g is not the quintic from its start to rest (%g)",
                               rd_name, i, rd->c[i], q.c[i]);
    if ((phase == AHC_PHASE_ANKLE && k_w != 0.0) ||
        ((phase == AHC_PHASE_HIP || phase == AHC_PHASE_HIP_TO_ANKLE) && k_w != 1.0))
        return ahc_fail_message(msg, msg_size, AHC_ERR_INCONSISTENT, "k_w = %g does not belong to phase %d", k_w, phase);
    return AHC_OK;
}
