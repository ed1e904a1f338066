/*
 * eomc_sensitivity.c -- forward sensitivities by the variational equations
 * (see eomc_sensitivity.h).  Why an augmented model: the integrators (and their
 * step control, dense output and statistics) stay exactly as they are; this
 * file only supplies an eomc_model whose rhs is [f(x); J S + P] and whose
 * jac_x is diag(J, ..., J).  The integrators pass the parameter pointer
 * through to rhs/jac_x untouched, so it carries this context (an object
 * pointer converted to const double * and back, C99 6.3.2.3p7; the context
 * starts with a double, so its alignment suits).
 */
#include <string.h>

#include "eomc_sensitivity.h"
#include "eomc_stagger.h"

#define EOMC_SENS_MAXCOL 4096

struct eomc_sens {
    double align_;            /* first: the context is aligned as a double */
    const eomc_model *m;
    eomc_mat_fn jac_p;
    eomc_jvp_fn jvp;
    eomc_jvp_more_fn jvp_more;   /* or NULL (eomc_sens_jvp_more) */
    const double *p;
    int nx, np, nxcol, npcol;
    int xcols[EOMC_SENS_MAXCOL];
    int pcols[EOMC_SENS_MAXCOL];
    double *J, *P;            /* nx x nx, nx x nparam scratch */
    double *D;                /* k x (nx + nparam): the directions handed to jvp */
    int errcon;               /* 1: the step control sees S too (simultaneous, as before) */
    int avx;                  /* the CPU has AVX (vzeroupper after the model's calls) */
    long njvp, niter, nslow;  /* the last run's staggered counts */
    int full_solves;          /* eomc_sens_full_solves */
    long ntrim;
    eomc_model aug;
};

size_t eomc_sens_size(void)
{
    return sizeof(eomc_sens);
}

size_t eomc_sens_scratch_size(const eomc_model *m, int k)
{
    size_t nx = (size_t)m->nx, np = (size_t)m->nparam;
    return nx * nx + nx * np + (size_t)(k > 0 ? k : 0) * (nx + np) + 1;
}

static const eomc_sens *ctx_of(const double *p)
{
    return (const eomc_sens *)(const void *)p;
}

/* [xdot; J S + P[:, pcols]] */
static int aug_rhs(double t, const double *X, const double *pc, const double *r, double *F, double *work)
{
    const eomc_sens *s = ctx_of(pc);
    const eomc_model *m = s->m;
    int n = s->nx, k = s->nxcol + s->npcol, st;
    const double *S = X + n;
    if (s->jvp) {
        /* direction j = [S[:, j]; e_p for a parameter column]; S is stored column by column */
        size_t nd = (size_t)n + (size_t)s->np;
        for (int j = 0; j < k; j++)
            memcpy(s->D + (size_t)j * nd, S + (size_t)j * n, (size_t)n * sizeof(double));
        st = s->jvp(t, X, s->p, r, k, s->D, F, F + n, work);
#if defined(__GNUC__) && defined(__x86_64__)
        /* A model built with -mavx2 (compiler/build/toolchain.MACHINE_FLAGS) can return from
         * jvp with the upper halves of the ymm registers dirty (gcc 12 left out vzeroupper on
         * the path through a static callee), and this file's SSE code then ran up to 2.5x
         * slower (false dependencies on the upper halves; DOP853 k = 8 without lanes 31.7 ms
         * against 12.5 ms with this, k = 4 with lanes 17.9 against 7.5).  vzeroupper clears
         * them; only on a CPU with AVX.  The default gcc build now adds -fno-ipa-ra, which
         * cures the cause (toolchain.GCC_MACHINE_FLAGS, tests/compiler/build/test_upper_state.py;
         * on the AMD EPYC the dirty state cost nothing measurable, benchmarks/results/
         * upper_state.md); this stays for libraries built with the user's --cflags. */
        if (s->avx) __asm__ volatile("vzeroupper");
#endif
        return st;
    }
    if ((st = m->rhs(t, X, s->p, r, F, work))) return st;
    if ((st = m->jac_x(t, X, s->p, r, s->J, work))) return st;
    if (s->npcol > 0 && (st = s->jac_p(t, X, s->p, r, s->P, work))) return st;
    for (int j = 0; j < k; j++) {
        const double *Sj = S + (size_t)j * n;
        double *Fj = F + n + (size_t)j * n;
        for (int i = 0; i < n; i++) {
            const double *Ji = s->J + (size_t)i * n;
            double acc = j >= s->nxcol ? s->P[(size_t)i * s->np + s->pcols[j - s->nxcol]] : 0.0;
            for (int l = 0; l < n; l++)
                acc += Ji[l] * Sj[l];
            Fj[i] = acc;
        }
    }
    return EOMC_OK;
}

/* diag(J, ..., J) (N x N, row-major) */
static int aug_jac(double t, const double *X, const double *pc, const double *r, double *out, double *work)
{
    const eomc_sens *s = ctx_of(pc);
    int n = s->nx, k = s->nxcol + s->npcol, st;
    size_t N = (size_t)n * (size_t)(1 + k);
    if ((st = s->m->jac_x(t, X, s->p, r, s->J, work))) return st;
    memset(out, 0, N * N * sizeof(double));
    for (int b = 0; b <= k; b++)
        for (int i = 0; i < n; i++)
            memcpy(out + ((size_t)b * n + i) * N + (size_t)b * n, s->J + (size_t)i * n,
                   (size_t)n * sizeof(double));
    return EOMC_OK;
}

int eomc_sens_init(eomc_sens *s, const eomc_model *m, eomc_mat_fn jac_p, eomc_jvp_fn jvp, const double *p,
                   int nxcol, const int *xcols, int npcol, const int *pcols, double *scratch)
{
    if (!s || !m || !m->rhs || !scratch || nxcol < 0 || npcol < 0 || nxcol > EOMC_SENS_MAXCOL
        || npcol > EOMC_SENS_MAXCOL)
        return EOMC_BAD_ARGUMENT;
    if (!m->jac_x || (npcol > 0 && !jac_p && !jvp)) return EOMC_NOT_AVAILABLE;
    memset(s, 0, sizeof *s);
    s->m = m; s->jac_p = jac_p; s->jvp = jvp; s->p = p;
    s->nx = m->nx; s->np = m->nparam; s->nxcol = nxcol; s->npcol = npcol;
#if defined(__GNUC__) && defined(__x86_64__)
    s->avx = __builtin_cpu_supports("avx") ? 1 : 0;
#endif
    for (int j = 0; j < nxcol; j++) {
        if (xcols[j] < 0 || xcols[j] >= m->nx) return EOMC_BAD_ARGUMENT;
        s->xcols[j] = xcols[j];
    }
    for (int j = 0; j < npcol; j++) {
        if (pcols[j] < 0 || pcols[j] >= m->nparam) return EOMC_BAD_ARGUMENT;
        s->pcols[j] = pcols[j];
    }
    s->J = scratch;
    s->P = scratch + (size_t)m->nx * (size_t)m->nx;
    s->D = s->P + (size_t)m->nx * (size_t)m->nparam;
    {   /* the parameter parts of the directions: fixed unit vectors */
        size_t nd = (size_t)m->nx + (size_t)m->nparam;
        memset(s->D, 0, (size_t)(nxcol + npcol) * nd * sizeof(double));
        for (int j = 0; j < npcol; j++)
            s->D[(size_t)(nxcol + j) * nd + (size_t)m->nx + (size_t)pcols[j]] = 1.0;
    }
    s->aug = *m;
    s->aug.nx = m->nx * (1 + nxcol + npcol);
    s->aug.nq = 0;
    s->aug.nu = s->aug.nx;
    s->aug.nhol = 0;
    s->aug.nvel = 0;
    s->aug.noutput = 0;
    s->aug.state_names = NULL;
    s->aug.rhs = aug_rhs;
    s->aug.jac_x = aug_jac;
    s->aug.jac_r = NULL;
    s->aug.mass_matrix = NULL;
    s->aug.forcing = NULL;
    s->aug.outputs = NULL;
    s->aug.constraints = NULL;
    s->aug.constraints_jac = NULL;
    return EOMC_OK;
}

int eomc_sens_nstates(const eomc_sens *s)
{
    return s->aug.nx;
}

void eomc_sens_start(const eomc_sens *s, const double *x0, double *X0)
{
    int n = s->nx;
    memcpy(X0, x0, (size_t)n * sizeof(double));
    memset(X0 + n, 0, (size_t)(s->aug.nx - n) * sizeof(double));
    for (int j = 0; j < s->nxcol; j++)
        X0[n + (size_t)j * n + s->xcols[j]] = 1.0;
}

void eomc_sens_error_control(eomc_sens *s, int on)
{
    s->errcon = on != 0;
}

void eomc_sens_jvp_more(eomc_sens *s, eomc_jvp_more_fn jvp_more)
{
    s->jvp_more = jvp_more;
}

/* Radau, S not steering the steps, jvp given: the staggered path on the plain model. */
static int staggered(const eomc_sens *s, int method)
{
    return method == EOMC_RADAU5 && !s->errcon && s->jvp;
}

size_t eomc_sens_work_size(const eomc_sens *s, int method)
{
    int k = s->nxcol + s->npcol;
    if (staggered(s, method))
        return (size_t)s->nx * (size_t)k + eomc_integrate_work_size(s->m, method)
               + eomc_stagger_work_size(s->nx, k, s->nx + s->np);
    return eomc_integrate_work_size(&s->aug, method);
}

void eomc_sens_counts(const eomc_sens *s, long *out)
{
    out[0] = s->njvp; out[1] = s->niter; out[2] = s->nslow;
}

void eomc_sens_full_solves(eomc_sens *s, int on)
{
    s->full_solves = on != 0;
}

long eomc_sens_trimmed(const eomc_sens *s)
{
    return s->ntrim;
}

int eomc_sens_integrate(eomc_sens *s, const eomc_options *opt, double t0, double t1,
                        const double *X0, int n_rgrid, const double *r_tgrid,
                        const double *r_values, int n_eval, const double *t_eval,
                        double *X_out, double *X_last, eomc_stats *stats,
                        double *work, size_t work_len)
{
    eomc_options o = *opt;
    eomc_stagger sg;
    int n = s->nx, k = s->nxcol + s->npcol, st;
    size_t nk = (size_t)n * (size_t)k;
    o.project = 0;
    o.baumgarte = 0.0;
    memset(&sg, 0, sizeof sg);
    s->njvp = s->niter = s->nslow = s->ntrim = 0;
    if (!staggered(s, o.method)) {
        /* explicit methods (and Radau with error control on S): the augmented model, whose
         * sensitivities stay out of the error test unless errcon */
        sg.n_err = s->errcon ? 0 : n;
        sg.n_fin = s->jvp ? n : 0;      /* jvp's own NAME_finite covers [xdot; out] */
        return eomc_integrate_sg(&s->aug, &o, t0, t1, X0, (const double *)(const void *)s, n_rgrid,
                                 r_tgrid, r_values, n_eval, t_eval, X_out, X_last, stats, work,
                                 work_len, &sg);
    }
    if (!work || work_len < nk) return EOMC_BAD_ARGUMENT;
    sg.k = k; sg.jvp = s->jvp; sg.jvp_more = s->jvp_more; sg.ndir = n + s->np; sg.D = s->D;
    sg.full_solves = s->full_solves;
    sg.S = work;
    sg.S_out = X_out ? X_out + n : NULL;
    sg.ld_out = n * (1 + k);
    memcpy(sg.S, X0 + n, nk * sizeof(double));
    st = eomc_integrate_sg(s->m, &o, t0, t1, X0, s->p, n_rgrid, r_tgrid, r_values, n_eval, t_eval,
                           X_out, X_last, stats, work + nk, work_len - nk, &sg);
    if (X_last) memcpy(X_last + n, sg.S, nk * sizeof(double));
    s->njvp = sg.njvp; s->niter = sg.niter; s->nslow = sg.nslow; s->ntrim = sg.ntrim;
    return st;
}
