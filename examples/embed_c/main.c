/*
 * main.c -- integrate an eomc-built model from plain C with a fixed-step RK4.
 *
 * Only the generated header and library are used: the model is reached
 * through its eomc_model struct (MODEL_FN(), e.g. double_pendulum_model()),
 * so the same program works for any model.  Usage:
 *
 *     ./embed T_END DT x0_1 ... x0_nx
 *
 * prints the final state, one "name value" line per state (%.17g).
 * Parameters are the model's defaults; inputs, if any, are zero.
 */
#include <stdio.h>
#include <stdlib.h>

#include MODEL_HEADER

static int rk4_step(const eomc_model *m, double t, double h, double *x, const double *p,
                    const double *r, double *k, double *tmp, double *work)
{
    /* k holds 4 stages of nx doubles each */
    const int n = m->nx;
    double *k1 = k, *k2 = k + n, *k3 = k + 2 * n, *k4 = k + 3 * n;
    int i, s;
    if ((s = m->rhs(t, x, p, r, k1, work)) != EOMC_OK) return s;
    for (i = 0; i < n; ++i) tmp[i] = x[i] + 0.5 * h * k1[i];
    if ((s = m->rhs(t + 0.5 * h, tmp, p, r, k2, work)) != EOMC_OK) return s;
    for (i = 0; i < n; ++i) tmp[i] = x[i] + 0.5 * h * k2[i];
    if ((s = m->rhs(t + 0.5 * h, tmp, p, r, k3, work)) != EOMC_OK) return s;
    for (i = 0; i < n; ++i) tmp[i] = x[i] + h * k3[i];
    if ((s = m->rhs(t + h, tmp, p, r, k4, work)) != EOMC_OK) return s;
    for (i = 0; i < n; ++i) x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    return EOMC_OK;
}

int main(int argc, char **argv)
{
    const eomc_model *m = MODEL_FN();
    double t_end, dt, t = 0.0;
    double *x, *r, *k, *tmp, *work;
    long step, nsteps;
    int i, status = EOMC_OK;

    if (m->abi_version != EOMC_ABI_VERSION) {
        fprintf(stderr, "model ABI %d, this program expects %d\n", m->abi_version, EOMC_ABI_VERSION);
        return 2;
    }
    if (argc != 3 + m->nx) {
        fprintf(stderr, "usage: %s T_END DT x0 (%d values: ", argv[0], m->nx);
        for (i = 0; i < m->nx; ++i) fprintf(stderr, "%s%s", m->state_names[i], i + 1 < m->nx ? " " : ")\n");
        return 2;
    }
    t_end = atof(argv[1]);
    dt = atof(argv[2]);
    x = malloc(sizeof(double) * (size_t)m->nx);
    r = calloc((size_t)m->ninput + 1, sizeof(double));
    k = malloc(sizeof(double) * 4 * (size_t)m->nx);
    tmp = malloc(sizeof(double) * (size_t)m->nx);
    work = malloc(sizeof(double) * (m->work_size + 1));
    if (!x || !r || !k || !tmp || !work) return 3;
    for (i = 0; i < m->nx; ++i) x[i] = atof(argv[3 + i]);

    nsteps = (long)(t_end / dt + 0.5);
    for (step = 0; step < nsteps && status == EOMC_OK; ++step) {
        status = rk4_step(m, t, dt, x, m->param_defaults, r, k, tmp, work);
        t = (step + 1) * dt;
    }
    if (status != EOMC_OK) {
        fprintf(stderr, "%s: rhs failed with status %d at t=%g\n", m->name, status, t);
        return 1;
    }
    printf("# %s t=%.17g steps=%ld\n", m->name, t, nsteps);
    for (i = 0; i < m->nx; ++i) printf("%s %.17g\n", m->state_names[i], x[i]);
    free(x); free(r); free(k); free(tmp); free(work);
    return 0;
}
