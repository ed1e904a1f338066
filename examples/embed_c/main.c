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
 * Every argument must be a number (read whole by strtod: no trailing text), finite, with DT > 0 and
 * T_END >= 0; a failed step is reported by its status name and start time.
 * Exit status: 0 done, 1 the model failed, 2 bad arguments, 3 out of memory.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include MODEL_HEADER

#define MAX_STEPS 1e9   /* more fixed steps than this is a typo in T_END or DT */

static const char *status_name(int status)
{
    switch (status) {
    case EOMC_OK: return "EOMC_OK";
    case EOMC_SINGULAR_MASS_MATRIX: return "EOMC_SINGULAR_MASS_MATRIX (the mass matrix is singular)";
    case EOMC_SINGULAR_CONSTRAINTS: return "EOMC_SINGULAR_CONSTRAINTS (the constraints are singular)";
    case EOMC_NONFINITE: return "EOMC_NONFINITE (a non-finite value appeared)";
    case EOMC_BAD_ARGUMENT: return "EOMC_BAD_ARGUMENT";
    case EOMC_NOT_AVAILABLE: return "EOMC_NOT_AVAILABLE (function not generated)";
    default: return "unknown status";
    }
}

/* The whole of text as a finite double; 0 and a message on stderr otherwise. */
static int parse_number(const char *text, const char *what, double *out)
{
    char *end;
    errno = 0;
    *out = strtod(text, &end);
    if (end == text || *end != '\0') {
        fprintf(stderr, "%s: expected a number, got '%s'\n", what, text);
        return 0;
    }
    if (errno == ERANGE && fabs(*out) > 1.0) {
        fprintf(stderr, "%s: '%s' is out of range\n", what, text);
        return 0;
    }
    if (!isfinite(*out)) {
        fprintf(stderr, "%s: must be finite, got '%s'\n", what, text);
        return 0;
    }
    return 1;
}

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
    double t_end, dt, steps, t = 0.0;
    double *x = NULL, *r = NULL, *k = NULL, *tmp = NULL, *work = NULL;
    long step, nsteps;
    int i, status = EOMC_OK, code = 0;

    if (m->abi_version != EOMC_ABI_VERSION) {
        fprintf(stderr, "model ABI %d, this program expects %d\n", m->abi_version, EOMC_ABI_VERSION);
        return 2;
    }
    if (m->rhs == NULL) {
        fprintf(stderr, "%s was built without rhs; rebuild it with functions including rhs\n", m->name);
        return 2;
    }
    if (argc != 3 + m->nx) {
        fprintf(stderr, "usage: %s T_END DT x0 (%d values: ", argv[0], m->nx);
        for (i = 0; i < m->nx; ++i) fprintf(stderr, "%s%s", m->state_names[i], i + 1 < m->nx ? " " : ")\n");
        return 2;
    }
    if (!parse_number(argv[1], "T_END", &t_end) || !parse_number(argv[2], "DT", &dt)) return 2;
    if (t_end < 0.0 || dt <= 0.0) {
        fprintf(stderr, "need T_END >= 0 and DT > 0; got T_END=%g DT=%g\n", t_end, dt);
        return 2;
    }
    steps = floor(t_end / dt + 0.5);  /* t_end / dt may overflow to inf: caught below */
    if (!(steps <= MAX_STEPS)) {
        fprintf(stderr, "T_END/DT = %g steps; at most %g (check T_END and DT)\n", t_end / dt, MAX_STEPS);
        return 2;
    }
    nsteps = (long)steps;

    x = malloc(sizeof(double) * (size_t)m->nx);
    r = calloc((size_t)m->ninput + 1, sizeof(double));
    k = malloc(sizeof(double) * 4 * (size_t)m->nx);
    tmp = malloc(sizeof(double) * (size_t)m->nx);
    work = malloc(sizeof(double) * (m->work_size + 1));
    if (!x || !r || !k || !tmp || !work) {
        fprintf(stderr, "out of memory\n");
        code = 3;
        goto done;
    }
    for (i = 0; i < m->nx; ++i) {
        if (!parse_number(argv[3 + i], m->state_names[i], &x[i])) {
            code = 2;
            goto done;
        }
    }

    for (step = 0; step < nsteps; ++step) {
        status = rk4_step(m, t, dt, x, m->param_defaults, r, k, tmp, work);
        if (status != EOMC_OK) break;
        t = (step + 1) * dt;
    }
    if (status != EOMC_OK) {
        fprintf(stderr, "%s: rhs failed with status %d, %s, in the step from t=%.17g\n",
                m->name, status, status_name(status), t);
        code = 1;
        goto done;
    }
    printf("# %s t=%.17g steps=%ld\n", m->name, t, nsteps);
    for (i = 0; i < m->nx; ++i) printf("%s %.17g\n", m->state_names[i], x[i]);
done:
    free(x); free(r); free(k); free(tmp); free(work);
    return code;
}
