/*
 * eomc_bdf.c -- variable-order (1..5), variable-step BDF/NDF integrator (EOMC_BDF).
 *
 * Why a second implicit method: at the tolerances users of contact simulation pick
 * (rtol 1e-2 .. 1e-6) a low-order multistep method needs far fewer model calls per unit
 * time than Radau IIA(5): one step costs one or two rhs calls (Newton from a good
 * predictor, with an LU and a Jacobian kept over many steps) against Radau's three stages
 * per Newton iteration.  LSODA and MATLAB's ode15s win there for that reason
 * (benchmarks/results/contact_wp.md).
 *
 * The method is Shampine & Reichelt's numerical differentiation formulas (NDF, "The
 * MATLAB ODE suite", SIAM J. Sci. Comput. 18, 1997) in the quasi-constant step size form
 * with the modified divided differences of the solution (Shampine, "Numerical solution of
 * ordinary differential equations", 1994), as scipy.integrate.BDF also implements it:
 * backward differences D[j] of the interpolating polynomial on an equally spaced grid,
 * re-interpolated onto a new grid when the step changes (change_D); order and step change
 * only after order + 1 steps of one size, unless a step fails.  Newton uses the model's
 * analytic Jacobian: J is evaluated again only when Newton fails to converge with an older
 * one or with a fresh one taken at the wrong place, at the iterate Newton stopped at
 * (RELINEARISE below), and the LU of I - c J is kept while c = h / alpha_k stays within 30 % of the c it
 * was factored for (as CVODE does), the correction scaled by 2 / (1 + c / c_lu) meanwhile.
 * Our own code; the constants are the published ones.
 */
#include "eomc_bdf.h"
#include "eomc_dense_lu.h"

#include <float.h>
#include <math.h>
#include <string.h>

/* Newton's iteration budget per attempt.  scipy's BDF allows 4; we allow 8, because on a
 * contact model a failed attempt costs far more than a few more iterations: it throws the
 * step away, evaluates a fresh Jacobian (gymnasium's ant: 31 us, 22 rhs calls) when the old
 * one was in use, and factors a new LU for the shorter step.  On the ant after touch-down
 * (friction regularised at v_s = 0.01 m/s, so J changes fast with the slip) most failures
 * were slow contraction, not divergence: with 8, rhs + Jacobian + LU work on the ant fell
 * 13-35 % at rtol 1e-2 .. 1e-8 (Jacobians 71 -> 42 at 1e-2, 90 -> 32 at 1e-7), Solo12
 * standing 0-17 %, the hopper within +-10 % (benchmarks/results/contact_wp.md).  A diverging
 * iteration (rate >= 1) or one predicted not to converge within the budget still stops at
 * once. */
#define NEWTON_MAXIT 8
/* The step-size safety factor's iteration count (scipy's form, 0.9 (2m + 1) / (2m + nit)),
 * kept at scipy's m = 4: a step that needed many iterations is followed by a smaller one. */
#define SAFETY_IT 4
/* Newton's stopping tolerance, in the error test's scaled norm: 3 % of the local error
 * allowed.  scipy's BDF takes min(0.03, sqrt(rtol)), which at the rtol BDF holds here (a
 * tenth of the one asked, BDF_TOL_SHARE in eomc_integrators.c) is 1e-4 .. 1e-2 for rtol
 * 1e-7 .. 1e-3 asked: Newton then iterated 3 times a step where the error test would have
 * accepted the second iterate (ant at rtol 1e-7: 2195 rhs calls over 734 steps).  LSODA's
 * and CVODE's tests are likewise a fixed fraction of the local tolerance (0.1 or more).
 * Measured (benchmarks/results/contact_wp.md, s8 notes): rhs calls ant 1e-6 / 1e-7 1611 /
 * 2195 -> 1247 / 1707, Solo12 1e-3 .. 1e-7 -10 .. -32 %, hopper 1e-3 .. 1e-7 -9 .. -18 %;
 * errors moved both ways (the ant's at 1e-3 / 1e-4 up 3-4x, Solo12's at 1e-6 / 1e-7 down
 * 7-60x).  0.1 was tried and dropped (Solo12 at 3e-2: 318 -> 3480 rhs calls). */
#define NEWTON_TOL 0.03
#define MIN_FACTOR 0.2
#define MAX_FACTOR 10.0
#define LU_BAND 0.3          /* refactor when |c / c_lu - 1| exceeds this (CVODE's dgmax) */
#define KEEP_BAND 1.2        /* a suggested growth below this keeps h (and the LU) */
/* The step after Newton failed with a Jacobian from this step: 0.3 of the failed one (CVODE's
 * and DLSODE's cut after a convergence failure is 0.25; this code halved).  On the contact
 * models a failure with a fresh J is a step too long for the contact's nonlinearity, and a half
 * step mostly failed again, each retry a Jacobian and an LU.  Measured (benchmarks/results/
 * contact_wp.md, s17 notes; medians over 8 starts, rtol 1e-1 .. 1e-7): Jacobians ant 75 / 61 / 54
 * / 44 / 42 / 34 -> 61 / 56 / 46 / 33 / 33 / 28 (rtol 1e-1, 3e-2, 1e-2 .. 1e-5), Solo12 113 / 84 /
 * 52 -> 84 / 61 / 45 (1e-1 .. 1e-2), hopper 22 -> 18-20 from 1e-2; rhs calls 0-23 % fewer on
 * most rows.  0.25 and 0.2 were no better; 0.7 was worse everywhere. */
#define NEWTON_CUT 0.3
#define DEFAULT_MAX_STEPS 100000L
#define NROWS (EOMC_BDF_MAX_ORDER + 3)
/* RELINEARISE.  A Newton failure with a fresh Jacobian on a contact model is mostly a
 * Jacobian taken at the wrong place: Solo12's stance puts the feet at depth ~1e-17 m, where
 * the Hunt-Crossley slope (~ depth^0.5) is ~0, so J misses the contact stiffness; on the
 * ant, J from before a touch-down or before the slip turns.  Halving the step does not help
 * while J stays where it was (the ant at rtol 1e-2: runs of 4-5 halvings, 93 of 213 LUs;
 * Solo12 at 1e-1: 476 failures in 886 trials).  So after such a failure the step is retried
 * once with J re-evaluated at Newton's last iterate (where the contact has engaged), and
 * if that fails too, the shorter step (NEWTON_CUT) starts from a J at its own predictor.  Measured
 * (benchmarks/results/contact_wp.md, s7 notes): Solo12 at 1e-1 2228 -> 61 rhs calls; the
 * ant at 1e-2 728 -> 507, 213 -> 99 LUs.
 * The same holds after a failure with an older J (session 14): J is taken at Newton's last
 * iterate, not at the predictor, and a failure with that J cuts the step at once.  The ant
 * at rtol 1e-1 in the sliding phase failed with the old J, then with a J at the predictor,
 * and converged only with the J re-linearised at the iterate: three Jacobians a step.  And
 * Newton goes on from the iterate it stopped at, instead of from the predictor again: the
 * corrections it made stay made (ynew = ypred + d, the same equation).  Measured
 * (benchmarks/results/contact_wp.md, s14 notes): the ant's Jacobians at rtol 1e-1 / 3e-2 /
 * 1e-2 100 / 72 / 72 -> 75 / 62 / 54, rhs calls 590 / 590 / 678 -> 492 / 480 / 637. */

/* Shampine & Reichelt's NDF coefficients kappa_k (kappa = 0 gives the classical BDFs;
 * order 5 keeps the BDF for stability); gamma_k = sum_{j<=k} 1/j, alpha_k = (1 - kappa_k)
 * gamma_k, and the error constants kappa_k gamma_k + 1/(k + 1). */
static const double KAPPA[EOMC_BDF_MAX_ORDER + 1] = {0, -0.1850, -1.0 / 9, -0.0823, -0.0415, 0};

static double gamma_k(int k)
{
    double g = 0.0;
    for (int j = 1; j <= k; j++) g += 1.0 / j;
    return g;
}

static double alpha_k(int k) { return (1.0 - KAPPA[k]) * gamma_k(k); }

static double error_const(int k) { return KAPPA[k] * gamma_k(k) + 1.0 / (k + 1); }

size_t eomc_bdf_work_size(int n)
{
    size_t nn = (size_t)n * n;
    return 2 * NROWS * (size_t)n + 4 * nn + 13 * (size_t)n + 16;
}

void eomc_bdf_init(eomc_bdf *b, const eomc_bdf_fns *fns, eomc_stats *st, int n, double rtol,
                   double atol, double hmax, long max_steps, double *work)
{
    size_t nn = (size_t)n * n;
    memset(b, 0, sizeof *b);
    b->fns = fns; b->st = st; b->n = n;
    b->rtol = rtol; b->atol = atol; b->hmax = hmax;
    b->max_steps = max_steps > 0 ? max_steps : DEFAULT_MAX_STEPS;
    /* Newton stops when its predicted remaining change is below NEWTON_TOL (scaled like
     * the error test); the floor keeps it above rounding at very tight rtol */
    b->newton_tol = fmax(10 * DBL_EPSILON / rtol, NEWTON_TOL);
    b->D = work; work += NROWS * (size_t)n;
    b->Dn = work; work += NROWS * (size_t)n;
    b->J = work; work += nn;
    b->LU = work; work += nn;
    b->ypred = work; work += n;
    b->psi = work; work += n;
    b->ynew = work; work += n;
    b->d = work; work += n;
    b->f = work; work += n;
    b->scale = work; work += n;
    b->dy = work; work += n;
    b->rk = work; work += n;
    b->piv = (int *)work;     /* n ints fit in n doubles */
    work += n;
    b->keep = (int *)work; work += n;
    b->elim = (int *)work; work += n;
    b->dep = (int *)work; work += n;
    b->zcnt = (int *)work; work += n;
    b->Z = work; work += nn;
    b->znz = (int *)work;     /* nn ints */
}

/* Smallest step that still advances t in floating point. */
static double min_step(double t)
{
    return 10.0 * fabs(nextafter(t, INFINITY) - t);
}

static double rms_scaled(int n, const double *v, const double *scale)
{
    double s = 0.0;
    for (int i = 0; i < n; i++) {
        double e = v[i] / scale[i];
        s += e * e;
    }
    return n > 0 ? sqrt(s / n) : 0.0;
}

/* The differences D[0..k] re-expressed on a grid of spacing factor * h (Shampine 1994):
 * D <- (R U)^T D with R = R(k, factor), U = R(k, 1), R_ij = prod_{m<=i} (m - 1 - factor j) / m. */
static void compute_R(int k, double factor, double R[NROWS][NROWS])
{
    for (int j = 0; j <= k; j++) R[0][j] = 1.0;
    for (int i = 1; i <= k; i++) {
        R[i][0] = 0.0;
        for (int j = 1; j <= k; j++) R[i][j] = R[i - 1][j] * (i - 1 - factor * j) / i;
    }
}

static void change_D(double *D, int n, int k, double factor)
{
    double R[NROWS][NROWS], U[NROWS][NROWS], RU[NROWS][NROWS], col[NROWS];
    if (factor == 1.0) return;
    compute_R(k, factor, R);
    compute_R(k, 1.0, U);
    for (int i = 0; i <= k; i++)
        for (int j = 0; j <= k; j++) {
            double s = 0.0;
            for (int m = 0; m <= k; m++) s += R[i][m] * U[m][j];
            RU[i][j] = s;
        }
    for (int x = 0; x < n; x++) {
        for (int i = 0; i <= k; i++) col[i] = D[(size_t)i * n + x];
        for (int i = 0; i <= k; i++) {
            double s = 0.0;
            for (int j = 0; j <= k; j++) s += RU[j][i] * col[j];
            D[(size_t)i * n + x] = s;
        }
    }
}

/* A new step size h * factor for the current order: the differences follow. */
static void rescale(eomc_bdf *b, double factor)
{
    change_D(b->D, b->n, b->order, factor);
    b->h *= factor;
    b->n_equal = 0;
}

int eomc_bdf_start(eomc_bdf *b, double t, const double *y, const double *f, double h)
{
    int n = b->n, s;
    memset(b->D, 0, NROWS * (size_t)n * sizeof(double));
    memcpy(b->D, y, (size_t)n * sizeof(double));
    for (int i = 0; i < n; i++) b->D[n + i] = h * f[i];
    b->t = t; b->h = h; b->order = 1; b->n_equal = 0; b->err_fails = 0;
    b->c_lu = 0.0;
    if ((s = b->fns->jac(b->fns->ctx, t, y, b->J))) return s;
    b->cur_jac = 1;
    b->jac_failed = 0;
    return EOMC_OK;
}

/* Newton's linear system (I - c J) x = r with the rows of the coordinates q (x = (q, v, ...),
 * nsplit q's) eliminated first.  A q's rate is a function of the speeds and of a few q's only:
 * a hinge's or slide's dq_i/dt = v_i, a free joint's position rates turn with the body's
 * angles, its angle rates depend on the angles.  Call D the q's some q rate depends on (the
 * ant's and Solo12's three base angles; none on a planar hopper).  With e the eliminated rows
 * and k the kept ones (the speeds and anything after them),
 *     x_e = w + c Z x_k,   w = (I - c J_ee)^-1 r_e,   Z = (I - c J_ee)^-1 J_ek,
 *     (I - c J_kk - c^2 J_ke Z) x_k = r_k + c J_ke w,
 * and I - c J_ee is cheap to invert: its only off-diagonal columns are D's, so D's rows are a
 * |D| x |D| system (LUd) and every other eliminated row follows from them.  The same linear
 * system; only the kept rows' Schur complement goes through the dense LU.  Gymnasium's ant
 * (n = 28): 14 rows kept (20 when only the q_i' = v_i rows went, 28 before that); Solo12 18 of
 * 36 (24); the hopper 6 of 12 (unchanged, bit for bit).  With more than EOMC_BDF_MAX_DEP such
 * q's, or I - c J_dd singular, D's rows stay in the LU (then J_ee = 0 and Z = J_ek). */

/* The split for the current J: b->elim / b->keep (in order), b->dep (D, as indices into elim),
 * b->znz's pattern comes with Z (factor_lu).  with_dep = 0 keeps D's rows in the LU. */
static int split_rows(eomc_bdf *b, int with_dep)
{
    int n = b->n, m = b->nsplit, nk = 0, ne = 0, nd = 0, *isdep = b->zcnt;
    for (int j = 0; j < m; j++) isdep[j] = 0;
    for (int i = 0; i < m; i++) {
        const double *Ji = b->J + (size_t)i * n;
        for (int j = 0; j < m; j++)
            if (Ji[j] != 0.0) isdep[j] = 1;
    }
    if (with_dep) {
        for (int j = 0; j < m; j++) nd += isdep[j];
        if (nd > EOMC_BDF_MAX_DEP) with_dep = 0;
    }
    nd = 0;
    for (int i = 0; i < n; i++) {
        if (i < m && (with_dep || !isdep[i])) {
            if (isdep[i]) b->dep[nd++] = ne;
            b->elim[ne++] = i;
        } else {
            b->keep[nk++] = i;
        }
    }
    b->nelim = ne; b->ndep = nd;
    return nk;
}

/* Z = (I - c J_ee)^-1 J_ek with its nonzero pattern per row; 1 if I - c J_dd is singular. */
static int eliminate(eomc_bdf *b, double c)
{
    int n = b->n, nk = b->nkeep, ne = b->nelim, nd = b->ndep;
    const double *J = b->J;
    for (int a = 0; a < ne; a++) {
        const double *Ja = J + (size_t)b->elim[a] * n;
        for (int l = 0; l < nk; l++) b->Z[(size_t)a * nk + l] = Ja[b->keep[l]];
    }
    if (nd > 0) {
        double t[EOMC_BDF_MAX_DEP];
        for (int e = 0; e < nd; e++) {
            const double *Je = J + (size_t)b->elim[b->dep[e]] * n;
            for (int f = 0; f < nd; f++)
                b->LUd[e * nd + f] = (e == f ? 1.0 : 0.0) - c * Je[b->elim[b->dep[f]]];
        }
        if (lu_factor(nd, b->LUd, b->pivd)) return 1;
        for (int l = 0; l < nk; l++) {      /* D's rows: (I - c J_dd)^-1 J_dk */
            for (int e = 0; e < nd; e++) t[e] = b->Z[(size_t)b->dep[e] * nk + l];
            lu_solve_rows(nd, b->LUd, b->pivd, t);
            for (int e = 0; e < nd; e++) b->Z[(size_t)b->dep[e] * nk + l] = t[e];
        }
        for (int a = 0, e = 0; a < ne; a++) {   /* the others: J_ak + c J_ad Z_d */
            const double *Ja = J + (size_t)b->elim[a] * n;
            if (e < nd && b->dep[e] == a) { e++; continue; }
            for (int f = 0; f < nd; f++) {
                double s = c * Ja[b->elim[b->dep[f]]];
                const double *Zd = b->Z + (size_t)b->dep[f] * nk;
                if (s != 0.0)
                    for (int l = 0; l < nk; l++) b->Z[(size_t)a * nk + l] += s * Zd[l];
            }
        }
    }
    for (int a = 0; a < ne; a++) {
        const double *Za = b->Z + (size_t)a * nk;
        int *nz = b->znz + (size_t)a * nk, cnt = 0;
        for (int l = 0; l < nk; l++)
            if (Za[l] != 0.0) nz[cnt++] = l;
        b->zcnt[a] = cnt;
    }
    return 0;
}

/* The LU for Newton's matrix I - c J: of the kept rows' Schur complement
 * I - c J_kk - c^2 J_ke Z when the state splits (above), else of the whole. */
static int factor_lu(eomc_bdf *b, double c)
{
    int n = b->n, nk;
    b->st->nlu++;
    b->c_lu = 0.0;
    nk = b->nkeep = n;
    b->nelim = 0;
    if (b->nsplit > 0) {
        nk = b->nkeep = split_rows(b, 1);
        if (b->nelim > 0 && eliminate(b, c)) {
            nk = b->nkeep = split_rows(b, 0);
            if (eliminate(b, c)) return 1;      /* not reached: no D rows left */
        }
    }
    if (nk < n) {
        for (int a = 0; a < nk; a++) {
            const double *Jk = b->J + (size_t)b->keep[a] * n;
            double *Ma = b->LU + (size_t)a * nk;
            for (int e = 0; e < nk; e++) Ma[e] = (a == e ? 1.0 : 0.0) - c * Jk[b->keep[e]];
            for (int i = 0; i < b->nelim; i++) {
                double s = c * c * Jk[b->elim[i]];
                const double *Zi = b->Z + (size_t)i * nk;
                const int *nz = b->znz + (size_t)i * nk;
                if (s != 0.0)
                    for (int q = 0; q < b->zcnt[i]; q++) Ma[nz[q]] -= s * Zi[nz[q]];
            }
        }
    } else {
        for (int i = 0; i < n; i++)
            for (int j = 0; j < n; j++)
                b->LU[(size_t)i * n + j] = (i == j ? 1.0 : 0.0) - c * b->J[(size_t)i * n + j];
    }
    if (lu_factor(nk, b->LU, b->piv)) return 1;
    b->c_lu = c;
    return 0;
}

/* Solve (I - c_lu J) x = r in place with factor_lu's factors. */
static void solve_lu(eomc_bdf *b, double *r)
{
    int n = b->n, nk = b->nkeep, ne = b->nelim, nd = b->ndep;
    double c = b->c_lu, *y = b->rk, *w = b->rk + nk;
    if (nk == n) {
        lu_solve_rows(n, b->LU, b->piv, r);
        return;
    }
    for (int a = 0; a < ne; a++) w[a] = r[b->elim[a]];
    if (nd > 0) {      /* w = (I - c J_ee)^-1 r_e: D's rows, then the others from them */
        double t[EOMC_BDF_MAX_DEP];
        for (int e = 0; e < nd; e++) t[e] = w[b->dep[e]];
        lu_solve_rows(nd, b->LUd, b->pivd, t);
        for (int e = 0; e < nd; e++) w[b->dep[e]] = t[e];
        for (int a = 0, e = 0; a < ne; a++) {
            const double *Ja = b->J + (size_t)b->elim[a] * n;
            double s = 0.0;
            if (e < nd && b->dep[e] == a) { e++; continue; }
            for (int f = 0; f < nd; f++) s += Ja[b->elim[b->dep[f]]] * t[f];
            w[a] += c * s;
        }
    }
    for (int a = 0; a < nk; a++) {    /* r_k + c J_ke w */
        const double *Jk = b->J + (size_t)b->keep[a] * n;
        double s = 0.0;
        for (int i = 0; i < ne; i++) s += Jk[b->elim[i]] * w[i];
        y[a] = r[b->keep[a]] + c * s;
    }
    lu_solve_rows(nk, b->LU, b->piv, y);
    for (int a = 0; a < nk; a++) r[b->keep[a]] = y[a];
    for (int i = 0; i < ne; i++) {    /* x_e = w + c Z x_k */
        const double *Zi = b->Z + (size_t)i * nk;
        const int *nz = b->znz + (size_t)i * nk;
        double s = 0.0;
        for (int q = 0; q < b->zcnt[i]; q++) s += Zi[nz[q]] * y[nz[q]];
        r[b->elim[i]] = w[i] + c * s;
    }
}

/* Simplified Newton for y = ypred + d with d - c f(tn, y) + psi = 0 (scipy's
 * solve_bdf_system), from the predictor (d = 0) or, from_last, from the last attempt's
 * iterate: stops when the contraction rate predicts the remaining change is
 * below newton_tol, fails when it diverges or would not get there in NEWTON_MAXIT
 * iterations.  A model failure or non-finite value is a failure to converge (*bad: that
 * status) unless the run was aborted. */
static int newton(eomc_bdf *b, double tn, double c, int from_last, int *conv, int *nit, int *bad)
{
    int n = b->n, s;
    double dn_old = 0.0, rate = 0.0, tol = b->newton_tol;
    double corr = c == b->c_lu ? 1.0 : 2.0 / (1.0 + c / b->c_lu);
    *conv = 0; *nit = 0;
    if (!from_last) {     /* else on from the last attempt's iterate, ynew = ypred + d */
        memcpy(b->ynew, b->ypred, (size_t)n * sizeof(double));
        memset(b->d, 0, (size_t)n * sizeof(double));
    }
    for (int k = 0; k < NEWTON_MAXIT; k++) {
        double dn;
        s = b->fns->rhs(b->fns->ctx, tn, b->ynew, b->f);
        ++*nit;
        if (s) {
            if (b->fns->aborted(b->fns->ctx)) return s;
            *bad = s;
            return EOMC_OK;
        }
        for (int i = 0; i < n; i++) b->dy[i] = c * b->f[i] - b->psi[i] - b->d[i];
        solve_lu(b, b->dy);
        if (corr != 1.0)
            for (int i = 0; i < n; i++) b->dy[i] *= corr;
        dn = rms_scaled(n, b->dy, b->scale);
        if (!isfinite(dn)) return EOMC_OK;
        if (k > 0) {
            rate = dn / dn_old;
            if (rate >= 1.0 || pow(rate, NEWTON_MAXIT - k) / (1.0 - rate) * dn > tol) return EOMC_OK;
        }
        for (int i = 0; i < n; i++) { b->ynew[i] += b->dy[i]; b->d[i] += b->dy[i]; }
        if (dn == 0.0 || (k > 0 && rate / (1.0 - rate) * dn < tol)) {
            *conv = 1;
            return EOMC_OK;
        }
        dn_old = dn;
    }
    return EOMC_OK;
}

int eomc_bdf_trial(eomc_bdf *b, double t1)
{
    int n = b->n, s, first = 1, refresh = 0, relin = 0;
    double t = b->t;
    eomc_stats *st = b->st;
    if (b->h > b->hmax) rescale(b, b->hmax / b->h);
    for (;;) {
        int k = b->order, conv = 0, nit = 0, mbad = 0, from_last = 0;
        double hmin = min_step(t), tn, c, a = alpha_k(k), err, safety, g[EOMC_BDF_MAX_ORDER + 1];
        st->t = t; st->h = b->h;
        if (b->h < hmin) return b->bad ? b->bad : EOMC_STEP_TOO_SMALL;
        if (st->steps >= b->max_steps) return EOMC_MAX_STEPS;
        if ((s = b->fns->aborted(b->fns->ctx))) return s;
        tn = t + b->h;
        if (tn > t1 || t1 - tn < hmin) {
            tn = t1;
            rescale(b, (t1 - t) / b->h);
        }
        st->steps++;
        for (int j = 1; j <= k; j++) g[j] = gamma_k(j);
        for (int i = 0; i < n; i++) {
            double yp = 0.0, ps = 0.0;
            for (int j = k; j >= 0; j--) yp += b->D[(size_t)j * n + i];
            for (int j = k; j >= 1; j--) ps += g[j] * b->D[(size_t)j * n + i];
            b->ypred[i] = yp;
            b->psi[i] = ps / a;
            b->scale[i] = b->atol + b->rtol * fabs(yp);
        }
        if (refresh) {    /* the last attempt failed with a fresh J: one at this predictor */
            refresh = 0;
            b->c_lu = 0.0;
            if ((s = b->fns->jac(b->fns->ctx, tn, b->ypred, b->J))) {
                if (b->fns->aborted(b->fns->ctx)) return s;
                b->bad = s;
                b->cur_jac = 0;     /* J is not one: Newton's failure evaluates it again */
                b->jac_failed = 1;
            } else {
                b->jac_failed = 0;
            }
        }
        c = b->h / a;
        for (;;) {     /* Newton; again with J from where it stopped (RELINEARISE above) */
            int ok;
            if (!(b->c_lu > 0.0) || fabs(c / b->c_lu - 1.0) > LU_BAND) {
                if (factor_lu(b, c)) { conv = 0; break; }
            }
            mbad = 0;
            if ((s = newton(b, tn, c, from_last, &conv, &nit, &mbad))) return s;
            from_last = 0;
            if (mbad) b->bad = mbad;
            if (conv) break;
            /* a J from Newton's iterate failed too: the step is cut (once per step size
             * since the last Newton failure) */
            if (b->cur_jac && relin) break;
            ok = !mbad;
            for (int i = 0; ok && i < n; i++) ok = isfinite(b->ynew[i]);
            if (b->cur_jac && !ok) break;
            b->c_lu = 0.0;      /* J changes: so does the split LU's A (solve_lu) */
            if ((s = b->fns->jac(b->fns->ctx, tn, ok ? b->ynew : b->ypred, b->J))) {
                if (b->fns->aborted(b->fns->ctx)) return s;
                b->bad = s;
                b->cur_jac = 0;     /* J is not one: Newton's next failure evaluates it again */
                b->jac_failed = 1;
                break;
            }
            b->cur_jac = 1;
            b->jac_failed = 0;
            relin = from_last = ok;
        }
        if (!conv) {
            st->rejected++;
            first = 0;
            /* a J that failed (its array partly written) may also have failed the LU before
             * Newton could ask for another: one at the next predictor, or every later step
             * size would fail alike (a sphere dropped on a plane, quaternion build, BDF:
             * 29 cuts to h = 3e-16 after a J at a predictor deep in the plane failed) */
            refresh = b->cur_jac || b->jac_failed;
            relin = 0;
            rescale(b, NEWTON_CUT);
            continue;
        }
        if (first) b->bad = 0;    /* a step that passed at once: no failure being closed in on */
        safety = 0.9 * (2 * SAFETY_IT + 1) / (2 * SAFETY_IT + nit);
        for (int i = 0; i < n; i++) {
            b->scale[i] = b->atol + b->rtol * fabs(b->ynew[i]);
            b->dy[i] = error_const(k) * b->d[i];
        }
        err = rms_scaled(n, b->dy, b->scale);
        if (!(err <= 1.0)) {
            double factor = isfinite(err) ? fmax(MIN_FACTOR, safety * pow(err, -1.0 / (k + 1)))
                                          : MIN_FACTOR;
            st->rejected++;
            first = 0;
            if (++b->err_fails >= 3 && k > 1) {   /* the history misleads: back to order 1 */
                b->order = 1;
                factor = fmin(factor, 0.5);
            }
            rescale(b, factor);
            continue;
        }
        {   /* the differences of the new interpolating polynomial (through ynew) */
            double *D = b->D, *Dn = b->Dn;
            for (int i = 0; i < n; i++) {
                Dn[(size_t)(k + 2) * n + i] = b->d[i] - D[(size_t)(k + 1) * n + i];
                Dn[(size_t)(k + 1) * n + i] = b->d[i];
            }
            for (int j = k; j >= 0; j--)
                for (int i = 0; i < n; i++)
                    Dn[(size_t)j * n + i] = D[(size_t)j * n + i] + Dn[(size_t)(j + 1) * n + i];
            for (int j = k + 3; j < NROWS; j++)
                memcpy(Dn + (size_t)j * n, D + (size_t)j * n, (size_t)n * sizeof(double));
        }
        b->tn = tn; b->ht = b->h; b->trial_order = k;
        b->trial_err = err; b->trial_safety = safety;
        return EOMC_OK;
    }
}

void eomc_bdf_dense(const eomc_bdf *b, double tau, double *out)
{
    int n = b->n, k = b->trial_order;
    double p = 1.0;
    memcpy(out, b->Dn, (size_t)n * sizeof(double));
    for (int j = 1; j <= k; j++) {
        const double *Dj = b->Dn + (size_t)j * n;
        p *= (tau - (b->tn - (j - 1) * b->ht)) / (j * b->ht);
        for (int i = 0; i < n; i++) out[i] += p * Dj[i];
    }
}

void eomc_bdf_commit(eomc_bdf *b)
{
    int n = b->n, k = b->trial_order, best = 1;
    double *tmp = b->D, fac[3], factor;
    b->D = b->Dn; b->Dn = tmp;
    b->t = b->tn;
    b->cur_jac = 0;
    b->err_fails = 0;
    if (++b->n_equal < k + 1) return;
    /* scipy's order selection: the step each neighbouring order would allow, from the
     * error estimates of orders k - 1 and k + 1 (differences k and k + 2) */
    for (int i = 0; i < n; i++) b->dy[i] = error_const(k - 1 > 0 ? k - 1 : 1) * b->D[(size_t)k * n + i];
    fac[0] = k > 1 ? pow(rms_scaled(n, b->dy, b->scale), -1.0 / k) : 0.0;
    fac[1] = pow(fmax(b->trial_err, 1e-300), -1.0 / (k + 1));
    if (k < EOMC_BDF_MAX_ORDER) {
        for (int i = 0; i < n; i++) b->dy[i] = error_const(k + 1) * b->D[(size_t)(k + 2) * n + i];
        fac[2] = pow(rms_scaled(n, b->dy, b->scale), -1.0 / (k + 2));
    } else {
        fac[2] = 0.0;
    }
    for (int j = 0; j < 3; j++)        /* a zero estimate allows any step; NaN none */
        if (!(fac[j] <= DBL_MAX)) fac[j] = isnan(fac[j]) ? 0.0 : DBL_MAX;
    if (fac[0] > fac[best]) best = 0;
    if (fac[2] > fac[best]) best = 2;
    factor = fmin(MAX_FACTOR, b->trial_safety * fac[best]);
    b->order = k + best - 1;
    if (best == 1 && factor >= 1.0 && factor <= KEEP_BAND) {   /* not worth a new LU */
        b->n_equal = 0;
        return;
    }
    rescale(b, factor);
}

void eomc_bdf_set_state(eomc_bdf *b, const double *y)
{
    memcpy(b->D, y, (size_t)b->n * sizeof(double));
}

int eomc_bdf_linear_solve(eomc_bdf *b, double c, double *r)
{
    if (factor_lu(b, c)) return -1;
    solve_lu(b, r);
    return b->nkeep;
}
