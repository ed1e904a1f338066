/* Stiff classics for the implicit integrators (test_bdf.py), with analytic Jacobians.
 * robertson: Robertson's chemical kinetics, p = [k1, k2, k3] = [0.04, 1e4, 3e7]; the sum
 *   y1 + y2 + y3 is conserved.
 * vdp: van der Pol in the form of Hairer & Wanner's and scipy's tests, x = [y, v]:
 *   y' = v, v' = mu (1 - y^2) v - y, p = [mu] (stiff for mu = 1000).
 * decay_fail: x' = -x, which reports a singular mass matrix once t > p[0] (a model failure
 *   inside an implicit method's Newton iteration). */
#include "eomc_model.h"

static int ro_rhs(double t, const double *x, const double *p, const double *r, double *xd, double *w)
{
    (void)t; (void)r; (void)w;
    xd[0] = -p[0] * x[0] + p[1] * x[1] * x[2];
    xd[2] = p[2] * x[1] * x[1];
    xd[1] = -xd[0] - xd[2];
    return EOMC_OK;
}
static int ro_jac(double t, const double *x, const double *p, const double *r, double *J, double *w)
{
    (void)t; (void)r; (void)w;
    J[0] = -p[0]; J[1] = p[1] * x[2]; J[2] = p[1] * x[1];
    J[6] = 0.0; J[7] = 2 * p[2] * x[1]; J[8] = 0.0;
    for (int j = 0; j < 3; j++) J[3 + j] = -J[j] - J[6 + j];
    return EOMC_OK;
}
static int vdp_rhs(double t, const double *x, const double *p, const double *r, double *xd, double *w)
{
    (void)t; (void)r; (void)w;
    xd[0] = x[1];
    xd[1] = p[0] * (1 - x[0] * x[0]) * x[1] - x[0];
    return EOMC_OK;
}
static int vdp_jac(double t, const double *x, const double *p, const double *r, double *J, double *w)
{
    (void)t; (void)r; (void)w;
    J[0] = 0.0; J[1] = 1.0;
    J[2] = -2 * p[0] * x[0] * x[1] - 1.0; J[3] = p[0] * (1 - x[0] * x[0]);
    return EOMC_OK;
}
static int df_rhs(double t, const double *x, const double *p, const double *r, double *xd, double *w)
{
    (void)r; (void)w;
    if (t > p[0]) return EOMC_SINGULAR_MASS_MATRIX;
    xd[0] = -x[0];
    return EOMC_OK;
}
static int df_jac(double t, const double *x, const double *p, const double *r, double *J, double *w)
{
    (void)x; (void)r; (void)w;
    if (t > p[0]) return EOMC_SINGULAR_MASS_MATRIX;
    J[0] = -1.0;
    return EOMC_OK;
}
static const char *const ro_states[] = {"y1", "y2", "y3"};
static const char *const ro_params[] = {"k1", "k2", "k3"};
static const double ro_defaults[] = {0.04, 1e4, 3e7};
static const char *const vdp_states[] = {"y", "v"};
static const char *const vdp_params[] = {"mu"};
static const double vdp_defaults[] = {1000.0};
static const char *const df_states[] = {"x"};
static const char *const df_params[] = {"t_fail"};
static const double df_defaults[] = {0.5};
static const eomc_model ro = {EOMC_ABI_VERSION, "robertson", 3, 0, 3, 3, 0, 0, 0, 0, 1,
    ro_states, ro_params, ro_defaults, 0, 0, ro_rhs, ro_jac, 0, 0, 0, 0, 0, 0};
static const eomc_model vdp = {EOMC_ABI_VERSION, "vdp", 1, 1, 2, 1, 0, 0, 0, 0, 1,
    vdp_states, vdp_params, vdp_defaults, 0, 0, vdp_rhs, vdp_jac, 0, 0, 0, 0, 0, 0};
static const eomc_model df = {EOMC_ABI_VERSION, "decay_fail", 1, 0, 1, 1, 0, 0, 0, 0, 1,
    df_states, df_params, df_defaults, 0, 0, df_rhs, df_jac, 0, 0, 0, 0, 0, 0};
const eomc_model *robertson_model(void) { return &ro; }
const eomc_model *vdp_model(void) { return &vdp; }
const eomc_model *decay_fail_model(void) { return &df; }
