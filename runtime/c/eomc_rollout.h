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
 * eomc_rollout, and each row's whole eomc_stats (rejected steps, rhs calls, the time
 * reached, ...) in stats (n, may be NULL): what simulate() reports per run, so a
 * batch (simulate_many, eomc.sweep) can run its cases here and report each as simulate would.
 */
int eomc_rollout_stats(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                       int n, const double *X0, const double *P, size_t p_stride,
                       int n_eval, const double *t_eval, double *X_out, double *X_last,
                       int *status, long *steps, eomc_stats *stats, int nthreads);

#ifdef __cplusplus
}
#endif

#endif /* EOMC_ROLLOUT_H */
