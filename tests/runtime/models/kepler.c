/* Kepler problem, mu = p[0]; outputs energy and angular momentum. */
#include "eomc_model.h"
#include <math.h>

static int kp_rhs(double t, const double *x, const double *p, const double *r, double *xd, double *w)
{
    double r2 = x[0] * x[0] + x[1] * x[1], r3 = r2 * sqrt(r2);
    (void)t; (void)r; (void)w;
    xd[0] = x[2]; xd[1] = x[3];
    xd[2] = -p[0] * x[0] / r3; xd[3] = -p[0] * x[1] / r3;
    return EOMC_OK;
}
static int kp_jac(double t, const double *x, const double *p, const double *r, double *J, double *w)
{
    double r2 = x[0] * x[0] + x[1] * x[1], r3 = r2 * sqrt(r2), r5 = r3 * r2;
    (void)t; (void)r; (void)w;
    for (int i = 0; i < 16; i++) J[i] = 0.0;
    J[2] = 1; J[7] = 1;
    J[8] = -p[0] / r3 + 3 * p[0] * x[0] * x[0] / r5; J[9] = 3 * p[0] * x[0] * x[1] / r5;
    J[12] = 3 * p[0] * x[0] * x[1] / r5; J[13] = -p[0] / r3 + 3 * p[0] * x[1] * x[1] / r5;
    return EOMC_OK;
}
static int kp_out(double t, const double *x, const double *p, const double *r, double *o, double *w)
{
    (void)t; (void)r; (void)w;
    o[0] = 0.5 * (x[2] * x[2] + x[3] * x[3]) - p[0] / sqrt(x[0] * x[0] + x[1] * x[1]);
    o[1] = x[0] * x[3] - x[1] * x[2];
    return EOMC_OK;
}
static const char *const kp_states[] = {"x", "y", "vx", "vy"};
static const char *const kp_params[] = {"mu"};
static const double kp_defaults[] = {1.0};
static const char *const kp_outputs[] = {"energy", "angular_momentum"};
static const eomc_model kp = {EOMC_ABI_VERSION, "kepler", 2, 2, 4, 1, 0, 2, 0, 0, 1,
    kp_states, kp_params, kp_defaults, 0, kp_outputs, kp_rhs, kp_jac, 0, 0, 0, kp_out, 0, 0};
const eomc_model *kepler_model(void) { return &kp; }
