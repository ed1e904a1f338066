/* eomc_rollout.c -- see eomc_rollout.h. */
#define _POSIX_C_SOURCE 200809L
#include <pthread.h>
#include <stdlib.h>
#include "eomc_rollout.h"

#define EOMC_ROLLOUT_MAX_THREADS 1024

typedef struct rollout_job {
    const eomc_model *m;
    const eomc_options *opt;
    double t0, t1;
    int n;
    const double *X0, *P;
    size_t p_stride;
    int n_eval;
    const double *t_eval;
    double *X_out, *X_last;
    int *status;
    long *steps;
    eomc_stats *stats;   /* may be NULL: each row's whole stats */
    size_t work_len;
    pthread_mutex_t lock;
    int next;            /* next row to hand out, under lock */
} rollout_job;

static int take_row(rollout_job *job)
{
    int i;
    pthread_mutex_lock(&job->lock);
    i = job->next < job->n ? job->next++ : -1;
    pthread_mutex_unlock(&job->lock);
    return i;
}

static void run_rows(rollout_job *job, double *work)
{
    const size_t nx = (size_t)job->m->nx;
    int i;
    while ((i = take_row(job)) >= 0) {
        eomc_stats st;
        const size_t row = (size_t)i;
        double *x_out = job->X_out ? job->X_out + row * (size_t)job->n_eval * nx : NULL;
        job->status[i] = eomc_integrate(job->m, job->opt, job->t0, job->t1, job->X0 + row * nx,
                                        job->P + row * job->p_stride, 0, NULL, NULL,
                                        job->n_eval, job->t_eval, x_out,
                                        job->X_last + row * nx, &st, work, job->work_len);
        if (job->steps)
            job->steps[i] = st.steps;
        if (job->stats)
            job->stats[i] = st;
    }
}

static void *worker(void *arg)
{
    rollout_job *job = (rollout_job *)arg;
    double *work = (double *)malloc(job->work_len * sizeof(double));
    if (work == NULL)
        return arg;      /* not NULL: this thread could not run; the others take its rows */
    run_rows(job, work);
    free(work);
    return NULL;
}

int eomc_rollout(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                 int n, const double *X0, const double *P, size_t p_stride,
                 int n_eval, const double *t_eval, double *X_out, double *X_last,
                 int *status, long *steps, int nthreads)
{
    return eomc_rollout_stats(m, opt, t0, t1, n, X0, P, p_stride, n_eval, t_eval, X_out, X_last,
                              status, steps, NULL, nthreads);
}

int eomc_rollout_stats(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                       int n, const double *X0, const double *P, size_t p_stride,
                       int n_eval, const double *t_eval, double *X_out, double *X_last,
                       int *status, long *steps, eomc_stats *stats, int nthreads)
{
    rollout_job job;
    pthread_t threads[EOMC_ROLLOUT_MAX_THREADS];
    int started = 0, k, ran = 0;
    if (m == NULL || opt == NULL || n < 0 || X0 == NULL || P == NULL || X_last == NULL
        || status == NULL || (n_eval > 0 && (t_eval == NULL || X_out == NULL)))
        return EOMC_BAD_ARGUMENT;
    if (nthreads <= 0)
        nthreads = 1;
    if (nthreads > EOMC_ROLLOUT_MAX_THREADS)
        nthreads = EOMC_ROLLOUT_MAX_THREADS;
    if (nthreads > n)
        nthreads = n > 0 ? n : 1;
    job.m = m; job.opt = opt; job.t0 = t0; job.t1 = t1; job.n = n;
    job.X0 = X0; job.P = P; job.p_stride = p_stride;
    job.n_eval = n_eval; job.t_eval = t_eval; job.X_out = n_eval > 0 ? X_out : NULL;
    job.X_last = X_last; job.status = status; job.steps = steps; job.stats = stats;
    job.work_len = eomc_integrate_work_size(m, opt->method)
                   + (opt->method == EOMC_IMPLICITFAST && opt->implicit ? opt->implicit->work_len : 0);
    job.next = 0;
    for (k = 0; k < n; ++k)
        status[k] = EOMC_ABORTED;        /* until its run says otherwise */
    if (pthread_mutex_init(&job.lock, NULL) != 0)
        return EOMC_BAD_ARGUMENT;
    /* The calling thread is worker 0; nthreads - 1 more are started. */
    for (k = 1; k < nthreads; ++k) {
        if (pthread_create(&threads[k], NULL, worker, &job) != 0)
            break;
        ++started;
    }
    if (worker(&job) == NULL)
        ran = 1;
    for (k = 1; k <= started; ++k) {
        void *res = NULL;
        pthread_join(threads[k], &res);
        if (res == NULL)
            ran = 1;
    }
    pthread_mutex_destroy(&job.lock);
    if (!ran)
        return EOMC_BAD_ARGUMENT;        /* no thread got a work buffer */
    for (k = 0; k < n; ++k)
        if (status[k] != EOMC_OK)
            return status[k];
    return EOMC_OK;
}
