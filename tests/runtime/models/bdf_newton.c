/* A harness for BDF's Newton linear solve (eomc_bdf_linear_solve): test_bdf.py hands it a
 * Jacobian with a multibody state's structure and checks x against a dense solve. */
#include <stdlib.h>
#include <string.h>

#include "eomc_bdf.h"

static int no_rhs(void *u, double t, const double *x, double *f)
{
    (void)u; (void)t; (void)x; (void)f;
    return EOMC_OK;
}

static int no_jac(void *u, double t, const double *x, double *J)
{
    (void)u; (void)t; (void)x; (void)J;
    return EOMC_OK;
}

static int not_aborted(void *u)
{
    (void)u;
    return 0;
}

/* r <- (I - c J)^-1 r with the state split after nsplit coordinates; the rows the LU held,
 * -1 if singular, -2 out of memory. */
int bdf_newton_solve(int n, int nsplit, const double *J, double c, double *r)
{
    eomc_stats st;
    eomc_bdf b;
    eomc_bdf_fns fns = {NULL, no_rhs, no_jac, not_aborted};
    double *work = malloc(eomc_bdf_work_size(n) * sizeof(double));
    int k;
    if (!work) return -2;
    memset(&st, 0, sizeof st);
    eomc_bdf_init(&b, &fns, &st, n, 1e-6, 1e-6, 1.0, 0, work);
    b.nsplit = nsplit;
    memcpy(b.J, J, (size_t)n * n * sizeof(double));
    k = eomc_bdf_linear_solve(&b, c, r);
    free(work);
    return k;
}
