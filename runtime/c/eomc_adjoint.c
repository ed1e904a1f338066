/* eomc_adjoint.c -- discrete adjoint of fixed-step RK4 (see eomc_adjoint.h). */
#include <math.h>
#include <string.h>

#include "eomc_adjoint.h"
#include "eomc_stagger.h"
#include "eomc_dense_lu.h"

size_t eomc_adjoint_work_size(int nx, int nparam)
{
    return (size_t)8 * (size_t)nx + (size_t)(nparam > 0 ? nparam : 0);
}

/* The stage states of the step from x at t: x2 = x + h/2 k1, x3 = x + h/2 k2,
 * x4 = x + h k3; ``acc`` (may be NULL) gets k1 + 2 k2 + 2 k3 + k4. */
static int stages(const eomc_model *m, double t, double h, const double *x, const double *p,
                  const double *r, double *k, double *x2, double *x3, double *x4, double *acc,
                  double *mwork)
{
    int i, nx = m->nx, status;
    status = m->rhs(t, x, p, r, k, mwork);
    if (status != EOMC_OK) return status;
    for (i = 0; i < nx; i++) x2[i] = x[i] + 0.5 * h * k[i];
    if (acc) for (i = 0; i < nx; i++) acc[i] = k[i];
    status = m->rhs(t + 0.5 * h, x2, p, r, k, mwork);
    if (status != EOMC_OK) return status;
    for (i = 0; i < nx; i++) x3[i] = x[i] + 0.5 * h * k[i];
    if (acc) for (i = 0; i < nx; i++) acc[i] += 2.0 * k[i];
    status = m->rhs(t + 0.5 * h, x3, p, r, k, mwork);
    if (status != EOMC_OK) return status;
    for (i = 0; i < nx; i++) x4[i] = x[i] + h * k[i];
    if (acc) {
        for (i = 0; i < nx; i++) acc[i] += 2.0 * k[i];
        status = m->rhs(t + h, x4, p, r, k, mwork);
        if (status != EOMC_OK) return status;
        for (i = 0; i < nx; i++) acc[i] += k[i];
    }
    return EOMC_OK;
}

int eomc_adjoint_rk4_forward(const eomc_model *m, double t0, double h, int nsteps,
                             const double *p, const double *r, double *X, double *S, double *work,
                             int *failed_step)
{
    int nx, k, i, status;
    double *ks, *x2, *x3, *x4, *acc, *mwork;
    if (!m || !X || !work || nsteps < 0 || !(h > 0.0)) return EOMC_BAD_ARGUMENT;
    nx = m->nx;
    ks = work; x2 = ks + nx; x3 = x2 + nx; x4 = x3 + nx; acc = x4 + nx;
    mwork = work + eomc_adjoint_work_size(nx, m->nparam);
    for (k = 0; k < nsteps; k++) {
        const double *x = X + (size_t)k * nx;
        double *x1 = X + (size_t)(k + 1) * nx;
        if (failed_step) *failed_step = k;
        double *s2 = S ? S + (size_t)k * 3 * nx : x2;
        status = stages(m, t0 + k * h, h, x, p, r, ks, s2, s2 == x2 ? x3 : s2 + nx,
                        s2 == x2 ? x4 : s2 + 2 * nx, acc, mwork);
        if (status != EOMC_OK) return status;
        for (i = 0; i < nx; i++) {
            x1[i] = x[i] + h / 6.0 * acc[i];
            if (!isfinite(x1[i])) return EOMC_NONFINITE;
        }
    }
    return EOMC_OK;
}

static int pull(eomc_vjp_fn vjp, double t, const double *x, const double *p, const double *r,
                const double *kb, double *gx, double *gpt, double *xb, double *gp, int nx,
                int nparam, double *mwork)
{
    int i, status = vjp(t, x, p, r, kb, NULL, gx, gp ? gpt : NULL, mwork);
    if (status != EOMC_OK) return status;
    for (i = 0; i < nx; i++) xb[i] += gx[i];
    if (gp) for (i = 0; i < nparam; i++) gp[i] += gpt[i];
    return EOMC_OK;
}

int eomc_adjoint_rk4_backward(const eomc_model *m, eomc_vjp_fn vjp, double t0, double h,
                              int nsteps, const double *p, const double *r, const double *X,
                              const double *S, const double *G, double *lam0, double *gp,
                              double *work)
{
    int nx, np, k, i, status;
    double *ks, *x2, *x3, *x4, *lam, *xb, *kb, *gx, *gpt, *mwork;
    if (!m || !vjp || !X || !G || !lam0 || !work || nsteps < 0 || !(h > 0.0))
        return EOMC_BAD_ARGUMENT;
    nx = m->nx;
    np = m->nparam;
    ks = work; x2 = ks + nx; x3 = x2 + nx; x4 = x3 + nx; lam = x4 + nx; xb = lam + nx;
    kb = xb + nx; gx = kb + nx; gpt = gx + nx;
    mwork = work + eomc_adjoint_work_size(nx, np);
    if (gp) for (i = 0; i < np; i++) gp[i] = 0.0;
    memcpy(lam, G + (size_t)nsteps * nx, (size_t)nx * sizeof(double));
    for (k = nsteps - 1; k >= 0; k--) {
        const double *x = X + (size_t)k * nx;
        double t = t0 + k * h;
        const double *y2 = x2, *y3 = x3, *y4 = x4;
        if (S) {
            y2 = S + (size_t)k * 3 * nx;
            y3 = y2 + nx;
            y4 = y3 + nx;
        } else {
            status = stages(m, t, h, x, p, r, ks, x2, x3, x4, NULL, mwork);
            if (status != EOMC_OK) return status;
        }
        memcpy(xb, lam, (size_t)nx * sizeof(double));
        /* x1 = x + h/6 (k1 + 2 k2 + 2 k3 + k4), ki = f(xi), x4 = x + h k3, x3 = x + h/2 k2,
         * x2 = x + h/2 k1: the stages' adjoints last to first */
        for (i = 0; i < nx; i++) kb[i] = h / 6.0 * lam[i];
        status = pull(vjp, t + h, y4, p, r, kb, gx, gpt, xb, gp, nx, np, mwork);
        if (status != EOMC_OK) return status;
        for (i = 0; i < nx; i++) kb[i] = h / 3.0 * lam[i] + h * gx[i];
        status = pull(vjp, t + 0.5 * h, y3, p, r, kb, gx, gpt, xb, gp, nx, np, mwork);
        if (status != EOMC_OK) return status;
        for (i = 0; i < nx; i++) kb[i] = h / 3.0 * lam[i] + 0.5 * h * gx[i];
        status = pull(vjp, t + 0.5 * h, y2, p, r, kb, gx, gpt, xb, gp, nx, np, mwork);
        if (status != EOMC_OK) return status;
        for (i = 0; i < nx; i++) kb[i] = h / 6.0 * lam[i] + 0.5 * h * gx[i];
        status = pull(vjp, t, x, p, r, kb, gx, gpt, xb, gp, nx, np, mwork);
        if (status != EOMC_OK) return status;
        for (i = 0; i < nx; i++) {
            lam[i] = xb[i] + G[(size_t)k * nx + i];
            if (!isfinite(lam[i])) return EOMC_NONFINITE;
        }
    }
    memcpy(lam0, lam, (size_t)nx * sizeof(double));
    return EOMC_OK;
}

/* ------------------------------------------------------- adaptive DOP853 */

int eomc_adjoint_erk_forward(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                             const double *x0, const double *p, const double *r, int ntstop,
                             const double *tstop, long rec_cap, double *rec_t, double *rec_x,
                             double *rec_k, long *nrec, double *x_last, eomc_stats *stats,
                             double *work, size_t work_len)
{
    eomc_stagger sg;
    int status;
    if (!m || !opt || !rec_t || !rec_x || !nrec || rec_cap <= 0 || ntstop < 0
        || (ntstop > 0 && !tstop))
        return EOMC_BAD_ARGUMENT;
    memset(&sg, 0, sizeof sg);
    sg.ntstop = ntstop; sg.tstop = tstop;
    sg.rec_cap = rec_cap; sg.rec_t = rec_t; sg.rec_x = rec_x; sg.rec_k = rec_k;
    status = eomc_integrate_sg(m, opt, t0, t1, x0, p, m->ninput > 0 ? 1 : 0, NULL, r, 0, NULL,
                               NULL, x_last, stats, work, work_len, &sg);
    *nrec = sg.nrec;
    return status;
}

#define ERK_S 12

size_t eomc_adjoint_erk_work_size(int nx, int nparam)
{
    return (size_t)(3 * ERK_S + 4) * (size_t)nx + (size_t)(nparam > 0 ? nparam : 0) + 8;
}

int eomc_adjoint_erk_backward(const eomc_model *m, eomc_vjp_fn vjp, long nrec,
                              const double *rec_t, const double *rec_x, const double *rec_k,
                              const double *p, const double *r, const double *G, double *lam0,
                              double *gp, double *work)
{
    const double *A, *B, *C;
    int nx, np, as, i, j, l, status;
    double *K, *Y, *Yb, *lam, *kb, *gx, *gpt, *mwork;
    if (!m || !vjp || nrec < 0 || !rec_t || (nrec > 0 && !rec_x) || !G || !lam0 || !work)
        return EOMC_BAD_ARGUMENT;
    eomc_dop853_tableau(&A, &as, &B, &C);
    nx = m->nx;
    np = m->nparam;
    K = work; Y = K + ERK_S * nx; Yb = Y + ERK_S * nx; lam = Yb + ERK_S * nx; kb = lam + nx;
    gx = kb + nx; gpt = gx + nx;
    mwork = work + eomc_adjoint_erk_work_size(nx, np);
    if (gp) for (i = 0; i < np; i++) gp[i] = 0.0;
    memcpy(lam, G + (size_t)nrec * nx, (size_t)nx * sizeof(double));
    for (long n = nrec - 1; n >= 0; n--) {
        const double *x = rec_x + (size_t)n * nx;
        double t = rec_t[n], h = rec_t[n + 1] - rec_t[n];
        /* the stages as run_erk computed them: Y_s = x + h sum_{j<s} a_sj K_j (zeros skipped,
         * j ascending), K_s = f(t + c_s h, Y_s) -- recorded by the forward run (the same
         * numbers: no rhs call here; the vjp calls below are then the backward run's whole
         * model cost), or recomputed */
        const double *Ks = rec_k ? rec_k + (size_t)n * ERK_S * nx : K;
        for (int st = 0; st < ERK_S; st++) {
            double *y = Y + (size_t)st * nx;
            for (i = 0; i < nx; i++) {
                double acc = 0.0;
                for (j = 0; j < st; j++) {
                    double a = A[(size_t)st * as + j];
                    if (a != 0.0) acc += a * Ks[(size_t)j * nx + i];
                }
                y[i] = st ? x[i] + h * acc : x[i];
            }
            if (rec_k) continue;
            status = m->rhs(t + C[st] * h, y, p, r, K + (size_t)st * nx, mwork);
            if (status != EOMC_OK) return status;
        }
        /* x_new = x + h sum_s b_s K_s: K_s's adjoint kb_s = h b_s lam + h sum_{l>s} a_ls Yb_l,
         * Y_s's adjoint Yb_s = J_s^T kb_s (vjp), and x's = lam + sum_s Yb_s */
        for (int st = ERK_S - 1; st >= 0; st--) {
            int any = 0;
            for (i = 0; i < nx; i++) {
                double acc = B[st] * lam[i];
                for (l = st + 1; l < ERK_S; l++) {
                    double a = A[(size_t)l * as + st];
                    if (a != 0.0) acc += a * Yb[(size_t)l * nx + i];
                }
                kb[i] = h * acc;
                any |= kb[i] != 0.0;
            }
            double *yb = Yb + (size_t)st * nx;
            if (!any) { memset(yb, 0, (size_t)nx * sizeof(double)); continue; }
            status = vjp(t + C[st] * h, Y + (size_t)st * nx, p, r, kb, NULL, yb, gp ? gpt : NULL, mwork);
            if (status != EOMC_OK) return status;
            if (gp) for (i = 0; i < np; i++) gp[i] += gpt[i];
        }
        for (i = 0; i < nx; i++) {
            double acc = lam[i] + G[(size_t)n * nx + i];
            for (int st = 0; st < ERK_S; st++) acc += Yb[(size_t)st * nx + i];
            lam[i] = acc;
            if (!isfinite(lam[i])) return EOMC_NONFINITE;
        }
    }
    memcpy(lam0, lam, (size_t)nx * sizeof(double));
    return EOMC_OK;
}

/* ------------------------------------------------------- adaptive Radau IIA */

size_t eomc_adjoint_radau_work_size(int nx, int nparam)
{
    size_t n = (size_t)nx;
    return 9 * n * n + 3 * n * n + 3 * n + 3 * n + 3 * n + 3 * n + (size_t)(nparam > 0 ? nparam : 0) + 8;
}

int eomc_adjoint_radau_backward(const eomc_model *m, eomc_vjp_fn vjp, long nrec,
                                const double *rec_t, const double *rec_x, const double *rec_z,
                                const double *p, const double *r, const double *G, double *lam0,
                                double *gp, double *work)
{
    const double s6 = sqrt(6.0);
    /* Radau IIA (order 5): the collocation coefficients and nodes the integrator's
     * eigenbasis form stands for */
    const double A[3][3] = {{(88 - 7 * s6) / 360, (296 - 169 * s6) / 1800, (-2 + 3 * s6) / 225},
                            {(296 + 169 * s6) / 1800, (88 + 7 * s6) / 360, (-2 - 3 * s6) / 225},
                            {(16 - s6) / 36, (16 + s6) / 36, 1.0 / 9}};
    const double C[3] = {(4 - s6) / 10, (4 + s6) / 10, 1.0};
    int nx, np, N, i, j, a, b, status;
    double *Kt, *J, *Y, *mu, *lam, *gx, *gpt, *mwork;
    int *piv;
    if (!m || !vjp || nrec < 0 || !rec_t || (nrec > 0 && (!rec_x || !rec_z)) || !G || !lam0 || !work)
        return EOMC_BAD_ARGUMENT;
    if (!m->jac_x) return EOMC_NOT_AVAILABLE;
    nx = m->nx;
    np = m->nparam;
    N = 3 * nx;
    Kt = work; J = Kt + (size_t)N * N; Y = J + (size_t)3 * nx * nx; mu = Y + N;
    lam = mu + N; gx = lam + nx; gpt = gx + nx;
    piv = (int *)(void *)(gpt + (np > 0 ? np : 0));     /* N ints in the N doubles that follow */
    mwork = work + eomc_adjoint_radau_work_size(nx, np);
    if (gp) for (i = 0; i < np; i++) gp[i] = 0.0;
    memcpy(lam, G + (size_t)nrec * nx, (size_t)nx * sizeof(double));
    for (long n = nrec - 1; n >= 0; n--) {
        const double *x = rec_x + (size_t)n * nx, *Z = rec_z + (size_t)n * N;
        double t = rec_t[n], h = rec_t[n + 1] - rec_t[n];
        for (a = 0; a < 3; a++) {
            double *ya = Y + (size_t)a * nx;
            for (i = 0; i < nx; i++) ya[i] = x[i] + Z[(size_t)a * nx + i];
            status = m->jac_x(t + C[a] * h, ya, p, r, J + (size_t)a * nx * nx, mwork);
            if (status != EOMC_OK) return status;
        }
        /* K = I - h (A (x) I) blkdiag(J_b): block (a, b) = delta_ab I - h A_ab J_b; Kt its
         * transpose, row (b, j), column (a, i) */
        for (b = 0; b < 3; b++)
            for (j = 0; j < nx; j++) {
                double *row = Kt + ((size_t)b * nx + j) * N;
                const double *Jb = J + (size_t)b * nx * nx;
                for (a = 0; a < 3; a++)
                    for (i = 0; i < nx; i++)
                        row[(size_t)a * nx + i] = (a == b && i == j ? 1.0 : 0.0) - h * A[a][b] * Jb[(size_t)i * nx + j];
            }
        memset(mu, 0, (size_t)N * sizeof(double));
        memcpy(mu + 2 * nx, lam, (size_t)nx * sizeof(double));     /* e_3 (x) lam */
        if (lu_factor(N, Kt, piv)) return EOMC_SINGULAR_MASS_MATRIX;
        lu_solve(N, Kt, piv, mu);
        for (i = 0; i < nx; i++) lam[i] += G[(size_t)n * nx + i];
        for (b = 0; b < 3; b++) {
            double *nu = Kt;                                /* scratch: the factors are spent */
            int any = 0;
            for (i = 0; i < nx; i++) {
                nu[i] = h * (A[0][b] * mu[i] + A[1][b] * mu[nx + i] + A[2][b] * mu[2 * nx + i]);
                any |= nu[i] != 0.0;
            }
            if (!any) continue;
            status = vjp(t + C[b] * h, Y + (size_t)b * nx, p, r, nu, NULL, gx, gp ? gpt : NULL, mwork);
            if (status != EOMC_OK) return status;
            for (i = 0; i < nx; i++) lam[i] += gx[i];
            if (gp) for (i = 0; i < np; i++) gp[i] += gpt[i];
        }
        for (i = 0; i < nx; i++)
            if (!isfinite(lam[i])) return EOMC_NONFINITE;
    }
    memcpy(lam0, lam, (size_t)nx * sizeof(double));
    return EOMC_OK;
}
