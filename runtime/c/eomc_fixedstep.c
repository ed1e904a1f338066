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

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* the lanes' vector code (eomc_fs_lanes_body.h, AVX2 when the CPU has it): the lanes rollout's
 * assembly, and the scalar assembly's secant slopes four contacts at a time (fs_secants) */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(EOMC_NO_FS_LANES)
#define EOMC_FS_LANES 1
#endif

/* The whole scalar step a second time, compiled for AVX2 (eomc_fixedstep_avx2.c includes this file
 * with EOMC_FS_AVX2_COPY defined, under #pragma GCC target("avx2")); eomc_fs_run hands a run to that
 * copy where the CPU has AVX2.  Why: the integrator library is built once at install for any x86-64
 * (SSE2), and the VEX encoding's three-operand forms drop the register copies of two-operand SSE2
 * in fs_assemble's and the solves' scalar code, as they did in the model libraries (toolchain.py's
 * MACHINE_FLAGS).  Measured (benchmarks/results/fixedstep.md, session 29): the gymnasium models'
 * checked qpos0 runs, ant 5-6 %, hopper 7 %, walker2d 4 %, humanoid 2-7 % faster (in one process
 * against the SSE2 build).  The same bits: AVX2 has no fused multiply-add (that
 * is FMA, not enabled) and C99 mode contracts nothing, so every operation is the SSE2 build's, in
 * the same order.  gcc only (clang's target pragma differs); EOMC_NO_FS_AVX2 builds without the
 * copy, and $EOMC_FS_NO_AVX2 (set, non-empty) runs the SSE2 build on any CPU (the tests compare
 * the two). */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(EOMC_NO_FS_AVX2)
#define EOMC_FS_AVX2 1
#endif

#define RESID_FRACTION 0.2    /* |r| <= this * |dx - h f| (+ a floor): W is good enough */
#define RESID_FLOOR 1e-7      /* scaled, per state: at rest dx -> 0 and r is roundoff */
#define KEPT_ITER 2           /* Newton iterations with the kept LU before a new jac_x */
#define NEWTON_MAXITER 8
#define SLOW_RATE 0.25        /* Newton contracting slower than this: a new jac_x */
#define NEWTON_TOL 1e-10       /* scaled RMS of a Newton correction that counts as converged */
#define MAX_SPLIT 64          /* a step that Newton cannot solve is split into up to 64 */
#define NEWTON_HALVINGS 6     /* damping of the Newton corrections per step */
#define DEFAULT_MAX_STEPS 100000L
#define HARD_FACTOR 20.0      /* fast path: a ratio above this * eomc_implicit.split is split
                                 even where halving does not help (see fs_fast_advance) */
#define FRICTION_FACTOR 2.0   /* fast path: a whole step's ratio up to this * split with no regime
                                 change is taken whole (see fs_switched) */
#define SWITCH_FACTOR 2.0     /* fast path: a contact depth or joint-law slope changing by more
                                 than this factor within a step is a regime change */
#define RESID_ACCEL 1.0       /* fast path: the residual test's floor, h * this (m/s^2, rad/s^2) */
#define ONSET_FACTOR 100.0    /* fast path: a contact in touch at a step's start whose depth grows by
                                 more than this within it touches down there (see fs_onset) */
#define LAND_FRACTION 0.01    /* fast path: a touch-down ending deeper than this * the contact's depth
                                 limit (its radius) lands deep (see fs_lands) */
#define CHART_FACTOR 4.0      /* fast path: the configuration's residual counts this many times in the
                                 try's ratio (see fs_chart_ratio) */
#define CREEP_FRACTION 0.001  /* fast path: a try taken above split as a stick/slip step presses no
                                 contact in by more than this * its depth limit (see fs_creeps) */
#define WALK_TARGET 0.5       /* fast path: after a touch-down's onset cell, the next sub-step is sized for a
                                 ratio of this * split (see fs_walk_size) */
#define WALK_GROW 16          /* ... growing at most this many times a take */

#ifndef EOMC_FS_AVX2_COPY   /* the copy has only eomc_fs_run (as eomc_fs_run_avx2) */
size_t eomc_fs_work_size(int nx)
{
    size_t n = (size_t)nx;
    return 2 * n * n + 12 * n + 8;
}
#endif

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

/* ------------------------------------------------------------------ the fast path
 *
 * With the model's NAME_implicit (eomc_implicit, from eomc_options.implicit) the step is
 * MuJoCo's implicitfast: velocities first, through the mass matrix and the slopes of the
 * smooth forces in the velocities, positions then with the new velocities:
 *
 *   (M + h C~ + h^2 K~) du = h (f - h K~ u),   u1 = u + du,   q1 = q + h (q'(q, u) + N du)  (2)
 *
 * where C~ = -d(contacts, joint laws)/du and K~ = -d(contacts, joint laws)/dq N are those
 * forces' slopes: per contact in touch Jᵀ C J and Jᵀ K J (J the contact point's 3 x nu
 * velocity Jacobian, built here from the speeds' world motions for the contacts in touch
 * only; C, K of compiler/contact/law.ground_jacobians: the normal force's stiffness and
 * damping with the friction they carry, the regularised friction's slope in the slip --
 * replaced by its secant, fs_secant_friction),
 * per joint law its damping and stiffness (their positive part) on the diagonal.  (2) is
 * linearly implicit Euler with that part of the Jacobian and q' linearised in u: the
 * stiff contact, friction and limit forces are damped, never amplified, and the smooth
 * rest is integrated symplectically.  Coriolis terms and the contact Jacobian's change
 * with q stay explicit (MuJoCo's implicitfast skips the same kind of terms) -- but for a touching
 * contact's velocity (a ground contact's or a body-body pair's), whose change over the step from
 * the motion alone (h J'(q) u, fs_point_bias) its linear model takes in: the damping and friction of (2) see the point's velocity change
 * J du + h J' u, not J du alone (b -= h J^T C J' u) -- and but for a root
 * free joint's momentum turning with its body-frame speeds, taken half implicitly
 * (fs_transport: explicit, it created energy on a spinning or rolling body; MuJoCo's free joint
 * has world-frame linear speeds, which do not turn).
 * Measured on gymnasium's ant at its 10 ms step: with C and K symmetrised (the friction
 * carried by the normal force left out) the ant blew up after 1 s of standing; with it,
 * it stands.  One NAME_implicit call per step, no Jacobian of the whole rhs, no Newton
 * iteration: the matrix of (2) has M's tree sparsity (a contact couples only the speeds
 * of its body's chain to the root), so it is factored without fill-in from the leaves up
 * in O(nu * depth^2) (parent[] given; dense without it).
 *
 * First order, like the W-method above and MuJoCo's own Euler and implicitfast; no
 * error control (a fixed step is what control and learning loops want).
 */

typedef struct fs_layout {
    size_t M, f, qd, N, screw, joint, contact, energy, size;
} fs_layout;

/* size: with room for the energy after the contacts, whether the model's terms end with it
 * (eomc_implicit.energy) or not: a caller that left imp->energy 0 for such a model (the struct
 * zeroed) then loses the watch's shortcut, not memory past the buffer */
static fs_layout fs_layout_of(int nq, int nu, int nc)
{
    fs_layout L;
    size_t q = (size_t)nq, u = (size_t)nu;
    L.M = 0;
    L.f = u * u;
    L.qd = L.f + u;
    L.N = L.qd + q;
    L.screw = L.N + q * u;
    L.joint = L.screw + 6 * u;
    L.contact = L.joint + 2 * u;
    L.energy = L.contact + 25 * (size_t)nc;
    L.size = L.energy + 1;
    return L;
}

/* Doubles of fs_assemble's cache for one set of terms: per contact its secant C (9), K v + C a (3), a
 * flag and, at most nu each, its J's columns (3) and their j . K v (1). */
static size_t fs_cache_size(int nu, int ncontact)
{
    return (size_t)ncontact * (13 + 4 * (size_t)nu);
}

/* The doubles at the tail of eomc_fs_implicit_work_size's that hold a run's fixed lists (fs_fixed_lists;
 * eomc_implicit.pattern's length): fs_pattern's bits and two own lists, the ancestor lists, M's column
 * lists and N's. */
static size_t fs_fixed_len(int nq, int nu, int ncontact)
{
    size_t u = (size_t)nu;
    return 2 * u + (size_t)ncontact + 2 * (u * u / 2 + u + 2) + u * u / 2 + u + 2 + u * u / 2 + u / 2 + 2
           + (size_t)nq * u + (size_t)nq + 2;
}

#ifndef EOMC_FS_AVX2_COPY
size_t eomc_fs_implicit_work_size(int nq, int nu, int ncontact)
{
    size_t u = (size_t)nu, x = (size_t)nq + u;
    /* two sets of terms, matrices, right sides and fs_assemble caches (the step's start and a
     * trial end: the residual test below), scratch, the ancestor lists (nu + 1 + nu (nu - 1) / 2 ints, in
     * nu * nu / 2 + nu + 1 doubles) and M's column lists (nu + 1 + nu * nu ints, in
     * nu * nu / 2 + nu / 2 + 1 doubles) */
    return 2 * fs_layout_of(nq, nu, ncontact).size + 2 * fs_cache_size(nu, ncontact) + 2 * u * u + 10 * u
           + 4 * x + 8 + u * u / 2 + u + 2
           + u * u / 2 + u / 2 + 2
           + 2 * u + (size_t)ncontact + 2 * (u * u / 2 + u + 2)    /* fs_pattern's bits and two own lists */
           + (size_t)nq * u + (size_t)nq + 2;                        /* fs_nlists' two lists (ints) */
}
#endif

/* A = U D L in place (D on the diagonal, unit U above it, unit L below it): A has nonzeros
 * only between a speed and its ancestors (parent[k] < k; NULL: every earlier speed, i.e.
 * dense), so eliminating from the leaves up (Featherstone's LTDL, RBDA table 6.3, here
 * without symmetry: A is M plus the contacts' slopes, not symmetric) makes no fill-in
 * (but where a body-body pair couples two branches: fs_ancestors' lists hold that fill).
 * 1 when a pivot is zero to rounding (64 eps of the largest diagonal entry) or not finite;
 * a negative pivot is no failure (A is not symmetric: a sliding contact's friction carried
 * by its normal force makes it indefinite, and measured on the falling humanoid a foot's
 * pivot goes negative while the step is fine). */
/* A contact's chain entry: its speed s, or ~s = -1 - s for a body-body pair's first body (the
 * point's velocity is the second body's less the first's: a minus in J). */
static int fs_speed(int e)
{
    return e >= 0 ? e : ~e;
}

/* anc[start[k] .. start[k + 1]) = speed k's ancestors, nearest first (parent[] NULL: every
 * earlier speed); the elimination below walks these lists, not the parent chain (a chain of
 * dependent loads: measured on the humanoid, the walk was 40% of the step outside the model).
 * These lists, with the couplings the contacts add: a ground contact's speeds lie on one path to
 * the root (they are ancestors of each other: nothing new), but a body-body pair's point joins its
 * two bodies' branches below their common ancestor (gymnasium's humanoid: a hand against a thigh),
 * and eliminating from the leaves up then fills in between them.  So the lists are the symbolic
 * elimination of M's pattern plus every contact's couplings: per k the speeds i < k that row or
 * column k meets when k is eliminated, largest first -- for a tree, and a model whose pairs each
 * lie on one path, exactly the ancestors, nearest first (the same lists and bits as before).
 * mark: n * n bytes of scratch. */
static void fs_ancestors(int n, const int *parent, const eomc_implicit *imp, unsigned char *mark, int *start,
                         int *anc)
{
    int pos = 0;
    memset(mark, 0, (size_t)n * n);
    for (int k = 0; k < n; k++)
        for (int i = parent ? parent[k] : k - 1; i >= 0; i = parent ? parent[i] : i - 1) mark[(size_t)k * n + i] = 1;
    for (int c = 0; imp && imp->chain && c < imp->ncontact; c++)
        for (int x = imp->chain_start[c]; x < imp->chain_start[c + 1]; x++)
            for (int y = imp->chain_start[c]; y < imp->chain_start[c + 1]; y++) {
                int i = fs_speed(imp->chain[x]), j = fs_speed(imp->chain[y]);
                if (i > j) mark[(size_t)i * n + j] = 1;
            }
    for (int k = n - 1; k >= 0; k--)                 /* eliminating k couples what k meets */
        for (int i = k - 1; i >= 0; i--)
            if (mark[(size_t)k * n + i])
                for (int j = i - 1; j >= 0; j--)
                    if (mark[(size_t)k * n + j]) mark[(size_t)i * n + j] = 1;
    for (int k = 0; k < n; k++) {
        start[k] = pos;
        for (int i = k - 1; i >= 0; i--)
            if (mark[(size_t)k * n + i]) anc[pos++] = i;
    }
    start[n] = pos;
}

/* cols[cstart[i] .. cstart[i + 1]) = the speeds k with M[i][k] possibly nonzero (k an ancestor
 * of i, i itself or a descendant of i), ascending; at most n * n entries.  Up to 64 speeds, each
 * row's set as the bits of one word, marked from the lists once (O(n^2 + entries)): the search of
 * both lists for every (i, k) was 42 % of a run's set-up, ~3 us a row on gymnasium's humanoid (perf
 * of 64 rows x 1 step, the RL pattern: the set-up is paid per row).  The same lists either way. */
static void fs_columns(int n, const int *start, const int *anc, int *cstart, int *cols)
{
    int pos = 0;
    if (n <= 64) {
        unsigned long long bits[64];
        for (int i = 0; i < n; i++) bits[i] = 1ULL << i;
        for (int k = 0; k < n; k++)
            for (int x = start[k]; x < start[k + 1]; x++) {
                bits[k] |= 1ULL << anc[x];
                bits[anc[x]] |= 1ULL << k;
            }
        for (int i = 0; i < n; i++) {
            cstart[i] = pos;
            for (int k = 0; k < n; k++)
                if (bits[i] >> k & 1ULL) cols[pos++] = k;
        }
        cstart[n] = pos;
        return;
    }
    for (int i = 0; i < n; i++) {
        cstart[i] = pos;
        for (int k = 0; k < n; k++) {
            int linked = k == i;
            for (int x = start[i]; x < start[i + 1] && !linked; x++) linked = anc[x] == k;
            for (int x = start[k]; x < start[k + 1] && !linked; x++) linked = anc[x] == i;
            if (linked) cols[pos++] = k;
        }
    }
    cstart[n] = pos;
}

/* A contact's chain is a few runs of consecutive speeds (gymnasium's humanoid: a foot's 0..12, a hand's
 * 0..5 and 20..22), and fs_assemble's J^T G J scatter goes over them in vectors where the compiler
 * has them (GNU C's vector extension: AVX2's four doubles in eomc_fixedstep_avx2.c's copy, SSE2's two
 * in the base build).  A vector's lanes are each the scalar operation (products, then sums in the
 * same order: C99 mode contracts nothing, and neither build has FMA), so the same bits. */
#if defined(__GNUC__)
#define FS_VEC 1
typedef double fs_v4 __attribute__((vector_size(32), aligned(8)));
typedef double fs_v2 __attribute__((vector_size(16), aligned(8)));
#endif

static int fs_tree_lu(int n, double *A, const int *start, const int *anc)
{
    double scale = 0.0;
    for (int k = 0; k < n; k++)
        if (fabs(A[(size_t)k * n + k]) > scale) scale = fabs(A[(size_t)k * n + k]);
    if (!isfinite(scale)) return 1;
    for (int k = n - 1; k >= 0; k--) {
        const int *a = anc + start[k];
        int na = start[k + 1] - start[k], x = 0;
        double dk = A[(size_t)k * n + k], inv, *rk = A + (size_t)k * n;
        if (!(fabs(dk) > 64 * DBL_EPSILON * scale) || !isfinite(dk)) return 1;
        inv = 1.0 / dk;
        /* Rows four, then two at a time: the rows of one k's ancestors take the same updates from the
         * same entries of row k (rk[a[y]], loaded once for all of them), and a list is at most 12 long
         * on gymnasium's humanoid, so the loop's own work per list bounded the factorisation, not memory
         * (session 30, helper humlevers: rdtsc medians in the run equal the same matrices replayed in a
         * harness, 2028 vs 2030 ticks).  Measured, rdtsc medians of one factorisation in the T2 run:
         * humanoid 2380 -> 1910 ticks, G1 5120 -> 3650.  Each entry gets the same operation as one row at
         * a time (a row whose u is 0 is skipped as before): the same bits. */
        for (; x + 3 < na; x += 4) {
            double *r0 = A + (size_t)a[x] * n, *r1 = A + (size_t)a[x + 1] * n;
            double *r2 = A + (size_t)a[x + 2] * n, *r3 = A + (size_t)a[x + 3] * n;
            double u0 = r0[k] * inv, u1 = r1[k] * inv, u2 = r2[k] * inv, u3 = r3[k] * inv;
            if (u0 != 0.0 && u1 != 0.0 && u2 != 0.0 && u3 != 0.0) {
                for (int y = 0; y < na; y++) {
                    int c = a[y];
                    double v = rk[c];
                    r0[c] -= u0 * v;
                    r1[c] -= u1 * v;
                    r2[c] -= u2 * v;
                    r3[c] -= u3 * v;
                }
            } else {
                if (u0 != 0.0) for (int y = 0; y < na; y++) r0[a[y]] -= u0 * rk[a[y]];
                if (u1 != 0.0) for (int y = 0; y < na; y++) r1[a[y]] -= u1 * rk[a[y]];
                if (u2 != 0.0) for (int y = 0; y < na; y++) r2[a[y]] -= u2 * rk[a[y]];
                if (u3 != 0.0) for (int y = 0; y < na; y++) r3[a[y]] -= u3 * rk[a[y]];
            }
            r0[k] = u0;
            r1[k] = u1;
            r2[k] = u2;
            r3[k] = u3;
        }
        for (; x + 1 < na; x += 2) {
            double *r0 = A + (size_t)a[x] * n, *r1 = A + (size_t)a[x + 1] * n;
            double u0 = r0[k] * inv, u1 = r1[k] * inv;
            if (u0 != 0.0 && u1 != 0.0) {
                for (int y = 0; y < na; y++) {
                    int c = a[y];
                    double v = rk[c];
                    r0[c] -= u0 * v;
                    r1[c] -= u1 * v;
                }
            } else {
                if (u0 != 0.0) for (int y = 0; y < na; y++) r0[a[y]] -= u0 * rk[a[y]];
                if (u1 != 0.0) for (int y = 0; y < na; y++) r1[a[y]] -= u1 * rk[a[y]];
            }
            r0[k] = u0;
            r1[k] = u1;
        }
        for (; x < na; x++) {
            double *ri = A + (size_t)a[x] * n, u = ri[k] * inv;
            if (u != 0.0)
                for (int y = 0; y < na; y++) ri[a[y]] -= u * rk[a[y]];
            ri[k] = u;
        }
        for (int y = 0; y < na; y++) rk[a[y]] *= inv;
    }
    return 0;
}

/* b := A^-1 b, and with two, c := A^-1 c as well, each vector by the same operations as alone
 * (the same bits).  Why two at once: the solve is a chain of dependent updates (a speed's entry
 * waits for its descendants'), so a second right side rides in the first one's latency; measured
 * (the ant's pattern, C harness): two solves 290 ns, one with both 176 ns. */
static inline void fs_tree_solve_n(int n, const double *A, const int *start, const int *anc, double *restrict b,
                                   double *restrict c, int two)
{
    for (int k = n - 1; k >= 0; k--) {
        double bk = b[k], ck = two ? c[k] : 0.0;
        for (int x = start[k]; x < start[k + 1]; x++) {
            double a = A[(size_t)anc[x] * n + k];
            b[anc[x]] -= a * bk;
            if (two) c[anc[x]] -= a * ck;
        }
    }
    for (int k = 0; k < n; k++) {
        b[k] /= A[(size_t)k * n + k];
        if (two) c[k] /= A[(size_t)k * n + k];
    }
    for (int k = 0; k < n; k++) {
        double sb = b[k], sc = two ? c[k] : 0.0;
        for (int x = start[k]; x < start[k + 1]; x++) {
            double a = A[(size_t)k * n + anc[x]];
            sb -= a * b[anc[x]];
            if (two) sc -= a * c[anc[x]];
        }
        b[k] = sb;
        if (two) c[k] = sc;
    }
}

static void fs_tree_solve(int n, const double *A, const int *start, const int *anc, double *b)
{
    fs_tree_solve_n(n, A, start, anc, b, NULL, 0);
}

static void fs_tree_solve2(int n, const double *A, const int *start, const int *anc, double *b, double *c)
{
    fs_tree_solve_n(n, A, start, anc, b, c, 1);
}

/* Cs = C with the friction's slope in the slip replaced by its secant: of the regularised
 * Coulomb law F_t = -mu F_n v_t / s (s^2 = |v_t|^2 + v_s^2) C holds the tangent slope
 * (mu F_n / s)(P - v_t v_t^T / s^2) (compiler/contact/law.ground_jacobians), which along a
 * fast slip is mu F_n v_s^2 / s^3: almost nothing.  Linearised with it, a step in which the
 * slip should come to rest applies the whole saturated force mu F_n explicitly and overshoots
 * through zero slip; the next step does the same the other way, growing (measured, session 6:
 * the humanoid's right knee speed alternating 0.22, -0.62, 0.56, -1.25, 0.73, -1.88 rad/s
 * through runs of h/32..h/64 sub-steps after its first impact).  The secant mu F_n / s, the
 * same in every tangential direction (P), makes the step's friction a damper that takes the
 * slip towards rest and never past it (MuJoCo's implicit damping does the same kind of
 * thing); at rest (|v_t| << v_s) tangent and secant agree.  Any slope keeps (2) a consistent
 * first-order step and the residual test still judges the result against the exact law.
 * The plane's normal n is read off K (K = k_n (n - mu v_t / s) n^T: every row is a multiple
 * of n^T), so no generated C changes, and jac_x (which shares the law's exact slopes) is
 * untouched.  Measured (gymnasium humanoid, 8 random starts, 1 s at 3 ms): model calls
 * 744 -> 560 a run, and a row that failed with a singular matrix now ends fine; on the
 * thrown ball at 5 ms, 3 of 16 starts gained energy with the tangent, none with the secant. */
static void fs_secant_friction(const double *K, const double *C, double *Cs)
{
    int r = -1, m;
    double big = 0.0, n[3], e[2][3], B[2][2], gf, l;
    memcpy(Cs, C, 9 * sizeof(double));
    for (int a = 0; a < 3; a++) {
        double s2 = K[3 * a] * K[3 * a] + K[3 * a + 1] * K[3 * a + 1] + K[3 * a + 2] * K[3 * a + 2];
        if (s2 > big) { big = s2; r = a; }
    }
    if (r < 0 || !isfinite(big)) return;       /* no normal force: no friction either */
    l = 1.0 / sqrt(big);
    for (int a = 0; a < 3; a++) n[a] = K[3 * r + a] * l;
    /* e[0], e[1]: the plane's axes (the world axis least along n made orthogonal, and n x it) */
    m = fabs(n[0]) <= fabs(n[1]) ? (fabs(n[0]) <= fabs(n[2]) ? 0 : 2) : (fabs(n[1]) <= fabs(n[2]) ? 1 : 2);
    for (int a = 0; a < 3; a++) e[0][a] = (a == m) - n[m] * n[a];
    l = 1.0 / sqrt(e[0][0] * e[0][0] + e[0][1] * e[0][1] + e[0][2] * e[0][2]);
    for (int a = 0; a < 3; a++) e[0][a] *= l;
    e[1][0] = n[1] * e[0][2] - n[2] * e[0][1];
    e[1][1] = n[2] * e[0][0] - n[0] * e[0][2];
    e[1][2] = n[0] * e[0][1] - n[1] * e[0][0];
    /* B = the tangent slope in the plane, gf = mu F_n / s its larger eigenvalue (across the slip) */
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++) {
            double t = 0.0;
            for (int a = 0; a < 3; a++)
                t += e[i][a] * (C[3 * a] * e[j][0] + C[3 * a + 1] * e[j][1] + C[3 * a + 2] * e[j][2]);
            B[i][j] = t;
        }
    {
        double mean = 0.5 * (B[0][0] + B[1][1]), half = 0.5 * (B[0][0] - B[1][1]), off = 0.5 * (B[0][1] + B[1][0]);
        gf = mean + sqrt(half * half + off * off);
    }
    if (!isfinite(gf)) return;
    /* Cs = C + sum_ij (gf delta_ij - B_ij) e_i e_j^T: the plane's block becomes gf P */
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++) {
            double d = (i == j ? gf : 0.0) - B[i][j];
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++) Cs[3 * a + b] += e[i][a] * d * e[j][b];
        }
}

/* The elimination's lists of one matrix of (2), per step: M's tree pattern, or, where a pressed
 * body-body pair joins two branches, that pattern with the pair's fill.  Why per step: the fill of
 * every pair the model has (fs_ancestors with them all) made gymnasium's humanoid's 109 self-pairs
 * couple nearly all its limbs' speeds -- 3795 updates a factorisation against M's 1394 -- at every
 * step, while a step has at most a few pairs pressed.  With bits (n <= 64), the fill of the pressed
 * pairs costs a few hundred operations and only on the steps that have one; the lists it gives are
 * fs_ancestors' for those pairs (the same order: the same bits where the pattern is the same, and
 * the same nonzero bits where a bigger pattern only adds exact zeros). */
typedef struct fs_pattern {
    int n;
    const int *start, *anc;              /* M's (n > 64 or NULL tree: with every pair's fill) */
    const unsigned long long *tree;      /* n: speed k's ancestors as bits; NULL: no per-step fill */
    const unsigned long long *cross;     /* per contact: its speeds' bits where it joins two branches, else 0 */
    unsigned long long *bits;            /* n: scratch */
} fs_pattern;

/* bits = the pattern's with contact c's couplings (bits holds the tree's already). */
static void fs_couple(const fs_pattern *pat, const eomc_implicit *imp, int c)
{
    unsigned long long m = pat->cross[c];
    for (int x = imp->chain_start[c]; x < imp->chain_start[c + 1]; x++) {
        int s = fs_speed(imp->chain[x]);
        pat->bits[s] |= m & ((1ULL << s) - 1);
    }
}

/* own = the lists of bits' pattern after elimination (as fs_ancestors builds them). */
static void fs_fill(const fs_pattern *pat, int *own)
{
    int n = pat->n, pos = 0, *start = own, *anc = own + n + 1;
    unsigned long long *m = pat->bits;
    for (int k = n - 1; k >= 0; k--)
        for (int i = k - 1; i >= 0; i--)
            if (m[k] >> i & 1) m[i] |= m[k] & ((1ULL << i) - 1);
    for (int k = 0; k < n; k++) {
        start[k] = pos;
        for (int i = k - 1; i >= 0; i--)
            if (m[k] >> i & 1) anc[pos++] = i;
    }
    start[n] = pos;
}

/* A's rows of a root free joint (first speed s: v = u[s .. s+2], w = u[s+3 .. s+5], body-frame)
 * += (h/2) w x M[s .. s+2][k].  Why: those rows are the balance of the linear momentum
 * p = M[s .. s+2] u of the joint's whole subtree in the body's frame, p' + w x p = F; the
 * turning w x p is in f, so (2) advanced p by (I - h w^) p: an explicit Euler rotation, whose
 * |p| grows by sqrt(1 + h^2 |w|^2) every step (a ball flying at 1 m/s spinning at 10 rad/s
 * gained 0.053 J in 1 s at 1 ms; rolling on the plane, 0.054 J, and simulate failed the run).
 * With half of it on the new momentum, (I + h/2 w^) p1 = (I - h/2 w^) p + h F: the Cayley
 * rotation, which keeps |p| to rounding (measured: 8e-16 J in that flight), a consistent
 * first-order step as before, at the cost of 3 nu products.  The angular rows' w x L + v x p
 * stay explicit (taken the same way they do not conserve: the frozen v x p then does work). */
static void fs_transport(double *A, const double *M, const double *u, int s, int nu, double h)
{
    const double *w = u + s + 3, *m0 = M + (size_t)s * nu, *m1 = m0 + nu, *m2 = m1 + nu;
    double g = 0.5 * h, *a0 = A + (size_t)s * nu, *a1 = a0 + nu, *a2 = a1 + nu;
    for (int k = 0; k < nu; k++) {
        double p0 = m0[k], p1 = m1[k], p2 = m2[k];
        if (p0 == 0.0 && p1 == 0.0 && p2 == 0.0) continue;     /* off M's pattern */
        a0[k] += g * (w[1] * p2 - w[2] * p1);
        a1[k] += g * (w[2] * p0 - w[0] * p2);
        a2[k] += g * (w[0] * p1 - w[1] * p0);
    }
}

/* A = M + h C~ + h^2 K~ from the terms T (factored in place) and b = f - h K~ u: the
 * matrix and right side of (2) for a step of size h from the state T was evaluated at; *start,
 * *anc its elimination's lists (the pattern's, or in own: fs_pattern).  cache: what does not
 * depend on h (each touching contact's secant slope, K v + C a, J and J^T (K v + C a)), made when *cached is
 * 0 and then *cached = 1, read when it is 1 (the same T assembled for another h: a split step's
 * sub-steps: on the ant 34 of its 179 assemblies a second; its 1-s checked run 0.553 -> 0.542 ms,
 * runtime .so A/B in one process).  The same bits either way. */
#define FS_CHAIN 64     /* fs_assemble: a contact's chain up to this many speeds is listed on the stack */

/* a = d/dt (J u) at fixed u for a contact's point p (its material velocity vp): the velocity the
 * point gains over a step from the configuration's motion alone (its bias acceleration), which (2)'s
 * J du leaves out.  Per speed k of the chain, J[:, k] = w_k x p + v0_k of the speed's screw (w_k, v0_k),
 * whose axis moves with the body that carries it, of spatial velocity V_a = (w_a, v_a):
 *
 *   d/dt J[:, k] = (w_a x w_k) x p + w_k x vp + w_a x v0_k + v_a x w_k
 *
 * V_a: the sum of the chain's screws times speeds before k's joint (the chain is the contact body's
 * path to the root, so those are k's ancestors).  Every joint's axes are fixed in its child body, so
 * V_a = V_before + V_J, V_J its own speeds' screws; summed over the joint, V_J x V_J = 0 leaves
 * V_before x V_J: each of a joint's speeds sees the V before its joint.  For a one-speed joint that
 * is the V before k; a joint of several speeds (a ball, a planar joint, a free joint below the root:
 * eomc_implicit.joint) must not take each as carried by the one before, as a chain of hinges is
 * (measured, session 28, helper pairbias, a ball-jointed arm: 3-43 % of |a| off; session 29,
 * ballbias: with the joint's V, 1e-11).  A root free joint's V before is 0: it adds nothing and is
 * skipped (eomc_implicit.free).  Summed: a = B_w x p + B_v + w x vp, B = sum_k V_a x (s_k u_k) (spatial
 * cross product), w the body's angular velocity: about 30 flops a speed.
 * Why (session 27, helper releaseslope): traced on gymnasium's humanoid at t = 0.75 s, its feet's
 * contacts went from pushing to clipped inside every step (the damped law's release) and back in the
 * next half, 3 calls a step: J(q) u1 at the end was 0.064 m/s upwards, J(q0) u1 0.018, J(q0) du 0.003 --
 * the rise came from the Jacobian's change with q, which (2) did not see, so the step's damping
 * predicted a push where the law clipped.  With C a in the contact's linear model (fs_assemble) those
 * whole steps pass at ratio 0.03 instead of 1.5.  Measured (bench_fixedstep_verdicts.py, seeds 0-10,
 * 704 starts a model, main's library in the same run; benchmarks/results/fixedstep_verdicts.md's
 * notes): model calls humanoid -12.6 % (qpos0 480 -> 454), walker2d -41 %, ant -0.2 %, hopper -0.1 %;
 * energy-verdict rows "wrong" / "more than the tolerance": humanoid 10 / 87 -> 9 / 78, walker2d 14 /
 * 104 -> 1 / 13; the ant and hopper none either way.
 *
 * A body-body pair (fs_pair_bias) when its chain lists a speed negated (its first body A's: v_rel =
 * v_B - v_A) or starts below the root (A an ancestor of B: its speeds, shared, are left out of the
 * chain); a ground contact's chain starts at the root.  0 (a untouched) for a pair when M has no
 * tree (parent NULL: the shared speeds cannot be found) or a chain longer than FS_CHAIN. */
static int fs_pair_bias(const eomc_implicit *imp, const double *scr, const double *u, const int *order, int m,
                        const double *p, const double *vp, double *a);

static int fs_point_bias(const eomc_implicit *imp, const double *scr, const double *u, const int *cols, int m,
                         const double *p, const double *vp, double *a)
{
    int order[FS_CHAIN], pair = 0;
    double V[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0}, B[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    double Vg[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    if (m > FS_CHAIN) return 0;
    for (int k = 0; k < m; k++) {
        pair |= cols[k] < 0;
        order[k] = cols[k];
    }
    for (int i = 1; i < m; i++)                       /* ascending: root first (parent[k] < k) */
        for (int j = i; j > 0 && fs_speed(order[j - 1]) > fs_speed(order[j]); j--) {
            int t = order[j];
            order[j] = order[j - 1];
            order[j - 1] = t;
        }
    if (m > 0 && imp->parent && imp->parent[fs_speed(order[0])] >= 0) pair = 1;
    if (pair) return imp->parent ? fs_pair_bias(imp, scr, u, order, m, p, vp, a) : 0;
    for (int i = 0; i < m; i++) {
        int k = order[i], own = 0;
        const double *w = scr + 6 * (size_t)k, *Vk = V;
        double S[6];
        for (int x = 0; x < 6; x++) S[x] = w[x] * u[k];
        for (int r = 0; r < imp->nfree; r++) own |= k >= imp->free[r] && k < imp->free[r] + 6;
        if (imp->joint) {                             /* V before k's joint (eomc_implicit.joint) */
            if (imp->joint[k] == k) memcpy(Vg, V, sizeof Vg);
            Vk = Vg;
        }
        if (!own) {                                   /* B += V x S (spatial), V the speeds before k */
            B[0] += Vk[1] * S[2] - Vk[2] * S[1];
            B[1] += Vk[2] * S[0] - Vk[0] * S[2];
            B[2] += Vk[0] * S[1] - Vk[1] * S[0];
            B[3] += (Vk[1] * S[5] - Vk[2] * S[4]) + (Vk[4] * S[2] - Vk[5] * S[1]);
            B[4] += (Vk[2] * S[3] - Vk[0] * S[5]) + (Vk[5] * S[0] - Vk[3] * S[2]);
            B[5] += (Vk[0] * S[4] - Vk[1] * S[3]) + (Vk[3] * S[1] - Vk[4] * S[0]);
        }
        for (int x = 0; x < 6; x++) V[x] += S[x];
    }
    a[0] = (B[1] * p[2] - B[2] * p[1]) + B[3] + (V[1] * vp[2] - V[2] * vp[1]);
    a[1] = (B[2] * p[0] - B[0] * p[2]) + B[4] + (V[2] * vp[0] - V[0] * vp[2]);
    a[2] = (B[0] * p[1] - B[1] * p[0]) + B[5] + (V[0] * vp[1] - V[1] * vp[0]);
    return 1;
}

/* fs_point_bias for a body-body pair: a = a_B - a_A, each body's material point at p, vp = v_rel =
 * v_B - v_A there (the pair table's, compiler/contact/pairs.law_slopes).  order: the chain ascending
 * (fs_speed), B's own speeds as s, A's as ~s (either side may be empty).  Each body's bias is the
 * ground's over its whole path to the root, a_X = B^X_w x p + B^X_v + w_X x vp_X; the shared speeds
 * (the path above the bodies' deepest common ancestor: parent[] from the chain's first speed) add the
 * same V x S to B^B and B^A, so only their sum V0 is needed, which both sides' own speeds start from:
 *
 *   a = D_w x p + D_v + w_B x vp + (w_B - w_A) x vp_A,   D = B^B - B^A,   vp_A = v_A + w_A x p
 *
 * (w_B x vp_B - w_A x vp_A with vp_B = vp + vp_A).  The shared speeds do not cancel: their axes turn
 * the relative velocity (w_k x v_rel), so leaving the pair's own chain alone would miss them (a pair
 * whose A is an ancestor of B, e.g. gymnasium humanoid's butt against a foot, took the ground's formula
 * over B's own speeds with vp = v_rel before session 28: V0 and A's velocity left out). */
static int fs_pair_bias(const eomc_implicit *imp, const double *scr, const double *u, const int *order, int m,
                        const double *p, const double *vp, double *a)
{
    double V0[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0}, D[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0}, VB[6], VA[6];
    double pa[3], dw[3], Vg[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    for (int k = imp->parent[fs_speed(order[0])]; k >= 0; k = imp->parent[k])
        for (int x = 0; x < 6; x++) V0[x] += scr[6 * (size_t)k + x] * u[k];
    memcpy(VB, V0, sizeof VB);
    memcpy(VA, V0, sizeof VA);
    for (int i = 0; i < m; i++) {
        int k = fs_speed(order[i]), own = 0;
        const double *w = scr + 6 * (size_t)k, *Vk;
        double S[6], *V = order[i] >= 0 ? VB : VA, X[6];
        for (int x = 0; x < 6; x++) S[x] = w[x] * u[k];
        for (int r = 0; r < imp->nfree; r++) own |= k >= imp->free[r] && k < imp->free[r] + 6;
        Vk = V;
        if (imp->joint) {                             /* that side's V before k's joint (one side's
                                                         speeds: a joint moves one body) */
            if (imp->joint[k] == k) memcpy(Vg, V, sizeof Vg);
            Vk = Vg;
        }
        if (!own) {                                   /* D +-= V x S, V that side's speeds before k */
            X[0] = Vk[1] * S[2] - Vk[2] * S[1];
            X[1] = Vk[2] * S[0] - Vk[0] * S[2];
            X[2] = Vk[0] * S[1] - Vk[1] * S[0];
            X[3] = (Vk[1] * S[5] - Vk[2] * S[4]) + (Vk[4] * S[2] - Vk[5] * S[1]);
            X[4] = (Vk[2] * S[3] - Vk[0] * S[5]) + (Vk[5] * S[0] - Vk[3] * S[2]);
            X[5] = (Vk[0] * S[4] - Vk[1] * S[3]) + (Vk[3] * S[1] - Vk[4] * S[0]);
            if (order[i] >= 0)
                for (int x = 0; x < 6; x++) D[x] += X[x];
            else
                for (int x = 0; x < 6; x++) D[x] -= X[x];
        }
        for (int x = 0; x < 6; x++) V[x] += S[x];
    }
    pa[0] = VA[3] + (VA[1] * p[2] - VA[2] * p[1]);
    pa[1] = VA[4] + (VA[2] * p[0] - VA[0] * p[2]);
    pa[2] = VA[5] + (VA[0] * p[1] - VA[1] * p[0]);
    for (int x = 0; x < 3; x++) dw[x] = VB[x] - VA[x];
    a[0] = (D[1] * p[2] - D[2] * p[1]) + D[3] + (VB[1] * vp[2] - VB[2] * vp[1]) + (dw[1] * pa[2] - dw[2] * pa[1]);
    a[1] = (D[2] * p[0] - D[0] * p[2]) + D[4] + (VB[2] * vp[0] - VB[0] * vp[2]) + (dw[2] * pa[0] - dw[0] * pa[2]);
    a[2] = (D[0] * p[1] - D[1] * p[0]) + D[5] + (VB[0] * vp[1] - VB[1] * vp[0]) + (dw[0] * pa[1] - dw[1] * pa[0]);
    return 1;
}
#define FS_TOUCH 64     /* fs_secants lists up to this many contacts in touch for fs_assemble */
static int fs_secants(const eomc_implicit *imp, const double *E, double *cache, int *touch);

static int fs_assemble(const eomc_fs_ops *ops, const fs_layout *L, double h, const double *u,
                       const double *T, double *A, double *b, double *GJ, double *cache, int *cached,
                       int *touch, int *ntl, const fs_pattern *pat, int *own, const int **start,
                       const int **anc)
{
    const eomc_implicit *imp = ops->imp;
    int nu = ops->nu, grown = 0, ntouch = *cached ? *ntl : -1;
    const double *scr = T + L->screw, *jl = T + L->joint;
    if (imp->terms_whole) imp->terms_whole((double *)T);    /* T: the run's T or T1 (writable) */
    memcpy(A, T + L->M, (size_t)nu * nu * sizeof(double));
    memcpy(b, T + L->f, (size_t)nu * sizeof(double));
    for (int r = 0; r < imp->nfree; r++) fs_transport(A, T + L->M, u, imp->free[r], nu, h);
    for (int s = 0; s < nu; s++) {                   /* joint laws: diagonal */
        /* their semidefinite part only (a limit's damping, as it fades in past the limit,
         * can have a negative slope in q) */
        double d = jl[2 * s] > 0.0 ? jl[2 * s] : 0.0, k = jl[2 * s + 1] > 0.0 ? jl[2 * s + 1] : 0.0;
        if (d != 0.0 || k != 0.0) {
            A[(size_t)s * nu + s] += h * d + h * h * k;
            b[s] -= h * k * u[s];
        }
    }
    if (!*cached) ntouch = *ntl = fs_secants(imp, T + L->contact, cache, touch);
    for (int t = 0; t < (ntouch >= 0 ? ntouch : imp->ncontact); t++) {
        int c = ntouch >= 0 ? touch[t] : t;
        const double *e = T + L->contact + 25 * (size_t)c, *p, *vp, *K, *C;
        const int *cols;
        int m, any = 0;
        double G[9], *Cs, *Kv, *filled, *J, *JKv;
        if (!(e[0] > 0.0)) continue;                  /* not touching: no force, no slope (the scan
                                                         over every contact: only the depth read;
                                                         touch[] lists them, made by fs_secants when
                                                         the cache was: the buffer unchanged since) */
        p = e + 1; vp = e + 4; K = e + 7; C = e + 16;
        cols = imp->chain + imp->chain_start[c];
        m = imp->chain_start[c + 1] - imp->chain_start[c];
        Cs = cache; Kv = Cs + 9; filled = Kv + 3; J = filled + 1; JKv = J + 3 * m;
        cache = JKv + m;
        C = Cs;                                       /* (fs_secants made it, filled 0) */
        for (int a = 0; a < 9; a++) {
            G[a] = h * C[a] + h * h * K[a];
            any |= G[a] != 0.0;
        }
        if (!any) continue;
        if (pat->tree && pat->cross[c]) {             /* a pressed pair across two branches */
            if (!grown) memcpy(pat->bits, pat->tree, (size_t)nu * sizeof *pat->bits);
            grown = 1;
            fs_couple(pat, imp, c);
        }
        if (*filled == 0.0) {                         /* (a contact with G = 0 at one h has none) */
            double ab[3] = {0.0, 0.0, 0.0};           /* Kv = K v + C a: fs_point_bias */
            int bias = fs_point_bias(imp, scr, u, cols, m, p, vp, ab);
            for (int a = 0; a < 3; a++) {
                Kv[a] = K[3 * a] * vp[0] + K[3 * a + 1] * vp[1] + K[3 * a + 2] * vp[2];
                if (bias) Kv[a] += C[3 * a] * ab[0] + C[3 * a + 1] * ab[1] + C[3 * a + 2] * ab[2];
            }
            for (int k = 0; k < m; k++) {             /* J[:, k] = ±(w x p + v0) of speed cols[k] */
                const double *w = scr + 6 * (size_t)fs_speed(cols[k]), *v0 = w + 3;
                double *j = J + 3 * k;
                j[0] = v0[0] + w[1] * p[2] - w[2] * p[1];
                j[1] = v0[1] + w[2] * p[0] - w[0] * p[2];
                j[2] = v0[2] + w[0] * p[1] - w[1] * p[0];
                if (cols[k] < 0) {                    /* a pair's first body: v_rel = v_B - v_A */
                    j[0] = -j[0];
                    j[1] = -j[1];
                    j[2] = -j[2];
                }
                JKv[k] = j[0] * Kv[0] + j[1] * Kv[1] + j[2] * Kv[2];
            }
            *filled = 1.0;
        }
        /* G J by its rows (g0, g1, g2: contiguous in k) and the chain's speeds decoded once (sp, for
         * chains up to FS_CHAIN long) instead of m times each in the m x m scatter: the same products
         * and sums in the same order, so the same bits.  Why: perf put this scatter at 18-22 % of
         * fs_assemble on the ant and the humanoid, fs_speed's decoding another 3-4 %.  Measured
         * (session 25; bench_fixedstep's qpos0 runs, the integrator libraries side by side in one
         * process, 3 copies each, core 1, load 10-19): hopper +-1 %, walker2d -3 %, ant -2 to -3 %,
         * humanoid -2 to -4 % (benchmarks/results/fixedstep.md's notes).  The scatter goes by the chain's
         * runs of consecutive speeds (run[]: a foot's chain on gymnasium's humanoid is one run 0..12), in
         * vectors (FS_VEC), each lane the scalar sum: the same bits.  Measured (session 32, rdtsc medians
         * of this contact loop in the humanoid's T2 run, base32's library against this, load 4-7): a
         * fresh assembly 1534-1586 -> 1352-1404 ticks, one for another h (the cache read, the scatter
         * left) 1248-1300 -> 936-1040; the ant's chains (7-8 speeds) 1586-1612 -> 1560. */
        {
            double *g0 = GJ, *g1 = GJ + m, *g2 = GJ + 2 * m;
            int sp[FS_CHAIN], run[FS_CHAIN + 1], *spd = m <= FS_CHAIN ? sp : NULL, nrun = 0;
            for (int k = 0; k < m; k++) {
                const double *j = J + 3 * k;
                int sk = fs_speed(cols[k]);
                if (spd) {
                    spd[k] = sk;
                    if (k == 0 || sk != spd[k - 1] + 1) run[nrun++] = k;   /* a run of speeds starts */
                }
                g0[k] = G[0] * j[0] + G[1] * j[1] + G[2] * j[2];
                g1[k] = G[3] * j[0] + G[4] * j[1] + G[5] * j[2];
                g2[k] = G[6] * j[0] + G[7] * j[1] + G[8] * j[2];
                b[sk] -= h * JKv[k];
            }
            run[nrun] = m;
            for (int a = 0; a < m; a++) {
                const double *ja = J + 3 * a;
                double j0 = ja[0], j1 = ja[1], j2 = ja[2];
                double *row = A + (size_t)fs_speed(cols[a]) * nu;
                if (spd)
                    for (int g = 0; g < nrun; g++) {
                        int i = 0, len = run[g + 1] - run[g];
                        double *r = row + spd[run[g]];
                        const double *h0 = g0 + run[g], *h1 = g1 + run[g], *h2 = g2 + run[g];
#ifdef FS_VEC
                        for (; i + 3 < len; i += 4)
                            *(fs_v4 *)(r + i) += j0 * *(const fs_v4 *)(h0 + i) + j1 * *(const fs_v4 *)(h1 + i)
                                                 + j2 * *(const fs_v4 *)(h2 + i);
                        if (i + 1 < len) {
                            *(fs_v2 *)(r + i) += j0 * *(const fs_v2 *)(h0 + i) + j1 * *(const fs_v2 *)(h1 + i)
                                                 + j2 * *(const fs_v2 *)(h2 + i);
                            i += 2;
                        }
#endif
                        for (; i < len; i++) r[i] += j0 * h0[i] + j1 * h1[i] + j2 * h2[i];
                    }
                else
                    for (int k = 0; k < m; k++) row[fs_speed(cols[k])] += j0 * g0[k] + j1 * g1[k] + j2 * g2[k];
            }
        }
    }
    *cached = 1;
    *start = pat->start;
    *anc = pat->anc;
    if (grown) {
        fs_fill(pat, own);
        *start = own;
        *anc = own + nu + 1;
    }
    /* M's own tree pattern (pat->tree: the lists are parent[]'s ancestors alone): the model's
     * straight-line twin of the loop where it has one (eomc_implicit.tree_lu), the same bits */
    if (!grown && pat->tree && imp->tree_lu ? imp->tree_lu(A) : fs_tree_lu(nu, A, *start, *anc))
        return EOMC_SINGULAR_MASS_MATRIX;
    return EOMC_OK;
}

/* ------------------------------------------------ the assembly in lanes (eomc_fixedstep.h)
 *
 * Why: in an implicitfast rollout in lanes (eomc_rollout.c) the model call is one batch call for
 * a group of rows, but each row's fs_assemble stayed scalar: on G1 (35 speeds, eight foot spheres)
 * perf put it at about 40 % of the integrator's time, most of it fs_tree_lu's indirect updates
 * (about 3200 of them per step).  Here the same updates run on vectors of one entry of every lane's
 * matrix, the slots of M's tree pattern (fs_columns) listed once in the elimination's order. */

/* One elimination pattern of the lanes' matrices, over the slots of every pair's fill (the slot
 * map: eomc_fs_lanes.slot): its lists (fs_ancestors'), per entry x the slots (anc[x], k) and (k,
 * anc[x]) (lo, up), the factorisation's slots in its order (upd: per k from nu - 1 down, the na
 * slots (k, a[y]); per x, (a[x], k) and the na slots (a[x], a[y])), and the slots it has (the ones
 * the kernel fills from M). */
typedef struct fsl_pattern {
    int *start, *anc, *lo, *up, *upd, *slots;
    int nslots;
} fsl_pattern;

/* The grown patterns kept (fsl_grow).  Measured (bench_rollout_contacts' humanoid, 64 rows, lanes
 * 8, session 32): of 3402 calls that grow a pattern, 763 made theirs anew with one kept, 164 with 8;
 * the rollout 0.6-1.7 % faster (one process switching call by call, 20-30 calls a side, core 1,
 * load 3-4), same bits (a pattern is a function of its bits). */
#define FSL_GROWN 8

struct eomc_fs_lanes {
    fs_layout L;
    int nq, nu, lanes, width, nslot;   /* width: the kernel's lanes (lanes: a multiple of it) */
    const eomc_implicit *imp;
    void (*kernel)(eomc_fs_lanes *, const double *, const double *, size_t, eomc_fs_request *const *,
                   double *const *, const double *const *, size_t, size_t);
    int *slot_ij;        /* nslot: i * nu + j of each slot (M's pattern, row by row) */
    int *slot;           /* nu * nu: the slot of (i, j), -1 off the pattern */
    int *diag;           /* nu: the slot of (i, i) */
    int *start, *anc;    /* fs_ancestors */
    int *cstart;         /* nu + 1: row i's slots are cstart[i] .. cstart[i + 1] (fs_columns) */
    int *lo, *up;        /* per entry x of anc (speed k's list): the slots (anc[x], k), (k, anc[x]) */
    int *upd;            /* per k from nu - 1 down: the na slots (k, a[y]); per x, (a[x], k) and
                            the na slots (a[x], a[y]) */
    int *cslot_start, *cslot;  /* per contact, the m x m slots (chain[a], chain[k]) */
    /* The pattern a call factors with (as the scalar fs_assemble's per-step fill, fs_pattern): M's
     * tree's (base), or, when a body-body pair across two branches has a depth > 0 in one of the
     * group's lanes, the tree's with the fill of every such pair (grown: the last FSL_GROWN such
     * patterns made, each kept with its bits gbits until the least recently used is made over).
     * full: every pair's fill (the slot map's), the pattern when M has no tree or more than 64
     * speeds (dyn 0).  mstart, mcols: M's row i's columns that can be nonzero (base's:
     * fs_columns), read by the residual's product and the transport. */
    fsl_pattern full, base, grown[FSL_GROWN];
    int dyn, ngrown;                  /* ngrown: the grown patterns made room for (FSL_GROWN with dyn, else 1:
                                         each the size of full's, which grows as nu^3 on a chain) */
    long gused[FSL_GROWN], gclock;    /* when each was last returned (0: never made) */
    int *mstart, *mcols;
    unsigned long long *tbits, *xbits, *gbits, *bits;   /* nu: the tree's; nc: each contact's speeds;
                                                           FSL_GROWN nu: grown's; nu: scratch */
    int *xon, *touch;                 /* nc each: the kernel's scratch (the ones in touch) */
    unsigned char *cross;             /* nc: 1 for the contacts across two branches (dyn) */
    unsigned char *mark;              /* nslot bytes (fsl_lists) */
    void *pmem;
    double *A, *b, *J, *GJ;    /* 64-byte aligned: nslot, nu, 3 nu, 3 nu vectors of lanes */
    double *D, *R, *V;         /* nu, nu, nq vectors: fs_fast_try's du and dv, the rate */
    void *mem;
    int *nstart, *ncol;        /* nq + 1, nq nu: N's columns not a constant 0 per row (fs_nlists' lists) */
    int *border;               /* per chain entry (imp->chain's order): each contact's chain sorted by speed */
    unsigned char *bflag;      /* per chain entry of border: 1 a root free joint's speed, 2 its joint's first */
    signed char *bpair;        /* nc: FSL_BIAS's case: 0 one branch, 1 a pair's (fs_pair_bias), -1 none */
    unsigned test_fail;        /* test hook: kernel lanes (bit l: lane l of every group) marked
                                  failed, as a failed pivot is ($EOMC_TEST_FS_LANES_FAIL, read once) */
};

/* Two kernels: 4 lanes (AVX2; a batch of 8 in two groups) and 8 lanes (AVX-512F and DQ: a batch of
 * 8 in one group), the 8-wide where the machine has it.  Same bits either way (each lane is the
 * scalar code).  Session 20 measured the 8-wide slower on G1 (3.3 against 2.6 us a row; eight
 * interleaved matrices past the 32 KB L1) and Go2 (110 against 106 ms) and kept the 4-wide only;
 * since, the kernel took the secant, the point bias and the next try's solves (FSL_SECANT, FSL_BIAS,
 * FSL_STEP), and measured again (session 28; bench_rollout_contacts' 64 rows, one process, the two
 * kernels alternating call by call, core 1, thread CPU, medians of 8-20, load 12-19) the 8-wide
 * took 0.83-0.95 of the 4-wide's rollout: hopper 0.87, walker2d 0.83, ant 0.86-0.95, humanoid
 * 0.94-0.95, Go2 0.85, G1 0.885 -- same bits.  $EOMC_FS_LANES_WIDTH=4 keeps the 4-wide (the tests
 * run both; read once per rollout thread). */
/* P's lo, up, upd and slots from its lists start and anc, through w's slot map; 0, or -1 when an
 * entry of the pattern has no slot (not a pattern within every pair's fill). */
static int fsl_lists(eomc_fs_lanes *w, fsl_pattern *P)
{
    const size_t n = (size_t)w->nu;
    int nupd = 0, ns = 0;
    memset(w->mark, 0, (size_t)w->nslot);
    for (size_t k = 0; k < n; k++) {
        if (w->slot[k * n + k] < 0) return -1;
        w->mark[w->slot[k * n + k]] = 1;
    }
    for (int k = w->nu - 1; k >= 0; k--) {
        const int *a = P->anc + P->start[k];
        int na = P->start[k + 1] - P->start[k];
        for (int y = 0; y < na; y++) P->upd[nupd++] = w->slot[(size_t)k * n + (size_t)a[y]];
        for (int x = 0; x < na; x++) {
            P->upd[nupd++] = w->slot[(size_t)a[x] * n + (size_t)k];
            for (int y = 0; y < na; y++) P->upd[nupd++] = w->slot[(size_t)a[x] * n + (size_t)a[y]];
        }
    }
    for (int i = 0; i < nupd; i++)
        if (P->upd[i] < 0) return -1;
    for (int k = 0; k < w->nu; k++)
        for (int x = P->start[k]; x < P->start[k + 1]; x++) {
            P->lo[x] = w->slot[(size_t)P->anc[x] * n + (size_t)k];
            P->up[x] = w->slot[(size_t)k * n + (size_t)P->anc[x]];
            if (P->lo[x] < 0 || P->up[x] < 0) return -1;
            w->mark[P->lo[x]] = w->mark[P->up[x]] = 1;
        }
    for (int x = 0; x < w->nslot; x++)
        if (w->mark[x]) P->slots[ns++] = x;
    P->nslots = ns;
    return 0;
}

#ifdef EOMC_FS_LANES    /* the lanes' kernel is its one caller (unused, and a warning, without it) */
/* The pattern for the tree with the fill of the contacts xs[0 .. nx) (each across two branches):
 * fs_couple and fs_fill's bits and lists (the scalar path's for the same pressed pairs), kept in
 * one of w->grown for the next calls with the same bits (the least recently used made over). */
static const fsl_pattern *fsl_grow(eomc_fs_lanes *w, const int *xs, int nx)
{
    const eomc_implicit *imp = w->imp;
    const int n = w->nu;
    unsigned long long *m = w->bits;
    int pos = 0;
    memcpy(m, w->tbits, (size_t)n * sizeof *m);
    for (int i = 0; i < nx; i++)
        for (int x = imp->chain_start[xs[i]]; x < imp->chain_start[xs[i] + 1]; x++) {
            int sp = fs_speed(imp->chain[x]);
            m[sp] |= w->xbits[xs[i]] & ((1ULL << sp) - 1);
        }
    for (int k = n - 1; k >= 0; k--)
        for (int i = k - 1; i >= 0; i--)
            if (m[k] >> i & 1) m[i] |= m[k] & ((1ULL << i) - 1);
    int g = 0;
    fsl_pattern *P;
    w->gclock++;
    for (int j = 0; j < w->ngrown; j++) {
        if (w->gused[j] && memcmp(m, w->gbits + (size_t)j * n, (size_t)n * sizeof *m) == 0) {
            w->gused[j] = w->gclock;
            return &w->grown[j];
        }
        if (w->gused[j] < w->gused[g]) g = j;        /* the least recently used (or one never made) */
    }
    P = &w->grown[g];
    for (int k = 0; k < n; k++) {
        P->start[k] = pos;
        for (int i = k - 1; i >= 0; i--)
            if (m[k] >> i & 1) P->anc[pos++] = i;
    }
    P->start[n] = pos;
    w->gused[g] = 0;
    if (fsl_lists(w, P)) return &w->full;
    memcpy(w->gbits + (size_t)g * n, m, (size_t)n * sizeof *m);
    w->gused[g] = w->gclock;
    return P;
}

#include <immintrin.h>
#define FSL_W 4
#define FSL_TARGET "avx2"
#include "eomc_fs_lanes_body.h"
#undef FSL_W
#undef FSL_TARGET
#ifndef EOMC_FS_AVX2_COPY
#define FSL_W 8
#define FSL_TARGET "avx512f,avx512dq"
#include "eomc_fs_lanes_body.h"
#undef FSL_W
#undef FSL_TARGET
#endif

/* fs_secant_friction of the contacts K[l], C[l] into Cs[l], l < cnt <= 4, at once: the lanes' own
 * (fsl_secant4: the scalar's bits in every lane); a lane past cnt repeats contact 0, its answer
 * dropped. */
__attribute__((target("avx2"))) static void fs_secants4(const double *const *K, const double *const *C,
                                                        double *const *Cs, int cnt)
{
    fsl_v4 k[9], c[9], o[9];
    for (int a = 0; a < 9; a++)
        for (int l = 0; l < 4; l++) {
            k[a][l] = K[l < cnt ? l : 0][a];
            c[a][l] = C[l < cnt ? l : 0][a];
        }
    fsl_secant4(k, c, o);
    for (int l = 0; l < cnt; l++)
        for (int a = 0; a < 9; a++) Cs[l][a] = o[a][l];
}
#endif

/* The secant slope (fs_secant_friction) of every contact in touch, into its slot of fs_assemble's
 * cache (in slot order: the contacts in touch in turn, 13 + 4 m doubles each), its "filled" flag
 * cleared; E: the terms' contact entries (25 doubles each).  touch[]: the contacts in touch, their
 * number returned (-1 past FS_TOUCH: fs_assemble then scans every contact again).  Where the CPU has
 * AVX2, four at a time (three or more): each secant is a chain of three square roots and two
 * divisions, about 200 cycles of latency (perf of a harness over the ant's 121 qpos0 assemblies: 21 %
 * of fs_assemble, with four feet down), which one contact after another did not overlap; in the
 * lanes' four they take one chain.  The same bits (the lanes' secant is the scalar's, operation for
 * operation, branches as selects). */
#define FS_SECANTS_MIN 3     /* fewer contacts in touch: one by one (two lanes of four did not pay
                                on the humanoid's two feet, harness of its 455 qpos0 assemblies) */
static int fs_secants(const eomc_implicit *imp, const double *E, double *cache, int *touch)
{
    const double *K[4], *C[4];
    double *Cs[4];
    int cnt = 0, wide = 0, nt = 0;
#ifdef EOMC_FS_LANES
    wide = __builtin_cpu_supports("avx2");
#endif
    for (int c = 0; c < imp->ncontact; c++) {
        const double *e = E + 25 * (size_t)c;
        if (!(e[0] > 0.0)) continue;
        if (nt >= 0 && nt < FS_TOUCH) touch[nt++] = c;
        else nt = -1;
        cache[12] = 0.0;                              /* filled: not yet (fs_assemble) */
        if (!wide) {
            fs_secant_friction(e + 7, e + 16, cache);
        } else {
            K[cnt] = e + 7;
            C[cnt] = e + 16;
            Cs[cnt++] = cache;
        }
        cache += 13 + 4 * (size_t)(imp->chain_start[c + 1] - imp->chain_start[c]);
#ifdef EOMC_FS_LANES
        if (cnt == 4) {
            fs_secants4(K, C, Cs, 4);
            cnt = 0;
        }
#endif
    }
#ifdef EOMC_FS_LANES
    if (cnt >= FS_SECANTS_MIN) {
        fs_secants4(K, C, Cs, cnt);
        cnt = 0;
    }
#endif
    for (int l = 0; l < cnt; l++) fs_secant_friction(K[l], C[l], Cs[l]);
    return nt;
}

#ifndef EOMC_FS_AVX2_COPY
void eomc_fs_lanes_free(eomc_fs_lanes *w)
{
    if (w == NULL) return;
    free(w->nstart);
    free(w->mem);
    free(w->slot_ij);
    free(w->pmem);
    free(w);
}

/* a pattern's arrays at the sizes of every pair's fill's (nanc entries, nupd updates), from *pos */
static void fsl_carve(fsl_pattern *P, int **pos, int nu, int nanc, int nupd, int nslot)
{
    P->start = *pos; *pos += nu + 1;
    P->anc = *pos; *pos += nanc;
    P->lo = *pos; *pos += nanc;
    P->up = *pos; *pos += nanc;
    P->upd = *pos; *pos += nupd;
    P->slots = *pos; *pos += nslot;
}

eomc_fs_lanes *eomc_fs_lanes_new(int nq, int nu, const eomc_implicit *imp, int lanes)
{
    eomc_fs_lanes *w;
    int *slot = NULL, *cstart, *cols, nc = imp ? imp->ncontact : 0, ncs = 0, nupd = 0, pos, nanc;
    size_t n = (size_t)nu, ints;
    void (*kernel)(eomc_fs_lanes *, const double *, const double *, size_t, eomc_fs_request *const *,
                   double *const *, const double *const *, size_t, size_t) = NULL;
    int width = 0;
#ifdef EOMC_FS_LANES
    __builtin_cpu_init();
    if ((lanes == 4 || lanes == 8) && __builtin_cpu_supports("avx2")) { kernel = fs_lanes_kernel4; width = 4; }
    if (lanes == 8 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq")) {
        const char *only = getenv("EOMC_FS_LANES_WIDTH");
        if (only == NULL || strtol(only, NULL, 10) != 4) { kernel = fs_lanes_kernel8; width = 8; }
    }
#endif
    if (kernel == NULL || imp == NULL || nu <= 0 || nc < 0 || (nc > 0 && (!imp->chain_start || !imp->chain)))
        return NULL;
    if ((w = (eomc_fs_lanes *)calloc(1, sizeof *w)) == NULL) return NULL;
    w->L = fs_layout_of(nq, nu, nc);
    w->nq = nq; w->nu = nu; w->lanes = lanes; w->width = width; w->imp = imp; w->kernel = kernel;
    {   /* the pivot-fail fallback's test (tests/runtime/test_rollout_lanes.py): no data makes a
         * lane fail where its row's own assembly passes, as the two are the same arithmetic */
        const char *fail = getenv("EOMC_TEST_FS_LANES_FAIL");
        w->test_fail = fail ? (unsigned)strtoul(fail, NULL, 0) : 0u;
    }
    for (int c = 0; c < nc; c++) {
        size_t m = (size_t)(imp->chain_start[c + 1] - imp->chain_start[c]);
        ncs += (int)(m * m);
    }
    /* ints: slot map (nu^2), start (nu+1), anc (nu^2), cstart (nu+1), cols (nu^2), diag (nu),
     * slot_ij (nu^2), upd (at most nu^2 (nu + 1)), cslot_start (nc + 1), cslot, lo and up (nu^2 each) */
    ints = 6 * n * n + 3 * n + 2 + n * n * (n + 1) + (size_t)nc + 1 + (size_t)ncs;
    if ((w->slot_ij = (int *)malloc(ints * sizeof(int))) == NULL) { free(w); return NULL; }
    slot = w->slot_ij + n * n;
    w->start = slot + n * n;
    w->anc = w->start + n + 1;
    cstart = w->anc + n * n;
    cols = cstart + n + 1;
    w->diag = cols + n * n;
    w->upd = w->diag + n;
    {
        unsigned char *mark = (unsigned char *)malloc(n * n + 1);
        if (mark == NULL) { eomc_fs_lanes_free(w); return NULL; }
        fs_ancestors(nu, imp->parent, imp, mark, w->start, w->anc);
        free(mark);
    }
    fs_columns(nu, w->start, w->anc, cstart, cols);
    w->cstart = cstart;
    w->slot = slot;
    for (size_t i = 0; i < n * n; i++) slot[i] = -1;
    w->nslot = cstart[nu];
    for (int i = 0; i < nu; i++)
        for (int x = cstart[i]; x < cstart[i + 1]; x++) {
            w->slot_ij[x] = i * nu + cols[x];
            slot[(size_t)i * n + cols[x]] = x;
        }
    for (int i = 0; i < nu; i++) w->diag[i] = slot[(size_t)i * n + i];
    for (int k = nu - 1; k >= 0; k--) {
        const int *a = w->anc + w->start[k];
        int na = w->start[k + 1] - w->start[k];
        for (int y = 0; y < na; y++) w->upd[nupd++] = slot[(size_t)k * n + a[y]];
        for (int x = 0; x < na; x++) {
            w->upd[nupd++] = slot[(size_t)a[x] * n + k];
            for (int y = 0; y < na; y++) w->upd[nupd++] = slot[(size_t)a[x] * n + a[y]];
        }
    }
    w->cslot_start = w->upd + nupd;
    w->cslot = w->cslot_start + nc + 1;
    pos = 0;
    for (int c = 0; c < nc; c++) {
        const int *ch = imp->chain + imp->chain_start[c];
        int m = imp->chain_start[c + 1] - imp->chain_start[c];
        w->cslot_start[c] = pos;
        for (int a = 0; a < m; a++)
            for (int k = 0; k < m; k++) w->cslot[pos++] = slot[(size_t)fs_speed(ch[a]) * n + fs_speed(ch[k])];
    }
    w->cslot_start[nc] = pos;
    w->lo = w->cslot + pos;
    w->up = w->lo + n * n;
    for (int k = 0; k < nu; k++)
        for (int x = w->start[k]; x < w->start[k + 1]; x++) {
            w->lo[x] = slot[(size_t)w->anc[x] * n + k];
            w->up[x] = slot[(size_t)k * n + w->anc[x]];
        }
    for (int i = 0; i < nupd; i++)
        if (w->upd[i] < 0) { eomc_fs_lanes_free(w); return NULL; }   /* not a tree pattern */
    for (int x = 0; x < w->start[nu]; x++)
        if (w->lo[x] < 0 || w->up[x] < 0) { eomc_fs_lanes_free(w); return NULL; }
    for (int i = 0; i < pos; i++)
        if (w->cslot[i] < 0) { eomc_fs_lanes_free(w); return NULL; }  /* a chain not on one path */
    nanc = w->start[nu];
    {   /* the patterns: full (the lists above), base and grown (dyn: M's tree given, nu <= 64) */
        size_t pints, words, bytes;
        int *p;
        w->dyn = imp->parent != NULL && nu <= 64;
        w->ngrown = w->dyn ? FSL_GROWN : 1;
        pints = (2 + (size_t)w->ngrown) * ((size_t)nu + 1 + 3 * (size_t)nanc + (size_t)nupd + (size_t)w->nslot)
                + (size_t)nu + 1 + (size_t)w->nslot + 2 * (size_t)nc;   /* the patterns, mstart, mcols, xon, touch */
        words = (2 + (size_t)w->ngrown) * n + (size_t)nc;                /* tbits, gbits, bits, xbits */
        bytes = pints * sizeof(int) + words * sizeof(unsigned long long) + (size_t)w->nslot + (size_t)nc;
        if ((w->pmem = calloc(1, bytes)) == NULL) {
            eomc_fs_lanes_free(w);
            return NULL;
        }
        w->tbits = (unsigned long long *)w->pmem;
        w->gbits = w->tbits + n;
        w->bits = w->gbits + (size_t)w->ngrown * n;
        w->xbits = w->bits + n;
        p = (int *)(w->xbits + nc);
        fsl_carve(&w->full, &p, nu, nanc, nupd, w->nslot);
        fsl_carve(&w->base, &p, nu, nanc, nupd, w->nslot);
        for (int g = 0; g < w->ngrown; g++) fsl_carve(&w->grown[g], &p, nu, nanc, nupd, w->nslot);
        w->mstart = p; p += nu + 1;
        w->mcols = p; p += w->nslot;
        w->xon = p; p += nc;
        w->touch = p; p += nc;
        w->mark = (unsigned char *)p;
        w->cross = w->mark + w->nslot;
        memcpy(w->full.start, w->start, (n + 1) * sizeof(int));
        memcpy(w->full.anc, w->anc, (size_t)nanc * sizeof(int));
        if (fsl_lists(w, &w->full)) { eomc_fs_lanes_free(w); return NULL; }
        if (w->dyn) {
            unsigned char *mark = (unsigned char *)malloc(n * n + 1);
            if (mark == NULL) { eomc_fs_lanes_free(w); return NULL; }
            fs_ancestors(nu, imp->parent, NULL, mark, w->base.start, w->base.anc);
            free(mark);
            if (w->base.start[nu] > nanc || fsl_lists(w, &w->base)) w->dyn = 0;
        }
        if (w->dyn) {
            for (int k = 0; k < nu; k++) {
                w->tbits[k] = 0;
                for (int x = w->base.start[k]; x < w->base.start[k + 1]; x++) w->tbits[k] |= 1ULL << w->base.anc[x];
            }
            for (int c = 0; c < nc; c++) {     /* a chain that is not on one path joins two branches */
                unsigned long long m = 0;
                int path = 1;
                for (int x = imp->chain_start[c]; x < imp->chain_start[c + 1]; x++) m |= 1ULL << fs_speed(imp->chain[x]);
                for (int x = imp->chain_start[c]; x < imp->chain_start[c + 1]; x++) {
                    int sp = fs_speed(imp->chain[x]);
                    if (m & ((1ULL << sp) - 1) & ~w->tbits[sp]) path = 0;
                }
                w->xbits[c] = m;
                w->cross[c] = !path;
            }
        }
        fs_columns(nu, w->dyn ? w->base.start : w->full.start, w->dyn ? w->base.anc : w->full.anc, w->mstart,
                   w->mcols);
    }
    {   /* N's lists (fs_nlists: the constant 0 entries found by NAME_implicit_const over NaN) and
           FSL_BIAS's per-contact order and flags (fs_point_bias's, made once) */
        int nch = nc > 0 ? imp->chain_start[nc] : 0, pn = 0;
        size_t bytes = ((size_t)nq + 1 + (size_t)nq * n + (size_t)nch) * sizeof(int) + (size_t)nch + (size_t)nc + 1;
        double *probe = NULL;
        if ((w->nstart = (int *)malloc(bytes)) == NULL) { eomc_fs_lanes_free(w); return NULL; }
        w->ncol = w->nstart + nq + 1;
        w->border = w->ncol + (size_t)nq * n;
        w->bflag = (unsigned char *)(w->border + nch);
        w->bpair = (signed char *)(w->bflag + nch);
        if (imp->terms_const) {
            if ((probe = (double *)malloc(w->L.size * sizeof(double) + 1)) == NULL) { eomc_fs_lanes_free(w); return NULL; }
            for (size_t e = 0; e < w->L.size; e++) probe[e] = NAN;
            imp->terms_const(probe);
        }
        for (int i = 0; i < nq; i++) {
            w->nstart[i] = pn;
            for (int k = 0; k < nu; k++) {
                double v = probe ? probe[w->L.N + (size_t)i * n + (size_t)k] : NAN;
                if (isnan(v) || v != 0.0) w->ncol[pn++] = k;
            }
        }
        w->nstart[nq] = pn;
        free(probe);
        for (int c = 0; c < nc; c++) {
            const int c0 = imp->chain_start[c], m = imp->chain_start[c + 1] - c0;
            int *order = w->border + c0, pair = 0;
            for (int k = 0; k < m; k++) {
                pair |= imp->chain[c0 + k] < 0;
                order[k] = imp->chain[c0 + k];
            }
            for (int i = 1; i < m; i++)
                for (int j = i; j > 0 && fs_speed(order[j - 1]) > fs_speed(order[j]); j--) {
                    int t = order[j];
                    order[j] = order[j - 1];
                    order[j - 1] = t;
                }
            if (m > 0 && imp->parent && imp->parent[fs_speed(order[0])] >= 0) pair = 1;
            w->bpair[c] = m > FS_CHAIN || (pair && !imp->parent) ? -1 : pair;
            for (int i = 0; i < m; i++) {
                int k = fs_speed(order[i]), own = 0;
                for (int r = 0; r < imp->nfree; r++) own |= k >= imp->free[r] && k < imp->free[r] + 6;
                w->bflag[c0 + i] = (unsigned char)(own | (imp->joint && imp->joint[k] == k ? 2 : 0));
            }
        }
    }
    {
        size_t doubles = ((size_t)w->nslot + 9 * n + (size_t)nq) * (size_t)width;
        if ((w->mem = malloc(doubles * sizeof(double) + 64)) == NULL) { eomc_fs_lanes_free(w); return NULL; }
        w->A = (double *)(((size_t)w->mem + 63) & ~(size_t)63);
        w->b = w->A + (size_t)w->nslot * width;
        w->J = w->b + n * width;
        w->GJ = w->J + 3 * n * width;
        w->D = w->GJ + 3 * n * width;
        w->R = w->D + n * width;
        w->V = w->R + n * width;
    }
    return w;
}

void eomc_fs_assemble_lanes(eomc_fs_lanes *w, const double *OUT, const double *U, eomc_fs_request *const *req,
                            double *const *ahead, const double *const *rows, size_t rlo, size_t rhi)
{
    for (int g = 0; g < w->lanes; g += w->width) {
        int any = 0;                     /* a group no lane of which asks: nothing to answer */
        for (int l = 0; l < w->width; l++) any |= req[g + l] != NULL;
        if (any)
            w->kernel(w, OUT + g, U + g, (size_t)w->lanes, req + g, ahead + g, rows ? rows + g : NULL, rlo, rhi);
    }
}

size_t eomc_fs_tested_outputs(int nq, int nu, const eomc_implicit *imp, size_t *idx)
{
    fs_layout L = fs_layout_of(nq, nu, imp->ncontact);
    size_t k = 0;
    for (int i = 0; i < nq; i++)                     /* fs_chart_ratio */
        for (int f = 0; f < imp->nfree; f++)
            for (int j = imp->free[f]; j < imp->free[f] + 6; j++) idx[k++] = L.N + (size_t)i * nu + j;
    for (int i = 0; i < 2 * nu; i++) idx[k++] = L.joint + (size_t)i;              /* fs_switched */
    for (int c = 0; c < imp->ncontact; c++) {
        size_t e = L.contact + 25 * (size_t)c;
        idx[k++] = e;                                           /* depth */
        for (int i = 7; i < 16; i += 4) idx[k++] = e + (size_t)i;   /* K's diagonal: fs_clipped */
    }
    if (imp->energy) idx[k++] = L.energy;              /* the energy watch (fs_loop's accept) */
    return k;
}
#endif

/* The fast path's state for fs_loop.  T, A, b: the terms at the step's start x and (2)'s
 * factored matrix and right side for a step of hA; T1, A1, b1 the same at a trial end
 * (swapped in when the trial is kept: the next step's matrix is then ready). */
typedef struct fs_fast {
    const eomc_fs_ops *ops;
    eomc_stats *st;
    fs_layout L;
    int n;
    double *T, *A, *b, *T1, *A1, *b1;
    double hA;                   /* the step A and b were made for (0: none, or T is stale) */
    int have_T;                  /* T holds the terms at the x fs_loop hands in */
    int deep;                    /* -1, or the first contact found deeper than its limit */
    double *du, *dv, *GJ, *x1, *xs, *f1;
    double *dun;                 /* the next try's du, made with the residual's solve (fs_fast_try) */
    const double *given;         /* NULL, or the next try's du (fs_last_cell's Newton iterates) */
    double *dug, *dub;           /* fs_last_cell: the iterate tried and the best one */
    double *cT, *cT1;            /* fs_assemble's caches for T and T1 */
    int vT, vT1;                 /* ... and whether they hold T's and T1's */
    int tl[2][FS_TOUCH], ntl[2], it;   /* the contacts in touch in T (tl[it]) and T1 (tl[1 - it]),
                                          ascending, made with the caches (fs_secants: valid while vT,
                                          vT1 are; ntl -1: more than FS_TOUCH) or by the lanes (lT, lT1) */
    int lT, lT1;                 /* T's and T1's list given by the lanes' answer (eomc_fs_request.touch) */
    const double *dun_T;         /* for a step from the terms in this buffer (T or T1), NULL: none */
    double dun_h;                /* ... of this size */
    eomc_fs_request req;         /* the lanes rollout's (ops->terms_lu): its last answer */
    const double *bare;          /* A1's (after a swap A's) buffer when the lanes answered without
                                    writing the matrix (req.ahead), else NULL */
    fs_pattern pat;
    const int *start, *anc, *start1, *anc1;   /* A's and A1's elimination lists (fs_assemble) */
    int *own, *own1;                          /* where they are made when a pair adds fill */
    const int *cstart, *cols;    /* per speed, the columns of M's row that can be nonzero */
    const int *nstart, *ncol;    /* per coordinate, the columns of N's row that can be nonzero (fs_nlists) */
    const int *fstart, *fcol;    /* ... and the root free joints' columns where N is not constant */
    double chart;                /* the last try's fs_chart_ratio (0: none) */
} fs_fast;

/* b := A^-1 b, and c := A^-1 c unless c is NULL, A factored over the lists start, anc: the model's
 * straight-line twin (eomc_implicit.tree_solve) where those are M's own tree pattern's, the same
 * operations and bits as the loop */
static void fs_solve(const fs_fast *q, const double *A, const int *start, const int *anc, double *b, double *c)
{
    const eomc_implicit *imp = q->ops->imp;
    if (start == q->pat.start && q->pat.tree && imp->tree_solve)
        imp->tree_solve(A, b, c);
    else if (c)
        fs_tree_solve2(q->ops->nu, A, start, anc, b, c);
    else
        fs_tree_solve(q->ops->nu, A, start, anc, b);
}

/* The columns of N (q' = qd + N u) that a step's products read: per row i, ncol[nstart[i] ..
 * nstart[i + 1]) the columns k whose entry is not a constant 0 (all of them without
 * eomc_implicit.terms_const), ascending, for the try's rate qd + N du; fcol[fstart[i] ..] the root
 * free joints' columns whose entry is not a constant at all, in fs_chart_ratio's order, for its
 * N(q) - N(q1).  Which entries are constants: N's slots are NaN-filled before terms_const writes
 * the constants (NAME_implicit_const writes no non-finite one); the slots left NaN are the ones
 * terms writes at every call.  Why: N is nq x nu but, beside a free joint's rotation, one entry a
 * row (the gymnasium humanoid: 35 of its 529 entries are not a constant 0, and 18 of the 138 in
 * its free joint's columns vary), and the dense rate and chart sums were ~3 % of the humanoid's
 * and ant's checked step (perf, session 23).  The sums skip only terms that are exactly +-0
 * (0 du[k], or c - c for a constant c) in the same order, so they are the same to the bit: a
 * sum that starts at +0 and adds nonzero or +0 terms never meets the -0 + +0 case (and a
 * non-finite du fails the try on x1 either way). */
static void fs_nlists(const eomc_implicit *imp, int nq, int nu, const double *N, int known, int *nstart,
                      int *ncol, int *fstart, int *fcol)
{
    int pos = 0, fpos = 0;
    for (int i = 0; i < nq; i++) {
        const double *row = N + (size_t)i * nu;
        nstart[i] = pos;
        for (int k = 0; k < nu; k++)
            if (!known || isnan(row[k]) || row[k] != 0.0) ncol[pos++] = k;
        fstart[i] = fpos;
        for (int f = 0; f < imp->nfree; f++)
            for (int k = imp->free[f]; k < imp->free[f] + 6; k++)
                if (!known || isnan(row[k])) fcol[fpos++] = k;
    }
    nstart[nq] = pos;
    fstart[nq] = fpos;
}

static void fs_swap(double **a, double **b)
{
    double *t = *a;
    *a = *b;
    *b = t;
}

/* A and A1 swapped with their lists. */
static void fs_swap_lists(fs_fast *q)
{
    const int *s = q->start, *a = q->anc;
    int *o = q->own;
    q->start = q->start1; q->anc = q->anc1; q->own = q->own1;
    q->start1 = s; q->anc1 = a; q->own1 = o;
}

/* One step (2) of size h from (t, x) with T, A, b made for it: x1, then the terms at x1 in
 * T1 and A1, b1 made for another step of h, and *ratio: how far x1 is from solving the
 * implicit Euler equation M(q1) (u1 - u) = h f(q1, u1) that (2) linearises.  The residual
 * r = M1 du - h f1 costs nothing but a product (T1 is the next step's call) and A1^-1 r is
 * Newton's correction to u1: *ratio = |A1^-1 r| / (|du| + h g) (2-norms over the speeds,
 * g = 1 m/s^2 or rad/s^2 keeps a step at rest from counting its rounding).  In free
 * flight and in a steady stance the linearisation is good to O(h^2) and the ratio is
 * small; where the linearisation fails (a limit or contact engaging at speed, a light link
 * whose contact geometry turns unstable inside the step: G1's ankles at 1 ms), it is
 * large, and the step is split (fs_fast_advance). */
/* The lanes' last answer gives this try's du and rate: it was made for the matrix A holds (or
 * would hold: q->bare) and a step of h. */
static int fs_ahead(const fs_fast *q, double h)
{
    return q->req.ahead && q->req.A == q->A && q->req.h == h;
}

/* The configuration's implicit Euler residual, as a ratio: the step took q1 = q + h N(q) u1,
 * implicit Euler would have q1 = q + h N(q1) u1, so |h (N(q) - N(q1)) u1| / (|q1 - q| + h^2 g)
 * (g as RESID_ACCEL), over the root free joints' columns of N (eomc_implicit.free: where N moves
 * with the configuration; a hinge's or slide's column is constant; a ball joint's is not counted).
 * It is O(h) but near gimbal lock of the free joint's body-XYZ angles, where N's 1/cos(ry) swings
 * within the step and the speeds' ratio (below) does not see it: the stiff contacts in A1 swallow
 * the force residual of a misturned body.  Measured (session 16, gymnasium humanoid,
 * bench_rollout_contacts' 64 starts at 3 ms; benchmarks/results/fixedstep.md's notes): rows 7 and
 * 49 each took one whole step with cos(ry) 0.004 and 0.012 whose speeds' ratio passed (0.39, 0.13)
 * and which put the feet and hands 6.5 and 9.6 mm into the floor (Radau from the same state: 0.6
 * and 1.7 mm) and the energy up by 284 and 588 J; this ratio was 1.5 and 4.1 there, median 0.001
 * over all tries.  Session 23 (fixedstep.md's notes): it counts CHART_FACTOR times, and a try it fails
 * is split further whatever halving did to it and never taken as a stick/slip step (fs_fast_advance):
 * the humanoid's rows 2, 4 and 56 took runs of whole steps passing at 0.2-0.38 (+1 to +6 J each),
 * row 49 whole steps failing at 0.72-0.85 taken by the stick/slip rule (+8 J each), row 46 a half-step
 * at 9.4 taken by the halving rule after 3.3 -- near gimbal lock the ratio does not halve with the
 * step.  Over the humanoid's 64 starts: rows flagged by the energy verdict as "the integration is
 * wrong here" 5 -> 1, their rises 116 -> 13 J, calls +2.1 %; the ant, G1 and Go2 take the same steps. */
static double fs_chart_ratio(const fs_fast *q, double h, const double *x)
{
    const eomc_implicit *imp = q->ops->imp;
    int nq = q->ops->nq, nu = q->ops->nu;
    const double *N0 = q->T + q->L.N, *N1 = q->T1 + q->L.N, *u1 = q->x1 + nq;
    double rn = 0.0, dn = 0.0, r;
    if (imp->nfree <= 0) return 0.0;
    for (int i = 0; i < nq; i++) {
        double a = 0.0, d = q->x1[i] - x[i];
        for (int j = q->fstart[i]; j < q->fstart[i + 1]; j++) {   /* the free columns' varying entries */
            int k = q->fcol[j];
            a += (N0[(size_t)i * nu + k] - N1[(size_t)i * nu + k]) * u1[k];
        }
        rn += a * a;
        dn += d * d;
    }
    r = CHART_FACTOR * h * sqrt(rn) / (sqrt(dn) + h * h * RESID_ACCEL);
    return isfinite(r) ? r : INFINITY;
}

/* Whether a contact in touch has its normal force clipped at 0 (the damped law's lift-off,
 * law.clip_switch: the point rising faster than 1 / (1.5 c)): its stiffness slope K (e[7..15],
 * world 3x3) is nil then, and its diagonal's trace is the normal stiffness while it pushes.  The
 * diagonal only: those three are among eomc_fs_tested_outputs (the lanes' rows read them before
 * the rest of the buffer is copied). */
static int fs_clipped(const double *e)
{
    return e[7] == 0.0 && e[11] == 0.0 && e[15] == 0.0;
}

/* Whether a contact touches down inside the step from T to T1 although it is in touch at T: a
 * depth growing more than ONSET_FACTOR-fold (a micro-touch at the start, the contact landing at
 * speed); or from out of touch, deep (fs_deep; session 23: A has no slope of that contact at all,
 * and a try ending millimetres in passed on A1's correction alone -- see fs_lands).  Why, for the first: the step's matrix A has the law's slopes at the start's depth, which for the Hertz
 * law (slopes ~ sqrt(depth)) are nearly nil there, so the step is nearly explicit in that contact
 * -- a touch-down in all but name -- while the residual's Newton correction A1^-1 r has the end's
 * slopes, sqrt(ONSET_FACTOR) or more times stiffer, and from that stiff side of the convex law
 * it falls short of the implicit Euler solution.  So a try that passes with such a contact is
 * measured with A as well (fs_start_ratio), and the touch-down's onset cell is not counted
 * unsolved (fs_switched: FS_TOUCHDOWN, as from out of touch).  Measured (session 17, benchmarks/results/
 * fixedstep.md's notes): gymnasium humanoid, bench_rollout_contacts' row 10 at 3 ms: a shin's end
 * sphere landing at 2.6 m/s, the step starting 0.16 um in touch, 1.6e-7 -> 3.52 mm and +160 J in
 * one whole step taken with ratio 0.12 (|du| 37.9 made large by the same error); a 1 kg MJCF ball
 * dropped at 1-5 m/s from 0.01-0.16 um in touch at 2-5 ms gains 0.06-340 J (status 20 or 10). */
static int fs_deep(const fs_fast *q, int c, double b);

/* The contacts in touch at T or T1 (depth > 0 at either end), ascending, into list (2 FS_TOUCH
 * long), their number returned; -1 when a buffer's list is not known (its cache not made for it,
 * the lanes' answer, or more than FS_TOUCH in touch): the caller then scans every contact.  The
 * scans below read a contact only where its depth is > 0 at one end or the other, so they go over
 * this list instead of every contact's record (138 on gymnasium's humanoid, 200 bytes apart, two
 * buffers): the same answers. */
#define FS_TL(q) (q)->tl[(q)->it], &(q)->ntl[(q)->it]             /* fs_assemble's touch list: T's */
#define FS_TL1(q) (q)->tl[1 - (q)->it], &(q)->ntl[1 - (q)->it]    /* ... T1's */
static int fs_touching(const fs_fast *q, int *list)
{
    const int *a = q->tl[q->it], *b = q->tl[1 - q->it];
    int na = q->ntl[q->it], nb = q->ntl[1 - q->it], x = 0, y = 0, n = 0;
    if (!(q->vT || q->lT) || !(q->vT1 || q->lT1) || na < 0 || nb < 0) return -1;
    while (x < na || y < nb) {
        if (y >= nb || (x < na && a[x] < b[y])) list[n++] = a[x++];
        else if (x >= na || b[y] < a[x]) list[n++] = b[y++];
        else { list[n++] = a[x++]; y++; }
    }
    return n;
}
#define FS_EACH_TOUCHING(q, c)                                                                  \
    int fs_list_[2 * FS_TOUCH], fs_n_ = fs_touching(q, fs_list_);                               \
    for (int fs_x_ = 0, c; fs_x_ < (fs_n_ >= 0 ? fs_n_ : (q)->ops->imp->ncontact)                \
                           && (c = fs_n_ >= 0 ? fs_list_[fs_x_] : fs_x_, 1); fs_x_++)

static int fs_onset(const fs_fast *q)
{
    FS_EACH_TOUCHING(q, c) {
        double a = q->T[q->L.contact + 25 * (size_t)c], b = q->T1[q->L.contact + 25 * (size_t)c];
        if (a > 0.0 ? b > ONSET_FACTOR * a : b > 0.0 && fs_deep(q, c, b)) return 1;
    }
    return 0;
}

/* Whether contact c's end depth b is deep for a touch-down: past LAND_FRACTION of its depth limit
 * (eomc_implicit.depth_limit: the contact's radius, or POINT_DEPTH_FAIL); a contact with no finite
 * limit (a body-body pair) at any depth. */
static int fs_deep(const fs_fast *q, int c, double b)
{
    const double *lim = q->ops->imp->depth_limit;
    return !lim || !isfinite(lim[c]) || b > LAND_FRACTION * lim[c];
}

/* Whether a contact lands deep inside the try: out of touch at its start (depth <= 0), or in touch
 * with a depth growing more than ONSET_FACTOR-fold (fs_onset), and at its end deeper than
 * LAND_FRACTION of its limit (fs_deep).  A failed try with one is split regardless of the halving
 * rule (fs_fast_advance), and one from out of touch that passes is measured with A as well
 * (fs_onset).  Why (session 23, benchmarks/results/fixedstep.md's notes): such a try that passes --
 * with A1's correction (the landed contact's stiff slopes swallow its residual), or taken by the
 * halving rule (at a touch-down the ratio need not halve as the step does) -- puts the contact
 * millimetres in with no force of it in the step: the energy its law stores there is made from
 * nothing.  gymnasium's ant, bench_rollout_contacts' row 34 at t = 0.18 s: a foot landing at 1.94
 * m/s, -5.8 -> +13.8 mm in one whole step at ratio 0.456, +8.96 J (the energy with the limit
 * springs it leaves out; Radau's never rises there); over the ant's 64 starts 25 rows rose, 111 J in
 * all; the humanoid's row 20 (3 ms): a shin landing from 0.1 um in touch, its half-step taken by
 * the halving rule at ratio 8.3 after 1.3, +4.8 J; G1's rows 27, 28, 63 +0.05-0.07 J.  Shallow
 * landings are left to the residual test: over the 64 starts of the ant, walker2d, hopper and G1, the
 * whole steps taken with a landing shallower than 0.01 of its radius rose by 0 J (the humanoid's
 * two, +0.76 and +0.44 J, landed 0.00005 and 0.002 of a radius deep, the energy made elsewhere in
 * the step), and measuring every landing with A (session 22's rule, branch antstep-tdh) cost the
 * humanoid +3.6 % calls, G1 +3.3 %. */
static int fs_lands(const fs_fast *q)
{
    FS_EACH_TOUCHING(q, c) {
        double a = q->T[q->L.contact + 25 * (size_t)c], b = q->T1[q->L.contact + 25 * (size_t)c];
        if ((a > 0.0 ? b > ONSET_FACTOR * a : b > 0.0) && fs_deep(q, c, b)) return 1;
    }
    return 0;
}

/* Whether a contact in touch at both ends of the try is pressed in by more than CREEP_FRACTION of its
 * (finite) depth limit.  A try whose ratio is above split is taken as a stick/slip step -- whole, by
 * the FRICTION_FACTOR rule, or as a sub-step that halving did not mend -- only without one
 * (fs_fast_advance): the residual those rules let through is the friction's (tangential, dissipated),
 * and one that lands on a contact's depth is not.  Why (session 31, benchmarks/results/fixedstep.md's
 * notes; tests/runtime/test_implicitfast_terms.py): a ball spinning at 30-50 rad/s about a horizontal
 * axis on a floor 1e4 times the file's stiffness, at 4-5 ms, had each step's first half taken at
 * ratio 0.78-0.81 after the whole step's 1.3-1.5 (no regime change) and sank 0.04-0.8 mm a step
 * until its centre crossed the floor (status 10 in 19 of 24 such starts on main 2aea16df); with
 * this rule they stay within 0.2-3 mm (one 17 mm), with fewer calls.  The humanoid, ant, walker2d,
 * hopper, Go2 and G1 (qpos0 and 12 of bench_rollout_contacts' starts each) take the same calls
 * within +0.3 % (G1 6968 -> 6986, humanoid 5956 -> 5963): their stance steps taken so press a foot
 * in by less than 0.001 of its radius.  A contact with no finite limit (a body-body pair) is not
 * measured.  Not mended: on that floor a ball spinning about a random axis also sinks through whole
 * steps that pass the ratio (35-40 of 48 starts end with status 10 with or without this rule). */
static int fs_creeps(const fs_fast *q)
{
    const double *lim = q->ops->imp->depth_limit;
    if (!lim) return 0;
    FS_EACH_TOUCHING(q, c) {
        double a = q->T[q->L.contact + 25 * (size_t)c], b = q->T1[q->L.contact + 25 * (size_t)c];
        if (a > 0.0 && isfinite(lim[c]) && b - a > CREEP_FRACTION * lim[c]) return 1;
    }
    return 0;
}

/* The try's ratio with Newton's correction taken with the start's matrix A (factored for this
 * step) instead of A1: |A^-1 r| / (|du| + h g), r the residual M1 du - h f1 (not changed).  Asked
 * only of a try that passes, at a touch-down from in touch (fs_onset), where A1's correction
 * falls short: A has the start's slopes, softer than the law's secant over the step, so this one
 * errs long. */
static double fs_start_ratio(fs_fast *q, double h, const double *r)
{
    int nu = q->ops->nu;
    double rn = 0.0, dn = 0.0, *w = q->GJ, ratio;
    memcpy(w, r, (size_t)nu * sizeof(double));
    fs_solve(q, q->A, q->start, q->anc, w, NULL);
    for (int i = 0; i < nu; i++) {
        rn += w[i] * w[i];
        dn += q->du[i] * q->du[i];
    }
    ratio = sqrt(rn) / (sqrt(dn) + h * RESID_ACCEL);
    return isfinite(ratio) ? ratio : INFINITY;
}

/* r = M1 du - h f1 into q->dv, over M's nonzeros only (a speed and its ancestors and
 * descendants: cols), in the same order as the dense product, so the sum is the same to the bit */
static void fs_residual(fs_fast *q, double h)
{
    const double *M1 = q->T1 + q->L.M, *f1 = q->T1 + q->L.f;
    if (q->ops->imp->terms_whole) q->ops->imp->terms_whole(q->T1);
    if (q->pat.tree && q->ops->imp->tree_residual) {     /* the model's straight-line twin, same bits */
        q->ops->imp->tree_residual(M1, f1, q->du, h, q->dv);
        return;
    }
    for (int i = 0; i < q->ops->nu; i++) {
        const double *row = M1 + (size_t)i * q->ops->nu;
        double r = -h * f1[i];
        for (int x = q->cstart[i]; x < q->cstart[i + 1]; x++) r += row[q->cols[x]] * q->du[q->cols[x]];
        q->dv[i] = r;
    }
}

static int fs_fast_try(fs_fast *q, double t, double h, const double *x, int check, double *ratio)
{
    const eomc_fs_ops *ops = q->ops;
    const fs_layout *L = &q->L;
    int nq = ops->nq, nu = ops->nu, s, done = 0, a_bare;
    const double *u = x + nq, *v1 = NULL;
    double rn = 0.0, dn = 0.0;
    eomc_fs_request *rq = &q->req;
    *ratio = INFINITY;
    q->chart = 0.0;
    if (q->given) {                     /* fs_last_cell's iterate */
        memcpy(q->du, q->given, (size_t)nu * sizeof(double));
    } else if (fs_ahead(q, h)) {        /* the lanes made du and the rate (below) */
        memcpy(q->du, rq->du1, (size_t)nu * sizeof(double));
        v1 = rq->v1;
    } else if (q->dun_T == q->T && q->dun_h == h) {   /* made with the last residual (below) */
        memcpy(q->du, q->dun, (size_t)nu * sizeof(double));
    } else {
        for (int i = 0; i < nu; i++) q->du[i] = h * q->b[i];
        fs_solve(q, q->A, q->start, q->anc, q->du, NULL);
    }
    rq->ahead = 0;
    if (!v1 && ops->imp->terms_whole) ops->imp->terms_whole(q->T);
    {
        const double *qd = q->T + L->qd, *N = q->T + L->N;
        for (int i = 0; i < nq; i++) {
            const double *row = N + (size_t)i * nu;
            double v = v1 ? v1[i] : qd[i];
            for (int x = q->nstart[i]; !v1 && x < q->nstart[i + 1]; x++) v += row[q->ncol[x]] * q->du[q->ncol[x]];
            q->x1[i] = x[i] + h * v;
        }
        for (int k = 0; k < nu; k++) q->x1[nq + k] = u[k] + q->du[k];
    }
    for (int i = 0; i < nq + nu; i++)
        if (!isfinite(q->x1[i])) return EOMC_NONFINITE;
    q->dun_T = NULL;                    /* T1 is overwritten below */
    q->vT1 = 0;
    q->lT1 = 0;
    a_bare = q->A == q->bare;           /* A unwritten: the lanes answered the last try ahead */
    if (ops->terms_lu && !q->given) {   /* the lanes rollout: maybe made with other rows */
        rq->h = h; rq->A = q->A1; rq->b = q->b1; rq->du = check ? q->du : NULL;
        rq->touch = q->tl[1 - q->it];   /* T1's list, made by the lanes as they assemble */
        if ((s = ops->terms_lu(ops->ctx, t + h, q->x1, q->T1, rq))) return s;
        done = rq->done;
        if (done) {
            q->ntl[1 - q->it] = rq->ntouch;
            q->lT1 = 1;
        }
        q->bare = rq->ahead ? q->A1 : NULL;
    } else {
        if (q->bare == q->A1) q->bare = NULL;    /* written below, by the scalar code */
        if ((s = ops->terms(ops->ctx, t + h, q->x1, q->T1))) return s;
    }
    if (done) {                         /* A1 unwritten (bare): the lists of its tree, as a placeholder */
        q->start1 = q->pat.start;
        q->anc1 = q->pat.anc;
    } else if ((s = fs_assemble(ops, L, h, q->x1 + nq, q->T1, q->A1, q->b1, q->GJ, q->cT1, &q->vT1, FS_TL1(q), &q->pat,
                                q->own1, &q->start1, &q->anc1))) {
        return s;
    }
    if (!check) {                       /* the residual test is off: nothing reads the ratio */
        *ratio = 0.0;
        return EOMC_OK;
    }
    if (done) {                         /* the lanes: the lines below, in vector code */
        *ratio = rq->ratio;
        q->chart = fs_chart_ratio(q, h, x);
        *ratio = fmax(*ratio, q->chart);
        if (*ratio <= ops->imp->split && fs_onset(q)) {   /* rare: scalar, the scalar path's bits */
            if (a_bare) {               /* the lanes made du without writing A: write it (q->bare
                                           is A1's by now: this try's answer) */
                if ((s = fs_assemble(ops, L, h, u, q->T, q->A, q->b, q->GJ, q->cT, &q->vT, FS_TL(q), &q->pat,
                                     q->own, &q->start, &q->anc)))
                    return s;
            }
            fs_residual(q, h);
            *ratio = fmax(*ratio, fs_start_ratio(q, h, q->dv));
        }
        return EOMC_OK;
    }
    fs_residual(q, h);
    /* and the next try's du from T1 at h (A1^-1 h b1: what that try would solve) in the same pass;
     * measured on the ant (1 s checked, runtime .so A/B in one process): 0.563 -> 0.551 ms */
    for (int i = 0; i < nu; i++) q->dun[i] = h * q->b1[i];
    fs_solve(q, q->A1, q->start1, q->anc1, q->dv, q->dun);
    q->dun_T = q->T1;
    q->dun_h = h;
    for (int i = 0; i < nu; i++) {
        rn += q->dv[i] * q->dv[i];
        dn += q->du[i] * q->du[i];
    }
    *ratio = sqrt(rn) / (sqrt(dn) + h * RESID_ACCEL);
    if (!isfinite(*ratio)) *ratio = INFINITY;
    q->chart = fs_chart_ratio(q, h, x);
    *ratio = fmax(*ratio, q->chart);
    /* a try that passes with a contact touching down from in touch, or from out of touch deep: also
     * with A (fs_onset) */
    if (*ratio <= ops->imp->split && fs_onset(q)) {
        /* A unwritten here (a_bare: the lanes answered the last try ahead, then declined this one)
         * only if the lanes' pivot test failed where fs_assemble's above passed -- the same
         * arithmetic, so only $EOMC_TEST_FS_LANES_FAIL's lanes (a model call that failed returned
         * above): written as the lanes' branch does, so fs_start_ratio never reads a stale A */
        if (a_bare && (s = fs_assemble(ops, L, h, u, q->T, q->A, q->b, q->GJ, q->cT, &q->vT, FS_TL(q), &q->pat,
                                       q->own, &q->start, &q->anc)))
            return s;
        fs_residual(q, h);              /* r again: the solve above overwrote it */
        *ratio = fmax(*ratio, fs_start_ratio(q, h, q->dv));
    }
    return EOMC_OK;
}

/* Whether a contact or joint law changed regime between the step's start (T) and the trial
 * end (T1): a contact touched down or lifted off or its depth changed by more than a factor
 * SWITCH_FACTOR, or a joint law's stiffness or damping slope did (a limit engaging).  Such a
 * step's linearisation can be far off in a way a shorter step mends; a step without one can
 * still show a large Newton correction (the regularised friction of a contact in touch at
 * both ends switching between stick and slip: its slope mu F_n / v_s is there at v = 0 and
 * gone at |v| >> v_s), which halving does not shrink (measured on the humanoid standing:
 * ratios 0.4-0.6 at every halving). */
static int fs_changed(double a, double b)
{
    if ((a > 0.0) != (b > 0.0)) return 1;
    return a > 0.0 && (a > SWITCH_FACTOR * b || b > SWITCH_FACTOR * a);
}

/* 0: no regime changed; FS_TOUCHDOWN: only contacts touching down (out of touch at the start,
 * in it at the end, or in touch at the start with a depth growing more than ONSET_FACTOR-fold:
 * fs_onset, or in touch at both ends with the normal force clipped at the start and pushing at
 * the end: fs_clipped); FS_OTHER: anything else (a lift-off, a depth or a joint law's slope
 * changing by more than SWITCH_FACTOR, a normal force going from pushing to clipped in touch).
 * The clip rules (session 18, helpers antcalls and clipfix): the damped law's force is clipped
 * at 0 while the point rises faster than its clip speed, and a step across the clip is no
 * stick/slip step: gymnasium's ant restarted from a t = 0.3 s state (bench_rollout_contacts'
 * row 34) took such a step whole at ratio 0.675 (FRICTION_FACTOR), two feet 4.5-5 mm in going
 * from clipped to pushing: +0.383 J in one step, status 20; a pressed 1 kg ball rising at
 * 1.05-3x its clip speed from 0.2-4 mm in gained up to 0.041 J at 5 ms (6 of 25 runs status 20).
 * Now neither has a status 20 (2 ball runs still rise, by <= 0.95 mJ).  Cost (model calls over bench_rollout_contacts' 64 starts, 1 s): ant +1.0 %,
 * humanoid +1.5 % (qpos0 504 -> 517), walker2d +1.2 %. */
enum { FS_TOUCHDOWN = 1, FS_OTHER = 2 };

static int fs_switched(const fs_fast *q)
{
    const eomc_fs_ops *ops = q->ops;
    const double *j0 = q->T + q->L.joint, *j1 = q->T1 + q->L.joint;
    int kind = 0;
    FS_EACH_TOUCHING(q, c) {
        const double *e0 = q->T + q->L.contact + 25 * (size_t)c, *e1 = q->T1 + q->L.contact + 25 * (size_t)c;
        double a = e0[0], b = e1[0];
        if (fs_changed(a, b)) {
            if (!(b > 0.0) || (a > 0.0 && !(b > ONSET_FACTOR * a))) return FS_OTHER;
            kind = FS_TOUCHDOWN;
        } else if (a > 0.0 && b > 0.0) {      /* the normal force's clip (law.clip_switch) in touch */
            int za = fs_clipped(e0), zb = fs_clipped(e1);
            if (za && !zb) kind = FS_TOUCHDOWN;   /* clipped -> pushing: a touch-down but for the name */
            else if (zb && !za) return FS_OTHER;
        }
    }
    for (int i = 0; i < 2 * ops->nu; i++)
        if (fs_changed(j0[i], j1[i])) return FS_OTHER;
    return kind;
}

/* Whether the try's only regime changes are joint laws letting go: every joint-law slope that changes
 * by more than SWITCH_FACTOR falls (a limit's spring and damping released as the joint leaves its
 * bound), and no contact changes regime (fs_switched's contact classes).  Such a try that misses by
 * a little (ratio up to FRICTION_FACTOR x split) is taken whole as a stick/slip step is
 * (fs_fast_advance).  Why: the step's matrix holds the start's stiffer slopes, so its linearised
 * force falls faster than the law's as the joint leaves (the release is under-predicted, never
 * pumped); halving that try buys calls, not a different state class.  Measured (session 33,
 * benchmarks/results/fixedstep.md's notes): gymnasium's ant from qpos0 at t = 0.21 s, its four
 * ankles leaving their upper limits, ratio 0.68 whole, then 0.36 and 0.04 for the halves: 121 ->
 * 119 calls. */
static int fs_releases(const fs_fast *q)
{
    const eomc_fs_ops *ops = q->ops;
    const double *j0 = q->T + q->L.joint, *j1 = q->T1 + q->L.joint;
    int fell = 0;
    FS_EACH_TOUCHING(q, c) {
        const double *e0 = q->T + q->L.contact + 25 * (size_t)c, *e1 = q->T1 + q->L.contact + 25 * (size_t)c;
        if (fs_changed(e0[0], e1[0])) return 0;
        if (e0[0] > 0.0 && e1[0] > 0.0 && fs_clipped(e0) != fs_clipped(e1)) return 0;
    }
    for (int i = 0; i < 2 * ops->nu; i++)
        if (fs_changed(j0[i], j1[i])) {
            if (!(j1[i] < j0[i])) return 0;
            fell = 1;
        }
    return fell;
}

/* Where a depth from a <= 0 to b > 0 over a try crosses 0, as a fraction of the try: the quadratic
 * a + th beta + th^2 (b - a - beta) where it is convex (beta > 0, the start's approach speed times
 * h, and b - a >= beta), its root in (0, 1) in the stable form, else the straight line a / (a - b). */
static double fs_crossing(double a, double b, double beta)
{
    const double cq = b - a - beta;
    if (beta > 0.0 && cq >= 0.0) {
        double th = -2.0 * a / (beta + sqrt(beta * beta - 4.0 * cq * a));
        if (th >= 0.0 && th < 1.0) return th;
    }
    return a / (a - b);
}

/* Where contact c's depth, from a < 0 at T to b > 0 at T1 over a try of h, crosses 0, as a fraction
 * of the try: the gap's quadratic a + th (h r0) + th^2 (b - a - h r0), r0 the point's approach speed
 * at T (its velocity along the contact's normal, which the end's stiffness slope K gives: each row
 * of K is a multiple of the normal), when that quadratic is convex (the approach speeding up, as in
 * a fall: b - a >= h r0); else, or with no normal known, the straight line a / (a - b).  Why: a
 * falling point's depth is convex in time, and the straight line between the try's ends crosses 0
 * early -- gymnasium's ant from its qpos0 at 10 ms, its feet landing at t = 0.19 s: cell 22 instead
 * of 23, so the part before the cell, then cell 22 passed untouched, the touch-down came in cell
 * 23, one try more.  Measured (session 24, benchmarks/results/fixedstep.md's notes): model calls
 * over bench_rollout_contacts' 64 starts, 1 s: ant 10303 -> 10130, G1 34867 -> 34605, Go2 33746 ->
 * 33514, humanoid 34629 -> 34591, walker2d 64820 -> 64741, hopper 34037 -> 33999; the energy
 * verdict's flagged rows as many as before on each model; the ant's qpos0 run 122 -> 121 calls.
 * The concave case kept linear: with it (the start speed's size trusted whatever its sign) the
 * humanoid's and the ant's unsolved sub-steps rose by one each. */
static double fs_onset_fraction(const fs_fast *q, int c, double h)
{
    const double *e0 = q->T + q->L.contact + 25 * (size_t)c, *e1 = q->T1 + q->L.contact + 25 * (size_t)c;
    const double *K = e1 + 7, *v0 = e0 + 4;
    double a = e0[0], b = e1[0], big = 0.0, beta;
    int r = -1;
    if (q->ops->imp->terms_whole) {             /* the lanes: T's vp and T1's K may not be copied yet */
        q->ops->imp->terms_whole(q->T);
        q->ops->imp->terms_whole(q->T1);
    }
    for (int i = 0; i < 3; i++) {
        double s2 = K[3 * i] * K[3 * i] + K[3 * i + 1] * K[3 * i + 1] + K[3 * i + 2] * K[3 * i + 2];
        if (s2 > big) { big = s2; r = i; }
    }
    beta = r >= 0 && isfinite(big) ? h * fabs(K[3 * r] * v0[0] + K[3 * r + 1] * v0[1] + K[3 * r + 2] * v0[2]) / sqrt(big)
                                   : 0.0;
    return fs_crossing(a, b, beta);
}

/* Limit l's depth d = sign (q - bound) at the try's start xs (*a) and end x1 (*b); 1 when the try
 * entered it (from <= 0 to > 0). */
static int fs_entered(const fs_fast *q, int l, const double *xs, double *a, double *b)
{
    const eomc_implicit *imp = q->ops->imp;
    const double sg = imp->limit_sign[l], bound = q->ops->p[imp->limit_bound[l]];
    *a = sg * (xs[imp->limit_state[l]] - bound);
    *b = sg * (q->x1[imp->limit_state[l]] - bound);
    return *a <= 0.0 && *b > 0.0;
}

/* Where limit l's depth d = sign (q - bound), from a <= 0 at the try's start xs to b > 0 at its end,
 * crosses 0, as a fraction of the try (of h): fs_onset_fraction's quadratic, the start's approach
 * speed h sign u (the joint's speed at xs: a one-speed joint's q' = u) in place of the point's, when
 * it is convex, else the straight line.  Why: the limit law's slopes come on past the bound, so a
 * try across it is as explicit in the limit as a touch-down's is in the contact, and the same
 * location (a part before the crossing's cell, the cell, the walk back) replaces the halving to it:
 * gymnasium's ant's ankles entering their limits at 7 rad/s took 8-13 tries a step (session 46). */
static double fs_limit_fraction(const fs_fast *q, int l, const double *xs, double h)
{
    const eomc_implicit *imp = q->ops->imp;
    double a, b;
    fs_entered(q, l, xs, &a, &b);
    return fs_crossing(a, b, h * imp->limit_sign[l] * xs[q->ops->nq + imp->limit_speed[l]]);
}

/* Whether the try from xs to x1 entered a joint limit (fs_limit_fraction: d from <= 0 to > 0), and
 * every regime change in it is such an entry or a touch-down (fs_switched's classes): each joint-law
 * slope that changes by more than SWITCH_FACTOR is at the speed of a limit entered; every contact
 * change a touch-down.  Such a try is located (fs_onset_cell); one with any other change is halved. */
static int fs_entries(const fs_fast *q, const double *xs)
{
    const eomc_fs_ops *ops = q->ops;
    const eomc_implicit *imp = ops->imp;
    const double *j0 = q->T + q->L.joint, *j1 = q->T1 + q->L.joint;
    unsigned char entered[FS_CHAIN];
    double a, b;
    int any = 0;
    if (imp->nlimit <= 0 || !ops->p || ops->nu > FS_CHAIN) return 0;
    memset(entered, 0, sizeof entered);
    for (int l = 0; l < imp->nlimit; l++)
        if (fs_entered(q, l, xs, &a, &b)) {
            entered[imp->limit_speed[l]] = 1;
            any = 1;
        }
    if (!any) return 0;
    for (int i = 0; i < 2 * ops->nu; i++)
        if (fs_changed(j0[i], j1[i]) && !entered[i / 2]) return 0;
    {
        FS_EACH_TOUCHING(q, c) {
            const double *e0 = q->T + q->L.contact + 25 * (size_t)c, *e1 = q->T1 + q->L.contact + 25 * (size_t)c;
            a = e0[0];
            b = e1[0];
            if (fs_changed(a, b)) {
                if (!(b > 0.0) || (a > 0.0 && !(b > ONSET_FACTOR * a))) return 0;
            } else if (a > 0.0 && b > 0.0 && fs_clipped(e1) && !fs_clipped(e0)) {
                return 0;
            }
        }
    }
    return 1;
}

/* The grid cell (units of h / MAX_SPLIT from the step's start) in which a failed try [pos, pos + size)
 * from xs touches down or enters a limit, or -1.  Only for a try whose regime changes are touch-downs
 * from out of touch (a contact's depth < 0 at T, > 0 at T1), or, when it failed hard, such touch-downs
 * and limits entered (fs_entries); the onset is where the gap crosses 0 (fs_onset_fraction: the try is
 * the free flight of that point, no force of it in the step) or the joint crosses its bound
 * (fs_limit_fraction), the earliest over them.  Why hard only for limits: a soft failure's halves
 * mostly pass (locating those too: humanoid +0.7 %, walker2d +0.5 % calls over 128 starts, session 46). */
static int fs_onset_cell(const fs_fast *q, int pos, int size, double h, const double *xs, int hard)
{
    const eomc_implicit *imp = q->ops->imp;
    double theta = INFINITY;
    int cell, kind = fs_switched(q), limits = hard && kind == FS_OTHER && fs_entries(q, xs);
    if (kind != FS_TOUCHDOWN && !limits) return -1;
    for (int l = 0; limits && l < imp->nlimit; l++) {      /* the limits entered (fs_entries) */
        double a, b, th;
        if (fs_entered(q, l, xs, &a, &b) && (th = fs_limit_fraction(q, l, xs, h)) < theta) theta = th;
    }
    for (int c = 0; c < q->ops->imp->ncontact; c++) {
        const double *e0 = q->T + q->L.contact + 25 * (size_t)c, *e1 = q->T1 + q->L.contact + 25 * (size_t)c;
        double a = e0[0], b = e1[0], th;
        if (a > 0.0 || !(b > 0.0)) continue;
        if (a < 0.0) {
            th = fs_onset_fraction(q, c, h);
        } else {                                /* no gap known (a pair the broad phase skipped): the end's rate */
            const double *K = e1 + 7, *vp = e1 + 4;
            double big = 0.0, kv = 0.0;
            int r = -1;
            if (q->ops->imp->terms_whole) q->ops->imp->terms_whole(q->T1);   /* the lanes: vp, K not yet copied */
            for (int i = 0; i < 3; i++) {
                double s2 = K[3 * i] * K[3 * i] + K[3 * i + 1] * K[3 * i + 1] + K[3 * i + 2] * K[3 * i + 2];
                if (s2 > big) { big = s2; r = i; }
            }
            if (r < 0 || !isfinite(big)) return -1;
            kv = fabs(K[3 * r] * vp[0] + K[3 * r + 1] * vp[1] + K[3 * r + 2] * vp[2]) / sqrt(big);
            th = kv > 0.0 ? 1.0 - b / (kv * h) : 0.0;
            if (!(th > 0.0)) th = 0.0;
        }
        if (th < theta) theta = th;
    }
    if (!(theta >= 0.0 && theta < 1.0)) return -1;
    cell = pos + (int)(theta * size);
    return cell < pos + size ? cell : pos + size - 1;
}

/* The last-resort cell: a try of the smallest size (h / MAX_SPLIT) whose ratio is still past
 * HARD_FACTOR * split with no touch-down in it is solved by Newton on its implicit Euler equation
 * instead of being taken as it is (and counted unsolved): du -= A1^-1 r, the correction the ratio
 * already measures, A1 made at each iterate's end (each try assembles the next step's matrix there
 * anyway, so the fresh matrix costs nothing beyond the try's model call); an iterate no better than
 * the best is halved back towards it (NEWTON_HALVINGS).  Up to LAST_ITER tries, until the ratio is
 * at most split; the best iterate is taken (tried again if the last try was not it, so T1, A1 and b1
 * are its own).  Its ratio is returned: still past HARD_FACTOR * split, the caller counts the cell.
 * Each try runs in the scalar code with a plain model call (fs_fast_try's given du), the lanes rollout's
 * too (where A or A1 may be unwritten, bare: made here), so both paths take the same bits.
 * Why: gymnasium's ant took 40 such cells over bench_rollout_contacts' 64 starts (its ankles' limits
 * engaging, a foot's normal force clipping), each one an unsolved sub-step and a warning. */
#define LAST_ITER 6
static int fs_last_cell(fs_fast *q, double t, double h, const double *x, double *ratio)
{
    const eomc_fs_ops *ops = q->ops;
    int nu = ops->nu, s, at_best = 1, halvings = 0;
    double best = *ratio, split = ops->imp->split, r;
    size_t bytes = (size_t)nu * sizeof(double);
    if (q->A == q->bare) {               /* the lanes answered ahead: A (read by fs_start_ratio) */
        if ((s = fs_assemble(ops, &q->L, h, x + ops->nq, q->T, q->A, q->b, q->GJ, q->cT, &q->vT, FS_TL(q), &q->pat,
                             q->own, &q->start, &q->anc)))
            return s;
        q->bare = NULL;
    }
    if (q->bare == q->A1) q->bare = NULL;
    if ((s = fs_assemble(ops, &q->L, h, q->x1 + ops->nq, q->T1, q->A1, q->b1, q->GJ, q->cT1, &q->vT1, FS_TL1(q), &q->pat,
                         q->own1, &q->start1, &q->anc1)))
        return s == EOMC_SINGULAR_MASS_MATRIX ? EOMC_OK : s;    /* no correction: taken as it is */
    fs_residual(q, h);                   /* dv = A1^-1 r at the try */
    fs_solve(q, q->A1, q->start1, q->anc1, q->dv, NULL);
    memcpy(q->dub, q->du, bytes);
    for (int i = 0; i < nu; i++) q->dug[i] = q->du[i] - q->dv[i];
    for (int it = 0; it < LAST_ITER && best > split; it++) {
        q->given = q->dug;
        s = fs_fast_try(q, t, h, x, 1, &r);
        q->given = NULL;
        if (s && s != EOMC_NONFINITE && s != EOMC_SINGULAR_MASS_MATRIX) return s;
        if (!s && r < best) {            /* better: the next iterate from here, with its A1 */
            best = r;
            at_best = 1;
            halvings = 0;
            memcpy(q->dub, q->du, bytes);
            for (int i = 0; i < nu; i++) q->dug[i] = q->du[i] - q->dv[i];
            continue;
        }
        at_best = 0;
        if (++halvings > NEWTON_HALVINGS) break;
        for (int i = 0; i < nu; i++) q->dug[i] = q->dub[i] + 0.5 * (q->dug[i] - q->dub[i]);
    }
    if (!at_best) {                      /* the best iterate's end again: its T1, A1, b1 */
        q->given = q->dub;
        s = fs_fast_try(q, t, h, x, 1, &r);
        q->given = NULL;
        if (s) return s;
        best = r;
    }
    *ratio = best;
    return EOMC_OK;
}

/* A try of hs from xs whose matrix is not made for hs (a split step's sub-step, or the whole step
 * after one): the lanes rollout's answer for it (eomc_fs_ops.assemble_lu: du1 and v1, made with other
 * rows' such tries at once, each the scalar code's bits), which fs_fast_try takes as it takes an
 * answer made ahead at a model call; 0: none (not the lanes, too few rows waiting, or its pivot test
 * failed): the caller assembles A.  Why: these tries' scalar fs_assemble, with the copy of T whole
 * before it, were ~10-12 % of the ant's and the humanoid's lanes rollouts (perf, 64 rows, session 30). */
static int fs_assemble_ahead(fs_fast *q, double hs, const double *xs)
{
    eomc_fs_request *rq = &q->req;
    if (!q->ops->assemble_lu) return 0;
    rq->h = hs; rq->A = q->A; rq->b = q->b; rq->du = NULL; rq->touch = NULL;
    if (q->ops->assemble_lu(q->ops->ctx, xs, q->T, rq) != EOMC_OK) rq->ahead = 0;
    return rq->ahead;
}

/* Whether the only regime changes from T to T1 are contacts in touch at both ends pressing in: a depth
 * growing more than SWITCH_FACTOR-fold but not ONSET_FACTOR-fold (fs_switched's FS_OTHER for it), no
 * normal force clipping or unclipping, no touch-down, lift-off or joint law's change.  After a located
 * touch-down this is the landed contact sinking in over the sub-steps that follow its onset cell. */
static int fs_pressing_in(const fs_fast *q)
{
    const eomc_fs_ops *ops = q->ops;
    const double *j0 = q->T + q->L.joint, *j1 = q->T1 + q->L.joint;
    FS_EACH_TOUCHING(q, c) {
        const double *e0 = q->T + q->L.contact + 25 * (size_t)c, *e1 = q->T1 + q->L.contact + 25 * (size_t)c;
        double a = e0[0], b = e1[0];
        if (fs_changed(a, b) && !(a > 0.0 && b > a && b <= ONSET_FACTOR * a)) return 0;
        if (a > 0.0 && b > 0.0 && fs_clipped(e0) != fs_clipped(e1)) return 0;
    }
    for (int i = 0; i < 2 * ops->nu; i++)
        if (fs_changed(j0[i], j1[i])) return 0;
    return 1;
}

/* The walk back after a touch-down's onset cell (fs_fast_advance): the next sub-step's size (grid
 * units) after a take of `size` ending at `pos` with ratio `ratio`, at least the halving grid's
 * `grid`.  The ratio is O(h) (the linearisation's error over |du|), so a take at ratio r predicts
 * WALK_TARGET * split at (WALK_TARGET * split / r) times its size; the size is that, at most
 * WALK_GROW times this one, cut to the largest power of two that pos is a multiple of (the halving
 * grid: every sub-step still starts and ends on it), never below the grid's own doubling.  Each
 * sub-step is checked as any (a failed one is halved or located again).  Why and what was measured:
 * fs_fast_advance's comment (session 30). */
static int fs_walk_size(int pos, int size, int grid, double ratio, double split)
{
    double g = ratio > 0.0 ? WALK_TARGET * split / ratio : WALK_GROW;
    int ns, p = 1;
    if (!(g < WALK_GROW)) g = WALK_GROW;
    ns = (int)(size * g);
    while (pos % (2 * p) == 0 && 2 * p <= ns) p *= 2;
    return p > grid ? p : grid;
}

#ifdef EOMC_FS_TRACE
#include <stdio.h>
/* One line on stderr per try of fs_fast_advance, in a library built with -DEOMC_FS_TRACE only
 * (benchmarks/trace_fixedstep.py builds one and sorts the tries by what made them): the step's start,
 * the try's place and size on the step's grid of MAX_SPLIT cells, its status and ratio, the located
 * onset cell, whether it is the walk back after one or the part before it, whether a contact is in
 * touch at either end, and whether a contact or a joint law changed regime over it (fs_switched's
 * tests, each on its own).  Why: where a run's model calls beyond one a step go decides which of the
 * step's rules to work on, and the tries' sizes and ratios say it where the calls' count cannot. */
static void fs_trace_try(const fs_fast *q, double t, int pos, int size, int status, double ratio, int onset,
                         int walk, int located)
{
    const double *j0 = q->T + q->L.joint, *j1 = q->T1 + q->L.joint;
    int touching = 0, contacts = 0, joints = 0;
    for (int c = 0; c < q->ops->imp->ncontact; c++) {
        const double *e0 = q->T + q->L.contact + 25 * (size_t)c, *e1 = q->T1 + q->L.contact + 25 * (size_t)c;
        touching |= e0[0] > 0.0 || e1[0] > 0.0;
        contacts |= fs_changed(e0[0], e1[0]) || (e0[0] > 0.0 && e1[0] > 0.0 && fs_clipped(e0) != fs_clipped(e1));
    }
    for (int i = 0; i < 2 * q->ops->nu; i++) joints |= fs_changed(j0[i], j1[i]);
    fprintf(stderr, "EOMC_FS_TRY %.17g %d %d %d %.6g %d %d %d %d %d %d\n", t, pos, size, status, ratio, onset, walk,
            located, touching, contacts, joints);
}
#define FS_TRACE_TRY(q, t, pos, size, s, ratio, onset, walk, located) \
    fs_trace_try(q, t, pos, size, s, ratio, onset, walk, located)
#else
#define FS_TRACE_TRY(q, t, pos, size, s, ratio, onset, walk, located) ((void)0)
#endif

/* fs_loop's step for the fast path: one step (2), or, with eomc_implicit.split > 0 and
 * where the step's residual ratio (fs_fast_try) is above it, 2, 4 ... MAX_SPLIT equal
 * sub-steps (as fs_advance does for the W-method).  A sub-step is split further only while
 * that helps: a linearisation error shrinks with the step, so halving must at least halve
 * the ratio, unless the ratio is above HARD_FACTOR * split (then it is split regardless).
 * Measured (2 s of Go2 and G1 collapsing onto their feet at 1, 2, 5 ms, the gymnasium
 * models at their own step): without the test G1 blows up at 1 and 5 ms and Go2 at 2 and
 * 5 ms -- the knee hitting its limit at 10 rad/s drives G1's 5 mm heel spheres past their
 * radius, where the light ankle links' contact geometry is unstable at a rate of ~1000/s,
 * and the step that linearised it has a ratio of 100 to 1000; a ratio of 0.5 to 1 is
 * common in a stance (the regularised friction switching between stick and slip within a
 * step: halving does not help there, so such steps are taken whole).  With split = 0.5 all
 * six runs end with status 0 and Go2's feet at most 11.5 mm deep (radius 22 mm).
 *
 * What a stick/slip switch costs (session 4): a whole step whose ratio is above split but at
 * most FRICTION_FACTOR * split, with no contact or joint law changing regime inside it
 * (fs_switched), is taken whole without a half tried (on the humanoid standing such steps
 * have ratios 0.4-1.3 at every halving).  Steps with a regime change (a touch-down, a limit
 * engaging) and steps missing by more are split as before.  Tried and dropped (measured):
 * taking a whole step after all when its first half does not halve the ratio -- on the
 * thrown ball of tests/runtime/test_rollout.py two of 16 starts then gained energy (0.12 and
 * 1.5 J, caught by simulate's verdict); at a touch-down the ratio grows as the step shrinks
 * (the impact's correction does not shrink with h, the step does), so the halving test
 * cannot tell it from friction.  Measured (gymnasium humanoid at its 3 ms step, 1 s): 1042
 * -> 697 model calls; the ant's and humanoid's 64 random-start rollouts fail exactly the
 * rows they failed before (none; 3, loudly); no energy verdict on the gymnasium models or the
 * ball.  Go2 collapsing at 5 and 2 ms is marginal with or without this: over 6 start heights
 * (+0 ... +2 mm) 7 of 12 runs end with status 10 (6 of 12 before).
 *
 * Tried and dropped (session 5): taking a sub-step inside a split step without trying its
 * halves when its ratio was within FRICTION_FACTOR of an earlier sub-step's that halving had not
 * mended (a "friction level").  The humanoid went 668 -> 585 model calls per simulated second and
 * the ant 145 -> 135, but a G1 built from its URDF (bench_rollout_contacts: feet spheres, hinge
 * springs, hinge speeds +-0.5) went 521-546 -> 1390-1499 calls and 8 -> 22 ms per simulated
 * second, and the sub-steps left unsolved over 32 thrown-ball runs 115 -> 183.
 *
 * Where the calls beyond one per step go (session 6, traced per try; gymnasium humanoid at its
 * 3 ms step from qpos0, 1 s: 650 calls for 334 steps): 299 steps are taken whole (1 call each);
 * the 35 split steps cost 350 calls, and 32 of them start with a regime change (touch-down,
 * lift-off, a limit) -- the bisection to the impact (about 12 tries per touch-down) and, after
 * it, runs of h/64 sub-steps whose ratio stays near 2 at h/32 and h/64 (after the first impact a
 * knee speed alternates in sign and grows from sub-step to sub-step: the linearisation misses
 * something there, and the test says so).  Ant (10 ms, 145 calls, 100 steps): 10 split steps,
 * 4 with a regime change (28 calls), 6 without (26).  G1 from URDF (2 ms, 543 calls, 500 steps):
 * 4 split steps, all at regime changes: its gap to MuJoCo is the cost per call, not the count.
 * The end-of-step call is already the next step's start (T1 -> T), and
 * the verdict costs no call.  Tried and dropped (session 6): taking the longer try after all
 * when its half does not halve the ratio and neither changes a regime (the half's try was made
 * anyway, so no call is lost): humanoid 650 -> 521 calls, ant 16 rows 228 -> 165 mean, but on
 * the thrown ball at 2 ms two of 16 starts gained energy (0.12 and 1.5 J: the ball's landing
 * spin-up has ratio ~2 at every size with no regime change; its half, taken, is followed by
 * halves that pass), the same two the session-4 whole-step version failed.  Not doubling the
 * sub-step after one taken above split: humanoid 16 rows 783 -> 750 mean, ant 228 -> 225,
 * unsolved sub-steps of the ball at 5 ms 101 -> 140: not worth it.
 *
 * Session 7: the chatter after impacts was the friction's tangent slope (nil along a fast slip):
 * fs_secant_friction cut the humanoid's calls 650 -> 522 (qpos0) and 744 -> 560 (8 random starts).
 * Tried and held back: Newton on a failed try across a regime change (du -= A1^-1 r, the
 * correction the ratio already measured; up to 3 iterations while each halves the ratio), before
 * splitting.  Measured (16 random starts, 1 s): ant calls median 173 -> 116, humanoid 555 -> 511
 * (mean 561 -> 576: a few rows fall into a stick-slip cycle), G1 519 -> 504, Go2 510 -> 503,
 * hopper 530 -> 505, unsolved sub-steps 58 -> 0 (humanoid), 8 -> 0 (ant); thrown ball: no energy
 * gain at 2 or 5 ms, unsolved 16 -> 0; bench_fixedstep ant 145 -> 118 calls.  But the ant dropped
 * at 10 ms (test_ant_stands_at_its_own_10ms_step) then comes to rest at 3 s at 0.62 m (|u| 0.005)
 * instead of creeping at 0.58 m, past the test's 0.556 +- 0.04 (MuJoCo's own 10 ms path); with
 * Newton on sub-steps only 0.596, on touch-downs only 0.574 but the ant's calls rise (345 -> 438).
 * Friction holds a family of postures, so which 10 ms posture is right is the test's call, not
 * this file's.  And the errors against the models' own Radau grew (bench_rollout_contacts, median
 * of 4 starts): humanoid 0.073 -> 0.22, ant 0.49 -> 0.66 -- Newton takes an impact in a longer
 * sub-step than the bisection did, and the first-order error goes with that step.  Also dropped: FRICTION_FACTOR 3 (the ball at 5 ms passes, at 4 it gains energy;
 * the humanoid only 560 -> 546).  Session 9 (benchmarks/results/fixedstep.md's notes): Newton across
 * a regime change retried in eight variants (whole steps, sub-steps, contacts or limits only, to a
 * tighter ratio): at best 1-5 % fewer calls over 8 random humanoid starts, the ant's rising up to 40 %,
 * errors mostly larger; aiming the split at a touch-down's interpolated onset: calls unchanged within 2 %
 * (the calls go to the onset cell, whose ratio stays 37-390 down to h/64, and the walk back up).
 * Session 10 (21 starts per model, fixedstep.md's notes): aiming the split at the touch-down with
 * sub-steps of any size (humanoid calls -1 %, ant, hopper, Go2 unchanged, G1 at 5 ms +3 %), trying
 * the rest of the step at once after a sub-step (humanoid error 0.105 -> 0.33) and doubling without
 * the grid's alignment: dropped.  Session 13 (fixedstep.md's notes, 21 starts): the ant's 6 split
 * steps without a regime change are its feet's normal force clipped at 0 at one end of the step and
 * not at the other (the damped lift-off, law.clip_switch; fs_switched sees depths only), whose
 * implicit Euler solution sits on the clip's kink: Newton stalls at ratio 0.55-0.6 and halving does
 * not help.  Retrying a failed whole step with the end's slopes (an engaging limit's, a contact's
 * touching down or clipping), with or without Newton after it, or with a clipping contact off:
 * no fewer calls (ant median 168 -> 142-197, walker2d 837 -> 804-959, humanoid 527 -> 515-546),
 * errors larger, and the retry-plus-Newton variant blew up rows of the ant and humanoid (status 10)
 * although each step it took passed the test.  Session 18: a try that failed hard (ratio past
 * HARD_FACTOR * split with a limit engaging or another regime change that is no touch-down, or no
 * finite end) ended past an onset; when a sub-step before its end then passes without a regime
 * change (fs_switched), the onset lies between the two ends, and the next sub-step is made short
 * enough to end before it (hard_end) instead of trying the rest whole, which only fails again (the
 * ant from qpos0 at t = 0.15 s, its ankles hitting their limits at 7.3 rad/s: ratios 42, 56, 35, 37
 * on those tries; 15 tries -> 11, the same end state).  Only sub-steps get shorter, each checked as
 * before.  Measured (bench_rollout_contacts' 64 starts, 1 s): model calls ant 11939 -> 11735,
 * humanoid 35581 -> 35345, walker2d 64408 -> 64431, hopper 34240 -> 34255, Go2 32865 -> 32865, G1
 * 33436 -> 33440, every row status 0 as before; bench_fixedstep's qpos0 runs: ant 145 -> 141 calls
 * with the same end state, the others unchanged.  After a touch-down's hard failure the rest is
 * still tried whole: a pair's landing there (tests/runtime/test_pair_slopes_step.py) passes it, and
 * skipping it took 68 calls for 50 steps instead of 63 (humanoid's 64 starts: 34742 calls).  Tried and
 * dropped in session 18: taking a whole step whose only regime change is a foot's normal force
 * clipping at 0 or pushing again while in touch (the damped lift-off's kink: the ant's feet after
 * its landing, ratio 2.4 at h and h/2) -- ant qpos0 145 -> 125 calls, no status 20 over the six
 * models' 64 starts, but from the ant's own state at t = 0.23 s its energy rose 6.19 -> 20.2 J in
 * 0.75 s where Radau's falls to 4.59 (the ant's starts are outside its ankles' ranges, and the
 * limits' energy at the start hides such a gain from the verdict).  A sub-step
 * of the smallest size whose ratio is still above HARD_FACTOR * split (no touch-down's onset cell) is
 * solved by Newton (session 26, fs_last_cell), and taken anyway where that leaves it above, counted in
 * stats->rejected (simulate warns); a step with no finite sub-step at all fails.  After
 * each kept step the contacts' depths are checked against eomc_implicit.depth_limit: the
 * first contact found deeper is remembered and the run fails at the next step with
 * EOMC_PENETRATED (the state is written first, so the failure shows where).
 *
 * Session 21 (benchmarks/results/fixedstep.md's notes): a try that fails with contacts touching down
 * from out of touch and no other regime change (fs_switched FS_TOUCHDOWN) is no longer halved down
 * to its onset: fs_onset_cell finds the cell of h / MAX_SPLIT where the earliest such contact's gap
 * crosses 0 (linear between the try's ends: the try is that point's free flight), the next try is
 * the part before that cell (any number of cells; it stands for the whole step, so the stick/slip
 * rule FRICTION_FACTOR applies to it as to a whole step), then the onset cell itself (size 1: the
 * same smallest cell as the bisection's, taken uncounted as before), then the walk back up the
 * halving grid.  Every try is checked as before; a try before the cell that fails is split (or
 * located again) as any.  Measured (bench_rollout_contacts' 64 starts, 1 s, simulate's calls):
 * humanoid 35865 -> 33692 (-6.1 %), ant 11848 -> 11570, walker2d 65194 -> 64733, hopper 34245 ->
 * 34037; no new status 20 (rollout, lanes rollout, restarts from each row's t = 0.3 s state);
 * error against Radau 1e-9 over 16 starts, median / mean: humanoid 0.083 / 0.104 -> 0.083 / 0.098,
 * walker2d 0.079 / 0.271 -> 0.060 / 0.208, ant 0.503 / 0.500 -> 0.497 / 0.489.  Tried with it and
 * dropped: the rest of the step at once after the onset cell (humanoid 64 starts 33200 calls, but
 * 3 rows status 20, walker2d 2) and a walk up by doubling off the grid (humanoid 32857-33325, one
 * lanes row status 20).  A limit's onset was not located then (the terms hold its slopes, not its
 * distance to the bound); session 46 gave the step the limits' bounds (eomc_implicit.nlimit ..,
 * eomc_fs_ops.p) and locates an entry where a try fails hard (fs_entries, fs_limit_fraction).
 *
 * Session 30 (benchmarks/results/fixedstep.md's notes; the rule in /work/notes/s30/walkback-rule.diff):
 * traced, 80 % of the humanoid's extra calls are sub-steps taken inside split steps, most of them the walk
 * back after a located touch-down (qpos0: 74 of 127), at ratios 0.02-0.2 against split 0.5 while the grid
 * lets a size only double. Measured and not landed: after the onset cell, the next size from each take's
 * ratio (the size reaching split / 2 if the ratio grows with h, at most 16 times the take's, cut to the
 * halving grid, never below its doubling), on takes with no regime change (or also with the landed
 * contacts pressing in). Over 704 starts a model calls fell 0.2-1.3 % (humanoid qpos0 462 -> 438, its T2
 * 3.61-3.64 -> 3.25-3.26 ms, 1.35-1.37x -> 1.47-1.49x mj_step Euler) with the verdicts within their
 * spread, but the thrown ball of tests/runtime/test_rollout.py at k x 1e4
 * (test_implicitfast_rows_get_simulates_energy_verdict) gets a row that penetrates (status 10 at t = 0.785
 * s; main: status 0; not in a walk: the path parted earlier, and at t = 0.775-0.78 s the ball sinks ~0.8
 * mm a step through sub-steps the halving rule takes at ratios 0.7-1.3 with no regime change) -- and G1's
 * drop from a height takes 2-3.5 % more calls at 1-2 ms. Also dropped: the same growth off the grid,
 * ending on the step's end (a walker2d row failed over 704 starts), and off the grid on every walk with a
 * target of split (humanoid calls -4.6 %, rows flagged wrong 7 -> 10, the largest rise 10.3 -> 15.3 J,
 * errors against Radau larger).
 *
 * Session 31 (benchmarks/results/fixedstep.md's notes): that rule landed (walk, fs_walk_size,
 * fs_pressing_in) after fs_creeps: the ball's row 12 sank through takes the halving rule made without
 * a halving, which a spinning ball on a stiff floor shows on main alone
 * (test_a_ball_spinning_on_a_stiff_floor_is_not_pressed_through_it_by_stick_slip_steps); with
 * fs_creeps the row ends as on main (status 20).  G1's +2-3.5 % calls on bench_fixedstep's drop are
 * its path's: over 10 start heights (+0 ... +0.9 mm) 9128 -> 9205 calls at 2 ms and 14261 -> 14127 at
 * 1 ms (single runs spread 809-994 and 1347-1575), and only 5 tries of its 2 ms drop were grown
 * past the grid's doubling (1 failed): no cap.
 */
static int fs_fast_advance(void *self, double t, double h, const double *x, double **x1, double **f1,
                           const double **e1)
{
    fs_fast *q = (fs_fast *)self;
    const eomc_fs_ops *ops = q->ops;
    const double *xs = x, *lim = ops->imp->depth_limit;
    int s, pos = 0, size = MAX_SPLIT, n = q->n, quiet, sw, grow;
    double split = ops->imp->split > 0.0 ? ops->imp->split : INFINITY;
    if (q->deep >= 0) return EOMC_PENETRATED;
    if (!q->have_T) {
        if ((s = ops->terms(ops->ctx, t, x, q->T))) return s;
        q->have_T = 1;
        q->vT = 0;
        q->lT = 0;
        q->hA = 0.0;
    }
    double before = INFINITY;          /* the ratio of the twice longer try from here */
    int hard_end = 0;                  /* where the last try split past HARD_FACTOR ended (grid units) */
    int onset = -1;                    /* a located touch-down's cell: the next take ends at it */
    int located = 0;                   /* this try ends at a located onset (it stands for the whole step) */
    int walk = 0;                      /* a located onset cell was taken: the walk back (fs_walk_size) */
    while (pos < MAX_SPLIT) {
        double ts = t + h * pos / MAX_SPLIT, hs = size == MAX_SPLIT ? h : h * size / MAX_SPLIT, ratio;
        if (q->hA != hs || (q->A == q->bare && !fs_ahead(q, hs))) {
            q->bare = NULL;
            if (fs_assemble_ahead(q, hs, xs)) {
                q->bare = q->A;         /* the lanes gave this try's du and rate, A unwritten */
            } else if ((s = fs_assemble(ops, &q->L, hs, xs + ops->nq, q->T, q->A, q->b, q->GJ, q->cT, &q->vT, FS_TL(q),
                                        &q->pat, q->own, &q->start, &q->anc))) {
                q->st->t_fail = ts;
                return s;
            }
            q->hA = hs;
            q->st->nlu++;
        }
        s = fs_fast_try(q, ts, hs, xs, split < INFINITY, &ratio);
        FS_TRACE_TRY(q, t, pos, size, s, ratio, onset, walk, located);
        if (s && s != EOMC_NONFINITE && s != EOMC_SINGULAR_MASS_MATRIX) return s;
        /* a whole step that misses by a little with no contact or joint law changing regime
         * inside it: the friction of a stance switching between stick and slip, which
         * halving does not mend (see fs_switched) */
        if ((size == MAX_SPLIT || located) && !s && ratio > split
            && ratio <= FRICTION_FACTOR * split && !(q->chart > split) && (!fs_switched(q) || fs_releases(q))
            && !fs_creeps(q))
            goto take;
        located = 0;
        /* split while the test fails and splitting helps: a linearisation error shrinks with
         * the step (the ratio falls at least by half per halving); one that does not (a
         * regularised friction law switching between stick and slip, where its slope jumps
         * by mu F_n / v_s) is no instability, and splitting it further only costs calls.  A
         * try in which a contact lands deep or is pressed in is split regardless (fs_lands,
         * fs_creeps) */
        if ((s || (ratio > split && (ratio > HARD_FACTOR * split || !(ratio > 0.5 * before) || q->chart > split
                                      || fs_lands(q) || fs_creeps(q))))
            && size > 1) {
            if (s || (ratio > HARD_FACTOR * split && fs_switched(q) == FS_OTHER)) hard_end = pos + size;
            before = s ? INFINITY : ratio;
            if (!s) {
                int cell = fs_onset_cell(q, pos, size, hs, xs, ratio > HARD_FACTOR * split);
                if (cell >= 0) {
                    onset = cell;
                    located = cell > pos;
                    size = cell > pos ? cell - pos : 1;
                    before = INFINITY;
                    continue;
                }
            }
            size /= 2;
            continue;
        }
        if (s) {
            q->st->t_fail = ts + hs;
            return s;
        }
        /* a touch-down's onset cell is not counted (see above: the correction there is the
         * implicit Euler impulse of the new contact's end force, which no step size shrinks) */
        if (size == 1 && ratio > HARD_FACTOR * split && fs_switched(q) != FS_TOUCHDOWN) {
            if ((s = fs_last_cell(q, ts, hs, xs, &ratio))) {     /* Newton on the cell */
                q->st->t_fail = ts + hs;
                return s;
            }
            if (ratio > HARD_FACTOR * split) q->st->rejected++;
        }
    take:
        /* a sub-step that ends before a hard failure's end (below) and changes no regime; sw is
         * read only there and in a walk (a whole step's take needs no class: fs_switched was ~2.6 %
         * of the ant's checked call, perf, session 33) */
        sw = pos + size < hard_end || walk ? fs_switched(q) : 0;
        quiet = pos + size < hard_end && !sw;
        /* the walk back grows from this take's ratio: no regime change in it, or only the landed
         * contacts pressing in */
        grow = walk && split < INFINITY && ratio >= 0.0 && (!sw || (sw == FS_OTHER && fs_pressing_in(q)));
        before = INFINITY;
        q->st->nlu++;
        pos += size;
        fs_swap(&q->T, &q->T1);
        fs_swap(&q->A, &q->A1);
        fs_swap_lists(q);
        fs_swap(&q->b, &q->b1);
        fs_swap(&q->cT, &q->cT1);
        {
            int v = q->vT;
            q->vT = q->vT1;
            q->vT1 = v;
            v = q->lT;
            q->lT = q->lT1;
            q->lT1 = v;
            q->it = 1 - q->it;
        }
        if (pos < MAX_SPLIT) {                  /* a sub-step ended inside the step */
            memcpy(q->xs, q->x1, (size_t)n * sizeof(double));
            xs = q->xs;
            if (pos == onset) {                 /* the located onset cell next */
                size = 1;
                walk = 1;
            } else {
                int grid = size;
                if ((size & (size - 1)) == 0 && pos % size == 0) {
                    if (pos % (2 * size) == 0) grid = 2 * size;
                } else {                        /* back on the halving grid */
                    int p = 1;
                    while (pos % (2 * p) == 0 && 2 * p <= size) p *= 2;
                    grid = p;
                }
                size = grow ? fs_walk_size(pos, size, grid, ratio, split) : grid;
            }
            if (pos > onset) onset = -1;
            if (size > MAX_SPLIT - pos) size = MAX_SPLIT - pos;
            while (quiet && size > 1 && pos + size >= hard_end) size /= 2;
        }
    }
    if (lim)
        for (int c = 0; c < ops->imp->ncontact && q->deep < 0; c++)
            if (q->T[q->L.contact + 25 * (size_t)c] > lim[c]) q->deep = c;
    *x1 = q->x1;
    *f1 = q->f1;          /* not used by the fast path; accept writes it only when projecting */
    *e1 = NULL;           /* the energy at x1: T holds the terms there (the last take's T1) */
    if (ops->imp->energy) *e1 = q->T + q->L.energy;
    return EOMC_OK;
}

/* fs_loop's step for the W-method: fs_advance, from f = f(t, x) (evaluated on the first
 * step, then the previous step's f1). */
typedef struct fs_slow {
    fs w;
    int have_f;
} fs_slow;

static int fs_slow_advance(void *self, double t, double h, const double *x, double **x1, double **f1,
                           const double **e1)
{
    fs_slow *q = (fs_slow *)self;
    int s;
    if (q->have_f)
        memcpy(q->w.f, q->w.f1, (size_t)q->w.n * sizeof(double));
    else if ((s = q->w.ops->rhs(q->w.ops->ctx, t, x, q->w.f)))
        return s;
    q->have_f = 1;
    if ((s = fs_advance(&q->w, t, h, x))) return s;
    *x1 = q->w.x1;
    *f1 = q->w.f1;
    *e1 = NULL;
    return EOMC_OK;
}

/* The fixed grid both paths walk: steps of h from t0, the last one shortened to end on t1
 * (every step but the last is exactly h, so a kept LU stays valid); each step's end goes
 * through ops->accept (output rows, events, projection) before it becomes x. */
static int fs_loop(const eomc_fs_ops *ops, eomc_stats *st, int n, double h, long maxs, double t0,
                   double t1, double *x, double *slope,
                   int (*advance)(void *, double, double, const double *, double **, double **,
                                  const double **),
                   void *self)
{
    long nsteps = (long)ceil((t1 - t0) / h * (1 - 1e-12));
    int s;
    if (nsteps < 1) nsteps = 1;
    for (long k = 0; k < nsteps; k++) {
        double t = t0 + k * h, tn = (k == nsteps - 1) ? t1 : t0 + (k + 1) * h;
        double hh = (k == nsteps - 1) ? t1 - t : h, *x1, *f1;
        const double *e1;
        int stop = 0;
        st->t = t; st->h = hh;
        if (st->steps >= maxs) return EOMC_MAX_STEPS;
        st->steps++;
        if ((s = advance(self, t, hh, x, &x1, &f1, &e1))) return s;
        st->accepted++;
        for (int i = 0; i < n; i++) slope[i] = (x1[i] - x[i]) / hh;
        if ((s = ops->accept(ops->ctx, t, tn, x, slope, x1, f1, e1, &stop))) return s;
        if (stop) return EOMC_OK;
        memcpy(x, x1, (size_t)n * sizeof(double));
    }
    st->t = t1;
    return EOMC_OK;
}

/* The run's fixed lists, in work from blk (the tail of eomc_fs_implicit_work_size's doubles: fs_pattern's
 * tree and cross bits and scratch bits, the two own lists, the ancestor lists, M's column lists, N's
 * lists): per-step fill (fs_pattern) with M's tree given and at most 64 speeds, else every pair's
 * fill at every step.  The lanes rollout's rows too: the lanes never write A or A1 (bare), so their
 * pattern (eomc_fs_lanes: per call, the union of the group's) is not this one's; the scalar
 * assemblies of its rows (a split step's tries: 7469 a 64-row humanoid rollout, fs_tree_lu half of
 * them, perf) take the per-step fill as the scalar rollout's do.  They depend on the model alone
 * (its tree, contacts' chains, free joints, N's constants: q->T holds terms_const's), so where
 * eomc_implicit.pattern holds them (made once per model: eomc_fs_pattern) the run reads them there
 * (read-only; the scratch bits and own lists stay in blk): ~4 us a row on gymnasium's humanoid (138
 * contacts' branch masks, the lists), what a rollout of one step a call paid per row (session 53).
 * mark: nu * nu bytes of scratch. */
static void fs_fixed_lists(fs_fast *q, double *blk, unsigned char *mark)
{
    const eomc_implicit *imp = q->ops->imp;
    int nq = q->ops->nq, nu = q->ops->nu;
    size_t uu = (size_t)nu * nu, own = uu / 2 + nu + 2;
    int nc = imp->ncontact, dyn = imp->parent != NULL && nu <= 64;
    int made = imp->pattern != NULL && imp->pattern_len == fs_fixed_len(nq, nu, nc);
    /* the lists: read where they were made once, else made here in blk (the same offsets) */
    const double *fixed = made ? imp->pattern : blk;
    const unsigned long long *tree = (const unsigned long long *)fixed;
    const int *lists = (const int *)(fixed + 2 * (size_t)nu + nc + 2 * own);
    q->pat.bits = (unsigned long long *)blk + nu + nc;      /* scratch: always the run's own */
    q->own = (int *)(blk + 2 * (size_t)nu + nc);
    q->own1 = (int *)(blk + 2 * (size_t)nu + nc + own);
    if (!made) {
        unsigned long long *mtree = (unsigned long long *)blk, *mcross = mtree + nu;
        int *mlists = (int *)(blk + 2 * (size_t)nu + nc + 2 * own), *mcstart, *mnstart;
        fs_ancestors(nu, imp->parent, dyn ? NULL : imp, mark, mlists, mlists + nu + 1);
        for (int k = 0; k < nu; k++) {
            mtree[k] = 0;
            for (int x = mlists[k]; dyn && x < mlists[k + 1]; x++) mtree[k] |= 1ULL << mlists[nu + 1 + x];
        }
        for (int c = 0; c < nc; c++) {     /* a chain that is not on one path joins two branches */
            unsigned long long m = 0;
            int path = 1;
            for (int x = imp->chain_start[c]; dyn && x < imp->chain_start[c + 1]; x++) m |= 1ULL << fs_speed(imp->chain[x]);
            for (int x = imp->chain_start[c]; dyn && x < imp->chain_start[c + 1]; x++) {
                int sp = fs_speed(imp->chain[x]);
                if (m & ((1ULL << sp) - 1) & ~mtree[sp]) path = 0;
            }
            mcross[c] = path ? 0 : m;
        }
        mcstart = mlists + nu + 1 + mlists[nu];
        fs_columns(nu, mlists, mlists + nu + 1, mcstart, mcstart + nu + 1);
        mnstart = (int *)((double *)mlists + (uu / 2 + nu + 2) + (uu / 2 + nu / 2 + 2));
        fs_nlists(imp, nq, nu, q->T + q->L.N, imp->terms_const != NULL, mnstart, mnstart + nq + 1,
                  mnstart + nq + 1 + (size_t)nq * nu, mnstart + nq + 1 + (size_t)nq * nu + nq + 1);
    }
    q->pat.n = nu;
    q->pat.start = lists;
    q->pat.anc = lists + nu + 1;
    q->pat.tree = dyn ? tree : NULL;
    q->pat.cross = tree + nu;
    q->start = q->start1 = q->pat.start;
    q->anc = q->anc1 = q->pat.anc;
    q->cstart = lists + nu + 1 + lists[nu];
    q->cols = q->cstart + nu + 1;
    q->nstart = (const int *)((const double *)lists + (uu / 2 + nu + 2) + (uu / 2 + nu / 2 + 2));
    q->ncol = q->nstart + nq + 1;
    q->fstart = q->ncol + (size_t)nq * nu;
    q->fcol = q->fstart + nq + 1;
}

#ifndef EOMC_FS_AVX2_COPY
/* eomc_implicit.pattern for imp: its run's fixed lists (fs_fixed_lists) in out (fs_fixed_len(nq, nu,
 * imp->ncontact) doubles, that many returned; out NULL: the count only), made with work (imp->work_len
 * doubles) as a run makes them.  imp->pattern must be NULL here. */
size_t eomc_fs_pattern(const eomc_implicit *imp, int nq, int nu, double *work, double *out)
{
    size_t len = fs_fixed_len(nq, nu, imp->ncontact), size = fs_layout_of(nq, nu, imp->ncontact).size;
    eomc_fs_ops ops;
    fs_fast q;
    if (out == NULL || imp->pattern != NULL) return len;
    memset(&ops, 0, sizeof ops);
    memset(&q, 0, sizeof q);
    ops.imp = imp; ops.nq = nq; ops.nu = nu;
    q.ops = &ops;
    q.L = fs_layout_of(nq, nu, imp->ncontact);
    q.T = work;
    memset(q.T, 0, size * sizeof(double));
    if (imp->terms_const) {     /* N's constants, as eomc_fs_run's buffers hold them */
        for (size_t i = 0; i < (size_t)nq * nu; i++) q.T[q.L.N + i] = NAN;
        imp->terms_const(q.T);
    }
    fs_fixed_lists(&q, work + size + (size_t)nu * nu, (unsigned char *)(work + size));
    memcpy(out, work + size + (size_t)nu * nu, len * sizeof(double));
    return len;
}
#endif

#if defined(EOMC_FS_AVX2) && !defined(EOMC_FS_AVX2_COPY)
/* weak: a build of this file without eomc_fixedstep_avx2.c (a test's harness) runs the SSE2 step */
int eomc_fs_run_avx2(const eomc_fs_ops *ops, eomc_stats *st, int nx, double h, long max_steps,
                     double t0, double t1, double *x, double *work) __attribute__((weak));
#endif
#ifdef EOMC_FS_AVX2_COPY
#define eomc_fs_run eomc_fs_run_avx2
#endif
int eomc_fs_run(const eomc_fs_ops *ops, eomc_stats *st, int nx, double h, long max_steps,
                double t0, double t1, double *x, double *work)
{
    long maxs = max_steps > 0 ? max_steps : DEFAULT_MAX_STEPS;
    int s;
#if defined(EOMC_FS_AVX2) && !defined(EOMC_FS_AVX2_COPY)
    const char *sse2 = getenv("EOMC_FS_NO_AVX2");
    if (eomc_fs_run_avx2 != NULL && __builtin_cpu_supports("avx2") && (sse2 == NULL || sse2[0] == '\0'))
        return eomc_fs_run_avx2(ops, st, nx, h, max_steps, t0, t1, x, work);
#endif
    if (!(h > 0) || !isfinite(h)) return EOMC_BAD_ARGUMENT;
    if (ops->terms) {
        fs_fast q;
        int nq = ops->nq, nu = ops->nu, n = nq + nu;
        double *pos = work, *slope;
        size_t uu = (size_t)nu * nu;
        memset(&q, 0, sizeof q);
        q.ops = ops; q.st = st; q.n = n; q.deep = -1;
        q.L = fs_layout_of(nq, nu, ops->imp->ncontact);
        q.T = pos; pos += q.L.size;
        q.T1 = pos; pos += q.L.size;
        /* zeros first: the pairs' loop keeps its slope block in these buffers from call to call
         * (compiler/contact/table.KEPT_BLOCK) and zeroes only the records it finds written, so a
         * buffer's first call must not find stale numbers there (the caller's work may hold any) */
        memset(q.T, 0, 2 * q.L.size * sizeof(double));
        if (ops->imp->terms_const) {    /* the terms' constant outputs, once (terms: the rest) */
            for (size_t i = 0; i < (size_t)nq * nu; i++) q.T[q.L.N + i] = NAN;   /* fs_nlists */
            ops->imp->terms_const(q.T);
            ops->imp->terms_const(q.T1);
        }
        q.A = pos; pos += uu;
        q.A1 = pos; pos += uu;
        q.b = pos; pos += nu;
        q.b1 = pos; pos += nu;
        q.du = pos; pos += nu;
        q.dv = pos; pos += nu;
        q.dun = pos; pos += nu;
        q.GJ = pos; pos += 3 * (size_t)nu;
        q.dug = pos; pos += nu;
        q.dub = pos; pos += nu;
        q.cT = pos; pos += fs_cache_size(nu, ops->imp->ncontact);
        q.cT1 = pos; pos += fs_cache_size(nu, ops->imp->ncontact);
        q.x1 = pos; pos += n;
        q.xs = pos; pos += n;
        slope = pos; pos += n;
        q.f1 = pos; pos += n;           /* accept's f1: quaternions rescale it; not read back */
        memset(q.f1, 0, (size_t)n * sizeof(double));
        fs_fixed_lists(&q, pos, (unsigned char *)q.A1);
        s = fs_loop(ops, st, n, h, maxs, t0, t1, x, slope, fs_fast_advance, &q);
        if (s == EOMC_OK && q.deep >= 0) s = EOMC_PENETRATED;
        return s;
    } else {
        fs_slow q;
        int n = nx;
        double *pos = work;
        q.have_f = 0;
        q.w.ops = ops; q.w.st = st; q.w.n = n; q.w.h_lu = 0.0;
        q.w.J = pos; pos += (size_t)n * n;
        q.w.A = pos; pos += (size_t)n * n;
        q.w.f = pos; pos += n;
        q.w.dx = pos; pos += n;
        q.w.x1 = pos; pos += n;
        q.w.f1 = pos; pos += n;
        q.w.r = pos; pos += n;
        q.w.slope = pos; pos += n;
        q.w.best = pos; pos += n;
        q.w.xs = pos; pos += n;
        q.w.piv = (int *)pos;
        return fs_loop(ops, st, n, h, maxs, t0, t1, x, q.w.slope, fs_slow_advance, &q);
    }
}
