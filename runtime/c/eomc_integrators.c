/*
 * eomc_integrators.c -- RK4, DOPRI5, DOP853 and Radau IIA(5) over eomc_model.
 *
 * Why in C: the whole loop (stages, error control, dense output, input
 * interpolation, projection) runs without returning to Python, so a
 * trajectory costs one foreign call.  Every function is reentrant: all
 * scratch lives in the caller's work buffer (see eomc_integrate_work_size).
 *
 * Step-size control follows Hairer, Norsett & Wanner (Solving ODEs I, II.4
 * and II, IV.8) in the form scipy.integrate uses (safety 0.9, factor limits
 * 0.2..10, RMS error norm with scale atol + rtol*max(|y|,|y_new|)), plus the
 * stabilized (PI) factor err_old^beta of Hairer's dopri5.f/dop853.f when
 * options.pi_beta > 0 (pi_beta = 0: step for step scipy's control).  The
 * Runge-Kutta coefficients are Dormand & Prince's (DOPRI5, with Shampine's
 * 4th-order interpolant) and Hairer's DOP853 with its 7th-order dense output,
 * as published with Hairer's Fortran codes (tabulated identically in
 * scipy.integrate._ivp); tests check the orders of convergence.
 */
#if !defined(_WIN32) && !defined(_POSIX_C_SOURCE)
#define _POSIX_C_SOURCE 200809L   /* sigaction under -std=c99 */
#endif
#include "eomc_integrators.h"
#include "eomc_dense_lu.h"
#include "eomc_dense_lu_c.h"
#include "eomc_fixedstep.h"
#include "eomc_bdf.h"
#include "eomc_stagger.h"

#include <complex.h>
#include <signal.h>
#include <float.h>
#include <math.h>
#include <string.h>
#include <stdint.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif


/* Event handling is kept out of line: inlined, it grew run_erk enough that GCC stopped
 * inlining the DOP853 stage sums with their constant tables (+5% on a plain run). */
#if defined(__GNUC__)
#define EOMC_NOINLINE static __attribute__((noinline))
#else
#define EOMC_NOINLINE static
#endif

#define SAFETY 0.9
#define MIN_FACTOR 0.2
#define MAX_FACTOR 10.0
#define DEFAULT_MAX_STEPS 100000L
#define NSTIFF 1000       /* Hairer: test stiffness every NSTIFF accepted steps */

/* ----------------------------------------- coefficient tables (generated) */
static const double DP5_A[6][5] = {
    {0, 0, 0, 0, 0},
    {0.20000000000000001, 0, 0, 0, 0},
    {0.074999999999999997, 0.22500000000000001, 0, 0, 0},
    {0.97777777777777775, -3.7333333333333334, 3.5555555555555554, 0, 0},
    {2.9525986892242035, -11.595793324188385, 9.8228928516994358, -0.29080932784636487, 0},
    {2.8462752525252526, -10.757575757575758, 8.9064227177434727, 0.27840909090909088, -0.2735313036020583}
};
static const double DP5_B[6] = {
    0.091145833333333329,
    0,
    0.44923629829290207,
    0.65104166666666663,
    -0.322376179245283,
    0.13095238095238096
};
static const double DP5_C[6] = {
    0,
    0.20000000000000001,
    0.29999999999999999,
    0.80000000000000004,
    0.88888888888888884,
    1
};
static const double DP5_E[7] = {
    -0.0012326388888888888,
    0,
    0.0042527702905061394,
    -0.036979166666666667,
    0.05086379716981132,
    -0.041904761904761903,
    0.025000000000000001
};
static const double DP5_P[7][4] = {
    {1, -2.8535800653862835, 3.0717434641059005, -1.1270175653862835},
    {0, 0, 0, 0},
    {0, 4.0231333792303046, -6.2493215652889997, 2.675424484351598},
    {0, -3.7324019615885042, 10.068970589843675, -5.6855269615885042},
    {0, 2.5548038301849423, -6.3991123773510168, 3.5219323679207912},
    {0, -1.3744241142186024, 3.2726577522467291, -1.7672812570757455},
    {0, 1.3824689317781436, -3.7649378635562871, 2.3824689317781438}
};
static const double D8_A[16][16] = {
    {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
    {0.05260015195876773, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
    {0.0197250569845379, 0.059175170953613701, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
    {0.029587585476806851, 0, 0.088762756430420545, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
    {0.24136513415926669, 0, -0.88454947932828609, 0.92483400326179199, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
    {0.037037037037037035, 0, 0, 0.17082860872947386, 0.12546768756682242, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
    {0.037109375, 0, 0, 0.17025221101954405, 0.060216538980455959, -0.017578125, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
    {0.037092000118504789, 0, 0, 0.17038392571223998, 0.10726203044637328, -0.015319437748624402, 0.0082737891638140233, 0, 0, 0, 0, 0, 0, 0, 0, 0},
    {0.62411095871607569, 0, 0, -3.3608926294469414, -0.86821934684172597, 27.59209969944671, 20.154067550477894, -43.489884181069961, 0, 0, 0, 0, 0, 0, 0, 0},
    {0.47766253643826434, 0, 0, -2.4881146199716677, -0.59029082683684297, 21.230051448181193, 15.279233632882423, -33.288210968984863, -0.020331201708508627, 0, 0, 0, 0, 0, 0, 0},
    {-0.9371424300859873, 0, 0, 5.1863724288440638, 1.0914373489967295, -8.1497870107469268, -18.520065659996959, 22.739487099350505, 2.4936055526796523, -3.0467644718982196, 0, 0, 0, 0, 0, 0},
    {2.273310147516538, 0, 0, -10.534495466737249, -2.0008720582248625, -17.958931863118799, 27.94888452941996, -2.8589982771350235, -8.8728569335306293, 12.360567175794303, 0.64339274601576357, 0, 0, 0, 0, 0},
    {0.054293734116568765, 0, 0, 0, 0, 4.4503128927524092, 1.8915178993145003, -5.8012039600105849, 0.3111643669578199, -0.15216094966251609, 0.20136540080403034, 0.044710615727772587, 0, 0, 0, 0},
    {0.056167502283047954, 0, 0, 0, 0, 0, 0.25350021021662483, -0.2462390374708025, -0.12419142326381637, 0.15329179827876568, 0.0082010522956346907, 0.0075678976605456994, -0.0082979999999999998, 0, 0, 0},
    {0.031834648163502142, 0, 0, 0, 0, 0.028300909672366776, 0.053541988307438566, -0.054923748571390991, 0, 0, -0.00010834732869724932, 0.00038257109083565839, -0.00034046500868740456, 0.1413124436746325, 0, 0},
    {-0.42889630158379194, 0, 0, 0, 0, -4.697621415361164, 7.6834211960625991, 4.0689898183971103, 0.35672718745528109, 0, 0, 0, -0.0013990241651590145, 2.9475147891527724, -9.1509584721798696, 0}
};
static const double D8_B[12] = {
    0.054293734116568765,
    0,
    0,
    0,
    0,
    4.4503128927524092,
    1.8915178993145003,
    -5.8012039600105849,
    0.3111643669578199,
    -0.15216094966251609,
    0.20136540080403034,
    0.044710615727772587
};
static const double D8_C[16] = {
    0,
    0.05260015195876773,
    0.078900227938151601,
    0.1183503419072274,
    0.28164965809277259,
    0.33333333333333331,
    0.25,
    0.30769230769230771,
    0.6512820512820513,
    0.59999999999999998,
    0.8571428571428571,
    1,
    1,
    0.10000000000000001,
    0.20000000000000001,
    0.77777777777777779
};
static const double D8_E3[13] = {
    -0.18980075407240762,
    0,
    0,
    0,
    0,
    4.4503128927524092,
    1.8915178993145003,
    -5.8012039600105849,
    -0.42268232132379191,
    -0.15216094966251609,
    0.20136540080403034,
    0.022651792198360821,
    0
};
static const double D8_E5[13] = {
    0.01312004499419488,
    0,
    0,
    0,
    0,
    -1.2251564463762044,
    -0.4957589496572502,
    1.6643771824549864,
    -0.35032884874997366,
    0.33417911871301748,
    0.08192320648511571,
    -0.022355307863886294,
    0
};
static const double D8_D[4][16] = {
    {-8.4289382761090135, 0, 0, 0, 0, 0.56671495351937773, -3.0689499459498917, 2.3846676565120699, 2.1170345824450281, -0.87139158377797299, 2.2404374302607883, 0.63157877876946877, -0.088990336451333307, 18.148505520854727, -9.194632392478356, -4.4360363875948936},
    {10.427508642579134, 0, 0, 0, 0, 242.28349177525817, 165.20045171727028, -374.5467547226902, -22.113666853125306, 7.7334326684722638, -30.674084731089398, -9.3321305264302286, 15.697238121770845, -31.139403219565178, -9.3529243588444793, 35.816841486394082},
    {19.985053242002433, 0, 0, 0, 0, -387.03730874935178, -189.17813819516758, 527.80815920542364, -11.573902539959629, 6.8812326946963003, -1.0006050966910838, 0.77771377980534429, -2.7782057523535082, -60.196695231264123, 84.320405506677162, 11.992291136182789},
    {-25.69393346270375, 0, 0, 0, 0, -154.18974869023643, -231.5293791760455, 357.63911791061412, 93.405324183624316, -37.458323136451632, 104.0996495089623, 29.840293426660502, -43.533456590011141, 96.324553959188279, -39.177261675615441, -149.72683625798564}
};

/* ---------------------------------------------------------------- context */

struct proj;

typedef struct ctx {
    const eomc_model *m;
    const double *p;
    int nr;                  /* input grid rows (0: none, 1: constant) */
    const double *rt, *rv;   /* grid times, values (nr x ninput) */
    double *r;               /* current inputs (ninput) */
    double *mwork;           /* model scratch */
    eomc_stats *st;
    int n;                   /* nx */
    struct proj *pj;         /* constraint scratch (projection, stabilization) */
    double stab;             /* Baumgarte-style stabilization rate; 0 = off */
    const eomc_feedback *fb; /* state feedback / input callback, or NULL */
    double *fbJ;             /* nx x ninput scratch: jac_r for Radau with feedback */
    double *fbK;             /* ninput x nx + nx scratch: K(t), x_ref(t) on a gain grid */
    const double *Kt;        /* the gain inputs_at applied last (fb->K, or fbK) */
    eomc_events *ev;         /* event detection, or NULL */
    double ev_t;             /* time of the terminal event that stopped the run */
    double *ev_x;            /* its state (in the events' scratch) */
    int abort;               /* nonzero: a callback failed, Ctrl-C or SIGTERM -- the run's status, no retry */
    long sigint0;            /* g_sigint at the start of the run */
    const int *stop;         /* eomc_options.stop: a caller's flag that ends the run, or NULL */
    int nsw;                 /* switching functions (events marked switching + linear ones) */
    int nswe;                /* of which events (a model call each) */
    int gnew_ok;             /* the events' gnew already holds g at the step's end */
    int sw_cuts;             /* consecutive steps cut at a switching point */
    int nquat;               /* unit quaternions in x (eomc_options.nquat, .quat) */
    const int *quat;
    int n_err;               /* leading states the error tests see (n, or the state part of
                                an augmented sensitivity model: eomc_stagger.h) */
    int n_fin;               /* leading derivatives frhs checks for finiteness (n, or the state
                                part of an augmented model whose jvp checks its S rows itself) */
    eomc_stagger *sg;        /* Radau's staggered sensitivities, the adjoint's checkpoints, or NULL */
    int istop;               /* next of sg->tstop */
    double sw_noise;         /* a switching function within this of zero keeps its side (sw_left) */
    double sw_hp;            /* BDF: the last kept step's length (0: none yet; sw_reach) */
} ctx;

/* ---------------------------------------------------------------- Ctrl-C, SIGTERM */

/* SIGINTs and SIGTERMs seen by the armed handler; a run stops when it changes (a count, never
 * reset, so concurrent runs need no coordination and a stale signal never stops a later run). */
static volatile sig_atomic_t g_sigint = 0;

#if defined(_POSIX_VERSION) || defined(__unix__) || defined(__APPLE__)
/* The two signals that stop a run: Ctrl-C, and a job scheduler's or `kill`'s SIGTERM (s27: a
 * killed `eomc check` went on for minutes, its Python handler waiting for the C call to return). */
static const int g_stop_signals[2] = {SIGINT, SIGTERM};
static struct sigaction g_prev[2];     /* the handler each replaced, chained to */

static void on_sigint(int sig, siginfo_t *info, void *uc)
{
    const struct sigaction *prev = &g_prev[sig == SIGTERM];
    g_sigint = (sig_atomic_t)(g_sigint + 1);
    if (prev->sa_flags & SA_SIGINFO) {
        if (prev->sa_sigaction) prev->sa_sigaction(sig, info, uc);
    } else if (prev->sa_handler != SIG_DFL && prev->sa_handler != SIG_IGN) {
        prev->sa_handler(sig);
    }
}

/* Arm signal k (0: SIGINT, 1: SIGTERM); 1 when armed, 0 when it is default or ignored. */
static int arm_one(int k)
{
    struct sigaction cur, mine, old;
    int sig = g_stop_signals[k];
    if (sigaction(sig, NULL, &cur) != 0) return 0;
    if ((cur.sa_flags & SA_SIGINFO) && cur.sa_sigaction == on_sigint) return 1;  /* armed already */
    if (!(cur.sa_flags & SA_SIGINFO) && (cur.sa_handler == SIG_DFL || cur.sa_handler == SIG_IGN))
        return 0;
    memset(&mine, 0, sizeof mine);
    mine.sa_sigaction = on_sigint;
    mine.sa_flags = SA_SIGINFO;
#ifdef SA_ONSTACK
    mine.sa_flags |= cur.sa_flags & SA_ONSTACK;
#endif
    sigemptyset(&mine.sa_mask);
    g_prev[k] = cur;
    if (sigaction(sig, &mine, &old) != 0) return 0;
    if ((old.sa_flags & SA_SIGINFO) && old.sa_sigaction == on_sigint) return 1;  /* raced: keep cur */
    g_prev[k] = old;     /* what was really replaced (never this handler: no self-chaining) */
    return 1;
}

int eomc_interrupt_arm(void)
{
    int sigint = arm_one(0);
    int sigterm = arm_one(1);
    return sigint | sigterm;
}

void eomc_interrupt_disarm(void)
{
    struct sigaction cur;
    int k;
    for (k = 0; k < 2; ++k)
        if (sigaction(g_stop_signals[k], NULL, &cur) == 0 && (cur.sa_flags & SA_SIGINFO)
            && cur.sa_sigaction == on_sigint)
            sigaction(g_stop_signals[k], &g_prev[k], NULL);
}
#else
int eomc_interrupt_arm(void) { return 0; }
void eomc_interrupt_disarm(void) { }
#endif

long eomc_interrupt_count(void) { return (long)g_sigint; }

long eomc_interrupt_arm_base(void)
{
    long base = (long)g_sigint + 1;      /* read first: a signal while arming counts as after */
    eomc_interrupt_arm();
    return base;
}

/* Nonzero when the run must stop now (Ctrl-C or SIGTERM, a callback that failed, or the
 * caller's eomc_options.stop set from another thread: read through volatile, never cached). */
static int aborted(ctx *c)
{
    if (!c->abort && (g_sigint != c->sigint0 || (c->stop && *(const volatile int *)c->stop)))
        c->abort = EOMC_ABORTED;
    return c->abort;
}

/* Dense output of the last accepted step [t, t + h], for events. */
typedef struct interp {
    int kind;                /* 0 Hermite (RK4), 1 DOPRI5, 2 DOP853, 3 Radau, 4 BDF */
    int n;
    double t, h;
    const double *x0, *f0, *x1, *f1, *K, *F, *Q;
    const eomc_bdf *bdf;     /* kind 4: its trial step's polynomial */
} interp;

static void interp_eval(const interp *ip, double tau, double *out);
static int events_eval(ctx *c, double t, const double *x, double *g);
static int events_cross(ctx *c, double tn, const double *xn, int *hits);
static int events_locate(ctx *c, const interp *ip);
static int events_commit(ctx *c, double tn, const double *xn, int recompute);
static int sw_detect(ctx *c, double t, const double *x, double tn, const double *xn, int nst,
                     const double *tst, const double *xst, int *ncross);
static int sw_interior(ctx *c, int nst, const double *tst, const double *xst, int *ncross);
static int sw_reach(const ctx *c, double h);
static void sw_step_kept(ctx *c, double h);
static int sw_locate(ctx *c, const interp *ip, double *t_cut);
static int sw_watch(ctx *c, double t, const double *x, double tn, const double *xn);
static void sw_keep(ctx *c);
static void sw_flip(ctx *c);
static void sw_lin_extrema(ctx *c, double t, double h, const double *x, const double *f0,
                           const double *xn, const double *f1, const interp *ip, double rtol,
                           double atol, int *ncross, int *near);
struct outw;
EOMC_NOINLINE int events_in_step(ctx *c, const interp *ip, struct outw *ow, double *x);

static int stabilize_rhs(ctx *c, double t, const double *x, double *f);

/* Bump allocator over the caller's work buffer. */
static double *take(double **pos, size_t n)
{
    double *out = *pos;
    *pos += n;
    return out;
}

static size_t proj_size(const eomc_model *m)
{
    size_t k = (size_t)(m->nhol + m->nvel), n = (size_t)m->nx;
    return k * n + k * k + 4 * k + 4 * n + 8;
}

static size_t base_size(const eomc_model *m)
{
    return (size_t)m->ninput + m->work_size + proj_size(m) + 8 * (size_t)m->nx + 16;
}

size_t eomc_integrate_work_size(const eomc_model *m, int method)
{
    size_t n = (size_t)m->nx, extra;
    switch (method) {
    case EOMC_RK4: extra = 10 * n; break;
    case EOMC_DOPRI5:
    case EOMC_DOP853: extra = 32 * n; break;
    case EOMC_RADAU5: extra = 6 * n * n + 40 * n; break;
    case EOMC_IMPLICITFAST: extra = eomc_fs_work_size(m->nx) + (size_t)m->noutput; break;   /* + the watch's */
    case EOMC_BDF: extra = eomc_bdf_work_size(m->nx) + 6 * n; break;
    default: extra = 0;
    }
    return base_size(m) + extra;
}

/* Cubic Hermite on grid interval [lo, hi] (length h, at fraction w) with the given slopes. */
static void cubic_inputs(ctx *c, int lo, int hi, double h, double w)
{
    int ni = c->m->ninput;
    const double *a = c->rv + (size_t)lo * ni, *b = c->rv + (size_t)hi * ni;
    const double *ma = c->fb->r_slopes + (size_t)lo * ni, *mb = c->fb->r_slopes + (size_t)hi * ni;
    double v = 1.0 - w;
    double h00 = (1 + 2 * w) * v * v, h10 = w * v * v, h01 = w * w * (3 - 2 * w), h11 = -w * w * v;
    for (int i = 0; i < ni; i++)
        c->r[i] = h00 * a[i] + h10 * h * ma[i] + h01 * b[i] + h11 * h * mb[i];
}

/* r(t): constant, or linear (cubic with r_slopes) interpolation on the grid held at its ends. */
static void grid_inputs_at(ctx *c, double t)
{
    int ni = c->m->ninput, lo = 0, hi = c->nr - 1;
    if (ni <= 0 || c->nr <= 1)
        return;
    if (t <= c->rt[0]) {
        memcpy(c->r, c->rv, (size_t)ni * sizeof(double));
        return;
    }
    if (t >= c->rt[hi]) {
        memcpy(c->r, c->rv + (size_t)hi * ni, (size_t)ni * sizeof(double));
        return;
    }
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (c->rt[mid] <= t) lo = mid; else hi = mid;
    }
    {
        double h = c->rt[hi] - c->rt[lo], w = (t - c->rt[lo]) / h;
        const double *a = c->rv + (size_t)lo * ni, *b = c->rv + (size_t)hi * ni;
        if (c->fb && c->fb->r_slopes) {
            cubic_inputs(c, lo, hi, h, w);
            return;
        }
        for (int i = 0; i < ni; i++)
            c->r[i] = (1.0 - w) * a[i] + w * b[i];
    }
}

static int all_finite(int n, const double *v)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

/* Row w-vectors V (n x w) on the increasing times tg at t, by grid_inputs_at's rule and
 * arithmetic: the first row before the grid, the last after it (both returned as they are),
 * linear between two rows (written to out). */
static const double *grid_rows_at(const double *tg, int n, const double *V, size_t w, double t,
                                  double *out)
{
    int lo = 0, hi = n - 1;
    if (t <= tg[0]) return V;
    if (t >= tg[hi]) return V + (size_t)hi * w;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (tg[mid] <= t) lo = mid; else hi = mid;
    }
    {
        double w_ = (t - tg[lo]) / (tg[hi] - tg[lo]);
        const double *a = V + (size_t)lo * w, *b = V + (size_t)hi * w;
        for (size_t i = 0; i < w; i++)
            out[i] = (1.0 - w_) * a[i] + w_ * b[i];
    }
    return out;
}

size_t eomc_feedback_work_size(const eomc_model *m, const eomc_feedback *fb)
{
    size_t ni = m && m->ninput > 0 ? (size_t)m->ninput : 0, nx = m ? (size_t)m->nx : 0;
    if (!fb) return 0;
    return ni * nx + (fb->n_kgrid >= 2 ? ni * nx + nx : 0);
}

/* r(t, x): the grid (or the caller's callback) plus K (x_ref - x), K and x_ref at t on a
 * gain grid.  Returns a status: the callback's failure or a non-finite input. */
static int inputs_at(ctx *c, double t, const double *x)
{
    const eomc_feedback *fb = c->fb;
    int ni = c->m->ninput, nx = c->n;
    const double *K, *ref;
    if (!fb || ni <= 0) {
        grid_inputs_at(c, t);
        return EOMC_OK;
    }
    if (fb->fn) {
        int s = fb->fn(fb->user, t, x, c->r);
        if (s) return c->abort = s;   /* the caller's callback failed: stop, never call it again */
    } else {
        if (c->nr <= 0) memset(c->r, 0, (size_t)ni * sizeof(double));
        else if (c->nr == 1) memcpy(c->r, c->rv, (size_t)ni * sizeof(double));
        else grid_inputs_at(c, t);
    }
    K = fb->K;
    ref = fb->x_ref;
    if (K && fb->n_kgrid >= 2) {
        K = grid_rows_at(fb->k_tgrid, fb->n_kgrid, fb->K, (size_t)ni * (size_t)nx, t, c->fbK);
        if (ref && fb->ref_on_grid)
            ref = grid_rows_at(fb->k_tgrid, fb->n_kgrid, fb->x_ref, (size_t)nx, t,
                               c->fbK + (size_t)ni * (size_t)nx);
    }
    c->Kt = K;
    if (K)
        for (int i = 0; i < ni; i++) {
            double acc = 0.0;
            const double *Ki = K + (size_t)i * nx;
            for (int j = 0; j < nx; j++)
                acc += Ki[j] * ((ref ? ref[j] : 0.0) - x[j]);
            c->r[i] += acc;
        }
    return all_finite(ni, c->r) ? EOMC_OK : EOMC_NONFINITE;
}

/* f = rhs(t, x); a non-finite derivative is EOMC_NONFINITE. */
static int frhs(ctx *c, double t, const double *x, double *f)
{
    int s;
    if (aborted(c)) { c->st->t_fail = t; return c->abort; }
    if (!c->fb) grid_inputs_at(c, t);           /* the plain path, as before feedback existed */
    else if ((s = inputs_at(c, t, x))) { c->st->t_fail = t; return s; }
    c->st->nfev++;
    s = c->m->rhs(t, x, c->p, c->r, f, c->mwork);
    if (s == EOMC_OK && c->stab > 0.0) s = stabilize_rhs(c, t, x, f);
    if (s == EOMC_OK && !all_finite(c->n_fin, f)) s = EOMC_NONFINITE;
    if (s != EOMC_OK) c->st->t_fail = t;
    return s;
}

static int fjac(ctx *c, double t, const double *x, double *J)
{
    int s;
    if (!c->m->jac_x) return EOMC_NOT_AVAILABLE;
    if (aborted(c)) { c->st->t_fail = t; return c->abort; }
    if ((s = inputs_at(c, t, x))) { c->st->t_fail = t; return s; }
    c->st->njev++;
    s = c->m->jac_x(t, x, c->p, c->r, J, c->mwork);
    if (s == EOMC_OK && c->fb && c->fb->K && c->m->ninput > 0) {
        /* d rhs(x, r(x)) / dx = jac_x - jac_r K */
        int n = c->n, ni = c->m->ninput;
        if (!c->m->jac_r) s = EOMC_NOT_AVAILABLE;
        else s = c->m->jac_r(t, x, c->p, c->r, c->fbJ, c->mwork);
        if (s == EOMC_OK)
            for (int i = 0; i < n; i++)
                for (int k = 0; k < ni; k++) {
                    double b = c->fbJ[(size_t)i * ni + k];
                    if (b != 0.0)
                        for (int j = 0; j < n; j++) J[(size_t)i * n + j] -= b * c->Kt[(size_t)k * n + j];
                }
    }
    if (s == EOMC_OK && !all_finite(c->n * c->n, J)) s = EOMC_NONFINITE;
    if (s != EOMC_OK) c->st->t_fail = t;
    return s;
}

static int ctx_init(ctx *c, const eomc_model *m, const double *p, int nr,
                    const double *rt, const double *rv, eomc_stats *st, double **pos)
{
    c->m = m; c->p = p; c->nr = nr; c->rt = rt; c->rv = rv; c->st = st; c->n = m->nx;
    c->pj = NULL; c->stab = 0.0; c->fb = NULL; c->fbJ = NULL; c->fbK = NULL; c->Kt = NULL; c->ev = NULL; c->ev_t = 0.0; c->ev_x = NULL;
    c->abort = 0; c->sigint0 = g_sigint; c->stop = NULL;
    c->nsw = 0; c->nswe = 0; c->gnew_ok = 0; c->sw_cuts = 0; c->sw_hp = 0.0;
    c->nquat = 0; c->quat = NULL;
    c->n_err = m->nx; c->n_fin = m->nx; c->sg = NULL; c->istop = 0;
    c->r = take(pos, (size_t)m->ninput + 1);
    c->mwork = take(pos, m->work_size + 1);
    if (m->ninput > 0) {
        if (nr <= 0) memset(c->r, 0, (size_t)m->ninput * sizeof(double));
        else if (!rv) return EOMC_BAD_ARGUMENT;
        else memcpy(c->r, rv, (size_t)m->ninput * sizeof(double));
        if (nr >= 2 && !rt) return EOMC_BAD_ARGUMENT;
    }
    return EOMC_OK;
}

/* RMS of v / (atol + rtol*max(|a|, |b|)) */
static double err_norm(int n, const double *v, const double *a, const double *b,
                       double rtol, double atol)
{
    double s = 0.0;
    for (int i = 0; i < n; i++) {
        double sc = atol + rtol * fmax(fabs(a[i]), fabs(b[i]));
        double e = v[i] / sc;
        s += e * e;
    }
    return n > 0 ? sqrt(s / n) : 0.0;
}

/* Hairer's starting step (Solving ODEs I, II.4); tmp, f1: nx scratch. */
static int initial_step(ctx *c, double t0, double t1, const double *x, const double *f0,
                        int order, double rtol, double atol, double hmax,
                        double *tmp, double *f1, double *h_out)
{
    int n = c->n, ne = c->n_err, s;
    double d0 = 0, d1 = 0, d2 = 0, h0, h1, len = t1 - t0;
    for (int i = 0; i < ne; i++) {
        double sc = atol + fabs(x[i]) * rtol;
        d0 += (x[i] / sc) * (x[i] / sc);
        d1 += (f0[i] / sc) * (f0[i] / sc);
    }
    d0 = sqrt(d0 / ne); d1 = sqrt(d1 / ne);
    h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    h0 = fmin(h0, len);
    for (int i = 0; i < n; i++) tmp[i] = x[i] + h0 * f0[i];
    s = frhs(c, t0 + h0, tmp, f1);
    if (s == EOMC_NONFINITE && !c->abort) { *h_out = fmin(h0 * 1e-3, hmax); return EOMC_OK; }
    if (s) return s;
    for (int i = 0; i < ne; i++) {
        double sc = atol + fabs(x[i]) * rtol;
        d2 += ((f1[i] - f0[i]) / sc) * ((f1[i] - f0[i]) / sc);
    }
    d2 = sqrt(d2 / ne) / h0;
    if (d1 <= 1e-15 && d2 <= 1e-15) h1 = fmax(1e-6, h0 * 1e-3);
    else h1 = pow(0.01 / fmax(d1, d2), 1.0 / (order + 1));
    *h_out = fmin(fmin(100 * h0, h1), fmin(len, hmax));
    return EOMC_OK;
}

/* Smallest step that still advances t in floating point. */
static double min_step(double t)
{
    return 10.0 * fabs(nextafter(t, INFINITY) - t);
}

/* ------------------------------------------------------- dense LU (real: eomc_dense_lu.h; complex: eomc_dense_lu_c.h) */

/* sum_j a_j b_j over the complex entries j = lo, lo + step, ..., up to (not including) hi,
 * in that order: re and im of the sum.  With SSE2 (every x86-64) one pair register holds
 * [ar br, ai bi] and another [ar bi, ai br]. */
static inline void sg_cdot(const double *a, const double *b, int lo, int hi, int step,
                           double *re, double *im)
{
#if defined(__SSE2__)
    __m128d P = _mm_setzero_pd(), Q = _mm_setzero_pd();
    double p[2], q[2];
    for (int j = lo; j != hi; j += step) {
        __m128d av = _mm_loadu_pd(a + 2 * j), bv = _mm_loadu_pd(b + 2 * j);
        P = _mm_add_pd(P, _mm_mul_pd(av, bv));
        Q = _mm_add_pd(Q, _mm_mul_pd(av, _mm_shuffle_pd(bv, bv, 1)));
    }
    _mm_storeu_pd(p, P);
    _mm_storeu_pd(q, Q);
    *re = p[0] - p[1];
    *im = q[0] + q[1];
#else
    double sr = 0.0, si = 0.0;
    for (int j = lo; j != hi; j += step) {
        sr += a[2 * j] * b[2 * j] - a[2 * j + 1] * b[2 * j + 1];
        si += a[2 * j] * b[2 * j + 1] + a[2 * j + 1] * b[2 * j];
    }
    *re = sr;
    *im = si;
#endif
}

/* Radau's staggered sensitivities: a real and a complex solve per column and iteration with
 * the step's LU, k columns (column j at B + j n).  Each row's sum runs from the oldest
 * unknown to the one just solved for (forward sweep: j ascending; back sweep: descending),
 * so the sum of the earlier terms does not wait on the newest value and the processor
 * overlaps the rows; the back sweep multiplies by the diagonal's reciprocal instead of
 * dividing (rr, and rq as re, im pairs: since s11 the caller's, computed once per
 * factorization instead of per row and iteration -- 54 divisions an iteration at n = 18).  The state's Newton keeps lu_solve/lu_solve_c, whose
 * dependent chain per row (the newest term first, then a division) made these solves
 * latency-bound: at n = 18 (the 8-link cart) a real solve 400 -> 190 ns, a complex one
 * 490 -> 350 ns (with the SSE2 complex products below), C loop, core 0.  The sums run in
 * another order than lu_solve's: the same solution to rounding.
 * The real and the complex solve run row by row together (s11): the two substitutions are
 * independent and each is a latency-bound chain, so with row i of both in one loop body the
 * processor overlaps them instead of running one after the other; each does the operations
 * of the separate solves of s9 in their order (bit for bit as before).  On CPUs with AVX2
 * the dot products run four real / two complex products an operation (sg_rdot_avx2,
 * sg_cdot_avx2): another order of the same sums; the solves were throughput-bound (perf:
 * ~590 ns a real + complex pair at n = 18), one column 1.528 -> 1.509 x plain, four 2.31 ->
 * 2.17.  Whole runs, n = 8 cart, Radau 1e-8: benchmarks/results/sensitivity_radau.md. */
typedef void (*sg_cdot_fn)(const double *, const double *, int, int, int, double *, double *);
typedef double (*sg_rdot_fn)(const double *, const double *, int, int, int);

/* sum_j a_j b_j for j = lo, lo + step, ... up to (not including) hi, in that order. */
static inline double sg_rdot(const double *a, const double *b, int lo, int hi, int step)
{
    double s = 0.0;
    for (int j = lo; j != hi; j += step) s += a[j] * b[j];
    return s;
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define EOMC_SG_AVX2 1
#include <immintrin.h>
/* sg_cdot with two complex entries an AVX2 operation (the even and the odd steps summed
 * apart, then together: another order than sg_cdot's, the same sums to rounding). */
__attribute__((target("avx2")))
static inline void sg_cdot_avx2(const double *a, const double *b, int lo, int hi, int step,
                                double *re, double *im)
{
    __m256d P = _mm256_setzero_pd(), Q = _mm256_setzero_pd();
    __m128d p2, q2;
    double p[2], q[2];
    int j = lo, cnt = step > 0 ? hi - lo : lo - hi;
    for (; cnt >= 2; cnt -= 2, j += 2 * step) {
        int o = step > 0 ? 2 * j : 2 * (j - 1);
        __m256d av = _mm256_loadu_pd(a + o), bv = _mm256_loadu_pd(b + o);
        P = _mm256_add_pd(P, _mm256_mul_pd(av, bv));
        Q = _mm256_add_pd(Q, _mm256_mul_pd(av, _mm256_permute_pd(bv, 5)));
    }
    p2 = _mm_add_pd(_mm256_castpd256_pd128(P), _mm256_extractf128_pd(P, 1));
    q2 = _mm_add_pd(_mm256_castpd256_pd128(Q), _mm256_extractf128_pd(Q, 1));
    if (cnt == 1) {
        __m128d av = _mm_loadu_pd(a + 2 * j), bv = _mm_loadu_pd(b + 2 * j);
        p2 = _mm_add_pd(p2, _mm_mul_pd(av, bv));
        q2 = _mm_add_pd(q2, _mm_mul_pd(av, _mm_shuffle_pd(bv, bv, 1)));
    }
    _mm_storeu_pd(p, p2);
    _mm_storeu_pd(q, q2);
    *re = p[0] - p[1];
    *im = q[0] + q[1];
}

/* sg_rdot four products an AVX2 operation (four partial sums, then the last up to three
 * terms -- the newest unknowns -- one by one: another order, the same sum to rounding). */
__attribute__((target("avx2")))
static inline double sg_rdot_avx2(const double *a, const double *b, int lo, int hi, int step)
{
    __m256d P = _mm256_setzero_pd();
    __m128d p2;
    double s;
    int j = lo, cnt = step > 0 ? hi - lo : lo - hi;
    for (; cnt >= 4; cnt -= 4, j += 4 * step) {
        int o = step > 0 ? j : j - 3;
        P = _mm256_add_pd(P, _mm256_mul_pd(_mm256_loadu_pd(a + o), _mm256_loadu_pd(b + o)));
    }
    p2 = _mm_add_pd(_mm256_castpd256_pd128(P), _mm256_extractf128_pd(P, 1));
    s = _mm_cvtsd_f64(_mm_add_sd(p2, _mm_unpackhi_pd(p2, p2)));
    for (; cnt > 0; cnt--, j += step) s += a[j] * b[j];
    return s;
}
#endif

static inline __attribute__((always_inline))
void sg_solve_body(int n, const double *A, const int *piv, double *B, const eomc_cplx *Ac,
                   const int *pivc, eomc_cplx *Bc, int k, const double *rr, const double *rq,
                   int top, sg_cdot_fn cdot, sg_rdot_fn rdot)
{
    for (int c = 0; c < k; c++) {
        double *b = B + (size_t)c * n;
        eomc_cplx *bc = Bc + (size_t)c * n;
        for (int r = 0; r < n; r++) {
            if (piv[r] != r) { double tmp = b[r]; b[r] = b[piv[r]]; b[piv[r]] = tmp; }
            if (pivc[r] != r) { eomc_cplx tmp = bc[r]; bc[r] = bc[pivc[r]]; bc[pivc[r]] = tmp; }
        }
    }
    for (int i = top > 1 ? top : 1; i < n; i++) {    /* the top rows' L parts are zero */
        const double *a = A + (size_t)i * n, *ac = (const double *)(Ac + (size_t)i * n);
        for (int c = 0; c < k; c++) {
            double *b = B + (size_t)c * n, *bc = (double *)(Bc + (size_t)c * n), sr, si;
            double s = rdot(a, b, 0, i, 1);
            cdot(ac, bc, 0, i, 1, &sr, &si);
            b[i] -= s;
            bc[2 * i] -= sr;
            bc[2 * i + 1] -= si;
        }
    }
    for (int i = n - 1; i >= top; i--) {
        const double *a = A + (size_t)i * n, r = rr[i], *ac = (const double *)(Ac + (size_t)i * n);
        double qr = rq[2 * i], qi = rq[2 * i + 1];
        for (int c = 0; c < k; c++) {
            double *b = B + (size_t)c * n, *bc = (double *)(Bc + (size_t)c * n), sr, si;
            double s = rdot(a, b, n - 1, i, -1);
            cdot(ac, bc, n - 1, i, -1, &sr, &si);
            b[i] = (b[i] - s) * r;
            sr = bc[2 * i] - sr;
            si = bc[2 * i + 1] - si;
            bc[2 * i] = sr * qr - si * qi;
            bc[2 * i + 1] = sr * qi + si * qr;
        }
    }
    for (int i = top - 1; i >= 0; i--) {             /* top rows: U's one entry at top + i */
        const double *a = A + (size_t)i * n, r = rr[i], *ac = (const double *)(Ac + (size_t)i * n);
        double qr = rq[2 * i], qi = rq[2 * i + 1];
        int u = top + i;
        for (int c = 0; c < k; c++) {
            double *b = B + (size_t)c * n, *bc = (double *)(Bc + (size_t)c * n), sr, si;
            double s = a[u] * b[u];
            sr = bc[2 * i] - (ac[2 * u] * bc[2 * u] - ac[2 * u + 1] * bc[2 * u + 1]);
            si = bc[2 * i + 1] - (ac[2 * u] * bc[2 * u + 1] + ac[2 * u + 1] * bc[2 * u]);
            b[i] = (b[i] - s) * r;
            bc[2 * i] = sr * qr - si * qi;
            bc[2 * i + 1] = sr * qi + si * qr;
        }
    }
}


#ifdef EOMC_SG_AVX2
__attribute__((target("avx2")))
static void sg_solve_rc_avx2(int n, const double *A, const int *piv, double *B, const eomc_cplx *Ac,
                             const int *pivc, eomc_cplx *Bc, int k, const double *rr, const double *rq,
                             int top)
{
    sg_solve_body(n, A, piv, B, Ac, pivc, Bc, k, rr, rq, top, sg_cdot_avx2, sg_rdot_avx2);
}
#endif

/* top > 0: both LUs' top rows are [mu e_i, -e_(top + i)] with zero L parts (sg_top_structure,
 * top = n / 2): their forward sums are skipped and their back sums are the one product. */
static void sg_solve_rc(int n, const double *A, const int *piv, double *B, const eomc_cplx *Ac,
                        const int *pivc, eomc_cplx *Bc, int k, const double *rr, const double *rq,
                        int top)
{
#ifdef EOMC_SG_AVX2
    if (__builtin_cpu_supports("avx2")) {
        sg_solve_rc_avx2(n, A, piv, B, Ac, pivc, Bc, k, rr, rq, top);
        return;
    }
#endif
    sg_solve_body(n, A, piv, B, Ac, pivc, Bc, k, rr, rq, top, sg_cdot, sg_rdot);
}

/* Radau's Newton matrix mu I - J when J's top h = n / 2 rows are [0 I] (x = [q; u], q' = u):
 * its top rows are [mu e_i, -e_(h + i)], and when the LU's first h pivots are the diagonal the
 * first h columns' multipliers in the top rows are 0 / mu = 0, which leaves those rows as they
 * are: L parts zero, U parts mu and -1.  sg_solve_body then skips the top rows' forward sums
 * (all zero) and takes their back sums as the one product, after the bottom rows.  Why: at n
 * = 18 that is 144 of a solve's 306 products, and the bottom rows' dependent chains no longer
 * pass through the top rows (half as long).  The skipped sums are exact zeros and the kept
 * one is the same product, so the solution is the same to the bit (a zero's sign aside). */
/* Whether J's top half rows are [0 I] exactly (n even), as sg_half_factor asks. */
static int sg_top_identity(const double *J, int n)
{
    int h = n / 2;
    if (n % 2 || h < 1) return 0;
    for (int i = 0; i < h; i++)
        for (int j = 0; j < n; j++)
            if (J[(size_t)i * n + j] != (j == h + i ? 1.0 : 0.0)) return 0;
    return 1;
}

/* Whether this factorization has that structure: J's top rows checked (top) and the
 * real and the complex LU's first n / 2 pivots on the diagonal. */
static int sg_top_structure(int top, int n, const int *pivr, const int *pivc)
{
    if (!top) return 0;
    for (int i = 0; i < n / 2; i++)
        if (pivr[i] != i || pivc[i] != i) return 0;
    return 1;
}

/* ---------------------------------------------------- unit quaternions */

/* Each quaternion of x scaled to length 1 (a zero or non-finite one is left for the rhs
 * to report); f (may be NULL), the derivative at x, gets its quaternion rows scaled by
 * the same factor: the rhs of a quaternion free joint is independent of the quaternion's
 * length and linear in it in these rows, so that is f at the normalised x, exactly,
 * without another rhs call. */
static void unit_quats(const ctx *c, double *x, double *f)
{
    for (int k = 0; k < c->nquat; k++) {
        int i = c->quat[k];
        double n2 = x[i] * x[i] + x[i + 1] * x[i + 1] + x[i + 2] * x[i + 2] + x[i + 3] * x[i + 3];
        double s;
        if (!(n2 > 0.0) || !isfinite(n2)) continue;
        s = 1.0 / sqrt(n2);
        for (int j = 0; j < 4; j++) {
            x[i + j] *= s;
            if (f) f[i + j] *= s;
        }
    }
}

/* ---------------------------------------------------- output and projection */

/* Rows of t_eval still to write; filled as steps pass them. */
typedef struct outw {
    int n, i, nx;
    int ld;                  /* row stride of x (>= nx: rows of a wider table) */
    const double *t;
    double *x;
} outw;

/* A row written at a step end before projection gets the projected state. */
static void fix_last_row(outw *ow, double tn, const double *x)
{
    if (ow->i > 0 && ow->t[ow->i - 1] == tn)
        memcpy(ow->x + (size_t)(ow->i - 1) * ow->ld, x, (size_t)ow->nx * sizeof(double));
}

typedef struct proj {
    int on, k;              /* k = nhol + nvel */
    double *g, *G, *S, *y;
    int *piv;
} proj;

static void proj_init(proj *pj, const eomc_model *m, int want, double **pos)
{
    size_t k = (size_t)(m->nhol + m->nvel), n = (size_t)m->nx;
    pj->k = (int)k;
    pj->on = want && k > 0 && m->constraints && m->constraints_jac;
    pj->g = take(pos, k + 1);
    pj->G = take(pos, k * n + 1);
    pj->S = take(pos, k * k + 1);
    pj->y = take(pos, k + 1);
    pj->piv = (int *)take(pos, k + 1);
}

static int eval_constraints(ctx *c, proj *pj, double t, const double *x, int jac)
{
    int s;
    if ((s = inputs_at(c, t, x))) return s;
    s = c->m->constraints(t, x, c->p, c->r, pj->g, c->mwork);
    if (s == EOMC_OK && jac)
        s = c->m->constraints_jac(t, x, c->p, c->r, pj->G, c->mwork);
    return s;
}

/* Minimum-norm correction of x[off:off+cols] so that rows [r0, r0+nr) of
 * the constraints vanish to first order: dz = -B^T (B B^T)^-1 g. */
static int gauss_newton_update(proj *pj, int nx, int r0, int nr, int off, int cols, double *x)
{
    for (int i = 0; i < nr; i++)
        for (int j = 0; j < nr; j++) {
            double s = 0.0;
            for (int l = 0; l < cols; l++)
                s += pj->G[(r0 + i) * nx + off + l] * pj->G[(r0 + j) * nx + off + l];
            pj->S[i * nr + j] = s;
        }
    if (lu_factor(nr, pj->S, pj->piv)) return EOMC_SINGULAR_CONSTRAINTS;
    memcpy(pj->y, pj->g + r0, (size_t)nr * sizeof(double));
    lu_solve(nr, pj->S, pj->piv, pj->y);
    for (int l = 0; l < cols; l++) {
        double s = 0.0;
        for (int i = 0; i < nr; i++) s += pj->G[(r0 + i) * nx + off + l] * pj->y[i];
        x[off + l] -= s;
    }
    return EOMC_OK;
}

/* Baumgarte-style stabilization of the ODE: xdot -= a * G^+ g, so that a
 * constraint residual g decays like exp(-a t) instead of drifting (inputs
 * are already set at t by frhs). */
static int stabilize_rhs(ctx *c, double t, const double *x, double *f)
{
    const eomc_model *m = c->m;
    proj *pj = c->pj;
    int s, nx = m->nx;
    if ((s = m->constraints(t, x, c->p, c->r, pj->g, c->mwork))) return s;
    if ((s = m->constraints_jac(t, x, c->p, c->r, pj->G, c->mwork))) return s;
    for (int i = 0; i < pj->k; i++) pj->g[i] *= c->stab;
    if (m->nhol > 0 && (s = gauss_newton_update(pj, nx, 0, m->nhol, 0, m->nq, f))) return s;
    if (m->nvel > 0 && (s = gauss_newton_update(pj, nx, m->nhol, m->nvel, m->nq, m->nu, f)))
        return s;
    return EOMC_OK;
}

/* Project q onto the holonomic manifold (Gauss-Newton), then u onto the
 * velocity constraints; record the remaining residual. */
static int project_state(ctx *c, proj *pj, double t, double *x)
{
    const eomc_model *m = c->m;
    int s, nx = m->nx;
    double res = 0.0;
    if (!pj->on) return EOMC_OK;
    for (int it = 0; m->nhol > 0 && it < 8; it++) {
        double gmax = 0.0;
        if ((s = eval_constraints(c, pj, t, x, 1))) return s;
        for (int i = 0; i < m->nhol; i++) gmax = fmax(gmax, fabs(pj->g[i]));
        if (gmax <= 1e-15) break;
        if ((s = gauss_newton_update(pj, nx, 0, m->nhol, 0, m->nq, x))) return s;
    }
    if (m->nvel > 0) {
        if ((s = eval_constraints(c, pj, t, x, 1))) return s;
        if ((s = gauss_newton_update(pj, nx, m->nhol, m->nvel, m->nq, m->nu, x))) return s;
    }
    if ((s = eval_constraints(c, pj, t, x, 0))) return s;
    for (int i = 0; i < pj->k; i++) res = fmax(res, fabs(pj->g[i]));
    c->st->nproj++;
    if (res > c->st->max_residual) c->st->max_residual = res;
    return all_finite(nx, x) ? EOMC_OK : EOMC_NONFINITE;
}

/* Write every pending t_eval row at or before `upto` with dense(tau). */
#define EMIT_UNTIL(ow, upto, DENSE)                                   \
    while ((ow)->i < (ow)->n && (ow)->t[(ow)->i] <= (upto)) {          \
        double tau = (ow)->t[(ow)->i];                                \
        double *row = (ow)->x + (size_t)(ow)->i * (ow)->ld;           \
        (void)tau;                                                    \
        DENSE;                                                        \
        (ow)->i++;                                                    \
    }

static void hermite(int n, double h, double theta, const double *x0, const double *f0,
                    const double *x1, const double *f1, double *out)
{
    double a = (1 + 2 * theta) * (1 - theta) * (1 - theta);
    double b = theta * (1 - theta) * (1 - theta);
    double cc = theta * theta * (3 - 2 * theta);
    double d = theta * theta * (theta - 1);
    for (int i = 0; i < n; i++)
        out[i] = a * x0[i] + b * h * f0[i] + cc * x1[i] + d * h * f1[i];
}

/* ---------------------------------------------------------------- RK4 */

static int run_rk4(ctx *c, const eomc_options *o, proj *pj, double t0, double t1,
                   double *x, outw *ow, double **pos)
{
    int n = c->n, s;
    long nsteps, maxs = o->max_steps > 0 ? o->max_steps : DEFAULT_MAX_STEPS;
    double h = o->h0;
    double *k1 = take(pos, n), *k2 = take(pos, n), *k3 = take(pos, n), *k4 = take(pos, n);
    double *tmp = take(pos, n), *x1 = take(pos, n);
    eomc_stats *st = c->st;
    if (!(h > 0) || !isfinite(h)) return EOMC_BAD_ARGUMENT;
    nsteps = (long)ceil((t1 - t0) / h * (1 - 1e-12));
    if (nsteps < 1) nsteps = 1;
    if ((s = frhs(c, t0, x, k1))) return s;
    for (long k = 0; k < nsteps; k++) {
        double t = t0 + k * h, tn = (k == nsteps - 1) ? t1 : t0 + (k + 1) * h, hh = tn - t;
        st->t = t; st->h = hh;
        if (st->steps >= maxs) return EOMC_MAX_STEPS;
        st->steps++;
        for (int i = 0; i < n; i++) tmp[i] = x[i] + 0.5 * hh * k1[i];
        if ((s = frhs(c, t + 0.5 * hh, tmp, k2))) return s;
        for (int i = 0; i < n; i++) tmp[i] = x[i] + 0.5 * hh * k2[i];
        if ((s = frhs(c, t + 0.5 * hh, tmp, k3))) return s;
        for (int i = 0; i < n; i++) tmp[i] = x[i] + hh * k3[i];
        if ((s = frhs(c, tn, tmp, k4))) return s;
        for (int i = 0; i < n; i++)
            x1[i] = x[i] + hh / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
        if (!all_finite(n, x1)) return EOMC_NONFINITE;
        if ((s = frhs(c, tn, x1, k2))) return s;        /* k2 := f(tn, x1) */
        st->accepted++;
        if (c->nsw && (s = sw_watch(c, t, x, tn, x1))) return s;
        if (c->ev) {
            int hits = 0;
            if ((s = events_cross(c, tn, x1, &hits))) return s;
            if (hits) {
                interp ip = {0, n, t, hh, x, k1, x1, k2, NULL, NULL, NULL, NULL};
                if ((s = events_in_step(c, &ip, ow, x))) return s;
                if (c->ev->terminated) return EOMC_OK;
            }
        }
        EMIT_UNTIL(ow, tn, hermite(n, hh, (tau - t) / hh, x, k1, x1, k2, row));
        if (c->nquat) { unit_quats(c, x1, k2); fix_last_row(ow, tn, x1); }
        if (pj->on) {
            if ((s = project_state(c, pj, tn, x1))) return s;
            fix_last_row(ow, tn, x1);
            if ((s = frhs(c, tn, x1, k2))) return s;
        }
        if (c->ev && (s = events_commit(c, tn, x1, pj->on))) return s;
        memcpy(x, x1, (size_t)n * sizeof(double));
        memcpy(k1, k2, (size_t)n * sizeof(double));
    }
    st->t = t1;
    return EOMC_OK;
}

/* ------------------------------------------------- DOPRI5 and DOP853 */

typedef struct erk {
    int s;                     /* stages; K[s] holds f(t + h, y_new) */
    int astride;               /* row length of A */
    const double *A, *B, *C;
    int err_order;             /* order of the error estimator */
    int is853;
    double stiff_limit;        /* Hairer's h*lambda bound of the stability region */
    double pi_weight;          /* c of the PI control's error exponent 1/(q+1) - c beta */
} erk;

static const erk ERK_DP5 = {6, 5, &DP5_A[0][0], DP5_B, DP5_C, 4, 0, 3.25, 0.75};
static const erk ERK_D853 = {12, 16, &D8_A[0][0], D8_B, D8_C, 7, 1, 6.1, 0.2};

void eomc_dop853_tableau(const double **A, int *astride, const double **B, const double **C)
{
    *A = &D8_A[0][0]; *astride = 16; *B = D8_B; *C = D8_C;
}

/* y[i] = x[i] + h * sum_j coef[j] * K[j][i] (x NULL: y[i] = the sum), the sum over the
 * nonzero coefficients, j ascending.  Skipping zeros leaves every finite sum bit-identical
 * to the full one (DOP853's tables are about a third zeros); the j-outer order runs over
 * contiguous rows.  gcc 12 at -O2 (the runtime's flags) uses its "very cheap" vectorizer
 * cost model, which leaves a loop of unknown length scalar (objdump: no packed
 * instruction; one load and one store per term); the dynamic model for this function
 * only vectorizes it (other compilers vectorize at -O2 or ignore the attribute).  Same
 * operations per row in the same order: bit for bit as before.  C harness, n = 8 cart,
 * DOP853 10 s at 1e-8 (benchmarks/results/sensitivity_dop853.md, notes): plain 2.92 ->
 * 2.87 ms, 1 sensitivity column 4.72 -> 4.67, 4 columns (90 states) 8.0 -> 7.58.  A
 * four-row block with the sums in registers (vectorized at -O2 by SLP) gained half as
 * much at 4 columns (8.0); eight rows and a nonzero list lost (8.2). */
static inline void combine_body(int n, int nst, const double *coef, const double *restrict K,
                                const double *x, double h, double *restrict y)
{
    for (int i = 0; i < n; i++) y[i] = 0.0;
    for (int j = 0; j < nst; j++) {
        const double a = coef[j], *restrict kj = K + (size_t)j * n;
        if (a == 0.0) continue;
        for (int i = 0; i < n; i++) y[i] += a * kj[i];
    }
    if (x)
        for (int i = 0; i < n; i++) y[i] = x[i] + h * y[i];
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define EOMC_COMBINE_AVX2 1
/* The same loops built for AVX2 (four doubles an operation, no FMA: the same operations and
 * roundings, bit for bit the SSE2 build's), taken on CPUs that have it (s11).  The runtime is
 * built for baseline x86-64, so the loops above ran two doubles at a time.  n = 8 cart, DOP853
 * 10 s at 1e-8, interleaved whole runs (runtime builds alternating, core 1, load 11-12, 8 x 21
 * repeats): the plain run unchanged (3.38 against 3.40 ms), one sensitivity column (36
 * states) 1.533 -> 1.454 x plain, four 2.37 -> 2.19. */
__attribute__((target("avx2"), optimize("vect-cost-model=dynamic")))
static void combine_into_avx2(int n, int nst, const double *coef, const double *restrict K,
                              const double *x, double h, double *restrict y)
{
    combine_body(n, nst, coef, K, x, h, y);
}
#endif

#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("vect-cost-model=dynamic")))
#endif
static void combine_into(int n, int nst, const double *coef, const double *restrict K,
                         const double *x, double h, double *restrict y)
{
#ifdef EOMC_COMBINE_AVX2
    if (__builtin_cpu_supports("avx2")) {
        combine_into_avx2(n, nst, coef, K, x, h, y);
        return;
    }
#endif
    combine_body(n, nst, coef, K, x, h, y);
}

static void combine(int n, int nst, const double *coef, const double *restrict K,
                    double *restrict acc)
{
    combine_into(n, nst, coef, K, NULL, 0.0, acc);
}

/* combine's first rows only: acc[i] = sum_j coef[j] K[j ld + i] for i < rows. */
static void combine_rows(int rows, int ld, int nst, const double *coef, const double *restrict K,
                         double *restrict acc)
{
    for (int i = 0; i < rows; i++) acc[i] = 0.0;
    for (int j = 0; j < nst; j++) {
        const double a = coef[j], *restrict kj = K + (size_t)j * ld;
        if (a == 0.0) continue;
        for (int i = 0; i < rows; i++) acc[i] += a * kj[i];
    }
}

/* The adjoint's checkpoint of an accepted step from t to tn (eomc_stagger.h): its start x
 * and, when asked for, its s x n stage values K (DOP853's stage derivatives, Radau's Z).
 * Out of line: inlined, the copies grew run_erk and a sensitivity run lost ~5 % (layout). */
EOMC_NOINLINE void record_step(eomc_stagger *g, int n, double t, double tn, const double *x,
                               const double *K, int s)
{
    if (g->nrec < g->rec_cap) {
        g->rec_t[g->nrec] = t;
        g->rec_t[g->nrec + 1] = tn;
        memcpy(g->rec_x + (size_t)g->nrec * n, x, (size_t)n * sizeof(double));
        if (g->rec_k) memcpy(g->rec_k + (size_t)g->nrec * s * n, K, (size_t)s * n * sizeof(double));
    }
    g->nrec++;
}

/* One trial step: stages, y_new, K[s] = f(t+h, y_new), ys = last stage point. */
static int erk_trial(ctx *c, const erk *tb, double t, double h, const double *x,
                     double *K, double *ynew, double *ys)
{
    int n = c->n, s;
    for (int st = 1; st < tb->s; st++) {
        double *y = (st == tb->s - 1) ? ys : ynew;
        combine_into(n, st, tb->A + (size_t)st * tb->astride, K, x, h, y);
        if ((s = frhs(c, t + tb->C[st] * h, y, K + (size_t)st * n))) return s;
    }
    combine_into(n, tb->s, tb->B, K, x, h, ynew);
    if (!all_finite(n, ynew)) return EOMC_NONFINITE;
    return frhs(c, t + h, ynew, K + (size_t)tb->s * n);
}

/* The error norm over the first ne of the n states (ne < n: an augmented sensitivity model
 * whose sensitivities do not steer the steps, eomc_stagger.h). */
static double erk_error(const erk *tb, int n, int ne, double h, const double *K, const double *x,
                        const double *ynew, double rtol, double atol, double *acc5, double *acc3)
{
    double e5 = 0.0, e3 = 0.0;
    /* only the rows the norm reads: an augmented sensitivity model's S rows (n - ne of them)
     * would otherwise pay two (s + 1)-stage combinations a step for nothing */
    combine_rows(ne, n, tb->s + 1, tb->is853 ? D8_E5 : DP5_E, K, acc5);
    if (tb->is853) combine_rows(ne, n, tb->s + 1, D8_E3, K, acc3);
    n = ne;
    for (int i = 0; i < n; i++) {
        double sc = atol + rtol * fmax(fabs(x[i]), fabs(ynew[i]));
        double a5 = tb->is853 ? acc5[i] : h * acc5[i], a3 = tb->is853 ? acc3[i] : 0.0;
        e5 += (a5 / sc) * (a5 / sc);
        e3 += (a3 / sc) * (a3 / sc);
    }
    if (!tb->is853) return sqrt(e5 / n);
    if (e5 == 0.0 && e3 == 0.0) return 0.0;
    return fabs(h) * e5 / sqrt((e5 + 0.01 * e3) * n);
}

/* DOP853: the three extra stages and the 7 interpolation vectors F. */
static int d853_dense_prepare(ctx *c, double t, double h, const double *x, const double *ynew,
                              double *K, double *F, double *tmp)
{
    int n = c->n, s;
    for (int st = 13; st < 16; st++) {
        combine_into(n, st, D8_A[st], K, x, h, tmp);
        if ((s = frhs(c, t + D8_C[st] * h, tmp, K + (size_t)st * n))) return s;
    }
    for (int i = 0; i < n; i++) {
        double dy = ynew[i] - x[i], f0 = K[i], f1 = K[(size_t)12 * n + i];
        F[i] = dy;
        F[n + i] = h * f0 - dy;
        F[2 * n + i] = 2 * dy - h * (f1 + f0);
    }
    for (int r = 0; r < 4; r++) {
        double *Fr = F + (size_t)(3 + r) * n;
        combine(n, 16, D8_D[r], K, Fr);
        for (int i = 0; i < n; i++) Fr[i] *= h;
    }
    return EOMC_OK;
}

static void d853_dense(int n, double theta, const double *x, const double *F, double *out)
{
    for (int i = 0; i < n; i++) {
        double y = 0.0;
        for (int k = 0; k < 7; k++) {
            y += F[(size_t)(6 - k) * n + i];
            y *= (k % 2 == 0) ? theta : (1 - theta);
        }
        out[i] = x[i] + y;
    }
}

static void dp5_dense(int n, double h, double theta, const double *x, const double *K, double *out)
{
    for (int i = 0; i < n; i++) {
        double y = 0.0, pw = 1.0;
        for (int k = 0; k < 4; k++) {
            double q = 0.0;
            pw *= theta;
            for (int j = 0; j < 7; j++) q += K[(size_t)j * n + i] * DP5_P[j][k];
            y += q * pw;
        }
        out[i] = x[i] + h * y;
    }
}

/* Hairer's stiffness test: h*|lambda| from the last two stage points. */
static double stiff_hlambda(int n, double h, const double *ynew, const double *ys,
                            const double *fnew, const double *fs)
{
    double num = 0.0, den = 0.0;
    for (int i = 0; i < n; i++) {
        num += (fnew[i] - fs[i]) * (fnew[i] - fs[i]);
        den += (ynew[i] - ys[i]) * (ynew[i] - ys[i]);
    }
    return den > 0.0 ? fabs(h) * sqrt(num / den) : 0.0;
}

static int run_erk(ctx *c, const erk *tb, const eomc_options *o, proj *pj,
                   double t0, double t1, double *x, outw *ow, double **pos)
{
    int n = c->n, s, iasti = 0, nonsti = 0, last_bad = 0, hits, rows, restart;
    long maxs = o->max_steps > 0 ? o->max_steps : DEFAULT_MAX_STEPS;
    double *K = take(pos, 16 * (size_t)n), *F = take(pos, 7 * (size_t)n);
    double *ynew = take(pos, n), *ys = take(pos, n), *tmp = take(pos, n);
    double *acc5 = take(pos, n), *acc3 = take(pos, n), *xst = take(pos, 2 * (size_t)n);
    double hmax = o->hmax > 0 ? o->hmax : t1 - t0, h, t = t0;
    double expo = -1.0 / (tb->err_order + 1), err_old = 1e-4;
    eomc_stats *st = c->st;

    if ((s = frhs(c, t0, x, K))) return s;
    if (o->h0 > 0) h = o->h0;
    else if ((s = initial_step(c, t0, t1, x, K, tb->err_order, o->rtol, o->atol, hmax,
                               tmp, ynew, &h)))
        return s;
    while (t < t1) {
        int rejected_now = 0;
        double tn, err;
        for (;;) {                                     /* until a step is accepted */
            double hmin = min_step(t);
            h = fmin(h, hmax);
            st->t = t; st->h = h;
            if (h < hmin) return last_bad ? last_bad : EOMC_STEP_TOO_SMALL;
            if (st->steps >= maxs) return EOMC_MAX_STEPS;
            tn = t + h;
            if (tn > t1 || t1 - tn < hmin) tn = t1;
            if (c->sg && c->sg->ntstop) {          /* the adjoint's grid: end on each time */
                const eomc_stagger *g = c->sg;
                while (c->istop < g->ntstop && g->tstop[c->istop] <= t) c->istop++;
                if (c->istop < g->ntstop && (tn > g->tstop[c->istop] || g->tstop[c->istop] - tn < hmin))
                    tn = g->tstop[c->istop];
            }
            h = tn - t;
            st->steps++;
            s = erk_trial(c, tb, t, h, x, K, ynew, ys);
            if (s) {        /* non-finite or model failure: shrink up to where it starts */
                if (c->abort) return c->abort;  /* ... but a failed callback or Ctrl-C stops now */
                last_bad = s; st->rejected++; rejected_now = 1;
                h *= MIN_FACTOR;
                continue;
            }
            last_bad = 0;
            err = erk_error(tb, n, c->n_err, h, K, x, ynew, o->rtol, o->atol, acc5, acc3);
            if (err < 1.0) break;
            st->rejected++; rejected_now = 1;
            h *= fmax(MIN_FACTOR, SAFETY * pow(err, expo));
        }
        hits = 0; restart = 0;
        if (c->nsw) {
            int ncross = 0, near = 0;
            double tst[2];
            /* Interior points too (a contact's onset crossed and left again inside one step: a
             * grazing foot, a short impact): the states at 1/3 and 2/3 of the step from the
             * cubic Hermite interpolant of its ends and slopes (K[s] = f(ynew)), no rhs call. */
            for (int a = 0; a < 2; a++) {
                tst[a] = t + (a + 1) * (tn - t) / 3.0;
                hermite(n, tn - t, (a + 1) / 3.0, x, K, ynew, K + (size_t)tb->s * n, xst + (size_t)a * n);
            }
            if ((s = sw_detect(c, t, x, tn, ynew, 2, tst, xst, &ncross))) return s;
            if (c->ev->nlin)
                sw_lin_extrema(c, t, tn - t, x, K, ynew, K + (size_t)tb->s * n, NULL, o->rtol,
                               o->atol, &ncross, &near);
            if (ncross || near) {   /* a switching point inside the step: end the step there */
                double tcut;
                interp ip = {tb->is853 ? 2 : 1, n, t, tn - t, x, NULL, ynew, NULL, K, F, NULL, NULL};
                if (tb->is853 && (s = d853_dense_prepare(c, t, tn - t, x, ynew, K, F, tmp)))
                    return s;
                if (near)           /* a limit nearly reached: the dense output decides */
                    sw_lin_extrema(c, t, tn - t, x, K, ynew, K + (size_t)tb->s * n, &ip, o->rtol,
                                   o->atol, &ncross, &near);
                if (ncross) {
                    if ((s = sw_locate(c, &ip, &tcut))) return s;
                    if (tcut > t) {                 /* redo the step up to just past the crossing */
                        st->rejected++;
                        h = tcut - t;
                        c->gnew_ok = 0;
                        continue;
                    }
                    restart = !c->ev->sw_observe;
                }
            }
            sw_keep(c);
        }
        st->accepted++;
        if (c->sg && c->sg->rec_cap > 0)            /* the adjoint's checkpoint of this step */
            record_step(c->sg, n, t, tn, x, K, tb->s);
        if (c->ev && (s = events_cross(c, tn, ynew, &hits))) return s;
        rows = ow->i < ow->n && ow->t[ow->i] <= tn;
        /* one call site of the DOP853 interpolant's set-up, so it stays inlined with its
           constant tables (an out-of-line copy cost 5% of a plain run under -fwrapv) */
        if (tb->is853 && (rows || hits) && !restart
            && (s = d853_dense_prepare(c, t, tn - t, x, ynew, K, F, tmp)))
            return s;
        if (hits) {
            interp ip = {tb->is853 ? 2 : 1, n, t, tn - t, x, NULL, ynew, NULL, K, F, NULL, NULL};
            if ((s = events_in_step(c, &ip, ow, x))) return s;
            if (c->ev->terminated) return EOMC_OK;
        }
        if (rows) {
            double hh = tn - t;
            if (tb->is853) {
                EMIT_UNTIL(ow, tn, d853_dense(n, (tau - t) / hh, x, F, row));
            } else {
                EMIT_UNTIL(ow, tn, dp5_dense(n, hh, (tau - t) / hh, x, K, row));
            }
        }
        if (o->stiff_check && (st->accepted % NSTIFF == 0 || iasti > 0)) {
            double hl = stiff_hlambda(c->n_err, tn - t, ynew, ys, K + (size_t)tb->s * n,
                                      K + (size_t)(tb->s - 1) * n);
            st->stiff_hlambda = hl;
            if (hl > tb->stiff_limit) {
                nonsti = 0;
                if (++iasti == 15) {
                    memcpy(x, ynew, (size_t)n * sizeof(double));
                    st->t = tn;
                    return EOMC_STIFF;
                }
            } else if (++nonsti == 6) {
                iasti = 0;
            }
        }
        {   /* Hairer's stabilized control (dopri5.f, dop853.f): err^-(1/(q+1) - c beta)
               * err_old^beta, c = 0.75 (DOPRI5) or 0.2 (DOP853); beta = 0: classical */
            double beta = o->pi_beta, f;
            f = err == 0.0 ? MAX_FACTOR
                : fmin(MAX_FACTOR, SAFETY * pow(err, expo + tb->pi_weight * beta)
                                   * (beta > 0.0 ? pow(err_old, beta) : 1.0));
            err_old = fmax(err, 1e-4);
            if (rejected_now) f = fmin(1.0, f);
            h = (tn - t) * f;
            if (restart) {      /* the law changed form: forget the step history */
                err_old = 1e-4;
                h = fmin(h, tn - t);
            }
        }
        memcpy(K, K + (size_t)tb->s * n, (size_t)n * sizeof(double));
        if (c->nquat) { unit_quats(c, ynew, K); fix_last_row(ow, tn, ynew); }
        if (pj->on) {
            if ((s = project_state(c, pj, tn, ynew))) return s;
            fix_last_row(ow, tn, ynew);
            if ((s = frhs(c, tn, ynew, K))) return s;
        }
        if (c->ev && (s = events_commit(c, tn, ynew, pj->on))) return s;
        memcpy(x, ynew, (size_t)n * sizeof(double));
        t = tn;
    }
    st->t = t1;
    return EOMC_OK;
}

/* --------------------------------------------------------- Radau IIA (5) */
/* Three-stage Radau IIA collocation, order 5, solved by simplified Newton in
 * the eigenbasis of the coefficient matrix (one real and one complex linear
 * system per iteration), error estimate and step control of Hairer & Wanner,
 * Solving ODEs II, IV.8, as also used by scipy's Radau. */

typedef struct radau_consts {
    double C[3], E[3], mu_real;
    eomc_cplx mu_complex;
    double T[3][3], TI[3][3], P[3][3];
} radau_consts;

static void radau_consts_init(radau_consts *k)
{
    const double s6 = sqrt(6.0);
    static const double T[3][3] = {
        {0.09443876248897524, -0.14125529502095421, 0.03002919410514742},
        {0.25021312296533332, 0.20412935229379994, -0.38294211275726192},
        {1.0, 1.0, 0.0}};
    static const double TI[3][3] = {
        {4.17871859155190428, 0.32768282076106237, 0.52337644549944951},
        {-4.17871859155190428, -0.32768282076106237, 0.47662355450055044},
        {0.50287263494578682, -2.57192694985560522, 0.59603920482822492}};
    k->C[0] = (4 - s6) / 10; k->C[1] = (4 + s6) / 10; k->C[2] = 1.0;
    k->E[0] = (-13 - 7 * s6) / 3; k->E[1] = (-13 + 7 * s6) / 3; k->E[2] = -1.0 / 3;
    k->mu_real = 3 + cbrt(9.0) - cbrt(3.0);
    k->mu_complex = (3 + 0.5 * (cbrt(3.0) - cbrt(9.0)))
                    - 0.5 * I * (pow(3.0, 5.0 / 6) + pow(3.0, 7.0 / 6));
    memcpy(k->T, T, sizeof T);
    memcpy(k->TI, TI, sizeof TI);
    k->P[0][0] = 13.0 / 3 + 7 * s6 / 3; k->P[0][1] = -23.0 / 3 - 22 * s6 / 3; k->P[0][2] = 10.0 / 3 + 5 * s6;
    k->P[1][0] = 13.0 / 3 - 7 * s6 / 3; k->P[1][1] = -23.0 / 3 + 22 * s6 / 3; k->P[1][2] = 10.0 / 3 - 5 * s6;
    k->P[2][0] = 1.0 / 3; k->P[2][1] = -8.0 / 3; k->P[2][2] = 10.0 / 3;
}

/* Hairer's radau5.f constants: Newton iterations per step; theta (the Newton contraction
 * rate) at or below which the Jacobian is kept for the next step (his default is 0.001 for
 * cheap Jacobians; he advises ~0.1 when a Jacobian is costly -- ours costs 20-30 rhs calls
 * on a robot); the band of h_new/h inside which h and the LU are kept; the largest step
 * reduction (1/FACL) and growth (1/FACR). */
#define RADAU_NIT 7
#define RADAU_THET 0.1
#define RADAU_QUOT1 1.0
#define RADAU_QUOT2 1.2
#define RADAU_FACL 5.0
#define RADAU_FACR 0.125
/* Newton's stopping tolerance: radau5.f's min(0.03, sqrt(rtol')), with the cap raised to 0.1
 * (Hairer: "usually chosen < 1"), so from rtol' ~ 1e-3 up to ~0.07 at rtol = 1e-2. */
#define RADAU_FNEWT 0.1

typedef struct radau_ws {
    double *J, *LUr, *Z, *W, *F, *dW, *Q, *yold, *ynew, *fnew, *tmp, *err, *ze, *scale;
    eomc_cplx *LUc, *bc;
    int *pivr, *pivc;
    double h_lu;          /* the step the LU belongs to */
} radau_ws;

/* What the step control carries from step to step (radau5.f's faccon, theta, hacc,
 * erracc, first). */
typedef struct radau_state {
    double faccon;        /* theta/(1 - theta) of the last Newton: lets a good guess
                             converge after one iteration */
    double theta;         /* last Newton contraction rate (RADAU_THET if one iteration) */
    double h_acc, err_acc;/* last accepted step and its error (Gustafsson); h_acc <= 0: none */
    int first;            /* no step accepted yet */
    int zero_guess;       /* start Newton from the step's start, not the extrapolation */
    int refresh;          /* after an accepted step: evaluate J at the new point */
} radau_state;

static void radau_ws_init(radau_ws *w, int n, double **pos)
{
    size_t nn = (size_t)n * n;
    w->J = take(pos, nn); w->LUr = take(pos, nn);
    w->LUc = (eomc_cplx *)take(pos, 2 * nn);
    w->bc = (eomc_cplx *)take(pos, 2 * (size_t)n);
    w->Z = take(pos, 3 * (size_t)n); w->W = take(pos, 3 * (size_t)n);
    w->F = take(pos, 3 * (size_t)n); w->dW = take(pos, 3 * (size_t)n);
    w->Q = take(pos, 3 * (size_t)n);
    w->yold = take(pos, n); w->ynew = take(pos, n); w->fnew = take(pos, n);
    w->tmp = take(pos, n); w->err = take(pos, n); w->ze = take(pos, n); w->scale = take(pos, n);
    w->pivr = (int *)take(pos, n); w->pivc = (int *)take(pos, n);
    w->h_lu = 0.0;
}

static int radau_factor(ctx *c, const radau_consts *k, radau_ws *w, double h)
{
    int n = c->n;
    eomc_cplx mc = k->mu_complex / h;
    double mr = k->mu_real / h;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            double d = (i == j) ? 1.0 : 0.0;
            w->LUr[i * n + j] = mr * d - w->J[i * n + j];
            w->LUc[i * n + j] = mc * d - w->J[i * n + j];
        }
    c->st->nlu += 2;
    w->h_lu = 0.0;
    if (lu_factor(n, w->LUr, w->pivr) || lu_factor_c(n, w->LUc, w->pivc)) return 1;
    w->h_lu = h;
    return EOMC_OK;
}

/* Simplified Newton for the collocation system from the guess in Z (radau5.f): converged
 * when faccon * |dW| <= fnewt, which a good guess meets after one iteration (faccon from the
 * last step); slow convergence predicted from the rate gives *hfac < 1 (the step to retry
 * with), divergence 0.5.  Returns a model status and sets *conv, *newt. */
static int radau_newton(ctx *c, const radau_consts *k, radau_ws *w, radau_state *rs, double t,
                        double h, const double *y, double fnewt, int *conv, double *hfac, int *newt)
{
    int n = c->n, s;
    double mr = k->mu_real / h, dynold = 1.0, thqold = 1.0;
    eomc_cplx mc = k->mu_complex / h;
    *conv = 0; *hfac = 0.5; *newt = 0;
    rs->faccon = pow(fmax(rs->faccon, DBL_EPSILON), 0.8);
    rs->theta = RADAU_THET;
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            w->W[a * n + i] = k->TI[a][0] * w->Z[i] + k->TI[a][1] * w->Z[n + i]
                              + k->TI[a][2] * w->Z[2 * n + i];
    while (*newt < RADAU_NIT) {
        double dyno = 0.0;
        for (int a = 0; a < 3; a++) {
            for (int i = 0; i < n; i++) w->tmp[i] = y[i] + w->Z[a * n + i];
            s = frhs(c, t + k->C[a] * h, w->tmp, w->F + (size_t)a * n);
            if (s) return s;           /* caller shrinks the step onto the failure */
        }
        for (int i = 0; i < n; i++) {
            double f0 = w->F[i], f1 = w->F[n + i], f2 = w->F[2 * n + i];
            w->dW[i] = k->TI[0][0] * f0 + k->TI[0][1] * f1 + k->TI[0][2] * f2 - mr * w->W[i];
            w->bc[i] = (k->TI[1][0] + I * k->TI[2][0]) * f0 + (k->TI[1][1] + I * k->TI[2][1]) * f1
                       + (k->TI[1][2] + I * k->TI[2][2]) * f2
                       - ((creal(mc) * w->W[n + i] - cimag(mc) * w->W[2 * n + i])
                          + I * (creal(mc) * w->W[2 * n + i] + cimag(mc) * w->W[n + i]));
        }
        lu_solve(n, w->LUr, w->pivr, w->dW);
        lu_solve_c(n, w->LUc, w->pivc, w->bc);
        for (int i = 0; i < n; i++) {
            double a0 = w->dW[i] / w->scale[i], a1, a2;
            w->dW[n + i] = creal(w->bc[i]);
            w->dW[2 * n + i] = cimag(w->bc[i]);
            a1 = w->dW[n + i] / w->scale[i]; a2 = w->dW[2 * n + i] / w->scale[i];
            dyno += a0 * a0 + a1 * a1 + a2 * a2;
        }
        dyno = sqrt(dyno / (3.0 * n));
        ++*newt;
        if (!isfinite(dyno)) return EOMC_OK;
        if (*newt > 1 && *newt < RADAU_NIT) {
            double thq = dyno / dynold;
            rs->theta = *newt == 2 ? thq : sqrt(thq * thqold);
            thqold = thq;
            if (!(rs->theta < 0.99)) return EOMC_OK;
            rs->faccon = rs->theta / (1.0 - rs->theta);
            {   /* the iterations left would not reach fnewt: retry with a smaller step */
                double dyth = rs->faccon * dyno * pow(rs->theta, RADAU_NIT - 1 - *newt) / fnewt;
                if (dyth >= 1.0) {
                    double q = fmax(1e-4, fmin(20.0, dyth));
                    *hfac = 0.8 * pow(q, -1.0 / (4.0 + RADAU_NIT - 1 - *newt));
                    return EOMC_OK;
                }
            }
        }
        dynold = fmax(dyno, DBL_EPSILON);
        for (size_t i = 0; i < 3 * (size_t)n; i++) w->W[i] += w->dW[i];
        for (int i = 0; i < n; i++)
            for (int a = 0; a < 3; a++)
                w->Z[a * n + i] = k->T[a][0] * w->W[i] + k->T[a][1] * w->W[n + i]
                                  + k->T[a][2] * w->W[2 * n + i];
        if (rs->faccon * dyno <= fnewt) {
            *conv = 1;
            return EOMC_OK;
        }
    }
    return EOMC_OK;
}

/* y(tau) on the last accepted step: yold + Q [x, x^2, x^3]. */
static void radau_dense(int n, const double *Q, const double *yold, double x, double *out)
{
    for (int i = 0; i < n; i++)
        out[i] = yold[i] + x * (Q[i] + x * (Q[n + i] + x * Q[2 * n + i]));
}

/* One accepted Radau step from (t, y, f); returns status, sets *tn_out.  rtol, atol: the
 * tolerances as radau5.f uses them (see run_radau).  On return *h is the next step and
 * rs->refresh says whether the Jacobian is to be evaluated at the new point; *lu_ok stays
 * set only when h is kept (radau5.f: theta <= RADAU_THET and h_new/h in [QUOT1, QUOT2]). */
static int radau_step(ctx *c, const radau_consts *k, radau_ws *w, radau_state *rs,
                      const eomc_options *o, double rtol, double atol, double t, double t1,
                      const double *y, const double *f, double *h, int have_sol, double hprev,
                      double tprev, int *lu_ok, int *cur_jac, double *tn_out)
{
    int n = c->n, s, rejected = 0, conv = 0, last_bad = 0, newt = 0;
    long maxs = o->max_steps > 0 ? o->max_steps : DEFAULT_MAX_STEPS;
    double fnewt = fmax(10 * DBL_EPSILON / rtol, fmin(RADAU_FNEWT, sqrt(rtol)));
    const double cfac = SAFETY * (1 + 2 * RADAU_NIT);
    eomc_stats *st = c->st;
    for (;;) {
        double hmin = min_step(t), tn, err, fac, quot, hnew, hfac = 0.5;
        st->t = t; st->h = *h;
        if (*h < hmin) return last_bad ? last_bad : EOMC_STEP_TOO_SMALL;
        if (st->steps >= maxs) return EOMC_MAX_STEPS;
        tn = t + *h;
        if (tn > t1 || t1 - tn < hmin) tn = t1;
        *h = tn - t;
        if (*h != w->h_lu) *lu_ok = 0;
        st->steps++;
        for (int a = 0; a < 3; a++) {                /* predictor: last collocation polynomial */
            if (have_sol && !rs->zero_guess) {
                radau_dense(n, w->Q, w->yold, (t + k->C[a] * *h - tprev) / hprev, w->tmp);
                for (int i = 0; i < n; i++) w->Z[a * n + i] = w->tmp[i] - y[i];
            } else {
                memset(w->Z + (size_t)a * n, 0, (size_t)n * sizeof(double));
            }
        }
        for (int i = 0; i < n; i++) w->scale[i] = atol + fabs(y[i]) * rtol;
        if (c->abort) return c->abort;    /* a failed callback or Ctrl-C: no retry */
        s = EOMC_OK;
        if (!*lu_ok && radau_factor(c, k, w, *h)) {
            conv = 0;                      /* singular: a smaller step */
        } else {
            *lu_ok = 1;
            s = radau_newton(c, k, w, rs, t, *h, y, fnewt, &conv, &hfac, &newt);
            last_bad = s;
            if (s && c->abort) return c->abort;
            if (s) { conv = 0; hfac = 0.5; }   /* non-finite or model failure in a stage */
        }
        if (!conv) {
            /* radau5.f: a smaller step, with a fresh Jacobian unless it is fresh already.
             * A fresh Jacobian that still fails from the extrapolated guess: the guess is
             * across a kink of the law (friction's regularisation band at loose tolerances)
             * -- start from the step's start from now on. */
            st->rejected++; rejected = 1;
            *h *= hfac;
            *lu_ok = 0;
            if (!*cur_jac) {
                if ((s = fjac(c, t, y, w->J))) return s;
                *cur_jac = 1;
            } else if (have_sol && !rs->zero_guess) {
                rs->zero_guess = 1;
            }
            continue;
        }
        for (int i = 0; i < n; i++) {
            w->ynew[i] = y[i] + w->Z[2 * n + i];
            w->ze[i] = (k->E[0] * w->Z[i] + k->E[1] * w->Z[n + i] + k->E[2] * w->Z[2 * n + i]) / *h;
            w->err[i] = f[i] + w->ze[i];
        }
        lu_solve(n, w->LUr, w->pivr, w->err);
        err = err_norm(n, w->err, y, w->ynew, rtol, atol);
        if (!(err < 1) && (rejected || rs->first)) {   /* radau5.f's second estimate */
            for (int i = 0; i < n; i++) w->tmp[i] = y[i] + w->err[i];
            s = frhs(c, t, w->tmp, w->err);
            if (s && (s != EOMC_NONFINITE || c->abort)) return s;
            if (s == EOMC_OK) {
                for (int i = 0; i < n; i++) w->err[i] += w->ze[i];
                lu_solve(n, w->LUr, w->pivr, w->err);
                err = err_norm(n, w->err, y, w->ynew, rtol, atol);
            }
        }
        err = fmax(err, 1e-10);
        fac = fmin(SAFETY, cfac / (newt + 2 * RADAU_NIT));
        quot = isfinite(err) ? fmax(RADAU_FACR, fmin(RADAU_FACL, pow(err, 0.25) / fac)) : RADAU_FACL;
        hnew = *h / quot;
        if (!(err < 1)) {                            /* also catches NaN */
            st->rejected++; rejected = 1;
            *h = rs->first ? 0.1 * *h : hnew;
            *lu_ok = 0;
            if (!*cur_jac) {
                if ((s = fjac(c, t, y, w->J))) return s;
                *cur_jac = 1;
            }
            continue;
        }
        rs->first = 0;
        if (rs->h_acc > 0.0) {                       /* Gustafsson's predictive control */
            double facgus = rs->h_acc / *h * pow(err * err / rs->err_acc, 0.25) / SAFETY;
            quot = fmax(quot, fmax(RADAU_FACR, fmin(RADAU_FACL, facgus)));
            hnew = *h / quot;
        }
        rs->h_acc = *h; rs->err_acc = fmax(1e-2, err);
        if (rejected) hnew = fmin(hnew, *h);
        *tn_out = tn;
        rs->refresh = rs->theta > RADAU_THET;
        {
            double qt = hnew / *h;
            if (!(rs->theta <= RADAU_THET && qt >= RADAU_QUOT1 && qt <= RADAU_QUOT2)) {
                *h = hnew;
                *lu_ok = 0;
            }
        }
        if (rs->refresh) *lu_ok = 0;
        return EOMC_OK;
    }
}

/* The tolerances Radau's error test and Newton use: radau5.f's rtol' = 0.1 rtol^(2/3) where
 * that is tighter than rtol (rtol > 1e-3), else rtol itself.  Hairer's rule makes the
 * order-3 estimate of the order-5 method track the tolerance asked for; at loose
 * tolerances (where contact models live) it keeps the solution near the slow manifold, so
 * Newton converges through the friction's regularisation band (Solo12 at rtol 1e-2 took
 * 305k steps of 2e-6 s without it).  At tight tolerances his rule would loosen the test
 * (rtol 1e-9 -> 1e-7: 40x the error asked for on an oscillator), so it is not applied
 * there. */
static void radau_tolerances(double rtol, double atol, double *rt, double *at)
{
    *rt = fmin(rtol, 0.1 * pow(rtol, 2.0 / 3.0));
    *at = *rt * atol / rtol;
}

/* ------------------------------------------- Radau: staggered sensitivities */
/* After a step's state is accepted, S = dx/dtheta is carried over the same step by the
 * collocation equations of S' = J S + P (J, P at the stage points; eomc_stagger.h):
 *     ZS_a = h sum_b A_ab (J(Y_b) (S + ZS_b) + P(Y_b)),
 * linear in ZS, solved by the state's simplified Newton in the eigenbasis of A with the
 * step's own LU (the real and the complex one): the first iteration one jvp call per stage
 * for all k columns, the later ones one call at the middle stage (RADAU_SG_CORR_STAGE);
 * each one real and one complex solve per column (sg_solve_rc).  The accounting of CVODES's staggered direct (BDF): per
 * iteration the sensitivity residual for all columns and one solve per column with the
 * state's Newton matrix, no Jacobian or factorization of its own -- the same here, with
 * three stages.  Predictor: the last step's
 * collocation polynomial of S; the iteration stops by the state's test (its rate times the
 * scaled correction below fnewt), with its own rate estimate.  The error estimate and the
 * step control never see S: the steps are the plain run's. */

/* The sensitivities' Newton tolerance: radau5.f's original cap 0.03 (the state's test is
 * stricter at tight tolerances, 1e-4 at rtol 1e-8).  On the n = 8 cart at rtol 1e-8 it
 * takes 2.0 iterations a step, against 2.9 with the state's 1e-4, and the error of S
 * against a 1e-12 reference is the same (4.0e-8 relative, the state's own 3.4e-8); one
 * fixed iteration gave 7e-6. */
#define RADAU_SG_FNEWT 0.03

/* The iterations after the first need only J (ZS - ZSe): the residual is linear in ZS and
 * exact at ZSe, the first iteration's point (jvp at the three stages).  They take J at the
 * middle stage Y_1 for all three stages, one jvp call with 3 k directions instead of 3 calls
 * with k (lanes of four: 8-link cart, k = 4, 1.4 us against 1.9).  That changes the point
 * the iteration converges to by h A (J(Y_a) - J(Y_1)) (ZS - ZSe), O(h^2 J') times the
 * predictor's error (S against the RK4 reference the same: 1.8e-8 at k = 1, 7.5e-8 at k = 4,
 * benchmarks/results/sensitivity_radau.md).  Until s9 they took three more jvp calls, or for
 * k <= 2 a forward difference of rhs per column and stage. */
#define RADAU_SG_CORR_STAGE 1


typedef struct radau_sg {
    double *ZS, *WS, *FS, *dW, *QS, *Sold, *scale, *tmp;   /* scale: 1 / (atol + |S| rtol) */
    double *ZSe, *FSe, *F0, *f1;   /* ZS and FS at the first iteration; f(Y_a), f(Y_1) */
    double *Dc;                    /* 3 k directions [ZS_aj - ZSe_aj; 0] (the corrections) */
    eomc_cplx *bc;
    double *rr, *rq;        /* the LU diagonals' reciprocals (real; complex as re, im pairs) */
    int top, trim;          /* J's top rows are [0 I] (checked at each new J); the LU has
                               sg_top_structure's (checked at each factorization) */
    long jev_seen;          /* ... of the J with this njev count */
    long lu_seen;           /* ... of the factorization with this nlu count */
    int half;               /* q' = u (J's top rows [0 I]): the solves' order, else 0 (sg_half) */
    double *Kr, *kr, *kq, *yr; /* sg_half's Schur complements: real K, reciprocals, rhs */
    double *Bt, *acc;       /* J's bottom-right block transposed; the products B q (3 h) */
    eomc_cplx *Kc, *yc;
    int *pk, *pkc;
    double t_end;           /* the last stage's time this step: F0 + 2 n holds f(y + Z_2) there */
    int fuse;               /* f(ynew) from that jvp call: 0 not yet checked, 1 yes, -1 no */
    double faccon;          /* the sensitivities' theta / (1 - theta), as the state's */
    int have;               /* QS, Sold hold the last step's polynomial */
    double hprev, tprev;
} radau_sg;

size_t eomc_stagger_work_size(int nx, int k, int ndir)
{
    size_t kk = (size_t)(k > 0 ? k : 0), nk = (size_t)nx * kk;
    return 26 * nk + 3 * kk * (size_t)ndir + 11 * (size_t)nx + 16
           + 2 * (size_t)nx * (size_t)nx + 2 * nk + 6 * (size_t)nx;    /* sg_half's */
}

static void radau_sg_init(radau_sg *g, int n, int k, int ndir, double **pos)
{
    size_t nk = (size_t)n * k;
    g->Dc = take(pos, 3 * (size_t)k * ndir);   /* the corrections' directions: parameter parts 0 */
    memset(g->Dc, 0, 3 * (size_t)k * ndir * sizeof(double));
    g->ZS = take(pos, 3 * nk); g->WS = take(pos, 3 * nk); g->FS = take(pos, 3 * nk);
    g->dW = take(pos, 3 * nk); g->QS = take(pos, 3 * nk);
    g->Sold = take(pos, nk); g->scale = take(pos, nk); g->tmp = take(pos, nk);
    g->bc = (eomc_cplx *)take(pos, 2 * nk);
    g->ZSe = take(pos, 3 * nk); g->FSe = take(pos, 3 * nk);
    g->F0 = take(pos, 3 * (size_t)n); g->f1 = take(pos, n);   /* jvp's xdot outputs */
    g->rr = take(pos, n); g->rq = take(pos, 2 * (size_t)n); g->lu_seen = -1;
    g->top = g->trim = 0; g->jev_seen = -1;
    {
        size_t h = (size_t)n / 2;
        g->Kr = take(pos, h * h); g->Kc = (eomc_cplx *)take(pos, 2 * h * h);
        g->kr = take(pos, h); g->kq = take(pos, 2 * h);
        g->yr = take(pos, h * k); g->yc = (eomc_cplx *)take(pos, 2 * h * k);
        g->pk = (int *)take(pos, h); g->pkc = (int *)take(pos, h);
        g->Bt = take(pos, h * h); g->acc = take(pos, 3 * h);
        g->half = 0;
    }
    g->faccon = 1.0; g->have = 0; g->hprev = 1.0; g->tprev = 0.0;
    g->t_end = NAN; g->fuse = 0;
}

/* out_a = sum_b M_ab in_b for a = 0, 1, 2 (M^T with transpose), rows of len doubles at
 * in + b len and out + a len: the staggered step's changes of basis (Z <-> W by T and
 * TI, the dense output by P).  Written a-outer with the coefficients in locals: as three
 * strided stores per i, reloading M (it might alias), this was ~15 % of the step's own
 * time at four columns (perf).  Same products summed in the same order as before. */
#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("vect-cost-model=dynamic")))
#endif
static void sg_mix3(const double M[3][3], int transpose, const double *restrict in,
                    double *restrict out, size_t len)
{
    const double *i0 = in, *i1 = in + len, *i2 = in + 2 * len;
    for (int a = 0; a < 3; a++) {
        const double m0 = transpose ? M[0][a] : M[a][0], m1 = transpose ? M[1][a] : M[a][1],
                     m2 = transpose ? M[2][a] : M[a][2];
        double *restrict o = out + (size_t)a * len;
        for (size_t i = 0; i < len; i++) o[i] = m0 * i0[i] + m1 * i1[i] + m2 * i2[i];
    }
}

/* The S solves at half the order when the state is x = [q; u] with q' = u (J's top half
 * rows [0 I] exactly, as a generated jac_x gives for a plain multibody model):
 *     (mu I - J) [a; b] = [ra; rb]  <=>  (mu^2 I - mu B - A) a = rb + mu ra - B ra,
 *                                         b = mu a - ra,
 * A, B = J's bottom-left and bottom-right blocks, mu = the real or the complex eigenvalue
 * over h.  Why: the staggered step's solves were ~590 ns a real + complex pair at n = 18
 * (two pairs a step, perf, s11), latency-bound substitutions of length n; this is one
 * matrix-vector product (independent rows) and substitutions of length n / 2, with the
 * Schur complements factored once per factorization of the state's (sg_half_factor).  The
 * state's Newton keeps its own LU (the plain run bit for bit); S comes out the same
 * solution to rounding (n = 8 cart: 5e-15 relative; tests/runtime/test_sensitivity.py).
 * Only from two columns on: the complements' factorizations (every ~3 steps on the cart)
 * cost about what one column's solves save (A/B of runtime builds, 8-link cart, Radau
 * 1e-8, core 0: one column 1.517 -> 1.519 x plain, four 2.168 -> 2.103).  Any other J
 * (extra states, quaternions, a singular complement) keeps the full-order solve. */
static int sg_half_factor(const radau_ws *w, radau_sg *g, int n, double mr, eomc_cplx mc)
{
    int h = n / 2;
    if (n % 2 || h < 1) return 0;
    for (int i = 0; i < h; i++)
        for (int j = 0; j < n; j++)
            if (w->J[(size_t)i * n + j] != (j == h + i ? 1.0 : 0.0)) return 0;
    for (int i = 0; i < h; i++) {
        const double *A = w->J + (size_t)(h + i) * n, *B = A + h;
        for (int j = 0; j < h; j++) {
            double d = i == j, re = d * CMUL_RE(mc, mc) - creal(mc) * B[j] - A[j],
                   im = d * CMUL_IM(mc, mc) - cimag(mc) * B[j];
            g->Kr[(size_t)i * h + j] = d * (mr * mr) - mr * B[j] - A[j];
            g->Bt[(size_t)j * h + i] = B[j];
            g->Kc[(size_t)i * h + j] = re + I * im;
        }
    }
    if (lu_factor(h, g->Kr, g->pk) || lu_factor_c(h, g->Kc, g->pkc)) return 0;
    for (int i = 0; i < h; i++) {
        eomc_cplx q = c_recip(g->Kc[(size_t)i * h + i]);
        g->kr[i] = 1.0 / g->Kr[(size_t)i * h + i];
        g->kq[2 * i] = creal(q); g->kq[2 * i + 1] = cimag(q);
    }
    return 1;
}

/* acc = [B ra; B Re qa; B Im qa] (qa: complex as re, im pairs), B given transposed: each
 * row's sum over j in order, the rows side by side (vectors across rows on CPUs with AVX2;
 * the same sums either way, no FMA). */
static inline __attribute__((always_inline))
void sg_half_products_body(int h, const double *restrict Bt, const double *restrict ra,
                           const double *restrict qa, double *restrict acc)
{
    double *restrict s = acc, *restrict sr = acc + h, *restrict si = acc + 2 * h;
    for (int i = 0; i < 3 * h; i++) acc[i] = 0.0;
    for (int j = 0; j < h; j++) {
        const double a = ra[j], qr = qa[2 * j], qi = qa[2 * j + 1], *restrict b = Bt + (size_t)j * h;
        for (int i = 0; i < h; i++) {
            s[i] += b[i] * a;
            sr[i] += b[i] * qr;
            si[i] += b[i] * qi;
        }
    }
}

#ifdef EOMC_SG_AVX2
__attribute__((target("avx2"), optimize("vect-cost-model=dynamic")))
static void sg_half_products_avx2(int h, const double *Bt, const double *ra, const double *qa, double *acc)
{
    sg_half_products_body(h, Bt, ra, qa, acc);
}
#endif

#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("vect-cost-model=dynamic")))
#endif
static void sg_half_products(int h, const double *Bt, const double *ra, const double *qa, double *acc)
{
#ifdef EOMC_SG_AVX2
    if (__builtin_cpu_supports("avx2")) {
        sg_half_products_avx2(h, Bt, ra, qa, acc);
        return;
    }
#endif
    sg_half_products_body(h, Bt, ra, qa, acc);
}

/* B[:, c] (real) and Bc[:, c] (complex), c < k, solved in place with the state's Newton
 * matrices (mr I - J, mc I - J) through sg_half_factor's complements. */
static void sg_half_solve(radau_sg *g, int n, int k, double mr, eomc_cplx mc,
                          double *B, eomc_cplx *Bc)
{
    int h = n / 2;
    const double cr = creal(mc), ci = cimag(mc);
    for (int c = 0; c < k; c++) {       /* complex vectors as (re, im) pairs of doubles */
        const double *ra = B + (size_t)c * n, *rb = ra + h;
        const double *qa = (const double *)(Bc + (size_t)c * n), *qb = qa + 2 * h;
        double *y = g->yr + (size_t)c * h, *yc = (double *)(g->yc + (size_t)c * h);
        const double *s = g->acc, *sr = s + h, *si = sr + h;
        sg_half_products(h, g->Bt, ra, qa, g->acc);
        for (int i = 0; i < h; i++) {
            y[i] = (rb[i] + mr * ra[i]) - s[i];
            yc[2 * i] = (qb[2 * i] + (cr * qa[2 * i] - ci * qa[2 * i + 1])) - sr[i];
            yc[2 * i + 1] = (qb[2 * i + 1] + (cr * qa[2 * i + 1] + ci * qa[2 * i])) - si[i];
        }
    }
    sg_solve_rc(h, g->Kr, g->pk, g->yr, g->Kc, g->pkc, g->yc, k, g->kr, g->kq, 0);
    for (int c = 0; c < k; c++) {
        double *ra = B + (size_t)c * n, *rb = ra + h;
        double *qa = (double *)(Bc + (size_t)c * n), *qb = qa + 2 * h;
        const double *y = g->yr + (size_t)c * h, *yc = (const double *)(g->yc + (size_t)c * h);
        for (int i = 0; i < h; i++) {
            rb[i] = mr * y[i] - ra[i];
            ra[i] = y[i];
            qb[2 * i] = (cr * yc[2 * i] - ci * yc[2 * i + 1]) - qa[2 * i];
            qb[2 * i + 1] = (cr * yc[2 * i + 1] + ci * yc[2 * i]) - qa[2 * i + 1];
            qa[2 * i] = yc[2 * i];
            qa[2 * i + 1] = yc[2 * i + 1];
        }
    }
}

/* The later iterations' directions ZS_a - ZSe_a (a = 0, 1, 2; k each) into Dc. */
static void sg_corr_dirs(radau_sg *g, int n, int kc, int nd)
{
    size_t nk = (size_t)n * kc;
    for (int b = 0; b < 3; b++)
        for (int j = 0; j < kc; j++) {
            double *d = g->Dc + ((size_t)b * kc + j) * nd;
            const double *Zj = g->ZS + b * nk + (size_t)j * n, *Ze = g->ZSe + b * nk + (size_t)j * n;
            for (int i = 0; i < n; i++) d[i] = Zj[i] - Ze[i];
        }
}

/* The staggered iteration's state between its iterations (radau_sens_step, sg_more). */
typedef struct sg_iter {
    int it;                      /* this iteration's number, from 1 */
    double dynold, thqold;
} sg_iter;

/* One iteration's update from the residuals FS (all three stages in): WS, ZS and faccon;
 * returns the scaled norm of the correction (not finite: the caller stops). */
static double sg_update(const radau_consts *k, radau_ws *w, radau_sg *g, int n, int kc, double mr,
                        eomc_cplx mc, sg_iter *it)
{
    size_t nk = (size_t)n * kc;
    double dyno = 0.0, theta;
    {   /* the residual in the eigenbasis: real part dW, complex part bc (re, im pairs) */
        const double *f0 = g->FS, *f1 = f0 + nk, *f2 = f1 + nk;
        const double *W0 = g->WS, *W1 = W0 + nk, *W2 = W1 + nk;
        const double t00 = k->TI[0][0], t01 = k->TI[0][1], t02 = k->TI[0][2];
        const double t10 = k->TI[1][0], t11 = k->TI[1][1], t12 = k->TI[1][2];
        const double t20 = k->TI[2][0], t21 = k->TI[2][1], t22 = k->TI[2][2];
        const double mcr = creal(mc), mci = cimag(mc);
        double *bc = (double *)g->bc;
        for (size_t i = 0; i < nk; i++) {
            g->dW[i] = t00 * f0[i] + t01 * f1[i] + t02 * f2[i] - mr * W0[i];
            bc[2 * i] = t10 * f0[i] + t11 * f1[i] + t12 * f2[i] - (mcr * W1[i] - mci * W2[i]);
            bc[2 * i + 1] = t20 * f0[i] + t21 * f1[i] + t22 * f2[i] - (mcr * W2[i] + mci * W1[i]);
        }
    }
    if (g->half) sg_half_solve(g, n, kc, mr, mc, g->dW, g->bc);
    else sg_solve_rc(n, w->LUr, w->pivr, g->dW, w->LUc, w->pivc, g->bc, kc, g->rr, g->rq,
                     g->trim ? n / 2 : 0);
    for (int j = 0; j < kc; j++) {
        size_t o = (size_t)j * n;
        const double *d0 = g->dW + o;
        const eomc_cplx *bc = g->bc + o;
        for (int i = 0; i < n; i++) {
            double a0 = d0[i] * g->scale[o + i], a1, a2;
            g->dW[nk + o + i] = creal(bc[i]);
            g->dW[2 * nk + o + i] = cimag(bc[i]);
            a1 = creal(bc[i]) * g->scale[o + i]; a2 = cimag(bc[i]) * g->scale[o + i];
            dyno += a0 * a0 + a1 * a1 + a2 * a2;
        }
    }
    dyno = sqrt(dyno / (3.0 * (double)nk));
    if (!isfinite(dyno)) return dyno;
    if (it->it > 1) {
        double thq = dyno / it->dynold;
        theta = it->it == 2 ? thq : sqrt(thq * it->thqold);
        it->thqold = thq;
        g->faccon = theta < 0.99 ? theta / (1.0 - theta) : 1.0;
    }
    it->dynold = fmax(dyno, DBL_EPSILON);
    for (size_t i = 0; i < 3 * nk; i++) g->WS[i] += g->dW[i];
    sg_mix3(k->T, 0, g->WS, g->ZS, nk);
    return dyno;
}

/* The first iteration's middle-stage call with the model's jvp_more: inside it, once that
 * stage's FS is out, the callback finishes the first iteration (its update and convergence
 * test) and, unless it converged, hands back the second iteration's 3 k directions, which the
 * same call carries with the primal it has already computed (no second primal at Y_1).  The
 * same operations as the separate calls: S, x and the counts are the same, bit for bit. */
typedef struct sg_more_ctx {
    ctx *c; const radau_consts *k; radau_ws *w; radau_sg *g; sg_iter *it;
    double mr, fnewt; eomc_cplx mc;
    int status, conv, corr;
} sg_more_ctx;

static int sg_more(void *u, const double **dirs, double **out)
{
    sg_more_ctx *m = (sg_more_ctx *)u;
    radau_sg *g = m->g;
    eomc_stagger *sg = m->c->sg;
    int n = m->c->n, kc = sg->k, nd = sg->ndir, a = RADAU_SG_CORR_STAGE;
    size_t nk = (size_t)n * kc;
    double dyno;
    if (!all_finite((int)nk, g->FS + (size_t)a * nk)) return 0;    /* the caller's test says so */
    memcpy(g->ZSe + a * nk, g->ZS + a * nk, nk * sizeof(double));
    memcpy(g->FSe + a * nk, g->FS + a * nk, nk * sizeof(double));
    sg->niter++;
    dyno = sg_update(m->k, m->w, g, n, kc, m->mr, m->mc, m->it);
    if (!isfinite(dyno)) { m->status = EOMC_NONFINITE; return 0; }
    if (g->faccon * dyno <= m->fnewt) { m->conv = 1; return 0; }
    sg_corr_dirs(g, n, kc, nd);
    sg->njvp++;
    m->corr = 1;
    *dirs = g->Dc; *out = g->FS;
    return 3 * kc;
}

static int radau_sens_step(ctx *c, const radau_consts *k, radau_ws *w, radau_sg *g, double t,
                           double h, const double *y, double rtol, double atol, double fnewt)
{
    eomc_stagger *sg = c->sg;
    int n = c->n, kc = sg->k, nd = sg->ndir, s, conv = 0;
    size_t nk = (size_t)n * kc;
    double *S = sg->S, mr = k->mu_real / h;
    eomc_cplx mc = k->mu_complex / h;
    sg_iter si = {1, 1.0, 1.0};
    int have_corr = 0;
    static const int MORE_ORDER[3] = {0, 2, 1};
    if (w->h_lu != h && radau_factor(c, k, w, h)) return EOMC_SINGULAR_MASS_MATRIX;
    if (g->lu_seen != c->st->nlu) {   /* the back sweeps' reciprocals, once per factorization */
        for (int i = 0; i < n; i++) {
            eomc_cplx q = c_recip(w->LUc[(size_t)i * n + i]);
            g->rr[i] = 1.0 / w->LUr[(size_t)i * n + i];
            g->rq[2 * i] = creal(q); g->rq[2 * i + 1] = cimag(q);
        }
        g->half = kc >= 2 && sg_half_factor(w, g, n, mr, mc);
        if (g->jev_seen != c->st->njev) {
            g->top = !sg->full_solves && sg_top_identity(w->J, n);
            g->jev_seen = c->st->njev;
        }
        g->trim = !g->half && sg_top_structure(g->top, n, w->pivr, w->pivc);
        sg->ntrim += g->trim;
        g->lu_seen = c->st->nlu;
    }
    for (int a = 0; a < 3; a++) {                    /* predictor */
        double *Za = g->ZS + (size_t)a * nk;
        if (g->have) {
            radau_dense((int)nk, g->QS, g->Sold, (t + k->C[a] * h - g->tprev) / g->hprev, Za);
            for (size_t i = 0; i < nk; i++) Za[i] -= S[i];
        } else {
            memset(Za, 0, nk * sizeof(double));
        }
    }
    for (size_t i = 0; i < nk; i++) g->scale[i] = 1.0 / (atol + fabs(S[i]) * rtol);   /* reciprocal */
    sg_mix3(k->TI, 0, g->ZS, g->WS, nk);
    g->faccon = pow(fmax(g->faccon, DBL_EPSILON), 0.8);
    for (si.it = 1; si.it <= EOMC_SG_MAXIT; si.it++) {
        double dyno;
        int more = si.it == 1 && sg->jvp_more != NULL;   /* the middle stage last, then sg_more */
        if (si.it > 1 && have_corr) {
            have_corr = 0;              /* the correction came with the first iteration's call */
        } else {
            for (int ai = 0; ai < 3; ai++) {         /* FS_a = J(Y_a) (S + ZS_a) + P(Y_a) */
                int a = more ? MORE_ORDER[ai] : ai;
                double ta = t + k->C[a] * h;
                for (int i = 0; i < n; i++) w->tmp[i] = y[i] + w->Z[a * n + i];
                if (aborted(c)) return c->abort;
                grid_inputs_at(c, ta);
                if (si.it > 1) {        /* FS_a = FSe_a + J(Y_1) (ZS_a - ZSe_a), one call */
                    if (a != RADAU_SG_CORR_STAGE) continue;
                    sg_corr_dirs(g, n, kc, nd);
                    sg->njvp++;
                    s = sg->jvp(ta, w->tmp, c->p, c->r, 3 * kc, g->Dc, g->f1, g->FS, c->mwork);
#if defined(__GNUC__) && defined(__x86_64__)
                    if (__builtin_cpu_supports("avx")) __asm__ volatile("vzeroupper");   /* see eomc_sensitivity.c */
#endif
                    if (s == EOMC_OK && !all_finite((int)(3 * nk), g->FS)) s = EOMC_NONFINITE;
                    if (s) { c->st->t_fail = ta; return s; }
                    for (size_t i = 0; i < 3 * nk; i++) g->FS[i] += g->FSe[i];
                    continue;
                }
                for (int j = 0; j < kc; j++) {          /* jvp's directions [S_j + ZS_aj; e_p] */
                    double *d = sg->D + (size_t)j * nd;
                    const double *Sj = S + (size_t)j * n, *Zj = g->ZS + a * nk + (size_t)j * n;
                    for (int i = 0; i < n; i++) d[i] = Sj[i] + Zj[i];
                }
                sg->njvp++;
                if (more && a == RADAU_SG_CORR_STAGE) {
                    sg_more_ctx mo = {c, k, w, g, &si, mr, fnewt, mc, 0, 0, 0};
                    s = sg->jvp_more(ta, w->tmp, c->p, c->r, kc, sg->D, g->F0 + (size_t)a * n,
                                     g->FS + (size_t)a * nk, c->mwork, sg_more, &mo);
#if defined(__GNUC__) && defined(__x86_64__)
                    if (__builtin_cpu_supports("avx")) __asm__ volatile("vzeroupper");   /* see eomc_sensitivity.c */
#endif
                    if (mo.status) { c->st->t_fail = t; return mo.status; }
                    if (s == EOMC_OK && (mo.corr ? !all_finite((int)(3 * nk), g->FS)
                                                 : !all_finite((int)nk, g->FS + (size_t)a * nk)))
                        s = EOMC_NONFINITE;
                    if (s) { c->st->t_fail = ta; return s; }
                    grid_inputs_at(c, t + k->C[2] * h);   /* where the separate calls leave them */
                    if (mo.conv) conv = 1;
                    else for (size_t i = 0; i < 3 * nk; i++) g->FS[i] += g->FSe[i];
                    have_corr = !mo.conv;
                    break;
                }
                s = sg->jvp(ta, w->tmp, c->p, c->r, kc, sg->D, g->F0 + (size_t)a * n, g->FS + (size_t)a * nk, c->mwork);
#if defined(__GNUC__) && defined(__x86_64__)
                if (__builtin_cpu_supports("avx")) __asm__ volatile("vzeroupper");   /* see eomc_sensitivity.c */
#endif
                if (s == EOMC_OK && !all_finite((int)nk, g->FS + (size_t)a * nk)) s = EOMC_NONFINITE;
                if (s) { c->st->t_fail = ta; return s; }
                memcpy(g->ZSe + a * nk, g->ZS + a * nk, nk * sizeof(double));
                memcpy(g->FSe + a * nk, g->FS + a * nk, nk * sizeof(double));
                if (a == 2) g->t_end = ta;
            }
            if (conv) break;
            if (have_corr) continue;    /* sg_more did the first iteration's update */
        }
        sg->niter++;
        dyno = sg_update(k, w, g, n, kc, mr, mc, &si);
        if (!isfinite(dyno)) { c->st->t_fail = t; return EOMC_NONFINITE; }
        if (g->faccon * dyno <= fnewt) { conv = 1; break; }
    }
    if (!conv) sg->nslow++;
    sg_mix3(k->P, 1, g->ZS, g->QS, nk);               /* QS = ZS^T P: S's dense output */
    memcpy(g->Sold, S, nk * sizeof(double));
    for (size_t i = 0; i < nk; i++) S[i] += g->ZS[2 * nk + i];
    g->have = 1; g->hprev = h; g->tprev = t;
    return EOMC_OK;
}

/* f(ynew) at the end of an accepted step, for the next step's error estimate.  With
 * staggered sensitivities the first iteration's jvp call at the last stage (c = 1: the point
 * y + Z_2, bit for bit ynew) has just returned it as its xdot, so it is taken from there
 * instead of one more rhs call (n = 8 cart: one model primal of ~8 a step).  Only when that
 * call's time is tn itself (t + 1.0 h may round off tn: an input table would then differ
 * in the last bit), and only after the first step has checked that the jvp's xdot equals
 * rhs bit for bit (the generated jvp computes its primal as rhs does; a model where it did
 * not would keep the rhs call, so the state stays the plain run's).  Counted in nfev, as the
 * rhs call it replaces: the statistics stay the plain run's too. */
static int radau_fnew(ctx *c, radau_sg *g, double tn, const double *ynew, double *fnew)
{
    int n = c->n, s;
    const double *fj = g->F0 + 2 * (size_t)n;
    if (!c->sg || c->sg->k <= 0 || g->fuse < 0 || g->t_end != tn || c->stab > 0.0 || c->fb)
        return frhs(c, tn, ynew, fnew);
    if (g->fuse == 0) {
        if ((s = frhs(c, tn, ynew, fnew))) return s;
        g->fuse = memcmp(fnew, fj, (size_t)n * sizeof(double)) == 0 ? 1 : -1;
        return EOMC_OK;
    }
    c->st->nfev++;
    memcpy(fnew, fj, (size_t)n * sizeof(double));
    return EOMC_OK;
}

static int run_radau(ctx *c, const eomc_options *o, proj *pj, double t0, double t1,
                     double *x, outw *ow, double **pos)
{
    int n = c->n, s, have_sol = 0, lu_ok = 0, cur_jac = 1, restart = 0;
    double *f = take(pos, n), hmax = o->hmax > 0 ? o->hmax : t1 - t0, h, t = t0;
    double hprev = 1.0, tprev = t0, rtol, atol;
    radau_consts k;
    radau_ws w;
    radau_state rs = {1.0, RADAU_THET, -1.0, 1.0, 1, 0, 0};
    radau_sg g = {0};   /* set by radau_sg_init when sensitivities ride along */
    radau_consts_init(&k);
    radau_ws_init(&w, n, pos);
    radau_tolerances(o->rtol, o->atol, &rtol, &atol);
    if (c->sg && c->sg->k > 0) radau_sg_init(&g, n, c->sg->k, c->sg->ndir, pos);
    if ((s = frhs(c, t0, x, f))) return s;
    if ((s = fjac(c, t0, x, w.J))) return s;
    if (o->h0 > 0) h = o->h0;
    else if ((s = initial_step(c, t0, t1, x, f, 3, o->rtol, o->atol, hmax, w.tmp, w.fnew, &h)))
        return s;
    while (t < t1) {
        double tn = t, hused, tend = t1;
        if (h > hmax) { h = hmax; rs.h_acc = -1.0; }
        if (c->sg && c->sg->ntstop) {              /* the adjoint's grid: end on each time */
            const eomc_stagger *g = c->sg;
            while (c->istop < g->ntstop && g->tstop[c->istop] <= t) c->istop++;
            if (c->istop < g->ntstop && g->tstop[c->istop] < t1) tend = g->tstop[c->istop];
        }
        if ((s = radau_step(c, &k, &w, &rs, o, rtol, atol, t, tend, x, f, &h, have_sol, hprev,
                            tprev, &lu_ok, &cur_jac, &tn)))
            return s;
        hused = tn - t;
        for (int i = 0; i < n; i++)                  /* Q = Z^T P */
            for (int a = 0; a < 3; a++)
                w.Q[a * n + i] = w.Z[i] * k.P[0][a] + w.Z[n + i] * k.P[1][a] + w.Z[2 * n + i] * k.P[2][a];
        memcpy(w.yold, x, (size_t)n * sizeof(double));
        restart = 0;
        if (c->nsw) {
            int ncross = 0;
            double tst[2];
            for (int a = 0; a < 2; a++) {            /* the interior collocation points */
                tst[a] = t + k.C[a] * hused;
                for (int i = 0; i < n; i++) w.W[a * n + i] = x[i] + w.Z[a * n + i];
            }
            if ((s = sw_detect(c, t, x, tn, w.ynew, 2, tst, w.W, &ncross))) return s;
            if (ncross) {
                double tcut;
                interp ip = {3, n, t, hused, w.yold, NULL, w.ynew, NULL, NULL, NULL, w.Q, NULL};
                if ((s = sw_locate(c, &ip, &tcut))) return s;
                if (tcut > t) {     /* redo up to just past the crossing; guess from this step */
                    c->st->rejected++;
                    h = tcut - t;
                    lu_ok = 0; have_sol = 1; hprev = hused; tprev = t;
                    rs.zero_guess = 0;
                    c->gnew_ok = 0;
                    continue;
                }
                restart = !c->ev->sw_observe;
            }
            sw_keep(c);
        }
        c->st->accepted++;
        if (c->sg && c->sg->rec_cap > 0)            /* the adjoint's checkpoint: start, Z */
            record_step(c->sg, n, t, tn, x, w.Z, 3);
        if (c->sg && c->sg->k > 0 && (s = radau_sens_step(c, &k, &w, &g, t, hused, x, rtol, atol,
                                          fmax(RADAU_SG_FNEWT, fmin(RADAU_FNEWT, sqrt(rtol))))))
            { c->st->t = t; return s; }
        if ((s = radau_fnew(c, &g, tn, w.ynew, w.fnew))) { c->st->t = t; return s; }
        if (c->ev) {
            int hits = 0;
            if ((s = events_cross(c, tn, w.ynew, &hits))) return s;
            if (hits) {
                interp ip = {3, n, t, hused, w.yold, NULL, w.ynew, NULL, NULL, NULL, w.Q, NULL};
                if ((s = events_in_step(c, &ip, ow, x))) return s;
                if (c->ev->terminated) return EOMC_OK;
            }
        }
        if (c->sg && c->sg->k > 0) {   /* S's rows at the same times, from its own polynomial */
            int i0 = ow->i, nk = n * c->sg->k;
            EMIT_UNTIL(ow, tn, radau_dense(n, w.Q, w.yold, (tau - t) / hused, row));
            for (int i = i0; i < ow->i; i++)
                radau_dense(nk, g.QS, g.Sold, (ow->t[i] - t) / hused, c->sg->S_out + (size_t)i * (c->sg->ld_out > 0 ? (size_t)ow->ld : (size_t)nk));
        } else {
            EMIT_UNTIL(ow, tn, radau_dense(n, w.Q, w.yold, (tau - t) / hused, row));
        }
        if (c->nquat) { unit_quats(c, w.ynew, w.fnew); fix_last_row(ow, tn, w.ynew); }
        if (pj->on) {
            if ((s = project_state(c, pj, tn, w.ynew))) return s;
            fix_last_row(ow, tn, w.ynew);
            if ((s = frhs(c, tn, w.ynew, w.fnew))) return s;
        }
        if (c->ev && (s = events_commit(c, tn, w.ynew, pj->on))) return s;
        if (rs.refresh || restart) {
            if ((s = fjac(c, tn, w.ynew, w.J))) { c->st->t = t; return s; }
            cur_jac = 1; lu_ok = 0;
        } else {
            cur_jac = 0;
        }
        have_sol = 1; hprev = hused; tprev = t;
        if (restart) {      /* the law changed form: no extrapolated guess, no step history */
            have_sol = 0; lu_ok = 0; rs.h_acc = -1.0; rs.faccon = 1.0; rs.zero_guess = 0;
            h = fmin(h, hused);
        }
        memcpy(x, w.ynew, (size_t)n * sizeof(double));
        memcpy(f, w.fnew, (size_t)n * sizeof(double));
        t = tn;
    }
    c->st->t = t1;
    return EOMC_OK;
}


/* ------------------------------------------------------- BDF (eomc_bdf.c) */
/* The method is in eomc_bdf.c; this driver does what every method shares around its
 * steps, as run_radau does: switching points (a trial step over which a contact or limit
 * changes side is redone to end just past the crossing, and the method restarts there at
 * order 1 with a fresh Jacobian), events, output rows, unit quaternions, projection. */

/* BDF passes over switching points: a trial step over which a contact or limit changes side is
 * kept when its error test passes, the sides flip at its end (sw_flip) and the method goes on
 * with its order, history and Jacobian -- no crossing located, no step cut to end at it, no
 * restart at order 1.  Radau and the explicit methods still end their steps there.  Why: the
 * laws here are continuous through their switching points (Hunt-Crossley's force grows from
 * zero as depth^1.5, a limit's spring from zero), so the solution is smooth enough there for
 * BDF's own error test to size the steps (it rejects and shrinks a step that a kink spoils),
 * and the locate-cut-restart sequence was most of the ant's cost through its touch-downs:
 * chains of cuts down to 1e-9 s, 20 order-1 restarts a run, each with a fresh Jacobian and
 * LU and a dozen steps to grow back (LSODA, which restarts nowhere, took 123 steps to eomc's
 * 178 at equal error).  Measured (benchmarks/results/contact_wp.md, s13 notes): at equal error
 * the ant 1.07-1.19x faster, Solo12 1.10-1.11x, the hopper within its noise; the bouncing
 * sphere's property grid (bench_bounce_grid.py, BDF at rtol 1e-3 .. 1e-8) stays right or
 * loud.  The functions are still evaluated at the step's end, and at two interior points
 * when some function could cross and come back within the step (sw_reach), for the verdict
 * (deepest penetration, limit excursion) and the flips.  Skipping the interior points
 * elsewhere saved the ant 4-10 % (s13, contact_wp.md notes). */

/* The tolerances BDF's error test uses: a tenth of those asked for.  A multistep method's
 * global error runs well above the local tolerance it holds each step to (variable steps and
 * orders; it restarted at order 1 at every contact switch then): the bouncing ball at rtol 1e-6 gained 300 rtol
 * of its energy with the plain rule -- past the verdict's 100 rtol -- and 30 rtol with
 * this one; Radau (order 5) stays below 1 rtol. */
#define BDF_TOL_SHARE 0.1

static int bdf_rhs(void *u, double t, const double *x, double *f) { return frhs((ctx *)u, t, x, f); }
static int bdf_jac(void *u, double t, const double *x, double *J) { return fjac((ctx *)u, t, x, J); }
static int bdf_aborted(void *u) { return aborted((ctx *)u); }

static int run_bdf(ctx *c, const eomc_options *o, proj *pj, double t0, double t1,
                   double *x, outw *ow, double **pos)
{
    int n = c->n, s;
    double *f = take(pos, n), *xs = take(pos, 2 * (size_t)n), *tmp = take(pos, n);
    double *f1 = take(pos, n), hmax = o->hmax > 0 ? o->hmax : t1 - t0, h;
    eomc_bdf_fns fns = {c, bdf_rhs, bdf_jac, bdf_aborted};
    eomc_bdf b;
    eomc_bdf_init(&b, &fns, c->st, n, BDF_TOL_SHARE * o->rtol, BDF_TOL_SHARE * o->atol, hmax,
                  o->max_steps, take(pos, eomc_bdf_work_size(n)));
    if (2 * c->m->nq <= n) b.nsplit = c->m->nq;    /* x = (q, v, ...): factor_lu's split */
    if ((s = frhs(c, t0, x, f))) return s;
    if (o->h0 > 0) h = fmin(o->h0, hmax);
    else if ((s = initial_step(c, t0, t1, x, f, 1, b.rtol, b.atol, hmax, tmp, f1, &h)))
        return s;
    if ((s = eomc_bdf_start(&b, t0, x, f, h))) return s;
    while (b.t < t1) {
        double t = b.t, tn;
        interp ip = {4, n, t, 0.0, x, NULL, NULL, NULL, NULL, NULL, NULL, &b};
        if ((s = eomc_bdf_trial(&b, t1))) return s;
        tn = b.tn;
        ip.h = tn - t; ip.x1 = b.ynew;
        if (c->nsw) {
            int ncross = 0;
            double tst[2];
            if ((s = sw_detect(c, t, x, tn, b.ynew, 0, NULL, NULL, &ncross))) return s;
            if (sw_reach(c, tn - t)) {
                for (int a = 0; a < 2; a++) {        /* interior points, on the polynomial */
                    tst[a] = t + (a + 1) * (tn - t) / 3.0;
                    eomc_bdf_dense(&b, tst[a], xs + (size_t)a * n);
                }
                if ((s = sw_interior(c, 2, tst, xs, &ncross))) return s;
            }
            sw_keep(c);
            sw_step_kept(c, tn - t);
            if (ncross) {         /* passed over (see above): the sides flip here */
                sw_flip(c);
                c->st->nswitch++;
            }
        }
        c->st->accepted++;
        if (c->ev) {
            int hits = 0;
            if ((s = events_cross(c, tn, b.ynew, &hits))) return s;
            if (hits) {
                if ((s = events_in_step(c, &ip, ow, x))) return s;
                if (c->ev->terminated) return EOMC_OK;
            }
        }
        EMIT_UNTIL(ow, tn, eomc_bdf_dense(&b, tau, row));
        memcpy(x, b.ynew, (size_t)n * sizeof(double));
        eomc_bdf_commit(&b);
        if (c->nquat) { unit_quats(c, x, NULL); fix_last_row(ow, tn, x); }
        if (pj->on) {
            if ((s = project_state(c, pj, tn, x))) return s;
            fix_last_row(ow, tn, x);
        }
        if (c->nquat || pj->on) eomc_bdf_set_state(&b, x);
        if (c->ev && (s = events_commit(c, tn, x, pj->on))) return s;
    }
    c->st->t = t1;
    return EOMC_OK;
}

/* ------------------------------------------------------------------ events */

static void interp_eval(const interp *ip, double tau, double *out)
{
    double th = (tau - ip->t) / ip->h;
    switch (ip->kind) {
    case 0: hermite(ip->n, ip->h, th, ip->x0, ip->f0, ip->x1, ip->f1, out); break;
    case 1: dp5_dense(ip->n, ip->h, th, ip->x0, ip->K, out); break;
    case 2: d853_dense(ip->n, th, ip->x0, ip->F, out); break;
    case 4: eomc_bdf_dense(ip->bdf, tau, out); break;
    default: radau_dense(ip->n, ip->Q, ip->x0, th, out); break;
    }
}

size_t eomc_events_scratch_size(const eomc_model *m, int ncol, int n)
{
    size_t nc = ncol > 0 ? (size_t)ncol : 0, ne = n > 0 ? (size_t)n : 0;
    return 3 * nc + 2 * (size_t)m->nx + 3 * ne + 8;
}

/* The events' scratch: g at the step's start and end, g and x at a trial
 * time, the state at a root, and per event: root time, hit flag, count. */
typedef struct evparts {
    double *gold, *gnew, *gtmp, *xtmp, *xroot, *troot, *hit, *count;
} evparts;

static evparts ev_parts(const ctx *c)
{
    const eomc_events *ev = c->ev;
    size_t nc = (size_t)ev->ncol, nx = (size_t)c->n, ne = (size_t)ev->n;
    evparts e;
    e.gold = ev->scratch; e.gnew = e.gold + nc; e.gtmp = e.gnew + nc;
    e.xtmp = e.gtmp + nc; e.xroot = e.xtmp + nx;
    e.troot = e.xroot + nx; e.hit = e.troot + ne; e.count = e.hit + ne;
    return e;
}

static int events_eval(ctx *c, double t, const double *x, double *g)
{
    int s = inputs_at(c, t, x);
    if (s == EOMC_OK) s = c->ev->fn(t, x, c->p, c->r, g, c->mwork);
    if (s == EOMC_OK && !all_finite(c->ev->ncol, g)) s = EOMC_NONFINITE;
    if (s != EOMC_OK) c->st->t_fail = t;
    return s;
}

/* g on the step's end; *hits = how many events change sign as they should. */
static int events_cross(ctx *c, double tn, const double *xn, int *hits)
{
    const eomc_events *ev = c->ev;
    evparts e = ev_parts(c);
    int s;
    *hits = 0;
    if (ev->n == 0) return EOMC_OK;
    if (!c->gnew_ok && (s = events_eval(c, tn, xn, e.gnew))) return s;
    c->gnew_ok = 0;
    for (int k = 0; k < ev->n; k++) {
        double a = e.gold[ev->col[k]], b = e.gnew[ev->col[k]];
        int dir = ev->direction ? ev->direction[k] : 0;
        int up = a < 0.0 && b >= 0.0, down = a > 0.0 && b <= 0.0;
        int hit = ((up && dir >= 0) || (down && dir <= 0))
                  && !(ev->switching && ev->switching[k] == 2);     /* 2: switching only */
        e.hit[k] = hit;
        *hits += hit;
    }
    return EOMC_OK;
}

/* g_k along the dense output at tau. */
static int event_at(ctx *c, const interp *ip, int k, double tau, double *val)
{
    evparts e = ev_parts(c);
    const eomc_events *ev = c->ev;
    int s;
    interp_eval(ip, tau, e.xtmp);
    if (k >= ev->n) {           /* a linear switching function: no model call */
        int j = k - ev->n;
        *val = ev->lin_s[j] * (e.xtmp[ev->lin_x[j]] - c->p[ev->lin_p[j]]);
        return EOMC_OK;
    }
    if ((s = events_eval(c, tau, e.xtmp, e.gtmp))) return s;
    *val = e.gtmp[ev->col[k]];
    return EOMC_OK;
}

/* Brent's method (zeroin) for g_k on [a, b] with g_k(a) g_k(b) <= 0, to a few
 * ulps of t; returns the end of the final bracket on b's side of the root,
 * so the state there has already crossed (a restart does not see it again). */
static int event_root(ctx *c, const interp *ip, int k, double a, double b, double fa,
                      double fb, double *root)
{
    double cc = b, fc = fb, d = b - a, e = d, fend = fb;
    int s;
    if (fb == 0.0) { *root = b; return EOMC_OK; }
    for (int it = 0; it < 200; it++) {
        double tol1, xm;
        if ((fb > 0 && fc > 0) || (fb < 0 && fc < 0)) { cc = a; fc = fa; d = e = b - a; }
        if (fabs(fc) < fabs(fb)) { a = b; b = cc; cc = a; fa = fb; fb = fc; fc = fa; }
        tol1 = 2.0 * DBL_EPSILON * fabs(b) + 1e-300;
        xm = 0.5 * (cc - b);
        if (fb == 0.0) { *root = b; return EOMC_OK; }
        if (fabs(xm) <= tol1) break;
        if (fabs(e) >= tol1 && fabs(fa) > fabs(fb)) {
            double p, q, r, sr = fb / fa, min1, min2;
            if (a == cc) { p = 2.0 * xm * sr; q = 1.0 - sr; }
            else {
                q = fa / fc; r = fb / fc;
                p = sr * (2.0 * xm * q * (q - r) - (b - a) * (r - 1.0));
                q = (q - 1.0) * (r - 1.0) * (sr - 1.0);
            }
            if (p > 0) q = -q;
            p = fabs(p);
            min1 = 3.0 * xm * q - fabs(tol1 * q); min2 = fabs(e * q);
            if (2.0 * p < (min1 < min2 ? min1 : min2)) { e = d; d = p / q; }
            else { d = xm; e = d; }
        } else {
            d = xm; e = d;
        }
        a = b; fa = fb;
        b += fabs(d) > tol1 ? d : copysign(tol1, xm);
        if ((s = event_at(c, ip, k, b, &fb))) return s;
    }
    /* b and cc bracket the root: take the one with the sign of the step's end */
    *root = ((fb > 0) == (fend > 0) || fb == 0.0) ? b : cc;
    return EOMC_OK;
}

/* Roots of the events that fired in this step, recorded in time order; a
 * terminal one stops the run at its time (c->ev_t, c->ev_x). */
static int events_locate(ctx *c, const interp *ip)
{
    eomc_events *ev = c->ev;
    evparts e = ev_parts(c);
    int s, nx = c->n;
    for (int k = 0; k < ev->n; k++)
        if (e.hit[k] != 0.0) {
            int col = ev->col[k];
            if ((s = event_root(c, ip, k, ip->t, ip->t + ip->h, e.gold[col], e.gnew[col],
                                e.troot + k)))
                return s;
        }
    for (;;) {
        int best = -1;
        for (int k = 0; k < ev->n; k++)
            if (e.hit[k] != 0.0 && (best < 0 || e.troot[k] < e.troot[best])) best = k;
        if (best < 0) break;
        e.hit[best] = 0.0;
        interp_eval(ip, e.troot[best], e.xroot);
        if (ev->n_rec < ev->capacity) {
            if (ev->t_rec) ev->t_rec[ev->n_rec] = e.troot[best];
            if (ev->id_rec) ev->id_rec[ev->n_rec] = best;
            if (ev->x_rec) memcpy(ev->x_rec + (size_t)ev->n_rec * nx, e.xroot, (size_t)nx * sizeof(double));
        }
        ev->n_rec++;
        e.count[best] += 1.0;
        if (ev->terminal && ev->terminal[best] > 0 && e.count[best] >= ev->terminal[best]) {
            ev->terminated = 1;
            c->ev_t = e.troot[best];
            c->ev_x = e.xroot;
            return EOMC_OK;
        }
    }
    return EOMC_OK;
}

/* After a step where events fired: locate and record them; at a terminal one write the
 * output rows up to it, leave its state in x and its time in stats->t. */
EOMC_NOINLINE int events_in_step(ctx *c, const interp *ip, struct outw *ow, double *x)
{
    int s = events_locate(c, ip);
    if (s || !c->ev->terminated) return s;
    EMIT_UNTIL(ow, c->ev_t, interp_eval(ip, tau, row));
    memcpy(x, c->ev_x, (size_t)c->n * sizeof(double));
    c->st->t = c->ev_t;
    return EOMC_OK;
}

/* ------------------------------------------------------ switching functions */

/* A step must end where a switching function crosses zero: the law changes form there
 * (a contact's force starts or stops, a limit's spring engages), so a step straddling the
 * point integrates a right-hand side that is not smooth and its error estimate does not
 * see it -- Radau accepted steps over a whole stiff impact and gained energy (issue 29).
 * A step whose switching function changed sign is redone to end just past the first
 * crossing (SW_FRAC of the step beyond it); a step whose first crossing lies within its
 * last SW_FRAC is accepted and the method restarts there. */
#define SW_FRAC 0.01
#define SW_MAX_CUTS 12
/* A switching function leaves its side only by more than its rounding noise, c->sw_noise =
 * SW_NOISE eps (1 + max |q| at the start): a value computed through the kinematics carries
 * rounding of the order of eps times the coordinates it is computed from, and its sign
 * within that band is noise.  Solo12 standing (examples/quadruped_stand.py) starts with its
 * feet at depth ~1e-17 m: the depths' signs flipped with rounding from step to step, and
 * every flip was located, cut at and restarted from (order 1, a fresh Jacobian, the step
 * cut to ~1e-15 s): 84-251 steps and 43-161 LUs before t = 1e-9 s on 5 of the 8 starts of
 * bench_contact_wp.py (3-8 ms, half of a 1 s run at rtol 1e-3).  A foot that really
 * touches down passes the band within a step and is located at its zero as before. */
#define SW_NOISE 256.0

size_t eomc_switch_scratch_size(int n, int nlin)
{
    return 8 * (size_t)((n > 0 ? n : 0) + (nlin > 0 ? nlin : 0)) + 8;
}

/* Per switching function: its side (1 on, 0 off), the value at the step's start, the
 * bracket end (then root) time and value where it first differs from its side, the value
 * at the step's end, whether it crossed, the largest value seen over the step, and (BDF,
 * sw_reach) the value at the last kept step's start. */
typedef struct swparts {
    double *side, *ga, *tb, *gb, *ge, *cross, *seen, *gp;
} swparts;

static swparts sw_parts(const ctx *c)
{
    size_t m = (size_t)(c->ev->n + c->ev->nlin);
    swparts w;
    w.side = c->ev->sw_scratch; w.ga = w.side + m; w.tb = w.ga + m; w.gb = w.tb + m;
    w.ge = w.gb + m; w.cross = w.ge + m; w.seen = w.cross + m; w.gp = w.seen + m;
    return w;
}

static int is_switch(const eomc_events *ev, int j)
{
    return j >= ev->n || (ev->switching && ev->switching[j]);
}

static double sw_lin(const ctx *c, int j, const double *x)
{
    const eomc_events *ev = c->ev;
    int l = j - ev->n;
    return ev->lin_s[l] * (x[ev->lin_x[l]] - c->p[ev->lin_p[l]]);
}

/* Whether g lies beyond the noise band on the other side than side (1: g > 0, 0: g <= 0;
 * -1: a function within the band at the start, on neither side until a kept step ends
 * beyond the band, sw_keep: the law the method integrates from the start is the one on the
 * side the motion goes to, so that is no crossing and no restart). */
static int sw_left(const ctx *c, double side, double g)
{
    if (side < 0.0) return 0;
    return side > 0.0 ? g < -c->sw_noise : g > c->sw_noise;
}

static void sw_seen(const ctx *c, int j, double g)
{
    if (c->ev->gmax && g > c->ev->gmax[j]) c->ev->gmax[j] = g;
}

/* Sides and gmax at the start (the events' gold holds g there). */
static void sw_start(ctx *c, const double *x)
{
    eomc_events *ev = c->ev;
    evparts e = ev_parts(c);
    swparts w = sw_parts(c);
    int m = ev->n + ev->nlin;
    double qmax = 0.0;
    for (int i = 0; i < c->m->nq; i++) qmax = fmax(qmax, fabs(x[i]));
    c->sw_noise = SW_NOISE * DBL_EPSILON * (1.0 + qmax);
    for (int j = 0; j < m; j++) {
        double g;
        if (ev->gmax) ev->gmax[j] = -HUGE_VAL;
        if (!is_switch(ev, j)) continue;
        g = j < ev->n ? e.gold[ev->col[j]] : sw_lin(c, j, x);
        w.side[j] = fabs(g) <= c->sw_noise ? -1.0 : g > 0.0;
        sw_seen(c, j, g);
    }
}

/* Which switching functions leave their side over the step [t, tn]: at its end, or at
 * one of nst interior points (tst, states xst, in time order: Radau's collocation
 * points).  Leaves g(tn) in the events' gnew (gnew_ok) for events_cross. */
static int sw_detect(ctx *c, double t, const double *x, double tn, const double *xn, int nst,
                     const double *tst, const double *xst, int *ncross)
{
    eomc_events *ev = c->ev;
    evparts e = ev_parts(c);
    swparts w = sw_parts(c);
    int m = ev->n + ev->nlin, s;
    (void)t;
    *ncross = 0;
    if (c->nswe) {
        if ((s = events_eval(c, tn, xn, e.gnew))) return s;
        c->gnew_ok = 1;
    }
    for (int j = 0; j < m; j++) {
        double ge;
        w.cross[j] = 0.0;
        if (!is_switch(ev, j)) continue;
        if (j < ev->n) { ge = e.gnew[ev->col[j]]; w.ga[j] = e.gold[ev->col[j]]; }
        else { ge = sw_lin(c, j, xn); w.ga[j] = sw_lin(c, j, x); }
        w.seen[j] = ge;
        w.ge[j] = ge;
        if (sw_left(c, w.side[j], ge)) {
            w.cross[j] = 1.0; w.tb[j] = tn; w.gb[j] = ge; ++*ncross;
        }
    }
    return sw_interior(c, nst, tst, xst, ncross);
}

/* sw_detect's interior points (after its ends). */
static int sw_interior(ctx *c, int nst, const double *tst, const double *xst, int *ncross)
{
    eomc_events *ev = c->ev;
    evparts e = ev_parts(c);
    swparts w = sw_parts(c);
    int m = ev->n + ev->nlin, s, nx = c->n;
    for (int a = 0; a < nst; a++) {
        const double *xa = xst + (size_t)a * nx;
        if (c->nswe && (s = events_eval(c, tst[a], xa, e.gtmp))) return s;
        for (int j = 0; j < m; j++) {
            double g;
            if (!is_switch(ev, j)) continue;
            g = j < ev->n ? e.gtmp[ev->col[j]] : sw_lin(c, j, xa);
            w.seen[j] = fmax(w.seen[j], g);
            if (sw_left(c, w.side[j], g) && !(w.cross[j] != 0.0 && w.tb[j] <= tst[a])) {
                if (w.cross[j] == 0.0) ++*ncross;
                w.cross[j] = 1.0; w.tb[j] = tst[a]; w.gb[j] = g;
            }
        }
    }
    return EOMC_OK;
}

/* Whether BDF's step of length h (sw_detect's ends evaluated) needs its interior points:
 * whether some switching function could leave its side and come back within it, unseen at
 * its ends.  A function that does travels at least d = da + de over the step (da, de: its
 * distances from zero, on its side, at the step's two ends); its travel is estimated by
 * SW_REACH times the larger of its change over this step and over the last kept step scaled
 * to this one's length (|ge - ga|, |ga - gp| h / hp).  In which sense that is safe: the
 * functions are smooth along BDF's polynomial (the interior points are on it too, and the
 * law is evaluated only at the steps' ends, so no force turns a function round inside a
 * step); a function that turns round inside a step near its peak -- a foot or a limit
 * grazed -- travels ~c h^2 / 4 each way (c its curvature), and its change over the step
 * before was ~c h (h + hp) scaled: SW_REACH = 2 covers it 4 times over.  What is left out:
 * a function whose rate jumps by more than that from one step to the next, unseen at both
 * ends -- a case the interior points caught only when its excursion spanned one of the two
 * points anyway.  Every function already off its side at an end, or within noise of zero, is
 * checked as before; the first step (no hp yet) always is.  The verdict still sees every
 * step's ends (gmax); inside a step kept in contact the deepest point may lie past both ends
 * by up to that travel (the bounce grid's verdicts are the same case for case, s13). */
#define SW_REACH 2.0
static int sw_reach(const ctx *c, double h)
{
    const eomc_events *ev = c->ev;
    swparts w = sw_parts(c);
    if (!(c->sw_hp > 0.0)) return 1;
    for (int j = 0; j < ev->n + ev->nlin; j++) {
        double da, de, travel;
        if (!is_switch(ev, j)) continue;
        if (w.side[j] < 0.0 || w.cross[j] != 0.0) return 1;
        da = w.side[j] > 0.0 ? w.ga[j] : -w.ga[j];
        de = w.side[j] > 0.0 ? w.ge[j] : -w.ge[j];
        travel = SW_REACH * fmax(fabs(w.ge[j] - w.ga[j]), fabs(w.ga[j] - w.gp[j]) * h / c->sw_hp);
        if (da + de <= travel + 2.0 * c->sw_noise) return 1;
    }
    return 0;
}

/* A BDF step of length h is kept: its start's values and length for the next sw_reach. */
static void sw_step_kept(ctx *c, double h)
{
    swparts w = sw_parts(c);
    memcpy(w.gp, w.ga, (size_t)(c->ev->n + c->ev->nlin) * sizeof(double));
    c->sw_hp = h;
}

/* The step is kept: what its switching functions reached counts for the verdict (a trial
 * step that is cut at a crossing or rejected does not: its end may lie far past the
 * crossing, deep in the ground). */
static void sw_keep(ctx *c)
{
    eomc_events *ev = c->ev;
    swparts w = sw_parts(c);
    for (int j = 0; j < ev->n + ev->nlin; j++) {
        if (!is_switch(ev, j)) continue;
        sw_seen(c, j, w.seen[j]);
        if (w.side[j] < 0.0 && fabs(w.ge[j]) > c->sw_noise) w.side[j] = w.ge[j] > 0.0;
    }
}

/* A step kept over crossings (fixed-step methods, BDF): the functions that crossed take the
 * side of their value at its end. */
static void sw_flip(ctx *c)
{
    swparts w = sw_parts(c);
    for (int j = 0; j < c->ev->n + c->ev->nlin; j++)
        if (w.cross[j] != 0.0) w.side[j] = w.ge[j] > 0.0;
}

/* A linear switching function (a joint limit) between the sampled points: its coordinate
 * along the step's cubic Hermite interpolant has at most two extrema, found in closed form,
 * so a joint that passes its limit and comes back inside one step is seen however short the
 * excursion (sampling alone misses excursions shorter than the sample spacing).  With ip ==
 * NULL an extremum within NEAR_SCALES tolerance scales of the limit only sets *near (the cubic
 * is an approximation); with the method's own dense output ip the value there decides. */
#define NEAR_SCALES 1e3
static void sw_lin_extrema(ctx *c, double t, double h, const double *x, const double *f0,
                           const double *xn, const double *f1, const interp *ip, double rtol,
                           double atol, int *ncross, int *near)
{
    eomc_events *ev = c->ev;
    swparts w = sw_parts(c);
    evparts e = ev_parts(c);
    *near = 0;
    for (int j = ev->n; j < ev->n + ev->nlin; j++) {
        int l = j - ev->n, i = ev->lin_x[l];
        /* x(th) = x0 + h f0 th + (3 d - h (2 f0 + f1)) th^2 + (h (f0 + f1) - 2 d) th^3, d = x1 - x0 */
        double d = xn[i] - x[i], b1 = h * f0[i], b2 = 3 * d - h * (2 * f0[i] + f1[i]);
        double b3 = h * (f0[i] + f1[i]) - 2 * d, qa = 3 * b3, qb = 2 * b2, qc = b1, th[2];
        int nr = 0;
        if (fabs(qa) > 1e-300) {
            double disc = qb * qb - 4 * qa * qc;
            if (disc >= 0) {
                double sq = sqrt(disc), qq = -0.5 * (qb + copysign(sq, qb));
                if (qq != 0.0) { th[nr++] = qq / qa; th[nr++] = qc / qq; }
            }
        } else if (fabs(qb) > 1e-300) {
            th[nr++] = -qc / qb;
        }
        for (int k = 0; k < nr; k++) {
            double tk = th[k], xi, g, tt = t + th[k] * h;
            if (!(tk > 0.0 && tk < 1.0)) continue;
            xi = x[i] + tk * (b1 + tk * (b2 + tk * b3));
            if (ip) {
                interp_eval(ip, tt, e.xtmp);
                xi = e.xtmp[i];
            }
            g = ev->lin_s[l] * (xi - c->p[ev->lin_p[l]]);
            if (!ip) {
                if ((g > 0.0) == (w.side[j] > 0.0)
                    && fabs(g) > NEAR_SCALES * (atol + rtol * fabs(xi))) continue;
                *near = 1;
                continue;
            }
            w.seen[j] = fmax(w.seen[j], g);
            if (sw_left(c, w.side[j], g) && !(w.cross[j] != 0.0 && w.tb[j] <= tt)) {
                if (w.cross[j] == 0.0) ++*ncross;
                w.cross[j] = 1.0; w.tb[j] = tt; w.gb[j] = g;
            }
        }
    }
}

/* The first crossing on the step's dense output: *t_cut = the end of a step to redo that
 * stops just past it, or *t_cut = the step's start when the step is accepted as it is
 * (the crossing lies at its end): the sides flip and the caller restarts the method.  (w.tb
 * holds each crossing function's root afterwards.)  Radau and the explicit methods; BDF passes
 * over switching points (run_bdf). */
static int sw_locate(ctx *c, const interp *ip, double *t_cut)
{
    eomc_events *ev = c->ev;
    swparts w = sw_parts(c);
    int m = ev->n + ev->nlin, s;
    double t = ip->t, tn = ip->t + ip->h, tr = INFINITY, cut;
    for (int j = 0; j < m; j++) {
        double root = t;
        if (w.cross[j] == 0.0) continue;
        if ((w.ga[j] > 0.0) != (w.gb[j] > 0.0)
            && (s = event_root(c, ip, j, t, w.tb[j], w.ga[j], w.gb[j], &root)))
            return s;
        w.tb[j] = root;
        tr = fmin(tr, root);
    }
    cut = t + (tr - t) * (1.0 + 0.25 * SW_FRAC);
    if (tn - tr > SW_FRAC * ip->h && c->sw_cuts < SW_MAX_CUTS && cut - t >= min_step(t) && cut < tn
        && !ev->sw_observe) {
        c->sw_cuts++;
        *t_cut = cut;
        return EOMC_OK;
    }
    for (int j = 0; j < m; j++)
        if (w.cross[j] != 0.0) w.side[j] = w.ge[j] > 0.0;
    c->sw_cuts = 0;
    c->st->nswitch++;
    *t_cut = t;
    return EOMC_OK;
}

/* Fixed-step methods keep their grid: they do not end a step at a crossing, but the
 * switching functions are still watched (gmax, sides) so every run gets its verdict. */
static int sw_watch(ctx *c, double t, const double *x, double tn, const double *xn)
{
    int ncross = 0, s;
    if (!c->nsw) return EOMC_OK;
    if ((s = sw_detect(c, t, x, tn, xn, 0, NULL, NULL, &ncross))) return s;
    sw_keep(c);
    if (ncross) sw_flip(c);
    return EOMC_OK;
}

/* The step's end becomes the next step's start (re-evaluated after a projection). */
static int events_commit(ctx *c, double tn, const double *xn, int recompute)
{
    evparts e = ev_parts(c);
    if (c->ev->n == 0) return EOMC_OK;
    if (recompute) return events_eval(c, tn, xn, e.gold);
    memcpy(e.gold, e.gnew, (size_t)c->ev->ncol * sizeof(double));
    return EOMC_OK;
}

/* ----------------------------------------- fixed-step implicit (eomc_fixedstep.c) */
/* The step is in eomc_fixedstep.c; what every method shares (inputs, checks, events,
 * output rows, projection) is handed to it through these callbacks. */

typedef struct fs_glue {
    ctx *c;
    proj *pj;
    outw *ow;
    const eomc_implicit *imp;
    int watch;               /* eomc_options.watch_output - 1, or -1: none */
    eomc_rhs_fn wfn;         /* eomc_options.watch_fn (its out[0]), or NULL: m->outputs */
    double *wout;            /* its outputs (noutput) */
    int nspring;             /* eomc_options.nspring, .spring */
    const eomc_spring *spring;
    int total;               /* the total's watch: 0 not started, 1 on, -1 not known (stats NaN) */
    double prev, run_lo, t_run_lo, jump, t_jump;   /* its last value, running min, and the largest
                                one-step rise since that min (and the step's end) */
} fs_glue;

/* One knot of an eomc_spring's table: the double whose bits are (base + k) << (52 - bits). */
static double spring_knot(const eomc_spring *s, long long k)
{
    uint64_t b = (uint64_t)(s->base + k) << (52 - s->bits);
    double d;
    memcpy(&d, &b, sizeof d);
    return d;
}

/* The stored energy of limit spring s at state x (eomc_spring: p[stiffness] * S(d), 0 inside
 * the range), or NAN when not known (past its table, another width, a non-finite depth). */
static double spring_energy(const eomc_spring *s, const double *x, const double *p)
{
    double d = s->sign * (x[s->state] - p[s->bound]), K = p[s->stiffness], d0, d1, S0, S1, f0, f1, h, u, v;
    uint64_t b;
    long long k;
    if (isnan(d)) return NAN;
    if (d <= 0.0 || !(K > 0.0)) return 0.0;     /* limit_energy.stored(): 0 for K <= 0 */
    if (p[s->width] != s->E) return NAN;
    memcpy(&b, &d, sizeof b);
    k = (long long)(b >> (52 - s->bits)) - s->base;
    if (k >= (long long)s->n - 1) return NAN;
    if (k < 0) {
        d0 = S0 = f0 = 0.0;
        d1 = spring_knot(s, 0);
        S1 = s->S[0];
        f1 = s->f[0];
    } else {
        d0 = spring_knot(s, k);
        d1 = spring_knot(s, k + 1);
        S0 = s->S[k];
        S1 = s->S[k + 1];
        f0 = s->f[k];
        f1 = s->f[k + 1];
    }
    h = d1 - d0;
    u = (d - d0) / h;
    v = 1.0 - u;
    return K * (v * v * ((1.0 + 2.0 * u) * S0 + u * h * f0) + u * u * ((3.0 - 2.0 * u) * S1 - v * h * f1));
}

/* The total's watch (eomc_stats.watch_total0 ... watch_t_jump) at (t, x) with the output's value v. */
static void fs_watch_total(fs_glue *g, double t, const double *x, double v)
{
    eomc_stats *st = g->c->st;
    double T = v;
    int k;
    if (g->total < 0) return;
    for (k = 0; k < g->nspring; k++)
        T += spring_energy(&g->spring[k], x, g->c->p);
    if (!isfinite(T)) {
        g->total = -1;
        st->watch_total0 = st->watch_total_lo = st->watch_total_hi = NAN;
        st->watch_rise = st->watch_low = st->watch_t_low = st->watch_peak = st->watch_t_peak = NAN;
        st->watch_t_jump = NAN;
        return;
    }
    if (!g->total) {
        g->total = 1;
        st->watch_total0 = st->watch_total_lo = st->watch_total_hi = T;
        st->watch_rise = 0.0;
        st->watch_low = st->watch_peak = T;
        st->watch_t_low = st->watch_t_peak = t;
        g->run_lo = T;
        g->t_run_lo = t;
        g->jump = -INFINITY;
        g->prev = T;
        return;
    }
    if (T < g->run_lo) {
        g->run_lo = T;
        g->t_run_lo = t;
        g->jump = -INFINITY;
    } else {
        if (T - g->prev > g->jump) {
            g->jump = T - g->prev;
            g->t_jump = t;
        }
        if (T - g->run_lo > st->watch_rise) {
            st->watch_rise = T - g->run_lo;
            st->watch_low = g->run_lo;
            st->watch_t_low = g->t_run_lo;
            st->watch_peak = T;
            st->watch_t_peak = t;
            st->watch_t_jump = g->t_jump;
        }
    }
    g->prev = T;
    if (T < st->watch_total_lo) st->watch_total_lo = T;
    if (T > st->watch_total_hi) st->watch_total_hi = T;
}

/* eomc_options.watch_output: output g->watch at (t, x) into the run's range (stats watch_lo,
 * watch_hi); a failed or non-finite evaluation makes the range NaN for good (no verdict, as
 * simulate's when an output is not finite).  Not counted in nfev: no step needs it.  energy: the
 * watched output (the model's energy: rollout's _energy_watch) as the fast path's terms at
 * (t, x) hold it (eomc_implicit.energy; read when the watch is watch_fn, the model's NAME_energy), or
 * NULL: evaluated here.  Why: the step made those terms
 * anyway, and NAME_energy at every step was 19-20 % of G1's lanes rollout (session 18).  With
 * quaternions too: the terms were made at the step's end before fs_accept normalised its
 * quaternions, and the energy, like the rhs and every output, does not see a quaternion's length
 * (compiler/multibody/joint_kinds.quaternion_rotation: R(c q) = R(q), s = 2/|q|^2, the only place
 * a quaternion enters), so that value is the normalised state's energy up to rounding
 * (tests/runtime/test_rollout_energy_watch: the ranges within 1e-12 of NAME_energy's at the
 * normalised states).  Until session 28 a quaternion model paid NAME_energy at every step here:
 * its rollouts 5-12 % slower than the Euler build's (benchmarks/results/quaternion_fixedstep.md). */
static void fs_watch(fs_glue *g, double t, const double *x, const double *energy)
{
    ctx *c = g->c;
    eomc_stats *st = c->st;
    double v;
    if (g->watch < 0 || isnan(st->watch_lo)) return;
    if (energy && g->wfn) {
        v = *energy;
    } else {
        grid_inputs_at(c, t);
        if (g->wfn) v = g->wfn(t, x, c->p, c->r, g->wout, c->mwork) == EOMC_OK ? g->wout[0] : NAN;
        else v = c->m->outputs(t, x, c->p, c->r, g->wout, c->mwork) == EOMC_OK ? g->wout[g->watch] : NAN;
    }
    if (!isfinite(v)) {
        st->watch_lo = st->watch_hi = NAN;
        fs_watch_total(g, t, x, NAN);
        return;
    }
    if (v < st->watch_lo) st->watch_lo = v;
    if (v > st->watch_hi) st->watch_hi = v;
    fs_watch_total(g, t, x, v);
}

/* The run's inputs at t before a model call (as frhs: grid or callback); an eomc_status. */
static int fs_inputs(ctx *c, double t, const double *x)
{
    int s;
    if (aborted(c)) { c->st->t_fail = t; return c->abort; }
    if (!c->fb) grid_inputs_at(c, t);
    else if ((s = inputs_at(c, t, x))) { c->st->t_fail = t; return s; }
    c->st->nfev++;
    return EOMC_OK;
}

/* NAME_implicit with the run's inputs at t (counted in nfev). */
static int fs_terms(void *g, double t, const double *x, double *out)
{
    ctx *c = ((fs_glue *)g)->c;
    int s;
    if ((s = fs_inputs(c, t, x))) return s;
    s = ((fs_glue *)g)->imp->terms(t, x, c->p, c->r, out, c->mwork);
    if (s != EOMC_OK) c->st->t_fail = t;
    return s;
}

/* fs_terms through the implicit's terms_lu (the lanes rollout's; eomc_fixedstep.h). */
static int fs_terms_lu(void *g, double t, const double *x, double *out, eomc_fs_request *req)
{
    ctx *c = ((fs_glue *)g)->c;
    int s;
    req->done = req->ahead = 0;
    if ((s = fs_inputs(c, t, x))) return s;
    s = ((fs_glue *)g)->imp->terms_lu(t, x, c->p, c->r, out, req, c->mwork);
    if (s != EOMC_OK) c->st->t_fail = t;
    return s;
}

/* A split step's try at another size (eomc_fs_ops.assemble_lu): the implicit's terms_lu with t NaN,
 * its sign for "no model call: out holds the terms at x" (the lanes rollout's, eomc_rollout.c). */
static int fs_assemble_lu(void *g, const double *x, double *out, eomc_fs_request *req)
{
    ctx *c = ((fs_glue *)g)->c;
    req->done = req->ahead = 0;
    return ((fs_glue *)g)->imp->terms_lu(NAN, x, c->p, c->r, out, req, c->mwork);
}

/* The fast path applies: the model's terms were given, no projection (it needs f at the
 * step's end), no linear feedback (its slope jac_r K is not in the terms), no extra states. */
static int fs_fast_ok(const ctx *c, const eomc_options *o, const proj *pj)
{
    const eomc_implicit *imp = o->implicit;
    return imp && imp->terms && !pj->on && !(c->fb && c->fb->K) && c->stab == 0.0
           && c->m->nx == c->m->nq + c->m->nu && imp->ncontact >= 0
           && (imp->ncontact == 0 || (imp->chain_start && imp->chain));
}

static int fs_rhs(void *g, double t, const double *x, double *f)
{
    return frhs(((fs_glue *)g)->c, t, x, f);
}

static int fs_jac(void *g, double t, const double *x, double *J)
{
    return fjac(((fs_glue *)g)->c, t, x, J);
}

/* As RK4 does after its step; the dense output is the step's line (Hermite with the
 * secant as both slopes). */
static int fs_accept(void *g, double t, double tn, double *x, const double *slope, double *x1,
                     double *f1, const double *energy1, int *stop)
{
    ctx *c = ((fs_glue *)g)->c;
    proj *pj = ((fs_glue *)g)->pj;
    outw *ow = ((fs_glue *)g)->ow;
    int n = c->n, s;
    double hh = tn - t;
    *stop = 0;
    if (!all_finite(n, x1)) return EOMC_NONFINITE;
    if (c->nsw && (s = sw_watch(c, t, x, tn, x1))) return s;
    if (c->ev) {
        int hits = 0;
        if ((s = events_cross(c, tn, x1, &hits))) return s;
        if (hits) {
            interp ip = {0, n, t, hh, x, slope, x1, slope, NULL, NULL, NULL, NULL};
            if ((s = events_in_step(c, &ip, ow, x))) return s;
            if (c->ev->terminated) { *stop = 1; return EOMC_OK; }
        }
    }
    EMIT_UNTIL(ow, tn, hermite(n, hh, (tau - t) / hh, x, slope, x1, slope, row));
    if (c->nquat) { unit_quats(c, x1, f1); fix_last_row(ow, tn, x1); }
    if (pj->on) {
        if ((s = project_state(c, pj, tn, x1))) return s;
        fix_last_row(ow, tn, x1);
        if ((s = frhs(c, tn, x1, f1))) return s;
    }
    if (c->ev && (s = events_commit(c, tn, x1, pj->on))) return s;
    fs_watch((fs_glue *)g, tn, x1, pj->on ? NULL : energy1);
    return EOMC_OK;
}

static int run_implicitfast(ctx *c, const eomc_options *o, proj *pj, double t0, double t1,
                            double *x, outw *ow, double **pos)
{
    fs_glue g = {c, pj, ow, o->implicit, -1, NULL, NULL, 0, NULL, 0, 0.0, 0.0, 0.0, 0.0, NAN};
    eomc_fs_ops ops = {&g, fs_rhs, fs_jac, fs_accept, NULL, NULL, 0, 0, NULL, NULL, NULL};
    int fast = fs_fast_ok(c, o, pj), s;
    c->st->watch_lo = c->st->watch_hi = NAN;
    if (o->watch_output > 0 && o->watch_output <= c->m->noutput && c->m->outputs && !c->fb) {
        g.watch = o->watch_output - 1;
        g.wfn = o->watch_fn;
        g.wout = take(pos, (size_t)c->m->noutput);
        g.nspring = o->spring ? o->nspring : 0;
        g.spring = o->spring;
        c->st->watch_lo = INFINITY;
        c->st->watch_hi = -INFINITY;
        fs_watch(&g, t0, x, NULL);
    }
    if (fast) {
        ops.terms = fs_terms;
        if (o->implicit->terms_lu) {
            ops.terms_lu = fs_terms_lu;
            ops.assemble_lu = fs_assemble_lu;
        }
        ops.imp = o->implicit;
        ops.nq = c->m->nq;
        ops.nu = c->m->nu;
        ops.p = c->p;
    }
    s = eomc_fs_run(&ops, c->st, c->n, o->h0, o->max_steps, t0, t1, x,
                    take(pos, fast ? o->implicit->work_len : eomc_fs_work_size(c->n)));
    if (s == EOMC_OK && !(c->ev && c->ev->terminated)) c->st->t = t1;
    return s;
}

/* ------------------------------------------------------------ public API */

static int check_args(const eomc_model *m, const eomc_options *o, double t0, double t1,
                      const double *x0, int n_eval, const double *t_eval, double *x_out)
{
    if (!m || !o || !x0 || !m->rhs || m->nx <= 0) return EOMC_BAD_ARGUMENT;
    if (!isfinite(t0) || !isfinite(t1) || !(t1 > t0)) return EOMC_BAD_ARGUMENT;
    if (o->method < EOMC_RK4 || o->method > EOMC_BDF) return EOMC_BAD_ARGUMENT;
    if (o->method != EOMC_RK4 && o->method != EOMC_IMPLICITFAST && !(o->rtol > 0 && o->atol > 0))
        return EOMC_BAD_ARGUMENT;
    if ((o->method == EOMC_RADAU5 || o->method == EOMC_BDF
         || (o->method == EOMC_IMPLICITFAST && !o->implicit)) && !m->jac_x)
        return EOMC_NOT_AVAILABLE;
    if (!(o->baumgarte >= 0.0) || !isfinite(o->baumgarte)) return EOMC_BAD_ARGUMENT;
    if (n_eval < 0 || (n_eval > 0 && (!t_eval || !x_out))) return EOMC_BAD_ARGUMENT;
    for (int i = 0; i < n_eval; i++)
        if (!(t_eval[i] >= t0 && t_eval[i] <= t1) || (i > 0 && !(t_eval[i] > t_eval[i - 1])))
            return EOMC_BAD_ARGUMENT;
    return all_finite(m->nx, x0) ? EOMC_OK : EOMC_NONFINITE;
}

int eomc_integrate(const eomc_model *m, const eomc_options *opt,
                   double t0, double t1, const double *x0, const double *p,
                   int n_rgrid, const double *r_tgrid, const double *r_values,
                   int n_eval, const double *t_eval, double *x_out,
                   double *x_last, eomc_stats *stats, double *work, size_t work_len)
{
    return eomc_integrate_ex(m, opt, t0, t1, x0, p, n_rgrid, r_tgrid, r_values, NULL, NULL,
                             n_eval, t_eval, x_out, x_last, stats, work, work_len);
}

static int check_extras(const eomc_model *m, const eomc_feedback *fb, const eomc_events *ev)
{
    if (fb && m->ninput <= 0) return EOMC_BAD_ARGUMENT;
    if (fb && fb->n_kgrid >= 2) {
        if (!fb->K || !fb->k_tgrid) return EOMC_BAD_ARGUMENT;
        for (int i = 0; i < fb->n_kgrid; i++)
            if (!isfinite(fb->k_tgrid[i]) || (i > 0 && !(fb->k_tgrid[i] > fb->k_tgrid[i - 1])))
                return EOMC_BAD_ARGUMENT;
    }
    if (ev && ev->n > 0) {
        if (!ev->fn || ev->ncol <= 0 || !ev->col || !ev->scratch || ev->capacity < 0)
            return EOMC_BAD_ARGUMENT;
        for (int k = 0; k < ev->n; k++)
            if (ev->col[k] < 0 || ev->col[k] >= ev->ncol) return EOMC_BAD_ARGUMENT;
    }
    if (ev && ev->nlin > 0) {
        if (!ev->lin_x || !ev->lin_p || !ev->lin_s) return EOMC_BAD_ARGUMENT;
        for (int j = 0; j < ev->nlin; j++)
            if (ev->lin_x[j] < 0 || ev->lin_x[j] >= m->nx || ev->lin_p[j] < 0
                || ev->lin_p[j] >= m->nparam || !isfinite(ev->lin_s[j]))
                return EOMC_BAD_ARGUMENT;
    }
    if (ev && (ev->nlin > 0 || ev->switching) && !ev->sw_scratch) return EOMC_BAD_ARGUMENT;
    if (ev && ev->nlin < 0) return EOMC_BAD_ARGUMENT;
    return EOMC_OK;
}

static int check_stagger(const eomc_model *m, const eomc_options *o, const eomc_stagger *sg,
                         int n_eval)
{
    if (!sg) return EOMC_OK;
    if (sg->n_err < 0 || sg->n_err > m->nx || sg->n_fin < 0 || sg->n_fin > m->nx || sg->k < 0)
        return EOMC_BAD_ARGUMENT;
    if ((sg->ntstop > 0 || sg->rec_cap > 0)
        && (sg->k > 0 || (o->method != EOMC_DOPRI5 && o->method != EOMC_DOP853
                          && o->method != EOMC_RADAU5)
            || (sg->ntstop > 0 && !sg->tstop) || (sg->rec_cap > 0 && (!sg->rec_t || !sg->rec_x))
            || (o->method == EOMC_RADAU5 && sg->rec_cap > 0 && !sg->rec_k)))
        return EOMC_BAD_ARGUMENT;
    if (sg->k > 0 && (o->method != EOMC_RADAU5 || !sg->jvp || !sg->D || !sg->S
                      || sg->ndir < m->nx || (n_eval > 0 && !sg->S_out)))
        return EOMC_BAD_ARGUMENT;
    return EOMC_OK;
}

static int integrate_core(const eomc_model *m, const eomc_options *opt,
                          double t0, double t1, const double *x0, const double *p,
                          int n_rgrid, const double *r_tgrid, const double *r_values,
                          const eomc_feedback *fb, eomc_events *ev,
                          int n_eval, const double *t_eval, double *x_out,
                          double *x_last, eomc_stats *stats, double *work, size_t work_len,
                          eomc_stagger *sg)
{
    ctx c;
    proj pj;
    outw ow;
    eomc_stats local;
    double *pos = work, *x;
    int s;
    if (!stats) stats = &local;
    memset(stats, 0, sizeof *stats);
    stats->t = t0;
    stats->t_fail = NAN;
    stats->watch_lo = stats->watch_hi = NAN;
    stats->watch_total0 = stats->watch_total_lo = stats->watch_total_hi = NAN;
    stats->watch_rise = stats->watch_low = stats->watch_t_low = stats->watch_peak = stats->watch_t_peak = NAN;
    stats->watch_t_jump = NAN;
    s = check_args(m, opt, t0, t1, x0, n_eval, t_eval, x_out);
    if (s == EOMC_OK) s = check_extras(m, fb, ev);
    if (s == EOMC_OK) s = check_stagger(m, opt, sg, n_eval);
    if (s == EOMC_OK && (!work || work_len < eomc_integrate_work_size(m, opt->method)
                         + eomc_feedback_work_size(m, fb)
                         + (sg && sg->k > 0 ? eomc_stagger_work_size(m->nx, sg->k, sg->ndir) : 0)
                         + (opt->method == EOMC_IMPLICITFAST && opt->implicit
                            ? opt->implicit->work_len : 0)))
        s = EOMC_BAD_ARGUMENT;
    if (s == EOMC_OK)
        s = ctx_init(&c, m, p, n_rgrid, r_tgrid, r_values, stats, &pos);
    if (ev) { ev->n_rec = 0; ev->terminated = 0; }
    if (s != EOMC_OK) {
        if (x_last && x0) memcpy(x_last, x0, (size_t)m->nx * sizeof(double));
        return stats->status = s;
    }
    proj_init(&pj, m, opt->project, &pos);
    c.pj = &pj;
    if (sg) {
        sg->njvp = sg->niter = sg->nslow = 0;
        sg->nrec = 0;
        if (sg->n_err > 0) c.n_err = sg->n_err;
        if (sg->n_fin > 0) c.n_fin = sg->n_fin;
        if (sg->k > 0 || sg->ntstop > 0 || sg->rec_cap > 0) c.sg = sg;
    }
    if (fb) {
        c.fb = fb;
        c.fbJ = take(&pos, (size_t)m->ninput * (size_t)m->nx);
        if (fb->n_kgrid >= 2) c.fbK = take(&pos, (size_t)m->ninput * (size_t)m->nx + (size_t)m->nx);
    }
    if (opt->baumgarte > 0.0 && pj.k > 0 && m->constraints && m->constraints_jac)
        c.stab = opt->baumgarte;
    x = take(&pos, m->nx);
    memcpy(x, x0, (size_t)m->nx * sizeof(double));
    if (opt->nquat > 0 && opt->quat) {
        for (int k = 0; k < opt->nquat; k++)
            if (opt->quat[k] < 0 || opt->quat[k] + 4 > m->nq) s = EOMC_BAD_ARGUMENT;
        c.nquat = opt->nquat; c.quat = opt->quat;
        if (s == EOMC_OK) unit_quats(&c, x, NULL);
    }
    c.stop = opt->stop;
    if (opt->interrupt_base > 0) c.sigint0 = opt->interrupt_base - 1;
    ow.n = n_eval; ow.i = 0; ow.nx = m->nx; ow.t = t_eval; ow.x = x_out;
    ow.ld = sg && sg->ld_out > 0 ? sg->ld_out : m->nx;
    if (pj.on) s = project_state(&c, &pj, t0, x);
    if (s == EOMC_OK && ev && (ev->n > 0 || ev->nlin > 0)) {
        evparts e;
        c.ev = ev;
        e = ev_parts(&c);
        memset(e.count, 0, (size_t)ev->n * sizeof(double));
        if (ev->n > 0) s = events_eval(&c, t0, x, e.gold);
        for (int k = 0; k < ev->n; k++)
            if (ev->switching && ev->switching[k]) c.nswe++;
        c.nsw = c.nswe + ev->nlin;
        if (s == EOMC_OK && c.nsw && !c.abort) sw_start(&c, x);
    }
    EMIT_UNTIL(&ow, t0, memcpy(row, x, (size_t)m->nx * sizeof(double)));
    if (c.sg && sg->k > 0)
        for (int i = 0; i < ow.i; i++)
            memcpy(sg->S_out + (size_t)i * (sg->ld_out > 0 ? (size_t)ow.ld : (size_t)m->nx * sg->k), sg->S, (size_t)m->nx * sg->k * sizeof(double));
    if (s == EOMC_OK) {
        switch (opt->method) {
        case EOMC_RK4: s = run_rk4(&c, opt, &pj, t0, t1, x, &ow, &pos); break;
        case EOMC_DOPRI5: s = run_erk(&c, &ERK_DP5, opt, &pj, t0, t1, x, &ow, &pos); break;
        case EOMC_DOP853: s = run_erk(&c, &ERK_D853, opt, &pj, t0, t1, x, &ow, &pos); break;
        case EOMC_IMPLICITFAST: s = run_implicitfast(&c, opt, &pj, t0, t1, x, &ow, &pos); break;
        case EOMC_BDF: s = run_bdf(&c, opt, &pj, t0, t1, x, &ow, &pos); break;
        default: s = run_radau(&c, opt, &pj, t0, t1, x, &ow, &pos); break;
        }
    }
    if (x_last) memcpy(x_last, x, (size_t)m->nx * sizeof(double));
    stats->n_out = ow.i;
    if (s == EOMC_OK || s == EOMC_STEP_TOO_SMALL || s == EOMC_MAX_STEPS || s == EOMC_STIFF
        || isnan(stats->t_fail))
        stats->t_fail = stats->t;
    return stats->status = s;
}

int eomc_integrate_ex(const eomc_model *m, const eomc_options *opt,
                      double t0, double t1, const double *x0, const double *p,
                      int n_rgrid, const double *r_tgrid, const double *r_values,
                      const eomc_feedback *fb, eomc_events *ev,
                      int n_eval, const double *t_eval, double *x_out,
                      double *x_last, eomc_stats *stats, double *work, size_t work_len)
{
    return integrate_core(m, opt, t0, t1, x0, p, n_rgrid, r_tgrid, r_values, fb, ev, n_eval,
                          t_eval, x_out, x_last, stats, work, work_len, NULL);
}

int eomc_integrate_sg(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                      const double *x0, const double *p, int n_rgrid, const double *r_tgrid,
                      const double *r_values, int n_eval, const double *t_eval, double *x_out,
                      double *x_last, eomc_stats *stats, double *work, size_t work_len,
                      eomc_stagger *sg)
{
    return integrate_core(m, opt, t0, t1, x0, p, n_rgrid, r_tgrid, r_values, NULL, NULL, n_eval,
                          t_eval, x_out, x_last, stats, work, work_len, sg);
}

int eomc_eval_along(const eomc_model *m, int which, int n, const double *t,
                    const double *X, const double *p, int n_rgrid,
                    const double *r_tgrid, const double *r_values,
                    double *out, double *work, size_t work_len)
{
    ctx c;
    eomc_stats st;
    double *pos = work;
    eomc_rhs_fn fn;
    int cols, s;
    if (!m || !t || !X || !out || n < 0) return EOMC_BAD_ARGUMENT;
    fn = which == 0 ? m->outputs : which == 1 ? m->constraints : NULL;
    cols = which == 0 ? m->noutput : m->nhol + m->nvel;
    if (which != 0 && which != 1) return EOMC_BAD_ARGUMENT;
    if (cols == 0) return EOMC_OK;
    if (!fn) return EOMC_NOT_AVAILABLE;
    if (!work || work_len < base_size(m)) return EOMC_BAD_ARGUMENT;
    memset(&st, 0, sizeof st);
    if ((s = ctx_init(&c, m, p, n_rgrid, r_tgrid, r_values, &st, &pos))) return s;
    for (int i = 0; i < n; i++) {
        grid_inputs_at(&c, t[i]);
        s = fn(t[i], X + (size_t)i * m->nx, p, c.r, out + (size_t)i * cols, c.mwork);
        if (s) return s;
    }
    return EOMC_OK;
}
