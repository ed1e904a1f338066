/* Spherical pendulum in spherical angles: theta from the downward vertical,
 * phi the azimuth; M = diag(L^2, L^2 sin^2 theta) is singular at the pole
 * theta = 0 (the gimbal-lock analogue).  p = [g, L].  The rhs solves M
 * numerically and reports EOMC_SINGULAR_MASS_MATRIX when its pivot falls
 * below 1e-14 of the largest, as generated code does.  Outputs: energy,
 * vertical angular momentum. */
#include "eomc_model.h"
#include <math.h>

static int sp_mass(double t, const double *x, const double *p, const double *r, double *M, double *w)
{
    double s = sin(x[0]);
    (void)t; (void)r; (void)w;
    M[0] = p[1] * p[1]; M[1] = 0; M[2] = 0; M[3] = p[1] * p[1] * s * s;
    return EOMC_OK;
}
static int sp_force(double t, const double *x, const double *p, const double *r, double *f, double *w)
{
    double s = sin(x[0]), c = cos(x[0]), L2 = p[1] * p[1];
    (void)t; (void)r; (void)w;
    f[0] = L2 * s * c * x[3] * x[3] - p[0] * p[1] * s;
    f[1] = -2.0 * L2 * s * c * x[2] * x[3];
    return EOMC_OK;
}
static int sp_rhs(double t, const double *x, const double *p, const double *r, double *xd, double *w)
{
    double M[4], f[2];
    sp_mass(t, x, p, r, M, w);
    sp_force(t, x, p, r, f, w);
    if (fabs(M[3]) < 1e-14 * fabs(M[0])) return EOMC_SINGULAR_MASS_MATRIX;
    xd[0] = x[2]; xd[1] = x[3];
    xd[2] = f[0] / M[0]; xd[3] = f[1] / M[3];
    return EOMC_OK;
}
static int sp_out(double t, const double *x, const double *p, const double *r, double *o, double *w)
{
    double s = sin(x[0]), L2 = p[1] * p[1];
    (void)t; (void)r; (void)w;
    o[0] = 0.5 * L2 * (x[2] * x[2] + s * s * x[3] * x[3]) - p[0] * p[1] * cos(x[0]);
    o[1] = L2 * s * s * x[3];
    return EOMC_OK;
}
static const char *const sp_states[] = {"theta", "phi", "theta_dot", "phi_dot"};
static const char *const sp_params[] = {"g", "L"};
static const double sp_defaults[] = {9.81, 1.0};
static const char *const sp_outputs[] = {"energy", "h"};
static const eomc_model sp = {EOMC_ABI_VERSION, "sphere", 2, 2, 4, 2, 0, 2, 0, 0, 1,
    sp_states, sp_params, sp_defaults, 0, sp_outputs,
    sp_rhs, 0, 0, sp_mass, sp_force, sp_out, 0, 0};
const eomc_model *sphere_model(void) { return &sp; }
