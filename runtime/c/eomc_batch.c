/* eomc_batch.c -- see eomc_batch.h. */
#include "eomc_batch.h"

int eomc_rhs_many(const eomc_model *model, size_t n,
                  const double *t, size_t t_stride,
                  const double *X, const double *p,
                  const double *R, size_t r_stride,
                  double *XD, double *work, size_t *failed_row)
{
    size_t i;
    const size_t nx = (size_t)model->nx;
    if (model->rhs == NULL)
        return EOMC_NOT_AVAILABLE;
    for (i = 0; i < n; ++i) {
        const double *r = R ? R + i * r_stride : NULL;
        int status = model->rhs(t[i * t_stride], X + i * nx, p, r,
                                XD + i * nx, work);
        if (status != EOMC_OK) {
            if (failed_row)
                *failed_row = i;
            return status;
        }
    }
    return EOMC_OK;
}
