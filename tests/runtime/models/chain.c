/* Stiff 2-mass spring-damper chain: wall -k1,c1- m1 -k2,c2- m2, unit masses.
 * p = [k1, k2, c1, c2]; the stiffness ratio is k2/k1. */
#include "eomc_model.h"

static int ch_rhs(double t, const double *x, const double *p, const double *r, double *xd, double *w)
{
    double s = p[1] * (x[1] - x[0]) + p[3] * (x[3] - x[2]);
    (void)t; (void)r; (void)w;
    xd[0] = x[2]; xd[1] = x[3];
    xd[2] = -p[0] * x[0] - p[2] * x[2] + s;
    xd[3] = -s;
    return EOMC_OK;
}
static int ch_jac(double t, const double *x, const double *p, const double *r, double *J, double *w)
{
    (void)t; (void)x; (void)r; (void)w;
    for (int i = 0; i < 16; i++) J[i] = 0.0;
    J[0 * 4 + 2] = 1; J[1 * 4 + 3] = 1;
    J[2 * 4 + 0] = -p[0] - p[1]; J[2 * 4 + 1] = p[1]; J[2 * 4 + 2] = -p[2] - p[3]; J[2 * 4 + 3] = p[3];
    J[3 * 4 + 0] = p[1]; J[3 * 4 + 1] = -p[1]; J[3 * 4 + 2] = p[3]; J[3 * 4 + 3] = -p[3];
    return EOMC_OK;
}
static const char *const ch_states[] = {"q1", "q2", "u1", "u2"};
static const char *const ch_params[] = {"k1", "k2", "c1", "c2"};
static const double ch_defaults[] = {1.0, 1e3, 0.1, 1.0};
static const eomc_model ch = {EOMC_ABI_VERSION, "chain", 2, 2, 4, 4, 0, 0, 0, 0, 1,
    ch_states, ch_params, ch_defaults, 0, 0, ch_rhs, ch_jac, 0, 0, 0, 0, 0, 0};
const eomc_model *chain_model(void) { return &ch; }
