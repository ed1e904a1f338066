/*
 * eomc_model.h -- the ABI every generated model implements (shipped with eomc).
 *
 * This header is the contract between the code generator (eomc.compiler),
 * the integrators (eomc_integrators.c) and the Python runtime (eomc.runtime).
 * Change it only together with EOMC_ABI_VERSION.
 *
 * Conventions
 *   - State x = [q (nq coordinates); u (nu speeds); z (extra first-order
 *     states, e.g. muscle activations)], nx = nq + nu + nz (nz may be 0).
 *   - p: nparam parameters, r: ninput inputs (may be NULL when ninput == 0).
 *   - Matrices are dense, row-major.
 *   - work: caller-supplied scratch of at least `work_size` doubles.  No
 *     function keeps state between calls, touches a global, or allocates:
 *     every function is reentrant and thread-safe.
 *   - Every function returns an eomc_status.  A singular mass matrix is
 *     reported as EOMC_SINGULAR_MASS_MATRIX and the outputs are left
 *     unspecified; no function turns it into NaN silently.
 *   - A function that was not generated (see --outputs) is a NULL pointer.
 */
#ifndef EOMC_MODEL_H
#define EOMC_MODEL_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#define EOMC_ABI_VERSION 1

typedef enum eomc_status {
    EOMC_OK = 0,
    EOMC_SINGULAR_MASS_MATRIX = 1,   /* M(q) could not be factored */
    EOMC_SINGULAR_CONSTRAINTS = 2,   /* dependent speeds / projection could not be solved */
    EOMC_NONFINITE = 3,              /* a non-finite value appeared in a state or derivative */
    EOMC_BAD_ARGUMENT = 4,
    EOMC_STEP_TOO_SMALL = 5,
    EOMC_MAX_STEPS = 6,
    EOMC_STIFF = 7,                  /* explicit method detected stiffness */
    EOMC_NOT_AVAILABLE = 8,          /* function not generated for this model */
    EOMC_ABORTED = 9                 /* a caller's input callback failed, or the run was
                                        interrupted (Ctrl-C): stop now, never retry */
} eomc_status;

/* xdot = f(t, x, p, r) */
typedef int (*eomc_rhs_fn)(double t, const double *x, const double *p,
                           const double *r, double *xdot, double *work);
/* out (rows x cols, row-major) = some matrix-valued function of (t, x, p, r) */
typedef int (*eomc_mat_fn)(double t, const double *x, const double *p,
                           const double *r, double *out, double *work);

/* NAME_jvp_more's callback: called once NAME_jvp's k directions are in out, at the same
 * point; returns how many more directions to carry with the primal already computed, pointing
 * *dirs and *out at them (0 or less: none). */
typedef int (*eomc_more_fn)(void *mctx, const double **dirs, double **out);
/* NAME_jvp_more (generated on request, with NAME_jvp): NAME_jvp, then once the directions
 * more hands back (runtime/c/eomc_integrators.c: Radau's staggered sensitivities). */
typedef int (*eomc_jvp_more_fn)(double t, const double *x, const double *p, const double *r, int k,
                                const double *dirs, double *xdot, double *out, double *work,
                                eomc_more_fn more, void *mctx);

typedef struct eomc_model {
    int abi_version;          /* EOMC_ABI_VERSION */
    const char *name;
    int nq, nu, nx;           /* coordinates, speeds, states (nx = nq + nu + nz) */
    int nparam, ninput;
    int noutput;              /* named outputs (energy, contact forces, ...) */
    int nhol;                 /* holonomic (configuration) constraint residuals */
    int nvel;                 /* velocity-level constraint residuals */
    size_t work_size;         /* doubles of scratch any function below needs */

    const char *const *state_names;    /* nx */
    const char *const *param_names;    /* nparam */
    const double *param_defaults;      /* nparam */
    const char *const *input_names;    /* ninput */
    const char *const *output_names;   /* noutput */

    eomc_rhs_fn rhs;          /* xdot (nx) */
    eomc_mat_fn jac_x;        /* d xdot / d x   (nx x nx) */
    eomc_mat_fn jac_r;        /* d xdot / d r   (nx x ninput) */
    eomc_mat_fn mass_matrix;  /* M (nu x nu) */
    eomc_rhs_fn forcing;      /* f (nu) */
    eomc_rhs_fn outputs;      /* named outputs (noutput) */
    eomc_rhs_fn constraints;  /* residuals (nhol + nvel): holonomic, then velocity-level */
    eomc_mat_fn constraints_jac; /* d residuals / d x ((nhol + nvel) x nx) */
} eomc_model;

#ifdef __cplusplus
}
#endif

#endif /* EOMC_MODEL_H */
