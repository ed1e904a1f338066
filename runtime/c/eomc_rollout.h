/* eomc_rollout.h -- many trajectories of one model, integrated on all cores in C threads.
 *
 * Compiled once with eomc (setup.py, into the integrator library), not into model
 * libraries.  Each row i is exactly one eomc_integrate call with the caller's options
 * (same method, step, output times), so a row agrees bit for bit with a scalar
 * simulate() of the same start; rows are handed to nthreads POSIX threads one at a time
 * (a shared counter), so a slow or failing row never holds up the others.  Each thread
 * allocates its own work buffer; nothing is shared but the read-only inputs.
 */
#ifndef EOMC_ROLLOUT_H
#define EOMC_ROLLOUT_H

#include <stddef.h>
#include "eomc_integrators.h"

#ifdef __cplusplus
extern "C" {
#endif

/*
 * Row i (< n): x0 = X0 + i * nx, p = P + i * p_stride (p_stride 0: one parameter
 * vector for all rows).  X_out (may be NULL when n_eval == 0): n x n_eval x nx, the
 * states at t_eval.  X_last: n x nx, the state at the end (or the last good state of
 * a failed row).  status: n, each row's eomc_status; steps (may be NULL): n, steps
 * taken.  nthreads <= 0 is taken as 1.  Returns EOMC_OK when every row succeeded,
 * EOMC_BAD_ARGUMENT when threads or buffers could not be made (nothing run), else the
 * status of the first failed row (by index).
 */
int eomc_rollout(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                 int n, const double *X0, const double *P, size_t p_stride,
                 int n_eval, const double *t_eval, double *X_out, double *X_last,
                 int *status, long *steps, int nthreads);

/*
 * eomc_rollout with inputs per row, and each row's whole eomc_stats (rejected steps, rhs
 * calls, the time reached, ...) in stats (n, may be NULL): what simulate() reports per run,
 * so a batch (simulate_many, eomc.sweep) can run its cases here and report each as simulate
 * would.  Inputs: n_rgrid == 0, none (zeros); else row i's grid of eomc_integrate is
 * (n_rgrid, r_tgrid, R + i * r_stride) -- one time grid shared, values per row (r_stride
 * 0: the same for all): a control sequence per trajectory.
 */
int eomc_rollout_stats(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                       int n, const double *X0, const double *P, size_t p_stride,
                       int n_rgrid, const double *r_tgrid, const double *R, size_t r_stride,
                       int n_eval, const double *t_eval, double *X_out, double *X_last,
                       int *status, long *steps, eomc_stats *stats, int nthreads);

/*
 * Per-row feedback and events for eomc_rollout_ex (either may be absent: NULL).
 *
 * fb: the feedback of eomc_integrate_ex; row i runs with a copy whose K is fb->K + i * K_stride
 * and x_ref fb->x_ref + i * ref_stride (0: one for every row) -- constant gains, or a gain
 * schedule (fb->n_kgrid) per row.  A callback (fb->fn) is refused: it would serialize the
 * threads on the caller's lock.
 *
 * ev: the events and switching functions of eomc_integrate_ex, read-only (n, fn, ncol, col,
 * direction, terminal, capacity, switching, nlin, lin_*, sw_observe); its record, scratch
 * and gmax pointers are not used.  Row i records into t_rec + i * capacity, id_rec + i *
 * capacity, x_rec + i * capacity * nx; n_rec[i] counts its occurrences (also past
 * capacity), terminated[i] says a terminal event ended it; gmax (may be NULL) + i *
 * gmax_len receives its switching maxima (gmax_len >= ev->n + ev->nlin).  Each thread
 * allocates its own events scratch.
 */
typedef struct eomc_rollout_extras {
    const eomc_feedback *fb;
    size_t K_stride, ref_stride;
    const eomc_events *ev;
    double *t_rec;
    int *id_rec;
    double *x_rec;
    int *n_rec, *terminated;
    double *gmax;
    size_t gmax_len;
} eomc_rollout_extras;

/*
 * eomc_rollout_stats with per-row feedback and events (ex may be NULL: eomc_rollout_stats).
 * Row i is exactly one eomc_integrate_ex call, so it equals a scalar run with the same
 * feedback and events bit for bit.
 */
int eomc_rollout_ex(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                    int n, const double *X0, const double *P, size_t p_stride,
                    int n_rgrid, const double *r_tgrid, const double *R, size_t r_stride,
                    const eomc_rollout_extras *ex,
                    int n_eval, const double *t_eval, double *X_out, double *X_last,
                    int *status, long *steps, eomc_stats *stats, int nthreads);

/*
 * A model's NAME_rhs_batch_p (compiler/emit/batch.py): xdot of n states stored as columns
 * (X[i*n + k]) with one parameter row per state (P[j*n + k]), several per instruction.
 */
typedef int (*eomc_batch_fn)(int n, double t, const double *X, const double *P, const double *R,
                             double *XDOT, int *status, double *work);

/*
 * RK4 over n rows in SIMD lanes: each thread takes blocks of `block` rows (<= 0: 64), stores
 * them as columns and makes each RK4 stage one f call over the block, with the step grid and
 * the order of arithmetic of eomc_integrate's RK4 -- so a row equals eomc_rollout's RK4 row
 * bit for bit wherever f equals the scalar rhs bit for bit.  Row i starts at X0 + i * nx
 * with parameters P + i * p_stride (0: one row for all).  X_out (NULL: not recorded): n x
 * (steps + 1) x nx, every step, NaN after a row failed.  X_last, status, steps (may be
 * NULL): as eomc_rollout (a failed row keeps its last good state; steps counts the step it
 * failed in).  Inputs (ninput of them): (n_rgrid, r_tgrid, R + i * r_stride) as
 * eomc_rollout_stats, interpolated at each stage as eomc_integrate does.  work_len: doubles
 * of the model's work buffer (f's scalar tail).  quat (nquat of them, may be NULL when 0): the
 * rows of x's unit quaternions' w (eomc_options.quat); each lane's are normalised at the start
 * and after every step (its k2 rows scaled alike), as eomc_integrate's RK4 does.  Returns
 * EOMC_OK, EOMC_BAD_ARGUMENT, or the status of the first failed row.
 */
int eomc_rollout_lanes(eomc_batch_fn f, int nx, int nparam, int ninput, size_t work_len, double t0, double t1,
                       double h, int n, const double *X0, const double *P, size_t p_stride,
                       int n_rgrid, const double *r_tgrid, const double *R, size_t r_stride, double *X_out,
                       double *X_last, int *status, long *steps, int block, int nthreads, int nquat,
                       const int *quat);

/*
 * eomc_rollout_stats with method EOMC_IMPLICITFAST's model calls (opt->implicit->terms,
 * NAME_implicit) made in SIMD lanes: each thread runs `lanes` rows at once, each in a fiber
 * running the scalar row's code, and evaluates the rows' waiting model calls together, one
 * batch (NAME_implicit_batch: X nx x k, OUT out_len x k, parameters shared) call per time and
 * parameter row.  reads_t: 0 when NAME_implicit does not read t (the model's metadata
 * implicit_batch.reads_t, compiler/emit/batch.py): its waiting calls are then batched whatever
 * their times (a split step's sub-steps end an ulp off the other rows' times).  A row is the
 * scalar row's step for step, so it equals eomc_rollout_stats's row bit for bit wherever batch
 * equals NAME_implicit bit for bit (-DEOMC_BATCH_LIBM_TRIG).
 * EOMC_BAD_ARGUMENT also when opt is not implicitfast with terms, or lanes is not 1..64.
 */
int eomc_rollout_implicit_lanes(const eomc_model *m, const eomc_options *opt, eomc_batch_fn batch, int lanes,
                                size_t out_len, int reads_t, double t0, double t1, int n, const double *X0, const double *P,
                                size_t p_stride, int n_rgrid, const double *r_tgrid, const double *R,
                                size_t r_stride, int n_eval, const double *t_eval, double *X_out,
                                double *X_last, int *status, long *steps, eomc_stats *stats, int nthreads);

/*
 * A model's NAME_implicit_batch_rows (compiler/emit/batch.py, made when its NAME_implicit writes a
 * body-body pairs' slope block): NAME_implicit_batch with that block (outputs block_first ..
 * block_first + block_len) written into rows[k], state k's own output buffer, instead of OUT.
 */
typedef int (*eomc_batch_rows_fn)(int n, double t, const double *X, const double *P, const double *R,
                                  double *OUT, double *const *rows, int *status, double *work);

/*
 * eomc_rollout_implicit_lanes with batch_rows: each round's call writes the pairs' slope block
 * straight into the waiting rows' buffers, so it is neither copied out of the batch's columns
 * nor assembled from them (eomc_fs_assemble_lanes reads those contacts from the rows).  Why: on
 * gymnasium's humanoid the block is 2725 of 4739 outputs, nearly all zeros, and its trip through
 * the columns was ~28 % of the lanes rollout's C time (session 26).  The same rows, bit for bit.
 */
int eomc_rollout_implicit_lanes_rows(const eomc_model *m, const eomc_options *opt, eomc_batch_rows_fn batch_rows,
                                     size_t block_first, size_t block_len, int lanes, size_t out_len, int reads_t,
                                     double t0, double t1, int n, const double *X0, const double *P,
                                     size_t p_stride, int n_rgrid, const double *r_tgrid, const double *R,
                                     size_t r_stride, int n_eval, const double *t_eval, double *X_out,
                                     double *X_last, int *status, long *steps, eomc_stats *stats, int nthreads);

#ifdef __cplusplus
}
#endif

#endif /* EOMC_ROLLOUT_H */
