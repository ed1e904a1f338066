/* Forced harmonic oscillator: q' = u, u' = (-k q - c u + F(t)) / m, F = r[0].
 * Closed form known; output 0 = energy. Hand-written stand-in for generated code. */
#include "eomc_model.h"
#include <math.h>

static int osc_rhs(double t, const double *x, const double *p, const double *r, double *xd, double *w)
{
    (void)t; (void)w;
    xd[0] = x[1];
    xd[1] = (-p[0] * x[0] - p[2] * x[1] + r[0]) / p[1];
    return EOMC_OK;
}
static int osc_jac(double t, const double *x, const double *p, const double *r, double *J, double *w)
{
    (void)t; (void)x; (void)r; (void)w;
    J[0] = 0; J[1] = 1; J[2] = -p[0] / p[1]; J[3] = -p[2] / p[1];
    return EOMC_OK;
}
static int osc_out(double t, const double *x, const double *p, const double *r, double *o, double *w)
{
    (void)t; (void)r; (void)w;
    o[0] = 0.5 * p[1] * x[1] * x[1] + 0.5 * p[0] * x[0] * x[0];
    return EOMC_OK;
}
static const char *const osc_states[] = {"q", "u"};
static const char *const osc_params[] = {"k", "m", "c"};
static const double osc_defaults[] = {4.0, 1.0, 0.0};
static const char *const osc_inputs[] = {"F"};
static const char *const osc_outputs[] = {"energy"};
static const eomc_model osc = {EOMC_ABI_VERSION, "oscillator", 1, 1, 2, 3, 1, 1, 0, 0, 1,
    osc_states, osc_params, osc_defaults, osc_inputs, osc_outputs,
    osc_rhs, osc_jac, 0, 0, 0, osc_out, 0, 0};
const eomc_model *oscillator_model(void) { return &osc; }
