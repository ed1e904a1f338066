/* eomc_rows.c -- a model function along rows in one call (see eomc_mat_rows in eomc_integrators.h).
 *
 * Compiled into the integrator library at install (setup.py), not into each model: the
 * function comes by pointer, so one copy serves every model (runtime/poses.py's rows for
 * the ground and pair verdicts along a run's output rows). */
#include "eomc_integrators.h"

#include <math.h>

int eomc_mat_rows(eomc_mat_fn fn, size_t n, const double *t, const double *X, size_t nx,
                  const double *p, const double *r, double *out, size_t nout,
                  double *work, size_t *failed_row)
{
    size_t i;
    if (fn == NULL)
        return EOMC_NOT_AVAILABLE;
    for (i = 0; i < n; ++i) {
        int status = fn(t[i], X + i * nx, p, r, out + i * nout, work);
        if (status != EOMC_OK) {
            if (failed_row)
                *failed_row = i;
            return status;
        }
    }
    return EOMC_OK;
}

/* numpy's maximum: NaN when either is NaN */
static double screen_max(double a, double b)
{
    if (isnan(a) || isnan(b))
        return NAN;
    return a > b ? a : b;
}

static double screen_energy(eomc_mat_fn energy, double t, const double *x, const double *p,
                            const double *r, double *work)
{
    double e = NAN;
    if (energy(t, x, p, r, &e, work) != EOMC_OK || !isfinite(e))
        return NAN;
    return e;
}

size_t eomc_energy_screen(eomc_mat_fn energy, size_t n, double t_end, const double *X0,
                          const double *X_last, size_t nx, const double *P, size_t p_stride,
                          const double *R, size_t r_stride, const int *status,
                          const eomc_stats *stats, int total_known, double rtol, double *E,
                          unsigned char *flag, double *work)
{
    size_t i, flagged = 0;
    for (i = 0; i < n; ++i) {
        const double *p = P + i * p_stride, *r = R ? R + i * r_stride : NULL;
        double seen[4], scale, top, gain;
        int k, m = 0, rose, risen = 0;
        flag[i] = 0;
        E[2 * i] = E[2 * i + 1] = NAN;
        if (status[i] != 0)
            continue;
        E[2 * i] = screen_energy(energy, 0.0, X0 + i * nx, p, r, work);
        E[2 * i + 1] = screen_energy(energy, t_end, X_last + i * nx, p, r, work);
        seen[m++] = E[2 * i];
        if (stats) {
            seen[m++] = stats[i].watch_lo;
            seen[m++] = stats[i].watch_hi;
        }
        seen[m++] = E[2 * i + 1];
        /* scale = max(|E0|, max |seen - E0|, 1e-300); gain = max(seen) - E0 (runtime/rollout.py) */
        scale = fabs(seen[0]);
        top = seen[0];
        for (k = 0; k < m; ++k) {
            scale = screen_max(scale, fabs(seen[k] - seen[0]));
            top = screen_max(top, seen[k]);
        }
        scale = screen_max(scale, 1e-300);
        gain = top - seen[0];
        rose = gain > rtol * scale;
        if (stats && total_known) {
            const eomc_stats *s = stats + i;
            double T0 = s->watch_total0;
            double tscale = screen_max(screen_max(screen_max(fabs(T0), s->watch_total_hi - T0),
                                                  T0 - s->watch_total_lo), 1e-300);
            risen = s->watch_rise > rtol * tscale;
        }
        if (rose || risen) {
            flag[i] = 1;
            ++flagged;
        }
    }
    return flagged;
}
