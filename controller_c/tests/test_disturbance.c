/*
 * test_disturbance — establishes the disturbance estimate (docs/controller.md, "Disturbance
 * estimate and kinematics source"):
 *  A. Exact sensor model of the two-link body on resting feet: given joint trajectories
 *     th1 = A1 sin(w1 t), th2 = A2 sin(w2 t + phi) (2 and 3 Hz, ZMP excursions of ~ +-25 mm) and
 *     a known external moment d_ext(t) about the sole point O under the ankle, the ZMP and the
 *     normal force follow analytically from the moment balance about O (ahc_test.h,
 *     test_body_dynamics, with the analytic rates and accelerations):
 *        p f_z = g (sum m_i x_i + m_f x_f) + d_ext + dH_O,   f_z = (m + m_f) g + sum m_i z_i''.
 *     The sensor model itself is checked first: dH_O equals -dH_y/dt by central differences of
 *     the angular momentum about O.
 *     Default controller (reaction_compensation = 1, feet modelled): disturbance_moment tracks
 *     d_ext low-passed by zmp_filter_tau (the controller's discretisation y += alpha (u - y),
 *     alpha = 1 - exp(-h/tau), applied to the samples of d_ext). The only error is the backward
 *     differences' truncation (rates: -h/2 q'', accelerations: -h q''' per absolute link angle
 *     q), which the filter (gain <= 1) does not amplify; the tolerance is that first-order bound
 *         e <= sum_j [ Ba_j h max|q_j'''| + Bw_j (h/2) max|q_j''| ],
 *         Ba_j = I_j + sum_i m_i L_ij rho_i,  Bw_j = 2 max|q_j'| sum_i m_i L_ij rho_i,
 *     (L_ij = lever of segment j to CoM i, rho_i >= distance of CoM i from O), times 1.25 for the
 *     O(h^2) rest. The error must also be first order in h (halving h halves it, ratio 1.6-2.4),
 *     which a modelling mismatch would not do. The paper-literal estimator
 *     (reaction_compensation = 0, d = m g (p - r_x) + feet term) is off by the filtered reaction
 *     term: its error must exceed half the filtered reaction amplitude and 20 tolerances.
 *  B. The algebraic-loop arithmetic of docs/controller.md: with the paper-literal estimator the
 *     hip's own acceleration re-enters eq. 16 with the loop gain k_m M12 / (I2 + m2 lg2^2):
 *     docs' figure (m2/(m + m_f)) (I2 + m2 (lg2^2 + l1 lg2)) / (I2 + m2 lg2^2) = 1.52; the exact
 *     coefficients about the sole point (M12_O, J_O, read off the sensor model) give 1.68/1.02
 *     (hip/ankle, feet ignored) and 1.85/1.12 (feet modelled). All exceed 1. This is why the
 *     first release turned the compensation on; push sweeps on the plant, one setting at a time,
 *     later showed the loop is stable without it (a gain above 1 on a negative feedback of the
 *     measured acceleration only makes the admittance heavier; the servo's finite bandwidth keeps
 *     the loop gain below 1 where its phase reaches -180 degrees; the limit cycle of the first
 *     release came from the measured kinematics) and that it costs push margin,
 *     so the paper's estimate is the default again (docs/controller.md sections 4.4-4.5).
 *  Closed-loop stability behind a servo is not asserted here: in a linear model an acceleration
 *  feedback of gain > 1 through a first-order servo lag and the ZMP filter is not by itself
 *  unstable (hip alone: J2 s^2 (1+Ts)(1+tau s) + (Ch s + Kh)(1+Ts)(1+tau s) + g J2 s^2 is Hurwitz
 *  for T = 30 ms, tau = 20 ms, g = 1.3 by Routh), so such a test could not discriminate; the
 *  divergence needs the sampled loop / servo and contact dynamics of the plant and is shown with
 *  the plant FMU (docs/controller.md).
 */
#include "ahc_test.h"

#define PI 3.14159265358979323846

/* Joint trajectories and their first three derivatives. */
typedef struct {
    double A1, w1, A2, w2, phi;
} traj;

static void traj_eval(const traj *T, double t, double q[2], double w[2], double a[2], double j[2])
{
    q[0] = T->A1 * sin(T->w1 * t);
    w[0] = T->A1 * T->w1 * cos(T->w1 * t);
    a[0] = -T->A1 * T->w1 * T->w1 * sin(T->w1 * t);
    j[0] = -T->A1 * T->w1 * T->w1 * T->w1 * cos(T->w1 * t);
    q[1] = T->A2 * sin(T->w2 * t + T->phi);
    w[1] = T->A2 * T->w2 * cos(T->w2 * t + T->phi);
    a[1] = -T->A2 * T->w2 * T->w2 * sin(T->w2 * t + T->phi);
    j[1] = -T->A2 * T->w2 * T->w2 * T->w2 * cos(T->w2 * t + T->phi);
}

static double d_ext(double t) { return 0.3 + 0.5 * sin(2.0 * PI * 0.7 * t); }

/* Exact sensors at time t. */
static void exact_sensors(const ahc_params *p, const traj *T, double t, ahc_sensors *s, double *dH)
{
    double q[2], w[2], a[2], j[2], rx, mzdd;
    const double m = p->m1 + p->m2, M = m + p->feet_mass;
    traj_eval(T, t, q, w, a, j);
    test_body_dynamics(p, q[0], q[1], w[0], w[1], a[0], a[1], dH, &mzdd, NULL);
    ahc_com(p, q[0], q[1], &rx, NULL);
    s->theta_ankle = q[0];
    s->theta_hip = q[1];
    s->fz = M * p->g + mzdd;
    s->zmp_x = (p->g * (m * rx + p->feet_mass * p->feet_com_x) + d_ext(t) + *dH) / s->fz;
}

typedef struct {
    double err;      /* max |d_out - LPF[d_ext]| for t >= t0 */
    double reaction; /* max |LPF[dH_O]| for t >= t0 */
    double pmin, pmax;
    int faults;
} run_result;

static run_result run(const ahc_params *p, const traj *T, double t_end)
{
    ahc_controller c;
    ahc_sensors s;
    ahc_outputs o;
    run_result r = { 0.0, 0.0, 1.0, -1.0, 0 };
    const double h = p->sample_period, alpha = 1.0 - exp(-h / p->zmp_filter_tau), t0 = 0.5;
    const int N = (int)(t_end / h + 0.5);
    double y = 0.0, yH = 0.0, dH;
    int n;
    CHECK(ahc_init(&c, p) == AHC_OK, "init");
    for (n = 0; n < N; ++n) {
        const double t = n * h;
        exact_sensors(p, T, t, &s, &dH);
        ahc_step(&c, &s, &o);
        y = n == 0 ? d_ext(t) : y + alpha * (d_ext(t) - y);
        yH = n == 0 ? dH : yH + alpha * (dH - yH);
        if (o.fault) r.faults++;
        if (s.zmp_x < r.pmin) r.pmin = s.zmp_x;
        if (s.zmp_x > r.pmax) r.pmax = s.zmp_x;
        if (t >= t0) {
            if (fabs(o.disturbance_moment - y) > r.err) r.err = fabs(o.disturbance_moment - y);
            if (fabs(yH) > r.reaction) r.reaction = fabs(yH);
        }
    }
    return r;
}

/* First-order truncation bound of the backward differences on dH_O (see the header). */
static double fd_bound(const ahc_params *p, const traj *T, double h)
{
    /* absolute link angles q1 = th1, q2 = th1 + th2: bound their derivatives by sums */
    const double W1 = T->A1 * T->w1, A1 = W1 * T->w1, J1 = A1 * T->w1;
    const double W2 = W1 + T->A2 * T->w2, A2 = A1 + T->A2 * T->w2 * T->w2,
                 J2 = J1 + T->A2 * T->w2 * T->w2 * T->w2;
    const double rho1 = p->ankle_height + p->lg1, rho2 = p->ankle_height + p->l1 + p->lg2;
    const double S1 = p->m1 * p->lg1 * rho1 + p->m2 * p->l1 * rho2; /* sum_i m_i L_i1 rho_i */
    const double S2 = p->m2 * p->lg2 * rho2;                         /* sum_i m_i L_i2 rho_i */
    const double Ba1 = p->I1 + S1, Ba2 = p->I2 + S2;
    const double Bw1 = 2.0 * W1 * S1, Bw2 = 2.0 * W2 * S2;
    return Ba1 * h * J1 + Ba2 * h * J2 + Bw1 * 0.5 * h * A1 + Bw2 * 0.5 * h * A2;
}

int main(void)
{
    ahc_params p;
    const traj T = { 0.01, 2.0 * PI * 2.0, 0.012, 2.0 * PI * 3.0, 0.5 };

    ahc_params_default(&p);
    /* the compensated estimate (an option since the push sweeps of docs/controller.md 4.5 made the
     * paper's estimate the default), with the feet modelled */
    CHECK(p.reaction_compensation == 0 && p.feet_offset_mode == AHC_FEET_IGNORE, "defaults: the paper's estimate");
    p.reaction_compensation = 1;
    p.feet_offset_mode = AHC_FEET_MODEL;

    /* ---- A0. the sensor model: dH_O = -dH_y/dt (central differences, step 1e-5 s) ---- */
    {
        int k;
        double worst = 0.0;
        for (k = 0; k < 50; ++k) {
            const double t = 0.037 * k, e = 1e-5;
            double q[2], w[2], a[2], j[2], dH, Hp, Hm;
            traj_eval(&T, t, q, w, a, j);
            test_body_dynamics(&p, q[0], q[1], w[0], w[1], a[0], a[1], &dH, NULL, NULL);
            traj_eval(&T, t + e, q, w, a, j);
            test_body_dynamics(&p, q[0], q[1], w[0], w[1], a[0], a[1], NULL, NULL, &Hp);
            traj_eval(&T, t - e, q, w, a, j);
            test_body_dynamics(&p, q[0], q[1], w[0], w[1], a[0], a[1], NULL, NULL, &Hm);
            if (fabs(dH + (Hp - Hm) / (2.0 * e)) > worst) worst = fabs(dH + (Hp - Hm) / (2.0 * e));
        }
        CHECK(worst < 1e-6, "sensor model: dH_O vs -dHy/dt differ by %.3g N m", worst);
    }

    /* ---- A. estimator vs exact sensors ---- */
    {
        ahc_params q = p, q2, qp;
        run_result r1, r2, rp;
        double tol, tol2;
        r1 = run(&q, &T, 3.0);
        tol = 1.25 * fd_bound(&q, &T, q.sample_period);
        q2 = q;
        q2.sample_period = 0.5 * q.sample_period;
        r2 = run(&q2, &T, 3.0);
        tol2 = 1.25 * fd_bound(&q2, &T, q2.sample_period);
        qp = q;
        qp.reaction_compensation = 0;
        rp = run(&qp, &T, 3.0);
        printf("ZMP range %.1f .. %.1f mm; filtered reaction up to %.3f N m\n", 1e3 * r1.pmin, 1e3 * r1.pmax,
               r1.reaction);
        printf("compensated: max error %.4f N m at h = 1 ms (tolerance %.4f), %.4f at 0.5 ms (tol %.4f), ratio %.2f\n",
               r1.err, tol, r2.err, tol2, r1.err / r2.err);
        printf("paper literal: max error %.3f N m (%.0f x the tolerance)\n", rp.err, rp.err / tol);
        CHECK(r1.faults == 0 && r2.faults == 0 && rp.faults == 0, "no faults (ZMP inside the foot)");
        CHECK(r1.err <= tol, "compensated estimate: error %.4g > tolerance %.4g", r1.err, tol);
        CHECK(r2.err <= tol2, "compensated estimate, h = 0.5 ms: error %.4g > tolerance %.4g", r2.err, tol2);
        CHECK(r1.err / r2.err > 1.6 && r1.err / r2.err < 2.4, "first-order convergence in h: ratio %.3g",
              r1.err / r2.err);
        CHECK(rp.err > 0.5 * r1.reaction && rp.err > 20.0 * tol,
              "paper-literal estimate off by the reaction: %.3g (reaction %.3g, tol %.3g)", rp.err, r1.reaction, tol);
        CHECK(r1.reaction > 1.0, "the test exercises a large reaction: %.3g N m", r1.reaction);
    }

    /* ---- B. algebraic-loop arithmetic ---- */
    {
        const double m = p.m1 + p.m2, M = m + p.feet_mass, km = p.m2 / m;
        const double J2 = p.I2 + p.m2 * p.lg2 * p.lg2;
        const double M12 = p.I2 + p.m2 * (p.lg2 * p.lg2 + p.l1 * p.lg2); /* about the ankle, erect */
        const double gain_doc = p.m2 / M * M12 / J2;                     /* docs' 0.658 * 0.168 / 0.073 */
        const double Ja = ahc_ankle_inertia(&p, 0.0);
        double M12_O, J_O, dH0, dH;
        /* exact reaction coefficients about the sole point O at the erect pose, from the sensor model */
        test_body_dynamics(&p, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, &dH0, NULL, NULL);
        test_body_dynamics(&p, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, &dH, NULL, NULL);
        M12_O = dH0 - dH; /* p f_z contains -M12_O th2'' */
        test_body_dynamics(&p, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, &dH, NULL, NULL);
        J_O = dH0 - dH;   /* p f_z contains -J_O th1'' */
        /* paper-literal estimator, f_z = M g:
         *   feet ignored  (d = m g (p - r_x)):           d contains -(m/M) (reaction moment);
         *   feet modelled (d = M g p - m g r_x - ...):    d contains the full reaction moment;
         * eq. 16 feeds k_m d / J2 back into th2'', eq. 11 d / J_ankle into th1''. */
        printf("hip loop gain, docs' formula (m2/(m + m_f)) M12/(I2 + m2 lg2^2) = %.3f * %.4f / %.4f = %.3f\n",
               p.m2 / M, M12, J2, gain_doc);
        printf("about the sole point (M12_O = %.4f, J_O = %.4f, J_ankle = %.4f): hip %.3f / ankle %.3f with the"
               " feet ignored, hip %.3f / ankle %.3f with the feet modelled\n",
               M12_O, J_O, Ja, km * (m / M) * M12_O / J2, (m / M) * J_O / Ja, km * M12_O / J2, J_O / Ja);
        CHECK(fabs(M12_O - (p.I2 + p.m2 * p.lg2 * (p.lg2 + p.l1 + p.ankle_height))) < 1e-12, "M12_O");
        CHECK(fabs(gain_doc - 1.52) < 0.02, "docs' hip loop gain 1.5: %.3g", gain_doc);
        CHECK(gain_doc > 1.0 && km * (m / M) * M12_O / J2 > 1.0 && km * M12_O / J2 > 1.0,
              "every reading of the hip loop gain exceeds 1");
        CHECK((m / M) * J_O / Ja > 1.0 && J_O / Ja > 1.0, "ankle loop gain > 1 (%.3g, %.3g)", (m / M) * J_O / Ja,
              J_O / Ja);
    }
    TEST_MAIN_END();
}
