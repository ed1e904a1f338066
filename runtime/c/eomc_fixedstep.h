/*
 * eomc_fixedstep.h -- the fixed-step implicit integrator (EOMC_IMPLICITFAST), internal.
 *
 * Not part of the cffi API (header_cdef reads eomc_integrators.h only): users
 * reach it through eomc_integrate with opt.method = EOMC_IMPLICITFAST.  The
 * step itself lives in eomc_fixedstep.c; what every method shares (input
 * interpolation, non-finite checks, Ctrl-C, events, output rows, projection)
 * stays in eomc_integrators.c and is handed in as the callbacks below, so the
 * two files meet only at this small seam.
 */
#ifndef EOMC_FIXEDSTEP_H
#define EOMC_FIXEDSTEP_H

#include "eomc_integrators.h"

typedef struct eomc_fs_ops {
    void *ctx;
    /* f = rhs(t, x) with the run's inputs; an eomc_status */
    int (*rhs)(void *ctx, double t, const double *x, double *f);
    /* J = d rhs / d x (nx x nx, row-major), feedback included; an eomc_status */
    int (*jac)(void *ctx, double t, const double *x, double *J);
    /* The step [t, tn] from x to x1 is taken; slope = (x1 - x) / (tn - t) (its
     * linear interpolant).  Writes output rows, finds events, projects x1 (then
     * x1 changes and f1 = rhs(tn, x1) is evaluated again).  *stop = 1 when a terminal event ended the run (x then
     * holds the event's state).  An eomc_status. */
    int (*accept)(void *ctx, double t, double tn, double *x, const double *slope, double *x1,
                  double *f1, int *stop);
    /* The fast path (MuJoCo's implicitfast, see eomc_fixedstep.c), when not NULL: out =
     * NAME_implicit(t, x) with the run's inputs; an eomc_status.  imp: its structure; the
     * state is x = [q (nq); u (nu)] (no extra states). */
    int (*terms)(void *ctx, double t, const double *x, double *out);
    const eomc_implicit *imp;
    int nq, nu;
} eomc_fs_ops;

/* Doubles of work eomc_fs_run needs for nx states. */
size_t eomc_fs_work_size(int nx);

/* Fixed steps of size h from t0 to t1 (the last one shortened to end on t1),
 * starting from x (overwritten with the end state, or the last good state on
 * failure).  Counts in st (steps, accepted, nlu; nfev and njev are the callbacks';
 * rejected = steps whose implicit equation was left unconverged). */
int eomc_fs_run(const eomc_fs_ops *ops, eomc_stats *st, int nx, double h, long max_steps,
                double t0, double t1, double *x, double *work);

#endif /* EOMC_FIXEDSTEP_H */
