/* eomc_adjoint.c -- discrete adjoint of fixed-step RK4 (see eomc_adjoint.h). */
#include <math.h>
#include <string.h>

#include "eomc_adjoint.h"
#include "eomc_stagger.h"
#include "eomc_dense_lu.h"
#include "eomc_dense_lu_c.h"

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

/* Radau IIA (order 5): the collocation coefficients and nodes the integrator's eigenbasis
 * form stands for */
typedef struct {
    double A[3][3], C[3];
    double lam0;                /* A's real eigenvalue */
    eomc_cplx lam1;             /* one of its complex pair */
    double w0[3], l0[3];        /* right eigenvector of A^T and left one (A l = lam l), l.w = 1 */
    eomc_cplx w1[3], l1[3];
} radau_tab;

static void cross3(const eomc_cplx *a, const eomc_cplx *b, eomc_cplx *c)
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* The eigenvector pair (w of A^T, l of A) for eigenvalue lam, l.w = 1 (no conjugation): each
 * the cross product of two rows of the singular (A^T or A) - lam I. */
static void radau_eigvec(const double A[3][3], eomc_cplx lam, eomc_cplx *w, eomc_cplx *l)
{
    eomc_cplx Mt[3][3], M[3][3], d;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            Mt[a][b] = A[b][a] - (a == b ? lam : 0.0);
            M[a][b] = A[a][b] - (a == b ? lam : 0.0);
        }
    cross3(Mt[0], Mt[1], w);
    cross3(M[0], M[1], l);
    d = l[0] * w[0] + l[1] * w[1] + l[2] * w[2];
    for (int a = 0; a < 3; a++) l[a] /= d;
}

static void radau_tableau(radau_tab *k)
{
    const double s6 = sqrt(6.0), c81 = cbrt(81.0), c9 = cbrt(9.0);
    const double A[3][3] = {{(88 - 7 * s6) / 360, (296 - 169 * s6) / 1800, (-2 + 3 * s6) / 225},
                            {(296 + 169 * s6) / 1800, (88 + 7 * s6) / 360, (-2 - 3 * s6) / 225},
                            {(16 - s6) / 36, (16 + s6) / 36, 1.0 / 9}};
    eomc_cplx w0[3], l0[3];
    memcpy(k->A, A, sizeof A);
    k->C[0] = (4 - s6) / 10; k->C[1] = (4 + s6) / 10; k->C[2] = 1.0;
    k->lam0 = (6 + c81 - c9) / 30;
    k->lam1 = (12 - c81 + c9) / 60 + I * ((c81 + c9) * sqrt(3.0) / 60);
    radau_eigvec(A, k->lam0, w0, l0);
    radau_eigvec(A, k->lam1, k->w1, k->l1);
    for (int a = 0; a < 3; a++) { k->w0[a] = creal(w0[a]); k->l0[a] = creal(l0[a]); }
}

/* The preconditioner of the transposed collocation system: K(J, h)^T = I - h (A^T (x) J^T)
 * with one Jacobian J for all three stages, inverted in A^T's eigenbasis (A^T = sum_k lam_k
 * w_k l_k^T): (I/(h lam_k) - J^T) v_k = (l_k^T (x) I) r / (h lam_k), then mu = sum_k w_k v_k
 * -- one real and one complex nx solve (the third eigenvalue is the second's conjugate). */
typedef struct {
    int nx;
    double hf;                  /* the step the factors are for */
    double *Er;                 /* LU of I/(h lam0) - J^T */
    eomc_cplx *Ec, *vc;         /* LU of I/(h lam1) - J^T; a complex nx vector */
    int *pr, *pc;
    double *Jt;                 /* J^T (row-major), kept for refactoring at another h */
} radau_prec;

static int prec_factor(radau_prec *P, const radau_tab *k, double h)
{
    int nx = P->nx;
    double dr = 1.0 / (h * k->lam0);
    eomc_cplx dc = 1.0 / (h * k->lam1);
    for (size_t e = 0; e < (size_t)nx * nx; e++) {
        P->Er[e] = -P->Jt[e];
        P->Ec[e] = -P->Jt[e];
    }
    for (int i = 0; i < nx; i++) {
        P->Er[(size_t)i * nx + i] += dr;
        P->Ec[(size_t)i * nx + i] += dc;
    }
    P->hf = h;
    return lu_factor(nx, P->Er, P->pr) || lu_factor_c(nx, P->Ec, P->pc);
}

/* d = P^{-1} r (3 x nx blocks) */
static void prec_apply(const radau_prec *P, const radau_tab *k, const double *r, double *d)
{
    int nx = P->nx, i, a;
    double h = P->hf, *v0 = d;          /* v0 in d's first block until the end */
    eomc_cplx s0 = 1.0 / (h * k->lam0), s1 = 1.0 / (h * k->lam1);
    for (i = 0; i < nx; i++) {
        double r0 = r[i], r1 = r[nx + i], r2 = r[2 * nx + i];
        v0[i] = creal(s0) * (k->l0[0] * r0 + k->l0[1] * r1 + k->l0[2] * r2);
        P->vc[i] = s1 * (k->l1[0] * r0 + k->l1[1] * r1 + k->l1[2] * r2);
    }
    lu_solve_rows(nx, P->Er, P->pr, v0);
    lu_solve_c(nx, P->Ec, P->pc, P->vc);
    for (i = 0; i < nx; i++) {
        double v = v0[i];
        eomc_cplx c = P->vc[i];
        for (a = 2; a >= 0; a--)      /* block 0 last: it holds v0 */
            d[(size_t)a * nx + i] = k->w0[a] * v + 2.0 * (creal(k->w1[a]) * creal(c) - cimag(k->w1[a]) * cimag(c));
    }
}

/* The preconditioned solve's Jacobian is taken afresh (jac_x at the middle stage of the step
 * being solved) after a step that took more than PREC_REFRESH iterations, and at once when,
 * from PREC_SLOW iterations on, an update is not 10x smaller than the one before or
 * PREC_MAXIT pass; a step where a fresh one does not do is solved densely.  G1 (nx = 70,
 * 838 steps, benchmarks/bench_adjoint_adaptive.py, PREC_RTOL 1e-10): a fresh J after > 4
 * iterations, 3.9 iterations a step and 56 jac_x; after > 3, 3.3 and 282, as fast (a jac_x
 * costs about three vjp, a real + complex nx = 70 factorization about ten).  At PREC_RTOL
 * 1e-13, never refreshing took 6.9 iterations a step and 20 % more time than after > 4. */
#define PREC_SLOW 4
#define PREC_REFRESH 4
#define PREC_MAXIT 12
/* Refactor (same J) when the step differs from the factors' by more than this fraction. */
#define PREC_HTOL 0.2
/* The solve stops when the update is this small against mu (sup norms): far below what the
 * forward run's Newton leaves in the collocation equations (its tolerance), and on G1 the
 * gradient within 3e-11 of the dense solve's (1e-13: within 1e-13, 30 % more iterations). */
#define PREC_RTOL 1e-10

size_t eomc_adjoint_radau_work_size(int nx, int nparam)
{
    size_t n = (size_t)nx, N = 3 * n;
    return N * N + 3 * n * n + N + N + n + n + (size_t)(nparam > 0 ? nparam : 0) + N
           /* preconditioner: Jt, Er, Ec (2 nx^2), vc (2 nx), pr and pc (nx ints each), residual,
            * update and the stage adjoints (3 x 3 nx), the step's parameter sum */
           + 4 * n * n + 2 * n + 2 * n + 3 * N + (size_t)(nparam > 0 ? nparam : 0) + 16;
}

/* One step's transposed collocation system solved densely (3nx LU) with the stage Jacobians
 * in J (3 x nx x nx): mu. */
static int radau_dense_mu(int nx, const radau_tab *k, double h, const double *J, const double *lam,
                          double *Kt, int *piv, double *mu)
{
    int N = 3 * nx, a, b, i, j;
    /* K = I - h (A (x) I) blkdiag(J_b): block (a, b) = delta_ab I - h A_ab J_b; Kt its
     * transpose, row (b, j), column (a, i) */
    for (b = 0; b < 3; b++)
        for (j = 0; j < nx; j++) {
            double *row = Kt + ((size_t)b * nx + j) * N;
            const double *Jb = J + (size_t)b * nx * nx;
            for (a = 0; a < 3; a++)
                for (i = 0; i < nx; i++)
                    row[(size_t)a * nx + i] = (a == b && i == j ? 1.0 : 0.0) - h * k->A[a][b] * Jb[(size_t)i * nx + j];
        }
    memset(mu, 0, (size_t)N * sizeof(double));
    memcpy(mu + 2 * nx, lam, (size_t)nx * sizeof(double));     /* e_3 (x) lam */
    if (lu_factor(N, Kt, piv)) return EOMC_SINGULAR_MASS_MATRIX;
    lu_solve(N, Kt, piv, mu);
    return EOMC_OK;
}

/* g_b = J_b^T nu_b, nu_b = h sum_a A_ab mu_a, by vjp at the three stages (gs += the parameter
 * parts when gs is not NULL) */
static int radau_pull(eomc_vjp_fn vjp, const radau_tab *k, double t, double h, const double *Y,
                      const double *p, const double *r, const double *mu, double *nu, double *g,
                      double *gs, double *gpt, int nx, int np, double *mwork)
{
    int b, i, status;
    if (gs) for (i = 0; i < np; i++) gs[i] = 0.0;
    for (b = 0; b < 3; b++) {
        int any = 0;
        double *gb = g + (size_t)b * nx;
        for (i = 0; i < nx; i++) {
            nu[i] = h * (k->A[0][b] * mu[i] + k->A[1][b] * mu[nx + i] + k->A[2][b] * mu[2 * nx + i]);
            any |= nu[i] != 0.0;
        }
        if (!any) { memset(gb, 0, (size_t)nx * sizeof(double)); continue; }
        status = vjp(t + k->C[b] * h, Y + (size_t)b * nx, p, r, nu, NULL, gb, gs ? gpt : NULL, mwork);
        if (status != EOMC_OK) return status;
        if (gs) for (i = 0; i < np; i++) gs[i] += gpt[i];
    }
    return EOMC_OK;
}

static double sup_norm(const double *v, int n)
{
    double m = 0.0;
    for (int i = 0; i < n; i++) m = fmax(m, fabs(v[i]));
    return m;
}

int eomc_adjoint_radau_backward(const eomc_model *m, eomc_vjp_fn vjp, long nrec,
                                const double *rec_t, const double *rec_x, const double *rec_z,
                                const double *p, const double *r, const double *G, double *lam0,
                                double *gp, double *work, int dense, long *counts)
{
    radau_tab k;
    radau_prec P;
    int nx, np, N, i, a, status, have_J = 0, factored = 0;
    double rate = 0.1;                  /* the iteration's last contraction (update over update) */
    double *Kt, *J, *Y, *mu, *lam, *gx, *gpt, *res, *del, *g, *gs, *mwork;
    int *piv;
    long cnt[5] = {0, 0, 0, 0, 0};      /* jac_x calls, factorizations, iterations, dense steps, vjp calls */
    if (!m || !vjp || nrec < 0 || !rec_t || (nrec > 0 && (!rec_x || !rec_z)) || !G || !lam0 || !work)
        return EOMC_BAD_ARGUMENT;
    if (!m->jac_x) return EOMC_NOT_AVAILABLE;
    radau_tableau(&k);
    nx = m->nx;
    np = m->nparam;
    N = 3 * nx;
    Kt = work; J = Kt + (size_t)N * N; Y = J + (size_t)3 * nx * nx; mu = Y + N;
    lam = mu + N; gx = lam + nx; gpt = gx + nx;
    piv = (int *)(void *)(gpt + (np > 0 ? np : 0));     /* N ints in the N doubles that follow */
    P.nx = nx;
    P.Jt = (double *)(void *)piv + N;
    P.Er = P.Jt + (size_t)nx * nx;
    P.Ec = (eomc_cplx *)(void *)(P.Er + (size_t)nx * nx);
    P.vc = P.Ec + (size_t)nx * nx;
    P.pr = (int *)(void *)(P.vc + nx);
    P.pc = (int *)(void *)((double *)(void *)P.pr + nx);
    res = (double *)(void *)P.pc + nx;
    del = res + N;
    g = del + N;
    gs = g + N;
    mwork = work + eomc_adjoint_radau_work_size(nx, np);
    if (gp) for (i = 0; i < np; i++) gp[i] = 0.0;
    memcpy(lam, G + (size_t)nrec * nx, (size_t)nx * sizeof(double));
    for (long n = nrec - 1; n >= 0; n--) {
        const double *x = rec_x + (size_t)n * nx, *Z = rec_z + (size_t)n * N;
        double t = rec_t[n], h = rec_t[n + 1] - rec_t[n];
        int fresh = 0, solved = 0, it;
        for (a = 0; a < 3; a++) {
            double *ya = Y + (size_t)a * nx;
            for (i = 0; i < nx; i++) ya[i] = x[i] + Z[(size_t)a * nx + i];
        }
        /* The step x_{n+1} = x_n + Z_3, Z = h (A (x) I) F(x_n + Z): its adjoint solves
         * K^T mu = e_3 (x) lam, K = I - h (A (x) I) blkdiag(J_b), by preconditioned iteration:
         * the residual's J_b^T products are the vjp calls the step needs anyway (the last
         * iteration's are the step's), the preconditioner one Jacobian's K (prec_apply),
         * reused over steps while the iteration converges fast */
        while (!dense && !solved) {
            double dprev = INFINITY, dlast;
            if (!have_J) {
                double *Jm = J;                     /* scratch: one nx x nx Jacobian */
                status = m->jac_x(t + k.C[1] * h, Y + nx, p, r, Jm, mwork);
                if (status != EOMC_OK) return status;
                for (i = 0; i < nx; i++)
                    for (int j = 0; j < nx; j++) P.Jt[(size_t)j * nx + i] = Jm[(size_t)i * nx + j];
                cnt[0]++;
                have_J = fresh = 1;
                factored = 0;
            }
            if (!factored || fabs(h / P.hf - 1.0) > PREC_HTOL) {
                if (prec_factor(&P, &k, h)) break;      /* singular: the dense path */
                cnt[1]++;
                factored = 1;
            }
            memset(res, 0, (size_t)N * sizeof(double));
            memcpy(res + 2 * nx, lam, (size_t)nx * sizeof(double));
            prec_apply(&P, &k, res, mu);
            dlast = sup_norm(mu, N);
            for (it = 1; it <= PREC_MAXIT; it++) {
                double dn, tol = PREC_RTOL * fmax(sup_norm(mu, N), sup_norm(lam, nx));
                /* the parameter part only where this iteration is expected to be the last
                 * (the last update times the last contraction within tol) */
                int with_gp = gp && dlast * rate <= tol;
                status = radau_pull(vjp, &k, t, h, Y, p, r, mu, gx, g, with_gp ? gs : NULL, gpt, nx, np, mwork);
                if (status != EOMC_OK) return status;
                cnt[2]++;
                cnt[4] += 3;
                for (i = 0; i < N; i++) res[i] = g[i] - mu[i];
                for (i = 0; i < nx; i++) res[2 * nx + i] += lam[i];
                prec_apply(&P, &k, res, del);
                dn = sup_norm(del, N);
                if (dlast > 0.0) rate = fmin(dn / dlast, 1.0);
                if (dn <= tol) {
                    solved = 1;
                    if (gp && !with_gp) {       /* mispredicted: the same products with it */
                        status = radau_pull(vjp, &k, t, h, Y, p, r, mu, gx, g, gs, gpt, nx, np, mwork);
                        if (status != EOMC_OK) return status;
                        cnt[4] += 3;
                    }
                    break;
                }
                if (!isfinite(dn) || (it >= PREC_SLOW && dn > 0.1 * dprev)) break;
                for (i = 0; i < N; i++) mu[i] += del[i];
                dprev = dlast = dn;
            }
            if (solved) { if (it > PREC_REFRESH) have_J = 0; break; }
            if (fresh) break;                   /* a fresh Jacobian did not do: the dense path */
            have_J = 0;                         /* a stale one: take jac_x here and try again */
        }
        if (!solved) {                          /* the dense 3nx system with each stage's J */
            for (a = 0; a < 3; a++) {
                status = m->jac_x(t + k.C[a] * h, Y + (size_t)a * nx, p, r, J + (size_t)a * nx * nx, mwork);
                if (status != EOMC_OK) return status;
            }
            cnt[0] += 3;
            cnt[3]++;
            status = radau_dense_mu(nx, &k, h, J, lam, Kt, piv, mu);
            if (status != EOMC_OK) return status;
            status = radau_pull(vjp, &k, t, h, Y, p, r, mu, gx, g, gp ? gs : NULL, gpt, nx, np, mwork);
            if (status != EOMC_OK) return status;
            cnt[4] += 3;
            have_J = 0;                         /* J's scratch was overwritten */
        }
        for (i = 0; i < nx; i++) {
            lam[i] += G[(size_t)n * nx + i] + g[i] + g[nx + i] + g[2 * nx + i];
            if (!isfinite(lam[i])) return EOMC_NONFINITE;
        }
        if (gp) for (i = 0; i < np; i++) gp[i] += gs[i];
    }
    memcpy(lam0, lam, (size_t)nx * sizeof(double));
    if (counts) memcpy(counts, cnt, sizeof cnt);
    return EOMC_OK;
}
