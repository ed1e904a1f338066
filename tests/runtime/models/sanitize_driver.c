/* Runs every integrator over the hand-written models with exactly sized work
 * buffers; built with -fsanitize=address,undefined by test_integrators_sanitize.py
 * so any out-of-bounds access or undefined behaviour in the C code fails. */
#include "eomc_integrators.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

const eomc_model *oscillator_model(void);
const eomc_model *pendulum_model(void);
const eomc_model *chain_model(void);
const eomc_model *ring_model(void);
const eomc_model *blowup_model(void);
const eomc_model *singular_model(void);
const eomc_model *robertson_model(void);
const eomc_model *vdp_model(void);
const eomc_model *decay_fail_model(void);

static int run(const eomc_model *m, int method, const double *x0, const double *p,
               int nr, const double *rt, const double *rv, int project, double t1, int expect)
{
    enum { NE = 7 };
    double te[NE], *xo = malloc(sizeof(double) * NE * m->nx), *xl = malloc(sizeof(double) * m->nx);
    size_t nw = eomc_integrate_work_size(m, method);
    double *w = malloc(sizeof(double) * nw);
    eomc_options o = {method, 1e-7, 1e-9, method == EOMC_RK4 || method == EOMC_IMPLICITFAST ? 0.01 : 0.0,
                      0.0, 20000,
                      project == 1, 1, project == 2 ? 5.0 : 0.0, 0.04, 0, NULL, NULL, 0, NULL, 0, NULL, NULL, 0};  /* project 2: baumgarte */
    eomc_stats st;
    int s;
    for (int i = 0; i < NE; i++) te[i] = t1 * i / (NE - 1);
    s = eomc_integrate(m, &o, 0.0, t1, x0, p, nr, rt, rv, NE, te, xo, xl, &st, w, nw);
    if (s == EOMC_OK && st.n_out != NE) s = -1;
    if (s == EOMC_OK && m->noutput > 0) {
        double *out = malloc(sizeof(double) * NE * m->noutput);
        s = eomc_eval_along(m, 0, NE, te, xo, p, nr, rt, rv, out, w, nw);
        free(out);
    }
    printf("%-10s method %d: status %d (expected %d) steps %ld nfev %ld t %g\n",
           m->name, method, s, expect, st.steps, st.nfev, st.t);
    free(xo); free(xl); free(w);
    if (expect == -1)          /* explicit method on a stiff problem: any clean stop */
        return s == EOMC_OK || s == EOMC_STIFF || s == EOMC_NONFINITE;
    if (expect == -2)          /* blow-up: non-finite, or the step shrinks to nothing */
        return s == EOMC_NONFINITE || s == EOMC_STEP_TOO_SMALL;
    return s == expect;
}

int main(void)
{
    double xp[2] = {2.0, 0.0}, xc[4] = {1, 1, 0, 0}, xr[4] = {1, 0, 0, 0}, xb[1] = {1.0};
    double pc[4] = {1.0, 1e6, 0.1, 2e3}, rt[3] = {0.0, 1.0, 2.0}, rv[3] = {0.0, 1.0, -1.0};
    double po[3] = {4.0, 1.0, 0.1}, pp[2] = {9.81, 1.0}, pr[2] = {9.81, 1.0}, ps[1] = {0.5};
    int ok = 1;
    for (int method = EOMC_RK4; method <= EOMC_RADAU5; method++) {
        ok &= run(oscillator_model(), method, xp, po, 3, rt, rv, 0, 3.0, 0);
        ok &= run(pendulum_model(), method, xp, pp, 0, NULL, NULL, 0, 5.0, 0);
        ok &= run(chain_model(), method, xc, pc, 0, NULL, NULL, 0, 2.0,
                  method == EOMC_RADAU5 ? 0 : -1);
        if (method != EOMC_RADAU5) {
            ok &= run(ring_model(), method, xr, pr, 0, NULL, NULL, 1, 3.0, 0);
            ok &= run(ring_model(), method, xr, pr, 0, NULL, NULL, 2, 3.0, 0);
        }
        ok &= run(singular_model(), method == EOMC_RADAU5 ? EOMC_DOP853 : method, xb, ps, 0,
                  NULL, NULL, 0, 1.0, EOMC_SINGULAR_MASS_MATRIX);
    }
    /* the fixed-step implicit method: inputs, a stiff chain, a blow-up */
    ok &= run(oscillator_model(), EOMC_IMPLICITFAST, xp, po, 3, rt, rv, 0, 3.0, 0);
    ok &= run(pendulum_model(), EOMC_IMPLICITFAST, xp, pp, 0, NULL, NULL, 0, 5.0, 0);
    ok &= run(chain_model(), EOMC_IMPLICITFAST, xc, pc, 0, NULL, NULL, 0, 2.0, 0);
    ok &= run(blowup_model(), EOMC_IMPLICITFAST, xb, NULL, 0, NULL, NULL, 0, 2.0, -1);  /* warned in Python */
    ok &= run(blowup_model(), EOMC_DOPRI5, xb, NULL, 0, NULL, NULL, 0, 2.0, -2);
    ok &= run(blowup_model(), EOMC_RADAU5, xb, NULL, 0, NULL, NULL, 0, 2.0, -2);
    {   /* BDF: inputs, orders 1..5 over a long smooth run, stiff problems, failures */
        double xro[3] = {1, 0, 0}, pro[3] = {0.04, 1e4, 3e7}, xv[2] = {2, 0}, pv[1] = {1000.0};
        double pf[1] = {0.5};
        ok &= run(oscillator_model(), EOMC_BDF, xp, po, 3, rt, rv, 0, 3.0, 0);
        ok &= run(pendulum_model(), EOMC_BDF, xp, pp, 0, NULL, NULL, 0, 5.0, 0);
        ok &= run(chain_model(), EOMC_BDF, xc, pc, 0, NULL, NULL, 0, 2.0, 0);
        ok &= run(robertson_model(), EOMC_BDF, xro, pro, 0, NULL, NULL, 0, 4e5, 0);
        ok &= run(vdp_model(), EOMC_BDF, xv, pv, 0, NULL, NULL, 0, 3000.0, 0);
        ok &= run(blowup_model(), EOMC_BDF, xb, NULL, 0, NULL, NULL, 0, 2.0, -2);
        ok &= run(decay_fail_model(), EOMC_BDF, xb, pf, 0, NULL, NULL, 0, 1.0, EOMC_SINGULAR_MASS_MATRIX);
    }
    puts(ok ? "SANITIZE OK" : "SANITIZE MISMATCH");
    return ok ? 0 : 1;
}
