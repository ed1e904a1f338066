/* eomc_rollout.c -- see eomc_rollout.h. */
#define _GNU_SOURCE          /* ucontext (the lanes' fibers) beside POSIX 2008 */
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <ucontext.h>
#include "eomc_rollout.h"
#include "eomc_fixedstep.h"

#define EOMC_ROLLOUT_MAX_THREADS 1024
typedef struct rollout_job {
    const eomc_model *m;
    const eomc_options *opt;
    double t0, t1;
    int n;
    const double *X0, *P;
    size_t p_stride;
    int n_rgrid;         /* each row's input grid: r_tgrid (shared), R + row * r_stride */
    const double *r_tgrid, *R;
    size_t r_stride;
    int n_eval;
    const double *t_eval;
    double *X_out, *X_last;
    int *status;
    long *steps;
    eomc_stats *stats;   /* may be NULL: each row's whole stats */
    const eomc_rollout_extras *ex;   /* may be NULL: no feedback, no events */
    size_t work_len;     /* doubles per thread: integrator work, feedback, events scratch */
    size_t ev_scratch, sw_scratch;   /* of which the events' two scratch buffers (at the end) */
    pthread_mutex_t lock;
    int next;            /* next row to hand out, under lock */
    long sigint0;        /* eomc_interrupt_count() at the start: once it changes, no row is handed out */
    eomc_batch_fn batch; /* NULL, or NAME_implicit_batch: implicitfast's model calls in lanes */
    int lanes;           /* rows each thread runs at once (fibers) with batch */
    size_t out_len;      /* doubles of NAME_implicit's output */
    int reads_t;         /* NAME_implicit reads t: a batch holds only calls at one time */
    eomc_batch_rows_fn batch_rows;   /* NULL, or NAME_implicit_batch_rows: used instead of batch, ... */
    size_t blk0, blkn;   /* ... its block of outputs blk0 .. blk0 + blkn written into the rows' own buffers */
} rollout_job;

static int take_row(rollout_job *job)
{
    int i;
    pthread_mutex_lock(&job->lock);
    i = job->next < job->n && eomc_interrupt_count() == job->sigint0 ? job->next++ : -1;
    pthread_mutex_unlock(&job->lock);
    return i;
}

/* Row i's copies of the extras' feedback and events, pointing at its slices. */
static void row_extras(const rollout_job *job, size_t row, double *work, eomc_feedback *fb,
                       eomc_events *ev)
{
    const eomc_rollout_extras *ex = job->ex;
    const size_t nx = (size_t)job->m->nx;
    if (ex->fb) {
        *fb = *ex->fb;
        fb->K = ex->fb->K ? ex->fb->K + row * ex->K_stride : NULL;
        fb->x_ref = ex->fb->x_ref ? ex->fb->x_ref + row * ex->ref_stride : NULL;
    }
    if (ex->ev) {
        const size_t cap = ex->ev->capacity > 0 ? (size_t)ex->ev->capacity : 0;
        *ev = *ex->ev;
        ev->t_rec = ex->t_rec + row * cap;
        ev->id_rec = ex->id_rec + row * cap;
        ev->x_rec = ex->x_rec + row * cap * nx;
        ev->gmax = ex->gmax ? ex->gmax + row * ex->gmax_len : NULL;
        ev->scratch = work + job->work_len - job->ev_scratch - job->sw_scratch;
        ev->sw_scratch = job->sw_scratch ? work + job->work_len - job->sw_scratch : NULL;
    }
}

/* Row i, integrated with opt in work. */
static void run_row(rollout_job *job, int i, double *work, const eomc_options *opt)
{
    const size_t nx = (size_t)job->m->nx;
    const size_t run_len = job->work_len - job->ev_scratch - job->sw_scratch;
    {
        eomc_stats st;
        eomc_feedback fb;
        eomc_events ev;
        const size_t row = (size_t)i;
        double *x_out = job->X_out ? job->X_out + row * (size_t)job->n_eval * nx : NULL;
        const eomc_feedback *fbp = NULL;
        eomc_events *evp = NULL;
        if (job->ex) {
            row_extras(job, row, work, &fb, &ev);
            fbp = job->ex->fb ? &fb : NULL;
            evp = job->ex->ev ? &ev : NULL;
        }
        job->status[i] = eomc_integrate_ex(job->m, opt, job->t0, job->t1, job->X0 + row * nx,
                                           job->P + row * job->p_stride, job->n_rgrid, job->r_tgrid,
                                           job->n_rgrid > 0 ? job->R + row * job->r_stride : NULL,
                                           fbp, evp, job->n_eval, job->t_eval, x_out,
                                           job->X_last + row * nx, &st, work, run_len);
        if (evp) {
            job->ex->n_rec[i] = ev.n_rec;
            job->ex->terminated[i] = ev.terminated;
        }
        if (job->steps)
            job->steps[i] = st.steps;
        if (job->stats)
            job->stats[i] = st;
    }
}

static void run_rows(rollout_job *job, double *work, const eomc_options *opt)
{
    int i;
    while ((i = take_row(job)) >= 0)
        run_row(job, i, work, opt);
}

/* ------------------------------------------------- implicitfast's model calls in lanes
 *
 * Each thread runs job->lanes rows at once, each row in a fiber (its own stack) running the
 * scalar code of run_row -- eomc_integrate_ex, the same step rule, splits and checks -- with its
 * options' NAME_implicit replaced by lanes_terms: a row's model call hands its state to the
 * thread's scheduler and waits.  When no fiber can go on, the scheduler evaluates the waiting
 * states that share the parameters (and the time, when NAME_implicit reads t: job->reads_t) in
 * one job->batch (NAME_implicit_batch) call -- padded to a whole batch when fewer wait -- and
 * resumes them; a fiber whose row ends takes the job's next row (take_row).  Each lane of the
 * batch is the scalar call's bits with -DEOMC_BATCH_LIBM_TRIG (so every row is the scalar
 * rollout's row), and within the vector sin/cos otherwise, whose bits depend on the lane's own
 * argument alone (compiler/emit/batch.py): every call of a row is a batch lane, so a row's bits
 * depend on that row alone -- not on which rows share its rounds, the threads' timing or count.
 * A row whose step is split calls again at sub-step times; those calls are batched with whatever
 * rows wait (at the same time, when the model reads t). */

enum { FIBER_RUNNING, FIBER_WAITING, FIBER_DONE };
#define FIBER_STACK ((size_t)1 << 20)   /* the integrator's frames (the model call runs outside) */

#if defined(__x86_64__) && defined(__GNUC__) && defined(__linux__) && !defined(EOMC_FIBER_UCONTEXT)
/* A switch between fibers without swapcontext's two system calls (it saves and restores the
 * signal mask): the callee-saved registers pushed on this stack, the stacks swapped, the
 * other's popped.  Measured (Go2, 64 rows): swapcontext's switches cost more than the lanes
 * won. */
__asm__(".text\n.p2align 4\n.globl eomc_rollout_fiber_switch\n.hidden eomc_rollout_fiber_switch\n"
        ".type eomc_rollout_fiber_switch, @function\n"
        "eomc_rollout_fiber_switch:\n"
        "\tpushq %rbp\n\tpushq %rbx\n\tpushq %r12\n\tpushq %r13\n\tpushq %r14\n\tpushq %r15\n"
        "\tmovq %rsp, (%rdi)\n\tmovq %rsi, %rsp\n"
        "\tpopq %r15\n\tpopq %r14\n\tpopq %r13\n\tpopq %r12\n\tpopq %rbx\n\tpopq %rbp\n\tret\n"
        ".size eomc_rollout_fiber_switch, .-eomc_rollout_fiber_switch\n");
void eomc_rollout_fiber_switch(void **from, void *to) __attribute__((visibility("hidden")));
typedef void *fiber_ctx;           /* the fiber's saved stack pointer */
#define fiber_jump(from, to) eomc_rollout_fiber_switch((from), *(to))
#else
typedef ucontext_t fiber_ctx;
#define fiber_jump(from, to) swapcontext((from), (to))
#endif

/* Under AddressSanitizer (-fsanitize=address) every switch is announced to it
 * (__sanitizer_start_switch_fiber before, __sanitizer_finish_switch_fiber after), so it knows
 * which stack runs -- the hand-written switch is invisible to it otherwise.  Without ASan these
 * are nothing and the build is the same. */
#ifdef __SANITIZE_ADDRESS__
#include <sanitizer/common_interface_defs.h>
#define EOMC_ASAN_FIBERS 1
#endif

typedef struct fiber {
    fiber_ctx ctx;
#ifdef EOMC_ASAN_FIBERS
    void *fake;            /* ASan's fake stack of the fiber while it is switched out */
#endif
    double *work;
    char *stack;
    int state, result;
    int row;               /* the row it runs (take_row) */
    double t;
    const double *x, *p, *r;
    double *out;
    eomc_fs_request *req;  /* lanes_terms_lu: what the row's step asks for (want), NULL: nothing */
    int asm_req;           /* 1: no model call, an assembly pass over out (lanes_terms_lu with t NaN) */
    double *wbuf[2];       /* the row's buffers a round wrote last (its T and T1): ... */
    int wob[2], wcol[2];   /* ... into which batch buffer and column, ... */
    long wround[2];        /* ... in which round (lanes_sched.round; -1: none) */
    double *ahead;         /* nu + nq: the next try's du and rate (eomc_fs_assemble_lanes) */
    double *pend[2];       /* out buffers (the row's T and T1) holding only the tested outputs of a
                              batch's column yet (NULL: none) ... */
    int pend_ob[2], pend_col[2];   /* ... which batch buffer (lanes_sched.OUTS) and column has them */
} fiber;

typedef struct lanes_sched {
    rollout_job *job;
    fiber_ctx main;
    fiber *f;
    int cur;
#ifdef EOMC_ASAN_FIBERS
    void *main_fake;               /* ASan: the thread's fake stack while a fiber runs */
    const void *main_bottom;       /* ASan: the thread's own stack, told to it when a fiber */
    size_t main_size;              /* switches back */
#endif
    eomc_options opt;      /* the job's, its implicit below */
    eomc_implicit imp;     /* the job's, its terms lanes_terms (and terms_lu lanes_terms_lu) */
    eomc_fs_lanes *lw;     /* NULL, or the step's assembly in lanes (eomc_fixedstep.h) */
    int cur_ob;            /* the batch buffer the last round wrote */
    double *OUTS[2];       /* the batch's outputs, rounds alternating between the two (lanes_rows) */
    double *pad;           /* job->batch_rows: the padding lanes' row (out_len doubles) */
    double *rowp[2][64];   /* job->batch_rows: each lane's row in the last round that wrote OUTS[b] */
    long round, ob_round[2];   /* rounds made, and the one that wrote OUTS[b] last */
    int asm_min;           /* lanes_pass: the fewest rows a pass over one batch buffer is made for */
    const size_t *hot, *var;   /* the outputs copied at once (eomc_fs_tested_outputs), and all a ... */
    size_t nhot, nvar;         /* ... call writes (not NAME_implicit_const's: var_outputs) */
} lanes_sched;

static __thread lanes_sched *cur_sched;

/* Fiber f to the thread's scheduler; returns when the scheduler resumes it.  last: f is done
 * and never resumed (ASan drops its fake stack). */
static void to_main(lanes_sched *s, fiber *f, int last)
{
#ifdef EOMC_ASAN_FIBERS
    __sanitizer_start_switch_fiber(last ? NULL : &f->fake, s->main_bottom, s->main_size);
#else
    (void)last;
#endif
    fiber_jump(&f->ctx, &s->main);
#ifdef EOMC_ASAN_FIBERS
    __sanitizer_finish_switch_fiber(f->fake, &s->main_bottom, &s->main_size);
#endif
}

/* The scheduler to fiber f; returns when f switches back. */
static void to_fiber(lanes_sched *s, fiber *f)
{
#ifdef EOMC_ASAN_FIBERS
    __sanitizer_start_switch_fiber(&s->main_fake, f->stack, FIBER_STACK);
#endif
    fiber_jump(&s->main, &f->ctx);
#ifdef EOMC_ASAN_FIBERS
    __sanitizer_finish_switch_fiber(s->main_fake, NULL, NULL);
#endif
}

static int lanes_terms(double t, const double *x, const double *p, const double *r, double *out, double *work)
{
    lanes_sched *s = cur_sched;
    fiber *f = &s->f[s->cur];
    (void)work;
    f->t = t; f->x = x; f->p = p; f->r = r; f->out = out;
    f->req = NULL;
    f->asm_req = 0;
    f->state = FIBER_WAITING;
    to_main(s, f, 0);
    return f->result;
}

/* lanes_terms, and what req asks for (eomc_implicit.terms_lu): made with the other rows of the
 * batch when it holds a whole group of lanes (req->done, req->ahead; else 0).  t NaN
 * (eomc_integrators.c's fs_assemble_lu, eomc_fs_ops.assemble_lu): no model call, out holds the
 * terms at x; the fiber waits for an assembly pass (lanes_pass) with the other rows that wait so. */
static int lanes_terms_lu(double t, const double *x, const double *p, const double *r, double *out,
                          eomc_fs_request *req, double *work)
{
    lanes_sched *s = cur_sched;
    fiber *f = &s->f[s->cur];
    (void)work;
    f->asm_req = isnan(t);
    if (!f->asm_req) f->t = t;           /* a pass keeps the row's last call time */
    f->x = x; f->p = p; f->r = r; f->out = out;
    f->req = req;
    req->done = req->ahead = 0;
    f->state = FIBER_WAITING;
    to_main(s, f, 0);
    return f->result;
}

static void fiber_main(void)
{
    lanes_sched *s = cur_sched;
    fiber *f = &s->f[s->cur];
#ifdef EOMC_ASAN_FIBERS
    __sanitizer_finish_switch_fiber(NULL, &s->main_bottom, &s->main_size);   /* its first entry */
#endif
    for (;;) {
        run_row(s->job, f->row, f->work, &s->opt);
        if ((f->row = take_row(s->job)) < 0) break;  /* the job's next row */
        f->pend[0] = f->pend[1] = NULL;              /* the row before's: nothing it needs */
        f->wround[0] = f->wround[1] = -1;
    }
    f->state = FIBER_DONE;
    to_main(s, f, 1);                    /* not resumed */
}

static void resume(lanes_sched *s, int i)
{
    s->cur = i;
    s->f[i].state = FIBER_RUNNING;
    to_fiber(s, &s->f[i]);
}

/* Fiber i waits for a call with fiber first's time and parameters (the batch's one t and p).
 * The time only when NAME_implicit reads it (job->reads_t): a split step's sub-steps end an ulp
 * off the whole step's t + h (0.014 against 0.014000000000000002), and on G1 an exact test left
 * 15 % of the calls out of the batch, in rounds of 7 rows and alone. */
static int same_call(const lanes_sched *s, int first, int i)
{
    const fiber *a = &s->f[first], *b = &s->f[i];
    return b->state == FIBER_WAITING && !b->asm_req && (!s->job->reads_t || a->t == b->t)
           && (a->p == b->p || s->job->p_stride == 0
               || memcmp(a->p, b->p, (size_t)s->job->m->nparam * sizeof(double)) == 0);
}

/* Fiber f's context: its stack, fiber_main to run.  0, or 1 when it could not be made. */
static int make_fiber(fiber *f)
{
#if defined(__x86_64__) && defined(__GNUC__) && defined(__linux__) && !defined(EOMC_FIBER_UCONTEXT)
    /* what eomc_rollout_fiber_switch pops: six registers, then fiber_main as the return
     * address, entered with the stack as a call leaves it (16-byte aligned + 8) */
    void **sp = (void **)(((size_t)(f->stack + FIBER_STACK)) & ~(size_t)15);
    *--sp = NULL;                            /* fiber_main's return address: it never returns */
    *--sp = (void *)(size_t)fiber_main;
    for (int k = 0; k < 6; k++) *--sp = NULL;
    f->ctx = (void *)sp;
    return 0;
#else
    /* getcontext returns twice: kept out of lanes_rows, whose locals it would clobber */
    if (getcontext(&f->ctx) != 0) return 1;
    f->ctx.uc_stack.ss_sp = f->stack;
    f->ctx.uc_stack.ss_size = FIBER_STACK;
    f->ctx.uc_link = NULL;
    makecontext(&f->ctx, fiber_main, 0);
    return 0;
#endif
}

/* The batch's outputs into the rows' buffers, lazily.  Why: the copy of every output of the batch's
 * columns into each row's buffer was a tenth to a fifth of the lanes rollout (rdtsc in lanes_rows,
 * bench_rollout_contacts' 64 rows: G1 10 %, ant 21 %, hopper 13 %), while a row whose try the lanes
 * answered reads only its tests' outputs there (eomc_fs_tested_outputs: G1 294 of its 3400) until
 * its step splits or its lane failed.  So each round copies those at once and leaves the buffer
 * pending on its column; the rest comes when the row's code asks (eomc_implicit.terms_whole:
 * lanes_whole), or before another round writes that batch buffer (two alternate, so a row's T from
 * the round before stays there for the split that may follow), or never, when the row's next call
 * writes the buffer again first.  A copy: the same bits either way. */

/* Fiber f's pending buffer p made whole from its column (the outputs a call writes). */
static void materialize(const lanes_sched *s, fiber *f, int p)
{
    const size_t L = (size_t)s->job->lanes;
    const double *src = s->OUTS[f->pend_ob[p]] + f->pend_col[p];
    double *dst = f->pend[p];
    for (size_t i = 0; i < s->nvar; i++) dst[s->var[i]] = src[s->var[i] * L];
    f->pend[p] = NULL;
}

/* Fiber f's buffer out is written anew (a call into it): what was pending there is not needed. */
static void drop_pending(fiber *f, const double *out)
{
    for (int p = 0; p < 2; p++)
        if (f->pend[p] == out) f->pend[p] = NULL;
}

/* Before a round writes batch buffer ob: every row's buffer still pending on it made whole. */
static void settle(const lanes_sched *s, int ob)
{
    for (int i = 0; i < s->job->lanes; i++)
        for (int p = 0; p < 2; p++)
            if (s->f[i].pend[p] && s->f[i].pend_ob[p] == ob) materialize(s, &s->f[i], p);
}

/* eomc_implicit.terms_whole of the lanes' rows: the running row's buffer out made whole. */
static void lanes_whole(double *out)
{
    lanes_sched *s = cur_sched;
    fiber *f = &s->f[s->cur];
    for (int p = 0; p < 2; p++)
        if (f->pend[p] == out) materialize(s, f, p);
}

/* Row f's call in column c of batch buffer ob: its tested outputs now, the rest pending. */
static void copy_tested(const lanes_sched *s, fiber *f, int ob, int c)
{
    const size_t L = (size_t)s->job->lanes;
    const double *src = s->OUTS[ob] + c;
    double *dst = f->out;
    int p = f->pend[0] == NULL ? 0 : f->pend[1] == NULL ? 1 : -1;
    for (size_t i = 0; i < s->nhot; i++) dst[s->hot[i]] = src[s->hot[i] * L];
    if (p < 0) {            /* not seen: a row has two buffers (its T and T1), dropped when written */
        materialize(s, f, 0);
        p = 0;
    }
    f->pend[p] = dst;
    f->pend_ob[p] = ob;
    f->pend_col[p] = c;
}

/* The outputs a call writes (var, their count returned): every one, except the constant outputs
 * of a model whose terms write only the others (eomc_implicit.terms_const, found as the outputs it
 * writes over a NaN sentinel): the fast path wrote those once into every buffer it hands terms
 * (eomc_fixedstep.c), so they are there already.  Measured (one-process A/B, before the copy was
 * lazy): G1 (1873 of its 3400 outputs constant) 6.4 % off the lanes rollout.  -1 when out of
 * memory. */
static long var_outputs(const eomc_implicit *imp, size_t n, size_t *var)
{
    const unsigned long long sentinel = 0x7ff4dead0000beefULL;   /* a signalling NaN's bits */
    double *probe = NULL;
    size_t k = 0;
    if (imp->terms_const) {
        if ((probe = (double *)malloc(n * sizeof(double) + 1)) == NULL) return -1;
        for (size_t e = 0; e < n; e++) memcpy(probe + e, &sentinel, sizeof sentinel);
        imp->terms_const(probe);
    }
    for (size_t e = 0; e < n; e++)
        if (!probe || memcmp(probe + e, &sentinel, sizeof sentinel) == 0) var[k++] = e;   /* not written */
    free(probe);
    return (long)k;
}

/* The batch's rows (its first k lanes; the others pad it) that asked for their step
 * (lanes_terms_lu) and whose model call succeeded get it from one eomc_fs_assemble_lanes over the
 * batch's columns; a row whose pivot test fails there is left to do it itself (the scalar code,
 * the same failure). */
static void lanes_assemble(lanes_sched *s, const int *idx, int k, const int *ibuf, const double *X,
                           const double *OUT)
{
    const int L = s->job->lanes;
    eomc_fs_request *req[64];
    double *ahead[64];
    int any = 0;
    for (int c = 0; c < L; c++) {
        fiber *q = c < k ? &s->f[idx[c]] : NULL;
        req[c] = q && ibuf[c] == EOMC_OK ? q->req : NULL;
        ahead[c] = q ? q->ahead : NULL;
        any |= req[c] != NULL;
    }
    if (!any) return;
    eomc_fs_assemble_lanes(s->lw, OUT, X + (size_t)s->job->m->nq * L, req, ahead,
                           s->job->batch_rows ? (const double *const *)s->rowp[s->cur_ob] : NULL, s->job->blk0,
                           s->job->blk0 + s->job->blkn);
}

/* A round of k < lanes waiting calls (the rollout's tail: the other fibers are done, or wait with
 * other parameters) is padded to a whole batch with the first row's call, never made by the scalar
 * call: the scalar call's sin and cos are libm's, not the lanes', so a row's bits would depend on
 * which of its calls fell in such a round -- on the rows beside it (session 19 fixed that with rows
 * in fixed groups, each ending in a tail of rounds with fewer rows: ant 64 rows +5 to +9 %).
 * Measured (ant, bench_rollout_contacts' 64 rows, lanes 8, one thread): the groups' tails held
 * 1170 of the 13018 calls in 723 scalar rounds of 1-3 rows and 450 padded ones; with rows from one
 * counter only the rollout's last rows run alone. */

/* Row f's buffer out is column c of batch buffer ob, written by this round. */
static void wrote(const lanes_sched *s, fiber *f, int ob, int c)
{
    int w = f->wbuf[0] == f->out ? 0 : f->wbuf[1] == f->out ? 1 : f->wround[0] <= f->wround[1] ? 0 : 1;
    f->wbuf[w] = f->out;
    f->wob[w] = ob;
    f->wcol[w] = c;
    f->wround[w] = s->round;
}

/* The k fibers idx[] waiting for an assembly pass (lanes_terms_lu with t NaN: a split step's try at
 * another size than its matrix was made for), each resumed with its answer (req->ahead), or none
 * (it assembles its own).  A row whose terms are still a column of a batch buffer (no round wrote
 * that buffer since: the round before's, or this one's) is answered with the others there, at
 * least s->asm_min of them, by one eomc_fs_assemble_lanes over that buffer: each in its own column,
 * as at a model call, so each lane the scalar code's bits; the other columns' rows go along
 * unasked.  Why over the columns where they are: a prototype that copied each row's terms into
 * columns first (session 29, rollpy) spent more on the copy than the pass saved, and one that
 * gathered each lane's terms from its own place (session 30) made the pass dearer than the
 * rows' own assemblies. */
static void lanes_pass(lanes_sched *s, double *X, const int *idx, int k)
{
    rollout_job *job = s->job;
    const int L = job->lanes, nq = job->m->nq, nu = job->m->nu;
    int at[64], n[2] = {0, 0};
    for (int c = 0; c < k; c++) {                     /* where each row's terms are: ob * L + column */
        const fiber *q = &s->f[idx[c]];
        int w = q->wbuf[0] == q->out ? 0 : q->wbuf[1] == q->out ? 1 : -1;
        at[c] = w >= 0 && q->wround[w] == s->ob_round[q->wob[w]] ? q->wob[w] * L + q->wcol[w] : -1;
        if (at[c] >= 0) n[at[c] / L]++;
    }
    for (int ob = 0; ob < 2; ob++) {
        eomc_fs_request *req[64];
        double *ahead[64];
        if (n[ob] < s->asm_min) continue;
        for (int c = 0; c < L; c++) {
            req[c] = NULL;
            ahead[c] = NULL;
        }
        for (int c = 0; c < k; c++) {
            const fiber *q = &s->f[idx[c]];
            const int col = at[c] - ob * L;
            if (at[c] < 0 || at[c] / L != ob) continue;
            req[col] = q->req;
            ahead[col] = q->ahead;
            for (int j = 0; j < nu; j++) X[(size_t)(nq + j) * L + col] = q->x[nq + j];   /* its speeds */
        }
        eomc_fs_assemble_lanes(s->lw, s->OUTS[ob], X + (size_t)nq * L, req, ahead,
                               job->batch_rows ? (const double *const *)s->rowp[ob] : NULL, job->blk0,
                               job->blk0 + job->blkn);
    }
    for (int c = 0; c < k; c++) {
        s->f[idx[c]].result = EOMC_OK;
        s->f[idx[c]].asm_req = 0;
    }
    for (int c = 0; c < k; c++) resume(s, idx[c]);
}

/* The thread's fibers (made) each on the job's next row, then each fiber the job's next row when
 * its row ends (take_row); their calls in rounds.  X, R: the batch's input columns (nx, then
 * ninput rows of lanes doubles), ibuf, idx: lanes ints each, mwork: the model's work. */
static void lanes_run(lanes_sched *s, double *X, double *R, int *ibuf, int *idx, double *mwork)
{
    rollout_job *job = s->job;
    fiber *f = s->f;
    const int L = job->lanes, nx = job->m->nx, nr = job->m->ninput;
    for (int i = 0; i < L; i++) {
        f[i].pend[0] = f[i].pend[1] = NULL;
        f[i].wround[0] = f[i].wround[1] = -1;
        f[i].state = FIBER_DONE;
        f[i].asm_req = 0;
        f[i].row = take_row(job);
    }
    s->ob_round[0] = s->ob_round[1] = -2;
    for (int i = 0; i < L; i++)          /* each to its first call, or done */
        if (f[i].row >= 0) resume(s, i);
    for (;;) {
        int first = -1, k = 0, ob;
        for (int i = 0; i < L; i++)      /* the rows that wait for an assembly first: their pass, then
                                            their tries' model calls join this round */
            if (f[i].state == FIBER_WAITING && f[i].asm_req) idx[k++] = i;
        if (k > 0) {
            lanes_pass(s, X, idx, k);
            continue;
        }
        /* the earliest call first: rows ahead in time wait for the others (a split step's
           sub-steps catch up), so the rows stay in step and the calls fill the lanes */
        for (int i = 0; i < L; i++)
            if (f[i].state == FIBER_WAITING && (first < 0 || f[i].t < f[first].t)) first = i;
        if (first < 0) break;                         /* every fiber done */
        for (int i = 0; i < L; i++)      /* from 0: a row before first may wait at another t */
            if (same_call(s, first, i)) idx[k++] = i;
        for (int c = 0; c < k; c++) drop_pending(&f[idx[c]], f[idx[c]].out);   /* written anew */
        for (int c = 0; c < L; c++) {    /* lanes k .. L - 1 pad: the first row's call again */
            const fiber *q = &f[idx[c < k ? c : 0]];
            for (int j = 0; j < nx; j++) X[(size_t)j * L + c] = q->x[j];
            for (int j = 0; j < nr; j++) R[(size_t)j * L + c] = q->r[j];
        }
        ob = s->cur_ob ^= 1;
        settle(s, ob);
        if (job->batch_rows) {           /* the pairs' block straight into each row's buffer */
            for (int c = 0; c < L; c++) s->rowp[ob][c] = c < k ? f[idx[c]].out : s->pad;
            job->batch_rows(L, f[first].t, X, f[first].p, nr ? R : NULL, s->OUTS[ob], s->rowp[ob], ibuf, mwork);
        } else
            job->batch(L, f[first].t, X, f[first].p, nr ? R : NULL, s->OUTS[ob], ibuf, mwork);
        s->ob_round[ob] = ++s->round;
        if (s->lw) lanes_assemble(s, idx, k, ibuf, X, s->OUTS[ob]);
        for (int c = 0; c < k; c++) {
            wrote(s, &f[idx[c]], ob, c);
            f[idx[c]].result = ibuf[c];
            copy_tested(s, &f[idx[c]], ob, c);
        }
        for (int c = 0; c < k; c++) resume(s, idx[c]);
    }
}

/* One thread's rows (lanes_run).  buf: the
 * batch's columns (nx + ninput rows of lanes doubles, then two buffers of out_len rows: OUTS;
 * 64-byte aligned), ibuf, idx: lanes ints each, mwork: the model's work, lw: NULL or the assembly
 * in lanes, hot, var: lanes_sched's.  0, or 1 when a fiber's context could not be made. */
static int lanes_rows(rollout_job *job, fiber *f, double *buf, int *ibuf, int *idx, double *mwork,
                      eomc_fs_lanes *lw, const size_t *hot, size_t nhot, const size_t *var, size_t nvar, double *pad)
{
    lanes_sched s;
    const int nx = job->m->nx, nr = job->m->ninput, L = job->lanes;
    double *X = buf, *R = X + (size_t)nx * L;
    memset(&s, 0, sizeof s);
    s.job = job; s.f = f; s.lw = lw;
    s.OUTS[0] = R + (size_t)nr * L;
    s.OUTS[1] = s.OUTS[0] + job->out_len * (size_t)L;
    s.hot = hot; s.nhot = nhot; s.var = var; s.nvar = nvar;
    s.pad = pad;
    {
        const char *e = getenv("EOMC_LANES_ASM_MIN");
        s.asm_min = e ? (int)strtol(e, NULL, 10) : 3;
    }
    s.opt = *job->opt;
    s.imp = *job->opt->implicit;
    s.imp.terms = lanes_terms;
    s.imp.terms_lu = lw ? lanes_terms_lu : NULL;
    s.imp.terms_whole = lanes_whole;
    s.opt.implicit = &s.imp;
    for (int i = 0; i < L; i++)          /* before any row is taken: the others can run them */
        if (make_fiber(&f[i])) return 1;
    cur_sched = &s;
    lanes_run(&s, X, R, ibuf, idx, mwork);
    cur_sched = NULL;
    return 0;
}

/* A thread of the lanes path: its fibers' stacks and work buffers, then lanes_rows. */
static void *lanes_fiber_worker(rollout_job *job)
{
    const int L = job->lanes;
    const eomc_implicit *imp = job->opt->implicit;
    const int nfree = imp->nfree > 0 ? imp->nfree : 0;
    const size_t cols = (size_t)job->m->nx + (size_t)job->m->ninput + 2 * job->out_len;
    const size_t nhot_max = 4 * (size_t)imp->ncontact + 2 * (size_t)job->m->nu + 6 * (size_t)job->m->nq * (size_t)nfree
                            + 1;
    fiber *f = (fiber *)calloc((size_t)L, sizeof(fiber));
    double *mem = (double *)malloc(cols * (size_t)L * sizeof(double) + 64);
    double *buf = mem ? (double *)(((size_t)mem + 63) & ~(size_t)63) : NULL;   /* the columns: aligned */
    double *mwork = (double *)malloc(((size_t)job->m->work_size + 1) * sizeof(double));
    int *ibuf = (int *)malloc(2 * (size_t)L * sizeof(int));
    size_t *hot = (size_t *)malloc((nhot_max + job->out_len + 1) * sizeof(size_t)), *var = hot ? hot + nhot_max : NULL;
    size_t nhot = hot ? eomc_fs_tested_outputs(job->m->nq, job->m->nu, imp, hot) : 0;
    long nvar = var ? var_outputs(imp, job->out_len, var) : -1;
    /* NULL (no vector kernel for L here, or a model without the fast path's structure): each row
     * assembles its own step, as before */
    eomc_fs_lanes *lw = imp->terms_lu == NULL ? eomc_fs_lanes_new(job->m->nq, job->m->nu, imp, L) : NULL;
    /* zeros: the pairs' loop keeps its block there too (it zeroes only the records it wrote) */
    double *pad = job->batch_rows ? (double *)calloc(job->out_len, sizeof(double)) : NULL;
    int ok = f && buf && mwork && ibuf && hot && nvar >= 0 && (pad || !job->batch_rows), failed = 1;
    if (ok) {               /* the tested outputs that a call writes (a constant one is there) */
        unsigned char *written = (unsigned char *)calloc(job->out_len + 1, 1);
        size_t k = 0, v = 0;
        if ((ok = written != NULL)) {
            for (long i = 0; i < nvar; i++) written[var[i]] = 1;
            for (size_t i = 0; i < nhot; i++)
                if (written[hot[i]]) hot[k++] = hot[i];
            nhot = k;
        }
        free(written);
        /* batch_rows: the block is in the rows' buffers already (written there by the call), so
           neither copied at once nor materialized from the columns, which do not hold it */
        for (k = 0; job->batch_rows && k < nhot; k++)
            if (hot[k] < job->blk0 || hot[k] >= job->blk0 + job->blkn) hot[v++] = hot[k];
        if (job->batch_rows) nhot = v;
        for (v = 0, k = 0; job->batch_rows && k < (size_t)nvar; k++)
            if (var[k] < job->blk0 || var[k] >= job->blk0 + job->blkn) var[v++] = var[k];
        if (job->batch_rows) nvar = (long)v;
    }
    for (int i = 0; ok && i < L; i++) {
        f[i].stack = (char *)malloc(FIBER_STACK);
        f[i].work = (double *)malloc(job->work_len * sizeof(double));
        f[i].ahead = (double *)malloc((size_t)job->m->nx * sizeof(double));
        ok = f[i].stack && f[i].work && f[i].ahead;
    }
    if (ok)
        failed = lanes_rows(job, f, buf, ibuf, ibuf + L, mwork, lw, hot, nhot, var, (size_t)nvar, pad);
    for (int i = 0; f && i < L; i++) {
        free(f[i].stack);
        free(f[i].work);
        free(f[i].ahead);
    }
    free(f); free(mem); free(mwork); free(ibuf); free(hot); free(pad);
    eomc_fs_lanes_free(lw);
    return failed ? (void *)job : NULL;  /* not NULL: this thread could not run; the others take its rows */
}

static void *worker(void *arg)
{
    rollout_job *job = (rollout_job *)arg;
    double *work;
    if (job->batch || job->batch_rows)
        return lanes_fiber_worker(job);
    work = (double *)malloc(job->work_len * sizeof(double));
    if (work == NULL)
        return arg;      /* not NULL: this thread could not run; the others take its rows */
    run_rows(job, work, job->opt);
    free(work);
    return NULL;
}

/* Runs fn(job) on the calling thread and on nthreads - 1 started ones, and waits for them.
   Returns 1 when at least one of them got its work buffer (fn returned NULL), else 0. */
static int run_threads(void *(*fn)(void *), void *job, int nthreads)
{
    pthread_t threads[EOMC_ROLLOUT_MAX_THREADS];
    int started = 0, k, ran = 0;
    for (k = 1; k < nthreads; ++k) {
        if (pthread_create(&threads[k], NULL, fn, job) != 0)
            break;
        ++started;
    }
    if (fn(job) == NULL)
        ran = 1;
    for (k = 1; k <= started; ++k) {
        void *res = NULL;
        pthread_join(threads[k], &res);
        if (res == NULL)
            ran = 1;
    }
    return ran;
}

int eomc_rollout(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                 int n, const double *X0, const double *P, size_t p_stride,
                 int n_eval, const double *t_eval, double *X_out, double *X_last,
                 int *status, long *steps, int nthreads)
{
    return eomc_rollout_stats(m, opt, t0, t1, n, X0, P, p_stride, 0, NULL, NULL, 0, n_eval, t_eval, X_out,
                              X_last, status, steps, NULL, nthreads);
}

int eomc_rollout_stats(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                       int n, const double *X0, const double *P, size_t p_stride,
                       int n_rgrid, const double *r_tgrid, const double *R, size_t r_stride,
                       int n_eval, const double *t_eval, double *X_out, double *X_last,
                       int *status, long *steps, eomc_stats *stats, int nthreads)
{
    return eomc_rollout_ex(m, opt, t0, t1, n, X0, P, p_stride, n_rgrid, r_tgrid, R, r_stride, NULL,
                           n_eval, t_eval, X_out, X_last, status, steps, stats, nthreads);
}

/* The extras' buffers are there (the per-row checks are eomc_integrate_ex's). */
static int extras_ok(const eomc_rollout_extras *ex)
{
    if (ex == NULL)
        return 1;
    if (ex->fb && (ex->fb->fn != NULL || (ex->fb->K == NULL && (ex->K_stride || ex->ref_stride))))
        return 0;
    if (ex->ev && (ex->t_rec == NULL || ex->id_rec == NULL || ex->x_rec == NULL || ex->n_rec == NULL
                   || ex->terminated == NULL || ex->ev->capacity < 0 || ex->ev->n < 0 || ex->ev->nlin < 0
                   || (ex->gmax && ex->gmax_len < (size_t)ex->ev->n + (size_t)ex->ev->nlin)))
        return 0;
    return 1;
}

static int rollout_rows(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                        int n, const double *X0, const double *P, size_t p_stride,
                        int n_rgrid, const double *r_tgrid, const double *R, size_t r_stride,
                        const eomc_rollout_extras *ex,
                        int n_eval, const double *t_eval, double *X_out, double *X_last,
                        int *status, long *steps, eomc_stats *stats, int nthreads,
                        eomc_batch_fn batch, int lanes, size_t out_len, int reads_t,
                        eomc_batch_rows_fn batch_rows, size_t blk0, size_t blkn)
{
    rollout_job job;
    int k, ran;
    if (m == NULL || opt == NULL || n < 0 || X0 == NULL || P == NULL || X_last == NULL
        || status == NULL || (n_eval > 0 && (t_eval == NULL || X_out == NULL))
        || (n_rgrid > 0 && R == NULL) || (n_rgrid > 1 && r_tgrid == NULL) || !extras_ok(ex))
        return EOMC_BAD_ARGUMENT;
    if (nthreads <= 0)
        nthreads = 1;
    if (nthreads > EOMC_ROLLOUT_MAX_THREADS)
        nthreads = EOMC_ROLLOUT_MAX_THREADS;
    if (nthreads > n)
        nthreads = n > 0 ? n : 1;
    /* lanes: a thread a whole batch of rows at least */
    if ((batch || batch_rows) && nthreads > (n + lanes - 1) / lanes)
        nthreads = n > 0 ? (n + lanes - 1) / lanes : 1;
    job.m = m; job.opt = opt; job.t0 = t0; job.t1 = t1; job.n = n;
    job.X0 = X0; job.P = P; job.p_stride = p_stride;
    job.n_rgrid = n_rgrid > 0 ? n_rgrid : 0; job.r_tgrid = r_tgrid; job.R = R; job.r_stride = r_stride;
    job.n_eval = n_eval; job.t_eval = t_eval; job.X_out = n_eval > 0 ? X_out : NULL;
    job.X_last = X_last; job.status = status; job.steps = steps; job.stats = stats;
    job.ex = ex;
    job.batch = batch; job.lanes = lanes; job.out_len = out_len; job.reads_t = reads_t;
    job.batch_rows = batch_rows; job.blk0 = blk0; job.blkn = blkn;
    job.ev_scratch = ex && ex->ev ? eomc_events_scratch_size(m, ex->ev->ncol, ex->ev->n) : 0;
    job.sw_scratch = ex && ex->ev && (ex->ev->nlin > 0 || ex->ev->switching)
                     ? eomc_switch_scratch_size(ex->ev->n, ex->ev->nlin) : 0;
    job.work_len = eomc_integrate_work_size(m, opt->method)
                   + (opt->method == EOMC_IMPLICITFAST && opt->implicit ? opt->implicit->work_len : 0)
                   + (ex ? eomc_feedback_work_size(m, ex->fb) : 0) + job.ev_scratch + job.sw_scratch;
    job.next = 0;
    job.sigint0 = opt->interrupt_base > 0 ? opt->interrupt_base - 1 : eomc_interrupt_count();
    for (k = 0; k < n; ++k)
        status[k] = EOMC_ABORTED;        /* until its run says otherwise */
    if (pthread_mutex_init(&job.lock, NULL) != 0)
        return EOMC_BAD_ARGUMENT;
    /* The calling thread is worker 0; nthreads - 1 more are started. */
    ran = run_threads(worker, &job, nthreads);
    pthread_mutex_destroy(&job.lock);
    if (!ran)
        return EOMC_BAD_ARGUMENT;        /* no thread got a work buffer */
    for (k = 0; k < n; ++k)
        if (status[k] != EOMC_OK)
            return status[k];
    return EOMC_OK;
}

int eomc_rollout_ex(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                    int n, const double *X0, const double *P, size_t p_stride,
                    int n_rgrid, const double *r_tgrid, const double *R, size_t r_stride,
                    const eomc_rollout_extras *ex,
                    int n_eval, const double *t_eval, double *X_out, double *X_last,
                    int *status, long *steps, eomc_stats *stats, int nthreads)
{
    return rollout_rows(m, opt, t0, t1, n, X0, P, p_stride, n_rgrid, r_tgrid, R, r_stride, ex, n_eval, t_eval,
                        X_out, X_last, status, steps, stats, nthreads, NULL, 0, 0, 1, NULL, 0, 0);
}

int eomc_rollout_implicit_lanes(const eomc_model *m, const eomc_options *opt, eomc_batch_fn batch, int lanes,
                                size_t out_len, int reads_t, double t0, double t1, int n, const double *X0, const double *P,
                                size_t p_stride, int n_rgrid, const double *r_tgrid, const double *R,
                                size_t r_stride, int n_eval, const double *t_eval, double *X_out,
                                double *X_last, int *status, long *steps, eomc_stats *stats, int nthreads)
{
    if (batch == NULL || lanes < 1 || lanes > 64 || opt == NULL || opt->method != EOMC_IMPLICITFAST
        || opt->implicit == NULL || opt->implicit->terms == NULL || out_len == 0)
        return EOMC_BAD_ARGUMENT;
    return rollout_rows(m, opt, t0, t1, n, X0, P, p_stride, n_rgrid, r_tgrid, R, r_stride, NULL, n_eval, t_eval,
                        X_out, X_last, status, steps, stats, nthreads, batch, lanes, out_len, reads_t != 0,
                        NULL, 0, 0);
}

int eomc_rollout_implicit_lanes_rows(const eomc_model *m, const eomc_options *opt, eomc_batch_rows_fn batch_rows,
                                     size_t block_first, size_t block_len, int lanes, size_t out_len, int reads_t,
                                     double t0, double t1, int n, const double *X0, const double *P,
                                     size_t p_stride, int n_rgrid, const double *r_tgrid, const double *R,
                                     size_t r_stride, int n_eval, const double *t_eval, double *X_out,
                                     double *X_last, int *status, long *steps, eomc_stats *stats, int nthreads)
{
    if (batch_rows == NULL || lanes < 1 || lanes > 64 || opt == NULL || opt->method != EOMC_IMPLICITFAST
        || opt->implicit == NULL || opt->implicit->terms == NULL || out_len == 0 || block_len == 0
        || block_first > out_len || block_len > out_len - block_first)
        return EOMC_BAD_ARGUMENT;
    return rollout_rows(m, opt, t0, t1, n, X0, P, p_stride, n_rgrid, r_tgrid, R, r_stride, NULL, n_eval, t_eval,
                        X_out, X_last, status, steps, stats, nthreads, NULL, lanes, out_len, reads_t != 0,
                        batch_rows, block_first, block_len);
}

/* ------------------------------------------------------------ RK4 in lanes */

typedef struct lanes_job {
    eomc_batch_fn f;
    int nx, nparam, ninput, block;
    int n_rgrid;         /* each row's input grid: r_tgrid (shared), R + row * r_stride */
    const double *r_tgrid, *R;
    size_t r_stride;
    size_t work_len;
    double t0, t1, h;
    long nsteps;
    int n;
    const double *X0, *P;
    size_t p_stride;
    double *X_out, *X_last;
    int *status;
    long *steps;
    int nquat;           /* unit quaternions in x: their w rows (eomc_options.nquat, .quat) */
    const int *quat;
    pthread_mutex_t lock;
    int next;            /* first row of the next block, under lock */
    long sigint0;        /* eomc_interrupt_count() at the start: once it changes, no block is handed out */
} lanes_job;

static int take_block(lanes_job *job, int *m)
{
    int i;
    pthread_mutex_lock(&job->lock);
    i = job->next < job->n && eomc_interrupt_count() == job->sigint0 ? job->next : -1;
    if (i >= 0) {
        *m = job->n - i < job->block ? job->n - i : job->block;
        job->next += *m;
    }
    pthread_mutex_unlock(&job->lock);
    return i;
}

/* Each live lane's quaternions scaled to length 1, and f's (may be NULL) quaternion rows by the
 * same factor: eomc_integrators.c's unit_quats on every lane, in its order of arithmetic (a zero
 * or non-finite quaternion is left for the rhs to report), so a lane keeps the scalar row's bits. */
static void lane_quats(const lanes_job *job, int m, const char *dead, double *x, double *f)
{
    const size_t cols = (size_t)m;
    int k, q, j;
    for (k = 0; k < m; ++k) {
        if (dead[k])
            continue;
        for (q = 0; q < job->nquat; ++q) {
            double *v = x + (size_t)job->quat[q] * cols + (size_t)k;
            double *g = f ? f + (size_t)job->quat[q] * cols + (size_t)k : NULL;
            double n2 = v[0] * v[0] + v[cols] * v[cols] + v[2 * cols] * v[2 * cols] + v[3 * cols] * v[3 * cols];
            double s;
            if (!(n2 > 0.0) || !isfinite(n2))
                continue;
            s = 1.0 / sqrt(n2);
            for (j = 0; j < 4; ++j) {
                v[(size_t)j * cols] *= s;
                if (g)
                    g[(size_t)j * cols] *= s;
            }
        }
    }
}

/* A stage's statuses: the first failure of a live row ends it (its status kept). */
static int mark(int m, const int *st, char *dead, int *status)
{
    int k, live = 0;
    for (k = 0; k < m; ++k) {
        if (!dead[k] && st[k] != EOMC_OK) {
            dead[k] = 1;
            status[k] = st[k];
        }
        live += !dead[k];
    }
    return live;
}

/* The inputs of rows first .. first + m - 1 at time t as columns (Rb[i*m + k]), by
 * grid_inputs_at's rule and arithmetic (eomc_integrators.c): the grid's first row before
 * it, its last row after it, linear between two rows; NULL when there are none (zeros). */
static const double *lane_inputs(const lanes_job *job, int first, int m, double t, double *Rb)
{
    const int ni = job->ninput, nr = job->n_rgrid;
    const double *rt = job->r_tgrid;
    int lo = 0, hi = nr - 1, i, k, between = 0;
    double w = 0.0;
    if (ni <= 0 || nr <= 0)
        return NULL;
    if (nr == 1 || t <= rt[0]) {
        lo = 0;
    } else if (t >= rt[hi]) {
        lo = hi;
    } else {
        while (hi - lo > 1) {
            const int mid = (lo + hi) / 2;
            if (rt[mid] <= t) lo = mid; else hi = mid;
        }
        w = (t - rt[lo]) / (rt[hi] - rt[lo]);
        between = 1;
    }
    for (k = 0; k < m; ++k) {
        const double *v = job->R + (size_t)(first + k) * job->r_stride;
        const double *a = v + (size_t)lo * (size_t)ni, *b = v + (size_t)hi * (size_t)ni;
        for (i = 0; i < ni; ++i)
            Rb[(size_t)i * (size_t)m + (size_t)k] = between ? (1.0 - w) * a[i] + w * b[i] : a[i];
    }
    return Rb;
}

/* Rows first .. first + m - 1: run_rk4's step grid and arithmetic (eomc_integrators.c), with
 * the m states as columns (x[i*m + k]) and each stage one batch call over all of them. */
static void lanes_block(lanes_job *job, int first, int m, double *buf, int *ibuf)
{
    const int nx = job->nx, np = job->nparam;
    const size_t cols = (size_t)m, nxm = (size_t)nx * cols;
    double *x = buf, *x1 = x + nxm, *k1 = x1 + nxm, *k2 = k1 + nxm, *k3 = k2 + nxm, *k4 = k3 + nxm;
    double *tmp = k4 + nxm, *good = tmp + nxm, *Pb = good + nxm, *Rb = Pb + (size_t)(np > 0 ? np : 1) * cols;
    double *work = Rb + (size_t)(job->ninput > 0 ? job->ninput : 1) * cols;
    int *st = ibuf, *status = st + m;
    char *dead = (char *)(status + m);
    long *done = job->steps ? job->steps + first : NULL;
    const double h = job->h;
    int i, k;
    size_t j;
    for (k = 0; k < m; ++k) {
        const double *x0 = job->X0 + (size_t)(first + k) * (size_t)nx;
        const double *p = job->P + (size_t)(first + k) * job->p_stride;
        for (i = 0; i < nx; ++i) x[(size_t)i * cols + (size_t)k] = x0[i];
        for (i = 0; i < np; ++i) Pb[(size_t)i * cols + (size_t)k] = p[i];
        dead[k] = 0;
        status[k] = EOMC_OK;
        if (done) done[k] = 0;
    }
    if (job->nquat)
        lane_quats(job, m, dead, x, NULL);    /* x0's quaternions made unit, as eomc_integrate's start */
    for (k = 0; k < m && job->X_out; ++k)
        for (i = 0; i < nx; ++i)
            job->X_out[((size_t)(first + k) * (size_t)(job->nsteps + 1)) * (size_t)nx + (size_t)i]
                = x[(size_t)i * cols + (size_t)k];
    memcpy(good, x, nxm * sizeof(double));
    job->f(m, job->t0, x, Pb, lane_inputs(job, first, m, job->t0, Rb), k1, st, work);
    if (mark(m, st, dead, status)) {
        for (long s = 0; s < job->nsteps; ++s) {
            const double t = job->t0 + s * h;
            const double tn = (s == job->nsteps - 1) ? job->t1 : job->t0 + (s + 1) * h, hh = tn - t;
            double *sw;
            int live;
            if (eomc_interrupt_count() != job->sigint0) {   /* Ctrl-C, SIGTERM: the block stops here */
                for (k = 0; k < m; ++k) {
                    double *rest = job->X_out ? job->X_out + ((size_t)(first + k) * (size_t)(job->nsteps + 1)
                                                              + (size_t)(s + 1)) * (size_t)nx : NULL;
                    if (!dead[k]) {
                        dead[k] = 1;
                        status[k] = EOMC_ABORTED;
                    }
                    for (j = 0; rest && j < (size_t)(job->nsteps - s) * (size_t)nx; ++j) rest[j] = NAN;
                }
                break;
            }
            if (done)
                for (k = 0; k < m; ++k) done[k] += !dead[k];
            for (j = 0; j < nxm; ++j) tmp[j] = x[j] + 0.5 * hh * k1[j];
            job->f(m, t + 0.5 * hh, tmp, Pb, lane_inputs(job, first, m, t + 0.5 * hh, Rb), k2, st, work);
            mark(m, st, dead, status);
            for (j = 0; j < nxm; ++j) tmp[j] = x[j] + 0.5 * hh * k2[j];
            job->f(m, t + 0.5 * hh, tmp, Pb, lane_inputs(job, first, m, t + 0.5 * hh, Rb), k3, st, work);
            mark(m, st, dead, status);
            for (j = 0; j < nxm; ++j) tmp[j] = x[j] + hh * k3[j];
            job->f(m, tn, tmp, Pb, lane_inputs(job, first, m, tn, Rb), k4, st, work);
            mark(m, st, dead, status);
            for (j = 0; j < nxm; ++j) x1[j] = x[j] + hh / 6.0 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
            for (k = 0; k < m; ++k) {
                if (dead[k]) continue;
                for (i = 0; i < nx; ++i) {
                    if (!isfinite(x1[(size_t)i * cols + (size_t)k])) {
                        dead[k] = 1;
                        status[k] = EOMC_NONFINITE;
                        break;
                    }
                }
            }
            job->f(m, tn, x1, Pb, lane_inputs(job, first, m, tn, Rb), k2, st, work);   /* k2 := f(tn, x1) */
            live = mark(m, st, dead, status);
            if (job->nquat)
                lane_quats(job, m, dead, x1, k2);     /* after f, as run_rk4: k2 scaled with x1 */
            for (k = 0; k < m; ++k) {
                double *row = job->X_out ? job->X_out + ((size_t)(first + k) * (size_t)(job->nsteps + 1)
                                                         + (size_t)(s + 1)) * (size_t)nx : NULL;
                for (i = 0; i < nx; ++i) {
                    const double v = x1[(size_t)i * cols + (size_t)k];
                    if (!dead[k]) good[(size_t)i * cols + (size_t)k] = v;
                    if (row) row[i] = dead[k] ? NAN : v;
                }
            }
            sw = x; x = x1; x1 = sw;
            sw = k1; k1 = k2; k2 = sw;
            if (!live) {          /* a row that failed has no state at the later steps: NaN */
                for (k = 0; k < m && job->X_out; ++k) {
                    double *rest = job->X_out + ((size_t)(first + k) * (size_t)(job->nsteps + 1)
                                                 + (size_t)(s + 2)) * (size_t)nx;
                    for (j = 0; j < (size_t)(job->nsteps - 1 - s) * (size_t)nx; ++j) rest[j] = NAN;
                }
                break;
            }
        }
    } else if (job->X_out) {
        for (k = 0; k < m; ++k) {
            double *rest = job->X_out + ((size_t)(first + k) * (size_t)(job->nsteps + 1) + 1) * (size_t)nx;
            for (j = 0; j < (size_t)job->nsteps * (size_t)nx; ++j) rest[j] = NAN;
        }
    }
    for (k = 0; k < m; ++k) {
        double *last = job->X_last + (size_t)(first + k) * (size_t)nx;
        for (i = 0; i < nx; ++i) last[i] = good[(size_t)i * cols + (size_t)k];
        job->status[first + k] = status[k];
    }
}

static void *lanes_worker(void *arg)
{
    lanes_job *job = (lanes_job *)arg;
    const size_t b = (size_t)job->block;
    double *buf = (double *)malloc((8 * (size_t)job->nx * b + (size_t)(job->nparam > 0 ? job->nparam : 1) * b
                                    + (size_t)(job->ninput > 0 ? job->ninput : 1) * b + job->work_len + 1)
                                   * sizeof(double));
    int *ibuf = (int *)malloc(2 * b * sizeof(int) + b);
    int first, m;
    if (buf == NULL || ibuf == NULL) {
        free(buf);
        free(ibuf);
        return arg;
    }
    while ((first = take_block(job, &m)) >= 0)
        lanes_block(job, first, m, buf, ibuf);
    free(buf);
    free(ibuf);
    return NULL;
}

int eomc_rollout_lanes(eomc_batch_fn f, int nx, int nparam, int ninput, size_t work_len, double t0, double t1,
                       double h, int n, const double *X0, const double *P, size_t p_stride,
                       int n_rgrid, const double *r_tgrid, const double *R, size_t r_stride, double *X_out,
                       double *X_last, int *status, long *steps, int block, int nthreads, int nquat,
                       const int *quat)
{
    lanes_job job;
    int k, ran, nblocks;
    if (f == NULL || nx <= 0 || nparam < 0 || n < 0 || X0 == NULL || (P == NULL && nparam > 0)
        || X_last == NULL || status == NULL || !(h > 0) || !isfinite(h) || !(t1 > t0) || ninput < 0
        || (ninput > 0 && n_rgrid > 0 && R == NULL) || (n_rgrid > 1 && r_tgrid == NULL)
        || nquat < 0 || (nquat > 0 && quat == NULL))
        return EOMC_BAD_ARGUMENT;
    for (k = 0; k < nquat; ++k)
        if (quat[k] < 0 || quat[k] + 4 > nx)
            return EOMC_BAD_ARGUMENT;
    if (block <= 0)
        block = 64;
    if (nthreads <= 0)
        nthreads = 1;
    if (nthreads > EOMC_ROLLOUT_MAX_THREADS)
        nthreads = EOMC_ROLLOUT_MAX_THREADS;
    nblocks = (n + block - 1) / block;
    if (nthreads > nblocks)
        nthreads = nblocks > 0 ? nblocks : 1;
    job.f = f; job.nx = nx; job.nparam = nparam; job.ninput = ninput; job.block = block; job.work_len = work_len;
    job.n_rgrid = n_rgrid > 0 ? n_rgrid : 0; job.r_tgrid = r_tgrid; job.R = R; job.r_stride = r_stride;
    job.t0 = t0; job.t1 = t1; job.h = h;
    job.nsteps = (long)ceil((t1 - t0) / h * (1 - 1e-12));
    if (job.nsteps < 1)
        job.nsteps = 1;
    job.n = n; job.X0 = X0; job.P = P; job.p_stride = p_stride;
    job.X_out = X_out; job.X_last = X_last; job.status = status; job.steps = steps;
    job.nquat = nquat; job.quat = quat;
    job.next = 0;
    job.sigint0 = eomc_interrupt_count();
    for (k = 0; k < n; ++k)
        status[k] = EOMC_ABORTED;        /* until its block says otherwise */
    if (pthread_mutex_init(&job.lock, NULL) != 0)
        return EOMC_BAD_ARGUMENT;
    ran = run_threads(lanes_worker, &job, nthreads);
    pthread_mutex_destroy(&job.lock);
    if (!ran)
        return EOMC_BAD_ARGUMENT;
    for (k = 0; k < n; ++k)
        if (status[k] != EOMC_OK)
            return status[k];
    return EOMC_OK;
}
