/* Torque-free rigid body (Euler's equations in body axes), x = omega.
 * p = [I1, I2, I3].  Outputs: kinetic energy and |L|^2, both conserved. */
#include "eomc_model.h"

static int tp_rhs(double t, const double *x, const double *p, const double *r, double *xd, double *w)
{
    (void)t; (void)r; (void)w;
    xd[0] = (p[1] - p[2]) * x[1] * x[2] / p[0];
    xd[1] = (p[2] - p[0]) * x[2] * x[0] / p[1];
    xd[2] = (p[0] - p[1]) * x[0] * x[1] / p[2];
    return EOMC_OK;
}
static int tp_jac(double t, const double *x, const double *p, const double *r, double *J, double *w)
{
    double a = (p[1] - p[2]) / p[0], b = (p[2] - p[0]) / p[1], c = (p[0] - p[1]) / p[2];
    (void)t; (void)r; (void)w;
    J[0] = 0; J[1] = a * x[2]; J[2] = a * x[1];
    J[3] = b * x[2]; J[4] = 0; J[5] = b * x[0];
    J[6] = c * x[1]; J[7] = c * x[0]; J[8] = 0;
    return EOMC_OK;
}
static int tp_out(double t, const double *x, const double *p, const double *r, double *o, double *w)
{
    (void)t; (void)r; (void)w;
    o[0] = 0.5 * (p[0] * x[0] * x[0] + p[1] * x[1] * x[1] + p[2] * x[2] * x[2]);
    o[1] = p[0] * p[0] * x[0] * x[0] + p[1] * p[1] * x[1] * x[1] + p[2] * p[2] * x[2] * x[2];
    return EOMC_OK;
}
static const char *const tp_states[] = {"w1", "w2", "w3"};
static const char *const tp_params[] = {"I1", "I2", "I3"};
static const double tp_defaults[] = {1.0, 2.0, 3.0};
static const char *const tp_outputs[] = {"energy", "L2"};
static const eomc_model tp = {EOMC_ABI_VERSION, "top", 0, 3, 3, 3, 0, 2, 0, 0, 1,
    tp_states, tp_params, tp_defaults, 0, tp_outputs, tp_rhs, tp_jac, 0, 0, 0, tp_out, 0, 0};
const eomc_model *top_model(void) { return &tp; }
