/* eomc_batch.h -- evaluate a model's right-hand side over many states in one C loop.
 *
 * Shipped with eomc and linked into every model library, so that a batched
 * call from Python crosses the language boundary once instead of once per
 * state (the per-call wrapper cost dominates small models).
 */
#ifndef EOMC_BATCH_H
#define EOMC_BATCH_H

#include <stddef.h>
#include "eomc_model.h"

#ifdef __cplusplus
extern "C" {
#endif

/*
 * XD[i, :] = rhs(t[i * t_stride], X[i, :], p, R + i * r_stride) for i < n.
 * X and XD are n x nx row-major; t_stride is 0 for one time for all rows,
 * r_stride is 0 for one input vector for all rows (or ninput for one per row).
 * Stops at the first row whose status is not EOMC_OK, stores its index in
 * *failed_row and returns that status.
 */
int eomc_rhs_many(const eomc_model *model, size_t n,
                  const double *t, size_t t_stride,
                  const double *X, const double *p,
                  const double *R, size_t r_stride,
                  double *XD, double *work, size_t *failed_row);

#ifdef __cplusplus
}
#endif

#endif /* EOMC_BATCH_H */
