/*
 * eomc_integrators.h -- ODE integrators over an eomc_model (see eomc_model.h).
 *
 * Compiled and linked into every model library, so the whole integration
 * loop runs in C: Python calls eomc_integrate() once per trajectory.
 *
 * Reentrant: no globals, no allocation.  The caller supplies a work buffer
 * of eomc_integrate_work_size() doubles; several threads may integrate the
 * same model at once, each with its own buffer.
 *
 * Methods
 *   EOMC_RK4     classical fixed-step Runge-Kutta (step opt->h0), cubic
 *                Hermite output between steps.
 *   EOMC_DOPRI5  Dormand-Prince 5(4), 4th-order dense output.
 *   EOMC_DOP853  Hairer's DOP853 8(5,3), 7th-order dense output.
 *   EOMC_RADAU5  Radau IIA order 5 (implicit, stiff), simplified Newton with
 *                the model's jac_x; real and complex LU written here.
 *   EOMC_IMPLICITFAST  fixed-step (opt->h0) linearly implicit Euler with the
 *                model's jac_x, kept across steps while it predicts the step
 *                and refreshed (with Newton) when not: for real-time and
 *                learning use on stiff contact (eomc_fixedstep.c).  First
 *                order; linear interpolation between steps.  rtol/atol unused.
 *   EOMC_BDF     variable-order (1..5), variable-step BDF/NDF (implicit, stiff;
 *                MATLAB's ode15s, scipy's BDF) with the model's jac_x, Jacobian
 *                and LU kept across steps; the cheap implicit method at loose
 *                tolerances (eomc_bdf.c).  Dense output: its interpolating
 *                polynomial.
 *
 * Output is written at caller-given times t_eval (increasing, inside
 * [t0, t1]) by dense output, not by stepping to each time.
 *
 * Inputs r(t): n_rgrid == 0 -> no inputs (or zeros); n_rgrid == 1 ->
 * constant r_values; n_rgrid >= 2 -> linear interpolation of the rows of
 * r_values (n_rgrid x ninput, row-major) over the increasing times r_tgrid,
 * held constant outside the grid.
 */
#ifndef EOMC_INTEGRATORS_H
#define EOMC_INTEGRATORS_H

#include "eomc_model.h"

#ifdef __cplusplus
extern "C" {
#endif

#define EOMC_RK4 0
#define EOMC_DOPRI5 1
#define EOMC_DOP853 2
#define EOMC_RADAU5 3
#define EOMC_IMPLICITFAST 4
#define EOMC_BDF 5

/*
 * The fixed-step implicit integrator's fast path (EOMC_IMPLICITFAST, runtime/c/eomc_fixedstep.c):
 * the model's NAME_implicit (M, f, q', dq'/du, the speeds' world motions, the joint laws' and
 * the contacts' slopes; compiler/tree/lower.implicit_layout) and the structure NAME.json's
 * "implicit" entry gives.  Set in eomc_options.implicit; NULL there: the linearly implicit
 * Euler on the full jac_x.
 */
/* The lanes rollout's request for a step of its fast path (eomc_implicit.terms_lu, eomc_rollout.c):
 * with the terms at a trial end x, (2)'s factored matrix A and right side b for a step of h from x,
 * and when du is given the try's residual ratio of eomc_fixedstep.c's fs_fast_try for that velocity
 * change, and the next try's velocity change du1 = A^-1 h b and rate v1 = q'(x) + N(x) du1, made for
 * the group's rows at once: each the scalar code's bits.  Answered either way: A and b written
 * (done = 1, ahead = 0), or the ratio, du1 and v1 given instead, A and b left unwritten (done =
 * ahead = 1: the caller's next try at h takes du1 and v1; one at another h assembles its own). */
typedef struct eomc_fs_request {
    double h;                 /* in: the step */
    double *A, *b;            /* in: where A and b go */
    const double *du;         /* in: the try's velocity change (the residual's); NULL: no ratio */
    int done;                 /* out: answered (ratio given when du was) */
    int ahead;                /* out: du1 and v1 given, A and b not written */
    double ratio;             /* out: the residual ratio (fs_fast_try's) */
    const double *du1, *v1;   /* out: nu and nq values the callee keeps until its next call */
    int *touch;               /* in: room for 64 contacts (NULL: not asked); out with done: the
                                 contacts in touch at x (depth > 0), ascending, ntouch of them
                                 (-1: more than 64) -- what fs_assemble's scan would list */
    int ntouch;
} eomc_fs_request;

typedef struct eomc_implicit {
    eomc_mat_fn terms;        /* NAME_implicit */
    int ncontact;
    const int *chain_start;   /* ncontact + 1 offsets into chain */
    const int *chain;         /* the speeds that move contact k: chain[chain_start[k] ..] */
    const int *parent;        /* nu: each speed's parent in the tree (-1: root), parent[s] < s;
                                 NULL: M is factored dense */
    size_t work_len;          /* doubles of work the path needs: eomc_fs_implicit_work_size */
    double split;             /* > 0: a step whose linearisation misses the implicit Euler
                                 equation by more than this (Newton's correction over the step's
                                 velocity change) is split (eomc_fixedstep.c); 0: never split,
                                 one model call per step, as MuJoCo's implicitfast */
    const double *depth_limit;/* ncontact (may be NULL: none): a contact deeper than this after
                                 a step ends the run with EOMC_PENETRATED (the state written) */
    /* NULL (what callers set), or the lanes rollout's (eomc_rollout.c): terms, and what req asks
       for when it can (req->done, req->ahead) */
    int (*terms_lu)(double t, const double *x, const double *p, const double *r, double *out,
                    eomc_fs_request *req, double *work);
    /* the root free joints (eomc's: speeds vx, vy, vz, wx, wy, wz, body-frame, their rows the
       body's whole subtree's momentum balance): the first speed of each; 0, NULL: none.  Their
       momentum's turning with the body (w x p, an explicit Euler rotation that grows |p| by
       sqrt(1 + h^2 w^2) a step) is taken half implicitly (eomc_fixedstep.c, fs_transport) */
    int nfree;
    const int *free;
    /* NULL (terms writes every output), or NAME_implicit_const with terms = NAME_implicit_var
       (a model whose NAME_implicit has constant outputs: NAME.h): the fast path writes the
       constants once per run into each buffer it hands terms, which then writes the rest */
    void (*terms_const)(double *out);
    /* NULL (what callers set), or the lanes rollout's (eomc_rollout.c): out, a buffer terms or
       terms_lu wrote, made whole.  Until then the fast path reads only the contacts' depths, the
       joint laws' slopes and the root free joints' columns of N there (its tests: what the lanes
       copy at once); it calls this before it reads more (fs_assemble, the residual, a try's rate) */
    void (*terms_whole)(double *out);
    /* 1: NAME_implicit's out[] ends with the model's energy output at the call's state (NAME.json
       implicit.layout.energy, compiler/tree/lower.implicit_layout), which the fast path's energy
       watch (eomc_options.watch_output) then reads from the terms it made at each step's end
       instead of calling watch_fn; 0: none */
    int energy;
    /* NULL (every joint of several speeds is a root free joint, or there is none), or nu: each
       speed's joint's first speed (NAME.json implicit.joints: a ball, a planar joint, a free joint
       below the root; the others their own).  Their axes are fixed in their child body, so each
       of a joint's speeds turns with the velocity before the joint, not after the speed before it
       (a contact's bias, eomc_fixedstep.c fs_point_bias) */
    const int *joint;
    /* NULL, or NAME_tree_lu (NAME.json "tree_lu": compiler/emit/tree_lu.py): fs_tree_lu over the
       tree of parent[] written out for this model, the same operations and bits; the fast path
       calls it where it factors M's own tree pattern (no pressed pair's fill), the loop elsewhere */
    int (*tree_lu)(double *A);
    /* NULL, or NAME_tree_solve: fs_tree_solve (c NULL) or fs_tree_solve2 with a tree_lu factor */
    void (*tree_solve)(const double *A, double *b, double *c);
    /* NULL, or NAME_tree_residual: r = M du - h f over M's tree pattern (fs_residual's sums) */
    void (*tree_residual)(const double *M, const double *f, const double *du, double h, double *r);
    /* 0, NULL: none; else the joint limits (runtime/switching.find_switches) of one-speed joints:
       per limit the x index of the joint's coordinate, its speed (the joint law's), the parameter
       index of its bound and its sign (+1 upper, d = q - bound; -1 lower, d = bound - q).  A try
       that fails with a limit entered (d from <= 0 to > 0) and no other regime change than such
       entries and touch-downs ends its next sub-step at the earliest crossing (eomc_fixedstep.c,
       fs_onset_cell) instead of halving towards it */
    int nlimit;
    const int *limit_state, *limit_speed, *limit_bound;
    const double *limit_sign;
    /* NULL, or the run's fixed lists for this struct's model (M's tree pattern, the contacts'
       branch masks, M's and N's column lists: eomc_fs_pattern made them once, pattern_len doubles),
       which the fast path then copies at a run's start instead of making them (eomc_fixedstep.c
       fs_fixed_lists) */
    const double *pattern;
    size_t pattern_len;
} eomc_implicit;

/* One joint limit's spring whose stored energy the watched output leaves out (MJCF's: unilateral
 * and held, no closed-form potential; runtime/limit_energy.spring_table builds it): the energy
 * watch (eomc_options.watch_output) adds p[stiffness] * S(d) at the limit's depth d = sign * (x[state]
 * - p[bound]) > 0, S the stored energy at K = 1 by cubic Hermite between knots that hold S and its
 * slope (the spring's force at rest) exactly.  Knot k is the double whose bits are (base + k) <<
 * (52 - bits): 2^bits knots an octave (relative spacing <= 2^-bits), found from d's own bits with no
 * log.  Below knot 0, Hermite from S(0) = S'(0) = 0; past knot n - 1, or with p[width] != E (the
 * width the table was built for), the total is not known: the watch's rise is NaN for the run. */
typedef struct eomc_spring {
    int state;           /* x index of the joint's coordinate */
    int bound;           /* parameter index of the limit (limit_lo_ / limit_hi_) */
    int stiffness;       /* parameter index of limit_k_ (S scales with it) */
    int width;           /* parameter index of limit_e_ */
    double sign;         /* +1: an upper limit (d = q - bound), -1: a lower one (d = bound - q) */
    double E;            /* the width S was built for */
    int bits;            /* knots an octave: 2^bits */
    long long base;      /* knot 0's bits >> (52 - bits) */
    int n;               /* knots (>= 2) */
    const double *S;     /* n: the stored energy at the knots (K = 1) */
    const double *f;     /* n: its slope there */
} eomc_spring;

/* The run failed its physics: a contact went deeper than eomc_implicit.depth_limit (an
 * integrator status beside eomc_status's; x_last holds the state that was too deep). */
#define EOMC_PENETRATED 10

/* Doubles of work the fast path needs (add to eomc_integrate_work_size). */
size_t eomc_fs_implicit_work_size(int nq, int nu, int ncontact);
/* eomc_implicit.pattern of imp (imp->pattern NULL, its other fields set): written to out, its
   length in doubles returned (out NULL: the length only); work: imp->work_len doubles */
size_t eomc_fs_pattern(const eomc_implicit *imp, int nq, int nu, double *work, double *out);

typedef struct eomc_options {
    int method;          /* EOMC_RK4 ... EOMC_BDF */
    double rtol, atol;   /* > 0 (ignored by RK4) */
    double h0;           /* first step; 0 = automatic.  RK4, IMPLICITFAST: the fixed step (> 0) */
    double hmax;         /* largest step; 0 = t1 - t0 */
    long max_steps;      /* attempted steps before EOMC_MAX_STEPS; <= 0 = 100000 */
    int project;         /* 1: project onto constraints after each accepted step */
    int stiff_check;     /* 1: Hairer's stiffness test for DOPRI5/DOP853 -> EOMC_STIFF */
    double baumgarte;    /* > 0: rhs -= baumgarte * G^+ g (constraint residuals decay
                            like exp(-baumgarte t)); 0 = off */
    double pi_beta;      /* DOPRI5/DOP853 step control: beta of Hairer's stabilized (PI)
                            control, 0.04 in his DOPRI5; 0 = the classical control that
                            scipy.integrate uses (steps then match scipy's) */
    int nquat;           /* unit quaternions in x (a free joint's orientation): each accepted
                            step ends with them normalised (and, at the start, x0's) */
    const int *quat;     /* nquat x indices into x of each quaternion's w (x, y, z follow).
                            The model's rhs must not depend on a quaternion's length and be
                            linear in it in its own rows (eomc's quaternion free joint), so
                            the step's end derivative is rescaled, not recomputed */
    const eomc_implicit *implicit;  /* EOMC_IMPLICITFAST: the fast path (see above), or NULL */
    int watch_output;    /* EOMC_IMPLICITFAST without feedback: k > 0 keeps the range of output
                            k - 1 (m->outputs) over the start and every kept step's end in
                            eomc_stats.watch_lo/watch_hi -- what simulate's energy verdict reads
                            along the steps, for rollout with either record (runtime/rollout.py);
                            0: none.  Costs an outputs call a step */
    eomc_rhs_fn watch_fn;  /* with watch_output > 0: read out[0] of this function instead of
                            output k - 1 of m->outputs -- a model's NAME_energy (the energy
                            output alone, bit for bit the outputs' value, a fraction of their
                            cost); NULL: m->outputs.  With implicit->energy the fast path reads
                            that value at each step's end from the terms it made there */
    int nspring;         /* with watch_output > 0: the limit springs the output leaves out, whose */
    const eomc_spring *spring;  /* stored energy the watch adds to it (the total); 0, NULL: none */
    const int *stop;     /* NULL, or a flag another thread may set while the run goes on: once
                            it is nonzero the run stops at its next model evaluation with
                            EOMC_ABORTED, its rows so far written (as on Ctrl-C).  `eomc check`
                            stops its two references where they part (runtime/stability.py) */
    long interrupt_base; /* 0: Ctrl-C and SIGTERM stop the run from its start on; n > 0: from when
                            eomc_interrupt_count() was n - 1, the caller's arm.  Why: a signal that
                            comes after the arm but before the run reads the count (Python has not
                            raised it yet) was otherwise taken as older than the run, which then
                            went on to its end (a million-row rollout: minutes; CI, session 41) */
} eomc_options;

typedef struct eomc_stats {
    long steps;          /* attempted steps */
    long accepted, rejected;
    long nfev;           /* rhs evaluations */
    long njev;           /* jac_x evaluations */
    long nlu;            /* LU factorizations */
    long nproj;          /* projections done */
    int status;          /* eomc_status of the run */
    int n_out;           /* t_eval rows written */
    double t;            /* time reached: the end, or of the last good state on failure */
    double t_fail;       /* failure: time of the failing model evaluation (else = t) */
    double h;            /* last step size tried */
    double stiff_hlambda;/* last h*|lambda| estimate of the stiffness test */
    double max_residual; /* max-norm constraint residual after projection (0 if none) */
    long nswitch;        /* steps ended at a switching point (touch-down, lift-off, limit entry);
                            BDF: steps passed over one (it does not end steps there) */
    double watch_lo, watch_hi; /* eomc_options.watch_output's running min and max (NaN: not
                            watched, or the output was not finite or failed somewhere) */
    /* The watch's total (the output plus eomc_options.spring's stored energy) over the start and
       every kept step's end: its value at the start and its range (the energy verdict's scale),
       its largest rise above its running minimum (what a passive model's total never does:
       runtime/switching.energy_verdict), from watch_low at watch_t_low to watch_peak at
       watch_t_peak, and watch_t_jump, the end of the step within that rise whose one-step rise was
       the largest (where the verdict names what touched down).  NaN: not watched, or not known
       (as watch_lo; or a spring past its table) */
    double watch_total0, watch_total_lo, watch_total_hi;
    double watch_rise, watch_low, watch_t_low, watch_peak, watch_t_peak, watch_t_jump;
} eomc_stats;

/* Doubles of work buffer eomc_integrate needs for this model and method. */
size_t eomc_integrate_work_size(const eomc_model *m, int method);

/*
 * Integrate x' = rhs(t, x, p, r(t)) from t0 to t1 (> t0) starting at x0.
 * x_out: n_eval x nx rows, the state at t_eval[i].  x_last (nx, may be
 * NULL): the state at stats->t (the end, or the last good state on failure).
 * Returns the eomc_status, also stored in stats->status.
 */
int eomc_integrate(const eomc_model *m, const eomc_options *opt,
                   double t0, double t1, const double *x0, const double *p,
                   int n_rgrid, const double *r_tgrid, const double *r_values,
                   int n_eval, const double *t_eval, double *x_out,
                   double *x_last, eomc_stats *stats,
                   double *work, size_t work_len);

/*
 * Optional extras of eomc_integrate_ex (either pointer may be NULL).
 *
 * Inputs with state feedback: r(t, x) = base(t, x) + K (x_ref - x), where
 * base is the input grid of eomc_integrate, or fn(user, t, x, r) when fn is
 * set (a caller's callback: the slow path, one call per stage; a nonzero
 * return stops the run at once with that status -- the stage is not retried
 * and fn is not called again; EOMC_ABORTED says "the callback failed").  K: ninput x nx row-major (NULL: no
 * linear feedback), x_ref: nx (NULL: zeros).  Radau's Jacobian includes
 * -jac_r K (it needs jac_r); a callback's dependence on x is not included.
 * r_slopes (n_rgrid x ninput, or NULL): dr/dt at the grid times, making the
 * grid a piecewise cubic Hermite interpolant (a cubic spline when the slopes
 * are a spline's) instead of a linear one; still held constant outside.
 *
 * Time-varying gains (a trajectory optimiser's K_k along its nominal x_k): n_kgrid >= 2
 * makes K the n_kgrid x ninput x nx gains at the increasing times k_tgrid, and, when
 * ref_on_grid is 1, x_ref the n_kgrid x nx references there; both linear between two grid
 * times (the input grid's arithmetic) and held at the grid's ends.  n_kgrid 0 or 1: K and
 * x_ref are constant (k_tgrid and ref_on_grid unused).  Work: eomc_feedback_work_size.
 */
typedef int (*eomc_input_fn)(void *user, double t, const double *x, double *r);

typedef struct eomc_feedback {
    const double *K;
    const double *x_ref;
    eomc_input_fn fn;
    void *user;
    const double *r_slopes;
    int n_kgrid;
    const double *k_tgrid;
    int ref_on_grid;
} eomc_feedback;

/* Doubles of work the feedback fb (may be NULL: 0) adds to eomc_integrate_work_size. */
size_t eomc_feedback_work_size(const eomc_model *m, const eomc_feedback *fb);

/*
 * Events: zero crossings of g_k = fn(t, x, p, r)[col[k]] (k < n), found after
 * each accepted step by a sign change between the step's ends and located
 * with Brent's method on the dense output to a few ulps of t.  direction[k]:
 * +1 only rising (g from < 0 to >= 0), -1 only falling, 0 both (NULL: all 0).
 * terminal[k] > 0: the run stops (status EOMC_OK, stats->t = the event time,
 * x_last = the state there) at the terminal[k]-th occurrence (NULL: none).
 * Records: up to capacity rows of (t_rec, id_rec, x_rec); n_rec counts every
 * occurrence, also those past capacity.  scratch: at least
 * eomc_events_scratch_size(m, ncol, n) doubles.
 */
typedef struct eomc_events {
    int n;
    eomc_rhs_fn fn;
    int ncol;
    const int *col;
    const int *direction;
    const int *terminal;
    int capacity;
    double *t_rec;
    int *id_rec;
    double *x_rec;
    int n_rec;           /* out */
    int terminated;      /* out: 1 if a terminal event stopped the run */
    double *scratch;
    /* Switching functions: where the model's law changes form (a contact's penetration
     * at touch-down and lift-off, a joint's distance past its limit).  The law is only
     * piecewise smooth there, so no step may straddle such a point: a step over which
     * a switching function changes sign (at its ends, or, for Radau, at an interior
     * collocation point) is redone to end just past the crossing, and the method restarts
     * there (fresh step-size history; Radau: new Jacobian, no extrapolated guess).  BDF
     * passes over crossings (the sides flip at the step's end); it looks at 1/3 and 2/3 of
     * a step on its polynomial when a function could cross and come back within it.
     * switching[k] != 0 marks event k (NULL: none).  nlin more switching functions need
     * no model call: g_j = lin_s[j] * (x[lin_x[j]] - p[lin_p[j]])
     * (a joint limit: q - hi, or -(q - lo)).  "On" means g > 0.  gmax (n + nlin, may be
     * NULL) receives the largest value of each switching function seen at the ends and
     * stage points of the steps kept (not of trial steps that were cut at a crossing or
     * rejected) and at the start (-HUGE_VAL if never evaluated); the caller turns it
     * into a verdict (penetration, limit overshoot).  sw_scratch: at least
     * eomc_switch_scratch_size(n, nlin) doubles when any switching function is given. */
    const int *switching;
    int nlin;
    const int *lin_x;
    const int *lin_p;
    const double *lin_s;
    double *gmax;        /* out */
    double *sw_scratch;
    int sw_observe;      /* 1: track gmax only, never end a step at a crossing (to measure
                            what the bare method does) */
} eomc_events;

size_t eomc_events_scratch_size(const eomc_model *m, int ncol, int n);
size_t eomc_switch_scratch_size(int n, int nlin);

/* eomc_integrate with state feedback and/or events (see above); work needs
 * eomc_integrate_work_size(m, method) + eomc_feedback_work_size(m, fb) doubles
 * (m->ninput * m->nx for constant gains). */
int eomc_integrate_ex(const eomc_model *m, const eomc_options *opt,
                      double t0, double t1, const double *x0, const double *p,
                      int n_rgrid, const double *r_tgrid, const double *r_values,
                      const eomc_feedback *fb, eomc_events *ev,
                      int n_eval, const double *t_eval, double *x_out,
                      double *x_last, eomc_stats *stats,
                      double *work, size_t work_len);

/*
 * Ctrl-C or SIGTERM during a run.  eomc_interrupt_arm() installs a handler of
 * SIGINT and of SIGTERM that counts the signal and then calls the handler it
 * replaced (Python's, which raises KeyboardInterrupt -- or what the program's
 * SIGTERM handler raises -- when the C call returns); while it is installed,
 * every run that started before the signal stops at its next model evaluation
 * with EOMC_ABORTED.  A signal whose handler is the default or ignored is left
 * alone (SIGTERM then ends the process as before).  It returns 1 when either
 * is armed (also when it already was), 0 when both are ignored or default
 * (nothing to chain) or on a platform without sigaction.
 * eomc_interrupt_disarm() puts the replaced handlers back where this one is
 * still installed.  Callers should serialize them (a race is benign: the
 * handler never chains to itself).
 */
int eomc_interrupt_arm(void);
void eomc_interrupt_disarm(void);

/*
 * The SIGINTs and SIGTERMs the armed handler has counted (never reset).  A caller that
 * runs many integrations (eomc_rollout's threads) reads it once at its start and takes
 * no new one after it has changed: the runs in flight stop by themselves (above), the
 * ones not started keep EOMC_ABORTED (s29: a rollout's threads went on taking rows).
 */
long eomc_interrupt_count(void);

/*
 * Arm (eomc_interrupt_arm) and return eomc_interrupt_count() + 1 as it was just before:
 * the value for eomc_options.interrupt_base, so that the run stops for any signal
 * after this call, also one that comes before the run itself starts.
 */
long eomc_interrupt_arm_base(void);

/*
 * Evaluate the model's outputs (which == 0; noutput columns) or constraint
 * residuals (which == 1; nhol + nvel columns) at n rows (t[i], X[i]) with the
 * same input interpolation as eomc_integrate.  work: at least
 * eomc_integrate_work_size(m, EOMC_RK4) doubles.
 */
int eomc_eval_along(const eomc_model *m, int which, int n, const double *t,
                    const double *X, const double *p, int n_rgrid,
                    const double *r_tgrid, const double *r_values,
                    double *out, double *work, size_t work_len);

/*
 * out[i, :] = fn(t[i], X[i, :], p, r, work) for i < n (eomc_rows.c): a model function (the
 * generated NAME_poses, by pointer) along a run's rows in one call from Python instead of one
 * per row.  X is n x nx and out n x nout, row-major; p and r shared by every row (may be NULL).
 * Stops at the first row whose status is not EOMC_OK, stores its index in *failed_row and
 * returns that status; rows before it are written.
 */
int eomc_mat_rows(eomc_mat_fn fn, size_t n, const double *t, const double *X, size_t nx,
                  const double *p, const double *r, double *out, size_t nout,
                  double *work, size_t *failed_row);

/*
 * The energy verdict's first look at a rollout's rows (eomc_rows.c; runtime/rollout.py
 * _energy_verdicts): for each row i < n whose status[i] is 0, its energy at the start and the
 * end, E[2i] = energy(0, X0[i]) and E[2i+1] = energy(t_end, X_last[i]) (NaN where the call fails
 * or is not finite; rows not run: NaN), with row i's parameters P + i * p_stride and inputs
 * R + i * r_stride (a stride 0: one row shared; R may be NULL), and whether the verdict must look
 * closer: its energy over [start, stats' watch_lo, watch_hi, end] (stats NULL: [start, end]) rose
 * above its start by more than rtol times its scale, or (total_known, stats given) the watch's
 * total rose above its running minimum by more than rtol times the total's scale -- numpy's
 * arithmetic, NaN included (a NaN anywhere: not flagged).  Returns the number of rows flagged
 * (flag[i] = 1); 0, the common case, leaves nothing for Python to do.
 */
size_t eomc_energy_screen(eomc_mat_fn energy, size_t n, double t_end, const double *X0,
                          const double *X_last, size_t nx, const double *P, size_t p_stride,
                          const double *R, size_t r_stride, const int *status,
                          const eomc_stats *stats, int total_known, double rtol, double *E,
                          unsigned char *flag, double *work);

#ifdef __cplusplus
}
#endif

#endif /* EOMC_INTEGRATORS_H */
