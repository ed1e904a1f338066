/* eomc_rows.c -- a model function along rows in one call (see eomc_mat_rows in eomc_integrators.h).
 *
 * Compiled into the integrator library at install (setup.py), not into each model: the
 * function comes by pointer, so one copy serves every model (runtime/poses.py's rows for
 * the ground and pair verdicts along a run's output rows). */
#include "eomc_integrators.h"

int eomc_mat_rows(eomc_mat_fn fn, size_t n, const double *t, const double *X, size_t nx,
                  const double *p, const double *r, double *out, size_t nout,
                  double *work, size_t *failed_row)
{
    size_t i;
    if (fn == NULL)
        return EOMC_NOT_AVAILABLE;
    for (i = 0; i < n; ++i) {
        int status = fn(t[i], X + i * nx, p, r, out + i * nout, work);
        if (status != EOMC_OK) {
            if (failed_row)
                *failed_row = i;
            return status;
        }
    }
    return EOMC_OK;
}
