/* eomc_adjoint.c -- discrete adjoint of fixed-step RK4 (see eomc_adjoint.h). */
#include <math.h>
#include <string.h>

#include "eomc_adjoint.h"

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
