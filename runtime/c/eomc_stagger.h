/*
 * eomc_stagger.h -- the integrators' hook for forward sensitivities (internal to eomc:
 * eomc_integrators.c and eomc_sensitivity.c; not part of the model ABI, not read by cffi).
 *
 * Two ways the sensitivities S = dx/dtheta ride a run without steering it (CVODES's
 * errconS = false: the step sequence is the plain run's):
 *   - explicit methods integrate the augmented model [x; S] of eomc_sensitivity.c, whose
 *     rhs is the model's jvp; n_err says how many leading states (nx) the error test, the
 *     starting step and the stiffness test look at;
 *   - Radau integrates the plain model and, after each accepted step, solves the linear
 *     collocation equations of S on that step with the step's own Newton matrix and LU
 *     (staggered direct, as CVODES does for BDF): residuals from jvp at the three stage
 *     points (later iterations: the correction from one jvp call at the middle stage),
 *     one real and one complex solve per column per iteration.
 */
#ifndef EOMC_STAGGER_H
#define EOMC_STAGGER_H

#include "eomc_integrators.h"

/* The model's generated NAME_jvp: xdot and J [dx; dp] for k directions (rows of dirs). */
typedef int (*eomc_dirs_fn)(double t, const double *x, const double *p, const double *r, int k,
                            const double *dirs, double *xdot, double *out, double *work);

typedef struct eomc_stagger {
    int n_err;            /* > 0: states the error test sees (explicit methods) */
    int n_fin;            /* > 0: derivatives the integrator checks for finiteness (explicit
                             methods: the state part; the augmented rhs's jvp reports a
                             non-finite S derivative itself, NAME_finite over its out) */
    int k;                /* Radau: sensitivity columns (0: none) */
    eomc_dirs_fn jvp;     /* Radau: the model's jvp */
    eomc_jvp_more_fn jvp_more;  /* Radau: the model's jvp_more, or NULL (eomc_integrators.c,
                                   sg_more: the second iteration in the first one's call) */
    int ndir;             /* nx + nparam */
    double *D;            /* k x ndir directions: parameter parts preset by the caller */
    double *S;            /* nx * k: S(t0) in, S at the time reached out; column j at j nx */
    double *S_out;        /* n_eval rows of nx * k (may be NULL when n_eval == 0) */
    int ld_out;           /* > 0: row stride of x_out and S_out (rows [x, S] of one table:
                             S_out = x_out + nx, ld_out = nx (1 + k)); 0: nx and nx k */
    long njvp;            /* out: jvp calls */
    long niter;           /* out: sensitivity iterations (a step's first: 3 jvp calls, each
                             later one: 1, with 3 k directions) */
    long nslow;           /* out: steps whose sensitivity iteration had not converged
                             after EOMC_SG_MAXIT iterations (kept, counted) */
    int full_solves;      /* Radau: 1 keeps S's solves over whole rows (0: the LU's top rows
                             skipped where J's top rows are [0 I], eomc_integrators.c
                             sg_top_structure: the same solution, fewer products) */
    long ntrim;           /* out: factorizations whose S solves skipped those entries */
    /* DOPRI5/DOP853/Radau for the adjoint (eomc_adjoint.c): checkpoints of the accepted steps. */
    int ntstop;           /* steps end exactly on these times (increasing, inside (t0, t1]) */
    const double *tstop;
    long rec_cap;         /* > 0: record up to rec_cap accepted steps */
    double *rec_t;        /* rec_cap + 1: each accepted step's start time, then the end time */
    double *rec_x;        /* rec_cap x nx: each accepted step's start state */
    double *rec_k;        /* NULL, or per accepted step s x nx: DOP853's 12 stage derivatives,
                             Radau's 3 converged stage increments Z (x + Z_a at c_a h) */
    long nrec;            /* out: accepted steps (also past rec_cap: the caller retries larger) */
} eomc_stagger;

/* DOP853's tableau as the integrators use it (12 stages; A rows of 16, B, C). */
void eomc_dop853_tableau(const double **A, int *astride, const double **B, const double **C);

#define EOMC_SG_MAXIT 10

/* Doubles of work the Radau hook adds to eomc_integrate_work_size. */
size_t eomc_stagger_work_size(int nx, int k, int ndir);

/* eomc_integrate with the hook (sg may be NULL: eomc_integrate). */
int eomc_integrate_sg(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                      const double *x0, const double *p, int n_rgrid, const double *r_tgrid,
                      const double *r_values, int n_eval, const double *t_eval, double *x_out,
                      double *x_last, eomc_stats *stats, double *work, size_t work_len,
                      eomc_stagger *sg);

#endif /* EOMC_STAGGER_H */
