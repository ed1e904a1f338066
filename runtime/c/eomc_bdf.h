/*
 * eomc_bdf.h -- the variable-order, variable-step BDF/NDF integrator (EOMC_BDF), internal.
 *
 * Not part of the cffi API (header_cdef reads eomc_integrators.h only): users reach it
 * through eomc_integrate with opt.method = EOMC_BDF.  The method itself (predictor,
 * Newton, error test, order and step selection, the difference array and its dense
 * output) lives in eomc_bdf.c; what every method shares (input interpolation,
 * non-finite checks, Ctrl-C, events, switching points, output rows, projection) stays in
 * eomc_integrators.c, which drives the steps through the calls below: a trial step is
 * computed without committing it, so the driver can look at it (events located on its dense
 * output, switching functions watched for the verdict: BDF passes over switching points,
 * run_bdf) before it commits it.
 */
#ifndef EOMC_BDF_H
#define EOMC_BDF_H

#include "eomc_integrators.h"

#define EOMC_BDF_MAX_ORDER 5
/* At most this many coordinates whose rates other rates depend on (a free joint's three angles)
 * are eliminated from Newton's LU with the rest (factor_lu in eomc_bdf.c); more stay in it. */
#define EOMC_BDF_MAX_DEP 8

typedef struct eomc_bdf_fns {
    void *ctx;
    /* f = rhs(t, x) with the run's inputs; an eomc_status */
    int (*rhs)(void *ctx, double t, const double *x, double *f);
    /* J = d rhs / d x (nx x nx, row-major), feedback included; an eomc_status */
    int (*jac)(void *ctx, double t, const double *x, double *J);
    /* nonzero (the run's status) when the run must stop now: Ctrl-C, a failed callback */
    int (*aborted)(void *ctx);
} eomc_bdf_fns;

typedef struct eomc_bdf {
    const eomc_bdf_fns *fns;
    eomc_stats *st;
    int n;
    double rtol, atol, hmax, newton_tol;
    long max_steps;
    /* the accepted solution: t, the step h the differences are spaced by, the order */
    double t, h;
    int order, n_equal;      /* steps taken with this h and order (a change waits order + 1) */
    double *D, *Dn;          /* (MAX_ORDER + 3) x n backward differences: accepted, trial */
    double tn, ht;           /* the trial step's end and length (valid after eomc_bdf_trial) */
    int trial_order;         /* the order the trial step used (its dense output's degree) */
    double trial_err, trial_safety;  /* its error norm and step safety factor */
    double *J, *LU;
    int *piv;
    double c_lu;             /* the c = h / alpha of the factored I - c J; 0: none */
    int nsplit;              /* the state is (q, v, ...) with nsplit q's and v's; 0: not known */
    int nkeep, *keep;        /* the rows the LU holds (factor_lu); nkeep = n: all */
    int nelim, *elim;        /* the q rows eliminated before the LU (factor_lu), in order */
    int ndep, *dep;          /* of those, the ones q rates depend on (indices into elim) */
    int *znz, *zcnt;         /* Z's nonzero columns per eliminated row, and their count */
    double *Z;               /* nelim x nkeep: (I - c J_ee)^-1 J_ek (factor_lu) */
    double LUd[EOMC_BDF_MAX_DEP * EOMC_BDF_MAX_DEP];  /* I - c J_dd factored (ndep > 0) */
    int pivd[EOMC_BDF_MAX_DEP];
    double *rk;              /* n: the kept rows' right-hand side (solve_lu) */
    int cur_jac;             /* J was evaluated at the current step's start or later */
    int jac_failed;          /* the last J evaluation failed: J holds no Jacobian (a
                                rejected step then takes one at its next predictor) */
    int err_fails;           /* consecutive error-test failures at this step */
    int bad;                 /* the last model failure while the step kept shrinking: the
                                run's status when it becomes too small (0: none) */
    double *ypred, *psi, *ynew, *d, *f, *scale, *dy;
} eomc_bdf;

/* Doubles of work the integrator needs for n states. */
size_t eomc_bdf_work_size(int n);

/* Set up over work (eomc_bdf_work_size(n) doubles); nothing is evaluated yet. */
void eomc_bdf_init(eomc_bdf *b, const eomc_bdf_fns *fns, eomc_stats *st, int n, double rtol,
                   double atol, double hmax, long max_steps, double *work);

/* (Re)start at order 1 from (t, y) with slope f and first step h: at the run's start and
 * after a switching point (the law changed form: the history is not smooth across it).
 * Evaluates the Jacobian at (t, y).  An eomc_status. */
int eomc_bdf_start(eomc_bdf *b, double t, const double *y, const double *f, double h);

/* Try steps from b->t (shrinking on Newton or error-test failure) until one passes; it
 * ends at b->tn <= t1 with the state b->ynew and is NOT committed: the driver looks at
 * it (events, switching functions, output rows) and commits it.  An eomc_status: EOMC_STEP_TOO_SMALL,
 * EOMC_MAX_STEPS, or the model's failure when a model evaluation kept failing. */
int eomc_bdf_trial(eomc_bdf *b, double t1);

/* The trial step's dense output at tau in [b->t, b->tn] (its interpolating polynomial). */
void eomc_bdf_dense(const eomc_bdf *b, double tau, double *out);

/* Accept the trial step: b->t = b->tn; chooses the next order and step. */
void eomc_bdf_commit(eomc_bdf *b);

/* The accepted state was changed after the step (unit quaternions, projection). */
void eomc_bdf_set_state(eomc_bdf *b, const double *y);

/* Newton's linear solve as the steps do it (factor_lu, solve_lu): r <- (I - c J)^-1 r with the
 * J the caller put in b->J (and b->nsplit set).  The rows the dense LU held, or -1 if the
 * matrix is singular.  For tests: the row elimination must give the dense solve's x. */
int eomc_bdf_linear_solve(eomc_bdf *b, double c, double *r);

#endif /* EOMC_BDF_H */
