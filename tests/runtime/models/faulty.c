/* Failure stand-ins.  blowup: x' = x^2 (infinite at t = 1/x0).
 * singular: x' = 1 but reports a singular mass matrix once t > p[0]. */
#include "eomc_model.h"

static int bl_rhs(double t, const double *x, const double *p, const double *r, double *xd, double *w)
{
    (void)t; (void)p; (void)r; (void)w;
    xd[0] = x[0] * x[0];
    return EOMC_OK;
}
static int bl_jac(double t, const double *x, const double *p, const double *r, double *J, double *w)
{
    (void)t; (void)p; (void)r; (void)w;
    J[0] = 2 * x[0];
    return EOMC_OK;
}
static int sg_rhs(double t, const double *x, const double *p, const double *r, double *xd, double *w)
{
    (void)x; (void)r; (void)w;
    if (t > p[0]) return EOMC_SINGULAR_MASS_MATRIX;
    xd[0] = 1.0;
    return EOMC_OK;
}
static const char *const one_state[] = {"x"};
static const char *const sg_params[] = {"t_sing"};
static const double sg_defaults[] = {0.5};
static const eomc_model bl = {EOMC_ABI_VERSION, "blowup", 1, 0, 1, 0, 0, 0, 0, 0, 1,
    one_state, 0, 0, 0, 0, bl_rhs, bl_jac, 0, 0, 0, 0, 0, 0};
static const eomc_model sg = {EOMC_ABI_VERSION, "singular", 1, 0, 1, 1, 0, 0, 0, 0, 1,
    one_state, sg_params, sg_defaults, 0, 0, sg_rhs, 0, 0, 0, 0, 0, 0, 0};
const eomc_model *blowup_model(void) { return &bl; }
const eomc_model *singular_model(void) { return &sg; }
