/*
 * eomc_fixedstep.c -- a fixed-step implicit integrator for real-time and learning use
 * (EOMC_IMPLICITFAST).
 *
 * Why: a robot on compliant ground is stiff (contact stiffness, friction regularised
 * over a small slip speed, joint damping and limits).  Explicit methods need steps far
 * below the 1-5 ms a controller or a learning loop runs at, and the adaptive implicit
 * methods cost a variable, unbounded amount per simulated second.  MuJoCo answers this
 * with "implicitfast": a fixed step, velocities advanced through (M - h D)^-1 with D
 * the derivative of the smooth forces in the velocities (Coriolis terms skipped),
 * positions then integrated with the new velocities.  eomc's contacts and limits are
 * forces in the rhs, stiff in the positions as well as in the velocities, and the model
 * has its analytic Jacobian jac_x, so the step here is implicit Euler in the whole
 * state, solved the cheap way:
 *
 *   (I - h W) dx = h f(t, x),   x_new = x + dx                              (1)
 *
 * a linearly implicit Euler (Rosenbrock-Euler / W-method) step: one rhs call and one
 * solve with a kept LU.  W = jac_x at some earlier state: any W gives a first-order
 * method; W close to the current jac_x gives implicit Euler's stability (L-stable: a
 * stiff contact or damper is damped, never amplified).  Whether W is still good enough
 * is measured, not guessed: after the step, the residual of the implicit Euler
 * equation
 *
 *   r = dx - h f(t + h, x_new) = h (f(t, x) + W dx - f(t + h, x_new))
 *
 * costs one rhs call that the next step needs anyway.  While |r| stays a fraction of the
 * step's implicit part |dx - h f| (scaled norms, RESID_FRACTION; see fs_trial) the step
 * is implicit Euler to that fraction and W and its LU are kept, for many steps in free
 * flight or a steady stance.  When a
 * foot touches down or lifts off, a limit engages, or the configuration has moved far,
 * |r| jumps: then the step is first corrected by simplified Newton with the kept LU
 * (KEPT_ITER iterations, one rhs call each: enough in a stance, where the regularised
 * friction makes W go stale every other step; measured on gymnasium's walker2d, this cut
 * jac_x calls from 311 to 63 per simulated second and the run's CPU time by 45%); if that
 * does not contract, jac_x is evaluated at the step's end, refactored, and the implicit
 * Euler equation is solved by Newton from there (NEWTON_MAXITER), so the
 * step that crosses a contact's onset is the implicit one.  Where Newton does not
 * converge (a regularised friction law saturating inside the step: its slope mu F_n / v_s
 * is huge at v = 0 and nil at |v| >> v_s), the step is split into 2, 4, up to MAX_SPLIT
 * sub-steps; output, events and the caller still see the fixed grid.  A smallest
 * sub-step that does not converge is taken anyway, counted in stats->rejected (simulate
 * warns, naming how many: never a silent status 0 on an unsolved step).
 *
 * Measured (tests/runtime/test_implicitfast.py): on the undamped bouncing sphere, k from
 * 1e3 to 1e12 N/m^1.5 and dt from 0.2 to 5 ms, the total energy (spring included) never
 * rises above its start; Solo12 standing 1 s is within 1e-6 of Radau at 1e-10 at
 * dt = 1 ms for ~140 jac_x evaluations.
 *
 * The price of L-stability is numerical damping of order h*omega^2 per unit time on
 * oscillations of frequency omega: fixed-step results are first order (error ~ h),
 * good for control and learning at the model's time step, not for accuracy studies.
 *
 * Reentrant: all scratch is the caller's (eomc_fs_work_size doubles).
 */
#include "eomc_fixedstep.h"

#include <math.h>
#include <string.h>

#define RESID_FRACTION 0.2    /* |r| <= this * |dx - h f| (+ a floor): W is good enough */
#define RESID_FLOOR 1e-7      /* scaled, per state: at rest dx -> 0 and r is roundoff */
#define KEPT_ITER 2           /* Newton iterations with the kept LU before a new jac_x */
#define NEWTON_MAXITER 8
#define SLOW_RATE 0.25        /* Newton contracting slower than this: a new jac_x */
#define NEWTON_TOL 1e-10       /* scaled RMS of a Newton correction that counts as converged */
#define MAX_SPLIT 64          /* a step that Newton cannot solve is split into up to 64 */
#define NEWTON_HALVINGS 6     /* damping of the Newton corrections per step */
#define DEFAULT_MAX_STEPS 100000L

size_t eomc_fs_work_size(int nx)
{
    size_t n = (size_t)nx;
    return 2 * n * n + 12 * n + 8;
}

/* In-place LU with partial pivoting of the n x n row-major A; 1 if singular. */
static int fs_lu_factor(int n, double *A, int *piv)
{
    for (int k = 0; k < n; k++) {
        int p = k;
        double big = fabs(A[(size_t)k * n + k]);
        for (int i = k + 1; i < n; i++)
            if (fabs(A[(size_t)i * n + k]) > big) { big = fabs(A[(size_t)i * n + k]); p = i; }
        piv[k] = p;
        if (!(big > 0.0)) return 1;
        if (p != k) {
            double *a = A + (size_t)k * n, *b = A + (size_t)p * n;
            for (int j = 0; j < n; j++) { double t = a[j]; a[j] = b[j]; b[j] = t; }
        }
        {
            const double *rk = A + (size_t)k * n;
            double inv = 1.0 / rk[k];
            for (int i = k + 1; i < n; i++) {
                double *ri = A + (size_t)i * n, l = ri[k] * inv;
                ri[k] = l;
                if (l != 0.0)
                    for (int j = k + 1; j < n; j++) ri[j] -= l * rk[j];
            }
        }
    }
    return 0;
}

static void fs_lu_solve(int n, const double *A, const int *piv, double *b)
{
    for (int k = 0; k < n; k++) {
        int p = piv[k];
        if (p != k) { double t = b[k]; b[k] = b[p]; b[p] = t; }
    }
    for (int i = 1; i < n; i++) {
        const double *ri = A + (size_t)i * n;
        double s = b[i];
        for (int j = 0; j < i; j++) s -= ri[j] * b[j];
        b[i] = s;
    }
    for (int i = n - 1; i >= 0; i--) {
        const double *ri = A + (size_t)i * n;
        double s = b[i];
        for (int j = i + 1; j < n; j++) s -= ri[j] * b[j];
        b[i] = s / ri[i];
    }
}

typedef struct fs {
    const eomc_fs_ops *ops;
    eomc_stats *st;
    int n;
    double *J, *A, *f, *dx, *x1, *f1, *r, *slope, *best, *xs;
    int *piv;
    double h_lu;             /* the step A = I - h_lu J was factored for; 0: none */
} fs;

/* A = I - h J, factored; the LU is kept until the next call. */
static int fs_factor(fs *w, double h)
{
    int n = w->n;
    for (size_t i = 0; i < (size_t)n * n; i++) w->A[i] = -h * w->J[i];
    for (int i = 0; i < n; i++) w->A[(size_t)i * n + i] += 1.0;
    w->st->nlu++;
    w->h_lu = 0.0;
    /* I - h J singular: h times an eigenvalue of J is 1 (an unstable mode); solving
     * with it would be division by zero, so it is reported as the non-finite value
     * it would have produced. */
    if (fs_lu_factor(n, w->A, w->piv)) return EOMC_NONFINITE;
    w->h_lu = h;
    return EOMC_OK;
}

/* x1 = x + dx, f1 = f(tn, x1), r = dx - h f1 and *ratio = |r| / (|dx - h f| + floor):
 * the residual against the implicit part of the step (what implicit Euler adds to an
 * explicit one, h W dx).  So the test is scale-free: W must predict the implicit
 * correction to RESID_FRACTION, which a Jacobian without a contact that has just
 * closed cannot do however soft the contact (an explicit treatment of a soft spring
 * still creates energy).  Norms scaled by 1e-3 + |x| per state (positions, angles and
 * speeds weigh alike); the floor makes |r| <= RESID_FLOOR per state good enough at rest. */
static int fs_trial(fs *w, double tn, double h, const double *x, double *ratio)
{
    int n = w->n, s;
    double rn = 0.0, dn = 0.0;
    for (int i = 0; i < n; i++) w->x1[i] = x[i] + w->dx[i];
    s = w->ops->rhs(w->ops->ctx, tn, w->x1, w->f1);
    if (s) return s;
    for (int i = 0; i < n; i++) {
        double sc = 1.0 / (1e-3 + fabs(x[i]));
        double ri = w->dx[i] - h * w->f1[i], ci = w->dx[i] - h * w->f[i];
        w->r[i] = ri;
        rn += (ri * sc) * (ri * sc);
        dn += (ci * sc) * (ci * sc);
    }
    *ratio = sqrt(rn) / (sqrt(dn) + RESID_FLOOR / RESID_FRACTION * sqrt((double)n));
    return EOMC_OK;
}

/* One step of size h from (t, x, f = f(t, x)): leaves x + dx in x1 and f there in f1.
 * *conv = 1 when the implicit Euler residual met RESID_FRACTION; 0: x1, f1 hold the best
 * (finite) iterate; -1: no finite iterate at all.  Returns a model status otherwise. */
static int fs_step(fs *w, double t, double h, const double *x, int kept, int *conv, double *resid)
{
    int n = w->n, s, have_best = 0, saved;
    double ratio = INFINITY, best = INFINITY;
    *conv = 0;
    *resid = INFINITY;
    if (w->h_lu != h) {                         /* first step, a sub-step, the last one */
        if (w->h_lu == 0.0 && (s = w->ops->jac(w->ops->ctx, t, x, w->J))) return s;
        if ((s = fs_factor(w, h))) return s;
    }
    for (int i = 0; i < n; i++) w->dx[i] = h * w->f[i];
    fs_lu_solve(n, w->A, w->piv, w->dx);
    s = fs_trial(w, t + h, h, x, &ratio);
    if (s && s != EOMC_NONFINITE) return s;
    if (s == EOMC_OK && ratio <= RESID_FRACTION) { *conv = 1; *resid = ratio; return EOMC_OK; }
    /* first, simplified Newton with the kept LU: costs an rhs call, no jac_x, no LU (whole
     * steps only: a step that had to be split gets Newton with a fresh jac_x at once).  The
     * slope buffer is free inside a step: it keeps the first iterate to restart from. */
    saved = s == EOMC_OK && kept > 0;
    if (saved)                           /* the linearly implicit step, to restart from */
        memcpy(w->slope, w->dx, (size_t)n * sizeof(double));
    for (int it = 0; s == EOMC_OK && it < kept; it++) {
        double before = ratio;
        memcpy(w->best, w->dx, (size_t)n * sizeof(double));
        for (int i = 0; i < n; i++) w->r[i] = -w->r[i];
        fs_lu_solve(n, w->A, w->piv, w->r);
        for (int i = 0; i < n; i++) w->dx[i] += w->r[i];
        s = fs_trial(w, t + h, h, x, &ratio);
        if (s && s != EOMC_NONFINITE) return s;
        if (s == EOMC_OK && ratio <= RESID_FRACTION) { *conv = 1; *resid = ratio; return EOMC_OK; }
        if (s || !(ratio < 0.5 * before)) break;     /* not contracting: refresh W */
    }
    if (saved) {                         /* not solved that way: Newton from the first step */
        memcpy(w->dx, w->slope, (size_t)n * sizeof(double));
        s = fs_trial(w, t + h, h, x, &ratio);
        if (s && s != EOMC_NONFINITE) return s;
    }
    /* W is stale (a contact or limit switched, or the state moved far): Newton on the
     * implicit Euler equation with jac_x at the predicted end (at the start if that
     * prediction was not even finite). */
    if (s == EOMC_OK) {
        s = w->ops->jac(w->ops->ctx, t + h, w->x1, w->J);
        if (s && s != EOMC_NONFINITE) return s;
    }
    if (s == EOMC_NONFINITE) {
        if ((s = w->ops->jac(w->ops->ctx, t, x, w->J))) return s;
        if ((s = fs_factor(w, h))) return s;
        for (int i = 0; i < n; i++) w->dx[i] = h * w->f[i];
        fs_lu_solve(n, w->A, w->piv, w->dx);
        s = fs_trial(w, t + h, h, x, &ratio);
        if (s && s != EOMC_NONFINITE) return s;
        if (s) { *conv = -1; return EOMC_OK; }
        if (ratio <= RESID_FRACTION) { *conv = 1; *resid = ratio; return EOMC_OK; }
    } else if ((s = fs_factor(w, h))) {
        return s;
    }
    best = ratio; have_best = 1;
    memcpy(w->best, w->dx, (size_t)n * sizeof(double));
    for (int it = 0, halvings = 0, refreshed_at_best = 0; it < NEWTON_MAXITER; it++) {
        double corr = 0.0;
        for (int i = 0; i < n; i++) w->r[i] = -w->r[i];
        fs_lu_solve(n, w->A, w->piv, w->r);
        for (int i = 0; i < n; i++) {
            double c = w->r[i] / (1e-3 + fabs(x[i]));
            corr += c * c;
            w->dx[i] = w->best[i] + w->r[i];
        }
        /* Newton's own test, with a fresh jac_x: the correction is below NEWTON_TOL of the
         * state (the residual test above is relative to the step's implicit part, which
         * shrinks like h^2 on a split step while a contact's onset inside it does not) */
        if (sqrt(corr / n) <= NEWTON_TOL) {
            s = fs_trial(w, t + h, h, x, &ratio);
            if (s && s != EOMC_NONFINITE) return s;
            if (s == EOMC_OK) { *conv = 1; *resid = ratio; return EOMC_OK; }
            break;
        }
        s = fs_trial(w, t + h, h, x, &ratio);
        if (s && s != EOMC_NONFINITE) return s;
        /* no better than the best iterate: halve the correction (a damped Newton, for the
         * contact law's kink at touch-down); give up after a few halvings */
        while ((s == EOMC_NONFINITE || !(ratio < best)) && halvings < NEWTON_HALVINGS) {
            halvings++;
            for (int i = 0; i < n; i++) {
                double d = w->dx[i] - w->best[i];
                w->dx[i] = w->best[i] + 0.5 * d;
            }
            s = fs_trial(w, t + h, h, x, &ratio);
            if (s && s != EOMC_NONFINITE) return s;
        }
        if (s == EOMC_NONFINITE || !(ratio < best)) {
            /* no progress along this direction: once, jac_x at the best iterate and on */
            if (refreshed_at_best || it + 1 >= NEWTON_MAXITER) break;
            memcpy(w->dx, w->best, (size_t)n * sizeof(double));
            s = fs_trial(w, t + h, h, x, &ratio);
            if (s && s != EOMC_NONFINITE) return s;
            if (s || (s = w->ops->jac(w->ops->ctx, t + h, w->x1, w->J))) {
                if (s != EOMC_NONFINITE) return s;
                break;
            }
            if ((s = fs_factor(w, h))) return s;
            refreshed_at_best = 1;
            halvings = 0;
            continue;
        }
        refreshed_at_best = 0;
        {
            int slow = ratio > SLOW_RATE * best;
            best = ratio;
            memcpy(w->best, w->dx, (size_t)n * sizeof(double));
            if (ratio <= RESID_FRACTION) { *conv = 1; *resid = ratio; return EOMC_OK; }
            /* contracting slowly: jac_x where the iterate is now (full Newton; at a touch-down
             * the first jac_x, at the predicted end, can be far from the solution's) */
            if (slow && it + 1 < NEWTON_MAXITER) {
                if ((s = w->ops->jac(w->ops->ctx, t + h, w->x1, w->J))) {
                    if (s != EOMC_NONFINITE) return s;
                    break;
                }
                if ((s = fs_factor(w, h))) return s;
            }
        }
    }
    if (!have_best) { *conv = -1; return EOMC_OK; }
    memcpy(w->dx, w->best, (size_t)n * sizeof(double));   /* back to the best iterate */
    s = fs_trial(w, t + h, h, x, &ratio);
    if (s && s != EOMC_NONFINITE) return s;
    if (s) *conv = -1;
    *resid = ratio;
    return EOMC_OK;
}

/* The step [t, t + h] from x: one implicit step, or, where its Newton does not converge
 * (a friction law saturating inside the step, a hard impact), 2, 4 ... MAX_SPLIT equal
 * sub-steps there (and back up to whole steps as they converge).  Leaves the end in x1,
 * f1.  A sub-step of the smallest size that still does not converge is taken anyway
 * (its best iterate), counted in stats->rejected: the caller warns (simulate.py).  Its
 * residual does not tell a hard touch-down (a few such sub-steps, harmless: measured on
 * the rolling sphere at dt = 4 ms) from a blow-up (no solution at all) apart, so neither
 * is turned into a failure here; no finite iterate at all is EOMC_NONFINITE. */
static int fs_advance(fs *w, double t, double h, const double *x)
{
    int n = w->n, s, conv, pos = 0, size = MAX_SPLIT;
    double resid;                               /* the residual ratio (kept for debugging) */
    const double *xs = x;
    while (pos < MAX_SPLIT) {
        double ts = t + h * pos / MAX_SPLIT, hs = size == MAX_SPLIT ? h : h * size / MAX_SPLIT;
        if ((s = fs_step(w, ts, hs, xs, size == MAX_SPLIT ? KEPT_ITER : 0, &conv, &resid))) return s;
        if (conv != 1 && size > 1) {
            size /= 2;
            continue;
        }
        if (conv == -1) return EOMC_NONFINITE;
        if (conv == 0) w->st->rejected++;
        pos += size;
        if (pos < MAX_SPLIT) {                  /* a sub-step ended inside the step */
            memcpy(w->xs, w->x1, (size_t)n * sizeof(double));
            memcpy(w->f, w->f1, (size_t)n * sizeof(double));
            xs = w->xs;
            if (pos % (2 * size) == 0) size *= 2;
        }
    }
    return EOMC_OK;
}

int eomc_fs_run(const eomc_fs_ops *ops, eomc_stats *st, int nx, double h, long max_steps,
                double t0, double t1, double *x, double *work)
{
    fs w;
    int n = nx, s;
    long nsteps, maxs = max_steps > 0 ? max_steps : DEFAULT_MAX_STEPS;
    double *pos = work;
    if (!(h > 0) || !isfinite(h)) return EOMC_BAD_ARGUMENT;
    w.ops = ops; w.st = st; w.n = n; w.h_lu = 0.0;
    w.J = pos; pos += (size_t)n * n;
    w.A = pos; pos += (size_t)n * n;
    w.f = pos; pos += n;
    w.dx = pos; pos += n;
    w.x1 = pos; pos += n;
    w.f1 = pos; pos += n;
    w.r = pos; pos += n;
    w.slope = pos; pos += n;
    w.best = pos; pos += n;
    w.xs = pos; pos += n;
    w.piv = (int *)pos;
    nsteps = (long)ceil((t1 - t0) / h * (1 - 1e-12));
    if (nsteps < 1) nsteps = 1;
    if ((s = ops->rhs(ops->ctx, t0, x, w.f))) return s;
    for (long k = 0; k < nsteps; k++) {
        /* every step but the last is exactly h, so the kept LU stays valid */
        double t = t0 + k * h, tn = (k == nsteps - 1) ? t1 : t0 + (k + 1) * h;
        double hh = (k == nsteps - 1) ? t1 - t : h;
        int stop = 0;
        st->t = t; st->h = hh;
        if (st->steps >= maxs) return EOMC_MAX_STEPS;
        st->steps++;
        if ((s = fs_advance(&w, t, hh, x))) return s;
        st->accepted++;
        for (int i = 0; i < n; i++) w.slope[i] = (w.x1[i] - x[i]) / hh;
        if ((s = ops->accept(ops->ctx, t, tn, x, w.slope, w.x1, w.f1, &stop))) return s;
        if (stop) return EOMC_OK;
        memcpy(x, w.x1, (size_t)n * sizeof(double));
        memcpy(w.f, w.f1, (size_t)n * sizeof(double));
    }
    st->t = t1;
    return EOMC_OK;
}
