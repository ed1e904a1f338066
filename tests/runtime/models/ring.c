/* Particle on a circle of radius L in Cartesian coordinates, constraint force
 * solved in closed form (index-1 form) so it drifts off |q| = L without
 * projection.  nhol = 1 (x^2 + y^2 - L^2), nvel = 1 (x vx + y vy).
 * p = [g, L]. Output: energy per unit mass. */
#include "eomc_model.h"

static int rg_rhs(double t, const double *x, const double *p, const double *r, double *xd, double *w)
{
    double q2 = x[0] * x[0] + x[1] * x[1], v2 = x[2] * x[2] + x[3] * x[3];
    double lam = (v2 - p[0] * x[1]) / q2;     /* keeps d2/dt2 (q.q) = 0 */
    (void)t; (void)r; (void)w;
    xd[0] = x[2]; xd[1] = x[3];
    xd[2] = -lam * x[0];
    xd[3] = -p[0] - lam * x[1];
    return EOMC_OK;
}
static int rg_out(double t, const double *x, const double *p, const double *r, double *o, double *w)
{
    (void)t; (void)r; (void)w;
    o[0] = 0.5 * (x[2] * x[2] + x[3] * x[3]) + p[0] * x[1];
    return EOMC_OK;
}
static int rg_con(double t, const double *x, const double *p, const double *r, double *g, double *w)
{
    (void)t; (void)r; (void)w;
    g[0] = x[0] * x[0] + x[1] * x[1] - p[1] * p[1];
    g[1] = x[0] * x[2] + x[1] * x[3];
    return EOMC_OK;
}
static int rg_conj(double t, const double *x, const double *p, const double *r, double *G, double *w)
{
    (void)t; (void)p; (void)r; (void)w;
    G[0] = 2 * x[0]; G[1] = 2 * x[1]; G[2] = 0; G[3] = 0;
    G[4] = x[2]; G[5] = x[3]; G[6] = x[0]; G[7] = x[1];
    return EOMC_OK;
}
static const char *const rg_states[] = {"x", "y", "vx", "vy"};
static const char *const rg_params[] = {"g", "L"};
static const double rg_defaults[] = {9.81, 1.0};
static const char *const rg_outputs[] = {"energy"};
static const eomc_model rg = {EOMC_ABI_VERSION, "ring", 2, 2, 4, 2, 0, 1, 1, 1, 1,
    rg_states, rg_params, rg_defaults, 0, rg_outputs, rg_rhs, 0, 0, 0, 0, rg_out, rg_con, rg_conj};
const eomc_model *ring_model(void) { return &rg; }
