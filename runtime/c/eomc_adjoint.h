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

#ifdef __cplusplus
}
#endif

#endif /* EOMC_ADJOINT_H */
