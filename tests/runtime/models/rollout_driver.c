/* eomc_rollout from 3 threads over the pendulum (rk4, every step recorded) and the
 * singular model (one failing parameter row), each row compared with a single
 * eomc_integrate call byte for byte.  Built by test_rollout_sanitize.py with
 * -fsanitize=thread (data races between the rows' threads) and with address,undefined. */
#include "eomc_rollout.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const eomc_model *pendulum_model(void);
const eomc_model *singular_model(void);

enum { N = 9, NE = 11 };

static int check(const eomc_model *m, int method, const double *P, size_t p_stride, int expect_fail_row)
{
    const int nx = m->nx;
    double X0[N * 8], te[NE], *X_out = malloc(sizeof(double) * N * NE * nx);
    double *X_last = malloc(sizeof(double) * N * nx), *xo = malloc(sizeof(double) * NE * nx);
    double *xl = malloc(sizeof(double) * nx);
    size_t nw = eomc_integrate_work_size(m, method);
    double *w = malloc(sizeof(double) * nw);
    int status[N], bad = 0;
    long steps[N];
    eomc_options o = {method, 1e-7, 1e-9, 0.01, 0.0, 20000, 0, 1, 0.0, 0.04, 0, NULL, NULL};
    for (int i = 0; i < N * nx; i++) X0[i] = 0.1 * (i % 7) - 0.3;
    for (int i = 0; i < NE; i++) te[i] = 0.1 * i;
    int s = eomc_rollout(m, &o, 0.0, 1.0, N, X0, P, p_stride, NE, te, X_out, X_last, status, steps, 3);
    for (int i = 0; i < N; i++) {
        eomc_stats st;
        int s1 = eomc_integrate(m, &o, 0.0, 1.0, X0 + i * nx, P + i * p_stride, 0, NULL, NULL, NE, te, xo,
                                xl, &st, w, nw);
        if (s1 != status[i] || (s1 == EOMC_OK && (memcmp(xo, X_out + (size_t)i * NE * nx, sizeof(double) * NE * nx)
                                                   || memcmp(xl, X_last + (size_t)i * nx, sizeof(double) * nx)
                                                   || st.steps != steps[i]))) {
            printf("%s row %d differs (status %d vs %d)\n", m->name, i, status[i], s1);
            bad = 1;
        }
        if ((status[i] != EOMC_OK) != (i == expect_fail_row)) {
            printf("%s row %d: status %d unexpected\n", m->name, i, status[i]);
            bad = 1;
        }
    }
    if ((expect_fail_row < 0) != (s == EOMC_OK)) bad = 1;
    printf("%s: rollout status %d\n", m->name, s);
    free(X_out); free(X_last); free(xo); free(xl); free(w);
    return bad;
}

int main(void)
{
    const eomc_model *pen = pendulum_model(), *sing = singular_model();
    double P[N * 2], Ps[N * 2];
    int bad = 0;
    for (int i = 0; i < pen->nparam; i++) P[i] = pen->param_defaults[i];
    bad |= check(pen, EOMC_RK4, P, 0, -1);
    for (int i = 0; i < N; i++) { Ps[i * 2] = i == 4 ? 0.5 : 2.0; Ps[i * 2 + 1] = 0.0; }  /* row 4: singular */
    bad |= check(sing, EOMC_RK4, Ps, 2, 4);
    if (!bad) printf("ROLLOUT SANITIZE OK\n");
    return bad;
}
