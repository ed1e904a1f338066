/* A harness for BDF's Newton linear solve (eomc_bdf_linear_solve): test_bdf.py hands it a
 * Jacobian with a multibody state's structure and checks x against a dense solve; and for one
 * BDF step with Newton's LU kept from another c (bdf_one_step). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "eomc_bdf.h"

static int no_rhs(void *u, double t, const double *x, double *f)
{
    (void)u; (void)t; (void)x; (void)f;
    return EOMC_OK;
}

static int no_jac(void *u, double t, const double *x, double *J)
{
    (void)u; (void)t; (void)x; (void)J;
    return EOMC_OK;
}

static int not_aborted(void *u)
{
    (void)u;
    return 0;
}

/* r <- (I - c J)^-1 r with the state split after nsplit coordinates; the rows the LU held,
 * -1 if singular, -2 out of memory. */
int bdf_newton_solve(int n, int nsplit, const double *J, double c, double *r)
{
    eomc_stats st;
    eomc_bdf b;
    eomc_bdf_fns fns = {NULL, no_rhs, no_jac, not_aborted};
    double *work = malloc(eomc_bdf_work_size(n) * sizeof(double));
    int k;
    if (!work) return -2;
    memset(&st, 0, sizeof st);
    eomc_bdf_init(&b, &fns, &st, n, 1e-6, 1e-6, 1.0, 0, work);
    b.nsplit = nsplit;
    memcpy(b.J, J, (size_t)n * n * sizeof(double));
    k = eomc_bdf_linear_solve(&b, c, r);
    free(work);
    return k;
}

/* One BDF step on a nonlinear (q, v) system of three joints with stiff springs and cubic
 * couplings: q' = v, v_i' = -k q_i - d v_i - g sin q_i - s (q_i - q_{i+1})^3
 * + s (q_{i-1} - q_i)^3 (q_4 = 0; no q_0 term), to test the Newton LU kept across a change
 * of c = h / alpha (eomc_bdf.c: LU_BAND, the correction scaled by 2 / (1 + c / c_lu)). */
#define STEP_M 3
static const double STEP_K = 4e4, STEP_D = 40.0, STEP_G = 9.81, STEP_S = 2e5;

static int step_rhs(void *u, double t, const double *x, double *f)
{
    long *calls = u;
    (void)t;
    ++*calls;
    for (int i = 0; i < STEP_M; i++) {
        double q = x[i], dq = q - (i + 1 < STEP_M ? x[i + 1] : 0.0);
        double dp = i > 0 ? x[i - 1] - q : 0.0;
        f[i] = x[STEP_M + i];
        f[STEP_M + i] = -STEP_K * q - STEP_D * x[STEP_M + i] - STEP_G * sin(q)
                        - STEP_S * dq * dq * dq + STEP_S * dp * dp * dp;
    }
    return EOMC_OK;
}

static int step_zero_jac;   /* 1: step_jac returns J = 0 (Newton is then a plain fixed-point
                             * iteration, which diverges on a step too long for the springs) */

void bdf_step_zero_jacobian(int on) { step_zero_jac = on; }

static int step_jac(void *u, double t, const double *x, double *J)
{
    int n = 2 * STEP_M;
    (void)u; (void)t;
    memset(J, 0, (size_t)n * n * sizeof(double));
    if (step_zero_jac) return EOMC_OK;
    for (int i = 0; i < STEP_M; i++) {
        double *Ji = J + (size_t)(STEP_M + i) * n, q = x[i];
        double dq = q - (i + 1 < STEP_M ? x[i + 1] : 0.0), dp = i > 0 ? x[i - 1] - q : 0.0;
        J[(size_t)i * n + STEP_M + i] = 1.0;
        Ji[i] = -STEP_K - STEP_G * cos(q) - 3 * STEP_S * dq * dq - 3 * STEP_S * dp * dp;
        if (i + 1 < STEP_M) Ji[i + 1] = 3 * STEP_S * dq * dq;
        if (i > 0) Ji[i - 1] = 3 * STEP_S * dp * dp;
        Ji[STEP_M + i] = -STEP_D;
    }
    return EOMC_OK;
}

/* Start at y0 (J there) with step h and take one trial step.  c_pre > 0: Newton's LU is
 * factored first for c_pre (as if the last step had another h or order), so the trial keeps
 * it when h / alpha_1 is within LU_BAND of c_pre.  Out: the trial's y (n = 6) and end time,
 * counts[0..2] = LUs factored (the pre-factor included), rhs calls in the trial, rejected
 * tries.  Returns the trial's status. */
int bdf_one_step(const double *y0, double h, double rtol, double c_pre, double *ynew, double *tn,
                 long *counts)
{
    int n = 2 * STEP_M, s;
    long calls = 0;
    eomc_stats st;
    eomc_bdf b;
    eomc_bdf_fns fns = {&calls, step_rhs, step_jac, not_aborted};
    double *work = malloc(eomc_bdf_work_size(n) * sizeof(double)), f0[2 * STEP_M], r[2 * STEP_M];
    if (!work) return -2;
    memset(&st, 0, sizeof st);
    eomc_bdf_init(&b, &fns, &st, n, rtol, rtol, 1.0, 0, work);
    b.nsplit = STEP_M;
    step_rhs(&calls, 0.0, y0, f0);
    if ((s = eomc_bdf_start(&b, 0.0, y0, f0, h))) { free(work); return s; }
    if (c_pre > 0.0) {
        memset(r, 0, sizeof r);
        eomc_bdf_linear_solve(&b, c_pre, r);
    }
    calls = 0;
    s = eomc_bdf_trial(&b, 1.0);
    memcpy(ynew, b.ynew, (size_t)n * sizeof(double));
    *tn = b.tn;
    counts[0] = st.nlu; counts[1] = calls; counts[2] = st.rejected;
    free(work);
    return s;
}
