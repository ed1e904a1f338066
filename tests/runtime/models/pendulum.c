/* Simple pendulum q'' = -(g/L) sin q; output energy per unit mass. */
#include "eomc_model.h"
#include <math.h>

static int pen_rhs(double t, const double *x, const double *p, const double *r, double *xd, double *w)
{
    (void)t; (void)r; (void)w;
    xd[0] = x[1];
    xd[1] = -p[0] / p[1] * sin(x[0]);
    return EOMC_OK;
}
static int pen_jac(double t, const double *x, const double *p, const double *r, double *J, double *w)
{
    (void)t; (void)r; (void)w;
    J[0] = 0; J[1] = 1; J[2] = -p[0] / p[1] * cos(x[0]); J[3] = 0;
    return EOMC_OK;
}
static int pen_out(double t, const double *x, const double *p, const double *r, double *o, double *w)
{
    (void)t; (void)r; (void)w;
    o[0] = 0.5 * p[1] * p[1] * x[1] * x[1] - p[0] * p[1] * cos(x[0]);
    return EOMC_OK;
}
static const char *const pen_states[] = {"q1", "u1"};
static const char *const pen_params[] = {"g", "L"};
static const double pen_defaults[] = {9.81, 1.0};
static const char *const pen_outputs[] = {"energy"};
static const eomc_model pen = {EOMC_ABI_VERSION, "pendulum", 1, 1, 2, 2, 0, 1, 0, 0, 1,
    pen_states, pen_params, pen_defaults, 0, pen_outputs,
    pen_rhs, pen_jac, 0, 0, 0, pen_out, 0, 0};
const eomc_model *pendulum_model(void) { return &pen; }
