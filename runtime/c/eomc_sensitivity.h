/*
 * eomc_sensitivity.h -- forward sensitivities dx(t)/dx0 and dx(t)/dp by the
 * variational equations, integrated with the state (shipped with eomc).
 *
 * With S = dx/dtheta (nx x k; theta = chosen initial states and parameters):
 *     S' = jac_x(t, x) S + jac_p(t, x)[:, parameter columns],
 *     S(t0) = [e_i for the chosen initial states | 0 for the parameters].
 * By default S does not steer the steps (CVODES's errconS = false): the run
 * takes the plain run's steps.  Explicit methods integrate the augmented
 * system [x; S] (nx (1 + k) states, rhs from jvp or jac_x) with the error
 * test on x only, so S rides the same stages.  Radau with jvp is staggered
 * direct: after each accepted step, S's collocation equations on that step
 * (linear) are solved with the step's own Newton matrix and LU, residuals
 * from jvp at the stage points (eomc_stagger.h).  eomc_sens_error_control(s,
 * 1) makes the step control watch S too (simultaneous approach; Radau then
 * integrates the augmented system with the block-diagonal Jacobian
 * diag(J, ..., J), an LU of nx (1 + k) rows).  Radau without jvp always
 * takes that simultaneous path.
 *
 * The context is opaque (eomc_sens_size() bytes, caller-allocated, aligned as
 * malloc aligns); no globals, no allocation: reentrant.
 */
#ifndef EOMC_SENSITIVITY_H
#define EOMC_SENSITIVITY_H

#include <stddef.h>
#include "eomc_model.h"
#include "eomc_integrators.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct eomc_sens eomc_sens;

/* A model's generated NAME_jvp: xdot and J·d for k directions d = [dx; dp] (rows of dirs,
 * nx + nparam each) at once, J = d xdot / d[x; p]. */
typedef int (*eomc_jvp_fn)(double t, const double *x, const double *p, const double *r, int k,
                           const double *dirs, double *xdot, double *out, double *work);

/* Bytes of an eomc_sens context. */
size_t eomc_sens_size(void);

/* Doubles of scratch eomc_sens_init needs for k columns: nx * nx + nx * nparam + k * (nx + nparam). */
size_t eomc_sens_scratch_size(const eomc_model *m, int k);

/*
 * Set up the context: k = nxcol + npcol columns, first the initial states
 * xcols[0..nxcol), then the parameters pcols[0..npcol) (indices into x, p).
 * jac_p may be NULL when npcol == 0.  jvp (may be NULL): the model's NAME_jvp;
 * given, S' = J S comes from k directional derivatives instead of forming J
 * (cheaper when k is small against nx).  p: the model's parameters (nparam),
 * read during the run.  Returns EOMC_NOT_AVAILABLE without jac_x (or jac_p
 * when parameter columns are asked for), EOMC_BAD_ARGUMENT for an index out
 * of range.
 */
int eomc_sens_init(eomc_sens *s, const eomc_model *m, eomc_mat_fn jac_p, eomc_jvp_fn jvp, const double *p,
                   int nxcol, const int *xcols, int npcol, const int *pcols, double *scratch);

/* jvp_more (after init; NULL: none): the model's NAME_jvp_more (generated on request with
 * jvp).  Radau's staggered iteration then carries its second iteration's directions in the
 * first iteration's middle-stage call, reusing that call's primal: the same operations, so S,
 * x and the counts are the same as without it, bit for bit; only faster.  It must be the same
 * model's as the jvp given to init. */
void eomc_sens_jvp_more(eomc_sens *s, eomc_jvp_more_fn jvp_more);

/* States of the augmented system: nx * (1 + k). */
int eomc_sens_nstates(const eomc_sens *s);

/* The augmented start X0 (nx (1 + k)) from x0 (nx). */
void eomc_sens_start(const eomc_sens *s, const double *x0, double *X0);

/* on != 0: the step control watches the sensitivities too (more steps); 0 (after init):
 * the steps are the plain run's. */
void eomc_sens_error_control(eomc_sens *s, int on);

/* Doubles of work eomc_sens_integrate needs for this method. */
size_t eomc_sens_work_size(const eomc_sens *s, int method);

/* The last run's staggered Radau counts: out[0] jvp calls, out[1] sensitivity iterations,
 * out[2] steps whose iteration had not converged (all 0 elsewhere). */
void eomc_sens_counts(const eomc_sens *s, long *out);

/* on != 0 (after init): Radau's staggered solves run over the LU's whole rows.  By default,
 * when J's top half rows are [0 I] (x = [q; u], q' = u) and the factorization kept its first
 * half pivots on the diagonal, they skip the LU's top rows' zero entries: the same solution
 * to the bit (a zero's sign aside), fewer products and shorter dependent chains.  Only to
 * measure or to check the difference. */
void eomc_sens_full_solves(eomc_sens *s, int on);

/* The last run's factorizations whose staggered solves skipped those entries (0 elsewhere). */
long eomc_sens_trimmed(const eomc_sens *s);

/*
 * eomc_integrate over the augmented system: X_out rows are [x, S column by
 * column] (nx (1 + k) doubles; S[:, j] at nx + j nx).  Options, inputs and
 * statistics as eomc_integrate (nfev counts augmented rhs calls, each one
 * rhs + jac_x (+ jac_p) of the model); constraint projection is not done.
 */
int eomc_sens_integrate(eomc_sens *s, const eomc_options *opt, double t0, double t1,
                        const double *X0, int n_rgrid, const double *r_tgrid,
                        const double *r_values, int n_eval, const double *t_eval,
                        double *X_out, double *X_last, eomc_stats *stats,
                        double *work, size_t work_len);

#ifdef __cplusplus
}
#endif

#endif /* EOMC_SENSITIVITY_H */
