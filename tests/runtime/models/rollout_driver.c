/* eomc_rollout from 3 threads over the pendulum (RK4, DOP853, Radau and BDF, 11 output times
 * each) and the
 * singular model (one failing parameter row), each row compared with a single
 * eomc_integrate call byte for byte; eomc_rollout_ex over the oscillator with a gain schedule
 * per row and a terminal event (DOP853), each row against one eomc_integrate_ex call.  Built by test_rollout_sanitize.py with
 * -fsanitize=thread (data races between the rows' threads) and with address,undefined. */
#include "eomc_rollout.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const eomc_model *pendulum_model(void);
const eomc_model *singular_model(void);
const eomc_model *oscillator_model(void);

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
    eomc_options o = {method, 1e-7, 1e-9, 0.01, 0.0, 20000, 0, 1, 0.0, 0.04, 0, NULL, NULL, 0, NULL, 0, NULL, NULL, 0};
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

/* The oscillator (1 input): u = K_i(t) (x_ref(t) - x) on a 3-point grid, one schedule per row,
 * and the event x' = 0 (column 0 of the rhs: the turning points; terminal at the third). */
static int check_ex(void)
{
    const eomc_model *m = oscillator_model();
    enum { NK = 3, CAP = 4 };
    const int nx = m->nx;
    double X0[N * 2], K[N * NK * 2], ref[NK * 2], tg[NK] = {0.0, 0.4, 0.9}, P[4], X_last[N * 2], xl[2];
    double t_rec[N * CAP], x_rec[N * CAP * 2], gmax[N * 2], tr1[CAP], xr1[CAP * 2];
    int id_rec[N * CAP], n_rec[N], term[N], status[N], ir1[CAP], col = 0, dir = 0, terminal = 3, bad = 0;
    long steps[N];
    eomc_options o = {EOMC_DOP853, 1e-8, 1e-10, 0.0, 0.0, 20000, 0, 1, 0.0, 0.04, 0, NULL, NULL, 0, NULL, 0, NULL, NULL, 0};
    eomc_feedback fb = {K, ref, NULL, NULL, NULL, NK, tg, 1};
    size_t evs = eomc_events_scratch_size(m, m->nx, 1);
    eomc_events ev = {1, m->rhs, m->nx, &col, &dir, &terminal, CAP, NULL, NULL, NULL, 0, 0, NULL,
                      NULL, 0, NULL, NULL, NULL, NULL, NULL, 0};
    eomc_rollout_extras ex = {&fb, NK * 2, 0, &ev, t_rec, id_rec, x_rec, n_rec, term, gmax, 2};
    size_t nw = eomc_integrate_work_size(m, EOMC_DOP853) + eomc_feedback_work_size(m, &fb);
    double *w = malloc(sizeof(double) * nw), *scr = malloc(sizeof(double) * evs);
    int s;
    for (int i = 0; i < m->nparam; i++) P[i] = m->param_defaults[i];
    for (int i = 0; i < N; i++) { X0[i * 2] = 0.2 + 0.05 * i; X0[i * 2 + 1] = 0.1 * (i % 3); }
    for (int i = 0; i < N * NK * 2; i++) K[i] = 0.3 * (i % 5) - 0.4;
    for (int i = 0; i < NK * 2; i++) ref[i] = 0.1 * i;
    s = eomc_rollout_ex(m, &o, 0.0, 2.0, N, X0, P, 0, 0, NULL, NULL, 0, &ex, 0, NULL, NULL, X_last, status,
                        steps, NULL, 3);
    for (int i = 0; i < N; i++) {
        eomc_stats st;
        eomc_feedback f1 = fb;
        eomc_events e1 = ev;
        int s1;
        f1.K = K + (size_t)i * NK * 2;
        e1.t_rec = tr1; e1.id_rec = ir1; e1.x_rec = xr1; e1.scratch = scr;
        s1 = eomc_integrate_ex(m, &o, 0.0, 2.0, X0 + i * nx, P, 0, NULL, NULL, &f1, &e1, 0, NULL, NULL, xl, &st,
                               w, nw);
        if (s1 != status[i] || memcmp(xl, X_last + (size_t)i * nx, sizeof(double) * nx) || st.steps != steps[i]
            || e1.n_rec != n_rec[i] || e1.terminated != term[i]
            || memcmp(tr1, t_rec + (size_t)i * CAP, sizeof(double) * (size_t)(e1.n_rec < CAP ? e1.n_rec : CAP))) {
            printf("oscillator ex row %d differs (status %d vs %d, events %d vs %d)\n", i, status[i], s1,
                   n_rec[i], e1.n_rec);
            bad = 1;
        }
        bad |= status[i] != EOMC_OK || n_rec[i] < 1;
    }
    printf("oscillator: rollout_ex status %d, row 0 events %d, terminated %d\n", s, n_rec[0], term[0]);
    free(w); free(scr);
    return bad;
}

int main(void)
{
    const eomc_model *pen = pendulum_model(), *sing = singular_model();
    double P[N * 2], Ps[N * 2];
    int bad = 0;
    for (int i = 0; i < pen->nparam; i++) P[i] = pen->param_defaults[i];
    bad |= check(pen, EOMC_RK4, P, 0, -1);
    /* the adaptive rows too: DOP853, and the implicit ones with their Newton work and LU (s29) */
    bad |= check(pen, EOMC_DOP853, P, 0, -1);
    bad |= check(pen, EOMC_RADAU5, P, 0, -1);
    bad |= check(pen, EOMC_BDF, P, 0, -1);
    for (int i = 0; i < N; i++) { Ps[i * 2] = i == 4 ? 0.5 : 2.0; Ps[i * 2 + 1] = 0.0; }  /* row 4: singular */
    bad |= check(sing, EOMC_RK4, Ps, 2, 4);
    bad |= check_ex();
    if (!bad) printf("ROLLOUT SANITIZE OK\n");
    return bad;
}
