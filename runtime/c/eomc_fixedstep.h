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
     * holds the event's state).  energy1: the model's energy at (tn, x1) in the terms the fast path
     * made there (eomc_implicit.energy), or NULL.  An eomc_status. */
    int (*accept)(void *ctx, double t, double tn, double *x, const double *slope, double *x1,
                  double *f1, const double *energy1, int *stop);
    /* The fast path (MuJoCo's implicitfast, see eomc_fixedstep.c), when not NULL: out =
     * NAME_implicit(t, x) with the run's inputs; an eomc_status.  imp: its structure; the
     * state is x = [q (nq); u (nu)] (no extra states). */
    int (*terms)(void *ctx, double t, const double *x, double *out);
    const eomc_implicit *imp;
    int nq, nu;
    /* Optional (NULL: terms, then the assembly here): terms, and what req asks for (the step's
     * matrix and right side for a step of req->h from x assembled and factored as eomc_fixedstep.c's
     * fs_assemble does, the try's ratio, the next try's du and rate: eomc_fs_request) when the callee
     * can (req->done, req->ahead; 0: only out was written, the caller does the rest).  The lanes
     * rollout's (eomc_rollout.c: several rows' steps at once). */
    int (*terms_lu)(void *ctx, double t, const double *x, double *out, eomc_fs_request *req);
    /* Optional (NULL: fs_assemble here): no model call; out already holds the terms at x, and the
     * callee gives what req asks for without a ratio (req->du NULL): du1 and v1 for a step of req->h
     * from x (req->ahead), made with other rows' at once, or nothing (req->ahead 0: the caller
     * assembles its own).  The lanes rollout's (eomc_rollout.c): a split step's try at another size
     * than its matrix was made for. */
    int (*assemble_lu)(void *ctx, const double *x, double *out, eomc_fs_request *req);
    /* The run's parameters (NULL: none known): the joint limits' bounds (eomc_implicit.limit_bound) */
    const double *p;
} eomc_fs_ops;

/* Doubles of work eomc_fs_run needs for nx states. */
size_t eomc_fs_work_size(int nx);

/* Fixed steps of size h from t0 to t1 (the last one shortened to end on t1),
 * starting from x (overwritten with the end state, or the last good state on
 * failure).  Counts in st (steps, accepted, nlu; nfev and njev are the callbacks';
 * rejected = steps whose implicit equation was left unconverged). */
int eomc_fs_run(const eomc_fs_ops *ops, eomc_stats *st, int nx, double h, long max_steps,
                double t0, double t1, double *x, double *work);

/* ------------------------------------------------ the fast path's assembly in lanes
 *
 * fs_assemble (the matrix and right side of the fast path's step, factored) for `lanes` states
 * at once, the terms and speeds stored as columns (OUT[e * lanes + c], U[j * lanes + c]: what
 * NAME_implicit_batch writes and reads) and the matrices interleaved (one per lane, entry by
 * entry), so the elimination is vector code: every lane gets the scalar function's operations in
 * its order, so its bits.  Internal to the runtime (the lanes rollout's). */
typedef struct eomc_fs_lanes eomc_fs_lanes;

/* The plan and scratch for nq, nu and imp's structure; NULL when this machine has no vector
 * kernel for `lanes` (4 or 8 with AVX2: groups of 4; 8 with AVX-512F and DQ: one group of 8) or out
 * of memory. */
eomc_fs_lanes *eomc_fs_lanes_new(int nq, int nu, const eomc_implicit *imp, int lanes);
void eomc_fs_lanes_free(eomc_fs_lanes *w);

/* rows (NULL: none): lane c's terms e in rlo <= e < rhi are rows[c][e], not in OUT (the lanes
 * rollout's NAME_implicit_batch_rows writes the pairs' slope block there).
 * For each lane c with req[c] != NULL: fs_assemble of the terms OUT (64-byte aligned) for a step
 * of req[c]->h at the speeds U, then with that matrix req[c]->du's residual ratio (fs_fast_try's)
 * and the next try's du1 and v1 (eomc_fs_request) in ahead[c] (nu + nq doubles, kept by the
 * caller): req[c]->done = req[c]->ahead = 1, req[c]->A and b not written.  0 when the lane's pivot
 * test failed (nothing written: the caller runs the scalar code, which fails the same way). */
void eomc_fs_assemble_lanes(eomc_fs_lanes *w, const double *OUT, const double *U, eomc_fs_request *const *req,
                            double *const *ahead, const double *const *rows, size_t rlo, size_t rhi);

/* The outputs of NAME_implicit the fast path reads in a buffer before it asks for the whole
 * buffer (eomc_implicit.terms_whole): the contacts' depths and K's diagonals, the joint laws'
 * slopes, the root free joints' columns of N (fs_chart_ratio, fs_onset, fs_switched, the depth
 * limits; and the energy, eomc_implicit.energy).  Their indices into idx (room for 4 ncontact + 2 nu
 * + 6 nq nfree + 1), their count returned. */
size_t eomc_fs_tested_outputs(int nq, int nu, const eomc_implicit *imp, size_t *idx);

#endif /* EOMC_FIXEDSTEP_H */
