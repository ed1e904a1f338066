/* eomc_adjoint.h -- adjoint (reverse) gradients of a fixed-step RK4 trajectory.
 *
 * Compiled once with eomc (setup.py, into the integrator library).  The gradient of a
 * scalar J(x_0, ..., x_N) of the states at the grid points t_k = t0 + k h with respect to
 * the initial state and every parameter, by the discrete adjoint of the classic RK4 step:
 * exact for the discrete trajectory (what central differences of the same simulation
 * approach), at about 3 rhs + 4 vjp per step backward whatever the number of parameters,
 * where forward sensitivities or differences cost one trajectory per parameter.
 * Checkpoints: every grid state (the forward run stores them); a step's stages are
 * recomputed from its checkpoint on the way back.
 */
#ifndef EOMC_ADJOINT_H
#define EOMC_ADJOINT_H

#include "eomc_integrators.h"

#ifdef __cplusplus
extern "C" {
#endif

/* NAME_vjp: xdot (may be NULL) and lamᵀ·d rhs/d x, lamᵀ·d rhs/d p (gp may be NULL). */
typedef int (*eomc_vjp_fn)(double t, const double *x, const double *p, const double *r,
                           const double *lam, double *xdot, double *gx, double *gp, double *work);

/* Doubles of work both calls below need (besides the model's own work_size). */
size_t eomc_adjoint_work_size(int nx, int nparam);

/* Forward: X (nsteps + 1) x nx, row 0 = x0 (copied in by the caller), row k the RK4
 * state at t0 + k h, inputs r held constant.  S (may be NULL): nsteps x 3 x nx, each step's
 * stage states x + h/2 k1, x + h/2 k2, x + h k3, kept so the backward run need not
 * recompute them (3 rhs per step saved for 3 nx doubles per step).  An eomc_status (the
 * first failing rhs's, or EOMC_NONFINITE when a state stops being finite); *failed_step the step. */
int eomc_adjoint_rk4_forward(const eomc_model *m, double t0, double h, int nsteps,
                             const double *p, const double *r, double *X, double *S, double *work,
                             int *failed_step);

/* Backward: G (nsteps + 1) x nx = dJ/dx_k (the cost's own gradient at each grid state);
 * writes lam0 = dJ/dx_0 (nx) and gp = dJ/dp (nparam; may be NULL).  X (and S, or NULL to
 * recompute the stages) from the forward call.  An eomc_status. */
int eomc_adjoint_rk4_backward(const eomc_model *m, eomc_vjp_fn vjp, double t0, double h,
                              int nsteps, const double *p, const double *r, const double *X,
                              const double *S, const double *G, double *lam0, double *gp,
                              double *work);

/*
 * The adaptive DOP853 trajectory: the same discrete adjoint over the steps the forward run
 * accepted (its step sizes held fixed: the gradient is of that sequence of steps, what
 * central differences of whole runs approach as the tolerance tightens).  Forward: the
 * integrator with every step ending on each of the ntstop grid times tstop (increasing, in
 * (t0, t1], the last = t1) and each accepted step's start (rec_t, rec_x) recorded up to
 * rec_cap steps; *nrec counts them all (more than rec_cap: call again with more room).
 * rec_t: rec_cap + 1 doubles (the last step's end follows), rec_x: rec_cap x nx.  x_last:
 * the state at t1.  rec_k (may be NULL): rec_cap x 12 x nx, each recorded step's 12 stage
 * derivatives as the integrator computed them, so the backward run need not recompute them.
 * opt->method: EOMC_DOP853 (or EOMC_DOPRI5: refused by the backward run) or EOMC_RADAU5
 * (rec_k then required: each step's 3 x nx stage increments Z);
 * work: eomc_integrate_work_size(m, method) doubles.  Constant inputs r.  An eomc_status.
 */
int eomc_adjoint_erk_forward(const eomc_model *m, const eomc_options *opt, double t0, double t1,
                             const double *x0, const double *p, const double *r, int ntstop,
                             const double *tstop, long rec_cap, double *rec_t, double *rec_x,
                             double *rec_k, long *nrec, double *x_last, eomc_stats *stats,
                             double *work, size_t work_len);

/* Doubles of work eomc_adjoint_erk_backward needs (besides the model's work_size). */
size_t eomc_adjoint_erk_work_size(int nx, int nparam);

/*
 * Backward over the nrec recorded DOP853 steps: G (nrec + 1) x nx = dJ/dx at each step
 * boundary (rows of zeros where the cost does not look), row nrec at t1.  Each step's 12
 * stage points come from its checkpoint and its recorded stage derivatives rec_k (the
 * forward run's; NULL: recomputed, 12 rhs a step) and are pulled back with 12 vjp calls (the
 * ones whose adjoint is zero skipped).  Writes lam0 = dJ/dx0 and gp = dJ/dp (may be NULL).
 */
int eomc_adjoint_erk_backward(const eomc_model *m, eomc_vjp_fn vjp, long nrec,
                              const double *rec_t, const double *rec_x, const double *rec_k,
                              const double *p, const double *r, const double *G, double *lam0,
                              double *gp, double *work);

/* Doubles of work eomc_adjoint_radau_backward needs (besides the model's work_size). */
size_t eomc_adjoint_radau_work_size(int nx, int nparam);

/*
 * Backward over the nrec recorded Radau IIA steps (eomc_adjoint_erk_forward with
 * opt->method EOMC_RADAU5: rec_k then holds each step's converged stage increments Z, 3 x nx,
 * and is required).  The step x_{n+1} = x_n + Z_3, Z = h (A (x) I) F(x_n + Z): its adjoint
 * solves the transposed collocation system K^T mu = e_3 (x) lam, K = I - h (A (x) I)
 * blkdiag(J_a) with J_a = jac_x at the three stage points, nu_b = h sum_a A_ab mu_a, then
 * lam_n = lam_{n+1} + sum_b J_b^T nu_b and gp += sum_b dF/dp_b^T nu_b by vjp.  Exact for the
 * collocation equations on that step sequence (the run's Newton stops within its tolerance of
 * them).  dense = 0: K^T mu = e_3 (x) lam by preconditioned iteration, each iteration's
 * residual by three vjp calls (the last iteration's are the step's), the preconditioner
 * K(J, h)^T with one Jacobian J for all stages in A's eigenbasis (one real and one complex nx
 * LU), J and the factors kept over steps while the iteration converges fast; a step where it
 * does not even with a fresh J is solved as with dense = 1: the 3nx system with the three
 * stage Jacobians by dense LU.  counts (may be NULL, 5 longs): jac_x calls, factorizations
 * (real + complex pairs), iterations, dense steps, vjp calls.  Needs m->jac_x.  G, lam0, gp as
 * for the DOP853 backward.
 */
int eomc_adjoint_radau_backward(const eomc_model *m, eomc_vjp_fn vjp, long nrec,
                                const double *rec_t, const double *rec_x, const double *rec_z,
                                const double *p, const double *r, const double *G, double *lam0,
                                double *gp, double *work, int dense, long *counts);

#ifdef __cplusplus
}
#endif

#endif /* EOMC_ADJOINT_H */
